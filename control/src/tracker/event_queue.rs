//! A small fixed-capacity FIFO of tracker events.
//!
//! One acquisition can produce several events at once (a new period, a located point, the
//! end of tracking), but a tracker reports at most one per frame: the rest wait here and go
//! out on the following frames, in order.

use super::TrackerEvent;

/// Events waiting to be reported; never allocates.
#[derive(Debug, Clone)]
pub struct EventQueue {
    slots: [Option<TrackerEvent>; EventQueue::CAPACITY],
    head: usize,
    len: usize,
}

impl Default for EventQueue {
    fn default() -> Self {
        Self {
            slots: [None; Self::CAPACITY],
            head: 0,
            len: 0,
        }
    }
}

impl EventQueue {
    pub const CAPACITY: usize = 8;

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Room for `n` more events.
    pub fn has_room_for(&self, n: usize) -> bool {
        self.len + n <= Self::CAPACITY
    }

    /// Append an event; returns it back if the queue is full.
    pub fn push(&mut self, event: TrackerEvent) -> Result<(), TrackerEvent> {
        if self.len == Self::CAPACITY {
            return Err(event);
        }
        self.slots[(self.head + self.len) % Self::CAPACITY] = Some(event);
        self.len += 1;
        Ok(())
    }

    pub fn pop(&mut self) -> Option<TrackerEvent> {
        if self.len == 0 {
            return None;
        }
        let event = self.slots[self.head].take();
        self.head = (self.head + 1) % Self::CAPACITY;
        self.len -= 1;
        event
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::SurfacePoint;

    fn missed(t_s: f64) -> TrackerEvent {
        TrackerEvent::Missed {
            t_s,
            at: SurfacePoint::default(),
        }
    }

    #[test]
    fn fifo_wraps_and_refuses_when_full() {
        let mut q = EventQueue::default();
        for round in 0..3 {
            for i in 0..EventQueue::CAPACITY {
                q.push(missed((round * 100 + i) as f64)).expect("room");
            }
            assert!(q.push(missed(-1.0)).is_err());
            for i in 0..EventQueue::CAPACITY {
                assert_eq!(q.pop(), Some(missed((round * 100 + i) as f64)));
            }
            assert_eq!(q.pop(), None);
            q.push(missed(0.5)).expect("room");
            assert_eq!(q.pop(), Some(missed(0.5)));
        }
    }
}
