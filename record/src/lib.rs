//! The project's record format (`../shared/data/README.md`):
//!
//! ```text
//! # key=value            (comment lines; sample_rate_hz when known)
//! t_s,force_g,strain_pct (header; other columns may follow and are ignored)
//! 0.0000,0.109,-0.00589
//! ```
//!
//! Writing and strict reading: every problem names the file, the line and the column.

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
    /// Extra numeric columns by name (command_g, true_force_g, …).
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
    /// Sample period from the time column (median step).
    pub fn sample_period_s(&self) -> Option<f64> {
        let mut d: Vec<f64> = self.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        if d.is_empty() {
            return None;
        }
        d.sort_by(f64::total_cmp);
        Some(d[d.len() / 2])
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

/// Reads a record strictly. Time must increase and be evenly sampled (within 1 % of the median
/// step); every cell of the required and extra columns must be a finite number.
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
        let cells: Vec<&str> = trimmed.split(',').map(str::trim).collect();
        let Some(names) = &header else {
            let names: Vec<String> = cells.iter().map(|c| c.to_string()).collect();
            for (slot, want) in index.iter_mut().zip(REQUIRED) {
                *slot = names.iter().position(|c| c == want).ok_or_else(|| {
                    err(
                        Some(n),
                        Some(want.to_string()),
                        format!(
                            "header lacks the required column (found: {})",
                            names.join(",")
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
        let mut values = Vec::with_capacity(cells.len());
        for (cell, name) in cells.iter().zip(names) {
            let v: f64 = cell.parse().map_err(|_| {
                err(
                    Some(n),
                    Some(name.clone()),
                    format!("'{}' is not a number", shown(cell)),
                )
            })?;
            if !v.is_finite() {
                return Err(err(
                    Some(n),
                    Some(name.clone()),
                    format!("'{}' is not finite", shown(cell)),
                ));
            }
            values.push(v);
        }
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
    let step = rec.sample_period_s().unwrap_or(0.0);
    // The first step that strays from the median by more than 1 % is uneven sampling.
    if let Some(k) = rec
        .t_s
        .windows(2)
        .position(|w| ((w[1] - w[0]) - step).abs() > 0.01 * step)
    {
        let (a, b) = (rec.t_s[k], rec.t_s[k + 1]);
        return Err(err(
            row_lines.get(k + 1).copied(),
            Some("t_s".into()),
            format!(
                "uneven sampling: step {:.6} s from {a} s, the record's median step is {step:.6} s",
                b - a
            ),
        ));
    }
    // The columns grew by doubling: a 600 s record at 1 kHz would hold 3.6 MB unused in each.
    for v in [&mut rec.t_s, &mut rec.force_g, &mut rec.strain_pct]
        .into_iter()
        .chain(rec.extra.iter_mut().map(|(_, v)| v))
    {
        v.shrink_to_fit();
    }
    Ok(rec)
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
    fn reads_the_shared_format_with_extra_columns() {
        let r = parse("# sample_rate_hz=200\nt_s,force_g,strain_pct,x\n0.0,1.0,0.5,9\n0.005,2.0,0.6,8\n0.010,3.0,0.7,7\n").unwrap();
        assert_eq!(r.meta("sample_rate_hz"), Some("200"));
        assert_eq!(r.force_g, vec![1.0, 2.0, 3.0]);
        assert_eq!(r.column("x"), Some(&[9.0, 8.0, 7.0][..]));
        assert!((r.sample_period_s().unwrap() - 0.005).abs() < 1e-12);
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
        assert!(e.message.contains("uneven sampling"), "{e}");
    }
}
