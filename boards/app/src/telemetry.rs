//! Outboxes: the producing side of the bounded queues between the real-time tasks and the
//! telemetry task. Sending numbers the frame ([`FrameCounter`]), never blocks, and on a full
//! queue drops the frame, counts it and flags the next frame that gets through.

use heapless::spsc::Producer;
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
}

impl<X> Numbered for Message<X> {
    fn sequence_slot(&mut self) -> Option<&mut u32> {
        match self {
            Message::Tick(frame, _) => Some(&mut frame.seq),
            Message::Start(_) | Message::End(_) => None,
        }
    }
    fn flag_dropped(&mut self) {
        if let Message::Tick(frame, _) = self {
            frame.flag_dropped();
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

    /// Numbers `item` and queues it; on a full queue drops it and counts the drop. Returns
    /// whether it was queued.
    pub fn send(&mut self, mut item: T) -> bool {
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
        assert_eq!(check.missing(), 2);
        // The marker is not numbered and does not clear the flag logic.
        assert!(matches!(consumer.dequeue(), Some(Message::Start(_))));
        assert!(outbox.send(Message::Tick(frame, ())));
        let Some(Message::Tick(after, ())) = consumer.dequeue() else {
            panic!("a frame was queued");
        };
        assert!(!after.faults.contains(FaultFlags::FRAMES_DROPPED));
        assert_eq!(after.seq, next.seq + 1);
    }
}
