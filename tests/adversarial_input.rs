//! Input an adversary would give, generated here: subnormal, huge and
//! negative masses and inertias for every built-in model, runs that would
//! never end or fill the disk, absurd initial velocities, values where
//! they do not belong, and randomly mutated scene files. Every case either
//! runs or stops with a message naming the culprit, before writing
//! anything; none panics, and no output holds NaN or inf.

use std::panic::AssertUnwindSafe;
use std::path::Path;

use ezy::App;
use proptest::prelude::*;

/// Runs `args` (after the program name) through the library; the printed
/// text or the error message. A panic fails the test with the arguments.
fn cli(args: &[&str]) -> Result<String, String> {
    let mut out = Vec::new();
    let app = App::new();
    let argv = std::iter::once("ezy").chain(args.iter().copied());
    match std::panic::catch_unwind(AssertUnwindSafe(|| app.run_cli(argv, &mut out))) {
        Ok(Ok(())) => Ok(String::from_utf8_lossy(&out).into_owned()),
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => panic!("ezy panicked on {args:?}"),
    }
}

/// Every number in every CSV under `dir` is finite.
fn csvs_are_finite(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "csv") {
            let text = std::fs::read_to_string(&p).unwrap();
            // events.csv: `t,event,direction,<state>`, the two names text
            let text_fields: &[usize] = if p.file_name().is_some_and(|n| n == "events.csv") { &[1, 2] } else { &[] };
            for (i, line) in text.lines().enumerate().skip(1) {
                for (_, v) in line.split(',').enumerate().filter(|(k, _)| !text_fields.contains(k)) {
                    let x: f64 =
                        v.parse().unwrap_or_else(|_| panic!("{}:{}: `{v}` is not a number", p.display(), i + 1));
                    assert!(x.is_finite(), "{}:{}: {v}", p.display(), i + 1);
                }
            }
        }
    }
}

/// One scene per built-in model, and the parameters that are its masses
/// and inertias.
fn scenes_and_mass_params() -> Vec<(String, Vec<String>)> {
    let app = App::new();
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    for src in app.scenes().unwrap() {
        let s = &src.scene;
        if out.iter().any(|(name, _)| ezy::models::scenes::get(name).model == s.model) {
            continue;
        }
        let info = ezy::models::scenes::model_info_with(&s.model, &s.params).unwrap().unwrap();
        let mut params: Vec<String> = Vec::new();
        for b in &info.bodies {
            for p in [b.mass_param, b.inertia_param].into_iter().flatten() {
                if !params.iter().any(|q| q == p) {
                    params.push(p.to_string());
                }
            }
        }
        out.push((s.name.clone(), params));
    }
    out
}

/// Subnormal, huge and negative masses and inertias of every model: a
/// subnormal or negative one is refused naming the parameter; a huge one
/// runs or stops with a message; never a panic, never NaN or inf written.
#[test]
fn masses_and_inertias_out_of_range_for_every_model() {
    let dir = tempfile::tempdir().unwrap();
    let cases = scenes_and_mass_params();
    assert!(cases.len() >= 6, "{cases:?}");
    let mut tried = 0;
    for (scene, params) in &cases {
        assert!(!params.is_empty(), "{scene}");
        for p in params {
            for value in ["1e-320", "1e-310", "-1", "1e300"] {
                let out = dir.path().join(format!("{scene}-{p}-{value}"));
                let set = format!("{p}={value}");
                let args =
                    ["run", scene, "--t-end", "0.02", "--no-figures", "--set", &set, "--out", out.to_str().unwrap()];
                let r = cli(&args);
                tried += 1;
                if value != "1e300" {
                    let err = r.expect_err(&set);
                    assert!(err.contains(&format!("invalid setting {p} (")), "{scene} {set}: {err}");
                    assert!(!out.exists(), "{scene} {set}: nothing is written");
                }
                csvs_are_finite(&out);
            }
        }
    }
    eprintln!("{tried} cases");
}

/// Runs that would never end or would fill the disk are refused before
/// any work with the estimate and the flag to pass; nothing is written.
#[test]
fn budgets_refuse_runs_that_would_never_end() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    for (args, want) in [
        (vec!["--dt", "1e-320"], "no budget makes this feasible"),
        (vec!["--t-end", "1e308"], "no budget makes this feasible"),
        (vec!["--dt", "1e-7"], "pass --max-steps 6e8"),
        (vec!["--integrator", "dop853", "--every", "1e-320"], "MB of output"),
        (
            vec!["--integrator", "dop853", "--every", "1e-6", "--t-end", "1e3"],
            "675000 MB of output (1e9 rows of 27 columns in trajectory.csv), more than the limit of 1000; pass --max-output-mb 676000",
        ),
        (vec!["--max-steps", "1000"], "more than the limit of 1000"),
        (vec!["--max-output-mb", "0.01"], "more than the limit of 0.01"),
    ] {
        let mut all = vec!["run", "drive", "--out", o];
        all.extend(&args);
        let err = cli(&all).expect_err(&format!("{args:?}"));
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!out.join("trajectory.csv").exists(), "{args:?}: nothing is written");
    }
    // an adaptive run is stopped when it reaches its step budget
    let err = cli(&[
        "run",
        "sleigh",
        "--integrator",
        "dopri5",
        "--rtol",
        "1e-12",
        "--atol",
        "1e-12",
        "--max-steps",
        "50",
        "--out",
        o,
    ])
    .unwrap_err();
    assert!(err.contains("extrapolated from 50 step attempts"), "{err}");
}

/// Numbers where they cannot be: each is one line naming the flag or the
/// scene key, before any work.
#[test]
fn bad_numbers_and_misplaced_values_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    for (args, want) in [
        (vec!["--dt", "-inf"], "invalid setting --dt = -inf"),
        (vec!["--t-end", "-1"], "invalid setting --t-end = -1"),
        (vec!["--rtol", "nan"], "invalid setting --rtol = NaN"),
        (vec!["--atol", "-1"], "invalid setting --atol = -1"),
        (vec!["--rtol", "1e-20", "--integrator", "rk4"], "invalid setting --rtol = 1e-20"),
        (vec!["--max-output-mb", "nan"], "must be a finite number > 0"),
        (vec!["--set", "m1=nan"], "the value must be finite"),
        (vec!["--integrator", "dopri5", "--rtol", "1e300"], "a relative tolerance above 0.1"),
        (vec!["--max-steps", "2.5"], "must be a whole number from 1 to 2^53"),
        (vec!["--max-steps", "0"], "must be a whole number from 1 to 2^53"),
    ] {
        let mut all = vec!["run", "drive", "--out", o];
        all.extend(&args);
        let err = cli(&all).expect_err(&format!("{args:?}"));
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?}: nothing is written");
    }
    let drive = ezy::models::scenes::BUILTIN[0].1;
    for (from, to, want) in [
        ("method = \"rk4\"", "method = \"dopri5\"\nrtol = 1e-16", "`integrator.rtol`: a tolerance below 1e-14"),
        ("method = \"rk4\"", "method = \"dopri5\"\nrtol = 1e300", "`integrator.rtol`: a relative tolerance above 0.1"),
        ("file = \"fig3_paths.png\"", "file = \"fig3\\u0000paths.png\"", "without directories or control characters"),
        ("[integrator]\nmethod = \"rk4\"\ndt = 1e-4", "[x]", ""),
        ("omega = \"omega\" }", "omega = \"omega\", phase = [0.0] }", "`effects.motor.torque.cos.phase`: an array"),
    ] {
        assert!(drive.contains(from), "{from}");
        let path = dir.path().join("bad.toml");
        let mut text = drive.replace(from, to);
        if want.is_empty() {
            // a top-level array where the [integrator] table belongs
            text = format!("integrator = [\"euler\", 0.01]\n{text}").replace("\n[x]\nprojection = \"mass\"", "");
        }
        let want = if want.is_empty() { "bad.toml:1:14: `integrator`: an array is not allowed here" } else { want };
        std::fs::write(&path, text).unwrap();
        let err = cli(&["run", path.to_str().unwrap(), "--out", o]).unwrap_err();
        assert!(err.contains("bad.toml:") && err.contains(want), "{to}: {err}");
    }
    let big = dir.path().join("big.toml");
    std::fs::write(&big, format!("{drive}\n{}", "# padding\n".repeat(120_000))).unwrap();
    let err = cli(&["run", big.to_str().unwrap(), "--out", o]).unwrap_err();
    assert!(err.contains("larger than 1 MiB"), "{err}");
}

/// The budget's advice is a value the flag takes, in the notation the
/// message uses (`--max-steps 600000`, or `6e10` beyond 1e6).
#[test]
fn the_advised_budget_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let o = o.to_str().unwrap();
    let err = cli(&["run", "drive", "--max-steps", "1e3", "--out", o]).unwrap_err();
    assert!(err.contains("pass --max-steps 600000 (or larger)"), "{err}");
    let err = cli(&["run", "drive", "--dt", "1e-9", "--out", o]).unwrap_err();
    assert!(err.contains("pass --max-steps 6e10 (or larger)"), "{err}");
    cli(&["run", "drive", "--max-steps", "6e10", "--t-end", "0.01", "--no-figures", "--out", o]).unwrap();
}

/// Failures that come from the masses and inertias say so: a spread
/// beyond double precision (constraints found dependent), massless parts
/// (a singular KKT matrix).
#[test]
fn failures_name_their_cause_in_the_masses() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let o = o.to_str().unwrap();
    let err = cli(&["run", "snake", "--set", "m=1e15", "--t-end", "0.1", "--out", o]).unwrap_err();
    assert!(
        err.contains("but the masses and inertias span a factor 1.3e17, from I (inertia of body link1) = 0.0075 to m (mass of body link"),
        "{err}"
    );
    let err = cli(&["run", "sleigh", "--set", "m=0", "--t-end", "0.1", "--out", o]).unwrap_err();
    assert!(err.contains("the KKT matrix (4 x 4) is singular; the massless parts (m (mass of body sleigh))"), "{err}");
    assert!(!Path::new(o).join("trajectory.csv").exists());
}

/// Output that cannot be printed after the files are committed says where
/// the files are; a long command's bad output directory is found before
/// its work.
#[test]
fn a_report_that_cannot_be_printed_and_a_bad_precision_directory() {
    struct Full;
    impl std::io::Write for Full {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::from_raw_os_error(28))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let err = App::new()
        .run_cli(["ezy", "run", "free", "--t-end", "0.1", "--no-figures", "--out", o.to_str().unwrap()], &mut Full)
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with(&format!(
            "the run finished and its output is in {}, but its report could not be written to standard output: ",
            o.display()
        )),
        "{err}"
    );
    assert!(o.join("trajectory.csv").exists());
    let file = dir.path().join("regular");
    std::fs::write(&file, "x").unwrap();
    let err = cli(&["precision", "drive", "--out", file.to_str().unwrap()]).unwrap_err();
    assert!(err.contains("cannot create output directory") && err.contains("regular"), "{err}");
}

/// Messages fit the method, the step and the run.
#[test]
fn messages_fit_the_method_and_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let o = o.to_str().unwrap();
    // a step longer than the run: one step of the run's length
    // (the DAE: on the minimal coordinates auto takes, a 0.5 s RK4 step
    // breaks the energy balance's 1e-2, which the projected DAE keeps)
    let text =
        cli(&["run", "drive", "--dt", "2", "--t-end", "0.5", "--formulation", "dae", "--no-figures", "--out", o])
            .unwrap();
    assert!(text.starts_with("drive: rk4 1 steps of h = 0.5 s to t = 0.5 s"), "{text}");
    // a 1e-15 s run is not "stiff"
    let text =
        cli(&["run", "sleigh", "--integrator", "dop853", "--t-end", "1e-15", "--no-figures", "--out", o]).unwrap();
    assert!(text.contains("to t = 1e-15 s"), "{text}");
    // a fixed step too large: make it smaller; an adaptive run: look at the scene
    let err = cli(&["run", "drive", "--dt", "0.7", "--out", o]).unwrap_err();
    assert!(err.contains("try a smaller --dt"), "{err}");
    for rate in ["1e155", "1e200"] {
        let scene = ezy::models::scenes::BUILTIN.iter().find(|(f, _)| *f == "sleigh.toml").unwrap().1;
        let path = dir.path().join("fast.toml");
        std::fs::write(
            &path,
            scene.replace("qd = { x = 1.0, phi = 1.0 }", &format!("qd = {{ x = {rate}, phi = 1.0 }}")),
        )
        .unwrap();
        let err = cli(&["run", path.to_str().unwrap(), "--integrator", "dop853", "--out", o]).unwrap_err();
        assert!(err.contains("at t = 0 s the kinetic energy T became inf"), "{rate}: {err}");
        assert!(!err.contains("--dt"), "{err}");
        csvs_are_finite(Path::new(o));
    }
}

/// Families of many links: a 10,000-link snake sets up and runs (setup
/// linear in the count: sparse initial values, names looked up by hash;
/// before, 400 links took 35 s and 1000 did not finish in 15 minutes), the
/// summary lists the first components of its state and says where the
/// rest is, `check` runs at 20,000 links (it allocated nc x nq, 720 GB at
/// 100,000), and a massless family too large for the dense LU path is
/// refused naming the parameter, before anything is written.
#[test]
fn huge_families_run_and_check() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("snake");
    let o = out.to_str().unwrap();
    let text = cli(&["run", "snake", "--set", "N=10000", "--t-end", "0.002", "--no-figures", "--out", o]).unwrap();
    assert!(text.contains(", setup ") && text.contains("whole run"), "{text}");
    // 3N coordinates, 3N velocities, N - 1 motors, N resistances, N - 1 springs
    let states = 6 * 10_000 + 3 * 10_000 - 2;
    let more = format!(" and {} more (the last row of trajectory.csv)", states - ezy::session::SUMMARY_STATES);
    assert!(text.contains(&more), "{}", &text[text.len().saturating_sub(300)..]);
    csvs_are_finite(&out);
    let rows = std::fs::read_to_string(out.join("trajectory.csv")).unwrap().lines().count();
    assert_eq!(rows, 3, "header, t = 0 and t = 0.002");

    let table = cli(&["check", "snake", "--set", "N=20000"]).unwrap();
    assert!(table.contains("at 5 random states") && !table.contains("FAILED"), "{table}");

    let massless = dir.path().join("massless");
    let err =
        cli(&["run", "snake", "--set", "N=1000", "--set", "m=0", "--out", massless.to_str().unwrap()]).unwrap_err();
    assert!(
        err.contains("invalid setting m (mass of body link1) = 0: a massless part needs the dense LU path"),
        "{err}"
    );
    assert!(!massless.exists());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    /// Randomly mutated scene files (characters deleted, inserted or
    /// replaced, numbers swapped for extreme values) never panic: each is
    /// refused with a located message or runs briefly, writing only finite
    /// numbers.
    #[test]
    fn mutated_scene_files_never_panic(
        scene in 0usize..ezy::models::scenes::BUILTIN.len(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0u8..4, prop::sample::select(vec![
            "1e308", "-1e308", "5e-324", "0", "-0", "nan", "inf", "\"", "[", "]", "{", "}", "=", "\n[x]\n", "1e400", "\"B\"", "-1",
        ])), 1..4),
    ) {
        let mut text = ezy::models::scenes::BUILTIN[scene].1.to_string();
        for (at, op, token) in edits {
            let bytes: Vec<usize> = text.char_indices().map(|(i, _)| i).collect();
            let i = bytes[at.index(bytes.len())];
            let end = text[i..].char_indices().nth(1).map_or(text.len(), |(j, _)| i + j);
            match op {
                0 => text.replace_range(i..end, ""),
                1 => text.insert_str(i, token),
                2 => text.replace_range(i..end, token),
                _ => {
                    // the number starting at or after i becomes the token
                    if let Some(start) = text[i..].find(|c: char| c.is_ascii_digit()).map(|k| i + k) {
                        let len = text[start..].find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-')).unwrap_or(text.len() - start);
                        text.replace_range(start..start + len, token);
                    }
                }
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mutated.toml");
        std::fs::write(&path, &text).unwrap();
        let out = dir.path().join("out");
        let r = cli(&["run", path.to_str().unwrap(), "--t-end", "0.02", "--max-steps", "20000", "--no-figures", "--out", out.to_str().unwrap()]);
        if let Err(e) = &r {
            prop_assert!(!e.is_empty());
        }
        csvs_are_finite(&out);
    }
}
