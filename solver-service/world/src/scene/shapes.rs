//! Initial shapes of a chain: joints along a straight line or on an arc, each link a chord of its own
//! length.

use nalgebra::Vector3;

/// Joints from `base` along the unit `axis`.
pub(super) fn straight(
    base: Vector3<f64>,
    axis: Vector3<f64>,
    lengths: &[f64],
) -> Vec<Vector3<f64>> {
    let mut p = Vec::with_capacity(lengths.len() + 1);
    p.push(base);
    let mut along = 0.0;
    for l in lengths {
        along += l;
        p.push(base + axis * along);
    }
    p
}

/// Joints on a circle of radius `r` through `base`, tangent to the unit `axis` there, bending toward the
/// unit `bend` (perpendicular to `axis`); each link is a chord of its own length.
pub(super) fn arc(
    base: Vector3<f64>,
    axis: Vector3<f64>,
    bend: Vector3<f64>,
    r: f64,
    lengths: &[f64],
) -> Vec<Vector3<f64>> {
    let centre = base + bend * r;
    let mut p = Vec::with_capacity(lengths.len() + 1);
    p.push(base);
    let mut phi = 0.0f64;
    for l in lengths {
        phi += 2.0 * (l / (2.0 * r)).min(1.0).asin();
        // The point at angle phi from the start, measured around the centre.
        p.push(centre + (bend * (-r * phi.cos()) + axis * (r * phi.sin())));
    }
    p
}

/// Link lengths between consecutive points; `Err(i)` if points `i` and `i + 1` coincide or the distance
/// overflows.
pub(super) fn lengths_of(points: &[Vector3<f64>]) -> Result<Vec<f64>, usize> {
    points
        .windows(2)
        .enumerate()
        .map(|(i, w)| {
            let len = (w[1] - w[0]).norm();
            if len.is_finite() && len > 0.0 {
                Ok(len)
            } else {
                Err(i)
            }
        })
        .collect()
}
