//! Harness for the end-to-end tests: the real daemon program (`pt-daemon`, which is
//! `pulsetrackd`) on the simulated bench, started as a child process with a config written
//! for the test, driven over its Unix socket with the console client.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use daemon::console::client::Client;
use serde_json::{Value, json};

pub const T: Duration = Duration::from_secs(30);

/// Settings a test changes in the shipped sim config.
#[derive(Debug, Clone)]
pub struct Setup {
    pub scene: String,
    pub seed: u64,
    pub time_scale: f64,
    pub debug_hooks: bool,
}

impl Default for Setup {
    fn default() -> Self {
        Self {
            scene: "seed-arc-220.ron".into(),
            seed: 1,
            time_scale: 40.0,
            debug_hooks: false,
        }
    }
}

pub struct Running {
    pub child: Child,
    pub dir: PathBuf,
    pub socket: PathBuf,
    pub config: PathBuf,
}

/// The shipped sim config with this test's socket, recording directory, scene and clock.
pub fn write_config(dir: &Path, s: &Setup) -> PathBuf {
    let (_, text) = config::shipped::SIM_CONFIG;
    let socket = dir.join("console.sock");
    let trials = dir.join("trials");
    let mut text = text
        .replace(
            "socket_path: \"{runtime}/console.sock\",",
            &format!(
                "socket_path: {:?},\n        debug_hooks: {},",
                socket.display().to_string(),
                s.debug_hooks
            ),
        )
        .replace(
            "dir: \"{state}/trials\",",
            &format!("dir: {:?},", trials.display().to_string()),
        )
        .replace(
            "file: \"{state}/sim-calibration.ron\",",
            &format!(
                "file: {:?},",
                dir.join("calibration.ron").display().to_string()
            ),
        )
        .replace(
            "time_scale: 1.0,",
            &format!("time_scale: {:?},", s.time_scale),
        )
        .replace("seed: 1,", &format!("seed: {},", s.seed))
        // Tests run side by side: the live view on any free port (status names it).
        .replace(
            "live: (\n        enabled: true,",
            "live: (\n        enabled: true,\n        port: 0,",
        )
        .replace("\"seed-arc-145.ron\"", &format!("{:?}", s.scene));
    text.push('\n');
    let path = dir.join("daemon.ron");
    std::fs::write(&path, text).expect("write config");
    path
}

/// Start the daemon on `dir` and wait until its socket answers and the tactile stream is live.
pub fn start(dir: &Path, s: &Setup) -> (Running, Client) {
    let config = write_config(dir, s);
    start_with_config(dir, config)
}

pub fn start_with_config(dir: &Path, config: PathBuf) -> (Running, Client) {
    start_wrapped(dir, config, &[])
}

/// Start the daemon under `wrapper` (a command and its arguments that exec the daemon, such
/// as `prlimit --fsize=N --`); empty runs it directly.
pub fn start_wrapped(dir: &Path, config: PathBuf, wrapper: &[&str]) -> (Running, Client) {
    let log = std::fs::File::options()
        .create(true)
        .append(true)
        .open(dir.join("daemon.log"))
        .expect("log file");
    let daemon = env!("CARGO_BIN_EXE_pt-daemon");
    let mut cmd = match wrapper.split_first() {
        Some((program, args)) => {
            let mut c = Command::new(program);
            c.args(args).arg(daemon);
            c
        }
        None => Command::new(daemon),
    };
    let child = cmd
        .arg("--config")
        .arg(&config)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("spawn pt-daemon");
    let mut r = Running {
        child,
        dir: dir.to_path_buf(),
        socket: dir.join("console.sock"),
        config,
    };
    let deadline = Instant::now() + T;
    let mut client = loop {
        if let Ok(c) = Client::connect(&r.socket, T) {
            break c;
        }
        if let Ok(Some(status)) = r.child.try_wait() {
            panic!(
                "the daemon exited ({status}) before listening:\n{}",
                r.log()
            );
        }
        assert!(
            Instant::now() < deadline,
            "no socket after 30 s:\n{}",
            r.log()
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    loop {
        let st = call(&mut client, "status", json!({}));
        if st["tactile"]["frames"].as_u64().unwrap_or(0) > 0 {
            break;
        }
        assert!(Instant::now() < deadline, "no tactile frames:\n{}", r.log());
        std::thread::sleep(Duration::from_millis(10));
    }
    (r, client)
}

impl Running {
    /// The command line against this daemon (`args`, then its socket and config): the exit
    /// code, stdout and stderr.
    pub fn cli(&self, args: &[&str]) -> (Option<i32>, String, String) {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
            .args(args)
            .arg("--socket")
            .arg(&self.socket)
            .arg("--config")
            .arg(&self.config)
            .output()
            .expect("run pulsetrack");
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).to_string(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("daemon.log")).unwrap_or_default()
    }

    pub fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    pub fn signal(&self, sig: i32) {
        // SAFETY-free: kill(1) is a process, not a libc call.
        let status = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(self.pid().to_string())
            .status()
            .expect("run kill");
        assert!(status.success());
    }

    pub fn wait(&mut self, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait().expect("wait") {
                return s;
            }
            assert!(
                Instant::now() < deadline,
                "the daemon did not exit:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// SIGTERM and wait for a clean exit.
    pub fn stop(mut self) {
        self.signal(15);
        let status = self.wait(T);
        assert!(status.success(), "exit {status}:\n{}", self.log());
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

pub fn call(c: &mut Client, verb: &str, args: Value) -> Value {
    let r = c.request(verb, args, T).expect("reply");
    assert_eq!(r["ok"], true, "{verb} refused: {r}");
    r
}

pub fn state(c: &mut Client) -> String {
    call(c, "status", json!({}))["state"]
        .as_str()
        .unwrap_or("?")
        .to_string()
}

/// Wait for an event matching `pred`, failing on a fault event (unless waited for).
pub fn wait_event(c: &mut Client, what: &str, pred: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + Duration::from_secs(300);
    loop {
        if let Some(e) = c.next_event(Duration::from_millis(500)).expect("event") {
            if pred(&e) {
                return e;
            }
            assert!(e["event"] != "fault", "fault while waiting for {what}: {e}");
        }
        assert!(Instant::now() < deadline, "no {what} within 300 s");
    }
}

pub fn wait_state(c: &mut Client, want: &str) {
    let deadline = Instant::now() + Duration::from_secs(300);
    loop {
        if state(c) == want {
            return;
        }
        assert!(Instant::now() < deadline, "never reached {want}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The scene's placements and tracked length from the daemon's status.
pub fn scene(c: &mut Client) -> ([(f64, f64); 2], Option<f64>) {
    let st = call(c, "status", json!({}));
    let s = &st["backend"]["scene"];
    let p = |i: usize| {
        (
            s["placements"][i][0].as_f64().expect("placement x"),
            s["placements"][i][1].as_f64().expect("placement z"),
        )
    };
    ([p(0), p(1)], s["tracked_length_m"].as_f64())
}

/// The located points reported until the trial's end, and the trial's `ended` event.
pub fn located_until_trial_end(c: &mut Client) -> (Vec<Value>, Value) {
    let mut located = Vec::new();
    loop {
        let e = wait_event(c, "the trial's end", |e| {
            e["event"] == "trial" && e["phase"] == "ended"
                || e["event"] == "detection" && e["kind"] == "located"
        });
        if e["event"] == "trial" {
            return (located, e);
        }
        located.push(e["point"].clone());
    }
}

/// Track `length_m` from the seeds, wait for the trial's end and stop the daemon: the points
/// streamed while tracking, the trial's end event and its recording's path.
pub fn track_to_recording(
    daemon: Running,
    c: &mut Client,
    length_m: f64,
) -> (Vec<Value>, Value, String) {
    call(c, "track", json!({ "length_m": length_m }));
    let (live, ended) = located_until_trial_end(c);
    daemon.stop();
    let file = ended["summary"]["recording"]
        .as_str()
        .expect("recording")
        .to_string();
    (live, ended, file)
}

/// Enable, move to each placement and mark it; both marks must find the pulse.
pub fn seed(c: &mut Client) {
    call(
        c,
        "subscribe",
        json!({"streams": ["state", "detections", "faults", "trials"]}),
    );
    let (placements, _) = scene(c);
    call(c, "enable", json!({}));
    for (x, z) in placements {
        call(c, "move", json!({"x_m": x, "z_m": z}));
        wait_state(c, "holding");
        call(c, "mark", json!({}));
        let e = wait_event(c, "a mark's result", |e| {
            e["event"] == "detection" && (e["kind"] == "located" || e["kind"] == "missed")
        });
        assert_eq!(e["kind"], "located", "a seed mark found no pulse: {e}");
        wait_state(c, "holding");
    }
}

/// A tmpfs of `bytes` at `at` (root only), unmounted when dropped: a disk that fills up.
pub struct SmallDisk {
    at: PathBuf,
}

impl SmallDisk {
    pub fn mount(at: &Path, bytes: u64) -> Option<SmallDisk> {
        std::fs::create_dir_all(at).expect("mount point");
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o"])
            .arg(format!("size={bytes},mode=0700"))
            .arg("tmpfs")
            .arg(at)
            .stderr(Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        ok.then(|| SmallDisk {
            at: at.to_path_buf(),
        })
    }

    /// Fill what is left of the disk with a file of zeros.
    pub fn fill(&self) {
        use std::io::Write;
        let mut f = std::fs::File::create(self.at.join("filler")).expect("filler");
        let block = vec![0u8; 4096];
        while f.write_all(&block).is_ok() {}
    }

    pub fn remount_read_only(&self) {
        let s = Command::new("mount")
            .args(["-o", "remount,ro"])
            .arg(&self.at)
            .status()
            .expect("remount");
        assert!(s.success(), "remount read-only");
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.at).status();
    }
}

/// A daemon config for `setup` whose calibration file lies on a 64 KiB tmpfs under `dir`, the
/// disk, and the file's path; `None` (saying why on stderr) where no tmpfs can be mounted.
pub fn config_with_calibration_on_small_disk(
    dir: &Path,
    setup: &Setup,
) -> Option<(PathBuf, SmallDisk, PathBuf)> {
    if !nix::unistd::geteuid().is_root() {
        eprintln!("skipped: mounting a tmpfs needs root");
        return None;
    }
    let disk = dir.join("disk");
    let Some(small) = SmallDisk::mount(&disk, 64 * 1024) else {
        eprintln!("skipped: cannot mount a tmpfs here");
        return None;
    };
    let config = write_config(dir, setup);
    let text = std::fs::read_to_string(&config).expect("config");
    let file = disk.join("calibration.ron");
    let moved = text.replace(
        &format!("{:?}", dir.join("calibration.ron").display().to_string()),
        &format!("{:?}", file.display().to_string()),
    );
    assert_ne!(
        text, moved,
        "the calibration file moved onto the small disk"
    );
    std::fs::write(&config, moved).expect("write");
    Some((config, small, file))
}

/// `value[field]` is text that contains `text` (a reason, a fault's cause).
pub fn assert_says(value: &Value, field: &str, text: &str) {
    assert!(
        value[field].as_str().unwrap_or("").contains(text),
        "{field} does not say {text:?}: {value}"
    );
}

/// A calibration that passed but could not be saved (its disk full): not applied, the disk's
/// error named, and the calibration file as it was (`before`).
pub fn assert_passed_but_not_saved(result: &Value, file: &Path, before: &[u8]) {
    assert_eq!(result["passed"], true, "{result}");
    assert_eq!(result["applied"], false, "{result}");
    assert_says(result, "reason", "No space left");
    assert_eq!(std::fs::read(file).expect("still there"), before);
}

/// `pulsetrack sim` of `scene` with `beatslide`, seeds 1 and 2, as JSON (null if it printed
/// none), with `extra` arguments (`--calibration FILE`): a calibration's effect on a track.
pub fn sim_two_trials(scene: &str, extra: &[&str]) -> Value {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args([
            "sim",
            "--scene",
            scene,
            "--tracker",
            "beatslide",
            "--trials",
            "2",
            "--seed",
            "1",
            "--json",
        ])
        .args(extra)
        .output()
        .expect("sim");
    serde_json::from_slice(&out.stdout).unwrap_or(Value::Null)
}

/// Wait for a calibration procedure's end (`done` or `failed`).
pub fn wait_calibration_end(c: &mut Client, procedure: &str) -> Value {
    wait_event(c, &format!("the {procedure} calibration's end"), |e| {
        e["event"] == "calibration"
            && e["procedure"] == procedure
            && (e["phase"] == "done" || e["phase"] == "failed")
    })
}

/// Send a `calibrate` request (`args` name the procedure) and wait for its end.
pub fn calibrate_and_wait(c: &mut Client, args: Value) -> Value {
    let procedure = args["procedure"].as_str().unwrap_or("?").to_string();
    let r = call(c, "calibrate", args);
    assert_eq!(r["procedure"], procedure.as_str(), "{r}");
    wait_calibration_end(c, &procedure)
}

/// A JSON number, NaN if it is not one (a comparison with it then fails, naming the value).
pub fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// A calibration record that did not pass (`fail` marks it so) stops the daemon's start
/// with `config` (exit 2), naming the file and `names`; the file is put back as it was.
pub fn failed_record_stops_the_start(
    config: &Path,
    file: &Path,
    fail: impl FnOnce(&mut config::calibration_file::CalibrationFile),
    names: &str,
) {
    let before = std::fs::read(file).expect("the calibration file");
    let mut failed = config::calibration_file::load(file)
        .expect("loads")
        .expect("there")
        .value;
    fail(&mut failed);
    config::calibration_file::save(file, &failed).expect("saved");
    let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(config)
        .output()
        .expect("daemon");
    std::fs::write(file, before).expect("put back");
    assert_eq!(out.status.code(), Some(2), "a failed record: {out:?}");
    let said = String::from_utf8_lossy(&out.stderr);
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    assert!(
        said.contains(name.as_ref()) && said.contains(names),
        "{said}"
    );
}

/// The daemon started with its calibration file on a small disk, subscribed to the
/// calibration and fault streams: the daemon, its client, the disk and the file's path;
/// `None` where no small disk can be made (not root).
pub fn start_on_small_disk(
    dir: &Path,
    setup: &Setup,
) -> Option<(Running, Client, SmallDisk, PathBuf)> {
    let (config, small, path) = config_with_calibration_on_small_disk(dir, setup)?;
    let (daemon, mut c) = start_with_config(dir, config);
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["calibration", "faults"]}),
    );
    Some((daemon, c, small, path))
}

/// The pivot procedure's unweighted bench with a `joints` block (`joints_ron`, the scene's
/// `joints: (...)` line) for the joints procedures, written into `dir` as `name`; its path.
pub fn unweighted_bench_with_joints(dir: &Path, name: &str, joints_ron: &str) -> String {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../config/scenes/pivot-off-arc-145-unweighted.ron"),
    )
    .expect("shipped scene");
    let end = text.rfind(')').expect("the scene's closing bracket");
    let scene = format!("{}    {joints_ron}\n{}", &text[..end], &text[end..]);
    let path = dir.join(name);
    std::fs::write(&path, scene).expect("write scene");
    path.display().to_string()
}
