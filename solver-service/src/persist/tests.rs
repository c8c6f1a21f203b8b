use super::*;
use shared::{Command, JOINT_HEAD};
use tractrix::Real;
use world::each_form;
use world::scene::default_scene;

fn joints(set: &World) -> Vec<u64> {
    (0..set.len() as u32)
        .flat_map(|c| set.elements_of(c, true).collect::<Vec<_>>())
        .flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect()
}

/// A snapshot of an earlier version's format (with or without the envelope) is refused by
/// name, and nothing changes: one format, no upgrade ladder.
#[test]
fn a_snapshot_of_an_earlier_format_is_refused_by_name() {
    let scene = default_scene();
    for (magic, name) in OLDER_SNAPSHOTS {
        for envelope in [false, true] {
            let dir = tempfile::tempdir().unwrap();
            // The magic number, then a few words of an old body.
            let mut body = bincode::serde::encode_to_vec(magic, config()).unwrap();
            body.extend_from_slice(&[7; 40]);
            let bytes = if envelope {
                let mut b = Vec::new();
                b.extend_from_slice(&SNAPSHOT_ENVELOPE);
                b.extend_from_slice(&(body.len() as u64).to_le_bytes());
                b.extend_from_slice(&[0; 8]);
                b.extend_from_slice(&body);
                let crc = crc32fast::hash(&b[20..]);
                b[16..20].copy_from_slice(&crc.to_le_bytes());
                b
            } else {
                body
            };
            std::fs::write(dir.path().join("snapshot.bin"), &bytes).unwrap();
            let mut set = World::new(&scene).unwrap();
            let before = joints(&set);
            let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
            let e = store.restore(&mut set, false).unwrap_err().to_string();
            assert!(
                e.contains(name) && e.contains("start without --restore"),
                "{name}, envelope {envelope}: {e}"
            );
            assert_eq!(joints(&set), before);
            assert_eq!(set.sequence(), 0);
        }
    }
}

/// Snapshot in the middle, journal after it, a torn record at the end: the restore holds exactly
/// the state after the last whole record.
#[test]
fn snapshot_plus_journal_restores_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = default_scene();
    let mut set = World::new(&scene).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.snapshot(&set).unwrap();
    for i in 0..200u32 {
        let t = (i as f64) * 0.37;
        let (req, p) = match i % 3 {
            0 => {
                let mut r = RequestHeader::new(Command::Move, 0);
                // Runs of moves of one end: the move after the snapshot starts from the
                // datum joint the snapshot kept.
                r.joint = if (i / 6) % 2 == 0 { JOINT_HEAD } else { 0 };
                (
                    r,
                    vec![Vec3::new(20.0 + 5.0 * t.cos(), 5.0 * t.sin(), t.sin())],
                )
            }
            1 => (
                RequestHeader::new(Command::Path, 1),
                vec![
                    Vec3::new(t.sin(), -50.0 + t, 0.3),
                    Vec3::new(t.cos(), -49.0 + t, 0.1),
                ],
            ),
            _ => (
                RequestHeader::new(Command::Reach, 2),
                vec![Vec3::new(1.2 * t.cos(), 1.2 * t.sin(), 0.0)],
            ),
        };
        let o = set.apply_wire(&req, &p).map_err(|r| r.reason().to_string());
        assert!(o.unwrap().changed);
        store.append(set.sequence(), &req, &p).unwrap();
        if i == 90 {
            store.snapshot(&set).unwrap();
        }
    }
    let expected = joints(&set);
    let expected_seq = set.sequence();
    drop(store);
    // A record cut short by a crash, never acknowledged.
    let mut f = OpenOptions::new()
        .append(true)
        .open(dir.path().join("journal.bin"))
        .unwrap();
    f.write_all(&[200, 0, 0, 0, 1, 2]).unwrap();
    drop(f);

    let mut fresh = World::new(&scene).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    let r = store.restore(&mut fresh, false).unwrap();
    assert_eq!(r.snapshot_sequence, 91);
    assert_eq!(r.replayed, 109);
    assert_eq!(r.dropped_tail_bytes, 6);
    assert_eq!(fresh.sequence(), expected_seq);
    assert_eq!(joints(&fresh), expected);
    // And the datum joints: the next move of the last moved joint starts where it did.
    assert_eq!(datums(&fresh), datums(&set));
    let mut req = RequestHeader::new(Command::Move, 0);
    req.joint = 0;
    let p = [Vec3::new(3.3, -1.7, 0.9)];
    assert!(set.apply_wire(&req, &p).unwrap().changed);
    assert!(fresh.apply_wire(&req, &p).unwrap().changed);
    assert_eq!(joints(&fresh), joints(&set));
}

/// A snapshot keeps each chain's datum joint (the last moved one, at its exact target) bit for bit.
#[test]
fn a_snapshot_keeps_the_datum_joints() {
    let dir = tempfile::tempdir().unwrap();
    let scene = default_scene();
    let mut set = World::new(&scene).unwrap();
    // The free chains' heads (a fixed-base arm refuses a move: its datum stays joint 0).
    for c in 0..set.len() as u32 {
        let req = RequestHeader::new(Command::Move, c);
        let _ = set.apply_wire(&req, &[Vec3::new(1.1, 0.7, 0.0)]);
    }
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.snapshot(&set).unwrap();
    drop(store);
    let mut fresh = World::new(&scene).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.restore(&mut fresh, false).unwrap();
    assert!(datums(&set).iter().any(|b| b.0 > 0), "{:?}", datums(&set));
    assert_eq!(datums(&fresh), datums(&set));
    assert_eq!(joints(&fresh), joints(&set));
}

/// A restored chain keeps its scene's joint limits: the next moves are limited as before the stop.
#[test]
fn a_restored_chain_keeps_its_limits() {
    let dir = tempfile::tempdir().unwrap();
    let scene = world::scene::parse_scene(
        "[[chain]]\nname = \"s\"\nlinks = 40\nlink_length = 0.5\nmin_bend_radius = 1.0\n",
        "t.toml",
    )
    .unwrap();
    let mut set = World::new(&scene).unwrap();
    let req = RequestHeader::new(Command::Move, 0);
    let _ = set.apply_wire(&req, &[Vec3::new(3.0, 6.0, 0.0)]);
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.snapshot(&set).unwrap();
    drop(store);
    let mut fresh = World::new(&scene).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.restore(&mut fresh, false).unwrap();
    assert_eq!(joints(&fresh), joints(&set));
    let limited = |set: &World| {
        set.geometry()
            .iter()
            .map(|g| each_form!(g, g => g.chain.joint_limits().is_some()))
            .collect::<Vec<_>>()
    };
    assert_eq!(limited(&fresh), vec![true]);
    // The same sharp move on both: the same limited rope.
    for s in [&mut set, &mut fresh] {
        let _ = s.apply_wire(&req, &[Vec3::new(-5.0, 0.0, 4.0)]);
    }
    assert_eq!(joints(&fresh), joints(&set));
}

/// Each chain's datum joint and the bits of its position.
fn datums(set: &World) -> Vec<(usize, Vec<u64>)> {
    set.geometry()
        .iter()
        .map(|g| {
            each_form!(g, g => {
                let (b, at) = g.chain.datum();
                (b, at.iter().map(|x| x.to_f64().to_bits()).collect())
            })
        })
        .collect()
}

/// Regression (issue 15): a failed append used to leave its partial bytes; later appends landed after
/// them and a restore stopped at the bad checksum, dropping every later acknowledged change. Now the
/// journal is cut back to its last whole record; if the cut fails too, changes are refused until a
/// snapshot. Every acknowledged change is restored, nothing unacknowledged is.
#[test]
fn a_failed_append_never_hides_later_acknowledged_changes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = default_scene();
    let mut set = World::new(&scene).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.snapshot(&set).unwrap();
    let (mut acknowledged, mut refused) = (0, 0);
    for i in 0..90u32 {
        let t = f64::from(i) * 0.3;
        let req = RequestHeader::new(Command::Move, 0);
        let p = [Vec3::new(38.0 + t.cos(), t.sin(), 0.2 * t.sin())];
        assert!(set.apply_wire(&req, &p).unwrap().changed);
        match i {
            20 | 21 => store.inject(Fault::ShortWrite),
            50 => store.inject(Fault::ShortWriteThenCutFails),
            // The service snapshots when it can; the journal is sound again after it.
            60 => store
                .snapshot(&{
                    let mut s = set.clone();
                    s.undo();
                    s
                })
                .unwrap(),
            _ => {}
        }
        // The service: append, and undo the change if the append fails (never acknowledged).
        match store.append(set.sequence(), &req, &p) {
            Ok(()) => acknowledged += 1,
            Err(e) => {
                assert!(
                    (20..=21).contains(&i) && matches!(e, PersistError::WriteFailed { .. })
                        || (50..60).contains(&i)
                            && matches!(
                                e,
                                PersistError::Unsound { .. } | PersistError::CutFailed { .. }
                            ),
                    "append {i}: {e}"
                );
                set.undo();
                refused += 1;
            }
        }
    }
    assert_eq!(
        refused,
        2 + 10,
        "two torn appends, then refusals until the snapshot at 60"
    );
    assert_eq!(set.sequence(), acknowledged);
    let expected = joints(&set);
    drop(store);
    let mut fresh = World::new(&scene).unwrap();
    let r = Store::open(dir.path(), JournalMode::Write)
        .unwrap()
        .restore(&mut fresh, false)
        .unwrap();
    assert_eq!(r.dropped_tail_bytes, 0, "no torn bytes left behind");
    assert_eq!(fresh.sequence(), acknowledged);
    assert_eq!(
        joints(&fresh),
        expected,
        "every acknowledged change, nothing else"
    );
}

/// A background snapshot leaves a restorable state at every step: journal rotated but no snapshot
/// yet, snapshot renamed but the segment not yet deleted, and done. Changes keep arriving meanwhile.
#[test]
fn a_background_snapshot_is_restorable_at_every_step() {
    let dir = tempfile::tempdir().unwrap();
    let scene = default_scene();
    let mut set = World::new(&scene).unwrap();
    let mut store = Store::open(dir.path(), JournalMode::Write).unwrap();
    store.begin(&set).unwrap();
    let change = |set: &mut World, store: &mut Store, i: u32| {
        let t = f64::from(i) * 0.21;
        let req = RequestHeader::new(Command::Move, 0);
        let p = [Vec3::new(38.0 + t.cos(), t.sin(), 0.1 * t)];
        assert!(set.apply_wire(&req, &p).unwrap().changed);
        store.append(set.sequence(), &req, &p).unwrap();
    };
    let restores_to = |from: &Path, set: &World, what: &str| {
        // The writer thread may rename or delete files while they are copied: what vanished
        // after the listing is skipped, and snapshot.bin is copied last, so the copy is a state a
        // crash could leave (a segment is deleted only once the snapshot covering it is in place).
        let copy = tempfile::tempdir().unwrap();
        let mut names: Vec<_> = std::fs::read_dir(from)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort_by_key(|n| n == "snapshot.bin");
        for n in names {
            match std::fs::copy(from.join(&n), copy.path().join(&n)) {
                Ok(_) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => panic!("copy {n:?}: {e}"),
            }
        }
        let mut fresh = World::new(&scene).unwrap();
        Store::open(copy.path(), JournalMode::Write)
            .unwrap()
            .restore(&mut fresh, false)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(fresh.sequence(), set.sequence(), "{what}");
        assert_eq!(joints(&fresh), joints(set), "{what}");
    };
    for i in 0..30 {
        change(&mut set, &mut store, i);
    }
    // Step 1: the journal moved aside, the snapshot never written.
    store.inject(Fault::WriterNeverRuns);
    let at_rotation = set.clone();
    assert!(store.snapshot_in_background(&set).unwrap());
    assert!(segment_path(dir.path(), 30).exists());
    for i in 30..60 {
        change(&mut set, &mut store, i);
    }
    restores_to(dir.path(), &set, "rotated, no snapshot");
    // Step 2: the snapshot in place, its segment not yet deleted.
    let (bytes, _) = encode_snapshot(&at_rotation, true).unwrap();
    write_snapshot_file(dir.path(), &bytes).unwrap();
    restores_to(dir.path(), &set, "snapshot written, segment kept");
    // The real thing, with changes while the writer works; at most one segment waits.
    for round in 0..3 {
        assert!(store.snapshot_in_background(&set).unwrap());
        for i in 0..20 {
            change(&mut set, &mut store, 100 * round + i);
        }
        restores_to(dir.path(), &set, "snapshot being written");
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
        let done = loop {
            if let Some(r) = store.finished() {
                break r;
            }
            assert!(std::time::Instant::now() < deadline, "no snapshot in 20 s");
            std::thread::sleep(std::time::Duration::from_millis(1));
        };
        assert!(done.is_ok(), "{done:?}");
        restores_to(dir.path(), &set, "snapshot done");
    }
    assert!(
        list_segments(dir.path()).unwrap().len() <= 1,
        "{:?}",
        list_segments(dir.path())
    );
    drop(store);
    restores_to(dir.path(), &set, "after the store closed");
}

#[test]
fn a_snapshot_of_another_scene_is_refused_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut set = World::new(&default_scene()).unwrap();
    Store::open(dir.path(), JournalMode::Off)
        .unwrap()
        .snapshot(&set)
        .unwrap();
    let other = world::scene::parse_scene(
        "[[chain]]\nname = \"rope\"\nlinks = 40\nlink_length = 0.5\n",
        "o.toml",
    )
    .unwrap();
    let mut other_set = World::new(&other).unwrap();
    let before = joints(&other_set);
    let e = Store::open(dir.path(), JournalMode::Off)
        .unwrap()
        .restore(&mut other_set, false)
        .unwrap_err();
    assert!(
        matches!(&e, PersistError::File { what, why, .. } if what == "does not fit the scene" && why.contains("chains")),
        "{e}"
    );
    assert_eq!(joints(&other_set), before);
    // Garbage is refused as well.
    std::fs::write(dir.path().join("snapshot.bin"), b"garbage").unwrap();
    assert!(
        Store::open(dir.path(), JournalMode::Off)
            .unwrap()
            .restore(&mut set, false)
            .is_err()
    );
}
