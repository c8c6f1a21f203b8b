//! The I/O-free numeric kernel: no iceoryx2, no files, no clocks, no printing, no allocation per move.
//! `.ci/run` greps this directory to keep it that way.
//!
//! * [`math`]: scalar trait, vector aliases, tolerances.
//! * [`link`]: one link, three ways (closed-form tractrix, the paper's TRACTRIX3D, follow-the-leader).
//! * [`chain`]: flat chain state and RESOLUTION-TRACTRIX (head, tail or interior joint moves, substeps).
//! * [`collision`]: self-collision and obstacles (the paper's spheres, capsules on a hash grid).
//! * [`fixed_base`]: fixed-base manipulators, both of the paper's strategies, workspace checks.
//! * [`knot`]: knot identification (closure, projection, Gauss code, Reidemeister I/II, Jones polynomial).
//! * [`angles`]: joint angles (eq. 15, relative rotations).
//! * [`pseudo_inverse`]: the damped-least-squares resolved-rate baseline of Korein & Badler.
//! * [`ground_truth`]: the continuous motion integrated by DOP853, for tests and accuracy reports.

pub mod angles;
pub mod chain;
pub mod collision;
pub mod fixed_base;
pub mod ground_truth;
pub mod knot;
pub mod link;
pub mod math;
pub mod pseudo_inverse;

pub use chain::{Chain, ChainError, MoveOptions, MoveOutcome, Substeps};
pub use fixed_base::{ReachError, ReachOptions, ReachOutcome, ReachWorkspace, Strategy, reach};
pub use link::{LinkStep, Method};
pub use math::{Real, Vector};
