//! Drawing one course of a family in its own frame (starting at the origin, heading along
//! `+x`); the draw then turns it to a start heading and centres it in the workspace.

use std::f64::consts::TAU;

use control::frames::SurfacePoint;
use rand::Rng;
use rand::rngs::ChaCha8Rng;

use super::{CountInterval, CourseFamily, Interval};
use crate::random::uniform_open;
use crate::scene::{CurvatureKnot, PathSpec, Turn};

impl Interval {
    /// A uniform draw from the range.
    pub fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        self.0 + (self.1 - self.0) * uniform_open(rng)
    }
}

impl CountInterval {
    /// A uniform draw from the counts, both ends included.
    pub fn draw(&self, rng: &mut ChaCha8Rng) -> u32 {
        let span = u64::from(self.1.saturating_sub(self.0)) + 1;
        // The modulo's bias is below 1e-17 for spans this small.
        self.0 + (rng.next_u64() % span) as u32
    }
}

fn coin(rng: &mut ChaCha8Rng) -> bool {
    uniform_open(rng) < 0.5
}

fn turn(rng: &mut ChaCha8Rng) -> Turn {
    if coin(rng) { Turn::Left } else { Turn::Right }
}

/// Where a drawn course begins and how its tracked part lies along it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Layout {
    /// The whole course's length, m.
    pub length_m: f64,
    /// Arc length of the first placement (where tracking starts), m.
    pub track_from_m: f64,
    /// The tracked length, m.
    pub track_m: f64,
    /// The largest heading from the course's own start heading the steering aims for, rad.
    pub heading_bound_rad: f64,
}

/// One course of `kind` in its own frame.
pub(super) fn draw_local(kind: &CourseFamily, layout: Layout, rng: &mut ChaCha8Rng) -> PathSpec {
    let origin = SurfacePoint::new(0.0, 0.0);
    let length = layout.length_m;
    match kind {
        CourseFamily::Smooth {
            max_curvature_per_m,
            max_curvature_rate_per_m2,
            knot_spacing_m,
        } => PathSpec::Clothoid {
            start: origin,
            heading_rad: 0.0,
            knots: smooth_knots(
                *max_curvature_per_m,
                *max_curvature_rate_per_m2,
                knot_spacing_m,
                layout,
                rng,
            ),
            step_m: None,
        },
        CourseFamily::Sinusoid {
            amplitude_m,
            wavelength_m,
        } => PathSpec::Sinusoid {
            start: origin,
            heading_rad: 0.0,
            amplitude_m: amplitude_m.draw(rng),
            wavelength_m: wavelength_m.draw(rng),
            length_m: length,
            phase_rad: TAU * uniform_open(rng),
            step_m: None,
        },
        CourseFamily::Spiral {
            start_radius_m,
            end_radius_m,
        } => {
            let (a, b) = (start_radius_m.draw(rng), end_radius_m.draw(rng));
            PathSpec::Spiral {
                start: origin,
                heading_rad: 0.0,
                // Shrinking, whichever range gave the larger.
                start_radius_m: a.max(b),
                end_radius_m: a.min(b),
                length_m: length,
                turn: turn(rng),
                step_m: None,
            }
        }
        CourseFamily::SCurve { radius_m } => PathSpec::SCurve {
            radius_m: radius_m.draw(rng),
            length_m: length,
            turn: turn(rng),
        },
        CourseFamily::Arc { radius_m } => PathSpec::Arc {
            radius_m: radius_m.draw(rng),
            length_m: length,
            chord_centre: origin,
            turn: turn(rng),
        },
        CourseFamily::Corners {
            bends,
            bend_rad,
            fillet_radius_m,
            min_leg_m,
        } => {
            let (legs_m, bends_rad) = corner_legs(*bends, bend_rad, *min_leg_m, layout, rng);
            PathSpec::Corners {
                start: origin,
                heading_rad: 0.0,
                legs_m,
                bends_rad,
                fillet_radius_m: fillet_radius_m.map_or(0.0, |f| f.draw(rng)),
            }
        }
    }
}

/// Knots of a random clothoid spline: each knot's curvature is drawn uniformly from what
/// the curvature bound, the curvature-rate bound and the heading bound all allow (when the
/// last two conflict, the rate bound wins and the heading is brought back as fast as it
/// allows).
fn smooth_knots(
    max_curvature: f64,
    max_rate: f64,
    spacing: &Interval,
    layout: Layout,
    rng: &mut ChaCha8Rng,
) -> Vec<CurvatureKnot> {
    let bound = 0.7 * layout.heading_bound_rad;
    let mut knots = vec![CurvatureKnot {
        s_m: 0.0,
        curvature_per_m: max_curvature * (2.0 * uniform_open(rng) - 1.0) * 0.5,
    }];
    let mut heading = 0.0;
    loop {
        let last = knots[knots.len() - 1];
        let rest = layout.length_m - last.s_m;
        if rest <= 1e-9 {
            break;
        }
        let mut step = spacing.draw(rng).max(1e-3);
        if rest < 1.5 * step {
            step = rest;
        }
        let k0 = last.curvature_per_m;
        let rate_lo = (k0 - max_rate * step).max(-max_curvature);
        let rate_hi = (k0 + max_rate * step).min(max_curvature);
        // Heading after the step: heading + step (k0 + k) / 2, kept within ±bound.
        let head_lo = 2.0 * (-bound - heading) / step - k0;
        let head_hi = 2.0 * (bound - heading) / step - k0;
        let (lo, hi) = (rate_lo.max(head_lo), rate_hi.min(head_hi));
        let k = if lo <= hi {
            lo + (hi - lo) * uniform_open(rng)
        } else if head_hi < rate_lo {
            rate_lo
        } else {
            rate_hi
        };
        heading += step * (k0 + k) / 2.0;
        knots.push(CurvatureKnot {
            s_m: if step == rest {
                layout.length_m
            } else {
                last.s_m + step
            },
            curvature_per_m: k,
        });
    }
    knots
}

/// Legs and bends of a corner course: the corners lie on the tracked part, at least
/// `min_leg` after the first placement, from each other and before the course's end; each
/// bend turns to the side that keeps the heading within the bound when the drawn side
/// would not.
fn corner_legs(
    count: CountInterval,
    bend: &Interval,
    min_leg: f64,
    layout: Layout,
    rng: &mut ChaCha8Rng,
) -> (Vec<f64>, Vec<f64>) {
    let first = layout.track_from_m + min_leg;
    let last = (layout.track_from_m + layout.track_m).min(layout.length_m - min_leg);
    let wanted = count.draw(rng) as usize;
    // As many corners as fit `min_leg` apart.
    let fit = if last >= first {
        ((last - first) / min_leg).floor() as usize + 1
    } else {
        0
    };
    let n = wanted.min(fit);
    let slack = if n > 0 {
        last - first - (n - 1) as f64 * min_leg
    } else {
        0.0
    };
    let mut offsets: Vec<f64> = (0..n).map(|_| slack * uniform_open(rng)).collect();
    offsets.sort_by(f64::total_cmp);
    let corners: Vec<f64> = offsets
        .iter()
        .enumerate()
        .map(|(i, o)| first + o + i as f64 * min_leg)
        .collect();
    let mut legs = Vec::with_capacity(n + 1);
    let mut at = 0.0;
    for &c in &corners {
        legs.push(c - at);
        at = c;
    }
    legs.push(layout.length_m - at);
    let mut heading = 0.0;
    let bound = layout.heading_bound_rad;
    let bends = (0..n)
        .map(|_| {
            let size = bend.draw(rng);
            let mut b = if coin(rng) { size } else { -size };
            if (heading + b).abs() > bound && (heading - b).abs() < (heading + b).abs() {
                b = -b;
            }
            heading += b;
            b
        })
        .collect();
    (legs, bends)
}
