//! The Rust client of the tractrix solver service: a connection to a running service (one
//! request-response client port, optionally the wake-up events) and its state stream. Every wait has
//! a deadline. The C library (`clients/c`) wraps this crate alone; the hand controllers and tools of
//! `clients` build on it.

use iceoryx2::port::client::Client;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::Service;
use iceoryx2::service::builder::request_response::RequestResponseOpenError;
use shared::{
    Command, RequestHeader, ResponseHeader, SERVICE_COMMAND, SERVICE_STATE, SERVICE_WAKE_CLIENT,
    SERVICE_WAKE_SERVER, StateHeader, Vec3, Wait,
};
use std::time::{Duration, Instant};

/// The iceoryx2 service variant between processes.
pub type Svc = ipc::Service;

/// Connection options.
#[derive(Debug, Clone)]
pub struct ConnectOptions {
    pub prefix: String,
    pub wait: Wait,
    /// How long to wait for the service to appear (0: fail at once if none runs).
    pub connect_timeout: Duration,
    /// How long to wait for each response.
    pub call_timeout: Duration,
    /// Largest request (points) this client can send; the service accepts up to
    /// [`shared::MAX_PATH_POINTS`]. Shared memory for it is reserved at connect time.
    pub max_request_points: usize,
}

impl Default for ConnectOptions {
    fn default() -> Self {
        ConnectOptions {
            prefix: shared::prefix_from_env(),
            wait: Wait::Hybrid(Duration::from_micros(50)),
            connect_timeout: Duration::ZERO,
            call_timeout: Duration::from_secs(5),
            max_request_points: shared::MAX_PATH_POINTS as usize,
        }
    }
}

impl ConnectOptions {
    /// What the command-line tools use: wait up to `wait_s` seconds for the service to appear, sleep on
    /// events after a short spin, 10 s per call.
    pub fn for_tool(prefix: &str, wait_s: f64) -> Result<Self, String> {
        if !(wait_s.is_finite() && (0.0..=3600.0).contains(&wait_s)) {
            return Err(format!(
                "wait for the service {wait_s} s: expected 0 to 3600 seconds"
            ));
        }
        Ok(ConnectOptions {
            prefix: prefix.to_string(),
            wait: Wait::Hybrid(Duration::from_micros(200)),
            connect_timeout: Duration::from_secs_f64(wait_s),
            call_timeout: Duration::from_secs(10),
            ..ConnectOptions::default()
        })
    }
}

/// Why a call failed (the service's refusals are not errors: they come back as a status).
#[derive(Debug, thiserror::Error)]
pub enum CallError {
    #[error(
        "no solver-service runs with prefix {prefix:?} (waited {waited:?}; start one: cargo run --release --bin solver-service, or wait longer: --wait-for-service SECONDS)"
    )]
    NoService { prefix: String, waited: Duration },
    #[error(
        "the service with prefix {prefix:?} speaks another protocol version (this client: v{})",
        shared::PROTOCOL_VERSION
    )]
    VersionMismatch { prefix: String },
    #[error("no response within {0:?}")]
    Timeout(Duration),
    #[error("the service went away before answering")]
    Disconnected,
    #[error("iceoryx2: {0}")]
    Ipc(String),
}

/// Maps an iceoryx2 failure of the step `what` to [`CallError::Ipc`] (for `map_err`).
pub fn ipc<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> CallError {
    move |e| CallError::Ipc(format!("{what}: {e:?}"))
}

/// A response copied out of shared memory.
#[derive(Debug, Clone)]
pub struct Reply {
    pub header: ResponseHeader,
    /// `n_joints` joints, then `n_angles` rotations, then `n_held` held joints, then `n_instruments`
    /// instruments.
    pub payload: Vec<Vec3>,
}

impl Reply {
    /// The payload cut into its parts.
    pub fn parts(&self) -> shared::Parts<'_> {
        shared::Parts::of_response(&self.header, &self.payload)
    }
    pub fn joints(&self) -> &[Vec3] {
        self.parts().joints
    }
    pub fn angles(&self) -> &[Vec3] {
        self.parts().angles
    }
    /// The held joints: `(index, anchor of the scene)`.
    pub fn held(&self) -> Vec<(u32, bool)> {
        self.parts().held_joints().collect()
    }
    /// The chain's instruments' poses.
    pub fn instruments(&self) -> Vec<shared::InstrumentPose> {
        self.parts().instrument_poses().collect()
    }
    pub fn is_ok(&self) -> bool {
        self.header.status == shared::Status::Ok as u32
    }
}

/// A connected client.
///
/// Generic over the iceoryx2 service variant: `ipc` (the default) between processes, `local` for a test
/// that serves and calls inside one process.
pub struct Connection<S: Service = Svc> {
    node: Node<S>,
    client: Client<S, [Vec3], RequestHeader, [Vec3], ResponseHeader>,
    wake_server: Option<Notifier<S>>,
    listener: Option<Listener<S>>,
    opts: ConnectOptions,
    next_id: u64,
}

impl<S: Service> std::fmt::Debug for Connection<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Connection")
            .field("prefix", &self.opts.prefix)
            .finish()
    }
}

impl Connection<Svc> {
    /// Connects to a service in another process, waiting up to `opts.connect_timeout` for it to appear.
    pub fn connect(opts: ConnectOptions) -> Result<Self, CallError> {
        Self::open(opts)
    }
}

impl<S: Service> Connection<S> {
    /// Connects over the service variant `S`, waiting up to `opts.connect_timeout` for the service to
    /// appear.
    pub fn open(opts: ConnectOptions) -> Result<Self, CallError> {
        let cfg = shared::iceoryx_config(&opts.prefix).map_err(CallError::Ipc)?;
        let node = NodeBuilder::new().config(&cfg).create::<S>().map_err(|e| {
            CallError::Ipc(match shared::iceoryx_root_problem(&cfg) {
                Some(why) => format!("node: {e:?}: {why}"),
                None => format!("node: {e:?}"),
            })
        })?;
        let deadline = Instant::now() + opts.connect_timeout;
        let name =
            |s: &str| -> Result<ServiceName, CallError> { s.try_into().map_err(ipc("name")) };
        let command = loop {
            match node
                .service_builder(&name(SERVICE_COMMAND)?)
                .request_response::<[Vec3], [Vec3]>()
                .request_user_header::<RequestHeader>()
                .response_user_header::<ResponseHeader>()
                .open()
            {
                Ok(s) => break s,
                Err(RequestResponseOpenError::DoesNotExist) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20));
                }
                Err(RequestResponseOpenError::DoesNotExist) => {
                    return Err(CallError::NoService {
                        prefix: opts.prefix.clone(),
                        waited: opts.connect_timeout,
                    });
                }
                Err(RequestResponseOpenError::IncompatibleRequestOrResponseType) => {
                    return Err(CallError::VersionMismatch {
                        prefix: opts.prefix.clone(),
                    });
                }
                Err(e) => return Err(ipc("open the command service")(e)),
            }
        };
        // The service exists a moment before its server port does (a service starting up): wait for
        // the server within the same deadline, or a first request would find nobody to answer it.
        while command.dynamic_config().number_of_servers() == 0 {
            if Instant::now() >= deadline {
                return Err(CallError::NoService {
                    prefix: opts.prefix.clone(),
                    waited: opts.connect_timeout,
                });
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let client = command
            .client_builder()
            .initial_max_slice_len(opts.max_request_points.max(1))
            .create()
            .map_err(ipc("client port (too many clients?)"))?;
        let (wake_server, listener) = match opts.wait {
            Wait::Spin => (None, None),
            _ => {
                let ws = node
                    .service_builder(&name(SERVICE_WAKE_SERVER)?)
                    .event()
                    .open()
                    .map_err(ipc("wake-server event"))?;
                let wc = node
                    .service_builder(&name(SERVICE_WAKE_CLIENT)?)
                    .event()
                    .open()
                    .map_err(ipc("wake-client event"))?;
                (
                    Some(ws.notifier_builder().create().map_err(ipc("notifier"))?),
                    Some(wc.listener_builder().create().map_err(ipc("listener"))?),
                )
            }
        };
        Ok(Connection {
            node,
            client,
            wake_server,
            listener,
            opts,
            next_id: 1,
        })
    }

    /// Sends one request and hands the response, in shared memory, to `read`: no copy. `header.
    /// request_id` is set to a fresh number unless it is non-zero.
    pub fn call_with<R>(
        &mut self,
        mut header: RequestHeader,
        points: &[Vec3],
        read: impl FnOnce(&ResponseHeader, &[Vec3]) -> R,
    ) -> Result<R, CallError> {
        if header.request_id == 0 {
            header.request_id = self.next_id;
            self.next_id += 1;
        }
        if let Some(l) = &self.listener {
            header.set_listener_id(l.id().value());
            // Drop wake-ups left from an earlier call that timed out.
            let _ = l.try_wait(|_| {});
        }
        let mut req = self
            .client
            .loan_slice_uninit(points.len())
            .map_err(ipc("loan a request"))?
            .write_from_slice(points);
        *req.user_header_mut() = header;
        let pending = req.send().map_err(ipc("send"))?;
        if pending.number_of_server_connections() == 0 {
            return Err(CallError::NoService {
                prefix: self.opts.prefix.clone(),
                waited: Duration::ZERO,
            });
        }
        if let Some(n) = &self.wake_server {
            n.notify().map_err(ipc("notify"))?;
        }
        let start = Instant::now();
        loop {
            if let Some(r) = pending.receive().map_err(ipc("receive"))? {
                return Ok(read(r.user_header(), r.payload()));
            }
            let waited = start.elapsed();
            if waited >= self.opts.call_timeout {
                return Err(CallError::Timeout(self.opts.call_timeout));
            }
            if !pending.is_connected() {
                // The response may have landed between `receive` and `is_connected`.
                if let Some(r) = pending.receive().map_err(ipc("receive"))? {
                    return Ok(read(r.user_header(), r.payload()));
                }
                return Err(CallError::Disconnected);
            }
            match (self.opts.wait, &self.listener) {
                (Wait::Hybrid(budget), Some(l)) if waited >= budget => {
                    let _ = l.timed_wait(|_| {}, Duration::from_millis(5));
                }
                (Wait::Event, Some(l)) => {
                    let _ = l.timed_wait(|_| {}, Duration::from_millis(5));
                }
                _ => std::hint::spin_loop(),
            }
        }
    }

    /// This connection's client port id: the owner the service names for the grasps it takes
    /// (`held` refusals of other clients print it in hex).
    pub fn client_id(&self) -> u128 {
        self.client.id().value()
    }

    /// Sends one request and copies the response out.
    pub fn call(&mut self, header: RequestHeader, points: &[Vec3]) -> Result<Reply, CallError> {
        self.call_with(header, points, |h, p| Reply {
            header: *h,
            payload: p.to_vec(),
        })
    }

    /// The handle of a chain by name (one describe per chain until found).
    pub fn find_chain(&mut self, name: &str) -> Result<Option<u32>, CallError> {
        let first = self.call(RequestHeader::new(Command::Describe, 0), &[])?;
        for c in 0..first.header.n_chains {
            let r = if c == 0 {
                first.clone()
            } else {
                self.call(RequestHeader::new(Command::Describe, c), &[])?
            };
            if r.header.name_str() == name {
                return Ok(Some(c));
            }
        }
        Ok(None)
    }

    /// The names of the service's chains and bundles, in handle order.
    pub fn chain_names(&mut self) -> Result<Vec<String>, CallError> {
        let first = self.call(RequestHeader::new(Command::Describe, 0), &[])?;
        let mut names = vec![first.header.name_str()];
        for c in 1..first.header.n_chains {
            names.push(
                self.call(RequestHeader::new(Command::Describe, c), &[])?
                    .header
                    .name_str(),
            );
        }
        Ok(names)
    }

    /// The handle of chain `name`; if the service has none, an error that lists the chains it has and
    /// names the shipped scene that declares `name`, if one does.
    pub fn require_chain(&mut self, name: &str) -> anyhow::Result<u32> {
        if let Some(c) = self.find_chain(name)? {
            return Ok(c);
        }
        let has = self.chain_names()?.join(", ");
        let from = shipped_scene_of(name).map_or(String::new(), |scene| {
            format!(
                "; {scene} declares it: start the service with --scene solver-service/scenes/{scene}"
            )
        });
        anyhow::bail!("the service has no chain {name:?} (it has {has}){from}")
    }

    /// Subscribes to the state stream.
    pub fn subscribe(&self) -> Result<StateStream<S>, CallError> {
        self.subscribe_to(SERVICE_STATE)
    }

    /// Subscribes to the bundles' state stream (a scene with bundles only).
    pub fn subscribe_bundles(&self) -> Result<StateStream<S>, CallError> {
        self.subscribe_to(shared::SERVICE_BUNDLE_STATE)
    }

    fn subscribe_to(&self, service: &str) -> Result<StateStream<S>, CallError> {
        let svc = self
            .node
            .service_builder(&service.try_into().map_err(ipc("name"))?)
            .publish_subscribe::<[Vec3]>()
            .user_header::<StateHeader>()
            .open()
            .map_err(ipc("open the state stream"))?;
        // The subscriber's buffer is as deep as the service offers (iceoryx2's default: the
        // service's `subscriber_max_buffer_size`, `solver-service --state-buffer`).
        Ok(StateStream {
            subscriber: svc
                .subscriber_builder()
                .create()
                .map_err(ipc("subscriber"))?,
        })
    }

    /// The node, for callers that wait on it (signals).
    pub fn node(&self) -> &Node<S> {
        &self.node
    }
}

/// The state stream: every accepted change, in order.
pub struct StateStream<S: Service = Svc> {
    subscriber: Subscriber<S, [Vec3], StateHeader>,
}

impl<S: Service> std::fmt::Debug for StateStream<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("StateStream")
    }
}

impl<S: Service> StateStream<S> {
    /// The next sample, if one is waiting, handed to `read` in place.
    pub fn try_next<R>(
        &self,
        read: impl FnOnce(&StateHeader, &[Vec3]) -> R,
    ) -> Result<Option<R>, CallError> {
        Ok(self
            .subscriber
            .receive()
            .map_err(ipc("receive a state"))?
            .map(|s| read(s.user_header(), s.payload())))
    }
}

/// The shipped scene (`default.toml`, `knots.toml`, `hair.toml`) that declares a chain or bundle named
/// `name`, by a plain reading of their `name = "..."` lines.
pub fn shipped_scene_of(name: &str) -> Option<&'static str> {
    const SCENES: [(&str, &str); 3] = [
        (
            "default.toml",
            include_str!("../../../solver-service/scenes/default.toml"),
        ),
        (
            "knots.toml",
            include_str!("../../../solver-service/scenes/knots.toml"),
        ),
        (
            "hair.toml",
            include_str!("../../../solver-service/scenes/hair.toml"),
        ),
    ];
    let line = format!("name = {name:?}");
    SCENES
        .iter()
        .find(|(_, text)| text.lines().any(|l| l.trim() == line))
        .map(|(file, _)| *file)
}
