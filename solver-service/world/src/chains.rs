//! The chains of a running scene, the [`World`]: one flat [`Chain`] per scene chain, addressed by its
//! index (the wire's chain handle), in exactly the form the scene declared (planar or spatial, f64 or
//! f32), with collision structures only where the scene declares collision; then the scene's bundles.
//!
//! [`World::apply`] runs a [`Command`] and is atomic: a refusal changes nothing, and the last accepted
//! change can be undone ([`World::undo`], for a journal write that failed). The world owns that
//! rollback, and nothing else does. [`World::elements_for`] streams the joints (and joint rotations,
//! held joints, instruments) straight into the caller's buffer: the service writes them into the
//! loaned shared-memory response, batch mode and the Unix socket into their output.
//!
//! No I/O and no clock here: the service measures time and does the persistence around it.

use crate::command::{Answer, BundleOp, Command, Point, Residual};
use crate::owners::{LOCAL, Owners};
use crate::refusal::Refusal;
use crate::refuse;
use crate::scene::{ChainSpec, Scene};
use nalgebra::Vector3;
use tractrix::angles::rotation_between;
use tractrix::collision::{
    CollisionModel, CollisionOptions, CollisionWorkspace, Obstacle, move_joint_colliding,
};
use tractrix::math::{CompensatedSum, Embed3, Real, Vector};
use tractrix::{Chain, ChainError, MoveOptions, MoveOutcome, ReachOptions, ReachWorkspace, reach};

/// A chain in the precision and dimension its scene declared, with its scene state (for reset) and the
/// buffers its requests reuse (allocated once).
#[derive(Debug, Clone)]
pub struct Held<T: Real, const D: usize> {
    /// The current state.
    pub chain: Chain<T, D>,
    /// The scene's state (reset).
    pub initial: Chain<T, D>,
    /// The state before the last change ([`World::undo`]).
    before: Chain<T, D>,
    ws: ReachWorkspace<T, D>,
    /// Collision model and buffers, only for chains whose scene declares collision.
    collision: Option<(CollisionModel<T, D>, CollisionWorkspace<T, D>)>,
    /// A path's targets in the chain's type (bounded by `MAX_PATH_POINTS`, kept between requests).
    targets: Vec<Vector<T, D>>,
    /// The chain's instruments: where they start in the collision model's obstacles (after the static
    /// ones), their scene poses (reset) and their poses before the last change (undo).
    instruments_at: usize,
    instruments_initial: Vec<Obstacle<T, D>>,
    instruments_before: Vec<Obstacle<T, D>>,
    /// For each instrument, the joint it rides with (scene `follows`).
    follows: Vec<Option<usize>>,
}

impl<T: Real, const D: usize> Held<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// The instruments' current poses.
    pub fn instruments(&self) -> &[Obstacle<T, D>] {
        self.collision
            .as_ref()
            .map_or(&[][..], |(m, _)| &m.obstacles[self.instruments_at..])
    }
    fn instruments_mut(&mut self) -> &mut [Obstacle<T, D>] {
        let at = self.instruments_at;
        self.collision
            .as_mut()
            .map_or(&mut [][..], |(m, _)| &mut m.obstacles[at..])
    }
    /// Remembers the state for [`World::undo`] (no allocation once warm).
    fn arm_undo(&mut self) {
        self.before.copy_from(&self.chain);
        if let Some((m, _)) = &self.collision {
            // Same length every time: no allocation once warm.
            self.instruments_before.clear();
            self.instruments_before
                .extend_from_slice(&m.obstacles[self.instruments_at..]);
        }
    }
    /// Puts back the state [`Held::arm_undo`] remembered.
    fn swap_undo(&mut self) {
        std::mem::swap(&mut self.chain, &mut self.before);
        let before = std::mem::take(&mut self.instruments_before);
        let now = self.instruments_mut();
        if now.len() == before.len() {
            now.copy_from_slice(&before);
        }
        self.instruments_before = before;
    }
    /// The instruments' poses as numbers (a sphere: its centre; a capsule: `a` then `b`), for a snapshot.
    pub fn instrument_numbers(&self) -> Vec<Vec<f64>> {
        self.instruments()
            .iter()
            .map(|o| {
                let pts: Vec<Vector<T, D>> = match o {
                    Obstacle::Sphere { center, .. } => vec![*center],
                    Obstacle::Capsule { a, b, .. } => vec![*a, *b],
                    Obstacle::HalfSpace { .. } => vec![],
                };
                pts.iter()
                    .flat_map(|p| p.iter().map(|x| x.to_f64()).collect::<Vec<_>>())
                    .collect()
            })
            .collect()
    }
    /// Sets the instruments' poses from [`Held::instrument_numbers`] (a restored snapshot).
    pub fn set_instrument_numbers(&mut self, poses: &[Vec<f64>]) -> Result<(), String> {
        if poses.len() != self.instruments().len() {
            return Err(format!(
                "{} instrument poses for {} instruments",
                poses.len(),
                self.instruments().len()
            ));
        }
        for (o, nums) in self.instruments_mut().iter_mut().zip(poses) {
            let pt = |k: usize| -> Result<Vector<T, D>, String> {
                let v = nums.get(k * D..(k + 1) * D).ok_or("a pose is too short")?;
                let p = Vector::<T, D>::from_iterator(v.iter().map(|&x| T::lit(x)));
                if tractrix::math::all_finite(&p) {
                    Ok(p)
                } else {
                    Err("a pose is not finite".into())
                }
            };
            match o {
                Obstacle::Sphere { center, .. } if nums.len() == D => *center = pt(0)?,
                Obstacle::Capsule { a, b, .. } if nums.len() == 2 * D => {
                    *a = pt(0)?;
                    *b = pt(1)?;
                }
                _ => return Err("an instrument's pose does not fit its shape".into()),
            }
        }
        Ok(())
    }
}

/// One of the four chain forms.
#[derive(Debug, Clone)]
pub enum Geometry {
    /// Planar, f64.
    Planar64(Held<f64, 2>),
    /// Spatial, f64.
    Spatial64(Held<f64, 3>),
    /// Planar, f32.
    Planar32(Held<f32, 2>),
    /// Spatial, f32.
    Spatial32(Held<f32, 3>),
}

/// Runs `$body` with `$h` bound to the [`Held`] of whichever form `$g` is (a
/// [`Geometry`](crate::chains::Geometry)).
#[macro_export]
macro_rules! each_form {
    ($g:expr, $h:ident => $body:expr) => {
        match $g {
            $crate::chains::Geometry::Planar64($h) => $body,
            $crate::chains::Geometry::Spatial64($h) => $body,
            $crate::chains::Geometry::Planar32($h) => $body,
            $crate::chains::Geometry::Spatial32($h) => $body,
        }
    };
}
pub use crate::each_form;

/// Elements of an instrument's pose in a payload: a sphere's centre twice, then `(radius, 0, 0)`; a
/// capsule's `a`, its `b`, then `(radius, 1, 0)` (the wire's `InstrumentPose`).
pub const INSTRUMENT_ELEMENTS: usize = 3;

/// The work a request may cost by default, in link-steps (one link following its tractrix once, about
/// 80 ns here): about 4 ms. See [`World::set_budget`].
pub const DEFAULT_BUDGET: u64 = 50_000;

/// Every chain and bundle of a scene, the state sequence number, and the undo record of the last
/// change.
#[derive(Debug, Clone)]
pub struct World {
    specs: Vec<ChainSpec>,
    geometry: Vec<Geometry>,
    /// The bundles, handles `specs.len()..`: not persisted, not in `sequence` (each counts its own).
    bundles: Vec<crate::bundles::Live>,
    sequence: u64,
    /// Most link-steps one request may cost.
    budget: u64,
    /// The chain and sequence before the last accepted change, while it can be undone.
    undo: Option<(u32, u64)>,
    /// Who owns each grasp ([`crate::owners`]).
    owners: Owners,
    /// The collision work the kernel's meter charged the last request, in link-steps.
    last_work: u64,
}

fn point<T: Real, const D: usize>(q: Point) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    Embed3::from_3d(&Vector3::new(T::lit(q.x), T::lit(q.y), T::lit(q.z)))
}

fn to_point<T: Real, const D: usize>(v: &Vector<T, D>) -> Point
where
    Vector<T, D>: Embed3<T>,
{
    let v = v.to_3d();
    Point::new(v.x.to_f64(), v.y.to_f64(), v.z.to_f64())
}

/// The links each following instrument holds: those within its reach of the joint it follows (its
/// radius, plus half its length for a capsule, in shortest links, and one more on each side).
fn holding(spec: &ChainSpec, c: &crate::scene::CollisionSpec) -> Vec<tractrix::collision::Holding> {
    let n = spec.lengths.len();
    c.instruments
        .iter()
        .zip(&c.follows)
        .enumerate()
        .filter_map(|(k, ((_, o), f))| {
            let j = (*f)? as usize;
            let extent = match o {
                Obstacle::Sphere { radius, .. } => *radius,
                Obstacle::Capsule { a, b, radius } => radius + 0.5 * (b - a).norm(),
                Obstacle::HalfSpace { .. } => 0.0,
            };
            let reach = ((extent + 0.5 * c.options.thickness) / spec.shortest).ceil();
            let reach = if reach.is_finite() {
                reach as usize + 1
            } else {
                n
            };
            Some(tractrix::collision::Holding {
                obstacle: c.obstacles.len() + k,
                links: j.saturating_sub(reach)..(j + reach).min(n),
            })
        })
        .collect()
}

fn held<T: Real, const D: usize>(spec: &ChainSpec) -> Result<Held<T, D>, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let p: Vec<Vector<T, D>> = spec.points.iter().map(|q| point(*q)).collect();
    let links: Vec<_> = p.windows(2).map(|w| w[1] - w[0]).collect();
    let lengths: Vec<T> = spec.lengths.iter().map(|&l| T::lit(l)).collect();
    let mut chain = Chain::from_parts(p[0], links, lengths)?;
    for &a in &spec.anchors {
        chain.hold(a as usize)?;
    }
    if let Some(l) = &spec.limits {
        let lim = l
            .kernel::<T>()
            .map_err(|_| ChainError::BadOption("the scene's joint limits"))?;
        chain
            .set_limits(Some(lim))
            .map_err(|_| ChainError::BadOption("the scene's joint limits"))?;
    }
    let collision = spec.collision.as_ref().map(|c| {
        let v = |q: &Vector3<f64>| point::<T, D>(*q);
        // The scene's obstacles, then its instruments (the kernel sees both as obstacles).
        let convert = |o: &Obstacle<f64, 3>| match o {
            Obstacle::Sphere { center, radius } => Obstacle::Sphere {
                center: v(center),
                radius: T::lit(*radius),
            },
            Obstacle::Capsule { a, b, radius } => Obstacle::Capsule {
                a: v(a),
                b: v(b),
                radius: T::lit(*radius),
            },
            Obstacle::HalfSpace { point, normal } => Obstacle::HalfSpace {
                point: v(point),
                normal: v(normal),
            },
        };
        let obstacles: Vec<Obstacle<T, D>> = c
            .obstacles
            .iter()
            .chain(c.instruments.iter().map(|(_, o)| o))
            .map(convert)
            .collect();
        let o = &c.options;
        let model = CollisionModel {
            options: CollisionOptions {
                scheme: o.scheme,
                self_collision: o.self_collision,
                thickness: T::lit(o.thickness),
                max_iterations: o.max_iterations,
                tolerance: T::lit(o.tolerance),
            },
            obstacles,
            holding: holding(spec, c),
        };
        (model, CollisionWorkspace::new())
    });
    let instruments_at = spec.collision.as_ref().map_or(0, |c| c.obstacles.len());
    let mut h = Held {
        initial: chain.clone(),
        before: chain.clone(),
        chain,
        ws: ReachWorkspace::default(),
        collision,
        targets: Vec::new(),
        instruments_at,
        instruments_initial: Vec::new(),
        instruments_before: Vec::new(),
        follows: spec.collision.as_ref().map_or_else(Vec::new, |c| {
            c.follows.iter().map(|f| f.map(|j| j as usize)).collect()
        }),
    };
    h.instruments_initial = h.instruments().to_vec();
    h.instruments_before = h.instruments_initial.clone();
    Ok(h)
}

impl World {
    /// Builds the chains a scene declares (and nothing else).
    pub fn new(scene: &Scene) -> Result<Self, String> {
        let mut geometry = Vec::with_capacity(scene.chains.len());
        for spec in &scene.chains {
            let g = match (spec.dims, spec.precision) {
                (2, crate::scene::Precision::F32) => held(spec).map(Geometry::Planar32),
                (2, _) => held(spec).map(Geometry::Planar64),
                (_, crate::scene::Precision::F32) => held(spec).map(Geometry::Spatial32),
                _ => held(spec).map(Geometry::Spatial64),
            }
            .map_err(|e| format!("chain {:?}: {e}", spec.name))?;
            geometry.push(g);
        }
        let bundles = scene
            .bundles
            .iter()
            .map(crate::bundles::Live::new)
            .collect::<Result<_, _>>()?;
        Ok(World {
            specs: scene.chains.clone(),
            geometry,
            bundles,
            sequence: 0,
            budget: DEFAULT_BUDGET,
            undo: None,
            owners: Owners::new(scene.chains.len()),
            last_work: 0,
        })
    }

    /// Sets the most work one request may cost, in link-steps (links × substeps × points for a move or
    /// a path, links × substeps × iterations for a reach). A request estimated above it is refused with
    /// `over-budget` before anything runs, so that one client cannot hold the serving thread. Collision
    /// work (detection, passes, re-solves), which depends on the contacts met, is charged by the
    /// kernel's meter as it is done ([`tractrix::collision::CollisionWorkspace::limit_work`]): a move
    /// that would pass the budget is stopped there and refused `over-budget`, the chain unchanged.
    pub fn set_budget(&mut self, link_steps: u64) {
        self.budget = link_steps.max(1);
    }

    /// The budget per request, in link-steps.
    pub fn budget(&self) -> u64 {
        self.budget
    }

    /// The collision work the kernel's meter charged the last request (accepted or refused), in
    /// link-steps: never more than the budget.
    pub fn last_work(&self) -> u64 {
        self.last_work
    }

    /// The work a request will cost at most, in link-steps, collision work aside (metered while it runs,
    /// [`World::set_budget`]): the substeps of a
    /// move are counted from where the joint is now, as the kernel will count them. A move needing more
    /// substeps than its chain allows is refused here as the kernel would refuse it (`too-many-substeps`).
    pub fn estimate(&self, req: &Command<'_>) -> Result<u64, Refusal> {
        if let Command::Bundle { index, op, .. } = req {
            return Ok(crate::bundles::estimate(&self.bundles[*index].spec, op));
        }
        let Some(chain) = req.chain() else {
            return Ok(0);
        };
        let spec = &self.specs[chain as usize];
        let n = spec.lengths.len() as u64;
        match *req {
            Command::Move {
                joint,
                targets,
                ref options,
                ..
            } => {
                // With held joints, each side up to a held joint iterates the fixed-base method: at
                // most `hierarchy_after` tractrix passes, then the hierarchy's one pass.
                let held = each_form!(&self.geometry[chain as usize], h => h.chain.held().any(|j| j != joint));
                // With joint limits the hierarchy's pose is kept only when it lands within them, so
                // the passes may run to `max_iterations`, each with a try of the hierarchy (two);
                // boundary following takes its passes from these (`ReachOptions::passes_bound`).
                let passes = if held {
                    options.held.passes_bound(spec.limits.is_some())
                } else {
                    1
                };
                let n = n.saturating_mul(passes);
                // Collision splits a move so that the hand moves at most half a clearance per substep.
                let half_clearance = spec.collision.as_ref().map(|c| {
                    let link = match c.options.scheme {
                        tractrix::collision::Scheme::Capsules => c.options.thickness,
                        tractrix::collision::Scheme::PaperSpheres => spec.shortest,
                    };
                    0.5 * if c.obstacles.is_empty() {
                        link
                    } else {
                        0.5 * link
                    }
                });
                if let (tractrix::Substeps::Fixed(k), None) = (options.substeps, half_clearance) {
                    // Fixed substeps, no collision: the distances do not matter (no walk to the joint).
                    if k > options.max_substeps {
                        return Err(ChainError::TooManySubsteps {
                            required: u64::from(k),
                            limit: options.max_substeps,
                        }
                        .into());
                    }
                    let substeps = u64::from(k).saturating_mul(targets.len() as u64);
                    return Ok(n.saturating_mul(substeps));
                }
                let mut substeps = 0u64;
                // Where the joint is now: one walk along the chain, for the substeps that depend on it.
                let mut from: Point = each_form!(&self.geometry[chain as usize], h => to_point(&h.chain.joint(joint)));
                for t in targets {
                    let d =
                        ((t.x - from.x).powi(2) + (t.y - from.y).powi(2) + (t.z - from.z).powi(2))
                            .sqrt();
                    let asked = match options.substeps {
                        tractrix::Substeps::Fixed(k) => f64::from(k),
                        tractrix::Substeps::MaxStep(s) => (d / (s * spec.shortest)).ceil(),
                    };
                    let needed = half_clearance.map_or(0.0, |h| (d / h).ceil());
                    let k = asked.max(needed).max(1.0);
                    let k = if k.is_finite() && k < 1e18 {
                        k as u64
                    } else {
                        u64::MAX
                    };
                    if k > u64::from(options.max_substeps) {
                        return Err(ChainError::TooManySubsteps {
                            required: k,
                            limit: options.max_substeps,
                        }
                        .into());
                    }
                    substeps = substeps.saturating_add(k);
                    from = *t;
                }
                // Instruments riding with the joint are carried after the move: as many substeps again.
                let carried = spec.collision.as_ref().map_or(0, |c| {
                    c.follows
                        .iter()
                        .filter(|f| f.map(|j| j as usize) == Some(joint))
                        .count()
                });
                Ok(n.saturating_mul(substeps)
                    .saturating_mul(1 + carried as u64))
            }
            // With joint limits each iteration also tries the hierarchy (a second pass).
            Command::Reach { ref options, .. } => Ok(n
                .saturating_mul(u64::from(options.substeps.max(1)))
                .saturating_mul(u64::from(options.max_iterations.max(1)))
                .saturating_mul(if spec.limits.is_some() { 2 } else { 1 })),
            Command::Instrument {
                index,
                centre,
                axis,
                max_substeps,
                ..
            } => {
                // Substeps of half a clearance (a link against an obstacle has half a link's), over
                // the farthest any point of the instrument travels.
                let travel = each_form!(&self.geometry[chain as usize], h => {
                    instrument_travel(&h.instruments()[index], centre, axis)
                });
                let link =
                    spec.collision
                        .as_ref()
                        .map_or(spec.thickness, |c| match c.options.scheme {
                            tractrix::collision::Scheme::Capsules => c.options.thickness,
                            tractrix::collision::Scheme::PaperSpheres => spec.shortest,
                        });
                let k = (travel / (0.25 * link)).ceil().max(1.0);
                if !(k.is_finite() && k <= f64::from(max_substeps)) {
                    return Err(ChainError::TooManySubsteps {
                        required: if k.is_finite() { k as u64 } else { u64::MAX },
                        limit: max_substeps,
                    }
                    .into());
                }
                Ok(n.saturating_mul(k as u64))
            }
            Command::Query { .. }
            | Command::Describe { .. }
            | Command::Reset { .. }
            | Command::Grasp { .. }
            | Command::Release { .. } => Ok(n),
            Command::Snapshot | Command::Bundle { .. } => Ok(0),
        }
    }

    /// The first chain or bundle whose `describe` (the least a client asks of it) would be refused as
    /// over the budget: its `links` line in the scene file and why. A service with one would start
    /// and refuse every request to it; it is refused at start and by `check` instead.
    pub fn unservable(&self) -> Option<(usize, String)> {
        let over = |what: &str, name: &str, links: String, cost: u64| {
            format!(
                "{what} {name:?}: field `links`: {links}: a describe costs {cost} link-steps, over the \
                 budget of {} (--budget): fewer links, or a larger --budget",
                self.budget
            )
        };
        for (i, spec) in self.specs.iter().enumerate() {
            let cost = self
                .estimate(&Command::Describe { chain: i as u32 })
                .unwrap_or(u64::MAX);
            if cost > self.budget {
                let links = format!("{} links", spec.lengths.len());
                return Some((spec.links_line, over("chain", &spec.name, links, cost)));
            }
        }
        for b in &self.bundles {
            let cost = crate::bundles::estimate(&b.spec, &BundleOp::Describe);
            if cost > self.budget {
                let links = format!("{} strands of {} links", b.spec.strands, b.spec.links);
                return Some((b.spec.links_line, over("bundle", &b.spec.name, links, cost)));
            }
        }
        None
    }

    /// Number of chains (bundles aside).
    pub fn len(&self) -> usize {
        self.specs.len()
    }
    /// Whether the scene has no chain (a scene of bundles only).
    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }
    /// The bundles, by handle − [`World::len`].
    pub fn bundles(&self) -> &[crate::bundles::Live] {
        &self.bundles
    }
    /// The bundle a handle addresses, and its index.
    pub fn bundle_of(&self, handle: u32) -> Option<(usize, &crate::bundles::Live)> {
        let i = (handle as usize).checked_sub(self.specs.len())?;
        self.bundles.get(i).map(|b| (i, b))
    }
    /// Joints in the largest bundle, for the bundle stream's samples (`None`: no bundles, no stream).
    pub fn bundle_stream_size(&self) -> Option<usize> {
        self.bundles.iter().map(|b| b.spec.joints()).max()
    }
    /// The chains' specifications, by handle.
    pub fn specs(&self) -> &[ChainSpec] {
        &self.specs
    }
    /// The chains' states, by handle.
    pub fn geometry(&self) -> &[Geometry] {
        &self.geometry
    }
    /// Replaces every chain's state and the sequence (a restored snapshot, checked by the caller).
    pub fn install(&mut self, geometry: Vec<Geometry>, sequence: u64) {
        self.geometry = geometry;
        self.sequence = sequence;
        self.undo = None;
    }
    /// The poses of a chain's instruments (a sphere's centre; a capsule's `a` then `b`).
    pub fn instrument_poses(&self, chain: u32) -> Vec<Vec<f64>> {
        self.geometry
            .get(chain as usize)
            .map_or_else(Vec::new, |g| each_form!(g, h => h.instrument_numbers()))
    }
    /// The sequence number of the last accepted change (0 before any).
    pub fn sequence(&self) -> u64 {
        self.sequence
    }
    /// The handle of a chain by name.
    pub fn find(&self, name: &str) -> Option<u32> {
        self.specs
            .iter()
            .map(|s| &s.name)
            .chain(self.bundles.iter().map(|b| &b.spec.name))
            .position(|n| n == name)
            .map(|i| i as u32)
    }
    /// The sizes the ports must hold: the most elements in a response (joints, rotations, held joints
    /// and instruments of the largest chain) and the most in a state sample (the same without
    /// rotations).
    pub fn response_sizes(&self) -> (usize, usize) {
        let mut most = (1, 1);
        for (spec, g) in self.specs.iter().zip(&self.geometry) {
            let links = spec.lengths.len();
            let tail = crate::sizes::MAX_HELD
                + INSTRUMENT_ELEMENTS * each_form!(g, h => h.instruments().len());
            most.0 = most.0.max(2 * links + 1 + tail);
            most.1 = most.1.max(links + 1 + tail);
        }
        if let Some(j) = self.bundle_stream_size() {
            most.0 = most.0.max(j);
        }
        most
    }

    /// Applies a decoded request as [`LOCAL`] (batch mode, the journal's replay, tests): see
    /// [`World::apply_for`].
    pub fn apply(&mut self, req: &Command<'_>) -> Result<Answer, Refusal> {
        self.apply_for(LOCAL, req)
    }

    /// Applies a decoded request of `client` (its port id; [`LOCAL`] for no client). A refusal changes
    /// nothing; an accepted change gets the next sequence number and can be undone until the next
    /// request. Grasps belong to their client ([`crate::owners`]).
    pub fn apply_for(&mut self, client: u128, req: &Command<'_>) -> Result<Answer, Refusal> {
        self.undo = None;
        self.owners.begin();
        self.owners.check(client, req)?;
        let outcome = self.apply_checked(req)?;
        if let Some(chain) = req.chain() {
            self.owners
                .record(client, req, &self.specs[chain as usize].anchors);
        }
        Ok(outcome)
    }

    /// Whether any grasp has an owner.
    pub fn grasps_owned(&self) -> bool {
        self.owners.any()
    }

    /// Leaves the grasps of clients for which `present` is false holding, unowned; returns how many.
    pub fn forget_absent_owners(&mut self, present: impl Fn(u128) -> bool) -> usize {
        self.owners.forget_absent(present)
    }

    fn apply_checked(&mut self, req: &Command<'_>) -> Result<Answer, Refusal> {
        self.last_work = 0;
        let work = self.estimate(req)?;
        if work > self.budget {
            return Err(refuse!(
                OverBudget,
                "about {work:.2e} link-steps, over the budget of {:.2e} (--budget)",
                self.budget as f64
            ));
        }
        if let Command::Bundle { handle, index, op } = *req {
            let b = &mut self.bundles[index];
            let substeps = b.apply(&op)?;
            return Ok(Answer {
                chain: Some(handle),
                changed: op.changes_state(),
                joints: b.spec.joints() as u32,
                substeps,
                describe: op == BundleOp::Describe,
                bundle: true,
                ..Answer::default()
            });
        }
        let Some(chain) = req.chain() else {
            return Ok(Answer::default());
        };
        let n_links = self.specs[chain as usize].lengths.len() as u32;
        let g = &mut self.geometry[chain as usize];
        let held_now = each_form!(&*g, h => h.chain.held().len());
        // A grasp of a held joint and a release of a free one are accepted and change nothing.
        let changes = match *req {
            Command::Grasp { joint, .. } => {
                let held = each_form!(&*g, h => h.chain.is_held(joint));
                if !held && held_now >= crate::sizes::MAX_HELD {
                    return Err(refuse!(
                        BadOption,
                        "chain {:?} already holds {held_now} joints, the most there may be",
                        self.specs[chain as usize].name
                    ));
                }
                !held
            }
            Command::Release { joint, .. } => each_form!(&*g, h => h.chain.is_held(joint)),
            _ => req.changes_state(),
        };
        let mut outcome = Answer {
            chain: Some(chain),
            changed: changes,
            joints: n_links + 1,
            ..Answer::default()
        };
        if outcome.changed {
            // Armed before the kernel runs, so that a panic inside it can be undone too.
            each_form!(&mut *g, h => h.arm_undo());
            self.undo = Some((chain, self.sequence));
        }
        // Collision work depends on the contacts met, not known before: the kernel's meter charges
        // every unit (sweeps, held solves, detection, passes, re-solves) before doing it and stops
        // the request at the budget, the chain unchanged.
        let budget = self.budget;
        each_form!(&mut *g, h => if let Some((_, ws)) = h.collision.as_mut() {
            ws.limit_work(budget);
        });
        let result = match *req {
            Command::Move {
                joint,
                targets,
                ref options,
                ..
            } => each_form!(&mut *g, h => move_and_carry(h, joint, targets, options)).map(|m| {
                outcome.substeps = m.substeps;
                outcome.paper_fallbacks = m.paper_fallbacks;
                outcome.iterations = m.collision_iterations;
                outcome.residual = Residual::Landing {
                    joint,
                    target: targets[targets.len() - 1],
                };
            }),
            Command::Reach {
                target,
                ref options,
                angles,
                ..
            } => each_form!(&mut *g, h => reach_held(h, target, options)).map(|(it, res)| {
                outcome.iterations = it;
                outcome.residual = Residual::Known(res);
                outcome.angles = if angles { n_links } else { 0 };
            }),
            Command::Query { angles, .. } => {
                outcome.angles = if angles { n_links } else { 0 };
                Ok(())
            }
            Command::Describe { .. } => {
                outcome.describe = true;
                Ok(())
            }
            Command::Reset { .. } => {
                each_form!(&mut *g, h => {
                    h.chain.copy_from(&h.initial);
                    let initial = std::mem::take(&mut h.instruments_initial);
                    h.instruments_mut().copy_from_slice(&initial);
                    h.instruments_initial = initial;
                });
                Ok(())
            }
            Command::Instrument {
                index,
                centre,
                axis,
                max_substeps,
                ..
            } => each_form!(&mut *g, h => push_instrument(h, index, centre, axis, max_substeps))
                .map(|m| {
                    outcome.substeps = m.substeps;
                    outcome.iterations = m.collision_iterations;
                }),
            Command::Grasp { joint, .. } => {
                each_form!(&mut *g, h => h.chain.hold(joint)).map_err(Refusal::from)
            }
            Command::Release { joint, .. } => each_form!(&mut *g, h => h.chain.release(joint))
                .map(|_| ())
                .map_err(Refusal::from),
            Command::Snapshot | Command::Bundle { .. } => Ok(()),
        };
        outcome.held = each_form!(&*g, h => h.chain.held().len()) as u32;
        outcome.instruments = each_form!(&*g, h => h.instruments().len()) as u32;
        self.last_work = each_form!(&*g, h => h.collision.as_ref().map_or(0, |(_, ws)| ws.work()));
        match result {
            Ok(()) => {
                if outcome.changed {
                    self.sequence += 1;
                }
                Ok(outcome)
            }
            Err(r) => {
                if outcome.changed {
                    each_form!(&mut *g, h => h.swap_undo());
                    self.undo = None;
                }
                Err(r)
            }
        }
    }

    /// Undoes the last accepted change (a journal write failed), or the change that was being applied
    /// when the solver panicked. Only once; nothing happens if there is nothing to undo.
    pub fn undo(&mut self) {
        if let Some((chain, sequence)) = self.undo.take() {
            each_form!(&mut self.geometry[chain as usize], h => h.swap_undo());
            self.sequence = sequence;
            self.owners.undo();
        }
    }

    /// The payload of an answer about `handle`: a chain's joints (tail first), then with `angles` one
    /// rotation vector per joint (joint 0: from +x to link 1; joint i: from link i to link i+1), its
    /// held joints with `held`, its instruments with `instruments`; a bundle's joints. Written in
    /// order, with no intermediate buffer; nothing for an unknown handle.
    pub fn elements_for(
        &self,
        handle: u32,
        angles: bool,
        held: bool,
        instruments: bool,
    ) -> Elements<'_> {
        if let Some((_, b)) = self.bundle_of(handle) {
            return Elements::Bundle(b.elements());
        }
        self.elements_with(handle, angles, held, instruments)
    }

    /// A chain's joints, then its joint rotations with `angles` (nothing for an unknown chain).
    pub fn elements_of(&self, chain: u32, angles: bool) -> Elements<'_> {
        self.elements_with(chain, angles, false, false)
    }

    /// A chain's joints, its rotations with `angles`, its held joints with `held` (index, 1 for an
    /// anchor and 0 for a grasp, 0), its instruments with `instruments` (the wire's three elements
    /// each: [`INSTRUMENT_ELEMENTS`]).
    pub fn elements_with(
        &self,
        chain: u32,
        angles: bool,
        held: bool,
        instruments: bool,
    ) -> Elements<'_> {
        let (Some(g), Some(spec)) = (
            self.geometry.get(chain as usize),
            self.specs.get(chain as usize),
        ) else {
            return Elements::Empty;
        };
        let a = &spec.anchors[..];
        let wants = Wants {
            angles,
            held,
            instruments,
        };
        match g {
            Geometry::Planar64(h) => Elements::Planar64(ChainElements::new(h, wants, a)),
            Geometry::Spatial64(h) => Elements::Spatial64(ChainElements::new(h, wants, a)),
            Geometry::Planar32(h) => Elements::Planar32(ChainElements::new(h, wants, a)),
            Geometry::Spatial32(h) => Elements::Spatial32(ChainElements::new(h, wants, a)),
        }
    }
}

/// A move or a path on one chain. The chain may be left moved on a refusal: [`World::apply`]
/// restores it.
/// The instrument `from` moved to `centre` (and, for a capsule, turned to `axis`), its size kept.
fn instrument_pose<T: Real, const D: usize>(
    from: &Obstacle<T, D>,
    centre: Point,
    axis: Option<Point>,
) -> Obstacle<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let c: Vector<T, D> = point(centre);
    match (*from, axis) {
        (Obstacle::Capsule { a, b, radius }, Some(axis)) => {
            let half = (b - a).norm() * T::lit(0.5);
            let d: Vector<T, D> = point(axis);
            let d = d / d.norm();
            Obstacle::Capsule {
                a: c - d * half,
                b: c + d * half,
                radius,
            }
        }
        (Obstacle::Sphere { radius, .. }, _) => Obstacle::Sphere { center: c, radius },
        (other, _) => other,
    }
}

/// How far any point of the instrument travels from its pose to the new one (the centre's distance
/// plus the arc its axis's end sweeps), in f64.
fn instrument_travel<T: Real, const D: usize>(
    from: &Obstacle<T, D>,
    centre: Point,
    axis: Option<Point>,
) -> f64
where
    Vector<T, D>: Embed3<T>,
{
    let v = |p: &Vector<T, D>| {
        let q = p.to_3d();
        Vector3::new(q.x.to_f64(), q.y.to_f64(), q.z.to_f64())
    };
    let to = Vector3::new(centre.x, centre.y, centre.z);
    match (from, axis) {
        (Obstacle::Capsule { a, b, .. }, Some(ax)) => {
            let (a, b) = (v(a), v(b));
            let h0 = (b - a) * 0.5;
            let d = Vector3::new(ax.x, ax.y, ax.z);
            let angle = h0.angle(&d);
            ((a + b) * 0.5 - to).norm() + h0.norm() * angle
        }
        (Obstacle::Sphere { center, .. }, _) => (v(center) - to).norm(),
        _ => 0.0,
    }
}

/// A move of `joint`; the instruments that follow it are then carried by the joint's displacement,
/// pushing the rest of the rope (locked: the whole move is refused).
fn move_and_carry<T: Real, const D: usize>(
    g: &mut Held<T, D>,
    joint: usize,
    targets: &[Point],
    opts: &MoveOptions<f64>,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    if !g.follows.contains(&Some(joint)) {
        return move_held(g, joint, targets, opts);
    }
    // Point by point, so that the instruments follow the path, not its chord (a refusal anywhere
    // refuses the whole request: the caller undoes it).
    let mut outcome = MoveOutcome::default();
    for t in targets {
        let from = g.chain.joint(joint);
        let m = move_held(g, joint, std::slice::from_ref(t), opts)?;
        outcome.substeps = outcome.substeps.saturating_add(m.substeps);
        outcome.paper_fallbacks = outcome.paper_fallbacks.saturating_add(m.paper_fallbacks);
        outcome.collision_iterations = outcome
            .collision_iterations
            .saturating_add(m.collision_iterations);
        let delta = g.chain.joint(joint) - from;
        for k in 0..g.follows.len() {
            if g.follows[k] != Some(joint) {
                continue;
            }
            let at = g.instruments_at + k;
            let Some((model, ws)) = g.collision.as_mut() else {
                continue;
            };
            let to = match model.obstacles[at] {
                Obstacle::Sphere { center, radius } => Obstacle::Sphere {
                    center: center + delta,
                    radius,
                },
                Obstacle::Capsule { a, b, radius } => Obstacle::Capsule {
                    a: a + delta,
                    b: b + delta,
                    radius,
                },
                other => other,
            };
            let m = tractrix::collision::push_by_obstacle(
                &mut g.chain,
                model,
                at,
                &to,
                opts.max_substeps,
                ws,
            )?;
            model.obstacles[at] = to;
            outcome.substeps = outcome.substeps.saturating_add(m.substeps);
            outcome.collision_iterations = outcome
                .collision_iterations
                .saturating_add(m.collision_iterations);
        }
    }
    Ok(outcome)
}

fn push_instrument<T: Real, const D: usize>(
    g: &mut Held<T, D>,
    index: usize,
    centre: Point,
    axis: Option<Point>,
    max_substeps: u32,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let at = g.instruments_at + index;
    let Some((model, ws)) = g.collision.as_mut() else {
        return Err(ChainError::BadOption("the chain has no instruments").into());
    };
    let to = instrument_pose(&model.obstacles[at], centre, axis);
    let m = tractrix::collision::push_by_obstacle(&mut g.chain, model, at, &to, max_substeps, ws)?;
    model.obstacles[at] = to;
    Ok(m)
}

fn move_held<T: Real, const D: usize>(
    g: &mut Held<T, D>,
    joint: usize,
    targets: &[Point],
    opts: &MoveOptions<f64>,
) -> Result<MoveOutcome, Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = MoveOptions {
        method: opts.method,
        substeps: match opts.substeps {
            tractrix::Substeps::Fixed(k) => tractrix::Substeps::Fixed(k),
            tractrix::Substeps::MaxStep(s) => tractrix::Substeps::MaxStep(T::lit(s)),
        },
        max_substeps: opts.max_substeps,
        held: tractrix::ReachOptions {
            strategy: opts.held.strategy,
            method: opts.held.method,
            substeps: opts.held.substeps,
            tolerance: T::lit(opts.held.tolerance).max(T::EPSILON * T::lit(64.0)),
            max_iterations: opts.held.max_iterations,
            hierarchy_after: opts.held.hierarchy_after,
        },
    };
    let converted = |g: &mut Held<T, D>| -> Result<(), Refusal> {
        g.targets.clear();
        for t in targets {
            let p: Vector<T, D> = point(*t);
            if !tractrix::math::all_finite(&p) {
                return Err(ChainError::NonFinite.into());
            }
            g.targets.push(p);
        }
        Ok(())
    };
    if let Some((model, ws)) = &mut g.collision {
        // Each target is a straight move with collision.
        let mut total = MoveOutcome::default();
        for t in targets {
            let p: Vector<T, D> = point(*t);
            let o = move_joint_colliding(&mut g.chain, joint, p, &opts, model, ws)?;
            total.substeps = total.substeps.saturating_add(o.substeps);
            total.paper_fallbacks = total.paper_fallbacks.saturating_add(o.paper_fallbacks);
            total.collision_iterations = total
                .collision_iterations
                .saturating_add(o.collision_iterations);
            total.contacts = total.contacts.saturating_add(o.contacts);
        }
        Ok(total)
    } else if targets.len() == 1 {
        let p: Vector<T, D> = point(targets[0]);
        if !tractrix::math::all_finite(&p) {
            return Err(ChainError::NonFinite.into());
        }
        Ok(g.chain.move_joint(joint, p, &opts)?)
    } else {
        converted(g)?;
        let Held { chain, targets, .. } = g;
        Ok(chain.move_along(joint, targets, &opts)?)
    }
}

/// A reach on one fixed-base chain: iterations and residual.
fn reach_held<T: Real, const D: usize>(
    g: &mut Held<T, D>,
    target: Point,
    opts: &ReachOptions<f64>,
) -> Result<(u32, f64), Refusal>
where
    Vector<T, D>: Embed3<T>,
{
    let t: Vector<T, D> = point(target);
    let opts = ReachOptions::<T> {
        strategy: opts.strategy,
        method: opts.method,
        substeps: opts.substeps,
        tolerance: T::lit(opts.tolerance),
        max_iterations: opts.max_iterations,
        hierarchy_after: opts.hierarchy_after,
    };
    if !tractrix::math::all_finite(&t) {
        return Err(ChainError::NonFinite.into());
    }
    let o = reach(&mut g.chain, &t, &opts, &mut g.ws)?;
    Ok((o.iterations, o.residual.to_f64()))
}

/// The payload of a response, in any of the four chain forms.
#[derive(Debug)]
pub enum Elements<'a> {
    /// No elements (an error response).
    Empty,
    /// Planar, f64.
    Planar64(ChainElements<'a, f64, 2>),
    /// Spatial, f64.
    Spatial64(ChainElements<'a, f64, 3>),
    /// Planar, f32.
    Planar32(ChainElements<'a, f32, 2>),
    /// Spatial, f32.
    Spatial32(ChainElements<'a, f32, 3>),
    /// A bundle's joints.
    Bundle(crate::bundles::BundleElements<'a>),
}

impl Elements<'_> {
    /// Appends the first `n` elements to `out` (a chain's joints by one tight loop:
    /// [`ChainElements::gather_into`]).
    pub fn gather_into<P: From<Point>>(self, out: &mut Vec<P>, n: usize) {
        match self {
            Elements::Empty => {}
            Elements::Planar64(e) => e.gather_into(out, n),
            Elements::Spatial64(e) => e.gather_into(out, n),
            Elements::Planar32(e) => e.gather_into(out, n),
            Elements::Spatial32(e) => e.gather_into(out, n),
            Elements::Bundle(e) => out.extend(e.take(n).map(P::from)),
        }
    }
}

impl Iterator for Elements<'_> {
    type Item = Point;
    #[inline]
    fn next(&mut self) -> Option<Point> {
        match self {
            Elements::Empty => None,
            Elements::Planar64(e) => e.next(),
            Elements::Spatial64(e) => e.next(),
            Elements::Planar32(e) => e.next(),
            Elements::Spatial32(e) => e.next(),
            Elements::Bundle(e) => e.next(),
        }
    }
}

/// Which parts of a payload to write after the joints.
#[derive(Debug, Clone, Copy)]
struct Wants {
    angles: bool,
    held: bool,
    instruments: bool,
}

/// Joints by a compensated prefix sum (restarted at every held joint, as the kernel sums them), then
/// joint rotations, then held joints, then instruments, one element at a time.
#[derive(Debug)]
pub struct ChainElements<'a, T: Real, const D: usize> {
    chain: &'a Chain<T, D>,
    /// Joint 0, summed back from the chain's datum once (an O(n) pass).
    origin: Vector<T, D>,
    acc: CompensatedSum<T, D>,
    /// Next joint (0..=n), then n+1+k for rotation k, then held joint k, then instrument elements.
    at: usize,
    rotations: usize,
    held: usize,
    instruments: &'a [Obstacle<T, D>],
    /// The next held joint whose state restarts the sum, and its index (`usize::MAX`: none left).
    pin: usize,
    pin_at: usize,
    anchors: &'a [u32],
}

impl<'a, T: Real, const D: usize> ChainElements<'a, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    fn new(h: &'a Held<T, D>, wants: Wants, anchors: &'a [u32]) -> Self {
        let chain = &h.chain;
        let origin = chain.origin();
        ChainElements {
            chain,
            origin,
            acc: CompensatedSum::new(origin),
            at: 0,
            rotations: if wants.angles { chain.links().len() } else { 0 },
            held: if wants.held { chain.held().len() } else { 0 },
            instruments: if wants.instruments {
                h.instruments()
            } else {
                &[]
            },
            pin: 0,
            pin_at: chain.held_state(0).map_or(usize::MAX, |(j, _)| j),
            anchors,
        }
    }

    /// Restarts the sum at joint `i` if it is held.
    #[inline]
    fn restart_at(&mut self, i: usize) -> bool {
        if i != self.pin_at {
            return false;
        }
        match self.chain.held_state(self.pin) {
            Some((j, s)) if j == i => {
                self.acc = s;
                self.pin += 1;
                self.pin_at = self
                    .chain
                    .held_state(self.pin)
                    .map_or(usize::MAX, |(j, _)| j);
                true
            }
            _ => false,
        }
    }
}

impl<T: Real, const D: usize> ChainElements<'_, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// Appends the first `n` elements to `out`, the same as `out.extend(self.take(n))`: the joints by
    /// one tight loop (the sum's state kept in registers, held joints restarting it), the rest one
    /// at a time.
    pub fn gather_into<P: From<Point>>(mut self, out: &mut Vec<P>, n: usize) {
        out.reserve(n);
        let start = out.len();
        let links = self.chain.links();
        let joints = (links.len() + 1).min(n);
        if self.at == 0 && joints > 0 {
            out.extend(self.next().map(P::from));
            let mut acc = self.acc;
            for (i, l) in links[..joints - 1]
                .iter()
                .enumerate()
                .map(|(i, l)| (i + 1, l))
            {
                acc.add(l);
                if i == self.pin_at {
                    self.acc = acc;
                    self.restart_at(i);
                    acc = self.acc;
                }
                out.push(P::from(to_point(&acc.value())));
            }
            self.acc = acc;
            self.at = joints;
        }
        let done = out.len() - start;
        out.extend(self.take(n - done).map(P::from));
    }
}

impl<T: Real, const D: usize> Iterator for ChainElements<'_, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    type Item = Point;
    #[inline]
    fn next(&mut self) -> Option<Point> {
        let links = self.chain.links();
        let n = links.len();
        let i = self.at;
        self.at += 1;
        if i == 0 {
            if self.restart_at(0) {
                return Some(to_point(&self.acc.value()));
            }
            return Some(to_point(&self.origin));
        }
        if i <= n {
            self.acc.add(&links[i - 1]);
            self.restart_at(i);
            return Some(to_point(&self.acc.value()));
        }
        let k = i - n - 1;
        if k < self.rotations {
            let b = links[k].to_3d();
            let a = if k == 0 {
                Vector3::x()
            } else {
                links[k - 1].to_3d()
            };
            return Some(if D == 2 {
                let theta = (a.x * b.y - a.y * b.x).atan2(a.dot(&b));
                Point::new(0.0, 0.0, theta.to_f64())
            } else {
                let r = rotation_between(&a, &b).scaled_axis();
                Point::new(r.x.to_f64(), r.y.to_f64(), r.z.to_f64())
            });
        }
        let k = k - self.rotations;
        if k < self.held {
            let (j, _) = self.chain.held_state(k)?;
            let anchor = self.anchors.contains(&(j as u32));
            return Some(Point::new(j as f64, if anchor { 1.0 } else { 0.0 }, 0.0));
        }
        let k = k - self.held;
        let per = INSTRUMENT_ELEMENTS;
        let Some(o) = self.instruments.get(k / per) else {
            self.at = i;
            return None;
        };
        Some(instrument_element(o, k % per))
    }
}

/// Element `e` (0, 1 or 2) of an instrument's pose ([`INSTRUMENT_ELEMENTS`]).
fn instrument_element<T: Real, const D: usize>(o: &Obstacle<T, D>, e: usize) -> Point
where
    Vector<T, D>: Embed3<T>,
{
    let (a, b, radius, capsule) = match *o {
        Obstacle::Sphere { center, radius } => (center, center, radius, false),
        Obstacle::Capsule { a, b, radius } => (a, b, radius, true),
        // Never an instrument (the scene declares spheres and capsules only).
        Obstacle::HalfSpace { .. } => return Point::zeros(),
    };
    match e {
        0 => to_point(&a),
        1 => to_point(&b),
        _ => Point::new(radius.to_f64(), if capsule { 1.0 } else { 0.0 }, 0.0),
    }
}
