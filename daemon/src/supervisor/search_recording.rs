//! A search's own recording, `search-<stamp>-<n>.mcap` beside the trials': everything a
//! trial's file holds while the search runs (frames, poses, the arm, the log), its events,
//! and its map on `/artery`, so that a search can be reviewed as a trial is. A search never
//! runs inside a trial (the state table refuses it), so the recorder's one file is free; the
//! trial that `--then-track` starts afterwards gets its own file. The summary beside it is
//! the search's outcome.

use super::*;

/// The open search recording.
#[derive(Debug, Clone)]
pub(super) struct SearchFile {
    pub id: String,
    pub epoch_offset_ns: i128,
}

impl Supervisor {
    /// Open the search's file (a no-op while a trial's file is open: the search then
    /// records into it).
    pub(super) fn open_search_recording(&mut self, t: f64, described: &Value) {
        if self.trial.is_some() {
            return;
        }
        let (id, epoch_offset_ns) = self.new_recording("search-", t);
        let mut meta = BTreeMap::new();
        meta.insert("search".to_string(), id.clone());
        meta.insert("backend".to_string(), self.info.kind.to_string());
        meta.insert(
            "calibration".to_string(),
            self.calibration
                .describe(self.tissue_stale().as_deref())
                .to_string(),
        );
        meta.insert("request".to_string(), described.to_string());
        self.open_recording(&id, "search", meta, t, epoch_offset_ns);
        self.search_file = Some(SearchFile {
            id,
            epoch_offset_ns,
        });
    }

    /// The search's file path, if one is open.
    pub(super) fn search_recording_path(&self) -> Option<PathBuf> {
        self.search_file
            .as_ref()
            .map(|f| self.s.recording_dir.join(format!("{}.mcap", f.id)))
    }

    /// Close the search's file with `outcome` as its summary.
    pub(super) fn close_search_recording(&mut self, outcome: &Value) {
        let Some(file) = self.search_file.take() else {
            return;
        };
        let path = self.s.recording_dir.join(format!("{}.mcap", file.id));
        let summary = json!({"search": file.id, "recording": path, "outcome": outcome});
        let _ = self.links.recorder.send(RecorderMsg::Close {
            summary,
            then: None,
        });
    }
}
