//! The firmware on QEMU's `netduinoplus2` (STM32F405, Cortex-M4F), with the simulated
//! applicator, finger and converters of `tactile-plant` as its hardware (firmware-in-the-loop).
//!
//! Task graph (RTIC 2; the bodies are `tactile-firmware`'s, shared with the real board):
//!
//! | task | priority | trigger | does |
//! | --- | --- | --- | --- |
//! | `control` | 4 | SysTick, 1 kHz (hardware reload: drift-free) | gauge → A1 → filter → DAC; then the simulated plant's next millisecond |
//! | `scan` | 3 | spawned by `control` each tick | four multiplexer steps (4 × 250 µs dwell per ms) |
//! | `locate` | 2 | spawned by `scan` once a frame | the contact's fit on the frame's estimates, the frame to the telemetry queue |
//! | `telemetry` | 1 | spawned by `control` each tick | drains the bounded queues to defmt (semihosting) |
//! | `idle` | 0 | — | WFI |
//!
//! The session runs the `force-steps` protocol, then 10 s of `pseudo-random`, each from a fresh
//! board and fresh task state, streams every control frame (with the simulator's true force)
//! and every taxel frame, prints the measured instruction counts, and exits QEMU through
//! semihosting. With `-icount shift=0` one instruction is one nanosecond of virtual time, and
//! SysTick counts the 168 MHz core clock, so SysTick counts × 1000/168 are instructions.
#![cfg_attr(target_os = "none", no_std, no_main)]
// No unwrap, expect, panicking index or panic! here: Cargo.toml's `[lints]`.

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "tactile-qemu is firmware: build it with `cargo fw-qemu` (thumbv7em-none-eabihf) and \
         run it with boards/qemu-netduinoplus2/run.sh"
    );
    std::process::exit(2);
}

#[cfg(target_os = "none")]
mod session;

#[cfg(target_os = "none")]
use defmt_semihosting as _;

#[cfg(target_os = "none")]
mod crash;

/// Panic: the simulated actuator to zero first, then the report; QEMU stops with a failure
/// code so the test sees it.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let safe = crash::zero_actuator("panic");
    defmt::error!("{} {}", safe, defmt::Display2Format(info));
    crash::stop()
}

/// HardFault: the same, with the faulting address.
#[cfg(target_os = "none")]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    let safe = crash::zero_actuator("hardfault");
    defmt::error!("{} HardFault at pc {=u32:#x}", safe, frame.pc());
    crash::stop()
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4::stm32f405, dispatchers = [USART1, USART2, USART3])]
mod app {
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m::peripheral::{SCB, SYST};
    use heapless::spsc::{Consumer, Producer, Queue};
    use tactile_core::contact::Locator;
    use tactile_core::estimator::EstimatorKind;
    use tactile_core::io::ControlIo;
    use tactile_firmware::{
        Action, Controller, FilRun, Message, Outbox, RunEnd, RunStart, Scanner, UnlocatedFrame,
    };
    use tactile_plant::hardware::SimHardware;
    use tactile_plant::rig::InjectedFault;

    use crate::session::{self, runs, Cost, SimTruth};
    use core::mem::MaybeUninit;

    /// Core clock of the netduinoplus2 model (and of the F407 board), Hz.
    const CORE_HZ: u32 = 168_000_000;
    /// SysTick reload for the 1 kHz control tick.
    const TICK_RELOAD: u32 = CORE_HZ / 1000 - 1;
    /// Multiplexer steps per control tick: 1 ms / 250 µs dwell.
    const SCAN_STEPS_PER_TICK: usize = 4;
    /// Queue depths: 32 control ticks and 4 taxel frames of slack for the telemetry task.
    const CONTROL_QUEUE: usize = 33;
    /// Largest command script, bytes.
    const SCRIPT_BYTES: usize = 4096;
    const TAXEL_QUEUE: usize = 5;
    /// Frames between the scan and the locate task: one being located, one more arriving.
    const UNLOCATED_QUEUE: usize = 3;

    type ControlMsg = Message<SimTruth>;
    type TaxelMsg = (
        tactile_core::telemetry::TaxelFrame,
        tactile_firmware::ArrayEstimate,
    );

    /// Set by `control` when the last run has ended; `telemetry` exits QEMU once drained.
    static SESSION_DONE: AtomicBool = AtomicBool::new(false);
    /// Taxel frames dropped (the locate task's outbox count, for the run summaries).
    static TAXEL_DROPS: AtomicU32 = AtomicU32::new(0);
    /// Frames the scan could not hand the locate task (its queue full): lost before the
    /// telemetry queue, so no gap in its numbering shows them.
    static UNLOCATED_DROPS: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {
        /// The simulated board, built in place in a static (it is 18 KB).
        hw: &'static mut SimHardware,
        cost: Cost,
        /// The command channel (`session=commands`): the control task takes the commands, the
        /// scan task a calibration table loaded by command when a run starts.
        port: session::Port,
    }

    #[local]
    struct Local {
        controller: Controller,
        scanner: &'static mut Scanner,
        unlocated_tx: Producer<'static, UnlocatedFrame>,
        unlocated_rx: Consumer<'static, UnlocatedFrame>,
        /// The scanner's locator: the scan configuration is the same in every run, so a
        /// rebuild at a run's start keeps this copy right.
        locator: Locator,
        syst: SYST,
        control_out: Outbox<'static, ControlMsg>,
        taxel_out: Outbox<'static, TaxelMsg>,
        control_rx: Consumer<'static, ControlMsg>,
        taxel_rx: Consumer<'static, TaxelMsg>,
        /// A crash the test asked for (`-append "panic-at-tick=N"`), or none.
        crash: Option<tactile_firmware::DeliberateCrash>,
        /// The command script (`session=commands script=PATH`).
        script: session::Script,
    }

    #[init(local = [
        control_queue: Queue<ControlMsg, CONTROL_QUEUE> = Queue::new(),
        taxel_queue: Queue<TaxelMsg, TAXEL_QUEUE> = Queue::new(),
        unlocated_queue: Queue<UnlocatedFrame, UNLOCATED_QUEUE> = Queue::new(),
        hw_slot: MaybeUninit<SimHardware> = MaybeUninit::uninit(),
        scanner_slot: MaybeUninit<Scanner> = MaybeUninit::uninit(),
        script_buf: [u8; SCRIPT_BYTES] = [0; SCRIPT_BYTES],
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        session::paint_stack();
        let cmdline = crate::crash::cmdline();
        session::choose(&cmdline);
        defmt::info!("tactile-qemu: {=usize} runs", runs().len());
        // Built straight into their statics: the stack never holds a whole board.
        let hw: &'static mut SimHardware =
            crate::crash::arm(cx.local.hw_slot.write(session::board()));
        let crash = crate::crash::requested(&cmdline);
        if let Some(c) = crash {
            defmt::warn!("deliberate crash requested: {}", defmt::Debug2Format(&c));
        }
        let (controller, scanner) = session::task_state(0, hw, cx.local.scanner_slot);
        let script = session::Script::load(&cmdline, cx.local.script_buf);
        let max_force_g = session::board_config().supervisor.command_max_g;
        let port = session::Port::new(max_force_g, tactile_firmware::HOLD_S);
        let (control_tx, control_rx) = cx.local.control_queue.split();
        let (taxel_tx, taxel_rx) = cx.local.taxel_queue.split();
        let (unlocated_tx, unlocated_rx) = cx.local.unlocated_queue.split();
        let locator = *scanner.locator();
        let mut syst = cx.core.SYST;
        // No clock-ready bits to wait for: QEMU's model has no RCC, and the core clock is
        // the model's fixed 168 MHz.
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(TICK_RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        (
            Shared {
                hw,
                cost: Cost::default(),
                port,
            },
            Local {
                controller,
                scanner,
                unlocated_tx,
                unlocated_rx,
                locator,
                control_out: Outbox::new(control_tx),
                taxel_out: Outbox::new(taxel_tx),
                control_rx,
                taxel_rx,
                syst,
                crash,
                script,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            // With `-icount …,sleep=off` QEMU jumps virtual time to the next interrupt.
            cortex_m::asm::wfi();
        }
    }

    /// The 1 kHz control tick; then the simulated plant's next millisecond (the board's
    /// "physics", which a real board gets for free).
    #[task(binds = SysTick, priority = 4, shared = [hw, cost, port],
           local = [controller, control_out, syst, crash, script, board_tick: u32 = 0,
                    run: usize = 0, started: bool = false, pending_reset: bool = false,
                    done: bool = false, commanded: Option<FilRun> = None, active: bool = false])]
    fn control(mut cx: control::Context) {
        let local = cx.local;
        if *local.done {
            let _ = telemetry::spawn();
            return;
        }
        let tick = *local.board_tick;
        // A requested crash hits at the start of its tick, with the DAC still driving.
        crate::crash::at_tick(*local.crash, tick);
        let controller = &mut *local.controller;
        let commands = session::commanded();
        if commands {
            let (start, stop, clear) =
                poll_commands(tick, local.script, local.control_out, &mut cx.shared.port);
            if clear {
                controller.clear_faults();
            }
            if stop || start.is_some() {
                if core::mem::take(local.active) {
                    let end = RunEnd {
                        end_tick: tick,
                        ..run_end(local.control_out.dropped(), controller)
                    };
                    local.control_out.send(Message::End(end));
                }
                if stop {
                    let zero = session::board_config().actuator.zero_code();
                    cx.shared.hw.lock(|hw| hw.write_actuator(zero));
                }
                if start.is_some() {
                    *local.commanded = start;
                    *local.pending_reset = true;
                }
            }
        }
        if core::mem::take(local.pending_reset) {
            // A fresh board and fresh task state for the next protocol.
            let run = *local.run;
            match local.commanded {
                Some(c) if commands => {
                    (&mut cx.shared.hw, &mut cx.shared.port)
                        .lock(|hw, port| session::renew_commanded(c, port, hw, controller));
                    *local.active = true;
                }
                _ => cx.shared.hw.lock(|hw| session::renew(run, hw, controller)),
            }
            // Rebuilding the board took longer than a tick: the new run starts its periods
            // now (the gap belongs to no run), so it is not counted as an overrun.
            SCB::clear_pendst();
            local.syst.clear_current();
            *local.started = false;
            session::RESET_SCANNER.store(true, Ordering::Release);
        }
        if commands && !*local.active {
            // No run: the plant goes on, the actuator at its safe output; the session ends
            // with the script.
            cx.shared.hw.lock(|hw| hw.advance_period());
            if local.script.finished() {
                *local.done = true;
                SESSION_DONE.store(true, Ordering::Release);
            }
            *local.board_tick = tick.wrapping_add(1);
            let _ = telemetry::spawn();
            return;
        }
        if !core::mem::replace(local.started, true) {
            let run = if commands {
                local.commanded.as_ref()
            } else {
                runs().get(*local.run)
            };
            if let Some(run) = run {
                local.control_out.send(Message::Start(RunStart {
                    name: run.name,
                    start_tick: tick,
                    duration_s: run.protocol.duration_s(),
                }));
            }
        }
        let (frame, truth, control_counts, physics_counts, miss_deadline) =
            cx.shared.hw.lock(|hw| tick_on_board(hw, controller, tick));
        cx.shared.cost.lock(|c| {
            c.control.observe(control_counts);
            c.physics.observe(physics_counts);
        });
        local.control_out.send(Message::Tick(frame, truth));
        // Scan and telemetry may still be running from the last tick: then they pick up this
        // tick's work themselves (telemetry) or the multiplexer dwells one tick longer (scan),
        // so a refused spawn loses no frame.
        let _ = scan::spawn(tick);
        let _ = telemetry::spawn();
        *local.board_tick = tick.wrapping_add(1);

        if controller.finished() {
            local.control_out.send(Message::End(RunEnd {
                end_tick: *local.board_tick,
                ..run_end(local.control_out.dropped(), controller)
            }));
            if commands {
                *local.active = false;
                let zero = session::board_config().actuator.zero_code();
                cx.shared.hw.lock(|hw| hw.write_actuator(zero));
                return;
            }
            *local.run += 1;
            if *local.run < runs().len() {
                // Swapped at the next tick, once this tick's scan has run on this board.
                *local.pending_reset = true;
            } else {
                *local.done = true;
                SESSION_DONE.store(true, Ordering::Release);
            }
        }
        if miss_deadline {
            // The injected timing fault, for real: keep the core busy until the next tick is
            // due, so the deadline check below sees it as the board would.
            while !SCB::is_pendst_pending() {
                cortex_m::asm::nop();
            }
        }
        // The deadline: SysTick pending again means the next tick is already due.
        if SCB::is_pendst_pending() {
            controller.record_overrun();
        }
    }

    /// This tick's bytes from the down-channel, and what their commands ask: a run to start,
    /// a stop, a clear of the faults.
    fn poll_commands(
        tick: u32,
        script: &mut session::Script,
        out: &mut Outbox<'static, ControlMsg>,
        port: &mut impl rtic::Mutex<T = session::Port>,
    ) -> (Option<FilRun>, bool, bool) {
        let (mut start, mut stop, mut clear) = (None, false, false);
        // Every entry due now, then the tick's (empty) poll that counts quiet ticks.
        loop {
            let due = script.due(tick);
            let bytes = due.unwrap_or(&[]);
            port.lock(|port| {
                port.poll(
                    bytes,
                    &tactile_firmware::CONTROLLER_TABLE,
                    |reply, action| {
                        out.send(Message::Reply(reply));
                        match action {
                            Action::Start(run) => start = Some(FilRun::commanded(run)),
                            Action::Hold { force_g } => start = Some(FilRun::hold(force_g)),
                            Action::Stop => (start, stop) = (None, true),
                            Action::ClearFaults => clear = true,
                            Action::None => {}
                        }
                    },
                )
            });
            if due.is_none() {
                break;
            }
        }
        (start, stop, clear)
    }

    /// The controller's tick on the simulated board, then the plant's next period: the frame,
    /// the simulator's truth at the instant the converters sampled, the cycles each took, and
    /// whether an injected deadline overrun hits the coming period.
    fn tick_on_board(
        hw: &mut SimHardware,
        controller: &mut Controller,
        tick: u32,
    ) -> (
        tactile_core::telemetry::ControlFrame,
        SimTruth,
        u32,
        u32,
        bool,
    ) {
        // Simulator truth at the instant the converters sampled (end of the last period).
        let true_force_g = hw.true_force_g() as f32;
        let in_contact = hw.in_contact();
        let t0 = SYST::get_current();
        let frame = controller.tick(hw, tick);
        let t1 = SYST::get_current();
        hw.advance_period();
        let t2 = SYST::get_current();
        let truth = SimTruth {
            tick,
            true_force_g,
            in_contact,
        };
        // An injected deadline overrun hits the coming period: this tick must run
        // late for it (the rig's tick k sees the overrun of the task before it).
        let miss = hw.fault_starting() == Some(InjectedFault::DeadlineOverrun);
        (frame, truth, elapsed(t0, t1), elapsed(t1, t2), miss)
    }

    /// The counts a run's end reports (its end tick filled in by the caller where it differs).
    fn run_end(control_frames_dropped: u32, controller: &Controller) -> RunEnd {
        RunEnd {
            end_tick: 0,
            control_frames_dropped,
            taxel_frames_dropped: TAXEL_DROPS.load(Ordering::Relaxed)
                + UNLOCATED_DROPS.load(Ordering::Relaxed),
            overruns: controller.overruns(),
        }
    }

    /// SysTick counts from `t0` to `t1` (it counts down and reloads once per tick).
    fn elapsed(t0: u32, t1: u32) -> u32 {
        if t0 >= t1 {
            t0 - t1
        } else {
            t0 + (TICK_RELOAD + 1 - t1)
        }
    }

    #[task(priority = 3, shared = [hw, cost, port], local = [scanner, unlocated_tx,
           started: bool = false, bench: Option<tactile_core::estimator::TaxelEstimators> = None,
           loaded: [u8; session::LOADED_TABLE_BYTES] = [0; session::LOADED_TABLE_BYTES]])]
    async fn scan(mut cx: scan::Context, tick: u32) {
        let local = cx.local;
        if session::RESET_SCANNER.swap(false, Ordering::AcqRel) {
            // A new run: fresh per-taxel state, calibrated on the new board, with a table
            // loaded by command if there is one (copied out: the rebuild must not hold the
            // port the control task takes commands through).
            let calibration = cx.shared.hw.lock(|hw| *hw.calibration());
            let buf = &mut *local.loaded;
            let n = cx.shared.port.lock(|port| port.copy_calibration_table(buf));
            let loaded = buf.get(..n).filter(|t| !t.is_empty());
            if !session::reset_scanner(local.scanner, calibration, loaded) {
                defmt::error!("the scanner's configuration was refused");
            }
            *local.started = false;
        }
        if local.bench.is_none() {
            let status = local.scanner.calibration_status();
            defmt::info!("{}", status);
            *local.bench = local.scanner.probe_bench();
        }
        for _ in 0..SCAN_STEPS_PER_TICK {
            let scanner = &mut **local.scanner;
            let started = &mut *local.started;
            let (report, counts) = cx.shared.hw.lock(|hw| {
                let hw: &mut SimHardware = hw;
                if !*started {
                    *started = true;
                    scanner.start(hw);
                }
                // The simulated converter first (board physics, not firmware), then the
                // firmware's step on its code: the measured span is the firmware alone.
                let code = hw.sample_selected_taxel();
                let mut converter = session::Converted { hw, code };
                let t0 = SYST::get_current();
                let report = scanner.step_unlocated(&mut converter, tick);
                let t1 = SYST::get_current();
                (report, elapsed(t0, t1))
            });
            // Once a frame, each estimator's update on the probed taxel's strain, timed alone.
            let mut per_estimator = [None; EstimatorKind::COUNT];
            if let (Some(_), Some(bench)) = (&report, local.bench.as_mut()) {
                let strain = bench.corrected(scanner.probe_strain_pct());
                for (slot, kind) in per_estimator.iter_mut().zip(EstimatorKind::ALL) {
                    let estimator = bench.estimator_mut(kind);
                    let t0 = SYST::get_current();
                    let force = estimator.force_g(strain);
                    let t1 = SYST::get_current();
                    core::hint::black_box(force);
                    *slot = Some(elapsed(t0, t1));
                }
            }
            cx.shared.cost.lock(|c| {
                if report.is_some() {
                    c.scan_frame_step.observe(counts);
                } else {
                    c.scan_step.observe(counts);
                }
                for (span, counts) in c.estimator_update.iter_mut().zip(per_estimator) {
                    if let Some(n) = counts {
                        span.observe(n);
                    }
                }
            });
            // The contact's fit outlasts a dwell: the locate task runs it below this
            // priority. A refused spawn (the task still draining) loses nothing: it finds the
            // frame queued.
            if let Some(frame) = report {
                if local.unlocated_tx.enqueue(frame).is_err() {
                    UNLOCATED_DROPS.fetch_add(1, Ordering::Relaxed);
                }
                let _ = locate::spawn();
            }
        }
    }

    /// The completed frames' contacts, located in turn (each fit timed), then each frame to
    /// the telemetry queue (numbered there, in the scan's order).
    #[task(priority = 2, shared = [cost], local = [unlocated_rx, locator, taxel_out])]
    async fn locate(mut cx: locate::Context) {
        let local = cx.local;
        while let Some(frame) = local.unlocated_rx.dequeue() {
            let t0 = SYST::get_current();
            let r = frame.locate(local.locator);
            let t1 = SYST::get_current();
            // Preempted by the tick, the span would count the tick's work: timed only when
            // SysTick did not reload in between (its counter runs down).
            if t1 <= t0 {
                cx.shared.cost.lock(|c| c.locate.observe(t0 - t1));
            }
            if !local.taxel_out.send((r.frame, r.estimate)) {
                TAXEL_DROPS.store(local.taxel_out.dropped(), Ordering::Relaxed);
            }
        }
    }

    #[task(priority = 1, shared = [cost], local = [control_rx, taxel_rx])]
    async fn telemetry(mut cx: telemetry::Context) {
        tactile_firmware::drain(
            cx.local.control_rx,
            cx.local.taxel_rx,
            |m| match m {
                Message::Tick(frame, truth) => defmt::info!("{} {}", frame, truth),
                Message::Start(s) => defmt::info!("{}", s),
                Message::End(e) => defmt::info!("{}", e),
                Message::Reply(r) => defmt::info!("{}", r),
            },
            |(frame, estimate)| defmt::info!("{} {}", frame, estimate),
        );
        if SESSION_DONE.load(Ordering::Acquire)
            && !cx.local.control_rx.ready()
            && !cx.local.taxel_rx.ready()
        {
            let cost = cx.shared.cost.lock(|c| *c);
            defmt::info!("{}", cost.report());
            defmt::info!("{}", session::memory());
            cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_SUCCESS);
        }
    }
}
