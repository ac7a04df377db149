//! A nested dissection fill-reducing ordering of a sparse symmetric matrix's graph (George
//! 1973; the multilevel recipe of Karypis & Kumar's METIS, 1998), for the FEM's sparse Cholesky.
//!
//! Recursively: find a small balanced vertex separator ([`super::vertex_separator`]), order
//! part A, then part B, then the separator last, so that eliminating A never fills B and the
//! dense fronts are the separators. Below [`LEAF_NODES`] vertices, and for the union of small
//! connected components, the pieces are ordered by approximate minimum degree (faer's AMD).
//! The two halves of each split are ordered in parallel. Deterministic.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::amd;

use super::vertex_separator::{Graph, PART_A, PART_B, SEPARATOR, vertex_separator};

/// Pieces this small (or smaller) are ordered by minimum degree instead of being split.
pub const LEAF_NODES: usize = 256;
fn leaf_nodes() -> usize { std::env::var("ND_LEAF").ok().and_then(|s| s.parse().ok()).unwrap_or(LEAF_NODES) }
/// Halves larger than this are ordered in parallel.
const PARALLEL_NODES: usize = 4096;
/// Largest halo joined into a clique for the leaves' minimum degree.
const HALO_CLIQUE_MAX: usize = 600;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OrderingError {
    #[error("graph column pointers: expected {expected} entries, got {got}")]
    ColumnPointers { expected: usize, got: usize },
    #[error("graph column pointers decrease or overrun the {len} row indices at column {col}")]
    BadPointer { col: usize, len: usize },
    #[error("graph row index {row} in column {col} is out of range for {n} vertices")]
    RowOutOfRange { row: usize, col: usize, n: usize },
    #[error("{0} vertices is too many for 32-bit vertex numbers")]
    TooLarge(usize),
    #[error("minimum degree ordering failed: {0}")]
    Amd(String),
}

/// The elimination order of the graph of A + Aᵀ, where A's pattern is given in compressed
/// columns (`col_ptr` of length n + 1, `row_idx`; either triangle or both, diagonal and
/// repeats ignored): `order[k]` is the vertex eliminated k-th.
pub fn order(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Result<Vec<usize>, OrderingError> {
    let tp = std::time::Instant::now();
    let g = symmetric_graph(n, col_ptr, row_idx)?;
    if std::env::var("ND_PROBE").is_ok() { eprintln!("graph {:.4}", tp.elapsed().as_secs_f64()); }
    let ids: Vec<u32> = (0..n as u32).collect();
    let mut out = dissect(&g, None, ids)?;
    Ok(out.drain(..).map(|v| v as usize).collect())
}

/// A + Aᵀ without the diagonal, rows sorted and unique, unit weights.
fn symmetric_graph(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Result<Graph, OrderingError> {
    if n >= u32::MAX as usize {
        return Err(OrderingError::TooLarge(n));
    }
    if col_ptr.len() != n + 1 {
        return Err(OrderingError::ColumnPointers {
            expected: n + 1,
            got: col_ptr.len(),
        });
    }
    let mut degree = vec![0usize; n + 1];
    for col in 0..n {
        let (a, b) = (col_ptr[col], col_ptr[col + 1]);
        if a > b || b > row_idx.len() {
            return Err(OrderingError::BadPointer {
                col,
                len: row_idx.len(),
            });
        }
        for &row in &row_idx[a..b] {
            if row >= n {
                return Err(OrderingError::RowOutOfRange { row, col, n });
            }
            if row != col {
                degree[row + 1] += 1;
                degree[col + 1] += 1;
            }
        }
    }
    for v in 0..n {
        degree[v + 1] += degree[v];
    }
    let mut next = degree.clone();
    let mut adj = vec![0u32; degree[n]];
    for col in 0..n {
        for &row in &row_idx[col_ptr[col]..col_ptr[col + 1]] {
            if row != col {
                adj[next[row]] = col as u32;
                next[row] += 1;
                adj[next[col]] = row as u32;
                next[col] += 1;
            }
        }
    }
    // Sort and deduplicate each row, compacting in place.
    let mut xadj = Vec::with_capacity(n + 1);
    xadj.push(0);
    let mut len = 0;
    for v in 0..n {
        let (a, b) = (degree[v], degree[v + 1]);
        adj[a..b].sort_unstable();
        for k in a..b {
            if k == a || adj[k] != adj[k - 1] {
                adj[len] = adj[k];
                len += 1;
            }
        }
        xadj.push(len);
    }
    adj.truncate(len);
    Ok(Graph {
        xadj,
        ewgt: Vec::new(),
        adj,
        vwgt: vec![1; n],
    })
}

/// The order of graph `piece` (`top` itself when `None`), whose vertex v is `ids[v]` in `top`.
fn dissect(top: &Graph, piece: Option<Graph>, ids: Vec<u32>) -> Result<Vec<u32>, OrderingError> {
    let g = piece.as_ref().unwrap_or(top);
    let n = g.n();
    if n <= leaf_nodes() {
        return minimum_degree(top, &ids);
    }
    let (count, component) = components(g);
    if count > 1 {
        // Independent pieces: each large one dissected, the small ones together by AMD.
        let mut size = vec![0usize; count];
        for &c in &component {
            size[c as usize] += 1;
        }
        let mut small = vec![false; n];
        let mut pieces: Vec<(Graph, Vec<u32>)> = Vec::new();
        for c in 0..count {
            if size[c] > leaf_nodes() {
                let keep: Vec<bool> = component.iter().map(|&x| x as usize == c).collect();
                pieces.push(induced(g, &ids, &keep));
            }
        }
        for v in 0..n {
            small[v] = size[component[v] as usize] <= leaf_nodes();
        }
        let mut out = Vec::with_capacity(n);
        if small.iter().any(|&s| s) {
            let (_, sids) = induced(g, &ids, &small);
            out.extend(minimum_degree(top, &sids)?);
        }
        drop(piece);
        for (pg, pids) in pieces {
            out.extend(dissect(top, Some(pg), pids)?);
        }
        return Ok(out);
    }
    let part = vertex_separator(g);
    let in_a: Vec<bool> = part.iter().map(|&p| p == PART_A).collect();
    let in_b: Vec<bool> = part.iter().map(|&p| p == PART_B).collect();
    let separator: Vec<u32> = (0..n)
        .filter(|&v| part[v] == SEPARATOR)
        .map(|v| ids[v])
        .collect();
    if !in_a.iter().any(|&x| x) || !in_b.iter().any(|&x| x) {
        // No useful split (a near-clique): minimum degree on the whole piece.
        return minimum_degree(top, &ids);
    }
    let (ga, ida) = induced(g, &ids, &in_a);
    let (gb, idb) = induced(g, &ids, &in_b);
    drop(piece);
    let (oa, ob) = if ga.n().min(gb.n()) > PARALLEL_NODES {
        rayon::join(|| dissect(top, Some(ga), ida), || dissect(top, Some(gb), idb))
    } else {
        (dissect(top, Some(ga), ida), dissect(top, Some(gb), idb))
    };
    let mut out = oa?;
    out.extend(ob?);
    out.extend(separator);
    Ok(out)
}

/// Connected components: their count and each vertex's component.
fn components(g: &Graph) -> (usize, Vec<u32>) {
    let n = g.n();
    let mut comp = vec![u32::MAX; n];
    let mut count = 0u32;
    let mut queue = Vec::with_capacity(n);
    for s in 0..n {
        if comp[s] != u32::MAX {
            continue;
        }
        comp[s] = count;
        queue.clear();
        queue.push(s);
        let mut head = 0;
        while head < queue.len() {
            let x = queue[head];
            head += 1;
            for &u in &g.adj[g.xadj[x]..g.xadj[x + 1]] {
                if comp[u as usize] == u32::MAX {
                    comp[u as usize] = count;
                    queue.push(u as usize);
                }
            }
        }
        count += 1;
    }
    (count as usize, comp)
}

/// The subgraph induced by the vertices flagged in `keep`, numbered in their old order (so
/// sorted rows stay sorted), with their original ids.
fn induced(g: &Graph, ids: &[u32], keep: &[bool]) -> (Graph, Vec<u32>) {
    let n = g.n();
    let mut local = vec![u32::MAX; n];
    let mut sub_ids = Vec::new();
    for v in 0..n {
        if keep[v] {
            local[v] = sub_ids.len() as u32;
            sub_ids.push(ids[v]);
        }
    }
    let m = sub_ids.len();
    let mut sub = Graph {
        xadj: Vec::with_capacity(m + 1),
        adj: Vec::new(),
        ewgt: Vec::new(),
        vwgt: Vec::with_capacity(m),
    };
    sub.xadj.push(0);
    for v in 0..n {
        if !keep[v] {
            continue;
        }
        for &u in &g.adj[g.xadj[v]..g.xadj[v + 1]] {
            let lu = local[u as usize];
            if lu != u32::MAX {
                sub.adj.push(lu);
            }
        }
        sub.xadj.push(sub.adj.len());
        sub.vwgt.push(1);
    }
    (sub, sub_ids)
}

/// faer's approximate minimum degree on a piece (`ids`, ascending, of the whole graph
/// `top`), with its halo: the already-ordered separator vertices next to it, joined into a
/// clique so that they look eliminated last and the piece's boundary vertices, which will
/// fill towards them, are deferred (the idea of Scotch's halo minimum degree).
fn minimum_degree(top: &Graph, ids: &[u32]) -> Result<Vec<u32>, OrderingError> {
    let m = ids.len();
    if m <= 1 {
        return Ok(ids.to_vec());
    }
    let mut halo: Vec<u32> = Vec::new();
    for &v in ids {
        let v = v as usize;
        for &u in &top.adj[top.xadj[v]..top.xadj[v + 1]] {
            if ids.binary_search(&u).is_err() {
                halo.push(u);
            }
        }
    }
    halo.sort_unstable();
    halo.dedup();
    // A large halo's clique would cost more than it is worth: keep the nearest part only.
    let clique = halo.len() <= HALO_CLIQUE_MAX;
    let n = m + halo.len();
    // Upper triangle (row < column) in compressed columns: the piece's own edges once, each
    // piece-halo edge in the halo vertex's column, and the halo clique.
    let local = |u: u32| match ids.binary_search(&u) {
        Ok(j) => Some(j),
        Err(_) => halo.binary_search(&u).ok().map(|h| m + h),
    };
    let mut halo_rows: Vec<Vec<usize>> = vec![Vec::new(); halo.len()];
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0);
    for (i, &v) in ids.iter().enumerate() {
        let v = v as usize;
        for &u in &top.adj[top.xadj[v]..top.xadj[v + 1]] {
            match local(u) {
                Some(j) if j < i => row_idx.push(j),
                Some(j) if j >= m => halo_rows[j - m].push(i),
                _ => {}
            }
        }
        col_ptr.push(row_idx.len());
    }
    for (h, rows) in halo_rows.iter().enumerate() {
        row_idx.extend_from_slice(rows);
        if clique {
            row_idx.extend(m..m + h);
        }
        col_ptr.push(row_idx.len());
    }
    let err = |e: faer::sparse::FaerError| OrderingError::Amd(format!("{e:?}"));
    let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
    let mut fwd = vec![0usize; n];
    let mut inv = vec![0usize; n];
    let mut mem = MemBuffer::try_new(amd::order_scratch::<usize>(n, row_idx.len()))
        .map_err(|_| OrderingError::Amd("out of memory".into()))?;
    amd::order(
        &mut fwd,
        &mut inv,
        pattern,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(err)?;
    Ok(fwd.iter().filter(|&&v| v < m).map(|&v| ids[v]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Upper-triangle pattern (with diagonal) of a k x k grid's 5-point graph.
    fn grid(k: usize) -> (usize, Vec<usize>, Vec<usize>) {
        let n = k * k;
        let mut ptr = vec![0];
        let mut idx = Vec::new();
        for v in 0..n {
            idx.push(v);
            if v % k + 1 < k {
                idx.push(v + 1);
            }
            if v + k < n {
                idx.push(v + k);
            }
            ptr.push(idx.len());
        }
        (n, ptr, idx)
    }

    fn is_permutation(order: &[usize], n: usize) -> bool {
        let mut seen = vec![false; n];
        order.len() == n && order.iter().all(|&v| v < n && !std::mem::replace(&mut seen[v], true))
    }

    #[test]
    fn grid_order_is_a_permutation() {
        let (n, p, i) = grid(100);
        let o = order(n, &p, &i).unwrap();
        assert!(is_permutation(&o, n));
    }
}

#[cfg(test)]
mod probe {
    use super::*;
    use faer::sparse::linalg::cholesky::{CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky};
    use faer::perm::PermRef;
    use faer::sparse::SymbolicSparseColMatRef;
    use faer::Side;

    fn grid9(k: usize) -> (usize, Vec<usize>, Vec<usize>) {
        let n = k * k;
        let mut ptr = vec![0];
        let mut idx = Vec::new();
        for v in 0..n {
            let (r, c) = (v / k, v % k);
            idx.push(v);
            if c + 1 < k { idx.push(v + 1); }
            if r + 1 < k {
                if c > 0 { idx.push(v + k - 1); }
                idx.push(v + k);
                if c + 1 < k { idx.push(v + k + 1); }
            }
            ptr.push(idx.len());
        }
        (n, ptr, idx)
    }

    fn nnz_l(n: usize, p: &[usize], i: &[usize], ord: Option<&[usize]>) -> usize {
        let a = SymbolicSparseColMatRef::new_checked(n, n, p, None, i);
        let so = match ord {
            None => factorize_symbolic_cholesky(a, Side::Lower, SymmetricOrdering::Amd, CholeskySymbolicParams::default()),
            Some(o) => {
                let mut inv = vec![0; n];
                for (k, &v) in o.iter().enumerate() { inv[v] = k; }
                let perm = PermRef::new_checked(o, &inv, n);
                factorize_symbolic_cholesky(a, Side::Lower, SymmetricOrdering::Custom(perm), CholeskySymbolicParams::default())
            }
        };
        let so = std::sync::Arc::new(so.unwrap());
        eprintln!("   flops {:.3e}", crate::fem::sparse::factor_flops(&so));
        so.len_val()
    }

    fn geo(k: usize, r0: usize, r1: usize, c0: usize, c1: usize, out: &mut Vec<usize>) {
        if (r1 - r0) * (c1 - c0) <= 64 {
            for r in r0..r1 { for c in c0..c1 { out.push(r * k + c); } }
            return;
        }
        if r1 - r0 >= c1 - c0 {
            let m = (r0 + r1) / 2;
            geo(k, r0, m, c0, c1, out); geo(k, m + 1, r1, c0, c1, out);
            for c in c0..c1 { out.push(m * k + c); }
        } else {
            let m = (c0 + c1) / 2;
            geo(k, r0, r1, c0, m, out); geo(k, r0, r1, m + 1, c1, out);
            for r in r0..r1 { out.push(r * k + m); }
        }
    }

    fn depth_stats(g: &Graph, depth: usize, stats: &mut Vec<(usize, usize, usize)>) {
        if g.n() <= LEAF_NODES || depth > 6 { return; }
        let part = vertex_separator(g);
        if stats.len() <= depth { stats.push((0, 0, 0)); }
        let s = part.iter().filter(|&&q| q == SEPARATOR).count();
        let a = part.iter().filter(|&&q| q == PART_A).count();
        let b = part.iter().filter(|&&q| q == PART_B).count();
        stats[depth].0 += 1; stats[depth].1 += s; stats[depth].2 = stats[depth].2.max(a.max(b) * 100 / (a + b));
        let ids: Vec<u32> = (0..g.n() as u32).collect();
        let ina: Vec<bool> = part.iter().map(|&q| q == PART_A).collect();
        let inb: Vec<bool> = part.iter().map(|&q| q == PART_B).collect();
        depth_stats(&induced(g, &ids, &ina).0, depth + 1, stats);
        depth_stats(&induced(g, &ids, &inb).0, depth + 1, stats);
    }

    #[test]
    #[ignore]
    fn print_grid() {
        for k in [200usize] {
            let (n, p, i) = grid9(k);
            let mut o = Vec::new();
            geo(k, 0, k, 0, k, &mut o);
            eprintln!("geo nnz {}", nnz_l(n, &p, &i, Some(&o)));
            let g = symmetric_graph(n, &p, &i).unwrap();
            let mut st = Vec::new();
            depth_stats(&g, 0, &mut st);
            eprintln!("{st:?}");
        }
        for k in [200usize] {
            let (n, p, i) = grid9(k);
            let g = symmetric_graph(n, &p, &i).unwrap();
            let part = vertex_separator(g);
            let cnt = |x: u8| part.iter().filter(|&&q| q == x).count();
            let t = std::time::Instant::now();
            let o = order(n, &p, &i).unwrap();
            let tnd = t.elapsed().as_secs_f64();
            eprintln!("k {k}: sep {} A {} B {}  nnz nd {} amd {} t {tnd:.3}", cnt(SEPARATOR), cnt(PART_A), cnt(PART_B), nnz_l(n,&p,&i,Some(&o)), nnz_l(n,&p,&i,None));
        }
    }
}
