//! Validating a scene: raw tables into [`ChainSpec`]s of kernel types, every error with the file, the
//! line and the field. Sizes are checked before anything is allocated.

/// The largest `budget` a scene may set (about a minute of work at 50 ns per link-step).
const MAX_BUDGET: i64 = 1_000_000_000;

use super::read::{Field, RawBundle, RawChain, RawObstacle, RawScene, line_of};
use super::{
    BundleSpec, ChainSpec, CollisionSpec, LimitSpec, MAX_INSTRUMENTS, MAX_OBSTACLES,
    MAX_SCENE_BUNDLE_JOINTS, MAX_SCENE_LINKS, MAX_SUBSTEPS_LIMIT, Scene, SceneError, Wound, shapes,
};
use super::{ChainKind, Precision};
use crate::sizes::{
    MAX_BUNDLE_JOINTS, MAX_BUNDLE_STRANDS, MAX_CHAINS, MAX_EYELETS, MAX_HELD, MAX_LINKS,
    MAX_NAME_BYTES, max_coordinate,
};
use nalgebra::Vector3;
use std::ops::Range;
use toml::Spanned;
use tractrix::collision::{CollisionOptions, Obstacle, Scheme};
use tractrix::{LimitKind, Method, MoveOptions, ReachOptions, Strategy, Substeps};

mod collision;
mod geometry;
mod options;
mod parts;
use collision::*;
use geometry::*;
use options::*;
use parts::*;

/// Turns a span and a message into a located error.
type At<'a> = dyn Fn(Range<usize>, String) -> SceneError + 'a;

/// Validates a read scene; `text` and `file` locate errors.
pub(super) fn scene(raw: RawScene, text: &str, file: &str) -> Result<Scene, SceneError> {
    let at = |span: Range<usize>, message: String| SceneError {
        file: file.to_string(),
        line: line_of(text, span.start),
        message,
    };
    let whole = |message: &str| SceneError {
        file: file.into(),
        line: 0,
        message: message.into(),
    };
    if raw.chain.is_empty() && raw.bundle.is_empty() {
        return Err(whole("the scene declares no [[chain]] and no [[bundle]]"));
    }
    if raw.chain.len() > MAX_CHAINS {
        return Err(at(
            raw.chain[MAX_CHAINS].span(),
            format!(
                "{} chains; a scene may have at most {MAX_CHAINS}",
                raw.chain.len()
            ),
        ));
    }
    let obstacles = obstacles(&raw, &at)?;
    let instruments = instruments(&raw, &at)?;
    let chains = chains(&raw, &obstacles, &instruments, &at)?;
    let bundles = bundles(&raw, &chains, &at)?;
    Ok(Scene {
        chains,
        bundles,
        budget: budget(&raw.budget, "budget", &at)?,
        pull_budget: budget(&raw.pull_budget, "pull_budget", &at)?,
    })
}

/// Shapes by name: a scene's obstacles or instruments.
type Named = Vec<(String, Obstacle<f64, 3>)>;

/// The scene's `[[obstacle]]` tables, by name.
fn obstacles(raw: &RawScene, at: &At<'_>) -> Result<Named, SceneError> {
    if raw.obstacle.len() > MAX_OBSTACLES {
        return Err(at(
            raw.obstacle[MAX_OBSTACLES].span(),
            format!(
                "{} obstacles; a scene may have at most {MAX_OBSTACLES}",
                raw.obstacle.len()
            ),
        ));
    }
    let mut obstacles: Named = Vec::with_capacity(raw.obstacle.len());
    for o in &raw.obstacle {
        let o = o.get_ref();
        let ob = obstacle(o, at)?;
        if let Some(f) = &o.follows {
            return Err(at(
                f.span(),
                format!(
                    "obstacle {:?}: field `follows`: obstacles stay where they are; an \
                     [[instrument]] can follow a joint",
                    o.name.get_ref()
                ),
            ));
        }
        if obstacles.iter().any(|(n, _)| n == o.name.get_ref()) {
            return Err(at(
                o.name.span(),
                format!(
                    "obstacle {:?}: field `name`: declared twice",
                    o.name.get_ref()
                ),
            ));
        }
        obstacles.push((o.name.get_ref().clone(), ob));
    }
    Ok(obstacles)
}

/// The scene's `[[instrument]]` tables, by name (spheres and capsules only).
fn instruments(raw: &RawScene, at: &At<'_>) -> Result<Named, SceneError> {
    if raw.instrument.len() > MAX_INSTRUMENTS {
        return Err(at(
            raw.instrument[MAX_INSTRUMENTS].span(),
            format!(
                "{} instruments; a scene may have at most {MAX_INSTRUMENTS}",
                raw.instrument.len()
            ),
        ));
    }
    let mut instruments: Named = Vec::with_capacity(raw.instrument.len());
    for o in &raw.instrument {
        let o = o.get_ref();
        let name = o.name.get_ref();
        let ob = obstacle(o, at).map_err(|e| SceneError {
            message: e.message.replacen("obstacle", "instrument", 1),
            ..e
        })?;
        if matches!(ob, Obstacle::HalfSpace { .. }) {
            return Err(at(
                o.shape.span(),
                format!(
                    "instrument {name:?}: field `shape`: an instrument is a sphere or a capsule"
                ),
            ));
        }
        if instruments.iter().any(|(n, _)| n == name) {
            return Err(at(
                o.name.span(),
                format!("instrument {name:?}: field `name`: declared twice"),
            ));
        }
        instruments.push((name.clone(), ob));
    }
    Ok(instruments)
}

/// The scene's `[[chain]]` tables: each validated, its instruments' `follows` resolved against it,
/// every instrument listed by one chain at most, the links of all within the scene's bound, names
/// unique.
fn chains(
    raw: &RawScene,
    obstacles: &Named,
    instruments: &Named,
    at: &At<'_>,
) -> Result<Vec<ChainSpec>, SceneError> {
    // Which chain lists each instrument: one at most (its pose is that chain's state).
    let mut owner: Vec<Option<String>> = vec![None; instruments.len()];
    let mut chains: Vec<ChainSpec> = Vec::with_capacity(raw.chain.len());
    let mut total_links = 0usize;
    for c in &raw.chain {
        let mut spec = chain(c.get_ref(), obstacles, instruments, at)?;
        let n_links = spec.lengths.len();
        if let Some(col) = &mut spec.collision {
            // The joints its instruments follow, resolved against this chain.
            for (n, _) in &col.instruments {
                let i = instruments
                    .iter()
                    .position(|(m, _)| m == n)
                    .expect("validated");
                let follows = match &raw.instrument[i].get_ref().follows {
                    None => None,
                    Some(f) => Some(match f.get_ref().as_str() {
                        "head" => n_links as u32,
                        "tail" => 0,
                        s => match s.parse::<u32>() {
                            Ok(j) if (j as usize) <= n_links => j,
                            _ => {
                                return Err(at(
                                    f.span(),
                                    format!(
                                        "instrument {n:?}: field `follows`: {s:?} is not \
                                         \"head\", \"tail\" or a joint 0..={n_links} of chain {:?}",
                                        spec.name
                                    ),
                                ));
                            }
                        },
                    }),
                };
                col.follows.push(follows);
            }
        }
        if let Some(col) = &spec.collision {
            for (n, _) in &col.instruments {
                let i = instruments
                    .iter()
                    .position(|(m, _)| m == n)
                    .expect("validated");
                if let Some(first) = &owner[i] {
                    let span = c
                        .get_ref()
                        .instruments
                        .as_ref()
                        .map(|s| s.span())
                        .unwrap_or(c.span());
                    return Err(at(
                        span,
                        format!(
                            "chain {:?}: field `instruments`: instrument {n:?} already pushes chain \
                             {first:?}; an instrument belongs to one chain",
                            spec.name
                        ),
                    ));
                }
                owner[i] = Some(spec.name.clone());
            }
        }
        needle_capsules(&mut spec, c.get_ref(), at)?;
        total_links += spec.lengths.len();
        let c = c.get_ref();
        if total_links > MAX_SCENE_LINKS {
            let span = c.links.as_ref().map(|l| l.span()).unwrap_or(c.name.span());
            return Err(at(
                span,
                format!(
                    "chain {:?}: field `links`: the scene's chains have {total_links} links in \
                     all; at most {MAX_SCENE_LINKS}",
                    spec.name
                ),
            ));
        }
        if chains.iter().any(|d| d.name == spec.name) {
            return Err(at(
                c.name.span(),
                format!("field `name`: chain {:?} is declared twice", spec.name),
            ));
        }
        chains.push(spec);
    }
    Ok(chains)
}

/// A chain's needle as capsules after its instruments, each following the head, laid along the head
/// link and curving up ([`crate::needle::Needle::initial_bend`]); at most [`MAX_INSTRUMENTS`]
/// instruments in all.
fn needle_capsules(spec: &mut ChainSpec, c: &RawChain, at: &At<'_>) -> Result<(), SceneError> {
    let (Some(nd), Some(col)) = (spec.needle.as_mut(), spec.collision.as_mut()) else {
        return Ok(());
    };
    nd.first = col.instruments.len();
    if nd.first + nd.segments > MAX_INSTRUMENTS {
        let span = c.needle.as_ref().map(|s| s.span()).unwrap_or(c.name.span());
        return Err(at(
            span,
            format!(
                "chain {:?}: field `needle`: its {} capsules and {} instruments pass the most a \
                 chain carries ({MAX_INSTRUMENTS})",
                spec.name, nd.segments, nd.first
            ),
        ));
    }
    let n = spec.points.len() - 1;
    let (swage, before) = (spec.points[n], spec.points[n - 1]);
    let tangent = (swage - before).normalize();
    let bend = nd.first_bend(tangent);
    if !(bend.iter().all(|v| v.is_finite())) {
        let span = c
            .needle_bend
            .as_ref()
            .map(|s| s.span())
            .unwrap_or(c.name.span());
        return Err(at(
            span,
            format!(
                "chain {:?}: field `needle_bend`: along the head link, so no way to curve",
                spec.name
            ),
        ));
    }
    for (k, o) in nd.capsules(swage, tangent, bend).into_iter().enumerate() {
        col.instruments.push((format!("needle {k}"), o));
        col.follows.push(Some(n as u32));
    }
    Ok(())
}

/// The scene's `[[bundle]]` tables: names unique among chains and bundles, their joints within the
/// scene's bound.
fn bundles(
    raw: &RawScene,
    chains: &[ChainSpec],
    at: &At<'_>,
) -> Result<Vec<BundleSpec>, SceneError> {
    if chains.len() + raw.bundle.len() > MAX_CHAINS {
        return Err(at(
            raw.bundle[MAX_CHAINS - chains.len()].span(),
            format!(
                "{} chains and {} bundles; a scene may have at most {MAX_CHAINS} in all",
                chains.len(),
                raw.bundle.len()
            ),
        ));
    }
    let mut bundles: Vec<BundleSpec> = Vec::with_capacity(raw.bundle.len());
    let mut bundle_joints = 0usize;
    for b in &raw.bundle {
        let spec = bundle(b.get_ref(), at)?;
        let name = b.get_ref().name.get_ref();
        if chains.iter().any(|c| &c.name == name) || bundles.iter().any(|c| &c.name == name) {
            return Err(at(
                b.get_ref().name.span(),
                format!("field `name`: {name:?} is declared twice"),
            ));
        }
        bundle_joints += spec.joints();
        if bundle_joints > MAX_SCENE_BUNDLE_JOINTS {
            return Err(at(
                b.span(),
                format!(
                    "bundle {name:?}: the scene's bundles have {bundle_joints} joints in all; at \
                     most {MAX_SCENE_BUNDLE_JOINTS}"
                ),
            ));
        }
        bundles.push(spec);
    }
    Ok(bundles)
}

/// The scene's `budget` or `pull_budget` (`name`), if it sets one.
fn budget(field: &Field<i64>, name: &str, at: &At<'_>) -> Result<Option<u64>, SceneError> {
    Ok(match field {
        None => None,
        Some(b) => {
            let v = *b.get_ref();
            if !(1..=MAX_BUDGET).contains(&v) {
                return Err(at(
                    b.span(),
                    format!(
                        "field `{name}`: {v}: the work one request may cost, in link-steps, from 1 \
                         to {MAX_BUDGET}"
                    ),
                ));
            }
            Some(v as u64)
        }
    })
}

/// One `[[bundle]]` table.
fn bundle(b: &RawBundle, at: &At<'_>) -> Result<BundleSpec, SceneError> {
    let name = b.name.get_ref().clone();
    let f = Fields {
        c: b,
        table: "bundle",
        name: &name,
        at,
        dims: 3,
    };
    f.check_name(b.name.span())?;
    let need = |field: &str| f.err(b.name.span(), field, "missing".into());
    let strands = f.count(
        b.strands.as_ref().ok_or_else(|| need("strands"))?,
        "strands",
        1,
        MAX_BUNDLE_STRANDS as i64,
    )?;
    let links_field = b.links.as_ref().ok_or_else(|| need("links"))?;
    let links = f.count(links_field, "links", 1, MAX_BUNDLE_JOINTS as i64 - 1)?;
    if (strands as usize) * (links as usize + 1) > MAX_BUNDLE_JOINTS {
        return Err(f.err(
            links_field.span(),
            "links",
            format!(
                "{strands} strands of {links} links have {} joints; a bundle may have at most \
                 {MAX_BUNDLE_JOINTS}",
                strands as usize * (links as usize + 1)
            ),
        ));
    }
    let link_length = f.positive(
        b.link_length.as_ref().ok_or_else(|| need("link_length"))?,
        "link_length",
    )?;
    let precision = f.choice(
        &b.precision,
        "precision",
        &[("f64", Precision::F64), ("f32", Precision::F32)],
        Precision::F64,
    )?;
    let origin = b
        .origin
        .as_ref()
        .map_or(Ok(Vector3::zeros()), |o| f.vector(o, "origin"))?;
    let spacing = b
        .spacing
        .as_ref()
        .map_or(Ok(link_length), |s| f.positive(s, "spacing"))?;
    let columns = f.count_or(
        &b.columns,
        "columns",
        1,
        MAX_BUNDLE_STRANDS as i64,
        (f64::from(strands).sqrt().ceil() as u32).max(1),
    )?;
    let hang = hang(&f)?;
    let substeps = f.count_or(&b.substeps, "substeps", 1, i64::from(MAX_SUBSTEPS_LIMIT), 1)?;
    let heads: Vec<Vector3<f64>> = (0..strands)
        .map(|i| {
            origin
                + Vector3::new(
                    f64::from(i % columns) * spacing,
                    f64::from(i / columns) * spacing,
                    0.0,
                )
        })
        .collect();
    // Every joint must stay where the precision can carry the link lengths.
    let reach = f64::from(links) * link_length;
    let max_coordinate = max_coordinate(link_length, precision == Precision::F32);
    let far = heads
        .iter()
        .map(|h| h.abs().max() + reach)
        .fold(0.0, f64::max);
    if far.is_nan() || far > max_coordinate {
        return Err(f.err(
            b.name.span(),
            "origin",
            format!(
                "a joint may lie {far:.3e} from the origin; links of {link_length} in {} allow \
                 {max_coordinate:.3e}",
                if precision == Precision::F32 {
                    "f32"
                } else {
                    "f64"
                }
            ),
        ));
    }
    if !representable(link_length, precision == Precision::F32) {
        let span = b
            .link_length
            .as_ref()
            .map(|l| l.span())
            .unwrap_or(b.name.span());
        return Err(f.err(
            span,
            "link_length",
            format!("{link_length:e}: {}", unrepresentable(precision)),
        ));
    }
    let links_span = b.links.as_ref().map(|l| l.span()).unwrap_or(b.name.span());
    let links_line = (f.at)(links_span, String::new()).line;
    Ok(BundleSpec {
        links_line,
        name,
        strands,
        links,
        link_length,
        precision,
        heads,
        hang,
        substeps,
        two_cores: b.two_cores.as_ref().is_none_or(|t| *t.get_ref()),
        max_coordinate,
    })
}

/// The direction a bundle's strands hang in (unit; default down, −z).
fn hang(f: &Fields<'_, RawBundle>) -> Result<Vector3<f64>, SceneError> {
    Ok(match &f.c.hang {
        None => -Vector3::z(),
        Some(h) => {
            let v = f.vector(h, "hang")?;
            let n = v.norm();
            if !(n > 0.0 && n.is_finite()) {
                return Err(f.err(h.span(), "hang", "must be a non-zero vector".into()));
            }
            v / n
        }
    })
}

/// Whether a link of length `d` can be carried in the precision: positive, and its square a normal
/// finite number (the kernel's norms square it), in f32 when `single`.
fn representable(d: f64, single: bool) -> bool {
    if single {
        let x = d as f32;
        x > 0.0 && (x * x).is_normal()
    } else {
        d > 0.0 && (d * d).is_normal()
    }
}

fn unrepresentable(precision: Precision) -> String {
    let (lo, hi, name) = if precision == Precision::F32 {
        (
            f32::MIN_POSITIVE.sqrt() as f64,
            f32::MAX.sqrt() as f64,
            "f32",
        )
    } else {
        (f64::MIN_POSITIVE.sqrt(), f64::MAX.sqrt(), "f64")
    };
    format!("{name} carries links from {lo:.1e} to {hi:.1e} (their squares must be normal numbers)")
}

/// A 2- or 3-vector of finite numbers (`z = 0` when two are given).
fn vector3(f: &Spanned<Vec<f64>>) -> Result<Vector3<f64>, String> {
    let v = f.get_ref();
    let p = match v.as_slice() {
        [x, y] => Vector3::new(*x, *y, 0.0),
        [x, y, z] => Vector3::new(*x, *y, *z),
        _ => return Err(format!("a point has 2 or 3 numbers, not {}", v.len())),
    };
    if p.iter().all(|x| x.is_finite()) {
        Ok(p)
    } else {
        Err(format!("{v:?} is not finite"))
    }
}

fn obstacle(o: &RawObstacle, at: &At<'_>) -> Result<Obstacle<f64, 3>, SceneError> {
    let name = o.name.get_ref();
    let err = |span: Range<usize>, field: &str, what: String| {
        at(span, format!("obstacle {name:?}: field `{field}`: {what}"))
    };
    let need_vec = |f: &Field<Vec<f64>>, field: &str| -> Result<Vector3<f64>, SceneError> {
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
        "sphere" => Ok(Obstacle::Sphere {
            center: need_vec(&o.center, "center")?,
            radius: radius()?,
        }),
        "capsule" => Ok(Obstacle::Capsule {
            a: need_vec(&o.a, "a")?,
            b: need_vec(&o.b, "b")?,
            radius: radius()?,
        }),
        "plane" => {
            let n = need_vec(&o.normal, "normal")?;
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                let span = o.normal.as_ref().map(|s| s.span()).unwrap_or(0..0);
                return Err(err(span, "normal", "must be a non-zero vector".into()));
            }
            Ok(Obstacle::HalfSpace {
                point: need_vec(&o.point, "point")?,
                normal: n / len,
            })
        }
        other => Err(err(
            o.shape.span(),
            "shape",
            format!("{other:?} is not one of [\"sphere\", \"capsule\", \"plane\"]"),
        )),
    }
}

/// The fields of one chain (or bundle) table, with errors that name the table, the line and the
/// field.
struct Fields<'a, R = RawChain> {
    c: &'a R,
    /// `"chain"` or `"bundle"`.
    table: &'static str,
    name: &'a str,
    at: &'a At<'a>,
    /// 2 (planar: every vector must have z = 0) or 3.
    dims: u32,
}

impl<R> Fields<'_, R> {
    /// The table's name: 1..=`MAX_NAME_BYTES` bytes, no control characters.
    fn check_name(&self, span: Range<usize>) -> Result<(), SceneError> {
        let name = self.name;
        if name.is_empty() || name.len() > MAX_NAME_BYTES || name.chars().any(|ch| ch.is_control())
        {
            return Err(self.err(
                span,
                "name",
                format!(
                    "{name:?} must have 1..={} bytes and no control characters",
                    MAX_NAME_BYTES
                ),
            ));
        }
        Ok(())
    }

    fn err(&self, span: Range<usize>, field: &str, what: String) -> SceneError {
        (self.at)(
            span,
            format!("{} {:?}: field `{field}`: {what}", self.table, self.name),
        )
    }

    /// The value among `options` (by name) or `default`.
    fn choice<T: Copy>(
        &self,
        f: &Field<String>,
        field: &str,
        options: &[(&str, T)],
        default: T,
    ) -> Result<T, SceneError> {
        let Some(s) = f else { return Ok(default) };
        options
            .iter()
            .find(|(n, _)| n == s.get_ref())
            .map(|(_, v)| *v)
            .ok_or_else(|| {
                let names: Vec<&str> = options.iter().map(|(n, _)| *n).collect();
                self.err(
                    s.span(),
                    field,
                    format!("{:?} is not one of {names:?}", s.get_ref()),
                )
            })
    }

    /// 2 or 3 finite numbers; a planar chain's must have z = 0.
    fn vector(&self, f: &Spanned<Vec<f64>>, field: &str) -> Result<Vector3<f64>, SceneError> {
        let v = f.get_ref();
        let p = match v.as_slice() {
            [x, y] => Vector3::new(*x, *y, 0.0),
            [x, y, z] => Vector3::new(*x, *y, *z),
            _ => {
                return Err(self.err(
                    f.span(),
                    field,
                    format!("a point has 2 or 3 numbers, not {}", v.len()),
                ));
            }
        };
        if !p.iter().all(|x| x.is_finite()) {
            return Err(self.err(f.span(), field, "numbers must be finite".into()));
        }
        if self.dims == 2 && p.z != 0.0 {
            return Err(self.err(
                f.span(),
                field,
                "a planar chain lies in z = 0; z must be 0".into(),
            ));
        }
        Ok(p)
    }

    fn positive(&self, f: &Spanned<f64>, field: &str) -> Result<f64, SceneError> {
        let v = *f.get_ref();
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(
                f.span(),
                field,
                format!("{v} is not a positive finite number"),
            ))
        }
    }

    fn count(&self, f: &Spanned<i64>, field: &str, lo: i64, hi: i64) -> Result<u32, SceneError> {
        let v = *f.get_ref();
        if (lo..=hi).contains(&v) {
            Ok(v as u32)
        } else {
            Err(self.err(f.span(), field, format!("{v} is outside {lo}..={hi}")))
        }
    }

    /// A real field that must pass `ok` (else "`value` `what`"), or `default`.
    fn real_or(
        &self,
        field: &Field<f64>,
        name: &str,
        ok: impl Fn(f64) -> bool,
        what: &str,
        default: f64,
    ) -> Result<f64, SceneError> {
        match field {
            Some(t) if ok(*t.get_ref()) => Ok(*t.get_ref()),
            Some(t) => Err(self.err(t.span(), name, format!("{} {what}", t.get_ref()))),
            None => Ok(default),
        }
    }

    fn count_or(
        &self,
        f: &Field<i64>,
        field: &str,
        lo: i64,
        hi: i64,
        default: u32,
    ) -> Result<u32, SceneError> {
        f.as_ref()
            .map_or(Ok(default), |f| self.count(f, field, lo, hi))
    }
}

/// The eyelets' friction (default 0): a number ≥ 0 (or inf), for a chain with eyelets or tissue only.
fn eyelet_friction(f: &Fields<'_>, nothing_threaded: bool) -> Result<f64, SceneError> {
    Ok(match &f.c.eyelet_friction {
        Some(x) if nothing_threaded => {
            return Err(f.err(
                x.span(),
                "eyelet_friction",
                "friction is for a chain with eyelets or tissue".into(),
            ));
        }
        Some(x) if *x.get_ref() >= 0.0 => *x.get_ref(),
        Some(x) => {
            return Err(f.err(
                x.span(),
                "eyelet_friction",
                format!("{} is not a number ≥ 0 (or inf)", x.get_ref()),
            ));
        }
        None => 0.0,
    })
}

/// Whether the chain's knot is named with each state: for free spatial chains (a rope) only.
fn knot(f: &Fields<'_>, kind: ChainKind) -> Result<bool, SceneError> {
    Ok(match &f.c.knot {
        Some(k) if *k.get_ref() && (kind != ChainKind::Free || f.dims != 3) => {
            return Err(f.err(
                k.span(),
                "knot",
                "a knot is named for free spatial chains (a rope), not planar or fixed-base ones"
                    .into(),
            ));
        }
        Some(k) => *k.get_ref(),
        None => false,
    })
}

/// A free chain must start where positions can hold its link lengths (requests beyond that are
/// refused as too far; a chain that starts there could never be moved).
fn within_coordinates(
    f: &Fields<'_>,
    kind: ChainKind,
    points: &[Vector3<f64>],
    max_coordinate: f64,
) -> Result<(), SceneError> {
    let c = f.c;
    let far = points.iter().fold(0.0f64, |m, p| m.max(p.amax()));
    if kind == ChainKind::Free && far > max_coordinate {
        let span = c.base.as_ref().map(|b| b.span()).unwrap_or(c.name.span());
        return Err(f.err(
            span,
            "base",
            format!(
                "a joint lies {far:e} from the origin, beyond {max_coordinate:e} (2^32 shortest \
                 links in f64, 2^12 in f32), where positions cannot hold the link lengths"
            ),
        ));
    }
    Ok(())
}

/// The chain's method (the kernel's names; the wire's text form spells the same, the service checks)
/// and its fixed-base strategy.
fn method_and_strategy(f: &Fields<'_>) -> Result<(Method, Strategy), SceneError> {
    let c = f.c;
    let methods = Method::ALL.map(|m| (m.name(), m));
    let method = f.choice(&c.method, "method", &methods, Method::Tractrix)?;
    let strategy = f.choice(
        &c.strategy,
        "strategy",
        &[
            ("translate-back", Strategy::TranslateBack),
            ("two-link", Strategy::TractrixTwoLink),
            ("pull-back", Strategy::PullBack),
        ],
        Strategy::TranslateBack,
    )?;
    Ok((method, strategy))
}

/// The line of the chain's `links` (or `points`, or its name): where a length error points.
fn links_line(f: &Fields<'_>) -> usize {
    let c = f.c;
    (f.at)(
        c.links
            .as_ref()
            .map(|l| l.span())
            .or(c.points.as_ref().map(|p| p.span()))
            .unwrap_or(c.name.span()),
        String::new(),
    )
    .line
}

/// The iterations of a held side's fixed-base solve. With joint limits the reach hierarchy cannot
/// finish a slow iteration (its pose is kept only when it lands within them), so a held side may
/// iterate to the limit, each pass with a try of the hierarchy: unless the scene sets
/// `max_iterations`, a smaller default keeps a held move within the service's budget.
fn held_iterations(f: &Fields<'_>, max_iterations: u32, limited: bool) -> u32 {
    if f.c.max_iterations.is_none() && limited {
        LIMITED_MAX_ITERATIONS
    } else {
        max_iterations
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Shape {
    Straight,
    Arc,
    Points,
}

fn chain(
    c: &RawChain,
    obstacles: &[(String, Obstacle<f64, 3>)],
    instruments: &[(String, Obstacle<f64, 3>)],
    at: &At<'_>,
) -> Result<ChainSpec, SceneError> {
    let name = c.name.get_ref().clone();
    let mut f = Fields {
        c,
        table: "chain",
        name: &name,
        at,
        dims: 3,
    };
    f.check_name(c.name.span())?;
    let kind = f.choice(
        &c.kind,
        "kind",
        &[
            ("free", ChainKind::Free),
            ("fixed-base", ChainKind::FixedBase),
        ],
        ChainKind::Free,
    )?;
    f.dims = f.choice(&c.space, "space", &[("planar", 2), ("spatial", 3)], 3)?;
    let precision = f.choice(
        &c.precision,
        "precision",
        &[("f64", Precision::F64), ("f32", Precision::F32)],
        Precision::F64,
    )?;
    let (method, strategy) = method_and_strategy(&f)?;
    let shape = f.choice(
        &c.shape,
        "shape",
        &[
            ("straight", Shape::Straight),
            ("arc", Shape::Arc),
            ("points", Shape::Points),
        ],
        Shape::Straight,
    )?;
    let scheme = f.choice(
        &c.collision,
        "collision",
        &[
            ("none", None),
            ("capsules", Some(Scheme::Capsules)),
            ("paper-spheres", Some(Scheme::PaperSpheres)),
        ],
        None,
    )?;
    let (points, lengths) = geometry(&f, shape)?;
    representable_links(&f, &points, &lengths, precision)?;
    let links_line = links_line(&f);
    let anchors = anchors(&f, kind, lengths.len())?;
    let eyelets = eyelets(&f, kind, &points, &lengths, &anchors)?;
    let tissue = tissue(&f, kind)?;
    let eyelet_friction = eyelet_friction(&f, eyelets.is_empty() && tissue.is_none())?;
    let wound = wound(&f, tissue.is_some())?;
    let knot = knot(&f, kind)?;
    let shortest = lengths.iter().copied().fold(f64::INFINITY, f64::min);
    let max_coordinate = max_coordinate(shortest, precision == Precision::F32);
    within_coordinates(&f, kind, &points, max_coordinate)?;
    let thickness = f.real_or(
        &c.thickness,
        "thickness",
        |t| t.is_finite() && t >= 0.0,
        "is not a finite number ≥ 0",
        0.0,
    )?;
    let (max_substeps, substeps) = substeps(&f)?;
    let (tolerance, max_iterations, hierarchy_after) = iteration(&f)?;
    let rope = (lengths.len(), shortest, thickness);
    let collision = collision(&f, scheme, kind, rope, obstacles, instruments)?;
    let needle = needle(&f, tissue.is_some(), collision.is_some())?;
    let limits = limits(&f, &points, &lengths)?;
    let reach = ReachOptions {
        strategy,
        method,
        substeps: 1,
        tolerance,
        max_iterations: held_iterations(&f, max_iterations, limits.is_some()),
        hierarchy_after,
    };
    Ok(ChainSpec {
        links_line,
        name: name.clone(),
        kind,
        dims: f.dims,
        precision,
        total_length: lengths.iter().sum(),
        shortest,
        max_coordinate,
        points,
        lengths,
        thickness,
        collision,
        anchors,
        limits,
        knot,
        eyelet_friction,
        eyelets,
        tissue,
        wound,
        needle,
        moves: MoveOptions {
            method,
            substeps,
            max_substeps,
            // The sides up to a held joint are solved with the chain's fixed-base options.
            held: reach,
        },
        reach,
    })
}

/// Every link as the chain's arithmetic will see it: a length whose square is a normal number.
fn representable_links(
    f: &Fields<'_>,
    points: &[Vector3<f64>],
    lengths: &[f64],
    precision: Precision,
) -> Result<(), SceneError> {
    let c = f.c;
    let single = precision == Precision::F32;
    for (i, w) in points.windows(2).enumerate() {
        let d = if single {
            let v = |p: &Vector3<f64>| p.map(|x| x as f32);
            f64::from((v(&w[1]) - v(&w[0])).norm())
        } else {
            (w[1] - w[0]).norm()
        };
        if !representable(d, single) {
            let (field, span) = [
                ("points", c.points.as_ref().map(|x| x.span())),
                ("radius", c.radius.as_ref().map(|x| x.span())),
                ("link_lengths", c.link_lengths.as_ref().map(|x| x.span())),
                ("link_length", c.link_length.as_ref().map(|x| x.span())),
            ]
            .into_iter()
            .find_map(|(n, s)| Some((n, s?)))
            .unwrap_or(("links", c.name.span()));
            return Err(f.err(
                span,
                field,
                format!(
                    "link {i} (length {:e}, {d:e} between its joints): {}",
                    lengths[i],
                    unrepresentable(precision)
                ),
            ));
        }
    }
    Ok(())
}
