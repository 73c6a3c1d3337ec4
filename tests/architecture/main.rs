//! The house's import rules, read from the source with a parser (`syn`),
//! as docs/dev/architecture.md states them. `cargo test --release --test
//! architecture`; with `EZY_TREE=DIR` the built test reads the tree at
//! `DIR` instead of its own checkout, so a changed copy is checked
//! without a rebuild.
//!
//! Every library file of every crate of the house is read (`ezy-lang`,
//! `ezy-derive`, `ezy-core`, `ezy-scene`, `models`, `src/`, `python/src`;
//! `src/main.rs` as a binary of its own): its modules from the crate root
//! down its `mod` items, every path into the crate in `use` trees (groups,
//! renames, globs), types, expressions, patterns and macros' tokens
//! (`source.rs`). Only items under `#[cfg(test)]` are skipped, by the
//! attribute; comments and strings name nothing. The rules
//! (`rules.rs`), on the floor table of each crate (`tables.rs`):
//!
//! - every module has a floor in its crate's table, and every line of the
//!   table is a module;
//! - an import never goes up a floor;
//! - the modules of a table import each other without a circle;
//! - the files of one folder (its child modules, beside each other; the
//!   folder's own `mod.rs` declares them and is not one of them) import
//!   each other without a circle, within one line of the table;
//! - an item is named where it is defined, not through a re-export (`pub
//!   use`, `pub(crate) use`, a glob `pub use m::*`, or the crate root's
//!   re-exports, which are for the crate's users);
//! - no command imports another (`src/commands/`).
//!
//! A message names the file and line, both modules and the path; a
//! circle is named with each of its steps. `selftest.rs` shows each rule
//! refusing a synthetic slip; `docs.rs` generates the page's tables.

mod docs;
mod rules;
mod selftest;
mod source;
mod tables;

use std::path::{Path, PathBuf};

use rules::{Rules, Violation};
use source::Files;

/// The tree the test reads: `EZY_TREE`, else the checkout it was built
/// from.
pub fn tree() -> PathBuf {
    std::env::var_os("EZY_TREE").map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")), PathBuf::from)
}

/// The binaries' roots of a crate's source folder: each a crate of its
/// own, which holds no module (a binary is a thin `main` over the
/// library).
const BINARIES: &[(&str, &str)] = &[("src", "main.rs")];

/// Every broken rule of one crate of the tree at `root`.
pub fn check_crate(root: &Path, rules: &Rules) -> Vec<Violation> {
    let mut files = Files::read(rules.src, &root.join(rules.src), rules.root);
    let mut bad = Vec::new();
    for (src, bin) in BINARIES.iter().filter(|(s, _)| *s == rules.src) {
        let Some(text) = files.texts.remove(*bin) else { continue };
        let krate = source::read(&Files::of(src, &[("lib.rs", &text)]));
        bad.extend(krate.problems.iter().map(|p| p.replace("lib.rs", bin)));
        if krate.modules.len() > 1 {
            bad.push(format!("{src}/{bin}: a binary holds no module of its own; the library does"));
        }
    }
    if files.texts.is_empty() {
        bad.push(format!("{}: no source files", root.join(rules.src).display()));
        return bad;
    }
    bad.extend(rules::check(&source::read(&files), rules));
    bad
}

#[test]
fn the_tree_keeps_the_rules() {
    let root = tree();
    let started = std::time::Instant::now();
    let mut bad = Vec::new();
    for rules in tables::CRATES {
        bad.extend(check_crate(&root, rules));
    }
    eprintln!("read and checked {} crates of {} in {:.2?}", tables::CRATES.len(), root.display(), started.elapsed());
    assert!(bad.is_empty(), "{} import rule(s) broken:\n{}", bad.len(), bad.join("\n"));
}

#[test]
fn every_library_of_the_house_has_a_table() {
    // the workspace's members with a library, the user examples aside
    let manifest = std::fs::read_to_string(tree().join("Cargo.toml")).unwrap();
    let members: Vec<&str> = manifest
        .lines()
        .find_map(|l| l.strip_prefix("members = ["))
        .expect("the workspace's members")
        .trim_end_matches(']')
        .split(',')
        .map(|m| m.trim().trim_matches('"'))
        .filter(|m| !m.starts_with("examples/"))
        .collect();
    let mut srcs: Vec<String> = members.iter().map(|m| format!("{m}/src")).collect();
    srcs.push("src".into());
    for src in &srcs {
        assert!(
            tables::CRATES.iter().any(|r| r.src == src),
            "{src} has no floor table in tests/architecture/tables.rs"
        );
    }
    assert_eq!(tables::CRATES.len(), srcs.len(), "a table for a crate that is no member: {srcs:?}");
}

/// The built test run on a changed copy of the tree: an import made to
/// go up a floor in the copy is refused, the checkout left alone.
#[test]
fn the_built_test_reads_the_tree_ezy_tree_names() {
    if std::env::var_os("EZY_TREE").is_some() {
        return; // run by the test below, on its copy
    }
    let copy = tempfile::tempdir().unwrap();
    let root = tree();
    let mut line = 0;
    std::fs::copy(root.join("Cargo.toml"), copy.path().join("Cargo.toml")).unwrap();
    for rules in tables::CRATES {
        let files = Files::read(rules.src, &root.join(rules.src), rules.root);
        for (rel, text) in &files.texts {
            let path = copy.path().join(rules.src).join(rel);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            let text = if rules.src == "ezy-scene/src" && rel == "view.rs" {
                line = text.lines().count() + 1;
                format!("{text}use crate::registry::ModelCatalog;\n")
            } else {
                text.clone()
            };
            std::fs::write(path, text).unwrap();
        }
    }
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "the_tree_keeps_the_rules", "--test-threads", "1"])
        .env("EZY_TREE", copy.path())
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!out.status.success(), "{text}");
    assert!(text.contains("1 import rule(s) broken"), "{text}");
    assert!(
        text.contains(&format!(
            "ezy-scene/src/view.rs:{line}: `view` (floor 0) imports `crate::registry::ModelCatalog` from `registry` (floor 4)"
        )),
        "{text}"
    );
}
