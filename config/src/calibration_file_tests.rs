use super::*;
use control::calibration::{ElementCalibration, ElementStatus};

fn tactile() -> TactileRecord {
    let good = ElementCalibration {
        offset_n: 0.05,
        noise_sd_n: 0.012,
        gain: 0.9,
        gain_standard_error: 0.002,
        status: ElementStatus::Good,
    };
    let mut elements = [good; control::types::ELEMENTS];
    elements[4] = ElementCalibration {
        gain: 0.01,
        status: ElementStatus::Dead,
        ..good
    };
    TactileRecord {
        measured_utc: "2026-11-28T00-30-00Z".into(),
        no_load_frames: 500,
        loaded_frames: 500,
        calibration: TactileCalibration {
            elements,
            known_force_per_element_n: 0.2,
        },
        checks: vec![CheckRecord {
            quantity: "unusable tactile elements".into(),
            value: 1.0,
            bound: "at_most".into(),
            limit: 1.0,
            unit: String::new(),
            passed: true,
        }],
        passed: true,
    }
}

fn tissue() -> TissueRecord {
    TissueRecord {
        measured_utc: "2026-11-28T06-00-00Z".into(),
        surface_in_base_m: vec![[0.0, -0.2, 0.3], [0.05, -0.2, 0.3], [0.0, -0.2, 0.35]],
        course_in_base_m: Some([[-0.05, -0.2, 0.3], [0.05, -0.2, 0.31]]),
        course_lateral_m: 0.0,
        prior: TissuePlacement {
            origin_in_base_m: [0.0, -0.2, 0.3],
            yaw_rad: 0.0,
        },
        placement: TissuePlacement {
            origin_in_base_m: [0.0, -0.2012, 0.3],
            yaw_rad: -0.0997,
        },
        tilt_rad: 0.001,
        pivot_in_base_m: Some([0.0, 0.0, 0.0]),
        joint_zero_rad: Some([0.001, 0.0, -0.002]),
        rms_residual_m: 0.0,
        max_residual_m: 0.0,
        checks: vec![],
        passed: true,
    }
}

fn pivot() -> PivotRecord {
    PivotRecord {
        measured_utc: "2026-11-28T12-00-00Z".into(),
        touched_in_tissue_m: vec![
            [-0.08, 0.0011, 0.045],
            [0.08, 0.0012, 0.045],
            [-0.04, -0.0003, 0.01],
            [0.04, -0.0002, 0.01],
            [0.0, 0.0009, 0.04],
        ],
        placement: TissuePlacement {
            origin_in_base_m: [0.0, -0.3745, 0.055],
            yaw_rad: 0.0,
        },
        prior_pivot_in_base_m: [0.0, -0.09, 0.055],
        pivot_in_base_m: [0.0001, -0.09, 0.0599],
        offset_m: [0.0001, 0.0049],
        standard_error_m: [0.00002, 0.00003],
        plate_height_m: -0.3745,
        rms_residual_m: 0.00004,
        max_residual_m: 0.00007,
        checks: vec![],
        passed: true,
    }
}

fn joints() -> JointsRecord {
    JointsRecord {
        measured_utc: "2026-11-28T13-00-00Z".into(),
        reset_pose_rad: [0.0, 0.0, 0.0],
        read_rad: [0.0, -0.0349, 0.0],
        zero_offset_rad: [0.0, 0.0349, 0.0],
        stops: vec![StopRecord {
            joint: 1,
            side: control::calibration::Side::Upper,
            at_rad: 1.25,
            stalled: true,
            software_limit_rad: 1.2,
            margin_rad: 0.05,
        }],
        checks: vec![],
        passed: true,
        stops_measured_utc: Some("2026-11-28T13-05-00Z".into()),
        stop_checks: vec![],
    }
}

#[test]
fn a_joints_record_from_before_the_stop_sweep_still_loads() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    let mut record = joints();
    record.stops.clear();
    record.stops_measured_utc = None;
    let file = CalibrationFile {
        joints: Some(record.clone()),
        ..CalibrationFile::default()
    };
    // As the homing wrote it before the sweep: no `stops_measured_utc`, no `stop_checks`.
    let text = ron::ser::to_string_pretty(&file, ron::ser::PrettyConfig::default())
        .expect("ron")
        .replace("        stops_measured_utc: None,\n", "")
        .replace("        stop_checks: [],\n", "");
    assert!(!text.contains("stop_checks"), "{text}");
    std::fs::write(&path, text).expect("write");
    let f = load(&path).expect("loads").expect("there").value;
    assert_eq!(f.joints, Some(record));
}

#[test]
fn a_tissue_record_from_before_it_named_its_pivot_and_zero_still_loads() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    let mut record = tissue();
    record.pivot_in_base_m = None;
    record.joint_zero_rad = None;
    let file = CalibrationFile {
        tissue: Some(record.clone()),
        ..CalibrationFile::default()
    };
    let text = ron::ser::to_string_pretty(&file, ron::ser::PrettyConfig::default())
        .expect("ron")
        .replace("        pivot_in_base_m: None,\n", "")
        .replace("        joint_zero_rad: None,\n", "");
    assert!(!text.contains("joint_zero_rad"), "{text}");
    std::fs::write(&path, text).expect("write");
    let f = load(&path).expect("loads").expect("there").value;
    assert_eq!(f.tissue, Some(record));
}

#[test]
fn a_file_from_before_the_joints_procedure_still_loads() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    let old = CalibrationFile {
        tactile: Some(tactile()),
        pivot: Some(pivot()),
        ..CalibrationFile::default()
    };
    // As a daemon without the joints procedure wrote it: no `joints` field at all.
    let text = ron::ser::to_string_pretty(&old, ron::ser::PrettyConfig::default()).expect("ron");
    let text: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("joints:"))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(!text.contains("joints"), "{text}");
    std::fs::write(&path, text).expect("write");
    let f = load(&path).expect("loads").expect("present").value;
    assert_eq!(f, old);
    assert_eq!(f.joints, None);
}

#[test]
fn a_joints_record_that_cannot_be_used_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    for (change, field) in [
        (
            (|j: &mut JointsRecord| j.zero_offset_rad[1] = f64::NAN) as fn(&mut JointsRecord),
            "joints.zero_offset_rad",
        ),
        (
            |j: &mut JointsRecord| j.stops[0].joint = 3,
            "joints.stops[0].joint",
        ),
        (
            |j: &mut JointsRecord| j.stops[0].at_rad = f64::INFINITY,
            "joints.stops[0]",
        ),
        (
            |j: &mut JointsRecord| {
                j.checks = vec![CheckRecord {
                    quantity: "joint 1 upper stop beyond its software limit".into(),
                    value: -0.03,
                    bound: "at_least".into(),
                    limit: 0.02,
                    unit: "rad".into(),
                    passed: false,
                }]
            },
            "joints.passed",
        ),
    ] {
        let mut j = joints();
        change(&mut j);
        let file = CalibrationFile {
            joints: Some(j),
            ..CalibrationFile::default()
        };
        std::fs::write(&path, ron::ser::to_string(&file).expect("ron")).expect("write");
        let e = load(&path).expect_err(field).to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

#[test]
fn a_file_from_before_the_pivot_procedure_still_loads() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    // A tissue record of then names neither the pivot nor the encoder zero.
    let mut then = tissue();
    then.pivot_in_base_m = None;
    then.joint_zero_rad = None;
    let old = CalibrationFile {
        tactile: Some(tactile()),
        tissue: Some(then),
        ..CalibrationFile::default()
    };
    // As a daemon without the pivot procedure wrote it: no `pivot` field at all.
    let text = ron::ser::to_string_pretty(&old, ron::ser::PrettyConfig::default()).expect("ron");
    let text: String = text
        .lines()
        .filter(|l| {
            let l = l.trim_start();
            !["pivot:", "pivot_in_base_m:", "joint_zero_rad:"]
                .iter()
                .any(|f| l.starts_with(f))
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert!(!text.contains("pivot"), "{text}");
    std::fs::write(&path, text).expect("write");
    let f = load(&path).expect("loads").expect("present").value;
    assert_eq!(f, old);
    assert_eq!(f.pivot, None);
}

#[test]
fn a_pivot_record_that_cannot_be_used_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    for (change, field) in [
        (
            (|p: &mut PivotRecord| p.touched_in_tissue_m.truncate(4)) as fn(&mut PivotRecord),
            "pivot.touched_in_tissue_m",
        ),
        (
            |p: &mut PivotRecord| p.pivot_in_base_m[2] = f64::INFINITY,
            "pivot.pivot_in_base_m",
        ),
        (
            |p: &mut PivotRecord| {
                p.checks = vec![CheckRecord {
                    quantity: "level plate RMS residual".into(),
                    value: 1e-3,
                    bound: "at_most".into(),
                    limit: 5e-4,
                    unit: "m".into(),
                    passed: false,
                }]
            },
            "pivot.passed",
        ),
    ] {
        let mut p = pivot();
        change(&mut p);
        let file = CalibrationFile {
            pivot: Some(p),
            ..CalibrationFile::default()
        };
        std::fs::write(&path, ron::ser::to_string(&file).expect("ron")).expect("write");
        let e = load(&path).expect_err(field).to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

#[test]
fn a_tissue_record_that_cannot_be_used_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    let mut t = tissue();
    t.surface_in_base_m.pop();
    let file = CalibrationFile {
        version: CALIBRATION_VERSION,
        tactile: None,
        tissue: Some(t),
        pivot: None,
        joints: None,
    };
    save(&path, &file).expect("saved");
    let e = load(&path).expect_err("two points").to_string();
    assert!(e.contains("tissue.surface_in_base_m"), "{e}");
    let mut t = tissue();
    t.placement.yaw_rad = f64::INFINITY;
    std::fs::write(
        &path,
        ron::ser::to_string(&CalibrationFile {
            version: CALIBRATION_VERSION,
            tactile: None,
            tissue: Some(t),
            pivot: None,
            joints: None,
        })
        .expect("ron"),
    )
    .expect("write");
    let e = load(&path).expect_err("infinite yaw").to_string();
    assert!(e.contains("tissue.placement"), "{e}");
    type Change = fn(&mut TissueRecord);
    let bad: [(&str, Change); 2] = [
        ("tissue.pivot_in_base_m", |t| {
            t.pivot_in_base_m = Some([f64::NAN, 0.0, 0.0])
        }),
        ("tissue.joint_zero_rad", |t| {
            t.joint_zero_rad = Some([0.0, f64::INFINITY, 0.0])
        }),
    ];
    for (field, change) in bad {
        let mut t = tissue();
        change(&mut t);
        let file = CalibrationFile {
            tissue: Some(t),
            ..CalibrationFile::default()
        };
        std::fs::write(&path, ron::ser::to_string(&file).expect("ron")).expect("write");
        let e = load(&path).expect_err(field).to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

#[test]
fn a_file_from_before_the_tissue_procedure_still_loads() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    std::fs::write(&path, "(version: 1)").expect("write");
    let f = load(&path).expect("loads").expect("present").value;
    assert_eq!(f.tissue, None);
    assert_eq!(f.tactile, None);
}

#[test]
fn a_saved_file_loads_back_the_same() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("state/calibration.ron");
    assert!(load(&path).expect("no file is no calibration").is_none());
    let file = CalibrationFile {
        version: CALIBRATION_VERSION,
        tactile: Some(tactile()),
        tissue: Some(tissue()),
        pivot: Some(pivot()),
        joints: Some(joints()),
    };
    save(&path, &file).expect("saved, making the folder");
    let back = load(&path).expect("loads").expect("present");
    assert_eq!(back.value, file);
    // No temporary file is left beside it.
    let names = names_in(path.parent().expect("dir"));
    assert_eq!(names.len(), 1, "{names:?}");
}

#[test]
fn a_bad_file_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("calibration.ron");
    let mut t = tactile();
    t.calibration.elements[2].gain = -1.0;
    save(
        &path,
        &CalibrationFile {
            version: CALIBRATION_VERSION,
            tactile: Some(t),
            tissue: None,
            pivot: None,
            joints: None,
        },
    )
    .expect("saved");
    let e = load(&path).expect_err("negative gain").to_string();
    assert!(
        e.contains("tactile.calibration") && e.contains("element 2"),
        "{e}"
    );

    let mut t = tactile();
    t.checks[0].passed = false;
    save(
        &path,
        &CalibrationFile {
            version: CALIBRATION_VERSION,
            tactile: Some(t),
            tissue: None,
            pivot: None,
            joints: None,
        },
    )
    .expect("saved");
    let e = load(&path)
        .expect_err("passed with a failed check")
        .to_string();
    assert!(e.contains("tactile.passed"), "{e}");

    std::fs::write(&path, "(version: 1, tactile: (measured_utc: \"x\"))").expect("write");
    let e = load(&path).expect_err("missing fields").to_string();
    assert!(e.contains("calibration.ron:1"), "{e}");
    std::fs::write(&path, "(version: 7)").expect("write");
    let e = load(&path).expect_err("version").to_string();
    assert!(e.contains("version 7"), "{e}");
    std::fs::write(&path, [0xff, 0xfe, 0x00]).expect("write");
    assert!(load(&path).is_err());
}

#[test]
fn a_file_that_cannot_be_written_leaves_the_old_one() {
    let dir = tempfile::tempdir().expect("tmp");
    // A folder where the file should be: the rename fails after the temporary is written.
    let path = dir.path().join("calibration.ron");
    std::fs::create_dir(&path).expect("dir in the way");
    std::fs::write(path.join("keep"), "x").expect("write");
    let e = save(&path, &CalibrationFile::default()).expect_err("a folder is in the way");
    assert!(e.contains("calibration.ron"), "{e}");
    let left = names_in(dir.path());
    assert_eq!(left.len(), 1, "the temporary file is removed: {left:?}");
}

#[test]
fn a_full_disk_leaves_the_old_file_whole() {
    if !nix_is_root() {
        eprintln!("skipped: mounting a tmpfs needs root");
        return;
    }
    let dir = tempfile::tempdir().expect("tmp");
    let disk = dir.path().join("disk");
    std::fs::create_dir(&disk).expect("dir");
    let mounted = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&disk)
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        eprintln!("skipped: cannot mount a tmpfs here");
        return;
    }
    let path = disk.join("calibration.ron");
    let old = CalibrationFile {
        version: CALIBRATION_VERSION,
        tactile: Some(tactile()),
        tissue: None,
        pivot: None,
        joints: None,
    };
    save(&path, &old).expect("room for the first");
    let before = std::fs::read(&path).expect("bytes");
    let mut f = std::fs::File::create(disk.join("filler")).expect("filler");
    let block = vec![0u8; 4096];
    while f.write_all(&block).is_ok() {}
    drop(f);
    let mut new = old.clone();
    if let Some(t) = &mut new.tactile {
        t.measured_utc = "2026-11-28T02-00-00Z".into();
    }
    let e = save(&path, &new).expect_err("no room");
    assert!(e.contains("No space left"), "{e}");
    assert_eq!(std::fs::read(&path).expect("still there"), before);
    assert_eq!(std::fs::read_dir(&disk).expect("list").count(), 2);
    let _ = std::process::Command::new("umount")
        .arg("-l")
        .arg(&disk)
        .status();
}

/// The names in a folder.
fn names_in(dir: &std::path::Path) -> Vec<std::ffi::OsString> {
    std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect()
}

fn nix_is_root() -> bool {
    // The effective uid without a dependency: /proc/self/status's second Uid field.
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(2).map(|u| u == "0"))
        })
        .unwrap_or(false)
}
