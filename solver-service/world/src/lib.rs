//! The world of a solver service: the chains a scene declares, wire-free. No wire types, no iceoryx2,
//! no bincode and no clock: the service (`solver-service`) decodes requests into calls of this crate
//! and encodes what they return; a Rust simulator may use it without a service.
//!
//! * [`scene`]: scene text (read, validate, shapes) into [`scene::ChainSpec`]s and
//!   [`scene::BundleSpec`]s of kernel types, every error with its line and field;
//! * [`chains`]: the [`World`]: every chain and bundle of a scene, by handle; apply (atomic) and undo;
//! * [`form`]: a chain at run time in its scene's form ([`form::LiveChain`], [`form::Geometry`]);
//! * `apply`: one command on one chain, generic over its form (the per-chain body of
//!   [`World::apply`] and [`World::estimate`], one dispatch each);
//! * [`moves`]: what a command does to one chain (moves, paths, instruments, reaches), through the
//!   kernel's door [`tractrix::Rope`];
//! * [`point`]: the world's points and their conversion to a chain's vectors;
//! * [`elements`]: the payload of an answer, streamed into the caller's buffer;
//! * [`build`]: why a scene's world could not be built;
//! * [`bundles`]: the scene's bundles at run time;
//! * [`command`]: what the world is asked ([`command::Command`]) and answers ([`command::Answer`]);
//! * [`owners`]: who holds which grasp;
//! * [`refusal`]: why a command was refused, allocation-free;
//! * [`state`]: the world's state as one value ([`World::state`], [`World::restore`]);
//! * [`sizes`]: the bounds on everything a scene or a request may ask for;
//! * [`two_cores`]: many strands (hair, fur) swept on both cores.
//!
//! The numbers come from the I/O-free kernel crate [`tractrix`].

pub use chains::World;

mod apply;
pub mod build;
pub mod bundles;
pub mod chains;
pub mod command;
pub mod elements;
pub mod form;
pub mod moves;
pub mod needle;
pub mod owners;
pub mod point;
pub mod refusal;
pub mod scene;
pub mod sizes;
pub mod state;
pub mod tension;
pub mod two_cores;
