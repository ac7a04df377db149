//! Writing a scene as a RON file that `scene::load` reads back to the same value (the
//! scenes a family draws are dumped this way).

use super::Scene;

/// The scene as RON text, headed by `comment` lines.
pub fn to_ron(scene: &Scene, comment: &str) -> Result<String, String> {
    let pretty = ron::ser::PrettyConfig::new()
        .struct_names(true)
        .depth_limit(8)
        .indentor("    ".to_string());
    let body = ron::Options::default()
        .to_string_pretty(scene, pretty)
        .map_err(|e| format!("scene `{}`: {e}", scene.name))?;
    let mut out = String::new();
    for line in comment.lines() {
        out.push_str("// ");
        out.push_str(line);
        out.push('\n');
    }
    out.push_str(&body);
    out.push('\n');
    Ok(out)
}
