//! The server side of [`SERVICE_COMMAND`](crate::SERVICE_COMMAND) and its wake-up events, opened with the
//! settings every server of this protocol uses (one server, [`MAX_CLIENTS`] clients, two requests in
//! flight per client). The solver service and the latency bench's raw echo both open theirs here.

use crate::{
    MAX_CLIENTS, RequestHeader, ResponseHeader, SERVICE_COMMAND, SERVICE_WAKE_CLIENT,
    SERVICE_WAKE_SERVER, Vec3,
};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::server::Server;
use iceoryx2::prelude::*;

type Svc = ipc::Service;

/// The request server and the two wake-up ports of a server.
pub struct ServerPorts {
    pub server: Server<Svc, [Vec3], RequestHeader, [Vec3], ResponseHeader>,
    /// Woken by clients after they send.
    pub wake_listener: Listener<Svc>,
    /// Wakes the client whose listener id a request carries.
    pub wake_notifier: Notifier<Svc>,
}

impl std::fmt::Debug for ServerPorts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ServerPorts")
    }
}

fn err<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> String {
    move |e| format!("{what}: {e:?}")
}

/// A service name of this protocol.
pub fn service_name(s: &str) -> Result<ServiceName, String> {
    s.try_into().map_err(|e| format!("service name {s}: {e:?}"))
}

impl ServerPorts {
    /// Opens (or creates) the command service and the wake-up events on `node`; responses hold up to
    /// `max_elements` elements.
    pub fn open(node: &Node<Svc>, max_elements: usize) -> Result<Self, String> {
        let server = node
            .service_builder(&service_name(SERVICE_COMMAND)?)
            .request_response::<[Vec3], [Vec3]>()
            .request_user_header::<RequestHeader>()
            .response_user_header::<ResponseHeader>()
            .max_servers(1)
            .max_clients(MAX_CLIENTS)
            .max_nodes(MAX_CLIENTS + 4)
            .max_active_requests_per_client(2)
            .open_or_create()
            .map_err(err(
                "cannot open or create the command service (a peer of another protocol version?)",
            ))?
            .server_builder()
            .initial_max_slice_len(max_elements.max(1))
            .create()
            .map_err(err(
                "cannot create the server (is another solver-service running with this prefix?)",
            ))?;
        let wake_listener = node
            .service_builder(&service_name(SERVICE_WAKE_SERVER)?)
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
            .service_builder(&service_name(SERVICE_WAKE_CLIENT)?)
            .event()
            .max_notifiers(2)
            .max_listeners(MAX_CLIENTS + 2)
            .max_nodes(MAX_CLIENTS + 4)
            .open_or_create()
            .map_err(err("cannot open or create the wake-client event"))?
            .notifier_builder()
            .create()
            .map_err(err("wake notifier"))?;
        Ok(ServerPorts {
            server,
            wake_listener,
            wake_notifier,
        })
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
