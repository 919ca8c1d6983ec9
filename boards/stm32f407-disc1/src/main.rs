//! The firmware on the STM32F407G-DISC1 (`boards/README.md` has every pin and scaling).
//!
//! Task graph (RTIC 2; bodies from `tactile-firmware`, shared with the QEMU build):
//!
//! | task | priority | trigger | does |
//! | --- | --- | --- | --- |
//! | `control` | 4 | SysTick, 1 kHz (hardware reload: drift-free) | 8 gauge samples → A1 → filter → DAC; probe channel → inverse model |
//! | `scan` | 3 | TIM2 update, 4 kHz (250 µs dwell) | sample the selected taxel, move the multiplexer on |
//! | `locate` | 2 | spawned by `scan` once a frame (62.5 Hz) | the contact's fit on the frame's estimates, the frame to the telemetry queue |
//! | `telemetry` | 1 | spawned by `control` | drains the bounded queues to defmt over RTT |
//!
//! Commands come down RTT down-channel 0 (`commands`); `control` takes the bytes
//! that have arrived at the start of each tick (a copy of at most [`DOWN_BYTES_PER_TICK`]:
//! never a wait) through `tactile_firmware::CommandPort`, answers each over defmt with its
//! sequence number, and starts, holds or stops the runs they ask for. At reset it runs the
//! build's protocol, as before. A calibration table loaded by command (eight taxels at most)
//! is kept in CCM RAM with the port; `scan` rebuilds its estimators from it at the next run.
//! | `idle` | 0 | — | WFI |
//!
//! Control frames go out every [`CONTROL_FRAME_EVERY`]-th tick (RTT bandwidth; only queued
//! frames are numbered, so a sequence gap is a loss after the queue, and a full queue is
//! counted and flagged); every taxel frame goes out.
//!
//! Safety: the panic and HardFault handlers write the DAC's safe code to its register before
//! anything else; the independent watchdog (100 ms) is fed from `idle` only when control and
//! telemetry have both checked in; the reset cause (RCC_CSR) is logged at boot.
#![cfg_attr(target_os = "none", no_std, no_main)]
// No unwrap, expect, panicking index or panic! here: Cargo.toml's `[lints]`.

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "tactile-f407 is firmware: build it with `cargo fw-f407`, flash and run it with \
         `cargo flash-f407` (probe-rs)"
    );
    std::process::exit(2);
}

#[cfg(target_os = "none")]
mod board;

// NOTE: the defmt logger is rtt-target's (up-channel 0), which also gives the down-channel;
// defmt-rtt has none.
#[cfg(target_os = "none")]
use rtt_target as _;

/// Panic: the actuator to its safe zero first, then the report (location only: formatting the
/// message would link `core::fmt`'s float code past the flash budget), then a HardFault, which
/// `probe-rs run` reports with a backtrace.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let safe = board::zero_actuator_register("panic");
    match info.location() {
        Some(at) => defmt::error!("{} at {=str}:{=u32}", safe, at.file(), at.line()),
        None => defmt::error!("{}", safe),
    }
    cortex_m::asm::udf()
}

/// HardFault: the actuator to zero, the report, then wait for the independent watchdog to reset
/// the board (the reset cause is reported at the next boot).
#[cfg(target_os = "none")]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    let safe = board::zero_actuator_register("hardfault");
    defmt::error!("{} HardFault at pc {=u32:#x}", safe, frame.pc());
    loop {
        cortex_m::asm::wfi();
    }
}

/// Independent watchdog timeout, ms: 100 control ticks. Long enough for the telemetry task to
/// drain a burst at priority 1, short enough that a hung control loop is reset well before a
/// person would notice the probe pressing.
#[cfg(target_os = "none")]
const WATCHDOG_TIMEOUT_MS: u32 = 100;

/// Control frames sent per control tick: one in five (200 frames/s, about 7 KB/s of RTT).
#[cfg(target_os = "none")]
const CONTROL_FRAME_EVERY: u32 = 5;

/// Command bytes taken from the down-channel per tick, at most (a chunk command is about 40
/// B, so a table loads at a frame a tick or so; the rest waits in the channel's buffer).
#[cfg(target_os = "none")]
const DOWN_BYTES_PER_TICK: usize = 64;

/// The command channel: with room for a calibration table loaded by command.
#[cfg(target_os = "none")]
type Port = tactile_firmware::CommandPort<{ tactile_firmware::LOADED_TABLE_BYTES }>;

/// CCM RAM, 64 KiB the CPU alone reaches (no DMA: nothing here is a DMA buffer) and that
/// nothing else uses: the command port (its two table buffers, about 7 KB), the copy of a
/// loaded calibration table the scan task rebuilds its estimators from, and the frames the
/// scan hands the locate task with the locator's configuration. Static RAM (the 32 KiB) is
/// spoken for.
#[cfg(target_os = "none")]
mod ccm {
    use core::mem::MaybeUninit;
    use core::sync::atomic::{AtomicBool, Ordering};
    use heapless::spsc::Queue;
    use tactile_core::contact::Locator;
    use tactile_firmware::{UnlocatedFrame, LOADED_TABLE_BYTES};

    /// Frames between the scan and the locate task: one being located, one more arriving.
    pub const UNLOCATED_QUEUE: usize = 3;
    pub type Unlocated = Queue<UnlocatedFrame, UNLOCATED_QUEUE>;

    /// The locate task's share: the hand-off queue, and the slot for the scanner's locator
    /// (known once the scanner is built).
    pub struct Locating {
        pub queue: &'static mut Unlocated,
        pub locator: &'static mut MaybeUninit<Locator>,
    }

    // NOTE: `.ccmram` is NOLOAD (memory.x): never zeroed at reset, so the slots are
    // `MaybeUninit` and written before they are read.
    #[link_section = ".ccmram.port"]
    static mut PORT: MaybeUninit<super::Port> = MaybeUninit::uninit();
    #[link_section = ".ccmram.table"]
    static mut TABLE: MaybeUninit<[u8; LOADED_TABLE_BYTES]> = MaybeUninit::uninit();
    #[link_section = ".ccmram.unlocated"]
    static mut UNLOCATED: MaybeUninit<Unlocated> = MaybeUninit::uninit();
    #[link_section = ".ccmram.locator"]
    static mut LOCATOR: MaybeUninit<Locator> = MaybeUninit::uninit();
    static TAKEN: AtomicBool = AtomicBool::new(false);

    /// The port, written with `port`, the table copy, zeroed, an empty hand-off queue and the
    /// locator's slot: once (from `init`; any later call gets `None`).
    pub fn take(
        port: super::Port,
    ) -> Option<(
        &'static mut super::Port,
        &'static mut [u8; LOADED_TABLE_BYTES],
        Locating,
    )> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: the flag hands the four slots out once; nothing else names them.
        let (p, t) = (&raw mut PORT, &raw mut TABLE);
        let (q, l) = (&raw mut UNLOCATED, &raw mut LOCATOR);
        let (p, t, q, l) = unsafe { (&mut *p, &mut *t, &mut *q, &mut *l) };
        let locating = Locating {
            queue: q.write(Queue::new()),
            locator: l,
        };
        Some((p.write(port), t.write([0; LOADED_TABLE_BYTES]), locating))
    }
}

/// The array estimator a command chose, for the scan task to rebuild its estimators with at
/// the next run.
#[cfg(target_os = "none")]
static SCAN_ESTIMATOR: tactile_firmware::EstimatorChoice = tactile_firmware::EstimatorChoice::new();

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART1, USART2])]
mod app {
    use core::mem::MaybeUninit;
    use core::sync::atomic::AtomicBool;
    use core::sync::atomic::{AtomicU32, Ordering};
    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m::peripheral::SCB;
    use heapless::spsc::{Consumer, Producer, Queue};
    use rtt_target::{ChannelMode, DownChannel};
    use stm32f4xx_hal::watchdog::IndependentWatchdog;
    use stm32f4xx_hal::{pac, prelude::*, timer};
    use tactile_core::contact::Locator;
    use tactile_core::tactile::TaxelCalibration;
    use tactile_core::telemetry::TaxelFrame;
    use tactile_firmware::{
        Action, ArrayEstimate, CheckIns, Controller, Message, Outbox, RunEnd, RunStart, Scanner,
        UnlocatedFrame, LOADED_TABLE_BYTES,
    };

    use crate::board::{self, ControlBoard, ScanBoard, WithAdc, CORE_HZ, PROTOCOL, PROTOCOL_NAME};
    use crate::{CONTROL_FRAME_EVERY, DOWN_BYTES_PER_TICK, SCAN_ESTIMATOR, WATCHDOG_TIMEOUT_MS};

    use crate::Port;

    /// Set by `control` when a commanded run starts: the scan task rebuilds its estimators
    /// (with the chosen array estimator) before its next dwell.
    static RESCAN: AtomicBool = AtomicBool::new(false);

    /// Check-ins of control and telemetry; `idle` feeds the watchdog only when both are in.
    static CHECK_INS: CheckIns = CheckIns::new();

    const CONTROL_QUEUE: usize = 17;
    const TAXEL_QUEUE: usize = 5;

    /// Frames the scan could not hand the locate task (its queue full), for the run's end.
    static UNLOCATED_DROPS: AtomicU32 = AtomicU32::new(0);

    /// The control tick now running (the scan stamps its frames with it).
    static TICK: AtomicU32 = AtomicU32::new(0);

    type ControlMsg = Message<()>;
    type TaxelMsg = (TaxelFrame, ArrayEstimate);

    #[shared]
    struct Shared {
        /// ADC1, converting for both the control and the scan task.
        adc: board::Converter,
        /// The command channel (in CCM RAM): `control` takes commands through it, `scan` copies
        /// a loaded calibration table out of it when a commanded run starts.
        port: &'static mut Port,
    }

    #[local]
    struct Local {
        control_board: ControlBoard,
        scan_board: ScanBoard,
        controller: Controller,
        probe_calibration: TaxelCalibration,
        down: DownChannel,
        table_copy: &'static mut [u8; LOADED_TABLE_BYTES],
        scanner: &'static mut Scanner,
        unlocated_tx: Producer<'static, UnlocatedFrame>,
        unlocated_rx: Consumer<'static, UnlocatedFrame>,
        locator: &'static Locator,
        control_out: Outbox<'static, ControlMsg>,
        taxel_out: Outbox<'static, TaxelMsg>,
        control_rx: Consumer<'static, ControlMsg>,
        taxel_rx: Consumer<'static, TaxelMsg>,
        scan_timer: timer::CounterHz<pac::TIM2>,
        watchdog: IndependentWatchdog,
    }

    #[init(local = [
        control_queue: Queue<ControlMsg, CONTROL_QUEUE> = Queue::new(),
        taxel_queue: Queue<TaxelMsg, TAXEL_QUEUE> = Queue::new(),
        // NOTE: the scanner (64 estimators, about 26 KB) is built in place, never on a stack.
        scanner_slot: MaybeUninit<Scanner> = MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        // First: every defmt message goes out through this up-channel.
        let channels = rtt_target::rtt_init! {
            up: {
                0: {
                    size: 1024,
                    mode: ChannelMode::NoBlockSkip,
                    name: "defmt"
                }
            }
            down: {
                0: {
                    size: 128,
                    name: "commands"
                }
            }
        };
        rtt_target::set_defmt_channel(channels.up.0);
        let config = tactile_firmware::BOARD;
        // The designed controller's table, checked as the calibration table is (refused: A1).
        #[cfg(feature = "controller-designed")]
        let (config, port) = {
            let table = &tactile_firmware::CONTROLLER_TABLE;
            let designed = tactile_core::designed::DesignedConfig::decode(table);
            match &designed {
                Ok(_) => defmt::info!(
                    "controller: the designed one ({=usize} B table)",
                    table.len()
                ),
                Err(e) => defmt::warn!("controller table refused ({}): A1", e),
            }
            let port = Port::new(config.supervisor.command_max_g, tactile_firmware::HOLD_S);
            (
                tactile_core::tasks::FirmwareConfig {
                    designed: designed.ok(),
                    ..config
                },
                port.with_controller(tactile_core::command::ControllerChoice::Designed),
            )
        };
        #[cfg(not(feature = "controller-designed"))]
        let port = Port::new(config.supervisor.command_max_g, tactile_firmware::HOLD_S);
        let board::Hardware {
            mut adc,
            mut control_board,
            mut scan_board,
            mut scan_timer,
            mut watchdog,
            reset_cause,
        } = board::setup(cx.device);
        control_board.zero_actuator();
        defmt::info!("{}", reset_cause);
        let Some((port, table_copy, locating)) = crate::ccm::take(port) else {
            defmt::panic!("the CCM RAM slots were taken before init");
        };
        // Calibrate with the probe lifted (the actuator output is at its safe zero).
        let calibration = scan_board.rest_calibration(&mut adc, 16);
        let probe = calibration.get(config.probe.index()).copied();
        let scanner = cx
            .local
            .scanner_slot
            .write(Scanner::blank(&config, calibration));
        let (Some(probe_calibration), Some(controller), Ok(())) = (
            probe,
            probe.and_then(|cal| Controller::new(&config, PROTOCOL, cal).ok()),
            scanner.reset(&config, calibration),
        ) else {
            defmt::panic!("the core library refused the board configuration");
        };
        scanner.start(&mut WithAdc {
            adc: &mut adc,
            board: &mut scan_board,
        });
        defmt::info!("tactile-f407: protocol {=str}", PROTOCOL_NAME);
        // The dynamic calibration table (boards/calibration/table.bin, compiled in): how many
        // taxels run their own models, or why the table was refused (then all run nominal).
        defmt::info!("{}", scanner.calibration_status());

        let (control_tx, control_rx) = cx.local.control_queue.split();
        let (taxel_tx, taxel_rx) = cx.local.taxel_queue.split();
        let (unlocated_tx, unlocated_rx) = locating.queue.split();
        // The scan configuration, the locator's with it, is the same in every run: a rebuild
        // at a commanded run keeps this copy right.
        let locator: &'static Locator = locating.locator.write(*scanner.locator());
        // The control tick: SysTick on the 168 MHz core clock, reloaded by hardware.
        let mut syst = cx.core.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(CORE_HZ / 1000 - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        // The scan: one multiplexer step per 250 µs dwell.
        let dwell_hz = (1.0 / config.scan.dwell_s) as u32;
        if scan_timer.start(dwell_hz.Hz()).is_err() {
            defmt::panic!("TIM2 cannot run at {=u32} Hz", dwell_hz);
        }
        scan_timer.listen(timer::Event::Update);
        // Last: the calibration above takes 256 ms and feeds nothing.
        watchdog.start(WATCHDOG_TIMEOUT_MS.millis());
        (
            Shared { adc, port },
            Local {
                control_board,
                scan_board,
                controller,
                probe_calibration,
                down: channels.down.0,
                table_copy,
                scanner,
                unlocated_tx,
                unlocated_rx,
                locator,
                control_out: Outbox::new(control_tx),
                taxel_out: Outbox::new(taxel_tx),
                control_rx,
                taxel_rx,
                scan_timer,
                watchdog,
            },
        )
    }

    /// Sleeps between interrupts and feeds the watchdog: from the lowest priority, and only
    /// when control and telemetry have both checked in since the last feed.
    #[idle(local = [watchdog])]
    fn idle(cx: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
            if CHECK_INS.both_since_last_feed() {
                cx.local.watchdog.feed();
            }
        }
    }

    #[task(binds = SysTick, priority = 4, shared = [adc, port],
           local = [controller, control_board, control_out, probe_calibration, down,
                    tick: u32 = 0, ended: bool = false, active: bool = true])]
    fn control(mut cx: control::Context) {
        let local = cx.local;
        let tick = *local.tick;
        TICK.store(tick, Ordering::Relaxed);
        if tick == 0 {
            local.control_out.send(Message::Start(RunStart {
                name: PROTOCOL_NAME,
                start_tick: 0,
                duration_s: PROTOCOL.duration_s(),
            }));
        }
        // This tick's command bytes, and what their commands ask.
        let mut bytes = [0u8; DOWN_BYTES_PER_TICK];
        let n = local.down.read(&mut bytes);
        let (mut start, mut stop, mut clear) = (None, false, false);
        let out = &mut *local.control_out;
        // NOTE: the highest priority that takes the port: its lock costs nothing.
        cx.shared.port.lock(|port| {
            port.poll(
                bytes.get(..n).unwrap_or(&[]),
                &tactile_firmware::CONTROLLER_TABLE,
                |reply, action| {
                    out.send(Message::Reply(reply));
                    match action {
                        Action::Start(run) => start = Some((run.name(), run.protocol())),
                        Action::Hold { force_g } => {
                            start = Some(("hold", tactile_firmware::hold(force_g)));
                        }
                        Action::Stop => (start, stop) = (None, true),
                        Action::ClearFaults => clear = true,
                        Action::None => {}
                    }
                },
            )
        });
        if clear {
            local.controller.clear_faults();
        }
        if stop || start.is_some() {
            if core::mem::replace(local.active, false) && !*local.ended {
                let end = run_end(tick, local.control_out, local.controller);
                local.control_out.send(Message::End(end));
            }
            // Between runs (and if the next cannot start) the actuator rests at its safe output.
            local.control_board.zero_actuator();
            if let Some((name, protocol)) = start {
                let config = cx.shared.port.lock(|port| {
                    port.firmware(tactile_firmware::BOARD, &tactile_firmware::CONTROLLER_TABLE)
                });
                match Controller::new(&config, protocol, *local.probe_calibration) {
                    Ok(c) => {
                        *local.controller = c;
                        *local.active = true;
                        *local.ended = false;
                        SCAN_ESTIMATOR.set(config.array_estimator);
                        RESCAN.store(true, Ordering::Release);
                        local.control_out.send(Message::Start(RunStart {
                            name,
                            start_tick: tick,
                            duration_s: protocol.duration_s(),
                        }));
                    }
                    Err(_) => defmt::error!("the commanded run's configuration was refused"),
                }
            }
        }
        if *local.active {
            let (controller, board) = (&mut *local.controller, &mut *local.control_board);
            let frame = cx
                .shared
                .adc
                .lock(|adc| controller.tick(&mut WithAdc { adc, board }, tick));
            if tick.is_multiple_of(CONTROL_FRAME_EVERY) {
                local.control_out.send(Message::Tick(frame, ()));
            }
            if local.controller.finished() && !core::mem::replace(local.ended, true) {
                let end = run_end(tick, local.control_out, local.controller);
                local.control_out.send(Message::End(end));
            }
        }
        let _ = telemetry::spawn();
        *local.tick = tick.wrapping_add(1);
        // The deadline: SysTick pending again means the next tick is already due.
        if SCB::is_pendst_pending() {
            local.controller.record_overrun();
        }
        CHECK_INS.control();
    }

    /// The counts a run's end reports.
    fn run_end(
        end_tick: u32,
        out: &Outbox<'static, ControlMsg>,
        controller: &Controller,
    ) -> RunEnd {
        RunEnd {
            end_tick,
            control_frames_dropped: out.dropped(),
            // A frame lost before the telemetry queue leaves no gap in its numbering.
            taxel_frames_dropped: UNLOCATED_DROPS.load(Ordering::Relaxed),
            overruns: controller.overruns(),
        }
    }

    #[task(binds = TIM2, priority = 3, shared = [adc, port],
           local = [scanner, scan_board, scan_timer, unlocated_tx, table_copy])]
    fn scan(mut cx: scan::Context) {
        let local = cx.local;
        local.scan_timer.clear_flags(timer::Flag::Update);
        let tick = TICK.load(Ordering::Relaxed);
        if RESCAN.swap(false, Ordering::AcqRel) {
            // A commanded run: the estimators afresh, with the array estimator chosen and the
            // calibration table loaded by command, if one is (copied out: the rebuild must not
            // hold the port the control task takes commands through).
            let config = SCAN_ESTIMATOR.applied(tactile_firmware::BOARD);
            let copy = &mut **local.table_copy;
            let n = cx
                .shared
                .port
                .lock(|port| port.copy_calibration_table(copy));
            let rebuilt = match copy.get(..n).filter(|t| !t.is_empty()) {
                Some(table) => local.scanner.rebuild_with_table(&config, table),
                None => local.scanner.rebuild(&config),
            };
            if rebuilt.is_err() {
                defmt::error!("the scanner's configuration was refused");
            }
            defmt::info!("{}", local.scanner.calibration_status());
        }
        let (scanner, board) = (&mut *local.scanner, &mut *local.scan_board);
        let frame = cx
            .shared
            .adc
            .lock(|adc| scanner.step_unlocated(&mut WithAdc { adc, board }, tick));
        // The contact's fit outlasts a dwell: the locate task runs it below this priority. A
        // refused spawn (the task still draining) loses nothing: it finds the frame queued.
        if let Some(frame) = frame {
            if local.unlocated_tx.enqueue(frame).is_err() {
                UNLOCATED_DROPS.fetch_add(1, Ordering::Relaxed);
            }
            let _ = locate::spawn();
        }
    }

    /// The completed frames' contacts, located in turn, then each frame to the telemetry queue
    /// (numbered there, in the scan's order).
    #[task(priority = 2, local = [unlocated_rx, locator, taxel_out])]
    async fn locate(cx: locate::Context) {
        while let Some(frame) = cx.local.unlocated_rx.dequeue() {
            let report = frame.locate(cx.local.locator);
            cx.local.taxel_out.send((report.frame, report.estimate));
        }
    }

    #[task(priority = 1, local = [control_rx, taxel_rx])]
    async fn telemetry(cx: telemetry::Context) {
        CHECK_INS.telemetry();
        tactile_firmware::drain(
            cx.local.control_rx,
            cx.local.taxel_rx,
            |m| match m {
                Message::Tick(frame, ()) => defmt::info!("{}", frame),
                Message::Start(s) => defmt::info!("{}", s),
                Message::End(e) => defmt::info!("{}", e),
                Message::Reply(r) => defmt::info!("{}", r),
            },
            |(frame, estimate)| defmt::info!("{} {}", frame, estimate),
        );
    }
}
