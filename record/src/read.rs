//! Reading a record: the header found in order, then the rows cut at line ends into a chunk
//! per core (a 600 s record at 1 kHz has 600 000 of them), each chunk's cells read on a thread
//! of its own, then the chunks' rows taken in order: a time that goes back refused, rows
//! stamped alike merged, and the first problem in the file the one reported.

use std::io::Read;
use std::path::Path;
use std::str::Utf8Error;

use crate::{logger, Record, RecordError, REQUIRED};

/// The least a chunk holds, bytes: a thread for less costs more than it saves.
const CHUNK_BYTES_MIN: usize = 1 << 20;

/// [`read_record`](crate::read_record) on any reader (`path` only names the source in errors).
pub fn parse_record(mut reader: impl Read, path: &Path) -> Result<Record, RecordError> {
    let err = |line: Option<usize>, column: Option<String>, message: String| RecordError {
        file: path.to_path_buf(),
        line,
        column,
        message,
    };
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| err(None, None, format!("unreadable: {e}")))?;
    let mut rec = Record::default();

    // The header, and the comments before it.
    let mut lines = Lines::new(&bytes);
    let header = loop {
        let Some((n, line)) = lines.next() else {
            return Err(err(
                None,
                None,
                "empty: no header line t_s,force_g,strain_pct".into(),
            ));
        };
        let line = line.map_err(|e| err(Some(n), None, format!("unreadable line: {e}")))?;
        match kind(line, n) {
            Line::Blank => {}
            Line::Meta(k, v) => rec.meta.push((k.to_string(), v.to_string())),
            Line::Cells(cells) => {
                break Header::read(cells).map_err(|(c, m)| err(Some(n), c, m))?
            }
        }
    };
    rec.extra = header
        .extra()
        .map(|c| (c.to_string(), Vec::new()))
        .collect();

    // Then the rows' cells, a chunk per core.
    let first_line = lines.line + 1;
    let chunks = split_at_lines(&bytes[lines.pos..]);
    let read: Vec<Chunk> = if let [one] = chunks.as_slice() {
        vec![Chunk::read(one, &header)]
    } else {
        std::thread::scope(|scope| {
            let header = &header;
            let runs: Vec<_> = chunks
                .iter()
                .map(|c| scope.spawn(move || Chunk::read(c, header)))
                .collect();
            runs.into_iter()
                .map(|r| r.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    drop(bytes);

    // Then the rows in order.
    let (merged, row_lines) =
        take_rows(&mut rec, read, &header, first_line).map_err(|(n, c, m)| err(Some(n), c, m))?;
    if rec.len() < 2 {
        return Err(err(
            None,
            None,
            format!("{} data rows; a record needs at least two", rec.len()),
        ));
    }
    rec.extra.retain(|(_, v)| v.iter().all(|x| x.is_finite()));
    logger::mend_time(&mut rec, merged)
        .map_err(|(k, message)| err(row_lines.get(k).copied(), Some("t_s".into()), message))?;
    // The columns grew by doubling: a 600 s record at 1 kHz would hold 3.6 MB unused in each.
    for v in [&mut rec.t_s, &mut rec.force_g, &mut rec.strain_pct]
        .into_iter()
        .chain(rec.extra.iter_mut().map(|(_, v)| v))
    {
        v.shrink_to_fit();
    }
    Ok(rec)
}

/// A problem found in the rows: its file line, its column (if one), what.
type RowError = (usize, Option<String>, String);

/// The chunks' rows into `rec` in order, from file line `first_line` on: time must not go back;
/// a row stamped with the time of the one before is averaged into it. The rows merged, and
/// each row's file line; `Err` the first problem in the file.
fn take_rows(
    rec: &mut Record,
    chunks: Vec<Chunk>,
    header: &Header,
    first_line: usize,
) -> Result<(usize, Vec<usize>), RowError> {
    let index = &header.index;
    let mut row_lines: Vec<usize> = Vec::new();
    // Rows averaged into the last one (with it), and rows merged in all.
    let (mut same_time, mut merged) = (1usize, 0usize);
    let mut line0 = first_line;
    for chunk in chunks {
        for (values, k) in chunk
            .values
            .chunks_exact(header.names.len())
            .zip(&chunk.lines)
        {
            let n = line0 + k;
            let t = values[index[0]];
            match rec.t_s.last() {
                Some(&last) if t < last => {
                    return Err((
                        n,
                        Some("t_s".into()),
                        format!("time {t} goes back (previous {last}): sort the rows by time"),
                    ))
                }
                Some(&last) if t == last => {
                    // A logger that stamps coarser than it samples: the rows are one sample.
                    same_time += 1;
                    merged += 1;
                    merge_row(rec, values, index, same_time);
                    continue;
                }
                _ => same_time = 1,
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
        if let Some((k, column, message)) = chunk.error {
            return Err((line0 + k, column, message));
        }
        rec.meta.extend(chunk.meta);
        line0 += chunk.count;
    }
    Ok((merged, row_lines))
}

/// A chunk of the rows, read.
struct Chunk {
    /// The rows' values one after the other, each as wide as the header.
    values: Vec<f64>,
    /// Each row's line, counted from the chunk's first (0).
    lines: Vec<usize>,
    /// The comments among the rows.
    meta: Vec<(String, String)>,
    /// The lines the chunk holds.
    count: usize,
    /// The first problem (its line from the chunk's first): the rows before it are read.
    error: Option<RowError>,
}

impl Chunk {
    fn read(bytes: &[u8], header: &Header) -> Chunk {
        let mut chunk = Chunk {
            values: Vec::new(),
            lines: Vec::new(),
            meta: Vec::new(),
            count: 0,
            error: None,
        };
        let mut row = Vec::with_capacity(header.names.len());
        let mut lines = Lines::new(bytes);
        for (n, line) in lines.by_ref() {
            let k = n - 1;
            let line = match line {
                Ok(line) => line,
                Err(e) => {
                    chunk.error = Some((k, None, format!("unreadable line: {e}")));
                    break;
                }
            };
            match kind(line, 0) {
                Line::Blank => {}
                Line::Meta(key, v) => chunk.meta.push((key.to_string(), v.to_string())),
                Line::Cells(cells) => {
                    if let Err((column, message)) = header.row_values(cells, &mut row) {
                        chunk.error = Some((k, column, message));
                        break;
                    }
                    chunk.values.extend_from_slice(&row);
                    chunk.lines.push(k);
                }
            }
        }
        chunk.count = lines.line;
        chunk
    }
}

/// A line's kind: blank (or a comment without a key), a comment `# key=value`, or cells.
enum Line<'a> {
    Blank,
    Meta(&'a str, &'a str),
    Cells(&'a str),
}

/// The kind of `line`, file line `n` (a spreadsheet's export may open with a byte-order mark).
fn kind(line: &str, n: usize) -> Line<'_> {
    let line = if n == 1 {
        line.strip_prefix('\u{feff}').unwrap_or(line)
    } else {
        line
    };
    let trimmed = line.trim();
    if trimmed.is_empty() {
        return Line::Blank;
    }
    match trimmed.strip_prefix('#') {
        Some(comment) => match comment.split_once('=') {
            Some((k, v)) => Line::Meta(k.trim(), v.trim()),
            None => Line::Blank,
        },
        None => Line::Cells(trimmed),
    }
}

/// The lines of a text, numbered from 1; where a line is not UTF-8, why.
struct Lines<'a> {
    bytes: &'a [u8],
    /// Where the next line starts.
    pos: usize,
    /// The lines given so far.
    line: usize,
}

impl<'a> Lines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Lines {
            bytes,
            pos: 0,
            line: 0,
        }
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, Result<&'a str, Utf8Error>);

    fn next(&mut self) -> Option<Self::Item> {
        let rest = self.bytes.get(self.pos..).filter(|r| !r.is_empty())?;
        let end = rest.iter().position(|b| *b == b'\n');
        let line = &rest[..end.unwrap_or(rest.len())];
        self.pos += end.map_or(rest.len(), |e| e + 1);
        self.line += 1;
        Some((self.line, std::str::from_utf8(line)))
    }
}

/// `bytes` cut after a line's end into one chunk per core, each at least
/// [`CHUNK_BYTES_MIN`] long (one chunk for less).
fn split_at_lines(bytes: &[u8]) -> Vec<&[u8]> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let count = cores.min(bytes.len() / CHUNK_BYTES_MIN).max(1);
    let mut chunks = Vec::with_capacity(count);
    let mut start = 0;
    for k in 1..count {
        let aim = (bytes.len() * k / count).max(start);
        let cut = bytes[aim..]
            .iter()
            .position(|b| *b == b'\n')
            .map_or(bytes.len(), |e| aim + e + 1);
        chunks.push(&bytes[start..cut]);
        start = cut;
    }
    chunks.push(&bytes[start..]);
    chunks
}

/// A record's header: its column names, and where the required ones are among them.
struct Header {
    names: Vec<String>,
    index: [usize; 3],
}

impl Header {
    /// The header line (trimmed); `Err`: the column and what is wrong with it.
    fn read(line: &str) -> Result<Header, (Option<String>, String)> {
        // Cells may be quoted (a quoted comma is not read: no column of the format holds one).
        let names: Vec<String> = line.split(',').map(|c| unquoted(c).to_string()).collect();
        // A column named twice: which of the two the reader took would be a guess.
        if let Some((i, twice)) = names
            .iter()
            .enumerate()
            .find(|(i, c)| !c.is_empty() && names[..*i].contains(c))
        {
            return Err((
                Some(twice.clone()),
                format!(
                    "the header names this column twice (cells {} and {})",
                    names.iter().position(|c| c == twice).map_or(0, |k| k + 1),
                    i + 1
                ),
            ));
        }
        let mut index = [0usize; 3];
        for (slot, want) in index.iter_mut().zip(REQUIRED) {
            *slot = names.iter().position(|c| c == want).ok_or_else(|| {
                (
                    Some(want.to_string()),
                    format!(
                        "header lacks the required column (found: {}){}",
                        shown(&names.join(",")),
                        separator_hint(&names)
                    ),
                )
            })?;
        }
        Ok(Header { names, index })
    }

    /// The names of the columns besides the required ones, in order.
    fn extra(&self) -> impl Iterator<Item = &str> {
        self.names
            .iter()
            .map(String::as_str)
            .filter(|c| !REQUIRED.contains(c))
    }

    /// A data row's values into `values`, in the header's order: the required columns strictly
    /// (a finite number), another column NaN where it holds no number (the column is left out
    /// after the reading). `Err`: the column (none for a row of the wrong length) and what is
    /// wrong, the length before any cell.
    fn row_values(
        &self,
        line: &str,
        values: &mut Vec<f64>,
    ) -> Result<(), (Option<String>, String)> {
        values.clear();
        let (mut cells, mut first_bad) = (0usize, None);
        for (j, cell) in line.split(',').map(unquoted).enumerate() {
            cells += 1;
            let Some(name) = self.names.get(j) else {
                continue;
            };
            let v = if self.index.contains(&j) {
                match cell.parse::<f64>() {
                    Ok(v) if v.is_finite() => v,
                    Ok(_) => {
                        first_bad.get_or_insert_with(|| {
                            (name, format!("'{}' is not finite", shown(cell)))
                        });
                        f64::NAN
                    }
                    Err(_) => {
                        first_bad.get_or_insert_with(|| {
                            (name, format!("'{}' is not a number", shown(cell)))
                        });
                        f64::NAN
                    }
                }
            } else {
                cell.parse().unwrap_or(f64::NAN)
            };
            values.push(v);
        }
        if cells != self.names.len() {
            return Err((
                None,
                format!("{} cells, the header has {}", cells, self.names.len()),
            ));
        }
        match first_bad {
            Some((name, message)) => Err((Some(name.clone()), message)),
            None => Ok(()),
        }
    }
}

/// Averages a row into the record's last one, which then stands for `rows` rows.
fn merge_row(rec: &mut Record, values: &[f64], index: &[usize; 3], rows: usize) {
    let mean = |old: &mut f64, new: f64| *old += (new - *old) / rows as f64;
    if let (Some(f), Some(e)) = (rec.force_g.last_mut(), rec.strain_pct.last_mut()) {
        mean(f, values[index[1]]);
        mean(e, values[index[2]]);
    }
    let mut extra = rec.extra.iter_mut();
    for (j, v) in values.iter().enumerate() {
        if !index.contains(&j) {
            if let Some(last) = extra.next().and_then(|(_, col)| col.last_mut()) {
                mean(last, *v);
            }
        }
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
