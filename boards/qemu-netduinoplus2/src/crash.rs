//! Panic and HardFault: the simulated actuator to its safe zero before anything else, then the
//! report, then QEMU stops with a failure code. A test can ask for either crash at a given tick
//! through the semihosting command line (`-append "panic-at-tick=N"`, `hardfault-at-tick=N`).

use core::sync::atomic::{AtomicPtr, AtomicU16, Ordering};

use tactile_core::gauge::AdcCode;
use tactile_firmware::{DeliberateCrash, SafeStop};
use tactile_plant::hardware::SimHardware;

/// The simulated DAC register (null until `init` has built the board).
static SIM_DAC: AtomicPtr<AdcCode> = AtomicPtr::new(core::ptr::null_mut());
/// The code that puts zero volts into the amplifier, from the board's actuator configuration.
static SAFE_CODE: AtomicU16 = AtomicU16::new(0);

/// Gives the crash handlers the board's DAC (call once the board sits in its static).
pub fn arm(hw: &'static mut SimHardware) -> &'static mut SimHardware {
    SAFE_CODE.store(
        hw.config().firmware.actuator.zero_code().0,
        Ordering::Relaxed,
    );
    SIM_DAC.store(hw.dac_register(), Ordering::Release);
    hw
}

/// Writes the safe code into the simulated DAC and reads it back. First thing in every crash
/// handler: nothing before it may fail or wait.
pub fn zero_actuator(cause: &'static str) -> SafeStop {
    let dac = SIM_DAC.load(Ordering::Acquire);
    let safe_code = SAFE_CODE.load(Ordering::Relaxed);
    if dac.is_null() {
        return SafeStop {
            cause,
            board: false,
            dac_code: 0,
            safe_code,
        };
    }
    // SAFETY: `dac` points into the board's static (set by `arm`), which is never moved or
    // freed. The task that held the board is not resumed after a crash, so this write is the
    // last access to the register, as a crash handler's write to a real DAC register is.
    let dac_code = unsafe {
        core::ptr::write_volatile(dac, AdcCode(safe_code));
        core::ptr::read_volatile(dac).0
    };
    SafeStop {
        cause,
        board: true,
        dac_code,
        safe_code,
    }
}

/// Stops QEMU with a failure code (the test sees it), after a crash report.
pub fn stop() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// The crash the command line asks for, if any.
pub fn requested(cmdline: &[u8]) -> Option<DeliberateCrash> {
    DeliberateCrash::from_cmdline(cmdline)
}

/// The semihosting command line (the ELF's path, then `-append`'s words), NUL-terminated;
/// empty if the host gives none.
pub fn cmdline() -> [u8; 256] {
    let mut cmdline = [0u8; 256];
    // SAFETY: SYS_GET_CMDLINE writes at most `len` bytes (NUL included) into the buffer.
    let status =
        unsafe { cortex_m_semihosting::syscall!(GET_CMDLINE, cmdline.as_mut_ptr(), cmdline.len()) };
    if status != 0 {
        return [0u8; 256];
    }
    cmdline
}

/// Reads the host file `path` into `buf` over semihosting; the bytes read, or `None` if it
/// cannot be opened or read.
pub fn read_file(path: &str, buf: &mut [u8]) -> Option<usize> {
    let mut name = [0u8; 200];
    let bytes = path.as_bytes();
    name.get_mut(..bytes.len())?.copy_from_slice(bytes);
    // NOTE: SYS_OPEN wants a NUL-terminated name and its length without the NUL; mode 1 is
    // "rb".
    // SAFETY: the name outlives the call and holds the NUL the host reads up to.
    let handle = unsafe { cortex_m_semihosting::syscall!(OPEN, name.as_ptr(), 1, bytes.len()) };
    if handle == usize::MAX || bytes.len() >= name.len() {
        return None;
    }
    // SAFETY: SYS_READ writes at most `len` bytes into the buffer; it returns the bytes not
    // read.
    let left = unsafe { cortex_m_semihosting::syscall!(READ, handle, buf.as_mut_ptr(), buf.len()) };
    // SAFETY: closes the handle opened above.
    unsafe { cortex_m_semihosting::syscall!(CLOSE, handle) };
    buf.len().checked_sub(left)
}

/// Crashes as asked when the control task reaches the requested tick.
pub fn at_tick(request: Option<DeliberateCrash>, tick: u32) {
    match request {
        Some(DeliberateCrash::Panic { tick: t }) if t == tick => deliberate_panic(tick),
        Some(DeliberateCrash::HardFault { tick: t }) if t == tick => cortex_m::asm::udf(),
        _ => {}
    }
}

#[allow(clippy::panic)] // the test's deliberate panic: the handler is what is being tested
fn deliberate_panic(tick: u32) -> ! {
    panic!("deliberate panic at tick {tick} (panic-at-tick)")
}
