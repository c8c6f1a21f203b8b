//! Faults: a client killed with `kill -9` mid-stream, a client started before the service, a peer of
//! another protocol version.

use clients::ClientWait;
use shared::{Command, RequestHeader, SERVICE_COMMAND, Vec3};
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};
use tests::{Service, bin, unique_prefix};

/// More clients than the service has ports for ([`shared::MAX_CLIENTS`]) are started, each killed
/// with `kill -9` while it streams requests. The test's own client is served throughout, and a new
/// client connects at the end: the dead clients' ports were reclaimed.
#[test]
fn a_client_killed_mid_stream_leaves_the_others_served_and_its_port_is_reclaimed() {
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let mut me = svc.connect_with(ClientWait::Event);
    let mut seq = 0;
    for round in 0..shared::MAX_CLIENTS + 4 {
        let mut child = Process::new(bin("latency"))
            .args(["client", "--prefix", &svc.prefix, "--wait", "event"])
            .args([
                "--samples",
                "100000000",
                "--warmup",
                "0",
                "--chain",
                "snake",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn latency client");
        // Mid-stream: the other client has moved the snake at least 20 times since it started.
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let r = me
                .call(RequestHeader::new(Command::Query, 1), &[])
                .expect("query");
            if r.header.sequence >= seq + 20 {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "round {round}: the streaming client made no progress"
            );
            if let Some(s) = child.try_wait().unwrap() {
                panic!("round {round}: the streaming client exited early: {s:?}");
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        child.kill().expect("kill -9"); // SIGKILL
        child.wait().expect("reap");
        // The survivor is served at once, its own move lands.
        let t = round as f64;
        let r = me
            .call(
                RequestHeader::new(Command::Move, 0),
                &[Vec3::new(40.0, 0.1 * t, 0.0)],
            )
            .expect("the service answers after a client died");
        assert!(r.is_ok(), "{}", r.header.reason_str());
        assert_eq!(r.joints()[40], Vec3::new(40.0, 0.1 * t, 0.0));
        seq = r.header.sequence;
    }
    // 20 clients died holding a port each; the service has 16. A new client still gets one.
    let mut late = svc.connect_with(ClientWait::Event);
    let r = late
        .call(RequestHeader::new(Command::Query, 0), &[])
        .expect("a new client after the dead ones");
    assert!(r.is_ok());
}

/// A client started before the service waits for it (`--wait-for-service`) and then succeeds; without
/// a service it gives up after its timeout and says so.
#[test]
fn a_client_started_before_the_service_waits_with_a_timeout() {
    let prefix = unique_prefix();
    let early = Process::new(bin("chainctl"))
        .args([
            "--prefix",
            &prefix,
            "--wait-for-service",
            "30",
            "query",
            "arm",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn chainctl");
    std::thread::sleep(Duration::from_millis(500));
    let _svc = Service::start(&prefix, &["--no-persist", "--wait", "event"]);
    let out = wait_output(early, Duration::from_secs(30));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines()
            .filter(|l| l.trim_start().starts_with("joint"))
            .count(),
        11,
        "{text}"
    );

    let t0 = Instant::now();
    let lonely = Process::new(bin("chainctl"))
        .args([
            "--prefix",
            &unique_prefix(),
            "--wait-for-service",
            "0.7",
            "query",
            "arm",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn chainctl");
    let out = wait_output(lonely, Duration::from_secs(20));
    let waited = t0.elapsed();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no solver-service runs") && err.contains("waited 700ms"),
        "{err}"
    );
    assert!(
        waited >= Duration::from_millis(700),
        "gave up after {waited:?}"
    );
}

/// The wire types of another protocol version: same shapes, other type names.
mod v0 {
    use iceoryx2::prelude::ZeroCopySend;

    #[derive(Debug, Clone, Copy, Default, ZeroCopySend)]
    #[repr(C)]
    #[type_name("tractrix.v0.Vec3")]
    pub struct Vec3 {
        pub x: f64,
        pub y: f64,
        pub z: f64,
    }

    #[derive(Debug, Clone, Copy, Default, ZeroCopySend)]
    #[repr(C)]
    #[type_name("tractrix.v0.Header")]
    pub struct Header {
        pub bytes: [u64; 12],
    }
}

/// A service of another protocol version: this version's client refuses it and says why. And a peer
/// of another version cannot open this version's service: iceoryx2 refuses it at `open` with
/// `IncompatibleRequestOrResponseType`, so it never reads the service's bytes as its own.
#[test]
fn a_peer_of_another_protocol_version_is_refused_with_a_message() {
    use iceoryx2::prelude::*;
    use iceoryx2::service::builder::request_response::RequestResponseOpenError;
    let prefix = unique_prefix();
    let cfg = shared::iceoryx_config(&prefix).unwrap();
    let node = NodeBuilder::new()
        .config(&cfg)
        .create::<ipc::Service>()
        .unwrap();
    let name: ServiceName = SERVICE_COMMAND.try_into().unwrap();
    {
        let _old = node
            .service_builder(&name)
            .request_response::<[v0::Vec3], [v0::Vec3]>()
            .request_user_header::<v0::Header>()
            .response_user_header::<v0::Header>()
            .create()
            .unwrap();
        let out = Process::new(bin("chainctl"))
            .args(["--prefix", &prefix, "query", "rope"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("speaks another protocol version")
                && err.contains(&format!("v{}", shared::PROTOCOL_VERSION)),
            "{err}"
        );
    }
    let svc = tests::Service::start(&prefix, &["--no-persist", "--wait", "event"]);
    let other = node
        .service_builder(&name)
        .request_response::<[v0::Vec3], [v0::Vec3]>()
        .request_user_header::<v0::Header>()
        .response_user_header::<v0::Header>()
        .open();
    assert!(
        matches!(
            other,
            Err(RequestResponseOpenError::IncompatibleRequestOrResponseType)
        ),
        "{other:?}"
    );
    // and the service serves this version's clients as before
    let mut c = svc.connect_with(ClientWait::Event);
    assert!(
        c.call(RequestHeader::new(Command::Query, 0), &[])
            .unwrap()
            .is_ok()
    );
}

fn wait_output(mut child: std::process::Child, timeout: Duration) -> std::process::Output {
    let deadline = Instant::now() + timeout;
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the child did not exit within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

/// The service's shared memory (payload segments, port management, events) and iceoryx2's service
/// descriptions are readable and writable by the owner only. The one exception is iceoryx2's own
/// 16-byte `*.global_mgmt` file per iceoryx2 version, which holds no data of ours.
#[test]
fn shared_memory_is_the_owners_alone() {
    use std::os::unix::fs::PermissionsExt;
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let mut c = svc.connect_with(ClientWait::Event);
    assert!(
        c.call(RequestHeader::new(Command::Query, 0), &[])
            .unwrap()
            .is_ok()
    );
    let mut checked = 0;
    for dir in ["/dev/shm", "/tmp/iceoryx2/services", "/tmp/iceoryx2/nodes"] {
        let Ok(entries) = std::fs::read_dir(dir) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if !name.starts_with(&svc.prefix) || name.ends_with(".global_mgmt") {
                continue;
            }
            let mode = e.metadata().unwrap().permissions().mode();
            assert_eq!(mode & 0o077, 0, "{dir}/{name} is open to others: {mode:o}");
            checked += 1;
        }
    }
    assert!(checked >= 5, "only {checked} files of the instance found");
}
