//! What a hand reports of the rope: its eyelets, its knot (named, in series, its knotted stretch), one line each.

use super::*;

/// The eyelets chain `chain` passes through, in one line, and the rope's length from its tail to the
/// first of them (the tail a stitch leaves before its entry point); `None` for a chain with none.
pub fn eyelets_line(conn: &mut Connection, chain: u32) -> anyhow::Result<Option<String>> {
    let r = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
    anyhow::ensure!(r.is_ok(), "query refused: {}", r.header.reason_str());
    let parts = r.parts();
    let eyelets: Vec<_> = parts.eyelet_states().collect();
    if eyelets.is_empty() {
        return Ok(None);
    }
    let p = |v: shared::Vec3| nalgebra::Vector3::new(v.x, v.y, v.z);
    let threaded: Vec<_> = eyelets.iter().filter(|e| e.threaded).collect();
    let places: Vec<String> = threaded
        .iter()
        .map(|e| {
            format!(
                "({:.3}, {:.3}, {:.3}) on link {}",
                e.at.x, e.at.y, e.at.z, e.link
            )
        })
        .collect();
    let mut line = format!(
        "eyelets: {} threaded of {}{}{}",
        threaded.len(),
        eyelets.len(),
        if places.is_empty() { "" } else { ": " },
        places.join(", ")
    );
    if let Some(first) = threaded.first() {
        let j = parts.joints;
        let k = first.link as usize;
        let before: f64 = j[..=k].windows(2).map(|w| (p(w[1]) - p(w[0])).norm()).sum();
        let tail = before + (p(first.at) - p(j[k])).norm();
        line.push_str(&format!("; rope before the first: {tail:.9}"));
    }
    Ok(Some(line))
}

/// Queries chain `chain` and names the knot tied in it.
pub fn knot_of(conn: &mut Connection, chain: u32) -> anyhow::Result<knots::KnotReport> {
    Ok(knots::identify(&joints_of(conn, chain)?))
}

/// The chain's joints as the service has them now.
pub(super) fn joints_of(
    conn: &mut Connection,
    chain: u32,
) -> anyhow::Result<Vec<nalgebra::Vector3<f64>>> {
    let r = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
    anyhow::ensure!(r.is_ok(), "query refused: {}", r.header.reason_str());
    Ok(r.joints()
        .iter()
        .map(|p| nalgebra::Vector3::new(p.x, p.y, p.z))
        .collect())
}

/// Cuts tried by [`series_of`].
pub(super) const SERIES_CUTS: usize = 24;

/// Whether the chain's knot is two knots one after the other ([`knots::in_series`]), for the
/// knots of two throws (square, granny, surgeon's, other); `None` for the others.
pub fn series_of(
    conn: &mut Connection,
    chain: u32,
    knot: &knots::KnotReport,
) -> anyhow::Result<Option<Option<knots::Series>>> {
    use knots::KnotType;
    if matches!(
        knot.kind,
        KnotType::Unknot | KnotType::Trefoil | KnotType::DoubleOverhand
    ) {
        return Ok(None);
    }
    Ok(Some(knots::in_series(
        &joints_of(conn, chain)?,
        SERIES_CUTS,
    )))
}

/// One line saying how a two-throw knot lies along the rope, as the tools print it.
pub fn series_line(s: &Option<knots::Series>) -> String {
    match s {
        Some(s) => format!(
            "in series: {} in joints 0..={} and {} from joint {} on: two knots one after the other, \
             not one knot whose strands hold each other",
            s.first.kind.name(),
            s.cut,
            s.second.kind.name(),
            s.cut
        ),
        None => format!(
            "in series: no: no cut of the {SERIES_CUTS} tried leaves a knot in each half (the strands hold each other)"
        ),
    }
}

/// The knotted stretch of the chain's knot ([`knots::knotted_stretch`]) as a line: its
/// joints, its length along the rope and in rope diameters; `None` for the unknot.
pub fn knotted_stretch_line(
    conn: &mut Connection,
    chain: u32,
    k: &knots::KnotReport,
) -> anyhow::Result<Option<String>> {
    let joints = joints_of(conn, chain)?;
    let Some((a, b)) = knots::knotted_stretch(&joints, k.kind) else {
        return Ok(None);
    };
    let d = conn.call(RequestHeader::new(Command::Describe, chain), &[])?;
    let length: f64 = joints[a..=b].windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    let thickness = d.header.thickness;
    Ok(Some(format!(
        "knotted stretch: joints {a}..={b}, {length:.3} long, {:.1} diameters",
        if thickness > 0.0 {
            length / thickness
        } else {
            f64::INFINITY
        }
    )))
}

/// The stitch of a chain whose answer's parts are `parts`, where its two strands meet: its first
/// anchor (a held joint the scene holds, not a grasp), else the joint halfway between the links of
/// its first and last threaded eyelets (the bite); `None` for a chain with neither.
pub fn stitch_of(parts: &shared::Parts<'_>) -> Option<usize> {
    if let Some(a) = parts.held.iter().find(|h| h.y == 1.0) {
        return Some(a.x as usize);
    }
    let links: Vec<u32> = parts
        .eyelet_states()
        .filter(|e| e.threaded)
        .map(|e| e.link)
        .collect();
    match (links.iter().min(), links.iter().max()) {
        (Some(&lo), Some(&hi)) => Some(((lo + hi) / 2 + 1) as usize),
        _ => None,
    }
}

/// The two strands of the chain's knot, cut at its stitch ([`stitch_of`], [`knots::strands`]), for the
/// knots of two throws (square, granny, surgeon's, other); `None` for the others or a chain without a
/// stitch. One query.
pub fn strands_of(
    conn: &mut Connection,
    chain: u32,
    knot: &knots::KnotReport,
) -> anyhow::Result<Option<knots::Series>> {
    use knots::KnotType;
    if matches!(
        knot.kind,
        KnotType::Unknot | KnotType::Trefoil | KnotType::DoubleOverhand
    ) {
        return Ok(None);
    }
    let r = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
    anyhow::ensure!(r.is_ok(), "query refused: {}", r.header.reason_str());
    let parts = r.parts();
    let Some(at) = stitch_of(&parts) else {
        return Ok(None);
    };
    let joints: Vec<_> = parts
        .joints
        .iter()
        .map(|p| nalgebra::Vector3::new(p.x, p.y, p.z))
        .collect();
    Ok(knots::strands(&joints, at))
}

/// The strands found by [`strands_of`] as a line: each strand's knot, and whether the knot is the real
/// one (both strands alone unknotted).
pub fn strands_line(s: &knots::Series) -> String {
    format!(
        "strands cut at joint {}: {} / {}: {}",
        s.cut,
        s.first.kind.name(),
        s.second.kind.name(),
        if s.both_unknotted() {
            "each strand alone unknotted, the real knot"
        } else {
            "a strand alone is knotted: not the real knot"
        }
    )
}

/// One line describing a knot report, as the tools print it.
pub fn knot_line(k: &knots::KnotReport) -> String {
    format!(
        "knot: {} ({} of {} closures agree; {} crossings, writhe {}, determinant {})",
        k.kind.name(),
        k.agreeing,
        k.closures,
        k.crossings,
        k.writhe,
        k.determinant
    )
}
