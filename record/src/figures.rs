//! The estimator figures the QEMU firmware produced: `tactile-decode` writes them as
//! `estimators.json` beside its records, `tactile estimators --qemu DIR` reads them.

use std::fmt::Write as _;

use tactile_core::estimator::EstimatorKind;

/// The estimators as the QEMU firmware ran them (written by `tactile-decode` as
/// `estimators.json` beside the records, read by `tactile estimators --qemu DIR`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FirmwareFigures {
    /// The protocol scored and how many scan frames of it.
    pub protocol: String,
    pub frames: usize,
    /// RMS of estimate − true contact force on the probed taxel (g), in
    /// `EstimatorKind::ALL`'s order.
    pub rms_g: [f64; EstimatorKind::COUNT],
    /// Instructions per taxel update, (min, max), same order.
    pub instructions: [(u32, u32); EstimatorKind::COUNT],
}

impl FirmwareFigures {
    /// The firmware's row, for the table.
    pub fn render(&self) -> String {
        let f = self;
        let names = EstimatorKind::ALL.map(EstimatorKind::name);
        let mut s = format!(
        "On the QEMU firmware ({}, probed taxel, the build's calibration table, {} frames):\n\n| | {} |\n|---{}|\n| RMS (g) |",
        f.protocol,
        f.frames,
        names.join(" | "),
        "|---".repeat(names.len())
    );
        for v in f.rms_g {
            let _ = write!(s, " {v:.3} |");
        }
        s.push_str("\n| instructions per taxel update (Cortex-M4F) |");
        for (lo, hi) in f.instructions {
            let _ = write!(s, " {lo}–{hi} |");
        }
        s.push('\n');
        s
    }
}
