//! The array's spatial calibration and its records: presses at known positions fitted for the
//! spatial response the chip's locator runs (pitch, depth, each taxel's gain), the presses the
//! simulated finger gives on a stage, and the chip's code over a frames record
//! (`tactile calibrate --array`, `tactile locate`).
//!
//! The protocol (docs/design.md): the probe on a positioning stage presses on a grid over the
//! array at about half the nominal pitch, each press held 1 s at a known force and lifted
//! 0.5 s; the frames record carries the stage's position and the probe's force.

use std::path::Path;

use tactile_core::contact::{ContactKind, Locator, LocatorConfig, SpatialResponse};
use tactile_core::estimator::TaxelModel;
use tactile_core::tactile::{StrainGrid, TaxelCalibration, TaxelId, COLS, ROWS, TAXELS};
use tactile_core::tasks::{ArrayEstimate, FirmwareConfig, Scanner};
use tactile_core::viscoelastic::NonlinearMkState;
use tactile_plant::finger::{Finger, NOMINAL_TAXEL};
use tactile_plant::spatial::SpatialLaw;
use tactile_record::{FramesRecord, Truth};

use crate::Error;

/// One press at rest: each taxel's force estimate and where and how hard the probe pressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Press {
    pub forces_g: [f32; TAXELS],
    pub truth: Truth,
}

/// A fitted spatial response and how well it explains the presses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrayFit {
    pub response: SpatialResponse,
    /// RMS of each taxel's estimate about the fitted response, grams.
    pub rms_g: f64,
    pub presses: usize,
}

/// Pitch and depth searched, mm: a fingertip's array (the memo's is 4 and 4).
const PITCH_RANGE_MM: (f64, f64) = (1.5, 12.0);
const DEPTH_RANGE_MM: (f64, f64) = (0.5, 12.0);
/// The plate's side as a share of the pitch: from a sliver to touching plates.
const PLATE_SHARE_RANGE: (f64, f64) = (0.2, 1.0);

/// Each taxel's least-squares gain at one geometry, and the fit's sum of squares: the gains are
/// linear given the geometry, so only pitch and depth are searched.
fn gains_and_cost(
    presses: &[Press],
    [pitch_mm, depth_mm, plate_mm]: [f64; 3],
) -> ([f32; TAXELS], f64) {
    let r = SpatialResponse {
        pitch_mm: pitch_mm as f32,
        depth_mm: depth_mm as f32,
        plate_mm: plate_mm as f32,
        gain: [1.0; TAXELS],
    };
    let Some(shares) = r.shares() else {
        return ([1.0; TAXELS], f64::INFINITY);
    };
    let (mut fm, mut mm, mut ff) = ([0.0f64; TAXELS], [0.0f64; TAXELS], [0.0f64; TAXELS]);
    for p in presses {
        for i in 0..TAXELS {
            let (cx, cy) = r.centre_mm(TaxelId::from_index(i));
            let w = shares.weight(cx - p.truth.x_mm as f32, cy - p.truth.y_mm as f32);
            let m = p.truth.force_g * f64::from(w);
            let f = f64::from(p.forces_g[i]);
            if f.is_finite() {
                fm[i] += f * m;
                mm[i] += m * m;
                ff[i] += f * f;
            }
        }
    }
    let mut gains = [1.0f32; TAXELS];
    let mut cost = 0.0;
    for i in 0..TAXELS {
        // A taxel the presses hardly loaded keeps the nominal gain.
        let g = if mm[i] > 1.0 { fm[i] / mm[i] } else { 1.0 };
        let g = g.clamp(0.25, 4.0);
        gains[i] = g as f32;
        cost += ff[i] - 2.0 * g * fm[i] + g * g * mm[i];
    }
    (gains, cost)
}

/// Golden-section search of `f` over [lo, hi] (a unimodal valley), to `tol`.
fn golden(mut lo: f64, mut hi: f64, tol: f64, f: impl Fn(f64) -> f64) -> f64 {
    const INV_PHI: f64 = 0.618_033_988_749_895;
    let (mut a, mut b) = (hi - INV_PHI * (hi - lo), lo + INV_PHI * (hi - lo));
    let (mut fa, mut fb) = (f(a), f(b));
    while hi - lo > tol {
        if fa < fb {
            hi = b;
            (b, fb) = (a, fa);
            a = hi - INV_PHI * (hi - lo);
            fa = f(a);
        } else {
            lo = a;
            (a, fa) = (b, fb);
            b = lo + INV_PHI * (hi - lo);
            fb = f(b);
        }
    }
    0.5 * (lo + hi)
}

/// The spatial response that best explains the presses: pitch and depth by a coarse grid (the
/// memo's plate), then golden sections along pitch, depth and plate in turn, each taxel's gain
/// in closed form.
pub fn fit_response(presses: &[Press]) -> Result<ArrayFit, Error> {
    if presses.len() < 9 {
        return Err(Error::Failed(format!(
            "{} presses: the array's calibration needs at least 9 at known positions",
            presses.len()
        )));
    }
    let cost = |p: f64, d: f64, w: f64| gains_and_cost(presses, [p, d, w]).1;
    let memo_plate = f64::from(SpatialResponse::MEMO.plate_mm);
    let (mut pitch, mut depth, mut best) = (4.0, 4.0, f64::INFINITY);
    for i in 0..=21 {
        let p = PITCH_RANGE_MM.0 + (PITCH_RANGE_MM.1 - PITCH_RANGE_MM.0) * i as f64 / 21.0;
        for j in 0..=23 {
            let d = DEPTH_RANGE_MM.0 + (DEPTH_RANGE_MM.1 - DEPTH_RANGE_MM.0) * j as f64 / 23.0;
            let c = cost(p, d, memo_plate.min(p));
            if c < best {
                (pitch, depth, best) = (p, d, c);
            }
        }
    }
    let mut plate = memo_plate.min(pitch);
    for _ in 0..6 {
        pitch = golden(pitch - 0.5, pitch + 0.5, 1e-4, |p| {
            cost(p, depth, plate.min(p))
        });
        depth = golden(depth - 1.0, depth + 1.0, 1e-4, |d| {
            cost(pitch, d.max(0.1), plate)
        });
        let (lo, hi) = (PLATE_SHARE_RANGE.0 * pitch, PLATE_SHARE_RANGE.1 * pitch);
        plate = golden(lo, hi, 1e-4, |w| cost(pitch, depth, w));
    }
    let (gain, sum) = gains_and_cost(presses, [pitch, depth, plate]);
    let response = SpatialResponse {
        pitch_mm: pitch as f32,
        depth_mm: depth as f32,
        plate_mm: plate as f32,
        gain,
    };
    response
        .check()
        .map_err(|e| Error::Failed(format!("the fitted response is refused: {e}")))?;
    Ok(ArrayFit {
        response,
        rms_g: (sum.max(0.0) / (presses.len() * TAXELS) as f64).sqrt(),
        presses: presses.len(),
    })
}

/// The press grid of the protocol over an array of `pitch_mm`: `n` × `n` positions spanning
/// the outer taxels' centres.
pub fn press_grid(pitch_mm: f64, n: usize) -> Vec<(f64, f64)> {
    let span = (COLS - 1) as f64 * pitch_mm;
    let step = span / (n.max(2) - 1) as f64;
    (0..n * n)
        .map(|k| ((k % n) as f64 * step, (k / n) as f64 * step))
        .collect()
}

/// Frame period of the scan, s.
fn frame_s() -> f64 {
    f64::from(FirmwareConfig::MEMO.scan.frame_period_s())
}

/// A frames record of the protocol on the simulated finger with spatial law `law`: at each of
/// `positions` a press of `force_g` held 1 s then lifted 0.5 s (see [`simulated_frames`]).
pub fn simulated_presses(
    law: SpatialLaw,
    positions: &[(f64, f64)],
    force_g: f64,
    gain_spread: f64,
    seed: u64,
) -> (Vec<(f64, StrainGrid)>, Vec<Truth>) {
    let frame = frame_s();
    let (hold, lift) = (
        (1.0 / frame).round() as usize,
        (0.5 / frame).round() as usize,
    );
    let schedule = positions.iter().flat_map(|&(x, y)| {
        (0..hold + lift).map(move |k| Truth {
            x_mm: x,
            y_mm: y,
            force_g: if k < hold { force_g } else { 0.0 },
        })
    });
    simulated_frames(law, schedule, gain_spread, seed)
}

/// Frames of the simulated finger with spatial law `law` under the probe's `schedule` (one
/// position and force a frame): each taxel's strain through the nominal element's dynamics
/// (creep and recovery) under its share of the load, a static gain error of up to
/// ±`gain_spread` per taxel.
pub fn simulated_frames(
    law: SpatialLaw,
    schedule: impl IntoIterator<Item = Truth>,
    gain_spread: f64,
    seed: u64,
) -> (Vec<(f64, StrainGrid)>, Vec<Truth>) {
    let mut finger = Finger::memo(seed);
    let mut noise = tactile_plant::noise::Noise::new(seed);
    let gain: [f64; TAXELS] =
        core::array::from_fn(|_| 1.0 + gain_spread * (2.0 * noise.uniform() - 1.0));
    let element = TaxelModel::nominal(NOMINAL_TAXEL).element;
    let mut state = [NonlinearMkState::default(); TAXELS];
    let (dt, frame) = (1e-3, frame_s());
    let per_frame = (frame / dt).round() as usize;
    let (mut frames, mut truth) = (Vec::new(), Vec::new());
    let mut t = 0.0;
    for probe in schedule {
        finger.press_at(law, probe.x_mm, probe.y_mm);
        let mut grid = [[0.0f32; COLS]; ROWS];
        for (i, cell) in grid.iter_mut().flatten().enumerate() {
            let load = probe.force_g * finger.load_share(i) * gain[i];
            for _ in 0..per_frame {
                element.step(&mut state[i], load, dt);
            }
            *cell = element.strain_pct(&state[i], load) as f32;
        }
        t += frame;
        frames.push((t, grid));
        truth.push(probe);
    }
    (frames, truth)
}

/// The chip's scanner for strains given as such (its read-out calibration is never used), its
/// taxels' estimators from the calibration table `table` (empty: the nominal models).
pub fn scanner(config: &FirmwareConfig, table: &[u8]) -> Result<Scanner, Error> {
    let rest = [TaxelCalibration {
        amplifier: tactile_core::tactile::ReadoutAmplifier::MEMO_ELEMENT_4_2,
        rest_output_v: 0.0,
        gain: 1.0,
    }; TAXELS];
    let refused = |e| Error::Failed(format!("the scanner's configuration was refused: {e}"));
    let mut scanner = Scanner::new(config, rest).map_err(refused)?;
    if !table.is_empty() {
        scanner
            .reset_with_table(config, rest, table)
            .map_err(refused)?;
        if let Some(e) = scanner.calibration_status().refused {
            return Err(Error::Failed(format!(
                "the calibration table was refused: {e}"
            )));
        }
    }
    Ok(scanner)
}

/// The chip's scan over a frames record: each row's strains through every taxel's estimator
/// (the firmware's code at the frame rate, `config`'s calibration), then the locator.
pub fn chip_estimates(
    rec: &FramesRecord,
    config: &FirmwareConfig,
) -> Result<Vec<ArrayEstimate>, Error> {
    Ok(chip_frames(rec, config)?
        .into_iter()
        .map(|(e, _)| e)
        .collect())
}

/// [`chip_estimates`] with each frame's per-taxel force estimates (grams).
pub fn chip_frames(
    rec: &FramesRecord,
    config: &FirmwareConfig,
) -> Result<Vec<(ArrayEstimate, StrainGrid)>, Error> {
    chip_frames_calibrated(rec, config, config.calibration)
}

/// [`chip_frames`] with each taxel's estimator from the calibration table `table` (a table
/// read from a file, which a configuration's `'static` one cannot be).
pub fn chip_frames_calibrated(
    rec: &FramesRecord,
    config: &FirmwareConfig,
    table: &[u8],
) -> Result<Vec<(ArrayEstimate, StrainGrid)>, Error> {
    let mut scanner = scanner(config, table)?;
    Ok(rec
        .strain_pct
        .iter()
        .enumerate()
        .map(|(k, grid)| {
            let e = scanner.step_strains(grid, k as u32).estimate;
            (e, *scanner.forces_g())
        })
        .collect())
}

/// The presses of a calibration record: each run of rows at one position with a force, the
/// per-taxel estimates averaged over its second half (the press at rest).
pub fn presses_from_record(
    rec: &FramesRecord,
    path: &Path,
    config: &FirmwareConfig,
) -> Result<Vec<Press>, Error> {
    presses_calibrated(rec, path, config, config.calibration)
}

/// [`presses_from_record`] with each taxel's estimator from the calibration table `table`.
pub fn presses_calibrated(
    rec: &FramesRecord,
    path: &Path,
    config: &FirmwareConfig,
    table: &[u8],
) -> Result<Vec<Press>, Error> {
    let config = FirmwareConfig {
        locator: LocatorConfig::MEMO,
        ..*config
    };
    presses_scanned(rec, path, &mut scanner(&config, table)?)
}

/// [`presses_from_record`] through a scanner that is running already (its estimators' state
/// the finger's history).
pub fn presses_scanned(
    rec: &FramesRecord,
    path: &Path,
    scanner: &mut Scanner,
) -> Result<Vec<Press>, Error> {
    if rec.truth.iter().all(Option::is_none) {
        return Err(Error::Usage(format!(
            "{}: no x_mm,y_mm,force_g: a calibration record carries the probe's position and force",
            path.display()
        )));
    }
    let mut runs: Vec<(Truth, Vec<[f32; TAXELS]>)> = Vec::new();
    for (k, (grid, truth)) in rec.strain_pct.iter().zip(&rec.truth).enumerate() {
        scanner.step_strains(grid, k as u32);
        let Some(truth) = truth.filter(|t| t.force_g > 0.0) else {
            continue;
        };
        let mut forces = [f32::NAN; TAXELS];
        for (slot, f) in forces.iter_mut().zip(scanner.forces_g().iter().flatten()) {
            *slot = *f;
        }
        // A press continues while the row before pressed at the same place.
        let pressing_before = k
            .checked_sub(1)
            .and_then(|j| rec.truth.get(j).copied().flatten())
            .is_some_and(|b| b.force_g > 0.0 && b.x_mm == truth.x_mm && b.y_mm == truth.y_mm);
        match runs.last_mut() {
            Some((last, rows)) if pressing_before => {
                *last = truth;
                rows.push(forces);
            }
            _ => runs.push((truth, vec![forces])),
        }
    }
    Ok(runs
        .into_iter()
        .filter(|(_, rows)| rows.len() >= 2)
        .map(|(truth, rows)| {
            let half = &rows[rows.len() / 2..];
            let forces_g = core::array::from_fn(|i| {
                half.iter().map(|r| r[i]).sum::<f32>() / half.len() as f32
            });
            Press { forces_g, truth }
        })
        .collect())
}

/// Location and force errors of the chip's estimates against a record's truth, beside the
/// centroid's: (frames scored, location RMS mm, centroid RMS mm, force RMS g, frames said one
/// point).
pub fn scored(
    estimates: &[ArrayEstimate],
    truth: &[Option<Truth>],
    pitch_mm: f32,
) -> (usize, f64, f64, f64, usize) {
    let (mut n, mut fit, mut centroid, mut force, mut points) = (0, 0.0, 0.0, 0.0, 0);
    for (e, t) in estimates.iter().zip(truth) {
        let Some(t) = t.filter(|t| t.force_g > 0.0) else {
            continue;
        };
        n += 1;
        let sq = |x: f64, y: f64| (x - t.x_mm).powi(2) + (y - t.y_mm).powi(2);
        fit += sq(f64::from(e.contact_x_mm), f64::from(e.contact_y_mm));
        let (cx, cy) = (e.centroid_col * pitch_mm, e.centroid_row * pitch_mm);
        centroid += if cx.is_finite() {
            sq(f64::from(cx), f64::from(cy))
        } else {
            sq(0.0, 0.0)
        };
        force += (f64::from(e.total_force_g) - t.force_g).powi(2);
        points += usize::from(e.contact == ContactKind::Point);
    }
    let rms = |s: f64| {
        if n > 0 {
            (s / n as f64).sqrt()
        } else {
            f64::NAN
        }
    };
    (n, rms(fit), rms(centroid), rms(force), points)
}

/// The locator of a fitted response (the memo's thresholds).
pub fn locator_of(response: SpatialResponse) -> Locator {
    Locator::new(LocatorConfig {
        response,
        ..LocatorConfig::MEMO
    })
}

/// A calibration table read from `path` (none: empty, each taxel's nominal models), checked
/// when a scanner is built on it.
fn calibration_bytes(path: Option<&Path>) -> Result<Vec<u8>, Error> {
    path.map_or(Ok(Vec::new()), |p| std::fs::read(p).map_err(Error::io(p)))
}

/// `tactile calibrate --array FRAMES.csv… [--calibration T.bin] --out A.bin`: the presses of
/// every record through each taxel's estimator (from the calibration table `calibration`, or
/// the nominal models), the fitted response sealed into `out`; the summary.
pub fn calibrate_command(
    records: &[std::path::PathBuf],
    calibration: Option<&Path>,
    out: &Path,
) -> Result<String, Error> {
    let mut inputs: Vec<&Path> = records.iter().map(|p| p.as_path()).collect();
    inputs.extend(calibration);
    let table_out = crate::output::Output::claim(out, &inputs)?;
    let cal = calibration_bytes(calibration)?;
    let mut presses = Vec::new();
    for path in records {
        let rec = tactile_record::read_frames(path)?;
        let found = presses_calibrated(&rec, path, &FirmwareConfig::MEMO, &cal)?;
        if found.is_empty() {
            return Err(Error::Failed(format!(
                "{}: no press held for two frames at one position",
                path.display()
            )));
        }
        presses.extend(found);
    }
    let fit = fit_response(&presses)?;
    let r = fit.response;
    let (lo, hi) = r.gain.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), g| {
        (lo.min(*g), hi.max(*g))
    });
    let written = table_out.write(r.encode())?;
    Ok(format!(
        "{} presses from {} record(s): pitch {:.3} mm, depth {:.3} mm, plate {:.3} mm, taxel \
         gains {lo:.3}–{hi:.3}; the taxels' estimates about it {:.3} g RMS\nwrote {}",
        fit.presses,
        records.len(),
        r.pitch_mm,
        r.depth_mm,
        r.plate_mm,
        fit.rms_g,
        written.display()
    ))
}

/// `tactile locate FRAMES.csv --table A.bin [--calibration T.bin] [--out OUT.csv]`: the
/// chip's scan (each taxel's estimator from the calibration table `calibration`, or the
/// nominal models; then the locator on the array table's response) over a frames record; the
/// errors against the truth where the record has it, the centroid's beside them.
pub fn locate_command(
    file: &Path,
    table: &Path,
    calibration: Option<&Path>,
    out: Option<&Path>,
) -> Result<String, Error> {
    let mut inputs = vec![file, table];
    inputs.extend(calibration);
    let out = crate::output::Output::claim_some(out, &inputs)?;
    let cal = calibration_bytes(calibration)?;
    let bytes = std::fs::read(table).map_err(Error::io(table))?;
    let response = SpatialResponse::decode(&bytes)
        .map_err(|e| Error::Failed(format!("{}: {e}", table.display())))?;
    let rec = tactile_record::read_frames(file)?;
    let config = FirmwareConfig {
        locator: LocatorConfig {
            response,
            ..LocatorConfig::MEMO
        },
        ..FirmwareConfig::MEMO
    };
    let estimates: Vec<ArrayEstimate> = chip_frames_calibrated(&rec, &config, &cal)?
        .into_iter()
        .map(|(e, _)| e)
        .collect();
    let mut text = format!(
        "{}: {} frames; pitch {:.3} mm, depth {:.3} mm from {}\n",
        file.display(),
        estimates.len(),
        response.pitch_mm,
        response.depth_mm,
        table.display()
    );
    let (n, fit_mm, centroid_mm, force_g, points) =
        scored(&estimates, &rec.truth, response.pitch_mm);
    if n == 0 {
        text += "no frame carries the truth (x_mm,y_mm,force_g with a force): nothing to score\n";
    } else {
        text += &format!(
            "{n} frames pressed, the truth beside them:\n\
             | | location RMS (mm) | force RMS (g) | said one point |\n\
             | --- | --- | --- | --- |\n\
             | the chip's locator | {fit_mm:.3} | {force_g:.2} | {points} of {n} |\n\
             | the centroid | {centroid_mm:.3} | | |\n"
        );
    }
    if let Some(out) = out {
        let mut csv = String::from("t_s,contact,x_mm,y_mm,force_g,centroid_x_mm,centroid_y_mm\n");
        for (k, e) in estimates.iter().enumerate() {
            let t = rec.t_s.get(k).copied().unwrap_or(f64::NAN);
            csv += &format!(
                "{t:.4},{},{:.4},{:.4},{:.3},{:.4},{:.4}\n",
                e.contact.name(),
                e.contact_x_mm,
                e.contact_y_mm,
                e.total_force_g,
                e.centroid_col * response.pitch_mm,
                e.centroid_row * response.pitch_mm
            );
        }
        text += &format!("wrote {}\n", out.write(csv)?.display());
    }
    Ok(text)
}

/// The demo's moving press: 40 g on the memo finger's half-space (taxel gains ±2 %) circling
/// the array's centre at 1.75 pitches, one turn in 5 s, located by the chip's code each frame;
/// the heat map `array_track.png` in `out` and the report's section.
pub fn moving_press_demo(out: &Path) -> Result<String, Error> {
    let law = SpatialLaw::MEMO_HALF_SPACE;
    let pitch = f64::from(SpatialResponse::MEMO.pitch_mm);
    let (centre, radius) = (3.5 * pitch, 1.75 * pitch);
    let n = (6.0 / frame_s()).round() as usize;
    let schedule = (0..n).map(|k| {
        let phase = 2.0 * std::f64::consts::PI * k as f64 * frame_s() / 5.0;
        Truth {
            x_mm: centre + radius * phase.cos(),
            y_mm: centre + radius * phase.sin(),
            force_g: 40.0,
        }
    });
    let (frames, truth) = simulated_frames(law, schedule, 0.02, 11);
    let rec = FramesRecord {
        t_s: frames.iter().map(|(t, _)| *t).collect(),
        strain_pct: frames.iter().map(|(_, g)| *g).collect(),
        truth: truth.iter().copied().map(Some).collect(),
        ..FramesRecord::default()
    };
    let chip = chip_frames(&rec, &FirmwareConfig::MEMO)?;
    let pitch_f = SpatialResponse::MEMO.pitch_mm;
    let centroid = |e: &ArrayEstimate| {
        (
            f64::from(e.centroid_col * pitch_f),
            f64::from(e.centroid_row * pitch_f),
        )
    };
    let snapshots: Vec<crate::plot::ArraySnapshot> = [1, 3, 5, 7]
        .iter()
        .filter_map(|q| {
            let k = q * n / 8;
            let ((e, forces), t) = (chip.get(k)?, truth.get(k)?);
            Some(crate::plot::ArraySnapshot {
                t_s: rec.t_s.get(k).copied().unwrap_or(0.0),
                forces_g: *forces,
                truth_mm: (t.x_mm, t.y_mm),
                located_mm: (e.contact != ContactKind::Nothing)
                    .then_some((f64::from(e.contact_x_mm), f64::from(e.contact_y_mm))),
                centroid_mm: Some(centroid(e)).filter(|c| c.0.is_finite()),
            })
        })
        .collect();
    let track: Vec<(f64, [f64; 6])> = chip
        .iter()
        .zip(&truth)
        .zip(&rec.t_s)
        .map(|(((e, _), t), time)| {
            let (cx, cy) = centroid(e);
            let (x, y) = (f64::from(e.contact_x_mm), f64::from(e.contact_y_mm));
            (*time, [t.x_mm, t.y_mm, x, y, cx, cy])
        })
        .collect();
    let png = out.join("array_track.png");
    crate::plot::plot_array_track(&png, pitch, &snapshots, &track)
        .map_err(|e| Error::Failed(format!("{}: {e}", png.display())))?;
    let estimates: Vec<ArrayEstimate> = chip.iter().map(|(e, _)| *e).collect();
    let (n, fit_mm, centroid_mm, force_g, points) = scored(&estimates, &rec.truth, pitch_f);
    Ok(format!(
        "A 40 g press circling the array's centre (radius 7 mm, a turn in 5 s) on the memo finger's \
         half-space, taxel gains ±2 %, each taxel's strain through its element's creep, located \
         each frame by the chip's code (each taxel's observer, then the locator): over {n} \
         frames, location RMS {fit_mm:.3} mm (the centroid {centroid_mm:.3} mm), force RMS \
         {force_g:.2} g, one point in {points}. `array_track.png`: the array at four instants \
         (true contact a ring, located a cross, centroid a square) and the track.\n\n\
         ![array](array_track.png)\n"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tactile_plant::noise::Noise;

    /// A finger of another size and skin (5 mm pitch, 3 mm of rubber over the plates, taxel
    /// gains spread ±2 %) calibrated through a frames record of the protocol as the chip
    /// estimates each taxel (creep included): its geometry within a few percent, and then
    /// presses anywhere at least half a pitch inside located to 0.3 mm.
    #[test]
    fn a_finger_of_another_geometry_calibrates_and_then_locates() {
        let (pitch, depth) = (5.0, 3.0);
        let law = SpatialLaw::HalfSpace {
            depth_mm: depth,
            pitch_mm: pitch,
        };
        let (frames, truth) = simulated_presses(law, &press_grid(pitch, 9), 50.0, 0.02, 5);
        let dir = std::env::temp_dir().join(format!("array-cal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("presses.csv");
        tactile_record::write_frames_with_truth(&path, &[], &frames, &truth).unwrap();
        let rec = tactile_record::read_frames(&path).unwrap();
        let presses = presses_from_record(&rec, &path, &FirmwareConfig::MEMO).unwrap();
        assert_eq!(presses.len(), 81);
        let fit = fit_response(&presses).unwrap();
        let r = fit.response;
        eprintln!(
            "calibrated: pitch {:.3} mm (true {pitch}), depth {:.3} mm (true {depth}), plate \
             {:.3} mm (true 3.571), RMS {:.3} g",
            r.pitch_mm, r.depth_mm, r.plate_mm, fit.rms_g
        );
        assert!((f64::from(r.pitch_mm) / pitch - 1.0).abs() < 0.02, "{r:?}");
        assert!((f64::from(r.depth_mm) / depth - 1.0).abs() < 0.03, "{r:?}");
        // The finger's plates are the memo's squares whatever its pitch.
        let plate = SpatialResponse::MEMO.plate_mm;
        assert!((r.plate_mm / plate - 1.0).abs() < 0.05, "{r:?}");
        // The fit itself, on the loads the taxels carried (no estimator between): the
        // geometry to a part in a thousand.
        let exact: Vec<Press> = presses
            .iter()
            .map(|p| {
                let shares = law.shares(NOMINAL_TAXEL, p.truth.x_mm, p.truth.y_mm);
                Press {
                    forces_g: core::array::from_fn(|i| (p.truth.force_g * shares[i]) as f32),
                    truth: p.truth,
                }
            })
            .collect();
        let e = fit_response(&exact).unwrap().response;
        eprintln!(
            "on the loads themselves: pitch {:.3} mm, depth {:.3} mm",
            e.pitch_mm, e.depth_mm
        );
        assert!((f64::from(e.pitch_mm) / pitch - 1.0).abs() < 1e-3, "{e:?}");
        assert!((f64::from(e.depth_mm) / depth - 1.0).abs() < 1e-3, "{e:?}");
        let bytes = r.encode();
        assert_eq!(SpatialResponse::decode(&bytes), Ok(r));

        // Presses elsewhere, 10–100 g, on the same finger, located by the chip's code with the
        // calibrated response.
        let mut noise = Noise::new(77);
        let positions: Vec<(f64, f64)> = (0..40)
            .map(|_| {
                let span = 6.0 * pitch;
                (
                    0.5 * pitch + span * noise.uniform(),
                    0.5 * pitch + span * noise.uniform(),
                )
            })
            .collect();
        let mut all = (Vec::new(), Vec::new());
        for (k, chunk) in positions.chunks(1).enumerate() {
            let force = 10.0 + 90.0 * noise.uniform();
            let (f, t) = simulated_presses(law, chunk, force, 0.02, 5 + k as u64);
            all.0.extend(f);
            all.1.extend(t.into_iter().map(Some));
        }
        let rec = FramesRecord {
            strain_pct: all.0.iter().map(|(_, g)| *g).collect(),
            truth: all.1,
            ..FramesRecord::default()
        };
        let config = FirmwareConfig {
            locator: LocatorConfig {
                response: r,
                ..LocatorConfig::MEMO
            },
            ..FirmwareConfig::MEMO
        };
        let estimates = chip_estimates(&rec, &config).unwrap();
        let (n, fit_mm, centroid_mm, force_g, points) = scored(&estimates, &rec.truth, r.pitch_mm);
        eprintln!(
            "located {n} frames: RMS {fit_mm:.3} mm (centroid {centroid_mm:.3} mm), force RMS \
             {force_g:.2} g, one point in {points}"
        );
        assert!(
            fit_mm <= 0.3 && fit_mm < 0.5 * centroid_mm,
            "{fit_mm} {centroid_mm}"
        );
        assert!(points * 10 >= n * 9, "{points} of {n}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The two commands end to end on the memo finger's presses: a table written and read
    /// back, the record located against its truth; malformed input named by file and line.
    #[test]
    fn calibrate_and_locate_commands_run_the_chips_code_and_name_bad_input() {
        let law = SpatialLaw::MEMO_HALF_SPACE;
        let dir = std::env::temp_dir().join(format!("array-cmd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (frames, truth) = simulated_presses(law, &press_grid(4.0, 8), 40.0, 0.0, 3);
        let presses = dir.join("presses.csv");
        tactile_record::write_frames_with_truth(&presses, &[], &frames, &truth).unwrap();
        let table = dir.join("array.bin");
        let text = calibrate_command(std::slice::from_ref(&presses), None, &table).unwrap();
        assert!(text.contains("64 presses"), "{text}");
        let r = SpatialResponse::decode(&std::fs::read(&table).unwrap()).unwrap();
        assert!(
            (r.pitch_mm - 4.0).abs() < 0.04 && (r.depth_mm - 4.0).abs() < 0.12,
            "{r:?}"
        );
        let out = dir.join("located.csv");
        let text = locate_command(&presses, &table, None, Some(&out)).unwrap();
        assert!(text.contains("| the centroid |"), "{text}");
        let rows = std::fs::read_to_string(&out).unwrap();
        assert_eq!(rows.lines().count(), frames.len() + 1);
        // A cell that is no number: the file and line, no panic.
        let text = std::fs::read_to_string(&presses).unwrap();
        let bad = dir.join("bad.csv");
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        lines[3] = lines[3].replacen(',', ",oops,", 1);
        std::fs::write(&bad, lines.join("\n")).unwrap();
        let e = locate_command(&bad, &table, None, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.csv:4"), "{e}");
        let e = locate_command(&presses, &presses, None, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("presses.csv") && e.contains("spatial table"),
            "{e}"
        );
        let e =
            calibrate_command(std::slice::from_ref(&bad), None, &dir.join("b.bin")).unwrap_err();
        assert!(e.to_string().contains("bad.csv:4"), "{e}");
        // A calibration table that is none: refused with why, no table written.
        let e = locate_command(&presses, &table, Some(&table), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("calibration table was refused"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The demo's moving press: its heat map is written and the chip's track is the press's
    /// to within 0.3 mm RMS while the centroid's is not.
    #[test]
    fn the_moving_press_is_tracked_and_drawn() {
        let dir = std::env::temp_dir().join(format!("array-demo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = moving_press_demo(&dir).unwrap();
        eprintln!("{text}");
        assert!(
            std::fs::metadata(dir.join("array_track.png"))
                .unwrap()
                .len()
                > 10_000
        );
        let rms = |key: &str| -> f64 {
            let at = text.find(key).unwrap() + key.len();
            text[at..]
                .split_whitespace()
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        let (fit, centroid) = (rms("location RMS "), rms("(the centroid "));
        assert!(fit <= 0.3 && centroid > 2.0 * fit, "{fit} {centroid}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
