//! The control core stays pure: no async runtime, no I/O crates, no clock, no threads.
//! This fails the build's tests the moment `control/` gains such a dependency or call.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn control_has_no_runtime_or_io_dependencies() {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "-p",
            "pulsetrack-control",
            "-e",
            "normal",
            "--prefix",
            "none",
            "--offline",
        ])
        .current_dir(workspace_root())
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    let forbidden = [
        "tokio",
        "tokio-serial",
        "socketcan",
        "mio",
        "async-std",
        "smol",
        "futures",
        "serialport",
        "libc",
        "nix",
        "crossbeam-channel",
        "tracing",
    ];
    for line in tree.lines() {
        let name = line.split_whitespace().next().unwrap_or("");
        assert!(
            !forbidden.contains(&name),
            "control depends on `{name}`: the core must stay pure"
        );
    }
    assert!(
        tree.contains("nalgebra"),
        "sanity: the tree lists control's real dependencies"
    );
}

#[test]
fn control_source_does_no_io_and_reads_no_clock() {
    let forbidden = [
        "std::fs",
        "std::net",
        "std::io",
        "std::time",
        "std::thread",
        "std::process",
        "std::env",
        "Instant::",
        "SystemTime",
        "println!",
        "eprintln!",
        "print!(",
    ];
    let mut files = Vec::new();
    collect_rs(&workspace_root().join("control/src"), &mut files);
    assert!(files.len() > 5, "found the control sources");
    for file in files {
        let text = std::fs::read_to_string(&file).expect("read source");
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for f in forbidden {
                assert!(
                    !code.contains(f),
                    "{}:{}: `{f}` in control: the core does no I/O and reads no clock",
                    file.display(),
                    n + 1
                );
            }
        }
    }
}

fn collect_rs(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read dir").flatten() {
        let p = entry.path();
        if p.is_dir() {
            collect_rs(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}
