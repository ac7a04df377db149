//! Seed recordings for the `recording_reader` target, written with the daemon's own
//! `TrialFile` so that the fuzzer starts from real MCAP: a complete trial, one cut short after
//! its last flushed chunk (a kill -9), the same cut inside a chunk, and an empty one. Run by
//! the target itself (it shares the fuzz build; a separate example would rebuild the daemon
//! without the fuzzer's flags):
//!
//!     cd fuzz && PULSETRACK_FUZZ_WRITE_SEEDS=seeds/recording_reader \
//!         cargo +nightly fuzz run -s none recording_reader -- -runs=0
//!
//! Each file is a few KiB (the four channel schemas are most of it).

use std::collections::BTreeMap;
use std::path::Path;

use daemon::recording::topics::Topic;
use daemon::recording::trial_file::TrialFile;

pub fn write_seeds(out: &Path) {
    std::fs::create_dir_all(out).expect("seed directory");
    let scratch = std::env::temp_dir().join(format!("pulsetrack-seeds-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).expect("scratch directory");

    let complete = write(&scratch.join("complete.mcap"), 12, true);
    std::fs::write(out.join("complete.mcap"), &complete).expect("write seed");

    let cut = write(&scratch.join("cut.mcap"), 12, false);
    std::fs::write(out.join("killed.mcap"), &cut).expect("write seed");
    // Cut in the middle of the last chunk: recovery keeps the chunks before it.
    std::fs::write(out.join("cut_in_chunk.mcap"), &cut[..cut.len() - 40]).expect("write seed");

    let empty = write(&scratch.join("empty.mcap"), 0, true);
    std::fs::write(out.join("empty.mcap"), &empty).expect("write seed");

    std::fs::remove_dir_all(&scratch).expect("remove scratch");
    for f in ["complete", "killed", "cut_in_chunk", "empty"] {
        let p = out.join(format!("{f}.mcap"));
        let len = std::fs::metadata(&p).expect("seed").len();
        println!("{} {len} bytes", p.display());
    }
}

/// A trial with `n` messages on every topic, flushed every 4 rounds; finished, or abandoned
/// as a kill -9 leaves it.
fn write(path: &Path, n: usize, finish: bool) -> Vec<u8> {
    let mut meta = BTreeMap::new();
    meta.insert("trial".to_string(), "seed".to_string());
    let mut f = TrialFile::create(path, &meta).expect("create");
    for i in 0..n {
        let t = i as f64 * 0.01;
        let tactile = serde_json::json!({"t_s": t, "seq": i, "force_n": vec![0.1; 10]});
        f.write(Topic::Tactile, t, tactile.to_string().as_bytes())
            .expect("write");
        let joints = serde_json::json!({"t_s": t, "q_rad": [0.0, 0.1, 0.2]});
        f.write(Topic::Joints, t, joints.to_string().as_bytes())
            .expect("write");
        if i % 4 == 0 {
            let event = serde_json::json!({"t_s": t, "event": "state", "state": "tracking"});
            f.write(Topic::Events, t, event.to_string().as_bytes())
                .expect("write");
        }
        if i % 4 == 3 {
            f.flush().expect("flush");
        }
    }
    if finish {
        f.finish().expect("finish");
    } else {
        f.flush().expect("flush");
        // As a kill -9 leaves it: never finished.
        std::mem::forget(f);
    }
    std::fs::read(path).expect("read back")
}
