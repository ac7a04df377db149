//! CAN faults on the emulated rig, end to end: the real daemon on `config/lab.ron` with its
//! joints on the Phantom emulator behind an slcan adapter on a pty (in this process, so the
//! test can inject faults and unplug it) and the tactile emulator program. For a lost and
//! returning adapter, an amplifier fault and an e-stop, each case checks that the fault
//! latches with the arm unpowered, that `reset` while the cause is present is refused naming
//! it, that `reset` once it is gone answers `ok` and leaves the arm `disabled`, that `enable`
//! then works, and that the daemon's log is not flooded while latched.
//!
//! Wall-clock time (the rig's clock is real); waits poll for conditions under generous
//! deadlines and nothing asserts how long anything took. A session the shared machine
//! stalls (a stale stream before the fault is injected) is run again, as in hardware_e2e.

mod e2e;
mod rig;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use drivers::can::phantom_emulator::PhantomEmulator;
use e2e::{T, call};
use rig::{
    Client, Emulator, Stalled, lab_config, phantom_in_process, poll_status, poll_until, slcan,
    spawn_daemon, tactile_emulator,
};
use serde_json::{Value, json};

/// Log lines the daemon may write while latched over the measured period (it wrote one
/// ERROR line per control cycle, 1000 a second, before refused writes were burst-logged).
const MAX_LINES_WHILE_LATCHED: usize = 20;

/// The daemon clock's span over which the log is counted, s.
const MEASURED_S: f64 = 2.0;

/// A daemon holding the emulated arm, powered.
struct Session {
    /// Kept for the session: the config, sockets, logs and recordings live there.
    _dir: tempfile::TempDir,
    can_link: PathBuf,
    config: PathBuf,
    arm: Option<PhantomEmulator>,
    _array: Emulator,
    daemon: e2e::Running,
    c: Client,
}

fn holding_session() -> Result<Session, Stalled> {
    let dir = tempfile::tempdir().expect("tmp");
    let (tactile_link, can_link) = (dir.path().join("tactile"), dir.path().join("slcan"));
    let config = lab_config(dir.path(), &tactile_link, &slcan(&can_link));
    let array = tactile_emulator(dir.path(), &tactile_link);
    let arm = phantom_in_process(&can_link, &config, [0.0, 0.0]);
    let daemon = spawn_daemon(dir.path(), &config)?;
    let mut c = Client::connect(&daemon.socket, T).expect("connect");
    poll_status(&mut c, "tactile frames", |s| {
        s["tactile"]["frames"].as_u64().unwrap_or(0) > 0
    })?;
    let r = c.request("enable", json!({}), T).expect("reply");
    if r["ok"] != true {
        return Err(Stalled(format!("enable refused: {r}")));
    }
    poll_status(&mut c, "holding", |s| s["state"] == "holding")?;
    Ok(Session {
        _dir: dir,
        can_link,
        config,
        arm: Some(arm),
        _array: array,
        daemon,
        c,
    })
}

impl Session {
    fn arm(&self) -> &PhantomEmulator {
        self.arm.as_ref().expect("the emulator is plugged in")
    }

    /// The fault latched: state `fault`, the loop faulted and every torque zero.
    fn expect_latched(&mut self) -> Value {
        poll_until(&mut self.c, "the fault latched, unpowered", |s| {
            s["state"] == "fault"
                && s["arm"]["mode"] == "faulted"
                && (0..3).all(|i| s["arm"]["torque_nm"][i].as_f64() == Some(0.0))
        })
    }

    /// Log lines written while the daemon's clock advanced [`MEASURED_S`], still latched.
    fn lines_while_latched(&mut self) -> usize {
        let t0 = call(&mut self.c, "status", json!({}))["t_s"]
            .as_f64()
            .expect("t_s");
        let before = self.daemon.log().lines().count();
        poll_until(&mut self.c, "time passing", |s| {
            s["t_s"].as_f64().is_some_and(|t| t >= t0 + MEASURED_S)
        });
        let after = self.daemon.log().lines().count();
        assert_eq!(
            call(&mut self.c, "status", json!({}))["state"],
            "fault",
            "still latched"
        );
        after - before
    }

    /// `reset` now: the reply.
    fn reset(&mut self) -> Value {
        self.c.request("reset", json!({}), T).expect("reply")
    }

    /// `reset` after the cause is gone: `ok`. The one refusal allowed on the way is a
    /// reopened bus whose amplifiers have not yet been heard (the loop waits 0.25 s for
    /// them; this machine may stall it longer).
    fn reset_once_the_cause_is_gone(&mut self) {
        let deadline = Instant::now() + T;
        loop {
            let r = self.reset();
            if r["ok"] == true {
                break;
            }
            let why = r["reason"].as_str().unwrap_or("");
            assert!(why.contains("no fresh feedback"), "reset refused: {r}");
            assert!(Instant::now() < deadline, "reset never accepted: {r}");
            std::thread::sleep(Duration::from_millis(100));
        }
        let st = call(&mut self.c, "status", json!({}));
        assert_eq!(st["state"], "disabled", "{st}");
        assert_eq!(st["arm"]["mode"], "disabled", "{st}");
        assert!(st["fault"].is_null(), "{st}");
        // The setpoint is where the arm is, not where it was going.
        assert_eq!(st["arm"]["setpoint"], st["arm"]["sensor"], "{st}");
    }

    /// `enable` works again and the arm holds; the refused writes' burst ends with its
    /// count, which is how many ERROR lines the daemon wrote for it before.
    fn enable_again(&mut self) -> u64 {
        let r = self.c.request("enable", json!({}), T).expect("reply");
        assert_eq!(r["ok"], true, "enable after reset: {r}");
        poll_until(&mut self.c, "holding again", |s| s["state"] == "holding");
        let deadline = Instant::now() + T;
        loop {
            let log = self.daemon.log();
            if let Some(n) = log
                .lines()
                .find_map(|l| l.split("writing torques failed: burst over, ").nth(1))
                .and_then(|rest| rest.split(' ').next())
                .and_then(|n| n.parse().ok())
            {
                return n;
            }
            assert!(Instant::now() < deadline, "no burst count:\n{log}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn report(&self, case: &str, lines: usize, refused_writes: u64) {
        eprintln!(
            "{case}: {lines} log lines in {MEASURED_S} s latched (bound {MAX_LINES_WHILE_LATCHED}); \
             {refused_writes} refused writes, each an ERROR line before"
        );
        assert!(
            lines <= MAX_LINES_WHILE_LATCHED,
            "{lines} lines while latched:\n{}",
            self.daemon.log()
        );
    }
}

/// Run `case` on a holding session, again if the machine stalled the session first.
fn with_session(case: impl Fn(&mut Session) -> Result<(), Stalled>) {
    const ATTEMPTS: usize = 4;
    for attempt in 1..=ATTEMPTS {
        match holding_session().and_then(|mut s| {
            case(&mut s)?;
            s.daemon.stop();
            Ok(())
        }) {
            Ok(()) => return,
            Err(Stalled(why)) => {
                eprintln!("attempt {attempt}/{ATTEMPTS}: the machine stalled the daemon: {why}")
            }
        }
    }
    panic!("the machine stalled the daemon in each of {ATTEMPTS} sessions (above)");
}

#[test]
fn can_adapter_lost_and_back_is_cleared_by_reset_without_a_restart() {
    with_session(|s| {
        // Unplugged: the pty closes and its stable path goes.
        drop(s.arm.take());
        let st = s.expect_latched();
        assert_eq!(st["fault"]["fault"], "backend", "{st}");
        let lines = s.lines_while_latched();
        let link = s.can_link.display().to_string();
        assert!(
            s.daemon
                .log()
                .contains(&format!("CAN adapter slcan {link} failed")),
            "the log names the lost adapter:\n{}",
            s.daemon.log()
        );
        // Still gone: refused, naming the adapter and what the OS said.
        let r = s.reset();
        assert_eq!(r["ok"], false, "{r}");
        let why = r["reason"].as_str().unwrap_or("");
        assert!(
            why.starts_with("the cause is still present: CAN adapter slcan ")
                && why.contains(&format!(
                    "{link} not available: cannot open slcan adapter {link}"
                )),
            "{r}"
        );
        assert_eq!(call(&mut s.c, "status", json!({}))["state"], "fault");
        // Plugged in again (a new pty behind the same path): reset reopens it.
        s.arm = Some(phantom_in_process(&s.can_link, &s.config, [0.0, 0.0]));
        s.reset_once_the_cause_is_gone();
        let refused_writes = s.enable_again();
        s.report("adapter lost", lines, refused_writes);
        Ok(())
    });
}

#[test]
fn can_amplifier_fault_is_refused_while_present_and_cleared_by_reset_after() {
    with_session(|s| {
        s.arm().amp_fault(1, true);
        let st = s.expect_latched();
        assert_eq!(st["fault"]["fault"], "backend", "{st}");
        let lines = s.lines_while_latched();
        assert!(
            s.daemon
                .log()
                .contains("joint 1 amplifier reports emergency code 0x2310"),
            "the log names the amplifier's emergency:\n{}",
            s.daemon.log()
        );
        let r = s.reset();
        assert_eq!(r["ok"], false, "{r}");
        assert_eq!(
            r["reason"],
            "the cause is still present: the amplifier of joint 1 (node 2) still reports a \
             fault (status 0x02) after being asked to clear it",
            "{r}"
        );
        assert_eq!(call(&mut s.c, "status", json!({}))["state"], "fault");
        // The over-current is gone; the amplifier's own latch is cleared by the reset.
        s.arm().amp_fault(1, false);
        s.reset_once_the_cause_is_gone();
        let refused_writes = s.enable_again();
        s.report("amplifier fault", lines, refused_writes);
        Ok(())
    });
}

#[test]
fn can_estop_is_refused_while_open_and_cleared_by_reset_once_released() {
    with_session(|s| {
        s.arm().estop(true);
        let st = s.expect_latched();
        assert_eq!(st["fault"]["fault"], "backend", "{st}");
        let lines = s.lines_while_latched();
        assert!(
            s.daemon.log().contains("CAN: e-stop open"),
            "the log names the e-stop:\n{}",
            s.daemon.log()
        );
        let r = s.reset();
        assert_eq!(r["ok"], false, "{r}");
        assert_eq!(
            r["reason"],
            "the cause is still present: e-stop open on joint 0 (node 1); release it first",
            "{r}"
        );
        // Enabling is refused too: the fault is latched.
        let r = s.c.request("enable", json!({}), T).expect("reply");
        assert_eq!(r["ok"], false, "{r}");
        s.arm().estop(false);
        s.reset_once_the_cause_is_gone();
        let refused_writes = s.enable_again();
        s.report("e-stop", lines, refused_writes);
        Ok(())
    });
}
