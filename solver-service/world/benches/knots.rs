//! Knot success over rope resolution × holds × knot (issue 16): the evidence for choosing a rope.
//!
//! `cargo bench -p world --bench knots` ties each knot on a rope 40 units long and 0.2 thick (capsule
//! collision) in 40, 80 and 160 links, over several runs whose throws are perturbed (size ±3 %,
//! direction ±0.05 per component, exit ±1 unit). Three ways to start and hold the rope:
//!
//! * *free, straight*: the built-in scripts (`knots::script`) scaled to 40 units, nothing held: the
//!   overhand is thrown at the head, which walks on 12 units; the two-handed knots are one throw at
//!   each end.
//! * *free, U*: the rope hangs in a U (a circular arc between ends 12 apart, both ends pointing up),
//!   nothing held. Overhand: the head throws upward and walks on 6, then 4 sideways. Two hands: six
//!   alternating turns (A throws, B pulls out, A pulls out, B throws, A pulls, B pulls).
//! * *held, U*: the same start and scripts with both ends held, so each move of a hand's end is
//!   solved by the paper's fixed-base method from the other end (translate back; the reach hierarchy
//!   after 16 iterations), as the service does for grasps and anchors.
//! * *free, straight, wide loop*: the overhand as one wide loop and a tuck (the built-in
//!   `overhand-wide`, [`knots::script::WideLoop`]), nothing held; its radius, direction and pull
//!   perturbed as the throws are.
//! * *held, U, wide loop*: the same from the U with both ends held, heading up, the loop on the side
//!   away from the tail.
//! * *held (pull-back)*: the held rows again with the held side corrected by pulling its end back
//!   by a tractrix pass (`tractrix::fixed_base::Strategy::PullBack`) instead of translating the whole
//!   side back: the slack is given up near the hold.
//!
//! * *held, straight, fed loop*: the rope straight, both ends held; the overhand as the built-in
//!   `overhand-anchored` draws it (one wide loop whose circle is fed toward the held tail, since the
//!   held rope cannot slide after the hand, then a pull back); the two-handed knots as the built-in
//!   `overhands-held` ties them, an overhand in each end (B's fed circle of radius 2 and a tuck that finds the
//!   loop where it lies, then A's, mirrored for the square; then the pulls in turn), perturbed as
//!   `hand run --perturb` perturbs them.
//!
//! A run succeeds when the rope's knot, named by the identification, is the one the script ties.
//!
//! A second table measures why the resolution matters: how much of a loop the hand draws stays in
//! the rope behind it. The head of a free rope (40 units, nothing held, no collision) circles at radius
//! `R` until it has travelled more than the rope's length, in moves of 0.05; then the rope's distance
//! from the circle's centre is read joint by joint behind the head (computed here).
//! `KNOT_BENCH_RUNS` (default 6) sets the runs per cell, `KNOT_BENCH_LINKS` keeps one resolution and
//! `KNOT_BENCH_DEBUG` prints the knot after every turn. `KNOT_BENCH_TABLES=bend` prints instead the
//! knot table over resolution × bend radius (the rows' scripts on 40 to 320 links with R_min none, 1
//! and 2: `tractrix::limits`) and the loop-survival table with R_min; `KNOT_BENCH_TABLES=topology` the
//! topology table (tie and tighten, every state checked), `KNOT_BENCH_ONLY=surgeon's` keeping one
//! knot's row; there `KNOT_BENCH_DEBUG` names the knot after every tightening state of a tied run and
//! prints the states where it first changes (which joint was pulled, the joints before and after).
//! Refused moves are counted and skipped, as a hand would skip them.

use knots::script::{Handedness, Script, Throw, Tuck, Turn, WideLoop};
use knots::{KnotType, identify};
use nalgebra::Vector3;
use tractrix::chain::{Chain, MoveOptions};
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, move_joint_colliding,
};
use tractrix::fixed_base::Strategy;

type V = Vector3<f64>;

const LENGTH: f64 = 40.0;
const THICKNESS: f64 = 0.2;
/// Distance between the held ends at the start.
const CHORD: f64 = 12.0;

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
    /// The surgeon's knot: a double throw, then a single one the other way.
    Surgeons,
}

/// How the rope starts and what holds it.
#[derive(Clone, Copy, PartialEq)]
enum Ends {
    /// Straight along x, nothing held: the built-in scripts.
    Free,
    /// Hanging in a U between ends 12 apart, the U scripts, nothing held: the control for `Held`.
    UFree,
    /// The same U and scripts with both ends held (the tail anchored or held by hand A, the head by
    /// the moving hand B): the move of a hand's end is solved by the paper's fixed-base method.
    Held,
    /// Straight, nothing held, the overhand as one wide loop and a tuck (`overhand-wide`).
    Wide,
    /// The U with both ends held, the overhand as one wide loop and a tuck heading up, the loop on
    /// the side away from the tail.
    WideHeld,
    /// `Held` with the held side corrected by pulling its end back (`Strategy::PullBack`).
    HeldPull,
    /// `WideHeld` with the held side corrected by pulling its end back.
    WideHeldPull,
    /// Straight, both ends held, the knots as fed wide loops: the overhand of the built-in
    /// `overhand-anchored`/`overhand-held` (the head's loop fed toward the held tail, then a pull
    /// back); the two-handed knots of `overhands-held` (each hand's fed circle and a
    /// tuck that watches the rope, then the pulls in turn).
    HeldFed,
}

impl Ends {
    fn name(self) -> &'static str {
        match self {
            Ends::Free => "free, straight",
            Ends::UFree => "free, U",
            Ends::Held => "held, U",
            Ends::Wide => "free, straight, wide loop",
            Ends::WideHeld => "held, U, wide loop",
            Ends::HeldPull => "held (pull-back), U",
            Ends::WideHeldPull => "held (pull-back), U, wide loop",
            Ends::HeldFed => "held, straight, fed loop",
        }
    }
    /// Whether the rope starts in the U.
    fn u(self) -> bool {
        !matches!(self, Ends::Free | Ends::Wide | Ends::HeldFed)
    }
    /// Whether both ends are held.
    fn held(self) -> bool {
        matches!(
            self,
            Ends::Held | Ends::WideHeld | Ends::HeldPull | Ends::WideHeldPull | Ends::HeldFed
        )
    }
    /// Whether the held sides are corrected by the pull-back.
    fn pull(self) -> bool {
        matches!(self, Ends::HeldPull | Ends::WideHeldPull)
    }
    /// Whether the script is the wide loop.
    fn wide(self) -> bool {
        matches!(self, Ends::Wide | Ends::WideHeld | Ends::WideHeldPull)
    }
}

/// One hand's turn: which end it moves (the head, else the tail), and how.
struct Phase {
    head: bool,
    throw: Option<Throw>,
    wide_loop: Option<WideLoop>,
    tuck: Option<Tuck>,
    waypoints: Vec<[f64; 3]>,
}

impl Phase {
    /// The phase as a script's turn on the bench's rope (hand B at the head, A at the tail).
    fn turn(self) -> Turn {
        Turn {
            wide_loop: self.wide_loop,
            tuck: self.tuck,
            ..knots::script::turn(
                if self.head { "B" } else { "A" },
                "rope",
                if self.head { "head" } else { "tail" },
                self.throw,
                self.waypoints,
            )
        }
    }
}

impl Knot {
    fn name(self) -> &'static str {
        match self {
            Knot::Overhand => "overhand",
            Knot::Square => "square",
            Knot::Granny => "granny",
            Knot::Surgeons => "surgeon's",
        }
    }
    fn expected(self) -> KnotType {
        match self {
            Knot::Overhand => KnotType::Trefoil,
            Knot::Square => KnotType::Square,
            Knot::Granny => KnotType::Granny,
            Knot::Surgeons => KnotType::Surgeons,
        }
    }
    /// The wide-loop overhand (`overhand-wide`) heading `outward` with the loop on `side`, perturbed
    /// by `rng` as the throws are (size ±3 %, direction ±0.05 per component, exit ±1 unit).
    fn wide(outward: [f64; 3], side: [f64; 3], rng: &mut Rng) -> Vec<Phase> {
        let builtin = Script::builtin("overhand-wide").expect("a built-in");
        let l = builtin.turn[0].wide_loop.expect("a wide loop");
        vec![Phase {
            head: true,
            throw: None,
            wide_loop: Some(WideLoop {
                outward: outward.map(|c| c + rng.range(-0.05, 0.05)),
                side,
                radius: l.radius * rng.range(0.97, 1.03),
                exit: (l.exit + rng.range(-1.0, 1.0)).max(0.0),
                ..l
            }),
            tuck: None,
            waypoints: vec![],
        }]
    }

    /// The fed wide loops on the straight rope held at both ends (`Ends::HeldFed`), perturbed by
    /// `rng` as the throws are.
    /// `watch`: the overhand as one throw of `overhands-held` (the circle only, a tuck that watches the
    /// rope, a pull of 2) instead of the built-in's drawn tuck and pull.
    fn fed(self, radius: Option<f64>, watch: bool, rng: &mut Rng) -> Vec<Phase> {
        let builtin = Script::builtin("overhand-anchored").expect("a built-in");
        let mut l = builtin.turn[0].wide_loop.expect("a wide loop");
        l.radius = radius.unwrap_or(l.radius);
        let pull = builtin.turn[1].waypoints[0][0].abs();
        let mut fed = |head: bool, handedness| Phase {
            head,
            throw: None,
            wide_loop: Some(WideLoop {
                outward: [if head { 1.0 } else { -1.0 }, 0.0, 0.0]
                    .map(|c| c + rng.range(-0.05, 0.05)),
                radius: l.radius * rng.range(0.97, 1.03),
                exit: (l.exit + rng.range(-1.0, 1.0)).max(0.0),
                handedness,
                ..l
            }),
            tuck: None,
            waypoints: vec![],
        };
        let pull_back = |head: bool| Phase {
            head,
            throw: None,
            wide_loop: None,
            tuck: None,
            waypoints: vec![[if head { -pull } else { pull }, 0.0, 0.0]],
        };
        match self {
            Knot::Overhand if watch => {
                let mut circle = fed(true, l.handedness);
                if let Some(w) = &mut circle.wide_loop {
                    w.tuck = false;
                }
                let tuck = Phase {
                    head: true,
                    throw: None,
                    wide_loop: None,
                    tuck: Some(Tuck {
                        outward: [1.0, 0.0, 0.0].map(|c| c + rng.range(-0.05, 0.05)),
                        side: [0.0, 1.0, 0.0],
                        clearance: 1.0,
                        exit: (2.0 + rng.range(-1.0, 1.0)).max(0.0),
                        handedness: l.handedness,
                    }),
                    waypoints: vec![],
                };
                let pull = Phase {
                    waypoints: vec![[-2.0, 0.0, 0.0]],
                    ..pull_back(true)
                };
                vec![circle, tuck, pull]
            }
            Knot::Overhand => vec![fed(true, l.handedness), pull_back(true)],
            // The built-in `overhands-held` (the granny's with the second throw unmirrored): each
            // hand's fed circle and a tuck that finds the loop where it lies, then the pulls in
            // turn; perturbed as the hands' `--perturb` does.
            _ => {
                let second = if self == Knot::Granny {
                    Handedness::Right
                } else {
                    Handedness::Left
                };
                let mut script = knots::script::overhands_held("overhands-held", second);
                if self == Knot::Surgeons {
                    // B's throw doubled: its end tucked through its loop a second time.
                    let at = script
                        .turn
                        .iter()
                        .position(|t| t.hand == "B" && t.tuck.is_some())
                        .expect("B's tuck");
                    let again = script.turn[at].clone();
                    script.turn.insert(at + 1, again);
                }
                script.perturb(1 + (rng.unit() * 1e15) as u64);
                script
                    .turn
                    .into_iter()
                    .map(|t| Phase {
                        head: t.joint == "head",
                        throw: None,
                        wide_loop: t.wide_loop,
                        tuck: t.tuck,
                        waypoints: t.waypoints,
                    })
                    .collect()
            }
        }
    }

    /// The script's phases, perturbed by `rng`, for the straight rope or the U.
    fn phases(self, u: bool, rng: &mut Rng) -> Vec<Phase> {
        let mut throw = |handedness, outward: [f64; 3], scale: f64, exit: f64| Throw {
            lobe: false,
            handedness,
            outward: [
                outward[0] + rng.range(-0.05, 0.05),
                outward[1] + rng.range(-0.05, 0.05),
                outward[2] + rng.range(-0.05, 0.05),
            ],
            scale: scale * rng.range(0.97, 1.03),
            exit: (exit + rng.range(-1.0, 1.0)).max(0.0),
        };
        let throw_at = |head, t| Phase {
            head,
            throw: Some(t),
            wide_loop: None,
            tuck: None,
            waypoints: vec![],
        };
        let second = if self == Knot::Square {
            Handedness::Right
        } else {
            Handedness::Left
        };
        match (self, u) {
            // The built-in overhand: the head throws away from the tail and walks on 12 units, the
            // free rope sliding through the knot after it.
            (Knot::Overhand, false) => vec![throw_at(
                true,
                throw(Handedness::Left, [1.0, 0.0, 0.0], 0.9, 12.0),
            )],
            // The built-in two-handed script on free ends, scaled to 40 units: each hand throws
            // at its own end, one turn each.
            (_, false) => vec![
                throw_at(false, throw(Handedness::Left, [-1.0, 0.0, 0.0], 0.45, 8.0)),
                throw_at(true, throw(second, [1.0, 0.0, 0.0], 0.45, 2.0)),
            ],
            // The U scripts are the `hand` built-ins `overhand-u`, `square-u` and `granny-u`
            // (knots::script), their throws perturbed here.
            (_, true) => Script::builtin(&format!("{}-u", self.name()))
                .expect("a built-in U script")
                .turn
                .into_iter()
                .map(|t| Phase {
                    head: t.joint == "head",
                    throw: t
                        .throw
                        .map(|th| throw(th.handedness, th.outward, th.scale, th.exit)),
                    wide_loop: None,
                    tuck: None,
                    waypoints: t.waypoints,
                })
                .collect(),
        }
    }
}

/// What one run did.
struct Outcome {
    knot: KnotType,
    refused: usize,
    moves: usize,
    /// Fixed-base iterations summed over the accepted moves.
    iterations: u64,
    /// Time of each move (accepted or refused), ns.
    times: Vec<f64>,
}

/// The starting rope: straight along x, or a U: a circular arc hanging between the ends, CHORD apart,
/// both of which point up (+y).
fn start_rope(n: usize, arc: bool) -> Chain<f64, 3> {
    if !arc {
        return Chain::straight(n, LENGTH / n as f64, V::zeros(), V::x()).expect("rope");
    }
    // A circular arc of length LENGTH through both ends, CHORD apart: half angle `a` solves
    // `sin a / a = CHORD / LENGTH` (bisection; above π/2 the arc bulges below its ends).
    let chord = CHORD;
    let (mut lo, mut hi) = (1e-6, std::f64::consts::PI - 1e-9);
    for _ in 0..200 {
        let a = 0.5 * (lo + hi);
        if a.sin() / a > chord / LENGTH {
            lo = a;
        } else {
            hi = a;
        }
    }
    let a = 0.5 * (lo + hi);
    let r = LENGTH / (2.0 * a);
    // The arc runs from the tail at the origin to the head at
    // (CHORD, 0, 0) through its lowest point.
    let centre = V::new(chord / 2.0, r * a.cos(), 0.0);
    let points: Vec<V> = (0..=n)
        .map(|k| {
            let t = -a + 2.0 * a * k as f64 / n as f64 - std::f64::consts::FRAC_PI_2;
            centre + V::new(r * t.cos(), r * t.sin(), 0.0)
        })
        .collect();
    Chain::from_points(&points).expect("rope")
}

/// The rope's collision (capsules of the rope's thickness) and, with `r_min`, its bend radius.
fn rope_model(chain: &mut Chain<f64, 3>, r_min: Option<f64>) -> CollisionModel<f64, 3> {
    if let Some(r) = r_min {
        let lim = tractrix::JointLimits::bend_radius(chain.lengths(), r).expect("a bend radius");
        chain.set_limits(Some(lim)).expect("limits for the rope");
    }
    CollisionModel {
        options: CollisionOptions {
            thickness: THICKNESS,
            ..CollisionOptions::default()
        },
        obstacles: vec![],
        holding: Vec::new(),
    }
}

/// Ties `knot` on `n` links as `ends` says; `radius` replaces the fed loops' radius; `r_min` gives the
/// rope a minimum bend radius (cones of `2 atan(L / 2 r_min)` at its joints, `tractrix::limits`).
#[allow(clippy::too_many_arguments)]
fn tie(
    n: usize,
    ends: Ends,
    knot: Knot,
    radius: Option<f64>,
    watch: bool,
    r_min: Option<f64>,
    rng: &mut Rng,
) -> Outcome {
    let u = ends.u();
    let mut chain = start_rope(n, u);
    let model = rope_model(&mut chain, r_min);
    let mut ws = CollisionWorkspace::new();
    let mut opts = MoveOptions::default();
    if ends.pull() {
        opts.held.strategy = Strategy::PullBack;
    }
    if ends.held() {
        chain.hold(0).expect("tail");
        chain.hold(n).expect("head");
    }
    let (mut refused, mut moves) = (0, 0);
    let (mut iters, mut max_iters) = (0u64, 0u32);
    let mut times = Vec::new();
    let phases = match ends {
        Ends::Wide => Knot::wide([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], rng),
        Ends::WideHeld | Ends::WideHeldPull => Knot::wide([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], rng),
        Ends::HeldFed => knot.fed(radius, watch, rng),
        _ => knot.phases(u, rng),
    };
    for phase in phases {
        let head = phase.head;
        let joint = if head { n } else { 0 };
        let turn = phase.turn();
        let rope: Vec<[f64; 3]> = chain.positions().iter().map(|p| [p.x, p.y, p.z]).collect();
        for t in turn.targets_on(&rope, joint, 0.05).unwrap_or_default() {
            moves += 1;
            let t = V::new(t[0], t[1], t[2]);
            let clock = std::time::Instant::now();
            let moved = move_joint_colliding(&mut chain, joint, t, &opts, &model, &mut ws);
            times.push(clock.elapsed().as_nanos() as f64);
            match moved {
                Ok(o) => {
                    iters += o.held_iterations as u64;
                    max_iters = max_iters.max(o.held_iterations);
                }
                Err(_) => refused += 1,
            }
        }
        if std::env::var_os("KNOT_BENCH_DEBUG").is_some() {
            let r = identify(&chain.positions());
            eprintln!(
                "  after {} phase: {} ({}/{}), head {:?}, tail {:?}, refused {refused}/{moves}, held iterations {iters} (max {max_iters})",
                if head { "head" } else { "tail" },
                r.kind.name(),
                r.agreeing,
                r.closures,
                chain.joint(n),
                chain.joint(0)
            );
        }
    }
    Outcome {
        knot: identify(&chain.positions()).kind,
        refused,
        moves,
        iterations: iters,
        times,
    }
}

/// The loop-survival table: for each link length and loop radius, how much rope behind the circling
/// head keeps at least half the loop's radius; with `bend`, also with bend radii of 1 and 1.5.
fn loop_survival(bend: bool) {
    println!(
        "\nHow much of a drawn loop stays in the rope: the head of a free 40-unit rope circles at \
         radius *R* (moves of 0.05, tractrix, one substep) until it has travelled more than the \
         rope's length; then the rope is read behind the head, joint by joint. *rope until R/2*: the \
         rope behind the head before the first joint nearer the circle's centre than R/2 (\"whole \
         rope\" when none is); *in loops*: that length ÷ 2πR; *model*: 3R²/(4L), where a steady \
         tractrix puts it (each link's tail circles at r² − L² when its head circles at r).\n"
    );
    let r_mins: &[Option<f64>] = if bend {
        println!(
            "With a bend radius *R_min* (cones of 2·atan(L / 2R_min) at every joint, \
             `tractrix::limits`) the rope cannot curl tighter than R_min behind the head.\n"
        );
        println!(
            "| link length L | links | R | R_min | rope until R/2 | in loops | model 3R²/(4L) (no R_min) |"
        );
        println!("|---:|---:|---:|---:|---:|---:|---:|");
        &[None, Some(1.0), Some(1.5)]
    } else {
        println!("| link length L | links | R | rope until R/2 | in loops | model 3R²/(4L) |");
        println!("|---:|---:|---:|---:|---:|---:|");
        &[None]
    };
    for (n, &r_min) in [40usize, 80, 160]
        .into_iter()
        .flat_map(|n| r_mins.iter().map(move |r| (n, r)))
    {
        let l = LENGTH / n as f64;
        for r in [1.0f64, 2.0, 3.0, 4.0] {
            // The rope trails straight behind the head, which starts on the circle heading +y.
            let head = V::new(r, 0.0, 0.0);
            let mut chain =
                Chain::straight(n, l, head - V::new(0.0, LENGTH, 0.0), V::y()).expect("rope");
            if let Some(rm) = r_min {
                let lim = tractrix::JointLimits::bend_radius(chain.lengths(), rm).expect("limits");
                chain.set_limits(Some(lim)).expect("limits");
            }
            let opts = MoveOptions::default();
            let loop_len = std::f64::consts::TAU * r;
            let turns = ((LENGTH + loop_len) / loop_len).ceil();
            let steps = (turns * loop_len / 0.05).ceil() as usize;
            for k in 1..=steps {
                let a = turns * std::f64::consts::TAU * k as f64 / steps as f64;
                let t = V::new(r * a.cos(), r * a.sin(), 0.0);
                chain.move_joint(n, t, &opts).expect("a free move");
            }
            let p = chain.positions();
            let until = (0..=n)
                .find(|&k| (p[n - k].x.powi(2) + p[n - k].y.powi(2)).sqrt() < 0.5 * r)
                .map(|k| k as f64 * l);
            let (until, loops) = match until {
                Some(u) => (format!("{u:.2}"), format!("{:.2}", u / loop_len)),
                None => ("whole rope".into(), format!("> {:.2}", LENGTH / loop_len)),
            };
            let model = 0.75 * r * r / l;
            if bend {
                let rm = r_min.map_or("–".to_string(), |v| v.to_string());
                println!("| {l} | {n} | {r} | {rm} | {until} | {loops} | {model:.2} |");
            } else {
                println!("| {l} | {n} | {r} | {until} | {loops} | {model:.2} |");
            }
        }
    }
}

/// The held overhand over its loop's radius and the rope's resolution: the fed loop of
/// `overhand-anchored` with other radii, tied on the straight rope held at both ends; and the rope its
/// circle takes.
fn fed_radius(runs: usize, only: Option<usize>) {
    let builtin = Script::builtin("overhand-anchored").expect("a built-in");
    let own = builtin.turn[0].wide_loop.expect("a wide loop").radius;
    let pull = builtin.turn[1].waypoints[0][0].abs();
    let radii = [1.5, 2.0, 2.5, 3.0, 3.5, 4.0];
    println!(
        "\nThe held overhand over its loop's radius and the rope's resolution: the fed loop of \
         *held, straight, fed loop* (feed as the built-in's) with its radius *R* set (the \
         built-in's is {own}), {runs} perturbed runs per cell, the end threaded two ways: *drawn*, \
         the built-in's tuck drawn where the circle was drawn, and a pull of {pull}; \
         *watching*, a tuck that finds the loop in the rope where it lies (`Tuck`; one throw of \
         `overhands-held`), and a pull of 2. *circle 2πR*: the rope one loop takes, which a second \
         throw (the two-handed knots) needs again.\n"
    );
    let sizes: Vec<usize> = [40usize, 80, 160]
        .into_iter()
        .filter(|&n| only.is_none_or(|o| o == n))
        .collect();
    print!("| R | circle 2πR |");
    for n in &sizes {
        print!(" {n} links tied, drawn | {n} links tied, watching |");
    }
    println!("\n|---:|---:|{}", "---:|---:|".repeat(sizes.len()));
    for r in radii {
        print!("| {r} | {:.1} |", std::f64::consts::TAU * r);
        for &n in &sizes {
            for watch in [false, true] {
                let mut rng = Rng(0xFED ^ (n as u64) << 8 ^ r.to_bits());
                let ok = (0..runs)
                    .filter(|_| {
                        tie(
                            n,
                            Ends::HeldFed,
                            Knot::Overhand,
                            Some(r),
                            watch,
                            None,
                            &mut rng,
                        )
                        .knot
                            == KnotType::Trefoil
                    })
                    .count();
                print!(" {ok}/{runs} |");
            }
        }
        println!();
    }
}

/// A point of the trefoil `(sin t + 2 sin 2t, cos t − 2 cos 2t, −sin 3t)` scaled by `s`.
fn trefoil_at(t: f64, s: f64) -> V {
    V::new(
        t.sin() + 2.0 * (2.0 * t).sin(),
        t.cos() - 2.0 * (2.0 * t).cos(),
        -(3.0 * t).sin(),
    ) * s
}

/// Sizes ±10 %, waypoints moved by up to 0.1 units, a tremor of up to 0.02 units on every step: the
/// perturbation issue 34 asks of a person's hand.
const PATH_SIZE: f64 = 0.10;
const PATH_SHIFT: f64 = 0.1;
const PATH_TREMOR: f64 = 0.02;

/// The overhand drawn by the head of a free rope along a smooth path: the trefoil knot (scale 1.2,
/// its tightest bend about 1.5 units) cut open at a lobe, the rope starting straight behind the cut
/// along the path's tangent, then 3 units out along the far end's tangent, in steps of about 0.01.
/// Perturbed as a hand would be ([`PATH_SIZE`], [`PATH_SHIFT`] as a smooth offset of the whole path,
/// [`PATH_TREMOR`] on every step).
/// The smooth paths a free rope's head draws.
#[derive(Clone, Copy, PartialEq)]
enum PathShape {
    /// The trefoil `(sin t + 2 sin 2t, …)` at scale 1.2, entered at a lobe (about 33 units; its
    /// tightest bend about 1.55).
    Lobe,
    /// The (2,3) torus knot: twice round a circle of radius 2.8 while winding three times round it at
    /// radius 1.2 (about 42 units; its tightest bend about 2.1), entered at its outermost point.
    Torus,
}

impl PathShape {
    fn name(self) -> &'static str {
        match self {
            PathShape::Lobe => "overhand, free, trefoil path",
            PathShape::Torus => "overhand, free, torus path",
        }
    }
}

fn tie_path(n: usize, r_min: Option<f64>, shape: PathShape, rng: &mut Rng) -> Outcome {
    let pi = std::f64::consts::PI;
    let size = 1.0 + rng.range(-PATH_SIZE, PATH_SIZE);
    // A smooth offset of the path (two harmonics per axis with random phases), at most PATH_SHIFT.
    let phases: Vec<(f64, f64)> = (0..6)
        .map(|_| (rng.range(0.0, 2.0 * pi), rng.range(-1.0, 1.0)))
        .collect();
    let offset = |t: f64| {
        let c = |k: usize| {
            let (p1, a1) = phases[2 * k];
            let (p2, a2) = phases[2 * k + 1];
            0.5 * PATH_SHIFT * (a1 * (t + p1).sin() + a2 * (2.0 * t + p2).sin())
        };
        V::new(c(0), c(1), c(2))
    };
    let (t0, t1, exit) = match shape {
        PathShape::Lobe => (pi + 0.2, 3.0 * pi - 0.2, 3.0),
        PathShape::Torus => (0.15, 2.0 * pi - 0.15, 2.0),
    };
    let at = |t: f64| {
        offset(t)
            + match shape {
                PathShape::Lobe => trefoil_at(t, 1.2 * size),
                PathShape::Torus => {
                    let (major, minor) = (2.8 * size, 1.2 * size);
                    let ring = major + minor * (3.0 * t).cos();
                    V::new(
                        ring * (2.0 * t).cos(),
                        ring * (2.0 * t).sin(),
                        minor * (3.0 * t).sin(),
                    )
                }
            }
    };
    let tangent = |t: f64| (at(t + 1e-6) - at(t - 1e-6)).normalize();
    let mut path: Vec<V> = (1..=4000)
        .map(|i| at(t0 + (t1 - t0) * i as f64 / 4000.0))
        .collect();
    let (end, out) = (at(t1), tangent(t1));
    path.extend((1..=150).map(|i| end + out * (exit * i as f64 / 150.0)));
    let mut chain = Chain::straight(
        n,
        LENGTH / n as f64,
        at(t0) - tangent(t0) * LENGTH,
        tangent(t0),
    )
    .expect("rope");
    let model = rope_model(&mut chain, r_min);
    let mut ws = CollisionWorkspace::new();
    let opts = MoveOptions::default();
    let (mut refused, mut times) = (0, Vec::with_capacity(path.len()));
    for p in &path {
        let tremor = V::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ) * (PATH_TREMOR / 3f64.sqrt());
        let clock = std::time::Instant::now();
        let moved = move_joint_colliding(&mut chain, n, p + tremor, &opts, &model, &mut ws);
        times.push(clock.elapsed().as_nanos() as f64);
        refused += usize::from(moved.is_err());
    }
    Outcome {
        knot: identify(&chain.positions()).kind,
        refused,
        moves: path.len(),
        iterations: 0,
        times,
    }
}

/// The knot table over the rope's resolution and its bend radius: the overhand drawn along a smooth
/// path ([`tie_path`]) on 40, 80, 160 and 320 links of the same 40-unit rope, without a bend radius and
/// with R_min from 1 to 2.5 units; then the kernel-level scripts that tie on the paper's unit links (the
/// free wide loop; the held fed loops of the overhand, square and granny) on 40, 80 and 160 links with
/// R_min none, 1 and 2: tied, refused, and the time per move.
fn bend_radius_table(runs: usize, only: Option<usize>) {
    println!(
        "\nKnots over the rope's resolution and its bend radius *R_min* (the same 40-unit rope, 0.2 \
         thick, capsule collision; the scripts of the rows above, perturbed as they are; {runs} runs \
         per cell). *tied*: runs whose rope the identification names as the script's knot; *refused*: \
         share of moves refused; *ms/move*: time per move (accepted or refused), median and p99 over \
         every move of the cell's runs.\n"
    );
    let path_runs: usize = std::env::var("KNOT_BENCH_PATH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&r| r > 0)
        .unwrap_or(16);
    println!(
        "*smooth paths*: the head of the free rope draws an overhand along a path with no corner, \
         made for no resolution in particular: the *trefoil path*, the trefoil knot cut open at a lobe \
         (scale 1.2: about 33 units, its tightest bend about 1.55 units; the built-in \
         `overhand-bend`), or the *torus path*, the (2,3) torus knot cut open at its outermost point \
         (twice round a circle of radius 2.8 winding three times round it at radius 1.2: about 42 \
         units, its tightest bend about 2.1); then 3 (2) units on. Perturbed as issue 34 asks of a \
         hand: sizes ±{:.0} %, the path shifted smoothly by up to {PATH_SHIFT} units, a tremor of up to \
         {PATH_TREMOR} units on every step; {path_runs} runs per cell. The other rows are the unit-link \
         scripts of the table above with their own, gentler perturbation, {runs} runs per cell.\n",
        100.0 * PATH_SIZE
    );
    println!("| script | R_min | links | tied | refused | ms/move p50 | ms/move p99 |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let cells = [PathShape::Lobe, PathShape::Torus]
        .into_iter()
        .flat_map(|shape| {
            let r_mins: &[Option<f64>] = match shape {
                PathShape::Lobe => &[None, Some(1.0), Some(1.5), Some(2.0), Some(2.5)],
                PathShape::Torus => &[None, Some(2.0), Some(2.3), Some(2.5)],
            };
            r_mins.iter().map(move |&r| (shape, r))
        });
    for (shape, r_min) in cells {
        for n in [40usize, 80, 160, 320] {
            if only.is_some_and(|o| o != n) {
                continue;
            }
            let runs = path_runs;
            let mut rng = Rng(0x7AE5 ^ (n as u64) << 8);
            let (mut ok, mut refused, mut moves) = (0, 0, 0);
            let mut times = Vec::new();
            let mut found = Vec::new();
            for _ in 0..runs {
                let o = tie_path(n, r_min, shape, &mut rng);
                ok += usize::from(o.knot == KnotType::Trefoil);
                refused += o.refused;
                moves += o.moves;
                times.extend(o.times);
                found.push(o.knot.name());
            }
            eprintln!(
                "{}, R_min {r_min:?}, {n} links: {}",
                shape.name(),
                found.join(" ")
            );
            times.sort_by(|a, b| a.total_cmp(b));
            let at = |p: f64| times[((times.len() - 1) as f64 * p).round() as usize] / 1e6;
            println!(
                "| {} | {} | {n} | {ok}/{runs} | {:.1} % | {:.3} | {:.3} |",
                shape.name(),
                r_min.map_or("–".to_string(), |v: f64| v.to_string()),
                100.0 * refused as f64 / moves.max(1) as f64,
                at(0.5),
                at(0.99)
            );
        }
    }
    if std::env::var("KNOT_BENCH_TABLES").is_ok_and(|t| t == "paths") {
        return;
    }
    let rows = [
        ("overhand, free, wide loop", Ends::Wide, Knot::Overhand),
        ("overhand, held, fed loop", Ends::HeldFed, Knot::Overhand),
        ("square, held, fed loops", Ends::HeldFed, Knot::Square),
        ("granny, held, fed loops", Ends::HeldFed, Knot::Granny),
    ];
    for (name, ends, knot) in rows {
        for r_min in [None, Some(1.0), Some(2.0)] {
            for n in [40usize, 80, 160] {
                if only.is_some_and(|o| o != n) {
                    continue;
                }
                let mut rng = Rng(0xBE7D ^ (n as u64) << 8 ^ knot as u64);
                let (mut ok, mut refused, mut moves) = (0, 0, 0);
                let mut times = Vec::new();
                let mut found = Vec::new();
                for _ in 0..runs {
                    let o = tie(n, ends, knot, None, false, r_min, &mut rng);
                    ok += usize::from(o.knot == knot.expected());
                    refused += o.refused;
                    moves += o.moves;
                    times.extend(o.times);
                    found.push(o.knot.name());
                }
                eprintln!("{name}, R_min {r_min:?}, {n} links: {}", found.join(" "));
                times.sort_by(|a, b| a.total_cmp(b));
                let at = |p: f64| times[((times.len() - 1) as f64 * p).round() as usize] / 1e6;
                println!(
                    "| {name} | {} | {n} | {ok}/{runs} | {:.1} % | {:.3} | {:.3} |",
                    r_min.map_or("–".to_string(), |v: f64| v.to_string()),
                    100.0 * refused as f64 / moves.max(1) as f64,
                    at(0.5),
                    at(0.99)
                );
            }
        }
    }
}

/// The rope of the topology table: the knots bench's rope (40 units, 0.2 thick, capsule collision)
/// straight along x, as a scene; the work budget of the shipped `knots.toml`.
const TOPOLOGY_SCENE: &str = r#"
budget = 2000000

[[chain]]
name = "rope"
links = 40
link_length = 1.0
base = [0.0, 0.0, 0.0]
axis = [1.0, 0.0, 0.0]
thickness = 0.2
collision = "capsules"
"#;

/// What one tie-and-tighten run of the topology table saw.
#[derive(Default)]
struct Checked {
    tied: bool,
    /// The knot after the tightening is the one tied.
    kept: bool,
    states: u64,
    crossings: u64,
    taut: usize,
    jammed: usize,
    /// Pulls whose last request stopped short at the request's work budget.
    out_of_work: usize,
    /// Pulls that ended otherwise: refused, no direction, a joint limit, or the step limit.
    other: usize,
    /// The knotted stretch at the end, in rope diameters.
    stretch: Option<f64>,
}

/// The joints of the world's rope.
fn world_joints(w: &world::World) -> Vec<V> {
    let n = w.specs()[0].lengths.len() + 1;
    w.elements_with(0, false, false, false, (false, false))
        .take(n)
        .collect()
}

/// A move of the world's rope.
fn world_move<'a>(
    w: &world::World,
    joint: usize,
    target: &'a [V],
    pull: bool,
) -> world::command::Command<'a> {
    world::command::Command::Move {
        chain: 0,
        joint,
        targets: target,
        options: w.specs()[0].moves,
        take_over: false,
        smooth: false,
        pull,
        needle: world::command::NeedleMove::Carried,
    }
}

/// Ties `knot` by the fed loops on the rope held at both ends (`Ends::HeldFed`, perturbed by `rng`),
/// then tightens it as `hand run --tighten 0.05` does (each end in turn, head first, pulled away from
/// the knot with the pull flag, 0.05 per request, until it has moved less than a tenth of that for 8
/// requests, those answered out of work not counted up to `knots::script::PULL_WAITS` in a row;
/// twice round), all through a [`world::World`] in this process. Every accepted state is
/// checked against the one before by the swept-volume check (`knots::check::crossings_between`).
fn tie_and_tighten(scene: &world::scene::Scene, knot: Knot, rng: &mut Rng) -> Checked {
    use world::command::Command;
    let mut w = world::World::new(scene).expect("the topology scene's world");
    let n = w.specs()[0].lengths.len();
    for joint in [0, n] {
        w.apply(&Command::Grasp {
            chain: 0,
            joint,
            take_over: false,
        })
        .expect("grasp an end");
    }
    let mut out = Checked::default();
    let mut prev = world_joints(&w);
    let check = |now: Vec<V>, prev: &mut Vec<V>, out: &mut Checked| {
        out.states += 1;
        let shortest = now
            .windows(2)
            .map(|p| (p[1] - p[0]).norm())
            .fold(f64::INFINITY, f64::min);
        out.crossings +=
            knots::check::crossings_between(prev, &now, 2, 1e-9 * shortest).len() as u64;
        *prev = now;
    };
    let array = |p: &[V]| -> Vec<[f64; 3]> { p.iter().map(|q| [q.x, q.y, q.z]).collect() };
    for phase in knot.fed(None, false, rng) {
        let joint = if phase.head { n } else { 0 };
        let turn = phase.turn();
        for t in turn
            .targets_on(&array(&prev), joint, 0.05)
            .unwrap_or_default()
        {
            let t = [V::new(t[0], t[1], t[2])];
            if w.apply(&world_move(&w, joint, &t, false)).is_ok() {
                check(world_joints(&w), &mut prev, &mut out);
            }
        }
    }
    out.tied = identify(&prev).kind == knot.expected();
    let tied_at = knots::knotted_stretch(&prev, knot.expected());
    let debug = std::env::var("KNOT_BENCH_DEBUG").is_ok();
    let mut changed = false;
    for _round in 0..2 {
        for idx in [n, 0] {
            let mut still = 0;
            let mut waiting = 0;
            let mut ended = false;
            for _ in 0..2000 {
                let at = prev[idx];
                let Some(away) = knots::contact::away_from_knot(&array(&prev), idx, THICKNESS)
                else {
                    break;
                };
                let t = [at + V::from(away) * 0.05];
                let Ok(answer) = w.apply(&world_move(&w, idx, &t, true)) else {
                    break;
                };
                let stopped = answer.stopped;
                let before = (debug && out.tied && !changed).then(|| prev.clone());
                check(world_joints(&w), &mut prev, &mut out);
                if let Some(before) = before {
                    let now = identify(&prev).kind;
                    if now != knot.expected() {
                        changed = true;
                        eprintln!(
                            "{}: became {} pulling joint {idx} by {:.4} (away {away:?}); knotted stretch before {:?}; joints before {:?}; after {:?}",
                            knot.name(),
                            now.name(),
                            (prev[idx] - at).norm(),
                            knots::knotted_stretch(&before, knot.expected()),
                            before.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
                            prev.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
                        );
                    }
                }
                // As the hand waits through pulls answered out of work (their resolution kept).
                let moved = (prev[idx] - at).norm();
                let waits = moved < 0.005 && stopped == Some(world::tension::Stop::Work);
                waiting = if waits { waiting + 1 } else { 0 };
                still = if moved >= 0.005 {
                    0
                } else if waits && waiting <= knots::script::PULL_WAITS {
                    still
                } else {
                    still + 1
                };
                if still >= 8 {
                    // Held joints (index, anchor, taut toward the head), then their pulls.
                    let all: Vec<V> = w
                        .elements_with(0, false, true, false, (true, false))
                        .collect();
                    let held = (all.len() - (n + 1)) / 2;
                    let k = (0..held).find(|&k| all[n + 1 + k].x as usize == idx);
                    let taut = k
                        .is_some_and(|k| all[n + 1 + k].z != 0.0 || (k > 0 && all[n + k].z != 0.0));
                    // As the hand says it (`clients::hand::Tightened::why`): the taut flag, else
                    // why the last pull stopped short.
                    use world::tension::Stop;
                    match (taut, stopped) {
                        (true, _) | (false, Some(Stop::Reach)) => out.taut += 1,
                        (false, Some(Stop::Contact)) => out.jammed += 1,
                        (false, Some(Stop::Work)) => out.out_of_work += 1,
                        (false, Some(Stop::Limit) | None) => out.other += 1,
                    }
                    ended = true;
                    break;
                }
            }
            if !ended {
                out.other += 1;
            }
        }
    }
    let report = identify(&prev);
    let end = report.kind;
    out.kept = out.tied && end == knot.expected();
    if debug && out.tied && !out.kept {
        eprintln!(
            "{}: tied (knotted stretch {tied_at:?}), then {} after the tightening ({} of 6 closures agree; {} crossings; knotted stretch {:?}); joints: {:?}",
            knot.name(),
            end.name(),
            report.agreeing,
            report.crossings,
            knots::knotted_stretch(&prev, end),
            prev.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>()
        );
    }
    if out.kept
        && let Some((a, b)) = knots::knotted_stretch(&prev, end)
    {
        let length: f64 = prev[a..=b].windows(2).map(|p| (p[1] - p[0]).norm()).sum();
        out.stretch = Some(length / THICKNESS);
    }
    out
}

/// The topology table (issue 38): `runs` perturbed tie-and-tighten runs per knot ([`tie_and_tighten`]),
/// counting the crossings the swept-volume check finds between consecutive states and the runs whose
/// knot after the tightening is not the one tied.
fn topology_table(runs: usize) {
    let scene = world::scene::parse_scene(TOPOLOGY_SCENE, "topology.toml").expect("the scene");
    println!(
        "Tie and tighten, {runs} perturbed runs per knot, through the world in this process (the \
         service's answer path without the IPC): the rope {LENGTH} units in 40 links, {THICKNESS} \
         thick, capsule collision, both ends held; the knot tied by the fed loops of *held, straight, \
         fed loop* above (each hand ties an overhand in its own end: the two knots in series have the \
         square's, the granny's or, with B's end tucked through its loop twice, the surgeon's knot's \
         type), then tightened as `hand run --tighten 0.05` does. *tied*: runs named the \
         script's knot by the identification after tying; *kept*: of those, runs named the same after \
         the tightening; *crossings*: link pairs the swept-volume check (`knots::check`) finds \
         passing through each other between consecutive accepted states, over every state of every \
         run; *runs with a topology change*: runs with a crossing, or tied and not kept.\n"
    );
    println!(
        "| knot | runs | tied | kept after tightening | states checked | crossings between consecutive states | runs with a topology change | pulls ended taut / jammed / out of work / otherwise | knotted stretch at the end, median (diameters) | seconds |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|");
    let only = std::env::var("KNOT_BENCH_ONLY").ok();
    for knot in [Knot::Overhand, Knot::Square, Knot::Granny, Knot::Surgeons] {
        if only.as_ref().is_some_and(|o| o != knot.name()) {
            continue;
        }
        let clock = std::time::Instant::now();
        let mut rng = Rng(0x70_9010 ^ (knot as u64) << 4);
        let (mut tied, mut kept, mut states, mut crossings, mut changed) = (0, 0, 0, 0, 0);
        let (mut taut, mut jammed, mut out_of_work, mut other) = (0, 0, 0, 0);
        let mut stretches = Vec::new();
        for _ in 0..runs {
            let c = tie_and_tighten(&scene, knot, &mut rng);
            tied += usize::from(c.tied);
            kept += usize::from(c.kept);
            states += c.states;
            crossings += c.crossings;
            changed += usize::from(c.crossings > 0 || (c.tied && !c.kept));
            (taut, jammed, out_of_work, other) = (
                taut + c.taut,
                jammed + c.jammed,
                out_of_work + c.out_of_work,
                other + c.other,
            );
            stretches.extend(c.stretch);
        }
        stretches.sort_by(f64::total_cmp);
        let median = stretches
            .get(stretches.len() / 2)
            .map_or("—".to_string(), |s| format!("{s:.1}"));
        println!(
            "| {} | {runs} | {tied} | {kept} | {states} | {crossings} | {changed} | {taut} / {jammed} / {out_of_work} / {other} | {median} | {:.0} |",
            knot.name(),
            clock.elapsed().as_secs_f64()
        );
    }
}

fn main() {
    let runs: usize = std::env::var("KNOT_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|&r| r > 0)
        .unwrap_or(6);
    let only: Option<usize> = std::env::var("KNOT_BENCH_LINKS")
        .ok()
        .and_then(|s| s.parse().ok());
    if std::env::var("KNOT_BENCH_TABLES").is_ok_and(|t| t == "topology") {
        // The topology table only (BENCHMARKS' block `knots-topology`); KNOT_BENCH_RUNS runs per knot.
        topology_table(runs);
        return;
    }
    if std::env::var("KNOT_BENCH_TABLES").is_ok_and(|t| t == "bend" || t == "paths") {
        // The bend-radius tables only (BENCHMARKS' block `knots-bend`); `paths`: its smooth paths'
        // rows alone.
        bend_radius_table(runs, only);
        if std::env::var("KNOT_BENCH_TABLES").is_ok_and(|t| t == "bend") {
            loop_survival(true);
        }
        return;
    }
    println!(
        "Knots tied on a rope {LENGTH} units long and {THICKNESS} thick (capsule collision), {runs} \
         perturbed runs per cell. *tied*: runs whose rope the identification names as the script's \
         knot; *refused*: share of moves refused (locked, or beyond the held rope's reach); \
         *iter/move*: fixed-base iterations per accepted move (0 when nothing is held; the reach \
         hierarchy finishes after 16).\n"
    );
    let knots = [Knot::Overhand, Knot::Square, Knot::Granny];
    print!("| links | link length | ends, start |");
    for k in knots {
        let k = k.name();
        print!(" {k} tied | {k} refused | {k} iter/move |");
    }
    println!("\n|---:|---:|---|{}", "---:|---:|---:|".repeat(knots.len()));
    for n in [40usize, 80, 160] {
        if only.is_some_and(|o| o != n) {
            continue;
        }
        for ends in [
            Ends::Free,
            Ends::UFree,
            Ends::Held,
            Ends::Wide,
            Ends::WideHeld,
            Ends::HeldPull,
            Ends::WideHeldPull,
            Ends::HeldFed,
        ] {
            print!("| {n} | {} | {} |", LENGTH / n as f64, ends.name());
            for knot in knots {
                // The wide loop is an overhand: no two-handed script.
                if ends.wide() && knot != Knot::Overhand {
                    print!(" – | – | – |");
                    continue;
                }
                let mut rng = Rng(0x5EED ^ (n as u64) << 8 ^ knot as u64);
                let (mut ok, mut refused, mut moves, mut iterations) = (0, 0, 0, 0u64);
                let mut found = Vec::new();
                for _ in 0..runs {
                    let o = tie(n, ends, knot, None, false, None, &mut rng);
                    ok += usize::from(o.knot == knot.expected());
                    refused += o.refused;
                    moves += o.moves;
                    iterations += o.iterations;
                    found.push(o.knot.name());
                }
                eprintln!(
                    "{n} links, {}, {}: {}",
                    ends.name(),
                    knot.name(),
                    found.join(" ")
                );
                print!(
                    " {ok}/{runs} | {:.1} % | {:.1} |",
                    100.0 * refused as f64 / moves.max(1) as f64,
                    iterations as f64 / (moves - refused).max(1) as f64
                );
            }
            println!();
        }
    }
    fed_radius(runs, only);
    loop_survival(false);
}
