//! A deterministic regression of `beatslide` on every shipped scene: one fixed seed each,
//! bounds loose enough to survive any honest change of the tracker (they sit 2-4x beyond what
//! it does today; docs/tracker-beatslide.md has the measured numbers) but tight enough that a
//! broken tracker, a lost artery or a followed lump fails them.

use pulsetrack_sim::runner::run_trial;
use pulsetrack_sim::scene::{self, ArteryPath, Scene};
use pulsetrack_sim::trial::TrialResult;

const SEED: u64 = 1;

fn run(name: &str) -> (Scene, TrialResult) {
    let (cname, text) = config::shipped::SIM_CONFIG;
    let cfg = config::load_str(cname, text).expect("the shipped config loads");
    let s = scene::load(name, None).expect("a shipped scene or a scene file");
    let t = run_trial(&s, &cfg, "beatslide", SEED).expect("the trial runs");
    (s, t)
}

fn summary(t: &TrialResult) -> String {
    format!(
        "{} {:?}: error mean {:.2} mm, SD {:.2} mm, max {:.2} mm over {} points; {} beats, \
         {:.1} s, {:.3} m tracked, {} backtracks",
        t.end_reason,
        t.detail,
        t.lateral_error_m.mean * 1e3,
        t.lateral_error_m.sd * 1e3,
        t.lateral_error_m.max * 1e3,
        t.lateral_error_m.points,
        t.beats,
        t.duration_s,
        t.tracked_length_m,
        t.backtracks
    )
}

/// Heartbeats per 26 cm of tracked artery.
fn beats_per_26cm(t: &TrialResult) -> f64 {
    t.beats as f64 * 0.26 / t.tracked_length_m.max(1e-3)
}

/// Completed, within `sd_m` of the artery (SD and, 4x looser, the worst point) and within
/// `beats` heartbeats per 26 cm.
fn assert_tracks(name: &str, sd_m: f64, beats: f64) {
    assert_tracks_with(name, sd_m, beats, 5);
}

/// As [`assert_tracks`], with at least `points` points (not counting the seeds).
fn assert_tracks_with(name: &str, sd_m: f64, beats: f64, points: usize) {
    let (_, t) = run(name);
    let why = summary(&t);
    assert!(t.completed, "{name}: {why}");
    assert!(t.lateral_error_m.points >= points, "{name}: {why}");
    assert!(t.lateral_error_m.sd < sd_m, "{name}: {why}");
    assert!(t.lateral_error_m.max < 4.0 * sd_m, "{name}: {why}");
    assert!(beats_per_26cm(&t) < beats, "{name}: {why}");
}

// The seed's scenes: the goal is SD <= 0.5 mm in <= 30 beats per 26 cm (the bench
// pools 7 trials); one trial here, bounded at twice that.

#[test]
fn seed_arc_80() {
    assert_tracks("seed-arc-80", 1.0e-3, 45.0);
}

#[test]
fn seed_arc_145() {
    assert_tracks("seed-arc-145", 1.0e-3, 45.0);
}

#[test]
fn seed_arc_220() {
    assert_tracks("seed-arc-220", 1.0e-3, 45.0);
}

#[test]
fn seed_s_curve() {
    assert_tracks("seed-s-curve", 1.0e-3, 45.0);
}

#[test]
fn seed_radial_wrist() {
    // The applanated radial artery swings an element by about 15 mN under 12 mN of noise:
    // felt at both placements (long windows at rest), then followed a few beats per fix.
    let (_, t) = run("seed-radial-wrist");
    let why = summary(&t);
    assert!(t.completed, "{why}");
    // Its 28 mm of track take one to three fixes of several beats each (counted from the
    // first placement: the first mark's unseen lag no longer shortens it).
    assert!(t.lateral_error_m.points >= 1, "{why}");
    assert!(t.lateral_error_m.max < 3.0e-3, "{why}");
    assert!(t.beats < 60, "{why}");
}

// Where it fails: the tightest radius and the weakest pulse.

#[test]
fn tight_arc_20_fails_without_wandering() {
    // A 20 mm radius turns the artery across the 18 mm array within one fix: it is not
    // held (errors of millimetres), but every point stays within the array's reach.
    let (_, t) = run("tight-arc-20");
    assert!(t.lateral_error_m.max < 0.02, "{}", summary(&t));
}

#[test]
fn tight_arc_30() {
    // Its track is 6 cm: seeds 1-7 report 3 or 4 points. Seed 1's first mark waits 2 s more
    // since a mark must know its pulse's sign (docs/BENCHMARKS.md), and then reports 3: on an
    // arc this tight the artery sweeps across the array between fixes, and a fix within half
    // that sweep of the array's end is not reported (it steers).
    assert_tracks_with("tight-arc-30", 1.0e-3, 60.0, 3);
}

#[test]
fn tight_arc_60() {
    assert_tracks("tight-arc-60", 1.0e-3, 60.0);
}

#[test]
fn tight_arc_50() {
    assert_tracks("tight-arc-50", 1.0e-3, 60.0);
}

#[test]
fn tight_arc_40() {
    assert_tracks("tight-arc-40", 1.0e-3, 60.0);
}

#[test]
fn weak_pulse_50kpa() {
    assert_tracks("weak-pulse-50kpa", 1.0e-3, 45.0);
}

#[test]
fn weak_pulse_25kpa() {
    assert_tracks("weak-pulse-25kpa", 1.5e-3, 60.0);
}

#[test]
fn weak_pulse_12kpa() {
    assert_tracks("weak-pulse-12kpa", 1.5e-3, 200.0);
}

#[test]
fn weak_pulse_6kpa_is_felt_at_the_marks_and_found_again_at_rest() {
    // At the edge: the marks find it (the long window at rest), the slide may not hold it.
    // Where it loses it, the search at rest lasts as long as a fix (twelve beats): with
    // four seconds this trial searched twice, found nothing and ended lost at 131 s.
    let (_, t) = run("weak-pulse-6kpa");
    assert_ne!(t.end_reason, "not_seeded", "{}", summary(&t));
    assert!(t.completed, "{}", summary(&t));
    assert!(t.lateral_error_m.max < 4.0e-3, "{}", summary(&t));
}

#[test]
fn weak_pulse_3kpa_is_felt_by_listening_and_tracked_at_stops_with_no_false_point() {
    // A tenth of the noise SD: no 40 s window shows it; the marks listen on and find it,
    // and the track is made by 5 mm steps, listening at each (docs/tracker-beatslide.md,
    // "A pulse too weak for a window"). Slow, but every reported point on the artery.
    let (_, t) = run("weak-pulse-3kpa");
    let why = summary(&t);
    assert!(t.completed, "{why}");
    assert!(t.lateral_error_m.points >= 20, "{why}");
    assert!(t.lateral_error_m.sd < 1.0e-3, "{why}");
    assert_eq!(t.false_points, 0, "{why}");
}

// Robustness.

#[test]
fn robust_heart_rate_change() {
    assert_tracks("robust-heart-rate", 1.0e-3, 60.0);
}

#[test]
fn robust_irregular_beats() {
    assert_tracks("robust-irregular-beats", 1.5e-3, 90.0);
}

#[test]
fn robust_noise_doubled() {
    assert_tracks("robust-noise-doubled", 1.0e-3, 60.0);
}

#[test]
fn robust_lumps_are_not_followed() {
    // The lumps sit 8-9 mm beside the artery: following one puts points millimetres off.
    assert_tracks("robust-lumps", 1.0e-3, 45.0);
}

#[test]
fn robust_occlusion_stops_lost_at_rest_near_the_artery() {
    let (s, t) = run("robust-occlusion");
    let why = summary(&t);
    assert_eq!(t.end_reason, "lost", "{why}");
    assert!(!t.completed, "{why}");
    // It followed the artery while the pulse was clear (the first half: the pulse goes as
    // the lumen radius squared, a quarter of it at half way) ...
    assert!(t.tracked_length_m > 0.05, "{why}");
    let clear: Vec<f64> = t
        .located
        .iter()
        .filter(|p| !p.seed && p.along_path_m < 0.13)
        .map(|p| p.lateral_error_m)
        .collect();
    assert!(clear.len() >= 5, "{why}");
    let worst = clear.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    assert!(worst < 2.0e-3, "worst {worst} m in the first half; {why}");
    // ... and as it faded no fix far off the path was accepted (a window whose timed
    // pulse collapsed gives no fix that surprises the path model; the worst point is now
    // 1.3 mm off, it was 6.4 mm).
    assert!(t.lateral_error_m.max < 4.0e-3, "{why}");
    // ... and never wandered: the true sensor stays on the artery (the array's reach) and
    // ends within the blind-travel bound of the last point it located.
    let path = ArteryPath::from_spec(&s.artery.path).expect("the scene's path");
    for (time, _, truth) in &t.sensor_track {
        let off = path.nearest(*truth).offset_m;
        assert!(off.abs() < 0.009, "{time} s: {off} m off the artery; {why}");
    }
    let last = t.located.last().expect("located points");
    let (_, _, end) = t.sensor_track.last().expect("a sensor track");
    let d = (end.x_m - last.true_x_m).hypot(end.z_m - last.true_z_m);
    assert!(d < 0.04, "ended {d} m from the last located point; {why}");
}

/// Each point's reported uncertainty covers its true error: the tracker never claims to
/// know a point better than it does (docs/tracker-beatslide.md, "How sure a point is").
#[test]
fn located_points_carry_an_uncertainty_that_covers_their_error() {
    let (_, t) = run("seed-arc-145.ron");
    let z: Vec<f64> = t
        .located
        .iter()
        .map(|p| {
            let sd = p.sd_m.expect("beatslide reports an SD with every point");
            assert!(sd.is_finite() && sd > 0.0 && sd < 0.01, "{p:?}");
            p.lateral_error_m / sd
        })
        .collect();
    assert!(z.len() >= 10, "{}", summary(&t));
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    assert!(z.iter().all(|v| v.abs() < 3.0), "{z:?}");
    // Conservative (the fix floor is a model-error allowance) but not uselessly so.
    assert!(rms > 0.1 && rms < 1.2, "RMS error / SD {rms:.2}: {z:?}");
}

// A stiffer rig must not be made worse by the compliance compensation tuned on the seed's
// compliant bench (issue 13): the seed's 145 mm arc on a stiff and on a rigid rig
// (config/scenes/rigs/), bounded as the compliant one is above.

fn rig_scene(file: &str) -> TrialResult {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../config/scenes/rigs")
        .join(file);
    run(&path.to_string_lossy()).1
}

#[test]
fn a_stiff_and_a_rigid_rig_are_tracked_as_well_as_the_seeds() {
    for file in ["seed-arc-145-stiff.ron", "seed-arc-145-rigid.ron"] {
        let t = rig_scene(file);
        let why = summary(&t);
        assert!(t.completed, "{file}: {why}");
        assert!(t.lateral_error_m.points >= 5, "{file}: {why}");
        // Today about +0.1 mm and 0.15 mm; when the issue was filed, -0.6 mm.
        assert!(t.lateral_error_m.mean.abs() < 0.3e-3, "{file}: {why}");
        assert!(t.lateral_error_m.sd < 0.5e-3, "{file}: {why}");
        assert!(t.lateral_error_m.max < 2.0e-3, "{file}: {why}");
        assert!(beats_per_26cm(&t) < 60.0, "{file}: {why}");
    }
}
