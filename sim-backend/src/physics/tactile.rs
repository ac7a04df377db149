//! What each tactile element feels: the static contact load, buried lumps, and the tube's
//! pulsatile pressure, with the rigid-contact correction, the crossing angle and, when the
//! scene models the pin joint, the body's attitude.
//!
//! The sensor body is a rigid cylinder lying along tissue `z`, pressed into the tissue by a
//! normal force `N`; its contact patch is the body's length times the chord width of the
//! indented cylinder. The pulsatile kernel (the half-space one of [`super::kernel`], the
//! FEM's, or the applanated artery's of [`super::applanation`]) is integrated exactly over
//! each element's rectangle using the *local* distance to the tube, so the crossing angle
//! between artery and element line enters by itself: as the artery turns toward `z` the
//! distance changes more slowly along the line and the pressure spreads over more elements.
//! A rigid body held by a constant load cannot take a net pulsatile force, so the kernel's
//! net force over the patch is taken back over the patch (the body lifts slightly,
//! unloading every point of a Winkler-like foam equally); a body that rocks freely on its
//! pin cannot take a pulsatile moment either, and the take-back then also tilts. That pushes
//! the far elements further out of phase, as the seed saw.
//!
//! The attitude ([`Attitude`]): a line tilted against the tissue loads one end harder and
//! may lift the other off (an element off the tissue feels no pulse); a body rocking on a
//! pin across the line keeps its load centre under the pin, shifted by the friction along
//! the line acting below it; an element strip turned off the bottom of the cylinder carries
//! less load.

use std::sync::Arc;

use control::frames::SurfacePoint;
use control::types::ELEMENTS;

use super::{applanation, kernel};
use crate::scene::{ArteryPath, ArterySpec, LumpSpec, PulseCoupling, SensorSpec};

/// Which surface pressure kernel the model integrates.
#[derive(Debug, Clone)]
enum Kernel {
    Analytic,
    Fem(Arc<pulsetrack_fem::kernel::Kernel>),
    Applanation,
}

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
    kernel: Kernel,
}

/// The per-element shape factors at one sensor pose.
#[derive(Debug, Clone, Copy)]
struct Cached {
    centre: SurfacePoint,
    patch_centre: SurfacePoint,
    width_m: f64,
    line_tilt_rad: f64,
    strip_angle_rad: f64,
    rocking: bool,
    /// Pulsatile force per pascal of lumen pressure on each element, N/Pa.
    pulse_n_per_pa: [f64; ELEMENTS],
    /// Where the tube crosses the element line, along it from its centre, m.
    crossing_m: f64,
}

/// How the sensor body sits on the tissue, from the pin joint and the rod's tilt (all zero:
/// level, as the robot's model assumes).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Attitude {
    /// Tilt of the element line against the surface in its own plane, rad; positive lifts
    /// the `+z` end.
    pub line_tilt_rad: f64,
    /// How far the element strip has turned around the cylinder off its bottom, rad.
    pub strip_angle_rad: f64,
    /// The tissue's friction on the sensor along the element line (tissue `z`), N: below a
    /// freely rocking pin it shifts the load centre.
    pub line_friction_n: f64,
    /// The body rocks freely in the line's plane (a pin across the line).
    pub rocking: bool,
    /// From the pin (on the body's axis) down to the element line, m.
    pub pin_height_m: f64,
}

/// The contact between the sensor body and the tissue at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Normal force on the body, N (0 when lifted off).
    pub normal_n: f64,
    /// How far the body's bottom edge is pressed below the surface (under the element
    /// line's centre), m.
    pub indentation_m: f64,
    pub attitude: Attitude,
    /// Centre of the contact patch when it differs from the element line's (a strip turned
    /// off the bottom of the cylinder senses beside it); `None`: the same.
    pub patch_centre: Option<SurfacePoint>,
}

impl Contact {
    /// A level contact with the patch centred on the element line.
    pub fn level(normal_n: f64, indentation_m: f64) -> Self {
        Self {
            normal_n,
            indentation_m,
            attitude: Attitude::default(),
            patch_centre: None,
        }
    }
}

/// Poses closer than this reuse the cached shape factors (well below the encoders' 0.03 mm).
const CACHE_MOVE_M: f64 = 2e-6;
/// Attitudes closer than this reuse them too, rad.
const CACHE_ANGLE_RAD: f64 = 1e-4;

/// The static load along the element line, per unit length, normalised over the body.
#[derive(Debug, Clone, Copy)]
enum LoadProfile {
    Uniform,
    /// Winkler under a tilted line: `(δ − s tan β)⁺`.
    Tilted {
        indentation_m: f64,
        slope: f64,
    },
    /// Linear `a + b s`, clipped at zero (rocking on a pin with the load centre at `m`).
    Linear {
        a: f64,
        b: f64,
    },
}

impl TactileModel {
    pub fn new(
        path: ArteryPath,
        artery: &ArterySpec,
        sensor: &SensorSpec,
        lumps: &[LumpSpec],
        direction: f64,
    ) -> Self {
        let kernel = match artery.kernel {
            crate::scene::PressureKernel::Applanation => Kernel::Applanation,
            // The FEM kernel is attached by `with_fem_kernel`; until then, analytic.
            _ => Kernel::Analytic,
        };
        Self {
            path,
            artery: artery.clone(),
            sensor: *sensor,
            lumps: lumps.to_vec(),
            direction: if direction < 0.0 { -1.0 } else { 1.0 },
            cache: None,
            kernel,
        }
    }

    /// Use an FEM kernel (computed for this artery's depth, radius and wall) instead of the
    /// analytic one.
    pub fn with_fem_kernel(mut self, kernel: Arc<pulsetrack_fem::kernel::Kernel>) -> Self {
        self.kernel = Kernel::Fem(kernel);
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

    /// The body's extent as (lower, upper) `z` offsets.
    fn span(&self) -> (f64, f64) {
        let (a, b) = self.body_span();
        (a.min(b), a.max(b))
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

    /// The tube's signed distance from `c` and its unit normal (x, z components).
    fn tube_from(&self, c: SurfacePoint) -> (f64, f64, f64, f64) {
        let near = self.path.nearest(c);
        (
            near.offset_m,
            -near.heading_rad.sin(),
            near.heading_rad.cos(),
            near.s_m,
        )
    }

    /// Pulsatile force per pascal on a rectangle centred at `c`, half-sizes along `x` and
    /// `z`, N/Pa.
    fn rectangle_n_per_pa(&self, c: SurfacePoint, half_x: f64, half_z: f64) -> f64 {
        let (u, gx, gz, s) = self.tube_from(c);
        let (h, a) = self.tube_at(s);
        match &self.kernel {
            Kernel::Fem(k) => kernel::fem_rectangle_integral(k, u, gx, gz, half_x, half_z),
            Kernel::Analytic => {
                kernel::strength_n(1.0, a)
                    * kernel::rectangle_integral(u, gx, gz, half_x, half_z, h)
            }
            Kernel::Applanation => {
                let outer = a + self.artery.wall_m;
                applanation::rectangle_integral(
                    u,
                    gx,
                    gz,
                    half_x,
                    half_z,
                    applanation::half_width_m(outer),
                    h - outer,
                )
            }
        }
    }

    /// Where along the element line (from its centre) the tube crosses it, clamped to the
    /// body.
    fn crossing(&self, centre: SurfacePoint) -> f64 {
        let (u, _, gz, _) = self.tube_from(centre);
        let (lo, hi) = self.span();
        if gz.abs() < 1e-9 {
            return if u > 0.0 { lo } else { hi };
        }
        (-u / gz).clamp(lo, hi)
    }

    fn profile(&self, contact: &Contact) -> LoadProfile {
        let at = contact.attitude;
        if at.rocking && contact.normal_n > 0.0 {
            // Moments about the pin (above the line's centre): the load centre sits where
            // the friction along the line, acting `pin_height` below the pin, is balanced.
            let m = -at.pin_height_m * at.line_friction_n / contact.normal_n;
            let (lo, hi) = self.span();
            let l = hi - lo;
            let s1 = (hi * hi - lo * lo) / 2.0;
            let s2 = (hi.powi(3) - lo.powi(3)) / 3.0;
            let det = l * s2 - s1 * s1;
            return LoadProfile::Linear {
                a: (s2 - m * s1) / det,
                b: (l * m - s1) / det,
            };
        }
        if at.line_tilt_rad != 0.0 {
            return LoadProfile::Tilted {
                indentation_m: contact.indentation_m,
                slope: at.line_tilt_rad.tan(),
            };
        }
        LoadProfile::Uniform
    }

    /// The static load per unit length at `s` along the line, relative to a level body's
    /// (1 everywhere on a level body).
    fn relative_load(&self, profile: LoadProfile, s: f64) -> f64 {
        let (lo, hi) = self.span();
        if s < lo - 1e-12 || s > hi + 1e-12 {
            return 0.0;
        }
        let l = hi - lo;
        match profile {
            LoadProfile::Uniform => 1.0,
            LoadProfile::Tilted {
                indentation_m,
                slope,
            } => {
                // Normalised by the integral of (δ − s tan β)⁺ over the body.
                let d = |z: f64| indentation_m - z * slope;
                let integral = clipped_linear_integral(d(lo), d(hi), l);
                if integral <= 0.0 {
                    return 0.0;
                }
                d(s).max(0.0) * l / integral
            }
            LoadProfile::Linear { a, b } => {
                let integral = clipped_linear_integral(a + b * lo, a + b * hi, l);
                if integral <= 0.0 {
                    return 0.0;
                }
                (a + b * s).max(0.0) * l / integral
            }
        }
    }

    fn shapes(&mut self, centre: SurfacePoint, contact: &Contact) -> Cached {
        let width = self.contact_width(contact.indentation_m);
        let patch_centre = contact.patch_centre.unwrap_or(centre);
        let at = contact.attitude;
        if let Some(c) = self.cache
            && c.centre.distance_to(&centre) < CACHE_MOVE_M
            && c.patch_centre.distance_to(&patch_centre) < CACHE_MOVE_M
            && (c.width_m - width).abs() < 0.02 * c.width_m
            && (c.line_tilt_rad - at.line_tilt_rad).abs() < CACHE_ANGLE_RAD
            && (c.strip_angle_rad - at.strip_angle_rad).abs() < CACHE_ANGLE_RAD
            && c.rocking == at.rocking
        {
            return c;
        }
        // Where the body touches: a tilted line lifts off where (δ − s tan β) < 0; the pulse
        // reaches only what touches.
        let touching = |s: f64| match at.line_tilt_rad {
            t if t != 0.0 => contact.indentation_m - s * t.tan() > 0.0,
            _ => true,
        };
        let half_len = self.element_length() / 2.0;
        let half_pitch = self.sensor.pitch_m / 2.0;
        let mut pulse = [0.0; ELEMENTS];
        for (i, p) in pulse.iter_mut().enumerate() {
            let z = self.element_z(i);
            if touching(z) {
                let c = SurfacePoint::new(centre.x_m, centre.z_m + z);
                *p = self.rectangle_n_per_pa(c, half_len, half_pitch);
            }
        }
        // The net pulsatile force (and its moment about the pin, above the line's centre)
        // over the touching patch, in strips about one pitch long.
        let (lo, hi) = self.span();
        let strips = ((hi - lo) / self.sensor.pitch_m).ceil().max(1.0) as usize;
        let strip = (hi - lo) / strips as f64;
        let (mut net, mut moment) = (0.0, 0.0);
        let (mut area, mut first, mut second) = (0.0, 0.0, 0.0);
        for k in 0..strips {
            let z = lo + (k as f64 + 0.5) * strip;
            if !touching(z) {
                continue;
            }
            let c = SurfacePoint::new(patch_centre.x_m, patch_centre.z_m + z);
            let f = self.rectangle_n_per_pa(c, width / 2.0, strip / 2.0);
            net += f;
            moment += f * z;
            let a = width * strip;
            area += a;
            first += a * z;
            second += a * z * z;
        }
        // Take back a + b z per unit area with ∫ = net and, when the body rocks freely,
        // ∫ z = moment; otherwise uniformly.
        let (a, b) = if at.rocking {
            let det = area * second - first * first;
            if det.abs() > 0.0 {
                (
                    (net * second - moment * first) / det,
                    (area * moment - first * net) / det,
                )
            } else {
                (0.0, 0.0)
            }
        } else if area > 0.0 {
            (net / area, 0.0)
        } else {
            (0.0, 0.0)
        };
        let element_area = self.sensor.element_area_m2;
        for (i, p) in pulse.iter_mut().enumerate() {
            let z = self.element_z(i);
            if touching(z) {
                *p -= (a + b * z) * element_area;
            }
        }
        let cached = Cached {
            centre,
            patch_centre,
            width_m: width,
            line_tilt_rad: at.line_tilt_rad,
            strip_angle_rad: at.strip_angle_rad,
            rocking: at.rocking,
            pulse_n_per_pa: pulse,
            crossing_m: self.crossing(centre),
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

    /// The load on the element strip relative to the bottom of the cylinder: turned off the
    /// bottom by `angle`, it is `r (1 − cos angle)` higher (Winkler: proportionally less).
    fn strip_factor(&self, contact: &Contact) -> f64 {
        let angle = contact.attitude.strip_angle_rad;
        if angle == 0.0 {
            return 1.0;
        }
        if contact.indentation_m <= 0.0 {
            return 0.0;
        }
        let r = self.sensor.body_diameter_m / 2.0;
        ((contact.indentation_m - r * (1.0 - angle.cos())) / contact.indentation_m).max(0.0)
    }

    /// Noise-free element forces for the element line centred at `centre` (true position,
    /// tissue frame) with `contact`, under a lumen pressure of `pulse_pa` above diastole, N.
    pub fn forces(
        &mut self,
        centre: SurfacePoint,
        contact: Contact,
        pulse_pa: f64,
    ) -> [f64; ELEMENTS] {
        if contact.normal_n <= 0.0 {
            return [0.0; ELEMENTS];
        }
        let shapes = self.shapes(centre, &contact);
        let profile = self.profile(&contact);
        let strip = self.strip_factor(&contact);
        let (lo, hi) = self.span();
        let element_area = self.sensor.element_area_m2;
        // The level body's share of N per element: its area over the patch's.
        let uniform = element_area / ((hi - lo) * shapes.width_m);
        // A strip turned clear of the tissue feels nothing.
        if strip <= 0.0 {
            return [0.0; ELEMENTS];
        }
        // How strongly the tube couples into the sensor here.
        let gain = match self.artery.coupling {
            PulseCoupling::Linear => 1.0,
            PulseCoupling::HoldDown { reference_normal_n } => {
                contact.normal_n / reference_normal_n
                    * self.relative_load(profile, shapes.crossing_m)
                    * strip
            }
        };
        let mut out = [0.0; ELEMENTS];
        for (i, f) in out.iter_mut().enumerate() {
            let z = self.element_z(i);
            let c = SurfacePoint::new(centre.x_m, centre.z_m + z);
            let load = contact.normal_n
                * uniform
                * self.relative_load(profile, z)
                * strip
                * (1.0 + self.lump_bump(c));
            // The tissue can push but not pull: a strong negative flank lifts the element off.
            *f = (load + gain * pulse_pa * shapes.pulse_n_per_pa[i]).max(0.0);
        }
        out
    }

    /// Pulsatile force per pascal on each element at a level pose (for tests and plots).
    pub fn pulse_shape(&mut self, centre: SurfacePoint, indentation_m: f64) -> [f64; ELEMENTS] {
        self.shapes(centre, &Contact::level(1.0, indentation_m))
            .pulse_n_per_pa
    }

    /// Pulsatile force per pascal on each element with `contact` (for tests and plots).
    pub fn pulse_shape_with(&mut self, centre: SurfacePoint, contact: &Contact) -> [f64; ELEMENTS] {
        self.shapes(centre, contact).pulse_n_per_pa
    }
}

/// ∫ over a length `l` of the positive part of a linear function running from `y0` to `y1`.
fn clipped_linear_integral(y0: f64, y1: f64, l: f64) -> f64 {
    match (y0 > 0.0, y1 > 0.0) {
        (true, true) => 0.5 * (y0 + y1) * l,
        (false, false) => 0.0,
        _ => {
            let (pos, neg) = if y0 > 0.0 { (y0, y1) } else { (y1, y0) };
            // The positive part is a triangle of height `pos` over the length where it is.
            0.5 * pos * l * pos / (pos - neg)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{PathSpec, PulseCoupling, Turn};

    fn seed_tube(path: PathSpec) -> TactileModel {
        model(path, |_| {})
    }

    fn model(path: PathSpec, artery: impl FnOnce(&mut ArterySpec)) -> TactileModel {
        let mut a = ArterySpec {
            path: path.clone(),
            depth_m: 0.005,
            depth_end_m: None,
            inner_radius_m: 0.0015,
            inner_radius_end_m: None,
            wall_m: 0.001,
            kernel: Default::default(),
            coupling: Default::default(),
        };
        artery(&mut a);
        TactileModel::new(
            ArteryPath::from_spec(&path).unwrap(),
            &a,
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
            let f = m.forces(c, Contact::level(2.9, 0.003), 100e3);
            assert!(f.iter().all(|v| v.is_finite() && *v >= 0.0), "{f:?}");
        }
    }

    #[test]
    fn lifted_off_sensor_feels_nothing() {
        let mut m = seed_tube(straight_along_x());
        let f = m.forces(SurfacePoint::new(0.0, 0.0), Contact::level(0.0, 0.0), 100e3);
        assert_eq!(f, [0.0; ELEMENTS]);
    }

    #[test]
    fn a_flattened_artery_under_a_thin_cover_presses_with_nearly_the_whole_pulse() {
        use crate::scene::PressureKernel;
        // Radial-artery size, its top 0.2 mm under the surface: over the flattened width
        // (π r = 5 mm) the surface carries the lumen pressure.
        let mut m = model(straight_along_x(), |a| {
            a.kernel = PressureKernel::Applanation;
            a.inner_radius_m = 0.0013;
            a.wall_m = 0.0003;
            a.depth_m = 0.0018;
        });
        let shape = m.pulse_shape(SurfacePoint::new(0.0, -0.001), 0.0015);
        let area = SensorSpec::default().element_area_m2;
        // Element 5 sits over the artery's axis. All of the flattened strip's force (π r =
        // 5.0 mm wide, per Pa per metre of artery) reaches the sensor, and the body takes it
        // back evenly over its 34 mm: 5.0/34 of the pressure.
        let expected = (0.99 - std::f64::consts::PI * 0.0016 / 0.034) * area;
        assert!(
            (shape[5] - expected).abs() < 0.03 * area,
            "{} vs {expected}",
            shape[5]
        );
        // Beyond the flattened width only the take-back remains: out of phase.
        assert!(shape[0] < 0.0 && shape[9] < 0.0, "{shape:?}");
        // A deeper artery spreads the pulse and lowers the peak.
        let mut deep = model(straight_along_x(), |a| {
            a.kernel = PressureKernel::Applanation;
            a.inner_radius_m = 0.0013;
            a.wall_m = 0.0003;
            a.depth_m = 0.0047;
        });
        let d = deep.pulse_shape(SurfacePoint::new(0.0, -0.001), 0.0015);
        assert!(d[5] < 0.85 * shape[5] && d[5] > 0.5 * shape[5], "{d:?}");
    }

    fn tilted(tilt_rad: f64) -> Contact {
        Contact {
            normal_n: 3.0,
            indentation_m: 0.00175,
            attitude: Attitude {
                line_tilt_rad: tilt_rad,
                pin_height_m: 0.0045,
                ..Attitude::default()
            },
            patch_centre: None,
        }
    }

    #[test]
    fn a_line_tilted_against_the_tissue_presses_one_end_and_lifts_the_other() {
        let mut m = seed_tube(straight_along_x());
        let level = m.forces(SurfacePoint::new(0.0, 0.0), tilted(0.0), 0.0);
        // 12°: the line rises 0.21 mm per mm, so beyond 8.2 mm on the +z side it is off the
        // tissue: element 9 (at +9 mm) carries nothing, element 0 more than on a level line.
        let tilt = 12f64.to_radians();
        let f = m.forces(SurfacePoint::new(0.0, 0.0), tilted(tilt), 0.0);
        assert_eq!(f[9], 0.0, "{f:?}");
        assert!(f[0] > 1.5 * level[0], "{f:?} vs {level:?}");
        assert!(f.windows(2).all(|w| w[0] >= w[1]), "{f:?}");
        // The tube under the lifted end: that element feels no pulse (nor any load).
        let pulsed = m.forces(SurfacePoint::new(0.0, -0.009), tilted(tilt), 100e3);
        assert_eq!(pulsed[9], 0.0, "{pulsed:?}");
        // Under the pressed end it does.
        let pulsed = m.forces(SurfacePoint::new(0.0, 0.009), tilted(tilt), 100e3);
        let still = m.forces(SurfacePoint::new(0.0, 0.009), tilted(tilt), 0.0);
        assert!(pulsed[0] - still[0] > 0.03, "{pulsed:?} {still:?}");
    }

    #[test]
    fn a_body_rocking_on_its_pin_takes_neither_force_nor_moment_from_the_pulse() {
        let contact = Contact {
            normal_n: 3.0,
            indentation_m: 0.003,
            attitude: Attitude {
                rocking: true,
                pin_height_m: 0.0045,
                ..Attitude::default()
            },
            patch_centre: None,
        };
        for z in [0.0, 0.004, -0.007] {
            let mut m = seed_tube(straight_along_x());
            let centre = SurfacePoint::new(0.0, z);
            let shape = m.pulse_shape_with(centre, &contact);
            let width = m.cache.unwrap().width_m;
            let half_len = m.element_length() / 2.0;
            let raw = |m: &TactileModel, i: usize| {
                m.rectangle_n_per_pa(
                    SurfacePoint::new(0.0, z + m.element_z(i)),
                    half_len,
                    m.sensor.pitch_m / 2.0,
                )
            };
            // The take-back per area is a + b z: recover it from two elements.
            let area = m.sensor.element_area_m2;
            let (z2, z7) = (m.element_z(2), m.element_z(7));
            let (t2, t7) = (
                (raw(&m, 2) - shape[2]) / area,
                (raw(&m, 7) - shape[7]) / area,
            );
            let b = (t7 - t2) / (z7 - z2);
            let a = t2 - b * z2;
            let (lo, hi) = m.span();
            let n = 340;
            let dz = (hi - lo) / n as f64;
            let (mut net, mut moment, mut scale) = (0.0, 0.0, 0.0);
            for k in 0..n {
                let s = lo + (k as f64 + 0.5) * dz;
                let f = m.rectangle_n_per_pa(SurfacePoint::new(0.0, z + s), width / 2.0, dz / 2.0)
                    - (a + b * s) * width * dz;
                net += f;
                moment += f * s;
                scale += f.abs();
            }
            assert!(net.abs() < 1e-3 * scale, "z {z}: net {net} of {scale}");
            assert!(
                moment.abs() < 1e-3 * scale * (hi - lo),
                "z {z}: moment {moment}"
            );
        }
    }

    #[test]
    fn a_pin_across_the_line_keeps_the_load_centre_under_it() {
        let mut m = seed_tube(straight_along_x());
        let at = |friction: f64| Contact {
            normal_n: 3.0,
            indentation_m: 0.00175,
            attitude: Attitude {
                rocking: true,
                line_friction_n: friction,
                pin_height_m: 0.0045,
                ..Attitude::default()
            },
            patch_centre: None,
        };
        // The body reaches 11 mm distal of the pin and 23 mm proximal: with the load centre
        // under the pin, the distal elements carry more than the proximal ones.
        let f = m.forces(SurfacePoint::new(0.0, 0.0), at(0.0), 0.0);
        assert!(f[0] > f[9] && f.windows(2).all(|w| w[0] >= w[1]), "{f:?}");
        // Friction along +z at the contact, 4.5 mm below the pin, moves the load centre
        // toward -z by 4.5 mm x F / N.
        let g = m.forces(SurfacePoint::new(0.0, 0.0), at(0.3), 0.0);
        let z: Vec<f64> = (0..ELEMENTS).map(|i| m.element_z(i)).collect();
        let centroid = |f: &[f64; ELEMENTS]| {
            let s: f64 = f.iter().sum();
            (0..ELEMENTS).map(|i| f[i] * z[i]).sum::<f64>() / s
        };
        assert!(centroid(&g) < centroid(&f) - 5e-5, "{g:?}");
    }

    #[test]
    fn a_strip_turned_off_the_bottom_carries_less() {
        let mut m = seed_tube(straight_along_x());
        let mut c = Contact::level(3.0, 0.00175);
        let level = m.forces(SurfacePoint::new(0.0, 0.0), c, 0.0);
        c.attitude.strip_angle_rad = 25f64.to_radians();
        let turned = m.forces(SurfacePoint::new(0.0, 0.0), c, 0.0);
        // r (1 − cos 25°) = 0.42 mm of the 1.75 mm indentation.
        let expect = (0.00175 - 0.0045 * (1.0 - 25f64.to_radians().cos())) / 0.00175;
        assert!((turned[4] / level[4] - expect).abs() < 1e-9);
        c.attitude.strip_angle_rad = 60f64.to_radians();
        assert_eq!(
            m.forces(SurfacePoint::new(0.0, 0.0), c, 100e3),
            [0.0; ELEMENTS]
        );
    }

    #[test]
    fn the_hold_down_coupling_scales_the_pulse_with_the_load() {
        let mut m = model(straight_along_x(), |a| {
            a.coupling = PulseCoupling::HoldDown {
                reference_normal_n: 3.0,
            };
        });
        let pulse = |m: &mut TactileModel, n: f64| {
            let c = Contact::level(n, 0.00175);
            let on = m.forces(SurfacePoint::new(0.0, 0.0), c, 100e3);
            let off = m.forces(SurfacePoint::new(0.0, 0.0), c, 0.0);
            on[4] - off[4]
        };
        let full = pulse(&mut m, 3.0);
        let mut linear = seed_tube(straight_along_x());
        assert!((full - pulse(&mut linear, 3.0)).abs() < 1e-12);
        assert!((pulse(&mut m, 1.5) - 0.5 * full).abs() < 1e-12);
        assert!((pulse(&mut linear, 1.5) - full).abs() < 1e-12);
    }
}
