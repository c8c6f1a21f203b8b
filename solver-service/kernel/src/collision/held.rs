//! A move of a rope with held joints among its contacts: each substep resolved, resumed or locked.

use super::*;

/// [`move_joint_colliding`] for a chain with held joints: each substep is a move with holds
/// ([`crate::hold`]), then contacts are resolved with the hand and the held joints fixed; a contact only
/// they could resolve locks the move.
#[allow(clippy::too_many_arguments)]
pub(super) fn move_held_colliding<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    start: Vector<T, D>,
    target: Vector<T, D>,
    k: u32,
    opts: &MoveOptions<T>,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let held: Vec<usize> = chain.held().filter(|&j| j != joint).collect();
    // Each substep records its passes, or the move goes on from those a move before it recorded.
    let keep = ws.unfinished.keep;
    let one = MoveOptions {
        substeps: crate::chain::Substeps::Fixed(1),
        max_substeps: 1,
        ..*opts
    };
    if keep && ws.can_resume(chain, joint, &target) {
        return resume_and_go_on(chain, joint, target, &held, opts, model, ws);
    }
    // A resumed pull of this state that jumped: its piece first, as two halves, then on from its
    // hand toward the target in `k` substeps.
    let halved = if keep {
        ws.halving(chain, joint, &target)
    } else {
        None
    };
    let origin = halved.map_or(start, |(hand, _)| hand);
    let backup = chain.clone();
    let sd = (target - origin) / T::lit(k as f64);
    let mut outcome = MoveOutcome {
        substeps: k,
        ..MoveOutcome::default()
    };
    ws.pos.resize(chain.n_links() + 1, Vector::zeros());
    // Each substep's move with holds is charged its bound (the passes its options allow over its
    // held sides, the links from the joint to the nearest held joint each way) before it runs, and
    // given back what its iterations did not use after; the free sides' sweeps, the copy back and
    // the closing are one pass over the rope.
    let charge = HeldCharge::of(chain, joint, opts);
    // The displacement guard (with `solve_contacts_together`: a pull): a held side's solve and the
    // re-solves between fixed joints can move a joint much farther than the hand, and a joint that
    // jumps more than half the smallest clearance in one substep can carry its link through another
    // (the swept-volume check of `watch --crossings` saw a tightening pull carry a joint several
    // times farther than the hand, through a knot). Such a substep is done again as two halves from where it
    // started, at most `GUARD_SPLITS` deep; one that still jumps at the deepest split locks the
    // move. Not on plain moves: on unit links held sides move joints more than half a clearance at
    // every substep of a tie, and the built-in knots failed to tie with it.
    let limit = smallest_clearance(chain, model) * T::lit(0.5);
    let mut pieces: Vec<(Vector<T, D>, u32)> = Vec::new();
    if let Some((hand, depth)) = halved {
        pieces.push((hand, depth));
        pieces.push((start + (hand - start) * T::lit(0.5), depth));
    }
    let mut from = start;
    let mut s = 0u32;
    // The last substep made whole (a move stopped short keeps the state of its last piece).
    let mut last_whole = 0u32;
    // Substeps left (`s` counts the ones done) and the stack of split pieces: (hand's end, depth).
    while s < k || !pieces.is_empty() {
        let (hand, depth) = match pieces.pop() {
            Some(p) => p,
            None => {
                s += 1;
                let hand = if s == k {
                    target
                } else {
                    origin + sd * T::lit(s as f64)
                };
                (hand, 0)
            }
        };
        if !ws.meter.charge(charge.bound) {
            let e = ws.meter.over(s);
            return stop_here(chain, backup, None, outcome, e, (last_whole, k), ws.frame);
        }
        let piece_backup = chain.clone();
        ws.pos_before.resize(chain.n_links() + 1, Vector::zeros());
        chain.write_positions(&mut ws.pos_before);
        match crate::hold::move_held(chain, joint, hand, &one) {
            Ok(o) => {
                outcome.paper_fallbacks = outcome.paper_fallbacks.saturating_add(o.paper_fallbacks);
                outcome.held_iterations = outcome.held_iterations.saturating_add(o.held_iterations);
                ws.meter.refund(charge.unused(o.held_iterations));
            }
            Err(e) => {
                let made = Some(piece_backup);
                return stop_here(chain, backup, made, outcome, e, (last_whole, k), ws.frame);
            }
        }
        chain.write_positions(&mut ws.pos);
        match resolve_recording(chain, (joint, hand, depth), &held, keep, limit, model, ws) {
            Ok((iterations, contacts)) => {
                outcome.collision_iterations =
                    outcome.collision_iterations.saturating_add(iterations);
                outcome.contacts = outcome.contacts.saturating_add(contacts);
            }
            Err(stop) => {
                let e = stop.error(s, &ws.meter);
                let made = Some(piece_backup);
                return stop_here(chain, backup, made, outcome, e, (last_whole, k), ws.frame);
            }
        }
        let jump = match settle_substep(chain, joint, &mut ws.pos, &ws.pos_before) {
            Ok(jump) => jump,
            Err(e) => {
                let made = Some(piece_backup);
                return stop_here(chain, backup, made, outcome, e, (last_whole, k), ws.frame);
            }
        };
        if ws.together && jump > limit {
            if depth >= GUARD_SPLITS {
                let e = ChainError::Jumped {
                    substep: s,
                    jump: jump.to_f64(),
                };
                let made = Some(piece_backup);
                return stop_here(chain, backup, made, outcome, e, (last_whole, k), ws.frame);
            }
            // Again as two halves: the second half's end first on the stack, popped last.
            *chain = piece_backup;
            let mid = from + (hand - from) * T::lit(0.5);
            pieces.push((hand, depth + 1));
            pieces.push((mid, depth + 1));
            outcome.substeps = outcome.substeps.saturating_add(1);
            continue;
        }
        from = hand;
        if pieces.is_empty() {
            last_whole = s;
        }
    }
    Ok(outcome)
}

/// What one substep of a move of `joint` with holds is charged, in meter units: before it runs,
/// the bound of its held sides' iterations (each side solved on its own, an iteration a pass over
/// the longer side) and one pass over the rope; after it ran, what its iterations used.
#[derive(Clone, Copy, Debug)]
struct HeldCharge {
    /// The charge before the substep runs: `per_iteration × passes bound × sides + sweep`.
    bound: u64,
    /// One held iteration: a pass over the longer held side.
    per_iteration: u64,
    /// One pass over the whole rope (the free sides' sweeps, the copy back and the closing).
    sweep: u64,
}

impl HeldCharge {
    fn of<T: Real, const D: usize>(chain: &Chain<T, D>, joint: usize, opts: &MoveOptions<T>) -> Self
    where
        Vector<T, D>: Embed3<T>,
    {
        let (lo, hi) = chain.held_around(joint);
        let sides = [lo.map(|h| joint - h), hi.map(|h| h - joint)];
        let longest = sides.iter().flatten().copied().max().unwrap_or(0) as u64;
        let count = sides.iter().flatten().count() as u64;
        let per_iteration = longest.saturating_mul(cost::LINK_STEP);
        let sweep = (chain.n_links() as u64).saturating_mul(cost::LINK_STEP);
        let passes = opts.held.passes_bound(chain.joint_limits().is_some());
        let bound = per_iteration
            .saturating_mul(passes)
            .saturating_mul(count)
            .saturating_add(sweep);
        Self {
            bound,
            per_iteration,
            sweep,
        }
    }

    /// What a substep whose held sides ran `iterations` gives back of its bound.
    fn unused(&self, iterations: u32) -> u64 {
        let used = self
            .per_iteration
            .saturating_mul(u64::from(iterations))
            .saturating_add(self.sweep)
            .min(self.bound);
        self.bound - used
    }
}

/// A move that resumes the substep a move before it recorded ([`resume_held`]): the substep
/// finished (its hand carried to `target` first when that is within the drift), then on toward
/// `target` as a move of its own. Inside a frame an unfinished or locked resumption stops short
/// where the rope was.
fn resume_and_go_on<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    held: &[usize],
    opts: &MoveOptions<T>,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let one = MoveOptions {
        substeps: crate::chain::Substeps::Fixed(1),
        max_substeps: 1,
        ..*opts
    };
    let u = &ws.unfinished;
    let recorded = u.target.first().copied().unwrap_or(target);
    // A piece of a split substep is resumed to its own hand: carried on to a target within the
    // drift it would be the larger piece that jumped again.
    let to = if u.depth == 0 && (recorded - target).norm() <= u.drift {
        target
    } else {
        recorded
    };
    // Refused outside a frame, the chain is put back as it was before the resumption.
    let backup = (!ws.frame && to != target).then(|| chain.clone());
    let mut outcome = match resume_held(chain, joint, to, held, &one, model, ws) {
        Ok(o) => o,
        // Out of work again, or locked: inside a frame it stops short where it was.
        Err(error) if ws.frame && stops_short_on(&error) => {
            return Ok(MoveOutcome {
                short: Some(Short {
                    error,
                    made: 0,
                    of: 1,
                }),
                ..MoveOutcome::default()
            });
        }
        Err(e) => return Err(e),
    };
    if to != target {
        match move_joint_colliding(chain, joint, target, opts, model, ws) {
            Ok(o) => outcome.add(&o),
            Err(e) => {
                if let Some(b) = backup {
                    *chain = b;
                }
                return Err(e);
            }
        }
    }
    Ok(outcome)
}

/// A piece's contacts resolved with the hand (`joint`, put at `hand`; the piece split `depth`
/// times) and `held` fixed; with
/// `record` its passes recorded and, when its work runs out, kept to be resumed from the joints the
/// piece started from ([`CollisionWorkspace::keep_unfinished`]; `half` half the smallest
/// clearance).
#[allow(clippy::too_many_arguments)]
fn resolve_recording<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    (joint, hand, depth): (usize, Vector<T, D>, u32),
    held: &[usize],
    record: bool,
    half: T,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<(u32, u32), Stop<T>>
where
    Vector<T, D>: Embed3<T>,
{
    if record {
        // The passes about to be recorded replace the ones kept: a resolution kept before, of
        // another move, can no longer be resumed.
        ws.unfinished.ready = false;
    }
    ws.unfinished.recording = record;
    ws.unfinished.recorded = false;
    let resolved = resolve(chain, joint, held, false, model, ws);
    ws.unfinished.recording = false;
    if record && ws.unfinished.recorded && matches!(resolved, Err(Stop::OverWork)) {
        ws.unfinished.ready_for(
            joint,
            hand,
            held,
            &ws.pos_before,
            (half * T::lit(0.5), depth),
        );
    }
    resolved
}

/// How a move with holds that cannot go on ends: with [`CollisionWorkspace::stop_short`] on and a
/// stop that the rope met ([`stops_short_on`]), stopped short at `made` (the state before the piece
/// that failed; `None`: the chain as it stands), `done.0` whole substeps of `done.1`; else refused
/// with the chain restored from `backup`.
#[allow(clippy::too_many_arguments)]
fn stop_here<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    backup: Chain<T, D>,
    made: Option<Chain<T, D>>,
    mut outcome: MoveOutcome,
    error: ChainError,
    (whole, of): (u32, u32),
    frame: bool,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    if frame && stops_short_on(&error) {
        if let Some(m) = made {
            *chain = m;
        }
        outcome.substeps = whole;
        outcome.short = Some(Short {
            error,
            made: whole,
            of,
        });
        return Ok(outcome);
    }
    *chain = backup;
    Err(error)
}

/// A substep's end once its contacts are resolved: the chain placed where the passes left it (its
/// origin at `pos[0]` unless joint 0 is held, the hand's pin re-recorded), its joint limits checked
/// (between held joints the passes re-solve the rope without steering them), its joints written to
/// `pos`; the farthest any joint moved from `before`. On an error the caller restores the chain.
pub(super) fn settle_substep<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    pos: &mut [Vector<T, D>],
    before: &[Vector<T, D>],
) -> Result<T, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    if !chain.is_held(0) {
        chain.translate_to(pos[0]);
    }
    chain.repin(joint);
    chain.check_limits()?;
    chain.write_positions(pos);
    Ok(pos
        .iter()
        .zip(before)
        .map(|(a, b)| (a - b).norm())
        .fold(T::zero(), |m, d| if d > m { d } else { m }))
}

/// The move of a single substep whose resolution ran out of work ([`Unfinished`]), resumed from its
/// last recorded pass with the work the meter allows now: done as [`move_held_colliding`] finishes a
/// substep (the limits checked, no joint farther than half the smallest clearance from where the
/// move started), or out of work again with the passes recorded so far kept. On any error the chain
/// is unchanged.
#[allow(clippy::too_many_arguments)]
pub(super) fn resume_held<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    held: &[usize],
    one: &MoveOptions<T>,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let u = &mut ws.unfinished;
    if let Some(e) = u.locked {
        return Err(e);
    }
    let backup = chain.clone();
    let Some(saved) = u.chain.as_ref() else {
        u.ready = false;
        return Err(ChainError::BadOption("no unfinished resolution to resume"));
    };
    chain.copy_from(saved);
    ws.pos.clone_from(&u.pos);
    ws.pos_prev.clone_from(&u.pos);
    if u.target.first() != Some(&target) {
        // The hand wandered within the drift: carried there from the recorded passes' pose (a held
        // move, charged as a substep's), the passes go on from it.
        u.target.clear();
        u.target.push(target);
        let charge = HeldCharge::of(chain, joint, one);
        if !ws.meter.charge(charge.bound) {
            *chain = backup;
            return Err(ws.meter.over(1));
        }
        match crate::hold::move_held(chain, joint, target, one) {
            Ok(o) => {
                ws.meter.refund(charge.unused(o.held_iterations));
            }
            Err(e) => {
                *chain = backup;
                return Err(e);
            }
        }
        chain.write_positions(&mut ws.pos);
    }
    let u = &mut ws.unfinished;
    u.resume_at = Some(u.state);
    u.recording = true;
    u.recorded = false;
    let alone = u.state.stalled;
    let resolved = resolve(chain, joint, held, false, model, ws);
    ws.unfinished.recording = false;
    ws.unfinished.resume_at = None;
    let (iterations, contacts) = match resolved {
        Ok(done) => done,
        Err(stop) => {
            // Out of work again: the passes recorded go on next time. Locked: the same move locks
            // at once next time.
            let over = matches!(stop, Stop::OverWork);
            let e = stop.error(1, &ws.meter);
            // Out of work before its next pass, with no projection left to give up, the same
            // request would do the same work again and again: like a locked one, it is refused so
            // at once from now on.
            let progressed = ws.unfinished.recorded || !alone;
            if !(over && progressed) {
                ws.unfinished.locked = Some(e);
            }
            *chain = backup;
            return Err(e);
        }
    };
    let jump = match settle_substep(chain, joint, &mut ws.pos, &ws.unfinished.base) {
        Ok(jump) => jump,
        Err(e) => {
            ws.unfinished.locked = Some(e);
            *chain = backup;
            return Err(e);
        }
    };
    // The displacement guard of a substep, on pulls only as there ([`move_held_colliding`]): a
    // resumed pull that jumped is answered out of work and leaves its piece to be done again as two
    // halves by the next pull from the same state ([`Unfinished::halve`]); at the deepest split it
    // locks, as a fresh piece does. On a plain move a substep is never guarded, and a resumed one
    // that was would throw its finished passes away and start them again, every time (history.md,
    // issue 68's eighth session).
    if ws.together && jump > smallest_clearance(chain, model) * T::lit(0.5) {
        *chain = backup;
        let u = &mut ws.unfinished;
        if u.depth < GUARD_SPLITS {
            u.ready = false;
            u.halve = Some(u.depth + 1);
            return Err(ws.meter.over(1));
        }
        let e = ChainError::Jumped {
            substep: 1,
            jump: jump.to_f64(),
        };
        u.locked = Some(e);
        return Err(e);
    }
    ws.unfinished.ready = false;
    Ok(MoveOutcome {
        substeps: 1,
        collision_iterations: iterations,
        contacts,
        ..MoveOutcome::default()
    })
}
