//! The wire's door to the scene's bundles (see `shared`'s "Bundles"): [`decode`] checks a request
//! against a [`BundleSpec`] into a [`BundleOp`] (which [`world::bundles::Live::apply`] runs), and
//! [`describe`] writes a bundle's description into a response.

use crate::wire::header::{Checked, check_header};
use shared::{
    ChainKind, FLAG_POSE, JOINT_HEAD, Precision, RequestHeader, ResponseHeader, SubstepMode, Vec3,
    WireMethod,
};
use world::refusal::Refusal;
use world::refuse;
use world::scene::BundleSpec;

pub use world::command::BundleOp;

/// Checks a request addressed to bundle `spec`. Nothing is changed.
pub fn decode<'a>(
    h: &RequestHeader,
    points: &'a [Vec3],
    spec: &BundleSpec,
) -> Result<BundleOp<'a>, Refusal> {
    // The wire's points are the world's, borrowed as they lie (the same three f64s).
    let points: &'a [world::command::Point] = bytemuck::cast_slice(points);
    let Checked {
        command,
        method,
        precision,
        substep_mode,
        ..
    } = check_header(h, FLAG_POSE)?;
    let name = &spec.name;
    if precision != Precision::Default && precision != crate::wire::precision(spec.precision) {
        return Err(refuse!(
            BadOption,
            "bundle {name:?} is stored in another precision"
        ));
    }
    let pose = h.flags & FLAG_POSE != 0;
    if pose && command != shared::Command::Move {
        return Err(refuse!(BadOption, "FLAG_POSE is for a bundle's move"));
    }
    let want = match command {
        shared::Command::Move if pose => 2,
        shared::Command::Move => spec.strands as usize,
        shared::Command::Query | shared::Command::Describe | shared::Command::Reset => 0,
        other => {
            return Err(refuse!(
                WrongChainKind,
                "{name:?} is a bundle: {} is not for bundles (move, query, describe, reset)",
                other.name()
            ));
        }
    };
    if points.len() != want {
        return Err(refuse!(
            BadPointCount,
            "{} of bundle {name:?} takes {want} points, got {}",
            command.name(),
            points.len()
        ));
    }
    for (i, p) in points.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(refuse!(NonFinite, "point {i} is not finite"));
        }
        let far = p.x.abs().max(p.y.abs()).max(p.z.abs());
        // A pose's second point is a rotation vector, bounded by what a rotation can be.
        if (!pose || i == 0) && far > spec.max_coordinate {
            return Err(refuse!(
                TooFar,
                "point {i}: {far:.3e} is beyond {:.3e}: too far to keep link lengths",
                spec.max_coordinate
            ));
        }
    }
    match command {
        shared::Command::Move => {
            if h.joint != JOINT_HEAD && h.joint != spec.links {
                return Err(refuse!(
                    JointOutOfRange,
                    "a bundle moves its heads: joint must be {} or JOINT_HEAD",
                    spec.links
                ));
            }
            if !matches!(method, WireMethod::Default | WireMethod::Tractrix) {
                return Err(refuse!(
                    BadOption,
                    "a bundle moves by the closed-form tractrix only (method 0 or 1)"
                ));
            }
            let substeps = match substep_mode {
                SubstepMode::Default => spec.substeps,
                SubstepMode::Fixed if (1..=spec.max_substeps()).contains(&h.substeps) => h.substeps,
                SubstepMode::Fixed => {
                    return Err(refuse!(
                        BadOption,
                        "substeps {} outside 1..={}",
                        h.substeps,
                        spec.max_substeps()
                    ));
                }
                SubstepMode::MaxStep => {
                    return Err(refuse!(
                        BadOption,
                        "a bundle takes fixed substeps (substep_mode 0 or 1)"
                    ));
                }
            };
            Ok(if pose {
                BundleOp::Pose {
                    translation: points[0],
                    rotation: points[1],
                    substeps,
                }
            } else {
                BundleOp::Heads {
                    targets: points,
                    substeps,
                }
            })
        }
        shared::Command::Query => Ok(BundleOp::Query),
        shared::Command::Describe => Ok(BundleOp::Describe),
        _ => Ok(BundleOp::Reset),
    }
}

/// The description fields of a response for the bundle `spec`.
pub fn describe(spec: &BundleSpec, h: &mut ResponseHeader) {
    h.kind = ChainKind::Bundle as u32;
    h.dims = 3;
    h.n_links = spec.links;
    h.precision = crate::wire::precision(spec.precision) as u32;
    h.method = WireMethod::Tractrix as u32;
    h.collision = 0;
    h.substep_mode = SubstepMode::Fixed as u32;
    h.substeps_default = spec.substeps;
    h.max_step = 0.0;
    h.total_length = f64::from(spec.links) * spec.link_length;
    h.thickness = 0.0;
    h.set_name(&spec.name);
}
