//! Joint limits: cones, planar ranges and a rope's bend radius. Every angle and length here is computed
//! by this file's own code from the published positions (no kernel helper), and every limited move is
//! checked to keep every joint within its limit, the links at their lengths, the moved joint on its
//! target; a move that never meets a limit is the unlimited move bit for bit; a held or colliding move
//! that cannot keep the limits is refused and changes nothing; and the bend radius keeps a circling
//! rope's loop open over the same length of rope at 40, 80 and 160 links.

use crate::support::Rng;
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, move_joint_colliding,
};
use tractrix::link::step;
use tractrix::{Chain, ChainError, JointLimits, LimitError, Method, MoveOptions, Substeps};

/// The turn at each interior joint (radians, unsigned), from the published positions.
fn turns3(c: &Chain<f64, 3>) -> Vec<f64> {
    let p = c.positions();
    p.windows(3)
        .map(|w| {
            let (a, b) = (w[1] - w[0], w[2] - w[1]);
            let cos = a.dot(&b) / (a.norm() * b.norm());
            let sin = a.cross(&b).norm() / (a.norm() * b.norm());
            sin.atan2(cos)
        })
        .collect()
}

/// The signed turn at each interior joint of a planar chain (counter-clockwise positive).
fn turns2(c: &Chain<f64, 2>) -> Vec<f64> {
    let p = c.positions();
    p.windows(3)
        .map(|w| {
            let (a, b) = (w[1] - w[0], w[2] - w[1]);
            (a.x * b.y - a.y * b.x).atan2(a.dot(&b))
        })
        .collect()
}

fn length_error<const D: usize>(c: &Chain<f64, D>) -> f64
where
    nalgebra::SVector<f64, D>: tractrix::math::Embed3<f64>,
{
    let p = c.positions();
    p.windows(2)
        .zip(c.lengths())
        .map(|(w, &l)| (((w[1] - w[0]).norm() - l) / l).abs())
        .fold(0.0, f64::max)
}

/// A random rope whose turns are all within `max_turn`.
fn rope_within(n: usize, len: f64, max_turn: f64, rng: &mut Rng) -> Chain<f64, 3> {
    let mut p = vec![Vector3::zeros()];
    let mut dir = Vector3::x();
    for _ in 0..n {
        let side = rng.dir3();
        let perp = (side - dir * side.dot(&dir)).normalize();
        let a = rng.range(0.0, max_turn * 0.95);
        dir = (dir * a.cos() + perp * a.sin()).normalize();
        p.push(p.last().unwrap() + dir * len);
    }
    Chain::from_points(&p).unwrap()
}

const TOL: f64 = 1e-9;

/// The links after `k` substeps of a move of `joint` to `target`, run one after the other over the
/// whole chain, each link turned back into its limit as it is stepped; with the links turned and the
/// paper-form fallbacks.
fn sequential_limited<const D: usize>(
    c: &Chain<f64, D>,
    joint: usize,
    target: nalgebra::SVector<f64, D>,
    k: u32,
    method: Method,
) -> (Vec<nalgebra::SVector<f64, D>>, u32, u32)
where
    nalgebra::SVector<f64, D>: tractrix::math::Embed3<f64>,
{
    let lim = c.joint_limits().unwrap();
    let n = c.n_links();
    let sub = (target - c.joint(joint)) / k as f64;
    let mut links = c.links().to_vec();
    let lengths = c.lengths().to_vec();
    let (mut clamps, mut fallbacks) = (0u32, 0u32);
    for _ in 0..k {
        let mut shift = sub;
        for i in (0..joint).rev() {
            let (st, fb) = step(method, &(-links[i]), &shift, lengths[i]);
            let (mut link, mut tail) = (st.link, st.tail_shift);
            if i + 1 < joint
                && let Some(t) = lim.clamp(
                    i + 1,
                    &(-links[i + 1]),
                    lengths[i + 1],
                    &link,
                    lengths[i],
                    true,
                )
            {
                tail += t - link;
                link = t;
                clamps += 1;
            }
            links[i] = -link;
            shift = tail;
            fallbacks += fb as u32;
        }
        let mut shift = sub;
        for i in joint..n {
            let (st, fb) = step(method, &links[i], &shift, lengths[i]);
            let (mut link, mut tail) = (st.link, st.tail_shift);
            if i > 0
                && let Some(t) =
                    lim.clamp(i, &links[i - 1], lengths[i - 1], &link, lengths[i], false)
            {
                tail += t - link;
                link = t;
                clamps += 1;
            }
            links[i] = link;
            shift = tail;
            fallbacks += fb as u32;
        }
    }
    (links, clamps, fallbacks)
}

fn opts(method: Method, k: u32) -> MoveOptions<f64> {
    MoveOptions {
        method,
        substeps: Substeps::Fixed(k),
        ..MoveOptions::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Free moves of any joint by any method keep every cone; lengths exact; the joint lands.
    #[test]
    fn free_moves_keep_every_cone(
        seed in 0u64..100_000, n in 3usize..60, cone_deg in 5.0f64..120.0, m in 0usize..3,
        k in 1u32..7, steps in 1usize..20, size in 0.01f64..3.0,
    ) {
        let mut rng = Rng(seed);
        let cone = cone_deg.to_radians();
        let mut c = rope_within(n, 1.0, cone, &mut rng);
        c.set_limits(Some(JointLimits::cone(n, cone).unwrap())).unwrap();
        let method = [Method::Tractrix, Method::FollowTheLeader, Method::TractrixPaper][m];
        for _ in 0..steps {
            let joint = match rng.below(3) { 0 => n, 1 => 0, _ => rng.below(n + 1) };
            let target = c.joint(joint) + rng.dir3() * size;
            c.move_joint(joint, target, &opts(method, k)).unwrap();
            prop_assert!((c.joint(joint) - target).norm() < 1e-12 * (1.0 + target.norm()));
            let worst = turns3(&c).into_iter().fold(0.0, f64::max);
            prop_assert!(worst <= cone + TOL, "turn {worst} beyond cone {cone}");
            prop_assert!(length_error(&c) < 1e-12);
        }
    }

    /// Asymmetric revolute ranges of a planar chain: every signed turn stays in its range.
    #[test]
    fn planar_moves_keep_every_range(
        seed in 0u64..100_000, n in 3usize..30, k in 1u32..5, steps in 1usize..30,
    ) {
        let mut rng = Rng(seed);
        let lo: Vec<f64> = (0..=n).map(|_| -rng.range(0.05, 1.5)).collect();
        let hi: Vec<f64> = (0..=n).map(|_| rng.range(0.0, 0.8)).collect();
        let mut c = Chain::<f64, 2>::straight(n, 1.0, Vector2::zeros(), Vector2::x()).unwrap();
        c.set_limits(Some(JointLimits::ranges(&lo, &hi).unwrap())).unwrap();
        for _ in 0..steps {
            let joint = match rng.below(3) { 0 => n, 1 => 0, _ => rng.below(n + 1) };
            let target = c.joint(joint) + Vector2::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0));
            c.move_joint(joint, target, &opts(Method::Tractrix, k)).unwrap();
            for (i, t) in turns2(&c).into_iter().enumerate() {
                let j = i + 1;
                prop_assert!(t <= hi[j] + TOL && t >= lo[j] - TOL,
                    "joint {j}: {t} outside [{}, {}]", lo[j], hi[j]);
            }
            prop_assert!(length_error(&c) < 1e-12);
        }
    }

    /// A limited move of `k` substeps equals, bit for bit, `k` substeps run one after the other over
    /// the whole chain, each link turned back into its limit about its neighbour toward the moved
    /// joint as it is stepped (the order written here: the tail side, then the head side, whose first
    /// link turns about the tail side's), however the kernel schedules them (from two substeps on, as
    /// wavefronts; the closed form on a spatial chain from `SIMD_FROM` substeps with SIMD lanes, to
    /// 1e-12 of a link). Cones on a spatial rope and ranges on a planar chain, every method.
    #[test]
    fn limited_substeps_in_any_order_give_the_sequential_result(
        seed in 0u64..100_000, n in 1usize..50, cone_deg in 5.0f64..120.0, m in 0usize..3,
        k in 2u32..40, size in 0.01f64..6.0, planar in proptest::bool::ANY,
    ) {
        let mut rng = Rng(seed);
        let method = [Method::Tractrix, Method::FollowTheLeader, Method::TractrixPaper][m];
        if planar {
            let lo: Vec<f64> = (0..=n).map(|_| -rng.range(0.05, 1.5)).collect();
            let hi: Vec<f64> = (0..=n).map(|_| rng.range(0.0, 0.8)).collect();
            let mut c = Chain::<f64, 2>::straight(n, 1.0, Vector2::zeros(), Vector2::x()).unwrap();
            c.set_limits(Some(JointLimits::ranges(&lo, &hi).unwrap())).unwrap();
            let joint = rng.below(n + 1);
            let target = c.joint(joint) + Vector2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * size;
            let want = sequential_limited(&c, joint, target, k, method);
            let out = c.move_joint(joint, target, &opts(method, k)).unwrap();
            prop_assert_eq!((out.limited, out.paper_fallbacks), (want.1, want.2));
            prop_assert_eq!(c.links(), &want.0[..], "n {}, joint {}, k {}", n, joint, k);
        } else {
            let cone = cone_deg.to_radians();
            let mut c = rope_within(n, 1.0, cone, &mut rng);
            c.set_limits(Some(JointLimits::cone(n, cone).unwrap())).unwrap();
            let joint = rng.below(n + 1);
            let target = c.joint(joint) + rng.dir3() * size;
            let want = sequential_limited(&c, joint, target, k, method);
            let out = c.move_joint(joint, target, &opts(method, k)).unwrap();
            let simd = method == Method::Tractrix && k as usize >= tractrix::chain::SIMD_FROM;
            if simd {
                // The SIMD lanes take the exponential from a polynomial: the links agree to 1e-12 of
                // a link, and a link that close to its limit may be turned in one and not the other.
                for (i, (a, b)) in c.links().iter().zip(&want.0).enumerate() {
                    prop_assert!((a - b).norm() <= 1e-12, "link {} of {}, joint {}, k {}: {} vs {}", i, n, joint, k, a, b);
                }
            } else {
                prop_assert_eq!((out.limited, out.paper_fallbacks), (want.1, want.2));
                prop_assert_eq!(c.links(), &want.0[..], "n {}, joint {}, k {}", n, joint, k);
            }
        }
    }

    /// Moves with held joints are kept within the limits or refused with nothing changed.
    #[test]
    fn held_moves_keep_the_limits_or_change_nothing(
        seed in 0u64..100_000, n in 4usize..30, cone_deg in 20.0f64..90.0, k in 1u32..4,
        steps in 1usize..10,
    ) {
        let mut rng = Rng(seed);
        let cone = cone_deg.to_radians();
        let mut c = rope_within(n, 1.0, cone, &mut rng);
        c.set_limits(Some(JointLimits::cone(n, cone).unwrap())).unwrap();
        let held = rng.below(n + 1);
        c.hold(held).unwrap();
        let at = c.joint(held);
        for _ in 0..steps {
            let joint = (held + 1 + rng.below(n)) % (n + 1);
            let target = c.joint(joint) + rng.dir3() * rng.range(0.01, 0.5);
            let before = c.clone();
            match c.move_joint(joint, target, &opts(Method::Tractrix, k)) {
                Ok(_) => {
                    let worst = turns3(&c).into_iter().fold(0.0, f64::max);
                    prop_assert!(worst <= cone + 2e-6, "turn {worst} beyond cone {cone}");
                    prop_assert!((c.joint(joint) - target).norm() < 1e-6);
                    prop_assert!(length_error(&c) < 1e-12);
                }
                Err(_) => prop_assert_eq!(&c, &before),
            }
            prop_assert_eq!(c.joint(held), at);
        }
    }
}

/// A limit the moves never reach changes nothing: the same bits as the chain without limits.
#[test]
fn limits_never_met_are_the_unlimited_move_bit_for_bit() {
    let mut rng = Rng(7);
    for k in [1, 2, 3] {
        for method in [
            Method::Tractrix,
            Method::FollowTheLeader,
            Method::TractrixPaper,
        ] {
            let mut free = rope_within(30, 1.0, 0.3, &mut rng);
            let mut limited = free.clone();
            limited
                .set_limits(Some(JointLimits::cone(30, std::f64::consts::PI).unwrap()))
                .unwrap();
            for _ in 0..200 {
                let joint = rng.below(31);
                let target = free.joint(joint) + rng.dir3() * 0.3;
                let a = free.move_joint(joint, target, &opts(method, k)).unwrap();
                let b = limited.move_joint(joint, target, &opts(method, k)).unwrap();
                assert_eq!(b.limited, 0);
                assert_eq!(a.substeps, b.substeps);
                assert_eq!(free.links(), limited.links(), "k {k} {method:?}");
                assert_eq!(free.positions(), limited.positions());
            }
        }
    }
}

/// The cones of a bend radius: `2 atan(L / 2R)` at each joint, from the shorter link.
#[test]
fn bend_radius_cones_follow_the_link_lengths() {
    let lengths = [1.0, 0.5, 0.5, 2.0];
    let l = JointLimits::bend_radius(&lengths, 1.5).unwrap();
    for (j, short) in [(1, 0.5), (2, 0.5), (3, 0.5)] {
        let want = 2.0 * (short / 3.0f64).atan();
        assert!((l.hi(j) - want).abs() < 1e-15, "joint {j}");
    }
    assert!(!l.limits(0) && !l.limits(4));
}

/// Bad limits are refused and change nothing.
#[test]
fn bad_limits_are_refused() {
    let mut c = Chain::<f64, 3>::straight(4, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
    assert!(matches!(
        c.set_limits(Some(JointLimits::cone(3, 0.5).unwrap())),
        Err(LimitError::Count {
            given: 4,
            joints: 5
        })
    ));
    assert!(matches!(
        JointLimits::<f64>::cone(4, 4.0),
        Err(LimitError::Value { .. })
    ));
    assert!(matches!(
        JointLimits::<f64>::cone(4, f64::NAN),
        Err(LimitError::Value { .. })
    ));
    assert!(matches!(
        JointLimits::<f64>::bend_radius(&[1.0; 4], 0.0),
        Err(LimitError::Value { .. })
    ));
    assert!(matches!(
        JointLimits::<f64>::ranges(&[0.5; 5], &[0.1; 5]),
        Err(LimitError::Value { .. })
    ));
    let range = JointLimits::ranges(&[-0.5; 5], &[0.5; 5]).unwrap();
    assert_eq!(c.set_limits(Some(range)), Err(LimitError::RangeInSpace));
    assert!(c.joint_limits().is_none());
}

/// The nearest any joint of the rope's last `rope_len` units comes to the centre of a circle of
/// radius `r` that the head has gone round for `travel` units (in the plane z = 0).
fn circle_gap(links: usize, rope_len: f64, r_min: Option<f64>, r: f64, travel: f64) -> f64 {
    let len = rope_len / links as f64;
    let mut c =
        Chain::<f64, 3>::straight(links, len, Vector3::new(-rope_len, 0.0, 0.0), Vector3::x())
            .unwrap();
    if let Some(r_min) = r_min {
        let lim = JointLimits::bend_radius(c.lengths(), r_min).unwrap();
        c.set_limits(Some(lim)).unwrap();
    }
    let centre = Vector3::new(0.0, r, 0.0);
    let steps = (travel / 0.05).ceil() as usize;
    let o = MoveOptions {
        substeps: Substeps::MaxStep(0.1),
        ..MoveOptions::default()
    };
    for s in 1..=steps {
        let a = s as f64 * travel / steps as f64 / r;
        let target = centre + Vector3::new(a.sin() * r, -a.cos() * r, 0.0);
        c.move_joint(links, target, &o).unwrap();
    }
    c.positions()
        .iter()
        .map(|p| (p - centre).norm())
        .fold(f64::INFINITY, f64::min)
}

/// The loop a circling head lays keeps open with a bend radius, at every resolution: without one the
/// rope spirals in toward the centre (nearer the finer the rope), with `R_min = 1.5` no joint comes
/// within a unit of it at 40, 80 or 160 links (the gap is a length of rope, not a number of links).
#[test]
fn a_bend_radius_keeps_a_circling_loop_open_at_every_resolution() {
    for links in [40, 80, 160] {
        let free = circle_gap(links, 40.0, None, 2.0, 48.0);
        let bent = circle_gap(links, 40.0, Some(1.5), 2.0, 48.0);
        assert!(free < 0.5, "{links} links without a limit: gap {free}");
        assert!(bent > 1.0, "{links} links with R_min 1.5: gap {bent}");
    }
}

/// With collision and limits both, an accepted move keeps every cone and the clearance; a refused one
/// changes nothing.
#[test]
fn colliding_moves_keep_the_cones() {
    let mut rng = Rng(11);
    let cone = 0.6;
    for _ in 0..20 {
        let mut c = rope_within(40, 1.0, cone, &mut rng);
        c.set_limits(Some(JointLimits::cone(40, cone).unwrap()))
            .unwrap();
        let model = CollisionModel {
            options: CollisionOptions {
                thickness: 0.2,
                ..CollisionOptions::default()
            },
            obstacles: Vec::new(),
            holding: Vec::new(),
        };
        let mut ws = CollisionWorkspace::new();
        for _ in 0..50 {
            let target = c.head() + rng.dir3() * 0.5;
            let before = c.clone();
            match move_joint_colliding(
                &mut c,
                40,
                target,
                &opts(Method::Tractrix, 1),
                &model,
                &mut ws,
            ) {
                Ok(_) => {
                    let worst = turns3(&c).into_iter().fold(0.0, f64::max);
                    assert!(worst <= cone + TOL, "turn {worst}");
                    assert!(length_error(&c) < 1e-12);
                }
                Err(ChainError::Locked { .. }) | Err(ChainError::JointLimit { .. }) => {
                    assert_eq!(c, before)
                }
                Err(e) => panic!("{e}"),
            }
        }
    }
}

/// A rope held at its tail and limited to R_min = 1.5 (cones of 2 atan(1/3), 37°) follows a hand
/// that moves its head in small random steps: most moves are made (within the limits), not refused.
#[test]
fn a_held_rope_with_a_bend_radius_follows_small_moves() {
    let mut rng = Rng(5);
    let n = 40;
    let mut c = rope_within(n, 1.0, 0.3, &mut rng);
    let lim = JointLimits::bend_radius(c.lengths(), 1.5).unwrap();
    c.set_limits(Some(lim)).unwrap();
    c.hold(0).unwrap();
    let (mut made, mut refused) = (0, 0);
    for _ in 0..400 {
        let target = c.head() + rng.dir3() * 0.1;
        let before = c.clone();
        match c.move_joint(n, target, &opts(Method::Tractrix, 1)) {
            Ok(_) => {
                made += 1;
                let worst = turns3(&c).into_iter().fold(0.0, f64::max);
                assert!(worst <= 2.0 * (1.0f64 / 3.0).atan() + 2e-6, "turn {worst}");
            }
            Err(_) => {
                refused += 1;
                assert_eq!(c, before);
            }
        }
    }
    eprintln!("held rope with a bend radius: {made} made, {refused} refused");
    assert!(made >= 300, "{made} made, {refused} refused");
}

/// A long rope (1000 links of 0.04, R_min = 1.5) held at its tail, lying straight, whose head a hand
/// walks inward in random steps of 0.1 (a straight rope pushed along itself first, then 10 units of
/// slack): each move's pull has to be taken up along the whole rope. The tractrix iteration alone
/// piled the bends at their limit near the moved end (145 joints) and stalled: it made 4 of these 300
/// moves. With boundary following (Korein & Badler) as its finish, at most 1 in 100 is refused.
#[test]
fn a_long_held_straight_rope_with_a_bend_radius_follows_a_hand_walking_in() {
    let c = Chain::<f64, 3>::straight(1000, 0.04, Vector3::zeros(), Vector3::x()).unwrap();
    let (made, _) = held_walk(c, 300, Some(30.0));
    assert!(made >= 297, "{made} of 300 made");
}

/// The same rope coiled into a helix whose every turn is at its limit (a hair inside), held at its
/// tail, its head walked in random steps of 0.1: every pull must open some turns and may close none
/// beyond the cone, so the joints at the limit that a step would bend further are frozen while the
/// others take it up. The tractrix iteration alone made none of these 300 moves.
#[test]
fn a_long_held_rope_coiled_to_its_bend_radius_follows_a_wandering_hand() {
    let (n, len) = (1000, 0.04);
    let cone = 2.0 * (len / 3.0f64).atan();
    let alpha: f64 = 0.05;
    // Directions at a fixed slope alpha, turning by theta about z: the angle between consecutive
    // links is acos(cos²α cos θ + sin²α), set to the cone less a billionth.
    let want = cone * (1.0 - 1e-9);
    let theta = ((want.cos() - alpha.sin().powi(2)) / alpha.cos().powi(2)).acos();
    let mut q = vec![Vector3::zeros()];
    for k in 0..n {
        let a = k as f64 * theta;
        let d = Vector3::new(a.cos() * alpha.cos(), a.sin() * alpha.cos(), alpha.sin());
        q.push(q[k] + d * len);
    }
    let c = Chain::from_points(&q).unwrap();
    let worst = turns3(&c).into_iter().fold(0.0, f64::max);
    assert!(
        worst > cone * (1.0 - 1e-6) && worst <= cone,
        "the coil's turn {worst}"
    );
    let (made, at_limit) = held_walk(c, 300, None);
    assert!(made >= 297, "{made} of 300 made");
    assert!(
        at_limit > 100,
        "only {at_limit} joints stayed at their limit"
    );
}

/// Walks the head of `c` (its tail held, limited to R_min = 1.5) in `steps` random steps of 0.1,
/// drawn back toward the hold beyond `pull_in` of it; checks every made move (every turn within the
/// cone, computed here; lengths; the head on its target; the hold) and every refusal (nothing
/// changed). Returns the moves made and the most joints at their limit after one.
fn held_walk(mut c: Chain<f64, 3>, steps: usize, pull_in: Option<f64>) -> (usize, usize) {
    let n = c.n_links();
    let len = c.lengths()[0];
    let cone = 2.0 * (len / 3.0).atan();
    c.set_limits(Some(JointLimits::bend_radius(c.lengths(), 1.5).unwrap()))
        .unwrap();
    c.hold(0).unwrap();
    let hold = c.joint(0);
    let mut rng = Rng(0xB0);
    let mut p = c.head();
    let (mut made, mut refused, mut at_limit) = (0, 0, 0usize);
    // Held sides iterate at most 64 times, a limited chain's default in a scene.
    let mut o = opts(Method::Tractrix, 1);
    o.held.max_iterations = 64;
    for _ in 0..steps {
        let mut d = rng.dir3();
        if let Some(r) = pull_in
            && (p - hold).norm() > r
        {
            d -= (p - hold).normalize() * 1.5;
        }
        p += d.normalize() * 0.1;
        let before = c.clone();
        match c.move_joint(n, p, &o) {
            Ok(_) => {
                made += 1;
                let turns = turns3(&c);
                let worst = turns.iter().copied().fold(0.0, f64::max);
                assert!(worst <= cone + TOL, "turn {worst} over the cone {cone}");
                at_limit = at_limit.max(turns.iter().filter(|&&t| t > cone - 1e-6).count());
                assert!(length_error(&c) < 1e-12);
                assert!((c.head() - p).norm() < 1e-6, "head off its target");
                assert_eq!(c.joint(0), hold, "the hold moved");
            }
            Err(_) => {
                refused += 1;
                assert_eq!(c, before, "a refusal changed the rope");
            }
        }
    }
    eprintln!("held walk: {made} made, {refused} refused, at most {at_limit} joints at the limit");
    (made, at_limit)
}

/// Targets the planar arm (10 links of 0.2) reaches with every joint in [−60°, 30°]: the head of a
/// pose drawn within the ranges (the base's own angle free).
fn ranged_targets(n: usize, seed: u64) -> Vec<Vector2<f64>> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let mut a = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
            let mut p = Vector2::zeros();
            for j in 0..10 {
                if j > 0 {
                    a += rng.range(-60f64.to_radians(), 30f64.to_radians());
                }
                p += Vector2::new(a.cos(), a.sin()) * 0.2;
            }
            p
        })
        .collect()
}

/// The fixed-base reach with ranges (each of the paper's strategies) and Korein & Badler's
/// boundary-following baseline never leave a solved pose beyond a range (signed angles computed here);
/// the head lands within the tolerance; a refusal changes nothing. Most targets inside the limited
/// workspace are reached.
#[test]
fn the_reach_with_ranges_never_leaves_a_range() {
    use tractrix::pseudo_inverse::{DlsOptions, RangeHandling, reach_dls_ranges};
    use tractrix::{ReachOptions, ReachWorkspace, Strategy, reach};
    let (lo, hi) = (-60f64.to_radians(), 30f64.to_radians());
    let targets = ranged_targets(200, 9);
    for method in 0..4 {
        let mut c = Chain::<f64, 2>::straight(10, 0.2, Vector2::zeros(), Vector2::x()).unwrap();
        c.set_limits(Some(JointLimits::ranges(&[lo; 11], &[hi; 11]).unwrap()))
            .unwrap();
        let mut ws = ReachWorkspace::default();
        let mut ok = 0;
        for t in &targets {
            let before = c.clone();
            let r = match method {
                0..=2 => {
                    let strategy = [
                        Strategy::TranslateBack,
                        Strategy::PullBack,
                        Strategy::TractrixTwoLink,
                    ][method];
                    let o = ReachOptions {
                        strategy,
                        ..ReachOptions::default()
                    };
                    reach(&mut c, t, &o, &mut ws).map(|_| ())
                }
                _ => reach_dls_ranges(&mut c, t, &DlsOptions::default(), RangeHandling::Boundary)
                    .map(|_| ()),
            };
            match r {
                Ok(()) => {
                    ok += 1;
                    assert!(
                        (c.head() - t).norm() <= 2e-9 * 2.0,
                        "method {method}: head off"
                    );
                    for (i, q) in turns2(&c).into_iter().enumerate() {
                        assert!(
                            q <= hi + 1e-9 && q >= lo - 1e-9,
                            "method {method}: joint {} at {q}",
                            i + 1
                        );
                    }
                    assert!(length_error(&c) < 1e-12);
                }
                Err(_) => assert_eq!(c, before, "method {method}: a refusal changed the arm"),
            }
        }
        eprintln!("method {method}: {ok} of {} reached", targets.len());
        // Translate-back (0) and boundary following (3) reach nearly all; pull-back most; the
        // two-link closed form, which ignores the ranges, is refused whenever it breaks one.
        let want = [0.9, 0.75, 0.1, 0.9][method];
        assert!(
            ok as f64 >= want * targets.len() as f64,
            "method {method}: {ok} of {} reached",
            targets.len()
        );
    }
}

/// A spatial fixed-base chain (20 links of 0.1) with a cone of 20° at every joint reaches the heads of
/// random poses within its cones, in sequence from the last pose, by translate-back and pull-back:
/// no solved pose has a joint beyond its cone (angles computed here), the head lands within the
/// tolerance, the base stays, a refusal changes nothing, and at least 9 in 10 are reached.
#[test]
fn the_spatial_reach_with_cones_never_leaves_a_cone() {
    use tractrix::{ReachOptions, ReachWorkspace, Strategy, reach};
    let cone = 20f64.to_radians();
    let mut rng = Rng(21);
    let targets: Vec<Vector3<f64>> = (0..200)
        .map(|_| rope_within(20, 0.1, cone, &mut rng).head())
        .collect();
    for strategy in [Strategy::TranslateBack, Strategy::PullBack] {
        let mut c = Chain::<f64, 3>::straight(20, 0.1, Vector3::zeros(), Vector3::x()).unwrap();
        c.set_limits(Some(JointLimits::cone(20, cone).unwrap()))
            .unwrap();
        let opts = ReachOptions {
            strategy,
            ..ReachOptions::default()
        };
        let mut ws = ReachWorkspace::default();
        let mut ok = 0;
        for t in &targets {
            let before = c.clone();
            match reach(&mut c, t, &opts, &mut ws) {
                Ok(_) => {
                    ok += 1;
                    assert!(
                        (c.head() - t).norm() <= 2e-9 * 2.0,
                        "{strategy:?}: head off"
                    );
                    let worst = turns3(&c).into_iter().fold(0.0, f64::max);
                    assert!(worst <= cone + TOL, "{strategy:?}: a turn of {worst}");
                    assert!(length_error(&c) < 1e-12);
                    assert_eq!(c.joint(0), Vector3::zeros(), "{strategy:?}: the base moved");
                }
                Err(_) => assert_eq!(c, before, "{strategy:?}: a refusal changed the chain"),
            }
        }
        eprintln!("{strategy:?} with cones: {ok} of {} reached", targets.len());
        assert!(ok >= 180, "{strategy:?}: {ok} of {} reached", targets.len());
    }
}

/// A target inside the unlimited workspace but outside the limited one (a planar arm of 10 links of
/// 0.2 whose joints turn at most 10° either way cannot bring its head nearer its base than the arc
/// of all joints at 10°) is refused as not converged, with the arm unchanged and the point the solve
/// reached: no farther from the target than the nearest point of the limited workspace (computed
/// here: the curled arc's head distance, the base turning freely, less the target's distance), plus
/// 5 % of the arm (the solve's nearest is a local one: 0.3–4 % here); and the point lies in the limited workspace (its distance from the base computed
/// here).
#[test]
fn a_target_outside_the_limited_workspace_is_refused_with_a_point_the_arm_reaches() {
    use tractrix::{ReachError, ReachOptions, ReachWorkspace, reach};
    let lim = 10f64.to_radians();
    let arm = || {
        let mut c = Chain::<f64, 2>::straight(10, 0.2, Vector2::zeros(), Vector2::x()).unwrap();
        c.set_limits(Some(JointLimits::ranges(&[-lim; 11], &[lim; 11]).unwrap()))
            .unwrap();
        c
    };
    // The nearest the head can come to the base: every joint turned 10° the same way.
    let (mut a, mut head) = (0.0f64, Vector2::zeros());
    for _ in 0..10 {
        head += Vector2::new(a.cos(), a.sin()) * 0.2;
        a += lim;
    }
    let inner = head.norm();
    for target in [
        Vector2::new(0.5, 0.0),
        Vector2::new(-0.3, 0.9),
        Vector2::new(0.0, -1.2),
    ] {
        let nearest = inner - target.norm();
        assert!(nearest > 0.1, "the target is inside the limited workspace");
        let mut c = arm();
        let before = c.clone();
        let mut ws = ReachWorkspace::default();
        let r = reach(&mut c, &target, &ReachOptions::default(), &mut ws);
        let Err(ReachError::NotConverged {
            reached: Some(p), ..
        }) = r
        else {
            panic!("{target:?}: {r:?}");
        };
        assert_eq!(c, before, "a refusal changed the arm");
        let off = (p - target).norm();
        assert!(
            off <= nearest + 0.05 * 2.0,
            "{target:?}: reached {p:?}, {off} from the target; the workspace comes within {nearest}"
        );
        // In the limited workspace: every head distance from the curled arc's to the straight
        // arm's is reached (curling every joint alike from 0° to 10°), the base turning freely.
        assert!(
            p.norm() >= inner - 1e-9 && p.norm() <= 2.0 + 1e-9,
            "{target:?}: reached {p:?} at {} from the base, outside [{inner}, 2]",
            p.norm()
        );
    }
}

/// The distance from `p` to the segment `a`–`b`, computed here.
fn to_segment(a: Vector3<f64>, b: Vector3<f64>, p: Vector3<f64>) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.dot(&ab)).clamp(0.0, 1.0);
    (a + ab * t - p).norm()
}

/// A rope with a bend radius (R_min = 2 on unit links: cones of 2 atan(1/4), 28°) threaded through
/// an eyelet with friction, its head led up and round so that the rope turns sharply at the eyelet: the rope may turn by any angle at the two joints of the link through the eyelet (the
/// tissue takes the bend there; a straight link through the point cannot follow the suture's curve
/// in the tissue), and every other joint keeps its cone. Every accepted move keeps the cones (the
/// turns computed here), the eyelet on its link and the lengths; a refused one changes nothing.
/// Without the walks steering their links into the cones 399 of the 400 moves were refused, and
/// without the eyelet's joints freed 231 (every move that turned the rope there past the cone).
#[test]
fn a_threaded_rope_keeps_its_cones_but_turns_freely_at_the_eyelet() {
    use tractrix::eyelet::{Eyelet, EyeletWorkspace, move_threaded};
    let mut c = Chain::<f64, 3>::straight(40, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
    let cone = 2.0 * (0.25f64).atan();
    c.set_limits(Some(JointLimits::bend_radius(c.lengths(), 2.0).unwrap()))
        .unwrap();
    let mut e = [Eyelet::thread(&c, Vector3::new(20.5, 0.0, 0.0), 1e-9).unwrap()];
    // With friction: the rope turns at the eyelet rather than sliding through it.
    let mut ws = EyeletWorkspace::new().with_friction(1.0);
    let mut rng = Rng(17);
    let (mut made, mut refused, mut sharpest) = (0, 0, 0.0f64);
    let start = e[0].link;
    for k in 0..400 {
        // Up from the rope's line, then round toward the tail side (the rope doubles back over the
        // eyelet), with a tremor.
        let a = 0.2 + (k as f64 / 400.0) * 2.4;
        let goal = Vector3::new(20.5 + 16.0 * a.cos(), 16.0 * a.sin(), 0.0);
        let step = (goal - c.head()).cap_magnitude(0.25) + rng.dir3() * 0.05;
        let target = c.head() + step;
        let before = (c.clone(), e);
        match move_threaded(&mut c, 40, target, &mut e, 1000, &mut ws) {
            Ok(_) => {
                made += 1;
                let free = [e[0].link, e[0].link + 1];
                for (i, t) in turns3(&c).into_iter().enumerate() {
                    let j = i + 1;
                    if free.contains(&j) {
                        sharpest = sharpest.max(t);
                    } else {
                        assert!(t <= cone + 2e-6, "move {k}: joint {j} turns {t} > {cone}");
                    }
                }
                let p = c.positions();
                let d = to_segment(p[e[0].link], p[e[0].link + 1], e[0].at);
                assert!(d <= 1e-9, "move {k}: the eyelet is {d:e} off its link");
                assert!(length_error(&c) < 1e-12);
            }
            Err(_) => {
                refused += 1;
                assert_eq!((&c, &e), (&before.0, &before.1), "move {k}");
            }
        }
    }
    eprintln!(
        "threaded, limited: {made} made, {refused} refused; sharpest turn at the eyelet {sharpest:.3} (cone {cone:.3}); eyelet from link {start} to {}",
        e[0].link
    );
    assert!(made >= 380, "{made} made, {refused} refused");
    assert!(
        sharpest > 2.0 * cone,
        "the rope never turned sharply at the eyelet"
    );
}

/// A slack rope with a bend radius (R_min = 1.5 on unit links: cones of 37°), laid as a U and held
/// at both ends, pushed by a sphere into one strand: the pushes dent the strand, and the rope between
/// the held ends is re-solved within its cones from the dented pose. Every accepted push keeps the
/// cones and the lengths (computed here) and the held ends bit for bit; all but one push at most are
/// made. Without the dented links turned back into their cones before the re-solve, the re-solve
/// refused the pushes that bent the rope past a cone (4 of 20 locked).
#[test]
fn a_held_rope_with_a_bend_radius_gives_way_to_an_instrument_within_its_cones() {
    use tractrix::collision::{Obstacle, push_by_obstacle};
    // A U: 15 units along x, a half circle of radius 2.5, 15 back.
    let mut pts: Vec<Vector3<f64>> = (0..=15).map(|k| Vector3::new(k as f64, 0.0, 0.0)).collect();
    let arc = std::f64::consts::PI * 2.5;
    let steps = arc.round() as usize;
    for s in 1..steps {
        let a = std::f64::consts::PI * s as f64 / steps as f64;
        pts.push(Vector3::new(15.0 + 2.5 * a.sin(), 2.5 - 2.5 * a.cos(), 0.0));
    }
    pts.extend((0..=15).rev().map(|k| Vector3::new(k as f64, 5.0, 0.0)));
    let mut c = Chain::<f64, 3>::from_points(&pts).unwrap();
    let n = c.n_links();
    let lim = JointLimits::bend_radius(c.lengths(), 1.5).unwrap();
    c.set_limits(Some(lim.clone())).unwrap();
    let cones: Vec<f64> = (1..n).map(|j| lim.hi(j)).collect();
    assert!(
        turns3(&c).iter().zip(&cones).all(|(t, h)| t <= h),
        "the U is within its cones"
    );
    c.hold(0).unwrap();
    c.hold(n).unwrap();
    let held = [c.joint(0), c.joint(n)];
    let r = 0.3;
    let mut model = CollisionModel {
        options: CollisionOptions {
            thickness: 0.2,
            ..CollisionOptions::default()
        },
        obstacles: vec![Obstacle::Sphere {
            center: Vector3::new(8.2, -1.0, 0.0),
            radius: r,
        }],
        holding: Vec::new(),
    };
    let mut ws = CollisionWorkspace::new();
    let (mut made, mut refused) = (0, 0);
    for k in 1..=20 {
        // Into the lower strand and on, up to y = 2 (the strand pushed about 1.4 toward the other).
        let to = Obstacle::Sphere {
            center: Vector3::new(8.2, -1.0 + 0.15 * k as f64, 0.0),
            radius: r,
        };
        let before = c.clone();
        match push_by_obstacle(&mut c, &model, 0, &to, 1000, &mut ws) {
            Ok(_) => {
                made += 1;
                model.obstacles[0] = to;
                for (t, h) in turns3(&c).into_iter().zip(&cones) {
                    assert!(t <= h + 2e-6, "push {k}: a turn of {t} > {h}");
                }
                assert!(length_error(&c) < 1e-12);
                assert_eq!([c.joint(0), c.joint(n)], held, "push {k}");
            }
            Err(_) => {
                refused += 1;
                assert_eq!(c, before, "push {k}");
            }
        }
    }
    eprintln!("held U with a bend radius under a sphere: {made} made, {refused} refused");
    assert!(made >= 19, "{made} made, {refused} refused");
}
