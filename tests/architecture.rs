//! The house's import rules, read from the source (the crates' layering
//! as in docs/dev/architecture.md).
//!
//! `ezy-core` is built in floors: an item is imported only from its own
//! floor or one below, never from above, and the modules of one floor
//! import each other without a circle. Every `crate::` path (in `use`
//! lines and in code, not in comments or unit tests) is read and:
//!
//! - a path into a higher floor fails, naming the file, the line and the
//!   two floors;
//! - a circle between modules fails, naming it;
//! - a path through a re-export (the crate root's `pub use`, or a
//!   module's `pub use` of a submodule's item) fails, naming the module
//!   that defines the item: inside the crate, everything is named where it
//!   is defined, so that reading an import tells where to look.
//!
//! The checker is a function of the files' text, and is itself tested on
//! a synthetic file that imports one floor up
//! (`an_import_up_a_floor_is_refused`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The floors of `ezy-core`, bottom up: a module path (relative to
/// `crate`) and its floor. A file belongs to the longest module path
/// here that is a prefix of its own.
const CORE_FLOORS: &[(&str, u32)] = &[
    // floor 0: what everything else speaks (names, numbers, settings, errors)
    ("names", 0),
    ("settings", 0),
    ("error", 0),
    ("scalar", 0),
    ("files", 0),
    // floor 1: what a model is (data) and the integrators (which see an
    // `Rhs` and a `NewtonSystem`, never the dynamics)
    ("model::info", 1),
    ("integrator", 1),
    // floor 2: forces and drives
    ("effects", 2),
    ("drive", 2),
    // floor 3: the trait generated models implement
    ("model", 3),
    // floor 4: linear algebra of the KKT system, event specs (data)
    ("kkt", 4),
    ("events", 4),
    // a model read from text (implements the trait)
    ("text", 4),
    // floor 5: the equations a run integrates
    ("formulation", 5),
    // floor 6: the step loop
    ("simulate", 6),
    // floor 7: what a user holds
    ("problem", 7),
    ("analysis", 7),
    ("erased", 7),
    // floor 8: built on what a user holds (a problem, its analysis)
    ("sensitivity", 8),
    // the geometry of locomotion (a model, its forces, a simulated gait)
    ("geometry", 8),
    // floor 9: design questions on the sensitivities (fits)
    ("design", 9),
];

/// The floors of the `ezy` crate (`src/`): what the commands share
/// (`session`) sits above what writes files and draws (`output`,
/// `render`, which import no command and no session), the work the
/// commands call (the run, the precision ladder, sweeps) above that, the
/// catalog of models and scenes (`app`) and the shared argument parsers
/// (`cli`) next, then the commands, and on top the dispatch that looks a
/// command up in their table (`app::dispatch`), as in cargo's
/// `src/bin/cargo/`.
const EZY_FLOORS: &[(&str, u32)] = &[
    ("output", 0),
    ("testing", 0),
    ("render", 1),
    ("session", 2),
    ("run", 3),
    ("precision", 3),
    ("sweep", 3),
    ("cli", 4),
    ("app", 4),
    ("commands", 5),
    ("app::dispatch", 6),
];

/// One source file: its module path (`formulation::dae`) and its text.
struct Source {
    module: String,
    file: PathBuf,
    text: String,
}

/// A broken rule, as the failure message prints it.
type Violation = String;

fn read_crate(src: &Path) -> Vec<Source> {
    let mut out = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
                if parts.last().is_some_and(|p| p == "mod" || p == "lib" || p == "main") {
                    parts.pop();
                }
                let text = std::fs::read_to_string(&path).unwrap();
                out.push(Source { module: parts.join("::"), file: path, text });
            }
        }
    }
    out.sort_by(|a, b| a.module.cmp(&b.module));
    out
}

/// The text without comments, string and char literals, and without the
/// unit tests (`#[cfg(test)]` and what follows it): what the crate's
/// library code imports. Newlines are kept so that line numbers hold.
fn code_only(text: &str) -> String {
    let cut = text.find("#[cfg(test)]").unwrap_or(text.len());
    let b = &text.as_bytes()[..cut];
    let mut out = String::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let rest = &text[i..cut];
        if rest.starts_with("//") {
            let end = rest.find('\n').map_or(cut, |n| i + n);
            i = end;
        } else if rest.starts_with("/*") {
            let end = rest.find("*/").map_or(cut, |n| i + n + 2);
            out.extend(text[i..end].chars().filter(|c| *c == '\n'));
            i = end;
        } else if rest.starts_with("r#\"") || rest.starts_with("r\"") {
            let hashes = rest[1..].chars().take_while(|c| *c == '#').count();
            let close = format!("\"{}", "#".repeat(hashes));
            let body = i + 2 + hashes;
            let end = text[body..cut].find(&close).map_or(cut, |n| body + n + close.len());
            out.extend(text[i..end].chars().filter(|c| *c == '\n'));
            i = end;
        } else if b[i] == b'"' {
            let mut j = i + 1;
            while j < cut && b[j] != b'"' {
                j += if b[j] == b'\\' { 2 } else { 1 };
            }
            out.extend(text[i..j.min(cut)].chars().filter(|c| *c == '\n'));
            i = (j + 1).min(cut);
        } else if b[i] == b'\'' && i + 2 < cut && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // a char literal ('"', '\n'); a lifetime has no closing quote
            let end = text[i + 1..cut].find('\'').map_or(cut, |n| i + n + 2);
            i = end;
        } else {
            let ch = text[i..].chars().next().unwrap();
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

/// Every path a `use` item names, expanded (`a::{b, c::d}` -> `a::b`,
/// `a::c::d`), without `as` renames and `self`.
fn expand_use(tree: &str, prefix: &str, out: &mut Vec<String>) {
    let tree = tree.trim();
    if let Some(open) = tree.find('{') {
        let head = tree[..open].trim_end_matches("::").trim();
        let inner = &tree[open + 1..tree.rfind('}').unwrap()];
        let prefix = join(prefix, head);
        let mut depth = 0;
        let mut start = 0;
        for (k, c) in inner.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    expand_use(&inner[start..k], &prefix, out);
                    start = k + 1;
                }
                _ => {}
            }
        }
        expand_use(&inner[start..], &prefix, out);
    } else if !tree.is_empty() {
        let path = tree.split(" as ").next().unwrap().trim();
        let path = join(prefix, path);
        out.push(path.strip_suffix("::self").unwrap_or(&path).to_string());
    }
}

fn join(a: &str, b: &str) -> String {
    match (a.is_empty(), b.is_empty()) {
        (true, _) => b.to_string(),
        (_, true) => a.to_string(),
        _ => format!("{a}::{b}"),
    }
}

/// The paths into the crate that `code` names, each with its line: `use`
/// items expanded, then every other `crate::a::b` in the code. `super::`
/// and `self::` paths are made absolute from `module`.
fn crate_paths(module: &str, code: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let line_of = |pos: usize| code[..pos].matches('\n').count() + 1;
    let absolute = |path: &str| -> Option<String> {
        let mut segs: Vec<&str> = path.split("::").collect();
        let mut base: Vec<&str> = if module.is_empty() { vec![] } else { module.split("::").collect() };
        match segs.first().copied() {
            Some("crate") => {
                segs.remove(0);
                Some(segs.join("::"))
            }
            Some("super") => {
                // `super` of a file module `a::b` (a/b.rs) is `a`; of a
                // folder module `a::b` (a/b/mod.rs) also `a`
                while segs.first() == Some(&"super") {
                    segs.remove(0);
                    base.pop();
                }
                base.extend(segs);
                Some(base.join("::"))
            }
            Some("self") => {
                segs.remove(0);
                base.extend(segs);
                Some(base.join("::"))
            }
            _ => None,
        }
    };
    let mut used = vec![false; code.len()];
    let mut search = 0;
    while let Some(k) = code[search..].find("use ") {
        let at = search + k;
        search = at + 4;
        let before = code[..at].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let Some(end) = code[at..].find(';') else { break };
        let tree: String = code[at + 4..at + end].split_whitespace().collect::<Vec<_>>().join(" ");
        if !(tree.starts_with("crate::") || tree.starts_with("super::") || tree.starts_with("self::")) {
            continue;
        }
        let mut paths = Vec::new();
        expand_use(&tree, "", &mut paths);
        for p in paths {
            if let Some(abs) = absolute(&p) {
                out.push((line_of(at), abs));
            }
        }
        used[at..at + end].iter_mut().for_each(|u| *u = true);
    }
    let bytes = code.as_bytes();
    let mut search = 0;
    while let Some(k) = code[search..].find("crate::") {
        let at = search + k;
        search = at + 7;
        if used[at]
            || (at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_' || bytes[at - 1] == b':'))
        {
            continue;
        }
        let len = code[at..].find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).unwrap_or(code.len() - at);
        let path = code[at..at + len].trim_end_matches(':');
        out.push((line_of(at), path["crate::".len()..].to_string()));
    }
    out
}

/// The items a module re-exports with `pub use` (name -> the path it
/// re-exports), read from its own file.
fn reexports(module: &str, code: &str, modules: &BTreeSet<String>) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut search = 0;
    while let Some(k) = code[search..].find("pub use ") {
        let at = search + k;
        search = at + 8;
        let Some(end) = code[at..].find(';') else { break };
        let tree: String = code[at + 8..at + end].split_whitespace().collect::<Vec<_>>().join(" ");
        let mut paths = Vec::new();
        expand_use(&tree, "", &mut paths);
        for p in paths {
            let name = p.rsplit("::").next().unwrap().to_string();
            // `crate::a::B`, `child::B` (a module below this one), or an
            // item of another crate (`ezy_scene::B`)
            let first = p.split("::").next().unwrap_or("");
            let source = if let Some(rest) = p.strip_prefix("crate::") {
                format!("crate::{rest}")
            } else if modules.contains(&join(module, first)) {
                format!("crate::{}", join(module, &p))
            } else {
                p.clone()
            };
            out.insert(name, source);
        }
    }
    out
}

/// The floor of a module path: its longest prefix in `floors`.
fn unit_of<'a>(path: &str, floors: &'a [(&'a str, u32)]) -> Option<(&'a str, u32)> {
    floors
        .iter()
        .filter(|(m, _)| path == *m || path.starts_with(&format!("{m}::")))
        .max_by_key(|(m, _)| m.len())
        .copied()
}

/// The longest prefix of `path` that is a module of the crate, and the
/// first segment after it (the item named), if any.
fn split_module<'a>(path: &'a str, modules: &BTreeSet<String>) -> (String, Option<&'a str>) {
    let segs: Vec<&str> = path.split("::").collect();
    for n in (0..=segs.len()).rev() {
        let m = segs[..n].join("::");
        if modules.contains(&m) {
            return (m, segs.get(n).copied());
        }
    }
    (String::new(), segs.first().copied())
}

/// Every broken rule of the crate made of `sources`, by the floors
/// `floors`.
fn check(sources: &[Source], floors: &[(&str, u32)]) -> Vec<Violation> {
    let modules: BTreeSet<String> = sources.iter().map(|s| s.module.clone()).collect();
    let codes: Vec<String> = sources.iter().map(|s| code_only(&s.text)).collect();
    let exported: BTreeMap<&str, BTreeMap<String, String>> =
        sources.iter().zip(&codes).map(|(s, c)| (s.module.as_str(), reexports(&s.module, c, &modules))).collect();
    let mut bad = Vec::new();
    let mut edges: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (s, code) in sources.iter().zip(&codes) {
        let Some((unit, floor)) = unit_of(&s.module, floors) else {
            if !s.module.is_empty() {
                bad.push(format!("{}: module `{}` has no floor in the table", s.file.display(), s.module));
            }
            continue;
        };
        for (line, path) in crate_paths(&s.module, code) {
            let at = format!("{}:{line}", s.file.display());
            let (module, item) = split_module(&path, &modules);
            if module.is_empty() {
                if !path.starts_with("__private") && !path.ends_with('!') && item.is_some_and(|i| i != "model") {
                    bad.push(format!(
                        "{at}: `crate::{path}` names a re-export of the crate root; name the module that defines it"
                    ));
                }
                continue;
            }
            if let Some(item) = item
                && let Some(source) = exported.get(module.as_str()).and_then(|e| e.get(item))
                && module != s.module
            {
                bad.push(format!(
                    "{at}: `crate::{path}` names `{item}` through the re-export in `{module}`; name it where it is defined: `{source}`"
                ));
            }
            let Some((target, target_floor)) = unit_of(&module, floors) else { continue };
            // a command imports no other command (the table in
            // `commands/mod.rs` and its shared helpers are not commands;
            // a command's own submodules, `commands::analyze::report`,
            // are that command)
            let command = |m: &str| m.split("::").take(2).collect::<Vec<_>>().join("::");
            if s.module.starts_with("commands::")
                && module.starts_with("commands::")
                && command(&module) != command(&s.module)
            {
                bad.push(format!("{at}: the command `{}` imports the command `{module}`", s.module));
            }
            if target == unit {
                continue;
            }
            if target_floor > floor {
                bad.push(format!(
                    "{at}: `{unit}` (floor {floor}) imports `crate::{path}` from `{target}` (floor {target_floor}): an import goes only down"
                ));
            } else {
                edges.entry(unit).or_default().insert(target);
            }
        }
    }
    // circles among the units of one floor
    for &start in edges.keys() {
        let mut path = vec![start];
        if let Some(circle) = find_circle(start, start, &edges, &mut path, &mut BTreeSet::new()) {
            let text = circle.join(" -> ");
            if !bad.iter().any(|b| b.contains(&text)) && circle[0] == *circle.iter().min().unwrap() {
                bad.push(format!("modules import each other in a circle: {text}"));
            }
        }
    }
    bad
}

fn find_circle<'a>(
    start: &'a str,
    at: &'a str,
    edges: &BTreeMap<&'a str, BTreeSet<&'a str>>,
    path: &mut Vec<&'a str>,
    seen: &mut BTreeSet<&'a str>,
) -> Option<Vec<&'a str>> {
    for &next in edges.get(at).into_iter().flatten() {
        if next == start {
            let mut circle = path.clone();
            circle.push(start);
            return Some(circle);
        }
        if seen.insert(next) {
            path.push(next);
            if let Some(c) = find_circle(start, next, edges, path, seen) {
                return Some(c);
            }
            path.pop();
        }
    }
    None
}

fn ezy_sources() -> Vec<Source> {
    read_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

fn core_sources() -> Vec<Source> {
    read_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("ezy-core/src"))
}

#[test]
fn ezy_core_imports_only_go_down_its_floors() {
    let sources = core_sources();
    assert!(sources.len() > 30, "read {} files of ezy-core/src", sources.len());
    let bad = check(&sources, CORE_FLOORS);
    assert!(bad.is_empty(), "{} import rule(s) broken in ezy-core:\n{}", bad.len(), bad.join("\n"));
}

#[test]
fn the_command_line_imports_only_go_down_its_floors() {
    let sources = ezy_sources();
    assert!(sources.len() > 30, "read {} files of src", sources.len());
    let bad = check(&sources, EZY_FLOORS);
    assert!(bad.is_empty(), "{} import rule(s) broken in src/:\n{}", bad.len(), bad.join("\n"));
}

#[test]
fn a_command_importing_another_is_refused() {
    let mut sources = ezy_sources();
    let run = sources.iter_mut().find(|s| s.module == "commands::run").unwrap();
    run.text = format!("use crate::commands::sweep::exec;\n{}", run.text);
    let bad = check(&sources, EZY_FLOORS);
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(bad[0].contains("the command `commands::run` imports the command `commands::sweep`"), "{}", bad[0]);

    // and drawing reaching up to what the commands share
    let mut sources = ezy_sources();
    let figures = sources.iter_mut().find(|s| s.module == "render::figures").unwrap();
    figures.text = format!("use crate::session::RunOptions;\n{}", figures.text);
    let bad = check(&sources, EZY_FLOORS);
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(
        bad[0].contains("`render` (floor 1) imports `crate::session::RunOptions` from `session` (floor 2)"),
        "{}",
        bad[0]
    );
}

#[test]
fn an_import_up_a_floor_is_refused() {
    // the real crate with one import made to go up: error.rs (floor 0)
    // naming the step loop (floor 6)
    let mut sources = core_sources();
    let error = sources.iter_mut().find(|s| s.module == "error").unwrap();
    error.text = format!("use crate::simulate::observer::Observer;\n{}", error.text);
    let bad = check(&sources, CORE_FLOORS);
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(
        bad[0].contains(
            "error.rs:1: `error` (floor 0) imports `crate::simulate::observer::Observer` from `simulate` (floor 6)"
        ),
        "{}",
        bad[0]
    );

    // through the root's re-export, and through a module's
    let mut sources = core_sources();
    let dae = sources.iter_mut().find(|s| s.module == "formulation::dae").unwrap();
    dae.text = format!("use crate::SimError;\nuse crate::events::EventSpec;\n{}", dae.text);
    let bad = check(&sources, CORE_FLOORS);
    assert_eq!(bad.len(), 2, "{bad:#?}");
    assert!(bad[0].contains("`crate::SimError` names a re-export of the crate root"), "{}", bad[0]);
    assert!(bad[1].contains("name it where it is defined: `crate::events::spec::EventSpec`"), "{}", bad[1]);

    // a circle on one floor
    let mut sources = core_sources();
    let names = sources.iter_mut().find(|s| s.module == "names").unwrap();
    names.text = format!("fn f() -> crate::error::SimError {{ todo!() }}\n{}", names.text);
    let bad = check(&sources, CORE_FLOORS);
    assert!(bad.iter().any(|b| b.contains("circle: error -> names -> error")), "{bad:#?}");
}

#[test]
fn comments_strings_and_unit_tests_are_not_imports() {
    let code = code_only(
        "/// see [`crate::simulate`]\nlet s = \"crate::simulate\"; // crate::simulate\nlet c = '\"';\nuse crate::names::fmt_value;\n#[cfg(test)]\nmod tests { use crate::simulate::Observer; }\n",
    );
    let paths = crate_paths("error", &code);
    assert_eq!(paths, vec![(4, "names::fmt_value".to_string())]);
}
