//! The chains of a running scene and the request handler over them.
//!
//! A [`ChainSet`] holds one flat [`Chain`] per scene chain, addressed by its index (the wire's chain
//! handle), in exactly the form the scene declared: planar or spatial, f64 or f32. [`ChainSet::apply`]
//! validates a wire request field by field, runs the kernel, and fills the response header; on any error
//! the state is unchanged and the header says what was wrong. [`ChainSet::elements`] then streams the
//! joints (and joint rotations) straight into the caller's buffer: the service writes them into the loaned
//! shared-memory response, batch mode into its output.
//!
//! No I/O and no clock here: the service measures time and does the persistence around it.

use crate::kernel::angles::rotation_between;
use crate::kernel::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Obstacle, move_joint_colliding,
};
use crate::kernel::math::{CompensatedSum, Embed3, Real, Vector, all_finite};
use crate::kernel::{
    Chain, ChainError, Method, MoveOptions, MoveOutcome, ReachError, ReachOptions, ReachWorkspace,
    Strategy, Substeps, reach,
};
use crate::scene::{ChainDef, ObstacleDef, Scene};
use nalgebra::Vector3;
use protocol::{
    ChainKind, Command, FLAG_ANGLES, JOINT_HEAD, MAX_PATH_POINTS, Precision, REASON_LEN,
    RequestHeader, ResponseHeader, Status, SubstepMode, Vec3, WireMethod, WireStrategy,
};
use std::fmt::Write as _;

/// A chain in the precision and dimension its scene declared, with its scene state (for reset) and the
/// reach workspace (allocated once).
#[derive(Debug, Clone)]
pub struct Held<T: Real, const D: usize> {
    pub chain: Chain<T, D>,
    pub initial: Chain<T, D>,
    /// The state before the request being applied (for a rollback).
    spare: Chain<T, D>,
    ws: ReachWorkspace<T, D>,
    /// Collision model and buffers, only for chains whose scene declares collision.
    collision: Option<(CollisionModel<T, D>, CollisionWorkspace<T, D>)>,
}

/// One of the four chain forms.
#[derive(Debug, Clone)]
pub enum Geometry {
    Planar64(Held<f64, 2>),
    Spatial64(Held<f64, 3>),
    Planar32(Held<f32, 2>),
    Spatial32(Held<f32, 3>),
}

/// Runs `$body` with `$h` bound to the [`Held`] of whichever form `$g` is.
macro_rules! each_form {
    ($g:expr, $h:ident => $body:expr) => {
        match $g {
            $crate::chain_set::Geometry::Planar64($h) => $body,
            $crate::chain_set::Geometry::Spatial64($h) => $body,
            $crate::chain_set::Geometry::Planar32($h) => $body,
            $crate::chain_set::Geometry::Spatial32($h) => $body,
        }
    };
}
pub(crate) use each_form;

/// A scene chain: its definition and its state.
#[derive(Debug, Clone)]
pub struct Entry {
    pub def: ChainDef,
    pub geometry: Geometry,
    /// Largest coordinate a target of this (free) chain may have: [`protocol::max_coordinate`].
    pub max_coordinate: f64,
}

/// Every chain of a scene plus the state sequence number.
#[derive(Debug, Clone)]
pub struct ChainSet {
    entries: Vec<Entry>,
    sequence: u64,
}

fn held<T: Real, const D: usize>(def: &ChainDef) -> Result<Held<T, D>, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let p: Vec<Vector<T, D>> = def.points.iter().map(|q| from_array(*q)).collect();
    let links: Vec<_> = p.windows(2).map(|w| w[1] - w[0]).collect();
    let lengths: Vec<T> = def.lengths.iter().map(|&l| T::lit(l)).collect();
    let chain = Chain::from_parts(p[0], links, lengths)?;
    let collision = def.collision_spec.as_ref().map(|spec| {
        let v = |q: &[f64; 3]| from_array::<T, D>(*q);
        let obstacles = spec
            .obstacles
            .iter()
            .map(|o| match o {
                ObstacleDef::Sphere { center, radius } => Obstacle::Sphere {
                    center: v(center),
                    radius: T::lit(*radius),
                },
                ObstacleDef::Capsule { a, b, radius } => Obstacle::Capsule {
                    a: v(a),
                    b: v(b),
                    radius: T::lit(*radius),
                },
                ObstacleDef::Plane { point, normal } => Obstacle::HalfSpace {
                    point: v(point),
                    normal: v(normal),
                },
            })
            .collect();
        let model = CollisionModel {
            options: CollisionOptions {
                scheme: spec.scheme,
                self_collision: spec.self_collision,
                thickness: T::lit(def.thickness),
                max_iterations: spec.iterations,
                tolerance: T::lit(spec.tolerance),
            },
            obstacles,
        };
        (model, CollisionWorkspace::new())
    });
    Ok(Held {
        initial: chain.clone(),
        spare: chain.clone(),
        chain,
        ws: ReachWorkspace::default(),
        collision,
    })
}

fn from_array<T: Real, const D: usize>(q: [f64; 3]) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    Embed3::from_3d(&Vector3::new(T::lit(q[0]), T::lit(q[1]), T::lit(q[2])))
}

fn to_wire<T: Real, const D: usize>(v: &Vector<T, D>) -> Vec3
where
    Vector<T, D>: Embed3<T>,
{
    let v = v.to_3d();
    Vec3::new(v.x.to_f64(), v.y.to_f64(), v.z.to_f64())
}

impl ChainSet {
    /// Builds the chains a scene declares (and nothing else).
    pub fn new(scene: &Scene) -> Result<Self, String> {
        let mut entries = Vec::with_capacity(scene.chains.len());
        for def in &scene.chains {
            let g = match (def.dims, def.precision) {
                (2, Precision::F32) => held(def).map(Geometry::Planar32),
                (2, _) => held(def).map(Geometry::Planar64),
                (_, Precision::F32) => held(def).map(Geometry::Spatial32),
                _ => held(def).map(Geometry::Spatial64),
            }
            .map_err(|e| format!("chain {:?}: {e}", def.name))?;
            let shortest = def.lengths.iter().copied().fold(f64::INFINITY, f64::min);
            entries.push(Entry {
                def: def.clone(),
                geometry: g,
                max_coordinate: protocol::max_coordinate(shortest, def.precision == Precision::F32),
            });
        }
        Ok(ChainSet {
            entries,
            sequence: 0,
        })
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }
    pub(crate) fn entries_mut(&mut self) -> &mut [Entry] {
        &mut self.entries
    }
    /// The sequence number of the last accepted change (0 before any).
    pub fn sequence(&self) -> u64 {
        self.sequence
    }
    pub(crate) fn set_sequence(&mut self, s: u64) {
        self.sequence = s;
    }
    /// The handle of a chain by name.
    pub fn find(&self, name: &str) -> Option<u32> {
        self.entries
            .iter()
            .position(|e| e.def.name == name)
            .map(|i| i as u32)
    }
    /// Remembers `chain`'s state (and the sequence) so that [`ChainSet::rollback`] can undo the next
    /// request. `None` for an unknown chain. Copies into a kept buffer: no allocation.
    pub fn backup(&mut self, chain: u32) -> Option<u64> {
        let e = self.entries.get_mut(chain as usize)?;
        each_form!(&mut e.geometry, g => g.spare.copy_from(&g.chain));
        Some(self.sequence)
    }

    /// Undoes everything since [`ChainSet::backup`] returned `backup`.
    pub fn rollback(&mut self, chain: u32, backup: Option<u64>) {
        if let (Some(seq), Some(e)) = (backup, self.entries.get_mut(chain as usize)) {
            each_form!(&mut e.geometry, g => std::mem::swap(&mut g.chain, &mut g.spare));
            self.sequence = seq;
        }
    }

    /// Joints of a chain (`n_links + 1`).
    pub fn n_joints(&self, chain: u32) -> usize {
        self.entries[chain as usize].def.lengths.len() + 1
    }

    /// Fills the chain-description fields of a response header.
    pub fn describe_into(&self, chain: u32, h: &mut ResponseHeader) {
        let e = &self.entries[chain as usize];
        let d = &e.def;
        h.kind = d.kind as u32;
        h.dims = d.dims;
        h.n_links = d.lengths.len() as u32;
        h.precision = d.precision as u32;
        h.method = match d.method {
            Method::Tractrix => WireMethod::Tractrix,
            Method::TractrixPaper => WireMethod::Paper,
            Method::FollowTheLeader => WireMethod::FollowTheLeader,
        } as u32;
        h.collision = d.collision;
        match d.substeps {
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
        h.total_length = d.lengths.iter().sum();
        h.thickness = d.thickness;
        h.set_name(&d.name);
    }

    /// Validates and applies one request, filling `h` (everything but `solve_ns`). Returns whether the
    /// state changed; on any error status nothing changed. [`Command::Snapshot`] is the caller's business:
    /// here it only passes validation.
    pub fn apply(&mut self, req: &RequestHeader, points: &[Vec3], h: &mut ResponseHeader) -> bool {
        *h = ResponseHeader {
            command: req.command,
            chain: req.chain,
            request_id: req.request_id,
            n_chains: self.entries.len() as u32,
            sequence: self.sequence,
            ..ResponseHeader::default()
        };
        match self.try_apply(req, points, h) {
            Ok(changed) => {
                h.status = Status::Ok as u32;
                if changed {
                    self.sequence += 1;
                    h.sequence = self.sequence;
                }
                changed
            }
            Err((status, reason)) => {
                h.status = status as u32;
                h.n_joints = 0;
                h.n_angles = 0;
                reason.write_to(h);
                false
            }
        }
    }

    // The error carries its reason formatted in place (no allocation on a refused request); 136 bytes
    // on the stack cost less than a box.
    #[allow(clippy::result_large_err)]
    fn try_apply(
        &mut self,
        req: &RequestHeader,
        points: &[Vec3],
        h: &mut ResponseHeader,
    ) -> Result<bool, (Status, Reason)> {
        let command = Command::from_u32(req.command).ok_or_else(|| {
            fail(
                Status::UnknownCommand,
                format_args!("command {} is not one of 1..=7", req.command),
            )
        })?;
        if req.reserved != [0, 0] {
            return Err(fail(
                Status::BadOption,
                format_args!("reserved fields must be zero"),
            ));
        }
        if req.flags & !FLAG_ANGLES != 0 {
            return Err(fail(
                Status::BadOption,
                format_args!("unknown flag bits {:#x}", req.flags & !FLAG_ANGLES),
            ));
        }
        let method = WireMethod::from_u32(req.method).ok_or_else(|| {
            fail(
                Status::BadOption,
                format_args!("method {} is not one of 0..=3", req.method),
            )
        })?;
        let precision = Precision::from_u32(req.precision).ok_or_else(|| {
            fail(
                Status::BadOption,
                format_args!("precision {} is not one of 0..=2", req.precision),
            )
        })?;
        let substep_mode = SubstepMode::from_u32(req.substep_mode).ok_or_else(|| {
            fail(
                Status::BadOption,
                format_args!("substep_mode {} is not one of 0..=2", req.substep_mode),
            )
        })?;
        let strategy = WireStrategy::from_u32(req.strategy).ok_or_else(|| {
            fail(
                Status::BadOption,
                format_args!("strategy {} is not one of 0..=2", req.strategy),
            )
        })?;
        let expected_points = match command {
            Command::Move | Command::Reach => 1..=1,
            Command::Path => 1..=MAX_PATH_POINTS as usize,
            _ => 0..=0,
        };
        if !expected_points.contains(&points.len()) {
            return Err(fail(
                Status::BadPointCount,
                format_args!(
                    "{} takes {}..={} points, got {}",
                    command.name(),
                    expected_points.start(),
                    expected_points.end(),
                    points.len()
                ),
            ));
        }
        if command == Command::Snapshot {
            return Ok(false);
        }
        let n_chains = self.entries.len();
        if req.chain as usize >= n_chains {
            return Err(fail(
                Status::UnknownChain,
                format_args!("chain {} (the scene has 0..{n_chains})", req.chain),
            ));
        }
        self.describe_into(req.chain, h);
        let entry = &mut self.entries[req.chain as usize];
        let def = &entry.def;
        if precision != Precision::Default && precision != def.precision {
            return Err(fail(
                Status::BadOption,
                format_args!(
                    "chain {:?} is stored in {}",
                    def.name,
                    if def.precision == Precision::F32 {
                        "f32"
                    } else {
                        "f64"
                    }
                ),
            ));
        }
        for (i, p) in points.iter().enumerate() {
            if !p.is_finite() {
                return Err(fail(
                    Status::NonFinite,
                    format_args!("point {i} is not finite"),
                ));
            }
            let far = p.x.abs().max(p.y.abs()).max(p.z.abs());
            if def.kind == ChainKind::Free && far > entry.max_coordinate {
                return Err(fail(
                    Status::TooFar,
                    format_args!(
                        "point {i}: {far:.3e} is beyond {:.3e}: too far to keep link lengths",
                        entry.max_coordinate
                    ),
                ));
            }
            if def.dims == 2 && p.z != 0.0 {
                return Err(fail(
                    Status::OffPlane,
                    format_args!("point {i}: chain {:?} is planar, z must be 0", def.name),
                ));
            }
        }
        let n_links = def.lengths.len();
        let with_angles = req.flags & FLAG_ANGLES != 0;
        let method = match method {
            WireMethod::Default => def.method,
            WireMethod::Tractrix => Method::Tractrix,
            WireMethod::Paper => Method::TractrixPaper,
            WireMethod::FollowTheLeader => Method::FollowTheLeader,
        };
        let changed = match command {
            Command::Move | Command::Path => {
                if def.kind == ChainKind::FixedBase {
                    return Err(fail(
                        Status::WrongChainKind,
                        format_args!("chain {:?} has a fixed base: use reach", def.name),
                    ));
                }
                let joint = if req.joint == JOINT_HEAD {
                    n_links
                } else if req.joint as usize <= n_links {
                    req.joint as usize
                } else {
                    return Err(fail(
                        Status::JointOutOfRange,
                        format_args!("joint {} (the chain has 0..={n_links})", req.joint),
                    ));
                };
                let substeps = match substep_mode {
                    SubstepMode::Default => def.substeps,
                    SubstepMode::Fixed if req.substeps == 0 => {
                        return Err(fail(
                            Status::BadOption,
                            format_args!("substeps must be at least 1"),
                        ));
                    }
                    SubstepMode::Fixed => Substeps::Fixed(req.substeps),
                    SubstepMode::MaxStep if !req.max_step.is_finite() => {
                        return Err(fail(
                            Status::NonFinite,
                            format_args!("max_step is not finite"),
                        ));
                    }
                    SubstepMode::MaxStep if req.max_step <= 0.0 => {
                        return Err(fail(
                            Status::BadOption,
                            format_args!("max_step {} must be positive", req.max_step),
                        ));
                    }
                    SubstepMode::MaxStep => Substeps::MaxStep(req.max_step),
                };
                let opts = MoveOptions {
                    method,
                    substeps,
                    max_substeps: def.max_substeps,
                };
                let r =
                    each_form!(&mut entry.geometry, g => move_generic(g, joint, points, &opts, h));
                r.map_err(|e| chain_error(e, def))?;
                true
            }
            Command::Reach => {
                if def.kind != ChainKind::FixedBase {
                    return Err(fail(
                        Status::WrongChainKind,
                        format_args!("chain {:?} is free: use move", def.name),
                    ));
                }
                if substep_mode != SubstepMode::Default {
                    return Err(fail(
                        Status::BadOption,
                        format_args!("reach takes `substeps` per pass; substep_mode must be 0"),
                    ));
                }
                if req.substeps > def.max_substeps {
                    return Err(fail(
                        Status::BadOption,
                        format_args!(
                            "substeps {} above the chain's limit {}",
                            req.substeps, def.max_substeps
                        ),
                    ));
                }
                let tolerance = if req.tolerance == 0.0 {
                    def.tolerance
                } else if !req.tolerance.is_finite() {
                    return Err(fail(
                        Status::NonFinite,
                        format_args!("tolerance is not finite"),
                    ));
                } else if !(req.tolerance > 0.0 && req.tolerance <= 0.1) {
                    return Err(fail(
                        Status::BadOption,
                        format_args!("tolerance {} is outside (0, 0.1]", req.tolerance),
                    ));
                } else {
                    req.tolerance
                };
                let max_iterations = match req.max_iterations {
                    0 => def.max_iterations,
                    m if m <= 100_000 => m,
                    m => {
                        return Err(fail(
                            Status::BadOption,
                            format_args!("max_iterations {m} is above 100000"),
                        ));
                    }
                };
                let strategy = match strategy {
                    WireStrategy::Default => def.strategy,
                    WireStrategy::TranslateBack => Strategy::TranslateBack,
                    WireStrategy::TractrixTwoLink => Strategy::TractrixTwoLink,
                };
                let opts = ReachOptions::<f64> {
                    strategy,
                    method,
                    substeps: req.substeps.max(1),
                    tolerance,
                    max_iterations,
                    ..ReachOptions::default()
                };
                each_form!(&mut entry.geometry, g => reach_generic(g, &points[0], &opts, def, h))?;
                true
            }
            Command::Query | Command::Describe => false,
            Command::Reset => {
                each_form!(&mut entry.geometry, g => g.chain = g.initial.clone());
                true
            }
            Command::Snapshot => false,
        };
        h.n_joints = (n_links + 1) as u32;
        h.n_angles = if with_angles { n_links as u32 } else { 0 };
        Ok(changed)
    }

    /// The response payload of a chain: its joints (tail first), then, with `angles`, one rotation vector
    /// per joint (joint 0: from +x to link 1; joint i: from link i to link i+1). Written in order, with no
    /// intermediate buffer.
    /// An unknown chain yields nothing (an error response has no elements).
    pub fn elements(&self, chain: u32, angles: bool) -> Elements<'_> {
        let Some(e) = self.entries.get(chain as usize) else {
            return Elements::Empty;
        };
        match &e.geometry {
            Geometry::Planar64(h) => Elements::Planar64(ChainElements::new(&h.chain, angles)),
            Geometry::Spatial64(h) => Elements::Spatial64(ChainElements::new(&h.chain, angles)),
            Geometry::Planar32(h) => Elements::Planar32(ChainElements::new(&h.chain, angles)),
            Geometry::Spatial32(h) => Elements::Spatial32(ChainElements::new(&h.chain, angles)),
        }
    }
}

/// An error's short reason, formatted into a fixed buffer (no allocation on the request path).
#[derive(Debug, Clone)]
pub struct Reason {
    buf: [u8; REASON_LEN],
    len: usize,
}

impl Reason {
    fn write_to(&self, h: &mut ResponseHeader) {
        h.reason = self.buf;
    }
}

impl std::fmt::Write for Reason {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        for ch in s.chars() {
            let mut b = [0u8; 4];
            let e = ch.encode_utf8(&mut b).as_bytes();
            if self.len + e.len() >= REASON_LEN {
                return Ok(());
            }
            self.buf[self.len..self.len + e.len()].copy_from_slice(e);
            self.len += e.len();
        }
        Ok(())
    }
}

fn fail(status: Status, args: std::fmt::Arguments<'_>) -> (Status, Reason) {
    let mut r = Reason {
        buf: [0; REASON_LEN],
        len: 0,
    };
    let _ = r.write_fmt(args);
    (status, r)
}

fn chain_error(e: ChainError, def: &ChainDef) -> (Status, Reason) {
    match e {
        ChainError::NonFinite => fail(
            Status::NonFinite,
            format_args!(
                "target does not fit the chain's {}",
                if def.precision == Precision::F32 {
                    "f32"
                } else {
                    "f64"
                }
            ),
        ),
        ChainError::JointOutOfRange { joint, last } => fail(
            Status::JointOutOfRange,
            format_args!("joint {joint} (the chain has 0..={last})"),
        ),
        ChainError::TooManySubsteps { required, limit } => fail(
            Status::TooManySubsteps,
            format_args!("the move needs {required} substeps; the chain allows {limit}"),
        ),
        ChainError::BadOption(s) => fail(Status::BadOption, format_args!("{s}")),
        ChainError::Locked {
            substep,
            iterations,
            penetration,
        } => fail(
            Status::Locked,
            format_args!(
                "links still {penetration:.2e} too close after {iterations} passes at substep {substep}"
            ),
        ),
        e @ (ChainError::Empty | ChainError::BadLength { .. }) => {
            fail(Status::Internal, format_args!("{e}"))
        }
    }
}

fn move_generic<T: Real, const D: usize>(
    g: &mut Held<T, D>,
    joint: usize,
    points: &[Vec3],
    opts: &MoveOptions<f64>,
    h: &mut ResponseHeader,
) -> Result<(), ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let substeps = match opts.substeps {
        Substeps::Fixed(k) => Substeps::Fixed(k),
        Substeps::MaxStep(s) => Substeps::MaxStep(T::lit(s)),
    };
    let opts = MoveOptions {
        method: opts.method,
        substeps,
        max_substeps: opts.max_substeps,
    };
    let last: Vector<T, D> = from_array(points[points.len() - 1].to_array());
    let outcome = if let Some((model, ws)) = &mut g.collision {
        // Each target is a straight move with collision. A failed move leaves the chain as it was
        // before that move, so a path that fails after its first point is undone here from the
        // spare copy (the whole request changes nothing).
        let mut total = MoveOutcome::default();
        if points.len() > 1 {
            g.spare.copy_from(&g.chain);
        }
        for p in points {
            let t: Vector<T, D> = from_array(p.to_array());
            let o = match move_joint_colliding(&mut g.chain, joint, t, &opts, model, ws) {
                Ok(o) => o,
                Err(e) => {
                    if points.len() > 1 {
                        std::mem::swap(&mut g.chain, &mut g.spare);
                    }
                    return Err(e);
                }
            };
            total.substeps = total.substeps.saturating_add(o.substeps);
            total.paper_fallbacks = total.paper_fallbacks.saturating_add(o.paper_fallbacks);
            total.collision_iterations = total
                .collision_iterations
                .saturating_add(o.collision_iterations);
            total.contacts = total.contacts.saturating_add(o.contacts);
        }
        total
    } else if points.len() == 1 {
        if !all_finite(&last) {
            return Err(ChainError::NonFinite);
        }
        g.chain.move_joint(joint, last, &opts)?
    } else {
        // Converting a path needs a buffer; paths are bounded by MAX_PATH_POINTS.
        let targets: Vec<Vector<T, D>> = points.iter().map(|p| from_array(p.to_array())).collect();
        g.chain.move_along(joint, &targets, &opts)?
    };
    h.substeps = outcome.substeps;
    h.paper_fallbacks = outcome.paper_fallbacks;
    h.iterations = outcome.collision_iterations;
    h.residual = (g.chain.joint(joint) - last).norm().to_f64();
    Ok(())
}

#[allow(clippy::result_large_err)] // see try_apply
fn reach_generic<T: Real, const D: usize>(
    g: &mut Held<T, D>,
    target: &Vec3,
    opts: &ReachOptions<f64>,
    def: &ChainDef,
    h: &mut ResponseHeader,
) -> Result<(), (Status, Reason)>
where
    Vector<T, D>: Embed3<T>,
{
    let t: Vector<T, D> = from_array(target.to_array());
    let opts_t = ReachOptions::<T> {
        strategy: opts.strategy,
        method: opts.method,
        substeps: opts.substeps,
        tolerance: T::lit(opts.tolerance),
        max_iterations: opts.max_iterations,
        hierarchy_after: opts.hierarchy_after,
    };
    match reach(&mut g.chain, &t, &opts_t, &mut g.ws) {
        Ok(o) => {
            h.iterations = o.iterations;
            h.residual = o.residual.to_f64();
            Ok(())
        }
        Err(ReachError::Unreachable { nearest, residual }) => {
            h.residual = residual.to_f64();
            let n = to_wire(&nearest);
            Err(fail(
                Status::Unreachable,
                format_args!(
                    "{:.3e} outside the workspace; nearest ({:.6}, {:.6}, {:.6})",
                    residual.to_f64(),
                    n.x,
                    n.y,
                    n.z
                ),
            ))
        }
        Err(ReachError::NotConverged {
            iterations,
            residual,
        }) => {
            h.iterations = iterations;
            h.residual = residual.to_f64();
            Err(fail(
                Status::NotConverged,
                format_args!(
                    "{iterations} iterations, residual {:.3e}",
                    residual.to_f64()
                ),
            ))
        }
        Err(ReachError::Chain(e)) => Err(chain_error(e, def)),
    }
}

/// The payload of a response, in any of the four chain forms.
#[derive(Debug)]
pub enum Elements<'a> {
    Empty,
    Planar64(ChainElements<'a, f64, 2>),
    Spatial64(ChainElements<'a, f64, 3>),
    Planar32(ChainElements<'a, f32, 2>),
    Spatial32(ChainElements<'a, f32, 3>),
}

impl Iterator for Elements<'_> {
    type Item = Vec3;
    #[inline]
    fn next(&mut self) -> Option<Vec3> {
        match self {
            Elements::Empty => None,
            Elements::Planar64(e) => e.next(),
            Elements::Spatial64(e) => e.next(),
            Elements::Planar32(e) => e.next(),
            Elements::Spatial32(e) => e.next(),
        }
    }
}

/// Joints by a compensated prefix sum, then joint rotations, one at a time.
#[derive(Debug)]
pub struct ChainElements<'a, T: Real, const D: usize> {
    chain: &'a Chain<T, D>,
    acc: CompensatedSum<T, D>,
    /// Next joint (0..=n), then n+1+k for rotation k.
    at: usize,
    angles: bool,
}

impl<'a, T: Real, const D: usize> ChainElements<'a, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    fn new(chain: &'a Chain<T, D>, angles: bool) -> Self {
        ChainElements {
            chain,
            acc: CompensatedSum::new(chain.origin()),
            at: 0,
            angles,
        }
    }
}

impl<T: Real, const D: usize> Iterator for ChainElements<'_, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    type Item = Vec3;
    #[inline]
    fn next(&mut self) -> Option<Vec3> {
        let links = self.chain.links();
        let n = links.len();
        let i = self.at;
        self.at += 1;
        if i == 0 {
            return Some(to_wire(&self.chain.origin()));
        }
        if i <= n {
            self.acc.add(&links[i - 1]);
            return Some(to_wire(&self.acc.value()));
        }
        let k = i - n - 1;
        if !self.angles || k >= n {
            self.at = i;
            return None;
        }
        let b = links[k].to_3d();
        let a = if k == 0 {
            Vector3::x()
        } else {
            links[k - 1].to_3d()
        };
        if D == 2 {
            let theta = (a.x * b.y - a.y * b.x).atan2(a.dot(&b));
            Some(Vec3::new(0.0, 0.0, theta.to_f64()))
        } else {
            let r = rotation_between(&a, &b).scaled_axis();
            Some(Vec3::new(r.x.to_f64(), r.y.to_f64(), r.z.to_f64()))
        }
    }
}
