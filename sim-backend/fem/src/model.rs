//! A FEM model described in RON (`config/fem/*.ron`), read with `config::load_file`.
//!
//! ```ron
//! FemModel(
//!     version: 1,
//!     name: "healthy-artery",
//!     analysis: PlaneStress,
//!     block: (width_m: 0.08, height_m: 0.03),
//!     tissue: (e_pa: 15e3, nu: 0.45),
//!     feature: (
//!         centre_x_m: 0.04, centre_depth_m: 0.015, lumen_radius_m: 0.004,
//!         layers: [(name: "wall", thickness_m: 0.001, material: (e_pa: 300e3, nu: 0.49))],
//!     ),
//!     load: Platen(indent_m: 0.0075),
//!     lumen: Pulse(diastolic_pa: 10666, systolic_pa: 16000, systole_s: 0.425, period_s: 0.85),
//!     times_s: [0.0, 0.159, 0.349, 0.425],
//! )
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use config::{Validate, Validator};

use super::contact::Tip;
use super::material::{Analysis, Material};
use super::mesher::{Density, Feature, Layer, check_size};

/// The model file format version this build reads.
pub const MODEL_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "FemModel", deny_unknown_fields)]
pub struct ModelFile {
    pub version: u32,
    pub name: String,
    pub analysis: Analysis,
    #[serde(default)]
    pub kinematics: Kinematics,
    pub block: Block,
    pub tissue: Material,
    #[serde(default)]
    pub feature: Option<FeatureSpec>,
    pub load: Load,
    /// The bottom's support (default: held in y, as in both papers).
    #[serde(default)]
    pub bottom: Bottom,
    #[serde(default)]
    pub lumen: Option<LumenPressure>,
    /// Output times, s (default: just t = 0).
    #[serde(default = "default_times")]
    pub times_s: Vec<f64>,
    #[serde(default)]
    pub mesh: MeshSpec,
    /// A Gmsh MSH 4.1 mesh to solve on instead of the built-in mesher's (docs/fem.md,
    /// "Gmsh meshes"); a relative path is taken from the model file's directory
    /// ([`ModelFile::resolve_mesh_file`]).
    #[serde(default)]
    pub mesh_file: Option<PathBuf>,
}

fn default_times() -> Vec<f64> {
    vec![0.0]
}

/// Small strain (superposition for prescribed loading) or finite strain.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Kinematics {
    #[default]
    Linear,
    /// Compressible neo-Hookean, total Lagrangian, with `steps` initial load increments.
    FiniteStrain { steps: u32 },
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Block {
    pub width_m: f64,
    pub height_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureSpec {
    pub centre_x_m: f64,
    /// Depth of the centre below the top surface.
    pub centre_depth_m: f64,
    /// Lumen radius (a hole with pressure on its wall); absent for a solid inclusion.
    #[serde(default)]
    pub lumen_radius_m: Option<f64>,
    /// Layers from the inside out (the first is the solid core when there is no lumen).
    pub layers: Vec<LayerSpec>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerSpec {
    pub name: String,
    /// Radial thickness (the radius for a solid core).
    pub thickness_m: f64,
    pub material: Material,
}

/// How the bottom edge is supported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Bottom {
    /// Held in y, free in x (a frictionless table).
    #[default]
    Held,
    /// Traction-free: the block hangs from a platen (the kernel's half-space stand-in, whose
    /// surface then carries zero net force, as a half-space's does).
    Free,
}

/// How the top surface is loaded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Load {
    /// The whole top pushed down by `indent_m` (frictionless: x free), as in paper 001.
    /// `indent_m: 0` holds the surface flat (a rigid flat sensor; the kernel's case).
    Platen { indent_m: f64 },
    /// A rigid finger in frictionless contact, as in paper 002. `centre_x_m` defaults to
    /// the feature's (or the block's middle).
    Finger {
        tip: Tip,
        indent_m: f64,
        #[serde(default)]
        centre_x_m: Option<f64>,
    },
}

/// Lumen pressure against time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum LumenPressure {
    Constant {
        pressure_pa: f64,
    },
    /// Linear rise from diastolic at t = 0 to systolic at `systole_s`, linear fall back to
    /// diastolic at `period_s`, repeating (paper 001's loading).
    Pulse {
        diastolic_pa: f64,
        systolic_pa: f64,
        systole_s: f64,
        period_s: f64,
    },
}

impl LumenPressure {
    pub fn at(&self, t_s: f64) -> f64 {
        match *self {
            LumenPressure::Constant { pressure_pa } => pressure_pa,
            LumenPressure::Pulse {
                diastolic_pa,
                systolic_pa,
                systole_s,
                period_s,
            } => {
                let t = t_s.rem_euclid(period_s);
                let s = if t <= systole_s {
                    t / systole_s
                } else {
                    1.0 - (t - systole_s) / (period_s - systole_s)
                };
                diastolic_pa + s * (systolic_pa - diastolic_pa)
            }
        }
    }
}

/// Mesh density; every `refine` level halves the element sizes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeshSpec {
    pub near_size_m: f64,
    pub far_size_m: f64,
    pub min_layer_elements: usize,
    pub growth: f64,
    pub refine: u32,
}

impl Default for MeshSpec {
    fn default() -> Self {
        Self {
            near_size_m: 0.0004,
            far_size_m: 0.0016,
            min_layer_elements: 4,
            growth: 1.15,
            refine: 0,
        }
    }
}

impl MeshSpec {
    pub fn density(&self, extra_refine: u32) -> Density {
        Density {
            near_size_m: self.near_size_m,
            far_size_m: self.far_size_m,
            min_layer_elements: self.min_layer_elements,
            growth: self.growth,
        }
        .refined(self.refine + extra_refine)
    }
}

/// Largest refinement level accepted (each level quadruples the element count).
pub const MAX_REFINE: u32 = 5;

impl ModelFile {
    /// Materials by region: 0 = tissue, then the feature's layers in order.
    pub fn materials(&self) -> Vec<Material> {
        let mut m = vec![self.tissue];
        if let Some(f) = &self.feature {
            m.extend(f.layers.iter().map(|l| l.material));
        }
        m
    }

    /// The mesher's view of the feature.
    pub fn feature(&self) -> Option<Feature> {
        let f = self.feature.as_ref()?;
        let mut r = f.lumen_radius_m.unwrap_or(0.0);
        let layers = f
            .layers
            .iter()
            .enumerate()
            .map(|(i, l)| {
                r += l.thickness_m;
                Layer {
                    outer_radius_m: r,
                    region: (i + 1) as u16,
                }
            })
            .collect();
        Some(Feature {
            centre_x_m: f.centre_x_m,
            centre_depth_m: f.centre_depth_m,
            lumen_radius_m: f.lumen_radius_m,
            layers,
        })
    }

    /// Lateral reference for outputs: the feature's centre, else the block's middle.
    pub fn x_origin_m(&self) -> f64 {
        self.feature
            .as_ref()
            .map_or(0.5 * self.block.width_m, |f| f.centre_x_m)
    }

    pub fn pressure_at(&self, t_s: f64) -> f64 {
        self.lumen.map_or(0.0, |l| l.at(t_s))
    }

    /// Take a relative `mesh_file` from `dir`, the model file's directory
    /// (`config::Loaded::dir`).
    pub fn resolve_mesh_file(&mut self, dir: Option<&Path>) {
        if let (Some(f), Some(dir)) = (&self.mesh_file, dir)
            && f.is_relative()
        {
            self.mesh_file = Some(dir.join(f));
        }
    }
}

fn validate_material(v: &mut Validator, field: &str, m: &Material) {
    v.at(field, |v| {
        v.positive("e_pa", m.e_pa);
        if v.finite("nu", m.nu) {
            v.check(
                m.nu > -1.0 && m.nu < 0.5,
                "nu",
                format!("Poisson's ratio must be in (-1, 0.5), got {}", m.nu),
            );
        }
    });
}

impl Validate for ModelFile {
    fn validate(&self, v: &mut Validator) {
        let problems_before = v.problem_count();
        v.check(
            self.version == MODEL_VERSION,
            "version",
            format!(
                "unsupported version {} (this build reads {MODEL_VERSION})",
                self.version
            ),
        );
        v.check(!self.name.trim().is_empty(), "name", "must not be empty");
        if let Kinematics::FiniteStrain { steps } = self.kinematics {
            v.check(
                (1..=1000).contains(&steps),
                "kinematics.steps",
                format!("must be between 1 and 1000, got {steps}"),
            );
        }
        v.at("block", |v| {
            v.positive("width_m", self.block.width_m);
            v.positive("height_m", self.block.height_m);
        });
        validate_material(v, "tissue", &self.tissue);
        if let Some(f) = &self.feature {
            v.at("feature", |v| {
                v.in_range("centre_x_m", f.centre_x_m, 0.0, self.block.width_m);
                v.in_range("centre_depth_m", f.centre_depth_m, 0.0, self.block.height_m);
                if let Some(r) = f.lumen_radius_m {
                    v.positive("lumen_radius_m", r);
                }
                v.check(!f.layers.is_empty(), "layers", "needs at least one layer");
                for (i, l) in f.layers.iter().enumerate() {
                    v.at(&format!("layers[{i}]"), |v| {
                        v.positive("thickness_m", l.thickness_m);
                        validate_material(v, "material", &l.material);
                    });
                }
                let outer = f.lumen_radius_m.unwrap_or(0.0)
                    + f.layers.iter().map(|l| l.thickness_m).sum::<f64>();
                // Sideways room is `centre_x_m`'s, vertical room `centre_depth_m`'s: each
                // is reported under the field that would have to change.
                let needed = 1.15 * outer;
                let sideways = f.centre_x_m.min(self.block.width_m - f.centre_x_m);
                let vertical = f.centre_depth_m.min(self.block.height_m - f.centre_depth_m);
                for (field, room, edges) in [
                    ("centre_x_m", sideways, "left and right edges"),
                    ("centre_depth_m", vertical, "top and bottom edges"),
                ] {
                    v.check(
                        !(outer.is_finite() && room.is_finite()) || room >= needed,
                        field,
                        format!(
                            "the feature (outer radius {outer} m) needs at least {needed} m to \
                             the block's {edges}; it has {room} m"
                        ),
                    );
                }
            });
        }
        v.at("load", |v| match self.load {
            Load::Platen { indent_m } => {
                v.finite("Platen.indent_m", indent_m);
            }
            Load::Finger {
                tip,
                indent_m,
                centre_x_m,
            } => {
                v.check(
                    tip.is_valid(),
                    "Finger.tip",
                    "sizes must be positive (a fillet no larger than the half width)",
                );
                v.finite("Finger.indent_m", indent_m);
                if let Some(x) = centre_x_m {
                    v.in_range("Finger.centre_x_m", x, 0.0, self.block.width_m);
                }
            }
        });
        if let Some(l) = &self.lumen {
            v.at("lumen", |v| match *l {
                LumenPressure::Constant { pressure_pa } => {
                    v.finite("Constant.pressure_pa", pressure_pa);
                }
                LumenPressure::Pulse {
                    diastolic_pa,
                    systolic_pa,
                    systole_s,
                    period_s,
                } => {
                    v.finite("Pulse.diastolic_pa", diastolic_pa);
                    v.finite("Pulse.systolic_pa", systolic_pa);
                    v.positive("Pulse.systole_s", systole_s);
                    if v.finite("Pulse.period_s", period_s) {
                        v.check(
                            period_s > systole_s,
                            "Pulse.period_s",
                            "must be longer than systole_s",
                        );
                    }
                }
            });
            let has_lumen = self
                .feature
                .as_ref()
                .is_some_and(|f| f.lumen_radius_m.is_some());
            v.check(
                has_lumen,
                "lumen",
                "lumen pressure needs a feature with a lumen",
            );
        }
        v.check(
            !self.times_s.is_empty(),
            "times_s",
            "needs at least one time",
        );
        v.all_finite("times_s", &self.times_s);
        if let Some(f) = &self.mesh_file {
            v.check(
                !f.as_os_str().is_empty(),
                "mesh_file",
                "must name a .msh file",
            );
            v.check(
                self.mesh == MeshSpec::default(),
                "mesh",
                "sets the built-in mesher's density, which a Gmsh mesh (mesh_file) does not \
                 use: remove one of them",
            );
        }
        v.at("mesh", |v| {
            v.positive("near_size_m", self.mesh.near_size_m);
            v.positive("far_size_m", self.mesh.far_size_m);
            v.check(
                self.mesh.min_layer_elements >= 1 && self.mesh.min_layer_elements <= 64,
                "min_layer_elements",
                "must be between 1 and 64",
            );
            if v.finite("growth", self.mesh.growth) {
                v.check(
                    self.mesh.growth > 1.0 && self.mesh.growth <= 2.0,
                    "growth",
                    format!("must be in (1, 2], got {}", self.mesh.growth),
                );
            }
            v.check(
                self.mesh.refine <= MAX_REFINE,
                "refine",
                format!("must be at most {MAX_REFINE}"),
            );
        });
        // Once every size is sane: a mesh beyond the mesher's node limit is refused here,
        // when the file is read, not after minutes of meshing.
        if v.problem_count() == problems_before
            && self.mesh_file.is_none()
            && let Err(e) = check_size(
                self.block.width_m,
                self.block.height_m,
                self.feature().as_ref(),
                &self.mesh.density(0),
            )
        {
            v.problem("mesh", e.to_string());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"FemModel(
    version: 1,
    name: "demo",
    analysis: PlaneStress,
    block: (width_m: 0.08, height_m: 0.03),
    tissue: (e_pa: 15e3, nu: 0.45),
    feature: (
        centre_x_m: 0.04,
        centre_depth_m: 0.015,
        lumen_radius_m: 0.004,
        layers: [(name: "wall", thickness_m: 0.001, material: (e_pa: 300e3, nu: 0.49))],
    ),
    load: Finger(tip: Elliptical(semi_width_m: 0.008, semi_height_m: 0.004), indent_m: 0.003),
    lumen: Pulse(diastolic_pa: 10666, systolic_pa: 16000, systole_s: 0.425, period_s: 0.85),
    times_s: [0.0, 0.425],
)"#;

    #[test]
    fn a_good_file_loads() {
        let m: ModelFile = config::load_str("good.ron", GOOD).unwrap();
        assert_eq!(m.materials().len(), 2);
        assert!((m.pressure_at(0.425) - 16000.0).abs() < 1e-9);
        assert!((m.pressure_at(0.85 + 0.2125) - 13333.0).abs() < 1.0);
        let f = m.feature().unwrap();
        assert!((f.layers[0].outer_radius_m - 0.005).abs() < 1e-15);
    }

    /// The load error of the good file with `from` replaced by `to`.
    fn error_for(from: &str, to: &str) -> String {
        config::load_str::<ModelFile>("bad.ron", &GOOD.replace(from, to))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn bad_values_name_file_line_and_field() {
        let bad = GOOD.replace("nu: 0.49", "nu: 0.5");
        let e = config::load_str::<ModelFile>("bad.ron", &bad).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("bad.ron:11:"), "{msg}");
        assert!(msg.contains("feature.layers[0].material.nu"), "{msg}");

        let msg = error_for("centre_depth_m: 0.015", "centre_depth_m: 0.004");
        assert!(
            msg.contains("bad.ron:9:") && msg.contains("centre_depth_m"),
            "{msg}"
        );

        // Too close to the left edge: reported under the field that places it sideways,
        // with its line, and not under the depth, which is fine.
        let msg = error_for("centre_x_m: 0.04", "centre_x_m: 0.004");
        assert!(
            msg.contains("bad.ron:8:")
                && msg.contains("feature.centre_x_m")
                && msg.contains("left and right")
                && !msg.contains("centre_depth_m"),
            "{msg}"
        );

        let msg = error_for("semi_height_m", "semi_heigth_m");
        assert!(
            msg.starts_with("bad.ron:13:") && msg.contains("semi_heigth_m"),
            "{msg}"
        );

        let msg = error_for("times_s: [0.0, 0.425]", "times_s: []");
        assert!(msg.contains(":15:") && msg.contains("times_s"), "{msg}");
    }

    /// Found with the `fem_model_loader` fuzz target (docs/fuzzing.md): a model whose block
    /// is far larger than its mesh size passed validation, then the mesher overflowed
    /// (`nx + 1` on a saturated count: a panic in debug builds, a huge allocation in
    /// release) or allocated gigabytes of grid lines before its node limit refused it.
    #[test]
    fn a_mesh_beyond_the_node_limit_is_refused_when_read() {
        let plain = r#"FemModel(version: 1, name: "wide", analysis: PlaneStress,
            block: (width_m: 1e30, height_m: 0.03), tissue: (e_pa: 15e3, nu: 0.45),
            load: Platen(indent_m: 0.0075))"#;
        let long = GOOD
            .replace("width_m: 0.08", "width_m: 1e5")
            .replace("centre_x_m: 0.04", "centre_x_m: 5e4");
        for (name, text) in [("wide.ron", plain), ("long.ron", long.as_str())] {
            let msg = config::load_str::<ModelFile>(name, text)
                .unwrap_err()
                .to_string();
            assert!(
                msg.starts_with(name) && msg.contains("field `mesh`") && msg.contains("3000000"),
                "{msg}"
            );
        }
        // The shipped sizes still pass, up to the largest refinement.
        let fine = GOOD.replace("times_s", "mesh: (refine: 5),\n    times_s");
        config::load_str::<ModelFile>("fine.ron", &fine).unwrap();
    }
}
