//! Issue 35: a damaged state directory restores the exact acknowledged state or refuses with a message,
//! never a state that did not exist, and a refusal touches no file. Every single-bit flip and every
//! truncation of a small snapshot and of its journal is tried (`cargo test -p solver-service --test
//! damage`); with `--restore-from-damaged` every journal flip restores a state that was acknowledged.

use shared::{Command, JOINT_HEAD, RequestHeader, Vec3};
use solver_service::persist::{JournalMode, Store};
use solver_service::wire::WireWorld;
use std::path::Path;
use world::World;
use world::scene::{Scene, parse_scene};

fn scene() -> Scene {
    parse_scene(
        "[[chain]]\nname = \"s\"\nlinks = 4\nlink_length = 1.0\nanchors = [0]\n",
        "small.toml",
    )
    .unwrap()
}

/// Every joint's bits, the held joints and the sequence: the whole state a client can see.
fn state(set: &World) -> (Vec<u64>, u64) {
    let bits = set
        .elements_with(0, true, true, false, (false, false))
        .collect::<Vec<_>>()
        .iter()
        .flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect();
    (bits, set.sequence())
}

/// The requests journaled: moves of the head and of joint 2, a grasp and a release.
fn requests() -> Vec<(RequestHeader, Vec<Vec3>)> {
    let mut out = Vec::new();
    for i in 0..6u32 {
        let t = f64::from(i) * 0.7;
        let mut h = RequestHeader::new(
            match i {
                2 => Command::Grasp,
                4 => Command::Release,
                _ => Command::Move,
            },
            0,
        );
        h.joint = if i == 2 || i == 4 { 2 } else { JOINT_HEAD };
        let p = if h.command == Command::Move as u32 {
            vec![Vec3::new(2.0 + t.cos(), t.sin(), 0.5 * t)]
        } else {
            vec![]
        };
        out.push((h, p));
    }
    out
}

/// The files of a state directory after the snapshot at the start and the journaled requests, and the
/// state after each number of records (index 0: the snapshot's).
struct Saved {
    snapshot: Vec<u8>,
    journal: Vec<u8>,
    /// Byte offset of the end of each record in the journal (after the 8-byte magic).
    ends: Vec<usize>,
    states: Vec<(Vec<u64>, u64)>,
}

fn saved() -> Saved {
    let dir = tempfile::tempdir().unwrap();
    let mut set = World::new(&scene()).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.begin(&set).unwrap();
    let mut states = vec![state(&set)];
    let mut ends = Vec::new();
    for (h, p) in requests() {
        let o = set.apply_wire(&h, &p).unwrap();
        assert!(o.changed);
        store.append(set.sequence(), &h, &p).unwrap();
        states.push(state(&set));
        ends.push(std::fs::metadata(store.journal_path()).unwrap().len() as usize);
    }
    Saved {
        snapshot: std::fs::read(store.snapshot_path()).unwrap(),
        journal: std::fs::read(store.journal_path()).unwrap(),
        ends,
        states,
    }
}

/// Every file of `dir` with its bytes, sorted.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// Restores from a directory holding `snapshot` and `journal` (`None`: no journal file).
fn restore(
    dir: &Path,
    snapshot: &[u8],
    journal: Option<&[u8]>,
    from_damaged: bool,
) -> Result<(Vec<u64>, u64), String> {
    for e in std::fs::read_dir(dir).unwrap() {
        std::fs::remove_file(e.unwrap().path()).unwrap();
    }
    std::fs::write(dir.join("snapshot.bin"), snapshot).unwrap();
    if let Some(j) = journal {
        std::fs::write(dir.join("journal.bin"), j).unwrap();
    }
    let before = files(dir);
    let mut set = World::new(&scene()).unwrap();
    let mut store = Store::open(dir, JournalMode::Write).unwrap();
    match store.restore(&mut set, from_damaged) {
        Ok(_) => Ok(state(&set)),
        Err(e) => {
            assert_eq!(files(dir), before, "a refused restore changed a file ({e})");
            Err(e.to_string())
        }
    }
}

fn flips(bytes: &[u8]) -> impl Iterator<Item = (usize, Vec<u8>)> + '_ {
    (0..bytes.len() * 8).map(move |bit| {
        let mut b = bytes.to_vec();
        b[bit / 8] ^= 1 << (bit % 8);
        (bit, b)
    })
}

#[test]
fn every_flip_and_truncation_of_the_snapshot_is_refused() {
    let s = saved();
    let dir = tempfile::tempdir().unwrap();
    let full = s.states.last().unwrap().clone();
    assert_eq!(
        restore(dir.path(), &s.snapshot, Some(&s.journal), false),
        Ok(full)
    );
    for (bit, snap) in flips(&s.snapshot) {
        let e = restore(dir.path(), &snap, Some(&s.journal), false).expect_err(&format!(
            "bit {bit} of the snapshot flipped, restored anyway"
        ));
        assert!(e.contains("snapshot.bin"), "bit {bit}: {e}");
    }
    for len in 0..s.snapshot.len() {
        let e = restore(dir.path(), &s.snapshot[..len], Some(&s.journal), false)
            .expect_err(&format!("the snapshot cut to {len} bytes restored anyway"));
        assert!(e.contains("snapshot.bin"), "cut to {len}: {e}");
    }
}

#[test]
fn every_flip_of_the_journal_is_refused_or_restored_past_with_what_it_drops() {
    let s = saved();
    let dir = tempfile::tempdir().unwrap();
    let full = s.states.last().unwrap().clone();
    for (bit, journal) in flips(&s.journal) {
        match restore(dir.path(), &s.snapshot, Some(&journal), false) {
            Ok(st) => assert_eq!(st, full, "bit {bit}: restored a state never acknowledged"),
            Err(e) => assert!(e.contains("journal.bin"), "bit {bit}: {e}"),
        }
        // Past the damage: a state that was acknowledged, and the damaged file kept.
        let st = restore(dir.path(), &s.snapshot, Some(&journal), true)
            .unwrap_or_else(|e| panic!("bit {bit}: --restore-from-damaged refused: {e}"));
        assert!(
            s.states.contains(&st),
            "bit {bit}: restored a state that never existed"
        );
        if st != full {
            let kept = files(dir.path())
                .into_iter()
                .any(|(name, bytes)| name.starts_with("damaged-") && bytes == journal);
            assert!(kept, "bit {bit}: the damaged journal was not kept");
        }
    }
    // A flipped bit in the middle is never taken for a torn tail: record 1's checksum.
    let mut mid = s.journal.clone();
    mid[s.ends[0] + 5] ^= 0x10;
    let e = restore(dir.path(), &s.snapshot, Some(&mid), false).unwrap_err();
    assert!(
        e.contains(&format!("at byte {}", s.ends[0])) && e.contains("4 whole record(s) follow"),
        "{e}"
    );
}

#[test]
fn a_truncated_journal_restores_its_whole_records_and_a_missing_one_is_reported() {
    let s = saved();
    let dir = tempfile::tempdir().unwrap();
    for len in 0..=s.journal.len() {
        let r = restore(dir.path(), &s.snapshot, Some(&s.journal[..len]), false);
        if len < 8 {
            let e = r.expect_err("a journal without its header");
            assert!(e.contains("journal.bin"), "{e}");
            continue;
        }
        // The records wholly inside the cut, by the offsets the appends produced.
        let whole = s.ends.iter().filter(|&&end| end <= len).count();
        assert_eq!(r, Ok(s.states[whole].clone()), "cut to {len} bytes");
    }
    let e = restore(dir.path(), &s.snapshot, None, false).unwrap_err();
    assert!(e.contains("journal.bin: missing"), "{e}");
    assert_eq!(
        restore(dir.path(), &s.snapshot, None, true),
        Ok(s.states[0].clone())
    );
}
