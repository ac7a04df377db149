use super::*;
use crate::test_normals::Normals;

const SIGMA: f64 = 0.012;
const LOAD: f64 = 0.5;
const FRAMES: usize = 500;

/// Frames of readings `reading(element, frame index)`.
fn record(count: usize, mut reading: impl FnMut(usize, usize) -> f64) -> Vec<TactileFrame> {
    (0..count)
        .map(|i| TactileFrame {
            t_s: i as f64 * 0.01,
            seq: 1000 + i as u64,
            force_n: std::array::from_fn(|e| reading(e, i)),
        })
        .collect()
}

/// An array with offsets and gains spread 20 % about 1; element 2 dead (noise, no response),
/// element 5 stuck (the same value always), element 8 saturated at the 1 N rail of
/// `settings()` (a high offset and gain).
struct Rig {
    offset: [f64; ELEMENTS],
    gain: [f64; ELEMENTS],
}

const DEAD: usize = 2;
const STUCK: usize = 5;
const SATURATED: usize = 8;

fn rig() -> Rig {
    Rig {
        offset: [0.05, -0.03, 0.02, 0.0, 0.11, 0.123, -0.08, 0.04, 0.7, 0.01],
        gain: [0.8, 1.2, 0.0, 1.05, 0.9, 1.0, 1.15, 0.85, 1.2, 1.1],
    }
}

fn settings() -> TactileSettings {
    TactileSettings {
        full_scale_n: 1.0,
        ..Default::default()
    }
}

fn recordings(rig: &Rig, seed: u64) -> (Vec<TactileFrame>, Vec<TactileFrame>) {
    let mut normals = Normals::new(seed);
    let mut reading = |e: usize, force: f64| {
        if e == STUCK {
            return rig.offset[e];
        }
        (rig.offset[e] + rig.gain[e] * force + SIGMA * normals.next()).min(settings().full_scale_n)
    };
    let rest = record(FRAMES, |e, _| reading(e, 0.0));
    let loaded = record(FRAMES, |e, _| reading(e, LOAD));
    (rest, loaded)
}

#[test]
fn offsets_noise_and_gains_are_measured_and_bad_elements_marked() {
    let rig = rig();
    let (rest, loaded) = recordings(&rig, 5);
    let tare = Tare::from_frames(&rest, &settings()).unwrap();
    assert_eq!(tare.frames(), FRAMES);
    let cal = calibrate_gains(&tare, &loaded, LOAD).unwrap();
    let n = FRAMES as f64;
    for (e, c) in cal.elements.iter().enumerate() {
        let expected = match e {
            DEAD => ElementStatus::Dead,
            STUCK => ElementStatus::Stuck,
            SATURATED => ElementStatus::Saturated,
            _ => ElementStatus::Good,
        };
        assert_eq!(c.status, expected, "element {e}: {c:?}");
        if e == STUCK {
            assert!(c.noise_sd_n < 1e-12, "{c:?}");
            continue;
        }
        assert!(
            (c.offset_n - rig.offset[e]).abs() < 4.0 * SIGMA / n.sqrt(),
            "element {e}: {c:?}"
        );
        assert!(
            (c.noise_sd_n / SIGMA - 1.0).abs() < 0.1,
            "element {e}: {c:?}"
        );
        if e != SATURATED {
            // Two means of n frames each: SE = √2 σ/(√n F).
            let se = 2f64.sqrt() * SIGMA / (n.sqrt() * LOAD);
            assert!((c.gain_standard_error / se - 1.0).abs() < 0.1, "{c:?}");
            assert!(
                (c.gain - rig.gain[e]).abs() < 4.0 * se,
                "element {e}: {c:?}"
            );
        }
    }
    assert_eq!(
        cal.usable(),
        [
            true, true, false, true, true, false, true, true, false, true
        ]
    );
    assert_eq!(cal.unusable_count(), 3);
    // Three unusable elements fail the default (at most one); the gains are precise.
    let [unusable, precision] = cal.checks(&Tolerances::default());
    assert!(!unusable.passed(), "{unusable}");
    assert!(precision.passed(), "{precision}");
    // The corrected reading of a usable element under the load is the load.
    let raw: [f64; ELEMENTS] = std::array::from_fn(|e| rig.offset[e] + rig.gain[e] * LOAD);
    let corrected = cal.correct(&raw);
    for (e, c) in corrected.iter().enumerate() {
        match c {
            Some(f) => assert!((f - LOAD).abs() < 0.01, "element {e}: {f}"),
            None => assert!(!cal.usable()[e], "element {e}"),
        }
    }
    let mut nan_raw = raw;
    nan_raw[0] = f64::NAN;
    assert_eq!(cal.correct(&nan_raw)[0], None);
    // σ for the localization: the median of σ/gain over the seven good elements.
    let sd = cal.noise_sd_n().unwrap();
    assert!(sd > SIGMA / 1.2 * 0.9 && sd < SIGMA / 0.8 * 1.1, "{sd}");
}

#[test]
fn a_rail_touched_once_saturates_and_one_just_below_does_not() {
    let s = settings();
    let rest = record(50, |e, i| 0.1 + 0.01 * ((e + i) % 3) as f64);
    let touches = |peak: f64| {
        record(50, move |e, i| {
            let base = 0.6 + 0.01 * ((e + i) % 3) as f64;
            if e == 4 && i == 17 { peak } else { base }
        })
    };
    let tare = Tare::from_frames(&rest, &s).unwrap();
    let at_rail = calibrate_gains(&tare, &touches(1.0), 0.5).unwrap();
    assert_eq!(at_rail.elements[4].status, ElementStatus::Saturated);
    assert_eq!(at_rail.unusable_count(), 1);
    let below = calibrate_gains(&tare, &touches(0.999_999), 0.5).unwrap();
    assert_eq!(below.unusable_count(), 0, "{below:?}");
    // At the rail with no load too.
    let rest_at_rail = record(50, |e, i| {
        if e == 0 && i == 3 {
            1.0
        } else {
            0.01 * ((e + i) % 3) as f64
        }
    });
    let tare = Tare::from_frames(&rest_at_rail, &s).unwrap();
    let cal = calibrate_gains(&tare, &touches(0.7), 0.5).unwrap();
    assert_eq!(cal.elements[0].status, ElementStatus::Saturated);
}

#[test]
fn the_dead_gain_threshold_is_sharp() {
    let s = settings();
    let rest = record(40, |e, i| 0.01 * ((e + i) % 5) as f64);
    // Element e responds with gain 0.15 + 0.01 e under a 1 N load: below 0.2 for e < 5.
    let loaded = record(40, |e, i| {
        0.01 * ((e + i) % 5) as f64 + 0.15 + 0.01 * e as f64
    });
    let tare = Tare::from_frames(&rest, &s).unwrap();
    let cal = calibrate_gains(&tare, &loaded, 1.0).unwrap();
    for (e, c) in cal.elements.iter().enumerate() {
        let dead = c.gain < 0.2;
        assert_eq!(c.status == ElementStatus::Dead, dead, "element {e}: {c:?}");
        assert_eq!(dead, e < 5, "element {e}: {c:?}");
    }
    // A reversed element (reads less under load) is dead too.
    let reversed = record(40, |e, i| {
        0.01 * ((e + i) % 5) as f64 - if e == 9 { 0.5 } else { -0.5 }
    });
    let cal = calibrate_gains(&tare, &reversed, 1.0).unwrap();
    assert_eq!(cal.elements[9].status, ElementStatus::Dead);
    assert!(cal.elements[9].gain < 0.0);
}

#[test]
fn flat_signals_are_stuck_or_saturated_never_trusted() {
    let s = settings();
    // Flat everywhere: every element stuck, nothing to localize with, every check fails.
    let flat = record(30, |e, _| 0.1 * e as f64 / ELEMENTS as f64);
    let tare = Tare::from_frames(&flat, &s).unwrap();
    let cal = calibrate_gains(&tare, &record(30, |_, _| 0.9), 0.5).unwrap();
    assert!(
        cal.elements
            .iter()
            .all(|c| c.status == ElementStatus::Stuck)
    );
    assert_eq!(cal.usable(), [false; ELEMENTS]);
    assert_eq!(cal.correct(&[0.5; ELEMENTS]), [None; ELEMENTS]);
    assert_eq!(cal.noise_sd_n(), None);
    assert!(cal.worst_gain_relative_error().is_nan());
    assert!(
        cal.checks(&Tolerances::default())
            .iter()
            .all(|c| !c.passed())
    );
    // Noisy at rest but flat under the load (clipped at a rail below full_scale_n).
    let rest = record(30, |e, i| 0.01 * ((e + i) % 4) as f64);
    let tare = Tare::from_frames(&rest, &s).unwrap();
    let loaded = record(30, |e, i| {
        if e == 3 {
            0.8
        } else {
            0.5 + 0.01 * ((e + i) % 4) as f64
        }
    });
    let cal = calibrate_gains(&tare, &loaded, 0.5).unwrap();
    assert_eq!(cal.elements[3].status, ElementStatus::Saturated);
    assert_eq!(cal.unusable_count(), 1);
    assert!(cal.checks(&Tolerances::default()).iter().all(Check::passed));
}

#[test]
fn bad_recordings_are_refused_naming_the_frame_and_element() {
    let s = settings();
    let good = record(30, |e, i| 0.01 * ((e + i) % 4) as f64);
    let mut nan = good.clone();
    nan[17].force_n[6] = f64::NAN;
    let e = Tare::from_frames(&nan, &s).unwrap_err();
    assert_eq!(
        e,
        TactileCalibrationError::NonFinite {
            recording: Recording::NoLoad,
            frame: 17,
            seq: 1017,
            element: 6
        }
    );
    assert_eq!(
        e.to_string(),
        "no-load recording: frame 17 (seq 1017), element 6 is not finite"
    );
    let tare = Tare::from_frames(&good, &s).unwrap();
    let mut inf = good.clone();
    inf[0].force_n[0] = f64::NEG_INFINITY;
    assert_eq!(
        calibrate_gains(&tare, &inf, 0.5).unwrap_err().to_string(),
        "loaded recording: frame 0 (seq 1000), element 0 is not finite"
    );
    assert_eq!(
        Tare::from_frames(&good[..19], &s).unwrap_err(),
        TactileCalibrationError::TooFewFrames {
            recording: Recording::NoLoad,
            frames: 19,
            min: 20
        }
    );
    assert!(Tare::from_frames(&good[..20], &s).is_ok());
    assert!(matches!(
        calibrate_gains(&tare, &good[..3], 0.5),
        Err(TactileCalibrationError::TooFewFrames {
            recording: Recording::Loaded,
            frames: 3,
            ..
        })
    ));
    for force in [0.0, -0.5, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            calibrate_gains(&tare, &good, force),
            Err(TactileCalibrationError::InvalidLoad { .. })
        ));
    }
    for bad in [
        TactileSettings { min_frames: 1, ..s },
        TactileSettings {
            stuck_max_noise_sd_n: 0.0,
            ..s
        },
        TactileSettings {
            full_scale_n: f64::NAN,
            ..s
        },
        TactileSettings {
            min_gain: -0.1,
            ..s
        },
    ] {
        assert!(
            matches!(
                Tare::from_frames(&good, &bad),
                Err(TactileCalibrationError::InvalidSettings(_))
            ),
            "{bad:?}"
        );
    }
}

#[test]
fn a_noisy_load_fails_the_gain_precision_check() {
    // 20 frames at σ = 12 mN under a 20 mN load: the gain is known only to about 19 %.
    let mut normals = Normals::new(9);
    let s = TactileSettings::default();
    let rest = record(20, |_, _| SIGMA * normals.next());
    let loaded = record(20, |_, _| 0.02 + SIGMA * normals.next());
    let tare = Tare::from_frames(&rest, &s).unwrap();
    let cal = calibrate_gains(&tare, &loaded, 0.02).unwrap();
    let [unusable, precision] = cal.checks(&Tolerances::default());
    assert!(unusable.passed(), "{unusable}");
    assert!(!precision.passed(), "{precision}");
    assert!(cal.worst_gain_relative_error() > 0.1);
}

#[test]
fn the_negative_rail_saturates_and_overflowing_readings_are_never_good() {
    let s = settings();
    let rest = record(30, |e, i| 0.01 * ((e + i) % 4) as f64);
    let tare = Tare::from_frames(&rest, &s).unwrap();
    let loaded = record(30, |e, i| {
        if e == 1 && i == 4 {
            -1.0
        } else {
            0.5 + 0.01 * ((e + i) % 4) as f64
        }
    });
    let cal = calibrate_gains(&tare, &loaded, 0.5).unwrap();
    assert_eq!(cal.elements[1].status, ElementStatus::Saturated);
    assert_eq!(cal.unusable_count(), 1);
    // With no rail in reach, readings whose sums overflow give no number for the gain (8:
    // inf − inf) or for its error (7): dead, never good.
    let unbounded = TactileSettings {
        full_scale_n: f64::MAX,
        ..s
    };
    let rest = record(30, |e, i| {
        if e == 8 {
            1e308
        } else {
            0.01 * ((e + i) % 4) as f64
        }
    });
    let tare = Tare::from_frames(&rest, &unbounded).unwrap();
    let loaded = record(30, |e, i| {
        if (7..=8).contains(&e) {
            1e308
        } else {
            0.5 + 0.01 * ((e + i) % 4) as f64
        }
    });
    let cal = calibrate_gains(&tare, &loaded, 0.5).unwrap();
    assert!(
        cal.elements[7].gain.is_infinite() && cal.elements[8].gain.is_nan(),
        "{cal:?}"
    );
    assert_eq!(
        cal.elements[7].status,
        ElementStatus::Dead,
        "{:?}",
        cal.elements[7]
    );
    assert_eq!(
        cal.elements[8].status,
        ElementStatus::Dead,
        "{:?}",
        cal.elements[8]
    );
    assert_eq!(cal.unusable_count(), 2);
    assert!(
        cal.correct(&[0.5; ELEMENTS])
            .iter()
            .flatten()
            .all(|f| f.is_finite())
    );
    assert!(cal.noise_sd_n().is_some_and(f64::is_finite));
    assert!(cal.worst_gain_relative_error().is_finite());
}

/// The calibration of `rig()` from fresh recordings.
fn calibrated(seed: u64) -> TactileCalibration {
    let (rest, loaded) = recordings(&rig(), seed);
    let tare = Tare::from_frames(&rest, &settings()).expect("tare");
    calibrate_gains(&tare, &loaded, LOAD).expect("gains")
}

#[test]
fn a_corrected_frame_reads_the_true_force_and_zero_where_unusable() {
    let cal = calibrated(11);
    let rig = rig();
    // A noise-free frame under 0.3 N on every element.
    let raw = TactileFrame {
        t_s: 4.0,
        seq: 77,
        force_n: std::array::from_fn(|e| rig.offset[e] + rig.gain[e] * 0.3),
    };
    let out = cal.correct_frame(&raw);
    assert_eq!((out.t_s, out.seq), (4.0, 77));
    for e in 0..ELEMENTS {
        if [DEAD, STUCK, SATURATED].contains(&e) {
            assert_eq!(out.force_n[e], 0.0, "element {e} is unusable");
        } else {
            // Offsets within ~1 mN and gains within ~0.3 % from 500 frames of 12 mN noise.
            assert!(
                (out.force_n[e] - 0.3).abs() < 0.01,
                "element {e}: {} N",
                out.force_n[e]
            );
        }
    }
}

#[test]
fn the_geometry_skips_the_unusable_elements_and_takes_the_measured_noise() {
    let cal = calibrated(12);
    let configured = crate::sensor::ArrayGeometry {
        skip_elements: crate::sensor::ElementMask::try_from(vec![0]).expect("mask"),
        ..Default::default()
    };
    let g = cal
        .geometry(&configured)
        .expect("seven elements stay trusted");
    assert_eq!(
        Vec::<usize>::from(g.skip_elements),
        vec![0, DEAD, STUCK, SATURATED]
    );
    // σ / gain over the usable elements: 0.012 over gains 0.8 to 1.15, median near 0.012.
    assert!((g.noise_sd_n - SIGMA).abs() < 0.002, "{}", g.noise_sd_n);
    assert_eq!(g.pitch_m, configured.pitch_m);
    // One more skipped in the config leaves five: refused, naming the skipped elements.
    let too_many = crate::sensor::ArrayGeometry {
        skip_elements: crate::sensor::ElementMask::try_from(vec![0, 1, 3]).expect("mask"),
        ..Default::default()
    };
    let e = cal.geometry(&too_many).expect_err("five trusted");
    assert!(
        e.contains("[0, 1, 2, 3, 5, 8]") && e.contains("leaves 4"),
        "{e}"
    );
}

#[test]
fn a_calibration_from_a_file_is_checked_naming_the_element() {
    let good = calibrated(13);
    assert!(good.validate().is_ok());
    let mut bad = good;
    bad.elements[3].gain = f64::NAN;
    let e = bad.validate().expect_err("NaN gain");
    assert!(e.contains("element 3") && e.contains("gain"), "{e}");
    let mut bad = good;
    bad.elements[4].gain = -0.5;
    assert!(bad.validate().expect_err("negative").contains("element 4"));
    // An unusable element's numbers are never used, so they are not judged.
    let mut dead = good;
    dead.elements[DEAD].gain = f64::NAN;
    assert!(dead.validate().is_ok());
    let mut bad = good;
    bad.known_force_per_element_n = 0.0;
    assert!(bad.validate().expect_err("no load").contains("known_force"));
}
