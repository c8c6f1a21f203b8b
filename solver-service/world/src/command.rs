//! Commands to the world and what they answer: a [`Command`] is a request with every field checked
//! and every default resolved against its chain (the door that decodes it does that); the world
//! applies it and returns an [`Answer`] or a [`crate::refusal::Refusal`]. Points are
//! [`Point`]s, which a door may borrow from its own buffers (the service from shared memory).

pub use crate::point::Point;
use serde::{Deserialize, Serialize};
use tractrix::{MoveOptions, ReachOptions};

/// A fixed-base reach's goal (Korein & Badler's point, orientation and region goals: [`tractrix::goals`]).
pub type Goal = tractrix::Goal<f64, 3>;

/// What a move of the head does to the chain's needle ([`crate::needle`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum NeedleMove {
    /// Carried rigidly with the head, turned with the head link (every move without a needle flag).
    #[default]
    Carried,
    /// Driven (the wire's `FLAG_DRIVE`): along its own arc instead of turning with the head link,
    /// its point making holes where it crosses the tissue's surface.
    Driven,
    /// Posed (the wire's `FLAG_POSE`), as a 6-DOF stylus holds a needle driver: the swage at the
    /// target and the needle turned to the rotation vector (axis × angle, radians) from its own
    /// frame to the world's: it leaves the swage along `R·x`, curving toward `R·y`. Its point makes
    /// holes as a driven needle's does.
    Posed(Point),
}

/// A command: everything checked and resolved, ready for the kernel.
#[derive(Debug, Clone, PartialEq)]
pub enum Command<'a> {
    /// Move `joint` through `targets` (one for a move, several for a path).
    Move {
        /// Chain handle.
        chain: u32,
        /// Joint index, resolved (the head is `n_links`).
        joint: usize,
        /// Target points, all finite, in range and in the chain's plane.
        targets: &'a [Point],
        /// Method and substeps, defaults resolved.
        options: MoveOptions<f64>,
        /// Move the joint even if another client grasps it, taking the grasp over
        /// (the wire's `FLAG_TAKE_OVER`).
        take_over: bool,
        /// Follow the natural cubic spline through the joint and the targets (C², Korein & Badler's
        /// smooth key frames: [`tractrix::path`]) instead of straight segments: each segment sampled
        /// into as many points as it has substeps.
        smooth: bool,
        /// Pull (the wire's `FLAG_PULL`; one target): a move the rope cannot make in full (a held side
        /// out of reach, contact locked, a joint limit) goes as far toward the target as it can, and
        /// the rest is the joint's pull ([`crate::tension`]) instead of a refusal.
        pull: bool,
        /// What the chain's needle does (a move of the head of a chain with a needle).
        needle: NeedleMove,
    },
    /// Bring a fixed-base chain's head to its goal: a point, a pose of the last link, or anywhere in a
    /// region.
    Reach {
        /// Chain handle.
        chain: u32,
        /// The goal, its points checked (finite, in the chain's plane).
        goal: Goal,
        /// Strategy, method, tolerance and limits, defaults resolved.
        options: ReachOptions<f64>,
        /// Append joint rotations to the response.
        angles: bool,
    },
    /// The current joints.
    Query {
        /// Chain handle.
        chain: u32,
        /// Append joint rotations to the response.
        angles: bool,
    },
    /// The chain's description and joints.
    Describe {
        /// Chain handle.
        chain: u32,
    },
    /// Back to the scene's initial state (every grasp dropped).
    Reset {
        /// Chain handle.
        chain: u32,
        /// Drop other clients' grasps too (the wire's `FLAG_TAKE_OVER`).
        take_over: bool,
    },
    /// Write a snapshot now (the service's business; the chain set only validates it).
    Snapshot,
    /// Hold `joint` where it is (a hand's grasp).
    Grasp {
        /// Chain handle (a free chain).
        chain: u32,
        /// Joint index, resolved.
        joint: usize,
        /// Take the grasp over if another client holds it (the wire's `FLAG_TAKE_OVER`).
        take_over: bool,
    },
    /// Let a grasped joint go.
    Release {
        /// Chain handle (a free chain).
        chain: u32,
        /// Joint index, resolved.
        joint: usize,
        /// Release another client's grasp (the wire's `FLAG_TAKE_OVER`).
        take_over: bool,
    },
    /// Move an instrument of the chain to a new pose, pushing the chain.
    Instrument {
        /// Chain handle (a chain that lists the instrument).
        chain: u32,
        /// The instrument's index in the chain's `instruments` list.
        index: usize,
        /// New centre.
        centre: Point,
        /// New axis direction (capsules; not normalised).
        axis: Option<Point>,
        /// Substep limit (the chain's).
        max_substeps: u32,
        /// Pull (the wire's `FLAG_PULL`): a pose the rope cannot make way for is taken as far as it
        /// goes (the centre along the straight line, the axis turned in proportion), and the rest is
        /// the instrument's pull ([`crate::tension`]) instead of a refusal.
        pull: bool,
    },
    /// Move an eyelet of the chain to a new point, carrying the rope's point at it
    /// ([`tractrix::eyelet::move_eyelet`]).
    Eyelet {
        /// Chain handle.
        chain: u32,
        /// The eyelet's index in the scene's `eyelets`.
        index: usize,
        /// Where it goes.
        at: Point,
        /// Substep limit (the chain's).
        max_substeps: u32,
    },
    /// A command to a bundle.
    Bundle {
        /// Wire handle (after the chains').
        handle: u32,
        /// Index among the scene's bundles.
        index: usize,
        /// What to do.
        op: BundleOp<'a>,
    },
}

impl Command<'_> {
    /// The chain the request addresses (`None` for a snapshot).
    pub fn chain(&self) -> Option<u32> {
        match *self {
            Command::Move { chain, .. }
            | Command::Reach { chain, .. }
            | Command::Query { chain, .. }
            | Command::Describe { chain }
            | Command::Reset { chain, .. }
            | Command::Grasp { chain, .. }
            | Command::Release { chain, .. }
            | Command::Instrument { chain, .. }
            | Command::Eyelet { chain, .. } => Some(chain),
            Command::Snapshot | Command::Bundle { .. } => None,
        }
    }

    /// Whether an accepted request of this kind changes the state.
    pub fn changes_state(&self) -> bool {
        matches!(
            self,
            Command::Move { .. }
                | Command::Reach { .. }
                | Command::Reset { .. }
                | Command::Grasp { .. }
                | Command::Release { .. }
                | Command::Instrument { .. }
                | Command::Eyelet { .. }
        ) || matches!(self, Command::Bundle { op, .. } if op.changes_state())
    }
}

/// What an accepted command did: what its answer holds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Answer {
    /// The chain (`None` for a snapshot).
    pub chain: Option<u32>,
    /// Whether the state changed (a new sequence number; journaled and published).
    pub changed: bool,
    /// The layout of the response's payload.
    pub counts: Counts,
    /// Substeps taken (moves).
    pub substeps: u32,
    /// Paper-form substeps that fell back to the closed form.
    pub paper_fallbacks: u32,
    /// Reach iterations, or collision passes of a move.
    pub iterations: u32,
    /// How the residual is known.
    pub residual: Residual,
    /// Whether the response carries the chain's description.
    pub describe: bool,
    /// Whether a bundle answered (its change goes to the bundle stream, not the journal).
    pub bundle: bool,
    /// The chain's knot after the command, when its scene asks for it (`knot = true`).
    pub knot: Option<knots::KnotType>,
    /// Why a move or an instrument pose stopped short of its target inside its frame (`None`: it
    /// made the whole move).
    pub stopped: Option<Stop>,
    /// What the kernel met where it stopped short (the substep, a lock's passes), when it did.
    pub short: Option<tractrix::Short>,
}

/// The distance between where a joint should be and where it is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Residual {
    /// Not applicable (zero on the wire).
    #[default]
    None,
    /// Known from the kernel (a reach).
    Known(f64),
    /// `joint` should be at `target`: measured on the joints as written into the response, so no extra
    /// pass over the chain (by the door that writes it).
    Landing {
        /// Joint index.
        joint: usize,
        /// Where it was sent.
        target: Point,
    },
}

/// What a command asks of a bundle, checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BundleOp<'a> {
    /// Every strand's head to its own target, in `substeps` substeps.
    Heads {
        /// One target per strand, finite and in range.
        targets: &'a [Point],
        /// Substeps, ≥ 1.
        substeps: u32,
    },
    /// Every head by one rigid motion of the scene's heads: `R(rotation)·h0 + translation`.
    Pose {
        /// Translation.
        translation: Point,
        /// Rotation vector (axis × angle, radians).
        rotation: Point,
        /// Substeps, ≥ 1.
        substeps: u32,
    },
    /// The joints.
    Query,
    /// The description and the joints.
    Describe,
    /// Back to the scene's strands.
    Reset,
}

impl BundleOp<'_> {
    /// Whether an accepted request of this kind changes the bundle.
    pub fn changes_state(&self) -> bool {
        matches!(
            self,
            BundleOp::Heads { .. } | BundleOp::Pose { .. } | BundleOp::Reset
        )
    }
}

/// Why a pulled joint or instrument stopped short of where it was asked to go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Stop {
    /// The stretch to a held joint is out of length (the rope is taut), or its solve did not converge.
    Reach,
    /// Contact could not make way (the knot or the instrument jammed).
    Contact,
    /// A joint would have gone beyond its limit.
    Limit,
    /// The request's frame ran out (its work budget): the next request goes on from where this one
    /// stopped.
    Work,
}

/// Elements of an instrument's pose in a payload: a sphere's centre twice, then `(radius, 0, 0)`; a
/// capsule's `a`, its `b`, then `(radius, 1, 0)` (the wire's `InstrumentPose`).
pub const INSTRUMENT_ELEMENTS: usize = 3;
/// Elements of an eyelet in a payload: its point, then `(link, 1 threaded / 0 left, 0)`.
pub const EYELET_ELEMENTS: usize = 2;
/// Elements of a block of tissue in a payload: its corners `lo` and `hi`.
pub const TISSUE_ELEMENTS: usize = 2;

/// The layout of an answer's payload: how many of each part it holds, in payload order (joints,
/// rotations, held joints, instruments, pulls, eyelets, tissue). The world sets it with the answer;
/// the door that writes the payload and the one that states it (the wire's header) read it, and
/// nothing reads it back from a header.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Joints (tail first), or a bundle's joints.
    pub joints: u32,
    /// Joint rotations (one per link), 0 unless asked.
    pub angles: u32,
    /// Held joints: `(index, 1 anchor / 0 grasp, 1 taut / 0)` each.
    pub held: u32,
    /// Instruments, [`INSTRUMENT_ELEMENTS`] elements each.
    pub instruments: u32,
    /// Pulls: one per held joint, then one per instrument ([`crate::tension`]).
    pub pulls: u32,
    /// Eyelets, [`EYELET_ELEMENTS`] elements each.
    pub eyelets: u32,
    /// Blocks of tissue (a describe's), [`TISSUE_ELEMENTS`] elements each.
    pub tissue: u32,
}

impl Counts {
    /// Elements of the whole payload.
    pub fn elements(&self) -> usize {
        self.joints as usize
            + self.angles as usize
            + self.held as usize
            + INSTRUMENT_ELEMENTS * self.instruments as usize
            + self.pulls as usize
            + EYELET_ELEMENTS * self.eyelets as usize
            + TISSUE_ELEMENTS * self.tissue as usize
    }
}
