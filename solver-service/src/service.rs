//! The solver as a [`Handler`] of the one serving loop ([`crate::serve`]), with persistence around it:
//! an accepted change is journaled before it is acknowledged (a failed journal write undoes it), a
//! snapshot is written every `snapshot_every` while the state changes, on `snapshot` requests and on
//! shutdown.

use crate::persist::{JournalMode, PersistError, Store};
use crate::serve::{
    Clients, ElementSink, ElementSource, Handled, Handler, LoopOptions, PortError, ServerPorts,
    serve,
};
use crate::shm::ShmError;
use crate::wire::WireWorld;
use iceoryx2::prelude::ipc;
use shared::{RequestHeader, Vec3, Wait};
use std::path::PathBuf;
use std::time::{Duration, Instant};
use world::World;
use world::bundles::BundleElements;
use world::command::{Answer, Command, Residual};
use world::elements::{ChainElements, Counts, Elements};
use world::refusal::Refusal;
use world::refuse;

/// Persistence settings.
#[derive(Debug, Clone)]
pub struct Persistence {
    /// The state directory (snapshot and journal).
    pub dir: PathBuf,
    /// How the journal is written.
    pub journal: JournalMode,
    /// Restore the state from `dir` instead of starting from the scene.
    pub restore: bool,
    /// Restore past a damaged journal (what is dropped is reported; see [`Store::restore`]).
    pub from_damaged: bool,
    /// A snapshot after this long if the state changed (zero: only on shutdown and on command).
    pub snapshot_every: Duration,
}

/// Everything the service needs, validated.
#[derive(Debug, Clone)]
pub struct ServiceConfig {
    /// iceoryx2 prefix of this instance.
    pub prefix: String,
    /// How the serving thread waits (hybrid: how long it keeps spinning after the last request).
    pub wait: Wait,
    /// Pin the serving thread to this core.
    pub pin: Option<usize>,
    /// Snapshots and journal, or none.
    pub persistence: Option<Persistence>,
    /// Samples each subscriber of the state stream may buffer ([`shared::STATE_BUFFER`] by default).
    pub state_buffer: usize,
}

/// The solver: the chain set and the store.
pub struct Solver {
    set: World,
    store: Option<Store>,
    dirty_since_snapshot: bool,
    snapshot_every: Duration,
    last_snapshot: Instant,
}

impl std::fmt::Debug for Solver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Solver")
            .field("chains", &self.set.len())
            .field("sequence", &self.set.sequence())
            .finish()
    }
}

impl Solver {
    /// A solver over `set`, persisting into `store` if given.
    pub fn new(set: World, store: Option<Store>, snapshot_every: Duration) -> Self {
        Solver {
            set,
            store,
            dirty_since_snapshot: false,
            snapshot_every,
            last_snapshot: Instant::now(),
        }
    }

    /// A solver over `set` with the persistence asked for (none: `None`), the way every door starts
    /// one: the state directory opened (and locked), the state restored from it or its first snapshot
    /// written. Returns the solver and, after a restore, what was restored (a note for the ready line).
    pub fn open(
        set: World,
        persistence: Option<&Persistence>,
    ) -> Result<(Solver, String), ServiceError> {
        let mut set = set;
        let Some(p) = persistence else {
            return Ok((Solver::new(set, None, Duration::ZERO), String::new()));
        };
        let mut store = Store::open(&p.dir, p.journal)?;
        let mut note = String::new();
        if p.restore {
            let r = store.restore(&mut set, p.from_damaged)?;
            if let Some(d) = &r.damage {
                eprintln!("solver-service: restored past damage: {d}");
            }
            note = format!(
                "; restored state {} (snapshot {} + {} journal records{})",
                set.sequence(),
                r.snapshot_sequence,
                r.replayed,
                if r.damage.is_some() {
                    ", past damage (see above)".to_string()
                } else if r.dropped_tail_bytes > 0 {
                    format!(
                        ", {} unacknowledged tail bytes dropped",
                        r.dropped_tail_bytes
                    )
                } else {
                    String::new()
                }
            );
        } else {
            store.begin(&set)?;
        }
        Ok((Solver::new(set, Some(store), p.snapshot_every), note))
    }

    /// Ends a door's run: the last snapshot written (with persistence) and the line that says so.
    pub fn close(&mut self) -> Result<(), ServiceError> {
        if let Some(store) = self.store.as_mut() {
            store.snapshot(&self.set)?;
        }
        for (k, st) in self.set.resolution_stats() {
            if st.resolutions > 0 {
                eprintln!(
                    "solver-service: {}",
                    resolution_line(&self.set.specs()[k as usize].name, &st)
                );
            }
        }
        eprintln!(
            "solver-service: shut down cleanly at state {} ({} snapshots written since the start)",
            self.set.sequence(),
            self.store.as_ref().map_or(0, |s| s.written())
        );
        Ok(())
    }

    /// The chains.
    pub fn set(&self) -> &World {
        &self.set
    }

    /// The chains, to change outside the answer path (benches, tests): nothing done through it is
    /// journaled.
    pub fn set_mut(&mut self) -> &mut World {
        &mut self.set
    }

    /// Decodes and applies a request of `client`, with the snapshot command and the journal around the
    /// chain set.
    fn run(
        &mut self,
        client: u128,
        header: &RequestHeader,
        points: &[Vec3],
    ) -> Result<Answer, Refusal> {
        let req = self.set.decode(header, points)?;
        if matches!(req, Command::Snapshot) {
            let outcome = self.set.apply(&req)?;
            return match self.store.as_mut().map(|s| s.snapshot(&self.set)) {
                Some(Ok(())) => {
                    self.dirty_since_snapshot = false;
                    Ok(outcome)
                }
                Some(Err(e)) => Err(refuse!(PersistenceFailed, "{e}")),
                None => Err(refuse!(
                    PersistenceFailed,
                    "persistence is off (--no-persist)"
                )),
            };
        }
        let outcome = self.set.apply_guarded(client, &req)?;
        // A bundle's change is not persisted (see `crate::bundles`).
        if outcome.changed && !outcome.bundle {
            if let Some(store) = self.store.as_mut()
                && let Err(e) = store.append(self.set.sequence(), header, points)
            {
                self.set.undo();
                return Err(refuse!(PersistenceFailed, "{e}"));
            }
            self.dirty_since_snapshot = true;
        }
        Ok(outcome)
    }

    /// Starts a background snapshot if one is due and the state changed since the last; collects the
    /// outcome of the one before.
    fn snapshot_if_due(&mut self, now: Instant) {
        let Some(store) = self.store.as_mut() else {
            return;
        };
        match store.finished() {
            Some(Ok(_)) => {}
            Some(Err(e)) => {
                eprintln!("solver-service: periodic snapshot failed: {e}");
                // Its changes are not on disk yet: the next period tries again.
                self.dirty_since_snapshot = true;
            }
            None => {}
        }
        if self.snapshot_every.is_zero()
            || now.duration_since(self.last_snapshot) < self.snapshot_every
            || !self.dirty_since_snapshot
        {
            return;
        }
        match store.snapshot_in_background(&self.set) {
            Ok(true) => {
                self.last_snapshot = now;
                self.dirty_since_snapshot = false;
            }
            Ok(false) => {} // the previous one is still being written
            Err(e) => {
                self.last_snapshot = now;
                eprintln!("solver-service: periodic snapshot failed: {e}");
            }
        }
    }
}

impl Handler for Solver {
    fn answer(&mut self, client: u128, req: &RequestHeader, points: &[Vec3]) -> Handled {
        let result = self.run(client, req, points);
        let landing = match result.as_ref().map(|o| o.residual) {
            Ok(Residual::Landing { joint, target }) => Some((joint, Vec3::from(target))),
            _ => None,
        };
        Handled {
            header: self.set.encode(req, &result),
            chain: req.chain,
            counts: result.as_ref().map_or(Counts::default(), |o| o.counts),
            changed: result.as_ref().is_ok_and(|o| o.changed),
            bundle: result.is_ok_and(|o| o.bundle),
            landing,
        }
    }

    fn write<K: ElementSink>(&self, chain: u32, counts: &Counts, sink: K) -> K::Out {
        // The form is picked once per response, not per element.
        match self.set.elements_for(chain, counts) {
            Elements::Empty => sink.take(Wire(std::iter::empty())),
            Elements::Planar64(e) => sink.take(Wire(e)),
            Elements::Spatial64(e) => sink.take(Wire(e)),
            Elements::Planar32(e) => sink.take(Wire(e)),
            Elements::Spatial32(e) => sink.take(Wire(e)),
            Elements::Bundle(e) => sink.take(Wire(e)),
        }
    }

    fn housekeeping(&mut self, now: Instant, clients: Option<&Clients<'_>>) {
        self.snapshot_if_due(now);
        if let Some(clients) = clients
            && self.set.grasps_owned()
        {
            let n = self.set.forget_absent_owners(|id| clients.present(id));
            if n > 0 {
                eprintln!(
                    "solver-service: {n} grasp(s) of clients that have gone now hold unowned"
                );
            }
        }
    }
}

/// One form of the world's elements as wire points.
struct Wire<E>(E);

impl<E: Iterator<Item = world::command::Point>> Iterator for Wire<E> {
    type Item = Vec3;
    #[inline]
    fn next(&mut self) -> Option<Vec3> {
        self.0.next().map(Vec3::from)
    }
}

/// A chain's joints are gathered by the form's own tight loop.
macro_rules! gathered_by_the_chain {
    ($($t:ty, $d:literal);*) => {$(
        impl ElementSource for Wire<ChainElements<'_, $t, $d>> {
            fn gather_into(self, out: &mut Vec<Vec3>, n: usize) {
                self.0.gather_into(out, n);
            }
        }
    )*};
}
gathered_by_the_chain!(f64, 2; f64, 3; f32, 2; f32, 3);
impl ElementSource for Wire<BundleElements<'_>> {}
impl ElementSource for Wire<std::iter::Empty<world::command::Point>> {}

/// Why the service stopped or did not start.
#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    /// The state directory (opening, restoring, the first or the last snapshot).
    #[error(transparent)]
    Persist(#[from] PersistError),
    /// iceoryx2's ports (opening them, or the loop's waits).
    #[error(transparent)]
    Ports(#[from] PortError),
    /// The shared memory for the ports.
    #[error(transparent)]
    SharedMemory(#[from] ShmError),
    /// The core to pin the serving thread to.
    #[error("{0}")]
    Pin(String),
    /// iceoryx2's configuration for the prefix.
    #[error("{0}")]
    Config(String),
}

/// Serves `set` until SIGINT or SIGTERM; then writes a last snapshot. `ready` is called once the ports
/// are open (the binary prints a line that scripts and tests wait for).
pub fn run(cfg: &ServiceConfig, set: World, ready: impl FnOnce(&str)) -> Result<(), ServiceError> {
    if let Some(core) = cfg.pin {
        shared::pin_current_thread(core).map_err(ServiceError::Pin)?;
    }
    let (mut solver, restored_note) = Solver::open(set, cfg.persistence.as_ref())?;
    let set = &solver.set;
    let (elements, joints) = set.response_sizes();
    let iox = shared::iceoryx_config(&cfg.prefix).map_err(ServiceError::Config)?;
    let shm = std::path::Path::new(crate::shm::SHM_DIR);
    crate::shm::check_room(shm)?;
    let (ports, stale) = ServerPorts::<ipc::Service>::open(
        &iox,
        "tractrix-solver",
        elements,
        Some(joints),
        cfg.state_buffer,
        set.bundle_stream_size(),
    )?;
    if stale > 0 {
        eprintln!("solver-service: cleaned the resources of {stale} dead process(es)");
    }
    let (_, reserved) = crate::shm::reserve(shm, &cfg.prefix)?;
    let bundles = match solver.set.bundles().len() {
        0 => String::new(),
        n => format!(" and {n} bundles"),
    };
    ready(&format!(
        "solver-service ready: {} chains{bundles}, prefix {}, wait {}, {:.1} MiB of shared memory reserved{}",
        solver.set.len(),
        cfg.prefix,
        cfg.wait.mode().name(),
        reserved as f64 / f64::from(1 << 20),
        restored_note
    ));
    serve(
        &ports,
        &mut solver,
        &LoopOptions {
            wait: cfg.wait,
            stop: None,
        },
    )?;
    solver.close()?;
    Ok(())
}

/// Serves the raw echo ([`crate::echo`]) through the same loop until SIGINT or SIGTERM.
pub fn run_echo(
    prefix: &str,
    elements: u32,
    opts: &LoopOptions,
    pin: Option<usize>,
    ready: impl FnOnce(&str),
) -> Result<(), ServiceError> {
    if let Some(core) = pin {
        shared::pin_current_thread(core).map_err(ServiceError::Pin)?;
    }
    let iox = shared::iceoryx_config(prefix).map_err(ServiceError::Config)?;
    let (ports, _) =
        ServerPorts::<ipc::Service>::open(&iox, "tractrix-echo", elements as usize, None, 1, None)?;
    ready(&format!(
        "solver-service echo ready: {elements} elements, prefix {prefix}, wait {}",
        opts.wait.mode().name()
    ));
    Ok(serve(&ports, &mut crate::echo::Echo { elements }, opts)?)
}

/// One chain's contact resolutions in a line (printed at shutdown): where its collision time went.
pub fn resolution_line(chain: &str, st: &tractrix::collision::ResolutionStats) -> String {
    format!(
        "chain {chain}: contact resolution: {} resolutions ({} of {} passes or more), {} passes; \
         joint projections: {} ({} converged, {} stalled), {} Newton steps",
        st.resolutions,
        st.long,
        tractrix::collision::ResolutionStats::LONG,
        st.passes,
        st.projections,
        st.converged,
        st.stalled,
        st.newton_steps
    )
}
