//! Faults the simulated board injects, and when: the converter faults into the codes it hands
//! out, lost contact into the physics; the two that live in the firmware (a NaN command, a
//! missed deadline) are announced for the harness to play.

use tactile_core::gauge::{AdcCode, GaugeConfig, SAMPLES_PER_TICK};
use tactile_core::CONTROL_PERIOD_S;

/// Faults the simulator can inject into the rig.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InjectedFault {
    /// The gauge's converter reads its lower rail (a broken wire).
    GaugeDisconnected,
    /// The gauge's converter reads its upper rail.
    GaugeSaturated,
    /// The gauge's converter repeats the codes it had.
    GaugeStuck,
    /// One tick of a spike of this many grams on the gauge.
    ForceSpike { g: f32 },
    /// The finger surface drops away by this much strain (infinite: the finger is removed).
    ContactLost { strain_pct: f64 },
    /// One tick of a NaN command.
    CommandNan,
    /// The control task misses one deadline.
    DeadlineOverrun,
    /// A taxel reads its converter's rail from then on.
    TaxelOpen { index: usize },
}

impl InjectedFault {
    /// The names `tactile experiment --fault` takes.
    pub const NAMES: [&'static str; 8] = [
        "gauge-disconnected",
        "gauge-saturated",
        "gauge-stuck",
        "force-spike",
        "contact-lost",
        "command-nan",
        "deadline-overrun",
        "taxel-open",
    ];

    pub fn parse(name: &str) -> Option<InjectedFault> {
        Some(match name {
            "gauge-disconnected" => InjectedFault::GaugeDisconnected,
            "gauge-saturated" => InjectedFault::GaugeSaturated,
            "gauge-stuck" => InjectedFault::GaugeStuck,
            "force-spike" => InjectedFault::ForceSpike { g: 80.0 },
            "contact-lost" => InjectedFault::ContactLost {
                strain_pct: f64::INFINITY,
            },
            "command-nan" => InjectedFault::CommandNan,
            "deadline-overrun" => InjectedFault::DeadlineOverrun,
            "taxel-open" => InjectedFault::TaxelOpen { index: 3 * 8 + 3 },
            _ => return None,
        })
    }
}

/// A fault and the time it starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultInjection {
    pub fault: InjectedFault,
    pub at_s: f64,
}

impl FaultInjection {
    /// True in the control period that starts at `t_s` once the fault has begun (the rig's
    /// test: `t_s ≥ at_s`).
    pub fn active_in(&self, t_s: f64) -> bool {
        t_s >= self.at_s
    }

    /// True only in the first period the fault is active (one-tick faults: spike, NaN command,
    /// missed deadline).
    pub fn starts_in(&self, t_s: f64) -> bool {
        t_s >= self.at_s && t_s - self.at_s < CONTROL_PERIOD_S
    }
}

/// What a converter fault does to one period's gauge samples (`previous`: the last period's
/// codes, which a stuck converter repeats). The rig's own rules: a disconnected gauge reads the
/// lower rail, a saturated one the upper, a spike adds `g` grams to every sample of its one
/// period.
pub fn inject_gauge_fault(
    gauge: &GaugeConfig,
    fault: InjectedFault,
    first_period: bool,
    previous: &[AdcCode; SAMPLES_PER_TICK],
    samples: &mut [AdcCode; SAMPLES_PER_TICK],
) {
    match fault {
        InjectedFault::GaugeDisconnected => *samples = [AdcCode(0); SAMPLES_PER_TICK],
        InjectedFault::GaugeSaturated => *samples = [gauge.adc.code(f32::MAX); SAMPLES_PER_TICK],
        InjectedFault::GaugeStuck => *samples = *previous,
        InjectedFault::ForceSpike { g } if first_period => {
            for s in samples.iter_mut() {
                let v = gauge.adc.volts(*s) + g / gauge.grams_per_volt;
                *s = gauge.adc.code(v);
            }
        }
        _ => {}
    }
}
