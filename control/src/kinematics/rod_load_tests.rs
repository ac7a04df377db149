use nalgebra::{Point3, Vector3};
use proptest::prelude::*;

use super::*;
use crate::kinematics::arm::tests::arm;
use crate::kinematics::phantom;

const G: f64 = 9.81;

/// The seed's rod: 4.5 mm steel, a 1000 N/m incision, 0.3 kg 3 cm above the tip.
fn seed_rod() -> RodMechanics {
    let d: f64 = 0.0045;
    RodMechanics {
        bending_stiffness_nm2: 200.0e9 * std::f64::consts::PI * d.powi(4) / 64.0,
        pivot_stiffness_n_per_m: 1000.0,
        rod_mass_kg: 0.062,
        tip_mass_kg: 0.3,
        tip_mass_height_m: 0.03,
    }
}

fn rod(axis: Vector3<f64>, a: f64) -> RodAt {
    RodAt {
        axis: axis.normalize(),
        gimbal_to_pivot_m: a,
        length_m: 0.495,
    }
}

/// The force the rod pushes on the gimbal, from the rod's own equilibrium written out
/// independently: the pivot takes whatever across-rod force makes the moments about the
/// gimbal vanish, and the gimbal takes the rest of every force.
fn gimbal_force_by_equilibrium(m: &RodMechanics, r: &RodAt, tip: Vector3<f64>) -> Vector3<f64> {
    let u = r.axis;
    let down = Vector3::new(0.0, -G, 0.0);
    let loads = [
        (tip, r.length_m),
        (down * m.rod_mass_kg, r.length_m / 2.0),
        (down * m.tip_mass_kg, r.length_m - m.tip_mass_height_m),
    ];
    // Moments about G: Σ s (u × F) + a (u × P) = 0, P across the rod.
    let mut moment = Vector3::zeros();
    for (f, s) in loads {
        moment += (u * s).cross(&f);
    }
    // With P ⟂ u, u × (u × P) = −P, so crossing the balance with u gives P = (u × M) / a.
    let p = u.cross(&moment) / r.gimbal_to_pivot_m;
    // Sum of forces on the rod is zero: the gimbal pushes back −(ΣF + P); the rod pushes the
    // gimbal with ΣF + P.
    let mut total = p;
    for (f, _) in loads {
        total += f;
    }
    // Check the moment balance actually holds with the P found.
    let residual = moment + (u * r.gimbal_to_pivot_m).cross(&p);
    assert!(
        residual.norm() < 1e-9 * (1.0 + moment.norm()),
        "{residual:?}"
    );
    total
}

#[test]
fn a_known_tip_load_is_read_back_from_the_gimbal() {
    let m = seed_rod();
    let r = rod(Vector3::new(0.3, -1.0, 0.2), 0.195);
    let tip = Vector3::new(0.4, 3.5, -0.25);
    let f_g = gimbal_force_by_equilibrium(&m, &r, tip);
    let back = m.tip_load_n(&r, &f_g, G).unwrap();
    assert!((back - tip).norm() < 1e-9, "{back:?} vs {tip:?}");
}

#[test]
fn the_compliance_is_the_beam_and_the_incision() {
    let m = seed_rod();
    let r = rod(Vector3::new(0.0, -1.0, 0.0), 0.195);
    let d = 0.495 - 0.195;
    let beam = d * d * 0.495 / (3.0 * m.bending_stiffness_nm2);
    let incision = (0.495f64 / 0.195).powi(2) / 1000.0;
    assert!((m.compliance_m_per_n(&r) - (beam + incision)).abs() < 1e-15);
    // About 10 mm/N on the seed's rig (docs: 11 mm/N × 0.4 N ≈ the 4.5 mm lag).
    assert!((0.009..0.012).contains(&m.compliance_m_per_n(&r)));
}

#[test]
fn loads_along_the_rod_do_not_deflect_it() {
    let m = RodMechanics {
        tip_mass_kg: 0.0,
        ..seed_rod()
    };
    let r = rod(Vector3::new(0.0, -1.0, 0.0), 0.2);
    let d = m.tip_deflection_m(&r, &Vector3::new(0.0, 3.0, 0.0), G);
    assert!(d.norm() < 1e-15, "{d:?}");
    // A sideways push moves the tip sideways by c·F, with the push.
    let d = m.tip_deflection_m(&r, &Vector3::new(0.5, 0.0, 0.0), G);
    assert!((d.x - 0.5 * m.compliance_m_per_n(&r)).abs() < 1e-15);
    assert!(d.y.abs() < 1e-15 && d.z.abs() < 1e-15);
}

#[test]
fn the_weight_on_a_leaning_rod_bends_its_tip_down_and_under() {
    // Rod leaning with its tip toward +x: the weight's part across the rod points down and
    // toward −x (under the rod), so with no tissue load the tip bends back toward the
    // vertical below the pivot; a contact load larger than the weight pushes it outward.
    let m = seed_rod();
    let r = rod(Vector3::new(0.4, -1.0, 0.0), 0.2);
    let d = m.tip_deflection_m(&r, &Vector3::zeros(), G);
    assert!(d.x < 0.0 && d.y < 0.0, "{d:?}");
    let pushed = m.tip_deflection_m(&r, &Vector3::new(0.0, 2.0 * m.tip_mass_kg * G, 0.0), G);
    assert!(pushed.x > 0.0, "{pushed:?}");
    assert!(d.dot(&r.axis).abs() < 1e-15);
}

#[test]
fn the_lever_at_its_fulcrum_and_bad_mechanics_are_refused() {
    let m = seed_rod();
    let at_fulcrum = RodAt {
        axis: Vector3::new(0.0, -1.0, 0.0),
        gimbal_to_pivot_m: 0.495,
        length_m: 0.495,
    };
    assert_eq!(
        m.tip_load_n(&at_fulcrum, &Vector3::new(1.0, 0.0, 0.0), G),
        Err(RodLoadError::NoLever)
    );
    for (bad, field) in [
        (
            RodMechanics {
                bending_stiffness_nm2: 0.0,
                ..m
            },
            "bending_stiffness_nm2",
        ),
        (
            RodMechanics {
                pivot_stiffness_n_per_m: f64::NAN,
                ..m
            },
            "pivot_stiffness_n_per_m",
        ),
        (
            RodMechanics {
                tip_mass_kg: -0.1,
                ..m
            },
            "tip_mass_kg",
        ),
    ] {
        let e = bad.check().unwrap_err();
        assert!(e.to_string().contains(field), "{e}");
    }
    assert_eq!(m.check(), Ok(()));
    // A non-finite gimbal force is an error, not a NaN deflection.
    let r = rod(Vector3::new(0.0, -1.0, 0.0), 0.2);
    assert!(
        m.tip_load_n(&r, &Vector3::new(f64::INFINITY, 0.0, 0.0), G)
            .is_err()
    );
}

#[test]
fn the_arm_reads_the_tip_load_through_its_joint_torques() {
    let arm = arm();
    let m = seed_rod();
    let q = arm
        .joints_for_sensor(&Point3::new(-0.06, 0.0, 0.03))
        .unwrap();
    let r = arm.rod_at(&q).unwrap();
    // The tissue's push (base frame): friction to −x, +z, and the normal load up.
    let tip = Vector3::new(-0.3, 3.4, 0.2);
    let f_g = gimbal_force_by_equilibrium(&m, &r, tip);
    let j = phantom::jacobian(arm.phantom(), &q).unwrap();
    let tau = j.transpose() * f_g;
    let (sensor, load) = arm
        .sensor_under_load(&q, &[tau.x, tau.y, tau.z], &m, G)
        .unwrap();
    let rigid = arm.sensor_from_joints(&q).unwrap();
    // The default tissue frame is the base frame shifted (no yaw): vectors read the same.
    assert!((load - tip).norm() < 1e-9, "{load:?}");
    let expected = m.tip_deflection_m(&r, &tip, G);
    assert!(((sensor - rigid) - expected).norm() < 1e-12);
    // Friction toward −x drags the tip that way by millimetres.
    assert!(expected.x < -1e-3, "{expected:?}");
}

proptest! {
    #[test]
    fn any_tip_load_round_trips(
        ax in -0.6f64..0.6, az in -0.6f64..0.6, a in 0.1f64..0.4,
        fx in -2.0f64..2.0, fy in -5.0f64..5.0, fz in -2.0f64..2.0,
    ) {
        let m = seed_rod();
        let r = rod(Vector3::new(ax, -1.0, az), a);
        let tip = Vector3::new(fx, fy, fz);
        let back = m.tip_load_n(&r, &gimbal_force_by_equilibrium(&m, &r, tip), G).unwrap();
        prop_assert!((back - tip).norm() < 1e-8 * (1.0 + tip.norm()), "{:?} vs {:?}", back, tip);
        // The deflection is always across the rod.
        let d = m.tip_deflection_m(&r, &tip, G);
        prop_assert!(d.dot(&r.axis).abs() < 1e-12);
    }
}
