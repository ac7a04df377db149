//! The artery's course on the tissue plane: arc-length parametrized, with a nearest-point
//! query that gives the signed lateral offset of any point.
//!
//! Every path is a chain of straight segments and circular arcs in the tissue `x`–`z` plane.
//! Headings are measured from `+x` toward `+z`; a positive offset lies on the `+z` side when
//! travelling along `+x` (the left normal `(-sin θ, cos θ)`). Beyond its two ends the tube is
//! taken to continue straight along the end tangents (the seed's tube ran on to its valve),
//! so the query is defined everywhere and a sensor past the end still feels the tube.
//!
//! The nearest-point query goes through a bounding-volume hierarchy over the pieces
//! ([`index`]), so courses of hundreds of pieces (splines, sinusoids, spirals) cost about
//! what an arc does; it returns exactly what a scan of every piece returns.

mod index;
mod shapes;

#[cfg(test)]
mod shape_tests;

use std::f64::consts::PI;

use control::frames::SurfacePoint;
use serde::{Deserialize, Serialize};

/// Which way an arc turns when travelled from its start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Turn {
    /// Toward `+z` (counter-clockwise seen with `x` right and `z` up on the page).
    #[default]
    Left,
    /// Toward `-z`.
    Right,
}

impl Turn {
    fn sign(self) -> f64 {
        match self {
            Turn::Left => 1.0,
            Turn::Right => -1.0,
        }
    }
}

/// How a scene describes the artery's course.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PathSpec {
    /// A circular arc of `length_m`, laid symmetric about `x` with its chord along `x` and the
    /// chord's midpoint at `chord_centre` (default the origin). It starts at the `-x` end.
    Arc {
        radius_m: f64,
        length_m: f64,
        #[serde(default)]
        chord_centre: SurfacePoint,
        #[serde(default)]
        turn: Turn,
    },
    /// Two arcs of equal radius and opposite turn, each half of `length_m`, symmetric about
    /// the origin; the path starts at the `-x` end heading so that its ends lie on `x`. The
    /// first arc turns `turn` (default left, toward `+z`).
    SCurve {
        radius_m: f64,
        length_m: f64,
        #[serde(default)]
        turn: Turn,
    },
    /// A straight segment from `start` at `heading_rad` (0 along `+x`, π/2 along `+z`).
    Straight {
        start: SurfacePoint,
        heading_rad: f64,
        length_m: f64,
    },
    /// Straight segments through the points, in order.
    Polyline { points: Vec<SurfacePoint> },
    /// A centripetal Catmull–Rom spline through the points, in order, sampled into short
    /// segments (`sample_m`, default 0.5 mm).
    Spline {
        points: Vec<SurfacePoint>,
        #[serde(default)]
        sample_m: Option<f64>,
    },
    /// A sine wave about a straight axis from `start` along `heading_rad`: the course lies
    /// `amplitude_m · (sin(2π u / wavelength_m + phase_rad) − sin(phase_rad))` to the axis's
    /// left at distance `u` along it, so it starts at `start`; `length_m` is the course's
    /// own arc length. Built from short arcs (`step_m`, default 1 mm) whose headings are
    /// exact at their ends.
    Sinusoid {
        start: SurfacePoint,
        heading_rad: f64,
        amplitude_m: f64,
        wavelength_m: f64,
        length_m: f64,
        #[serde(default)]
        phase_rad: f64,
        #[serde(default)]
        step_m: Option<f64>,
    },
    /// A spiral whose radius goes linearly in arc length from `start_radius_m` to
    /// `end_radius_m` over `length_m`, from `start` at `heading_rad`, turning `turn`. Built
    /// from short arcs (`step_m`, default 1 mm) whose headings are exact at their ends.
    Spiral {
        start: SurfacePoint,
        heading_rad: f64,
        start_radius_m: f64,
        end_radius_m: f64,
        length_m: f64,
        #[serde(default)]
        turn: Turn,
        #[serde(default)]
        step_m: Option<f64>,
    },
    /// Straight legs from `start` at `heading_rad`: leg `i` is `legs_m[i]` long between its
    /// corners, and the course turns by `bends_rad[i]` (positive toward `+z` when travelling
    /// along `+x`, below ±180°) between leg `i` and leg `i + 1`. With `fillet_radius_m` each
    /// corner is rounded by an arc of that radius tangent to both legs (the corner points
    /// stay where they are; the legs are shortened); 0 (the default) keeps the corners sharp.
    Corners {
        start: SurfacePoint,
        heading_rad: f64,
        legs_m: Vec<f64>,
        bends_rad: Vec<f64>,
        #[serde(default)]
        fillet_radius_m: f64,
    },
    /// A clothoid spline: the curvature (1/m, positive turning toward `+z` when travelling
    /// along `+x`) goes linearly in arc length between `knots` (their `s_m` increasing from
    /// 0; the last one's is the course's length), from `start` at `heading_rad`. Built from
    /// short arcs (`step_m`, default 1 mm) whose headings are exact at their ends. Random
    /// smooth courses of bounded curvature and curvature rate are drawn as these.
    Clothoid {
        start: SurfacePoint,
        heading_rad: f64,
        knots: Vec<CurvatureKnot>,
        #[serde(default)]
        step_m: Option<f64>,
    },
    /// Another path moved rigidly: rotated by `rotation_rad` about the origin (toward `+z`
    /// from `+x`), then shifted by `translation`; with `reverse` it is travelled from its end
    /// to its start (the other tracking direction).
    Transformed {
        path: Box<PathSpec>,
        #[serde(default)]
        rotation_rad: f64,
        #[serde(default)]
        translation: SurfacePoint,
        #[serde(default)]
        reverse: bool,
    },
}

/// The curvature at one arc length of a [`PathSpec::Clothoid`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurvatureKnot {
    pub s_m: f64,
    pub curvature_per_m: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Piece {
    Line {
        start: [f64; 2],
        heading: f64,
        length: f64,
    },
    Arc {
        centre: [f64; 2],
        radius: f64,
        /// Polar angle of the start point about the centre.
        start_angle: f64,
        /// Heading at the start.
        heading: f64,
        /// Signed curvature sign: +1 turns toward +z.
        turn: f64,
        length: f64,
    },
}

impl Piece {
    fn length(&self) -> f64 {
        match *self {
            Piece::Line { length, .. } | Piece::Arc { length, .. } => length,
        }
    }

    /// Point and heading at arc length `s` from the piece's start (unclamped for lines).
    fn at(&self, s: f64) -> ([f64; 2], f64) {
        match *self {
            Piece::Line { start, heading, .. } => (
                [start[0] + s * heading.cos(), start[1] + s * heading.sin()],
                heading,
            ),
            Piece::Arc {
                centre,
                radius,
                start_angle,
                heading,
                turn,
                ..
            } => {
                let a = start_angle + turn * s / radius;
                (
                    [centre[0] + radius * a.cos(), centre[1] + radius * a.sin()],
                    heading + turn * s / radius,
                )
            }
        }
    }

    /// Arc length (clamped to the piece) of the point nearest to `p`.
    fn nearest_s(&self, p: [f64; 2]) -> f64 {
        match *self {
            Piece::Line {
                start,
                heading,
                length,
            } => {
                let s = (p[0] - start[0]) * heading.cos() + (p[1] - start[1]) * heading.sin();
                s.clamp(0.0, length)
            }
            Piece::Arc {
                centre,
                radius,
                start_angle,
                turn,
                length,
                ..
            } => {
                let dx = p[0] - centre[0];
                let dz = p[1] - centre[1];
                if dx.hypot(dz) < 1e-12 * radius.max(1.0) {
                    // Every point of the arc is equally near the centre.
                    return 0.0;
                }
                let angle = dz.atan2(dx);
                // Angle travelled from the start, in the turn's direction, wrapped to [0, 2π).
                let swept = (turn * (angle - start_angle)).rem_euclid(2.0 * PI);
                let s = swept * radius;
                if s <= length {
                    return s;
                }
                // Outside the swept range: the nearer end.
                let (a, _) = self.at(0.0);
                let (b, _) = self.at(length);
                if dist2(p, a) <= dist2(p, b) {
                    0.0
                } else {
                    length
                }
            }
        }
    }
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// The result of a nearest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// Arc length of the nearest point from the path's start, m; below 0 or beyond the
    /// length on the straight continuations past the ends.
    pub s_m: f64,
    /// Signed lateral offset of the query point from the path (positive on the left
    /// normal's side), m.
    pub offset_m: f64,
    /// Heading of the path at the nearest point, rad.
    pub heading_rad: f64,
    /// The nearest point itself.
    pub point: SurfacePoint,
}

/// Why a path description cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PathError {
    #[error("{0}")]
    Invalid(String),
}

/// An arc-length parametrized artery path.
#[derive(Debug, Clone, PartialEq)]
pub struct ArteryPath {
    pieces: Vec<Piece>,
    /// Arc length at the start of each piece.
    starts: Vec<f64>,
    length: f64,
    index: index::PieceIndex,
    /// The path's two ends and their heading's (cos, sin), for the straight continuations.
    ends: [([f64; 2], f64, f64); 2],
}

impl ArteryPath {
    /// Build the path a scene describes.
    pub fn from_spec(spec: &PathSpec) -> Result<Self, PathError> {
        let bad = |m: String| Err(PathError::Invalid(m));
        match spec {
            PathSpec::Arc {
                radius_m,
                length_m,
                chord_centre,
                turn,
            } => {
                let (r, l) = (*radius_m, *length_m);
                if !(r.is_finite() && r > 0.0 && l.is_finite() && l > 0.0) {
                    return bad(format!(
                        "arc radius and length must be positive, got {r} and {l}"
                    ));
                }
                if l >= 2.0 * PI * r {
                    return bad(format!(
                        "an arc of length {l} m on radius {r} m would close on itself"
                    ));
                }
                let sweep = l / r;
                let sign = turn.sign();
                let heading0 = -sign * sweep / 2.0;
                let half_chord = r * (sweep / 2.0).sin();
                let start = [chord_centre.x_m - half_chord, chord_centre.z_m];
                Ok(Self::chain(start, heading0, &[(sign / r, l)]))
            }
            PathSpec::SCurve {
                radius_m,
                length_m,
                turn,
            } => {
                let (r, l) = (*radius_m, *length_m);
                if !(r.is_finite() && r > 0.0 && l.is_finite() && l > 0.0) {
                    return bad(format!(
                        "S-curve radius and length must be positive, got {r} and {l}"
                    ));
                }
                if l / 2.0 >= PI * r {
                    return bad(format!(
                        "each half of an S-curve of length {l} m turns more than 180° on radius {r} m"
                    ));
                }
                let sign = turn.sign();
                let sweep = l / 2.0 / r;
                let heading0 = -sign * sweep / 2.0;
                // Place it so that its midpoint (the inflection) is the origin.
                let first = Self::chain([0.0, 0.0], heading0, &[(sign / r, l / 2.0)]);
                let (mid, _) = first.pieces[0].at(l / 2.0);
                Ok(Self::chain(
                    [-mid[0], -mid[1]],
                    heading0,
                    &[(sign / r, l / 2.0), (-sign / r, l / 2.0)],
                ))
            }
            PathSpec::Straight {
                start,
                heading_rad,
                length_m,
            } => {
                if !(start.is_finite()
                    && heading_rad.is_finite()
                    && length_m.is_finite()
                    && *length_m > 0.0)
                {
                    return bad(
                        "a straight path needs a finite start and heading and a positive length"
                            .into(),
                    );
                }
                Ok(Self::chain(
                    [start.x_m, start.z_m],
                    *heading_rad,
                    &[(0.0, *length_m)],
                ))
            }
            PathSpec::Polyline { points } => Self::polyline(points),
            PathSpec::Spline { points, sample_m } => {
                let step = sample_m.unwrap_or(0.0005);
                if !(step.is_finite() && step > 0.0) {
                    return bad(format!("spline sample_m must be positive, got {step}"));
                }
                let sampled = catmull_rom(points, step)?;
                Self::polyline(&sampled)
            }
            PathSpec::Sinusoid {
                start,
                heading_rad,
                amplitude_m,
                wavelength_m,
                length_m,
                phase_rad,
                step_m,
            } => Ok(Self::from_pieces(shapes::sinusoid(
                *start,
                *heading_rad,
                *amplitude_m,
                *wavelength_m,
                *length_m,
                *phase_rad,
                step_m.unwrap_or(shapes::DEFAULT_STEP_M),
            )?)),
            PathSpec::Spiral {
                start,
                heading_rad,
                start_radius_m,
                end_radius_m,
                length_m,
                turn,
                step_m,
            } => Ok(Self::from_pieces(shapes::spiral(
                *start,
                *heading_rad,
                *start_radius_m,
                *end_radius_m,
                *length_m,
                *turn,
                step_m.unwrap_or(shapes::DEFAULT_STEP_M),
            )?)),
            PathSpec::Corners {
                start,
                heading_rad,
                legs_m,
                bends_rad,
                fillet_radius_m,
            } => Ok(Self::from_pieces(shapes::corners(
                *start,
                *heading_rad,
                legs_m,
                bends_rad,
                *fillet_radius_m,
            )?)),
            PathSpec::Clothoid {
                start,
                heading_rad,
                knots,
                step_m,
            } => Ok(Self::from_pieces(shapes::clothoid(
                *start,
                *heading_rad,
                knots,
                step_m.unwrap_or(shapes::DEFAULT_STEP_M),
            )?)),
            PathSpec::Transformed {
                path,
                rotation_rad,
                translation,
                reverse,
            } => {
                let inner = Self::from_spec(path)?;
                Ok(Self::from_pieces(shapes::transformed(
                    inner.pieces,
                    *rotation_rad,
                    *translation,
                    *reverse,
                )?))
            }
        }
    }

    /// Pieces of given signed curvature (1/m, 0 for straight) and length, joined end to end.
    fn chain(start: [f64; 2], heading0: f64, parts: &[(f64, f64)]) -> Self {
        let mut pieces = Vec::with_capacity(parts.len());
        let mut p = start;
        let mut heading = heading0;
        for &(curvature, length) in parts {
            let piece = if curvature == 0.0 {
                Piece::Line {
                    start: p,
                    heading,
                    length,
                }
            } else {
                let radius = 1.0 / curvature.abs();
                let turn = curvature.signum();
                // The centre lies on the side the path turns toward.
                let normal = [-heading.sin(), heading.cos()];
                let centre = [
                    p[0] + turn * radius * normal[0],
                    p[1] + turn * radius * normal[1],
                ];
                let start_angle = (p[1] - centre[1]).atan2(p[0] - centre[0]);
                Piece::Arc {
                    centre,
                    radius,
                    start_angle,
                    heading,
                    turn,
                    length,
                }
            };
            let (end, end_heading) = piece.at(length);
            p = end;
            heading = end_heading;
            pieces.push(piece);
        }
        Self::from_pieces(pieces)
    }

    fn polyline(points: &[SurfacePoint]) -> Result<Self, PathError> {
        if points.len() < 2 {
            return Err(PathError::Invalid(format!(
                "a polyline needs at least two points, got {}",
                points.len()
            )));
        }
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(PathError::Invalid(format!("point {i} is not finite")));
        }
        let mut pieces = Vec::with_capacity(points.len() - 1);
        for (i, w) in points.windows(2).enumerate() {
            let (a, b) = (w[0], w[1]);
            let length = a.distance_to(&b);
            if length < 1e-9 {
                return Err(PathError::Invalid(format!(
                    "points {i} and {} coincide",
                    i + 1
                )));
            }
            pieces.push(Piece::Line {
                start: [a.x_m, a.z_m],
                heading: (b.z_m - a.z_m).atan2(b.x_m - a.x_m),
                length,
            });
        }
        Ok(Self::from_pieces(pieces))
    }

    fn from_pieces(pieces: Vec<Piece>) -> Self {
        let mut starts = Vec::with_capacity(pieces.len());
        let mut s = 0.0;
        for p in &pieces {
            starts.push(s);
            s += p.length();
        }
        let index = index::PieceIndex::new(&pieces);
        let mut path = Self {
            pieces,
            starts,
            length: s,
            index,
            ends: [([0.0; 2], 1.0, 0.0); 2],
        };
        if !path.pieces.is_empty() {
            for (k, s) in [0.0, path.length].into_iter().enumerate() {
                let (p, h) = path.at(s);
                path.ends[k] = ([p.x_m, p.z_m], h.cos(), h.sin());
            }
        }
        path
    }

    /// How many pieces (segments and arcs) the path is built from.
    pub fn piece_count(&self) -> usize {
        self.pieces.len()
    }

    /// Total arc length, m.
    pub fn length_m(&self) -> f64 {
        self.length
    }

    /// Point and heading at arc length `s_m`; beyond the ends, on the straight continuations.
    pub fn at(&self, s_m: f64) -> (SurfacePoint, f64) {
        let (i, local) = self.locate(s_m);
        let piece = &self.pieces[i];
        let (p, h) = if local < 0.0 {
            let (p0, h0) = piece.at(0.0);
            ([p0[0] + local * h0.cos(), p0[1] + local * h0.sin()], h0)
        } else if local > piece.length() {
            let (p1, h1) = piece.at(piece.length());
            let extra = local - piece.length();
            ([p1[0] + extra * h1.cos(), p1[1] + extra * h1.sin()], h1)
        } else {
            piece.at(local)
        };
        (SurfacePoint::new(p[0], p[1]), h)
    }

    fn locate(&self, s: f64) -> (usize, f64) {
        let i = match self.starts.partition_point(|&st| st <= s) {
            0 => 0,
            n => n - 1,
        };
        (i, s - self.starts[i])
    }

    /// The path's nearest point to `p`, with the signed offset.
    pub fn nearest(&self, p: SurfacePoint) -> Nearest {
        let q = [p.x_m, p.z_m];
        let (best_s, best_d2) = match self.index.nearest(&self.pieces, q) {
            Some((i, s, d2)) => (self.starts[i] + s, d2),
            None => (0.0, f64::INFINITY),
        };
        self.finish_nearest(q, best_s, best_d2)
    }

    /// [`Self::nearest`] by scanning every piece (the query before the index): the
    /// reference the index must match, public for the speed example.
    #[doc(hidden)]
    pub fn nearest_by_scan(&self, p: SurfacePoint) -> Nearest {
        let q = [p.x_m, p.z_m];
        let mut best_s = 0.0;
        let mut best_d2 = f64::INFINITY;
        for (piece, &start) in self.pieces.iter().zip(&self.starts) {
            let s = piece.nearest_s(q);
            let (c, _) = piece.at(s);
            let d2 = dist2(q, c);
            if d2 < best_d2 {
                best_d2 = d2;
                best_s = start + s;
            }
        }
        self.finish_nearest(q, best_s, best_d2)
    }

    /// The straight continuations past the ends against the best piece, and the offset.
    fn finish_nearest(&self, q: [f64; 2], mut best_s: f64, mut best_d2: f64) -> Nearest {
        // The straight continuations beyond the ends.
        let [(p0, cos0, sin0), (p1, cos1, sin1)] = self.ends;
        let before = (q[0] - p0[0]) * cos0 + (q[1] - p0[1]) * sin0;
        if before < 0.0 {
            let (c, _) = self.at(before);
            let d2 = dist2(q, [c.x_m, c.z_m]);
            if d2 < best_d2 {
                best_d2 = d2;
                best_s = before;
            }
        }
        let after = (q[0] - p1[0]) * cos1 + (q[1] - p1[1]) * sin1;
        if after > 0.0 {
            let (c, _) = self.at(self.length + after);
            let d2 = dist2(q, [c.x_m, c.z_m]);
            if d2 < best_d2 {
                best_s = self.length + after;
            }
        }
        let (c, heading) = self.at(best_s);
        let normal = [-heading.sin(), heading.cos()];
        let offset = (q[0] - c.x_m) * normal[0] + (q[1] - c.z_m) * normal[1];
        Nearest {
            s_m: best_s,
            offset_m: offset,
            heading_rad: heading,
            point: c,
        }
    }

    /// The largest curvature of any arc piece, 1/m (0 for straight pieces only; the
    /// corners between pieces are [`Self::largest_corner_rad`]).
    pub fn largest_curvature_per_m(&self) -> f64 {
        self.pieces
            .iter()
            .map(|p| match *p {
                Piece::Line { .. } => 0.0,
                Piece::Arc { radius, .. } => 1.0 / radius,
            })
            .fold(0.0, f64::max)
    }

    /// The largest change of heading where one piece meets the next (a sharp corner), rad.
    pub fn largest_corner_rad(&self) -> f64 {
        self.pieces
            .windows(2)
            .map(|w| {
                let (_, end) = w[0].at(w[0].length());
                let (_, start) = w[1].at(0.0);
                let d = (start - end).rem_euclid(2.0 * PI);
                d.min(2.0 * PI - d)
            })
            .fold(0.0, f64::max)
    }

    /// Points every `step_m` along the path, both ends included (for plots).
    pub fn sample(&self, step_m: f64) -> Vec<SurfacePoint> {
        let n = ((self.length / step_m.max(1e-6)).ceil() as usize).clamp(1, 1_000_000);
        (0..=n)
            .map(|i| self.at(self.length * i as f64 / n as f64).0)
            .collect()
    }
}

/// Centripetal Catmull–Rom through `points`, sampled about every `step` metres.
fn catmull_rom(points: &[SurfacePoint], step: f64) -> Result<Vec<SurfacePoint>, PathError> {
    if points.len() < 2 {
        return Err(PathError::Invalid(format!(
            "a spline needs at least two points, got {}",
            points.len()
        )));
    }
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(PathError::Invalid(format!("point {i} is not finite")));
    }
    for (i, w) in points.windows(2).enumerate() {
        if w[0].distance_to(&w[1]) < 1e-9 {
            return Err(PathError::Invalid(format!(
                "points {i} and {} coincide",
                i + 1
            )));
        }
    }
    let n = points.len();
    let get = |i: isize| -> [f64; 2] {
        // Reflect the end points to make phantom control points.
        if i < 0 {
            let (a, b) = (points[0], points[1]);
            [2.0 * a.x_m - b.x_m, 2.0 * a.z_m - b.z_m]
        } else if i as usize >= n {
            let (a, b) = (points[n - 1], points[n - 2]);
            [2.0 * a.x_m - b.x_m, 2.0 * a.z_m - b.z_m]
        } else {
            let p = points[i as usize];
            [p.x_m, p.z_m]
        }
    };
    let mut out = vec![points[0]];
    for seg in 0..n - 1 {
        let i = seg as isize;
        let (p0, p1, p2, p3) = (get(i - 1), get(i), get(i + 1), get(i + 2));
        let knot = |a: [f64; 2], b: [f64; 2]| dist2(a, b).sqrt().sqrt().max(1e-9);
        let t1 = knot(p0, p1);
        let t2 = t1 + knot(p1, p2);
        let t3 = t2 + knot(p2, p3);
        let chord = dist2(p1, p2).sqrt();
        let m = ((chord / step).ceil() as usize).clamp(1, 100_000);
        for k in 1..=m {
            let t = t1 + (t2 - t1) * k as f64 / m as f64;
            let lerp = |a: [f64; 2], b: [f64; 2], ta: f64, tb: f64| {
                let w = (t - ta) / (tb - ta);
                [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])]
            };
            let a1 = lerp(p0, p1, 0.0, t1);
            let a2 = lerp(p1, p2, t1, t2);
            let a3 = lerp(p2, p3, t2, t3);
            let b1 = lerp(a1, a2, 0.0, t2);
            let b2 = lerp(a2, a3, t1, t3);
            let c = lerp(b1, b2, t1, t2);
            let c = SurfacePoint::new(c[0], c[1]);
            if out.last().is_none_or(|l| l.distance_to(&c) > 1e-9) {
                out.push(c);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn arc(r: f64, l: f64) -> ArteryPath {
        ArteryPath::from_spec(&PathSpec::Arc {
            radius_m: r,
            length_m: l,
            chord_centre: SurfacePoint::default(),
            turn: Turn::Left,
        })
        .unwrap()
    }

    #[test]
    fn arc_is_symmetric_about_x_with_its_chord_on_x() {
        for r in [0.08, 0.145, 0.22] {
            let p = arc(r, 0.26);
            let (a, ha) = p.at(0.0);
            let (b, hb) = p.at(0.26);
            assert!(a.z_m.abs() < 1e-12 && b.z_m.abs() < 1e-12);
            assert!((a.x_m + b.x_m).abs() < 1e-12);
            // The turn through 0.26 / r rad, symmetric headings.
            assert!((hb - ha - 0.26 / r).abs() < 1e-12);
            assert!((ha + hb).abs() < 1e-12);
        }
        // DESIGN.md section 6: an 80 mm arc of 26 cm turns through 186°.
        assert!(((0.26_f64 / 0.08).to_degrees() - 186.2).abs() < 0.1);
    }

    #[test]
    fn nearest_on_arc_gives_radial_offset_with_side() {
        let r = 0.145;
        let p = arc(r, 0.26);
        let (mid, h) = p.at(0.13);
        assert!(h.abs() < 1e-12);
        // Left turn: the centre is on +z; a point toward the centre has positive offset.
        let inside = SurfacePoint::new(mid.x_m, mid.z_m + 0.003);
        let n = p.nearest(inside);
        assert!((n.offset_m - 0.003).abs() < 1e-12);
        assert!((n.s_m - 0.13).abs() < 1e-9);
        let outside = SurfacePoint::new(mid.x_m, mid.z_m - 0.004);
        assert!((p.nearest(outside).offset_m + 0.004).abs() < 1e-12);
    }

    #[test]
    fn past_the_ends_the_tube_runs_straight_on() {
        let p = ArteryPath::from_spec(&PathSpec::Straight {
            start: SurfacePoint::new(0.0, 0.0),
            heading_rad: 0.0,
            length_m: 0.1,
        })
        .unwrap();
        let n = p.nearest(SurfacePoint::new(0.15, -0.002));
        assert!((n.s_m - 0.15).abs() < 1e-12);
        assert!((n.offset_m + 0.002).abs() < 1e-12);
        let n = p.nearest(SurfacePoint::new(-0.05, 0.001));
        assert!((n.s_m + 0.05).abs() < 1e-12);
        assert!((n.offset_m - 0.001).abs() < 1e-12);
    }

    #[test]
    fn s_curve_passes_the_origin_and_ends_on_x() {
        let p = ArteryPath::from_spec(&PathSpec::SCurve {
            radius_m: 0.1,
            length_m: 0.26,
            turn: Turn::Left,
        })
        .unwrap();
        let (mid, _) = p.at(0.13);
        assert!(mid.x_m.abs() < 1e-12 && mid.z_m.abs() < 1e-12);
        let (a, ha) = p.at(0.0);
        let (b, hb) = p.at(0.26);
        assert!((a.z_m + b.z_m).abs() < 1e-12, "point-symmetric ends");
        assert!((ha - hb).abs() < 1e-12, "same heading at both ends");
        assert!((p.length_m() - 0.26).abs() < 1e-12);
    }

    #[test]
    fn spline_through_collinear_points_is_the_line() {
        let pts = vec![
            SurfacePoint::new(0.0, 0.0),
            SurfacePoint::new(0.01, 0.0),
            SurfacePoint::new(0.03, 0.0),
        ];
        let p = ArteryPath::from_spec(&PathSpec::Spline {
            points: pts,
            sample_m: None,
        })
        .unwrap();
        assert!((p.length_m() - 0.03).abs() < 1e-9);
        assert!(p.nearest(SurfacePoint::new(0.02, 0.001)).offset_m - 0.001 < 1e-9);
    }

    #[test]
    fn bad_paths_are_errors() {
        assert!(
            ArteryPath::from_spec(&PathSpec::Arc {
                radius_m: 0.01,
                length_m: 0.26,
                chord_centre: SurfacePoint::default(),
                turn: Turn::Left
            })
            .is_err()
        );
        assert!(
            ArteryPath::from_spec(&PathSpec::Polyline {
                points: vec![SurfacePoint::new(0.0, 0.0)]
            })
            .is_err()
        );
        assert!(
            ArteryPath::from_spec(&PathSpec::Polyline {
                points: vec![SurfacePoint::new(0.0, 0.0), SurfacePoint::new(0.0, 0.0)]
            })
            .is_err()
        );
        assert!(
            ArteryPath::from_spec(&PathSpec::Spline {
                points: vec![
                    SurfacePoint::new(0.0, f64::NAN),
                    SurfacePoint::new(0.1, 0.0)
                ],
                sample_m: None
            })
            .is_err()
        );
    }

    proptest! {
        /// The nearest point is really nearest: no sampled path point is closer, and the
        /// offset's magnitude is that distance.
        #[test]
        fn nearest_is_nearest(x in -0.2f64..0.2, z in -0.2f64..0.1, r in 0.08f64..0.3) {
            let p = arc(r, 0.26);
            let q = SurfacePoint::new(x, z);
            let n = p.nearest(q);
            let d = q.distance_to(&n.point);
            prop_assert!((n.offset_m.abs() - d).abs() < 1e-9);
            for s in (-100..=360).map(|i| i as f64 * 0.001) {
                let (c, _) = p.at(s);
                prop_assert!(q.distance_to(&c) >= d - 1e-9);
            }
        }
    }
}
