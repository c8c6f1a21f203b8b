//! Collision handling for free chains: self-collision and static obstacles, two schemes.
//!
//! A knot survives in a tractrix rope only if the rope cannot pass through itself: tractrix trailing cuts
//! corners, so without collision handling a loop shrinks until the strand through it slips out. A move
//! with collision runs substep by substep; after each substep's tractrix sweep the links are checked and,
//! where two of them (or a link and an obstacle) are closer than their clearance, pushed apart; the chain
//! is then re-straightened to its exact link lengths by a follow-the-leader pass *outward from the grasped
//! joint* (which never moves: the hand holds it on its path). This repeats until no contact is deeper than
//! [`CollisionOptions::tolerance`] of its clearance, or up to [`CollisionOptions::max_iterations`]; a chain
//! still in contact then is *locked* (the paper's word) and the whole move is refused, the chain unchanged.
//!
//! # Schemes
//!
//! * [`Scheme::PaperSpheres`], section 4.2 as printed: a bounding sphere per link (centre at the link's
//!   middle, diameter the link's length); two non-adjacent links collide when their centres are closer
//!   than `(lᵢ + lⱼ)/2`, and the colliding link (the one farther from the hand) is moved along the common
//!   normal until they are just apart. All pairs are tested, O(n²), as in the paper. The spheres are as
//!   thick as a link is long: a rope of unit links behaves as a rope one unit thick.
//! * [`Scheme::Capsules`]: each link is a capsule of diameter [`CollisionOptions::thickness`] (the rope's
//!   real thickness); two links collide when their axes are closer than one thickness, unless there is
//!   less than a thickness of rope between them ([`neighbour_span`]: only adjacent links when the links
//!   are longer than the rope is thick). The
//!   contact pushes the four joints along the common normal in proportion to where the closest points
//!   lie on each link (the grasped joint does not move). Candidate pairs come from a spatial hash grid
//!   with cells one link plus one thickness wide, so detection costs O(n) for a rope that is not piled
//!   into one cell.
//!
//! # Guarantees
//!
//! After every substep of a successful move, every contact is within `tolerance × clearance` (the
//! clearance of a capsule pair is the thickness; of a link and an obstacle, the sum of their radii). With
//! collision on, a move is also split so that the grasped joint moves at most half a clearance per
//! substep: tractrix links trail their heads by less than the head moves, so two links approach each
//! other by at most one clearance per substep and cannot tunnel through each other between checks.
//! When nothing touches, a move with collision handling gives bit for bit the chain a move without it
//! gives.

use crate::chain::{Chain, ChainError, MoveOptions, MoveOutcome};
use crate::math::{CompensatedSum, Embed3, Real, Vector, all_finite, positive_finite};
use nalgebra::Vector3;

/// Which collision test and response a chain uses (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// Section 4.2 as printed: one bounding sphere per link, all pairs, the colliding link moved.
    PaperSpheres,
    /// Capsules of the rope's thickness, spatial hash grid, contact pushes weighted along the links.
    Capsules,
}

/// A static obstacle, in the chain's coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Obstacle<T: Real, const D: usize> {
    /// A ball (a disc in a planar scene).
    Sphere {
        /// Centre.
        center: Vector<T, D>,
        /// Radius, positive.
        radius: T,
    },
    /// The set of points within `radius` of the segment `a`–`b` (a post, a tool shaft).
    Capsule {
        /// One end of the axis.
        a: Vector<T, D>,
        /// The other end of the axis.
        b: Vector<T, D>,
        /// Radius, positive.
        radius: T,
    },
    /// The half-space behind a plane (a table): the chain stays on the side `normal` points to.
    HalfSpace {
        /// A point of the plane.
        point: Vector<T, D>,
        /// Unit normal, pointing to the free side.
        normal: Vector<T, D>,
    },
}

/// Knobs of collision handling. Each trades speed for how strictly links are kept apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollisionOptions<T> {
    /// Test and response.
    pub scheme: Scheme,
    /// Whether links collide with each other (obstacles are tested whenever any are given).
    pub self_collision: bool,
    /// Rope diameter for [`Scheme::Capsules`], in length units; must be positive. Ignored by
    /// [`Scheme::PaperSpheres`] (a link's sphere is as wide as the link is long). Thicker ropes need
    /// more substeps (a substep moves the grasped joint at most half a clearance).
    pub thickness: T,
    /// Resolution passes allowed per substep before the chain is declared locked. Too few locks a rope
    /// that would have come apart; more passes cost one detection each, and a jammed knot spends all
    /// of them before it is refused.
    pub max_iterations: u32,
    /// Penetration accepted, as a fraction of each pair's clearance, in `(0, 1)`. Smaller is stricter
    /// and costs more passes; the default keeps links within 1 % of a thickness.
    pub tolerance: T,
}

impl<T: Real> Default for CollisionOptions<T> {
    fn default() -> Self {
        CollisionOptions {
            scheme: Scheme::Capsules,
            self_collision: true,
            thickness: T::lit(0.2),
            max_iterations: 64,
            tolerance: T::lit(0.01),
        }
    }
}

impl<T: Real> CollisionOptions<T> {
    /// Checks the options (positive thickness for capsules, tolerance in `(0, 1)`, at least one pass).
    pub fn validate(&self) -> Result<(), ChainError> {
        if self.scheme == Scheme::Capsules && !positive_finite(self.thickness) {
            return Err(ChainError::BadOption(
                "collision thickness must be a positive finite length",
            ));
        }
        if !(self.tolerance > T::zero() && self.tolerance < T::one()) {
            return Err(ChainError::BadOption(
                "collision tolerance must lie strictly between 0 and 1",
            ));
        }
        if self.max_iterations == 0 {
            return Err(ChainError::BadOption(
                "collision needs at least one iteration",
            ));
        }
        Ok(())
    }
}

/// What a chain collides with: options plus obstacles, built once per chain from its scene.
#[derive(Clone, Debug, PartialEq)]
pub struct CollisionModel<T: Real, const D: usize> {
    /// Scheme and knobs.
    pub options: CollisionOptions<T>,
    /// Static obstacles this chain avoids.
    pub obstacles: Vec<Obstacle<T, D>>,
}

/// Caller-owned buffers reused across moves: after the first move of a chain, a move with collision
/// allocates nothing.
#[derive(Clone, Debug, Default)]
pub struct CollisionWorkspace<T: Real, const D: usize> {
    pos: Vec<Vector<T, D>>,
    backup_links: Vec<Vector<T, D>>,
    grid: HashGrid,
}

impl<T: Real, const D: usize> CollisionWorkspace<T, D> {
    /// An empty workspace (buffers grow on first use).
    pub fn new() -> Self {
        CollisionWorkspace {
            pos: Vec::new(),
            backup_links: Vec::new(),
            grid: HashGrid::default(),
        }
    }
}

/// The smallest distance between the axes of two non-adjacent links, by testing every pair (O(n²)):
/// an independent check of what collision handling guarantees, for tests and tools. Returns the
/// distance and the two 0-based link indices, or `None` for a chain of fewer than three links.
pub fn closest_nonadjacent_links<T: Real, const D: usize>(
    positions: &[Vector<T, D>],
) -> Option<(T, usize, usize)>
where
    Vector<T, D>: Embed3<T>,
{
    closest_links_apart(positions, 1)
}

/// Like [`closest_nonadjacent_links`], testing only links more than `span` links apart (`span` from
/// [`neighbour_span`] leaves out the neighbours capsule collision never tests).
pub fn closest_links_apart<T: Real, const D: usize>(
    positions: &[Vector<T, D>],
    span: usize,
) -> Option<(T, usize, usize)>
where
    Vector<T, D>: Embed3<T>,
{
    let n = positions.len().checked_sub(1)?;
    let mut best: Option<(T, usize, usize)> = None;
    for i in 0..n {
        for j in i + span + 1..n {
            let (a0, a1, b0, b1) = (
                positions[i],
                positions[i + 1],
                positions[j],
                positions[j + 1],
            );
            let (s, t) = closest_params_segment_segment(&a0, &a1, &b0, &b1);
            let d = (lerp(&a0, &a1, s) - lerp(&b0, &b1, t)).norm();
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, i, j));
            }
        }
    }
    best
}

/// Moves joint `joint` along the straight segment to `target` like [`Chain::move_joint`], keeping links
/// apart from each other and from the model's obstacles after every substep (see the module docs). On
/// any error, [`ChainError::Locked`] included, the chain is unchanged.
pub fn move_joint_colliding<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    joint: usize,
    target: Vector<T, D>,
    opts: &MoveOptions<T>,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<MoveOutcome, ChainError>
where
    Vector<T, D>: Embed3<T>,
{
    chain.check_joint(joint)?;
    model.options.validate()?;
    if !all_finite(&target) {
        return Err(ChainError::NonFinite);
    }
    let start = chain.joint(joint);
    let delta = target - start;
    let requested = chain.substep_count(&delta, opts)?;
    // No substep may move the hand more than half the smallest clearance (no tunnelling).
    let half = smallest_clearance(chain, model) * T::lit(0.5);
    let needed = (delta.norm() / half).to_f64();
    let needed = if needed.is_finite() {
        needed.ceil().max(1.0)
    } else {
        f64::INFINITY
    };
    let k = if needed > requested as f64 {
        if needed > opts.max_substeps as f64 {
            return Err(ChainError::TooManySubsteps {
                required: if needed.is_finite() {
                    needed as u64
                } else {
                    u64::MAX
                },
                limit: opts.max_substeps,
            });
        }
        needed as u32
    } else {
        requested
    };
    if delta.iter().all(|c| *c == T::zero()) {
        return Ok(MoveOutcome::default());
    }
    ws.backup_links.clear();
    ws.backup_links.extend_from_slice(chain.links());
    let backup_origin = chain.origin();
    ws.pos.resize(chain.n_links() + 1, Vector::zeros());

    let sd = delta / T::lit(k as f64);
    let mut outcome = MoveOutcome {
        substeps: k,
        ..MoveOutcome::default()
    };
    for s in 1..=k {
        outcome.paper_fallbacks =
            outcome
                .paper_fallbacks
                .saturating_add(chain.sweep(joint, &sd, opts.method));
        let hand = if s == k {
            target
        } else {
            start + sd * T::lit(s as f64)
        };
        positions_from(chain, joint, hand, &mut ws.pos);
        match resolve(chain, joint, model, ws) {
            Ok((iterations, contacts)) => {
                outcome.collision_iterations =
                    outcome.collision_iterations.saturating_add(iterations);
                outcome.contacts = outcome.contacts.saturating_add(contacts);
            }
            Err((iterations, penetration)) => {
                chain.links_mut().copy_from_slice(&ws.backup_links);
                chain.translate_to(backup_origin);
                return Err(ChainError::Locked {
                    substep: s,
                    iterations,
                    penetration: penetration.to_f64(),
                });
            }
        }
        chain.translate_to(ws.pos[0]);
    }
    Ok(outcome)
}

/// The smallest clearance any contact of this chain can have: half of what a substep may move.
fn smallest_clearance<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    model: &CollisionModel<T, D>,
) -> T
where
    Vector<T, D>: Embed3<T>,
{
    let link = match model.options.scheme {
        Scheme::Capsules => model.options.thickness,
        Scheme::PaperSpheres => chain.min_length(),
    };
    // A link against an obstacle has at least half a link's clearance.
    if model.obstacles.is_empty() {
        link
    } else {
        link * T::lit(0.5)
    }
}

/// Joint positions from the hand's position outward, along the current link vectors.
fn positions_from<T: Real, const D: usize>(
    chain: &Chain<T, D>,
    m: usize,
    hand: Vector<T, D>,
    pos: &mut [Vector<T, D>],
) where
    Vector<T, D>: Embed3<T>,
{
    let links = chain.links();
    pos[m] = hand;
    let mut acc = CompensatedSum::new(hand);
    for i in (0..m).rev() {
        acc.add(&-links[i]);
        pos[i] = acc.value();
    }
    let mut acc = CompensatedSum::new(hand);
    for i in m..links.len() {
        acc.add(&links[i]);
        pos[i + 1] = acc.value();
    }
}

/// Re-straightens the chain to its exact lengths, follow-the-leader outward from the hand (joint `m`,
/// which stays put): each link keeps the direction from its already placed inner joint to its pushed
/// outer joint. Writes the link vectors and the exact positions.
fn restraighten<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    pos: &mut [Vector<T, D>],
) where
    Vector<T, D>: Embed3<T>,
{
    let (links, lengths) = chain.links_and_lengths_mut();
    for i in m..links.len() {
        let d = pos[i + 1] - pos[i];
        let n = d.norm();
        if positive_finite(n) {
            links[i] = d * (lengths[i] / n);
        }
        pos[i + 1] = pos[i] + links[i];
    }
    for i in (0..m).rev() {
        let d = pos[i + 1] - pos[i];
        let n = d.norm();
        if positive_finite(n) {
            links[i] = d * (lengths[i] / n);
        }
        pos[i] = pos[i + 1] - links[i];
    }
}

/// How many links on each side of a link are its neighbours, never tested against it: those closer along
/// the rope than one thickness (`m` links of length `min_len` with `m·min_len ≥ thickness`). Two links
/// with fewer than a thickness of rope between them touch even when the rope is straight; testing them
/// would lock every move of a rope whose links are shorter than it is thick.
pub fn neighbour_span<T: Real>(min_len: T, thickness: T) -> usize {
    if !(positive_finite(min_len) && thickness.is_finite() && thickness > T::zero()) {
        return 1;
    }
    let m = (thickness / min_len).ceil().to_f64();
    if m.is_finite() {
        (m as usize).max(1)
    } else {
        1
    }
}

/// Resolution passes on `ws.pos` (positions of the chain after the sweep). Returns the passes that
/// pushed something and the contacts pushed, or, when locked, the passes and the worst penetration.
fn resolve<T: Real, const D: usize>(
    chain: &mut Chain<T, D>,
    m: usize,
    model: &CollisionModel<T, D>,
    ws: &mut CollisionWorkspace<T, D>,
) -> Result<(u32, u32), (u32, T)>
where
    Vector<T, D>: Embed3<T>,
{
    let opts = &model.options;
    let mut contacts = 0u32;
    let mut iterations = 0u32;
    let use_grid = opts.self_collision && opts.scheme == Scheme::Capsules;
    let span = neighbour_span(chain.min_length(), opts.thickness);
    loop {
        if use_grid {
            ws.grid.build(&ws.pos, opts.thickness * T::lit(0.5));
        }
        let mut pass = Pass {
            m,
            tol: opts.tolerance,
            pushed: 0,
            worst: T::zero(),
        };
        if opts.self_collision {
            match opts.scheme {
                Scheme::Capsules => pass.capsules(&mut ws.pos, &mut ws.grid, opts.thickness, span),
                Scheme::PaperSpheres => pass.spheres(&mut ws.pos),
            }
        }
        for ob in &model.obstacles {
            pass.obstacle(&mut ws.pos, ob, opts);
        }
        if pass.pushed == 0 {
            return Ok((iterations, contacts));
        }
        if iterations == opts.max_iterations {
            return Err((iterations, pass.worst));
        }
        iterations += 1;
        contacts = contacts.saturating_add(pass.pushed);
        restraighten(chain, m, &mut ws.pos);
    }
}

/// One resolution pass: contacts are pushed as they are found (Gauss–Seidel), each to its clearance
/// plus half the tolerance so that re-straightening does not bring it straight back.
struct Pass<T> {
    m: usize,
    tol: T,
    pushed: u32,
    worst: T,
}

impl<T: Real> Pass<T> {
    /// Inverse mass of joint `i`: the hand's joint does not move.
    #[inline]
    fn w(&self, i: usize) -> T {
        if i == self.m { T::zero() } else { T::one() }
    }

    /// Records a contact of depth `depth` against clearance `clearance`; `true` when it must be pushed.
    #[inline]
    fn violates(&mut self, depth: T, clearance: T) -> bool {
        if depth <= T::zero() {
            return false;
        }
        if depth > self.worst {
            self.worst = depth;
        }
        depth > self.tol * clearance
    }

    /// The push that brings a contact of depth `depth` to its clearance plus half the tolerance.
    #[inline]
    fn push_depth(&self, depth: T, clearance: T) -> T {
        depth + self.tol * T::lit(0.5) * clearance
    }

    fn capsules<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        grid: &mut HashGrid,
        thickness: T,
        span: usize,
    ) where
        Vector<T, D>: Embed3<T>,
    {
        let n = pos.len() - 1;
        for i in 0..n {
            let (lo, hi) = (grid.lo[i], grid.hi[i]);
            for cx in lo[0]..=hi[0] {
                for cy in lo[1]..=hi[1] {
                    for cz in lo[2]..=hi[2] {
                        let h = grid.slot([cx, cy, cz]);
                        for e in grid.starts[h]..grid.starts[h + 1] {
                            let j = grid.entries[e as usize] as usize;
                            if j <= i + span || !grid.first_visit(j, i) {
                                continue;
                            }
                            self.capsule_pair(pos, i, j, thickness);
                        }
                    }
                }
            }
        }
    }

    fn capsule_pair<const D: usize>(&mut self, pos: &mut [Vector<T, D>], i: usize, j: usize, c: T)
    where
        Vector<T, D>: Embed3<T>,
    {
        let (a0, a1, b0, b1) = (pos[i], pos[i + 1], pos[j], pos[j + 1]);
        let (s, t) = closest_params_segment_segment(&a0, &a1, &b0, &b1);
        let d = lerp(&a0, &a1, s) - lerp(&b0, &b1, t);
        let dist = d.norm();
        if !self.violates(c - dist, c) {
            return;
        }
        let n = unit_or_perpendicular(&d, dist, &(a1 - a0), &(b1 - b0));
        let (w0, w1, w2, w3) = (self.w(i), self.w(i + 1), self.w(j), self.w(j + 1));
        let (s1, t1) = (T::one() - s, T::one() - t);
        let den = w0 * s1 * s1 + w1 * s * s + w2 * t1 * t1 + w3 * t * t;
        if den <= T::zero() {
            return;
        }
        let lambda = self.push_depth(c - dist, c) / den;
        pos[i] += n * (w0 * s1 * lambda);
        pos[i + 1] += n * (w1 * s * lambda);
        pos[j] -= n * (w2 * t1 * lambda);
        pos[j + 1] -= n * (w3 * t * lambda);
        self.pushed += 1;
    }

    fn spheres<const D: usize>(&mut self, pos: &mut [Vector<T, D>])
    where
        Vector<T, D>: Embed3<T>,
    {
        let n = pos.len() - 1;
        let half = T::lit(0.5);
        for i in 0..n {
            for j in i + 2..n {
                let ci = (pos[i] + pos[i + 1]) * half;
                let cj = (pos[j] + pos[j + 1]) * half;
                let (ri, rj) = (
                    (pos[i + 1] - pos[i]).norm() * half,
                    (pos[j + 1] - pos[j]).norm() * half,
                );
                let clearance = ri + rj;
                let d = ci - cj;
                let dist = d.norm();
                if !self.violates(clearance - dist, clearance) {
                    continue;
                }
                let dir = if positive_finite(dist) {
                    d / dist
                } else {
                    any_perpendicular(&(pos[i + 1] - pos[i]))
                };
                // The colliding link is the one farther from the hand; it is moved, not the other.
                let far_i = self.distance_from_hand(i) >= self.distance_from_hand(j);
                let (k, sign) = if far_i { (i, T::one()) } else { (j, -T::one()) };
                self.translate_link(
                    pos,
                    k,
                    dir * (sign * self.push_depth(clearance - dist, clearance)),
                );
            }
        }
    }

    /// How many links lie between link `i` and the hand's joint.
    fn distance_from_hand(&self, i: usize) -> usize {
        if i >= self.m {
            i - self.m
        } else {
            self.m - 1 - i
        }
    }

    /// Moves link `k`'s centre by `delta`: both joints, or the free one twice as far when the other is
    /// the hand's.
    fn translate_link<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        k: usize,
        delta: Vector<T, D>,
    ) {
        let two = T::lit(2.0);
        if k == self.m {
            pos[k + 1] += delta * two;
        } else if k + 1 == self.m {
            pos[k] += delta * two;
        } else {
            pos[k] += delta;
            pos[k + 1] += delta;
        }
        self.pushed += 1;
    }

    fn obstacle<const D: usize>(
        &mut self,
        pos: &mut [Vector<T, D>],
        ob: &Obstacle<T, D>,
        opts: &CollisionOptions<T>,
    ) where
        Vector<T, D>: Embed3<T>,
    {
        let half = T::lit(0.5);
        for i in 0..pos.len() - 1 {
            let (a, b) = (pos[i], pos[i + 1]);
            let link_r = match opts.scheme {
                Scheme::Capsules => opts.thickness * half,
                Scheme::PaperSpheres => (b - a).norm() * half,
            };
            // The point of the link that meets the obstacle: its centre for a sphere, the closest
            // point of its axis for a capsule.
            let (s, normal, depth, clearance) = match (opts.scheme, ob) {
                (Scheme::PaperSpheres, _) => {
                    let c = (a + b) * half;
                    let (n, dist, r) = away_from(ob, &c, &(b - a));
                    (half, n, link_r + r - dist, link_r + r)
                }
                (Scheme::Capsules, Obstacle::HalfSpace { point, normal }) => {
                    let (da, db) = ((a - point).dot(normal), (b - point).dot(normal));
                    let s = if da <= db { T::zero() } else { T::one() };
                    (s, *normal, link_r - da.min(db), link_r)
                }
                (Scheme::Capsules, Obstacle::Sphere { center, radius }) => {
                    let s = closest_param_point_segment(center, &a, &b);
                    let p = lerp(&a, &b, s);
                    let (n, dist, r) = away_from(ob, &p, &(b - a));
                    debug_assert_eq!(r, *radius);
                    (s, n, link_r + r - dist, link_r + r)
                }
                (
                    Scheme::Capsules,
                    Obstacle::Capsule {
                        a: oa,
                        b: ob_b,
                        radius,
                    },
                ) => {
                    let (s, t) = closest_params_segment_segment(&a, &b, oa, ob_b);
                    let d = lerp(&a, &b, s) - lerp(oa, ob_b, t);
                    let dist = d.norm();
                    let n = unit_or_perpendicular(&d, dist, &(b - a), &(*ob_b - *oa));
                    (s, n, link_r + *radius - dist, link_r + *radius)
                }
            };
            if !self.violates(depth, clearance) {
                continue;
            }
            let push = self.push_depth(depth, clearance);
            if opts.scheme == Scheme::PaperSpheres {
                self.translate_link(pos, i, normal * push);
                continue;
            }
            let (w0, w1) = (self.w(i), self.w(i + 1));
            let s1 = T::one() - s;
            let den = w0 * s1 * s1 + w1 * s * s;
            if den <= T::zero() {
                continue;
            }
            let lambda = push / den;
            pos[i] += normal * (w0 * s1 * lambda);
            pos[i + 1] += normal * (w1 * s * lambda);
            self.pushed += 1;
        }
    }
}

/// Unit direction from an obstacle to point `p`, the distance from the obstacle's core (centre, axis or
/// plane) and the obstacle's radius (0 for a plane). `axis` picks a direction when `p` is on the core.
fn away_from<T: Real, const D: usize>(
    ob: &Obstacle<T, D>,
    p: &Vector<T, D>,
    axis: &Vector<T, D>,
) -> (Vector<T, D>, T, T)
where
    Vector<T, D>: Embed3<T>,
{
    match ob {
        Obstacle::Sphere { center, radius } => {
            let d = p - center;
            let dist = d.norm();
            (unit_or_perpendicular(&d, dist, axis, axis), dist, *radius)
        }
        Obstacle::Capsule { a, b, radius } => {
            let t = closest_param_point_segment(p, a, b);
            let d = p - lerp(a, b, t);
            let dist = d.norm();
            (
                unit_or_perpendicular(&d, dist, axis, &(b - a)),
                dist,
                *radius,
            )
        }
        Obstacle::HalfSpace { point, normal } => (*normal, (p - point).dot(normal), T::zero()),
    }
}

#[inline]
fn lerp<T: Real, const D: usize>(a: &Vector<T, D>, b: &Vector<T, D>, s: T) -> Vector<T, D> {
    a + (b - a) * s
}

/// `d / dist`, or when the two axes touch exactly, a direction perpendicular to both (to the first if
/// they are parallel): the contact normal must exist for every configuration.
fn unit_or_perpendicular<T: Real, const D: usize>(
    d: &Vector<T, D>,
    dist: T,
    u: &Vector<T, D>,
    v: &Vector<T, D>,
) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    if positive_finite(dist) && dist > T::EPSILON * (u.norm() + v.norm()) {
        return d / dist;
    }
    let c = Vector::<T, D>::from_3d(&u.to_3d().cross(&v.to_3d()));
    let cn = c.norm();
    if positive_finite(cn) && D == 3 {
        return c / cn;
    }
    any_perpendicular(u)
}

/// A unit vector perpendicular to `u` (any unit vector when `u` is zero), deterministic.
fn any_perpendicular<T: Real, const D: usize>(u: &Vector<T, D>) -> Vector<T, D>
where
    Vector<T, D>: Embed3<T>,
{
    let u3 = u.to_3d();
    for axis in [Vector3::z(), Vector3::x(), Vector3::y()] {
        let c = Vector::<T, D>::from_3d(&u3.cross(&axis));
        let cn = c.norm();
        if positive_finite(cn) {
            return c / cn;
        }
    }
    let mut e = Vector::<T, D>::zeros();
    e[0] = T::one();
    e
}

/// Parameter in `[0, 1]` of the point of segment `a`–`b` closest to `p`.
pub fn closest_param_point_segment<T: Real, const D: usize>(
    p: &Vector<T, D>,
    a: &Vector<T, D>,
    b: &Vector<T, D>,
) -> T {
    let ab = b - a;
    let den = ab.norm_squared();
    if den <= T::zero() {
        return T::zero();
    }
    ((p - a).dot(&ab) / den).max(T::zero()).min(T::one())
}

/// Parameters `(s, t)` in `[0, 1]²` of the closest points of segments `p1`–`q1` and `p2`–`q2`
/// (Ericson, *Real-Time Collision Detection*, 5.1.9), robust to parallel and degenerate segments.
pub fn closest_params_segment_segment<T: Real, const D: usize>(
    p1: &Vector<T, D>,
    q1: &Vector<T, D>,
    p2: &Vector<T, D>,
    q2: &Vector<T, D>,
) -> (T, T) {
    let (zero, one) = (T::zero(), T::one());
    let clamp = |x: T| x.max(zero).min(one);
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    if a <= zero && e <= zero {
        return (zero, zero);
    }
    if a <= zero {
        return (zero, clamp(f / e));
    }
    let c = d1.dot(&r);
    if e <= zero {
        return (clamp(-c / a), zero);
    }
    let b = d1.dot(&d2);
    let den = a * e - b * b;
    // Parallel segments (den ≈ 0 relative to a·e): any s works; take 0 and let t follow.
    let mut s = if den > T::EPSILON * a * e {
        clamp((b * f - c * e) / den)
    } else {
        zero
    };
    let mut t = (b * s + f) / e;
    if t < zero {
        t = zero;
        s = clamp(-c / a);
    } else if t > one {
        t = one;
        s = clamp((b - c) / a);
    }
    (s, t)
}

/// A spatial hash grid over links (counting-sort layout, after Müller's "ten minute physics"): cells
/// one link plus one thickness wide, so a link's inflated box covers at most two cells per axis. The
/// table has twice as many slots as entries; a stamp per link de-duplicates candidates found through
/// several cells.
#[derive(Clone, Debug, Default)]
struct HashGrid {
    cell: f64,
    starts: Vec<u32>,
    entries: Vec<u32>,
    stamp: Vec<u32>,
    lo: Vec<[i64; 3]>,
    hi: Vec<[i64; 3]>,
    mask: usize,
}

impl HashGrid {
    fn build<T: Real, const D: usize>(&mut self, pos: &[Vector<T, D>], radius: T) {
        let n = pos.len() - 1;
        let longest = pos
            .windows(2)
            .map(|w| (w[1] - w[0]).amax().to_f64())
            .fold(0.0, f64::max);
        let r = radius.to_f64();
        self.cell = (longest + 2.0 * r).max(f64::MIN_POSITIVE);
        self.lo.resize(n, [0; 3]);
        self.hi.resize(n, [0; 3]);
        let mut inserts = 0usize;
        for i in 0..n {
            let (mut lo, mut hi) = ([0i64; 3], [0i64; 3]);
            for k in 0..D.min(3) {
                let (a, b) = (pos[i][k].to_f64(), pos[i + 1][k].to_f64());
                lo[k] = ((a.min(b) - r) / self.cell).floor() as i64;
                hi[k] = ((a.max(b) + r) / self.cell).floor() as i64;
            }
            inserts += cells_in(&lo, &hi);
            self.lo[i] = lo;
            self.hi[i] = hi;
        }
        let slots = (2 * inserts).next_power_of_two().max(16);
        self.mask = slots - 1;
        self.starts.clear();
        self.starts.resize(slots + 1, 0);
        for i in 0..n {
            self.for_each_cell(i, |g, h| g.starts[h] += 1);
        }
        let mut acc = 0u32;
        for s in self.starts.iter_mut() {
            acc += *s;
            *s = acc;
        }
        self.entries.clear();
        self.entries.resize(inserts, 0);
        for i in 0..n {
            self.for_each_cell(i, |g, h| {
                g.starts[h] -= 1;
                g.entries[g.starts[h] as usize] = i as u32;
            });
        }
        self.stamp.clear();
        self.stamp.resize(n, u32::MAX);
    }

    fn for_each_cell(&mut self, i: usize, mut f: impl FnMut(&mut Self, usize)) {
        let (lo, hi) = (self.lo[i], self.hi[i]);
        for cx in lo[0]..=hi[0] {
            for cy in lo[1]..=hi[1] {
                for cz in lo[2]..=hi[2] {
                    let h = self.slot([cx, cy, cz]);
                    f(self, h);
                }
            }
        }
    }

    #[inline]
    fn slot(&self, c: [i64; 3]) -> usize {
        let h = (c[0].wrapping_mul(92_837_111))
            ^ (c[1].wrapping_mul(689_287_499))
            ^ (c[2].wrapping_mul(283_923_481));
        (h as u64 as usize) & self.mask
    }

    /// `true` the first time link `j` is seen while querying link `i`.
    #[inline]
    fn first_visit(&mut self, j: usize, i: usize) -> bool {
        if self.stamp[j] == i as u32 {
            return false;
        }
        self.stamp[j] = i as u32;
        true
    }
}

fn cells_in(lo: &[i64; 3], hi: &[i64; 3]) -> usize {
    (0..3).map(|k| (hi[k] - lo[k] + 1) as usize).product()
}
