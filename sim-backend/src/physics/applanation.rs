//! The surface pressure over an artery flattened against bone by the sensor (applanation).
//!
//! Over the wrist the radial artery lies on the radius. Pressed by the sensor, its top is
//! flattened against the bone; a flat wall carries no hoop tension, so over the flattened
//! width the lumen pressure acts on the tissue above it directly (the principle of
//! applanation tonometry: the contact pressure over the flattened part approaches the
//! arterial pressure). The flattened width of a tube whose outer radius is `r` is half its
//! circumference, `w = π r`. The pressure change `Δp` over that strip reaches the rigid sensor
//! through the tissue above the artery (the cover, `t = h − r`), spreading as a strip load
//! does through an elastic half-space (Flamant's solution integrated over the strip):
//!
//! ```text
//! p(u) = (Δp / π) [F(u + b) − F(u − b)],   F(v) = atan(v / t) + v t / (v² + t²),   b = w / 2
//! ```
//!
//! and `∫ F = v atan(v / t)`, so the force on a rectangle has a closed form across the
//! artery. Its integral over the line is `Δp w` (all of the strip's force reaches the sensor:
//! the bone under the artery takes the reaction), unlike the half-space kernel's zero; the
//! sensor body, held by a constant load, takes that net force back (physics::tactile). As
//! the cover thins, `p` tends to `Δp` over the flattened width and zero outside: ideal
//! applanation. The spreading uses the free-surface strip solution; a rigid sensor
//! concentrates the load a little more (docs/calibration.md compares it with the FEM).

use std::f64::consts::PI;

/// Half the flattened width of a tube of outer radius `outer_radius_m`, m.
pub fn half_width_m(outer_radius_m: f64) -> f64 {
    0.5 * PI * outer_radius_m
}

fn f(v: f64, t: f64) -> f64 {
    (v / t).atan() + v * t / (v * v + t * t)
}

/// Antiderivative of `f` in `v`.
fn g(v: f64, t: f64) -> f64 {
    v * (v / t).atan()
}

/// Surface pressure per pascal of lumen pressure at lateral distance `u` from the artery's
/// axis, for a flattened half-width `b` under a cover `t` (dimensionless).
pub fn pressure_per_pa(u: f64, b: f64, t: f64) -> f64 {
    (f(u + b, t) - f(u - b, t)) / PI
}

/// ∫ p du per pascal from −∞ to `u`, m (it rises from 0 to `2 b`).
fn cumulative(u: f64, b: f64, t: f64) -> f64 {
    // ∫ F(v) dv over [v0, v1] is g(v1) − g(v0). As u → −∞, g(u + b) − g(u − b) → −π b, so
    // adding π b makes the integral vanish there.
    (g(u + b, t) - g(u - b, t) + PI * b) / PI
}

/// Five-point Gauss–Legendre nodes and weights on [-1, 1].
const GL_NODES: [f64; 5] = [
    0.0,
    -0.538_469_310_105_683_1,
    0.538_469_310_105_683_1,
    -0.906_179_845_938_664,
    0.906_179_845_938_664,
];
const GL_WEIGHTS: [f64; 5] = [
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
    0.236_926_885_056_189_1,
];

/// Force per pascal of lumen pressure on a rectangle, m² (N/Pa), with the arguments of
/// `physics::kernel::rectangle_integral`: the artery's signed distance `u0` from the centre,
/// its unit normal (`ga`, `gb`) in the rectangle's axes, and the half-sizes.
pub fn rectangle_integral(
    u0: f64,
    ga: f64,
    gb: f64,
    half_a: f64,
    half_b: f64,
    b: f64,
    t: f64,
) -> f64 {
    let (g_fast, half_fast, g_slow, half_slow) = if ga.abs() >= gb.abs() {
        (ga, half_a, gb, half_b)
    } else {
        (gb, half_b, ga, half_a)
    };
    if g_fast.abs() < 1e-15 {
        return 0.0;
    }
    let mut sum = 0.0;
    for (x, w) in GL_NODES.iter().zip(GL_WEIGHTS) {
        let u = u0 + g_slow * x * half_slow;
        let hi = cumulative(u + g_fast * half_fast, b, t);
        let lo = cumulative(u - g_fast * half_fast, b, t);
        sum += w * (hi - lo) / g_fast;
    }
    sum * half_slow
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_of_the_strips_force_reaches_the_surface() {
        let (b, t) = (0.0025, 0.002);
        // Numerically: ∫ p du over a wide line equals the strip width.
        let n = 200_000;
        let l = 2.0;
        let du = 2.0 * l / n as f64;
        let s: f64 = (0..n)
            .map(|i| pressure_per_pa(-l + (i as f64 + 0.5) * du, b, t) * du)
            .sum();
        assert!((s - 2.0 * b).abs() < 1e-5, "{s}");
        // And the cumulative form runs from 0 to 2b.
        assert!(cumulative(-10.0, b, t).abs() < 1e-6);
        assert!((cumulative(10.0, b, t) - 2.0 * b).abs() < 1e-6);
        assert!((cumulative(0.0, b, t) - b).abs() < 1e-12);
    }

    #[test]
    fn a_thin_cover_gives_the_lumen_pressure_over_the_flattened_width() {
        let b = 0.0025;
        let t = 1e-6;
        assert!((pressure_per_pa(0.0, b, t) - 1.0).abs() < 1e-3);
        assert!((pressure_per_pa(0.002, b, t) - 1.0).abs() < 1e-3);
        assert!(pressure_per_pa(0.003, b, t).abs() < 1e-3);
        // Half at the edge.
        assert!((pressure_per_pa(b, b, t) - 0.5).abs() < 1e-3);
    }

    #[test]
    fn a_thicker_cover_spreads_and_lowers_the_peak() {
        let b = half_width_m(0.0016);
        let p = |t: f64| pressure_per_pa(0.0, b, t);
        // Flamant's strip at the centreline: (α + sin α)/π with α = 2 atan(b/t).
        for t in [0.0018, 0.0031] {
            let a = 2.0 * (b / t).atan();
            assert!((p(t) - (a + a.sin()) / PI).abs() < 1e-12);
        }
        assert!(p(0.0018) > p(0.0031) && p(0.0031) > 0.5);
        assert!(pressure_per_pa(0.006, b, 0.0031) > pressure_per_pa(0.006, b, 0.0018));
    }

    #[test]
    fn no_element_feels_more_than_the_lumen_pressure_times_its_area() {
        // The bound behind docs/calibration.md's radial-wrist result: however thin the cover
        // and wherever the artery crosses, the force per pascal on a 2 x 2 mm element stays
        // under its 4 mm², and reaches it only as the cover vanishes over a wide strip.
        let area = 4e-6;
        for r in [0.0011, 0.0016, 0.0019] {
            let b = half_width_m(r);
            for t in [1e-7, 1e-4, 0.0008, 0.0018, 0.0031, 0.006] {
                for u0 in [0.0, 0.0005, 0.001, 0.002, 0.004] {
                    for deg in [90.0f64, 60.0, 30.0] {
                        let phi = deg.to_radians();
                        let k = rectangle_integral(u0, phi.sin(), phi.cos(), 0.001, 0.001, b, t);
                        assert!(
                            k >= 0.0 && k <= area * (1.0 + 1e-9),
                            "{r} {t} {u0} {deg}: {k}"
                        );
                    }
                }
            }
        }
        let thin = rectangle_integral(0.0, 1.0, 0.0, 0.001, 0.001, half_width_m(0.0016), 1e-7);
        assert!((thin - area).abs() < 1e-3 * area, "{thin}");
    }

    #[test]
    fn rectangle_integral_matches_brute_force_at_any_crossing_angle() {
        let (b, t) = (0.0025, 0.0018);
        let brute = |u0: f64, ga: f64, gb: f64| {
            let n = 300;
            let h = 0.001;
            let mut s = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let a = -h + (i as f64 + 0.5) * 2.0 * h / n as f64;
                    let c = -h + (j as f64 + 0.5) * 2.0 * h / n as f64;
                    s += pressure_per_pa(u0 + ga * a + gb * c, b, t);
                }
            }
            s * (2.0 * h / n as f64).powi(2)
        };
        for deg in [90.0f64, 45.0, 10.0, 0.0] {
            let phi = deg.to_radians();
            let (ga, gb) = (phi.sin(), phi.cos());
            for u0 in [0.0, 0.002, 0.0035, 0.008] {
                let exact = rectangle_integral(u0, ga, gb, 0.001, 0.001, b, t);
                let bf = brute(u0, ga, gb);
                assert!(
                    (exact - bf).abs() < 2e-4 * bf.abs().max(1e-7),
                    "{deg} {u0}: {exact} vs {bf}"
                );
            }
        }
    }
}
