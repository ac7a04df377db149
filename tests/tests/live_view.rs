//! The live view as an independent viewer sees it: a Foxglove WebSocket client written from
//! the protocol's specification (`pulsetrack_tests::foxglove_ws`, not the SDK the daemon
//! serves it with) connects to the real daemon on the simulated bench, subscribes, and checks
//! what arrives against what the daemon says on its console. No wall-clock timing is asserted
//! (a shared, noisy machine): rates are judged in the daemon's own clock and counts loosely.

mod e2e;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use e2e::{
    Setup, T, call, located_until_trial_end, seed, start, start_with_config, wait_state,
    write_config,
};
use pulsetrack_tests::foxglove_ws::{FoxgloveClient, LIVE_TOPICS as ALL_TOPICS, Received};
use serde_json::{Value, json};

fn live_url(c: &mut daemon::console::client::Client) -> String {
    let st = call(c, "status", json!({}));
    assert_eq!(st["live"]["enabled"], true, "{}", st["live"]);
    st["live"]["url"].as_str().expect("live url").to_string()
}

fn on<'a>(msgs: &'a [Received], topic: &'a str) -> impl Iterator<Item = Value> + 'a {
    msgs.iter()
        .filter(move |m| m.topic == topic)
        .map(Received::json)
}

/// The sensor's translation in the newest `/tf` message of `msgs`.
fn tf_sensor(msgs: &[Received]) -> Option<(f64, f64)> {
    on(msgs, "/tf").last().and_then(|tf| {
        let s = tf["transforms"]
            .as_array()?
            .iter()
            .find(|t| t["child_frame_id"] == "sensor")?
            .clone();
        assert_eq!(s["parent_frame_id"], "tissue");
        Some((
            s["translation"]["x"].as_f64()?,
            s["translation"]["z"].as_f64()?,
        ))
    })
}

#[test]
fn frames_at_the_array_rate_and_transforms_where_status_puts_the_sensor() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(
        dir.path(),
        &Setup {
            time_scale: 1.0,
            ..Setup::default()
        },
    );
    let url = live_url(&mut c);
    assert!(url.starts_with("ws://127.0.0.1:"), "{url}");
    let mut fox = FoxgloveClient::connect(&url, T).expect("connect");
    assert_eq!(fox.server_info["name"], "pulsetrackd");
    fox.wait_for_channels(&ALL_TOPICS, T).expect("advertised");
    for (topic, schema) in [
        ("/tactile", "pulsetrack.TactileFrame"),
        ("/tf", "foxglove.FrameTransforms"),
        ("/artery", "foxglove.SceneUpdate"),
        ("/log", "foxglove.Log"),
        ("/sensor/believed", "foxglove.PoseInFrame"),
    ] {
        let ch = fox.channel(topic).expect("channel");
        assert_eq!(ch.schema_name, schema, "{topic}");
        assert_eq!(ch.encoding, "json", "{topic}");
        let s: Value = serde_json::from_str(&ch.schema).expect("JSON Schema");
        assert_eq!(s["title"], schema);
    }
    call(&mut c, "enable", json!({}));
    wait_state(&mut c, "holding");
    fox.subscribe(&["/tactile", "/tf", "/tactile/bandpassed", "/state", "/loop"])
        .expect("subscribe");
    let msgs = fox.collect_for(Duration::from_secs(4)).expect("receive");

    // Tactile frames: every one from the first received to the last, 100 Hz of daemon time.
    let frames: Vec<Value> = on(&msgs, "/tactile").collect();
    assert!(frames.len() > 100, "{} frames in 4 s", frames.len());
    let seq = |v: &Value| v["seq"].as_u64().expect("seq");
    let t = |v: &Value| v["t_s"].as_f64().expect("t_s");
    let (first, last) = (&frames[0], &frames[frames.len() - 1]);
    let span = seq(last) - seq(first) + 1;
    assert!(
        frames.len() as f64 >= 0.95 * span as f64,
        "{} of {span} frames received",
        frames.len()
    );
    let rate_hz = (seq(last) - seq(first)) as f64 / (t(last) - t(first));
    assert!((90.0..=110.0).contains(&rate_hz), "{rate_hz} Hz");
    for f in &frames {
        assert_eq!(f["force_n"].as_array().map(Vec::len), Some(10), "{f}");
    }
    // The band-passed frames follow the raw ones, one per frame once the filter is full.
    let bp: Vec<Value> = on(&msgs, "/tactile/bandpassed").collect();
    assert!(
        bp.len() as f64 > 0.5 * frames.len() as f64,
        "{} band-passed of {} frames",
        bp.len(),
        frames.len()
    );
    assert!(
        bp.iter()
            .all(|b| b["delay_s"].as_f64().is_some_and(|d| d > 0.0))
    );
    // Each log time is the daemon time on one fixed epoch: the spacing agrees.
    let lt: Vec<(u64, f64)> = msgs
        .iter()
        .filter(|m| m.topic == "/tactile")
        .map(|m| (m.log_time_ns, t(&m.json())))
        .collect();
    let (a, b) = (lt[0], lt[lt.len() - 1]);
    assert!((((b.0 - a.0) as f64 * 1e-9) - (b.1 - a.1)).abs() < 1e-6);
    assert!(on(&msgs, "/state").any(|s| s["state"] == "holding"));
    assert!(on(&msgs, "/loop").any(|l| l["cycles"].as_u64().unwrap_or(0) > 0));

    // The frame tree puts the sensor where status does (the arm holds still).
    let st = call(&mut c, "status", json!({}));
    let more = fox
        .collect_for(Duration::from_millis(500))
        .expect("receive");
    let (x, z) = tf_sensor(&more).expect("a /tf with the sensor");
    let sx = st["arm"]["sensor"]["x_m"].as_f64().expect("sensor x");
    let sz = st["arm"]["sensor"]["z_m"].as_f64().expect("sensor z");
    assert!(
        (x - sx).abs() < 2e-4 && (z - sz).abs() < 2e-4,
        "tf ({x}, {z}) against status ({sx}, {sz})"
    );
    drop(fox);
    daemon.stop();
}

#[test]
fn a_demo_trial_shows_its_located_points_live_and_replays_in_the_same_view() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    let url = live_url(&mut c);
    let mut fox = FoxgloveClient::connect(&url, T).expect("connect");
    fox.wait_for_channels(&["/artery", "/log"], T)
        .expect("advertised");
    fox.subscribe(&["/artery", "/log"]).expect("subscribe");
    // The scene is sent again every second: once it arrives, the subscription is in place.
    let first = fox
        .next(T)
        .expect("read")
        .expect("an /artery message within 30 s");
    assert_eq!(first.topic, "/artery");
    seed(&mut c);
    // The two seed marks' points, as the trial's record has them so far.
    let seeds = call(&mut c, "status", json!({}))["trial"]["located"]
        .as_u64()
        .expect("located so far");
    assert_eq!(seeds, 2);
    call(&mut c, "track", json!({"length_m": 0.03}));
    let (tracked, ended) = located_until_trial_end(&mut c);
    let located: Vec<Value> = ended["summary"]["located"]
        .as_array()
        .expect("the summary's located points")
        .clone();
    assert_eq!(located.len(), tracked.len() + 2);
    assert_eq!(&located[2..], &tracked[..]);
    assert!(!tracked.is_empty(), "nothing located while tracking");
    let msgs = fox.collect_for(Duration::from_secs(2)).expect("receive");
    drop(fox);
    daemon.stop();

    // The newest "located" entity holds every point the console was told, in order.
    let spheres = |msgs: &[Received]| -> Vec<(f64, f64)> {
        on(msgs, "/artery")
            .filter_map(|u| {
                u["entities"]
                    .as_array()?
                    .iter()
                    .find(|e| e["id"] == "located")
                    .cloned()
            })
            .last()
            .map(|e| {
                e["spheres"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .map(|s| {
                        (
                            s["pose"]["position"]["x"].as_f64().unwrap_or(f64::NAN),
                            s["pose"]["position"]["z"].as_f64().unwrap_or(f64::NAN),
                        )
                    })
                    .collect()
            })
            .unwrap_or_default()
    };
    let want: Vec<(f64, f64)> = located
        .iter()
        .map(|p| {
            (
                p["x_m"].as_f64().expect("x_m"),
                p["z_m"].as_f64().expect("z_m"),
            )
        })
        .collect();
    assert_eq!(spheres(&msgs), want);
    assert!(
        on(&msgs, "/artery").any(|u| u["entities"]
            .as_array()
            .is_some_and(|e| e.iter().any(|e| e["id"] == "true_path"))),
        "no true path"
    );
    let lines: Vec<String> = on(&msgs, "/log")
        .map(|l| l["message"].as_str().unwrap_or("").to_string())
        .collect();
    assert_eq!(
        lines.iter().filter(|l| l.starts_with("located")).count(),
        located.len(),
        "{lines:?}"
    );
    assert!(lines.iter().any(|l| l.contains("ended")), "{lines:?}");

    // The recorded trial, served again on the live protocol, shows the same points.
    let file = ended["summary"]["recording"].as_str().expect("recording");
    let mut replay = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .args(["replay", file, "--live", "--port", "0", "--speed", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run pulsetrack replay --live");
    let mut out = BufReader::new(replay.stdout.take().expect("stdout"));
    let mut first = String::new();
    out.read_line(&mut first).expect("first line");
    let url = first
        .split_whitespace()
        .find(|w| w.starts_with("ws://"))
        .unwrap_or_else(|| panic!("no URL in {first:?}"))
        .to_string();
    let mut fox = FoxgloveClient::connect(&url, T).expect("connect to the replay");
    fox.wait_for_channels(&["/artery", "/tactile", "/tactile/bandpassed"], T)
        .expect("advertised");
    fox.subscribe(&["/artery", "/tactile", "/tactile/bandpassed"])
        .expect("subscribe");
    let mut got = Vec::new();
    // Until the replay ends and closes the connection (or falls silent).
    while let Ok(Some(m)) = fox.next(Duration::from_secs(30)) {
        got.push(m);
    }
    let status = replay.wait().expect("replay exits");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).expect("stdout");
    assert!(status.success(), "{first}{rest}");
    assert!(rest.contains("replayed"), "{rest}");
    assert_eq!(spheres(&got), want);
    let back = daemon::recording::recover::read(std::path::Path::new(file)).expect("read");
    let recorded = back.on(daemon::recording::topics::Topic::Tactile).count();
    let replayed = got.iter().filter(|m| m.topic == "/tactile").count();
    assert!(
        replayed as f64 >= 0.8 * recorded as f64,
        "{replayed} of {recorded} frames"
    );
    assert!(got.iter().any(|m| m.topic == "/tactile/bandpassed"));
    // On the recording's own timeline: the same log times as in the file.
    let first_recorded = back
        .on(daemon::recording::topics::Topic::Tactile)
        .map(|m| m.log_time_ns)
        .min();
    let first_replayed = got
        .iter()
        .filter(|m| m.topic == "/tactile")
        .map(|m| m.log_time_ns)
        .min();
    assert!(first_replayed >= first_recorded);
}

/// The newest entity called `id` in the `/artery` messages of `msgs`.
fn newest_entity(msgs: &[Received], id: &str) -> Option<Value> {
    on(msgs, "/artery")
        .filter_map(|u| {
            u["entities"]
                .as_array()?
                .iter()
                .find(|e| e["id"] == id)
                .cloned()
        })
        .last()
}

#[test]
fn a_beatslide_trial_shows_how_sure_each_point_is_the_course_ahead_the_beats_and_the_daemons_log() {
    let dir = tempfile::tempdir().expect("tmp");
    let config = write_config(dir.path(), &Setup::default());
    let text = std::fs::read_to_string(&config).expect("config");
    let beatslide = text.replace("name: \"seed2002\",", "name: \"beatslide\",");
    assert_ne!(
        text, beatslide,
        "the shipped sim config no longer names seed2002"
    );
    std::fs::write(&config, beatslide).expect("write config");
    let (daemon, mut c) = start_with_config(dir.path(), config);
    let url = live_url(&mut c);
    let mut fox = FoxgloveClient::connect(&url, T).expect("connect");
    let topics = ["/artery", "/log", "/pulse"];
    fox.wait_for_channels(&topics, T).expect("advertised");
    fox.subscribe(&topics).expect("subscribe");
    let first = fox.next(T).expect("read").expect("a message within 30 s");
    assert!(topics.contains(&first.topic.as_str()), "{}", first.topic);
    seed(&mut c);
    call(&mut c, "track", json!({"length_m": 0.03}));
    // Keep reading while it tracks: the course ahead is cleared once tracking ends.
    let mut msgs = vec![first];
    let mut ended = None;
    let deadline = std::time::Instant::now() + Duration::from_secs(240);
    while ended.is_none() && std::time::Instant::now() < deadline {
        msgs.extend(
            fox.collect_for(Duration::from_millis(500))
                .expect("receive"),
        );
        let st = call(&mut c, "status", json!({}));
        if st["state"] == "done" || st["state"] == "holding" {
            ended = Some(st);
        }
    }
    assert!(ended.is_some(), "the trial did not end");
    msgs.extend(fox.collect_for(Duration::from_secs(2)).expect("receive"));
    drop(fox);
    let trials = std::fs::read_dir(dir.path().join("trials"))
        .expect("trials")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "mcap"))
        .expect("a trial recording");
    daemon.stop();

    // Every located point carries its SD, and is drawn on a disc of radius two SDs.
    let back = daemon::recording::recover::read(&trials).expect("read the recording");
    let sds: Vec<f64> = back
        .on(daemon::recording::topics::Topic::Events)
        .filter_map(|m| serde_json::from_slice::<Value>(&m.data).ok())
        .filter(|e| e["kind"] == "located")
        .map(|e| {
            e["point"]["sd_m"]
                .as_f64()
                .expect("beatslide records an SD")
        })
        .collect();
    assert!(sds.len() >= 3, "{sds:?}");
    assert!(sds.iter().all(|sd| *sd > 0.0 && *sd < 0.01), "{sds:?}");
    let located = newest_entity(&msgs, "located").expect("located points");
    let discs: Vec<f64> = located["spheres"]
        .as_array()
        .expect("spheres")
        .iter()
        .filter(|s| s["color"]["a"].as_f64() < Some(1.0))
        .map(|s| s["size"]["x"].as_f64().unwrap_or(f64::NAN))
        .collect();
    assert_eq!(discs.len(), sds.len(), "{located}");
    for (d, sd) in discs.iter().zip(&sds) {
        assert!((d - 4.0 * sd).abs() < 1e-12, "disc {d} for SD {sd}");
    }

    // While tracking, the course ahead: its centre line and the band of two SDs either side.
    let ahead = on(&msgs, "/artery")
        .filter_map(|u| {
            u["entities"]
                .as_array()?
                .iter()
                .find(|e| e["id"] == "ahead" && e["lines"].as_array().is_some_and(|l| l.len() == 3))
                .cloned()
        })
        .last()
        .expect("a course ahead with its band while tracking");
    let point = |l: &Value, i: usize| {
        let p = &l["points"][i];
        (
            p["x"].as_f64().unwrap_or(f64::NAN),
            p["z"].as_f64().unwrap_or(f64::NAN),
        )
    };
    let n = ahead["lines"][0]["points"].as_array().map_or(0, Vec::len);
    assert!(n >= 3, "{ahead}");
    let centre = point(&ahead["lines"][0], 0);
    let (left, right) = (point(&ahead["lines"][1], 0), point(&ahead["lines"][2], 0));
    let half_width = |e: (f64, f64)| (e.0 - centre.0).hypot(e.1 - centre.1);
    assert!(half_width(left) > 0.0 && (half_width(left) - half_width(right)).abs() < 1e-9);
    // The far end is less certain than the near one.
    let far = |k: usize| {
        let (c, e) = (
            point(&ahead["lines"][0], n - 1),
            point(&ahead["lines"][k], n - 1),
        );
        (e.0 - c.0).hypot(e.1 - c.1)
    };
    assert!(far(1) > half_width(left), "{ahead}");

    // Beats on /pulse, about a period apart once the tracker has reported one.
    let mut spaced = 0;
    for p in on(&msgs, "/pulse") {
        let (Some(period), Some(beats)) = (p["period_s"].as_f64(), p["beat_times_s"].as_array())
        else {
            continue;
        };
        let beats: Vec<f64> = beats.iter().filter_map(Value::as_f64).collect();
        for pair in beats.windows(2) {
            let ratio = (pair[1] - pair[0]) / period;
            assert!(
                (0.6..1.6).contains(&ratio),
                "beats {beats:?}, period {period}"
            );
            spaced += 1;
        }
    }
    assert!(spaced > 0, "no two beats in any /pulse message");

    // The daemon's own log lines reach /log with where they were logged, and the lines the
    // supervisor writes there itself come once.
    let logs: Vec<Value> = on(&msgs, "/log").collect();
    assert!(
        logs.iter().any(|l| l["message"]
            .as_str()
            .is_some_and(|m| m.starts_with("recording trial to"))
            && l["name"].as_str().is_some_and(|n| n.contains("recorder"))
            && l["file"].as_str().is_some_and(|f| f.ends_with(".rs"))),
        "{logs:?}"
    );
    let state_lines = logs
        .iter()
        .filter(|l| l["message"] == "state holding -> seeding")
        .count();
    assert_eq!(state_lines, 2, "one per mark: {logs:?}");
}

#[test]
fn a_subscriber_that_never_reads_does_not_hold_the_daemon_up() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    let url = live_url(&mut c);
    // Subscribes to everything (at 40x real time: thousands of messages a second), then
    // never reads again: the kernel's buffers fill and the server's backlog for it drops.
    let mut stalled = FoxgloveClient::connect(&url, T).expect("connect");
    stalled
        .wait_for_channels(&ALL_TOPICS, T)
        .expect("advertised");
    stalled.subscribe(&ALL_TOPICS).expect("subscribe");
    let before = call(&mut c, "status", json!({}));
    call(&mut c, "enable", json!({}));
    std::thread::sleep(Duration::from_secs(6));
    let after = call(&mut c, "status", json!({}));
    // The supervisor kept up with the loop: every frame the array sent was taken in.
    let frames = |s: &Value| s["tactile"]["frames"].as_u64().unwrap_or(0);
    let seen = |s: &Value| s["tactile"]["frames_supervised"].as_u64().unwrap_or(0);
    let new_frames = frames(&after) - frames(&before);
    assert!(new_frames > 1000, "{new_frames} frames in 6 s at 40x");
    assert!(
        (frames(&after) as f64 - seen(&after) as f64).abs() < 0.02 * frames(&after) as f64,
        "loop {} frames, supervisor {}",
        frames(&after),
        seen(&after)
    );
    assert_eq!(
        after["loop"]["dropped"], before["loop"]["dropped"],
        "the loop dropped samples"
    );
    // The live queue's drops are counted and reported.
    assert!(
        after["live"]["dropped"].as_u64().is_some(),
        "{}",
        after["live"]
    );
    // A client that does read still gets the frames meanwhile.
    let mut reader = FoxgloveClient::connect(&url, T).expect("connect");
    reader
        .wait_for_channels(&["/tactile"], T)
        .expect("advertised");
    reader.subscribe(&["/tactile"]).expect("subscribe");
    let got = reader.collect_for(Duration::from_secs(2)).expect("receive");
    assert!(got.len() > 100, "{} frames in 2 s at 40x", got.len());
    assert_eq!(e2e::state(&mut c), "holding");
    drop(reader);
    // ... and the daemon still stops cleanly with the stalled client connected.
    daemon.stop();
    drop(stalled);
}

#[test]
fn a_non_loopback_address_without_allow_remote_is_refused() {
    let dir = tempfile::tempdir().expect("tmp");
    let config = e2e::write_config(dir.path(), &Setup::default());
    let text = std::fs::read_to_string(&config).expect("config");
    let text = text.replace(
        "live: (\n        enabled: true,",
        "live: (\n        enabled: true,\n        address: \"0.0.0.0\",",
    );
    assert!(text.contains("0.0.0.0"));
    std::fs::write(&config, text).expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_pt-daemon"))
        .arg("--config")
        .arg(&config)
        .stdin(Stdio::null())
        .output()
        .expect("run pt-daemon");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("live.address"), "{err}");
    assert!(err.contains("allow_remote"), "{err}");
    assert!(!dir.path().join("console.sock").exists());
}

/// A search's map reaches the live view's 3D panel: after each look an `/artery` update with
/// a `search_map` entity (the region's outline, the looks, and tiles where the artery may
/// run), and at the end the tiles lie along the artery the search found.
#[test]
fn a_search_shows_its_map_live() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    let url = live_url(&mut c);
    let mut fox = FoxgloveClient::connect(&url, T).expect("connect");
    fox.wait_for_channels(&["/artery"], T).expect("advertised");
    fox.subscribe(&["/artery"]).expect("subscribe");
    fox.next(T).expect("read").expect("an /artery message");
    let ([_, (x2, z2)], _) = e2e::scene(&mut c);
    call(
        &mut c,
        "subscribe",
        json!({"streams": ["search", "faults"]}),
    );
    call(&mut c, "enable", json!({}));
    let h = 0.015;
    call(
        &mut c,
        "search",
        json!({"x0_m": x2 - h, "z0_m": z2 - h, "x1_m": x2 + h, "z1_m": z2 + h}),
    );
    let end = e2e::wait_event(&mut c, "the search's end", |e| {
        e["event"] == "search" && e["kind"] == "finished"
    });
    assert_eq!(end["outcome"], "found", "{end}");
    let msgs = fox.collect_for(Duration::from_secs(2)).expect("receive");
    drop(fox);
    daemon.stop();
    let maps: Vec<Value> = on(&msgs, "/artery")
        .flat_map(|u| u["entities"].as_array().cloned().unwrap_or_default())
        .filter(|e| e["id"] == "search_map")
        .collect();
    assert_eq!(
        maps.len() as u64,
        end["looks"].as_u64().expect("looks"),
        "one map per look"
    );
    let last = maps.last().expect("a map");
    assert_eq!(
        last["spheres"].as_array().map(Vec::len),
        end["looks"].as_u64().map(|n| n as usize)
    );
    let tiles = last["cubes"].as_array().expect("tiles");
    assert!(!tiles.is_empty());
    // The most opaque tiles lie on the line through the two seeds.
    let seed = |i: usize, k: &str| end["seeds"][i]["point"][k].as_f64().expect("seed");
    let (ax, az, bx, bz) = (
        seed(0, "x_m"),
        seed(0, "z_m"),
        seed(1, "x_m"),
        seed(1, "z_m"),
    );
    for t in tiles
        .iter()
        .filter(|t| t["color"]["a"].as_f64().unwrap_or(0.0) > 0.4)
    {
        let (x, z) = (
            t["pose"]["position"]["x"].as_f64().expect("x"),
            t["pose"]["position"]["z"].as_f64().expect("z"),
        );
        let on_line = az + (bz - az) * (x - ax) / (bx - ax);
        assert!(
            (z - on_line).abs() < 0.003,
            "tile ({x}, {z}) off the found line"
        );
    }
}
