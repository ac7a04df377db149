//! Solve one of the shipped models (`config/fem/*.ron`) through the library alone and print,
//! per output time, the peak top-edge von Mises and where it is, against seed 001's Table 1
//! for its artery models: the smallest use of the crate without the CLI.
//!
//! `cargo run --release -p pulsetrack-fem --example shipped_model -- [NAME] [EXTRA_REFINE]`
//! (default `seed-001-healthy-artery.ron`, 0)

use pulsetrack_fem::run::run_model;
use pulsetrack_fem::study::{SHIPPED, TABLE1_HEALTHY_PA, TABLE1_STENOTIC_PA, shipped};

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let name = args
        .next()
        .unwrap_or_else(|| "seed-001-healthy-artery.ron".into());
    let refine: u32 = match args.next() {
        Some(s) => s.parse().map_err(|e| format!("EXTRA_REFINE {s:?}: {e}"))?,
        None => 0,
    };
    let model = shipped(&name).map_err(|e| {
        let names: Vec<&str> = SHIPPED.iter().map(|(n, _)| *n).collect();
        format!("{e} (shipped: {})", names.join(", "))
    })?;
    let run = run_model(&model, refine).map_err(|e| e.to_string())?;
    let table = match name.as_str() {
        "seed-001-healthy-artery.ron" => Some(TABLE1_HEALTHY_PA),
        "seed-001-stenotic-artery.ron" => Some(TABLE1_STENOTIC_PA),
        _ => None,
    };
    println!("{}: {} DOFs, {:.2} s", run.name, run.dofs, run.wall_s);
    println!("t (s)   peak von Mises (Pa)   at x (mm)   paper (Pa)");
    for (i, t) in run.times.iter().enumerate() {
        let paper = table
            .and_then(|p| p.get(i).copied())
            .map_or("-".to_string(), |p| format!("{p:.0}"));
        println!(
            "{:<7.3} {:<21.1} {:<11.3} {paper}",
            t.t_s,
            t.summary.peak,
            t.summary.x_peak * 1e3
        );
    }
    Ok(())
}
