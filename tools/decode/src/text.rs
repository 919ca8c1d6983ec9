//! Parsing the text defmt's `Format` derives produce: `Name { field: value, … }`, with values
//! that are numbers, `true`/`false`, bare strings, tuple structs `Name(value)` and nested
//! arrays `[[1, 2], [3, 4]]`. Nothing here panics on any input.

use std::str::FromStr;

/// One `Name { … }` group of a message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Struct {
    pub name: String,
    /// The text between the braces.
    pub body: String,
}

/// The top-level `Name { … }` groups of a message, in order.
pub fn parse_structs(text: &str) -> Vec<Struct> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        // An identifier followed by " {".
        if bytes.get(i).is_some_and(|b| b.is_ascii_alphabetic())
            && (i == 0
                || !bytes
                    .get(i - 1)
                    .is_some_and(|b| b.is_ascii_alphanumeric() || *b == b'_'))
        {
            let start = i;
            let mut j = i;
            while bytes
                .get(j)
                .is_some_and(|b| b.is_ascii_alphanumeric() || *b == b'_')
            {
                j += 1;
            }
            if text.get(j..).is_some_and(|t| t.starts_with(" {")) {
                let open = j + 1;
                if let Some(close) = matching(bytes, open) {
                    out.push(Struct {
                        name: text.get(start..j).unwrap_or_default().to_string(),
                        body: text
                            .get(open + 1..close)
                            .unwrap_or_default()
                            .trim()
                            .to_string(),
                    });
                    i = close + 1;
                    continue;
                }
            }
            i = j.max(i + 1);
            continue;
        }
        i += 1;
    }
    out
}

/// Index of the bracket closing the one at `open`.
fn matching(bytes: &[u8], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (k, &b) in bytes.iter().enumerate().skip(open) {
        match b {
            b'{' | b'[' | b'(' => depth += 1,
            b'}' | b']' | b')' => {
                depth = depth.checked_sub(1)?;
                if depth == 0 {
                    return Some(k);
                }
            }
            _ => {}
        }
    }
    None
}

/// Splits at commas outside brackets.
fn split_top(text: &str) -> Vec<&str> {
    let mut parts = Vec::new();
    let mut depth = 0i32;
    let mut start = 0;
    for (k, c) in text.char_indices() {
        match c {
            '{' | '[' | '(' => depth += 1,
            '}' | ']' | ')' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(text.get(start..k).unwrap_or_default().trim());
                start = k + 1;
            }
            _ => {}
        }
    }
    let last = text.get(start..).unwrap_or_default().trim();
    if !last.is_empty() {
        parts.push(last);
    }
    parts
}

/// The fields of a struct, by name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fields<'a> {
    pub name: &'a str,
    pub fields: Vec<(&'a str, &'a str)>,
}

impl Struct {
    pub fn fields(&self) -> Fields<'_> {
        Fields {
            name: &self.name,
            fields: split_top(&self.body)
                .into_iter()
                .filter_map(|f| f.split_once(':'))
                .map(|(k, v)| (k.trim(), v.trim()))
                .collect(),
        }
    }
}

impl Fields<'_> {
    /// The raw text of a field (a string without its quotes).
    pub fn text(&self, key: &str) -> Result<&str, String> {
        self.fields
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| {
                v.strip_prefix('"')
                    .and_then(|u| u.strip_suffix('"'))
                    .unwrap_or(v)
            })
            .ok_or_else(|| format!("{} lacks field '{key}'", self.name))
    }

    /// A number (integer or float, as its type parses it; `NaN` and `inf` for floats).
    pub fn num<T: FromStr>(&self, key: &str) -> Result<T, String> {
        let v = self.text(key)?;
        v.parse().map_err(|_| {
            format!(
                "{}.{key}: '{v}' is not a number of the expected type",
                self.name
            )
        })
    }

    pub fn flag(&self, key: &str) -> Result<bool, String> {
        match self.text(key)? {
            "true" => Ok(true),
            "false" => Ok(false),
            v => Err(format!("{}.{key}: '{v}' is not true or false", self.name)),
        }
    }

    /// A number wrapped in a tuple struct: `Wrapper(3)`.
    pub fn wrapped_num<T: FromStr>(&self, key: &str, wrapper: &str) -> Result<T, String> {
        let v = self.text(key)?;
        let inner = v
            .strip_prefix(wrapper)
            .and_then(|r| r.strip_prefix('('))
            .and_then(|r| r.strip_suffix(')'))
            .ok_or_else(|| format!("{}.{key}: '{v}' is not {wrapper}(…)", self.name))?;
        inner
            .trim()
            .parse()
            .map_err(|_| format!("{}.{key}: '{inner}' is not a number", self.name))
    }

    /// Every number of a (nested) array, flattened in order.
    pub fn numbers<T: FromStr>(&self, key: &str) -> Result<Vec<T>, String> {
        let v = self.text(key)?;
        if !v.starts_with('[') {
            return Err(format!("{}.{key}: '{v}' is not an array", self.name));
        }
        v.split(['[', ']', ','])
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|s| {
                s.parse()
                    .map_err(|_| format!("{}.{key}: '{s}' is not a number", self.name))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_nested_structs_arrays_and_wrappers() {
        let s = parse_structs(
            "ControlFrame { seq: 3, tick: 4, command_g: 1.5, faults: FaultFlags(128) } \
             SimTruth { tick: 4, true_force_g: -0.0, in_contact: false }",
        );
        assert_eq!(s.len(), 2);
        let f = s[0].fields();
        assert_eq!(f.num::<u32>("seq"), Ok(3));
        assert_eq!(f.num::<f32>("command_g"), Ok(1.5));
        assert_eq!(f.wrapped_num::<u16>("faults", "FaultFlags"), Ok(128));
        assert!(f
            .num::<u32>("missing")
            .unwrap_err()
            .contains("lacks field 'missing'"));
        assert_eq!(s[1].fields().flag("in_contact"), Ok(false));
        let t = parse_structs("TaxelFrame { seq: 0, cells: [[1, -2], [3, 4]], bad: 0 }");
        assert_eq!(t[0].fields().numbers::<i16>("cells"), Ok(vec![1, -2, 3, 4]));
        let r = parse_structs("RunStart { name: force-steps, start_tick: 0, duration_s: 10.5 }");
        assert_eq!(r[0].fields().text("name"), Ok("force-steps"));
    }

    #[test]
    fn garbage_gives_errors_not_panics() {
        for text in [
            "",
            "{",
            "}",
            "A {",
            "A { b: [[1, 2 }",
            "A { x }",
            "ü { ä: ö }",
            "A {{{{",
        ] {
            for s in parse_structs(text) {
                let f = s.fields();
                let _ = f.num::<u32>("x");
                let _ = f.numbers::<i16>("b");
                let _ = f.wrapped_num::<u16>("x", "W");
            }
        }
        let s = parse_structs("A { n: 1e99, f: NaN, w: W(x) }");
        assert!(s[0].fields().num::<u32>("n").is_err());
        assert!(s[0].fields().num::<f32>("f").is_ok_and(f32::is_nan));
        assert!(s[0].fields().wrapped_num::<u16>("w", "W").is_err());
    }
}
