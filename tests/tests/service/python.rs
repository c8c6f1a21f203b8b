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
