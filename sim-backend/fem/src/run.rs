//! Run one model: mesh it, apply supports and loads, solve at each output time and recover
//! the top-edge stresses. The supports are [`super::boundary`]'s.

use std::time::Instant;

use serde::Serialize;

use super::boundary::supports;
use super::contact::{Indenter, solve_contact};
use super::finite;
use super::gmsh::{Expected, GmshError, read_mesh};
use super::linear::{LinearModel, Timings};
use super::material::von_mises;
use super::mesh::Mesh;
use super::mesher::{MeshError, mesh_block};
use super::model::{Kinematics, Load, ModelFile};
use super::recovery::{CurveSummary, summarize};
use super::solve_error::SolveError;

#[derive(Debug, Clone, thiserror::Error)]
pub enum FemError {
    #[error("model {model}: mesh: {source}")]
    Mesh { model: String, source: MeshError },
    #[error("model {model}: solve: {source}")]
    Solve { model: String, source: SolveError },
    #[error("model {model}: Gmsh mesh {source}")]
    Gmsh { model: String, source: GmshError },
}

/// The top edge at one time.
#[derive(Debug, Clone)]
pub struct TimeResult {
    pub t_s: f64,
    pub lumen_pa: f64,
    /// Top-node positions relative to the model's lateral origin, m (reference positions).
    pub x_m: Vec<f64>,
    pub von_mises_pa: Vec<f64>,
    /// σyy at the top nodes (negative in compression), Pa.
    pub sigma_yy_pa: Vec<f64>,
    pub summary: CurveSummary,
    /// Deformed height of the lumen (top to bottom of its wall's inner edge), m; NaN
    /// without a lumen. An artery collapsing under a finger shows here.
    pub lumen_height_m: f64,
}

#[derive(Debug, Clone)]
pub struct ModelRun {
    pub name: String,
    pub dofs: usize,
    pub wall_s: f64,
    pub timings: Timings,
    pub times: Vec<TimeResult>,
}

/// One record of `pulsetrack fem --json` (field names are an interface).
#[derive(Debug, Clone, Serialize)]
pub struct Record {
    pub model: String,
    pub t_s: f64,
    pub x_m: Vec<f64>,
    pub von_mises_pa: Vec<f64>,
    pub peak_pa: f64,
    pub x_peak_m: f64,
    pub von_mises_x0_pa: f64,
    pub dofs: usize,
    pub wall_s: f64,
}

impl ModelRun {
    pub fn records(&self) -> Vec<Record> {
        self.times
            .iter()
            .map(|t| Record {
                model: self.name.clone(),
                t_s: t.t_s,
                x_m: t.x_m.clone(),
                von_mises_pa: t.von_mises_pa.clone(),
                peak_pa: t.summary.peak,
                x_peak_m: t.summary.x_peak,
                von_mises_x0_pa: t.summary.at_x0,
                dofs: self.dofs,
                wall_s: self.wall_s,
            })
            .collect()
    }
}

/// The model's mesh: its Gmsh file if it names one (which cannot be refined), else the
/// built-in mesher's at its density plus `extra_refine` levels.
pub fn build_mesh(model: &ModelFile, extra_refine: u32) -> Result<Mesh, FemError> {
    if let Some(path) = &model.mesh_file {
        let wrap = |problem: String| FemError::Gmsh {
            model: model.name.clone(),
            source: GmshError {
                file: path.display().to_string(),
                problem,
            },
        };
        if extra_refine > 0 {
            return Err(wrap(
                "a Gmsh mesh is solved as it is: refine it in Gmsh, not with --refine".into(),
            ));
        }
        let want = Expected::for_model(model).map_err(wrap)?;
        return read_mesh(path, &want).map_err(|source| FemError::Gmsh {
            model: model.name.clone(),
            source,
        });
    }
    let feature = model.feature();
    mesh_block(
        model.block.width_m,
        model.block.height_m,
        feature.as_ref(),
        &model.mesh.density(extra_refine),
    )
    .map_err(|source| FemError::Mesh {
        model: model.name.clone(),
        source,
    })
}

/// Deformed vertical extent of the lumen's boundary, m (NaN without a lumen).
pub fn lumen_height_m(mesh: &Mesh, u: &[f64]) -> f64 {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &n in mesh.lumen_edges.iter().flatten() {
        let y = mesh.nodes[n as usize][1] + u[2 * n as usize + 1];
        lo = lo.min(y);
        hi = hi.max(y);
    }
    if hi >= lo { hi - lo } else { f64::NAN }
}

fn time_result(
    model: &ModelFile,
    mesh: &Mesh,
    t_s: f64,
    stresses: &[[f64; 4]],
    u: &[f64],
) -> TimeResult {
    let x0 = model.x_origin_m();
    let x_m = mesh.top_x_m(x0);
    let von_mises_pa: Vec<f64> = stresses
        .iter()
        .map(|s| von_mises(s[0], s[1], s[2], s[3]))
        .collect();
    let sigma_yy_pa = stresses.iter().map(|s| s[1]).collect();
    let summary = summarize(&x_m, &von_mises_pa, 0.0);
    TimeResult {
        t_s,
        lumen_pa: model.pressure_at(t_s),
        x_m,
        von_mises_pa,
        sigma_yy_pa,
        summary,
        lumen_height_m: lumen_height_m(mesh, u),
    }
}

/// Run `model` with `extra_refine` more refinement levels than its file asks for.
pub fn run_model(model: &ModelFile, extra_refine: u32) -> Result<ModelRun, FemError> {
    let start = Instant::now();
    let mesh = build_mesh(model, extra_refine)?;
    let wrap = |source: SolveError| FemError::Solve {
        model: model.name.clone(),
        source,
    };
    let (times, timings) = match model.kinematics {
        Kinematics::Linear => solve_linear(model, &mesh).map_err(wrap)?,
        Kinematics::FiniteStrain { steps } => (
            finite::solve_times(model, &mesh, steps)
                .map_err(wrap)?
                .into_iter()
                .map(|s| time_result(model, &mesh, s.t_s, &s.stresses, &s.u))
                .collect(),
            Timings::default(),
        ),
    };
    Ok(ModelRun {
        name: model.name.clone(),
        dofs: mesh.dofs(),
        wall_s: start.elapsed().as_secs_f64(),
        timings,
        times,
    })
}

fn solve_linear(model: &ModelFile, mesh: &Mesh) -> Result<(Vec<TimeResult>, Timings), SolveError> {
    let lm = LinearModel::new(mesh, &model.materials(), model.analysis)?;
    let (fixed, pres) = supports(mesh, model);
    let unit = mesh.lumen_pressure_forces(1.0);
    let zeros = vec![0.0; mesh.dofs()];
    let mut out = Vec::with_capacity(model.times_s.len());
    match model.load {
        Load::Platen { .. } => {
            // Linear and the supports do not change: superpose the platen and a unit lumen
            // pressure, solved with one factorization.
            let c = lm.factor(&fixed)?;
            let mut u = c.solve_many(&[(&zeros, &pres), (&unit, &zeros)])?;
            let u_unit = u.pop().ok_or(SolveError::NonFinite)?;
            let u_platen = u.pop().ok_or(SolveError::NonFinite)?;
            let s_platen = lm.top_stresses(&u_platen);
            let s_unit = lm.top_stresses(&u_unit);
            for &t in &model.times_s {
                let p = model.pressure_at(t);
                let u: Vec<f64> = u_platen
                    .iter()
                    .zip(&u_unit)
                    .map(|(a, b)| a + p * b)
                    .collect();
                let s: Vec<[f64; 4]> = s_platen
                    .iter()
                    .zip(&s_unit)
                    .map(|(a, b)| {
                        [
                            a[0] + p * b[0],
                            a[1] + p * b[1],
                            a[2] + p * b[2],
                            a[3] + p * b[3],
                        ]
                    })
                    .collect();
                out.push(time_result(model, mesh, t, &s, &u));
            }
        }
        Load::Finger {
            tip,
            indent_m,
            centre_x_m,
        } => {
            let indenter = Indenter {
                tip,
                centre_x_m: centre_x_m.unwrap_or_else(|| model.x_origin_m()),
                indent_m,
                surface_y_m: model.block.height_m,
            };
            for &t in &model.times_s {
                let p = model.pressure_at(t);
                let force: Vec<f64> = unit.iter().map(|f| f * p).collect();
                let sol = solve_contact(&lm, &fixed, &pres, &force, &indenter)?;
                let s = lm.top_stresses(&sol.u);
                out.push(time_result(model, mesh, t, &s, &sol.u));
            }
        }
    }
    Ok((out, lm.timings))
}
