//! At start-up: find trials a previous run left unfinished (killed, crashed, power cut),
//! rewrite their recordings as complete files and give them a summary saying so. A file that
//! is not a readable recording at all is moved aside to `quarantine/` (named in the log), so
//! that one corrupt file never stops the daemon from starting; a recovery that fails for
//! lack of room leaves the file as it is for the next start.

use std::path::{Path, PathBuf};

use serde_json::json;

use crate::recording::recorder::write_json_atomically;
use crate::recording::recover::{ReadError, recover_in_place};

/// What start-up recovery did.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct StartupRecovery {
    /// Trial ids rewritten as complete files.
    pub recovered: Vec<String>,
    /// Files moved to `quarantine/`, with the reason.
    pub quarantined: Vec<(PathBuf, String)>,
    /// Files left in place because recovery failed (disk full, permissions), with the reason.
    pub left: Vec<(PathBuf, String)>,
}

/// Names recovery itself makes (kept originals, staging files): never recovered again.
fn is_recovery_artifact(name: &str) -> bool {
    let Some(stem) = name.strip_suffix(".mcap") else {
        return true;
    };
    stem.ends_with(".recovering")
        || stem.ends_with(".truncated")
        || stem
            .rsplit_once(".truncated-")
            .is_some_and(|(_, n)| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// Recover every unfinished `*.mcap` in `dir`.
pub fn recover_unfinished(dir: &Path) -> StartupRecovery {
    let mut out = StartupRecovery::default();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    for path in paths {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if is_recovery_artifact(&name) || !path.is_file() {
            continue;
        }
        let summary = path.with_extension("json");
        if summary.exists() {
            continue;
        }
        match recover_in_place(&path) {
            Ok(Some(n)) => {
                let id = name.trim_end_matches(".mcap").to_string();
                tracing::warn!(
                    "recovered the unfinished trial {id}: {n} messages rewritten to {}",
                    path.display()
                );
                let s = json!({
                    "trial": id,
                    "recording": path,
                    "end_reason": "daemon_stopped_unexpectedly",
                    "completed": false,
                    "recovered_messages": n,
                });
                if let Err(e) = write_json_atomically(&summary, &s) {
                    tracing::error!("writing {}: {e}", summary.display());
                }
                out.recovered.push(id);
            }
            Ok(None) => {}
            Err(ReadError::NotMcap { reason, .. }) => match quarantine(dir, &path) {
                Ok(to) => {
                    tracing::error!(
                        "{} is not a readable recording ({reason}); moved to {}",
                        path.display(),
                        to.display()
                    );
                    out.quarantined.push((to, reason));
                }
                Err(e) => {
                    tracing::error!(
                        "{} is not a readable recording ({reason}) and could not be moved to quarantine: {e}; left in place",
                        path.display()
                    );
                    out.left.push((path, reason));
                }
            },
            Err(e) => {
                tracing::error!("cannot recover {} now: {e}; left as it is", path.display());
                out.left.push((path, e.to_string()));
            }
        }
    }
    out
}

/// Move `path` into `dir/quarantine/` under a name not yet taken there.
fn quarantine(dir: &Path, path: &Path) -> std::io::Result<PathBuf> {
    let q = dir.join("quarantine");
    crate::private_fs::ensure_private_dir(&q).map_err(std::io::Error::other)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "unnamed".into());
    for n in 0..10_000u32 {
        let to = if n == 0 {
            q.join(&name)
        } else {
            q.join(format!("{name}.{n}"))
        };
        // Link then unlink: never replaces a file already in quarantine.
        match std::fs::hard_link(path, &to) {
            Ok(()) => {
                std::fs::remove_file(path)?;
                return Ok(to);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::other("no free name in quarantine/"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovery_artifacts_are_recognised() {
        for n in [
            "a.truncated.mcap",
            "a.truncated-3.mcap",
            "a.recovering.mcap",
            "notes.txt",
        ] {
            assert!(is_recovery_artifact(n), "{n}");
        }
        for n in ["2026-11-25T10-00-00Z-3.mcap", "a.truncated-x.mcap"] {
            assert!(!is_recovery_artifact(n), "{n}");
        }
    }
}
