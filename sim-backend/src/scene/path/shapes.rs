//! The courses that are built from many short pieces: sinusoids and spirals (short arcs
//! whose headings are exact at their ends, so the course is smooth and its heading does not
//! drift), corner polylines with optional fillets, and the rigid move and reversal that
//! apply to any path.

use std::f64::consts::PI;

use control::frames::SurfacePoint;

use super::{CurvatureKnot, PathError, Piece, Turn};

/// Most pieces one shape may be built from (a bound on memory and build time).
const MAX_PIECES: usize = 200_000;

/// Default length of the short arcs of sinusoids and spirals, m.
pub(super) const DEFAULT_STEP_M: f64 = 0.001;

/// A turn below this over one piece is built as a straight segment: an arc of nearly zero
/// curvature would put its centre so far away that its points lose precision.
const STRAIGHT_BELOW_RAD: f64 = 1e-7;

fn bad<T>(message: String) -> Result<T, PathError> {
    Err(PathError::Invalid(message))
}

fn check_step(step: f64) -> Result<f64, PathError> {
    if step.is_finite() && step > 0.0 {
        Ok(step)
    } else {
        bad(format!("step_m must be positive, got {step}"))
    }
}

/// Pieces from `start` through `(heading at start, heading at end, length)` triples: each an
/// arc turning exactly between the two headings (a straight segment at their mean when the
/// turn is negligible). The next piece starts where this one ends, at its own exact heading.
fn exact_heading_chain(start: [f64; 2], parts: &[(f64, f64, f64)]) -> Vec<Piece> {
    let mut pieces = Vec::with_capacity(parts.len());
    let mut p = start;
    for &(h0, h1, length) in parts {
        let turned = h1 - h0;
        let piece = if turned.abs() < STRAIGHT_BELOW_RAD {
            Piece::Line {
                start: p,
                heading: 0.5 * (h0 + h1),
                length,
            }
        } else {
            let curvature = turned / length;
            let radius = 1.0 / curvature.abs();
            let turn = curvature.signum();
            let normal = [-h0.sin(), h0.cos()];
            let centre = [
                p[0] + turn * radius * normal[0],
                p[1] + turn * radius * normal[1],
            ];
            Piece::Arc {
                centre,
                radius,
                start_angle: (p[1] - centre[1]).atan2(p[0] - centre[0]),
                heading: h0,
                turn,
                length,
            }
        };
        p = piece.at(length).0;
        pieces.push(piece);
    }
    pieces
}

fn start_ok(start: SurfacePoint, heading: f64, length: f64) -> Result<(), PathError> {
    if !(start.is_finite() && heading.is_finite()) {
        return bad("the start point and heading must be finite".into());
    }
    if !(length.is_finite() && length > 0.0) {
        return bad(format!("length_m must be positive, got {length}"));
    }
    Ok(())
}

/// The sinusoid of [`super::PathSpec::Sinusoid`].
#[allow(clippy::too_many_arguments)]
pub(super) fn sinusoid(
    start: SurfacePoint,
    heading: f64,
    amplitude: f64,
    wavelength: f64,
    length: f64,
    phase: f64,
    step: f64,
) -> Result<Vec<Piece>, PathError> {
    start_ok(start, heading, length)?;
    let step = check_step(step)?;
    if !(amplitude.is_finite() && amplitude >= 0.0) {
        return bad(format!("amplitude_m must not be negative, got {amplitude}"));
    }
    if !(wavelength.is_finite() && wavelength > 0.0) {
        return bad(format!("wavelength_m must be positive, got {wavelength}"));
    }
    if !phase.is_finite() {
        return bad("phase_rad must be finite".into());
    }
    let k = 2.0 * PI / wavelength;
    let slope_max = amplitude * k;
    // Equal steps along the axis, short enough that no piece is longer than `step`.
    let du = step / (1.0 + slope_max * slope_max).sqrt();
    if length / du > MAX_PIECES as f64 {
        return bad(format!(
            "a sinusoid of {length} m in steps of {step} m needs more than {MAX_PIECES} pieces"
        ));
    }
    let slope = |u: f64| slope_max * (k * u + phase).cos();
    let heading_at = |u: f64| heading + slope(u).atan();
    let speed = |u: f64| (1.0 + slope(u).powi(2)).sqrt();
    let mut parts = Vec::new();
    let (mut u, mut s) = (0.0, 0.0);
    while s < length {
        let ds = du / 6.0 * (speed(u) + 4.0 * speed(u + du / 2.0) + speed(u + du));
        let (h0, h1) = (heading_at(u), heading_at(u + du));
        if s + ds >= length {
            // The last piece keeps its curvature and stops at the requested length.
            let rest = length - s;
            parts.push((h0, h0 + (h1 - h0) * rest / ds, rest));
            break;
        }
        parts.push((h0, h1, ds));
        s += ds;
        u += du;
    }
    Ok(exact_heading_chain([start.x_m, start.z_m], &parts))
}

/// The spiral of [`super::PathSpec::Spiral`].
#[allow(clippy::too_many_arguments)]
pub(super) fn spiral(
    start: SurfacePoint,
    heading: f64,
    start_radius: f64,
    end_radius: f64,
    length: f64,
    turn: Turn,
    step: f64,
) -> Result<Vec<Piece>, PathError> {
    start_ok(start, heading, length)?;
    let step = check_step(step)?;
    if !(start_radius.is_finite()
        && start_radius > 0.0
        && end_radius.is_finite()
        && end_radius > 0.0)
    {
        return bad(format!(
            "spiral radii must be positive, got {start_radius} and {end_radius}"
        ));
    }
    let n = (length / step).ceil();
    if n > MAX_PIECES as f64 {
        return bad(format!(
            "a spiral of {length} m in steps of {step} m needs more than {MAX_PIECES} pieces"
        ));
    }
    let n = (n as usize).max(1);
    let h = length / n as f64;
    let rate = (end_radius - start_radius) / length;
    // Heading turned after arc length s: the integral of 1 / r(s).
    let turned = |s: f64| {
        if rate.abs() < 1e-12 {
            s / start_radius
        } else {
            ((start_radius + rate * s) / start_radius).ln() / rate
        }
    };
    let sign = turn.sign();
    let parts: Vec<(f64, f64, f64)> = (0..n)
        .map(|i| {
            let (a, b) = (i as f64 * h, (i + 1) as f64 * h);
            (heading + sign * turned(a), heading + sign * turned(b), h)
        })
        .collect();
    Ok(exact_heading_chain([start.x_m, start.z_m], &parts))
}

/// The clothoid spline of [`super::PathSpec::Clothoid`].
pub(super) fn clothoid(
    start: SurfacePoint,
    heading: f64,
    knots: &[CurvatureKnot],
    step: f64,
) -> Result<Vec<Piece>, PathError> {
    if !(start.is_finite() && heading.is_finite()) {
        return bad("the start point and heading must be finite".into());
    }
    let step = check_step(step)?;
    if knots.len() < 2 {
        return bad(format!(
            "a clothoid needs at least two knots, got {}",
            knots.len()
        ));
    }
    if knots[0].s_m != 0.0 {
        return bad(format!("knots[0].s_m must be 0, got {}", knots[0].s_m));
    }
    for (i, k) in knots.iter().enumerate() {
        if !(k.s_m.is_finite() && k.curvature_per_m.is_finite()) {
            return bad(format!("knots[{i}] is not finite"));
        }
        if i > 0 && k.s_m <= knots[i - 1].s_m {
            return bad(format!(
                "knots[{i}].s_m ({}) must exceed knots[{}].s_m ({})",
                k.s_m,
                i - 1,
                knots[i - 1].s_m
            ));
        }
    }
    let length = knots[knots.len() - 1].s_m;
    if length / step > MAX_PIECES as f64 {
        return bad(format!(
            "a clothoid of {length} m in steps of {step} m needs more than {MAX_PIECES} pieces"
        ));
    }
    let mut parts = Vec::new();
    let mut h = heading;
    for w in knots.windows(2) {
        let (a, b) = (w[0], w[1]);
        let span = b.s_m - a.s_m;
        let n = ((span / step).ceil() as usize).max(1);
        let rate = (b.curvature_per_m - a.curvature_per_m) / span;
        // Heading turned from the knot `a` after `x` along: the integral of the curvature.
        let turned = |x: f64| a.curvature_per_m * x + 0.5 * rate * x * x;
        let h_a = h;
        for i in 0..n {
            let (x0, x1) = (span * i as f64 / n as f64, span * (i + 1) as f64 / n as f64);
            parts.push((h_a + turned(x0), h_a + turned(x1), x1 - x0));
        }
        h = h_a + turned(span);
    }
    Ok(exact_heading_chain([start.x_m, start.z_m], &parts))
}

/// The corner course of [`super::PathSpec::Corners`].
pub(super) fn corners(
    start: SurfacePoint,
    heading: f64,
    legs: &[f64],
    bends: &[f64],
    fillet: f64,
) -> Result<Vec<Piece>, PathError> {
    if !(start.is_finite() && heading.is_finite()) {
        return bad("the start point and heading must be finite".into());
    }
    if legs.is_empty() {
        return bad("corners need at least one leg".into());
    }
    if bends.len() + 1 != legs.len() {
        return bad(format!(
            "{} legs need {} bends between them, got {}",
            legs.len(),
            legs.len() - 1,
            bends.len()
        ));
    }
    if let Some(i) = legs.iter().position(|l| !(l.is_finite() && *l > 0.0)) {
        return bad(format!("legs_m[{i}] must be positive, got {}", legs[i]));
    }
    if let Some(i) = bends.iter().position(|b| !(b.is_finite() && b.abs() < PI)) {
        return bad(format!(
            "bends_rad[{i}] must lie strictly between -180° and 180°, got {}",
            bends[i]
        ));
    }
    if !(fillet.is_finite() && fillet >= 0.0) {
        return bad(format!(
            "fillet_radius_m must not be negative, got {fillet}"
        ));
    }
    // How much of each adjacent leg a corner's fillet takes.
    let cut: Vec<f64> = bends
        .iter()
        .map(|b| fillet * (b.abs() / 2.0).tan())
        .collect();
    let mut pieces = Vec::with_capacity(2 * legs.len());
    let mut p = [start.x_m, start.z_m];
    let mut h = heading;
    for (i, &leg) in legs.iter().enumerate() {
        let before = if i > 0 { cut[i - 1] } else { 0.0 };
        let after = cut.get(i).copied().unwrap_or(0.0);
        let straight = leg - before - after;
        if straight < -1e-12 {
            return bad(format!(
                "legs_m[{i}] ({leg} m) is shorter than its corners' fillets take ({:.4} m)",
                before + after
            ));
        }
        if straight > 1e-12 {
            let line = Piece::Line {
                start: p,
                heading: h,
                length: straight,
            };
            p = line.at(straight).0;
            pieces.push(line);
        }
        if let Some(&bend) = bends.get(i) {
            if fillet > 0.0 && bend != 0.0 {
                let arc = exact_heading_chain(p, &[(h, h + bend, fillet * bend.abs())]);
                for a in arc {
                    p = a.at(a.length()).0;
                    pieces.push(a);
                }
            }
            h += bend;
        }
    }
    Ok(pieces)
}

/// `pieces` rotated by `rotation` about the origin, then shifted by `translation`, and
/// travelled backward with `reverse`.
pub(super) fn transformed(
    pieces: Vec<Piece>,
    rotation: f64,
    translation: SurfacePoint,
    reverse: bool,
) -> Result<Vec<Piece>, PathError> {
    if !(rotation.is_finite() && translation.is_finite()) {
        return bad("rotation_rad and translation must be finite".into());
    }
    let (sin, cos) = rotation.sin_cos();
    let mv = |q: [f64; 2]| {
        [
            cos * q[0] - sin * q[1] + translation.x_m,
            sin * q[0] + cos * q[1] + translation.z_m,
        ]
    };
    let moved = pieces.into_iter().map(|piece| match piece {
        Piece::Line {
            start,
            heading,
            length,
        } => Piece::Line {
            start: mv(start),
            heading: heading + rotation,
            length,
        },
        Piece::Arc {
            centre,
            radius,
            start_angle,
            heading,
            turn,
            length,
        } => Piece::Arc {
            centre: mv(centre),
            radius,
            start_angle: start_angle + rotation,
            heading: heading + rotation,
            turn,
            length,
        },
    });
    if !reverse {
        return Ok(moved.collect());
    }
    let mut out: Vec<Piece> = moved.map(reversed).collect();
    out.reverse();
    Ok(out)
}

/// The same piece travelled from its end to its start.
fn reversed(piece: Piece) -> Piece {
    match piece {
        Piece::Line {
            start,
            heading,
            length,
        } => Piece::Line {
            start: Piece::Line {
                start,
                heading,
                length,
            }
            .at(length)
            .0,
            heading: heading + PI,
            length,
        },
        Piece::Arc {
            centre,
            radius,
            start_angle,
            heading,
            turn,
            length,
        } => {
            let swept = turn * length / radius;
            Piece::Arc {
                centre,
                radius,
                start_angle: start_angle + swept,
                heading: heading + swept + PI,
                turn: -turn,
                length,
            }
        }
    }
}
