//! Issue 16: paper 002's swing against the finger's indentation in finite strain, with the
//! lumen pressure as a follower load and the lumen's self-contact, and for comparison the
//! earlier dead-load model without contact. Prints one table per lumen model: the swing over
//! the artery, the lumen's opening through its centre, its area, the wall nodes in contact,
//! and the Newton work.
//!
//! `cargo run --release -p pulsetrack-fem --example seed002_collapse -- [--refine N]
//! [--steps N] [--from MM --to MM --by MM] [--only follower-contact|follower|dead]
//! [--indent-first] [--unpressurized]`
//! (defaults: refine 0, 8 steps, 1.5 to 4.5 mm by 0.25 mm, all three models, the finger and
//! the pressure ramped together; `--indent-first` indents first and then pressurizes, as the
//! paper's load history says; `--unpressurized` leaves the lumen pressure at zero)

use pulsetrack_fem::collapse::{CollapsePoint, SweepOptions, indentation_sweep};
use pulsetrack_fem::finite::{LoadPath, LumenModel};
use pulsetrack_fem::study::StudyError;

struct Args {
    refine: u32,
    steps: u32,
    from: f64,
    to: f64,
    by: f64,
    only: Option<String>,
    indent_first: bool,
    unpressurized: bool,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        refine: 0,
        steps: 8,
        from: 1.5,
        to: 4.5,
        by: 0.25,
        only: None,
        indent_first: false,
        unpressurized: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        let num = |v: String| -> Result<f64, String> {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or(format!("{flag} {v:?}: not a number"))
        };
        match flag.as_str() {
            "--refine" => a.refine = value()?.parse().map_err(|e| format!("--refine: {e}"))?,
            "--steps" => a.steps = value()?.parse().map_err(|e| format!("--steps: {e}"))?,
            "--from" => a.from = num(value()?)?,
            "--to" => a.to = num(value()?)?,
            "--by" => a.by = num(value()?)?,
            "--only" => a.only = Some(value()?),
            "--indent-first" => a.indent_first = true,
            "--unpressurized" => a.unpressurized = true,
            _ => return Err(format!("unknown argument {flag:?}")),
        }
    }
    if !(a.by > 0.0 && a.from > 0.0 && a.to >= a.from) || (a.to - a.from) / a.by > 200.0 {
        return Err(format!(
            "--from {} --to {} --by {}: need 0 < from <= to and at most 200 steps of by > 0",
            a.from, a.to, a.by
        ));
    }
    if a.steps == 0 {
        return Err("--steps must be at least 1".into());
    }
    Ok(a)
}

fn print(name: &str, points: &[Result<CollapsePoint, StudyError>], indents: &[f64]) {
    let dofs = points
        .iter()
        .find_map(|p| p.as_ref().ok())
        .map_or(0, |p| p.dofs);
    println!("\n{name} ({dofs} DOFs)");
    println!(
        "{:>7} {:>11} {:>11} {:>21} {:>19} {:>13} {:>14} {:>16} {:>7}",
        "δ (mm)",
        "swing (Pa)",
        "peak (kPa)",
        "opening d/s (mm)",
        "area d/s (A0)",
        "contact d/s",
        "pen. max (µm)",
        "Newton it/cut/hb",
        "s"
    );
    let a0 = std::f64::consts::PI * 0.00225f64.powi(2);
    for (p, d) in points.iter().zip(indents) {
        let p = match p {
            Ok(p) => p,
            Err(e) => {
                println!("{d:>7.2} failed: {e}");
                continue;
            }
        };
        let l = |s: &pulsetrack_fem::collapse::Snapshot| s.lumen;
        let open = |s| l(s).and_then(|l| l.opening_m).map_or(f64::NAN, |o| o * 1e3);
        let area = |s| l(s).map_or(f64::NAN, |l| l.area_m2 / a0);
        let nodes = |s| l(s).map_or(0, |l| l.contact_nodes);
        let pen = |s| l(s).map_or(0.0, |l| l.penetration_m * 1e6);
        println!(
            "{:>7.2} {:>11.1} {:>11.3} {:>10.3} / {:<8.3} {:>8.3} / {:<8.3} {:>5} / {:<5} {:>14.3} {:>5}/{:>3}/{:<3} {:>8.1}",
            p.indent_mm,
            p.swing_pa,
            p.systole.peak_pa * 1e-3,
            open(&p.diastole),
            open(&p.systole),
            area(&p.diastole),
            area(&p.systole),
            nodes(&p.diastole),
            nodes(&p.systole),
            pen(&p.diastole).max(pen(&p.systole)),
            p.newton[0],
            p.newton[1],
            p.newton[2],
            p.wall_s
        );
    }
}

fn main() -> Result<(), String> {
    let a = parse()?;
    let n = ((a.to - a.from) / a.by + 1e-9).floor() as usize;
    let indents: Vec<f64> = (0..=n).map(|k| a.from + a.by * k as f64).collect();
    let models = [
        ("follower-contact", LumenModel::default()),
        (
            "follower",
            LumenModel {
                self_contact: false,
                ..LumenModel::default()
            },
        ),
        (
            "dead",
            LumenModel {
                follower: false,
                self_contact: false,
                ..LumenModel::default()
            },
        ),
    ];
    if let Some(o) = a
        .only
        .as_deref()
        .filter(|o| !models.iter().any(|(n, _)| n == o))
    {
        return Err(format!(
            "--only {o:?}: one of follower-contact, follower, dead"
        ));
    }
    println!(
        "seed-002 artery, finite strain, refine {}, {} initial steps, {}{}; swing = systolic minus diastolic top von Mises over the artery",
        a.refine,
        a.steps,
        if a.indent_first {
            "indentation first, then pressure"
        } else {
            "indentation and pressure together"
        },
        if a.unpressurized {
            ", no lumen pressure"
        } else {
            ""
        }
    );
    for (name, how) in models {
        if a.only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let o = SweepOptions {
            refine: a.refine,
            steps: a.steps,
            lumen: how,
            path: if a.indent_first {
                LoadPath::IndentFirst
            } else {
                LoadPath::Together
            },
            unpressurized: a.unpressurized,
            mesh: None,
        };
        let points = indentation_sweep(&indents, &o).map_err(|e| e.to_string())?;
        print(name, &points, &indents);
    }
    Ok(())
}
