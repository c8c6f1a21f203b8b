//! What the journal costs per request, beside what the request itself costs, measured in one run.
//!
//! `cargo bench -p solver-service --bench journal` prints, for a head move of the 40-link rope with
//! 8 substeps: the solve time and the journal append time with the journal off, written (survives
//! `kill -9`) and fsynced (survives power loss): median, p99 and max over interleaved rounds.

use shared::{Command, RequestHeader, SubstepMode, Vec3};
use solver_service::persist::{JournalMode, Store};
use solver_service::serve::respond;
use solver_service::service::Solver;
use std::time::Instant;
use world::World;
use world::owners::LOCAL;
use world::scene::default_scene;

fn pct(v: &mut [u64], p: f64) -> u64 {
    v.sort_unstable();
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let rounds = 20;
    let per_round = std::env::var("JOURNAL_BENCH_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(500);
    let modes = [JournalMode::Off, JournalMode::Write, JournalMode::Fsync];
    let mut solve: Vec<Vec<u64>> = vec![Vec::new(); 3];
    let mut append: Vec<Vec<u64>> = vec![Vec::new(); 3];
    let dir = tempfile::tempdir().expect("temp dir");
    let mut out = Vec::new();
    let mut req = RequestHeader::new(Command::Move, 0);
    req.substep_mode = SubstepMode::Fixed as u32;
    req.substeps = 8;
    for round in 0..rounds {
        for (m, mode) in modes.iter().enumerate() {
            // fsync rounds are slow; fewer of them give the same medians.
            let n = if *mode == JournalMode::Fsync {
                per_round / 10
            } else {
                per_round
            };
            let set = World::new(&default_scene()).expect("scene");
            let mut store = Store::open(&dir.path().join(format!("{m}")), *mode).expect("store");
            store.snapshot(&set).expect("snapshot");
            // The service's answer path without its store: the append is timed on its own.
            let mut solver = Solver::new(set, None, std::time::Duration::ZERO);
            for i in 0..n {
                let t = (round * n + i) as f64 * 0.01;
                let p = [Vec3::new(40.0 + t.cos(), t.sin(), 0.1 * t)];
                let t0 = Instant::now();
                assert!(respond(&mut solver, LOCAL, &req, &p, &mut out).1);
                let t1 = Instant::now();
                store
                    .append(solver.set().sequence(), &req, &p)
                    .expect("append");
                let t2 = Instant::now();
                solve[m].push((t1 - t0).as_nanos() as u64);
                append[m].push((t2 - t1).as_nanos() as u64);
            }
        }
        eprint!("\rround {}/{rounds}", round + 1);
    }
    eprintln!();
    println!(
        "Head moves of the default rope (40 links, 8 substeps), {rounds} rounds interleaving the modes, \
         {per_round} requests per round ({} with fsync); \"solve\" is the whole request path without IPC \
         (`serve::respond` on the solver, without its store), \"append\" the journal record written after it:\n",
        per_round / 10
    );
    println!(
        "| journal | solve p50 (µs) | append p50 (µs) | append p99 (µs) | append max (µs) \
         | append p50 ÷ solve p50 |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for (m, mode) in modes.iter().enumerate() {
        let s50 = pct(&mut solve[m], 0.5);
        let a50 = pct(&mut append[m], 0.5);
        let a99 = pct(&mut append[m], 0.99);
        let amax = pct(&mut append[m], 1.0);
        println!(
            "| {mode:?} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} |",
            s50 as f64 / 1e3,
            a50 as f64 / 1e3,
            a99 as f64 / 1e3,
            amax as f64 / 1e3,
            a50 as f64 / s50 as f64
        );
    }
}
