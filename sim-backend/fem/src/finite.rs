//! The finite-strain solve: Newton-Raphson on the neo-Hookean Q4 ([`super::neo_hookean`])
//! with load stepping, step cut-backs and a backtracking line search.
//!
//! The rigid finger enters as a penalty on the deformed configuration
//! ([`super::finger_penalty`]), its indentation ramped with the load. The lumen pressure is,
//! by default, a follower load on the deformed wall ([`super::follower_pressure`]; exact and
//! symmetric tangent on a closed lumen) and the wall is in frictionless self-contact
//! ([`super::self_contact`]; its tangent couples nodes across the lumen, so the pattern then
//! couples every pair of wall nodes), so that a lumen can close. Without
//! [`FiniteModel::with_lumen`] the pressure keeps its reference direction (a dead load).

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::boundary::supports;
use super::contact::Indenter;
use super::element::Q4;
use super::finger_penalty::{FingerPenalty, PENALTY_PER_MODULUS};
use super::follower_pressure;
use super::lumen_wall::LumenWall;
use super::material::{Analysis, Material};
use super::mesh::Mesh;
use super::model::{Load, ModelFile};
use super::neo_hookean::{element_cauchy, element_state};
use super::recovery::top_stresses;
use super::self_contact::{Facing, SELF_PENALTY_PER_MODULUS, SelfContact, wall_pairs};
use super::solve_error::SolveError;
use super::sparse::{Constrained, Pattern, element_dofs};

/// How the lumen is modelled in finite strain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LumenModel {
    /// The pressure acts on the deformed wall (else in its reference direction).
    pub follower: bool,
    /// The wall's frictionless self-contact.
    pub self_contact: bool,
    /// The self-contact's penalty per unit of the stiffest wall material's modulus.
    pub penalty_per_modulus: f64,
}

impl Default for LumenModel {
    fn default() -> Self {
        Self {
            follower: true,
            self_contact: true,
            penalty_per_modulus: SELF_PENALTY_PER_MODULUS,
        }
    }
}

#[derive(Debug)]
struct Lumen {
    wall: LumenWall,
    follower: bool,
    contact: Option<SelfContact>,
}

/// Work done by a model's solves so far (they run on several threads).
#[derive(Debug, Default)]
pub struct NewtonStats {
    /// Newton iterations of converged load steps.
    pub iterations: AtomicUsize,
    /// Load steps that failed and were cut.
    pub cuts: AtomicUsize,
    /// Newton steps solved without the follower's load stiffness, because the tangent with
    /// it was not positive definite.
    pub tangents_held_back: AtomicUsize,
}

/// The nonlinear problem on one mesh.
#[derive(Debug)]
pub struct FiniteModel<'m> {
    pub mesh: &'m Mesh,
    pub materials: Vec<Material>,
    pub analysis: Analysis,
    elements: Vec<Q4>,
    pattern: Pattern,
    symbolic: super::sparse::Symbolic,
    /// The lumen's follower pressure and self-contact ([`FiniteModel::with_lumen`]); without
    /// it the lumen pressure is the dead load `dead_unit` × p.
    lumen: Option<Lumen>,
    dead_unit: Vec<f64>,
    /// A force per unit thickness below which a residual is round-off: 10⁻⁶ of the stiffest
    /// modulus times the mesh's size (a stress-free rigid motion has no other force scale).
    force_floor: f64,
    pub stats: NewtonStats,
}

/// Newton settings.
const MAX_NEWTON: usize = 30;
const MAX_CUTS: u32 = 10;
const TOL_R: f64 = 1e-8;
/// Re-solves of one Newton step for nodes it would push into the finger or through the
/// opposite wall.
const MAX_CLOSING_PASSES: usize = 6;

/// One end of a load path: prescribed values on the fixed DOFs, dead forces, the finger's
/// indentation and the lumen pressure.
#[derive(Debug, Clone, Copy)]
pub struct Loads<'a> {
    pub target: &'a [f64],
    pub fext: &'a [f64],
    pub indent_m: f64,
    pub lumen_pa: f64,
}

/// The loads at one load level.
struct Level<'a> {
    target: Vec<f64>,
    fext: Vec<f64>,
    finger: Option<(&'a FingerPenalty, f64)>,
    lumen_pa: f64,
}

/// Forces and tangent at one configuration.
struct State {
    /// Internal forces, with the penalties'.
    fint: Vec<f64>,
    /// Applied forces: dead loads and the lumen pressure.
    load: Vec<f64>,
    /// Tangent values on the pattern (with the follower's load stiffness).
    values: Vec<f64>,
    /// The follower's share of `values`, to take out if the tangent with it is indefinite.
    follower_values: Option<Vec<f64>>,
}

impl<'m> FiniteModel<'m> {
    pub fn new(
        mesh: &'m Mesh,
        materials: &[Material],
        analysis: Analysis,
    ) -> Result<Self, SolveError> {
        let pattern = Pattern::new(mesh)?;
        let elements = (0..mesh.elements.len())
            .map(|e| Q4::new(&mesh.element_coords(e)).map_err(|_| SolveError::BadElement(e)))
            .collect::<Result<Vec<_>, _>>()?;
        let symbolic = pattern.symbolic()?;
        let size = elements.iter().map(|q| q.area).sum::<f64>().sqrt();
        let modulus = materials.iter().fold(0.0f64, |m, mat| m.max(mat.e_pa));
        Ok(Self {
            mesh,
            materials: materials.to_vec(),
            analysis,
            elements,
            pattern,
            symbolic,
            lumen: None,
            dead_unit: mesh.lumen_pressure_forces(1.0),
            force_floor: 1e-6 * modulus * size,
            stats: NewtonStats::default(),
        })
    }

    /// Model the lumen (if the mesh has one) as `how` says. The self-contact's penalty is
    /// scaled by the stiffest material on the wall.
    pub fn with_lumen(mut self, how: LumenModel) -> Result<Self, SolveError> {
        if self.mesh.lumen_edges.is_empty() || !(how.follower || how.self_contact) {
            return Ok(self);
        }
        let wall = LumenWall::new(self.mesh)?;
        let contact = if how.self_contact {
            let modulus = wall.edges.iter().fold(0.0f64, |m, e| {
                let region = self.mesh.region[e.element] as usize;
                m.max(self.materials.get(region).map_or(0.0, |mat| mat.e_pa))
            });
            // The contact couples wall nodes across the lumen: a pattern (and its symbolic
            // factorization) with every pair of them.
            self.pattern = Pattern::with_pairs(self.mesh, &wall_pairs(&wall))?;
            self.symbolic = self.pattern.symbolic()?;
            Some(SelfContact::for_wall(
                &wall,
                self.mesh,
                how.penalty_per_modulus * modulus,
            ))
        } else {
            None
        };
        self.lumen = Some(Lumen {
            wall,
            follower: how.follower,
            contact,
        });
        Ok(self)
    }

    fn gather(&self, e: usize, u: &[f64]) -> [f64; 8] {
        let d = element_dofs(&self.mesh.elements[e]);
        let mut ue = [0.0; 8];
        for (i, &k) in d.iter().enumerate() {
            ue[i] = u[k];
        }
        ue
    }

    /// Forces and tangent at `u` under the loads of `level`; `None` if any element inverts.
    fn state(&self, u: &[f64], level: &Level<'_>) -> Option<State> {
        let per: Option<Vec<([f64; 8], [f64; 36])>> = (0..self.mesh.elements.len())
            .into_par_iter()
            .map(|e| {
                let m = &self.materials[self.mesh.region[e] as usize];
                element_state(&self.elements[e], m, self.analysis, &self.gather(e, u))
            })
            .collect();
        let per = per?;
        let mut fint = vec![0.0; self.mesh.dofs()];
        let mut ke = Vec::with_capacity(per.len());
        for (e, (f, k)) in per.into_iter().enumerate() {
            for (i, &d) in element_dofs(&self.mesh.elements[e]).iter().enumerate() {
                fint[d] += f[i];
            }
            ke.push(k);
        }
        let mut load = level.fext.clone();
        let mut follower_values = None;
        let p = level.lumen_pa;
        match &self.lumen {
            Some(l) if l.follower => {
                follower_pressure::add_forces(&l.wall, self.mesh, u, p, &mut load);
                if p != 0.0 {
                    let mut kp = vec![[0.0; 36]; ke.len()];
                    follower_pressure::add_tangent(&l.wall, p, &mut kp);
                    follower_pressure::add_tangent(&l.wall, p, &mut ke);
                    follower_values = Some(self.pattern.assemble(&kp));
                }
            }
            _ => {
                for (f, d) in load.iter_mut().zip(&self.dead_unit) {
                    *f += p * d;
                }
            }
        }
        let mut values = self.pattern.assemble(&ke);
        if let Some((f, indent_m)) = level.finger {
            f.add(
                self.mesh,
                &self.pattern,
                u,
                indent_m,
                &mut fint,
                &mut values,
            );
        }
        if let Some(Lumen {
            wall,
            contact: Some(c),
            ..
        }) = &self.lumen
        {
            c.add(wall, self.mesh, &self.pattern, u, &mut fint, &mut values);
        }
        Some(State {
            fint,
            load,
            values,
            follower_values,
        })
    }

    fn residual_norm(fixed: &[bool], load: &[f64], fint: &[f64]) -> f64 {
        load.iter()
            .zip(fint)
            .zip(fixed)
            .filter(|(_, f)| !**f)
            .map(|((a, b), _)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    }

    /// Solve the Newton system with tangent `values`; if it is not positive definite and
    /// holds the follower's load stiffness, again without it.
    fn solve_tangent(
        &self,
        values: &[f64],
        follower_values: Option<&[f64]>,
        fixed: &[bool],
        rhs: &[f64],
        du_c: &[f64],
    ) -> Result<Vec<f64>, SolveError> {
        match (
            Constrained::new(&self.pattern, &self.symbolic, values, fixed),
            follower_values,
        ) {
            (Ok(c), _) => c.solve(rhs, du_c),
            (Err(SolveError::NotPositiveDefinite), Some(kp)) => {
                self.stats
                    .tangents_held_back
                    .fetch_add(1, Ordering::Relaxed);
                let held: Vec<f64> = values.iter().zip(kp).map(|(a, b)| a - b).collect();
                Constrained::new(&self.pattern, &self.symbolic, &held, fixed)?.solve(rhs, du_c)
            }
            (Err(e), _) => Err(e),
        }
    }

    /// One Newton direction. Nodes the step would push into the finger or through the
    /// opposite wall are given the penalty branch they are entering and the step is
    /// recomputed (a few times at most; the sets only grow).
    fn newton_step(
        &self,
        x: &[f64],
        st: &State,
        fixed: &[bool],
        du_c: &[f64],
        level: &Level<'_>,
    ) -> Result<Vec<f64>, SolveError> {
        let solve = |fi: &[f64], k: &[f64]| -> Result<Vec<f64>, SolveError> {
            let rhs: Vec<f64> = st.load.iter().zip(fi).map(|(a, b)| a - b).collect();
            self.solve_tangent(k, st.follower_values.as_deref(), fixed, &rhs, du_c)
        };
        let mut du = solve(&st.fint, &st.values)?;
        let contact = match &self.lumen {
            Some(Lumen {
                wall,
                contact: Some(c),
                ..
            }) => Some((wall, c)),
            _ => None,
        };
        if level.finger.is_none() && contact.is_none() {
            return Ok(du);
        }
        let mut extra = vec![false; self.mesh.top.len()];
        let mut closing_walls: Vec<Facing> = Vec::new();
        for _ in 0..MAX_CLOSING_PASSES {
            let mut grew = false;
            if let Some((f, indent_m)) = level.finger {
                let closing = f.closing(self.mesh, x, &du, indent_m);
                for (e, c) in extra.iter_mut().zip(&closing) {
                    grew |= *c && !*e;
                    *e |= *c;
                }
            }
            if let Some((wall, c)) = contact {
                for f in c.closing(wall, self.mesh, x, &du) {
                    if !closing_walls
                        .iter()
                        .any(|g| g.slave == f.slave && g.edge == f.edge)
                    {
                        closing_walls.push(f);
                        grew = true;
                    }
                }
            }
            if !grew {
                break;
            }
            let mut fi = st.fint.clone();
            let mut k = st.values.clone();
            if let Some((f, indent_m)) = level.finger {
                f.add_closing(
                    self.mesh,
                    &self.pattern,
                    x,
                    indent_m,
                    &extra,
                    &mut fi,
                    &mut k,
                );
            }
            if let Some((wall, c)) = contact {
                c.add_branch(wall, &self.pattern, closing_walls.iter(), &mut fi, &mut k);
            }
            du = solve(&fi, &k)?;
        }
        Ok(du)
    }

    /// Newton at one load level. Updates `u` in place only on success.
    fn equilibrate(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        level: &Level<'_>,
    ) -> Result<usize, SolveError> {
        let target = &level.target;
        let mut x = u.clone();
        let mut st = self.state(&x, level).ok_or(SolveError::NonFinite)?;
        // Force scale: applied loads and support reactions at the current iterate.
        let scale = |st: &State| -> f64 {
            let ext: f64 = st.load.iter().map(|v| v * v).sum();
            let reac: f64 = st
                .fint
                .iter()
                .zip(fixed)
                .filter(|(_, f)| **f)
                .map(|(v, _)| v * v)
                .sum();
            ext.max(reac).sqrt().max(self.force_floor).max(1e-30)
        };
        for it in 0..MAX_NEWTON {
            let du_c: Vec<f64> = target.iter().zip(&x).map(|(t, xi)| t - xi).collect();
            let du = self.newton_step(&x, &st, fixed, &du_c, level)?;
            let r0 = Self::residual_norm(fixed, &st.load, &st.fint);
            let constrained_jump = du_c.iter().zip(fixed).any(|(d, f)| *f && d.abs() > 0.0);
            // Backtracking: accept the first step that keeps every element valid and, once
            // the supports are in place, reduces the residual.
            let mut alpha = 1.0;
            let mut accepted = None;
            for _ in 0..8 {
                let trial: Vec<f64> = x.iter().zip(&du).map(|(a, d)| a + alpha * d).collect();
                if let Some(s) = self.state(&trial, level) {
                    let r1 = Self::residual_norm(fixed, &s.load, &s.fint);
                    if constrained_jump || r1 < (1.0 - 1e-4 * alpha) * r0 || r1 <= TOL_R * scale(&s)
                    {
                        accepted = Some((trial, s, r1));
                        break;
                    }
                }
                alpha *= 0.5;
            }
            let Some((trial, s, r1)) = accepted else {
                return Err(SolveError::NoConvergence(format!(
                    "line search failed at Newton iteration {it}"
                )));
            };
            let du_norm = du.iter().map(|v| v * v).sum::<f64>().sqrt() * alpha;
            let u_norm = trial.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-30);
            x = trial;
            st = s;
            let supports_done = target
                .iter()
                .zip(&x)
                .zip(fixed)
                .all(|((t, xi), f)| !*f || (t - xi).abs() <= 1e-12 * u_norm.max(1e-12));
            if supports_done && r1 <= TOL_R * scale(&st) && du_norm <= 1e-6 * u_norm {
                *u = x;
                return Ok(it + 1);
            }
        }
        Err(SolveError::NoConvergence(format!(
            "Newton did not converge in {MAX_NEWTON} iterations"
        )))
    }

    /// Move from load level a to b (prescribed values and forces interpolated linearly) in
    /// `steps` increments, halving a failed increment up to `MAX_CUTS` times.
    pub fn advance(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        (target_a, fext_a): (&[f64], &[f64]),
        (target_b, fext_b): (&[f64], &[f64]),
        steps: u32,
    ) -> Result<(), SolveError> {
        self.advance_with_finger(
            u,
            fixed,
            (target_a, fext_a),
            (target_b, fext_b),
            None,
            steps,
        )
    }

    /// As [`FiniteModel::advance`], with a finger whose indentation moves from `indent.1`
    /// to `indent.2` along with the other loads.
    pub fn advance_with_finger(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        (target_a, fext_a): (&[f64], &[f64]),
        (target_b, fext_b): (&[f64], &[f64]),
        finger: Option<(&FingerPenalty, f64, f64)>,
        steps: u32,
    ) -> Result<(), SolveError> {
        let (indent_a, indent_b) = finger.map_or((0.0, 0.0), |(_, a, b)| (a, b));
        self.advance_loads(
            u,
            fixed,
            Loads {
                target: target_a,
                fext: fext_a,
                indent_m: indent_a,
                lumen_pa: 0.0,
            },
            Loads {
                target: target_b,
                fext: fext_b,
                indent_m: indent_b,
                lumen_pa: 0.0,
            },
            finger.map(|(f, _, _)| f),
            steps,
        )
    }

    /// Move from loads `a` to `b` (every load interpolated linearly) in `steps`
    /// increments, halving a failed increment up to `MAX_CUTS` times.
    pub fn advance_loads(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        a: Loads<'_>,
        b: Loads<'_>,
        finger: Option<&FingerPenalty>,
        steps: u32,
    ) -> Result<(), SolveError> {
        let lerp = |a: &[f64], b: &[f64], s: f64| -> Vec<f64> {
            a.iter().zip(b).map(|(x, y)| x + s * (y - x)).collect()
        };
        let mut s = 0.0f64;
        let mut ds = 1.0 / f64::from(steps.max(1));
        let mut cuts = 0;
        while s < 1.0 - 1e-12 {
            let next = (s + ds).min(1.0);
            let level = Level {
                target: lerp(a.target, b.target, next),
                fext: lerp(a.fext, b.fext, next),
                finger: finger.map(|f| (f, a.indent_m + next * (b.indent_m - a.indent_m))),
                lumen_pa: a.lumen_pa + next * (b.lumen_pa - a.lumen_pa),
            };
            match self.equilibrate(u, fixed, &level) {
                Ok(iterations) => {
                    self.stats
                        .iterations
                        .fetch_add(iterations, Ordering::Relaxed);
                    s = next;
                    if cuts > 0 {
                        ds *= 1.5;
                    }
                }
                Err(e) => {
                    cuts += 1;
                    self.stats.cuts.fetch_add(1, Ordering::Relaxed);
                    if cuts > MAX_CUTS {
                        return Err(SolveError::NoConvergence(format!(
                            "load step cut {MAX_CUTS} times at load fraction {s:.4}: {e}"
                        )));
                    }
                    ds *= 0.5;
                }
            }
        }
        Ok(())
    }

    /// The elements' internal forces at `u` (no penalties or loads): on the fixed DOFs at
    /// equilibrium, the support reactions. `None` if an element inverts.
    pub fn internal_forces(&self, u: &[f64]) -> Option<Vec<f64>> {
        let mut fint = vec![0.0; self.mesh.dofs()];
        for e in 0..self.mesh.elements.len() {
            let m = &self.materials[self.mesh.region[e] as usize];
            let (f, _) = element_state(&self.elements[e], m, self.analysis, &self.gather(e, u))?;
            for (i, &d) in element_dofs(&self.mesh.elements[e]).iter().enumerate() {
                fint[d] += f[i];
            }
        }
        Some(fint)
    }

    /// Recovered Cauchy stresses at the top nodes.
    pub fn top_cauchy(&self, u: &[f64]) -> Vec<[f64; 4]> {
        top_stresses(self.mesh, |e| {
            let m = &self.materials[self.mesh.region[e] as usize];
            element_cauchy(&self.elements[e], m, self.analysis, &self.gather(e, u))
        })
    }

    /// The lumen's shape and contact at `u` (`None` without [`FiniteModel::with_lumen`]):
    /// opening along the vertical line at `x_m`, area, and the self-contact.
    pub fn lumen_state(&self, u: &[f64], x_m: f64) -> Option<LumenState> {
        let l = self.lumen.as_ref()?;
        let (contact_nodes, penetration_m, contact_force_n_per_m) = match &l.contact {
            Some(c) => {
                let (f, deepest) = c.forces(&l.wall, self.mesh, u);
                let mut active: Vec<usize> = c
                    .facings(&l.wall, self.mesh, u)
                    .iter()
                    .filter(|f| f.g < 0.0)
                    .map(|f| f.slave)
                    .collect();
                active.dedup();
                let active = active.len();
                // Half the sum of |force| over the nodes: each pair pushes both ways.
                let total = 0.5
                    * f.chunks_exact(2)
                        .map(|v| (v[0] * v[0] + v[1] * v[1]).sqrt())
                        .sum::<f64>();
                (active, deepest, total)
            }
            None => (0, 0.0, 0.0),
        };
        Some(LumenState {
            opening_m: l.wall.opening_at(self.mesh, u, x_m),
            area_m2: l.wall.area(self.mesh, u),
            contact_nodes,
            penetration_m,
            contact_force_n_per_m,
        })
    }
}

/// The lumen at one output time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LumenState {
    /// Opening along the vertical through the feature's centre (negative if the walls
    /// overlap there), m.
    pub opening_m: Option<f64>,
    /// Enclosed area, m².
    pub area_m2: f64,
    /// Wall nodes in self-contact.
    pub contact_nodes: usize,
    /// Deepest penetration of a wall node behind the opposite wall, m.
    pub penetration_m: f64,
    /// Total force the walls press on each other with, N per m of thickness.
    pub contact_force_n_per_m: f64,
}

/// One output time of a finite-strain solve.
#[derive(Debug, Clone)]
pub struct TopState {
    pub t_s: f64,
    /// Recovered top Cauchy stresses (σxx, σyy, σxy, σzz) per top node.
    pub stresses: Vec<[f64; 4]>,
    pub u: Vec<f64>,
    /// The finger's deepest penetration at this time (0 without a finger), m.
    pub penetration_m: f64,
    /// The lumen, when it is modelled with [`FiniteModel::with_lumen`].
    pub lumen: Option<LumenState>,
}

/// The finger of a model's load, as a penalty scaled by the tissue's modulus.
pub fn finger_of(model: &ModelFile) -> Option<(FingerPenalty, f64)> {
    match model.load {
        Load::Finger {
            tip,
            indent_m,
            centre_x_m,
        } => {
            let ind = Indenter {
                tip,
                centre_x_m: centre_x_m.unwrap_or_else(|| model.x_origin_m()),
                indent_m,
                surface_y_m: model.block.height_m,
            };
            Some((
                FingerPenalty {
                    tip: ind.tip,
                    centre_x_m: ind.centre_x_m,
                    surface_y_m: ind.surface_y_m,
                    penalty_pa: PENALTY_PER_MODULUS * model.tissue.e_pa,
                },
                indent_m,
            ))
        }
        Load::Platen { .. } => None,
    }
}

/// Solve a model in finite strain with the lumen's follower pressure and self-contact
/// ([`solve_times_with`] and [`LumenModel::default`]).
pub fn solve_times(
    model: &ModelFile,
    mesh: &Mesh,
    steps: u32,
) -> Result<Vec<TopState>, SolveError> {
    solve_times_with(
        model,
        mesh,
        steps,
        LumenModel::default(),
        LoadPath::Together,
    )
    .map(|(states, _)| states)
}

/// The order in which a finite-strain solve applies its loads before the first output time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LoadPath {
    /// The platen or finger and the first time's lumen pressure ramped together: the artery
    /// is pressurized all the way in.
    #[default]
    Together,
    /// The platen or finger first with no lumen pressure, then the pressure: paper 002's
    /// "for the first 1 second, the finger reached on maximum indentation and, for the next
    /// 1 second, the pressure data was applied".
    IndentFirst,
}

/// Solve a model in finite strain: bring the platen or the finger and the first time's lumen
/// pressure from zero in `steps` increments (in the order `path` says), then follow the
/// pressure through the output times. Also returns the Newton iterations, cuts and held-back
/// tangents it took.
pub fn solve_times_with(
    model: &ModelFile,
    mesh: &Mesh,
    steps: u32,
    lumen: LumenModel,
    path: LoadPath,
) -> Result<(Vec<TopState>, [usize; 3]), SolveError> {
    let fm = FiniteModel::new(mesh, &model.materials(), model.analysis)?.with_lumen(lumen)?;
    let (fixed, target) = supports(mesh, model);
    let finger = finger_of(model);
    let indent = finger.as_ref().map_or(0.0, |(_, d)| *d);
    let zeros = vec![0.0; mesh.dofs()];
    let x_centre = mesh.feature_centre.map_or(model.x_origin_m(), |c| c[0]);
    let mut u = zeros.clone();
    let mut out = Vec::new();
    let loads = |target, indent_m, lumen_pa| Loads {
        target,
        fext: &zeros,
        indent_m,
        lumen_pa,
    };
    let finger_ref = finger.as_ref().map(|(f, _)| f);
    let mut prev: Option<f64> = None;
    for &t in &model.times_s {
        let p = model.pressure_at(t);
        match (prev, path) {
            (None, LoadPath::Together) => fm.advance_loads(
                &mut u,
                &fixed,
                loads(&zeros, 0.0, 0.0),
                loads(&target, indent, p),
                finger_ref,
                steps,
            )?,
            (None, LoadPath::IndentFirst) => {
                fm.advance_loads(
                    &mut u,
                    &fixed,
                    loads(&zeros, 0.0, 0.0),
                    loads(&target, indent, 0.0),
                    finger_ref,
                    steps,
                )?;
                fm.advance_loads(
                    &mut u,
                    &fixed,
                    loads(&target, indent, 0.0),
                    loads(&target, indent, p),
                    finger_ref,
                    steps,
                )?;
            }
            (Some(pa), _) => fm.advance_loads(
                &mut u,
                &fixed,
                loads(&target, indent, pa),
                loads(&target, indent, p),
                finger_ref,
                2,
            )?,
        }
        let penetration_m = finger
            .as_ref()
            .map_or(0.0, |(f, d)| f.forces(mesh, &u, *d).1);
        out.push(TopState {
            t_s: t,
            stresses: fm.top_cauchy(&u),
            lumen: fm.lumen_state(&u, x_centre),
            u: u.clone(),
            penetration_m,
        });
        prev = Some(p);
    }
    let s = &fm.stats;
    let counts = [
        s.iterations.load(Ordering::Relaxed),
        s.cuts.load(Ordering::Relaxed),
        s.tangents_held_back.load(Ordering::Relaxed),
    ];
    Ok((out, counts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neo_hookean::neo_hookean;

    #[test]
    fn uniaxial_plane_stress_compression_matches_the_closed_form() {
        // A block squeezed by 25% between frictionless platens, sides free: the exact
        // neo-Hookean plane-stress state is homogeneous. Compare the Newton solution with a
        // direct scalar solve of the same constitutive law.
        use crate::mesher::{Density, mesh_block};
        let d = Density {
            near_size_m: 0.005,
            far_size_m: 0.005,
            min_layer_elements: 1,
            growth: 1.2,
        };
        let mesh = mesh_block(0.02, 0.01, None, &d).unwrap();
        let mat = Material::new(15e3, 0.45);
        let fm = FiniteModel::new(&mesh, &[mat], Analysis::PlaneStress).unwrap();
        let mut fixed = vec![false; mesh.dofs()];
        let mut target = vec![0.0; mesh.dofs()];
        for &n in &mesh.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * mesh.bottom[0] as usize] = true;
        for &n in &mesh.top {
            fixed[2 * n as usize + 1] = true;
            target[2 * n as usize + 1] = -0.0025;
        }
        let zeros = vec![0.0; mesh.dofs()];
        let mut u = zeros.clone();
        fm.advance(&mut u, &fixed, (&zeros, &zeros), (&target, &zeros), 4)
            .unwrap();
        let s = fm.top_cauchy(&u);
        // Closed form: F = diag(a, 0.75); find a with S11 = 0 (plane stress, free sides).
        let mut lo = 0.9;
        let mut hi = 1.6;
        for _ in 0..200 {
            let a = 0.5 * (lo + hi);
            let st = neo_hookean(&mat, Analysis::PlaneStress, &[[a, 0.0], [0.0, 0.75]]).unwrap();
            if st.s[0] > 0.0 {
                hi = a;
            } else {
                lo = a;
            }
        }
        let a = 0.5 * (lo + hi);
        let st = neo_hookean(&mat, Analysis::PlaneStress, &[[a, 0.0], [0.0, 0.75]]).unwrap();
        let sigma_yy = 0.75 * st.s[1] * 0.75 / st.j;
        for v in &s {
            assert!(
                (v[1] - sigma_yy).abs() < 1e-6 * sigma_yy.abs(),
                "{} vs {sigma_yy}",
                v[1]
            );
            assert!(v[0].abs() < 1e-6 * sigma_yy.abs());
        }
        // It is stiffer than the linear answer E·ε in compression? Not necessarily; it must
        // differ from it, which is the point of the option.
        assert!((sigma_yy.abs() - 15e3 * 0.25).abs() > 0.01 * 15e3 * 0.25);
    }

    /// Seed 001's healthy artery in plane strain at ν = 0.4999 under a hundredth of its load
    /// (strains of order 10⁻³): the finite-strain peak must be the linear B-bar one, on each
    /// mesh. Full 2x2 integration of the λ term locked here: peaks that moved with the mesh.
    #[test]
    fn near_incompressible_plane_strain_matches_the_linear_b_bar_at_small_load() {
        use crate::model::{Kinematics, Load, LumenPressure};
        use crate::run::run_model;
        let mut m = crate::study::shipped("seed-001-healthy-artery.ron").unwrap();
        m.analysis = Analysis::PlaneStrain;
        m.tissue.nu = 0.4999;
        if let Some(f) = m.feature.as_mut() {
            for l in &mut f.layers {
                l.material.nu = 0.4999;
            }
        }
        m.load = Load::Platen {
            indent_m: 0.0075 * 0.01,
        };
        m.lumen = m.lumen.take().map(|l| match l {
            LumenPressure::Pulse {
                diastolic_pa,
                systolic_pa,
                systole_s,
                period_s,
            } => LumenPressure::Pulse {
                diastolic_pa: diastolic_pa * 0.01,
                systolic_pa: systolic_pa * 0.01,
                systole_s,
                period_s,
            },
            other => other,
        });
        m.times_s = vec![0.425];
        let mut peaks = Vec::new();
        for refine in [0, 1] {
            m.kinematics = Kinematics::Linear;
            let lin = run_model(&m, refine).unwrap().times[0].summary.peak;
            m.kinematics = Kinematics::FiniteStrain { steps: 2 };
            let fin = run_model(&m, refine).unwrap().times[0].summary.peak;
            let rel = (fin - lin).abs() / lin;
            assert!(
                rel < 0.02,
                "refine {refine}: finite {fin} linear {lin} ({rel:.4})"
            );
            peaks.push(fin);
        }
        let drift = (peaks[1] - peaks[0]).abs() / peaks[1];
        assert!(
            drift < 0.03,
            "finite-strain peaks {peaks:?} move {drift:.4} with the mesh"
        );
    }
}
