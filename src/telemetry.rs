//! Telemetry frames: what the firmware streams over defmt, and what the simulator and the
//! host tools write as records. Small in bytes (a control frame is 30 bytes of payload), every
//! frame numbered, drops counted where they happen.

use crate::tactile::{COLS, ROWS};

bitflags::bitflags! {
    /// Fault flags carried by every control frame (bit set = fault present).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct FaultFlags: u16 {
        /// A gauge sample sat at a converter rail (saturated or disconnected).
        const GAUGE_AT_RAIL = 1 << 0;
        /// The averaged gauge force is outside the applicator's physical range.
        const GAUGE_OUT_OF_RANGE = 1 << 1;
        /// The adjusted command hit the actuator's range.
        const ACTUATOR_SATURATED = 1 << 2;
        /// A command or reading was NaN or infinite.
        const INVALID_INPUT = 1 << 3;
        /// The control task missed its deadline.
        const DEADLINE_OVERRUN = 1 << 4;
        /// The probe is not touching the finger while force is commanded.
        const CONTACT_LOST = 1 << 5;
        /// A taxel reads at a rail (open or shorted).
        const TAXEL_AT_RAIL = 1 << 6;
        /// Frames were dropped since the last frame that got through.
        const FRAMES_DROPPED = 1 << 7;
        /// The gauge reading has not changed for a stated time while the command did.
        const GAUGE_STUCK = 1 << 8;
        /// The gauge reading changed faster in one tick than the applicator can.
        const FORCE_SLEW = 1 << 9;
        /// The command was outside the applicator's range and was clamped.
        const COMMAND_CLAMPED = 1 << 10;
        /// A fault is latched: the actuator is held at zero until the fault is cleared.
        const LATCHED = 1 << 11;
        /// Contact was lost and the probe is re-approaching at a bounded force.
        const APPROACHING = 1 << 12;
    }
}

impl FaultFlags {
    pub const NONE: FaultFlags = FaultFlags::empty();
    /// The flags of a tick whose drive the supervisor held at zero (its safe output): a latched
    /// fault, or a reading at the gauge's rail or past its range (no force to control with).
    pub const DRIVE_HELD_AT_ZERO: FaultFlags = FaultFlags::LATCHED
        .union(FaultFlags::GAUGE_AT_RAIL)
        .union(FaultFlags::GAUGE_OUT_OF_RANGE);

    /// Names of the set flags, for logs and reports.
    pub fn names(self) -> impl Iterator<Item = &'static str> {
        const NAMES: [&str; 13] = [
            "gauge_at_rail",
            "gauge_out_of_range",
            "actuator_saturated",
            "invalid_input",
            "deadline_overrun",
            "contact_lost",
            "taxel_at_rail",
            "frames_dropped",
            "gauge_stuck",
            "force_slew",
            "command_clamped",
            "latched",
            "approaching",
        ];
        NAMES
            .into_iter()
            .enumerate()
            .filter(move |(i, _)| self.bits() & (1 << i) != 0)
            .map(|(_, n)| n)
    }
}

/// On the wire as `FaultFlags(bits)`, as the decoder reads it.
#[cfg(feature = "defmt")]
impl defmt::Format for FaultFlags {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "FaultFlags({=u16})", self.bits());
    }
}

/// One control tick of the element under the probe.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControlFrame {
    pub seq: u32,
    /// Time since start, in control ticks (1 ms at the memo's rate).
    pub tick: u32,
    pub command_g: f32,
    pub sensed_g: f32,
    pub adjusted_g: f32,
    /// Strain of the element under the probe, percent.
    pub strain_pct: f32,
    /// Contact force estimated from that strain by the on-chip inverse model.
    pub estimate_g: f32,
    /// The code this tick wrote to the DAC: what the actuator was told, excitation included
    /// (the applicator's identification takes its response against it).
    pub dac_code: u16,
    pub faults: FaultFlags,
}

/// Strain quantum of a taxel frame: 0.01 % (a 16-bit cell spans ±327 %).
pub const TAXEL_STRAIN_QUANTUM_PCT: f32 = 0.01;

/// One 8×8 scan (128 bytes of strain plus header).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TaxelFrame {
    pub seq: u32,
    /// Control tick at which the scan completed.
    pub tick: u32,
    /// Strain in units of [`TAXEL_STRAIN_QUANTUM_PCT`], row-major.
    pub strain_centi_pct: [[i16; COLS]; ROWS],
    /// Bit `row * 8 + col` set for a taxel marked bad.
    pub bad_taxels: u64,
}

impl TaxelFrame {
    /// Quantizes a strain to a cell, saturating.
    #[inline]
    pub fn quantize(strain_pct: f32) -> i16 {
        // `as` saturates at the i16 range and maps NaN to 0.
        libm::roundf(strain_pct / TAXEL_STRAIN_QUANTUM_PCT) as i16
    }
    #[inline]
    pub fn strain_pct(cell: i16) -> f32 {
        f32::from(cell) * TAXEL_STRAIN_QUANTUM_PCT
    }
}

/// Numbers frames at the source and counts those that could not be queued.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameCounter {
    next_seq: u32,
    dropped: u32,
}

impl FrameCounter {
    pub const fn new() -> Self {
        Self {
            next_seq: 0,
            dropped: 0,
        }
    }
    /// The sequence number for the next frame.
    pub fn next_seq(&mut self) -> u32 {
        let s = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1);
        s
    }
    /// Records that a numbered frame could not be queued.
    pub fn record_drop(&mut self) {
        self.dropped = self.dropped.saturating_add(1);
    }
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

/// Checks a received sequence: counts the frames missing between consecutive numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SequenceCheck {
    last: Option<u32>,
    missing: u64,
    received: u64,
}

impl SequenceCheck {
    pub fn observe(&mut self, seq: u32) {
        if let Some(last) = self.last {
            self.missing += u64::from(seq.wrapping_sub(last).wrapping_sub(1));
        }
        self.last = Some(seq);
        self.received += 1;
    }
    pub fn missing(&self) -> u64 {
        self.missing
    }
    pub fn received(&self) -> u64 {
        self.received
    }
}

/// What one control tick produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TickRecord {
    pub t_s: f64,
    pub command_g: f32,
    /// Force from the gauge path (the value the law uses next tick); on a gauge fault, the raw
    /// reading, with the fault flagged.
    pub sensed_g: f32,
    pub adjusted_g: f32,
    pub strain_pct: f32,
    pub estimate_g: f32,
    /// Simulator truth: the contact force at the end of the tick.
    pub true_force_g: f32,
    pub in_contact: bool,
    pub faults: FaultFlags,
    /// The code written to the actuator's DAC.
    pub dac_code: u16,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_small() {
        assert!(core::mem::size_of::<ControlFrame>() <= 32);
        assert!(core::mem::size_of::<TaxelFrame>() <= 8 + 128 + 8);
    }

    #[test]
    fn quantization_saturates_and_round_trips() {
        assert_eq!(TaxelFrame::quantize(12.345), 1235);
        assert!((TaxelFrame::strain_pct(1235) - 12.35).abs() < 1e-5);
        assert_eq!(TaxelFrame::quantize(1e6), i16::MAX);
        assert_eq!(TaxelFrame::quantize(-1e6), i16::MIN);
        assert_eq!(TaxelFrame::quantize(f32::NAN), 0);
    }

    #[test]
    fn sequence_gaps_are_counted() {
        let mut counter = FrameCounter::new();
        let mut check = SequenceCheck::default();
        for i in 0..10 {
            let seq = counter.next_seq();
            if i == 3 || i == 4 || i == 7 {
                counter.record_drop();
            } else {
                check.observe(seq);
            }
        }
        assert_eq!(counter.dropped(), 3);
        assert_eq!(check.missing(), 3);
        assert_eq!(check.received(), 7);
    }

    #[test]
    fn sequence_check_survives_wraparound() {
        let mut check = SequenceCheck::default();
        check.observe(u32::MAX - 1);
        check.observe(u32::MAX);
        check.observe(0);
        check.observe(2);
        assert_eq!(check.missing(), 1);
    }

    #[test]
    fn fault_flags() {
        let mut f = FaultFlags::NONE;
        f.insert(FaultFlags::GAUGE_AT_RAIL);
        assert!(f.contains(FaultFlags::GAUGE_AT_RAIL));
        assert!(!f.contains(FaultFlags::CONTACT_LOST));
    }
}
