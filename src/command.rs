//! Commands from the host to a running board: small frames with sequence numbers,
//! written by the host's `tactile board` (through [`Command::encode`]) and read on the chip by
//! [`Decoder`], one byte at a time, without allocation or panic.
//!
//! A frame is `SYNC, LEN, SEQ (u16 LE), OP, ARGS…, CRC (u16 LE)`, where `LEN` counts `SEQ`,
//! `OP` and `ARGS`, and the CRC (CRC-16/IBM-3740) covers `LEN` through `ARGS`. A frame whose
//! CRC fails is dropped (counted; the host sees no acknowledgement and sends it again) and the
//! decoder resynchronizes on the next `SYNC`. A well-framed command with bad arguments is
//! returned as a [`Refusal`] with its sequence number, so the board can say why.
//!
//! ```
//! use tactile_core::command::{Command, Decoder, MAX_FRAME_BYTES};
//!
//! let mut frame = [0u8; MAX_FRAME_BYTES];
//! let n = Command::Hold { force_g: 30.0 }.encode(7, &mut frame);
//! let mut decoder = Decoder::new();
//! let mut bytes = &frame[..n];
//! let r = decoder.read(&mut bytes).unwrap();
//! assert_eq!((r.seq, r.command), (7, Ok(Command::Hold { force_g: 30.0 })));
//! ```

use crate::estimator::EstimatorKind;
use crate::seal::bytes_at;
use crate::tactile::{TaxelId, TAXELS};

/// First byte of every frame.
pub const SYNC: u8 = 0xA5;
/// Table bytes one [`Command::TableChunk`] carries at most.
pub const CHUNK_BYTES: usize = 64;
/// Longest body (`SEQ`, `OP`, `ARGS`): a table chunk.
pub const MAX_BODY_BYTES: usize = 3 + 4 + CHUNK_BYTES;
/// Longest frame.
pub const MAX_FRAME_BYTES: usize = 2 + MAX_BODY_BYTES + 2;
/// Shortest body: a sequence number and an opcode.
const MIN_BODY_BYTES: usize = 3;

/// A protocol the board can be told to run (the memo's, the calibration, the excitation).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Run {
    ForceSteps,
    /// The memo's pseudo-random protocol with its seed, cut to `duration_s`.
    PseudoRandom {
        seed: u32,
        duration_s: f32,
    },
    Sines,
    StepLoads,
    LowForce,
    /// The calibration protocol with the probe over `taxel`.
    Calibration {
        taxel: TaxelId,
    },
    /// The applicator's excitation about `preload_g` (the design's chirp).
    Excitation {
        preload_g: f32,
    },
}

impl Run {
    /// Its name in the records (`RunStart`), as the memo's protocols are named.
    pub fn name(self) -> &'static str {
        match self {
            Run::ForceSteps => "force-steps",
            Run::PseudoRandom { .. } => "pseudo-random",
            Run::Sines => "sines",
            Run::StepLoads => "step-loads",
            Run::LowForce => "low-force",
            Run::Calibration { .. } => "calibration",
            Run::Excitation { .. } => "excitation",
        }
    }

    /// The protocol it runs.
    pub fn protocol(self) -> crate::profile::Protocol {
        use crate::profile::Protocol;
        match self {
            Run::ForceSteps => Protocol::FORCE_STEPS_MEMO,
            Run::PseudoRandom { seed, duration_s } => {
                Protocol::pseudo_random_memo(u64::from(seed), duration_s)
            }
            Run::Sines => Protocol::SINES_MEMO,
            Run::StepLoads => Protocol::StepLoads,
            Run::LowForce => Protocol::LowForce { hold_s: 3.0 },
            Run::Calibration { .. } => Protocol::CALIBRATION,
            Run::Excitation { preload_g } => Protocol::design_excitation(preload_g),
        }
    }
}

/// Which table a chunk or a load is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableKind {
    /// The per-taxel calibration table ([`crate::calibration::CalibrationTable`]).
    Calibration,
    /// The designed force controller's table ([`crate::designed::DesignedConfig`]).
    Controller,
}

/// The force law the board runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControllerChoice {
    /// The memo's law A1.
    A1,
    /// The designed controller of the loaded table.
    Designed,
}

/// One command.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Run a protocol from its start.
    Run(Run),
    /// Hold a constant force, g.
    Hold { force_g: f32 },
    /// Stop: the safe output (actuator at zero), no protocol.
    Stop,
    /// Clear latched faults.
    ClearFaults,
    /// The force law for the next run.
    Controller(ControllerChoice),
    /// The array's estimator.
    Estimator(EstimatorKind),
    /// `len` bytes of a table at `offset` (into the board's loading buffer).
    TableChunk {
        table: TableKind,
        offset: u16,
        len: u8,
        data: [u8; CHUNK_BYTES],
    },
    /// The first `len` bytes of the loading buffer are a table: check it as at start-up and
    /// use it.
    LoadTable { table: TableKind, len: u16 },
}

/// Which argument a refusal is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Param {
    Protocol,
    Seed,
    DurationS,
    Taxel,
    PreloadG,
    ForceG,
    Controller,
    Estimator,
    Table,
    Offset,
    Length,
}

/// Why a well-framed command was not taken (nothing changed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    #[error("unknown command {op}")]
    UnknownCommand { op: u8 },
    #[error("command {op} takes other arguments ({len} bytes given)")]
    BadLength { op: u8, len: u8 },
    #[error("{param:?} is not finite")]
    NotFinite { param: Param },
    #[error("{param:?} is out of range")]
    OutOfRange { param: Param },
    #[error("the table was refused (as at start-up)")]
    TableRefused,
    #[error("the designed controller has no valid table")]
    NoControllerTable,
    #[error("{param:?}: not on this board")]
    Unsupported { param: Param },
}

/// A command as received: its sequence number and the command, or why it was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Received {
    pub seq: u16,
    pub command: Result<Command, Refusal>,
}

/// Limits a board checks commands against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest force the board may be told to hold or preload, g.
    pub max_force_g: f32,
    /// Longest open-ended protocol, s.
    pub max_duration_s: f32,
    /// Size of the board's table loading buffer, bytes.
    pub table_bytes: usize,
}

const OP_RUN: u8 = 1;
const OP_HOLD: u8 = 2;
const OP_STOP: u8 = 3;
const OP_CLEAR: u8 = 4;
const OP_CONTROLLER: u8 = 5;
const OP_ESTIMATOR: u8 = 6;
const OP_CHUNK: u8 = 7;
const OP_LOAD: u8 = 8;

fn crc16(bytes: &[u8]) -> u16 {
    const CRC: crc::Crc<u16, crc::NoTable> =
        crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_IBM_3740);
    CRC.checksum(bytes)
}

fn f32_at(a: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(bytes_at(a, at))
}

fn finite(x: f32, param: Param) -> Result<f32, Refusal> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(Refusal::NotFinite { param })
    }
}

fn table_kind(b: u8) -> Result<TableKind, Refusal> {
    match b {
        0 => Ok(TableKind::Calibration),
        1 => Ok(TableKind::Controller),
        _ => Err(Refusal::OutOfRange {
            param: Param::Table,
        }),
    }
}

impl Command {
    /// The table bytes a [`Command::TableChunk`] carries: the first `len` of its data (all of
    /// it for a `len` past [`CHUNK_BYTES`]); none for any other command.
    pub fn chunk_bytes(&self) -> &[u8] {
        match self {
            Command::TableChunk { len, data, .. } => data.get(..usize::from(*len)).unwrap_or(data),
            _ => &[],
        }
    }

    /// The chunks that carry `table` (its bytes in [`CHUNK_BYTES`] pieces, in order; a
    /// [`Command::LoadTable`] of its length then checks and loads it). Offsets wrap past
    /// 64 KiB, which no table reaches: the port refuses a load over its buffer.
    pub fn table_chunks(kind: TableKind, table: &[u8]) -> impl Iterator<Item = Command> + '_ {
        table
            .chunks(CHUNK_BYTES)
            .enumerate()
            .map(move |(i, chunk)| {
                let mut data = [0u8; CHUNK_BYTES];
                if let Some(head) = data.get_mut(..chunk.len()) {
                    head.copy_from_slice(chunk);
                }
                Command::TableChunk {
                    table: kind,
                    offset: (i * CHUNK_BYTES) as u16,
                    len: chunk.len() as u8,
                    data,
                }
            })
    }

    /// Parses a command from its opcode and arguments (format only; [`Command::check`] checks
    /// the values against a board's limits).
    pub fn parse(op: u8, a: &[u8]) -> Result<Command, Refusal> {
        let expect = |n: usize| {
            if a.len() == n {
                Ok(())
            } else {
                Err(Refusal::BadLength {
                    op,
                    len: a.len() as u8,
                })
            }
        };
        let byte = |i: usize| a.get(i).copied().unwrap_or(0);
        match op {
            OP_RUN => {
                expect(9)?;
                let (x, n) = (f32_at(a, 1), u32::from_le_bytes(bytes_at(a, 5)));
                let run = match byte(0) {
                    0 => Run::ForceSteps,
                    1 => Run::PseudoRandom {
                        seed: n,
                        duration_s: finite(x, Param::DurationS)?,
                    },
                    2 => Run::Sines,
                    3 => Run::StepLoads,
                    4 => Run::LowForce,
                    5 => Run::Calibration {
                        taxel: match usize::try_from(n) {
                            Ok(i) if i < TAXELS => TaxelId::from_index(i),
                            _ => {
                                return Err(Refusal::OutOfRange {
                                    param: Param::Taxel,
                                })
                            }
                        },
                    },
                    6 => Run::Excitation {
                        preload_g: finite(x, Param::PreloadG)?,
                    },
                    _ => {
                        return Err(Refusal::OutOfRange {
                            param: Param::Protocol,
                        })
                    }
                };
                Ok(Command::Run(run))
            }
            OP_HOLD => {
                expect(4)?;
                Ok(Command::Hold {
                    force_g: finite(f32_at(a, 0), Param::ForceG)?,
                })
            }
            OP_STOP => expect(0).map(|_| Command::Stop),
            OP_CLEAR => expect(0).map(|_| Command::ClearFaults),
            OP_CONTROLLER => {
                expect(1)?;
                match byte(0) {
                    0 => Ok(Command::Controller(ControllerChoice::A1)),
                    1 => Ok(Command::Controller(ControllerChoice::Designed)),
                    _ => Err(Refusal::OutOfRange {
                        param: Param::Controller,
                    }),
                }
            }
            OP_ESTIMATOR => {
                expect(1)?;
                EstimatorKind::ALL
                    .get(usize::from(byte(0)))
                    .map(|k| Command::Estimator(*k))
                    .ok_or(Refusal::OutOfRange {
                        param: Param::Estimator,
                    })
            }
            OP_CHUNK => {
                let data = a.get(3..).unwrap_or(&[]);
                if a.len() < 3 || data.len() > CHUNK_BYTES {
                    return Err(Refusal::BadLength {
                        op,
                        len: a.len() as u8,
                    });
                }
                let mut chunk = [0u8; CHUNK_BYTES];
                for (c, d) in chunk.iter_mut().zip(data) {
                    *c = *d;
                }
                Ok(Command::TableChunk {
                    table: table_kind(byte(0))?,
                    offset: u16::from_le_bytes(bytes_at(a, 1)),
                    len: data.len() as u8,
                    data: chunk,
                })
            }
            OP_LOAD => {
                expect(3)?;
                Ok(Command::LoadTable {
                    table: table_kind(byte(0))?,
                    len: u16::from_le_bytes(bytes_at(a, 1)),
                })
            }
            _ => Err(Refusal::UnknownCommand { op }),
        }
    }

    /// Checks the command's values against a board's limits.
    pub fn check(&self, limits: &Limits) -> Result<(), Refusal> {
        let force = |g: f32, param| {
            if (0.0..=limits.max_force_g).contains(&g) {
                Ok(())
            } else {
                Err(Refusal::OutOfRange { param })
            }
        };
        match *self {
            Command::Hold { force_g } => force(force_g, Param::ForceG),
            Command::Run(Run::Excitation { preload_g }) => force(preload_g, Param::PreloadG),
            Command::Run(Run::PseudoRandom { duration_s, .. })
                if !(duration_s > 0.0 && duration_s <= limits.max_duration_s) =>
            {
                Err(Refusal::OutOfRange {
                    param: Param::DurationS,
                })
            }
            Command::TableChunk { offset, len, .. }
                if usize::from(offset) + usize::from(len) > limits.table_bytes =>
            {
                Err(Refusal::OutOfRange {
                    param: Param::Offset,
                })
            }
            Command::LoadTable { len, .. } if usize::from(len) > limits.table_bytes => {
                Err(Refusal::OutOfRange {
                    param: Param::Length,
                })
            }
            _ => Ok(()),
        }
    }

    /// The command's frame with sequence number `seq`.
    pub fn frame(&self, seq: u16) -> Frame {
        let mut bytes = [0u8; MAX_FRAME_BYTES];
        let len = self.encode(seq, &mut bytes);
        Frame { bytes, len }
    }

    /// Writes the command's frame with sequence number `seq` into `out` (at least
    /// [`MAX_FRAME_BYTES`]); returns its length (0 if `out` is too short).
    pub fn encode(&self, seq: u16, out: &mut [u8]) -> usize {
        let mut args = [0u8; MAX_BODY_BYTES];
        let (op, n) = self.args(&mut args);
        let body = MIN_BODY_BYTES + n;
        let total = 2 + body + 2;
        let Some(frame) = out.get_mut(..total) else {
            return 0;
        };
        let mut w = 0;
        let mut put = |b: u8| {
            if let Some(x) = frame.get_mut(w) {
                *x = b;
            }
            w += 1;
        };
        put(SYNC);
        put(body as u8);
        seq.to_le_bytes().into_iter().for_each(&mut put);
        put(op);
        args.iter().take(n).for_each(|b| put(*b));
        let crc = crc16(frame.get(1..2 + body).unwrap_or(&[]));
        for (x, b) in frame.iter_mut().skip(2 + body).zip(crc.to_le_bytes()) {
            *x = b;
        }
        total
    }

    /// The opcode and the arguments written into `a`, with their length.
    fn args(&self, a: &mut [u8; MAX_BODY_BYTES]) -> (u8, usize) {
        let mut put = |at: usize, bytes: &[u8]| {
            for (x, b) in a.iter_mut().skip(at).zip(bytes) {
                *x = *b;
            }
        };
        match *self {
            Command::Run(run) => {
                let (id, x, n) = match run {
                    Run::ForceSteps => (0, 0.0, 0),
                    Run::PseudoRandom { seed, duration_s } => (1, duration_s, seed),
                    Run::Sines => (2, 0.0, 0),
                    Run::StepLoads => (3, 0.0, 0),
                    Run::LowForce => (4, 0.0, 0),
                    Run::Calibration { taxel } => (5, 0.0, taxel.index() as u32),
                    Run::Excitation { preload_g } => (6, preload_g, 0),
                };
                put(0, &[id]);
                put(1, &f32::to_le_bytes(x));
                put(5, &n.to_le_bytes());
                (OP_RUN, 9)
            }
            Command::Hold { force_g } => {
                put(0, &force_g.to_le_bytes());
                (OP_HOLD, 4)
            }
            Command::Stop => (OP_STOP, 0),
            Command::ClearFaults => (OP_CLEAR, 0),
            Command::Controller(c) => {
                put(0, &[c as u8]);
                (OP_CONTROLLER, 1)
            }
            Command::Estimator(k) => {
                let i = EstimatorKind::ALL.iter().position(|e| *e == k).unwrap_or(0);
                put(0, &[i as u8]);
                (OP_ESTIMATOR, 1)
            }
            Command::TableChunk { table, offset, .. } => {
                let bytes = self.chunk_bytes();
                put(0, &[table as u8]);
                put(1, &offset.to_le_bytes());
                put(3, bytes);
                (OP_CHUNK, 3 + bytes.len())
            }
            Command::LoadTable { table, len } => {
                put(0, &[table as u8]);
                put(1, &len.to_le_bytes());
                (OP_LOAD, 3)
            }
        }
    }
}

/// A command's frame, as [`Command::frame`] writes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame {
    bytes: [u8; MAX_FRAME_BYTES],
    len: usize,
}

impl Frame {
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }
}

/// Reads frames from a byte stream: [`Decoder::push`] each byte, then take what is complete
/// with [`Decoder::next_frame`] until it returns `None`; or both at once with
/// [`Decoder::read`].
#[derive(Clone, Debug)]
pub struct Decoder {
    buf: [u8; MAX_FRAME_BYTES],
    len: usize,
    dropped: u32,
    /// The stream paused ([`Decoder::idle`]): a frame still incomplete will not complete.
    gap: bool,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    pub const fn new() -> Decoder {
        Decoder {
            buf: [0; MAX_FRAME_BYTES],
            len: 0,
            dropped: 0,
            gap: false,
        }
    }

    /// The stream paused (the board calls this when a poll brings no bytes): a frame still
    /// incomplete then is a false start (a sync byte in noise, with a long length), and the
    /// frames behind it are read at the next [`Decoder::next_frame`]. Without it, a false
    /// start waits for up to [`MAX_FRAME_BYTES`] more bytes while the host waits for an
    /// acknowledgement.
    pub fn idle(&mut self) {
        self.gap = self.len > 0;
    }

    /// Frames dropped so far (a failed CRC, an impossible length, bytes between frames).
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Takes one byte of the stream.
    pub fn push(&mut self, byte: u8) {
        if self.len == MAX_FRAME_BYTES {
            // Not polled: the oldest byte goes (no frame is longer than the buffer).
            self.skip(1);
        }
        if let Some(x) = self.buf.get_mut(self.len) {
            *x = byte;
            self.len += 1;
        }
    }

    /// The next frame of the stream: what was pushed, then the bytes at the front of `bytes`
    /// pushed one at a time until a frame is complete (the rest left in `bytes` for the next
    /// call). `None` once every byte is pushed and no frame is complete.
    pub fn read(&mut self, bytes: &mut &[u8]) -> Option<Received> {
        loop {
            if let Some(r) = self.next_frame() {
                return Some(r);
            }
            let (&b, rest) = bytes.split_first()?;
            *bytes = rest;
            self.push(b);
        }
    }

    /// The next complete frame in what was pushed, if any.
    pub fn next_frame(&mut self) -> Option<Received> {
        loop {
            // To the next sync byte.
            let start = self.pending().iter().position(|b| *b == SYNC);
            match start {
                None => {
                    if self.len > 0 {
                        self.dropped += 1;
                    }
                    self.len = 0;
                    self.gap = false;
                    return None;
                }
                Some(0) => {}
                Some(i) => {
                    self.dropped += 1;
                    self.skip(i);
                }
            }
            let complete = self.pending().get(1).and_then(|b| {
                let body = usize::from(*b);
                (2 + body + 2 <= self.len).then_some(body)
            });
            let body = match (self.pending().get(1), complete) {
                (Some(b), _) if !(MIN_BODY_BYTES..=MAX_BODY_BYTES).contains(&usize::from(*b)) => {
                    self.dropped += 1;
                    self.skip(1);
                    continue;
                }
                (_, Some(body)) => body,
                // Incomplete: wait for more, unless the stream paused.
                _ if self.gap => {
                    self.dropped += 1;
                    self.skip(1);
                    continue;
                }
                _ => return None,
            };
            let frame = self.pending().get(..2 + body + 2).unwrap_or(&[]);
            let stored = u16::from_le_bytes(bytes_at(frame, 2 + body));
            if crc16(frame.get(1..2 + body).unwrap_or(&[])) != stored {
                self.dropped += 1;
                self.skip(1);
                continue;
            }
            let b = frame.get(2..2 + body).unwrap_or(&[]);
            let seq = u16::from_le_bytes(bytes_at(b, 0));
            let op = b.get(2).copied().unwrap_or(0);
            let command = Command::parse(op, b.get(3..).unwrap_or(&[]));
            self.skip(2 + body + 2);
            return Some(Received { seq, command });
        }
    }

    fn pending(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// Drops the first `n` pending bytes.
    fn skip(&mut self, n: usize) {
        let n = n.min(self.len);
        // Byte by byte rather than `copy_within`, whose bounds check pulls core's formatting
        // of a slice index onto the firmware.
        for i in 0..self.len - n {
            if let Some(&b) = self.buf.get(i + n) {
                if let Some(d) = self.buf.get_mut(i) {
                    *d = b;
                }
            }
        }
        self.len -= n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(c: &Command, seq: u16) -> Vec<u8> {
        c.frame(seq).as_bytes().to_vec()
    }

    fn decode_all(mut bytes: &[u8]) -> (Vec<Received>, u32) {
        let mut d = Decoder::new();
        let mut out: Vec<Received> = core::iter::from_fn(|| d.read(&mut bytes)).collect();
        d.idle();
        out.extend(core::iter::from_fn(|| d.next_frame()));
        (out, d.dropped())
    }

    pub(crate) fn examples() -> Vec<Command> {
        let mut data = [0u8; CHUNK_BYTES];
        data.iter_mut().enumerate().for_each(|(i, d)| *d = i as u8);
        vec![
            Command::Run(Run::ForceSteps),
            Command::Run(Run::PseudoRandom {
                seed: 1989,
                duration_s: 10.0,
            }),
            Command::Run(Run::Sines),
            Command::Run(Run::StepLoads),
            Command::Run(Run::LowForce),
            Command::Run(Run::Calibration {
                taxel: TaxelId::new(3, 2).unwrap(),
            }),
            Command::Run(Run::Excitation { preload_g: 35.0 }),
            Command::Hold { force_g: 12.5 },
            Command::Stop,
            Command::ClearFaults,
            Command::Controller(ControllerChoice::A1),
            Command::Controller(ControllerChoice::Designed),
            Command::Estimator(EstimatorKind::Observer),
            Command::TableChunk {
                table: TableKind::Controller,
                offset: 256,
                len: 40,
                data: {
                    let mut d = data;
                    d[40..].iter_mut().for_each(|x| *x = 0);
                    d
                },
            },
            Command::TableChunk {
                table: TableKind::Calibration,
                offset: 0,
                len: CHUNK_BYTES as u8,
                data,
            },
            Command::LoadTable {
                table: TableKind::Calibration,
                len: 716,
            },
        ]
    }

    #[test]
    fn a_table_in_chunks_reassembles_to_itself() {
        let table: [u8; 150] = core::array::from_fn(|i| (i * 7) as u8);
        let mut back = [0u8; 150];
        let mut count = 0;
        for c in Command::table_chunks(TableKind::Controller, &table) {
            let Command::TableChunk {
                table: kind,
                offset,
                len,
                data,
            } = c
            else {
                panic!("{c:?}");
            };
            assert_eq!(kind, TableKind::Controller);
            let (at, len) = (usize::from(offset), usize::from(len));
            back[at..at + len].copy_from_slice(&data[..len]);
            // Past its length a chunk is zeros (what its frame carries is only `len` bytes).
            assert!(data[len..].iter().all(|b| *b == 0));
            count += 1;
        }
        // 64 + 64 + 22 bytes.
        assert_eq!(count, 3);
        assert_eq!(back, table);
    }

    #[test]
    fn every_command_survives_its_frame() {
        for (i, c) in examples().iter().enumerate() {
            let (got, dropped) = decode_all(&frame(c, 1000 + i as u16));
            assert_eq!(dropped, 0, "{c:?}");
            assert_eq!(
                got,
                [Received {
                    seq: 1000 + i as u16,
                    command: Ok(*c)
                }]
            );
        }
    }

    #[test]
    fn a_frame_by_hand() {
        // Stop with sequence number 0x0102: A5, LEN 3, 02 01, 03, then the CRC-16/IBM-3740
        // (init 0xFFFF, poly 0x1021, no reflection) of 03 02 01 03.
        let f = frame(&Command::Stop, 0x0102);
        assert_eq!(&f[..5], &[SYNC, 3, 0x02, 0x01, OP_STOP]);
        let crc = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740).checksum(&[3, 2, 1, 3]);
        assert_eq!(f[5..], crc.to_le_bytes());
        // The check value of the catalogue: "123456789" → 0x29B1.
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn a_corrupt_frame_is_dropped_and_the_next_is_read() {
        let mut bytes = frame(&Command::Hold { force_g: 5.0 }, 1);
        bytes[6] ^= 0x40;
        bytes.extend(frame(&Command::ClearFaults, 2));
        let (got, dropped) = decode_all(&bytes);
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].seq, 2);
        assert!(dropped >= 1);
        // Garbage with sync bytes and long lengths before a frame: the frame still comes out.
        let mut bytes = vec![SYNC, 200, SYNC, 70, 1, 2, 3, SYNC];
        bytes.extend(frame(&Command::Stop, 9));
        let (got, _) = decode_all(&bytes);
        assert_eq!(
            got,
            [Received {
                seq: 9,
                command: Ok(Command::Stop)
            }]
        );
    }

    #[test]
    fn bad_arguments_are_refused_with_the_reason() {
        let raw = |op: u8, args: &[u8]| {
            let mut body = vec![(MIN_BODY_BYTES + args.len()) as u8, 5, 0, op];
            body.extend(args);
            let crc = crc16(&body);
            let mut f = vec![SYNC];
            f.extend(body);
            f.extend(crc.to_le_bytes());
            decode_all(&f).0
        };
        let refused = |op, args: &[u8]| raw(op, args)[0].command.unwrap_err();
        assert_eq!(refused(42, &[]), Refusal::UnknownCommand { op: 42 });
        assert_eq!(refused(OP_STOP, &[1]), Refusal::BadLength { op: 3, len: 1 });
        assert_eq!(
            refused(OP_HOLD, &f32::NAN.to_le_bytes()),
            Refusal::NotFinite {
                param: Param::ForceG
            }
        );
        assert_eq!(
            refused(OP_RUN, &[5, 0, 0, 0, 0, 64, 0, 0, 0]),
            Refusal::OutOfRange {
                param: Param::Taxel
            }
        );
        assert_eq!(
            refused(OP_CONTROLLER, &[2]),
            Refusal::OutOfRange {
                param: Param::Controller
            }
        );
        assert_eq!(
            refused(OP_ESTIMATOR, &[5]),
            Refusal::OutOfRange {
                param: Param::Estimator
            }
        );
        assert_eq!(raw(OP_STOP, &[])[0].seq, 5);
    }

    #[test]
    fn values_are_checked_against_the_boards_limits() {
        let limits = Limits {
            max_force_g: 120.0,
            max_duration_s: 600.0,
            table_bytes: 1024,
        };
        assert_eq!(Command::Hold { force_g: 120.0 }.check(&limits), Ok(()));
        for bad in [
            Command::Hold { force_g: 121.0 },
            Command::Hold { force_g: -1.0 },
            Command::Run(Run::Excitation { preload_g: 500.0 }),
            Command::Run(Run::PseudoRandom {
                seed: 1,
                duration_s: 0.0,
            }),
            Command::LoadTable {
                table: TableKind::Controller,
                len: 1025,
            },
            Command::TableChunk {
                table: TableKind::Controller,
                offset: 1000,
                len: 25,
                data: [0; CHUNK_BYTES],
            },
        ] {
            assert!(
                matches!(bad.check(&limits), Err(Refusal::OutOfRange { .. })),
                "{bad:?}"
            );
        }
    }
}
