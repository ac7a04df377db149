//! Reading trial recordings back, including files cut short by a crash or kill -9: every
//! message up to the last complete chunk is recovered and can be rewritten as a complete,
//! indexed MCAP file (the same job as `mcap recover`).
//!
//! Any file may be corrupt: the reader never panics (the mcap crate can, on a record length
//! near `u64::MAX` inside a chunk, so its parse runs behind `catch_unwind` and a panic becomes
//! [`ReadError::NotMcap`]), and recovery never destroys data: it writes the rewritten file
//! under a new name and only then moves names, keeping the original bytes under a name of
//! their own.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::recording::provenance::MetadataRecord;
use crate::recording::topics::Topic;
use crate::recording::trial_file::{mcap_err, open_writer};

/// One message read back.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadMessage {
    pub topic: String,
    pub log_time_ns: u64,
    pub publish_time_ns: u64,
    pub sequence: u32,
    /// The channel's id in the file read ([`ReadBack::channels`]).
    pub channel_id: u16,
    /// The message as written.
    pub data: Vec<u8>,
    /// The message parsed as JSON (`null` if it is not JSON).
    pub json: serde_json::Value,
}

/// A channel as the file declares it, with its schema.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelInfo {
    pub topic: String,
    pub message_encoding: String,
    pub metadata: BTreeMap<String, String>,
    /// Name, encoding and bytes of the schema; `None` for a schemaless channel.
    pub schema: Option<(String, String, Vec<u8>)>,
}

/// What a read found.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadBack {
    pub messages: Vec<ReadMessage>,
    pub channels: BTreeMap<u16, ChannelInfo>,
    /// The file's metadata records, in file order.
    pub metadata: Vec<MetadataRecord>,
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

    /// The first metadata record called `name`.
    pub fn metadata_named(&self, name: &str) -> Option<&BTreeMap<String, String>> {
        self.metadata
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, m)| m)
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

/// Read from memory; a panic inside the parser is turned into an error (the input is only
/// borrowed, so nothing is left half-changed by the unwind).
pub fn read_bytes(bytes: &[u8]) -> Result<ReadBack, String> {
    match std::panic::catch_unwind(|| read_bytes_unguarded(bytes)) {
        Ok(r) => r,
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown cause".into());
            Err(format!(
                "corrupt record structure (the MCAP parser gave up: {what})"
            ))
        }
    }
}

/// The largest uncompressed chunk believed. Trial files close chunks at 8 MiB.
const MAX_CHUNK_UNCOMPRESSED: u64 = 256 * 1024 * 1024;

/// The mcap crate allocates whatever length a record inside a compressed chunk declares
/// before reading it, so one corrupt length near `u64::MAX` aborts the process (an
/// allocation failure, which no `catch_unwind` stops). This walks the records (opcode u8,
/// length u64, body) and the records inside each chunk first, and returns the offset of the
/// first chunk whose sizes cannot be right, with why; reading then ends before it. Other
/// framing errors are left to the parser, which reports them.
fn implausible_chunk(bytes: &[u8]) -> Option<(usize, String)> {
    const CHUNK: u8 = 0x06;
    let mut at = mcap::MAGIC.len();
    while let (Some(&op), Some(len)) = (bytes.get(at), u64_at(bytes, at + 1)) {
        let body = at + 9;
        let end = usize::try_from(len)
            .ok()
            .and_then(|l| body.checked_add(l))?;
        let record = bytes.get(body..end)?;
        if op == CHUNK
            && let Err(why) = check_chunk(record)
        {
            return Some((at, format!("corrupt chunk at byte {at}: {why}")));
        }
        at = end;
    }
    None
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    let b = bytes.get(at..at.checked_add(8)?)?;
    Some(u64::from_le_bytes(b.try_into().ok()?))
}

/// A chunk body: start time u64, end time u64, uncompressed size u64, crc u32, compression
/// (u32 length + name), records (u64 length + bytes).
fn check_chunk(body: &[u8]) -> Result<(), String> {
    let short = || "cut short".to_string();
    let size = u64_at(body, 16).ok_or_else(short)?;
    if size > MAX_CHUNK_UNCOMPRESSED {
        return Err(format!("declares {size} uncompressed bytes"));
    }
    let name_len = body
        .get(28..32)
        .and_then(|b| b.try_into().ok())
        .map(u32::from_le_bytes)
        .ok_or_else(short)? as usize;
    let name = body.get(32..32 + name_len).ok_or_else(short)?;
    let records_len = u64_at(body, 32 + name_len).ok_or_else(short)?;
    let start = 40 + name_len;
    let records = usize::try_from(records_len)
        .ok()
        .and_then(|l| body.get(start..start.checked_add(l)?))
        .ok_or_else(short)?;
    let plain: std::borrow::Cow<[u8]> = match name {
        b"" => records.into(),
        b"zstd" => zstd::bulk::decompress(records, size as usize)
            .map_err(|e| format!("zstd: {e}"))?
            .into(),
        // Others are the parser's to refuse.
        _ => return Ok(()),
    };
    let mut at = 0usize;
    while at < plain.len() {
        let len = u64_at(&plain, at + 1).ok_or_else(short)?;
        let left = (plain.len() - at).saturating_sub(9) as u64;
        if len > left {
            return Err(format!(
                "a record inside declares {len} bytes, {left} are left"
            ));
        }
        at += 9 + len as usize;
    }
    Ok(())
}

fn read_bytes_unguarded(bytes: &[u8]) -> Result<ReadBack, String> {
    let complete = mcap::read::footer(bytes).is_ok();
    let (bytes, cut) = match implausible_chunk(bytes) {
        Some((at, why)) => (&bytes[..at], Some(why)),
        None => (bytes, None),
    };
    let complete = complete && cut.is_none();
    let stream =
        mcap::MessageStream::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into())
            .map_err(|e| e.to_string())?;
    let mut messages = Vec::new();
    let mut channels = BTreeMap::new();
    let mut stopped_at = None;
    for m in stream {
        match m {
            Ok(m) => {
                let json = serde_json::from_slice(&m.data).unwrap_or(serde_json::Value::Null);
                channels.entry(m.channel.id).or_insert_with(|| ChannelInfo {
                    topic: m.channel.topic.clone(),
                    message_encoding: m.channel.message_encoding.clone(),
                    metadata: m.channel.metadata.clone(),
                    schema: m
                        .channel
                        .schema
                        .as_ref()
                        .map(|s| (s.name.clone(), s.encoding.clone(), s.data.to_vec())),
                });
                messages.push(ReadMessage {
                    topic: m.channel.topic.clone(),
                    log_time_ns: m.log_time,
                    publish_time_ns: m.publish_time,
                    sequence: m.sequence,
                    channel_id: m.channel.id,
                    data: m.data.into_owned(),
                    json,
                });
            }
            Err(e) => {
                stopped_at = Some(e.to_string());
                break;
            }
        }
    }
    if stopped_at.is_none() {
        stopped_at = cut;
    }
    if messages.is_empty()
        && let Some(why) = &stopped_at
    {
        // Not one message before the first error: nothing here to recover.
        return Err(format!("no readable message ({why})"));
    }
    Ok(ReadBack {
        messages,
        channels,
        metadata: read_metadata(bytes),
        complete,
        stopped_at,
    })
}

/// Metadata records, in order, up to the first record that does not parse.
fn read_metadata(bytes: &[u8]) -> Vec<MetadataRecord> {
    let Ok(records) = mcap::read::LinearReader::new_with_options(
        bytes,
        mcap::read::Options::IgnoreEndMagic.into(),
    ) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for r in records {
        match r {
            Ok(mcap::records::Record::Metadata(m)) => out.push((m.name, m.metadata)),
            Ok(_) => {}
            Err(_) => break,
        }
    }
    out
}

/// Rewrite a cut-short recording as a complete one. The rewritten file is written first as
/// `NAME.recovering.mcap`; only when it is complete does the original move aside (to
/// `NAME.truncated.mcap`, or `NAME.truncated-N.mcap` if that name is taken: nothing is ever
/// overwritten) and the rewritten file take the original name. A failure at any step (a full
/// disk, say) leaves the original where it was. Returns the number of messages recovered; a
/// complete file is left alone (returns `None`).
pub fn recover_in_place(path: &Path) -> Result<Option<u64>, ReadError> {
    let back = read(path)?;
    if back.complete {
        return Ok(None);
    }
    let io_at = |at: &Path| {
        let at = at.display().to_string();
        move |source| ReadError::Io {
            path: at.clone(),
            source,
        }
    };
    let staging = sibling(path, "recovering");
    // A staging file can only be left by a recovery that failed half way; the original is
    // still in place, so it is ours to redo.
    match std::fs::remove_file(&staging) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(io_at(&staging)(e)),
    }
    let result = write_recovered(&staging, path, &back);
    let n = match result {
        Ok(n) => n,
        Err(e) => {
            let _ = std::fs::remove_file(&staging);
            return Err(io_at(&staging)(e));
        }
    };
    // Keep the original under a free name (a hard link: the original name never disappears),
    // then atomically replace the original name with the rewritten file.
    let kept = link_to_free_name(path).map_err(io_at(path))?;
    std::fs::rename(&staging, path).map_err(io_at(path))?;
    sync_dir(path);
    tracing::info!(
        "recovered {}: {n} messages; the original bytes are kept in {}",
        path.display(),
        kept.display()
    );
    Ok(Some(n))
}

/// Copy what was read into a new, complete file: the same channels and schemas, the same
/// metadata (plus a `recovery` record), every message with its own times.
fn write_recovered(staging: &Path, original: &Path, back: &ReadBack) -> std::io::Result<u64> {
    let file = crate::private_fs::create_new(staging)?;
    let sync_handle = file.try_clone()?;
    let mut w = open_writer(file)?;
    let mut recovery = BTreeMap::new();
    recovery.insert("recovered_from".to_string(), original.display().to_string());
    if let Some(why) = &back.stopped_at {
        recovery.insert("stopped_at".to_string(), why.clone());
    }
    for (name, map) in back
        .metadata
        .iter()
        .chain(std::iter::once(&("recovery".to_string(), recovery)))
    {
        w.write_metadata(&mcap::records::Metadata {
            name: name.clone(),
            metadata: map.clone(),
        })
        .map_err(mcap_err)?;
    }
    let mut ids = BTreeMap::new();
    for (&id, c) in &back.channels {
        let schema_id = match &c.schema {
            Some((name, encoding, data)) => w.add_schema(name, encoding, data).map_err(mcap_err)?,
            None => 0,
        };
        let new = w
            .add_channel(schema_id, &c.topic, &c.message_encoding, &c.metadata)
            .map_err(mcap_err)?;
        ids.insert(id, new);
    }
    let mut n = 0u64;
    for m in &back.messages {
        let Some(&channel_id) = ids.get(&m.channel_id) else {
            continue;
        };
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id,
                sequence: m.sequence,
                log_time: m.log_time_ns,
                publish_time: m.publish_time_ns,
            },
            &m.data,
        )
        .map_err(mcap_err)?;
        n += 1;
    }
    w.finish().map_err(mcap_err)?;
    let mut sink = w.into_inner();
    std::io::Write::flush(&mut sink)?;
    sync_handle.sync_all()?;
    Ok(n)
}

/// Hard-link `path` to `NAME.truncated.mcap` or the first free `NAME.truncated-N.mcap`.
fn link_to_free_name(path: &Path) -> std::io::Result<PathBuf> {
    for n in 0..10_000u32 {
        let kept = if n == 0 {
            sibling(path, "truncated")
        } else {
            sibling(path, &format!("truncated-{n}"))
        };
        match std::fs::hard_link(path, &kept) {
            Ok(()) => return Ok(kept),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::other(format!(
        "no free name for the original of {}",
        path.display()
    )))
}

fn sync_dir(path: &Path) {
    if let Some(dir) = path.parent()
        && let Ok(d) = std::fs::File::open(dir)
    {
        let _ = d.sync_all();
    }
}

/// `dir/STEM.TAG.mcap` beside `dir/STEM.mcap`.
fn sibling(path: &Path, tag: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "trial".into());
    path.with_file_name(format!("{stem}.{tag}.mcap"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::trial_file::TrialFile;

    fn write_trial(path: &Path, n: usize, finish: bool) -> u64 {
        let mut f = TrialFile::create(path, &[], 0).expect("create");
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

    #[test]
    fn no_corruption_of_a_record_length_panics_the_reader() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("t.mcap");
        write_trial(&p, 12, false);
        let good = std::fs::read(&p).expect("bytes");
        // Every 8-byte field at every offset set to lengths near u64::MAX and other
        // extremes: an error or a shorter read, never a panic.
        let mut panicked_inside = 0;
        for at in 0..good.len().saturating_sub(8) {
            for v in [u64::MAX, u64::MAX - 7, 1 << 63, u64::from(u32::MAX) + 1] {
                let mut bad = good.clone();
                bad[at..at + 8].copy_from_slice(&v.to_le_bytes());
                match read_bytes(&bad) {
                    Ok(b) => assert!(b.messages.len() <= 12),
                    Err(e) => {
                        if e.contains("the MCAP parser gave up") {
                            panicked_inside += 1;
                        }
                    }
                }
            }
        }
        // Not an assertion on the crate's behaviour, which may improve: a report.
        eprintln!("{panicked_inside} corruptions made the mcap parser panic (caught)");
    }

    #[test]
    fn recovery_that_cannot_finish_leaves_the_original_and_never_overwrites() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("t.mcap");
        write_trial(&p, 15, false);
        let original = std::fs::read(&p).expect("bytes");
        // The staging name is taken by something that cannot be removed as a file: the
        // recovery fails, and the original stays where it was, byte for byte.
        std::fs::create_dir(dir.path().join("t.recovering.mcap")).expect("blocker");
        let e = recover_in_place(&p).expect_err("cannot stage");
        assert!(e.to_string().contains("t.recovering.mcap"), "{e}");
        assert_eq!(std::fs::read(&p).expect("still there"), original);
        std::fs::remove_dir(dir.path().join("t.recovering.mcap")).expect("rmdir");
        // An older kept original is not overwritten: this one goes to `.truncated-1`.
        std::fs::write(dir.path().join("t.truncated.mcap"), b"older").expect("older");
        assert_eq!(recover_in_place(&p).expect("recover"), Some(15));
        assert_eq!(
            std::fs::read(dir.path().join("t.truncated.mcap")).expect("older"),
            b"older"
        );
        assert_eq!(
            std::fs::read(dir.path().join("t.truncated-1.mcap")).expect("kept"),
            original
        );
        assert!(read(&p).expect("read").complete);
        assert!(!dir.path().join("t.recovering.mcap").exists());
    }

    #[test]
    fn recovery_on_a_full_disk_leaves_the_original() {
        if !nix::unistd::geteuid().is_root() {
            eprintln!("skipped: mounting a tmpfs needs root");
            return;
        }
        let dir = tempfile::tempdir().expect("tmp");
        let disk = dir.path().join("disk");
        std::fs::create_dir(&disk).expect("dir");
        let mounted = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
            .arg(&disk)
            .status()
            .is_ok_and(|s| s.success());
        if !mounted {
            eprintln!("skipped: cannot mount a tmpfs here");
            return;
        }
        let p = disk.join("t.mcap");
        write_trial(&p, 40, false);
        let original = std::fs::read(&p).expect("bytes");
        // Fill the rest of the disk.
        let filler = disk.join("filler");
        let mut f = std::fs::File::create(&filler).expect("filler");
        let block = vec![0u8; 4096];
        use std::io::Write;
        while f.write_all(&block).is_ok() {}
        drop(f);
        let e = recover_in_place(&p).expect_err("no room");
        assert!(e.to_string().contains("No space left"), "{e}");
        assert_eq!(std::fs::read(&p).expect("still there"), original);
        assert!(!disk.join("t.recovering.mcap").exists());
        assert!(!disk.join("t.truncated.mcap").exists());
        let _ = std::process::Command::new("umount")
            .arg("-l")
            .arg(&disk)
            .status();
    }

    /// A trial file written by the recorder as it was before issue 14 (uncompressed chunks,
    /// daemon-clock times, hand-written schemas): still read whole, and still recovered when
    /// cut short.
    #[test]
    fn a_recording_from_before_issue_14_still_opens_and_recovers() {
        let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/v0-trial.mcap");
        let bytes = std::fs::read(&fixture).expect("fixture");
        let back = read_bytes(&bytes).expect("read");
        assert!(back.complete);
        assert_eq!(back.on(Topic::Tactile).count(), 20);
        assert_eq!(back.on(Topic::Joints).count(), 4);
        assert_eq!(back.on(Topic::Truth).count(), 4);
        assert_eq!(back.on(Topic::Events).count(), 3);
        let located = back
            .on(Topic::Events)
            .find(|m| m.json["kind"] == "located")
            .expect("located");
        assert_eq!(located.json["point"]["element"], 4.6);
        // Cut inside its data: what was flushed is recovered into a complete file.
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("old.mcap");
        let cut = bytes.len() * 2 / 3;
        std::fs::write(&p, &bytes[..cut]).expect("write");
        let n = recover_in_place(&p).expect("recover").expect("was cut");
        assert!(n >= 10, "{n}");
        let again = read(&p).expect("read");
        assert!(again.complete);
        assert_eq!(again.messages.len() as u64, n);
    }

    #[test]
    fn recovery_keeps_channels_schemas_and_metadata_and_says_so() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("t.mcap");
        let mut cfg = BTreeMap::new();
        cfg.insert("json".to_string(), "{\"version\":1}".to_string());
        let offset = 1_795_000_000_000_000_000i128;
        let mut f = TrialFile::create(&p, &[("config".to_string(), cfg)], offset).expect("create");
        f.write(Topic::Log, 2.5, br#"{"message":"hello"}"#)
            .expect("write");
        f.flush().expect("flush");
        std::mem::forget(f);
        assert_eq!(recover_in_place(&p).expect("recover"), Some(1));
        let back = read(&p).expect("read");
        assert!(back.complete);
        assert_eq!(
            back.metadata_named("config").map(|m| m["json"].as_str()),
            Some("{\"version\":1}")
        );
        assert!(back.metadata_named("recovery").is_some());
        let m = &back.messages[0];
        assert_eq!(m.log_time_ns, 1_795_000_002_500_000_000);
        let schema = &back.channels[&m.channel_id].schema;
        assert_eq!(schema.as_ref().map(|s| s.0.as_str()), Some("foxglove.Log"));
    }
}
