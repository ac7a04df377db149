//! The searcher on a synthetic bench: an ideal robot (the sensor goes straight to each
//! target at the asked speed), a straight artery pressing the array through the kernel with
//! a periodic pulse, and the seed's element noise.

use proptest::prelude::*;

use super::*;
use crate::sensor::ArrayGeometry;
use crate::signal::kernel_fit::element_kernel;
use crate::test_normals::Normals;
use crate::tracker::TrackerInput;
use crate::types::{ELEMENTS, TactileFrame};

/// A straight artery `z = z0 + tan(h) (x − x0)`, or none.
#[derive(Debug, Clone, Copy)]
struct Artery {
    x0: f64,
    z0: f64,
    heading: f64,
    /// Peak pulse force on the element over it, N.
    amplitude_n: f64,
}

struct Bench {
    artery: Option<Artery>,
    geometry: ArrayGeometry,
    sensor: SurfacePoint,
    target: Option<(SurfacePoint, f64)>,
    t: f64,
    seq: u64,
    rng: Normals,
    period_s: f64,
    /// Every target the searcher asked for.
    asked: Vec<SurfacePoint>,
}

impl Bench {
    fn new(artery: Option<Artery>, start: SurfacePoint, seed: u64) -> Self {
        Self {
            artery,
            geometry: ArrayGeometry::default(),
            sensor: start,
            target: None,
            t: 0.0,
            seq: 0,
            rng: Normals::new(seed),
            period_s: 0.9,
            asked: Vec::new(),
        }
    }

    fn frame(&mut self) -> TactileFrame {
        let phase = (self.t / self.period_s).fract();
        let pulse = (std::f64::consts::PI * phase).sin().powi(4);
        let mut force_n = [0.0; ELEMENTS];
        for (e, f) in force_n.iter_mut().enumerate() {
            let z = self.sensor.z_m + self.geometry.offset_z_m(e as f64);
            let felt = self.artery.map_or(0.0, |a| {
                let line = a.z0 + a.heading.tan() * (self.sensor.x_m - a.x0);
                // The lateral distance shrinks by cos(h) as the line crosses obliquely.
                let u = (z - line) * a.heading.cos();
                a.amplitude_n * element_kernel(u, 0.005, self.geometry.pitch_m)
            });
            *f = 0.5 + felt * pulse + self.geometry.noise_sd_n * self.rng.next();
        }
        self.seq += 1;
        TactileFrame {
            t_s: self.t,
            seq: self.seq,
            force_n,
        }
    }

    /// Run until the searcher ends (or `limit_s`); returns the outcome and every event.
    fn run(&mut self, s: &mut Searcher, limit_s: f64) -> (Option<SearchOutcome>, Vec<SearchEvent>) {
        let dt = 1.0 / self.geometry.sample_rate_hz;
        let mut events = Vec::new();
        while self.t < limit_s {
            let frame = self.frame();
            let settled = self.target.is_none();
            let out = s.step(&TrackerInput {
                frame: &frame,
                sensor: self.sensor,
                settled,
                loaded_sensor: None,
            });
            if let Some(e) = out.event {
                events.push(e);
            }
            match out.motion {
                MotionCommand::MoveTo { target, speed_m_s } => {
                    if self.asked.last() != Some(&target) {
                        self.asked.push(target);
                    }
                    self.target = Some((target, speed_m_s));
                }
                MotionCommand::Hold => self.target = None,
            }
            if let Some((target, v)) = self.target {
                let d = self.sensor.distance_to(&target);
                let step = v * dt;
                if d <= step {
                    self.sensor = target;
                    self.target = None;
                } else {
                    let k = step / d;
                    self.sensor = SurfacePoint::new(
                        self.sensor.x_m + k * (target.x_m - self.sensor.x_m),
                        self.sensor.z_m + k * (target.z_m - self.sensor.z_m),
                    );
                }
            }
            self.t += dt;
            if matches!(events.last(), Some(SearchEvent::Finished(_))) {
                break;
            }
        }
        (s.outcome().copied(), events)
    }
}

fn region() -> Region {
    Region::square(SurfacePoint::new(0.0, 0.0), 0.04).expect("region")
}

fn searcher(method: SearchMethod) -> Searcher {
    Searcher::new(
        SearchParams::default(),
        ArrayGeometry::default(),
        region(),
        method,
    )
    .expect("searcher")
}

fn lateral_error(a: &Artery, p: SurfacePoint) -> f64 {
    let line = a.z0 + a.heading.tan() * (p.x_m - a.x0);
    (p.z_m - line) * a.heading.cos()
}

#[test]
fn finds_an_oblique_artery_and_seeds_on_it() {
    let artery = Artery {
        x0: 0.0,
        z0: 0.012,
        heading: -35f64.to_radians(),
        amplitude_n: 0.08,
    };
    for method in [SearchMethod::Search, SearchMethod::Raster] {
        let mut bench = Bench::new(Some(artery), region().centre(), 7);
        let mut s = searcher(method);
        let (outcome, events) = bench.run(&mut s, 200.0);
        let Some(SearchOutcome::Found {
            seeds, heading_rad, ..
        }) = outcome
        else {
            panic!("{method:?}: {outcome:?}");
        };
        for seed in seeds {
            let e = lateral_error(&artery, seed.point);
            assert!(e.abs() < 0.5e-3, "{method:?}: seed {seed:?} {e} m off");
        }
        assert!(
            seeds[1].point.distance_to(&seeds[0].point) >= 0.01
                && seeds[1].point.x_m >= seeds[0].point.x_m
        );
        assert!((heading_rad - artery.heading).abs() < 3f64.to_radians());
        assert!(events.iter().any(|e| matches!(e, SearchEvent::Look(_))));
        assert!(bench.asked.iter().all(|p| region().contains(*p)));
    }
}

#[test]
fn a_named_course_direction_finds_a_steep_artery_the_default_cone_leaves_out() {
    let artery = Artery {
        x0: 0.0,
        z0: 0.004,
        heading: 70f64.to_radians(),
        amplitude_n: 0.08,
    };
    let mut bench = Bench::new(Some(artery), region().centre(), 9);
    let mut s = searcher(SearchMethod::Search)
        .expect_heading(65f64.to_radians())
        .expect("heading");
    let (outcome, _) = bench.run(&mut s, 200.0);
    let Some(SearchOutcome::Found {
        seeds, heading_rad, ..
    }) = outcome
    else {
        panic!("{outcome:?}");
    };
    assert!(
        (heading_rad - artery.heading).abs() < 5f64.to_radians(),
        "{heading_rad}"
    );
    for seed in seeds {
        let e = lateral_error(&artery, seed.point);
        assert!(e.abs() < 0.5e-3, "seed {seed:?} {e} m off");
    }
    assert!(
        searcher(SearchMethod::Search)
            .expect_heading(85f64.to_radians())
            .is_err()
    );
    assert!(
        searcher(SearchMethod::Search)
            .expect_heading(f64::NAN)
            .is_err()
    );
}

#[test]
fn an_empty_region_ends_not_found_at_rest() {
    let mut bench = Bench::new(None, region().centre(), 3);
    let mut s = searcher(SearchMethod::Search);
    let (outcome, _) = bench.run(&mut s, 200.0);
    let Some(SearchOutcome::NotFound {
        reason,
        p_present,
        weakest_felt_n,
        looks,
        ..
    }) = outcome
    else {
        panic!("{outcome:?}");
    };
    assert_eq!(reason, NotFoundReason::NothingPulses);
    assert!(p_present <= 0.05 && looks >= 3, "{p_present} after {looks}");
    // 4 s windows at the seed's noise: 8 · 0.012 · √(2/400) ≈ 6.8 mN.
    assert!((weakest_felt_n - 6.8e-3).abs() < 0.5e-3, "{weakest_felt_n}");
    // At rest from then on.
    let frame = bench.frame();
    let out = s.step(&TrackerInput {
        frame: &frame,
        sensor: bench.sensor,
        settled: true,
        loaded_sensor: None,
    });
    assert_eq!(out.motion, MotionCommand::Hold);
}

#[test]
fn stop_mid_search_ends_at_rest() {
    let artery = Artery {
        x0: 0.0,
        z0: -0.015,
        heading: 0.3,
        amplitude_n: 0.08,
    };
    let mut bench = Bench::new(Some(artery), region().centre(), 5);
    let mut s = searcher(SearchMethod::Search);
    bench.run(&mut s, 3.0);
    assert!(s.outcome().is_none());
    s.stop();
    let (outcome, events) = bench.run(&mut s, 4.0);
    assert!(
        matches!(outcome, Some(SearchOutcome::Stopped { .. })),
        "{outcome:?}"
    );
    assert!(matches!(
        events.last(),
        Some(SearchEvent::Finished(SearchOutcome::Stopped { .. }))
    ));
    assert!(bench.target.is_none());
}

#[test]
fn an_unreachable_look_is_not_asked_again() {
    let mut bench = Bench::new(None, region().centre(), 11);
    let mut s = searcher(SearchMethod::Raster);
    let frame = bench.frame();
    let out = s.step(&TrackerInput {
        frame: &frame,
        sensor: bench.sensor,
        settled: true,
        loaded_sensor: None,
    });
    let MotionCommand::MoveTo { target: first, .. } = out.motion else {
        panic!("{out:?}");
    };
    s.target_unreachable();
    bench.run(&mut s, 200.0);
    assert!(!bench.asked.contains(&first), "{first:?} asked again");
    assert!(s.outcome().is_some());
}

#[test]
fn bad_parameters_are_named() {
    let p = SearchParams {
        p_detect: 1.5,
        ..SearchParams::default()
    };
    let e = Searcher::new(p, ArrayGeometry::default(), region(), SearchMethod::Search)
        .expect_err("refused");
    assert!(e.to_string().contains("p_detect"), "{e}");
    let p = SearchParams {
        first_look_s: 2.0,
        ..SearchParams::default()
    };
    assert!(p.validate().is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Wherever the region and the artery, every look asked for lies inside the region.
    #[test]
    fn never_asks_for_a_look_outside_the_region(
        cx in -0.03f64..0.03, cz in -0.03f64..0.03, side in 0.01f64..0.05,
        offset in -0.5f64..0.5, heading in -1.0f64..1.0, present in any::<bool>(),
        seed in 0u64..1000,
    ) {
        let region = Region::square(SurfacePoint::new(cx, cz), side).expect("region");
        let artery = present.then_some(Artery {
            x0: cx,
            z0: cz + offset * side,
            heading,
            amplitude_n: 0.08,
        });
        let mut bench = Bench::new(artery, region.centre(), seed);
        let mut s = Searcher::new(
            SearchParams::default(),
            ArrayGeometry::default(),
            region,
            SearchMethod::Search,
        )
        .expect("searcher");
        bench.run(&mut s, 60.0);
        for p in &bench.asked {
            prop_assert!(region.contains(*p), "{p:?} outside {region:?}");
        }
    }
}
