//! Korein & Badler's reach hierarchy through the eyelets: the walk from a held joint to the moved one that finishes a held side, and its parts.

use super::*;

/// The threaded eyelets on links `lo..hi`, in the walk's order (`up`: from `lo`), into `ahead`, each
/// with the way from it through the ones after it to `target` (and its link).
pub(super) fn eyelets_ahead<T: Real, const D: usize>(
    eyelets: &[Eyelet<T, D>],
    (lo, hi): (usize, usize),
    up: bool,
    target: Vector<T, D>,
    ahead: &mut Vec<(usize, T, usize)>,
) where
    Vector<T, D>: Embed3<T>,
{
    ahead.clear();
    let between = |e: &Eyelet<T, D>| e.threaded && e.link >= lo && e.link < hi;
    if up {
        ahead.extend(
            eyelets
                .iter()
                .enumerate()
                .filter(|(_, e)| between(e))
                .map(|(i, e)| (i, T::zero(), e.link)),
        );
    } else {
        ahead.extend(
            eyelets
                .iter()
                .enumerate()
                .rev()
                .filter(|(_, e)| between(e))
                .map(|(i, e)| (i, T::zero(), e.link)),
        );
    }
    let mut way = T::zero();
    let mut next = target;
    for (i, g, _) in ahead.iter_mut().rev() {
        way += (next - eyelets[*i].at).norm();
        next = eyelets[*i].at;
        *g = way;
    }
}

/// Where a link is led before it passes straight through the eyelet at `q`: half a link (`half`)
/// before it on the line from `after`, where the rope goes next.
pub(super) fn lead_point<T: Real, const D: usize>(
    q: &Vector<T, D>,
    after: &Vector<T, D>,
    half: T,
) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let back = q - after;
    if back.norm() > T::zero() {
        q + back * (half / back.norm())
    } else {
        *q
    }
}

/// The next joint from `x` (link length `l`, its last direction `c`) with no eyelet ahead: `keep`
/// (the link's old direction) unless the rope left (`material`, its longest link `longest`) could
/// then no longer reach `target`, or would have to fold back on itself; then the nearest that can.
pub(super) fn toward<T: Real, const D: usize>(
    x: &Vector<T, D>,
    keep: &Vector<T, D>,
    target: &Vector<T, D>,
    l: T,
    (longest, material): (T, T),
    c: &Vector<T, D>,
) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let inner = (longest * T::lit(2.0) - material).max(T::zero());
    let dk = (keep - target).norm();
    if dk > material || dk < inner {
        let want = dk.max(inner).min(material);
        x + crate::fixed_base::two_link(x, target, l, want, c).0
    } else {
        *keep
    }
}

/// The joint between the last two links (lengths `a1`, `a2`) from `x` to `target`, bent toward
/// `c`, in closed form; `None` when they cannot close within 64 `slack`.
pub(super) fn close_two<T: Real, const D: usize>(
    x: &Vector<T, D>,
    target: &Vector<T, D>,
    (a1, a2): (T, T),
    c: &Vector<T, D>,
    slack: T,
) -> Option<Vector<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let (l1, l2) = crate::fixed_base::two_link(x, target, a1, a2, c);
    if (x + l1 + l2 - target).norm() > slack * T::lit(64.0) {
        None
    } else {
        Some(x + l1)
    }
}

/// An alternation whose miss shrinks by less than this factor in one round has stalled.
pub(super) const STALL: f64 = 0.9;

/// Korein & Badler's reach hierarchy for the rope from joint `h` (put on `at`) to joint `m` (put on
/// `target`) through the eyelets between, from the pose `src`, written into `dst`: from `h` outward
/// each link keeps its direction unless the rope left could then no longer reach `target` through
/// the eyelets ahead (the way from the link's end through them to the target longer than the rope
/// after it), when it turns only as much as needed. A link whose leader is within its length of the
/// next eyelet passes through it (aimed at its point) when it is the link that passed through it
/// before, or when the rope left allows no other way; the last two links close on the target in
/// closed form (lengths exact). One pass, exact for a target the rope reaches through the eyelets.
/// (A threaded move walks it from the moved joint to the held one.)
#[allow(clippy::too_many_arguments)]
pub(super) fn finish<T: Real, const D: usize>(
    src: &[Vector<T, D>],
    dst: &mut [Vector<T, D>],
    lengths: &[T],
    (h, at): (usize, Vector<T, D>),
    m: usize,
    target: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    ahead: &mut Vec<(usize, T, usize)>,
) -> Result<(), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let up = m > h;
    let k = if up { m - h } else { h - m };
    let joint = |i: usize| if up { h + i } else { h - i };
    let link_of = |i: usize| if up { h + i } else { h - i - 1 };
    let (lo, hi) = (h.min(m), h.max(m));
    let fail = || EyeletError::NearHeld { held: h };
    if k < 2 {
        return Err(fail());
    }
    eyelets_ahead(eyelets, (lo, hi), up, target, ahead);
    let longest = (0..k).fold(T::zero(), |x, i| x.max(lengths[link_of(i)]));
    let mut material = (0..k).fold(T::zero(), |x, i| x + lengths[link_of(i)]);
    let slack = |x: T| x * T::EPSILON * T::lit(64.0);
    let mut x = at;
    dst[h] = at;
    let mut a = 0;
    let mut i = 0;
    while i + 2 < k {
        let l = lengths[link_of(i)];
        material -= l;
        let c = src[joint(i + 1)] - src[joint(i)];
        let keep = x + c * (l / c.norm());
        let y = if let Some(&(idx, g, old_link)) = ahead.get(a) {
            let q = eyelets[idx].at;
            let d = (x - q).norm();
            // The end must stay within `rho` of the eyelet for the rope after it to get there and on.
            let rho = material - g;
            let through = (d <= l)
                .then(|| aim(&x, &q, l, &c))
                .filter(|y| match ahead.get(a + 1) {
                    Some(&(i2, g2, _)) => {
                        (y - eyelets[i2].at).norm() + g2 <= material + slack(material)
                    }
                    None => (y - target).norm() <= material + slack(material),
                });
            let forced = d <= l && rho <= l - d + slack(l + material);
            // A link passes straight through an eyelet, so the rope cannot bend there: it is led
            // to a point half a link before the eyelet on the line from where it goes next, and
            // through it from there.
            let after = ahead
                .get(a + 1)
                .map_or(target, |&(i2, _, _)| eyelets[i2].at);
            let half = l * T::lit(0.5);
            let lead = lead_point(&q, &after, half);
            let rho_lead = rho - half;
            let led = (keep - lead).norm() <= rho_lead;
            // At or past the link that passed through the eyelet before: the rope is led to it
            // straight (the shape kept from the last pose may wander off; the eyelet passed as
            // near its old link as can be).
            let due = if up {
                link_of(i) >= old_link
            } else {
                link_of(i) <= old_link
            };
            match through {
                Some(y) if forced || due || !led => {
                    eyelets[idx].link = link_of(i);
                    a += 1;
                    y
                }
                _ if forced => {
                    // Nearly taut, and the link from here through the eyelet would leave the rope
                    // after it too short: this link and the next are laid on the line from the
                    // eyelet to where the rope goes next (the next through the eyelet), so that the
                    // rope passes it straight toward there.
                    let Some((y, z)) = (i + 3 < k)
                        .then(|| aligned_pass(&x, &q, &after, l, lengths[link_of(i + 1)]))
                        .flatten()
                    else {
                        return Err(fail());
                    };
                    let left = material - lengths[link_of(i + 1)];
                    let ok = match ahead.get(a + 1) {
                        Some(&(i2, g2, _)) => {
                            (z - eyelets[i2].at).norm() + g2 <= left + slack(material)
                        }
                        None => (z - target).norm() <= left + slack(material),
                    };
                    if !ok {
                        return Err(fail());
                    }
                    eyelets[idx].link = link_of(i + 1);
                    a += 1;
                    dst[joint(i + 1)] = y;
                    dst[joint(i + 2)] = z;
                    material = left;
                    x = z;
                    i += 2;
                    continue;
                }
                _ if due => {
                    let want = ((x - lead).norm() - l).max(T::zero());
                    x + crate::fixed_base::two_link(&x, &lead, l, want, &c).0
                }
                _ if led || (rho_lead < T::zero() && (keep - q).norm() <= rho) => keep,
                _ if rho_lead >= T::zero() => {
                    x + crate::fixed_base::two_link(&x, &lead, l, rho_lead, &c).0
                }
                _ => x + crate::fixed_base::two_link(&x, &q, l, rho.max(T::zero()), &c).0,
            }
        } else {
            toward(&x, &keep, &target, l, (longest, material), &c)
        };
        dst[joint(i + 1)] = y;
        x = y;
        i += 1;
    }
    if a < ahead.len() {
        return Err(fail());
    }
    let (a1, a2) = (lengths[link_of(k - 2)], lengths[link_of(k - 1)]);
    let c = src[joint(k - 1)] - src[joint(k - 2)];
    dst[joint(k - 1)] = close_two(&x, &target, (a1, a2), &c, slack(a1 + a2)).ok_or_else(fail)?;
    dst[m] = target;
    Ok(())
}

/// Two links from `x` (lengths `l1`, `l2`) with the second through the eyelet at `q` and both on the
/// line from `q` toward `after`: the joint between them behind `q` on that line, the end beyond it.
/// `None` when no point of that line behind `q` within the second link lies at `l1` from `x`.
pub(super) fn aligned_pass<T: Real, const D: usize>(
    x: &Vector<T, D>,
    q: &Vector<T, D>,
    after: &Vector<T, D>,
    l1: T,
    l2: T,
) -> Option<(Vector<T, D>, Vector<T, D>)> {
    let v = after - q;
    let vn = v.norm();
    if vn.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let u = v / vn;
    // The joint between at q − t·u, t in [0, l2]: |x − q + t·u| = l1.
    let w = x - q;
    let b = w.dot(&u);
    let disc = b * b - w.norm_squared() + l1 * l1;
    if disc < T::zero() {
        return None;
    }
    let r = disc.sqrt();
    let t = [-b + r, -b - r]
        .into_iter()
        .filter(|t| *t >= T::zero() && *t <= l2)
        .fold(None, |best: Option<T>, t| {
            Some(best.map_or(t, |b| b.max(t)))
        })?;
    let y = q - u * t;
    Some((y, y + u * l2))
}
