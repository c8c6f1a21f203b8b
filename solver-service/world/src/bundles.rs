//! The scene's bundles at run time: many free strands moved together by one command. Each bundle is
//! a [`Bundle`] (the kernel's SIMD strands, on two cores when a move is large enough) in the precision
//! its scene declared, with its scene state for `reset` and a buffer for the targets (allocated once).
//!
//! [`Live::apply`] runs a [`BundleOp`], atomically: a refused command changes nothing. Bundles are not
//! persisted (their state is megabytes per move); each counts its own changes in [`Live::sequence`].

use crate::build::BuildError;
use crate::command::{BundleOp, Point};
use crate::refusal::Refusal;
use crate::refuse;
use crate::scene::BundleSpec;
use crate::two_cores::Bundle;
use nalgebra::{Rotation3, Vector3};
use tractrix::strands::{LANES, StrandReal, Strands};

/// The work of `op` on the bundle `spec` in block-steps (one block of [`LANES`] strands' links
/// following once; about as long as one link-step of a chain), for the service's budget.
pub fn estimate(spec: &BundleSpec, op: &BundleOp<'_>) -> u64 {
    let blocks = u64::from(spec.strands).div_ceil(LANES as u64);
    let links = u64::from(spec.links);
    match *op {
        BundleOp::Heads { substeps, .. } | BundleOp::Pose { substeps, .. } => blocks
            .saturating_mul(links)
            .saturating_mul(u64::from(substeps)),
        _ => blocks.saturating_mul(links),
    }
}

/// A bundle's strands in one precision.
#[derive(Debug, Clone)]
pub struct State<T: StrandReal + Send> {
    bundle: Bundle<T>,
    initial: Strands<T>,
    targets: Vec<Vector3<T>>,
}

/// The two precisions.
#[derive(Debug, Clone)]
pub enum Form {
    /// f64.
    F64(State<f64>),
    /// f32.
    F32(State<f32>),
}

/// One bundle of the running scene.
#[derive(Debug, Clone)]
pub struct Live {
    /// What the scene declared.
    pub spec: BundleSpec,
    /// The strands.
    pub form: Form,
    /// Accepted changes since the service started.
    pub sequence: u64,
}

fn state<T: StrandReal + Send>(spec: &BundleSpec) -> Result<State<T>, BuildError> {
    let v = |p: &Vector3<f64>| Vector3::new(T::lit(p.x), T::lit(p.y), T::lit(p.z));
    let heads: Vec<Vector3<T>> = spec.heads.iter().map(v).collect();
    let initial = Strands::straight(
        &heads,
        spec.links as usize,
        T::lit(spec.link_length),
        v(&spec.hang),
    )
    .map_err(|source| BuildError::Bundle {
        name: spec.name.clone(),
        source,
    })?;
    let bundle = Bundle::new(initial.clone(), spec.two_cores).map_err(|e| BuildError::Helper {
        name: spec.name.clone(),
        why: e.to_string(),
    })?;
    Ok(State {
        bundle,
        initial,
        targets: Vec::with_capacity(spec.strands as usize),
    })
}

impl Live {
    /// Builds the strands `spec` declares.
    pub fn new(spec: &BundleSpec) -> Result<Self, BuildError> {
        Ok(Live {
            form: match spec.precision {
                crate::scene::Precision::F32 => Form::F32(state(spec)?),
                _ => Form::F64(state(spec)?),
            },
            spec: spec.clone(),
            sequence: 0,
        })
    }

    /// Runs a decoded request; on a refusal nothing changed. Returns the substeps taken.
    pub fn apply(&mut self, op: &BundleOp<'_>) -> Result<u32, Refusal> {
        let r = match &mut self.form {
            Form::F64(s) => apply(s, &self.spec, op),
            Form::F32(s) => apply(s, &self.spec, op),
        }?;
        if op.changes_state() {
            self.sequence += 1;
        }
        Ok(r)
    }

    /// Whether moves of this bundle use a second thread.
    pub fn on_two_cores(&self) -> bool {
        match &self.form {
            Form::F64(s) => s.bundle.on_two_cores(),
            Form::F32(s) => s.bundle.on_two_cores(),
        }
    }

    /// The joints, strand after strand, each tail first.
    pub fn elements(&self) -> BundleElements<'_> {
        let blocks = match &self.form {
            Form::F64(s) => s.bundle.n_blocks(),
            Form::F32(s) => s.bundle.n_blocks(),
        };
        BundleElements {
            live: self,
            block: 0,
            blocks,
            buf: vec![Point::zeros(); LANES * (self.spec.links as usize + 1)],
            at: 0,
            len: 0,
        }
    }
}

fn apply<T: StrandReal + Send>(
    s: &mut State<T>,
    spec: &BundleSpec,
    op: &BundleOp<'_>,
) -> Result<u32, Refusal> {
    let v = |p: Point| Vector3::new(T::lit(p.x), T::lit(p.y), T::lit(p.z));
    let substeps = match *op {
        BundleOp::Heads { targets, substeps } => {
            s.targets.clear();
            s.targets.extend(targets.iter().map(|&p| v(p)));
            substeps
        }
        BundleOp::Pose {
            translation,
            rotation,
            substeps,
        } => {
            let r = Rotation3::from_scaled_axis(Vector3::new(rotation.x, rotation.y, rotation.z));
            let t = Vector3::new(translation.x, translation.y, translation.z);
            s.targets.clear();
            for (i, h0) in spec.heads.iter().enumerate() {
                let p = r * h0 + t;
                if p.amax().is_nan() || p.amax() > spec.max_coordinate {
                    return Err(refuse!(
                        TooFar,
                        "the pose takes head {i} {:.3e} from the origin, beyond {:.3e}",
                        p.amax(),
                        spec.max_coordinate
                    ));
                }
                s.targets.push(v(Point::new(p.x, p.y, p.z)));
            }
            substeps
        }
        BundleOp::Reset => {
            s.bundle.set_to(&s.initial);
            return Ok(0);
        }
        BundleOp::Query | BundleOp::Describe => return Ok(0),
    };
    // The targets were checked (count, finite, in range): an error here is the helper thread's death.
    s.bundle
        .move_heads(&s.targets, substeps as usize)
        .map_err(|e| refuse!(Internal, "{e}"))?;
    Ok(substeps)
}

/// A bundle's joints as points, strand after strand, each tail first (one block of
/// [`LANES`] strands computed at a time, eight lanes at once, straight into a block-sized buffer).
#[derive(Debug)]
pub struct BundleElements<'a> {
    live: &'a Live,
    block: usize,
    blocks: usize,
    buf: Vec<Point>,
    at: usize,
    len: usize,
}

impl BundleElements<'_> {
    /// Fills `buf` with the next block's joints; false at the end.
    fn refill(&mut self) -> bool {
        self.at = 0;
        self.len = 0;
        if self.block >= self.blocks {
            return false;
        }
        self.len = match &self.live.form {
            Form::F64(s) => s
                .bundle
                .block_joints_into(self.block, &mut self.buf, |p| Point::new(p.x, p.y, p.z)),
            Form::F32(s) => s.bundle.block_joints_into(self.block, &mut self.buf, |p| {
                Point::new(f64::from(p.x), f64::from(p.y), f64::from(p.z))
            }),
        };
        self.block += 1;
        self.len > 0
    }
}

impl Iterator for BundleElements<'_> {
    type Item = Point;
    #[inline]
    fn next(&mut self) -> Option<Point> {
        if self.at == self.len && !self.refill() {
            return None;
        }
        self.at += 1;
        Some(self.buf[self.at - 1])
    }
}
