//! The frames record: `t_s,r0c0,…,r7c7` (each taxel's strain in percent, `NaN` for a taxel
//! marked bad), with the probe's position and force as `x_mm,y_mm,force_g` where the truth is
//! known (x along the columns, y along the rows, from the centre of taxel r0c0): a calibration
//! press on a positioning stage, or the simulator.

use std::io::{BufRead, Write};
use std::path::Path;

use tactile_core::tactile::{StrainGrid, COLS, ROWS, TAXELS};

use crate::RecordError;

/// Where and how hard the probe pressed, as the stage and its gauge say.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    pub x_mm: f64,
    pub y_mm: f64,
    pub force_g: f64,
}

/// A frames record read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FramesRecord {
    pub meta: Vec<(String, String)>,
    pub t_s: Vec<f64>,
    pub strain_pct: Vec<StrainGrid>,
    /// Each row's truth, when the record carries the columns and the row fills them.
    pub truth: Vec<Option<Truth>>,
    /// Each data row's line in the file, for messages about a row.
    pub lines: Vec<usize>,
}

const TRUTH: [&str; 3] = ["x_mm", "y_mm", "force_g"];

fn taxel_column(i: usize) -> String {
    format!("r{}c{}", i / COLS, i % COLS)
}

/// Cell index of t_s, of each taxel, of the truth's columns if there; the header's width.
type Layout = (usize, Vec<usize>, Option<[usize; 3]>, usize);

/// Reads a frames record strictly: every taxel's column, time that does not go back, numbers
/// in every strain cell (`NaN` allowed: a taxel marked bad), the truth's three columns all or
/// none (a row may leave them empty: no truth there). Errors name file, line and column.
pub fn read_frames(path: &Path) -> Result<FramesRecord, RecordError> {
    let file = std::fs::File::open(path).map_err(|e| RecordError {
        file: path.to_path_buf(),
        line: None,
        column: None,
        message: format!("cannot open: {e}"),
    })?;
    parse_frames(std::io::BufReader::new(file), path)
}

/// [`read_frames`] on any reader (`path` only names the source in errors).
pub fn parse_frames(reader: impl BufRead, path: &Path) -> Result<FramesRecord, RecordError> {
    let err = |line: usize, column: Option<&str>, message: String| RecordError {
        file: path.to_path_buf(),
        line: Some(line),
        column: column.map(str::to_string),
        message,
    };
    let mut rec = FramesRecord::default();
    let mut layout: Option<Layout> = None;
    for (i, line) in reader.lines().enumerate() {
        let n = i + 1;
        let line = line.map_err(|e| err(n, None, format!("unreadable line: {e}")))?;
        let trimmed = line.trim().trim_start_matches('\u{feff}');
        if trimmed.is_empty() {
            continue;
        }
        if let Some(comment) = trimmed.strip_prefix('#') {
            if let Some((k, v)) = comment.split_once('=') {
                rec.meta.push((k.trim().to_string(), v.trim().to_string()));
            }
            continue;
        }
        let cells: Vec<&str> = trimmed
            .split(',')
            .map(|c| c.trim().trim_matches('"'))
            .collect();
        let Some((t_at, taxels, truth_at, width)) = &layout else {
            let find = |name: &str| cells.iter().position(|c| *c == name);
            let need = |name: &str| {
                find(name).ok_or_else(|| {
                    err(
                        n,
                        Some(name),
                        "the header lacks this column (a frames record: t_s,r0c0,…,r7c7)".into(),
                    )
                })
            };
            let t_at = need("t_s")?;
            let taxels = (0..TAXELS)
                .map(|i| need(&taxel_column(i)))
                .collect::<Result<Vec<_>, _>>()?;
            let truth = TRUTH.map(find);
            let truth_at = match truth {
                [Some(x), Some(y), Some(f)] => Some([x, y, f]),
                [None, None, None] => None,
                _ => {
                    let missing = TRUTH
                        .iter()
                        .zip(truth)
                        .find(|(_, at)| at.is_none())
                        .map_or("x_mm", |(name, _)| *name);
                    return Err(err(
                        n,
                        Some(missing),
                        "the truth's columns are x_mm,y_mm,force_g: all three or none".into(),
                    ));
                }
            };
            layout = Some((t_at, taxels, truth_at, cells.len()));
            continue;
        };
        if cells.len() != *width {
            return Err(err(
                n,
                None,
                format!("{} cells, the header has {width}", cells.len()),
            ));
        }
        let cell = |at: usize| cells.get(at).copied().unwrap_or("");
        let number = |at: usize, name: &str| -> Result<f64, RecordError> {
            cell(at)
                .parse::<f64>()
                .map_err(|_| err(n, Some(name), format!("'{}' is not a number", cell(at))))
        };
        let t = number(*t_at, "t_s")?;
        if !t.is_finite() {
            return Err(err(n, Some("t_s"), format!("time {t} is not finite")));
        }
        if let Some(&last) = rec.t_s.last() {
            if t < last {
                return Err(err(
                    n,
                    Some("t_s"),
                    format!("time {t} goes back (previous {last}): sort the rows by time"),
                ));
            }
        }
        let mut grid = [[0.0f32; COLS]; ROWS];
        for (i, (slot, &at)) in grid.iter_mut().flatten().zip(taxels).enumerate() {
            let v = number(at, &taxel_column(i))?;
            if v.is_infinite() {
                return Err(err(n, Some(&taxel_column(i)), "an infinite strain".into()));
            }
            *slot = v as f32;
        }
        let truth = match truth_at {
            Some(at) if at.iter().all(|&a| cell(a).is_empty()) => None,
            Some([x, y, f]) => {
                let (x, y, f) = (
                    number(*x, "x_mm")?,
                    number(*y, "y_mm")?,
                    number(*f, "force_g")?,
                );
                for (v, name) in [(x, "x_mm"), (y, "y_mm"), (f, "force_g")] {
                    if !v.is_finite() {
                        return Err(err(n, Some(name), format!("{v} is not a finite number")));
                    }
                }
                Some(Truth {
                    x_mm: x,
                    y_mm: y,
                    force_g: f,
                })
            }
            None => None,
        };
        rec.t_s.push(t);
        rec.strain_pct.push(grid);
        rec.truth.push(truth);
        rec.lines.push(n);
    }
    if layout.is_none() {
        return Err(RecordError {
            file: path.to_path_buf(),
            line: None,
            column: None,
            message: "no header: an empty frames record".into(),
        });
    }
    Ok(rec)
}

/// Writes a frames record with the truth's columns (`truth` beside `frames`, row by row).
pub fn write_frames_with_truth(
    path: &Path,
    meta: &[(String, String)],
    frames: &[(f64, StrainGrid)],
    truth: &[Truth],
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    for (k, v) in meta {
        writeln!(w, "# {k}={v}")?;
    }
    write!(w, "t_s")?;
    for i in 0..TAXELS {
        write!(w, ",{}", taxel_column(i))?;
    }
    writeln!(w, ",x_mm,y_mm,force_g")?;
    for ((t, grid), truth) in frames.iter().zip(truth) {
        write!(w, "{t:.4}")?;
        for v in grid.iter().flatten() {
            write!(w, ",{v:.5}")?;
        }
        writeln!(
            w,
            ",{:.4},{:.4},{:.3}",
            truth.x_mm, truth.y_mm, truth.force_g
        )?;
    }
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> String {
        let mut h = "t_s".to_string();
        for i in 0..TAXELS {
            h += &format!(",{}", taxel_column(i));
        }
        h
    }

    fn parse(text: &str) -> Result<FramesRecord, RecordError> {
        parse_frames(text.as_bytes(), Path::new("f.csv"))
    }

    #[test]
    fn frames_with_and_without_truth_read_and_bad_ones_are_named() {
        let row = |t: f64| {
            let mut r = format!("{t}");
            for i in 0..TAXELS {
                r += &format!(",{}", i as f64 * 0.01);
            }
            r
        };
        let plain = parse(&format!(
            "# a=b\n{}\n{}\n{}\n",
            header(),
            row(0.0),
            row(0.016)
        ))
        .unwrap();
        assert_eq!(plain.t_s, vec![0.0, 0.016]);
        assert_eq!(plain.strain_pct[1][7][7], 0.63);
        assert_eq!(plain.truth, vec![None, None]);
        let truth = parse(&format!(
            "{},x_mm,y_mm,force_g\n{},1.5,2.5,40\n{},,,\n",
            header(),
            row(0.0),
            row(0.1)
        ))
        .unwrap();
        assert_eq!(
            truth.truth[0],
            Some(Truth {
                x_mm: 1.5,
                y_mm: 2.5,
                force_g: 40.0
            })
        );
        assert_eq!(truth.truth[1], None);
        // A bad taxel reads NaN.
        let nan = row(0.0).replacen(",0.05,", ",NaN,", 1);
        assert!(parse(&format!("{}\n{nan}\n", header())).unwrap().strain_pct[0][0][5].is_nan());
        let e = parse(&format!(
            "{}\n{}\n",
            header(),
            row(0.0).replacen(",0.05,", ",x,", 1)
        ))
        .unwrap_err();
        assert_eq!(
            (e.line, e.column.as_deref()),
            (Some(2), Some("r0c5")),
            "{e}"
        );
        assert!(e.to_string().starts_with("f.csv:2: column 'r0c5'"), "{e}");
        let e = parse(&format!("{},x_mm\n", header())).unwrap_err();
        assert_eq!(e.column.as_deref(), Some("y_mm"), "{e}");
        let e = parse("t_s,r0c0\n0,1\n").unwrap_err();
        assert_eq!(
            (e.line, e.column.as_deref()),
            (Some(1), Some("r0c1")),
            "{e}"
        );
        let e = parse(&format!("{}\n{}\n{}\n", header(), row(1.0), row(0.5))).unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(3), Some("t_s")), "{e}");
        let e = parse(&format!("{}\n0,1\n", header())).unwrap_err();
        assert_eq!(e.line, Some(2), "{e}");
        assert!(parse("").is_err());
    }
}
