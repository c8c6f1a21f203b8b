//! The wire's door to the world: [`request`] decodes a request header and its points into a
//! [`world::command::Command`] (or a refusal) and encodes an answer or a refusal into a response
//! header; [`bundle`] does the same for bundles; here, the world's enums as the wire numbers them,
//! and the bounds the wire states to clients checked against the ones the world enforces.

pub mod bundle;
pub mod door;
pub mod header;
pub mod request;

pub use door::WireWorld;

use shared::{COLLISION_OBSTACLES, COLLISION_PAPER_SPHERES, COLLISION_SELF};
use tractrix::collision::Scheme;
use world::refusal::{Cause, MAX_REASON_BYTES, Refusal};
use world::scene::{ChainKind, ChainSpec, Precision};
use world::sizes;

// The bounds the wire states (`shared`) are the ones the world enforces.
const _: () = {
    assert!(sizes::MAX_CHAINS == shared::MAX_CHAINS as usize);
    assert!(sizes::MAX_LINKS == shared::MAX_LINKS as usize);
    assert!(sizes::MAX_NAME_BYTES == shared::NAME_LEN - 1);
    assert!(sizes::MAX_HELD == shared::MAX_HELD as usize);
    assert!(sizes::MAX_GRASPS_PER_CLIENT == shared::MAX_GRASPS_PER_CLIENT as usize);
    assert!(sizes::MAX_BUNDLE_JOINTS == shared::MAX_BUNDLE_JOINTS as usize);
    assert!(sizes::MAX_BUNDLE_STRANDS == shared::MAX_BUNDLE_STRANDS as usize);
    assert!(MAX_REASON_BYTES == shared::REASON_LEN - 1);
};

/// The wire's status of a refusal's cause (the same name).
pub fn status(c: Cause) -> shared::Status {
    use shared::Status as S;
    match c {
        Cause::UnknownCommand => S::UnknownCommand,
        Cause::UnknownChain => S::UnknownChain,
        Cause::JointOutOfRange => S::JointOutOfRange,
        Cause::NonFinite => S::NonFinite,
        Cause::BadOption => S::BadOption,
        Cause::BadPointCount => S::BadPointCount,
        Cause::Unreachable => S::Unreachable,
        Cause::NotConverged => S::NotConverged,
        Cause::TooManySubsteps => S::TooManySubsteps,
        Cause::WrongChainKind => S::WrongChainKind,
        Cause::OffPlane => S::OffPlane,
        Cause::PersistenceFailed => S::PersistenceFailed,
        Cause::Internal => S::Internal,
        Cause::Locked => S::Locked,
        Cause::TooFar => S::TooFar,
        Cause::OverBudget => S::OverBudget,
        Cause::JointLimit => S::JointLimit,
        Cause::Held => S::Held,
    }
}

/// A refusal's reason in the wire's NUL-padded field.
pub fn reason(r: &Refusal) -> [u8; shared::REASON_LEN] {
    let mut out = [0; shared::REASON_LEN];
    let text = r.reason().as_bytes();
    out[..text.len()].copy_from_slice(text);
    out
}

/// Why a pull stopped short, as the wire says it (an ok response's reason).
pub fn pull_stop(s: world::tension::Stop) -> shared::PullStop {
    use world::tension::Stop;
    match s {
        Stop::Reach => shared::PullStop::Taut,
        Stop::Contact => shared::PullStop::Jammed,
        Stop::Limit => shared::PullStop::Limit,
        Stop::Work => shared::PullStop::Work,
    }
}

/// A chain's kind as the wire numbers it.
pub fn kind(k: ChainKind) -> shared::ChainKind {
    match k {
        ChainKind::Free => shared::ChainKind::Free,
        ChainKind::FixedBase => shared::ChainKind::FixedBase,
    }
}

/// A precision as the wire numbers it.
pub fn precision(p: Precision) -> shared::Precision {
    match p {
        Precision::F64 => shared::Precision::F64,
        Precision::F32 => shared::Precision::F32,
    }
}

/// A chain's collision handling as the wire's bits (`shared::COLLISION_*`).
pub fn collision_bits(spec: &ChainSpec) -> u32 {
    spec.collision.as_ref().map_or(0, |s| {
        (if s.options.self_collision {
            COLLISION_SELF
        } else {
            0
        }) | (if s.obstacles.is_empty() && s.instruments.is_empty() {
            0
        } else {
            COLLISION_OBSTACLES
        }) | (if s.options.scheme == Scheme::PaperSpheres {
            COLLISION_PAPER_SPHERES
        } else {
            0
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_world_enums_take_the_wire_numbers_of_their_names() {
        assert_eq!(kind(ChainKind::Free) as u32, 0);
        assert_eq!(kind(ChainKind::FixedBase) as u32, 1);
        assert_eq!(precision(Precision::F64) as u32, 1);
        assert_eq!(precision(Precision::F32) as u32, 2);
    }

    #[test]
    fn every_status_but_ok_is_the_cause_of_its_name() {
        let causes = [
            Cause::UnknownCommand,
            Cause::UnknownChain,
            Cause::JointOutOfRange,
            Cause::NonFinite,
            Cause::BadOption,
            Cause::BadPointCount,
            Cause::Unreachable,
            Cause::NotConverged,
            Cause::TooManySubsteps,
            Cause::WrongChainKind,
            Cause::OffPlane,
            Cause::PersistenceFailed,
            Cause::Internal,
            Cause::Locked,
            Cause::TooFar,
            Cause::OverBudget,
            Cause::JointLimit,
            Cause::Held,
        ];
        let wire: Vec<_> = causes.iter().map(|&c| status(c)).collect();
        for (c, s) in causes.iter().zip(&wire) {
            assert_eq!(format!("{c:?}"), format!("{s:?}"));
        }
        let others: Vec<_> = shared::Status::ALL
            .into_iter()
            .filter(|s| *s != shared::Status::Ok)
            .collect();
        assert_eq!(wire, others, "every status but ok, in wire order");
    }

    #[test]
    fn a_reason_fills_the_wire_s_field_with_a_nul_left() {
        let long = "é".repeat(80);
        let r = world::refuse!(BadOption, "{long}");
        let field = reason(&r);
        assert!(r.reason().len() <= MAX_REASON_BYTES);
        assert_eq!(&field[..r.reason().len()], r.reason().as_bytes());
        assert_eq!(field[shared::REASON_LEN - 1], 0);
    }

    /// The kernel names its methods once (scenes take those names); the wire's text form parses the
    /// same names to the wire's numbers for them.
    #[test]
    fn every_method_has_the_kernel_s_name_on_the_wire() {
        for m in tractrix::Method::ALL {
            assert_eq!(
                shared::text::parse_method(m.name()),
                Ok(crate::wire::request::method_to_wire(m)),
                "{m:?}"
            );
            assert_eq!(
                shared::text::method_name(crate::wire::request::method_to_wire(m) as u32),
                m.name()
            );
        }
    }

    #[test]
    fn the_largest_coordinate_is_the_wire_s() {
        for (l, f32_chain) in [(1.0, false), (1.0, true), (0.013, false), (7.5, true)] {
            assert_eq!(
                sizes::max_coordinate(l, f32_chain),
                shared::max_coordinate(l, f32_chain)
            );
        }
    }
}
