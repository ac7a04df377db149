//! Meshes from Gmsh: 2-D MSH 4.1 files, ASCII or binary, whose physical groups name the
//! materials and boundaries (docs/fem.md, "Gmsh meshes"): one 2-D group per material,
//! named as the model names it ("tissue", then each feature layer's `name`); 1-D groups
//! "top" (loaded and reported), "bottom" (held) and "lumen" (pressurized). 4-node
//! quadrilaterals and 2-node lines only.
//!
//! The format is read by the `mshio` crate, the only Rust reader of MSH 4.1 in both
//! encodings (the others read 2.2 or are placeholders). It is small and readable but has
//! been unchanged since 2020, so it was audited before use rather than trusted:
//! - it panics on some malformed input (unwraps and `unimplemented!` in the `$MeshFormat`
//!   header, `count - 1` on an empty `$Nodes` or `$Elements`): [`super::gmsh_guard`] checks
//!   the bytes for each of these first, so that every file reaching mshio is one it answers
//!   with an error. No `catch_unwind`: the tests feed truncated and corrupted files and any
//!   panic fails them.
//! - its lists grow as entries parse (nom 5's `count` does not preallocate from the file's
//!   counts), so a lying count costs no memory; files over [`MAX_FILE_BYTES`] are refused.
//! - its error's `Display` dumps the rest of the file in hex; the message here is built
//!   from its backtrace instead (what it was reading, and where).
//! - it leaves out `$PhysicalNames`, read by [`super::gmsh_names`].
//! - its numbers go through nom 5 and lexical-core 0.7, which RUSTSEC-2023-0086 flags as
//!   unsound (writers and internal iterators). Replacing it means a reader of our own.

use std::io::Read;
use std::path::Path;

use super::gmsh_build::{Msh, build};
use super::gmsh_check::finish;
use super::gmsh_guard::{check_header, check_sections, line_of};
use super::gmsh_names::physical_names;
use super::mesh::Mesh;
use super::model::{Bottom, ModelFile};

pub use super::gmsh_build::{BOTTOM, Expected, LUMEN, TOP};

/// Larger files are refused before they are read whole.
pub const MAX_FILE_BYTES: u64 = 512 << 20;

/// Why a `.msh` file could not become a mesh; `file` is the path as given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct GmshError {
    pub file: String,
    pub problem: String,
}

impl Expected {
    /// What `model` needs of a mesh: its materials by name, and the boundaries its loads
    /// and supports use. Layer names must differ from each other and from "tissue".
    pub fn for_model(model: &ModelFile) -> Result<Expected, String> {
        let mut regions = vec!["tissue".to_string()];
        let mut need_lumen = false;
        if let Some(f) = &model.feature {
            need_lumen = f.lumen_radius_m.is_some();
            for l in &f.layers {
                if regions.contains(&l.name) {
                    return Err(format!(
                        "the model names the material \"{}\" twice: a Gmsh mesh finds \
                         materials by name",
                        l.name
                    ));
                }
                regions.push(l.name.clone());
            }
        }
        Ok(Expected {
            regions,
            need_bottom: model.bottom == Bottom::Held,
            need_lumen,
            width_m: model.block.width_m,
            height_m: model.block.height_m,
        })
    }
}

/// Read `path` into a mesh for a model expecting `want`.
pub fn read_mesh(path: &Path, want: &Expected) -> Result<Mesh, GmshError> {
    let file = path.display().to_string();
    let fail = |problem: String| GmshError {
        file: file.clone(),
        problem,
    };
    // Only a regular file: a FIFO would block the open, /dev/zero never end.
    let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot open: {e}")))?;
    if !meta.is_file() {
        return Err(fail("not a regular file".into()));
    }
    let f = std::fs::File::open(path).map_err(|e| fail(format!("cannot open: {e}")))?;
    let mut bytes = Vec::new();
    f.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| fail(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(fail(format!(
            "larger than {} MiB: refused",
            MAX_FILE_BYTES >> 20
        )));
    }
    parse_mesh(&file, &bytes, want)
}

/// As [`read_mesh`], from the file's bytes; `file` names it in errors.
pub fn parse_mesh(file: &str, bytes: &[u8], want: &Expected) -> Result<Mesh, GmshError> {
    parse(bytes, want).map_err(|problem| GmshError {
        file: file.to_string(),
        problem,
    })
}

fn parse(bytes: &[u8], want: &Expected) -> Result<Mesh, String> {
    let binary = check_header(bytes)?;
    check_sections(bytes, binary)?;
    let names = physical_names(bytes)?;
    let msh: Msh = mshio::parse_msh_bytes(bytes).map_err(|e| parser_error(bytes, binary, &e))?;
    finish(build(&msh, &names, want)?, want)
}

/// mshio's error as "line N: in <what it was reading>: <problem>".
fn parser_error(bytes: &[u8], binary: bool, e: &mshio::MshParserError<&[u8]>) -> String {
    let trace = e.filtered_backtrace();
    let Some((rest, kind)) = trace.first().or(e.backtrace.first()) else {
        return "not a readable MSH 4.1 file".into();
    };
    let at = bytes.len().saturating_sub(rest.len());
    let place = if binary {
        format!("byte {at}")
    } else {
        format!("line {}", line_of(bytes, at))
    };
    let path: Vec<String> = trace
        .iter()
        .skip(1)
        .rev()
        .map(|(_, k)| k.context().map_or_else(|| k.to_string(), str::to_string))
        .collect();
    let problem = match kind.context() {
        // mshio's contexts name what was being read ("x coordinate"), or are sentences.
        Some(c) if c.starts_with(|ch: char| ch.is_ascii_lowercase()) => {
            format!("cannot read the {c}")
        }
        Some(c) => c.to_string(),
        None if kind.is_nom_error() => "unexpected content".to_string(),
        None => kind.to_string(),
    };
    if path.is_empty() {
        format!("{place}: {problem}")
    } else {
        format!("{place}: in {}: {problem}", path.join(", in "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(layers: &str) -> ModelFile {
        let text = format!(
            r#"FemModel(version: 1, name: "m", analysis: PlaneStress,
            block: (width_m: 0.08, height_m: 0.03), tissue: (e_pa: 15e3, nu: 0.45),
            feature: (centre_x_m: 0.04, centre_depth_m: 0.015, lumen_radius_m: 0.004,
                layers: [{layers}]),
            load: Platen(indent_m: 0.001), bottom: Free)"#
        );
        config::load_str("m.ron", &text).unwrap()
    }

    #[test]
    fn what_a_model_expects() {
        let wall = r#"(name: "wall", thickness_m: 0.001, material: (e_pa: 3e5, nu: 0.49))"#;
        let e = Expected::for_model(&model(wall)).unwrap();
        assert_eq!(e.regions, ["tissue", "wall"]);
        assert!(e.need_lumen && !e.need_bottom);
        let twice = format!("{wall}, {}", wall.replace("0.001", "0.0005"));
        let err = Expected::for_model(&model(&twice)).unwrap_err();
        assert!(err.contains("\"wall\" twice"), "{err}");
        let tissue = wall.replace("\"wall\"", "\"tissue\"");
        assert!(Expected::for_model(&model(&tissue)).is_err());
    }

    #[test]
    fn only_regular_files_are_read() {
        let e = read_mesh(
            Path::new("/dev/zero"),
            &Expected::for_model(&model(
                r#"(name: "wall", thickness_m: 0.001, material: (e_pa: 3e5, nu: 0.49))"#,
            ))
            .unwrap(),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "/dev/zero: not a regular file");
    }
}
