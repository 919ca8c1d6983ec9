//! Where a contact is and how hard it presses, from one frame of the array's per-taxel force
//! estimates: the array's spatial response (an elastic layer's subsurface stress over each
//! element's plate) and the fit of one point contact to a frame, which says when the frame is
//! not one point at all.
//!
//! Coordinates in millimetres: x along the columns, y along the rows, from the centre of taxel
//! r0c0.

pub mod locate;
pub mod response;
pub mod table;

pub use locate::{ContactEstimate, ContactKind, Locator, LocatorConfig};
pub use response::SpatialResponse;
pub use table::{SpatialTableError, SPATIAL_TABLE_BYTES};
