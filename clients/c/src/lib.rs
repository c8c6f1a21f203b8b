//! The solver service's client with a C ABI: the path for C, C++ and C# (issue 17).
//!
//! A thin wrapper over [`client::Connection`]: the same requests, the same waits, the same errors, as C
//! functions on an opaque handle. The header is `shared/include/tractrix_client.h` (it includes the wire
//! header `tractrix.h` for the request, response and state types); the build makes
//! `libtractrix_client.so` and `libtractrix_client.a` in `target/release`.
//!
//! # Conventions
//!
//! * Every function returns an `int`: `0` for success; a positive value is the service's refusal, a
//!   `tractrix_Status` (`TRACTRIX_UNREACHABLE`, `TRACTRIX_LOCKED`, ...); a negative value is a failure
//!   on this side (`TRACTRIX_E_*`: a bad argument, no service, a timeout, a buffer too small, a panic
//!   caught). After any non-zero return, `tractrix_client_error(handle)` says why in UTF-8 (for a
//!   refusal: the service's reason); the text lives until the next call on the handle. A failed
//!   `tractrix_client_open` leaves its message in `tractrix_last_open_error()` (per thread).
//! * Joints are copied into the caller's buffer of `capacity` elements; the count is written to
//!   `*n_joints`. A buffer too small returns `TRACTRIX_E_BUFFER` with the count needed in `*n_joints`
//!   (the request was applied: ask with a bigger buffer via `tractrix_client_query`).
//! * No panic crosses the boundary: each function runs under `catch_unwind` and returns
//!   `TRACTRIX_E_PANIC`.
//! * Thread safety: a client handle may be used from any thread; calls on one handle are serialised
//!   (a mutex), so one handle per thread is the fast way. A stream handle is used by one thread at a
//!   time. Close streams before the client they came from.

// A C ABI passes each buffer as pointer, capacity and count: the functions have many arguments.
#![allow(clippy::too_many_arguments)]

use client::{CallError, ConnectOptions, Connection, StateStream};
use iceoryx2::service::ipc_threadsafe;
use shared::Wait;
use shared::{Command, PullStop, RequestHeader, ResponseHeader, StateHeader, Status, Vec3};
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Mutex;
use std::sync::atomic::{AtomicI32, Ordering};
use std::time::Duration;

type Svc = ipc_threadsafe::Service;

/// A bad argument (a null pointer, a name that is not UTF-8, an option out of range).
pub const TRACTRIX_E_ARGUMENT: c_int = -1;
/// No service runs with that prefix (within the connect timeout).
pub const TRACTRIX_E_NO_SERVICE: c_int = -2;
/// The service speaks another protocol version.
pub const TRACTRIX_E_VERSION: c_int = -3;
/// No response within the call timeout.
pub const TRACTRIX_E_TIMEOUT: c_int = -4;
/// The service went away before answering.
pub const TRACTRIX_E_DISCONNECTED: c_int = -5;
/// iceoryx2 failed (the message says where).
pub const TRACTRIX_E_IPC: c_int = -6;
/// The caller's buffer is too small (the count needed is written).
pub const TRACTRIX_E_BUFFER: c_int = -7;
/// A panic was caught (a bug: please report the message).
pub const TRACTRIX_E_PANIC: c_int = -8;
/// No chain of that name.
pub const TRACTRIX_E_NO_CHAIN: c_int = -9;

/// Wait modes of `tractrix_client_open`.
pub const TRACTRIX_WAIT_SPIN: c_int = 0;
/// Sleep on an event until the service answers.
pub const TRACTRIX_WAIT_EVENT: c_int = 1;
/// Spin for 50 µs, then sleep (the default of the Rust client).
pub const TRACTRIX_WAIT_HYBRID: c_int = 2;

/// A connection to a running service (opaque to C).
#[derive(Debug)]
pub struct TractrixClient {
    conn: Mutex<Connection<Svc>>,
    error: Mutex<CString>,
    /// Why the last `tractrix_client_pull` stopped short ([`pull_stop_code`]).
    pull_stop: AtomicI32,
}

/// A pull's stop as the header numbers it (`TRACTRIX_PULL_STOP_*`): 0 the whole move was made.
fn pull_stop_code(s: Option<PullStop>) -> c_int {
    match s {
        None => 0,
        Some(PullStop::Taut) => 1,
        Some(PullStop::Jammed) => 2,
        Some(PullStop::Limit) => 3,
        Some(PullStop::Work) => 4,
    }
}

/// A subscription to the state stream (opaque to C).
#[derive(Debug)]
pub struct TractrixStream {
    stream: StateStream<Svc>,
}

// The thread-safety the header promises, checked by the compiler: a client handle may be shared
// between threads (its calls serialise on the mutex); a stream may move between threads.
const _: () = {
    const fn shared_between_threads<T: Send + Sync>() {}
    const fn moves_between_threads<T: Send>() {}
    shared_between_threads::<TractrixClient>();
    moves_between_threads::<TractrixStream>();
};

thread_local! {
    static OPEN_ERROR: std::cell::RefCell<CString> = std::cell::RefCell::new(CString::default());
}

fn c_text(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).unwrap_or_default()
}

fn code(e: &CallError) -> c_int {
    match e {
        CallError::NoService { .. } => TRACTRIX_E_NO_SERVICE,
        CallError::VersionMismatch { .. } => TRACTRIX_E_VERSION,
        CallError::Timeout(_) => TRACTRIX_E_TIMEOUT,
        CallError::Disconnected => TRACTRIX_E_DISCONNECTED,
        CallError::Ipc(_) => TRACTRIX_E_IPC,
    }
}

/// Runs `f` with the handle's connection, records the message of a non-zero result, catches panics.
fn with_client(
    client: *mut TractrixClient,
    f: impl FnOnce(&mut Connection<Svc>) -> Result<c_int, (c_int, String)>,
) -> c_int {
    // SAFETY: the caller passes a handle from `tractrix_client_open` that it has not closed (or null,
    // refused here); the handle is only read through shared references and its mutexes.
    let Some(c) = (unsafe { client.as_ref() }) else {
        return TRACTRIX_E_ARGUMENT;
    };
    let result = catch_unwind(AssertUnwindSafe(|| {
        let mut conn = match c.conn.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        f(&mut conn)
    }));
    let (rc, msg) = match result {
        Ok(Ok(rc)) => (rc, String::new()),
        Ok(Err((rc, msg))) => (rc, msg),
        Err(p) => (
            TRACTRIX_E_PANIC,
            format!(
                "panic: {}",
                p.downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_default()
            ),
        ),
    };
    if let Ok(mut e) = c.error.lock() {
        *e = c_text(&msg);
    }
    rc
}

/// Sends a request; the reply's header goes to `on_reply` with the payload in shared memory.
fn request(
    conn: &mut Connection<Svc>,
    header: RequestHeader,
    points: &[Vec3],
    on_reply: impl FnOnce(&ResponseHeader, &[Vec3]) -> c_int,
) -> Result<c_int, (c_int, String)> {
    let (status, reason, rc) = conn
        .call_with(header, points, |h, p| {
            (h.status, h.reason_str().to_string(), on_reply(h, p))
        })
        .map_err(|e| (code(&e), e.to_string()))?;
    if status != Status::Ok as u32 {
        let name = Status::from_u32(status).map_or("unknown status", |s| s.name());
        return Err((status as c_int, format!("{name}: {reason}")));
    }
    if rc != 0 {
        return Err((
            rc,
            "the buffer is too small for the joints (the count needed is written)".into(),
        ));
    }
    Ok(0)
}

/// Copies the joints of a reply into `(out, capacity)` and writes the count to `n_out`.
fn copy_joints(
    h: &ResponseHeader,
    p: &[Vec3],
    out: *mut Vec3,
    capacity: usize,
    n_out: *mut usize,
) -> c_int {
    let n = (h.n_joints as usize).min(p.len());
    if !n_out.is_null() {
        // SAFETY: `n_out` is non-null and, by the function's contract, points to a writable size_t.
        unsafe { n_out.write(n) };
    }
    // No buffer (null, 0): the caller does not want the joints.
    if n == 0 || (out.is_null() && capacity == 0) {
        return 0;
    }
    if out.is_null() || capacity < n {
        return TRACTRIX_E_BUFFER;
    }
    // SAFETY: `out` is non-null and, by contract, valid for `capacity` ≥ `n` writes of `tractrix_Vec3`
    // (the same layout as `Vec3`: repr(C), three doubles); `p` is a live slice of at least `n`.
    unsafe { std::ptr::copy_nonoverlapping(p.as_ptr(), out, n) };
    0
}

/// A UTF-8 C string argument.
fn text_arg<'a>(s: *const c_char, what: &str) -> Result<&'a str, (c_int, String)> {
    if s.is_null() {
        return Err((TRACTRIX_E_ARGUMENT, format!("{what} is null")));
    }
    // SAFETY: `s` is non-null and, by contract, a NUL-terminated string that outlives the call.
    unsafe { CStr::from_ptr(s) }
        .to_str()
        .map_err(|_| (TRACTRIX_E_ARGUMENT, format!("{what} is not UTF-8")))
}

/// `n` points from a C array (`null` with `n = 0` is an empty list).
fn points_arg<'a>(p: *const Vec3, n: usize) -> Result<&'a [Vec3], (c_int, String)> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err((TRACTRIX_E_ARGUMENT, "points is null".into()));
    }
    if n > shared::MAX_PATH_POINTS as usize {
        return Err((
            TRACTRIX_E_ARGUMENT,
            format!("{n} points; at most {}", shared::MAX_PATH_POINTS),
        ));
    }
    // SAFETY: `p` is non-null and, by contract, valid for `n` reads of `tractrix_Vec3` for the call.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// Connects to the service with iceoryx2 prefix `prefix` (null: `TRACTRIX_IOX_PREFIX` or the default),
/// waiting up to `connect_timeout_s` for it to appear; each call then waits up to `call_timeout_s`.
/// Writes the handle to `*out`. Thread-safe.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_open(
    prefix: *const c_char,
    wait: c_int,
    connect_timeout_s: f64,
    call_timeout_s: f64,
    out: *mut *mut TractrixClient,
) -> c_int {
    let result = catch_unwind(AssertUnwindSafe(
        || -> Result<*mut TractrixClient, (c_int, String)> {
            if out.is_null() {
                return Err((TRACTRIX_E_ARGUMENT, "out is null".into()));
            }
            let prefix = if prefix.is_null() {
                shared::prefix_from_env()
            } else {
                text_arg(prefix, "prefix")?.to_string()
            };
            let secs = |s: f64, what: &str| {
                if s.is_finite() && (0.0..=3600.0).contains(&s) {
                    Ok(Duration::from_secs_f64(s))
                } else {
                    Err((
                        TRACTRIX_E_ARGUMENT,
                        format!("{what} {s}: expected 0 to 3600 seconds"),
                    ))
                }
            };
            let wait = match wait {
                TRACTRIX_WAIT_SPIN => Wait::Spin,
                TRACTRIX_WAIT_EVENT => Wait::Event,
                TRACTRIX_WAIT_HYBRID => Wait::Hybrid(Duration::from_micros(50)),
                w => {
                    return Err((
                        TRACTRIX_E_ARGUMENT,
                        format!("wait mode {w} is not 0, 1 or 2"),
                    ));
                }
            };
            let opts = ConnectOptions {
                prefix,
                wait,
                connect_timeout: secs(connect_timeout_s, "connect timeout")?,
                call_timeout: secs(call_timeout_s, "call timeout")?,
                ..ConnectOptions::default()
            };
            let conn = Connection::<Svc>::open(opts).map_err(|e| (code(&e), e.to_string()))?;
            Ok(Box::into_raw(Box::new(TractrixClient {
                conn: Mutex::new(conn),
                error: Mutex::new(CString::default()),
                pull_stop: AtomicI32::new(0),
            })))
        },
    ));
    let (rc, msg) = match result {
        Ok(Ok(handle)) => {
            // SAFETY: checked non-null above; by contract it points to a writable handle pointer.
            unsafe { out.write(handle) };
            (0, String::new())
        }
        Ok(Err(e)) => e,
        Err(_) => (TRACTRIX_E_PANIC, "panic while connecting".into()),
    };
    OPEN_ERROR.with(|e| *e.borrow_mut() = c_text(&msg));
    rc
}

/// The message of this thread's last failed `tractrix_client_open` (empty after a success). Valid until
/// the thread's next open.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_last_open_error() -> *const c_char {
    OPEN_ERROR.with(|e| e.borrow().as_ptr())
}

/// Closes a client (null is ignored). Its streams must be closed first.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_close(client: *mut TractrixClient) {
    if client.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: a non-null handle from `tractrix_client_open`, closed once (the caller's contract);
        // it was made by `Box::into_raw`.
        drop(unsafe { Box::from_raw(client) });
    }));
}

/// Why the last call on this handle failed (UTF-8, empty after a success). Valid until the next call.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_error(client: *const TractrixClient) -> *const c_char {
    // SAFETY: null or a live handle (the caller's contract).
    match unsafe { client.as_ref() } {
        // The CString stays in the handle until the next call replaces it.
        Some(c) => c.error.lock().map_or(c"".as_ptr(), |e| e.as_ptr()),
        None => c"null client".as_ptr(),
    }
}

/// The handle of the chain named `name`, written to `*chain` (`TRACTRIX_E_NO_CHAIN` if none).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_find_chain(
    client: *mut TractrixClient,
    name: *const c_char,
    chain: *mut u32,
) -> c_int {
    with_client(client, |conn| {
        let name = text_arg(name, "name")?;
        if chain.is_null() {
            return Err((TRACTRIX_E_ARGUMENT, "chain is null".into()));
        }
        match conn
            .find_chain(name)
            .map_err(|e| (code(&e), e.to_string()))?
        {
            Some(c) => {
                // SAFETY: checked non-null; by contract a writable uint32_t.
                unsafe { chain.write(c) };
                Ok(0)
            }
            None => Err((
                TRACTRIX_E_NO_CHAIN,
                format!("the service has no chain {name:?}"),
            )),
        }
    })
}

/// The general call: any request header and points; the response header is copied to `*response`
/// (written for refusals too) and its elements (`n_joints + n_angles + n_held` + 3 ×
/// `n_instruments`: the whole payload) into `(elements, capacity)`. Returns 0, the service's status, or a client error.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_call(
    client: *mut TractrixClient,
    header: *const RequestHeader,
    points: *const Vec3,
    n_points: usize,
    response: *mut ResponseHeader,
    elements: *mut Vec3,
    capacity: usize,
) -> c_int {
    with_client(client, |conn| {
        // SAFETY: null or, by contract, a readable tractrix_RequestHeader (repr(C), same layout).
        let Some(h) = (unsafe { header.as_ref() }) else {
            return Err((TRACTRIX_E_ARGUMENT, "header is null".into()));
        };
        let pts = points_arg(points, n_points)?;
        request(conn, *h, pts, |rh, p| {
            if !response.is_null() {
                // SAFETY: non-null; by contract a writable tractrix_ResponseHeader.
                unsafe { response.write(*rh) };
            }
            let n = p.len();
            if n == 0 {
                return 0;
            }
            if elements.is_null() || capacity < n {
                return TRACTRIX_E_BUFFER;
            }
            // SAFETY: non-null and, by contract, valid for `capacity` ≥ `n` element writes.
            unsafe { std::ptr::copy_nonoverlapping(p.as_ptr(), elements, n) };
            0
        })
    })
}

/// A request on `chain`'s `joint` with no points whose joints the caller does not want.
fn command_only(client: *mut TractrixClient, command: Command, chain: u32, joint: u32) -> c_int {
    joint_request(
        client,
        command,
        chain,
        joint,
        &[],
        std::ptr::null_mut(),
        0,
        std::ptr::null_mut(),
    )
}

/// A request on `chain`'s `joint` with `points`; joints into `(joints, capacity)`, count to `*n_joints`.
fn joint_request(
    client: *mut TractrixClient,
    command: Command,
    chain: u32,
    joint: u32,
    points: &[Vec3],
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    flagged_request(
        client, command, chain, joint, 0, points, joints, capacity, n_joints,
    )
}

/// [`joint_request`] with the request's `flags`.
#[allow(clippy::too_many_arguments)]
fn flagged_request(
    client: *mut TractrixClient,
    command: Command,
    chain: u32,
    joint: u32,
    flags: u32,
    points: &[Vec3],
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    with_client(client, |conn| {
        let mut h = RequestHeader::new(command, chain);
        h.joint = joint;
        h.flags = flags;
        request(conn, h, points, |rh, p| {
            copy_joints(rh, p, joints, capacity, n_joints)
        })
    })
}

/// Moves `joint` of `chain` (0 = tail, `TRACTRIX_JOINT_HEAD` = head) straight to `target`, with the
/// chain's default method and substeps; the new joints go to `(joints, capacity)` (null with capacity
/// 0 to skip them), their count to `*n_joints` (may be null).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_move(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
    target: Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    joint_request(
        client,
        Command::Move,
        chain,
        joint,
        &[target],
        joints,
        capacity,
        n_joints,
    )
}

/// Poses the needle of `chain` (a chain with a needle) as a 6-DOF stylus holds the needle driver
/// (`TRACTRIX_FLAG_POSE`): its swage (the chain's head) to `swage`, the needle turned by the rotation
/// vector `rotation` (axis × angle, radians) from its own frame, in which it leaves the swage along +x
/// and curves toward +y. The rope follows the head; where the needle's point crosses the tissue's
/// surface it cuts a hole the rope then threads. Joints as with [`tractrix_client_move`].
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_needle_pose(
    client: *mut TractrixClient,
    chain: u32,
    swage: Vec3,
    rotation: Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    flagged_request(
        client,
        Command::Move,
        chain,
        shared::JOINT_HEAD,
        shared::FLAG_POSE,
        &[swage, rotation],
        joints,
        capacity,
        n_joints,
    )
}

/// Drives the needle of `chain` (a chain with a needle) along its own arc, as a needle driver turns
/// a curved needle, its swage (the chain's head) to `target` (`TRACTRIX_FLAG_DRIVE`: a target on the
/// needle's circle turns it about its centre); where its point crosses the tissue's surface it cuts
/// a hole the rope then threads. Joints as with [`tractrix_client_move`].
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_needle_drive(
    client: *mut TractrixClient,
    chain: u32,
    target: Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    flagged_request(
        client,
        Command::Move,
        chain,
        shared::JOINT_HEAD,
        shared::FLAG_DRIVE,
        &[target],
        joints,
        capacity,
        n_joints,
    )
}

/// The pull on `joint` in a response (its held pull, or for a joint that is not held where it is less
/// the target) and whether a stretch of rope that ends at it is taut.
fn pull_of(h: &ResponseHeader, p: &[Vec3], joint: u32, target: Vec3) -> (Vec3, bool) {
    let parts = shared::Parts::of_response(h, p);
    let j = if joint == shared::JOINT_HEAD {
        parts.joints.len().saturating_sub(1) as u32
    } else {
        joint
    };
    let taut: Vec<bool> = parts.taut().collect();
    match parts.held_joints().position(|(k, _)| k == j) {
        Some(k) => (
            parts.pulls.get(k).copied().unwrap_or_default(),
            taut[k] || (k > 0 && taut[k - 1]),
        ),
        None => match parts.joints.get(j as usize) {
            Some(q) => (
                Vec3::new(q.x - target.x, q.y - target.y, q.z - target.z),
                false,
            ),
            None => (Vec3::default(), false),
        },
    }
}

/// Moves `joint` toward `target` as far as the rope lets it (`TRACTRIX_FLAG_PULL`): a move the rope
/// cannot make in full (out of length between held joints, contact jammed, a joint limit) stops
/// short instead of being refused. The joints go to `(joints, capacity)` as with
/// [`tractrix_client_move`]; the pull on the joint (where the rope let it be less where it was asked
/// to be: zero when slack; times a coupling stiffness, the force on the hand) to `*pull`, and 1 to
/// `*taut` when a stretch of rope from it to a neighbouring held joint is taut, else 0 (both may be
/// null).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_pull(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
    target: Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
    pull: *mut Vec3,
    taut: *mut c_int,
) -> c_int {
    let mut stop = 0;
    let rc = with_client(client, |conn| {
        let mut h = RequestHeader::new(Command::Move, chain);
        h.joint = joint;
        h.flags = shared::FLAG_PULL;
        request(conn, h, &[target], |rh, p| {
            stop = pull_stop_code(rh.pull_stop());
            let (v, t) = pull_of(rh, p, joint, target);
            if !pull.is_null() {
                // SAFETY: non-null and, by contract, a writable tractrix_Vec3.
                unsafe { pull.write(v) };
            }
            if !taut.is_null() {
                // SAFETY: non-null and, by contract, a writable int.
                unsafe { taut.write(c_int::from(t)) };
            }
            copy_joints(rh, p, joints, capacity, n_joints)
        })
    });
    // SAFETY: null or a live handle (the caller's contract).
    if let Some(c) = unsafe { client.as_ref() } {
        c.pull_stop.store(stop, Ordering::Relaxed);
    }
    rc
}

/// Why the last `tractrix_client_pull` on this handle stopped short of its target
/// (`TRACTRIX_PULL_STOP_*`): 0 when it made the whole move (or failed, or none was made), 1 the rope
/// taut, 2 contact jammed, 3 a joint limit, 4 the request's work budget; `TRACTRIX_E_ARGUMENT` for a
/// null handle.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_pull_stop(client: *const TractrixClient) -> c_int {
    // SAFETY: null or a live handle (the caller's contract).
    match unsafe { client.as_ref() } {
        Some(c) => c.pull_stop.load(Ordering::Relaxed),
        None => TRACTRIX_E_ARGUMENT,
    }
}

/// Moves `joint` through `n_points` targets in order (at most 4096).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_path(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
    points: *const Vec3,
    n_points: usize,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    let out = (joints, capacity, n_joints);
    path_with(client, chain, joint, (points, n_points), out, 0)
}

/// A path request with `flags` (0 or `FLAG_SMOOTH`).
fn path_with(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
    (points, n_points): (*const Vec3, usize),
    (joints, capacity, n_joints): (*mut Vec3, usize, *mut usize),
    flags: u32,
) -> c_int {
    with_client(client, |conn| {
        let pts = points_arg(points, n_points)?;
        let mut h = RequestHeader::new(Command::Path, chain);
        h.joint = joint;
        h.flags = flags;
        request(conn, h, pts, |rh, p| {
            copy_joints(rh, p, joints, capacity, n_joints)
        })
    })
}

/// [`tractrix_client_path`] along the natural cubic spline through the joint and the points (C²,
/// `TRACTRIX_FLAG_SMOOTH`) instead of straight segments.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_path_smooth(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
    points: *const Vec3,
    n_points: usize,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    let out = (joints, capacity, n_joints);
    path_with(
        client,
        chain,
        joint,
        (points, n_points),
        out,
        shared::FLAG_SMOOTH,
    )
}

/// A fixed-base chain's head to `target` (the chain's strategy and tolerance); the distance left is
/// written to `*residual` (may be null).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_reach(
    client: *mut TractrixClient,
    chain: u32,
    target: Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
    residual: *mut f64,
) -> c_int {
    with_client(client, |conn| {
        request(
            conn,
            RequestHeader::new(Command::Reach, chain),
            &[target],
            |rh, p| {
                if !residual.is_null() {
                    // SAFETY: non-null; by contract a writable double.
                    unsafe { residual.write(rh.residual) };
                }
                copy_joints(rh, p, joints, capacity, n_joints)
            },
        )
    })
}

/// A fixed-base chain's head to a goal beyond a point (Korein & Badler): `goal` is
/// `TRACTRIX_FLAG_ORIENT` (`a` where the head goes, `b` the last link's direction),
/// `TRACTRIX_FLAG_IN_BOX` (`a`, `b` the corners of smallest and largest coordinates) or
/// `TRACTRIX_FLAG_IN_BALL` (`a` the centre, `b.x` the radius); 0 is a point goal at `a`. The distance
/// left is written to `*residual` (may be null).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_reach_goal(
    client: *mut TractrixClient,
    chain: u32,
    goal: u32,
    a: Vec3,
    b: Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
    residual: *mut f64,
) -> c_int {
    with_client(client, |conn| {
        let mut h = RequestHeader::new(Command::Reach, chain);
        h.flags = goal;
        let ball = [a, Vec3::new(b.x, 0.0, 0.0)];
        let points: &[Vec3] = match goal {
            0 => &[a],
            shared::FLAG_IN_BALL => &ball,
            _ => &[a, b],
        };
        request(conn, h, points, |rh, p| {
            if !residual.is_null() {
                // SAFETY: non-null; by contract a writable double.
                unsafe { residual.write(rh.residual) };
            }
            copy_joints(rh, p, joints, capacity, n_joints)
        })
    })
}

/// The chain's current joints.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_query(
    client: *mut TractrixClient,
    chain: u32,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    joint_request(
        client,
        Command::Query,
        chain,
        0,
        &[],
        joints,
        capacity,
        n_joints,
    )
}

/// Back to the scene's initial state.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_reset(client: *mut TractrixClient, chain: u32) -> c_int {
    command_only(client, Command::Reset, chain, 0)
}

/// Holds `joint` where it is (a hand's grasp).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_grasp(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
) -> c_int {
    command_only(client, Command::Grasp, chain, joint)
}

/// Lets a grasped joint go.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_release(
    client: *mut TractrixClient,
    chain: u32,
    joint: u32,
) -> c_int {
    command_only(client, Command::Release, chain, joint)
}

/// Moves instrument `index` of `chain` to `centre`, turned to `*axis` (capsules; null for a sphere).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_instrument(
    client: *mut TractrixClient,
    chain: u32,
    index: u32,
    centre: Vec3,
    axis: *const Vec3,
    joints: *mut Vec3,
    capacity: usize,
    n_joints: *mut usize,
) -> c_int {
    // SAFETY: null or, by contract, a readable tractrix_Vec3.
    let points: Vec<Vec3> = match unsafe { axis.as_ref() } {
        Some(a) => vec![centre, *a],
        None => vec![centre],
    };
    joint_request(
        client,
        Command::Instrument,
        chain,
        index,
        &points,
        joints,
        capacity,
        n_joints,
    )
}

/// The chain's description (name, kind, links, lengths, defaults) in `*description`.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_client_describe(
    client: *mut TractrixClient,
    chain: u32,
    description: *mut ResponseHeader,
) -> c_int {
    with_client(client, |conn| {
        if description.is_null() {
            return Err((TRACTRIX_E_ARGUMENT, "description is null".into()));
        }
        request(
            conn,
            RequestHeader::new(Command::Describe, chain),
            &[],
            |rh, _| {
                // SAFETY: checked non-null; by contract a writable tractrix_ResponseHeader.
                unsafe { description.write(*rh) };
                0
            },
        )
    })
}

/// Subscribes to the state stream (every accepted change, in order); the handle goes to `*out`.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_stream_open(
    client: *mut TractrixClient,
    out: *mut *mut TractrixStream,
) -> c_int {
    with_client(client, |conn| {
        if out.is_null() {
            return Err((TRACTRIX_E_ARGUMENT, "out is null".into()));
        }
        let stream = conn.subscribe().map_err(|e| (code(&e), e.to_string()))?;
        let handle = Box::into_raw(Box::new(TractrixStream { stream }));
        // SAFETY: checked non-null; by contract a writable stream pointer.
        unsafe { out.write(handle) };
        Ok(0)
    })
}

/// Called with each state: the header, and its joints (borrowed for the call only).
pub type TractrixOnState = extern "C" fn(
    user: *mut c_void,
    header: *const StateHeader,
    joints: *const Vec3,
    n_joints: usize,
);

/// Hands the next waiting state, if any, to `on_state` (joints borrowed for the call). Returns 1 if a
/// state was delivered, 0 if none was waiting, a negative error otherwise. Never blocks.
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_stream_next(
    stream: *mut TractrixStream,
    on_state: Option<TractrixOnState>,
    user: *mut c_void,
) -> c_int {
    // SAFETY: null or a live stream handle used by one thread at a time (the caller's contract).
    let Some(s) = (unsafe { stream.as_ref() }) else {
        return TRACTRIX_E_ARGUMENT;
    };
    let Some(f) = on_state else {
        return TRACTRIX_E_ARGUMENT;
    };
    match catch_unwind(AssertUnwindSafe(|| {
        s.stream.try_next(|h, p| {
            // The counts cut to the payload, so that a caller who follows them stays inside it.
            let parts = shared::Parts::of_state(h, p);
            let h = StateHeader {
                n_joints: parts.joints.len() as u32,
                n_held: parts.held.len() as u32,
                n_instruments: (parts.instruments.len() / shared::INSTRUMENT_ELEMENTS as usize)
                    as u32,
                n_pulls: parts.pulls.len() as u32,
                n_eyelets: (parts.eyelets.len() / shared::EYELET_ELEMENTS as usize) as u32,
                ..*h
            };
            f(user, &h, p.as_ptr(), parts.joints.len());
        })
    })) {
        Ok(Ok(Some(()))) => 1,
        Ok(Ok(None)) => 0,
        Ok(Err(e)) => code(&e),
        Err(_) => TRACTRIX_E_PANIC,
    }
}

/// Closes a stream (null is ignored).
///
/// # Safety
///
/// Every pointer is null or valid as `tractrix_client.h` says (handles from the matching `open` and
/// not yet closed; buffers valid for their stated capacity; strings NUL-terminated).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tractrix_stream_close(stream: *mut TractrixStream) {
    if stream.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: a non-null handle from `tractrix_stream_open`, closed once; made by `Box::into_raw`.
        drop(unsafe { Box::from_raw(stream) });
    }));
}
