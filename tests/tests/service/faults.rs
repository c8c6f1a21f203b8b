//! Faults: a client killed with `kill -9` mid-stream, a client started before the service, a peer of
//! another protocol version.

use clients::Wait;
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
    let mut me = svc.connect_with(Wait::Event);
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
    let mut late = svc.connect_with(Wait::Event);
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
    let mut c = svc.connect_with(Wait::Event);
    assert!(
        c.call(RequestHeader::new(Command::Query, 0), &[])
            .unwrap()
            .is_ok()
    );
}

pub(crate) fn wait_output(
    mut child: std::process::Child,
    timeout: Duration,
) -> std::process::Output {
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
    let mut c = svc.connect_with(Wait::Event);
    assert!(
        c.call(RequestHeader::new(Command::Query, 0), &[])
            .unwrap()
            .is_ok()
    );
    let mut checked = 0;
    let cfg = shared::iceoryx_config(&svc.prefix).unwrap();
    let root = shared::iceoryx_root(&cfg);
    let dirs = [
        "/dev/shm".to_string(),
        format!("{root}services"),
        format!("{root}nodes"),
    ];
    for dir in &dirs {
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

/// Runs `script` with `sh` in a private mount namespace (its own `/dev/shm`): as root with `unshare
/// -m`, else in a user namespace (`unshare -Urm`). `None` if neither is allowed on this machine.
fn in_private_mounts(script: &str, env: &[(&str, &str)]) -> Option<std::process::Output> {
    for args in [
        &["-m", "--propagation", "private"][..],
        &["-Urm", "--propagation", "private"],
    ] {
        let probe = Process::new("unshare").args(args).arg("true").output();
        if !probe.is_ok_and(|o| o.status.success()) {
            continue;
        }
        let child = Process::new("unshare")
            .args(args)
            .args(["sh", "-c", script])
            .envs(env.iter().copied())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn unshare");
        return Some(wait_output(child, Duration::from_secs(120)));
    }
    None
}

/// Issue 35: the service's shared memory is reserved when it starts. In a private `/dev/shm` of 1 MiB
/// the start fails with a message that names `/dev/shm` (before: SIGBUS at the first large response
/// or at once, with no message); in one of 256 MiB a running service, its client connected, goes on
/// serving large responses after another process has filled `/dev/shm` to the last byte (the part
/// inside the namespace is the ignored test below, run by this one).
#[test]
fn a_full_dev_shm_fails_the_start_with_a_message_and_a_running_service_keeps_serving() {
    let service = bin("solver-service");
    let start = format!(
        "mount -t tmpfs -o size=1m tmpfs /dev/shm && exec {} --no-persist --prefix {}",
        service.display(),
        unique_prefix()
    );
    let Some(out) = in_private_mounts(&start, &[]) else {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI must be able to make a private mount namespace (unshare -m)"
        );
        tests::skip(
            "the full /dev/shm test: no private mount namespace here (unshare -m and unshare -Urm refused)",
        );
        return;
    };
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("shared memory") && err.contains("/dev/shm") && err.contains("reserve"),
        "{err}"
    );
    let exe = std::env::current_exe().unwrap();
    let inner = format!(
        "mount -t tmpfs -o size=256m tmpfs /dev/shm && exec {} --exact \
         faults::inside_a_private_dev_shm_a_running_service_survives_it_filling_up --ignored --nocapture",
        exe.display()
    );
    let out = in_private_mounts(&inner, &[("TRACTRIX_PRIVATE_SHM", "1")]).expect("namespace");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("1 passed"),
        "the inner test did not run: {text}"
    );
}

/// Run by the test above inside its private 256 MiB `/dev/shm` (ignored otherwise): a service with a
/// 2000-link chain and its client start, `/dev/shm` is filled to the last byte, and the client's
/// queries (48 KB and 96 KB responses, many pages each) and moves are all served; the service exits
/// cleanly.
#[test]
#[ignore = "runs inside the private /dev/shm of a_full_dev_shm_fails_the_start_with_a_message_and_a_running_service_keeps_serving"]
fn inside_a_private_dev_shm_a_running_service_survives_it_filling_up() {
    assert_eq!(
        std::env::var("TRACTRIX_PRIVATE_SHM").as_deref(),
        Ok("1"),
        "run by its outer test only: it fills /dev/shm"
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("long.toml");
    std::fs::write(
        &scene,
        "[[chain]]\nname = \"long\"\nlinks = 2000\nlink_length = 0.1\n",
    )
    .unwrap();
    let mut svc = Service::start(
        &unique_prefix(),
        &["--no-persist", "--scene", scene.to_str().unwrap()],
    );
    let shm = std::path::Path::new("/dev/shm");
    let names = || -> Vec<String> {
        std::fs::read_dir(shm)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect()
    };
    let service_files = names();
    let mut c = svc.connect();
    // A client's own segments are sparse too: the client's (not the service's) are reserved here,
    // the way the service reserves its own, or this process would be the one to die of SIGBUS (it
    // did).
    let (files, bytes) =
        solver_service::shm::reserve_where(shm, |n| !service_files.iter().any(|s| s == n)).unwrap();
    eprintln!("{files} segments of the client reserved, {bytes} bytes");
    // Fill /dev/shm: write until the file system says no more.
    {
        use std::io::Write;
        let mut f = std::fs::File::create("/dev/shm/filler").unwrap();
        let block = vec![1u8; 1 << 16];
        while f.write_all(&block).is_ok() {}
        let mut byte = [1u8];
        while f.write_all(&byte).is_ok() {
            byte[0] = 2;
        }
    }
    let free = Process::new("df")
        .args(["--output=avail", "/dev/shm"])
        .output()
        .unwrap();
    eprintln!(
        "/dev/shm filled: {}",
        String::from_utf8_lossy(&free.stdout).trim()
    );
    for i in 0..20 {
        let mut q = RequestHeader::new(Command::Query, 0);
        if i % 2 == 1 {
            q.flags = shared::FLAG_ANGLES;
        }
        let r = c.call(q, &[]).expect("a query after /dev/shm filled up");
        assert!(r.is_ok(), "{}", r.header.reason_str());
        assert_eq!(r.joints().len(), 2001);
        let t = f64::from(i) * 0.3;
        let r = c
            .call(
                RequestHeader::new(Command::Move, 0),
                &[Vec3::new(200.0 + t.cos(), t.sin(), 0.0)],
            )
            .expect("a move after /dev/shm filled up");
        assert!(r.is_ok(), "{}", r.header.reason_str());
    }
    drop(c);
    svc.signal("TERM");
    assert!(svc.wait_exit(Duration::from_secs(30)).success());
}
