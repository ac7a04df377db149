//! Bad `.msh` files: each kind gives an error naming the file and what is wrong, and no
//! input makes the reader panic (truncated and corrupted files at many places).

use std::path::{Path, PathBuf};

use pulsetrack_fem::gmsh::{Expected, GmshError, parse_mesh, read_mesh};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn bytes(name: &str) -> Vec<u8> {
    std::fs::read(data(name)).expect("read test data")
}

/// The seed-001 healthy artery's expectations (tissue, wall; top, bottom, lumen).
fn artery() -> Expected {
    Expected {
        regions: vec!["tissue".into(), "wall".into()],
        need_bottom: true,
        need_lumen: true,
        width_m: 0.08,
        height_m: 0.03,
    }
}

fn tissue_only() -> Expected {
    Expected {
        regions: vec!["tissue".into()],
        need_lumen: false,
        ..artery()
    }
}

/// The error for `bytes` read as `bad.msh`, which must name the file.
fn error(bytes: &[u8], want: &Expected) -> String {
    let e: GmshError = parse_mesh("bad.msh", bytes, want).expect_err("a bad file");
    assert_eq!(e.file, "bad.msh");
    let text = e.to_string();
    assert!(text.starts_with("bad.msh: "), "{text}");
    text
}

/// The file with the first `from` replaced by `to` (bytes: binary files too).
fn replaced(name: &str, from: &str, to: &str) -> Vec<u8> {
    let b = bytes(name);
    let at = b
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap_or_else(|| panic!("{from:?} not in {name}"));
    let mut out = b[..at].to_vec();
    out.extend_from_slice(to.as_bytes());
    out.extend_from_slice(&b[at + from.len()..]);
    out
}

#[test]
fn a_missing_file_is_named() {
    let e = read_mesh(Path::new("no/such/mesh.msh"), &artery())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("no/such/mesh.msh: cannot open"), "{e}");
}

#[test]
fn missing_groups_are_named() {
    let e = error(
        &replaced("small-artery.msh", "1 5 \"bottom\"", "1 5 \"base\""),
        &artery(),
    );
    assert!(e.contains("no 1-D physical group \"bottom\""), "{e}");
    let e = error(
        &replaced("small-artery.msh", "1 3 \"lumen\"", "1 3 \"hole\""),
        &artery(),
    );
    assert!(e.contains("\"lumen\""), "{e}");
    let e = error(
        &replaced("small-artery.msh", "1 4 \"top\"", "1 4 \"skin\""),
        &artery(),
    );
    assert!(e.contains("\"top\""), "{e}");
    // A material the model names but the mesh lacks, and a surface of no known material.
    let mut three = artery();
    three.regions.push("stenosis".into());
    let e = error(&bytes("small-artery.msh"), &three);
    assert!(e.contains("no 2-D physical group \"stenosis\""), "{e}");
    let e = error(
        &replaced("small-artery.msh", "2 2 \"wall\"", "2 2 \"media\""),
        &artery(),
    );
    assert!(e.contains("surface 2") && e.contains("media"), "{e}");
    // The tissue-only model needs no lumen, but the file's wall is no material of it.
    let e = error(&bytes("small-artery.msh"), &tissue_only());
    assert!(e.contains("\"wall\""), "{e}");
    let e = error(
        &replaced("small-artery.msh", "$PhysicalNames", "$PhysicalNamez"),
        &artery(),
    );
    assert!(e.contains("no $PhysicalNames"), "{e}");
}

#[test]
fn wrong_element_types_and_dimensions() {
    let e = error(&bytes("triangles.msh"), &tissue_only());
    assert!(e.contains("triangles") && e.contains("RecombineAll"), "{e}");
    let e = error(&bytes("box-3d.msh"), &tissue_only());
    assert!(e.contains("only 2-D meshes"), "{e}");
}

#[test]
fn truncated_files() {
    let full = bytes("small-artery.msh");
    let e = error(&full[..full.len() / 2], &artery());
    assert!(
        e.contains("$Nodes is not ended") && e.contains("truncated"),
        "{e}"
    );
    // Cut inside the last section, before its end tag: the parser names the place.
    let cut = full.len() - "$EndElements\n".len() - 40;
    let mut text = full[..cut].to_vec();
    text.extend_from_slice(b"\n$EndElements\n");
    let e = error(&text, &artery());
    assert!(e.contains("line ") && e.contains("element"), "{e}");
    let bin = bytes("small-artery-binary.msh");
    let e = error(&bin[..bin.len() / 2], &artery());
    assert!(e.contains("truncated"), "{e}");
}

#[test]
fn garbage_and_other_versions() {
    let e = error(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR", &artery());
    assert!(e.contains("not a Gmsh MSH file"), "{e}");
    let e = error(b"", &artery());
    assert!(e.contains("not a Gmsh MSH file"), "{e}");
    let e = error(
        &replaced("small-artery.msh", "4.1 0 8", "2.2 0 8"),
        &artery(),
    );
    assert!(e.contains("version 2.2") && e.contains("msh41"), "{e}");
    let e = error(
        &replaced(
            "small-artery.msh",
            "$Entities\n6 6 2 0\n",
            "$Entities\n6 6 2 x\n",
        ),
        &artery(),
    );
    assert!(
        e.contains("line 13: in entity section")
            && e.contains("cannot read the number of volume entities"),
        "{e}"
    );
}

#[test]
fn non_utf8_group_names() {
    let e = error(&non_utf8(), &artery());
    assert!(e.contains("line 10") && e.contains("not UTF-8"), "{e}");
}

/// The small artery with a byte that is not UTF-8 in the wall's name.
fn non_utf8() -> Vec<u8> {
    let mut b = bytes("small-artery.msh");
    let at = b
        .windows(6)
        .position(|w| w == b"\"wall\"")
        .expect("the wall's name");
    b[at + 2] = 0xff;
    b
}

/// Inputs on which mshio 0.4.2 would panic; the checks before it refuse them.
#[test]
fn inputs_that_would_panic_the_parser_are_refused_first() {
    let e = error(
        &replaced(
            "small-artery.msh",
            "$Nodes\n14 394 1 394",
            "$Nodes\n14 0 1 394",
        ),
        &artery(),
    );
    assert!(e.contains("$Nodes says it holds 0 nodes"), "{e}");
    let mut bin = bytes("small-artery-binary.msh");
    let at = bin
        .windows(8)
        .position(|w| w == b"\n$Nodes\n")
        .expect("$Nodes")
        + 8;
    bin[at + 8..at + 16].fill(0);
    let e = error(&bin, &artery());
    assert!(e.contains("$Nodes says it holds 0"), "{e}");
    let e = error(
        &replaced("small-artery-binary.msh", "4.1 1 8", "4.1 1 3"),
        &artery(),
    );
    assert!(e.contains("data size 3"), "{e}");
}

#[test]
fn meshes_that_do_not_fit_the_model() {
    // Drawn in millimetres (here: the model's block 1000 times smaller).
    let tiny = Expected {
        width_m: 0.08e-3,
        height_m: 0.03e-3,
        ..artery()
    };
    let e = error(&bytes("small-artery.msh"), &tiny);
    assert!(e.contains("millimetres"), "{e}");
    // Two halves meshed apart: their shared edge has two nodes at each place.
    let e = error(&bytes("unglued.msh"), &tissue_only());
    assert!(e.contains("not conforming"), "{e}");
    // Node coordinates off the plane.
    let e = error(
        &replaced("small-artery.msh", "0.045 0.015 0\n", "0.045 0.015 0.001\n"),
        &artery(),
    );
    assert!(e.contains("z = 0.001"), "{e}");
}

/// Truncations and corrupted bytes all over both encodings: each read returns (mostly an
/// error); a panic anywhere fails the test.
#[test]
fn truncated_and_corrupted_files_never_panic() {
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let mut errors = 0;
    let mut tries = 0;
    for name in ["small-artery.msh", "small-artery-binary.msh"] {
        let full = bytes(name);
        for k in 0..150 {
            let cut = (full.len() * k) / 150;
            tries += 1;
            errors += usize::from(parse_mesh(name, &full[..cut], &artery()).is_err());
        }
        for _ in 0..300 {
            let mut b = full.clone();
            for _ in 0..(1 + next() % 4) {
                let at = (next() % b.len() as u64) as usize;
                b[at] = match next() % 4 {
                    0 => b'0',
                    1 => b'\n',
                    2 => b'$',
                    _ => next() as u8,
                };
            }
            tries += 1;
            errors += usize::from(parse_mesh(name, &b, &artery()).is_err());
        }
    }
    // Most damage is noticed (a changed digit in a coordinate may not be).
    assert!(errors * 2 > tries, "{errors} errors in {tries} reads");
}
