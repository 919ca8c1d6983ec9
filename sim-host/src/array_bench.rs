//! The array's benchmark through the chip's path: a finger whose 64 elements each have their own
//! dynamics (the simulator's per-taxel spread), each taxel calibrated from its own record of the
//! calibration protocol, the array's spatial response calibrated from presses through those
//! calibrated estimators, and then steps of one contact, two contacts or a line anywhere on the
//! array located every frame by the firmware's scanner (`Scanner::step_strains`: each taxel's
//! conditioner and estimator from the table, then the locator).
//!
//! The finger here is the simulated finger's elements and spatial law, each taxel's strain
//! stepped once a frame (exact for a load held over the frame: a contact's step lands on a
//! frame's start), with the finger's strain noise and the converter's step (12 bits through
//! the read-out's 8.5× stage: 0.012 % strain). The calibration records are the protocol's
//! command as the applicator's force (its loop tracks to a fraction of a gram) and the taxel's
//! strain under it with the same noise.

use tactile_core::calibration::CalibrationTable;
use tactile_core::contact::{ContactKind, LocatorConfig, SpatialResponse};
use tactile_core::estimator::TaxelModel;
use tactile_core::profile::{CommandSource, Protocol};
use tactile_core::tactile::{StrainGrid, TaxelId, COLS, ROWS, TAXELS};
use tactile_core::tasks::{ArrayEstimate, FirmwareConfig, Scanner};
use tactile_core::viscoelastic::{NonlinearMk, NonlinearMkState};
use tactile_plant::finger::{Finger, ReadoutParams, NOMINAL_TAXEL};
use tactile_plant::noise::Noise;
use tactile_plant::spatial::SpatialLaw;
use tactile_record::{FramesRecord, Truth};

use crate::array_calibration::{fit_response, press_grid, presses_scanned, scanner};
use crate::dynamic_calibration::{encode_table, fit_taxel, CalibrationError};
use crate::Error;

/// One 12-bit converter step as strain through the read-out's stage, percent.
const CODE_STEP_PCT: f64 = 0.012;
/// A contact's step is held this long, then lifted for [`LIFT_S`].
const HOLD_S: f64 = 3.0;
const LIFT_S: f64 = 1.5;
/// The step's first second is its creep; its last second, at rest.
const CREEP_S: f64 = 1.0;
const REST_FROM_S: f64 = 2.0;

/// Frame period of the scan, s.
fn frame_s() -> f64 {
    f64::from(FirmwareConfig::MEMO.scan.frame_period_s())
}

/// The simulated finger's 64 elements under a spatial law, read as the scan reads them.
pub struct BenchFinger {
    elements: [NonlinearMk; TAXELS],
    state: [NonlinearMkState; TAXELS],
    law: SpatialLaw,
    noise: Noise,
    noise_pct: f64,
}

impl BenchFinger {
    /// The finger drawn from `seed` (each taxel's springs and dashpots spread about element
    /// 4,2 as the simulator's finger spreads them), at rest.
    pub fn new(seed: u64, law: SpatialLaw) -> Self {
        let finger = Finger::memo(seed);
        Self {
            elements: core::array::from_fn(|i| finger.element_of(i)),
            state: [NonlinearMkState::default(); TAXELS],
            law,
            noise: Noise::new(seed ^ 0x6265_6e63),
            noise_pct: ReadoutParams::default().noise_pct,
        }
    }

    /// A strain as the converter gives it: the finger's noise, then the code's step.
    fn read(&mut self, strain_pct: f64) -> f64 {
        let noisy = strain_pct + self.noise_pct * self.noise.gaussian();
        (noisy / CODE_STEP_PCT).round() * CODE_STEP_PCT
    }

    /// Each taxel's load under point contacts `(x_mm, y_mm, force_g)`.
    pub fn loads(&self, contacts: &[(f64, f64, f64)]) -> [f64; TAXELS] {
        let mut load = [0.0; TAXELS];
        for &(x, y, f) in contacts {
            let shares = self.law.shares(NOMINAL_TAXEL, x, y);
            for (l, s) in load.iter_mut().zip(shares) {
                *l += f * s;
            }
        }
        load
    }

    /// One frame with each taxel carrying `load_g` over it: the strains the scan reads at its
    /// end.
    pub fn frame(&mut self, load_g: &[f64; TAXELS]) -> StrainGrid {
        let dt = frame_s();
        let mut grid = [[0.0f32; COLS]; ROWS];
        for (i, cell) in grid.iter_mut().flatten().enumerate() {
            let (element, load) = (self.elements[i], load_g[i]);
            element.step(&mut self.state[i], load, dt);
            let strain = element.strain_pct(&self.state[i], load);
            *cell = self.read(strain) as f32;
        }
        grid
    }

    /// Frames under a schedule of contacts (each entry one frame's contacts).
    pub fn frames<'a>(
        &mut self,
        schedule: impl IntoIterator<Item = &'a [(f64, f64, f64)]>,
    ) -> Vec<StrainGrid> {
        schedule
            .into_iter()
            .map(|contacts| {
                let load = self.loads(contacts);
                self.frame(&load)
            })
            .collect()
    }

    /// The calibration protocol's record of taxel `index` with the applicator over its centre
    /// (its share 1), sampled every millisecond: (force g, strain %). Its own state, apart
    /// from the finger's.
    fn calibration_record(&mut self, index: usize) -> (Vec<f64>, Vec<f64>) {
        let protocol = Protocol::CALIBRATION;
        let mut source = CommandSource::new(protocol);
        let element = self.elements[index];
        let mut state = NonlinearMkState::default();
        let n = (f64::from(protocol.duration_s()) / 1e-3).round() as usize;
        (0..n)
            .map(|k| {
                let force = f64::from(source.command_g(k as f32 * 1e-3)).max(0.0);
                element.step(&mut state, force, 1e-3);
                let strain = self.read(element.strain_pct(&state, force));
                (force, strain)
            })
            .unzip()
    }

    /// Every taxel's calibration as a table's bytes: fitted from its own record of the
    /// calibration protocol (`tactile calibrate`'s fit, about 6 s a taxel), or its own element
    /// given whole (what a perfect fit would find; the observer runs it).
    pub fn calibrate_taxels(&mut self, how: TaxelCalibration) -> Result<Vec<u8>, Error> {
        let models: Vec<TaxelModel> = match how {
            TaxelCalibration::Fitted => {
                let records: Vec<(Vec<f64>, Vec<f64>)> =
                    (0..TAXELS).map(|i| self.calibration_record(i)).collect();
                fit_in_parallel(&records)?
            }
            TaxelCalibration::Exact => (0..TAXELS)
                .map(|i| TaxelModel {
                    element: self.elements[i],
                    ..TaxelModel::nominal(TaxelId::from_index(i))
                })
                .collect(),
        };
        let mut table = CalibrationTable::default();
        for model in models {
            table
                .taxels
                .push(model)
                .map_err(|_| CalibrationError::TooManyTaxels)?;
        }
        encode_table(std::path::Path::new("bench"), &table)
    }

    /// The array's spatial calibration through the calibrated estimators, `scanner` running
    /// them: the protocol's presses (an `n` × `n` grid, 50 g) on the finger, fitted for the
    /// response.
    pub fn calibrate_array(
        &mut self,
        scanner: &mut Scanner,
        n: usize,
    ) -> Result<SpatialResponse, Error> {
        let pitch = f64::from(self.law.response().pitch_mm);
        let (hold, lift) = (
            (1.0 / frame_s()).round() as usize,
            (0.5 / frame_s()).round() as usize,
        );
        let mut truth = Vec::new();
        for (x, y) in press_grid(pitch, n) {
            for k in 0..hold + lift {
                let force_g = if k < hold { 50.0 } else { 0.0 };
                truth.push(Truth {
                    x_mm: x,
                    y_mm: y,
                    force_g,
                });
            }
        }
        let rec = self.record(&truth.iter().map(|t| vec![*t]).collect::<Vec<_>>());
        let presses = presses_scanned(&rec, std::path::Path::new("bench"), scanner)?;
        Ok(fit_response(&presses)?.response)
    }

    /// A frames record of contacts (each frame's list; the first contact is the record's
    /// truth).
    fn record(&mut self, schedule: &[Vec<Truth>]) -> FramesRecord {
        let as_points: Vec<Vec<(f64, f64, f64)>> = schedule
            .iter()
            .map(|c| c.iter().map(|t| (t.x_mm, t.y_mm, t.force_g)).collect())
            .collect();
        let frames = self.frames(as_points.iter().map(Vec::as_slice));
        FramesRecord {
            t_s: (1..=frames.len()).map(|k| k as f64 * frame_s()).collect(),
            strain_pct: frames,
            truth: schedule.iter().map(|c| c.first().copied()).collect(),
            ..FramesRecord::default()
        }
    }
}

/// Each taxel's fit from its record (by taxel index), the work shared over the machine's cores.
fn fit_in_parallel(records: &[(Vec<f64>, Vec<f64>)]) -> Result<Vec<TaxelModel>, Error> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = records.len().div_ceil(threads).max(1);
    let fitted: Vec<Result<Vec<TaxelModel>, Error>> = std::thread::scope(|scope| {
        let handles: Vec<_> = records
            .chunks(chunk)
            .enumerate()
            .map(|(k, part)| {
                scope.spawn(move || {
                    part.iter()
                        .enumerate()
                        .map(|(j, (force, strain))| {
                            let taxel = TaxelId::from_index(k * chunk + j);
                            fit_taxel(taxel, Protocol::CALIBRATION, 1e-3, force, strain)
                                .map(|(m, _)| m)
                                .map_err(Error::from)
                        })
                        .collect()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join().unwrap_or_else(|_| {
                    Err(Error::Failed("a taxel's calibration panicked".to_string()))
                })
            })
            .collect()
    });
    let mut models = Vec::with_capacity(records.len());
    for part in fitted {
        models.extend(part?);
    }
    Ok(models)
}

/// How each taxel's dynamic calibration is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaxelCalibration {
    /// Fitted from the taxel's record of the calibration protocol.
    Fitted,
    /// The taxel's own element (a fit without error).
    Exact,
}

/// A finger calibrated as a user would (the taxels' table and the array's response), and the
/// chip's scanner that has run since the finger was at rest: its estimators carry the
/// finger's history (a scanner started over on a finger that has crept reads the creep
/// still to recover as load).
pub struct Calibrated {
    pub finger: BenchFinger,
    pub table: Vec<u8>,
    pub response: SpatialResponse,
    scanner: Scanner,
    frames: u32,
}

impl Calibrated {
    /// The finger `seed` under `law`, its taxels (`how`) and then its array calibrated.
    pub fn new(seed: u64, law: SpatialLaw, how: TaxelCalibration) -> Result<Self, Error> {
        let mut finger = BenchFinger::new(seed, law);
        let table = finger.calibrate_taxels(how)?;
        let mut scanner = scanner(&FirmwareConfig::MEMO, &table)?;
        let response = finger.calibrate_array(&mut scanner, 9)?;
        let mut calibrated = Self {
            finger,
            table,
            response,
            scanner,
            frames: 0,
        };
        calibrated.locate_with(response);
        Ok(calibrated)
    }

    /// The scanner locates with `response` from now on (its estimators go on).
    pub fn locate_with(&mut self, response: SpatialResponse) {
        self.response = response;
        self.scanner.set_locator(LocatorConfig {
            response,
            ..LocatorConfig::MEMO
        });
    }

    /// Starts the scanner over (a board's new run, or its start-up) on the finger as it is.
    pub fn restart_scanner(&mut self) -> Result<(), Error> {
        self.scanner = scanner(&FirmwareConfig::MEMO, &self.table)?;
        self.locate_with(self.response);
        Ok(())
    }

    /// The chip's estimates over frames of contacts.
    fn located(&mut self, schedule: &[Vec<Truth>]) -> Vec<ArrayEstimate> {
        let rec = self.finger.record(schedule);
        rec.strain_pct
            .iter()
            .map(|grid| {
                self.frames += 1;
                self.scanner.step_strains(grid, self.frames).estimate
            })
            .collect()
    }
}

/// A phase of a step's frames: location and force errors against the truth, the centroid's
/// beside them.
#[derive(Clone, Copy, Debug, Default)]
pub struct PhaseErrors {
    pub frames: usize,
    /// Location RMS, mm: the locator's and the centroid's.
    pub location_mm: f64,
    pub centroid_mm: f64,
    /// Frames whose force is within 3 % + 0.5 g, and the worst error as a share of that.
    pub force_within: usize,
    pub force_worst: f64,
    /// The force's RMS error, percent of the truth, and its mean (a bias), grams.
    pub force_rms_pct: f64,
    pub force_bias_g: f64,
    /// Frames said to be one point.
    pub points: usize,
}

impl PhaseErrors {
    fn add(&mut self, e: &ArrayEstimate, t: &Truth, pitch_mm: f32) {
        let sq = |x: f32, y: f32| (f64::from(x) - t.x_mm).powi(2) + (f64::from(y) - t.y_mm).powi(2);
        self.frames += 1;
        self.location_mm += sq(e.contact_x_mm, e.contact_y_mm);
        let (cx, cy) = (e.centroid_col * pitch_mm, e.centroid_row * pitch_mm);
        self.centroid_mm += if cx.is_finite() {
            sq(cx, cy)
        } else {
            sq(0.0, 0.0)
        };
        let error = f64::from(e.total_force_g) - t.force_g;
        let share = error.abs() / (0.03 * t.force_g + 0.5);
        self.force_within += usize::from(share <= 1.0);
        self.force_worst = self.force_worst.max(share);
        self.force_rms_pct += (100.0 * error / t.force_g).powi(2);
        self.force_bias_g += error;
        self.points += usize::from(e.contact == ContactKind::Point);
    }

    fn finish(mut self) -> Self {
        let n = self.frames.max(1) as f64;
        self.location_mm = (self.location_mm / n).sqrt();
        self.centroid_mm = (self.centroid_mm / n).sqrt();
        self.force_rms_pct = (self.force_rms_pct / n).sqrt();
        self.force_bias_g /= n;
        self
    }
}

/// Somewhere at least half a pitch inside the array's outer centres.
fn position(noise: &mut Noise, pitch_mm: f64) -> (f64, f64) {
    let span = (COLS - 2) as f64 * pitch_mm;
    (
        0.5 * pitch_mm + span * noise.uniform(),
        0.5 * pitch_mm + span * noise.uniform(),
    )
}

/// Frames of a step held [`HOLD_S`] then lifted [`LIFT_S`], each frame's contacts and the
/// time since the step (negative while lifted).
fn step_schedule(contacts: &[Truth]) -> Vec<(Vec<Truth>, f64)> {
    let (hold, lift) = (
        (HOLD_S / frame_s()).round() as usize,
        (LIFT_S / frame_s()).round() as usize,
    );
    (0..hold + lift)
        .map(|k| {
            if k < hold {
                (contacts.to_vec(), (k + 1) as f64 * frame_s())
            } else {
                (Vec::new(), -1.0)
            }
        })
        .collect()
}

/// Single contacts: `steps` steps, each at a random position at least half a pitch inside,
/// 10–100 g; each step's first second (creep) and its last second (at rest) scored apart.
pub fn single_contacts(
    finger: &mut Calibrated,
    steps: usize,
    seed: u64,
) -> Result<(PhaseErrors, PhaseErrors), Error> {
    let pitch = finger.finger.law.response().pitch_mm;
    let mut noise = Noise::new(seed);
    let mut schedule = Vec::new();
    for _ in 0..steps {
        let (x_mm, y_mm) = position(&mut noise, f64::from(pitch));
        let force_g = 10.0 + 90.0 * noise.uniform();
        schedule.extend(step_schedule(&[Truth {
            x_mm,
            y_mm,
            force_g,
        }]));
    }
    let contacts: Vec<Vec<Truth>> = schedule.iter().map(|(c, _)| c.clone()).collect();
    let estimates = finger.located(&contacts);
    let (mut creep, mut rest) = (PhaseErrors::default(), PhaseErrors::default());
    for (e, (c, since)) in estimates.iter().zip(&schedule) {
        let Some(t) = c.first() else {
            continue;
        };
        if *since <= CREEP_S {
            creep.add(e, t, finger.response.pitch_mm);
        } else if *since > REST_FROM_S {
            rest.add(e, t, finger.response.pitch_mm);
        }
    }
    Ok((creep.finish(), rest.finish()))
}

/// Frames said not to be one point, and the frames pressed.
pub type Flagged = (usize, usize);

/// Frames not said to be one point, of those pressed: two contacts 10 mm apart (any
/// direction, each 10–100 g, both at least half a pitch inside) and a 12 mm line (any
/// direction, 10–100 g spread along it), `steps` steps of each.
pub fn not_one_point(
    finger: &mut Calibrated,
    steps: usize,
    seed: u64,
) -> Result<(Flagged, Flagged), Error> {
    let pitch = f64::from(finger.finger.law.response().pitch_mm);
    let mut noise = Noise::new(seed);
    let inside = |v: f64| (0.5 * pitch..=(COLS as f64 - 1.5) * pitch).contains(&v);
    let (mut two, mut line) = (Vec::new(), Vec::new());
    for _ in 0..steps {
        let ((x, y), (x2, y2)) = loop {
            let (x, y) = position(&mut noise, pitch);
            let angle = std::f64::consts::TAU * noise.uniform();
            let (x2, y2) = (x + 10.0 * angle.cos(), y + 10.0 * angle.sin());
            if inside(x2) && inside(y2) {
                break ((x, y), (x2, y2));
            }
        };
        let (f1, f2) = (10.0 + 90.0 * noise.uniform(), 10.0 + 90.0 * noise.uniform());
        let point = |x_mm, y_mm, force_g| Truth {
            x_mm,
            y_mm,
            force_g,
        };
        two.extend(step_schedule(&[point(x, y, f1), point(x2, y2, f2)]));
        let (x, y) = position(&mut noise, pitch);
        let angle = std::f64::consts::TAU * noise.uniform();
        let total = 10.0 + 90.0 * noise.uniform();
        let points: Vec<Truth> = (0..25)
            .map(|k| {
                let s = -6.0 + 12.0 * f64::from(k) / 24.0;
                point(x + s * angle.cos(), y + s * angle.sin(), total / 25.0)
            })
            .collect();
        line.extend(step_schedule(&points));
    }
    let mut count = |schedule: &[(Vec<Truth>, f64)]| -> Result<Flagged, Error> {
        let contacts: Vec<Vec<Truth>> = schedule.iter().map(|(c, _)| c.clone()).collect();
        let estimates = finger.located(&contacts);
        let pressed = estimates
            .iter()
            .zip(schedule)
            .filter(|(_, (c, _))| !c.is_empty());
        Ok(pressed.fold((0, 0), |(flagged, n), (e, _)| {
            (
                flagged + usize::from(e.contact != ContactKind::Point),
                n + 1,
            )
        }))
    };
    Ok((count(&two)?, count(&line)?))
}

/// A phase's row of the benchmark's table.
fn row(name: &str, p: &PhaseErrors) -> String {
    let share = |k: usize| 100.0 * k as f64 / p.frames.max(1) as f64;
    format!(
        "| {name} | {} | {:.3} | {:.3} | {:.1} % | {:.2} | {:.2} | {:+.2} | {:.1} % |\n",
        p.frames,
        p.location_mm,
        p.centroid_mm,
        share(p.force_within),
        p.force_worst,
        p.force_rms_pct,
        p.force_bias_g,
        share(p.points),
    )
}

/// The benchmark's table on the finger `seed`: `steps` single contacts right after the
/// calibration, then `steps` / 2 steps each of two contacts and of a line, then `steps` single
/// contacts again (the finger's elements have crept and recovered for as long again), the
/// same located with the memo geometry instead of the array's calibration, and again with the
/// scanner started over.
pub fn bench_table(
    seed: u64,
    law: SpatialLaw,
    how: TaxelCalibration,
    steps: usize,
) -> Result<String, Error> {
    let mut finger = Calibrated::new(seed, law, how)?;
    let r = finger.response;
    let (creep, rest) = single_contacts(&mut finger, steps, seed + 1)?;
    let ((two, n2), (line, nl)) = not_one_point(&mut finger, steps / 2, seed + 2)?;
    let (late_creep, late_rest) = single_contacts(&mut finger, steps, seed + 4)?;
    let minutes = (HOLD_S + LIFT_S) * steps as f64 / 60.0;
    let mut text = format!(
        "finger seed {seed}, {how:?} taxel calibration; array calibrated to pitch {:.3} mm, depth \
         {:.3} mm, plate {:.3} mm\n\n\
         | phase | frames | location RMS (mm) | centroid RMS (mm) | force within 3 % + 0.5 g | \
         worst (of the allowance) | force RMS (%) | mean error (g) | one point |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
        r.pitch_mm, r.depth_mm, r.plate_mm
    );
    text += &row("first second (creep)", &creep);
    text += &row("at rest (2–3 s)", &rest);
    let late = |what: &str| format!("{what}, {:.0}–{:.0} min on", 2.0 * minutes, 3.0 * minutes);
    text += &row(&late("first second"), &late_creep);
    text += &row(&late("at rest"), &late_rest);
    text += &format!(
        "\nnot one point: two contacts 10 mm apart {two} of {n2} frames ({:.1} %), a 12 mm line \
         {line} of {nl} ({:.1} %)\n",
        100.0 * two as f64 / n2.max(1) as f64,
        100.0 * line as f64 / nl.max(1) as f64
    );
    // The same finger located with the memo geometry the firmware has without an array table.
    let calibrated = finger.response;
    finger.locate_with(SpatialResponse::MEMO);
    let (creep, rest) = single_contacts(&mut finger, steps, seed + 3)?;
    text += &format!(
        "without the array's calibration (the memo geometry), {:.0}–{:.0} min on: location RMS \
         {:.3} mm in the first second, {:.3} mm at rest; force within 3 % + 0.5 g on {:.1} % \
         and {:.1} % of frames\n",
        3.0 * minutes,
        4.0 * minutes,
        creep.location_mm,
        rest.location_mm,
        100.0 * creep.force_within as f64 / creep.frames.max(1) as f64,
        100.0 * rest.force_within as f64 / rest.frames.max(1) as f64,
    );
    // The scanner started over on the finger as it has crept (a board's next run).
    finger.locate_with(calibrated);
    finger.restart_scanner()?;
    let (creep, rest) = single_contacts(&mut finger, steps, seed + 5)?;
    text += &format!(
        "the scanner started over after {:.0} min of use (a board's next run; the elements' creep \
         still to recover read as load): location RMS {:.3} mm and {:.3} mm; force within 3 % + \
         0.5 g on {:.1} % and {:.1} % of frames, {:+.2} g and {:+.2} g on average\n",
        4.0 * minutes,
        creep.location_mm,
        rest.location_mm,
        100.0 * creep.force_within as f64 / creep.frames.max(1) as f64,
        100.0 * rest.force_within as f64 / rest.frames.max(1) as f64,
        creep.force_bias_g,
        rest.force_bias_g,
    );
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One contact anywhere at least half a pitch inside, 10–100 g, on two fingers each of
    /// whose taxels has its own dynamics (each calibrated with its own element; the fitted
    /// calibration's figures are `--example array_bench -- --fitted`'s): the 0.3 mm
    /// in the step's first second, when every element creeps, and at rest, well inside the
    /// centroid's error (the taxels' quantization, about an eighth of the 4 mm pitch); the
    /// force within 3 % + 0.5 g on nearly every frame, and still after minutes of use (each
    /// estimator follows its element's slow creep); two contacts 10 mm apart and a 12 mm line
    /// said not to be one point in 95 % of their frames.
    #[test]
    fn contacts_are_located_through_each_taxels_dynamics() {
        for seed in [3, 4] {
            let mut finger =
                Calibrated::new(seed, SpatialLaw::MEMO_HALF_SPACE, TaxelCalibration::Exact)
                    .unwrap();
            let (creep, rest) = single_contacts(&mut finger, 40, 100 + seed).unwrap();
            let ((two, n2), (line, nl)) = not_one_point(&mut finger, 20, 200 + seed).unwrap();
            let (late_creep, late_rest) = single_contacts(&mut finger, 40, 300 + seed).unwrap();
            eprintln!(
                "finger {seed}:\n  creep {creep:?}\n  rest {rest:?}\n  two contacts {two} of \
                 {n2}, line {line} of {nl}\n  later, creep {late_creep:?}\n  later, rest \
                 {late_rest:?}"
            );
            for p in [creep, rest, late_creep, late_rest] {
                assert!(p.frames > 2000, "{p:?}");
                assert!(p.location_mm <= 0.3, "{p:?}");
                assert!(p.location_mm < 0.25 * p.centroid_mm, "{p:?}");
                assert!(p.force_within * 100 >= 98 * p.frames, "{p:?}");
                assert!(p.points * 100 >= 99 * p.frames, "{p:?}");
            }
            assert!(two * 100 >= 95 * n2 && line * 100 >= 95 * nl);
        }
    }

    /// A scanner started over on a finger that has crept for minutes reads the creep its
    /// elements have still to recover (N₁/α ≈ 1 000 s) as load: the force high by grams.
    #[test]
    fn a_scanner_started_over_on_a_crept_finger_reads_its_creep_as_load() {
        let mut finger =
            Calibrated::new(6, SpatialLaw::MEMO_HALF_SPACE, TaxelCalibration::Exact).unwrap();
        let (_, rest) = single_contacts(&mut finger, 120, 106).unwrap();
        finger.restart_scanner().unwrap();
        let (_, restarted) = single_contacts(&mut finger, 20, 107).unwrap();
        eprintln!("running on {rest:?}\nstarted over {restarted:?}");
        assert!(rest.force_bias_g.abs() < 0.2, "{rest:?}");
        assert!(restarted.force_bias_g > 1.0, "{restarted:?}");
    }

    /// The finger's strain read as strain, not stress (a field the locator's model does not
    /// hold): said with the figures, asserted loosely (the array's calibration takes up part
    /// of it as a shallower layer).
    #[test]
    fn a_field_the_model_does_not_hold_is_located_within_a_millimetre() {
        let law = SpatialLaw::Strain {
            depth_mm: 4.0,
            pitch_mm: 4.0,
            poisson: 0.5,
        };
        let mut finger = Calibrated::new(5, law, TaxelCalibration::Exact).unwrap();
        let (creep, rest) = single_contacts(&mut finger, 30, 105).unwrap();
        eprintln!(
            "read as strain: calibrated to depth {:.3} mm, plate {:.3} mm\n  creep {creep:?}\n  \
             rest {rest:?}",
            finger.response.depth_mm, finger.response.plate_mm
        );
        assert!(creep.location_mm < 1.0 && rest.location_mm < 1.0);
    }
}
