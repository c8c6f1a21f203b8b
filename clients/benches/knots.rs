//! Knot success over rope resolution × holds × knot (issue 16): the evidence for choosing a rope.
//!
//! `cargo bench -p clients --bench knots` ties each knot on a rope 40 units long and 0.2 thick (capsule
//! collision) in 40, 80 and 160 links, with free ends or with the ends held (the tail anchored while the
//! head ties the overhand; for the two-handed knots each hand holds its end for the whole script, so
//! the rope between is a fixed-base chain from the other hand), over several runs whose throws are
//! perturbed (size ±3 %, direction ±0.05 per component, exit ±1 unit). A run succeeds when the rope's
//! knot, named by the kernel's identification, is the one the script ties. `KNOT_BENCH_RUNS` (default
//! 6) sets the runs per cell. The scripts are the built-in throws (`clients::script`), scaled to the
//! 40-unit rope; moves refused (locked by collision, or out of the held rope's reach) are counted and
//! skipped, as a hand would skip them.

use clients::script::{Handedness, Throw, Turn};
use nalgebra::Vector3;
use tractrix::chain::{Chain, MoveOptions};
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, move_joint_colliding,
};
use tractrix::knot::{KnotType, identify};

type V = Vector3<f64>;

const LENGTH: f64 = 40.0;
const THICKNESS: f64 = 0.2;

/// A small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Knot {
    Overhand,
    Square,
    Granny,
}

impl Knot {
    fn name(self) -> &'static str {
        match self {
            Knot::Overhand => "overhand",
            Knot::Square => "square",
            Knot::Granny => "granny",
        }
    }
    fn expected(self) -> KnotType {
        match self {
            Knot::Overhand => KnotType::Trefoil,
            Knot::Square => KnotType::Square,
            Knot::Granny => KnotType::Granny,
        }
    }
    /// The turns: (joint moved, throw). Joint 0 is the tail, `usize::MAX` the head.
    fn turns(self, rng: &mut Rng) -> Vec<(bool, Throw)> {
        let mut throw = |handedness, outward: [f64; 3], scale: f64, exit: f64| Throw {
            handedness,
            outward: [
                outward[0] + rng.range(-0.05, 0.05),
                outward[1] + rng.range(-0.05, 0.05),
                outward[2] + rng.range(-0.05, 0.05),
            ],
            scale: scale * rng.range(0.97, 1.03),
            exit: (exit + rng.range(-1.0, 1.0)).max(0.0),
        };
        match self {
            // (head?, throw): the built-in overhand; the two-handed throws scaled to 40 units.
            Knot::Overhand => vec![(true, throw(Handedness::Left, [1.0, 0.0, 0.0], 0.9, 12.0))],
            Knot::Square | Knot::Granny => {
                let second = if self == Knot::Square {
                    Handedness::Right
                } else {
                    Handedness::Left
                };
                vec![
                    (false, throw(Handedness::Left, [-1.0, 0.0, 0.0], 0.45, 8.0)),
                    (true, throw(second, [1.0, 0.0, 0.0], 0.45, 2.0)),
                ]
            }
        }
    }
}

/// What one run did.
struct Outcome {
    knot: KnotType,
    refused: usize,
    moves: usize,
}

fn tie(n: usize, held: bool, knot: Knot, rng: &mut Rng) -> Outcome {
    let mut chain =
        Chain::<f64, 3>::straight(n, LENGTH / n as f64, V::zeros(), V::x()).expect("rope");
    let model = CollisionModel {
        options: CollisionOptions {
            thickness: THICKNESS,
            ..CollisionOptions::default()
        },
        obstacles: vec![],
    };
    let mut ws = CollisionWorkspace::new();
    let opts = MoveOptions::default();
    if held {
        // Overhand: the tail anchored, the hand holds the head. Two hands: each holds its end.
        chain.hold(0).expect("tail");
        chain.hold(n).expect("head");
    }
    let (mut refused, mut moves) = (0, 0);
    for (head, throw) in knot.turns(rng) {
        let joint = if head { n } else { 0 };
        let start = chain.joint(joint);
        let turn = Turn {
            hand: "A".into(),
            chain: "rope".into(),
            joint: if head { "head" } else { "tail" }.into(),
            throw: Some(throw),
            waypoints: vec![],
        };
        for t in turn.targets([start.x, start.y, start.z], 0.05) {
            moves += 1;
            let t = V::new(t[0], t[1], t[2]);
            if move_joint_colliding(&mut chain, joint, t, &opts, &model, &mut ws).is_err() {
                refused += 1;
            }
        }
    }
    Outcome {
        knot: identify(&chain.positions()).kind,
        refused,
        moves,
    }
}

fn main() {
    let runs: usize = std::env::var("KNOT_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&r| r > 0)
        .unwrap_or(6);
    println!(
        "Knots tied on a rope {LENGTH} units long and {THICKNESS} thick (capsule collision), {runs} \
         perturbed runs per cell; a cell is the runs whose rope holds the knot the script ties, then \
         the share of moves refused (locked, or out of the held rope's reach):\n"
    );
    let knots = [Knot::Overhand, Knot::Square, Knot::Granny];
    print!("| links | link length | ends |");
    for k in knots {
        print!(" {} tied | {} moves refused |", k.name(), k.name());
    }
    println!("\n|---:|---:|---|{}", "---:|---:|".repeat(knots.len()));
    for n in [40usize, 80, 160] {
        for held in [false, true] {
            print!(
                "| {n} | {} | {} |",
                LENGTH / n as f64,
                if held { "held" } else { "free" }
            );
            for knot in knots {
                let mut rng = Rng(0x5EED ^ (n as u64) << 8 ^ knot as u64);
                let (mut ok, mut refused, mut moves) = (0, 0, 0);
                let mut found = Vec::new();
                for _ in 0..runs {
                    let o = tie(n, held, knot, &mut rng);
                    ok += usize::from(o.knot == knot.expected());
                    refused += o.refused;
                    moves += o.moves;
                    found.push(format!("{:?}", o.knot).to_lowercase());
                }
                eprintln!(
                    "{n} links, {}, {}: {}",
                    if held { "held" } else { "free" },
                    knot.name(),
                    found.join(" ")
                );
                print!(
                    " {ok}/{runs} | {:.1} % |",
                    100.0 * refused as f64 / moves.max(1) as f64
                );
            }
            println!();
        }
    }
}
