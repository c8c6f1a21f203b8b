//! `tractrix_sweep` (clients/python, on Ray): a sweep of 23 short knot episodes on a local Ray of two
//! CPUs, each episode its own service on a unique prefix driven by the `hand` binaries, and 2 accuracy
//! episodes (the `episode` binary); resumed, with two failing episodes as rows. The checks are in
//! `sweep_check.py`.

use std::path::PathBuf;
use std::process::Command as Process;
use std::time::{Duration, Instant};
use tests::bin;

#[test]
fn a_sweep_on_a_local_ray_resumes_and_reports_failures() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let py = root.join("target/pyenv/bin/python");
    // Both binaries the episodes start, built if the runner did not.
    let service = bin("solver-service");
    assert!(bin("hand").exists() && bin("episode").exists());
    let bin_dir = service.parent().unwrap().to_path_buf();
    let work = tempfile::tempdir().unwrap();
    let t0 = Instant::now();
    let mut child = Process::new(&py)
        .arg(root.join("tests/tests/service/sweep_check.py"))
        .arg(&bin_dir)
        .arg(work.path())
        // Ray keeps its session files here, not in /tmp/ray of other runs.
        .env("RAY_TMPDIR", work.path())
        .env("TRACTRIX_TRUTH_CACHE", work.path().join("truth"))
        // Files, not pipes: nothing blocks on a full pipe while this waits.
        .stdout(std::fs::File::create(work.path().join("out.txt")).unwrap())
        .stderr(std::fs::File::create(work.path().join("err.txt")).unwrap())
        .spawn()
        .expect("run sweep_check.py (scripts/python-venv.sh installs ray)");
    let deadline = t0 + Duration::from_secs(600);
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the sweep took more than 600 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let stdout = std::fs::read_to_string(work.path().join("out.txt")).unwrap();
    let stderr = std::fs::read_to_string(work.path().join("err.txt")).unwrap();
    let tail: Vec<&str> = stderr.lines().rev().take(40).collect();
    assert!(
        status.success(),
        "{stdout}\n{}",
        tail.into_iter().rev().collect::<Vec<_>>().join("\n")
    );
    assert!(stdout.contains("| overhand | 40 |"), "{stdout}");
    eprintln!("{stdout}\nsweep test: {:.1} s", t0.elapsed().as_secs_f64());
}
