//! The real bus: a SocketCAN raw socket (`can0`), non-blocking, with error frames enabled.
//!
//! Builds everywhere; runs where the kernel has AF_CAN (the lab PC). Opening explains what
//! to do when the interface is missing, down, or the kernel lacks CAN support.

use std::io;
use std::path::Path;

use socketcan::{CanFrame, CanSocket, EmbeddedFrame, Socket, SocketOptions, StandardId};

use super::adapter::{AdapterError, CanAdapter};
use super::frame::{BusEvent, DataFrame};
use super::socketcan_conv::event_from_frame;

/// A SocketCAN interface.
#[derive(Debug)]
pub struct SocketCanAdapter {
    interface: String,
    socket: CanSocket,
}

/// Why the interface cannot be used, in words that say what to do.
pub fn diagnose(interface: &str, err: &io::Error) -> String {
    let sys = Path::new("/sys/class/net").join(interface);
    if err.raw_os_error() == Some(libc_eafnosupport()) {
        return format!(
            "cannot open CAN interface {interface}: this kernel has no SocketCAN (AF_CAN) support \
             ({err}); load it with `modprobe can_raw`, or use a serial-line adapter \
             (joints.adapter: Slcan(...))"
        );
    }
    if !sys.exists() {
        return format!(
            "CAN interface {interface} does not exist ({err}); is the USB-CAN adapter plugged in \
             and its driver loaded? `ip -details link show type can` lists the interfaces"
        );
    }
    let oper = std::fs::read_to_string(sys.join("operstate")).unwrap_or_default();
    let flags = std::fs::read_to_string(sys.join("flags")).unwrap_or_default();
    let up =
        u32::from_str_radix(flags.trim().trim_start_matches("0x"), 16).is_ok_and(|f| f & 1 != 0);
    if !up || oper.trim() == "down" {
        return format!(
            "CAN interface {interface} is down ({err}); bring it up with \
             `sudo ip link set {interface} up type can bitrate 1000000`"
        );
    }
    format!("cannot open CAN interface {interface}: {err}")
}

fn libc_eafnosupport() -> i32 {
    97 // EAFNOSUPPORT on Linux
}

impl SocketCanAdapter {
    pub fn open(interface: &str) -> Result<Self, String> {
        let socket = CanSocket::open(interface).map_err(|e| diagnose(interface, &e))?;
        let configure = |s: &CanSocket| -> io::Result<()> {
            s.set_nonblocking(true)?;
            s.set_error_filter_accept_all()?;
            Ok(())
        };
        configure(&socket)
            .map_err(|e| format!("cannot configure CAN socket on {interface}: {e}"))?;
        // A UP interface may still be administratively fine but have no carrier.
        let sys = Path::new("/sys/class/net").join(interface);
        if let Ok(state) = std::fs::read_to_string(sys.join("operstate"))
            && state.trim() == "down"
        {
            return Err(format!(
                "CAN interface {interface} is down; bring it up with \
                 `sudo ip link set {interface} up type can bitrate 1000000`"
            ));
        }
        Ok(Self {
            interface: interface.to_string(),
            socket,
        })
    }
}

impl CanAdapter for SocketCanAdapter {
    fn recv(&mut self) -> Result<Option<BusEvent>, AdapterError> {
        match self.socket.read_frame() {
            Ok(frame) => Ok(Some(event_from_frame(frame.into()))),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(None),
            Err(e) => Err(AdapterError::Io(diagnose(&self.interface, &e))),
        }
    }

    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError> {
        let id = StandardId::new(frame.id())
            .ok_or_else(|| AdapterError::Io(format!("id {:#x} is not standard", frame.id())))?;
        let f = CanFrame::new(id, frame.data())
            .ok_or_else(|| AdapterError::Io("frame does not fit classic CAN".into()))?;
        match self.socket.write_frame(&f) {
            Ok(()) => Ok(()),
            // ENOBUFS: the interface's transmit queue is full.
            Err(e) if e.kind() == io::ErrorKind::WouldBlock || e.raw_os_error() == Some(105) => {
                Err(AdapterError::TxFull)
            }
            Err(e) => Err(AdapterError::Io(diagnose(&self.interface, &e))),
        }
    }

    /// Reopening the socket drops the frames still in its send buffer. Frames already handed
    /// to the controller's hardware mailboxes cannot be recalled from user space; the
    /// amplifiers' command watchdog covers those (docs/protocols/phantom-can.md).
    fn discard_pending_tx(&mut self) -> Result<(), AdapterError> {
        let fresh = Self::open(&self.interface).map_err(AdapterError::Io)?;
        self.socket = fresh.socket;
        Ok(())
    }

    fn describe(&self) -> String {
        format!("SocketCAN {}", self.interface)
    }

    /// A new socket on the same interface (it fails, saying what to do, while the
    /// interface is missing or down).
    fn reopen(&mut self) -> Result<(), AdapterError> {
        let fresh = Self::open(&self.interface).map_err(AdapterError::Io)?;
        self.socket = fresh.socket;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opening_here_fails_with_an_actionable_message() {
        // This machine's kernel has no AF_CAN; a lab PC without the interface says so too.
        match SocketCanAdapter::open("pt_nocan0") {
            Ok(_) => {} // a kernel with CAN and that interface: nothing to check
            Err(msg) => {
                assert!(
                    msg.contains("modprobe")
                        || msg.contains("does not exist")
                        || msg.contains("is down"),
                    "{msg}"
                );
            }
        }
    }
}
