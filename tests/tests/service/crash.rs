//! The journal against crashes and a full file system (issue 15): `kill -9` at random points while a
//! client streams changes and background snapshots come and go, and a state directory on a tmpfs that
//! fills up. After each, a restore holds every acknowledged change and nothing else.
//!
//! The expected state comes from a mirror: the test applies every request it sends to a
//! [`World`] of its own (the kernel is deterministic, so the mirror matches the service bit for bit;
//! each response is checked against it). A request whose response was lost with the process may or may
//! not have reached the journal before the kill: the restored state is the last acknowledged one, or
//! the one that request produces, and nothing else.

use clients::{ConnectOptions, Connection, Wait};
use shared::{Command, RequestHeader, Status, Vec3};
use solver_service::wire::WireWorld;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tests::{Service, unique_prefix};
use world::World;
use world::scene::default_scene;

/// Every chain's joints as bits, and the sequence number, from the mirror.
fn mirror_state(set: &World) -> (Vec<u64>, u64) {
    let bits = (0..set.len() as u32)
        .flat_map(|c| set.elements_of(c, false).collect::<Vec<_>>())
        .flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect();
    (bits, set.sequence())
}

/// Every chain's joints as bits, and the sequence number, from the service.
fn served_state(c: &mut Connection, chains: u32) -> (Vec<u64>, u64) {
    let mut bits = Vec::new();
    let mut seq = 0;
    for chain in 0..chains {
        let r = c
            .call(RequestHeader::new(Command::Query, chain), &[])
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        seq = r.header.sequence;
        bits.extend(
            r.joints()
                .iter()
                .flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]),
        );
    }
    (bits, seq)
}

/// The `i`-th change the client sends: moves of the rope, paths of the snake, reaches of the arm.
fn change(i: u64) -> (RequestHeader, Vec<Vec3>) {
    let t = i as f64 * 0.05;
    match i % 3 {
        0 => (
            RequestHeader::new(Command::Move, 0),
            vec![Vec3::new(30.0 * t.cos(), 30.0 * t.sin(), (0.1 * t).sin())],
        ),
        1 => (
            RequestHeader::new(Command::Path, 1),
            vec![
                Vec3::new(t.sin(), -50.0 + 0.1 * t, 0.5),
                Vec3::new(t.cos(), -49.0 + 0.1 * t, 1.0),
            ],
        ),
        _ => (
            RequestHeader::new(Command::Reach, 2),
            vec![Vec3::new(1.5 * t.cos(), 1.5 * t.sin(), 0.0)],
        ),
    }
}

/// A small generator for the kill times (xorshift64*), seeded from the clock or `CRASH_SEED`.
struct Rng(u64);
impl Rng {
    fn new() -> (Rng, u64) {
        let seed = std::env::var("CRASH_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(1, |d| d.as_nanos() as u64)
                    | 1
            });
        (Rng(seed), seed)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) % n
    }
}

fn connect(svc: &Service, call_timeout: Duration) -> Connection {
    Connection::connect(ConnectOptions {
        prefix: svc.prefix.clone(),
        wait: Wait::Event,
        connect_timeout: Duration::from_secs(5),
        call_timeout,
        max_request_points: 16,
    })
    .expect("connect to the service")
}

/// Sends changes until the process dies (`killed` was set before the kill; a failed call before it is
/// a failure). Returns the mirror after the last acknowledged change and the mirror with the change in
/// flight at the kill applied (when its response was lost).
fn stream_until_killed(
    c: &mut Connection,
    mirror: &mut World,
    next: &mut u64,
    killed: &AtomicBool,
) -> Option<World> {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        assert!(Instant::now() < deadline, "the service was never killed");
        let (h, p) = change(*next);
        let mut ahead = mirror.clone();
        let expected = ahead.apply_wire(&h, &p).map(|o| o.changed);
        match c.call(h, &p) {
            Ok(r) => {
                match expected {
                    Ok(_) => assert!(r.is_ok(), "change {next}: {}", r.header.reason_str()),
                    Err(e) => {
                        assert!(
                            !r.is_ok(),
                            "change {next}: the mirror refused: {}",
                            e.reason()
                        )
                    }
                }
                *mirror = ahead;
                assert_eq!(r.header.sequence, mirror.sequence(), "change {next}");
                *next += 1;
            }
            Err(e) => {
                assert!(
                    killed.load(Ordering::SeqCst),
                    "change {next} failed before the kill: {e}"
                );
                return expected.is_ok_and(|changed| changed).then_some(ahead);
            }
        }
    }
}

/// `kill -9` at random points of a stream of changes, with a background snapshot every 5 ms (so kills
/// land before, during and after journal rotations and snapshot renames), twelve times over one state
/// directory: each restore holds every acknowledged change, and nothing unacknowledged but the one
/// change whose response the kill cut off.
#[test]
fn kill_9_at_random_points_loses_no_acknowledged_change() {
    let (mut rng, seed) = Rng::new();
    eprintln!("kill -9 at random points: CRASH_SEED={seed}");
    let dir = tempfile::tempdir().unwrap();
    let state_dir = dir.path().join("state");
    let d = state_dir.to_str().unwrap();
    let mut mirror = World::new(&default_scene()).unwrap();
    let chains = mirror.len() as u32;
    let mut next = 0u64;
    let (mut acknowledged_only, mut with_lost_response) = (0, 0);
    for round in 0..12 {
        let mut args = vec!["--state-dir", d, "--snapshot-every", "0.005"];
        if round > 0 {
            args.push("--restore");
        }
        let svc = Service::start(&unique_prefix(), &args);
        // A call to a killed service ends at this timeout.
        let mut c = connect(&svc, Duration::from_secs(1));
        assert_eq!(
            served_state(&mut c, chains),
            mirror_state(&mirror),
            "round {round}: the restored state is not the last acknowledged one ({})",
            svc.ready_line
        );
        let killed = Arc::new(AtomicBool::new(false));
        let pid = svc.id();
        let delay = Duration::from_millis(10 + rng.below(150));
        let killer = {
            let killed = killed.clone();
            std::thread::spawn(move || {
                std::thread::sleep(delay);
                killed.store(true, Ordering::SeqCst);
                let s = std::process::Command::new("kill")
                    .args(["-9", &pid.to_string()])
                    .status();
                assert!(s.is_ok_and(|s| s.success()), "kill -9 {pid}");
            })
        };
        let in_flight = stream_until_killed(&mut c, &mut mirror, &mut next, &killed);
        killer.join().unwrap();
        drop(c);
        drop(svc);
        // Which of the two states did the disk keep? Restore and look.
        let svc = Service::start(&unique_prefix(), &["--state-dir", d, "--restore"]);
        let mut c = connect(&svc, Duration::from_secs(10));
        let restored = served_state(&mut c, chains);
        if restored == mirror_state(&mirror) {
            acknowledged_only += 1;
        } else if let Some(ahead) = in_flight.filter(|a| restored == mirror_state(a)) {
            // The change reached the journal; its response was lost with the process.
            mirror = ahead;
            next += 1;
            with_lost_response += 1;
        } else {
            panic!(
                "round {round} (CRASH_SEED={seed}, killed after {delay:?}): restored state {} is \
                 neither the last acknowledged {} nor the one after it ({})",
                restored.1,
                mirror.sequence(),
                svc.ready_line
            );
        }
        // Killed again, so that every round restores from what a kill left.
        drop(c);
        svc.kill9();
    }
    eprintln!(
        "12 kills: {next} changes acknowledged; the restore held the last acknowledged state \
         {acknowledged_only} times, and the change whose response the kill cut off \
         {with_lost_response} times"
    );
    assert!(next > 12, "only {next} changes in 12 rounds");
}

/// A tmpfs of its own, unmounted on drop (lazily: a killed service may still hold files).
struct Tmpfs {
    path: std::path::PathBuf,
}

impl Tmpfs {
    /// Mounts it, which needs root (CAP_SYS_ADMIN): as a normal user the test is skipped with one
    /// line (`None`), except under `CI=true`, where nothing may be skipped.
    fn mount(path: &Path, bytes: u64) -> Option<Tmpfs> {
        std::fs::create_dir_all(path).unwrap();
        let out = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o"])
            .arg(format!("size={bytes},mode=0700"))
            .arg("tmpfs")
            .arg(path)
            .output()
            .expect("run mount");
        if out.status.success() {
            return Some(Tmpfs {
                path: path.to_path_buf(),
            });
        }
        let root = std::fs::read_to_string("/proc/self/status").is_ok_and(|s| {
            s.lines()
                .any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(2) == Some("0"))
        });
        if !root && std::env::var("CI").as_deref() != Ok("true") {
            tests::skip(
                "the full-disk test: mounting a tmpfs to fill needs root (CI runs it as root)",
            );
            return None;
        }
        panic!(
            "this test mounts a small tmpfs to fill it, which needs root (CAP_SYS_ADMIN), as on the \
             CI machine: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg("-l")
            .arg(&self.path)
            .status();
    }
}

/// Fills the file system holding `dir` with one file, until a write fails.
fn fill(dir: &Path) -> std::path::PathBuf {
    use std::io::Write;
    let path = dir.join("filler");
    let mut f = std::fs::File::create(&path).unwrap();
    let block = [0u8; 512];
    loop {
        if let Err(e) = f.write_all(&block).and_then(|_| f.flush()) {
            assert_eq!(e.raw_os_error(), Some(28), "ENOSPC expected: {e}");
            break;
        }
    }
    path
}

/// The state directory on a 512 KiB tmpfs, filled: changes whose records no longer fit are refused
/// with `persistence-failed` and leave the state as it was (queries are still served, and periodic snapshots fail without harm);
/// once space is freed, changes are accepted again; `kill -9` then a restore holds exactly the
/// acknowledged changes.
#[test]
fn a_full_file_system_refuses_changes_and_loses_no_acknowledged_one() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fs) = Tmpfs::mount(&dir.path().join("fs"), 512 * 1024) else {
        return;
    };
    let state_dir = fs.path.join("state");
    let d = state_dir.to_str().unwrap();
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--state-dir",
            d,
            "--snapshot-every",
            "0.02",
            "--wait",
            "event",
        ],
    );
    let mut c = connect(&svc, Duration::from_secs(10));
    let mut mirror = World::new(&default_scene()).unwrap();
    let chains = mirror.len() as u32;
    let filler = fill(&fs.path);
    // Appends go on into the journal's last page, then fail.
    let mut next = 0u64;
    let (mut accepted, mut refused) = (0, 0);
    while refused < 50 {
        assert!(
            next < 100_000,
            "no journal write failed on a full file system"
        );
        let (h, p) = change(next);
        next += 1;
        let mut ahead = mirror.clone();
        let expected = ahead.apply_wire(&h, &p);
        let r = c.call(h, &p).unwrap();
        if r.is_ok() {
            // (A short record may still fit where a longer one did not.)
            assert!(expected.is_ok());
            mirror = ahead;
            accepted += 1;
        } else if expected.is_ok() {
            assert_eq!(
                r.header.status,
                Status::PersistenceFailed as u32,
                "{}",
                r.header.reason_str()
            );
            assert_eq!(r.header.sequence, mirror.sequence(), "a refusal moved on");
            refused += 1;
        }
        // Between changes, sometimes the periodic snapshot's turn.
        if refused > 0 && refused % 10 == 0 {
            std::thread::sleep(Duration::from_millis(30));
        }
    }
    assert_eq!(
        served_state(&mut c, chains),
        mirror_state(&mirror),
        "refused changes left a trace"
    );
    eprintln!("full file system: {accepted} changes accepted and {refused} refused");
    // Room again: changes are accepted, at once or after the next snapshot starts a new journal.
    std::fs::remove_file(&filler).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut after = 0;
    while after < 200 {
        assert!(
            Instant::now() < deadline,
            "changes still refused with room on the disk"
        );
        let (h, p) = change(next);
        next += 1;
        let mut ahead = mirror.clone();
        let expected = ahead.apply_wire(&h, &p);
        let r = c.call(h, &p).unwrap();
        if r.is_ok() {
            mirror = ahead;
            after += 1;
        } else if expected.is_ok() {
            assert_eq!(after, 0, "{}", r.header.reason_str());
            std::thread::sleep(Duration::from_millis(5));
        }
    }
    assert!(
        !state_dir.join("snapshot.bin.tmp").exists(),
        "a failed snapshot left its temporary file"
    );
    drop(c);
    svc.kill9();
    let svc = Service::start(&unique_prefix(), &["--state-dir", d, "--restore"]);
    let mut c = connect(&svc, Duration::from_secs(10));
    assert_eq!(
        served_state(&mut c, chains),
        mirror_state(&mirror),
        "after kill -9 and restore ({})",
        svc.ready_line
    );
    drop(c);
    drop(svc);
    drop(fs);
}
