//! The fault matrix (docs/reliability.md): the real daemon on the simulated bench, driven
//! into each fault a lab meets — a full or read-only recording disk, a second daemon, a
//! corrupt recording at start, idle clients filling the console, a planted link, a
//! foreign-owned folder, a swapped socket, a stranger at the socket — asserting the safe
//! state, the exact reply, and that every acknowledged item is in the recording afterwards
//! (read back with the mcap crate and counted).
//!
//! Cases that need root (mounting a small tmpfs, acting as another user) fall back or say
//! why they were skipped: CI runs as root, so there every case runs.

mod e2e;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use daemon::console::client::Client;
use daemon::recording::recover;
use daemon::recording::topics::Topic;
use e2e::{Setup, SmallDisk, T, call, scene, start_with_config, state, wait_state};
use serde_json::{Value, json};

fn is_root() -> bool {
    nix::unistd::geteuid().is_root()
}

/// The user every "stranger" case acts as.
const NOBODY: u32 = 65_534;

/// A copy of `exe` in a world-readable folder under `dir`, so that another user can run it: the
/// build folder may sit under a home directory only its owner can enter (CI builds in
/// `/root/.cache`).
fn runnable_by_anyone(dir: &Path, exe: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).expect("bin dir");
    std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o755)).expect("chmod bin");
    let copy = bin.join(exe.file_name().expect("exe name"));
    std::fs::copy(exe, &copy).expect("copy exe");
    std::fs::set_permissions(&copy, std::fs::Permissions::from_mode(0o755)).expect("chmod exe");
    copy
}

/// The test config with `edit` applied to its text (a field added after a known line).
fn config_with(dir: &Path, setup: &Setup, edits: &[(&str, &str)]) -> PathBuf {
    let path = e2e::write_config(dir, setup);
    let mut text = std::fs::read_to_string(&path).expect("config");
    for (after, add) in edits {
        assert!(text.contains(after), "no {after:?} in the test config");
        text = text.replacen(after, &format!("{after}\n        {add}"), 1);
    }
    std::fs::write(&path, text).expect("write config");
    path
}

/// The line of the test config that names the recording folder.
fn dir_line(dir: &Path) -> String {
    format!("dir: {:?},", dir.join("trials").display().to_string())
}

/// A temporary folder with `trials/` in it on a tmpfs of `bytes`; `None` when not root (the
/// test is skipped, saying that `what` needs root).
fn trials_on_a_small_disk(
    bytes: u64,
    what: &str,
) -> Option<(tempfile::TempDir, PathBuf, SmallDisk)> {
    if !is_root() {
        eprintln!("skipped: {what} needs root");
        return None;
    }
    let dir = tempfile::tempdir().expect("tmp");
    let trials = dir.path().join("trials");
    let disk = SmallDisk::mount(&trials, bytes).expect("tmpfs as root");
    Some((dir, trials, disk))
}

/// Collect events until `pred` holds (faults included: these tests wait for them).
fn events_until(c: &mut Client, what: &str, pred: impl Fn(&Value) -> bool) -> Vec<Value> {
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut seen = Vec::new();
    loop {
        if let Some(e) = c.next_event(Duration::from_millis(200)).expect("event") {
            let done = pred(&e);
            seen.push(e);
            if done {
                return seen;
            }
        }
        assert!(
            Instant::now() < deadline,
            "no {what} within 120 s: {seen:?}"
        );
    }
}

/// Every `.mcap` trial file in `trials` (recovery's own names excluded).
fn trial_files(trials: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(trials)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    v.retain(|p| {
        let n = p.file_name().map(|n| n.to_string_lossy().into_owned());
        n.is_some_and(|n| n.ends_with(".mcap") && !n.contains(".truncated"))
    });
    v.sort();
    v
}

/// What a console client was told was done: ok replies of durable verbs (by id) and located
/// points.
#[derive(Debug, Default)]
struct Acknowledged {
    verbs: Vec<(String, u64)>,
    located: Vec<Value>,
}

impl Acknowledged {
    fn request(&mut self, c: &mut Client, verb: &str, args: Value) -> Value {
        let r = c.request(verb, args, T).expect("reply");
        if r["ok"] == true
            && matches!(verb, "mark" | "track" | "resume" | "stop")
            && let Some(id) = r["id"].as_u64()
        {
            self.verbs.push((verb.to_string(), id));
        }
        r
    }

    fn note(&mut self, events: &[Value]) {
        for e in events {
            if e["event"] == "detection" && e["kind"] == "located" {
                self.located.push(e["point"].clone());
            }
        }
    }

    /// Every acknowledged item is in the recordings of `trials`.
    fn assert_recorded(&self, trials: &Path) {
        let mut verbs = Vec::new();
        let mut located = Vec::new();
        for f in trial_files(trials) {
            let back = recover::read(&f).unwrap_or_else(|e| panic!("{e}"));
            for m in back.on(Topic::Events) {
                if m.json["event"] == "verb"
                    && let (Some(v), Some(id)) = (m.json["verb"].as_str(), m.json["id"].as_u64())
                {
                    verbs.push((v.to_string(), id));
                }
                if m.json["kind"] == "located" {
                    located.push(m.json["point"].clone());
                }
            }
        }
        for v in &self.verbs {
            assert!(verbs.contains(v), "acknowledged {v:?} is not recorded");
        }
        for p in &self.located {
            assert!(
                located.contains(p),
                "acknowledged point {p} is not recorded"
            );
        }
    }
}

/// Drive a trial until the recording fails: seeds, then track. Returns the fault event.
fn run_until_recording_fails(c: &mut Client, ack: &mut Acknowledged) -> Value {
    call(
        c,
        "subscribe",
        json!({"streams": ["state", "detections", "faults", "trials"]}),
    );
    let (placements, _) = scene(c);
    call(c, "enable", json!({}));
    let is_fault = |e: &Value| e["event"] == "fault";
    for (x, z) in placements {
        call(c, "move", json!({"x_m": x, "z_m": z}));
        wait_state(c, "holding");
        let r = ack.request(c, "mark", json!({}));
        if r["ok"] != true {
            assert_eq!(r["error"], "recording_failed", "{r}");
            let ev = events_until(c, "the fault", is_fault);
            ack.note(&ev);
            return ev.last().cloned().unwrap_or_default();
        }
        let ev = events_until(c, "a mark's result or a fault", |e| {
            is_fault(e)
                || (e["event"] == "detection" && (e["kind"] == "located" || e["kind"] == "missed"))
        });
        ack.note(&ev);
        if let Some(f) = ev.iter().find(|e| is_fault(e)) {
            return f.clone();
        }
        wait_state(c, "holding");
    }
    let r = ack.request(c, "track", json!({}));
    if r["ok"] != true {
        assert_eq!(r["error"], "recording_failed", "{r}");
    }
    let ev = events_until(c, "the recording_failed fault", is_fault);
    ack.note(&ev);
    ev.last().cloned().unwrap_or_default()
}

/// How the recording runs out of room.
#[derive(Debug, Clone, Copy, PartialEq)]
enum NoRoom {
    /// A 200 KiB tmpfs as the recording folder (root only).
    SmallDisk,
    /// A 2 MiB file-size limit on the daemon (RLIMIT_FSIZE, through `prlimit`): room for
    /// the seeds and part of the track, so that located points were acknowledged first.
    FileSizeLimit,
}

fn recording_runs_out_mid_trial(how: NoRoom) {
    let dir = tempfile::tempdir().expect("tmp");
    let trials = dir.path().join("trials");
    let disk = match how {
        NoRoom::SmallDisk => match SmallDisk::mount(&trials, 200 * 1024) {
            Some(d) => Some(d),
            None => {
                eprintln!("skipped: mounting a tmpfs needs root (the file-size case runs anyway)");
                return;
            }
        },
        NoRoom::FileSizeLimit => None,
    };
    let config = config_with(
        dir.path(),
        &Setup::default(),
        &[(&dir_line(dir.path()), "min_free_bytes: 0,")],
    );
    let limit = format!("--fsize={}", 2 << 20);
    let wrapper: &[&str] = match how {
        NoRoom::SmallDisk => &[],
        NoRoom::FileSizeLimit => &["prlimit", &limit, "--"],
    };
    let (daemon, mut c) = e2e::start_wrapped(dir.path(), config.clone(), wrapper);
    let mut ack = Acknowledged::default();
    let fault = run_until_recording_fails(&mut c, &mut ack);
    assert_eq!(fault["fault"], "recording_failed", "{fault}");
    let reason = fault["reason"].as_str().unwrap_or("");
    let os_error = match how {
        NoRoom::SmallDisk => "No space left on device",
        NoRoom::FileSizeLimit => "File too large",
    };
    assert!(
        reason.contains(&trials.display().to_string()) && reason.contains(os_error),
        "the fault names the file and the OS error: {reason}"
    );
    // The safe state: power off, latched, the trial ended. The arm's mode follows the latch on
    // the loop's next cycle, so a status taken in between may still say "enabled".
    let deadline = Instant::now() + T;
    let st = loop {
        let st = call(&mut c, "status", json!({}));
        if st["arm"]["mode"] == "faulted" || Instant::now() > deadline {
            break st;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(st["state"], "fault", "{st}");
    assert_eq!(st["arm"]["mode"], "faulted", "{st}");
    assert!(st["trial"].is_null(), "{st}");
    assert!(
        st["fault"]["detail"]
            .as_str()
            .is_some_and(|d| d.contains(os_error)),
        "{st}"
    );
    // Nothing that was acknowledged is missing from the file.
    eprintln!(
        "{how:?}: acknowledged before the failure: {:?}, {} located points",
        ack.verbs,
        ack.located.len()
    );
    assert!(
        !ack.verbs.is_empty(),
        "the first mark was acknowledged before the disk filled"
    );
    if how == NoRoom::FileSizeLimit {
        // 2 MiB holds the seeds and the start of the track (a 26 cm track records ~6 MB).
        assert!(
            ack.verbs.iter().any(|(v, _)| v == "track") && !ack.located.is_empty(),
            "{ack:?}"
        );
    }
    ack.assert_recorded(&trials);
    // A new trial cannot promise anything either: its mark fails rather than say ok.
    call(&mut c, "reset", json!({}));
    assert_eq!(state(&mut c), "disabled");
    call(&mut c, "enable", json!({}));
    if how == NoRoom::SmallDisk {
        let r = c.request("mark", json!({}), T).expect("reply");
        assert_eq!(r["ok"], false, "{r}");
        assert_eq!(r["error"], "recording_failed", "{r}");
    }
    daemon.stop();
    // Two restarts (still full) never destroy the recording.
    let before: Vec<(PathBuf, Vec<u8>)> = trial_files(&trials)
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).expect("read");
            (p, b)
        })
        .collect();
    assert!(!before.is_empty());
    for _ in 0..2 {
        let (d, _c) = e2e::start_wrapped(dir.path(), config.clone(), wrapper);
        d.stop();
    }
    for (p, bytes) in &before {
        let kept = std::fs::read(p).expect("the recording is still there");
        let stem = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let original_kept = std::fs::read(p.with_file_name(format!("{stem}.truncated.mcap")))
            .is_ok_and(|orig| &orig == bytes);
        assert!(
            &kept == bytes || original_kept,
            "{} lost its bytes",
            p.display()
        );
    }
    ack.assert_recorded(&trials);
    drop(disk);
}

#[test]
fn a_full_disk_mid_trial_holds_then_latches_recording_failed_and_loses_nothing_acknowledged() {
    recording_runs_out_mid_trial(NoRoom::SmallDisk);
}

#[test]
fn a_file_size_limit_mid_trial_holds_then_latches_recording_failed_and_loses_nothing_acknowledged()
{
    recording_runs_out_mid_trial(NoRoom::FileSizeLimit);
}

#[test]
fn a_full_disk_refuses_a_trial_up_front_with_the_figure() {
    let Some((dir, trials, _disk)) = trials_on_a_small_disk(200 * 1024, "mounting a tmpfs") else {
        return;
    };
    // The default minimum (64 MiB) is more than the disk.
    let (daemon, mut c) = e2e::start(dir.path(), &Setup::default());
    call(&mut c, "enable", json!({}));
    let r = c.request("mark", json!({}), T).expect("reply");
    assert_eq!(
        (r["ok"].clone(), r["error"].clone()),
        (json!(false), json!("refused")),
        "{r}"
    );
    let why = r["reason"].as_str().unwrap_or("");
    assert!(
        why.contains("KiB free in") && why.contains("recording.min_free_bytes is 64.0 MiB"),
        "{why}"
    );
    assert_eq!(state(&mut c), "holding", "nothing started");
    assert!(trial_files(&trials).is_empty());
    daemon.stop();
}

#[test]
fn a_read_only_recording_folder_refuses_trials_with_the_reason() {
    let Some((dir, _, disk)) = trials_on_a_small_disk(4 << 20, "a read-only mount") else {
        return;
    };
    disk.remount_read_only();
    let config = config_with(
        dir.path(),
        &Setup::default(),
        &[(&dir_line(dir.path()), "min_free_bytes: 0,")],
    );
    // The daemon starts (the arm can still be moved and stopped), says why in its log, and
    // refuses every trial with the reason.
    let (daemon, mut c) = start_with_config(dir.path(), config);
    assert!(daemon.log().contains("is read-only"), "{}", daemon.log());
    call(&mut c, "enable", json!({}));
    let r = c.request("mark", json!({}), T).expect("reply");
    assert_eq!(
        (r["ok"].clone(), r["error"].clone()),
        (json!(false), json!("refused")),
        "{r}"
    );
    assert!(
        r["reason"]
            .as_str()
            .is_some_and(|r| r.contains("read-only filesystem") && r.contains("trials")),
        "{r}"
    );
    assert_eq!(state(&mut c), "holding");
    daemon.stop();
}

#[test]
fn a_second_daemon_on_the_same_config_exits_without_touching_the_first() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = e2e::start(dir.path(), &Setup::default());
    e2e::seed(&mut c);
    let trials = dir.path().join("trials");
    let files = trial_files(&trials);
    assert_eq!(files.len(), 1);
    let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(&daemon.config)
        .output()
        .expect("second daemon");
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("(pid {})", daemon.pid()))
            && err.contains("already running on this configuration")
            && err.contains("console.sock.lock"),
        "{err}"
    );
    // The first daemon's trial file is untouched: no rename, no recovered copy, no summary.
    assert_eq!(trial_files(&trials), files);
    assert!(!files[0].with_extension("json").exists());
    let names: Vec<String> = std::fs::read_dir(&trials)
        .expect("dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !names
            .iter()
            .any(|n| n.contains("truncated") || n.contains("recovering")),
        "{names:?}"
    );
    call(&mut c, "track", json!({}));
    assert_eq!(state(&mut c), "tracking");
    daemon.stop();
    let back = recover::read(&files[0]).expect("readable");
    assert!(back.complete);
}

/// A recording whose chunk holds a record length near u64::MAX (what made the mcap reader
/// panic): a trial file with an uncompressed chunk (as trial files were before issue 14, so
/// the record can be found and overwritten) with one record's length overwritten.
fn corrupt_recording(path: &Path) {
    let file = std::fs::File::create(path).expect("create");
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(std::io::BufWriter::new(file))
        .expect("writer");
    let schema = w
        .add_schema(
            Topic::Tactile.schema_name(),
            "jsonschema",
            Topic::Tactile.schema().as_bytes(),
        )
        .expect("schema");
    let channel = w
        .add_channel(schema, Topic::Tactile.name(), "json", &Default::default())
        .expect("channel");
    for i in 0..20u32 {
        let body = json!({"seq": i, "force_n": vec![0.0; 10]}).to_string();
        let ns = u64::from(i) * 10_000_000;
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channel,
                sequence: i,
                log_time: ns,
                publish_time: ns,
            },
            body.as_bytes(),
        )
        .expect("write");
    }
    w.flush().expect("flush");
    drop(w.into_inner());
    let mut bytes = std::fs::read(path).expect("read");
    // The first message record (opcode 0x05) inside the chunk: its length field follows.
    let at = bytes
        .windows(2)
        .rposition(|w| w[0] == 0x05 && w[1] > 0)
        .expect("a message record");
    bytes[at + 1..at + 9].copy_from_slice(&(u64::MAX - 7).to_le_bytes());
    std::fs::write(path, bytes).expect("write");
}

#[test]
fn a_corrupt_recording_at_start_is_quarantined_and_named() {
    let dir = tempfile::tempdir().expect("tmp");
    let trials = dir.path().join("trials");
    std::fs::create_dir_all(&trials).expect("dir");
    std::fs::set_permissions(&trials, std::fs::Permissions::from_mode(0o750)).expect("chmod");
    let bad = trials.join("2026-11-25T10-00-00Z-1.mcap");
    corrupt_recording(&bad);
    let garbage = trials.join("garbage.mcap");
    std::fs::write(&garbage, b"\x89MCAP0\r\n not really").expect("write");
    // The CLI names the file and fails, without a panic (exit 1, not 101).
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .arg("recover")
        .arg(&bad)
        .output()
        .expect("recover");
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&bad.display().to_string()), "{err}");
    // The daemon starts, moves both aside and says which.
    let (daemon, _c) = e2e::start(dir.path(), &Setup::default());
    let q = trials.join("quarantine");
    assert!(q.join("2026-11-25T10-00-00Z-1.mcap").exists());
    assert!(q.join("garbage.mcap").exists());
    assert!(!bad.exists() && !garbage.exists());
    let log = daemon.log();
    assert!(
        log.contains(&format!("{} is not a readable recording", bad.display())),
        "{log}"
    );
    daemon.stop();
}

#[test]
fn idle_connections_cannot_lock_out_estop() {
    let dir = tempfile::tempdir().expect("tmp");
    let config = config_with(
        dir.path(),
        &Setup::default(),
        &[(
            "debug_hooks: false,",
            "max_clients: 3,\n        idle_timeout_s: 8.0,",
        )],
    );
    let (daemon, mut first) = start_with_config(dir.path(), config);
    // A subscriber is a watcher, never idle: this one keeps its slot throughout.
    call(&mut first, "subscribe", json!({"streams": ["state"]}));
    // Fill the console: the harness's client and two more, all idle.
    let mut idle: Vec<Client> = (0..2)
        .map(|_| Client::connect(&daemon.socket, T).expect("connect"))
        .collect();
    // The reserved connection: estop and status only.
    let mut spare = Client::connect(&daemon.socket, T).expect("the reserved connection");
    assert!(
        spare.hello["restricted"]
            .as_str()
            .is_some_and(|r| r.contains("accepts only estop and status")),
        "{}",
        spare.hello
    );
    let r = spare.request("enable", json!({}), T).expect("reply");
    assert_eq!(r["error"], "unavailable", "{r}");
    // One more is refused and told why.
    let e = Client::connect(&daemon.socket, T).expect_err("full");
    assert!(e.to_string().contains("too many console clients"), "{e}");
    call(&mut first, "enable", json!({}));
    let r = spare.request("estop", json!({}), T).expect("reply");
    assert_eq!(
        (r["ok"].clone(), r["state"].clone()),
        (json!(true), json!("fault")),
        "{r}"
    );
    // Idle clients are disconnected with the reason, freeing their slots.
    for c in idle.iter_mut() {
        let line = c
            .reply_to(None, Duration::from_secs(60))
            .expect("told why before the close");
        assert!(
            line["reason"]
                .as_str()
                .is_some_and(|r| r.contains("no request for 8 s")),
            "{line}"
        );
    }
    let mut again = Client::connect(&daemon.socket, T).expect("a slot is free again");
    assert!(again.hello["restricted"].is_null(), "{}", again.hello);
    assert_eq!(state(&mut again), "fault");
    daemon.stop();
}

#[test]
fn estop_replies_ok_with_the_state_it_left() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = e2e::start(dir.path(), &Setup::default());
    call(&mut c, "enable", json!({}));
    let r = c.request("estop", json!({}), T).expect("reply");
    assert_eq!(r["ok"], true, "{r}");
    assert_eq!(r["state"], "fault", "{r}");
    // Again with a fault latched, and from the command line: exit 0, "ok".
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["estop", "--socket"])
        .arg(&daemon.socket)
        .output()
        .expect("pt-console");
    assert!(out.status.success(), "{out:?}");
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("estop: ok (state fault)"),
        "{out:?}"
    );
    daemon.stop();
}

#[test]
fn a_planted_link_is_never_followed_by_the_flight_recorder() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = e2e::start(dir.path(), &Setup::default());
    let trials = dir.path().join("trials");
    let victim = dir.path().join("root-only");
    std::fs::write(&victim, b"precious").expect("victim");
    // Links at every name the next few seconds of estop dumps could take.
    let now = std::time::SystemTime::now();
    for dt in 0..20 {
        let stamp = daemon::recording::naming::utc_stamp(now + Duration::from_secs(dt));
        std::os::unix::fs::symlink(&victim, trials.join(format!("fault-{stamp}-estop.jsonl")))
            .expect("plant");
    }
    call(&mut c, "enable", json!({}));
    call(&mut c, "estop", json!({}));
    let st = call(&mut c, "status", json!({}));
    let dump = PathBuf::from(st["fault"]["flight_recorder"].as_str().expect("a dump"));
    assert!(
        !std::fs::symlink_metadata(&dump)
            .expect("dump")
            .file_type()
            .is_symlink(),
        "{}",
        dump.display()
    );
    assert!(
        dump.display().to_string().ends_with("-estop-1.jsonl"),
        "{}",
        dump.display()
    );
    assert_eq!(std::fs::read(&victim).expect("victim"), b"precious");
    // A second fault in the same second gets a file of its own.
    call(&mut c, "reset", json!({}));
    call(&mut c, "enable", json!({}));
    call(&mut c, "estop", json!({}));
    let st = call(&mut c, "status", json!({}));
    let second = PathBuf::from(st["fault"]["flight_recorder"].as_str().expect("a dump"));
    assert_ne!(second, dump);
    assert!(second.exists() && dump.exists());
    daemon.stop();
}

#[test]
fn a_foreign_owned_or_world_writable_folder_is_refused_at_start() {
    let dir = tempfile::tempdir().expect("tmp");
    let config = e2e::write_config(dir.path(), &Setup::default());
    let trials = dir.path().join("trials");
    std::fs::create_dir_all(&trials).expect("dir");
    std::fs::set_permissions(&trials, std::fs::Permissions::from_mode(0o777)).expect("chmod");
    let refused = |why: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
            .arg("--config")
            .arg(&config)
            .output()
            .expect("daemon");
        assert_eq!(
            out.status.code(),
            Some(2),
            "a configuration problem: no restart helps"
        );
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(
            err.contains(&trials.display().to_string()) && err.contains(why),
            "{err}"
        );
        assert!(!dir.path().join("console.sock").exists(), "never listened");
    };
    refused("writable by every user");
    if is_root() {
        std::fs::set_permissions(&trials, std::fs::Permissions::from_mode(0o750)).expect("chmod");
        std::os::unix::fs::chown(&trials, Some(NOBODY), Some(NOBODY)).expect("chown");
        refused(&format!("belongs to uid {NOBODY}"));
    } else {
        eprintln!("foreign owner case skipped: chown needs root");
    }
}

#[test]
fn a_config_whose_scene_is_missing_exits_2_naming_it() {
    let dir = tempfile::tempdir().expect("tmp");
    let setup = Setup {
        scene: "no-such-scene.ron".into(),
        ..Setup::default()
    };
    let config = e2e::write_config(dir.path(), &setup);
    let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(&config)
        .output()
        .expect("daemon");
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no-such-scene.ron: no such scene file"),
        "{err}"
    );
}

/// With `PT_FAKE_DAEMON_SOCKET` set, this test is a fake daemon: it listens there and
/// answers every request `ok` (what a swapped socket would do). Otherwise it does nothing.
#[test]
fn fake_daemon_entry() {
    let Some(path) = std::env::var_os("PT_FAKE_DAEMON_SOCKET") else {
        return;
    };
    use std::io::{BufRead, BufReader, Write};
    let l = std::os::unix::net::UnixListener::bind(&path).expect("bind");
    if let Ok((s, _)) = l.accept() {
        let mut w = s.try_clone().expect("clone");
        let _ = writeln!(w, "{}", json!({"hello": "pulsetrackd", "protocol": 1}));
        for line in BufReader::new(s).lines().map_while(Result::ok) {
            let id = serde_json::from_str::<Value>(&line).map(|v| v["id"].clone());
            let _ = writeln!(
                w,
                "{}",
                json!({"id": id.unwrap_or_default(), "ok": true, "state": "disabled"})
            );
        }
    }
}

#[test]
fn the_console_tool_refuses_a_socket_served_by_another_user() {
    if !is_root() {
        eprintln!("skipped: acting as another user needs root");
        return;
    }
    let dir = tempfile::tempdir().expect("tmp");
    let open = dir.path().join("open");
    std::fs::create_dir(&open).expect("dir");
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).expect("chmod");
    std::fs::set_permissions(&open, std::fs::Permissions::from_mode(0o777)).expect("chmod");
    let sock = open.join("console.sock");
    use std::os::unix::process::CommandExt;
    let fake_exe = runnable_by_anyone(dir.path(), &std::env::current_exe().expect("exe"));
    let mut fake = Command::new(fake_exe)
        .args(["fake_daemon_entry", "--exact", "--nocapture"])
        .env("PT_FAKE_DAEMON_SOCKET", &sock)
        .uid(NOBODY)
        .gid(NOBODY)
        .stdout(Stdio::null())
        .spawn()
        .expect("fake daemon");
    let deadline = Instant::now() + T;
    while !sock.exists() {
        assert!(Instant::now() < deadline, "the fake daemon never listened");
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["estop", "--socket"])
        .arg(&sock)
        .output()
        .expect("pt-console");
    let _ = fake.kill();
    let _ = fake.wait();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("served by uid {NOBODY}"))
            && !String::from_utf8_lossy(&out.stdout).contains("ok"),
        "{err}"
    );
}

/// A user with a supplementary group that is not its primary one, from /etc/group.
fn user_with_a_supplementary_group() -> Option<(u32, u32, u32)> {
    let text = std::fs::read_to_string("/etc/group").ok()?;
    for line in text.lines() {
        let f: Vec<&str> = line.split(':').collect();
        let (Some(gid), Some(members)) = (f.get(2).and_then(|g| g.parse::<u32>().ok()), f.get(3))
        else {
            continue;
        };
        for m in members.split(',').filter(|m| !m.is_empty()) {
            if let Ok(Some(u)) = nix::unistd::User::from_name(m)
                && u.gid.as_raw() != gid
                && u.uid.as_raw() != 0
            {
                return Some((u.uid.as_raw(), u.gid.as_raw(), gid));
            }
        }
    }
    None
}

#[test]
fn strangers_are_refused_by_uid_and_groups_and_supplementary_members_let_in() {
    if !is_root() {
        eprintln!("skipped: acting as another user needs root");
        return;
    }
    let dir = tempfile::tempdir().expect("tmp");
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).expect("chmod");
    let member = user_with_a_supplementary_group();
    let allowed_gid = member.map(|(_, _, g)| g).unwrap_or(4242);
    let config = config_with(
        dir.path(),
        &Setup::default(),
        &[(
            "debug_hooks: false,",
            &format!("allowed_gids: [{allowed_gid}],"),
        )],
    );
    let (daemon, _c) = start_with_config(dir.path(), config);
    // The socket is 0660 root:root; open it up so that the peer check is what decides.
    std::fs::set_permissions(&daemon.socket, std::fs::Permissions::from_mode(0o666))
        .expect("chmod");
    use std::os::unix::process::CommandExt;
    let console = runnable_by_anyone(dir.path(), Path::new(env!("CARGO_BIN_EXE_pt-console")));
    let as_user = |uid: u32, gid: u32| {
        Command::new(&console)
            .args(["status", "--json", "--socket"])
            .arg(&daemon.socket)
            .uid(uid)
            .gid(gid)
            .output()
            .expect("pt-console")
    };
    let out = as_user(NOBODY, NOBODY);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "uid {NOBODY} with groups [{NOBODY}] is not allowed"
        )) && err.contains(&format!("allowed_gids [{allowed_gid}]")),
        "{err}"
    );
    match member {
        Some((uid, gid, _)) => {
            let out = as_user(uid, gid);
            assert!(out.status.success(), "a supplementary member: {out:?}");
        }
        None => eprintln!("supplementary case skipped: no user in /etc/group has one"),
    }
    daemon.stop();
}
