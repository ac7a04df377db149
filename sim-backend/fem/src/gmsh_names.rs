//! The `$PhysicalNames` section of a `.msh` file: (dimension, tag) -> name. `mshio` skips
//! this section, so it is read here; it is a few text lines, ASCII in binary files too:
//!
//! ```text
//! $PhysicalNames
//! 2
//! 1 4 "top"
//! 2 1 "tissue"
//! $EndPhysicalNames
//! ```

use std::collections::HashMap;

use super::gmsh_guard::{line_of, sections};

/// Physical group names by (dimension, tag).
pub type PhysicalNames = HashMap<(i32, i32), String>;

pub fn physical_names(bytes: &[u8]) -> Result<PhysicalNames, String> {
    let found = sections(bytes, "PhysicalNames");
    let start = match found.as_slice() {
        [s] => *s,
        [] => {
            return Err("no $PhysicalNames section: the physical groups need names \
                 (docs/fem.md, Gmsh meshes)"
                .into());
        }
        _ => return Err("$PhysicalNames appears more than once".into()),
    };
    let body = &bytes[start.body_at..];
    let end = sections(body, "EndPhysicalNames")
        .first()
        .map(|s| s.header_at)
        .ok_or("$PhysicalNames is not ended by $EndPhysicalNames: the file is truncated")?;
    let first_line = line_of(bytes, start.body_at);
    let mut rows = body[..end]
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .enumerate()
        .map(|(i, l)| (first_line + i, l))
        .filter(|(_, l)| !l.trim_ascii().is_empty());
    let (count_line, count) = rows
        .next()
        .ok_or("$PhysicalNames is empty: it must start with the number of names")?;
    let count: usize = std::str::from_utf8(count)
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .ok_or_else(|| format!("line {count_line}: $PhysicalNames count is not a number"))?;
    let mut out = PhysicalNames::new();
    let mut read = 0;
    for (line, row) in rows {
        let (key, name) = entry(row).map_err(|e| format!("line {line}: {e}"))?;
        if out.insert(key, name).is_some() {
            return Err(format!(
                "line {line}: physical group {} of dimension {} is named twice",
                key.1, key.0
            ));
        }
        read += 1;
    }
    if read != count {
        return Err(format!(
            "$PhysicalNames says it has {count} names but lists {read}"
        ));
    }
    Ok(out)
}

/// One `dim tag "name"` line.
fn entry(row: &[u8]) -> Result<((i32, i32), String), String> {
    let text = std::str::from_utf8(row).map_err(|e| {
        format!(
            "a physical group name is not UTF-8 (invalid byte at column {})",
            e.valid_up_to() + 1
        )
    })?;
    let shape = || format!("{text:?} is not `dimension tag \"name\"`");
    let (dim, rest) = text
        .trim()
        .split_once(char::is_whitespace)
        .ok_or_else(shape)?;
    let (tag, quoted) = rest
        .trim_start()
        .split_once(char::is_whitespace)
        .ok_or_else(shape)?;
    let dim: i32 = dim.parse().map_err(|_| shape())?;
    let tag: i32 = tag.parse().map_err(|_| shape())?;
    let name = quoted
        .trim()
        .strip_prefix('"')
        .and_then(|s| s.strip_suffix('"'))
        .ok_or_else(shape)?;
    if !(0..=3).contains(&dim) {
        return Err(format!("dimension {dim} in {text:?}: expected 0 to 3"));
    }
    Ok(((dim, tag), name.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_with_spaces_and_crlf() {
        let text = b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\r\n2\r\n\
                     2 1 \"soft tissue\"\r\n1  4   \"top\"\r\n$EndPhysicalNames\r\n";
        let n = physical_names(text).unwrap();
        assert_eq!(n[&(2, 1)], "soft tissue");
        assert_eq!(n[&(1, 4)], "top");
    }

    #[test]
    fn bad_sections_name_the_line() {
        let base = |body: &[u8]| {
            let mut v = b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n".to_vec();
            v.extend_from_slice(body);
            v
        };
        let e = physical_names(&base(b"1\n2 1 \"t\xffssue\"\n$EndPhysicalNames\n")).unwrap_err();
        assert!(e.starts_with("line 6:") && e.contains("not UTF-8"), "{e}");
        let e = physical_names(&base(b"2\n2 1 \"tissue\"\n$EndPhysicalNames\n")).unwrap_err();
        assert!(e.contains("says it has 2 names but lists 1"), "{e}");
        let e = physical_names(&base(b"1\n2 1 tissue\n$EndPhysicalNames\n")).unwrap_err();
        assert!(
            e.starts_with("line 6:") && e.contains("dimension tag"),
            "{e}"
        );
        let e = physical_names(&base(b"1\n2 1 \"tissue\"\n")).unwrap_err();
        assert!(e.contains("truncated"), "{e}");
        let e = physical_names(&base(b"x\n$EndPhysicalNames\n")).unwrap_err();
        assert!(e.starts_with("line 5:"), "{e}");
        let e = physical_names(b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n").unwrap_err();
        assert!(e.contains("no $PhysicalNames"), "{e}");
    }
}
