//! A completed frame on its way from the scan to the locator: a board's scan interrupt hands
//! it to a lower-priority task, which fits the contact (the fit outlasts a dwell).

use crate::contact::Locator;
use crate::tactile::TAXELS;
use crate::telemetry::TaxelFrame;

use super::scan::{ArrayEstimate, ScanReport};

/// A completed frame whose contact is not located yet: the frame, its estimate without the
/// locator's fields, and the locator's input. A board locates it outside the scan's interrupt
/// (the fit outlasts a dwell); the answer depends on this alone, so where it runs cannot
/// change it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnlocatedFrame {
    pub frame: TaxelFrame,
    pub estimate: ArrayEstimate,
    /// The good taxels' estimates, grams (a bad taxel NaN, left out by the locator).
    pub good_g: [f32; TAXELS],
}

impl UnlocatedFrame {
    /// The frame with its contact located by `locator` (the scanner's:
    /// [`Scanner::locator`](super::Scanner::locator)).
    pub fn locate(&self, locator: &Locator) -> ScanReport {
        let contact = locator.locate(&self.good_g);
        ScanReport {
            frame: self.frame,
            estimate: ArrayEstimate {
                total_force_g: contact.force_g,
                contact_x_mm: contact.x_mm,
                contact_y_mm: contact.y_mm,
                contact: contact.kind,
                ..self.estimate
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tactile::{ReadoutAmplifier, TaxelCalibration, TaxelId};
    use crate::tasks::scan::tests::Panel;
    use crate::tasks::{FirmwareConfig, Scanner};

    /// A board's split (the scan's step, the fit later, by the scanner's locator) gives what
    /// the host's `Scanner::step` gives, frame for frame, a bad taxel included.
    #[test]
    fn locating_later_gives_the_scans_own_answer() {
        let config = FirmwareConfig::MEMO;
        let rest = TaxelCalibration {
            amplifier: ReadoutAmplifier::MEMO_ELEMENT_4_2,
            rest_output_v: 4.0,
            gain: 1.0,
        };
        let mut host = Scanner::new(&config, [rest; TAXELS]).unwrap();
        let mut board = host.clone();
        let mut volts = [4.0f32; TAXELS];
        // A press over r3c4 spreading to its neighbours, and a shorted taxel.
        for (i, v) in [
            (3 * 8 + 4, 6.0),
            (3 * 8 + 5, 5.2),
            (2 * 8 + 4, 4.9),
            (63, -12.0),
        ] {
            volts[i] = v;
        }
        let adc = config.taxel_adc;
        let mut a = Panel {
            volts,
            selected: TaxelId::default(),
            adc,
        };
        let mut b = Panel {
            volts,
            selected: TaxelId::default(),
            adc,
        };
        host.start(&mut a);
        board.start(&mut b);
        let (mut frames, mut last) = (0, None);
        for k in 0..(TAXELS * 4) as u32 {
            let expected = host.step(&mut a, k);
            let got = board
                .step_unlocated(&mut b, k)
                .map(|f| f.locate(board.locator()));
            assert_eq!(expected, got, "step {k}");
            frames += usize::from(got.is_some());
            last = got.or(last);
        }
        assert_eq!(frames, 4);
        let e = last.unwrap().estimate;
        assert_ne!(e.contact, crate::contact::ContactKind::Nothing, "{e:?}");
    }
}
