//! The firmware's defmt stream → the project's records.
//!
//! The firmware logs the core library's frames through their `defmt::Format` derives
//! (`ControlFrame`, `TaxelFrame`) with board data riding along (`SimTruth` under QEMU,
//! `ArrayEstimate`), plus run markers (`RunStart`, `RunEnd`) and, under QEMU, the measured
//! `InstructionCounts`. The decoder reads the ELF's defmt table, splits the log at the rzCOBS
//! frame delimiters, and parses each message's text back into those types by struct and field
//! name, so a field the firmware stops sending is an error that names it.

use std::path::{Path, PathBuf};

use defmt_decoder::{DecodeError, Table};
use tactile_core::contact::ContactKind;
use tactile_core::estimator::EstimatorKind;
use tactile_core::tactile::{COLS, ROWS};
use tactile_core::telemetry::TickRecord;
use tactile_core::telemetry::{ControlFrame, FaultFlags, SequenceCheck, TaxelFrame};
use tactile_core::CONTROL_PERIOD_S;
use tactile_firmware::ArrayEstimate;

pub mod text;
pub mod transport;

use text::Fields;

/// What went wrong, and where: the file, and the defmt frame (0-based, counted from the start
/// of the log) when there is one.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}{}: {message}", .file.display(), .frame.map(|n| format!(": frame {n}")).unwrap_or_default())]
pub struct Error {
    pub file: PathBuf,
    pub frame: Option<usize>,
    pub message: String,
}

/// One control tick as decoded, with the simulator's truth when the log carries it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    pub frame: ControlFrame,
    pub true_force_g: Option<f32>,
    pub in_contact: Option<bool>,
}

/// One protocol run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Run {
    pub name: String,
    pub start_tick: u32,
    pub duration_s: f32,
    pub ticks: Vec<Tick>,
    pub frames: Vec<(TaxelFrame, Option<ArrayEstimate>)>,
    /// The firmware's own counts at the end of the run (since boot).
    pub end: Option<RunEnd>,
}

/// The `RunEnd` marker.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunEnd {
    pub end_tick: u32,
    pub control_frames_dropped: u32,
    pub taxel_frames_dropped: u32,
    pub overruns: u32,
}

/// A decoded log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Session {
    pub runs: Vec<Run>,
    /// Sequence checks over the whole log (numbers run on across runs).
    pub control_seq: SequenceCheck,
    pub taxel_seq: SequenceCheck,
    /// Control frames that arrived flagged `FRAMES_DROPPED`.
    pub flagged_drops: usize,
    /// Messages that are not frames (boot banner, instruction counts, errors), as text.
    pub notes: Vec<String>,
    /// Error-level messages from the firmware (a panic, a refused configuration).
    pub errors: Vec<String>,
    /// Bytes after the last complete frame (a log cut off mid-frame).
    pub trailing_bytes: usize,
    /// The board's answers to commands, in order: (sequence number, `None` when taken, or
    /// the reason it was refused as the board wrote it).
    pub replies: Vec<(u16, Option<String>)>,
    /// Frames of a run whose start the stream did not carry (a board joined mid-run,
    /// [`Live::joined`]), left out.
    pub before_first_run: usize,
}

impl Session {
    pub fn run(&self, name: &str) -> Option<&Run> {
        self.runs.iter().find(|r| r.name == name)
    }
}

/// Decodes `log` (raw defmt bytes, rzCOBS-framed as `defmt-semihosting` and `defmt-rtt`
/// write them) with the defmt table of `elf`. `log_path` and `elf_path` only name the sources
/// in errors.
pub fn decode(elf: &[u8], elf_path: &Path, log: &[u8], log_path: &Path) -> Result<Session, Error> {
    let table = table(elf, elf_path)?;
    let mut live = Live::new(&table, log_path);
    live.push(log)?;
    Ok(live.finish())
}

/// Follows a board's session over `transport` to the end of its stream, decoding as the bytes
/// arrive and calling `progress` with the decoder after each piece.
pub fn follow<'t>(
    transport: &mut dyn transport::Transport,
    mut live: Live<'t>,
    mut progress: impl FnMut(&Live<'t>),
) -> Result<Session, String> {
    while let Some(bytes) = transport.receive().map_err(|e| e.to_string())? {
        if !bytes.is_empty() {
            live.push(&bytes).map_err(|e| e.to_string())?;
            progress(&live);
        }
    }
    Ok(live.finish())
}

/// How long the board must have sent nothing before [`drive`] ends a session (a run streams
/// a control frame every millisecond; the frames of its last scan follow its end).
pub const QUIET: std::time::Duration = std::time::Duration::from_millis(100);

/// How [`drive`] ends a live board's session.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Until {
    /// Once every command is answered, no run is in progress and nothing has arrived for
    /// [`QUIET`], this long after the last command was sent (the length of what it asked
    /// for).
    pub settle: std::time::Duration,
    /// At the latest this long after the last command was sent: the session as it is if
    /// every command was answered (a run still going is cut off), else an error (a board
    /// that stopped answering).
    pub timeout: std::time::Duration,
}

/// Drives a live board over `transport`: sends each entry of `script` when the host's clock
/// reaches its tick (milliseconds from the start), decodes what arrives, and returns the
/// session once it ends ([`Until`]); an error if the board stopped answering.
pub fn drive<'t>(
    transport: &mut dyn transport::Transport,
    script: &[(u32, Vec<u8>)],
    mut live: Live<'t>,
    until: Until,
    mut progress: impl FnMut(&Live<'t>),
) -> Result<Session, String> {
    use std::time::{Duration, Instant};
    let commands = command_count(script);
    let start = Instant::now();
    let mut next = 0;
    let mut last_sent = start;
    let mut last_heard = start;
    loop {
        while let Some((tick, bytes)) = script.get(next) {
            if start.elapsed() < Duration::from_millis(u64::from(*tick)) {
                break;
            }
            transport.send(bytes).map_err(|e| e.to_string())?;
            last_sent = Instant::now();
            next += 1;
        }
        match transport.receive().map_err(|e| e.to_string())? {
            Some(bytes) if !bytes.is_empty() => {
                live.push(&bytes).map_err(|e| e.to_string())?;
                last_heard = Instant::now();
                progress(&live);
            }
            Some(_) => {}
            None => break,
        }
        if next < script.len() {
            continue;
        }
        let answered = live.session.replies.len() >= commands;
        let since = last_sent.elapsed();
        // NOTE: not while bytes still arrive: the frames of a run's last scan follow its end,
        // and a session replayed faster than the settle on a loaded machine ended at the
        // run's end without them.
        if answered && !live.running() && since >= until.settle && last_heard.elapsed() >= QUIET {
            break;
        }
        if since >= until.timeout {
            if answered {
                // What the board streamed until now (a run cut off included).
                break;
            }
            return Err(format!(
                "the board answered {} of {commands} commands and {} after {:.0} s",
                live.session.replies.len(),
                if live.running() {
                    "is still running"
                } else {
                    "runs nothing"
                },
                since.as_secs_f64()
            ));
        }
    }
    Ok(live.finish())
}

/// The command frames in a script.
fn command_count(script: &[(u32, Vec<u8>)]) -> usize {
    let mut decoder = tactile_core::command::Decoder::new();
    let mut n = 0;
    for (_, bytes) in script {
        let mut bytes = &bytes[..];
        while decoder.read(&mut bytes).is_some() {
            n += 1;
        }
    }
    n
}

/// The defmt table of a firmware ELF (`elf_path` only names it in errors).
pub fn table(elf: &[u8], elf_path: &Path) -> Result<Table, Error> {
    let elf_err = |message: String| Error {
        file: elf_path.to_path_buf(),
        frame: None,
        message,
    };
    Table::parse(elf)
        .map_err(|e| elf_err(format!("not a firmware ELF with a defmt table: {e}")))?
        .ok_or_else(|| elf_err("the ELF has no .defmt section".into()))
}

/// A defmt stream decoded as it arrives (a board's RTT up-channel, QEMU's output): bytes in
/// with [`Live::push`] in any pieces, the run in progress in [`Live::current`] (with
/// [`Live::progress`] and [`Live::summary`]), the whole session from [`Live::finish`]. [`decode`] is one push of a whole log.
pub struct Live<'t> {
    stream: Box<dyn defmt_decoder::StreamDecoder + 't>,
    source: PathBuf,
    session: Session,
    builder: Builder,
    index: usize,
    pending: Vec<u8>,
}

impl<'t> Live<'t> {
    /// A decoder of the stream `source` names (in errors) with the defmt table `table`.
    pub fn new(table: &'t Table, source: &Path) -> Live<'t> {
        Live {
            stream: table.new_stream_decoder(),
            source: source.to_path_buf(),
            session: Session::default(),
            builder: Builder::default(),
            index: 0,
            pending: Vec::new(),
        }
    }

    /// A decoder of a stream joined while the board runs (a probe attached to a running
    /// board): what belongs to a run begun before is counted and left out
    /// ([`Session::before_first_run`]); the stream should start at a frame boundary.
    pub fn joined(table: &'t Table, source: &Path) -> Live<'t> {
        let mut live = Live::new(table, source);
        live.builder.joined = true;
        live
    }

    /// Takes the next bytes of the stream and decodes the frames they complete.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), Error> {
        self.pending.extend_from_slice(bytes);
        let mut used = 0;
        // rzCOBS frames end in 0x00; a frame body never contains one.
        while let Some(end) = self.pending[used..].iter().position(|&b| b == 0) {
            let body = &self.pending[used..used + end + 1];
            used += end + 1;
            if body.len() == 1 {
                continue; // a run of delimiters
            }
            let at = |message: String| Error {
                file: self.source.clone(),
                frame: Some(self.index),
                message,
            };
            self.stream.received(body);
            let text = match self.stream.decode() {
                Ok(frame) => {
                    let level = frame.level();
                    // The decoder's formatting unwraps on format strings it cannot parse (only a
                    // damaged ELF has those): contain it and report the frame.
                    let text = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        frame.display_message().to_string()
                    }))
                    .map_err(|_| {
                        at("the ELF's format string for this frame does not parse".into())
                    })?;
                    if matches!(level, Some(defmt_parser::Level::Error)) {
                        self.session.errors.push(text.clone());
                    }
                    text
                }
                Err(DecodeError::Malformed) => {
                    return Err(at(
                        "malformed defmt frame (corrupt log, or a log from another ELF)".into(),
                    ))
                }
                Err(DecodeError::UnexpectedEof) => {
                    return Err(at("defmt frame ends early".into()));
                }
            };
            self.builder
                .message(&text, &mut self.session)
                .map_err(|m| at(format!("{m} in: {}", shorten(&text))))?;
            self.index += 1;
        }
        self.pending.drain(..used);
        Ok(())
    }

    /// The run in progress, if any.
    pub fn current(&self) -> Option<&Run> {
        self.builder.current.as_ref()
    }

    /// Whether a run has started and not ended.
    pub fn running(&self) -> bool {
        self.current().is_some_and(|r| r.end.is_none())
    }

    /// The run in progress and the share of it done (by its ticks and its length).
    pub fn progress(&self) -> Option<(&str, f64)> {
        let run = self.current()?;
        let last = run.ticks.last().map_or(run.start_tick, |t| t.frame.tick);
        let done_s = f64::from(last.wrapping_sub(run.start_tick)) * CONTROL_PERIOD_S;
        Some((
            &run.name,
            (done_s / f64::from(run.duration_s).max(CONTROL_PERIOD_S)).clamp(0.0, 1.0),
        ))
    }

    /// One line on the latest control tick: force, its error from the command, faults, and
    /// frames lost (missing from the stream, or dropped on the board).
    pub fn summary(&self) -> String {
        let lost = self.session.control_seq.missing() as usize + self.session.flagged_drops;
        match self.current().and_then(|r| r.ticks.last()) {
            Some(t) => {
                let f = &t.frame;
                let faults: Vec<&str> = f.faults.names().collect();
                format!(
                    "force {:6.2} g  error {:+6.2} g  faults {}  lost {lost}",
                    f.sensed_g,
                    f.sensed_g - f.command_g,
                    if faults.is_empty() {
                        "none".to_string()
                    } else {
                        faults.join(",")
                    }
                )
            }
            None => format!("no run in progress  lost {lost}"),
        }
    }

    /// The whole session (a run the stream cut off included).
    pub fn finish(mut self) -> Session {
        self.session.trailing_bytes = self.pending.len();
        self.builder.finish(&mut self.session);
        self.session
    }
}

fn shorten(text: &str) -> String {
    const MAX: usize = 160;
    if text.len() <= MAX {
        text.to_string()
    } else {
        let mut end = MAX;
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        format!("{}…", &text[..end])
    }
}

/// Puts decoded messages into runs.
#[derive(Default)]
struct Builder {
    current: Option<Run>,
    /// Frames before the first `RunStart` are counted and left out, not an error.
    joined: bool,
}

impl Builder {
    fn message(&mut self, text: &str, session: &mut Session) -> Result<(), String> {
        let structs = text::parse_structs(text);
        let Some(first) = structs.first() else {
            session.notes.push(text.to_string());
            return Ok(());
        };
        let run_part = matches!(
            first.name.as_str(),
            "RunEnd" | "ControlFrame" | "TaxelFrame"
        );
        if self.joined && run_part && self.current.is_none() {
            session.before_first_run += 1;
            return Ok(());
        }
        match first.name.as_str() {
            "RunStart" => {
                self.finish(session);
                let f = first.fields();
                self.current = Some(Run {
                    name: f.text("name")?.to_string(),
                    start_tick: f.num("start_tick")?,
                    duration_s: f.num("duration_s")?,
                    ..Default::default()
                });
            }
            "CommandAck" => session.replies.push((first.fields().num("seq")?, None)),
            "CommandRefused" => {
                let f = first.fields();
                let reason = f.text("reason")?.to_string();
                session.replies.push((f.num("seq")?, Some(reason)));
            }
            "RunEnd" => {
                let f = first.fields();
                let end = RunEnd {
                    end_tick: f.num("end_tick")?,
                    control_frames_dropped: f.num("control_frames_dropped")?,
                    taxel_frames_dropped: f.num("taxel_frames_dropped")?,
                    overruns: f.num("overruns")?,
                };
                self.run_mut("RunEnd")?.end = Some(end);
            }
            "ControlFrame" => {
                let frame = control_frame(&first.fields())?;
                session.control_seq.observe(frame.seq);
                if frame.faults.contains(FaultFlags::FRAMES_DROPPED) {
                    session.flagged_drops += 1;
                }
                let truth = structs.iter().find(|s| s.name == "SimTruth");
                let (true_force_g, in_contact) = match truth {
                    Some(s) => {
                        let f = s.fields();
                        let tick: u32 = f.num("tick")?;
                        if tick != frame.tick {
                            return Err(format!(
                                "SimTruth tick {tick} rides with ControlFrame tick {}",
                                frame.tick
                            ));
                        }
                        (Some(f.num("true_force_g")?), Some(f.flag("in_contact")?))
                    }
                    None => (None, None),
                };
                self.run_mut("ControlFrame")?.ticks.push(Tick {
                    frame,
                    true_force_g,
                    in_contact,
                });
            }
            "TaxelFrame" => {
                let frame = taxel_frame(&first.fields())?;
                session.taxel_seq.observe(frame.seq);
                let estimate = match structs.iter().find(|s| s.name == "ArrayEstimate") {
                    Some(s) => Some(array_estimate(&s.fields())?),
                    None => None,
                };
                self.run_mut("TaxelFrame")?.frames.push((frame, estimate));
            }
            _ => session.notes.push(text.to_string()),
        }
        Ok(())
    }

    fn run_mut(&mut self, what: &str) -> Result<&mut Run, String> {
        self.current
            .as_mut()
            .ok_or_else(|| format!("{what} before any RunStart"))
    }

    fn finish(&mut self, session: &mut Session) {
        if let Some(run) = self.current.take() {
            session.runs.push(run);
        }
    }
}

fn control_frame(f: &Fields) -> Result<ControlFrame, String> {
    Ok(ControlFrame {
        seq: f.num("seq")?,
        tick: f.num("tick")?,
        command_g: f.num("command_g")?,
        sensed_g: f.num("sensed_g")?,
        adjusted_g: f.num("adjusted_g")?,
        strain_pct: f.num("strain_pct")?,
        estimate_g: f.num("estimate_g")?,
        dac_code: f.num("dac_code")?,
        faults: FaultFlags::from_bits_retain(f.wrapped_num("faults", "FaultFlags")?),
    })
}

fn taxel_frame(f: &Fields) -> Result<TaxelFrame, String> {
    let cells: Vec<i16> = f.numbers("strain_centi_pct")?;
    if cells.len() != ROWS * COLS {
        return Err(format!(
            "field 'strain_centi_pct' has {} cells, not {}",
            cells.len(),
            ROWS * COLS
        ));
    }
    let mut frame = TaxelFrame {
        seq: f.num("seq")?,
        tick: f.num("tick")?,
        bad_taxels: f.num("bad_taxels")?,
        ..Default::default()
    };
    for (row, chunk) in frame.strain_centi_pct.iter_mut().zip(cells.chunks(COLS)) {
        row.copy_from_slice(chunk);
    }
    Ok(frame)
}

impl Session {
    /// The estimators' figures of a firmware-in-the-loop session: their RMS on the
    /// pseudo-random run (after its first second, the probe's approach) and the instructions
    /// per taxel update the firmware measured. `None` without both.
    pub fn estimator_figures(&self) -> Option<tactile_record::FirmwareFigures> {
        let run = self.run("pseudo-random")?;
        let (rms_g, frames) = run.probe_estimator_rms(1.0);
        let counts = self
            .notes
            .iter()
            .flat_map(|n| text::parse_structs(n))
            .find(|s| s.name == "InstructionCounts")?;
        let f = counts.fields();
        let spans: Vec<(u32, u32)> = text::parse_structs(f.text("estimator_update").ok()?)
            .iter()
            .filter(|s| s.name == "InstructionSpan")
            .filter_map(|s| {
                let f = s.fields();
                Some((f.num("min").ok()?, f.num("max").ok()?))
            })
            .collect();
        Some(tactile_record::FirmwareFigures {
            protocol: format!("pseudo-random, {:.0} s", run.duration_s),
            frames,
            rms_g,
            instructions: spans.try_into().ok()?,
        })
    }
}

fn array_estimate(f: &Fields) -> Result<ArrayEstimate, String> {
    Ok(ArrayEstimate {
        tick: f.num("tick")?,
        total_force_g: f.num("total_force_g")?,
        centroid_row: f.num("centroid_row")?,
        centroid_col: f.num("centroid_col")?,
        contact_x_mm: f.num("contact_x_mm")?,
        contact_y_mm: f.num("contact_y_mm")?,
        contact: contact_kind(f.text("contact")?)?,
        probe_force_g: f.num("probe_force_g")?,
        probe_estimates_g: {
            let v: Vec<f32> = f.numbers("probe_estimates_g")?;
            v.try_into().map_err(|v: Vec<f32>| {
                format!(
                    "probe_estimates_g: {} values, expected {}",
                    v.len(),
                    EstimatorKind::COUNT
                )
            })?
        },
        extrapolated_taxels: f.num("extrapolated_taxels")?,
    })
}

/// A contact kind as defmt prints the core's enum.
fn contact_kind(text: &str) -> Result<ContactKind, String> {
    Ok(match text {
        "Nothing" => ContactKind::Nothing,
        "Point" => ContactKind::Point,
        "TwoPeaks" => ContactKind::TwoPeaks,
        "Spread" => ContactKind::Spread,
        other => return Err(format!("contact: '{other}' is no contact kind")),
    })
}

impl Run {
    /// RMS of each estimator of the probed taxel against the simulator's true force at the
    /// instant the scan sampled it (the truth riding with the next control tick), over the
    /// frames after `after_s`; with the number of frames scored.
    pub fn probe_estimator_rms(&self, after_s: f64) -> ([f64; EstimatorKind::COUNT], usize) {
        let truth: std::collections::HashMap<u32, f32> = self
            .ticks
            .iter()
            .filter_map(|t| Some((t.frame.tick, t.true_force_g?)))
            .collect();
        let mut sums = [0.0f64; EstimatorKind::COUNT];
        let mut n = 0usize;
        for (frame, estimate) in &self.frames {
            let (Some(e), Some(&f)) = (estimate, truth.get(&frame.tick.wrapping_add(1))) else {
                continue;
            };
            if self.tick_time_s(frame.tick) < after_s {
                continue;
            }
            for (s, v) in sums.iter_mut().zip(e.probe_estimates_g) {
                *s += f64::from(v - f).powi(2);
            }
            n += 1;
        }
        (sums.map(|s| (s / n.max(1) as f64).sqrt()), n)
    }

    /// Seconds since the run started for a control tick: the frame's readings were sampled
    /// at the start of its tick, i.e. at the end of the period before it.
    pub fn tick_time_s(&self, tick: u32) -> f64 {
        f64::from(tick.wrapping_sub(self.start_tick)) * CONTROL_PERIOD_S
    }

    /// True when every tick carries the simulator's truth (a QEMU log).
    pub fn has_truth(&self) -> bool {
        !self.ticks.is_empty() && self.ticks.iter().all(|t| t.true_force_g.is_some())
    }

    /// The ticks as the simulator's tick records, in its convention: record `k` holds tick
    /// `k`'s command and adjusted force with the readings taken at the end of its period
    /// (which the firmware reports with tick `k + 1`), stamped `t_s = (k + 1) Δt`. The last
    /// tick's period has no readings in the log and is left out. Without the simulator's
    /// truth, true force is NaN and contact false. In a decimated log each record is one
    /// frame, stamped at its own tick.
    pub fn tick_records(&self) -> Vec<TickRecord> {
        self.ticks
            .windows(2)
            .map(|w| {
                let now = &w[0];
                // Consecutive ticks pair up as the simulator's records do; a decimated log (the
                // board sends every 5th frame) keeps each frame's own readings.
                let next = if w[1].frame.tick == now.frame.tick.wrapping_add(1) {
                    &w[1]
                } else {
                    now
                };
                TickRecord {
                    t_s: self.tick_time_s(next.frame.tick),
                    command_g: now.frame.command_g,
                    sensed_g: next.frame.sensed_g,
                    adjusted_g: now.frame.adjusted_g,
                    strain_pct: next.frame.strain_pct,
                    estimate_g: next.frame.estimate_g,
                    true_force_g: next.true_force_g.unwrap_or(f32::NAN),
                    in_contact: next.in_contact.unwrap_or(false),
                    faults: now.frame.faults | next.frame.faults,
                    // The code tick `k` wrote, as the simulator's record `k` holds it.
                    dac_code: now.frame.dac_code,
                }
            })
            .collect()
    }

    /// Whole frames as (time, strain grid): a frame completes after the scan that follows its
    /// tick's period, at the end of that period.
    pub fn strain_frames(&self) -> Vec<(f64, [[f32; COLS]; ROWS])> {
        self.frames
            .iter()
            .map(|(f, _)| {
                let grid = f
                    .strain_centi_pct
                    .map(|row| row.map(TaxelFrame::strain_pct));
                (self.tick_time_s(f.tick) + CONTROL_PERIOD_S, grid)
            })
            .collect()
    }
}

/// Writes a run's record (`NAME.csv`, the project's record format), its frames
/// (`NAME_frames.csv`) and the array estimates (`NAME_array.csv`) into `dir`.
pub fn write_run(
    dir: &Path,
    run: &Run,
    meta: &[(String, String)],
) -> std::io::Result<Vec<PathBuf>> {
    use std::io::Write;
    std::fs::create_dir_all(dir)?;
    let mut meta = meta.to_vec();
    meta.push(("scenario".into(), run.name.clone()));
    meta.push((
        "sample_rate_hz".into(),
        format!("{}", 1.0 / CONTROL_PERIOD_S),
    ));
    let record = dir.join(format!("{}.csv", run.name));
    let ticks = run.tick_records();
    // A board knows no true force: the same columns without the simulator's truth.
    tactile_record::write_ticks(
        &record,
        &meta,
        &ticks,
        1,
        run.has_truth(),
        &tactile_firmware::BOARD.actuator,
    )?;
    let frames = dir.join(format!("{}_frames.csv", run.name));
    tactile_record::write_frames(&frames, &meta, &run.strain_frames())?;
    let array = dir.join(format!("{}_array.csv", run.name));
    let mut w = std::io::BufWriter::new(std::fs::File::create(&array)?);
    for (k, v) in &meta {
        writeln!(w, "# {k}={v}")?;
    }
    writeln!(
        w,
        "t_s,total_force_g,centroid_row,centroid_col,contact_x_mm,contact_y_mm,contact,probe_force_g,probe_elastic_g,probe_second_order_g,probe_scheduled_g,probe_observer_g,probe_bank_g,extrapolated_taxels"
    )?;
    for (f, e) in &run.frames {
        if let Some(e) = e {
            writeln!(
                w,
                "{:.4},{:.3},{:.3},{:.3},{:.3},{:.3},{},{:.3},{},{:#018x}",
                run.tick_time_s(f.tick) + CONTROL_PERIOD_S,
                e.total_force_g,
                e.centroid_row,
                e.centroid_col,
                e.contact_x_mm,
                e.contact_y_mm,
                e.contact.name(),
                e.probe_force_g,
                e.probe_estimates_g.map(|v| format!("{v:.3}")).join(","),
                e.extrapolated_taxels
            )?;
        }
    }
    w.flush()?;
    Ok(vec![record, frames, array])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_is_not_a_firmware_elf_is_named_in_the_error() {
        let e = decode(
            b"\x7fELF nonsense",
            Path::new("fw.elf"),
            b"",
            Path::new("x.log"),
        )
        .unwrap_err();
        assert_eq!(e.file, Path::new("fw.elf"));
        assert!(e.to_string().starts_with("fw.elf: "), "{e}");
    }
}
