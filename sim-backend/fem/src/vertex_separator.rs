//! Small balanced vertex separators of a graph, by multilevel bisection (Karypis & Kumar,
//! METIS, 1998): the nested dissection ordering's splitting step.
//!
//! The graph is coarsened by heavy-edge matching down to about a hundred vertices and bisected
//! there by greedy graph growing from several starts (each refined by Fiduccia-Mattheyses on
//! the edge cut, the best kept). The bisection is projected back level by level, refined on its
//! edge cut at each, and on the input graph the cut's edges are turned into a vertex separator
//! by a minimum vertex cover of their bipartite graph (König), which a last Fiduccia-Mattheyses
//! pass on the separator's weight improves (moving a separator vertex to one side pulls its
//! neighbours on the other side into the separator). Refining the vertex separator at every
//! level instead, as METIS does, gave larger separators here. Deterministic: ties are broken by
//! vertex number and by a fixed hash.

use std::collections::BinaryHeap;

/// Side of a vertex: part A, part B, or the separator.
pub const PART_A: u8 = 0;
pub const PART_B: u8 = 1;
pub const SEPARATOR: u8 = 2;

/// Coarsening stops at this many vertices.
const COARSEST: usize = 120;
/// Greedy-growing starts tried on the coarsest graph.
const INITIAL_TRIES: usize = 6;
/// Largest share of the total weight either part may hold after a refinement move.
const MAX_PART_SHARE: f64 = 0.7;

/// An undirected graph in compressed rows, symmetric, no self loops, with vertex and edge
/// weights (sums of merged vertices and edges on coarse graphs).
#[derive(Debug, Clone, Default)]
pub struct Graph {
    pub xadj: Vec<usize>,
    pub adj: Vec<u32>,
    /// Edge weights, or empty when all are 1 (the input graph: saves its largest array).
    pub ewgt: Vec<u32>,
    pub vwgt: Vec<u32>,
}

impl Graph {
    pub fn n(&self) -> usize {
        self.vwgt.len()
    }

    fn edge_weight(&self, e: usize) -> u32 {
        if self.ewgt.is_empty() {
            1
        } else {
            self.ewgt[e]
        }
    }

    fn neighbours(&self, v: usize) -> impl Iterator<Item = (usize, i64)> + '_ {
        (self.xadj[v]..self.xadj[v + 1])
            .map(|e| (self.adj[e] as usize, i64::from(self.edge_weight(e))))
    }

    fn total_weight(&self) -> i64 {
        self.vwgt.iter().map(|&w| i64::from(w)).sum()
    }
}

/// A vertex separator of `g`: for every vertex, [`PART_A`], [`PART_B`] or [`SEPARATOR`], with
/// no edge between A and B. `seed` varies the matching's tie-breaks (another coarsening).
pub fn vertex_separator(g: &Graph, seed: u64) -> Vec<u8> {
    // The hierarchy: levels[i] is the (i+1)-th coarse graph and the map from the vertices of
    // the graph below it to its own.
    let mut levels: Vec<(Vec<u32>, Graph)> = Vec::new();
    loop {
        let fine = levels.last().map_or(g, |(_, c)| c);
        if fine.n() <= COARSEST {
            break;
        }
        let (cmap, coarse) = coarsen(fine, seed * 1000 + levels.len() as u64);
        // Matching stalls on star-like graphs: stop rather than loop for little gain.
        if coarse.n() as f64 > 0.9 * fine.n() as f64 {
            break;
        }
        levels.push((cmap, coarse));
    }
    let coarsest = levels.last().map_or(g, |(_, c)| c);
    let mut part = initial_bisection(coarsest);
    for i in (0..levels.len()).rev() {
        let fine = if i == 0 { g } else { &levels[i - 1].1 };
        let cmap = &levels[i].0;
        part = cmap.iter().map(|&c| part[c as usize]).collect();
        refine_edge_cut(fine, &mut part, max_part_weight(fine.total_weight()));
    }
    cover_cut(g, &mut part);
    refine_separator(g, &mut part);
    part
}

/// Heavy-edge matching: each vertex, in order (the mesh numbering keeps this cache-friendly),
/// is merged with the unmatched neighbour joined by the heaviest edge; ties go to the lighter
/// neighbour, then to a hash of its number salted by `seed`, so that unit-weight graphs are
/// matched in no preferred direction.
fn coarsen(g: &Graph, seed: u64) -> (Vec<u32>, Graph) {
    let n = g.n();
    const UNMATCHED: u32 = u32::MAX;
    let mut mate = vec![UNMATCHED; n];
    // Keep coarse vertices comparable in weight so that balance stays reachable.
    let max_vwgt = (1.5 * g.total_weight() as f64 / COARSEST as f64).max(1.0) as u32;
    let salt = (seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 32) as u32;
    let hash = |u: u32| (u ^ salt).wrapping_mul(0x2c1b_3c6d).rotate_left(13);
    for v in 0..n {
        if mate[v] != UNMATCHED {
            continue;
        }
        let mut best = UNMATCHED;
        let mut best_key = (0u32, 0u32, 0u32);
        for e in g.xadj[v]..g.xadj[v + 1] {
            let u = g.adj[e];
            if mate[u as usize] != UNMATCHED || g.vwgt[v] + g.vwgt[u as usize] > max_vwgt {
                continue;
            }
            let key = (g.edge_weight(e), u32::MAX - g.vwgt[u as usize], hash(u));
            if best == UNMATCHED || key > best_key {
                best = u;
                best_key = key;
            }
        }
        if best == UNMATCHED {
            mate[v] = v as u32;
        } else {
            mate[v] = best;
            mate[best as usize] = v as u32;
        }
    }
    let mut cmap = vec![0u32; n];
    let mut nc = 0u32;
    for v in 0..n {
        let m = mate[v] as usize;
        if v <= m {
            cmap[v] = nc;
            cmap[m] = nc;
            nc += 1;
        }
    }
    let nc = nc as usize;
    // Coarse rows never exceed the fine ones in total: one allocation, no regrowth.
    let mut xadj = Vec::with_capacity(nc + 1);
    let mut adj: Vec<u32> = Vec::with_capacity(g.adj.len());
    let mut ewgt: Vec<u32> = Vec::with_capacity(g.adj.len());
    let mut vwgt = Vec::with_capacity(nc);
    xadj.push(0);
    // slot[c'] = position of coarse neighbour c' in the row being built.
    let mut slot = vec![u32::MAX; nc];
    let unit = g.ewgt.is_empty();
    for v in 0..n {
        let m = mate[v] as usize;
        if v > m {
            continue;
        }
        let c = cmap[v];
        let row_start = adj.len();
        for x in [v, m] {
            let (lo, hi) = (g.xadj[x], g.xadj[x + 1]);
            for (k, &u) in g.adj[lo..hi].iter().enumerate() {
                let cu = cmap[u as usize];
                if cu == c {
                    continue;
                }
                let w = if unit { 1 } else { g.ewgt[lo + k] };
                let s = &mut slot[cu as usize];
                if *s == u32::MAX {
                    *s = adj.len() as u32;
                    adj.push(cu);
                    ewgt.push(w);
                } else {
                    ewgt[*s as usize] += w;
                }
            }
            if m == v {
                break;
            }
        }
        for &cu in &adj[row_start..] {
            slot[cu as usize] = u32::MAX;
        }
        vwgt.push(if m == v {
            g.vwgt[v]
        } else {
            g.vwgt[v] + g.vwgt[m]
        });
        xadj.push(adj.len());
    }
    let coarse = Graph {
        xadj,
        adj,
        ewgt,
        vwgt,
    };
    (cmap, coarse)
}

/// The best of several greedy-growing bisections of a small graph, each refined on its edge
/// cut.
fn initial_bisection(g: &Graph) -> Vec<u8> {
    let n = g.n();
    if n == 0 {
        return Vec::new();
    }
    let mut starts = vec![peripheral_vertex(g, 0)];
    for k in 0..INITIAL_TRIES.saturating_sub(1) {
        starts.push(k * n / INITIAL_TRIES.saturating_sub(1).max(1));
    }
    starts.sort_unstable();
    starts.dedup();
    let total = g.total_weight();
    let max_part = max_part_weight(total);
    let mut best: Option<(i64, i64, Vec<u8>)> = None;
    for &s in &starts {
        let mut part = grow_bisection(g, s);
        let cut = refine_edge_cut(g, &mut part, max_part);
        let wb: i64 = (0..n)
            .filter(|&v| part[v] == PART_B)
            .map(|v| i64::from(g.vwgt[v]))
            .sum();
        let imbalance = (total - 2 * wb).abs();
        if best
            .as_ref()
            .is_none_or(|(c, i, _)| (cut, imbalance) < (*c, *i))
        {
            best = Some((cut, imbalance, part));
        }
    }
    best.map(|(_, _, p)| p).unwrap_or_default()
}

fn max_part_weight(total: i64) -> i64 {
    ((MAX_PART_SHARE * total as f64).ceil() as i64).max(1)
}

/// The last vertex reached by a breadth-first search from `v`, repeated twice: an end of a
/// long path through the graph (George & Liu's pseudo-peripheral vertex).
fn peripheral_vertex(g: &Graph, v: usize) -> usize {
    let n = g.n();
    let mut far = v;
    let mut seen = vec![u32::MAX; n];
    let mut queue = Vec::with_capacity(n);
    for round in 0..2u32 {
        queue.clear();
        queue.push(far);
        seen[far] = round;
        let mut head = 0;
        while head < queue.len() {
            let x = queue[head];
            head += 1;
            for (u, _) in g.neighbours(x) {
                if seen[u] != round {
                    seen[u] = round;
                    queue.push(u);
                }
            }
        }
        far = queue.last().copied().unwrap_or(far);
    }
    far
}

/// Grow part B from `start`, always adding the frontier vertex that most reduces the cut, until
/// it holds half the weight (all of it starts in A).
fn grow_bisection(g: &Graph, start: usize) -> Vec<u8> {
    let n = g.n();
    let mut part = vec![PART_A; n];
    let half = g.total_weight() / 2;
    // gain[v] = weight of v's edges into B minus into A, for v in A; the frontier is a heap
    // with stale entries skipped (gains only grow).
    let mut gain: Vec<i64> = (0..n)
        .map(|v| -g.neighbours(v).map(|(_, w)| w).sum::<i64>())
        .collect();
    let mut frontier = BinaryHeap::new();
    frontier.push((gain[start], std::cmp::Reverse(start)));
    // Where to look for a vertex of A when a component is exhausted.
    let mut cursor = 0;
    let mut wb = 0;
    while wb < half {
        let mut next = None;
        while let Some((gv, std::cmp::Reverse(v))) = frontier.pop() {
            if part[v] == PART_A && gv == gain[v] {
                next = Some(v);
                break;
            }
        }
        let v = match next {
            Some(v) => v,
            None => {
                while cursor < n && part[cursor] != PART_A {
                    cursor += 1;
                }
                if cursor == n {
                    break;
                }
                cursor
            }
        };
        part[v] = PART_B;
        wb += i64::from(g.vwgt[v]);
        for (u, w) in g.neighbours(v) {
            if part[u] == PART_A {
                gain[u] += 2 * w;
                frontier.push((gain[u], std::cmp::Reverse(u)));
            }
        }
    }
    part
}

/// Fiduccia-Mattheyses on the edge cut of a two-way partition (no separator vertices): moves
/// boundary vertices by best gain under the balance bound, keeps the best prefix of each pass.
/// Returns the final cut weight.
fn refine_edge_cut(g: &Graph, part: &mut [u8], max_part: i64) -> i64 {
    let n = g.n();
    let mut internal = vec![0i64; n];
    let mut external = vec![0i64; n];
    let mut pw = [0i64; 2];
    let mut cut2 = 0;
    for v in 0..n {
        pw[part[v] as usize] += i64::from(g.vwgt[v]);
        for (u, w) in g.neighbours(v) {
            if part[u] == part[v] {
                internal[v] += w;
            } else {
                external[v] += w;
            }
        }
        cut2 += external[v];
    }
    let mut cut = cut2 / 2;
    let mut locked = vec![false; n];
    let limit = (n / 20).clamp(15, 150);
    for _pass in 0..4 {
        let mut heaps = [BinaryHeap::new(), BinaryHeap::new()];
        for v in 0..n {
            locked[v] = false;
            if external[v] > 0 {
                heaps[part[v] as usize].push((external[v] - internal[v], std::cmp::Reverse(v)));
            }
        }
        let excess = |pw: &[i64; 2]| (pw[0] - max_part).max(0) + (pw[1] - max_part).max(0);
        let score = |pw: &[i64; 2], cut: i64| (excess(pw), cut, (pw[0] - pw[1]).abs());
        let mut best = score(&pw, cut);
        let mut moves: Vec<usize> = Vec::new();
        let mut best_len = 0;
        loop {
            let mut pick: Option<(i64, usize)> = None;
            for side in 0..2 {
                while let Some(&(gain, std::cmp::Reverse(v))) = heaps[side].peek() {
                    if locked[v]
                        || part[v] as usize != side
                        || gain != external[v] - internal[v]
                        || external[v] == 0
                    {
                        heaps[side].pop();
                        continue;
                    }
                    let wv = i64::from(g.vwgt[v]);
                    let to = 1 - side;
                    // Allowed if it keeps the balance, or moves weight off an overfull side.
                    let ok = pw[to] + wv <= max_part || pw[side] > pw[to] + wv;
                    if ok && pick.is_none_or(|(pg, _)| gain > pg) {
                        pick = Some((gain, v));
                    }
                    break;
                }
            }
            let Some((gain, v)) = pick else { break };
            locked[v] = true;
            cut -= gain;
            move_across(
                g,
                part,
                v,
                &mut pw,
                &mut internal,
                &mut external,
                |u, side, ext, gu| {
                    if !locked[u] && ext > 0 {
                        heaps[side].push((gu, std::cmp::Reverse(u)));
                    }
                },
            );
            moves.push(v);
            let s = score(&pw, cut);
            if s < best {
                best = s;
                best_len = moves.len();
            } else if moves.len() - best_len > limit {
                break;
            }
        }
        for &v in moves[best_len..].iter().rev() {
            cut += external[v] - internal[v];
            move_across(
                g,
                part,
                v,
                &mut pw,
                &mut internal,
                &mut external,
                |_, _, _, _| {},
            );
        }
        if best_len == 0 {
            break;
        }
    }
    cut
}

/// Move `v` to the other part, updating part weights and the internal/external edge weights
/// of `v` and its neighbours; `touched(u, part, external, gain)` is called for each neighbour.
fn move_across(
    g: &Graph,
    part: &mut [u8],
    v: usize,
    pw: &mut [i64; 2],
    internal: &mut [i64],
    external: &mut [i64],
    mut touched: impl FnMut(usize, usize, i64, i64),
) {
    let from = part[v] as usize;
    let to = 1 - from;
    let wv = i64::from(g.vwgt[v]);
    part[v] = to as u8;
    pw[from] -= wv;
    pw[to] += wv;
    std::mem::swap(&mut internal[v], &mut external[v]);
    for (u, w) in g.neighbours(v) {
        if part[u] as usize == to {
            internal[u] += w;
            external[u] -= w;
        } else {
            internal[u] -= w;
            external[u] += w;
        }
        touched(u, part[u] as usize, external[u], external[u] - internal[u]);
    }
}

/// Turn a two-way partition into a vertex separator: the vertices of a minimum vertex cover of
/// the cut edges (König's theorem on a maximum matching of the boundary's bipartite graph).
fn cover_cut(g: &Graph, part: &mut [u8]) {
    let n = g.n();
    // Left: boundary vertices of A; right: boundary vertices of B.
    let boundary = |v: usize, part: &[u8]| g.neighbours(v).any(|(u, _)| part[u] != part[v]);
    let left: Vec<usize> = (0..n)
        .filter(|&v| part[v] == PART_A && boundary(v, part))
        .collect();
    const NONE: usize = usize::MAX;
    let mut match_of = vec![NONE; n];
    // Augmenting paths by depth-first search, iteratively (the boundary can be long).
    let mut visited = vec![usize::MAX; n];
    let mut stack: Vec<(usize, usize)> = Vec::new();
    let mut path: Vec<(usize, usize)> = Vec::new();
    for (round, &root) in left.iter().enumerate() {
        stack.clear();
        path.clear();
        stack.push((root, g.xadj[root]));
        visited[root] = round;
        let mut found = false;
        // path[i] is the edge that led to stack[i + 1] (or, last, to a free vertex).
        while let Some(&mut (x, ref mut e)) = stack.last_mut() {
            if *e == g.xadj[x + 1] {
                stack.pop();
                path.pop();
                continue;
            }
            let y = g.adj[*e] as usize;
            *e += 1;
            if part[y] != PART_B || visited[y] == round {
                continue;
            }
            visited[y] = round;
            let m = match_of[y];
            if m == NONE {
                path.push((x, y));
                found = true;
                break;
            }
            if visited[m] != round {
                visited[m] = round;
                path.push((x, y));
                stack.push((m, g.xadj[m]));
            }
        }
        if found {
            for &(x, y) in &path {
                match_of[x] = y;
                match_of[y] = x;
            }
        }
    }
    // König: Z = vertices reachable from unmatched left vertices by alternating paths;
    // cover = (left \ Z) + (right ∩ Z).
    let mut in_z = vec![false; n];
    let mut queue: Vec<usize> = left
        .iter()
        .copied()
        .filter(|&v| match_of[v] == NONE)
        .collect();
    for &v in &queue {
        in_z[v] = true;
    }
    let mut head = 0;
    while head < queue.len() {
        let x = queue[head];
        head += 1;
        for (y, _) in g.neighbours(x) {
            if part[y] == PART_B && !in_z[y] && match_of[x] != y {
                in_z[y] = true;
                let m = match_of[y];
                if m != NONE && !in_z[m] {
                    in_z[m] = true;
                    queue.push(m);
                }
            }
        }
    }
    let mut cover = Vec::new();
    for &x in &left {
        if !in_z[x] {
            cover.push(x);
        }
        for (y, _) in g.neighbours(x) {
            if part[y] == PART_B && in_z[y] {
                cover.push(y);
            }
        }
    }
    for v in cover {
        part[v] = SEPARATOR;
    }
}

/// Fiduccia-Mattheyses on the separator's weight: a separator vertex moved into one part pulls
/// its neighbours in the other part into the separator. Best prefix of each pass kept, under
/// the balance bound.
fn refine_separator(g: &Graph, part: &mut [u8]) {
    let n = g.n();
    let total = g.total_weight();
    let max_part = max_part_weight(total);
    let mut pw = [0i64; 3];
    for v in 0..n {
        pw[part[v] as usize] += i64::from(g.vwgt[v]);
    }
    // Weight of v's neighbours in `side` (what moving v to the other side pulls in).
    let pulled = |part: &[u8], v: usize, side: u8| -> i64 {
        g.neighbours(v)
            .filter(|&(u, _)| part[u] == side)
            .map(|(u, _)| i64::from(g.vwgt[u]))
            .sum()
    };
    let mut locked = vec![false; n];
    let limit = (n / 50).clamp(20, 200);
    struct Move {
        v: usize,
        to: u8,
        pulled: Vec<usize>,
    }
    for _pass in 0..4 {
        // heaps[t]: moves of separator vertices into part t, by gain.
        let mut heaps = [BinaryHeap::new(), BinaryHeap::new()];
        let mut sep: Vec<usize> = Vec::new();
        for v in 0..n {
            locked[v] = false;
            if part[v] == SEPARATOR {
                sep.push(v);
            }
        }
        for &v in &sep {
            let wv = i64::from(g.vwgt[v]);
            for t in 0..2u8 {
                heaps[t as usize].push((wv - pulled(part, v, 1 - t), std::cmp::Reverse(v)));
            }
        }
        let excess = |pw: &[i64; 3]| (pw[0] - max_part).max(0) + (pw[1] - max_part).max(0);
        let score = |pw: &[i64; 3]| (excess(pw), pw[2], (pw[0] - pw[1]).abs());
        let mut best = score(&pw);
        let mut moves: Vec<Move> = Vec::new();
        let mut best_len = 0;
        loop {
            let mut pick: Option<(i64, usize, u8)> = None;
            for t in 0..2u8 {
                while let Some(&(gain, std::cmp::Reverse(v))) = heaps[t as usize].peek() {
                    let wv = i64::from(g.vwgt[v]);
                    if locked[v] || part[v] != SEPARATOR || gain != wv - pulled(part, v, 1 - t) {
                        heaps[t as usize].pop();
                        continue;
                    }
                    let ok =
                        pw[t as usize] + wv <= max_part || pw[1 - t as usize] > pw[t as usize] + wv;
                    if ok && pick.is_none_or(|(pg, _, _)| gain > pg) {
                        pick = Some((gain, v, t));
                    }
                    break;
                }
            }
            let Some((_, v, t)) = pick else { break };
            let other = 1 - t;
            locked[v] = true;
            part[v] = t;
            let wv = i64::from(g.vwgt[v]);
            pw[t as usize] += wv;
            pw[2] -= wv;
            let mut pulled_in = Vec::new();
            for (u, _) in g.neighbours(v) {
                if part[u] == other {
                    part[u] = SEPARATOR;
                    let wu = i64::from(g.vwgt[u]);
                    pw[other as usize] -= wu;
                    pw[2] += wu;
                    pulled_in.push(u);
                }
            }
            // Separator neighbours of v now pull v in if moved to the other part.
            for (x, _) in g.neighbours(v) {
                if part[x] == SEPARATOR && !locked[x] {
                    let wx = i64::from(g.vwgt[x]);
                    heaps[other as usize].push((wx - pulled(part, x, t), std::cmp::Reverse(x)));
                }
            }
            // New separator vertices, and separator neighbours whose gains changed.
            for &u in &pulled_in {
                if !locked[u] {
                    let wu = i64::from(g.vwgt[u]);
                    for s in 0..2u8 {
                        heaps[s as usize].push((wu - pulled(part, u, 1 - s), std::cmp::Reverse(u)));
                    }
                }
                for (x, _) in g.neighbours(u) {
                    if part[x] == SEPARATOR && !locked[x] {
                        let wx = i64::from(g.vwgt[x]);
                        heaps[t as usize].push((wx - pulled(part, x, other), std::cmp::Reverse(x)));
                    }
                }
            }
            moves.push(Move {
                v,
                to: t,
                pulled: pulled_in,
            });
            let s = score(&pw);
            if s < best {
                best = s;
                best_len = moves.len();
            } else if moves.len() - best_len > limit {
                break;
            }
        }
        for m in moves.drain(best_len..).rev() {
            let other = 1 - m.to;
            for &u in &m.pulled {
                part[u] = other;
                let wu = i64::from(g.vwgt[u]);
                pw[other as usize] += wu;
                pw[2] -= wu;
            }
            part[m.v] = SEPARATOR;
            let wv = i64::from(g.vwgt[m.v]);
            pw[m.to as usize] -= wv;
            pw[2] += wv;
        }
        if best_len == 0 {
            break;
        }
    }
}
