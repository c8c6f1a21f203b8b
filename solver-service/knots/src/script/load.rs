//! Parsing and checking a script, and what may be changed on one (a perturbation, a tail, a tightening).

use super::*;

impl Script {
    /// Parses and checks a script; errors carry the line.
    pub fn parse(text: &str, file: &str) -> Result<Script, String> {
        let s: Script = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|sp| text[..sp.start.min(text.len())].matches('\n').count() + 1);
            match line {
                Some(l) => format!("{file}:{l}: {}", e.message().trim()),
                None => format!("{file}: {}", e.message().trim()),
            }
        })?;
        s.check().map_err(|m| format!("{file}: {m}"))?;
        Ok(s)
    }

    /// Checks sizes and numbers (a script from a file is outside input).
    pub fn check(&self) -> Result<(), String> {
        if self.turn.is_empty() || self.turn.len() > MAX_TURNS {
            return Err(format!(
                "a script has 1..={MAX_TURNS} turns, not {}",
                self.turn.len()
            ));
        }
        if !(self.max_step > 0.0 && self.max_step.is_finite()) {
            return Err(format!(
                "max_step {} is not a positive length",
                self.max_step
            ));
        }
        if self.name.is_empty()
            || self.name.len() > 64
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(format!(
                "name {:?}: 1..=64 letters, digits, - or _",
                self.name
            ));
        }
        for (k, t) in self.turn.iter().enumerate() {
            let at = |m: String| format!("turn {}: {m}", k + 1);
            if t.waypoints.len() > MAX_WAYPOINTS {
                return Err(at(format!("more than {MAX_WAYPOINTS} waypoints")));
            }
            if t.hand.is_empty() || t.hand.len() > 16 {
                return Err(at("hand: 1..=16 characters".into()));
            }
            parse_joint(&t.joint).map_err(at)?;
            if !t.waypoints.iter().flatten().all(|x| x.is_finite()) {
                return Err(at("a waypoint is not finite".into()));
            }
            if let Some(d) = &t.draw
                && !(d.tail >= 0.0 && d.tail <= 1e9)
            {
                return Err(at(format!("draw.tail {} is not in [0, 1e9]", d.tail)));
            }
            if let Some(th) = &t.throw {
                let n = norm(th.outward);
                if !(n > 0.0 && n.is_finite()) {
                    return Err(at("throw.outward must be a non-zero vector".into()));
                }
                if !(th.scale > 0.0 && th.scale.is_finite() && th.scale <= 1e6) {
                    return Err(at(format!("throw.scale {} is not in (0, 1e6]", th.scale)));
                }
                if !(th.exit >= 0.0 && th.exit.is_finite() && th.exit <= 1e9) {
                    return Err(at(format!("throw.exit {} is not in [0, 1e9]", th.exit)));
                }
            }
            if let Some(k) = &t.tuck {
                if loop_frame(k.outward, k.side).is_none() {
                    return Err(at(
                        "tuck.outward and tuck.side must be finite, non-zero and not parallel"
                            .into(),
                    ));
                }
                if !(k.clearance > 0.0 && k.clearance <= 1e6) {
                    return Err(at(format!(
                        "tuck.clearance {} is not in (0, 1e6]",
                        k.clearance
                    )));
                }
                if !(k.exit >= 0.0 && k.exit <= 1e9) {
                    return Err(at(format!("tuck.exit {} is not in [0, 1e9]", k.exit)));
                }
            }
            if let Some(w) = &t.wrap {
                if !(w.radius > 0.0 && w.radius.is_finite() && w.radius <= 1e6) {
                    return Err(at(format!("wrap.radius {} is not in (0, 1e6]", w.radius)));
                }
                if !(w.turns > 0.0 && w.turns <= 100.0) {
                    return Err(at(format!("wrap.turns {} is not in (0, 100]", w.turns)));
                }
                if !(w.at.is_finite()
                    && w.at.abs() <= 1e6
                    && w.pitch.is_finite()
                    && w.pitch.abs() <= 1e6)
                {
                    return Err(at(
                        "wrap.at and wrap.pitch must be finite, at most 1e6".into()
                    ));
                }
            }
            if let Some(m) = &t.instrument {
                let n = norm(m.axis);
                if !(m.tip.iter().all(|c| c.is_finite() && c.abs() <= 1e9)
                    && n > 0.0
                    && n.is_finite())
                {
                    return Err(at(
                        "instrument.tip must be finite and instrument.axis finite and non-zero"
                            .into(),
                    ));
                }
                if t.throw.is_some()
                    || t.wide_loop.is_some()
                    || t.tuck.is_some()
                    || t.wrap.is_some()
                    || !t.waypoints.is_empty()
                {
                    return Err(at(
                        "a turn that moves an instrument moves nothing else".into()
                    ));
                }
            }
            if let Some(g) = &t.tighten {
                if !(g.speed > 0.0 && g.speed.is_finite() && g.speed <= 1e6) {
                    return Err(at(format!("tighten.speed {} is not in (0, 1e6]", g.speed)));
                }
                if !(1..=10_000).contains(&g.stall) || g.max_steps as usize > MAX_WAYPOINTS {
                    return Err(at(format!(
                        "tighten.stall must be in 1..=10000 and tighten.max_steps at most \
                         {MAX_WAYPOINTS}"
                    )));
                }
                if t.throw.is_some()
                    || t.wide_loop.is_some()
                    || t.tuck.is_some()
                    || t.wrap.is_some()
                    || t.instrument.is_some()
                    || !t.waypoints.is_empty()
                {
                    return Err(at("a turn that tightens moves nothing else".into()));
                }
            }
            if let Some(l) = &t.wide_loop {
                if loop_frame(l.outward, l.side).is_none() {
                    return Err(at(
                        "wide_loop.outward and wide_loop.side must be finite, non-zero and not parallel"
                            .into(),
                    ));
                }
                if !(l.radius > 0.0 && l.radius.is_finite() && l.radius <= 1e6) {
                    return Err(at(format!(
                        "wide_loop.radius {} is not in (0, 1e6]",
                        l.radius
                    )));
                }
                if !(l.exit >= 0.0 && l.exit.is_finite() && l.exit <= 1e9) {
                    return Err(at(format!("wide_loop.exit {} is not in [0, 1e9]", l.exit)));
                }
                if !(l.feed.is_finite() && (0.0..=10.0).contains(&l.feed)) {
                    return Err(at(format!("wide_loop.feed {} is not in [0, 10]", l.feed)));
                }
            }
        }
        Ok(())
    }

    /// Perturbs the script as a person's hand departs from it (issue 34's magnitudes, [`HAND_SIZE`],
    /// [`HAND_DIRECTION`], [`HAND_SHIFT`]): each throw's, wide loop's and wrap's size by up to ±10 %,
    /// each component of a direction by up to ±0.05, an exit by up to ±1 unit (kept ≥ 0), and every
    /// waypoint, a wrap's place along its instrument and an instrument's tip by a random offset of
    /// length up to 0.1 units (half the knot ropes' thickness). The tremor on every step is the hand's
    /// ([`Tremor`]). One seed gives one script, so the hands of a script agree when each perturbs it
    /// with the same seed; seed 0 leaves it as it is.
    pub fn perturb(&mut self, seed: u64) {
        if seed == 0 {
            return;
        }
        let mut rng = SplitMix(seed);
        let size = |rng: &mut SplitMix| rng.range(1.0 - HAND_SIZE, 1.0 + HAND_SIZE);
        let turn = |rng: &mut SplitMix, v: &mut [f64; 3]| {
            for c in v {
                *c += rng.range(-HAND_DIRECTION, HAND_DIRECTION);
            }
        };
        let exit = |rng: &mut SplitMix, e: f64| (e + rng.range(-1.0, 1.0)).max(0.0);
        for t in &mut self.turn {
            if let Some(th) = &mut t.throw {
                th.scale *= size(&mut rng);
                turn(&mut rng, &mut th.outward);
                th.exit = exit(&mut rng, th.exit);
            }
            if let Some(l) = &mut t.wide_loop {
                l.radius *= size(&mut rng);
                turn(&mut rng, &mut l.outward);
                l.exit = exit(&mut rng, l.exit);
            }
            if let Some(w) = &mut t.wrap {
                w.radius *= size(&mut rng);
                w.at += rng.range(-HAND_SHIFT, HAND_SHIFT);
            }
            if let Some(m) = &mut t.instrument {
                m.tip = add(m.tip, rng.in_ball(HAND_SHIFT));
            }
            if let Some(k) = &mut t.tuck {
                turn(&mut rng, &mut k.outward);
                k.exit = exit(&mut rng, k.exit);
            }
            for w in &mut t.waypoints {
                *w = add(*w, rng.in_ball(HAND_SHIFT));
            }
        }
    }

    /// The script with every draw turn ([`Draw`]) leaving a tail of `tail` (`hand run --tail`).
    pub fn with_tail(mut self, tail: f64) -> Script {
        for t in self.turn.iter_mut().filter(|t| t.draw.is_some()) {
            t.draw = Some(Draw { tail });
        }
        self
    }

    /// The script followed by a tightening phase (`hand run --tighten SPEED`): every hand pulls the
    /// rope's end it holds away from the knot ([`Tighten`]) in turn, in the order of the hands, twice
    /// round (the first round cinches the knot, the second finds whether the other end's pull left
    /// room). An end is a chain's tail or head some turn of the hand drives; hands that drive neither
    /// (a hand that only carries an instrument) do not pull.
    pub fn with_tighten(mut self, speed: f64) -> Script {
        let mut ends: Vec<(String, String, String)> = Vec::new();
        for t in &self.turn {
            let end = t.joint == "tail" || t.joint == "head" || t.joint == "0";
            let key = (t.hand.clone(), t.chain.clone(), t.joint.clone());
            if end && t.instrument.is_none() && !ends.contains(&key) {
                ends.push(key);
            }
        }
        for _ in 0..2 {
            for (hand, chain, joint) in &ends {
                if self.turn.len() >= MAX_TURNS {
                    break;
                }
                self.turn.push(Turn {
                    hand: hand.clone(),
                    chain: chain.clone(),
                    joint: joint.clone(),
                    throw: None,
                    wide_loop: None,
                    tuck: None,
                    wrap: None,
                    instrument: None,
                    tighten: Some(Tighten::at(speed)),
                    drive: None,
                    pose: None,
                    draw: None,
                    waypoints: Vec::new(),
                });
            }
        }
        self
    }

    /// The hands of the script, in order of first appearance.
    pub fn hands(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for t in &self.turn {
            if !out.contains(&t.hand) {
                out.push(t.hand.clone());
            }
        }
        out
    }
}
