//! Joint angles from link vectors (remark 3 of section 4.1).
//!
//! The tractrix resolves redundancy in Cartesian space; joint angles are read off afterwards.
//!
//! * Planar (rotary joints): [`planar_joint_angles`] gives the signed relative angle at each joint
//!   (joint 1 relative to the +x axis), [`planar_link_rotations`] the signed rotation of each link between
//!   two instants (eq. 15, with the sign the `cos⁻¹` of the paper drops).
//! * Spatial (spherical joints): [`spatial_joint_rotations`] gives each joint's relative rotation as a
//!   unit quaternion, the shortest arc from the previous link's direction to the next (a line-segment link
//!   has no twist, so the shortest arc is the rotation the joint has to make).

use crate::math::Real;
use nalgebra::{UnitQuaternion, Vector2, Vector3};

/// Signed angle from `a` to `b` in the plane, in `(−π, π]`. `atan2` of cross and dot: accurate at every
/// angle, unlike `acos` of the dot product near 0 and π.
#[inline]
pub fn signed_angle<T: Real>(a: &Vector2<T>, b: &Vector2<T>) -> T {
    let cross = a.x * b.y - a.y * b.x;
    cross.atan2(a.dot(b))
}

/// Relative joint angles of a planar chain: `out[0]` is link 1's angle from +x, `out[i]` the angle from
/// link `i` to link `i+1`. `out.len()` must equal the number of links.
pub fn planar_joint_angles<T: Real>(links: &[Vector2<T>], out: &mut [T]) {
    let mut prev = Vector2::new(T::one(), T::zero());
    for (o, l) in out.iter_mut().zip(links) {
        *o = signed_angle(&prev, l);
        prev = *l;
    }
}

/// Eq. (15) with its sign: the rotation of each link from instant `k` (`before`) to `k+1` (`after`).
pub fn planar_link_rotations<T: Real>(before: &[Vector2<T>], after: &[Vector2<T>], out: &mut [T]) {
    for ((o, a), b) in out.iter_mut().zip(before).zip(after) {
        *o = signed_angle(a, b);
    }
}

/// The change of each relative joint angle between two planar configurations, wrapped to `(−π, π]`:
/// what each actuator of a manipulator turns (the quantity of the paper's figure 8).
pub fn planar_joint_motion<T: Real>(before: &[Vector2<T>], after: &[Vector2<T>], out: &mut [T]) {
    let mut pb = Vector2::new(T::one(), T::zero());
    let mut pa = pb;
    for ((o, b), a) in out.iter_mut().zip(before).zip(after) {
        let d = signed_angle(&pa, a) - signed_angle(&pb, b);
        *o = wrap_angle(d);
        pb = *b;
        pa = *a;
    }
}

/// Wraps an angle to `(−π, π]`.
pub fn wrap_angle<T: Real>(a: T) -> T {
    let two_pi = T::two_pi();
    let mut x = a % two_pi;
    if x > T::pi() {
        x -= two_pi;
    } else if x <= -T::pi() {
        x += two_pi;
    }
    x
}

/// Shortest-arc rotation taking direction `a` to direction `b`; for opposite directions, a half turn about
/// an axis perpendicular to `a`.
pub fn rotation_between<T: Real>(a: &Vector3<T>, b: &Vector3<T>) -> UnitQuaternion<T> {
    UnitQuaternion::rotation_between(a, b).unwrap_or_else(|| {
        let axis = if a.x.abs() < a.norm() * T::lit(0.9) {
            Vector3::x().cross(a)
        } else {
            Vector3::y().cross(a)
        };
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), T::pi())
    })
}

/// Relative rotations of the spherical joints: `out[0]` takes +x to link 1, `out[i]` takes link `i`'s
/// direction to link `i+1`'s.
pub fn spatial_joint_rotations<T: Real>(links: &[Vector3<T>], out: &mut [UnitQuaternion<T>]) {
    let mut prev = Vector3::x();
    for (o, l) in out.iter_mut().zip(links) {
        *o = rotation_between(&prev, l);
        prev = *l;
    }
}
