//! The checker shown refusing each slip it exists for, on synthetic
//! crates (strings parsed as the files of a crate `syn/src`): each must
//! be refused with a message naming the file and line and both modules.

use crate::rules::{Door, Floor, Knot, Rules, Violation, check};
use crate::source::{Files, read};
use crate::tables;

/// A crate of two floors: `low` (floor 0, with `low::deep` in it),
/// `effects` (floor 0, a folder of files) and `up`, `user` (floor 1).
const SYNTHETIC: Rules = Rules {
    name: "synthetic",
    src: "syn/src",
    root: "lib.rs",
    floors: &[
        Floor { module: "low", floor: 0, holds: "" },
        Floor { module: "effects", floor: 0, holds: "" },
        Floor { module: "up", floor: 1, holds: "" },
        Floor { module: "user", floor: 1, holds: "" },
    ],
    doors: &[],
    knots: &[],
    commands: None,
};

const LIB: &str = "pub mod effects;\npub mod low;\npub mod up;\npub mod user;\n";
const UP: &str = "pub struct Chart;\npub const LIMIT: usize = 1;\n";
const EFFECTS: &str = "pub mod hinge;\npub mod registry;\n";
const HINGE: &str = "pub struct HingeLaw;\n";
const REGISTRY: &str = "pub trait Reference {}\n";
const USER: &str = "pub fn user() {}\n";

/// The broken rules of the synthetic crate with `changed` files in place
/// of the plain ones.
fn broken(changed: &[(&str, &str)], rules: &Rules) -> Vec<Violation> {
    let mut files: Vec<(&str, &str)> = vec![
        ("lib.rs", LIB),
        ("low.rs", "pub fn low() {}\n"),
        ("up.rs", UP),
        ("user.rs", USER),
        ("effects/mod.rs", EFFECTS),
        ("effects/hinge.rs", HINGE),
        ("effects/registry.rs", REGISTRY),
    ];
    for (path, text) in changed {
        files.retain(|(p, _)| p != path);
        files.push((path, text));
    }
    check(&read(&Files::of("syn/src", &files)), rules)
}

/// `broken` must be the one violation `wanted` (a part of its message).
#[track_caller]
fn refused(changed: &[(&str, &str)], wanted: &str) {
    let bad = broken(changed, &SYNTHETIC);
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(bad[0].contains(wanted), "wanted `{wanted}` in\n{}", bad[0]);
}

const UPWARD: &str = "`low` (floor 0) imports `crate::up::Chart` from `up` (floor 1): an import goes only down";

#[test]
fn the_synthetic_crate_keeps_the_rules() {
    let bad = broken(&[], &SYNTHETIC);
    assert!(bad.is_empty(), "{bad:#?}");
}

/// (a) `#[cfg(test)] mod tests;` early in a file (as in plot/mod.rs)
/// hides nothing after it.
#[test]
fn a_test_module_early_in_a_file_hides_nothing_after_it() {
    let low = "//! Low.\n\n#[cfg(test)]\nmod tests;\n\npub use crate::up::Chart;\n";
    refused(&[("low.rs", low), ("low/tests.rs", "use crate::up::LIMIT;\n")], &format!("syn/src/low.rs:6: {UPWARD}"));
}

/// (b) A `super::` path in an expression, from a file two folders down.
#[test]
fn a_super_path_in_an_expression_is_an_import() {
    refused(
        &[
            ("low.rs", "pub mod deep;\n"),
            ("low/deep.rs", "pub fn limit() -> usize {\n    super::super::up::LIMIT + 1\n}\n"),
        ],
        "syn/src/low/deep.rs:2: `low::deep` (in `low`, floor 0) imports `crate::up::LIMIT` from `up` (floor 1)",
    );
}

/// (c) Code after a module of unit tests is read; the tests are not.
#[test]
fn code_after_a_tests_module_is_read() {
    let low = "#[cfg(test)]\nmod tests {\n    use crate::up::Chart;\n}\n\npub fn draw(_: crate::up::Chart) {}\n";
    refused(&[("low.rs", low)], &format!("syn/src/low.rs:6: {UPWARD}"));
}

/// (d) A doc comment that names `#[cfg(test)]` cuts nothing.
#[test]
fn a_doc_comment_naming_cfg_test_cuts_nothing() {
    let low = "//! Never `#[cfg(test)]` here.\n\n/// Unlike #[cfg(test)] code:\nuse crate::up::Chart;\n";
    refused(&[("low.rs", low)], &format!("syn/src/low.rs:4: {UPWARD}"));
}

/// (e) An item named through a glob re-export (`pub use hinge::*`).
#[test]
fn a_name_through_a_glob_re_export_is_refused() {
    refused(
        &[
            ("effects/mod.rs", "pub mod hinge;\npub mod registry;\npub use hinge::*;\n"),
            ("user.rs", "use crate::effects::HingeLaw;\n"),
        ],
        "syn/src/user.rs:1: `user` names `crate::effects::HingeLaw` through the glob `pub use crate::effects::hinge::*` in `effects` (syn/src/effects/mod.rs:3); name it where it is defined: `crate::effects::hinge::HingeLaw`",
    );
}

/// (f) An item named through a `pub(crate) use` re-export, in a type.
#[test]
fn a_name_through_a_crate_visible_re_export_is_refused() {
    refused(
        &[
            ("effects/mod.rs", "pub mod hinge;\npub mod registry;\npub(crate) use hinge::HingeLaw as Law;\n"),
            ("user.rs", "pub fn user(_: &crate::effects::Law) {}\n"),
        ],
        "syn/src/user.rs:1: `user` names `crate::effects::Law` through the `pub(crate) use` in `effects` (syn/src/effects/mod.rs:3); name it where it is defined: `crate::effects::hinge::HingeLaw`",
    );
    // and through the crate root's re-export
    refused(
        &[("lib.rs", &format!("{LIB}pub use effects::hinge::HingeLaw;\n")), ("user.rs", "use crate::HingeLaw;\n")],
        "syn/src/user.rs:1: `user` names `crate::HingeLaw` through the crate root's `pub use HingeLaw` (syn/src/lib.rs:5); name it where it is defined: `crate::effects::hinge::HingeLaw`",
    );
}

/// (g) A path inside a macro's tokens.
#[test]
fn a_path_inside_a_macro_is_an_import() {
    let low = "pub fn label() -> String {\n    format!(\"{}\", crate::up::LIMIT)\n}\n";
    refused(
        &[("low.rs", low)],
        "syn/src/low.rs:2: `low` (floor 0) imports `crate::up::LIMIT` from `up` (floor 1): an import goes only down",
    );
}

/// (h) Two files of one folder importing each other; a knot named in
/// the rules is let through, the other import between them is not.
#[test]
fn a_circle_among_the_files_of_a_folder_is_refused() {
    let hinge = "use super::registry::Reference;\npub struct HingeLaw;\nimpl Reference for HingeLaw {}\n";
    let registry = "pub trait Reference {}\npub fn laws() -> Vec<super::hinge::HingeLaw> {\n    Vec::new()\n}\n";
    refused(
        &[("effects/hinge.rs", hinge), ("effects/registry.rs", registry)],
        "the files of `effects` (syn/src/effects/) import each other in a circle: 2 modules (`effects::hinge`, `effects::registry`); `effects::hinge` -> `effects::registry` (syn/src/effects/hinge.rs:1: `crate::effects::registry::Reference`), `effects::registry` -> `effects::hinge` (syn/src/effects/registry.rs:2: `crate::effects::hinge::HingeLaw`)",
    );
    let knot = Rules { knots: &[Knot { item: "effects::hinge::HingeLaw", reason: "" }], ..SYNTHETIC };
    assert!(broken(&[("effects/hinge.rs", hinge), ("effects/registry.rs", registry)], &knot).is_empty());
    let registry = format!("{registry}pub const ONE: usize = super::hinge::ONE;\n");
    let hinge = format!("{hinge}pub const ONE: usize = 1;\n");
    let bad = broken(&[("effects/hinge.rs", &hinge), ("effects/registry.rs", &registry)], &knot);
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(bad[0].contains("(syn/src/effects/registry.rs:5: `crate::effects::hinge::ONE`)"), "{}", bad[0]);
}

/// A circle between the modules of a table's floor, a command importing
/// another, a module without a floor, a door.
#[test]
fn the_table_s_own_rules_refuse_their_slips() {
    refused(
        &[
            ("effects/hinge.rs", "pub struct HingeLaw;\npub fn f() -> usize {\n    crate::low::LOW\n}\n"),
            ("low.rs", "pub const LOW: usize = 0;\npub use crate::effects::hinge::HingeLaw;\n"),
        ],
        "modules of synthetic's floor table import each other in a circle: 2 modules (`effects`, `low`); `effects` -> `low` (syn/src/effects/hinge.rs:3: `crate::low::LOW`), `low` -> `effects` (syn/src/low.rs:2: `crate::effects::hinge::HingeLaw`)",
    );
    let commands = Rules { commands: Some("user"), ..SYNTHETIC };
    let bad = broken(
        &[
            ("user.rs", "pub mod run;\npub mod sweep;\n"),
            ("user/run.rs", "use crate::user::sweep::exec;\n"),
            ("user/sweep.rs", "pub fn exec() {}\n"),
        ],
        &commands,
    );
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(
        bad[0].contains("syn/src/user/run.rs:1: the command `user::run` imports the command `user::sweep`"),
        "{}",
        bad[0]
    );
    refused(
        &[("lib.rs", &format!("{LIB}pub mod extra;\n")), ("extra.rs", "")],
        "syn/src/extra.rs: module `extra` has no floor in the table of synthetic",
    );
    refused(&[("stray.rs", "pub fn f() {}\n")], "syn/src/stray.rs: no `mod` item of the crate reaches this file");
    // a door is outside the floors, and its re-exports are for users only
    let door = Rules { doors: &[Door { module: "door", reason: "" }], ..SYNTHETIC };
    let lib = format!("{LIB}pub mod door {{\n    pub use crate::up::Chart;\n}}\n");
    assert!(broken(&[("lib.rs", &lib)], &door).is_empty());
    let bad = broken(&[("lib.rs", &lib), ("user.rs", "use crate::door::Chart;\n")], &door);
    assert_eq!(bad.len(), 1, "{bad:#?}");
    assert!(bad[0].contains("names `crate::door::Chart` through the `pub use` in `door`"), "{}", bad[0]);
}

/// Comments, strings, `#[test]` functions and a test module's files are
/// no imports; `$crate` in a macro's definition is the crate.
#[test]
fn comments_strings_and_tests_are_not_imports() {
    let low = "// crate::up::Chart\n/* crate::up::Chart */\n/// [`crate::up::Chart`]\npub const S: &str = \"crate::up::Chart\";\n#[test]\nfn t() { let _ = crate::up::Chart; }\n#[cfg(all(test, unix))]\nmod more { use crate::up::Chart; }\n#[macro_export]\nmacro_rules! m { () => { $crate::low::S } }\n";
    assert!(broken(&[("low.rs", low)], &SYNTHETIC).is_empty());
    let low = "#[macro_export]\nmacro_rules! m {\n    () => {\n        $crate::up::LIMIT\n    };\n}\n";
    refused(&[("low.rs", low)], "syn/src/low.rs:4: `low` (floor 0) imports `crate::up::LIMIT` from `up` (floor 1)");
}

/// A file `tables.rs` holds for a crate, synthetic: every module of the
/// table (and the folders above it) as an empty file.
fn table_files(rules: &Rules) -> Vec<(String, String)> {
    let mut modules: Vec<String> = Vec::new();
    for f in rules.floors {
        let segs: Vec<&str> = f.module.split("::").collect();
        for n in 1..=segs.len() {
            let m = segs[..n].join("::");
            if !modules.contains(&m) {
                modules.push(m);
            }
        }
    }
    let file = |m: &str| {
        let has_children = modules.iter().any(|c| c.starts_with(&format!("{m}::")));
        let path = m.replace("::", "/");
        if has_children { format!("{path}/mod.rs") } else { format!("{path}.rs") }
    };
    let decls = |parent: Option<&str>| -> String {
        modules
            .iter()
            .filter(|m| match parent {
                None => !m.contains("::"),
                Some(p) => m.strip_prefix(&format!("{p}::")).is_some_and(|r| !r.contains("::")),
            })
            .map(|m| format!("pub mod {};\n", m.rsplit("::").next().unwrap()))
            .collect()
    };
    let mut files = vec![("lib.rs".to_string(), decls(None))];
    files.extend(modules.iter().map(|m| (file(m), decls(Some(m)))));
    files
}

/// The index in `files` of the file of `module`.
fn file_of(files: &[(String, String)], module: &str) -> usize {
    let path = module.replace("::", "/");
    files.iter().position(|(p, _)| *p == format!("{path}.rs") || *p == format!("{path}/mod.rs")).unwrap()
}

/// (i) An import up a floor in every crate's own table (where a table
/// has one floor, imports both ways between two of its modules: a
/// circle).
#[test]
fn every_crate_s_table_refuses_an_import_up_a_floor() {
    for rules in tables::CRATES {
        let mut files = table_files(rules);
        let low = rules.floors.iter().min_by_key(|f| f.floor).unwrap();
        let top = rules.floors.iter().filter(|f| f.module != low.module).max_by_key(|f| f.floor).unwrap();
        let (l, t) = (file_of(&files, low.module), file_of(&files, top.module));
        files[t]
            .1
            .push_str(&format!("pub struct Thing;\npub fn f() {{\n    let _ = crate::{}::Other;\n}}\n", low.module));
        files[l].1.push_str(&format!("pub struct Other;\nuse crate::{}::Thing;\n", top.module));
        let pairs: Vec<(&str, &str)> = files.iter().map(|(p, t)| (p.as_str(), t.as_str())).collect();
        let bad = check(&read(&Files::of(rules.src, &pairs)), rules);
        assert_eq!(bad.len(), 1, "{}: {bad:#?}", rules.name);
        let wanted = if top.floor > low.floor {
            format!(
                "`{}` (floor {}) imports `crate::{}::Thing` from `{}` (floor {})",
                low.module, low.floor, top.module, top.module, top.floor
            )
        } else {
            format!("modules of {}'s floor table import each other in a circle", rules.name)
        };
        assert!(bad[0].contains(&wanted), "{}: wanted `{wanted}` in\n{}", rules.name, bad[0]);
        assert!(bad[0].contains(&format!("{}/", rules.src)), "{}", bad[0]);
    }
}
