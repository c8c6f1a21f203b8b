//! The tractrix solver service: a long-running process that holds the chains of a scene and answers
//! "move this point of the chain to P" over iceoryx2 shared memory. The numbers come from the I/O-free
//! kernel crate [`tractrix`]; this crate is everything around it.
//!
//! * [`scene`]: scene files (read, validate, shapes) into [`scene::ChainSpec`]s of kernel types;
//! * [`request`]: the typed request path (`decode` → [`chain_set::ChainSet::apply`] → `encode`);
//! * [`chain_set`]: the chains of a scene, flat, addressed by handle, and the one owner of rollback;
//! * [`serve`]: the one serving loop (generic over the iceoryx2 service variant) and its ports;
//! * [`service`]: the solver as a [`serve::Handler`], with persistence and shutdown;
//! * [`echo`]: the raw echo, the latency bench's baseline, served by the same loop;
//! * [`persist`]: snapshots and the journal (the only bincode user);
//! * [`bundle`]: many strands (hair, fur) swept on both cores;
//! * [`batch`], [`unix_socket`]: the same requests from a file and over a Unix socket.

pub mod batch;
pub mod bundle;
pub mod bundles;
pub mod chain_set;
pub mod echo;
pub mod owners;
pub mod persist;
pub mod request;
pub mod scene;
pub mod serve;
pub mod service;
pub mod shm;
pub mod unix_socket;
