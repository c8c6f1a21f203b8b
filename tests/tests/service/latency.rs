//! The latency tools as a user runs them (issue 5): `latency client` against the service, the raw
//! iceoryx2 echo and the Unix-socket server, every request answered and accounted for; `latency bench`
//! runs its driver end to end (event mode only, no loaded run: the tests share two cores).

use clients::process::Proc;
use shared::{Command, RequestHeader};
use std::process::{Command as Process, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};
use tests::{Service, bin, unique_prefix};

const TIMEOUT: Duration = Duration::from_secs(120);

/// Runs a binary to its end with a deadline; returns (success, stdout, stderr).
fn run(args: &[&str]) -> (bool, String, String) {
    let child = Process::new(bin("latency"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn latency");
    let deadline = Instant::now() + TIMEOUT;
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    let out = rx
        .recv_timeout(deadline.saturating_duration_since(Instant::now()))
        .expect("latency finished in time")
        .expect("latency output");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn summary(args: &[&str]) -> clients::latency::Summary {
    let mut all = vec!["client", "--samples", "200", "--warmup", "20", "--json"];
    all.extend_from_slice(args);
    let (ok, out, err) = run(&all);
    assert!(ok, "latency {all:?} failed:\n{out}\n{err}");
    serde_json::from_str(out.lines().last().unwrap_or("")).expect("a JSON summary")
}

fn check(s: &clients::latency::Summary, what: &str) {
    assert_eq!(
        (s.ok, s.refused, s.mismatched),
        (200, 0, 0),
        "{what}: {s:?}"
    );
    assert_eq!(s.elements, 41, "{what}");
    let p = s.round_trip;
    assert_eq!(p.count, 200, "{what}");
    assert!(
        p.p50 > 0 && p.p50 <= p.p99 && p.p99 <= p.max,
        "{what}: {p:?}"
    );
}

#[test]
fn latency_client_measures_the_service_the_raw_echo_and_the_unix_socket() {
    // The service: every move applied (sequence 220 afterwards), solve times reported.
    let svc = Service::start(&unique_prefix(), &["--wait", "event", "--no-persist"]);
    let s = summary(&["--prefix", &svc.prefix, "--wait", "event"]);
    check(&s, "service");
    assert!(s.solve.p50 > 1, "the service reports its solve time");
    let mut c = svc.connect();
    let q = c.call(RequestHeader::new(Command::Query, 0), &[]).unwrap();
    assert_eq!(
        q.header.sequence, 220,
        "every warm-up and timed move applied"
    );

    // The raw echo: same sizes, no solving.
    let prefix = unique_prefix();
    let mut echo = Process::new(bin("solver-service"));
    echo.args([
        "echo",
        "--prefix",
        &prefix,
        "--wait",
        "event",
        "--elements",
        "41",
    ]);
    let mut raw = Proc::ready(echo, "solver-service echo").unwrap();
    let s = summary(&["--prefix", &prefix, "--wait", "event", "--raw"]);
    check(&s, "raw echo");
    assert_eq!(s.solve.max, 1, "the echo solves nothing");
    raw.signal("TERM").unwrap();
    assert!(
        raw.wait_exit(Duration::from_secs(10)).unwrap().success(),
        "the echo stops cleanly on SIGTERM"
    );

    // The Unix socket: one connection, then the server exits and removes its socket.
    let dir = tempfile::tempdir().unwrap();
    let sock = dir.path().join("s.sock");
    let sock = sock.to_str().unwrap();
    let mut server = Process::new(bin("solver-service"));
    server.args(["unix", "--socket", sock, "--connections", "1"]);
    let mut unix = Proc::ready(server, "solver-service unix").unwrap();
    let s = summary(&["--unix", sock]);
    check(&s, "unix socket");
    assert!(unix.wait_exit(Duration::from_secs(10)).unwrap().success());
    assert!(
        !std::path::Path::new(sock).exists(),
        "the socket is removed"
    );
}

#[test]
fn latency_bench_prints_its_tables() {
    let (ok, out, err) = run(&[
        "bench",
        "--modes",
        "event",
        "--sizes",
        "5",
        "--samples",
        "50",
        "--warmup",
        "5",
        "--loaded-seconds",
        "0",
    ]);
    assert!(ok, "{out}\n{err}");
    for row in [
        "| 5 | raw iceoryx2 | event |",
        "| 5 | service, iceoryx2 | event |",
        "| 5 | service, Unix socket | blocking read |",
    ] {
        let line = out
            .lines()
            .find(|l| l.starts_with(row))
            .unwrap_or_else(|| panic!("no row {row:?} in\n{out}"));
        assert!(line.ends_with("| 0 |"), "nothing refused: {line}");
    }
    assert!(
        out.lines().any(|l| l.starts_with("| 5 | event | ")),
        "{out}"
    );
    assert!(err.contains("[3/3]"), "progress on stderr: {err}");
}

/// The load run (issue 6) for two seconds, nothing spinning (the tests share two cores): a hand at
/// full speed and one at 1 kHz on one rope plus a viewer. Every change is accounted for exactly once
/// over both hands, every response answers its own request in order, link lengths hold in every
/// response and every viewed state, and the tails are recorded.
#[test]
fn the_load_run_loses_and_duplicates_nothing() {
    let (ok, out, err) = run(&[
        "load",
        "--seconds",
        "2",
        "--no-pin",
        "--service-wait",
        "event",
        "--hand-wait",
        "event",
        "--json",
    ]);
    assert!(ok, "latency load failed:\n{out}\n{err}");
    let r: clients::latency_bench::LoadReport =
        serde_json::from_str(out.lines().last().unwrap_or("")).expect("a JSON report");
    assert!(r.problems().is_empty(), "{:?}", r.problems());
    assert_eq!((r.lost, r.duplicated), (0, 0));
    let (a, b) = (&r.full_speed, &r.one_khz);
    assert_eq!(r.changes, a.ok + b.ok + 1000, "warmup included: {r:?}");
    // How many moves fit in the run depends on the machine's load (a busy CI runner made 995 at
    // 1 kHz in 2 s); what does not is that both hands moved and the paced one kept its pace.
    assert!(a.ok > 0, "the full-speed hand made {} moves", a.ok);
    assert!(
        b.ok > 0 && b.ok <= 2000,
        "the 1 kHz hand made {} moves in 2 s",
        b.ok
    );
    for h in [a, b] {
        assert_eq!((h.refused, h.mismatched, h.out_of_order), (0, 0, 0));
        assert!(h.max_length_error < 1e-12, "{}", h.max_length_error);
        assert!(h.round_trip.p999 >= h.round_trip.p50 && h.round_trip.max > 0);
    }
    assert!(
        b.from_due.is_some(),
        "the 1 kHz hand counts from the due time"
    );
    assert!(r.viewer.contains(" 0 duplicated"), "{}", r.viewer);
    assert!(out.contains("| full speed (head) |"), "{out}");
}
