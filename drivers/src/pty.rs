//! Pseudo-terminal pairs that stand in for USB serial devices, for the emulators.
//!
//! The emulator holds the master end; the driver opens the slave end by path, exactly as it
//! opens a real tty. A symlink gives the device a stable path (like `/dev/serial/by-id/...`)
//! that survives an emulated unplug and replug, when the slave's own `/dev/pts/N` changes.

use std::fs::File;
use std::io;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};

use nix::fcntl::{FcntlArg, FdFlag, OFlag, fcntl};
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
use nix::sys::termios::{SetArg, cfmakeraw, tcgetattr, tcsetattr};

/// One pty pair. Dropping it closes both ends: a reader of the slave then sees an error or
/// end of file, as on a USB unplug.
#[derive(Debug)]
pub struct Pty {
    master: File,
    /// Kept open so that the line discipline keeps the slave's raw settings and the master
    /// does not report a hangup while the driver has the port closed.
    _slave: OwnedFd,
    slave_path: PathBuf,
}

impl Pty {
    /// A new pair with the slave in raw mode (no echo, no line editing, 8-bit clean) and a
    /// non-blocking master.
    pub fn open() -> io::Result<Self> {
        let pair = nix::pty::openpty(None, None).map_err(io::Error::from)?;
        // openpty(3) leaves both ends inheritable: a program started later (a daemon under
        // test) would hold the master open, and dropping the pair would unplug nothing.
        for fd in [&pair.master, &pair.slave] {
            fcntl(fd, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).map_err(io::Error::from)?;
        }
        let mut t = tcgetattr(&pair.slave).map_err(io::Error::from)?;
        cfmakeraw(&mut t);
        tcsetattr(&pair.slave, SetArg::TCSANOW, &t).map_err(io::Error::from)?;
        let flags = fcntl(&pair.master, FcntlArg::F_GETFL).map_err(io::Error::from)?;
        let flags = OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK;
        fcntl(&pair.master, FcntlArg::F_SETFL(flags)).map_err(io::Error::from)?;
        let slave_path = nix::unistd::ttyname(&pair.slave).map_err(io::Error::from)?;
        Ok(Self {
            master: File::from(pair.master),
            _slave: pair.slave,
            slave_path,
        })
    }

    /// The slave's own path (`/dev/pts/N`).
    pub fn slave_path(&self) -> &Path {
        &self.slave_path
    }

    /// The master end (non-blocking: reads and writes return `WouldBlock` instead of
    /// waiting).
    pub fn master(&mut self) -> &mut File {
        &mut self.master
    }

    /// Wait up to `timeout_ms` for bytes to read on the master. True if there are some.
    pub fn wait_readable(&self, timeout_ms: u16) -> io::Result<bool> {
        let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(timeout_ms)) {
            Ok(n) => Ok(n > 0
                && fds[0]
                    .revents()
                    .is_some_and(|r| r.contains(PollFlags::POLLIN))),
            Err(nix::errno::Errno::EINTR) => Ok(false),
            Err(e) => Err(e.into()),
        }
    }
}

/// A symlink at a stable path pointing at a pty's slave; removed on drop.
#[derive(Debug)]
pub struct StableLink {
    path: PathBuf,
}

impl StableLink {
    /// Point `path` at `target`, replacing any link already there.
    pub fn create(path: &Path, target: &Path) -> io::Result<Self> {
        match std::fs::remove_file(path) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(e),
        }
        std::os::unix::fs::symlink(target, path)?;
        Ok(Self {
            path: path.to_path_buf(),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for StableLink {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    #[test]
    fn bytes_cross_the_pair_unchanged() {
        let mut pty = Pty::open().expect("ptys work on this machine");
        let mut slave = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(pty.slave_path())
            .expect("open slave");
        let bytes: Vec<u8> = (0..=255u8).collect();
        pty.master().write_all(&bytes).expect("write master");
        let mut got = vec![0u8; 256];
        slave.read_exact(&mut got).expect("read slave");
        assert_eq!(got, bytes, "raw mode: no byte translated");
        slave.write_all(b"\r\n\x00").expect("write slave");
        assert!(pty.wait_readable(1000).expect("poll"));
        let mut back = [0u8; 3];
        pty.master().read_exact(&mut back).expect("read master");
        assert_eq!(&back, b"\r\n\x00");
    }
}
