//! Moving an eyelet: the rope carried by the point it passes through, side by side.

use super::*;

/// Moves eyelet `index` straight to `to` (tissue that a simulator moves), carrying the rope's point
/// at it: the link through the eyelet is translated with it, and the rope on each side follows by the
/// tractrix (and the aim rule at the other eyelets), as from a moved joint. An eyelet the rope has
/// left just moves. With held joints the rope from each joint of the carried link to the nearest held
/// joint on its side is a held side, solved as in [`move_threaded`] (the held joints bit for bit; a
/// held joint on the carried link is refused). Split into substeps of at most half the shortest link,
/// at most `max_substeps`, the last landing on `to` exactly; refused, changing nothing, as
/// [`move_threaded`] is.
pub fn move_eyelet<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    index: usize,
    to: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    eyelet_moves(chain, index, to, eyelets, max_substeps, ws, None)
}

/// [`move_eyelet`] with collision: after every substep the contacts are resolved as in
/// [`move_threaded_colliding`], the joints of every threaded eyelet's link fixed; the substeps are
/// also at most half the smallest clearance.
#[allow(clippy::too_many_arguments)]
pub fn move_eyelet_colliding<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    index: usize,
    to: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    model: &crate::collision::CollisionModel<T, D>,
    cws: &mut crate::collision::CollisionWorkspace<T, D>,
    ws: &mut EyeletWorkspace<T, D>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    eyelet_moves(
        chain,
        index,
        to,
        eyelets,
        max_substeps,
        ws,
        Some((model, cws)),
    )
}

/// The substeps of [`move_eyelet`], with collision when `collision` is given.
pub(super) fn eyelet_moves<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    index: usize,
    to: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
    collision: Option<Collision<'_, T, D>>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let from = eyelets.get(index).map(|e| e.at);
    let moved = freeing(chain, eyelets, ws, |chain, eyelets, ws| {
        eyelet_substeps(chain, index, to, eyelets, max_substeps, ws, collision)
    });
    if let (Err(_), Some(from)) = (&moved, from) {
        eyelets[index].at = from;
    }
    moved
}

/// [`eyelet_moves`] on a chain whose limits [`freeing`] has set.
pub(super) fn eyelet_substeps<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    index: usize,
    to: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
    mut collision: Option<Collision<'_, T, D>>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let Some(&e) = eyelets.get(index) else {
        return Err(ChainError::BadOption("no such eyelet").into());
    };
    if !crate::math::all_finite(&to) {
        return Err(ChainError::NonFinite.into());
    }
    if !e.threaded {
        eyelets[index].at = to;
        return Ok(Threaded::default());
    }
    if collision.is_some() {
        ws.keep(chain);
    }
    ws.begin(chain, eyelets);
    let from = e.at;
    let way = to - from;
    // Held joints: the rope from each joint of the carried link to the nearest held joint on its
    // side is a held side, as in a threaded move of that joint (the link's own joints may not be
    // held).
    let link = e.link;
    if let Some(h) = [link, link + 1].into_iter().find(|&j| chain.is_held(j)) {
        return Err(EyeletError::NearHeld { held: h });
    }
    let holds = Holds::of_link(chain, link, &way, eyelets, ws)?;
    let (mut k, mut steps) = substeps(chain, &way, max_substeps)?;
    if let Some((model, _)) = &collision {
        (k, steps) = clearance_substeps(chain, model, &way, k, max_substeps)?;
    }
    let mut out = Threaded::default();
    let frame = collision.as_ref().is_some_and(|(_, c)| c.stops_short());
    // Where the eyelet was after the last whole substep.
    let mut made = from;
    for s in 1..=steps {
        std::mem::swap(&mut ws.old, &mut ws.new);
        // The last substep lands on the target exactly.
        let at = if s == steps {
            to
        } else {
            from + way * (T::lit(f64::from(s)) / k)
        };
        let shift = at - eyelets[index].at;
        let link = eyelets[index].link;
        eyelets[index].at = at;
        let rope = (chain.lengths(), chain.joint_limits());
        let EyeletWorkspace {
            old,
            new,
            alt,
            ahead,
            ..
        } = &mut *ws;
        if holds.is_some() {
            // The rope beyond a held joint is not walked: it stays where it was.
            new.copy_from_slice(old);
        }
        new[link] = old[link] + shift;
        new[link + 1] = old[link + 1] + shift;
        let mut one_side = |m: usize, up: bool| {
            let hold = holds
                .as_ref()
                .and_then(|h| if up { h.head } else { h.tail });
            match hold {
                None => side(old, new, rope, m, eyelets, up, None, false),
                Some(hold) => {
                    let max = holds.as_ref().map_or(1, |h| h.max_iterations);
                    held_side(old, new, alt, rope, m, hold, eyelets, max, ahead).map(|(l, _)| l)
                }
            }
        };
        let mut walked = one_side(link, false)
            .and_then(|a| Ok(a + one_side(link + 1, true)?))
            .and_then(|left| apart(eyelets).map(|()| left));
        if let (Ok(_), Some((model, cws))) = (&walked, collision.as_mut())
            && let Err(e) = resolve_carried(chain, link, eyelets, s, model, cws, ws)
        {
            walked = Err(e);
        }
        match walked {
            Ok(left) => {
                out.left += left;
                if frame {
                    // The state an eyelet's move stopped short in a later substep keeps.
                    ws.keep(chain);
                    ws.saved.clear();
                    ws.saved
                        .extend(eyelets.iter().map(|e| (e.link, e.threaded)));
                    made = eyelets[index].at;
                }
            }
            Err(err) => {
                ws.put_back(collision.is_some().then_some(&mut *chain), eyelets);
                eyelets[index].at = made;
                if frame && stops_short(&err) {
                    out.short = Some(short_of(err, s, steps));
                    return Ok(out);
                }
                return Err(err);
            }
        }
        out.substeps = s;
    }
    if collision.is_none() {
        chain.set_positions(&ws.new)?;
    }
    Ok(out)
}

/// Whether the link from a leader now at `now` (before the move at `was`, its follower at `other`),
/// aimed at `p`, would point the other way than it did: the leader went through the eyelet.
pub(super) fn turns_over<T: Real, const D: usize>(
    was: &Vector<T, D>,
    other: &Vector<T, D>,
    now: &Vector<T, D>,
    p: &Vector<T, D>,
    len: T,
) -> bool {
    let follower = aim(now, p, len, &(was - other));
    (now - follower).dot(&(was - other)) < T::zero()
}

/// The walk from `m` toward the head (`up`) or the tail: each follower placed by the tractrix from its
/// leader's displacement, or by the aim rule at an eyelet's link. Returns the eyelets left.
#[allow(clippy::too_many_arguments)]
pub(super) fn side<T: Real, const D: usize>(
    old: &[Vector<T, D>],
    new: &mut [Vector<T, D>],
    (lengths, limits): Rope<'_, T>,
    m: usize,
    eyelets: &mut [Eyelet<T, D>],
    up: bool,
    stop: Option<usize>,
    steer_start: bool,
) -> Result<u32, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let n = lengths.len();
    let mut left = 0;
    let mut i = m;
    // Whether the leader was placed by the aim rule or is the moved joint (then it is on its side of
    // the eyelet ahead by construction, and its old link says nothing after a slide).
    let mut aimed = true;
    loop {
        if stop == Some(i) {
            break;
        }
        let f = if up {
            if i == n {
                break;
            }
            i + 1
        } else {
            if i == 0 {
                break;
            }
            i - 1
        };
        let link = i.min(f);
        let len = lengths[link];
        let Some(e) = eyelets.iter_mut().find(|e| e.threaded && e.link == link) else {
            // The tractrix: the link as follower − leader, the leader's displacement.
            let step = tractrix_step(&(old[f] - old[i]), &(new[i] - old[i]), len);
            new[f] = old[f] + step.tail_shift;
            if let Some(lim) = limits
                && (i != m || steer_start)
            {
                steer(lim, new, lengths, i, f, eyelets);
            }
            aimed = false;
            i = f;
            continue;
        };
        if !aimed && turns_over(&old[i], &old[f], &new[i], &e.at, len) {
            // The leader (placed by the tractrix) was pushed through the eyelet: the eyelet passes
            // to the link behind it, whose leader is aimed at it; the follower then follows by the
            // tractrix. A leader too far from the eyelet to reach it would fold the rope: refused.
            let back = if up { i - 1 } else { i + 1 };
            let back_len = lengths[i.min(back)];
            if (new[back] - e.at).norm() > back_len {
                return Err(EyeletError::Fold { link });
            }
            e.link = i.min(back);
            new[i] = aim(&new[back], &e.at, back_len, &(old[i] - old[back]));
            let step = tractrix_step(&(old[f] - old[i]), &(new[i] - old[i]), len);
            new[f] = old[f] + step.tail_shift;
            aimed = false;
            i = f;
            continue;
        }
        aimed = true;
        let dist = (new[i] - e.at).norm();
        new[f] = aim(&new[i], &e.at, len, &(old[i] - old[f]));
        if dist > len {
            // Slid through: the follower stays on the leader's side; the eyelet passes to the next
            // link, or the chain leaves it at its end. Not past the walk's last joint (a held
            // joint): the rope is pulled taut against it.
            if stop == Some(f) {
                return Err(EyeletError::PastStop { joint: f });
            } else if f == 0 || f == n {
                e.threaded = false;
                left += 1;
            } else {
                e.link = if up { f } else { f - 1 };
            }
        }
        i = f;
    }
    Ok(left)
}

/// A rope's link lengths and its joint limits, for the walks.
pub(super) type Rope<'a, T> = (&'a [T], Option<&'a crate::limits::JointLimits<T>>);

/// The joints of the links through the threaded `eyelets` (ascending, in `free`): not limited, since
/// the tissue takes the suture's bend where it passes through (the chain's straight link through an
/// eyelet stands for the suture's curve along the needle's track, so the rope turns there by about
/// the angle the track enters at).
pub(super) fn free_joints<T: Real, const D: usize>(
    eyelets: &[Eyelet<T, D>],
    free: &mut Vec<usize>,
) {
    free.clear();
    for e in eyelets.iter().filter(|e| e.threaded) {
        free.extend([e.link, e.link + 1]);
    }
    free.sort_unstable();
    free.dedup();
}

/// Turns the link from joint `i` to its follower `f` (just placed by the tractrix in `new`) back into
/// joint `i`'s limit about the link from `i`'s own leader, as a limited chain's sweep does
/// ([`crate::limits`]); not at an end, nor at a joint of a link through an eyelet ([`free_joints`]).
pub(super) fn steer<T: Real, const D: usize>(
    lim: &crate::limits::JointLimits<T>,
    new: &mut [Vector<T, D>],
    lengths: &[T],
    i: usize,
    f: usize,
    eyelets: &[Eyelet<T, D>],
) where
    Vector<T, D>: Embed3<T>,
{
    let up = f > i;
    let n = lengths.len();
    if !lim.limits(i)
        || (up && i == 0)
        || (!up && i == n)
        || eyelets
            .iter()
            .any(|e| e.threaded && (e.link == i || e.link + 1 == i))
    {
        return;
    }
    let lead = if up { i - 1 } else { i + 1 };
    let prev = new[i] - new[lead];
    let v = new[f] - new[i];
    if let Some(c) = lim.clamp(i, &prev, lengths[i.min(lead)], &v, lengths[i.min(f)], !up) {
        new[f] = new[i] + c;
    }
}

/// The follower of a leader at `leader` whose link passes through `p`: a link length from the leader
/// toward `p` (along `fallback`, the link's direction from follower to leader before the move, when
/// the leader is on `p`).
pub(super) fn aim<T: Real, const D: usize>(
    leader: &Vector<T, D>,
    p: &Vector<T, D>,
    len: T,
    fallback: &Vector<T, D>,
) -> Vector<T, D> {
    let d = leader - p;
    let dist = d.norm();
    if dist > T::zero() {
        leader - d * (len / dist)
    } else {
        leader - fallback * (len / fallback.norm())
    }
}

/// The contacts after substep `s` of an eyelet's move carrying `link`, the links through the eyelets
/// fixed; the next substep starts from the resolved pose (written to the workspace's `new`).
fn resolve_carried<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    link: usize,
    eyelets: &[Eyelet<T, D>],
    s: u32,
    model: &crate::collision::CollisionModel<T, D>,
    cws: &mut crate::collision::CollisionWorkspace<T, D>,
    ws: &mut EyeletWorkspace<T, D>,
) -> Result<(), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    chain.set_positions(&ws.new)?;
    ws.limits.apply(chain, eyelets);
    let (through, pressed) = through_block(&ws.new, chain.min_length(), eyelets, model);
    cws.pass_through(through, pressed);
    resolve_threaded(chain, link, eyelets, s, model, cws, &mut ws.fixed)?;
    chain.write_positions(&mut ws.new);
    if cws.together() {
        // Under a pull (tissue that gives, drawn in by a tightening): the held sides re-solved
        // round a tightened surgeon's knot lost the knot without this.
        no_jump(chain, model, &ws.old, &ws.new, s)?;
    }
    Ok(())
}
