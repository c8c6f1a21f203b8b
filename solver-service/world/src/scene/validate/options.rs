//! A chain's solver options (substeps, iterations) and joint limits.

use super::*;

/// The chain's `max_substeps`, and its `substeps` or `max_step` (not both).
pub(super) fn substeps(f: &Fields<'_>) -> Result<(u32, Substeps<f64>), SceneError> {
    let c = f.c;
    let max_substeps = f.count_or(
        &c.max_substeps,
        "max_substeps",
        1,
        MAX_SUBSTEPS_LIMIT as i64,
        1 << 16,
    )?;
    let substeps = match (&c.substeps, &c.max_step) {
        (Some(_), Some(m)) => {
            return Err(f.err(
                m.span(),
                "max_step",
                "give `substeps` or `max_step`, not both".into(),
            ));
        }
        (Some(k), None) => Substeps::Fixed(f.count(k, "substeps", 1, max_substeps as i64)?),
        (None, Some(m)) => Substeps::MaxStep(f.positive(m, "max_step")?),
        (None, None) => Substeps::Fixed(1),
    };
    Ok((max_substeps, substeps))
}

/// The chain's `tolerance`, `max_iterations` and `hierarchy_after` (fixed-base solves and held sides).
pub(super) fn iteration(f: &Fields<'_>) -> Result<(f64, u32, u32), SceneError> {
    let c = f.c;
    let tolerance = match &c.tolerance {
        Some(t) => {
            let v = f.positive(t, "tolerance")?;
            if v > 0.1 {
                return Err(f.err(t.span(), "tolerance", format!("{v} is above 0.1")));
            }
            v
        }
        None => 1e-9,
    };
    let max_iterations = f.count_or(&c.max_iterations, "max_iterations", 1, 100_000, 1000)?;
    let hierarchy_after = f.count_or(
        &c.hierarchy_after,
        "hierarchy_after",
        0,
        100_000,
        ReachOptions::<f64>::default().hierarchy_after,
    )?;
    Ok((tolerance, max_iterations, hierarchy_after))
}

/// The default `max_iterations` of a chain with joint limits.
pub(super) const LIMITED_MAX_ITERATIONS: u32 = 64;

/// The chain's one limit field and its span, if it gives one; two are refused.
fn limit_field(f: &Fields<'_>) -> Result<Option<(&'static str, Range<usize>)>, SceneError> {
    let c = f.c;
    let given: Vec<(&'static str, Range<usize>)> = [
        (
            "min_bend_radius",
            c.min_bend_radius.as_ref().map(|v| v.span()),
        ),
        ("max_bend", c.max_bend.as_ref().map(|v| v.span())),
        ("max_bends", c.max_bends.as_ref().map(|v| v.span())),
        ("joint_range", c.joint_range.as_ref().map(|v| v.span())),
        ("joint_ranges", c.joint_ranges.as_ref().map(|v| v.span())),
    ]
    .into_iter()
    .filter_map(|(n, s)| Some((n, s?)))
    .collect();
    if given.len() > 1 {
        return Err(f.err(
            given[1].1.clone(),
            given[1].0,
            format!(
                "give one limit field, not `{}` and `{}`",
                given[0].0, given[1].0
            ),
        ));
    }
    Ok(given.first().cloned())
}

/// The chain's joint limits (at most one of the limit fields), in radians; the initial pose must lie
/// within them.
pub(super) fn limits(
    f: &Fields<'_>,
    points: &[Vector3<f64>],
    lengths: &[f64],
) -> Result<Option<LimitSpec>, SceneError> {
    let c = f.c;
    let Some((field, span)) = limit_field(f)? else {
        return Ok(None);
    };
    let joints = lengths.len() + 1;
    let pi = std::f64::consts::PI;
    let degrees = |v: f64, lo: f64, what: &str| -> Result<f64, SceneError> {
        if v.is_finite() && (lo..=180.0).contains(&v) {
            Ok(v.to_radians())
        } else {
            Err(f.err(span.clone(), field, format!("{v} is not {what}")))
        }
    };
    let pair = |p: &[f64]| -> Result<(f64, f64), SceneError> {
        match p {
            [a, b] if a <= b => Ok((
                degrees(*a, -180.0, "an angle in [-180, 180] degrees")?,
                degrees(*b, -180.0, "an angle in [-180, 180] degrees")?,
            )),
            _ => Err(f.err(
                span.clone(),
                field,
                format!("{p:?} is not a range [lo, hi] with lo ≤ hi (degrees)"),
            )),
        }
    };
    let count = |n: usize| -> Result<(), SceneError> {
        if n == joints {
            Ok(())
        } else {
            Err(f.err(
                span.clone(),
                field,
                format!("{n} entries for {joints} joints (one per joint, the ends' ignored)"),
            ))
        }
    };
    let ends = |mut lo: Vec<f64>, mut hi: Vec<f64>| {
        for j in [0, joints - 1] {
            lo[j] = -pi;
            hi[j] = pi;
        }
        (lo, hi)
    };
    let cones = |hi: Vec<f64>| ends(hi.iter().map(|a| -a).collect(), hi);
    let (kind, (lo, hi), r) = match field {
        "min_bend_radius" => {
            let r = f.positive(c.min_bend_radius.as_ref().expect("given"), field)?;
            let hi = (0..joints)
                .map(|j| {
                    if j == 0 || j + 1 == joints {
                        pi
                    } else {
                        2.0 * (lengths[j - 1].min(lengths[j]) / (2.0 * r)).atan()
                    }
                })
                .collect();
            (LimitKind::Cone, cones(hi), Some(r))
        }
        "max_bend" => {
            let a = degrees(
                *c.max_bend.as_ref().expect("given").get_ref(),
                0.0,
                "an angle in [0, 180] degrees",
            )?;
            (LimitKind::Cone, cones(vec![a; joints]), None)
        }
        "max_bends" => {
            let v = c.max_bends.as_ref().expect("given").get_ref();
            count(v.len())?;
            let hi = v
                .iter()
                .map(|&a| degrees(a, 0.0, "an angle in [0, 180] degrees"))
                .collect::<Result<Vec<_>, _>>()?;
            (LimitKind::Cone, cones(hi), None)
        }
        "joint_range" | "joint_ranges" => {
            if f.dims != 2 {
                return Err(f.err(
                    span.clone(),
                    field,
                    "signed ranges are for planar chains (a spatial chain takes `max_bend`)".into(),
                ));
            }
            let pairs = match (&c.joint_range, &c.joint_ranges) {
                (Some(p), _) => vec![pair(p.get_ref())?; joints],
                (_, Some(v)) => {
                    count(v.get_ref().len())?;
                    v.get_ref()
                        .iter()
                        .map(|p| pair(p))
                        .collect::<Result<Vec<_>, _>>()?
                }
                _ => unreachable!("one of them was given"),
            };
            let (lo, hi) = pairs.into_iter().unzip();
            (LimitKind::Range, ends(lo, hi), None)
        }
        _ => unreachable!("the fields listed above"),
    };
    pose_within(f, (field, span), kind, (&lo, &hi), points)?;
    Ok(Some(LimitSpec {
        kind,
        lo,
        hi,
        min_bend_radius: r,
    }))
}

/// The initial pose within the limits `[lo, hi]` of `kind`, the angle computed as the kernel's check
/// does; an error names the limit's `field` at its `span`.
pub(super) fn pose_within(
    f: &Fields<'_>,
    (field, span): (&str, Range<usize>),
    kind: LimitKind,
    (lo, hi): (&[f64], &[f64]),
    points: &[Vector3<f64>],
) -> Result<(), SceneError> {
    let joints = points.len();
    for j in 1..joints - 1 {
        let (a, b) = (points[j] - points[j - 1], points[j + 1] - points[j]);
        let angle = match kind {
            LimitKind::Cone => a.cross(&b).norm().atan2(a.dot(&b)),
            LimitKind::Range => a.cross(&b).z.atan2(a.dot(&b)),
        };
        if angle > hi[j] + 1e-9 || angle < lo[j] - 1e-9 {
            return Err(f.err(
                span.clone(),
                field,
                format!(
                    "the initial pose turns {:.3}° at joint {j}, outside its limit [{:.3}°, {:.3}°]",
                    angle.to_degrees(),
                    lo[j].to_degrees(),
                    hi[j].to_degrees()
                ),
            ));
        }
    }
    Ok(())
}
