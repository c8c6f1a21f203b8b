//! What eyelets cost per move and how exactly the rope keeps to them (issue 39).
//!
//! `cargo bench -p tractrix --bench eyelets` prints three Markdown tables (as BENCHMARKS.md shows
//! them).
//!
//! *Cost*: a rope of `n` unit links straight along x, its head moved a tenth of a link at a time round
//! a circle of radius 1 across the rope's line through where it started (so the rope slides back and
//! forth through its eyelets, and never folds onto itself): the plain move (`Chain::move_joint`, one substep) against the threaded move
//! (`tractrix::eyelet::move_threaded`) through 1 and 4 eyelets spread along the rope; and with capsule
//! collision (0.2 thick, nothing touching on this path: the detection's cost), the move with
//! collision (`move_joint_colliding`) against the threaded one (`move_threaded_colliding`). Moves are
//! timed one by one, the cases interleaved in rounds so the machine's noise falls on all alike;
//! median and 99th percentile per move, and the median's ratio to the plain move.
//!
//! *Held*: see [`held`].
//!
//! *Accuracy*: a rope of 40 unit links through two eyelets, its head and tail sent in turn to random
//! points within 3 units of where they started (so the rope slides both ways, a few links each time),
//! `EYELET_BENCH_MOVES` moves (default 10⁶). After every move the bench's own code measures each
//! eyelet's distance from its link's segment and, every 1000th move, every link's length from the
//! joints. `EYELET_BENCH_ROUNDS` (default 20) sets the cost table's rounds.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Instant;
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, move_joint_colliding,
};
use tractrix::eyelet::{Eyelet, EyeletWorkspace, move_threaded, move_threaded_colliding};
use tractrix::{Chain, MoveOptions, Substeps};

type V = Vector3<f64>;

/// Moves per case per round.
const MOVES: usize = 200;

fn rope(n: usize) -> Chain<f64, 3> {
    Chain::straight(n, 1.0, V::zeros(), V::x()).expect("a rope")
}

/// `k` eyelets spread evenly along a rope of `n` links, half-way along their links.
fn eyelets(r: &Chain<f64, 3>, n: usize, k: usize) -> Vec<Eyelet<f64, 3>> {
    (1..=k)
        .map(|i| {
            let at = V::new((i * n / (k + 1)) as f64 + 0.5, 0.0, 0.0);
            Eyelet::thread(r, at, 1e-9).expect("on the rope")
        })
        .collect()
}

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The distance from `p` to the segment `a`–`b` (the bench's own).
fn to_segment(a: V, b: V, p: V) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.dot(&ab)).clamp(0.0, 1.0);
    (a + ab * t - p).norm()
}

fn cost(rounds: usize) {
    println!(
        "| links | case | median ns/move | p99 ns/move | median ÷ plain move (of its kind) |\n|---:|---|---:|---:|---:|"
    );
    let opts = MoveOptions {
        substeps: Substeps::Fixed(1),
        ..MoveOptions::default()
    };
    let model = CollisionModel {
        options: CollisionOptions::default(),
        obstacles: vec![],
        holding: vec![],
    };
    for n in [40usize, 320] {
        // (eyelets, with capsule collision)
        let cases = [
            (0usize, false),
            (1, false),
            (4, false),
            (0, true),
            (4, true),
        ];
        let mut ropes: Vec<Chain<f64, 3>> = cases.iter().map(|_| rope(n)).collect();
        let mut eys: Vec<Vec<Eyelet<f64, 3>>> = cases
            .iter()
            .zip(&ropes)
            .map(|(&(k, _), r)| eyelets(r, n, k))
            .collect();
        let mut ws = EyeletWorkspace::new();
        let mut cws = CollisionWorkspace::new();
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
        let start = V::new(n as f64, 0.0, 0.0);
        let mut step = 0usize;
        for _ in 0..rounds {
            for (c, &(k, colliding)) in cases.iter().enumerate() {
                for s in 0..MOVES {
                    let a = 0.1 * (step + s) as f64;
                    let t = start + V::new(0.0, a.sin(), a.cos() - 1.0);
                    let clock = Instant::now();
                    match (k, colliding) {
                        (0, false) => {
                            black_box(ropes[c].move_joint(n, t, &opts)).expect("a free move");
                        }
                        (0, true) => {
                            black_box(move_joint_colliding(
                                &mut ropes[c],
                                n,
                                t,
                                &opts,
                                &model,
                                &mut cws,
                            ))
                            .expect("a move with collision");
                        }
                        (_, false) => {
                            black_box(move_threaded(
                                &mut ropes[c],
                                n,
                                t,
                                &mut eys[c],
                                1000,
                                &mut ws,
                            ))
                            .expect("a threaded move");
                        }
                        (_, true) => {
                            black_box(move_threaded_colliding(
                                &mut ropes[c],
                                n,
                                t,
                                &mut eys[c],
                                1000,
                                &model,
                                &mut cws,
                                &mut ws,
                            ))
                            .expect("a threaded move with collision");
                        }
                    }
                    times[c].push(clock.elapsed().as_nanos() as f64);
                }
            }
            step += MOVES;
        }
        let plain = percentile(&mut times[0].clone(), 0.5);
        let plain_colliding = percentile(&mut times[3].clone(), 0.5);
        for (c, &(k, colliding)) in cases.iter().enumerate() {
            let what = match (k, colliding) {
                (0, false) => "plain move (no eyelet)".to_string(),
                (0, true) => "plain move, capsule collision".to_string(),
                (1, false) => "through 1 eyelet".to_string(),
                (_, false) => format!("through {k} eyelets"),
                (_, true) => format!("through {k} eyelets, capsule collision"),
            };
            let base = if colliding { plain_colliding } else { plain };
            let med = percentile(&mut times[c], 0.5);
            let p99 = percentile(&mut times[c], 0.99);
            println!("| {n} | {what} | {med:.0} | {p99:.0} | {:.2} |", med / base);
        }
    }
}

/// *Held*: the same circle of moves on a rope whose tail is held (a grasp), after its head was first
/// taken in to three quarters of the rope's length and aside by a tenth (slack between the hold and
/// the head): the held move without eyelets (`Chain::move_joint`, the held side a fixed-base solve)
/// against the threaded move through 1 and 4 eyelets, whose held side alternates tractrix walks and
/// is finished by the reach hierarchy after `alternations` (the knob `EyeletWorkspace::with_holds`;
/// a scene's `hierarchy_after`). Besides the time: the alternations per substep, the moves refused,
/// and the largest distance of an eyelet from its link and of the held tail from where it was held,
/// measured by the bench's own code after every move.
fn held(rounds: usize) {
    println!(
        "\n| links | case | alternations before the hierarchy | median ns/move | p99 ns/move | median ÷ held move without eyelets | alternations per substep (mean) | refused | largest distance from an eyelet to its link (links) | largest move of the held tail |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let opts = MoveOptions {
        substeps: Substeps::Fixed(1),
        ..MoveOptions::default()
    };
    for n in [40usize, 320] {
        // (eyelets, alternations before the hierarchy)
        let cases = [(0usize, 0u32), (1, 4), (1, 16), (1, 64), (4, 16)];
        let centre = V::new(0.75 * n as f64, 0.1 * n as f64, 0.0);
        let mut ropes: Vec<Chain<f64, 3>> = Vec::new();
        let mut eys: Vec<Vec<Eyelet<f64, 3>>> = Vec::new();
        let mut wss: Vec<EyeletWorkspace<f64, 3>> = Vec::new();
        for &(k, alternations) in &cases {
            let mut r = rope(n);
            let mut e = eyelets(&r, n, k);
            let mut ws = EyeletWorkspace::new().with_holds(1e-9, alternations.max(1));
            move_threaded(&mut r, n, centre, &mut e, 100_000, &mut ws).expect("slack");
            r.hold(0).expect("a hold");
            ropes.push(r);
            eys.push(e);
            wss.push(ws);
        }
        let tails: Vec<V> = ropes.iter().map(|r| r.joint(0)).collect();
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
        let mut stats = vec![(0u64, 0u64, 0usize, 0.0f64, 0.0f64); cases.len()];
        let mut p = Vec::new();
        let mut step = 0usize;
        for _ in 0..rounds {
            for (c, &(k, _)) in cases.iter().enumerate() {
                for s in 0..MOVES {
                    let a = 0.1 * (step + s) as f64;
                    let t = centre + V::new(0.0, a.sin(), a.cos() - 1.0);
                    let clock = Instant::now();
                    let done = if k == 0 {
                        black_box(ropes[c].move_joint(n, t, &opts)).map(|o| (o.substeps, 0))
                    } else {
                        black_box(move_threaded(
                            &mut ropes[c],
                            n,
                            t,
                            &mut eys[c],
                            1000,
                            &mut wss[c],
                        ))
                        .map(|o| (o.substeps, o.held_iterations))
                        .map_err(|_| tractrix::ChainError::NonFinite)
                    };
                    times[c].push(clock.elapsed().as_nanos() as f64);
                    let st = &mut stats[c];
                    match done {
                        Ok((substeps, alternations)) => {
                            st.0 += u64::from(substeps);
                            st.1 += u64::from(alternations);
                        }
                        Err(_) => st.2 += 1,
                    }
                    p.resize(n + 1, V::zeros());
                    ropes[c].write_positions(&mut p);
                    for x in eys[c].iter().filter(|x| x.threaded) {
                        st.3 = st.3.max(to_segment(p[x.link], p[x.link + 1], x.at));
                    }
                    st.4 = st.4.max((p[0] - tails[c]).norm());
                }
            }
            step += MOVES;
        }
        let base = percentile(&mut times[0].clone(), 0.5);
        for (c, &(k, alternations)) in cases.iter().enumerate() {
            let what = match k {
                0 => "held move (no eyelet)".to_string(),
                1 => "through 1 eyelet".to_string(),
                _ => format!("through {k} eyelets"),
            };
            let alt = if k == 0 {
                "-".to_string()
            } else {
                alternations.to_string()
            };
            let med = percentile(&mut times[c], 0.5);
            let p99 = percentile(&mut times[c], 0.99);
            let (substeps, alts, refused, off, tail) = stats[c];
            let per = if k == 0 {
                "-".to_string()
            } else {
                format!("{:.1}", alts as f64 / substeps.max(1) as f64)
            };
            println!(
                "| {n} | {what} | {alt} | {med:.0} | {p99:.0} | {:.2} | {per} | {refused} | {off:.1e} | {tail:.1e} |",
                med / base
            );
        }
    }
}

/// SplitMix64.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn sym(&mut self, a: f64) -> f64 {
        a * (2.0 * self.unit() - 1.0)
    }
}

fn accuracy(moves: usize) {
    let mut rng = Rng(0xE7E_1E7);
    let mut r = rope(40);
    let mut e = vec![
        Eyelet::thread(&r, V::new(12.5, 0.0, 0.0), 1e-9).expect("on the rope"),
        Eyelet::thread(&r, V::new(27.5, 0.0, 0.0), 1e-9).expect("on the rope"),
    ];
    let homes = [V::zeros(), V::new(40.0, 0.0, 0.0)];
    let mut ws = EyeletWorkspace::new();
    let (mut refused, mut slid, mut worst_eyelet, mut worst_length) =
        (0usize, 0usize, 0.0f64, 0.0f64);
    let mut p = r.positions();
    let clock = Instant::now();
    for k in 0..moves {
        let (joint, home) = if k % 2 == 0 {
            (40, homes[1])
        } else {
            (0, homes[0])
        };
        let t = home + V::new(rng.sym(3.0), rng.sym(3.0), rng.sym(3.0));
        let links = [e[0].link, e[1].link];
        if move_threaded(&mut r, joint, t, &mut e, 1000, &mut ws).is_err() {
            refused += 1;
            continue;
        }
        slid += usize::from(links != [e[0].link, e[1].link]);
        r.write_positions(&mut p);
        for x in e.iter().filter(|x| x.threaded) {
            worst_eyelet = worst_eyelet.max(to_segment(p[x.link], p[x.link + 1], x.at));
        }
        if k % 1000 == 0 || k + 1 == moves {
            for w in p.windows(2) {
                worst_length = worst_length.max(((w[1] - w[0]).norm() - 1.0).abs());
            }
        }
    }
    let threaded = e.iter().filter(|x| x.threaded).count();
    println!(
        "\n| moves | refused (folding through an eyelet, or eyelets within a link) | moves that slid an eyelet to another link | eyelets still threaded at the end | largest distance from an eyelet to its link (links) | largest link-length error (links) | seconds |\n|---:|---:|---:|---:|---:|---:|---:|"
    );
    println!(
        "| {moves} | {refused} | {slid} | {threaded} of 2 | {worst_eyelet:.1e} | {worst_length:.1e} | {:.1} |",
        clock.elapsed().as_secs_f64()
    );
}

fn main() {
    let rounds = std::env::var("EYELET_BENCH_ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&r: &usize| r > 0)
        .unwrap_or(20);
    let moves = std::env::var("EYELET_BENCH_MOVES")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&m: &usize| m > 0)
        .unwrap_or(1_000_000);
    cost(rounds);
    held(rounds);
    accuracy(moves);
}
