//! Scenes: the chains a service instance holds, read from TOML and validated before anything is built.
//!
//! A scene is a list of `[[chain]]` tables. Each chain declares what it needs, and the service builds
//! nothing more: planar chains get planar (2D) state and math, f32 chains f32 state, and collision
//! structures exist only for chains that declare collision.
//!
//! | field | type | default | meaning |
//! |---|---|---|---|
//! | `name` | string, 1..=31 bytes | required | unique handle for clients |
//! | `kind` | `"free"` \| `"fixed-base"` | `"free"` | a rope or snake, or a manipulator whose joint 0 never moves |
//! | `space` | `"planar"` \| `"spatial"` | `"spatial"` | planar chains live in the z = 0 plane |
//! | `links` | integer, 1..=65536 | required unless `shape = "points"` | number of links |
//! | `link_length` / `link_lengths` | positive number / list of `links` numbers | required unless `shape = "points"` | link lengths |
//! | `base` | `[x, y]` or `[x, y, z]` | origin | position of joint 0 (the tail; the base of a manipulator) |
//! | `shape` | `"straight"` \| `"arc"` \| `"points"` | `"straight"` | initial shape |
//! | `axis` | vector | `[1, 0, 0]` | direction of a straight chain; start tangent of an arc |
//! | `radius`, `bend` | number, vector | –, `[0, 1, 0]` | arc radius (≥ half the longest link) and the side it bends to |
//! | `points` | list of `links + 1` points | – | explicit joints (`shape = "points"`); lengths come from them |
//! | `thickness` | number ≥ 0 | 0 | diameter, for collision and pictures |
//! | `collision` | `"none"` \| `"capsules"` \| `"paper-spheres"` | `"none"` | collision scheme (free chains only; see `kernel::collision`) |
//! | `self_collision` | bool | `true` with a scheme | whether links collide with each other |
//! | `obstacles` | list of obstacle names | `[]` | the `[[obstacle]]`s this chain avoids (needs a scheme) |
//! | `collision_iterations` | integer 1..=10000 | 64 | passes per substep before the chain is "locked" |
//! | `collision_tolerance` | number in (0, 1) | 0.01 | accepted penetration, fraction of the clearance |
//! | `precision` | `"f64"` \| `"f32"` | `"f64"` | arithmetic and storage of the chain |
//! | `method` | `"tractrix"` \| `"paper"` \| `"ftl"` | `"tractrix"` | default single-link method |
//! | `substeps` / `max_step` | integer ≥ 1 / fraction of the shortest link | `substeps = 1` | default substep policy |
//! | `max_substeps` | integer ≥ 1 | 65536 | a move needing more substeps is refused |
//! | `strategy` | `"translate-back"` \| `"two-link"` | `"translate-back"` | fixed-base strategy |
//! | `tolerance` | number in (0, 0.1] | 1e-9 | fixed-base tolerance, fraction of the total length |
//! | `max_iterations` | integer 1..=100000 | 1000 | fixed-base iteration limit |
//!
//! Static obstacles are `[[obstacle]]` tables: `name`, `shape = "sphere"` (`center`, `radius`),
//! `"capsule"` (`a`, `b`, `radius`) or `"plane"` (`point`, `normal`: the free side). A chain lists the
//! ones it avoids; a planar chain's obstacles must lie in its plane.
//!
//! Errors name the file, the line and the field; sizes are checked before anything is allocated.

use crate::kernel::collision::Scheme;
use crate::kernel::{Method, Strategy, Substeps};
use protocol::{
    COLLISION_OBSTACLES, COLLISION_PAPER_SPHERES, COLLISION_SELF, ChainKind, MAX_CHAINS, MAX_LINKS,
    NAME_LEN, Precision,
};
use serde::Deserialize;
use std::fmt;
use toml::Spanned;

/// The scene served when no file is given: the paper's rope, snake and planar manipulator.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/default.toml");
/// Name under which the default scene is reported in errors.
pub const DEFAULT_SCENE_NAME: &str = "<default scene>";
/// Largest scene file read (bytes).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;
/// Largest `max_substeps` a scene may allow.
pub const MAX_SUBSTEPS_LIMIT: u32 = 1 << 20;

/// A scene error: where and what.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub file: String,
    /// 1-based line (0 when the error concerns the whole file).
    pub line: usize,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}: {}", self.file, self.line, self.message)
        } else {
            write!(f, "{}: {}", self.file, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

/// One chain of a validated scene, everything resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainDef {
    pub name: String,
    pub kind: ChainKind,
    /// 2 or 3.
    pub dims: u32,
    /// `F64` or `F32`.
    pub precision: Precision,
    /// Initial joint positions, tail first (z = 0 for planar chains).
    pub points: Vec<[f64; 3]>,
    /// Link lengths.
    pub lengths: Vec<f64>,
    pub thickness: f64,
    /// Collision bits (`protocol::COLLISION_*`).
    pub collision: u32,
    /// Collision handling, when the chain declares a scheme.
    pub collision_spec: Option<CollisionSpec>,
    pub method: Method,
    pub substeps: Substeps<f64>,
    pub max_substeps: u32,
    pub strategy: Strategy,
    pub tolerance: f64,
    pub max_iterations: u32,
}

/// A chain's collision handling as its scene declares it.
#[derive(Debug, Clone, PartialEq)]
pub struct CollisionSpec {
    pub scheme: Scheme,
    pub self_collision: bool,
    pub iterations: u32,
    pub tolerance: f64,
    pub obstacles: Vec<ObstacleDef>,
}

/// A static obstacle of the scene.
#[derive(Debug, Clone, PartialEq)]
pub enum ObstacleDef {
    Sphere {
        center: [f64; 3],
        radius: f64,
    },
    Capsule {
        a: [f64; 3],
        b: [f64; 3],
        radius: f64,
    },
    /// `normal` is unit length.
    Plane {
        point: [f64; 3],
        normal: [f64; 3],
    },
}

/// A validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub chains: Vec<ChainDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    #[serde(default)]
    chain: Vec<Spanned<RawChain>>,
    #[serde(default)]
    obstacle: Vec<Spanned<RawObstacle>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObstacle {
    name: Spanned<String>,
    shape: Spanned<String>,
    center: Option<Spanned<Vec<f64>>>,
    radius: Option<Spanned<f64>>,
    a: Option<Spanned<Vec<f64>>>,
    b: Option<Spanned<Vec<f64>>>,
    point: Option<Spanned<Vec<f64>>>,
    normal: Option<Spanned<Vec<f64>>>,
}

/// Most links all the chains of a scene may have together (about 100 MB of state and buffers): a
/// short file cannot make the service allocate gigabytes.
pub const MAX_SCENE_LINKS: usize = 1 << 20;

/// Most obstacles a scene may declare (each is tested against every link of the chains that list it).
pub const MAX_OBSTACLES: usize = 256;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawChain {
    name: Spanned<String>,
    kind: Option<Spanned<String>>,
    space: Option<Spanned<String>>,
    links: Option<Spanned<i64>>,
    link_length: Option<Spanned<f64>>,
    link_lengths: Option<Spanned<Vec<f64>>>,
    base: Option<Spanned<Vec<f64>>>,
    shape: Option<Spanned<String>>,
    axis: Option<Spanned<Vec<f64>>>,
    radius: Option<Spanned<f64>>,
    bend: Option<Spanned<Vec<f64>>>,
    points: Option<Spanned<Vec<Vec<f64>>>>,
    thickness: Option<Spanned<f64>>,
    collision: Option<Spanned<String>>,
    self_collision: Option<Spanned<bool>>,
    obstacles: Option<Spanned<Vec<String>>>,
    collision_iterations: Option<Spanned<i64>>,
    collision_tolerance: Option<Spanned<f64>>,
    precision: Option<Spanned<String>>,
    method: Option<Spanned<String>>,
    substeps: Option<Spanned<i64>>,
    max_step: Option<Spanned<f64>>,
    max_substeps: Option<Spanned<i64>>,
    strategy: Option<Spanned<String>>,
    tolerance: Option<Spanned<f64>>,
    max_iterations: Option<Spanned<i64>>,
}

/// Reads and validates a scene file.
pub fn load_scene(path: &std::path::Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let whole = |message: String| SceneError {
        file: file.clone(),
        line: 0,
        message,
    };
    let meta = std::fs::metadata(path).map_err(|e| whole(format!("cannot read: {e}")))?;
    if meta.len() > MAX_SCENE_BYTES {
        return Err(whole(format!(
            "{} bytes; a scene file may have at most {MAX_SCENE_BYTES}",
            meta.len()
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| whole(format!("cannot read: {e}")))?;
    parse_scene(&text, &file)
}

/// The embedded default scene.
pub fn default_scene() -> Scene {
    parse_scene(DEFAULT_SCENE, DEFAULT_SCENE_NAME).expect("the embedded default scene is valid")
}

/// Parses and validates scene text; `file` names it in errors.
pub fn parse_scene(text: &str, file: &str) -> Result<Scene, SceneError> {
    let at = |span: std::ops::Range<usize>, message: String| SceneError {
        file: file.to_string(),
        line: line_of(text, span.start),
        message,
    };
    if text.len() as u64 > MAX_SCENE_BYTES {
        return Err(SceneError {
            file: file.into(),
            line: 0,
            message: format!("a scene may have at most {MAX_SCENE_BYTES} bytes"),
        });
    }
    let raw: RawScene = toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        let line_text = text[..]
            .lines()
            .nth(line_of(text, span.start).saturating_sub(1))
            .unwrap_or("")
            .trim();
        let message = e.message().trim().to_string();
        SceneError {
            file: file.to_string(),
            line: if e.span().is_some() {
                line_of(text, span.start)
            } else {
                0
            },
            message: if line_text.is_empty() {
                message
            } else {
                format!("{message} (in `{line_text}`)")
            },
        }
    })?;
    if raw.chain.is_empty() {
        return Err(SceneError {
            file: file.into(),
            line: 0,
            message: "the scene declares no [[chain]]".into(),
        });
    }
    if raw.chain.len() > MAX_CHAINS as usize {
        return Err(at(
            raw.chain[MAX_CHAINS as usize].span(),
            format!(
                "{} chains; a scene may have at most {MAX_CHAINS}",
                raw.chain.len()
            ),
        ));
    }
    if raw.obstacle.len() > MAX_OBSTACLES {
        return Err(at(
            raw.obstacle[MAX_OBSTACLES].span(),
            format!(
                "{} obstacles; a scene may have at most {MAX_OBSTACLES}",
                raw.obstacle.len()
            ),
        ));
    }
    let mut obstacles: Vec<(String, ObstacleDef)> = Vec::with_capacity(raw.obstacle.len());
    for o in &raw.obstacle {
        let o = o.get_ref();
        let def = obstacle_def(o, &at)?;
        if obstacles.iter().any(|(n, _)| n == o.name.get_ref()) {
            return Err(at(
                o.name.span(),
                format!(
                    "obstacle {:?}: field `name`: declared twice",
                    o.name.get_ref()
                ),
            ));
        }
        obstacles.push((o.name.get_ref().clone(), def));
    }
    let mut chains: Vec<ChainDef> = Vec::with_capacity(raw.chain.len());
    let mut total_links = 0usize;
    for c in &raw.chain {
        let def = chain_def(c.get_ref(), &obstacles, &at)?;
        total_links += def.lengths.len();
        if total_links > MAX_SCENE_LINKS {
            let c = c.get_ref();
            let span = c.links.as_ref().map(|l| l.span()).unwrap_or(c.name.span());
            return Err(at(
                span,
                format!(
                    "chain {:?}: field `links`: the scene's chains have {total_links} links in \
                     all; at most {MAX_SCENE_LINKS}",
                    def.name
                ),
            ));
        }
        if chains.iter().any(|d| d.name == def.name) {
            let c = c.get_ref();
            return Err(at(
                c.name.span(),
                format!("field `name`: chain {:?} is declared twice", def.name),
            ));
        }
        chains.push(def);
    }
    Ok(Scene { chains })
}

fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

type At<'a> = dyn Fn(std::ops::Range<usize>, String) -> SceneError + 'a;

/// A 2- or 3-vector of finite numbers (`z = 0` when two are given).
fn vector3(f: &Spanned<Vec<f64>>) -> Result<[f64; 3], String> {
    let v = f.get_ref();
    let p = match v.as_slice() {
        [x, y] => [*x, *y, 0.0],
        [x, y, z] => [*x, *y, *z],
        _ => return Err(format!("a point has 2 or 3 numbers, not {}", v.len())),
    };
    if p.iter().all(|x| x.is_finite()) {
        Ok(p)
    } else {
        Err(format!("{v:?} is not finite"))
    }
}

fn obstacle_def(o: &RawObstacle, at: &At<'_>) -> Result<ObstacleDef, SceneError> {
    let name = o.name.get_ref();
    let err = |span: std::ops::Range<usize>, field: &str, what: String| {
        at(span, format!("obstacle {name:?}: field `{field}`: {what}"))
    };
    let need_vec = |f: &Option<Spanned<Vec<f64>>>, field: &str| -> Result<[f64; 3], SceneError> {
        match f {
            Some(v) => vector3(v).map_err(|m| err(v.span(), field, m)),
            None => Err(err(o.shape.span(), field, "missing".into())),
        }
    };
    let radius = || -> Result<f64, SceneError> {
        match &o.radius {
            Some(r) if r.get_ref().is_finite() && *r.get_ref() > 0.0 => Ok(*r.get_ref()),
            Some(r) => Err(err(
                r.span(),
                "radius",
                format!("{} is not a positive finite number", r.get_ref()),
            )),
            None => Err(err(o.shape.span(), "radius", "missing".into())),
        }
    };
    match o.shape.get_ref().as_str() {
        "sphere" => Ok(ObstacleDef::Sphere {
            center: need_vec(&o.center, "center")?,
            radius: radius()?,
        }),
        "capsule" => Ok(ObstacleDef::Capsule {
            a: need_vec(&o.a, "a")?,
            b: need_vec(&o.b, "b")?,
            radius: radius()?,
        }),
        "plane" => {
            let n = need_vec(&o.normal, "normal")?;
            let len = norm(n);
            if !(len > 0.0 && len.is_finite()) {
                let span = o.normal.as_ref().map(|s| s.span()).unwrap_or(0..0);
                return Err(err(span, "normal", "must be a non-zero vector".into()));
            }
            Ok(ObstacleDef::Plane {
                point: need_vec(&o.point, "point")?,
                normal: [n[0] / len, n[1] / len, n[2] / len],
            })
        }
        other => Err(err(
            o.shape.span(),
            "shape",
            format!("{other:?} is not one of [\"sphere\", \"capsule\", \"plane\"]"),
        )),
    }
}

fn chain_def(
    c: &RawChain,
    obstacles: &[(String, ObstacleDef)],
    at: &At<'_>,
) -> Result<ChainDef, SceneError> {
    let name = c.name.get_ref().clone();
    let err = |span: std::ops::Range<usize>, field: &str, what: String| {
        at(span, format!("chain {name:?}: field `{field}`: {what}"))
    };
    if name.is_empty() || name.len() >= NAME_LEN || name.chars().any(|ch| ch.is_control()) {
        return Err(err(
            c.name.span(),
            "name",
            format!(
                "{name:?} must have 1..={} bytes and no control characters",
                NAME_LEN - 1
            ),
        ));
    }
    let choice =
        |f: &Option<Spanned<String>>, field: &str, options: &[&str], default: usize| match f {
            None => Ok(default),
            Some(s) => options
                .iter()
                .position(|o| o == s.get_ref())
                .ok_or_else(|| {
                    err(
                        s.span(),
                        field,
                        format!("{:?} is not one of {options:?}", s.get_ref()),
                    )
                }),
        };
    let kind = [ChainKind::Free, ChainKind::FixedBase]
        [choice(&c.kind, "kind", &["free", "fixed-base"], 0)?];
    let dims = [2u32, 3][choice(&c.space, "space", &["planar", "spatial"], 1)?];
    let precision =
        [Precision::F64, Precision::F32][choice(&c.precision, "precision", &["f64", "f32"], 0)?];
    let method = [
        Method::Tractrix,
        Method::TractrixPaper,
        Method::FollowTheLeader,
    ][choice(&c.method, "method", &["tractrix", "paper", "ftl"], 0)?];
    let strategy = [Strategy::TranslateBack, Strategy::TractrixTwoLink]
        [choice(&c.strategy, "strategy", &["translate-back", "two-link"], 0)?];
    let shape = choice(&c.shape, "shape", &["straight", "arc", "points"], 0)?;
    let scheme = [None, Some(Scheme::Capsules), Some(Scheme::PaperSpheres)][choice(
        &c.collision,
        "collision",
        &["none", "capsules", "paper-spheres"],
        0,
    )?];

    // A vector field: 2 or 3 finite numbers; planar chains must stay in z = 0.
    let vector = |f: &Spanned<Vec<f64>>, field: &str| -> Result<[f64; 3], SceneError> {
        let v = f.get_ref();
        let p = match v.as_slice() {
            [x, y] => [*x, *y, 0.0],
            [x, y, z] => [*x, *y, *z],
            _ => {
                return Err(err(
                    f.span(),
                    field,
                    format!("a point has 2 or 3 numbers, not {}", v.len()),
                ));
            }
        };
        if !p.iter().all(|x| x.is_finite()) {
            return Err(err(f.span(), field, "numbers must be finite".into()));
        }
        if dims == 2 && p[2] != 0.0 {
            return Err(err(
                f.span(),
                field,
                "a planar chain lies in z = 0; z must be 0".into(),
            ));
        }
        Ok(p)
    };
    let positive = |f: &Spanned<f64>, field: &str| -> Result<f64, SceneError> {
        let v = *f.get_ref();
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(err(
                f.span(),
                field,
                format!("{v} is not a positive finite number"),
            ))
        }
    };
    let count = |f: &Spanned<i64>, field: &str, lo: i64, hi: i64| -> Result<u32, SceneError> {
        let v = *f.get_ref();
        if (lo..=hi).contains(&v) {
            Ok(v as u32)
        } else {
            Err(err(f.span(), field, format!("{v} is outside {lo}..={hi}")))
        }
    };

    let base = match &c.base {
        Some(b) => vector(b, "base")?,
        None => [0.0; 3],
    };
    let (points, lengths) = if shape == 2 {
        let pts = c.points.as_ref().ok_or_else(|| {
            err(
                c.name.span(),
                "points",
                "missing (shape = \"points\" needs it)".into(),
            )
        })?;
        for (field, present) in [
            ("links", c.links.is_some()),
            ("link_length", c.link_length.is_some()),
            ("link_lengths", c.link_lengths.is_some()),
            ("base", c.base.is_some()),
        ] {
            if present {
                return Err(err(
                    pts.span(),
                    field,
                    "not allowed with shape = \"points\" (the points define the chain)".into(),
                ));
            }
        }
        let n = pts.get_ref().len();
        if !(2..=MAX_LINKS as usize + 1).contains(&n) {
            return Err(err(
                pts.span(),
                "points",
                format!("{n} points; a chain has 2..={} joints", MAX_LINKS + 1),
            ));
        }
        let mut p = Vec::with_capacity(n);
        for (i, q) in pts.get_ref().iter().enumerate() {
            let s = Spanned::new(pts.span(), q.clone());
            p.push(vector(&s, &format!("points[{i}]"))?);
        }
        let mut lengths = Vec::with_capacity(n - 1);
        for (i, w) in p.windows(2).enumerate() {
            let d = [w[1][0] - w[0][0], w[1][1] - w[0][1], w[1][2] - w[0][2]];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if !(len.is_finite() && len > 0.0) {
                return Err(err(
                    pts.span(),
                    "points",
                    format!("points {i} and {} coincide or are too far apart", i + 1),
                ));
            }
            lengths.push(len);
        }
        (p, lengths)
    } else {
        let links = c
            .links
            .as_ref()
            .ok_or_else(|| err(c.name.span(), "links", "missing".into()))?;
        let n = count(links, "links", 1, MAX_LINKS as i64)? as usize;
        let lengths = match (&c.link_length, &c.link_lengths) {
            (Some(_), Some(l)) => {
                return Err(err(
                    l.span(),
                    "link_lengths",
                    "give `link_length` or `link_lengths`, not both".into(),
                ));
            }
            (Some(l), None) => vec![positive(l, "link_length")?; n],
            (None, Some(l)) => {
                if l.get_ref().len() != n {
                    return Err(err(
                        l.span(),
                        "link_lengths",
                        format!("{} lengths for {n} links", l.get_ref().len()),
                    ));
                }
                let mut v = Vec::with_capacity(n);
                for (i, &x) in l.get_ref().iter().enumerate() {
                    v.push(positive(
                        &Spanned::new(l.span(), x),
                        &format!("link_lengths[{i}]"),
                    )?);
                }
                v
            }
            (None, None) => {
                return Err(err(
                    links.span(),
                    "link_length",
                    "missing (or `link_lengths`)".into(),
                ));
            }
        };
        let axis = match &c.axis {
            Some(a) => vector(a, "axis")?,
            None => [1.0, 0.0, 0.0],
        };
        let an = norm(axis);
        if an == 0.0 {
            let span = c.axis.as_ref().map(|a| a.span()).unwrap_or(0..0);
            return Err(err(span, "axis", "must not be zero".into()));
        }
        let axis = scale(axis, 1.0 / an);
        let p = if shape == 0 {
            straight_points(base, axis, &lengths)
        } else {
            let r = c.radius.as_ref().ok_or_else(|| {
                err(
                    c.name.span(),
                    "radius",
                    "missing (shape = \"arc\" needs it)".into(),
                )
            })?;
            let radius = positive(r, "radius")?;
            let longest = lengths.iter().copied().fold(0.0, f64::max);
            if radius * 2.0 < longest {
                return Err(err(
                    r.span(),
                    "radius",
                    format!("{radius} is less than half the longest link ({longest})"),
                ));
            }
            let bend = match &c.bend {
                Some(b) => vector(b, "bend")?,
                None => [0.0, 1.0, 0.0],
            };
            // The bend direction, made perpendicular to the axis.
            let b = sub(bend, scale(axis, dot(bend, axis)));
            let bn = norm(b);
            if bn < 1e-12 * norm(bend).max(1.0) {
                let span = c.bend.as_ref().map(|b| b.span()).unwrap_or(c.name.span());
                return Err(err(span, "bend", "must not be parallel to `axis`".into()));
            }
            arc_points(base, axis, scale(b, 1.0 / bn), radius, &lengths)
        };
        (p, lengths)
    };
    if !points.iter().flatten().all(|x| x.is_finite()) {
        return Err(err(
            c.name.span(),
            "link_length",
            "the chain's joints overflow".into(),
        ));
    }
    // Free chains must start where positions can hold their link lengths (requests beyond that are
    // refused as too far; a chain that starts there could never be moved).
    let shortest = lengths.iter().copied().fold(f64::INFINITY, f64::min);
    let limit = protocol::max_coordinate(shortest, precision == Precision::F32);
    let far = points.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    if kind == ChainKind::Free && far > limit {
        let span = c.base.as_ref().map(|b| b.span()).unwrap_or(c.name.span());
        return Err(err(
            span,
            "base",
            format!(
                "a joint lies {far:e} from the origin, beyond {limit:e} (2^32 shortest links in \
                 f64, 2^12 in f32), where positions cannot hold the link lengths"
            ),
        ));
    }
    let thickness = match &c.thickness {
        None => 0.0,
        Some(t) if t.get_ref().is_finite() && *t.get_ref() >= 0.0 => *t.get_ref(),
        Some(t) => {
            return Err(err(
                t.span(),
                "thickness",
                format!("{} is not a finite number ≥ 0", t.get_ref()),
            ));
        }
    };
    let max_substeps = match &c.max_substeps {
        Some(m) => count(m, "max_substeps", 1, MAX_SUBSTEPS_LIMIT as i64)?,
        None => 1 << 16,
    };
    let substeps = match (&c.substeps, &c.max_step) {
        (Some(_), Some(m)) => {
            return Err(err(
                m.span(),
                "max_step",
                "give `substeps` or `max_step`, not both".into(),
            ));
        }
        (Some(k), None) => Substeps::Fixed(count(k, "substeps", 1, max_substeps as i64)?),
        (None, Some(m)) => Substeps::MaxStep(positive(m, "max_step")?),
        (None, None) => Substeps::Fixed(1),
    };
    let tolerance = match &c.tolerance {
        Some(t) => {
            let v = positive(t, "tolerance")?;
            if v > 0.1 {
                return Err(err(t.span(), "tolerance", format!("{v} is above 0.1")));
            }
            v
        }
        None => 1e-9,
    };
    let max_iterations = match &c.max_iterations {
        Some(m) => count(m, "max_iterations", 1, 100_000)?,
        None => 1000,
    };
    let collision_spec = match scheme {
        None => {
            // Collision knobs without a scheme would silently do nothing: refuse them.
            let stray = [
                c.self_collision
                    .as_ref()
                    .map(|s| ("self_collision", s.span())),
                c.obstacles.as_ref().map(|s| ("obstacles", s.span())),
                c.collision_iterations
                    .as_ref()
                    .map(|s| ("collision_iterations", s.span())),
                c.collision_tolerance
                    .as_ref()
                    .map(|s| ("collision_tolerance", s.span())),
            ];
            if let Some((field, span)) = stray.into_iter().flatten().next() {
                return Err(err(
                    span,
                    field,
                    "needs `collision = \"capsules\"` or `\"paper-spheres\"`".into(),
                ));
            }
            None
        }
        Some(scheme) => {
            let span = c.collision.as_ref().map(|s| s.span()).unwrap_or(0..0);
            if kind == ChainKind::FixedBase {
                return Err(err(
                    span,
                    "collision",
                    "collision is handled for free chains; a fixed-base reach does not check it"
                        .into(),
                ));
            }
            if scheme == Scheme::Capsules && thickness <= 0.0 {
                return Err(err(
                    span,
                    "thickness",
                    "capsule collision needs a positive `thickness` (the rope's diameter)".into(),
                ));
            }
            let iterations = match &c.collision_iterations {
                Some(m) => count(m, "collision_iterations", 1, 10_000)?,
                None => 64,
            };
            let tolerance = match &c.collision_tolerance {
                Some(t) if *t.get_ref() > 0.0 && *t.get_ref() < 1.0 => *t.get_ref(),
                Some(t) => {
                    return Err(err(
                        t.span(),
                        "collision_tolerance",
                        format!("{} is not strictly between 0 and 1", t.get_ref()),
                    ));
                }
                None => 0.01,
            };
            let mut list = Vec::new();
            if let Some(names) = &c.obstacles {
                for n in names.get_ref() {
                    let Some((_, o)) = obstacles.iter().find(|(m, _)| m == n) else {
                        return Err(err(
                            names.span(),
                            "obstacles",
                            format!("no [[obstacle]] is named {n:?}"),
                        ));
                    };
                    if dims == 2 && !in_plane(o) {
                        return Err(err(
                            names.span(),
                            "obstacles",
                            format!("obstacle {n:?} is not in the planar chain's plane z = 0"),
                        ));
                    }
                    list.push(o.clone());
                }
            }
            let self_collision = c.self_collision.as_ref().is_none_or(|s| *s.get_ref());
            Some(CollisionSpec {
                scheme,
                self_collision,
                iterations,
                tolerance,
                obstacles: list,
            })
        }
    };
    let collision = collision_spec.as_ref().map_or(0, |s| {
        (if s.self_collision { COLLISION_SELF } else { 0 })
            | (if s.obstacles.is_empty() {
                0
            } else {
                COLLISION_OBSTACLES
            })
            | (if s.scheme == Scheme::PaperSpheres {
                COLLISION_PAPER_SPHERES
            } else {
                0
            })
    });
    Ok(ChainDef {
        name,
        kind,
        dims,
        precision,
        points,
        lengths,
        thickness,
        collision,
        collision_spec,
        method,
        substeps,
        max_substeps,
        strategy,
        tolerance,
        max_iterations,
    })
}

/// Whether a planar chain (z = 0) can use the obstacle: its geometry lies in the plane.
fn in_plane(o: &ObstacleDef) -> bool {
    match o {
        ObstacleDef::Sphere { center, .. } => center[2] == 0.0,
        ObstacleDef::Capsule { a, b, .. } => a[2] == 0.0 && b[2] == 0.0,
        ObstacleDef::Plane { point, normal } => point[2] == 0.0 && normal[2] == 0.0,
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn straight_points(base: [f64; 3], axis: [f64; 3], lengths: &[f64]) -> Vec<[f64; 3]> {
    let mut p = Vec::with_capacity(lengths.len() + 1);
    p.push(base);
    let mut along = 0.0;
    for l in lengths {
        along += l;
        p.push(add(base, scale(axis, along)));
    }
    p
}

/// Joints on a circle of radius `r` through `base`, tangent to `axis` there, bending toward `bend`; each
/// link is a chord of its own length.
fn arc_points(
    base: [f64; 3],
    axis: [f64; 3],
    bend: [f64; 3],
    r: f64,
    lengths: &[f64],
) -> Vec<[f64; 3]> {
    let centre = add(base, scale(bend, r));
    let mut p = Vec::with_capacity(lengths.len() + 1);
    p.push(base);
    let mut phi = 0.0f64;
    for l in lengths {
        phi += 2.0 * (l / (2.0 * r)).min(1.0).asin();
        // Point at angle phi from the start, measured around the centre.
        let q = add(
            centre,
            add(scale(bend, -r * phi.cos()), scale(axis, r * phi.sin())),
        );
        p.push(q);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scene_is_the_papers() {
        let s = default_scene();
        let names: Vec<_> = s.chains.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["rope", "snake", "arm"]);
        assert_eq!(s.chains[0].lengths, vec![1.0; 40]);
        assert_eq!(s.chains[2].kind, ChainKind::FixedBase);
        assert_eq!(s.chains[2].dims, 2);
        assert_eq!(s.chains[2].lengths, vec![0.2; 10]);
    }

    #[test]
    fn an_arc_has_chords_of_the_link_lengths() {
        let s = parse_scene(
            "[[chain]]\nname = \"a\"\nlinks = 12\nlink_length = 0.5\nshape = \"arc\"\nradius = 2.0\n",
            "t.toml",
        )
        .unwrap();
        let p = &s.chains[0].points;
        for w in p.windows(2) {
            assert!((norm(sub(w[1], w[0])) - 0.5).abs() < 1e-12);
        }
        for q in p {
            assert!((norm(sub(*q, [0.0, 2.0, 0.0])) - 2.0).abs() < 1e-12);
        }
    }

    /// Each bad scene names the line and the field, and huge sizes are refused before allocation.
    #[test]
    fn errors_name_file_line_and_field() {
        let cases: &[(&str, usize, &str)] = &[
            (
                "[[chain]]\nname = \"a\"\nlinks = 1000000000\nlink_length = 1.0\n",
                3,
                "`links`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = -1.0\n",
                4,
                "`link_length`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = nan\n",
                4,
                "`link_length`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = \"four\"\nlink_length = 1.0\n",
                3,
                "links",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlinkk_length = 1.0\n",
                4,
                "linkk_length",
            ),
            ("[[chain]]\nname = \"a\"\nlink_length = 1.0\n", 2, "`links`"),
            (
                "[[chain]]\nname = \"a\"\nlinks = 4\nlink_length = 1.0\n\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\n",
                7,
                "twice",
            ),
            (
                "[[chain]]\nname = \"a\"\nspace = \"planar\"\nlinks = 2\nlink_length = 1.0\nbase = [0, 0, 1]\n",
                6,
                "`base`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nmethod = \"magic\"\n",
                5,
                "`method`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ncollision = \"self\"\n",
                5,
                "`collision`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\ncollision = \"capsules\"\n",
                5,
                "`thickness`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nobstacles = [\"post\"]\n",
                5,
                "`obstacles`: needs `collision",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\nobstacles = [\"post\"]\n",
                7,
                "no [[obstacle]] is named \"post\"",
            ),
            (
                "[[chain]]\nname = \"a\"\nkind = \"fixed-base\"\nlinks = 2\nlink_length = 1.0\ncollision = \"paper-spheres\"\n",
                6,
                "free chains",
            ),
            (
                "[[obstacle]]\nname = \"b\"\nshape = \"sphere\"\ncenter = [0, 0]\nradius = -1\n[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\n",
                5,
                "obstacle \"b\": field `radius`",
            ),
            (
                "[[obstacle]]\nname = \"t\"\nshape = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n[[chain]]\nname = \"a\"\nspace = \"planar\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\nobstacles = [\"t\"]\n",
                13,
                "not in the planar chain's plane",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = 0.1\ncollision = \"capsules\"\ncollision_tolerance = 1.5\n",
                7,
                "`collision_tolerance`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nsubsteps = 0\n",
                5,
                "`substeps`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1e308\nbase = [1e308, 0, 0]\n",
                2,
                "overflow",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nbase = [0, 5e9, 0]\n",
                5,
                "`base`: a joint lies 5e9",
            ),
            (
                "[[chain]]\nname = \"a\"\nprecision = \"f32\"\nlinks = 8000\nlink_length = 1.0\n",
                2,
                "2^12 in f32",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 0.0\n",
                4,
                "`link_length`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 0\nlink_length = 1.0\n",
                3,
                "`links`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = -4\nlink_length = 1.0\n",
                3,
                "`links`",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nthickness = \"thick\"\n",
                5,
                "thickness",
            ),
            ("[[chain]]\nlinks = 2\nlink_length = 1.0\n", 1, "name"),
            (
                "[[chain]]\nname = \"a\"\nlinks = 2\nlink_length = 1.0\nlink_length = 2.0\n",
                5,
                "duplicate",
            ),
            (
                "[[chain]]\nname = \"a\"\nlinks = 3\nlink_lengths = [1.0, 2.0]\n",
                4,
                "2 lengths for 3 links",
            ),
            ("[[chain]]\nname = \"a\"\nlinks = 2\n[[chain\n", 4, ""),
        ];
        for (text, line, field) in cases {
            let e = parse_scene(text, "bad.toml").expect_err(text);
            assert_eq!(e.file, "bad.toml");
            assert_eq!(e.line, *line, "{e}");
            assert!(e.message.contains(field), "{e} should mention {field}");
        }
        let empty = parse_scene("", "empty.toml").unwrap_err();
        assert!(empty.message.contains("no [[chain]]"));
    }

    /// Many chains at the per-chain maximum: the total is bounded, and the error names the chain that
    /// crosses it (its `links` line), before its successors are built.
    #[test]
    fn the_scene_total_of_links_is_bounded() {
        let text: String = (0..40)
            .map(|i| format!("[[chain]]\nname = \"c{i}\"\nlinks = 65536\nlink_length = 1.0\n"))
            .collect();
        let e = parse_scene(&text, "big.toml").unwrap_err();
        // Chain 16 (the 17th) crosses 2^20; each chain takes 4 lines, `links` is the third.
        assert_eq!(e.line, 16 * 4 + 3, "{e}");
        assert!(e.message.contains("chain \"c16\": field `links`"), "{e}");
        assert!(e.message.contains("at most 1048576"), "{e}");
        // 16 such chains are fine.
        let ok: String = text
            .lines()
            .take(16 * 4)
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(parse_scene(&ok, "ok.toml").unwrap().chains.len(), 16);
    }
}
