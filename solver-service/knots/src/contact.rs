//! Where a knot's crossings are: the centre of a rope's contacts, and the way that pulls a joint away
//! from them (the direction a tightening hand draws its end).

use crate::check::segment_distance;
use crate::vec3::{add, norm, scale, sub};

/// The way a tightening pull moves joint `idx`: the unit vector away from the centre of the rope's
/// contacts ([`contact_centre`]), or along the rope's last link outward when nothing touches; `None`
/// when neither has a direction.
pub fn away_from_knot(rope: &[[f64; 3]], idx: usize, thickness: f64) -> Option<[f64; 3]> {
    let at = rope[idx];
    let away = match contact_centre(rope, thickness) {
        Some(c) if norm(sub(at, c)) > 0.0 => sub(at, c),
        _ => {
            // Along the last link outward (from the joint's neighbour to the joint).
            let nb = if idx > 0 { idx - 1 } else { idx + 1 };
            sub(at, rope[nb.min(rope.len() - 1)])
        }
    };
    let n = norm(away);
    (n.is_finite() && n > 0.0).then(|| scale(away, 1.0 / n))
}

/// The centre of the rope's contacts: the mean of the joints of links that come within two
/// thicknesses of a link three or more along the rope (a knot's crossings, drawn tight); `None` when
/// no links do.
pub fn contact_centre(rope: &[[f64; 3]], thickness: f64) -> Option<[f64; 3]> {
    let reach = 2.0 * thickness.max(1e-12);
    let n = rope.len().saturating_sub(1);
    let mut sum = [0.0; 3];
    let mut count = 0usize;
    let p = |i: usize| nalgebra::Vector3::from(rope[i]);
    for (i, joint) in rope.iter().enumerate().take(n) {
        let touches = (0..n).any(|j| {
            i.abs_diff(j) >= 3 && segment_distance(p(i), p(i + 1), p(j), p(j + 1)) < reach
        });
        if touches {
            sum = add(sum, *joint);
            count += 1;
        }
    }
    (count > 0).then(|| scale(sum, 1.0 / count as f64))
}
