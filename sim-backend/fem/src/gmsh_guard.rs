//! Checks on a `.msh` file's raw bytes that run before `mshio` sees them: each one closes a
//! path on which mshio 0.4.2 would panic instead of returning an error (read from its
//! source; see [`super::gmsh`]), and the rest give clearer messages than its own.
//!
//! - `$MeshFormat` must read `4.1 0|1 8`: mshio unwraps the numbers it reads there and has
//!   `unimplemented!` for data sizes other than 1, 2, 4, 8 and 16 bytes.
//! - `$Nodes` and `$Elements` must each count at least one entry: mshio computes
//!   `count - 1` in u64 (an overflow panic in debug and test builds when the count is 0).
//! - Each of `$Entities`, `$Nodes`, `$Elements` once and ended (mshio would only say it
//!   hit the end of its input).

/// Where a section header line starts and where the line after it starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Section {
    pub header_at: usize,
    pub body_at: usize,
}

/// Lines of `bytes` (without their `\n` or `\r\n`) with the offset each starts at.
fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    let mut at = 0;
    std::iter::from_fn(move || {
        if at >= bytes.len() {
            return None;
        }
        let start = at;
        let end = bytes[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |p| start + p);
        at = end + 1;
        let line = &bytes[start..end];
        Some((start, line.strip_suffix(b"\r").unwrap_or(line)))
    })
}

/// Every line that is exactly `$name` (a binary payload that happened to contain one would
/// only make a clearer error than the parser's).
pub fn sections(bytes: &[u8], name: &str) -> Vec<Section> {
    let tag = format!("${name}");
    let mut out = Vec::new();
    let mut pending: Option<usize> = None;
    for (at, line) in lines(bytes) {
        if let Some(header_at) = pending.take() {
            out.push(Section {
                header_at,
                body_at: at,
            });
        }
        if line == tag.as_bytes() {
            pending = Some(at);
        }
    }
    if let Some(header_at) = pending {
        out.push(Section {
            header_at,
            body_at: bytes.len(),
        });
    }
    out
}

/// The 1-based line number of byte `at` (for messages about ASCII files).
pub fn line_of(bytes: &[u8], at: usize) -> usize {
    1 + bytes[..at.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// Whether the file is binary (`$MeshFormat` file type 1); checks the header as mshio will
/// read it.
pub fn check_header(bytes: &[u8]) -> Result<bool, String> {
    let mut it = lines(bytes);
    match it.next() {
        Some((_, b"$MeshFormat")) => {}
        _ => return Err("does not start with $MeshFormat: not a Gmsh MSH file".into()),
    }
    let format = it.next().map_or(&b""[..], |(_, l)| l);
    let format = String::from_utf8_lossy(format);
    let fields: Vec<&str> = format.split_whitespace().collect();
    let [version, file_type, size_t] = fields[..] else {
        return Err(format!(
            "line 2, {format:?}: expected `version file-type data-size` after $MeshFormat"
        ));
    };
    if version != "4.1" {
        return Err(format!(
            "MSH version {version}: only 4.1 is read; save it again as 4.1 \
             (gmsh -format msh41, or Mesh.MshFileVersion = 4.1)"
        ));
    }
    let binary = match file_type {
        "0" => false,
        "1" => true,
        _ => {
            return Err(format!(
                "line 2: file type {file_type}: expected 0 (ASCII) or 1 (binary)"
            ));
        }
    };
    if size_t != "8" {
        return Err(format!(
            "line 2: data size {size_t}: only 8-byte size_t is read (what Gmsh writes)"
        ));
    }
    Ok(binary)
}

/// Each of `$Entities`, `$Nodes`, `$Elements` exactly once, each ended, and `$Nodes` and
/// `$Elements` not empty.
pub fn check_sections(bytes: &[u8], binary: bool) -> Result<(), String> {
    for name in ["Entities", "Nodes", "Elements"] {
        let starts = sections(bytes, name);
        let ends = sections(bytes, &format!("End{name}"));
        let start = match (starts.as_slice(), ends.len()) {
            ([s], 1) => *s,
            ([], _) => return Err(format!("no ${name} section")),
            ([_], 0) => {
                return Err(format!(
                    "${name} is not ended by $End{name}: the file is truncated"
                ));
            }
            _ => {
                return Err(format!(
                    "${name} appears {} times (ended {} times): one is read",
                    starts.len(),
                    ends.len()
                ));
            }
        };
        if name != "Entities" && second_count_is_zero(&bytes[start.body_at..], binary) {
            return Err(format!(
                "line {}: ${name} says it holds 0 {}: nothing to read",
                line_of(bytes, start.header_at),
                name.to_lowercase()
            ));
        }
    }
    Ok(())
}

/// Whether the second number of a `$Nodes` or `$Elements` header (numEntityBlocks,
/// numNodes or numElements, ...) is zero, read the way mshio reads it: in ASCII, after
/// spaces and line breaks, the longest run of digits; in binary, a size_t (zero in either
/// byte order). Anything mshio could not read as a number is left for its error.
fn second_count_is_zero(body: &[u8], binary: bool) -> bool {
    if binary {
        return body.get(8..16).is_some_and(|b| b.iter().all(|&x| x == 0));
    }
    let mut rest = body;
    let mut digits: &[u8] = &[];
    for _ in 0..2 {
        let skip = rest.iter().take_while(|b| b" \t\r\n".contains(b)).count();
        rest = &rest[skip..];
        let n = rest.iter().take_while(|b| b.is_ascii_digit()).count();
        if n == 0 {
            return false;
        }
        digits = &rest[..n];
        rest = &rest[n..];
    }
    digits.iter().all(|&d| d == b'0')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_versions_and_sizes() {
        assert_eq!(
            check_header(b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"),
            Ok(false)
        );
        assert_eq!(check_header(b"$MeshFormat\r\n4.1 1 8\r\n"), Ok(true));
        let e = check_header(b"$MeshFormat\n2.2 0 8\n").unwrap_err();
        assert!(e.contains("version 2.2") && e.contains("4.1"), "{e}");
        let e = check_header(b"$MeshFormat\n4.1 1 4\n").unwrap_err();
        assert!(e.contains("data size 4"), "{e}");
        let e = check_header(b"$MeshFormat\n4.1 0 99999999999999999999\n").unwrap_err();
        assert!(e.contains("data size"), "{e}");
        let e = check_header(b"$MeshFormat\n4.1 2 8\n").unwrap_err();
        assert!(e.contains("file type 2"), "{e}");
        let e = check_header(b"hello").unwrap_err();
        assert!(e.contains("not a Gmsh MSH file"), "{e}");
        let e = check_header(b"$MeshFormat\n").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
    }

    #[test]
    fn zero_counts_are_refused_in_both_encodings() {
        assert!(second_count_is_zero(b"1 0 1 1\n", false));
        assert!(second_count_is_zero(b" 1\n 000 1 1", false));
        assert!(!second_count_is_zero(b"1 10 1 10\n", false));
        assert!(!second_count_is_zero(b"1 x", false));
        let mut bin = vec![1u8, 0, 0, 0, 0, 0, 0, 0];
        bin.extend([0u8; 8]);
        assert!(second_count_is_zero(&bin, true));
        bin[9] = 1;
        assert!(!second_count_is_zero(&bin, true));
        assert!(!second_count_is_zero(&bin[..12], true));
    }

    #[test]
    fn sections_are_found_by_whole_lines() {
        let text = b"$A\n1\n$EndA\n$Ab\n$A\r\n";
        let s = sections(text, "A");
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].header_at, 0);
        assert_eq!(s[0].body_at, 3);
        assert_eq!(s[1].body_at, text.len());
        assert_eq!(line_of(text, s[1].header_at), 5);
    }
}
