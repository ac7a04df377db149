//! Tests of the many-piece courses, the rigid move, and the index against the full scan.

use std::f64::consts::PI;

use proptest::prelude::*;

use super::*;

fn build(spec: PathSpec) -> ArteryPath {
    ArteryPath::from_spec(&spec).unwrap_or_else(|e| panic!("{e}"))
}

fn origin() -> SurfacePoint {
    SurfacePoint::new(0.0, 0.0)
}

#[test]
fn a_sinusoid_lies_on_its_sine_and_is_smooth() {
    let (a, wl, phase) = (0.01, 0.12, 0.7);
    let p = build(PathSpec::Sinusoid {
        start: SurfacePoint::new(-0.1, 0.02),
        heading_rad: 0.3,
        amplitude_m: a,
        wavelength_m: wl,
        length_m: 0.25,
        phase_rad: phase,
        step_m: None,
    });
    assert!((p.length_m() - 0.25).abs() < 1e-12);
    assert!(p.largest_corner_rad() < 1e-6, "{}", p.largest_corner_rad());
    // The crest's radius: wavelength² / (4π² amplitude).
    let crest = wl * wl / (4.0 * PI * PI * a);
    assert!((1.0 / p.largest_curvature_per_m() - crest).abs() < 0.02 * crest);
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let k = 2.0 * PI / wl;
    for i in 0..200 {
        let u = 0.2 * i as f64 / 200.0;
        let v = a * ((k * u + phase).sin() - phase.sin());
        let q = SurfacePoint::new(-0.1 + u * c - v * s, 0.02 + u * s + v * c);
        let off = p.nearest(q).offset_m;
        assert!(off.abs() < 5e-6, "u {u}: {off}");
    }
}

#[test]
fn a_spiral_shrinks_from_its_start_radius_to_its_end_radius() {
    let (r0, r1, l) = (0.2, 0.05, 0.2);
    let p = build(PathSpec::Spiral {
        start: origin(),
        heading_rad: 0.0,
        start_radius_m: r0,
        end_radius_m: r1,
        length_m: l,
        turn: Turn::Right,
        step_m: None,
    });
    assert!((p.length_m() - l).abs() < 1e-12);
    assert!((1.0 / p.largest_curvature_per_m() - r1).abs() < 0.01 * r1);
    let turned = l / (r1 - r0) * (r1 / r0).ln();
    let (_, h_end) = p.at(l);
    assert!((h_end + turned).abs() < 1e-9, "{h_end} vs -{turned}");
    assert!(p.largest_corner_rad() < 1e-6);
}

#[test]
fn corners_bend_where_the_legs_meet_and_fillets_round_them() {
    let spec = |fillet| PathSpec::Corners {
        start: origin(),
        heading_rad: 0.0,
        legs_m: vec![0.05, 0.04, 0.03],
        bends_rad: vec![PI / 4.0, -PI / 3.0],
        fillet_radius_m: fillet,
    };
    let sharp = build(spec(0.0));
    assert!((sharp.length_m() - 0.12).abs() < 1e-12);
    let (corner, h) = sharp.at(0.05);
    assert!((corner.x_m - 0.05).abs() < 1e-12 && corner.z_m.abs() < 1e-12);
    assert!((h - PI / 4.0).abs() < 1e-12);
    assert!((sharp.largest_corner_rad() - PI / 3.0).abs() < 1e-12);
    let r = 0.005;
    let round = build(spec(r));
    assert!(round.largest_corner_rad() < 1e-9);
    let saved: f64 = [PI / 4.0, PI / 3.0]
        .iter()
        .map(|b| 2.0 * r * (b / 2.0).tan() - r * b)
        .sum();
    assert!((round.length_m() - (0.12 - saved)).abs() < 1e-12);
    // The same end point, the same end heading.
    let (a, ha) = sharp.at(sharp.length_m());
    let (b, hb) = round.at(round.length_m());
    assert!(a.distance_to(&b) < 1e-12 && (ha - hb).abs() < 1e-12);
    // A fillet that does not fit is an error.
    assert!(ArteryPath::from_spec(&spec(0.1)).is_err());
}

#[test]
fn a_clothoid_of_constant_curvature_is_an_arc() {
    let p = build(PathSpec::Clothoid {
        start: origin(),
        heading_rad: 0.0,
        knots: vec![
            CurvatureKnot {
                s_m: 0.0,
                curvature_per_m: 10.0,
            },
            CurvatureKnot {
                s_m: 0.2,
                curvature_per_m: 10.0,
            },
        ],
        step_m: None,
    });
    for i in 0..=20 {
        let s = 0.01 * i as f64;
        let (q, h) = p.at(s);
        let a = 10.0 * s;
        let exact = SurfacePoint::new(a.sin() / 10.0, (1.0 - a.cos()) / 10.0);
        assert!(q.distance_to(&exact) < 1e-12, "{s}");
        assert!((h - a).abs() < 1e-12);
    }
    // Linear curvature: the heading is its integral.
    let p = build(PathSpec::Clothoid {
        start: origin(),
        heading_rad: 0.1,
        knots: vec![
            CurvatureKnot {
                s_m: 0.0,
                curvature_per_m: 0.0,
            },
            CurvatureKnot {
                s_m: 0.1,
                curvature_per_m: 20.0,
            },
            CurvatureKnot {
                s_m: 0.15,
                curvature_per_m: -10.0,
            },
        ],
        step_m: None,
    });
    let (_, h) = p.at(0.15);
    assert!((h - (0.1 + 0.5 * 20.0 * 0.1 + 0.5 * (20.0 - 10.0) * 0.05)).abs() < 1e-12);
    assert!(p.largest_corner_rad() < 1e-9);
}

#[test]
fn a_moved_and_reversed_path_is_the_same_course() {
    let inner = PathSpec::Arc {
        radius_m: 0.1,
        length_m: 0.2,
        chord_centre: SurfacePoint::default(),
        turn: Turn::Left,
    };
    let base = build(inner.clone());
    let rot = 0.8;
    let shift = SurfacePoint::new(0.01, -0.02);
    let moved = build(PathSpec::Transformed {
        path: Box::new(inner.clone()),
        rotation_rad: rot,
        translation: shift,
        reverse: false,
    });
    let back = build(PathSpec::Transformed {
        path: Box::new(inner),
        rotation_rad: rot,
        translation: shift,
        reverse: true,
    });
    let mv = |p: SurfacePoint| {
        SurfacePoint::new(
            rot.cos() * p.x_m - rot.sin() * p.z_m + shift.x_m,
            rot.sin() * p.x_m + rot.cos() * p.z_m + shift.z_m,
        )
    };
    for i in 0..=20 {
        let s = 0.01 * i as f64;
        let (p, h) = base.at(s);
        let (m, hm) = moved.at(s);
        assert!(m.distance_to(&mv(p)) < 1e-12);
        assert!((hm - h - rot).abs() < 1e-12);
        let (r, hr) = back.at(0.2 - s);
        assert!(r.distance_to(&m) < 1e-12, "{s}");
        assert!(((hr - hm).rem_euclid(2.0 * PI) - PI).abs() < 1e-9);
        // A point beside the course: the same distance, the other side.
        let q = SurfacePoint::new(m.x_m + 0.003, m.z_m - 0.002);
        let (a, b) = (moved.nearest(q), back.nearest(q));
        assert!((a.offset_m + b.offset_m).abs() < 1e-12);
        assert!((a.s_m + b.s_m - 0.2).abs() < 1e-9);
    }
}

#[test]
fn bad_shapes_are_errors() {
    let bad = [
        PathSpec::Sinusoid {
            start: origin(),
            heading_rad: 0.0,
            amplitude_m: -0.01,
            wavelength_m: 0.1,
            length_m: 0.1,
            phase_rad: 0.0,
            step_m: None,
        },
        PathSpec::Sinusoid {
            start: origin(),
            heading_rad: 0.0,
            amplitude_m: 0.01,
            wavelength_m: 0.1,
            length_m: 0.1,
            phase_rad: 0.0,
            step_m: Some(1e-9),
        },
        PathSpec::Spiral {
            start: origin(),
            heading_rad: 0.0,
            start_radius_m: 0.0,
            end_radius_m: 0.1,
            length_m: 0.1,
            turn: Turn::Left,
            step_m: None,
        },
        PathSpec::Corners {
            start: origin(),
            heading_rad: 0.0,
            legs_m: vec![0.1, 0.1],
            bends_rad: vec![],
            fillet_radius_m: 0.0,
        },
        PathSpec::Corners {
            start: origin(),
            heading_rad: 0.0,
            legs_m: vec![0.1, 0.1],
            bends_rad: vec![PI],
            fillet_radius_m: 0.0,
        },
        PathSpec::Clothoid {
            start: origin(),
            heading_rad: 0.0,
            knots: vec![
                CurvatureKnot {
                    s_m: 0.0,
                    curvature_per_m: 0.0,
                },
                CurvatureKnot {
                    s_m: 0.0,
                    curvature_per_m: 1.0,
                },
            ],
            step_m: None,
        },
        PathSpec::Transformed {
            path: Box::new(PathSpec::Polyline { points: vec![] }),
            rotation_rad: 0.0,
            translation: origin(),
            reverse: false,
        },
        PathSpec::Transformed {
            path: Box::new(PathSpec::Straight {
                start: origin(),
                heading_rad: 0.0,
                length_m: 0.1,
            }),
            rotation_rad: f64::NAN,
            translation: origin(),
            reverse: false,
        },
    ];
    for spec in bad {
        assert!(ArteryPath::from_spec(&spec).is_err(), "{spec:?}");
    }
}

fn point() -> impl Strategy<Value = SurfacePoint> {
    (-0.1f64..0.1, -0.1f64..0.1).prop_map(|(x, z)| SurfacePoint::new(x, z))
}

/// Random courses of every kind, many of them of hundreds of pieces.
fn any_path() -> impl Strategy<Value = PathSpec> {
    let polyline =
        prop::collection::vec(point(), 2..60).prop_map(|points| PathSpec::Polyline { points });
    let spline = prop::collection::vec(point(), 2..12).prop_map(|points| PathSpec::Spline {
        points,
        sample_m: Some(0.002),
    });
    let sinusoid = (
        0.0f64..0.02,
        0.02f64..0.2,
        0.02f64..0.3,
        -3.0f64..3.0,
        -3.0f64..3.0,
    )
        .prop_map(|(a, wl, l, phase, h)| PathSpec::Sinusoid {
            start: SurfacePoint::new(-0.05, 0.01),
            heading_rad: h,
            amplitude_m: a,
            wavelength_m: wl,
            length_m: l,
            phase_rad: phase,
            step_m: Some(0.002),
        });
    let spiral =
        (0.01f64..0.3, 0.01f64..0.3, 0.02f64..0.4, any::<bool>()).prop_map(|(r0, r1, l, left)| {
            PathSpec::Spiral {
                start: SurfacePoint::new(0.0, -0.02),
                heading_rad: 0.4,
                start_radius_m: r0,
                end_radius_m: r1,
                length_m: l,
                turn: if left { Turn::Left } else { Turn::Right },
                step_m: Some(0.002),
            }
        });
    let corners = (
        prop::collection::vec(0.01f64..0.08, 1..8),
        prop::collection::vec(-2.5f64..2.5, 7),
        0.0f64..0.003,
    )
        .prop_map(|(legs, bends, fillet)| PathSpec::Corners {
            start: SurfacePoint::new(-0.05, 0.0),
            heading_rad: 0.2,
            bends_rad: bends[..legs.len() - 1].to_vec(),
            legs_m: legs,
            fillet_radius_m: fillet,
        });
    let arc = (0.02f64..0.3, 0.01f64..0.3).prop_map(|(r, l)| PathSpec::Arc {
        radius_m: r,
        length_m: l.min(6.0 * r),
        chord_centre: SurfacePoint::default(),
        turn: Turn::Right,
    });
    let leaf = prop_oneof![polyline, spline, sinusoid, spiral, corners, arc];
    (leaf, -4.0f64..4.0, point(), any::<bool>(), any::<bool>()).prop_map(
        |(path, rot, shift, moved, reverse)| {
            if moved || reverse {
                PathSpec::Transformed {
                    path: Box::new(path),
                    rotation_rad: rot,
                    translation: shift,
                    reverse,
                }
            } else {
                path
            }
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The index returns exactly what the scan of every piece returns, bit for bit.
    #[test]
    fn the_index_finds_exactly_what_the_scan_finds(
        spec in any_path(),
        queries in prop::collection::vec((-0.3f64..0.3, -0.3f64..0.3), 1..40),
    ) {
        let Ok(path) = ArteryPath::from_spec(&spec) else {
            // Coinciding random points, a fillet that does not fit: not a course.
            return Ok(());
        };
        for (x, z) in queries {
            let q = SurfacePoint::new(x, z);
            prop_assert_eq!(path.nearest(q), path.nearest_by_scan(q));
        }
        // On the pieces' own points and corners, where ties are likeliest.
        for q in path.sample(0.003) {
            prop_assert_eq!(path.nearest(q), path.nearest_by_scan(q));
        }
    }
}

#[test]
fn the_index_matches_the_scan_on_ties_and_odd_queries() {
    // A polyline that doubles back over itself: equal distances to several pieces.
    let p = build(PathSpec::Polyline {
        points: vec![
            SurfacePoint::new(0.0, 0.0),
            SurfacePoint::new(0.1, 0.0),
            SurfacePoint::new(0.0, 0.0001),
            SurfacePoint::new(0.1, 0.0001),
        ],
    });
    for q in [
        SurfacePoint::new(0.05, 0.00005),
        SurfacePoint::new(0.0, 0.0),
        SurfacePoint::new(f64::NAN, 0.0),
        SurfacePoint::new(f64::INFINITY, 0.0),
        SurfacePoint::new(1e6, -1e6),
    ] {
        let (a, b) = (p.nearest(q), p.nearest_by_scan(q));
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "{q:?}");
    }
}
