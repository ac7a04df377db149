//! `pulsetrack check-config FILE`: load and validate a daemon configuration, a scene, a
//! FEM model or a calibration file, and what it refers to; print every problem with file, line and field.
//!
//! The kind of file is its top-level RON struct name (`Config(`, `Scene(`, `FemModel(`); a
//! file without one is tried as each kind. Beyond parsing and validation: a simulator
//! configuration's scene must exist and pass the scene checks; a scene's artery path must be
//! buildable and, for an FEM pressure kernel, its mesh too (meshed, not solved); a FEM
//! model's mesh must be buildable (its Gmsh file, if it names one, read and checked); a
//! configuration's calibration file, where it exists, must load as the daemon would load it.
//! A calibration file on its own is checked too.

use crate::cli::stdout::outln;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use config::load::Problem;
use config::locate::{locate, parse_path};
use config::{Config, ConfigError, load_file};
use pulsetrack_fem::model::ModelFile;
use sim::scene::{ArteryPath, PressureKernel, Scene};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The RON file to check: a daemon configuration, a scene or a FEM model.
    pub file: PathBuf,
    /// Print `{"ok":true,"file":...,"summary":...}` on stdout, and a problem as a JSON error
    /// on stderr.
    #[arg(long)]
    pub json: bool,
}

/// The kinds of file this checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Config,
    Scene,
    FemModel,
    /// The rig's calibration file (written by the daemon; no struct name).
    Calibration,
}

const KINDS: [Kind; 4] = [Kind::Config, Kind::Scene, Kind::FemModel, Kind::Calibration];

pub fn run(args: &Args) -> ExitCode {
    match check(&args.file) {
        Ok(summary) if args.json => {
            let doc = serde_json::json!({
                "ok": true,
                "file": args.file.display().to_string(),
                "summary": summary,
            });
            outln!("{doc}");
            ExitCode::SUCCESS
        }
        Ok(summary) => {
            outln!("{summary}");
            ExitCode::SUCCESS
        }
        Err(e) if args.json => crate::cli::failure::failed("check-config", true, &e.to_string()),
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

/// Check `path`; a one-line summary of what it is when it is sound.
pub fn check(path: &Path) -> Result<String, ConfigError> {
    let source = std::fs::read_to_string(path).map_err(|e| {
        problem(
            &path.display().to_string(),
            None,
            "",
            format!("cannot read: {e}"),
        )
    })?;
    match top_level_name(&source).and_then(kind_named) {
        Some(kind) => check_as(kind, path, &source),
        None => {
            // No struct name: whichever kind reads it. Report the config's problems if none
            // does (the file's most common kind).
            let mut first_error = None;
            for kind in KINDS {
                match check_as(kind, path, &source) {
                    Ok(s) => return Ok(s),
                    Err(e) => {
                        first_error.get_or_insert(e);
                    }
                }
            }
            Err(first_error.unwrap_or_else(|| {
                problem(&path.display().to_string(), None, "", "empty file".into())
            }))
        }
    }
}

fn check_as(kind: Kind, path: &Path, source: &str) -> Result<String, ConfigError> {
    let origin = path.display().to_string();
    match kind {
        Kind::Config => {
            let loaded = load_file::<Config>(path)?;
            let mut summary = format!(
                "{origin}: ok (daemon config version {})",
                loaded.value.version
            );
            if let config::schema::Backend::Sim(s) = &loaded.value.backend {
                let dir = loaded.dir.as_deref();
                let scene_origin = scene_file(&s.scene, dir).map_or_else(
                    || format!("<shipped {}>", s.scene),
                    |p| p.display().to_string(),
                );
                let scene = sim::scene::load(&s.scene, dir).and_then(|scene| {
                    let scene_source = scene_file(&s.scene, dir)
                        .and_then(|p| std::fs::read_to_string(p).ok())
                        .unwrap_or_default();
                    check_scene(&scene, &scene_origin, &scene_source).map(|()| scene)
                });
                // Named at the config's `backend.scene`, with the scene's own problems.
                let scene = scene.map_err(|e| {
                    located(
                        &origin,
                        source,
                        "backend.scene",
                        format!("the scene {:?} does not load:\n{e}", s.scene),
                    )
                })?;
                summary.push_str(&format!("; scene {:?} ({scene_origin}) ok", scene.name));
            }
            // The calibration file the daemon would load with it, where it exists.
            let file = crate::runtime_paths::expand(&loaded.value.calibration.file);
            let file = match &loaded.dir {
                Some(d) if file.is_relative() => d.join(file),
                _ => file,
            };
            match config::calibration_file::load(&file) {
                Ok(None) => summary.push_str(&format!(
                    "; no calibration file at {} (the array is read as configured)",
                    file.display()
                )),
                Ok(Some(c)) => summary.push_str(&format!(
                    "; calibration {} ok{}",
                    file.display(),
                    if c.value.tactile.is_some() {
                        " (tactile)"
                    } else {
                        ""
                    }
                )),
                Err(e) => {
                    return Err(located(
                        &origin,
                        source,
                        "calibration.file",
                        format!("the calibration file cannot be used:\n{e}"),
                    ));
                }
            }
            Ok(summary)
        }
        Kind::Calibration => {
            let loaded = load_file::<config::calibration_file::CalibrationFile>(path)?;
            Ok(format!(
                "{origin}: ok (calibration file version {}{})",
                loaded.value.version,
                loaded
                    .value
                    .tactile
                    .as_ref()
                    .map(|t| format!(", tactile of {}", t.measured_utc))
                    .unwrap_or_default()
            ))
        }
        Kind::Scene => {
            let loaded = load_file::<Scene>(path)?;
            check_scene(&loaded.value, &origin, source)?;
            Ok(format!(
                "{origin}: ok (scene {:?}, version {})",
                loaded.value.name, loaded.value.version
            ))
        }
        Kind::FemModel => {
            let loaded = load_file::<ModelFile>(path)?;
            let mut model = loaded.value.clone();
            model.resolve_mesh_file(loaded.dir.as_deref());
            // A Gmsh mesh is read and checked against the model; else the block is meshed.
            let field = if model.mesh_file.is_some() {
                "mesh_file"
            } else {
                "block"
            };
            pulsetrack_fem::run::build_mesh(&model, 0).map_err(|e| {
                located(
                    &origin,
                    source,
                    field,
                    format!("the model cannot be meshed: {e}"),
                )
            })?;
            Ok(format!(
                "{origin}: ok (FEM model {:?}, version {})",
                loaded.value.name, loaded.value.version
            ))
        }
    }
}

/// What the simulator builds from a scene before it runs, short of solving anything.
fn check_scene(scene: &Scene, origin: &str, source: &str) -> Result<(), ConfigError> {
    ArteryPath::from_spec(&scene.artery.path)
        .map_err(|e| located(origin, source, "artery.path", e.to_string()))?;
    if let PressureKernel::Fem(spec) = &scene.artery.kernel {
        let a = &scene.artery;
        let params = spec.params(a.inner_radius_m, a.wall_m, a.depth_m);
        if !params.is_valid() {
            return Err(located(
                origin,
                source,
                "artery.kernel",
                format!("the FEM kernel's parameters are out of range: {params:?}"),
            ));
        }
        pulsetrack_fem::run::build_mesh(&params.model(), params.refine).map_err(|e| {
            located(
                origin,
                source,
                "artery.kernel",
                format!("the FEM kernel's model cannot be meshed: {e}"),
            )
        })?;
    }
    Ok(())
}

/// The scene's file, if the config names a file rather than a shipped scene.
fn scene_file(name: &str, dir: Option<&Path>) -> Option<PathBuf> {
    let p = Path::new(name);
    let resolved = match dir {
        Some(d) if p.is_relative() => d.join(p),
        _ => p.to_path_buf(),
    };
    resolved.is_file().then_some(resolved)
}

fn located(origin: &str, source: &str, field: &str, message: String) -> ConfigError {
    let at = locate(source, &parse_path(field));
    problem(origin, at.map(|a| (a.line, a.col)), field, message)
}

fn problem(origin: &str, at: Option<(usize, usize)>, field: &str, message: String) -> ConfigError {
    ConfigError {
        file: origin.to_string(),
        problems: vec![Problem {
            line: at.map(|a| a.0),
            col: at.map(|a| a.1),
            field: field.to_string(),
            message,
        }],
    }
}

fn kind_named(name: &str) -> Option<Kind> {
    match name {
        "Config" => Some(Kind::Config),
        "Scene" => Some(Kind::Scene),
        "FemModel" => Some(Kind::FemModel),
        _ => None,
    }
}

/// The identifier before the first `(` outside comments, if there is one.
fn top_level_name(source: &str) -> Option<&str> {
    let mut rest = source;
    loop {
        rest = rest.trim_start();
        if let Some(after) = rest.strip_prefix("//") {
            rest = after.split_once('\n').map_or("", |(_, r)| r);
        } else if let Some(after) = rest.strip_prefix("/*") {
            rest = after.split_once("*/").map_or("", |(_, r)| r);
        } else if rest.starts_with("#![") {
            // RON extension attributes (`#![enable(implicit_some)]`).
            rest = rest.split_once(']').map_or("", |(_, r)| r);
        } else {
            break;
        }
    }
    let end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    let name = &rest[..end];
    (!name.is_empty() && rest[end..].trim_start().starts_with('(')).then_some(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_top_level_name_is_found_past_comments() {
        assert_eq!(
            top_level_name("// a\n/* b */\n  Scene(version: 1)"),
            Some("Scene")
        );
        assert_eq!(top_level_name("FemModel ("), Some("FemModel"));
        assert_eq!(top_level_name("(version: 1)"), None);
        assert_eq!(top_level_name(""), None);
        assert_eq!(top_level_name("// only a comment"), None);
    }

    /// A config's calibration file is checked with it, and on its own.
    #[test]
    fn a_calibration_file_is_checked_with_its_config_and_alone() {
        let dir = tempfile::tempdir().expect("tmp");
        let (_, sim) = config::shipped::SIM_CONFIG;
        let text = sim.replace(
            "file: \"{state}/sim-calibration.ron\",",
            "file: \"cal.ron\",",
        );
        assert_ne!(
            text, sim,
            "the shipped sim config names its calibration file"
        );
        let config_path = dir.path().join("daemon.ron");
        std::fs::write(&config_path, &text).expect("write");
        let summary = check(&config_path).expect("no calibration file yet");
        assert!(summary.contains("no calibration file"), "{summary}");

        let cal = dir.path().join("cal.ron");
        config::calibration_file::save(&cal, &config::calibration_file::CalibrationFile::default())
            .expect("save");
        let alone = check(&cal).expect("a calibration file alone");
        assert!(alone.contains("calibration file version 1"), "{alone}");
        assert!(check(&config_path).expect("ok").contains("calibration"));

        std::fs::write(&cal, "(version: 1, tactile: (measured_utc: 5))").expect("write");
        let e = check(&config_path).expect_err("a broken calibration file");
        let e = e.to_string();
        assert!(
            e.contains("calibration.file") && e.contains("cal.ron"),
            "{e}"
        );
    }
}
