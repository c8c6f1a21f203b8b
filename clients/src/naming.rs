//! The knot's name with every state, timed: what `watch --name-knots` reports after a run.
//!
//! The states a run published (every one, in order) are named one after the other by one
//! [`tractrix::knot::Namer`], as a scene's rope would be named with each state, each call timed; a
//! sample of them (and the last) is also named by [`tractrix::knot::identify`], the six-closure
//! majority, to say how often the fast name agrees with it. The naming runs after the stream ended,
//! so the service and the hands do not share the cores with it.

use crate::latency::Percentiles;
use nalgebra::Vector3;
use std::time::Instant;
use tractrix::knot::{KnotType, Namer, identify};

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
}

/// Names `states` in order with one namer, timing each; `identify` names `samples` of them spread
/// evenly (and the last).
pub fn name_states(states: &[Vec<Vector3<f64>>], samples: usize) -> Naming {
    let mut namer = Namer::new();
    let mut h = hdrhistogram::Histogram::<u64>::new_with_bounds(1, 60_000_000_000, 3)
        .expect("valid HDR bounds");
    let mut names = Vec::with_capacity(states.len());
    for s in states {
        let t = Instant::now();
        let kind = namer.name(s);
        let ns = t.elapsed().as_nanos() as u64;
        let _ = h.record(ns.max(1));
        names.push(kind);
    }
    let mut out = Naming {
        joints: states.first().map_or(0, Vec::len),
        time: Percentiles::of(&h),
        evaluated: namer.evaluations(),
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
        if let Some((fast, full)) = self.last {
            write!(f, "; last {} (identify {})", fast.name(), full.name())?;
        }
        Ok(())
    }
}
