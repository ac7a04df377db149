//! One daemon per configuration: an exclusive `flock` on a lock file beside the console
//! socket and another in the recording directory, taken before anything else (before
//! start-up recovery, before opening hardware), so that a second `pulsetrackd` on the same
//! config stops at once without touching the first one's trial or devices. The kernel drops
//! the locks when the process dies, so a crash never leaves a stale lock.

use std::fs::File;
use std::io::{Read, Seek, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

use nix::fcntl::{Flock, FlockArg};

use crate::private_fs::ensure_private_dir;

/// Why the daemon cannot take its configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LockError {
    /// Another daemon runs on this configuration.
    #[error("{0}")]
    Held(String),
    /// A folder is not the daemon's own, or cannot be made or opened.
    #[error("{0}")]
    Folder(String),
}

/// Held for the daemon's life.
#[derive(Debug)]
pub struct InstanceLock {
    held: Vec<(PathBuf, Flock<File>)>,
}

impl InstanceLock {
    /// Lock `<socket>.lock` and `<recording dir>/.pulsetrackd.lock`, making each directory
    /// (and checking that it is the daemon's own) first.
    pub fn acquire(socket: &Path, recording_dir: &Path) -> Result<InstanceLock, LockError> {
        let socket_dir = socket
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        ensure_private_dir(socket_dir).map_err(LockError::Folder)?;
        let name = socket
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "console.sock".into());
        let mut held = Vec::new();
        let first = socket_dir.join(format!("{name}.lock"));
        held.push((first.clone(), lock(&first)?));
        ensure_private_dir(recording_dir).map_err(LockError::Folder)?;
        let second = recording_dir.join(".pulsetrackd.lock");
        if crate::recording::space::free_bytes(recording_dir).is_ok_and(|(_, ro)| ro) {
            // Nothing can be written there, so nothing there needs guarding; trials are
            // refused with the reason when they start.
            tracing::warn!(
                "the recording folder {} is read-only: no trial can be recorded until it is writable",
                recording_dir.display()
            );
        } else {
            held.push((second.clone(), lock(&second)?));
        }
        Ok(InstanceLock { held })
    }

    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.held.iter().map(|(p, _)| p.as_path())
    }
}

fn lock(path: &Path) -> Result<Flock<File>, LockError> {
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .mode(0o640)
        .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
        .open(path)
        .map_err(|e| {
            LockError::Folder(format!("cannot open the lock file {}: {e}", path.display()))
        })?;
    match Flock::lock(file, FlockArg::LockExclusiveNonblock) {
        Ok(mut locked) => {
            // The holder's pid, for the message a second daemon prints.
            let pid = std::process::id();
            let _ = locked.set_len(0);
            let _ = locked.rewind();
            let _ = writeln!(locked, "{pid}");
            Ok(locked)
        }
        Err((mut file, errno)) if errno == nix::errno::Errno::EWOULDBLOCK => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
            let holder = holder.trim();
            let who = if holder.is_empty() {
                "another pulsetrackd".to_string()
            } else {
                format!("another pulsetrackd (pid {holder})")
            };
            Err(LockError::Held(format!(
                "{who} is already running on this configuration: it holds {}",
                path.display()
            )))
        }
        Err((_, errno)) => Err(LockError::Folder(format!(
            "cannot lock {}: {errno}",
            path.display()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_holder_is_refused_with_the_first_ones_pid_and_the_lock_is_freed_on_drop() {
        let tmp = tempfile::tempdir().expect("tmp");
        let sock = tmp.path().join("run/console.sock");
        let rec = tmp.path().join("trials");
        let first = InstanceLock::acquire(&sock, &rec).expect("first");
        assert_eq!(first.paths().count(), 2);
        let e = InstanceLock::acquire(&sock, &rec)
            .expect_err("second")
            .to_string();
        assert!(
            e.contains(&format!("(pid {})", std::process::id())) && e.contains("console.sock.lock"),
            "{e}"
        );
        // Another socket on the same recording directory is refused too.
        let e = InstanceLock::acquire(&tmp.path().join("run/other.sock"), &rec)
            .expect_err("same recordings")
            .to_string();
        assert!(e.contains(".pulsetrackd.lock"), "{e}");
        drop(first);
        InstanceLock::acquire(&sock, &rec).expect("free again");
    }
}
