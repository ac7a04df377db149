//! Files and directories the daemon creates where others might reach first: directories it
//! uses must be its own and not writable by others, and new files never follow a symbolic
//! link and never replace what is there (`O_CREAT | O_EXCL | O_NOFOLLOW`). A daemon running
//! as root in a folder an unprivileged user made first must not be steered into writing a
//! root-only file or listening where a stranger controls the socket.

use std::fs::{File, OpenOptions};
use std::io;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// Create `dir` (and its parents, mode 0750) if missing, then check that it is a real
/// directory owned by this process's user and not writable by others.
pub fn ensure_private_dir(dir: &Path) -> Result<(), String> {
    if !dir.exists() {
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o750)
            .create(dir)
            .map_err(|e| format!("cannot create the directory {}: {e}", dir.display()))?;
    }
    check_private_dir(dir, nix::unistd::geteuid().as_raw())
}

/// The check alone, for a given user (tests pass another uid).
pub fn check_private_dir(dir: &Path, uid: u32) -> Result<(), String> {
    let m = std::fs::symlink_metadata(dir)
        .map_err(|e| format!("cannot inspect the directory {}: {e}", dir.display()))?;
    if m.file_type().is_symlink() {
        return Err(format!(
            "{} is a symbolic link; the daemon uses only a real directory there (remove the link or configure another path)",
            dir.display()
        ));
    }
    if !m.is_dir() {
        return Err(format!("{} is not a directory", dir.display()));
    }
    if m.uid() != uid {
        return Err(format!(
            "{} belongs to uid {}, not to the daemon's user (uid {uid}); refusing to use a directory someone else controls",
            dir.display(),
            m.uid()
        ));
    }
    if m.mode() & 0o002 != 0 {
        return Err(format!(
            "{} is writable by every user (mode {:o}); refusing it (chmod o-w, or configure another path)",
            dir.display(),
            m.mode() & 0o7777
        ));
    }
    Ok(())
}

/// Create a new file at `path` (mode 0640), failing if anything exists there, a link
/// included.
pub fn create_new(path: &Path) -> io::Result<File> {
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o640)
        .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
        .open(path)
}

/// Create `dir/STEM.EXT`, or `dir/STEM-N.EXT` for the first free N: never overwrites.
pub fn create_unique(dir: &Path, stem: &str, ext: &str) -> io::Result<(PathBuf, File)> {
    for n in 0..10_000u32 {
        let name = if n == 0 {
            format!("{stem}.{ext}")
        } else {
            format!("{stem}-{n}.{ext}")
        };
        let path = dir.join(name);
        match create_new(&path) {
            Ok(f) => return Ok((path, f)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(io::Error::new(
        io::ErrorKind::AlreadyExists,
        format!("no free name for {stem}.{ext} in {}", dir.display()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn a_world_writable_or_foreign_or_linked_directory_is_refused() {
        let tmp = tempfile::tempdir().expect("tmp");
        let own = nix::unistd::geteuid().as_raw();
        let d = tmp.path().join("run");
        ensure_private_dir(&d).expect("created and ours");
        assert_eq!(
            std::fs::metadata(&d).expect("meta").permissions().mode() & 0o777,
            0o750
        );
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o777)).expect("chmod");
        let e = ensure_private_dir(&d).expect_err("world-writable");
        assert!(
            e.contains("writable by every user") && e.contains("777"),
            "{e}"
        );
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o700)).expect("chmod");
        let e = check_private_dir(&d, own.wrapping_add(1)).expect_err("foreign");
        assert!(e.contains(&format!("belongs to uid {own}")), "{e}");
        let link = tmp.path().join("link");
        std::os::unix::fs::symlink(&d, &link).expect("symlink");
        let e = ensure_private_dir(&link).expect_err("link");
        assert!(e.contains("symbolic link"), "{e}");
    }

    #[test]
    fn new_files_never_follow_links_nor_overwrite() {
        let tmp = tempfile::tempdir().expect("tmp");
        let victim = tmp.path().join("victim");
        std::fs::write(&victim, b"precious").expect("write");
        let planted = tmp.path().join("fault.jsonl");
        std::os::unix::fs::symlink(&victim, &planted).expect("symlink");
        assert!(create_new(&planted).is_err());
        assert_eq!(std::fs::read(&victim).expect("read"), b"precious");
        // A unique name goes around the planted link and an existing file.
        let (p, _) = create_unique(tmp.path(), "fault", "jsonl").expect("unique");
        assert_eq!(p, tmp.path().join("fault-1.jsonl"));
        let (p, _) = create_unique(tmp.path(), "fault", "jsonl").expect("unique");
        assert_eq!(p, tmp.path().join("fault-2.jsonl"));
        assert_eq!(std::fs::read(&victim).expect("read"), b"precious");
    }
}
