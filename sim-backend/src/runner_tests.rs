use super::*;
use crate::scene::{PathSpec, PulseSpec, TrackSpec};

fn sim_config() -> config::Config {
    let (name, text) = config::shipped::SIM_CONFIG;
    config::load_str(name, text).expect("the shipped config loads")
}

fn scene(name: &str) -> Scene {
    crate::scene::load(name, None).expect("shipped scene")
}

fn run(s: &Scene, seed: u64) -> TrialResult {
    run_trial(s, &sim_config(), "seed2002", seed).expect("the trial runs")
}

/// The trial without its only machine-dependent number.
fn comparable(mut t: TrialResult) -> String {
    t.wall_s = 0.0;
    serde_json::to_string(&t).expect("serializes")
}

#[test]
fn same_seed_gives_bit_identical_trials() {
    let s = scene("seed-arc-220.ron");
    let a = run(&s, 11);
    let b = run(&s, 11);
    assert_eq!(a.first_acquisition, b.first_acquisition);
    assert_eq!(a.sensor_track, b.sensor_track);
    assert_eq!(comparable(a), comparable(b));
}

#[test]
fn json_has_the_documented_fields() {
    let t = run(&scene("seed-arc-220.ron"), 1);
    let v: serde_json::Value = serde_json::to_value(&t).unwrap();
    for key in [
        "located",
        "duration_s",
        "beats",
        "backtracks",
        "completed",
        "end_reason",
        "lateral_error_m",
        "wall_s",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    for key in ["mean", "sd", "max"] {
        assert!(
            v["lateral_error_m"].get(key).is_some(),
            "missing lateral_error_m.{key}"
        );
    }
    let p = &v["located"][0];
    for key in ["t_s", "x_m", "z_m", "true_x_m", "true_z_m"] {
        assert!(p.get(key).is_some(), "missing located[].{key}");
    }
}

#[test]
fn seed_arc_220_regression() {
    // The gentlest arc: completes without backtracking, errs by about an element.
    let t = run(&scene("seed-arc-220.ron"), 1);
    assert!(t.completed, "{} {:?}", t.end_reason, t.detail);
    assert_eq!(t.backtracks, 0);
    assert!(t.lateral_error_m.sd < 2.0e-3, "{:?}", t.lateral_error_m);
    assert!(t.lateral_error_m.points >= 10);
    // On the order of two minutes, and the beats counted at about 1 Hz.
    assert!((40.0..300.0).contains(&t.duration_s), "{}", t.duration_s);
    let rate = t.beats as f64 / t.duration_s;
    assert!((0.9..1.1).contains(&rate), "{rate}");
    // Seeds first, then the autonomous points, in time order.
    assert!(t.located[0].seed && t.located[1].seed && !t.located[2].seed);
    assert!(t.located.windows(2).all(|w| w[0].t_s < w[1].t_s));
}

#[test]
fn seed_arc_145_and_s_curve_regression() {
    for name in ["seed-arc-145.ron", "seed-s-curve.ron"] {
        let t = run(&scene(name), 1);
        assert!(t.completed, "{name}: {} {:?}", t.end_reason, t.detail);
        assert!(
            t.lateral_error_m.sd < 5.0e-3,
            "{name}: {:?}",
            t.lateral_error_m
        );
        assert!(t.backtracks <= 3, "{name}: {}", t.backtracks);
    }
}

#[test]
fn seed_arc_80_regression() {
    // The tightest arc: it may lose the artery near its far end (the seed's compliance
    // problem), but it follows most of the way first.
    let t = run(&scene("seed-arc-80.ron"), 1);
    assert!(
        ["length_reached", "lost"].contains(&t.end_reason.as_str()),
        "{} {:?}",
        t.end_reason,
        t.detail
    );
    assert!(t.tracked_length_m > 0.1, "{}", t.tracked_length_m);
    assert!(t.lateral_error_m.sd < 6.0e-3, "{:?}", t.lateral_error_m);
}

#[test]
fn radial_wrist_regression() {
    // Even flattened against the radius (applanation), a 2.6 mm radial artery under 120/80
    // mmHg swings a 2 x 2 mm element by about 15 mN, under the seed's 2σ = 24 mN test: the
    // manual placements find no pulse (docs/calibration.md).
    let t = run(&scene("seed-radial-wrist.ron"), 1);
    assert_eq!(t.end_reason, "not_seeded", "{:?}", t.detail);
    assert!(!t.completed);
    assert_eq!(t.duration_s, 0.0);
}

#[test]
fn a_rigid_shaft_errs_less_than_a_compliant_one() {
    let compliant = scene("seed-arc-145.ron");
    let mut rigid = compliant.clone();
    rigid.shaft = None;
    rigid.pivot = None;
    // How far the robot's belief was from the truth at each localization.
    let belief_error = |t: &TrialResult| {
        let d: Vec<f64> = t
            .located
            .iter()
            .map(|p| {
                // The reported point minus the element offset is the believed sensor; the
                // true sensor is the same offset from true_x/true_z.
                (p.x_m - p.true_x_m).hypot(p.z_m - p.true_z_m)
            })
            .collect();
        d.iter().sum::<f64>() / d.len().max(1) as f64
    };
    let mut sd = [0.0; 2];
    for (k, s) in [&rigid, &compliant].into_iter().enumerate() {
        let t = run(s, 2);
        assert!(t.completed, "{} {:?}", t.end_reason, t.detail);
        let e = belief_error(&t);
        if k == 0 {
            // Only the encoders' quantization separates belief from truth.
            assert!(e < 0.2e-3, "rigid: {e}");
        } else {
            assert!(e > 1.0e-3, "compliant: {e}");
        }
        sd[k] = t.lateral_error_m.sd;
    }
    assert!(sd[0] < sd[1], "rigid {} vs compliant {}", sd[0], sd[1]);
}

fn straight_scene(heading_rad: f64, length_m: f64, track_m: f64) -> Scene {
    let mut s = scene("seed-arc-220.ron");
    let (c, sn) = (heading_rad.cos(), heading_rad.sin());
    let start = SurfacePoint::new(-0.1 * c, -0.1 * sn);
    s.artery.path = PathSpec::Straight {
        start,
        heading_rad,
        length_m,
    };
    s.placements = [
        SurfacePoint::new(start.x_m + 0.01 * c, start.z_m + 0.01 * sn),
        SurfacePoint::new(start.x_m + 0.02 * c, start.z_m + 0.02 * sn),
    ];
    s.track = TrackSpec {
        length_m: track_m,
        reason: "test".into(),
    };
    s
}

#[test]
fn an_artery_along_the_element_line_ends_cleanly() {
    let s = straight_scene(std::f64::consts::FRAC_PI_2, 0.2, 0.1);
    let t = run(&s, 1);
    assert!(!t.end_reason.is_empty());
    assert!(
        t.located
            .iter()
            .all(|p| p.x_m.is_finite() && p.z_m.is_finite())
    );
    assert!(t.simulated_s < TRIAL_TIME_LIMIT_S);
}

#[test]
fn a_path_leaving_the_workspace_ends_at_its_edge() {
    // 60 cm of straight artery: far beyond what the arm can reach through the pivot.
    let s = straight_scene(0.0, 0.6, 0.55);
    let t = run(&s, 1);
    assert!(!t.completed);
    assert!(
        ["workspace_edge", "lost"].contains(&t.end_reason.as_str()),
        "{} {:?}",
        t.end_reason,
        t.detail
    );
    assert!(t.tracked_length_m > 0.05, "{}", t.tracked_length_m);
}

#[test]
fn no_pulse_ends_cleanly_unseeded() {
    let mut s = scene("seed-arc-145.ron");
    s.pulse = PulseSpec::Absent;
    let t = run(&s, 1);
    assert_eq!(t.end_reason, "not_seeded");
    assert!(t.located.is_empty());
    assert_eq!(t.beats, 0);
}

#[test]
fn an_unknown_tracker_is_refused_by_name() {
    let e = run_trial(&scene("seed-arc-145.ron"), &sim_config(), "nope", 1).unwrap_err();
    assert!(e.to_string().contains("seed2002"), "{e}");
}

#[test]
fn the_ideal_robot_tracks_with_belief_equal_to_truth() {
    let mut s = scene("seed-arc-145.ron");
    s.robot = None;
    let t = run(&s, 1);
    assert!(t.completed, "{} {:?}", t.end_reason, t.detail);
    for p in &t.located {
        assert!(
            (p.x_m - p.true_x_m).abs() < 1e-12 && (p.z_m - p.true_z_m).abs() < 1e-12,
            "{p:?}"
        );
    }
}

#[test]
fn placing_by_eye_puts_the_sensor_itself_on_the_mark() {
    let mut s = scene("seed-arc-220.ron");
    s.placed_by = crate::scene::Placing::Eye;
    let t = run(&s, 1);
    let first = &t.located[0];
    assert!(first.seed);
    // Where the sensor truly was, and where the robot believed it, when the first mark was
    // made.
    let (_, believed, truth) = t
        .sensor_track
        .iter()
        .min_by(|a, b| (a.0 - first.t_s).abs().total_cmp(&(b.0 - first.t_s).abs()))
        .copied()
        .unwrap();
    let mark = s.placements[0];
    assert!(truth.distance_to(&mark) < 1.5e-3, "{truth:?} vs {mark:?}");
    // The approach was along +x: the compliance left the belief ahead, along +x.
    assert!(believed.x_m - truth.x_m > 2e-3, "{believed:?} {truth:?}");
    // Commanded by the robot instead, the belief is sent to the mark (it stops a little
    // short against the friction) and the sensor trails it by the compliance lag.
    let t = run(&scene("seed-arc-220.ron"), 1);
    let first = &t.located[0];
    let (_, believed, truth) = t
        .sensor_track
        .iter()
        .min_by(|a, b| (a.0 - first.t_s).abs().total_cmp(&(b.0 - first.t_s).abs()))
        .copied()
        .unwrap();
    assert!(truth.distance_to(&mark) > 3e-3, "{truth:?}");
    assert!(believed.distance_to(&mark) < truth.distance_to(&mark) - 2e-3);
    assert!(believed.x_m - truth.x_m > 2e-3, "{believed:?} {truth:?}");
}

#[test]
fn marking_is_refused_when_the_arm_stops_short() {
    // Joints too stiff with friction for the low-gain PD (and its trim) to move the sensor
    // the 10 mm to the first placement: the trial reports the shortfall and marks nothing.
    let mut s = scene("seed-arc-145.ron");
    let mut robot = s.robot.unwrap_or_default();
    robot.coulomb_friction_nm = [0.3, 0.3, 0.3];
    s.robot = Some(robot);
    for tracker in ["seed2002", "beatslide"] {
        let t = run_trial(&s, &sim_config(), tracker, 1).expect("the trial runs");
        assert_eq!(t.end_reason, SHORT_OF_TARGET, "{tracker}: {:?}", t.detail);
        assert!(!t.completed);
        assert!(t.located.is_empty(), "{tracker} marked: {:?}", t.located);
        let short = t.shortfall.as_ref().expect("the shortfall is reported");
        assert_eq!(short.what, "placement 1");
        assert_eq!(
            (short.target_x_m, short.target_z_m),
            (s.placements[0].x_m, s.placements[0].z_m)
        );
        assert!(short.shortfall_m > 1e-3, "{short:?}");
        assert!(["stalled", "not_at_rest"].contains(&short.reason.as_str()));
        let detail = t.detail.as_deref().unwrap_or("");
        assert!(
            detail.contains("mm short") && detail.contains("placement 1"),
            "{detail}"
        );
        let v = serde_json::to_value(&t).unwrap();
        assert_eq!(
            v["shortfall"]["shortfall_m"].as_f64(),
            Some(short.shortfall_m)
        );
    }
    // The same rig with the seed's friction arrives and marks.
    let t = run(&scene("seed-arc-145.ron"), 1);
    assert!(t.shortfall.is_none());
    assert!(
        t.located.iter().filter(|p| p.seed).count() == 2,
        "{:?}",
        t.detail
    );
}

/// The hang the lead found: on this drawn scene the arm rests at the first placement within
/// the tolerance while the speed measured from the encoders spikes with each heartbeat; the
/// move was judged afresh every frame, `settled` flickered, `beatslide`'s mark never saw the
/// unbroken rest it waits for, and the trial ran into the simulated time limit with nothing
/// marked. The move's first verdict now stands: both marks are made within seconds.
#[test]
fn a_flickering_arrival_still_marks() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/scenes/smooth-random-1008.ron"
    );
    let s = crate::scene::load(path, None).expect("the fixture loads");
    let t = run_trial(&s, &sim_config(), "beatslide", 1008).expect("the trial runs");
    assert_ne!(t.end_reason, "timeout", "{:?}", t.detail);
    let seeds: Vec<f64> = t.located.iter().filter(|p| p.seed).map(|p| p.t_s).collect();
    assert_eq!(seeds.len(), 2, "{} {:?}", t.end_reason, t.detail);
    // Bounded in simulated time, not wall time: two placements and two marks.
    assert!(seeds[1] < 60.0, "second mark at {} s", seeds[1]);
}

/// The rod's deflection read from the arm's torques (control's `kinematics::rod_load`)
/// against the simulator's own rod, which shares only the beam formula: after the robot
/// places the sensor, friction holds the tip millimetres from where a straight rod would put
/// it, and the joint torques beyond the arm's gravity say where. Measured on the
/// seed's rig; nothing in the estimate is fitted. What is left is mostly the joints' Coulomb
/// friction, which holds part of the load the motors would otherwise show.
#[test]
fn the_arm_torques_say_where_the_compliant_rod_left_the_sensor() {
    use control::pd::gravity::{GravityModel, PhantomGravity};
    for name in ["seed-arc-145.ron", "seed-arc-220.ron", "seed-s-curve.ron"] {
        let s = scene(name);
        let config = sim_config();
        let mut trial =
            Lockstep::new(&s, &config, "beatslide", 1, &Calibrated::default()).expect("builds");
        trial.bench.set_enabled(true);
        trial.pd.reset();
        trial.hold_here().expect("holds");
        for (i, p) in s.placements.iter().enumerate() {
            assert!(trial.place(i, *p, s.placed_by).is_ok(), "{name}: placed");
            for _ in 0..300 {
                assert!(trial.servo().is_ok());
            }
            let mech = trial.bench.rod_mechanics().expect("a compliant rod");
            let q = trial.bench.read_joints().position_rad;
            let tau = trial.bench.commanded_torque_nm();
            let g = PhantomGravity::new(&config.robot.link_masses).torque_nm(&q);
            let rod_tau = [-(tau[0] - g[0]), -(tau[1] - g[1]), -(tau[2] - g[2])];
            let (loaded, load) = trial
                .model
                .sensor_under_load(&q, &rod_tau, &mech, config.robot.link_masses.gravity_m_s2)
                .expect("a pose in range");
            // The composed reading the runner and the daemon feed the tracker is the same.
            let felt = trial
                .model
                .sensor_felt(&q, &tau, &g, &mech, config.robot.link_masses.gravity_m_s2)
                .expect("a pose in range");
            assert!((felt.x_m - loaded.x).abs() < 1e-12 && (felt.z_m - loaded.z).abs() < 1e-12);
            let rigid = trial.model.surface_point(&q).expect("a pose in range");
            let truth = trial.bench.truth();
            let off = |x: f64, z: f64| (x - truth.sensor.x_m).hypot(z - truth.sensor.z_m);
            let rigid_off = off(rigid.x_m, rigid.z_m);
            let loaded_off = off(loaded.x, loaded.z);
            assert!(rigid_off > 2e-3, "{name} placement {i}: rigid {rigid_off}");
            assert!(
                loaded_off < 0.2 * rigid_off && loaded_off < 1e-3,
                "{name} placement {i}: rigid {rigid_off} m off, loaded {loaded_off} m off"
            );
            let friction = (load.x - truth.friction_n[0]).hypot(load.z - truth.friction_n[1]);
            assert!(
                friction < 0.06,
                "{name} placement {i}: friction read {friction} N off"
            );
            assert!(
                (load.y - truth.normal_n).abs() < 0.2,
                "{load:?} vs {}",
                truth.normal_n
            );
        }
    }
}

/// A dead element (reading only noise) near the array's middle, told to `beatslide` as one
/// to skip (the tactile calibration's mark, `sensor.skip_elements`) against trusted as a
/// live element reading no pulse. Seeds 1-7 measured: SD 0.79 mm trusted against 0.25 mm
/// skipped (the shipped arc without the fault: 0.26 mm).
#[test]
fn skipping_a_dead_element_keeps_the_fixes_on_the_artery() {
    let mut s = scene("seed-arc-145.ron");
    s.faults = Some(crate::scene::FaultSpec {
        dead_elements: vec![4],
        ..Default::default()
    });
    let trusting = sim_config();
    let mut skipping = sim_config();
    skipping.sensor.skip_elements =
        control::sensor::ElementMask::try_from(vec![4]).expect("an element");
    let pooled = |config: &config::Config| {
        let mut errors = Vec::new();
        let mut false_points = 0;
        for seed in 1..=4 {
            let t = run_trial(&s, config, "beatslide", seed).expect("the trial runs");
            assert!(t.completed, "seed {seed}: {:?}", t.end_reason);
            false_points += t.false_points;
            errors.extend(
                t.located
                    .iter()
                    .filter(|p| !p.seed)
                    .map(|p| p.lateral_error_m),
            );
        }
        let n = errors.len() as f64;
        let mean = errors.iter().sum::<f64>() / n;
        let sd = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n).sqrt();
        (sd, false_points)
    };
    let (trusted_sd, _) = pooled(&trusting);
    let (skipped_sd, skipped_false) = pooled(&skipping);
    assert!(skipped_sd < 0.4e-3, "skipped: SD {skipped_sd}");
    assert_eq!(skipped_false, 0);
    // Trusting the dead element cost more before the rod's deflection across the motion was
    // read from the load (SD 0.79 mm then, 0.28 now on these seeds): skipping it must
    // still do no worse.
    assert!(
        skipped_sd <= trusted_sd,
        "skipped SD {skipped_sd} against trusted {trusted_sd}"
    );
}

/// The seed points on the seed's arc, marked where friction left the rod's tip 3-5 mm off
/// the rigid map: with the config's `rod`, `beatslide` reports each where the arm's load
/// puts it; without, where its own lag model does. Seeds 1-4 measured: RMS lateral error
/// 0.20 mm against 1.05 mm.
#[test]
fn the_seed_points_are_placed_where_the_arm_load_puts_the_sensor() {
    let s = scene("seed-arc-145.ron");
    let with = sim_config();
    assert!(
        with.rod.is_some(),
        "the shipped sim config describes its rod"
    );
    let mut without = sim_config();
    without.rod = None;
    let seed_rms = |config: &config::Config| {
        let mut sq = Vec::new();
        for seed in 1..=4 {
            let t = run_trial(&s, config, "beatslide", seed).expect("the trial runs");
            assert!(t.completed, "seed {seed}: {:?}", t.end_reason);
            assert_eq!(t.false_points, 0, "seed {seed}");
            sq.extend(
                t.located
                    .iter()
                    .filter(|p| p.seed)
                    .map(|p| p.lateral_error_m.powi(2)),
            );
        }
        (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
    };
    let (felt, believed) = (seed_rms(&with), seed_rms(&without));
    assert!(
        felt < 0.5e-3 && felt < 0.4 * believed,
        "seed points RMS {felt} m with the rod's reading, {believed} m without"
    );
}
