//! The service's shared memory, reserved at start (issue 35). iceoryx2's segments are sparse files in
//! `/dev/shm`: a page is backed only when first written, so with `/dev/shm` filled by someone else a
//! running service died with SIGBUS at its next large response, and could not start again. After the
//! ports are open, every segment of the instance's prefix is allocated (`fallocate`): a full
//! `/dev/shm` then fails the start with a message naming it, and a running service writes only into
//! memory it already holds.

use std::path::{Path, PathBuf};

/// Why the shared memory could not be checked or reserved.
#[derive(Debug, thiserror::Error)]
pub enum ShmError {
    /// `dir` could not be read.
    #[error("{}: cannot {what}: {source}", dir.display())]
    Read {
        /// The directory or file.
        dir: PathBuf,
        /// What was tried (stat, list).
        what: &'static str,
        /// The system's error.
        source: std::io::Error,
    },
    /// Less room than the ports need to open.
    #[error(
        "shared memory: {} has {free} bytes free, less than the {MIN_FREE} the service needs to \
         open its ports (`df -h {}`); free it",
        dir.display(),
        dir.display()
    )]
    Full {
        /// Where.
        dir: PathBuf,
        /// Bytes free.
        free: u64,
    },
    /// A segment could not be allocated.
    #[error(
        "shared memory: cannot reserve the {len} bytes of {} ({source}): {} has no room \
         (`df -h {}`); free it, or give the service a smaller scene",
        file.display(),
        dir.display(),
        dir.display()
    )]
    Reserve {
        /// The segment.
        file: PathBuf,
        /// Its length.
        len: u64,
        /// Its directory.
        dir: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
}

fn read(dir: &Path, what: &'static str) -> impl FnOnce(std::io::Error) -> ShmError {
    let dir = dir.to_path_buf();
    move |source| ShmError::Read { dir, what, source }
}

/// Where POSIX shared memory lives on Linux.
pub const SHM_DIR: &str = "/dev/shm";

/// Least free room in `dir` to open the ports at all: iceoryx2 writes its segments' management data
/// while creating them, before [`reserve`] can run, and dies with SIGBUS if even that has no room
/// (seen with 8 KiB free).
pub const MIN_FREE: u64 = 256 << 10;

/// Fails with a message naming `dir` if it has less than [`MIN_FREE`] bytes free (nothing to check
/// where `dir` does not exist).
pub fn check_room(dir: &Path) -> Result<(), ShmError> {
    if !dir.is_dir() {
        return Ok(());
    }
    let st = rustix::fs::statvfs(dir).map_err(|e| read(dir, "stat")(e.into()))?;
    let free = st.f_bavail.saturating_mul(st.f_frsize);
    if free < MIN_FREE {
        return Err(ShmError::Full {
            dir: dir.to_path_buf(),
            free,
        });
    }
    Ok(())
}

/// Allocates every file of `dir` whose name starts with `prefix` (the instance's iceoryx2 prefix) to
/// its full length. Returns the files and bytes reserved; nothing to do where `dir` does not exist.
pub fn reserve(dir: &Path, prefix: &str) -> Result<(usize, u64), ShmError> {
    reserve_where(dir, |name| name.starts_with(prefix))
}

/// [`reserve`] for the files of `dir` whose names `pick` accepts.
pub fn reserve_where(dir: &Path, pick: impl Fn(&str) -> bool) -> Result<(usize, u64), ShmError> {
    if !dir.is_dir() {
        return Ok((0, 0));
    }
    let list = std::fs::read_dir(dir).map_err(read(dir, "list"))?;
    let (mut files, mut bytes) = (0, 0);
    for entry in list {
        let entry = entry.map_err(read(dir, "list"))?;
        let name = entry.file_name();
        if !name.to_str().is_some_and(&pick) {
            continue;
        }
        let path = entry.path();
        let f = match std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
        {
            Ok(f) => f,
            // Gone since listed (a client that left), or not ours to write: not the service's.
            Err(_) => continue,
        };
        let meta = f.metadata().map_err(read(&path, "stat"))?;
        let len = meta.len();
        if !meta.is_file() || len == 0 {
            continue;
        }
        rustix::fs::fallocate(&f, rustix::fs::FallocateFlags::empty(), 0, len).map_err(|e| {
            ShmError::Reserve {
                file: path.clone(),
                len,
                dir: dir.to_path_buf(),
                source: e.into(),
            }
        })?;
        files += 1;
        bytes += len;
    }
    Ok((files, bytes))
}
