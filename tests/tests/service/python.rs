//! The Python client (`clients/python/tractrix_client.py`, PyPI wheel iceoryx2==0.10.0 in the venv that
//! `scripts/python-venv.sh` makes) against the real service: a move answered with every joint (counted
//! from the response header, not from the wheel's byte-counting slice), bit for bit what a Rust client
//! then reads; a bad target refused with its reason and the state unchanged.

use shared::{Command, RequestHeader};
use std::path::PathBuf;
use std::process::Command as Process;
use std::time::{Duration, Instant};
use tests::{Service, unique_prefix};

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn python() -> PathBuf {
    let py = workspace().join("target/pyenv/bin/python");
    if !py.exists() {
        let ok = Process::new(workspace().join("scripts/python-venv.sh"))
            .status()
            .expect("run scripts/python-venv.sh")
            .success();
        assert!(ok, "scripts/python-venv.sh failed");
    }
    py
}

/// Runs the MuJoCo loop (`clients/python/examples/mujoco_loop.py --json`) against the service at
/// `prefix` with `args`; its one JSON object (the run must succeed).
fn mujoco_loop(prefix: &str, args: &[&str]) -> serde_json::Value {
    let out = Process::new(python())
        .arg(workspace().join("clients/python/examples/mujoco_loop.py"))
        .args(["--prefix", prefix, "--json"])
        .args(args)
        .output()
        .expect("run the MuJoCo loop");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(text.trim()).expect("one JSON object")
}

fn client(prefix: &str, args: &[&str]) -> (Option<i32>, String, String) {
    let t0 = Instant::now();
    let out = Process::new(python())
        .arg(workspace().join("clients/python/tractrix_client.py"))
        .args(["--prefix", prefix])
        .args(args)
        .output()
        .expect("run the Python client");
    assert!(t0.elapsed() < Duration::from_secs(60));
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_python_client_moves_a_chain_and_reads_the_joints() {
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let (code, out, err) = client(&svc.prefix, &["move", "rope", "35", "8", "2"]);
    assert_eq!(code, Some(0), "{out}\n{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("JSON");
    assert_eq!(v["status"], "ok");
    assert_eq!(v["sequence"], 1);
    let joints: Vec<[f64; 3]> = serde_json::from_value(v["joints"].clone()).unwrap();
    // 41 joints: the wheel's Slice.len() would have said 984 (bytes).
    assert_eq!(joints.len(), 41);
    assert_eq!(joints[40], [35.0, 8.0, 2.0]);
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    let rust: Vec<[f64; 3]> = q.joints().iter().map(|p| p.to_array()).collect();
    assert_eq!(joints, rust, "Python and Rust read the same bits");

    // A refused move: the reason, exit 1, nothing changed.
    let (code, _, err) = client(&svc.prefix, &["move", "rope", "nan", "0", "0"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("non-finite: point 0 is not finite"), "{err}");
    let q2 = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(q2.joints(), q.joints());
    assert_eq!(q2.header.sequence, 1);

    // The planar arm through the same client.
    let (code, out, err) = client(&svc.prefix, &["query", "arm"]);
    assert_eq!(code, Some(0), "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["n_links"], 10);

    // Its bench (scripts/lang-latency.sh times it): every move answered, percentiles printed.
    let (code, out, err) = client(&svc.prefix, &["bench", "rope", "50"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("50 moves at 0 Hz: round trip p50"), "{out}");
    let q3 = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(
        q3.header.sequence,
        1 + 55,
        "50 counted moves and 5 warming up"
    );
}

#[test]
fn the_python_client_without_a_service_says_so() {
    let (code, _, err) = client(
        &unique_prefix(),
        &["--wait-for-service", "0.3", "query", "rope"],
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("no solver-service runs"), "{err}");
}

/// The client installed as a package (`pip install clients/python`, done by scripts/python-venv.sh):
/// its `tractrix-client` command has chainctl's commands, and the module imports from anywhere.
#[test]
fn the_installed_python_package_has_chainctl_s_commands() {
    let py = python();
    let script = py.with_file_name("tractrix-client");
    assert!(
        script.exists(),
        "{} (scripts/python-venv.sh installs it)",
        script.display()
    );
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let run = |args: &[&str]| -> serde_json::Value {
        let out = Process::new(&script)
            .args(["--prefix", svc.prefix.as_str()])
            .args(args)
            .current_dir("/")
            .output()
            .expect("run tractrix-client");
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{args:?}: {text}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_str(text.trim()).expect("one JSON object")
    };
    let d = run(&["describe", "rope"]);
    assert_eq!(
        (d["name"].as_str(), d["n_links"].as_u64()),
        (Some("rope"), Some(40))
    );
    assert_eq!(d["total_length"], 40.0);
    assert_eq!(
        run(&["grasp", "rope", "--joint", "0"])["held"][0]["joint"],
        0
    );
    let p = run(&["path", "rope", "39,1,0", "38,2,0.5"]);
    // With the tail held the head lands within the fixed-base tolerance (1e-9 of the rope's length).
    let head: Vec<f64> = serde_json::from_value(p["joints"][40].clone()).unwrap();
    let off = ((head[0] - 38.0).powi(2) + (head[1] - 2.0).powi(2) + (head[2] - 0.5).powi(2)).sqrt();
    assert!(off <= 40.0 * 1e-9, "{head:?}");
    assert_eq!(
        p["joints"][0],
        serde_json::json!([0.0, 0.0, 0.0]),
        "the grasped tail stayed"
    );
    assert_eq!(
        run(&["release", "rope", "--joint", "0"])["held"],
        serde_json::json!([])
    );
    let r = run(&["reach", "arm", "1.0", "0.9", "0"]);
    assert!(r["residual"].as_f64().unwrap() < 1e-6, "{r}");
    assert_eq!(
        run(&["reset", "rope"])["joints"][40],
        serde_json::json!([40.0, 0.0, 0.0])
    );
    assert_eq!(run(&["query", "rope"])["sequence"], 5);
    // Korein & Badler's goals: the last link along (0, -1, 0), then a ball around the head it reached
    // (nothing moves).
    let o = run(&[
        "reach",
        "arm",
        "1.1",
        "0.8",
        "0",
        "--direction",
        "0",
        "-1",
        "0",
    ]);
    let j: Vec<Vec<f64>> = serde_json::from_value(o["joints"].clone()).unwrap();
    assert!(
        (j[10][0] - j[9][0]).abs() < 1e-12 && (j[10][1] - j[9][1] + 0.2).abs() < 1e-12,
        "{o}"
    );
    let w = run(&["reach", "arm", "1.1", "0.8", "0", "--within", "0.5"]);
    assert_eq!(w["joints"], o["joints"], "a head within the ball stays");
    let out = Process::new(&py)
        .args([
            "-c",
            "import tractrix_client; print(tractrix_client.__file__)",
        ])
        .current_dir("/")
        .output()
        .unwrap();
    let at = String::from_utf8_lossy(&out.stdout);
    assert!(at.contains("site-packages"), "imported from {at}");
}

/// The MuJoCo loop's haptic hand (`--coupling K`, issue 38): the suture's tail is grasped and the hand's
/// circle takes its end beyond the suture's length for part of each turn, every move sent with the
/// pull flag. The force the loop reports on the hand must be zero while the hand is within the
/// suture's length of the tail, K times the over-pull beyond it (so growing with it), pointing back
/// toward the tail: the over-pull computed here from the hand's positions, the tail and the length.
#[test]
fn the_mujoco_loop_turns_the_pull_into_a_force_on_the_hand() {
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let mut c = svc.connect();
    let d = c
        .call(RequestHeader::new(Command::Describe, 0), &[])
        .unwrap();
    let (length, tail) = (d.header.total_length, d.joints()[0]);
    let k = 100.0;
    let v = mujoco_loop(&svc.prefix, &["--steps", "600", "--coupling", "100"]);
    let hands: Vec<[f64; 3]> = serde_json::from_value(v["coupling"]["hand"].clone()).unwrap();
    let forces: Vec<[f64; 3]> = serde_json::from_value(v["coupling"]["forces"].clone()).unwrap();
    let stops: Vec<Option<String>> =
        serde_json::from_value(v["coupling"]["stops"].clone()).unwrap();
    assert_eq!(hands.len(), 600);
    assert_eq!(stops.len(), 600);
    let (mut slack, mut taut) = (0, 0);
    for ((h, f), stop) in hands.iter().zip(&forces).zip(&stops) {
        let r = [h[0] - tail.x, h[1] - tail.y, h[2] - tail.z];
        let dist = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let over = dist - length;
        let force = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        if over < -1e-3 {
            slack += 1;
            assert!(
                force <= 1e-6 * k,
                "hand {over} inside the length, force {force} N"
            );
            assert_eq!(stop, &None, "hand {over} inside the length");
        } else if over > 1e-3 {
            taut += 1;
            assert!(
                (force - k * over).abs() <= 1e-4 * k,
                "hand {over} beyond the length: force {force} N, not {}",
                k * over
            );
            // The service says why the stopped short: the rope is taut.
            assert_eq!(
                stop.as_deref(),
                Some("taut"),
                "hand {over} beyond the length"
            );
            let back = (f[0] * r[0] + f[1] * r[1] + f[2] * r[2]) / (force * dist);
            assert!(
                back < -0.999,
                "the force points {back} along the hand's direction"
            );
        }
    }
    assert!(
        slack > 100 && taut > 100,
        "{slack} slack and {taut} taut steps"
    );
}

/// The MuJoCo loop (clients/python/examples/mujoco_loop.py): MuJoCo steps with the suture's capsules
/// posed from the service every step; at the end every capsule sits between the two joints the service
/// holds (midpoints computed here from a Rust client's query); four frames are rendered offscreen.
#[test]
fn the_mujoco_loop_poses_the_capsules_where_the_service_puts_the_joints() {
    if !tests::system_packages("the MuJoCo loop's offscreen frames", &["libOSMesa"]) {
        return;
    }
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let frames = tempfile::tempdir().unwrap();
    let frames_dir = frames.path().to_str().expect("a UTF-8 path");
    let v = mujoco_loop(&svc.prefix, &["--steps", "300", "--frames", frames_dir]);
    assert_eq!(v["steps"], 300);
    // Four frames rendered offscreen (OSMesa): PNG files of a 640 × 360 picture.
    for k in 0..4 {
        let png = std::fs::read(frames.path().join(format!("mujoco-{k}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[16..24], &[0, 0, 2, 128, 0, 0, 1, 104], "640 x 360");
    }
    for part in ["mujoco_and_service", "service_call", "posing"] {
        assert!(v[part]["p50_us"].as_f64().unwrap() > 0.0, "{part}");
    }
    let centres: Vec<[f64; 3]> = serde_json::from_value(v["capsule_centres"].clone()).unwrap();
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(q.header.sequence, 301, "the reset, then one move per step");
    let j = q.joints();
    assert_eq!(centres.len(), j.len() - 1);
    for (i, m) in centres.iter().enumerate() {
        let want = [
            (j[i].x + j[i + 1].x) / 2.0,
            (j[i].y + j[i + 1].y) / 2.0,
            (j[i].z + j[i + 1].z) / 2.0,
        ];
        let off =
            ((m[0] - want[0]).powi(2) + (m[1] - want[1]).powi(2) + (m[2] - want[2]).powi(2)).sqrt();
        assert!(
            off < 1e-12,
            "capsule {i} is {off} from its joints' midpoint"
        );
    }
}

/// Issue 39: the MuJoCo loop knows a suture's eyelets. On a scene whose rope passes through two
/// eyelets the loop adds a sphere per eyelet and moves each to where the service has it every step;
/// at the end they are at the scene's points, and the service's rope (queried here) passes through
/// each (the nearest segment, computed here, to 1e-9).
#[test]
fn the_mujoco_loop_draws_the_suture_s_eyelets() {
    let (svc, _scene) = tests::suture_service();
    let points = tests::SUTURE_EYELETS;
    let v = mujoco_loop(&svc.prefix, &["--chain", "suture", "--steps", "200"]);
    let drawn: Vec<[f64; 3]> = serde_json::from_value(v["eyelets"].clone()).unwrap();
    assert_eq!(drawn, points);
    // The suture's tissue (from the describe) is a box of the MuJoCo model, where the scene put it.
    let (lo, hi) = tests::SUTURE_TISSUE;
    let centre: [f64; 3] = serde_json::from_value(v["tissue"]["centre"].clone()).unwrap();
    let half: [f64; 3] = serde_json::from_value(v["tissue"]["half"].clone()).unwrap();
    for k in 0..3 {
        assert_eq!(centre[k], (lo[k] + hi[k]) / 2.0, "{}", v["tissue"]);
        assert_eq!(half[k], (hi[k] - lo[k]) / 2.0, "{}", v["tissue"]);
    }
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    let j = q.joints();
    for p in points {
        let (_, d, _) = tests::nearest_link(j, p);
        assert!(d < 1e-9, "the rope passes {d:e} from the eyelet at {p:?}");
    }
}

/// Issue 39: the MuJoCo loop draws a chain's instruments, here a curved needle swaged to the suture's
/// head (`needle = [1, 135°, 0.15]`: six capsules). The loop moves the head round its circle, the
/// needle carried with it; at the end each capsule of the MuJoCo model lies where the service has
/// the needle (its ends, from a Rust client's query, to 1e-9), the first on the head.
#[test]
fn the_mujoco_loop_draws_the_needle() {
    let (svc, _dir) = tests::service_on_scene(
        "budget = 2000000\n[[chain]]\nname = \"suture\"\nlinks = 40\nlink_length = 0.5\n\
         base = [0.0, 0.0, 2.0]\nthickness = 0.1\ncollision = \"capsules\"\n\
         tissue = [[22.0, -6.0, -3.0], [34.0, 6.0, 0.0]]\nneedle = [1.0, 135.0, 0.15]\n",
    );
    let v = mujoco_loop(&svc.prefix, &["--chain", "suture", "--steps", "300"]);
    let drawn: Vec<[[f64; 3]; 2]> = serde_json::from_value(v["instruments"].clone()).unwrap();
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(q.header.sequence, 301, "the reset, then one move per step");
    let parts = shared::Parts::of_response(&q.header, &q.payload);
    let needle: Vec<_> = parts.instrument_poses().collect();
    assert_eq!((drawn.len(), needle.len()), (6, 6));
    let d = |p: [f64; 3], q: [f64; 3]| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
    for (k, (m, s)) in drawn.iter().zip(&needle).enumerate() {
        // The body's axis may run either way along the capsule.
        let (a, b) = (s.a.to_array(), s.b.to_array());
        let off = (d(m[0], a) + d(m[1], b)).min(d(m[0], b) + d(m[1], a));
        assert!(
            off < 1e-9,
            "capsule {k}: MuJoCo {m:?}, the service {a:?}–{b:?}"
        );
    }
    let head = parts.joints[parts.joints.len() - 1].to_array();
    assert!(
        d(needle[0].a.to_array(), head) < 1e-9,
        "the needle off the head"
    );
}
