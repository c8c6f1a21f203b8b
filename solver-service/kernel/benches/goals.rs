//! Korein & Badler's goals beyond a point on the paper's 10-link planar arm (links of 0.2, base at the
//! origin): what an orientation goal and a goal in a region cost per solve beside the position-only
//! reach, on the same 500 targets, and whether each goal is met, checked by this bench's own geometry.
//!
//! `cargo bench -p tractrix --bench goals` prints one row per goal: solved, refused, mean iterations,
//! time per solve (median and p99, µs), the ratio of medians to the point goal, and the check (pose:
//! the largest angle between the last link and the asked direction and the largest head miss; regions:
//! heads outside their region) and the mean distance the head moved. The targets are poses of the arm
//! drawn at random (every joint in [-90°, 90°]): the point goal is their head, the pose goal their head
//! and last link, the box a square of side 0.2 and the ball a disk of radius 0.1 centred on their head.
//! Each goal's arm goes from target to target in sequence, keeping its own pose; goals alternate
//! target by target so they share the machine's noise.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

mod common;
use common::Rng;
use nalgebra::Vector2;
use std::time::Instant;
use tractrix::{Chain, Goal, ReachOptions, ReachWorkspace, reach_goal};

type V = Vector2<f64>;

const LINKS: usize = 10;
const LINK: f64 = 0.2;
const TARGETS: usize = 500;

/// Head and last link of random poses (base angle anywhere, every other joint in [-90°, 90°]).
fn poses() -> Vec<(V, V)> {
    let mut rng = Rng(0x60A1);
    (0..TARGETS)
        .map(|_| {
            let mut a = std::f64::consts::TAU * rng.unit();
            let (mut p, mut last) = (V::zeros(), V::zeros());
            for j in 0..LINKS {
                if j > 0 {
                    a += std::f64::consts::PI * (rng.unit() - 0.5);
                }
                last = V::new(a.cos(), a.sin()) * LINK;
                p += last;
            }
            (p, last)
        })
        .collect()
}

fn goal(kind: usize, head: V, last: V) -> Goal<f64, 2> {
    match kind {
        0 => Goal::Point(head),
        1 => Goal::Pose {
            at: head,
            direction: last,
        },
        2 => Goal::Box {
            lo: head - V::new(0.1, 0.1),
            hi: head + V::new(0.1, 0.1),
        },
        _ => Goal::Ball {
            centre: head,
            radius: 0.1,
        },
    }
}

/// Joint positions summed here from the links.
fn joints(c: &Chain<f64, 2>) -> Vec<V> {
    let mut p = vec![c.origin()];
    for l in c.links() {
        let q = p[p.len() - 1] + l;
        p.push(q);
    }
    p
}

#[derive(Default)]
struct Tally {
    solved: usize,
    iterations: u64,
    ns: Vec<f64>,
    /// Pose: the largest angle (radians) between the last link and the goal's direction, the largest
    /// head miss; regions: heads outside, and the head's travel summed.
    worst_angle: f64,
    worst_miss: f64,
    outside: usize,
    travel: f64,
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let targets = poses();
    let opts = ReachOptions::default();
    let names = [
        "point (the head at the target)",
        "pose (and the last link along a direction)",
        "box (the head in a square of side 0.2)",
        "ball (the head within 0.1)",
    ];
    let mut arms: Vec<Chain<f64, 2>> = (0..4)
        .map(|_| Chain::straight(LINKS, LINK, V::zeros(), V::x()).unwrap())
        .collect();
    let mut ws: Vec<ReachWorkspace<f64, 2>> = (0..4).map(|_| ReachWorkspace::default()).collect();
    let mut tally: Vec<Tally> = (0..4).map(|_| Tally::default()).collect();
    for (i, &(head, last)) in targets.iter().enumerate() {
        for k0 in 0..4 {
            // A different goal first on each target.
            let k = (k0 + i) % 4;
            let g = goal(k, head, last);
            let before = arms[k].head();
            let t0 = Instant::now();
            let r = reach_goal(&mut arms[k], &g, &opts, &mut ws[k]);
            let ns = t0.elapsed().as_nanos() as f64;
            let t = &mut tally[k];
            t.ns.push(ns);
            let Ok(o) = r else { continue };
            t.solved += 1;
            t.iterations += u64::from(o.iterations);
            let p = joints(&arms[k]);
            let (h, l) = (p[LINKS], p[LINKS] - p[LINKS - 1]);
            t.travel += (h - before).norm();
            match k {
                0 | 1 => {
                    t.worst_miss = t.worst_miss.max((h - head).norm());
                    if k == 1 {
                        let angle = (l.x * last.y - l.y * last.x).atan2(l.dot(&last)).abs();
                        t.worst_angle = t.worst_angle.max(angle);
                    }
                }
                2 => {
                    let d = h - head;
                    t.outside += usize::from(d.x.abs() > 0.1 || d.y.abs() > 0.1);
                }
                _ => {
                    t.outside += usize::from((h - head).norm() > 0.1);
                }
            }
        }
    }
    println!(
        "The paper's 10-link planar arm (links of 0.2) reaching {TARGETS} goals made from random poses \
         (every joint in [-90°, 90°]), each goal's arm in sequence from its last pose, translate-back, \
         tolerance 1e-9 of the arm's length. *check*: for the point and the pose, the largest head miss \
         (and the largest angle between the last link and the asked direction), computed here from the \
         joints; for the regions, heads outside their region. *head moved*: the mean distance from the \
         head before a solve to the head after it (a region is met with less motion than its centre).\n"
    );
    println!(
        "| goal | solved | refused | mean iterations | p50 µs | p99 µs | p50 ÷ point's | head moved (mean) | check |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---|");
    let point_p50 = pct(&mut tally[0].ns.clone(), 0.5);
    for (k, t) in tally.iter_mut().enumerate() {
        let (p50, p99) = (pct(&mut t.ns, 0.5), pct(&mut t.ns, 0.99));
        let moved = t.travel / t.solved.max(1) as f64;
        let check = match k {
            0 => format!("miss ≤ {:.1e}", t.worst_miss),
            1 => format!(
                "miss ≤ {:.1e}, angle ≤ {:.1e} rad",
                t.worst_miss, t.worst_angle
            ),
            _ => format!("{} outside", t.outside),
        };
        println!(
            "| {} | {} | {} | {:.1} | {:.2} | {:.2} | {:.2}× | {moved:.3} | {check} |",
            names[k],
            t.solved,
            TARGETS - t.solved,
            t.iterations as f64 / t.solved.max(1) as f64,
            p50 / 1e3,
            p99 / 1e3,
            p50 / point_p50
        );
    }
}
