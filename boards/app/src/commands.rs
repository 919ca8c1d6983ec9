//! The board's end of the command channel: bytes from the host's down-channel
//! (RTT on a board, a script under QEMU) through the core's [`Decoder`], each command checked
//! against the board's [`Limits`] and answered with a [`Reply`] carrying its sequence number.
//! What a command asks of the tasks (start a run, stop, clear faults) comes back as an
//! [`Action`]; the settings (the force law, the array's estimator, a loaded controller table,
//! a loaded calibration table) stay here and shape the next run ([`CommandPort::firmware`],
//! [`CommandPort::calibration_table`]). Nothing here blocks: a poll takes the bytes that have
//! arrived and returns. `CAL` is the room for a calibration table (0: none can be loaded, as on
//! a board whose RAM is spoken for).

use core::sync::atomic::{AtomicU8, Ordering};

use tactile_core::calibration::TableView;
use tactile_core::command::{
    Command, ControllerChoice, Decoder, Limits, Param, Refusal, Run, TableKind,
};
use tactile_core::designed::{DesignedConfig, TABLE_BYTES};
use tactile_core::estimator::EstimatorKind;
use tactile_core::tasks::FirmwareConfig;

/// A command taken (`Ok`) or refused with the reason; its sequence number either way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reply {
    pub seq: u16,
    pub result: Result<(), Refusal>,
}

/// On the wire as `CommandAck { seq }` or `CommandRefused { seq, reason }`.
#[cfg(feature = "defmt")]
impl defmt::Format for Reply {
    fn format(&self, f: defmt::Formatter) {
        match self.result {
            Ok(()) => defmt::write!(f, "CommandAck {{ seq: {=u16} }}", self.seq),
            Err(reason) => defmt::write!(
                f,
                "CommandRefused {{ seq: {=u16}, reason: {} }}",
                self.seq,
                reason
            ),
        }
    }
}

/// What a taken command asks of the tasks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Nothing beyond the setting it changed.
    None,
    /// Start this run now (ending the one in progress).
    Start(Run),
    /// Hold this force until told otherwise (ending the run in progress).
    Hold {
        force_g: f32,
    },
    /// End the run in progress; the actuator to its safe output.
    Stop,
    ClearFaults,
}

/// The command channel's state on the board.
#[derive(Clone, Debug)]
pub struct CommandPort<const CAL: usize> {
    decoder: Decoder,
    limits: Limits,
    controller: ControllerChoice,
    estimator: Option<EstimatorKind>,
    /// The controller table being loaded, and the one loaded (checked) last.
    loading: [u8; TABLE_BYTES],
    loaded: Option<DesignedConfig>,
    /// The calibration table: its bytes, and the length of the one loaded (checked) last. A
    /// chunk unloads it (the next run then uses the build's) until the new one is loaded: one
    /// buffer, where RAM is short.
    cal: [u8; CAL],
    cal_len: usize,
    /// Ticks since the last byte.
    quiet: u16,
}

/// Room for a calibration table loaded by command on a board that has it: eight taxels (about
/// 3 KB; a build's own table may calibrate the whole array).
pub const LOADED_TABLE_BYTES: usize = tactile_core::calibration::table_bytes(8);

/// How long a commanded hold lasts at most, s (a `Stop` or the next run ends it sooner), and
/// the longest open-ended run a command may ask for.
pub const HOLD_S: f32 = 3600.0;

/// The protocol of a commanded hold: `force_g` from now on.
pub fn hold(force_g: f32) -> tactile_core::profile::Protocol {
    tactile_core::profile::Protocol::Step {
        load_g: force_g,
        lead_s: 0.0,
        on_s: HOLD_S,
        off_s: 0.0,
    }
}

/// Ticks without a byte after which a frame still incomplete is given up, 20 ms: a host writes
/// a frame in one go, and a frame split by the ring buffer's wrap arrives within a tick or two.
pub const QUIET_TICKS: u16 = 20;

impl<const CAL: usize> CommandPort<CAL> {
    /// A port checking forces against `max_force_g` and open-ended runs against
    /// `max_duration_s`.
    pub fn new(max_force_g: f32, max_duration_s: f32) -> Self {
        CommandPort {
            decoder: Decoder::new(),
            limits: Limits {
                max_force_g,
                max_duration_s,
                table_bytes: TABLE_BYTES.max(CAL),
            },
            controller: ControllerChoice::A1,
            estimator: None,
            loading: [0; TABLE_BYTES],
            loaded: None,
            cal: [0; CAL],
            cal_len: 0,
            quiet: 0,
        }
    }

    /// The same port with `choice` as the force law until a command chooses another (a build
    /// that runs the designed controller from reset).
    pub fn with_controller(self, choice: ControllerChoice) -> Self {
        CommandPort {
            controller: choice,
            ..self
        }
    }

    /// The calibration table loaded last (checked), if any.
    pub fn calibration_table(&self) -> Option<&[u8]> {
        self.cal.get(..self.cal_len).filter(|t| !t.is_empty())
    }

    /// Copies the calibration table loaded last into `buf` and returns its length (0: none
    /// loaded, or longer than `buf`): a task that rebuilds its estimators from it holds the
    /// port only for the copy, not for the rebuild.
    pub fn copy_calibration_table(&self, buf: &mut [u8]) -> usize {
        let table = self.calibration_table().unwrap_or(&[]);
        buf.get_mut(..table.len())
            .map(|dst| copy(dst, table))
            .map_or(0, |()| table.len())
    }

    /// Frames dropped by the decoder (failed checks, noise).
    pub fn dropped(&self) -> u32 {
        self.decoder.dropped()
    }

    /// Takes one tick's bytes from the down-channel (none, most ticks) and hands each command's
    /// reply and action to `out`, in order. After [`QUIET_TICKS`] ticks without a byte, a frame
    /// still incomplete is dropped (a false start in noise, or a host that stopped mid-frame),
    /// so the frames behind it are read.
    pub fn poll(&mut self, mut bytes: &[u8], compiled: &[u8], mut out: impl FnMut(Reply, Action)) {
        if bytes.is_empty() {
            self.quiet = self.quiet.saturating_add(1);
            if self.quiet == QUIET_TICKS {
                self.decoder.idle();
            }
        } else {
            self.quiet = 0;
        }
        while let Some(r) = self.decoder.read(&mut bytes) {
            let (result, action) = self.apply(r.command, compiled);
            out(Reply { seq: r.seq, result }, action);
        }
    }

    /// One command: checked, then applied (a refused one changes nothing). `compiled` is the
    /// controller table the build carries.
    fn apply(
        &mut self,
        command: Result<Command, Refusal>,
        compiled: &[u8],
    ) -> (Result<(), Refusal>, Action) {
        let command = match command.and_then(|c| c.check(&self.limits).map(|_| c)) {
            Ok(c) => c,
            Err(e) => return (Err(e), Action::None),
        };
        let action = match command {
            Command::Run(run) => Action::Start(run),
            Command::Hold { force_g } => Action::Hold { force_g },
            Command::Stop => Action::Stop,
            Command::ClearFaults => Action::ClearFaults,
            Command::Controller(choice) => {
                if choice == ControllerChoice::Designed && self.designed(compiled).is_none() {
                    return (Err(Refusal::NoControllerTable), Action::None);
                }
                self.controller = choice;
                Action::None
            }
            Command::Estimator(kind) => {
                self.estimator = Some(kind);
                Action::None
            }
            Command::TableChunk { table, offset, .. } => {
                let bytes = command.chunk_bytes();
                let at = usize::from(offset);
                let buffer: &mut [u8] = match table {
                    TableKind::Controller => &mut self.loading,
                    TableKind::Calibration => {
                        self.cal_len = 0;
                        &mut self.cal
                    }
                };
                match buffer.get_mut(at..at + bytes.len()) {
                    Some(dst) => copy(dst, bytes),
                    None => return (Err(room(table)), Action::None),
                }
                Action::None
            }
            Command::LoadTable {
                table: TableKind::Controller,
                len,
            } => match self
                .loading
                .get(..usize::from(len))
                .and_then(|b| DesignedConfig::decode(b).ok())
            {
                Some(config) => {
                    self.loaded = Some(config);
                    Action::None
                }
                None => return (Err(Refusal::TableRefused), Action::None),
            },
            Command::LoadTable {
                table: TableKind::Calibration,
                len,
            } => {
                let len = usize::from(len);
                let Some(bytes) = self.cal.get(..len) else {
                    return (Err(room(TableKind::Calibration)), Action::None);
                };
                if TableView::check(bytes).is_err() {
                    return (Err(Refusal::TableRefused), Action::None);
                }
                self.cal_len = len;
                Action::None
            }
        };
        (Ok(()), action)
    }

    /// The designed controller's configuration: the table loaded last, else the build's.
    pub fn designed(&self, compiled: &[u8]) -> Option<DesignedConfig> {
        self.loaded
            .or_else(|| DesignedConfig::decode(compiled).ok())
    }

    /// The configuration the next run starts with: `base` with the chosen force law and the
    /// chosen array estimator.
    pub fn firmware(&self, base: FirmwareConfig, compiled: &[u8]) -> FirmwareConfig {
        FirmwareConfig {
            designed: match self.controller {
                ControllerChoice::A1 => None,
                ControllerChoice::Designed => self.designed(compiled),
            },
            array_estimator: self.estimator.or(base.array_estimator),
            ..base
        }
    }
}

/// The array estimator a command chose, from the task that takes commands to the scan task
/// that rebuilds its estimators with it (lock-free: an index into [`EstimatorKind::ALL`]).
pub struct EstimatorChoice(AtomicU8);

impl EstimatorChoice {
    /// No choice: each taxel's own estimator.
    const NONE: u8 = u8::MAX;

    pub const fn new() -> Self {
        EstimatorChoice(AtomicU8::new(Self::NONE))
    }

    pub fn set(&self, kind: Option<EstimatorKind>) {
        let i = kind.and_then(|k| EstimatorKind::ALL.iter().position(|a| *a == k));
        let v = i.and_then(|i| u8::try_from(i).ok()).unwrap_or(Self::NONE);
        self.0.store(v, Ordering::Release);
    }

    pub fn get(&self) -> Option<EstimatorKind> {
        EstimatorKind::ALL
            .get(usize::from(self.0.load(Ordering::Acquire)))
            .copied()
    }

    /// `config` with the chosen array estimator, if one was chosen.
    pub fn applied(&self, config: FirmwareConfig) -> FirmwareConfig {
        FirmwareConfig {
            array_estimator: self.get().or(config.array_estimator),
            ..config
        }
    }
}

impl Default for EstimatorChoice {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a table does not fit: no room for one at all on this board, or not this long.
fn room(table: TableKind) -> Refusal {
    match table {
        TableKind::Calibration => Refusal::Unsupported {
            param: Param::Table,
        },
        TableKind::Controller => Refusal::OutOfRange {
            param: Param::Offset,
        },
    }
}

/// `dst` from `src`, byte for byte over the shorter: `copy_from_slice`'s length check would
/// pull core's formatting of its panic onto the firmware (the callers' lengths already match).
fn copy(dst: &mut [u8], src: &[u8]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(commands: &[(u16, Command)]) -> Vec<u8> {
        commands
            .iter()
            .flat_map(|(seq, c)| c.frame(*seq).as_bytes().to_vec())
            .collect()
    }

    /// `table` as the chunks that load it, numbered from `seq`.
    fn chunks(table: &[u8], kind: TableKind, seq: u16) -> Vec<(u16, Command)> {
        Command::table_chunks(kind, table)
            .enumerate()
            .map(|(i, c)| (seq + i as u16, c))
            .collect()
    }

    /// `table` as the chunks that load it, numbered from `seq`, with one byte flipped by
    /// `damage` (chunk, byte, bits) if given, then its load, numbered `load_seq`.
    fn loading(
        table: &[u8],
        kind: TableKind,
        seq: u16,
        damage: Option<(usize, usize, u8)>,
        load_seq: u16,
    ) -> Vec<(u16, Command)> {
        let mut out = chunks(table, kind, seq);
        if let Some((chunk, byte, bits)) = damage {
            if let Command::TableChunk { data, .. } = &mut out[chunk].1 {
                data[byte] ^= bits;
            }
        }
        let len = table.len() as u16;
        out.push((load_seq, Command::LoadTable { table: kind, len }));
        out
    }

    /// The replies to `commands`, polled in one tick with `compiled` as the build's table.
    fn replies_to<const CAL: usize>(
        port: &mut CommandPort<CAL>,
        commands: &[(u16, Command)],
        compiled: &[u8],
    ) -> Vec<Reply> {
        let mut replies = Vec::new();
        port.poll(&bytes(commands), compiled, |r, _| replies.push(r));
        replies
    }

    fn poll(port: &mut CommandPort<0>, commands: &[(u16, Command)]) -> Vec<(Reply, Action)> {
        let mut got = Vec::new();
        let compiled = crate::CONTROLLER_TABLE;
        port.poll(&bytes(commands), &compiled, |r, a| got.push((r, a)));
        got
    }

    /// A frame split across ticks is read whole; a false start is given up after the quiet
    /// ticks and the frame behind it read.
    #[test]
    fn an_estimator_choice_crosses_as_it_was_made() {
        let choice = EstimatorChoice::new();
        assert_eq!(choice.get(), None);
        let base = crate::BOARD;
        assert_eq!(choice.applied(base).array_estimator, base.array_estimator);
        for kind in EstimatorKind::ALL {
            choice.set(Some(kind));
            assert_eq!(choice.get(), Some(kind));
            assert_eq!(choice.applied(base).array_estimator, Some(kind));
        }
        choice.set(None);
        assert_eq!(choice.get(), None);
    }

    #[test]
    fn frames_across_ticks_and_false_starts() {
        let mut port = CommandPort::<0>::new(120.0, 600.0);
        let frame = bytes(&[(7, Command::Stop)]);
        let mut got = Vec::new();
        port.poll(&frame[..3], &[], |r, _| got.push(r));
        port.poll(&[], &[], |r, _| got.push(r));
        port.poll(&frame[3..], &[], |r, _| got.push(r));
        assert_eq!(
            got,
            [Reply {
                seq: 7,
                result: Ok(())
            }]
        );
        // A sync byte and a long length, then a whole frame: held until the line is quiet.
        let mut noisy = vec![tactile_core::command::SYNC, 60];
        noisy.extend(bytes(&[(8, Command::ClearFaults)]));
        let mut got = Vec::new();
        port.poll(&noisy, &[], |r, _| got.push(r));
        for _ in 0..QUIET_TICKS - 1 {
            port.poll(&[], &[], |r, _| got.push(r));
        }
        assert!(got.is_empty());
        port.poll(&[], &[], |r, _| got.push(r));
        assert_eq!(
            got,
            [Reply {
                seq: 8,
                result: Ok(())
            }]
        );
    }

    #[test]
    fn commands_are_answered_in_order_and_refusals_change_nothing() {
        let mut port = CommandPort::<0>::new(120.0, 600.0);
        let got = poll(
            &mut port,
            &[
                (1, Command::Hold { force_g: 30.0 }),
                (2, Command::Hold { force_g: 500.0 }),
                (3, Command::Controller(ControllerChoice::Designed)),
                (4, Command::Estimator(EstimatorKind::Elastic)),
                (5, Command::Stop),
            ],
        );
        assert_eq!(got.len(), 5);
        assert_eq!(
            got[0],
            (
                Reply {
                    seq: 1,
                    result: Ok(())
                },
                Action::Hold { force_g: 30.0 }
            )
        );
        assert_eq!(
            got[1].0.result,
            Err(Refusal::OutOfRange {
                param: Param::ForceG
            })
        );
        assert_eq!(got[1].1, Action::None);
        assert_eq!(got[4].1, Action::Stop);
        let fw = port.firmware(crate::BOARD, &crate::CONTROLLER_TABLE);
        assert!(fw.designed.is_some());
        assert_eq!(fw.array_estimator, Some(EstimatorKind::Elastic));
    }

    #[test]
    fn a_controller_table_is_loaded_in_chunks_and_checked() {
        let mut port = CommandPort::<0>::new(120.0, 600.0);
        // No table compiled in: the designed controller is refused until one is loaded.
        let none: [u8; 0] = [];
        let designed = [(1, Command::Controller(ControllerChoice::Designed))];
        let replies = replies_to(&mut port, &designed, &none);
        assert_eq!(replies[0].result, Err(Refusal::NoControllerTable));
        let table = crate::CONTROLLER_TABLE;
        // A damaged table first: refused, nothing loaded.
        let damaged = loading(&table, TableKind::Controller, 10, Some((1, 7, 1)), 50);
        let replies = replies_to(&mut port, &damaged, &none);
        assert_eq!(replies.last().unwrap().result, Err(Refusal::TableRefused));
        assert!(port.designed(&none).is_none());
        let mut commands = loading(&table, TableKind::Controller, 10, None, 60);
        commands.push((61, Command::Controller(ControllerChoice::Designed)));
        let replies = replies_to(&mut port, &commands, &none);
        assert!(replies.iter().all(|r| r.result.is_ok()), "{replies:?}");
        assert_eq!(
            port.firmware(crate::BOARD, &none).designed,
            DesignedConfig::decode(&table).ok()
        );
    }

    /// A calibration table in chunks: checked as at start-up, then given to the next run; a
    /// damaged one refused and nothing loaded; a board without room says so.
    #[test]
    fn a_calibration_table_is_loaded_in_chunks_and_checked() {
        use tactile_core::calibration::table_bytes;
        let table = crate::CALIBRATION_TABLE;
        let chunks = |damage: bool| {
            let damage = damage.then_some((2, 5, 0x20));
            loading(&table, TableKind::Calibration, 0, damage, 500)
        };
        let mut port = CommandPort::<{ table_bytes(8) }>::new(120.0, 600.0);
        let replies = replies_to(&mut port, &chunks(true), &[]);
        assert_eq!(replies.last().unwrap().result, Err(Refusal::TableRefused));
        assert_eq!(port.calibration_table(), None);
        let replies = replies_to(&mut port, &chunks(false), &[]);
        assert!(replies.iter().all(|r| r.result.is_ok()), "{replies:?}");
        assert_eq!(port.calibration_table(), Some(&table[..]));
        let mut copy = [0u8; 4096];
        let n = port.copy_calibration_table(&mut copy);
        assert_eq!(&copy[..n], &table[..]);
        // A buffer too short for it gets nothing rather than a part.
        assert_eq!(port.copy_calibration_table(&mut copy[..table.len() - 1]), 0);
        let mut none = CommandPort::<0>::new(120.0, 600.0);
        let replies = replies_to(&mut none, &chunks(false)[..1], &[]);
        assert_eq!(
            replies[0].result,
            Err(Refusal::Unsupported {
                param: Param::Table
            })
        );
    }
}
