//! Offline replay (`pulsetrack replay`): a trial recorded by the real daemon on the
//! simulated bench, fed back to the tracker that recorded it, reproduces every recorded
//! located point bit for bit; another tracker runs on the same data; a recording from before
//! replay existed is refused with the reason.

mod e2e;

use std::process::Command;

use e2e::{Setup, seed, start, track_to_recording};
use serde_json::Value;

fn replay(args: &[&str]) -> (bool, Value, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_pt-console"))
        .arg("replay")
        .args(args)
        .output()
        .expect("run pulsetrack replay");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let doc = serde_json::from_str(&stdout).unwrap_or(Value::Null);
    (out.status.success(), doc, stderr)
}

/// Bit-for-bit equality of two JSON numbers (serde_json writes the shortest text that reads
/// back as the same f64, and the daemon reads with `float_roundtrip`).
fn bits(v: &Value) -> Option<u64> {
    v.as_f64().map(f64::to_bits)
}

#[test]
fn a_recorded_trial_replays_bit_for_bit_through_its_own_tracker() {
    let dir = tempfile::tempdir().expect("tmp");
    let (daemon, mut c) = start(dir.path(), &Setup::default());
    seed(&mut c);
    let (live, ended, file) = track_to_recording(daemon, &mut c, 0.04);
    assert!(!live.is_empty(), "no point located while tracking");

    let (ok, doc, err) = replay(&[&file, "--tracker", "seed2002", "--json"]);
    assert!(ok, "{err}");
    assert_eq!(doc["recorded_tracker"], "seed2002");
    assert_eq!(
        doc["parameters_from"],
        "the configuration recorded in the trial"
    );
    assert_eq!(doc["missing_frames"], 0);
    assert!(
        doc["frames"].as_u64().unwrap_or(0) > 100,
        "{}",
        doc["frames"]
    );
    assert_eq!(doc["identical_to_recorded"], true, "{doc}");
    let replayed = doc["located"].as_array().expect("located");
    // Against what the console was told live, field by field, to the bit: the trial's
    // summary lists every located point (seeds too); the detections after the seeds were
    // streamed one by one.
    let summary = ended["summary"]["located"].as_array().expect("summary");
    assert_eq!(replayed.len(), summary.len(), "{doc}");
    assert_eq!(&summary[summary.len() - live.len()..], &live[..]);
    for (r, l) in replayed.iter().zip(summary) {
        for k in [
            "t_s",
            "x_m",
            "z_m",
            "sensor_x_m",
            "sensor_z_m",
            "element",
            "amplitude_n",
        ] {
            assert_eq!(bits(&r[k]), bits(&l[k]), "{k}: replayed {r}, live {l}");
            assert!(bits(&r[k]).is_some(), "{k} missing in {r}");
        }
        assert_eq!(r["seed"], l["seed"]);
    }

    // Another tracker runs on the same frames and says what it would have found.
    let (ok, doc, err) = replay(&[&file, "--tracker", "beatslide", "--json"]);
    assert!(ok, "{err}");
    assert_eq!(doc["tracker"], "beatslide");
    assert!(
        doc["located"].is_array() && doc["events"].is_array(),
        "{doc}"
    );

    // An unknown tracker is refused by name.
    let (ok, _, err) = replay(&[&file, "--tracker", "seed2003"]);
    assert!(!ok && err.contains("unknown tracker `seed2003`"), "{err}");
}

/// `beatslide` on the shipped sim config, whose `rod` section makes the daemon read where the
/// arm's load puts the sensor: the reading is recorded with each frame the tracker saw, and
/// replay feeds it back, so the points (placed with it at rest) come back to the bit.
#[test]
fn a_beatslide_trial_replays_bit_for_bit_with_the_rods_reading() {
    let dir = tempfile::tempdir().expect("tmp");
    let config = e2e::write_config(dir.path(), &Setup::default());
    let text = std::fs::read_to_string(&config).expect("config");
    assert!(
        text.contains("rod: ("),
        "the shipped sim config describes its rod"
    );
    let tracker = "name: \"seed2002\",";
    assert!(text.contains(tracker));
    std::fs::write(&config, text.replacen(tracker, "name: \"beatslide\",", 1)).expect("write");
    let (daemon, mut c) = e2e::start_with_config(dir.path(), config);
    seed(&mut c);
    let (_, ended, file) = track_to_recording(daemon, &mut c, 0.03);

    // Every frame the tracker saw carries the reading, a few mm at most from the belief.
    let bytes = std::fs::read(&file).expect("recording");
    let (mut fed, mut read) = (0, 0);
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        if m.channel.topic != "/tactile" {
            continue;
        }
        let v: Value = serde_json::from_slice(&m.data).expect("json");
        if v["tracker_settled"].is_null() {
            continue;
        }
        fed += 1;
        if let (Some(x), Some(z), Some(bx), Some(bz)) = (
            v["loaded_x_m"].as_f64(),
            v["loaded_z_m"].as_f64(),
            v["sensor_x_m"].as_f64(),
            v["sensor_z_m"].as_f64(),
        ) {
            read += 1;
            assert!((x - bx).hypot(z - bz) < 0.01, "{v}");
        }
    }
    assert!(fed > 100 && read == fed, "{read} of {fed} frames read");

    let (ok, doc, err) = replay(&[&file, "--tracker", "beatslide", "--json"]);
    assert!(ok, "{err}");
    assert_eq!(doc["recorded_tracker"], "beatslide");
    assert_eq!(doc["identical_to_recorded"], true, "{doc}");
    let summary = ended["summary"]["located"].as_array().expect("summary");
    let replayed = doc["located"].as_array().expect("located");
    assert_eq!(replayed.len(), summary.len(), "{doc}");
    for (r, l) in replayed.iter().zip(summary) {
        for k in ["x_m", "z_m", "sensor_x_m", "sensor_z_m"] {
            assert_eq!(bits(&r[k]), bits(&l[k]), "{k}: replayed {r}, live {l}");
        }
    }
}

#[test]
fn a_recording_from_before_replay_is_refused_with_the_reason() {
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../daemon/tests/fixtures/v0-trial.mcap"
    );
    let (ok, _, err) = replay(&[fixture, "--tracker", "seed2002"]);
    assert!(!ok);
    assert!(
        err.contains("v0-trial.mcap") && err.contains("no tracker inputs"),
        "{err}"
    );
    let (ok, _, err) = replay(&["/nonexistent/trial.mcap", "--tracker", "seed2002"]);
    assert!(!ok && err.contains("/nonexistent/trial.mcap"), "{err}");
}
