//! A chain's collision model: its obstacles, instruments and options.

use super::*;

/// The solver's own passes and pushed joints' weight for a rope of `links` links, the shortest
/// `shortest` long, `thickness` thick, where the scene does not set them (`collision_iterations`,
/// `collision_pushed_weight`, for benchmarks): on links shorter than five thicknesses one contact
/// between two strands is many nearly dependent rows and the passes creep, so a resolution may take
/// 3.2 passes per link (at least 64, the limit on longer links); on links shorter than two
/// thicknesses the pushed joints weigh twice the others when a held rope is relaxed (0.5; 1
/// otherwise), which took fewer passes there (BENCHMARKS.md, contact, the held-ropes table). A rope
/// at 40, 80, 160 or 320 links differs only in `links` and `link_length`.
pub(crate) fn resolution_defaults(links: usize, shortest: f64, thickness: f64) -> (u32, f64) {
    let passes = if shortest < 5.0 * thickness {
        (3.2 * links as f64).round().clamp(64.0, 10_000.0) as u32
    } else {
        64
    };
    let pushed = if shortest < 2.0 * thickness { 0.5 } else { 1.0 };
    (passes, pushed)
}

/// Collision handling, if the chain declares a scheme; stray collision knobs without one are refused.
pub(super) fn collision(
    f: &Fields<'_>,
    scheme: Option<Scheme>,
    kind: ChainKind,
    (links, shortest, thickness): (usize, f64, f64),
    obstacles: &[(String, Obstacle<f64, 3>)],
    instruments: &[(String, Obstacle<f64, 3>)],
) -> Result<Option<CollisionSpec>, SceneError> {
    let c = f.c;
    let Some(scheme) = scheme else {
        no_stray_knobs(f)?;
        return Ok(None);
    };
    let span = c.collision.as_ref().map(|s| s.span()).unwrap_or(0..0);
    if kind == ChainKind::FixedBase {
        return Err(f.err(
            span,
            "collision",
            "collision is handled for free chains; a fixed-base reach does not check it".into(),
        ));
    }
    if scheme == Scheme::Capsules && thickness <= 0.0 {
        return Err(f.err(
            span,
            "thickness",
            "capsule collision needs a positive `thickness` (the rope's diameter)".into(),
        ));
    }
    let (passes, pushed) = resolution_defaults(links, shortest, thickness);
    let max_iterations = f.count_or(
        &c.collision_iterations,
        "collision_iterations",
        1,
        10_000,
        passes,
    )?;
    let tolerance = f.real_or(
        &c.collision_tolerance,
        "collision_tolerance",
        |t| t > 0.0 && t < 1.0,
        "is not strictly between 0 and 1",
        0.01,
    )?;
    let over_relaxation = f.real_or(
        &c.collision_over_relaxation,
        "collision_over_relaxation",
        |t| (1.0..2.0).contains(&t),
        "is not in [1, 2)",
        CollisionOptions::<f64>::default().over_relaxation,
    )?;
    let pushed_weight = f.real_or(
        &c.collision_pushed_weight,
        "collision_pushed_weight",
        |t| t > 0.0 && t <= 1.0,
        "is not in (0, 1]",
        pushed,
    )?;
    let together_after = f.count_or(
        &c.collision_together_after,
        "collision_together_after",
        0,
        i64::from(tractrix::collision::MAX_TOGETHER_AFTER),
        CollisionOptions::<f64>::default().together_after,
    )?;
    let list = named_obstacles(f, obstacles)?;
    let mine = named_instruments(f, instruments)?;
    Ok(Some(CollisionSpec {
        options: CollisionOptions {
            scheme,
            self_collision: c.self_collision.as_ref().is_none_or(|s| *s.get_ref()),
            thickness,
            max_iterations,
            tolerance,
            over_relaxation,
            pushed_weight,
            together_after,
        },
        obstacles: list,
        instruments: mine,
        follows: Vec::new(),
    }))
}

/// Whether a planar chain (z = 0) can use the obstacle: its geometry lies in the plane.
pub(super) fn in_plane(o: &Obstacle<f64, 3>) -> bool {
    match o {
        Obstacle::Sphere { center, .. } => center.z == 0.0,
        Obstacle::Capsule { a, b, .. } => a.z == 0.0 && b.z == 0.0,
        Obstacle::HalfSpace { point, normal } => point.z == 0.0 && normal.z == 0.0,
        // Never a scene's obstacle (a chain's tissue is spatial).
        Obstacle::Block { .. } => false,
    }
}

/// Collision knobs without a scheme would silently do nothing: refused.
fn no_stray_knobs(f: &Fields<'_>) -> Result<(), SceneError> {
    let c = f.c;
    let stray = [
        c.self_collision
            .as_ref()
            .map(|s| ("self_collision", s.span())),
        c.obstacles.as_ref().map(|s| ("obstacles", s.span())),
        c.instruments.as_ref().map(|s| ("instruments", s.span())),
        c.collision_iterations
            .as_ref()
            .map(|s| ("collision_iterations", s.span())),
        c.collision_tolerance
            .as_ref()
            .map(|s| ("collision_tolerance", s.span())),
        c.collision_over_relaxation
            .as_ref()
            .map(|s| ("collision_over_relaxation", s.span())),
        c.collision_pushed_weight
            .as_ref()
            .map(|s| ("collision_pushed_weight", s.span())),
        c.collision_together_after
            .as_ref()
            .map(|s| ("collision_together_after", s.span())),
    ];
    if let Some((field, span)) = stray.into_iter().flatten().next() {
        return Err(f.err(
            span,
            field,
            "needs `collision = \"capsules\"` or `\"paper-spheres\"`".into(),
        ));
    }
    Ok(())
}

/// The chain's obstacles, by name among the scene's; a planar chain's must lie in its plane.
fn named_obstacles(
    f: &Fields<'_>,
    obstacles: &[(String, Obstacle<f64, 3>)],
) -> Result<Vec<Obstacle<f64, 3>>, SceneError> {
    let c = f.c;
    let mut list = Vec::new();
    if let Some(names) = &c.obstacles {
        for n in names.get_ref() {
            let Some((_, o)) = obstacles.iter().find(|(m, _)| m == n) else {
                return Err(f.err(
                    names.span(),
                    "obstacles",
                    format!("no [[obstacle]] is named {n:?}"),
                ));
            };
            if f.dims == 2 && !in_plane(o) {
                return Err(f.err(
                    names.span(),
                    "obstacles",
                    format!("obstacle {n:?} is not in the planar chain's plane z = 0"),
                ));
            }
            list.push(*o);
        }
    }
    Ok(list)
}

/// The chain's instruments, by name among the scene's, each once; a planar chain's must lie in its
/// plane.
fn named_instruments(
    f: &Fields<'_>,
    instruments: &[(String, Obstacle<f64, 3>)],
) -> Result<Vec<(String, Obstacle<f64, 3>)>, SceneError> {
    let c = f.c;
    let mut mine: Vec<(String, Obstacle<f64, 3>)> = Vec::new();
    if let Some(names) = &c.instruments {
        for n in names.get_ref() {
            let Some((_, o)) = instruments.iter().find(|(m, _)| m == n) else {
                return Err(f.err(
                    names.span(),
                    "instruments",
                    format!("no [[instrument]] is named {n:?}"),
                ));
            };
            if mine.iter().any(|(m, _)| m == n) {
                return Err(f.err(
                    names.span(),
                    "instruments",
                    format!("instrument {n:?} is listed twice"),
                ));
            }
            if f.dims == 2 && !in_plane(o) {
                return Err(f.err(
                    names.span(),
                    "instruments",
                    format!("instrument {n:?} is not in the planar chain's plane z = 0"),
                ));
            }
            mine.push((n.clone(), *o));
        }
    }
    Ok(mine)
}
