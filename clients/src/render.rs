//! SVG pictures of chains and of joint-rotation plots (plotters, SVG backend only: no fonts or system
//! libraries needed, text sizes are estimated).
//!
//! * [`write_frames_svg`]: key frames like the paper's figures 4 to 7, one panel per frame, every chain
//!   projected orthographically along a [`View`] with a **depth cue**: links nearer the viewer are darker and
//!   wider, and links are painted far to near, so at a crossing the strand on top is the one drawn on top
//!   (a knot diagram can be read off the picture). All panels share one scale.
//! * [`write_plot_svg`]: line plots in panels with a legend (figure 8: joint rotations, dotted tractrix
//!   against solid pseudo-inverse).

use plotters::prelude::*;
use std::path::Path;

/// Why a picture could not be written.
#[derive(Debug, thiserror::Error)]
#[error("writing {path}: {message}")]
pub struct RenderError {
    pub path: String,
    pub message: String,
}

fn err<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> RenderError + '_ {
    move |e| RenderError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// An orthographic view: the viewer looks at the scene from azimuth (about +z, from +x) and elevation
/// (above the x-y plane), in degrees. `View::TOP` looks down the z axis, the plane of planar chains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
}

impl View {
    /// Straight down the z axis: x to the right, y up.
    pub const TOP: View = View {
        azimuth_deg: -90.0,
        elevation_deg: 90.0,
    };
    /// A three-quarter view from above, for spatial chains.
    pub const OBLIQUE: View = View {
        azimuth_deg: -60.0,
        elevation_deg: 30.0,
    };

    /// Looking from the side at motion along `dir` (which runs left to right), from `elevation_deg` above.
    pub fn side_on(dir: [f64; 3], elevation_deg: f64) -> View {
        let az = if dir[0].hypot(dir[1]) > 1e-12 {
            dir[1].atan2(dir[0]).to_degrees() - 90.0
        } else {
            -90.0
        };
        View {
            azimuth_deg: az,
            elevation_deg,
        }
    }

    /// `azimuth,elevation` in degrees.
    pub fn parse(s: &str) -> Result<View, String> {
        let v: Vec<f64> = s
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("view {s:?}: expected azimuth,elevation in degrees"))?;
        match v[..] {
            [a, e] if a.is_finite() && (-90.0..=90.0).contains(&e) => Ok(View {
                azimuth_deg: a,
                elevation_deg: e,
            }),
            _ => Err(format!(
                "view {s:?}: expected azimuth,elevation with elevation in [-90, 90]"
            )),
        }
    }

    /// Screen `(x, y)` and depth (larger is nearer the viewer) of a point.
    pub fn project(&self, p: [f64; 3]) -> (f64, f64, f64) {
        let (sa, ca) = self.azimuth_deg.to_radians().sin_cos();
        let (se, ce) = self.elevation_deg.to_radians().sin_cos();
        // Towards the viewer, screen right and screen up: an orthonormal right-handed frame.
        let toward = [ce * ca, ce * sa, se];
        let right = [-sa, ca, 0.0];
        let up = [-se * ca, -se * sa, ce];
        let dot = |a: [f64; 3]| a[0] * p[0] + a[1] * p[1] + a[2] * p[2];
        (dot(right), dot(up), dot(toward))
    }
}

/// One chain in a frame: its joints, tail first.
#[derive(Debug, Clone)]
pub struct Polyline {
    pub joints: Vec<[f64; 3]>,
    /// The colour of the nearest links; farther links fade towards white.
    pub color: (u8, u8, u8),
    /// Draw a dot at every joint (the manipulator pictures).
    pub markers: bool,
}

/// One panel: a caption, the chains and marked points (targets, drawn as crosses).
#[derive(Debug, Clone, Default)]
pub struct Frame {
    pub label: String,
    pub lines: Vec<Polyline>,
    pub marks: Vec<[f64; 3]>,
}

/// A projected link: depth, ends on screen, colour.
type Segment = (f64, (f64, f64), (f64, f64), (u8, u8, u8));

/// Pixel size of one panel.
pub const PANEL_PX: u32 = 360;

/// Writes `frames` as panels of one SVG picture, `columns` wide, all at one scale.
pub fn write_frames_svg(
    path: &Path,
    title: &str,
    frames: &[Frame],
    view: View,
    columns: usize,
) -> Result<(), RenderError> {
    let columns = columns.clamp(1, frames.len().max(1));
    let rows = frames.len().div_ceil(columns).max(1);
    // One scale and one depth range for every panel, so frames compare.
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let all = frames.iter().flat_map(|f| {
        f.lines
            .iter()
            .flat_map(|l| l.joints.iter())
            .chain(f.marks.iter())
    });
    for p in all {
        let q = view.project(*p);
        for (k, v) in [q.0, q.1, q.2].into_iter().enumerate() {
            if v.is_finite() {
                lo[k] = lo[k].min(v);
                hi[k] = hi[k].max(v);
            }
        }
    }
    if lo[0] > hi[0] || lo[0].is_nan() {
        (lo, hi) = ([-1.0; 3], [1.0; 3]);
    }
    // Equal scales on both axes; the panel's shape follows the picture's (within 1:4 and 3:2).
    let (wx, wy) = (
        (hi[0] - lo[0]).max(1e-9) * 1.08,
        (hi[1] - lo[1]).max(1e-9) * 1.08,
    );
    let aspect = (wy / wx).clamp(0.25, 1.5);
    let (wx, wy) = (wx.max(wy / aspect), wy.max(wx * aspect));
    let span = wx.max(wy);
    let (cx, cy) = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
    let (xr, yr) = (cx - wx / 2.0..cx + wx / 2.0, cy - wy / 2.0..cy + wy / 2.0);
    let depth_span = (hi[2] - lo[2]).max(1e-12);
    // 0 at the far end, 1 at the near end (a flat picture is all near).
    let nearness = |d: f64| {
        if hi[2] - lo[2] < 1e-9 * span {
            1.0
        } else {
            ((d - lo[2]) / depth_span).clamp(0.0, 1.0)
        }
    };

    let e = err(path);
    let panel_h = (PANEL_PX as f64 * aspect).round() as u32 + 30;
    let size = (PANEL_PX * columns as u32, panel_h * rows as u32 + 30);
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(&e)?;
    let root = root.titled(title, ("sans-serif", 18)).map_err(&e)?;
    let panels = root.split_evenly((rows, columns));
    for (area, frame) in panels.iter().zip(frames) {
        let mut chart = ChartBuilder::on(area)
            .caption(&frame.label, ("sans-serif", 13))
            .margin(6)
            .build_cartesian_2d(xr.clone(), yr.clone())
            .map_err(&e)?;
        // A thin frame instead of axes: a projection's screen coordinates mean little.
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(xr.start, yr.start), (xr.end, yr.end)],
                ShapeStyle::from(&RGBColor(200, 200, 200)).stroke_width(1),
            )))
            .map_err(&e)?;
        // Every link of every chain, painted far to near.
        let mut segments: Vec<Segment> = Vec::new();
        for line in &frame.lines {
            for w in line.joints.windows(2) {
                let (a, b) = (view.project(w[0]), view.project(w[1]));
                if [a.0, a.1, b.0, b.1].iter().all(|v| v.is_finite()) {
                    segments.push(((a.2 + b.2) / 2.0, (a.0, a.1), (b.0, b.1), line.color));
                }
            }
        }
        segments.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(segments.iter().map(|&(d, a, b, c)| {
                let t = nearness(d);
                PathElement::new(vec![a, b], depth_style(c, t))
            }))
            .map_err(&e)?;
        for line in frame.lines.iter().filter(|l| l.markers) {
            let (r, g, b) = line.color;
            chart
                .draw_series(line.joints.iter().map(|p| {
                    let q = view.project(*p);
                    Circle::new((q.0, q.1), 3, RGBColor(r, g, b).filled())
                }))
                .map_err(&e)?;
        }
        chart
            .draw_series(frame.marks.iter().map(|p| {
                let q = view.project(*p);
                Cross::new((q.0, q.1), 6, ShapeStyle::from(&RED).stroke_width(2))
            }))
            .map_err(&e)?;
    }
    root.present().map_err(&e)?;
    Ok(())
}

/// The depth cue: nearer is darker (the line's colour) and wider; farther fades to 30 % colour and 1 px.
fn depth_style((r, g, b): (u8, u8, u8), nearness: f64) -> ShapeStyle {
    let fade = 0.7 * (1.0 - nearness);
    let mix = |c: u8| (c as f64 + (255.0 - c as f64) * fade).round() as u8;
    ShapeStyle::from(&RGBColor(mix(r), mix(g), mix(b))).stroke_width(1 + (3.0 * nearness) as u32)
}

/// One curve of a plot.
#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub color: (u8, u8, u8),
    /// Dotted (the paper draws the tractrix dotted) instead of solid.
    pub dotted: bool,
}

/// One panel of a plot.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    pub title: String,
    pub series: Vec<Series>,
}

/// Writes line-plot panels with axes, labels and a legend, `columns` wide.
pub fn write_plot_svg(
    path: &Path,
    title: &str,
    (x_desc, y_desc): (&str, &str),
    panels: &[Panel],
    columns: usize,
) -> Result<(), RenderError> {
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let e = err(path);
    let root =
        SVGBackend::new(path, (440 * columns as u32, 340 * rows as u32 + 30)).into_drawing_area();
    root.fill(&WHITE).map_err(&e)?;
    let root = root.titled(title, ("sans-serif", 18)).map_err(&e)?;
    for (area, panel) in root.split_evenly((rows, columns)).iter().zip(panels) {
        let pts = panel.series.iter().flat_map(|s| s.points.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in pts.filter(|(x, y)| x.is_finite() && y.is_finite()) {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        let pad = |a: f64, b: f64| {
            let m = ((b - a) * 0.06).max(1e-9);
            a - m..b + m
        };
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 14))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(48)
            .build_cartesian_2d(pad(x0, x1), pad(y0, y1))
            .map_err(&e)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(&e)?;
        for s in &panel.series {
            let (r, g, b) = s.color;
            let color = RGBColor(r, g, b);
            let style = ShapeStyle::from(&color).stroke_width(2);
            let finite = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect::<Vec<_>>();
            let drawn = if s.dotted {
                chart.draw_series(DashedLineSeries::new(finite.clone(), 3, 4, style))
            } else {
                chart.draw_series(LineSeries::new(finite.clone(), style))
            };
            drawn
                .map_err(&e)?
                .label(s.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
            chart
                .draw_series(
                    finite
                        .iter()
                        .map(|&p| Circle::new(p, 2, ShapeStyle::from(&color).filled())),
                )
                .map_err(&e)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(&e)?;
    }
    root.present().map_err(&e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_is_orthonormal_and_top_view_keeps_the_plane() {
        let v = View::OBLIQUE;
        let (x, y, d) = v.project([1.0, 2.0, 3.0]);
        assert!(
            (x * x + y * y + d * d - 14.0).abs() < 1e-12,
            "lengths are kept"
        );
        let (x, y, d) = View::TOP.project([1.5, -2.0, 0.0]);
        assert!((x - 1.5).abs() < 1e-12 && (y + 2.0).abs() < 1e-12 && d.abs() < 1e-12);
        // Side on: the motion runs left to right.
        let v = View::side_on([0.0, -1.0, 0.0], 0.0);
        assert!(v.project([0.0, -1.0, 0.0]).0 > 0.999);
        assert!(View::parse("30,95").is_err() && View::parse("30").is_err());
        // Looking down, a point above is nearer.
        assert!(View::TOP.project([0.0, 0.0, 1.0]).2 > 0.0);
    }

    /// Links are painted far to near: in the file the far strand of a crossing comes first and is paler
    /// and thinner than the near one.
    #[test]
    fn crossing_strands_are_painted_far_to_near_with_a_depth_cue() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.svg");
        let near = Polyline {
            joints: vec![[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0]],
            color: (0, 0, 0),
            markers: false,
        };
        let far = Polyline {
            joints: vec![[0.0, -1.0, -1.0], [0.0, 1.0, -1.0]],
            color: (0, 0, 0),
            markers: false,
        };
        let frame = Frame {
            label: "crossing".into(),
            lines: vec![near, far],
            marks: vec![],
        };
        write_frames_svg(&path, "t", &[frame], View::TOP, 1).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"));
        let lines: Vec<&str> = svg.lines().filter(|l| l.contains("<polyline")).collect();
        assert_eq!(lines.len(), 2, "one path per link: {svg}");
        assert!(
            lines[0].contains("stroke-width=\"1\""),
            "far first, thin: {}",
            lines[0]
        );
        assert!(
            lines[1].contains("stroke-width=\"4\""),
            "near last, wide: {}",
            lines[1]
        );
        assert!(lines[0].contains("#B3B3B3"), "far is faded: {}", lines[0]);
        assert!(
            lines[1].contains("#000000"),
            "near keeps its colour: {}",
            lines[1]
        );
    }

    #[test]
    fn plots_have_a_legend_entry_per_series() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.svg");
        let s = |label: &str, dotted| Series {
            label: label.into(),
            points: (1..=10).map(|j| (j as f64, (j as f64).sqrt())).collect(),
            color: (0, 0, 200),
            dotted,
        };
        let panel = Panel {
            title: "p".into(),
            series: vec![s("tractrix", true), s("pseudo-inverse", false)],
        };
        write_plot_svg(&path, "t", ("joint", "deg"), &[panel], 1).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        let texts: Vec<&str> = svg.lines().map(str::trim).collect();
        assert!(
            texts.contains(&"tractrix") && texts.contains(&"pseudo-inverse"),
            "{svg}"
        );
    }
}
