//! Room for a trial: checked before a trial starts, so that a full or read-only recording
//! folder refuses the trial up front with the figure instead of failing half way.

use std::path::Path;

/// Bytes free to this user, and whether the filesystem is mounted read-only.
pub fn free_bytes(dir: &Path) -> Result<(u64, bool), String> {
    let st = nix::sys::statvfs::statvfs(dir)
        .map_err(|e| format!("cannot read the free space of {}: {e}", dir.display()))?;
    let free = st.blocks_available().saturating_mul(st.fragment_size());
    let read_only = st.flags().contains(nix::sys::statvfs::FsFlags::ST_RDONLY);
    Ok((free, read_only))
}

/// Ok if `dir` can take a trial: writable and at least `min_free` bytes free.
pub fn check_room(dir: &Path, min_free: u64) -> Result<(), String> {
    let (free, read_only) = free_bytes(dir)?;
    if read_only {
        return Err(format!(
            "the recording folder {} is on a read-only filesystem; no trial can be recorded",
            dir.display()
        ));
    }
    if free < min_free {
        return Err(format!(
            "only {} free in {} (recording.min_free_bytes is {}); free space or point recording.dir elsewhere",
            human(free),
            dir.display(),
            human(min_free)
        ));
    }
    Ok(())
}

/// `12.3 MiB`: people read this, the config holds bytes.
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn room_is_judged_against_the_minimum_and_named_in_people_units() {
        let tmp = tempfile::tempdir().expect("tmp");
        let (free, ro) = free_bytes(tmp.path()).expect("statvfs");
        assert!(!ro);
        check_room(tmp.path(), 0).expect("any room is enough for 0");
        let e =
            check_room(tmp.path(), free.saturating_mul(2).max(1 << 40)).expect_err("too little");
        assert!(
            e.contains("recording.min_free_bytes") && e.contains("free in"),
            "{e}"
        );
        assert_eq!(human(512), "512 B");
        assert_eq!(human(200 * 1024), "200.0 KiB");
        assert_eq!(human(64 << 20), "64.0 MiB");
        let e = check_room(&tmp.path().join("missing"), 0).expect_err("missing");
        assert!(e.contains("missing"), "{e}");
    }
}
