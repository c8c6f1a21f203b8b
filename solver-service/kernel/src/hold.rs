//! Moves of a chain with held joints (anchors, grasps): the paper's remark 2 with fixed bases.
//!
//! A move of joint `m` splits the chain at `m`. On each side, the links from `m` to the nearest held
//! joint form a fixed-base chain whose base is that held joint and whose end is `m`; it is solved by the
//! paper's fixed-base method ([`crate::fixed_base::reach`]: tractrix passes with `m` moving straight to
//! the target, each followed by a rigid translation back to the base, finished by Korein & Badler's reach
//! hierarchy when the iteration is slow, or for a limited chain by boundary following when the
//! hierarchy's pose breaks a limit), and nothing beyond the held joint moves. A side with no held
//! joint follows `m` freely, dragged along the straight segment from where `m` was to where it lands,
//! exactly as a move without holds. With held joints on both sides, the tail side is solved first and the
//! head side reaches the end the tail side found, to a tolerance of a few ulps, so the links between
//! them close on the held joint (the last link absorbs the rounding).
//!
//! The target is checked first against what the held sides allow: a point within the rope's length of
//! each held joint (and no nearer than the rope can fold). Outside, the move is refused with the nearest
//! reachable point, so a hand can pull the rope taut instead. On any refusal nothing changes.
//!
//! A move with holds copies its held sides into scratch chains (it allocates, unlike a free move).

use crate::chain::{Chain, ChainError, MoveOptions, MoveOutcome};
use crate::fixed_base::{ReachError, ReachOptions, ReachWorkspace, reach, workspace_radii};
use crate::math::{Embed3, Real, Vector, all_finite, robust_norm};

/// A chain's moves: free, or with its held joints kept (this module's held solution).
impl<T: Real, const D: usize> Chain<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// Moves joint `joint` (0 = tail, `n` = head) along the straight segment to `target`; the rest of the
    /// chain follows by `opts.method`. On error nothing changes.
    pub fn move_joint(
        &mut self,
        joint: usize,
        target: Vector<T, D>,
        opts: &MoveOptions<T>,
    ) -> Result<MoveOutcome, ChainError> {
        self.check_joint(joint)?;
        if !all_finite(&target) {
            return Err(ChainError::NonFinite);
        }
        if self.held_elsewhere(joint) {
            return move_held(self, joint, target, opts);
        }
        let delta = target - self.current(joint);
        let k = self.substep_count(&delta, opts)?;
        let outcome = self.apply_move(joint, target, delta, k, opts.method);
        self.repin(joint);
        Ok(outcome)
    }

    /// Where joint `joint` can go nearest to `target` with the held joints kept: `target` itself when
    /// the held sides reach it (each within its rope's length of its held joint, and no nearer than
    /// the rope can fold), else the nearest point they reach (on the boundary of the held sides'
    /// shells). A hand pulling the rope taut moves the joint there.
    pub fn nearest_reachable(
        &self,
        joint: usize,
        target: Vector<T, D>,
    ) -> Result<Vector<T, D>, ChainError> {
        self.check_joint(joint)?;
        if !all_finite(&target) {
            return Err(ChainError::NonFinite);
        }
        nearest_reachable(self, joint, target)
    }

    /// Moves joint `joint` through `targets` in order, one straight move per target. Every target and
    /// substep count is validated before anything moves.
    pub fn move_along(
        &mut self,
        joint: usize,
        targets: &[Vector<T, D>],
        opts: &MoveOptions<T>,
    ) -> Result<MoveOutcome, ChainError> {
        self.check_joint(joint)?;
        let mut from = self.current(joint);
        for t in targets {
            if !all_finite(t) {
                return Err(ChainError::NonFinite);
            }
            self.substep_count(&(t - from), opts)?;
            from = *t;
        }
        let mut total = MoveOutcome::default();
        if self.held_elsewhere(joint) {
            // Each target may be refused (out of the held rope's reach): all or nothing.
            let before = self.clone();
            for t in targets {
                match move_held(self, joint, *t, opts) {
                    Ok(o) => {
                        total.substeps = total.substeps.saturating_add(o.substeps);
                        total.paper_fallbacks =
                            total.paper_fallbacks.saturating_add(o.paper_fallbacks);
                    }
                    Err(e) => {
                        *self = before;
                        return Err(e);
                    }
                }
            }
            return Ok(total);
        }
        for t in targets {
            let delta = t - self.current(joint);
            let k = self.substep_count(&delta, opts)?;
            let o = self.apply_move(joint, *t, delta, k, opts.method);
            total.substeps = total.substeps.saturating_add(o.substeps);
            total.paper_fallbacks = total.paper_fallbacks.saturating_add(o.paper_fallbacks);
        }
        self.repin(joint);
        Ok(total)
    }
}

/// The part of the chain between `m` and a held joint, as a fixed-base chain: its base is the held
/// joint, its end `m`.
struct Side<T: Real, const D: usize> {
    held: usize,
    chain: Chain<T, D>,
}

fn side<T: Real, const D: usize>(
    c: &Chain<T, D>,
    m: usize,
    held: usize,
) -> Result<Side<T, D>, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let base = c.joint(held);
    let (links, lengths): (Vec<_>, Vec<_>) = if held < m {
        (c.links()[held..m].to_vec(), c.lengths()[held..m].to_vec())
    } else {
        (
            c.links()[m..held].iter().rev().map(|l| -l).collect(),
            c.lengths()[m..held].iter().rev().copied().collect(),
        )
    };
    let mut chain = Chain::from_raw_parts(base, links, lengths)?;
    if let Some(l) = c.joint_limits() {
        let sub = if held < m {
            l.sub(held, m, false)
        } else {
            l.sub(m, held, true)
        };
        chain
            .set_limits(Some(sub))
            .map_err(|_| ChainError::BadOption("limits of a held side"))?;
    }
    Ok(Side { held, chain })
}

/// Where `p` lies relative to the shell about `c` with radii `inner..=outer`: the nearest point of the
/// shell and the distance to it (zero inside).
fn nearest_on_shell<T: Real, const D: usize>(
    c: &Vector<T, D>,
    inner: T,
    outer: T,
    p: &Vector<T, D>,
    fallback: &Vector<T, D>,
) -> (Vector<T, D>, T) {
    let v = p - c;
    let r = robust_norm(&v);
    let dir = if r > T::zero() {
        v / r
    } else {
        let f = fallback - c;
        let n = f.norm();
        if n > T::zero() { f / n } else { unit_x() }
    };
    if r > outer {
        (c + dir * outer, r - outer)
    } else if r < inner {
        (c + dir * inner, inner - r)
    } else {
        (*p, T::zero())
    }
}

fn unit_x<T: Real, const D: usize>() -> Vector<T, D> {
    let mut e = Vector::zeros();
    e[0] = T::one();
    e
}

fn inside<T: Real, const D: usize>(c: &Vector<T, D>, inner: T, outer: T, p: &Vector<T, D>) -> bool {
    // A few ulps of slack: a point computed on a sphere may land a rounding outside it.
    let r = robust_norm(&(p - c));
    let slack = (outer + r) * T::EPSILON * T::lit(16.0);
    r <= outer + slack && r + slack >= inner
}

/// The point nearest to `p` on the circle where the spheres about `c1` (radius `r1`) and `c2` (radius
/// `r2`) meet (two points in a plane), if they meet.
fn nearest_on_meeting<T: Real, const D: usize>(
    c1: &Vector<T, D>,
    r1: T,
    c2: &Vector<T, D>,
    r2: T,
    p: &Vector<T, D>,
) -> Option<Vector<T, D>>
where
    Vector<T, D>: Embed3<T>,
{
    let d = robust_norm(&(c2 - c1));
    if d <= T::zero() || d > r1 + r2 || d < (r1 - r2).abs() {
        return None;
    }
    let u = (c2 - c1) / d;
    let a = (d * d + r1 * r1 - r2 * r2) / (T::lit(2.0) * d);
    let h = (r1 * r1 - a * a).max(T::zero()).sqrt();
    let centre = c1 + u * a;
    let w = (p - centre) - u * (p - centre).dot(&u);
    let wn = w.norm();
    let dir = if wn > T::zero() {
        w / wn
    } else {
        // Any direction across the axis (in the plane for a planar chain).
        let u3 = u.to_3d();
        let mut q = nalgebra::Vector3::z().cross(&u3);
        if D == 3 && q.norm() < T::lit(0.1) {
            q = nalgebra::Vector3::x().cross(&u3);
        }
        let q = Vector::<T, D>::from_3d(&q);
        q / q.norm()
    };
    Some(centre + dir * h)
}

/// Checks `target` against the held sides; `Err` with the nearest reachable point when outside.
fn check_reach<T: Real, const D: usize>(
    sides: &[&Side<T, D>],
    m_now: &Vector<T, D>,
    target: &Vector<T, D>,
) -> Result<(), ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let shells: Vec<(usize, Vector<T, D>, T, T)> = sides
        .iter()
        .map(|s| {
            let (inner, outer) = workspace_radii(s.chain.lengths());
            (s.held, s.chain.origin(), inner, outer)
        })
        .collect();
    if shells.iter().all(|(_, c, i, o)| inside(c, *i, *o, target)) {
        return Ok(());
    }
    // Candidates: the nearest point of each shell, and the meeting circles of their boundaries.
    let mut candidates = Vec::new();
    for (_, c, i, o) in &shells {
        candidates.push(nearest_on_shell(c, *i, *o, target, m_now).0);
    }
    if let [(_, c1, i1, o1), (_, c2, i2, o2)] = shells[..] {
        for r1 in [i1, o1] {
            for r2 in [i2, o2] {
                if r1 > T::zero() && r2 > T::zero() {
                    candidates.extend(nearest_on_meeting(&c1, r1, &c2, r2, target));
                }
            }
        }
    }
    // Where the joint is now is always allowed: the fallback.
    candidates.push(*m_now);
    let (nearest, residual) = candidates
        .into_iter()
        .filter(|q| shells.iter().all(|(_, c, i, o)| inside(c, *i, *o, q)))
        .map(|q| (q, robust_norm(&(q - target))))
        .min_by(|a, b| a.1.to_f64().total_cmp(&b.1.to_f64()))
        .unwrap_or((*m_now, robust_norm(&(m_now - target))));
    // The held joint that limits: the first whose shell the target is outside.
    let held = shells
        .iter()
        .find(|(_, c, i, o)| !inside(c, *i, *o, target))
        .map_or(sides[0].held, |s| s.0);
    let n3 = nearest.to_3d();
    Err(ChainError::HeldUnreachable {
        held,
        nearest: [n3.x.to_f64(), n3.y.to_f64(), n3.z.to_f64()],
        residual: residual.to_f64(),
    })
}

/// See [`Chain::nearest_reachable`].
pub(crate) fn nearest_reachable<T: Real, const D: usize>(
    c: &Chain<T, D>,
    m: usize,
    target: Vector<T, D>,
) -> Result<Vector<T, D>, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let (lo, hi) = c.held_around(m);
    let tail = lo.map(|h| side(c, m, h)).transpose()?;
    let head = hi.map(|h| side(c, m, h)).transpose()?;
    let sides: Vec<&Side<T, D>> = tail.iter().chain(head.iter()).collect();
    if sides.is_empty() {
        return Ok(target);
    }
    match check_reach(&sides, &c.current(m), &target) {
        Ok(()) => Ok(target),
        Err(ChainError::HeldUnreachable { nearest, .. }) => Ok(Vector::<T, D>::from_3d(
            &nalgebra::Vector3::new(T::lit(nearest[0]), T::lit(nearest[1]), T::lit(nearest[2])),
        )),
        Err(e) => Err(e),
    }
}

fn solve<T: Real, const D: usize>(
    s: &mut Side<T, D>,
    target: &Vector<T, D>,
    opts: &ReachOptions<T>,
    ws: &mut ReachWorkspace<T, D>,
) -> Result<u32, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let base = s.chain.origin();
    if s.chain.n_links() == 1 {
        // One link: its shell is a sphere, which a rounded point is never exactly on. The link points
        // at the target (already checked to be at its length, to rounding).
        let v = target - base;
        let r = v.norm();
        if r > T::zero() {
            let len = s.chain.lengths()[0];
            s.chain = Chain::from_raw_parts(base, vec![v * (len / r)], vec![len])?;
        }
        return Ok(1);
    }
    // A target that passed `check_reach` may still lie a rounding outside this side's shell (the
    // nearest point of a refusal, sent back): put it on the shell.
    let (inner, outer) = workspace_radii(s.chain.lengths());
    let head = s.chain.head();
    let (mut target, _) = nearest_on_shell(&base, inner, outer, target, &head);
    // The shell's nearest point may itself round a hair outside: pull it in by ulps until it is not.
    for _ in 0..8 {
        let r = robust_norm(&(target - base));
        if r <= outer && r >= inner {
            break;
        }
        let want = if r > outer {
            outer * (T::one() - T::EPSILON * T::lit(4.0))
        } else {
            inner * (T::one() + T::EPSILON * T::lit(4.0))
        };
        if r > T::zero() {
            target = base + (target - base) * (want / r);
        }
    }
    match reach(&mut s.chain, &target, opts, ws) {
        Ok(o) => Ok(o.iterations),
        Err(ReachError::Unreachable { nearest, residual }) => {
            let n3 = nearest.to_3d();
            Err(ChainError::HeldUnreachable {
                held: s.held,
                nearest: [n3.x.to_f64(), n3.y.to_f64(), n3.z.to_f64()],
                residual: residual.to_f64(),
            })
        }
        Err(ReachError::NotConverged {
            iterations,
            residual,
            ..
        }) => Err(ChainError::HeldNotConverged {
            iterations,
            residual: residual.to_f64(),
        }),
        Err(ReachError::Chain(e)) => Err(e),
    }
}

/// Makes the links of `c` between joint `from` and the held joint `top` meet `top` exactly: the last two
/// links are placed by the closed-form two-link solution from joint `top − 2` (lengths exact, the
/// elbow nearest where it was), taking up the rounding of the sums and the fixed-base tolerance; a
/// single link points at `top`.
pub(crate) fn close_on<T: Real, const D: usize>(c: &mut Chain<T, D>, from: usize, top: usize)
where
    Vector<T, D>: Embed3<T>,
{
    let held_at = c.joint(top);
    if top >= from + 2 {
        let base = c.joint(top - 2);
        let (a1, a2) = (c.lengths()[top - 2], c.lengths()[top - 1]);
        let cur = c.links()[top - 2];
        let (l1, l2) = crate::fixed_base::two_link(&base, &held_at, a1, a2, &cur);
        let links = c.links_mut();
        links[top - 2] = l1;
        links[top - 1] = l2;
    } else {
        let before = c.joint(top - 1);
        c.links_mut()[top - 1] = held_at - before;
    }
}

/// Moves joint `m` of `c` to `target` with the chain's held joints kept (see the module docs). On error
/// nothing changes.
pub(crate) fn move_held<T: Real, const D: usize>(
    c: &mut Chain<T, D>,
    m: usize,
    target: Vector<T, D>,
    opts: &MoveOptions<T>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let m_now = c.current(m);
    let delta = target - m_now;
    let k = c.substep_count(&delta, opts)?;
    if delta.iter().all(|x| *x == T::zero()) {
        return Ok(MoveOutcome::default());
    }
    let (lo, hi) = c.held_around(m);
    let mut tail = lo.map(|h| side(c, m, h)).transpose()?;
    let mut head = hi.map(|h| side(c, m, h)).transpose()?;
    let sides: Vec<&Side<T, D>> = tail.iter().chain(head.iter()).collect();
    check_reach(&sides, &m_now, &target)?;

    let reach_opts = ReachOptions {
        method: opts.method,
        substeps: k,
        ..opts.held
    };
    let mut ws = ReachWorkspace::default();
    let mut iterations = 0u32;
    // Where m lands: the end of the first held side solved (exactly consistent with its links).
    let mut landed = target;
    if let Some(t) = tail.as_mut() {
        iterations += solve(t, &target, &reach_opts, &mut ws)?;
        landed = t.chain.head();
    }
    if let Some(h) = head.as_mut() {
        // With both sides held, the head side must close on the tail side's end to rounding.
        let tight = if tail.is_some() {
            ReachOptions {
                tolerance: reach_opts.tolerance.min(T::EPSILON * T::lit(64.0)),
                ..reach_opts
            }
        } else {
            reach_opts
        };
        iterations += solve(h, &landed, &tight, &mut ws)?;
        if tail.is_none() {
            landed = h.chain.head();
        }
    }

    // Nothing can fail from here on but the limits' final check: write the sides back.
    let before = c.joint_limits().is_some().then(|| c.clone());
    let shift = (landed - m_now) / T::lit(k as f64);
    let mut fallbacks = 0u32;
    match (&tail, lo) {
        (Some(t), Some(l)) => c.links_mut()[l..m].copy_from_slice(t.chain.links()),
        _ => {
            for _ in 0..k {
                fallbacks += c.sweep_tail_side(m, &shift, opts.method, 0).0;
            }
            c.place_origin_from(m, landed);
        }
    }
    match (&head, hi) {
        (Some(h), Some(top)) => {
            let links = c.links_mut();
            for (j, l) in h.chain.links().iter().enumerate() {
                links[top - 1 - j] = -l;
            }
        }
        _ => {
            let n = c.n_links();
            for _ in 0..k {
                fallbacks += c.sweep_head_side(m, &shift, opts.method, n);
            }
        }
    }
    c.repin(m);
    if let Some(top) = hi {
        close_on(c, m, top);
    }
    if let Some(before) = before {
        // The sides were solved within their own joints' limits; the held joints' and the moved
        // joint's angles, and the closing two-link solution, are checked here.
        if let Err(e) = c.check_limits() {
            *c = before;
            return Err(e);
        }
    }
    Ok(MoveOutcome {
        substeps: k,
        paper_fallbacks: fallbacks,
        held_iterations: iterations,
        ..MoveOutcome::default()
    })
}
