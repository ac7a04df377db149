use super::*;

const DT: f64 = 1e-3;

fn state(position_rad: Joints, velocity_rad_s: Joints) -> JointState {
    JointState {
        t_s: 0.0,
        position_rad,
        velocity_rad_s,
    }
}

fn unlimited_rate() -> PdParams {
    PdParams {
        torque_rate_limit_nm_per_s: [1e9; 3],
        ..PdParams::default()
    }
}

#[test]
fn a_known_step_gives_the_known_torque() {
    let p = unlimited_rate();
    let mut pd = PdController::new(p).unwrap();
    let sp = JointSetpoint {
        position_rad: [0.004, -0.006, 0.002],
        velocity_rad_s: [0.1, 0.0, -0.2],
    };
    let st = state([0.0, 0.0, 0.001], [0.0, 0.05, 0.0]);
    let g = [0.0, 0.01, -0.02];
    let tau = pd.step(&sp, &st, &g, DT).unwrap();
    // Hand arithmetic with the default gains kp (25, 20, 20), kd (0.5, 0.4, 0.3).
    let expected = [
        25.0 * 0.004 + 0.5 * 0.1,
        20.0 * -0.006 + 0.4 * -0.05 + 0.01,
        20.0 * 0.001 + 0.3 * -0.2 - 0.02,
    ];
    assert_eq!(p.kp_nm_per_rad, [25.0, 20.0, 20.0]);
    assert_eq!(p.kd_nm_s_per_rad, [0.5, 0.4, 0.3]);
    for (j, want) in expected.iter().enumerate() {
        assert!((tau.torque_nm[j] - want).abs() < 1e-15, "joint {j}");
    }
    assert_eq!(pd.last_torque(), tau);
}

#[test]
fn torque_is_clamped_to_the_limit() {
    let p = unlimited_rate();
    let mut pd = PdController::new(p).unwrap();
    // 0.07 rad at 25 N·m/rad wants 1.75 N·m; the limits are 0.38 / 0.32 / 0.32.
    let sp = JointSetpoint::at_rest([0.07, -0.07, 0.07]);
    let tau = pd
        .step(&sp, &state([0.0; 3], [0.0; 3]), &[0.0; 3], DT)
        .unwrap();
    assert_eq!(tau.torque_nm, [0.38, -0.32, 0.32]);
    // Gravity cannot push the command past the limit either.
    let tau = pd
        .step(&sp, &state([0.0; 3], [0.0; 3]), &[5.0, -5.0, 5.0], DT)
        .unwrap();
    assert_eq!(tau.torque_nm, [0.38, -0.32, 0.32]);
}

#[test]
fn torque_changes_no_faster_than_the_rate_limit() {
    let p = PdParams::default();
    let mut pd = PdController::new(p).unwrap();
    let sp = JointSetpoint::at_rest([0.01, 0.0, 0.0]);
    let st = state([0.0; 3], [0.0; 3]);
    // Wants 0.25 N·m on joint 0; 50 N·m/s allows 0.05 N·m per millisecond.
    let mut seen = Vec::new();
    for _ in 0..7 {
        seen.push(pd.step(&sp, &st, &[0.0; 3], DT).unwrap().torque_nm[0]);
    }
    let expected = [0.05, 0.10, 0.15, 0.20, 0.25, 0.25, 0.25];
    for (got, want) in seen.iter().zip(expected) {
        assert!((got - want).abs() < 1e-12, "{seen:?}");
    }
    // A longer step allows a proportionally larger change, and reversal is limited too.
    let back = JointSetpoint::at_rest([-0.01, 0.0, 0.0]);
    let tau = pd.step(&back, &st, &[0.0; 3], 2.0 * DT).unwrap();
    assert!((tau.torque_nm[0] - 0.15).abs() < 1e-12);
    // Reset: the ramp starts again from zero.
    pd.reset();
    assert_eq!(pd.last_torque(), JointTorques::ZERO);
    let tau = pd.step(&sp, &st, &[0.0; 3], DT).unwrap();
    assert!((tau.torque_nm[0] - 0.05).abs() < 1e-12);
}

#[test]
fn tracking_error_trips() {
    let p = PdParams::default();
    let mut pd = PdController::new(p).unwrap();
    let limit = p.max_tracking_error_rad[1];
    let st = state([0.2, 0.3, 0.4], [0.0; 3]);
    let inside = JointSetpoint::at_rest([0.2, 0.3 - limit * 0.999, 0.4]);
    let before = pd.step(&inside, &st, &[0.0; 3], DT).unwrap();
    let beyond = JointSetpoint::at_rest([0.2, 0.3 - limit * 1.001, 0.4]);
    match pd.step(&beyond, &st, &[0.0; 3], DT) {
        Err(PdFault::TrackingError {
            joint,
            error_rad,
            limit_rad,
        }) => {
            assert_eq!(joint, 1);
            assert!((error_rad + limit * 1.001).abs() < 1e-12);
            assert_eq!(limit_rad, limit);
        }
        other => panic!("{other:?}"),
    }
    // The fault leaves the last command as it was.
    assert_eq!(pd.last_torque(), before);
}

#[test]
fn non_finite_inputs_and_bad_time_steps_are_refused() {
    let mut pd = PdController::new(PdParams::default()).unwrap();
    let good_sp = JointSetpoint::at_rest([0.01; 3]);
    let good_st = state([0.0; 3], [0.0; 3]);
    pd.step(&good_sp, &good_st, &[0.0; 3], DT).unwrap();
    let before = pd.last_torque();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut sp = good_sp;
        sp.position_rad[2] = bad;
        let mut sv = good_sp;
        sv.velocity_rad_s[0] = bad;
        let mut st = good_st;
        st.position_rad[1] = bad;
        let mut sw = good_st;
        sw.velocity_rad_s[2] = bad;
        let cases = [
            (pd.step(&sp, &good_st, &[0.0; 3], DT), "setpoint position"),
            (pd.step(&sv, &good_st, &[0.0; 3], DT), "setpoint velocity"),
            (pd.step(&good_sp, &st, &[0.0; 3], DT), "measured position"),
            (pd.step(&good_sp, &sw, &[0.0; 3], DT), "measured velocity"),
            (
                pd.step(&good_sp, &good_st, &[0.0, bad, 0.0], DT),
                "gravity torque",
            ),
        ];
        for (result, what) in cases {
            assert_eq!(result, Err(PdFault::NonFinite { what }));
        }
    }
    for dt in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            pd.step(&good_sp, &good_st, &[0.0; 3], dt),
            Err(PdFault::InvalidTimeStep { .. })
        ));
    }
    // Gains so large that the P and D terms overflow to opposite infinities.
    let huge = PdParams {
        kp_nm_per_rad: [1e308; 3],
        kd_nm_s_per_rad: [1e308; 3],
        max_tracking_error_rad: [10.0; 3],
        ..PdParams::default()
    };
    let mut wild = PdController::new(huge).unwrap();
    let sp = JointSetpoint {
        position_rad: [5.0; 3],
        velocity_rad_s: [-5.0; 3],
    };
    assert_eq!(
        wild.step(&sp, &good_st, &[0.0; 3], DT),
        Err(PdFault::NonFinite {
            what: "commanded torque"
        })
    );
    assert_eq!(pd.last_torque(), before);
}

#[test]
fn invalid_settings_are_refused() {
    let d = PdParams::default();
    let cases = [
        PdParams {
            kp_nm_per_rad: [1.0, -1.0, 1.0],
            ..d
        },
        PdParams {
            kd_nm_s_per_rad: [f64::NAN, 0.1, 0.1],
            ..d
        },
        PdParams {
            torque_limit_nm: [0.3, 0.0, 0.3],
            ..d
        },
        PdParams {
            torque_rate_limit_nm_per_s: [1.0, 1.0, f64::INFINITY],
            ..d
        },
        PdParams {
            max_tracking_error_rad: [0.0; 3],
            ..d
        },
    ];
    for p in cases {
        assert!(matches!(
            PdController::new(p),
            Err(PdFault::InvalidParams { .. })
        ));
    }
}

/// One decoupled joint per axis: inertia, an optional constant gravity load, ZOH torque.
struct Plant {
    inertia: Joints,
    load_nm: Joints,
    q: Joints,
    v: Joints,
}

impl Plant {
    fn advance(&mut self, tau: &JointTorques, dt: f64) {
        for j in 0..3 {
            let a = (tau.torque_nm[j] - self.load_nm[j]) / self.inertia[j];
            self.q[j] += self.v[j] * dt + 0.5 * a * dt * dt;
            self.v[j] += a * dt;
        }
    }
}

/// Run the real controller (clamp and rate limit included) against the plant from rest.
fn run(
    pd: &mut PdController,
    plant: &mut Plant,
    target: Joints,
    gravity: Joints,
    backward_difference: bool,
    seconds: f64,
) -> (Joints, f64) {
    let sp = JointSetpoint::at_rest(target);
    let mut max_overshoot: f64 = 0.0;
    let mut q_prev = plant.q;
    for _ in 0..(seconds / DT).round() as usize {
        let rate = if backward_difference {
            std::array::from_fn(|j| (plant.q[j] - q_prev[j]) / DT)
        } else {
            plant.v
        };
        q_prev = plant.q;
        let tau = pd
            .step(&sp, &state(plant.q, rate), &gravity, DT)
            .expect("no fault in a healthy run");
        for (j, goal) in target.iter().enumerate() {
            assert!(tau.torque_nm[j].abs() <= pd.params().torque_limit_nm[j] + 1e-15);
            max_overshoot = max_overshoot.max((plant.q[j] - goal) * goal.signum());
        }
        plant.advance(&tau, DT);
    }
    (
        std::array::from_fn(|j| plant.q[j] - target[j]),
        max_overshoot,
    )
}

#[test]
fn saturated_steps_settle_without_limit_cycles() {
    // Steps big enough to hit the torque limit, light (bare arm) and heavy (rod and mass)
    // joints, true rate and backward-difference rate.
    let target = [0.03, -0.03, 0.03];
    for inertia in [[3.8e-3, 2.6e-3, 1.1e-3], [4e-2, 2e-2, 1.4e-2]] {
        for backward_difference in [false, true] {
            let mut pd = PdController::new(PdParams::default()).unwrap();
            let mut plant = Plant {
                inertia,
                load_nm: [0.0; 3],
                q: [0.0; 3],
                v: [0.0; 3],
            };
            let (err, overshoot) = run(
                &mut pd,
                &mut plant,
                target,
                [0.0; 3],
                backward_difference,
                3.0,
            );
            for j in 0..3 {
                assert!(
                    err[j].abs() < 1e-6,
                    "{inertia:?} bd {backward_difference}: {err:?}"
                );
                assert!(plant.v[j].abs() < 1e-5, "still moving: {:?}", plant.v);
            }
            // Lightly damped only when heavy; never wild.
            assert!(overshoot < 0.6 * 0.03, "{inertia:?}: overshoot {overshoot}");
        }
    }
}

#[test]
fn gravity_term_removes_the_steady_state_sag() {
    let masses = PhantomMasses {
        gimbal: PointMass {
            mass_kg: 0.1,
            along_upper_arm_m: 0.215,
            along_forearm_m: 0.170,
        },
        ..PhantomMasses::default()
    };
    let model = PhantomGravity::new(&masses);
    let target = [0.0, 0.5, 0.5];
    // A constant load equal to gravity at the target (the plant stays near it).
    let load = model.torque_nm(&target);
    assert!(load[1].abs() > 0.01 && load[2].abs() > 0.01);
    let inertia = [3.8e-3, 2.6e-3, 1.1e-3];
    for (gravity, expect_sag) in [([0.0; 3], true), (load, false)] {
        let mut pd = PdController::new(PdParams::default()).unwrap();
        let mut plant = Plant {
            inertia,
            load_nm: load,
            q: target,
            v: [0.0; 3],
        };
        let (err, _) = run(&mut pd, &mut plant, target, gravity, false, 2.0);
        for j in 1..3 {
            let sag = -load[j] / PdParams::default().kp_nm_per_rad[j];
            if expect_sag {
                assert!((err[j] - sag).abs() < 1e-6, "joint {j}: {err:?} vs {sag}");
            } else {
                assert!(err[j].abs() < 1e-9, "joint {j}: {err:?}");
            }
        }
    }
}
