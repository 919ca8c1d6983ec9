//! The tactile finger: an 8×8 array of Maxwell–Kelvin elements (eq. 14 with the load-dependent
//! springs of Table I), the probe's load spreading to neighbours, each taxel's capacitance
//! (eq. 1), sensed amplitude (eq. 2), envelope detector, offset/gain stage with per-taxel trims
//! and the converter; plus the effects that can be switched on for identification tests.
//!
//! Two read-out paths, as in the memo's lab: the element under the probe on its own channel,
//! sampled every control tick (the memo's single-element experiments), and the multiplexed 8×8
//! scan at the rate the envelope detector allows.

use tactile_core::gauge::{AdcCode, AdcScale};
use tactile_core::tactile::{
    ElementGeometry, ReadoutAmplifier, ScanConfig, SenseNode, StrainForm, TaxelCalibration,
    TaxelId, COLS, TAXELS,
};
use tactile_core::viscoelastic::{NonlinearMk, NonlinearMkState, SpringLaw};

use crate::noise::Noise;
use crate::spatial::{loaded_of, SpatialLaw};

/// Effects beyond the memo's own physics, each with a strength; all off by default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Effects {
    /// Scales the load dependence of both springs about their 30 g values: 1 is the memo's
    /// stiffening, 0 linear springs, 2 twice as strong.
    pub stiffening: f64,
    /// Rate-independent hysteresis: amplitude (percent strain) of a sum of play operators.
    pub hysteresis_pct: f64,
    /// Additive baseline drift of the strain signal, percent per second.
    pub drift_pct_per_s: f64,
    /// Periodic interference on the taxel signal: amplitude (percent strain) and frequency.
    pub interference_pct: f64,
    pub interference_hz: f64,
    /// Pure delay in the read-out of the element under the probe.
    pub delay_s: f64,
    /// An extra slow Kelvin element: its compliance relative to G₂'s at 30 g (0 = off) and its
    /// time constant.
    pub slow_relaxation: f64,
    pub slow_relaxation_tau_s: f64,
    /// The element every taxel varies about, for fingers unlike the memo's (springs that
    /// stiffen by other laws, other α and relaxation times); `None`: element 4,2.
    pub element: Option<NonlinearMk>,
}

impl Effects {
    /// Only the memo's own physics.
    pub const MEMO: Effects = Effects {
        stiffening: 1.0,
        hysteresis_pct: 0.0,
        drift_pct_per_s: 0.0,
        interference_pct: 0.0,
        interference_hz: 7.3,
        delay_s: 0.0,
        slow_relaxation: 0.0,
        slow_relaxation_tau_s: 40.0,
        element: None,
    };
}

/// Stress at which [`Effects::stiffening`] pivots.
const STIFFENING_PIVOT_G: f64 = 30.0;

/// The power law's load dependence scaled by `s` about its 30 g stiffness (other laws are
/// given whole by [`Effects::element`] and left as they are).
fn scale_law(law: SpringLaw, s: f64) -> SpringLaw {
    match law {
        SpringLaw::Power {
            sqrt_coeff,
            linear_coeff,
            ..
        } => {
            let pivot = law.stiffness(STIFFENING_PIVOT_G);
            let varying =
                sqrt_coeff * libm::sqrt(STIFFENING_PIVOT_G) + linear_coeff * STIFFENING_PIVOT_G;
            SpringLaw::power(
                (pivot - s * varying).max(0.2),
                s * sqrt_coeff,
                s * linear_coeff,
            )
        }
        other => other,
    }
}

/// The taxel with element 4,2's parameters (the memo's element, row 4 column 2 counted from
/// one): the probed taxel of the firmware's configuration.
pub const NOMINAL_TAXEL: TaxelId = tactile_core::tactile::PROBED_TAXEL;

/// The taxels the dynamic calibration visits, on the simulator and on the QEMU firmware: the
/// nominal element and three others of the finger's spread.
pub const CALIBRATION_TAXELS: [TaxelId; 4] = [
    NOMINAL_TAXEL,
    TaxelId::from_index(COLS + 5),
    TaxelId::from_index(5 * COLS + 1),
    TaxelId::from_index(6 * COLS + 6),
];

/// A finger unlike the memo's, of the same physics (eq. 14): G₁ grows linearly with load
/// (1 + 0.08σ, 3.4 g/% at 30 g as element 4,2's), G₂ stiffens and saturates (15 + 45(1 −
/// e^(−σ/30 g)), 43 g/% at 30 g), α = 6 g/%. The calibration tests and the QEMU calibration
/// session's last run use it.
pub const LINEAR_SATURATING_ELEMENT: NonlinearMk = NonlinearMk {
    g1: SpringLaw::power(1.0, 0.0, 0.08),
    n1: 5000.0,
    alpha: 6.0,
    n2: 500.0,
    g2: SpringLaw::Saturating {
        base: 15.0,
        gain: 45.0,
        scale_g: 30.0,
    },
};

/// Seed of the simulated finger those calibrations run on.
pub const CALIBRATION_FINGER_SEED: u64 = 7;

/// Play-operator radii of the simulated finger's hysteresis, grams.
const FINGER_PLAY_RADII_G: [f64; 3] = [2.0, 5.0, 10.0];
/// Longest read-out delay the ring buffer holds, in control ticks.
pub const MAX_DELAY_TICKS: usize = 512;

/// How a taxel's element differs from the finger's: each spring's stiffness and each
/// dashpot scaled (the finger holds one element, so 64 taxels do not hold 64 copies of its
/// spring curves).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementScale {
    pub g1: f64,
    pub n1: f64,
    pub n2: f64,
    pub g2: f64,
}

impl ElementScale {
    /// The taxel's element from the finger's.
    pub fn of(&self, finger: &NonlinearMk) -> NonlinearMk {
        NonlinearMk {
            g1: finger.g1.scaled(self.g1),
            n1: finger.n1 * self.n1,
            alpha: finger.alpha,
            n2: finger.n2 * self.n2,
            g2: finger.g2.scaled(self.g2),
        }
    }
}

/// One taxel: mechanics and read-out.
#[derive(Clone, Copy, Debug)]
pub struct Taxel {
    pub scale: ElementScale,
    pub state: NonlinearMkState,
    /// Amplified |V_s| with no strain (about 5 V).
    pub rest_amplitude_v: f64,
    /// Pre-amplifier gain that makes eq. 2's amplitude at rest equal `rest_amplitude_v`.
    preamp_gain: f64,
    pub amplifier: ReadoutAmplifier,
    /// Stress integral since the last update (g·s), and its start time.
    stress_integral_g_s: f64,
    last_update_s: f64,
    /// Envelope detector output at the last sample.
    detector_v: f64,
}

/// Load spread from the probe to a taxel `(dr, dc)` away (fraction of the probe's stress).
pub fn crosstalk_weight(dr: i32, dc: i32) -> f64 {
    match (dr.abs(), dc.abs()) {
        (0, 0) => 1.0,
        (0, 1) | (1, 0) => 0.25,
        (1, 1) => 0.10,
        (0, 2) | (2, 0) => 0.04,
        (1, 2) | (2, 1) => 0.02,
        _ => 0.0,
    }
}

/// Read-out chain constants shared by every taxel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReadoutParams {
    pub geometry: ElementGeometry,
    pub node: SenseNode,
    /// Where the trims put the at-rest amplifier output (headroom for the negative swing).
    pub rest_output_target_v: f32,
    /// Strain noise of the finger signal, percent RMS (memo: 0.022 g equivalent).
    pub noise_pct: f64,
}

impl Default for ReadoutParams {
    fn default() -> Self {
        Self {
            geometry: ElementGeometry::MEMO,
            node: SenseNode {
                lumped_capacitance_f: 100e-12,
                input_resistance_ohm: 1e6,
                drive_amplitude_v: 10.0,
                drive_frequency_hz: 200e3,
            },
            rest_output_target_v: 4.0,
            noise_pct: 0.022 / 3.6,
        }
    }
}

/// The finger under the probe.
#[derive(Clone, Debug)]
pub struct Finger {
    /// The element every taxel's varies about ([`Effects::element`], stiffened as
    /// [`Effects::stiffening`] asks).
    pub element: NonlinearMk,
    pub taxels: [Taxel; TAXELS],
    pub probe: TaxelId,
    pub effects: Effects,
    pub readout: ReadoutParams,
    /// The taxel converter (the firmware's `taxel_adc`).
    pub adc: AdcScale,
    noise: Noise,
    /// Taxels other than the probe's that carry part of the probe's load, with their share.
    loaded: heapless::Vec<(usize, f64), TAXELS>,
    /// Every taxel's share of the probe's load, by taxel index (the probe's own included).
    shares: [f64; TAXELS],
    /// How the load spreads: the fixed kernel about the probe's centre unless pressed elsewhere.
    law: SpatialLaw,
    /// Fraction of the previous taxel left in a scan sample.
    blend: f64,
    plays_g: [f64; 3],
    slow_kelvin_pct: f64,
    delay_line: [f64; MAX_DELAY_TICKS],
    delay_head: usize,
}

impl Finger {
    /// The memo's finger drawn from `seed` on the memo's board (its taxel converter and scan),
    /// probed at [`NOMINAL_TAXEL`], read out as by default.
    pub fn memo(seed: u64) -> Self {
        let config = tactile_core::tasks::FirmwareConfig::MEMO;
        Finger::new(
            seed,
            NOMINAL_TAXEL,
            Effects::MEMO,
            ReadoutParams::default(),
            config.taxel_adc,
            config.scan,
        )
    }

    /// A finger with per-taxel variation drawn from `seed`; [`NOMINAL_TAXEL`] keeps the nominal
    /// element 4,2 parameters, so experiments with the probe there (the default) compare with
    /// the memo's tables, and a probe moved elsewhere meets a taxel of its own. `adc` and
    /// `scan` are the board's taxel converter and scan timing.
    pub fn new(
        seed: u64,
        probe: TaxelId,
        effects: Effects,
        readout: ReadoutParams,
        adc: AdcScale,
        scan: ScanConfig,
    ) -> Self {
        let mut rng = Noise::new(seed ^ 0x7461_7869);
        let mut vary = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let nominal = effects.element.unwrap_or(NonlinearMk::ELEMENT_4_2);
        let element = NonlinearMk {
            g1: scale_law(nominal.g1, effects.stiffening),
            g2: scale_law(nominal.g2, effects.stiffening),
            ..nominal
        };
        let taxels = core::array::from_fn(|i| {
            let is_nominal = i == NOMINAL_TAXEL.index();
            let mut f = |lo: f64, hi: f64| if is_nominal { 1.0 } else { vary(lo, hi) };
            let (k1, k2, kn1, kn2) = (f(0.8, 1.3), f(0.8, 1.3), f(0.8, 1.4), f(0.7, 1.3));
            let (kv, kpf, trim_err) = (f(0.9, 1.1), f(0.95, 1.05), f(0.95, 1.05));
            let scale = ElementScale {
                g1: k1,
                n1: kn1,
                n2: kn2,
                g2: k2,
            };
            let rest_amplitude_v = 5.0 * kv;
            let mut amplifier = ReadoutAmplifier {
                rpf_ohm: 187e3 * kpf as f32,
                offset_supply_v: -14.7,
                ..ReadoutAmplifier::MEMO_ELEMENT_4_2
            };
            let target = readout.rest_output_target_v * trim_err as f32;
            amplifier.rp1_ohm = amplifier
                .trim_rp1_ohm(rest_amplitude_v as f32, target)
                .unwrap_or(73.5e3);
            let c0 = readout.geometry.capacitance_f(0.0);
            Taxel {
                scale,
                state: NonlinearMkState::default(),
                rest_amplitude_v,
                preamp_gain: rest_amplitude_v / readout.node.sensed_amplitude_v(c0),
                amplifier,
                stress_integral_g_s: 0.0,
                last_update_s: 0.0,
                detector_v: rest_amplitude_v - f64::from(amplifier.diode_drop_v),
            }
        });
        let shares = SpatialLaw::Kernel.shares(probe, 0.0, 0.0);
        Self {
            element,
            taxels,
            probe,
            effects,
            readout,
            adc,
            loaded: loaded_of(&shares, probe),
            shares,
            law: SpatialLaw::Kernel,
            blend: f64::from(scan.blend()),
            noise: Noise::new(seed ^ 0x6e6f_6973),
            plays_g: [0.0; 3],
            slow_kelvin_pct: 0.0,
            delay_line: [0.0; MAX_DELAY_TICKS],
            delay_head: 0,
        }
    }

    /// Moves the contact to (`x_mm`, `y_mm`) (x along the columns, y along the rows, from the
    /// centre of taxel r0c0) under `law`; the probe's channel stays on [`Finger::probe`], which
    /// reads its share as every taxel does. Between presses: the taxels' states are kept.
    pub fn press_at(&mut self, law: SpatialLaw, x_mm: f64, y_mm: f64) {
        self.law = law;
        self.shares = law.shares(self.probe, x_mm, y_mm);
        self.loaded = loaded_of(&self.shares, self.probe);
    }

    /// How the load spreads now.
    pub fn law(&self) -> SpatialLaw {
        self.law
    }

    /// Taxel `index`'s share of the probe's load (0 outside the array).
    pub fn load_share(&self, index: usize) -> f64 {
        self.shares.get(index).copied().unwrap_or(0.0)
    }

    /// The probe taxel's own share (1 for the fixed kernel: the probe over its centre).
    fn probe_share(&self) -> f64 {
        self.load_share(self.probe.index())
    }

    pub fn probe_taxel(&self) -> &Taxel {
        // `probe` is a valid TaxelId, so its index is < TAXELS.
        &self.taxels[self.probe.index()]
    }

    /// The element of taxel `index` (the finger's, scaled as the taxel is).
    pub fn element_of(&self, index: usize) -> NonlinearMk {
        self.taxels
            .get(index)
            .map_or(self.element, |t| t.scale.of(&self.element))
    }

    /// The element under the probe.
    pub fn probe_element(&self) -> NonlinearMk {
        self.element_of(self.probe.index())
    }

    /// Rest strain of the surface under the probe (what the probe must indent past).
    pub fn probe_rest_strain_pct(&self) -> f64 {
        let t = self.probe_taxel();
        t.scale.of(&self.element).rest_strain_pct(&t.state)
    }

    /// Advances the finger by one control tick under the probe stress `probe_stress_g` (the
    /// tick's mean contact force). Neighbours accumulate their share and are brought up to date
    /// when scanned.
    pub fn tick(&mut self, probe_stress_g: f64, dt_s: f64) {
        // The probe taxel's own stress (the probe's for the kernel: a share of exactly 1).
        let own_g = self.probe_share() * probe_stress_g;
        for &(i, w) in &self.loaded {
            if let Some(t) = self.taxels.get_mut(i) {
                t.stress_integral_g_s += w * probe_stress_g * dt_s;
            }
        }
        let probe = self.probe.index();
        let element = self.element_of(probe);
        let t = &mut self.taxels[probe];
        element.step(&mut t.state, own_g, dt_s);
        t.stress_integral_g_s = 0.0;
        t.last_update_s += dt_s;
        // Sensor-side effects of the element under the probe.
        for (p, r) in self.plays_g.iter_mut().zip(FINGER_PLAY_RADII_G) {
            *p = tactile_core::hysteresis::play(*p, own_g, r);
        }
        if self.effects.slow_relaxation > 0.0 {
            let g3 = NonlinearMk::ELEMENT_4_2.g2.stiffness(STIFFENING_PIVOT_G)
                / self.effects.slow_relaxation;
            let phi = libm::exp(-dt_s / self.effects.slow_relaxation_tau_s);
            self.slow_kelvin_pct = self.slow_kelvin_pct * phi + (1.0 - phi) * own_g / g3;
        }
    }

    /// Brings a neighbour's viscoelastic state up to time `t_s` with its mean stress.
    fn catch_up(&mut self, index: usize, t_s: f64) -> f64 {
        let element = self.element_of(index);
        let Some(t) = self.taxels.get_mut(index) else {
            return 0.0;
        };
        let elapsed = t_s - t.last_update_s;
        let mean = if elapsed > 0.0 {
            t.stress_integral_g_s / elapsed
        } else {
            0.0
        };
        let unloaded = t.stress_integral_g_s == 0.0 && t.state == NonlinearMkState::default();
        if unloaded {
            // Nothing to relax: skip the exponentials (most of the array, most of the time).
            t.last_update_s = t_s;
        } else if elapsed > 0.0 {
            element.step(&mut t.state, mean, elapsed);
            t.stress_integral_g_s = 0.0;
            t.last_update_s = t_s;
        }
        mean
    }

    /// True strain of the element under the probe carrying `stress_g`, with the sensor-side
    /// effects (hysteresis, slow relaxation, drift, interference) but before the read-out.
    fn probe_sensor_strain_pct(&self, probe_stress_g: f64, t_s: f64) -> f64 {
        let stress_g = self.probe_share() * probe_stress_g;
        let t = self.probe_taxel();
        let mut e = self.probe_element().strain_pct(&t.state, stress_g);
        if self.effects.hysteresis_pct > 0.0 {
            let mean = self
                .plays_g
                .iter()
                .zip(FINGER_PLAY_RADII_G)
                .map(|(p, r)| (p - stress_g) / r)
                .sum::<f64>()
                / FINGER_PLAY_RADII_G.len() as f64;
            e += self.effects.hysteresis_pct * mean;
        }
        e + self.slow_kelvin_pct + self.time_effects_pct(t_s)
    }

    fn time_effects_pct(&self, t_s: f64) -> f64 {
        let fx = &self.effects;
        let mut e = fx.drift_pct_per_s * t_s;
        if fx.interference_pct != 0.0 {
            e += fx.interference_pct
                * libm::sin(2.0 * core::f64::consts::PI * fx.interference_hz * t_s);
        }
        e
    }

    /// Amplifier output of a taxel for strain `strain_pct` (before the envelope settling).
    fn detector_target_v(&self, taxel: &Taxel, strain_pct: f64) -> f64 {
        let g = &self.readout.geometry;
        let vs = taxel.preamp_gain
            * self
                .readout
                .node
                .sensed_amplitude_v(g.capacitance_f(strain_pct));
        vs - f64::from(taxel.amplifier.diode_drop_v)
    }

    fn convert(&self, taxel_index: usize, detector_v: f64) -> AdcCode {
        let Some(t) = self.taxels.get(taxel_index) else {
            return AdcCode(0);
        };
        let amp = &t.amplifier;
        let out =
            -amp.rpf_ohm * (amp.offset_supply_v / amp.rp1_ohm + detector_v as f32 / amp.r1_ohm);
        self.adc.code(out)
    }

    /// The element-under-probe channel: one converter code per control tick, with the probe
    /// carrying `stress_g` at time `t_s`.
    pub fn sample_probe_channel(&mut self, stress_g: f64, t_s: f64) -> AdcCode {
        let mut strain = self.probe_sensor_strain_pct(stress_g, t_s);
        strain += self.readout.noise_pct * self.noise.gaussian();
        // Read-out delay: a ring buffer of past strains, one per tick.
        let delay_ticks = libm::round(self.effects.delay_s / 1e-3) as usize;
        if delay_ticks > 0 {
            let n = delay_ticks.min(MAX_DELAY_TICKS - 1);
            self.delay_line[self.delay_head % MAX_DELAY_TICKS] = strain;
            let past = (self.delay_head + MAX_DELAY_TICKS - n) % MAX_DELAY_TICKS;
            strain = self.delay_line[past];
            self.delay_head = (self.delay_head + 1) % MAX_DELAY_TICKS;
        }
        let probe = self.probe.index();
        let target = self.detector_target_v(self.probe_taxel(), strain);
        self.convert(probe, target)
    }

    /// One step of the multiplexed scan at time `t_s`: the detector has dwelt on `taxel`
    /// (after `previous`), with the probe carrying `probe_stress_g`.
    pub fn sample_scan(
        &mut self,
        taxel: TaxelId,
        previous: TaxelId,
        probe_stress_g: f64,
        t_s: f64,
    ) -> AdcCode {
        let i = taxel.index();
        let strain = if taxel == self.probe {
            self.probe_sensor_strain_pct(probe_stress_g, t_s)
        } else {
            let w = self.load_share(i);
            self.catch_up(i, t_s);
            let t = &self.taxels[i];
            self.element_of(i).strain_pct(&t.state, w * probe_stress_g) + self.time_effects_pct(t_s)
        } + self.readout.noise_pct * self.noise.gaussian();
        let target = self.detector_target_v(&self.taxels[i], strain);
        // The detector starts from the previous taxel's level and settles toward this one's.
        let start = self.taxels[previous.index()].detector_v;
        let v = target + (start - target) * self.blend;
        self.taxels[i].detector_v = v;
        self.convert(i, v)
    }

    /// Eq. 2 divides by C_s + C_l, not C_l, so eq. 6 reads strain low by about C_s/(C_s + C_l):
    /// the static gain calibration puts it back (1.0065 with the default 100 pF).
    pub fn static_gain(&self) -> f32 {
        let c0 = self.readout.geometry.capacitance_f(0.0);
        let cl = self.readout.node.lumped_capacitance_f;
        ((c0 + cl) / cl) as f32
    }

    /// Calibration as a technician captures it at start-up, probe lifted: each taxel's trims
    /// and its at-rest output (the mean of `frames` converter readings at rest).
    pub fn rest_calibration(&mut self, frames: usize) -> [TaxelCalibration; TAXELS] {
        core::array::from_fn(|i| {
            let mut sum = 0.0f64;
            for _ in 0..frames.max(1) {
                let noise = self.readout.noise_pct * self.noise.gaussian();
                let target = self.detector_target_v(&self.taxels[i], noise);
                sum += f64::from(self.adc.volts(self.convert(i, target)));
            }
            TaxelCalibration {
                amplifier: self.taxels[i].amplifier,
                rest_output_v: (sum / frames.max(1) as f64) as f32,
                gain: self.static_gain(),
            }
        })
    }
}

/// Strain from a converter code through the core's calibration (the firmware's conversion).
pub fn code_to_strain_pct(adc: &AdcScale, cal: &TaxelCalibration, code: AdcCode) -> f32 {
    cal.strain_pct(adc.volts(code), StrainForm::Exact)
}

pub use tactile_core::tactile::StrainGrid;

#[cfg(test)]
mod tests {
    use super::*;

    fn finger(effects: Effects) -> Finger {
        Finger::new(
            3,
            TaxelId::new(3, 2).unwrap_or_default(),
            effects,
            ReadoutParams::default(),
            AdcScale::BIPOLAR_10V_12BIT,
            ScanConfig::DESIGN,
        )
    }

    #[test]
    fn read_out_chain_recovers_strain_within_a_converter_step() {
        let mut f = Finger {
            readout: ReadoutParams {
                noise_pct: 0.0,
                ..Default::default()
            },
            ..finger(Effects::MEMO)
        };
        let cal = f.rest_calibration(4);
        let probe = f.probe.index();
        for stress in [0.0, 10.0, 50.0, 100.0] {
            let truth = f.probe_element().strain_pct(&f.probe_taxel().state, stress);
            let code = f.sample_probe_channel(stress, 0.0);
            let got = code_to_strain_pct(&f.adc, &cal[probe], code);
            // One 12-bit code is 4.9 mV, about 0.012 % strain through the 8.5× stage; the
            // residual eq. 2 nonlinearity after the gain calibration is below 0.01 % at 20 %.
            assert!(
                (f64::from(got) - truth).abs() < 0.025,
                "{stress} g: {got} vs {truth}"
            );
        }
    }

    #[test]
    fn a_short_dwell_reads_a_blend_of_the_previous_taxel() {
        let quick = ReadoutParams {
            noise_pct: 0.0,
            ..Default::default()
        };
        let mut scan = ScanConfig::DESIGN;
        scan.dwell_s = scan.envelope_tau_s; // one τ: 37 % of the previous taxel
        let mut f = Finger::new(
            3,
            TaxelId::new(3, 2).unwrap_or_default(),
            Effects::MEMO,
            quick,
            AdcScale::BIPOLAR_10V_12BIT,
            scan,
        );
        let cal = f.rest_calibration(1);
        let probe = f.probe;
        let next = TaxelId::from_index(probe.index() + 1);
        // Load the probe taxel hard, then read its unloaded-far neighbour after it.
        let _ = f.sample_scan(probe, TaxelId::from_index(probe.index() - 1), 80.0, 0.0);
        let code = f.sample_scan(next, probe, 0.0, 0.0);
        let blended = code_to_strain_pct(&f.adc, &cal[next.index()], code);
        assert!(
            blended > 3.0,
            "a one-τ dwell should carry the 80 g taxel over: {blended}"
        );
        // With the design dwell (10 τ) the carry-over is below a converter step.
        let mut g = finger(Effects::MEMO);
        g.readout.noise_pct = 0.0;
        let cal = g.rest_calibration(1);
        let _ = g.sample_scan(probe, TaxelId::from_index(probe.index() - 1), 80.0, 0.0);
        let code = g.sample_scan(next, probe, 0.0, 0.0);
        let clean = code_to_strain_pct(&g.adc, &cal[next.index()], code);
        assert!(clean.abs() < 0.02, "{clean}");
    }

    #[test]
    fn hysteresis_separates_loading_from_unloading() {
        // The hysteresis part is the difference from the same history without the effect.
        let run = |amplitude: f64| {
            let mut f = finger(Effects {
                hysteresis_pct: amplitude,
                ..Effects::MEMO
            });
            // Up to 40 g, down to 30 g: the plays of radius 2 and 5 g sit at their upper edge
            // (+1 each), the 10 g one on the load (0) → +2/3 of the amplitude.
            for s in (0..=40).chain((30..40).rev()) {
                f.tick(f64::from(s), 1e-3);
            }
            let down = f.probe_sensor_strain_pct(30.0, 0.0);
            // Down to 10 g and back up to 30 g: every play lags below → −1 of the amplitude.
            for s in (10..30).rev().chain(10..=30) {
                f.tick(f64::from(s), 1e-3);
            }
            (down, f.probe_sensor_strain_pct(30.0, 0.0))
        };
        let (down, up) = run(1.0);
        let (down0, up0) = run(0.0);
        assert!(((down - down0) - 2.0 / 3.0).abs() < 1e-9, "{down} {down0}");
        assert!(((up - up0) + 1.0).abs() < 1e-9, "{up} {up0}");
    }

    #[test]
    fn stiffening_scale_pivots_at_30_g() {
        let law = NonlinearMk::ELEMENT_4_2.g1;
        for s in [0.0, 0.5, 1.0] {
            let scaled = scale_law(law, s);
            assert!((scaled.stiffness(30.0) - law.stiffness(30.0)).abs() < 1e-9);
        }
        assert_eq!(scale_law(law, 1.0), law);
        assert_eq!(scale_law(law, 0.0).stiffness(80.0), law.stiffness(30.0));
        // Stronger: stiffer at high load. Weaker: stiffer at low load, softer at high load.
        assert!(scale_law(law, 2.0).stiffness(80.0) > law.stiffness(80.0));
        assert!(scale_law(law, 0.5).stiffness(5.0) > law.stiffness(5.0));
        assert!(scale_law(law, 0.5).stiffness(80.0) < law.stiffness(80.0));
    }
}
