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
//! | `chains/NAME/at_limit` | `Points3D`, red, labelled `J`: the joints turned to their joint limit ([`LimitView::at_limit`]; empty when none) | every state of a chain with a bend radius or one cone |
//! | `chains/NAME/instruments/K` | `Capsules3D` (from end `a` to `b`) or `Ellipsoids3D` (a sphere): instrument `K` of the chain in the scene's order | every state of a chain with instruments |
//! | `chains/NAME/pulls` | `Arrows3D` from each held joint and instrument along its pull (docs/tension.md), labelled with its length (empty when slack) | every state of a chain with held joints or instruments |
//! | `chains/NAME/taut` | `LineStrips3D`, red: the stretches between held joints that are taut | every state of a chain with held joints |
//! | `chains/NAME/pull/joint_J`, `chains/NAME/pull/instrument_K` | `Scalars`: the pull's length | every state of a chain with held joints or instruments |
//! | `chains/NAME/knot` | `TextLog`: the knot's name | when the name changes (free chains only) |
//! | `chains/NAME/knot_crossings` | `Scalars`: crossings of the reduced diagram | with each identification |
//! | `bundles/NAME/strands` | `LineStrips3D`, one strip per strand (timeline `bundle_sequence`: the bundle's own count of changes) | every state of a bundle |
//! | `latency/query_round_trip_us` | `Scalars`: a `query` round trip timed by `watch` itself | every 100 ms |
//! | `stream/missed` | `Scalars`: states lost so far (sequence gaps: a viewer too slow for its buffer) | on a gap |
//!
//! Knots are identified at most every 200 ms per chain, when the stream is idle, so a busy stream costs
//! the viewer no more than drawing it.

use std::path::Path;

/// What a chain's state shows beside its joints: its held joints, its instruments and their pulls,
/// and its eyelets.
#[derive(Debug, Clone, Copy)]
pub struct Around<'a> {
    pub held: &'a [Held],
    pub instruments: &'a [shared::InstrumentPose],
    pub instrument_pulls: &'a [[f64; 3]],
    pub eyelets: &'a [shared::EyeletState],
}

/// A held joint as a state shows it: its index, whether the scene anchors it, whether the stretch from
/// it to the next held joint is taut, and its pull (docs/tension.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    pub joint: u32,
    pub anchor: bool,
    pub taut: bool,
    pub pull: [f64; 3],
}

impl Held {
    /// The held joints of a payload with their taut flags and pulls.
    pub fn of(parts: &shared::Parts<'_>) -> Vec<Held> {
        parts
            .held_joints()
            .zip(parts.taut())
            .enumerate()
            .map(|(k, ((joint, anchor), taut))| Held {
                joint,
                anchor,
                taut,
                pull: parts.pulls.get(k).map_or([0.0; 3], |p| p.to_array()),
            })
            .collect()
    }
}

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

/// A chain's joint limits as a viewer can draw them, from its `describe` (`limits`, `limit_value`):
/// the limits a describe carries exactly. Per-joint cones and planar ranges are described by their
/// widest value only, so they are not drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LimitView {
    /// A rope's minimum bend radius (a length): joint `j`'s cone is `2·atan(L / 2R)`, `L` the shorter
    /// of its two links.
    BendRadius(f64),
    /// One cone (radians) at every joint.
    Cone(f64),
}

impl LimitView {
    /// From a describe's `limits` and `limit_value`; `None` for no limits or limits not drawn.
    pub fn from_describe(limits: u32, value: f64) -> Option<Self> {
        match limits {
            shared::LIMITS_BEND_RADIUS if value > 0.0 => Some(LimitView::BendRadius(value)),
            shared::LIMITS_CONE if value > 0.0 => Some(LimitView::Cone(value)),
            _ => None,
        }
    }

    /// The interior joints of `joints` (tail first) whose turn is at their limit, to within `1e-6`
    /// rad (the kernel turns a link back onto its cone exactly, to rounding).
    pub fn at_limit(&self, joints: &[[f64; 3]]) -> Vec<usize> {
        let sub = |a: [f64; 3], b: [f64; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let mut out = Vec::new();
        for j in 1..joints.len().saturating_sub(1) {
            let (u, v) = (sub(joints[j - 1], joints[j]), sub(joints[j], joints[j + 1]));
            let cross = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let turn = norm(cross).atan2(u[0] * v[0] + u[1] * v[1] + u[2] * v[2]);
            let cone = match *self {
                LimitView::Cone(a) => a,
                LimitView::BendRadius(r) => 2.0 * (norm(u).min(norm(v)) / (2.0 * r)).atan(),
            };
            if turn >= cone - 1e-6 {
                out.push(j);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::LimitView;

    #[test]
    fn a_joint_turned_to_its_cone_is_at_its_limit_and_a_straight_one_is_not() {
        // Unit links; bend radius 1.5: cone 2·atan(1/3) ≈ 0.6435 rad.
        let cone = 2.0 * (1.0f64 / 3.0).atan();
        let at = |turn: f64| {
            let j = [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0 + turn.cos(), turn.sin(), 0.0],
            ];
            LimitView::BendRadius(1.5).at_limit(&j)
        };
        assert_eq!(at(cone), vec![1]);
        assert_eq!(at(cone - 1e-3), Vec::<usize>::new());
        assert_eq!(at(0.0), Vec::<usize>::new());
        assert_eq!(
            LimitView::from_describe(shared::LIMITS_CONE, 0.5),
            Some(LimitView::Cone(0.5))
        );
        assert_eq!(LimitView::from_describe(shared::LIMITS_CONES, 0.5), None);
    }
}
