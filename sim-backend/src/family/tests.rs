use std::f64::consts::PI;

use super::draw::{LEAD_M, bounding_box, heading_range};
use super::*;
use crate::scene::{ArteryPath, PathSpec};

fn shipped(name: &str) -> LoadedFamily {
    load(name, None).unwrap_or_else(|e| panic!("{e}"))
}

/// Seeds every geometric check runs over (drawing is cheap; no trial runs).
const SEEDS: std::ops::RangeInclusive<u64> = 1..=25;

#[test]
fn every_shipped_family_loads_from_its_file_and_embedded() {
    assert_eq!(shipped_family_names().len(), 8);
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/families");
    for name in shipped_family_names() {
        let embedded = shipped(name);
        let from_file =
            load(dir.join(name).to_str().expect("utf-8"), None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(embedded, from_file, "{name}");
        assert_eq!(
            format!("{}.ron", embedded.family.name),
            name,
            "a family is named as its file"
        );
        assert!(!embedded.family.description.is_empty(), "{name}");
    }
    // Every file in the directory is shipped.
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .expect("config/families")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ron"))
        .collect();
    on_disk.sort();
    let mut names: Vec<String> = shipped_family_names()
        .iter()
        .map(|n| n.to_string())
        .collect();
    names.sort();
    assert_eq!(on_disk, names);
}

#[test]
fn the_same_seed_draws_the_same_scene_and_others_differ() {
    for name in shipped_family_names() {
        let f = shipped(name);
        let a = f.draw(7).unwrap_or_else(|e| panic!("{e}"));
        let b = f.draw(7).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(a, b, "{name}");
        let c = f.draw(8).unwrap_or_else(|e| panic!("{e}"));
        assert_ne!(a.artery.path, c.artery.path, "{name}: seeds 7 and 8");
        assert_eq!(a.name, format!("{}-7", f.family.name));
    }
    // Families drawn with the same seed differ.
    let a = shipped("smooth-random").draw(3).expect("draws");
    let b = shipped("breathing").draw(3).expect("draws");
    assert_ne!(a.artery.path, b.artery.path);
}

/// Every drawn scene is valid (the draw validates it) and keeps the family's limits: the
/// tracked part within the heading bound of x, no arc tighter than the family's radius,
/// the course and the array's reach inside the workspace, the placements on the course, the
/// effects within their ranges.
#[test]
fn drawn_scenes_keep_the_family_limits() {
    for name in shipped_family_names() {
        let f = shipped(name);
        let fam = &f.family;
        let mut toward_minus_x = 0;
        for seed in SEEDS {
            let s = f
                .draw(seed)
                .unwrap_or_else(|e| panic!("{name} {seed}: {e}"));
            let path = ArteryPath::from_spec(&s.artery.path).expect("builds");
            let track = s.track.length_m;
            assert!(
                (fam.track_length_m.0..=fam.track_length_m.1).contains(&track),
                "{name} {seed}"
            );
            let (lo, hi) = heading_range(&path, LEAD_M, LEAD_M + track);
            // Relative to +x or to -x, whichever the course runs along.
            let mid = 0.5 * (lo + hi);
            let axis = (mid / PI).round() * PI;
            if ((axis / PI).round() as i64).rem_euclid(2) == 1 {
                toward_minus_x += 1;
            }
            let bound = fam.max_heading_rad + 1e-9;
            assert!(
                lo - axis >= -bound && hi - axis <= bound,
                "{name} {seed}: headings {:.1} to {:.1} deg about {:.0}",
                lo.to_degrees(),
                hi.to_degrees(),
                axis.to_degrees()
            );
            let inner = match &s.artery.path {
                PathSpec::Transformed { path, .. } => path.as_ref(),
                other => panic!("{name} {seed}: {other:?}"),
            };
            match inner {
                PathSpec::Corners { bends_rad, .. } => {
                    let (b_lo, b_hi) = fam
                        .courses
                        .iter()
                        .find_map(|c| match c.course {
                            CourseFamily::Corners { bend_rad, .. } => {
                                Some((bend_rad.0, bend_rad.1))
                            }
                            _ => None,
                        })
                        .expect("a corner family");
                    for b in bends_rad {
                        assert!((b_lo..=b_hi).contains(&b.abs()), "{name} {seed}: bend {b}");
                    }
                    assert!(path.largest_corner_rad() <= b_hi + 1e-9);
                }
                _ => {
                    if let Some(r) = fam.min_radius_m {
                        assert!(
                            path.largest_curvature_per_m() * r <= 1.0 + 1e-9,
                            "{name} {seed}: radius {} mm",
                            1e3 / path.largest_curvature_per_m()
                        );
                    }
                    assert!(path.largest_corner_rad() < 1e-6, "{name} {seed}: smooth");
                }
            }
            let (min, max) = bounding_box(&path);
            let w = &fam.workspace;
            let m = w.margin_m - 1e-9;
            assert!(
                min[0] - m >= w.x_m.0 && max[0] + m <= w.x_m.1,
                "{name} {seed}: x {min:?} {max:?}"
            );
            assert!(
                min[1] - m >= w.z_m.0 && max[1] + m <= w.z_m.1,
                "{name} {seed}: z {min:?} {max:?}"
            );
            for p in s.placements {
                assert!(path.nearest(p).offset_m.abs() < 1e-9, "{name} {seed}");
            }
            if let (Some(h), crate::scene::PulseSpec::Physiological { heart_rate_hz, .. }) =
                (&fam.heart, &s.pulse)
            {
                assert!((h.rate_hz.0..=h.rate_hz.1).contains(heart_rate_hz));
            }
            if let Some(b) = &fam.breathing {
                let drawn = s.tissue.breathing.expect("breathing drawn");
                assert!((b.amplitude_m.0..=b.amplitude_m.1).contains(&drawn.amplitude_m));
                assert!((b.frequency_hz.0..=b.frequency_hz.1).contains(&drawn.frequency_hz));
            } else {
                assert!(s.tissue.breathing.is_none());
            }
            if let Some(l) = &fam.lumps {
                assert!((l.count.0 as usize..=l.count.1 as usize).contains(&s.lumps.len()));
                for lump in &s.lumps {
                    let off = path.nearest(lump.centre).offset_m.abs();
                    assert!(off >= l.lateral_offset_m.0 - 1e-4, "{name} {seed}: {off}");
                }
            } else {
                assert!(s.lumps.is_empty());
            }
        }
        if fam.either_direction {
            assert!(
                (1..SEEDS.count()).contains(&toward_minus_x),
                "{name}: both directions drawn ({toward_minus_x} toward -x)"
            );
        }
    }
}

/// A drawn scene written out is an ordinary scene file that loads back to the same scene.
/// The limit sweeps (docs/BENCHMARKS.md, "Limits") load, are named after their files, and
/// draw scenes that hold the one value each fixes.
#[test]
fn every_limits_sweep_family_loads_and_draws() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/families/limits");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).expect("config/families/limits") {
        let path = entry.expect("entry").path();
        if path.extension().and_then(|e| e.to_str()) != Some("ron") {
            continue;
        }
        let file = path.to_str().expect("utf-8");
        let f = load(file, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            path.file_stem().and_then(|s| s.to_str()),
            Some(f.family.name.as_str()),
            "a family is named as its file"
        );
        let s = f.draw(1).unwrap_or_else(|e| panic!("{file}: {e}"));
        if let Some(m) = f.family.instrument.as_ref().and_then(|i| i.mass_kg) {
            assert_eq!(s.mass.map(|m| m.mass_kg), Some(m.0), "{file}");
        }
        count += 1;
    }
    assert!(count >= 30, "{count} sweep families");
}

#[test]
fn a_drawn_scene_written_out_loads_back_identical() {
    let dir = std::env::temp_dir().join(format!("pulsetrack-family-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    for name in shipped_family_names() {
        let f = shipped(name);
        for seed in [1, 2] {
            let s = f.draw(seed).expect("draws");
            let text = crate::scene::to_ron(&s, "test").expect("writes");
            let file = dir.join(format!("{}.ron", s.name));
            std::fs::write(&file, &text).expect("written");
            let back = crate::scene::load(file.to_str().expect("utf-8"), None)
                .unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert_eq!(back, s, "{name} {seed}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The default workspace (with its margin) lies within what the shipped rig reaches.
#[test]
fn the_default_workspace_is_reachable_on_the_shipped_rig() {
    let (name, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(name, text).expect("config");
    let r = &config.robot;
    let model = control::kinematics::ArmModel::new(
        r.phantom,
        r.joint_limits,
        r.pivot,
        r.tissue,
        r.sensor_offset_m,
    )
    .expect("model");
    let planner = control::motion::MotionPlanner::new(config.control.motion).expect("planner");
    let w = Workspace::default();
    for i in 0..=10 {
        for j in 0..=10 {
            let x = w.x_m.0 + (w.x_m.1 - w.x_m.0) * f64::from(i) / 10.0;
            let z = w.z_m.0 + (w.z_m.1 - w.z_m.0) * f64::from(j) / 10.0;
            let p = planner.contact_point(&control::frames::SurfacePoint::new(x, z));
            assert!(
                model
                    .joint_setpoint(&p, &nalgebra::Vector3::zeros())
                    .is_ok(),
                "({x}, {z}) is out of reach"
            );
        }
    }
}

#[test]
fn bad_families_are_refused_by_field() {
    let good = shipped_family_source("sinusoids").expect("shipped").1;
    for (from, to, field) in [
        ("version: 1", "version: 2", "version"),
        (
            "max_heading_rad: 1.0471975511965976",
            "max_heading_rad: 1.3",
            "max_heading_rad",
        ),
        ("(0.004, 0.015)", "(0.015, 0.004)", "amplitude_m"),
        (
            "track_length_m: (0.15, 0.22)",
            "track_length_m: (0.15, 5.0)",
            "track_length_m",
        ),
        ("base: \"seed-arc-145\"", "base: \"\"", "base"),
    ] {
        assert!(good.contains(from), "{from}");
        let bad = good.replace(from, to);
        let e = config::load_str::<Family>("bad.ron", &bad).expect_err(field);
        let text = e.to_string();
        assert!(text.contains(field), "{text}");
        assert!(text.contains("bad.ron:"), "names the line: {text}");
    }
    // Unknown fields are refused with their line.
    let bad = good.replace("min_radius_m", "min_radius");
    let e = config::load_str::<Family>("bad.ron", &bad).expect_err("unknown field");
    assert!(e.to_string().contains("bad.ron:"), "{e}");
    // A base scene that does not load names the family's `base`.
    let dir = std::env::temp_dir().join(format!("pulsetrack-badfam-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("f.ron");
    std::fs::write(&file, good.replace("seed-arc-145", "no-such-scene")).expect("write");
    let e = load(file.to_str().expect("utf-8"), None).expect_err("bad base");
    assert!(e.to_string().contains("base"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(load("no-such-family", None).is_err());
}

#[test]
fn an_unsatisfiable_family_is_an_error_not_a_hang() {
    let mut f = shipped("sinusoids");
    // Crests far tighter than the radius bound allows: every draw is refused.
    f.family.courses[0].course = CourseFamily::Sinusoid {
        amplitude_m: Interval(0.05, 0.05),
        wavelength_m: Interval(0.02, 0.02),
    };
    let e = f.draw(1).expect_err("unsatisfiable");
    assert!(e.contains("sinusoids"), "{e}");
}

/// A deterministic regression per shipped family: a short lockstep trial of `beatslide` on
/// the scene of seed 1 (its track cut to 40 mm to keep the test fast) runs to an end the
/// runner knows, with finite located points; loose bounds that cannot flake.
#[test]
fn a_short_trial_on_each_family_runs_to_a_clean_end() {
    let (name, text) = config::shipped::SIM_CONFIG;
    let config: config::Config = config::load_str(name, text).expect("config");
    for family in shipped_family_names() {
        let mut s = shipped(family).draw(1).expect("draws");
        s.track.length_m = 0.04;
        let t = crate::runner::run_trial(&s, &config, "beatslide", 1)
            .unwrap_or_else(|e| panic!("{family}: {e}"));
        assert!(
            [
                "length_reached",
                "lost",
                "workspace_edge",
                "stopped",
                "not_seeded",
                "timeout",
                "fault"
            ]
            .contains(&t.end_reason.as_str()),
            "{family}: {}",
            t.end_reason
        );
        assert!(t.simulated_s > 0.0 && t.simulated_s <= crate::runner::TRIAL_TIME_LIMIT_S + 1.0);
        assert!(
            t.located
                .iter()
                .all(|p| p.x_m.is_finite() && p.z_m.is_finite() && p.lateral_error_m.is_finite())
        );
        assert_eq!(t.false_points, crate::trial::false_points(&t.located));
    }
}
