//! A chain at run time in the form its scene declared ([`LiveChain`], in one of the four
//! [`Geometry`] forms: planar or spatial, f64 or f32), with its scene state, its undo state, its
//! collision structures and instruments, and the buffers its commands reuse; built from a
//! [`ChainSpec`] when the world is built.

use crate::point::Point;
use crate::scene::{ChainSpec, CollisionSpec};
use nalgebra::Vector3;
use tractrix::collision::{CollisionModel, CollisionOptions, CollisionWorkspace, Obstacle};
use tractrix::eyelet::{Eyelet, EyeletWorkspace};
use tractrix::math::{Embed3, Real, Vector};
use tractrix::{Chain, ChainError, ReachWorkspace};

/// What a request changes of one rope, as one value: its chain, its instruments' poses, its eyelets
/// and the targets its hands asked for that stopped short ([`crate::tension`]). A [`LiveChain`] keeps
/// three besides its live state: the scene's (reset), the one before the last change (undo) and the
/// furthest a pulled move reached. A new piece of rope state is a field here and a line in each of
/// `LiveChain::save` and `LiveChain::load`, the only two places that copy it.
#[derive(Debug, Clone)]
pub struct RopeState<T: Real, const D: usize> {
    /// The chain: its joints, held joints and limits.
    pub chain: Chain<T, D>,
    /// The instruments' poses, in the scene's order.
    pub instruments: Vec<Obstacle<T, D>>,
    /// The eyelets the chain passes through (or has left).
    pub eyelets: Vec<Eyelet<T, D>>,
    /// The asked targets that stopped short: of held joints, then of instruments.
    pub asked: (Vec<crate::tension::Asked>, Vec<crate::tension::Asked>),
}

/// Which of a [`LiveChain`]'s kept [`RopeState`]s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kept {
    /// The scene's state (reset).
    Initial,
    /// The state before the last change ([`World::undo`](crate::World::undo)).
    Before,
    /// The furthest pose a pulled move reached so far.
    Best,
}

/// A chain in the precision and dimension its scene declared, with its scene state (for reset) and the
/// buffers its requests reuse (allocated once).
#[derive(Debug, Clone)]
pub struct LiveChain<T: Real, const D: usize> {
    /// The current state (with the instruments in the collision model, the eyelets and the tension:
    /// together the live [`RopeState`]).
    pub chain: Chain<T, D>,
    /// The scene's state (reset).
    pub initial: RopeState<T, D>,
    /// The state before the last change ([`World::undo`]).
    pub(crate) before: RopeState<T, D>,
    /// The furthest pose a pulled move reached so far.
    pub(crate) best: RopeState<T, D>,
    pub(crate) ws: ReachWorkspace<T, D>,
    /// Collision model and buffers, only for chains whose scene declares collision.
    pub(crate) collision: Option<(CollisionModel<T, D>, CollisionWorkspace<T, D>)>,
    /// A path's targets in the chain's type (bounded by `MAX_PATH_POINTS`, kept between requests).
    pub(crate) targets: Vec<Vector<T, D>>,
    /// The joints a carried needle is checked against (kept between requests).
    pub(crate) needle_joints: Vec<Vector<T, D>>,
    /// Where the chain's instruments start in the collision model's obstacles (after the static ones).
    pub(crate) instruments_at: usize,
    /// For each instrument, the joint it rides with (scene `follows`).
    pub(crate) follows: Vec<Option<usize>>,
    /// What the hands feel: asked targets that stopped short, and the pulls they give.
    pub(crate) tension: crate::tension::Tension,
    /// The rope's length from joint 0 to each joint (`n + 1` sums of the scene's lengths).
    pub(crate) prefix: Vec<f64>,
    /// How much shorter than its rope a taut stretch's chord may be ([`crate::tension::taut_slack`]).
    pub(crate) taut_slack: f64,
    /// The eyelets the chain passes through (scene `eyelets`), and the buffers of a threaded move.
    pub(crate) eyelets: Vec<Eyelet<T, D>>,
    pub(crate) eyelet_ws: EyeletWorkspace<T, D>,
    /// The block of tissue the head pierces (scene `tissue`: its lower and upper corners).
    pub(crate) tissue: Option<(Point, Point)>,
    /// Tissue that gives (scene `incision`, `tissue_give`, `wound_margin`).
    pub(crate) wound: Option<crate::scene::Wound>,
    /// A curved needle swaged to the head (scene `needle`): its capsules among the instruments.
    pub(crate) needle: Option<crate::needle::Needle>,
}

impl<T: Real, const D: usize> LiveChain<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// The instruments' current poses.
    pub fn instruments(&self) -> &[Obstacle<T, D>] {
        self.collision
            .as_ref()
            .map_or(&[][..], |(m, _)| &m.obstacles[self.instruments_at..])
    }
    pub(crate) fn instruments_mut(&mut self) -> &mut [Obstacle<T, D>] {
        let at = self.instruments_at;
        self.collision
            .as_mut()
            .map_or(&mut [][..], |(m, _)| &mut m.obstacles[at..])
    }
    /// The kernel's door to this rope ([`tractrix::Rope`]): its chain with its collision model when
    /// it has one, and threaded through its eyelets when it has eyelets or tissue (where the head
    /// makes them).
    pub(crate) fn rope(&mut self) -> tractrix::Rope<'_, T, D> {
        let threaded = !self.eyelets.is_empty() || self.tissue.is_some();
        self.rope_with(threaded)
    }
    /// [`LiveChain::rope`], threaded through its eyelets (even none) when `threaded`.
    pub(crate) fn rope_with(&mut self, threaded: bool) -> tractrix::Rope<'_, T, D> {
        let LiveChain {
            chain,
            collision,
            eyelets,
            eyelet_ws,
            ..
        } = self;
        let mut rope = tractrix::Rope::new(chain);
        if let Some((model, ws)) = collision {
            rope = rope.with_collision(model, ws);
        }
        if threaded {
            rope = rope.with_eyelets(eyelets, eyelet_ws);
        }
        rope
    }
    /// Sets obstacle `at` of the collision model (an instrument's new pose).
    pub(crate) fn set_obstacle(&mut self, at: usize, to: Obstacle<T, D>) {
        if let Some((model, _)) = &mut self.collision {
            model.obstacles[at] = to;
        }
    }
    /// Copies the live state into the kept state `which` (no allocation once warm).
    pub(crate) fn save(&mut self, which: Kept) {
        let LiveChain {
            chain,
            initial,
            before,
            best,
            collision,
            instruments_at,
            tension,
            eyelets,
            ..
        } = self;
        let to = match which {
            Kept::Initial => initial,
            Kept::Before => before,
            Kept::Best => best,
        };
        to.chain.copy_from(chain);
        to.instruments.clear();
        if let Some((m, _)) = collision {
            to.instruments
                .extend_from_slice(&m.obstacles[*instruments_at..]);
        }
        to.eyelets.clone_from(eyelets);
        to.asked.0.clone_from(&tension.joints);
        to.asked.1.clone_from(&tension.instruments);
    }
    /// Makes the kept state `which` the live one, keeping it (the pulls are not refreshed: see
    /// [`LiveChain::refresh_tension`]).
    pub(crate) fn load(&mut self, which: Kept) {
        let LiveChain {
            chain,
            initial,
            before,
            best,
            collision,
            instruments_at,
            tension,
            eyelets,
            ..
        } = self;
        let from = match which {
            Kept::Initial => &*initial,
            Kept::Before => &*before,
            Kept::Best => &*best,
        };
        chain.copy_from(&from.chain);
        if let Some((m, _)) = collision {
            let now = &mut m.obstacles[*instruments_at..];
            if now.len() == from.instruments.len() {
                now.copy_from_slice(&from.instruments);
            }
        }
        eyelets.clone_from(&from.eyelets);
        tension.joints.clone_from(&from.asked.0);
        tension.instruments.clone_from(&from.asked.1);
    }
    /// Remembers the state for [`World::undo`] (no allocation once warm).
    pub(crate) fn arm_undo(&mut self) {
        self.save(Kept::Before);
    }
    /// Puts back the state [`LiveChain::arm_undo`] remembered, its pulls refreshed.
    pub(crate) fn swap_undo(&mut self) {
        self.load(Kept::Before);
        self.refresh_tension();
    }
    /// Back to the state [`LiveChain::arm_undo`] remembered, keeping that memory (a pulled move's next
    /// try).
    pub(crate) fn restore_armed(&mut self) {
        self.load(Kept::Before);
    }
    /// Remembers the state as the furthest a pulled move reached.
    pub(crate) fn keep_best(&mut self) {
        self.save(Kept::Best);
    }
    /// Puts back the state [`LiveChain::keep_best`] remembered.
    pub(crate) fn take_best(&mut self) {
        self.load(Kept::Best);
    }
    /// Recomputes the pulls and taut flags from the asked targets and the chain as it is now
    /// ([`crate::tension::Tension::refresh`]).
    pub(crate) fn refresh_tension(&mut self) {
        let instruments = self
            .collision
            .as_ref()
            .map_or(&[][..], |(m, _)| &m.obstacles[self.instruments_at..]);
        self.tension.refresh(
            &self.chain,
            instruments,
            &self.follows,
            &self.prefix,
            self.taut_slack,
        );
    }
    /// The eyelets the chain passes through (or has left).
    pub fn eyelets(&self) -> &[Eyelet<T, D>] {
        &self.eyelets
    }
    /// What the hands feel ([`crate::tension`]).
    pub fn tension(&self) -> &crate::tension::Tension {
        &self.tension
    }
    /// The instruments' poses as numbers (a sphere: its centre; a capsule: `a` then `b`), for a snapshot.
    pub fn instrument_numbers(&self) -> Vec<Vec<f64>> {
        self.instruments()
            .iter()
            .map(|o| {
                let pts: Vec<Vector<T, D>> = match o {
                    Obstacle::Sphere { center, .. } => vec![*center],
                    Obstacle::Capsule { a, b, .. } => vec![*a, *b],
                    Obstacle::HalfSpace { .. } | Obstacle::Block { .. } => vec![],
                };
                pts.iter()
                    .flat_map(|p| p.iter().map(|x| x.to_f64()).collect::<Vec<_>>())
                    .collect()
            })
            .collect()
    }
    /// Sets the instruments' poses from [`LiveChain::instrument_numbers`] (a restored snapshot).
    pub fn set_instrument_numbers(&mut self, poses: &[Vec<f64>]) -> Result<(), PoseError> {
        if poses.len() != self.instruments().len() {
            return Err(PoseError::Count {
                got: poses.len(),
                want: self.instruments().len(),
            });
        }
        for (o, nums) in self.instruments_mut().iter_mut().zip(poses) {
            let pt = |k: usize| -> Result<Vector<T, D>, PoseError> {
                let v = nums.get(k * D..(k + 1) * D).ok_or(PoseError::Shape)?;
                let p = Vector::<T, D>::from_iterator(v.iter().map(|&x| T::lit(x)));
                if tractrix::math::all_finite(&p) {
                    Ok(p)
                } else {
                    Err(PoseError::NonFinite)
                }
            };
            match o {
                Obstacle::Sphere { center, .. } if nums.len() == D => *center = pt(0)?,
                Obstacle::Capsule { a, b, .. } if nums.len() == 2 * D => {
                    *a = pt(0)?;
                    *b = pt(1)?;
                }
                _ => return Err(PoseError::Shape),
            }
        }
        Ok(())
    }
}

/// Why instrument poses were not set (those before the one at fault may be: set them on a copy).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// Another number of poses than the chain has instruments.
    #[error("{got} instrument poses for {want} instruments")]
    Count {
        /// Poses given.
        got: usize,
        /// Instruments of the chain.
        want: usize,
    },
    /// Numbers that do not fit the instrument's shape (a sphere's centre; a capsule's two ends).
    #[error("an instrument's pose does not fit its shape")]
    Shape,
    /// A number that is not finite.
    #[error("an instrument's pose is not finite")]
    NonFinite,
}

/// One of the four chain forms.
#[derive(Debug, Clone)]
pub enum Geometry {
    /// Planar, f64.
    Planar64(LiveChain<f64, 2>),
    /// Spatial, f64.
    Spatial64(LiveChain<f64, 3>),
    /// Planar, f32.
    Planar32(LiveChain<f32, 2>),
    /// Spatial, f32.
    Spatial32(LiveChain<f32, 3>),
}

/// Runs `$body` with `$h` bound to the [`LiveChain`] of whichever form `$g` is (a
/// [`Geometry`](crate::form::Geometry)).
#[macro_export]
macro_rules! each_form {
    ($g:expr, $h:ident => $body:expr) => {
        match $g {
            $crate::form::Geometry::Planar64($h) => $body,
            $crate::form::Geometry::Spatial64($h) => $body,
            $crate::form::Geometry::Planar32($h) => $body,
            $crate::form::Geometry::Spatial32($h) => $body,
        }
    };
}
pub use crate::each_form;

use crate::point::point;

/// The links each following instrument holds: those within its reach of the joint it follows (its
/// radius, plus half its length for a capsule, in shortest links, and one more on each side).
fn holding(spec: &ChainSpec, c: &CollisionSpec) -> Vec<tractrix::collision::Holding> {
    let n = spec.lengths.len();
    c.instruments
        .iter()
        .zip(&c.follows)
        .enumerate()
        .filter_map(|(k, ((_, o), f))| {
            let j = (*f)? as usize;
            let extent = match o {
                Obstacle::Sphere { radius, .. } => *radius,
                Obstacle::Capsule { a, b, radius } => radius + 0.5 * (b - a).norm(),
                Obstacle::HalfSpace { .. } | Obstacle::Block { .. } => 0.0,
            };
            let reach = ((extent + 0.5 * c.options.thickness) / spec.shortest).ceil();
            let reach = if reach.is_finite() {
                reach as usize + 1
            } else {
                n
            };
            Some(tractrix::collision::Holding {
                obstacle: c.obstacles.len() + usize::from(spec.tissue.is_some()) + k,
                links: j.saturating_sub(reach)..(j + reach).min(n),
            })
        })
        .collect()
}

/// The chain's collision model: the scene's obstacles, its tissue and its instruments as the kernel's
/// obstacles, with the scene's collision options.
fn collision_model<T: Real, const D: usize>(
    spec: &ChainSpec,
    c: &CollisionSpec,
) -> CollisionModel<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    // The scene's obstacles, the chain's tissue (a block the rope stays out of but between its
    // eyelets), then its instruments.
    let tissue = spec.tissue.map(|(lo, hi)| Obstacle::Block { lo, hi });
    let obstacles: Vec<Obstacle<T, D>> = c
        .obstacles
        .iter()
        .chain(tissue.as_ref())
        .chain(c.instruments.iter().map(|(_, o)| o))
        .map(kernel_obstacle)
        .collect();
    let o = &c.options;
    CollisionModel {
        options: CollisionOptions {
            scheme: o.scheme,
            self_collision: o.self_collision,
            thickness: T::lit(o.thickness),
            max_iterations: o.max_iterations,
            tolerance: T::lit(o.tolerance),
            over_relaxation: T::lit(o.over_relaxation),
            pushed_weight: T::lit(o.pushed_weight),
            together_after: o.together_after,
        },
        obstacles,
        holding: holding(spec, c),
    }
}

/// A scene's obstacle (f64, spatial) as the chain's (its precision and space).
fn kernel_obstacle<T: Real, const D: usize>(o: &Obstacle<f64, 3>) -> Obstacle<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let v = |q: &Vector3<f64>| point::<T, D>(*q);
    match o {
        Obstacle::Sphere { center, radius } => Obstacle::Sphere {
            center: v(center),
            radius: T::lit(*radius),
        },
        Obstacle::Capsule { a, b, radius } => Obstacle::Capsule {
            a: v(a),
            b: v(b),
            radius: T::lit(*radius),
        },
        Obstacle::HalfSpace { point, normal } => Obstacle::HalfSpace {
            point: v(point),
            normal: v(normal),
        },
        Obstacle::Block { lo, hi } => Obstacle::Block {
            lo: v(lo),
            hi: v(hi),
        },
    }
}

pub(crate) fn build<T: Real, const D: usize>(
    spec: &ChainSpec,
) -> Result<LiveChain<T, D>, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    let p: Vec<Vector<T, D>> = spec.points.iter().map(|q| point(*q)).collect();
    let links: Vec<_> = p.windows(2).map(|w| w[1] - w[0]).collect();
    let lengths: Vec<T> = spec.lengths.iter().map(|&l| T::lit(l)).collect();
    let mut chain = Chain::from_parts(p[0], links, lengths)?;
    for &a in &spec.anchors {
        chain.hold(a as usize)?;
    }
    if let Some(l) = &spec.limits {
        let lim = l
            .kernel::<T>()
            .map_err(|_| ChainError::BadOption("the scene's joint limits"))?;
        chain
            .set_limits(Some(lim))
            .map_err(|_| ChainError::BadOption("the scene's joint limits"))?;
    }
    let collision = spec
        .collision
        .as_ref()
        .map(|c| (collision_model(spec, c), CollisionWorkspace::new()));
    let instruments_at = spec.collision.as_ref().map_or(0, |c| {
        c.obstacles.len() + usize::from(spec.tissue.is_some())
    });
    let mut prefix = Vec::with_capacity(spec.lengths.len() + 1);
    prefix.push(0.0);
    for l in &spec.lengths {
        prefix.push(prefix[prefix.len() - 1] + l);
    }
    let kept = RopeState {
        chain: chain.clone(),
        instruments: Vec::new(),
        eyelets: Vec::new(),
        asked: (Vec::new(), Vec::new()),
    };
    let mut h = LiveChain {
        initial: kept.clone(),
        before: kept.clone(),
        best: kept,
        chain,
        ws: ReachWorkspace::default(),
        collision,
        targets: Vec::new(),
        needle_joints: Vec::new(),
        instruments_at,
        follows: spec.collision.as_ref().map_or_else(Vec::new, |c| {
            c.follows.iter().map(|f| f.map(|j| j as usize)).collect()
        }),
        tension: crate::tension::Tension::default(),
        taut_slack: crate::tension::taut_slack(spec.moves.held.tolerance, prefix[prefix.len() - 1]),
        prefix,
        eyelets: spec
            .eyelets
            .iter()
            .map(|&(at, link)| Eyelet {
                at: point(at),
                link,
                threaded: true,
            })
            .collect(),
        // A held side through eyelets alternates as many times as a fixed-base solve iterates
        // before the reach hierarchy finishes it.
        eyelet_ws: EyeletWorkspace::new()
            .with_holds(
                spec.moves.held.tolerance,
                match spec.moves.held.hierarchy_after {
                    0 => 16,
                    k => k,
                },
            )
            .with_friction(spec.eyelet_friction),
        tissue: spec.tissue,
        wound: spec.wound,
        needle: spec.needle,
    };
    for which in [Kept::Initial, Kept::Before, Kept::Best] {
        h.save(which);
    }
    h.refresh_tension();
    Ok(h)
}
