//! Smooth key-frame paths against straight segments (Korein & Badler: linear interpolation between key
//! frames gives infinite acceleration at every key frame): what the natural cubic spline through the
//! key frames ([`tractrix::path`], the service's `path` with `FLAG_SMOOTH`) changes in the rope's
//! motion, and whether the knot still ties.
//!
//! `cargo bench -p tractrix --bench smooth` ties the built-in overhand (the `hand run --builtin
//! overhand` head path) on a 40-unit rope of thickness 0.2 with capsule collision, in 40, 160 and
//! 320 links (at 40 the path ties nothing either way, as in "Collision handling"). Key frames: every fifth point of the script's head path (half a unit apart) and its last.
//! *straight*: the key frames joined by straight segments; *smooth*: the spline through them; both
//! sampled into the same number of points per segment (its chord over the script's step of 0.1), one
//! move of the head per sample (one tick). Acceleration is the second difference of a joint's
//! positions over three ticks, in units per tick², computed here from the joints after every move:
//! the largest over every joint and tick, its 99th percentile over ticks (of each tick's largest
//! joint), and the head's largest, over the ticks with no locked move among them. The knot is what
//! the rope holds at the end.

// The kernel's I/O rules (clippy.toml) are for its library: benches time and print, tests may print.
#![allow(
    clippy::disallowed_types,
    clippy::disallowed_macros,
    clippy::disallowed_methods
)]

use knots::identify;
use knots::script::Script;
use nalgebra::Vector3;
use tractrix::chain::{Chain, MoveOptions};
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Scheme, move_joint_colliding,
};

type V = Vector3<f64>;

/// Key frames: every this many points of the script's head path (0.1 apart).
const EVERY: usize = 5;

/// The path through `keys` joined by straight segments, each split into `k(chord)` equal steps.
fn straight(keys: &[V], step: f64) -> Vec<V> {
    let mut out = Vec::new();
    for w in keys.windows(2) {
        let k = ((w[1] - w[0]).norm() / step).ceil().max(1.0) as usize;
        for j in 1..=k {
            out.push(w[0] + (w[1] - w[0]) * (j as f64 / k as f64));
        }
    }
    out
}

struct Run {
    worst: f64,
    p99: f64,
    head: f64,
    locked: usize,
    knot: String,
}

fn run(links: usize, samples: &[V]) -> Run {
    let mut chain =
        Chain::<f64, 3>::straight(links, 40.0 / links as f64, V::zeros(), V::x()).expect("rope");
    let model = CollisionModel {
        options: CollisionOptions {
            scheme: Scheme::Capsules,
            thickness: 0.2,
            ..CollisionOptions::default()
        },
        obstacles: vec![],
        holding: Vec::new(),
    };
    let mut ws = CollisionWorkspace::new();
    let opts = MoveOptions::default();
    let mut history: Vec<Vec<V>> = vec![chain.positions()];
    // Ticks since the last locked move: a locked move leaves the rope where it was, and the next
    // one makes up two ticks at once, which is the collision's doing, not the path's.
    let mut clean = 3usize;
    let mut per_tick: Vec<f64> = Vec::new();
    let (mut worst, mut head, mut locked) = (0.0f64, 0.0f64, 0usize);
    for t in samples {
        if move_joint_colliding(&mut chain, links, *t, &opts, &model, &mut ws).is_err() {
            locked += 1;
            clean = 0;
        } else {
            clean += 1;
        }
        history.push(chain.positions());
        if history.len() > 3 {
            history.remove(0);
        }
        if history.len() == 3 && clean >= 3 {
            let (a, b, c) = (&history[0], &history[1], &history[2]);
            let mut tick = 0.0f64;
            for j in 0..a.len() {
                let acc = (c[j] - b[j] * 2.0 + a[j]).norm();
                tick = tick.max(acc);
                if j == links {
                    head = head.max(acc);
                }
            }
            worst = worst.max(tick);
            per_tick.push(tick);
        }
    }
    per_tick.sort_by(f64::total_cmp);
    let p99 = per_tick[((per_tick.len() - 1) as f64 * 0.99).round() as usize];
    Run {
        worst,
        p99,
        head,
        locked,
        knot: format!("{:?}", identify(&chain.positions()).kind).to_lowercase(),
    }
}

fn main() {
    let script = Script::builtin("overhand").expect("built-in overhand");
    let step = script.max_step;
    let dense: Vec<V> = script.turn[0]
        .targets([40.0, 0.0, 0.0], step)
        .into_iter()
        .map(V::from)
        .collect();
    let mut keys: Vec<V> = vec![V::new(40.0, 0.0, 0.0)];
    keys.extend(dense.iter().step_by(EVERY).skip(1).copied());
    if keys.last() != dense.last() {
        keys.push(*dense.last().expect("a path"));
    }
    let lines = straight(&keys, step);
    let mut smooth = Vec::new();
    tractrix::path::spline_samples(
        &keys,
        |_, chord| (chord / step).ceil().max(1.0) as usize,
        &mut smooth,
    );
    println!(
        "The built-in overhand's head path on a 40-unit rope of thickness 0.2 with capsule collision: \
         {} key frames (every {EVERY}th point of the script's path), {} samples either way, one move \
         of the head per sample (a tick). Acceleration: the second difference of a joint's positions \
         over three ticks (units per tick²), computed here from the joints after every move, over the \
         ticks with no locked move among them (a locked move leaves the rope, the next makes up two \
         ticks: the collision's doing, not the path's).\n",
        keys.len(),
        lines.len()
    );
    println!(
        "| links | between key frames | largest joint acceleration | p99 over ticks | head's largest | moves locked | knot at the end |"
    );
    println!("|---:|---|---:|---:|---:|---:|---|");
    for links in [40, 160, 320] {
        for (name, samples) in [
            ("straight segments", &lines),
            ("cubic spline (C²)", &smooth),
        ] {
            let r = run(links, samples);
            println!(
                "| {links} | {name} | {:.4} | {:.4} | {:.4} | {} | {} |",
                r.worst, r.p99, r.head, r.locked, r.knot
            );
        }
    }
}
