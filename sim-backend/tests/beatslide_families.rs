//! A deterministic regression of `beatslide` on every shipped scene family: one scene drawn
//! per family from a fixed seed (never one the tracker's constants were chosen on: those
//! were seeds 1001-1030), run once. The bounds are loose (several times what it does today,
//! docs/BENCHMARKS.md "Scene families") so that an honest change of the tracker passes,
//! but a tracker that loses the artery, slides past a bend or follows a lump fails.

use pulsetrack_sim::family;
use pulsetrack_sim::runner::run_trial;
use pulsetrack_sim::trial::TrialResult;

const SEED: u64 = 1;

/// Farthest any autonomous point may lie from the artery here, m.
const WORST_M: f64 = 6e-3;

fn run(name: &str) -> TrialResult {
    let (cname, text) = config::shipped::SIM_CONFIG;
    let cfg = config::load_str(cname, text).expect("the shipped config loads");
    let fam = family::load(name, None).expect("a shipped family");
    let scene = fam.draw(SEED).expect("the family draws a scene");
    run_trial(&scene, &cfg, "beatslide", SEED).expect("the trial runs")
}

fn assert_holds(name: &str) {
    let t = run(name);
    let why = format!(
        "{name}: {} {:?}; error SD {:.2} mm, max {:.2} mm over {} points; {} backtracks",
        t.end_reason,
        t.detail,
        t.lateral_error_m.sd * 1e3,
        t.lateral_error_m.max * 1e3,
        t.lateral_error_m.points,
        t.backtracks
    );
    assert!(t.completed, "{why}");
    assert!(t.lateral_error_m.points >= 5, "{why}");
    assert!(t.lateral_error_m.max < WORST_M, "{why}");
    assert!(t.lateral_error_m.sd < WORST_M / 4.0, "{why}");
}

#[test]
fn every_shipped_family_is_covered_here() {
    let mut names = family::shipped_family_names();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "bends.ron",
            "breathing.ron",
            "fast-irregular-heart.ron",
            "heavy-instrument.ron",
            "seed-bench-mixed.ron",
            "sinusoids.ron",
            "smooth-random.ron",
            "spirals.ron",
        ],
        "a new family needs its regression below"
    );
}

#[test]
fn bends() {
    assert_holds("bends");
}

#[test]
fn breathing() {
    assert_holds("breathing");
}

#[test]
fn fast_irregular_heart() {
    assert_holds("fast-irregular-heart");
}

#[test]
fn heavy_instrument() {
    assert_holds("heavy-instrument");
}

#[test]
fn seed_bench_mixed() {
    assert_holds("seed-bench-mixed");
}

#[test]
fn sinusoids() {
    assert_holds("sinusoids");
}

#[test]
fn smooth_random() {
    assert_holds("smooth-random");
}

#[test]
fn spirals() {
    assert_holds("spirals");
}
