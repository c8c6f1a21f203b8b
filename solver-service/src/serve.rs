//! The one serving loop: the service and the latency bench's raw echo both serve through [`serve`], so the
//! echo baseline waits exactly as the service does. Generic over the iceoryx2 service variant (`ipc` for
//! processes, `local` for a test inside one process).
//!
//! One thread serves everything. Requests are served **round robin over clients** ([`Fair`]): every
//! request waiting is taken into its client's queue, and each round serves at most one request per
//! client, the client just served going to the back; a client that connects while others flood is
//! served after at most one request of each of them. A client's own requests keep their order. Between
//! any two requests the loop looks for signals and runs housekeeping (see below). For each request:
//!
//! 1. receive it (header + target slice, read in place in shared memory);
//! 2. [`Handler::answer`] answers it: a response header, whether the state changed, and a move's
//!    landing;
//! 3. loan the response slice and [`Handler::write`] its elements into it (gathered by a tight loop
//!    into a reused buffer and copied at once, or, for a bundle's megabytes, streamed straight in);
//!    the landing's residual is measured on what was written (what the client receives);
//! 4. send the response and wake the client if it asked; for a change, publish the joints just
//!    written on the state stream (no second pass over the chain), from the buffer after the
//!    response has gone, so the client does not wait for the viewers' sample (a sample of more than
//!    [`DEFER_STATE_UP_TO`] elements, a bundle's, is copied from the response before it goes).
//!
//! Waiting ([`Wait`]): `spin` polls without pause (one core at 100 %, the lowest latency), `event`
//! sleeps on a WaitSet until a client's notification (no CPU when idle, one wake-up per request),
//! `hybrid` sleeps like `event` but after each request spins for a short budget so a burst (a 1 kHz
//! haptic loop) is served at spin latency while an idle service sleeps. In every mode the loop looks
//! for SIGINT/SIGTERM and runs [`Handler::housekeeping`] (periodic snapshots, grasps of clients gone) between any two requests
//! once [`CHECK_EVERY`] has passed, whatever the traffic (a request in hand, bounded by the budget, is
//! finished first).

use iceoryx2::active_request::ActiveRequest;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::prelude::*;
use iceoryx2::response_mut::ResponseMut;
use iceoryx2::response_mut_uninit::ResponseMutUninit;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::sample_mut_uninit::SampleMutUninit;
use iceoryx2::service::Service;
use iceoryx2::waitset::WaitSetRunResult;
use shared::{
    BUNDLE_STATE_BUFFER, MAX_BUNDLE_SUBSCRIBERS, MAX_CLIENTS, RequestHeader, ResponseHeader,
    SERVICE_BUNDLE_STATE, SERVICE_COMMAND, SERVICE_STATE, SERVICE_WAKE_CLIENT, SERVICE_WAKE_SERVER,
    StateHeader, Status, Vec3, Wait, service_name,
};
use std::collections::VecDeque;
use std::mem::MaybeUninit;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use world::elements::Counts;

/// How often the loop looks for a termination request and runs housekeeping, under any traffic.
pub const CHECK_EVERY: Duration = Duration::from_millis(1);
/// How often the loop looks for clients that have gone, while the handler tracks clients.
pub const CLIENTS_EVERY: Duration = Duration::from_millis(500);
/// Least time between two checks of the clients present forced by a request refused as `held` (a
/// client that sends such requests in a loop cannot make the loop list clients for each).
pub const CLIENTS_FORCED_EVERY: Duration = Duration::from_millis(20);
/// Longest sleep of the event and hybrid modes without a notification (a polling client may not
/// notify; its request is served at the next tick).
pub const TICK: Duration = Duration::from_millis(50);

/// Why the serving loop's ports could not be opened, or why the loop stopped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PortError {
    /// iceoryx2 refused a step (`what`); `detail` is its error as iceoryx2 prints it.
    #[error("{what}: {detail}")]
    Iceoryx {
        /// The step.
        what: &'static str,
        /// iceoryx2's error.
        detail: String,
    },
    /// Another server holds this prefix's ports.
    #[error("{ANOTHER} ({detail})")]
    Taken {
        /// Which port is taken, and iceoryx2's error.
        detail: String,
    },
    /// A service name the protocol builds from the prefix was refused.
    #[error("{0}")]
    Name(String),
    /// SIGINT or SIGTERM arrived while the ports were being opened.
    #[error("terminated while starting")]
    Terminated,
}

fn err<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> PortError {
    move |e| PortError::Iceoryx {
        what,
        detail: format!("{e:?}"),
    }
}

/// The protocol's service `s` under this process's prefix.
fn protocol_name(s: &str) -> Result<iceoryx2::prelude::ServiceName, PortError> {
    service_name(s).map_err(PortError::Name)
}

/// The ports of a server of this protocol: the request server, the two wake-up events and, for the
/// service, the state stream. Opened with the settings every server of the protocol uses (one server,
/// [`MAX_CLIENTS`] clients, two requests in flight per client).
pub struct ServerPorts<S: Service> {
    /// The process's node (termination requests arrive here).
    pub node: Node<S>,
    /// Requests in, responses out.
    pub server: Server<S, [Vec3], RequestHeader, [Vec3], ResponseHeader>,
    /// Woken by clients after they send.
    pub wake_listener: Listener<S>,
    /// Wakes the client whose listener id a request carries.
    pub wake_notifier: Notifier<S>,
    /// Every accepted change, in order (the service has one, the raw echo none).
    pub state: Option<Publisher<S, [Vec3], StateHeader>>,
    /// Every accepted change of a bundle (only for a scene with bundles).
    pub bundle_state: Option<Publisher<S, [Vec3], StateHeader>>,
    /// The command service (its clients are listed to find grasp owners that have gone).
    pub command: CommandService<S>,
}

/// The command service's port factory.
pub type CommandService<S> = iceoryx2::service::port_factory::request_response::PortFactory<
    S,
    [Vec3],
    RequestHeader,
    [Vec3],
    ResponseHeader,
>;

impl<S: Service> std::fmt::Debug for ServerPorts<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServerPorts")
            .field("state", &self.state.is_some())
            .finish()
    }
}

impl<S: Service> ServerPorts<S> {
    /// Creates the node `name` with `iox` and opens (or creates) the services: responses of up to
    /// `max_elements` elements, a state stream of up to `state_joints` joints if given (each subscriber
    /// may buffer `state_buffer` samples), and a bundle stream of up to `bundle_joints` joints if
    /// given. Resources
    /// of a dead predecessor (kill -9, power cut) are cleaned first; the count is returned.
    pub fn open(
        iox: &iceoryx2::config::Config,
        name: &str,
        max_elements: usize,
        state_joints: Option<usize>,
        state_buffer: usize,
        bundle_joints: Option<usize>,
    ) -> Result<(Self, usize), PortError> {
        let mut stale = 0;
        let _ = Node::<S>::list(iox, |state| {
            if let NodeState::Dead(view) = state
                && view.try_remove_stale_resources().is_ok()
            {
                stale += 1;
            }
            CallbackProgression::Continue
        });
        let node = NodeBuilder::new()
            .config(iox)
            .name(&name.try_into().map_err(err("node name"))?)
            .create::<S>()
            .map_err(|e| PortError::Iceoryx {
                what: "cannot create the iceoryx2 node",
                detail: match shared::iceoryx_root_problem(iox) {
                    Some(why) => format!("{e:?}: {why}"),
                    None => format!("{e:?}"),
                },
            })?;
        // iceoryx2 installs its SIGINT/SIGTERM handlers the first time a termination request is looked
        // for. Look now, before the caller says it is ready: a signal sent right after the ready line
        // would otherwise kill the process the default way, without its final snapshot (the signal
        // test found it).
        if node.wait(Duration::ZERO).is_err() {
            return Err(PortError::Terminated);
        }
        // The command service and its server come last: a client that finds the command service
        // finds the wake-up events and the state stream already there.
        let wake_listener = node
            .service_builder(&protocol_name(SERVICE_WAKE_SERVER)?)
            .event()
            .max_notifiers(MAX_CLIENTS + 2)
            .max_listeners(2)
            .max_nodes(MAX_CLIENTS + 4)
            .open_or_create()
            .map_err(err("cannot open or create the wake-server event"))?
            .listener_builder()
            .create()
            .map_err(err("wake listener"))?;
        let wake_notifier = node
            .service_builder(&protocol_name(SERVICE_WAKE_CLIENT)?)
            .event()
            .max_notifiers(2)
            .max_listeners(MAX_CLIENTS + 2)
            .max_nodes(MAX_CLIENTS + 4)
            .open_or_create()
            .map_err(err("cannot open or create the wake-client event"))?
            .notifier_builder()
            .create()
            .map_err(err("wake notifier"))?;
        let state = state_joints
            .map(|joints| {
                stream_publisher(
                    &node,
                    SERVICE_STATE,
                    MAX_CLIENTS,
                    state_buffer,
                    joints,
                    "state stream",
                )
            })
            .transpose()?;
        // Megabytes per sample: a short buffer, few subscribers (shared memory is reserved for every
        // sample a subscriber may hold).
        let bundle_state = bundle_joints
            .map(|joints| {
                stream_publisher(
                    &node,
                    SERVICE_BUNDLE_STATE,
                    MAX_BUNDLE_SUBSCRIBERS,
                    BUNDLE_STATE_BUFFER,
                    joints,
                    "bundle stream",
                )
            })
            .transpose()?;
        let command = node
            .service_builder(&protocol_name(SERVICE_COMMAND)?)
            .request_response::<[Vec3], [Vec3]>()
            .request_user_header::<RequestHeader>()
            .response_user_header::<ResponseHeader>()
            .max_servers(1)
            .max_clients(MAX_CLIENTS)
            .max_nodes(MAX_CLIENTS + 4)
            .max_active_requests_per_client(2)
            // One response per request, read before the next: a buffer of one and one borrowed
            // response keep the server's data segment (reserved at start, `crate::shm`) at
            // 16 × 4 × 3 responses instead of 16 × 4 × 5.
            .max_response_buffer_size(1)
            .max_borrowed_responses_per_pending_response(1)
            .open_or_create()
            .map_err(err(
                "cannot open or create the command service (a peer of another protocol version?)",
            ))?;
        let server = command
            .server_builder()
            // One response per request: the data segment holds fewer samples (a bundle's response
            // is megabytes).
            .max_loaned_responses_per_request(1)
            .initial_max_slice_len(max_elements.max(1))
            .create()
            .map_err(|e| PortError::Taken {
                detail: format!("the command service has its server already: {e:?}"),
            })?;
        Ok((
            ServerPorts {
                node,
                server,
                wake_listener,
                wake_notifier,
                state,
                bundle_state,
                command,
            },
            stale,
        ))
    }

    /// Wakes the client listener `id` (from [`RequestHeader::listener_id`]); zero wakes nobody.
    pub fn wake_client(&self, id: u128) {
        if id == 0 {
            return;
        }
        self.wake_notifier.for_each_listener(|m, d| {
            if d.listener_id.value() == id {
                let _ = m.notify();
                CallbackProgression::Stop
            } else {
                CallbackProgression::Continue
            }
        });
    }
}

/// What a start says when the prefix is taken.
const ANOTHER: &str = "another solver-service already serves this prefix: stop it, or start this one \
     with --prefix NAME (and give its clients the same --prefix, or TRACTRIX_IOX_PREFIX=NAME)";

/// The publisher of a stream of accepted states (`service`): samples of up to `joints` elements, at
/// most `subscribers` subscribers buffering `buffer` samples each, the oldest dropped on overflow.
fn stream_publisher<S: Service>(
    node: &Node<S>,
    service: &str,
    subscribers: usize,
    buffer: usize,
    joints: usize,
    what: &'static str,
) -> Result<Publisher<S, [Vec3], StateHeader>, PortError> {
    node.service_builder(&protocol_name(service)?)
        .publish_subscribe::<[Vec3]>()
        .user_header::<StateHeader>()
        .max_publishers(1)
        .max_subscribers(subscribers)
        .max_nodes(MAX_CLIENTS + 4)
        .subscriber_max_buffer_size(buffer)
        .history_size(0)
        .enable_safe_overflow(true)
        .open_or_create()
        .map_err(|e| PortError::Iceoryx {
            what: "cannot open or create a state stream",
            detail: format!("the {what}: {e:?}"),
        })?
        .publisher_builder()
        .initial_max_slice_len(joints.max(1))
        .create()
        .map_err(|e| {
            let e = format!("{e:?}");
            if e.contains("ExceedsMaxSupportedPublishers") {
                PortError::Taken {
                    detail: format!("the {what} has its publisher already: {e}"),
                }
            } else {
                PortError::Iceoryx {
                    what: "cannot create a state stream's publisher",
                    detail: format!("the {what}: {e}"),
                }
            }
        })
}

/// A handled request: the response header, the layout of its payload and whether the state changed
/// (then the payload's joints, held joints, instruments, pulls and eyelets are the new state,
/// published on the state stream).
#[derive(Debug, Clone, Copy)]
pub struct Handled {
    /// The response header, everything but `solve_ns` (the loop measures it) and, for a landing, the
    /// residual (measured on the written elements).
    pub header: ResponseHeader,
    /// The chain (or bundle) the payload is of.
    pub chain: u32,
    /// The payload's layout, as the handler answered it (the header states the same counts; the loop
    /// never reads them back from it).
    pub counts: Counts,
    /// Whether an accepted change was made.
    pub changed: bool,
    /// Whether a bundle changed (published on the bundle stream instead of the state stream).
    pub bundle: bool,
    /// A move's landing: element `.0` of the response should be at `.1`. The response's `residual` is
    /// their distance, measured on the elements as written (what the client receives), with no extra
    /// pass over the chain.
    pub landing: Option<(usize, Vec3)>,
}

/// A response's elements in one concrete form ([`Handler::write`] picks the form once per response,
/// not per element).
pub trait ElementSource: Iterator<Item = Vec3> + Sized {
    /// Appends the first `n` elements to `out`, the same as `out.extend(self.take(n))` (a chain's
    /// joints are gathered by one tight loop).
    fn gather_into(self, out: &mut Vec<Vec3>, n: usize) {
        out.extend(self.take(n));
    }
}

/// Where a response's elements go: the loaned shared memory, or a buffer.
pub trait ElementSink {
    /// What taking the elements gives.
    type Out;
    /// Consumes the elements.
    fn take<I: ElementSource>(self, it: I) -> Self::Out;
}

/// Gathers the first `.1` elements into a buffer (the loop's scratch; no allocation once warm).
struct Gather<'a>(&'a mut Vec<Vec3>, usize);

impl ElementSink for Gather<'_> {
    type Out = ();
    fn take<I: ElementSource>(self, it: I) {
        it.gather_into(self.0, self.1);
    }
}

/// Writes elements into a loaned response slice.
struct Fill<S: Service>(ResponseMutUninit<S, [MaybeUninit<Vec3>], ResponseHeader>);

impl<S: Service> ElementSink for Fill<S> {
    type Out = ResponseMut<S, [Vec3], ResponseHeader>;
    fn take<I: ElementSource>(self, mut it: I) -> Self::Out {
        self.0.write_from_fn(|_| it.next().unwrap_or_default())
    }
}

/// The clients connected now, listed when first asked (listing cleans up dead nodes first, which is
/// not free), for a handler that keeps something per client (grasp owners).
pub struct Clients<'a> {
    list: &'a dyn Fn() -> Vec<u128>,
    listed: std::cell::OnceCell<Vec<u128>>,
}

impl std::fmt::Debug for Clients<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Clients")
            .field("listed", &self.listed.get())
            .finish()
    }
}

impl<'a> Clients<'a> {
    /// The clients `list` gives, listed on the first [`Clients::present`].
    pub fn new(list: &'a dyn Fn() -> Vec<u128>) -> Self {
        Clients {
            list,
            listed: std::cell::OnceCell::new(),
        }
    }

    /// Whether the client `id` (its iceoryx2 port id) is connected.
    pub fn present(&self, id: u128) -> bool {
        self.listed.get_or_init(|| (self.list)()).contains(&id)
    }
}

/// Whoever answers the requests: the solver, or the raw echo. One request is answered by
/// [`Handler::answer`] (the header, complete but for the loop's measurements) and its elements written
/// by [`Handler::write`] wherever the door puts them.
pub trait Handler {
    /// Whether the response's `solve_ns` is the time [`Handler::answer`] took (the raw echo solves
    /// nothing and reports zero).
    const SOLVES: bool = true;
    /// Answers one request of `client` (its iceoryx2 port id).
    fn answer(&mut self, client: u128, req: &RequestHeader, points: &[Vec3]) -> Handled;
    /// Hands the elements of the last answered response, of `chain` laid out as `counts` (its
    /// [`Handled`]'s), to `sink`, in one form.
    fn write<K: ElementSink>(&self, chain: u32, counts: &Counts, sink: K) -> K::Out;
    /// Runs at least every [`CHECK_EVERY`] (periodic snapshots; an error is reported, not fatal), with
    /// the clients present every [`CLIENTS_EVERY`] (those absent lose what the handler kept for them).
    fn housekeeping(&mut self, _now: Instant, _clients: Option<&Clients<'_>>) {}
}

/// Answers one request of `client` into `out` (the response's elements), the way the serving loop does
/// (answer, time, write, measure the landing): the answer path of batch mode and the Unix socket.
/// Returns the response header and whether the state changed.
pub fn respond<H: Handler>(
    handler: &mut H,
    client: u128,
    request: &RequestHeader,
    points: &[Vec3],
    out: &mut Vec<Vec3>,
) -> (ResponseHeader, bool) {
    let (handled, n) = answer_timed(handler, client, request, points);
    let mut header = handled.header;
    out.clear();
    handler.write(handled.chain, &handled.counts, Gather(out, n));
    out.resize(n, Vec3::default());
    measure_landing(&mut header, handled.landing, out);
    (header, handled.changed)
}

/// [`Handler::answer`], its `solve_ns` measured, and the number of elements its response has.
fn answer_timed<H: Handler>(
    handler: &mut H,
    client: u128,
    request: &RequestHeader,
    points: &[Vec3],
) -> (Handled, usize) {
    let t0 = Instant::now();
    let mut handled = handler.answer(client, request, points);
    let header = &mut handled.header;
    if H::SOLVES {
        header.solve_ns = t0.elapsed().as_nanos() as u64;
    }
    let n = handled.counts.elements();
    (handled, n)
}

/// A landing's residual, measured on the written elements.
fn measure_landing(h: &mut ResponseHeader, landing: Option<(usize, Vec3)>, written: &[Vec3]) {
    if let Some((joint, target)) = landing
        && let Some(p) = written.get(joint)
    {
        h.residual =
            ((p.x - target.x).powi(2) + (p.y - target.y).powi(2) + (p.z - target.z).powi(2)).sqrt();
    }
}

/// How the loop waits, and when it stops.
#[derive(Debug, Clone)]
pub struct LoopOptions {
    /// Spin, sleep, or sleep and spin for the budget after each request.
    pub wait: Wait,
    /// Besides SIGINT and SIGTERM, the loop ends within [`CHECK_EVERY`] (event mode: [`TICK`]) of this
    /// flag being set: a service embedded in a thread, a test serving inside its own process.
    pub stop: Option<Arc<AtomicBool>>,
}

impl Default for LoopOptions {
    /// Sleeps until notified; no stop flag.
    fn default() -> Self {
        LoopOptions {
            wait: Wait::Event,
            stop: None,
        }
    }
}

/// Serves requests until SIGINT or SIGTERM (or a broken port).
pub fn serve<S: Service, H: Handler>(
    ports: &ServerPorts<S>,
    handler: &mut H,
    opts: &LoopOptions,
) -> Result<(), PortError>
where
    Listener<S>: SynchronousMultiplexing,
{
    // A small state sample's contents while its response is sent first (no allocation once warm).
    let mut scratch: Vec<Vec3> = Vec::new();
    let mut fair = Fair::default();
    let mut checks = Checks {
        next: Instant::now() + CHECK_EVERY,
        clients_next: Instant::now() + CLIENTS_EVERY,
        forced_next: Instant::now(),
        stop: false,
        flag: opts.stop.clone(),
    };
    match opts.wait {
        Wait::Spin => {
            while !checks.stop {
                if serve_pending(ports, handler, &mut fair, &mut checks, &mut scratch)? == 0 {
                    std::hint::spin_loop();
                }
                checks.run(ports, handler);
            }
        }
        Wait::Event | Wait::Hybrid(_) => {
            let ws = WaitSetBuilder::new()
                .create::<S>()
                .map_err(err("cannot create the WaitSet"))?;
            let guard = ws
                .attach_notification(&ports.wake_listener)
                .map_err(err("cannot attach the wake listener"))?;
            while !checks.stop {
                let r = ws.wait_and_process_once_with_timeout(
                    |id| {
                        if id.has_event_from(&guard) {
                            let _ = ports.wake_listener.try_wait(|_| {});
                        }
                        CallbackProgression::Continue
                    },
                    TICK,
                );
                match r {
                    Ok(WaitSetRunResult::TerminationRequest) => break,
                    // An interrupted wait: SIGINT or SIGTERM (the termination flag says so), or a
                    // signal that only woke it (SIGCONT after a stop: Ctrl-Z then `fg`), which is
                    // not a reason to stop.
                    Ok(WaitSetRunResult::Interrupt) => {
                        if ports.node.wait(Duration::ZERO).is_err() {
                            break;
                        }
                    }
                    Ok(_) => {}
                    Err(e) => return Err(err("WaitSet")(e)),
                }
                // Serve even without a notification: a polling client may not notify.
                let served = serve_pending(ports, handler, &mut fair, &mut checks, &mut scratch)?;
                if let (Wait::Hybrid(budget), true) = (opts.wait, served > 0 && !checks.stop) {
                    spin_while_busy(ports, handler, budget, &mut fair, &mut checks, &mut scratch)?;
                }
                checks.next = Instant::now();
                checks.run(ports, handler);
            }
        }
    }
    Ok(())
}

/// Termination and housekeeping, at least every [`CHECK_EVERY`].
struct Checks {
    next: Instant,
    clients_next: Instant,
    /// When a refusal as `held` may next force a check of the clients present.
    forced_next: Instant,
    stop: bool,
    flag: Option<Arc<AtomicBool>>,
}

impl Checks {
    fn run<S: Service, H: Handler>(&mut self, ports: &ServerPorts<S>, handler: &mut H) {
        let now = Instant::now();
        if now < self.next {
            return;
        }
        self.next = now + CHECK_EVERY;
        // `wait` reports a pending SIGINT/SIGTERM once: remember it.
        if ports.node.wait(Duration::ZERO).is_err()
            || self
                .flag
                .as_ref()
                .is_some_and(|f| f.load(Ordering::Relaxed))
        {
            self.stop = true;
        }
        let list = || present_clients(ports);
        let clients = Clients::new(&list);
        if now >= self.clients_next {
            self.clients_next = now + CLIENTS_EVERY;
            handler.housekeeping(now, Some(&clients));
        } else {
            handler.housekeeping(now, None);
        }
    }

    /// Checks the clients present now (those gone lose their grasps), unless a forced check ran
    /// within [`CLIENTS_FORCED_EVERY`]; `true` if it ran. A request refused because another client
    /// holds the joint may come right after that client exited, before the periodic check saw it go
    /// (`tractrix-client grasp`, then `tractrix-client release` from the next process).
    fn clients_now<S: Service, H: Handler>(
        &mut self,
        ports: &ServerPorts<S>,
        handler: &mut H,
    ) -> bool {
        let now = Instant::now();
        if now < self.forced_next {
            return false;
        }
        self.forced_next = now + CLIENTS_FORCED_EVERY;
        let list = || present_clients(ports);
        handler.housekeeping(now, Some(&Clients::new(&list)));
        true
    }
}

/// The port ids of the clients connected now.
fn present_clients<S: Service>(ports: &ServerPorts<S>) -> Vec<u128> {
    // A client killed with SIGKILL keeps its port until its node is cleaned up.
    let _ = ports.node.try_cleanup_dead_nodes();
    let mut present = Vec::new();
    ports.command.dynamic_config().list_clients(|c| {
        present.push(c.client_id.value());
        CallbackProgression::Continue
    });
    present
}

/// Hybrid mode after a request: spin for `budget` past the last one, then sleep again.
fn spin_while_busy<S: Service, H: Handler>(
    ports: &ServerPorts<S>,
    handler: &mut H,
    budget: Duration,
    fair: &mut Fair<S>,
    checks: &mut Checks,
    scratch: &mut Vec<Vec3>,
) -> Result<(), PortError> {
    let mut last = Instant::now();
    loop {
        while last.elapsed() < budget {
            if serve_pending(ports, handler, fair, checks, scratch)? > 0 {
                last = Instant::now();
            } else {
                std::hint::spin_loop();
            }
            checks.run(ports, handler);
            if checks.stop {
                return Ok(());
            }
        }
        // Notifications that arrived while spinning are stale now: drop them, then serve once more. A
        // request that landed after the last poll has its notification dropped here, and would otherwise
        // wait for the next tick (the loaded latency bench caught it).
        let _ = ports.wake_listener.try_wait(|_| {});
        if serve_pending(ports, handler, fair, checks, scratch)? == 0 || checks.stop {
            return Ok(());
        }
        last = Instant::now();
    }
}

/// The largest state sample (elements) published after its response (kept in a reused buffer
/// meanwhile): a chain of tens of thousands of links. Larger ones (bundles) are copied from the
/// response before it is sent, which spares copying megabytes twice.
pub const DEFER_STATE_UP_TO: usize = 1 << 16;

/// Serves every request waiting, round robin over clients ([`Fair`]), with the checks between any two;
/// returns how many (it stops early when the checks say stop).
///
/// Two ways to write a response, by size. Up to [`DEFER_STATE_UP_TO`] elements (a chain): the
/// elements are gathered into `scratch` by a tight loop, copied into the loaned response at once,
/// and after the response has gone the state sample is copied from `scratch`, so the client never
/// waits for the viewers. Above (a bundle's megabytes): the elements are streamed straight into the
/// loaned response and the state sample copied from it before it goes, to spare a third copy.
fn serve_pending<S: Service, H: Handler>(
    ports: &ServerPorts<S>,
    handler: &mut H,
    fair: &mut Fair<S>,
    checks: &mut Checks,
    scratch: &mut Vec<Vec3>,
) -> Result<usize, PortError> {
    let mut served = 0;
    loop {
        while let Some(req) = ports.server.receive().map_err(err("receive"))? {
            fair.push(req.origin().value(), req);
        }
        let Some(req) = fair.pop() else {
            return Ok(served);
        };
        serve_one(ports, handler, req, scratch, checks);
        served += 1;
        checks.run(ports, handler);
        if checks.stop {
            return Ok(served);
        }
    }
}

/// A request as the server receives it.
type Request<S> = ActiveRequest<S, [Vec3], RequestHeader, [Vec3], ResponseHeader>;

/// Requests received and not yet served, one queue per client (its port id), served round robin: the
/// client served goes to the back of the ring, a new client joins at the back. At most
/// `2 × MAX_CLIENTS` requests wait here (two in flight per client, enforced by iceoryx2).
pub struct Fair<S: Service> {
    ring: VecDeque<(u128, VecDeque<Request<S>>)>,
    /// Emptied queues kept for the next client that joins: no allocation once warm.
    spare: Vec<VecDeque<Request<S>>>,
}

impl<S: Service> std::fmt::Debug for Fair<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fair")
            .field("clients", &self.ring.len())
            .finish()
    }
}

impl<S: Service> Default for Fair<S> {
    fn default() -> Self {
        Fair {
            ring: VecDeque::new(),
            spare: Vec::new(),
        }
    }
}

impl<S: Service> Fair<S> {
    fn push(&mut self, client: u128, req: Request<S>) {
        fair_push(&mut self.ring, &mut self.spare, client, req);
    }

    fn pop(&mut self) -> Option<Request<S>> {
        fair_pop(&mut self.ring, &mut self.spare)
    }
}

/// Queues `item` behind its client's earlier ones; a client with nothing queued joins the ring at the
/// back, with a queue from `spare` if there is one.
fn fair_push<T>(
    ring: &mut VecDeque<(u128, VecDeque<T>)>,
    spare: &mut Vec<VecDeque<T>>,
    client: u128,
    item: T,
) {
    match ring.iter_mut().find(|(c, _)| *c == client) {
        Some((_, q)) => q.push_back(item),
        None => {
            let mut q = spare.pop().unwrap_or_default();
            q.push_back(item);
            ring.push_back((client, q));
        }
    }
}

/// The front client's oldest item; the client goes to the back if it has more, leaves the ring if not
/// (its queue kept in `spare`).
fn fair_pop<T>(
    ring: &mut VecDeque<(u128, VecDeque<T>)>,
    spare: &mut Vec<VecDeque<T>>,
) -> Option<T> {
    let (client, mut q) = ring.pop_front()?;
    let item = q.pop_front();
    if q.is_empty() {
        spare.push(q);
    } else {
        ring.push_back((client, q));
    }
    item
}

/// Answers one request, sends its response, wakes its client and publishes the change.
fn serve_one<S: Service, H: Handler>(
    ports: &ServerPorts<S>,
    handler: &mut H,
    req: Request<S>,
    scratch: &mut Vec<Vec3>,
    checks: &mut Checks,
) {
    let request = *req.user_header();
    let mut answered = answer_timed(handler, req.origin().value(), &request, req.payload());
    // Refused because another client holds the joint: that client may have just gone. A refusal
    // changed nothing, so once the clients present are checked the request is answered afresh.
    if answered.0.header.status == Status::Held as u32 && checks.clients_now(ports, handler) {
        answered = answer_timed(handler, req.origin().value(), &request, req.payload());
    }
    let (
        Handled {
            mut header,
            chain,
            counts,
            changed,
            bundle,
            landing,
        },
        n,
    ) = answered;
    let slot = match req.loan_slice_uninit(n) {
        Ok(slot) => slot,
        Err(e) => {
            // Only possible if the scene outgrew the port, which `open` sizes for.
            eprintln!("solver-service: cannot loan a response of {n} elements: {e:?}");
            return;
        }
    };
    let small = n <= DEFER_STATE_UP_TO;
    let mut resp = if small {
        scratch.clear();
        handler.write(chain, &counts, Gather(scratch, n));
        scratch.resize(n, Vec3::default());
        slot.write_from_slice(scratch)
    } else {
        handler.write(chain, &counts, Fill(slot))
    };
    measure_landing(&mut header, landing, resp.payload());
    *resp.user_header_mut() = header;
    let stream = if bundle {
        &ports.bundle_state
    } else {
        &ports.state
    };
    let publisher = stream.as_ref().filter(|_| changed);
    // The sample: the response's joints, held joints, instruments and pulls (not its rotations).
    let c = &counts;
    let parts = shared::Parts::new(
        resp.payload(),
        c.joints,
        c.angles,
        c.held,
        c.instruments,
        (c.pulls, c.eyelets),
    );
    let (nj, na) = (parts.joints.len(), c.angles as usize);
    let n_state =
        nj + parts.held.len() + parts.instruments.len() + parts.pulls.len() + parts.eyelets.len();
    let state_header = StateHeader {
        sequence: header.sequence,
        chain: header.chain,
        n_joints: nj as u32,
        command: request.command,
        n_held: parts.held.len() as u32,
        request_id: request.request_id,
        n_instruments: (parts.instruments.len() / shared::INSTRUMENT_ELEMENTS as usize) as u32,
        n_pulls: parts.pulls.len() as u32,
        knot: header.knot,
        n_eyelets: (parts.eyelets.len() / shared::EYELET_ELEMENTS as usize) as u32,
    };
    let early = match publisher {
        Some(p) if !small => {
            let (joints, held, instruments, pulls, eyelets) = (
                parts.joints,
                parts.held,
                parts.instruments,
                parts.pulls,
                parts.eyelets,
            );
            state_sample(p, n_state, state_header, |s| {
                // One memcpy when there are only joints (a bundle), else element by element.
                if held.is_empty()
                    && instruments.is_empty()
                    && pulls.is_empty()
                    && eyelets.is_empty()
                {
                    s.write_from_slice(joints)
                } else {
                    let nh = held.len();
                    s.write_from_fn(|i| {
                        if i < nj {
                            joints[i]
                        } else if i < nj + nh {
                            held[i - nj]
                        } else if i < nj + nh + instruments.len() {
                            instruments[i - nj - nh]
                        } else {
                            let k = i - nj - nh - instruments.len();
                            pulls
                                .get(k)
                                .or_else(|| eyelets.get(k - pulls.len()))
                                .copied()
                                .unwrap_or_default()
                        }
                    })
                }
            })
        }
        _ => None,
    };
    if let Err(e) = resp.send() {
        eprintln!("solver-service: response not delivered: {e:?}");
    }
    ports.wake_client(request.listener_id());
    drop(req);
    let late = match publisher {
        Some(p) if small => {
            // The response's elements without its rotations.
            scratch.drain(nj..nj + na);
            state_sample(p, n_state, state_header, |s| s.write_from_slice(scratch))
        }
        _ => None,
    };
    if let Some(s) = early.or(late)
        && let Err(e) = s.send()
    {
        eprintln!("solver-service: state not published: {e:?}");
    }
}

/// A state sample of `n` elements written by `write`, with its header (`None`, reported, if the
/// publisher has no room).
fn state_sample<S: Service>(
    publisher: &Publisher<S, [Vec3], StateHeader>,
    n: usize,
    header: StateHeader,
    write: impl FnOnce(
        SampleMutUninit<S, [MaybeUninit<Vec3>], StateHeader>,
    ) -> SampleMut<S, [Vec3], StateHeader>,
) -> Option<SampleMut<S, [Vec3], StateHeader>> {
    match publisher.loan_slice_uninit(n) {
        Ok(s) => {
            let mut s = write(s);
            *s.user_header_mut() = header;
            Some(s)
        }
        Err(e) => {
            eprintln!("solver-service: cannot loan a state sample: {e:?}");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{fair_pop, fair_push};
    use std::collections::VecDeque;

    /// Two flooding clients (1, 2) with two requests each and a third (3) that arrives after them: the
    /// third is served second-next, each client's requests keep their order, and a client that sends
    /// again while queued stays in its place in the ring.
    #[test]
    fn the_ring_serves_one_request_per_client_per_round() {
        let (mut ring, mut spare) = (VecDeque::new(), Vec::new());
        for (client, item) in [(1, "a1"), (1, "a2"), (2, "b1"), (2, "b2"), (3, "c1")] {
            fair_push(&mut ring, &mut spare, client, item);
        }
        assert_eq!(fair_pop(&mut ring, &mut spare), Some("a1"));
        fair_push(&mut ring, &mut spare, 1, "a3");
        assert_eq!(fair_pop(&mut ring, &mut spare), Some("b1"));
        assert_eq!(fair_pop(&mut ring, &mut spare), Some("c1"));
        let rest: Vec<_> = std::iter::from_fn(|| fair_pop(&mut ring, &mut spare)).collect();
        assert_eq!(rest, ["a2", "b2", "a3"]);
        assert!(ring.is_empty());
        // Every queue kept for reuse.
        assert_eq!(spare.len(), 3);
    }
}
