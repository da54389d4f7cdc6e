//! Records the git commit the binary is built from (`CROSSAUDIT_GIT_COMMIT`),
//! with `-dirty` when tracked files differ from it, for the provenance
//! written into run.json and every report. Outside a git checkout (a
//! packaged crate) the commit is `unknown`.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(c) if !c.is_empty() => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{c}-dirty")
            } else {
                c
            }
        }
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=CROSSAUDIT_GIT_COMMIT={commit}");
    // Rerun on a commit or checkout, and on any change to the sources (so a
    // build from edited sources says `-dirty`).
    for path in [".git/HEAD", ".git/index", ".git/refs", "src", "grammar", "Cargo.toml", "Cargo.lock", "build.rs"] {
        println!("cargo:rerun-if-changed={path}");
    }
}
