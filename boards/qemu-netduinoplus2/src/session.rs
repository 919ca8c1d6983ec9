//! What the QEMU firmware runs: the protocols, a fresh simulated board and fresh task state per
//! run, the simulator truth that rides with each control frame, and the instruction counts.

use core::cell::Cell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, AtomicU8, AtomicUsize, Ordering};

use tactile_core::estimator::EstimatorKind;
use tactile_core::profile::Protocol;
use tactile_core::tactile::{TaxelCalibration, TAXELS};
use tactile_firmware::{Controller, Scanner};
use tactile_plant::applicator::{ApplicatorParams, APPLICATOR_BYTES};
use tactile_plant::hardware::SimHardware;
use tactile_plant::rig::RigConfig;

use tactile_firmware::FilRun;

/// Set at start-up to the session the command line asks for (its place in [`SESSIONS`]).
static SESSION: AtomicU8 = AtomicU8::new(0);
/// Set at start-up to the one run the command line asks for (`run=N`); `usize::MAX`: all.
static ONLY: AtomicUsize = AtomicUsize::new(usize::MAX);

const SESSIONS: [tactile_firmware::Session; 4] = [
    tactile_firmware::Session::FirmwareInTheLoop,
    tactile_firmware::Session::Calibration,
    tactile_firmware::Session::Excitation,
    tactile_firmware::Session::Commands,
];

/// The session the command line chose.
fn session() -> tactile_firmware::Session {
    SESSIONS
        .get(usize::from(SESSION.load(Ordering::Acquire)))
        .copied()
        .unwrap_or(tactile_firmware::Session::FirmwareInTheLoop)
}

/// Whether the command line chose the command-driven session.
pub fn commanded() -> bool {
    session() == tactile_firmware::Session::Commands
}

/// Chooses the session (and, with `run=N`, one run of it) from the semihosting command line
/// (call first in `init`).
pub fn choose(cmdline: &[u8]) {
    let session = tactile_firmware::session_from_cmdline(cmdline);
    let index = SESSIONS.iter().position(|s| *s == session).unwrap_or(0);
    SESSION.store(index as u8, Ordering::Release);
    let only = tactile_firmware::only_run_from_cmdline(cmdline).unwrap_or(usize::MAX);
    ONLY.store(only, Ordering::Release);
    let blank = tactile_firmware::words_of_cmdline(cmdline).any(|w| w == "calibration=none");
    NO_TABLE.store(blank, Ordering::Release);
    if let Some(path) = tactile_firmware::applicator_from_cmdline(cmdline) {
        let mut buf = [0u8; APPLICATOR_BYTES + 1];
        let Some(n) = crate::crash::read_file(path, &mut buf) else {
            defmt::error!("applicator file {=str}: cannot be read", path);
            exit_failure();
        };
        match ApplicatorParams::decode(buf.get(..n).unwrap_or(&[])) {
            Ok(params) => {
                defmt::info!("applicator from {=str}", path);
                cortex_m::interrupt::free(|cs| APPLICATOR.borrow(cs).set(Some(params)));
            }
            Err(e) => {
                defmt::error!(
                    "applicator file {=str} refused: {}",
                    path,
                    defmt::Display2Format(&e)
                );
                exit_failure();
            }
        }
    }
}

/// Set at start-up by `applicator=PATH`: the plant every run's board is built with (the
/// memo's, the simulator's default, otherwise).
static APPLICATOR: cortex_m::interrupt::Mutex<Cell<Option<ApplicatorParams>>> =
    cortex_m::interrupt::Mutex::new(Cell::new(None));

/// The session's runs (shared with the QEMU test, which replays them on the host simulator):
/// the firmware-in-the-loop session, the calibration or the excitation session, or one run of
/// one of them.
pub fn runs() -> &'static [FilRun] {
    let only = ONLY.load(Ordering::Acquire);
    session().runs_of((only != usize::MAX).then_some(only))
}

/// Set by `control` when it replaced the board: the scan task starts a fresh scanner.
pub static RESET_SCANNER: AtomicBool = AtomicBool::new(false);

/// The simulator's rig configuration for run `run`: the firmware runs exactly what the host
/// simulator runs, with that run's injected fault on the board.
fn rig(run: usize) -> RigConfig {
    // No runs of its own (the command session): the board as a commanded run builds it.
    board_rig(runs().get(run).unwrap_or(&FilRun::hold(0.0)))
}

/// A run's rig, without the build's calibration table when the command line says
/// `calibration=none` (a board whose calibration sector is blank).
fn board_rig(run: &FilRun) -> RigConfig {
    let mut config = run.rig();
    if NO_TABLE.load(Ordering::Acquire) {
        config.firmware.calibration = &[];
    }
    if let Some(params) = cortex_m::interrupt::free(|cs| APPLICATOR.borrow(cs).get()) {
        config.set_applicator(params);
    }
    config
}

/// Set at start-up by `calibration=none`.
static NO_TABLE: AtomicBool = AtomicBool::new(false);

pub use tactile_firmware::LOADED_TABLE_BYTES;

/// The command channel of this board.
pub type Port = tactile_firmware::CommandPort<LOADED_TABLE_BYTES>;

/// The board's configuration (the session's first run's, or the default rig's).
pub fn board_config() -> tactile_core::tasks::FirmwareConfig {
    rig(0).firmware
}

/// The board of the session's first run, as the simulator's rig builds it.
#[inline(never)]
pub fn board() -> SimHardware {
    SimHardware::new(&rig(0))
}

/// The control state for run `run`, calibrated on `hw`, and the scan state built straight
/// into `slot` (kept out of line: init's stack frame never holds a scanner).
#[inline(never)]
pub fn task_state(
    run: usize,
    hw: &SimHardware,
    slot: &'static mut MaybeUninit<Scanner>,
) -> (Controller, &'static mut Scanner) {
    let fw = rig(run).firmware;
    let protocol = runs()
        .get(run)
        .map_or(Protocol::FORCE_STEPS_MEMO, |r| r.protocol);
    let calibration = *hw.calibration();
    let probe = calibration.get(fw.probe.index()).copied();
    let controller = probe.and_then(|cal| Controller::new(&fw, protocol, cal).ok());
    let scan_config = rig(0).firmware;
    let scanner = slot.write(Scanner::blank(&scan_config, calibration));
    match (controller, reset_scanner(scanner, calibration, None)) {
        (Some(controller), true) => (controller, scanner),
        _ => fail(),
    }
}

/// Replaces the board and the controller in place for run `run` (kept out of line so the
/// control task's stack frame does not hold a whole board).
#[inline(never)]
pub fn renew(run: usize, hw: &mut SimHardware, controller: &mut Controller) {
    let protocol = runs()
        .get(run)
        .map_or(Protocol::FORCE_STEPS_MEMO, |r| r.protocol);
    renew_with(&rig(run), protocol, hw, controller);
}

/// Replaces the board and the controller in place for a run a command asked for, with the
/// force law and the array estimator the commands chose.
#[inline(never)]
pub fn renew_commanded(
    run: &FilRun,
    port: &Port,
    hw: &mut SimHardware,
    controller: &mut Controller,
) {
    let mut config = board_rig(run);
    config.firmware = port.firmware(config.firmware, &tactile_firmware::CONTROLLER_TABLE);
    SCAN_ESTIMATOR.set(config.firmware.array_estimator);
    renew_with(&config, run.protocol, hw, controller);
}

/// The array estimator a commanded run chose, for the scan task's reset.
static SCAN_ESTIMATOR: tactile_firmware::EstimatorChoice = tactile_firmware::EstimatorChoice::new();

fn renew_with(
    config: &RigConfig,
    protocol: Protocol,
    hw: &mut SimHardware,
    controller: &mut Controller,
) {
    let fw = config.firmware;
    *hw = SimHardware::new(config);
    let probe = hw.calibration().get(fw.probe.index()).copied();
    match probe.and_then(|cal| Controller::new(&fw, protocol, cal).ok()) {
        Some(c) => *controller = c,
        None => fail(),
    }
}

/// The scanner started over in place on a new board's rest calibration (no copy of it on the
/// scan task's stack). The scan configuration is the same in every run (faults do not change
/// it).
#[inline(never)]
pub fn reset_scanner(
    scanner: &mut Scanner,
    calibration: [TaxelCalibration; TAXELS],
    loaded: Option<&[u8]>,
) -> bool {
    let config = SCAN_ESTIMATOR.applied(rig(0).firmware);
    let table = loaded.unwrap_or(config.calibration);
    scanner
        .reset_with_table(&config, calibration, table)
        .is_ok()
}

/// The command script of `session=commands`: entries of (board tick: u32 LE, length: u16 LE,
/// the bytes that arrive on the down-channel at that tick), in increasing tick.
pub struct Script {
    bytes: &'static [u8],
    at: usize,
}

impl Script {
    /// The script file the command line names (`script=PATH`), read into `buf`; empty when
    /// there is none.
    pub fn load(cmdline: &[u8], buf: &'static mut [u8]) -> Script {
        let n = tactile_firmware::script_from_cmdline(cmdline)
            .and_then(|path| crate::crash::read_file(path, buf))
            .unwrap_or(0);
        let bytes: &'static [u8] = buf;
        Script {
            bytes: bytes.get(..n).unwrap_or(&[]),
            at: 0,
        }
    }

    /// The next entry's bytes if it is due at `tick` (call until `None`).
    pub fn due(&mut self, tick: u32) -> Option<&'static [u8]> {
        let rest = self.bytes.get(self.at..)?;
        let entry = || {
            let due = u32::from_le_bytes(rest.get(..4)?.try_into().ok()?);
            let len = usize::from(u16::from_le_bytes(rest.get(4..6)?.try_into().ok()?));
            Some((due, rest.get(6..6 + len)?))
        };
        match entry() {
            Some((due, _)) if due > tick => None,
            Some((_, data)) => {
                self.at += 6 + data.len();
                Some(data)
            }
            // A cut-off entry: the script ends there.
            None => {
                self.at = self.bytes.len();
                None
            }
        }
    }

    /// Every entry taken.
    pub fn finished(&self) -> bool {
        self.at >= self.bytes.len()
    }
}

/// The constant configuration was refused: nothing sensible to run.
fn fail() -> ! {
    defmt::error!("configuration refused by the core library");
    exit_failure()
}

fn exit_failure() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// The scanned channel with its sample already taken from the simulated board, so timing the
/// scan step measures the firmware and not the simulated finger.
pub struct Converted<'a> {
    pub hw: &'a mut SimHardware,
    pub code: tactile_core::gauge::AdcCode,
}

impl tactile_firmware::ScanIo for Converted<'_> {
    fn select_taxel(&mut self, taxel: tactile_core::tactile::TaxelId) {
        self.hw.select_taxel(taxel);
    }
    fn read_taxel(&mut self) -> tactile_core::gauge::AdcCode {
        self.code
    }
}

/// Simulator truth riding with a control frame: the contact force when the converters
/// sampled.
#[derive(Clone, Copy, Debug, Default, PartialEq, defmt::Format)]
pub struct SimTruth {
    pub tick: u32,
    pub true_force_g: f32,
    pub in_contact: bool,
}

/// SysTick counts per instruction at `-icount shift=0` (1 ns each) and a 168 MHz core clock,
/// as a ratio: instructions = counts × 1000 / 168.
const INSTRUCTIONS_PER_COUNT: (u64, u64) = (1000, 168);

/// Smallest and largest SysTick span seen.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Span {
    pub min: u32,
    pub max: u32,
    pub n: u32,
}

impl Span {
    pub fn observe(&mut self, counts: u32) {
        if self.n == 0 {
            self.min = counts;
            self.max = counts;
        } else {
            self.min = self.min.min(counts);
            self.max = self.max.max(counts);
        }
        self.n = self.n.saturating_add(1);
    }
    fn instructions(&self) -> InstructionSpan {
        let i =
            |c: u32| (u64::from(c) * INSTRUCTIONS_PER_COUNT.0 / INSTRUCTIONS_PER_COUNT.1) as u32;
        InstructionSpan {
            min: i(self.min),
            max: i(self.max),
            samples: self.n,
        }
    }
}

/// What the tasks cost, in SysTick counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    /// The control body (`Controller::tick`).
    pub control: Span,
    /// The simulated plant's millisecond (not firmware: the board's physics).
    pub physics: Span,
    /// A scan step that did not complete a frame.
    pub scan_step: Span,
    /// The scan step that completes a frame (adds the array sums and the frame).
    pub scan_frame_step: Span,
    /// The contact's fit on a completed frame (the locate task), when no tick preempted it.
    pub locate: Span,
    /// One taxel update of each estimator (elastic, second-order inverse, scheduled inverse,
    /// observer, force bank), timed one at a time on the probed taxel's strain.
    pub estimator_update: [Span; EstimatorKind::COUNT],
}

#[derive(Clone, Copy, Debug, Default, PartialEq, defmt::Format)]
pub struct InstructionSpan {
    pub min: u32,
    pub max: u32,
    pub samples: u32,
}

/// Instruction counts (±6: one SysTick count is 5.95 instructions at `-icount shift=0`).
#[derive(Clone, Copy, Debug, Default, PartialEq, defmt::Format)]
pub struct InstructionCounts {
    pub control_tick: InstructionSpan,
    pub scan_step: InstructionSpan,
    pub scan_frame_step: InstructionSpan,
    pub locate_frame: InstructionSpan,
    /// Per taxel update: elastic, second-order inverse, scheduled inverse, observer, force bank.
    pub estimator_update: [InstructionSpan; EstimatorKind::COUNT],
    pub simulated_plant_ms: InstructionSpan,
}

impl Cost {
    pub fn report(&self) -> InstructionCounts {
        InstructionCounts {
            control_tick: self.control.instructions(),
            scan_step: self.scan_step.instructions(),
            scan_frame_step: self.scan_frame_step.instructions(),
            locate_frame: self.locate.instructions(),
            estimator_update: self.estimator_update.map(|s| s.instructions()),
            simulated_plant_ms: self.physics.instructions(),
        }
    }
}

/// Stack painting: every word between the stack's lowest address and the stack pointer at
/// boot gets this pattern; the deepest word overwritten since is the stack's high-water mark.
const PAINT: u32 = 0xA5A5_5A5A;

/// Where RAM starts (SRAM1 of the STM32F405/F407).
const RAM_START: usize = 0x2000_0000;

extern "C" {
    /// The stack's lowest address (cortex-m-rt's link.x; flip-link moves it to the start of
    /// RAM, below the statics, so an overflow faults instead of overwriting them).
    static mut _stack_end: u32;
    /// Top of the stack.
    static _stack_start: u32;
    /// End of RAM.
    static _ram_end: u32;
}

/// The stack's region, [lowest, top).
fn stack_region() -> (usize, usize) {
    (
        core::ptr::addr_of_mut!(_stack_end) as usize,
        core::ptr::addr_of!(_stack_start) as usize,
    )
}

/// Paints the free stack (call first thing in `init`).
pub fn paint_stack() {
    let sp = cortex_m::register::msp::read() as usize;
    // Leave the words `init` itself is using.
    let top = sp.saturating_sub(256);
    let (mut p, _) = stack_region();
    while p < top {
        // SAFETY: [stack end, sp − 256) is stack no one uses yet (below the live frames);
        // aligned to 4 by the linker script.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Static RAM and stack use, bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, defmt::Format)]
pub struct MemoryUse {
    pub static_ram: u32,
    pub stack_peak: u32,
    pub stack_free: u32,
}

pub fn memory() -> MemoryUse {
    let (base, top) = stack_region();
    let ram_end = core::ptr::addr_of!(_ram_end) as usize;
    let mut p = base;
    // SAFETY: reads words of the stack region, below the live frames once painted.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    MemoryUse {
        // Whatever RAM the stack does not have holds the statics.
        static_ram: (ram_end.saturating_sub(RAM_START) - (top - base)) as u32,
        stack_peak: (top - p) as u32,
        stack_free: (p - base) as u32,
    }
}
