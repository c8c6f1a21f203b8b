//! The world's rules, by property: random sequences of commands (moves and paths of any joint,
//! grasps and releases, an instrument pushed about, resets, a fixed-base reach with joint ranges, a
//! bundle's heads) on a scene with collision, an instrument, a bend radius, a limited arm and a
//! bundle, moves and instrument poses with the pull flag. After every command, checked by code
//! written here: a refused command changes nothing
//! (the whole state, bit for bit, and the sequence number); an accepted one keeps every link's length
//! (1e-12 of it), every grasped joint where it was grasped, bit for bit, and publishes no NaN; the
//! sequence number counts the accepted changes; a pulled move (or one that stopped short inside its
//! frame) ends no further from its target than it started, and a held joint's pull is where it is
//! less where it was asked to be.

use proptest::prelude::*;
use world::World;
use world::command::{BundleOp, Command, Point};
use world::scene::parse_scene;

const SCENE: &str = r#"
[[instrument]]
name = "post"
shape = "sphere"
center = [6.0, 3.0, 0.0]
radius = 0.5

[[chain]]
name = "rope"
links = 24
link_length = 0.5
thickness = 0.2
collision = "capsules"
instruments = ["post"]
min_bend_radius = 0.4

[[chain]]
name = "arm"
kind = "fixed-base"
space = "planar"
links = 6
link_length = 0.3
joint_range = [-70.0, 40.0]

[[bundle]]
name = "hair"
strands = 9
links = 4
link_length = 0.25
"#;

/// Every joint of every chain, and every joint of the bundle, as points.
fn joints(w: &World) -> Vec<Vec<Point>> {
    let mut out: Vec<Vec<Point>> = (0..w.len() as u32)
        .map(|c| {
            let n = w.specs()[c as usize].lengths.len() + 1;
            w.elements_with(c, false, false, false, (false, false))
                .take(n)
                .collect()
        })
        .collect();
    out.push(
        w.elements_for(
            w.len() as u32,
            &world::elements::Counts {
                joints: w.bundles()[0].spec.joints() as u32,
                ..Default::default()
            },
        )
        .collect(),
    );
    out
}

/// A small generator of commands (a seed and a kind).
#[derive(Debug, Clone)]
enum Op {
    Move {
        joint: usize,
        dx: [f64; 3],
        path: bool,
        pull: bool,
    },
    Grasp(usize),
    Release(usize),
    Instrument([f64; 3], bool),
    Reset,
    Reach([f64; 2]),
    Hair([f64; 3]),
}

fn op() -> impl Strategy<Value = Op> {
    let v3 = || prop::array::uniform3(-2.0f64..2.0);
    prop_oneof![
        4 => (0usize..25, v3(), any::<bool>(), any::<bool>())
            .prop_map(|(joint, dx, path, pull)| Op::Move { joint, dx, path: path && !pull, pull }),
        2 => (0usize..25).prop_map(Op::Grasp),
        1 => (0usize..25).prop_map(Op::Release),
        1 => (v3(), any::<bool>()).prop_map(|(c, pull)| Op::Instrument(c, pull)),
        1 => Just(Op::Reset),
        2 => prop::array::uniform2(-1.8f64..1.8).prop_map(Op::Reach),
        1 => v3().prop_map(Op::Hair),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn a_refusal_changes_nothing_and_an_answer_keeps_lengths_and_grasps(ops in prop::collection::vec(op(), 1..40)) {
        let scene = parse_scene(SCENE, "rules.toml").unwrap();
        let mut w = World::new(&scene).unwrap();
        let lengths: Vec<Vec<f64>> = w.specs().iter().map(|s| s.lengths.clone()).collect();
        // Grasped joints of the rope and where each was grasped (the test's own record).
        let mut grasped: Vec<(usize, Point)> = Vec::new();
        let mut changes = 0u64;
        for op in ops {
            let before_state = w.state();
            let before = joints(&w);
            let rope = &before[0];
            let moves = w.specs()[0].moves;
            let reach = w.specs()[1].reach;
            let targets: Vec<Point>;
            let heads: Vec<Point>;
            let cmd = match &op {
                Op::Move { joint, dx, path, pull } => {
                    let from = rope[*joint];
                    let to = from + Point::new(dx[0], dx[1], dx[2]);
                    targets = if *path { vec![(from + to) * 0.5, to] } else { vec![to] };
                    Command::Move { chain: 0, joint: *joint, targets: &targets, options: moves, take_over: false, smooth: false, pull: *pull, needle: world::command::NeedleMove::Carried }
                }
                Op::Grasp(j) => Command::Grasp { chain: 0, joint: *j, take_over: false },
                Op::Release(j) => Command::Release { chain: 0, joint: *j, take_over: false },
                Op::Instrument(c, pull) => Command::Instrument {
                    chain: 0, index: 0, centre: Point::new(c[0] + 6.0, c[1] + 3.0, c[2]), axis: None,
                    max_substeps: moves.max_substeps, pull: *pull,
                },
                Op::Reset => Command::Reset { chain: 0, take_over: false },
                Op::Reach(t) => Command::Reach { chain: 1, goal: world::command::Goal::Point(Point::new(t[0], t[1], 0.0)), options: reach, angles: false },
                Op::Hair(d) => {
                    heads = (0..9).map(|i| {
                        let h = before[2][i * 5 + 4];
                        h + Point::new(d[0], d[1], d[2]) * 0.2
                    }).collect();
                    Command::Bundle { handle: 2, index: 0, op: BundleOp::Heads { targets: &heads, substeps: 2 } }
                }
            };
            match w.apply(&cmd) {
                Err(r) => {
                    prop_assert_eq!(&w.state(), &before_state, "{:?} refused ({}) but changed the state", op, r.reason());
                    prop_assert_eq!(&joints(&w), &before, "{:?} refused ({}) but moved a joint", op, r.reason());
                }
                Ok(a) => {
                    changes += u64::from(a.changed && !a.bundle);
                    match op {
                        Op::Grasp(j) if !grasped.iter().any(|g| g.0 == j) => grasped.push((j, before[0][j])),
                        Op::Release(j) => grasped.retain(|g| g.0 != j),
                        Op::Reset => grasped.clear(),
                        // The moved joint lands on its last target: exactly on a free chain, within the
                        // chain's reach tolerance (a fraction of its length) where a held side is
                        // solved as a fixed-base chain. The hand that holds a joint moves it, and it
                        // is held where it lands.
                        // A pull, or a move that stopped short inside its frame, ends never further
                        // from its target than it started; a held joint's pull in the payload is
                        // where it is less where it was asked.
                        Op::Move { joint, pull, .. } => {
                            // Any move may stop short inside its frame (the answer says so): it is
                            // checked as a pull is.
                            let pull = pull || a.stopped.is_some();
                            let now = joints(&w)[0][joint];
                            let last = match &cmd { Command::Move { targets, .. } => targets[targets.len() - 1], _ => unreachable!() };
                            let miss = ((now.x - last.x).powi(2) + (now.y - last.y).powi(2) + (now.z - last.z).powi(2)).sqrt();
                            let spec = &w.specs()[0];
                            let bound = spec.reach.tolerance * spec.total_length + 1e-12;
                            if pull {
                                let was = before[0][joint];
                                let start = ((was.x - last.x).powi(2) + (was.y - last.y).powi(2) + (was.z - last.z).powi(2)).sqrt();
                                prop_assert!(miss <= start + bound, "{:?}: joint {} pulled from {:e} to {:e} of its target", op, joint, start, miss);
                                let payload: Vec<Point> = w.elements_with(0, false, true, true, (true, false)).collect();
                                // Joints, held joints, the post (three elements), then one pull per
                                // held joint and one for the post.
                                let n = spec.lengths.len() + 1;
                                let n_held = (payload.len() - n - 4) / 2;
                                if let Some(k) = payload[n..n + n_held].iter().position(|p| p.x as usize == joint) {
                                    // Zero when the move was made (to the reach's tolerance).
                                    let p = payload[n + n_held + 3 + k];
                                    let want = now - last;
                                    let made = p == Point::zeros() && miss <= bound;
                                    prop_assert!(made || (p - want).norm() <= 1e-9 * (1.0 + want.norm()), "{:?}: pull {:?}, the joint is {:?} from its target", op, p, want);
                                }
                            } else {
                                prop_assert!(miss <= bound, "{:?}: joint {} landed {:e} from its target", op, joint, miss);
                            }
                            if let Some(g) = grasped.iter_mut().find(|g| g.0 == joint) {
                                g.1 = now;
                            }
                        }
                        _ => {}
                    }
                }
            }
            prop_assert_eq!(w.sequence(), changes);
            let now = joints(&w);
            for (c, js) in now.iter().enumerate() {
                for p in js {
                    prop_assert!(p.x.is_finite() && p.y.is_finite() && p.z.is_finite(), "chain {} has {:?}", c, p);
                }
            }
            for (c, ls) in lengths.iter().enumerate() {
                for (i, &l) in ls.iter().enumerate() {
                    let (a, b) = (now[c][i], now[c][i + 1]);
                    let d = ((b.x - a.x).powi(2) + (b.y - a.y).powi(2) + (b.z - a.z).powi(2)).sqrt();
                    prop_assert!((d - l).abs() <= 1e-12 * l.max(1.0), "{:?}: chain {} link {} is {} long, not {}", op, c, i, d, l);
                }
            }
            for &(j, at) in &grasped {
                let p = now[0][j];
                prop_assert!(
                    p.x.to_bits() == at.x.to_bits() && p.y.to_bits() == at.y.to_bits() && p.z.to_bits() == at.z.to_bits(),
                    "{:?}: grasped joint {} moved from {:?} to {:?}", op, j, at, p
                );
            }
        }
    }
}
