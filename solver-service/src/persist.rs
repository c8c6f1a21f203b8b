//! Snapshots and the journal: nothing acknowledged is lost. The only module that touches bincode.
//!
//! * A **snapshot** is the world's whole state ([`world::state::State`]: every chain's joint 0 and
//!   link vectors, bit for bit, its holds, instruments and datum joint, and the sequence number) in
//!   one format (a snapshot of an earlier version is refused by name), written to a temporary file,
//!   synced and renamed over `snapshot.bin`, so a crash leaves either the old or the new snapshot,
//!   never half of one.
//! * The **journal** `journal.bin` holds every accepted state-changing request since that snapshot, each
//!   record `[u32 length][u32 crc32][bincode record]`, appended *before* the response is sent. Replaying
//!   it through the same handler reproduces the state bit for bit (the kernel is deterministic).
//! * **Periodic snapshots leave the serving thread at once** ([`Store::snapshot_in_background`]): it
//!   encodes the state and moves the journal aside as a *segment* `journal-<state>.bin` (every record in
//!   it at most `<state>`) behind a new `journal.bin`; a writer thread writes, syncs and renames the
//!   snapshot, then deletes the segments it covers. A crash at any point leaves a snapshot and the
//!   journals after it: restore replays the segments, oldest first, then `journal.bin`, skipping what
//!   the snapshot already holds. Start-up, the `snapshot` command and shutdown snapshot on the calling
//!   thread ([`Store::snapshot`]).
//!
//! A failed or short append never hides a later acknowledged change: the journal is cut back to its last
//! whole record (the change is refused and undone), so the next record follows it directly; if even the
//! cut fails, the journal is *unsound* and every change is refused until the next snapshot starts a new
//! journal file. Tested with injected faults (`Fault`), a full file system and `kill -9` at random
//! points (the `tests` crate).
//!
//! With [`JournalMode::Write`] a record reaches the kernel's page cache before the response: it survives
//! `kill -9` of the service but not a power cut; [`JournalMode::Fsync`] also survives the latter at the
//! cost of one `fdatasync` per request. Sizes read back are bounded: a snapshot by the scene's size, a
//! record by [`MAX_RECORD_BYTES`].

use crate::wire::WireWorld;
use serde::{Deserialize, Serialize};
use shared::{MAX_PATH_POINTS, RequestHeader, Vec3};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use world::World;
use world::state::State;

/// The snapshot body's format: the magic number, then the world's [`State`] ("TRX7": since the
/// chains' eyelets).
const SNAPSHOT_MAGIC: u32 = 0x5452_5837; // "TRX7"
/// Formats of earlier versions, refused with a message (their state is not read: start without
/// `--restore`).
const OLDER_SNAPSHOTS: [(u32, &str); 6] = [
    (0x5452_5836, "TRX6"),
    (0x5452_5835, "TRX5"),
    (0x5452_5834, "TRX4"),
    (0x5452_5833, "TRX3"),
    (0x5452_5832, "TRX2"),
    (0x5452_5853, "TRXS"),
];
const JOURNAL_MAGIC: [u8; 8] = *b"TRXJ\x01\0\0\0";
/// A snapshot file since issue 35: this magic, the body's length (u64 LE), the CRC-32 of what follows
/// it (u32 LE), flags (u32 LE: bit 0, a journal follows this snapshot), then the body (a [`Snapshot`] in
/// bincode). Files without it are read as the older formats, unchecked.
const SNAPSHOT_ENVELOPE: [u8; 8] = *b"TRXSNAP5";
/// Bytes before the body: magic, length, CRC, flags.
const ENVELOPE_BYTES: usize = 8 + 8 + 4 + 4;
/// Envelope flag: the store was journaling when it wrote the snapshot, so a journal must follow it.
const FLAG_JOURNAL_FOLLOWS: u32 = 1;
/// Largest journal record (a full path request with its header).
pub const MAX_RECORD_BYTES: usize = 256 + 32 * MAX_PATH_POINTS as usize;

type Config = bincode::config::Configuration;
fn config() -> Config {
    bincode::config::standard()
}

/// How the journal is written.
/// What went wrong with the state directory. Every error names the file or the directory, and says
/// what a user can do where there is something to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PersistError {
    /// A file or directory could not be read, written, synced or renamed, or does not read as what it
    /// should be (another format, damage, another scene's state).
    #[error("{}: {what}: {why}", path.display())]
    File {
        /// The file or directory.
        path: PathBuf,
        /// What was being done, or what the file turned out to be.
        what: String,
        /// Why.
        why: String,
    },
    /// The state or a journal record could not be encoded.
    #[error("cannot encode {what}: {why}")]
    Encode {
        /// A snapshot or a journal record.
        what: &'static str,
        /// The encoder's reason.
        why: String,
    },
    /// Too many journal segments wait for a snapshot: no more are started.
    #[error("{}: {segments} journal segments wait for a snapshot; no more are started", dir.display())]
    Backlog {
        /// The state directory.
        dir: PathBuf,
        /// Segments waiting.
        segments: usize,
    },
    /// A journal write failed and the journal was cut back to its last whole record.
    #[error("journal write failed ({why}); cut back to its last whole record")]
    WriteFailed {
        /// The write's error.
        why: String,
    },
    /// A journal write failed and so did the cut back: the journal is unsound from here.
    #[error("journal write failed: {why}")]
    CutFailed {
        /// Both errors.
        why: String,
    },
    /// The journal is unsound: every change is refused until a snapshot starts a new journal.
    #[error("the journal is unsound ({why}): changes are refused until a snapshot succeeds")]
    Unsound {
        /// Why it became unsound.
        why: String,
    },
    /// The snapshot writer thread could not start, or has ended.
    #[error("{0}")]
    Writer(String),
    /// Damage that restore found (the files are kept as they are), and what
    /// `--restore-from-damaged` would restore.
    #[error("{0}")]
    Damaged(String),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum JournalMode {
    /// No journal: state since the last snapshot is lost on a crash.
    Off,
    /// Written before each response (survives the process being killed).
    Write,
    /// Written and `fdatasync`ed before each response (survives a power cut).
    Fsync,
}

/// A snapshot body: the format's magic number, then the world's state.
#[derive(Debug, Serialize, Deserialize)]
struct Snapshot {
    magic: u32,
    state: State,
}

/// A decoded snapshot file.
struct SnapshotFile {
    snap: Snapshot,
    /// Whether a journal must follow it.
    journal_follows: bool,
}

/// Checks and opens a snapshot file's envelope ([`SNAPSHOT_ENVELOPE`]): its length and checksum.
fn decode_snapshot_file(bytes: &[u8], path: &Path) -> Result<SnapshotFile, PersistError> {
    if !bytes.starts_with(&SNAPSHOT_ENVELOPE) {
        // A file of an earlier version (no envelope) is named by its format; anything else is not a
        // snapshot.
        decode_snapshot(bytes, path)?;
        return Err(io(path, "not a snapshot", "no envelope"));
    }
    let damaged = |why: String| {
        io(
            path,
            "damaged snapshot (start without --restore, or restore a copy)",
            why,
        )
    };
    if bytes.len() < ENVELOPE_BYTES {
        return Err(damaged(format!(
            "{} bytes, shorter than its header",
            bytes.len()
        )));
    }
    let word = |at: usize, n: usize| -> u64 {
        bytes[at..at + n]
            .iter()
            .rev()
            .fold(0u64, |v, &b| (v << 8) | u64::from(b))
    };
    let (len, crc, flags) = (word(8, 8), word(16, 4) as u32, word(20, 4) as u32);
    let body = &bytes[ENVELOPE_BYTES..];
    if len != body.len() as u64 {
        return Err(damaged(format!(
            "its header says {len} bytes of state, the file holds {}",
            body.len()
        )));
    }
    if crc32fast::hash(&bytes[20..]) != crc {
        return Err(damaged("checksum mismatch".to_string()));
    }
    if flags & !FLAG_JOURNAL_FOLLOWS != 0 {
        return Err(damaged(format!("unknown flags {flags:#x}")));
    }
    let snap = decode_snapshot(body, path)?;
    Ok(SnapshotFile {
        snap,
        journal_follows: flags & FLAG_JOURNAL_FOLLOWS != 0,
    })
}

/// Decodes a snapshot body of this format; one of an earlier version is refused by its name (one
/// format, no upgrade ladder: docs/service.md, "Persistence").
fn decode_snapshot(bytes: &[u8], path: &Path) -> Result<Snapshot, PersistError> {
    // The magic number comes first in every format.
    let (magic, _): (u32, usize) = bincode::serde::decode_from_slice(bytes, config())
        .map_err(|e| io(path, "not a snapshot", e))?;
    if let Some((_, name)) = OLDER_SNAPSHOTS.iter().find(|(m, _)| *m == magic) {
        return Err(io(
            path,
            "not a snapshot of this version",
            format!(
                "format {name}, written by an earlier version; start without --restore (the state \
                 of an earlier version is not read)"
            ),
        ));
    }
    if magic != SNAPSHOT_MAGIC {
        return Err(io(
            path,
            "not a snapshot of this version",
            "wrong magic number",
        ));
    }
    let (snap, _): (Snapshot, usize) = bincode::serde::decode_from_slice(bytes, config())
        .map_err(|e| io(path, "not a snapshot", e))?;
    Ok(snap)
}

#[derive(Debug, Serialize)]
struct JournalRecordRef<'a> {
    sequence: u64,
    header: &'a RequestHeader,
    points: &'a [Vec3],
}

#[derive(Debug, Deserialize)]
struct JournalRecord {
    sequence: u64,
    header: RequestHeader,
    points: Vec<Vec3>,
}

/// A fault injected into the next journal append (tests).
#[cfg(test)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    /// Half the record is written, then the write fails.
    ShortWrite,
    /// As `ShortWrite`, and the cut back fails too.
    ShortWriteThenCutFails,
    /// The next background snapshot rotates the journal, then the process "crashes" before the writer
    /// thread has written anything (the job is never sent).
    WriterNeverRuns,
}

/// The state directory of one instance.
#[derive(Debug)]
pub struct Store {
    dir: PathBuf,
    mode: JournalMode,
    journal: Option<File>,
    buf: Vec<u8>,
    /// Bytes of the journal up to its last whole record.
    journal_len: u64,
    /// Why the journal cannot be trusted (a cut-back failed); changes are refused until a new journal
    /// is started (at the next snapshot).
    unsound: Option<String>,
    /// Journal segments on disk (by the sequence they end at or before), waiting for a snapshot.
    pending: Vec<u64>,
    /// The thread that writes snapshots started by [`Store::snapshot_in_background`].
    writer: Option<Writer>,
    /// Snapshots written since the store was opened.
    written: u64,
    /// A fault to inject into the next append (tests).
    #[cfg(test)]
    fault: Option<Fault>,
}

/// What a restore found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Restored {
    pub snapshot_sequence: u64,
    pub replayed: u64,
    /// Bytes at the journal's end that did not form a whole record (a write cut by the crash; never
    /// acknowledged).
    pub dropped_tail_bytes: u64,
    /// With `--restore-from-damaged`: what was dropped, and where the damaged files were kept.
    pub damage: Option<String>,
}

fn io(path: &Path, what: &str, e: impl std::fmt::Display) -> PersistError {
    PersistError::File {
        path: path.to_path_buf(),
        what: what.to_string(),
        why: e.to_string(),
    }
}

impl Store {
    /// Opens (creating, owner-only) the state directory.
    pub fn open(dir: &Path, mode: JournalMode) -> Result<Self, PersistError> {
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(dir)
            .map_err(|e| io(dir, "cannot create the state directory", e))?;
        Ok(Store {
            dir: dir.to_path_buf(),
            mode,
            journal: None,
            buf: vec![0; MAX_RECORD_BYTES + 8],
            journal_len: 0,
            unsound: None,
            pending: list_segments(dir)?,
            writer: None,
            written: 0,
            #[cfg(test)]
            fault: None,
        })
    }

    pub fn snapshot_path(&self) -> PathBuf {
        self.dir.join("snapshot.bin")
    }
    pub fn journal_path(&self) -> PathBuf {
        self.dir.join("journal.bin")
    }
    pub fn mode(&self) -> JournalMode {
        self.mode
    }

    /// Writes a snapshot of `set` on this thread (after any snapshot the writer thread has in hand),
    /// then drops the journal it covers. Used at start-up, on the `snapshot` command and at shutdown.
    pub fn snapshot(&mut self, set: &World) -> Result<(), PersistError> {
        if let Some(Err(e)) = self.wait_for_writer() {
            // Reported to the caller of this snapshot; this one may still succeed.
            eprintln!("solver-service: a background snapshot failed: {e}");
        }
        let (bytes, sequence) = encode_snapshot(set, self.mode != JournalMode::Off)?;
        self.rotate(sequence)?;
        write_snapshot_file(&self.dir, &bytes)?;
        self.written += 1;
        self.covered(sequence)
    }

    /// Snapshots written since the store was opened (on every path).
    pub fn written(&self) -> u64 {
        self.written
    }

    /// Starts from `set` and forgets the saved state: the old journals go first, then a new empty
    /// journal, then the snapshot, so a crash in between leaves the old snapshot alone (never a new
    /// snapshot beside old records).
    pub fn begin(&mut self, set: &World) -> Result<(), PersistError> {
        if let Some(Err(e)) = self.wait_for_writer() {
            eprintln!("solver-service: a background snapshot failed: {e}");
        }
        self.journal = None;
        let path = self.journal_path();
        if path.exists() {
            std::fs::remove_file(&path).map_err(|e| io(&path, "cannot remove", e))?;
        }
        remove_journals(&self.dir, u64::MAX)?;
        self.pending.clear();
        // The new (empty) journal before the snapshot that says one follows it: a crash in between
        // leaves the old snapshot and an empty journal, never a snapshot whose journal is missing.
        self.start_journal(&self.journal_path())?;
        let (bytes, _) = encode_snapshot(set, self.mode != JournalMode::Off)?;
        write_snapshot_file(&self.dir, &bytes)?;
        self.written += 1;
        Ok(())
    }

    /// Starts a snapshot of `set` without waiting for the disk: the state is encoded and the journal
    /// rotated here (microseconds); the writer thread writes, syncs and renames the snapshot, then deletes
    /// the journal segments it covers. `Ok(false)`: the previous one is still being written (try later).
    /// Its outcome comes back through [`Store::finished`].
    pub fn snapshot_in_background(&mut self, set: &World) -> Result<bool, PersistError> {
        if self.writer.as_ref().is_some_and(|w| w.in_flight) {
            return Ok(false);
        }
        let (bytes, sequence) = encode_snapshot(set, self.mode != JournalMode::Off)?;
        // After a failed snapshot the last segment is still pending; the journal goes on in one file
        // until a snapshot succeeds (at most one segment waits), unless it must be replaced (unsound).
        if self.pending.is_empty() || self.unsound.is_some() {
            self.rotate(sequence)?;
        }
        #[cfg(test)]
        if self
            .fault
            .take_if(|f| *f == Fault::WriterNeverRuns)
            .is_some()
        {
            return Ok(true);
        }
        let w = match &mut self.writer {
            Some(w) => w,
            None => self.writer.insert(Writer::start(self.dir.clone())?),
        };
        w.jobs
            .as_ref()
            .and_then(|j| j.send(Job { bytes, sequence }).ok())
            .ok_or_else(|| {
                PersistError::Writer("the snapshot writer thread has ended".to_string())
            })?;
        w.in_flight = true;
        Ok(true)
    }

    /// The outcome of the background snapshot, once it is done (`Ok(sequence)` it holds).
    pub fn finished(&mut self) -> Option<Result<u64, PersistError>> {
        let w = self.writer.as_mut().filter(|w| w.in_flight)?;
        let r = match w.done.try_recv() {
            Ok(r) => r,
            Err(std::sync::mpsc::TryRecvError::Empty) => return None,
            Err(std::sync::mpsc::TryRecvError::Disconnected) => Err(PersistError::Writer(
                "the snapshot writer thread has ended".to_string(),
            )),
        };
        w.in_flight = false;
        Some(self.settle(r))
    }

    /// Waits for the background snapshot, if one is being written, and returns its outcome.
    fn wait_for_writer(&mut self) -> Option<Result<u64, PersistError>> {
        let w = self.writer.as_mut().filter(|w| w.in_flight)?;
        let r = w.done.recv().unwrap_or_else(|_| {
            Err(PersistError::Writer(
                "the snapshot writer thread has ended".to_string(),
            ))
        });
        w.in_flight = false;
        Some(self.settle(r))
    }

    fn settle(&mut self, r: Result<u64, PersistError>) -> Result<u64, PersistError> {
        if let Ok(sequence) = r {
            self.written += 1;
            self.pending.retain(|&n| n > sequence);
        }
        r
    }

    /// A snapshot of state `sequence` is on disk: the journal segments it covers go.
    fn covered(&mut self, sequence: u64) -> Result<(), PersistError> {
        remove_journals(&self.dir, sequence)?;
        self.pending.retain(|&n| n > sequence);
        Ok(())
    }

    /// Moves the journal aside as segment `sequence` (every record in it is at most `sequence`) and
    /// starts a new one: a fresh file, so an unsound journal is sound again. On the calling thread, no
    /// sync (with [`JournalMode::Fsync`], the new file and the directory are synced).
    fn rotate(&mut self, sequence: u64) -> Result<(), PersistError> {
        let path = self.journal_path();
        if self.mode == JournalMode::Off {
            self.journal = None;
            let _ = std::fs::remove_file(&path);
            return Ok(());
        }
        if self.pending.len() >= MAX_SEGMENTS {
            return Err(PersistError::Backlog {
                dir: self.dir.clone(),
                segments: self.pending.len(),
            });
        }
        // The new journal is made first: if that fails, nothing has changed.
        let fresh = self.dir.join("journal.bin.new");
        let mut f = self.create_journal(&fresh)?;
        let segment = segment_path(&self.dir, sequence);
        if path.exists() {
            if let Err(e) = std::fs::rename(&path, &segment) {
                let _ = std::fs::remove_file(&fresh);
                return Err(io(&path, "cannot move the journal aside", e));
            }
            self.pending.push(sequence);
        }
        if let Err(e) = std::fs::rename(&fresh, &path) {
            // The old journal is a segment now and the new one has no name: nothing may be
            // acknowledged until a snapshot succeeds.
            let why = io(&path, "cannot name the new journal", e);
            self.unsound = Some(why.to_string());
            self.journal = Some(f);
            self.journal_len = JOURNAL_MAGIC.len() as u64;
            return Err(why);
        }
        if self.mode == JournalMode::Fsync {
            f.sync_all()
                .and_then(|_| File::open(&self.dir)?.sync_all())
                .map_err(|e| io(&self.dir, "cannot sync", e))?;
        }
        f.seek(SeekFrom::End(0))
            .map_err(|e| io(&path, "cannot seek", e))?;
        self.journal_len = JOURNAL_MAGIC.len() as u64;
        self.unsound = None;
        self.journal = Some(f);
        Ok(())
    }

    /// A new journal file holding only the magic number.
    fn create_journal(&self, path: &Path) -> Result<File, PersistError> {
        let mut f = owner_only()
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)
            .map_err(|e| io(path, "cannot create", e))?;
        f.write_all(&JOURNAL_MAGIC)
            .map_err(|e| io(path, "cannot write", e))?;
        Ok(f)
    }

    fn start_journal(&mut self, path: &Path) -> Result<(), PersistError> {
        self.journal = None;
        if self.mode == JournalMode::Off {
            return Ok(());
        }
        let f = self.create_journal(path)?;
        f.sync_all().map_err(|e| io(path, "cannot sync", e))?;
        self.journal_len = JOURNAL_MAGIC.len() as u64;
        self.unsound = None;
        self.journal = Some(f);
        Ok(())
    }

    /// Appends an accepted request that produced state `sequence`. Must succeed before the response is
    /// sent. No allocation: the record is encoded into a buffer kept for the purpose.
    pub fn append(
        &mut self,
        sequence: u64,
        header: &RequestHeader,
        points: &[Vec3],
    ) -> Result<(), PersistError> {
        if self.journal.is_none() {
            return Ok(());
        }
        if let Some(why) = &self.unsound {
            return Err(PersistError::Unsound { why: why.clone() });
        }
        let rec = JournalRecordRef {
            sequence,
            header,
            points,
        };
        let n =
            bincode::serde::encode_into_slice(&rec, &mut self.buf[8..], config()).map_err(|e| {
                PersistError::Encode {
                    what: "a journal record",
                    why: e.to_string(),
                }
            })?;
        let crc = crc32fast::hash(&self.buf[8..8 + n]);
        self.buf[0..4].copy_from_slice(&(n as u32).to_le_bytes());
        self.buf[4..8].copy_from_slice(&crc.to_le_bytes());
        let len = 8 + n;
        match self.write_record(len) {
            Ok(()) => {
                self.journal_len += len as u64;
                Ok(())
            }
            Err(e) => match self.cut_back() {
                Ok(()) => Err(PersistError::WriteFailed { why: e.to_string() }),
                Err(c) => {
                    let why = format!("a write failed ({e}) and the cut back failed too ({c})");
                    self.unsound = Some(why.clone());
                    Err(PersistError::CutFailed { why })
                }
            },
        }
    }

    /// Writes (and with `Fsync` syncs) the record in `buf[..len]`.
    fn write_record(&mut self, len: usize) -> std::io::Result<()> {
        let f = self.journal.as_mut().ok_or(std::io::ErrorKind::NotFound)?;
        #[cfg(test)]
        if let Some(Fault::ShortWrite | Fault::ShortWriteThenCutFails) = self.fault {
            f.write_all(&self.buf[..len / 2])?;
            return Err(std::io::Error::other("injected short write"));
        }
        f.write_all(&self.buf[..len])?;
        if self.mode == JournalMode::Fsync {
            f.sync_data()?;
        }
        Ok(())
    }

    /// Truncates the journal to its last whole record and puts the write position there.
    fn cut_back(&mut self) -> std::io::Result<()> {
        #[cfg(test)]
        if let Some(fault) = self.fault.take()
            && fault == Fault::ShortWriteThenCutFails
        {
            return Err(std::io::Error::other("injected failure to truncate"));
        }
        let f = self.journal.as_mut().ok_or(std::io::ErrorKind::NotFound)?;
        f.set_len(self.journal_len)?;
        f.seek(SeekFrom::Start(self.journal_len))?;
        if self.mode == JournalMode::Fsync {
            f.sync_data()?;
        }
        Ok(())
    }

    /// Injects a fault into the next append.
    #[cfg(test)]
    pub(crate) fn inject(&mut self, fault: Fault) {
        self.fault = Some(fault);
    }

    /// Restores `set` (built from the same scene) from the snapshot and the journal, then compacts: a
    /// new snapshot of the restored state and an empty journal.
    ///
    /// A damaged snapshot is refused. A journal record that does not read is a torn tail only where a
    /// crash can leave one: at the end of the file, incomplete, with no whole record after it (then it
    /// was never acknowledged and is dropped, counted in `dropped_tail_bytes`). Anything else is damage:
    /// restore refuses, saying where and how many whole records follow, and changes no file; with
    /// `from_damaged` it restores the state before the damage, keeps the damaged files beside the new
    /// ones (`damaged-<state>-<name>`) and says what it dropped. A journal missing after a snapshot that
    /// says one follows is damage too.
    pub fn restore(
        &mut self,
        set: &mut World,
        from_damaged: bool,
    ) -> Result<Restored, PersistError> {
        let path = self.snapshot_path();
        let bound = snapshot_bound(set);
        let bytes = read_bounded(&path, bound)?;
        let SnapshotFile {
            snap,
            journal_follows,
        } = decode_snapshot_file(&bytes, &path)?;
        set.restore(&snap.state)
            .map_err(|e| io(&path, "does not fit the scene", e))?;
        let mut restored = Restored {
            snapshot_sequence: snap.state.sequence,
            replayed: 0,
            dropped_tail_bytes: 0,
            damage: None,
        };
        let journal = self.journal_path();
        if journal_follows && !journal.exists() && self.pending.is_empty() {
            let why = io(
                &journal,
                "missing",
                format!(
                    "the snapshot (state {}) says a journal follows it; the changes after it are unknown",
                    snap.state.sequence
                ),
            );
            if !from_damaged {
                return Err(PersistError::Damaged(format!(
                    "{why}; --restore-from-damaged restores the snapshot alone"
                )));
            }
            restored.damage = Some(format!("{why}: restored the snapshot alone"));
        }
        // Records were accepted under the budget of their time: replay them whatever today's is.
        let budget = set.budget();
        set.set_budget(u64::MAX);
        let mut files: Vec<PathBuf> = self
            .pending
            .iter()
            .map(|&n| segment_path(&self.dir, n))
            .collect();
        files.push(self.journal_path());
        let mut damaged: Vec<PathBuf> = Vec::new();
        for (k, jpath) in files.iter().enumerate().filter(|(_, p)| p.exists()) {
            // (A failed replay ends the start-up, so the error path need not restore the budget.)
            if let Err(damage) = replay(jpath, set, &mut restored) {
                let later = files[k + 1..].iter().filter(|p| p.exists()).count();
                let what = match later {
                    0 => damage.to_string(),
                    n => format!("{damage}; {n} later journal file(s) are not replayed either"),
                };
                if !from_damaged {
                    return Err(PersistError::Damaged(format!(
                        "{what}. The files are kept as they are; --restore-from-damaged restores state {} \
                         and drops the rest",
                        set.sequence()
                    )));
                }
                damaged.extend(files[k..].iter().filter(|p| p.exists()).cloned());
                restored.damage = Some(what);
                break;
            }
        }
        // Kept before compaction deletes the journals: the evidence of what was dropped.
        for f in &damaged {
            let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("journal");
            let keep = self.dir.join(format!("damaged-{}-{name}", set.sequence()));
            std::fs::copy(f, &keep).map_err(|e| io(&keep, "cannot keep a damaged journal", e))?;
        }
        if !damaged.is_empty()
            && let Some(d) = restored.damage.as_mut()
        {
            d.push_str(&format!(
                "; restored state {}, the damaged file(s) kept as damaged-{}-*",
                set.sequence(),
                set.sequence()
            ));
        }
        set.set_budget(budget);
        self.snapshot(set)?;
        Ok(restored)
    }
}

/// At most this many journal segments wait for a snapshot (one normally; more only after a journal
/// became unsound while a snapshot failed).
const MAX_SEGMENTS: usize = 64;

/// A snapshot for the writer thread: the encoded state and its sequence number.
struct Job {
    bytes: Vec<u8>,
    sequence: u64,
}

/// The snapshot writer thread and the channels to it (one job at a time).
#[derive(Debug)]
struct Writer {
    jobs: Option<std::sync::mpsc::SyncSender<Job>>,
    done: std::sync::mpsc::Receiver<Result<u64, PersistError>>,
    in_flight: bool,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl std::fmt::Debug for Job {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Job({} bytes, state {})",
            self.bytes.len(),
            self.sequence
        )
    }
}

impl Writer {
    fn start(dir: PathBuf) -> Result<Self, PersistError> {
        let (jobs, rx) = std::sync::mpsc::sync_channel::<Job>(1);
        let (tx, done) = std::sync::mpsc::sync_channel(1);
        let thread = std::thread::Builder::new()
            .name("snapshot-writer".into())
            .spawn(move || {
                while let Ok(job) = rx.recv() {
                    let r = write_snapshot_file(&dir, &job.bytes)
                        .and_then(|()| remove_journals(&dir, job.sequence))
                        .map(|()| job.sequence);
                    if tx.send(r).is_err() {
                        break;
                    }
                }
            })
            .map_err(|e| {
                PersistError::Writer(format!("cannot start the snapshot writer thread: {e}"))
            })?;
        Ok(Writer {
            jobs: Some(jobs),
            done,
            in_flight: false,
            thread: Some(thread),
        })
    }
}

impl Drop for Writer {
    fn drop(&mut self) {
        // Closing the job channel ends the thread after the snapshot it is writing.
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The state of `set` as a snapshot file's bytes (envelope and body), and its sequence number;
/// `journal` says whether a journal follows it.
fn encode_snapshot(set: &World, journal: bool) -> Result<(Vec<u8>, u64), PersistError> {
    let snap = Snapshot {
        magic: SNAPSHOT_MAGIC,
        state: set.state(),
    };
    let body =
        bincode::serde::encode_to_vec(&snap, config()).map_err(|e| PersistError::Encode {
            what: "the snapshot",
            why: e.to_string(),
        })?;
    let flags = if journal { FLAG_JOURNAL_FOLLOWS } else { 0 };
    let mut bytes = Vec::with_capacity(ENVELOPE_BYTES + body.len());
    bytes.extend_from_slice(&SNAPSHOT_ENVELOPE);
    bytes.extend_from_slice(&(body.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&[0; 4]);
    bytes.extend_from_slice(&flags.to_le_bytes());
    bytes.extend_from_slice(&body);
    let crc = crc32fast::hash(&bytes[20..]);
    bytes[16..20].copy_from_slice(&crc.to_le_bytes());
    Ok((bytes, set.sequence()))
}

/// Writes `bytes` to a temporary file, syncs it, renames it over `snapshot.bin` and syncs the directory:
/// a crash leaves the old snapshot or the new one. A failed write removes its temporary file (on a full
/// file system it would hold the space).
fn write_snapshot_file(dir: &Path, bytes: &[u8]) -> Result<(), PersistError> {
    let path = dir.join("snapshot.bin");
    let tmp = dir.join("snapshot.bin.tmp");
    let mut f = owner_only()
        .write(true)
        .create(true)
        .truncate(true)
        .open(&tmp)
        .map_err(|e| io(&tmp, "cannot create", e))?;
    if let Err(e) = f.write_all(bytes).and_then(|_| f.sync_all()) {
        drop(f);
        let _ = std::fs::remove_file(&tmp);
        return Err(io(&tmp, "cannot write", e));
    }
    std::fs::rename(&tmp, &path).map_err(|e| io(&path, "cannot rename into place", e))?;
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| io(dir, "cannot sync", e))
}

/// The path of the journal segment that ends at or before state `sequence`.
fn segment_path(dir: &Path, sequence: u64) -> PathBuf {
    dir.join(format!("journal-{sequence:020}.bin"))
}

/// The journal segments in `dir`, oldest first (at most [`MAX_SEGMENTS`]).
fn list_segments(dir: &Path) -> Result<Vec<u64>, PersistError> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| io(dir, "cannot list", e))? {
        let name = entry.map_err(|e| io(dir, "cannot list", e))?.file_name();
        let Some(n) = name
            .to_str()
            .and_then(|n| n.strip_prefix("journal-")?.strip_suffix(".bin"))
            .and_then(|n| n.parse::<u64>().ok())
        else {
            continue;
        };
        if found.len() == MAX_SEGMENTS {
            return Err(io(
                dir,
                "too many journal segments",
                format!("more than {MAX_SEGMENTS}"),
            ));
        }
        found.push(n);
    }
    found.sort_unstable();
    Ok(found)
}

/// Removes the journal segments that end at or before `sequence`.
fn remove_journals(dir: &Path, sequence: u64) -> Result<(), PersistError> {
    for n in list_segments(dir)? {
        if n <= sequence {
            let p = segment_path(dir, n);
            std::fs::remove_file(&p).map_err(|e| io(&p, "cannot remove", e))?;
        }
    }
    Ok(())
}

/// Replays the journal file `jpath` onto `set`, streamed record by record (memory is bounded by one
/// record, whatever the journal's size). Records the state already holds are skipped; a gap is an
/// error. A record that does not read ends the file: a torn tail ([`is_torn_tail`]: a write cut by a
/// crash or a failed append, never acknowledged) is dropped and counted; anything else is damage, an
/// error that says where and how many whole records follow.
fn replay(jpath: &Path, set: &mut World, restored: &mut Restored) -> Result<(), PersistError> {
    let file = File::open(jpath).map_err(|e| io(jpath, "cannot open", e))?;
    let file_len = file
        .metadata()
        .map_err(|e| io(jpath, "cannot stat", e))?
        .len();
    let mut input = std::io::BufReader::new(file);
    let mut magic = [0u8; 8];
    if input.read_exact(&mut magic).is_err() || magic != JOURNAL_MAGIC {
        return Err(io(
            jpath,
            "damaged journal",
            format!("no journal header ({file_len} bytes)"),
        ));
    }
    let mut at = 8u64;
    let mut body = Vec::new();
    while at < file_len {
        let Some((rec, len)) = next_record(&mut input, &mut body) else {
            let mut f = File::open(jpath).map_err(|e| io(jpath, "cannot open", e))?;
            if is_torn_tail(&mut f, at, file_len).map_err(|e| io(jpath, "cannot read", e))? {
                restored.dropped_tail_bytes += file_len - at;
                break;
            }
            let follow =
                records_after(&mut f, at + 1, file_len).map_err(|e| io(jpath, "cannot read", e))?;
            return Err(io(
                jpath,
                "damaged journal",
                format!(
                    "the record at byte {at} (after state {}) does not read; {}",
                    set.sequence(),
                    match follow {
                        Some((first, n)) => format!(
                            "{n} whole record(s) follow it, from byte {first}: acknowledged changes that would be lost"
                        ),
                        None => "no whole record follows it".to_string(),
                    }
                ),
            ));
        };
        at += len;
        if rec.sequence <= set.sequence() {
            continue;
        }
        if rec.sequence != set.sequence() + 1 {
            return Err(io(
                jpath,
                "gap",
                format!("record {} follows state {}", rec.sequence, set.sequence()),
            ));
        }
        match set.apply_wire(&rec.header, &rec.points) {
            Ok(o) if o.changed => {}
            Ok(_) => {
                return Err(io(
                    jpath,
                    "does not replay on this scene",
                    format!("record {}: changes nothing", rec.sequence),
                ));
            }
            Err(r) => {
                return Err(io(
                    jpath,
                    "does not replay on this scene",
                    format!("record {}: {}", rec.sequence, r.reason()),
                ));
            }
        }
        restored.replayed += 1;
    }
    Ok(())
}

/// Whether the bytes of `f` from `at` to `len`, where a record does not read, are what a crash during
/// an append leaves: an incomplete header, a header whose body the file does not hold in full (and
/// whose checksum does not fit what is there), or zeros (a file extended without its data), and no
/// whole record after `at`. A complete record with a wrong checksum, a length beyond any record, or a
/// whole record after it, is damage.
fn is_torn_tail(f: &mut File, at: u64, len: u64) -> std::io::Result<bool> {
    let rest = len - at;
    if rest < 8 {
        return Ok(true);
    }
    let mut head = [0u8; 8];
    f.seek(SeekFrom::Start(at))?;
    f.read_exact(&mut head)?;
    let n = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as u64;
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if rest > (8 + MAX_RECORD_BYTES) as u64 {
        // No single record is this long: more than one was written after this point.
        return Ok(false);
    }
    let mut tail = Vec::with_capacity(rest as usize - 8);
    f.take(rest - 8).read_to_end(&mut tail)?;
    if head.iter().chain(&tail).all(|&b| b == 0) {
        return Ok(true);
    }
    let incomplete = n as usize <= MAX_RECORD_BYTES && 8 + n > rest;
    Ok(incomplete && crc32fast::hash(&tail) != crc && records_after(f, at + 1, len)?.is_none())
}

/// The first whole record (length, checksum and decoding all right) at or after byte `from` of `f`,
/// and how many whole records follow in a row from there (`None`: none). Scans byte by byte, a window
/// at a time (memory bounded by the window and one record).
fn records_after(f: &mut File, from: u64, len: u64) -> std::io::Result<Option<(u64, u64)>> {
    const STEP: usize = 1 << 22;
    let mut buf = Vec::new();
    let mut start = from;
    let mut record = Vec::new();
    while start + 8 <= len {
        let want = ((len - start) as usize).min(STEP + 8 + MAX_RECORD_BYTES);
        buf.resize(want, 0);
        f.seek(SeekFrom::Start(start))?;
        f.read_exact(&mut buf)?;
        for k in 0..want.min(STEP) {
            let mut cursor = &buf[k..];
            if next_record(&mut cursor, &mut record).is_some() {
                let first = start + k as u64;
                f.seek(SeekFrom::Start(first))?;
                let mut input = std::io::BufReader::new(&mut *f);
                let mut n = 0;
                while next_record(&mut input, &mut record).is_some() {
                    n += 1;
                }
                return Ok(Some((first, n)));
            }
        }
        start += want.min(STEP) as u64;
    }
    Ok(None)
}

fn owner_only() -> OpenOptions {
    let mut o = OpenOptions::new();
    o.mode(0o600);
    o
}

fn read_bounded(path: &Path, bound: u64) -> Result<Vec<u8>, PersistError> {
    let f = File::open(path).map_err(|e| io(path, "cannot open", e))?;
    let len = f.metadata().map_err(|e| io(path, "cannot stat", e))?.len();
    if len > bound {
        return Err(io(
            path,
            "too large",
            format!("{len} bytes, at most {bound} expected"),
        ));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    f.take(bound)
        .read_to_end(&mut bytes)
        .map_err(|e| io(path, "cannot read", e))?;
    Ok(bytes)
}

/// The most bytes a snapshot of this scene can take (varint-encoded lengths are smaller).
fn snapshot_bound(set: &World) -> u64 {
    64 + ENVELOPE_BYTES as u64
        + set
            .specs()
            .iter()
            .map(|s| {
                128 + 9 * 8 * (s.lengths.len() as u64 + 1)
                    + s.name.len() as u64
                    + 16 * 8 * u64::from(shared::MAX_HELD)
                    + s.collision
                        .as_ref()
                        .map_or(0, |c| 16 + 64 * c.instruments.len() as u64)
            })
            .sum::<u64>()
}

/// The next whole record of a journal stream and its length in bytes; `None` at a torn or corrupt
/// record (or the end). `buf` holds the record's body (at most [`MAX_RECORD_BYTES`]).
fn next_record(input: &mut impl Read, buf: &mut Vec<u8>) -> Option<(JournalRecord, u64)> {
    let mut head = [0u8; 8];
    input.read_exact(&mut head).ok()?;
    let n = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if n > MAX_RECORD_BYTES {
        return None;
    }
    buf.resize(n, 0);
    input.read_exact(&mut buf[..n]).ok()?;
    if crc32fast::hash(&buf[..n]) != crc {
        return None;
    }
    let (rec, used): (JournalRecord, usize) =
        bincode::serde::decode_from_slice(&buf[..n], config()).ok()?;
    (used == n && rec.points.len() <= MAX_PATH_POINTS as usize).then_some((rec, 8 + n as u64))
}

#[cfg(test)]
mod tests;
