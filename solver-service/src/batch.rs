//! Batch mode: a file of requests (JSON lines, [`shared::text`]) applied to a scene without IPC, through
//! the service's own answer path ([`crate::serve::respond`] over a [`Solver`]: decode, apply, persist,
//! encode, the panic guard), with the resulting joints written as JSON lines or CSV. For scripts,
//! regression files and debugging. Requests come from [`LOCAL`] (grasps unowned). With a store (the
//! binary's `batch` with `--state-dir`) changes are journaled and `snapshot` writes one, as in the
//! service; without, a `snapshot` is refused (`persistence-failed`), as the service refuses it under
//! `--no-persist`.

use crate::serve::respond;
use crate::service::Solver;
use shared::text::{TextRequest, TextResponse};
use shared::{Status, Vec3};
use std::io::{BufRead, Write};
use world::owners::LOCAL;

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// One [`TextResponse`] per line.
    #[value(name = "jsonl")]
    JsonLines,
    /// `line,sequence,status,chain,kind,index,x,y,z`: one row per joint (`kind = joint`) and rotation
    /// (`kind = angle`); an error row has `kind = error` and no coordinates.
    Csv,
}

/// Why a batch stopped.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// A line that is not a request: its source, line number and what is wrong with it.
    #[error("{source_name}:{line}: {why}")]
    Line {
        /// The input's name.
        source_name: String,
        /// The line, counted from 1.
        line: usize,
        /// What is wrong.
        why: String,
    },
    /// The input could not be read.
    #[error("{source_name}:{line}: {error}")]
    Read {
        /// The input's name.
        source_name: String,
        /// The line being read.
        line: usize,
        /// The system's error.
        error: std::io::Error,
    },
    /// The output could not be written.
    #[error("writing the responses: {0}")]
    Write(#[from] std::io::Error),
}

/// What a batch did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Summary {
    pub requests: u64,
    pub failed: u64,
}

/// Largest request line read (bytes): a full path of 4096 points in text.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Applies every request of `input` to `set` and writes the responses to `out`. A malformed line stops
/// the batch with an error naming the line; a request the solver refuses is reported in the output (and
/// counted) and the batch goes on.
pub fn run_batch(
    solver: &mut Solver,
    input: &mut dyn BufRead,
    out: &mut dyn Write,
    format: Format,
    source: &str,
) -> Result<Summary, BatchError> {
    let mut summary = Summary::default();
    let mut payload: Vec<Vec3> = Vec::new();
    let mut line = String::new();
    let mut number = 0usize;
    let at = |line: usize, why: String| BatchError::Line {
        source_name: source.to_string(),
        line,
        why,
    };
    if format == Format::Csv {
        writeln!(out, "line,sequence,status,chain,kind,index,x,y,z")?;
    }
    loop {
        line.clear();
        number += 1;
        let n = std::io::Read::take(&mut *input, MAX_LINE_BYTES as u64 + 1)
            .read_line(&mut line)
            .map_err(|error| BatchError::Read {
                source_name: source.to_string(),
                line: number,
                error,
            })?;
        if n == 0 {
            break;
        }
        if n > MAX_LINE_BYTES {
            return Err(at(
                number,
                format!("line longer than {MAX_LINE_BYTES} bytes"),
            ));
        }
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let req: TextRequest = serde_json::from_str(text).map_err(|e| at(number, e.to_string()))?;
        let (header, points) = req
            .to_wire(&|name| solver.set().find(name))
            .map_err(|e| at(number, e.to_string()))?;
        let (h, _) = respond(solver, LOCAL, &header, &points, &mut payload);
        summary.requests += 1;
        let ok = h.status == Status::Ok as u32;
        if !ok {
            summary.failed += 1;
        }
        match format {
            Format::JsonLines => {
                let r = TextResponse::from_wire(&h, &payload);
                serde_json::to_writer(&mut *out, &r).map_err(std::io::Error::from)?;
                writeln!(out)?;
            }
            Format::Csv => {
                let status = Status::from_u32(h.status).map(Status::name).unwrap_or("?");
                if !ok {
                    writeln!(
                        out,
                        "{number},{},{status},{},error,,,,",
                        h.sequence, h.chain
                    )?;
                }
                for (i, p) in payload.iter().enumerate() {
                    let (kind, index) = if i < h.n_joints as usize {
                        ("joint", i)
                    } else {
                        ("angle", i - h.n_joints as usize)
                    };
                    writeln!(
                        out,
                        "{number},{},{status},{},{kind},{index},{:?},{:?},{:?}",
                        h.sequence, h.chain, p.x, p.y, p.z
                    )?;
                }
            }
        }
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use world::World;
    use world::scene::default_scene;

    fn solver(set: World) -> Solver {
        Solver::new(set, None, std::time::Duration::ZERO)
    }

    /// Runs `input` as a batch and parses the JSON-lines output.
    fn run_lines(set: World, input: &str) -> (Summary, Vec<TextResponse>) {
        let mut out = Vec::new();
        let s = run_batch(
            &mut solver(set),
            &mut input.as_bytes(),
            &mut out,
            Format::JsonLines,
            "t",
        )
        .unwrap();
        let lines = String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        (s, lines)
    }

    #[test]
    fn a_batch_moves_reaches_and_reports_refusals() {
        let set = World::new(&default_scene()).unwrap();
        let input = r#"
# comment lines and blank lines are skipped
{"cmd":"move","chain":"rope","target":[40,5,0]}
{"cmd":"reach","chain":"arm","target":[1.0,0.9],"angles":true}
{"cmd":"reach","chain":"arm","target":[5.0,0.0]}
{"cmd":"query","chain":"snake"}
{"cmd":"snapshot"}
"#;
        let (s, lines) = run_lines(set, input);
        assert_eq!(
            s,
            Summary {
                requests: 5,
                failed: 2
            }
        );
        assert_eq!(lines[0].status, "ok");
        assert_eq!(lines[0].joints.len(), 41);
        assert_eq!(lines[0].joints[40], [40.0, 5.0, 0.0]);
        assert_eq!(lines[1].angles.len(), 10);
        assert_eq!(lines[2].status, "unreachable");
        assert!(lines[2].joints.is_empty());
        assert_eq!(lines[3].sequence, 2);
        // No store: a snapshot is refused, not answered ok without writing one.
        assert_eq!(lines[4].status, "persistence-failed");
    }

    /// An f32 planar chain is served in f32: moves land within f32 rounding, a target that overflows
    /// f32 is refused (too far: beyond 2¹² links), asking for f64 is refused.
    #[test]
    fn an_f32_planar_chain_is_served_in_f32() {
        let scene = world::scene::parse_scene(
            "[[chain]]\nname = \"hair\"\nspace = \"planar\"\nprecision = \"f32\"\nlinks = 20\nlink_length = 0.01\nshape = \"arc\"\nradius = 0.1\n",
            "f32.toml",
        )
        .unwrap();
        let set = World::new(&scene).unwrap();
        let input = "{\"cmd\":\"move\",\"chain\":\"hair\",\"target\":[0.3,0.1],\"substeps\":16}\n{\"cmd\":\"move\",\"chain\":0,\"target\":[1e39,0]}\n{\"cmd\":\"move\",\"chain\":0,\"target\":[0,0],\"precision\":\"f64\"}\n";
        let (s, lines) = run_lines(set, input);
        assert_eq!(
            s,
            Summary {
                requests: 3,
                failed: 2
            }
        );
        let j = &lines[0].joints;
        assert_eq!(j[20], [0.3f32 as f64, 0.1f32 as f64, 0.0]);
        // Lengths are kept in the stored link vectors; positions (|x| < 0.5) are f32 numbers, each
        // rounded by up to half an ulp of 0.5, so a distance read off them is good to about 2 ulps.
        let tol = 2.0 * 0.5 * f32::EPSILON as f64;
        for w in j.windows(2) {
            let d = ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
            assert!((d - 0.01).abs() < tol, "{d}");
        }
        assert_eq!(
            (lines[1].status.as_str(), lines[2].status.as_str()),
            ("too-far", "bad-option")
        );
        assert!(lines[1].reason.contains("4.096e1"), "{}", lines[1].reason);
    }

    #[test]
    fn a_malformed_line_is_named() {
        let set = World::new(&default_scene()).unwrap();
        let input = "{\"cmd\":\"query\",\"chain\":0}\n{\"cmd\":\"move\",\"chain\":0,\"target\":[1,2,3,4]}\n";
        let e = run_batch(
            &mut solver(set),
            &mut input.as_bytes(),
            &mut Vec::new(),
            Format::Csv,
            "r.jsonl",
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("r.jsonl:2:"), "{e}");
        assert!(e.contains("2 or 3 coordinates"), "{e}");
    }
}
