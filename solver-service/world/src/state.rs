//! The world's state as one value: every chain's joint 0 and link vectors bit for bit, its held
//! joints (the prefix sum's state there), its instruments' poses and its datum joint, and the
//! sequence number. [`World::state`] takes it, [`World::restore`] puts it back after checking that it
//! belongs to this scene; a snapshot is this value encoded (the service's `persist`). Bundles are not
//! part of it (megabytes per move; they start from their scene).

use crate::World;
use crate::each_form;
use crate::scene::Precision;
use crate::sizes::MAX_HELD;
use crate::tension::Asked;
use serde::{Deserialize, Serialize};
use tractrix::Chain;
use tractrix::math::{Embed3, Real, Vector};

/// One chain's state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChainState {
    /// The scene's name of the chain.
    pub name: String,
    /// 2 or 3.
    pub dims: u32,
    /// The chain's arithmetic.
    pub precision: Precision,
    /// Link lengths (the scene's, checked on restore).
    pub lengths: Vec<f64>,
    /// Joint 0, `dims` numbers.
    pub origin: Vec<f64>,
    /// The link vectors, `dims` numbers each.
    pub links: Vec<f64>,
    /// Held joints: index, and the prefix sum's state there (sum, then carry).
    pub held: Vec<(u32, Vec<f64>, Vec<f64>)>,
    /// The chain's instruments' poses (a sphere's centre; a capsule's `a` then `b`).
    pub instruments: Vec<Vec<f64>>,
    /// The datum joint (the last moved one) and its position: the next move of it starts there.
    pub datum: (u32, Vec<f64>),
    /// Held joints whose last pulled move stopped short, and where they were asked to go
    /// ([`crate::tension`]).
    pub asked_joints: Vec<Asked>,
    /// Instruments whose last pulled pose stopped short, and their asked centres.
    pub asked_instruments: Vec<Asked>,
    /// The chain's eyelets in order (the scene's, and those its head made in tissue): the point
    /// (`dims` numbers), the link through it, and whether the chain still passes through it.
    pub eyelets: Vec<(Vec<f64>, u32, bool)>,
}

/// The state of every chain of a world, and its sequence number.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// The sequence number of the last accepted change.
    pub sequence: u64,
    /// Every chain, by handle.
    pub chains: Vec<ChainState>,
}

/// Why a state was not restored (nothing was changed).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RestoreError {
    /// Another number of chains than the scene's.
    #[error("{found} chains, the scene has {scene}")]
    ChainCount {
        /// Chains in the state.
        found: usize,
        /// Chains in the scene.
        scene: usize,
    },
    /// A chain of another name, dimension or precision than the scene's at its handle.
    #[error(
        "chain {found:?} ({found_dims}D, {found_precision:?}) in the state, {scene:?} ({scene_dims}D, {scene_precision:?}) in the scene"
    )]
    NotTheScene {
        /// The state's chain.
        found: String,
        /// Its dimension.
        found_dims: u32,
        /// Its precision.
        found_precision: Precision,
        /// The scene's chain.
        scene: String,
        /// Its dimension.
        scene_dims: u32,
        /// Its precision.
        scene_precision: Precision,
    },
    /// Link lengths that are not the scene's, bit for bit.
    #[error("chain {0:?}: link lengths differ from the scene")]
    Lengths(String),
    /// A joint the scene anchors that the state does not hold.
    #[error("chain {chain:?}: the scene anchors joint {joint}, the state does not hold it")]
    Anchor {
        /// The chain.
        chain: String,
        /// The anchored joint.
        joint: u32,
    },
    /// Numbers that do not make a pose of the chain (sizes, limits, held joints, datum, instruments).
    #[error("chain {chain:?}: {what}")]
    Pose {
        /// The chain.
        chain: String,
        /// What does not fit.
        what: String,
    },
}

impl World {
    /// The state of every chain, bit for bit, and the sequence number.
    pub fn state(&self) -> State {
        State {
            sequence: self.sequence(),
            chains: self
                .specs()
                .iter()
                .zip(self.geometry())
                .map(|(spec, g)| {
                    let (origin, links, held, datum) = each_form!(g, g => raw_parts(&g.chain));
                    ChainState {
                        name: spec.name.clone(),
                        dims: spec.dims,
                        precision: spec.precision,
                        lengths: spec.lengths.clone(),
                        origin,
                        links,
                        held,
                        instruments: each_form!(g, g => g.instrument_numbers()),
                        datum,
                        asked_joints: each_form!(g, g => g.tension().asked().0.to_vec()),
                        asked_instruments: each_form!(g, g => g.tension().asked().1.to_vec()),
                        eyelets: each_form!(g, g => g
                            .eyelets()
                            .iter()
                            .map(|e| {
                                let at = e.at.iter().map(|x| x.to_f64()).collect();
                                (at, e.link as u32, e.threaded)
                            })
                            .collect()),
                    }
                })
                .collect(),
        }
    }

    /// Puts every chain and the sequence number back as `state` has them, after checking that it
    /// belongs to this scene (chains, names, dimensions, precisions, link lengths bit for bit,
    /// anchors held, poses within the joint limits, the datum where the links put it): on an error
    /// nothing changed. Grasps and anchors come back as held joints; who owned a grasp does not
    /// (every restored grasp is unowned).
    pub fn restore(&mut self, state: &State) -> Result<(), RestoreError> {
        if state.chains.len() != self.len() {
            return Err(RestoreError::ChainCount {
                found: state.chains.len(),
                scene: self.len(),
            });
        }
        // Check everything before changing anything.
        let mut built = Vec::with_capacity(self.len());
        for ((d, geometry), s) in self.specs().iter().zip(self.geometry()).zip(&state.chains) {
            if s.name != d.name || s.dims != d.dims || s.precision != d.precision {
                return Err(RestoreError::NotTheScene {
                    found: s.name.clone(),
                    found_dims: s.dims,
                    found_precision: s.precision,
                    scene: d.name.clone(),
                    scene_dims: d.dims,
                    scene_precision: d.precision,
                });
            }
            if s.lengths.len() != d.lengths.len()
                || s.lengths
                    .iter()
                    .zip(&d.lengths)
                    .any(|(a, b)| a.to_bits() != b.to_bits())
            {
                return Err(RestoreError::Lengths(d.name.clone()));
            }
            if let Some(&joint) = d
                .anchors
                .iter()
                .find(|&&a| !s.held.iter().any(|h| h.0 == a))
            {
                return Err(RestoreError::Anchor {
                    chain: d.name.clone(),
                    joint,
                });
            }
            let pose = |what: String| RestoreError::Pose {
                chain: d.name.clone(),
                what,
            };
            let mut g = geometry.clone();
            each_form!(&mut g, h => {
                h.chain = rebuild(&h.initial.chain, &s.origin, &s.links, &s.held, &s.datum).map_err(pose)?;
                h.set_instrument_numbers(&s.instruments).map_err(|e| pose(e.to_string()))?;
                let n_inst = h.instruments().len();
                if let Some(a) = s.asked_joints.iter().find(|a| !h.chain.is_held(a.at)) {
                    return Err(pose(format!("asked target of joint {}, which is not held", a.at)));
                }
                if let Some(a) = s.asked_instruments.iter().find(|a| a.at >= n_inst) {
                    return Err(pose(format!("asked target of instrument {}, of {n_inst}", a.at)));
                }
                let all = s.asked_joints.iter().chain(&s.asked_instruments);
                if all.clone().any(|a| !a.target.iter().all(|x| x.is_finite())) {
                    return Err(pose("an asked target is not finite".into()));
                }
                if s.asked_joints.len() > MAX_HELD || s.asked_instruments.len() > n_inst {
                    return Err(pose("more asked targets than held joints or instruments".into()));
                }
                h.tension.set_asked(s.asked_joints.clone(), s.asked_instruments.clone());
                h.refresh_tension();
                set_eyelets(h, &s.eyelets, d.tissue.is_some()).map_err(pose)?;
            });
            built.push(g);
        }
        self.install(built, state.sequence);
        Ok(())
    }
}

/// The eyelets of a restored chain: the scene's (any number up to the most, made by the head in the
/// chain's tissue, when it has tissue), each on the link the state says, passing through it while
/// threaded (to 1e-9 of the link in f64, a thousand roundings in f32), in order and two links apart.
fn set_eyelets<T: Real, const D: usize>(
    h: &mut crate::form::LiveChain<T, D>,
    eyelets: &[(Vec<f64>, u32, bool)],
    tissue: bool,
) -> Result<(), String>
where
    Vector<T, D>: Embed3<T>,
{
    let scene = &h.initial.eyelets;
    let same_points = eyelets.len() == scene.len()
        && eyelets.iter().zip(scene).all(|(e, s)| {
            e.0.len() == D && e.0.iter().zip(s.at.iter()).all(|(a, b)| *a == b.to_f64())
        });
    if !tissue && !same_points {
        return Err(format!(
            "{} eyelets that are not the scene's {}",
            eyelets.len(),
            scene.len()
        ));
    }
    if eyelets.len() > crate::sizes::MAX_EYELETS {
        return Err(format!(
            "{} eyelets, at most {}",
            eyelets.len(),
            crate::sizes::MAX_EYELETS
        ));
    }
    h.eyelets.clear();
    let mut last: Option<u32> = None;
    for (k, (at, link, threaded)) in eyelets.iter().enumerate() {
        let (link, threaded) = (*link, *threaded);
        if link as usize >= h.chain.n_links() {
            return Err(format!("eyelet {k} on link {link}, past the head"));
        }
        if at.len() != D || !at.iter().all(|x| x.is_finite()) {
            return Err(format!("eyelet {k}: {at:?} is not a point"));
        }
        h.eyelets.push(tractrix::eyelet::Eyelet {
            at: Vector::<T, D>::from_iterator(at.iter().map(|&x| T::lit(x))),
            link: link as usize,
            threaded,
        });
        if !threaded {
            continue;
        }
        if last.is_some_and(|l| link < l + 2) {
            return Err(format!(
                "eyelet {k} on link {link}, less than two links after the one before"
            ));
        }
        last = Some(link);
        let off = h.eyelets[k].residual(&h.chain).map_or(0.0, |r| r.to_f64());
        let scale = h.chain.lengths()[link as usize]
            .to_f64()
            .max(h.eyelets[k].at.norm().to_f64());
        if off.is_nan() || off > scale * (1e3 * T::EPSILON.to_f64()).max(1e-9) {
            return Err(format!("eyelet {k} is {off:e} off link {link}"));
        }
    }
    Ok(())
}

type HeldParts = Vec<(u32, Vec<f64>, Vec<f64>)>;

type DatumPart = (u32, Vec<f64>);

fn raw_parts<T: Real, const D: usize>(c: &Chain<T, D>) -> (Vec<f64>, Vec<f64>, HeldParts, DatumPart)
where
    Vector<T, D>: Embed3<T>,
{
    let f = |v: &Vector<T, D>| v.iter().map(|x| x.to_f64()).collect::<Vec<f64>>();
    let origin = f(&c.origin());
    let links = c.links().iter().flat_map(f).collect();
    let held = c
        .held_raw()
        .map(|(j, sum, carry)| (j as u32, f(&sum), f(&carry)))
        .collect();
    let (b, at) = c.datum();
    (origin, links, held, (b as u32, f(&at)))
}
fn rebuild<T: Real, const D: usize>(
    like: &Chain<T, D>,
    origin: &[f64],
    links: &[f64],
    held: &HeldParts,
    datum: &DatumPart,
) -> Result<Chain<T, D>, String>
where
    Vector<T, D>: Embed3<T>,
{
    let n = like.n_links();
    if origin.len() != D || links.len() != n * D {
        return Err(format!("{} link numbers, expected {}", links.len(), n * D));
    }
    if held.len() > MAX_HELD {
        return Err(format!("{} held joints, at most {}", held.len(), MAX_HELD));
    }
    let v = |c: &[f64]| Vector::<T, D>::from_iterator(c.iter().map(|&x| T::lit(x)));
    let o = v(origin);
    let l: Vec<Vector<T, D>> = links.chunks_exact(D).map(v).collect();
    let mut chain =
        Chain::from_raw_parts(o, l, like.lengths().to_vec()).map_err(|e| e.to_string())?;
    // The limits are the scene's; a stored pose beyond them did not come from this scene.
    chain
        .set_limits(like.joint_limits().cloned())
        .map_err(|e| format!("joint limits: {e}"))?;
    if let Some((j, angle, excess)) = chain.limit_excess(T::lit(tractrix::chain::LIMIT_TOLERANCE)) {
        return Err(format!(
            "joint {j} turns {:.4} rad, {:.2e} beyond the scene's limit",
            angle.to_f64(),
            excess.to_f64()
        ));
    }
    let mut pins = Vec::with_capacity(held.len());
    for (j, sum, carry) in held {
        if sum.len() != D || carry.len() != D {
            return Err(format!("held joint {j}: {} coordinates", sum.len()));
        }
        pins.push((*j as usize, v(sum), v(carry)));
    }
    chain
        .set_held_raw(&pins)
        .map_err(|e| format!("held joints: {e}"))?;
    if datum.1.len() != D {
        return Err(format!("datum joint: {} coordinates", datum.1.len()));
    }
    let (b, at) = (datum.0 as usize, v(&datum.1));
    // The datum must put joint 0 where the stored origin is (the parts came from this chain).
    let mut probe = chain.clone();
    probe
        .set_datum(b, at)
        .map_err(|e| format!("datum joint {b}: {e}"))?;
    let extent = chain.total_length() + o.norm();
    let tol = T::EPSILON.sqrt() * (T::one() + extent);
    if (probe.origin() - o).norm() > tol {
        return Err(format!("datum joint {b} is not where the links put it"));
    }
    Ok(probe)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{Command, Point};
    use crate::scene::{default_scene, parse_scene};
    use tractrix::{MoveOptions, Substeps};

    /// Every joint of every chain as bits (computed here from the payload).
    fn bits(w: &World) -> Vec<u64> {
        (0..w.len() as u32)
            .flat_map(|c| {
                w.elements_with(c, true, true, true, (true, true))
                    .collect::<Vec<_>>()
            })
            .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect()
    }

    fn moved(scene: &crate::scene::Scene, n: u32) -> World {
        let mut w = World::new(scene).unwrap();
        for i in 0..n {
            let t = f64::from(i) * 0.3;
            let target = [Point::new(
                20.0 + 3.0 * t.cos(),
                3.0 * t.sin(),
                0.5 * t.sin(),
            )];
            let joint = if i % 4 == 3 { 0 } else { 40 };
            w.apply(&Command::Move {
                chain: 0,
                joint,
                targets: &target,
                options: MoveOptions {
                    substeps: Substeps::Fixed(1 + i % 3),
                    ..w.specs()[0].moves
                },
                take_over: false,
                smooth: false,
                pull: false,
                needle: crate::command::NeedleMove::Carried,
            })
            .unwrap();
        }
        w
    }

    #[test]
    fn a_restored_state_is_the_state_bit_for_bit() {
        let scene = default_scene();
        let w = moved(&scene, 25);
        let state = w.state();
        let mut fresh = World::new(&scene).unwrap();
        fresh.restore(&state).unwrap();
        assert_eq!(fresh.sequence(), w.sequence());
        assert_eq!(bits(&fresh), bits(&w));
        assert_eq!(fresh.state(), state);
        // The next move of the last moved joint starts where it did in the original.
        let (mut a, mut b) = (w, fresh);
        let target = [Point::new(21.0, 1.0, 0.25)];
        for x in [&mut a, &mut b] {
            let options = x.specs()[0].moves;
            x.apply(&Command::Move {
                chain: 0,
                joint: 40,
                targets: &target,
                options,
                take_over: false,
                smooth: false,
                pull: false,
                needle: crate::command::NeedleMove::Carried,
            })
            .unwrap();
        }
        assert_eq!(bits(&a), bits(&b));
    }

    #[test]
    fn a_state_that_is_not_the_scene_s_changes_nothing() {
        let scene = default_scene();
        let state = moved(&scene, 5).state();
        let mut w = World::new(&scene).unwrap();
        let before = bits(&w);
        let mut bad = Vec::new();
        let mut s = state.clone();
        s.chains.pop();
        bad.push(s);
        let mut s = state.clone();
        s.chains[0].lengths[3] = f64::from_bits(s.chains[0].lengths[3].to_bits() + 1);
        bad.push(s);
        let mut s = state.clone();
        s.chains[0].precision = crate::scene::Precision::F32;
        bad.push(s);
        let mut s = state.clone();
        s.chains[1].links.pop();
        bad.push(s);
        let mut s = state.clone();
        s.chains[0].datum.1[0] += 1.0;
        bad.push(s);
        for s in bad {
            assert!(w.restore(&s).is_err());
            assert_eq!(bits(&w), before);
            assert_eq!(w.sequence(), 0);
        }
        // A scene that anchors a joint the state does not hold.
        let anchored = parse_scene(
            "[[chain]]\nname = \"rope\"\nlinks = 4\nlink_length = 1.0\nanchors = [0]\n",
            "anchored",
        )
        .unwrap();
        let free = parse_scene(
            "[[chain]]\nname = \"rope\"\nlinks = 4\nlink_length = 1.0\n",
            "free",
        )
        .unwrap();
        let mut w = World::new(&anchored).unwrap();
        let e = w.restore(&World::new(&free).unwrap().state()).unwrap_err();
        assert!(matches!(e, RestoreError::Anchor { joint: 0, .. }), "{e}");
    }
}
