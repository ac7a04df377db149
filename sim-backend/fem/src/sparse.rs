//! The global stiffness in compressed-column form (lower triangle), its assembly, and
//! constrained solves with faer's sparse Cholesky.
//!
//! Prescribed displacements are imposed by zeroing their rows and columns and keeping the
//! diagonal, so the sparsity pattern never changes: one symbolic factorization serves every
//! load case, every contact active set and every Newton iteration on the same mesh.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;

use super::llt::{cholesky_flops, numeric_llt};
use super::mesh::Mesh;
use super::nested_dissection::{self, LEAF_NODES};
use super::solve_error::SolveError;
use super::split_cholesky::{SplitNumeric, SplitSymbolic};

/// The symbolic factorization (ordering, elimination tree, supernodes), shared by every
/// numeric factorization on one mesh.
pub type Symbolic = Arc<SymbolicFactor>;

/// One sparse Cholesky of K, or one split at the top separator into two halves factored side
/// by side ([`SplitSymbolic`]).
#[derive(Debug)]
#[allow(clippy::large_enum_variant)] // one per mesh, behind an Arc
pub enum SymbolicFactor {
    Whole(SymbolicCholesky<usize>),
    Split(SplitSymbolic),
}

impl SymbolicFactor {
    /// Nonzeros stored for the factor.
    pub fn len_val(&self) -> usize {
        match self {
            Self::Whole(s) => s.len_val(),
            Self::Split(s) => s.len_val(),
        }
    }
}

/// How the fill-reducing ordering is computed (the benchmark compares them). The default,
/// [`Ordering::SplitNd`], is the fastest on the seed-001 artery at 328k DOFs by a quarter
/// (docs/BENCHMARKS.md); meshes within one dissection leaf fall back to [`Ordering::NodeAmd`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Ordering {
    /// Approximate minimum degree on the node graph (a quarter of the DOF graph's entries),
    /// each node's two DOFs kept adjacent: cheaper to order, and every node is a 2x2 block.
    NodeAmd,
    /// Approximate minimum degree on the DOF graph (faer's built-in).
    DofAmd,
    /// Nested dissection of the node graph ([`nested_dissection`]): 27 % fewer operations than
    /// AMD on the seed-001 artery, but as much more to compute as it saves.
    NodeNd,
    /// Nested dissection, factored as two halves side by side (one per core) that meet on the
    /// top separator ([`super::split_cholesky`]).
    #[default]
    SplitNd,
}

/// Lower-triangle CSC pattern of a Q4 mesh with 2 DOFs per node (dof = 2 node + component),
/// and for every element the 36 value slots its upper-triangle entries add into.
#[derive(Debug)]
pub struct Pattern {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    /// slots[e][i] for the i-th (p <= q) pair of element e's local DOFs.
    pub slots: Vec<[u32; 36]>,
    /// Node graph, upper part of each column (rows b >= a, sorted): the ordering's input
    /// and the map from node pairs to value slots.
    node_ptr: Vec<usize>,
    node_idx: Vec<usize>,
    /// Elements touching each node (CSR), for the parallel assembly by columns.
    incident_ptr: Vec<usize>,
    incident: Vec<u32>,
    symbolic: SymbolicSparseColMat<usize>,
}

fn local_dofs(el: &[u32; 4]) -> [usize; 8] {
    let mut d = [0; 8];
    for a in 0..4 {
        d[2 * a] = 2 * el[a] as usize;
        d[2 * a + 1] = 2 * el[a] as usize + 1;
    }
    d
}

/// Compressed rows of `nn` lists filled by `fill(push)`, by counting (no sort of triplets).
fn csr_by_counting(nn: usize, each: impl Fn(&mut dyn FnMut(usize, u32))) -> (Vec<usize>, Vec<u32>) {
    let mut ptr = vec![0usize; nn + 1];
    each(&mut |a, _| ptr[a + 1] += 1);
    for i in 0..nn {
        ptr[i + 1] += ptr[i];
    }
    let mut next = ptr.clone();
    let mut idx = vec![0u32; ptr[nn]];
    each(&mut |a, b| {
        idx[next[a]] = b;
        next[a] += 1;
    });
    (ptr, idx)
}

impl Pattern {
    pub fn new(mesh: &Mesh) -> Result<Self, SolveError> {
        Self::with_pairs(mesh, &[])
    }

    /// The pattern of `mesh` with the node pairs `extra` coupled as well (a contact between
    /// nodes that share no element). Out-of-range nodes are an error.
    pub fn with_pairs(mesh: &Mesh, extra: &[[usize; 2]]) -> Result<Self, SolveError> {
        let nn = mesh.nodes.len();
        if let Some(p) = extra.iter().find(|p| p[0] >= nn || p[1] >= nn) {
            return Err(SolveError::Factor(format!(
                "node pair {p:?} is outside the mesh's {nn} nodes"
            )));
        }
        let n = 2 * nn;
        if n >= u32::MAX as usize / 8 {
            return Err(SolveError::Factor(format!("{nn} nodes is too many")));
        }
        // Elements around each node.
        let (incident_ptr, incident) = csr_by_counting(nn, |push| {
            for (e, el) in mesh.elements.iter().enumerate() {
                for &a in el {
                    push(a as usize, e as u32);
                }
            }
        });
        // Upper node graph: for node a, the nodes b >= a sharing an element (with repeats),
        // then sorted and deduplicated per node in parallel.
        let (raw_ptr, mut raw_idx) = csr_by_counting(nn, |push| {
            for el in &mesh.elements {
                for &a in el {
                    for &b in el {
                        if b >= a {
                            push(a as usize, b);
                        }
                    }
                }
            }
            for &[a, b] in extra {
                push(a.min(b), a.max(b) as u32);
            }
        });
        let mut lens = vec![0usize; nn];
        {
            let mut rows: Vec<&mut [u32]> = Vec::with_capacity(nn);
            let mut rest = raw_idx.as_mut_slice();
            for a in 0..nn {
                let (row, tail) = rest.split_at_mut(raw_ptr[a + 1] - raw_ptr[a]);
                rows.push(row);
                rest = tail;
            }
            rows.par_iter_mut()
                .zip(lens.par_iter_mut())
                .for_each(|(row, len)| {
                    row.sort_unstable();
                    let mut k = 0;
                    for i in 0..row.len() {
                        if i == 0 || row[i] != row[i - 1] {
                            row[k] = row[i];
                            k += 1;
                        }
                    }
                    *len = k;
                });
        }
        let mut node_ptr = Vec::with_capacity(nn + 1);
        let mut node_idx = Vec::with_capacity(lens.iter().sum());
        node_ptr.push(0);
        for a in 0..nn {
            node_idx.extend(
                raw_idx[raw_ptr[a]..raw_ptr[a] + lens[a]]
                    .iter()
                    .map(|&b| b as usize),
            );
            node_ptr.push(node_idx.len());
        }
        drop(raw_idx);
        // DOF columns: column 2a holds rows 2a, 2a+1, then 2b, 2b+1 for the upper neighbours
        // b > a; column 2a+1 the same without row 2a. So a node pair's slot is arithmetic.
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        for a in 0..nn {
            let upper = node_ptr[a + 1] - node_ptr[a] - 1;
            let c0 = col_ptr[2 * a] + 2 + 2 * upper;
            col_ptr.push(c0);
            col_ptr.push(c0 + 1 + 2 * upper);
        }
        if col_ptr[n] > u32::MAX as usize {
            // Value slots are u32.
            return Err(SolveError::Factor(format!(
                "{} stiffness entries is too many",
                col_ptr[n]
            )));
        }
        let mut row_idx = vec![0usize; col_ptr[n]];
        row_idx
            .par_chunks_mut(1024)
            .enumerate()
            .for_each(|(chunk, out)| {
                let first = chunk * 1024;
                // Columns overlapping this chunk.
                let mut col = col_ptr.partition_point(|&p| p <= first) - 1;
                for (k, r) in out.iter_mut().enumerate() {
                    let pos = first + k;
                    while col_ptr[col + 1] <= pos {
                        col += 1;
                    }
                    let a = col / 2;
                    let j = pos - col_ptr[col];
                    let nb = &node_idx[node_ptr[a]..node_ptr[a + 1]];
                    *r = if col % 2 == 0 {
                        // rows 2a, 2a+1, then pairs.
                        if j < 2 {
                            2 * a + j
                        } else {
                            2 * nb[1 + (j - 2) / 2] + (j - 2) % 2
                        }
                    } else if j == 0 {
                        2 * a + 1
                    } else {
                        2 * nb[1 + (j - 1) / 2] + (j - 1) % 2
                    };
                }
            });
        // Slot of DOF (row, col) with node(row) >= node(col).
        let slot = |row: usize, col: usize| -> u32 {
            let (a, c) = (col / 2, col % 2);
            let (b, d) = (row / 2, row % 2);
            let base = col_ptr[col];
            let off = if b == a {
                d - c
            } else {
                let nb = &node_idx[node_ptr[a] + 1..node_ptr[a + 1]];
                let k = nb
                    .iter()
                    .position(|&x| x == b)
                    .expect("every element pair is in the pattern by construction");
                (2 - c) + 2 * k + d
            };
            (base + off) as u32
        };
        let slots: Vec<[u32; 36]> = mesh
            .elements
            .par_iter()
            .map(|el| {
                let d = local_dofs(el);
                let mut s = [0u32; 36];
                let mut i = 0;
                for p in 0..8 {
                    for q in p..8 {
                        let (r, c) =
                            if d[p] / 2 > d[q] / 2 || (d[p] / 2 == d[q] / 2 && d[p] >= d[q]) {
                                (d[p], d[q])
                            } else {
                                (d[q], d[p])
                            };
                        s[i] = slot(r, c);
                        i += 1;
                    }
                }
                s
            })
            .collect();
        let symbolic =
            SymbolicSparseColMat::new_checked(n, n, col_ptr.clone(), None, row_idx.clone());
        Ok(Self {
            n,
            col_ptr,
            row_idx,
            slots,
            node_ptr,
            node_idx,
            incident_ptr,
            incident,
            symbolic,
        })
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Value slot of the entry coupling DOFs `p` and `q` (either order; the lower triangle
    /// holds it), if the pattern has it.
    pub fn slot_of(&self, p: usize, q: usize) -> Option<usize> {
        // Stored at (row, col) with node(row) >= node(col), and row >= col within a node.
        let (row, col) = if p / 2 > q / 2 || (p / 2 == q / 2 && p >= q) {
            (p, q)
        } else {
            (q, p)
        };
        let (a, c) = (col / 2, col % 2);
        let (b, d) = (row / 2, row % 2);
        if row >= self.n {
            return None;
        }
        let base = self.col_ptr[col];
        if a == b {
            return Some(base + d - c);
        }
        let nb = &self.node_idx[self.node_ptr[a] + 1..self.node_ptr[a + 1]];
        let k = nb.binary_search(&b).ok()?;
        Some(base + (2 - c) + 2 * k + d)
    }

    /// Value slots of node `a`'s diagonal 2x2 block: (x, x), (y, x), (y, y).
    pub fn node_block(&self, a: usize) -> [usize; 3] {
        let c = self.col_ptr[2 * a];
        [c, c + 1, self.col_ptr[2 * a + 1]]
    }

    /// Assemble element matrices (upper triangles, 36 values each) into a value array, in
    /// parallel: each thread owns a range of nodes, i.e. a contiguous range of columns, and
    /// adds only the entries that land there.
    pub fn assemble(&self, element_k: &[[f64; 36]]) -> Vec<f64> {
        let nn = self.n / 2;
        let mut values = vec![0.0; self.nnz()];
        let blocks = (nn / 2048).max(1);
        let per = nn.div_ceil(blocks);
        let mut parts: Vec<(usize, usize, &mut [f64])> = Vec::with_capacity(blocks);
        let mut rest = values.as_mut_slice();
        let mut a0 = 0;
        while a0 < nn {
            let a1 = (a0 + per).min(nn);
            let len = self.col_ptr[2 * a1] - self.col_ptr[2 * a0];
            let (part, tail) = rest.split_at_mut(len);
            parts.push((a0, a1, part));
            rest = tail;
            a0 = a1;
        }
        parts.par_iter_mut().for_each(|(a0, a1, part)| {
            let lo = self.col_ptr[2 * *a0];
            let hi = self.col_ptr[2 * *a1];
            for a in *a0..*a1 {
                for &e in &self.incident[self.incident_ptr[a]..self.incident_ptr[a + 1]] {
                    let e = e as usize;
                    for (s, v) in self.slots[e].iter().zip(&element_k[e]) {
                        let s = *s as usize;
                        // Column range of node a only: each entry is added exactly once,
                        // by the node owning its column.
                        if s >= self.col_ptr[2 * a] && s < self.col_ptr[2 * a + 2] {
                            debug_assert!(s >= lo && s < hi);
                            part[s - lo] += v;
                        }
                    }
                }
            }
        });
        values
    }

    /// y = K x for the symmetric matrix stored as its lower triangle.
    pub fn mul(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for col in 0..self.n {
            for k in self.col_ptr[col]..self.col_ptr[col + 1] {
                let row = self.row_idx[k];
                let v = values[k];
                y[row] += v * x[col];
                if row != col {
                    y[col] += v * x[row];
                }
            }
        }
        y
    }

    /// Symbolic Cholesky (fill-reducing ordering, elimination tree, supernodes),
    /// computed once per mesh.
    pub fn symbolic(&self) -> Result<Symbolic, SolveError> {
        self.symbolic_with(Ordering::default())
    }

    /// Symbolic Cholesky with a chosen ordering.
    pub fn symbolic_with(&self, ordering: Ordering) -> Result<Symbolic, SolveError> {
        let err = |e: faer::sparse::FaerError| SolveError::Factor(format!("{e:?}"));
        match ordering {
            Ordering::DofAmd => factorize_symbolic_cholesky(
                self.symbolic.as_ref(),
                Side::Lower,
                SymmetricOrdering::Amd,
                CholeskySymbolicParams::default(),
            )
            .map(|s| Arc::new(SymbolicFactor::Whole(s)))
            .map_err(err),
            Ordering::NodeAmd => {
                self.symbolic_from_node_order(&self.node_amd_order().map_err(err)?)
            }
            Ordering::NodeNd => self.symbolic_from_node_order(&self.node_nd_order(LEAF_NODES)?),
            Ordering::SplitNd => self.split_symbolic(),
        }
    }

    /// Nested dissection split at its top separator; a mesh within one dissection leaf gets
    /// one factor by AMD (as [`Ordering::NodeAmd`]), a disconnected one one factor by nested
    /// dissection.
    fn split_symbolic(&self) -> Result<Symbolic, SolveError> {
        let nn = self.n / 2;
        if nn <= LEAF_NODES {
            return self.symbolic_with(Ordering::NodeAmd);
        }
        let split = nested_dissection::order_split(nn, &self.node_ptr, &self.node_idx)
            .map_err(|e| SolveError::Factor(e.to_string()))?;
        match split.parts {
            Some([na, nb]) => {
                let (dof_order, _) = dof_permutation(&split.order);
                SplitSymbolic::new(
                    self.n,
                    &self.col_ptr,
                    &self.row_idx,
                    &dof_order,
                    [2 * na, 2 * nb],
                )
                .map(|s| Arc::new(SymbolicFactor::Split(s)))
            }
            None => self.symbolic_from_node_order(&split.order),
        }
    }

    /// Symbolic Cholesky for a node elimination order (`order[k]` the node eliminated k-th),
    /// each node's two DOFs kept adjacent.
    pub fn symbolic_from_node_order(&self, node_order: &[usize]) -> Result<Symbolic, SolveError> {
        let mut seen = vec![false; self.n / 2];
        if node_order.len() != seen.len()
            || !node_order
                .iter()
                .all(|&a| a < seen.len() && !std::mem::replace(&mut seen[a], true))
        {
            return Err(SolveError::Factor(format!(
                "the node order is not a permutation of the {} nodes",
                seen.len()
            )));
        }
        let (fwd, inv) = dof_permutation(node_order);
        let perm = PermRef::new_checked(&fwd, &inv, self.n);
        factorize_symbolic_cholesky(
            self.symbolic.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(perm),
            CholeskySymbolicParams::default(),
        )
        .map(|s| Arc::new(SymbolicFactor::Whole(s)))
        .map_err(|e| SolveError::Factor(format!("{e:?}")))
    }

    /// Nested dissection of the node graph, pieces of at most `leaf_nodes` ordered by minimum
    /// degree.
    pub fn node_nd_order(&self, leaf_nodes: usize) -> Result<Vec<usize>, SolveError> {
        nested_dissection::order_with_leaves(self.n / 2, &self.node_ptr, &self.node_idx, leaf_nodes)
            .map_err(|e| SolveError::Factor(e.to_string()))
    }

    /// AMD on the node graph: `order[k]` is the node eliminated k-th.
    fn node_amd_order(&self) -> Result<Vec<usize>, faer::sparse::FaerError> {
        let nn = self.n / 2;
        let graph =
            SymbolicSparseColMatRef::new_checked(nn, nn, &self.node_ptr, None, &self.node_idx);
        let mut fwd = vec![0usize; nn];
        let mut inv = vec![0usize; nn];
        let mut mem = MemBuffer::try_new(amd::order_scratch::<usize>(nn, self.node_idx.len()))
            .map_err(|_| faer::sparse::FaerError::OutOfMemory)?;
        amd::order(
            &mut fwd,
            &mut inv,
            graph,
            amd::Control::default(),
            MemStack::new(&mut mem),
        )?;
        Ok(fwd)
    }
}

/// A node elimination order expanded to DOFs (node k of the order becomes DOFs 2k, 2k+1):
/// the forward and inverse permutations.
fn dof_permutation(node_order: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let mut dof_fwd = Vec::with_capacity(2 * node_order.len());
    for &a in node_order {
        dof_fwd.push(2 * a);
        dof_fwd.push(2 * a + 1);
    }
    let mut dof_inv = vec![0usize; dof_fwd.len()];
    for (k, &d) in dof_fwd.iter().enumerate() {
        dof_inv[d] = k;
    }
    (dof_fwd, dof_inv)
}

/// Multiply-adds of the numeric factorization, sum over L's columns of their squared counts
/// (what an ordering should minimize; for the benchmark).
pub fn factor_flops(symbolic: &Symbolic) -> f64 {
    match &**symbolic {
        SymbolicFactor::Whole(s) => cholesky_flops(s),
        SymbolicFactor::Split(s) => s.flops(),
    }
}

/// A factorization of K with a set of DOFs prescribed, ready to solve load cases.
#[derive(Debug)]
pub struct Constrained<'p> {
    pattern: &'p Pattern,
    /// K's values, untouched (for reactions).
    values: &'p [f64],
    fixed: Vec<bool>,
    /// Diagonal kept on the fixed DOFs (scale of the identity rows).
    diag: Vec<f64>,
    symbolic: Symbolic,
    factor: Factor,
}

#[derive(Debug)]
enum Factor {
    Whole(Vec<f64>),
    Split(SplitNumeric),
}

impl<'p> Constrained<'p> {
    /// Factor K with the DOFs flagged in `fixed` prescribed.
    pub fn new(
        pattern: &'p Pattern,
        symbolic: &Symbolic,
        values: &'p [f64],
        fixed: &[bool],
    ) -> Result<Self, SolveError> {
        let mut mv = values.to_vec();
        let mut diag = vec![0.0; pattern.n];
        for col in 0..pattern.n {
            for k in pattern.col_ptr[col]..pattern.col_ptr[col + 1] {
                let row = pattern.row_idx[k];
                if row == col {
                    diag[col] = values[k];
                    if fixed[col] && (values[k].is_nan() || values[k] <= 0.0) {
                        mv[k] = 1.0;
                        diag[col] = 1.0;
                    }
                } else if fixed[row] || fixed[col] {
                    mv[k] = 0.0;
                }
            }
        }
        let factor = match &**symbolic {
            SymbolicFactor::Whole(sym) => Factor::Whole(numeric_llt(
                sym,
                SparseColMatRef::new(pattern.symbolic.as_ref(), &mv),
            )?),
            SymbolicFactor::Split(split) => Factor::Split(split.factor(&mv)?),
        };
        Ok(Self {
            pattern,
            values,
            fixed: fixed.to_vec(),
            diag,
            symbolic: Arc::clone(symbolic),
            factor,
        })
    }

    /// Solve K u = f with u = `prescribed` on the fixed DOFs (other entries ignored).
    pub fn solve(&self, force: &[f64], prescribed: &[f64]) -> Result<Vec<f64>, SolveError> {
        self.solve_many(&[(force, prescribed)])?
            .pop()
            .ok_or(SolveError::NonFinite)
    }

    /// Several load cases (force, prescribed) in one pass over the factor: the triangular
    /// solves are bound by reading L, so k right-hand sides cost little more than one.
    pub fn solve_many(&self, cases: &[(&[f64], &[f64])]) -> Result<Vec<Vec<f64>>, SolveError> {
        let p = self.pattern;
        let n = p.n;
        let k = cases.len();
        if n == 0 || k == 0 {
            return Ok(vec![Vec::new(); k]);
        }
        let mut rhs = vec![0.0; n * k];
        for (j, (force, prescribed)) in cases.iter().enumerate() {
            let col_rhs = &mut rhs[j * n..(j + 1) * n];
            col_rhs.copy_from_slice(force);
            for col in 0..n {
                for kk in p.col_ptr[col]..p.col_ptr[col + 1] {
                    let row = p.row_idx[kk];
                    if row == col {
                        continue;
                    }
                    let v = self.values[kk];
                    if self.fixed[col] && !self.fixed[row] {
                        col_rhs[row] -= v * prescribed[col];
                    } else if self.fixed[row] && !self.fixed[col] {
                        col_rhs[col] -= v * prescribed[row];
                    }
                }
            }
            for i in 0..n {
                if self.fixed[i] {
                    col_rhs[i] = self.diag[i] * prescribed[i];
                }
            }
        }
        match (&*self.symbolic, &self.factor) {
            (SymbolicFactor::Whole(sym), Factor::Whole(factor)) => {
                let par = Par::Seq;
                let mut mem = MemBuffer::try_new(sym.solve_in_place_scratch::<f64>(k, par))
                    .map_err(|_| SolveError::Factor("out of memory for the solve".into()))?;
                LltRef::<'_, usize, f64>::new(sym, factor).solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(&mut rhs, n, k),
                    par,
                    MemStack::new(&mut mem),
                );
            }
            (SymbolicFactor::Split(split), Factor::Split(numeric)) => {
                split.solve_in_place(numeric, &mut rhs, k);
            }
            _ => {
                return Err(SolveError::Factor(
                    "the factor does not match its symbolic".into(),
                ));
            }
        }
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(SolveError::NonFinite);
        }
        Ok(rhs.chunks_exact(n).map(<[f64]>::to_vec).collect())
    }

    /// Reactions K u - f (non-zero only on fixed DOFs at equilibrium).
    pub fn reactions(&self, u: &[f64], force: &[f64]) -> Vec<f64> {
        let mut r = self.pattern.mul(self.values, u);
        for (ri, fi) in r.iter_mut().zip(force) {
            *ri -= fi;
        }
        r
    }
}

/// Dense element matrix from an upper triangle (for tests and small checks).
pub fn upper_to_dense(k: &[f64; 36]) -> [[f64; 8]; 8] {
    let mut m = [[0.0; 8]; 8];
    let mut i = 0;
    for p in 0..8 {
        for q in p..8 {
            m[p][q] = k[i];
            m[q][p] = k[i];
            i += 1;
        }
    }
    m
}

/// Element DOF indices (global) of an element.
pub fn element_dofs(el: &[u32; 4]) -> [usize; 8] {
    local_dofs(el)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesher::test_artery_block;

    fn artery_mesh() -> Mesh {
        test_artery_block(0.008, 0.0025, 0.0008, 0.003)
    }

    /// Deterministic pseudo-random element matrices (xorshift).
    fn element_matrices(n: usize) -> Vec<[f64; 36]> {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        (0..n)
            .map(|_| {
                let mut k = [0.0; 36];
                for v in &mut k {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    *v = (s % 1000) as f64 / 1000.0 - 0.5;
                }
                k
            })
            .collect()
    }

    #[test]
    fn the_parallel_assembly_adds_every_element_entry_exactly_once() {
        let m = artery_mesh();
        let p = Pattern::new(&m).unwrap();
        let ke = element_matrices(m.elements.len());
        let values = p.assemble(&ke);
        // Lower triangle, sorted rows, diagonal first in every column.
        for col in 0..p.n {
            let rows = &p.row_idx[p.col_ptr[col]..p.col_ptr[col + 1]];
            assert_eq!(rows[0], col);
            assert!(
                rows.windows(2).all(|w| w[0] < w[1]),
                "column {col}: {rows:?}"
            );
        }
        // K x element by element against the assembled product.
        let x: Vec<f64> = (0..p.n).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
        let mut want = vec![0.0; p.n];
        for (el, k) in m.elements.iter().zip(&ke) {
            let d = element_dofs(el);
            let kd = upper_to_dense(k);
            for a in 0..8 {
                for b in 0..8 {
                    want[d[a]] += kd[a][b] * x[d[b]];
                }
            }
        }
        let got = p.mul(&values, &x);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-9 * (1.0 + w.abs()), "{g} vs {w}");
        }
    }

    #[test]
    fn node_dof_and_nested_dissection_orderings_solve_the_same_system() {
        use crate::linear::LinearModel;
        use crate::material::{Analysis, Material};
        let m = artery_mesh();
        let mats = [Material::new(15e3, 0.45), Material::new(300e3, 0.49)];
        let mut fixed = vec![false; m.dofs()];
        for &n in &m.bottom {
            fixed[2 * n as usize] = true;
            fixed[2 * n as usize + 1] = true;
        }
        let force = m.lumen_pressure_forces(1e4);
        let zeros = vec![0.0; m.dofs()];
        let solve = |o: Ordering| {
            let lm = LinearModel::with_ordering(&m, &mats, Analysis::PlaneStress, o).unwrap();
            let u = lm.factor(&fixed).unwrap().solve(&force, &zeros).unwrap();
            (u, lm.symbolic.len_val())
        };
        let (u_node, fill_node) = solve(Ordering::NodeAmd);
        let (u_dof, fill_dof) = solve(Ordering::DofAmd);
        let (u_nd, _) = solve(Ordering::NodeNd);
        // This mesh is smaller than one nested dissection leaf: also dissect it down to
        // pieces of 16 nodes, so that the separators really are ordered last.
        let lm = LinearModel::new(&m, &mats, Analysis::PlaneStress).unwrap();
        let order = lm.pattern.node_nd_order(16).unwrap();
        assert!(m.nodes.len() > 10 * 16, "{} nodes", m.nodes.len());
        let symbolic = lm.pattern.symbolic_from_node_order(&order).unwrap();
        let mut repeated = order.clone();
        repeated[1] = repeated[0];
        assert!(lm.pattern.symbolic_from_node_order(&repeated).is_err());
        assert!(lm.pattern.symbolic_from_node_order(&order[1..]).is_err());
        let u_deep = Constrained::new(&lm.pattern, &symbolic, &lm.values, &fixed)
            .unwrap()
            .solve(&force, &zeros)
            .unwrap();
        let scale = u_dof.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(scale > 0.0);
        for u in [&u_node, &u_nd, &u_deep] {
            for (a, b) in u.iter().zip(&u_dof) {
                assert!((a - b).abs() < 1e-9 * scale);
            }
        }
        // Ordering nodes loses nothing against ordering DOFs (AMD finds the 2x2 blocks).
        assert!(
            fill_node as f64 <= 1.05 * fill_dof as f64,
            "{fill_node} vs {fill_dof}"
        );
    }

    #[test]
    fn the_split_factorization_solves_the_same_system_with_prescribed_values() {
        use crate::linear::LinearModel;
        use crate::material::{Analysis, Material};
        let m = artery_mesh();
        let mats = [Material::new(15e3, 0.45), Material::new(600e3, 0.49)];
        let lm = LinearModel::new(&m, &mats, Analysis::PlaneStrain).unwrap();
        // Bottom fixed, the top pushed down by a prescribed displacement that varies along x,
        // lumen pressure: two load cases, prescribed values in one of them.
        let (mut fixed, mut pres) = (vec![false; m.dofs()], vec![0.0; m.dofs()]);
        for &n in &m.bottom {
            fixed[2 * n as usize] = true;
            fixed[2 * n as usize + 1] = true;
        }
        for &n in &m.top {
            fixed[2 * n as usize + 1] = true;
            pres[2 * n as usize + 1] = -1e-4 * (1.0 + m.nodes[n as usize][0] / 0.04);
        }
        let force = m.lumen_pressure_forces(1e4);
        let zeros = vec![0.0; m.dofs()];
        let cases: [(&[f64], &[f64]); 2] = [(&zeros, &pres), (&force, &zeros)];
        let whole = lm.factor(&fixed).unwrap().solve_many(&cases).unwrap();

        // The mesh is smaller than a leaf: split it with small leaves.
        let p = &lm.pattern;
        let split =
            nested_dissection::order_split_with_leaves(p.n / 2, &p.node_ptr, &p.node_idx, 16)
                .unwrap();
        let [na, nb] = split.parts.expect("a connected mesh of this size is split");
        assert!(na > 0 && nb > 0 && na + nb < p.n / 2);
        let (dof_order, _) = dof_permutation(&split.order);
        let sym =
            SplitSymbolic::new(p.n, &p.col_ptr, &p.row_idx, &dof_order, [2 * na, 2 * nb]).unwrap();
        let symbolic: Symbolic = Arc::new(SymbolicFactor::Split(sym));
        let parts = Constrained::new(p, &symbolic, &lm.values, &fixed)
            .unwrap()
            .solve_many(&cases)
            .unwrap();
        for (w, s) in whole.iter().zip(&parts) {
            let scale = w.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(scale > 0.0);
            for (a, b) in w.iter().zip(s) {
                assert!((a - b).abs() < 1e-9 * scale, "{a} vs {b}");
            }
        }
        // Prescribed values are met (to rounding: the row is the kept diagonal's).
        for (i, &f) in fixed.iter().enumerate() {
            if f {
                assert!((parts[0][i] - pres[i]).abs() <= 1e-12 * 2e-4, "DOF {i}");
            }
        }

        // A split whose "separator" does not separate is refused, as is a non-permutation.
        let not_separating = SplitSymbolic::new(
            p.n,
            &p.col_ptr,
            &p.row_idx,
            &dof_order,
            [2 * na + 2, 2 * nb - 2],
        );
        let err = |r: Result<SplitSymbolic, SolveError>| r.err().map(|e| e.to_string());
        assert!(
            err(not_separating).is_some_and(|e| e.contains("across the separator")),
            "moving a node of B into A must couple A and B"
        );
        let mut repeated = dof_order.clone();
        repeated[1] = repeated[0];
        assert!(
            err(SplitSymbolic::new(
                p.n,
                &p.col_ptr,
                &p.row_idx,
                &repeated,
                [2 * na, 2 * nb]
            ))
            .is_some_and(|e| e.contains("permutation"))
        );
        assert!(SplitSymbolic::new(p.n, &p.col_ptr, &p.row_idx, &dof_order, [0, 2 * nb]).is_err());
    }

    #[test]
    fn several_load_cases_in_one_solve_match_separate_solves() {
        use crate::linear::LinearModel;
        use crate::material::{Analysis, Material};
        let m = artery_mesh();
        let lm = LinearModel::new(
            &m,
            &[Material::new(15e3, 0.45), Material::new(3e5, 0.49)],
            Analysis::PlaneStrain,
        )
        .unwrap();
        let mut fixed = vec![false; m.dofs()];
        let mut pres = vec![0.0; m.dofs()];
        for &n in &m.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * m.bottom[0] as usize] = true;
        for &n in &m.top {
            fixed[2 * n as usize + 1] = true;
            pres[2 * n as usize + 1] = -1e-3;
        }
        let c = lm.factor(&fixed).unwrap();
        let zeros = vec![0.0; m.dofs()];
        let unit = m.lumen_pressure_forces(1.0);
        let both = c.solve_many(&[(&zeros, &pres), (&unit, &zeros)]).unwrap();
        let a = c.solve(&zeros, &pres).unwrap();
        let b = c.solve(&unit, &zeros).unwrap();
        assert_eq!(both.len(), 2);
        assert!(
            both[0]
                .iter()
                .zip(&a)
                .all(|(x, y)| (x - y).abs() <= 1e-14 * (1.0 + y.abs()))
        );
        assert!(
            both[1]
                .iter()
                .zip(&b)
                .all(|(x, y)| (x - y).abs() <= 1e-14 * (1.0 + y.abs()))
        );
        assert!(b.iter().any(|v| v.abs() > 0.0));
    }
}
