//! A bounding-volume hierarchy over a path's pieces, so that the nearest-point query visits
//! a few pieces instead of all of them (a spline or sinusoid has hundreds).
//!
//! Written here rather than taken from a spatial-index crate because the query must return
//! exactly what the full scan returns, ties included (the first piece in path order wins),
//! and the pieces are arcs and segments, not points: a tree over the pieces in path order
//! (consecutive pieces are neighbours on the tissue, so halving the index range gives tight
//! boxes without sorting) and a branch-and-bound descent that prunes only boxes strictly
//! farther than the best piece so far do both in about a hundred lines.

use std::f64::consts::FRAC_PI_2;

use super::{Piece, dist2};

/// Pieces per leaf: scanning a few is cheaper than another level of boxes.
const LEAF_PIECES: usize = 4;

/// An axis-aligned box `[min, max]` on the tissue plane.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bounds {
    min: [f64; 2],
    max: [f64; 2],
}

impl Bounds {
    fn of_point(p: [f64; 2]) -> Self {
        Self { min: p, max: p }
    }

    fn include(&mut self, p: [f64; 2]) {
        self.min = [self.min[0].min(p[0]), self.min[1].min(p[1])];
        self.max = [self.max[0].max(p[0]), self.max[1].max(p[1])];
    }

    fn union(mut self, other: &Self) -> Self {
        self.include(other.min);
        self.include(other.max);
        self
    }

    /// Grown by `pad` on every side.
    fn padded(mut self, pad: f64) -> Self {
        for k in 0..2 {
            self.min[k] -= pad;
            self.max[k] += pad;
        }
        self
    }

    /// Squared distance from `q` to the box (0 inside). Rounding is monotone, so for any
    /// point `c` inside the box this is at most `dist2(q, c)` as computed in floating point.
    fn dist2(&self, q: [f64; 2]) -> f64 {
        let mut d = [0.0; 2];
        for k in 0..2 {
            if q[k] < self.min[k] {
                d[k] = self.min[k] - q[k];
            } else if q[k] > self.max[k] {
                d[k] = q[k] - self.max[k];
            }
        }
        d[0].powi(2) + d[1].powi(2)
    }
}

/// The box around one piece: its ends and, for an arc, the extreme points of its circle
/// that it sweeps through; padded to cover the rounding of the points the query computes.
fn piece_bounds(piece: &Piece) -> Bounds {
    let (a, _) = piece.at(0.0);
    let (b, _) = piece.at(piece.length());
    let mut bounds = Bounds::of_point(a);
    bounds.include(b);
    let mut scale = a[0].abs().max(a[1].abs()).max(b[0].abs()).max(b[1].abs());
    if let Piece::Arc {
        centre,
        radius,
        start_angle,
        turn,
        length,
        ..
    } = *piece
    {
        for k in 0..4 {
            let angle = k as f64 * FRAC_PI_2;
            let swept = (turn * (angle - start_angle)).rem_euclid(4.0 * FRAC_PI_2);
            if swept * radius <= length {
                bounds.include([
                    centre[0] + radius * angle.cos(),
                    centre[1] + radius * angle.sin(),
                ]);
            }
        }
        scale = scale
            .max(centre[0].abs() + radius)
            .max(centre[1].abs() + radius);
    }
    bounds.padded(1e-12 + 1e-12 * scale)
}

#[derive(Debug, Clone, PartialEq)]
struct Node {
    bounds: Bounds,
    /// Pieces `first..end` (a leaf), or the two children's node indices.
    first: usize,
    end: usize,
    children: Option<(usize, usize)>,
}

/// A cheap lower bound on a piece's distance without trigonometry: its chord, and how far
/// the piece can stray from the chord (the sagitta of an arc, with a margin for rounding).
/// A piece whose bound is strictly beyond the best so far is not evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Chord {
    a: [f64; 2],
    b: [f64; 2],
    stray: f64,
}

impl Chord {
    fn of(piece: &Piece) -> Self {
        let (a, _) = piece.at(0.0);
        let (b, _) = piece.at(piece.length());
        let scale = a[0].abs().max(a[1].abs()).max(b[0].abs()).max(b[1].abs());
        let stray = match *piece {
            Piece::Line { .. } => 0.0,
            Piece::Arc { radius, length, .. } => {
                let angle = length / radius;
                if angle <= std::f64::consts::PI {
                    radius * (1.0 - (angle / 2.0).cos())
                } else {
                    2.0 * radius
                }
            }
        };
        Self {
            a,
            b,
            stray: stray + 1e-12 + 1e-12 * scale,
        }
    }

    /// At most the distance from `q` to the piece.
    fn lower_bound(&self, q: [f64; 2]) -> f64 {
        let ab = [self.b[0] - self.a[0], self.b[1] - self.a[1]];
        let aq = [q[0] - self.a[0], q[1] - self.a[1]];
        let len2 = ab[0] * ab[0] + ab[1] * ab[1];
        let t = if len2 > 0.0 {
            ((aq[0] * ab[0] + aq[1] * ab[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = (aq[0] - t * ab[0]).hypot(aq[1] - t * ab[1]);
        d - self.stray
    }
}

/// The hierarchy over one path's pieces.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PieceIndex {
    nodes: Vec<Node>,
    chords: Vec<Chord>,
}

impl PieceIndex {
    pub(super) fn new(pieces: &[Piece]) -> Self {
        let leaves: Vec<Bounds> = pieces.iter().map(piece_bounds).collect();
        let mut nodes = Vec::with_capacity(2 * pieces.len() / LEAF_PIECES + 2);
        if !pieces.is_empty() {
            build(&leaves, 0, pieces.len(), &mut nodes);
        }
        Self {
            nodes,
            chords: pieces.iter().map(Chord::of).collect(),
        }
    }

    /// Index and arc length within it of the piece nearest to `q`, and the squared
    /// distance, exactly as a scan of every piece in order that keeps the first strictly
    /// nearer one would find; `None` for a path with no pieces or a query no piece compares
    /// with (not finite).
    pub(super) fn nearest(&self, pieces: &[Piece], q: [f64; 2]) -> Option<(usize, f64, f64)> {
        let mut best: Option<(usize, f64, f64)> = None;
        let mut stack: Vec<usize> = Vec::with_capacity(64);
        if !self.nodes.is_empty() {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            // Strictly farther boxes only: a tie may still hold an earlier piece.
            if let Some((_, _, d2)) = best
                && node.bounds.dist2(q) > d2
            {
                continue;
            }
            match node.children {
                Some((l, r)) => {
                    // Visit the nearer child first (pushed last).
                    let (dl, dr) = (self.nodes[l].bounds.dist2(q), self.nodes[r].bounds.dist2(q));
                    if dl <= dr {
                        stack.push(r);
                        stack.push(l);
                    } else {
                        stack.push(l);
                        stack.push(r);
                    }
                }
                None => {
                    for (i, piece) in pieces.iter().enumerate().take(node.end).skip(node.first) {
                        if let Some((_, _, bd2)) = best {
                            let d = self.chords[i].lower_bound(q);
                            // Strictly beyond: a tie may still be an earlier piece.
                            if d > 0.0 && d * d > bd2 {
                                continue;
                            }
                        }
                        let s = piece.nearest_s(q);
                        let (c, _) = piece.at(s);
                        let d2 = dist2(q, c);
                        let better = match best {
                            None => d2 < f64::INFINITY,
                            Some((bi, _, bd2)) => d2 < bd2 || (d2 == bd2 && i < bi),
                        };
                        if better {
                            best = Some((i, s, d2));
                        }
                    }
                }
            }
        }
        best
    }
}

/// Node for pieces `first..end`; returns its index.
fn build(leaves: &[Bounds], first: usize, end: usize, nodes: &mut Vec<Node>) -> usize {
    let at = nodes.len();
    let bounds = leaves[first + 1..end]
        .iter()
        .fold(leaves[first], |b, l| b.union(l));
    nodes.push(Node {
        bounds,
        first,
        end,
        children: None,
    });
    if end - first > LEAF_PIECES {
        let mid = first + (end - first) / 2;
        let l = build(leaves, first, mid, nodes);
        let r = build(leaves, mid, end, nodes);
        nodes[at].children = Some((l, r));
    }
    at
}
