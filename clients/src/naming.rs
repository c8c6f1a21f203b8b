//! The knot's name with every state, timed: what `watch --name-knots` reports after a run.
//!
//! The states a run published (every one, in order) are named one after the other by one
//! [`knots::Namer`], as a scene's rope would be named with each state, each call timed; a
//! sample of them (and the last) is also named by [`knots::identify`], the six-closure
//! majority, to say how often the fast name agrees with it. The naming runs after the stream ended,
//! so the service and the hands do not share the cores with it. The whole sequence is named
//! [`PASSES`] times, each by a new namer (the same calls, the same work): the first pass's times are
//! what a scene would see; the least of each state's times over the passes is the work alone, the
//! machine's interruptions (a core taken away for tens of µs, BENCHMARKS.md's noise tables) left out.

use crate::latency::Percentiles;
use knots::{KnotType, Namer, identify};
use nalgebra::Vector3;
use std::time::Instant;

/// How the states of one chain were named.
#[derive(Debug, Clone, Default)]
pub struct Naming {
    /// Joints per state.
    pub joints: usize,
    /// Time per state, nanoseconds.
    pub time: Percentiles,
    /// States whose reduced diagram the namer had not named before (their invariant computed).
    pub evaluated: u64,
    /// States also named by `identify`, and how many of them got the same name.
    pub sampled: u64,
    pub agreeing: u64,
    /// The name of the last state, fast and by `identify`.
    pub last: Option<(KnotType, KnotType)>,
    /// Each state's least time over the passes, nanoseconds.
    pub least: Percentiles,
    /// The longest of those among the states whose diagram was new, nanoseconds.
    pub new_max: u64,
}

/// How many times the states are named.
pub const PASSES: usize = 3;

/// Names `states` in order with one namer, timing each; `identify` names `samples` of them spread
/// evenly (and the last).
pub fn name_states(states: &[Vec<Vector3<f64>>], samples: usize) -> Naming {
    let histogram = || {
        hdrhistogram::Histogram::<u64>::new_with_bounds(1, 60_000_000_000, 3)
            .expect("valid HDR bounds")
    };
    let mut h = histogram();
    let mut names = Vec::with_capacity(states.len());
    let mut least = vec![u64::MAX; states.len()];
    let mut new = vec![false; states.len()];
    let mut evaluated = 0;
    for pass in 0..PASSES {
        let mut namer = Namer::new();
        for (k, s) in states.iter().enumerate() {
            let before = namer.evaluations();
            let t = Instant::now();
            let kind = namer.name(s);
            let ns = t.elapsed().as_nanos() as u64;
            least[k] = least[k].min(ns.max(1));
            if pass == 0 {
                let _ = h.record(ns.max(1));
                names.push(kind);
                new[k] = namer.evaluations() > before;
            }
        }
        if pass == 0 {
            evaluated = namer.evaluations();
        }
    }
    let mut l = histogram();
    for &ns in &least {
        let _ = l.record(ns);
    }
    let mut out = Naming {
        joints: states.first().map_or(0, Vec::len),
        time: Percentiles::of(&h),
        evaluated,
        least: Percentiles::of(&l),
        new_max: least
            .iter()
            .zip(&new)
            .filter(|(_, n)| **n)
            .map(|(t, _)| *t)
            .max()
            .unwrap_or(0),
        ..Naming::default()
    };
    if states.is_empty() {
        return out;
    }
    let every = (states.len() / samples.max(1)).max(1);
    for k in (0..states.len()).step_by(every).chain([states.len() - 1]) {
        let full = identify(&states[k]).kind;
        out.sampled += 1;
        out.agreeing += u64::from(full == names[k]);
        if k == states.len() - 1 {
            out.last = Some((names[k], full));
        }
    }
    out
}

impl std::fmt::Display for Naming {
    /// One line, as `watch` prints it and the tighten bench reads it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let us = |ns: u64| ns as f64 / 1e3;
        write!(
            f,
            "{} states of {} joints; µs per state p50 {:.1} p99 {:.1} p99.9 {:.1} max {:.1}; \
             evaluated {}; agrees with identify in {} of {} sampled",
            self.time.count,
            self.joints,
            us(self.time.p50),
            us(self.time.p99),
            us(self.time.p999),
            us(self.time.max),
            self.evaluated,
            self.agreeing,
            self.sampled
        )?;
        write!(
            f,
            "; the least of each state's passes p99.9 {:.1} max {:.1}; new diagrams max {:.1}",
            us(self.least.p999),
            us(self.least.max),
            us(self.new_max)
        )?;
        if let Some((fast, full)) = self.last {
            write!(f, "; last {} (identify {})", fast.name(), full.name())?;
        }
        Ok(())
    }
}
