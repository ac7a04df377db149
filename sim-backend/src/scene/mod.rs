//! Scenes: what exists on the simulated bench, read from RON (`Scene(version: 1, ...)`).
//!
//! A scene names the artery (path, depth, size), the pressure waveform, the tissue, lumps,
//! the sensor, and which mechanical effects exist: shaft bending, pivot compliance, the added
//! mass, robot dynamics, faults. Each optional section is an effect that is simulated only
//! when the scene names it; its absence means the effect does not exist (a rigid shaft, a
//! fixed pivot, no friction), with the documented defaults in docs/sim.md. Geometry that the
//! robot *believes* (link lengths, pivot position, rod length, where the tissue lies) comes
//! from the daemon's configuration; a scene may make the truth differ.

pub mod path;
pub mod pulse;
mod shipped;
mod spec;
mod validate;
mod write;

use std::path::Path;

pub use path::{ArteryPath, CurvatureKnot, Nearest, PathSpec, Turn};
pub use pulse::{Ectopic, PulseSource, PulseSpec, RateChange};
pub use shipped::{SHIPPED, shipped_names, shipped_source};
pub use spec::*;
pub use write::to_ron;

use config::ConfigError;

/// The scene file format version this build reads.
pub const SCENE_VERSION: u32 = 1;

/// Load a shipped scene by file name (`seed-arc-145.ron`, with or without `.ron`) or a scene
/// file by path. Relative paths resolve against `base_dir` (the directory of the config file
/// that names the scene) when given, else the working directory. A name that is both a
/// shipped scene and an existing file loads the file.
pub fn load(name_or_path: &str, base_dir: Option<&Path>) -> Result<Scene, ConfigError> {
    let as_path = Path::new(name_or_path);
    let resolved = match base_dir {
        Some(dir) if as_path.is_relative() => dir.join(as_path),
        _ => as_path.to_path_buf(),
    };
    if resolved.is_file() {
        return config::load_file::<Scene>(&resolved).map(|l| l.value);
    }
    if let Some((name, text)) = shipped_source(name_or_path) {
        return config::load_str::<Scene>(&format!("<shipped {name}>"), text);
    }
    // Neither: report the file as unreadable, naming the shipped alternatives.
    Err(ConfigError {
        file: resolved.display().to_string(),
        problems: vec![config::load::Problem {
            line: None,
            col: None,
            field: String::new(),
            message: format!(
                "no such scene file, and not a shipped scene ({})",
                shipped_names().join(", ")
            ),
        }],
    })
}

#[cfg(test)]
mod tests;
