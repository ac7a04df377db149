use super::*;

#[test]
fn every_shipped_scene_loads_and_builds_its_path() {
    assert_eq!(shipped_names().len(), SHIPPED.len());
    for name in shipped_names() {
        let scene = load(name, None).unwrap_or_else(|e| panic!("{e}"));
        let path = ArteryPath::from_spec(&scene.artery.path).unwrap();
        assert!(path.length_m() > 0.02, "{name}");
        // The placements lie on the artery (within a millimetre).
        for p in scene.placements {
            let off = path.nearest(p).offset_m;
            assert!(
                off.abs() < 1e-3,
                "{name}: placement {p:?} is {off} m off the path"
            );
        }
        // And the name without `.ron` finds the same scene.
        let again = load(name.trim_end_matches(".ron"), None).unwrap();
        assert_eq!(again, scene);
    }
}

#[test]
fn arcs_are_the_seed_geometry() {
    for (name, radius) in [
        ("seed-arc-80.ron", 0.08),
        ("seed-arc-145.ron", 0.145),
        ("seed-arc-220.ron", 0.22),
    ] {
        let s = load(name, None).unwrap();
        match s.artery.path {
            PathSpec::Arc {
                radius_m, length_m, ..
            } => {
                assert_eq!(radius_m, radius);
                assert_eq!(length_m, 0.26);
            }
            ref other => panic!("{name}: {other:?}"),
        }
        // 5 mm OD, 1 mm wall, 5 mm deep, 100 kPa.
        assert_eq!(s.artery.inner_radius_m + s.artery.wall_m, 0.0025);
        assert!(matches!(s.pulse, PulseSpec::Solenoid { pressure_pa, .. } if pressure_pa == 100e3));
        assert_eq!(s.mass.map(|m| m.mass_kg), Some(0.3));
        let [a, b] = s.placements;
        let gap = a.distance_to(&b);
        assert!(
            (0.0095..=0.0205).contains(&gap),
            "{name}: placements {gap} m apart"
        );
    }
}

#[test]
fn radial_wrist_is_physiological() {
    let s = load("seed-radial-wrist.ron", None).unwrap();
    let d = 2.0 * s.artery.inner_radius_m;
    assert!((0.0022..=0.0032).contains(&d));
    assert!((0.0034..=0.0047).contains(&s.artery.depth_m));
    assert!(
        s.artery
            .depth_end_m
            .is_some_and(|e| (0.0034..=0.0047).contains(&e))
    );
    let [a, b] = s.placements;
    assert!((a.distance_to(&b) - 0.005).abs() < 0.001);
    assert!(matches!(s.pulse, PulseSpec::Physiological { .. }));
}

fn minimal(extra: &str) -> String {
    format!(
        "Scene(\n  version: 1,\n  name: \"t\",\n  artery: (\n    path: Straight(start: (x_m: 0.0, z_m: 0.0), heading_rad: 0.0, length_m: 0.1),\n    depth_m: 0.005,\n    inner_radius_m: 0.0015,\n    wall_m: 0.001,\n  ),\n  pulse: Absent,\n  placements: [(x_m: 0.0, z_m: 0.0), (x_m: 0.01, z_m: 0.0)],\n  track: (length_m: 0.05, reason: \"test\"),\n{extra})"
    )
}

#[test]
fn a_minimal_scene_takes_the_documented_defaults() {
    let s: Scene = config::load_str("t.ron", &minimal("")).unwrap();
    assert!(s.shaft.is_none() && s.pivot.is_none() && s.mass.is_none() && s.robot.is_none());
    assert!(s.tissue.friction.is_none());
    assert_eq!(s.sensor, SensorSpec::default());
}

#[test]
fn bad_scene_files_name_file_line_and_field() {
    // Unknown field, deep in a section.
    let src = minimal("  tissue: (contact_stiffnes_n_per_m: 10.0),\n");
    let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
    let msg = e.to_string();
    assert!(msg.starts_with("bad.ron:13:"), "{msg}");
    assert!(msg.contains("contact_stiffnes_n_per_m"), "{msg}");
    // A value out of range is located by validation.
    let src =
        minimal("  shaft: (\n    diameter_m: -0.0045,\n    youngs_modulus_pa: 200e9,\n  ),\n");
    let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
    assert_eq!(e.problems[0].field, "shaft.diameter_m");
    assert_eq!(e.problems[0].line, Some(14), "{e}");
    // A tube that breaks the surface.
    let src = minimal("").replace("depth_m: 0.005", "depth_m: 0.002");
    let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
    assert_eq!(e.problems[0].field, "artery.depth_m", "{e}");
    assert_eq!(e.problems[0].line, Some(6), "{e}");
    // An arc that closes on itself.
    let src = minimal("").replace(
        "Straight(start: (x_m: 0.0, z_m: 0.0), heading_rad: 0.0, length_m: 0.1)",
        "Arc(radius_m: 0.01, length_m: 0.1)",
    );
    let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
    assert!(e.problems.iter().any(|p| p.field == "artery.path"), "{e}");
    // Wrong type.
    let src = minimal("").replace("depth_m: 0.005", "depth_m: \"deep\"");
    let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
    assert_eq!(e.problems[0].field, "artery.depth_m");
    assert_eq!(e.problems[0].line, Some(6));
    // Coincident placements, a missing reason, a dead element that does not exist.
    let src = minimal("  faults: (dead_elements: [12]),\n")
        .replace("(x_m: 0.01, z_m: 0.0)]", "(x_m: 0.0, z_m: 0.0)]")
        .replace("reason: \"test\"", "reason: \"\"");
    let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
    let fields: Vec<&str> = e.problems.iter().map(|p| p.field.as_str()).collect();
    assert!(fields.contains(&"placements[1]"), "{fields:?}");
    assert!(fields.contains(&"track.reason"), "{fields:?}");
    assert!(fields.contains(&"faults.dead_elements[0]"), "{fields:?}");
    // Garbage never panics.
    for junk in [
        "",
        "Scene(",
        "Scene(version: 1)",
        "[1, 2",
        "Scene(version: 1, name: 3)",
    ] {
        assert!(config::load_str::<Scene>("junk.ron", junk).is_err());
    }
}

#[test]
fn files_load_by_path_relative_to_a_base_dir() {
    let dir = std::env::temp_dir().join(format!("pulsetrack-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("mine.ron"), minimal("")).unwrap();
    let s = load("mine.ron", Some(&dir)).unwrap();
    assert_eq!(s.name, "t");
    std::fs::write(
        dir.join("broken.ron"),
        minimal("  lumps: [(centre: (x_m: 0.0, z_m: 0.0), depth_m: -1.0, pressure_gain: 1.0)],\n"),
    )
    .unwrap();
    let e = load("broken.ron", Some(&dir)).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("broken.ron:13:"), "{msg}");
    assert!(msg.contains("lumps[0].depth_m"), "{msg}");
    let e = load("nope.ron", Some(&dir)).unwrap_err();
    assert!(e.to_string().contains("seed-arc-145.ron"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_daemons_default_config_names_a_scene_that_loads() {
    let (name, text) = config::shipped::SIM_CONFIG;
    let c: config::Config = config::load_str(name, text).unwrap();
    let config::schema::Backend::Sim(sim) = c.backend else {
        panic!("sim.ron must use the simulator");
    };
    let scene = load(&sim.scene, None).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.name, "seed-arc-145");
}

#[test]
fn the_new_physics_options_are_checked() {
    let check = |extra: &str, replace: Option<(&str, &str)>, field: &str| {
        let mut src = minimal(extra);
        if let Some((a, b)) = replace {
            src = src.replace(a, b);
        }
        let e = config::load_str::<Scene>("bad.ron", &src).unwrap_err();
        assert!(e.problems.iter().any(|p| p.field == field), "{field}: {e}");
    };
    check(
        "  pivot: (hysteresis_slip_n: 0.1),\n",
        None,
        "pivot.hysteresis_slip_n",
    );
    check(
        "",
        Some((
            "wall_m: 0.001,",
            "wall_m: 0.001,\n    kernel: Fem((tissue: (e_pa: 2e4, nu: 0.45), wall: (e_pa: 2e4, nu: 0.45), wall_flattened: true)),",
        )),
        "artery.kernel.Fem.wall_flattened",
    );
    check(
        "",
        Some((
            "wall_m: 0.001,",
            "wall_m: 0.001,\n    kernel: Fem((tissue: (e_pa: 2e4, nu: 0.45), wall: (e_pa: 2e4, nu: 0.45), backing_gap_m: 0.0001)),",
        )),
        "artery.kernel.Fem.backing_gap_m",
    );
    check(
        "",
        Some((
            "wall_m: 0.001,",
            "wall_m: 0.001,\n    coupling: HoldDown(reference_normal_n: 0.0),",
        )),
        "artery.coupling.HoldDown.reference_normal_n",
    );
    // And the good forms load.
    let src = minimal("  sensor: (mount: (pin: AlongLine)),\n  placed_by: Eye,\n")
        .replace("wall_m: 0.001,", "wall_m: 0.001,\n    kernel: Applanation,");
    let s: Scene = config::load_str("ok.ron", &src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.placed_by, Placing::Eye);
    assert!(matches!(s.artery.kernel, PressureKernel::Applanation));
}

/// Found with the `scene_loader` fuzz target (docs/fuzzing.md; the crash input was
/// tight-arc-30.ron with `chord_centre: (x_m: NaN, ...)`): an arc's chord centre was never
/// checked, so a NaN passed validation and every point of the path was NaN. And a spline's
/// sampling step had no lower bound: a tiny one would build the path from billions of
/// pieces (found reading the path code while fixing the first).
#[test]
fn an_arc_centre_and_a_spline_step_are_checked() {
    let arc = |centre: &str| {
        minimal("").replace(
            "Straight(start: (x_m: 0.0, z_m: 0.0), heading_rad: 0.0, length_m: 0.1)",
            &format!("Arc(radius_m: 0.03, length_m: 0.15, chord_centre: {centre})"),
        )
    };
    for (centre, field) in [
        ("(x_m: NaN, z_m: 0.0393)", "artery.path.chord_centre.x_m"),
        ("(x_m: 0.0, z_m: inf)", "artery.path.chord_centre.z_m"),
    ] {
        let e = config::load_str::<Scene>("bad.ron", &arc(centre)).unwrap_err();
        assert!(e.problems.iter().any(|p| p.field == field), "{e}");
        assert!(e.to_string().starts_with("bad.ron:5:"), "{e}");
    }
    let s: Scene = config::load_str("t.ron", &arc("(x_m: 0.0, z_m: 0.0393)")).unwrap();
    let path = ArteryPath::from_spec(&s.artery.path).unwrap();
    let (p, _) = path.at(0.5 * path.length_m());
    assert!(p.is_finite());

    let spline = minimal("").replace(
        "Straight(start: (x_m: 0.0, z_m: 0.0), heading_rad: 0.0, length_m: 0.1)",
        "Spline(points: [(x_m: -0.05, z_m: 0.0), (x_m: 0.0, z_m: 0.01), (x_m: 0.05, z_m: 0.0)], sample_m: 1e-12)",
    );
    let e = config::load_str::<Scene>("bad.ron", &spline).unwrap_err();
    assert!(
        e.problems.iter().any(|p| p.field == "artery.path.sample_m"),
        "{e}"
    );
    let ok = spline.replace("sample_m: 1e-12", "sample_m: 0.001");
    let _: Scene = config::load_str("t.ron", &ok).unwrap();
}

/// The golden lines of one path: points along it (and past its ends) and nearest-point
/// queries beside it, every number exactly (`{:?}` round-trips an f64).
fn golden(name: &str, path: &ArteryPath) -> String {
    use control::frames::SurfacePoint;
    let mut out = String::new();
    let l = path.length_m();
    out.push_str(&format!("scene {name} length {l:?}\n"));
    for i in 0..=12 {
        let s = -0.02 + (l + 0.04) * i as f64 / 12.0;
        let (p, h) = path.at(s);
        out.push_str(&format!("at {s:?} {:?} {:?} {h:?}\n", p.x_m, p.z_m));
    }
    for j in 0..24 {
        let s = l * (j as f64 + 0.5) / 24.0;
        let (p, h) = path.at(s);
        let o = -0.03 + 0.06 * ((j * 7) % 24) as f64 / 23.0;
        let q = SurfacePoint::new(p.x_m - o * h.sin(), p.z_m + o * h.cos());
        let n = path.nearest(q);
        out.push_str(&format!(
            "near {:?} {:?} -> {:?} {:?} {:?} {:?} {:?}\n",
            q.x_m, q.z_m, n.s_m, n.offset_m, n.heading_rad, n.point.x_m, n.point.z_m
        ));
    }
    out
}

/// Every shipped scene (version 1) gives exactly the path it gave before the scene families
/// (the new path types, the rigid move, the nearest-point index): points, headings and
/// nearest points, bit for bit, as recorded from the code before them.
#[test]
fn shipped_scenes_give_exactly_the_paths_they_gave_before() {
    let expected = include_str!("testdata/shipped_paths.golden");
    let mut got = String::new();
    // Scenes shipped since have no "before": they are left out.
    let recorded = |name: &str| expected.contains(&format!("scene {name} length"));
    for name in shipped_names().iter().filter(|n| recorded(n)) {
        let scene = load(name, None).unwrap();
        let path = ArteryPath::from_spec(&scene.artery.path).unwrap();
        got.push_str(&golden(name, &path));
        // And the index agrees with the full scan around every path.
        for q in path.sample(0.002) {
            for (dx, dz) in [(0.0, 0.0), (0.004, -0.007), (-0.02, 0.013)] {
                let q = control::frames::SurfacePoint::new(q.x_m + dx, q.z_m + dz);
                assert_eq!(path.nearest(q), path.nearest_by_scan(q), "{name}");
            }
        }
    }
    for (i, (g, e)) in got.lines().zip(expected.lines()).enumerate() {
        assert_eq!(g, e, "line {}", i + 1);
    }
    assert_eq!(got.lines().count(), expected.lines().count());
}
