//! Lawicel serial-line CAN (slcan), the ASCII protocol of common USB-CAN adapters: the codec,
//! and an adapter that drives such a device on a tty directly (no kernel CAN support needed).
//!
//! Host to adapter: `S8\r` (1 Mbit/s), `O\r` open, `C\r` close, `F\r` status flags,
//! `tIIILDD..\r` send a standard frame. Adapter to host: `\r` ok, `\x07` error, `z\r` frame
//! queued, `FXX\r` status, `tIIILDD..[TTTT]\r` received frame (optional timestamp).

use std::collections::VecDeque;
use std::io::Write;
use std::time::{Duration, Instant};

use super::adapter::{AdapterError, CanAdapter};
use super::frame::{BusCondition, BusEvent, DataFrame};

/// Longest line either side sends: `T` + 8 id digits + dlc + 16 data digits + 4 timestamp.
const MAX_LINE: usize = 32;

/// Status flag bits of the `F` reply.
pub mod flags {
    pub const RX_FIFO_FULL: u8 = 0x01;
    pub const TX_FIFO_FULL: u8 = 0x02;
    pub const ERROR_WARNING: u8 = 0x04;
    pub const DATA_OVERRUN: u8 = 0x08;
    pub const ERROR_PASSIVE: u8 = 0x20;
    pub const ARBITRATION_LOST: u8 = 0x40;
    /// Lawicel's "bus error" flag; compatible firmwares set it when the controller goes
    /// bus-off, and it is treated as bus-off here.
    pub const BUS_ERROR: u8 = 0x80;
}

/// The `S` code for a bitrate.
pub fn bitrate_code(bitrate_bps: u32) -> Option<u8> {
    config::schema::SLCAN_BITRATES
        .iter()
        .position(|&b| b == bitrate_bps)
        .map(|i| i as u8)
}

/// What the bus condition is, given the status flags.
pub fn condition_from_flags(f: u8) -> BusCondition {
    BusCondition {
        bus_off: f & flags::BUS_ERROR != 0,
        error_passive: f & flags::ERROR_PASSIVE != 0,
        error_warning: f & flags::ERROR_WARNING != 0,
        back_to_active: f & (flags::ERROR_PASSIVE | flags::BUS_ERROR) == 0,
        restarted: false,
        other: f
            & (flags::RX_FIFO_FULL
                | flags::TX_FIFO_FULL
                | flags::DATA_OVERRUN
                | flags::ARBITRATION_LOST)
            != 0,
    }
}

fn hex_digit(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'A'..=b'F' => Some(b - b'A' + 10),
        b'a'..=b'f' => Some(b - b'a' + 10),
        _ => None,
    }
}

fn hex_value(digits: &[u8]) -> Option<u32> {
    digits
        .iter()
        .try_fold(0u32, |acc, &d| Some(acc << 4 | u32::from(hex_digit(d)?)))
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

/// `tIIILDD..\r` for a frame.
pub fn encode_frame(f: &DataFrame, out: &mut Vec<u8>) {
    out.push(b't');
    for shift in [8, 4, 0] {
        out.push(HEX[usize::from((f.id() >> shift) & 0xF)]);
    }
    out.push(HEX[f.data().len()]);
    for &b in f.data() {
        out.push(HEX[usize::from(b >> 4)]);
        out.push(HEX[usize::from(b & 0xF)]);
    }
    out.push(b'\r');
}

/// One complete item from the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Item {
    Frame(DataFrame),
    /// An extended or remote frame: not used here.
    Foreign,
    /// `\r`, `z\r` or `Z\r`: the last command was accepted.
    Ack,
    /// BEL: the last command was refused.
    Nack,
    Status(u8),
    /// Any other line the adapter sends (version, serial number): ignored.
    Other(u8),
    /// What came was not slcan; the text says why.
    Malformed(&'static str),
}

/// Parse one line (without its `\r`).
pub fn parse_line(line: &[u8]) -> Item {
    let Some((&kind, rest)) = line.split_first() else {
        return Item::Ack;
    };
    match kind {
        b't' => {
            let (Some(id), Some(len)) = (
                rest.get(..3).and_then(hex_value),
                rest.get(3).and_then(|&d| hex_digit(d)),
            ) else {
                return Item::Malformed("frame without a valid id and length");
            };
            let len = usize::from(len);
            if len > 8 {
                return Item::Malformed("frame length above 8");
            }
            let data = &rest[4..];
            // Data, optionally followed by a 4-digit timestamp.
            if data.len() != 2 * len && data.len() != 2 * len + 4 {
                return Item::Malformed("frame data does not match its length");
            }
            let mut bytes = [0u8; 8];
            for (i, b) in bytes.iter_mut().take(len).enumerate() {
                match hex_value(&data[2 * i..2 * i + 2]) {
                    Some(v) => *b = v as u8,
                    None => return Item::Malformed("frame data is not hex"),
                }
            }
            if data.len() == 2 * len + 4 && hex_value(&data[2 * len..]).is_none() {
                return Item::Malformed("frame timestamp is not hex");
            }
            match DataFrame::new(id as u16, &bytes[..len]) {
                Some(f) => Item::Frame(f),
                None => Item::Malformed("frame id above 0x7FF"),
            }
        }
        b'T' | b'r' | b'R' => Item::Foreign,
        b'z' | b'Z' if rest.is_empty() => Item::Ack,
        b'F' => match (rest.len(), hex_value(rest)) {
            (2, Some(v)) => Item::Status(v as u8),
            _ => Item::Malformed("status reply is not two hex digits"),
        },
        b'V' | b'v' | b'N' => Item::Other(kind),
        _ => Item::Malformed("unknown line"),
    }
}

/// Splits the byte stream into lines; bounded, resynchronizes at the next `\r`.
#[derive(Debug, Clone)]
pub struct LineParser {
    buf: [u8; MAX_LINE],
    len: usize,
    overflow: bool,
}

impl Default for LineParser {
    fn default() -> Self {
        Self {
            buf: [0; MAX_LINE],
            len: 0,
            overflow: false,
        }
    }
}

impl LineParser {
    pub fn push(&mut self, bytes: &[u8], mut on: impl FnMut(Item)) {
        for &b in bytes {
            match b {
                0x07 => {
                    self.len = 0;
                    self.overflow = false;
                    on(Item::Nack);
                }
                b'\r' | b'\n' => {
                    if self.overflow {
                        on(Item::Malformed("line too long"));
                    } else if b == b'\r' || self.len > 0 {
                        on(parse_line(&self.buf[..self.len]));
                    }
                    self.len = 0;
                    self.overflow = false;
                }
                _ if self.len < MAX_LINE => {
                    self.buf[self.len] = b;
                    self.len += 1;
                }
                _ => self.overflow = true,
            }
        }
    }
}

/// How often the adapter's status flags are polled.
const STATUS_POLL: Duration = Duration::from_millis(20);

/// Bytes waiting to be written before the adapter counts as full.
const MAX_PENDING_OUT: usize = 2048;

/// A Lawicel adapter on a tty.
pub struct SlcanAdapter {
    path: String,
    baud: u32,
    bitrate_code: u8,
    port: Box<dyn tokio_serial::SerialPort>,
    parser: LineParser,
    events: VecDeque<BusEvent>,
    out: Vec<u8>,
    last_poll: Instant,
    malformed: u64,
    nacks: u64,
}

impl std::fmt::Debug for SlcanAdapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlcanAdapter")
            .field("path", &self.path)
            .field("malformed", &self.malformed)
            .field("nacks", &self.nacks)
            .finish_non_exhaustive()
    }
}

impl SlcanAdapter {
    /// Open the tty, set the bitrate and open the CAN channel; waits up to 1 s for the
    /// adapter to acknowledge.
    pub fn open(path: &str, baud: u32, bitrate_bps: u32) -> Result<Self, String> {
        let code = bitrate_code(bitrate_bps)
            .ok_or_else(|| format!("slcan adapters do not support {bitrate_bps} bit/s"))?;
        let port = open_tty(path, baud)?;
        let mut a = Self {
            path: path.to_string(),
            baud,
            bitrate_code: code,
            port,
            parser: LineParser::default(),
            events: VecDeque::new(),
            out: Vec::new(),
            last_poll: Instant::now(),
            malformed: 0,
            nacks: 0,
        };
        // Close first in case it was left open (that one may be refused), then configure.
        a.write_now(b"C\r")?;
        std::thread::sleep(Duration::from_millis(10));
        let _ = a.port.clear(tokio_serial::ClearBuffer::Input);
        a.write_now(format!("S{code}\rO\r").as_bytes())?;
        let deadline = Instant::now() + Duration::from_secs(1);
        let mut acks = 0;
        while acks < 2 {
            if Instant::now() > deadline {
                return Err(format!(
                    "no answer from {path} to the slcan open sequence; is it a Lawicel (slcan) \
                     adapter, at {baud} baud?"
                ));
            }
            let mut buf = [0u8; 64];
            let n = read_available(&mut *a.port, &mut buf).map_err(|e| format!("{path}: {e}"))?;
            let mut refused = false;
            a.parser.push(&buf[..n], |item| match item {
                Item::Ack => acks += 1,
                Item::Nack => refused = true,
                _ => {}
            });
            if refused {
                return Err(format!(
                    "{path} refused the slcan open sequence (bitrate {bitrate_bps})"
                ));
            }
            if n == 0 {
                std::thread::sleep(Duration::from_millis(2));
            }
        }
        Ok(a)
    }

    fn write_now(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.port
            .write_all(bytes)
            .map_err(|e| format!("{}: {e}", self.path))
    }

    /// Write as much of the pending output as the tty takes now.
    fn flush_out(&mut self) -> Result<(), AdapterError> {
        while !self.out.is_empty() {
            match self.port.write(&self.out) {
                Ok(0) => break,
                Ok(n) => {
                    self.out.drain(..n);
                }
                Err(e) if is_would_block(&e) => break,
                Err(e) => return Err(AdapterError::Io(format!("{}: {e}", self.path))),
            }
        }
        Ok(())
    }

    /// Lines that were not slcan, and commands the adapter refused.
    pub fn counters(&self) -> (u64, u64) {
        (self.malformed, self.nacks)
    }
}

fn open_tty(path: &str, baud: u32) -> Result<Box<dyn tokio_serial::SerialPort>, String> {
    tokio_serial::new(path, baud)
        .timeout(Duration::ZERO)
        .open()
        .map_err(|e| {
            format!("cannot open slcan adapter {path}: {e}; is the USB-CAN adapter plugged in?")
        })
}

fn is_would_block(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    )
}

fn read_available(
    port: &mut dyn tokio_serial::SerialPort,
    buf: &mut [u8],
) -> std::io::Result<usize> {
    match port.read(buf) {
        Ok(0) => Err(std::io::Error::new(
            std::io::ErrorKind::UnexpectedEof,
            "adapter disconnected (end of file)",
        )),
        Ok(n) => Ok(n),
        Err(e) if is_would_block(&e) => Ok(0),
        Err(e) => Err(e),
    }
}

impl CanAdapter for SlcanAdapter {
    fn recv(&mut self) -> Result<Option<BusEvent>, AdapterError> {
        if let Some(ev) = self.events.pop_front() {
            return Ok(Some(ev));
        }
        if self.last_poll.elapsed() >= STATUS_POLL {
            self.last_poll = Instant::now();
            self.out.extend_from_slice(b"F\r");
        }
        self.flush_out()?;
        let mut buf = [0u8; 512];
        let n = read_available(&mut *self.port, &mut buf)
            .map_err(|e| AdapterError::Io(format!("{}: {e}", self.path)))?;
        let (events, malformed, nacks) = (&mut self.events, &mut self.malformed, &mut self.nacks);
        self.parser.push(&buf[..n], |item| match item {
            Item::Frame(f) => events.push_back(BusEvent::Frame(f)),
            Item::Foreign => events.push_back(BusEvent::Foreign),
            Item::Status(s) => events.push_back(BusEvent::Condition(condition_from_flags(s))),
            Item::Nack => *nacks += 1,
            Item::Malformed(_) => *malformed += 1,
            Item::Ack | Item::Other(_) => {}
        });
        Ok(self.events.pop_front())
    }

    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError> {
        if self.out.len() > MAX_PENDING_OUT {
            self.flush_out()?;
            if self.out.len() > MAX_PENDING_OUT {
                return Err(AdapterError::TxFull);
            }
        }
        encode_frame(frame, &mut self.out);
        self.flush_out()
    }

    /// Drop what is still in this process and the tty's output queue, then close and reopen
    /// the CAN channel, which aborts the adapter's own pending transmissions.
    fn discard_pending_tx(&mut self) -> Result<(), AdapterError> {
        self.out.clear();
        let _ = self.port.clear(tokio_serial::ClearBuffer::Output);
        self.out.extend_from_slice(b"C\rO\r");
        self.flush_out()
    }

    fn describe(&self) -> String {
        format!("slcan {}", self.path)
    }

    /// Open the tty again and send the open sequence (close, bitrate, open) without waiting
    /// for the answers, which `recv` then reads as acknowledgements: the control loop calls
    /// this and must not block. A device that does not answer shows as missing feedback.
    fn reopen(&mut self) -> Result<(), AdapterError> {
        let port = open_tty(&self.path, self.baud).map_err(AdapterError::Io)?;
        self.port = port;
        self.parser = LineParser::default();
        self.events.clear();
        self.out.clear();
        self.out
            .extend_from_slice(format!("C\rS{}\rO\r", self.bitrate_code).as_bytes());
        self.last_poll = Instant::now();
        self.flush_out()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn frame_text_is_lawicel() {
        let f = DataFrame::new(0x181, &[0xDE, 0xAD, 0x01]).expect("frame");
        let mut out = Vec::new();
        encode_frame(&f, &mut out);
        assert_eq!(out, b"t1813DEAD01\r");
        assert_eq!(parse_line(b"t1813DEAD01"), Item::Frame(f));
        // With the adapter's 4-digit timestamp.
        assert_eq!(parse_line(b"t1813dead01FFFF"), Item::Frame(f));
        assert_eq!(
            parse_line(b"t0000"),
            Item::Frame(DataFrame::new(0, &[]).expect("empty"))
        );
    }

    #[test]
    fn replies_and_junk() {
        let mut items = Vec::new();
        let mut p = LineParser::default();
        p.push(
            b"\rz\r\x07F24\rT1234567810\rr1230\rV1013\rt12\rt1239\rt1231XX\rQQ\r",
            |i| items.push(i),
        );
        assert_eq!(
            items,
            vec![
                Item::Ack,
                Item::Ack,
                Item::Nack,
                Item::Status(0x24),
                Item::Foreign,
                Item::Foreign,
                Item::Other(b'V'),
                Item::Malformed("frame without a valid id and length"),
                Item::Malformed("frame length above 8"),
                Item::Malformed("frame data is not hex"),
                Item::Malformed("unknown line"),
            ]
        );
        let c = condition_from_flags(0x24);
        assert!(c.error_passive && c.error_warning && !c.bus_off && c.is_fatal());
        assert!(condition_from_flags(flags::BUS_ERROR).bus_off);
        assert!(condition_from_flags(0).back_to_active);
    }

    #[test]
    fn an_endless_line_is_dropped_and_the_next_one_parses() {
        let mut items = Vec::new();
        let mut p = LineParser::default();
        let mut bytes = vec![b'7'; 1000];
        bytes.extend_from_slice(b"\rt1000\r");
        p.push(&bytes, |i| items.push(i));
        assert_eq!(
            items,
            vec![
                Item::Malformed("line too long"),
                Item::Frame(DataFrame::new(0x100, &[]).expect("frame"))
            ]
        );
    }

    proptest! {
        #[test]
        fn round_trip(id in 0u16..=0x7FF, data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let f = DataFrame::new(id, &data).expect("frame");
            let mut out = Vec::new();
            encode_frame(&f, &mut out);
            let mut items = Vec::new();
            LineParser::default().push(&out, |i| items.push(i));
            prop_assert_eq!(items, vec![Item::Frame(f)]);
        }

        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            LineParser::default().push(&bytes, |_| {});
        }
    }
}
