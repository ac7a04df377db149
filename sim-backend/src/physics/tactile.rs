//! What each tactile element feels: the static contact load, buried lumps, and the tube's
//! pulsatile pressure, with the rigid-contact correction and the crossing angle.
//!
//! The sensor body is a rigid cylinder lying along tissue `z`, pressed into the tissue by a
//! normal force `N`; its contact patch is the body's length times the chord width of the
//! indented cylinder. The pulsatile kernel ([`super::kernel`]) is integrated exactly over
//! each element's rectangle using the *local* distance to the artery, so the crossing angle
//! between artery and element line enters by itself: as the artery turns toward `z` the
//! distance changes more slowly along the line and the pressure spreads over more elements.
//! A rigid body held by a constant load cannot take a net pulsatile force, so the kernel's
//! net force over the patch is taken back uniformly over the patch (the body lifts slightly,
//! unloading every point of a Winkler-like foam equally). That pushes the far elements
//! further out of phase, as the seed saw.

use control::frames::SurfacePoint;
use control::types::ELEMENTS;

use super::kernel::{rectangle_integral, strength_n};
use crate::scene::{ArteryPath, ArterySpec, LumpSpec, SensorSpec};

/// The array as it really is (the robot's belief is the configuration's `sensor`).
#[derive(Debug, Clone)]
pub struct TactileModel {
    path: ArteryPath,
    artery: ArterySpec,
    sensor: SensorSpec,
    lumps: Vec<LumpSpec>,
    /// +1: element 0 at the most negative `z`, and the body's distal end beyond it.
    direction: f64,
    cache: Option<Cached>,
    /// The FEM kernel, when the scene chose it (`None`: analytic).
    fem: Option<std::sync::Arc<crate::fem::kernel::Kernel>>,
}

/// The per-element shape factors at one sensor pose.
#[derive(Debug, Clone, Copy)]
struct Cached {
    centre: SurfacePoint,
    width_m: f64,
    /// Pulsatile force per pascal of lumen pressure on each element, N/Pa.
    pulse_n_per_pa: [f64; ELEMENTS],
    /// Share of the normal force carried by each element (static contact and lumps).
    static_share: [f64; ELEMENTS],
}

/// The contact between the sensor body and the tissue at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Normal force on the body, N (0 when lifted off).
    pub normal_n: f64,
    /// How far the body's bottom edge is pressed below the surface, m.
    pub indentation_m: f64,
}

/// Poses closer than this reuse the cached shape factors (well below the encoders' 0.03 mm).
const CACHE_MOVE_M: f64 = 2e-6;

impl TactileModel {
    pub fn new(
        path: ArteryPath,
        artery: &ArterySpec,
        sensor: &SensorSpec,
        lumps: &[LumpSpec],
        direction: f64,
    ) -> Self {
        Self {
            path,
            artery: artery.clone(),
            sensor: *sensor,
            lumps: lumps.to_vec(),
            direction: if direction < 0.0 { -1.0 } else { 1.0 },
            cache: None,
            fem: None,
        }
    }

    /// Use an FEM kernel (computed for this artery's depth, radius and wall) instead of the
    /// analytic one.
    pub fn with_fem_kernel(mut self, kernel: std::sync::Arc<crate::fem::kernel::Kernel>) -> Self {
        self.fem = Some(kernel);
        self.cache = None;
        self
    }

    pub fn path(&self) -> &ArteryPath {
        &self.path
    }

    /// Lateral offset of element `i`'s centre from the sensor centre, m.
    fn element_z(&self, i: usize) -> f64 {
        self.direction * (i as f64 - (ELEMENTS as f64 - 1.0) / 2.0) * self.sensor.pitch_m
    }

    /// The body's extent along `z` relative to the sensor centre: (distal end, proximal end).
    fn body_span(&self) -> (f64, f64) {
        let half_line = ELEMENTS as f64 * self.sensor.pitch_m / 2.0;
        let distal = half_line + self.sensor.distal_margin_m;
        let proximal = self.sensor.body_length_m - distal;
        (-self.direction * distal, self.direction * proximal)
    }

    /// Chord width of the cylinder indented by `indentation` (at least one element's
    /// length: the elements are on the bottom edge and touch first).
    fn contact_width(&self, indentation: f64) -> f64 {
        let d = self.sensor.body_diameter_m;
        let delta = indentation.clamp(0.0, d / 2.0);
        let chord = 2.0 * (delta * (d - delta)).sqrt();
        chord.max(self.element_length())
    }

    fn element_length(&self) -> f64 {
        self.sensor.element_area_m2 / self.sensor.pitch_m
    }

    /// Depth and inner radius of the tube at arc length `s`.
    fn tube_at(&self, s: f64) -> (f64, f64) {
        let w = (s / self.path.length_m()).clamp(0.0, 1.0);
        let lerp = |a: f64, b: Option<f64>| a + (b.unwrap_or(a) - a) * w;
        (
            lerp(self.artery.depth_m, self.artery.depth_end_m),
            lerp(self.artery.inner_radius_m, self.artery.inner_radius_end_m),
        )
    }

    /// Pulsatile force per pascal on a rectangle centred at `c`, half-sizes along `x` and
    /// `z`, N/Pa.
    fn rectangle_n_per_pa(&self, c: SurfacePoint, half_x: f64, half_z: f64) -> f64 {
        let near = self.path.nearest(c);
        let (h, a) = self.tube_at(near.s_m);
        // The tube's unit normal in (x, z): moving along x (z) changes the distance by its
        // x (z) component.
        let (gx, gz) = (-near.heading_rad.sin(), near.heading_rad.cos());
        if let Some(k) = &self.fem {
            return k.rectangle_integral(near.offset_m, gx, gz, half_x, half_z);
        }
        strength_n(1.0, a) * rectangle_integral(near.offset_m, gx, gz, half_x, half_z, h)
    }

    fn shapes(&mut self, centre: SurfacePoint, indentation: f64) -> Cached {
        let width = self.contact_width(indentation);
        if let Some(c) = self.cache
            && c.centre.distance_to(&centre) < CACHE_MOVE_M
            && (c.width_m - width).abs() < 0.02 * c.width_m
        {
            return c;
        }
        let half_len = self.element_length() / 2.0;
        let half_pitch = self.sensor.pitch_m / 2.0;
        let mut pulse = [0.0; ELEMENTS];
        for (i, p) in pulse.iter_mut().enumerate() {
            let c = SurfacePoint::new(centre.x_m, centre.z_m + self.element_z(i));
            *p = self.rectangle_n_per_pa(c, half_len, half_pitch);
        }
        // The net pulsatile force over the whole patch, in strips about one pitch long.
        let (a, b) = self.body_span();
        let (lo, hi) = (a.min(b), a.max(b));
        let strips = ((hi - lo) / self.sensor.pitch_m).ceil().max(1.0) as usize;
        let strip = (hi - lo) / strips as f64;
        let mut net = 0.0;
        for k in 0..strips {
            let z = lo + (k as f64 + 0.5) * strip;
            let c = SurfacePoint::new(centre.x_m, centre.z_m + z);
            net += self.rectangle_n_per_pa(c, width / 2.0, strip / 2.0);
        }
        let patch_area = (hi - lo) * width;
        let element_area = self.sensor.element_area_m2;
        let take_back = net * element_area / patch_area;
        let mut static_share = [element_area / patch_area; ELEMENTS];
        for (i, (p, s)) in pulse.iter_mut().zip(static_share.iter_mut()).enumerate() {
            *p -= take_back;
            let c = SurfacePoint::new(centre.x_m, centre.z_m + self.element_z(i));
            *s *= 1.0 + self.lump_bump(c);
        }
        let cached = Cached {
            centre,
            width_m: width,
            pulse_n_per_pa: pulse,
            static_share,
        };
        self.cache = Some(cached);
        cached
    }

    /// Fractional extra contact pressure over the lumps at `c`: a buried stiff inclusion
    /// concentrates the load with the profile of a point load seen through `depth`.
    fn lump_bump(&self, c: SurfacePoint) -> f64 {
        self.lumps
            .iter()
            .map(|l| {
                let rho2 = (c.x_m - l.centre.x_m).powi(2) + (c.z_m - l.centre.z_m).powi(2);
                l.pressure_gain * (1.0 + rho2 / (l.depth_m * l.depth_m)).powf(-1.5)
            })
            .sum()
    }

    /// Noise-free element forces for the sensor centred at `centre` (true position, tissue
    /// frame) with `contact`, under a lumen pressure of `pulse_pa` above diastole, N.
    pub fn forces(
        &mut self,
        centre: SurfacePoint,
        contact: Contact,
        pulse_pa: f64,
    ) -> [f64; ELEMENTS] {
        if contact.normal_n <= 0.0 {
            return [0.0; ELEMENTS];
        }
        let shapes = self.shapes(centre, contact.indentation_m);
        let mut out = [0.0; ELEMENTS];
        for (i, f) in out.iter_mut().enumerate() {
            // The tissue can push but not pull: a strong negative flank lifts the element off.
            *f = (contact.normal_n * shapes.static_share[i] + pulse_pa * shapes.pulse_n_per_pa[i])
                .max(0.0);
        }
        out
    }

    /// Pulsatile force per pascal on each element at a pose (for tests and plots).
    pub fn pulse_shape(&mut self, centre: SurfacePoint, indentation_m: f64) -> [f64; ELEMENTS] {
        self.shapes(centre, indentation_m).pulse_n_per_pa
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{PathSpec, Turn};

    fn seed_tube(path: PathSpec) -> TactileModel {
        let artery = ArterySpec {
            path: path.clone(),
            depth_m: 0.005,
            depth_end_m: None,
            inner_radius_m: 0.0015,
            inner_radius_end_m: None,
            wall_m: 0.001,
            kernel: Default::default(),
        };
        TactileModel::new(
            ArteryPath::from_spec(&path).unwrap(),
            &artery,
            &SensorSpec::default(),
            &[],
            1.0,
        )
    }

    fn straight_along_x() -> PathSpec {
        PathSpec::Straight {
            start: SurfacePoint::new(-0.1, 0.0),
            heading_rad: 0.0,
            length_m: 0.2,
        }
    }

    #[test]
    fn seed_tube_swings_about_six_centinewtons_on_the_centred_elements() {
        // Fig. 2: "two of the elements can be seen to vary up to 0.06 N".
        let mut m = seed_tube(straight_along_x());
        let shape = m.pulse_shape(SurfacePoint::new(0.0, 0.0), 0.003);
        let swing = |i: usize| shape[i] * 100e3;
        assert!((0.05..0.065).contains(&swing(4)), "{}", swing(4));
        assert!((swing(4) - swing(5)).abs() < 1e-3);
        // Elements beyond the tube's depth move out of phase.
        assert!(swing(1) < 0.0 && swing(8) < 0.0, "{shape:?}");
    }

    #[test]
    fn rigid_body_takes_no_net_pulsatile_force() {
        for z in [0.0, 0.004, -0.007, 0.015] {
            let mut m = seed_tube(straight_along_x());
            m.pulse_shape(SurfacePoint::new(0.0, z), 0.003);
            // Integrate the corrected pressure over the whole patch: elements cover only
            // part of it, so check with the model's own strips.
            let c = m.cache.unwrap();
            let (a, b) = m.body_span();
            let (lo, hi) = (a.min(b), a.max(b));
            let n = 340;
            let dz = (hi - lo) / n as f64;
            let mut net = 0.0;
            let take_back_per_area = {
                let elem = m.sensor.element_area_m2;
                let raw4 = m.rectangle_n_per_pa(
                    SurfacePoint::new(0.0, z + m.element_z(4)),
                    m.element_length() / 2.0,
                    m.sensor.pitch_m / 2.0,
                );
                (raw4 - c.pulse_n_per_pa[4]) / elem
            };
            for k in 0..n {
                let zz = z + lo + (k as f64 + 0.5) * dz;
                net += m.rectangle_n_per_pa(SurfacePoint::new(0.0, zz), c.width_m / 2.0, dz / 2.0)
                    - take_back_per_area * c.width_m * dz;
            }
            let scale = m.rectangle_n_per_pa(SurfacePoint::new(0.0, 0.0), c.width_m / 2.0, 0.001);
            assert!(net.abs() < 1e-3 * scale, "z {z}: net {net} vs {scale}");
        }
    }

    #[test]
    fn localizes_under_the_right_element_with_sign_convention() {
        let mut m = seed_tube(straight_along_x());
        // The tube lies 5 mm to -z of the sensor centre: element 2 or 3 (direction +1 puts
        // element 0 at the most negative z).
        let shape = m.pulse_shape(SurfacePoint::new(0.0, 0.005), 0.003);
        let best = (0..ELEMENTS)
            .max_by(|&a, &b| shape[a].total_cmp(&shape[b]))
            .unwrap();
        assert_eq!(best, 2, "{shape:?}");
    }

    #[test]
    fn turning_toward_the_line_spreads_the_pulse() {
        let shape_at = |heading: f64| {
            let mut m = seed_tube(PathSpec::Straight {
                start: SurfacePoint::new(-0.1 * heading.cos(), -0.1 * heading.sin()),
                heading_rad: heading,
                length_m: 0.2,
            });
            m.pulse_shape(SurfacePoint::new(0.0, 0.0), 0.003)
        };
        let peak_and_width = |s: [f64; ELEMENTS]| {
            let peak = s.iter().cloned().fold(f64::MIN, f64::max);
            let positive = s.iter().filter(|&&v| v > 0.3 * peak).count();
            (peak, positive)
        };
        let (p0, w0) = peak_and_width(shape_at(0.0));
        let (p60, w60) = peak_and_width(shape_at(60f64.to_radians()));
        assert!(w60 > w0, "{w0} {w60}");
        assert!(p60 < p0, "{p0} {p60}");
        // Nearly parallel: every element sees about the same pressure; nothing localizes.
        let s89 = shape_at(89f64.to_radians());
        let spread = s89.iter().cloned().fold(f64::MIN, f64::max)
            - s89.iter().cloned().fold(f64::MAX, f64::min);
        assert!(spread < 0.1 * p0, "{s89:?}");
    }

    #[test]
    fn curved_path_gives_finite_forces_everywhere() {
        let mut m = seed_tube(PathSpec::Arc {
            radius_m: 0.08,
            length_m: 0.26,
            chord_centre: SurfacePoint::default(),
            turn: Turn::Left,
        });
        for i in 0..200 {
            let c = SurfacePoint::new(
                -0.1 + i as f64 * 0.001,
                -0.08 + (i as f64 * 0.37).sin() * 0.05,
            );
            let f = m.forces(
                c,
                Contact {
                    normal_n: 2.9,
                    indentation_m: 0.003,
                },
                100e3,
            );
            assert!(f.iter().all(|v| v.is_finite() && *v >= 0.0), "{f:?}");
        }
    }

    #[test]
    fn lifted_off_sensor_feels_nothing() {
        let mut m = seed_tube(straight_along_x());
        let f = m.forces(
            SurfacePoint::new(0.0, 0.0),
            Contact {
                normal_n: 0.0,
                indentation_m: 0.0,
            },
            100e3,
        );
        assert_eq!(f, [0.0; ELEMENTS]);
    }
}
