//! Benchmark (not a test): the seed-001 healthy artery, linear, at several refinement levels.
//! Times each phase (mesh, pattern, element matrices + assembly, symbolic and numeric
//! Cholesky, the two load-case solves, recovery) and prints medians over repetitions, with the
//! peak top von Mises at t = 0.425 s for the convergence table, the nonzeros of L and the
//! factorization's multiply-adds (GFlop).
//!
//! cargo bench -p pulsetrack-fem --bench seed001 -- [--refine 0,1,2,3] [--reps 5]
//!     [--size-scale S] [--ordering split|node|dof|nd] (default split) [--export DIR]
//!
//! `--export DIR` writes the finest level's constrained system and its mesh for the Python
//! comparison (scripts/fem_compare.sh; the files are listed in `export.rs`).

use std::time::Instant;

use pulsetrack_fem::boundary::supports;
use pulsetrack_fem::linear::LinearModel;
use pulsetrack_fem::recovery::von_mises_of;
use pulsetrack_fem::run::build_mesh;
use pulsetrack_fem::sparse::{Ordering, factor_flops};
use pulsetrack_fem::study::shipped;

#[path = "export/mod.rs"]
mod export;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let get = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let levels: Vec<u32> = get("--refine")
        .unwrap_or_else(|| "0,1,2,3".into())
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let reps: usize = get("--reps").and_then(|s| s.parse().ok()).unwrap_or(5);
    let export = get("--export");
    let ordering = match get("--ordering").as_deref() {
        None => Ordering::default(),
        Some("node") => Ordering::NodeAmd,
        Some("dof") => Ordering::DofAmd,
        Some("nd") => Ordering::NodeNd,
        Some("split") => Ordering::SplitNd,
        Some(other) => {
            eprintln!("--ordering {other}: expected node, dof, nd or split");
            std::process::exit(2);
        }
    };
    let mut model = shipped("seed-001-healthy-artery.ron").expect("shipped model");
    // Scale the element sizes (0.84 at refine 3 gives about 340k DOFs).
    if let Some(s) = get("--size-scale").and_then(|s| s.parse::<f64>().ok()) {
        model.mesh.near_size_m *= s;
        model.mesh.far_size_m *= s;
    }
    let p_sys = model.pressure_at(0.425);
    println!(
        "{:>6} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9} {:>8} {:>8} {:>9} {:>10} {:>8} {:>7}",
        "refine",
        "dofs",
        "mesh s",
        "pattern",
        "assembly",
        "symbolic",
        "numeric",
        "solve",
        "recover",
        "total s",
        "peak kPa",
        "L nnz M",
        "GFlop"
    );
    for &level in &levels {
        let mut rows: Vec<[f64; 8]> = Vec::new();
        let mut peak = f64::NAN;
        let mut dofs = 0;
        let mut l_nnz = 0;
        let mut flops = 0.0;
        for _ in 0..reps {
            let t0 = Instant::now();
            let mesh = build_mesh(&model, level).expect("mesh");
            let t_mesh = t0.elapsed().as_secs_f64();
            let lm =
                LinearModel::with_ordering(&mesh, &model.materials(), model.analysis, ordering)
                    .expect("assemble");
            l_nnz = lm.symbolic.len_val();
            flops = factor_flops(&lm.symbolic);
            let (fixed, pres) = supports(&mesh, &model);
            let t1 = Instant::now();
            let c = lm.factor(&fixed).expect("factor");
            let t_num = t1.elapsed().as_secs_f64();
            let t2 = Instant::now();
            let zeros = vec![0.0; mesh.dofs()];
            let unit = mesh.lumen_pressure_forces(1.0);
            let mut both = c
                .solve_many(&[(&zeros, &pres), (&unit, &zeros)])
                .expect("solve");
            let u_unit = both.pop().expect("two cases");
            let u_platen = both.pop().expect("two cases");
            let t_solve = t2.elapsed().as_secs_f64();
            let t3 = Instant::now();
            let u: Vec<f64> = u_platen
                .iter()
                .zip(&u_unit)
                .map(|(a, b)| a + p_sys * b)
                .collect();
            let vm = von_mises_of(&lm.top_stresses(&u));
            let t_rec = t3.elapsed().as_secs_f64();
            peak = vm.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            dofs = mesh.dofs();
            let t = lm.timings;
            let total = t0.elapsed().as_secs_f64();
            rows.push([
                t_mesh,
                t.pattern_s,
                t.assembly_s,
                t.symbolic_s,
                t_num,
                t_solve,
                t_rec,
                total,
            ]);
            if let Some(dir) = &export
                && Some(&level) == levels.last()
                && rows.len() == 1
            {
                export::write(
                    dir,
                    &export::Case {
                        lm: &lm,
                        fixed: &fixed,
                        pres: &pres,
                        lumen_unit: &unit,
                        p_sys,
                        peak_pa: peak,
                    },
                );
            }
        }
        let col = |i: usize| median(rows.iter().map(|r| r[i]).collect());
        println!(
            "{:>6} {:>9} {:>8.3} {:>8.3} {:>9.3} {:>9.3} {:>9.3} {:>8.3} {:>8.3} {:>9.3} {:>10.4} {:>8.2} {:>7.2}",
            level,
            dofs,
            col(0),
            col(1),
            col(2),
            col(3),
            col(4),
            col(5),
            col(6),
            col(7),
            peak * 1e-3,
            l_nnz as f64 * 1e-6,
            flops * 1e-9
        );
    }
}
