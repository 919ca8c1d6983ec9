//! The hardware a board puts behind the task bodies ([`crate::tasks`]), in converter codes: a
//! real board, QEMU's simulated one and the simulator's rig implement these two traits.
//!
//! Codes are right-aligned 12-bit values on the signal's own scale (the core's
//! [`AdcScale`](crate::gauge::AdcScale) maps them back to the memo's ±10 V); any level
//! shifting lives in the board's analog front end and its scale constants.

use crate::gauge::{AdcCode, SAMPLES_PER_TICK};
use crate::tactile::TaxelId;

/// The control task's peripherals: strain-gauge converter, actuator DAC and the probed
/// element's own channel.
pub trait ControlIo {
    /// The gauge samples converted during the control period that just ended.
    fn read_gauge(&mut self) -> [AdcCode; SAMPLES_PER_TICK];
    /// The probed element's envelope-detector channel, converted at the end of the period.
    fn read_probe_channel(&mut self) -> AdcCode;
    /// Sets the DAC that drives the current amplifier.
    fn write_actuator(&mut self, code: AdcCode);
}

/// The scan task's peripherals: multiplexer address lines and the scanned channel's converter.
pub trait ScanIo {
    /// Drives `taxel`'s row and senses its column (the dwell starts now).
    fn select_taxel(&mut self, taxel: TaxelId);
    /// Converts the selected taxel's envelope detector after the dwell.
    fn read_taxel(&mut self) -> AdcCode;
}
