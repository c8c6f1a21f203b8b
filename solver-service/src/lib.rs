//! Tractrix redundancy resolution for flexible objects (sutures, ropes, snakes) and hyper-redundant
//! manipulators, after Sreenivasan, Goel & Ghosal, with the goal-directed-motion baselines of Korein &
//! Badler.
//!
//! The crate has one I/O-free numeric [`kernel`]; the service binary around it lives in `src/main.rs`.
//!
//! ```
//! use solver::kernel::{Chain, MoveOptions};
//! use nalgebra::Vector3;
//!
//! // A 40-link rope of unit links along +x, its head dragged sideways.
//! let mut rope = Chain::<f64, 3>::straight(40, 1.0, Vector3::zeros(), Vector3::x()).unwrap();
//! let head = rope.head_index();
//! rope.move_joint(head, Vector3::new(40.0, 5.0, 0.0), &MoveOptions::default()).unwrap();
//! assert!((rope.head() - Vector3::new(40.0, 5.0, 0.0)).norm() < 1e-12);
//! ```

pub mod batch;
pub mod chain_set;
pub mod kernel;
pub mod persist;
pub mod scene;
pub mod service;
pub mod unix_socket;
