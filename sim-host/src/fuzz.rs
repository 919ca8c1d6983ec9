//! A small, seeded mutation fuzzer for the parsers (record CSV, command-line specs, defmt logs).
//! It runs on stable Rust inside ordinary tests: mutations of a checked-in corpus, each input
//! fed to the parser under `catch_unwind`. Not coverage-guided; a bounded run in every test
//! command, the same inputs every time.

use tactile_plant::noise::Noise;

/// Tokens that parsers of numbers and CSV tend to mishandle.
const TOKENS: [&str; 18] = [
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e400",
    "-1e-400",
    "",
    ",",
    ",,",
    "\n",
    "\r\n",
    "#",
    "=",
    "0x1f",
    "\u{661}",
    "\u{feff}",
    "-0",
    "99999999999999999999999999",
];

pub struct Mutator {
    noise: Noise,
}

impl Mutator {
    pub fn new(seed: u64) -> Self {
        Self {
            noise: Noise::new(seed),
        }
    }

    fn below(&mut self, n: usize) -> usize {
        ((self.noise.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// One to four random edits of `input`, sometimes spliced with another corpus entry.
    pub fn mutate(&mut self, input: &[u8], corpus: &[Vec<u8>]) -> Vec<u8> {
        let mut v = input.to_vec();
        let edits = 1 + self.below(4);
        for _ in 0..edits {
            let len = v.len();
            match self.below(8) {
                0 if len > 0 => {
                    let i = self.below(len);
                    v[i] ^= 1 << self.below(8);
                }
                1 if len > 0 => {
                    let i = self.below(len);
                    const BYTES: &[u8] = b"\0\xff,\n#-.e9 ";
                    v[i] = BYTES[self.below(BYTES.len())];
                }
                2 => {
                    let i = self.below(len + 1);
                    let t = TOKENS[self.below(TOKENS.len())].as_bytes();
                    v.splice(i..i, t.iter().copied());
                }
                3 if len > 0 => {
                    let a = self.below(len);
                    let b = (a + 1 + self.below(64)).min(len);
                    v.drain(a..b);
                }
                4 if len > 0 => {
                    let a = self.below(len);
                    let b = (a + 1 + self.below(64)).min(len);
                    let piece: Vec<u8> = v[a..b].to_vec();
                    let at = self.below(len + 1);
                    v.splice(at..at, piece);
                }
                5 if len > 0 => v.truncate(self.below(len)),
                6 if !corpus.is_empty() => {
                    let other = &corpus[self.below(corpus.len())];
                    let cut = self.below(v.len() + 1);
                    let from = self.below(other.len() + 1);
                    v.truncate(cut);
                    v.extend_from_slice(&other[from..]);
                }
                _ => {
                    // Swap two lines.
                    let text = String::from_utf8_lossy(&v).into_owned();
                    let mut lines: Vec<&str> = text.lines().collect();
                    if lines.len() > 2 {
                        let (a, b) = (self.below(lines.len()), self.below(lines.len()));
                        lines.swap(a, b);
                        v = lines.join("\n").into_bytes();
                    }
                }
            }
        }
        v
    }
}

/// Runs `iterations` mutated inputs through `target`; returns the first input that panicked.
pub fn run(
    seed: u64,
    corpus: &[Vec<u8>],
    iterations: usize,
    mut target: impl FnMut(&[u8]),
) -> Option<Vec<u8>> {
    let mut m = Mutator::new(seed);
    let mut failure = None;
    for i in 0..iterations {
        let Some(base) = corpus.get(i % corpus.len().max(1)) else {
            break;
        };
        let input = if i < corpus.len() {
            base.clone()
        } else {
            m.mutate(base, corpus)
        };
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| target(&input)));
        if outcome.is_err() {
            failure = Some(input);
            break;
        }
    }
    failure
}

/// Reads every file of a corpus folder.
pub fn load_corpus(dir: &std::path::Path) -> std::io::Result<Vec<Vec<u8>>> {
    let mut files: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .collect();
    files.sort();
    files.iter().map(std::fs::read).collect()
}
