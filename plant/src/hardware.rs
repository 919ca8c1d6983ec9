//! The simulated board: the applicator and the finger seen through their converters, for
//! firmware-in-the-loop runs. The firmware writes a DAC code and reads converter codes, exactly
//! as on a board; the physics between those codes is the rig's (the same step sequence, noise
//! streams and sampling instants as [`crate::rig::Rig::tick`]), with no control code here.
//!
//! One control period is `write DAC → advance_period → read gauge and probe codes`; the scan
//! reads the taxel selected by the multiplexer with the probe force at the end of the period.
//!
//! Fault injection: the board injects `RigConfig::fault` as the rig does, at the same instants
//! (the converter faults into the codes it hands out, lost contact into the physics). The two
//! faults that live in the firmware rather than in the hardware (a NaN command, a missed
//! deadline) are announced by [`SimHardware::fault_starting`] for the harness to act on.

use tactile_core::gauge::{AdcCode, SAMPLES_PER_TICK};
use tactile_core::io::{ControlIo, ScanIo};
use tactile_core::tactile::{TaxelCalibration, TaxelId, TAXELS};

use crate::applicator::{self, ApplicatorState, Contact, Lumped};
use crate::config::RigConfig;
use crate::fault::{inject_gauge_fault, FaultInjection, InjectedFault};
use crate::finger::Finger;
use crate::noise::Noise;
use tactile_core::CONTROL_PERIOD_S;

/// Plant steps per control tick.
pub const SUBSTEPS: usize = 10;

/// Converter samples the rig takes of the element under the probe when calibrating at rest.
const CALIBRATION_FRAMES: usize = 16;

/// The simulated applicator, finger and converters.
pub struct SimHardware {
    config: RigConfig,
    plant: ApplicatorState,
    lumped: Lumped,
    finger: Finger,
    calibration: [TaxelCalibration; TAXELS],
    gauge_noise: Noise,
    /// DAC code driving the current amplifier (the safe zero until the firmware writes).
    dac: AdcCode,
    /// Gauge samples taken during the last period.
    gauge_codes: [AdcCode; SAMPLES_PER_TICK],
    /// The probed element's channel, sampled at the end of the last period.
    probe_code: AdcCode,
    true_force_g: f64,
    periods: u64,
    /// End of the last period, s (the time the scan samples at).
    t_end_s: f64,
    /// Taxel the multiplexer selects, and the one the envelope detector held before it.
    selected: TaxelId,
    last_sampled: TaxelId,
}

impl SimHardware {
    /// The board of `config`'s rig, probe lifted and at rest. Takes the technician's rest
    /// calibration at once, as [`crate::rig::Rig::new`] does (same noise draws).
    pub fn new(config: &RigConfig) -> Self {
        let fw = &config.firmware;
        let mut finger = Finger::new(
            config.seed,
            fw.probe,
            config.effects,
            config.readout,
            fw.taxel_adc,
            fw.scan,
        );
        let calibration = finger.rest_calibration(CALIBRATION_FRAMES);
        let plant = ApplicatorState {
            stuck: true,
            ..Default::default()
        };
        // Before the first period the converters read the unloaded gauge, noise-free (no
        // draw, so the noise stream stays the rig's).
        let rest_code = gauge_code(config, plant.gauge_force_g(&config.applicator));
        Self {
            plant,
            lumped: Lumped::new(&config.applicator, CONTROL_PERIOD_S / SUBSTEPS as f64),
            finger,
            calibration,
            gauge_noise: Noise::new(config.seed ^ 0x6761_7567),
            dac: fw.actuator.zero_code(),
            gauge_codes: [rest_code; SAMPLES_PER_TICK],
            probe_code: AdcCode(0),
            true_force_g: 0.0,
            periods: 0,
            t_end_s: 0.0,
            selected: TaxelId::from_index(0),
            last_sampled: TaxelId::from_index(TAXELS - 1),
            config: config.clone(),
        }
    }

    pub fn config(&self) -> &RigConfig {
        &self.config
    }

    /// Per-taxel calibration captured at rest when the board was built.
    pub fn calibration(&self) -> &[TaxelCalibration; TAXELS] {
        &self.calibration
    }

    /// The DAC register.
    pub fn write_dac(&mut self, code: AdcCode) {
        self.dac = code;
    }

    pub fn dac(&self) -> AdcCode {
        self.dac
    }

    /// Where the DAC register lives, for a crash handler that must zero the output without
    /// going through whichever task holds the board (as firmware writes a memory-mapped
    /// register). Valid while the board stays where it is (on the target it lives in a static).
    pub fn dac_register(&mut self) -> *mut AdcCode {
        core::ptr::addr_of_mut!(self.dac)
    }

    /// The fault whose injection begins with the coming period, if any: what the harness must
    /// do itself for the faults that live in the firmware (`CommandNan`, `DeadlineOverrun`).
    /// The rig's tick `k` is this board's period `k`, so "the coming period" is the rig's tick
    /// that first sees the fault.
    pub fn fault_starting(&self) -> Option<InjectedFault> {
        let t_s = self.periods as f64 * CONTROL_PERIOD_S;
        self.config
            .fault
            .filter(|f| f.starts_in(t_s))
            .map(|f| f.fault)
    }

    /// One control period of physics with the DAC held: the plant's ten steps, the gauge
    /// sampled eight times, the finger advanced, the probed element's channel sampled at the end.
    pub fn advance_period(&mut self) {
        let t_s = self.periods as f64 * CONTROL_PERIOD_S;
        let fault = self.config.fault.filter(|f| f.active_in(t_s));
        let actuator = &self.config.firmware.actuator;
        let drive_v = f64::from(actuator.dac.volts(self.dac));
        let p = self.config.applicator;
        // A tick's reading averages its samples: each carries √8 times the reading's noise.
        let noise_g = p.gauge_noise_g * libm::sqrt(SAMPLES_PER_TICK as f64);
        let mut contact = Contact::new(
            &p,
            self.finger.probe_element().g1,
            self.finger.probe_rest_strain_pct(),
        );
        if let Some(FaultInjection {
            fault: InjectedFault::ContactLost { strain_pct },
            ..
        }) = fault
        {
            contact.rest_strain_pct += strain_pct;
        }
        let mut samples = [AdcCode(0); SAMPLES_PER_TICK];
        let mut stress_sum = 0.0;
        for k in 0..SUBSTEPS {
            applicator::step_lumped(&self.lumped, &mut self.plant, &contact, drive_v);
            stress_sum += contact.force_g(self.plant.tip_m, self.plant.tip_m_per_s);
            if let Some(slot) = k
                .checked_sub(SUBSTEPS - SAMPLES_PER_TICK)
                .and_then(|i| samples.get_mut(i))
            {
                let force = self.plant.gauge_force_g(&p) + noise_g * self.gauge_noise.gaussian();
                *slot = gauge_code(&self.config, force);
            }
        }
        if let Some(f) = fault {
            // The noise was drawn all the same: the streams stay the rig's.
            inject_gauge_fault(
                &self.config.firmware.gauge,
                f.fault,
                f.starts_in(t_s),
                &self.gauge_codes,
                &mut samples,
            );
        }
        self.gauge_codes = samples;
        self.finger
            .tick(stress_sum / SUBSTEPS as f64, CONTROL_PERIOD_S);
        // Same expression as the rig's, so the time effects see the same instants.
        let t_end = t_s + CONTROL_PERIOD_S;
        self.true_force_g = contact.force_g(self.plant.tip_m, self.plant.tip_m_per_s);
        self.probe_code = self.finger.sample_probe_channel(self.true_force_g, t_end);
        self.t_end_s = t_end;
        self.periods += 1;
    }

    /// The gauge converter's samples of the last period.
    pub fn gauge_codes(&self) -> [AdcCode; SAMPLES_PER_TICK] {
        self.gauge_codes
    }

    /// The probed element's channel at the end of the last period.
    pub fn probe_code(&self) -> AdcCode {
        self.probe_code
    }

    /// Multiplexer address: drive `taxel`'s row, sense its column.
    pub fn select_taxel(&mut self, taxel: TaxelId) {
        self.selected = taxel;
    }

    /// Samples the envelope detector on the selected taxel after its dwell (the detector
    /// still holds the blend of the taxel sampled before it).
    pub fn sample_selected_taxel(&mut self) -> AdcCode {
        let mut code = self.finger.sample_scan(
            self.selected,
            self.last_sampled,
            self.true_force_g,
            self.t_end_s,
        );
        // The scan after period k belongs to the rig's tick k (its start time is the fault's
        // clock there).
        let tick_s = self.periods.saturating_sub(1) as f64 * CONTROL_PERIOD_S;
        if self.periods > 0
            && self.config.fault.is_some_and(|f| {
                f.active_in(tick_s)
                    && f.fault
                        == InjectedFault::TaxelOpen {
                            index: self.selected.index(),
                        }
            })
        {
            // An open taxel: its detector reads the converter's lower rail.
            code = AdcCode(0);
        }
        self.last_sampled = self.selected;
        code
    }

    /// Simulator truth: the contact force at the end of the last period, grams.
    pub fn true_force_g(&self) -> f64 {
        self.true_force_g
    }

    /// Puts the probe `gap_m` off the finger, at rest with the beam unbent (a rig whose probe
    /// was retracted before the run: the touch-down's start).
    pub fn lift_probe(&mut self, gap_m: f64) {
        self.plant.motor_m = -gap_m;
        self.plant.tip_m = -gap_m;
        self.plant.motor_m_per_s = 0.0;
        self.plant.tip_m_per_s = 0.0;
        self.plant.stuck = true;
    }

    /// The probe tip's and the motor's positions, m (zero: the finger's surface at rest).
    pub fn positions_m(&self) -> (f64, f64) {
        (self.plant.tip_m, self.plant.motor_m)
    }

    pub fn in_contact(&self) -> bool {
        self.true_force_g > 0.0
    }

    /// Control periods simulated so far.
    pub fn periods(&self) -> u64 {
        self.periods
    }
}

/// The converter's code for `force_g` on the rig's gauge: the bridge's volts at the applicator's
/// scale (the firmware reads them back at its own, [`RigConfig::set_applicator`]'s).
fn gauge_code(config: &RigConfig, force_g: f64) -> AdcCode {
    let gauge = &config.firmware.gauge;
    // In f32, as the firmware's own conversion back is.
    let volts = force_g as f32 / config.applicator.gauge_g_per_v as f32 + gauge.zero_v;
    gauge.adc.code(volts)
}

impl ControlIo for SimHardware {
    fn read_gauge(&mut self) -> [AdcCode; SAMPLES_PER_TICK] {
        self.gauge_codes()
    }
    fn read_probe_channel(&mut self) -> AdcCode {
        self.probe_code()
    }
    fn write_actuator(&mut self, code: AdcCode) {
        self.write_dac(code);
    }
}

impl ScanIo for SimHardware {
    fn select_taxel(&mut self, taxel: TaxelId) {
        SimHardware::select_taxel(self, taxel);
    }
    fn read_taxel(&mut self) -> AdcCode {
        self.sample_selected_taxel()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_dac_code_presses_the_probe_into_the_finger() {
        let config = RigConfig::default();
        let mut hw = SimHardware::new(&config);
        for _ in 0..200 {
            hw.advance_period();
        }
        assert!(
            !hw.in_contact(),
            "the zero code must leave the probe lifted"
        );
        // 30 g at the probe through the actuator path.
        hw.write_dac(config.firmware.actuator.code(30.0));
        for _ in 0..1500 {
            hw.advance_period();
        }
        assert!(hw.in_contact());
        let gauge = config
            .firmware
            .gauge
            .average_force(&hw.gauge_codes())
            .unwrap();
        assert!((gauge - 30.0).abs() < 3.0, "gauge {gauge} g");
        assert!(
            (hw.true_force_g() - 30.0).abs() < 3.0,
            "{}",
            hw.true_force_g()
        );
        assert_eq!(hw.periods(), 1700);
    }
}
