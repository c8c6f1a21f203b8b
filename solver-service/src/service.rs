//! The iceoryx2 side of the service: ports, waiting, the serving loop, persistence around it. The only
//! module that touches iceoryx2.
//!
//! One thread serves everything, in request order:
//!
//! 1. receive a request (header + target slice, read in place in shared memory);
//! 2. back up the chain, validate and apply ([`ChainSet::apply`]); journal an accepted change before
//!    anything is acknowledged (a failed journal write rolls the change back);
//! 3. loan the response slice and stream the joints **directly into it**, set the header, send;
//! 4. wake the client if it asked to be woken; publish the new state on the state stream.
//!
//! Waiting ([`WaitMode`]): `spin` polls without pause (one core at 100 %, the lowest latency), `event`
//! sleeps on a WaitSet until a client's notification (no CPU when idle, one wake-up per request),
//! `hybrid` sleeps like `event` but after each request spins for a short budget so a burst (a 1 kHz
//! haptic loop) is served at spin latency while an idle service sleeps. Hybrid is the default: with two
//! cores, two hand clients and a viewer, at most the service spins, and only while requests flow.

use crate::chain_set::ChainSet;
use crate::persist::{JournalMode, Store};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use protocol::ports::{ServerPorts, service_name};
use protocol::{
    Command, MAX_CLIENTS, RequestHeader, ResponseHeader, SERVICE_STATE, StateHeader, Status, Vec3,
};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How the serving thread waits for requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitMode {
    Spin,
    Event,
    Hybrid,
}

impl WaitMode {
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "spin" => Ok(WaitMode::Spin),
            "event" => Ok(WaitMode::Event),
            "hybrid" => Ok(WaitMode::Hybrid),
            _ => Err(format!("wait mode {s:?}: expected spin, event or hybrid")),
        }
    }
}

/// Persistence settings.
#[derive(Debug, Clone)]
pub struct Persistence {
    pub dir: PathBuf,
    pub journal: JournalMode,
    /// Restore the state from `dir` instead of starting from the scene.
    pub restore: bool,
    /// A snapshot after this long if the state changed (zero: only on shutdown and on command).
    pub snapshot_every: Duration,
}

/// Everything the serving loop needs, validated.
#[derive(Debug, Clone)]
pub struct ServiceConfig {
    pub prefix: String,
    pub wait: WaitMode,
    /// Hybrid: how long to keep spinning after the last request.
    pub spin_budget: Duration,
    /// Pin the serving thread to this core.
    pub pin: Option<usize>,
    pub persistence: Option<Persistence>,
}

type Svc = ipc::Service;

struct Ports {
    node: Node<Svc>,
    server_ports: ServerPorts,
    publisher: Publisher<Svc, [Vec3], StateHeader>,
}

fn err<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> String {
    move |e| format!("{what}: {e:?}")
}

fn open_ports(
    cfg: &ServiceConfig,
    max_elements: usize,
    max_joints: usize,
) -> Result<Ports, String> {
    let iox = protocol::iceoryx_config(&cfg.prefix)?;
    // Resources of a predecessor that died without cleaning up (kill -9, power cut).
    let mut stale = 0;
    let _ = Node::<Svc>::list(&iox, |state| {
        if let NodeState::Dead(view) = state
            && view.try_remove_stale_resources().is_ok()
        {
            stale += 1;
        }
        CallbackProgression::Continue
    });
    if stale > 0 {
        eprintln!("solver-service: cleaned the resources of {stale} dead process(es)");
    }
    let node = NodeBuilder::new()
        .config(&iox)
        .name(&"tractrix-solver".try_into().map_err(err("node name"))?)
        .create::<Svc>()
        .map_err(err("cannot create the iceoryx2 node"))?;
    let server_ports = ServerPorts::open(&node, max_elements)?;
    let publisher = node
        .service_builder(&service_name(SERVICE_STATE)?)
        .publish_subscribe::<[Vec3]>()
        .user_header::<StateHeader>()
        .max_publishers(1)
        .max_subscribers(MAX_CLIENTS)
        .max_nodes(MAX_CLIENTS + 4)
        .subscriber_max_buffer_size(64)
        .history_size(0)
        .enable_safe_overflow(true)
        .open_or_create()
        .map_err(err("cannot open or create the state stream"))?
        .publisher_builder()
        .initial_max_slice_len(max_joints)
        .create()
        .map_err(err("cannot create the state publisher"))?;
    Ok(Ports {
        node,
        server_ports,
        publisher,
    })
}

/// The serving loop's state.
pub struct Solver {
    set: ChainSet,
    store: Option<Store>,
    dirty_since_snapshot: bool,
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
    fn serve_pending(&mut self, ports: &Ports) -> Result<usize, String> {
        let mut served = 0;
        while let Some(req) = ports
            .server_ports
            .server
            .receive()
            .map_err(err("receive"))?
        {
            served += 1;
            let t0 = Instant::now();
            let header = *req.user_header();
            let points = req.payload();
            let mut h = ResponseHeader::default();
            let changed = self.handle(&header, points, &mut h);
            h.solve_ns = t0.elapsed().as_nanos() as u64;
            let n = (h.n_joints + h.n_angles) as usize;
            match req.loan_slice_uninit(n) {
                Ok(slot) => {
                    let mut it = self.set.elements(h.chain, h.n_angles > 0).take(n);
                    // n == 0 (an error) never touches the iterator's chain.
                    let mut resp = slot.write_from_fn(|_| it.next().unwrap_or_default());
                    *resp.user_header_mut() = h;
                    if let Err(e) = resp.send() {
                        eprintln!("solver-service: response not delivered: {e:?}");
                    }
                }
                Err(e) => {
                    // Only possible if the scene outgrew the port, which open_ports sizes for.
                    eprintln!("solver-service: cannot loan a response of {n} elements: {e:?}");
                }
            }
            ports.server_ports.wake_client(header.listener_id());
            drop(req);
            if changed {
                self.publish(ports, &header, h.sequence);
            }
        }
        Ok(served)
    }

    fn handle(&mut self, header: &RequestHeader, points: &[Vec3], h: &mut ResponseHeader) -> bool {
        if header.command == Command::Snapshot as u32 {
            self.set.apply(header, points, h);
            if h.status == Status::Ok as u32 {
                match self.store.as_mut().map(|s| s.snapshot(&self.set)) {
                    Some(Ok(())) => self.dirty_since_snapshot = false,
                    Some(Err(e)) => {
                        h.status = Status::PersistenceFailed as u32;
                        h.set_reason(&e);
                    }
                    None => {
                        h.status = Status::PersistenceFailed as u32;
                        h.set_reason("persistence is off (--no-persist)");
                    }
                }
            }
            return false;
        }
        let chain = header.chain;
        let changes = Command::from_u32(header.command).is_some_and(Command::changes_state);
        let backup = if changes {
            self.set.backup(chain)
        } else {
            None
        };
        let changed = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            self.set.apply(header, points, h)
        })) {
            Ok(c) => c,
            Err(_) => {
                self.set.rollback(chain, backup);
                *h = ResponseHeader {
                    status: Status::Internal as u32,
                    command: header.command,
                    chain,
                    request_id: header.request_id,
                    sequence: self.set.sequence(),
                    ..ResponseHeader::default()
                };
                h.set_reason("internal error in the solver; state kept");
                return false;
            }
        };
        if changed {
            if let Some(store) = self.store.as_mut()
                && let Err(e) = store.append(self.set.sequence(), header, points)
            {
                self.set.rollback(chain, backup);
                h.status = Status::PersistenceFailed as u32;
                h.n_joints = 0;
                h.n_angles = 0;
                h.sequence = self.set.sequence();
                h.set_reason(&e);
                return false;
            }
            self.dirty_since_snapshot = true;
        }
        changed
    }

    fn publish(&self, ports: &Ports, header: &RequestHeader, sequence: u64) {
        let n = self.set.n_joints(header.chain);
        match ports.publisher.loan_slice_uninit(n) {
            Ok(slot) => {
                let mut it = self.set.elements(header.chain, false);
                let mut s = slot.write_from_fn(|_| it.next().unwrap_or_default());
                *s.user_header_mut() = StateHeader {
                    sequence,
                    chain: header.chain,
                    n_joints: n as u32,
                    command: header.command,
                    reserved: 0,
                    request_id: header.request_id,
                };
                if let Err(e) = s.send() {
                    eprintln!("solver-service: state not published: {e:?}");
                }
            }
            Err(e) => eprintln!("solver-service: cannot loan a state sample: {e:?}"),
        }
    }

    fn snapshot_if_due(&mut self, due: bool) {
        if due
            && self.dirty_since_snapshot
            && let Some(store) = self.store.as_mut()
        {
            match store.snapshot(&self.set) {
                Ok(()) => self.dirty_since_snapshot = false,
                Err(e) => eprintln!("solver-service: periodic snapshot failed: {e}"),
            }
        }
    }
}

/// Pins the calling thread to CPU `core`.
pub fn pin_current_thread(core: usize) -> Result<(), String> {
    let id = core_affinity::get_core_ids()
        .unwrap_or_default()
        .into_iter()
        .find(|c| c.id == core)
        .ok_or_else(|| format!("--pin {core}: no such core"))?;
    if core_affinity::set_for_current(id) {
        Ok(())
    } else {
        Err(format!("--pin {core}: the scheduler refused"))
    }
}

/// Serves `set` until SIGINT or SIGTERM; then writes a last snapshot. `ready` is called once the ports
/// are open (the binary prints a line that scripts and tests wait for).
pub fn run(cfg: &ServiceConfig, set: ChainSet, ready: impl FnOnce(&str)) -> Result<(), String> {
    if let Some(core) = cfg.pin {
        pin_current_thread(core)?;
    }
    let mut solver = Solver {
        set,
        store: None,
        dirty_since_snapshot: false,
    };
    let mut restored_note = String::new();
    if let Some(p) = &cfg.persistence {
        let mut store = Store::open(&p.dir, p.journal)?;
        if p.restore {
            let r = store.restore(&mut solver.set)?;
            restored_note = format!(
                "; restored state {} (snapshot {} + {} journal records{})",
                solver.set.sequence(),
                r.snapshot_sequence,
                r.replayed,
                if r.dropped_tail_bytes > 0 {
                    format!(
                        ", {} unacknowledged tail bytes dropped",
                        r.dropped_tail_bytes
                    )
                } else {
                    String::new()
                }
            );
        } else {
            store.snapshot(&solver.set)?;
        }
        solver.store = Some(store);
    }
    let max_links = solver
        .set
        .entries()
        .iter()
        .map(|e| e.def.lengths.len())
        .max()
        .unwrap_or(1);
    let ports = open_ports(cfg, 2 * max_links + 1, max_links + 1)?;
    ready(&format!(
        "solver-service ready: {} chains, prefix {}, wait {:?}{}",
        solver.set.len(),
        cfg.prefix,
        cfg.wait,
        restored_note
    ));

    let tick = Duration::from_millis(50);
    let mut last_snapshot = Instant::now();
    let snapshot_every = cfg
        .persistence
        .as_ref()
        .map(|p| p.snapshot_every)
        .unwrap_or(Duration::ZERO);
    let due = |last: &Instant| !snapshot_every.is_zero() && last.elapsed() >= snapshot_every;

    match cfg.wait {
        WaitMode::Spin => {
            let mut idle: u32 = 0;
            loop {
                if solver.serve_pending(&ports)? > 0 {
                    idle = 0;
                    continue;
                }
                idle = idle.wrapping_add(1);
                if idle.is_multiple_of(4096) {
                    if ports.node.wait(Duration::ZERO).is_err() {
                        break;
                    }
                    if due(&last_snapshot) {
                        solver.snapshot_if_due(true);
                        last_snapshot = Instant::now();
                    }
                }
                std::hint::spin_loop();
            }
        }
        WaitMode::Event | WaitMode::Hybrid => {
            let ws = WaitSetBuilder::new()
                .create::<Svc>()
                .map_err(err("cannot create the WaitSet"))?;
            let guard = ws
                .attach_notification(&ports.server_ports.wake_listener)
                .map_err(err("cannot attach the wake listener"))?;
            let mut failure: Option<String> = None;
            loop {
                let r = ws.wait_and_process_once_with_timeout(
                    |id| {
                        if id.has_event_from(&guard) {
                            let _ = ports.server_ports.wake_listener.try_wait(|_| {});
                        }
                        CallbackProgression::Continue
                    },
                    tick,
                );
                match r {
                    Ok(WaitSetRunResult::TerminationRequest | WaitSetRunResult::Interrupt) => {
                        break;
                    }
                    Ok(_) => {}
                    Err(e) => return Err(format!("WaitSet: {e:?}")),
                }
                // Serve even without a notification: a polling client may not notify.
                let mut served = match solver.serve_pending(&ports) {
                    Ok(n) => n,
                    Err(e) => {
                        failure = Some(e);
                        break;
                    }
                };
                if cfg.wait == WaitMode::Hybrid && served > 0 {
                    let mut last = Instant::now();
                    let mut polls: u32 = 0;
                    loop {
                        while last.elapsed() < cfg.spin_budget {
                            served = solver.serve_pending(&ports)?;
                            if served > 0 {
                                last = Instant::now();
                            }
                            polls = polls.wrapping_add(1);
                            if polls.is_multiple_of(4096)
                                && ports.node.wait(Duration::ZERO).is_err()
                            {
                                break;
                            }
                            std::hint::spin_loop();
                        }
                        // Notifications that arrived while spinning are stale now: drop them, then
                        // serve once more. A request that landed after the last poll has its
                        // notification dropped here, and would otherwise wait for the next tick
                        // (50 ms; the loaded latency bench caught it).
                        let _ = ports.server_ports.wake_listener.try_wait(|_| {});
                        if solver.serve_pending(&ports)? == 0 {
                            break;
                        }
                        last = Instant::now();
                    }
                }
                if due(&last_snapshot) {
                    solver.snapshot_if_due(true);
                    last_snapshot = Instant::now();
                }
                if ports.node.wait(Duration::ZERO).is_err() {
                    break;
                }
            }
            drop(guard);
            if let Some(e) = failure {
                return Err(e);
            }
        }
    }
    if let Some(store) = solver.store.as_mut() {
        store.snapshot(&solver.set)?;
    }
    eprintln!(
        "solver-service: shut down cleanly at state {}",
        solver.set.sequence()
    );
    Ok(())
}
