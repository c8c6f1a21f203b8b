//! The payload of an answer: a chain's joints (a compensated prefix sum, restarted at every held
//! joint as the kernel sums them), its joint rotations, held joints and instruments, or a bundle's
//! joints, streamed as [`Point`]s straight into the caller's buffer.

use crate::form::LiveChain;
use crate::point::Point;
use crate::point::to_point;
use nalgebra::Vector3;
use tractrix::Chain;
use tractrix::angles::rotation_between;
use tractrix::collision::Obstacle;
use tractrix::math::{CompensatedSum, Embed3, Real, Vector};

pub use crate::command::{Counts, EYELET_ELEMENTS, INSTRUMENT_ELEMENTS, TISSUE_ELEMENTS};

/// The payload of a response, in any of the four chain forms.
#[derive(Debug)]
pub enum Elements<'a> {
    /// No elements (an error response).
    Empty,
    /// Planar, f64.
    Planar64(ChainElements<'a, f64, 2>),
    /// Spatial, f64.
    Spatial64(ChainElements<'a, f64, 3>),
    /// Planar, f32.
    Planar32(ChainElements<'a, f32, 2>),
    /// Spatial, f32.
    Spatial32(ChainElements<'a, f32, 3>),
    /// A bundle's joints.
    Bundle(crate::bundles::BundleElements<'a>),
}

impl Elements<'_> {
    /// Appends the first `n` elements to `out` (a chain's joints by one tight loop:
    /// [`ChainElements::gather_into`]).
    pub fn gather_into<P: From<Point>>(self, out: &mut Vec<P>, n: usize) {
        match self {
            Elements::Empty => {}
            Elements::Planar64(e) => e.gather_into(out, n),
            Elements::Spatial64(e) => e.gather_into(out, n),
            Elements::Planar32(e) => e.gather_into(out, n),
            Elements::Spatial32(e) => e.gather_into(out, n),
            Elements::Bundle(e) => out.extend(e.take(n).map(P::from)),
        }
    }
}

impl Iterator for Elements<'_> {
    type Item = Point;
    #[inline]
    fn next(&mut self) -> Option<Point> {
        match self {
            Elements::Empty => None,
            Elements::Planar64(e) => e.next(),
            Elements::Spatial64(e) => e.next(),
            Elements::Planar32(e) => e.next(),
            Elements::Spatial32(e) => e.next(),
            Elements::Bundle(e) => e.next(),
        }
    }
}

impl From<&Counts> for Wants {
    /// Which parts a chain's payload laid out as `c` writes after its joints.
    fn from(c: &Counts) -> Wants {
        Wants {
            angles: c.angles > 0,
            held: c.held > 0,
            instruments: c.instruments > 0,
            pulls: c.pulls > 0,
            eyelets: c.eyelets > 0,
            tissue: c.tissue > 0,
        }
    }
}

/// Which parts of a payload to write after the joints.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Wants {
    pub(crate) angles: bool,
    pub(crate) held: bool,
    pub(crate) instruments: bool,
    pub(crate) pulls: bool,
    pub(crate) eyelets: bool,
    pub(crate) tissue: bool,
}

/// Joints by a compensated prefix sum (restarted at every held joint, as the kernel sums them), then
/// joint rotations, then held joints, then instruments, one element at a time.
#[derive(Debug)]
pub struct ChainElements<'a, T: Real, const D: usize> {
    chain: &'a Chain<T, D>,
    /// Joint 0, summed back from the chain's datum once (an O(n) pass).
    origin: Vector<T, D>,
    acc: CompensatedSum<T, D>,
    /// Next joint (0..=n), then n+1+k for rotation k, then held joint k, then instrument elements.
    at: usize,
    rotations: usize,
    held: usize,
    instruments: &'a [Obstacle<T, D>],
    /// One per held joint, then one per instrument ([`crate::tension`]); empty unless asked for.
    pulls: &'a [Point],
    tension: &'a crate::tension::Tension,
    /// The eyelets, two elements each; empty unless asked for.
    eyelets: &'a [tractrix::eyelet::Eyelet<T, D>],
    /// The tissue's corners; none unless asked for.
    tissue: Option<(Point, Point)>,
    /// The next held joint whose state restarts the sum, and its index (`usize::MAX`: none left).
    pin: usize,
    pin_at: usize,
    anchors: &'a [u32],
}

impl<'a, T: Real, const D: usize> ChainElements<'a, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    pub(crate) fn new(h: &'a LiveChain<T, D>, wants: Wants, anchors: &'a [u32]) -> Self {
        let chain = &h.chain;
        let origin = chain.origin();
        ChainElements {
            chain,
            origin,
            acc: CompensatedSum::new(origin),
            at: 0,
            rotations: if wants.angles { chain.links().len() } else { 0 },
            held: if wants.held { chain.held().len() } else { 0 },
            instruments: if wants.instruments {
                h.instruments()
            } else {
                &[]
            },
            pulls: if wants.pulls { h.tension.pulls() } else { &[] },
            tension: &h.tension,
            eyelets: if wants.eyelets { &h.eyelets } else { &[] },
            tissue: h.tissue.filter(|_| wants.tissue),
            pin: 0,
            pin_at: chain.held_state(0).map_or(usize::MAX, |(j, _)| j),
            anchors,
        }
    }

    /// Restarts the sum at joint `i` if it is held.
    #[inline]
    fn restart_at(&mut self, i: usize) -> bool {
        if i != self.pin_at {
            return false;
        }
        match self.chain.held_state(self.pin) {
            Some((j, s)) if j == i => {
                self.acc = s;
                self.pin += 1;
                self.pin_at = self
                    .chain
                    .held_state(self.pin)
                    .map_or(usize::MAX, |(j, _)| j);
                true
            }
            _ => false,
        }
    }
}

impl<T: Real, const D: usize> ChainElements<'_, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    /// Appends the first `n` elements to `out`, the same as `out.extend(self.take(n))`: the joints by
    /// one tight loop (the sum's state kept in registers, held joints restarting it), the rest one
    /// at a time.
    pub fn gather_into<P: From<Point>>(mut self, out: &mut Vec<P>, n: usize) {
        out.reserve(n);
        let start = out.len();
        let links = self.chain.links();
        let joints = (links.len() + 1).min(n);
        if self.at == 0 && joints > 0 {
            out.extend(self.next().map(P::from));
            let mut acc = self.acc;
            for (i, l) in links[..joints - 1]
                .iter()
                .enumerate()
                .map(|(i, l)| (i + 1, l))
            {
                acc.add(l);
                if i == self.pin_at {
                    self.acc = acc;
                    self.restart_at(i);
                    acc = self.acc;
                }
                out.push(P::from(to_point(&acc.value())));
            }
            self.acc = acc;
            self.at = joints;
        }
        let done = out.len() - start;
        out.extend(self.take(n - done).map(P::from));
    }
}

impl<T: Real, const D: usize> Iterator for ChainElements<'_, T, D>
where
    Vector<T, D>: Embed3<T>,
{
    type Item = Point;
    #[inline]
    fn next(&mut self) -> Option<Point> {
        let links = self.chain.links();
        let n = links.len();
        let i = self.at;
        self.at += 1;
        if i == 0 {
            if self.restart_at(0) {
                return Some(to_point(&self.acc.value()));
            }
            return Some(to_point(&self.origin));
        }
        if i <= n {
            self.acc.add(&links[i - 1]);
            self.restart_at(i);
            return Some(to_point(&self.acc.value()));
        }
        let k = i - n - 1;
        if k < self.rotations {
            let b = links[k].to_3d();
            let a = if k == 0 {
                Vector3::x()
            } else {
                links[k - 1].to_3d()
            };
            return Some(if D == 2 {
                let theta = (a.x * b.y - a.y * b.x).atan2(a.dot(&b));
                Point::new(0.0, 0.0, theta.to_f64())
            } else {
                let r = rotation_between(&a, &b).scaled_axis();
                Point::new(r.x.to_f64(), r.y.to_f64(), r.z.to_f64())
            });
        }
        let k = k - self.rotations;
        if k < self.held {
            let (j, _) = self.chain.held_state(k)?;
            let anchor = self.anchors.contains(&(j as u32));
            let taut = self.tension.taut(k);
            return Some(Point::new(
                j as f64,
                if anchor { 1.0 } else { 0.0 },
                if taut { 1.0 } else { 0.0 },
            ));
        }
        let k = k - self.held;
        let per = INSTRUMENT_ELEMENTS;
        if let Some(o) = self.instruments.get(k / per) {
            return Some(instrument_element(o, k % per));
        }
        let k = k - self.instruments.len() * per;
        if let Some(p) = self.pulls.get(k) {
            return Some(*p);
        }
        let k = k - self.pulls.len();
        let Some(e) = self.eyelets.get(k / 2) else {
            let k = k - 2 * self.eyelets.len();
            return match (self.tissue, k) {
                (Some((lo, _)), 0) => Some(lo),
                (Some((_, hi)), 1) => Some(hi),
                _ => {
                    self.at = i;
                    None
                }
            };
        };
        Some(if k.is_multiple_of(2) {
            to_point(&e.at)
        } else {
            Point::new(e.link as f64, if e.threaded { 1.0 } else { 0.0 }, 0.0)
        })
    }
}

/// Element `e` (0, 1 or 2) of an instrument's pose ([`INSTRUMENT_ELEMENTS`]).
fn instrument_element<T: Real, const D: usize>(o: &Obstacle<T, D>, e: usize) -> Point
where
    Vector<T, D>: Embed3<T>,
{
    let (a, b, radius, capsule) = match *o {
        Obstacle::Sphere { center, radius } => (center, center, radius, false),
        Obstacle::Capsule { a, b, radius } => (a, b, radius, true),
        // Never an instrument (the scene declares spheres and capsules only).
        Obstacle::HalfSpace { .. } | Obstacle::Block { .. } => return Point::zeros(),
    };
    match e {
        0 => to_point(&a),
        1 => to_point(&b),
        _ => Point::new(radius.to_f64(), if capsule { 1.0 } else { 0.0 }, 0.0),
    }
}
