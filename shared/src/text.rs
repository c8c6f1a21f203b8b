//! The text form of requests and responses: one JSON object per line, used by the service's batch mode,
//! by `chainctl --json` and by regression files. It maps one to one onto the wire types; nothing here is on
//! the hot path.
//!
//! ```json
//! {"cmd":"move","chain":"rope","joint":"head","target":[40,5,0],"method":"tractrix","substeps":8}
//! {"cmd":"path","chain":0,"joint":"tail","path":[[0,1,0],[0,2,0]],"max_step":0.1}
//! {"cmd":"reach","chain":"arm","target":[1.2,0.8],"tolerance":1e-9,"angles":true}
//! {"cmd":"query","chain":"snake"}
//! {"cmd":"instrument","chain":"suture","joint":0,"target":[3,1,0],"axis":[0,0,1]}
//! {"cmd":"eyelet","chain":"suture","joint":0,"target":[10.5,2,0]}
//! ```
//!
//! Field names are those of [`RequestHeader`]; `chain` is a name or an index, `joint` is `"head"`,
//! `"tail"` or an index, points have 2 or 3 coordinates (a missing `z` is 0), `method` is `tractrix`,
//! `paper` or `ftl`, `precision` is `f64` or `f32`, `strategy` is `translate-back`, `two-link` or
//! `pull-back`. For `instrument`, `joint` is the instrument's index in the chain's `instruments` list,
//! `target` its new centre and `axis` (capsules only) its new axis direction. A `move` with `rotation` (a rotation
//! vector, axis × angle in radians) is a pose move ([`crate::FLAG_POSE`]): a bundle's, every head by
//! the rigid motion `R(rotation)·h0 + target`; or, for the head of a chain with a needle, the needle's
//! pose, swaged at `target` and turned by `R(rotation)` from its own frame. Unknown fields are an
//! error.

use crate::{
    Command, FLAG_ANGLES, FLAG_DRIVE, FLAG_IN_BALL, FLAG_IN_BOX, FLAG_ORIENT, FLAG_POSE, FLAG_PULL,
    FLAG_SMOOTH, FLAG_TAKE_OVER, InstrumentPose, JOINT_HEAD, MAX_PATH_POINTS, Parts, Precision,
    RequestHeader, ResponseHeader, Status, SubstepMode, Vec3, WireMethod, WireStrategy,
};
use serde::{Deserialize, Serialize};

/// A chain by name or by index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ChainRef {
    Index(u32),
    Name(String),
}

/// A joint: `"head"`, `"tail"` or an index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum JointRef {
    Index(u32),
    Named(String),
}

/// One request in text form.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextRequest {
    pub cmd: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chain: Option<ChainRef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<JointRef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<Vec<Vec<f64>>>,
    /// An instrument's axis direction (capsules).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<Vec<f64>>,
    /// A pose move's rotation vector: a bundle's heads' (`target` is then the translation), or a
    /// needle's, from its own frame (`target` is then where its swage goes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<Vec<f64>>,
    /// A reach's orientation goal: the direction of the last link ([`crate::FLAG_ORIENT`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<Vec<f64>>,
    /// A reach's ball goal: the head within this distance of `target` ([`crate::FLAG_IN_BALL`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<f64>,
    /// A reach's box goal: the corners of smallest and largest coordinates, no `target`
    /// ([`crate::FLAG_IN_BOX`]).
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub in_box: Option<Vec<Vec<f64>>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub precision: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub substeps: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_step: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strategy: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_iterations: Option<u32>,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub angles: bool,
    /// Take over other clients' grasps ([`crate::FLAG_TAKE_OVER`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub take_over: bool,
    /// A path along the natural cubic spline through its points ([`crate::FLAG_SMOOTH`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub smooth: bool,
    /// A move or an instrument pose taken as far as the rope lets it, the rest reported as the pull
    /// ([`crate::FLAG_PULL`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub pull: bool,
    /// A move of the head that drives the chain's needle along its arc ([`crate::FLAG_DRIVE`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub drive: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request_id: Option<u64>,
}

/// Parses a command name.
pub fn parse_command(s: &str) -> Result<Command, String> {
    Command::ALL
        .into_iter()
        .find(|c| c.name() == s)
        .ok_or_else(|| {
            format!(
                "unknown command {s:?} (expected move, path, reach, query, reset, describe, snapshot, \
                 grasp, release or instrument)"
            )
        })
}

/// Parses a method name.
pub fn parse_method(s: &str) -> Result<WireMethod, String> {
    match s {
        "tractrix" => Ok(WireMethod::Tractrix),
        "paper" => Ok(WireMethod::Paper),
        "ftl" | "follow-the-leader" => Ok(WireMethod::FollowTheLeader),
        _ => Err(format!(
            "unknown method {s:?} (expected tractrix, paper or ftl)"
        )),
    }
}

/// The name of a wire method value.
pub fn method_name(m: u32) -> &'static str {
    match WireMethod::from_u32(m) {
        Some(WireMethod::Tractrix) => "tractrix",
        Some(WireMethod::Paper) => "paper",
        Some(WireMethod::FollowTheLeader) => "ftl",
        Some(WireMethod::Default) => "default",
        None => "?",
    }
}

/// Parses a precision name.
pub fn parse_precision(s: &str) -> Result<Precision, String> {
    match s {
        "f64" => Ok(Precision::F64),
        "f32" => Ok(Precision::F32),
        _ => Err(format!("unknown precision {s:?} (expected f64 or f32)")),
    }
}

/// Parses a fixed-base strategy name.
pub fn parse_strategy(s: &str) -> Result<WireStrategy, String> {
    match s {
        "translate-back" => Ok(WireStrategy::TranslateBack),
        "two-link" => Ok(WireStrategy::TractrixTwoLink),
        "pull-back" => Ok(WireStrategy::PullBack),
        _ => Err(format!(
            "unknown strategy {s:?} (expected translate-back, two-link or pull-back)"
        )),
    }
}

/// A point of 2 or 3 coordinates.
pub fn parse_point(p: &[f64]) -> Result<Vec3, String> {
    match p {
        [x, y] => Ok(Vec3::new(*x, *y, 0.0)),
        [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
        _ => Err(format!("a point has 2 or 3 coordinates, not {}", p.len())),
    }
}

impl TextRequest {
    /// The wire form. `resolve` maps a chain name to its handle.
    pub fn to_wire(
        &self,
        resolve: &dyn Fn(&str) -> Option<u32>,
    ) -> Result<(RequestHeader, Vec<Vec3>), String> {
        let command = parse_command(&self.cmd)?;
        let chain = match &self.chain {
            None if command == Command::Snapshot => 0,
            None => return Err(format!("{}: field `chain` is missing", self.cmd)),
            Some(ChainRef::Index(i)) => *i,
            Some(ChainRef::Name(n)) => resolve(n).ok_or_else(|| format!("unknown chain {n:?}"))?,
        };
        let mut h = RequestHeader::new(command, chain);
        h.joint = match &self.joint {
            None => JOINT_HEAD,
            Some(JointRef::Index(i)) => *i,
            Some(JointRef::Named(s)) if s == "head" => JOINT_HEAD,
            Some(JointRef::Named(s)) if s == "tail" => 0,
            Some(JointRef::Named(s)) => {
                return Err(format!(
                    "joint {s:?}: expected \"head\", \"tail\" or an index"
                ));
            }
        };
        if let Some(m) = &self.method {
            h.method = parse_method(m)? as u32;
        }
        if let Some(p) = &self.precision {
            h.precision = parse_precision(p)? as u32;
        }
        match (self.substeps, self.max_step) {
            (Some(_), Some(_)) => {
                return Err("give `substeps` or `max_step`, not both".into());
            }
            (Some(k), None) => {
                h.substep_mode = SubstepMode::Fixed as u32;
                h.substeps = k;
            }
            (None, Some(s)) => {
                h.substep_mode = SubstepMode::MaxStep as u32;
                h.max_step = s;
            }
            (None, None) => {}
        }
        if command == Command::Reach {
            // Reach takes `substeps` as the count of each tractrix pass, not as a mode.
            h.substep_mode = 0;
        }
        if let Some(s) = &self.strategy {
            h.strategy = parse_strategy(s)? as u32;
        }
        h.tolerance = self.tolerance.unwrap_or(0.0);
        h.max_iterations = self.max_iterations.unwrap_or(0);
        if self.angles {
            h.flags |= FLAG_ANGLES;
        }
        if self.take_over {
            h.flags |= FLAG_TAKE_OVER;
        }
        if self.smooth {
            if command != Command::Path {
                return Err(format!("{}: `smooth` is for a path", self.cmd));
            }
            h.flags |= FLAG_SMOOTH;
        }
        if self.pull {
            if !matches!(command, Command::Move | Command::Instrument) {
                return Err(format!(
                    "{}: `pull` is for a move or an instrument",
                    self.cmd
                ));
            }
            h.flags |= FLAG_PULL;
        }
        if self.drive {
            if command != Command::Move {
                return Err(format!("{}: `drive` is for a move", self.cmd));
            }
            h.flags |= FLAG_DRIVE;
        }
        h.request_id = self.request_id.unwrap_or(0);
        let goals = [
            self.direction.is_some(),
            self.within.is_some(),
            self.in_box.is_some(),
        ];
        if goals.iter().any(|&g| g) && command != Command::Reach {
            return Err(format!(
                "{}: `direction`, `within` and `box` are goals of a reach",
                self.cmd
            ));
        }
        if goals.iter().filter(|&&g| g).count() > 1 {
            return Err("reach: one goal at a time: `direction`, `within` or `box`".into());
        }
        let points = match command {
            Command::Reach if self.in_box.is_some() => {
                if self.target.is_some() {
                    return Err("reach: a `box` goal takes no `target`".into());
                }
                h.flags |= FLAG_IN_BOX;
                match self.in_box.as_deref() {
                    Some([lo, hi]) => vec![parse_point(lo)?, parse_point(hi)?],
                    _ => return Err("reach: `box` is two corners, [[lo...], [hi...]]".into()),
                }
            }
            Command::Reach if self.direction.is_some() || self.within.is_some() => {
                let t = self
                    .target
                    .as_ref()
                    .ok_or_else(|| "reach: field `target` is missing".to_string())?;
                if let Some(d) = &self.direction {
                    h.flags |= FLAG_ORIENT;
                    vec![parse_point(t)?, parse_point(d)?]
                } else {
                    h.flags |= FLAG_IN_BALL;
                    let r = self.within.expect("checked");
                    vec![parse_point(t)?, Vec3::new(r, 0.0, 0.0)]
                }
            }
            Command::Move | Command::Reach => {
                let t = self
                    .target
                    .as_ref()
                    .ok_or_else(|| format!("{}: field `target` is missing", self.cmd))?;
                match (&self.rotation, command) {
                    (Some(r), Command::Move) => {
                        h.flags |= FLAG_POSE;
                        vec![parse_point(t)?, parse_point(r)?]
                    }
                    (Some(_), _) => return Err("reach: `rotation` is for a move (a pose)".into()),
                    (None, _) => vec![parse_point(t)?],
                }
            }
            Command::Path => {
                let p = self
                    .path
                    .as_ref()
                    .ok_or_else(|| "path: field `path` is missing".to_string())?;
                if p.is_empty() || p.len() > MAX_PATH_POINTS as usize {
                    return Err(format!(
                        "path: {} points (1..={MAX_PATH_POINTS} allowed)",
                        p.len()
                    ));
                }
                p.iter().map(|q| parse_point(q)).collect::<Result<_, _>>()?
            }
            Command::Instrument => {
                let t = self.target.as_ref().ok_or_else(|| {
                    "instrument: field `target` (its centre) is missing".to_string()
                })?;
                let mut p = vec![parse_point(t)?];
                if let Some(a) = &self.axis {
                    p.push(parse_point(a)?);
                }
                p
            }
            Command::Eyelet => {
                let t = self.target.as_ref().ok_or_else(|| {
                    "eyelet: field `target` (where it goes) is missing".to_string()
                })?;
                vec![parse_point(t)?]
            }
            _ => Vec::new(),
        };
        Ok((h, points))
    }
}

/// One response in text form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextResponse {
    pub status: String,
    /// Why it was refused; on an ok pull that stopped short, why it did ([`crate::PullStop`]).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub reason: String,
    pub command: String,
    pub chain: u32,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    pub sequence: u64,
    pub request_id: u64,
    pub solve_ns: u64,
    pub iterations: u32,
    pub substeps: u32,
    pub residual: f64,
    pub joints: Vec<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub angles: Vec<[f64; 3]>,
    /// Held joints (anchors of the scene and grasps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<HeldJoint>,
    /// The chain's instruments' poses.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub instruments: Vec<TextInstrument>,
    /// The pull on each instrument (in the order of `instruments`): where it is less where it was
    /// last asked to be ([`crate::FLAG_PULL`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub instrument_pulls: Vec<[f64; 3]>,
    /// A describe's joint limits in words ([`limits_text`]); empty otherwise.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub limits: String,
    /// The eyelets the chain passes through (the scene's, in order along the rope).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub eyelets: Vec<TextEyelet>,
    /// The chain's knot, when its scene asks for it ([`crate::knot_name`]); empty otherwise.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub knot: String,
    /// A describe's block of tissue (scene `tissue`): its corners `lo` and `hi`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tissue: Option<[[f64; 3]; 2]>,
}

/// An eyelet in a text response ([`crate::EyeletState`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TextEyelet {
    /// The fixed point.
    pub at: [f64; 3],
    /// The link through it.
    pub link: u32,
    /// Whether the rope still passes through it.
    pub threaded: bool,
}

/// A held joint in a text response.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeldJoint {
    pub joint: u32,
    /// Declared by the scene (never released), not grasped by a client.
    pub anchor: bool,
    /// The stretch from this joint to the next held joint toward the head is taut.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub taut: bool,
    /// The pull on the joint: where it is less where its owner last asked it to be (zero when
    /// slack; [`crate::FLAG_PULL`]).
    #[serde(default)]
    pub pull: [f64; 3],
}

impl TextResponse {
    /// From a header and its payload (`n_joints` positions, `n_angles` rotations, `n_held` held joints,
    /// then `n_instruments` instruments; a payload shorter than the header claims is cut to what is
    /// there).
    pub fn from_wire(h: &ResponseHeader, payload: &[Vec3]) -> Self {
        let parts = Parts::of_response(h, payload);
        TextResponse {
            status: Status::from_u32(h.status)
                .map(|s| s.name().to_string())
                .unwrap_or_else(|| format!("status-{}", h.status)),
            reason: h.reason_str(),
            command: Command::from_u32(h.command)
                .map(|c| c.name().to_string())
                .unwrap_or_else(|| format!("command-{}", h.command)),
            chain: h.chain,
            name: h.name_str(),
            sequence: h.sequence,
            request_id: h.request_id,
            solve_ns: h.solve_ns,
            iterations: h.iterations,
            substeps: h.substeps,
            residual: h.residual,
            joints: parts.joints.iter().map(|v| v.to_array()).collect(),
            angles: parts.angles.iter().map(|v| v.to_array()).collect(),
            held: parts
                .held_joints()
                .zip(parts.taut())
                .enumerate()
                .map(|(k, ((joint, anchor), taut))| HeldJoint {
                    joint,
                    anchor,
                    taut,
                    pull: parts.pulls.get(k).map_or([0.0; 3], |p| p.to_array()),
                })
                .collect(),
            instruments: parts.instrument_poses().map(TextInstrument::from).collect(),
            instrument_pulls: parts
                .instrument_pulls()
                .iter()
                .map(|p| p.to_array())
                .collect(),
            limits: limits_text(h.limits, h.limit_value),
            knot: crate::knot_name(h.knot).unwrap_or_default().to_string(),
            eyelets: parts
                .eyelet_states()
                .map(|e| TextEyelet {
                    at: e.at.to_array(),
                    link: e.link,
                    threaded: e.threaded,
                })
                .collect(),
            tissue: parts
                .tissue_box()
                .map(|(lo, hi)| [lo.to_array(), hi.to_array()]),
        }
    }
}

/// A describe's joint limits ([`ResponseHeader::limits`], `limit_value`) in words: `bend radius 1.5`,
/// `cone 30°`, `cones up to 30°`, `ranges up to 90° wide`, or empty without limits.
pub fn limits_text(limits: u32, value: f64) -> String {
    match limits {
        crate::LIMITS_BEND_RADIUS => format!("bend radius {value}"),
        crate::LIMITS_CONE => format!("cone {:.3}°", value.to_degrees()),
        crate::LIMITS_CONES => format!("cones up to {:.3}°", value.to_degrees()),
        crate::LIMITS_RANGES => format!("ranges up to {:.3}° wide", value.to_degrees()),
        _ => String::new(),
    }
}

/// An instrument in a text response: a sphere has `a == b`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextInstrument {
    /// `sphere` or `capsule`.
    pub shape: String,
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub radius: f64,
}

impl From<InstrumentPose> for TextInstrument {
    fn from(p: InstrumentPose) -> Self {
        TextInstrument {
            shape: if p.capsule { "capsule" } else { "sphere" }.to_string(),
            a: p.a.to_array(),
            b: p.b.to_array(),
            radius: p.radius,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_move_with_a_rotation_is_a_pose_move() {
        let r = TextRequest {
            cmd: "move".into(),
            chain: Some(ChainRef::Index(3)),
            target: Some(vec![1.0, 2.0, 3.0]),
            rotation: Some(vec![0.0, 0.0, 0.5]),
            ..Default::default()
        };
        let (h, p) = r.to_wire(&|_| None).expect("valid request");
        assert_eq!(h.flags, FLAG_POSE);
        assert_eq!(p, vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, 0.5)]);
    }

    #[test]
    fn reach_goals_map_onto_flags_and_points() {
        let parse = |text: &str| {
            serde_json::from_str::<TextRequest>(text)
                .unwrap()
                .to_wire(&|_| Some(2))
        };
        let (h, p) =
            parse(r#"{"cmd":"reach","chain":"arm","target":[1,0.5],"direction":[0,1]}"#).unwrap();
        assert_eq!(h.flags, FLAG_ORIENT);
        assert_eq!(p, vec![Vec3::new(1.0, 0.5, 0.0), Vec3::new(0.0, 1.0, 0.0)]);
        let (h, p) =
            parse(r#"{"cmd":"reach","chain":"arm","target":[1,0.5],"within":0.1}"#).unwrap();
        assert_eq!(h.flags, FLAG_IN_BALL);
        assert_eq!(p, vec![Vec3::new(1.0, 0.5, 0.0), Vec3::new(0.1, 0.0, 0.0)]);
        let (h, p) = parse(r#"{"cmd":"reach","chain":"arm","box":[[0,0],[1,2]]}"#).unwrap();
        assert_eq!(h.flags, FLAG_IN_BOX);
        assert_eq!(p, vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 2.0, 0.0)]);
        for (bad, says) in [
            (
                r#"{"cmd":"move","chain":"arm","target":[1,0],"within":0.1}"#,
                "goals of a reach",
            ),
            (
                r#"{"cmd":"reach","chain":"arm","target":[1,0],"within":0.1,"direction":[1,0]}"#,
                "one goal at a time",
            ),
            (
                r#"{"cmd":"reach","chain":"arm","target":[1,0],"box":[[0,0],[1,1]]}"#,
                "no `target`",
            ),
            (
                r#"{"cmd":"reach","chain":"arm","box":[[0,0]]}"#,
                "two corners",
            ),
        ] {
            let e = parse(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn a_move_maps_onto_the_wire() {
        let r = TextRequest {
            cmd: "move".into(),
            chain: Some(ChainRef::Name("rope".into())),
            joint: Some(JointRef::Named("tail".into())),
            target: Some(vec![1.0, 2.0]),
            method: Some("ftl".into()),
            substeps: Some(8),
            ..Default::default()
        };
        let (h, p) = r
            .to_wire(&|n| (n == "rope").then_some(3))
            .expect("valid request");
        assert_eq!(h.command, Command::Move as u32);
        assert_eq!(h.chain, 3);
        assert_eq!(h.joint, 0);
        assert_eq!(h.method, WireMethod::FollowTheLeader as u32);
        assert_eq!((h.substep_mode, h.substeps), (SubstepMode::Fixed as u32, 8));
        assert_eq!(p, vec![Vec3::new(1.0, 2.0, 0.0)]);
    }

    #[test]
    fn strategies_by_name() {
        for (name, w) in [
            ("translate-back", WireStrategy::TranslateBack),
            ("two-link", WireStrategy::TractrixTwoLink),
            ("pull-back", WireStrategy::PullBack),
        ] {
            assert_eq!(parse_strategy(name), Ok(w));
        }
        assert!(parse_strategy("push").unwrap_err().contains("pull-back"));
    }

    #[test]
    fn text_errors_name_the_field() {
        let bad = |r: TextRequest| r.to_wire(&|_| Some(0)).unwrap_err();
        assert!(
            bad(TextRequest {
                cmd: "fly".into(),
                ..Default::default()
            })
            .contains("fly")
        );
        let no_target = TextRequest {
            cmd: "move".into(),
            chain: Some(ChainRef::Index(0)),
            ..Default::default()
        };
        assert!(bad(no_target).contains("target"));
        let empty = TextRequest {
            cmd: "path".into(),
            chain: Some(ChainRef::Index(0)),
            path: Some(vec![]),
            ..Default::default()
        };
        assert!(bad(empty).contains("0 points"));
        let both = TextRequest {
            cmd: "move".into(),
            chain: Some(ChainRef::Index(0)),
            target: Some(vec![0.0, 0.0]),
            substeps: Some(2),
            max_step: Some(0.1),
            ..Default::default()
        };
        assert!(bad(both).contains("not both"));
    }
}
