//! The machine's own noise, measured beside the latency figures: how late a thread that sleeps to a
//! 1 ms schedule wakes up, and the gaps a busy loop sees (time the core was taken from it), on each
//! core the bench pins to. Nothing of ours runs meanwhile.

use anyhow::{Result, anyhow};
use std::io::Write;
use std::time::{Duration, Instant};

/// One probe's samples, in ns.
struct Probe {
    core: usize,
    what: &'static str,
    ns: Vec<u64>,
    note: String,
}

fn pct(v: &[u64], p: f64) -> u64 {
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// Wake-up lateness of `wakes` sleeps to a 1 ms schedule, on `core`.
fn sleeper(core: usize, wakes: usize) -> Result<Probe> {
    std::thread::spawn(move || -> Result<Probe> {
        shared::pin_current_thread(core).map_err(|e| anyhow!(e))?;
        let period = Duration::from_millis(1);
        let mut due = Instant::now() + period;
        let mut ns = Vec::with_capacity(wakes);
        for _ in 0..wakes {
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
            let now = Instant::now();
            ns.push(now.saturating_duration_since(due).as_nanos() as u64);
            due += period;
            if due < now {
                due = now + period;
            }
        }
        Ok(Probe {
            core,
            what: "sleep to a 1 ms schedule: wake-up lateness",
            ns,
            note: String::new(),
        })
    })
    .join()
    .map_err(|_| anyhow!("the noise probe panicked"))?
}

/// Gaps of at least 1 µs between two clock reads of a busy loop running `secs` on `core`.
fn spinner(core: usize, secs: f64) -> Result<Probe> {
    std::thread::spawn(move || -> Result<Probe> {
        shared::pin_current_thread(core).map_err(|e| anyhow!(e))?;
        let start = Instant::now();
        let end = start + Duration::from_secs_f64(secs);
        let mut last = start;
        let mut ns = Vec::new();
        let mut stolen = 0u64;
        loop {
            let now = Instant::now();
            if now >= end {
                break;
            }
            let gap = now.duration_since(last).as_nanos() as u64;
            if gap >= 1_000 {
                ns.push(gap);
                stolen += gap;
            }
            last = now;
        }
        let total = start.elapsed().as_nanos() as f64;
        Ok(Probe {
            core,
            what: "busy loop: gaps of 1 µs or more",
            note: format!(
                "{} gaps in {secs} s, {:.3} % of the time",
                ns.len(),
                100.0 * stolen as f64 / total
            ),
            ns,
        })
    })
    .join()
    .map_err(|_| anyhow!("the noise probe panicked"))?
}

/// Measures both probes on cores 0 and 1 (one at a time) and prints a Markdown table.
pub fn noise(out: &mut impl Write, wakes: usize, spin_secs: f64) -> Result<()> {
    let mut probes = Vec::new();
    for core in [0, 1] {
        probes.push(sleeper(core, wakes)?);
        probes.push(spinner(core, spin_secs)?);
    }
    writeln!(
        out,
        "The machine's own noise, measured before the rows below with nothing of ours running (µs):\n"
    )?;
    writeln!(
        out,
        "| core | probe | samples | p50 | p99 | p99.9 | max | note |\n|---:|---|---:|---:|---:|---:|---:|---|"
    )?;
    for p in &mut probes {
        p.ns.sort_unstable();
        let us = |ns: u64| format!("{:.1}", ns as f64 / 1e3);
        if p.ns.is_empty() {
            writeln!(
                out,
                "| {} | {} | 0 | – | – | – | – | {} |",
                p.core, p.what, p.note
            )?;
            continue;
        }
        writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            p.core,
            p.what,
            p.ns.len(),
            us(pct(&p.ns, 0.5)),
            us(pct(&p.ns, 0.99)),
            us(pct(&p.ns, 0.999)),
            us(pct(&p.ns, 1.0)),
            p.note
        )?;
    }
    writeln!(out)?;
    Ok(())
}
