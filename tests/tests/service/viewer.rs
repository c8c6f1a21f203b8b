//! `watch --save` (the Rerun view, cargo feature `rerun`, built by scripts/test.sh into target/viewer/): the recording is read
//! back with Rerun's own Python reader (`read_rrd.py`, rerun-sdk in the venv), and its entities, its
//! number of states, the rope's last strip and the held joints are checked against what this test did
//! and what the service answers.

use shared::{Command, JOINT_HEAD, RequestHeader, Vec3};
use std::path::PathBuf;
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};
use tests::{Service, cargo_build, stderr_lines, unique_prefix};

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `target/viewer/watch`: `watch` with the feature `rerun`, in the profile `viewer` (scripts/test.sh
/// builds it; built here if it is missing).
fn watch_with_rerun() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let target = exe
        .ancestors()
        .nth(3)
        .expect("target/<profile>/deps/<test>")
        .to_path_buf();
    let path = target.join("viewer/watch");
    if !path.exists() {
        cargo_build(&[
            "-p",
            "clients",
            "--features",
            "rerun",
            "--bin",
            "watch",
            "--profile",
            "viewer",
        ]);
    }
    path
}

/// Starts `watch --save RRD --count COUNT` on the service with `extra` arguments and waits until it
/// listens; returns it and its stderr lines.
fn start_watch(
    prefix: &str,
    rrd: &std::path::Path,
    count: usize,
    extra: &[&str],
) -> (std::process::Child, std::sync::mpsc::Receiver<String>) {
    let mut watch = Process::new(watch_with_rerun())
        .args(["--prefix", prefix])
        .args(extra)
        .arg("--save")
        .arg(rrd)
        .args(["--count", &count.to_string(), "--duration", "200"])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn watch");
    let rx = stderr_lines(&mut watch);
    let line = rx
        .recv_timeout(Duration::from_secs(30))
        .expect("watch says something");
    assert!(line.contains("listening"), "{line}");
    (watch, rx)
}

/// Waits (240 s at most) for `watch` to stop by itself and returns what it said on stderr.
fn wait_for(mut watch: std::process::Child, rx: &std::sync::mpsc::Receiver<String>) -> Vec<String> {
    let deadline = Instant::now() + Duration::from_secs(240);
    let st = loop {
        if let Some(st) = watch.try_wait().unwrap() {
            break st;
        }
        assert!(Instant::now() < deadline, "watch did not stop");
        std::thread::sleep(Duration::from_millis(10));
    };
    // The pipe's reader thread forwards the last lines and ends with the pipe (on a loaded machine
    // after `watch` has exited): wait for it.
    let mut said: Vec<String> = Vec::new();
    while let Ok(l) = rx.recv_timeout(Duration::from_secs(10)) {
        said.push(l);
    }
    assert!(st.success(), "{said:?}");
    said
}

/// The recording as `read_rrd.py` (Rerun's own Python reader) prints it.
fn read_rrd(rrd: &std::path::Path) -> serde_json::Value {
    let out = Process::new(workspace().join("target/pyenv/bin/python"))
        .arg(workspace().join("tests/tests/service/read_rrd.py"))
        .arg(rrd)
        .output()
        .expect("run read_rrd.py (scripts/python-venv.sh installs rerun-sdk)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON")
}

/// Issue 37: `watch --save` records every state of two hands tying the square knot at full speed
/// (`hand` processes taking turns, no rate), beside a service whose subscribers buffer 4096 states
/// (`--state-buffer`, the README's advice for a recorder): 1500 states recorded, none missed. The
/// buffer is deeper than the count, so this holds however late `watch` gets the CPU; `watch` reads on
/// a thread of its own, so writing the recording does not hold up its reading either.
#[test]
fn watch_saves_every_state_of_two_hands_at_full_speed_beside_a_deep_buffer() {
    let scene = workspace().join("solver-service/scenes/knots.toml");
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--no-persist",
            "--wait",
            "event",
            "--state-buffer",
            "4096",
        ],
    );
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("states.rrd");
    let count = 1500;
    let (watch, rx) = start_watch(&svc.prefix, &rrd, count, &[]);
    let hand = |which: &str| {
        Process::new(tests::bin("hand"))
            .args(["--prefix", &svc.prefix, "run", "--builtin", "square-held"])
            .args(["--hand", which, "--quiet", "--turn-timeout", "120"])
            .stdout(Stdio::null())
            .spawn()
            .expect("spawn hand")
    };
    let hands = [hand("A"), hand("B")];
    let said = wait_for(watch, &rx);
    for mut h in hands {
        let deadline = Instant::now() + Duration::from_secs(240);
        while h.try_wait().unwrap().is_none() {
            assert!(Instant::now() < deadline, "a hand did not finish");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    assert!(
        said.iter()
            .any(|l| l.contains(&format!("{count} states sent to Rerun"))),
        "{said:?}"
    );
    assert!(
        said.iter()
            .any(|l| l.contains(&format!("watch: {count} states")) && l.contains(" 0 missed")),
        "{said:?}"
    );
}

const MOVES: usize = 28;

#[test]
fn watch_saves_every_state_to_a_rerun_recording_that_reads_back() {
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("states.rrd");
    // grasp + MOVES moves + release
    let states = MOVES + 2;
    let (watch, rx) = start_watch(&svc.prefix, &rrd, states, &["--chain", "rope"]);
    let mut c = svc.connect();
    let rope = c
        .find_chain("rope")
        .unwrap()
        .expect("the default scene's rope");
    let mut grasp = RequestHeader::new(Command::Grasp, rope);
    grasp.joint = 0;
    assert!(c.call(grasp, &[]).unwrap().is_ok());
    // Idle long enough for watch to time a query and name the knot (it probes every 100 ms).
    std::thread::sleep(Duration::from_millis(400));
    for i in 0..MOVES {
        let a = i as f64 * 0.2;
        let mut mv = RequestHeader::new(Command::Move, rope);
        mv.joint = JOINT_HEAD;
        let target = Vec3::new(30.0 + 3.0 * a.cos(), 3.0 * a.sin(), 0.1 * i as f64);
        let r = c.call(mv, &[target]).unwrap();
        assert!(r.is_ok(), "{:?}", r.header.reason_str());
    }
    let held_last = c
        .call(RequestHeader::new(Command::Query, rope), &[])
        .unwrap();
    let mut release = RequestHeader::new(Command::Release, rope);
    release.joint = 0;
    assert!(c.call(release, &[]).unwrap().is_ok());
    let last = c
        .call(RequestHeader::new(Command::Query, rope), &[])
        .unwrap();

    let said = wait_for(watch, &rx);
    assert!(
        said.iter()
            .any(|l| l.contains(&format!("{states} states sent to Rerun"))),
        "{said:?}"
    );
    let v = read_rrd(&rrd);
    for entity in [
        "/chains/rope/rope",
        "/chains/rope/joints",
        "/chains/rope/held",
        "/chains/rope/knot",
        "/chains/rope/knot_crossings",
        "/latency/query_round_trip_us",
    ] {
        assert!(v.get(entity).is_some(), "no {entity} in {:?}", keys(&v));
    }
    assert!(
        v.as_object().unwrap().keys().all(|k| !k.contains("snake")),
        "--chain rope logs the rope only: {:?}",
        keys(&v)
    );
    // One rope per state, at consecutive sequence numbers ending at the service's.
    let rope_e = &v["/chains/rope/rope"];
    assert_eq!(rope_e["rows"], states as u64);
    let mut seqs: Vec<u64> = serde_json::from_value(rope_e["sequences"].clone()).unwrap();
    seqs.sort_unstable();
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    assert_eq!(*seqs.last().unwrap(), last.header.sequence);

    // The last strip is the service's last state, as f32.
    let strips = rope_e["values"]["strips"].as_array().unwrap();
    let (_, strip) = strips
        .iter()
        .map(|e| (e[0].as_u64().unwrap(), &e[1]))
        .max_by_key(|(s, _)| *s)
        .unwrap();
    let strip: Vec<Vec<[f32; 3]>> = serde_json::from_value(strip.clone()).unwrap();
    let expected: Vec<[f32; 3]> = last
        .joints()
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    assert_eq!(strip, vec![expected]);

    // Held: the tail labelled "grasp 0" at its position while held; nothing after the release.
    let held = &v["/chains/rope/held"]["values"];
    let at = |what: &str, seq: u64| -> serde_json::Value {
        held[what]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e[0].as_u64() == Some(seq))
            .map(|e| e[1].clone())
            .unwrap_or(serde_json::Value::Null)
    };
    let held_seq = held_last.header.sequence;
    assert_eq!(at("labels", held_seq), serde_json::json!(["grasp 0"]));
    let tail = held_last.joints()[0];
    assert_eq!(
        at("positions", held_seq),
        serde_json::json!([[tail.x as f32, tail.y as f32, tail.z as f32]])
    );
    let after = at("positions", last.header.sequence);
    assert!(after.is_null() || after == serde_json::json!([]), "{after}");

    // The knot is named (a rope dragged around a circle stays unknotted) and a round trip was timed.
    let knots = v["/chains/rope/knot"]["values"]["text"].as_array().unwrap();
    assert!(
        knots[0][1][0].as_str().unwrap().starts_with("unknot"),
        "{knots:?}"
    );
    let rtts = v["/latency/query_round_trip_us"]["values"]["scalars"]
        .as_array()
        .unwrap();
    assert!(!rtts.is_empty());
    for r in rtts {
        let us = r[1][0].as_f64().unwrap();
        assert!(us > 0.0 && us < 60e6, "{us}");
    }
}

fn keys(v: &serde_json::Value) -> Vec<String> {
    v.as_object().unwrap().keys().cloned().collect()
}

/// Rotates `v` by the unit quaternion `q` (x, y, z, w), written here.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [x, y, z, w] = q;
    let u = [x, y, z];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    // v' = v + 2w (u × v) + 2 u × (u × v)
    let t = cross(u, v);
    let t2 = cross(u, t);
    [
        v[0] + 2.0 * w * t[0] + 2.0 * t2[0],
        v[1] + 2.0 * w * t[1] + 2.0 * t2[1],
        v[2] + 2.0 * w * t[2] + 2.0 * t2[2],
    ]
}

/// The instruments are drawn: a capsule from its end `a` along its axis and a sphere at its centre,
/// at every state, where the test moved them (expected poses computed here from the requests).
#[test]
fn watch_draws_the_instruments_where_the_service_has_them() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("suture.toml");
    std::fs::write(&scene, crate::instruments::SCENE).unwrap();
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--no-persist",
            "--wait",
            "event",
        ],
    );
    let rrd = dir.path().join("instruments.rrd");
    let steps = 6;
    let (watch, rx) = start_watch(&svc.prefix, &rrd, steps, &[]);
    let mut c = svc.connect();
    // The driver steps towards the rope, turning; the ball rises.
    let mut last_driver = ([0.0; 3], [0.0; 3]);
    let mut last_ball = [0.0; 3];
    let mut last_seq = 0;
    for k in 0..steps / 2 {
        let y = -2.8 + 0.1 * k as f64;
        let dir_ = [0.0, 0.2 * k as f64, 1.0];
        let mut h = RequestHeader::new(Command::Instrument, 0);
        h.joint = 0;
        let r = c
            .call(
                h,
                &[
                    Vec3::new(20.3, y, 0.0),
                    Vec3::new(dir_[0], dir_[1], dir_[2]),
                ],
            )
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        let n = (dir_[1] * dir_[1] + 1.0).sqrt();
        let d = [0.0, dir_[1] / n * 20.0, 20.0 / n];
        last_driver = (
            [20.3 - d[0], y - d[1], -d[2]],
            [20.3 + d[0], y + d[1], d[2]],
        );
        let mut h = RequestHeader::new(Command::Instrument, 0);
        h.joint = 1;
        last_ball = [5.0, 6.0, 0.2 * (k + 1) as f64];
        let r = c
            .call(h, &[Vec3::new(last_ball[0], last_ball[1], last_ball[2])])
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        last_seq = r.header.sequence;
    }
    wait_for(watch, &rx);
    let v = read_rrd(&rrd);
    let last_of = |entity: &str, what: &str| -> serde_json::Value {
        let e = &v[entity];
        assert_eq!(e["rows"], steps as u64, "{entity}: one row per state");
        e["values"][what]
            .as_array()
            .unwrap_or_else(|| panic!("{entity} has no {what}: {e}"))
            .iter()
            .find(|x| x[0].as_u64() == Some(last_seq))
            .map(|x| x[1].clone())
            .unwrap_or_else(|| panic!("{entity}: no {what} at {last_seq}"))
    };
    let near = |got: &serde_json::Value, want: [f64; 3], what: &str| {
        let g: [f64; 3] = serde_json::from_value(got.clone()).unwrap();
        for (a, b) in g.iter().zip(want) {
            assert!((a - b).abs() < 1e-4, "{what}: {g:?} against {want:?}");
        }
    };
    let capsule = "/chains/suture/instruments/0";
    let (a, b) = last_driver;
    near(&last_of(capsule, "translations")[0], a, "capsule start");
    let length = last_of(capsule, "lengths")[0].as_f64().unwrap();
    let axis = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    assert!((length - len).abs() < 1e-4, "{length} against {len}");
    let q: [f64; 4] = serde_json::from_value(last_of(capsule, "quaternions")[0].clone()).unwrap();
    let along = rotate(q, [0.0, 0.0, len]);
    near(
        &serde_json::json!([a[0] + along[0], a[1] + along[1], a[2] + along[2]]),
        b,
        "capsule end (translation + rotated +Z × length)",
    );
    assert!((last_of(capsule, "radii")[0].as_f64().unwrap() - 0.3).abs() < 1e-6);
    let ball = "/chains/suture/instruments/1";
    near(&last_of(ball, "centers")[0], last_ball, "sphere centre");
    near(&last_of(ball, "half_sizes")[0], [0.5; 3], "sphere radius");
}

/// Tension in the Rerun view (issue 38): the default rope held at both ends, its head pulled out
/// along the rope beyond its length with the pull flag. At the last state the recording's pull
/// arrow starts at the head and is the over-pull back toward the tail, its length is the head's
/// pull scalar, and the stretch between the holds is drawn taut: the over-pull computed here from
/// the target, the tail and the rope's length.
#[test]
fn watch_draws_the_pull_on_a_held_joint_and_the_taut_stretch() {
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("pull.rrd");
    let mut c = svc.connect();
    let d = c
        .call(RequestHeader::new(Command::Describe, 0), &[])
        .unwrap();
    let (length, joints) = (d.header.total_length, d.joints().to_vec());
    let (tail, head) = (joints[0], joints[joints.len() - 1]);
    let n = joints.len() - 1;
    let steps = 5;
    let (watch, rx) = start_watch(&svc.prefix, &rrd, steps, &[]);
    for j in [0, JOINT_HEAD] {
        let mut h = RequestHeader::new(Command::Grasp, 0);
        h.joint = j;
        assert!(c.call(h, &[]).unwrap().is_ok());
    }
    // Along the rope, 0.5 then 1.5 beyond its length.
    let along = [
        (head.x - tail.x) / length,
        (head.y - tail.y) / length,
        (head.z - tail.z) / length,
    ];
    for over in [0.5, 1.5, 3.0] {
        let target = Vec3::new(
            tail.x + along[0] * (length + over),
            tail.y + along[1] * (length + over),
            tail.z + along[2] * (length + over),
        );
        let mut h = RequestHeader::new(Command::Move, 0);
        h.flags = shared::FLAG_PULL;
        let r = c.call(h, &[target]).unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
    }
    let last_seq = steps as u64;
    wait_for(watch, &rx);
    let v = read_rrd(&rrd);
    let at_last = |entity: &str, what: &str| -> serde_json::Value {
        v[entity]["values"][what]
            .as_array()
            .unwrap_or_else(|| panic!("{entity} has no {what}: {}", v[entity]))
            .iter()
            .find(|x| x[0].as_u64() == Some(last_seq))
            .map(|x| x[1].clone())
            .unwrap_or_else(|| panic!("{entity}: no {what} at {last_seq}"))
    };
    let over = 3.0;
    let vectors: Vec<[f64; 3]> =
        serde_json::from_value(at_last("/chains/rope/pulls", "vectors")).unwrap();
    let origins: Vec<[f64; 3]> =
        serde_json::from_value(at_last("/chains/rope/pulls", "origins")).unwrap();
    // Two arrows: the head's own pull and the tail's, carried along the taut rope.
    assert_eq!(vectors.len(), 2, "{vectors:?}");
    let k = origins
        .iter()
        .position(|o| (o[0] - head.x).abs() < 1e-3 && (o[1] - head.y).abs() < 1e-3)
        .expect("an arrow from the head");
    let want = [-along[0] * over, -along[1] * over, -along[2] * over];
    for (a, b) in vectors[k].iter().zip(want) {
        assert!((a - b).abs() < 1e-4, "{:?} against {want:?}", vectors[k]);
    }
    let scalar = at_last(&format!("/chains/rope/pull/joint_{n}"), "scalars");
    let s = scalar
        .as_array()
        .map_or(scalar.as_f64(), |a| a[0].as_f64())
        .unwrap();
    assert!((s - over).abs() < 1e-6, "the head's pull scalar {s}");
    let strips = at_last("/chains/rope/taut", "strips");
    assert_eq!(strips.as_array().map(|a| a.len()), Some(1), "{strips}");
}

/// A bundle in the Rerun view: `watch --save` subscribes to the bundles' stream and logs each state
/// of the bundle as one line strip per strand, on the bundle's own timeline; the last strips are the
/// service's last state, strand by strand.
#[test]
fn watch_draws_a_bundles_strands() {
    const STRANDS: usize = 12;
    const LINKS: usize = 5;
    const MOVES: usize = 4;
    let (svc, dir) = tests::service_on_scene(&format!(
        "[[chain]]\nname = \"rope\"\nlinks = 10\nlink_length = 1.0\n\n\
             [[bundle]]\nname = \"hair\"\nstrands = {STRANDS}\nlinks = {LINKS}\n\
             link_length = 0.3\ncolumns = 4\nspacing = 0.5\norigin = [0.0, 0.0, 2.0]\n"
    ));
    let rrd = dir.path().join("hair.rrd");
    let (watch, rx) = start_watch(&svc.prefix, &rrd, MOVES, &["--chain", "hair"]);
    let mut c = svc.connect();
    let hair = c.find_chain("hair").unwrap().expect("the bundle");
    let start = c
        .call(RequestHeader::new(Command::Query, hair), &[])
        .unwrap();
    let heads: Vec<Vec3> = start.joints().chunks(LINKS + 1).map(|s| s[LINKS]).collect();
    for m in 1..=MOVES {
        let targets: Vec<Vec3> = heads
            .iter()
            .enumerate()
            .map(|(i, h)| {
                let a = 0.9 * (i + m) as f64;
                Vec3::new(h.x + 0.3 * a.cos(), h.y + 0.3 * a.sin(), h.z)
            })
            .collect();
        let r = c
            .call(RequestHeader::new(Command::Move, hair), &targets)
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        // A viewer's pace (the bundles' stream buffers two samples per subscriber).
        std::thread::sleep(Duration::from_millis(100));
    }
    let last = c
        .call(RequestHeader::new(Command::Query, hair), &[])
        .unwrap();
    let said = wait_for(watch, &rx);
    assert!(
        said.iter()
            .any(|l| l.contains(&format!("{MOVES} states sent to Rerun"))),
        "{said:?}"
    );
    let v = read_rrd(&rrd);
    let e = &v["/bundles/hair/strands"];
    assert!(e.is_object(), "no bundle entity in {:?}", keys(&v));
    assert_eq!(e["rows"], MOVES as u64);
    let mut seqs: Vec<u64> = serde_json::from_value(e["bundle_sequences"].clone()).unwrap();
    seqs.sort_unstable();
    assert_eq!(seqs, (1..=MOVES as u64).collect::<Vec<_>>());
    // The service's last state is among the logged ones: one strip per strand, each the strand's
    // joints (tail first) as f32.
    let expected: Vec<Vec<[f32; 3]>> = last
        .joints()
        .chunks(LINKS + 1)
        .map(|s| {
            s.iter()
                .map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect()
        })
        .collect();
    let strips = e["values"]["strips"].as_array().unwrap();
    assert_eq!(strips.len(), MOVES);
    assert!(
        strips.iter().any(|s| {
            serde_json::from_value::<Vec<Vec<[f32; 3]>>>(s[1].clone()).unwrap() == expected
        }),
        "the last state is not among the logged strips"
    );
}

/// Issue 34: the view draws the joints at their limit. A suture with a bend radius (`bend-80` of
/// knots.toml: 80 links of 0.5, R_min 1.5) has its head led round a circle tighter than the radius
/// allows; at the last state the recording's `at_limit` joints are exactly those this test finds
/// turned to their cone `2·atan(L / 2R_min)` (angles computed here from the service's joints), and
/// there are some.
#[test]
fn the_view_marks_the_joints_at_their_bend_limit() {
    let scene = workspace().join("solver-service/scenes/knots.toml");
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--no-persist",
            "--wait",
            "event",
            "--scene",
            scene.to_str().unwrap(),
        ],
    );
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("bend.rrd");
    const STEPS: usize = 40;
    let (watch, rx) = start_watch(&svc.prefix, &rrd, STEPS, &["--chain", "bend-80"]);
    let mut c = svc.connect();
    let chain = c.find_chain("bend-80").unwrap().expect("bend-80");
    for i in 0..STEPS {
        // A circle of radius 0.8 about (38.5, 0.8): tighter than the bend radius of 1.5.
        let a = i as f64 * 0.25;
        let mut mv = RequestHeader::new(Command::Move, chain);
        mv.joint = JOINT_HEAD;
        let target = Vec3::new(38.5 + 0.8 * a.sin(), 0.8 - 0.8 * a.cos(), 0.0);
        let r = c.call(mv, &[target]).unwrap();
        assert!(r.is_ok(), "{:?}", r.header.reason_str());
    }
    let last = c
        .call(RequestHeader::new(Command::Query, chain), &[])
        .unwrap();
    wait_for(watch, &rx);
    // The test's own turn angles.
    let p: Vec<[f64; 3]> = last.joints().iter().map(|q| [q.x, q.y, q.z]).collect();
    let mut expected = Vec::new();
    for j in 1..p.len() - 1 {
        let u: Vec<f64> = (0..3).map(|k| p[j][k] - p[j - 1][k]).collect();
        let v: Vec<f64> = (0..3).map(|k| p[j + 1][k] - p[j][k]).collect();
        let (nu, nv) = (
            u.iter().map(|x| x * x).sum::<f64>().sqrt(),
            v.iter().map(|x| x * x).sum::<f64>().sqrt(),
        );
        let cos = u.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>() / (nu * nv);
        let turn = cos.clamp(-1.0, 1.0).acos();
        let cone = 2.0 * (nu.min(nv) / 3.0).atan();
        assert!(turn <= cone + 1e-9, "joint {j} beyond its cone");
        if turn >= cone - 1e-6 {
            expected.push(j.to_string());
        }
    }
    assert!(!expected.is_empty(), "no joint reached the bend limit");
    let v = read_rrd(&rrd);
    let labels = v["/chains/bend-80/at_limit"]["values"]["labels"]
        .as_array()
        .expect("at_limit labels");
    let (_, at_last) = labels
        .iter()
        .map(|e| (e[0].as_u64().unwrap(), e[1].clone()))
        .max_by_key(|(s, _)| *s)
        .unwrap();
    let logged: Vec<String> = serde_json::from_value(at_last).unwrap();
    assert_eq!(logged, expected);
}

/// Issue 39: the Rerun view draws a chain's eyelets where the scene put them, each labelled with
/// the link through it. The service's rope is moved twice; at the last state the recording's eyelet
/// points are the scene's and their labels name the links that the test finds passing through them
/// in the last response's joints (the nearest segment, computed here).
#[test]
fn watch_draws_the_eyelets_on_the_links_through_them() {
    let (svc, dir) = tests::suture_service();
    let points = tests::SUTURE_EYELETS;
    let rrd = dir.path().join("eyelets.rrd");
    let (watch, rx) = start_watch(&svc.prefix, &rrd, 2, &[]);
    let mut c = svc.connect();
    let mut joints = Vec::new();
    for t in [Vec3::new(41.0, 5.0, 2.0), Vec3::new(43.0, 3.0, -2.0)] {
        let mut h = RequestHeader::new(Command::Move, 0);
        h.joint = JOINT_HEAD;
        let r = c.call(h, &[t]).unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        joints = r.joints().to_vec();
    }
    wait_for(watch, &rx);
    let links: Vec<String> = points
        .iter()
        .map(|p| {
            let (k, d, _) = tests::nearest_link(&joints, *p);
            assert!(d < 1e-9, "the rope passes {d:e} from {p:?}");
            format!("link {k}")
        })
        .collect();
    let v = read_rrd(&rrd);
    let e = &v["/chains/suture/eyelets"]["values"];
    let last = |what: &str| -> serde_json::Value {
        e[what]
            .as_array()
            .unwrap_or_else(|| panic!("no {what}: {e}"))
            .iter()
            .find(|x| x[0].as_u64() == Some(2))
            .map(|x| x[1].clone())
            .unwrap_or_else(|| panic!("no {what} at state 2: {e}"))
    };
    let at: Vec<[f64; 3]> = serde_json::from_value(last("positions")).unwrap();
    assert_eq!(at, points);
    let labels: Vec<String> = serde_json::from_value(last("labels")).unwrap();
    assert_eq!(labels, links);
    // The chain's tissue, from the describe: one static box, its centre and half sizes the scene's.
    let (lo, hi) = tests::SUTURE_TISSUE;
    let t = &v["/chains/suture/tissue"]["static"];
    // (Rows of instances: one row, one box.)
    let centres: Vec<Vec<[f64; 3]>> = serde_json::from_value(t["centers"].clone())
        .unwrap_or_else(|e| panic!("no tissue box ({e}): {t}"));
    let halves: Vec<Vec<[f64; 3]>> = serde_json::from_value(t["half_sizes"].clone()).unwrap();
    assert_eq!((centres.len(), centres[0].len()), (1, 1), "{t}");
    for k in 0..3 {
        assert!(
            (centres[0][0][k] - (lo[k] + hi[k]) / 2.0).abs() < 1e-5,
            "{t}"
        );
        assert!(
            (halves[0][0][k] - (hi[k] - lo[k]) / 2.0).abs() < 1e-5,
            "{t}"
        );
    }
}
