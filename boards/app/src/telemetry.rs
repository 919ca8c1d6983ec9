//! Outboxes: the producing side of the bounded queues between the real-time tasks and the
//! telemetry task. Sending never blocks: on a full queue the frame is dropped, counted, and the
//! next frame that gets through carries `FRAMES_DROPPED`. Only queued frames are numbered
//! ([`FrameCounter`]), so the receiver's sequence stays contiguous across such drops and a gap
//! there means something else lost frames (the RTT buffer, a damaged log): the two kinds of
//! loss are told apart, and neither is silent.

use heapless::spsc::{Consumer, Producer};
use tactile_core::telemetry::{ControlFrame, FaultFlags, FrameCounter, TaxelFrame};

/// A frame that carries a sequence number.
pub trait Numbered {
    /// Where the sequence number goes; `None` for unnumbered messages.
    fn sequence_slot(&mut self) -> Option<&mut u32>;
    /// Marks that frames were dropped before this one (no-op where there is no flag).
    fn flag_dropped(&mut self) {}
}

impl Numbered for ControlFrame {
    fn sequence_slot(&mut self) -> Option<&mut u32> {
        Some(&mut self.seq)
    }
    fn flag_dropped(&mut self) {
        self.faults.insert(FaultFlags::FRAMES_DROPPED);
    }
}

impl Numbered for TaxelFrame {
    fn sequence_slot(&mut self) -> Option<&mut u32> {
        Some(&mut self.seq)
    }
}

/// A frame with board data riding along (simulator truth, the array estimate).
impl<A: Numbered, B> Numbered for (A, B) {
    fn sequence_slot(&mut self) -> Option<&mut u32> {
        self.0.sequence_slot()
    }
    fn flag_dropped(&mut self) {
        self.0.flag_dropped();
    }
}

/// A protocol run begins: its name, the board tick of its first control tick, its length.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RunStart {
    pub name: &'static str,
    pub start_tick: u32,
    pub duration_s: f32,
}

/// A protocol run ended; counts since boot.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RunEnd {
    pub end_tick: u32,
    pub control_frames_dropped: u32,
    pub taxel_frames_dropped: u32,
    pub overruns: u32,
}

/// What the control task sends: its frames (with `X` riding along) and run markers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message<X> {
    Tick(ControlFrame, X),
    Start(RunStart),
    End(RunEnd),
    /// The answer to a command from the host.
    Reply(crate::commands::Reply),
}

impl<X> Numbered for Message<X> {
    fn sequence_slot(&mut self) -> Option<&mut u32> {
        match self {
            Message::Tick(frame, _) => Some(&mut frame.seq),
            Message::Start(_) | Message::End(_) | Message::Reply(_) => None,
        }
    }
    fn flag_dropped(&mut self) {
        if let Message::Tick(frame, _) = self {
            frame.flag_dropped();
        }
    }
}

/// The telemetry task's body: every control message waiting, then one taxel frame, again until
/// both queues are empty; each handed to its log.
pub fn drain<C, T>(
    control: &mut Consumer<'_, C>,
    taxels: &mut Consumer<'_, T>,
    mut log_control: impl FnMut(C),
    mut log_taxel: impl FnMut(T),
) {
    loop {
        let mut idle = true;
        while let Some(m) = control.dequeue() {
            idle = false;
            log_control(m);
        }
        if let Some(t) = taxels.dequeue() {
            idle = false;
            log_taxel(t);
        }
        if idle {
            break;
        }
    }
}

/// The producing end of a telemetry queue.
pub struct Outbox<'q, T> {
    producer: Producer<'q, T>,
    counter: FrameCounter,
    dropped_since_sent: bool,
}

impl<'q, T: Numbered> Outbox<'q, T> {
    pub fn new(producer: Producer<'q, T>) -> Self {
        Self {
            producer,
            counter: FrameCounter::new(),
            dropped_since_sent: false,
        }
    }

    /// Numbers `item` and queues it; on a full queue drops it and counts the drop, without
    /// waiting. Returns whether it was queued.
    pub fn send(&mut self, mut item: T) -> bool {
        // One producer: a queue with room now still has room at the enqueue below.
        if !self.producer.ready() {
            self.counter.record_drop();
            self.dropped_since_sent = true;
            return false;
        }
        let numbered = match item.sequence_slot() {
            Some(slot) => {
                *slot = self.counter.next_seq();
                true
            }
            None => false,
        };
        if self.dropped_since_sent && numbered {
            item.flag_dropped();
        }
        match self.producer.enqueue(item) {
            Ok(()) => {
                if numbered {
                    self.dropped_since_sent = false;
                }
                true
            }
            Err(_) => {
                // Not reachable with a single producer (checked above); counted all the same.
                self.counter.record_drop();
                self.dropped_since_sent = true;
                false
            }
        }
    }

    /// Items dropped since the outbox was made.
    pub fn dropped(&self) -> u32 {
        self.counter.dropped()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heapless::spsc::Queue;
    use tactile_core::telemetry::SequenceCheck;

    #[test]
    fn a_full_queue_drops_counts_and_flags_the_next_frame() {
        let mut queue: Queue<Message<()>, 4> = Queue::new();
        let (producer, mut consumer) = queue.split();
        let mut outbox = Outbox::new(producer);
        let capacity = consumer.capacity();
        let frame = ControlFrame::default();
        for _ in 0..capacity {
            assert!(outbox.send(Message::Tick(frame, ())));
        }
        // Full: the next two are dropped, not waited for.
        assert!(!outbox.send(Message::Tick(frame, ())));
        assert!(!outbox.send(Message::Tick(frame, ())));
        assert_eq!(outbox.dropped(), 2);
        let mut check = SequenceCheck::default();
        while let Some(Message::Tick(f, ())) = consumer.dequeue() {
            assert!(!f.faults.contains(FaultFlags::FRAMES_DROPPED));
            check.observe(f.seq);
        }
        assert!(outbox.send(Message::Tick(frame, ())));
        assert!(outbox.send(Message::Start(RunStart {
            name: "x",
            start_tick: 0,
            duration_s: 1.0,
        })));
        let Some(Message::Tick(next, ())) = consumer.dequeue() else {
            panic!("a frame was queued");
        };
        assert!(next.faults.contains(FaultFlags::FRAMES_DROPPED));
        check.observe(next.seq);
        // The drops are in the count and the flag, not in the sequence.
        assert_eq!(check.missing(), 0);
        // The marker is not numbered and does not clear the flag logic.
        assert!(matches!(consumer.dequeue(), Some(Message::Start(_))));
        assert!(outbox.send(Message::Tick(frame, ())));
        let Some(Message::Tick(after, ())) = consumer.dequeue() else {
            panic!("a frame was queued");
        };
        assert!(!after.faults.contains(FaultFlags::FRAMES_DROPPED));
        assert_eq!(after.seq, next.seq + 1);
    }

    /// The control task against a telemetry task that falls behind: 3 s of force steps on the
    /// simulated board, sending every frame into a 4-deep queue that is drained only every
    /// 10th tick. Control never waits and computes exactly what it computes with a queue that
    /// is always drained; every drop is counted and flagged on the next frame through, and the
    /// received sequence has no gap.
    #[test]
    fn a_full_telemetry_queue_never_blocks_or_changes_control() {
        use crate::Controller;
        use tactile_core::profile::Protocol;
        use tactile_plant::hardware::SimHardware;
        use tactile_plant::rig::RigConfig;

        const TICKS: u32 = 3000;
        const DRAIN_EVERY: u32 = 10;
        let protocol = Protocol::FORCE_STEPS_MEMO;
        let rig = RigConfig {
            command_slew_g_per_s: protocol.slew_limit_g_per_s(),
            ..RigConfig::default()
        };
        let fw = rig.firmware;
        // Control outputs with a queue drained every tick (`slow` false) or every 10th.
        let run = |slow: bool| {
            let mut hw = SimHardware::new(&rig);
            let cal = hw.calibration()[fw.probe.index()];
            let mut controller = Controller::new(&fw, protocol, cal).unwrap();
            let mut queue: Queue<Message<()>, 5> = Queue::new();
            let (producer, mut consumer) = queue.split();
            let mut outbox = Outbox::new(producer);
            let (mut dac, mut received, mut refused) = (Vec::new(), Vec::new(), 0u32);
            for k in 0..TICKS {
                let frame = controller.tick(&mut hw, k);
                dac.push(hw.dac().0);
                hw.advance_period();
                // `send` returns at once, queued or not: the loop finishing is the proof.
                if !outbox.send(Message::Tick(frame, ())) {
                    refused += 1;
                }
                if !slow || k % DRAIN_EVERY == DRAIN_EVERY - 1 {
                    while let Some(Message::Tick(f, ())) = consumer.dequeue() {
                        received.push(f);
                    }
                }
            }
            (dac, received, refused, outbox.dropped())
        };
        let (dac_fast, received_fast, refused_fast, dropped_fast) = run(false);
        let (dac_slow, received, refused, dropped) = run(true);
        assert_eq!((refused_fast, dropped_fast), (0, 0));
        assert_eq!(received_fast.len(), TICKS as usize);
        assert_eq!(
            dac_slow, dac_fast,
            "a full queue changed what control computed"
        );
        // Capacity 4, drained every 10 ticks: 6 of every 10 frames dropped and counted.
        assert_eq!(refused, TICKS / DRAIN_EVERY * 6);
        assert_eq!(dropped, refused);
        assert_eq!(received.len() as u32 + dropped, TICKS);
        let mut check = SequenceCheck::default();
        for (i, f) in received.iter().enumerate() {
            check.observe(f.seq);
            // Each burst of drops is flagged on the first frame through after it: the first of
            // every drained batch of 4 but the very first one.
            let flagged = f.faults.contains(FaultFlags::FRAMES_DROPPED);
            assert_eq!(flagged, i > 0 && i % 4 == 0, "frame {i} seq {}", f.seq);
        }
        assert_eq!(check.missing(), 0);
        assert_eq!(check.received(), received.len() as u64);
        // What got through is what control computed, in order.
        assert!(received
            .iter()
            .zip(received.iter().skip(1))
            .all(|(a, b)| b.tick > a.tick));
    }
}
