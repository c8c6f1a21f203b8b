//! A free rope with a bend radius, capsule collision and links shorter than it is thick (`knots.toml`'s
//! `bend-320`), its head driven along the built-in `overhand-bend`'s path through the world in
//! process: some moves lock, the bend limit's re-straightening holding contacts a hundredth of a
//! unit too close. Their passes settle (each moves the joints less than the last, by about 0.4) and
//! the resolution locks once two passes in a row moved no joint more than a millionth of the
//! clearance, not after its 64 passes. Every locked move stops short inside its frame, no farther
//! from its target than it was, and most lock before the pass limit: since a stopped substep is
//! taken on by halvings, the rope is pressed up to its jams, and about a fifth of the locks on this
//! path go round without settling to the 64th pass (tests/README.md).

use knots::script::Script;
use tractrix::ChainError;
use world::World;
use world::command::{Command, NeedleMove, Point};
use world::scene::parse_scene;

const ROPE: &str = r#"
[[chain]]
name = "bend-320"
links = 320
link_length = 0.125
axis = [1.0, 0.0, 0.0]
thickness = 0.2
collision = "capsules"
min_bend_radius = 1.5
collision_iterations = 64
"#;

/// The collision passes the rope may take per substep (its `collision_iterations`, the limit on
/// longer links: the test is about how locks come before it).
const PASS_LIMIT: u32 = 64;

#[test]
fn a_move_whose_passes_settle_short_of_clear_locks_before_its_pass_limit() {
    let scene = parse_scene(ROPE, "bend.toml").unwrap();
    let mut w = World::new(&scene).unwrap();
    // A frame the passes, not the work, end the resolutions in.
    w.set_budget(2_000_000);
    let script = Script::builtin("overhand-bend").unwrap();
    let path = script.turn[0].targets([40.0, 0.0, 0.0], script.max_step);
    let joints = |w: &World| w.elements_of(0, false).collect::<Vec<Point>>();
    let (mut locked, mut made, mut at_limit) = (0, 0, 0);
    for t in &path {
        let before = joints(&w);
        let target = [Point::new(t[0], t[1], t[2])];
        let r = w.apply(&Command::Move {
            chain: 0,
            joint: 320,
            targets: &target,
            options: w.specs()[0].moves,
            take_over: false,
            smooth: false,
            pull: false,
            needle: NeedleMove::Carried,
        });
        let a = r.unwrap_or_else(|e| panic!("{}", e.reason()));
        match a.short.map(|s| s.error) {
            None => made += 1,
            Some(ChainError::Locked { iterations, .. }) => {
                locked += 1;
                assert!(iterations <= PASS_LIMIT, "{iterations} passes");
                at_limit += usize::from(iterations == PASS_LIMIT);
                // Stopped short: the joint no nearer its target than it was is allowed, never
                // farther.
                let (was, now) = (before[320], joints(&w)[320]);
                assert!((now - target[0]).norm() <= (was - target[0]).norm() + 1e-12);
            }
            Some(e) => panic!("stopped short by {e:?}"),
        }
    }
    eprintln!("{made} moves made, {locked} locked, {at_limit} of them after {PASS_LIMIT} passes");
    assert!(locked > 0, "no move locked: the test shows nothing");
    assert!(
        at_limit * 2 < locked,
        "{at_limit} of {locked} locks ran all {PASS_LIMIT} passes: the passes did not settle"
    );
    assert!(made > locked);
}
