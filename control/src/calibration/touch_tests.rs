use super::*;

/// Deterministic noise in [-1, 1] for frame `i`.
fn noise(i: u32) -> f64 {
    let x = (f64::from(i) * 12.9898).sin() * 43_758.545;
    2.0 * (x - x.floor()) - 1.0
}

/// A descent at `speed` m/s sampled at 100 Hz onto a spring of `k` N/m (the summed element
/// force) whose surface is at `surface` m, with an offset, a gain, noise of `sd` N and a
/// 1 Hz pulse of 10 mN; returns the result.
fn descend(k: f64, surface: f64, offset: f64, gain: f64, speed: f64, sd: f64) -> Touch {
    let mut t = SurfaceTouch::new(TouchSettings::default()).expect("settings");
    let mut h = surface + 0.008;
    let mut i = 0u32;
    loop {
        i += 1;
        let pulse = 0.01 * (f64::from(i) * 0.01 * std::f64::consts::TAU).sin();
        let f = offset + gain * k * (surface - h).max(0.0) + sd * noise(i) + pulse;
        if let Some(r) = t.push(h, f) {
            return r.expect("touch");
        }
        if t.ready() {
            h -= speed * 0.01;
        }
        assert!(h > surface - 0.01, "the descent never ended");
    }
}

#[test]
fn the_surface_is_the_knee_of_the_force_not_where_it_crossed_a_threshold() {
    // The simulator's array: ~200 N/m of summed element force, 40 mN of noise. The stop
    // threshold (0.25 N) lies 1.25 mm below the surface, the start (0.16 N) 0.8 mm.
    let touch = descend(200.0, 0.0012, 0.4, 1.0, 0.002, 0.04);
    assert!(
        (touch.surface_height_m - 0.0012).abs() < 0.1e-3,
        "{touch:?}"
    );
    assert!((touch.stiffness_n_per_m - 200.0).abs() < 40.0, "{touch:?}");
    assert!((touch.baseline_n - 0.4).abs() < 0.02, "{touch:?}");
    // Where it rested, 8 mm above the surface: what tells a real fall from a touch at rest.
    assert!((touch.rest_height_m - 0.0092).abs() < 1e-12, "{touch:?}");
}

#[test]
fn an_array_gain_error_scales_the_force_but_not_the_surface() {
    let low = descend(1500.0, -0.003, 0.0, 0.8, 0.002, 0.01);
    let high = descend(1500.0, -0.003, 0.0, 1.2, 0.002, 0.01);
    for t in [low, high] {
        assert!((t.surface_height_m + 0.003).abs() < 0.03e-3, "{t:?}");
    }
    assert!((high.stiffness_n_per_m / low.stiffness_n_per_m - 1.5).abs() < 0.15);
}

#[test]
fn frames_while_settling_and_a_glitch_in_the_baseline_do_not_raise_the_thresholds() {
    let settings = TouchSettings::default();
    let mut t = SurfaceTouch::new(settings).expect("settings");
    // The swing after a long move: large, and skipped.
    for i in 0..settings.settle_frames {
        assert!(t.push(0.01, if i % 2 == 0 { 1.0 } else { -1.0 }).is_none());
        assert!(!t.ready());
    }
    // Quiet frames but one glitch: the median and the MAD ignore it.
    for i in 0..settings.baseline_frames {
        let f = if i == 7 { 5.0 } else { 0.001 * noise(i as u32) };
        assert!(t.push(0.01, f).is_none());
    }
    assert!(t.ready());
    let sd = t.baseline_sd_n().expect("baseline");
    assert!(sd < 0.002, "{sd}");
    // So 0.3 N ends the descent (stop 0.25 N), which a mean and SD (SD ~0.7 N) would not.
    for i in 0..50 {
        assert!(t.push(0.009 - f64::from(i) * 1e-5, 0.0).is_none());
    }
    let mut ended = None;
    for i in 0..100 {
        let h = 0.0085 - f64::from(i) * 2e-5;
        if let Some(r) = t.push(h, 200.0 * (0.0085 - h)) {
            ended = Some(r);
            break;
        }
    }
    let touch = ended.expect("ended").expect("touch");
    assert!(
        (touch.surface_height_m - 0.0085).abs() < 0.05e-3,
        "{touch:?}"
    );
}

#[test]
fn a_descent_that_meets_nothing_says_how_far_it_went_and_what_it_felt() {
    let mut t = SurfaceTouch::new(TouchSettings::default()).expect("settings");
    let mut i = 0;
    while !t.ready() {
        t.push(0.008, 0.01 * noise(i));
        i += 1;
    }
    for k in 0..200 {
        assert!(
            t.push(0.008 - f64::from(k) * 1e-4, 0.01 * noise(k))
                .is_none()
        );
    }
    match t.finish() {
        Err(TouchError::NoSurface {
            most_n, lowest_m, ..
        }) => {
            assert!(most_n < 0.05, "{most_n}");
            assert!((lowest_m - (0.008 - 199e-4)).abs() < 1e-12, "{lowest_m}");
        }
        other => panic!("{other:?}"),
    }
    assert!(t.push(0.0, 10.0).is_none(), "once ended, it stays ended");
}

#[test]
fn a_force_that_falls_as_the_sensor_goes_down_is_not_a_surface() {
    let mut t = SurfaceTouch::new(TouchSettings::default()).expect("settings");
    let mut i = 0;
    while !t.ready() {
        t.push(0.0, 0.001 * noise(i));
        i += 1;
    }
    // Pushed at first (a knock, something brushing the array), then nothing as it goes down.
    for k in 0..60 {
        let f = if k < 10 { 0.2 } else { 0.0 };
        assert!(t.push(-f64::from(k) * 2e-5, f).is_none());
    }
    let r = t.finish();
    assert!(matches!(r, Err(TouchError::NotASurface { .. })), "{r:?}");
}

#[test]
fn a_non_finite_sample_ends_the_touch_with_an_error() {
    let mut t = SurfaceTouch::new(TouchSettings::default()).expect("settings");
    let r = t.push(f64::NAN, 0.0).expect("ends");
    assert!(matches!(r, Err(TouchError::NonFinite { .. })));
    assert!(t.push(0.0, 10.0).is_none(), "once ended, it stays ended");
}

#[test]
fn settings_that_cannot_work_are_refused() {
    for s in [
        TouchSettings {
            baseline_frames: 2,
            ..TouchSettings::default()
        },
        TouchSettings {
            start_n: 0.0,
            ..TouchSettings::default()
        },
        TouchSettings {
            stop_n: 0.06,
            ..TouchSettings::default()
        },
        TouchSettings {
            stop_n: f64::NAN,
            ..TouchSettings::default()
        },
        TouchSettings {
            descent_speed_m_s: 0.0,
            ..TouchSettings::default()
        },
        TouchSettings {
            clearance_m: 0.2,
            ..TouchSettings::default()
        },
    ] {
        assert!(SurfaceTouch::new(s).is_err(), "{s:?}");
    }
}
