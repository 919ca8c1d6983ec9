//! The tactile path: the capacitive element (memo eqs. 1–6), its read-out amplifier
//! ("Finger Amplifier Circuit") and the 8×8 scan sequencer.
//!
//! Forward relations (strain → capacitance → sensed amplitude → amplifier output) are used by
//! the simulator; the inverse (amplifier output → strain, with per-taxel calibration) runs on
//! the chip. Both live here so there is one copy of the memo's equations.

/// Rows (drive strips) and columns (sense strips) of the multiplexed array.
pub const ROWS: usize = 8;
pub const COLS: usize = 8;
/// One 8×8 frame of the array, row-major: strain in percent.
pub type StrainGrid = [[f32; COLS]; ROWS];
pub const TAXELS: usize = ROWS * COLS;
/// The taxel under the force probe: element 4,2 of the memo (row 4, column 2 counted from one),
/// read on its own channel every control tick.
pub const PROBED_TAXEL: TaxelId = TaxelId::from_index(3 * COLS + 2);

/// Permittivity of free space, F/m.
pub const EPSILON_0_F_PER_M: f64 = 8.854_187_812_8e-12;

/// One crossing of a drive row and a sense column. Fields are always < 8.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TaxelId {
    row: u8,
    col: u8,
}

impl TaxelId {
    /// `None` when out of the array.
    pub const fn new(row: usize, col: usize) -> Option<TaxelId> {
        if row < ROWS && col < COLS {
            Some(TaxelId {
                row: row as u8,
                col: col as u8,
            })
        } else {
            None
        }
    }
    /// Row-major index 0..64, wrapping.
    pub const fn from_index(index: usize) -> TaxelId {
        let i = index % TAXELS;
        TaxelId {
            row: (i / COLS) as u8,
            col: (i % COLS) as u8,
        }
    }
    pub const fn row(self) -> usize {
        self.row as usize
    }
    pub const fn col(self) -> usize {
        self.col as usize
    }
    pub const fn index(self) -> usize {
        self.row() * COLS + self.col()
    }
}

/// Geometry of one capacitive element (memo section 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementGeometry {
    pub dielectric_constant: f64,
    pub plate_area_m2: f64,
    pub gap_m: f64,
}

impl ElementGeometry {
    /// 2.5 mm × 5.1 mm plates, 0.7 mm gap, dielectric constant about 4.
    pub const MEMO: ElementGeometry = ElementGeometry {
        dielectric_constant: 4.0,
        plate_area_m2: 2.5e-3 * 5.1e-3,
        gap_m: 0.7e-3,
    };

    /// Eq. 1: C = K₀ ε₀ A / (d₀ − Δd), with Δd = ε d₀ (ε in percent / 100).
    pub fn capacitance_f(&self, strain_pct: f64) -> f64 {
        let delta_d = strain_pct / 100.0 * self.gap_m;
        self.dielectric_constant * EPSILON_0_F_PER_M * self.plate_area_m2 / (self.gap_m - delta_d)
    }
}

/// The sensing node of memo Fig. 4: element C_s against the lumped C_l ∥ R_l.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SenseNode {
    pub lumped_capacitance_f: f64,
    pub input_resistance_ohm: f64,
    /// Drive amplitude |V_d| (memo: 10 V).
    pub drive_amplitude_v: f64,
    /// Drive frequency (memo: 200 kHz).
    pub drive_frequency_hz: f64,
}

impl SenseNode {
    /// Eq. 2: |V_s| = C_s R_l ω / √(1 + [ω R_l (C_s + C_l)]²) · |V_d|.
    pub fn sensed_amplitude_v(&self, element_f: f64) -> f64 {
        let w = 2.0 * core::f64::consts::PI * self.drive_frequency_hz;
        let rl = self.input_resistance_ohm;
        let x = w * rl * (element_f + self.lumped_capacitance_f);
        element_f * rl * w / crate::trig::sqrt(1.0 + x * x) * self.drive_amplitude_v
    }
    /// Eq. 3, the C_l ≫ C_s, high-ω limit: |V_s| = (C_s / C_l) |V_d|.
    pub fn sensed_amplitude_limit_v(&self, element_f: f64) -> f64 {
        element_f / self.lumped_capacitance_f * self.drive_amplitude_v
    }
}

/// Eq. 6, exact under eq. 1: ε = (|V_s| − |V_o|) / |V_s|, in percent.
#[inline]
pub fn strain_from_amplitudes_pct(sensed_v: f32, rest_v: f32) -> f32 {
    100.0 * (sensed_v - rest_v) / sensed_v
}

/// Which strain formula to use (see FACTS.md misprint 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StrainForm {
    /// ε = (V_s − V_o)/V_s = Δd/d₀, eq. 6 (exact).
    Exact,
    /// ε = (V_s − V_o)/V_o, the memo appendix's form; overstates strain by 1/(1 − ε).
    Appendix,
}

/// Offset and gain stage after the envelope detector, with its per-taxel trims.
///
/// `V_out = −R_pf [V_cc/R_p1 + (V_s − V_D)/R_1]`. With the memo's V_cc = +14.7 V the offset
/// cannot bring V_out,o near zero for any positive trim (misprint 4), so the offset here is taken
/// from the negative rail: `offset_supply_v` is −14.7 V by default and R_p1 is the trim.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReadoutAmplifier {
    pub r1_ohm: f32,
    pub rpf_ohm: f32,
    pub rp1_ohm: f32,
    pub diode_drop_v: f32,
    pub offset_supply_v: f32,
}

impl ReadoutAmplifier {
    /// Element 4,2's trims, with the memo's (positive) supply: V_out,o lands far outside ±10 V.
    pub const MEMO_ELEMENT_4_2: ReadoutAmplifier = ReadoutAmplifier {
        r1_ohm: 22e3,
        rpf_ohm: 187e3,
        rp1_ohm: 48e3,
        diode_drop_v: 0.6,
        offset_supply_v: 14.7,
    };

    /// Output voltage for an envelope-detector input of `sensed_v − V_D`.
    #[inline]
    pub fn output_v(&self, sensed_v: f32) -> f32 {
        -self.rpf_ohm
            * (self.offset_supply_v / self.rp1_ohm + (sensed_v - self.diode_drop_v) / self.r1_ohm)
    }

    /// Sensed amplitude V_s that produced `output_v` (the amplifier relation solved for V_s).
    #[inline]
    pub fn sensed_v(&self, output_v: f32) -> f32 {
        -(self.r1_ohm / self.rpf_ohm)
            * (output_v + self.rpf_ohm / self.rp1_ohm * self.offset_supply_v)
            + self.diode_drop_v
    }

    /// The R_p1 that puts the at-rest output at `target_v` for a rest amplitude `rest_v`;
    /// `None` when no positive resistor can (the offset supply has the wrong sign).
    pub fn trim_rp1_ohm(&self, rest_v: f32, target_v: f32) -> Option<f32> {
        let per_ohm = -target_v / self.rpf_ohm - (rest_v - self.diode_drop_v) / self.r1_ohm;
        let rp1 = self.offset_supply_v / per_ohm;
        (rp1.is_finite() && rp1 > 0.0).then_some(rp1)
    }
}

/// Per-taxel calibration: the amplifier trims, the at-rest output captured at start-up, and a
/// gain that corrects the element's sensitivity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaxelCalibration {
    pub amplifier: ReadoutAmplifier,
    /// V_out,o: the amplifier output with no load, captured at start-up.
    pub rest_output_v: f32,
    /// Multiplies the computed strain (1.0 when the element is nominal).
    pub gain: f32,
}

impl TaxelCalibration {
    /// Strain (percent) from an amplifier output.
    ///
    /// `V_s − V_o = −(R_1/R_pf)(V_out,s − V_out,o)` and
    /// `V_o = −(R_1/R_pf)[V_out,o + (R_pf/R_p1) V_cc] + V_D`.
    #[inline]
    pub fn strain_pct(&self, output_v: f32, form: StrainForm) -> f32 {
        let amp = &self.amplifier;
        let rest_v = amp.sensed_v(self.rest_output_v);
        let delta_v = -(amp.r1_ohm / amp.rpf_ohm) * (output_v - self.rest_output_v);
        let denominator = match form {
            StrainForm::Exact => rest_v + delta_v,
            StrainForm::Appendix => rest_v,
        };
        self.gain * 100.0 * delta_v / denominator
    }
}

/// The 8×8 scan: which row and column to select next, how long to dwell, and which sample
/// belongs to which taxel. Pure logic; the firmware and the simulator drive it.
///
/// The envelope detector is a diode with a single-pole lowpass of time constant τ. When the
/// multiplexer moves on, the detector output approaches the new taxel's level as e^(−t/τ), so a
/// sample taken after a dwell `t` still carries e^(−t/τ) of the previous taxel. The dwell is
/// chosen to push that blend below one converter code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanConfig {
    /// Envelope-detector time constant (the design uses 25 µs: five carrier periods at 200 kHz).
    pub envelope_tau_s: f32,
    /// Dwell on each taxel before it is sampled.
    pub dwell_s: f32,
}

impl ScanConfig {
    /// τ = 25 µs, dwell 250 µs (10 τ: the blend is e⁻¹⁰ = 4.5×10⁻⁵ of the previous taxel, below
    /// one 12-bit code), so a frame of 64 taxels takes 16 ms: 62.5 frames per second.
    pub const DESIGN: ScanConfig = ScanConfig {
        envelope_tau_s: 25e-6,
        dwell_s: 250e-6,
    };

    /// Fraction of the previous taxel's level left in a sample.
    pub fn blend(&self) -> f32 {
        libm::expf(-self.dwell_s / self.envelope_tau_s)
    }

    /// The dwell that leaves at most `residual` of the previous taxel.
    pub fn dwell_for_residual_s(envelope_tau_s: f32, residual: f32) -> f32 {
        envelope_tau_s * libm::logf(1.0 / residual)
    }

    pub fn frame_period_s(&self) -> f32 {
        self.dwell_s * TAXELS as f32
    }
}

/// One step of the scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScanStep {
    /// The taxel the sample just taken belongs to.
    pub sampled: TaxelId,
    /// The taxel now selected: drive its row, sense its column, then dwell.
    pub next: TaxelId,
    /// `sampled` was the last taxel of a frame.
    pub frame_complete: bool,
}

/// Row-major scan over the array.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScanSequencer {
    index: u8,
}

impl ScanSequencer {
    pub const fn new() -> Self {
        Self { index: 0 }
    }
    /// The taxel whose row and column are selected now.
    pub const fn selected(&self) -> TaxelId {
        TaxelId::from_index(self.index as usize)
    }
    /// Call once the dwell has elapsed and the converter has sampled the selected taxel.
    pub fn advance(&mut self) -> ScanStep {
        let sampled = self.selected();
        self.index = ((self.index as usize + 1) % TAXELS) as u8;
        ScanStep {
            sampled,
            next: self.selected(),
            frame_complete: sampled.index() == TAXELS - 1,
        }
    }
}

/// A whole 8×8 frame of values (strain in percent, say).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrayFrame<T: Copy> {
    pub cells: [[T; COLS]; ROWS],
}

impl<T: Copy + Default> Default for ArrayFrame<T> {
    fn default() -> Self {
        Self {
            cells: [[T::default(); COLS]; ROWS],
        }
    }
}

impl<T: Copy> ArrayFrame<T> {
    pub fn get(&self, taxel: TaxelId) -> Option<T> {
        self.cells
            .get(taxel.row())
            .and_then(|r| r.get(taxel.col()))
            .copied()
    }
    pub fn set(&mut self, taxel: TaxelId, value: T) {
        if let Some(cell) = self
            .cells
            .get_mut(taxel.row())
            .and_then(|r| r.get_mut(taxel.col()))
        {
            *cell = value;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capacitance_by_hand() {
        // C = 4 · 8.854e-12 · 12.75e-6 / 0.7e-3 = 0.6451 pF at rest; at 10 % strain the gap is
        // 0.63 mm and C = 0.7168 pF.
        let g = ElementGeometry::MEMO;
        assert!((g.capacitance_f(0.0) - 0.645_090e-12).abs() < 1e-16);
        assert!((g.capacitance_f(10.0) - 0.716_767e-12).abs() < 1e-16);
    }

    #[test]
    fn eq_5_and_6_recover_the_geometric_strain() {
        // With the eq. 3 limit, (V_s − V_o)/V_s is exactly Δd/d₀ for any strain.
        let g = ElementGeometry::MEMO;
        let node = SenseNode {
            lumped_capacitance_f: 20e-12,
            input_resistance_ohm: 1e6,
            drive_amplitude_v: 10.0,
            drive_frequency_hz: 200e3,
        };
        let rest = node.sensed_amplitude_limit_v(g.capacitance_f(0.0));
        for strain in [0.5, 3.0, 12.0, 20.0] {
            let vs = node.sensed_amplitude_limit_v(g.capacitance_f(strain));
            let e = strain_from_amplitudes_pct(vs as f32, rest as f32);
            assert!((f64::from(e) - strain).abs() < 1e-4, "{e} vs {strain}");
        }
        // Eq. 2 approaches eq. 3 when C_l ≫ C_s and ω R_l (C_s + C_l) ≫ 1: here ωR_lC_l = 25.1
        // and C_s/C_l = 3.2 %, so eq. 2 is C_s/(C_s + C_l) ≈ 3.1 % below the limit.
        let c = g.capacitance_f(0.0);
        let full = node.sensed_amplitude_v(c);
        let limit = node.sensed_amplitude_limit_v(c);
        assert!(((full - limit) / limit).abs() < 3.5e-2, "{full} {limit}");
    }

    #[test]
    fn amplifier_by_hand_with_the_memo_values() {
        let amp = ReadoutAmplifier::MEMO_ELEMENT_4_2;
        // V_o = 5 V: V_out,o = −187k (14.7/48k + 4.4/22k) = −187k (306.25 µ + 200 µ) = −94.669 V.
        let rest_out = amp.output_v(5.0);
        assert!((rest_out + 94.668_75).abs() < 1e-3, "{rest_out}");
        assert!((amp.sensed_v(rest_out) - 5.0).abs() < 1e-4);
        // 10 % strain: V_s = 5/0.9 = 5.5556 V.
        let strained_out = amp.output_v(5.0 / 0.9);
        let cal = TaxelCalibration {
            amplifier: amp,
            rest_output_v: rest_out,
            gain: 1.0,
        };
        let exact = cal.strain_pct(strained_out, StrainForm::Exact);
        let appendix = cal.strain_pct(strained_out, StrainForm::Appendix);
        assert!((exact - 10.0).abs() < 2e-3, "{exact}");
        // Appendix form: 0.5556/5 = 11.11 %, the 1/(1 − ε) overstatement.
        assert!((appendix - 11.111).abs() < 2e-3, "{appendix}");
    }

    #[test]
    fn trim_brings_the_rest_output_into_range_only_from_the_negative_rail() {
        let memo = ReadoutAmplifier::MEMO_ELEMENT_4_2;
        assert_eq!(memo.trim_rp1_ohm(5.0, 0.0), None);
        let mut amp = ReadoutAmplifier {
            offset_supply_v: -14.7,
            ..memo
        };
        // −14.7 / R_p1 = −4.4/22k → R_p1 = 73.5 kΩ for V_out,o = 0.
        let rp1 = amp.trim_rp1_ohm(5.0, 0.0).unwrap();
        assert!((rp1 - 73_500.0).abs() < 1.0, "{rp1}");
        amp.rp1_ohm = rp1;
        assert!(amp.output_v(5.0).abs() < 1e-3);
    }

    #[test]
    fn scan_walks_row_major_and_flags_frame_ends() {
        let mut s = ScanSequencer::new();
        assert_eq!(s.selected(), TaxelId::new(0, 0).unwrap());
        let mut frames = 0;
        for i in 0..(2 * TAXELS) {
            let step = s.advance();
            assert_eq!(step.sampled.index(), i % TAXELS);
            assert_eq!(step.next.index(), (i + 1) % TAXELS);
            assert_eq!(step.sampled.row(), (i % TAXELS) / 8);
            assert_eq!(step.sampled.col(), i % 8);
            frames += usize::from(step.frame_complete);
        }
        assert_eq!(frames, 2);
    }

    #[test]
    fn design_dwell_arithmetic() {
        let c = ScanConfig::DESIGN;
        assert!((c.blend() - (-10.0f32).exp()).abs() < 1e-7);
        assert!(c.blend() < 1.0 / 4096.0);
        assert!((c.frame_period_s() - 0.016).abs() < 1e-7);
        let dwell = ScanConfig::dwell_for_residual_s(25e-6, 1.0 / 4096.0);
        assert!((dwell - 25e-6 * 4096f32.ln()).abs() < 1e-9);
    }

    #[test]
    fn frame_access_never_panics() {
        let mut f = ArrayFrame::<f32>::default();
        let t = TaxelId::new(7, 3).unwrap();
        f.set(t, 2.5);
        assert_eq!(f.get(t), Some(2.5));
        assert_eq!(f.cells[7][3], 2.5);
        assert!(TaxelId::new(8, 0).is_none());
    }
}
