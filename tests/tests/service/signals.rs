//! SIGTERM and SIGINT end the service with its final snapshot, in every wait mode, idle, under a 1 kHz
//! client and under a client at full speed; 20 times per mode (issue 15). The serving loop looks for a
//! termination request at least every millisecond whatever the traffic; before the one serving loop, a
//! hybrid service under a 1 kHz client consumed the request in its spin phase and ran on for good.
//!
//! Speed is not asserted here (tests share two noisy cores; a final snapshot's `fsync` beside a compiler
//! takes hundreds of milliseconds): the deadline only tells a service that exits from one that runs on.
//! Each test prints its exit times; `cargo test -p tests --test service signals -- --nocapture
//! --test-threads 1` on an idle machine is the measurement the README quotes.
//!
//! The journal is off, so the shutdown snapshot alone carries the state: it is read back in this
//! process (`Store::restore`) and must hold exactly the last state a client was told about.

use clients::{ConnectOptions, Connection, Wait};
use shared::{Command, JOINT_HEAD, RequestHeader, Vec3};
use solver_service::persist::{JournalMode, Store};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};
use tests::{Service, unique_prefix};
use world::World;
use world::scene::default_scene;

/// How long a signalled service may take to exit, final snapshot included, before it counts as running
/// on (the bug this guards against never exited at all).
const EXIT_WITHIN: Duration = Duration::from_secs(5);

#[derive(Clone, Copy, Debug)]
enum Load {
    Idle,
    /// One move per millisecond.
    Rate1kHz,
    /// Moves back to back.
    FullSpeed,
}

/// One run: start, load, signal, time the exit, read the snapshot back. Returns the exit time.
fn one_run(wait: &str, load: Load, sig: &str) -> Duration {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state");
    let d = state.to_str().unwrap();
    let mut svc = Service::start(
        &unique_prefix(),
        &["--state-dir", d, "--journal", "off", "--wait", wait],
    );
    let stop = Arc::new(AtomicBool::new(false));
    let last_acked = Arc::new(AtomicU64::new(0));
    let client = match load {
        Load::Idle => None,
        Load::Rate1kHz | Load::FullSpeed => {
            let (stop, last, prefix) = (stop.clone(), last_acked.clone(), svc.prefix.clone());
            Some(std::thread::spawn(move || {
                // The client sleeps on its listener (at most one spinning thread per core: a spin
                // service is one).
                let mut c = Connection::connect(ConnectOptions {
                    prefix,
                    wait: Wait::Event,
                    connect_timeout: Duration::from_secs(5),
                    call_timeout: Duration::from_secs(5),
                    max_request_points: 1,
                })
                .expect("connect");
                let mut i = 0u32;
                while !stop.load(Ordering::Relaxed) {
                    let t = f64::from(i) * 0.01;
                    let mut h = RequestHeader::new(Command::Move, 0);
                    h.joint = JOINT_HEAD;
                    match c.call(h, &[Vec3::new(40.0 + t.cos(), t.sin(), 0.0)]) {
                        Ok(r) if r.is_ok() => last.store(r.header.sequence, Ordering::Relaxed),
                        Ok(r) => panic!("refused: {}", r.header.reason_str()),
                        // The service went away mid-call: the signal did its work.
                        Err(_) => break,
                    }
                    if matches!(load, Load::Rate1kHz) {
                        std::thread::sleep(Duration::from_millis(1));
                    }
                    i += 1;
                }
            }))
        }
    };
    if client.is_some() {
        // Let the traffic settle into its rhythm (a hybrid service spins between requests by now).
        let t0 = Instant::now();
        while last_acked.load(Ordering::Relaxed) < 20 {
            assert!(
                t0.elapsed() < Duration::from_secs(60),
                "the client made no progress"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    let sent = Instant::now();
    svc.signal(sig);
    let status = svc.wait_exit(Duration::from_secs(10));
    let took = sent.elapsed();
    stop.store(true, Ordering::Relaxed);
    if let Some(t) = client {
        t.join().expect("the client thread");
    }
    assert!(status.success(), "{wait} {load:?} {sig}: {status:?}");
    // The final snapshot holds the last state a client was told about.
    let mut set = World::new(&default_scene()).unwrap();
    Store::open(&state, JournalMode::Off)
        .unwrap()
        .restore(&mut set, false)
        .unwrap_or_else(|e| panic!("{wait} {load:?} {sig}: {e}"));
    assert_eq!(
        set.sequence(),
        last_acked.load(Ordering::Relaxed),
        "{wait} {load:?} {sig}: the snapshot is not the last acknowledged state"
    );
    took
}

fn twenty_runs(wait: &str) {
    let mut worst = (Duration::ZERO, String::new());
    let mut all = Vec::new();
    for i in 0..20 {
        let load = [Load::Idle, Load::Rate1kHz, Load::FullSpeed][i % 3];
        let sig = if i % 2 == 0 { "TERM" } else { "INT" };
        let took = one_run(wait, load, sig);
        all.push(took);
        if took > worst.0 {
            worst = (took, format!("{load:?} SIG{sig}"));
        }
    }
    all.sort();
    eprintln!(
        "--wait {wait}: signal to exit (final snapshot included) over 20 runs: median {:.1} ms, max {:.1} ms ({})",
        all[10].as_secs_f64() * 1e3,
        worst.0.as_secs_f64() * 1e3,
        worst.1
    );
    assert!(
        worst.0 <= EXIT_WITHIN,
        "--wait {wait}: the slowest exit took {:?} ({}), more than {EXIT_WITHIN:?}",
        worst.0,
        worst.1
    );
}

#[test]
fn signals_end_a_spinning_service_promptly_with_its_snapshot() {
    twenty_runs("spin");
}

#[test]
fn signals_end_a_sleeping_service_promptly_with_its_snapshot() {
    twenty_runs("event");
}

#[test]
fn signals_end_a_hybrid_service_promptly_with_its_snapshot() {
    twenty_runs("hybrid");
}

/// Periodic snapshots happen at their period under sustained traffic (issue 15: before the one serving
/// loop, a hybrid service under a 1 kHz client never left its spin phase to take one, and the journal
/// grew without bound). Over 1.5 s of a 1 kHz client with `--snapshot-every 0.2`, the snapshot file is
/// replaced again and again, and the journal, emptied at each snapshot, stays short.
#[test]
fn periodic_snapshots_happen_under_traffic() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state");
    let d = state.to_str().unwrap();
    let svc = Service::start(
        &unique_prefix(),
        &[
            "--state-dir",
            d,
            "--snapshot-every",
            "0.2",
            "--wait",
            "hybrid",
        ],
    );
    let mut c = svc.connect_with(Wait::Event);
    let snapshot = state.join("snapshot.bin");
    let journal = state.join("journal.bin");
    let modified = || std::fs::metadata(&snapshot).and_then(|m| m.modified()).ok();
    let mut seen = vec![modified()];
    let mut longest_journal = 0;
    let t0 = Instant::now();
    let mut i = 0u32;
    let mut round_trips = Vec::new();
    while t0.elapsed() < Duration::from_millis(1500) {
        let t = f64::from(i) * 0.01;
        let sent = Instant::now();
        let r = c
            .call(
                RequestHeader::new(Command::Move, 0),
                &[Vec3::new(40.0 + t.cos(), t.sin(), 0.0)],
            )
            .unwrap();
        assert!(r.is_ok(), "{}", r.header.reason_str());
        round_trips.push(sent.elapsed());
        let m = modified();
        if m != *seen.last().unwrap() {
            seen.push(m);
        }
        longest_journal = longest_journal.max(std::fs::metadata(&journal).map_or(0, |m| m.len()));
        std::thread::sleep(Duration::from_millis(1));
        i += 1;
    }
    // What a snapshot costs the client (not asserted: a timing; the README quotes a run of
    // `cargo test -p tests --test service periodic -- --nocapture` on an idle machine).
    round_trips.sort();
    let at =
        |q: f64| round_trips[((round_trips.len() - 1) as f64 * q) as usize].as_secs_f64() * 1e6;
    eprintln!(
        "1 kHz client with a snapshot every 0.2 s: {} snapshots, {i} requests, round trip p50 {:.0} µs, \
         p99 {:.0} µs, max {:.0} µs",
        seen.len() - 1,
        at(0.5),
        at(0.99),
        at(1.0)
    );
    // 1.5 s at one snapshot per 0.2 s is 7; a loaded machine may stretch the client's loop, not the
    // service's period, so ask for 3.
    assert!(
        seen.len() > 3,
        "the snapshot was replaced {} times in 1.5 s of traffic ({i} requests)",
        seen.len() - 1
    );
    // Fewer than all the requests' records: the journal is emptied at each snapshot.
    let all_records = u64::from(i) * 100;
    assert!(
        longest_journal < all_records / 2,
        "the journal reached {longest_journal} bytes for {i} requests"
    );
}

/// A service stopped and continued (Ctrl-Z then `fg`, a debugger, a frozen container) keeps serving: the
/// wake-up that continuing causes is not a termination request (iceoryx2 reports any interrupted wait
/// alike). In every wait mode: continued, it answers a query, then SIGTERM still ends it cleanly.
#[test]
fn a_service_stopped_and_continued_keeps_serving() {
    for mode in ["event", "hybrid", "spin"] {
        let mut svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", mode]);
        svc.signal("STOP");
        std::thread::sleep(std::time::Duration::from_millis(200));
        svc.signal("CONT");
        let mut c = svc.connect();
        let r = c
            .call(shared::RequestHeader::new(shared::Command::Query, 0), &[])
            .unwrap_or_else(|e| panic!("{mode}: no answer after SIGCONT: {e}"));
        assert!(r.is_ok(), "{mode}");
        drop(c);
        svc.signal("TERM");
        let st = svc.wait_exit(std::time::Duration::from_secs(30));
        assert!(st.success(), "{mode}: {st:?}");
    }
}
