//! Eyelets: fixed points a chain passes through, the rope sliding through each in both directions
//! (issue 39: a suture through its entry and exit points in tissue).
//!
//! An eyelet is a point `P` the chain must pass through: some link's segment contains `P`. The rope
//! is free to slide through it, and the point of the rope at `P` changes as it does. A move of joint
//! `m` runs the tractrix out from `m` on each side, as [`Chain::move_joint`] does, link by link; at the
//! link that passes through an eyelet the follower is not placed by the tractrix but on the ray from
//! its (moved) leader through `P`, a link length from the leader (the *aim rule*): the link's line
//! passes through `P` by construction, exactly, and the rope beyond follows from there as from a
//! moving leader. When the leader has drawn away from `P` by more than a link, the follower stays on
//! the leader's side and the eyelet passes to the next link, the next follower aimed at `P` too: the
//! rope slides through by as many links as the pull asks, in one step, with no per-step limit. When a
//! leader is pushed past `P` (the rope pushed through), the eyelet passes to the link on the leader's
//! other side and the leader is aimed at `P` from its own leader. When the chain's end slides through,
//! the chain leaves the eyelet.
//!
//! A move is split into substeps of at most half the shortest link, so that a push carries no joint
//! past more than one eyelet in one substep (the aim rule alone would pull through by any length). Two eyelets may not come within one link of each other
//! along the rope (the link through both would be overconstrained): such a move is refused, the chain
//! unchanged.
//!
//! **Held joints.** On a side of the moved joint with a held joint (an anchor, a grasp), the rope
//! between them is a fixed-base chain threaded through the eyelets between: the walk from the moved
//! joint to the held one and the walk back from the held joint (put back where it is held) to the
//! moved one alternate, as FABRIK's passes do, each a tractrix walk with the aim rule; when the walk
//! out meets the held joint within a tolerance, the two links before it close on it in closed form.
//! A nearly taut rope passes each correction on almost undamped, so after a few alternations (or one
//! that stalls) Korein & Badler's reach hierarchy finishes from the last pose: from the moved joint
//! on its target (else from the held joint) each link keeps its direction unless the rope after it
//! could then no longer reach the far end through the eyelets ahead, the rope is led straight to an
//! eyelet from the link that passed through it before, and the last two links close on the far end.
//! The held joints stay bit for bit, the moved joint lands on its target, and every length and eyelet
//! is exact. A target farther from the held joint, along the shortest way through the eyelets
//! between, than the rope between them is refused with the nearest point that way reaches; within
//! about a link of taut a move may be refused as not converged (a link passes straight through an
//! eyelet, so the rope cannot bend at it). An eyelet may not lie on the two links next to a held
//! joint on the moved joint's side.
//!
//! **Friction** ([`EyeletWorkspace::with_friction`]): above 0 a move first holds the rope in every
//! eyelet (both joints of the link through it, as held joints) and slides it only when the rope on
//! the moved joint's side is taut; infinite friction never slides.
//!
//! **Joint limits** (a suture's bend radius, [`crate::limits`]): the walks turn each link they place
//! by the tractrix back into its joint's limit, as a limited chain's sweep does. The two joints of the
//! link through an eyelet are not limited: the tissue takes the suture's bend there (the straight
//! link through the point stands for the suture's curve along the needle's track, so the rope turns
//! there by about the angle the track meets the surface at). While a move runs those joints are freed
//! in the chain's limits, so the contacts' re-solve respects the rest; after it every other joint
//! must be within its limit (the aim rule, the closing two-link solutions and the contacts place
//! links unsteered), or the move is refused, changing nothing.
//!
//! Allocation-free per move: the positions are worked on in the caller's [`EyeletWorkspace`] (a
//! limited chain allocates its freed limits when its eyelets pass to other links).

use crate::chain::{Chain, ChainError};
use crate::limits::JointLimits;
use crate::link::tractrix_step;
use crate::math::{Embed3, Real, Vector};
use std::sync::Arc;

mod colliding;
mod hierarchy;
mod moving;
pub use colliding::*;
use hierarchy::*;
pub use moving::*;

/// One eyelet of a chain: where it is, and the link that passes through it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eyelet<T: Real, const D: usize> {
    /// The fixed point.
    pub at: Vector<T, D>,
    /// The link through it (joints `link` and `link + 1`); meaningless once `threaded` is false.
    pub link: usize,
    /// Whether the chain still passes through it (false once an end has slid out).
    pub threaded: bool,
}

/// Why an eyelet could not be threaded or a threaded move was refused (the chain unchanged).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EyeletError {
    /// No link of the chain passes within the tolerance of the point.
    #[error("no link passes through the eyelet at {distance:e} (link {link} comes nearest)")]
    NotOnChain {
        /// The nearest link.
        link: usize,
        /// Its distance from the point.
        distance: f64,
    },
    /// Two eyelets would lie within one link of each other along the rope.
    #[error("eyelets {a} and {b} would come within one link of each other along the rope")]
    TooClose {
        /// The eyelets, by index.
        a: usize,
        /// The eyelets, by index.
        b: usize,
    },
    /// A joint pushed through an eyelet too far from the joint before it to pass the eyelet on:
    /// the rope would fold through it.
    #[error("the rope would fold through the eyelet on link {link}")]
    Fold {
        /// The link.
        link: usize,
    },
    /// The eyelets are not in the order of their links along the rope.
    #[error("eyelets must be given in the order of their links along the rope")]
    Unordered,
    /// A walk along the rope slid an eyelet past the joint where it had to stop (a held joint): the
    /// rope pulled taut against it. Internal to a move with held joints, which reports it as not
    /// converged.
    #[error("the rope slid through an eyelet past joint {joint}")]
    PastStop {
        /// The joint.
        joint: usize,
    },
    /// A move with held joints closes the rope on each held joint by its two nearest links: an
    /// eyelet may not lie on them, nor the moved joint within a link of the held one.
    #[error(
        "a threaded move cannot close on held joint {held}: an eyelet or the moved joint is within two links of it"
    )]
    NearHeld {
        /// The held joint.
        held: usize,
    },
    /// The move itself (joint, target, substeps) is not valid.
    #[error(transparent)]
    Chain(#[from] ChainError),
}

impl<T: Real, const D: usize> Eyelet<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// The eyelet at `at`, threaded on the link of `chain` whose segment passes nearest to it, if
    /// within `tolerance` times that link's length.
    pub fn thread(
        chain: &Chain<T, D>,
        at: Vector<T, D>,
        tolerance: T,
    ) -> Result<Self, EyeletError> {
        let (mut best, mut best_d) = (0, T::lit(f64::INFINITY));
        let mut a = chain.joint(0);
        for k in 0..chain.n_links() {
            let b = a + chain.links()[k];
            let d = segment_point_distance(&a, &b, &at);
            if d < best_d {
                (best, best_d) = (k, d);
            }
            a = b;
        }
        if best_d <= tolerance * chain.lengths()[best] {
            Ok(Eyelet {
                at,
                link: best,
                threaded: true,
            })
        } else {
            Err(EyeletError::NotOnChain {
                link: best,
                distance: best_d.to_f64(),
            })
        }
    }

    /// How far the eyelet's point is from its link's segment (0 when exactly threaded), or `None`
    /// once the chain has left it.
    pub fn residual(&self, chain: &Chain<T, D>) -> Option<T> {
        self.threaded.then(|| {
            let a = chain.joint(self.link);
            segment_point_distance(&a, &(a + chain.links()[self.link]), &self.at)
        })
    }
}

/// The distance from `p` to the segment `a`–`b`.
fn segment_point_distance<T: Real, const D: usize>(
    a: &Vector<T, D>,
    b: &Vector<T, D>,
    p: &Vector<T, D>,
) -> T {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > T::zero() {
        ((p - a).dot(&ab) / l2).max(T::zero()).min(T::one())
    } else {
        T::zero()
    };
    (a + ab * t - p).norm()
}

/// The positions a threaded move works on, kept between moves.
#[derive(Clone, Debug)]
pub struct EyeletWorkspace<T: Real, const D: usize> {
    old: Vec<Vector<T, D>>,
    new: Vec<Vector<T, D>>,
    saved: Vec<(usize, bool)>,
    /// A move with held joints: the positions of the walks back from a held joint, and the eyelets
    /// ahead of the reach hierarchy's walk (index, the way from it to the target, its link before).
    alt: Vec<Vector<T, D>>,
    ahead: Vec<(usize, T, usize)>,
    /// A threaded move with collision: the chain before it, and the joints its resolution fixes.
    backup: Option<Chain<T, D>>,
    fixed: Vec<usize>,
    /// A move with held joints: how closely the rope must meet each held joint (a fraction of the
    /// rope's length between it and the moved joint) before the closing links take up the rest, and
    /// the most alternations per substep ([`EyeletWorkspace::with_holds`]).
    held_tolerance: f64,
    held_iterations: u32,
    /// Friction at the eyelets ([`EyeletWorkspace::with_friction`]).
    friction: f64,
    /// A limited chain's own limits while a move runs with the eyelets' joints freed.
    limits: FreedLimits<T>,
}

/// A limited chain's joint limits during a threaded move: its own, set aside, and the ones in place
/// with the joints of the links through the eyelets freed ([`free_joints`]), kept for the next
/// move while the eyelets stay on the same links.
#[derive(Clone, Debug)]
struct FreedLimits<T: Real> {
    own: Option<Arc<JointLimits<T>>>,
    free: Vec<usize>,
    /// The freed limits, the own limits and the joints they were made for.
    made: Option<Made<T>>,
}

/// Freed limits as [`FreedLimits`] keeps them: the freed, the own they came from, the joints freed.
type Made<T> = (Arc<JointLimits<T>>, Arc<JointLimits<T>>, Vec<usize>);

impl<T: Real> FreedLimits<T> {
    /// Puts into `chain` its own limits with the joints of the links through the threaded
    /// `eyelets` freed (nothing for a chain without limits).
    fn apply<const D: usize>(&mut self, chain: &mut Chain<T, D>, eyelets: &[Eyelet<T, D>])
    where
        Vector<T, D>: Embed3<T>,
    {
        let Some(own) = &self.own else {
            return;
        };
        free_joints(eyelets, &mut self.free);
        let fresh = match &self.made {
            Some((freed, of, joints)) if Arc::ptr_eq(of, own) && *joints == self.free => {
                freed.clone()
            }
            _ => {
                let freed = Arc::new(own.freed(&self.free));
                self.made = Some((freed.clone(), own.clone(), self.free.clone()));
                freed
            }
        };
        chain.replace_limits(Some(fresh));
    }
}

impl<T: Real, const D: usize> Default for EyeletWorkspace<T, D> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const D: usize> EyeletWorkspace<T, D> {
    /// An empty workspace (it grows to the chain on the first move).
    pub fn new() -> Self {
        EyeletWorkspace {
            old: Vec::new(),
            new: Vec::new(),
            saved: Vec::new(),
            alt: Vec::new(),
            ahead: Vec::new(),
            backup: None,
            fixed: Vec::new(),
            held_tolerance: 1e-9,
            held_iterations: 16,
            friction: 0.0,
            limits: FreedLimits {
                own: None,
                free: Vec::new(),
                made: None,
            },
        }
    }

    /// Friction at the eyelets: 0 (the default) lets the rope slide through them freely, dragged
    /// by the tractrix; any positive value makes it stick in each while the rope on the moved
    /// joint's side can make the move without sliding (the link through each eyelet then stays put,
    /// as if both its joints were held, and nothing beyond it moves), and slide, as without
    /// friction, only when it cannot: the rope there is taut. Infinite friction never slides: the
    /// eyelets act as holds, and a move the rope cannot make is refused. With an inextensible,
    /// massless rope Coulomb friction decides no more than that: how large a finite friction is would
    /// only change the force a taut rope needs to slide, which a kinematic solve does not compute
    /// (docs/eyelets.md).
    pub fn with_friction(mut self, friction: f64) -> Self {
        self.friction = if friction.is_finite() {
            friction.max(0.0)
        } else {
            f64::INFINITY
        };
        self
    }

    /// How a threaded move of a chain with held joints converges: the alternation stops when the
    /// rope meets each held joint within `tolerance` of the rope's length between it and the moved
    /// joint (at least 64 ε); after `max_iterations` alternations in a substep Korein & Badler's reach
    /// hierarchy finishes it (as [`crate::ReachOptions::hierarchy_after`] does for a fixed-base
    /// chain). The defaults: 1e-9 and 16.
    pub fn with_holds(mut self, tolerance: f64, max_iterations: u32) -> Self {
        self.held_tolerance = tolerance;
        self.held_iterations = max_iterations.max(1);
        self
    }
}

impl<T: Real, const D: usize> EyeletWorkspace<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// Keeps a copy of `chain` to put back if a move with collision is refused (no allocation once
    /// warm).
    fn keep(&mut self, chain: &Chain<T, D>) {
        match &mut self.backup {
            Some(b) if b.n_links() == chain.n_links() => b.copy_from(chain),
            b => *b = Some(chain.clone()),
        }
    }

    /// Puts the eyelets' links and flags back as [`EyeletWorkspace::begin`] saved them and, given
    /// `chain`, the chain as [`EyeletWorkspace::keep`] kept it (a refusal).
    fn put_back(&self, chain: Option<&mut Chain<T, D>>, eyelets: &mut [Eyelet<T, D>]) {
        if let (Some(c), Some(b)) = (chain, &self.backup) {
            c.copy_from(b);
        }
        for (e, &(link, on)) in eyelets.iter_mut().zip(&self.saved) {
            (e.link, e.threaded) = (link, on);
        }
    }

    /// Sized to `chain`, its positions in `new`, the eyelets' links and flags saved (for a refusal).
    fn begin(&mut self, chain: &Chain<T, D>, eyelets: &[Eyelet<T, D>]) {
        let n = chain.n_links();
        self.old.resize(n + 1, Vector::zeros());
        self.new.resize(n + 1, Vector::zeros());
        self.alt.resize(n + 1, Vector::zeros());
        chain.write_positions(&mut self.new);
        self.saved.clear();
        self.saved
            .extend(eyelets.iter().map(|e| (e.link, e.threaded)));
    }
}

/// The substeps of a move along `way`: at most half the shortest link each, at most `max_substeps`
/// (their count as `T` and as a number).
fn substeps<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    way: &Vector<T, D>,
    max_substeps: u32,
) -> Result<(T, u32), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let k = (way.norm() / (chain.min_length() * T::lit(0.5)))
        .ceil()
        .max(T::one());
    if k.to_f64().is_nan() || k > T::lit(f64::from(max_substeps.max(1))) {
        return Err(ChainError::TooManySubsteps {
            required: k.to_f64().min(u64::MAX as f64) as u64,
            limit: max_substeps,
        }
        .into());
    }
    Ok((k, k.to_f64() as u32))
}

/// What a threaded move did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Threaded {
    /// Substeps taken.
    pub substeps: u32,
    /// Eyelets the chain left during the move (an end slid out).
    pub left: u32,
    /// Forward-and-back alternations spent on the rope between the moved joint and held joints.
    pub held_iterations: u32,
    /// Whether the rope stuck in the eyelets (friction, [`EyeletWorkspace::with_friction`]): the
    /// links through them did not move.
    pub stuck: bool,
    /// A move with collision that stopped short inside its frame
    /// ([`crate::collision::CollisionWorkspace::stop_short`]); `None` when it was made whole.
    pub short: Option<crate::chain::Short>,
}

/// Moves joint `joint` of `chain` straight to `target` with the chain threaded through `eyelets`
/// (given in the order of their links along the rope; their links and `threaded` flags are updated).
/// At most `max_substeps` substeps (the move is split into substeps of at most half the shortest
/// link).
/// Held joints stay where they are (see the module docs). Refused, changing nothing (chain and
/// eyelets), when the eyelets are out of order or would come within a link of each other, the target
/// is out of the held rope's reach, a held side does not converge, or the move is invalid.
pub fn move_threaded<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    threaded(chain, joint, target, eyelets, max_substeps, ws, None)
}

/// A threaded move, with collision when `collision` is given: stuck in the eyelets first when there
/// is friction, sliding when that finds the rope taut (and the friction finite).
fn threaded<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
    mut collision: Option<Collision<'_, T, D>>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    freeing(chain, eyelets, ws, |chain, eyelets, ws| {
        threaded_sticking(
            chain,
            joint,
            target,
            eyelets,
            max_substeps,
            ws,
            collision.take(),
        )
    })
}

/// Runs `f` (a threaded move, an eyelet's, a push) on a limited chain with the joints of the links
/// through the eyelets freed of their limits ([`free_joints`]; `f` frees them again as the eyelets
/// pass along the rope), then checks the chain's own limits but at those joints after it: the walks
/// steer the links they place by the tractrix, not those the aim rule, the closing two-link
/// solutions and the contacts place. Refused with the chain and the eyelets' links as they were
/// (from the workspace's backup, which `f` keeps for a limited chain). The chain's own limits are
/// back in place however it ends.
fn freeing<T: Real, const D: usize, R>(
    chain: &mut Chain<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    ws: &mut EyeletWorkspace<T, D>,
    f: impl FnOnce(
        &mut Chain<T, D>,
        &mut [Eyelet<T, D>],
        &mut EyeletWorkspace<T, D>,
    ) -> Result<R, EyeletError>,
) -> Result<R, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    ws.limits.own = chain.shared_limits();
    if ws.limits.own.is_none() {
        return f(chain, eyelets, ws);
    }
    ws.keep(chain);
    ws.limits.apply(chain, eyelets);
    let done = f(chain, eyelets, ws);
    let own = ws.limits.own.take();
    chain.replace_limits(own.clone());
    let checked = done.and_then(|out| {
        free_joints(eyelets, &mut ws.limits.free);
        match chain.check_limits_except(&ws.limits.free) {
            Ok(()) => Ok(out),
            Err(e) => {
                ws.put_back(Some(chain), eyelets);
                Err(e.into())
            }
        }
    });
    chain.replace_limits(own);
    checked
}

/// [`threaded`] on a chain whose limits [`freeing`] has set.
fn threaded_sticking<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
    mut collision: Option<Collision<'_, T, D>>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let stick = sticks(eyelets, ws);
    let slides = ws.friction.is_finite();
    let mut once = |chain: &mut Chain<T, D>, eyelets: &mut [Eyelet<T, D>], stick| {
        let collision = collision.as_mut().map(|(m, c)| (*m, &mut **c));
        threaded_once(
            chain,
            (joint, target),
            eyelets,
            max_substeps,
            &mut *ws,
            stick,
            collision,
        )
    };
    match once(chain, eyelets, stick) {
        Err(e) if stick && taut(&e) && slides => once(chain, eyelets, false),
        Ok(mut o) => {
            o.stuck = stick;
            Ok(o)
        }
        r => r,
    }
}

/// A collision model and its workspace, for the moves that resolve contacts.
type Collision<'a, T, const D: usize> = (
    &'a crate::collision::CollisionModel<T, D>,
    &'a mut crate::collision::CollisionWorkspace<T, D>,
);

/// Whether a move sticks the rope in the eyelets first: friction, and an eyelet threaded.
fn sticks<T: Real, const D: usize>(eyelets: &[Eyelet<T, D>], ws: &EyeletWorkspace<T, D>) -> bool {
    ws.friction > 0.0 && eyelets.iter().any(|e| e.threaded)
}

/// Whether a refusal says the rope on the moved joint's side could not make the move with the
/// eyelets stuck (it is taut, or a stuck eyelet lies too near to close on): it then slides.
fn taut(e: &EyeletError) -> bool {
    matches!(
        e,
        EyeletError::NearHeld { .. }
            | EyeletError::Chain(
                ChainError::HeldUnreachable { .. } | ChainError::HeldNotConverged { .. }
            )
    )
}

/// Whether a threaded move with collision that met `e` stops short inside its frame rather than
/// being refused ([`crate::collision::stops_short_on`]; an eyelet that would come within a link of
/// another, or a walk that would fold the rope through one, as a lock).
fn stops_short(e: &EyeletError) -> bool {
    match e {
        EyeletError::Chain(c) => crate::collision::stops_short_on(c),
        EyeletError::TooClose { .. } | EyeletError::Fold { .. } => true,
        _ => false,
    }
}

/// A threaded move stopped short by `err` in substep `s` of `of` (an eyelet's error as a lock).
fn short_of(err: EyeletError, s: u32, of: u32) -> crate::chain::Short {
    crate::chain::Short {
        error: match err {
            EyeletError::Chain(c) => c,
            _ => ChainError::Locked {
                substep: s,
                iterations: 0,
                penetration: 0.0,
            },
        },
        made: s - 1,
        of,
    }
}

/// One try of a threaded move, the rope stuck in the eyelets (`stick`) or sliding; with collision,
/// the contacts resolved after every substep and the chain restored from the workspace's backup on a
/// refusal.
fn threaded_once<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    (joint, target): (usize, Vector<T, D>),
    eyelets: &mut [Eyelet<T, D>],
    max_substeps: u32,
    ws: &mut EyeletWorkspace<T, D>,
    stick: bool,
    mut collision: Option<Collision<'_, T, D>>,
) -> Result<Threaded, EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    admit(chain, joint, &target, eyelets)?;
    if collision.is_some() {
        ws.keep(chain);
    }
    ws.begin(chain, eyelets);
    let holds = Holds::of(chain, joint, &target, eyelets, ws, stick)?;
    let from = ws.new[joint];
    let way = target - from;
    let (mut k, mut steps) = substeps(chain, &way, max_substeps)?;
    if let Some((model, _)) = &collision {
        (k, steps) = clearance_substeps(chain, model, &way, k, max_substeps)?;
    }
    let mut out = Threaded::default();
    let frame = collision.as_ref().is_some_and(|(_, c)| c.stops_short());
    for s in 1..=steps {
        if collision.is_some() {
            // The pose the last resolution left.
            chain.write_positions(&mut ws.old);
        } else {
            std::mem::swap(&mut ws.old, &mut ws.new);
        }
        let to = from + way * (T::lit(f64::from(s)) / k);
        let done = substep(
            &ws.old,
            &mut ws.new,
            &mut ws.alt,
            (chain.lengths(), chain.joint_limits()),
            joint,
            to,
            eyelets,
            &holds,
            &mut ws.ahead,
        )
        .and_then(|left| {
            if let Some((model, cws)) = collision.as_mut() {
                set_threaded(chain, joint, &ws.new)?;
                // The eyelets may have passed to other links in the walk.
                ws.limits.apply(chain, eyelets);
                let (through, pressed) = through_block(&ws.new, chain.min_length(), eyelets, model);
                cws.pass_through(through, pressed);
                resolve_threaded(chain, joint, eyelets, s, model, cws, &mut ws.fixed)?;
                if cws.together() {
                    // A pull (a tightening): `watch --crossings` saw a tightened surgeon's knot over
                    // a bite lose its second throw without this. The pull stops there instead: the
                    // knot has jammed.
                    chain.write_positions(&mut ws.new);
                    no_jump(chain, model, &ws.old, &ws.new, s)?;
                }
            }
            Ok(left)
        });
        match done {
            Ok((left, iterations)) => {
                out.left += left;
                out.held_iterations += iterations;
                if frame {
                    // The state a move stopped short in a later substep keeps.
                    ws.keep(chain);
                    ws.saved.clear();
                    ws.saved
                        .extend(eyelets.iter().map(|e| (e.link, e.threaded)));
                }
            }
            Err(err) => {
                ws.put_back(collision.is_some().then_some(&mut *chain), eyelets);
                // A stuck try that finds the rope taut is refused: the rope slides instead.
                let slides = stick && ws.friction.is_finite() && taut(&err);
                if frame && !slides && stops_short(&err) {
                    out.short = Some(short_of(err, s, steps));
                    return Ok(out);
                }
                return Err(err);
            }
        }
        out.substeps = s;
    }
    if collision.is_none() {
        set_threaded(chain, joint, &ws.new)?;
    }
    Ok(out)
}

/// Refuses a substep (`Jumped`) in which a joint moved from `old` to `new` by more than half the
/// smallest clearance: its link could have been carried through another between the checks.
fn no_jump<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    model: &crate::collision::CollisionModel<T, D>,
    old: &[Vector<T, D>],
    new: &[Vector<T, D>],
    substep: u32,
) -> Result<(), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let limit = crate::collision::smallest_clearance(chain, model) * T::lit(0.5);
    let jump = new
        .iter()
        .zip(old)
        .map(|(a, b)| (a - b).norm())
        .fold(T::zero(), |m, d| if d > m { d } else { m });
    if jump > limit {
        return Err(ChainError::Jumped {
            substep,
            jump: jump.to_f64(),
        }
        .into());
    }
    Ok(())
}

/// Writes a threaded move's positions into the chain; a held moved joint is held where it landed.
fn set_threaded<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    positions: &[Vector<T, D>],
) -> Result<(), ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    chain.set_positions(positions)?;
    chain.repin(joint);
    Ok(())
}

/// The held joints a threaded move keeps: the nearest on each side of the moved joint (where it is
/// held), how closely the alternation must meet each (absolute), and the most alternations.
struct Holds<T: Real, const D: usize> {
    tail: Option<(usize, Vector<T, D>, T)>,
    head: Option<(usize, Vector<T, D>, T)>,
    max_iterations: u32,
}

impl<T: Real, const D: usize> Holds<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// The holds around `m` (none on a chain without held joints). Refused when the target is out of
    /// the reach the rope allows from a held joint through the eyelets between (the nearest point it
    /// reaches named), or a held joint is too near the moved joint or an eyelet to close on.
    fn of(
        chain: &Chain<T, D>,
        m: usize,
        target: &Vector<T, D>,
        eyelets: &[Eyelet<T, D>],
        ws: &EyeletWorkspace<T, D>,
        stick: bool,
    ) -> Result<Self, EyeletError> {
        let (mut lo, mut hi) = chain.held_around(m);
        if stick {
            // The rope stuck in an eyelet: both joints of the link through it held.
            for e in eyelets.iter().filter(|e| e.threaded) {
                for j in [e.link, e.link + 1] {
                    if j < m {
                        lo = Some(lo.map_or(j, |l| l.max(j)));
                    } else if j > m {
                        hi = Some(hi.map_or(j, |h| h.min(j)));
                    }
                }
            }
        }
        let tol = held_tolerance(ws);
        let one = |h| hold(chain, m, h, target, eyelets, &ws.new, tol);
        Ok(Holds {
            tail: lo.map(one).transpose()?,
            head: hi.map(one).transpose()?,
            max_iterations: ws.held_iterations,
        })
    }

    /// The holds of an eyelet's move carrying link `link` by `way`: the rope from each of its joints
    /// to the nearest held joint on its side is a held side, as in a threaded move of that joint;
    /// `None` on a chain without held joints.
    fn of_link(
        chain: &Chain<T, D>,
        link: usize,
        way: &Vector<T, D>,
        eyelets: &[Eyelet<T, D>],
        ws: &EyeletWorkspace<T, D>,
    ) -> Result<Option<Self>, EyeletError> {
        if chain.held().len() == 0 {
            return Ok(None);
        }
        let tol = held_tolerance(ws);
        let side_hold = |m: usize, h: Option<usize>| {
            h.map(|h| hold(chain, m, h, &(ws.new[m] + way), eyelets, &ws.new, tol))
                .transpose()
        };
        Ok(Some(Holds {
            tail: side_hold(link, chain.held_around(link).0)?,
            head: side_hold(link + 1, chain.held_around(link + 1).1)?,
            max_iterations: ws.held_iterations,
        }))
    }
}

/// How closely the rope must meet a held joint, as a fraction of the rope between (at least 64 ε).
fn held_tolerance<T: Real, const D: usize>(ws: &EyeletWorkspace<T, D>) -> T {
    T::lit(ws.held_tolerance).max(T::EPSILON * T::lit(64.0))
}

/// Held joint `h` as a move of joint `m` to `target` keeps it: where it is held (in `pos`) and how
/// closely the rope must meet it. Refused when the target is out of the reach the rope allows from
/// `h` through the eyelets between (the nearest point it reaches named), or `h` is too near the
/// moved joint or an eyelet to close on.
fn hold<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    m: usize,
    h: usize,
    target: &Vector<T, D>,
    eyelets: &[Eyelet<T, D>],
    pos: &[Vector<T, D>],
    tol: T,
) -> Result<(usize, Vector<T, D>, T), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let lengths = chain.lengths();
    let (a, b) = (h.min(m), h.max(m));
    // The two links the move closes on the held joint.
    let closing = if h > m { h.saturating_sub(2) } else { h };
    if b - a < 2
        || eyelets
            .iter()
            .any(|e| e.threaded && (closing..closing + 2).contains(&e.link))
    {
        return Err(EyeletError::NearHeld { held: h });
    }
    let rope = lengths[a..b].iter().fold(T::zero(), |x, &l| x + l);
    // The shortest way the rope can take: from the held joint through the eyelets between, in
    // order, to the target.
    let mut at = pos[h];
    let mut used = T::zero();
    let between = |e: &&Eyelet<T, D>| e.threaded && e.link >= a && e.link < b;
    let mut walk = |e: &Eyelet<T, D>| {
        used += (e.at - at).norm();
        at = e.at;
    };
    if h < m {
        eyelets.iter().filter(between).for_each(&mut walk);
    } else {
        eyelets.iter().rev().filter(between).for_each(&mut walk);
    }
    let last = (target - at).norm();
    if used + last > rope {
        let spare = (rope - used).max(T::zero());
        let nearest = if last > T::zero() {
            at + (target - at) * (spare / last)
        } else {
            at
        };
        let n3 = nearest.to_3d();
        return Err(ChainError::HeldUnreachable {
            held: h,
            nearest: [n3.x.to_f64(), n3.y.to_f64(), n3.z.to_f64()],
            residual: (used + last - rope).to_f64(),
        }
        .into());
    }
    Ok((h, pos[h], tol * rope))
}

/// One straight substep of joint `m` to `to`: `old` the positions before, `new` written (`alt` the
/// scratch of the walks back from held joints). Returns the eyelets left and the alternations spent
/// on held sides.
#[allow(clippy::too_many_arguments)]
fn substep<T: Real, const D: usize>(
    old: &[Vector<T, D>],
    new: &mut [Vector<T, D>],
    alt: &mut [Vector<T, D>],
    rope: Rope<'_, T>,
    m: usize,
    to: Vector<T, D>,
    eyelets: &mut [Eyelet<T, D>],
    holds: &Holds<T, D>,
    ahead: &mut Vec<(usize, T, usize)>,
) -> Result<(u32, u32), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let lengths = rope.0;
    let n = lengths.len();
    if holds.tail.is_some() || holds.head.is_some() {
        // The rope beyond a held joint is not walked: it stays where it was.
        new.copy_from_slice(old);
    }
    new[m] = to;
    // The moved joint pushed through an eyelet on a link beside it (the link aimed from it would
    // turn over): the eyelet passes to the link on its other side.
    for e in eyelets.iter_mut().filter(|e| e.threaded) {
        if m > 0
            && m < n
            && e.link == m - 1
            && turns_over(&old[m], &old[m - 1], &to, &e.at, lengths[m - 1])
        {
            e.link = m;
        } else if m > 0
            && m < n
            && e.link == m
            && turns_over(&old[m], &old[m + 1], &to, &e.at, lengths[m])
        {
            e.link = m - 1;
        }
    }
    let (mut left, mut iterations) = (0, 0);
    for (up, hold) in [(false, holds.tail), (true, holds.head)] {
        match hold {
            // The head side's first link turns about the tail side's, walked first.
            None => left += side(old, new, rope, m, eyelets, up, None, up)?,
            Some((h, at, tol)) => {
                let (l, i) = held_side(
                    old,
                    new,
                    alt,
                    rope,
                    m,
                    (h, at, tol),
                    eyelets,
                    holds.max_iterations,
                    ahead,
                )?;
                left += l;
                iterations += i;
            }
        }
    }
    apart(eyelets)?;
    Ok((left, iterations))
}

/// The rope from the moved joint `m` (at `new[m]`) to the held joint `h` (held at `at`): walked from
/// `m` to `h`, then, while the walk misses `at` by more than `tol`, walked back from `h` put on `at`
/// to `m` and out from `m` put back on its goal again (the forward and backward passes of FABRIK,
/// each a tractrix walk with the aim rule at the eyelets between). When the walk from `m` meets `at`
/// within `tol`, the two links before `h` are placed by the closed-form two-link solution from the
/// joint two links back, so that the rope meets `at` exactly with every length kept. Returns the
/// eyelets left (none: the rope cannot leave an eyelet between) and the alternations.
#[allow(clippy::too_many_arguments)]
fn held_side<T: Real, const D: usize>(
    old: &[Vector<T, D>],
    new: &mut [Vector<T, D>],
    alt: &mut [Vector<T, D>],
    rope: Rope<'_, T>,
    m: usize,
    (h, at, tol): (usize, Vector<T, D>, T),
    eyelets: &mut [Eyelet<T, D>],
    max_iterations: u32,
    ahead: &mut Vec<(usize, T, usize)>,
) -> Result<(u32, u32), EyeletError>
where
    Vector<T, D>: Embed3<T>,
{
    let lengths = rope.0;
    let up = h > m;
    let goal = new[m];
    // Whether `alt` holds the last pose that meets the held joint (else `old` does).
    let mut from_alt = false;
    let mut miss = T::zero();
    // A walk that slides an eyelet past its last joint, or (back from the held joint) pushes the
    // rope to fold through an eyelet, ends the alternation: the reach hierarchy finishes.
    let stalls =
        |e: &EyeletError| matches!(e, EyeletError::PastStop { .. } | EyeletError::Fold { .. });
    let mut it = 0;
    while it < max_iterations {
        it += 1;
        let walked = if from_alt {
            side(alt, new, rope, m, eyelets, up, Some(h), up)
        } else {
            side(old, new, rope, m, eyelets, up, Some(h), up)
        };
        let left = match walked {
            Ok(left) => left,
            Err(e) if stalls(&e) => break,
            Err(e) => return Err(e),
        };
        let before = miss;
        miss = (new[h] - at).norm();
        if miss <= tol {
            // Close on the held joint: joints c2 (kept), c1 (placed), h. The two links cannot close
            // when they are stretched straight (a taut rope): then the alternation goes on.
            let (c1, c2) = if up { (h - 1, h - 2) } else { (h + 1, h + 2) };
            let (a1, a2) = (lengths[c1.min(c2)], lengths[c1.min(h)]);
            let (l1, l2) = crate::fixed_base::two_link(&new[c2], &at, a1, a2, &(new[c1] - new[c2]));
            if (new[c2] + l1 + l2 - at).norm() <= (a1 + a2) * T::EPSILON * T::lit(64.0) {
                new[c1] = new[c2] + l1;
                new[h] = at;
                return Ok((left, it));
            }
        }
        // A stalled alternation (a straight stretch passes the correction on undamped: a rope
        // pushed along its own line) is left to the hierarchy at once.
        let stalled = it > 2 && miss > before * T::lit(STALL);
        alt[h] = at;
        match side(new, alt, rope, h, eyelets, !up, Some(m), false) {
            Ok(_) if stalled => {
                from_alt = true;
                break;
            }
            Ok(_) => from_alt = true,
            Err(e) if stalls(&e) => {
                from_alt = false;
                break;
            }
            Err(e) => return Err(e),
        }
    }
    // Not converged (a nearly taut rope passes each correction on almost undamped): the reach
    // hierarchy finishes from the last pose that meets the held joint, walking from the moved joint
    // on its goal and closing on the held joint (no eyelet lies on the two links next to it; one may
    // lie next to the moved joint, as where a needle has just pierced).
    let src: &[Vector<T, D>] = if from_alt { alt } else { old };
    // From the moved joint first (closing on the held joint: the rope by the hand keeps the shape the
    // walks gave it); when the rope next to the held joint is too taut to close on it, from the held
    // joint (closing on the moved joint's goal).
    let first = finish(src, new, lengths, (m, goal), h, at, eyelets, ahead);
    if first.is_ok() {
        return Ok((0, it));
    }
    for &(i, _, link) in ahead.iter() {
        eyelets[i].link = link;
    }
    finish(src, new, lengths, (h, at), m, goal, eyelets, ahead).map_err(|_| {
        ChainError::HeldNotConverged {
            iterations: it,
            residual: miss.to_f64(),
        }
    })?;
    Ok((0, it))
}
