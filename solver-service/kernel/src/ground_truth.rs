//! Continuous ground truth: the defining motion integrated by an adaptive high-order method.
//!
//! While the driven joint moves along a straight segment at constant velocity, every other joint moves
//! along its link (the tractrix condition, section 2.1) with the speed that keeps the link's length:
//! for a joint `t` trailing a joint `h` with unit direction `e = (t − h)/|t − h|`,
//!
//! ```text
//! ṫ = (ḣ · e) e
//! ```
//!
//! propagated outward from the driven joint. The whole chain is one ODE system, integrated segment by
//! segment by Dormand–Prince 8(5,3) (`ode_solvers::Dop853`) at tight tolerances. Tests and the accuracy
//! report measure every discrete method against this. It allocates and is slow; it is not for the service.

use crate::chain::ChainError;
use crate::math::{Real, Vector, all_finite};
use nalgebra::Vector3;
use ode_solvers::dop_shared::{IntegrationError, OutputType};
use ode_solvers::{DVector, Dop853, System};

/// Integration tolerances of the ground truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundTruthOptions {
    /// Relative tolerance of the adaptive step control.
    pub rtol: f64,
    /// Absolute tolerance, in the chain's length units.
    pub atol: f64,
}

impl Default for GroundTruthOptions {
    fn default() -> Self {
        GroundTruthOptions {
            rtol: 1e-12,
            atol: 1e-13,
        }
    }
}

/// Why the ground truth could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum GroundTruthError {
    /// Bad input.
    #[error(transparent)]
    Chain(#[from] ChainError),
    /// The integrator gave up.
    #[error("integration failed: {0}")]
    Integration(#[from] IntegrationError),
}

struct TractrixOde<const D: usize> {
    joint: usize,
    n_joints: usize,
    velocity: Vector<f64, D>,
}

impl<const D: usize> TractrixOde<D> {
    #[inline]
    fn at(y: &DVector<f64>, i: usize) -> Vector<f64, D> {
        Vector::<f64, D>::from_fn(|k, _| y[i * D + k])
    }
    #[inline]
    fn put(dy: &mut DVector<f64>, i: usize, v: &Vector<f64, D>) {
        for k in 0..D {
            dy[i * D + k] = v[k];
        }
    }
    /// The trailing joint's velocity given the leading joint's.
    #[inline]
    fn follow(
        lead: &Vector<f64, D>,
        trail: &Vector<f64, D>,
        lead_vel: &Vector<f64, D>,
    ) -> Vector<f64, D> {
        let e = trail - lead;
        let n2 = e.norm_squared();
        if n2 == 0.0 {
            return *lead_vel;
        }
        e * (lead_vel.dot(&e) / n2)
    }
}

impl<const D: usize> System<f64, DVector<f64>> for TractrixOde<D> {
    fn system(&self, _x: f64, y: &DVector<f64>, dy: &mut DVector<f64>) {
        let m = self.joint;
        Self::put(dy, m, &self.velocity);
        let mut vel = self.velocity;
        for i in (0..m).rev() {
            vel = Self::follow(&Self::at(y, i + 1), &Self::at(y, i), &vel);
            Self::put(dy, i, &vel);
        }
        let mut vel = self.velocity;
        for i in m + 1..self.n_joints {
            vel = Self::follow(&Self::at(y, i - 1), &Self::at(y, i), &vel);
            Self::put(dy, i, &vel);
        }
    }
}

/// Joint positions after joint `joint` of the chain through `points` moves along the straight segments to
/// each of `targets` in turn, with the rest of the chain following the continuous tractrix motion.
pub fn follow_path<T: Real, const D: usize>(
    points: &[Vector<T, D>],
    joint: usize,
    targets: &[Vector<T, D>],
    opts: &GroundTruthOptions,
) -> Result<Vec<Vector<f64, D>>, GroundTruthError> {
    if points.len() < 2 {
        return Err(ChainError::Empty.into());
    }
    if joint >= points.len() {
        return Err(ChainError::JointOutOfRange {
            joint,
            last: points.len() - 1,
        }
        .into());
    }
    if !points.iter().chain(targets).all(all_finite) {
        return Err(ChainError::NonFinite.into());
    }
    let n = points.len();
    let mut y = DVector::<f64>::from_fn(n * D, |i, _| points[i / D][i % D].to_f64());
    for t in targets {
        let t = t.map(|c| c.to_f64());
        let from = TractrixOde::<D>::at(&y, joint);
        let velocity = t - from;
        if velocity.norm() == 0.0 {
            continue;
        }
        let system = TractrixOde::<D> {
            joint,
            n_joints: n,
            velocity,
        };
        let mut solver = Dop853::from_param(
            system,
            0.0,
            1.0,
            1.0,
            y.clone(),
            opts.rtol,
            opts.atol,
            0.9,
            0.0,
            0.333,
            6.0,
            1.0,
            0.0,
            10_000_000,
            u32::MAX,
            OutputType::Sparse,
        );
        solver.integrate()?;
        y = solver
            .y_out()
            .last()
            .cloned()
            .expect("the integrator reports the final state");
        // The driven joint is exactly on its target, as in the discrete methods.
        for k in 0..D {
            y[joint * D + k] = t[k];
        }
    }
    Ok((0..n).map(|i| TractrixOde::<D>::at(&y, i)).collect())
}

/// `samples` points of a helix of radius `r` and `pitch` per turn over `turns` turns, starting at `start`
/// (excluded) with its axis along +z: the head path of the convergence tests and the accuracy benches.
pub fn helix(
    start: Vector3<f64>,
    r: f64,
    pitch: f64,
    turns: f64,
    samples: usize,
) -> Vec<Vector3<f64>> {
    (1..=samples)
        .map(|k| {
            let a = std::f64::consts::TAU * turns * k as f64 / samples as f64;
            start
                + Vector3::new(
                    r * a.cos() - r,
                    r * a.sin(),
                    pitch * a / std::f64::consts::TAU,
                )
        })
        .collect()
}
