//! The planar manipulator of figures 7 and 8: a fixed-base chain reaches a sequence of targets, by the
//! service's tractrix reach and, side by side, by the pseudo-inverse baseline (damped least squares,
//! [`tractrix::pseudo_inverse::reach_dls`]) run here on a copy of the same chain.
//!
//! Each target is approached in `steps` equal steps of the head along the straight line from where it is
//! (the intermediate configurations of figure 7); both methods start from the same configuration and each
//! continues from its own result. For every target the joint rotations of both are kept (figure 8): the
//! change of each relative joint angle, summed over the steps. The tractrix moves the joints near the base
//! least (remark 5: it minimises the motion of the links, not the joint rates); the pseudo-inverse
//! minimises joint rates in the least-squares sense and spreads the motion over all joints.
//!
//! With a direction every step is an orientation goal as well (Korein & Badler): the tractrix fixes
//! the last link along it and resolves the rest ([`tractrix::goals`]); the pseudo-inverse minimises
//! the joint rates of a three-row task, the head and the last link's angle
//! ([`tractrix::pseudo_inverse::reach_dls_pose`]).

use crate::connection::Connection;
use anyhow::bail;
use nalgebra::Vector2;
use shared::{ChainKind, Command, RequestHeader, Status, Vec3};
use std::time::Instant;
use tractrix::angles::planar_joint_motion;
use tractrix::chain::Chain;
use tractrix::pseudo_inverse::{DlsOptions, reach_dls, reach_dls_pose};

/// Most targets per run.
pub const MAX_TARGETS: usize = 64;

/// What a reach run asks for.
#[derive(Debug, Clone)]
pub struct ReachConfig {
    pub chain: String,
    pub targets: Vec<[f64; 2]>,
    /// Straight-line steps of the head towards each target (1: straight to it).
    pub steps: usize,
    /// Reach tolerance of both methods, as a fraction of the chain's length (0: the chain's default for
    /// the tractrix, 1e-9 for the pseudo-inverse).
    pub tolerance: f64,
    /// Reset the chain before the first target.
    pub reset: bool,
    /// An orientation goal at every step of every target: the last link along this direction (the
    /// tractrix's `FLAG_ORIENT` on the service, the pseudo-inverse's three-row task here).
    pub direction: Option<[f64; 2]>,
}

/// One method's way to one target.
#[derive(Debug, Clone, Default)]
pub struct Leg {
    /// Joints after each step (the last is the final pose).
    pub poses: Vec<Vec<[f64; 3]>>,
    /// Rotation of each joint over the leg, radians (joint 1 at the base).
    pub rotation: Vec<f64>,
    pub iterations: u64,
    /// Distance from head to target at the end.
    pub residual: f64,
    /// Solve time summed over the steps, ns (the service's own timing for the tractrix, timed here
    /// for the pseudo-inverse: both exclude transport).
    pub solve_ns: u64,
}

impl Leg {
    /// Σ |rotation| in radians.
    pub fn total_rotation(&self) -> f64 {
        self.rotation.iter().map(|r| r.abs()).sum()
    }
    /// Share of the total rotation made by the base half of the joints.
    pub fn base_share(&self) -> f64 {
        let total = self.total_rotation();
        let half = self.rotation.len() / 2;
        if total > 0.0 {
            self.rotation[..half].iter().map(|r| r.abs()).sum::<f64>() / total
        } else {
            0.0
        }
    }
}

/// Both methods' way to one target.
#[derive(Debug, Clone)]
pub struct TargetResult {
    pub target: [f64; 2],
    pub tractrix: Leg,
    pub pseudo_inverse: Leg,
    /// Configurations before the leg: the tractrix's, the pseudo-inverse's.
    pub start: (Vec<[f64; 3]>, Vec<[f64; 3]>),
}

fn links_of(joints: &[[f64; 3]]) -> Vec<Vector2<f64>> {
    joints
        .windows(2)
        .map(|w| Vector2::new(w[1][0] - w[0][0], w[1][1] - w[0][1]))
        .collect()
}

fn accumulate(rotation: &mut [f64], before: &[[f64; 3]], after: &[[f64; 3]]) {
    let mut d = vec![0.0; rotation.len()];
    planar_joint_motion(&links_of(before), &links_of(after), &mut d);
    for (r, x) in rotation.iter_mut().zip(d) {
        *r += x;
    }
}

/// Runs every target with both methods.
pub fn run_reach(conn: &mut Connection, cfg: &ReachConfig) -> anyhow::Result<Vec<TargetResult>> {
    if cfg.targets.is_empty() || cfg.targets.len() > MAX_TARGETS {
        bail!("give 1 to {MAX_TARGETS} targets");
    }
    if !(1..=1000).contains(&cfg.steps) {
        bail!("steps must be 1 to 1000");
    }
    if !(cfg.tolerance.is_finite() && (0.0..=0.1).contains(&cfg.tolerance)) {
        bail!("tolerance must be in [0, 0.1] (a fraction of the chain's length)");
    }
    let chain = conn.require_chain(&cfg.chain)?;
    let d = conn.call(RequestHeader::new(Command::Describe, chain), &[])?;
    if d.header.kind != ChainKind::FixedBase as u32 || d.header.dims != 2 {
        bail!(
            "chain {:?} is not a planar fixed-base manipulator",
            cfg.chain
        );
    }
    if cfg.reset {
        let r = conn.call(RequestHeader::new(Command::Reset, chain), &[])?;
        if !r.is_ok() {
            bail!("reset {:?}: {}", cfg.chain, r.header.reason_str());
        }
    }
    let q = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
    let mut tractrix_pose: Vec<[f64; 3]> = q.joints().iter().map(|p| p.to_array()).collect();
    let points: Vec<Vector2<f64>> = tractrix_pose
        .iter()
        .map(|p| Vector2::new(p[0], p[1]))
        .collect();
    let mut dls_chain =
        Chain::<f64, 2>::from_points(&points).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let dls_opts = DlsOptions {
        tolerance: if cfg.tolerance > 0.0 {
            cfg.tolerance
        } else {
            DlsOptions::<f64>::default().tolerance
        },
        ..DlsOptions::default()
    };
    let n_links = tractrix_pose.len() - 1;
    let mut results = Vec::new();
    for target in &cfg.targets {
        let dls_pose = |c: &Chain<f64, 2>| -> Vec<[f64; 3]> {
            c.positions().iter().map(|p| [p.x, p.y, 0.0]).collect()
        };
        let mut res = TargetResult {
            target: *target,
            tractrix: Leg {
                rotation: vec![0.0; n_links],
                ..Leg::default()
            },
            pseudo_inverse: Leg {
                rotation: vec![0.0; n_links],
                ..Leg::default()
            },
            start: (tractrix_pose.clone(), dls_pose(&dls_chain)),
        };
        let from_t = *tractrix_pose.last().unwrap_or(&[0.0; 3]);
        let from_d = dls_chain.head();
        for k in 1..=cfg.steps {
            let s = k as f64 / cfg.steps as f64;
            // Tractrix, on the service.
            let goal = [
                from_t[0] + (target[0] - from_t[0]) * s,
                from_t[1] + (target[1] - from_t[1]) * s,
            ];
            let mut h = RequestHeader::new(Command::Reach, chain);
            h.tolerance = cfg.tolerance;
            let r = match cfg.direction {
                None => conn.call(h, &[Vec3::new(goal[0], goal[1], 0.0)])?,
                Some(d) => {
                    h.flags = shared::FLAG_ORIENT;
                    conn.call(
                        h,
                        &[Vec3::new(goal[0], goal[1], 0.0), Vec3::new(d[0], d[1], 0.0)],
                    )?
                }
            };
            if r.header.status() != Some(Status::Ok) {
                bail!(
                    "tractrix reach of ({:.4}, {:.4}): {} ({})",
                    goal[0],
                    goal[1],
                    r.header.status().map_or("unknown", |s| s.name()),
                    r.header.reason_str()
                );
            }
            let after: Vec<[f64; 3]> = r.joints().iter().map(|p| p.to_array()).collect();
            accumulate(&mut res.tractrix.rotation, &tractrix_pose, &after);
            res.tractrix.iterations += r.header.iterations as u64;
            res.tractrix.solve_ns += r.header.solve_ns;
            res.tractrix.residual = r.header.residual;
            tractrix_pose = after;
            res.tractrix.poses.push(tractrix_pose.clone());
            // Pseudo-inverse, here.
            let goal = from_d + (Vector2::new(target[0], target[1]) - from_d) * s;
            let before = dls_pose(&dls_chain);
            let t0 = Instant::now();
            let out = match cfg.direction {
                None => reach_dls(&mut dls_chain, &goal, &dls_opts),
                Some(d) => {
                    reach_dls_pose(&mut dls_chain, &goal, &Vector2::new(d[0], d[1]), &dls_opts)
                }
            };
            res.pseudo_inverse.solve_ns += t0.elapsed().as_nanos() as u64;
            let out = out.map_err(|e| {
                anyhow::anyhow!(
                    "pseudo-inverse reach of ({:.4}, {:.4}): {e}",
                    goal.x,
                    goal.y
                )
            })?;
            let after = dls_pose(&dls_chain);
            accumulate(&mut res.pseudo_inverse.rotation, &before, &after);
            res.pseudo_inverse.iterations += out.iterations as u64;
            res.pseudo_inverse.residual = out.residual;
            res.pseudo_inverse.poses.push(after);
        }
        results.push(res);
    }
    Ok(results)
}

/// `x,y x,y ...`
pub fn parse_targets(s: &str) -> Result<Vec<[f64; 2]>, String> {
    let mut out = Vec::new();
    for (i, group) in s.split_whitespace().enumerate() {
        let v: Vec<f64> = group
            .split(',')
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("target {}: {group:?} is not x,y", i + 1))?;
        match v[..] {
            [x, y] if x.is_finite() && y.is_finite() => out.push([x, y]),
            _ => return Err(format!("target {}: {group:?} is not x,y (finite)", i + 1)),
        }
    }
    if out.is_empty() || out.len() > MAX_TARGETS {
        return Err(format!("give 1 to {MAX_TARGETS} targets"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_and_are_checked() {
        assert_eq!(
            parse_targets("1,0.9  -0.5,1").unwrap(),
            vec![[1.0, 0.9], [-0.5, 1.0]]
        );
        assert!(parse_targets("1,2,3").is_err());
        assert!(parse_targets("1,nan").is_err());
        assert!(parse_targets("").is_err());
    }

    #[test]
    fn rotations_accumulate_and_the_base_share_is_a_share() {
        let straight = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let bent = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let mut r = vec![0.0; 2];
        accumulate(&mut r, &straight, &bent);
        assert!(r[0].abs() < 1e-15 && (r[1] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        let leg = Leg {
            rotation: r,
            ..Leg::default()
        };
        assert_eq!(leg.base_share(), 0.0);
    }
}
