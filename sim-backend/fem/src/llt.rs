//! One sparse LLᵀ on a faer symbolic factorization: the numeric factorization and its
//! operation count. Shared by the whole-matrix factor (`sparse`) and each half of the split
//! one (`split_cholesky`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::{Par, Side};

use super::solve_error::SolveError;

/// Numeric supernodal or simplicial Cholesky of `mat` (lower triangle) for its symbolic
/// factorization: L's values.
pub fn numeric_llt(
    symbolic: &SymbolicCholesky<usize>,
    mat: SparseColMatRef<'_, usize, f64>,
) -> Result<Vec<f64>, SolveError> {
    let mut factor = Vec::new();
    factor
        .try_reserve_exact(symbolic.len_val())
        .map_err(|_| SolveError::Factor("out of memory for the factor".into()))?;
    factor.resize(symbolic.len_val(), 0.0);
    let par = Par::Seq;
    let mut mem =
        MemBuffer::try_new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()))
            .map_err(|_| SolveError::Factor("out of memory for the workspace".into()))?;
    symbolic
        .factorize_numeric_llt::<f64>(
            &mut factor,
            mat,
            Side::Lower,
            LltRegularization::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .map_err(|_| SolveError::NotPositiveDefinite)?;
    Ok(factor)
}

/// Multiply-adds of a sparse Cholesky: the sum over L's columns of their squared counts.
pub fn cholesky_flops(symbolic: &SymbolicCholesky<usize>) -> f64 {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(sn) => (0..sn.n_supernodes())
            .map(|s| {
                let w = sn.supernode_end()[s] - sn.supernode_begin()[s];
                let below = sn.supernode(s).pattern().len();
                (0..w)
                    .map(|c| ((w - c + below) as f64).powi(2))
                    .sum::<f64>()
            })
            .sum(),
        SymbolicCholeskyRaw::Simplicial(sm) => {
            let p = sm.col_ptr();
            (0..sm.ncols())
                .map(|j| ((p[j + 1] - p[j]) as f64).powi(2))
                .sum()
        }
    }
}
