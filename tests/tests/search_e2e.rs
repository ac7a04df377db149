//! The autonomous search through the real daemon on the simulated bench (issue 17): a
//! region around the artery is searched and found, every look inside it; an artery-free
//! region ends "not found" at rest; `estop` mid-search latches a fault with the search
//! ended; hostile requests are refused naming the argument; and `pulsetrack search
//! --then-track` seeds a track from what it found and follows it.

mod e2e;

use e2e::{Setup, T, call, scene, start, wait_event, wait_state};
use serde_json::{Value, json};

fn region(cx: f64, cz: f64, half: f64) -> Value {
    json!({"x0_m": cx - half, "z0_m": cz - half, "x1_m": cx + half, "z1_m": cz + half})
}

fn inside(e: &Value, r: &Value) -> bool {
    let (x, z) = (
        e["at"]["x_m"].as_f64().unwrap_or(f64::NAN),
        e["at"]["z_m"].as_f64().unwrap_or(f64::NAN),
    );
    let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    // The look's place is where the sensor rested (the arm's load's reading): a compliant
    // rod may leave it a hair outside a look asked for at the edge margin.
    let slack = 1e-3;
    (f("x0_m") - slack..=f("x1_m") + slack).contains(&x)
        && (f("z0_m") - slack..=f("z1_m") + slack).contains(&z)
}

#[test]
fn a_region_around_the_artery_is_searched_and_found_inside_it() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    let ([_, (x2, z2)], _) = scene(&mut c);
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["search", "faults", "state"]}),
    );
    // Refused before power, and hostile arguments named.
    let r = c
        .request("search", region(x2, z2, 0.015), T)
        .expect("reply");
    assert_eq!(r["error"], "wrong_state", "{r}");
    call(&mut c, "enable", json!({}));
    for (args, needle) in [
        (json!({"x0_m": 0.0, "z0_m": 0.0, "x1_m": 0.02}), "z1_m"),
        (
            json!({"x0_m": 0.0, "z0_m": 0.0, "x1_m": 0.0005, "z1_m": 0.02}),
            "along x",
        ),
        (
            json!({"x0_m": "a", "z0_m": 0.0, "x1_m": 0.02, "z1_m": 0.02}),
            "x0_m",
        ),
        (
            json!({"x0_m": 0.0, "z0_m": 0.0, "x1_m": 0.02, "z1_m": 0.02, "method": "guess"}),
            "guess",
        ),
        (
            json!({"x0_m": 0.0, "z0_m": 0.0, "x1_m": 0.02, "z1_m": 0.02, "extra": 1}),
            "extra",
        ),
        (
            json!({"x0_m": 0.0, "z0_m": 0.0, "x1_m": 0.02, "z1_m": 0.02, "heading_rad": 2.0}),
            "heading_rad",
        ),
    ] {
        let r = c.request("search", args, T).expect("reply");
        assert_eq!(r["ok"], false, "{r}");
        assert!(
            r["reason"].as_str().unwrap_or("").contains(needle),
            "{needle}: {r}"
        );
    }
    let r = region(x2, z2, 0.015);
    call(&mut c, "search", r.clone());
    assert_eq!(e2e::state(&mut c), "searching");
    // Nothing else moves the arm meanwhile.
    let m = c.request("mark", json!({}), T).expect("reply");
    assert_eq!(m["error"], "wrong_state", "{m}");
    let mut looks = 0;
    let end = loop {
        let e = wait_event(&mut c, "a search event", |e| e["event"] == "search");
        match e["kind"].as_str() {
            Some("look") => {
                looks += 1;
                assert!(inside(&e, &r), "look outside the region: {e}");
            }
            Some("finished") => break e,
            _ => {}
        }
    };
    assert_eq!(end["outcome"], "found", "{end}");
    assert_eq!(end["looks"], looks);
    // Both seeds lie near the artery's course through the second placement: within the
    // region, on the artery's side of it.
    for s in end["seeds"].as_array().expect("seeds") {
        let p = &s["point"];
        let (x, z) = (p["x_m"].as_f64().expect("x"), p["z_m"].as_f64().expect("z"));
        assert!((x - x2).abs() <= 0.0151 && (z - z2).abs() <= 0.025, "{s}");
    }
    wait_state(&mut c, "holding");
    daemon.stop();
    // The search has its own recording: the frames it felt, its events, its map; and its
    // outcome beside it.
    let trials = dir.path().join("trials");
    let mcap = std::fs::read_dir(&trials)
        .expect("recording dir")
        .flatten()
        .map(|e| e.path())
        .find(|p| {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            name.is_some_and(|n| n.starts_with("search-") && n.ends_with(".mcap"))
        })
        .expect("a search recording");
    let summary: Value = serde_json::from_slice(
        &std::fs::read(mcap.with_extension("json")).expect("the search's summary"),
    )
    .expect("summary JSON");
    assert_eq!(summary["outcome"]["outcome"], "found", "{summary}");
    let bytes = std::fs::read(&mcap).expect("read the recording");
    let (mut frames, mut maps, mut finished) = (0, 0, 0);
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("message");
        let v: Value = serde_json::from_slice(&m.data).expect("JSON message");
        match m.channel.topic.as_str() {
            "/tactile" => frames += 1,
            "/artery" => {
                let entities = v["entities"].as_array().cloned().unwrap_or_default();
                maps += entities.iter().filter(|e| e["id"] == "search_map").count();
            }
            "/events" if v["event"] == "search" && v["kind"] == "finished" => finished += 1,
            _ => {}
        }
    }
    assert!(frames > 100, "{frames} tactile frames");
    assert_eq!(maps, looks as usize, "one map per look");
    assert_eq!(finished, 1);
    // Replay replays trials: a search's file is refused with the reason.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .arg("replay")
        .arg(&mcap)
        .output()
        .expect("run pulsetrack replay");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("a search's own recording"), "{err}");
}

#[test]
fn an_empty_region_ends_not_found_at_rest_and_estop_ends_a_search() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    let ([(x1, z1), _], _) = scene(&mut c);
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["search", "faults", "state"]}),
    );
    call(&mut c, "enable", json!({}));
    // 45 mm to the side the arc does not bend to: nothing pulses there.
    call(&mut c, "search", region(x1, z1 + 0.045, 0.012));
    let end = wait_event(&mut c, "the search's end", |e| {
        e["event"] == "search" && e["kind"] == "finished"
    });
    assert_eq!(end["outcome"], "not_found", "{end}");
    assert_eq!(end["reason"], "nothing_pulses", "{end}");
    assert!(
        end["weakest_felt_n"]
            .as_f64()
            .is_some_and(|w| w > 0.0 && w < 0.05)
    );
    wait_state(&mut c, "holding");
    // Again, and an estop in the middle: a fault, and the search ended as stopped.
    call(&mut c, "search", region(x1, z1 + 0.045, 0.012));
    wait_event(&mut c, "a look", |e| {
        e["event"] == "search" && e["kind"] == "look"
    });
    call(&mut c, "estop", json!({}));
    // The search's end comes before the fault it ended for.
    let end = loop {
        let e = c
            .next_event(std::time::Duration::from_secs(30))
            .expect("event")
            .expect("an event within 30 s");
        if e["event"] == "search" && e["kind"] == "finished" {
            break e;
        }
        assert_ne!(
            e["event"], "fault",
            "the fault came before the search's end"
        );
    };
    assert_eq!(end["outcome"], "stopped", "{end}");
    wait_event(&mut c, "the estop's fault", |e| e["event"] == "fault");
    wait_state(&mut c, "fault");
    // And after reset a search starts again with no restart.
    call(&mut c, "reset", json!({}));
    call(&mut c, "enable", json!({}));
    call(&mut c, "search", region(x1, z1 + 0.045, 0.012));
    call(&mut c, "stop", json!({}));
    let end = wait_event(&mut c, "the search's end", |e| {
        e["event"] == "search" && e["kind"] == "finished"
    });
    assert_eq!(end["outcome"], "stopped", "{end}");
    wait_state(&mut c, "holding");
    daemon.stop();
}

#[test]
fn the_command_line_searches_then_tracks() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    let ([_, (x2, z2)], _) = scene(&mut c);
    call(&mut c, "enable", json!({}));
    let mm = |v: f64| format!("{:.1}", v * 1e3);
    let region = format!(
        "{},{},{},{}",
        mm(x2 - 0.015),
        mm(z2 - 0.015),
        mm(x2 + 0.015),
        mm(z2 + 0.015)
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args([
            "search",
            "--region",
            &region,
            "--then-track",
            "--length-mm",
            "40",
        ])
        .arg("--socket")
        .arg(&daemon.socket)
        .arg("--config")
        .arg(&daemon.config)
        .output()
        .expect("run pulsetrack search");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    );
    assert!(
        stdout.contains("search found the artery"),
        "{stdout}{stderr}"
    );
    assert!(stdout.contains("located seed"), "{stdout}{stderr}");
    // The shipped sim config's tracker (the seed's) follows 40 mm of the 220 mm arc.
    assert_eq!(out.status.code(), Some(0), "{stdout}{stderr}");
    // A region the daemon refuses exits 1, naming why.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["search", "--region", "0,0,0.1,20"])
        .arg("--socket")
        .arg(&daemon.socket)
        .arg("--config")
        .arg(&daemon.config)
        .output()
        .expect("run pulsetrack search");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("along x"));
    daemon.stop();
}

/// `pulsetrack demo --search`: the whole 24 cm of the seed's 145 mm arc, tracked from the two
/// points a search of a 40 mm region around the first placement found, through the daemon.
#[test]
fn the_demo_searches_then_tracks_the_whole_artery() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args([
            "demo",
            "--search",
            "--tracker",
            "beatslide",
            "--time-scale",
            "200",
            "--json",
        ])
        .arg("--out")
        .arg(dir.path())
        .output()
        .expect("run pulsetrack demo --search");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    );
    assert!(stderr.contains("search found the artery"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stdout}{stderr}");
    let summary: Value = serde_json::from_str(stdout.trim()).expect("the summary");
    assert_eq!(summary["completed"], true, "{summary}");
}

/// A search is recorded as a trial is: refused where the disk has no room, and ended with
/// `recording_failed` latched when the disk fills up under it.
#[test]
fn a_search_on_a_full_disk_ends_with_recording_failed_and_the_next_is_refused() {
    if !nix::unistd::geteuid().is_root() {
        eprintln!("skipped: mounting a tmpfs needs root");
        return;
    }
    let dir = tempfile::tempdir().expect("tmp");
    let trials = dir.path().join("trials");
    let Some(disk) = e2e::SmallDisk::mount(&trials, 256 * 1024) else {
        eprintln!("skipped: cannot mount a tmpfs here");
        return;
    };
    let config = e2e::write_config(dir.path(), &Setup::default());
    let text = std::fs::read_to_string(&config).expect("config");
    let dir_line = format!("dir: {:?},", trials.display().to_string());
    let lowered = text.replacen(
        &dir_line,
        &format!("{dir_line}\n        min_free_bytes: 65536,"),
        1,
    );
    assert_ne!(text, lowered, "the config names the recording folder");
    std::fs::write(&config, lowered).expect("write");
    let (daemon, mut c) = e2e::start_with_config(dir.path(), config);
    let ([_, (x2, z2)], _) = scene(&mut c);
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["search", "faults", "state"]}),
    );
    call(&mut c, "enable", json!({}));
    // Room for the file's start, not for the search. Its end cannot be recorded, so it is
    // not published either (what is said is recorded): the fault says it, naming the disk's
    // error, and the search is over.
    let r = region(x2, z2, 0.015);
    call(&mut c, "search", r.clone());
    disk.fill();
    let fault = wait_event(&mut c, "the recording_failed fault", |e| {
        e["event"] == "fault"
    });
    assert_eq!(fault["fault"], "recording_failed", "{fault}");
    e2e::assert_says(&fault, "reason", "No space left on device");
    wait_state(&mut c, "fault");
    // After a reset, with the disk still full, the next search is refused, naming why.
    call(&mut c, "reset", json!({}));
    call(&mut c, "enable", json!({}));
    let again = c.request("search", r, T).expect("reply");
    assert_eq!(again["ok"], false, "{again}");
    e2e::assert_says(&again, "reason", "recording.min_free_bytes");
    daemon.stop();
}
