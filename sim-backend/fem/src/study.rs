//! The two papers' studies: seed-001 (four models under a platen and the pulse; Table 1)
//! and seed-002 (a finger on tissue, tumour and artery; sweeps of artery diameter, wall
//! modulus, indentation and depth; the four tip shapes).

use rayon::prelude::*;

use super::contact::Tip;
use super::model::{Kinematics, Load, LumenPressure, ModelFile};
use super::run::{FemError, ModelRun, run_model};

/// The shipped model files (config/fem/).
pub const SHIPPED: [(&str, &str); 7] = [
    (
        "seed-001-tissue.ron",
        include_str!("../../../config/fem/seed-001-tissue.ron"),
    ),
    (
        "seed-001-tumour.ron",
        include_str!("../../../config/fem/seed-001-tumour.ron"),
    ),
    (
        "seed-001-healthy-artery.ron",
        include_str!("../../../config/fem/seed-001-healthy-artery.ron"),
    ),
    (
        "seed-001-stenotic-artery.ron",
        include_str!("../../../config/fem/seed-001-stenotic-artery.ron"),
    ),
    (
        "seed-002-tissue.ron",
        include_str!("../../../config/fem/seed-002-tissue.ron"),
    ),
    (
        "seed-002-tumour.ron",
        include_str!("../../../config/fem/seed-002-tumour.ron"),
    ),
    (
        "seed-002-artery.ron",
        include_str!("../../../config/fem/seed-002-artery.ron"),
    ),
];

/// A shipped model by file name.
pub fn shipped(name: &str) -> Result<ModelFile, config::ConfigError> {
    let src = SHIPPED
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
        .ok_or_else(|| config::ConfigError {
            file: name.to_string(),
            problems: vec![config::load::Problem {
                line: None,
                col: None,
                field: String::new(),
                message: "no such shipped FEM model".into(),
            }],
        })?;
    config::load_str(&format!("<embedded {name}>"), src)
}

/// Table 1 of paper 001: peak top von Mises, Pa, at t = 0, 0.159, 0.349, 0.425 s.
pub const TABLE1_TIMES_S: [f64; 4] = [0.0, 0.159, 0.349, 0.425];
pub const TABLE1_HEALTHY_PA: [f64; 4] = [5550.0, 5740.0, 6102.0, 6254.0];
pub const TABLE1_STENOTIC_PA: [f64; 4] = [6281.0, 6322.0, 6400.0, 6432.0];

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StudyOptions {
    /// Extra refinement levels.
    pub refine: u32,
    /// Solve the models in finite strain (neo-Hookean; the finger by a penalty on the
    /// deformed surface) instead of linear.
    pub finite_strain: bool,
}

fn apply(mut m: ModelFile, o: &StudyOptions) -> ModelFile {
    if o.finite_strain {
        m.kinematics = Kinematics::FiniteStrain { steps: 8 };
    }
    m
}

/// Told the name of each model as its solve ends (from the solving threads, in any order):
/// progress for a study that runs for minutes.
pub type ModelDone<'a> = &'a (dyn Fn(&str) + Sync);

fn run_all(
    models: Vec<ModelFile>,
    o: &StudyOptions,
    done: ModelDone<'_>,
) -> Result<Vec<ModelRun>, FemError> {
    models
        .into_par_iter()
        .map(|m| {
            let run = run_model(&apply(m, o), o.refine);
            if let Ok(r) = &run {
                done(&r.name);
            }
            run
        })
        .collect()
}

fn load_all(names: &[&str]) -> Result<Vec<ModelFile>, StudyError> {
    names
        .iter()
        .map(|n| shipped(n).map_err(StudyError::Config))
        .collect()
}

#[derive(Debug, Clone, thiserror::Error)]
pub enum StudyError {
    #[error("{0}")]
    Config(config::ConfigError),
    #[error("{0}")]
    Fem(#[from] FemError),
}

/// Paper 001: the four models in order tissue, tumour, healthy artery, stenotic artery.
#[derive(Debug, Clone)]
pub struct Seed001 {
    pub runs: Vec<ModelRun>,
}

impl Seed001 {
    /// Peaks of the healthy and stenotic models at the Table 1 times, if present.
    pub fn peaks(&self, model: &str) -> Option<Vec<f64>> {
        let run = self.runs.iter().find(|r| r.name == model)?;
        Some(run.times.iter().map(|t| t.summary.peak).collect())
    }
}

pub fn seed_001(o: &StudyOptions) -> Result<Seed001, StudyError> {
    seed_001_with(o, &|_| {})
}

/// [`seed_001`], telling `done` as each model is solved.
pub fn seed_001_with(o: &StudyOptions, done: ModelDone<'_>) -> Result<Seed001, StudyError> {
    let models = load_all(&[
        "seed-001-tissue.ron",
        "seed-001-tumour.ron",
        "seed-001-healthy-artery.ron",
        "seed-001-stenotic-artery.ron",
    ])?;
    Ok(Seed001 {
        runs: run_all(models, o, done)?,
    })
}

/// Paper 001 Fig. 3, the "2-D tactile image": the four models' top von Mises over x and
/// time, sampled `samples` times over one pulse period (systole in the middle). Linear
/// models superpose two solves, so this costs one factorization per model; with
/// `finite_strain` every sample is a Newton solve.
pub fn seed_001_image(o: &StudyOptions, samples: usize) -> Result<Seed001, StudyError> {
    seed_001_image_with(o, samples, &|_| {})
}

/// [`seed_001_image`], telling `done` as each model is solved.
pub fn seed_001_image_with(
    o: &StudyOptions,
    samples: usize,
    done: ModelDone<'_>,
) -> Result<Seed001, StudyError> {
    let mut models = load_all(&[
        "seed-001-tissue.ron",
        "seed-001-tumour.ron",
        "seed-001-healthy-artery.ron",
        "seed-001-stenotic-artery.ron",
    ])?;
    let period_s = models
        .iter()
        .find_map(|m| match m.lumen {
            Some(LumenPressure::Pulse { period_s, .. }) => Some(period_s),
            _ => None,
        })
        .unwrap_or(0.85);
    let n = samples.max(2);
    let times: Vec<f64> = (0..n)
        .map(|k| period_s * k as f64 / (n - 1) as f64)
        .collect();
    for m in &mut models {
        m.times_s = times.clone();
    }
    Ok(Seed001 {
        runs: run_all(models, o, done)?,
    })
}

/// One value of a swept parameter and the model's response.
#[derive(Debug, Clone)]
pub struct SweepPoint {
    /// The parameter in the sweep's display unit (mm, MPa).
    pub value: f64,
    pub run: ModelRun,
    /// Systolic minus diastolic top von Mises along x (Pa), and its value over the artery.
    pub difference_pa: Vec<f64>,
    pub swing_pa: f64,
}

#[derive(Debug, Clone)]
pub struct Sweep {
    pub name: &'static str,
    pub label: &'static str,
    pub points: Vec<SweepPoint>,
}

#[derive(Debug, Clone)]
pub struct Seed002 {
    /// tissue, tumour, artery under the base finger.
    pub base: Vec<ModelRun>,
    pub sweeps: Vec<Sweep>,
    /// The artery under the four tips at 3 mm (one run per tip), always linear.
    pub tips: Vec<ModelRun>,
}

/// Diastole and systole of the seed-002 pulse.
pub const DIASTOLE_S: f64 = 0.0;
pub const SYSTOLE_S: f64 = 0.425;

fn swing(run: &ModelRun) -> (Vec<f64>, f64) {
    let at = |t: f64| run.times.iter().find(|r| (r.t_s - t).abs() < 1e-12);
    match (at(DIASTOLE_S), at(SYSTOLE_S)) {
        (Some(d), Some(s)) => {
            let diff: Vec<f64> = s
                .von_mises_pa
                .iter()
                .zip(&d.von_mises_pa)
                .map(|(a, b)| a - b)
                .collect();
            // Read over the artery (x = 0): the maximum of the difference sits at the
            // contact's edge, where a node entering contact makes a mesh-dependent spike.
            let at_artery = super::recovery::interpolate(&d.x_m, &diff, 0.0);
            (diff, at_artery)
        }
        _ => (Vec::new(), f64::NAN),
    }
}

fn sweep(
    name: &'static str,
    label: &'static str,
    base: &ModelFile,
    values: &[f64],
    edit: impl Fn(&mut ModelFile, f64) + Sync,
    o: &StudyOptions,
    done: ModelDone<'_>,
) -> Result<Sweep, StudyError> {
    let models: Vec<ModelFile> = values
        .iter()
        .map(|&v| {
            let mut m = base.clone();
            m.times_s = vec![DIASTOLE_S, SYSTOLE_S];
            edit(&mut m, v);
            m.name = format!("{name}-{v}");
            m
        })
        .collect();
    let runs = run_all(models, o, done)?;
    let points = values
        .iter()
        .zip(runs)
        .map(|(&value, run)| {
            let (difference_pa, swing_pa) = swing(&run);
            SweepPoint {
                value,
                run,
                difference_pa,
                swing_pa,
            }
        })
        .collect();
    Ok(Sweep {
        name,
        label,
        points,
    })
}

/// Depth of the artery's top below the surface, m.
fn artery_top_depth(m: &ModelFile) -> f64 {
    m.feature.as_ref().map_or(f64::NAN, |f| {
        f.centre_depth_m
            - f.lumen_radius_m.unwrap_or(0.0)
            - f.layers.iter().map(|l| l.thickness_m).sum::<f64>()
    })
}

fn outer_radius(m: &ModelFile) -> f64 {
    m.feature.as_ref().map_or(0.0, |f| {
        f.lumen_radius_m.unwrap_or(0.0) + f.layers.iter().map(|l| l.thickness_m).sum::<f64>()
    })
}

pub fn seed_002(o: &StudyOptions) -> Result<Seed002, StudyError> {
    seed_002_with(o, &|_| {})
}

/// [`seed_002`], telling `done` as each model is solved.
pub fn seed_002_with(o: &StudyOptions, done: ModelDone<'_>) -> Result<Seed002, StudyError> {
    let base_models = load_all(&[
        "seed-002-tissue.ron",
        "seed-002-tumour.ron",
        "seed-002-artery.ron",
    ])?;
    let artery = base_models[2].clone();
    let base = run_all(base_models, o, done)?;
    let top = artery_top_depth(&artery);
    let mut sweeps = Vec::new();
    // Inner diameter 3 -> 9.5 mm, the artery's top kept at the base depth.
    sweeps.push(sweep(
        "diameter",
        "artery inner diameter (mm)",
        &artery,
        &[3.0, 4.5, 6.0, 7.5, 9.5],
        |m, d_mm| {
            if let Some(f) = m.feature.as_mut() {
                f.lumen_radius_m = Some(0.5 * d_mm * 1e-3);
            }
            let r = outer_radius(m);
            if let Some(f) = m.feature.as_mut() {
                f.centre_depth_m = top + r;
            }
        },
        o,
        done,
    )?);
    sweeps.push(sweep(
        "wall-modulus",
        "artery wall modulus (MPa)",
        &artery,
        &[0.4, 1.4, 2.4, 3.4, 4.4],
        |m, e_mpa| {
            if let Some(f) = m.feature.as_mut() {
                for l in &mut f.layers {
                    l.material.e_pa = e_mpa * 1e6;
                }
            }
        },
        o,
        done,
    )?);
    sweeps.push(sweep(
        "indentation",
        "finger indentation (mm)",
        &artery,
        // The paper's 2.5-4.1 mm and issue 16's 1.5-4.5 mm.
        &[1.5, 2.0, 2.5, 3.0, 3.5, 3.8, 4.1, 4.5],
        |m, d_mm| {
            if let Load::Finger { indent_m, .. } = &mut m.load {
                *indent_m = d_mm * 1e-3;
            }
        },
        o,
        done,
    )?);
    sweeps.push(sweep(
        "depth",
        "depth of the artery's top (mm)",
        &artery,
        &[10.5, 13.0, 15.5, 18.0, 20.5],
        |m, depth_mm| {
            let r = outer_radius(m);
            if let Some(f) = m.feature.as_mut() {
                f.centre_depth_m = depth_mm * 1e-3 + r;
            }
        },
        o,
        done,
    )?);
    let tips = Tip::PAPER_002;
    let tip_models: Vec<ModelFile> = tips
        .iter()
        .map(|&tip| {
            let mut m = artery.clone();
            m.load = Load::Finger {
                tip,
                indent_m: 0.003,
                centre_x_m: None,
            };
            m.times_s = vec![SYSTOLE_S];
            m.name = format!("tip-{}", tip.name());
            m
        })
        .collect();
    // The rectangular tip's sharp corner does not converge in finite strain (the elements
    // under the corner collapse at about a third of 3 mm; docs/fem.md), so the tip
    // comparison stays linear.
    let linear = StudyOptions {
        finite_strain: false,
        ..*o
    };
    let tips = run_all(tip_models, &linear, done)?;
    Ok(Seed002 { base, sweeps, tips })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peak_at(model: &str, refine: u32, t: f64) -> f64 {
        let mut m = shipped(model).unwrap();
        m.times_s = vec![t];
        run_model(&m, refine).unwrap().times[0].summary.peak
    }

    #[test]
    fn artery_peaks_converge_with_refinement_even_at_a_40x_contrast() {
        // Stenosis 600 kPa in 15 kPa tissue: a 40x stiffness contrast.
        for model in [
            "seed-001-healthy-artery.ron",
            "seed-001-stenotic-artery.ron",
        ] {
            let coarse = peak_at(model, 0, 0.425);
            let fine = peak_at(model, 1, 0.425);
            assert!(
                (coarse - fine).abs() < 0.005 * fine,
                "{model}: {coarse} vs {fine}"
            );
        }
        // The papers' ordering: the stenotic peak is larger, its systolic rise smaller.
        let h = [
            peak_at("seed-001-healthy-artery.ron", 0, 0.0),
            peak_at("seed-001-healthy-artery.ron", 0, 0.425),
        ];
        let s = [
            peak_at("seed-001-stenotic-artery.ron", 0, 0.0),
            peak_at("seed-001-stenotic-artery.ron", 0, 0.425),
        ];
        assert!(s[1] > h[1] && s[1] - s[0] < h[1] - h[0], "{h:?} {s:?}");
        // Linear Q4 lands at 70-80% of Table 1 (the independent check); a regression
        // outside that band means the model changed.
        let r = h[1] / TABLE1_HEALTHY_PA[3];
        assert!(r > 0.68 && r < 0.82, "{r}");
    }

    #[test]
    fn the_thin_wall_swing_converges() {
        // Paper 002's 0.63 mm wall under the finger: the swing over the artery, on the coarse
        // default mesh refined twice; the changes must shrink (about 49, 44, 41 Pa).
        let swing_at = |refine: u32| {
            let mut m = shipped("seed-002-artery.ron").unwrap();
            m.mesh = crate::model::MeshSpec::default();
            m.times_s = vec![DIASTOLE_S, SYSTOLE_S];
            swing(&run_model(&m, refine).unwrap()).1
        };
        let s: Vec<f64> = (0..3).map(swing_at).collect();
        let (d1, d2) = ((s[0] - s[1]).abs(), (s[1] - s[2]).abs());
        assert!(s[2] > 0.0 && d2 < 0.7 * d1 && d2 < 0.1 * s[2], "{s:?}");
    }

    #[test]
    fn the_finger_model_runs_in_finite_strain_from_its_file() {
        // Paper 002's artery under the elliptical finger, finite strain, on the coarse default
        // mesh: the file is accepted, the run converges, the finger flattens the lumen, and
        // the finite-strain swing is larger than the linear one on the same mesh.
        let run = |k: Kinematics| {
            let mut m = shipped("seed-002-artery.ron").unwrap();
            m.mesh = crate::model::MeshSpec::default();
            m.times_s = vec![DIASTOLE_S, SYSTOLE_S];
            m.kinematics = k;
            run_model(&m, 0).unwrap()
        };
        let finite = run(Kinematics::FiniteStrain { steps: 8 });
        let linear = run(Kinematics::Linear);
        let (s_fin, s_lin) = (swing(&finite).1, swing(&linear).1);
        assert!(
            s_fin > 0.0 && s_lin > 0.0 && s_fin > 1.2 * s_lin,
            "{s_fin} vs {s_lin}"
        );
        let h = finite.times[0].lumen_height_m;
        assert!(h > 0.0025 && h < 0.0045, "lumen height {h}");
    }

    #[test]
    fn every_shipped_model_loads() {
        for (name, _) in SHIPPED {
            shipped(name).unwrap();
        }
        assert!(shipped("nope.ron").is_err());
    }
}
