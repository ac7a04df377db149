//! Paper 002's indentation study in finite strain, with what a collapse needs (issue 16):
//! the swing over the artery against the finger's indentation, with the lumen's shape and
//! self-contact at diastole and systole, for a choice of lumen model (dead or follower
//! pressure, with or without self-contact).
//!
//! The model is the shipped `seed-002-artery.ron` with only the indentation changed; the
//! swing is the study's ([`super::study`]): systolic minus diastolic top von Mises over the
//! artery (x = 0).

use std::time::Instant;

use rayon::prelude::*;

use super::finite::{LoadPath, LumenModel, LumenState, solve_times_with};
use super::material::von_mises;
use super::model::{Kinematics, Load, MeshSpec};
use super::recovery::{interpolate, summarize};
use super::run::{FemError, build_mesh};
use super::study::{DIASTOLE_S, SYSTOLE_S, StudyError, shipped};

/// The top edge and the lumen at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Snapshot {
    /// Top von Mises over the artery and its peak along the top, Pa.
    pub at_artery_pa: f64,
    pub peak_pa: f64,
    pub lumen: Option<LumenState>,
}

/// One indentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollapsePoint {
    pub indent_mm: f64,
    /// Systolic minus diastolic top von Mises over the artery, Pa.
    pub swing_pa: f64,
    pub diastole: Snapshot,
    pub systole: Snapshot,
    pub dofs: usize,
    /// Newton iterations, cut load steps and Newton steps solved without the follower's
    /// load stiffness, over the whole load path.
    pub newton: [usize; 3],
    pub wall_s: f64,
}

/// How to solve each indentation of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepOptions {
    /// Extra refinement levels.
    pub refine: u32,
    /// Initial load increments.
    pub steps: u32,
    pub lumen: LumenModel,
    pub path: LoadPath,
    /// Lumen pressure at zero (and the swing then 0): what the finger alone does.
    pub unpressurized: bool,
    /// A mesh density instead of the model file's (e.g. a coarse one for a quick look).
    pub mesh: Option<MeshSpec>,
}

impl Default for SweepOptions {
    fn default() -> Self {
        Self {
            refine: 0,
            steps: 8,
            lumen: LumenModel::default(),
            path: LoadPath::Together,
            unpressurized: false,
            mesh: None,
        }
    }
}

/// Solve the seed-002 artery at each indentation (mm) in finite strain; the indentations
/// are solved side by side, each from the unloaded state. One result per indentation: a
/// solve that fails does not hide the others.
pub fn indentation_sweep(
    indents_mm: &[f64],
    o: &SweepOptions,
) -> Result<Vec<Result<CollapsePoint, StudyError>>, StudyError> {
    let base = shipped("seed-002-artery.ron").map_err(StudyError::Config)?;
    Ok(indents_mm
        .par_iter()
        .map(|&d_mm| -> Result<CollapsePoint, StudyError> {
            let start = Instant::now();
            let mut m = base.clone();
            if let Load::Finger { indent_m, .. } = &mut m.load {
                *indent_m = d_mm * 1e-3;
            }
            m.times_s = vec![DIASTOLE_S, SYSTOLE_S];
            m.kinematics = Kinematics::FiniteStrain { steps: o.steps };
            if o.unpressurized {
                m.lumen = None;
            }
            if let Some(spec) = o.mesh {
                m.mesh = spec;
            }
            m.name = format!("indentation-{d_mm}");
            let mesh = build_mesh(&m, o.refine)?;
            let (states, newton) =
                solve_times_with(&m, &mesh, o.steps, o.lumen, o.path).map_err(|source| {
                    FemError::Solve {
                        model: m.name.clone(),
                        source,
                    }
                })?;
            let x0 = m.x_origin_m();
            let x = mesh.top_x_m(x0);
            let snap = |k: usize| -> Snapshot {
                let vm: Vec<f64> = states[k]
                    .stresses
                    .iter()
                    .map(|s| von_mises(s[0], s[1], s[2], s[3]))
                    .collect();
                Snapshot {
                    at_artery_pa: interpolate(&x, &vm, 0.0),
                    peak_pa: summarize(&x, &vm, 0.0).peak,
                    lumen: states[k].lumen,
                }
            };
            let (diastole, systole) = (snap(0), snap(1));
            Ok(CollapsePoint {
                indent_mm: d_mm,
                swing_pa: systole.at_artery_pa - diastole.at_artery_pa,
                diastole,
                systole,
                dofs: mesh.dofs(),
                newton,
                wall_s: start.elapsed().as_secs_f64(),
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::run_model;

    #[test]
    fn the_sweep_reads_the_swing_as_the_study_does_and_sees_the_lumen() {
        // Two indentations on the coarse default mesh: the swing agrees with the one read
        // from the CLI's path (run_model, the same solve), the lumen is open and narrower
        // under the deeper finger, nothing is in self-contact.
        let o = SweepOptions {
            mesh: Some(MeshSpec::default()),
            ..SweepOptions::default()
        };
        let points = indentation_sweep(&[1.5, 3.0], &o).unwrap();
        let p: Vec<&CollapsePoint> = points.iter().map(|p| p.as_ref().unwrap()).collect();
        let mut m = shipped("seed-002-artery.ron").unwrap();
        m.mesh = MeshSpec::default();
        m.times_s = vec![DIASTOLE_S, SYSTOLE_S];
        m.kinematics = Kinematics::FiniteStrain { steps: 8 };
        if let Load::Finger { indent_m, .. } = &mut m.load {
            *indent_m = 0.003;
        }
        let run = run_model(&m, 0).unwrap();
        let at = |k: usize| interpolate(&run.times[k].x_m, &run.times[k].von_mises_pa, 0.0);
        let swing = at(1) - at(0);
        assert!(
            (p[1].swing_pa - swing).abs() < 1e-9 * swing,
            "{} vs {swing}",
            p[1].swing_pa
        );
        assert!(p[0].swing_pa > 0.0 && p[1].swing_pa > 0.0);
        let open = |q: &CollapsePoint| q.diastole.lumen.and_then(|l| l.opening_m).unwrap();
        assert!(
            open(p[0]) > open(p[1]) && open(p[1]) > 0.003,
            "{} {}",
            open(p[0]),
            open(p[1])
        );
        for q in &p {
            for s in [q.diastole, q.systole] {
                assert_eq!(s.lumen.map(|l| l.contact_nodes), Some(0));
            }
            assert!(q.systole.lumen.unwrap().area_m2 > q.diastole.lumen.unwrap().area_m2);
            assert!(q.newton[0] > 0 && q.newton[2] == 0, "{:?}", q.newton);
        }
    }
}
