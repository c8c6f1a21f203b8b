//! Naming an open rope's knot: [`identify`] (six closures, majority), [`Namer`] (one closure, kept
//! between states), [`in_series`] and [`knotted_stretch`].

use crate::diagram::{Diagram, Sweep};
use crate::kind::{KnotType, MAX_EVALUATED_CROSSINGS};
use nalgebra::Vector3;

/// What [`identify`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct KnotReport {
    /// The majority name.
    pub kind: KnotType,
    /// How many closures gave that name.
    pub agreeing: u32,
    /// How many closures were named (of six; a closure none of whose three views is generic is not).
    pub closures: u32,
    /// Crossings of the simplest winning view after reduction.
    pub crossings: u32,
    /// Writhe (sum of crossing signs) of that reduced diagram.
    pub writhe: i32,
    /// `|V(−1)|`, the knot determinant, of that view.
    pub determinant: u64,
    /// Its Jones polynomial as `(lowest power of t, coefficients)`.
    pub jones: (i32, Vec<i64>),
}

/// Names the knot tied in an open chain through `points` (joint positions, tail first).
pub fn identify(points: &[Vector3<f64>]) -> KnotReport {
    let (centroid, radius) = centroid_and_radius(points);
    let mut tallies: Vec<(KnotType, u32, Option<Diagram>)> = Vec::new();
    let mut closures = 0;
    let mut closed: Vec<Vector3<f64>> = Vec::with_capacity(points.len() + 1);
    for u in closure_directions() {
        closed.clear();
        closed.extend_from_slice(points);
        closed.push(centroid + u * (3.0 * radius));
        // The first generic view names this closure; the others would say the same.
        let Some(d) = projection_directions(&u)
            .iter()
            .find_map(|v| Diagram::project(&closed, v))
        else {
            continue;
        };
        let d = d.reduced();
        let kind = d.name();
        closures += 1;
        match tallies.iter_mut().find(|t| t.0 == kind) {
            Some(t) => {
                t.1 += 1;
                // Report the simplest diagram seen of this knot.
                if t.2
                    .as_ref()
                    .is_some_and(|best| d.crossings() < best.crossings())
                {
                    t.2 = Some(d);
                }
            }
            None => tallies.push((kind, 1, Some(d))),
        }
    }
    // Majority; ties go to the simpler knot (the enum's order).
    tallies.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    match tallies.into_iter().next() {
        Some((kind, agreeing, Some(d))) => {
            let jones = d.jones().unwrap_or_default();
            KnotReport {
                kind,
                agreeing,
                closures,
                crossings: d.crossings() as u32,
                writhe: d.writhe(),
                determinant: jones.determinant(),
                jones: (-(jones.lo + jones.coef.len() as i32 - 1) / 4, jones.to_t()),
            }
        }
        _ => KnotReport {
            kind: KnotType::Other,
            agreeing: 0,
            closures,
            crossings: 0,
            writhe: 0,
            determinant: 0,
            jones: (0, Vec::new()),
        },
    }
}

/// Reduced diagrams larger than this are not evaluated by a [`Namer`] made with [`Namer::new`], and
/// count as [`KnotType::Other`].
pub const NAMER_CROSSINGS: usize = 16;

/// Segment pairs a [`Namer`]'s sweep may test per point of the rope in one view.
pub const NAMER_PAIRS_PER_POINT: usize = 16;

/// Crossings a [`Namer`]'s view may have before reduction.
pub const NAMER_RAW_CROSSINGS: usize = 128;

/// A [`Namer`] tries the next closure only while the smallest reduced diagram of the closures tried
/// so far has more crossings than its limit and at most this many times it (none at all: a rope no
/// view of which fits the sweep's budget is [`KnotType::Other`] after the first closure).
pub const NAMER_HOPELESS: usize = 2;

/// How many diagrams a [`Namer`] remembers with their names.
pub const NAMER_MEMORY: usize = 64;

/// Names a rope's knot fast enough to ask with every state (a haptic frame, a published state): the
/// incremental form of [`identify`].
///
/// It closes the rope once, through a point far away in the direction its two ends leave the rope's
/// centroid (three times the rope's radius out, as [`identify`] closes it: the ends are extended
/// outward and joined round the outside), takes the first generic view of that closed curve (of three;
/// the next when moves I and II leave more crossings than the namer evaluates, and when none of the
/// three is small enough, the views of [`identify`]'s closures in turn), finds its crossings
/// by a sweep along the picture (segments whose ranges overlap, not every pair), and reduces the
/// diagram by Reidemeister moves I and II in place. The reduced diagram, as a code (its
/// passages in order along the rope, crossings numbered as first met, each over or under and its
/// sign), is looked up among the last [`NAMER_MEMORY`] diagrams it named: a rope that moves without
/// passing through itself mostly keeps its reduced diagram, and then no invariant is computed. Only a
/// new diagram is named by its Jones polynomial, as [`identify`] names one (up to
/// the namer's crossing limit; larger is [`KnotType::Other`]).
///
/// One closure is one answer: [`identify`] names six and takes the majority, which differs from this
/// closure's name only while an end is inside the tangle (the knot of an open rope depends on how it
/// is closed). The buffers are kept; naming a remembered diagram allocates nothing.
#[derive(Clone, Debug)]
pub struct Namer {
    limit: usize,
    closed: Vec<Vector3<f64>>,
    sweep: Sweep,
    view: Diagram,
    diagram: Diagram,
    at: Vec<[usize; 2]>,
    label: Vec<u32>,
    code: Vec<u32>,
    known: Vec<(u64, Vec<u32>, KnotType)>,
    next: usize,
    evaluations: u64,
    crossings: usize,
}

impl Default for Namer {
    fn default() -> Self {
        Namer::new()
    }
}

impl Namer {
    /// A namer that evaluates reduced diagrams of up to [`NAMER_CROSSINGS`] crossings.
    pub fn new() -> Self {
        Namer::with_limit(NAMER_CROSSINGS)
    }

    /// A namer that evaluates reduced diagrams of up to `max_crossings` crossings (at most
    /// [`MAX_EVALUATED_CROSSINGS`]); larger ones are [`KnotType::Other`]. The work of naming a new
    /// diagram grows with the width of the bracket's sweep, at most as `2^max_crossings`.
    pub fn with_limit(max_crossings: usize) -> Self {
        Namer {
            limit: max_crossings.min(MAX_EVALUATED_CROSSINGS),
            closed: Vec::new(),
            sweep: Sweep::default(),
            view: Diagram::default(),
            diagram: Diagram::default(),
            at: Vec::new(),
            label: Vec::new(),
            code: Vec::new(),
            known: Vec::with_capacity(NAMER_MEMORY),
            next: 0,
            evaluations: 0,
            crossings: 0,
        }
    }

    /// How many diagrams it has named by their invariant (the rest were remembered).
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// Crossings of the last reduced diagram.
    pub fn crossings(&self) -> usize {
        self.crossings
    }

    /// The knot tied in the open chain through `points` (joint positions, tail first), closed as the
    /// type's documentation says. [`KnotType::Other`] when no view of any closure tried is generic.
    /// The work is bounded: each view tests at most [`NAMER_PAIRS_PER_POINT`] segment pairs per
    /// point and finds at most [`NAMER_RAW_CROSSINGS`] crossings before it counts as not generic
    /// (a crumpled rope whose every view crosses itself that often is `Other`).
    pub fn name(&mut self, points: &[Vector3<f64>]) -> KnotType {
        self.sweep.budget = Some((
            NAMER_PAIRS_PER_POINT * (points.len() + 1),
            NAMER_RAW_CROSSINGS,
        ));
        let Some((&first, &last)) = points.first().zip(points.last()) else {
            return KnotType::Unknot;
        };
        let (centroid, radius) = centroid_and_radius(points);
        let unit = |v: Vector3<f64>| v.try_normalize(1e-12 * radius);
        let (a, b) = (first - centroid, last - centroid);
        // The ends' direction; ends on opposite sides (a rope pulled straight) close to the side.
        let ends = match (unit(a), unit(b)) {
            (Some(a), Some(b)) if (a + b).norm() > 0.1 => unit(a + b),
            (Some(a), Some(b)) => {
                unit(b - a).and_then(|d| unit(d.cross(&Vector3::new(0.267, 0.534, 0.802))))
            }
            (Some(u), None) | (None, Some(u)) => Some(u),
            (None, None) => None,
        };
        // The first generic view whose reduced diagram is within the limit (a view can leave
        // crossings that moves I and II cannot remove), of the ends' closure, else of the next
        // closures; else the smallest seen.
        let mut best: Option<usize> = None;
        for u in ends.into_iter().chain(closure_directions()) {
            self.closed.clear();
            self.closed.extend_from_slice(points);
            self.closed.push(centroid + u * (3.0 * radius));
            for v in projection_directions(&u) {
                if !self.sweep.project(&self.closed, &v, &mut self.view) {
                    continue;
                }
                self.view.reduce(&mut self.at);
                let c = self.view.crossings();
                if best.is_none_or(|b| c < b) {
                    best = Some(c);
                    std::mem::swap(&mut self.view, &mut self.diagram);
                }
                if c <= self.limit {
                    break;
                }
            }
            // Named, or so far from nameable that the other closures would cost more than a
            // request's frame and find no better (a rope crumpled into a ball: no view of it
            // within the sweep's budget, or only diagrams far past the limit).
            if best.is_none_or(|b| b <= self.limit || b > NAMER_HOPELESS * self.limit) {
                break;
            }
        }
        let Some(crossings) = best else {
            return KnotType::Other;
        };
        self.crossings = crossings;
        // The reduced diagram's code.
        self.label.clear();
        self.label.resize(self.diagram.sign.len(), u32::MAX);
        self.code.clear();
        let mut labels = 0;
        for p in &self.diagram.seq {
            if self.label[p.crossing] == u32::MAX {
                self.label[p.crossing] = labels;
                labels += 1;
            }
            let positive = self.diagram.sign[p.crossing] > 0;
            self.code
                .push(self.label[p.crossing] << 2 | u32::from(p.over) << 1 | u32::from(positive));
        }
        // FNV-1a of the code: the memory is searched by it, then the code compared.
        let hash = self.code.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &c| {
            (h ^ u64::from(c)).wrapping_mul(0x100_0000_01b3)
        });
        if let Some((_, _, kind)) = self
            .known
            .iter()
            .find(|(h, c, _)| *h == hash && *c == self.code)
        {
            return *kind;
        }
        self.evaluations += 1;
        // A new diagram: named by its polynomial (the bracket's sweep costs less than seeing the
        // closure from other views for a diagram with fewer crossings, as the state sum once did).
        let kind = if self.diagram.crossings() > self.limit {
            KnotType::Other
        } else {
            self.diagram.name()
        };
        let entry = (hash, self.code.clone(), kind);
        if self.known.len() < NAMER_MEMORY {
            self.known.push(entry);
        } else {
            self.known[self.next] = entry;
            self.next = (self.next + 1) % NAMER_MEMORY;
        }
        kind
    }
}

/// A rope cut at one joint, each part named alone: two knots one after the other ([`in_series`]), or
/// the two strands of a knot tied at a stitch ([`strands`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// The joint where the rope was cut (each half keeps it).
    pub cut: usize,
    /// The knot in joints `0..=cut`.
    pub first: KnotReport,
    /// The knot in joints `cut..`.
    pub second: KnotReport,
}

impl Series {
    /// Whether both parts are unknotted: for [`strands`], the knot holds its strands round each
    /// other, as a real square, granny or surgeon's knot does.
    pub fn both_unknotted(&self) -> bool {
        self.first.kind == KnotType::Unknot && self.second.kind == KnotType::Unknot
    }
}

/// The two strands of a rope cut at joint `at` (the stitch: an anchor, or the bite between two
/// eyelets), joints `0..=at` and `at..`, each closed far away by itself as [`identify`] closes a rope
/// and named alone. A real square, granny or surgeon's knot ties the two strands round each other, so
/// each strand alone is unknotted; an overhand in one end, or two overhands in series, leave one
/// strand or both knotted, though the whole rope may have the same knot type. `None` unless `at` is an
/// inner joint. Two identifications: a tool, not for the per-move path.
pub fn strands(points: &[Vector3<f64>], at: usize) -> Option<Series> {
    (at > 0 && at + 1 < points.len()).then(|| Series {
        cut: at,
        first: identify(&points[..=at]),
        second: identify(&points[at..]),
    })
}

/// Whether the rope's knot lies along it as two knots in series: a joint where the rope can be cut so
/// that each half, closed away from the cut as [`identify`] closes a rope, is knotted by itself (two
/// stoppers, one in each end, rather than one knot whose strands hold each other). The cuts tried are
/// `cuts` joints spread evenly between a fifth and four fifths of the rope (at most one per joint); the
/// first cut whose two halves are both knotted is returned, `None` when no cut tried makes two
/// knots. A square or granny knot tied as a knot-tier ties it (the strands round each other) has no
/// such cut: each half alone is unknotted. Each cut costs two identifications: a tool, not for the
/// per-move path.
pub fn in_series(points: &[Vector3<f64>], cuts: usize) -> Option<Series> {
    let n = points.len();
    if n < 8 || cuts == 0 {
        return None;
    }
    let (lo, hi) = (n / 5, 4 * n / 5);
    let mut last = usize::MAX;
    for k in 0..cuts {
        let cut = lo + (hi - lo) * k / cuts.max(2).saturating_sub(1).max(1);
        if cut == last || cut >= n - 1 {
            continue;
        }
        last = cut;
        let first = identify(&points[..=cut]);
        if matches!(first.kind, KnotType::Unknot) {
            continue;
        }
        let second = identify(&points[cut..]);
        if !matches!(second.kind, KnotType::Unknot) {
            return Some(Series { cut, first, second });
        }
    }
    None
}

/// The knotted stretch of a rope: the shortest run of joints `first..=last` that, closed far away by
/// itself as [`identify`] closes a rope, is still the knot `kind` (the rest of the rope cut off). Its
/// length along the rope, in rope diameters, is how tight the knot is: an ideal open trefoil takes
/// about 10 diameters, the ideal closed one 16.37. Found by two pointers (the knot of a run survives
/// lengthening it, to the closures' agreement: runs that a majority of closures name `kind`), so
/// about `2n` identifications: a tool for the end of a tightening, not for every move. `None` for
/// the unknot, or when the whole rope is not `kind`.
pub fn knotted_stretch(points: &[Vector3<f64>], kind: KnotType) -> Option<(usize, usize)> {
    if kind == KnotType::Unknot || points.len() < 4 || identify(points).kind != kind {
        return None;
    }
    let n = points.len();
    let carries = |a: usize, b: usize| b >= a + 3 && identify(&points[a..=b]).kind == kind;
    let mut best: Option<(usize, usize)> = None;
    let mut hi = 3;
    for lo in 0..n {
        if hi < lo + 3 {
            hi = lo + 3;
        }
        while hi < n && !carries(lo, hi) {
            hi += 1;
        }
        if hi >= n {
            break;
        }
        if best.is_none_or(|(a, b)| hi - lo < b - a) {
            best = Some((lo, hi));
        }
    }
    best
}

/// The points' centroid and their largest distance from it (positive): where a rope is closed from,
/// and the scale of the closing point's distance.
fn centroid_and_radius(points: &[Vector3<f64>]) -> (Vector3<f64>, f64) {
    let n = points.len().max(1) as f64;
    let centroid = points.iter().fold(Vector3::zeros(), |a, p| a + p) / n;
    let radius = points
        .iter()
        .map(|p| (p - centroid).norm())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    (centroid, radius)
}

/// Six closure directions spread over the sphere, none along an axis (ropes are often laid out along
/// axes, and an axis-aligned closure would run along the rope).
fn closure_directions() -> impl Iterator<Item = Vector3<f64>> {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    // Icosahedron vertices, one of each antipodal pair, tilted off the axes.
    let tilt = nalgebra::Rotation3::from_euler_angles(0.31, 0.17, 0.23);
    [
        Vector3::new(0.0, 1.0, phi),
        Vector3::new(0.0, -1.0, phi),
        Vector3::new(1.0, phi, 0.0),
        Vector3::new(-1.0, phi, 0.0),
        Vector3::new(phi, 0.0, 1.0),
        Vector3::new(-phi, 0.0, 1.0),
    ]
    .into_iter()
    .map(move |v| tilt * v.normalize())
}

/// Three viewing directions, well away from the closure direction `u`.
fn projection_directions(u: &Vector3<f64>) -> [Vector3<f64>; 3] {
    let a = u.cross(&Vector3::new(0.267, 0.534, 0.802)).normalize();
    let b = u.cross(&a).normalize();
    let c = (a + b * 0.61 + u * 0.37).normalize();
    [a, b, c]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagram::{Laurent, bracket};
    use std::f64::consts::TAU;

    /// The standard trefoil `(sin t + 2 sin 2t, cos t − 2 cos 2t, −sin 3t)`, `n` points, closed.
    fn trefoil(n: usize, mirror: bool, shift: f64) -> Vec<Vector3<f64>> {
        (0..n)
            .map(|k| {
                let t = TAU * k as f64 / n as f64;
                let z = -(3.0 * t).sin();
                Vector3::new(
                    t.sin() + 2.0 * (2.0 * t).sin() + shift,
                    t.cos() - 2.0 * (2.0 * t).cos(),
                    if mirror { -z } else { z },
                )
            })
            .collect()
    }

    /// Two closed knots joined by a band between the right-most point of `a` and the left-most of `b`:
    /// their connected sum, returned as one closed polygon.
    fn connected_sum(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        let ia = (0..a.len())
            .max_by(|&i, &j| a[i].x.total_cmp(&a[j].x))
            .unwrap();
        let ib = (0..b.len())
            .min_by(|&i, &j| b[i].x.total_cmp(&b[j].x))
            .unwrap();
        let mut out = Vec::new();
        for k in 1..=a.len() {
            out.push(a[(ia + k) % a.len()]);
        }
        for k in 0..b.len() {
            out.push(b[(ib + k) % b.len()]);
        }
        out
    }

    fn circle(n: usize) -> Vec<Vector3<f64>> {
        (0..n)
            .map(|k| {
                let t = TAU * k as f64 / n as f64;
                Vector3::new(5.0 * t.cos(), 5.0 * t.sin(), 0.3 * (2.0 * t).sin())
            })
            .collect()
    }

    /// A closed knot cut open at its left-most point, both ends run straight out to `x = −40`: an open
    /// rope whose ends lie far from the knotted region, as a rope pulled out at both ends.
    fn long_knot(closed: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        let n = closed.len();
        let c = (0..n)
            .min_by(|&i, &j| closed[i].x.total_cmp(&closed[j].x))
            .unwrap();
        let first = closed[(c + 1) % n];
        let last = closed[(c + n - 1) % n];
        let mut out = vec![Vector3::new(-40.0, first.y, first.z)];
        for k in 1..n {
            out.push(closed[(c + k) % n]);
        }
        out.push(Vector3::new(-40.0, last.y, last.z));
        out
    }

    /// The knotted stretch of a trefoil with long straight tails (20 joints each) lies in the knot,
    /// not in the tails, and is the shortest: the runs one joint shorter at either end are not knotted.
    #[test]
    fn the_knotted_stretch_is_the_shortest_knotted_run() {
        let knot = long_knot(&trefoil(60, false, 0.0));
        let (a, b) = (knot[0], knot[1]);
        let (c, d) = (knot[knot.len() - 2], knot[knot.len() - 1]);
        let mut rope: Vec<Vector3<f64>> =
            (0..20).map(|k| a + (b - a) * (k as f64 / 20.0)).collect();
        rope.extend_from_slice(&knot[1..knot.len() - 1]);
        rope.extend((1..=20).map(|k| c + (d - c) * (k as f64 / 20.0)));
        assert_eq!(identify(&rope).kind, KnotType::Trefoil);
        let (lo, hi) = knotted_stretch(&rope, KnotType::Trefoil).expect("a knotted stretch");
        assert!(
            lo >= 19 && hi <= rope.len() - 20,
            "{lo}..={hi} of {}",
            rope.len()
        );
        assert_eq!(identify(&rope[lo..=hi]).kind, KnotType::Trefoil);
        assert_ne!(identify(&rope[lo + 1..=hi]).kind, KnotType::Trefoil);
        assert_ne!(identify(&rope[lo..hi]).kind, KnotType::Trefoil);
        assert_eq!(knotted_stretch(&rope, KnotType::Square), None);
        assert_eq!(knotted_stretch(&circle(40), KnotType::Unknot), None);
    }

    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }

    fn union(parent: &mut [usize], a: usize, b: usize) {
        let (ra, rb) = (find(parent, a), find(parent, b));
        if ra != rb {
            parent[ra] = rb;
        }
    }

    /// The bracket summed over the `2^c` smoothings one by one (how [`bracket`] summed it before the
    /// sweep): each smoothing's loops counted by union–find.
    fn bracket_by_states(pd: &[[usize; 4]], n: usize) -> Laurent {
        let c = pd.len();
        // counts[a][loops]: states with `a` A-smoothings and `loops` loops.
        let mut counts = vec![vec![0i64; n + 2]; c + 1];
        let mut parent = vec![0usize; n];
        for state in 0u32..(1u32 << c) {
            for (i, p) in parent.iter_mut().enumerate() {
                *p = i;
            }
            let mut a_count = 0;
            for (x, q) in pd.iter().enumerate() {
                // The A-smoothing joins the regions swept counterclockwise from the over strand:
                // with `q` counterclockwise from the incoming under arc, arcs q0–q3 and q1–q2.
                if state >> x & 1 == 0 {
                    a_count += 1;
                    union(&mut parent, q[0], q[3]);
                    union(&mut parent, q[1], q[2]);
                } else {
                    union(&mut parent, q[0], q[1]);
                    union(&mut parent, q[2], q[3]);
                }
            }
            let loops = (0..n).filter(|&i| find(&mut parent, i) == i).count();
            counts[a_count][loops] += 1;
        }
        // <D> = Σ A^(a − b) d^(loops − 1), d = −A² − A⁻².
        let d = Laurent {
            lo: -2,
            coef: vec![-1, 0, 0, 0, -1],
        };
        let mut bracket = Laurent::zero();
        for (a, row) in counts.iter().enumerate() {
            for (loops, &cnt) in row.iter().enumerate() {
                if cnt == 0 {
                    continue;
                }
                let mut term = Laurent::monomial(2 * a as i32 - c as i32, cnt);
                for _ in 1..loops {
                    term = term.mul(&d);
                }
                bracket = bracket.add(&term);
            }
        }
        bracket
    }

    /// Random closed polygons (6 to 30 points in a ball, seen along random directions), reduced:
    /// wherever the diagram has 1 to 16 crossings, the sweep's bracket is the state sum's.
    #[test]
    fn the_sweep_s_bracket_is_the_state_sum_s() {
        let mut x = 0x2545_f491_4f6c_dd1d_u64;
        let mut r = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut compared = [0usize; 17];
        for k in 0..6000 {
            let p: Vec<Vector3<f64>> = (0..6 + k % 25)
                .map(|_| Vector3::new(r(), r(), r()))
                .collect();
            let view = Vector3::new(r(), r(), r());
            let Some(d) = Diagram::project(&p, &view) else {
                continue;
            };
            let d = d.reduced();
            let c = d.crossings();
            if c == 0 || c > 16 {
                continue;
            }
            let pd = d.pd();
            assert_eq!(
                bracket(&pd, d.seq.len()),
                bracket_by_states(&pd, d.seq.len()),
                "{pd:?}"
            );
            compared[c] += 1;
        }
        // Diagrams of every size from 3 to 16 crossings (the namer's limit) were compared (a
        // reduced diagram of a knot has none or at least 3).
        assert!(compared[3..=16].iter().all(|&k| k > 0), "{compared:?}");
    }

    #[test]
    fn laurent_trefoil_values() {
        let t = Laurent::trefoil();
        assert_eq!(t.determinant(), 3);
        assert_eq!(t.mul(&t).determinant(), 9);
        assert_eq!(t.mul(&t.mirror()).determinant(), 9);
        assert_ne!(t.mul(&t), t.mul(&t.mirror()));
        assert_eq!(t.mirror().mirror(), t);
    }

    fn test_knots() -> Vec<(Vec<Vector3<f64>>, KnotType)> {
        vec![
            (circle(60), KnotType::Unknot),
            (trefoil(90, false, 0.0), KnotType::Trefoil),
            (trefoil(90, true, 0.0), KnotType::Trefoil),
            (
                connected_sum(&trefoil(90, false, 0.0), &trefoil(90, false, 8.0)),
                KnotType::Granny,
            ),
            (
                connected_sum(&trefoil(90, true, 0.0), &trefoil(90, true, 8.0)),
                KnotType::Granny,
            ),
            (
                connected_sum(&trefoil(90, false, 0.0), &trefoil(90, true, 8.0)),
                KnotType::Square,
            ),
        ]
    }

    #[test]
    fn every_view_of_a_closed_knot_agrees() {
        // Closed polygons seen from many directions: the conventions (crossing signs, smoothings,
        // writhe normalisation) are consistent, or diagrams of one knot would disagree.
        for (points, want) in test_knots() {
            let mut views = 0;
            for u in closure_directions() {
                for v in projection_directions(&u) {
                    if let Some(d) = Diagram::project(&points, &v) {
                        if d.crossings() <= MAX_EVALUATED_CROSSINGS {
                            assert_eq!(d.name(), want, "unreduced, view {v:?}");
                        }
                        assert_eq!(d.reduced().name(), want, "reduced, view {v:?}");
                        views += 1;
                    }
                }
            }
            assert!(views >= 12, "{views} generic views");
        }
    }

    #[test]
    fn names_the_open_test_knots_with_ends_pulled_out() {
        for (points, want) in test_knots() {
            let r = identify(&long_knot(&points));
            assert_eq!(r.kind, want, "{r:?}");
            assert_eq!(r.agreeing, r.closures, "{r:?}");
            assert!(r.closures >= 5, "{r:?}");
        }
    }

    #[test]
    fn invariants_of_each_knot() {
        let r = identify(&long_knot(&trefoil(90, false, 0.0)));
        assert_eq!((r.crossings, r.writhe.abs(), r.determinant), (3, 3, 3));
        let r = identify(&long_knot(&connected_sum(
            &trefoil(90, false, 0.0),
            &trefoil(90, false, 8.0),
        )));
        assert_eq!((r.crossings, r.writhe.abs(), r.determinant), (6, 6, 9));
        let r = identify(&long_knot(&connected_sum(
            &trefoil(90, false, 0.0),
            &trefoil(90, true, 8.0),
        )));
        assert_eq!((r.crossings, r.writhe, r.determinant), (6, 0, 9));
        let r = identify(&circle(50));
        assert_eq!(
            (r.crossings, r.determinant, r.jones.1.clone()),
            (0, 1, vec![1])
        );
    }

    #[test]
    fn jones_unchanged_by_kinks_without_reduction() {
        // A trefoil with a small curl added: the unreduced diagram has an extra crossing, and its Jones
        // polynomial must still be the trefoil's (the writhe normalisation matches the smoothing rule).
        let mut p = trefoil(120, false, 0.0);
        let at = p[10];
        let dir = (p[11] - p[10]).normalize();
        let side = dir.cross(&Vector3::z()).normalize();
        let curl: Vec<_> = (1..12)
            .map(|k| {
                let a = TAU * k as f64 / 12.0;
                at + dir * (0.15 * a.sin())
                    + side * (0.15 * (1.0 - a.cos()))
                    + Vector3::z() * (0.05 * a.sin())
            })
            .collect();
        p.splice(11..11, curl);
        let v = Vector3::new(0.1, 0.2, 1.0).normalize();
        let d = Diagram::project(&p, &v).expect("generic view");
        assert!(d.crossings() > 3, "the curl adds a crossing");
        assert_eq!(d.name(), KnotType::Trefoil);
        assert_eq!(d.reduced().crossings(), 3);
    }

    #[test]
    fn open_rope_straight_is_unknot_and_mirror_trefoil_is_trefoil() {
        let straight: Vec<_> = (0..=40).map(|k| Vector3::new(k as f64, 0.0, 0.0)).collect();
        assert_eq!(identify(&straight).kind, KnotType::Unknot);
        // An open trefoil: the closed curve cut open at one point, ends left where they were.
        let r = identify(&long_knot(&trefoil(90, true, 0.0)));
        assert_eq!(r.kind, KnotType::Trefoil);
    }
}
