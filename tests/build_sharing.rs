//! `cargo test --workspace` after `cargo run` reuses every crate the run
//! built: for each package of `ezy`'s own build (`cargo run`), each set of
//! features it is compiled with there is also one the whole workspace's
//! build (tests, benches, the Python module) compiles it with. A dev- or
//! member dependency that turns on a feature of a shared crate (criterion
//! turned on serde's `alloc`, and serde, faer and ezy were rebuilt after
//! every `cargo run`) fails here, naming the crate; the features it needs
//! go into the root `Cargo.toml`'s workspace-hack entries.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// `package version` -> the feature sets `cargo tree` resolves it with.
fn features(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["tree", "--locked", "--prefix", "none", "--format", "{p} {f}"])
        .args(args)
        .output()
        .expect("cargo runs");
    assert!(out.status.success(), "cargo tree {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8(out.stdout).unwrap().lines() {
        let line = line.trim_end_matches("(*)").trim();
        let mut words = line.split(' ');
        let (Some(name), Some(version)) = (words.next(), words.next()) else { continue };
        // a path package's "(/path)" then its features; a registry one's features
        let feats = words.rfind(|w| !w.starts_with('(') && !w.ends_with(')')).unwrap_or("");
        map.entry(format!("{name} {version}")).or_default().insert(feats.to_string());
    }
    map
}

#[test]
fn cargo_test_reuses_what_cargo_run_built() {
    let run = features(&["--package", "ezy", "--edges", "normal,build"]);
    let all = features(&["--workspace", "--edges", "normal,build,dev"]);
    assert!(run.len() > 100, "ezy's own build has {} packages: cargo tree's output changed", run.len());
    let differ: Vec<String> = run
        .iter()
        .filter_map(|(package, sets)| {
            let in_all = all.get(package)?;
            (!sets.is_subset(in_all))
                .then(|| format!("{package}: `cargo run` builds {sets:?}, the workspace {in_all:?}"))
        })
        .collect();
    assert!(
        differ.is_empty(),
        "`cargo test --workspace` would rebuild these with other features (turn them on in the root Cargo.toml's workspace-hack entries):\n{}",
        differ.join("\n")
    );
}
