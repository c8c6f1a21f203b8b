//! A chain's holds, eyelets, tissue, needle and wound.

use super::*;

/// The chain's `anchors`: distinct joints of a free chain, at most [`MAX_HELD`], sorted.
pub(super) fn anchors(
    f: &Fields<'_>,
    kind: ChainKind,
    n_links: usize,
) -> Result<Vec<u32>, SceneError> {
    Ok(match &f.c.anchors {
        None => Vec::new(),
        Some(a) => {
            if kind != ChainKind::Free {
                return Err(f.err(
                    a.span(),
                    "anchors",
                    "anchors are for free chains (a fixed-base chain is held at its base)".into(),
                ));
            }
            let n = n_links as i64;
            let mut v: Vec<u32> = Vec::with_capacity(a.get_ref().len());
            for &j in a.get_ref() {
                if !(0..=n).contains(&j) {
                    return Err(f.err(
                        a.span(),
                        "anchors",
                        format!("joint {j} is outside 0..={n}"),
                    ));
                }
                v.push(j as u32);
            }
            v.sort_unstable();
            v.dedup();
            if v.len() != a.get_ref().len() || v.len() > MAX_HELD {
                return Err(f.err(
                    a.span(),
                    "anchors",
                    format!("anchors must be distinct joints, at most {}", MAX_HELD),
                ));
            }
            v
        }
    })
}

/// The chain's `eyelets`: points on its links (within 1e-9 of a link), at most [`MAX_EYELETS`], at
/// least two links apart along the rope, on a free chain with no collision and no anchors; sorted
/// along the rope, each with its link.
pub(super) fn eyelets(
    f: &Fields<'_>,
    kind: ChainKind,
    points: &[Vector3<f64>],
    lengths: &[f64],
    anchors: &[u32],
) -> Result<Vec<(Vector3<f64>, usize)>, SceneError> {
    let Some(e) = &f.c.eyelets else {
        return Ok(Vec::new());
    };
    let err = |what: String| Err(f.err(e.span(), "eyelets", what));
    if kind != ChainKind::Free {
        return err("eyelets are for free chains".into());
    }
    if e.get_ref().len() > MAX_EYELETS {
        return err(format!("at most {MAX_EYELETS} eyelets"));
    }
    let mut out = Vec::with_capacity(e.get_ref().len());
    for (i, v) in e.get_ref().iter().enumerate() {
        let p = match v.as_slice() {
            [x, y] if f.dims == 2 => Vector3::new(*x, *y, 0.0),
            [x, y, z] if f.dims == 3 || *z == 0.0 => Vector3::new(*x, *y, *z),
            _ => return err(format!("eyelet {i}: a point has {} numbers", f.dims)),
        };
        if !p.iter().all(|x| x.is_finite()) {
            return err(format!("eyelet {i}: {v:?} is not finite"));
        }
        let (link, d) = points
            .windows(2)
            .enumerate()
            .map(|(k, w)| {
                let ab = w[1] - w[0];
                let t = ((p - w[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
                (k, (w[0] + ab * t - p).norm())
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, f64::INFINITY));
        if d > 1e-9 * lengths.get(link).copied().unwrap_or(0.0) {
            return err(format!(
                "eyelet {i} at {v:?} is not on the chain (link {link} passes {d:e} from it)"
            ));
        }
        out.push((p, link));
    }
    out.sort_by_key(|e| e.1);
    if let Some(w) = out.windows(2).find(|w| w[1].1 < w[0].1 + 2) {
        return err(format!(
            "eyelets on links {} and {} are less than two links apart",
            w[0].1, w[1].1
        ));
    }
    // A move closes the rope on a held joint by the two links beside it.
    for &(_, link) in &out {
        if let Some(a) = anchors
            .iter()
            .find(|&&a| link + 2 > a as usize && link < a as usize + 2)
        {
            return err(format!(
                "the eyelet on link {link} lies within two links of anchor {a}"
            ));
        }
    }
    Ok(out)
}

/// A box's lower and upper corners.
pub(super) type Corners = (Vector3<f64>, Vector3<f64>);

/// The chain's `tissue`: two corners `[lo, hi]` of a box, `lo` below `hi` on every axis, on a free
/// spatial chain.
pub(super) fn tissue(f: &Fields<'_>, kind: ChainKind) -> Result<Option<Corners>, SceneError> {
    let Some(t) = &f.c.tissue else {
        return Ok(None);
    };
    let err = |what: String| Err(f.err(t.span(), "tissue", what));
    if kind != ChainKind::Free || f.dims != 3 {
        return err("tissue is for free spatial chains".into());
    }
    let corner = |v: &Vec<f64>| match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Some(Vector3::new(*x, *y, *z)),
        _ => None,
    };
    match t.get_ref().as_slice() {
        [a, b] => match (corner(a), corner(b)) {
            (Some(lo), Some(hi)) if (0..3).all(|k| lo[k] < hi[k]) => Ok(Some((lo, hi))),
            _ => err(
                "two corners [[x, y, z], [x, y, z]], the first below the second on every axis"
                    .into(),
            ),
        },
        _ => err("two corners [[x, y, z], [x, y, z]]".into()),
    }
}

/// The chain's `needle = [radius, angle°, thickness]`, on a chain with `tissue` and collision (its
/// capsules are added as the chain's last instruments once the scene's are resolved).
pub(super) fn needle(
    f: &Fields<'_>,
    has_tissue: bool,
    has_collision: bool,
) -> Result<Option<crate::needle::Needle>, SceneError> {
    let Some(nd) = &f.c.needle else {
        if let Some(b) = &f.c.needle_bend {
            return Err(f.err(
                b.span(),
                "needle_bend",
                "is for a chain with a `needle`".into(),
            ));
        }
        return Ok(None);
    };
    let err = |what: String| Err(f.err(nd.span(), "needle", what));
    if !has_tissue || !has_collision {
        return err("a needle is for a chain with `tissue` and `collision`".into());
    }
    match nd.get_ref().as_slice() {
        [r, a, t]
            if r.is_finite()
                && *r > 0.0
                && a.is_finite()
                && *a > 0.0
                && a.to_radians() <= crate::needle::MAX_NEEDLE_ANGLE
                && t.is_finite()
                && *t > 0.0 =>
        {
            let mut n = crate::needle::Needle::new(*r, a.to_radians(), *t, 0);
            if let Some(b) = &f.c.needle_bend {
                match b.get_ref().as_slice() {
                    [x, y, z] if [x, y, z].iter().all(|v| v.is_finite()) => {
                        n.bend = Some(crate::command::Point::new(*x, *y, *z));
                    }
                    _ => {
                        return Err(f.err(
                            b.span(),
                            "needle_bend",
                            "[x, y, z]: three finite numbers".into(),
                        ));
                    }
                }
            }
            Ok(Some(n))
        }
        _ => err(
            "[radius, angle, thickness]: a radius > 0, an angle in degrees in (0, 270], a \
             thickness > 0"
                .into(),
        ),
    }
}

/// The chain's wound: `incision = [point, normal]` with `tissue_give` (> 0) and `wound_margin`
/// (≥ 0, default 0), on a chain with `tissue`; all three or none but the margin.
pub(super) fn wound(f: &Fields<'_>, has_tissue: bool) -> Result<Option<Wound>, SceneError> {
    let c = f.c;
    let Some(inc) = &c.incision else {
        for (x, name) in [
            (&c.tissue_give, "tissue_give"),
            (&c.wound_margin, "wound_margin"),
        ] {
            if let Some(x) = x {
                return Err(f.err(x.span(), name, "needs an `incision`".into()));
            }
        }
        return Ok(None);
    };
    let err = |what: String| Err(f.err(inc.span(), "incision", what));
    if !has_tissue {
        return err("an incision is for a chain with `tissue`".into());
    }
    let v = |v: &Vec<f64>| match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Some(Vector3::new(*x, *y, *z)),
        _ => None,
    };
    let (point, normal) = match inc.get_ref().as_slice() {
        [a, b] => match (v(a), v(b)) {
            (Some(p), Some(n)) if n.norm() > 1e-12 && n.norm().is_finite() => (p, n.normalize()),
            _ => {
                return err(
                    "a point and a normal [[x, y, z], [nx, ny, nz]], the normal not zero".into(),
                );
            }
        },
        _ => return err("a point and a normal [[x, y, z], [nx, ny, nz]]".into()),
    };
    let Some(g) = &c.tissue_give else {
        return err("needs `tissue_give`: how far the tissue gives per unit of pull".into());
    };
    let give = f.positive(g, "tissue_give")?;
    let margin = match &c.wound_margin {
        Some(m) if m.get_ref().is_finite() && *m.get_ref() >= 0.0 => *m.get_ref(),
        Some(m) => {
            return Err(f.err(
                m.span(),
                "wound_margin",
                format!("{} is not a number ≥ 0", m.get_ref()),
            ));
        }
        None => 0.0,
    };
    Ok(Some(Wound {
        point,
        normal,
        give,
        margin,
    }))
}
