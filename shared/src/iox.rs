//! The iceoryx2 configuration every process of this protocol uses (the service, the Rust clients, the C
//! library; the Python client mirrors it in `tractrix_client.py`), and the node helpers around it.
//!
//! # Where iceoryx2 keeps its files
//!
//! iceoryx2 keeps its node and service files under a root directory (its default `/tmp/iceoryx2/`, made
//! owner-only by the first user who runs anything with it; another user's processes then cannot create
//! a node). So that two users of one machine never collide, the root directory is **per user**:
//!
//! 1. If iceoryx2 finds a configuration file, in its own order (`config/iceoryx2.toml` in the working
//!    directory, then the user's `~/.config/iceoryx2/iceoryx2.toml`, then `/etc/iceoryx2/iceoryx2.toml`),
//!    that file is used as it is, root path included.
//! 2. Otherwise iceoryx2's defaults are used with the root path [`IOX_ROOT_BASE`] followed by the user's
//!    numeric id: `/tmp/iceoryx2.1000/` for uid 1000.
//!
//! Processes see each other only with the same root path and the same prefix. The shared-memory
//! segments in `/dev/shm` are named by the prefix and ids that are unique per creation, so two users
//! with the same prefix do not collide there either.

use iceoryx2::prelude::SemanticString;
use std::path::PathBuf;

/// The start of the per-user root directory, followed by the user's numeric id and `/`.
pub const IOX_ROOT_BASE: &str = "/tmp/iceoryx2.";

/// The configuration file iceoryx2 itself loads (the first of its three places that exists), or `None`.
pub fn iceoryx_config_file() -> Option<PathBuf> {
    let mut places = vec![PathBuf::from("config/iceoryx2.toml")];
    // iceoryx2 takes the home directory from the password database, not from $HOME.
    if let Ok(user) = iceoryx2_bb_posix::user::User::from_self()
        && let Some(details) = user.details()
        && let Ok(dir) = std::str::from_utf8(details.config_dir().as_bytes())
    {
        places.push(PathBuf::from(dir).join("iceoryx2/iceoryx2.toml"));
    }
    places.push(PathBuf::from("/etc/iceoryx2/iceoryx2.toml"));
    places.into_iter().find(|p| p.is_file())
}

/// The numeric id of the user this process runs as (the owner of `/proc/self`), as the machine sees
/// it: inside a user namespace (`unshare -U`), mapped out through `/proc/self/uid_map`, so a process
/// that is root in its namespace still uses its user's own directory.
fn uid() -> Option<u32> {
    use std::os::unix::fs::MetadataExt;
    let uid = std::fs::metadata("/proc/self").ok()?.uid();
    let map = std::fs::read_to_string("/proc/self/uid_map").unwrap_or_default();
    Some(outside_uid(uid, &map))
}

/// `uid` mapped by a `uid_map` text (lines of `inside outside count`); itself where no line maps it.
fn outside_uid(uid: u32, map: &str) -> u32 {
    map.lines()
        .filter_map(|l| {
            let n: Vec<u64> = l
                .split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect();
            (n.len() == 3).then(|| (n[0], n[1], n[2]))
        })
        .find(|&(inside, _, count)| (inside..inside + count).contains(&u64::from(uid)))
        .and_then(|(inside, outside, _)| u32::try_from(outside + (u64::from(uid) - inside)).ok())
        .unwrap_or(uid)
}

/// The iceoryx2 configuration of one instance: iceoryx2's global configuration (its configuration file
/// when there is one, see the module's documentation; else its defaults with the per-user root path),
/// with `prefix` (a valid file-name prefix such as `tractrix_` or `kt1234_7_`).
pub fn iceoryx_config(prefix: &str) -> Result<iceoryx2::config::Config, String> {
    if prefix.is_empty()
        || prefix.len() > 64
        || !prefix
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-' || b == b'.')
    {
        return Err(format!(
            "prefix {prefix:?}: use 1..=64 characters from [A-Za-z0-9_.-]"
        ));
    }
    // iceoryx2 warns on stderr that no config file exists; the defaults are what we want.
    if std::env::var_os("IOX2_LOG_LEVEL").is_none() {
        iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
    }
    let mut cfg = iceoryx2::config::Config::global_config().clone();
    if iceoryx_config_file().is_none() {
        let uid = uid().ok_or("cannot read this process's user id from /proc/self")?;
        let root = format!("{IOX_ROOT_BASE}{uid}/");
        let path = iceoryx2::prelude::Path::new(root.as_bytes())
            .map_err(|e| format!("root path {root}: {e:?}"))?;
        cfg.global.set_root_path(&path);
    }
    cfg.global.prefix = iceoryx2::prelude::FileName::new(prefix.as_bytes())
        .map_err(|e| format!("prefix {prefix:?}: {e:?}"))?;
    Ok(cfg)
}

/// The root directory of `cfg` (with its trailing `/`).
pub fn iceoryx_root(cfg: &iceoryx2::config::Config) -> String {
    String::from_utf8_lossy(cfg.global.root_path().as_bytes()).into_owned()
}

/// Why iceoryx2 could not create a node under `cfg`, when the reason is its root directory: made by
/// another user (iceoryx2 makes it owner-only), where this process cannot create its files. `None`
/// when the directory is missing or writable.
pub fn iceoryx_root_problem(cfg: &iceoryx2::config::Config) -> Option<String> {
    use std::os::unix::fs::MetadataExt;
    let root = iceoryx_root(cfg);
    let dir = std::path::Path::new(&root);
    let owner = std::fs::metadata(dir).ok()?.uid();
    let probe = dir.join(format!(".tractrix-probe-{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            None
        }
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => Some(format!(
            "iceoryx2's root directory {root} belongs to another user (uid {owner}), so this user \
             cannot open iceoryx2 ports there. Give this user a root path of its own: `[global] \
             root-path = \"/tmp/iceoryx2.mine/\"` in ~/.config/iceoryx2/iceoryx2.toml{}",
            match iceoryx_config_file() {
                Some(f) => format!(" (the file in use now: {})", f.display()),
                None => String::new(),
            }
        )),
        Err(_) => None,
    }
}

/// Sleeps `d` on `node` and says whether SIGINT or SIGTERM asks the process to stop. A signal that only
/// interrupts the sleep is not a stop: iceoryx2's `Node::wait` reports any interrupted sleep as
/// `Interrupt`, so a process stopped and continued (Ctrl-Z then `fg`, a debugger, a frozen container)
/// would otherwise quit when continued; after such an interruption the termination flag is asked
/// again.
pub fn stop_requested<S: iceoryx2::service::Service>(
    node: &iceoryx2::node::Node<S>,
    d: std::time::Duration,
) -> bool {
    match node.wait(d) {
        Ok(()) => false,
        Err(iceoryx2::node::NodeWaitFailure::TerminationRequest) => true,
        Err(iceoryx2::node::NodeWaitFailure::Interrupt) => {
            node.wait(std::time::Duration::ZERO).is_err()
        }
    }
}

/// A service name of this protocol (one of the `SERVICE_*` constants).
pub fn service_name(s: &str) -> Result<iceoryx2::prelude::ServiceName, String> {
    s.try_into().map_err(|e| format!("service name {s}: {e:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_root_is_the_config_files_or_the_users_own() {
        let root = iceoryx_root(&iceoryx_config("tractrix_").unwrap());
        if iceoryx_config_file().is_some() {
            // This machine's user chose a root path: the file's, as iceoryx2 loaded it.
            let global = iceoryx2::config::Config::global_config();
            assert_eq!(root, iceoryx_root(global));
            return;
        }
        // The machine's id of this process's user, found here: the owner of /proc/self, mapped out
        // of a user namespace by the line of uid_map (`inside outside count`) that holds it.
        let uid = std::fs::metadata("/proc/self")
            .map(|m| u64::from(std::os::unix::fs::MetadataExt::uid(&m)))
            .unwrap();
        let map = std::fs::read_to_string("/proc/self/uid_map").unwrap_or_default();
        let mut outside = uid;
        for line in map.lines() {
            let f: Vec<u64> = line
                .split_whitespace()
                .map(|w| w.parse().unwrap())
                .collect();
            if f.len() == 3 && f[0] <= uid && uid < f[0] + f[2] {
                outside = f[1] + (uid - f[0]);
                break;
            }
        }
        assert_eq!(root, format!("/tmp/iceoryx2.{outside}/"));
    }

    #[test]
    fn a_user_namespace_maps_root_to_its_user() {
        assert_eq!(outside_uid(0, "         0       1001          1\n"), 1001);
        assert_eq!(outside_uid(5, "0 100000 65536\n"), 100005);
        assert_eq!(outside_uid(1000, "0 0 4294967295\n"), 1000);
        assert_eq!(outside_uid(7, ""), 7);
    }

    #[test]
    fn a_bad_prefix_is_refused() {
        for p in ["", "a/b", &"x".repeat(65)] {
            assert!(iceoryx_config(p).is_err(), "{p:?}");
        }
    }
}
