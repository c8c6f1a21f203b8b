//! Reading a scene: TOML into raw tables that remember where each field was written, so validation can
//! name the file, the line and the field. Nothing is interpreted here.

use super::{MAX_SCENE_BYTES, SceneError};
use serde::Deserialize;
use toml::Spanned;

/// A field as written, with its byte span.
pub(super) type Field<T> = Option<Spanned<T>>;

/// The scene file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    /// The work one request may cost, in link-steps (top level, before any table).
    pub budget: Field<i64>,
    /// The work one pull (a move or instrument pose with the pull flag) may cost, in link-steps.
    pub pull_budget: Field<i64>,
    #[serde(default)]
    pub chain: Vec<Spanned<RawChain>>,
    #[serde(default)]
    pub obstacle: Vec<Spanned<RawObstacle>>,
    /// `[[instrument]]` tables: obstacles that clients move (spheres and capsules).
    #[serde(default)]
    pub instrument: Vec<Spanned<RawObstacle>>,
    /// `[[bundle]]` tables: many free strands moved together.
    #[serde(default)]
    pub bundle: Vec<Spanned<RawBundle>>,
}

/// A `[[bundle]]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBundle {
    pub name: Spanned<String>,
    pub strands: Field<i64>,
    pub links: Field<i64>,
    pub link_length: Field<f64>,
    pub origin: Field<Vec<f64>>,
    pub spacing: Field<f64>,
    pub columns: Field<i64>,
    pub hang: Field<Vec<f64>>,
    pub precision: Field<String>,
    pub substeps: Field<i64>,
    pub two_cores: Field<bool>,
}

/// An `[[obstacle]]` or `[[instrument]]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawObstacle {
    pub name: Spanned<String>,
    pub shape: Spanned<String>,
    pub center: Field<Vec<f64>>,
    pub radius: Field<f64>,
    pub a: Field<Vec<f64>>,
    pub b: Field<Vec<f64>>,
    pub point: Field<Vec<f64>>,
    pub normal: Field<Vec<f64>>,
    /// Instruments only: the joint of its chain it follows (`"head"`, `"tail"` or an index).
    pub follows: Field<String>,
}

/// A `[[chain]]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawChain {
    pub name: Spanned<String>,
    pub kind: Field<String>,
    pub space: Field<String>,
    pub links: Field<i64>,
    pub link_length: Field<f64>,
    pub link_lengths: Field<Vec<f64>>,
    pub base: Field<Vec<f64>>,
    pub shape: Field<String>,
    pub axis: Field<Vec<f64>>,
    pub radius: Field<f64>,
    pub bend: Field<Vec<f64>>,
    pub points: Field<Vec<Vec<f64>>>,
    pub thickness: Field<f64>,
    pub collision: Field<String>,
    pub self_collision: Field<bool>,
    pub obstacles: Field<Vec<String>>,
    pub instruments: Field<Vec<String>>,
    pub collision_iterations: Field<i64>,
    pub collision_tolerance: Field<f64>,
    pub collision_over_relaxation: Field<f64>,
    pub collision_pushed_weight: Field<f64>,
    pub collision_together_after: Field<i64>,
    pub precision: Field<String>,
    pub method: Field<String>,
    pub substeps: Field<i64>,
    pub max_step: Field<f64>,
    pub max_substeps: Field<i64>,
    pub strategy: Field<String>,
    pub tolerance: Field<f64>,
    pub max_iterations: Field<i64>,
    pub hierarchy_after: Field<i64>,
    pub anchors: Field<Vec<i64>>,
    pub min_bend_radius: Field<f64>,
    pub max_bend: Field<f64>,
    pub max_bends: Field<Vec<f64>>,
    pub joint_range: Field<Vec<f64>>,
    pub joint_ranges: Field<Vec<Vec<f64>>>,
    pub knot: Field<bool>,
    pub eyelets: Field<Vec<Vec<f64>>>,
    pub tissue: Field<Vec<Vec<f64>>>,
    pub eyelet_friction: Field<f64>,
    pub incision: Field<Vec<Vec<f64>>>,
    pub tissue_give: Field<f64>,
    pub wound_margin: Field<f64>,
    pub needle: Field<Vec<f64>>,
    pub needle_bend: Field<Vec<f64>>,
}

/// 1-based line of a byte offset.
pub(super) fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Parses scene text (at most [`MAX_SCENE_BYTES`]); `file` names it in errors.
pub(super) fn read(text: &str, file: &str) -> Result<RawScene, SceneError> {
    if text.len() as u64 > MAX_SCENE_BYTES {
        return Err(SceneError {
            file: file.into(),
            line: 0,
            message: format!("a scene may have at most {MAX_SCENE_BYTES} bytes"),
        });
    }
    toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        let line_text = text
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
    })
}
