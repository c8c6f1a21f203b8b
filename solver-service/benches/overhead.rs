//! What the service adds to the kernel's move (issue 18, "the service adds nothing"), without IPC.
//!
//! `cargo bench -p solver-service --bench overhead` moves the head of one free chain (no collision, no
//! holds, one substep, closed-form tractrix) of 40 and of 1000 unit links along a helix, in f64 and f32,
//! three ways side by side in one run, batches interleaved, every way making the same moves:
//!
//! * **kernel**: `Chain::move_joint` on a chain built from the same scene;
//! * **handle**: the service's request handler (`Solver::handle`, what `solve_ns` in a response
//!   times: decode, the work estimate, the undo copy, the move, the response header);
//! * **handle + payload**: `handle`, then the response's joints written out as the serving loop
//!   writes them (`Handler::gather`, a compensated prefix sum into a buffer, copied at once, here
//!   into a plain buffer instead of shared memory) and `finish`
//!   (the landing residual from the written joints): everything the service computes per request.
//!
//! Medians over the batches of the mean ns per move; the ratio columns divide medians of one run.
//! `OVERHEAD_BENCH_SCALE` (default 1.0) scales the work.

use nalgebra::Vector3;
use shared::{Command, JOINT_HEAD, RequestHeader, Vec3};
use solver_service::serve::{Handler, respond};
use solver_service::service::Solver;
use std::hint::black_box;
use std::time::{Duration, Instant};
use tractrix::{Chain, Method, MoveOptions, Real, Substeps};
use world::World;
use world::scene::parse_scene;

/// Moves per timed batch are chosen so that a batch is about this many link-steps.
const BATCH_WORK: usize = 200_000;

fn scene(n: usize, precision: &str) -> String {
    format!(
        "[[chain]]\nname = \"rope\"\nkind = \"free\"\nspace = \"spatial\"\nprecision = \"{precision}\"\n\
         links = {n}\nlink_length = 1.0\nbase = [0.0, 0.0, 0.0]\nshape = \"straight\"\n\
         axis = [1.0, 0.0, 0.0]\nmethod = \"tractrix\"\nsubsteps = 1\n"
    )
}

/// A circle of radius n/4 (at most 50) about the initial chain's axis, swaying along it by 10 links,
/// about a third of a link per move: bounded, so that an f32 chain stays within the service's
/// coordinate limit however long the run.
fn target(n: usize, k: usize) -> [f64; 3] {
    let r = (n as f64 / 4.0).min(50.0);
    let s = k as f64 / 3.0;
    let a = s / r.max(1.0);
    [
        n as f64 + 10.0 * (1.0 - (s / 30.0).cos()),
        r * (1.0 - a.cos()),
        r * a.sin(),
    ]
}

enum Way<T: Real> {
    Kernel(Chain<T, 3>, MoveOptions<T>),
    Handle(Box<Solver>, bool),
}

impl<T: Real> Way<T> {
    fn batch(
        &mut self,
        n: usize,
        k: &mut usize,
        moves: usize,
        (out, gathered): (&mut Vec<Vec3>, &mut Vec<Vec3>),
    ) -> f64 {
        let mut req = RequestHeader::new(Command::Move, 0);
        req.joint = JOINT_HEAD;
        let t0 = Instant::now();
        for _ in 0..moves {
            *k += 1;
            let p = target(n, *k);
            match self {
                Way::Kernel(c, o) => {
                    let to = Vector3::new(T::lit(p[0]), T::lit(p[1]), T::lit(p[2]));
                    black_box(c.move_joint(n, to, o).expect("a move"));
                }
                Way::Handle(s, payload) => {
                    let to = [Vec3::new(p[0], p[1], p[2])];
                    if *payload {
                        // As the serving loop does: answered, gathered, then copied at once (here
                        // into a plain buffer instead of the loaned shared memory).
                        let (header, changed) = respond(&mut **s, 0, &req, &to, gathered);
                        assert!(
                            changed,
                            "the service refused a move: {}",
                            header.reason_str()
                        );
                        out.resize(gathered.len(), Vec3::default());
                        out.copy_from_slice(gathered);
                        black_box((&header, &out));
                    } else {
                        let h = s.answer(0, &req, &to);
                        assert!(
                            h.changed,
                            "the service refused a move: {}",
                            h.header.reason_str()
                        );
                        black_box(&h.header);
                    }
                }
            }
        }
        t0.elapsed().as_nanos() as f64 / moves as f64
    }

    fn joints(&self) -> Vec<[f64; 3]> {
        match self {
            Way::Kernel(c, _) => c
                .positions()
                .iter()
                .map(|p| [p.x.to_f64(), p.y.to_f64(), p.z.to_f64()])
                .collect(),
            Way::Handle(s, _) => s
                .set()
                .elements_of(0, false)
                .map(|v| [v.x, v.y, v.z])
                .collect(),
        }
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn rows<T: Real>(precision: &str, scale: f64) {
    for n in [40usize, 1000] {
        let text = scene(n, precision);
        let sc = parse_scene(&text, "overhead.toml").expect("the bench's scene");
        let solver = || {
            Box::new(Solver::new(
                World::new(&sc).expect("a chain set"),
                None,
                Duration::from_secs(3600),
            ))
        };
        let chain = Chain::<T, 3>::straight(n, T::one(), Vector3::zeros(), Vector3::x())
            .expect("a straight chain");
        let opts = MoveOptions {
            method: Method::Tractrix,
            substeps: Substeps::Fixed(1),
            ..MoveOptions::default()
        };
        let mut ways: Vec<Way<T>> = vec![
            Way::Kernel(chain, opts),
            Way::Handle(solver(), false),
            Way::Handle(solver(), true),
        ];
        let moves = (BATCH_WORK / n).max(1);
        let batches = ((30.0 * scale) as usize).max(5);
        let mut ks = vec![0usize; ways.len()];
        let mut ns = vec![Vec::new(); ways.len()];
        let (mut out, mut gathered) = (Vec::new(), Vec::new());
        for b in 0..batches {
            for j in 0..ways.len() {
                let i = (j + b) % ways.len();
                ns[i].push(ways[i].batch(n, &mut ks[i], moves, (&mut out, &mut gathered)));
            }
        }
        // The same moves: the service's chain against the kernel's.
        let (kj, sj) = (ways[0].joints(), ways[1].joints());
        let diff = kj
            .iter()
            .zip(&sj)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        let med: Vec<f64> = ns.iter_mut().map(|v| median(v)).collect();
        println!(
            "| {n} | {precision} | {batches} | {:.2} | {:.2} | {:.2} | **{:.2}** | **{:.2}** | {diff:.1e} |",
            med[0] / 1e3,
            med[1] / 1e3,
            med[2] / 1e3,
            med[1] / med[0],
            med[2] / med[0],
        );
    }
}

fn main() {
    let scale: f64 = std::env::var("OVERHEAD_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|s: &f64| s.is_finite() && *s > 0.0)
        .unwrap_or(1.0);
    println!(
        "Head moves of about a third of a link along a swaying circle, one substep, closed-form tractrix, no collision \
         or holds; batches of ~{BATCH_WORK} link-steps timed whole and interleaved; medians of the \
         batches' mean µs per move. *handle*: what a response's `solve_ns` times; *+ payload*: also the \
         response's joints written and its residual computed, as the serving loop does (no IPC). \
         *max joint difference*: the service's chain against the kernel's after the run.\n"
    );
    println!(
        "| links | precision | batches | kernel `move_joint` (µs) | handle (µs) | handle + payload (µs) \
         | handle ÷ kernel | handle + payload ÷ kernel | max joint difference |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    rows::<f64>("f64", scale);
    rows::<f32>("f32", scale);
}
