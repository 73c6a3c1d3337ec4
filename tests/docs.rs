//! The documentation stays true to the code: README.md is a front page
//! that opens with the two commands CI runs; every relative link in the
//! README, the guide (`docs/book/src`), `docs/physics.md` and `docs/dev`
//! leads to a file; every chapter is in the guide's table of contents;
//! and the guide's reference pages generated from the code (the named
//! settings, the output columns, the commands' help) match it. A stale
//! page fails here; `EZY_BLESS=1 cargo test --release --test docs`
//! rewrites the pages from the code.

use std::path::{Path, PathBuf};
use std::process::Command;

use ezy_core::{Choice, Formulation, Method, Model, ProjectionKind};
use ezy_scene::{OutputGroup, OutputSettings};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The Markdown files whose links are checked.
fn markdown_files() -> Vec<PathBuf> {
    let mut files = vec![root().join("README.md"), root().join("docs/physics.md")];
    for dir in ["docs/book/src", "docs/book/src/reference", "docs/dev"] {
        let mut found: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
            .unwrap_or_else(|e| panic!("{dir}: {e}"))
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "md"))
            .collect();
        found.sort();
        files.extend(found);
    }
    files
}

/// The targets of the Markdown links `[text](target)` and images in `text`
/// that are paths in the repository (not URLs, not anchors alone), without
/// their `#anchor`, skipping code blocks and code spans.
fn relative_links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_block = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            continue;
        }
        if in_block || line.starts_with("    ") {
            continue;
        }
        // drop code spans: a link inside backticks is code, not a link
        let mut plain = String::new();
        for (k, part) in line.split('`').enumerate() {
            if k % 2 == 0 {
                plain.push_str(part);
            }
        }
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            let target = after[..end].split_whitespace().next().unwrap_or("");
            let path = target.split('#').next().unwrap_or("");
            if !path.is_empty() && !path.contains("://") && !path.starts_with("mailto:") {
                out.push(path.to_string());
            }
            rest = &after[end..];
        }
    }
    out
}

/// The README is a front page (at most 12 kB) that opens with the two
/// commands a new user types, and CI runs exactly its test command.
#[test]
fn the_readme_is_a_front_page_with_the_two_commands() {
    let readme = read("README.md");
    assert!(readme.len() <= 12 * 1024, "README.md is {} bytes; the front page is at most 12 kB", readme.len());
    let first_block: String =
        readme.split("```").nth(1).expect("README.md opens with a code block").lines().skip(1).collect();
    for command in ["cargo run --release", "cargo test --release --workspace"] {
        assert!(first_block.contains(command), "README.md's first code block lacks `{command}`");
    }
    let ci = read(".ci/run");
    assert!(
        ci.lines().any(|l| l.trim() == "cargo test --release --workspace"),
        ".ci/run must run the README's test command"
    );
}

/// Every relative link and image of the documentation names a file that
/// exists, and every chapter of the guide is in its SUMMARY.md.
#[test]
fn every_link_of_the_docs_leads_to_a_file() {
    let mut broken = Vec::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        let dir = file.parent().unwrap();
        for link in relative_links(&text) {
            if !dir.join(&link).exists() {
                broken.push(format!("{}: {link}", file.strip_prefix(root()).unwrap().display()));
            }
        }
    }
    assert!(broken.is_empty(), "links to missing files:\n{}", broken.join("\n"));
    let summary = read("docs/book/src/SUMMARY.md");
    let listed = relative_links(&summary);
    for file in markdown_files() {
        let Ok(rel) = file.strip_prefix(root().join("docs/book/src")) else { continue };
        let rel = rel.to_string_lossy().to_string();
        if rel != "SUMMARY.md" {
            assert!(listed.contains(&rel), "docs/book/src/{rel} is not in SUMMARY.md");
        }
    }
}

/// Compares the page `rel` with what the code generates, or rewrites it
/// under `EZY_BLESS`.
fn check_page(rel: &str, source: &str, body: &str) {
    let page = format!(
        "<!-- Generated from {source} by tests/docs.rs: edit the source, then run\n     EZY_BLESS=1 cargo test --release --test docs -->\n\n{body}"
    );
    let path = root().join(rel);
    if std::env::var_os("EZY_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &page).unwrap();
        return;
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == page,
        "{rel} differs from what {source} gives: regenerate it with `EZY_BLESS=1 cargo test --release --test docs`"
    );
}

fn choice_table<T: Choice>(title: &str, key: &str, flag: &str) -> String {
    let mut s = format!("## {title}\n\nScene key `{key}`, flag `{flag}`.\n\n| value | what it is |\n|---|---|\n");
    for &v in T::ALL {
        s.push_str(&format!("| `{}` | {} |\n", v.name(), v.help()));
    }
    s
}

/// The named settings (integrator, projection, formulation) as the code
/// lists them ([`Choice`]).
#[test]
fn the_settings_reference_is_the_code_s() {
    let body = format!(
        "# Integrators, projections, formulations\n\nThe values scene files and the command line accept, with the help the\ncommand line prints.\n\n{}\n{}\n{}",
        choice_table::<Method>("Integrators", "[integrator] method", "--integrator"),
        choice_table::<ProjectionKind>("Projections", "[integrator] projection", "--projection"),
        choice_table::<Formulation>("Formulations", "[integrator] formulation", "--formulation"),
    );
    check_page("docs/book/src/reference/settings.md", "ezy_core::Choice (Method, ProjectionKind, Formulation)", &body);
}

/// The output columns each group adds, as `Scene::columns` names them for
/// the EzyRoller's `drive` scene.
#[test]
fn the_columns_reference_is_the_code_s() {
    let info = ezy::models::EzyRoller::default().info();
    let mut scene = ezy::models::scenes::drive();
    scene.output = OutputSettings { include: Vec::new(), ..scene.output };
    let always = scene.columns(&info);
    let mut body = String::from(
        "# Output columns\n\nThe columns of `trajectory.csv`, as the `drive` scene of the EzyRoller\nnames them (one coordinate per body axis and heading, one effect `motor`).\nAlways written:\n\n",
    );
    body.push_str(&format!("    {}\n\n", always.join(",")));
    body.push_str("Each group of `[output] include = [...]` adds:\n\n| group | columns it adds |\n|---|---|\n");
    for g in OutputGroup::ALL {
        scene.output.include = vec![g];
        let cols = scene.columns(&info);
        let added: Vec<String> = cols[always.len()..].iter().map(|c| format!("`{c}`")).collect();
        body.push_str(&format!("| `{}` | {} |\n", g.name(), added.join(" ")));
    }
    body.push_str(
        "\nUnits: coordinates \\[m, rad\\], velocities (`..d`) \\[m/s, rad/s\\], accelerations\n(`..dd`) \\[m/s^2, rad/s^2\\], energies and works (`T`, `W`, `W_..`) \\[J\\], `tau_..`\n\\[N m\\], `F_..` \\[N\\], points \\[m\\] and their velocities \\[m/s\\], `res_phi` \\[m\\],\n`res_vel` \\[m/s\\].\n",
    );
    check_page("docs/book/src/reference/columns.md", "ezy_scene::Scene::columns", &body);
}

/// The help of every command, as clap prints it.
#[test]
fn the_commands_reference_is_clap_s() {
    let ezy = Path::new(env!("CARGO_BIN_EXE_ezy"));
    let help = |args: &[&str]| {
        let out = Command::new(ezy).args(args).output().unwrap();
        assert!(out.status.success(), "ezy {args:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let top = help(&["--help"]);
    let commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 5, "{top}");
    let mut body = format!("# Commands\n\n```text\n$ ezy --help\n{top}```\n");
    for c in &commands {
        body.push_str(&format!("\n## ezy {c}\n\n```text\n$ ezy {c} --help\n{}```\n", help(&[c, "--help"])));
    }
    check_page("docs/book/src/reference/commands.md", "the command line's help (clap)", &body);
}

/// The reference page of the effect kinds (docs/book/src/reference/effects.md)
/// is the registry's list (`ezy_core::effects::REFERENCE`), one row per
/// built-in kind in its order; and each row names every key the kind
/// accepts: the keys as serde knows them, read from its refusal of an
/// unknown key ("expected `hinge` or `torque`").
#[test]
fn the_effects_reference_is_the_registry_s() {
    use ezy_core::effects::{EFFECT_KINDS, EffectSpec, REFERENCE};
    let kinds: Vec<&str> = REFERENCE.iter().map(|r| r.kind).collect();
    assert_eq!(kinds, EFFECT_KINDS, "the reference rows are the built-in kinds, in order");
    let cell = |s: &str| s.replace('|', "\\|");
    let mut body = String::from(
        "# Effect kinds\n\nThe built-in kinds an `[effects.NAME]` table names by its `kind` key, in\nthe order of the registry (`ezy-core/src/effects/registry.rs`, the one list\nof them). Every number is in SI units; a key with a default shows it in\nparentheses. Each effect's work is its state `W_<name>` [J]; its value\ncolumn is `tau_<name>` [N m] for a torque, `F_<name>` [N] for a force. The\nconventions, the ranges of numbers and the waveforms: [Scenes and\neffects](../scenes.md).\n\n| `kind` | keys | force law | value column |\n|---|---|---|---|\n",
    );
    for r in REFERENCE {
        let e = toml::from_str::<EffectSpec>(&format!("kind = \"{}\"\nzz_no_such_key = 1", r.kind))
            .expect_err("an unknown key is refused")
            .to_string();
        let expected = e.split("expected").nth(1).unwrap_or_else(|| panic!("{}: {e}", r.kind));
        let fields: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
        assert!(!fields.is_empty(), "{}: {e}", r.kind);
        for f in fields {
            let named = r.keys.match_indices(&format!("`{f}")).any(|(i, m)| {
                r.keys[i + m.len()..].chars().next().is_some_and(|c| !(c.is_ascii_alphanumeric() || c == '_'))
            });
            assert!(named, "the keys of `{}` (its Reference::KEYS) do not name its key `{f}`: {}", r.kind, r.keys);
        }
        body.push_str(&format!(
            "| `{}` | {} | {} | `{}_<name>` |\n",
            r.kind,
            cell(r.keys),
            cell(r.law),
            r.value_prefix
        ));
    }
    check_page("docs/book/src/reference/effects.md", "ezy_core::effects::REFERENCE (the registry)", &body);
}

/// The numbers the drive chapter quotes (docs/book/src/drive.md includes
/// the page), from `ezy run drive`, what `cargo run --release` runs: the
/// method and formulation the run takes, the largest gap of the energy
/// balance and residuals over the run, and the state at its end.
#[test]
fn the_drive_chapter_quotes_the_run() {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("docs-drive-run");
    let _ = std::fs::remove_dir_all(&out);
    let o = Command::new(env!("CARGO_BIN_EXE_ezy"))
        .args(["run", "drive", "--no-figures", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success(), "ezy run drive: {said}{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&out);
    // the rest of the line that starts with `start`
    let after = |start: &str| {
        said.lines()
            .find_map(|l| l.trim().strip_prefix(start))
            .unwrap_or_else(|| panic!("no line `{start}`: {said}"))
            .to_string()
    };
    // the text of `text` between `from` and the next `to`
    fn between(text: &str, from: &str, to: &str) -> String {
        let rest = text.split(from).nth(1).unwrap_or_else(|| panic!("no `{from}` in `{text}`"));
        rest.split(to).next().unwrap().trim().to_string()
    }
    let first = said.lines().next().unwrap();
    let gap = after("max |T - T0 - W| = ");
    let residuals = after("max residuals ");
    let (c, g) = (between(&residuals, "|C| = ", ","), between(&residuals, "|G qd| = ", " ("));
    let unit = |name: &str| match name {
        n if n.starts_with('W') => "J",
        n if n.starts_with("phi") && n.ends_with('d') => "rad/s",
        n if n.starts_with("phi") => "rad",
        n if n.ends_with('d') => "m/s",
        _ => "m",
    };
    let state: Vec<String> = after("final state: ")
        .split(", ")
        .map(|kv| {
            let (name, value) = kv.split_once(" = ").unwrap_or_else(|| panic!("`{kv}` in the final state"));
            format!("{name} = {value} {}", unit(name))
        })
        .collect();
    let body = format!(
        "`ezy run drive` (what `cargo run --release` runs) says which method and\nformulation it took in its first line:\n\n```text\n{first}\n```\n\nOver the run, the largest gap of the energy balance `abs(T - T(0) - W)`\nis {gap}, the largest position residual `abs(C)` {c} and the\nlargest velocity residual `abs(G qd)` {g}. The state at t = 60 s:\n{}.\n\nThe test suite reruns the scene and checks these numbers against this\npage (tests/docs.rs).\n",
        state.join(", ")
    );
    check_page("docs/book/src/generated/drive-run.md", "`ezy run drive`", &body);
}

/// The contents list at the top of docs/physics.md (the guide's physics
/// chapter) names every numbered section, in order.
#[test]
fn the_physics_contents_list_every_section() {
    let text = read("docs/physics.md");
    let sections: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("## "))
        .filter(|h| h.starts_with(|c: char| c.is_ascii_digit()))
        .collect();
    let listed: Vec<&str> = text
        .split("Contents:\n")
        .nth(1)
        .expect("docs/physics.md has a contents list")
        .lines()
        .skip_while(|l| l.trim().is_empty())
        .take_while(|l| !l.trim().is_empty())
        .collect();
    assert!(sections.len() >= 12, "{sections:?}");
    assert_eq!(listed, sections, "the contents list of docs/physics.md against its sections");
}

/// The guide's Quantities page (docs/book/src/quantities.md) is the
/// quantities table (`ezy_core::quantities::TABLES`): one section per CSV
/// file, a row per column with its unit, definition, formula, frame and
/// time, and source.
#[test]
fn the_quantities_page_is_the_table_s() {
    use ezy_core::quantities::TABLES;
    // (a name's varying part, `<k>`, is text outside code: escaped, or
    // mdbook reads it as an HTML tag left open)
    let pipe = |s: &str| s.replace('|', "\\|");
    let cell = |s: &str| pipe(s).replace('<', "&lt;").replace('>', "&gt;");
    let code = |s: &str| if s.is_empty() { String::new() } else { format!("`{}`", pipe(s)) };
    let mut body = String::from(
        "# Quantities\n\nEvery column of the CSV files `ezy analyze`, `ezy sensitivity`, `ezy optimize`,\n`ezy gait-optimize`, `ezy plan` and `ezy geometry` write, defined once (`ezy-core/src/quantities/`): its unit,\nwhat it is in words and as a formula, the frame it is expressed in and the\ntime it is taken at, and where the definition comes from. Python's\n`describe()` on a result reads the same table.\n\nA name in angle brackets is a part that varies: `<state>` a coordinate or its\nrate (`x1`, `x1d`), `<parameter>` a parameter as the command line names it\n(`motor.omega`), `<hinge>` a hinge's (a shape coordinate's) name, `<k>` a\nnumber from 1, `<quantity>` a differentiated gait quantity, `<objective>`\nan optimization's objective, `<metric>` a run's metric (`final(x1)`),\n`<factor>` a shape rate or a momentum component, `<input>` an input of a\nplan (`push.fx`), `<coefficient>` a coefficient of a gait's Fourier series\n(`alpha1.a0`, `alpha1.b2`), and `<a|b>` one of the words listed.\n\nThe *reference body* of `ezy analyze` and `ezy optimize` is the model's first\nbody; `ezy geometry`'s is the body `--body` names (by default the one at the\nmiddle of the hinge tree).\n",
    );
    for t in TABLES {
        body.push_str(&format!(
            "\n## {}\n\nWritten by `{}`. {}.\n\n| column | unit | definition | formula | frame and time | source |\n|---|---|---|---|---|---|\n",
            cell(t.file),
            t.command,
            cell(t.about)
        ));
        for c in t.columns() {
            body.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} |\n",
                code(c.name),
                cell(c.unit),
                cell(c.meaning),
                code(c.formula),
                cell(c.frame),
                cell(c.source)
            ));
        }
    }
    check_page("docs/book/src/quantities.md", "ezy_core::quantities::TABLES", &body);
}
