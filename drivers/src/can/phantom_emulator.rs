//! An emulator of the Phantom's three joint amplifiers behind a Lawicel (slcan) USB-CAN
//! adapter, on the master end of a pseudo-terminal: the real driver, through
//! [`super::slcan::SlcanAdapter`], runs end to end against it.
//!
//! Each joint is an inertia with viscous damping driven by the commanded torque. The
//! amplifiers behave as the protocol says: feedback at 1 kHz, heartbeats at 10 Hz, enable and
//! disable on command, a command watchdog (no torque for 20 ms: zero torque), a host-heartbeat
//! watchdog (none for 0.5 s: disable), an e-stop input, bus-off on request, and amplifier
//! faults on request: an over-current whose cause persists until the test removes it, then
//! stays latched until the host sends clear-faults.

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use config::schema::CanJoints;
use control::types::JOINTS;

use super::frame::DataFrame;
use super::protocol::{ControlCommand, Message, NodeState, status};
use super::scaling::JointScaling;
use super::slcan::{Item, encode_frame, flags};
use crate::pty::{Pty, StableLink};

const COMMAND_WATCHDOG_S: f64 = 0.020;
const HOST_HEARTBEAT_TIMEOUT_S: f64 = 0.5;
const INERTIA_KG_M2: f64 = 2.0e-3;
const DAMPING_NM_S_PER_RAD: f64 = 0.02;

/// How the emulated arm is set up.
#[derive(Debug, Clone, PartialEq)]
pub struct PhantomEmulatorSettings {
    /// Stable path of the emulated USB-CAN adapter.
    pub link_path: PathBuf,
    /// Node ids, scaling and host node, as the driver is configured.
    pub joints: CanJoints,
    /// Joint angles at power-up, rad.
    pub initial_rad: [f64; JOINTS],
    /// Emulated seconds per wall second.
    pub time_scale: f64,
}

impl PhantomEmulatorSettings {
    pub fn new(link_path: impl Into<PathBuf>) -> Self {
        Self {
            link_path: link_path.into(),
            joints: CanJoints::default(),
            initial_rad: [0.0; JOINTS],
            time_scale: 1.0,
        }
    }
}

enum Command {
    EStop(bool),
    BusOff,
    AmpFault { joint: usize, present: bool },
    Stop,
}

/// The emergency code an injected amplifier fault sends (CiA 301: current, device output
/// side).
pub const AMP_FAULT_EMERGENCY_CODE: u16 = 0x2310;

/// The running emulator (its own thread). Dropping it stops it and removes the device.
#[derive(Debug)]
pub struct PhantomEmulator {
    commands: mpsc::Sender<Command>,
    thread: Option<JoinHandle<io::Result<()>>>,
    link_path: PathBuf,
}

impl PhantomEmulator {
    pub fn start(settings: PhantomEmulatorSettings) -> io::Result<Self> {
        let pty = Pty::open()?;
        let link = StableLink::create(&settings.link_path, pty.slave_path())?;
        let (tx, rx) = mpsc::channel();
        let link_path = settings.link_path.clone();
        let thread = std::thread::Builder::new()
            .name("phantom-emulator".into())
            .spawn(move || {
                let _link = link;
                Arm::new(settings, pty, rx).run()
            })?;
        Ok(Self {
            commands: tx,
            thread: Some(thread),
            link_path,
        })
    }

    pub fn path(&self) -> &Path {
        &self.link_path
    }

    /// Open (`true`) or close the e-stop input.
    pub fn estop(&self, open: bool) {
        let _ = self.commands.send(Command::EStop(open));
    }

    /// The controller goes bus-off: it stops transmitting and its status flags say so.
    pub fn bus_off(&self) {
        let _ = self.commands.send(Command::BusOff);
    }

    /// Joint `joint`'s amplifier detects an over-current (`present`), or its cause goes
    /// away (`!present`). While present, the amplifier is disabled, reports a fault (status,
    /// heartbeat, one emergency frame when it starts) and clear-faults does nothing; once
    /// gone, the fault stays latched until the host sends clear-faults.
    pub fn amp_fault(&self, joint: usize, present: bool) {
        let _ = self.commands.send(Command::AmpFault { joint, present });
    }

    /// Stop; returns the thread's error, if it ended with one.
    pub fn stop(mut self) -> io::Result<()> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> io::Result<()> {
        let _ = self.commands.send(Command::Stop);
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(io::Error::other("emulator thread panicked")),
            None => Ok(()),
        }
    }
}

impl Drop for PhantomEmulator {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Amp {
    enabled: bool,
    fault: bool,
    /// The cause of a fault is still there: clear-faults cannot clear it.
    fault_cause: bool,
    torque_counts: i16,
    last_command_s: f64,
    seq: u8,
    theta_rad: f64,
    omega_rad_s: f64,
}

struct Arm {
    settings: PhantomEmulatorSettings,
    scaling: [JointScaling; JOINTS],
    pty: Pty,
    commands: mpsc::Receiver<Command>,
    partial: Vec<u8>,
    amps: [Amp; JOINTS],
    channel_open: bool,
    estop: bool,
    bus_off: bool,
    last_host_heartbeat_s: f64,
    t_s: f64,
    out: Vec<u8>,
}

impl Arm {
    fn new(settings: PhantomEmulatorSettings, pty: Pty, commands: mpsc::Receiver<Command>) -> Self {
        let scaling = JointScaling::for_joints(&settings.joints);
        let amps = std::array::from_fn(|j| Amp {
            theta_rad: settings.initial_rad[j],
            ..Amp::default()
        });
        Self {
            settings,
            scaling,
            pty,
            commands,
            partial: Vec::new(),
            amps,
            channel_open: false,
            estop: false,
            bus_off: false,
            last_host_heartbeat_s: 0.0,
            t_s: 0.0,
            out: Vec::new(),
        }
    }

    fn run(mut self) -> io::Result<()> {
        let dt_s = 0.001;
        let wall_dt = Duration::from_secs_f64(dt_s / self.settings.time_scale);
        let mut due = Instant::now();
        let mut step: u64 = 0;
        loop {
            match self.commands.try_recv() {
                Ok(Command::Stop) | Err(mpsc::TryRecvError::Disconnected) => return Ok(()),
                Ok(Command::EStop(open)) => self.estop = open,
                Ok(Command::BusOff) => self.bus_off = true,
                Ok(Command::AmpFault { joint, present }) => self.amp_fault(joint, present),
                Err(mpsc::TryRecvError::Empty) => {}
            }
            let wait = due.saturating_duration_since(Instant::now());
            if self.pty.wait_readable(wait.as_millis().min(5) as u16)? {
                self.read_host()?;
            }
            if Instant::now() < due {
                continue;
            }
            due += wall_dt;
            step += 1;
            self.t_s += dt_s;
            self.integrate(dt_s);
            if self.channel_open && !self.bus_off {
                self.send_feedback();
                if step.is_multiple_of(100) {
                    self.send_heartbeats();
                }
            }
            self.flush();
        }
    }

    fn amp_fault(&mut self, joint: usize, present: bool) {
        let Some(a) = self.amps.get_mut(joint) else {
            return;
        };
        a.fault_cause = present;
        if !present || a.fault {
            return;
        }
        a.fault = true;
        a.enabled = false;
        a.torque_counts = 0;
        if self.channel_open && !self.bus_off {
            let m = Message::Emergency {
                node: self.settings.joints.node_ids[joint],
                code: AMP_FAULT_EMERGENCY_CODE,
                error_register: 0x03, // generic + current
                state: NodeState::Fault,
                detail: [0; 4],
            };
            encode_frame(&m.encode(), &mut self.out);
        }
    }

    fn read_host(&mut self) -> io::Result<()> {
        let mut buf = [0u8; 1024];
        let n = match self.pty.master().read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => 0,
            Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => 0,
            Err(e) => return Err(e),
        };
        // Host commands, one per `\r`; a partial line waits for the rest.
        for &b in &buf[..n] {
            if b == b'\r' {
                let line = std::mem::take(&mut self.partial);
                self.host_line(&line);
            } else if self.partial.len() < 40 {
                self.partial.push(b);
            }
        }
        Ok(())
    }

    fn host_line(&mut self, line: &[u8]) {
        match line.first() {
            Some(b'S') if !self.channel_open => self.out.push(b'\r'),
            Some(b'O') => {
                self.channel_open = true;
                self.out.push(b'\r');
            }
            Some(b'C') => {
                self.channel_open = false;
                self.out.push(b'\r');
            }
            Some(b'F') => {
                let f = if self.bus_off { flags::BUS_ERROR } else { 0 };
                self.out.extend_from_slice(format!("F{f:02X}\r").as_bytes());
            }
            Some(b't') if self.channel_open && !self.bus_off => {
                match super::slcan::parse_line(line) {
                    Item::Frame(f) => {
                        self.frame(&f);
                        self.out.extend_from_slice(b"z\r");
                    }
                    _ => self.out.push(0x07),
                }
            }
            _ => self.out.push(0x07),
        }
    }

    fn joint_of(&self, node: u8) -> Option<usize> {
        self.settings
            .joints
            .node_ids
            .iter()
            .position(|&n| n == node)
    }

    fn frame(&mut self, f: &DataFrame) {
        let Ok(Some(m)) = Message::decode(f) else {
            return;
        };
        match m {
            Message::Control { command, node } => {
                for j in 0..JOINTS {
                    if node != 0 && Some(j) != self.joint_of(node) {
                        continue;
                    }
                    let a = &mut self.amps[j];
                    match command {
                        ControlCommand::Enable => {
                            if !self.estop && !a.fault && !a.fault_cause {
                                a.enabled = true;
                                a.last_command_s = self.t_s;
                            }
                        }
                        ControlCommand::Disable => {
                            a.enabled = false;
                            a.torque_counts = 0;
                        }
                        ControlCommand::ClearFault => a.fault = a.fault_cause,
                    }
                }
            }
            Message::Torque { node, torque, .. } => {
                if let Some(j) = self.joint_of(node) {
                    let a = &mut self.amps[j];
                    if a.enabled {
                        a.torque_counts = torque;
                        a.last_command_s = self.t_s;
                    }
                }
            }
            Message::Heartbeat { node, .. } if node == self.settings.joints.host_node_id => {
                self.last_host_heartbeat_s = self.t_s;
            }
            _ => {}
        }
    }

    fn integrate(&mut self, dt_s: f64) {
        let host_lost = self.t_s - self.last_host_heartbeat_s > HOST_HEARTBEAT_TIMEOUT_S;
        for j in 0..JOINTS {
            let s = self.scaling[j];
            let a = &mut self.amps[j];
            if self.estop || host_lost {
                a.enabled = false;
            }
            if !a.enabled || self.t_s - a.last_command_s > COMMAND_WATCHDOG_S {
                a.torque_counts = 0;
            }
            let tau = if a.enabled {
                s.joint_torque_nm(a.torque_counts)
            } else {
                0.0
            };
            let alpha = (tau - DAMPING_NM_S_PER_RAD * a.omega_rad_s) / INERTIA_KG_M2;
            a.omega_rad_s += alpha * dt_s;
            a.theta_rad += a.omega_rad_s * dt_s;
        }
    }

    fn send_feedback(&mut self) {
        let amp_time_us = ((self.t_s * 1e6).round() as u64 & 0xFFFF) as u16;
        for j in 0..JOINTS {
            let a = &mut self.amps[j];
            a.seq = a.seq.wrapping_add(1);
            let mut st = 0;
            if a.enabled {
                st |= status::ENABLED;
            }
            if a.fault {
                st |= status::FAULT;
            }
            if self.estop {
                st |= status::ESTOP;
            }
            let m = Message::Feedback {
                node: self.settings.joints.node_ids[j],
                counts: self.scaling[j].counts_for(a.theta_rad),
                amp_time_us,
                status: st,
                seq: a.seq,
            };
            encode_frame(&m.encode(), &mut self.out);
        }
    }

    fn send_heartbeats(&mut self) {
        for j in 0..JOINTS {
            let a = self.amps[j];
            let state = if a.fault {
                NodeState::Fault
            } else if a.enabled {
                NodeState::Enabled
            } else {
                NodeState::Disabled
            };
            let m = Message::Heartbeat {
                node: self.settings.joints.node_ids[j],
                state,
                error_register: 0,
            };
            encode_frame(&m.encode(), &mut self.out);
        }
    }

    /// Write what fits; a real adapter drops what the host does not read.
    fn flush(&mut self) {
        if self.out.is_empty() {
            return;
        }
        let _ = self.pty.master().write(&self.out);
        self.out.clear();
    }
}
