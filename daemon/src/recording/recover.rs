//! Reading trial recordings back, including files cut short by a crash or kill -9: every
//! message up to the last complete chunk is recovered and can be rewritten as a complete,
//! indexed MCAP file (the same job as `mcap recover`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::recording::topics::Topic;

/// One message read back.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadMessage {
    pub topic: String,
    pub log_time_ns: u64,
    pub json: serde_json::Value,
}

/// What a read found.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadBack {
    pub messages: Vec<ReadMessage>,
    /// The file has its summary, footer and closing magic.
    pub complete: bool,
    /// Why reading stopped early, for a truncated file.
    pub stopped_at: Option<String>,
}

impl ReadBack {
    pub fn on(&self, topic: Topic) -> impl Iterator<Item = &ReadMessage> {
        self.messages
            .iter()
            .filter(move |m| m.topic == topic.name())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not an MCAP file ({reason})")]
    NotMcap { path: String, reason: String },
}

/// Read every message of a recording, complete or cut short.
pub fn read(path: &Path) -> Result<ReadBack, ReadError> {
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
        path: path.display().to_string(),
        source,
    })?;
    read_bytes(&bytes).map_err(|reason| ReadError::NotMcap {
        path: path.display().to_string(),
        reason,
    })
}

pub fn read_bytes(bytes: &[u8]) -> Result<ReadBack, String> {
    let complete = mcap::read::footer(bytes).is_ok();
    let stream =
        mcap::MessageStream::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into())
            .map_err(|e| e.to_string())?;
    let mut messages = Vec::new();
    let mut stopped_at = None;
    for m in stream {
        match m {
            Ok(m) => {
                let json = serde_json::from_slice(&m.data).unwrap_or(serde_json::Value::Null);
                messages.push(ReadMessage {
                    topic: m.channel.topic.clone(),
                    log_time_ns: m.log_time,
                    json,
                });
            }
            Err(e) => {
                stopped_at = Some(e.to_string());
                break;
            }
        }
    }
    Ok(ReadBack {
        messages,
        complete,
        stopped_at,
    })
}

/// Rewrite a cut-short recording as a complete one. The original is kept beside it as
/// `NAME.truncated.mcap`; the recovered file takes the original name. Returns the number of
/// messages recovered. A complete file is left alone (returns `None`).
pub fn recover_in_place(path: &Path) -> Result<Option<u64>, ReadError> {
    let back = read(path)?;
    if back.complete {
        return Ok(None);
    }
    let io = |source| ReadError::Io {
        path: path.display().to_string(),
        source,
    };
    let kept = truncated_name(path);
    std::fs::rename(path, &kept).map_err(io)?;
    let mut meta = BTreeMap::new();
    meta.insert("recovered_from".to_string(), kept.display().to_string());
    if let Some(why) = &back.stopped_at {
        meta.insert("stopped_at".to_string(), why.clone());
    }
    let mut out = crate::recording::trial_file::TrialFile::create(path, &meta).map_err(io)?;
    for m in &back.messages {
        let Some(topic) = Topic::from_name(&m.topic) else {
            continue;
        };
        let data = serde_json::to_vec(&m.json).map_err(|e| io(std::io::Error::other(e)))?;
        out.write(topic, m.log_time_ns as f64 * 1e-9, &data)
            .map_err(io)?;
    }
    let n = out.finish().map_err(io)?;
    Ok(Some(n))
}

fn truncated_name(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "trial".into());
    path.with_file_name(format!("{stem}.truncated.mcap"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::trial_file::TrialFile;

    fn write_trial(path: &Path, n: usize, finish: bool) -> u64 {
        let mut f = TrialFile::create(path, &BTreeMap::new()).expect("create");
        for i in 0..n {
            let body =
                serde_json::json!({"t_s": i as f64 * 0.01, "seq": i, "force_n": vec![0.0; 10]});
            f.write(Topic::Tactile, i as f64 * 0.01, body.to_string().as_bytes())
                .expect("write");
            if i % 10 == 9 {
                f.flush().expect("flush");
            }
        }
        if finish {
            f.finish().expect("finish")
        } else {
            f.flush().expect("flush");
            let m = f.messages();
            // Simulate a crash: the writer is forgotten, never finished.
            std::mem::forget(f);
            m
        }
    }

    #[test]
    fn a_complete_file_reads_whole() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("t.mcap");
        assert_eq!(write_trial(&p, 25, true), 25);
        let back = read(&p).expect("read");
        assert!(back.complete);
        assert_eq!(back.on(Topic::Tactile).count(), 25);
        assert_eq!(back.messages[24].json["seq"], 24);
        // Indexed readers see the summary too.
        let bytes = std::fs::read(&p).expect("bytes");
        let summary = mcap::Summary::read(&bytes)
            .expect("summary")
            .expect("present");
        assert_eq!(summary.stats.map(|s| s.message_count), Some(25));
    }

    #[test]
    fn a_file_cut_anywhere_recovers_every_flushed_chunk() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("t.mcap");
        write_trial(&p, 30, false);
        let full = std::fs::read(&p).expect("bytes");
        // Unfinished: no footer, but all 30 flushed messages readable.
        let back = read_bytes(&full).expect("read");
        assert!(!back.complete);
        assert_eq!(back.messages.len(), 30);
        // Cut at every length: never a panic, and the count never goes backwards as the cut
        // moves later.
        let mut last = 0;
        for cut in (0..full.len()).step_by(97) {
            if let Ok(b) = read_bytes(&full[..cut]) {
                assert!(b.messages.len() >= last, "cut {cut}");
                last = b.messages.len();
            }
        }
        // Rewritten in place as a complete file.
        let n = recover_in_place(&p)
            .expect("recover")
            .expect("was incomplete");
        assert_eq!(n, 30);
        let back = read(&p).expect("read");
        assert!(back.complete);
        assert_eq!(back.messages.len(), 30);
        assert!(dir.path().join("t.truncated.mcap").exists());
        assert_eq!(recover_in_place(&p).expect("again"), None);
    }
}
