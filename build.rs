//! Records the git commit the binary is built from (`CROSSAUDIT_GIT_COMMIT`),
//! with `-dirty` when the files it reads (`SOURCES`) differ from it, for the provenance
//! written into run.json and every report. Outside a git checkout (a
//! packaged crate) the commit is `unknown`.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    // No optional locks: a build must not take .git/index's lock from a
    // concurrent `git commit`, nor rewrite the index (which would make
    // the next build run this script again).
    let out = Command::new("git").arg("--no-optional-locks").args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// The paths a build reads: a change to one makes its label `-dirty`.
const SOURCES: [&str; 6] = ["src", "grammar", "crates", "Cargo.toml", "Cargo.lock", "build.rs"];

fn main() {
    let commit = match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(c) if !c.is_empty() => {
            // Only the files the build reads: a regenerated result (a report
            // under results/) does not make a binary's sources differ.
            let mut args = vec!["status", "--porcelain", "--untracked-files=no", "--"];
            args.extend(SOURCES);
            let dirty = git(&args).is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{c}-dirty")
            } else {
                c
            }
        }
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=CROSSAUDIT_GIT_COMMIT={commit}");
    // Rerun when the commit can have changed (HEAD, the branch it names,
    // packed refs) and on any change to the sources (so a build from edited
    // sources says `-dirty`); not on .git/index, which every checkout,
    // commit and `git status` rewrites without changing either.
    let mut watched = vec![".git/HEAD".to_string(), ".git/packed-refs".to_string()];
    if let Some(branch) =
        std::fs::read_to_string(".git/HEAD").ok().and_then(|h| h.strip_prefix("ref: ").map(|r| r.trim().to_string()))
    {
        watched.push(format!(".git/{branch}"));
    }
    watched.extend(SOURCES.map(String::from));
    // A path that does not exist (.git/packed-refs in a fresh clone) would
    // make cargo rerun this script, and rebuild the crate, on every command.
    for path in watched.into_iter().filter(|p| std::path::Path::new(p).exists()) {
        println!("cargo:rerun-if-changed={path}");
    }
}
