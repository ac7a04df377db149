//! The seed001 bench's `--export DIR`: the finest level's constrained system and the mesh it
//! came from, as plain text for the Python comparison (scripts/fem_compare.sh,
//! scripts/fem_superlu.py). SI units; DOF 2n is node n's x, 2n + 1 its y.
//!
//! - `k.mtx`: K on the free DOFs (Matrix Market, symmetric, lower triangle)
//! - `f.txt`: the platen case's right-hand side on the free DOFs (the prescribed
//!   displacements moved to the right)
//! - `f_lumen.txt`: the unit lumen pressure case's right-hand side on the free DOFs
//! - `nodes.txt`: x y (m); `elements.txt`: four nodes (counter-clockwise) and the region
//! - `materials.txt`: E (Pa) and ν of each region, in region order
//! - `dofs.txt`: for every DOF, fixed (0/1), prescribed value (m), unit lumen force (N/m)
//! - `top.txt`: the top nodes, sorted by x
//! - `case.txt`: the analysis, the lumen pressure at t = 0.425 s and the peak top von Mises

use std::fs::File;
use std::io::{BufWriter, Write};

use pulsetrack_fem::linear::LinearModel;

/// What one export holds besides the assembled model.
#[derive(Debug)]
pub struct Case<'a> {
    pub lm: &'a LinearModel<'a>,
    pub fixed: &'a [bool],
    pub pres: &'a [f64],
    pub lumen_unit: &'a [f64],
    pub p_sys: f64,
    pub peak_pa: f64,
}

fn create(dir: &str, name: &str) -> BufWriter<File> {
    let path = format!("{dir}/{name}");
    BufWriter::new(File::create(&path).unwrap_or_else(|e| panic!("{path}: {e}")))
}

fn lines<T>(dir: &str, name: &str, items: impl IntoIterator<Item = T>, fmt: impl Fn(T) -> String) {
    let mut f = create(dir, name);
    for it in items {
        writeln!(f, "{}", fmt(it)).expect("write");
    }
    f.flush().expect("write");
}

pub fn write(dir: &str, c: &Case<'_>) {
    std::fs::create_dir_all(dir).expect("export dir");
    let (lm, fixed, pres) = (c.lm, c.fixed, c.pres);
    let p = &lm.pattern;
    let mut index = vec![usize::MAX; p.n];
    let mut n_free = 0;
    for i in 0..p.n {
        if !fixed[i] {
            index[i] = n_free;
            n_free += 1;
        }
    }
    let mut rhs = vec![0.0; n_free];
    let mut entries = Vec::new();
    for col in 0..p.n {
        for k in p.col_ptr[col]..p.col_ptr[col + 1] {
            let row = p.row_idx[k];
            let v = lm.values[k];
            match (fixed[row], fixed[col]) {
                (false, false) => entries.push((index[row], index[col], v)),
                (false, true) => rhs[index[row]] -= v * pres[col],
                (true, false) => rhs[index[col]] -= v * pres[row],
                _ => {}
            }
        }
    }
    let mut f = create(dir, "k.mtx");
    writeln!(f, "%%MatrixMarket matrix coordinate real symmetric").expect("write");
    writeln!(f, "{n_free} {n_free} {}", entries.len()).expect("write");
    for (r, col, v) in entries {
        writeln!(f, "{} {} {:.17e}", r + 1, col + 1, v).expect("write");
    }
    f.flush().expect("write");
    lines(dir, "f.txt", rhs, |v| format!("{v:.17e}"));
    let free = (0..p.n).filter(|&i| !fixed[i]);
    lines(dir, "f_lumen.txt", free, |i| {
        format!("{:.17e}", c.lumen_unit[i])
    });

    let mesh = lm.mesh;
    lines(dir, "nodes.txt", &mesh.nodes, |x| {
        format!("{:.17e} {:.17e}", x[0], x[1])
    });
    let elements = mesh.elements.iter().zip(&mesh.region);
    lines(dir, "elements.txt", elements, |(e, r)| {
        format!("{} {} {} {} {r}", e[0], e[1], e[2], e[3])
    });
    lines(dir, "materials.txt", &lm.materials, |m| {
        format!("{:.17e} {:.17e}", m.e_pa, m.nu)
    });
    lines(dir, "dofs.txt", 0..p.n, |i| {
        format!(
            "{} {:.17e} {:.17e}",
            u8::from(fixed[i]),
            pres[i],
            c.lumen_unit[i]
        )
    });
    lines(dir, "top.txt", &mesh.top, |n| n.to_string());
    let mut g = create(dir, "case.txt");
    writeln!(g, "analysis {:?}", lm.analysis).expect("write");
    writeln!(g, "p_sys_pa {:.17e}", c.p_sys).expect("write");
    writeln!(g, "peak_top_von_mises_pa {:.17e}", c.peak_pa).expect("write");
    g.flush().expect("write");
    eprintln!("exported {n_free} free DOFs and the mesh to {dir}");
}
