//! The chains of a running scene, the [`World`]: one flat [`tractrix::Chain`] per scene chain,
//! addressed by its index (the wire's chain handle), in exactly the form the scene declared (planar
//! or spatial, f64 or f32), with collision structures only where the scene declares collision; then
//! the scene's bundles.
//!
//! [`World::apply`] runs a [`Command`] and is atomic: a refusal changes nothing, and the last accepted
//! change can be undone ([`World::undo`], for a journal write that failed). The world owns that
//! rollback, and nothing else does. [`World::elements_for`] streams the joints (and joint rotations,
//! held joints, instruments) straight into the caller's buffer: the service writes them into the
//! loaned shared-memory response, batch mode and the Unix socket into their output.
//!
//! No I/O and no clock here: the service measures time and does the persistence around it.

use crate::build::BuildError;
use crate::command::Point;
use crate::command::{Answer, BundleOp, Command};
use crate::each_form;
use crate::elements::{ChainElements, Counts, Elements, INSTRUMENT_ELEMENTS, Wants};
use crate::form::{Geometry, build};
use crate::owners::{LOCAL, Owners};
use crate::point::to_point;
use crate::refusal::Refusal;
use crate::refuse;
use crate::scene::{ChainKind, ChainSpec, Scene};
use tractrix::{ChainError, MoveOptions, Substeps};

/// The frame: the work a request may cost by default, in link-steps (one link following its tractrix
/// once, about 62 ns on the machines this project runs on): 1 ms, a haptic device's sample, with the
/// meter's charge for collision work above its time (BENCHMARKS.md, "Every request inside its
/// frame"). See [`World::set_budget`].
pub const DEFAULT_BUDGET: u64 = 16_000;

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
    /// Most link-steps one pull may cost (never more than `budget`): the scene's `pull_budget`.
    pull_budget: Option<u64>,
    /// The chain and sequence before the last accepted change, while it can be undone.
    undo: Option<(u32, u64)>,
    /// Who owns each grasp ([`crate::owners`]).
    owners: Owners,
    /// The collision work the kernel's meter charged the last request, in link-steps.
    last_work: u64,
    /// A knot namer for each chain whose scene asks for its knot (`knot = true`), and the joints it
    /// reads.
    namers: Vec<Option<knots::Namer>>,
    knot_points: Vec<Point>,
    /// Tests: the next command panics after the kernel has run (a kernel bug, injected).
    #[cfg(test)]
    panic_after_kernel: bool,
}

impl World {
    /// Builds the chains a scene declares (and nothing else).
    pub fn new(scene: &Scene) -> Result<Self, BuildError> {
        let mut geometry = Vec::with_capacity(scene.chains.len());
        for spec in &scene.chains {
            let g = match (spec.dims, spec.precision) {
                (2, crate::scene::Precision::F32) => build(spec).map(Geometry::Planar32),
                (2, _) => build(spec).map(Geometry::Planar64),
                (_, crate::scene::Precision::F32) => build(spec).map(Geometry::Spatial32),
                _ => build(spec).map(Geometry::Spatial64),
            }
            .map_err(|source| BuildError::Chain {
                name: spec.name.clone(),
                source,
            })?;
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
            pull_budget: scene.pull_budget,
            undo: None,
            owners: Owners::new(scene.chains.len()),
            last_work: 0,
            namers: scene
                .chains
                .iter()
                .map(|c| c.knot.then(knots::Namer::new))
                .collect(),
            knot_points: Vec::new(),
            #[cfg(test)]
            panic_after_kernel: false,
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

    /// Sets the most work one pull may cost, in link-steps (`None`: the request's budget; never more
    /// than it): the scene's `pull_budget` unless a service option overrides it.
    pub fn set_pull_budget(&mut self, link_steps: Option<u64>) {
        self.pull_budget = link_steps.map(|b| b.max(1));
    }

    /// The budget of one pull, in link-steps: the pull budget, at most the request's.
    pub fn pull_budget(&self) -> u64 {
        crate::apply::pull_cap(self.pull_budget, self.budget)
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
        each_form!(&self.geometry[chain as usize], h => {
            crate::apply::estimate(h, &self.specs[chain as usize], req)
        })
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
    /// What each chain's contact resolutions did since its state was made (the service's start or
    /// the snapshot it restored): `(handle, statistics)` for every chain with collision handling.
    pub fn resolution_stats(&self) -> Vec<(u32, tractrix::collision::ResolutionStats)> {
        self.geometry
            .iter()
            .enumerate()
            .filter_map(|(k, g)| {
                each_form!(g, h => h.collision.as_ref().map(|(_, ws)| ws.stats()))
                    .map(|s| (k as u32, s))
            })
            .collect()
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
    pub(crate) fn install(&mut self, geometry: Vec<Geometry>, sequence: u64) {
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
    /// The sizes the ports must hold: the most elements in a response (joints, rotations, held joints,
    /// instruments and pulls of the largest chain) and the most in a state sample (the same without
    /// rotations).
    pub fn response_sizes(&self) -> (usize, usize) {
        let mut most = (1, 1);
        for (spec, g) in self.specs.iter().zip(&self.geometry) {
            let links = spec.lengths.len();
            let instruments = each_form!(g, h => h.instruments().len());
            // Eyelets (the scene's, and those a needle makes in tissue) and the tissue's corners.
            let eyelets = if !spec.eyelets.is_empty() || spec.tissue.is_some() {
                2 * crate::sizes::MAX_EYELETS + 2
            } else {
                0
            };
            let tail =
                2 * crate::sizes::MAX_HELD + (INSTRUMENT_ELEMENTS + 1) * instruments + eyelets;
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
        if let Command::Move {
            targets,
            pull: true,
            ..
        } = *req
            && targets.len() != 1
        {
            return Err(refuse!(
                BadPointCount,
                "a pull takes one target, not {}",
                targets.len()
            ));
        }
        if let Command::Move {
            chain,
            joint,
            targets,
            options,
            take_over,
            smooth: true,
            pull,
            needle,
        } = *req
        {
            let (samples, options) = self.smooth_samples(chain, joint, targets, &options)?;
            let straight = Command::Move {
                chain,
                joint,
                targets: &samples,
                options,
                take_over,
                smooth: false,
                pull,
                needle,
            };
            return self.apply_for(client, &straight);
        }
        self.undo = None;
        self.owners.begin();
        self.owners.check(client, req)?;
        let mut outcome = self.apply_checked(req)?;
        if let Some(chain) = req.chain() {
            self.owners
                .record(client, req, &self.specs[chain as usize].anchors);
        }
        if let Some(chain) = outcome.chain {
            outcome.knot = self.name_knot(chain);
        }
        Ok(outcome)
    }

    /// The knot of `chain` as it is now, for a chain whose scene asks for it (`None` otherwise):
    /// named by the chain's own [`knots::Namer`], so a state whose reduced diagram it has
    /// named before costs a projection and a lookup (BENCHMARKS, "The knot's name with every state").
    pub fn name_knot(&mut self, chain: u32) -> Option<knots::KnotType> {
        let namer = self.namers.get_mut(chain as usize)?.as_mut()?;
        let points = &mut self.knot_points;
        points.clear();
        each_form!(&self.geometry[chain as usize], h => {
            points.extend(h.chain.joints().map(|p| to_point(&p)));
        });
        Some(namer.name(points))
    }

    /// A smooth path's samples: the natural cubic spline through the joint and `targets`, each
    /// segment sampled into as many points as it would take substeps (fixed substeps: that many, each
    /// then one substep; a longest step: its chord over the step). Refused, changing nothing, when a
    /// segment needs more than the chain's substep limit or a sample lies beyond the chain's
    /// coordinate range.
    fn smooth_samples(
        &self,
        chain: u32,
        joint: usize,
        targets: &[Point],
        options: &MoveOptions<f64>,
    ) -> Result<(Vec<Point>, MoveOptions<f64>), Refusal> {
        let spec = &self.specs[chain as usize];
        let from: Point =
            each_form!(&self.geometry[chain as usize], h => to_point(&h.chain.joint(joint)));
        let mut keys = Vec::with_capacity(targets.len() + 1);
        keys.push(from);
        keys.extend_from_slice(targets);
        // Samples of a segment: as many as its substeps would be (at least one).
        let per_chord = |chord: f64| -> f64 {
            match options.substeps {
                Substeps::Fixed(k) => f64::from(k),
                Substeps::MaxStep(s) => (chord / (s * spec.shortest)).ceil().max(1.0),
            }
        };
        // Bounded before anything is allocated: each segment by the substep limit, and every
        // sample is at least one substep over the chain's links, so a path whose samples alone
        // pass the budget is refused here.
        let limit = options.max_substeps;
        let mut count = 0u64;
        for w in keys.windows(2) {
            let k = per_chord((w[1] - w[0]).norm());
            if k.is_nan() || k > f64::from(limit) {
                return Err(ChainError::TooManySubsteps {
                    required: if k.is_finite() { k as u64 } else { u64::MAX },
                    limit,
                }
                .into());
            }
            count = count.saturating_add(k as u64);
        }
        let work = count.saturating_mul(spec.lengths.len() as u64);
        if work > self.budget {
            return Err(refuse!(
                OverBudget,
                "about {work:.2e} link-steps, over the budget of {:.2e} (--budget)",
                self.budget as f64
            ));
        }
        let mut samples = Vec::new();
        tractrix::path::spline_samples(&keys, |_, chord| per_chord(chord) as usize, &mut samples);
        if spec.kind == ChainKind::Free
            && let Some((i, p)) = samples
                .iter()
                .enumerate()
                .find(|(_, p)| p.amax() > spec.max_coordinate)
        {
            return Err(refuse!(
                TooFar,
                "smooth path sample {i}: {:.3e} is beyond {:.3e}",
                p.amax(),
                spec.max_coordinate
            ));
        }
        let mut options = *options;
        if let Substeps::Fixed(_) = options.substeps {
            options.substeps = Substeps::Fixed(1);
        }
        Ok((samples, options))
    }

    /// [`World::apply_for`] behind a guard, the way every door answers: a panic inside (a kernel
    /// bug) is caught, the change that was being made is undone (chains; a bundle keeps what its
    /// sweep did), and the command is refused as `Internal`.
    pub fn apply_guarded(&mut self, client: u128, req: &Command<'_>) -> Result<Answer, Refusal> {
        let world = &mut *self;
        match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            world.apply_for(client, req)
        })) {
            Ok(r) => r,
            Err(_) => {
                self.undo();
                Err(refuse!(
                    Internal,
                    "internal error in the solver; state kept"
                ))
            }
        }
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
        if let Command::Bundle { handle, index, op } = *req {
            let b = &mut self.bundles[index];
            crate::apply::within_budget(crate::bundles::estimate(&b.spec, &op), self.budget)?;
            let substeps = b.apply(&op)?;
            return Ok(Answer {
                chain: Some(handle),
                changed: op.changes_state(),
                counts: Counts {
                    joints: b.spec.joints() as u32,
                    ..Counts::default()
                },
                substeps,
                describe: op == BundleOp::Describe,
                bundle: true,
                ..Answer::default()
            });
        }
        let Some(chain) = req.chain() else {
            return Ok(Answer::default());
        };
        let World {
            specs,
            geometry,
            budget,
            pull_budget,
            undo,
            sequence,
            last_work,
            ..
        } = self;
        let cx = crate::apply::Context {
            chain,
            spec: &specs[chain as usize],
            budget: *budget,
            pull_budget: *pull_budget,
            sequence: *sequence,
            undo,
            last_work,
        };
        let result =
            each_form!(&mut geometry[chain as usize], h => crate::apply::apply(h, req, cx));
        #[cfg(test)]
        if std::mem::take(&mut self.panic_after_kernel) {
            panic!("injected: a kernel bug after the chain moved");
        }
        if result.as_ref().is_ok_and(|a| a.changed) {
            self.sequence += 1;
        }
        result
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

    /// The payload of an answer about `handle` laid out as `counts` says (the answer's): a chain's
    /// joints (tail first), then the rotation vectors (joint 0: from +x to link 1; joint i: from link
    /// i to link i+1), held joints, instruments, pulls, eyelets and tissue (a describe's: the block's
    /// corners) that it counts; a bundle's joints. Written in order, with no intermediate buffer;
    /// nothing for an unknown handle or an empty layout.
    pub fn elements_for(&self, handle: u32, counts: &Counts) -> Elements<'_> {
        if counts.elements() == 0 {
            return Elements::Empty;
        }
        if let Some((_, b)) = self.bundle_of(handle) {
            return Elements::Bundle(b.elements());
        }
        self.elements_wanting(handle, counts.into())
    }

    /// A chain's joints, then its joint rotations with `angles` (nothing for an unknown chain).
    pub fn elements_of(&self, chain: u32, angles: bool) -> Elements<'_> {
        self.elements_with(chain, angles, false, false, (false, false))
    }

    /// A chain's joints, its rotations with `angles`, its held joints with `held` (index, 1 for an
    /// anchor and 0 for a grasp, 1 if the stretch to the next held joint is taut), its instruments
    /// with `instruments` (the wire's three elements each: [`INSTRUMENT_ELEMENTS`]), its pulls with
    /// `pulls` (one per held joint, then one per instrument: [`crate::tension`]), its eyelets with
    /// `eyelets` (two elements each: the point, then `(link, 1 threaded / 0 left, 0)`).
    pub fn elements_with(
        &self,
        chain: u32,
        angles: bool,
        held: bool,
        instruments: bool,
        (pulls, eyelets): (bool, bool),
    ) -> Elements<'_> {
        self.elements_wanting(
            chain,
            Wants {
                angles,
                held,
                instruments,
                pulls,
                eyelets,
                tissue: false,
            },
        )
    }

    /// The elements [`World::elements_with`] lists, and the chain's tissue with `wants.tissue`.
    fn elements_wanting(&self, chain: u32, wants: Wants) -> Elements<'_> {
        let (Some(g), Some(spec)) = (
            self.geometry.get(chain as usize),
            self.specs.get(chain as usize),
        ) else {
            return Elements::Empty;
        };
        let a = &spec.anchors[..];
        match g {
            Geometry::Planar64(h) => Elements::Planar64(ChainElements::new(h, wants, a)),
            Geometry::Spatial64(h) => Elements::Spatial64(ChainElements::new(h, wants, a)),
            Geometry::Planar32(h) => Elements::Planar32(ChainElements::new(h, wants, a)),
            Geometry::Spatial32(h) => Elements::Spatial32(ChainElements::new(h, wants, a)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::Point;
    use crate::refusal::Cause;
    use crate::scene::default_scene;

    /// The head of the default rope moved to `t`.
    fn head_to<'a>(w: &World, t: &'a [Point]) -> Command<'a> {
        Command::Move {
            chain: 0,
            joint: 40,
            targets: t,
            options: w.specs()[0].moves,
            take_over: false,
            smooth: false,
            pull: false,
            needle: crate::command::NeedleMove::Carried,
        }
    }

    /// A panic inside a command (injected after the kernel moved the chain) is refused as `Internal`,
    /// and the world is as it was: the chain, the sequence number, and what the next command does.
    #[test]
    fn a_panic_inside_a_command_is_refused_and_undone() {
        let (a, b) = ([Point::new(30.0, 4.0, 1.0)], [Point::new(33.0, -2.0, 0.5)]);
        let mut w = World::new(&default_scene()).unwrap();
        w.apply(&head_to(&w, &a)).unwrap();
        let before = w.state();
        w.panic_after_kernel = true;
        let e = w.apply_guarded(LOCAL, &head_to(&w, &b)).unwrap_err();
        assert_eq!(e.cause, Cause::Internal, "{}", e.reason());
        assert_eq!(w.state(), before);
        // The same command again does what it would have done.
        let mut fresh = World::new(&default_scene()).unwrap();
        fresh.apply(&head_to(&fresh, &a)).unwrap();
        fresh.apply(&head_to(&fresh, &b)).unwrap();
        w.apply_guarded(LOCAL, &head_to(&w, &b)).unwrap();
        assert_eq!(w.state(), fresh.state());
    }
}
