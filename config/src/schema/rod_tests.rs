//! The `rod` section: absent in old configs and on the lab's until measured, every number
//! checked by its field.

use crate::load_str;
use crate::schema::Config;
use crate::shipped::{LAB_CONFIG, SIM_CONFIG};

/// The lab config (no `rod` yet) with one.
fn lab_with_rod(rod: &str) -> String {
    let (_, text) = LAB_CONFIG;
    let at = text
        .rfind(')')
        .expect("the lab config ends with a parenthesis");
    format!("{}    rod: {rod},\n)", &text[..at])
}

#[test]
fn the_sim_config_describes_its_rod_and_the_lab_config_waits_for_a_measured_one() {
    let (name, text) = SIM_CONFIG;
    let rod = load_str::<Config>(name, text).expect("loads").rod;
    let rod = rod.expect("the sim config's rod");
    assert_eq!(rod.bending_stiffness_nm2, 4.03);
    assert_eq!(rod.pivot_stiffness_n_per_m, 1000.0);
    let (name, text) = LAB_CONFIG;
    assert_eq!(load_str::<Config>(name, text).expect("loads").rod, None);
    // The masses may be left out (a bare shaft).
    let c = load_str::<Config>(
        "c.ron",
        &lab_with_rod("(bending_stiffness_nm2: 4.0, pivot_stiffness_n_per_m: 800.0)"),
    )
    .expect("loads");
    assert_eq!(c.rod.map(|r| r.tip_mass_kg), Some(0.0));
}

#[test]
fn a_rod_that_cannot_bend_or_weighs_less_than_nothing_is_refused_by_field() {
    for (rod, field, says) in [
        (
            "(bending_stiffness_nm2: 0.0, pivot_stiffness_n_per_m: 800.0)",
            "rod.bending_stiffness_nm2",
            "must be positive",
        ),
        (
            "(bending_stiffness_nm2: 4.0, pivot_stiffness_n_per_m: -1.0)",
            "rod.pivot_stiffness_n_per_m",
            "must be positive",
        ),
        (
            "(bending_stiffness_nm2: 4.0, pivot_stiffness_n_per_m: 800.0, tip_mass_kg: -0.3)",
            "rod.tip_mass_kg",
            "must not be negative",
        ),
        (
            "(bending_stiffness_nm2: inf, pivot_stiffness_n_per_m: 800.0)",
            "rod.bending_stiffness_nm2",
            "",
        ),
    ] {
        let e = load_str::<Config>("c.ron", &lab_with_rod(rod)).unwrap_err();
        assert_eq!(e.problems.len(), 1, "{rod}: {e}");
        assert_eq!(e.problems[0].field, field, "{rod}: {e}");
        assert!(e.to_string().contains(says), "{rod}: {e}");
    }
    // A misspelt field is named, not ignored.
    let e = load_str::<Config>(
        "c.ron",
        &lab_with_rod("(bending_stiffness: 4.0, pivot_stiffness_n_per_m: 800.0)"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("bending_stiffness"), "{e}");
}
