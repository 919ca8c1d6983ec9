//! The tactile scan: one multiplexer step per dwell, strain per taxel through its calibration,
//! the inverse model per taxel at the frame rate, and once a frame where the contact is and how
//! hard it presses (the locator on the per-taxel estimates), beside the array's centroid.
//!
//! Frame rate: the envelope detector's τ is 25 µs and each taxel dwells 10 τ = 250 µs, leaving
//! e⁻¹⁰ = 4.5·10⁻⁵ of the previous taxel (below one 12-bit code); 64 taxels × 250 µs = 16 ms a
//! frame, 62.5 frames/s (`ScanConfig::DESIGN`).

use crate::calibration::{TableError, TableView, MAX_LOOP_TAXELS};
use crate::contact::{ContactKind, Locator, LocatorConfig, SpatialResponse, SpatialTableError};
use crate::estimator::{CalibrationFlags, TaxelModel};
use crate::estimator::{EstimatorKind, StrainConditioner, TaxelEstimator, TaxelEstimators};
use crate::gauge::AdcScale;
use crate::hysteresis::LoopCompensator;
use crate::io::ScanIo;
use crate::tactile::{
    ArrayFrame, ScanSequencer, StrainForm, TaxelCalibration, TaxelId, COLS, ROWS, TAXELS,
};
use crate::telemetry::TaxelFrame;

use super::config::{ConfigError, FirmwareConfig};
pub use super::unlocated::UnlocatedFrame;

/// Array force below which the centroid is not defined (no contact), grams.
pub const CONTACT_THRESHOLD_G: f32 = 0.5;

/// Force over the whole array from one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ArrayEstimate {
    /// Board tick of the frame it belongs to (same as its `TaxelFrame`).
    pub tick: u32,
    /// The contact's force: the point the locator fits to the good taxels' estimates (a press
    /// loads its neighbours too, so their sum reads well above it); their sum when the frame
    /// holds nothing, grams.
    pub total_force_g: f32,
    /// Force-weighted row and column of the good taxels (0..7); NaN when their sum is below
    /// [`CONTACT_THRESHOLD_G`].
    pub centroid_row: f32,
    pub centroid_col: f32,
    /// Where the contact is, mm: x along the columns, y along the rows, from the centre of
    /// taxel r0c0 (0 when the frame holds nothing).
    pub contact_x_mm: f32,
    pub contact_y_mm: f32,
    /// Whether the frame is one point contact, two, a load no point explains, or nothing.
    pub contact: ContactKind,
    /// The probed element's force from the scan (frame rate), grams.
    pub probe_force_g: f32,
    /// The probed element's force by every estimator, side by side (elastic, second-order
    /// inverse, scheduled inverse, observer, force bank), grams.
    pub probe_estimates_g: [f32; EstimatorKind::COUNT],
    /// Taxels whose force this frame lies beyond the load their calibration covered (the
    /// spring curves extrapolated): bit `TaxelId::index`.
    pub extrapolated_taxels: u64,
}

/// What the scanner made of the calibration table at start-up.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationStatus {
    /// Taxels running their own calibration (the rest run the nominal models).
    pub calibrated_taxels: u8,
    /// Taxels whose calibration says it is poor (held out above 1 g, or an offset the model
    /// misses): bit `TaxelId::index`.
    pub flagged_taxels: u64,
    /// Why the table was refused, if it was.
    pub refused: Option<TableError>,
    /// Why the array's spatial table was refused, if one was given and was (the locator then
    /// runs the configuration's response).
    pub array_refused: Option<SpatialTableError>,
}

/// A completed frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanReport {
    pub frame: TaxelFrame,
    pub estimate: ArrayEstimate,
}

/// The scan task's state.
#[derive(Clone, Debug)]
pub struct Scanner {
    sequencer: ScanSequencer,
    calibration: [TaxelCalibration; TAXELS],
    adc: AdcScale,
    probe: TaxelId,
    strain_pct: ArrayFrame<f32>,
    force_g: ArrayFrame<f32>,
    estimators: [TaxelEstimator; TAXELS],
    /// Each taxel's strain conditioning from its calibration (offset, interference notch).
    conditioners: [StrainConditioner; TAXELS],
    /// The hysteresis taken off before the estimator of the taxels whose calibration has one,
    /// by taxel index.
    loops: heapless::Vec<(u8, LoopCompensator), MAX_LOOP_TAXELS>,
    /// `None` until [`Scanner::reset`] has run.
    probe_bench: Option<TaxelEstimators>,
    probe_estimates_g: [f32; EstimatorKind::COUNT],
    status: CalibrationStatus,
    bad_taxels: u64,
    /// The load each taxel's calibration covered, grams (infinite without a calibration).
    range_g: [f32; TAXELS],
    extrapolated_taxels: u64,
    locator: Locator,
}

impl Scanner {
    /// A scanner with each taxel's rest calibration and, from the configuration's table, its
    /// dynamic calibration (nominal models where the table has none, or when it is refused);
    /// every estimator is discretized at the frame period (each taxel is sampled once a frame).
    pub fn new(
        config: &FirmwareConfig,
        calibration: [TaxelCalibration; TAXELS],
    ) -> Result<Self, ConfigError> {
        let mut scanner = Self::blank(config, calibration);
        scanner.reset(config, calibration)?;
        Ok(scanner)
    }

    /// A scanner whose estimators are not built yet: [`Self::reset`] builds them in place. A
    /// board writes this into its static and resets it there (the 64 estimators are 20 KB,
    /// too much to build on a stack and move).
    pub fn blank(config: &FirmwareConfig, calibration: [TaxelCalibration; TAXELS]) -> Self {
        Self {
            sequencer: ScanSequencer::new(),
            calibration,
            adc: config.taxel_adc,
            probe: config.probe,
            strain_pct: ArrayFrame::default(),
            force_g: ArrayFrame::default(),
            estimators: [TaxelEstimator::Elastic { g_per_pct: 0.0 }; TAXELS],
            conditioners: [StrainConditioner::default(); TAXELS],
            loops: heapless::Vec::new(),
            probe_bench: None,
            probe_estimates_g: [0.0; EstimatorKind::COUNT],
            status: CalibrationStatus {
                calibrated_taxels: 0,
                flagged_taxels: 0,
                refused: None,
                array_refused: None,
            },
            bad_taxels: 0,
            range_g: [f32::INFINITY; TAXELS],
            extrapolated_taxels: 0,
            locator: Locator::new(config.locator),
        }
    }

    /// The locator's configuration: the array table's response over `config.locator`'s when
    /// the table is given and passes its check; with why it was refused if it was not.
    fn locator_of(config: &FirmwareConfig) -> (LocatorConfig, Option<SpatialTableError>) {
        if config.array_table.is_empty() {
            return (config.locator, None);
        }
        match SpatialResponse::decode(config.array_table) {
            Ok(response) => (
                LocatorConfig {
                    response,
                    ..config.locator
                },
                None,
            ),
            Err(e) => (config.locator, Some(e)),
        }
    }

    /// Starts over in place, as [`Self::new`] would build it (64 observers are 20 KB: a board
    /// starting a new run rebuilds them where they are rather than on its stack).
    pub fn reset(
        &mut self,
        config: &FirmwareConfig,
        calibration: [TaxelCalibration; TAXELS],
    ) -> Result<(), ConfigError> {
        self.reset_with_table(config, calibration, config.calibration)
    }

    /// [`Self::reset`] on the rest calibration it holds (a board that does not calibrate
    /// again between runs: the probe may be pressing).
    pub fn rebuild(&mut self, config: &FirmwareConfig) -> Result<(), ConfigError> {
        self.reset(config, self.calibration)
    }

    /// [`Self::rebuild`] with the calibration table `table` (one loaded by command) in place of
    /// the configuration's.
    pub fn rebuild_with_table(
        &mut self,
        config: &FirmwareConfig,
        table: &[u8],
    ) -> Result<(), ConfigError> {
        self.reset_with_table(config, self.calibration, table)
    }

    /// [`Self::reset`] with the calibration table `table` in place of the configuration's (one
    /// loaded at run time; checked here as the built-in one is).
    pub fn reset_with_table(
        &mut self,
        config: &FirmwareConfig,
        calibration: [TaxelCalibration; TAXELS],
        table: &[u8],
    ) -> Result<(), ConfigError> {
        let frame_s = f64::from(config.scan.frame_period_s());
        let (view, mut status) = match TableView::check(table) {
            Ok(v) => (
                Some(v),
                CalibrationStatus {
                    calibrated_taxels: v.len() as u8,
                    // Filled in below, as each record is read.
                    flagged_taxels: 0,
                    refused: None,
                    array_refused: None,
                },
            ),
            Err(e) => (
                None,
                CalibrationStatus {
                    calibrated_taxels: 0,
                    flagged_taxels: 0,
                    refused: Some(e),
                    array_refused: None,
                },
            ),
        };
        // The nominal models once for every taxel without a calibration, then the table's
        // taxels over them: a start-up that decodes each record once and tabulates the
        // nominal springs once (a new run on the QEMU board resets within a few ticks).
        let nominal = TaxelModel::nominal(config.probe);
        // The estimator the taxel's calibration held out best with, unless the build fixes one
        // for the whole array.
        let kind_of = |m: &TaxelModel| config.array_estimator.unwrap_or(m.estimator);
        let build = |m: &TaxelModel| -> Result<(TaxelEstimator, StrainConditioner), ConfigError> {
            let est =
                TaxelEstimator::new(kind_of(m), m, frame_s).map_err(ConfigError::Estimator)?;
            Ok((est, StrainConditioner::new(m, frame_s)))
        };
        let (nominal_est, nominal_cond) = build(&nominal)?;
        self.estimators.fill(nominal_est);
        self.conditioners.fill(nominal_cond);
        self.loops.clear();
        self.range_g.fill(f32::INFINITY);
        let mut probe_model = nominal;
        for m in view.iter().flat_map(|v| v.models()) {
            let i = m.taxel.index();
            if let (Some(est), Some(cond)) =
                (self.estimators.get_mut(i), self.conditioners.get_mut(i))
            {
                (*est, *cond) = build(&m)?;
            }
            // The table's check allows no more loops than there is room for.
            let plays = kind_of(&m).loop_taken_off(&m);
            if !plays.is_empty() {
                let _ = self.loops.push((i as u8, LoopCompensator::new(plays)));
            }
            if let Some(range) = self.range_g.get_mut(i).filter(|_| m.range_g > 0.0) {
                *range = m.range_g as f32;
            }
            if m.flags
                .intersects(CalibrationFlags::POOR | CalibrationFlags::OFFSET)
            {
                status.flagged_taxels |= 1 << i;
            }
            if m.taxel == config.probe {
                probe_model = m;
            }
        }
        self.probe_bench =
            Some(TaxelEstimators::new(&probe_model, frame_s).map_err(ConfigError::Estimator)?);
        self.sequencer = ScanSequencer::new();
        self.calibration = calibration;
        self.adc = config.taxel_adc;
        self.probe = config.probe;
        self.strain_pct = ArrayFrame::default();
        self.force_g = ArrayFrame::default();
        self.probe_estimates_g = [0.0; EstimatorKind::COUNT];
        self.status = status;
        self.bad_taxels = 0;
        self.extrapolated_taxels = 0;
        let (locator, array_refused) = Self::locator_of(config);
        self.locator = Locator::new(locator);
        self.status.array_refused = array_refused;
        Ok(())
    }

    /// The probed taxel's side-by-side estimators (a copy, to time each on its own).
    pub fn probe_bench(&self) -> Option<TaxelEstimators> {
        self.probe_bench
    }

    /// The probed taxel's latest strain, percent.
    pub fn probe_strain_pct(&self) -> f32 {
        self.strain_pct.get(self.probe).unwrap_or(0.0)
    }

    /// What the scanner made of the calibration table.
    pub fn calibration_status(&self) -> CalibrationStatus {
        self.status
    }

    /// Selects the first taxel (call once before the first dwell).
    pub fn start(&mut self, io: &mut impl ScanIo) {
        io.select_taxel(self.sequencer.selected());
    }

    /// One scan step, after the dwell: converts the selected taxel, moves the multiplexer on,
    /// and returns the frame, its contact located, when the last taxel of the array was
    /// sampled.
    pub fn step(&mut self, io: &mut impl ScanIo, board_tick: u32) -> Option<ScanReport> {
        self.step_unlocated(io, board_tick)
            .map(|frame| frame.locate(&self.locator))
    }

    /// The locator the frames are located with (its configuration is the scanner's, set at
    /// each reset).
    pub fn locator(&self) -> &Locator {
        &self.locator
    }

    /// Locates the next frames with `config`, the taxels' estimators going on as they are: a
    /// host that learns the array's response from the frames it scans (a reset would start
    /// every estimator over on a finger that has crept).
    pub fn set_locator(&mut self, config: LocatorConfig) {
        self.locator = Locator::new(config);
    }

    /// [`Self::step`] without the locator, for an interrupt that must stay within its dwell:
    /// the completed frame is located later by [`UnlocatedFrame::locate`].
    pub fn step_unlocated(
        &mut self,
        io: &mut impl ScanIo,
        board_tick: u32,
    ) -> Option<UnlocatedFrame> {
        let code = io.read_taxel();
        let step = self.sequencer.advance();
        io.select_taxel(step.next);
        let taxel = step.sampled;
        let bit = 1u64 << taxel.index();
        // A taxel at a converter rail is open or shorted: marked, and left out of the sums.
        if self.adc.at_rail(code) {
            self.bad_taxels |= bit;
        } else {
            self.bad_taxels &= !bit;
        }
        let strain = self.calibration.get(taxel.index()).map_or(f32::NAN, |cal| {
            cal.strain_pct(self.adc.volts(code), StrainForm::Exact)
        });
        self.take_strain(taxel, strain);
        step.frame_complete.then(|| self.unlocated(board_tick))
    }

    /// A whole frame of strains (percent, a record's row) through each taxel's path as
    /// [`Self::step`] takes a converted code: the chip's code over a record. A non-finite
    /// strain marks its taxel bad, as a converter rail does.
    pub fn step_strains(
        &mut self,
        strain_pct: &[[f32; COLS]; ROWS],
        board_tick: u32,
    ) -> ScanReport {
        for (i, &strain) in strain_pct.iter().flatten().enumerate() {
            let taxel = TaxelId::from_index(i);
            let bit = 1u64 << i;
            if strain.is_finite() {
                self.bad_taxels &= !bit;
                self.take_strain(taxel, strain);
            } else {
                // Left out, its estimator's state kept for when it reads again.
                self.bad_taxels |= bit;
                self.strain_pct.set(taxel, f32::NAN);
                self.force_g.set(taxel, f32::NAN);
            }
        }
        self.unlocated(board_tick).locate(&self.locator)
    }

    /// One taxel's strain through its conditioner, loop compensator and estimator.
    fn take_strain(&mut self, taxel: TaxelId, strain: f32) {
        let bit = 1u64 << taxel.index();
        self.strain_pct.set(taxel, strain);
        let conditioned = self
            .conditioners
            .get_mut(taxel.index())
            .map_or(strain, |c| c.update(strain));
        let i = taxel.index();
        let comp = self.loops.iter_mut().find(|(t, _)| usize::from(*t) == i);
        let force = match (self.estimators.get_mut(i), comp) {
            (Some(e), Some((_, comp))) => comp.force_g(|s| e.force_g(s), conditioned),
            (Some(e), None) => e.force_g(conditioned),
            (None, _) => 0.0,
        };
        self.force_g.set(taxel, force);
        if self.range_g.get(taxel.index()).is_some_and(|r| force > *r) {
            self.extrapolated_taxels |= bit;
        } else {
            self.extrapolated_taxels &= !bit;
        }
        if taxel == self.probe {
            if let Some(bench) = &mut self.probe_bench {
                self.probe_estimates_g = bench.update(strain);
            }
        }
    }

    fn unlocated(&self, board_tick: u32) -> UnlocatedFrame {
        let mut frame = TaxelFrame {
            seq: 0,
            tick: board_tick,
            bad_taxels: self.bad_taxels,
            ..Default::default()
        };
        let (mut total, mut row_moment, mut col_moment) = (0.0f32, 0.0f32, 0.0f32);
        // The locator's input: the good taxels' estimates, a bad one left out (NaN).
        let mut good_g = [f32::NAN; TAXELS];
        for (r, (cells, (strains, forces))) in frame
            .strain_centi_pct
            .iter_mut()
            .zip(self.strain_pct.cells.iter().zip(self.force_g.cells.iter()))
            .enumerate()
        {
            for (c, (cell, (&strain, &force))) in cells
                .iter_mut()
                .zip(strains.iter().zip(forces.iter()))
                .enumerate()
            {
                *cell = TaxelFrame::quantize(strain);
                if self.bad_taxels & (1u64 << (r * COLS + c)) == 0 && force.is_finite() {
                    if let Some(g) = good_g.get_mut(r * COLS + c) {
                        *g = force;
                    }
                    total += force;
                    row_moment += force * r as f32;
                    col_moment += force * c as f32;
                }
            }
        }
        let (centroid_row, centroid_col) = if total >= CONTACT_THRESHOLD_G {
            (row_moment / total, col_moment / total)
        } else {
            (f32::NAN, f32::NAN)
        };
        UnlocatedFrame {
            frame,
            // The locator's fields are [`UnlocatedFrame::locate`]'s.
            estimate: ArrayEstimate {
                tick: board_tick,
                total_force_g: total,
                centroid_row,
                centroid_col,
                contact_x_mm: 0.0,
                contact_y_mm: 0.0,
                contact: ContactKind::Nothing,
                probe_force_g: self.force_g.get(self.probe).unwrap_or(0.0),
                probe_estimates_g: self.probe_estimates_g,
                extrapolated_taxels: self.extrapolated_taxels,
            },
            good_g,
        }
    }

    /// Taxels at a converter rail in their latest sample (open or shorted): bit
    /// `TaxelId::index`.
    pub fn bad_taxels(&self) -> u64 {
        self.bad_taxels
    }

    /// The latest force estimate of every taxel, grams.
    pub fn forces_g(&self) -> &[[f32; COLS]; ROWS] {
        &self.force_g.cells
    }

    /// The latest strain of every taxel, percent.
    pub fn strain_pct(&self) -> &[[f32; COLS]; ROWS] {
        &self.strain_pct.cells
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::calibration::{CalibrationTable, MAX_TABLE_BYTES};
    use crate::gauge::AdcCode;

    /// The table the firmware builds carry (`boards/calibration/table.bin`).
    static CALIBRATION_TABLE: &[u8] = include_bytes!("../../boards/calibration/table.bin");
    const BOARD: FirmwareConfig = FirmwareConfig {
        calibration: CALIBRATION_TABLE,
        ..FirmwareConfig::MEMO
    };

    /// A fake multiplexer: per-taxel output volts, converted by the memo's converter (the
    /// unlocated frame's tests share it).
    pub(in crate::tasks) struct Panel {
        pub(in crate::tasks) volts: [f32; TAXELS],
        pub(in crate::tasks) selected: TaxelId,
        pub(in crate::tasks) adc: AdcScale,
    }

    impl ScanIo for Panel {
        fn select_taxel(&mut self, taxel: TaxelId) {
            self.selected = taxel;
        }
        fn read_taxel(&mut self) -> AdcCode {
            self.adc.code(self.volts[self.selected.index()])
        }
    }

    fn calibration(rest_v: f32) -> [TaxelCalibration; TAXELS] {
        [TaxelCalibration {
            amplifier: crate::tactile::ReadoutAmplifier::MEMO_ELEMENT_4_2,
            rest_output_v: rest_v,
            gain: 1.0,
        }; TAXELS]
    }

    #[test]
    fn one_pressed_taxel_puts_the_centroid_on_it_and_a_railed_one_is_left_out() {
        // Nominal models everywhere (no table), so every unpressed taxel reads zero force.
        let config = FirmwareConfig {
            calibration: &[],
            ..BOARD
        };
        // The rest output as the converter reads it, so unpressed taxels read zero strain.
        let rest_v = config.taxel_adc.volts(config.taxel_adc.code(4.0));
        let mut scanner = Scanner::new(&config, calibration(rest_v)).unwrap();
        assert_eq!(
            scanner.calibration_status().refused,
            Some(TableError::TooShort {
                bytes: 0,
                needed: 8
            })
        );
        let mut panel = Panel {
            volts: [4.0; TAXELS],
            selected: TaxelId::default(),
            adc: config.taxel_adc,
        };
        // Taxel (5, 6) strained: more capacitance, larger V_s, the output stage moves up.
        panel.volts[5 * 8 + 6] = 6.0;
        // Taxel (0, 0) shorted to the negative rail.
        panel.volts[0] = -12.0;
        scanner.start(&mut panel);
        let mut reports = Vec::new();
        for k in 0..(TAXELS * 3) {
            if let Some(r) = scanner.step(&mut panel, k as u32) {
                reports.push(r);
            }
        }
        assert_eq!(reports.len(), 3);
        let last = reports[2];
        assert_eq!(last.frame.bad_taxels, 1);
        assert!(last.frame.strain_centi_pct[5][6] > 100, "{:?}", last.frame);
        assert_eq!(last.frame.strain_centi_pct[1][1], 0);
        let e = last.estimate;
        assert!(e.total_force_g > CONTACT_THRESHOLD_G, "{e:?}");
        assert!((e.centroid_row - 5.0).abs() < 1e-3 && (e.centroid_col - 6.0).abs() < 1e-3);
        assert_eq!(e.tick, (TAXELS * 3 - 1) as u32);
        // Nothing pressed: no centroid.
        let mut quiet = Scanner::new(&config, calibration(rest_v)).unwrap();
        panel.volts = [4.0; TAXELS];
        quiet.start(&mut panel);
        let r = (0..TAXELS)
            .find_map(|k| quiet.step(&mut panel, k as u32))
            .unwrap();
        assert!(r.estimate.centroid_row.is_nan() && r.estimate.total_force_g.abs() < 0.5);
    }

    /// A press between taxels loads its neighbours too (their estimates sum to about 2.7 times
    /// the press by the memo geometry's spread): the frame's force is the contact's, and its
    /// location the press's. Every taxel on the elastic model (G = 3.23 g/%), so a strain of
    /// F·share/G is a force of F·share by hand.
    #[test]
    fn a_press_spread_over_neighbours_reads_its_own_force_where_it_is() {
        let config = FirmwareConfig {
            calibration: &[],
            array_estimator: Some(EstimatorKind::Elastic),
            ..BOARD
        };
        let mut scanner = Scanner::new(&config, calibration(4.0)).unwrap();
        let g = TaxelModel::nominal(config.probe).elastic_g_per_pct as f32;
        let r = config.locator.response;
        let (x, y, force) = (10.6f32, 13.1f32, 40.0f32);
        let mut strain = [[0.0f32; COLS]; ROWS];
        let mut sum_g = 0.0;
        for (i, s) in strain.iter_mut().flatten().enumerate() {
            let (cx, cy) = r.centre_mm(TaxelId::from_index(i));
            let share = r.share(cx - x, cy - y).weight;
            *s = force * share / g;
            sum_g += force * share;
        }
        assert!(sum_g > 2.0 * force, "{sum_g}");
        let mut last = None;
        for k in 0..50 {
            last = Some(scanner.step_strains(&strain, k).estimate);
        }
        let e = last.unwrap();
        assert_eq!(e.contact, ContactKind::Point, "{e:?}");
        assert!((e.total_force_g - force).abs() < 0.01 * force, "{e:?}");
        assert!(
            (e.contact_x_mm - x).abs() < 0.02 && (e.contact_y_mm - y).abs() < 0.02,
            "{e:?}"
        );
        // A taxel gone bad (NaN) beside the press is left out, the contact still found.
        strain[3][2] = f32::NAN;
        let e = scanner.step_strains(&strain, 50).estimate;
        assert_eq!(e.contact, ContactKind::Point, "{e:?}");
        assert_eq!(scanner.bad_taxels(), 1 << (3 * COLS + 2));
        assert!((e.contact_x_mm - x).abs() < 0.05, "{e:?}");
    }

    /// The array's table is checked at start-up: a good one's geometry locates the press, a
    /// damaged one is refused with the reason and the configuration's response stands.
    #[test]
    fn the_array_table_is_read_and_checked_at_start_up() {
        let wide = SpatialResponse {
            pitch_mm: 5.0,
            depth_mm: 3.0,
            ..SpatialResponse::MEMO
        };
        let good: &'static [u8] = Box::leak(Box::new(wide.encode()));
        let mut bad = wide.encode();
        bad[20] ^= 4;
        let bad: &'static [u8] = Box::leak(Box::new(bad));
        let base = FirmwareConfig {
            calibration: &[],
            array_estimator: Some(EstimatorKind::Elastic),
            ..BOARD
        };
        let g = TaxelModel::nominal(base.probe).elastic_g_per_pct as f32;
        // A 30 g press at (13, 17) mm on the 5 mm finger, every taxel elastic.
        let mut strain = [[0.0f32; COLS]; ROWS];
        for (i, s) in strain.iter_mut().flatten().enumerate() {
            let (cx, cy) = wide.centre_mm(TaxelId::from_index(i));
            *s = 30.0 * wide.share(cx - 13.0, cy - 17.0).weight / g;
        }
        let run = |array_table: &'static [u8]| {
            let config = FirmwareConfig {
                array_table,
                ..base
            };
            let mut scanner = Scanner::new(&config, calibration(4.0)).unwrap();
            let e = (0..30)
                .map(|k| scanner.step_strains(&strain, k).estimate)
                .last()
                .unwrap();
            (scanner.calibration_status().array_refused, e)
        };
        let (refused, e) = run(good);
        assert_eq!(refused, None);
        assert!(
            (e.contact_x_mm - 13.0).abs() < 0.02 && (e.contact_y_mm - 17.0).abs() < 0.02,
            "{e:?}"
        );
        assert!((e.total_force_g - 30.0).abs() < 0.3, "{e:?}");
        let (refused, e) = run(bad);
        assert!(
            matches!(refused, Some(SpatialTableError::Checksum { .. })),
            "{refused:?}"
        );
        // The memo geometry's 4 mm pitch puts the press elsewhere.
        assert!((e.contact_x_mm - 13.0).abs() > 1.0, "{e:?}");
    }

    #[test]
    fn the_build_carries_a_table_of_four_calibrated_taxels_and_a_damaged_one_is_refused() {
        let rest = [TaxelCalibration {
            amplifier: crate::tactile::ReadoutAmplifier::MEMO_ELEMENT_4_2,
            rest_output_v: 4.0,
            gain: 1.0,
        }; TAXELS];
        let scanner = Scanner::new(&BOARD, rest).unwrap();
        assert_eq!(
            scanner.calibration_status(),
            CalibrationStatus {
                calibrated_taxels: 4,
                flagged_taxels: 0,
                refused: None,
                array_refused: None,
            }
        );
        let mut damaged = CALIBRATION_TABLE.to_vec();
        damaged[100] ^= 1;
        let leaked: &'static [u8] = Box::leak(damaged.into_boxed_slice());
        let config = FirmwareConfig {
            calibration: leaked,
            ..BOARD
        };
        let status = Scanner::new(&config, rest).unwrap().calibration_status();
        assert!(
            matches!(status.refused, Some(TableError::Checksum { .. })),
            "{status:?}"
        );
        assert_eq!(status.calibrated_taxels, 0);
    }

    #[test]
    fn a_force_beyond_the_calibrated_range_is_flagged_extrapolated() {
        // Taxel 0 calibrated to 20 g and flagged poor; the rest nominal (never extrapolated).
        let taxel = TaxelId::from_index(0);
        let mut table = CalibrationTable::default();
        let model = TaxelModel {
            range_g: 20.0,
            flags: CalibrationFlags::POOR,
            estimator: crate::estimator::EstimatorKind::Elastic,
            ..TaxelModel::nominal(taxel)
        };
        table.taxels.push(model).unwrap();
        let (config, mut scanner) = board_with(&table);
        assert_eq!(scanner.calibration_status().flagged_taxels, 1);
        // Every taxel at the same strain: taxel 0 runs the elastic model (G = 3.23 g/%), so a
        // strain of 3 % reads 9.7 g (inside 20 g) and 9 % reads 29 g (beyond).
        let inside = frame_at_strain(&mut scanner, &config, 3.0);
        assert_eq!(inside.extrapolated_taxels, 0, "{inside:?}");
        let beyond = frame_at_strain(&mut scanner, &config, 9.0);
        assert_eq!(beyond.extrapolated_taxels, 1, "{beyond:?}");
    }

    /// The board's configuration carrying `table`, and its scanner at rest (4 V).
    fn board_with(table: &CalibrationTable) -> (FirmwareConfig, Scanner) {
        let mut bytes = vec![0u8; MAX_TABLE_BYTES];
        let n = table.encode(&mut bytes).unwrap();
        bytes.truncate(n);
        let config = FirmwareConfig {
            calibration: Box::leak(bytes.into_boxed_slice()),
            ..BOARD
        };
        let rest_v = config.taxel_adc.volts(config.taxel_adc.code(4.0));
        let scanner = Scanner::new(&config, calibration(rest_v)).unwrap();
        (config, scanner)
    }

    /// One frame with every taxel at `strain_pct` (the read-out is monotone: its volts found by
    /// bisection).
    fn frame_at_strain(
        scanner: &mut Scanner,
        config: &FirmwareConfig,
        strain_pct: f32,
    ) -> ArrayEstimate {
        let rest_v = config.taxel_adc.volts(config.taxel_adc.code(4.0));
        let rest = calibration(rest_v);
        let (mut lo, mut hi) = (rest_v, 10.0f32);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if rest[0].strain_pct(mid, StrainForm::Exact) < strain_pct {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut panel = Panel {
            volts: [lo; TAXELS],
            selected: TaxelId::default(),
            adc: config.taxel_adc,
        };
        scanner.start(&mut panel);
        (0..TAXELS)
            .find_map(|k| scanner.step(&mut panel, k as u32))
            .map(|r| r.estimate)
            .unwrap()
    }

    /// A taxel whose calibration has hysteresis: the loop its last estimate leaves is taken off
    /// its strain. By hand, elastic G with one play (r, w) and the strain held at ε: the first
    /// frame reads G ε and leaves the play r behind, the loop −w r; every later frame reads
    /// G (ε + w r).
    #[test]
    fn a_taxels_hysteresis_is_taken_off_its_strain() {
        use crate::hysteresis::Plays;
        let probe = BOARD.probe;
        let model = TaxelModel {
            estimator: crate::estimator::EstimatorKind::Elastic,
            hysteresis: Plays::new(&[(2.0, 0.05)]).unwrap(),
            ..TaxelModel::nominal(probe)
        };
        let g = model.elastic_g_per_pct as f32;
        let mut table = CalibrationTable::default();
        table.taxels.push(model).unwrap();
        let (config, mut scanner) = board_with(&table);
        let first = frame_at_strain(&mut scanner, &config, 3.0).probe_force_g;
        let strain = scanner.probe_strain_pct();
        assert!(
            (first - g * strain).abs() < 1e-3,
            "{first} vs {}",
            g * strain
        );
        for _ in 0..3 {
            let later = frame_at_strain(&mut scanner, &config, 3.0).probe_force_g;
            let expected = g * (strain + 0.05 * 2.0);
            assert!((later - expected).abs() < 1e-3, "{later} vs {expected}");
        }
    }
}
