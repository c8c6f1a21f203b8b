//! Between the world and the wire: the world's enums as the wire numbers them, and the bounds the
//! wire states to clients checked against the ones the world enforces.

use shared::{COLLISION_OBSTACLES, COLLISION_PAPER_SPHERES, COLLISION_SELF};
use tractrix::collision::Scheme;
use world::scene::{ChainKind, ChainSpec, Precision};
use world::sizes;

// The bounds the wire states (`shared`) are the ones the world enforces.
const _: () = {
    assert!(sizes::MAX_CHAINS == shared::MAX_CHAINS as usize);
    assert!(sizes::MAX_LINKS == shared::MAX_LINKS as usize);
    assert!(sizes::MAX_NAME_BYTES == shared::NAME_LEN - 1);
    assert!(sizes::MAX_HELD == shared::MAX_HELD as usize);
    assert!(sizes::MAX_BUNDLE_JOINTS == shared::MAX_BUNDLE_JOINTS as usize);
    assert!(sizes::MAX_BUNDLE_STRANDS == shared::MAX_BUNDLE_STRANDS as usize);
};

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
    fn the_largest_coordinate_is_the_wire_s() {
        for (l, f32_chain) in [(1.0, false), (1.0, true), (0.013, false), (7.5, true)] {
            assert_eq!(
                sizes::max_coordinate(l, f32_chain),
                shared::max_coordinate(l, f32_chain)
            );
        }
    }
}
