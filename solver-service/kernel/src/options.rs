//! The options of a move ([`MoveOptions`], its [`Substeps`]) and of a fixed-base reach
//! ([`ReachOptions`], its [`Strategy`]): plain values, a leaf of the crate (a move with held joints
//! carries the reach options its held sides are solved with).

use crate::link::Method;
use crate::math::Real;

/// How a move is divided into straight substeps. Motion is path dependent: finer substeps follow a curved
/// path more closely (error ∝ h² for the tractrix, ∝ h for follow-the-leader) and cost proportionally more.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Substeps<T> {
    /// Exactly `k ≥ 1` equal substeps.
    Fixed(u32),
    /// As many equal substeps as needed so that none is longer than this fraction of the chain's shortest
    /// link (must be positive and finite).
    MaxStep(T),
}

/// Options of a move. `Default` is the closed-form tractrix in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveOptions<T> {
    /// Single-link method propagated down the chain.
    pub method: Method,
    /// Substep policy.
    pub substeps: Substeps<T>,
    /// Upper bound on substeps per move; a move that would need more is refused (`TooManySubsteps`)
    /// rather than spinning. Each substep costs one pass over the chain.
    pub max_substeps: u32,
    /// How the sides of a move that end at a held joint are solved ([`crate::hold`]): strategy,
    /// tolerance, iteration limit and when the reach hierarchy finishes. Its `method` and `substeps` are
    /// the move's own. Unused without held joints.
    pub held: ReachOptions<T>,
}

impl<T: Real> Default for MoveOptions<T> {
    fn default() -> Self {
        MoveOptions {
            method: Method::Tractrix,
            substeps: Substeps::Fixed(1),
            max_substeps: 1 << 16,
            held: ReachOptions::default(),
        }
    }
}

/// Which of the paper's two fixed-base strategies to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Strategy {
    /// (i) tractrix, then rigid translation back to the base, repeated. The paper's preferred strategy.
    #[default]
    TranslateBack = 0,
    /// (ii) tractrix down to the third link, closed-form two-link solution for the first two.
    TractrixTwoLink = 1,
    /// Tractrix to the target, then tractrix pulling joint 0 back to the base, repeated: the
    /// correction dies out away from the base (not one of the paper's two).
    PullBack = 2,
}

/// Options of a fixed-base reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReachOptions<T> {
    /// Strategy (i) or (ii).
    pub strategy: Strategy,
    /// Single-link method for the tractrix passes.
    pub method: Method,
    /// Substeps of each tractrix pass. More substeps follow the straight head path more closely; the
    /// converged pose differs slightly, the cost grows linearly.
    pub substeps: u32,
    /// Accepted distance between head and target, as a fraction of the chain's total length. Smaller
    /// costs more iterations; below ~100 ε of the scalar type it may not be reachable at all.
    pub tolerance: T,
    /// Iteration limit; reaching it is reported as [`crate::ReachError::NotConverged`] and nothing moves. Most
    /// targets need about 3 iterations (as the paper found); targets near full reach, where a nearly
    /// straight chain passes a pull on almost undamped, need hundreds.
    pub max_iterations: u32,
    /// After this many tractrix iterations without convergence, finish with Korein & Badler's reach
    /// hierarchy from the current pose (0 = never). The iteration converges linearly with a rate that
    /// tends to 1 near full reach; the hierarchy places each joint minimally (proximal joints least) and
    /// lands exactly in one O(n) pass. Larger keeps more of the tractrix's character, smaller is faster.
    pub hierarchy_after: u32,
}

impl<T: Real> Default for ReachOptions<T> {
    fn default() -> Self {
        ReachOptions {
            strategy: Strategy::TranslateBack,
            method: Method::Tractrix,
            substeps: 1,
            tolerance: T::lit(1e-9).max(T::EPSILON * T::lit(64.0)),
            max_iterations: 1000,
            hierarchy_after: 16,
        }
    }
}

impl<T: Real> ReachOptions<T> {
    /// The most tractrix passes over the chain (per substep) a fixed-base solve with these options
    /// runs: `max_iterations`, or without limits (`limited` false) the `hierarchy_after` iterations and
    /// the hierarchy's one pass when that comes first; with limits the hierarchy's pose is kept only
    /// when it lands within them, so each of the `max_iterations` may also try it (two passes);
    /// boundary following ([`crate::boundary`]) takes its passes from the same budget. What a
    /// move with held joints is charged per side ([`crate::hold`]) and what the service's estimate
    /// counts.
    pub fn passes_bound(&self, limited: bool) -> u64 {
        let passes = if self.hierarchy_after == 0 {
            u64::from(self.max_iterations)
        } else if limited {
            u64::from(self.max_iterations).saturating_mul(2)
        } else {
            u64::from(
                self.max_iterations
                    .min(self.hierarchy_after.saturating_add(1)),
            )
        };
        passes.max(1)
    }
}
