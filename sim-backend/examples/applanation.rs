//! How much of a pulse reaches a 2 x 2 mm element over the radial artery, by model: the
//! half-space kernel, the FEM with the radius bone as a rigid backing (a round wall, and a
//! wall flattened so it carries no hoop tension), and the applanated artery of
//! `physics::applanation`; the applanation limit as the cover thins; and the seed's tube in
//! a foam sheet lying on a table. Forces are before the sensor body's rigid take-back (the
//! simulator's `element_swing` example gives them after it).
//!
//! `cargo run --release -p pulsetrack-sim --example applanation`

use pulsetrack_fem::kernel::{KernelParams, compute};
use pulsetrack_fem::material::Material;
use pulsetrack_sim::physics::{applanation, kernel};

/// 120/80 mmHg: the pulse pressure, Pa.
const PULSE_PA: f64 = 5333.0;
/// Half the element's side, m.
const HALF: f64 = 0.001;

fn fem_element(p: &KernelParams) -> Result<(f64, f64), String> {
    let k = compute(p).map_err(|e| e.to_string())?;
    Ok((
        k.at(0.0),
        kernel::fem_rectangle_integral(&k, 0.0, 1.0, 0.0, HALF, HALF),
    ))
}

fn main() -> Result<(), String> {
    let skin = Material::new(50e3, 0.49);
    let (lumen, wall) = (0.0013, 0.0003);
    let outer = lumen + wall;
    println!("radial artery: lumen 2.6 mm, wall 0.3 mm, bone 1 mm below it; 40 mmHg pulse;");
    println!("p(0) per Pa of pulse, and the force on a 2 x 2 mm element centred over it (mN)");
    println!(
        "{:<44} {:>8} {:>8} {:>8} {:>8}",
        "model", "h 3.4 mm", "mN", "h 4.7 mm", "mN"
    );
    let mut rows: Vec<(String, [f64; 4])> = Vec::new();
    let mut row = |name: &str, f: &dyn Fn(f64) -> Result<(f64, f64), String>| {
        let mut v = [0.0; 4];
        for (k, h) in [0.0034, 0.0047].into_iter().enumerate() {
            match f(h) {
                Ok((p0, e)) => {
                    v[2 * k] = p0;
                    v[2 * k + 1] = e * PULSE_PA * 1e3;
                }
                Err(e) => return println!("{name}: {e}"),
            }
        }
        println!(
            "{name:<44} {:>8.3} {:>8.1} {:>8.3} {:>8.1}",
            v[0], v[1], v[2], v[3]
        );
        rows.push((name.to_string(), v));
    };
    row("half-space (DESIGN.md section 5)", &|h| {
        Ok((
            kernel::strength_n(1.0, lumen) * kernel::kernel(0.0, h),
            kernel::strength_n(1.0, lumen)
                * kernel::rectangle_integral(0.0, 1.0, 0.0, HALF, HALF, h),
        ))
    });
    row("FEM, round 400 kPa wall, on bone", &|h| {
        fem_element(&KernelParams {
            tissue: skin,
            lumen_radius_m: lumen,
            wall_thickness_m: wall,
            wall: Material::new(400e3, 0.49),
            centre_depth_m: h,
            refine: 0,
            backing_depth_m: Some(h + outer + 0.001),
        })
    });
    row("FEM, wall flattened (round lumen), on bone", &|h| {
        fem_element(&KernelParams {
            tissue: skin,
            lumen_radius_m: outer,
            wall_thickness_m: 0.0,
            wall: skin,
            centre_depth_m: h,
            refine: 0,
            backing_depth_m: Some(h + outer + 0.001),
        })
    });
    row("applanated (flat over pi r, strip spreading)", &|h| {
        let (b, t) = (applanation::half_width_m(outer), h - outer);
        Ok((
            applanation::pressure_per_pa(0.0, b, t),
            applanation::rectangle_integral(0.0, 1.0, 0.0, HALF, HALF, b, t),
        ))
    });
    println!(
        "{:<44} {:>8.3} {:>8.1} {:>8.3} {:>8.1}",
        "upper bound: the whole pulse on the element",
        1.0,
        4.0 * HALF * HALF * PULSE_PA * 1e3,
        1.0,
        4.0 * HALF * HALF * PULSE_PA * 1e3
    );
    println!("seed2002's test needs a peak - off-peak contrast above 2 sigma = 24 mN");

    println!();
    println!("the applanation limit: p(0) per Pa as the cover over the flattened artery thins");
    let b = applanation::half_width_m(outer);
    for cover in [0.004, 0.002, 0.001, 0.0005, 0.0001] {
        println!(
            "  cover {:>4.1} mm: {:.3}",
            cover * 1e3,
            applanation::pressure_per_pa(0.0, b, cover)
        );
    }

    println!();
    println!(
        "the seed's tube (a 1.5 mm hole, 5 mm deep) in a foam sheet (20 kPa, nu 0.45) on a table:"
    );
    println!(
        "  {:<22} {:>8} {:>10} {:>10}",
        "sheet", "p(0)", "elem mN", "net/|p|"
    );
    let foam = Material::new(20e3, 0.45);
    for sheet in [Some(0.010), Some(0.015), Some(0.025), None] {
        let p = KernelParams {
            tissue: foam,
            lumen_radius_m: 0.0015,
            wall_thickness_m: 0.0,
            wall: foam,
            centre_depth_m: 0.005,
            refine: 0,
            backing_depth_m: sheet,
        };
        let k = compute(&p).map_err(|e| e.to_string())?;
        println!(
            "  {:<22} {:>8.4} {:>10.1} {:>10.3}",
            sheet.map_or("no table (half-space)".to_string(), |s| format!(
                "{:.0} mm",
                s * 1e3
            )),
            k.at(0.0),
            kernel::fem_rectangle_integral(&k, 0.001, 1.0, 0.0, HALF, HALF) * 100e3 * 1e3,
            k.net_force_m() / k.total_magnitude_m()
        );
    }
    Ok(())
}
