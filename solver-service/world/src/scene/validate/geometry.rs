//! A chain's joints and link lengths from its shape.

use super::*;

/// The initial joints and the link lengths.
pub(super) fn geometry(
    f: &Fields<'_>,
    shape: Shape,
) -> Result<(Vec<Vector3<f64>>, Vec<f64>), SceneError> {
    let c = f.c;
    if shape == Shape::Points {
        return given_points(f);
    }
    let links = c
        .links
        .as_ref()
        .ok_or_else(|| f.err(c.name.span(), "links", "missing".into()))?;
    let n = f.count(links, "links", 1, MAX_LINKS as i64)? as usize;
    let lengths = link_lengths(f, links, n)?;
    let base = match &c.base {
        Some(b) => f.vector(b, "base")?,
        None => Vector3::zeros(),
    };
    let axis = match &c.axis {
        Some(a) => f.vector(a, "axis")?,
        None => Vector3::x(),
    };
    let an = axis.norm();
    if an == 0.0 {
        let span = c.axis.as_ref().map(|a| a.span()).unwrap_or(0..0);
        return Err(f.err(span, "axis", "must not be zero".into()));
    }
    let axis = axis * (1.0 / an);
    let p = if shape == Shape::Straight {
        shapes::straight(base, axis, &lengths)
    } else {
        arc(f, base, axis, &lengths)?
    };
    if !p.iter().all(|q| q.iter().all(|x| x.is_finite())) {
        return Err(f.err(
            c.name.span(),
            "link_length",
            "the chain's joints overflow".into(),
        ));
    }
    Ok((p, lengths))
}

/// A chain of `shape = "points"`: its joints as given (nothing else may place them) and the lengths
/// between them.
fn given_points(f: &Fields<'_>) -> Result<(Vec<Vector3<f64>>, Vec<f64>), SceneError> {
    let c = f.c;
    let pts = c.points.as_ref().ok_or_else(|| {
        f.err(
            c.name.span(),
            "points",
            "missing (shape = \"points\" needs it)".into(),
        )
    })?;
    for (field, present) in [
        ("links", c.links.is_some()),
        ("link_length", c.link_length.is_some()),
        ("link_lengths", c.link_lengths.is_some()),
        ("base", c.base.is_some()),
    ] {
        if present {
            return Err(f.err(
                pts.span(),
                field,
                "not allowed with shape = \"points\" (the points define the chain)".into(),
            ));
        }
    }
    let n = pts.get_ref().len();
    if !(2..=MAX_LINKS + 1).contains(&n) {
        return Err(f.err(
            pts.span(),
            "points",
            format!("{n} points; a chain has 2..={} joints", MAX_LINKS + 1),
        ));
    }
    let mut p = Vec::with_capacity(n);
    for (i, q) in pts.get_ref().iter().enumerate() {
        let s = Spanned::new(pts.span(), q.clone());
        p.push(f.vector(&s, &format!("points[{i}]"))?);
    }
    let lengths = shapes::lengths_of(&p).map_err(|i| {
        f.err(
            pts.span(),
            "points",
            format!("points {i} and {} coincide or are too far apart", i + 1),
        )
    })?;
    Ok((p, lengths))
}

/// The `n` links' lengths: one `link_length` for all or a `link_lengths` list, not both.
fn link_lengths(f: &Fields<'_>, links: &Spanned<i64>, n: usize) -> Result<Vec<f64>, SceneError> {
    let c = f.c;
    Ok(match (&c.link_length, &c.link_lengths) {
        (Some(_), Some(l)) => {
            return Err(f.err(
                l.span(),
                "link_lengths",
                "give `link_length` or `link_lengths`, not both".into(),
            ));
        }
        (Some(l), None) => vec![f.positive(l, "link_length")?; n],
        (None, Some(l)) => {
            if l.get_ref().len() != n {
                return Err(f.err(
                    l.span(),
                    "link_lengths",
                    format!("{} lengths for {n} links", l.get_ref().len()),
                ));
            }
            let mut v = Vec::with_capacity(n);
            for (i, &x) in l.get_ref().iter().enumerate() {
                v.push(f.positive(&Spanned::new(l.span(), x), &format!("link_lengths[{i}]"))?);
            }
            v
        }
        (None, None) => {
            return Err(f.err(
                links.span(),
                "link_length",
                "missing (or `link_lengths`)".into(),
            ));
        }
    })
}

/// The joints of a chain of `shape = "arc"`: from `base` along `axis` (unit), bent toward `bend` on a
/// circle of `radius`, at least half the longest link.
fn arc(
    f: &Fields<'_>,
    base: Vector3<f64>,
    axis: Vector3<f64>,
    lengths: &[f64],
) -> Result<Vec<Vector3<f64>>, SceneError> {
    let c = f.c;
    let r = c.radius.as_ref().ok_or_else(|| {
        f.err(
            c.name.span(),
            "radius",
            "missing (shape = \"arc\" needs it)".into(),
        )
    })?;
    let radius = f.positive(r, "radius")?;
    let longest = lengths.iter().copied().fold(0.0, f64::max);
    if radius * 2.0 < longest {
        return Err(f.err(
            r.span(),
            "radius",
            format!("{radius} is less than half the longest link ({longest})"),
        ));
    }
    let bend = match &c.bend {
        Some(b) => f.vector(b, "bend")?,
        None => Vector3::y(),
    };
    // The bend direction, made perpendicular to the axis.
    let b = bend - axis * bend.dot(&axis);
    let bn = b.norm();
    if bn < 1e-12 * bend.norm().max(1.0) {
        let span = c.bend.as_ref().map(|b| b.span()).unwrap_or(c.name.span());
        return Err(f.err(span, "bend", "must not be parallel to `axis`".into()));
    }
    Ok(shapes::arc(base, axis, b * (1.0 / bn), radius, lengths))
}
