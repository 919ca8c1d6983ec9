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

use std::path::{Path, PathBuf};

mod figures;
mod frames;
mod logger;
mod read;
mod write;

pub use figures::FirmwareFigures;
pub use frames::{parse_frames, read_frames, write_frames_with_truth, FramesRecord, Truth};
pub use logger::{
    bridge_held, held_values, runs_of, Resampling, GAP_STEPS, JITTER_SHARE, MAX_HELD_RUN,
    MIN_HELD_RUN,
};
pub use read::parse_record;
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
    /// How the time column was mended on reading (jitter resampled, duplicate rows merged);
    /// `None`: as written.
    pub resampling: Option<Resampling>,
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
    /// Sample period from the time column: its median step (after reading, within a rounding
    /// of the step jittered stamps were resampled onto).
    pub fn sample_period_s(&self) -> Option<f64> {
        logger::median_step(&self.t_s)
    }

    /// How far the time stamps spread about an even grid, as a share of the step: as read
    /// (before any resampling), 0 for a record sampled evenly.
    pub fn jitter(&self) -> f64 {
        match &self.resampling {
            Some(r) => r.jitter_share,
            None => logger::stamp_spread(&self.t_s).unwrap_or(0.0),
        }
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

/// Reads a record strictly. Time must not go back; rows stamped with the time of the row
/// before are averaged into it. Stamps within 1 % of the median step are kept; stamps that
/// jitter (spread by at most [`JITTER_SHARE`] of a step about an even grid) are resampled onto
/// that grid's step by linear interpolation ([`Record::resampling`] says so); a gap of more than
/// [`GAP_STEPS`] steps, or a clock that changes rate, is refused. Every cell of the required
/// columns must be a finite number.
pub fn read_record(path: &Path) -> Result<Record, RecordError> {
    let err = |line: Option<usize>, column: Option<String>, message: String| RecordError {
        file: path.to_path_buf(),
        line,
        column,
        message,
    };
    let file =
        std::fs::File::open(path).map_err(|e| err(None, None, format!("cannot open: {e}")))?;
    parse_record(file, path)
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
    fn a_long_record_read_in_chunks_is_read_as_one() {
        // 120 000 rows (about 3.4 MB: a chunk per core of at least 1 MB), a comment and a
        // twice-stamped row past the middle: every row in order, the pair merged.
        let mut text = String::from("t_s,force_g,strain_pct,note\n");
        let rows = 120_000;
        for i in 0..rows {
            text.push_str(&format!("{:.3},{i},{},x\n", i as f64 * 0.001, i % 7));
            if i == 90_000 {
                text.push_str("# late=note\n90.000,90001,2,y\n");
            }
        }
        let r = parse(&text).unwrap();
        assert_eq!(r.len(), rows);
        assert_eq!(r.meta("late"), Some("note"));
        assert_eq!(r.force_g[90_000], 90_000.5);
        assert_eq!(r.strain_pct[90_000], (90_000 % 7 + 2) as f64 / 2.0);
        for i in (0..rows).filter(|i| *i != 90_000) {
            assert_eq!(r.force_g[i], i as f64, "row {i}");
        }
        // A problem in a later chunk is named at its file line (the header is line 1, row i
        // line i + 2; the comment and the merged row are two lines more past row 90 000).
        let at = |row: usize, bad: &str| {
            let mut lines: Vec<&str> = text.lines().collect();
            let n = if row > 90_000 { row + 4 } else { row + 2 };
            lines[n - 1] = bad;
            (n, parse(&lines.join("\n")).unwrap_err())
        };
        let (n, e) = at(100_000, "100.000,abc,1,x");
        assert_eq!((e.line, e.column.as_deref()), (Some(n), Some("force_g")));
        let (n, e) = at(110_000, "1.000,1,1,x");
        assert_eq!((e.line, e.column.as_deref()), (Some(n), Some("t_s")));
        // Of two problems, the first in the file, whatever chunk finds which.
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        lines[30_001] = "30.000,1,1".into();
        lines[100_001] = "100.000,abc,1,x".into();
        let e = parse(&lines.join("\n")).unwrap_err();
        assert_eq!(e.line, Some(30_002));
        assert!(e.message.contains("cells"), "{e}");
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
        assert!(e.message.contains("goes back"), "{e}");
        let e = parse("t_s,force_g,strain_pct\n0.0,1,1\n0.01,1\n").unwrap_err();
        assert_eq!(e.line, Some(3));
        let e = parse("# only=comments\n").unwrap_err();
        assert!(e.message.contains("empty"));
        let e =
            parse("t_s,force_g,strain_pct\n0.0,1,1\n0.01,1,1\n0.02,1,1\n0.06,1,1\n").unwrap_err();
        assert!(
            e.message.contains("a gap of 0.040000 s after 0.02 s"),
            "{e}"
        );
        assert!(e.message.contains("about 3 samples missing"), "{e}");
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
    fn time_stamps_that_jitter_about_an_even_grid_are_resampled() {
        // A logger's stamps ±20 % of a 10 ms step (a pattern, so the test is exact).
        let jitter = [0.0, 0.2, -0.15, 0.1, -0.2, 0.05, 0.18, -0.1];
        let r = parse(&stamps(801, 0.01, |k| jitter[k % 8])).unwrap();
        // The stamps spread from -0.2 to +0.2 of a step about the grid that fits them (but for
        // the pattern's slight trend over the record's last partial cycle): 0.4 of a step.
        assert!((r.jitter() - 0.4).abs() < 2e-3, "{}", r.jitter());
        // Resampled onto the step of the grid that fits them, 10 ms (the median step, 11.3 ms
        // for this pattern, would resample a 100 Hz logger at 88 Hz).
        let rs = r.resampling.as_ref().unwrap();
        assert!((rs.resampled_step_s.unwrap() - 0.01).abs() < 1e-7, "{rs:?}");
        assert!((r.sample_period_s().unwrap() - 0.01).abs() < 1e-7);
        // The force column is k at stamp (k + jitter)·10 ms: interpolated at 40 ms (between
        // the stamps 38 and 50.5 ms of rows 4 and 5) it is 4 + 2/12.5.
        assert!((r.force_g[4] - 4.16).abs() < 1e-4, "{}", r.force_g[4]);
        // Even stamps: no jitter, the values as written, and the median step as before.
        let even = parse(&stamps(100, 0.01, |_| 0.0)).unwrap();
        assert!(even.jitter() < 1e-6);
        assert_eq!(even.resampling, None);
        assert_eq!(even.force_g[17], 17.0);
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
        // A stamp 60 % of a step early (once refused as a burst) is jitter: read, resampled.
        let r = parse(&stamps(50, 0.01, |k| if k == 20 { -0.6 } else { 0.0 })).unwrap();
        assert!((r.jitter() - 0.6).abs() < 0.05, "{}", r.jitter());
        // The grid's step, pulled a little long, ends it before the last stamp.
        assert!((49..=50).contains(&r.len()), "{}", r.len());
    }
}
