//! A curved needle swaged to a suture's head (scene `needle = [radius, angle, thickness]`): a rigid
//! circular arc, carried as capsules (the chain's last instruments, so the wire, the viewers and the
//! MuJoCo loop draw it as they draw any instrument). It leaves the head along the head link's
//! direction and curves, initially, up (toward +z; toward +x when the head link is vertical): taken
//! down into tissue, turned under it and up again, the head link turns the needle with it so that it
//! curves the way the stitch turns, its point ahead. Every
//! move carries it rigidly with the head: translated with the head joint and turned by the smallest
//! rotation that takes the head link's old direction to its new one (the suture has no twist), so it
//! stays tangent to the rope at the swage; carried, it pushes the rest of the rope as instruments do.

use crate::command::Point;
use nalgebra::{Rotation3, Unit};
use tractrix::collision::Obstacle;

/// A chain's needle: the arc's radius, its angle (radians), its thickness (diameter), and where its
/// capsules are among the chain's instruments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Needle {
    /// The arc's radius.
    pub radius: f64,
    /// The angle the arc spans, radians (0, 3π/2].
    pub angle: f64,
    /// The needle's diameter.
    pub thickness: f64,
    /// The index of its first capsule among the chain's instruments.
    pub first: usize,
    /// How many capsules: one per 22.5° of arc or part of it.
    pub segments: usize,
    /// The way it first curves from the head link, as the scene gives it (`needle_bend`; up when
    /// `None`, [`Needle::initial_bend`]).
    pub bend: Option<Point>,
}

/// The most a needle's arc may span: three quarters of a circle.
pub const MAX_NEEDLE_ANGLE: f64 = 1.5 * std::f64::consts::PI;

impl Needle {
    /// A needle of `radius`, `angle` (radians) and `thickness`, its capsules from instrument `first`.
    pub fn new(radius: f64, angle: f64, thickness: f64, first: usize) -> Self {
        let segments = (angle / (std::f64::consts::PI / 8.0)).ceil().max(1.0) as usize;
        Needle {
            radius,
            angle,
            thickness,
            first,
            segments,
            bend: None,
        }
    }

    /// The capsules of the needle swaged at `swage`, leaving it along the unit `tangent` and curving
    /// toward the unit `bend` (perpendicular to it): the arc `c + r(−bend cos φ + tangent sin φ)`,
    /// `c = swage + r bend`, for φ from 0 to the angle, cut into [`Needle::segments`] equal pieces.
    pub fn capsules(&self, swage: Point, tangent: Point, bend: Point) -> Vec<Obstacle<f64, 3>> {
        let c = swage + bend * self.radius;
        let at = |k: usize| {
            let phi = self.angle * k as f64 / self.segments as f64;
            c + (tangent * phi.sin() - bend * phi.cos()) * self.radius
        };
        (0..self.segments)
            .map(|k| Obstacle::Capsule {
                a: at(k),
                b: at(k + 1),
                radius: 0.5 * self.thickness,
            })
            .collect()
    }

    /// The direction this needle first curves toward from a head link along `tangent`: the scene's
    /// `needle_bend` made perpendicular to it, else [`Needle::initial_bend`].
    pub fn first_bend(&self, tangent: Point) -> Point {
        match self.bend {
            Some(b) => (b - tangent * b.dot(&tangent)).normalize(),
            None => Needle::initial_bend(tangent),
        }
    }

    /// The direction a needle first curves toward from a head link along `tangent`: up (+z) made
    /// perpendicular to it, or +x when the link is vertical.
    pub fn initial_bend(tangent: Point) -> Point {
        let up = Point::z();
        let b = up - tangent * up.dot(&tangent);
        if b.norm() > 1e-6 {
            b.normalize()
        } else {
            let x = Point::x();
            (x - tangent * x.dot(&tangent)).normalize()
        }
    }
}

/// The rigid motion that carries a needle from the head frame `(head, tangent)` before a move to the
/// one after it: the smallest rotation from the old tangent to the new one, about the head, then the
/// head's displacement. Returns the capsule `o` so moved (anything else unchanged).
pub fn carry(
    o: &Obstacle<f64, 3>,
    before: (Point, Point),
    after: (Point, Point),
) -> Obstacle<f64, 3> {
    moved(o, before.0, &turn(before.1, after.1), after.0)
}

/// The needle's unit tangent at its swage, from its capsules (`capsules`, its own, in order): the
/// first capsule's chord turned back by half the angle each capsule spans, in the plane of the first
/// two chords (one capsule: its chord).
pub fn tangent(needle: &Needle, capsules: &[Obstacle<f64, 3>]) -> Option<Point> {
    let chord = |o: &Obstacle<f64, 3>| match o {
        Obstacle::Capsule { a, b, .. } => Some((b - a).normalize()),
        _ => None,
    };
    let u0 = chord(capsules.first()?)?;
    let Some(u1) = capsules.get(1).and_then(chord) else {
        return Some(u0);
    };
    let n = u0.cross(&u1);
    if n.norm() < 1e-12 {
        return Some(u0);
    }
    let half = 0.5 * needle.angle / needle.segments as f64;
    Some(Rotation3::from_axis_angle(&Unit::new_normalize(n), -half) * u0)
}

/// A driven needle's rigid motion ([`shared`'s `FLAG_DRIVE`]): from its swage at `swage` with unit
/// tangent `tangent`, along the circular arc that leaves the swage along the tangent and ends at `to`
/// (a straight line when `to` lies on the tangent's line). Returns the rotation of that arc (twice the
/// smallest rotation from the tangent to the chord, so a target on the needle's own circle turns it
/// about its centre); the needle moves by `p ↦ to + R (p − swage)` ([`moved`]).
pub fn drive(swage: Point, tangent: Point, to: Point) -> Rotation3<f64> {
    let way = to - swage;
    if way.norm() <= f64::EPSILON * (1.0 + swage.norm()) {
        return Rotation3::identity();
    }
    let half = turn(tangent, way.normalize());
    half * half
}

/// The capsules of `needle` posed ([`shared`'s `FLAG_POSE`]): swaged at `swage` and turned by the
/// rotation vector `rotation` (axis × angle, radians) from its own frame, in which it leaves the swage
/// along +x and curves toward +y, to the world's.
pub fn posed(needle: &Needle, swage: Point, rotation: Point) -> Vec<Obstacle<f64, 3>> {
    let r = Rotation3::new(rotation);
    needle.capsules(swage, r * Point::x(), r * Point::y())
}

/// Capsule `o` moved by the rigid motion `p ↦ to + rotation (p − from)`.
pub fn moved(
    o: &Obstacle<f64, 3>,
    from: Point,
    rotation: &Rotation3<f64>,
    to: Point,
) -> Obstacle<f64, 3> {
    let map = |p: &Point| to + rotation * (p - from);
    match o {
        Obstacle::Capsule { a, b, radius } => Obstacle::Capsule {
            a: map(a),
            b: map(b),
            radius: *radius,
        },
        other => *other,
    }
}

/// The smallest rotation taking unit `from` to unit `to` (a half turn about a perpendicular axis when
/// they are opposite). Its angle from `atan2(|from × to|, from · to)`: nalgebra's `rotation_between`
/// takes the arccosine of the dot product, which rounding can put above 1 (a NaN needle was seen).
fn turn(from: Point, to: Point) -> Rotation3<f64> {
    let cross = from.cross(&to);
    let (sin, cos) = (cross.norm(), from.dot(&to));
    if sin > 1e-300 {
        Rotation3::from_axis_angle(&Unit::new_unchecked(cross / sin), sin.atan2(cos))
    } else if cos >= 0.0 {
        Rotation3::identity()
    } else {
        let axis = Needle::initial_bend(from);
        Rotation3::from_axis_angle(&Unit::new_normalize(axis), std::f64::consts::PI)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Head links turned by angles from 1e-17 to 1e-6 rad about random axes: the turn is finite, a
    /// rotation (orthonormal to 1e-12), and takes the old direction to the new one to 1e-12.
    #[test]
    fn tiny_turns_are_finite_rotations() {
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        let mut r = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for k in 0..100_000 {
            let from = Point::new(r(), r(), r()).normalize();
            let axis = from.cross(&Point::new(r(), r(), r())).normalize();
            let angle = 10f64.powf(-17.0 + 11.0 * (k as f64 / 100_000.0));
            let to =
                (Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle) * from).normalize();
            let t = turn(from, to);
            let m = t.matrix();
            assert!(m.iter().all(|v| v.is_finite()), "{from:?} {to:?}: {m:?}");
            assert!((m.transpose() * m - nalgebra::Matrix3::identity()).norm() < 1e-12);
            assert!((t * from - to).norm() < 1e-12, "{from:?} -> {to:?}");
        }
    }
}
