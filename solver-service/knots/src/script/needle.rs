//! The needle's arc: its circle from the instruments' capsules, and the poses that drive it round.

use super::*;

/// The needle among `instruments` (its capsules end to end from `swage`): the arc's points from the
/// swage, the circle's centre (the circumcentre of the swage, the first capsule's far end and the
/// point) and the normal of its plane (not unit).
pub(super) fn needle_circle(
    swage: [f64; 3],
    instruments: &[InstrumentEnds],
) -> Result<Circle, String> {
    use nalgebra::Vector3;
    let v = |p: [f64; 3]| Vector3::new(p[0], p[1], p[2]);
    let near = |p: Vector3<f64>, q: Vector3<f64>| (p - q).norm() <= 1e-9 * (1.0 + p.norm());
    // The needle: the capsules end to end from the swage.
    let mut arc = vec![v(swage)];
    while let Some((_, b)) = instruments
        .iter()
        .find(|(a, _)| near(v(*a), *arc.last().unwrap()))
    {
        arc.push(v(*b));
        if arc.len() > instruments.len() + 1 {
            break;
        }
    }
    if arc.len() < 3 {
        return Err("no needle of two capsules or more starts at the swage".into());
    }
    let (p0, p1, p2) = (arc[0], arc[1], arc[arc.len() - 1]);
    let (a, b) = (p1 - p0, p2 - p0);
    let n = a.cross(&b);
    if n.norm() <= 1e-12 || !n.norm().is_finite() {
        return Err("the needle is straight".into());
    }
    let centre = p0
        + (b.cross(&n) * a.norm_squared() + n.cross(&a) * b.norm_squared())
            / (2.0 * n.norm_squared());
    Ok((arc, centre, n))
}

/// The moves of a [`Drive`]: the swage at `swage` moved round the circle of the needle among
/// `instruments` (the capsules end to end from the swage) by `angle_deg`, in steps of at most
/// `max_step` along the circle, each with the needle's rotation vector there (its frame now turned
/// about the circle's axis as far as the swage: the pose a trembling hand's drive sends, `FLAG_POSE`;
/// a steady one sends the points alone with `FLAG_DRIVE`).
pub fn needle_arc(
    swage: [f64; 3],
    instruments: &[InstrumentEnds],
    angle_deg: f64,
    max_step: f64,
) -> Result<Vec<PoseMove>, String> {
    use nalgebra::{Unit, UnitQuaternion};
    let (arc, centre, n) = needle_circle(swage, instruments)?;
    if !(max_step > 0.0 && angle_deg.is_finite()) {
        return Err("the step or the angle is not usable".into());
    }
    let p0 = arc[0];
    let now = needle_frame(&arc, centre)?;
    let r = (p0 - centre).norm();
    let angle = angle_deg.to_radians();
    let steps = ((angle.abs() * r / max_step).ceil() as usize).clamp(1, 1 << 20);
    let axis = Unit::new_normalize(n);
    Ok((1..=steps)
        .map(|k| {
            let turn = UnitQuaternion::from_axis_angle(&axis, angle * k as f64 / steps as f64);
            let p = centre + turn * (p0 - centre);
            let q = (turn * now).scaled_axis();
            ([p.x, p.y, p.z], [q.x, q.y, q.z])
        })
        .collect())
}

/// The needle's frame from its arc's points and its circle's centre: x its tangent at the swage (the
/// first capsule's chord made perpendicular to the bend: the chord is turned half a capsule's angle
/// from the tangent), y its bend toward the centre.
pub(super) fn needle_frame(
    arc: &[nalgebra::Vector3<f64>],
    centre: nalgebra::Vector3<f64>,
) -> Result<nalgebra::UnitQuaternion<f64>, String> {
    let bend = centre - arc[0];
    let chord = arc[1] - arc[0];
    frame(
        chord - bend * (chord.dot(&bend) / bend.norm_squared()),
        bend,
    )
}

/// The rotation whose x is along `t` and whose y along `b` made perpendicular to it.
pub(super) fn frame(
    t: nalgebra::Vector3<f64>,
    b: nalgebra::Vector3<f64>,
) -> Result<nalgebra::UnitQuaternion<f64>, String> {
    let t = t.try_normalize(1e-12).ok_or("a zero tangent")?;
    let b = (b - t * b.dot(&t))
        .try_normalize(1e-12)
        .ok_or("a bend along the tangent")?;
    let m = nalgebra::Rotation3::from_basis_unchecked(&[t, b, t.cross(&b)]);
    Ok(nalgebra::UnitQuaternion::from_rotation_matrix(&m))
}

/// One move of a [`Pose`] turn: where the swage goes, and the needle's rotation vector.
pub type PoseMove = ([f64; 3], [f64; 3]);

/// The moves of a [`Pose`] turn: the needle among `instruments` (its capsules end to end from
/// `swage`) turned from its pose now to `pose` while its swage goes along the first `turning` points
/// of `path` (the turn's targets; empty: it stays), in equal steps, as many as those points and
/// enough that the needle's point moves at most `max_step` in each by the turn; then posed so along
/// the rest of the path. Each move: where the swage goes and the needle's rotation vector from its
/// own frame (it leaves the swage along x, curving toward y), as `FLAG_POSE` sends them.
pub fn needle_poses(
    swage: [f64; 3],
    instruments: &[InstrumentEnds],
    path: &[[f64; 3]],
    turning: usize,
    pose: &Pose,
    max_step: f64,
) -> Result<Vec<PoseMove>, String> {
    use nalgebra::Vector3;
    let (arc, centre, _) = needle_circle(swage, instruments)?;
    let v = |p: [f64; 3]| Vector3::new(p[0], p[1], p[2]);
    if max_step.is_nan()
        || max_step <= 0.0
        || !pose.tangent.iter().chain(&pose.bend).all(|c| c.is_finite())
    {
        return Err("the step or the pose is not usable".into());
    }
    let r = (arc[0] - centre).norm();
    let now = needle_frame(&arc, centre)?;
    let goal = frame(v(pose.tangent), v(pose.bend)).map_err(|e| format!("the pose: {e}"))?;
    // The point is at most twice the radius from the swage: a turn by θ moves it at most 2rθ.
    let (path, rest) = path.split_at(turning.min(path.len()));
    let turn = now.angle_to(&goal);
    let steps = ((2.0 * r * turn / max_step).ceil() as usize)
        .max(path.len())
        .clamp(1, 1 << 20);
    // The swage's place at fraction f of the path (its points equally spaced in f from the start).
    let pts: Vec<Vector3<f64>> = std::iter::once(arc[0])
        .chain(path.iter().map(|p| v(*p)))
        .collect();
    let along = |f: f64| {
        let x = f * (pts.len() - 1) as f64;
        let i = (x.floor() as usize).min(pts.len() - 1);
        let j = (i + 1).min(pts.len() - 1);
        pts[i] + (pts[j] - pts[i]) * (x - i as f64)
    };
    let posed = goal.scaled_axis();
    Ok((1..=steps)
        .map(|k| {
            let f = k as f64 / steps as f64;
            let p = along(f);
            let q = now.slerp(&goal, f).scaled_axis();
            ([p.x, p.y, p.z], [q.x, q.y, q.z])
        })
        .chain(rest.iter().map(|p| (*p, [posed.x, posed.y, posed.z])))
        .collect())
}
