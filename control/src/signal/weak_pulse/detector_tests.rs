//! The detector on synthetic frames: the kernel family, the generic waveform, Gaussian
//! noise from `test_normals`, and a heart whose beat intervals vary as a real one's.

use super::*;
use crate::signal::detection_bound::{self, glrt_threshold, per_beat, snr_needed, waveform_energy};
use crate::signal::kernel_fit::element_kernel;
use crate::test_heart::{BeatCursor, beats};
use crate::test_normals::Normals;

const SIGMA: f64 = 0.012;
const FS: f64 = 100.0;
const PITCH: f64 = 0.002;
const WIDTH: f64 = 0.005;

fn settings(limit_s: f64) -> WeakPulseSettings {
    WeakPulseSettings {
        limit_s,
        ..WeakPulseSettings::default()
    }
}

/// What the array feels.
#[derive(Clone, Copy)]
struct Scene {
    /// Artery offset along the array, m, and its pulse's peak force on the nearest
    /// element, N (0 for none).
    x0_m: f64,
    amplitude_n: f64,
    period_s: f64,
    /// A static lump (peak force, N, at 2 mm) and a drift (N/s, and a slow swell, N).
    lump_n: f64,
    drift_n_per_s: f64,
    swell_n: f64,
}

impl Scene {
    fn noise() -> Self {
        Self {
            x0_m: 0.0,
            amplitude_n: 0.0,
            period_s: 0.85,
            lump_n: 0.0,
            drift_n_per_s: 0.0,
            swell_n: 0.0,
        }
    }
}

fn kernel_at(x0: f64) -> [f64; ELEMENTS] {
    std::array::from_fn(|e| element_kernel((e as f64 - 4.5) * PITCH - x0, WIDTH, PITCH))
}

/// Feed `detector` the scene until it decides; the decision and the last progress.
fn run(
    detector: &mut WeakPulseDetector,
    scene: Scene,
    rng: &mut Normals,
) -> (Decision, Vec<Progress>) {
    let span = 400.0;
    let onsets = if scene.amplitude_n > 0.0 && scene.period_s > 0.0 {
        beats(scene.period_s, span, rng)
    } else if scene.amplitude_n > 0.0 {
        // A negative period: a metronome, for diagnosis.
        (0..1000)
            .map(|k| (k as f64 * -scene.period_s, -scene.period_s))
            .collect()
    } else {
        Vec::new()
    };
    let s = kernel_at(scene.x0_m);
    let peak = s.iter().copied().fold(0.0, f64::max);
    let lump = kernel_at(0.002);
    let mut heart = BeatCursor::new(onsets);
    let mut progress = Vec::new();
    for i in 0.. {
        let t = i as f64 / FS;
        let pulse = heart
            .at(t)
            .map_or(0.0, |(t0, rr)| generic_pressure(t - t0, rr));
        let drift =
            scene.drift_n_per_s * t + scene.swell_n * (std::f64::consts::TAU * t / 40.0).sin();
        let frame = TactileFrame {
            t_s: t,
            seq: i,
            force_n: std::array::from_fn(|e| {
                scene.amplitude_n * s[e] / peak * pulse
                    + scene.lump_n * lump[e]
                    + drift
                    + SIGMA * rng.next()
            }),
        };
        if let Some(p) = detector.push(&frame).expect("a good frame") {
            progress.push(p);
            if let Some(d) = p.decision {
                return (d, progress);
            }
        }
    }
    unreachable!()
}

fn three_se(p: f64, n: usize) -> f64 {
    3.0 * (p * (1.0 - p) / n as f64).sqrt()
}

fn law(limit_s: f64, draws: usize, seed: u64) -> NoiseLaw {
    let mut rng = Normals::new(seed);
    NoiseLaw::measure(&settings(limit_s), &PulseShape::Generic, draws, &mut || {
        rng.next()
    })
    .expect("law")
}

fn detector(threshold: &Threshold) -> WeakPulseDetector {
    WeakPulseDetector::new(
        settings(threshold.settings.limit_s),
        PulseShape::Generic,
        threshold,
    )
    .expect("detector")
}

#[test]
fn noise_only_windows_of_every_length_alarm_at_the_designed_rate() {
    let pfa = 0.05;
    let law = law(45.0, 800, 1);
    let mut rng = Normals::new(2);
    let trials = 500;
    let mut last = f64::NEG_INFINITY;
    for limit in [9.0, 24.0, 45.0] {
        let threshold = law.threshold(pfa, limit).expect("threshold");
        // Averaged likelihood ratio: its sup stays under ln(1/pfa) (Ville) at every length,
        // and a longer window needs a higher one.
        assert!(
            threshold.log_ratio < (1.0 / pfa).ln(),
            "{limit} s: {}",
            threshold.log_ratio
        );
        assert!(threshold.log_ratio >= last);
        last = threshold.log_ratio;
        let alarms = (0..trials)
            .filter(|_| {
                matches!(
                    run(&mut detector(&threshold), Scene::noise(), &mut rng).0,
                    Decision::Found(_)
                )
            })
            .count();
        let rate = alarms as f64 / trials as f64;
        assert!(
            (rate - pfa).abs() < three_se(pfa, trials),
            "{limit} s: threshold {:.3}, false alarms {rate}",
            threshold.log_ratio
        );
    }
}

#[test]
fn a_static_lump_and_slow_drift_do_not_pass_for_a_pulse() {
    let pfa = 0.05;
    let threshold = law(30.0, 600, 3).threshold(pfa, 30.0).expect("threshold");
    let mut rng = Normals::new(4);
    let trials = 300;
    // A lump pressing 0.3 N (25 noise SDs) under element 5, the contact load creeping
    // 5 mN/s and swelling ±40 mN over 40 s: hundreds of times the pulse.
    let scene = Scene {
        lump_n: 0.3,
        drift_n_per_s: 0.005,
        swell_n: 0.04,
        ..Scene::noise()
    };
    let alarms = (0..trials)
        .filter(|_| {
            matches!(
                run(&mut detector(&threshold), scene, &mut rng).0,
                Decision::Found(_)
            )
        })
        .count();
    let rate = alarms as f64 / trials as f64;
    assert!(rate < pfa + three_se(pfa, trials), "{rate}");
}

/// The searched-position bound's beats for a pulse of peak `amplitude_n` at `x0`, with the
/// same kernel, noise and waveform (at the mean period), at `pfa` and `pd`, and the
/// position Fisher information of one beat.
fn bound(amplitude_n: f64, x0: f64, period_s: f64, pfa: f64, pd: f64) -> (f64, f64) {
    let table: Vec<(f64, [f64; ELEMENTS])> = (-22..=22)
        .map(|k| {
            let x = k as f64 * 0.0005;
            (x, kernel_at(x))
        })
        .collect();
    let at = table
        .iter()
        .enumerate()
        .fold((0, f64::INFINITY), |a, (i, (x, _))| {
            if (x - x0).abs() < a.1 {
                (i, (x - x0).abs())
            } else {
                a
            }
        })
        .0;
    let peak = kernel_at(x0).iter().copied().fold(0.0, f64::max);
    let w: Vec<f64> = (0..(period_s * FS).round() as usize)
        .map(|i| amplitude_n / peak * generic_pressure(i as f64 / FS, period_s))
        .collect();
    let beat = per_beat(&table, at, waveform_energy(&w), SIGMA).expect("signal");
    let mut rng = Normals::new(99);
    let eta = glrt_threshold(&table, pfa, 20_000, &mut || rng.next()).expect("threshold");
    let beats = detection_bound::beats_for(snr_needed(eta, pd).expect("pd"), beat.snr);
    (beats, beat.position_information_per_m2)
}

#[test]
fn a_pulse_the_bound_feels_in_five_beats_is_found_where_it_is() {
    let (pfa, pd, period) = (0.05, 0.9, 0.85);
    let x0 = 0.0013; // between elements 5 and 6
    // Scale the pulse so that the bound needs 5 beats. (At 15 beats, the internal
    // mammary artery, this detector does not reach pd 0.9 within 2x: the timing search
    // costs more than the bound's margin; see the module's notes and the example.)
    let (b1, _) = bound(0.0014, x0, period, pfa, pd);
    let amplitude = 0.0014 * (b1 / 5.0).sqrt();
    let (bound_beats, info_per_beat) = bound(amplitude, x0, period, pfa, pd);
    assert!((bound_beats - 5.0).abs() < 0.1, "{bound_beats}");
    let limit = 30.0;
    let threshold = law(limit, 600, 5).threshold(pfa, limit).expect("threshold");
    let mut rng = Normals::new(6);
    let trials = 120;
    let (mut found, mut close, mut timed, mut beats_used, mut sq, mut z2) =
        (0, 0, 0, 0.0, 0.0, 0.0);
    for _ in 0..trials {
        let scene = Scene {
            x0_m: x0,
            amplitude_n: amplitude,
            period_s: period,
            ..Scene::noise()
        };
        let (decision, progress) = run(&mut detector(&threshold), scene, &mut rng);
        if let Decision::Found(f) = decision {
            found += 1;
            beats_used += f.elapsed_s / period;
            let error = f.offset_z_m - x0;
            close += usize::from(error.abs() < 0.001);
            sq += error * error;
            z2 += (error / f.offset_se_m).powi(2);
            timed += usize::from((f.period_s / period - 1.0).abs() < 0.1);
            // Progress rose to the threshold and said what was left.
            let before = progress[progress.len().saturating_sub(2)];
            assert!(progress.len() == 1 || before.snr <= before.snr_needed);
        }
    }
    let rate = found as f64 / trials as f64;
    let mean_beats = beats_used / found.max(1) as f64;
    let rms = (sq / found.max(1) as f64).sqrt();
    let crb = (1.0 / (info_per_beat * mean_beats)).sqrt();
    let rms_z = (z2 / found.max(1) as f64).sqrt();
    // The figures every assertion below reports (no printing in control: its purity test).
    let summary = format!(
        "found {rate} (bound {bound_beats:.1} beats, limit {:.1}); mean beats to decide {mean_beats:.1}; within 1 mm {close}/{found}; rms error {:.2} mm, CRB at those beats {:.2} mm; rms error/SE {rms_z:.2}; period within 10 % {timed}",
        limit / period,
        rms * 1e3,
        crb * 1e3
    );
    assert!(
        rate > pd - 2.0 * (pd * (1.0 - pd) / trials as f64).sqrt(),
        "{summary}"
    );
    assert!(timed as f64 >= 0.9 * found as f64, "{summary}");
    // Decided just above threshold along a searched track, the place is rougher than the
    // bound at those beats: measured 87 % within 1 mm, RMS 3.1x the bound, and the reported
    // SE (the bound's formula at the estimate) understating the scatter 1.9x (with 3 s
    // segments: 82 %, 3.4x, 2.05x, deciding at 14 beats against 17.5 now, as no decision
    // comes before a 10 s segment's end). A caller that needs the place weighs on
    // (`keep_weighing`). Asserted as measured, not as hoped.
    assert!(close as f64 >= 0.75 * found as f64, "{summary}");
    assert!(rms < 4.0 * crb, "{summary}");
    assert!((0.6..2.5).contains(&rms_z), "{summary}");
}

#[test]
fn degenerate_inputs_give_errors_or_no_decision_never_a_panic() {
    // Three segments, whatever the default segment's length.
    let limit = 3.0 * WeakPulseSettings::default().segment_s;
    let frames = ((limit + 6.0) * FS) as u64;
    let threshold = law(limit, 20, 7).threshold(0.5, limit).expect("threshold");
    // A flat signal: no noise to weigh anything by; refused at every segment, then the
    // limit passes with no decision for a pulse.
    let mut d = detector(&threshold);
    let mut flat = 0;
    for i in 0..frames {
        let frame = TactileFrame {
            t_s: i as f64 / FS,
            seq: i,
            force_n: [0.7; ELEMENTS],
        };
        match d.push(&frame) {
            Err(WeakPulseError::Flat { .. }) => flat += 1,
            Ok(_) => {}
            Err(e) => panic!("{e}"),
        }
    }
    assert!(flat >= 3);
    assert!(
        matches!(d.decision(), Some(Decision::NotFound { .. })),
        "{:?}",
        d.decision()
    );
    // A NaN frame and a frame out of time order are refused and skipped.
    let mut d = detector(&threshold);
    let mut rng = Normals::new(8);
    let frame = |i: u64, rng: &mut Normals| TactileFrame {
        t_s: i as f64 / FS,
        seq: i,
        force_n: std::array::from_fn(|_| SIGMA * rng.next()),
    };
    assert!(d.push(&frame(0, &mut rng)).is_ok());
    let mut bad = frame(1, &mut rng);
    bad.force_n[3] = f64::NAN;
    assert!(matches!(
        d.push(&bad),
        Err(WeakPulseError::NonFinite { seq: 1, .. })
    ));
    assert!(d.push(&frame(1, &mut rng)).is_ok());
    assert!(matches!(
        d.push(&frame(1, &mut rng)),
        Err(WeakPulseError::TimeOrder { .. })
    ));
    // One dead (stuck) element is left out, the others still weighed.
    let mut d = detector(&threshold);
    for i in 0..frames {
        let mut f = frame(i, &mut rng);
        f.force_n[2] = 0.3;
        assert!(d.push(&f).is_ok());
    }
    // Bad settings, waveforms and thresholds are refused.
    let bad = WeakPulseSettings {
        max_rate_hz: 0.5,
        ..settings(limit)
    };
    assert!(matches!(
        NoiseLaw::measure(&bad, &PulseShape::Generic, 20, &mut || 0.0),
        Err(WeakPulseError::Setting { .. })
    ));
    assert!(matches!(
        NoiseLaw::measure(
            &settings(limit),
            &PulseShape::Learned(vec![1.0; 3]),
            20,
            &mut || 0.0
        ),
        Err(WeakPulseError::Waveform(_))
    ));
    assert!(matches!(
        NoiseLaw::measure(
            &settings(limit),
            &PulseShape::Learned(vec![1.0; 30]),
            20,
            &mut || 0.0
        ),
        Err(WeakPulseError::Waveform(_))
    ));
    assert!(
        WeakPulseDetector::new(settings(limit + 3.0), PulseShape::Generic, &threshold).is_err()
    );
    let law = law(limit, 20, 9);
    assert!(law.threshold(0.01, limit).is_err() && law.threshold(0.5, 2.0 * limit).is_err());
}
