//! Latest-value slots: one writer publishes a fixed-size record, any number of readers take
//! the newest complete copy. A sequence lock over atomics: the writer never waits, never
//! allocates and never takes a lock, so the 1 kHz loop can publish into one every cycle.

use std::sync::atomic::{AtomicU64, Ordering, fence};

/// Words in every slot record.
pub const SLOT_WORDS: usize = 48;

/// Attempts a reader spins before it starts yielding to a busy writer.
const SPINS_BEFORE_YIELD: u32 = 1000;
/// How long a reader waits for a writer caught in the middle of a record.
const READ_PATIENCE: std::time::Duration = std::time::Duration::from_millis(250);

/// A record that travels through a [`Slot`] as plain 64-bit words.
pub trait Packed: Sized {
    fn pack(&self, out: &mut [u64; SLOT_WORDS]);
    fn unpack(words: &[u64; SLOT_WORDS]) -> Self;
}

/// A single-writer latest-value slot.
#[derive(Debug)]
pub struct Slot<T> {
    seq: AtomicU64,
    words: [AtomicU64; SLOT_WORDS],
    _record: std::marker::PhantomData<fn() -> T>,
}

impl<T: Packed> Default for Slot<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Packed> Slot<T> {
    pub fn new() -> Self {
        Self {
            seq: AtomicU64::new(0),
            words: std::array::from_fn(|_| AtomicU64::new(0)),
            _record: std::marker::PhantomData,
        }
    }

    /// Publish a record. Only one thread may write a given slot.
    pub fn write(&self, value: &T) {
        let mut buf = [0u64; SLOT_WORDS];
        value.pack(&mut buf);
        let s = self.seq.load(Ordering::Relaxed);
        self.seq.store(s.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        for (w, v) in self.words.iter().zip(buf.iter()) {
            w.store(*v, Ordering::Relaxed);
        }
        self.seq.store(s.wrapping_add(2), Ordering::Release);
    }

    /// The newest record, or `None` if nothing was written yet, or if the writer stayed in
    /// the middle of a record for `READ_PATIENCE` (a writer thread stopped mid-record).
    ///
    /// A writer preempted between its stores (a loaded machine deschedules even the loop's
    /// thread for milliseconds) holds the slot busy far longer than a spin: the reader then
    /// yields and tries again rather than give up. It used to give up after 1000 spins, and
    /// `status` then showed a default record (no sensor position, the arm disabled) in a
    /// loaded CI run. Readers are the supervisor and the watchdog, never the 1 kHz loop.
    pub fn read(&self) -> Option<T> {
        let mut since: Option<std::time::Instant> = None;
        let mut spins = 0u32;
        loop {
            let s1 = self.seq.load(Ordering::Acquire);
            if s1 == 0 {
                return None;
            }
            if s1 & 1 == 0 {
                let buf: [u64; SLOT_WORDS] =
                    std::array::from_fn(|i| self.words[i].load(Ordering::Relaxed));
                fence(Ordering::Acquire);
                if self.seq.load(Ordering::Relaxed) == s1 {
                    return Some(T::unpack(&buf));
                }
            }
            spins += 1;
            if spins < SPINS_BEFORE_YIELD {
                std::hint::spin_loop();
                continue;
            }
            let started = *since.get_or_insert_with(std::time::Instant::now);
            if started.elapsed() >= READ_PATIENCE {
                return None;
            }
            std::thread::yield_now();
        }
    }
}

/// Sequential packing of numbers into slot words.
#[derive(Debug)]
pub struct Packer<'a> {
    out: &'a mut [u64; SLOT_WORDS],
    at: usize,
}

impl<'a> Packer<'a> {
    pub fn new(out: &'a mut [u64; SLOT_WORDS]) -> Self {
        Self { out, at: 0 }
    }
    pub fn u64(&mut self, v: u64) -> &mut Self {
        if let Some(w) = self.out.get_mut(self.at) {
            *w = v;
        }
        self.at += 1;
        self
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.u64(v.to_bits())
    }
    pub fn f64s(&mut self, vs: &[f64]) -> &mut Self {
        for v in vs {
            self.f64(*v);
        }
        self
    }
}

/// Sequential unpacking, the mirror of [`Packer`].
#[derive(Debug)]
pub struct Unpacker<'a> {
    words: &'a [u64; SLOT_WORDS],
    at: usize,
}

impl<'a> Unpacker<'a> {
    pub fn new(words: &'a [u64; SLOT_WORDS]) -> Self {
        Self { words, at: 0 }
    }
    pub fn u64(&mut self) -> u64 {
        let v = self.words.get(self.at).copied().unwrap_or(0);
        self.at += 1;
        v
    }
    pub fn f64(&mut self) -> f64 {
        f64::from_bits(self.u64())
    }
    pub fn f64s<const N: usize>(&mut self) -> [f64; N] {
        std::array::from_fn(|_| self.f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[derive(Debug, PartialEq)]
    struct Pair {
        a: f64,
        b: u64,
    }

    impl Packed for Pair {
        fn pack(&self, out: &mut [u64; SLOT_WORDS]) {
            let mut p = Packer::new(out);
            p.f64(self.a).u64(self.b);
            // Fill every word so a torn read would show as a mismatch.
            for i in 2..SLOT_WORDS {
                p.u64(self.b.wrapping_add(i as u64));
            }
        }
        fn unpack(words: &[u64; SLOT_WORDS]) -> Self {
            let b = words[1];
            for (i, w) in words.iter().enumerate().skip(2) {
                assert_eq!(*w, b.wrapping_add(i as u64), "torn read");
            }
            Pair {
                a: f64::from_bits(words[0]),
                b,
            }
        }
    }

    #[test]
    fn empty_then_latest() {
        let s: Slot<Pair> = Slot::new();
        assert!(s.read().is_none());
        s.write(&Pair { a: 1.5, b: 7 });
        s.write(&Pair { a: -2.0, b: 9 });
        assert_eq!(s.read(), Some(Pair { a: -2.0, b: 9 }));
    }

    /// A writer preempted in the middle of a record (the sequence left odd) for far longer
    /// than a spin: the reader waits for it and gets its record, not `None`.
    #[test]
    fn a_reader_waits_out_a_writer_preempted_mid_record() {
        let s: Arc<Slot<Pair>> = Arc::new(Slot::new());
        s.write(&Pair { a: 1.0, b: 1 });
        // Half a write: the sequence odd, as between the writer's first and last store.
        let busy = s.seq.load(Ordering::Relaxed);
        s.seq.store(busy + 1, Ordering::Release);
        let w = Arc::clone(&s);
        let writer = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(20));
            // The rest of that write.
            let mut buf = [0u64; SLOT_WORDS];
            Pair { a: 2.0, b: 2 }.pack(&mut buf);
            for (word, v) in w.words.iter().zip(buf.iter()) {
                word.store(*v, Ordering::Relaxed);
            }
            w.seq.store(busy + 2, Ordering::Release);
        });
        assert_eq!(s.read(), Some(Pair { a: 2.0, b: 2 }));
        writer.join().expect("writer thread");
    }

    #[test]
    fn concurrent_readers_never_see_a_torn_record() {
        let s: Arc<Slot<Pair>> = Arc::new(Slot::new());
        let w = Arc::clone(&s);
        let writer = std::thread::spawn(move || {
            for i in 0..200_000u64 {
                w.write(&Pair { a: i as f64, b: i });
            }
        });
        let mut last = 0;
        while !writer.is_finished() {
            if let Some(p) = s.read() {
                assert_eq!(p.a, p.b as f64);
                assert!(p.b >= last, "went backwards");
                last = p.b;
            }
        }
        writer.join().expect("writer thread");
    }
}
