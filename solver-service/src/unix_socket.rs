//! The same protocol over a Unix domain socket: a comparison transport for the latency bench (and for a
//! peer that cannot map iceoryx2's shared memory). Same wire types, the service's own answer path
//! ([`crate::serve::respond`] over a [`Solver`]), persistence as the solver has it (the binary's
//! `unix` persists only into a `--state-dir` given; without, a `snapshot` is refused), requests from
//! [`LOCAL`], one connection at a time, every wait a blocking read (the kernel wakes the server).
//!
//! Framing: [`shared::unix_frame`]. A request with more than [`MAX_PATH_POINTS`] points or a non-zero pad
//! gets a `bad-point-count` (`bad-option`) response and the connection is closed: the stream cannot be
//! trusted after it.

use crate::serve::{Handler, respond};
use crate::service::Solver;
use shared::unix_frame::{REQUEST_PREFIX, frame_ok, split_request_prefix, write_response};
use shared::{MAX_PATH_POINTS, ResponseHeader, Status, Vec3};
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use world::owners::LOCAL;

/// Serves connections one after another until the listener fails. Returns after `max_connections`
/// connections if given (the tests and the bench use one).
pub fn serve(
    listener: &UnixListener,
    solver: &mut Solver,
    max_connections: Option<usize>,
) -> std::io::Result<()> {
    for (served, stream) in listener.incoming().enumerate() {
        if let Err(e) = serve_connection(stream?, solver) {
            eprintln!("solver-service: unix socket connection ended: {e}");
        }
        if max_connections.is_some_and(|m| served + 1 >= m) {
            break;
        }
    }
    Ok(())
}

/// Serves one connection until the peer closes it (`Ok`) or breaks the framing (`Err`).
pub fn serve_connection(mut stream: UnixStream, solver: &mut Solver) -> std::io::Result<()> {
    let mut prefix = [0u8; REQUEST_PREFIX];
    let mut points: Vec<Vec3> = Vec::with_capacity(MAX_PATH_POINTS as usize);
    let mut out: Vec<u8> = Vec::new();
    let mut elements: Vec<Vec3> = Vec::new();
    loop {
        match stream.read_exact(&mut prefix) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(()),
            Err(e) => return Err(e),
        }
        let (header, n, pad) = split_request_prefix(&prefix);
        let mut h = ResponseHeader::default();
        if !frame_ok(n, pad) {
            h.status = if pad != 0 {
                Status::BadOption
            } else {
                Status::BadPointCount
            } as u32;
            h.command = header.command;
            h.chain = header.chain;
            h.request_id = header.request_id;
            h.sequence = solver.set().sequence();
            h.set_reason(&format!(
                "unix frame: {n} points (at most {MAX_PATH_POINTS}), pad {pad} (must be 0); closing"
            ));
            stream.write_all(bytemuck::bytes_of(&h))?;
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "bad frame",
            ));
        }
        points.resize(n as usize, Vec3::default());
        stream.read_exact(bytemuck::cast_slice_mut(&mut points))?;
        let (h, _) = respond(solver, LOCAL, &header, &points, &mut elements);
        write_response(&mut stream, &mut out, &h, elements.iter().copied())?;
        // Periodic snapshots, as the serving loop runs them between requests.
        solver.housekeeping(std::time::Instant::now(), None);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::unix_frame::{read_response, write_request};
    use shared::{Command, RequestHeader};
    use world::World;

    #[test]
    fn a_move_over_the_socket_matches_the_same_move_in_process() {
        let scene = world::scene::default_scene();
        let mut served = Solver::new(World::new(&scene).unwrap(), None, std::time::Duration::ZERO);
        let mut local = Solver::new(World::new(&scene).unwrap(), None, std::time::Duration::ZERO);
        let (a, mut b) = UnixStream::pair().unwrap();
        let server = std::thread::spawn(move || {
            let r = serve_connection(a, &mut served);
            (r.is_err(), served.set().sequence())
        });
        let req = RequestHeader::new(Command::Move, 0);
        let target = [Vec3::new(38.0, 3.0, 1.0)];
        let mut buf = Vec::new();
        let mut got = Vec::new();
        write_request(&mut b, &mut buf, &req, &target).unwrap();
        let h = read_response(&mut b, &mut got).unwrap();
        let mut expected = Vec::new();
        let (_, changed) = respond(&mut local, LOCAL, &req, &target, &mut expected);
        assert!(changed);
        assert_eq!(h.status, Status::Ok as u32);
        assert_eq!(h.n_joints, 41);
        assert_eq!(got, expected);
        // A frame announcing too many points is refused and closes the connection.
        let mut bad = Vec::new();
        bad.extend_from_slice(bytemuck::bytes_of(&req));
        bad.extend_from_slice(&(MAX_PATH_POINTS + 1).to_le_bytes());
        bad.extend_from_slice(&0u32.to_le_bytes());
        b.write_all(&bad).unwrap();
        let h = read_response(&mut b, &mut got).unwrap();
        assert_eq!(h.status, Status::BadPointCount as u32);
        drop(b);
        let (broken, sequence) = server.join().unwrap();
        assert!(broken, "the bad frame ends the connection with an error");
        assert_eq!(sequence, 1, "only the good move was applied");
    }
}
