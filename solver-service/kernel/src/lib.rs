//! Tractrix redundancy resolution for flexible objects (sutures, ropes, snakes) and hyper-redundant
//! manipulators, after Sreenivasan, Goel & Ghosal, with the goal-directed-motion baselines of Korein &
//! Badler. An I/O-free library: no files, no clocks, no printing, no threads, no IPC, no allocation per
//! move; state is taken by `&mut` and results are written into the caller's buffers, so a Rust simulator
//! (a Bevy or rapier system, any game loop) can embed it in-process, without the solver service.
//!
//! ```
//! use nalgebra::Vector3;
//! use tractrix::{Chain, MoveOptions};
//!
//! // The paper's rope: 40 links of unit length along +x.
//! let mut rope = Chain::<f64, 3>::straight(40, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
//! // Drag the head sideways; every link follows its tractrix, lengths are kept exactly.
//! let head = rope.head_index();
//! rope.move_joint(head, Vector3::new(40.0, 5.0, 0.0), &MoveOptions::default()).unwrap();
//! assert!((rope.head() - Vector3::new(40.0, 5.0, 0.0)).norm() < 1e-12);
//! ```
//!
//! * [`rope`]: **the door**: one chain with its collision model and eyelets, one method per action
//!   (`move_to`, `move_along`, `push`, `move_eyelet`), one outcome type; the modules below are its
//!   implementation.
//! * [`options`]: the options of a move and of a fixed-base reach.
//! * [`math`]: scalar trait, vector aliases, tolerances.
//! * [`link`]: one link, three ways (closed-form tractrix, the paper's TRACTRIX3D, follow-the-leader).
//! * [`chain`]: flat chain state and RESOLUTION-TRACTRIX (head, tail or interior joint moves, substeps).
//! * [`collision`]: self-collision and obstacles (the paper's spheres, capsules on a tree of boxes
//!   over the chain), in query, tree and resolve modules.
//! * [`eyelet`]: fixed points a chain passes through, the rope sliding through each (a suture's entry
//!   and exit points in tissue).
//! * [`fixed_base`]: fixed-base manipulators, both of the paper's strategies, workspace checks.
//! * [`goals`]: Korein & Badler's goals beyond a point for a fixed-base chain: an orientation of the
//!   last link, a box or a ball for the head.
//! * [`hold`]: moves with held joints (anchors, grasps): each side up to a held joint solved as a
//!   fixed-base chain.
//! * [`limits`]: joint limits (cones, planar ranges, a rope's minimum bend radius), honoured link by
//!   link as a sweep runs.
//! * [`path`]: smooth key-frame paths (a natural cubic spline through key points, C² everywhere).
//! * [`angles`]: joint angles (eq. 15, relative rotations).
//! * [`strands`]: many free strands at once (hair, fur, bundles), SIMD across strands, the substep
//!   wavefront; and one chain's wavefront with SIMD across its steps in flight
//!   ([`strands::chain_wave`], what [`Chain::move_joint`] runs from four closed-form substeps on).
//! * `pseudo_inverse` (feature `reference`): the damped-least-squares resolved-rate baseline of Korein &
//!   Badler.
//! * `ground_truth` (feature `reference`): the continuous motion integrated by DOP853, for tests and
//!   accuracy reports.
//!
//! Cargo keeps the crate pure: its only dependencies are `nalgebra`, `pulp` (safe run-time SIMD dispatch for [`strands`]; no I/O) and `thiserror` (and `ode_solvers`
//! with the `reference` feature).

#![deny(missing_docs)]

pub mod angles;
pub mod boundary;
pub mod chain;
pub mod collision;
pub mod eyelet;
pub mod fixed_base;
pub mod goals;
#[cfg(feature = "reference")]
pub mod ground_truth;
pub mod hold;
pub mod limits;
pub mod link;
pub mod math;
pub mod options;
pub mod path;
#[cfg(feature = "reference")]
pub mod pseudo_inverse;
pub mod rope;
pub mod strands;

pub use chain::{Chain, ChainError, MoveOptions, MoveOutcome, Short, Substeps};
pub use fixed_base::{ReachError, ReachOptions, ReachOutcome, ReachWorkspace, Strategy, reach};
pub use goals::{Goal, reach_goal};
pub use limits::{JointLimits, LimitError, LimitKind};
pub use link::{LinkStep, Method};
pub use math::{Real, Vector};
pub use rope::{Rope, RopeError};
