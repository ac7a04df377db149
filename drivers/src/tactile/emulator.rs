//! An emulator of the tactile array's interface board: it speaks the serial protocol on the
//! master end of a pseudo-terminal, so the real driver runs end to end on a machine with no
//! array. Forces come from any [`ForceSource`]; impairments inject each kind of bad input on
//! a fixed schedule so tests can count them exactly.

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use control::types::ELEMENTS;

use super::decoder::FrameDecoder;
use super::wire::{DeviceInfo, Forces, Message, NEWTONS_PER_COUNT, PROTOCOL_VERSION};
use crate::pty::{Pty, StableLink};

/// Gives the forces on every element at a device time.
pub trait ForceSource: Send {
    fn sample(&mut self, t_s: f64) -> [f64; ELEMENTS];
}

impl<F: FnMut(f64) -> [f64; ELEMENTS] + Send> ForceSource for F {
    fn sample(&mut self, t_s: f64) -> [f64; ELEMENTS] {
        self(t_s)
    }
}

impl ForceSource for super::pulse::SyntheticPulse {
    fn sample(&mut self, t_s: f64) -> [f64; ELEMENTS] {
        SyntheticPulse::sample(self, t_s)
    }
}

use super::pulse::SyntheticPulse;

/// Every `n`th frame (counting from 1) gets the impairment; `None` never. Several may hit
/// the same frame; they apply in the order listed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Impairments {
    /// Skip the frame (a lost frame: the receiver sees a gap).
    pub drop_every: Option<u64>,
    /// Send the frame twice.
    pub duplicate_every: Option<u64>,
    /// Flip a bit inside the frame (a CRC error).
    pub corrupt_every: Option<u64>,
    /// Send only the first half of the frame, then the next frame (a truncated frame).
    pub truncate_every: Option<u64>,
    /// Send 9 channels instead of 10.
    pub wrong_channels_every: Option<u64>,
    /// Put one element at the fault code.
    pub element_fault_every: Option<u64>,
    /// Send 17 bytes of line noise (no delimiter) before the frame.
    pub garbage_every: Option<u64>,
}

fn hits(every: Option<u64>, k: u64) -> bool {
    every.is_some_and(|n| n > 0 && k.is_multiple_of(n))
}

/// How the emulated device behaves.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorSettings {
    /// Stable path for the device (a symlink to the pty's slave), like `/dev/serial/by-id/...`.
    pub link_path: PathBuf,
    /// Emulated seconds per wall-clock second (frames go out this much faster).
    pub time_scale: f64,
    /// Channels announced in the device information (10 for a real array).
    pub channels: u8,
    pub firmware: [u8; 3],
    pub serial_number: u32,
    /// Streaming starts without waiting for a configure message (a device that was left
    /// streaming).
    pub stream_at_power_up: Option<u16>,
    /// Stop streaming after this many frames since power-up (tests that count exactly).
    pub max_frames: Option<u64>,
    pub impairments: Impairments,
}

impl EmulatorSettings {
    pub fn new(link_path: impl Into<PathBuf>) -> Self {
        Self {
            link_path: link_path.into(),
            time_scale: 1.0,
            channels: ELEMENTS as u8,
            firmware: [1, 0, 0],
            serial_number: 4242,
            stream_at_power_up: None,
            max_frames: None,
            impairments: Impairments::default(),
        }
    }
}

/// What the emulator has done so far.
#[derive(Debug, Default)]
pub struct EmulatorCounters {
    /// Frames produced since the last power-up, impaired or not (the frame number).
    pub frames_generated: AtomicU64,
    pub frames_sent: AtomicU64,
    /// Frames not written because the pty's buffer was full (nobody reading).
    pub frames_unread: AtomicU64,
    pub configures: AtomicU64,
}

enum Command {
    Hang(bool),
    Unplug,
    Replug,
    Stop,
}

/// A running emulator (its own thread). Dropping it stops it and removes the device.
#[derive(Debug)]
pub struct TactileEmulator {
    commands: mpsc::Sender<Command>,
    thread: Option<JoinHandle<()>>,
    counters: Arc<EmulatorCounters>,
    link_path: PathBuf,
    error: Arc<Mutex<Option<String>>>,
}

impl TactileEmulator {
    /// Plug in a device at `settings.link_path` and start it.
    pub fn start(settings: EmulatorSettings, source: Box<dyn ForceSource>) -> io::Result<Self> {
        let device = Device::plug(&settings)?;
        let (tx, rx) = mpsc::channel();
        let counters = Arc::new(EmulatorCounters::default());
        let error = Arc::new(Mutex::new(None));
        let link_path = settings.link_path.clone();
        let mut runner = Runner {
            settings,
            source,
            counters: counters.clone(),
            commands: rx,
            device: Some(device),
            hung: false,
        };
        let err = error.clone();
        let thread = std::thread::Builder::new()
            .name("tactile-emulator".into())
            .spawn(move || {
                if let Err(e) = runner.run() {
                    *err.lock().unwrap_or_else(|p| p.into_inner()) = Some(e.to_string());
                }
            })?;
        Ok(Self {
            commands: tx,
            thread: Some(thread),
            counters,
            link_path,
            error,
        })
    }

    /// The device's stable path.
    pub fn path(&self) -> &Path {
        &self.link_path
    }

    pub fn counters(&self) -> &EmulatorCounters {
        &self.counters
    }

    /// The error that stopped the emulator thread, if any.
    pub fn error(&self) -> Option<String> {
        self.error.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Hang (`true`: stop answering and streaming while staying plugged in, a firmware
    /// stall) or recover (`false`).
    pub fn hang(&self, hung: bool) {
        let _ = self.commands.send(Command::Hang(hung));
    }

    /// Pull the cable: the pty closes and the stable path disappears.
    pub fn unplug(&self) {
        let _ = self.commands.send(Command::Unplug);
    }

    /// Plug it back in: a new pty (a new `/dev/pts/N`) behind the same stable path; the
    /// device powers up again (not streaming, sequence from 0).
    pub fn replug(&self) {
        let _ = self.commands.send(Command::Replug);
    }

    /// Stop and wait for the thread.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        let _ = self.commands.send(Command::Stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for TactileEmulator {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// A plugged-in device: its pty, its stable link and its protocol state.
struct Device {
    pty: Pty,
    _link: StableLink,
    decoder: FrameDecoder,
    rate_hz: u16,
    streaming: bool,
    seq: u32,
    /// Device time of the next frame, s, and the wall instant it is due.
    next_t_s: f64,
    next_due: Instant,
    frame_no: u64,
}

impl Device {
    fn plug(settings: &EmulatorSettings) -> io::Result<Self> {
        let pty = Pty::open()?;
        let link = StableLink::create(&settings.link_path, pty.slave_path())?;
        let mut d = Self {
            pty,
            _link: link,
            decoder: FrameDecoder::new(),
            rate_hz: settings.stream_at_power_up.unwrap_or(100),
            streaming: settings.stream_at_power_up.is_some(),
            seq: 0,
            next_t_s: 0.0,
            next_due: Instant::now(),
            frame_no: 0,
        };
        d.send_info(settings);
        Ok(d)
    }

    fn send_info(&mut self, settings: &EmulatorSettings) {
        let m = Message::DeviceInfo(DeviceInfo {
            protocol_version: PROTOCOL_VERSION,
            firmware: settings.firmware,
            channels: settings.channels,
            rate_hz: if self.streaming { self.rate_hz } else { 0 },
            serial_number: settings.serial_number,
        });
        let _ = self.write(&m.to_wire());
    }

    /// Write without waiting; false if the bytes could not all go (nobody is reading).
    fn write(&mut self, bytes: &[u8]) -> bool {
        match self.pty.master().write(bytes) {
            Ok(n) => n == bytes.len(),
            Err(_) => false,
        }
    }
}

struct Runner {
    settings: EmulatorSettings,
    source: Box<dyn ForceSource>,
    counters: Arc<EmulatorCounters>,
    commands: mpsc::Receiver<Command>,
    device: Option<Device>,
    hung: bool,
}

impl Runner {
    fn run(&mut self) -> io::Result<()> {
        loop {
            match self.commands.try_recv() {
                Ok(Command::Stop) | Err(mpsc::TryRecvError::Disconnected) => return Ok(()),
                Ok(Command::Hang(h)) => {
                    self.hung = h;
                    if let (false, Some(dev)) = (h, self.device.as_mut()) {
                        dev.next_due = Instant::now();
                    }
                }
                Ok(Command::Unplug) => self.device = None,
                Ok(Command::Replug) => {
                    self.device = None;
                    self.device = Some(Device::plug(&self.settings)?);
                    self.counters.frames_generated.store(0, Ordering::Relaxed);
                }
                Err(mpsc::TryRecvError::Empty) => {}
            }
            let Some(dev) = self.device.as_mut().filter(|_| !self.hung) else {
                std::thread::sleep(Duration::from_millis(5));
                continue;
            };
            // Wait for host bytes until the next frame is due (at most 20 ms, to see
            // commands).
            let wait = dev.next_due.saturating_duration_since(Instant::now());
            let wait_ms = wait.as_millis().min(20) as u16;
            if dev.pty.wait_readable(wait_ms)? {
                self.read_host()?;
            }
            self.maybe_send_frame();
        }
    }

    fn read_host(&mut self) -> io::Result<()> {
        let Some(dev) = self.device.as_mut() else {
            return Ok(());
        };
        let mut buf = [0u8; 256];
        let n = match dev.pty.master().read(&mut buf) {
            Ok(n) => n,
            // EIO: no process has the slave open; not an error for a device.
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => 0,
            Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => 0,
            Err(e) => return Err(e),
        };
        let mut configures = Vec::new();
        dev.decoder.push(&buf[..n], |m| {
            if let Ok(Message::Configure(c)) = m {
                configures.push(c);
            }
        });
        for c in configures {
            self.counters.configures.fetch_add(1, Ordering::Relaxed);
            let now = Instant::now();
            if c.streaming && !dev.streaming {
                dev.next_due = now;
            }
            dev.rate_hz = c.rate_hz.clamp(1, 1000);
            dev.streaming = c.streaming;
            dev.send_info(&self.settings);
        }
        Ok(())
    }

    fn maybe_send_frame(&mut self) {
        let Some(dev) = self.device.as_mut() else {
            return;
        };
        if !dev.streaming || Instant::now() < dev.next_due {
            return;
        }
        if self.settings.max_frames.is_some_and(|m| dev.frame_no >= m) {
            dev.streaming = false;
            return;
        }
        let rate = f64::from(dev.rate_hz);
        let t_s = dev.next_t_s;
        let forces = self.source.sample(t_s);
        dev.next_t_s += 1.0 / rate;
        dev.next_due += Duration::from_secs_f64(1.0 / (rate * self.settings.time_scale));
        dev.frame_no += 1;
        let k = dev.frame_no;
        self.counters.frames_generated.store(k, Ordering::Relaxed);
        let seq = dev.seq;
        dev.seq = dev.seq.wrapping_add(1);
        let imp = self.settings.impairments;
        if hits(imp.drop_every, k) {
            return;
        }
        let mut counts = [0i16; ELEMENTS];
        for (c, f) in counts.iter_mut().zip(forces) {
            // Saturate like an ADC; the fault code is never produced by a measurement.
            *c = (f / NEWTONS_PER_COUNT)
                .round()
                .clamp(f64::from(i16::MIN + 1), f64::from(i16::MAX)) as i16;
        }
        if hits(imp.element_fault_every, k) {
            counts[3] = super::wire::ELEMENT_FAULT;
        }
        let n = if hits(imp.wrong_channels_every, k) {
            ELEMENTS - 1
        } else {
            ELEMENTS
        };
        let device_us = (t_s * 1e6).round() as u64 as u32;
        let Some(f) = Forces::new(seq, device_us, &counts[..n]) else {
            return;
        };
        let mut raw = Message::Forces(f).to_bytes();
        if hits(imp.corrupt_every, k) {
            // One flipped bit in the device time: framing intact, the CRC catches it.
            raw[5] ^= 0x04;
        }
        let mut wire = Vec::with_capacity(raw.len() + 3);
        wire.push(0);
        super::cobs::encode_into(&raw, &mut wire);
        wire.push(0);
        if hits(imp.garbage_every, k) {
            let garbage = [0x5A_u8; 17];
            let _ = dev.write(&garbage);
        }
        if hits(imp.truncate_every, k) {
            let half = wire.len() / 2;
            wire.truncate(half);
        }
        let repeats = if hits(imp.duplicate_every, k) { 2 } else { 1 };
        for _ in 0..repeats {
            if dev.write(&wire) {
                self.counters.frames_sent.fetch_add(1, Ordering::Relaxed);
            } else {
                self.counters.frames_unread.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}
