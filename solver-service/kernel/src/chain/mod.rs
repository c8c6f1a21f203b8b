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

mod sweep;

/// What a successful move did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
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
    /// A move that stopped short inside its frame
    /// ([`CollisionWorkspace::stop_short`](crate::collision::CollisionWorkspace::stop_short)): what
    /// stopped it, the state that of the last substep made. `None` when the whole move was made.
    pub short: Option<Short>,
}

/// Why and where a move stopped short of its target: the chain is left as its last whole substep
/// left it (every length kept, its contacts resolved, its holds and eyelets kept).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Short {
    /// What stopped the next substep (out of work, locked, a held side out of reach, a limit).
    pub error: ChainError,
    /// The substeps made, of `of` planned (0: the chain did not move).
    pub made: u32,
    /// The substeps the move was split into.
    pub of: u32,
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
        self.short = self.short.or(o.short);
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
        for (o, p) in out[..=self.links.len()].iter_mut().zip(self.joints()) {
            *o = p;
        }
    }

    /// The `n + 1` joint positions, tail first, in one pass over the links (the values of
    /// [`Chain::write_positions`], bit for bit; [`Chain::joint`] costs a pass of its own per joint).
    pub fn joints(&self) -> impl Iterator<Item = Vector<T, D>> + '_ {
        let origin = self.origin();
        let mut acc = CompensatedSum::new(origin);
        let mut pins = self.pins.iter().peekable();
        let mut first = origin;
        if let Some(&(_, s)) = pins.next_if(|p| p.0 == 0) {
            acc = s;
            first = s.value();
        }
        core::iter::once(first).chain(self.links.iter().enumerate().map(move |(i, l)| {
            acc.add(l);
            if let Some(&(_, s)) = pins.next_if(|p| p.0 == i + 1) {
                acc = s;
            }
            acc.value()
        }))
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
