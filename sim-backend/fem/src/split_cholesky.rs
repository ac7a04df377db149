//! A sparse Cholesky split at the nested dissection's top separator, so that the two cores
//! each eliminate one half of the mesh.
//!
//! With the DOFs ordered A, B, S (S the top separator: no entry couples A and B), K's factor is
//! `[[L_AA, 0, 0], [0, L_BB, 0], [L_SA, L_SB, L_S]]`. Each half h is factored on its own as
//! `M_h = K[h ∪ S, h ∪ S]` (a principal submatrix, so positive definite), S ordered last; the
//! last block of its factor satisfies `L_SS^h L_SS^hᵀ = K_SS − K_Sh K_hh⁻¹ K_hS`, so the
//! separator's Schur complement is `L_SS^A L_SS^Aᵀ + L_SS^B L_SS^Bᵀ − K_SS`, factored dense. A
//! solve runs each half's forward substitution up to S, the dense solve on S, then each half's
//! back substitution: the same arithmetic as one factorization of K in the A, B, S order, with
//! the halves' work (nearly all of it) on two threads.

use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::solvers::{Llt, SolveCore};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par, Side};

use super::llt::{cholesky_flops, numeric_llt};
use super::solve_error::SolveError;

const PART_A: u8 = 0;
const PART_B: u8 = 1;
const PART_S: u8 = 2;

/// The structure of the split factorization, computed once per mesh.
#[derive(Debug)]
pub struct SplitSymbolic {
    n: usize,
    halves: [Half; 2],
    /// K's DOFs on the separator, in their elimination order.
    separator: Vec<usize>,
    /// K_SS's lower entries: (row, column) in the separator's numbering, and the value's slot.
    separator_entries: Vec<(u32, u32, usize)>,
}

/// One half h and the separator: `M_h = K[dofs, dofs]`.
#[derive(Debug)]
struct Half {
    /// K's DOF for each local DOF: the half's own `own` first, then the separator's.
    dofs: Vec<usize>,
    own: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For each local entry (in column order), its slot in K's values.
    slot: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
}

/// A numeric split factorization.
#[derive(Debug)]
pub struct SplitNumeric {
    factors: [Vec<f64>; 2],
    schur: Llt<f64>,
}

fn factor_error(what: &str) -> impl Fn(faer::sparse::FaerError) -> SolveError + '_ {
    move |e| SolveError::Factor(format!("{what}: {e:?}"))
}

impl SplitSymbolic {
    /// From K's lower-triangle pattern (`col_ptr`, `row_idx`, `n` DOFs), a DOF elimination
    /// order, and the sizes of its two leading parts (the rest being the separator).
    pub fn new(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        dof_order: &[usize],
        parts: [usize; 2],
    ) -> Result<Self, SolveError> {
        let [na, nb] = parts;
        if dof_order.len() != n || na + nb > n || na == 0 || nb == 0 {
            return Err(SolveError::Factor(format!(
                "a split of {n} DOFs into parts of {na} and {nb}"
            )));
        }
        let mut part = vec![u8::MAX; n];
        let mut local = vec![0usize; n];
        for (k, &dof) in dof_order.iter().enumerate() {
            if dof >= n || part[dof] != u8::MAX {
                return Err(SolveError::Factor(
                    "the DOF order is not a permutation".into(),
                ));
            }
            (part[dof], local[dof]) = if k < na {
                (PART_A, k)
            } else if k < na + nb {
                (PART_B, k - na)
            } else {
                (PART_S, k - na - nb)
            };
        }
        let separator = dof_order[na + nb..].to_vec();
        let ns = separator.len();
        let mut separator_entries = Vec::new();
        for &col in &separator {
            for (k, &row) in row_idx[col_ptr[col]..col_ptr[col + 1]].iter().enumerate() {
                if part[row] == PART_S {
                    let (i, j) = (local[row], local[col]);
                    separator_entries.push((i.max(j) as u32, i.min(j) as u32, col_ptr[col] + k));
                }
            }
        }
        let build = |h: u8, own: usize| -> Result<Half, SolveError> {
            let m = own + ns;
            let first = if h == PART_A { 0 } else { na };
            let dofs: Vec<usize> = dof_order[first..first + own]
                .iter()
                .chain(&separator)
                .copied()
                .collect();
            let at = |dof: usize| match part[dof] {
                p if p == h => Some(local[dof]),
                PART_S => Some(own + local[dof]),
                _ => None,
            };
            // Local lower entries (column, row, slot) from K's columns on this half and the
            // separator; an entry from this half into the other means no separator at all.
            let mut e: Vec<(u32, u32, usize)> = Vec::new();
            for (j, &col) in dofs.iter().enumerate() {
                for (k, &row) in row_idx[col_ptr[col]..col_ptr[col + 1]].iter().enumerate() {
                    match at(row) {
                        Some(i) => e.push((i.min(j) as u32, i.max(j) as u32, col_ptr[col] + k)),
                        None if part[col] == h => {
                            return Err(SolveError::Factor(format!(
                                "K couples DOFs {row} and {col} across the separator"
                            )));
                        }
                        None => {}
                    }
                }
            }
            // Lower compressed columns (the values' layout) and upper ones (the symbolic
            // analysis reads the upper triangle when given no permutation), by counting, each
            // short column sorted by row.
            let (col_ptr, rows) = by_columns(m, e.iter().map(|&(c, r, s)| (c, r, s)));
            let (upper_ptr, upper_rows) = by_columns(m, e.iter().map(|&(c, r, _)| (r, c, 0)));
            let row_idx: Vec<usize> = rows.iter().map(|&(r, _)| r as usize).collect();
            let slot: Vec<usize> = rows.iter().map(|&(_, s)| s).collect();
            let upper_idx: Vec<usize> = upper_rows.iter().map(|&(r, _)| r as usize).collect();
            let upper = SymbolicSparseColMatRef::new_checked(m, m, &upper_ptr, None, &upper_idx);
            let symbolic = factorize_symbolic_cholesky(
                upper,
                Side::Upper,
                SymmetricOrdering::Identity,
                // The substitutions and the separator's block read supernodes.
                CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    ..Default::default()
                },
            )
            .map_err(factor_error("symbolic factorization of a half"))?;
            Ok(Half {
                dofs,
                own,
                col_ptr,
                row_idx,
                slot,
                symbolic,
            })
        };
        let (a, b) = rayon::join(|| build(PART_A, na), || build(PART_B, nb));
        Ok(Self {
            n,
            halves: [a?, b?],
            separator,
            separator_entries,
        })
    }

    /// Nonzeros of the factor: both halves' (the separator's block counted in each, as it is
    /// computed in each) and the dense separator's lower triangle.
    pub fn len_val(&self) -> usize {
        let ns = self.separator.len();
        self.halves
            .iter()
            .map(|h| h.symbolic.len_val())
            .sum::<usize>()
            + ns * (ns + 1) / 2
    }

    /// Multiply-adds of the factorization (each half's supernodes, the two products forming
    /// the Schur complement, its dense Cholesky).
    pub fn flops(&self) -> f64 {
        let ns = self.separator.len() as f64;
        self.halves
            .iter()
            .map(|h| cholesky_flops(&h.symbolic))
            .sum::<f64>()
            + 2.0 * ns * ns * ns / 3.0
            + ns * ns * ns / 3.0
    }

    /// Factor K given its values in the pattern's slots.
    pub fn factor(&self, values: &[f64]) -> Result<SplitNumeric, SolveError> {
        let ns = self.separator.len();
        let half = |h: &Half| -> Result<(Vec<f64>, Mat<f64>), SolveError> {
            let local: Vec<f64> = h.slot.iter().map(|&s| values[s]).collect();
            let m = h.dofs.len();
            let pattern = SymbolicSparseColMatRef::new_checked(m, m, &h.col_ptr, None, &h.row_idx);
            let factor = numeric_llt(&h.symbolic, SparseColMatRef::new(pattern, &local))?;
            // L_SS^h L_SS^hᵀ: the separator's share after eliminating the half.
            let l = separator_block(h, &factor, ns);
            // Lower triangle only: a third of the full product's work.
            let mut g = Mat::<f64>::zeros(ns, ns);
            triangular::matmul(
                g.as_mut(),
                BlockStructure::TriangularLower,
                Accum::Replace,
                l.as_ref(),
                BlockStructure::TriangularLower,
                l.transpose(),
                BlockStructure::TriangularUpper,
                1.0,
                Par::Seq,
            );
            Ok((factor, g))
        };
        let (a, b) = rayon::join(|| half(&self.halves[0]), || half(&self.halves[1]));
        let ((fa, mut schur), (fb, gb)) = (a?, b?);
        schur += &gb;
        for &(i, j, s) in &self.separator_entries {
            let (i, j) = (i as usize, j as usize);
            schur[(i, j)] -= values[s];
        }
        let schur = schur
            .llt(Side::Lower)
            .map_err(|_| SolveError::NotPositiveDefinite)?;
        Ok(SplitNumeric {
            factors: [fa, fb],
            schur,
        })
    }

    /// Solve K X = B in place (`rhs` column-major, n x k).
    pub fn solve_in_place(&self, numeric: &SplitNumeric, rhs: &mut [f64], k: usize) {
        let n = self.n;
        let ns = self.separator.len();
        let forward = |h: &Half, factor: &[f64]| -> Vec<f64> {
            let m = h.dofs.len();
            let mut w = vec![0.0; m * k];
            for q in 0..k {
                for (i, &dof) in h.dofs[..h.own].iter().enumerate() {
                    w[i * k + q] = rhs[dof + q * n];
                }
            }
            substitute(h, factor, &mut w, k, Direction::Forward);
            w
        };
        let (mut wa, mut wb) = rayon::join(
            || forward(&self.halves[0], &numeric.factors[0]),
            || forward(&self.halves[1], &numeric.factors[1]),
        );
        // The separator's right-hand side less what the halves pass on, then its solution.
        let mut g = Mat::<f64>::zeros(ns, k);
        for q in 0..k {
            for (i, &dof) in self.separator.iter().enumerate() {
                g[(i, q)] = rhs[dof + q * n]
                    + wa[(self.halves[0].own + i) * k + q]
                    + wb[(self.halves[1].own + i) * k + q];
            }
        }
        numeric.schur.solve_in_place_with_conj(Conj::No, g.as_mut());
        let backward = |h: &Half, factor: &[f64], w: &mut Vec<f64>| {
            for q in 0..k {
                for i in 0..ns {
                    w[(h.own + i) * k + q] = g[(i, q)];
                }
            }
            substitute(h, factor, w, k, Direction::Backward);
        };
        rayon::join(
            || backward(&self.halves[0], &numeric.factors[0], &mut wa),
            || backward(&self.halves[1], &numeric.factors[1], &mut wb),
        );
        for (h, w) in self.halves.iter().zip([&wa, &wb]) {
            for q in 0..k {
                for (i, &dof) in h.dofs[..h.own].iter().enumerate() {
                    rhs[dof + q * n] = w[i * k + q];
                }
            }
        }
        for q in 0..k {
            for (i, &dof) in self.separator.iter().enumerate() {
                rhs[dof + q * n] = g[(i, q)];
            }
        }
    }
}

/// Compressed columns of `m` columns from (column, row, payload) entries, by counting; each
/// column's (row, payload) pairs sorted by row.
fn by_columns(
    m: usize,
    entries: impl Iterator<Item = (u32, u32, usize)> + Clone,
) -> (Vec<usize>, Vec<(u32, usize)>) {
    let mut ptr = vec![0usize; m + 1];
    for (c, _, _) in entries.clone() {
        ptr[c as usize + 1] += 1;
    }
    for c in 0..m {
        ptr[c + 1] += ptr[c];
    }
    let mut next = ptr.clone();
    let mut rows = vec![(0u32, 0usize); ptr[m]];
    for (c, r, payload) in entries {
        rows[next[c as usize]] = (r, payload);
        next[c as usize] += 1;
    }
    for c in 0..m {
        rows[ptr[c]..ptr[c + 1]].sort_unstable();
    }
    (ptr, rows)
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Direction {
    Forward,
    Backward,
}

/// Each supernode of a half's factor: (first column, columns, rows below the block diagonal,
/// its values column-major with leading dimension columns + below).
fn supernodes<'a>(
    h: &'a Half,
    factor: &'a [f64],
) -> impl DoubleEndedIterator<Item = (usize, usize, &'a [usize], &'a [f64])> + 'a {
    let sn = match h.symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(sn) => Some(sn),
        SymbolicCholeskyRaw::Simplicial(_) => None,
    };
    let count = sn.map_or(0, |sn| sn.n_supernodes());
    (0..count).filter_map(move |s| {
        let sn = sn?;
        let b = sn.supernode_begin()[s];
        let w = sn.supernode_end()[s] - b;
        let below = sn.supernode(s).pattern();
        let v = &factor[sn.col_ptr_for_val()[s]..sn.col_ptr_for_val()[s + 1]];
        Some((b, w, below, v))
    })
}

/// Row of the block row `r` of a supernode starting at `b` with `w` columns.
fn block_row(b: usize, w: usize, below: &[usize], r: usize) -> usize {
    if r < w { b + r } else { below[r - w] }
}

/// The dense lower block of a half's factor on the separator (its last `ns` columns).
fn separator_block(h: &Half, factor: &[f64], ns: usize) -> Mat<f64> {
    let own = h.own;
    let mut l = Mat::<f64>::zeros(ns, ns);
    for (b, w, below, v) in supernodes(h, factor) {
        if b + w <= own {
            continue;
        }
        let ld = w + below.len();
        for c in own.max(b) - b..w {
            for r in c..ld {
                let row = block_row(b, w, below, r);
                l[(row - own, b + c - own)] = v[r + c * ld];
            }
        }
    }
    l
}

/// Forward (L y = x) or back (Lᵀ x = y) substitution over a half's own columns only; rows on
/// the separator receive the forward pass's updates and supply the back pass's known values.
/// The right-hand sides are interleaved (`w[row * k + q]`), so that a supernode's rows form a
/// row-major block for the dense triangular solve and product.
fn substitute(h: &Half, factor: &[f64], w: &mut [f64], k: usize, direction: Direction) {
    let own = h.own;
    let mut update = Vec::new();
    let mut visit = |(b, width, below, v): (usize, usize, &[usize], &[f64])| {
        if b >= own {
            return;
        }
        let ld = width + below.len();
        // The supernode's own columns (all of them unless it reaches into the separator);
        // every other row of the block is updated from them.
        let wc = width.min(own - b);
        let l = MatRef::from_column_major_slice(v, ld, width);
        let (diag, rest) = (l.submatrix(0, 0, wc, wc), l.submatrix(wc, 0, ld - wc, wc));
        let rows = (b + wc..b + width).chain(below.iter().copied());
        update.clear();
        update.resize((ld - wc) * k, 0.0);
        match direction {
            Direction::Forward => {
                let x = MatMut::from_row_major_slice_mut(&mut w[b * k..(b + wc) * k], wc, k);
                solve_lower_triangular_in_place(diag, x, Par::Seq);
                let x = MatRef::from_row_major_slice(&w[b * k..(b + wc) * k], wc, k);
                let t = MatMut::from_row_major_slice_mut(&mut update, ld - wc, k);
                matmul(t, Accum::Replace, rest, x, 1.0, Par::Seq);
                for (row, t) in rows.zip(update.chunks_exact(k)) {
                    for (wq, tq) in w[row * k..(row + 1) * k].iter_mut().zip(t) {
                        *wq -= tq;
                    }
                }
            }
            Direction::Backward => {
                for (row, t) in rows.zip(update.chunks_exact_mut(k)) {
                    t.copy_from_slice(&w[row * k..(row + 1) * k]);
                }
                let y = MatRef::from_row_major_slice(&update, ld - wc, k);
                let x = MatMut::from_row_major_slice_mut(&mut w[b * k..(b + wc) * k], wc, k);
                matmul(x, Accum::Add, rest.transpose(), y, -1.0, Par::Seq);
                let x = MatMut::from_row_major_slice_mut(&mut w[b * k..(b + wc) * k], wc, k);
                solve_upper_triangular_in_place(diag.transpose(), x, Par::Seq);
            }
        }
    };
    match direction {
        Direction::Forward => supernodes(h, factor).for_each(&mut visit),
        Direction::Backward => supernodes(h, factor).rev().for_each(&mut visit),
    }
}
