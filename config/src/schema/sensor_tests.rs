//! The `sensor` section's skipped elements: a list of indices, checked by field.

use crate::load_str;
use crate::schema::Config;
use crate::schema::shipped_with;
use crate::shipped::SIM_CONFIG;

fn with_sensor(section: &str) -> String {
    shipped_with(&format!("sensor: {section},"))
}

#[test]
fn skipped_elements_load_as_a_list_and_default_to_none() {
    let (name, text) = SIM_CONFIG;
    let c = load_str::<Config>(name, text).expect("loads");
    assert!(c.sensor.skip_elements.is_empty());
    let c = load_str::<Config>("c.ron", &with_sensor("(skip_elements: [4, 7])")).expect("loads");
    assert!(c.sensor.skip_elements.contains(4) && c.sensor.skip_elements.contains(7));
    assert_eq!(c.sensor.skip_elements.len(), 2);
}

#[test]
fn a_missing_element_or_too_many_skipped_are_refused() {
    let e = load_str::<Config>("c.ron", &with_sensor("(skip_elements: [12])")).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("element 12 does not exist"), "{text}");
    let e =
        load_str::<Config>("c.ron", &with_sensor("(skip_elements: [0, 1, 2, 3, 4])")).unwrap_err();
    assert_eq!(e.problems.len(), 1, "{e}");
    assert_eq!(e.problems[0].field, "sensor.skip_elements", "{e}");
    assert!(e.to_string().contains("leaves 5 elements"), "{e}");
}
