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
        let import = line.contains("crate::") || line.trim_start().starts_with("use ") || line.contains(" use ");
        open = import && line.matches('{').count() > line.matches('}').count();
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
        let (Some(k), prefix) = [rest.find("crate::"), rest.find("super::"), rest.find("self::")]
            .into_iter()
            .enumerate()
            .filter_map(|(i, k)| k.map(|k| (k, i)))
            .min()
            .map_or((None, 0), |(k, i)| (Some(k), i))
        else {
            break;
        };
        if line[..at + k].chars().last().is_some_and(ident) {
            at += k + 5;
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
        } else if prefix == 2 {
            tail = &tail["self::".len()..];
            Some(0)
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

/// The child modules a file declares (`mod x;`, `pub(crate) mod x;`).
fn children(path: &Path) -> BTreeSet<String> {
    code_lines(path)
        .into_iter()
        .filter_map(|(_, l)| {
            let l = l.trim();
            let rest = l.strip_prefix("mod ").or_else(|| l.split_once(" mod ").map(|(_, r)| r))?;
            let name = rest.strip_suffix(';')?;
            name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_').then(|| name.to_string())
        })
        .collect()
}

/// `line` with every path that starts at a child module (`record::X`, as
/// a parent names its children's items) written from `self::`.
fn with_self(line: &str, children: &BTreeSet<String>) -> String {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = String::new();
    let mut at = 0;
    while at < line.len() {
        let rest = &line[at..];
        let starts = !line[..at].chars().last().is_some_and(|c| ident(c) || c == ':');
        let child = children.iter().find(|c| rest.starts_with(&format!("{c}::")));
        match (starts, child) {
            (true, Some(c)) => {
                out.push_str("self::");
                out.push_str(c);
                at += c.len();
            }
            _ => {
                let ch = rest.chars().next().unwrap_or(' ');
                out.push(ch);
                at += ch.len_utf8();
            }
        }
    }
    out
}

/// A crate's modules: each module path's file, the child modules each
/// file declares, and what each module imports (`use`, of any visibility,
/// which its children see too): the item's name to the absolute path it
/// names.
struct Modules {
    files: BTreeMap<Vec<String>, PathBuf>,
    children: BTreeMap<PathBuf, BTreeSet<String>>,
    reexports: BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>>,
    /// The items each module's file defines at its top level.
    items: BTreeMap<Vec<String>, BTreeSet<String>>,
    /// The modules each module imports whole (`use x::*`).
    globs: BTreeMap<Vec<String>, Vec<Vec<String>>>,
}

/// Whether a code line re-exports (`pub use`, of any visibility).
fn re_exports(line: &str) -> bool {
    let t = line.trim_start();
    t.starts_with("pub use ")
        || t.starts_with("pub(crate) use ")
        || t.starts_with("pub(super) use ")
        || (t.starts_with("pub(in ") && t.contains(") use "))
}

/// The name of the item a top-level line defines (`pub fn f(`, `struct S`).
fn item_defined(line: &str) -> Option<String> {
    if line.starts_with(char::is_whitespace) {
        return None;
    }
    let mut words = line.split_whitespace().skip_while(|w| w.starts_with("pub") || *w == "async" || *w == "unsafe");
    match words.next()? {
        "fn" | "struct" | "enum" | "const" | "static" | "type" | "trait" | "union" => {}
        _ => return None,
    }
    let name: String = words.next()?.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
    (!name.is_empty()).then_some(name)
}

impl Modules {
    fn read(src: &Path) -> Modules {
        let mut files = Vec::new();
        rust_files(src, &mut files);
        let mut m = Modules {
            files: BTreeMap::new(),
            children: BTreeMap::new(),
            reexports: BTreeMap::new(),
            items: BTreeMap::new(),
            globs: BTreeMap::new(),
        };
        for p in &files {
            m.files.insert(module_path(src, p), p.clone());
            m.children.insert(p.clone(), children(p));
        }
        for p in &files {
            let me = module_path(src, p);
            for (_, line) in m.lines(p) {
                if let Some(item) = item_defined(&line) {
                    m.items.entry(me.clone()).or_default().insert(item);
                }
                // Any `use` names its item in this module (a child sees
                // its parent's private imports too).
                let t = line.trim_start();
                if !(re_exports(&line) || t.starts_with("use ")) {
                    continue;
                }
                for full in paths_of(&me, &line) {
                    let Some(item) = full.last() else { continue };
                    if line.contains("::*") && m.files.contains_key(&full) {
                        m.globs.entry(me.clone()).or_default().push(full.clone());
                    } else {
                        m.reexports.entry(me.clone()).or_default().insert(item.clone(), full.clone());
                    }
                }
            }
        }
        m
    }

    /// A file's code lines, its children's paths written from `self::`,
    /// `#[cfg(test)]` modules left out (their `super::` is the file itself).
    fn lines(&self, path: &Path) -> Vec<(usize, String)> {
        let none = BTreeSet::new();
        let children = self.children.get(path).unwrap_or(&none);
        code_lines(path)
            .into_iter()
            .take_while(|(_, l)| !l.contains("#[cfg(test)]"))
            .map(|(k, l)| (k, with_self(&l, children)))
            .collect()
    }

    /// The file that defines what the absolute path `full` names: the file
    /// of its longest module prefix, or, where that module re-exports the
    /// next segment, the file the re-export names (followed up to 8 times).
    fn resolve(&self, full: &[String], depth: usize) -> Option<&PathBuf> {
        let k = (1..=full.len()).rev().find(|&k| self.files.contains_key(&full[..k]))?;
        let named = |m: &[String], item: &String| {
            self.items.get(m).is_some_and(|i| i.contains(item))
                || self.reexports.get(m).is_some_and(|r| r.contains_key(item))
        };
        let through_glob = |item: &String| -> Option<Vec<String>> {
            let globs = self.globs.get(&full[..k])?;
            let g = globs.iter().find(|g| named(g, item))?;
            Some(g.iter().chain([item]).cloned().collect())
        };
        let via = full.get(k).and_then(|item| {
            self.reexports.get(&full[..k]).and_then(|r| r.get(item)).cloned().or_else(|| through_glob(item))
        });
        let via = via.as_ref();
        match via {
            Some(target) if depth < 8 && target.as_slice() != full => {
                let next: Vec<String> = target.iter().chain(&full[k + 1..]).cloned().collect();
                self.resolve(&next, depth + 1).or_else(|| self.files.get(&full[..k]))
            }
            _ => self.files.get(&full[..k]),
        }
    }
}

/// The absolute paths (from the crate root) a line of module `me` names.
fn paths_of(me: &[String], line: &str) -> Vec<Vec<String>> {
    paths_named(line)
        .into_iter()
        .map(|(supers, segs)| {
            let mut full: Vec<String> = match supers {
                None => Vec::new(),
                Some(n) => me[..me.len().saturating_sub(n)].to_vec(),
            };
            full.extend(segs);
            full
        })
        .collect()
}

/// Imports between the source files of one crate (`src` its source
/// folder): each file to the files that define the items it names (a
/// path through a re-export followed to the file that defines the item;
/// a parent's `child::` paths read as its children's).
fn file_imports(src: &Path) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let modules = Modules::read(src);
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = BTreeMap::new();
    for (me, path) in &modules.files {
        let mut named = BTreeSet::new();
        let lines = modules.lines(path);
        // Every word of the file that can name an imported item (not a
        // method, `.f(`, nor a path's later segment, `a::f`), for what a
        // glob import (`use super::*`) takes.
        let words: BTreeSet<&str> = lines
            .iter()
            .flat_map(|(_, l)| {
                let mut out = Vec::new();
                let mut start = None;
                for (k, c) in l.char_indices().chain([(l.len(), ' ')]) {
                    match (ident(c), start) {
                        (true, None) => start = Some(k),
                        (false, Some(b)) => {
                            let before = &l[..b];
                            if !before.ends_with('.') && !before.ends_with("::") {
                                out.push(&l[b..k]);
                            }
                            start = None;
                        }
                        _ => {}
                    }
                }
                out
            })
            .collect();
        for (_, line) in &lines {
            // A re-export is no use of the item: its users import its file.
            if re_exports(line) {
                continue;
            }
            for full in paths_of(me, line) {
                let glob = line.contains("::*") && modules.files.contains_key(&full);
                let targets: Vec<Vec<String>> = if glob {
                    // The glob's module's items that the file names.
                    let none = BTreeSet::new();
                    let items = modules.items.get(&full).unwrap_or(&none);
                    let re: BTreeSet<String> =
                        modules.reexports.get(&full).map(|r| r.keys().cloned().collect()).unwrap_or_default();
                    // A name the file defines itself shadows the glob's.
                    let own = modules.items.get(me).cloned().unwrap_or_default();
                    items
                        .iter()
                        .chain(&re)
                        .filter(|i| words.contains(i.as_str()) && !own.contains(*i))
                        .map(|i| full.iter().cloned().chain([i.clone()]).collect())
                        .collect()
                } else {
                    vec![full]
                };
                for t in targets {
                    if let Some(t) = modules.resolve(&t, 0).filter(|t| *t != path) {
                        named.insert(t.clone());
                    }
                }
            }
        }
        out.insert(path.clone(), named);
    }
    out
}

/// The graph's circles: each set of files that all reach each other
/// (a strongly connected component of more than one file), by Tarjan's
/// algorithm.
fn circles(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<Vec<PathBuf>> {
    struct T<'a> {
        graph: &'a BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        index: BTreeMap<&'a PathBuf, (usize, usize)>,
        stack: Vec<&'a PathBuf>,
        on: BTreeSet<&'a PathBuf>,
        out: Vec<Vec<PathBuf>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a PathBuf) {
        let n = t.index.len();
        t.index.insert(v, (n, n));
        t.stack.push(v);
        t.on.insert(v);
        let graph = t.graph;
        for w in graph.get(v).into_iter().flatten() {
            if !t.index.contains_key(w) {
                visit(t, w);
                let low = t.index[w].1.min(t.index[v].1);
                t.index.get_mut(v).unwrap().1 = low;
            } else if t.on.contains(w) {
                let low = t.index[w].0.min(t.index[v].1);
                t.index.get_mut(v).unwrap().1 = low;
            }
        }
        if t.index[v].0 == t.index[v].1 {
            let mut c = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                c.push(w.clone());
                if w == v {
                    break;
                }
            }
            if c.len() > 1 {
                c.sort();
                t.out.push(c);
            }
        }
    }
    let mut t = T { graph, index: BTreeMap::new(), stack: Vec::new(), on: BTreeSet::new(), out: Vec::new() };
    for v in graph.keys() {
        if !t.index.contains_key(v) {
            visit(&mut t, v);
        }
    }
    t.out
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

/// The finder sees a circle through a re-export (`super::Y` named where
/// the parent only re-exports `y::Y`) and through a parent's `child::`
/// path, and sees none where the re-export leads away from the circle.
#[test]
fn the_cycle_finder_follows_re_exports_and_a_parent_s_child_paths() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path();
    std::fs::create_dir_all(src.join("a")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod a;\npub mod b;\n").unwrap();
    std::fs::write(src.join("b.rs"), "pub struct B;\n").unwrap();
    std::fs::write(src.join("a/mod.rs"), "mod x;\nmod y;\npub use y::{\n    Y,\n};\npub use crate::b::B;\n").unwrap();
    std::fs::write(src.join("a/x.rs"), "use super::Y;\npub struct X;\n").unwrap();
    std::fs::write(src.join("a/y.rs"), "pub struct Y(super::x::X);\n").unwrap();
    let graph = file_imports(src);
    assert_eq!(graph[&src.join("a/x.rs")], BTreeSet::from([src.join("a/y.rs")]));
    assert!(a_cycle(&graph).is_some_and(|c| c.len() == 2), "{graph:?}");
    // A parent naming its child's item by `child::` imports that file.
    std::fs::write(src.join("a/y.rs"), "pub struct Y;\n").unwrap();
    std::fs::write(src.join("a/x.rs"), "use super::B;\npub fn g() {}\n").unwrap();
    let graph = file_imports(src);
    assert_eq!(graph[&src.join("a/x.rs")], BTreeSet::from([src.join("b.rs")]));
    assert_eq!(a_cycle(&graph), None);
    std::fs::write(src.join("a/mod.rs"), "mod x;\nmod y;\npub use y::Y;\npub fn f() { x::g() }\n").unwrap();
    std::fs::write(src.join("a/x.rs"), "pub fn g() { super::f() }\n").unwrap();
    let graph = file_imports(src);
    assert!(graph[&src.join("a/mod.rs")].contains(&src.join("a/x.rs")), "{graph:?}");
    assert!(a_cycle(&graph).is_some_and(|c| c.len() == 2), "{graph:?}");
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
        let circles = circles(&graph);
        let shown: Vec<String> = circles
            .iter()
            .map(|c| {
                let names: Vec<String> =
                    c.iter().map(|p| p.strip_prefix(root()).unwrap().display().to_string()).collect();
                let one = a_cycle(
                    &graph
                        .iter()
                        .filter(|(k, _)| c.contains(k))
                        .map(|(k, v)| (k.clone(), v.iter().filter(|w| c.contains(w)).cloned().collect()))
                        .collect(),
                );
                let round: Vec<String> = one
                    .unwrap_or_default()
                    .iter()
                    .map(|p| p.strip_prefix(root()).unwrap().display().to_string())
                    .collect();
                let rel = |p: &PathBuf| p.strip_prefix(root()).unwrap().display().to_string();
                let arrows: Vec<String> = c
                    .iter()
                    .flat_map(|a| {
                        graph[a].iter().filter(|b| c.contains(b)).map(move |b| format!("{} -> {}", rel(a), rel(b)))
                    })
                    .collect();
                format!(
                    "{} files: {}\n  e.g. {} -> (back to the first)\n  arrows: {}",
                    c.len(),
                    names.join(", "),
                    round.join(" -> "),
                    arrows.join("; ")
                )
            })
            .collect();
        assert!(
            shown.is_empty(),
            "source files import each other round {} circle(s):\n{}",
            shown.len(),
            shown.join("\n")
        );
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
        "src/bin/crossaudit/design_file.rs",
        "src/bin/crossaudit/methods.rs",
        "src/bin/crossaudit/external.rs",
        "python/src/lib.rs",
        "src/run/slurm/mod.rs",
        "src/run/external/levels.rs",
        "src/run/external/score.rs",
        // The reader of a combined folder reopens each combined run's design.
        "src/run/combine.rs",
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
    for rel in &loaders[..6] {
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
    let mut files = all_sources();
    rust_files(&root().join("crates/stats/src"), &mut files);
    for path in files {
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
                // A declaration without a body (a trait's method), whose
                // signature may run over several lines: it ends with `;`
                // before any line opens a body.
                let declared = lines[i..]
                    .iter()
                    .map(|s| s.trim_end())
                    .find(|s| s.ends_with(';') || s.ends_with('{'))
                    .is_some_and(|s| s.ends_with(';'));
                if declared {
                    // Nothing to measure.
                } else if one_line {
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

/// No function of the library's source (or the statistics crate's) grows
/// past 80 lines: those longer are listed with their length and why in
/// `tests/long_functions.txt`, which
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
            // `LENGTH PATH::FUNCTION  # why`
            let entry = l.split('#').next().unwrap_or("").trim();
            let (n, f) = entry.split_once(' ').unwrap();
            (f.trim().to_string(), n.parse().unwrap())
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

/// The fields of the analysis types (`Analysis`, `FamilyAnalysis`,
/// `MultiverseAnalysis` and their parts: every struct of their files)
/// that no struct outside `analysis/` also has.
fn analysis_fields() -> BTreeSet<String> {
    let field = |l: &str| -> Option<String> {
        let rest = l.strip_prefix("    ")?;
        let rest = match rest.strip_prefix("pub") {
            Some(r) if r.starts_with('(') => r.split_once(") ")?.1,
            Some(r) => r.strip_prefix(' ')?,
            None => rest,
        };
        let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
        // Names of one or two letters (`d`, `z`) are too common to trace.
        (rest[name.len()..].starts_with(':') && name.len() > 2).then_some(name)
    };
    let fields_of = |path: &Path| -> BTreeSet<String> {
        let text = std::fs::read_to_string(path).unwrap();
        let mut inside = false;
        let mut out = BTreeSet::new();
        for l in text.lines() {
            if l.contains("struct ") && l.ends_with('{') && !l.starts_with(' ') {
                inside = true;
            } else if l == "}" {
                inside = false;
            } else if inside {
                out.extend(field(l));
            }
        }
        out
    };
    let src = root().join("src");
    let mut ours = BTreeSet::new();
    for f in [
        "analysis/types/mod.rs",
        "analysis/types/decision.rs",
        "analysis/family/types.rs",
        "analysis/multiverse/types.rs",
        "analysis/standing.rs",
    ] {
        ours.extend(fields_of(&src.join(f)));
    }
    for path in all_sources().into_iter().filter(|p| !p.starts_with(src.join("analysis"))) {
        for f in fields_of(&path) {
            ours.remove(&f);
        }
    }
    ours
}

/// The lines of `text` that assign to, or mutate in place, one of
/// `fields` (`x.field = `, `x.field.push(`, `x.field.extend(` ...), or
/// take an analysis by `&mut`.
fn analysis_mutations(text: &str, fields: &BTreeSet<String>) -> Vec<String> {
    let mutators = ["push(", "extend(", "insert(", "retain(", "clear(", "append(", "splice(", "truncate(", "sort"];
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        for f in fields {
            for (at, _) in code.match_indices(&format!(".{f}")) {
                let rest = &code[at + f.len() + 1..];
                if rest.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_') {
                    continue;
                }
                let assigned = rest.trim_start().starts_with('=') && !rest.trim_start().starts_with("==");
                let mutated = rest.strip_prefix('.').is_some_and(|m| mutators.iter().any(|x| m.starts_with(x)));
                let compound = ["+=", "-=", "|=", "&="].iter().any(|op| rest.trim_start().starts_with(op));
                if assigned || mutated || compound {
                    out.push(format!("{}: {}", k + 1, code.trim()));
                }
            }
        }
        for t in ["&mut Analysis", "&mut FamilyAnalysis", "&mut MultiverseAnalysis", "&mut StudyAnalysis"] {
            if code.contains(t) && !code.contains(&format!("{t}Error")) {
                out.push(format!("{}: {}", k + 1, code.trim()));
            }
        }
        // An analysis held mutably: `let mut x = ...analyze...(` or a
        // wrapped one (`StudyAnalysis::Single(...)`).
        let held = code.trim_start().strip_prefix("let mut ").is_some_and(|r| {
            let value = r.split_once('=').map_or("", |(_, v)| v);
            value.contains("analyze") || value.contains("Analysis::")
        });
        if held {
            out.push(format!("{}: {}", k + 1, code.trim()));
        }
    }
    out
}

/// The analysis is computed in `analysis/` alone: no file outside it (the
/// run, the report, the binary, the Python package) assigns to a field of
/// an analysis type or takes one by `&mut`; a run and a reanalysis
/// therefore report the same analysis.
#[test]
fn no_analysis_field_is_assigned_outside_analysis() {
    let fields = analysis_fields();
    // (Fields that a struct outside analysis/ also has, `coverage` or
    // `decision`, are left to the `&mut` and `let mut` checks.)
    for f in ["warnings", "figures", "standing", "provenance", "margins", "covered_only", "sources"] {
        assert!(fields.contains(f), "`{f}` is not read as an analysis field: {fields:?}");
    }
    let mut files = all_sources();
    rust_files(&root().join("python/src"), &mut files);
    let mut found = Vec::new();
    for path in files.iter().filter(|p| !p.starts_with(root().join("src/analysis"))) {
        let text = std::fs::read_to_string(path).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        let rel = path.strip_prefix(root()).unwrap().display().to_string();
        found.extend(analysis_mutations(code, &fields).into_iter().map(|l| format!("{rel}:{l}")));
    }
    assert!(found.is_empty(), "analysis fields assigned outside analysis/:\n{}", found.join("\n"));
    // The check sees what it looks for.
    let planted = "fn f(a: &mut Analysis) {\n    a.warnings.push(w);\n    a.standing = Standing::Unrecorded;\n    x.figures.len();\n    let mut b = analysis::analyze(p, c, o)?;\n}\n";
    assert_eq!(analysis_mutations(planted, &fields).len(), 4, "{:?}", analysis_mutations(planted, &fields));
}

/// The public types (`pub struct`, `pub enum`) of `src/` and the statistics
/// crate, each name once over both: two things are never both called
/// `Role` or `Prepared`, so a reader who sees a name knows which it is.
#[test]
fn every_public_type_has_a_name_of_its_own() {
    let mut files = all_sources();
    rust_files(&root().join("crates/stats/src"), &mut files);
    let mut seen: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for f in &files {
        for l in std::fs::read_to_string(f).unwrap().lines() {
            let Some(rest) = l.strip_prefix("pub struct ").or_else(|| l.strip_prefix("pub enum ")) else {
                continue;
            };
            let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            seen.entry(name).or_default().push(f.strip_prefix(root()).unwrap().display().to_string());
        }
    }
    assert!(seen.len() > 200, "only {} public types found", seen.len());
    let twice: Vec<String> =
        seen.iter().filter(|(_, at)| at.len() > 1).map(|(n, at)| format!("{n}: {}", at.join(", "))).collect();
    assert!(twice.is_empty(), "public types sharing a name:\n{}", twice.join("\n"));
}
