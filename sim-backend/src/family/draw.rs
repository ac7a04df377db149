//! Drawing one scene from (family, seed): the course, turned and placed so that it can be
//! tracked, then every effect the family names.

use std::f64::consts::{PI, TAU};

use config::{Validate, Validator};
use control::frames::SurfacePoint;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

use super::course::{Layout, draw_local};
use super::{Family, LoadedFamily};
use crate::random::uniform_open;
use crate::scene::{
    ArteryPath, Breathing, Ectopic, LumpSpec, MassSpec, PathSpec, PulseSpec, Scene, ShaftSpec,
    TrackSpec,
};

/// From the course's start to the first placement, m (the sensor rests at the start).
pub const LEAD_M: f64 = 0.01;
/// From the first placement to the second, m (the seed's placements).
pub const PLACEMENT_GAP_M: f64 = 0.01;
/// Course beyond the tracked part, m (room for the tracker to overshoot its end).
pub const TAIL_M: f64 = 0.015;
/// Courses drawn for one scene before the family is declared unsatisfiable.
const ATTEMPTS: usize = 500;
/// Spacing of the points a course is checked at, m.
const CHECK_STEP_M: f64 = 0.001;

/// The generator of one draw: ChaCha8 from the seed, on a stream named by the family (so
/// families drawn with the same seed differ).
fn family_rng(name: &str, seed: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // FNV-1a of the name: stable across builds and platforms.
    let stream = name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    rng.set_stream(stream);
    rng
}

impl LoadedFamily {
    /// The scene of `seed`: the same seed gives the identical scene. Errors name the family
    /// when no course within its limits was found.
    pub fn draw(&self, seed: u64) -> Result<Scene, String> {
        let f = &self.family;
        let mut rng = family_rng(&f.name, seed);
        for _ in 0..ATTEMPTS {
            if let Some((spec, layout)) = draw_course(f, &mut rng) {
                return self.assemble(spec, layout, seed, &mut rng);
            }
        }
        Err(format!(
            "family `{}`: no course within its limits (heading, tightest radius, workspace) in {ATTEMPTS} draws with seed {seed}; widen the limits or narrow the course ranges",
            f.name
        ))
    }

    fn assemble(
        &self,
        spec: PathSpec,
        layout: Layout,
        seed: u64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Scene, String> {
        let f = &self.family;
        let path = ArteryPath::from_spec(&spec).map_err(|e| e.to_string())?;
        let mut s = self.base.clone();
        s.name = format!("{}-{seed}", f.name);
        s.description = format!(
            "Drawn from family `{}` with seed {seed} on the rig of `{}`.",
            f.name, self.base.name
        );
        s.artery.path = spec;
        s.placements = [
            path.at(layout.track_from_m).0,
            path.at(layout.track_from_m + PLACEMENT_GAP_M).0,
        ];
        s.start = Some(path.at(0.0).0);
        s.track = TrackSpec {
            length_m: layout.track_m,
            reason: format!(
                "Drawn by family `{}`: the tracked part stays within {:.0} degrees of x, so the element line (along z) crosses it at 30 degrees or more.",
                f.name,
                f.max_heading_rad.to_degrees()
            ),
        };
        // The base's lumps lay beside its own course.
        s.lumps.clear();
        if let Some(h) = &f.heart {
            let rate = h.rate_hz.draw(rng);
            let pulse_pressure = h.pulse_pressure_pa.draw(rng);
            let diastolic = h.diastolic_pa.draw(rng);
            let interval_sd = h.interval_sd_fraction.draw(rng) / rate;
            let pressure_sd = h.pressure_sd_fraction.draw(rng);
            let ectopic = h.ectopic_probability.draw(rng);
            s.pulse = PulseSpec::Physiological {
                systolic_pa: diastolic + pulse_pressure,
                diastolic_pa: diastolic,
                heart_rate_hz: rate,
                interval_sd_s: interval_sd,
                pressure_sd_fraction: pressure_sd,
                rate_change: None,
                ectopic: (ectopic > 0.0).then_some(Ectopic {
                    probability: ectopic,
                    prematurity: 0.35,
                    pressure_fraction: 0.5,
                }),
            };
        }
        if let Some(a) = &f.artery {
            if let Some(d) = a.depth_m {
                s.artery.depth_m = d.draw(rng);
                s.artery.depth_end_m = None;
            }
            if let Some(r) = a.inner_radius_m {
                s.artery.inner_radius_m = r.draw(rng);
                s.artery.inner_radius_end_m = None;
            }
            if let Some(w) = a.wall_m {
                s.artery.wall_m = w.draw(rng);
            }
        }
        if let Some(n) = f.noise_sd_n {
            s.sensor.noise_sd_n = n.draw(rng);
        }
        if let Some(i) = &f.instrument {
            if let Some(m) = i.mass_kg {
                let mass = m.draw(rng);
                s.mass = Some(match s.mass {
                    Some(old) => MassSpec {
                        mass_kg: mass,
                        ..old
                    },
                    None => MassSpec {
                        mass_kg: mass,
                        height_above_tip_m: 0.03,
                    },
                });
            }
            if i.shaft_diameter_m.is_some() || i.shaft_youngs_modulus_pa.is_some() {
                let mut shaft = s.shaft.unwrap_or(ShaftSpec {
                    diameter_m: 0.0045,
                    youngs_modulus_pa: 200e9,
                    density_kg_m3: 7850.0,
                    length_m: None,
                });
                if let Some(d) = i.shaft_diameter_m {
                    shaft.diameter_m = d.draw(rng);
                }
                if let Some(e) = i.shaft_youngs_modulus_pa {
                    shaft.youngs_modulus_pa = e.draw(rng);
                }
                s.shaft = Some(shaft);
            }
            if let Some(k) = i.pivot_stiffness_n_per_m {
                let mut pivot = s.pivot.unwrap_or_default();
                pivot.lateral_stiffness_n_per_m = Some(k.draw(rng));
                s.pivot = Some(pivot);
            }
        }
        if let Some(l) = &f.lumps {
            for _ in 0..l.count.draw(rng) {
                let along = layout.track_from_m
                    + PLACEMENT_GAP_M
                    + (layout.track_m - PLACEMENT_GAP_M).max(0.0) * uniform_open(rng);
                let side = if uniform_open(rng) < 0.5 { 1.0 } else { -1.0 };
                let offset = side * l.lateral_offset_m.draw(rng);
                let (p, h) = path.at(along);
                s.lumps.push(LumpSpec {
                    centre: SurfacePoint::new(p.x_m - offset * h.sin(), p.z_m + offset * h.cos()),
                    depth_m: l.depth_m.draw(rng),
                    pressure_gain: l.pressure_gain.draw(rng),
                });
            }
        }
        if let Some(b) = &f.breathing {
            s.tissue.breathing = Some(Breathing {
                amplitude_m: b.amplitude_m.draw(rng),
                frequency_hz: b.frequency_hz.draw(rng),
                direction_rad: b.direction_rad.draw(rng),
                phase_rad: TAU * uniform_open(rng),
            });
        }
        let mut v = Validator::new();
        s.validate(&mut v);
        let problems = v.into_problems();
        if !problems.is_empty() {
            let list: Vec<String> = problems
                .iter()
                .map(|p| format!("{}: {}", p.field, p.message))
                .collect();
            return Err(format!(
                "family `{}` seed {seed}: the drawn scene is not valid: {}",
                f.name,
                list.join("; ")
            ));
        }
        Ok(s)
    }
}

/// One course within the family's limits, or `None` to draw again.
fn draw_course(f: &Family, rng: &mut ChaCha8Rng) -> Option<(PathSpec, Layout)> {
    let total: f64 = f.courses.iter().map(|c| c.weight).sum();
    let mut pick = total * uniform_open(rng);
    let kind = f
        .courses
        .iter()
        .find(|c| {
            pick -= c.weight;
            pick < 0.0
        })
        .or(f.courses.last())?;
    let track = f.track_length_m.draw(rng);
    let layout = Layout {
        length_m: LEAD_M + track + TAIL_M,
        track_from_m: LEAD_M,
        track_m: track,
        heading_bound_rad: f.max_heading_rad,
    };
    let local = draw_local(&kind.course, layout, rng);
    let path = ArteryPath::from_spec(&local).ok()?;
    // Corners are bends, their fillets below any course radius: the bound is for curves.
    let curved = !matches!(kind.course, super::CourseFamily::Corners { .. });
    if let Some(r) = f.min_radius_m
        && curved
        && path.largest_curvature_per_m() * r > 1.0 + 1e-9
    {
        return None;
    }
    // The tracked part's headings relative to its own frame, and the start rotations that
    // keep all of them within the bound of x.
    let (lo, hi) = heading_range(&path, layout.track_from_m, layout.track_from_m + track);
    let bound = f.max_heading_rad;
    let (rot_lo, rot_hi) = (-bound - lo, bound - hi);
    if rot_lo > rot_hi {
        return None;
    }
    let mut rotation = rot_lo + (rot_hi - rot_lo) * uniform_open(rng);
    if f.either_direction && uniform_open(rng) < 0.5 {
        rotation += PI;
    }
    // Centre the whole course in the workspace, and check it fits with the margin.
    let turned = PathSpec::Transformed {
        path: Box::new(local.clone()),
        rotation_rad: rotation,
        translation: SurfacePoint::new(0.0, 0.0),
        reverse: false,
    };
    let turned_path = ArteryPath::from_spec(&turned).ok()?;
    let (min, max) = bounding_box(&turned_path);
    let w = &f.workspace;
    let m = w.margin_m;
    if max[0] - min[0] + 2.0 * m > w.x_m.1 - w.x_m.0
        || max[1] - min[1] + 2.0 * m > w.z_m.1 - w.z_m.0
    {
        return None;
    }
    let shift = [
        0.5 * (w.x_m.0 + w.x_m.1) - 0.5 * (min[0] + max[0]),
        0.5 * (w.z_m.0 + w.z_m.1) - 0.5 * (min[1] + max[1]),
    ];
    let spec = PathSpec::Transformed {
        path: Box::new(local),
        rotation_rad: rotation,
        translation: SurfacePoint::new(shift[0], shift[1]),
        reverse: false,
    };
    Some((spec, layout))
}

/// Lowest and highest heading over `from..=to` along the path, unwrapped from the first.
pub(crate) fn heading_range(path: &ArteryPath, from: f64, to: f64) -> (f64, f64) {
    let n = (((to - from) / CHECK_STEP_M).ceil() as usize).max(1);
    let mut prev = path.at(from).1;
    let (mut lo, mut hi) = (prev, prev);
    for i in 1..=n {
        let h = path.at(from + (to - from) * i as f64 / n as f64).1;
        // Unwrap: the change since the last sample lies within ±π.
        let h = prev + (h - prev + PI).rem_euclid(TAU) - PI;
        lo = lo.min(h);
        hi = hi.max(h);
        prev = h;
    }
    (lo, hi)
}

/// The box around the whole course, sampled every millimetre.
pub(crate) fn bounding_box(path: &ArteryPath) -> ([f64; 2], [f64; 2]) {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for p in path.sample(CHECK_STEP_M) {
        min = [min[0].min(p.x_m), min[1].min(p.z_m)];
        max = [max[0].max(p.x_m), max[1].max(p.z_m)];
    }
    (min, max)
}
