//! The flight recorder: the last few seconds of the loop's states and commands in a
//! preallocated ring, frozen when a fault latches and dumped to a file for the post-mortem.
//!
//! The loop writes with `try_lock` only, so it never waits: while a dump holds the ring, the
//! loop skips recording (and the ring is frozen then anyway).

use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Mutex};

use control::types::Joints;
use serde::Serialize;

/// One cycle as the loop saw and commanded it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct CycleRecord {
    pub t_s: f64,
    pub cycle: u64,
    /// 0 disabled, 1 enabled, 2 faulted.
    pub mode: u8,
    pub position_rad: Joints,
    pub velocity_rad_s: Joints,
    pub setpoint_rad: Joints,
    pub torque_nm: Joints,
    pub sensor_x_m: f64,
    pub sensor_z_m: f64,
    pub setpoint_x_m: f64,
    pub setpoint_z_m: f64,
    pub contact_n: f64,
    pub tactile_age_s: f64,
    /// Sequence number of the last command applied.
    pub command_seq: u64,
}

#[derive(Debug)]
struct Ring {
    records: Vec<CycleRecord>,
    next: usize,
    filled: bool,
    frozen: bool,
}

/// Shared between the loop (writer) and whoever dumps it.
#[derive(Debug, Clone)]
pub struct FlightRecorder {
    ring: Arc<Mutex<Ring>>,
}

impl FlightRecorder {
    /// Room for `capacity` cycles, allocated now.
    pub fn new(capacity: usize) -> Self {
        Self {
            ring: Arc::new(Mutex::new(Ring {
                records: vec![CycleRecord::default(); capacity.max(1)],
                next: 0,
                filled: false,
                frozen: false,
            })),
        }
    }

    /// Record a cycle unless frozen or busy. Never blocks, never allocates.
    pub fn record(&self, r: &CycleRecord) {
        if let Ok(mut ring) = self.ring.try_lock() {
            if ring.frozen {
                return;
            }
            let i = ring.next;
            ring.records[i] = *r;
            ring.next = (i + 1) % ring.records.len();
            if ring.next == 0 {
                ring.filled = true;
            }
        }
    }

    /// Stop recording (on a fault): the ring keeps the seconds that led up to it.
    pub fn freeze(&self) {
        if let Ok(mut ring) = self.ring.try_lock() {
            ring.frozen = true;
        }
    }

    /// Start recording again (after a reset).
    pub fn thaw(&self) {
        if let Ok(mut ring) = self.ring.try_lock() {
            ring.frozen = false;
        }
    }

    /// The recorded cycles, oldest first.
    pub fn snapshot(&self) -> Vec<CycleRecord> {
        let ring = match self.ring.lock() {
            Ok(r) => r,
            Err(poisoned) => poisoned.into_inner(),
        };
        let mut out = Vec::with_capacity(ring.records.len());
        if ring.filled {
            out.extend_from_slice(&ring.records[ring.next..]);
        }
        out.extend_from_slice(&ring.records[..ring.next]);
        out
    }

    /// Write the snapshot as JSON lines to `path`, fsync'd. Returns the number of records.
    pub fn dump(&self, path: &Path) -> std::io::Result<usize> {
        self.dump_to(crate::private_fs::create_new(path)?)
    }

    /// Write the frozen ring to `file` (one JSON object a line) and fsync it.
    pub fn dump_to(&self, file: std::fs::File) -> std::io::Result<usize> {
        let records = self.snapshot();
        let mut f = std::io::BufWriter::new(file);
        for r in &records {
            serde_json::to_writer(&mut f, r)?;
            f.write_all(b"\n")?;
        }
        let f = f.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()?;
        Ok(records.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(cycle: u64) -> CycleRecord {
        CycleRecord {
            cycle,
            t_s: cycle as f64 * 0.001,
            ..Default::default()
        }
    }

    #[test]
    fn keeps_the_last_cycles_oldest_first_and_freezes() {
        let fr = FlightRecorder::new(5);
        for c in 0..12 {
            fr.record(&rec(c));
        }
        let s: Vec<u64> = fr.snapshot().iter().map(|r| r.cycle).collect();
        assert_eq!(s, vec![7, 8, 9, 10, 11]);
        fr.freeze();
        fr.record(&rec(12));
        assert_eq!(fr.snapshot().last().map(|r| r.cycle), Some(11));
        fr.thaw();
        fr.record(&rec(13));
        assert_eq!(fr.snapshot().last().map(|r| r.cycle), Some(13));
    }

    #[test]
    fn partial_ring_and_dump() {
        let fr = FlightRecorder::new(100);
        for c in 0..3 {
            fr.record(&rec(c));
        }
        assert_eq!(fr.snapshot().len(), 3);
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("fault.jsonl");
        assert_eq!(fr.dump(&p).expect("dump"), 3);
        let text = std::fs::read_to_string(&p).expect("read");
        let lines: Vec<serde_json::Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).expect("json"))
            .collect();
        assert_eq!(lines[2]["cycle"], 2);
    }
}
