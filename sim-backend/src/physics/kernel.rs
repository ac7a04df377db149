//! The surface pressure kernel of a pulsing tube under a rigid flat contact, and its exact
//! integrals over rectangles.
//!
//! DESIGN.md section 5: a tube of inner radius `a` whose centre lies at depth `h`, with pulse
//! pressure `Δp`, gives on a rigid flat contact (2-D, `a << h`, from the half-space image
//! solution)
//!
//! ```text
//! p(u) = 2 Δp a² (h² − u²) / (u² + h²)²        u = lateral distance from the tube's axis
//! ```
//!
//! which is `2 Δp a² G'(u)` with `G(u) = u / (u² + h²)`, and `∫ G = ½ ln(u² + h²)`. So the
//! force on any rectangle crossed by a locally straight tube has a closed form in one
//! direction; the other is integrated by Gauss–Legendre (exactly in closed form too when the
//! rectangle is square to the tube, but the general crossing angle needs the mixed form to
//! stay finite as the tube turns parallel to a side). Its integral over the whole line is
//! zero: the net force is zero and the far field is negative, which is why elements beyond
//! `|u| = h` move out of phase.

/// `2 Δp a²`: the kernel's strength, N (Pa·m²).
pub fn strength_n(pressure_pa: f64, inner_radius_m: f64) -> f64 {
    2.0 * pressure_pa * inner_radius_m * inner_radius_m
}

/// The kernel per unit strength at lateral distance `u` for depth `h`, 1/m².
pub fn kernel(u: f64, h: f64) -> f64 {
    let d = u * u + h * h;
    (h * h - u * u) / (d * d)
}

/// Antiderivative of [`kernel`] in `u`, 1/m.
fn g(u: f64, h: f64) -> f64 {
    u / (u * u + h * h)
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

/// Integral of the unit-strength kernel over a rectangle, m⁰ (multiply by
/// [`strength_n`] for newtons).
///
/// The rectangle has half-widths `half_a` and `half_b` along two perpendicular axes; the
/// tube's signed distance from the rectangle's centre is `u0`, and moving `+1` along the
/// first (second) axis changes the distance by `ga` (`gb`), with `ga² + gb² = 1` (the unit
/// normal of the tube expressed in the rectangle's axes; the crossing angle lives here).
pub fn rectangle_integral(u0: f64, ga: f64, gb: f64, half_a: f64, half_b: f64, h: f64) -> f64 {
    integrate_over_rectangle(|u| g(u, h), u0, ga, gb, half_a, half_b)
}

/// Integral over a rectangle of any kernel that depends only on the signed distance `u` from
/// the tube, given its antiderivative in `u`; the arguments are those of
/// [`rectangle_integral`]. The analytic, applanation and FEM kernels all share it.
pub fn integrate_over_rectangle(
    antiderivative: impl Fn(f64) -> f64,
    u0: f64,
    ga: f64,
    gb: f64,
    half_a: f64,
    half_b: f64,
) -> f64 {
    // Integrate in closed form along the axis the distance changes fastest along; Gauss in
    // the other, where the integrand is smooth.
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
        let inner = (antiderivative(u + g_fast * half_fast)
            - antiderivative(u - g_fast * half_fast))
            / g_fast;
        sum += w * inner;
    }
    sum * half_slow
}

/// Force per Pa of lumen pressure on a rectangle (m², i.e. N/Pa) under a kernel computed by
/// the FEM (`pulsetrack_fem::kernel`), with the arguments of [`rectangle_integral`].
pub fn fem_rectangle_integral(
    k: &pulsetrack_fem::kernel::Kernel,
    u0: f64,
    ga: f64,
    gb: f64,
    half_a: f64,
    half_b: f64,
) -> f64 {
    integrate_over_rectangle(|u| k.antiderivative_m(u), u0, ga, gb, half_a, half_b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force midpoint integration over the rectangle.
    fn brute(u0: f64, ga: f64, gb: f64, ha: f64, hb: f64, h: f64) -> f64 {
        let n = 400;
        let mut s = 0.0;
        for i in 0..n {
            for j in 0..n {
                let a = -ha + (i as f64 + 0.5) * 2.0 * ha / n as f64;
                let b = -hb + (j as f64 + 0.5) * 2.0 * hb / n as f64;
                s += kernel(u0 + ga * a + gb * b, h);
            }
        }
        s * (2.0 * ha / n as f64) * (2.0 * hb / n as f64)
    }

    #[test]
    fn net_force_over_the_whole_line_is_zero() {
        // ∫ p du over ±L tends to zero as 1/L: the kernel has no net force.
        let h = 0.005;
        for l in [0.1, 1.0, 10.0] {
            let f = rectangle_integral(0.0, 1.0, 0.0, l, 0.5, h);
            assert!(f.abs() < 2.0 / l, "L = {l}: {f}");
        }
        let far = rectangle_integral(0.0, 1.0, 0.0, 1e4, 0.5, h);
        assert!(far.abs() < 1e-3);
        // The positive middle is balanced by the negative flanks.
        let middle = rectangle_integral(0.0, 1.0, 0.0, h, 0.5, h);
        let flanks = far - middle;
        assert!(middle > 0.0 && flanks < 0.0);
        assert!((middle + flanks).abs() < 1e-3 * middle);
    }

    #[test]
    fn matches_brute_force_at_any_crossing_angle() {
        let h = 0.005;
        for deg in [90.0f64, 60.0, 30.0, 10.0, 1.0, 0.0] {
            let phi = deg.to_radians();
            let (ga, gb) = (phi.sin(), phi.cos());
            for u0 in [0.0, 0.001, 0.004, 0.009] {
                let exact = rectangle_integral(u0, ga, gb, 0.001, 0.001, h);
                let b = brute(u0, ga, gb, 0.001, 0.001, h);
                assert!(
                    (exact - b).abs() < 1e-4 * b.abs().max(1e-6) + 1e-12,
                    "{deg}° u0 {u0}: {exact} vs {b}"
                );
            }
        }
    }

    #[test]
    fn seed_tube_gives_about_six_centinewtons_on_a_centred_element() {
        // 5 mm OD, 1 mm wall -> a = 1.5 mm; 100 kPa; centre 5 mm deep; a 2 x 2 mm element
        // with the tube along one edge (centred between two elements).
        let s = strength_n(100e3, 0.0015);
        let f = s * rectangle_integral(0.001, 1.0, 0.0, 0.001, 0.001, 0.005);
        assert!((f - 0.062).abs() < 0.002, "{f}");
    }

    #[test]
    fn the_fem_kernels_rectangle_integral_matches_the_analytic_one_for_a_small_hole() {
        let (a, h) = (0.0005, 0.005);
        let k = pulsetrack_fem::kernel::compute(&pulsetrack_fem::kernel::KernelParams {
            tissue: pulsetrack_fem::material::Material::new(20e3, 0.45),
            lumen_radius_m: a,
            wall_thickness_m: 0.0,
            wall: pulsetrack_fem::material::Material::new(20e3, 0.45),
            centre_depth_m: h,
            refine: 0,
            backing_depth_m: None,
        })
        .unwrap();
        // A 2 x 2 mm element over the tube and one beyond |u| = h, square and at 45°.
        // The far lobe (beyond |u| = h) of the finite block is within 15% of the half-space's.
        for (u0, ga, gb, tol) in [
            (0.0, 1.0, 0.0, 0.05),
            (0.008, 1.0, 0.0, 0.15),
            (
                0.002,
                std::f64::consts::FRAC_1_SQRT_2,
                std::f64::consts::FRAC_1_SQRT_2,
                0.05,
            ),
        ] {
            let fem = fem_rectangle_integral(&k, u0, ga, gb, 0.001, 0.001);
            let exact = strength_n(1.0, a) * rectangle_integral(u0, ga, gb, 0.001, 0.001, h);
            assert!(
                (fem - exact).abs() < tol * exact.abs() + 1e-12,
                "u0 {u0}: fem {fem} analytic {exact}"
            );
        }
        // The antiderivative over the whole table is the net force (about zero).
        let end = *k.x_m.last().unwrap();
        assert!((k.antiderivative_m(end + 1.0) - k.net_force_m()).abs() < 1e-15);
    }
}
