//! The same protocol over a Unix domain socket: a comparison transport for the latency bench (and for a
//! peer that cannot map iceoryx2's shared memory). Same wire types, same [`ChainSet`], no persistence,
//! one connection at a time, every wait a blocking read (the kernel wakes the server).
//!
//! Framing, little-endian, no padding:
//!
//! * request: [`RequestHeader`] (96 B), then `n_points: u32` and a zero `u32`, then `n_points` × [`Vec3`];
//! * response: [`ResponseHeader`] (256 B), then `n_joints + n_angles` × [`Vec3`].
//!
//! A request with more than [`MAX_PATH_POINTS`] points or a non-zero pad gets a `bad-point-count`
//! (`bad-option`) response and the connection is closed: the stream cannot be trusted after it.

use crate::chain_set::ChainSet;
use protocol::{MAX_PATH_POINTS, RequestHeader, ResponseHeader, Status, Vec3};
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::time::Instant;

/// Bytes of the request frame before the points.
pub const REQUEST_PREFIX: usize = size_of::<RequestHeader>() + 8;

/// Writes one request frame.
pub fn write_request(
    out: &mut impl Write,
    buf: &mut Vec<u8>,
    header: &RequestHeader,
    points: &[Vec3],
) -> std::io::Result<()> {
    buf.clear();
    buf.extend_from_slice(bytemuck::bytes_of(header));
    buf.extend_from_slice(&(points.len() as u32).to_le_bytes());
    buf.extend_from_slice(&0u32.to_le_bytes());
    buf.extend_from_slice(bytemuck::cast_slice(points));
    out.write_all(buf)
}

/// Reads one response frame: the header, and its elements into `elements` (bounded by
/// [`protocol::MAX_RESPONSE_ELEMENTS`]).
pub fn read_response(
    input: &mut impl Read,
    elements: &mut Vec<Vec3>,
) -> std::io::Result<ResponseHeader> {
    let mut h = ResponseHeader::default();
    input.read_exact(bytemuck::bytes_of_mut(&mut h))?;
    let n = h.n_joints as u64 + h.n_angles as u64;
    if n > protocol::MAX_RESPONSE_ELEMENTS as u64 {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("response announces {n} elements"),
        ));
    }
    elements.resize(n as usize, Vec3::default());
    input.read_exact(bytemuck::cast_slice_mut(elements))?;
    Ok(h)
}

/// Serves connections one after another until the listener fails. Returns after `max_connections`
/// connections if given (the tests and the bench use one).
pub fn serve(
    listener: &UnixListener,
    set: &mut ChainSet,
    max_connections: Option<usize>,
) -> std::io::Result<()> {
    for (served, stream) in listener.incoming().enumerate() {
        if let Err(e) = serve_connection(stream?, set) {
            eprintln!("solver-service: unix socket connection ended: {e}");
        }
        if max_connections.is_some_and(|m| served + 1 >= m) {
            break;
        }
    }
    Ok(())
}

/// Serves one connection until the peer closes it (`Ok`) or breaks the framing (`Err`).
pub fn serve_connection(mut stream: UnixStream, set: &mut ChainSet) -> std::io::Result<()> {
    let mut prefix = [0u8; REQUEST_PREFIX];
    let mut points: Vec<Vec3> = Vec::with_capacity(MAX_PATH_POINTS as usize);
    let mut out: Vec<u8> = Vec::new();
    loop {
        match stream.read_exact(&mut prefix) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(()),
            Err(e) => return Err(e),
        }
        let t0 = Instant::now();
        let header: RequestHeader =
            bytemuck::pod_read_unaligned(&prefix[..size_of::<RequestHeader>()]);
        let tail = &prefix[size_of::<RequestHeader>()..];
        let n = u32::from_le_bytes(tail[..4].try_into().expect("4 bytes"));
        let pad = u32::from_le_bytes(tail[4..].try_into().expect("4 bytes"));
        let mut h = ResponseHeader::default();
        if n > MAX_PATH_POINTS || pad != 0 {
            h.status = if pad != 0 {
                Status::BadOption
            } else {
                Status::BadPointCount
            } as u32;
            h.command = header.command;
            h.chain = header.chain;
            h.request_id = header.request_id;
            h.sequence = set.sequence();
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
        set.apply(&header, &points, &mut h);
        h.solve_ns = t0.elapsed().as_nanos() as u64;
        let count = (h.n_joints + h.n_angles) as usize;
        out.clear();
        out.extend_from_slice(bytemuck::bytes_of(&h));
        for e in set.elements(h.chain, h.n_angles > 0).take(count) {
            out.extend_from_slice(bytemuck::bytes_of(&e));
        }
        stream.write_all(&out)?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::Command;

    #[test]
    fn a_move_over_the_socket_matches_the_same_move_in_process() {
        let scene = crate::scene::default_scene();
        let mut served = ChainSet::new(&scene).unwrap();
        let mut local = ChainSet::new(&scene).unwrap();
        let (a, mut b) = UnixStream::pair().unwrap();
        let server = std::thread::spawn(move || {
            let r = serve_connection(a, &mut served);
            (r.is_err(), served.sequence())
        });
        let req = RequestHeader::new(Command::Move, 0);
        let target = [Vec3::new(38.0, 3.0, 1.0)];
        let mut buf = Vec::new();
        let mut got = Vec::new();
        write_request(&mut b, &mut buf, &req, &target).unwrap();
        let h = read_response(&mut b, &mut got).unwrap();
        let mut want = ResponseHeader::default();
        assert!(local.apply(&req, &target, &mut want));
        assert_eq!(h.status, Status::Ok as u32);
        assert_eq!(h.n_joints, 41);
        let expected: Vec<Vec3> = local.elements(0, false).collect();
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
