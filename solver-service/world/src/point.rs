//! The world's points ([`Point`]: f64, three coordinates) and their conversion to and from a chain's
//! own vectors (planar or spatial, f64 or f32). A leaf: it imports nothing of the world.

use nalgebra::Vector3;
use tractrix::math::{Embed3, Real, Vector};

/// A point or vector in the world's coordinates (planar chains: `z = 0`).
pub type Point = Vector3<f64>;

/// `q` in a chain's vector type (a planar chain drops `z`).
pub(crate) fn point<T: Real, const D: usize>(q: Point) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    Embed3::from_3d(&Vector3::new(T::lit(q.x), T::lit(q.y), T::lit(q.z)))
}

/// A chain's vector as a world point (a planar one with `z = 0`).
pub(crate) fn to_point<T: Real, const D: usize>(v: &Vector<T, D>) -> Point
where
    Vector<T, D>: Embed3<T>,
{
    let v = v.to_3d();
    Point::new(v.x.to_f64(), v.y.to_f64(), v.z.to_f64())
}
