//! One trial's MCAP file: zstd-compressed chunks, JSON channels, Unix-epoch times.
//!
//! Durability: messages collect in the open chunk in memory; [`TrialFile::flush`] closes the
//! chunk (compressing it) and hands it to the kernel (what a kill -9 cannot take away),
//! [`TrialFile::sync`] also fdatasyncs (what a power cut cannot take away). A file cut short
//! anywhere is still readable up to its last complete chunk by standard linear readers that
//! do not insist on the closing magic, and [`crate::recording::recover`] rewrites it as a
//! complete, indexed file.
//!
//! Times: every message carries the daemon clock in its own `t_s`; its MCAP log and publish
//! times are that clock moved onto the Unix epoch by the offset taken when the trial opened
//! (recorded in the `trial` metadata as `epoch_offset_ns`), so tools show the wall date and
//! time of the trial while intervals stay those of the daemon clock.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::recording::provenance::MetadataRecord;
use crate::recording::topics::Topic;

/// Chunks close at our flushes, not on size, up to this bound.
const CHUNK_BYTES: u64 = 8 * 1024 * 1024;

/// The writer side handed to mcap: a buffered file.
#[derive(Debug)]
pub(crate) struct Sink(BufWriter<File>);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

impl Seek for Sink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.0.seek(pos)
    }
}

/// How every trial file is written (also by recovery): zstd chunks compressed on the
/// writing thread itself (no compression threads competing with the control loop's core).
pub(crate) fn open_writer(file: File) -> std::io::Result<mcap::Writer<Sink>> {
    mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .compression_threads(0)
        .chunk_size(Some(CHUNK_BYTES))
        .profile("")
        .library(concat!("pulsetrackd ", env!("CARGO_PKG_VERSION")))
        .create(Sink(BufWriter::with_capacity(256 * 1024, file)))
        .map_err(mcap_err)
}

/// The daemon clock (s) on the Unix epoch (ns): `epoch_offset_ns + t_s * 1e9`, clamped to
/// the representable range; a non-finite time maps to the offset itself.
pub fn epoch_ns(epoch_offset_ns: i128, t_s: f64) -> u64 {
    let t_ns = if t_s.is_finite() {
        (t_s * 1e9) as i128
    } else {
        0
    };
    u64::try_from((epoch_offset_ns + t_ns).max(0)).unwrap_or(u64::MAX)
}

/// A mapping of daemon time onto the Unix epoch: the open trial's (its file's log times) or
/// the live view's (fixed when the daemon starts, so its timeline never runs backwards).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Epoch {
    pub offset_ns: i128,
}

impl Epoch {
    /// Unix ns of daemon time `t_s`.
    pub fn ns(&self, t_s: f64) -> u64 {
        epoch_ns(self.offset_ns, t_s)
    }

    /// Daemon time `t_s` as a Foxglove time.
    pub fn time(&self, t_s: f64) -> crate::recording::foxglove_msgs::Time {
        crate::recording::foxglove_msgs::Time::from_ns(self.ns(t_s))
    }
}

/// The offset that puts daemon time `t_s` at the wall-clock instant `now`.
pub fn epoch_offset_ns(now: std::time::SystemTime, t_s: f64) -> i128 {
    let wall = now
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i128)
        .unwrap_or(0);
    wall - if t_s.is_finite() {
        (t_s * 1e9) as i128
    } else {
        0
    }
}

pub struct TrialFile {
    path: PathBuf,
    writer: Option<mcap::Writer<Sink>>,
    /// A second descriptor of the same file, for fdatasync.
    sync_handle: File,
    channels: BTreeMap<Topic, u16>,
    sequence: BTreeMap<Topic, u32>,
    epoch_offset_ns: i128,
    messages: u64,
    unflushed: bool,
}

impl std::fmt::Debug for TrialFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TrialFile")
            .field("path", &self.path)
            .field("messages", &self.messages)
            .finish()
    }
}

/// mcap wraps the OS error in a message that does not name it ("I/O error from writing");
/// hand back the OS error itself, so the log and the fault say "No space left on device".
pub(crate) fn mcap_err(e: mcap::McapError) -> std::io::Error {
    match e {
        mcap::McapError::Io(io) => io,
        other => std::io::Error::other(other),
    }
}

impl TrialFile {
    /// Create `path` (refusing to overwrite or to follow a link) with every channel declared
    /// and the metadata records written. A file that cannot even take its header (a full
    /// disk) is removed again: it holds nothing, and would only be quarantined at the next
    /// start.
    pub fn create(
        path: &Path,
        metadata: &[MetadataRecord],
        epoch_offset_ns: i128,
    ) -> std::io::Result<Self> {
        let file = crate::private_fs::create_new(path)?;
        Self::start(path, file, metadata, epoch_offset_ns).inspect_err(|_| {
            let _ = std::fs::remove_file(path);
        })
    }

    fn start(
        path: &Path,
        file: File,
        metadata: &[MetadataRecord],
        epoch_offset_ns: i128,
    ) -> std::io::Result<Self> {
        let sync_handle = file.try_clone()?;
        let mut writer = open_writer(file)?;
        let mut channels = BTreeMap::new();
        for t in Topic::ALL {
            let schema = writer
                .add_schema(t.schema_name(), "jsonschema", t.schema().as_bytes())
                .map_err(mcap_err)?;
            let id = writer
                .add_channel(schema, t.name(), "json", &BTreeMap::new())
                .map_err(mcap_err)?;
            channels.insert(t, id);
        }
        for (name, map) in metadata {
            writer
                .write_metadata(&mcap::records::Metadata {
                    name: name.clone(),
                    metadata: map.clone(),
                })
                .map_err(mcap_err)?;
        }
        let mut f = Self {
            path: path.to_path_buf(),
            writer: Some(writer),
            sync_handle,
            channels,
            sequence: BTreeMap::new(),
            epoch_offset_ns,
            messages: 0,
            unflushed: false,
        };
        f.sync()?;
        Ok(f)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// The Unix-epoch time, ns, of daemon time `t_s` in this file.
    pub fn log_time_ns(&self, t_s: f64) -> u64 {
        epoch_ns(self.epoch_offset_ns, t_s)
    }

    /// Append one message stamped with the daemon clock.
    pub fn write(&mut self, topic: Topic, t_s: f64, json: &[u8]) -> std::io::Result<()> {
        let ns = self.log_time_ns(t_s);
        let Some(w) = self.writer.as_mut() else {
            return Err(std::io::Error::other("recording already closed"));
        };
        let Some(&channel_id) = self.channels.get(&topic) else {
            return Err(std::io::Error::other("unknown channel"));
        };
        let seq = self.sequence.entry(topic).or_insert(0);
        *seq = seq.wrapping_add(1);
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id,
                sequence: *seq,
                log_time: ns,
                publish_time: ns,
            },
            json,
        )
        .map_err(mcap_err)?;
        self.messages += 1;
        self.unflushed = true;
        Ok(())
    }

    /// Add a metadata record (closes the open chunk first: metadata sits between chunks).
    pub fn write_metadata(&mut self, record: &MetadataRecord) -> std::io::Result<()> {
        let Some(w) = self.writer.as_mut() else {
            return Err(std::io::Error::other("recording already closed"));
        };
        w.write_metadata(&mcap::records::Metadata {
            name: record.0.clone(),
            metadata: record.1.clone(),
        })
        .map_err(mcap_err)?;
        self.unflushed = true;
        Ok(())
    }

    /// Close the open chunk and hand everything to the kernel (survives kill -9).
    pub fn flush(&mut self) -> std::io::Result<()> {
        if !self.unflushed {
            return Ok(());
        }
        if let Some(w) = self.writer.as_mut() {
            w.flush().map_err(mcap_err)?;
        }
        self.unflushed = false;
        Ok(())
    }

    /// Flush and fdatasync (survives a power cut).
    pub fn sync(&mut self) -> std::io::Result<()> {
        if let Some(w) = self.writer.as_mut() {
            w.flush().map_err(mcap_err)?;
        }
        self.unflushed = false;
        self.sync_handle.sync_data()
    }

    /// Let go of a file that failed to write, without trying to write its footer (what is
    /// on disk stays readable up to its last complete chunk).
    pub fn abandon(mut self) {
        if let Some(w) = self.writer.take() {
            // `into_inner` hands back the sink without writing the summary (dropping the
            // Writer would try to finish the file); the unwritten buffer is discarded.
            let Sink(buffered) = w.into_inner();
            let _ = buffered.into_parts();
        }
    }

    /// Write the summary section and footer, and sync.
    pub fn finish(mut self) -> std::io::Result<u64> {
        if let Some(mut w) = self.writer.take() {
            w.finish().map_err(mcap_err)?;
            let mut sink = w.into_inner();
            sink.flush()?;
        }
        self.sync_handle.sync_all()?;
        Ok(self.messages)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn daemon_time_maps_onto_the_epoch_and_never_wraps() {
        let now = std::time::UNIX_EPOCH + std::time::Duration::from_secs(1_795_253_891);
        let offset = epoch_offset_ns(now, 12.5);
        assert_eq!(epoch_ns(offset, 12.5), 1_795_253_891_000_000_000);
        assert_eq!(epoch_ns(offset, 13.0), 1_795_253_891_500_000_000);
        assert_eq!(epoch_ns(offset, f64::NAN), epoch_ns(offset, 0.0));
        assert_eq!(epoch_ns(-5, 0.0), 0);
        assert_eq!(epoch_ns(i128::from(u64::MAX), 1.0), u64::MAX);
    }
}
