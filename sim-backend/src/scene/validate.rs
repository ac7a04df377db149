//! Semantic checks of a scene, each problem named by its field path.

use config::{Validate, Validator};

use super::SCENE_VERSION;
use super::path::{ArteryPath, PathSpec};
use super::pulse::PulseSpec;
use super::spec::*;

impl Validate for Scene {
    fn validate(&self, v: &mut Validator) {
        v.check(
            self.version == SCENE_VERSION,
            "version",
            format!(
                "unsupported version {} (this build reads {SCENE_VERSION})",
                self.version
            ),
        );
        v.check(!self.name.trim().is_empty(), "name", "must name the scene");
        v.section("artery", &self.artery);
        v.section("pulse", &self.pulse);
        v.section("tissue", &self.tissue);
        for (i, lump) in self.lumps.iter().enumerate() {
            v.section(&format!("lumps[{i}]"), lump);
        }
        v.section("sensor", &self.sensor);
        if let Some(s) = &self.shaft {
            v.section("shaft", s);
        }
        if let Some(p) = &self.pivot {
            v.section("pivot", p);
        }
        if let Some(m) = &self.mass {
            v.at("mass", |v| {
                v.in_range("mass_kg", m.mass_kg, 0.0, 5.0);
                v.in_range("height_above_tip_m", m.height_above_tip_m, 0.0, 0.4);
            });
        }
        if let Some(r) = &self.robot {
            v.section("robot", r);
        }
        if let Some(j) = &self.joints {
            v.at("joints", |v| {
                for (i, e) in j.encoder_zero_error_rad.iter().enumerate() {
                    v.in_range(&format!("encoder_zero_error_rad[{i}]"), *e, -0.5, 0.5);
                }
                for (i, sides) in j.stop_beyond_limit_rad.iter().enumerate() {
                    for (k, b) in sides.iter().enumerate() {
                        v.in_range(&format!("stop_beyond_limit_rad[{i}][{k}]"), *b, -0.5, 0.5);
                    }
                }
            });
        }
        if let Some(f) = &self.faults {
            v.at("faults", |v| {
                for (i, &e) in f.dead_elements.iter().enumerate() {
                    v.check(
                        e < control::types::ELEMENTS,
                        &format!("dead_elements[{i}]"),
                        format!(
                            "element {e} does not exist (0..{})",
                            control::types::ELEMENTS
                        ),
                    );
                }
                v.in_range("frame_drop_probability", f.frame_drop_probability, 0.0, 0.9);
                for (name, values, lo, hi) in [
                    ("element_gains", &f.element_gains, 0.0, 10.0),
                    ("element_offsets_n", &f.element_offsets_n, -3.0, 3.0),
                ] {
                    v.check(
                        values.is_empty() || values.len() == control::types::ELEMENTS,
                        name,
                        format!(
                            "lists {} values; give one per element ({}) or none",
                            values.len(),
                            control::types::ELEMENTS
                        ),
                    );
                    for (i, &x) in values.iter().enumerate() {
                        v.in_range(&format!("{name}[{i}]"), x, lo, hi);
                    }
                }
            });
        }
        for (i, p) in self.placements.iter().enumerate() {
            v.at(&format!("placements[{i}]"), |v| {
                v.in_range("x_m", p.x_m, -1.0, 1.0);
                v.in_range("z_m", p.z_m, -1.0, 1.0);
            });
        }
        let [a, b] = self.placements;
        if a.is_finite() && b.is_finite() {
            v.check(
                a.distance_to(&b) >= 0.002,
                "placements[1]",
                format!(
                    "the two placements are {:.1} mm apart; they must be at least 2 mm apart to give a direction",
                    a.distance_to(&b) * 1e3
                ),
            );
        }
        v.at("track", |v| {
            v.in_range("length_m", self.track.length_m, 0.001, 2.0);
            v.check(
                !self.track.reason.trim().is_empty(),
                "reason",
                "say why this length is tracked",
            );
        });
        if let Some(s) = &self.start {
            v.at("start", |v| {
                v.in_range("x_m", s.x_m, -1.0, 1.0);
                v.in_range("z_m", s.z_m, -1.0, 1.0);
            });
        }
    }
}

impl Validate for ArterySpec {
    fn validate(&self, v: &mut Validator) {
        v.at("path", |v| validate_path(&self.path, v));
        v.in_range("depth_m", self.depth_m, 1e-4, 0.1);
        if let Some(d) = self.depth_end_m {
            v.in_range("depth_end_m", d, 1e-4, 0.1);
        }
        v.in_range("inner_radius_m", self.inner_radius_m, 1e-5, 0.02);
        if let Some(r) = self.inner_radius_end_m {
            v.in_range("inner_radius_end_m", r, 1e-5, 0.02);
        }
        v.in_range("wall_m", self.wall_m, 0.0, 0.01);
        // The tube must lie under the surface everywhere.
        let ends = [
            (self.depth_m, self.inner_radius_m, "depth_m"),
            (
                self.depth_end_m.unwrap_or(self.depth_m),
                self.inner_radius_end_m.unwrap_or(self.inner_radius_m),
                "depth_end_m",
            ),
        ];
        if let PressureKernel::Fem(spec) = &self.kernel {
            v.check(
                self.depth_end_m.is_none() && self.inner_radius_end_m.is_none(),
                "kernel",
                "the FEM kernel needs a constant depth and radius (no depth_end_m, inner_radius_end_m)",
            );
            v.check(
                spec.tissue.is_valid() && spec.wall.is_valid(),
                "kernel.Fem",
                "moduli must be positive and Poisson's ratios in (-1, 0.5)",
            );
            v.check(spec.refine <= 3, "kernel.Fem.refine", "must be at most 3");
            if let Some(g) = spec.backing_gap_m {
                // The mesher needs 1.15 meshed radii below the centre (a hole's mesh has a
                // ring of 0.25 lumen radii around it); 1.2 keeps a margin.
                let (lumen, wall) = if spec.wall_flattened {
                    (self.inner_radius_m + self.wall_m, 0.0)
                } else {
                    (self.inner_radius_m, self.wall_m)
                };
                let meshed = if wall > 0.0 {
                    lumen + wall
                } else {
                    1.25 * lumen
                };
                let least = 1.2 * meshed - (lumen + wall);
                v.check(
                    g.is_finite() && g >= least && g <= 0.1,
                    "kernel.Fem.backing_gap_m",
                    format!(
                        "must be between {:.2} mm (room for the tube's mesh) and 100 mm",
                        least * 1e3
                    ),
                );
            }
            v.check(
                !spec.wall_flattened || spec.backing_gap_m.is_some(),
                "kernel.Fem.wall_flattened",
                "a tube is flattened against a backing: give backing_gap_m",
            );
            let r_out = self.inner_radius_m + self.wall_m;
            v.check(
                self.depth_m >= 1.2 * r_out,
                "kernel",
                format!(
                    "the FEM kernel needs the tube's centre at least 1.2 outer radii deep ({:.2} mm)",
                    1.2 * r_out * 1e3
                ),
            );
        }
        if let PulseCoupling::HoldDown { reference_normal_n } = self.coupling {
            v.in_range(
                "coupling.HoldDown.reference_normal_n",
                reference_normal_n,
                0.01,
                100.0,
            );
        }
        for (depth, radius, field) in ends {
            if depth.is_finite() && radius.is_finite() && self.wall_m.is_finite() {
                v.check(
                    depth > radius + self.wall_m,
                    field,
                    format!(
                        "the tube (outer radius {:.2} mm) would break the surface at a depth of {:.2} mm",
                        (radius + self.wall_m) * 1e3,
                        depth * 1e3
                    ),
                );
            }
        }
    }
}

fn validate_path(spec: &PathSpec, v: &mut Validator) {
    match spec {
        PathSpec::Arc {
            radius_m,
            length_m,
            chord_centre,
            ..
        } => {
            v.in_range("radius_m", *radius_m, 1e-3, 10.0);
            v.in_range("length_m", *length_m, 1e-3, 2.0);
            v.in_range("chord_centre.x_m", chord_centre.x_m, -1.0, 1.0);
            v.in_range("chord_centre.z_m", chord_centre.z_m, -1.0, 1.0);
        }
        PathSpec::SCurve {
            radius_m, length_m, ..
        } => {
            v.in_range("radius_m", *radius_m, 1e-3, 10.0);
            v.in_range("length_m", *length_m, 1e-3, 2.0);
        }
        PathSpec::Straight {
            start,
            heading_rad,
            length_m,
        } => {
            v.finite("start.x_m", start.x_m);
            v.finite("start.z_m", start.z_m);
            v.finite("heading_rad", *heading_rad);
            v.in_range("length_m", *length_m, 1e-3, 2.0);
        }
        PathSpec::Polyline { points } | PathSpec::Spline { points, .. } => {
            for (i, p) in points.iter().enumerate() {
                v.in_range(&format!("points[{i}].x_m"), p.x_m, -1.0, 1.0);
                v.in_range(&format!("points[{i}].z_m"), p.z_m, -1.0, 1.0);
            }
            // A tiny sampling step would make the path from billions of pieces.
            if let PathSpec::Spline {
                sample_m: Some(step),
                ..
            } = spec
            {
                v.in_range("sample_m", *step, 1e-5, 0.01);
            }
        }
        PathSpec::Sinusoid {
            start,
            heading_rad,
            amplitude_m,
            wavelength_m,
            length_m,
            phase_rad,
            step_m,
        } => {
            start_and_heading(v, start, *heading_rad);
            v.in_range("amplitude_m", *amplitude_m, 0.0, 0.5);
            v.in_range("wavelength_m", *wavelength_m, 1e-3, 10.0);
            v.in_range("length_m", *length_m, 1e-3, 2.0);
            v.finite("phase_rad", *phase_rad);
            if let Some(step) = step_m {
                v.in_range("step_m", *step, 1e-5, 0.01);
            }
        }
        PathSpec::Spiral {
            start,
            heading_rad,
            start_radius_m,
            end_radius_m,
            length_m,
            step_m,
            ..
        } => {
            start_and_heading(v, start, *heading_rad);
            v.in_range("start_radius_m", *start_radius_m, 1e-3, 10.0);
            v.in_range("end_radius_m", *end_radius_m, 1e-3, 10.0);
            v.in_range("length_m", *length_m, 1e-3, 2.0);
            if let Some(step) = step_m {
                v.in_range("step_m", *step, 1e-5, 0.01);
            }
        }
        PathSpec::Corners {
            start,
            heading_rad,
            legs_m,
            bends_rad,
            fillet_radius_m,
        } => {
            start_and_heading(v, start, *heading_rad);
            for (i, &l) in legs_m.iter().enumerate() {
                v.in_range(&format!("legs_m[{i}]"), l, 1e-3, 2.0);
            }
            for (i, &b) in bends_rad.iter().enumerate() {
                v.check(
                    b.is_finite() && b.abs() < std::f64::consts::PI,
                    &format!("bends_rad[{i}]"),
                    format!("must lie strictly between -180 and 180 degrees, got {b}"),
                );
            }
            v.in_range("fillet_radius_m", *fillet_radius_m, 0.0, 1.0);
        }
        PathSpec::Clothoid {
            start,
            heading_rad,
            knots,
            step_m,
        } => {
            start_and_heading(v, start, *heading_rad);
            for (i, k) in knots.iter().enumerate() {
                v.in_range(&format!("knots[{i}].s_m"), k.s_m, 0.0, 2.0);
                v.in_range(
                    &format!("knots[{i}].curvature_per_m"),
                    k.curvature_per_m,
                    -1000.0,
                    1000.0,
                );
            }
            if let Some(step) = step_m {
                v.in_range("step_m", *step, 1e-5, 0.01);
            }
        }
        PathSpec::Transformed {
            path,
            rotation_rad,
            translation,
            ..
        } => {
            v.finite("rotation_rad", *rotation_rad);
            v.in_range("translation.x_m", translation.x_m, -1.0, 1.0);
            v.in_range("translation.z_m", translation.z_m, -1.0, 1.0);
            // The inner path's own checks; whether the whole builds is checked once below.
            let before = v.problem_count();
            v.at("path", |v| validate_path(path, v));
            if v.problem_count() > before {
                return;
            }
        }
    }
    // Whatever the numbers, the path must build.
    if let Err(e) = ArteryPath::from_spec(spec) {
        v.problem("", e.to_string());
    }
}

fn start_and_heading(v: &mut Validator, start: &control::frames::SurfacePoint, heading: f64) {
    v.in_range("start.x_m", start.x_m, -1.0, 1.0);
    v.in_range("start.z_m", start.z_m, -1.0, 1.0);
    v.finite("heading_rad", heading);
}

impl Validate for PulseSpec {
    fn validate(&self, v: &mut Validator) {
        match *self {
            PulseSpec::Solenoid {
                pressure_pa,
                period_s,
                duty,
                time_constant_s,
            } => {
                v.in_range("pressure_pa", pressure_pa, 0.0, 1.0e6);
                v.in_range("period_s", period_s, 0.1, 10.0);
                v.in_range("duty", duty, 0.05, 0.95);
                v.in_range("time_constant_s", time_constant_s, 0.0, 1.0);
            }
            PulseSpec::Physiological {
                systolic_pa,
                diastolic_pa,
                heart_rate_hz,
                interval_sd_s,
                pressure_sd_fraction,
                rate_change,
                ectopic,
            } => {
                v.in_range("systolic_pa", systolic_pa, 0.0, 1.0e5);
                v.in_range("diastolic_pa", diastolic_pa, 0.0, 1.0e5);
                v.check(
                    systolic_pa >= diastolic_pa,
                    "systolic_pa",
                    "must not be below diastolic_pa",
                );
                v.in_range("heart_rate_hz", heart_rate_hz, 0.3, 4.0);
                v.in_range("interval_sd_s", interval_sd_s, 0.0, 0.5);
                v.in_range("pressure_sd_fraction", pressure_sd_fraction, 0.0, 0.5);
                if let Some(e) = ectopic {
                    v.at("ectopic", |v| {
                        v.in_range("probability", e.probability, 0.0, 0.5);
                        v.in_range("prematurity", e.prematurity, 0.05, 0.5);
                        v.in_range("pressure_fraction", e.pressure_fraction, 0.0, 1.0);
                    });
                }
                if let Some(c) = rate_change {
                    v.at("rate_change", |v| {
                        v.in_range("to_hz", c.to_hz, 0.3, 4.0);
                        v.in_range("start_s", c.start_s, 0.0, 1.0e5);
                        v.in_range("duration_s", c.duration_s, 0.0, 1.0e5);
                    });
                }
            }
            PulseSpec::Absent => {}
        }
    }
}

impl Validate for TissueSpec {
    fn validate(&self, v: &mut Validator) {
        v.in_range(
            "contact_stiffness_n_per_m",
            self.contact_stiffness_n_per_m,
            10.0,
            1.0e6,
        );
        v.in_range(
            "contact_damping_n_s_per_m",
            self.contact_damping_n_s_per_m,
            0.0,
            1.0e4,
        );
        if let Some(e) = &self.placement_error {
            v.at("placement_error", |v| {
                v.in_range("yaw_rad", e.yaw_rad, -0.5, 0.5);
                for (i, &o) in e.origin_offset_m.iter().enumerate() {
                    v.in_range(&format!("origin_offset_m[{i}]"), o, -0.05, 0.05);
                }
            });
        }
        if let Some(b) = &self.breathing {
            v.at("breathing", |v| {
                v.in_range("amplitude_m", b.amplitude_m, 0.0, 0.02);
                v.in_range("frequency_hz", b.frequency_hz, 0.01, 2.0);
                v.finite("direction_rad", b.direction_rad);
                v.finite("phase_rad", b.phase_rad);
            });
        }
        if let Some(f) = &self.friction {
            v.at("friction", |v| {
                v.in_range("static_coefficient", f.static_coefficient, 0.0, 3.0);
                v.in_range("kinetic_coefficient", f.kinetic_coefficient, 0.0, 3.0);
                v.check(
                    f.kinetic_coefficient <= f.static_coefficient,
                    "kinetic_coefficient",
                    "must not exceed static_coefficient",
                );
                v.in_range(
                    "shear_stiffness_n_per_m",
                    f.shear_stiffness_n_per_m,
                    1.0,
                    1.0e7,
                );
            });
        }
    }
}

impl Validate for LumpSpec {
    fn validate(&self, v: &mut Validator) {
        v.finite("centre.x_m", self.centre.x_m);
        v.finite("centre.z_m", self.centre.z_m);
        v.in_range("depth_m", self.depth_m, 1e-4, 0.1);
        v.in_range("pressure_gain", self.pressure_gain, 0.0, 20.0);
    }
}

impl Validate for SensorSpec {
    fn validate(&self, v: &mut Validator) {
        v.in_range("pitch_m", self.pitch_m, 1e-4, 0.02);
        v.in_range("element_area_m2", self.element_area_m2, 1e-8, 1e-3);
        v.in_range("noise_sd_n", self.noise_sd_n, 0.0, 10.0);
        v.in_range("body_diameter_m", self.body_diameter_m, 1e-3, 0.05);
        v.in_range("distal_margin_m", self.distal_margin_m, 0.0, 0.05);
        let needed = self.distal_margin_m + control::types::ELEMENTS as f64 * self.pitch_m;
        if v.finite("body_length_m", self.body_length_m) {
            v.check(
                self.body_length_m >= needed && self.body_length_m <= 0.2,
                "body_length_m",
                format!(
                    "must hold the margin and all elements ({:.1} mm) and be at most 200 mm, got {:.1} mm",
                    needed * 1e3,
                    self.body_length_m * 1e3
                ),
            );
        }
    }
}

impl Validate for ShaftSpec {
    fn validate(&self, v: &mut Validator) {
        v.in_range("diameter_m", self.diameter_m, 1e-4, 0.05);
        v.in_range("youngs_modulus_pa", self.youngs_modulus_pa, 1e6, 1e12);
        v.in_range("density_kg_m3", self.density_kg_m3, 0.0, 25_000.0);
        if let Some(l) = self.length_m {
            v.in_range("length_m", l, 0.05, 2.0);
        }
    }
}

impl Validate for PivotSpec {
    fn validate(&self, v: &mut Validator) {
        for (i, &o) in self.offset_m.iter().enumerate() {
            v.in_range(&format!("offset_m[{i}]"), o, -0.05, 0.05);
        }
        if let Some(k) = self.lateral_stiffness_n_per_m {
            v.in_range("lateral_stiffness_n_per_m", k, 1.0, 1.0e8);
        }
        if let Some(f) = self.hysteresis_slip_n {
            v.in_range("hysteresis_slip_n", f, 0.0, 100.0);
            v.check(
                self.lateral_stiffness_n_per_m.is_some(),
                "hysteresis_slip_n",
                "an incision's hysteresis needs its lateral_stiffness_n_per_m",
            );
        }
    }
}

impl Validate for RobotSpec {
    fn validate(&self, v: &mut Validator) {
        if let Some(g) = &self.phantom {
            v.at("phantom", |v| {
                v.in_range("l1_m", g.l1_m, 0.05, 1.0);
                v.in_range("l2_m", g.l2_m, 0.05, 1.0);
            });
        }
        for i in 0..3 {
            v.in_range(
                &format!("joint_inertia_kg_m2[{i}]"),
                self.joint_inertia_kg_m2[i],
                1e-6,
                10.0,
            );
            v.in_range(
                &format!("coulomb_friction_nm[{i}]"),
                self.coulomb_friction_nm[i],
                0.0,
                10.0,
            );
            v.in_range(
                &format!("viscous_friction_nm_s[{i}]"),
                self.viscous_friction_nm_s[i],
                0.0,
                10.0,
            );
            v.in_range(
                &format!("capstan_ratio[{i}]"),
                self.capstan_ratio[i],
                0.1,
                1000.0,
            );
            v.in_range(
                &format!("torque_saturation_nm[{i}]"),
                self.torque_saturation_nm[i],
                1e-3,
                100.0,
            );
        }
        if let Some(m) = &self.masses {
            v.at("masses", |v| {
                v.in_range("gravity_m_s2", m.gravity_m_s2, 0.0, 20.0);
                let named = [
                    ("forearm", m.forearm),
                    ("parallel_link", m.parallel_link),
                    ("upper_arm", m.upper_arm),
                    ("drive_link", m.drive_link),
                    ("gimbal", m.gimbal),
                ];
                for (name, b) in named {
                    v.in_range(&format!("{name}.mass_kg"), b.mass_kg, 0.0, 10.0);
                    v.in_range(
                        &format!("{name}.along_upper_arm_m"),
                        b.along_upper_arm_m,
                        -1.0,
                        1.0,
                    );
                    v.in_range(
                        &format!("{name}.along_forearm_m"),
                        b.along_forearm_m,
                        -1.0,
                        1.0,
                    );
                }
            });
        }
        v.in_range(
            "encoder_counts_per_rev",
            self.encoder_counts_per_rev,
            1.0,
            1.0e9,
        );
        v.in_range("velocity_filter_s", self.velocity_filter_s, 0.0, 1.0);
    }
}
