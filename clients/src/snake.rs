//! The snake of figure 4: its head follows a curve in space and the body follows the head by the tractrix.
//!
//! Curves are built from where the head is and where it points, so the same curve suits any snake: a
//! `crawl` (a lateral wave while it climbs a hill and comes down) or a `helix` (a climbing spiral), or
//! points read from a file. Every curve is resampled by arc length so each request moves the head by
//! one `step`.
//!
//! What a run reports is what the tractrix promises: the head on every target, every link length kept,
//! and the body following the head's path (each joint's distance from the path the head traced; the
//! tractrix cuts corners by about `L²/(2R)` for links of length `L` on a bend of radius `R`).

use crate::connection::{Connection, Pacer, count_refusal};
use anyhow::bail;
use knots::vec3::{cross, dist, dot, lerp, sub, unit};
use shared::{Command, RequestHeader, Status, Vec3};
use std::time::{Duration, Instant};

/// Longest curve file, in points.
pub const MAX_CURVE_POINTS: usize = 1_000_000;

/// A curve for the head.
#[derive(Debug, Clone, PartialEq)]
pub enum Curve {
    /// Forward with a lateral sine wave (amplitude 3, wavelength 20) over one hill of height 8.
    /// (Built-in curves are `length` long, measured along the arc.)
    Crawl,
    /// A spiral of radius 6 about the heading, climbing 0.35 per unit of arc.
    Helix,
    /// Absolute points (the head first moves straight to the first).
    Points(Vec<[f64; 3]>),
}

impl Curve {
    /// `crawl`, `helix`, or a file of `x,y,z` lines (blank lines and `#` comments skipped).
    pub fn parse(spec: &str) -> Result<Curve, String> {
        match spec {
            "crawl" => Ok(Curve::Crawl),
            "helix" => Ok(Curve::Helix),
            path => {
                let meta = std::fs::metadata(path).map_err(|e| {
                    format!("curve {path:?}: not crawl, helix or a readable file ({e})")
                })?;
                if meta.len() > 64 * MAX_CURVE_POINTS as u64 {
                    return Err(format!(
                        "{path}: larger than {} bytes",
                        64 * MAX_CURVE_POINTS
                    ));
                }
                let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
                Curve::parse_points(&text, path).map(Curve::Points)
            }
        }
    }

    /// Points from text, one `x,y,z` (or `x y z`) per line.
    pub fn parse_points(text: &str, origin: &str) -> Result<Vec<[f64; 3]>, String> {
        let mut out = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            if out.len() == MAX_CURVE_POINTS {
                return Err(format!(
                    "{origin}:{}: more than {MAX_CURVE_POINTS} points",
                    i + 1
                ));
            }
            let v: Vec<&str> = line
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|s| !s.is_empty())
                .collect();
            if v.len() != 3 {
                return Err(format!(
                    "{origin}:{}: expected x,y,z, found {} numbers",
                    i + 1,
                    v.len()
                ));
            }
            let mut p = [0.0; 3];
            for (k, s) in v.iter().enumerate() {
                p[k] = s
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        format!(
                            "{origin}:{}: field {}: {s:?} is not a finite number",
                            i + 1,
                            k + 1
                        )
                    })?;
            }
            out.push(p);
        }
        if out.is_empty() {
            return Err(format!("{origin}: no points"));
        }
        Ok(out)
    }

    /// The head's targets: the curve started at `head` heading `dir`, `length` long (built-in curves),
    /// resampled every `step` of arc.
    pub fn targets(&self, head: [f64; 3], dir: [f64; 3], length: f64, step: f64) -> Vec<[f64; 3]> {
        let f = unit(dir).unwrap_or([1.0, 0.0, 0.0]);
        // A side direction in the horizontal plane and an up direction, both normal to the heading.
        let l = unit(cross(f, [0.0, 0.0, 1.0]))
            .or_else(|| unit(cross(f, [1.0, 0.0, 0.0])))
            .unwrap_or([0.0, 1.0, 0.0]);
        let u = cross(l, f);
        let at = |a: f64, b: f64, c: f64| {
            [
                head[0] + a * f[0] + b * l[0] + c * u[0],
                head[1] + a * f[1] + b * l[1] + c * u[1],
                head[2] + a * f[2] + b * l[2] + c * u[2],
            ]
        };
        let dense: Vec<[f64; 3]> = match self {
            Curve::Crawl => {
                let tau = std::f64::consts::TAU;
                // One hill over the forward distance the arc covers (the wave adds about a fifth).
                let hill = length / 1.2;
                by_arc(length, |t| {
                    at(
                        t,
                        3.0 * (tau * t / 20.0).sin(),
                        4.0 * (1.0 - (tau * t / hill).cos()),
                    )
                })
            }
            Curve::Helix => {
                let (r, climb): (f64, f64) = (6.0, 0.35);
                by_arc(length, |s| {
                    let c = climb * r;
                    let th = s / (r * r + c * c).sqrt();
                    at(c * th, r * th.sin(), r * (1.0 - th.cos()))
                })
            }
            Curve::Points(p) => std::iter::once(head).chain(p.iter().copied()).collect(),
        };
        resample(&dense, step)
    }
}

/// A dense polyline of `curve(t)` for growing `t`, cut where its arc reaches `length`.
fn by_arc(length: f64, curve: impl Fn(f64) -> [f64; 3]) -> Vec<[f64; 3]> {
    let dt = 0.02;
    let mut out = vec![curve(0.0)];
    let mut arc = 0.0;
    let mut t = 0.0;
    // Bounded: every built-in curve gains at least a fraction of dt of arc per step.
    while arc < length && out.len() < 100 * MAX_CURVE_POINTS {
        t += dt;
        let p = curve(t);
        let prev = out[out.len() - 1];
        let d = dist(prev, p);
        if arc + d >= length {
            out.push(lerp(prev, p, (length - arc) / d));
            break;
        }
        arc += d;
        out.push(p);
    }
    out
}

/// Points every `step` of arc along a polyline (the first point left out: it is where the head is; the
/// last point kept).
pub fn resample(poly: &[[f64; 3]], step: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let mut carried = 0.0; // arc since the last emitted point
    for w in poly.windows(2) {
        let d = dist(w[0], w[1]);
        if d == 0.0 {
            continue;
        }
        let mut s = step - carried; // arc along this segment of the next point
        while s <= d {
            out.push(lerp(w[0], w[1], s / d));
            s += step;
        }
        carried = d - (s - step);
    }
    if let Some(&last) = poly.last()
        && out.last().is_none_or(|p| dist(*p, last) > 1e-12 * step)
        && poly.len() > 1
    {
        out.push(last);
    }
    out
}

/// What a snake run asks for.
#[derive(Debug, Clone)]
pub struct SnakeConfig {
    pub chain: String,
    pub curve: Curve,
    /// Length of a built-in curve.
    pub length: f64,
    /// Arc between two head targets (one request each).
    pub step: f64,
    /// Requests per second (0: as fast as the service answers).
    pub rate_hz: f64,
    /// Key frames to keep (evenly spaced, the first before the first move).
    pub frames: usize,
    pub progress: bool,
}

/// What a snake run did.
#[derive(Debug, Clone, Default)]
pub struct SnakeReport {
    pub requests: usize,
    pub ok: usize,
    /// Refusals by status name.
    pub refused: Vec<(String, u64)>,
    /// Largest distance between the head and its target after a move.
    pub head_error: f64,
    /// Largest change of a link's length over the kept frames and the final state.
    pub length_error: f64,
    /// Each joint's distance from the path the head traced (the initial body, then the curve), at the
    /// end: the largest, and over the joints.
    pub body_deviation_max: f64,
    pub body_deviation_mean: f64,
    /// Arc the head travelled.
    pub travelled: f64,
    pub elapsed: Duration,
    /// The head's path: the initial body, tail to head, then the targets.
    pub path: Vec<[f64; 3]>,
    /// `(request number, joints)`.
    pub frames: Vec<(usize, Vec<[f64; 3]>)>,
}

/// Drives the head of `cfg.chain` along `cfg.curve`.
pub fn run_snake(conn: &mut Connection, cfg: &SnakeConfig) -> anyhow::Result<SnakeReport> {
    if !(cfg.step.is_finite() && cfg.step > 0.0 && cfg.length.is_finite() && cfg.length > 0.0) {
        bail!("step and length must be positive");
    }
    if cfg.length / cfg.step > MAX_CURVE_POINTS as f64 {
        bail!("length / step is more than {MAX_CURVE_POINTS} moves");
    }
    let chain = conn.require_chain(&cfg.chain)?;
    let q = conn.call(RequestHeader::new(Command::Query, chain), &[])?;
    if !q.is_ok() {
        bail!("query {:?}: {}", cfg.chain, q.header.reason_str());
    }
    let start: Vec<[f64; 3]> = q.joints().iter().map(|p| p.to_array()).collect();
    let n = start.len();
    if n < 2 {
        bail!("chain {:?} has no links", cfg.chain);
    }
    let lengths: Vec<f64> = start.windows(2).map(|w| dist(w[0], w[1])).collect();
    let head = start[n - 1];
    let dir = sub(head, start[n - 2]);
    let targets = cfg.curve.targets(head, dir, cfg.length, cfg.step);
    if targets.is_empty() {
        bail!("the curve is empty");
    }
    let mut report = SnakeReport {
        path: start
            .iter()
            .copied()
            .chain(targets.iter().copied())
            .collect(),
        ..SnakeReport::default()
    };
    let every = (targets.len() / cfg.frames.saturating_sub(1).max(1)).max(1);
    if cfg.frames > 0 {
        report.frames.push((0, start.clone()));
    }
    let pacer = Pacer::new(cfg.rate_hz);
    let t0 = Instant::now();
    let mut last = start.clone();
    let mut prev = head;
    for (i, t) in targets.iter().enumerate() {
        pacer.wait(i);
        let h = RequestHeader::new(Command::Move, chain);
        let r = conn.call(h, &[Vec3::new(t[0], t[1], t[2])])?;
        report.requests += 1;
        match r.header.status() {
            Some(Status::Ok) => {
                report.ok += 1;
                last = r.joints().iter().map(|p| p.to_array()).collect();
                let got = *last.last().unwrap_or(&[f64::NAN; 3]);
                report.head_error = report.head_error.max(dist(got, *t));
                report.travelled += dist(prev, *t);
                prev = *t;
            }
            other => count_refusal(&mut report.refused, other.map_or("unknown", |s| s.name())),
        }
        let done = i + 1;
        let at_end = done == targets.len();
        if cfg.frames > 0
            && (done % every == 0 || at_end)
            && (report.frames.len() < cfg.frames || at_end)
        {
            // The last frame is always the final pose.
            if report.frames.len() == cfg.frames {
                report.frames.pop();
            }
            report.frames.push((done, last.clone()));
        }
        if cfg.progress && done % 100 == 0 {
            eprintln!("snake: {done}/{} moves", targets.len());
        }
    }
    report.elapsed = t0.elapsed();
    for joints in report
        .frames
        .iter()
        .map(|f| &f.1)
        .chain(std::iter::once(&last))
    {
        for (w, l) in joints.windows(2).zip(&lengths) {
            report.length_error = report.length_error.max((dist(w[0], w[1]) - l).abs());
        }
    }
    let devs: Vec<f64> = last
        .iter()
        .map(|p| distance_to_polyline(*p, &report.path))
        .collect();
    report.body_deviation_max = devs.iter().copied().fold(0.0, f64::max);
    report.body_deviation_mean = devs.iter().sum::<f64>() / devs.len() as f64;
    Ok(report)
}

/// Distance from `p` to the nearest point of a polyline.
pub fn distance_to_polyline(p: [f64; 3], poly: &[[f64; 3]]) -> f64 {
    if poly.len() == 1 {
        return dist(p, poly[0]);
    }
    poly.windows(2)
        .map(|w| {
            let d = sub(w[1], w[0]);
            let dd = dot(d, d);
            let t = if dd > 0.0 {
                (dot(sub(p, w[0]), d) / dd).clamp(0.0, 1.0)
            } else {
                0.0
            };
            dist(p, lerp(w[0], w[1], t))
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_spaces_targets_by_the_step_along_the_arc() {
        let poly = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.05, 0.0]];
        let t = resample(&poly, 0.5);
        // 3.05 of arc: 6 full steps, then the end.
        assert_eq!(t.len(), 7);
        assert_eq!(t[0], [0.5, 0.0, 0.0]);
        assert!((t[2][0] - 1.0).abs() < 1e-12 && (t[2][1] - 0.5).abs() < 1e-12);
        assert_eq!(*t.last().unwrap(), [1.0, 2.05, 0.0]);
    }

    #[test]
    fn built_in_curves_start_at_the_head_and_have_the_asked_length() {
        for c in [Curve::Crawl, Curve::Helix] {
            let head = [0.0, -50.0, 0.0];
            let t = c.targets(head, [0.0, -1.0, 0.0], 60.0, 0.25);
            assert!(dist(t[0], head) <= 0.25 + 1e-9, "{c:?}");
            let arc: f64 = std::iter::once(head)
                .chain(t.iter().copied())
                .collect::<Vec<_>>()
                .windows(2)
                .map(|w| dist(w[0], w[1]))
                .sum();
            // Chords are a little shorter than the arc they cut.
            assert!((arc - 60.0).abs() < 0.05, "{c:?}: {arc}");
            // Leaves the plane of the initial body: a curve in space.
            assert!(t.iter().any(|p| p[2].abs() > 2.0), "{c:?}");
            // Heads on, not back into the body.
            assert!(t[3][1] < head[1], "{c:?}");
        }
    }

    #[test]
    fn curve_files_are_checked_with_line_and_field() {
        let e = Curve::parse_points("1,2,3\n\n4,x,6\n", "c.txt").unwrap_err();
        assert_eq!(e, "c.txt:3: field 2: \"x\" is not a finite number");
        let e = Curve::parse_points("1 2\n", "c.txt").unwrap_err();
        assert!(e.starts_with("c.txt:1: expected x,y,z"), "{e}");
        let p = Curve::parse_points("# a comment\n1, 2, 3 # trailing\n", "c").unwrap();
        assert_eq!(p, vec![[1.0, 2.0, 3.0]]);
        assert!(Curve::parse_points("1,2,inf", "c").is_err());
    }

    #[test]
    fn distance_to_a_polyline() {
        let poly = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(distance_to_polyline([1.0, 1.0, 0.0], &poly), 1.0);
        assert_eq!(distance_to_polyline([3.0, 0.0, 0.0], &poly), 1.0);
    }
}
