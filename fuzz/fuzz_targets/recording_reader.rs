//! Trial recordings read back and recovered: arbitrary bytes through
//! `daemon::recording::recover::read_bytes`, and as a file `trial.mcap` in a scratch
//! directory (on tmpfs when there is one) through `recover_in_place`. Nothing may panic.
//! Recovery never loses the original: whatever it returns, a file in the directory still
//! holds exactly the original bytes. A file it recovers reads back complete with the count
//! of messages it reported; a complete file is left alone; recovering twice changes nothing.
#![no_main]

use std::path::{Path, PathBuf};
use std::sync::LazyLock;

use daemon::recording::recover::{read, read_bytes, recover_in_place};
use libfuzzer_sys::fuzz_target;

mod recording_seeds;

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// One scratch directory per fuzzing process.
static SCRATCH: LazyLock<PathBuf> = LazyLock::new(|| {
    let base = if Path::new("/dev/shm").is_dir() {
        PathBuf::from("/dev/shm")
    } else {
        std::env::temp_dir()
    };
    let dir = base.join(format!("pulsetrack-fuzz-recording-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
});

/// libfuzzer-sys aborts on every panic, even one caught. The reader parses behind
/// `catch_unwind` (the mcap crate panics on some lengths inside a chunk): let a panic raised
/// under that guard unwind to it, and abort on any other. A panic that escapes the guard
/// still aborts (it cannot unwind out of the fuzz target).
fn init() {
    if let Some(dir) = std::env::var_os("PULSETRACK_FUZZ_WRITE_SEEDS") {
        recording_seeds::write_seeds(Path::new(&dir));
        std::process::exit(0);
    }
    let abort = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        // Raised in mcap, or in std on mcap's behalf (an allocation, an index) while the
        // guarded parse is on the stack.
        let in_mcap = info.location().is_some_and(|l| l.file().contains("/mcap-"));
        if in_mcap
            || std::backtrace::Backtrace::force_capture()
                .to_string()
                .contains("read_bytes_unguarded")
        {
            if GUARDED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) == 0 {
                eprintln!("recording_reader: a panic in mcap caught by the reader's guard: {info}");
            }
            return;
        }
        abort(info);
    }));
}

/// Panics of the mcap crate caught by the reader's guard (the first is printed).
static GUARDED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

fuzz_target!(init: init(), |data: &[u8]| {
    let back = read_bytes(data);
    if let Ok(b) = &back {
        // Complete means a footer and the closing magic.
        assert!(
            !b.complete || data.ends_with(MAGIC),
            "complete without the end magic"
        );
    }

    let dir = &*SCRATCH;
    clear(dir);
    let path = dir.join("trial.mcap");
    std::fs::write(&path, data).expect("write the input");
    let result = recover_in_place(&path);
    assert!(
        holds_original(dir, data),
        "recovery lost the original bytes ({result:?}); files: {:?}",
        listing(dir)
    );
    match result {
        Ok(None) => {
            assert!(
                back.as_ref().is_ok_and(|b| b.complete),
                "a file left alone as complete that does not read complete"
            );
        }
        Ok(Some(n)) => {
            let again = read(&path).expect("the recovered file reads");
            assert!(again.complete, "recovered but not complete");
            assert_eq!(again.messages.len() as u64, n, "recovered count");
            let before = back.as_ref().map_or(0, |b| b.messages.len() as u64);
            assert!(n <= before, "recovered {n} of {before} messages");
            assert!(
                matches!(recover_in_place(&path), Ok(None)),
                "a recovered file is recovered again"
            );
            assert!(
                holds_original(dir, data),
                "a second recovery lost the original"
            );
        }
        Err(e) => assert!(!e.to_string().trim().is_empty()),
    }
    clear(dir);
});

fn holds_original(dir: &Path, data: &[u8]) -> bool {
    std::fs::read_dir(dir).expect("list scratch").any(|e| {
        let p = e.expect("entry").path();
        p.is_file() && std::fs::read(&p).is_ok_and(|b| b == data)
    })
}

fn listing(dir: &Path) -> Vec<(String, u64)> {
    std::fs::read_dir(dir)
        .expect("list scratch")
        .filter_map(|e| {
            let e = e.ok()?;
            Some((
                e.file_name().to_string_lossy().into_owned(),
                e.metadata().ok()?.len(),
            ))
        })
        .collect()
}

fn clear(dir: &Path) {
    for e in std::fs::read_dir(dir).expect("list scratch").flatten() {
        let p = e.path();
        if p.is_dir() {
            let _ = std::fs::remove_dir_all(&p);
        } else {
            let _ = std::fs::remove_file(&p);
        }
    }
}
