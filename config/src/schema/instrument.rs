//! The optional `instrument` section: what the gimbal carries and how much of its weight
//! should press the sensor into the tissue. The rest is gravity-compensated by the
//! controller (control's `pd::gravity::Instrument`). Absent: nothing beyond the arm's own
//! bodies is compensated, as before the section existed.

use control::pd::gravity::{ArmGravity, GravityModel, Instrument, PhantomGravity};
use nalgebra::Point3;

use super::{ControlSection, RobotSection};
use crate::validate::Validator;

/// Heavier than this is a typo (grams for kilograms), not a Phantom instrument, kg.
const MAX_MASS_KG: f64 = 5.0;

/// Share of each joint's torque limit the compensation may take at the patch centre; the
/// rest is the PD's, to move the arm.
const MAX_TORQUE_SHARE: f64 = 0.5;

/// Checks `instrument` under the field it sits at, against the robot it hangs on.
pub fn validate(i: &Instrument, robot: &RobotSection, control: &ControlSection, v: &mut Validator) {
    let before = v.problem_count();
    v.in_range("mass_kg", i.mass_kg, 0.0, MAX_MASS_KG);
    v.non_negative("contact_load_n", i.contact_load_n);
    if v.problem_count() > before {
        return;
    }
    let g = robot.link_masses.gravity_m_s2;
    let weight_n = i.mass_kg * g;
    if i.contact_load_n > weight_n {
        v.problem(
            "contact_load_n",
            format!(
                "{} N is more than the instrument's weight, {weight_n:.3} N ({} kg): the drive \
                 only holds weight up, it does not press the instrument in (is it in N?)",
                i.contact_load_n, i.mass_kg
            ),
        );
        return;
    }
    // The Phantom's motors are small: holding the excess must leave the PD room to move.
    let (Ok(arm), true) = (robot.arm_model(), g.is_finite()) else {
        return; // the robot section reports its own problems
    };
    let centre = Point3::new(0.0, control.motion.contact_height_m, 0.0);
    let Ok(q) = arm.joints_for_sensor(&centre) else {
        return;
    };
    let with = ArmGravity::new(&robot.link_masses, &robot.phantom, &robot.pivot, Some(i));
    let bare = PhantomGravity::new(&robot.link_masses);
    let (a, b) = (with.torque_nm(&q), bare.torque_nm(&q));
    let limits = control.pd.torque_limit_nm;
    for j in 0..3 {
        let tau = (a[j] - b[j]).abs();
        if tau > MAX_TORQUE_SHARE * limits[j] {
            v.problem(
                "mass_kg",
                format!(
                    "holding the {:.2} N the instrument weighs beyond its contact load takes \
                     {tau:.3} N·m at joint {} over the patch centre, more than half its torque \
                     limit of {} N·m (control.pd.torque_limit_nm) that the PD needs to move \
                     the arm: raise contact_load_n or lighten the instrument",
                    with.instrument_excess_n(),
                    j + 1,
                    limits[j]
                ),
            );
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::shipped::SIM_CONFIG;
    use crate::{Config, load_str};

    use crate::schema::shipped_with as with_section;

    #[test]
    fn absent_is_none_and_old_configs_load() {
        let (name, text) = SIM_CONFIG;
        let c = load_str::<Config>(name, text).expect("loads");
        assert_eq!(c.instrument, None);
        let c = load_str::<Config>(
            "c.ron",
            &with_section("instrument: (mass_kg: 0.6, contact_load_n: 5.2),"),
        )
        .expect("loads");
        let i = c.instrument.expect("present");
        assert_eq!((i.mass_kg, i.contact_load_n), (0.6, 5.2));
    }

    #[test]
    fn bad_instruments_are_refused_by_field() {
        for (section, field, says) in [
            (
                "instrument: (mass_kg: -0.1, contact_load_n: 0.0),",
                "instrument.mass_kg",
                "between",
            ),
            (
                "instrument: (mass_kg: 300.0, contact_load_n: 0.0),",
                "instrument.mass_kg",
                "between",
            ),
            (
                "instrument: (mass_kg: 0.3, contact_load_n: -1.0),",
                "instrument.contact_load_n",
                "negative",
            ),
            (
                "instrument: (mass_kg: 0.3, contact_load_n: 30.0),",
                "instrument.contact_load_n",
                "more than the instrument's weight",
            ),
            (
                "instrument: (mass_kg: 0.6, contact_load_n: 2.943),",
                "instrument.mass_kg",
                "torque limit",
            ),
            (
                "instrument: (mass_kg: 0.3, contact_load_n: inf),",
                "instrument.contact_load_n",
                "finite",
            ),
        ] {
            let e = load_str::<Config>("c.ron", &with_section(section)).unwrap_err();
            assert_eq!(e.problems.len(), 1, "{section}: {e}");
            assert_eq!(e.problems[0].field, field, "{section}: {e}");
            assert!(e.problems[0].message.contains(says), "{section}: {e}");
            assert!(e.problems[0].line.is_some(), "{section}: {e}");
        }
        // A missing field and an unknown one are named too.
        let e =
            load_str::<Config>("c.ron", &with_section("instrument: (mass_kg: 0.3),")).unwrap_err();
        assert!(e.to_string().contains("contact_load_n"), "{e}");
        let e = load_str::<Config>(
            "c.ron",
            &with_section("instrument: (mass_kg: 0.3, contact_load_n: 1.0, mass_g: 3.0),"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("mass_g"), "{e}");
    }
}
