//! The project's record format (`../shared/data/README.md`):
//!
//! ```text
//! # key=value            (comment lines; sample_rate_hz when known)
//! t_s,force_g,strain_pct (header; other columns may follow and are ignored)
//! 0.0000,0.109,-0.00589
//! ```
//!
//! Writing and strict reading: every problem names the file, the line and the column. What
//! spreadsheets add is read: a byte-order mark, CRLF line ends, cells in double quotes.

use std::io::BufRead;
use std::path::{Path, PathBuf};

mod figures;
mod write;

pub use figures::FirmwareFigures;
pub use write::{write_frames, write_record, write_ticks};

/// A record read back: the three required columns, any extra ones, and the metadata.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Record {
    pub meta: Vec<(String, String)>,
    pub t_s: Vec<f64>,
    pub force_g: Vec<f64>,
    pub strain_pct: Vec<f64>,
    /// Extra numeric columns by name (command_g, true_force_g, …); a column with a cell that
    /// is not a finite number (a logger's note, a flag) is ignored.
    pub extra: Vec<(String, Vec<f64>)>,
}

impl Record {
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.meta
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.extra
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_slice())
    }
    pub fn len(&self) -> usize {
        self.t_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
    /// Sample period from the time column: the median step, or, where the time stamps jitter
    /// (a step more than 1 % off the median), the step of the even grid that fits them.
    pub fn sample_period_s(&self) -> Option<f64> {
        let median = median_step(&self.t_s)?;
        Some(if max_step_deviation(&self.t_s, median) > EVEN_STEP_SHARE {
            grid(&self.t_s).map_or(median, |g| g.1)
        } else {
            median
        })
    }

    /// How far the time stamps stray from an even grid, as a share of the step: 0 for a record
    /// sampled evenly, at most [`JITTER_SHARE`] for one that was read.
    pub fn jitter(&self) -> f64 {
        grid_deviation(&self.t_s).unwrap_or(0.0)
    }
}

/// What is wrong with a record, and where: `file:line: column 'name': message`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}{}{}: {message}", .file.display(), at_line(.line), in_column(.column))]
pub struct RecordError {
    pub file: PathBuf,
    /// 1-based line, when the problem has one.
    pub line: Option<usize>,
    /// Column name (or number), when the problem has one.
    pub column: Option<String>,
    pub message: String,
}

fn at_line(line: &Option<usize>) -> String {
    line.map(|l| format!(":{l}")).unwrap_or_default()
}

fn in_column(column: &Option<String>) -> String {
    column
        .as_ref()
        .map(|c| format!(": column '{c}'"))
        .unwrap_or_default()
}

const REQUIRED: [&str; 3] = ["t_s", "force_g", "strain_pct"];

/// Reads a record strictly. Time must increase and be evenly sampled: every step within 1 % of
/// the median, or time stamps that jitter by at most [`JITTER_SHARE`] of a step about an even
/// grid (read as evenly sampled at that grid's step; no gap, no change of rate); every cell of
/// the required and extra columns must be a finite number.
pub fn read_record(path: &Path) -> Result<Record, RecordError> {
    let err = |line: Option<usize>, column: Option<String>, message: String| RecordError {
        file: path.to_path_buf(),
        line,
        column,
        message,
    };
    let file =
        std::fs::File::open(path).map_err(|e| err(None, None, format!("cannot open: {e}")))?;
    parse_record(std::io::BufReader::new(file), path)
}

/// [`read_record`] on any reader (`path` only names the source in errors).
pub fn parse_record(reader: impl BufRead, path: &Path) -> Result<Record, RecordError> {
    let err = |line: Option<usize>, column: Option<String>, message: String| RecordError {
        file: path.to_path_buf(),
        line,
        column,
        message,
    };
    let mut rec = Record::default();
    let mut header: Option<Vec<String>> = None;
    let mut index = [0usize; 3];
    // File line of each data row, for errors found after reading.
    let mut row_lines: Vec<usize> = Vec::new();
    for (i, line) in reader.lines().enumerate() {
        let n = i + 1;
        let line = line.map_err(|e| err(Some(n), None, format!("unreadable line: {e}")))?;
        // A spreadsheet's export may open with a byte-order mark.
        let line = if i == 0 {
            line.strip_prefix('\u{feff}').unwrap_or(&line)
        } else {
            &line
        };
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        if let Some(comment) = trimmed.strip_prefix('#') {
            if let Some((k, v)) = comment.split_once('=') {
                rec.meta.push((k.trim().to_string(), v.trim().to_string()));
            }
            continue;
        }
        // Cells may be quoted (a quoted comma is not read: no column of the format holds one).
        let cells: Vec<&str> = trimmed.split(',').map(unquoted).collect();
        let Some(names) = &header else {
            let names: Vec<String> = cells.iter().map(|c| c.to_string()).collect();
            // A column named twice: which of the two the reader took would be a guess.
            if let Some((i, twice)) = names
                .iter()
                .enumerate()
                .find(|(i, c)| !c.is_empty() && names[..*i].contains(c))
            {
                return Err(err(
                    Some(n),
                    Some(twice.clone()),
                    format!(
                        "the header names this column twice (cells {} and {})",
                        names.iter().position(|c| c == twice).map_or(0, |k| k + 1),
                        i + 1
                    ),
                ));
            }
            for (slot, want) in index.iter_mut().zip(REQUIRED) {
                *slot = names.iter().position(|c| c == want).ok_or_else(|| {
                    err(
                        Some(n),
                        Some(want.to_string()),
                        format!(
                            "header lacks the required column (found: {}){}",
                            shown(&names.join(",")),
                            separator_hint(&names)
                        ),
                    )
                })?;
            }
            rec.extra = names
                .iter()
                .filter(|c| !REQUIRED.contains(&c.as_str()))
                .map(|c| (c.clone(), Vec::new()))
                .collect();
            header = Some(names);
            continue;
        };
        if cells.len() != names.len() {
            return Err(err(
                Some(n),
                None,
                format!("{} cells, the header has {}", cells.len(), names.len()),
            ));
        }
        let values =
            row_values(&cells, names, &index).map_err(|(c, m)| err(Some(n), Some(c), m))?;
        let t = values[index[0]];
        if let Some(&last) = rec.t_s.last() {
            if t <= last {
                return Err(err(
                    Some(n),
                    Some("t_s".into()),
                    format!("time {t} does not increase (previous {last})"),
                ));
            }
        }
        rec.t_s.push(t);
        row_lines.push(n);
        rec.force_g.push(values[index[1]]);
        rec.strain_pct.push(values[index[2]]);
        let mut extra = rec.extra.iter_mut();
        for (j, v) in values.iter().enumerate() {
            if !index.contains(&j) {
                if let Some((_, col)) = extra.next() {
                    col.push(*v);
                }
            }
        }
    }
    if header.is_none() {
        return Err(err(
            None,
            None,
            "empty: no header line t_s,force_g,strain_pct".into(),
        ));
    }
    if rec.len() < 2 {
        return Err(err(
            None,
            None,
            format!("{} data rows; a record needs at least two", rec.len()),
        ));
    }
    check_sampling(&rec.t_s)
        .map_err(|(k, message)| err(row_lines.get(k).copied(), Some("t_s".into()), message))?;
    rec.extra.retain(|(_, v)| v.iter().all(|x| x.is_finite()));
    // The columns grew by doubling: a 600 s record at 1 kHz would hold 3.6 MB unused in each.
    for v in [&mut rec.t_s, &mut rec.force_g, &mut rec.strain_pct]
        .into_iter()
        .chain(rec.extra.iter_mut().map(|(_, v)| v))
    {
        v.shrink_to_fit();
    }
    Ok(rec)
}

/// A data row's values in the header's order: the `required` columns strictly (a finite
/// number), another column NaN where it holds no number (the column is left out after the
/// reading). `Err`: the column and what is wrong with its cell.
fn row_values(
    cells: &[&str],
    names: &[String],
    required: &[usize; 3],
) -> Result<Vec<f64>, (String, String)> {
    cells
        .iter()
        .zip(names)
        .enumerate()
        .map(|(j, (cell, name))| {
            if !required.contains(&j) {
                return Ok(cell.parse().unwrap_or(f64::NAN));
            }
            let v: f64 = cell
                .parse()
                .map_err(|_| (name.clone(), format!("'{}' is not a number", shown(cell))))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err((name.clone(), format!("'{}' is not finite", shown(cell))))
            }
        })
        .collect()
}

/// Steps within this share of the median are even sampling.
const EVEN_STEP_SHARE: f64 = 0.01;
/// Most a time stamp may stray from the even grid that fits the stamps, as a share of the step:
/// the jitter of a logger's clock, not a change of rate. The samples are then read as evenly
/// spaced (a sampler's clock ticks evenly; its time stamps are what jitter).
pub const JITTER_SHARE: f64 = 0.25;

fn median_step(t: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2])
}

/// Largest step's departure from `step`, as a share of it.
fn max_step_deviation(t: &[f64], step: f64) -> f64 {
    t.windows(2)
        .map(|w| ((w[1] - w[0]) - step).abs() / step)
        .fold(0.0, f64::max)
}

/// The even grid that fits the time stamps best (least squares): its first time and its step.
fn grid(t: &[f64]) -> Option<(f64, f64)> {
    let n = t.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let k_mean = (nf - 1.0) / 2.0;
    let t_mean = t.iter().sum::<f64>() / nf;
    let (mut skt, mut skk) = (0.0, 0.0);
    for (k, v) in t.iter().enumerate() {
        let dk = k as f64 - k_mean;
        skt += dk * (v - t_mean);
        skk += dk * dk;
    }
    let step = skt / skk;
    Some((t_mean - step * k_mean, step))
}

/// Each time stamp's departure from the grid `(t0, step)`, as a share of its step.
fn grid_offsets(t: &[f64], (t0, step): (f64, f64)) -> impl Iterator<Item = f64> + '_ {
    t.iter()
        .enumerate()
        .map(move |(k, v)| (v - (t0 + k as f64 * step)) / step)
}

/// Largest departure of a time stamp from the even grid that fits them, as a share of the step.
fn grid_deviation(t: &[f64]) -> Option<f64> {
    Some(grid_offsets(t, grid(t)?).map(f64::abs).fold(0.0, f64::max))
}

/// Even sampling, or time stamps that jitter about an even grid; else the index of the first
/// row that breaks it and why (a gap, a burst, a clock that changes rate).
fn check_sampling(t: &[f64]) -> Result<(), (usize, String)> {
    let Some(step) = median_step(t) else {
        return Ok(());
    };
    if max_step_deviation(t, step) <= EVEN_STEP_SHARE {
        return Ok(());
    }
    for (k, w) in t.windows(2).enumerate() {
        let d = w[1] - w[0];
        if d > 1.5 * step {
            let missing = ((d / step).round() - 1.0).max(1.0);
            let samples = if missing > 1.0 { "samples" } else { "sample" };
            return Err((
                k + 1,
                format!(
                    "a gap of {d:.6} s after {} s (about {missing:.0} {samples} missing at the \
                     median step {step:.6} s): split the record there or fill the gap",
                    w[0]
                ),
            ));
        }
        if d < 0.5 * step {
            return Err((
                k + 1,
                format!(
                    "uneven sampling: step {d:.6} s from {} s, the record's median step is \
                     {step:.6} s",
                    w[0]
                ),
            ));
        }
    }
    // Every step is within half of the median: jitter, unless the stamps wander off the grid.
    let Some(fitted) = grid(t) else {
        return Ok(());
    };
    match grid_offsets(t, fitted)
        .enumerate()
        .find(|(_, d)| d.abs() > JITTER_SHARE)
    {
        None => Ok(()),
        Some((k, off)) => Err((
            k,
            format!(
                "uneven sampling: time {} s is {:.0} % of a step off the even grid of {:.6} s \
                 that fits the time stamps (they may jitter by {:.0} %): a rate that changes \
                 within the record, or jitter too large to read as even sampling",
                t[k],
                100.0 * off.abs(),
                fitted.1,
                100.0 * JITTER_SHARE
            ),
        )),
    }
}

/// A cell trimmed, and without the double quotes around it if it has them.
fn unquoted(cell: &str) -> &str {
    let cell = cell.trim();
    cell.strip_prefix('"')
        .and_then(|c| c.strip_suffix('"'))
        .map_or(cell, str::trim)
}

/// A header read as one cell that holds the names between another separator.
fn separator_hint(names: &[String]) -> &'static str {
    match names {
        [one] if one.contains('\t') => "; the format is comma-separated, this header tab-separated",
        [one] if one.contains(';') => {
            "; the format is comma-separated, this header semicolon-separated"
        }
        _ => "",
    }
}

/// A cell as an error message shows it: at most 40 characters, control characters escaped
/// (a damaged file can hold a megabyte of NULs in one cell).
fn shown(cell: &str) -> String {
    let mut out: String = cell.chars().take(40).flat_map(char::escape_debug).collect();
    if cell.chars().count() > 40 {
        out.push_str(&format!("… ({} characters)", cell.chars().count()));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Record, RecordError> {
        parse_record(text.as_bytes(), Path::new("mem.csv"))
    }

    #[test]
    fn reads_a_byte_order_mark_quoted_cells_and_crlf() {
        let r = parse(
            "\u{feff}\"t_s\",\"force_g\",\"strain_pct\"\r\n\"0.0\",1.0,0.5\r\n0.005,\" 2.0\",0.6\r\n",
        )
        .unwrap();
        assert_eq!(r.t_s, vec![0.0, 0.005]);
        assert_eq!(r.force_g, vec![1.0, 2.0]);
        assert_eq!(r.strain_pct, vec![0.5, 0.6]);
        // A mark anywhere but the file's start, or a quote left open, is still refused.
        assert!(parse("t_s,force_g,strain_pct\n\u{feff}0.0,1,1\n").is_err());
        let e = parse("t_s,force_g,strain_pct\n\"0.0,1,1\n").unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(2), Some("t_s")));
    }

    #[test]
    fn reads_the_shared_format_with_extra_columns() {
        let r = parse("# sample_rate_hz=200\nt_s,force_g,strain_pct,x\n0.0,1.0,0.5,9\n0.005,2.0,0.6,8\n0.010,3.0,0.7,7\n").unwrap();
        assert_eq!(r.meta("sample_rate_hz"), Some("200"));
        assert_eq!(r.force_g, vec![1.0, 2.0, 3.0]);
        assert_eq!(r.column("x"), Some(&[9.0, 8.0, 7.0][..]));
        assert!((r.sample_period_s().unwrap() - 0.005).abs() < 1e-12);
    }

    #[test]
    fn a_column_of_text_is_ignored_and_the_required_ones_read() {
        // A logger's note and a flag that is once "inf": both columns are left out; a number
        // column beside them is kept.
        let r = parse(
            "t_s,force_g,strain_pct,note,flag,drive_g\n0.0,1.0,0.5,start,0,4\n\
             0.005,2.0,0.6,,inf,5\n0.010,3.0,0.7,end,1,6\n",
        )
        .unwrap();
        assert_eq!(r.strain_pct, vec![0.5, 0.6, 0.7]);
        assert_eq!(r.column("note"), None);
        assert_eq!(r.column("flag"), None);
        assert_eq!(r.column("drive_g"), Some(&[4.0, 5.0, 6.0][..]));
        // A required column stays strict.
        let e = parse("t_s,force_g,strain_pct,note\n0.0,1.0,x,a\n0.005,2.0,0.6,b\n").unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(2), Some("strain_pct")));
    }

    #[test]
    fn errors_name_the_line_and_column() {
        let e = parse("t_s,force_g,strain_pct\n0.0,1.0,0.5\n0.005,abc,0.6\n").unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(3), Some("force_g")));
        assert_eq!(
            e.to_string(),
            "mem.csv:3: column 'force_g': 'abc' is not a number"
        );
        // A damaged cell is shown short and escaped, not echoed whole.
        let long = format!(
            "t_s,force_g,strain_pct\n0.0,1.0,0.5\n0.005,30.{},0.6\n",
            "\0".repeat(5000)
        );
        let e = parse(&long).unwrap_err();
        let text = e.to_string();
        assert!(
            text.len() < 200 && text.contains("\\0") && text.contains("5003 characters"),
            "{text}"
        );
        let e = parse("t_s,force_g,strain_pct\n0.0,1.0,NaN\n0.005,1,1\n").unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(2), Some("strain_pct")));
        let e = parse("t_s,force_g\n0.0,1.0\n").unwrap_err();
        assert_eq!(e.column.as_deref(), Some("strain_pct"));
        let e = parse("t_s,force_g,strain_pct\n0.0,1,1\n0.01,1,1\n0.005,1,1\n").unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(4), Some("t_s")));
        let e = parse("t_s,force_g,strain_pct\n0.0,1,1\n0.01,1\n").unwrap_err();
        assert_eq!(e.line, Some(3));
        let e = parse("# only=comments\n").unwrap_err();
        assert!(e.message.contains("empty"));
        let e =
            parse("t_s,force_g,strain_pct\n0.0,1,1\n0.01,1,1\n0.02,1,1\n0.05,1,1\n").unwrap_err();
        assert!(
            e.message.contains("a gap of 0.030000 s after 0.02 s"),
            "{e}"
        );
        assert!(e.message.contains("about 2 samples missing"), "{e}");
        assert_eq!(e.line, Some(5));
        let e = parse("t_s\tforce_g\tstrain_pct\n0.0\t1\t1\n").unwrap_err();
        assert!(e.message.ends_with("this header tab-separated"), "{e}");
    }

    #[test]
    fn a_column_named_twice_is_refused_where_it_is_named() {
        let dir = std::env::temp_dir().join(format!("record-twice-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("twice.csv");
        std::fs::write(
            &path,
            "t_s,force_g,strain_pct,force_g\n0,1,1,2\n0.01,2,2,3\n",
        )
        .unwrap();
        let e = read_record(&path).unwrap_err();
        assert_eq!(
            (e.line, e.column.as_deref()),
            (Some(1), Some("force_g")),
            "{e}"
        );
        assert!(
            e.message
                .contains("names this column twice (cells 2 and 4)"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The refusal of `text` (a record read instead is not printed: it can be long).
    fn refused(text: &str) -> RecordError {
        match parse(text) {
            Ok(r) => panic!("a record of {} rows was read", r.len()),
            Err(e) => e,
        }
    }

    /// `n` time stamps at `step` s, each moved by `off(k)` steps.
    fn stamps(n: usize, step: f64, off: impl Fn(usize) -> f64) -> String {
        let mut text = String::from("t_s,force_g,strain_pct\n");
        for k in 0..n {
            let t = (k as f64 + off(k)) * step;
            text.push_str(&format!("{t:.7},{k},{}\n", k % 7));
        }
        text
    }

    #[test]
    fn time_stamps_that_jitter_about_an_even_grid_are_read_as_even() {
        // A logger's stamps ±20 % of a 10 ms step (a pattern, so the test is exact).
        let jitter = [0.0, 0.2, -0.15, 0.1, -0.2, 0.05, 0.18, -0.1];
        let r = parse(&stamps(801, 0.01, |k| jitter[k % 8])).unwrap();
        // The pattern's mean is 0.01 step: the grid 0.1 ms late, its step 10 ms (but for the
        // pattern's slight trend over the record's last partial cycle); the farthest stamp is
        // the -0.2 one, 0.21 of a step off that grid.
        assert!((r.sample_period_s().unwrap() - 0.01).abs() < 1e-8);
        assert!((r.jitter() - 0.21).abs() < 1e-3, "{}", r.jitter());
        // Even stamps: no jitter, and the median step as before.
        let even = parse(&stamps(100, 0.01, |_| 0.0)).unwrap();
        assert!(even.jitter() < 1e-6);
        assert!((even.sample_period_s().unwrap() - 0.01).abs() < 1e-12);
    }

    #[test]
    fn a_clock_that_changes_rate_is_refused_where_it_leaves_the_grid() {
        // 3 % slower from sample 400 on: every step within half of the median, but the stamps
        // leave the best even grid by about 1.5 steps.
        let text = stamps(801, 0.01, |k| {
            if k > 400 {
                0.03 * (k - 400) as f64
            } else {
                0.0
            }
        });
        let e = refused(&text);
        assert!(
            e.message.contains("a rate that changes within the record"),
            "{e}"
        );
        assert_eq!(e.column.as_deref(), Some("t_s"));
        // Stamps that bunch (a step under half the median) are uneven sampling.
        let e = refused(&stamps(50, 0.01, |k| if k == 20 { -0.6 } else { 0.0 }));
        assert!(
            e.message.contains("uneven sampling: step 0.004000 s"),
            "{e}"
        );
        assert_eq!(e.line, Some(22));
    }
}
