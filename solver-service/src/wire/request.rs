//! The typed request path: [`decode`] turns a wire request into a [`Command`] (every field checked, every
//! wire enum through `TryFrom`, every default resolved against the chain's [`ChainSpec`]) or a
//! [`Refusal`]; [`World::apply`](world::World::apply) turns a `Command` into an
//! [`Answer`] or a `Refusal`; [`encode`] is the one place that turns either into a response header.
//! Kernel errors become refusals by `From`.
//!
//! No I/O and no allocation on a refused request: a refusal's reason is formatted into a fixed buffer.

use shared::{
    FLAG_ANGLES, FLAG_DRIVE, FLAG_IN_BALL, FLAG_IN_BOX, FLAG_ORIENT, FLAG_POSE, FLAG_PULL,
    FLAG_SMOOTH, FLAG_TAKE_OVER, JOINT_HEAD, MAX_PATH_POINTS, Precision, RequestHeader,
    ResponseHeader, Status, SubstepMode, Vec3, WireMethod, WireStrategy,
};
use tractrix::{Method, MoveOptions, ReachOptions, Strategy, Substeps};
use world::scene::{ChainKind, ChainSpec};

/// Highest `max_iterations` a reach request may ask for.
pub const MAX_REACH_ITERATIONS: u32 = 100_000;

use crate::wire::header::{Checked, check_header};
use world::command::{Answer, Command, Goal, NeedleMove, Point, Residual};
use world::refusal::Refusal;
use world::refuse;

/// The kernel method a wire method asks for (`None`: the chain's default).
pub fn method_from_wire(m: WireMethod) -> Option<Method> {
    match m {
        WireMethod::Default => None,
        WireMethod::Tractrix => Some(Method::Tractrix),
        WireMethod::Paper => Some(Method::TractrixPaper),
        WireMethod::FollowTheLeader => Some(Method::FollowTheLeader),
    }
}

/// The wire number of a kernel method.
pub fn method_to_wire(m: Method) -> WireMethod {
    match m {
        Method::Tractrix => WireMethod::Tractrix,
        Method::TractrixPaper => WireMethod::Paper,
        Method::FollowTheLeader => WireMethod::FollowTheLeader,
    }
}

/// The kernel strategy a wire strategy asks for (`None`: the chain's default).
pub fn strategy_from_wire(s: WireStrategy) -> Option<Strategy> {
    match s {
        WireStrategy::Default => None,
        WireStrategy::TranslateBack => Some(Strategy::TranslateBack),
        WireStrategy::TractrixTwoLink => Some(Strategy::TractrixTwoLink),
        WireStrategy::PullBack => Some(Strategy::PullBack),
    }
}

/// Refuses (`held`) a request that would release or move an anchor of the scene: anchors are the
/// scene's (a suture's end in tissue), for every client.
fn anchored(spec: &ChainSpec, joint: usize, what: &str) -> Result<(), Refusal> {
    if spec.anchors.contains(&(joint as u32)) {
        return Err(refuse!(
            Held,
            "joint {joint} of {:?} is an anchor of the scene, never {what}",
            spec.name
        ));
    }
    Ok(())
}

/// Checks a request against the scene's chains and resolves its defaults. Nothing is changed.
pub fn decode<'a>(
    h: &RequestHeader,
    points: &'a [Vec3],
    chains: &[ChainSpec],
) -> Result<Command<'a>, Refusal> {
    // The wire's points are the world's, borrowed as they lie (the same three f64s).
    let points: &'a [Point] = bytemuck::cast_slice(points);
    let Checked {
        command,
        method,
        precision,
        substep_mode,
        strategy,
    } = check_header(
        h,
        FLAG_ANGLES
            | FLAG_TAKE_OVER
            | FLAG_ORIENT
            | FLAG_IN_BOX
            | FLAG_IN_BALL
            | FLAG_SMOOTH
            | FLAG_PULL
            | FLAG_DRIVE
            | FLAG_POSE,
    )?;
    if h.flags & FLAG_PULL != 0
        && !matches!(command, shared::Command::Move | shared::Command::Instrument)
    {
        return Err(refuse!(
            BadOption,
            "flag pull (128) is for move and instrument, not {}",
            command.name()
        ));
    }
    let pose = h.flags & FLAG_POSE != 0;
    if pose && command != shared::Command::Move {
        return Err(refuse!(
            BadOption,
            "flag pose (2) is for a move, not {}",
            command.name()
        ));
    }
    if pose && h.flags & (FLAG_DRIVE | FLAG_PULL) != 0 {
        return Err(refuse!(
            BadOption,
            "flag pose (2) sets the needle's pose: not with drive (256) or pull (128)"
        ));
    }
    if h.flags & FLAG_SMOOTH != 0 && command != shared::Command::Path {
        return Err(refuse!(
            BadOption,
            "flag smooth (64) is for path, not {}",
            command.name()
        ));
    }
    let goal_flags = h.flags & (FLAG_ORIENT | FLAG_IN_BOX | FLAG_IN_BALL);
    if goal_flags != 0 && command != shared::Command::Reach {
        return Err(refuse!(
            BadOption,
            "flags orient (8), in-box (16) and in-ball (32) are for reach, not {}",
            command.name()
        ));
    }
    if goal_flags.count_ones() > 1 {
        return Err(refuse!(
            BadOption,
            "one goal at a time: flags orient (8), in-box (16) and in-ball (32) are exclusive"
        ));
    }
    let take_over = h.flags & FLAG_TAKE_OVER != 0;
    if take_over
        && !matches!(
            command,
            shared::Command::Grasp
                | shared::Command::Release
                | shared::Command::Move
                | shared::Command::Path
                | shared::Command::Reset
        )
    {
        return Err(refuse!(
            BadOption,
            "flag take-over (4) is for grasp, release, move, path and reset, not {}",
            command.name()
        ));
    }
    let expected = match command {
        shared::Command::Reach if goal_flags != 0 => 2..=2,
        shared::Command::Move if pose => 2..=2,
        shared::Command::Move | shared::Command::Reach => 1..=1,
        shared::Command::Path => 1..=MAX_PATH_POINTS as usize,
        shared::Command::Instrument => 1..=2,
        shared::Command::Eyelet => 1..=1,
        _ => 0..=0,
    };
    if !expected.contains(&points.len()) {
        return Err(refuse!(
            BadPointCount,
            "{} takes {}..={} points, got {}",
            command.name(),
            expected.start(),
            expected.end(),
            points.len()
        ));
    }
    if command == shared::Command::Snapshot {
        return Ok(Command::Snapshot);
    }
    let chain = h.chain;
    let spec = chains.get(chain as usize).ok_or_else(|| {
        refuse!(
            UnknownChain,
            "chain {chain} (the scene has 0..{})",
            chains.len()
        )
    })?;
    if precision != Precision::Default && precision != crate::wire::precision(spec.precision) {
        return Err(refuse!(
            BadOption,
            "chain {:?} is stored in {}",
            spec.name,
            if spec.precision == world::scene::Precision::F32 {
                "f32"
            } else {
                "f64"
            }
        ));
    }
    check_points(points, spec)?;
    let at = At {
        h,
        spec,
        method: method_from_wire(method),
        take_over,
    };
    match command {
        shared::Command::Instrument => instrument(&at, points),
        shared::Command::Grasp | shared::Command::Release => grasp(&at, command),
        shared::Command::Move | shared::Command::Path => move_or_path(&at, points, substep_mode),
        shared::Command::Reach => reach(&at, points, substep_mode, strategy),
        shared::Command::Query => Ok(Command::Query {
            chain: h.chain,
            angles: h.flags & FLAG_ANGLES != 0,
        }),
        shared::Command::Describe => Ok(Command::Describe { chain: h.chain }),
        shared::Command::Reset => Ok(Command::Reset {
            chain: h.chain,
            take_over,
        }),
        shared::Command::Snapshot => Ok(Command::Snapshot),
        shared::Command::Eyelet => Ok(Command::Eyelet {
            chain: h.chain,
            index: h.joint as usize,
            at: points[0],
            max_substeps: spec.moves.max_substeps,
        }),
    }
}

/// Every point finite, within the chain's coordinate range (free chains) and in its plane (planar).
fn check_points(points: &[Point], spec: &ChainSpec) -> Result<(), Refusal> {
    for (i, p) in points.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(refuse!(NonFinite, "point {i} is not finite"));
        }
        let far = p.x.abs().max(p.y.abs()).max(p.z.abs());
        if spec.kind == ChainKind::Free && far > spec.max_coordinate {
            return Err(refuse!(
                TooFar,
                "point {i}: {far:.3e} is beyond {:.3e}: too far to keep link lengths",
                spec.max_coordinate
            ));
        }
        if spec.dims == 2 && p.z != 0.0 {
            return Err(refuse!(
                OffPlane,
                "point {i}: chain {:?} is planar, z must be 0",
                spec.name
            ));
        }
    }
    Ok(())
}

/// What every command's decoding needs: the request, its chain, the method it asks for and whether it
/// takes grasps over.
struct At<'h> {
    h: &'h RequestHeader,
    spec: &'h ChainSpec,
    method: Option<Method>,
    take_over: bool,
}

impl At<'_> {
    /// The joint the request names, resolved (the head is `n_links`).
    fn joint(&self) -> Result<usize, Refusal> {
        let n_links = self.spec.lengths.len();
        if self.h.joint == JOINT_HEAD {
            Ok(n_links)
        } else if self.h.joint as usize <= n_links {
            Ok(self.h.joint as usize)
        } else {
            Err(refuse!(
                JointOutOfRange,
                "joint {} (the chain has 0..={n_links})",
                self.h.joint
            ))
        }
    }
}

/// An instrument's new pose: its centre, and a capsule's axis.
fn instrument<'a>(at: &At<'_>, points: &'a [Point]) -> Result<Command<'a>, Refusal> {
    let At { h, spec, .. } = *at;
    let chain = h.chain;
    let list = spec
        .collision
        .as_ref()
        .map_or(&[][..], |c| c.instruments.as_slice());
    let Some((name, shape)) = list.get(h.joint as usize) else {
        return Err(refuse!(
            BadOption,
            "instrument {} (chain {:?} has {} instruments)",
            h.joint,
            spec.name,
            list.len()
        ));
    };
    let capsule = matches!(shape, tractrix::collision::Obstacle::Capsule { .. });
    let want = if capsule { 2 } else { 1 };
    if points.len() != want {
        return Err(refuse!(
            BadPointCount,
            "instrument {name:?} is a {}: {want} point{} ({}), got {}",
            if capsule { "capsule" } else { "sphere" },
            if want == 1 { "" } else { "s" },
            if capsule { "centre, axis" } else { "centre" },
            points.len()
        ));
    }
    let axis = capsule.then(|| points[1]);
    if let Some(a) = axis {
        let n = (a.x * a.x + a.y * a.y + a.z * a.z).sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return Err(refuse!(
                BadOption,
                "instrument {name:?}: the axis must be a non-zero vector"
            ));
        }
    }
    Ok(Command::Instrument {
        chain,
        index: h.joint as usize,
        centre: points[0],
        axis,
        max_substeps: spec.moves.max_substeps,
        pull: h.flags & FLAG_PULL != 0,
    })
}

/// A grasp or a release of one joint of a free chain (an anchor is never released).
fn grasp(at: &At<'_>, command: shared::Command) -> Result<Command<'static>, Refusal> {
    let At {
        h, spec, take_over, ..
    } = *at;
    let chain = h.chain;
    if spec.kind == ChainKind::FixedBase {
        return Err(refuse!(
            WrongChainKind,
            "chain {:?} has a fixed base: grasps are for free chains",
            spec.name
        ));
    }
    let joint = at.joint()?;
    if command == shared::Command::Release {
        anchored(spec, joint, "released")?;
    }
    Ok(if command == shared::Command::Grasp {
        Command::Grasp {
            chain,
            joint,
            take_over,
        }
    } else {
        Command::Release {
            chain,
            joint,
            take_over,
        }
    })
}

/// A move or a path of one joint of a free chain (an anchor is never moved), its substeps resolved.
fn move_or_path<'a>(
    at: &At<'_>,
    points: &'a [Point],
    substep_mode: SubstepMode,
) -> Result<Command<'a>, Refusal> {
    let At {
        h,
        spec,
        method,
        take_over,
    } = *at;
    let chain = h.chain;
    if spec.kind == ChainKind::FixedBase {
        return Err(refuse!(
            WrongChainKind,
            "chain {:?} has a fixed base: use reach",
            spec.name
        ));
    }
    let joint = at.joint()?;
    anchored(spec, joint, "moved")?;
    let substeps = match substep_mode {
        SubstepMode::Default => spec.moves.substeps,
        SubstepMode::Fixed if h.substeps == 0 => {
            return Err(refuse!(BadOption, "substeps must be at least 1"));
        }
        SubstepMode::Fixed => Substeps::Fixed(h.substeps),
        SubstepMode::MaxStep if h.max_step <= 0.0 => {
            return Err(refuse!(
                BadOption,
                "max_step {:e} must be positive",
                h.max_step
            ));
        }
        SubstepMode::MaxStep => Substeps::MaxStep(h.max_step),
    };
    // The needle's flags: a move of the head of a chain with a needle (a pose's second point is
    // the needle's rotation vector, checked in range as every point is).
    let (needle, flag) = match h.flags & (FLAG_DRIVE | FLAG_POSE) {
        FLAG_DRIVE => (NeedleMove::Driven, "drive (256)"),
        FLAG_POSE => (NeedleMove::Posed(points[1]), "pose (2)"),
        _ => (NeedleMove::Carried, ""),
    };
    if needle != NeedleMove::Carried {
        if spec.needle.is_none() {
            return Err(refuse!(
                BadOption,
                "flag {flag}: chain {:?} carries no needle",
                spec.name
            ));
        }
        if h.command != shared::Command::Move as u32 || joint + 1 != spec.points.len() {
            return Err(refuse!(
                BadOption,
                "flag {flag} is for a move of the head, the needle's swage"
            ));
        }
    }
    let points = if matches!(needle, NeedleMove::Posed(_)) {
        &points[..1]
    } else {
        points
    };
    Ok(Command::Move {
        chain,
        joint,
        targets: points,
        options: MoveOptions {
            method: method.unwrap_or(spec.moves.method),
            substeps,
            ..spec.moves
        },
        take_over,
        smooth: h.flags & FLAG_SMOOTH != 0,
        pull: h.flags & FLAG_PULL != 0,
        needle,
    })
}

/// A fixed-base reach, its strategy, tolerance and iteration limit resolved.
fn reach<'a>(
    at: &At<'_>,
    points: &'a [Point],
    substep_mode: SubstepMode,
    strategy: WireStrategy,
) -> Result<Command<'a>, Refusal> {
    let At {
        h, spec, method, ..
    } = *at;
    let chain = h.chain;
    let angles = h.flags & FLAG_ANGLES != 0;
    if spec.kind != ChainKind::FixedBase {
        return Err(refuse!(
            WrongChainKind,
            "chain {:?} is free: use move",
            spec.name
        ));
    }
    if substep_mode != SubstepMode::Default {
        return Err(refuse!(
            BadOption,
            "reach takes `substeps` per pass; substep_mode must be 0"
        ));
    }
    if h.substeps > spec.moves.max_substeps {
        return Err(refuse!(
            BadOption,
            "substeps {} above the chain's limit {}",
            h.substeps,
            spec.moves.max_substeps
        ));
    }
    let tolerance = if h.tolerance == 0.0 {
        spec.reach.tolerance
    } else if !(h.tolerance > 0.0 && h.tolerance <= 0.1) {
        return Err(refuse!(
            BadOption,
            "tolerance {:e} is outside (0, 0.1]",
            h.tolerance
        ));
    } else {
        h.tolerance
    };
    let max_iterations = match h.max_iterations {
        0 => spec.reach.max_iterations,
        m if m <= MAX_REACH_ITERATIONS => m,
        m => {
            return Err(refuse!(
                BadOption,
                "max_iterations {m} is above {MAX_REACH_ITERATIONS}"
            ));
        }
    };
    Ok(Command::Reach {
        chain,
        goal: goal(h.flags, points)?,
        options: ReachOptions {
            strategy: strategy_from_wire(strategy).unwrap_or(spec.reach.strategy),
            method: method.unwrap_or(spec.reach.method),
            substeps: h.substeps.max(1),
            tolerance,
            max_iterations,
            hierarchy_after: spec.reach.hierarchy_after,
        },
        angles,
    })
}

/// A reach's goal from its flags and its points (their count checked): a point, or with
/// [`FLAG_ORIENT`] a point and a direction, [`FLAG_IN_BOX`] two corners, [`FLAG_IN_BALL`] a centre
/// and `(radius, 0, 0)`.
fn goal(flags: u32, points: &[Point]) -> Result<Goal, Refusal> {
    Ok(if flags & FLAG_ORIENT != 0 {
        if points[1].norm() == 0.0 {
            return Err(refuse!(
                BadOption,
                "orient: the direction (point 1) has zero length"
            ));
        }
        Goal::Pose {
            at: points[0],
            direction: points[1],
        }
    } else if flags & FLAG_IN_BOX != 0 {
        let (lo, hi) = (points[0], points[1]);
        if (0..3).any(|i| lo[i] > hi[i]) {
            return Err(refuse!(
                BadOption,
                "in-box: point 0 is the corner of smallest coordinates, point 1 the largest"
            ));
        }
        Goal::Box { lo, hi }
    } else if flags & FLAG_IN_BALL != 0 {
        let r = points[1];
        if !(r.x > 0.0 && r.y == 0.0 && r.z == 0.0) {
            return Err(refuse!(
                BadOption,
                "in-ball: point 1 is (radius, 0, 0) with a positive radius"
            ));
        }
        Goal::Ball {
            centre: points[0],
            radius: r.x,
        }
    } else {
        Goal::Point(points[0])
    })
}

/// The wire's code of a knot ([`shared::KNOT_UNKNOT`] and the rest).
pub fn knot_code(k: knots::KnotType) -> u32 {
    use knots::KnotType;
    match k {
        KnotType::Unknot => shared::KNOT_UNKNOT,
        KnotType::Trefoil => shared::KNOT_TREFOIL,
        KnotType::Square => shared::KNOT_SQUARE,
        KnotType::Granny => shared::KNOT_GRANNY,
        KnotType::DoubleOverhand => shared::KNOT_DOUBLE_OVERHAND,
        KnotType::Surgeons => shared::KNOT_SURGEONS,
        KnotType::Other => shared::KNOT_OTHER,
    }
}

/// The response header of a request: from its outcome or its refusal. `sequence` is the state after it;
/// `chains` is the scene's (for the description). The residual of a landing is measured by the serving
/// loop once the joints are written (`crate::serve::Handled::landing`).
pub fn encode(
    req: &RequestHeader,
    result: &Result<Answer, Refusal>,
    sequence: u64,
    chains: &[ChainSpec],
) -> ResponseHeader {
    let mut h = ResponseHeader {
        command: req.command,
        chain: req.chain,
        request_id: req.request_id,
        n_chains: chains.len() as u32,
        sequence,
        ..ResponseHeader::default()
    };
    match result {
        Ok(o) => {
            h.status = Status::Ok as u32;
            let c = &o.counts;
            h.n_joints = c.joints;
            h.n_angles = c.angles;
            h.n_held = c.held;
            h.n_instruments = c.instruments;
            h.n_pulls = c.pulls;
            h.n_eyelets = c.eyelets;
            h.n_tissue = c.tissue;
            h.knot = o.knot.map_or(shared::KNOT_NOT_ASKED, knot_code);
            h.substeps = o.substeps;
            h.paper_fallbacks = o.paper_fallbacks;
            h.iterations = o.iterations;
            if let Residual::Known(r) = o.residual {
                h.residual = r;
            }
            if let Some(stop) = o.stopped {
                h.set_reason(crate::wire::pull_stop(stop).reason());
            }
            if o.describe
                && let Some(spec) = o.chain.and_then(|c| chains.get(c as usize))
            {
                describe(spec, &mut h);
            }
        }
        Err(r) => {
            h.status = crate::wire::status(r.cause) as u32;
            h.reason = crate::wire::reason(r);
            h.residual = r.residual;
            h.iterations = r.iterations;
            h.substeps = r.substeps;
        }
    }
    h
}

/// The description fields of a chain.
fn describe(spec: &ChainSpec, h: &mut ResponseHeader) {
    h.kind = crate::wire::kind(spec.kind) as u32;
    (h.limits, h.limit_value) = match &spec.limits {
        None => (shared::LIMITS_NONE, 0.0),
        Some(l) => {
            let inner = &l.hi[1..l.hi.len().saturating_sub(1)];
            let widest = inner.iter().copied().fold(0.0f64, f64::max);
            match (l.kind, l.min_bend_radius) {
                (_, Some(r)) => (shared::LIMITS_BEND_RADIUS, r),
                (tractrix::LimitKind::Cone, None) if inner.windows(2).all(|w| w[0] == w[1]) => {
                    (shared::LIMITS_CONE, widest)
                }
                (tractrix::LimitKind::Cone, None) => (shared::LIMITS_CONES, widest),
                (tractrix::LimitKind::Range, None) => (
                    shared::LIMITS_RANGES,
                    l.hi[1..]
                        .iter()
                        .zip(&l.lo[1..])
                        .take(inner.len())
                        .map(|(h, l)| h - l)
                        .fold(0.0, f64::max),
                ),
            }
        }
    };
    h.dims = spec.dims;
    h.n_links = spec.lengths.len() as u32;
    h.precision = crate::wire::precision(spec.precision) as u32;
    h.method = method_to_wire(spec.moves.method) as u32;
    h.collision = crate::wire::collision_bits(spec);
    match spec.moves.substeps {
        Substeps::Fixed(k) => {
            h.substep_mode = SubstepMode::Fixed as u32;
            h.substeps_default = k;
            h.max_step = 0.0;
        }
        Substeps::MaxStep(s) => {
            h.substep_mode = SubstepMode::MaxStep as u32;
            h.substeps_default = 0;
            h.max_step = s;
        }
    }
    h.total_length = spec.total_length;
    h.thickness = spec.thickness;
    h.set_name(&spec.name);
}
