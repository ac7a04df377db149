//! Semantic checks of a family file, each problem named by its field path.

use config::{Validate, Validator};

use super::{
    ArteryFamily, BreathingFamily, CountInterval, CourseFamily, FAMILY_VERSION, Family,
    HeartFamily, InstrumentFamily, Interval, LumpFamily,
};

/// `iv` is a finite range `(low, high)` with `lo <= low <= high <= hi`.
fn interval(v: &mut Validator, field: &str, iv: Interval, lo: f64, hi: f64) {
    v.check(
        iv.0.is_finite() && iv.1.is_finite() && iv.0 <= iv.1 && lo <= iv.0 && iv.1 <= hi,
        field,
        format!(
            "must be a range (low, high) with {lo} <= low <= high <= {hi}, got ({}, {})",
            iv.0, iv.1
        ),
    );
}

fn optional(v: &mut Validator, field: &str, iv: Option<Interval>, lo: f64, hi: f64) {
    if let Some(iv) = iv {
        interval(v, field, iv, lo, hi);
    }
}

fn count(v: &mut Validator, field: &str, c: CountInterval, hi: u32) {
    v.check(
        c.0 <= c.1 && c.1 <= hi,
        field,
        format!(
            "must be a range (low, high) of counts with low <= high <= {hi}, got ({}, {})",
            c.0, c.1
        ),
    );
}

impl Validate for Family {
    fn validate(&self, v: &mut Validator) {
        v.check(
            self.version == FAMILY_VERSION,
            "version",
            format!(
                "unsupported version {} (this build reads {FAMILY_VERSION})",
                self.version
            ),
        );
        v.check(
            !self.name.is_empty()
                && self
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_'),
            "name",
            "must name the family with letters, digits, `-` and `_` (drawn scenes are named and written after it)",
        );
        v.check(
            !self.base.trim().is_empty(),
            "base",
            "must name the base scene",
        );
        v.check(
            !self.courses.is_empty(),
            "courses",
            "must name at least one kind of course",
        );
        for (i, c) in self.courses.iter().enumerate() {
            v.at(&format!("courses[{i}]"), |v| {
                v.check(
                    c.weight.is_finite() && c.weight > 0.0,
                    "weight",
                    format!("must be positive, got {}", c.weight),
                );
                v.at("course", |v| course(v, &c.course));
            });
        }
        interval(v, "track_length_m", self.track_length_m, 0.01, 1.0);
        v.check(
            self.max_heading_rad.is_finite()
                && self.max_heading_rad > 0.0
                && self.max_heading_rad <= 60f64.to_radians() + 1e-12,
            "max_heading_rad",
            format!(
                "must lie in (0, 60 degrees] (the element line along z cannot follow an artery running nearly along it), got {:.1} degrees",
                self.max_heading_rad.to_degrees()
            ),
        );
        if let Some(r) = self.min_radius_m {
            v.in_range("min_radius_m", r, 1e-3, 10.0);
        }
        v.at("workspace", |v| {
            let w = &self.workspace;
            interval(v, "x_m", w.x_m, -1.0, 1.0);
            interval(v, "z_m", w.z_m, -1.0, 1.0);
            v.in_range("margin_m", w.margin_m, 0.0, 0.05);
        });
        if let Some(h) = &self.heart {
            v.section("heart", h);
        }
        if let Some(a) = &self.artery {
            v.section("artery", a);
        }
        optional(v, "noise_sd_n", self.noise_sd_n, 0.0, 10.0);
        if let Some(i) = &self.instrument {
            v.section("instrument", i);
        }
        if let Some(l) = &self.lumps {
            v.section("lumps", l);
        }
        if let Some(b) = &self.breathing {
            v.section("breathing", b);
        }
    }
}

fn course(v: &mut Validator, c: &CourseFamily) {
    match c {
        CourseFamily::Smooth {
            max_curvature_per_m,
            max_curvature_rate_per_m2,
            knot_spacing_m,
        } => {
            v.in_range("max_curvature_per_m", *max_curvature_per_m, 0.0, 200.0);
            v.in_range(
                "max_curvature_rate_per_m2",
                *max_curvature_rate_per_m2,
                0.0,
                1.0e5,
            );
            interval(v, "knot_spacing_m", *knot_spacing_m, 0.002, 0.5);
        }
        CourseFamily::Sinusoid {
            amplitude_m,
            wavelength_m,
        } => {
            interval(v, "amplitude_m", *amplitude_m, 0.0, 0.1);
            interval(v, "wavelength_m", *wavelength_m, 0.01, 2.0);
        }
        CourseFamily::Spiral {
            start_radius_m,
            end_radius_m,
        } => {
            interval(v, "start_radius_m", *start_radius_m, 0.005, 10.0);
            interval(v, "end_radius_m", *end_radius_m, 0.005, 10.0);
        }
        CourseFamily::SCurve { radius_m } | CourseFamily::Arc { radius_m } => {
            interval(v, "radius_m", *radius_m, 0.005, 10.0);
        }
        CourseFamily::Corners {
            bends,
            bend_rad,
            fillet_radius_m,
            min_leg_m,
        } => {
            count(v, "bends", *bends, 20);
            interval(v, "bend_rad", *bend_rad, 0.0, 170f64.to_radians());
            optional(v, "fillet_radius_m", *fillet_radius_m, 0.0, 0.1);
            v.in_range("min_leg_m", *min_leg_m, 0.005, 0.5);
        }
    }
}

impl Validate for HeartFamily {
    fn validate(&self, v: &mut Validator) {
        interval(v, "rate_hz", self.rate_hz, 0.3, 4.0);
        interval(
            v,
            "interval_sd_fraction",
            self.interval_sd_fraction,
            0.0,
            0.3,
        );
        interval(
            v,
            "pressure_sd_fraction",
            self.pressure_sd_fraction,
            0.0,
            0.5,
        );
        interval(v, "ectopic_probability", self.ectopic_probability, 0.0, 0.5);
        interval(v, "pulse_pressure_pa", self.pulse_pressure_pa, 0.0, 1.0e5);
        interval(v, "diastolic_pa", self.diastolic_pa, 0.0, 1.0e5);
    }
}

impl Validate for ArteryFamily {
    fn validate(&self, v: &mut Validator) {
        optional(v, "depth_m", self.depth_m, 1e-4, 0.1);
        optional(v, "inner_radius_m", self.inner_radius_m, 1e-5, 0.02);
        optional(v, "wall_m", self.wall_m, 0.0, 0.01);
    }
}

impl Validate for InstrumentFamily {
    fn validate(&self, v: &mut Validator) {
        optional(v, "mass_kg", self.mass_kg, 0.0, 5.0);
        optional(v, "shaft_diameter_m", self.shaft_diameter_m, 1e-4, 0.05);
        optional(
            v,
            "shaft_youngs_modulus_pa",
            self.shaft_youngs_modulus_pa,
            1e6,
            1e12,
        );
        optional(
            v,
            "pivot_stiffness_n_per_m",
            self.pivot_stiffness_n_per_m,
            1.0,
            1e8,
        );
    }
}

impl Validate for LumpFamily {
    fn validate(&self, v: &mut Validator) {
        count(v, "count", self.count, 20);
        interval(v, "lateral_offset_m", self.lateral_offset_m, 0.0, 0.1);
        interval(v, "depth_m", self.depth_m, 1e-4, 0.1);
        interval(v, "pressure_gain", self.pressure_gain, 0.0, 20.0);
    }
}

impl Validate for BreathingFamily {
    fn validate(&self, v: &mut Validator) {
        interval(v, "amplitude_m", self.amplitude_m, 0.0, 0.02);
        interval(v, "frequency_hz", self.frequency_hz, 0.01, 2.0);
        interval(v, "direction_rad", self.direction_rad, -10.0, 10.0);
    }
}
