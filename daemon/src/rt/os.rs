//! The few operating-system calls the real-time loop needs: the monotonic clock, sleeping to
//! an absolute deadline, SCHED_FIFO and locked memory. The only unsafe code in the daemon;
//! each call is a plain libc call on values owned here.
#![allow(unsafe_code)]

use std::io;

/// A point on CLOCK_MONOTONIC, in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct MonoNs(pub i64);

impl MonoNs {
    pub fn now() -> MonoNs {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
        if rc != 0 {
            return MonoNs(0);
        }
        MonoNs(ts.tv_sec * 1_000_000_000 + ts.tv_nsec)
    }

    pub fn plus_ns(self, ns: i64) -> MonoNs {
        MonoNs(self.0.saturating_add(ns))
    }

    pub fn ns_since(self, earlier: MonoNs) -> i64 {
        self.0.saturating_sub(earlier.0)
    }
}

/// Sleep until `deadline` on CLOCK_MONOTONIC (clock_nanosleep with TIMER_ABSTIME: no drift,
/// and a signal only makes us go back to sleep to the same deadline).
pub fn sleep_until(deadline: MonoNs) {
    let ts = libc::timespec {
        tv_sec: deadline.0.div_euclid(1_000_000_000),
        tv_nsec: deadline.0.rem_euclid(1_000_000_000),
    };
    loop {
        // SAFETY: `ts` is a valid timespec; the remainder pointer may be null with
        // TIMER_ABSTIME.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        if rc != libc::EINTR {
            return;
        }
    }
}

/// Ask for SCHED_FIFO at `priority` for the calling thread.
pub fn set_fifo_priority(priority: u8) -> io::Result<()> {
    let param = libc::sched_param {
        sched_priority: i32::from(priority),
    };
    // SAFETY: pid 0 is the calling thread; `param` is a valid sched_param.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// Lock all current and future pages of the process in memory.
pub fn lock_all_memory() -> io::Result<()> {
    // SAFETY: mlockall takes flags only.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// Touch `bytes` of stack so the loop's first cycles do not page-fault on it.
pub fn prefault_stack(bytes: usize) {
    fn touch<const N: usize>() {
        let buf = [0u8; N];
        std::hint::black_box(&buf);
    }
    if bytes >= 256 * 1024 {
        touch::<{ 256 * 1024 }>();
    } else {
        touch::<{ 64 * 1024 }>();
    }
}

/// Make a file-size limit (RLIMIT_FSIZE) an error instead of death: by default SIGXFSZ
/// kills the process, and a recording that outgrows a limit must fail like a full disk
/// (EFBIG), stopping the trial safely, not take the daemon down with the arm powered.
pub fn ignore_file_size_signal() {
    // SAFETY: installs the predefined SIG_IGN disposition; no handler code runs.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// The process's effective user id.
pub fn effective_uid() -> u32 {
    // SAFETY: geteuid has no arguments and cannot fail.
    unsafe { libc::geteuid() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sleeping_to_an_absolute_deadline_does_not_return_early() {
        let start = MonoNs::now();
        let deadline = start.plus_ns(2_000_000);
        sleep_until(deadline);
        assert!(MonoNs::now() >= deadline);
        // A deadline in the past returns at once.
        sleep_until(start);
    }
}
