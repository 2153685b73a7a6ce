//! Records the compiler version for run metadata, and the git revision the binary is built from
//! for `pointsight --version` (`harness::paths::VERSION`).

use std::path::Path;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let dir = std::env::var("CARGO_MANIFEST_DIR").ok()?;
    Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_owned())
}

fn main() {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = Command::new(rustc)
        .arg("-V")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_owned())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=POINTSIGHT_RUSTC={version}");
    println!("cargo:rerun-if-env-changed=RUSTC");

    // The revision: HEAD (uncommitted changes are not seen: the run metadata records them).
    // Rebuilt when HEAD moves: its file, the branch's ref, the packed refs.
    let revision = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let short = &revision[..revision.len().min(10)];
    println!("cargo:rustc-env=POINTSIGHT_GIT_REVISION={revision}");
    println!(
        "cargo:rustc-env=POINTSIGHT_VERSION={} (git {short})",
        std::env::var("CARGO_PKG_VERSION").unwrap_or_default()
    );
    for (what, rel) in [("--git-dir", "HEAD"), ("--git-common-dir", "packed-refs")] {
        if let Some(dir) = git(&["rev-parse", what]) {
            let dir = Path::new(&std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default()).join(dir);
            println!("cargo:rerun-if-changed={}", dir.join(rel).display());
        }
    }
    if let (Some(common), Some(branch)) = (
        git(&["rev-parse", "--git-common-dir"]),
        git(&["symbolic-ref", "-q", "HEAD"]),
    ) {
        let dir = Path::new(&std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default()).join(common);
        println!("cargo:rerun-if-changed={}", dir.join(branch).display());
    }
    println!("cargo:rerun-if-changed=build.rs");
}
