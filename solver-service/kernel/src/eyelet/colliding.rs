//! Threaded moves with collision: the rope kept clear of itself and its obstacles while it slides through its eyelets, and pushed by an obstacle.

use super::*;

/// [`move_threaded`] with collision: after every substep the chain's contacts are resolved as a
/// move's are ([`crate::collision`]), with the moved joint and the two joints of every threaded
/// eyelet's link fixed, so that each eyelet stays exactly on its link while the rope elsewhere is
/// pushed apart and re-solved between the fixed joints. Substeps are at most half the shortest link
/// and at most half the smallest clearance. Refused, changing nothing, as [`move_threaded`] is, and
/// when the contacts cannot be resolved (locked) or would take more work than the workspace's meter
/// allows.
#[allow(clippy::too_many_arguments)]
pub fn move_threaded_colliding<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    model: &crate::collision::CollisionModel<T, D>,
    cws: &mut crate::collision::CollisionWorkspace<T, D>,
    ws: &mut EyeletWorkspace<T, D>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    threaded(
        chain,
        joint,
        target,
        eyelets,
        max_substeps,
        ws,
        Some((model, cws)),
    )
}

/// Moves obstacle `which` of `model` (an instrument) to the pose `to`, pushing the threaded chain
/// out of its way as [`crate::collision::push_by_obstacle`] does, with the two joints of every
/// threaded eyelet's link kept where they are besides the held joints: each eyelet stays exactly on
/// its link (the rope does not slide through an eyelet under an instrument's push). A contact only
/// those joints could part locks the push; on any error the chain is unchanged.
#[allow(clippy::too_many_arguments)]
pub fn push_threaded<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    model: &crate::collision::CollisionModel<T, D>,
    which: usize,
    to: &crate::collision::Obstacle<T, D>,
    eyelets: &[Eyelet<T, D>],
    max_substeps: u32,
    cws: &mut crate::collision::CollisionWorkspace<T, D>,
    ws: &mut EyeletWorkspace<T, D>,
) -> Result<crate::chain::MoveOutcome, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    ws.fixed.clear();
    for e in eyelets.iter().filter(|e| e.threaded) {
        ws.fixed.extend([e.link, e.link + 1]);
    }
    ws.fixed.sort_unstable();
    ws.fixed.dedup();
    ws.old.resize(chain.n_links() + 1, Vector::zeros());
    chain.write_positions(&mut ws.old);
    let (through, pressed) = through_block(&ws.old, chain.min_length(), eyelets, model);
    cws.pass_through(through, pressed);
    let mut push = |chain: &mut Chain<T, D>, ws: &mut EyeletWorkspace<T, D>| {
        crate::collision::push_fixing(chain, model, which, to, max_substeps, &ws.fixed, cws)
            .map_err(EyeletError::from)
    };
    if chain.joint_limits().is_none() {
        return push(chain, ws);
    }
    // The eyelets stay on their links under a push.
    let mut eyelets = eyelets.to_vec();
    freeing(chain, &mut eyelets, ws, |chain, _, ws| push(chain, ws))
}

/// The links of a rope at `pos` that pass through the model's block (tissue,
/// [`crate::collision::Obstacle::Block`]): from the link before the first threaded eyelet's to the
/// link after the last one's; to the head while the rope has gone in and not out (an odd number of
/// eyelets: the needle on its way through, its way out made an eyelet only after the move); and,
/// while the head is within a thickness of the block (the needle's point going in), from the link
/// before the first one back from the head that is not. Each span is widened by the links within a
/// thickness of its ends (at least one): the eyelet link's joints, which the resolution keeps where
/// they are, lie within a link of the surface, so the rope beside them may lie on it or dip into it
/// (seen at 160 links, a joint beside the entry under the surface, the rope pushed out of the
/// block there locked the pull). Empty when the model has no block.
///
/// With it, how many links either side of the span press into the block rather than keep their
/// radius from it ([`PRESSED`] thicknesses of rope, at least one link): a suture drawn out of a hole
/// at a shallow angle lies on the tissue beside it (at 160 links of the whole stitch the pull rose
/// about 5° from the exit, and the links just past the span, pushed out of the tissue by their
/// radius, locked every move of the last fifth of the needle's pass; with them pressing in, none).
pub(super) fn through_block<T: Real, const D: usize>(
    pos: &[Vector<T, D>],
    min_length: T,
    eyelets: &[Eyelet<T, D>],
    model: &crate::collision::CollisionModel<T, D>,
) -> (core::ops::Range<usize>, usize) {
    let Some((lo, hi)) = model.obstacles.iter().find_map(|o| match o {
        crate::collision::Obstacle::Block { lo, hi } => Some((lo, hi)),
        _ => None,
    }) else {
        return (0..0, 0);
    };
    let n = pos.len() - 1;
    let margin = model.options.thickness;
    let inside =
        |p: &Vector<T, D>| (0..D).all(|k| lo[k] - margin <= p[k] && p[k] <= hi[k] + margin);
    let mut span: Option<(usize, usize)> = None;
    let mut widen = |a: usize, b: usize| {
        span = Some(span.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
    };
    // The links within a thickness of a span's end, and one more.
    let beside = 1 + (margin / min_length).ceil().to_f64().min(n as f64) as usize;
    let mut threaded = eyelets.iter().filter(|e| e.threaded).map(|e| e.link);
    if let Some(first) = threaded.next() {
        let (count, last) = threaded.fold((1usize, first), |(c, _), l| (c + 1, l));
        let end = if count % 2 == 1 {
            n
        } else {
            (last + 1 + beside).min(n)
        };
        widen(first.saturating_sub(beside), end);
    }
    if inside(&pos[n]) {
        let mut j = n;
        while j > 0 && inside(&pos[j]) {
            j -= 1;
        }
        widen(j.saturating_sub(beside), n);
    }
    let pressed = (margin * T::lit(PRESSED) / min_length)
        .ceil()
        .to_f64()
        .clamp(1.0, n as f64) as usize;
    (span.map_or(0..0, |(a, b)| a..b), pressed)
}

/// How far from a hole, in thicknesses of rope along it beyond the links that pass through the
/// tissue, the suture may press into the tissue by up to its radius ([`through_block`]).
pub(super) const PRESSED: f64 = 4.0;

/// The substeps `k` of a move along `way` raised to at most half the smallest clearance each (no
/// link passes another within a substep), at most `max_substeps`.
pub(super) fn clearance_substeps<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    model: &crate::collision::CollisionModel<T, D>,
    way: &Vector<T, D>,
    k: T,
    max_substeps: u32,
) -> Result<(T, u32), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let half = crate::collision::smallest_clearance(chain, model) * T::lit(0.5);
    let k = k.max((way.norm() / half).ceil());
    if k.to_f64().is_nan() || k > T::lit(f64::from(max_substeps.max(1))) {
        return Err(ChainError::TooManySubsteps {
            required: k.to_f64().min(u64::MAX as f64) as u64,
            limit: max_substeps,
        }
        .into());
    }
    Ok((k, k.to_f64() as u32))
}

/// Resolves the chain's contacts after a substep of a threaded move: `hand` and the two joints of
/// every threaded eyelet's link fixed (their list built in `fixed`).
pub(super) fn resolve_threaded<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    hand: usize,
    eyelets: &[Eyelet<T, D>],
    substep: u32,
    model: &crate::collision::CollisionModel<T, D>,
    cws: &mut crate::collision::CollisionWorkspace<T, D>,
    fixed: &mut Vec<usize>,
) -> Result<(), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    fixed.clear();
    for e in eyelets.iter().filter(|e| e.threaded) {
        fixed.extend([e.link, e.link + 1]);
    }
    fixed.extend(chain.held());
    fixed.retain(|&j| j != hand);
    fixed.sort_unstable();
    fixed.dedup();
    crate::collision::resolve_fixed(chain, hand, fixed, substep, model, cws)?;
    Ok(())
}

/// Whether a threaded move of `joint` to `target` may run: the joint on the chain, the target finite,
/// the threaded eyelets in the order of their links.
pub(super) fn admit<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    joint: usize,
    target: &Vector<T, D>,
    eyelets: &[Eyelet<T, D>],
) -> Result<(), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let n = chain.n_links();
    if joint > n {
        return Err(ChainError::JointOutOfRange { joint, last: n }.into());
    }
    if !crate::math::all_finite(target) {
        return Err(ChainError::NonFinite.into());
    }
    let threaded = || eyelets.iter().filter(|e| e.threaded).map(|e| e.link);
    if threaded().zip(threaded().skip(1)).any(|(a, b)| b <= a) {
        return Err(EyeletError::Unordered);
    }
    Ok(())
}

/// No two threaded eyelets within one link of each other.
pub(super) fn apart<T: Real, const D: usize>(eyelets: &[Eyelet<T, D>]) -> Result<(), EyeletError> {
    let mut last: Option<(usize, usize)> = None;
    for (i, e) in eyelets.iter().enumerate().filter(|(_, e)| e.threaded) {
        if let Some((a, link)) = last
            && e.link <= link + 1
        {
            return Err(EyeletError::TooClose { a, b: i });
        }
        last = Some((i, e.link));
    }
    Ok(())
}
