//! The tractrix solver service: a long-running process that holds the chains of a scene and answers
//! "move this point of the chain to P" over iceoryx2 shared memory. The numbers come from the I/O-free
//! kernel crate [`tractrix`], the chains' model from the wire-free crate [`world`] (scenes, the
//! bundles' two-core helper); this crate is the doors around them.
//!
//! * [`scene_file`]: reading a scene file, which [`world::scene`] parses and validates;
//! * [`wire`]: the wire's door: [`wire::request`] decodes into a [`world::command::Command`],
//!   [`world::World::apply`] answers, [`wire::request`] encodes; [`wire::bundle`] for bundles;
//! * [`serve`]: the one serving loop (generic over the iceoryx2 service variant) and its ports;
//! * [`service`]: the solver as a [`serve::Handler`], with persistence and shutdown;
//! * [`echo`]: the raw echo, the latency bench's baseline, served by the same loop;
//! * [`persist`]: snapshots and the journal (the only bincode user);
//! * [`batch`], [`unix_socket`]: the same requests from a file and over a Unix socket.

pub mod batch;
pub mod echo;
pub mod persist;
pub mod scene_file;
pub mod serve;
pub mod service;
pub mod shm;
pub mod unix_socket;
pub mod wire;
