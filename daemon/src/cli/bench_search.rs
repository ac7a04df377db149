//! `pulsetrack bench --task search --region-mm 40 --methods search,raster --trials N
//! [--seed S] [--families GLOB] [--json]`: the autonomous search (issue 17) against its
//! raster baseline on drawn regions, in one run.
//!
//! Trial `i` (seed `S + i`) draws one region scene (`sim::search_scene`): a square of the
//! given side on the seed's bench (`seed-arc-145`), or on the scene a family draws from the
//! same seed (its heart, depth, pulse, noise and rig), with a straight artery through it
//! at a random offset and heading, or, in a fifth of trials, lumps only. Every method runs
//! on the same draws. Rows per (rig, method): `method`, `trials`, `found_rate` (found among
//! regions with an artery), `beats_mean` (heartbeats from start to seeded, found trials),
//! `seed_error_m` (the larger of the two seeds' lateral errors, mean over found trials),
//! `false_found_rate` (found among artery-free regions), and more (docs/search.md).

use control::frames::SurfacePoint;
use control::search::SearchMethod;
use rayon::prelude::*;
use serde::Serialize;
use sim::runner::search::{SearchTrial, run_search};
use sim::scene::Scene;
use sim::search_scene::{self, SearchDraw};

use crate::cli::progress::Progress;

/// The base rig of a row: the seed's bench, or a family's draws.
pub enum Rig {
    Seed(Box<Scene>),
    Family(Box<sim::family::LoadedFamily>),
}

impl Rig {
    fn name(&self) -> String {
        match self {
            Rig::Seed(s) => s.name.clone(),
            Rig::Family(f) => f.family.name.clone(),
        }
    }

    fn draw(&self, side_m: f64, seed: u64) -> Result<SearchDraw, String> {
        let base = match self {
            Rig::Seed(s) => (**s).clone(),
            Rig::Family(f) => f.draw(seed)?,
        };
        search_scene::draw(&base, SurfacePoint::new(0.0, 0.0), side_m, seed)
    }
}

/// One row of the report.
#[derive(Debug, Clone, Serialize)]
pub struct SearchRow {
    /// The rig the regions were drawn on (a scene or a family).
    pub rig: String,
    pub method: String,
    pub trials: usize,
    /// Trials whose region held an artery, and those that held only lumps.
    pub artery_trials: usize,
    pub empty_trials: usize,
    /// Found, among regions with an artery.
    pub found_rate: Option<f64>,
    /// Heartbeats from the start to seeded, mean and median over found trials.
    pub beats_mean: Option<f64>,
    pub beats_median: Option<f64>,
    /// The larger of the two seeds' lateral errors, mean and maximum over found trials, m.
    pub seed_error_m: Option<f64>,
    pub seed_error_max_m: Option<f64>,
    /// Found among artery-free regions.
    pub false_found_rate: Option<f64>,
    /// Seeds more than 2 mm from the artery (issue 13's false-point rule).
    pub false_points: usize,
    /// Heartbeats until an artery-free region was declared empty, mean.
    pub empty_beats_mean: Option<f64>,
    pub looks_mean: f64,
    /// How every trial ended, in trial order.
    pub ends: Vec<String>,
    /// The farthest the sensor went outside its region in any trial, m.
    pub outside_max_m: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct SearchReport {
    pub task: &'static str,
    pub region_m: f64,
    pub seed: u64,
    pub trials: u32,
    pub rows: Vec<SearchRow>,
}

/// Run every method on every rig's draws (in parallel) and summarize.
pub fn bench_search(
    config: &config::Config,
    rigs: &[Rig],
    methods: &[SearchMethod],
    side_m: f64,
    trials: u32,
    seed: u64,
) -> Result<SearchReport, String> {
    let mut draws = Vec::with_capacity(rigs.len());
    for rig in rigs {
        let d = (0..trials)
            .map(|i| rig.draw(side_m, seed.wrapping_add(u64::from(i))))
            .collect::<Result<Vec<_>, _>>()?;
        draws.push(d);
    }
    let jobs: Vec<(usize, usize, u32)> = (0..rigs.len())
        .flat_map(|r| (0..methods.len()).flat_map(move |m| (0..trials).map(move |i| (r, m, i))))
        .collect();
    let bar = Progress::new("bench search", Some(jobs.len() as u64));
    let results: Vec<Result<SearchTrial, String>> = jobs
        .par_iter()
        .map(|&(r, m, i)| {
            let d = &draws[r][i as usize];
            let trial_seed = seed.wrapping_add(u64::from(i));
            let result = run_search(
                &d.scene,
                config,
                d.region,
                methods[m],
                config.search,
                trial_seed,
            )
            .map_err(|e| format!("{} with {}: {e}", d.scene.name, methods[m].as_str()));
            bar.step(&format!(
                "{} {} seed {trial_seed}: {}",
                rigs[r].name(),
                methods[m].as_str(),
                result.as_ref().map_or("error", |t| t.end.as_str())
            ));
            result
        })
        .collect();
    bar.finish();
    let mut it = results.into_iter();
    let mut rows = Vec::new();
    for (r, rig) in rigs.iter().enumerate() {
        for m in methods {
            let mut ts = Vec::with_capacity(trials as usize);
            for _ in 0..trials {
                ts.push(it.next().ok_or("missing trial result")??);
            }
            rows.push(summarize(&rig.name(), *m, &draws[r], &ts));
        }
    }
    Ok(SearchReport {
        task: "search",
        region_m: side_m,
        seed,
        trials,
        rows,
    })
}

fn mean(xs: &[f64]) -> Option<f64> {
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

fn median(xs: &[f64]) -> Option<f64> {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).map(|m| {
        if v.len().is_multiple_of(2) {
            0.5 * (m + v[v.len() / 2 - 1])
        } else {
            *m
        }
    })
}

fn summarize(
    rig: &str,
    method: SearchMethod,
    draws: &[SearchDraw],
    ts: &[SearchTrial],
) -> SearchRow {
    let artery: Vec<(&SearchDraw, &SearchTrial)> = draws
        .iter()
        .zip(ts)
        .filter(|(d, _)| d.artery_in_region)
        .collect();
    let empty: Vec<&SearchTrial> = draws
        .iter()
        .zip(ts)
        .filter(|(d, _)| !d.artery_in_region)
        .map(|(_, t)| t)
        .collect();
    let found: Vec<&SearchTrial> = artery
        .iter()
        .filter(|(_, t)| t.end == "found")
        .map(|(_, t)| *t)
        .collect();
    let beats: Vec<f64> = found.iter().map(|t| t.beats as f64).collect();
    let worst: Vec<f64> = found
        .iter()
        .map(|t| t.seed_errors_m.iter().copied().fold(0.0, f64::max))
        .collect();
    let rate = |n: usize, of: usize| (of > 0).then(|| n as f64 / of as f64);
    let false_found = empty.iter().filter(|t| t.end == "found").count();
    let empty_beats: Vec<f64> = empty
        .iter()
        .filter(|t| t.end == "not_found")
        .map(|t| t.beats as f64)
        .collect();
    SearchRow {
        rig: rig.to_string(),
        method: method.as_str().to_string(),
        trials: ts.len(),
        artery_trials: artery.len(),
        empty_trials: empty.len(),
        found_rate: rate(found.len(), artery.len()),
        beats_mean: mean(&beats),
        beats_median: median(&beats),
        seed_error_m: mean(&worst),
        seed_error_max_m: worst.iter().copied().reduce(f64::max),
        false_found_rate: rate(false_found, empty.len()),
        false_points: ts
            .iter()
            .flat_map(|t| &t.seed_errors_m)
            .filter(|e| **e > 2e-3)
            .count(),
        empty_beats_mean: mean(&empty_beats),
        looks_mean: mean(&ts.iter().map(|t| t.looks as f64).collect::<Vec<_>>()).unwrap_or(0.0),
        ends: ts.iter().map(|t| t.end.clone()).collect(),
        outside_max_m: ts.iter().map(|t| t.outside_m).fold(0.0, f64::max),
    }
}

/// A table for people (millimetres).
pub fn print_table(report: &SearchReport) {
    use crate::cli::stdout::outln;
    outln!(
        "search of a {:.0} mm region, {} trials from seed {}",
        report.region_m * 1e3,
        report.trials,
        report.seed
    );
    outln!(
        "{:<22} {:<8} {:>7} {:>7} {:>7} {:>9} {:>9} {:>7} {:>6} {:>7}",
        "rig",
        "method",
        "found",
        "beats",
        "median",
        "seed mm",
        "max mm",
        "false",
        "empty",
        "looks"
    );
    let pct = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{:.0}%", r * 100.0));
    let num = |x: Option<f64>, k: f64, d: usize| {
        x.map_or("-".to_string(), |x| format!("{:.*}", d, x * k))
    };
    for r in &report.rows {
        outln!(
            "{:<22} {:<8} {:>7} {:>7} {:>7} {:>9} {:>9} {:>7} {:>6} {:>7.1}",
            r.rig,
            r.method,
            pct(r.found_rate),
            num(r.beats_mean, 1.0, 1),
            num(r.beats_median, 1.0, 1),
            num(r.seed_error_m, 1e3, 2),
            num(r.seed_error_max_m, 1e3, 2),
            pct(r.false_found_rate),
            num(r.empty_beats_mean, 1.0, 1),
            r.looks_mean
        );
    }
}
