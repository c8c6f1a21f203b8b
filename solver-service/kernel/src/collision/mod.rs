//! Collision handling for free chains: self-collision and static obstacles, two schemes.
//!
//! A knot survives in a tractrix rope only if the rope cannot pass through itself: tractrix trailing cuts
//! corners, so without collision handling a loop shrinks until the strand through it slips out. A move
//! with collision runs substep by substep; after each substep's tractrix sweep the links are checked and,
//! where two of them (or a link and an obstacle) are closer than their clearance, pushed apart; the chain
//! is then re-straightened to its exact link lengths by a follow-the-leader pass *outward from the grasped
//! joint* (which never moves: the hand holds it on its path). This repeats until no contact is deeper than
//! [`CollisionOptions::tolerance`] of its clearance, or up to [`CollisionOptions::max_iterations`]; a chain
//! still in contact then is *locked* (the paper's word) and the whole move is refused, the chain unchanged.
//!
//! # Schemes
//!
//! * [`Scheme::PaperSpheres`], section 4.2 as printed: a bounding sphere per link (centre at the link's
//!   middle, diameter the link's length); two non-adjacent links collide when their centres are closer
//!   than `(lᵢ + lⱼ)/2`, and the colliding link (the one farther from the hand) is moved along the common
//!   normal until they are just apart. All pairs are tested, O(n²), as in the paper. The spheres are as
//!   thick as a link is long: a rope of unit links behaves as a rope one unit thick.
//! * [`Scheme::Capsules`]: each link is a capsule of diameter [`CollisionOptions::thickness`] (the rope's
//!   real thickness); two links collide when their axes are closer than one thickness, unless there is
//!   less than a thickness of rope between them ([`neighbour_span`]: only adjacent links when the links
//!   are longer than the rope is thick). The
//!   contact pushes the four joints along the common normal in proportion to where the closest points
//!   lie on each link (the grasped joint does not move). Candidate pairs come from a bounding-volume
//!   tree over the chain whose shape never changes (leaves of four consecutive links, refitted every
//!   pass in O(n)), so detection costs O(n) for a rope that is not piled into a ball.
//!
//! # Guarantees
//!
//! After every substep of a successful move, every contact is within `tolerance × clearance` (the
//! clearance of a capsule pair is the thickness; of a link and an obstacle, the sum of their radii). With
//! collision on, a move is also split so that the grasped joint moves at most half a clearance per
//! substep: tractrix links trail their heads by less than the head moves, so two links approach each
//! other by at most one clearance per substep and cannot tunnel through each other between checks.
//! When nothing touches, a move with collision handling gives bit for bit the chain a move without it
//! gives.

//! # Modules
//!
//! [`query`]: distances and closest points (point–segment, segment–segment, link pairs, obstacles);
//! `tree`: the bounding-volume tree over the chain that finds candidate pairs; `resolve`: one resolution pass over the
//! contacts; `held`: a held rope's moves among its contacts; `push`: an instrument moved against the
//! rope; `clearance`: the smallest clearance kept, the re-straightening, the neighbour span; this module: the options, the model and the driver that moves a joint with collision.

mod clearance;
mod held;
mod project;
mod push;
pub mod query;
mod relax;
mod resolve;
mod tree;

use crate::chain::{Chain, ChainError, MoveOptions, MoveOutcome, Short};
use crate::math::{CompensatedSum, Embed3, Real, Vector, all_finite, positive_finite};
pub use query::{
    closest_links_apart, closest_nonadjacent_links, closest_param_point_segment,
    closest_params_segment_segment,
};
use resolve::resolve;
use tree::ChainTree;

pub use clearance::*;
use held::*;
pub use push::*;

/// Which collision test and response a chain uses (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// Section 4.2 as printed: one bounding sphere per link, all pairs, the colliding link moved.
    PaperSpheres,
    /// Capsules of the rope's thickness, a tree of boxes over the chain, contact pushes weighted along
    /// the links.
    Capsules,
}

/// A static obstacle, in the chain's coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Obstacle<T: Real, const D: usize> {
    /// A ball (a disc in a planar scene).
    Sphere {
        /// Centre.
        center: Vector<T, D>,
        /// Radius, positive.
        radius: T,
    },
    /// The set of points within `radius` of the segment `a`–`b` (a post, a tool shaft).
    Capsule {
        /// One end of the axis.
        a: Vector<T, D>,
        /// The other end of the axis.
        b: Vector<T, D>,
        /// Radius, positive.
        radius: T,
    },
    /// The half-space behind a plane (a table): the chain stays on the side `normal` points to.
    HalfSpace {
        /// A point of the plane.
        point: Vector<T, D>,
        /// Unit normal, pointing to the free side.
        normal: Vector<T, D>,
    },
    /// An axis-aligned block (a slab of tissue): the chain stays outside it, except the links that
    /// pass through it between the eyelets on its surface (a stitch's bite,
    /// [`CollisionWorkspace::pass_through`]).
    Block {
        /// The corner with the smallest coordinates.
        lo: Vector<T, D>,
        /// The corner with the largest coordinates.
        hi: Vector<T, D>,
    },
}

/// Knobs of collision handling. Each trades speed for how strictly links are kept apart; what each
/// buys is measured by `cargo bench -p tractrix --bench collision` and the contact bench
/// (BENCHMARKS.md), and what was tried on the way is in docs/history.md.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollisionOptions<T> {
    /// Test and response. Default [`Scheme::Capsules`].
    pub scheme: Scheme,
    /// Whether links collide with each other (obstacles are tested whenever any are given). Default
    /// `true`.
    pub self_collision: bool,
    /// Rope diameter for [`Scheme::Capsules`], in length units, positive; default 0.2. Ignored by
    /// [`Scheme::PaperSpheres`] (a link's sphere is as wide as the link is long). A substep moves the
    /// grasped joint at most half a clearance, so a thicker rope takes more substeps.
    pub thickness: T,
    /// Resolution passes allowed per substep before the move is locked, at least 1; default 64.
    /// Fewer cost less and lock more moves; a jammed knot spends all of them before it is refused.
    pub max_iterations: u32,
    /// Penetration accepted, as a fraction of each pair's clearance, in `(0, 1)`; default 0.01 (links
    /// within 1 % of a thickness). Smaller is stricter and costs more passes.
    pub tolerance: T,
    /// How far each contact is pushed, as a multiple of its depth (plus half the tolerance), in
    /// `[1, 2)`; default 1.5 (successive over-relaxation: a jammed knot's passes converge in fewer
    /// passes than at 1, where they creep toward the tolerance). A contact is left at most its depth
    /// farther apart than it need be. On a chain with held joints the extra push is capped at the
    /// tolerance.
    pub over_relaxation: T,
    /// On a rope with held joints, the inverse mass of the joints a pass pushed when the rope between
    /// the fixed joints is relaxed back to its lengths, in `(0, 1]`; default 1 (like every other
    /// joint). Smaller leaves more of a push in place and takes the length from the rope around it:
    /// fewer passes, more moves locked and, too small, other knots tied. Not used in pulls, where the
    /// contacts and lengths are solved together.
    pub pushed_weight: T,
    /// On a rope with held joints, the passes of pushes after which a move's contacts and lengths are
    /// solved together (the joint projection, docs/kernel.md) while the contacts have not parted, up
    /// to [`MAX_TOGETHER_AFTER`]; default 2; 0: never on plain moves. Not on a rope through eyelets;
    /// pulls always use it after two passes.
    pub together_after: u32,
}

/// The largest [`CollisionOptions::together_after`].
pub const MAX_TOGETHER_AFTER: u32 = 4096;

impl<T: Real> Default for CollisionOptions<T> {
    fn default() -> Self {
        CollisionOptions {
            scheme: Scheme::Capsules,
            self_collision: true,
            thickness: T::lit(0.2),
            max_iterations: 64,
            tolerance: T::lit(0.01),
            over_relaxation: T::lit(1.5),
            pushed_weight: T::one(),
            together_after: 2,
        }
    }
}

impl<T: Real> CollisionOptions<T> {
    /// Checks the options (positive thickness for capsules, tolerance in `(0, 1)`, over-relaxation in
    /// `[1, 2)`, pushed joints' weight in `(0, 1]`, at least one pass).
    pub fn validate(&self) -> Result<(), ChainError> {
        if self.scheme == Scheme::Capsules && !positive_finite(self.thickness) {
            return Err(ChainError::BadOption(
                "collision thickness must be a positive finite length",
            ));
        }
        if !(self.tolerance > T::zero() && self.tolerance < T::one()) {
            return Err(ChainError::BadOption(
                "collision tolerance must lie strictly between 0 and 1",
            ));
        }
        if !(self.over_relaxation >= T::one() && self.over_relaxation < T::lit(2.0)) {
            return Err(ChainError::BadOption(
                "collision over-relaxation must lie in [1, 2)",
            ));
        }
        if !(self.pushed_weight > T::zero() && self.pushed_weight <= T::one()) {
            return Err(ChainError::BadOption(
                "collision pushed-joint weight must lie in (0, 1]",
            ));
        }
        if self.together_after > MAX_TOGETHER_AFTER {
            return Err(ChainError::BadOption(
                "collision together-after must be at most 4096 passes",
            ));
        }
        if self.max_iterations == 0 {
            return Err(ChainError::BadOption(
                "collision needs at least one iteration",
            ));
        }
        Ok(())
    }
}

/// What a chain collides with: options plus obstacles, built once per chain from its scene.
#[derive(Clone, Debug, PartialEq)]
pub struct CollisionModel<T: Real, const D: usize> {
    /// Scheme and knobs.
    pub options: CollisionOptions<T>,
    /// Static obstacles this chain avoids.
    pub obstacles: Vec<Obstacle<T, D>>,
    /// Links an obstacle holds (an instrument's jaws around a grasped joint): never tested against it.
    pub holding: Vec<Holding>,
}

/// Links `links` (link `i` joins joints `i` and `i + 1`) that obstacle `obstacle` holds: they touch it
/// by design and are not tested against it; every other link is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Holding {
    /// Index into [`CollisionModel::obstacles`].
    pub obstacle: usize,
    /// The links it holds.
    pub links: core::ops::Range<usize>,
}

/// Caller-owned buffers reused across moves (after the first move of a chain, a move with collision
/// allocates nothing), and the work meter of the calls made with it ([`CollisionWorkspace::limit_work`]).
#[derive(Clone, Debug, Default)]
pub struct CollisionWorkspace<T: Real, const D: usize> {
    pos: Vec<Vector<T, D>>,
    /// The joints before a substep of a move with holds (the displacement guard).
    pos_before: Vec<Vector<T, D>>,
    /// The joints after a resolution's previous pass (its settled passes lock).
    pos_prev: Vec<Vector<T, D>>,
    backup_links: Vec<Vector<T, D>>,
    /// The links after the last whole substep (a move that may stop short keeps it).
    made_links: Vec<Vector<T, D>>,
    /// Moves stop short at their last whole substep instead of being refused
    /// ([`CollisionWorkspace::stop_short`]).
    frame: bool,
    tree: ChainTree<T, D>,
    meter: Meter,
    projection: project::Projection<T, D>,
    /// Solve the contacts of a rope with held joints together with its lengths after its first
    /// passes ([`project`]).
    together: bool,
    /// Links that pass through the blocks ([`CollisionWorkspace::pass_through`]).
    through: core::ops::Range<usize>,
    /// How many links either side of `through` only keep their axis out of the blocks.
    pressed: usize,
    /// The joints a resolution pass pushed (held ropes: the relaxation that follows keeps them).
    pushed: Vec<bool>,
    /// The capsule pairs kept from pass to pass ([`tree::NearPairs`]).
    near: tree::NearPairs<T, D>,
    /// What the resolutions did since the workspace was made ([`CollisionWorkspace::stats`]).
    stats: ResolutionStats,
    /// A pull's resolution that ran out of work, kept to be resumed ([`Unfinished`]).
    unfinished: Unfinished<T, D>,
}

/// A pull's resolution that ran out of work before its contacts were clear, kept at its last pass
/// so that the next pull of the same joint toward the same target, from the same state, goes on
/// from there instead of doing the same passes again (issue 38: on a knot pulled tight the passes
/// creep, and a resolution that needs more than one request's work budget was never finished: the
/// same request was refused the same way each time). Only the move of a single substep that
/// [`CollisionWorkspace::keep_unfinished`] asks for records its passes; a resumed resolution goes
/// on with the passes' counts where they were (the pass limit and the settled passes count across
/// requests), its candidate pairs found afresh.
#[derive(Clone, Debug, Default)]
struct Unfinished<T: Real, const D: usize> {
    /// Whether the moves that follow record their resolution and resume a matching one.
    keep: bool,
    /// Whether the resolution running now records its passes.
    recording: bool,
    /// Whether a pass has been recorded since recording began.
    recorded: bool,
    /// Whether the fields below describe a resolution that can be resumed.
    ready: bool,
    /// The resumed resolution locked, or moved a joint too far: the same move from the same state
    /// is refused so again at once, with no work (the passes would only repeat).
    locked: Option<ChainError>,
    /// The counts a resumed resolution starts from (taken by its first pass).
    resume_at: Option<resolve::PassState>,
    joint: usize,
    target: Vec<Vector<T, D>>,
    /// How far a target may be from `target` and resume the resolution (a quarter of the smallest
    /// clearance).
    drift: T,
    held: Vec<usize>,
    /// The joints where the move started: the state it resumes from.
    base: Vec<Vector<T, D>>,
    /// How many times the recorded piece's substep was halved (0: a whole substep).
    depth: u32,
    /// A resumed pull whose passes finished but moved a joint more than half the smallest
    /// clearance: the next move of `joint` from `base` does that piece (its hand `target[0]`) as
    /// two halves of this depth, each recorded, as a fresh pull's substep that jumps is split
    /// ([`held::move_held_colliding`]), then goes on toward its own target.
    halve: Option<u32>,
    /// The chain and its joints after the last recorded pass, and the passes' counts there.
    chain: Option<Chain<T, D>>,
    pos: Vec<Vector<T, D>>,
    state: resolve::PassState,
}

impl<T: Real, const D: usize> Unfinished<T, D> {
    /// The recorded passes can be resumed by the same move (`joint` to `target` with `held` held,
    /// from the joints `base`).
    fn ready_for(
        &mut self,
        joint: usize,
        target: Vector<T, D>,
        held: &[usize],
        base: &[Vector<T, D>],
        (drift, depth): (T, u32),
    ) {
        self.ready = true;
        self.drift = drift;
        self.depth = depth;
        self.halve = None;
        self.locked = None;
        self.joint = joint;
        self.target.clear();
        self.target.push(target);
        self.held.clear();
        self.held.extend_from_slice(held);
        self.base.clear();
        self.base.extend_from_slice(base);
    }

    /// Records the chain after a pass (its joints `pos`, the passes' counts `state`).
    fn record(&mut self, chain: &Chain<T, D>, pos: &[Vector<T, D>], state: resolve::PassState)
    where
        Vector<T, D>: Embed3<T>,
    {
        match &mut self.chain {
            Some(c) => c.copy_from(chain),
            None => self.chain = Some(chain.clone()),
        }
        self.pos.clear();
        self.pos.extend_from_slice(pos);
        self.state = state;
        self.recorded = true;
    }

    /// Whether a move of `joint` of `chain` to `target` is the one recorded: the same joint and held
    /// joints, a target within the drift of the recorded one, from the same joints bit for bit
    /// (written to `now`, a buffer).
    fn matches(
        &self,
        chain: &Chain<T, D>,
        joint: usize,
        target: &Vector<T, D>,
        now: &mut Vec<Vector<T, D>>,
    ) -> bool
    where
        Vector<T, D>: Embed3<T>,
    {
        if !(self.ready && self.same_start(chain, joint, now)) {
            return false;
        }
        // A hand's target wanders (a tremor, a haptic device) and moves on: the recorded piece is
        // resumed when its hand is within the drift of the new target, or (unless it locked) brings
        // the joint nearer the new target than it is.
        let Some(h) = self.target.first() else {
            return false;
        };
        let (left, now_left) = ((h - target).norm(), (now[joint] - target).norm());
        left <= self.drift || (self.locked.is_none() && left < now_left)
    }

    /// Whether `chain` stands where the recorded move started (`base`, bit for bit, written to
    /// `now`), with the same joint moved and the same joints held.
    fn same_start(&self, chain: &Chain<T, D>, joint: usize, now: &mut Vec<Vector<T, D>>) -> bool
    where
        Vector<T, D>: Embed3<T>,
    {
        if !(self.joint == joint
            && self
                .held
                .iter()
                .copied()
                .eq(chain.held().filter(|&j| j != joint)))
        {
            return false;
        }
        now.resize(chain.n_links() + 1, Vector::zeros());
        chain.write_positions(now);
        self.base == *now
    }

    /// The piece a move of `joint` of `chain` toward `target` does first as two halves
    /// ([`Unfinished::halve`]): its hand and the halves' depth, when the chain stands where it
    /// started and that hand is within the drift of `target` or brings the joint nearer it.
    fn halving(
        &self,
        chain: &Chain<T, D>,
        joint: usize,
        target: &Vector<T, D>,
        now: &mut Vec<Vector<T, D>>,
    ) -> Option<(Vector<T, D>, u32)>
    where
        Vector<T, D>: Embed3<T>,
    {
        let depth = self.halve?;
        let hand = *self.target.first()?;
        if !self.same_start(chain, joint, now) {
            return None;
        }
        let (left, now_left) = ((hand - target).norm(), (now[joint] - target).norm());
        (left <= self.drift || left < now_left).then_some((hand, depth))
    }
}

/// Counts of what a workspace's contact resolutions did since it was made: where a chain's collision
/// time goes (a scene's slow moves are the resolutions of many passes, and on a rope with held joints
/// the joint projections that stall). Counting costs a few additions per pass; the service prints
/// each chain's at shutdown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ResolutionStats {
    /// Resolutions run (one per substep of a move with collision, and per push of an instrument).
    pub resolutions: u64,
    /// Passes that pushed something, over all resolutions.
    pub passes: u64,
    /// Resolutions of [`ResolutionStats::LONG`] passes or more (stopped short or not).
    pub long: u64,
    /// Joint projections of a rope with held joints (contacts and lengths solved together).
    pub projections: u64,
    /// Of those, the ones that converged (their pose kept).
    pub converged: u64,
    /// The ones that stalled, ran out of Newton steps or had too many contacts (the passes went on
    /// from the pose before them).
    pub stalled: u64,
    /// Newton steps taken by all projections.
    pub newton_steps: u64,
}

impl ResolutionStats {
    /// Passes from which a resolution counts as long.
    pub const LONG: u64 = 32;
}

impl<T: Real, const D: usize> CollisionWorkspace<T, D> {
    /// An empty workspace (buffers grow on first use), its work unlimited.
    pub fn new() -> Self {
        CollisionWorkspace::default()
    }

    /// What this workspace's resolutions did since it was made.
    pub fn stats(&self) -> ResolutionStats {
        self.stats
    }

    /// Limits the work of the calls that follow ([`move_joint_colliding`], [`push_by_obstacle`]), in
    /// total, to `link_steps`, and starts counting from zero. The work is counted in link-steps, the
    /// cost of one link following its tractrix once, and charged *before* it is done: every tractrix
    /// sweep (one per link per substep), every held side's solve (its bound,
    /// [`ReachOptions::passes_bound`]), and each collision pass's tree (an eighth per link to refit
    /// it, a sixteenth per pair of boxes tested), candidate pairs (three eighths per pair tested, and
    /// a link-step and three eighths more for the closest points of a pair whose boxes meet; the
    /// paper's spheres all pairs at once), obstacles (three eighths of a link-step per link per
    /// obstacle, three link-steps for a block), re-straightening (one per link), relaxation
    /// iterations (half a link-step per link) and re-solves (four per link per iteration, the
    /// iterations capped by what is left). A call that would pass the limit stops before it, leaves
    /// the chain unchanged and returns [`ChainError::OverWork`]; so the work done never exceeds the
    /// limit, whatever the chain, the scene's `max_iterations` or the contacts.
    ///
    /// [`ReachOptions::passes_bound`]: crate::ReachOptions::passes_bound
    pub fn limit_work(&mut self, link_steps: u64) {
        self.meter = Meter {
            limit: link_steps.saturating_mul(cost::LINK_STEP),
            done: 0,
        };
    }

    /// Whether the calls that follow treat a rope with held joints as a knot under tension: its
    /// contacts solved together with its lengths once the first passes have not parted them (the
    /// joint projection: passes of single pushes only creep there), and no substep that moves a joint
    /// more than half the smallest clearance (split in halves, at most 16 pieces, else locked: no
    /// link carried through another). The service's pulls (`FLAG_PULL`, a tightening) turn it on;
    /// off by default, where the passes alone tie the built-in knots (with the projection on every
    /// move the instrument ties at 160 links locked many of their moves, and with the guard the ties
    /// on unit links failed).
    pub fn solve_contacts_together(&mut self, on: bool) {
        self.together = on;
    }

    /// Links `links` pass through the model's blocks ([`Obstacle::Block`]: a suture between the
    /// eyelets of its bite, and from the last one to a needle still in the tissue) and are not tested
    /// against them; the `pressed` links either side of them press into the block by up to the
    /// rope's radius (only their axis is kept out of it: tissue gives round a hole, and a suture
    /// drawn out of a hole at a shallow angle lies on it); every other link keeps its radius from
    /// it. The eyelets' moves ([`crate::eyelet`]) set them from the rope before each resolution;
    /// empty by default (a block is solid).
    pub fn pass_through(&mut self, links: core::ops::Range<usize>, pressed: usize) {
        self.through = links;
        self.pressed = pressed;
    }

    /// Whether the moves that follow keep a resolution that runs out of work, and resume it: each
    /// substep of a move of a rope with held joints records its passes; when the work runs out in
    /// one, the move stops short before it (inside a frame, [`CollisionWorkspace::stop_short`]) or
    /// is refused ([`ChainError::OverWork`], the chain unchanged), and the next move of the same
    /// joint from the state it left, toward a target within a quarter of the smallest clearance of
    /// that substep's hand or one that substep brings the joint nearer to, goes on from its last
    /// pass, then on toward its own target (a locked one is refused so again at once when the
    /// target is within that quarter, with no work). Any other state of the chain (another move
    /// made, a hold taken or let go) makes it stale. Off by default.
    pub fn keep_unfinished(&mut self, on: bool) {
        self.unfinished.keep = on;
    }

    /// Whether a move of `joint` of `chain` to `target` would resume an unfinished resolution
    /// ([`CollisionWorkspace::keep_unfinished`]).
    pub fn can_resume(&mut self, chain: &Chain<T, D>, joint: usize, target: &Vector<T, D>) -> bool
    where
        Vector<T, D>: Embed3<T>,
    {
        self.unfinished
            .matches(chain, joint, target, &mut self.pos_before)
    }

    /// The piece a move of `joint` to `target` starts with in halves ([`Unfinished::halve`]).
    fn halving(
        &mut self,
        chain: &Chain<T, D>,
        joint: usize,
        target: &Vector<T, D>,
    ) -> Option<(Vector<T, D>, u32)>
    where
        Vector<T, D>: Embed3<T>,
    {
        self.unfinished
            .halving(chain, joint, target, &mut self.pos_before)
    }

    /// Whether the calls that follow ([`move_joint_colliding`], [`push_by_obstacle`] and the
    /// threaded moves with collision) answer a move that cannot be finished with the best valid
    /// state it reached instead of refusing it: when a substep runs out of work, locks, finds a held
    /// side out of reach or a joint past its limit, the chain is left as the last whole substep left
    /// it and the outcome says why ([`MoveOutcome::short`]). A haptic device's request inside its
    /// frame: the joint stays behind its target, a proxy. Bad input is refused as before. Off by
    /// default.
    pub fn stop_short(&mut self, on: bool) {
        self.frame = on;
    }

    /// Whether [`CollisionWorkspace::stop_short`] is on.
    pub fn stops_short(&self) -> bool {
        self.frame
    }

    /// Whether [`CollisionWorkspace::keep_unfinished`] is on.
    pub(crate) fn keeps_unfinished(&self) -> bool {
        self.unfinished.keep
    }

    /// Lets the calls that follow spend only `1/parts` of the work left; the limit to give back to
    /// [`CollisionWorkspace::give_back`] after them.
    pub(crate) fn hold_back(&mut self, parts: u64) -> u64 {
        let limit = self.meter.limit;
        self.meter.limit = self.meter.done + self.meter.left() / parts.max(1);
        limit
    }

    /// Puts back the limit [`CollisionWorkspace::hold_back`] returned.
    pub(crate) fn give_back(&mut self, limit: u64) {
        self.meter.limit = limit;
    }

    /// Whether [`CollisionWorkspace::solve_contacts_together`] is on (a pull).
    pub(crate) fn together(&self) -> bool {
        self.together
    }

    /// The work charged since the last [`CollisionWorkspace::limit_work`] (or since the workspace was
    /// made), in link-steps (rounded up).
    pub fn work(&self) -> u64 {
        self.meter.done.div_ceil(cost::LINK_STEP)
    }
}

/// What each unit of collision work is charged, in sixteenths of a link-step (one link following its
/// tractrix once): set from the time each takes beside a tractrix link-step, rounded up (the
/// tree's refit and box tests from the free path of `cargo bench -p tractrix --bench collision`,
/// where they are all the work a pass does). `cargo bench -p solver-service --bench budget`
/// (BENCHMARKS.md, "Every request inside its budget") checks that no request takes longer than its
/// budget's time.
pub(super) mod cost {
    /// A link-step: one link of a tractrix sweep.
    pub const LINK_STEP: u64 = 16;
    /// Refitting the tree's boxes, per link.
    pub const REFIT_PER_LINK: u64 = 2;
    /// One pair of the tree's boxes tested.
    pub const NODE_PAIR: u64 = 1;
    /// One capsule pair tested: the box test that parts most candidates.
    pub const CAPSULE_PAIR: u64 = 6;
    /// The closest points of a capsule pair whose boxes meet, its distance and the push: timed (by
    /// `perf`) on a rope crumpled by random moves, where most candidates need them, at about 50 ns
    /// on an AMD EPYC whose plain link-step takes 37–50 ns, rounded up.
    pub const CLOSEST: u64 = 22;
    /// One pair of the paper's spheres tested.
    pub const SPHERE_PAIR: u64 = 2;
    /// One link tested against one obstacle.
    pub const OBSTACLE_PER_LINK: u64 = 6;
    /// One link tested against a block: the golden-section search's 47 signed distances, each
    /// about a sixteenth of a link-step (not timed alone; charged for every link, the box test
    /// that skips most of them aside).
    pub const BLOCK_PER_LINK: u64 = 3 * LINK_STEP;

    /// What testing one link against `ob` is charged.
    pub fn obstacle_per_link<T: crate::math::Real, const D: usize>(
        ob: &super::Obstacle<T, D>,
    ) -> u64 {
        match ob {
            super::Obstacle::Block { .. } => BLOCK_PER_LINK,
            _ => OBSTACLE_PER_LINK,
        }
    }
    /// Re-straightening, per link.
    pub const RESTRAIGHTEN_PER_LINK: u64 = 4;
    /// One iteration of the relaxation (a fast projection: a tridiagonal solve), per link: set from
    /// its arithmetic (a square root and three divisions per link, about half a link-step's), not
    /// timed alone; the budget bench times whole requests against their budget.
    pub const RELAX_PER_LINK: u64 = 8;
    /// One iteration of a held part's re-solve, per link (up to three tractrix passes and a
    /// translation).
    pub const RESOLVE_PER_LINK: u64 = 4 * LINK_STEP;
}

/// The work of collision handling charged against a limit, in link-steps (see
/// [`CollisionWorkspace::limit_work`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Meter {
    limit: u64,
    done: u64,
}

impl Default for Meter {
    fn default() -> Self {
        Meter {
            limit: u64::MAX,
            done: 0,
        }
    }
}

impl Meter {
    /// Charges `units` before they are spent: `false` (and nothing charged) if they would pass the
    /// limit.
    #[inline]
    pub(super) fn charge(&mut self, units: u64) -> bool {
        match self.done.checked_add(units) {
            Some(next) if next <= self.limit => {
                self.done = next;
                true
            }
            _ => false,
        }
    }

    /// Gives back units charged but not spent.
    pub(super) fn refund(&mut self, units: u64) {
        self.done = self.done.saturating_sub(units);
    }

    /// What is left before the limit.
    pub(super) fn left(&self) -> u64 {
        self.limit - self.done
    }

    fn over(&self, substep: u32) -> ChainError {
        ChainError::OverWork {
            substep,
            work: self.done.div_ceil(cost::LINK_STEP),
            limit: self.limit / cost::LINK_STEP,
        }
    }
}

/// Why a resolution stopped short.
pub(super) enum Stop<T> {
    /// A contact that only fixed joints could resolve, or the passes ran out: the passes spent and the
    /// worst penetration left.
    Locked(u32, T),
    /// The next unit of work would pass the meter's limit.
    OverWork,
}

impl<T: Real> Stop<T> {
    fn error(self, substep: u32, meter: &Meter) -> ChainError {
        match self {
            Stop::Locked(iterations, penetration) => ChainError::Locked {
                substep,
                iterations,
                penetration: penetration.to_f64(),
            },
            Stop::OverWork => meter.over(substep),
        }
    }
}

/// Whether `e` stops a move short inside its frame ([`CollisionWorkspace::stop_short`]) rather than
/// refusing it: what the rope met on the way (work, a lock, a jump, a held side out of reach or not
/// converging, a joint limit), not bad input.
pub fn stops_short_on(e: &ChainError) -> bool {
    matches!(
        e,
        ChainError::OverWork { .. }
            | ChainError::Locked { .. }
            | ChainError::Jumped { .. }
            | ChainError::HeldUnreachable { .. }
            | ChainError::HeldNotConverged { .. }
            | ChainError::JointLimit { .. }
    )
}

/// Resolves the contacts of `chain` as it stands, with joint `m` (the hand) and the joints `fixed`
/// (ascending, without `m`) never moving, as a move's substep does: pushes, then the rope between
/// fixed joints re-solved as fixed-base chains. For moves that place the chain by other means (an
/// eyelet's threaded move: [`crate::eyelet`]). The chain is left as the passes left it on an error
/// (the caller restores it); `substep` names the substep in the error.
pub(crate) fn resolve_fixed<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    fixed: &[usize],
    substep: u32,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<(u32, u32), ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    model.options.validate()?;
    ws.pos.resize(chain.n_links() + 1, Vector::zeros());
    chain.write_positions(&mut ws.pos);
    let hand = ws.pos[m];
    let out =
        resolve(chain, m, fixed, true, model, ws).map_err(|stop| stop.error(substep, &ws.meter));
    chain.place_origin_from(m, hand);
    out
}

/// Moves joint `joint` along the straight segment to `target` like [`Chain::move_joint`], keeping links
/// apart from each other and from the model's obstacles after every substep (see the module docs). On
/// any error, [`ChainError::Locked`] included, the chain is unchanged.
pub fn move_joint_colliding<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    opts: &MoveOptions<T>,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    chain.check_joint(joint)?;
    model.options.validate()?;
    if !all_finite(&target) {
        return Err(ChainError::NonFinite);
    }
    let start = chain.current(joint);
    let delta = target - start;
    let requested = chain.substep_count(&delta, opts)?;
    // No substep may move the hand more than half the smallest clearance (no tunnelling).
    let half = smallest_clearance(chain, model) * T::lit(0.5);
    let needed = (delta.norm() / half).to_f64();
    let needed = if needed.is_finite() {
        needed.ceil().max(1.0)
    } else {
        f64::INFINITY
    };
    let k = if needed > requested as f64 {
        if needed > opts.max_substeps as f64 {
            return Err(ChainError::TooManySubsteps {
                required: if needed.is_finite() {
                    needed as u64
                } else {
                    u64::MAX
                },
                limit: opts.max_substeps,
            });
        }
        needed as u32
    } else {
        requested
    };
    if delta.iter().all(|c| *c == T::zero()) {
        return Ok(MoveOutcome::default());
    }
    if chain.held_elsewhere(joint) {
        return move_held_colliding(chain, joint, start, target, k, opts, model, ws);
    }
    ws.backup_links.clear();
    ws.backup_links.extend_from_slice(chain.links());
    let backup_datum = chain.datum();
    ws.pos.resize(chain.n_links() + 1, Vector::zeros());

    let sd = delta / T::lit(k as f64);
    let mut outcome = MoveOutcome {
        substeps: k,
        ..MoveOutcome::default()
    };
    let sweep = (chain.n_links() as u64).saturating_mul(cost::LINK_STEP);
    let mut made = backup_datum;
    if ws.frame {
        ws.made_links.clone_from(&ws.backup_links);
    }
    for s in 1..=k {
        let stop = if ws.meter.charge(sweep) {
            outcome.paper_fallbacks =
                outcome
                    .paper_fallbacks
                    .saturating_add(chain.sweep(joint, &sd, opts.method));
            let hand = if s == k {
                target
            } else {
                start + sd * T::lit(s as f64)
            };
            positions_from(chain, joint, hand, &mut ws.pos);
            match resolve(chain, joint, &[], false, model, ws) {
                Ok((iterations, contacts)) => {
                    outcome.collision_iterations =
                        outcome.collision_iterations.saturating_add(iterations);
                    outcome.contacts = outcome.contacts.saturating_add(contacts);
                    // The moved joint is where the hand put it: the datum (as after a plain move).
                    chain.place_origin_from(joint, hand);
                    if ws.frame {
                        ws.made_links.copy_from_slice(chain.links());
                        made = (joint, hand);
                    }
                    continue;
                }
                Err(stop) => stop.error(s, &ws.meter),
            }
        } else {
            ws.meter.over(s)
        };
        if ws.frame {
            // The last whole substep's state: the move stops short there.
            chain.links_mut().copy_from_slice(&ws.made_links);
            chain.place_origin_from(made.0, made.1);
            chain.repin(joint);
            outcome.substeps = s - 1;
            outcome.short = Some(Short {
                error: stop,
                made: s - 1,
                of: k,
            });
            return Ok(outcome);
        }
        chain.links_mut().copy_from_slice(&ws.backup_links);
        chain.place_origin_from(backup_datum.0, backup_datum.1);
        return Err(stop);
    }
    // The hand may hold the joint it moves: its pin follows it.
    chain.repin(joint);
    Ok(outcome)
}
