//! The live 3D view of `watch --rerun` (cargo feature `rerun`): every state of every chain goes to a
//! Rerun viewer, or with `--save` into an `.rrd` recording.
//!
//! What is logged (entity paths; the timelines are `sequence`, the state stream's sequence number, and
//! `elapsed`, seconds since `watch` started):
//!
//! | entity | archetype | when |
//! |---|---|---|
//! | `chains/NAME/rope` | `LineStrips3D`, radius = half the chain's thickness | every state |
//! | `chains/NAME/joints` | `Points3D` | every state |
//! | `chains/NAME/held` | `Points3D`, labelled `anchor J` / `grasp J` (empty when nothing is held) | every state |
//! | `chains/NAME/instruments/K` | `Capsules3D` (from end `a` to `b`) or `Ellipsoids3D` (a sphere): instrument `K` of the chain in the scene's order | every state of a chain with instruments |
//! | `chains/NAME/knot` | `TextLog`: the knot's name | when the name changes (free chains only) |
//! | `chains/NAME/knot_crossings` | `Scalars`: crossings of the reduced diagram | with each identification |
//! | `bundles/NAME/strands` | `LineStrips3D`, one strip per strand (timeline `bundle_sequence`: the bundle's own count of changes) | every state of a bundle |
//! | `latency/query_round_trip_us` | `Scalars`: a `query` round trip timed by `watch` itself | every 100 ms |
//! | `stream/missed` | `Scalars`: states lost so far (sequence gaps: a viewer too slow for its buffer) | on a gap |
//!
//! Knots are identified at most every 200 ms per chain, when the stream is idle, so a busy stream costs
//! the viewer no more than drawing it.

use std::path::Path;

/// The default address of a viewer started with `rerun` (its gRPC proxy).
pub const DEFAULT_URL: &str = "rerun+http://127.0.0.1:9876/proxy";

/// Where the recording goes.
#[derive(Debug, Clone, Copy)]
pub enum Sink<'a> {
    /// A running viewer at this gRPC address.
    Viewer(&'a str),
    /// An `.rrd` file.
    File(&'a Path),
}

#[cfg(feature = "rerun")]
mod recording;
#[cfg(feature = "rerun")]
pub use recording::RerunView;

#[cfg(not(feature = "rerun"))]
mod absent;
#[cfg(not(feature = "rerun"))]
pub use absent::RerunView;
