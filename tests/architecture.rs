//! The dependency order of ARCHITECTURE.md, checked against the source:
//! every `crate::` import of every module must be one its row allows, the
//! table itself must be acyclic, and the invariants that are a matter of
//! grep (pest only in `design`, no file reads in `report`) hold.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::common::root;

/// `module -> modules it may import`, read from ARCHITECTURE.md.
fn allowed() -> BTreeMap<String, BTreeSet<String>> {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let section = text.split("## Dependency order").nth(1).expect("a Dependency order section");
    let mut out = BTreeMap::new();
    for line in section.lines().take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 || !cells[1].starts_with('`') {
            continue;
        }
        let names = |s: &str| -> BTreeSet<String> {
            s.split(',').map(|x| x.trim().trim_matches('`').to_string()).filter(|x| !x.is_empty()).collect()
        };
        out.insert(cells[1].trim_matches('`').to_string(), names(cells[2]));
    }
    assert!(out.len() >= 10, "the dependency table was not found: {out:?}");
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The stage a source file belongs to: its top-level folder or file under src/.
fn module_of(path: &Path) -> String {
    let rel = path.strip_prefix(root().join("src")).unwrap();
    let first = rel.components().next().unwrap().as_os_str().to_string_lossy().into_owned();
    first.trim_end_matches(".rs").to_string()
}

/// Source lines without comments (doc links may name any module), a `use`
/// group written over several lines joined into its first.
fn code_lines(path: &Path) -> Vec<(usize, String)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut open = false;
    for (k, l) in text.lines().enumerate() {
        if l.trim_start().starts_with("//") {
            continue;
        }
        let code = l.split("//").next().unwrap_or("").to_string();
        match (open, out.last_mut()) {
            (true, Some(last)) => last.1.push_str(code.trim()),
            _ => out.push((k + 1, code.clone())),
        }
        let line = &out.last().map(|x| x.1.clone()).unwrap_or_default();
        open = line.contains("crate::") && line.matches('{').count() > line.matches('}').count();
    }
    out
}

/// Every `crate::name` referenced on a line (including `use crate::{a, b}`).
fn crate_refs(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(k) = rest.find("crate::") {
        rest = &rest[k + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let inner = group.split('}').next().unwrap_or("");
            out.extend(inner.split(',').map(|s| s.trim().split("::").next().unwrap_or("").to_string()));
        } else {
            let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            out.push(name);
        }
    }
    out.into_iter().filter(|n| !n.is_empty()).collect()
}

fn all_sources() -> Vec<PathBuf> {
    let mut files = Vec::new();
    rust_files(&root().join("src"), &mut files);
    files.sort();
    files
}

#[test]
fn import_groups_over_several_lines_are_read_whole() {
    let dir = std::env::temp_dir().join(format!("crossaudit-arch-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("m.rs");
    std::fs::write(&file, "use crate::{\n    io::sha256_hex, // hashes\n    Plan,\n};\nfn f() {}\n").unwrap();
    let lines = code_lines(&file);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(lines[0].0, 1);
    assert_eq!(crate_refs(&lines[0].1), ["io", "Plan"]);
    assert_eq!(lines[1], (5, "fn f() {}".to_string()));
}

#[test]
fn every_import_follows_the_declared_dependency_order() {
    let allowed = allowed();
    let stages: BTreeSet<&String> = allowed.keys().collect();
    let mut violations = Vec::new();
    for path in all_sources() {
        let module = module_of(&path);
        // The crate root and the binary sit above every stage; the crate's
        // error type has a row of its own (above every stage it wraps).
        if ["lib", "bin"].contains(&module.as_str()) {
            continue;
        }
        let Some(may) = allowed.get(&module) else {
            violations.push(format!("{}: module `{module}` is not in ARCHITECTURE.md's table", path.display()));
            continue;
        };
        for (line, code) in code_lines(&path) {
            for name in crate_refs(&code) {
                let is_stage = stages.contains(&name);
                // Beside the stages, the crate root holds only its re-exports
                // (for users): a stage reaching one (`crate::Plan`,
                // `crate::analyze`, `crate::BUILD`) goes round the table.
                if !is_stage || (name != module && !may.contains(&name)) {
                    violations.push(format!("{}:{line}: `{module}` imports `crate::{name}`", path.display()));
                }
            }
            // In a single-file module, `super::` is the crate root: a way around the table.
            let single_file = path.parent() == Some(root().join("src").as_path());
            if single_file && code.contains("super::") && !code.contains("use super::*") {
                violations.push(format!("{}:{line}: `super::` from a top-level module", path.display()));
            }
        }
    }
    assert!(violations.is_empty(), "imports against ARCHITECTURE.md's dependency order:\n{}", violations.join("\n"));
}

#[test]
fn the_declared_dependency_order_has_no_cycle() {
    let allowed = allowed();
    // Kahn's algorithm: repeatedly remove modules whose allowed imports are all removed.
    let mut left: BTreeMap<&String, &BTreeSet<String>> = allowed.iter().collect();
    while !left.is_empty() {
        let ready: Vec<&String> =
            left.iter().filter(|(_, deps)| deps.iter().all(|d| !left.contains_key(d))).map(|(m, _)| *m).collect();
        assert!(!ready.is_empty(), "cycle among {:?}", left.keys().collect::<Vec<_>>());
        for m in ready {
            left.remove(m);
        }
    }
    for (m, deps) in &allowed {
        for d in deps {
            assert!(allowed.contains_key(d), "`{m}` may import `{d}`, which is not a module of the table");
        }
    }
}

#[test]
fn pest_stays_inside_design_and_report_reads_no_file() {
    for path in all_sources() {
        let module = module_of(&path);
        for (line, code) in code_lines(&path) {
            if module != "design" {
                assert!(!code.contains("pest"), "{}:{line}: pest outside design", path.display());
            }
            if module == "report" || module == "analysis" {
                for read in ["fs::read", "File::open", "read_dir", "read_to_string"] {
                    assert!(!code.contains(read), "{}:{line}: `{module}` reads a file", path.display());
                }
            }
        }
    }
}

#[test]
fn lib_rs_declares_modules_and_conveniences_only() {
    let lib: Vec<String> = code_lines(&root().join("src/lib.rs")).into_iter().map(|(_, l)| l).collect();
    let conveniences = [
        "pub fn analyze_files(",
        "pub fn analyze_with(",
        "pub fn analyze_family_files(",
        "pub fn analyze_family_with(",
        "pub fn analyze_study(",
    ];
    let fns: Vec<&String> =
        lib.iter().filter(|l| l.contains("fn ") && !conveniences.iter().any(|c| l.contains(c))).collect();
    assert!(fns.is_empty(), "lib.rs holds functions beyond the analyze conveniences: {fns:?}");
    assert!(!lib.iter().any(|l| l.contains("std::fs")), "lib.rs touches files");
}

/// The module path of a source file below `src` (`analysis::unit` for
/// `analysis/unit/mod.rs`, empty for `lib.rs`).
fn module_path(src: &Path, path: &Path) -> Vec<String> {
    let rel = path.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|l| l == "mod" || l == "lib") {
        parts.pop();
    }
    parts
}

/// Every path a line names through `crate::` or `super::` (groups
/// `{a::b, c}` one level deep), each as (how many `super::`, or None for
/// `crate::`; its segments).
fn paths_named(line: &str) -> Vec<(Option<usize>, Vec<String>)> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let segments = |s: &str| -> Vec<String> {
        s.split("::")
            .map(|p| p.trim().chars().take_while(|c| ident(*c)).collect::<String>())
            .take_while(|p| !p.is_empty())
            .collect()
    };
    let mut out = Vec::new();
    let mut at = 0;
    while at < line.len() {
        let rest = &line[at..];
        let (Some(k), prefix) = [rest.find("crate::"), rest.find("super::")]
            .into_iter()
            .enumerate()
            .filter_map(|(i, k)| k.map(|k| (k, i)))
            .min()
            .map_or((None, 0), |(k, i)| (Some(k), i))
        else {
            break;
        };
        if line[..at + k].chars().last().is_some_and(ident) {
            at += k + 7;
            continue;
        }
        let mut tail = &rest[k..];
        let supers = if prefix == 1 {
            let mut n = 0;
            while let Some(t) = tail.strip_prefix("super::") {
                n += 1;
                tail = t;
            }
            Some(n)
        } else {
            tail = &tail["crate::".len()..];
            None
        };
        // `a::b::{c::D, e}`: the prefix, then each item of the group.
        let (head, group) = match tail.find('{') {
            Some(b) if tail[..b].chars().all(|c| ident(c) || c == ':') => (&tail[..b], Some(&tail[b + 1..])),
            _ => (tail, None),
        };
        let prefix = segments(head);
        match group {
            Some(group) => {
                for item in group.split('}').next().unwrap_or("").split(',') {
                    out.push((supers, prefix.iter().cloned().chain(segments(item)).collect()));
                }
            }
            None => out.push((supers, prefix)),
        }
        at = line.len() - tail.len();
    }
    out
}

/// Imports between the source files of one crate (`src` its source
/// folder): each file to the files whose items it names, by the longest
/// module prefix of each path. `#[cfg(test)]` modules are left out (their
/// `super::` is the file itself).
fn file_imports(src: &Path) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let by_module: BTreeMap<Vec<String>, PathBuf> = files.iter().map(|p| (module_path(src, p), p.clone())).collect();
    let mut out = BTreeMap::new();
    for path in &files {
        let me = module_path(src, path);
        let mut named = BTreeSet::new();
        for (_, line) in code_lines(path).into_iter().take_while(|(_, l)| !l.contains("#[cfg(test)]")) {
            for (supers, segs) in paths_named(&line) {
                let mut full: Vec<String> = match supers {
                    None => Vec::new(),
                    Some(n) => me[..me.len().saturating_sub(n)].to_vec(),
                };
                full.extend(segs);
                let target = (1..=full.len()).rev().find_map(|k| by_module.get(&full[..k]));
                if let Some(t) = target.filter(|t| *t != path) {
                    named.insert(t.clone());
                }
            }
        }
        out.insert(path.clone(), named);
    }
    out
}

/// A cycle of the graph, as the files in order, if it has one.
fn a_cycle(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Option<Vec<PathBuf>> {
    fn visit<'a>(
        v: &'a PathBuf,
        graph: &'a BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        state: &mut BTreeMap<&'a PathBuf, u8>,
        stack: &mut Vec<&'a PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        state.insert(v, 1);
        stack.push(v);
        for w in graph.get(v).into_iter().flatten() {
            match state.get(w).copied().unwrap_or(0) {
                1 => {
                    let from = stack.iter().position(|x| *x == w).unwrap_or(0);
                    return Some(stack[from..].iter().map(|p| (*p).clone()).collect());
                }
                0 => {
                    if let Some(c) = visit(w, graph, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(v, 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in graph.keys() {
        if !state.contains_key(v) {
            if let Some(c) = visit(v, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn the_cycle_finder_finds_a_circle_of_files() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path();
    std::fs::create_dir_all(src.join("a")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod a;\n").unwrap();
    std::fs::write(src.join("a/mod.rs"), "mod x;\nmod y;\n").unwrap();
    std::fs::write(src.join("a/x.rs"), "use super::y::Y;\npub struct X;\n").unwrap();
    std::fs::write(
        src.join("a/y.rs"),
        "use crate::a::{x::X, y};\npub struct Y;\n#[cfg(test)]\nmod tests { use super::*; }\n",
    )
    .unwrap();
    let graph = file_imports(src);
    assert_eq!(graph[&src.join("a/x.rs")], BTreeSet::from([src.join("a/y.rs")]));
    assert_eq!(graph[&src.join("a/y.rs")], BTreeSet::from([src.join("a/x.rs")]));
    assert!(a_cycle(&graph).is_some_and(|c| c.len() == 2));
    std::fs::write(src.join("a/y.rs"), "pub struct Y;\n").unwrap();
    assert_eq!(a_cycle(&file_imports(src)), None);
}

/// No two source files import each other, directly or round a longer
/// circle, in the crate or in its statistics crate: each file can be read
/// after the files it imports.
#[test]
fn no_source_files_import_each_other_round_a_circle() {
    for src in [root().join("src"), root().join("crates/stats/src")] {
        let graph = file_imports(&src);
        let edges: usize = graph.values().map(BTreeSet::len).sum();
        assert!(graph.len() > 10 && edges > graph.len(), "{}: {} files, {edges} imports", src.display(), graph.len());
        if let Some(cycle) = a_cycle(&graph) {
            let names: Vec<String> =
                cycle.iter().map(|p| p.strip_prefix(root()).unwrap().display().to_string()).collect();
            panic!("source files import each other round a circle: {} -> (back to the first)", names.join(" -> "));
        }
    }
}

/// A design is compiled in one place: `plan::compile` is called only inside
/// `plan/` (by `compile_study`, level by level), and `compile_study` only
/// where a design is loaded: each front end (the binary's subcommands, the
/// Python package, lib.rs's conveniences), and the two runners that reopen
/// a design copy they wrote (a Slurm task, a scoring of an export). Every
/// other stage is handed the `StudyPlan` or one of its plans.
#[test]
fn a_design_is_compiled_only_by_the_study_stage_and_once_per_front_end() {
    let mut files = all_sources();
    rust_files(&root().join("python/src"), &mut files);
    let loaders = [
        "src/lib.rs",
        "src/bin/crossaudit/main.rs",
        "src/bin/crossaudit/methods.rs",
        "src/bin/crossaudit/external.rs",
        "python/src/lib.rs",
        "src/run/slurm/mod.rs",
        "src/run/external/levels.rs",
        "src/run/external/score.rs",
    ];
    let (mut compiles, mut studies) = (Vec::new(), Vec::new());
    for path in &files {
        let rel = path.strip_prefix(root()).unwrap().to_string_lossy().replace('\\', "/");
        let in_plan = rel.starts_with("src/plan/");
        for (line, code) in code_lines(path) {
            if calls_compile(&code) && !in_plan {
                compiles.push(format!("{rel}:{line}: {}", code.trim()));
            }
            if code.contains("compile_study(")
                && !code.contains("fn compile_study(")
                && !loaders.contains(&rel.as_str())
            {
                studies.push(format!("{rel}:{line}: {}", code.trim()));
            }
        }
    }
    assert!(
        compiles.is_empty(),
        "`compile` called outside plan/ (call `compile_study` once and pass it on):\n{}",
        compiles.join("\n")
    );
    assert!(studies.is_empty(), "`compile_study` called where no design is loaded:\n{}", studies.join("\n"));
    // And each of the binary's subcommands compiles at most once: no
    // function of a front end holds two calls.
    for rel in &loaders[..5] {
        let text = std::fs::read_to_string(root().join(rel)).unwrap();
        for f in text.split("\nfn ").chain(text.split("\npub fn ")).chain(text.split("\npub(crate) fn ")) {
            let body = f.split("\n}\n").next().unwrap_or("");
            assert!(body.matches("compile_study(").count() <= 1, "{rel}: a function compiles twice:\n{body}");
        }
    }
}

/// Whether a line calls `compile(`: not preceded by an identifier
/// character (so neither `compile_study(` nor `recompile(`), and not its
/// definition.
fn calls_compile(l: &str) -> bool {
    l.match_indices("compile(")
        .any(|(k, _)| !l[..k].ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_') && !l[..k].ends_with("fn "))
}

/// The check above is not vacuous: it sees a `compile` call in stage
/// code, however it is named, and nothing else.
#[test]
fn the_compile_check_would_see_a_stray_call() {
    assert!(calls_compile("let p = crate::plan::compile(&d);"));
    assert!(calls_compile("let p = crossaudit::compile(&file.design);"));
    assert!(calls_compile("use crate::plan::compile; let p = compile(&d);"));
    assert!(!calls_compile("let s = crate::plan::compile_study(&d);"));
    assert!(!calls_compile("pub fn compile(design: &Design) -> Plan {"));
    assert!(!calls_compile("let r = recompile(&d);"));
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("x.rs");
    std::fs::write(&file, "/// crate::plan::compile(&d) in a doc\nfn f() { let p = crate::plan::compile(&d); }\n")
        .unwrap();
    let lines = code_lines(&file);
    assert_eq!(lines.len(), 1, "the doc line is not code");
    assert!(calls_compile(&lines[0].1));
}

/// Every function of the library's source (tests modules aside) with its
/// length in lines, as `path::name`: a `fn` line up to the `}` at its own
/// indentation (rustfmt's layout).
fn function_lengths() -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for path in all_sources() {
        let text = std::fs::read_to_string(&path).unwrap();
        let rel = path.strip_prefix(root()).unwrap().to_string_lossy().replace('\\', "/");
        let lines: Vec<&str> = text.lines().collect();
        let tests_from = lines.iter().position(|l| l.trim() == "#[cfg(test)]").unwrap_or(lines.len());
        let mut i = 0;
        while i < tests_from {
            let l = lines[i];
            let body = l.trim_start();
            let indent = &l[..l.len() - body.len()];
            let after_vis = body
                .strip_prefix("pub ")
                .or_else(|| body.split_once(") ").map(|(_, r)| r).filter(|_| body.starts_with("pub(")));
            let rest = after_vis.unwrap_or(body);
            let rest = rest.strip_prefix("const ").unwrap_or(rest);
            if let Some(sig) = rest.strip_prefix("fn ") {
                let name: String = sig.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                let close = format!("{indent}}}");
                // A body on the signature's line (`fn start(&self) {}`) is
                // one line: its closing brace is not a later line's.
                let one_line = l.trim_end().ends_with('}') && l.contains('{');
                if one_line {
                    out.entry(format!("{rel}::{name}")).or_insert(1);
                } else if let Some(end) = (i + 1..lines.len()).find(|&j| lines[j] == close) {
                    if !l.trim_end().ends_with(';') {
                        let key = format!("{rel}::{name}");
                        let n = end - i + 1;
                        let e = out.entry(key).or_insert(0);
                        *e = (*e).max(n);
                        i = end;
                    }
                }
            }
            i += 1;
        }
    }
    out
}

/// No function of the library's source grows past 80 lines: those longer
/// today are listed with their length in `tests/long_functions.txt`, which
/// may only shrink (a listed function that got shorter is listed at its
/// new length, one at 80 lines or fewer leaves the list).
#[test]
fn no_function_grows_past_80_lines() {
    const MAX: usize = 80;
    let listed: BTreeMap<String, usize> = std::fs::read_to_string(root().join("tests/long_functions.txt"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (n, f) = l.trim().split_once(' ').unwrap();
            (f.to_string(), n.parse().unwrap())
        })
        .collect();
    let now = function_lengths();
    let mut wrong = Vec::new();
    for (f, &n) in now.iter().filter(|(_, &n)| n > MAX) {
        match listed.get(f) {
            None => wrong.push(format!("{f} has {n} lines (more than {MAX}): split it")),
            Some(&was) if n > was => wrong.push(format!("{f} grew from {was} to {n} lines: split it")),
            Some(&was) if n < was => wrong.push(format!("{f} is {n} lines now: list it at {n}, not {was}")),
            _ => {}
        }
    }
    for (f, was) in &listed {
        if now.get(f).is_none_or(|&n| n <= MAX) {
            wrong.push(format!("{f} (listed at {was}) is gone or {MAX} lines or fewer: remove it from the list"));
        }
    }
    assert!(wrong.is_empty(), "tests/long_functions.txt:\n{}", wrong.join("\n"));
    assert!(now.len() > 1000, "the finder found {} functions", now.len());
}
