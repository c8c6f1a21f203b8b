//! The Rerun recording (feature `rerun`).

use super::Sink;
use anyhow::{Context, Result};
use nalgebra::{UnitQuaternion, Vector3};
use rerun::{
    Arrows3D, Capsules3D, Color, Ellipsoids3D, FillMode, LineStrips3D, Points3D, Quaternion,
    Radius, RecordingStream, RecordingStreamBuilder, Scalars, TextLog,
};
use shared::InstrumentPose;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// How often a chain's knot is identified at most.
const KNOT_EVERY: Duration = Duration::from_millis(200);

struct ChainView {
    name: String,
    radius: f32,
    free: bool,
    /// The limits drawn (joints at their limit), if any.
    limit: Option<super::LimitView>,
    last_knot: Option<String>,
    knot_at: Option<Instant>,
    /// The latest joints not yet identified.
    unidentified: Option<(u64, Vec<[f64; 3]>)>,
}

/// One Rerun recording of the state stream.
#[allow(missing_debug_implementations)] // RecordingStream has no Debug
pub struct RerunView {
    rec: RecordingStream,
    start: Instant,
    chains: HashMap<u32, ChainView>,
    /// Bundles by handle: their names.
    bundles: HashMap<u32, String>,
    logged: u64,
}

impl RerunView {
    /// Opens the recording. Nothing is sent before the first state.
    pub fn open(sink: Sink<'_>) -> Result<Self> {
        let builder = RecordingStreamBuilder::new("tractrix");
        let rec = match sink {
            Sink::Viewer(url) => builder
                .connect_grpc_opts(url)
                .with_context(|| format!("connect to the Rerun viewer at {url}"))?,
            Sink::File(path) => builder
                .save(path)
                .with_context(|| format!("create {}", path.display()))?,
        };
        Ok(Self {
            rec,
            start: Instant::now(),
            chains: HashMap::new(),
            bundles: HashMap::new(),
            logged: 0,
        })
    }

    /// Declares a chain: its name, thickness (0 for a line), whether it is free (knots are
    /// identified on free chains only) and its joint limits (the joints at their limit are drawn).
    pub fn add_chain(
        &mut self,
        chain: u32,
        name: &str,
        thickness: f64,
        free: bool,
        limit: Option<super::LimitView>,
    ) {
        self.chains.insert(
            chain,
            ChainView {
                name: name.to_owned(),
                radius: (thickness / 2.0) as f32,
                free,
                limit,
                last_knot: None,
                knot_at: None,
                unidentified: None,
            },
        );
    }

    /// Logs a chain's block of tissue (its corners `lo` and `hi`), static: a box in a flesh colour.
    pub fn tissue(&mut self, chain: u32, (lo, hi): ([f64; 3], [f64; 3])) -> Result<()> {
        let Some(c) = self.chains.get(&chain) else {
            return Ok(());
        };
        let f = |v: [f64; 3]| v.map(|x| x as f32);
        let size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        self.rec.log_static(
            format!("chains/{}/tissue", c.name),
            &rerun::Boxes3D::from_mins_and_sizes([f(lo)], [f(size)])
                .with_colors([Color::from_rgb(210, 150, 130)]),
        )?;
        Ok(())
    }

    /// Declares a bundle: its strands are drawn as one line strip each.
    pub fn add_bundle(&mut self, chain: u32, name: &str) {
        self.bundles.insert(chain, name.to_owned());
    }

    /// Logs one state of a bundle: `joints` strand after strand, `per_strand` of them each (tail
    /// first). `sequence` is the bundle's own count of changes (timeline `bundle_sequence`).
    pub fn bundle_state(
        &mut self,
        sequence: u64,
        chain: u32,
        joints: &[[f64; 3]],
        per_strand: usize,
    ) -> Result<()> {
        let Some(name) = self.bundles.get(&chain) else {
            return Ok(());
        };
        self.rec
            .set_time_sequence("bundle_sequence", sequence as i64);
        self.rec
            .set_duration_secs("elapsed", self.start.elapsed().as_secs_f64());
        let strips = joints.chunks(per_strand.max(1)).map(|s| {
            s.iter()
                .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
                .collect::<Vec<_>>()
        });
        self.rec.log(
            format!("bundles/{name}/strands"),
            &LineStrips3D::new(strips)
                .with_radii([Radius::new_ui_points(1.0)])
                .with_colors([Color::from_rgb(120, 70, 20)]),
        )?;
        self.logged += 1;
        Ok(())
    }

    fn at(&self, sequence: u64) {
        self.rec.set_time_sequence("sequence", sequence as i64);
        self.rec
            .set_duration_secs("elapsed", self.start.elapsed().as_secs_f64());
    }

    /// Logs one state: the joints (tail first), the held joints (with their pulls and taut flags),
    /// the chain's instruments and their pulls, its eyelets.
    pub fn state(
        &mut self,
        sequence: u64,
        chain: u32,
        joints: &[[f64; 3]],
        around: super::Around<'_>,
    ) -> Result<()> {
        let super::Around {
            held,
            instruments,
            instrument_pulls,
            eyelets,
        } = around;
        if !self.chains.contains_key(&chain) {
            return Ok(());
        }
        self.at(sequence);
        let c = self.chains.get_mut(&chain).expect("checked above");
        let pts: Vec<[f32; 3]> = joints
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
            .collect();
        let radius = if c.radius > 0.0 {
            Radius::new_scene_units(c.radius)
        } else {
            Radius::new_ui_points(1.5)
        };
        let base = format!("chains/{}", c.name);
        self.rec.log(
            format!("{base}/rope"),
            &LineStrips3D::new([pts.clone()])
                .with_radii([radius])
                .with_colors([Color::from_rgb(40, 90, 200)]),
        )?;
        let joint_radius = if c.radius > 0.0 {
            Radius::new_scene_units(c.radius * 1.1)
        } else {
            Radius::new_ui_points(2.5)
        };
        self.rec.log(
            format!("{base}/joints"),
            &Points3D::new(pts.iter().copied())
                .with_radii([joint_radius])
                .with_colors([Color::from_rgb(20, 40, 120)]),
        )?;
        let held: Vec<super::Held> = held
            .iter()
            .filter(|h| (h.joint as usize) < pts.len())
            .copied()
            .collect();
        let held_pts: Vec<[f32; 3]> = held.iter().map(|h| pts[h.joint as usize]).collect();
        let labels: Vec<String> = held
            .iter()
            .map(|h| format!("{} {}", if h.anchor { "anchor" } else { "grasp" }, h.joint))
            .collect();
        let colors: Vec<Color> = held
            .iter()
            .map(|h| {
                if h.anchor {
                    Color::from_rgb(150, 20, 20)
                } else {
                    Color::from_rgb(240, 140, 0)
                }
            })
            .collect();
        let held_radius = if c.radius > 0.0 {
            Radius::new_scene_units(c.radius * 2.0)
        } else {
            Radius::new_ui_points(5.0)
        };
        self.rec.log(
            format!("{base}/held"),
            &Points3D::new(held_pts)
                .with_radii([held_radius])
                .with_colors(colors)
                .with_labels(labels),
        )?;
        if let Some(limit) = c.limit {
            let at = limit.at_limit(joints);
            self.rec.log(
                format!("{base}/at_limit"),
                &Points3D::new(at.iter().map(|&j| pts[j]))
                    .with_radii([held_radius])
                    .with_colors([Color::from_rgb(230, 30, 30)])
                    .with_labels(at.iter().map(|j| j.to_string())),
            )?;
        }
        for (k, inst) in instruments.iter().enumerate() {
            log_instrument(&self.rec, &format!("{base}/instruments/{k}"), inst)?;
        }
        if !eyelets.is_empty() {
            // The points the rope passes through: green while threaded, grey once it has left.
            self.rec.log(
                format!("{base}/eyelets"),
                &Points3D::new(
                    eyelets
                        .iter()
                        .map(|e| [e.at.x as f32, e.at.y as f32, e.at.z as f32]),
                )
                .with_radii([held_radius])
                .with_colors(eyelets.iter().map(|e| {
                    if e.threaded {
                        Color::from_rgb(20, 160, 60)
                    } else {
                        Color::from_rgb(150, 150, 150)
                    }
                }))
                .with_labels(eyelets.iter().map(|e| {
                    if e.threaded {
                        format!("link {}", e.link)
                    } else {
                        "left".to_string()
                    }
                })),
            )?;
        }
        log_tension(&self.rec, &base, &pts, &held, instruments, instrument_pulls)?;
        if c.free && joints.len() >= 4 {
            c.unidentified = Some((sequence, joints.to_vec()));
        }
        self.logged += 1;
        Ok(())
    }

    /// States lost so far (sequence gaps).
    pub fn missed(&mut self, sequence: u64, missed: u64) -> Result<()> {
        self.at(sequence);
        self.rec
            .log("stream/missed", &Scalars::single(missed as f64))?;
        Ok(())
    }

    /// A query round trip measured by the caller.
    pub fn round_trip(&mut self, sequence: u64, rtt: Duration) -> Result<()> {
        self.at(sequence);
        self.rec.log(
            "latency/query_round_trip_us",
            &Scalars::single(rtt.as_secs_f64() * 1e6),
        )?;
        Ok(())
    }

    /// Identifies the knot of one chain whose latest state is not yet identified and whose last
    /// identification is older than 200 ms. Call when the stream is idle; returns whether it did work.
    pub fn identify_one(&mut self) -> Result<bool> {
        let now = Instant::now();
        let Some((&chain, _)) = self.chains.iter().find(|(_, c)| {
            c.unidentified.is_some() && c.knot_at.is_none_or(|t| now - t >= KNOT_EVERY)
        }) else {
            return Ok(false);
        };
        let c = self.chains.get_mut(&chain).expect("found above");
        let (sequence, joints) = c.unidentified.take().expect("found above");
        c.knot_at = Some(now);
        let pts: Vec<nalgebra::Vector3<f64>> = joints
            .iter()
            .map(|p| nalgebra::Vector3::new(p[0], p[1], p[2]))
            .collect();
        let report = knots::identify(&pts);
        let name = report.kind.name().to_owned();
        let base = format!("chains/{}", c.name);
        let changed = c.last_knot.as_deref() != Some(name.as_str());
        c.last_knot = Some(name.clone());
        self.at(sequence);
        self.rec.log(
            format!("{base}/knot_crossings"),
            &Scalars::single(report.crossings as f64),
        )?;
        if changed {
            self.rec.log(
                format!("{base}/knot"),
                &TextLog::new(format!(
                    "{name} ({} of {} closures agree)",
                    report.agreeing, report.closures
                )),
            )?;
        }
        Ok(true)
    }

    /// States logged so far.
    pub fn logged(&self) -> u64 {
        self.logged
    }

    /// Identifies what is left and writes everything out (a file is complete after this).
    pub fn finish(mut self) -> Result<()> {
        while self.identify_one()? {
            for c in self.chains.values_mut() {
                c.knot_at = None;
            }
        }
        self.rec
            .flush_blocking()
            .map_err(|e| anyhow::anyhow!("flush the Rerun recording: {e}"))?;
        Ok(())
    }
}

/// The pulls as arrows from their held joints and instruments (and their lengths as scalars), and the
/// taut stretches in red.
fn log_tension(
    rec: &RecordingStream,
    base: &str,
    pts: &[[f32; 3]],
    held: &[super::Held],
    instruments: &[InstrumentPose],
    instrument_pulls: &[[f64; 3]],
) -> Result<()> {
    if held.is_empty() && instruments.is_empty() {
        return Ok(());
    }
    let len = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let f = |p: [f64; 3]| [p[0] as f32, p[1] as f32, p[2] as f32];
    let mut origins = Vec::new();
    let mut vectors = Vec::new();
    let mut labels = Vec::new();
    for h in held {
        rec.log(
            format!("{base}/pull/joint_{}", h.joint),
            &Scalars::single(len(h.pull)),
        )?;
        if len(h.pull) > 0.0 {
            origins.push(pts[h.joint as usize]);
            vectors.push(f(h.pull));
            labels.push(format!("{:.3}", len(h.pull)));
        }
    }
    for (k, (inst, p)) in instruments.iter().zip(instrument_pulls).enumerate() {
        rec.log(
            format!("{base}/pull/instrument_{k}"),
            &Scalars::single(len(*p)),
        )?;
        if len(*p) > 0.0 {
            let c = [
                (inst.a.x + inst.b.x) / 2.0,
                (inst.a.y + inst.b.y) / 2.0,
                (inst.a.z + inst.b.z) / 2.0,
            ];
            origins.push(f(c));
            vectors.push(f(*p));
            labels.push(format!("{:.3}", len(*p)));
        }
    }
    rec.log(
        format!("{base}/pulls"),
        &Arrows3D::from_vectors(vectors)
            .with_origins(origins)
            .with_colors([Color::from_rgb(200, 0, 160)])
            .with_labels(labels),
    )?;
    let taut: Vec<Vec<[f32; 3]>> = held
        .windows(2)
        .filter(|w| w[0].taut)
        .map(|w| pts[w[0].joint as usize..=w[1].joint as usize].to_vec())
        .collect();
    rec.log(
        format!("{base}/taut"),
        &LineStrips3D::new(taut)
            .with_radii([Radius::new_ui_points(3.0)])
            .with_colors([Color::from_rgb(220, 30, 30)]),
    )?;
    Ok(())
}

/// One instrument: a capsule from `a` to `b`, or a sphere, in the instruments' steel grey.
fn log_instrument(rec: &RecordingStream, path: &str, p: &InstrumentPose) -> Result<()> {
    let grey = Color::from_rgb(150, 155, 165);
    let radius = p.radius as f32;
    let a = Vector3::new(p.a.x, p.a.y, p.a.z);
    if !p.capsule {
        let centre = [a.x as f32, a.y as f32, a.z as f32];
        rec.log(
            path,
            &Ellipsoids3D::from_centers_and_radii([centre], [radius])
                .with_colors([grey])
                .with_fill_mode(FillMode::Solid),
        )?;
        return Ok(());
    }
    let axis = Vector3::new(p.b.x, p.b.y, p.b.z) - a;
    // Rerun's capsules run along +Z from their translation.
    let turn = UnitQuaternion::rotation_between(&Vector3::z(), &axis).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    let q = turn.coords;
    rec.log(
        path,
        &Capsules3D::from_lengths_and_radii([axis.norm() as f32], [radius])
            .with_translations([[a.x as f32, a.y as f32, a.z as f32]])
            .with_quaternions([Quaternion::from_xyzw([
                q.x as f32, q.y as f32, q.z as f32, q.w as f32,
            ])])
            .with_colors([grey])
            .with_fill_mode(FillMode::Solid),
    )?;
    Ok(())
}
