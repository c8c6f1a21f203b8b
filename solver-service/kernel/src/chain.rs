//! A chain of rigid links and algorithm RESOLUTION-TRACTRIX (section 4.1) over it.
//!
//! # State
//!
//! Joints are numbered `0..=n`: joint 0 is the *tail* end (the base of a manipulator), joint `n` the
//! *head*. Link `i` (1-based) joins joints `i−1` and `i`. The state is flat: one contiguous buffer of
//! link vectors `lᵢ = Xᵢ − Xᵢ₋₁`, the nominal lengths, and one *datum*: a joint `b` and its position.
//! Joint 0 (the origin) is the compensated sum `X_b − Σ_{i<b} lᵢ`, computed when it is asked for, and
//! every other position is summed forward from it. A move sets the datum to the moved joint and its
//! target, O(1), instead of walking the chain to place the origin: a move costs one pass over the
//! links, nothing more, and the next move of the same joint starts exactly where the last one put it.
//!
//! Storing link vectors rather than absolute positions is a deliberate choice: a link's length is then a
//! property of one stored vector, so it is kept to a few ulps *relative to the link* however far the chain
//! has travelled (a rope 10⁹ link lengths from the origin, or an f32 chain in metres with millimetre
//! links). Absolute positions are produced on demand by a prefix sum ([`Chain::write_positions`]), which
//! the service does anyway when it writes a response.
//!
//! # Moves
//!
//! [`Chain::move_joint`] moves any joint along a straight segment. A head move runs the tractrix from the
//! head to the tail; a tail move from the tail to the head; an interior joint splits the chain into two
//! parts that both follow outward (remark 2). A move can be split into substeps ([`Substeps`]); the moved
//! joint lands exactly on its target. A move allocates nothing.
//!
//! Two or more substeps run as a *wavefront*: substep `j` of link `i` beside substep `j − 1` of link
//! `i + 1`, up to [`MAX_WAVE`] in flight, the same operations as substep after substep, bit for bit.
//! From [`SIMD_FROM`] substeps on, the closed-form tractrix of a spatial f64 or f32 chain runs the steps
//! in flight with SIMD ([`crate::strands::chain_wave`]): the same arithmetic but for the exponential
//! (a polynomial within an ulp of the platform's), so the links agree with substep after substep to
//! about 1e-13 of a link, and are the same bits on every instruction set.
//!
//! # Holds
//!
//! Joints can be *held* ([`Chain::hold`]): an anchor in tissue, a grasp of a hand. A held joint stores
//! its position as the state of the prefix sum at that joint, so it and every joint beyond it up to
//! the next moved link are bit for bit unchanged by moves elsewhere, and positions are summed from the
//! nearest held joint before them. A move of joint `m` with holds splits the chain at `m`; on each side
//! the links up to the nearest held joint form a fixed-base chain whose base is that joint, solved by
//! the paper's fixed-base method ([`crate::fixed_base::reach`]); a side with no held joint follows
//! freely, exactly as without holds ([`crate::hold`]).

use crate::limits::{JointLimits, LimitError};
use crate::link::{LinkStep, Method, follow_the_leader_step, step, tractrix_step};
use crate::math::{CompensatedSum, Embed3, Real, Vector, all_finite, positive_finite};
pub use crate::options::{MoveOptions, Substeps};

/// What a successful move did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MoveOutcome {
    /// Substeps taken (0 for a move to where the joint already is).
    pub substeps: u32,
    /// Link steps where the paper's form was undefined and the closed form was used instead.
    pub paper_fallbacks: u32,
    /// Collision resolution passes that pushed something, summed over substeps (0 without collision).
    pub collision_iterations: u32,
    /// Contacts pushed apart, summed over passes and substeps.
    pub contacts: u32,
    /// Fixed-base iterations spent on the sides that end at a held joint (0 without holds).
    pub held_iterations: u32,
    /// Link steps turned back into their joint's limit (0 without limits): how often the move ran into
    /// the chain's cones or ranges ([`crate::limits`]).
    pub limited: u32,
    /// Eyelets the rope left during the move (an end slid out; 0 without eyelets).
    pub left: u32,
    /// Whether the rope stuck in its eyelets (friction): the links through them did not move.
    pub stuck: bool,
}

impl MoveOutcome {
    /// Adds `o`'s counts to these (a path of moves; saturating), `stuck` if either stuck.
    pub fn add(&mut self, o: &MoveOutcome) {
        self.substeps = self.substeps.saturating_add(o.substeps);
        self.paper_fallbacks = self.paper_fallbacks.saturating_add(o.paper_fallbacks);
        self.collision_iterations = self
            .collision_iterations
            .saturating_add(o.collision_iterations);
        self.contacts = self.contacts.saturating_add(o.contacts);
        self.held_iterations = self.held_iterations.saturating_add(o.held_iterations);
        self.limited = self.limited.saturating_add(o.limited);
        self.left = self.left.saturating_add(o.left);
        self.stuck |= o.stuck;
    }
}

/// Why a chain could not be built or moved. A failed move leaves the chain unchanged.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ChainError {
    /// A chain needs at least one link (two joints).
    #[error("a chain needs at least one link")]
    Empty,
    /// A link length is zero, negative or not finite.
    #[error("link {link}: length {length} is not a positive finite number")]
    BadLength {
        /// Index of the link.
        link: usize,
        /// Its length as given.
        length: f64,
    },
    /// A coordinate is NaN or infinite.
    #[error("non-finite coordinate")]
    NonFinite,
    /// The joint index is past the head.
    #[error("joint {joint} out of range (the chain has joints 0..={last})")]
    JointOutOfRange {
        /// The joint asked for.
        joint: usize,
        /// The head's index.
        last: usize,
    },
    /// The move needs more substeps than `max_substeps`.
    #[error("move needs {required} substeps, more than the limit {limit}")]
    TooManySubsteps {
        /// Substeps the move would need.
        required: u64,
        /// The limit it was given.
        limit: u32,
    },
    /// An option is out of range.
    #[error("invalid option: {0}")]
    BadOption(&'static str),
    /// The target is farther from a held joint than the rope between them (or nearer than the rope can
    /// fold): nothing moved; `nearest` is the nearest point the moved joint can reach.
    #[error(
        "target unreachable from held joint {held}: {residual:e} outside; nearest reachable point {nearest:?}"
    )]
    HeldUnreachable {
        /// The held joint that limits the move.
        held: usize,
        /// The nearest reachable point (x, y, z; z = 0 for a planar chain).
        nearest: [f64; 3],
        /// Distance from the target to it.
        residual: f64,
    },
    /// The fixed-base solution of a held side did not converge within its iteration limit.
    #[error("held side not converged after {iterations} iterations, residual {residual:e}")]
    HeldNotConverged {
        /// Iterations spent.
        iterations: u32,
        /// Distance from the target when they ran out.
        residual: f64,
    },
    /// A solve that the limits do not steer (a held side, a collision pass) left a joint beyond its limit
    /// ([`crate::limits`]): the move is refused.
    #[error("joint {joint} at {angle:.4} rad, {excess:.3e} rad beyond its limit")]
    JointLimit {
        /// The joint.
        joint: usize,
        /// Its angle (unsigned for a cone, signed for a range), radians.
        angle: f64,
        /// How far beyond the limit, radians.
        excess: f64,
    },
    /// Collision handling could not separate the links within its iteration limit: the chain is
    /// "locked" (section 4.2) and the move is refused.
    #[error(
        "locked by collision at substep {substep}: {penetration:.3e} penetration left after {iterations} iterations"
    )]
    Locked {
        /// 1-based substep at which the chain locked.
        substep: u32,
        /// Iterations spent on that substep.
        iterations: u32,
        /// Worst penetration left, in the chain's length unit.
        penetration: f64,
    },
    /// A substep of a move with holds would carry a joint farther than half the smallest clearance
    /// however finely it was split: a link could pass through another (the rope jumping through a
    /// jammed knot). Nothing moved; to collision handling, the rope is locked.
    #[error(
        "locked: a joint would jump {jump:.3e} in one substep at substep {substep}, more than half the clearance"
    )]
    Jumped {
        /// 1-based substep.
        substep: u32,
        /// The largest joint displacement of the finest split, in the chain's length unit.
        jump: f64,
    },
    /// Collision handling would have done more work than its limit allows
    /// ([`crate::collision::CollisionWorkspace::limit_work`]): stopped before it, nothing moved.
    #[error(
        "collision work of {work} link-steps at substep {substep} would pass the limit of {limit}"
    )]
    OverWork {
        /// 1-based substep at which the work ran out.
        substep: u32,
        /// Work charged when it stopped, in link-steps.
        work: u64,
        /// The limit.
        limit: u64,
    },
}

/// A chain of rigid links in `D` dimensions (see the module docs for the layout).
#[derive(Clone, Debug, PartialEq)]
pub struct Chain<T: Real, const D: usize> {
    /// The datum joint `b` (at most the first held joint) and its position; joint 0 is summed back from
    /// it on demand.
    datum: usize,
    datum_at: Vector<T, D>,
    links: Vec<Vector<T, D>>,
    lengths: Vec<T>,
    min_length: T,
    /// Held joints, ascending, each with the prefix sum's state at it (positions restart there).
    pins: Vec<(usize, CompensatedSum<T, D>)>,
    /// Joint limits ([`crate::limits`]); `None` costs nothing. Shared: they never change once set, so
    /// a copy of the chain (the service's per-request backup) shares them instead of allocating.
    limits: Option<std::sync::Arc<JointLimits<T>>>,
}

impl<T: Real, const D: usize> Chain<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// A chain through the given joint positions (tail first). Lengths are taken from the points.
    pub fn from_points(points: &[Vector<T, D>]) -> Result<Self, ChainError> {
        if points.len() < 2 {
            return Err(ChainError::Empty);
        }
        if !points.iter().all(all_finite) {
            return Err(ChainError::NonFinite);
        }
        let links: Vec<_> = points.windows(2).map(|w| w[1] - w[0]).collect();
        let lengths: Vec<_> = links.iter().map(|l| l.norm()).collect();
        Self::from_parts(points[0], links, lengths)
    }

    /// A straight chain of `n` links of length `len` from `origin` along `dir` (normalised here).
    pub fn straight(
        n: usize,
        len: T,
        origin: Vector<T, D>,
        dir: Vector<T, D>,
    ) -> Result<Self, ChainError> {
        let dn = dir.norm();
        if !positive_finite(dn) {
            return Err(ChainError::BadOption(
                "direction must be a non-zero finite vector",
            ));
        }
        let unit = dir / dn;
        Self::from_parts(origin, vec![unit * len; n], vec![len; n])
    }

    /// A chain from the position of joint 0, the link vectors and their nominal lengths. Each link vector
    /// is rescaled to its nominal length (its direction is what counts).
    pub fn from_parts(
        origin: Vector<T, D>,
        mut links: Vec<Vector<T, D>>,
        lengths: Vec<T>,
    ) -> Result<Self, ChainError> {
        check_parts(&origin, &links, &lengths)?;
        for (i, (l, &len)) in links.iter_mut().zip(&lengths).enumerate() {
            let n = l.norm();
            if !positive_finite(len) || !positive_finite(n) {
                return Err(ChainError::BadLength {
                    link: i + 1,
                    length: if len > T::zero() {
                        n.to_f64()
                    } else {
                        len.to_f64()
                    },
                });
            }
            *l *= len / n;
        }
        Ok(Self::assemble(origin, links, lengths))
    }

    /// A chain from stored parts, bit for bit (a snapshot restore): unlike [`Chain::from_parts`] the link
    /// vectors are not rescaled. Each must be finite and within `√ε` (relative) of its nominal length,
    /// or the parts did not come from a chain.
    pub fn from_raw_parts(
        origin: Vector<T, D>,
        links: Vec<Vector<T, D>>,
        lengths: Vec<T>,
    ) -> Result<Self, ChainError> {
        check_parts(&origin, &links, &lengths)?;
        let tol = T::EPSILON.sqrt();
        for (i, (l, &len)) in links.iter().zip(&lengths).enumerate() {
            let n = l.norm();
            if !positive_finite(len) || (n - len).abs() > tol * len {
                return Err(ChainError::BadLength {
                    link: i + 1,
                    length: n.to_f64(),
                });
            }
        }
        Ok(Self::assemble(origin, links, lengths))
    }

    fn assemble(origin: Vector<T, D>, links: Vec<Vector<T, D>>, lengths: Vec<T>) -> Self {
        let min_length = lengths.iter().copied().fold(lengths[0], T::min);
        Chain {
            datum: 0,
            datum_at: origin,
            links,
            lengths,
            min_length,
            pins: Vec::new(),
            limits: None,
        }
    }

    /// Makes `self` equal to `other`, reusing `self`'s buffers when the sizes match (no allocation: the
    /// service's per-request backup).
    pub fn copy_from(&mut self, other: &Self) {
        if self.links.len() == other.links.len() {
            self.datum = other.datum;
            self.datum_at = other.datum_at;
            self.links.copy_from_slice(&other.links);
            self.lengths.copy_from_slice(&other.lengths);
            self.min_length = other.min_length;
            self.pins.clone_from(&other.pins);
            self.limits.clone_from(&other.limits);
        } else {
            *self = other.clone();
        }
    }

    /// Sets (or with `None` removes) the chain's joint limits ([`crate::limits`]): one entry per joint.
    /// Moves from then on keep every joint within them; the present pose is not changed (see
    /// [`Chain::limit_excess`]). Ranges need a planar chain.
    pub fn set_limits(&mut self, limits: Option<JointLimits<T>>) -> Result<(), LimitError> {
        if let Some(l) = &limits {
            if l.joints() != self.links.len() + 1 {
                return Err(LimitError::Count {
                    given: l.joints(),
                    joints: self.links.len() + 1,
                });
            }
            if D != 2 && l.kind() == crate::limits::LimitKind::Range {
                return Err(LimitError::RangeInSpace);
            }
        }
        self.limits = limits.map(std::sync::Arc::new);
        Ok(())
    }

    /// The chain's joint limits, if any.
    pub fn joint_limits(&self) -> Option<&JointLimits<T>> {
        self.limits.as_deref()
    }

    /// The chain's joint limits as their shared handle (a count, not a copy), for solvers that hold
    /// them while they change the links.
    pub(crate) fn shared_limits(&self) -> Option<std::sync::Arc<JointLimits<T>>> {
        self.limits.clone()
    }

    /// Puts `limits` in place of the chain's joint limits and returns those (a handle, not a copy):
    /// for a move that frees some joints of their limits while it runs ([`crate::eyelet`]).
    pub(crate) fn replace_limits(
        &mut self,
        limits: Option<std::sync::Arc<JointLimits<T>>>,
    ) -> Option<std::sync::Arc<JointLimits<T>>> {
        std::mem::replace(&mut self.limits, limits)
    }

    /// The joint farthest beyond its limit by more than `tol` radians: (joint, angle, excess); `None`
    /// within the limits (or without any).
    pub fn limit_excess(&self, tol: T) -> Option<(usize, T, T)> {
        self.limits.as_ref().and_then(|l| l.worst(&self.links, tol))
    }

    /// [`Chain::limit_excess`] beyond [`LIMIT_TOLERANCE`] as the error a move reports.
    pub(crate) fn check_limits(&self) -> Result<(), ChainError> {
        self.check_limits_except(&[])
    }

    /// [`Chain::check_limits`] with the joints `free` (ascending) not limited
    /// ([`JointLimits::worst_except`]).
    pub(crate) fn check_limits_except(&self, free: &[usize]) -> Result<(), ChainError> {
        match self
            .limits
            .as_ref()
            .and_then(|l| l.worst_except(&self.links, T::lit(LIMIT_TOLERANCE), free))
        {
            None => Ok(()),
            Some((joint, angle, excess)) => Err(ChainError::JointLimit {
                joint,
                angle: angle.to_f64(),
                excess: excess.to_f64(),
            }),
        }
    }

    /// Number of links `n`.
    pub fn n_links(&self) -> usize {
        self.links.len()
    }

    /// Index of the head joint, `n`.
    pub fn head_index(&self) -> usize {
        self.links.len()
    }

    /// Nominal link lengths, tail first.
    pub fn lengths(&self) -> &[T] {
        &self.lengths
    }

    /// Link vectors `lᵢ = Xᵢ − Xᵢ₋₁`, tail first.
    pub fn links(&self) -> &[Vector<T, D>] {
        &self.links
    }

    /// Position of joint 0 (the base of a manipulator).
    pub fn origin(&self) -> Vector<T, D> {
        if self.datum == 0 {
            return self.datum_at;
        }
        // The moved joint's target back along the links before it (compensated, in link order).
        let mut acc = CompensatedSum::new(self.datum_at);
        for l in &self.links[..self.datum] {
            acc.add(&-l);
        }
        acc.value()
    }

    /// The datum joint and its position (see the module docs): what a snapshot stores besides the
    /// links and the held joints.
    pub fn datum(&self) -> (usize, Vector<T, D>) {
        (self.datum, self.datum_at)
    }

    /// Restores a datum stored by [`Chain::datum`]. Fails, changing nothing, unless the joint is in
    /// range and at most the first held joint and the position is finite.
    pub fn set_datum(&mut self, joint: usize, at: Vector<T, D>) -> Result<(), ChainError> {
        self.check_joint(joint)?;
        if !all_finite(&at) {
            return Err(ChainError::NonFinite);
        }
        if self.pins.first().is_some_and(|p| p.0 < joint) {
            return Err(ChainError::BadOption(
                "the datum joint must not lie beyond the first held joint",
            ));
        }
        self.datum = joint;
        self.datum_at = at;
        Ok(())
    }

    /// Moves the datum to joint 0 (where it already was summed): positions do not change, bit for bit.
    /// Needed before anything edits the links before the datum other than a move that sets it again.
    pub(crate) fn settle_origin(&mut self) {
        if self.datum != 0 {
            self.datum_at = self.origin();
            self.datum = 0;
        }
    }

    /// Where joint `joint` is: the datum's own position if it is the datum (exactly where the last move
    /// put it), else summed ([`Chain::joint`]).
    #[inline]
    pub(crate) fn current(&self, joint: usize) -> Vector<T, D> {
        if joint == self.datum {
            self.datum_at
        } else {
            self.joint(joint)
        }
    }

    /// The shortest nominal link length.
    pub fn min_length(&self) -> T {
        self.min_length
    }

    /// Total nominal length.
    pub fn total_length(&self) -> T {
        self.lengths.iter().fold(T::zero(), |a, &b| a + b)
    }

    /// Position of joint `i` (O(i), compensated sum from the nearest held joint at or before it).
    pub fn joint(&self, i: usize) -> Vector<T, D> {
        self.sum_at(i).value()
    }

    /// The prefix sum's state at joint `i`: from the nearest held joint at or before `i` (or joint 0).
    pub(crate) fn sum_at(&self, i: usize) -> CompensatedSum<T, D> {
        let (mut acc, from) = match self.pins.iter().rev().find(|p| p.0 <= i) {
            Some(&(j, s)) => (s, j),
            None => (CompensatedSum::new(self.origin()), 0),
        };
        for l in &self.links[from..i] {
            acc.add(l);
        }
        acc
    }

    /// Holds joint `joint` where it is (an anchor, a grasp): moves elsewhere leave it, and every joint
    /// beyond it toward the next moved part, bit for bit where they are. Holding changes no position.
    /// Holding a held joint again changes nothing.
    pub fn hold(&mut self, joint: usize) -> Result<(), ChainError> {
        self.check_joint(joint)?;
        match self.pins.binary_search_by_key(&joint, |p| p.0) {
            Ok(_) => {}
            Err(at) => {
                // The datum stays at or before the first held joint.
                if joint < self.datum {
                    self.settle_origin();
                }
                let state = self.sum_at(joint);
                self.pins.insert(at, (joint, state));
            }
        }
        Ok(())
    }

    /// Lets joint `joint` go; returns whether it was held. Positions beyond it are summed from the joint
    /// held before it again, which moves them by rounding only (ulps).
    pub fn release(&mut self, joint: usize) -> Result<bool, ChainError> {
        self.check_joint(joint)?;
        match self.pins.binary_search_by_key(&joint, |p| p.0) {
            Ok(at) => {
                self.pins.remove(at);
                Ok(true)
            }
            Err(_) => Ok(false),
        }
    }

    /// Lets every held joint go.
    pub fn release_all(&mut self) {
        self.pins.clear();
    }

    /// Whether joint `joint` is held.
    pub fn is_held(&self, joint: usize) -> bool {
        self.pins.binary_search_by_key(&joint, |p| p.0).is_ok()
    }

    /// The held joints, ascending.
    pub fn held(&self) -> impl ExactSizeIterator<Item = usize> + '_ {
        self.pins.iter().map(|p| p.0)
    }

    /// The `k`-th held joint (ascending) and the prefix sum's state there, from which positions restart
    /// (for callers that sum positions themselves, like the service's response writer).
    pub fn held_state(&self, k: usize) -> Option<(usize, CompensatedSum<T, D>)> {
        self.pins.get(k).copied()
    }

    /// The held joints with the prefix sum's state at each (sum, carry): what a snapshot stores.
    pub fn held_raw(&self) -> impl Iterator<Item = (usize, Vector<T, D>, Vector<T, D>)> + '_ {
        self.pins.iter().map(|(j, s)| {
            let (sum, carry) = s.parts();
            (*j, sum, carry)
        })
    }

    /// Restores held joints stored by [`Chain::held_raw`], bit for bit. Fails, changing nothing, unless
    /// the joints ascend, are in range, and each is finite and where the links put it (within `√ε` of
    /// the chain's extent: the parts came from this chain).
    pub fn set_held_raw(
        &mut self,
        held: &[(usize, Vector<T, D>, Vector<T, D>)],
    ) -> Result<(), ChainError> {
        let extent = self.total_length() + self.origin().norm();
        let tol = T::EPSILON.sqrt() * (T::one() + extent);
        let mut pins = Vec::with_capacity(held.len());
        for (k, &(j, sum, carry)) in held.iter().enumerate() {
            self.check_joint(j)?;
            if k > 0 && held[k - 1].0 >= j {
                return Err(ChainError::BadOption("held joints must ascend"));
            }
            if !all_finite(&sum) || !all_finite(&carry) {
                return Err(ChainError::NonFinite);
            }
            let state = CompensatedSum::from_parts(sum, carry);
            // Where the links before it put the joint (from the pins restored so far).
            let mut probe = self.clone();
            probe.pins.clone_from(&pins);
            if (probe.joint(j) - state.value()).norm() > tol {
                return Err(ChainError::BadOption(
                    "a held joint is not where its links put it",
                ));
            }
            pins.push((j, state));
        }
        // The datum stays at or before the first held joint (settling it moves no position).
        if pins.first().is_some_and(|p| p.0 < self.datum) {
            self.settle_origin();
        }
        self.pins = pins;
        Ok(())
    }

    /// Position of the head joint.
    pub fn head(&self) -> Vector<T, D> {
        self.joint(self.n_links())
    }

    /// Writes the `n + 1` joint positions into `out` (tail first). Panics if `out` is shorter.
    /// Positions are accurate to a few ulps of their magnitude whatever the chain's length (compensated
    /// prefix sum).
    pub fn write_positions(&self, out: &mut [Vector<T, D>]) {
        let origin = self.origin();
        let mut acc = CompensatedSum::new(origin);
        out[0] = origin;
        let mut pins = self.pins.iter().peekable();
        if let Some(&(_, s)) = pins.next_if(|p| p.0 == 0) {
            acc = s;
            out[0] = s.value();
        }
        for (i, (o, l)) in out[1..=self.links.len()]
            .iter_mut()
            .zip(&self.links)
            .enumerate()
        {
            acc.add(l);
            if let Some(&(_, s)) = pins.next_if(|p| p.0 == i + 1) {
                acc = s;
            }
            *o = acc.value();
        }
    }

    /// The joint positions as a new vector (allocates; for tests and tools, not the hot path).
    pub fn positions(&self) -> Vec<Vector<T, D>> {
        let mut v = vec![Vector::zeros(); self.links.len() + 1];
        self.write_positions(&mut v);
        v
    }

    /// Replaces the joint positions, keeping the nominal lengths (each link is rescaled along its new
    /// direction). Used by collision handling and restores. Fails, changing nothing, on a count mismatch,
    /// a non-finite point or coincident neighbours.
    pub fn set_positions(&mut self, points: &[Vector<T, D>]) -> Result<(), ChainError> {
        if points.len() != self.links.len() + 1 {
            return Err(ChainError::BadOption(
                "point count does not match the chain",
            ));
        }
        if !points.iter().all(all_finite) {
            return Err(ChainError::NonFinite);
        }
        for (i, w) in points.windows(2).enumerate() {
            if !positive_finite((w[1] - w[0]).norm()) {
                return Err(ChainError::BadLength {
                    link: i + 1,
                    length: 0.0,
                });
            }
        }
        self.datum = 0;
        self.datum_at = points[0];
        for ((l, w), &len) in self
            .links
            .iter_mut()
            .zip(points.windows(2))
            .zip(&self.lengths)
        {
            let v = w[1] - w[0];
            *l = v * (len / v.norm());
        }
        Ok(())
    }

    /// Moves the origin (joint 0) to `p` without rotating any link: a rigid translation (of the part
    /// before the first held joint: held joints stay).
    pub fn translate_to(&mut self, p: Vector<T, D>) {
        self.datum = 0;
        self.datum_at = p;
    }

    /// Overwrites link vectors directly (same count; used by solvers that rotate links). Callers keep
    /// lengths: the vectors are not rescaled here.
    pub(crate) fn links_mut(&mut self) -> &mut [Vector<T, D>] {
        self.settle_origin();
        &mut self.links
    }

    /// Link vectors (mutable) beside the nominal lengths and the joint limits, for solvers that place
    /// links one after the other (and turn each back into its limit).
    pub(crate) fn links_lengths_limits_mut(
        &mut self,
    ) -> (&mut [Vector<T, D>], &[T], Option<&JointLimits<T>>) {
        self.settle_origin();
        (&mut self.links, &self.lengths, self.limits.as_deref())
    }

    /// How many substeps `opts` asks for when a joint moves by `delta`.
    pub fn substep_count(
        &self,
        delta: &Vector<T, D>,
        opts: &MoveOptions<T>,
    ) -> Result<u32, ChainError> {
        let required: u64 = match opts.substeps {
            Substeps::Fixed(0) => return Err(ChainError::BadOption("substeps must be at least 1")),
            Substeps::Fixed(k) => k as u64,
            Substeps::MaxStep(f) => {
                if !positive_finite(f) {
                    return Err(ChainError::BadOption(
                        "max step must be a positive finite fraction",
                    ));
                }
                let ratio = (delta.norm() / (f * self.min_length)).to_f64();
                if !ratio.is_finite() {
                    u64::MAX
                } else {
                    (ratio.ceil() as u64).max(1)
                }
            }
        };
        if required > opts.max_substeps as u64 {
            return Err(ChainError::TooManySubsteps {
                required,
                limit: opts.max_substeps,
            });
        }
        Ok(required as u32)
    }

    /// Whether a joint other than `joint` is held (a move of `joint` then needs the held solution).
    pub(crate) fn held_elsewhere(&self, joint: usize) -> bool {
        self.pins.iter().any(|p| p.0 != joint)
    }

    /// If `joint` is held, re-records its pin where the links now put it (after a move of it).
    pub(crate) fn repin(&mut self, joint: usize) {
        if let Ok(at) = self.pins.binary_search_by_key(&joint, |p| p.0) {
            self.pins.remove(at);
            let state = self.sum_at(joint);
            self.pins.insert(at, (joint, state));
        }
    }

    /// The held joints nearest to `m` below and above it (not `m` itself).
    pub(crate) fn held_around(&self, m: usize) -> (Option<usize>, Option<usize>) {
        let lo = self.pins.iter().rev().map(|p| p.0).find(|&j| j < m);
        let hi = self.pins.iter().map(|p| p.0).find(|&j| j > m);
        (lo, hi)
    }

    /// Makes `joint` the datum, at `at`: the origin is then the compensated sum of the links before it
    /// back from `at` (for a chain with no held joint before `joint`).
    pub(crate) fn place_origin_from(&mut self, joint: usize, at: Vector<T, D>) {
        self.datum = joint;
        self.datum_at = at;
    }

    pub(crate) fn check_joint(&self, joint: usize) -> Result<(), ChainError> {
        if joint > self.links.len() {
            return Err(ChainError::JointOutOfRange {
                joint,
                last: self.links.len(),
            });
        }
        Ok(())
    }

    pub(crate) fn apply_move(
        &mut self,
        joint: usize,
        target: Vector<T, D>,
        delta: Vector<T, D>,
        k: u32,
        method: Method,
    ) -> MoveOutcome {
        if delta.iter().all(|c| *c == T::zero()) {
            return MoveOutcome::default();
        }
        let sd = delta / T::lit(k as f64);
        if self.limits.is_some() {
            // Each link turned back into its limit as it is stepped: one substep, or several as
            // wavefronts (a link's clamp needs the link before it at the same substep, which the
            // wavefront has at hand: [`wave_limited`]).
            let mut clamps = 0u32;
            let fallbacks = if k == 1 {
                let n = self.links.len();
                self.tail_side_limited(joint, &sd, method, 0, &mut clamps)
                    .0
                    .saturating_add(self.head_side_limited(joint, &sd, method, n, &mut clamps))
            } else if method == Method::Tractrix
                && self.simd_waves_limited(joint, &sd, k, &mut clamps)
            {
                0
            } else {
                self.waves_limited(joint, &sd, k, method, &mut clamps)
            };
            self.place_origin_from(joint, target);
            return MoveOutcome {
                substeps: k,
                paper_fallbacks: fallbacks,
                limited: clamps,
                ..MoveOutcome::default()
            };
        }
        let fallbacks = if k == 1 {
            let (fb, _) = self.tail_side(joint, &sd, method, 0);
            let n = self.links.len();
            fb + self.head_side(joint, &sd, method, n)
        } else {
            match method {
                Method::Tractrix => {
                    if !self.simd_waves(joint, &sd, k) {
                        self.waves(joint, &sd, k, |t, s, l| (tractrix_step(t, s, l), false));
                    }
                    0
                }
                Method::FollowTheLeader => self.waves(joint, &sd, k, |t, s, l| {
                    (follow_the_leader_step(t, s, l), false)
                }),
                Method::TractrixPaper => self.waves(joint, &sd, k, paper_or_closed_form),
            }
        };
        // The moved joint lands on its target: it becomes the datum.
        self.place_origin_from(joint, target);
        MoveOutcome {
            substeps: k,
            paper_fallbacks: fallbacks,
            ..MoveOutcome::default()
        }
    }

    /// `k` substeps of `s` of joint `m`, both sides, as wavefronts of up to [`MAX_WAVE`] substeps in
    /// flight. The two sides share no link, so each side's substeps can run to the end before the other
    /// side's start; within a side, substep `j` of link `i` needs only link `i` after substep `j − 1` and
    /// the shift of link `i − 1` at substep `j`, so it runs beside substep `j − 1` of link `i + 1`. The
    /// same operations on the same inputs as substep after substep: the result is equal bit for bit
    /// (the kernel's tests check it), only the independent divisions, square roots and exponentials
    /// overlap in the CPU. Returns the paper-form fallbacks.
    #[inline(always)]
    fn waves<F>(&mut self, m: usize, s: &Vector<T, D>, k: u32, f: F) -> u32
    where
        F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    {
        let (tail, head) = self.links.split_at_mut(m);
        let (tail_lengths, head_lengths) = self.lengths.split_at(m);
        let mut fallbacks = 0u32;
        let mut left = k as usize;
        while left > 0 {
            let w = left.min(MAX_WAVE);
            fallbacks = fallbacks
                .saturating_add(wave::<T, D, true, F>(tail, tail_lengths, s, w, &f))
                .saturating_add(wave::<T, D, false, F>(head, head_lengths, s, w, &f));
            left -= w;
        }
        fallbacks
    }

    /// [`Chain::waves`] with the chain's limits ([`wave_limited`]): each side as wavefronts of up to
    /// [`MAX_WAVE`] substeps, the tail side first, which hands the head side its first link (the one
    /// beside the moved joint) after each substep: the head side's first link is turned back into the
    /// moved joint's limit about it, as substep after substep does. Counts the links turned in
    /// `clamps`; returns the paper-form fallbacks.
    fn waves_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        k: u32,
        method: Method,
        clamps: &mut u32,
    ) -> u32 {
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return 0;
        };
        let (tail, head) = links.split_at_mut(m);
        let (tail_lengths, head_lengths) = lengths.split_at(m);
        let f = |t: &Vector<T, D>, s: &Vector<T, D>, l: T| step(method, t, s, l);
        let mut across = Across {
            links: [Vector::zeros(); MAX_WAVE],
            length: tail_lengths.last().copied().unwrap_or_else(T::one),
        };
        let mut fallbacks = 0u32;
        let mut left = k as usize;
        while left > 0 {
            let w = left.min(MAX_WAVE);
            let side = |links, lengths, offset| LimitedSide {
                links,
                lengths,
                offset,
                lim,
            };
            fallbacks = fallbacks
                .saturating_add(wave_limited::<T, D, true, _>(
                    side(&mut *tail, tail_lengths, 0),
                    s,
                    w,
                    &f,
                    &mut across,
                    clamps,
                ))
                .saturating_add(wave_limited::<T, D, false, _>(
                    side(&mut *head, head_lengths, m),
                    s,
                    w,
                    &f,
                    &mut across,
                    clamps,
                ));
            left -= w;
        }
        fallbacks
    }

    /// [`Chain::simd_waves`] for a limited chain (cones: a spatial chain in f64 or f32): the lanes
    /// step as there, each stepped link turned back into its limit
    /// ([`crate::strands::chain_wave_limited`]); `false` (nothing changed) for other chains and for
    /// fewer than [`SIMD_FROM`] substeps.
    fn simd_waves_limited(&mut self, m: usize, s: &Vector<T, D>, k: u32, clamps: &mut u32) -> bool {
        use std::any::Any;
        if (k as usize) < SIMD_FROM {
            return false;
        }
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return false;
        };
        let links: &mut dyn Any = links;
        let lengths: &dyn Any = lengths;
        let s: &dyn Any = s;
        let lim: &dyn Any = lim;
        if let (Some(l), Some(len), Some(s), Some(lim)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f64>>>(),
            lengths.downcast_ref::<Vec<f64>>(),
            s.downcast_ref::<nalgebra::Vector3<f64>>(),
            lim.downcast_ref::<JointLimits<f64>>(),
        ) {
            simd_side_waves_limited(l, len, lim, m, *s, k, clamps);
            return true;
        }
        if let (Some(l), Some(len), Some(s), Some(lim)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f32>>>(),
            lengths.downcast_ref::<Vec<f32>>(),
            s.downcast_ref::<nalgebra::Vector3<f32>>(),
            lim.downcast_ref::<JointLimits<f32>>(),
        ) {
            simd_side_waves_limited(l, len, lim, m, *s, k, clamps);
            return true;
        }
        false
    }

    /// The closed-form tractrix's `k` substeps of `s` with SIMD across the steps in flight, for a
    /// spatial chain in f64 or f32 (the types the lanes are written for; found at run time, so a
    /// planar chain or another scalar type answers `false` and changes nothing). Waves of at least
    /// [`SIMD_FROM`] substeps run in [`crate::strands::chain_wave`], shorter ones (a block of lanes
    /// would stand mostly idle) as the scalar wavefront.
    fn simd_waves(&mut self, m: usize, s: &Vector<T, D>, k: u32) -> bool {
        use std::any::Any;
        if (k as usize) < SIMD_FROM {
            return false;
        }
        let links: &mut dyn Any = &mut self.links;
        let lengths: &dyn Any = &self.lengths;
        let s: &dyn Any = s;
        if let (Some(l), Some(len), Some(s)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f64>>>(),
            lengths.downcast_ref::<Vec<f64>>(),
            s.downcast_ref::<nalgebra::Vector3<f64>>(),
        ) {
            simd_side_waves(l, len, m, *s, k);
            return true;
        }
        if let (Some(l), Some(len), Some(s)) = (
            links.downcast_mut::<Vec<nalgebra::Vector3<f32>>>(),
            lengths.downcast_ref::<Vec<f32>>(),
            s.downcast_ref::<nalgebra::Vector3<f32>>(),
        ) {
            simd_side_waves(l, len, m, *s, k);
            return true;
        }
        false
    }

    /// One substep: joint `m` moves by `s`; links toward the tail and toward the head follow outward.
    /// Returns the number of paper-form fallbacks. The origin is kept where it was (callers place it).
    pub(crate) fn sweep(&mut self, m: usize, s: &Vector<T, D>, method: Method) -> u32 {
        self.settle_origin();
        let (fallbacks, _) = self.tail_side(m, s, method, 0);
        fallbacks + self.head_side(m, s, method, self.links.len())
    }

    /// Joint `m` moves by `s`; links with 0-based index `m..hi` follow toward the head (the moving end of
    /// link index `i` is joint `i`, its trailing end joint `i+1`). Returns the fallbacks.
    pub(crate) fn sweep_head_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        hi: usize,
    ) -> u32 {
        if m < self.datum {
            self.settle_origin();
        }
        self.head_side(m, s, method, hi)
    }

    /// [`Chain::sweep_head_side`] leaving the datum alone (the caller places it).
    #[inline]
    fn head_side(&mut self, m: usize, s: &Vector<T, D>, method: Method, hi: usize) -> u32 {
        if self.limits.is_some() {
            return self.head_side_limited(m, s, method, hi, &mut 0);
        }
        // One loop per method, the method chosen once per sweep rather than once per link.
        match method {
            Method::Tractrix => {
                self.head_side_with(m, s, hi, |t, s, l| (tractrix_step(t, s, l), false))
            }
            Method::FollowTheLeader => {
                self.head_side_with(m, s, hi, |t, s, l| (follow_the_leader_step(t, s, l), false))
            }
            Method::TractrixPaper => self.head_side_with(m, s, hi, paper_or_closed_form),
        }
    }

    #[inline(always)]
    fn head_side_with<F>(&mut self, m: usize, s: &Vector<T, D>, hi: usize, f: F) -> u32
    where
        F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    {
        let mut fallbacks = 0;
        let mut shift = *s;
        for (l, &len) in self.links[m..hi].iter_mut().zip(&self.lengths[m..hi]) {
            let (st, fb) = f(l, &shift, len);
            *l = st.link;
            shift = st.tail_shift;
            fallbacks += fb as u32;
        }
        fallbacks
    }

    /// Joint `m` moves by `s`; links with 0-based index `lo..m` follow toward the tail (link index `i` has
    /// its head at joint `i+1`). Returns the fallbacks and the displacement of joint `lo`.
    pub(crate) fn sweep_tail_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        lo: usize,
    ) -> (u32, Vector<T, D>) {
        if lo < self.datum {
            self.settle_origin();
        }
        self.tail_side(m, s, method, lo)
    }

    /// [`Chain::sweep_tail_side`] leaving the datum alone (the caller places it).
    #[inline]
    fn tail_side(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        lo: usize,
    ) -> (u32, Vector<T, D>) {
        if self.limits.is_some() {
            return self.tail_side_limited(m, s, method, lo, &mut 0);
        }
        match method {
            Method::Tractrix => {
                self.tail_side_with(m, s, lo, |t, s, l| (tractrix_step(t, s, l), false))
            }
            Method::FollowTheLeader => {
                self.tail_side_with(m, s, lo, |t, s, l| (follow_the_leader_step(t, s, l), false))
            }
            Method::TractrixPaper => self.tail_side_with(m, s, lo, paper_or_closed_form),
        }
    }

    #[inline(always)]
    fn tail_side_with<F>(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        lo: usize,
        f: F,
    ) -> (u32, Vector<T, D>)
    where
        F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    {
        let mut fallbacks = 0;
        let mut shift = *s;
        for (l, &len) in self.links[lo..m].iter_mut().zip(&self.lengths[lo..m]).rev() {
            let (st, fb) = f(&(-*l), &shift, len);
            *l = -st.link;
            shift = st.tail_shift;
            fallbacks += fb as u32;
        }
        (fallbacks, shift)
    }

    /// [`Chain::head_side`] with the chain's limits: link `i`, once stepped, is turned back into joint
    /// `i`'s limit about link `i − 1` (already moved: the tail side's first link for an interior move).
    /// Counts the links turned in `clamps`.
    fn head_side_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        hi: usize,
        clamps: &mut u32,
    ) -> u32 {
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return 0;
        };
        let mut fallbacks = 0u32;
        let mut shift = *s;
        for i in m..hi {
            let (st, fb) = step(method, &links[i], &shift, lengths[i]);
            let (mut link, mut tail_shift) = (st.link, st.tail_shift);
            if i > 0
                && let Some(c) =
                    lim.clamp(i, &links[i - 1], lengths[i - 1], &link, lengths[i], false)
            {
                tail_shift += c - link;
                link = c;
                *clamps += 1;
            }
            links[i] = link;
            shift = tail_shift;
            fallbacks += fb as u32;
        }
        fallbacks
    }

    /// [`Chain::tail_side`] with the chain's limits: link `j`, once stepped, is turned back into joint
    /// `j + 1`'s limit about link `j + 1` (the moved joint's own angle is left to the head side).
    fn tail_side_limited(
        &mut self,
        m: usize,
        s: &Vector<T, D>,
        method: Method,
        lo: usize,
        clamps: &mut u32,
    ) -> (u32, Vector<T, D>) {
        let Chain {
            links,
            lengths,
            limits,
            ..
        } = self;
        let Some(lim) = limits.as_deref() else {
            return (0, *s);
        };
        let mut fallbacks = 0u32;
        let mut shift = *s;
        for j in (lo..m).rev() {
            let (st, fb) = step(method, &(-links[j]), &shift, lengths[j]);
            let (mut link, mut tail_shift) = (st.link, st.tail_shift);
            if j + 1 < m
                && let Some(c) = lim.clamp(
                    j + 1,
                    &(-links[j + 1]),
                    lengths[j + 1],
                    &link,
                    lengths[j],
                    true,
                )
            {
                tail_shift += c - link;
                link = c;
                *clamps += 1;
            }
            links[j] = -link;
            shift = tail_shift;
            fallbacks += fb as u32;
        }
        (fallbacks, shift)
    }
}

/// Largest excess over a joint limit, in radians, that a move may leave where the limits are not steered
/// link by link (held sides, collision passes, the closing two-link solutions); beyond it the move is
/// refused ([`ChainError::JointLimit`]). A clamped link sits on its limit to a few ulps.
pub const LIMIT_TOLERANCE: f64 = 1e-6;

/// Most substeps one wavefront keeps in flight ([`Chain::move_joint`] with `k ≥ 2` substeps); more
/// substeps run as several wavefronts. Two in flight already hide most of a step's latency on the
/// machine the throughput bench ran on; more cost nothing but a few hundred bytes of stack.
pub const MAX_WAVE: usize = 16;

/// The fewest substeps in flight for which a move runs its closed-form steps with SIMD
/// ([`crate::strands::chain_wave`]). Measured by the throughput bench: with four in flight a block of
/// eight lanes already beats the scalar wavefront; with two it stands mostly idle and does not.
pub const SIMD_FROM: usize = 4;

/// Both sides of a move of joint `m`, `k` substeps of `s`, in waves of up to
/// [`crate::strands::CHAIN_WAVE`]: SIMD for waves of at least [`SIMD_FROM`], the scalar wavefront
/// for a shorter last one.
fn simd_side_waves<T: crate::strands::StrandReal>(
    links: &mut [nalgebra::Vector3<T>],
    lengths: &[T],
    m: usize,
    s: nalgebra::Vector3<T>,
    k: u32,
) {
    use crate::strands::{CHAIN_WAVE, Simd, chain_wave};
    let (tail, head) = links.split_at_mut(m);
    let (tail_lengths, head_lengths) = lengths.split_at(m);
    let step =
        |t: &nalgebra::Vector3<T>, s: &nalgebra::Vector3<T>, l: T| (tractrix_step(t, s, l), false);
    let mut left = k as usize;
    while left > 0 {
        let w = left.min(CHAIN_WAVE);
        if w >= SIMD_FROM {
            chain_wave(tail, tail_lengths, s, w, true, Simd::Best);
            chain_wave(head, head_lengths, s, w, false, Simd::Best);
        } else {
            wave::<T, 3, true, _>(tail, tail_lengths, &s, w, &step);
            wave::<T, 3, false, _>(head, head_lengths, &s, w, &step);
        }
        left -= w;
    }
}

/// [`simd_side_waves`] for a limited chain: both sides of a move of joint `m`, the tail side first,
/// which hands the head side its link beside the moved joint after each substep; SIMD for waves of at
/// least [`SIMD_FROM`], the scalar [`wave_limited`] for a shorter last one.
fn simd_side_waves_limited<T: crate::strands::StrandReal>(
    links: &mut [nalgebra::Vector3<T>],
    lengths: &[T],
    lim: &JointLimits<T>,
    m: usize,
    s: nalgebra::Vector3<T>,
    k: u32,
    clamps: &mut u32,
) {
    use crate::strands::{CHAIN_WAVE, WaveLimits, chain_wave_limited};
    let (tail, head) = links.split_at_mut(m);
    let (tail_lengths, head_lengths) = lengths.split_at(m);
    let across_len = tail_lengths.last().copied().unwrap_or_else(T::one);
    let mut across = [nalgebra::Vector3::zeros(); CHAIN_WAVE];
    let step =
        |t: &nalgebra::Vector3<T>, s: &nalgebra::Vector3<T>, l: T| (tractrix_step(t, s, l), false);
    let mut left = k as usize;
    while left > 0 {
        let w = left.min(CHAIN_WAVE);
        if w >= SIMD_FROM {
            for (tail_side, offset) in [(true, 0), (false, m)] {
                let side: &mut [nalgebra::Vector3<T>] = if tail_side { tail } else { head };
                let side_lengths = if tail_side {
                    tail_lengths
                } else {
                    head_lengths
                };
                chain_wave_limited(
                    side,
                    side_lengths,
                    s,
                    w,
                    tail_side,
                    WaveLimits {
                        lim,
                        offset,
                        across: &mut across,
                        across_len,
                        clamps,
                    },
                );
            }
        } else {
            let mut a = Across {
                links: [nalgebra::Vector3::zeros(); MAX_WAVE],
                length: across_len,
            };
            let side = |links, lengths, offset| LimitedSide {
                links,
                lengths,
                offset,
                lim,
            };
            wave_limited::<T, 3, true, _>(
                side(&mut *tail, tail_lengths, 0),
                &s,
                w,
                &step,
                &mut a,
                clamps,
            );
            wave_limited::<T, 3, false, _>(
                side(&mut *head, head_lengths, m),
                &s,
                w,
                &step,
                &mut a,
                clamps,
            );
        }
        left -= w;
    }
}

/// `w ≤ MAX_WAVE` substeps of `s` along one side's links, as a wavefront: at diagonal `d`, substep `j`
/// steps the `(d − j)`-th link from the moved joint. `REV` is the tail side: its links are walked from
/// the last to the first and stepped reversed (`−l`), exactly as [`Chain::sweep_tail_side`] does.
#[inline(always)]
fn wave<T: Real, const D: usize, const REV: bool, F>(
    links: &mut [Vector<T, D>],
    lengths: &[T],
    s: &Vector<T, D>,
    w: usize,
    f: &F,
) -> u32
where
    F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
{
    let n = links.len();
    if n == 0 {
        return 0;
    }
    let mut lanes = [*s; MAX_WAVE];
    let mut fallbacks = 0u32;
    for d in 0..n + w - 1 {
        // Substeps lo..=hi are in flight; substep j is at the (d − j)-th link from the moved joint, so
        // the links stepped form one contiguous run (zipped, not indexed: no bounds check per step).
        let lo = d.saturating_sub(n - 1);
        let hi = d.min(w - 1);
        let lanes = &mut lanes[lo..=hi];
        if REV {
            // The (d − j)-th from the moved joint is index n − 1 + j − d: rising with j.
            let run = n - 1 + lo - d..=n - 1 + hi - d;
            for ((l, &len), lane) in links[run.clone()].iter_mut().zip(&lengths[run]).zip(lanes) {
                let (st, fb) = f(&(-*l), lane, len);
                *l = -st.link;
                *lane = st.tail_shift;
                fallbacks += fb as u32;
            }
        } else {
            // Index d − j: falling with j.
            let run = d - hi..=d - lo;
            let steps = links[run.clone()].iter_mut().zip(&lengths[run]).rev();
            for ((l, &len), lane) in steps.zip(lanes) {
                let (st, fb) = f(l, lane, len);
                *l = st.link;
                *lane = st.tail_shift;
                fallbacks += fb as u32;
            }
        }
    }
    fallbacks
}

/// One side of a limited chain for [`wave_limited`]: its links and lengths, the chain index of its
/// first link, the chain's limits.
struct LimitedSide<'a, T: Real, const D: usize> {
    links: &'a mut [Vector<T, D>],
    lengths: &'a [T],
    offset: usize,
    lim: &'a JointLimits<T>,
}

/// The tail side's link beside the moved joint after each substep of a wave, and its length: the head
/// side's first link is turned back into the moved joint's limit about it.
struct Across<T: Real, const D: usize> {
    links: [Vector<T, D>; MAX_WAVE],
    length: T,
}

/// [`wave`] with joint limits: each link, once stepped, is turned back into its limit about its
/// neighbour toward the moved joint at the same substep (as [`Chain::head_side_limited`] and
/// [`Chain::tail_side_limited`] do substep after substep). The substeps in flight run in ascending
/// order along a diagonal, so when substep `j` steps a link its neighbour still holds substep `j`'s
/// step (substep `j + 1` reaches it later in the same diagonal): the same operations on the same
/// inputs, equal bit for bit. The tail side (`REV`) writes `across` (its link beside the moved joint
/// after each substep); the head side reads it for its first link. Returns the fallbacks.
#[inline(always)]
fn wave_limited<T: Real, const D: usize, const REV: bool, F>(
    side: LimitedSide<'_, T, D>,
    s: &Vector<T, D>,
    w: usize,
    f: &F,
    across: &mut Across<T, D>,
    clamps: &mut u32,
) -> u32
where
    F: Fn(&Vector<T, D>, &Vector<T, D>, T) -> (LinkStep<T, D>, bool),
    Vector<T, D>: Embed3<T>,
{
    let LimitedSide {
        links,
        lengths,
        offset,
        lim,
    } = side;
    let n = links.len();
    if n == 0 {
        return 0;
    }
    let mut lanes = [*s; MAX_WAVE];
    let mut fallbacks = 0u32;
    for d in 0..n + w - 1 {
        let lo = d.saturating_sub(n - 1);
        let hi = d.min(w - 1);
        for (j, lane) in lanes.iter_mut().enumerate().take(hi + 1).skip(lo) {
            let along = d - j;
            if REV {
                let i = n - 1 - along;
                let (st, fb) = f(&(-links[i]), lane, lengths[i]);
                let (mut link, mut shift) = (st.link, st.tail_shift);
                if i + 1 < n
                    && let Some(c) = lim.clamp(
                        offset + i + 1,
                        &(-links[i + 1]),
                        lengths[i + 1],
                        &link,
                        lengths[i],
                        true,
                    )
                {
                    shift += c - link;
                    link = c;
                    *clamps += 1;
                }
                links[i] = -link;
                if along == 0 {
                    across.links[j] = links[i];
                }
                *lane = shift;
                fallbacks += fb as u32;
            } else {
                let i = along;
                let (st, fb) = f(&links[i], lane, lengths[i]);
                let (mut link, mut shift) = (st.link, st.tail_shift);
                if offset + i > 0 {
                    let (prev, prev_len) = if i > 0 {
                        (links[i - 1], lengths[i - 1])
                    } else {
                        (across.links[j], across.length)
                    };
                    if let Some(c) =
                        lim.clamp(offset + i, &prev, prev_len, &link, lengths[i], false)
                    {
                        shift += c - link;
                        link = c;
                        *clamps += 1;
                    }
                }
                links[i] = link;
                *lane = shift;
                fallbacks += fb as u32;
            }
        }
    }
    fallbacks
}

/// The paper's form where it is defined, the closed form (counted as a fallback) where it is not.
#[inline(always)]
fn paper_or_closed_form<T: Real, const D: usize>(
    t: &Vector<T, D>,
    s: &Vector<T, D>,
    len: T,
) -> (LinkStep<T, D>, bool)
where
    Vector<T, D>: Embed3<T>,
{
    step(Method::TractrixPaper, t, s, len)
}

/// The checks every constructor shares: at least one link, one length per link, finite coordinates.
fn check_parts<T: Real, const D: usize>(
    origin: &Vector<T, D>,
    links: &[Vector<T, D>],
    lengths: &[T],
) -> Result<(), ChainError> {
    if links.is_empty() {
        return Err(ChainError::Empty);
    }
    if links.len() != lengths.len() {
        return Err(ChainError::BadOption("links and lengths differ in count"));
    }
    if !all_finite(origin) || !links.iter().all(all_finite) {
        return Err(ChainError::NonFinite);
    }
    Ok(())
}
