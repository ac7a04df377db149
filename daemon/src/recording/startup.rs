//! At start-up: find trials a previous run left unfinished (killed, crashed, power cut),
//! rewrite their recordings as complete files and give them a summary saying so.

use std::path::Path;

use serde_json::json;

use crate::recording::recorder::write_json_atomically;
use crate::recording::recover::recover_in_place;

/// Recover every unfinished `*.mcap` in `dir`. Returns the trial ids recovered.
pub fn recover_unfinished(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut recovered = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !name.ends_with(".mcap") || name.ends_with(".truncated.mcap") {
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
                recovered.push(id);
            }
            Ok(None) => {}
            Err(e) => tracing::error!("cannot recover {}: {e}", path.display()),
        }
    }
    recovered
}
