//! What a simulated run is made of: the firmware's configuration and the board around it.

use tactile_core::control::ForceLawConfig;
use tactile_core::gauge::GaugeConfig;
use tactile_core::tasks::FirmwareConfig;

use crate::applicator::ApplicatorParams;
use crate::fault::FaultInjection;
use crate::finger::{Effects, ReadoutParams};

/// Everything a run is made of; `Default` is the memo's rig.
#[derive(Clone, Debug)]
pub struct RigConfig {
    pub seed: u64,
    /// What the firmware runs with: law, filter, the gauge's and the actuator's scales, the
    /// taxel converter and scan, the probed taxel, the estimators, the fault thresholds, the
    /// calibration table. The simulated board is built to the same scales.
    pub firmware: FirmwareConfig,
    /// Command slew limit ahead of the law, g/s (scenarios take it from their protocol).
    pub command_slew_g_per_s: f32,
    /// The simulated rig's applicator and gauge ([`Self::set_applicator`] gives the firmware
    /// the gauge's scale too).
    pub applicator: ApplicatorParams,
    pub effects: Effects,
    /// The finger's read-out chain up to the taxel converter.
    pub readout: ReadoutParams,
    /// Run the 8×8 scan (off for speed when only the probed element matters).
    pub scan_array: bool,
    /// A fault to inject, and when.
    pub fault: Option<FaultInjection>,
}

/// The error gain K_e the simulated rig runs with.
///
/// With the memo's filter (its Q = 2.8 section peaks near 27 Hz and reaches −180° near 31 Hz)
/// and K_p = 2, K_d = 0.03 s, the A1 loop is linearly unstable at 100 g on any plant whose gain
/// near 30 Hz is about one, which a 50 Hz inertia–finger resonance forces: the Nyquist plot of
/// the loop encircles −1 (see `analysis::loop_encirclements`, and docs/design.md). K_e is the
/// memo's own knob for the overall feedback gain, so the simulator keeps A1's structure, K_p,
/// K_d and the filter, and sets K_e = 0.07: the largest stable K_e at 100 g is 0.184, a gain
/// margin of 2.6 (`cargo test --release -p sim-host the_memo_gains_are_unstable -- --nocapture`
/// prints it per load); at 0.1 a 100 g step rings at the edge of the ±1 g band for 0.13 s.
pub const SIM_ERROR_GAIN: f32 = 0.07;

impl RigConfig {
    /// The firmware the simulator runs: the memo's, with K_e = [`SIM_ERROR_GAIN`].
    pub const SIM_FIRMWARE: FirmwareConfig = FirmwareConfig {
        law: ForceLawConfig {
            ke: SIM_ERROR_GAIN,
            ..ForceLawConfig::MEMO
        },
        ..FirmwareConfig::MEMO
    };
}

impl RigConfig {
    /// The rig with `applicator`, and the firmware reading its gauge at the gauge's scale (on a
    /// board the user sets it from a calibration with weights).
    pub fn set_applicator(&mut self, applicator: ApplicatorParams) {
        self.applicator = applicator;
        self.firmware.gauge = GaugeConfig::with_scale(applicator.gauge_g_per_v as f32);
    }
}

impl Default for RigConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            firmware: Self::SIM_FIRMWARE,
            command_slew_g_per_s: tactile_core::profile::STEP_SLEW_G_PER_S,
            applicator: ApplicatorParams::MEMO,
            effects: Effects::MEMO,
            readout: ReadoutParams::default(),
            scan_array: true,
            fault: None,
        }
    }
}
