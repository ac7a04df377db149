//! The extrapolation line has no preferred axis: any direction, duplicated and collinear
//! points, two points only.

extern crate pulsetrack_control as control;

use std::f64::consts::PI;

use control::frames::SurfacePoint;
use control::tracker::line_fit::PathLine;
use proptest::prelude::*;

fn angle_between(d: [f64; 2], heading: f64) -> f64 {
    let a = d[1].atan2(d[0]) - heading;
    a.sin().atan2(a.cos()).abs()
}

fn along(origin: SurfacePoint, heading: f64, s: f64, offset: f64) -> SurfacePoint {
    let (c, n) = (heading.cos(), heading.sin());
    SurfacePoint::new(
        origin.x_m + s * c - offset * n,
        origin.z_m + s * n + offset * c,
    )
}

proptest! {
    #[test]
    fn collinear_points_in_any_direction_give_that_direction(
        heading in -PI..PI,
        x0 in -0.2..0.2f64,
        z0 in -0.2..0.2f64,
        spacing in 0.001..0.05f64,
        n in 2usize..=4,
    ) {
        let origin = SurfacePoint::new(x0, z0);
        let pts: Vec<SurfacePoint> =
            (0..n).map(|k| along(origin, heading, k as f64 * spacing, 0.0)).collect();
        let line = PathLine::fit(&pts).expect("a line");
        prop_assert!(angle_between(line.direction, heading) < 1e-9);
        prop_assert!((line.direction[0].hypot(line.direction[1]) - 1.0).abs() < 1e-12);
        for p in &pts {
            prop_assert!(line.across(p).abs() < 1e-12);
        }
        // The next target: one spacing beyond the newest point, on the path.
        let next = line.beyond(&pts[n - 1], spacing);
        let want = along(origin, heading, n as f64 * spacing, 0.0);
        prop_assert!(next.distance_to(&want) < 1e-12);
    }

    #[test]
    fn noisy_points_in_any_direction_fit_within_the_noise(
        heading in -PI..PI,
        offsets in proptest::collection::vec(-0.001..0.001f64, 4),
    ) {
        // Four points 10 mm apart with up to 1 mm lateral scatter (the element pitch is 2 mm).
        let pts: Vec<SurfacePoint> = offsets
            .iter()
            .enumerate()
            .map(|(k, &o)| along(SurfacePoint::new(0.05, -0.02), heading, 0.01 * k as f64, o))
            .collect();
        let line = PathLine::fit(&pts).expect("a line");
        // Worst case for 1 mm scatter over a 30 mm span is about 0.1 rad; no axis is favoured.
        prop_assert!(angle_between(line.direction, heading) < 0.12);
    }

    #[test]
    fn duplicated_points_do_not_change_the_line(
        heading in -PI..PI,
        dup in 0usize..3,
    ) {
        let mut pts: Vec<SurfacePoint> = (0..3)
            .map(|k| along(SurfacePoint::default(), heading, 0.01 * k as f64, 0.0))
            .collect();
        pts.insert(dup, pts[dup]);
        let line = PathLine::fit(&pts).expect("a line");
        prop_assert!(angle_between(line.direction, heading) < 1e-9);
    }
}

#[test]
fn two_points_give_the_line_through_them_oriented_from_old_to_new() {
    let a = SurfacePoint::new(0.01, 0.02);
    let b = SurfacePoint::new(0.01, 0.005);
    let line = PathLine::fit(&[a, b]).expect("a line");
    assert!((line.direction[0]).abs() < 1e-15 && (line.direction[1] + 1.0).abs() < 1e-15);
    let next = line.beyond(&b, 0.015);
    assert!(next.distance_to(&SurfacePoint::new(0.01, -0.01)) < 1e-15);
}

#[test]
fn coincident_or_too_few_points_give_no_line() {
    let p = SurfacePoint::new(0.1, -0.1);
    assert_eq!(PathLine::fit(&[]), None);
    assert_eq!(PathLine::fit(&[p]), None);
    assert_eq!(PathLine::fit(&[p, p, p, p]), None);
    assert_eq!(PathLine::fit(&[p, SurfacePoint::new(f64::NAN, 0.0)]), None);
}

#[test]
fn an_isotropic_scatter_falls_back_to_the_chord() {
    // The corners of a square have no principal axis; travel runs oldest to newest.
    let pts = [
        SurfacePoint::new(0.0, 0.0),
        SurfacePoint::new(0.01, 0.0),
        SurfacePoint::new(0.0, 0.01),
        SurfacePoint::new(0.01, 0.01),
    ];
    let line = PathLine::fit(&pts).expect("a line");
    let h = std::f64::consts::FRAC_1_SQRT_2;
    assert!((line.direction[0] - h).abs() < 1e-12 && (line.direction[1] - h).abs() < 1e-12);
}

#[test]
fn a_path_that_doubles_back_is_oriented_by_its_order() {
    // The newest point lies behind the previous one along the line: travel still follows
    // the overall order of the points, not the last pair.
    let pts = [
        SurfacePoint::new(0.0, 0.0),
        SurfacePoint::new(0.0, 0.01),
        SurfacePoint::new(0.0, 0.03),
        SurfacePoint::new(0.0, 0.025),
    ];
    let line = PathLine::fit(&pts).expect("a line");
    assert!(line.direction[1] > 0.999);
}
