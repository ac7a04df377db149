//! Stamps the build with the git commit it was built from (for trial recordings' `build`
//! metadata). No git or no repository (a source tarball): `unknown`.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (!s.is_empty()).then_some(s)
}

fn main() {
    let commit = std::env::var("PULSETRACK_BUILD_COMMIT")
        .ok()
        .or_else(|| git(&["rev-parse", "HEAD"]))
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=PULSETRACK_COMMIT={commit}");
    println!("cargo:rerun-if-env-changed=PULSETRACK_BUILD_COMMIT");
    // Rebuild the stamp when HEAD moves (a worktree's HEAD lives in its own git dir).
    if let Some(head) = git(&["rev-parse", "--path-format=absolute", "--git-path", "HEAD"]) {
        println!("cargo:rerun-if-changed={head}");
    }
    if let Some(refs) = git(&["rev-parse", "--symbolic-full-name", "HEAD"])
        .and_then(|r| git(&["rev-parse", "--path-format=absolute", "--git-path", &r]))
    {
        println!("cargo:rerun-if-changed={refs}");
    }
}
