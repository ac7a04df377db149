//! A trial recorded by the real daemon on the simulated bench, read back with the `mcap`
//! crate alone: zstd-compressed chunks, Unix-epoch log and publish times, the resolved
//! configuration, scene, build and host in metadata, schemas derived from the message types
//! (and Foxglove's well-known ones where they fit), the label, and every acknowledged request,
//! reply and located point.

mod e2e;

use std::collections::{BTreeMap, BTreeSet};
use std::time::{SystemTime, UNIX_EPOCH};

use e2e::{Setup, call, located_until_trial_end, seed, start};
use serde_json::{Value, json};

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

#[test]
fn a_trial_file_is_compressed_epoch_stamped_self_describing_and_complete() {
    let dir = tempfile::tempdir().expect("tmp");
    let wall_before = now_ns();
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    seed(&mut c);
    let label = "specimen 7, left radial, 2 N preload";
    let r = call(&mut c, "track", json!({"length_m": 0.03, "label": label}));
    let track_id = r["id"].as_u64().expect("id");
    let (located, ended) = located_until_trial_end(&mut c);
    let summary = &ended["summary"];
    assert_eq!(summary["label"], label, "{summary}");
    let config_path = daemon.config.clone();
    daemon.stop();
    let wall_after = now_ns();

    let path = summary["recording"].as_str().expect("recording path");
    let bytes = std::fs::read(path).expect("read the trial file");
    let written: Value = serde_json::from_slice(
        &std::fs::read(std::path::Path::new(path).with_extension("json")).expect("summary file"),
    )
    .expect("summary json");
    assert_eq!(written["label"], label);

    // Every chunk is zstd-compressed, and compression pays.
    let mut chunks = 0;
    let (mut compressed, mut uncompressed) = (0u64, 0u64);
    for r in mcap::read::LinearReader::new(&bytes).expect("linear reader") {
        if let mcap::records::Record::Chunk { header, .. } = r.expect("record") {
            assert_eq!(header.compression, "zstd");
            chunks += 1;
            compressed += header.compressed_size;
            uncompressed += header.uncompressed_size;
        }
    }
    assert!(chunks > 0);
    assert!(
        compressed * 2 < uncompressed,
        "zstd should at least halve JSON: {compressed} of {uncompressed} bytes"
    );
    eprintln!(
        "{chunks} chunks, {compressed} bytes compressed from {uncompressed} ({:.1}x)",
        uncompressed as f64 / compressed as f64
    );

    // Metadata: the trial with its label, the resolved config, the scene, build and host.
    let summary_rec = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("indexed");
    let mut meta: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    for index in &summary_rec.metadata_indexes {
        let m = mcap::read::metadata(&bytes, index).expect("metadata");
        meta.insert(m.name, m.metadata);
    }
    for name in ["trial", "config", "scene", "build", "host", "label"] {
        assert!(
            meta.contains_key(name),
            "no {name} metadata: {:?}",
            meta.keys()
        );
    }
    assert_eq!(meta["label"]["label"], label);
    assert_eq!(meta["trial"]["tracker"], "seed2002");
    let resolved: Value = serde_json::from_str(&meta["config"]["json"]).expect("config json");
    let on_disk: config::Config = config::load_file(&config_path).expect("config").value;
    assert_eq!(
        resolved,
        serde_json::to_value(&on_disk).expect("config as json")
    );
    assert!(resolved["tracker"]["params"]["seed2002"].is_object());
    let scene: Value = serde_json::from_str(&meta["scene"]["json"]).expect("scene json");
    assert_eq!(scene["name"], "seed-arc-220");
    assert!(!meta["build"]["version"].is_empty() && !meta["build"]["commit"].is_empty());
    assert!(!meta["host"]["hostname"].is_empty());

    // Schemas: JSON Schema for every channel, Foxglove's names where they fit.
    let mut schema_of = BTreeMap::new();
    for ch in summary_rec.channels.values() {
        let s = ch.schema.as_ref().expect("every channel has a schema");
        assert_eq!(s.encoding, "jsonschema");
        assert_eq!(ch.message_encoding, "json");
        let v: Value = serde_json::from_slice(&s.data).expect("schema is JSON");
        assert_eq!(v["title"], s.name.as_str());
        schema_of.insert(ch.topic.clone(), s.name.clone());
    }
    assert_eq!(schema_of["/log"], "foxglove.Log");
    assert_eq!(schema_of["/sensor/believed"], "foxglove.PoseInFrame");
    assert_eq!(schema_of["/sensor/true"], "foxglove.PoseInFrame");
    assert_eq!(schema_of["/artery"], "foxglove.SceneUpdate");
    assert_eq!(schema_of["/tf"], "foxglove.FrameTransforms");

    // Times are Unix-epoch nanoseconds within the test's wall-clock span.
    let mut by_topic: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    let mut n = 0;
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        assert!(
            (wall_before..=wall_after + 60_000_000_000).contains(&m.log_time),
            "{} log time {} not within the test's wall time {wall_before}..{wall_after}",
            m.channel.topic,
            m.log_time
        );
        assert_eq!(m.publish_time, m.log_time);
        let v: Value = serde_json::from_slice(&m.data).expect("json message");
        by_topic.entry(m.channel.topic.clone()).or_default().push(v);
        n += 1;
    }
    assert!(n > 1000);
    for topic in [
        "/joints",
        "/tactile",
        "/truth",
        "/sensor/believed",
        "/log",
        "/artery",
        "/tf",
    ] {
        assert!(by_topic.contains_key(topic), "nothing on {topic}");
    }

    // The frame tree: base -> tissue, gimbal, pivot; tissue -> sensor, where the believed
    // pose (recorded from the same sample) has the sensor.
    let poses = &by_topic["/sensor/believed"];
    let trees = &by_topic["/tf"];
    assert_eq!(trees.len(), poses.len());
    for (tree, pose) in trees.iter().zip(poses).step_by(97) {
        let frames: BTreeMap<String, &Value> = tree["transforms"]
            .as_array()
            .expect("transforms")
            .iter()
            .map(|t| (t["child_frame_id"].as_str().unwrap_or("").to_string(), t))
            .collect();
        for (child, parent) in [
            ("tissue", "base"),
            ("gimbal", "base"),
            ("pivot", "base"),
            ("sensor", "tissue"),
        ] {
            assert_eq!(frames[child]["parent_frame_id"], parent, "{tree}");
        }
        assert_eq!(frames["sensor"]["timestamp"], pose["timestamp"]);
        for axis in ["x", "z"] {
            let a = frames["sensor"]["translation"][axis].as_f64().expect("t");
            let b = pose["pose"]["position"][axis].as_f64().expect("p");
            assert!((a - b).abs() < 1e-12, "{axis}: tf {a} pose {b}");
        }
    }

    // Every acknowledged request is there with its structured arguments and the client's
    // uid, and so is its reply.
    let uid = nix::unistd::geteuid().as_raw();
    let events = &by_topic["/events"];
    let verb = events
        .iter()
        .find(|e| e["event"] == "verb" && e["id"] == track_id)
        .expect("the track request is recorded");
    assert_eq!(verb["verb"], "track");
    assert_eq!(verb["args"], json!({"length_m": 0.03, "label": label}));
    assert_eq!(verb["client"]["uid"], uid);
    let reply = events
        .iter()
        .find(|e| e["event"] == "reply" && e["id"] == track_id)
        .expect("the track reply is recorded");
    assert_eq!(reply["reply"]["ok"], true);
    assert_eq!(reply["client"]["uid"], uid);
    let marks = events
        .iter()
        .filter(|e| e["event"] == "verb" && e["verb"] == "mark")
        .count();
    assert_eq!(marks, 2);
    assert!(
        events
            .iter()
            .all(|e| e["event"] != "verb" || e["args"].is_object()),
        "arguments are JSON objects, not debug strings"
    );

    // Every located point the console was told of is recorded.
    let recorded: BTreeSet<String> = events
        .iter()
        .filter(|e| e["kind"] == "located")
        .map(|e| e["point"].to_string())
        .collect();
    assert!(!located.is_empty());
    for p in &located {
        assert!(recorded.contains(&p.to_string()), "{p} not recorded");
    }
    let spheres = by_topic["/artery"]
        .iter()
        .filter_map(|u| {
            u["entities"]
                .as_array()?
                .iter()
                .find(|e| e["id"] == "located")
                .map(|e| e["spheres"].as_array().map(Vec::len).unwrap_or(0))
        })
        .max()
        .unwrap_or(0);
    assert_eq!(
        spheres,
        recorded.len(),
        "the scene shows every located point"
    );
}
