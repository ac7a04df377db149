//! Scene families: RON files (`Family(version: 1, ...)`) that describe *distributions* of
//! scenes, so that a tracker is measured on shapes and rigs it was never tuned on.
//!
//! A family names a base scene (the rig: tissue, sensor, shaft, pivot, mass, robot), the
//! kinds of course to draw with their weights and parameter ranges, the tracked length and
//! the limits every drawn course keeps (the heading relative to `x`, the tightest radius,
//! the workspace), and optionally ranges for the heart, the artery's size and depth, the
//! sensor noise, the instrument, lumps beside the artery and breathing. [`LoadedFamily::draw`]
//! turns (family, seed) into one ordinary [`Scene`], deterministically; every effect it
//! draws is a field of the scene schema, so a drawn scene written out with
//! [`crate::scene::to_ron`] is a scene file like any other. docs/sim.md describes the format
//! and the shipped families.

mod course;
mod draw;
mod shipped;
mod validate;

#[cfg(test)]
mod tests;

use std::path::Path;

use config::ConfigError;
use serde::{Deserialize, Serialize};

use crate::scene::Scene;

pub use shipped::{SHIPPED_FAMILIES, shipped_family_names, shipped_family_source};

/// The family file format version this build reads.
pub const FAMILY_VERSION: u32 = 1;

/// A range `(low, high)` drawn uniformly; `(x, x)` is the fixed value `x`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval(pub f64, pub f64);

/// A range of counts `(low, high)`, both included, drawn uniformly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct CountInterval(pub u32, pub u32);

/// A whole family.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Family", deny_unknown_fields)]
pub struct Family {
    pub version: u32,
    /// Short name; drawn scenes are named `<name>-<seed>`.
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// The scene every draw starts from: a shipped scene name or a file (relative to the
    /// family file). Its rig is kept; its course, placements, track, start and lumps are
    /// replaced by the draw.
    pub base: String,
    /// The kinds of course, drawn in proportion to their weights.
    pub courses: Vec<WeightedCourse>,
    /// Path length to follow from the first placement, m.
    pub track_length_m: Interval,
    /// The largest angle, rad, between the artery and the `x` axis anywhere on the tracked
    /// part (and its start heading's range): the element line lies along `z` and cannot
    /// follow a course running along it (DESIGN.md section 6), so at most 60°.
    #[serde(default = "sixty_degrees")]
    pub max_heading_rad: f64,
    /// Track toward `-x` in half of the draws (the course turned by 180°).
    #[serde(default = "yes")]
    pub either_direction: bool,
    /// No arc of a drawn course is tighter than this, m (draws that are, are redrawn);
    /// corner courses are exempt (their fillets are part of the bend).
    #[serde(default)]
    pub min_radius_m: Option<f64>,
    /// Where the whole course (with the array's reach around it) must lie on the tissue.
    #[serde(default)]
    pub workspace: Workspace,
    /// The pulse; absent: the base scene's.
    #[serde(default)]
    pub heart: Option<HeartFamily>,
    /// The artery's depth and size; absent: the base scene's.
    #[serde(default)]
    pub artery: Option<ArteryFamily>,
    /// Each element's noise SD, N; absent: the base scene's.
    #[serde(default)]
    pub noise_sd_n: Option<Interval>,
    /// The instrument and the incision; absent: the base scene's.
    #[serde(default)]
    pub instrument: Option<InstrumentFamily>,
    /// Lumps beside the artery; absent: none.
    #[serde(default)]
    pub lumps: Option<LumpFamily>,
    /// The tissue moving with breathing; absent: at rest.
    #[serde(default)]
    pub breathing: Option<BreathingFamily>,
}

fn sixty_degrees() -> f64 {
    60f64.to_radians()
}

fn yes() -> bool {
    true
}

fn one() -> f64 {
    1.0
}

/// A kind of course and its weight among the family's courses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeightedCourse {
    #[serde(default = "one")]
    pub weight: f64,
    pub course: CourseFamily,
}

/// How one kind of course is drawn. Every course is drawn in its own frame, then turned to
/// a start heading drawn uniformly over the headings that keep the tracked part within
/// `max_heading_rad` of `x`, and centred in the workspace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum CourseFamily {
    /// A random smooth course (a [`crate::scene::PathSpec::Clothoid`]): the curvature
    /// changes linearly between knots `knot_spacing_m` apart, each knot's curvature drawn
    /// within `±max_curvature_per_m` and within `max_curvature_rate_per_m2` times the
    /// spacing of the previous one's, steered to keep the heading bound.
    Smooth {
        max_curvature_per_m: f64,
        max_curvature_rate_per_m2: f64,
        knot_spacing_m: Interval,
    },
    /// A sine wave (random phase).
    Sinusoid {
        amplitude_m: Interval,
        wavelength_m: Interval,
    },
    /// A spiral of shrinking radius (random turn).
    Spiral {
        start_radius_m: Interval,
        end_radius_m: Interval,
    },
    /// The seed's S-curve: two arcs of equal radius and opposite turn.
    SCurve { radius_m: Interval },
    /// A circular arc (random turn).
    Arc { radius_m: Interval },
    /// Straight legs with `bends` corners, each turning by an angle drawn from `bend_rad`
    /// (random side), rounded by a fillet drawn from `fillet_radius_m` ((0, 0): sharp);
    /// no leg after the first placement is shorter than `min_leg_m`.
    Corners {
        bends: CountInterval,
        bend_rad: Interval,
        #[serde(default)]
        fillet_radius_m: Option<Interval>,
        #[serde(default = "default_min_leg")]
        min_leg_m: f64,
    },
}

fn default_min_leg() -> f64 {
    0.03
}

/// The rectangle of the tissue plane a drawn course keeps to, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Workspace {
    pub x_m: Interval,
    pub z_m: Interval,
    /// How far around the course must also lie inside (the array reaches 9 mm to each
    /// side of its centre), m.
    #[serde(default = "reach")]
    pub margin_m: f64,
}

fn reach() -> f64 {
    0.01
}

impl Default for Workspace {
    /// Where the shipped scenes' arcs lie on the shipped rig (their tracked parts span
    /// x ±0.12 m, z -0.03 to 0.07 m), which the shipped simulator configuration reaches
    /// (tested).
    fn default() -> Self {
        Self {
            x_m: Interval(-0.13, 0.13),
            z_m: Interval(-0.04, 0.08),
            margin_m: reach(),
        }
    }
}

/// The pulse: a physiological waveform drawn per scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeartFamily {
    pub rate_hz: Interval,
    /// Beat-interval SD as a fraction of the mean interval.
    #[serde(default = "zero")]
    pub interval_sd_fraction: Interval,
    /// Beat-to-beat SD of the pulse pressure, as a fraction.
    #[serde(default = "zero")]
    pub pressure_sd_fraction: Interval,
    /// Probability of a premature beat after each beat; (0, 0): none.
    #[serde(default = "zero")]
    pub ectopic_probability: Interval,
    /// Systolic minus diastolic pressure, Pa.
    pub pulse_pressure_pa: Interval,
    #[serde(default = "zero")]
    pub diastolic_pa: Interval,
}

fn zero() -> Interval {
    Interval(0.0, 0.0)
}

/// The artery's depth (constant along it) and size; each absent keeps the base scene's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArteryFamily {
    #[serde(default)]
    pub depth_m: Option<Interval>,
    #[serde(default)]
    pub inner_radius_m: Option<Interval>,
    #[serde(default)]
    pub wall_m: Option<Interval>,
}

/// The instrument and the incision; each absent keeps the base scene's (a section the base
/// scene lacks is added with the drawn value and its other fields' defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentFamily {
    #[serde(default)]
    pub mass_kg: Option<Interval>,
    #[serde(default)]
    pub shaft_diameter_m: Option<Interval>,
    #[serde(default)]
    pub shaft_youngs_modulus_pa: Option<Interval>,
    #[serde(default)]
    pub pivot_stiffness_n_per_m: Option<Interval>,
}

/// Lumps that do not pulse, beside the tracked part of the artery.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LumpFamily {
    pub count: CountInterval,
    /// Distance from the artery to the lump's centre, to either side, m.
    pub lateral_offset_m: Interval,
    pub depth_m: Interval,
    pub pressure_gain: Interval,
}

/// Breathing motion of the tissue.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BreathingFamily {
    pub amplitude_m: Interval,
    pub frequency_hz: Interval,
    /// Direction of the motion, rad from `+x`; default across the course, along `z`.
    #[serde(default = "along_z")]
    pub direction_rad: Interval,
}

fn along_z() -> Interval {
    Interval(std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2)
}

/// A family with its base scene, ready to draw from.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedFamily {
    pub family: Family,
    pub base: Scene,
}

/// Load a shipped family by file name (`sinusoids.ron`, with or without `.ron`) or a family
/// file by path (relative paths against `base_dir` when given), with its base scene
/// (resolved against the family file's directory, or the shipped scenes).
pub fn load(name_or_path: &str, base_dir: Option<&Path>) -> Result<LoadedFamily, ConfigError> {
    let as_path = Path::new(name_or_path);
    let resolved = match base_dir {
        Some(dir) if as_path.is_relative() => dir.join(as_path),
        _ => as_path.to_path_buf(),
    };
    let (family, dir, origin) = if resolved.is_file() {
        let loaded = config::load_file::<Family>(&resolved)?;
        (loaded.value, loaded.dir, loaded.origin)
    } else if let Some((name, text)) = shipped_family_source(name_or_path) {
        let origin = format!("<shipped family {name}>");
        (config::load_str::<Family>(&origin, text)?, None, origin)
    } else {
        return Err(ConfigError {
            file: resolved.display().to_string(),
            problems: vec![config::load::Problem {
                line: None,
                col: None,
                field: String::new(),
                message: format!(
                    "no such family file, and not a shipped family ({})",
                    shipped_family_names().join(", ")
                ),
            }],
        });
    };
    let base = crate::scene::load(&family.base, dir.as_deref()).map_err(|e| ConfigError {
        file: origin.clone(),
        problems: vec![config::load::Problem {
            line: config_line(&origin, "base"),
            col: None,
            field: "base".into(),
            message: format!("the base scene does not load: {e}"),
        }],
    })?;
    Ok(LoadedFamily { family, base })
}

/// The line of `field` in a family file, for errors found after loading.
fn config_line(origin: &str, field: &str) -> Option<usize> {
    let text = std::fs::read_to_string(origin).ok().or_else(|| {
        let name = origin.strip_prefix("<shipped family ")?.strip_suffix('>')?;
        shipped_family_source(name).map(|(_, t)| t.to_string())
    })?;
    text.lines()
        .position(|l| l.trim_start().starts_with(&format!("{field}:")))
        .map(|i| i + 1)
}
