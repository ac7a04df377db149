//! Replaying a candump log (`candump -L` format) as a CAN adapter: events come out when the
//! caller's clock reaches their time in the log (relative to the first record), and frames
//! the driver sends are kept for inspection. Lines that do not parse are counted, not fatal.

use std::io::Read;
use std::sync::Arc;

use socketcan::dump::Reader;

use super::adapter::{AdapterError, CanAdapter};
use super::frame::{BusEvent, DataFrame};
use super::socketcan_conv::event_from_frame;
use crate::clock::Clock;

/// A candump log played back against a clock.
#[derive(Debug)]
pub struct CandumpReplay {
    events: Vec<(f64, BusEvent)>,
    next: usize,
    start_s: f64,
    clock: Arc<dyn Clock>,
    sent: Vec<DataFrame>,
    bad_lines: Vec<String>,
}

impl CandumpReplay {
    /// Read every record of the log. Playback starts at the clock's current time.
    pub fn from_reader(log: impl Read, clock: Arc<dyn Clock>) -> Self {
        let mut reader = Reader::from_reader(log);
        let mut events = Vec::new();
        let mut bad_lines = Vec::new();
        let mut t0_us = None;
        let mut line = 0usize;
        loop {
            line += 1;
            match reader.next_record() {
                Ok(None) => break,
                Ok(Some(rec)) => {
                    let t0 = *t0_us.get_or_insert(rec.t_us);
                    let t_s = rec.t_us.saturating_sub(t0) as f64 * 1e-6;
                    events.push((t_s, event_from_frame(rec.frame)));
                }
                Err(socketcan::dump::ParseError::Io(e)) => {
                    bad_lines.push(format!("line {line}: {e}"));
                    break;
                }
                Err(e) => bad_lines.push(format!("line {line}: {e}")),
            }
        }
        let start_s = clock.now_s();
        Self {
            events,
            next: 0,
            start_s,
            clock,
            sent: Vec::new(),
            bad_lines,
        }
    }

    /// Open a log file.
    pub fn from_file(path: &std::path::Path, clock: Arc<dyn Clock>) -> std::io::Result<Self> {
        Ok(Self::from_reader(std::fs::File::open(path)?, clock))
    }

    /// Records that could not be parsed, with their line numbers.
    pub fn bad_lines(&self) -> &[String] {
        &self.bad_lines
    }

    pub fn events(&self) -> usize {
        self.events.len()
    }

    /// Everything has been played.
    pub fn finished(&self) -> bool {
        self.next >= self.events.len()
    }

    /// Time of the last event, relative to the first, s.
    pub fn duration_s(&self) -> f64 {
        self.events.last().map_or(0.0, |e| e.0)
    }

    /// Frames the driver sent.
    pub fn sent(&self) -> &[DataFrame] {
        &self.sent
    }
}

impl CanAdapter for CandumpReplay {
    fn recv(&mut self) -> Result<Option<BusEvent>, AdapterError> {
        let elapsed = self.clock.now_s() - self.start_s;
        match self.events.get(self.next) {
            Some(&(t, ev)) if t <= elapsed + 1e-9 => {
                self.next += 1;
                Ok(Some(ev))
            }
            _ => Ok(None),
        }
    }

    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError> {
        self.sent.push(*frame);
        Ok(())
    }

    fn discard_pending_tx(&mut self) -> Result<(), AdapterError> {
        Ok(())
    }

    fn describe(&self) -> String {
        "candump replay".into()
    }

    /// A log cannot be unplugged: nothing to reopen; the replay goes on where it was.
    fn reopen(&mut self) -> Result<(), AdapterError> {
        Ok(())
    }
}
