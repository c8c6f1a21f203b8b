//! Holds through the service (issue 16): grasp and release on the wire, held joints in responses and on
//! the state stream, a held joint bit for bit unchanged by moves elsewhere, a target out of the held
//! rope's reach refused with the nearest point, anchors of a scene never released, and a held state
//! restored bit for bit after `kill -9`.

use shared::{Command, RequestHeader, Status, Vec3};
use std::time::{Duration, Instant};
use tests::{InProcess, Service, unique_prefix};

fn req(cmd: Command, chain: u32, joint: u32) -> RequestHeader {
    let mut h = RequestHeader::new(cmd, chain);
    h.joint = joint;
    h
}

fn bits(v: &Vec3) -> [u64; 3] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

fn dist(a: &Vec3, b: &Vec3) -> f64 {
    ((a.x - b.x).powi(2) + (a.y - b.y).powi(2) + (a.z - b.z).powi(2)).sqrt()
}

#[test]
fn a_grasped_joint_stays_while_the_rope_is_moved_and_goes_when_released() {
    let svc = InProcess::start();
    let mut c = svc.connect();
    let stream = c.subscribe().unwrap();
    let head = shared::JOINT_HEAD;
    let q = c.call(req(Command::Query, 0, head), &[]).unwrap();
    assert_eq!(q.header.n_held, 0);
    let tail = q.joints()[0];

    let g = c.call(req(Command::Grasp, 0, 0), &[]).unwrap();
    assert!(g.is_ok(), "{}", g.header.reason_str());
    assert_eq!(g.header.sequence, q.header.sequence + 1);
    assert_eq!(g.held(), vec![(0, false)]);
    assert_eq!(bits(&g.joints()[0]), bits(&tail), "a grasp moves nothing");
    // Grasping it again changes nothing (no new state).
    let again = c.call(req(Command::Grasp, 0, 0), &[]).unwrap();
    assert!(again.is_ok());
    assert_eq!(again.header.sequence, g.header.sequence);

    // Moves of the head: the tail stays, bit for bit; the head lands; lengths kept (unit links).
    let mut seq = g.header.sequence;
    for i in 0..30 {
        let t = f64::from(i) * 0.2;
        let target = Vec3::new(30.0 + 3.0 * t.cos(), 8.0 * t.sin(), t);
        let r = c.call(req(Command::Move, 0, head), &[target]).unwrap();
        assert!(r.is_ok(), "move {i}: {}", r.header.reason_str());
        seq = r.header.sequence;
        let j = r.joints();
        assert_eq!(bits(&j[0]), bits(&tail), "move {i}: the held tail moved");
        assert!(dist(&j[40], &target) < 1e-6, "move {i}: head off target");
        for (k, w) in j.windows(2).enumerate() {
            let l = dist(&w[0], &w[1]);
            assert!((l - 1.0).abs() < 1e-12, "move {i}: link {k} is {l}");
        }
        assert_eq!(
            r.held(),
            vec![(0, false)],
            "every response carries the holds"
        );
    }
    // Out of reach of the held tail: refused with the nearest point, nothing changes.
    let before = c.call(req(Command::Query, 0, head), &[]).unwrap();
    let far = Vec3::new(tail.x + 100.0, tail.y, tail.z);
    let r = c.call(req(Command::Move, 0, head), &[far]).unwrap();
    assert_eq!(Status::from_u32(r.header.status), Some(Status::Unreachable));
    assert!(
        r.header.reason_str().contains("held joint 0"),
        "{}",
        r.header.reason_str()
    );
    assert!(
        (r.header.residual - 60.0).abs() < 1e-6,
        "{}",
        r.header.residual
    );
    let after = c.call(req(Command::Query, 0, head), &[]).unwrap();
    assert_eq!(
        after.payload, before.payload,
        "a refused move changed the rope"
    );
    // Taut instead: just inside the rope's length from the tail.
    let taut = Vec3::new(tail.x + 40.0 * (1.0 - 1e-9), tail.y, tail.z);
    let r = c.call(req(Command::Move, 0, head), &[taut]).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    assert_eq!(bits(&r.joints()[0]), bits(&tail));
    seq = r.header.sequence.max(seq);

    let rel = c.call(req(Command::Release, 0, 0), &[]).unwrap();
    assert!(rel.is_ok());
    assert_eq!(rel.header.n_held, 0);
    assert_eq!(rel.header.sequence, seq + 1);
    let again = c.call(req(Command::Release, 0, 0), &[]).unwrap();
    assert!(again.is_ok());
    assert_eq!(
        again.header.sequence, rel.header.sequence,
        "nothing to release"
    );
    // Free again: the tail follows a head move.
    let r = c
        .call(req(Command::Move, 0, head), &[Vec3::new(0.0, 60.0, 0.0)])
        .unwrap();
    assert!(r.is_ok());
    assert!(
        dist(&r.joints()[0], &tail) > 1.0,
        "the released tail did not follow"
    );

    // The state stream carried the holds: the grasp's sample has one, the release's none.
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut held_by_seq = std::collections::HashMap::new();
    while Instant::now() < deadline && !held_by_seq.contains_key(&rel.header.sequence) {
        match stream
            .try_next(|h, payload| {
                let held: Vec<u32> = payload[h.n_joints as usize..]
                    .iter()
                    .take(h.n_held as usize)
                    .map(|v| v.x as u32)
                    .collect();
                (h.sequence, held)
            })
            .unwrap()
        {
            Some((s, held)) => {
                held_by_seq.insert(s, held);
            }
            None => std::thread::sleep(Duration::from_millis(1)),
        }
    }
    assert_eq!(held_by_seq.get(&g.header.sequence), Some(&vec![0]));
    assert_eq!(held_by_seq.get(&rel.header.sequence), Some(&vec![]));
}

#[test]
fn grasps_are_refused_where_they_make_no_sense() {
    let svc = InProcess::start();
    let mut c = svc.connect();
    let cases = [
        (
            req(Command::Grasp, 2, 3),
            vec![],
            Status::WrongChainKind,
            "free chains",
        ),
        (
            req(Command::Grasp, 0, 41),
            vec![],
            Status::JointOutOfRange,
            "joint 41",
        ),
        (
            req(Command::Release, 0, 41),
            vec![],
            Status::JointOutOfRange,
            "joint 41",
        ),
        (
            req(Command::Grasp, 0, 3),
            vec![Vec3::new(0.0, 0.0, 0.0)],
            Status::BadPointCount,
            "grasp takes",
        ),
    ];
    for (h, points, status, fragment) in cases {
        let r = c.call(h, &points).unwrap();
        assert_eq!(Status::from_u32(r.header.status), Some(status));
        assert!(
            r.header.reason_str().contains(fragment),
            "{}",
            r.header.reason_str()
        );
    }
}

/// A scene's anchors are held from the start, reported as anchors, and never released; a held state
/// (anchors and a grasp) comes back bit for bit after `kill -9` and `--restore`.
#[test]
fn anchors_hold_from_the_start_and_holds_survive_kill_9() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("suture.toml");
    std::fs::write(
        &scene,
        "[[chain]]\nname = \"suture\"\nlinks = 40\nlink_length = 1.0\nanchors = [0]\n",
    )
    .unwrap();
    let state = dir.path().join("state");
    let args = [
        "--scene",
        scene.to_str().unwrap(),
        "--state-dir",
        state.to_str().unwrap(),
    ];
    let prefix = unique_prefix();
    let svc = Service::start(&prefix, &args);
    let mut c = svc.connect();
    let q = c.call(req(Command::Query, 0, 0), &[]).unwrap();
    assert_eq!(q.held(), vec![(0, true)]);
    // An anchor is the scene's: no client releases or moves it, take-over or not.
    for (cmd, points, flags) in [
        (Command::Release, vec![], 0),
        (Command::Release, vec![], shared::FLAG_TAKE_OVER),
        (Command::Move, vec![Vec3::new(0.0, 1.0, 0.0)], 0),
        (
            Command::Path,
            vec![Vec3::new(0.0, 1.0, 0.0)],
            shared::FLAG_TAKE_OVER,
        ),
    ] {
        let mut h = req(cmd, 0, 0);
        h.flags = flags;
        let r = c.call(h, &points).unwrap();
        assert_eq!(
            Status::from_u32(r.header.status),
            Some(Status::Held),
            "{cmd:?}: {}",
            r.header.reason_str()
        );
        assert!(
            r.header.reason_str().contains("anchor"),
            "{}",
            r.header.reason_str()
        );
    }
    assert_eq!(
        c.call(req(Command::Query, 0, 0), &[]).unwrap().joints()[0],
        q.joints()[0]
    );
    // A hand grasps the middle and moves the free end around it.
    assert!(c.call(req(Command::Grasp, 0, 20), &[]).unwrap().is_ok());
    for i in 0..20 {
        let t = f64::from(i) * 0.3;
        let r = c
            .call(
                req(Command::Move, 0, 40),
                &[Vec3::new(20.0 + 10.0 * t.cos(), 10.0 * t.sin(), 2.0)],
            )
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
    }
    let before = c.call(req(Command::Query, 0, 0), &[]).unwrap();
    assert_eq!(before.held(), vec![(0, true), (20, false)]);
    drop(c);
    svc.kill9();
    let svc = Service::start(&unique_prefix(), &[&args[..], &["--restore"]].concat());
    let mut c = svc.connect();
    let after = c.call(req(Command::Query, 0, 0), &[]).unwrap();
    assert_eq!(after.header.sequence, before.header.sequence);
    assert_eq!(after.held(), before.held());
    let (a, b): (Vec<_>, Vec<_>) = (
        after.joints().iter().map(bits).collect(),
        before.joints().iter().map(bits).collect(),
    );
    assert_eq!(a, b, "the held rope is not restored bit for bit");
    // And it goes on holding: a move of the end leaves joints 0..=20 where they are.
    let r = c
        .call(req(Command::Move, 0, 40), &[Vec3::new(25.0, 5.0, -3.0)])
        .unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    for j in 0..=20 {
        assert_eq!(bits(&r.joints()[j]), bits(&after.joints()[j]), "joint {j}");
    }
}

/// Two hand processes holding their ends for the whole script (a script's default) take six
/// alternating turns on the 40-unit rope. Every state on the stream is checked: while one hand's end
/// moves, the other hand's end is bit for bit where it was; both ends are held during the moves; the
/// grips are taken before the first move and let go after the last.
#[test]
fn two_holding_hands_alternate_and_the_idle_hand_never_moves() {
    // A buffer deeper than the whole run's states: the watcher below sleeps between reads, and on
    // a loaded machine it may be away for longer than the default 64 states (it checks none is missed).
    let svc = Service::start(
        &unique_prefix(),
        &["--wait", "event", "--no-persist", "--state-buffer", "1024"],
    );
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("alternate.toml");
    let mut text = String::from("name = \"alternate\"\nmax_step = 0.1\n");
    let turns = [
        ("A", "tail", "[[3, 2, 0], [4, 4, 1]]"),
        ("B", "head", "[[-3, 2, 0], [-4, 4, -1]]"),
        ("A", "tail", "[[-1, -2, 0]]"),
        ("B", "head", "[[1, -2, 0]]"),
        ("A", "tail", "[[0, 1, 1]]"),
        ("B", "head", "[[0, 1, -1]]"),
    ];
    for (hand, joint, waypoints) in turns {
        text += &format!(
            "[[turn]]\nhand = \"{hand}\"\nchain = \"rope\"\njoint = \"{joint}\"\nwaypoints = {waypoints}\n"
        );
    }
    std::fs::write(&script, text).unwrap();

    let mut c = svc.connect();
    let q0 = c.call(req(Command::Query, 0, 0), &[]).unwrap();
    let n = q0.joints().len();
    let seq0 = q0.header.sequence;
    // Every state of the rope from here on: (sequence, command, held joints, tail, head).
    type Seen = (u64, u32, u32, [u64; 3], [u64; 3]);
    let prefix = svc.prefix.clone();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    let (ready_tx, ready) = std::sync::mpsc::channel();
    let watcher = std::thread::spawn(move || {
        let conn = clients::Connection::connect(clients::ConnectOptions {
            prefix,
            ..clients::ConnectOptions::default()
        })
        .unwrap();
        let stream = conn.subscribe().unwrap();
        ready_tx.send(()).unwrap();
        let mut seen: Vec<Seen> = Vec::new();
        let mut idle = None;
        let mut next = seq0 + 1;
        loop {
            let got = stream
                .try_next(|h, p| {
                    let j = h.n_joints as usize;
                    (
                        h.sequence,
                        h.chain,
                        h.command,
                        h.n_held,
                        bits(&p[0]),
                        bits(&p[j - 1]),
                    )
                })
                .unwrap();
            if let Some((seq, ..)) = got {
                idle = None;
                assert_eq!(seq, next, "a published state was missed");
                next += 1;
            }
            match got {
                Some((seq, 0, cmd, held, tail, head)) => seen.push((seq, cmd, held, tail, head)),
                Some(_) => {}
                None => {
                    if flag.load(std::sync::atomic::Ordering::Relaxed) {
                        let t = *idle.get_or_insert_with(Instant::now);
                        if t.elapsed() > Duration::from_millis(300) {
                            return seen;
                        }
                    }
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
    });
    ready.recv_timeout(Duration::from_secs(20)).unwrap();

    let spawn = |hand: &str| {
        std::process::Command::new(tests::bin("hand"))
            .arg("--prefix")
            .arg(&svc.prefix)
            .arg("run")
            .args(["--quiet", "--turn-timeout", "60", "--hand", hand])
            .arg("--script")
            .arg(&script)
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    // B first, A a moment later: the first move must still wait for B's grip.
    let b = spawn("B");
    std::thread::sleep(Duration::from_millis(50));
    let a = spawn("A");
    for mut h in [a, b] {
        let deadline = Instant::now() + Duration::from_secs(120);
        let status = loop {
            if let Some(st) = h.try_wait().unwrap() {
                break st;
            }
            assert!(Instant::now() < deadline, "a hand did not finish in 120 s");
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut out = String::new();
        std::io::Read::read_to_string(h.stdout.as_mut().unwrap(), &mut out).unwrap();
        assert!(status.success(), "{out}");
        assert!(out.contains("0 locked"), "{out}");
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let seen = watcher.join().unwrap();

    let moves: Vec<&Seen> = seen
        .iter()
        .filter(|s| s.1 == Command::Move as u32)
        .collect();
    assert!(moves.len() > 100, "{} moves seen", moves.len());
    assert!(
        moves.iter().all(|s| s.2 == 2),
        "both ends held in every moved state"
    );
    // Grips before the first move, releases after the last.
    let first_move = seen
        .iter()
        .position(|s| s.1 == Command::Move as u32)
        .unwrap();
    let last_move = seen
        .iter()
        .rposition(|s| s.1 == Command::Move as u32)
        .unwrap();
    let grasps: Vec<usize> = (0..seen.len())
        .filter(|&i| seen[i].1 == Command::Grasp as u32)
        .collect();
    let releases: Vec<usize> = (0..seen.len())
        .filter(|&i| seen[i].1 == Command::Release as u32)
        .collect();
    assert_eq!(grasps.len(), 2);
    assert_eq!(releases.len(), 2);
    assert!(grasps.iter().all(|&i| i < first_move));
    assert!(releases.iter().all(|&i| i > last_move));
    // Consecutive states: never both ends changed; each end moved in some state.
    let (mut tail_moved, mut head_moved) = (0, 0);
    let mut prev = (bits(&q0.joints()[0]), bits(&q0.joints()[n - 1]));
    for s in &seen {
        let (t, h) = (s.3 != prev.0, s.4 != prev.1);
        assert!(!(t && h), "both held ends changed in state {}", s.0);
        tail_moved += usize::from(t);
        head_moved += usize::from(h);
        prev = (s.3, s.4);
    }
    assert!(
        tail_moved > 50 && head_moved > 50,
        "{tail_moved} {head_moved}"
    );
    let end = c.call(req(Command::Query, 0, 0), &[]).unwrap();
    assert_eq!(end.held(), vec![], "both hands let go");
}

/// Issue 35: a grasp belongs to the client that took it. Another client's release of it, move of that
/// joint or reset of the chain is refused (`held`, the owner named) unless it takes the grasp over; one
/// client owns at most `MAX_GRASPS_PER_CLIENT` grasps of a chain; when the owner's port goes, its grasps
/// hold on, unowned, and any client may release them.
#[test]
fn grasps_belong_to_the_client_that_took_them() {
    let svc = Service::start(&unique_prefix(), &["--no-persist"]);
    let mut a = svc.connect();
    let mut b = svc.connect();
    let status = |r: &clients::Reply| Status::from_u32(r.header.status);
    assert!(a.call(req(Command::Grasp, 0, 20), &[]).unwrap().is_ok());
    let owner = format!("{:x}", a.client_id());
    let before = b.call(req(Command::Query, 0, 0), &[]).unwrap();
    for (cmd, joint, points) in [
        (Command::Release, 20, vec![]),
        (Command::Grasp, 20, vec![]),
        (Command::Move, 20, vec![Vec3::new(20.0, 3.0, 0.0)]),
        (Command::Path, 20, vec![Vec3::new(20.0, 3.0, 0.0)]),
        (Command::Reset, 0, vec![]),
    ] {
        let r = b.call(req(cmd, 0, joint), &points).unwrap();
        assert_eq!(
            status(&r),
            Some(Status::Held),
            "{cmd:?}: {}",
            r.header.reason_str()
        );
        assert!(
            r.header.reason_str().contains(&owner),
            "{cmd:?}: the reason {:?} does not name the owner {owner}",
            r.header.reason_str()
        );
    }
    let after = b.call(req(Command::Query, 0, 0), &[]).unwrap();
    assert_eq!(
        after.header.sequence, before.header.sequence,
        "a refusal changed the state"
    );
    assert_eq!(after.held(), vec![(20, false)]);
    // The owner moves what it holds, and moves the free end around it.
    let r = a
        .call(req(Command::Move, 0, 20), &[Vec3::new(20.0, 1.0, 0.0)])
        .unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    let r = b
        .call(req(Command::Move, 0, 40), &[Vec3::new(30.0, 8.0, 0.0)])
        .unwrap();
    assert!(
        r.is_ok(),
        "another joint is anyone's: {}",
        r.header.reason_str()
    );
    // A flag takes it over: then the first client is the one refused.
    let mut h = req(Command::Move, 0, 20);
    h.flags = shared::FLAG_TAKE_OVER;
    let r = b.call(h, &[Vec3::new(20.0, 2.0, 0.0)]).unwrap();
    assert!(r.is_ok(), "{}", r.header.reason_str());
    let r = a.call(req(Command::Release, 0, 20), &[]).unwrap();
    assert_eq!(status(&r), Some(Status::Held), "{}", r.header.reason_str());
    assert!(
        r.header
            .reason_str()
            .contains(&format!("{:x}", b.client_id()))
    );
    assert!(b.call(req(Command::Release, 0, 20), &[]).unwrap().is_ok());
    // One client cannot take every hold slot of a chain.
    let most = shared::MAX_GRASPS_PER_CLIENT;
    for j in 0..most {
        let r = a.call(req(Command::Grasp, 0, 1 + 2 * j), &[]).unwrap();
        assert!(r.is_ok(), "grasp {j}: {}", r.header.reason_str());
    }
    let r = a.call(req(Command::Grasp, 0, 2), &[]).unwrap();
    assert_eq!(
        status(&r),
        Some(Status::BadOption),
        "{}",
        r.header.reason_str()
    );
    assert!(
        b.call(req(Command::Grasp, 0, 2), &[]).unwrap().is_ok(),
        "another client may"
    );
    // The owner goes: its grasps hold on, unowned; any client may release them (the service looks
    // for absent clients every half second: poll, with a deadline).
    let held = b.call(req(Command::Query, 0, 0), &[]).unwrap().held();
    assert_eq!(held.len(), most as usize + 1);
    drop(a);
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let r = b.call(req(Command::Release, 0, 1), &[]).unwrap();
        if r.is_ok() {
            break;
        }
        assert_eq!(status(&r), Some(Status::Held), "{}", r.header.reason_str());
        assert!(
            Instant::now() < deadline,
            "the gone client's grasps stayed owned"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let left = b.call(req(Command::Query, 0, 0), &[]).unwrap().held();
    assert_eq!(
        left.len(),
        most as usize,
        "the other grasps went on holding"
    );
}
