//! Framing of the same protocol over a Unix domain socket (the comparison transport of the latency
//! bench, and a way in for a peer that cannot map iceoryx2's shared memory). Little-endian, no padding:
//!
//! * request: [`RequestHeader`] (96 B), then `n_points: u32` and a zero `u32`, then `n_points` × [`Vec3`];
//! * response: [`ResponseHeader`] (288 B), then `n_joints + n_angles + n_held + 3 n_instruments` ×
//!   [`Vec3`] (the payload of the shared-memory response).
//!
//! A server refuses a frame announcing more than [`MAX_PATH_POINTS`] points or a non-zero pad and closes
//! the connection: the stream cannot be trusted after it.

use crate::{
    INSTRUMENT_ELEMENTS, MAX_PATH_POINTS, MAX_RESPONSE_ELEMENTS, RequestHeader, ResponseHeader,
    Vec3,
};
use std::io::{Read, Write};

/// Bytes of the request frame before the points.
pub const REQUEST_PREFIX: usize = size_of::<RequestHeader>() + 8;

/// Writes one request frame (assembled in `buf`, one write).
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

/// The parts of a request frame's prefix: the header, the announced point count and the pad.
pub fn split_request_prefix(prefix: &[u8; REQUEST_PREFIX]) -> (RequestHeader, u32, u32) {
    let header: RequestHeader = bytemuck::pod_read_unaligned(&prefix[..size_of::<RequestHeader>()]);
    let tail = &prefix[size_of::<RequestHeader>()..];
    let word = |i: usize| u32::from_le_bytes([tail[i], tail[i + 1], tail[i + 2], tail[i + 3]]);
    (header, word(0), word(4))
}

/// Whether a frame announcing `n_points` with `pad` may be read (else the server refuses and closes).
pub fn frame_ok(n_points: u32, pad: u32) -> bool {
    n_points <= MAX_PATH_POINTS && pad == 0
}

/// Writes one response frame (assembled in `buf`, one write).
pub fn write_response(
    out: &mut impl Write,
    buf: &mut Vec<u8>,
    header: &ResponseHeader,
    elements: impl Iterator<Item = Vec3>,
) -> std::io::Result<()> {
    buf.clear();
    buf.extend_from_slice(bytemuck::bytes_of(header));
    for e in elements {
        buf.extend_from_slice(bytemuck::bytes_of(&e));
    }
    out.write_all(buf)
}

/// Reads one response frame: the header, and its elements into `elements` (bounded by
/// [`MAX_RESPONSE_ELEMENTS`]).
pub fn read_response(
    input: &mut impl Read,
    elements: &mut Vec<Vec3>,
) -> std::io::Result<ResponseHeader> {
    let mut h = ResponseHeader::default();
    input.read_exact(bytemuck::bytes_of_mut(&mut h))?;
    let n = h.n_joints as u64
        + h.n_angles as u64
        + h.n_held as u64
        + h.n_instruments as u64 * INSTRUMENT_ELEMENTS as u64;
    if n > MAX_RESPONSE_ELEMENTS as u64 {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("response announces {n} elements"),
        ));
    }
    elements.resize(n as usize, Vec3::default());
    input.read_exact(bytemuck::cast_slice_mut(elements))?;
    Ok(h)
}
