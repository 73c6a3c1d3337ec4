//! The README's two commands share one build: `cargo test --release
//! --workspace` right after `cargo run --release` compiles only test code
//! (test harnesses, examples, benches, and crates only they use), never a
//! crate the run built again with another profile or other features.
//!
//! Cargo plans both commands without compiling anything (its unit graph:
//! every crate it would compile, with profile, features and
//! dependencies). A unit of the test command whose package the run also
//! builds, in the same mode, must be one of the run's units: equal
//! profile, features and dependencies, so cargo reuses the run's
//! artifact. A dev-dependency that turns on a feature of a shared crate
//! (criterion turned on serde's `alloc`) or builds it on the proc macros'
//! side at another opt-level (trybuild's TOML crates under ezy-derive)
//! fails here, naming the crate and what differs; the fix goes into the
//! root `Cargo.toml` (its workspace-hack entries and its release
//! profile's package overrides) or ezy-derive's dev-dependencies.
//!
//! The unit graph is an unstable cargo output (`--unit-graph -Z
//! unstable-options`, read here with `RUSTC_BOOTSTRAP=1`, which changes
//! nothing that is built). Where the cargo in use does not offer it, the
//! test says so and compares the features `cargo tree` resolves instead.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::process::Command;

use serde_json::Value;

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// One planned compilation: `package target mode` and its identity
/// (profile, platform, features and its dependencies' identities).
struct Unit {
    name: String,
    package: String,
    mode: String,
    identity: String,
    profile: Value,
    features: Value,
}

/// The units `cargo <args>` would compile, or why cargo cannot say.
fn unit_graph(args: &[&str]) -> Result<Vec<Unit>, String> {
    let out = cargo()
        .args(args)
        .args(["--locked", "--unit-graph", "-Z", "unstable-options"])
        .env("RUSTC_BOOTSTRAP", "1")
        .output()
        .map_err(|e| format!("cannot start cargo: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let graph: Value = serde_json::from_slice(&out.stdout).map_err(|e| format!("cargo's unit graph: {e}"))?;
    let units = graph["units"].as_array().ok_or("the unit graph has no `units`")?;
    let mut identities: HashMap<usize, String> = HashMap::new();
    fn identity(k: usize, units: &[Value], memo: &mut HashMap<usize, String>) -> String {
        if let Some(id) = memo.get(&k) {
            return id.clone();
        }
        let u = &units[k];
        let mut deps: Vec<String> = u["dependencies"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|d| identity(d["index"].as_u64().unwrap() as usize, units, memo))
            .collect();
        deps.sort();
        let id = format!(
            "{} {} {} {} {} {} [{}]",
            u["pkg_id"],
            u["target"]["name"],
            u["mode"],
            u["profile"],
            u["platform"],
            u["features"],
            deps.join(", ")
        );
        memo.insert(k, id.clone());
        id
    }
    Ok((0..units.len())
        .map(|k| {
            let u = &units[k];
            // `registry+...#serde@1.0.229`, or `path+file:///.../ezy-core#0.1.0`
            let id = u["pkg_id"].as_str().unwrap_or_default();
            let (source, version) = id.rsplit_once('#').unwrap_or((id, ""));
            let package = match version.contains('@') {
                true => version.to_string(),
                false => format!("{}@{version}", source.rsplit('/').next().unwrap_or_default()),
            };
            Unit {
                name: format!("{package} {}", u["target"]["name"].as_str().unwrap_or_default()),
                package: u["pkg_id"].to_string(),
                mode: u["mode"].to_string(),
                identity: identity(k, units, &mut identities),
                profile: u["profile"].clone(),
                features: u["features"].clone(),
            }
        })
        .collect())
}

#[test]
fn cargo_test_after_cargo_run_compiles_only_test_code() {
    let run = unit_graph(&["build", "--release", "--package", "ezy", "--bin", "ezy"]);
    let test = unit_graph(&["test", "--release", "--workspace", "--no-run"]);
    let (run, test) = match (run, test) {
        (Ok(run), Ok(test)) => (run, test),
        (Err(why), _) | (_, Err(why)) => {
            eprintln!("cargo cannot plan without building (--unit-graph): {why}; comparing features only");
            return features_agree();
        }
    };
    assert!(run.len() > 100, "`cargo run --release` plans {} units: cargo's unit graph changed", run.len());
    let built: BTreeSet<&str> = run.iter().map(|u| u.identity.as_str()).collect();
    let mut again = Vec::new();
    for u in &test {
        if built.contains(u.identity.as_str()) {
            continue;
        }
        let same: Vec<&Unit> =
            run.iter().filter(|r| r.package == u.package && r.name == u.name && r.mode == u.mode).collect();
        if same.is_empty() {
            continue; // a unit only the tests build
        }
        let why: Vec<String> = same
            .iter()
            .map(|r| {
                let mut d = Vec::new();
                if r.features != u.features {
                    d.push(format!("features {} (run) against {} (test)", r.features, u.features));
                }
                if r.profile != u.profile {
                    d.push(format!(
                        "opt-level {} (run) against {} (test)",
                        r.profile["opt_level"], u.profile["opt_level"]
                    ));
                }
                if d.is_empty() { "its dependencies differ (see the crates above)".to_string() } else { d.join(", ") }
            })
            .collect();
        again.push(format!("{} ({}): {}", u.name, u.mode, why.join("; ")));
    }
    assert!(
        again.is_empty(),
        "`cargo test --release --workspace` after `cargo run --release` would compile these again (align them in the root Cargo.toml's workspace-hack entries or release profile overrides):\n{}",
        again.join("\n")
    );
    // the planner is not vacuous: the tests build the run's crates (the
    // same units) and test code besides
    assert!(test.iter().any(|u| u.name.starts_with("ezy-core@") && built.contains(u.identity.as_str())));
    assert!(test.len() > run.len(), "the tests plan {} units, the run {}", test.len(), run.len());
}

/// `package version` -> the feature sets `cargo tree` resolves it with.
fn features(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let out = cargo()
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

/// Where cargo cannot plan: each package of the run is resolved with
/// feature sets the workspace's build resolves too (profiles unchecked).
fn features_agree() {
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
