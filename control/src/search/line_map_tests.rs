use super::*;

fn settings() -> MapSettings {
    MapSettings {
        max_heading_rad: 60f64.to_radians(),
        heading_centre_rad: 0.0,
        offset_step_m: 0.25e-3,
        heading_step_rad: 1f64.to_radians(),
        reach_m: 0.01,
        p_detect: 0.95,
        p_false: 0.002,
        place_floor_m: 0.3e-3,
        prior_absent: 0.5,
    }
}

fn region() -> Region {
    Region::square(SurfacePoint::new(0.01, -0.02), 0.04).expect("region")
}

/// Where the line of heading `h` through `(x0, z0)` crosses `x`.
fn on_line(h: f64, x0: f64, z0: f64, x: f64) -> f64 {
    z0 + h.tan() * (x - x0)
}

#[test]
fn two_felt_crossings_fix_the_line() {
    let mut map = LineMap::new(&region(), settings());
    let (h, x0, z0) = (25f64.to_radians(), 0.01, -0.015);
    for (lx, lz) in [(0.0, -0.02), (0.02, -0.01)] {
        let xi = on_line(h, x0, z0, lx) - lz;
        assert!(xi.abs() < 0.01);
        map.observe(
            SurfacePoint::new(lx, lz),
            LookReading::Felt {
                offset_z_m: xi,
                se_m: 0.2e-3,
            },
        );
    }
    let s = map.summary();
    assert!(s.p_present > 0.999, "{s:?}");
    // Two crossings 20 mm apart, each ±0.36 mm: the heading to about 1.5 degrees.
    assert!((s.heading_rad - h).abs() < 2f64.to_radians(), "{s:?}");
    // A few lines through one point only (the other taken for a false alarm) widen the SD;
    // the credible mass about the best heading is what the search stops on.
    let (bh, _) = map.best_line();
    let mass = map.heading_mass_within(bh, 3f64.to_radians());
    assert!(mass > 0.95 && mass <= s.p_present + 1e-12, "{mass}");
    assert!((s.offset_m - z0).abs() < 0.5e-3, "{s:?}");
    let (_, bz) = map.best_line();
    assert!((bh - h).abs() < 1.5f64.to_radians() && (bz - z0).abs() < 0.5e-3);
    // Its SD too carries the tails, but is far below the one-point case below.
    assert!(map.crossing_sd_m(0.0) < 2e-3, "{}", map.crossing_sd_m(0.0));
    // One crossing alone leaves the heading open: the SD of the other crossing is large.
    let mut one = LineMap::new(&region(), settings());
    one.observe(
        SurfacePoint::new(0.0, -0.02),
        LookReading::Felt {
            offset_z_m: on_line(h, x0, z0, 0.0) + 0.02,
            se_m: 0.2e-3,
        },
    );
    assert!(
        one.crossing_sd_m(0.02) > 5e-3,
        "{}",
        one.crossing_sd_m(0.02)
    );
    assert!(one.summary().heading_sd_rad > 20f64.to_radians());
}

#[test]
fn misses_across_the_middle_column_say_no_artery() {
    let mut map = LineMap::new(&region(), settings());
    let r = region();
    let c = r.centre();
    // Four looks across the middle column: a miss rules out lines within the inner reach
    // (10 − 4 mm), so together they cover every line of the prior, some twice.
    let looks = [-0.015, -0.005, 0.005, 0.015];
    for dz in looks {
        map.observe(SurfacePoint::new(c.x_m, c.z_m + dz), LookReading::Nothing);
    }
    let s = map.summary();
    // The same posterior counted by hand over the grid's offsets (every heading crosses the
    // middle column at its offset): each line keeps 0.05 per look that covers it.
    let inner = 0.01 - FLANK_MARGIN_M;
    let lines: f64 = (0..=160)
        .map(|i| {
            let o = -0.02 + 0.04 * i as f64 / 160.0;
            let k = looks.iter().filter(|z| (o - **z).abs() <= inner).count();
            assert!(k >= 1, "offset {o} uncovered");
            0.05f64.powi(k as i32)
        })
        .sum::<f64>()
        / 161.0;
    let expected = 0.5 * lines / (0.5 * lines + 0.5 * 0.998f64.powi(4));
    assert!(
        (s.p_present - expected).abs() < 1e-9,
        "{} vs {expected}",
        s.p_present
    );
    assert!(s.p_present < 0.05, "{}", s.p_present);
    // A look that misses only part of the lines leaves more doubt.
    let mut part = LineMap::new(&region(), settings());
    part.observe(c, LookReading::Nothing);
    assert!(part.summary().p_present > 0.2);
}

#[test]
fn information_prefers_the_unknown_crossing_and_is_zero_where_nothing_can_be_learnt() {
    let mut map = LineMap::new(&region(), settings());
    let felt_at = SurfacePoint::new(0.01, -0.02);
    map.observe(
        felt_at,
        LookReading::Felt {
            offset_z_m: 0.0,
            se_m: 0.2e-3,
        },
    );
    let mut p = Vec::new();
    map.probabilities(&mut p);
    let mut bins = vec![0.0; 40];
    let again = map.look_information(&p, felt_at, 0.2e-3, &mut bins);
    let along = map.look_information(&p, SurfacePoint::new(0.025, -0.02), 0.2e-3, &mut bins);
    assert!(along > again + 0.5, "again {again}, along {along}");
    // A look far beyond every line left: nothing to learn.
    let mut sure = LineMap::new(&region(), settings());
    for x in [0.0, 0.02] {
        sure.observe(
            SurfacePoint::new(x, -0.02),
            LookReading::Felt {
                offset_z_m: 0.0,
                se_m: 0.1e-3,
            },
        );
    }
    sure.probabilities(&mut p);
    let off = sure.look_information(&p, SurfacePoint::new(0.01, 0.1), 0.2e-3, &mut bins);
    assert!(off < 1e-3, "{off}");
}

#[test]
fn a_single_heading_and_a_flat_prior_do_not_break_the_grid() {
    let mut s = settings();
    s.max_heading_rad = 0.0;
    let mut map = LineMap::new(&region(), s);
    assert_eq!(map.cells(), 161);
    map.observe(
        SurfacePoint::new(0.01, -0.02),
        LookReading::Felt {
            offset_z_m: 0.004,
            se_m: 0.2e-3,
        },
    );
    let sum = map.summary();
    assert!(sum.heading_sd_rad == 0.0 && sum.heading_rad == 0.0);
    assert!((sum.offset_m - -0.016).abs() < 0.5e-3, "{sum:?}");
    assert!(sum.p_present.is_finite() && sum.offset_sd_m.is_finite());
}

#[test]
fn the_picture_puts_the_probability_on_the_felt_line() {
    let mut map = LineMap::new(&region(), settings());
    let r = region();
    // One felt point and one at 20 mm along x: a line at heading 0 through z = -0.015.
    for x in [0.0, 0.02] {
        map.observe(
            SurfacePoint::new(x, -0.02),
            LookReading::Felt {
                offset_z_m: 0.005,
                se_m: 0.1e-3,
            },
        );
    }
    let (nx, nz) = (8, 20);
    let occ = map.occupancy(&r, nx, nz);
    for c in 0..nx {
        let col = &occ[c * nz..(c + 1) * nz];
        let total: f64 = col.iter().sum();
        assert!(
            (total - map.summary().p_present).abs() < 0.02,
            "column {c}: {total}"
        );
        // z = -0.015 lies in row (−0.015 − (−0.04)) / 0.002 = 12.5 → row 12.
        let (best, _) = col
            .iter()
            .enumerate()
            .fold((0, 0.0), |b, (k, &v)| if v > b.1 { (k, v) } else { b });
        assert_eq!(best, 12, "column {c}: {col:?}");
    }
    assert!(map.occupancy(&r, 0, 5).is_empty());
}
