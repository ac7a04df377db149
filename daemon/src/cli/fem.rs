//! `pulsetrack fem`: run the seed FEM studies or one model file; print a summary, JSON
//! records, and plots like the papers' figures.

use crate::cli::progress::Progress;
use crate::cli::stdout::outln;

use std::time::Duration;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use pulsetrack_fem::model::{Kinematics, ModelFile};
use pulsetrack_fem::run::{ModelRun, Record, run_model};
use pulsetrack_fem::study::{
    Seed001, Seed002, StudyOptions, TABLE1_HEALTHY_PA, TABLE1_STENOTIC_PA, TABLE1_TIMES_S,
    seed_001_image_with, seed_001_with, seed_002_with,
};

use crate::plot::{Chart, Heatmap, HeatmapFigure, Mark, Series, write_chart, write_heatmaps};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StudyName {
    #[value(name = "seed-001")]
    Seed001,
    #[value(name = "seed-002")]
    Seed002,
}

#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("what").required(true).args(["study", "model", "kernel_table"])))]
pub struct Args {
    /// Run a paper's study: seed-001 (Table 1) or seed-002 (sweeps and tip shapes).
    #[arg(long, value_enum)]
    pub study: Option<StudyName>,
    /// Run one model described in RON (see config/fem/).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Solve the model on this Gmsh mesh (MSH 4.1, ASCII or binary; physical groups named
    /// for the model's materials and "top", "bottom", "lumen") instead of the built-in
    /// mesher's or the model's `mesh_file` (docs/fem.md, Gmsh meshes).
    #[arg(long, value_name = "FILE.msh", conflicts_with_all = ["study", "kernel_table"])]
    pub mesh: Option<PathBuf>,
    /// Print one JSON array of records (model, t_s, x_m, von_mises_pa, peak_pa, x_peak_m,
    /// von_mises_x0_pa, dofs, wall_s) instead of the text summary.
    #[arg(long)]
    pub json: bool,
    /// Write PNG and SVG plots into this directory.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Extra mesh refinement levels (each halves the element size).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=4))]
    pub refine: u32,
    /// Solve the platen models in finite strain (compressible neo-Hookean) instead of linear.
    #[arg(long)]
    pub finite_strain: bool,
    /// Compare the FEM surface-pressure kernel with the analytic one for small tubes and the
    /// seed's 5 mm latex tube (docs/fem.md).
    #[arg(long)]
    pub kernel_table: bool,
}

pub fn run(args: &Args) -> ExitCode {
    match execute(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => crate::cli::failure::failed("fem", args.json, &e),
    }
}

fn execute(args: &Args) -> Result<(), String> {
    let opts = StudyOptions {
        refine: args.refine,
        finite_strain: args.finite_strain,
    };
    if args.kernel_table {
        return kernel_table(args.refine);
    }
    if let Some(path) = &args.model {
        let loaded = config::load_file::<ModelFile>(path).map_err(|e| e.to_string())?;
        let mut model = loaded.value;
        model.resolve_mesh_file(loaded.dir.as_deref());
        if let Some(mesh) = &args.mesh {
            model.mesh_file = Some(mesh.clone());
        }
        if args.finite_strain && model.kinematics == Kinematics::Linear {
            model.kinematics = Kinematics::FiniteStrain { steps: 8 };
        }
        let solving = spinner(&format!("solving {}", path.display()));
        let run = run_model(&model, args.refine).map_err(|e| e.to_string())?;
        solving.finish();
        let runs = vec![run];
        emit(args, &runs, || print_runs(&runs))?;
        if let Some(dir) = &args.plot {
            plot_runs(dir, &runs)?;
        }
        return Ok(());
    }
    match args.study {
        Some(StudyName::Seed001) => {
            let solving = models("seed-001: models solved", Some(4));
            let s = seed_001_with(&opts, &|name| solving.step(name)).map_err(|e| e.to_string())?;
            solving.finish();
            emit(args, &s.runs, || print_seed_001(&s, &opts))?;
            if let Some(dir) = &args.plot {
                plot_seed_001(dir, &s)?;
                let solving = models("seed-001 tactile image: models solved", Some(4));
                let image = seed_001_image_with(&opts, IMAGE_SAMPLES, &|name| solving.step(name))
                    .map_err(|e| e.to_string())?;
                solving.finish();
                plot_tactile_image(dir, &image)?;
            }
        }
        Some(StudyName::Seed002) => {
            // Base models, four sweeps and the tip shapes: counted as they end.
            let solving = models("seed-002: models solved", None);
            let s = seed_002_with(&opts, &|name| solving.step(name)).map_err(|e| e.to_string())?;
            solving.finish();
            let mut all: Vec<ModelRun> = s.base.clone();
            for sw in &s.sweeps {
                all.extend(sw.points.iter().map(|p| p.run.clone()));
            }
            all.extend(s.tips.iter().cloned());
            emit(args, &all, || print_seed_002(&s))?;
            if let Some(dir) = &args.plot {
                plot_seed_002(dir, &s)?;
            }
        }
        None => return Err("give --study or --model".into()),
    }
    Ok(())
}

/// A spinner with the elapsed time on a terminal, else a line now and one every 10 s:
/// the study's solves report no steps of their own.
/// A count of models solved (each named as it ends), with a heartbeat between them.
fn models(what: &str, total: Option<u64>) -> Progress {
    let p = Progress::new(what, total);
    p.heartbeat(Duration::from_secs(10));
    p
}

fn spinner(what: &str) -> Progress {
    let p = Progress::new("fem", None);
    p.status(what);
    p.heartbeat(Duration::from_secs(10));
    p
}

fn emit(args: &Args, runs: &[ModelRun], text: impl FnOnce()) -> Result<(), String> {
    if args.json {
        let records: Vec<Record> = runs.iter().flat_map(|r| r.records()).collect();
        let s = serde_json::to_string(&records).map_err(|e| e.to_string())?;
        outln!("{s}");
    } else {
        text();
    }
    Ok(())
}

fn kpa(v: f64) -> f64 {
    v * 1e-3
}

fn print_runs(runs: &[ModelRun]) {
    outln!(
        "{:<24} {:>7} {:>10} {:>10} {:>12} {:>9} {:>8}",
        "model",
        "t (s)",
        "peak kPa",
        "x_peak mm",
        "vm(x=0) kPa",
        "dofs",
        "wall s"
    );
    for r in runs {
        for t in &r.times {
            outln!(
                "{:<24} {:>7.3} {:>10.3} {:>10.2} {:>12.3} {:>9} {:>8.3}",
                r.name,
                t.t_s,
                kpa(t.summary.peak),
                t.summary.x_peak * 1e3,
                kpa(t.summary.at_x0),
                r.dofs,
                r.wall_s
            );
        }
    }
}

fn print_seed_001(s: &Seed001, o: &StudyOptions) {
    print_runs(&s.runs);
    let kind = if o.finite_strain {
        "finite strain (neo-Hookean)"
    } else {
        "linear"
    };
    outln!("\nTable 1 of paper 001 (peak top von Mises, kPa) against this model ({kind}):");
    outln!(
        "{:<18} {:>7} {:>9} {:>9} {:>8}",
        "model",
        "t (s)",
        "paper",
        "ours",
        "ours/paper"
    );
    for (name, paper) in [
        ("healthy-artery", TABLE1_HEALTHY_PA),
        ("stenotic-artery", TABLE1_STENOTIC_PA),
    ] {
        if let Some(ours) = s.peaks(name) {
            for ((t, p), v) in TABLE1_TIMES_S.iter().zip(paper).zip(ours) {
                outln!(
                    "{:<18} {:>7.3} {:>9.3} {:>9.3} {:>8.3}",
                    name,
                    t,
                    kpa(p),
                    kpa(v),
                    v / p
                );
            }
            let rise_paper = paper[3] - paper[0];
            if let (Some(first), Some(last)) = (
                s.peaks(name).and_then(|v| v.first().copied()),
                s.peaks(name).and_then(|v| v.last().copied()),
            ) {
                outln!(
                    "{:<18} systolic rise: paper {:.3} kPa, ours {:.3} kPa",
                    name,
                    kpa(rise_paper),
                    kpa(last - first)
                );
            }
        }
    }
}

fn print_seed_002(s: &Seed002) {
    print_runs(&s.base);
    for sw in &s.sweeps {
        outln!("\nsweep {} ({}):", sw.name, sw.label);
        outln!(
            "{:>10} {:>22} {:>16} {:>16} {:>22}",
            "value",
            "swing at x=0 (kPa)",
            "peak (dia) kPa",
            "peak (sys) kPa",
            "lumen height d/s (mm)"
        );
        for p in &sw.points {
            let first = p.run.times.first();
            let last = p.run.times.last();
            let peak = |t: Option<&pulsetrack_fem::run::TimeResult>| {
                t.map_or(f64::NAN, |t| t.summary.peak)
            };
            let height = |t: Option<&pulsetrack_fem::run::TimeResult>| {
                t.map_or(f64::NAN, |t| t.lumen_height_m)
            };
            outln!(
                "{:>10.2} {:>22.4} {:>16.3} {:>16.3} {:>10.3} / {:<9.3}",
                p.value,
                kpa(p.swing_pa),
                kpa(peak(first)),
                kpa(peak(last)),
                height(first) * 1e3,
                height(last) * 1e3
            );
        }
    }
    outln!("\ntip shapes at 3 mm (systole, linear): peak and von Mises over the artery");
    for r in &s.tips {
        if let Some(t) = r.times.first() {
            outln!(
                "{:<18} peak {:>8.3} kPa at x = {:>6.2} mm; at x = 0: {:>8.3} kPa; overshoot ratio {:.2}",
                r.name,
                kpa(t.summary.peak),
                t.summary.x_peak * 1e3,
                kpa(t.summary.at_x0),
                t.summary.peak / t.summary.at_x0
            );
        }
    }
}

fn curve(x_m: &[f64], y_pa: &[f64]) -> Vec<(f64, f64)> {
    x_m.iter()
        .zip(y_pa)
        .map(|(x, y)| (x * 1e3, y * 1e-3))
        .collect()
}

fn plot_runs(dir: &Path, runs: &[ModelRun]) -> Result<(), String> {
    for r in runs {
        let mut c = Chart::new(
            format!("{}: top von Mises", r.name),
            "x from the feature (mm)",
            "von Mises (kPa)",
        );
        for t in &r.times {
            c = c.with(Series::new(
                format!("t = {:.3} s", t.t_s),
                curve(&t.x_m, &t.von_mises_pa),
                Mark::Line,
            ));
        }
        announce(write_chart(&c, dir, &r.name).map_err(|e| e.to_string())?);
    }
    Ok(())
}

fn plot_seed_001(dir: &Path, s: &Seed001) -> Result<(), String> {
    plot_runs(dir, &s.runs)?;
    let mut c = Chart::new(
        "Table 1: peak top von Mises during systole",
        "t (s)",
        "peak von Mises (kPa)",
    );
    for (name, paper) in [
        ("healthy-artery", TABLE1_HEALTHY_PA),
        ("stenotic-artery", TABLE1_STENOTIC_PA),
    ] {
        if let Some(ours) = s.peaks(name) {
            c = c
                .with(Series::new(
                    format!("{name} (paper)"),
                    TABLE1_TIMES_S
                        .iter()
                        .zip(paper)
                        .map(|(t, p)| (*t, p * 1e-3))
                        .collect(),
                    Mark::LinePoints,
                ))
                .with(Series::new(
                    format!("{name} (ours)"),
                    TABLE1_TIMES_S
                        .iter()
                        .zip(ours)
                        .map(|(t, p)| (*t, p * 1e-3))
                        .collect(),
                    Mark::LinePoints,
                ));
        }
    }
    announce(write_chart(&c, dir, "seed-001-table1").map_err(|e| e.to_string())?);
    Ok(())
}

/// Time samples of the tactile image over one pulse period.
const IMAGE_SAMPLES: usize = 35;

/// Paper 001 Fig. 3: top von Mises over x (the sensor's line) and time, one panel per model.
fn plot_tactile_image(dir: &Path, s: &Seed001) -> Result<(), String> {
    let panels = s
        .runs
        .iter()
        .map(|r| Heatmap {
            title: r.name.clone(),
            xs: r
                .times
                .first()
                .map(|t| t.x_m.iter().map(|x| x * 1e3).collect())
                .unwrap_or_default(),
            ys: r.times.iter().map(|t| t.t_s).collect(),
            values: r
                .times
                .iter()
                .map(|t| t.von_mises_pa.iter().map(|v| v * 1e-3).collect())
                .collect(),
        })
        .collect();
    let fig = HeatmapFigure {
        title: "2-D tactile image: top von Mises over x and one pulse (paper 001 Fig. 3)".into(),
        x_label: "x from the feature (mm)".into(),
        y_label: "t (s)".into(),
        value_label: "von Mises (kPa)".into(),
        panels,
        columns: 2,
        size_px: (1300, 900),
    };
    announce(write_heatmaps(&fig, dir, "seed-001-tactile-image").map_err(|e| e.to_string())?);
    Ok(())
}

fn plot_seed_002(dir: &Path, s: &Seed002) -> Result<(), String> {
    let base_dir = dir.join("base");
    plot_runs(&base_dir, &s.base)?;
    for sw in &s.sweeps {
        let c = Chart::new(
            format!("systolic - diastolic top von Mises against {}", sw.label),
            sw.label,
            "swing over the artery (kPa)",
        )
        .with(Series::new(
            "swing",
            sw.points
                .iter()
                .map(|p| (p.value, p.swing_pa * 1e-3))
                .collect(),
            Mark::LinePoints,
        ));
        announce(write_chart(&c, dir, &format!("sweep-{}", sw.name)).map_err(|e| e.to_string())?);
        let mut d = Chart::new(
            format!("systolic - diastolic von Mises along the top: {}", sw.label),
            "x from the artery (mm)",
            "difference (kPa)",
        );
        for p in &sw.points {
            if let Some(t) = p.run.times.first() {
                d = d.with(Series::new(
                    format!("{}", p.value),
                    curve(&t.x_m, &p.difference_pa),
                    Mark::Line,
                ));
            }
        }
        announce(
            write_chart(&d, dir, &format!("sweep-{}-curves", sw.name))
                .map_err(|e| e.to_string())?,
        );
    }
    let mut c = Chart::new(
        "finger tips at 3 mm: top von Mises (systole)",
        "x from the artery (mm)",
        "von Mises (kPa)",
    );
    for r in &s.tips {
        if let Some(t) = r.times.first() {
            c = c.with(Series::new(
                r.name.clone(),
                curve(&t.x_m, &t.von_mises_pa),
                Mark::Line,
            ));
        }
    }
    announce(write_chart(&c, dir, "tips").map_err(|e| e.to_string())?);
    Ok(())
}

fn kernel_table(refine: u32) -> Result<(), String> {
    use pulsetrack_fem::kernel::{KernelParams, analytic_per_pa, compute};
    use pulsetrack_fem::material::Material;
    let soft = Material::new(20e3, 0.45);
    let cases: [(&str, f64, f64, Material, f64); 7] = [
        ("hole a=0.25 mm", 0.00025, 0.0, soft, 0.005),
        ("hole a=0.5 mm", 0.0005, 0.0, soft, 0.005),
        ("hole a=1.5 mm (seed size)", 0.0015, 0.0, soft, 0.005),
        (
            "IMA 2.7 mm, 0.3 mm wall 400 kPa",
            0.00135,
            0.0003,
            Material::new(400e3, 0.49),
            0.005,
        ),
        (
            "radial 2.7 mm, 0.3 mm wall 400 kPa, 4 mm",
            0.00135,
            0.0003,
            Material::new(400e3, 0.49),
            0.004,
        ),
        (
            "seed latex 5 mm OD, 1 mm wall 1.5 MPa",
            0.0015,
            0.001,
            Material::new(1.5e6, 0.49),
            0.005,
        ),
        (
            "seed tube, wall as soft as the foam",
            0.0015,
            0.001,
            soft,
            0.005,
        ),
    ];
    outln!(
        "tissue E = 20 kPa, nu = 0.45, plane strain; kernel = surface pressure per Pa of lumen pressure"
    );
    outln!(
        "{:<42} {:>6} {:>10} {:>10} {:>7} {:>10} {:>10} {:>9} {:>7}",
        "tube",
        "h mm",
        "fem p(0)",
        "analytic",
        "ratio",
        "fem p(h)",
        "fem min",
        "x_min mm",
        "net"
    );
    for (name, a, t, wall, h) in cases {
        let p = KernelParams {
            tissue: soft,
            lumen_radius_m: a,
            wall_thickness_m: t,
            wall,
            centre_depth_m: h,
            refine,
            backing_depth_m: None,
        };
        let k = compute(&p).map_err(|e| e.to_string())?;
        let (mut min, mut x_min) = (f64::INFINITY, 0.0);
        for (x, v) in k.x_m.iter().zip(&k.pressure_per_pa) {
            if *x >= 0.0 && *v < min {
                min = *v;
                x_min = *x;
            }
        }
        let an = analytic_per_pa(0.0, a, h);
        outln!(
            "{:<42} {:>6.1} {:>10.5} {:>10.5} {:>7.3} {:>10.5} {:>10.5} {:>9.2} {:>7.4}",
            name,
            h * 1e3,
            k.at(0.0),
            an,
            k.at(0.0) / an,
            k.at(h),
            min,
            x_min * 1e3,
            k.net_force_m() / k.total_magnitude_m()
        );
    }
    outln!(
        "analytic: p(h) = 0, min -{:.4} x p(0) at x = sqrt(3) h",
        1.0 / 8.0
    );
    Ok(())
}

/// Say where each plot went (stderr: stdout carries the results).
fn announce(files: Vec<std::path::PathBuf>) {
    for f in files {
        eprintln!("wrote {}", f.display());
    }
}
