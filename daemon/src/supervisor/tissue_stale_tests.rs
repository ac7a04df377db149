use super::*;
use control::frames::TissuePlacement;

const PIVOT: [f64; 3] = [0.0, -0.09, 0.055];

fn placement() -> TissuePlacement {
    TissuePlacement {
        origin_in_base_m: [0.0, -0.3745, 0.055],
        yaw_rad: 0.0,
    }
}

/// A tissue frame measured at 06:00 through `PIVOT` and a zero encoder offset (`None`:
/// a record from before it named them).
fn tissue(named: bool) -> TissueRecord {
    TissueRecord {
        measured_utc: "2026-11-28T06-00-00Z".into(),
        surface_in_base_m: vec![[0.0; 3]; 3],
        course_in_base_m: None,
        course_lateral_m: 0.0,
        prior: placement(),
        placement: placement(),
        tilt_rad: 0.0,
        pivot_in_base_m: named.then_some(PIVOT),
        joint_zero_rad: named.then_some([0.0; 3]),
        rms_residual_m: 0.0,
        max_residual_m: 0.0,
        checks: vec![],
        passed: true,
    }
}

fn pivot_record(at: &str, pivot_in_base_m: [f64; 3]) -> PivotRecord {
    PivotRecord {
        measured_utc: at.into(),
        touched_in_tissue_m: vec![],
        placement: placement(),
        prior_pivot_in_base_m: PIVOT,
        pivot_in_base_m,
        offset_m: [0.0, 0.0],
        standard_error_m: [0.0, 0.0],
        plate_height_m: 0.0,
        rms_residual_m: 0.0,
        max_residual_m: 0.0,
        checks: vec![],
        passed: true,
    }
}

fn joints_record(at: &str, zero: [f64; 3]) -> JointsRecord {
    JointsRecord {
        measured_utc: at.into(),
        reset_pose_rad: [0.0; 3],
        read_rad: zero.map(|z| -z),
        zero_offset_rad: zero,
        stops: vec![],
        checks: vec![],
        passed: true,
        stops_measured_utc: None,
        stop_checks: vec![],
    }
}

fn now<'a>(
    pivot_in_base_m: [f64; 3],
    zero: [f64; 3],
    pivot: Option<&'a PivotRecord>,
    joints: Option<&'a JointsRecord>,
) -> InUse<'a> {
    InUse {
        pivot_in_base_m: Some(pivot_in_base_m),
        joint_zero_rad: zero,
        pivot,
        joints,
    }
}

#[test]
fn a_frame_measured_through_the_pivot_and_zero_in_use_is_true() {
    assert_eq!(
        tissue_stale(&tissue(true), &now(PIVOT, [0.0; 3], None, None)),
        None
    );
    // Within the tolerances: a tenth of a millimetre, a tenth of a milliradian.
    let near = [PIVOT[0] + 1e-4, PIVOT[1], PIVOT[2]];
    assert_eq!(
        tissue_stale(&tissue(true), &now(near, [1e-4, 0.0, 0.0], None, None)),
        None
    );
}

#[test]
fn a_pivot_moved_since_the_frame_makes_it_stale_saying_how_far_and_what_to_do() {
    let moved = [PIVOT[0], PIVOT[1], PIVOT[2] + 0.005];
    let p = pivot_record("2026-11-28T07-00-00Z", moved);
    let why = tissue_stale(&tissue(true), &now(moved, [0.0; 3], Some(&p), None)).expect("stale");
    assert!(why.contains("5.00 mm"), "{why}");
    assert!(why.contains("pulsetrack calibrate tissue"), "{why}");
    // Measured again through the new pivot: true again, whatever the records' times.
    let mut again = tissue(true);
    again.pivot_in_base_m = Some(moved);
    assert_eq!(
        tissue_stale(&again, &now(moved, [0.0; 3], Some(&p), None)),
        None
    );
}

#[test]
fn a_homing_since_the_frame_makes_it_stale() {
    let zero = [0.0, 0.0349, 0.0];
    let j = joints_record("2026-11-28T07-00-00Z", zero);
    let why = tissue_stale(&tissue(true), &now(PIVOT, zero, None, Some(&j))).expect("stale");
    assert!(why.contains("2.000 deg"), "{why}");
    let moved = [PIVOT[0] + 0.003, PIVOT[1], PIVOT[2]];
    let both = tissue_stale(&tissue(true), &now(moved, zero, None, Some(&j))).expect("stale");
    assert!(
        both.contains("pivot") && both.contains("encoder zero"),
        "{both}"
    );
}

#[test]
fn an_old_record_is_stale_only_after_a_later_calibration() {
    let old = tissue(false);
    let moved = [PIVOT[0], PIVOT[1], PIVOT[2] + 0.005];
    assert_eq!(tissue_stale(&old, &now(moved, [0.0; 3], None, None)), None);
    let before = pivot_record("2026-11-28T05-00-00Z", moved);
    assert_eq!(
        tissue_stale(&old, &now(moved, [0.0; 3], Some(&before), None)),
        None
    );
    let after = pivot_record("2026-11-28T07-00-00Z", moved);
    let why = tissue_stale(&old, &now(moved, [0.0; 3], Some(&after), None)).expect("stale");
    assert!(why.contains("2026-11-28T07-00-00Z"), "{why}");
    let homed = joints_record("2026-11-28T08-00-00Z", [0.0; 3]);
    let why = tissue_stale(&old, &now(PIVOT, [0.0; 3], None, Some(&homed))).expect("stale");
    assert!(why.contains("homing of 2026-11-28T08-00-00Z"), "{why}");
}
