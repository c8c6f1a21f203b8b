//! The scenarios of the speed-against-accuracy measurements (`cargo bench -p clients --bench accuracy`,
//! and the sweep episodes of `episode accuracy`): a 40-link rope whose head follows a helix, and the knot
//! scripts' hand paths (the overhand on 160 links, the square knot's two hands on 320), collision off
//! (the ground truth, DOP853 from `tractrix::ground_truth`, knows no contacts).

use knots::script::Script;
use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Instant;
use tractrix::ground_truth::{GroundTruthOptions, follow_path, helix};
use tractrix::{Chain, Method, MoveOptions, Real, Substeps};

/// One driven-joint leg: which joint, through which targets.
#[derive(Debug, Clone)]
pub struct Leg {
    /// The driven joint.
    pub joint: usize,
    /// Its targets, in order.
    pub targets: Vec<Vector3<f64>>,
}

#[derive(Debug, Clone)]
pub struct Scenario {
    /// Its name in tables.
    pub name: &'static str,
    /// Its short name on the command line (`helix`, `overhand`, `square`).
    pub key: &'static str,
    /// Links of the straight start, along +x from the origin.
    pub links: usize,
    /// Their length.
    pub link: f64,
    /// The driven joints' paths, played in order.
    pub legs: Vec<Leg>,
    /// The substeps the bench measures.
    pub substeps: Vec<u32>,
}

impl Scenario {
    /// Moves in the whole scenario.
    pub fn moves(&self) -> usize {
        self.legs.iter().map(|l| l.targets.len()).sum()
    }
}

/// A script's turns as legs on a straight rope of `links` links of `link` along +x, played on a
/// collision-free chain (each turn starts where the previous left its joint).
pub fn script_legs(script: &Script, links: usize, link: f64) -> Vec<Leg> {
    let mut rope = Chain::<f64, 3>::straight(links, link, Vector3::zeros(), Vector3::x()).unwrap();
    let mut legs = Vec::new();
    for turn in &script.turn {
        let joint = match turn.joint.as_str() {
            "head" => links,
            "tail" => 0,
            j => j.parse().unwrap(),
        };
        let s = rope.joint(joint);
        let targets: Vec<Vector3<f64>> = turn
            .targets([s.x, s.y, s.z], script.max_step)
            .into_iter()
            .map(Vector3::from)
            .collect();
        rope.move_along(joint, &targets, &MoveOptions::default())
            .unwrap();
        legs.push(Leg { joint, targets });
    }
    legs
}

/// The three scenarios, in table order.
pub fn scenarios() -> Vec<Scenario> {
    let all: Vec<u32> = (0..=8).map(|e| 1 << e).collect();
    let script = |name| Script::builtin(name).expect("a builtin script");
    vec![
        Scenario {
            name: "helix, 40 links",
            key: "helix",
            links: 40,
            link: 1.0,
            legs: vec![Leg {
                joint: 40,
                targets: helix(Vector3::new(40.0, 0.0, 0.0), 4.0, 3.0, 1.5, 30),
            }],
            substeps: all,
        },
        Scenario {
            name: "overhand script, 160 links",
            key: "overhand",
            links: 160,
            link: 0.25,
            legs: script_legs(&script("overhand"), 160, 0.25),
            substeps: vec![1, 2, 4, 8, 16],
        },
        Scenario {
            name: "square-knot script, 320 links",
            key: "square",
            links: 320,
            link: 0.25,
            legs: script_legs(&script("square"), 320, 0.25),
            substeps: vec![1, 2, 4, 8],
        },
    ]
}

/// The ground truth: the joints at the end of the continuous motion.
pub fn truth(s: &Scenario) -> Vec<Vector3<f64>> {
    let mut p = Chain::<f64, 3>::straight(s.links, s.link, Vector3::zeros(), Vector3::x())
        .unwrap()
        .positions();
    for leg in &s.legs {
        p = follow_path(&p, leg.joint, &leg.targets, &GroundTruthOptions::default())
            .expect("ground truth");
    }
    p
}

/// Plays the scenario with one method, substeps `k` and precision `T`; returns (seconds, largest joint
/// error against `truth`, in links).
pub fn play<T: Real>(s: &Scenario, method: Method, k: u32, truth: &[Vector3<f64>]) -> (f64, f64) {
    let cast = |v: &Vector3<f64>| Vector3::new(T::lit(v.x), T::lit(v.y), T::lit(v.z));
    let legs: Vec<(usize, Vec<Vector3<T>>)> = s
        .legs
        .iter()
        .map(|l| (l.joint, l.targets.iter().map(cast).collect()))
        .collect();
    let mut c =
        Chain::<T, 3>::straight(s.links, T::lit(s.link), Vector3::zeros(), Vector3::x()).unwrap();
    let opts = MoveOptions {
        method,
        substeps: Substeps::Fixed(k),
        ..MoveOptions::default()
    };
    let t0 = Instant::now();
    for (joint, targets) in &legs {
        for t in targets {
            black_box(c.move_joint(*joint, *t, &opts).expect("a move"));
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let err = c
        .positions()
        .iter()
        .zip(truth)
        .map(|(a, b)| (Vector3::new(a.x.to_f64(), a.y.to_f64(), a.z.to_f64()) - b).norm())
        .fold(0.0, f64::max)
        / s.link;
    (secs, err)
}

/// The ground truth of `s`, read from `dir` if an earlier episode left it there, else computed and
/// written there (atomically: concurrent episodes of one sweep share it). Returns it and the seconds
/// spent computing it (0 when read). A file of the wrong size is computed again.
pub fn truth_cached(
    s: &Scenario,
    dir: Option<&std::path::Path>,
) -> std::io::Result<(Vec<Vector3<f64>>, f64)> {
    let n = s.links + 1;
    if let Some(d) = dir {
        let file = d.join(format!("{}-{}x{}.truth", s.key, s.links, s.link));
        if let Ok(bytes) = std::fs::read(&file)
            && bytes.len() == n * 24
        {
            let v = bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect::<Vec<_>>();
            return Ok((
                v.chunks_exact(3)
                    .map(|p| Vector3::new(p[0], p[1], p[2]))
                    .collect(),
                0.0,
            ));
        }
        let t0 = Instant::now();
        let gt = truth(s);
        let secs = t0.elapsed().as_secs_f64();
        std::fs::create_dir_all(d)?;
        let tmp = d.join(format!(
            "{}.{}.tmp",
            file.file_name().and_then(|f| f.to_str()).unwrap_or("truth"),
            std::process::id()
        ));
        let bytes: Vec<u8> = gt
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .flat_map(f64::to_le_bytes)
            .collect();
        std::fs::write(&tmp, bytes)?;
        std::fs::rename(&tmp, &file)?;
        return Ok((gt, secs));
    }
    let t0 = Instant::now();
    let gt = truth(s);
    Ok((gt, t0.elapsed().as_secs_f64()))
}
