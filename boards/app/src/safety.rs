//! What keeps a board safe when the firmware itself fails: the check-ins that let the
//! independent watchdog be fed, the reset cause reported at boot, and the report a crash
//! handler gives after it has zeroed the actuator.

use core::sync::atomic::{AtomicBool, Ordering};

/// Check-ins of the tasks the watchdog stands for. The watchdog is fed only when every one has
/// checked in since the last feed: a stuck control task, or a telemetry task starved of CPU,
/// lets it expire and reset the board (the DAC then comes up at its reset state, and the
/// firmware writes the safe code before anything else).
#[derive(Debug, Default)]
pub struct CheckIns {
    control: AtomicBool,
    telemetry: AtomicBool,
}

impl CheckIns {
    pub const fn new() -> Self {
        Self {
            control: AtomicBool::new(false),
            telemetry: AtomicBool::new(false),
        }
    }

    /// The control task completed a tick.
    pub fn control(&self) {
        self.control.store(true, Ordering::Release);
    }

    /// The telemetry task ran.
    pub fn telemetry(&self) {
        self.telemetry.store(true, Ordering::Release);
    }

    /// True when both tasks have checked in since the last time this returned true; the
    /// check-ins are then consumed (the caller feeds the watchdog). A check-in that lands
    /// between the test and the clear is lost, which only delays the next feed by one tick.
    pub fn both_since_last_feed(&self) -> bool {
        if self.control.load(Ordering::Acquire) && self.telemetry.load(Ordering::Acquire) {
            self.control.store(false, Ordering::Release);
            self.telemetry.store(false, Ordering::Release);
            true
        } else {
            false
        }
    }
}

/// Why the chip last reset: the STM32F4's RCC_CSR flags (RM0090 §7.3.21), read at boot before
/// they are cleared. A power-on reset also sets the pin and brown-out flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResetCause {
    /// The most telling flag set, in the order below (`"none"` when no flag is set).
    pub cause: &'static str,
    pub independent_watchdog: bool,
    pub window_watchdog: bool,
    pub low_power: bool,
    pub software: bool,
    pub power_on: bool,
    pub pin: bool,
    pub brown_out: bool,
    /// The register as read.
    pub rcc_csr: u32,
}

impl ResetCause {
    /// RCC_CSR bits (RM0090): LPWRRSTF 31, WWDGRSTF 30, IWDGRSTF 29, SFTRSTF 28, PORRSTF 27,
    /// PINRSTF 26, BORRSTF 25.
    const FLAGS: [(u32, &'static str); 7] = [
        (29, "independent-watchdog"),
        (30, "window-watchdog"),
        (31, "low-power"),
        (28, "software"),
        (27, "power-on"),
        (25, "brown-out"),
        (26, "pin"),
    ];

    pub fn from_rcc_csr(rcc_csr: u32) -> Self {
        let bit = |n: u32| rcc_csr & (1 << n) != 0;
        let cause = Self::FLAGS
            .iter()
            .find(|(n, _)| bit(*n))
            .map_or("none", |(_, name)| name);
        Self {
            cause,
            independent_watchdog: bit(29),
            window_watchdog: bit(30),
            low_power: bit(31),
            software: bit(28),
            power_on: bit(27),
            pin: bit(26),
            brown_out: bit(25),
            rcc_csr,
        }
    }
}

/// What a panic or HardFault handler reports, after it has put the safe code into the DAC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafeStop {
    /// `"panic"` or `"hardfault"`.
    pub cause: &'static str,
    /// Whether there was an actuator to make safe (false: the crash came before it existed).
    pub board: bool,
    /// The DAC register read back after the write.
    pub dac_code: u16,
    /// The code that puts zero volts into the amplifier.
    pub safe_code: u16,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_watchdog_is_fed_only_when_both_tasks_checked_in() {
        let c = CheckIns::new();
        assert!(!c.both_since_last_feed());
        c.control();
        c.control();
        assert!(!c.both_since_last_feed(), "telemetry has not run");
        c.telemetry();
        assert!(c.both_since_last_feed());
        // Consumed: the next feed needs both again.
        assert!(!c.both_since_last_feed());
        c.telemetry();
        assert!(!c.both_since_last_feed(), "control has not run");
        c.control();
        assert!(c.both_since_last_feed());
    }

    #[test]
    fn reset_causes_are_named_from_rcc_csr() {
        // Power-on: POR, PIN and BOR set together (the reset value of the register).
        let por = ResetCause::from_rcc_csr(0x0E00_0000);
        assert_eq!(por.cause, "power-on");
        assert!(por.power_on && por.pin && por.brown_out && !por.independent_watchdog);
        let iwdg = ResetCause::from_rcc_csr((1 << 29) | (1 << 26));
        assert_eq!(iwdg.cause, "independent-watchdog");
        assert!(iwdg.independent_watchdog && iwdg.pin);
        assert_eq!(ResetCause::from_rcc_csr(1 << 26).cause, "pin");
        assert_eq!(ResetCause::from_rcc_csr(1 << 28).cause, "software");
        assert_eq!(ResetCause::from_rcc_csr(0).cause, "none");
        // RMVF (bit 24) and the LSI bits are not causes.
        assert_eq!(ResetCause::from_rcc_csr((1 << 24) | 0b11).cause, "none");
    }
}
