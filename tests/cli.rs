//! The `ezy` binary: list, run with outputs, and errors that name the culprit.

use std::path::PathBuf;
use std::process::{Command, Output};

use crate::common;

fn ezy(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("ezy runs")
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ezy-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Whether `dir` holds a temporary of a run (its private directory, or a
/// `.partial` file of older versions).
fn has_temporaries(dir: &std::path::Path) -> bool {
    std::fs::read_dir(dir).into_iter().flatten().flatten().any(|e| {
        let n = e.file_name().to_string_lossy().into_owned();
        n.starts_with(".ezy-run.") || n.ends_with(".partial")
    })
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn list_shows_models_and_scenes() {
    let o = ezy(&["list"]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    for name in ["ezyroller", "chaplygin_sleigh", "drive", "free", "sleigh"] {
        assert!(out.contains(name), "`{name}` missing from:\n{out}");
    }
}

#[test]
fn run_writes_the_csv_and_every_figure() {
    let dir = tmp_dir("drive");
    let o = ezy(&["run", "drive", "--t-end", "0.5", "--every", "0.1", "--out", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    assert_eq!(
        header,
        "t,x1,y1,phi1,x2,y2,phi2,x1d,y1d,phi1d,x2d,y2d,phi2d,T,W,W_motor,A.x,A.y,B1.x,B1.y,B2.x,B2.y,C.x,C.y,tau_motor,res_phi,res_vel"
    );
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    // t = 0, 0.1, ..., 0.5: the final time is written
    assert_eq!(rows.len(), 6);
    assert!((rows[5][0] - 0.5).abs() < 1e-12);
    // the motor column is M0 cos(omega t); W is the motor's work alone
    let tau = rows[5][24];
    assert_eq!(rows[5][14], rows[5][15]);
    assert!((tau - 2.0 * (std::f64::consts::PI * 0.5).cos()).abs() < 1e-12);
    for f in common::DRIVE_FIGURES {
        let bytes = std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert!(bytes.starts_with(b"\x89PNG"), "{f} is not a PNG");
    }
    assert!(!has_temporaries(&dir));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("rk4 5000 steps of h = 0.0001 s") && out.contains("max |T - T0 - W|"), "{out}");
}

#[test]
fn set_changes_a_parameter() {
    let dir = tmp_dir("set");
    let base = ezy(&["run", "free", "--t-end", "0.1", "--no-figures", "--out", dir.to_str().unwrap()]);
    let csv0 = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let o = ezy(&["run", "free", "--t-end", "0.1", "--no-figures", "--set", "m1=20", "--out", dir.to_str().unwrap()]);
    assert!(base.status.success() && o.status.success(), "{}", stderr(&o));
    let csv1 = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let t0 = |csv: &str| -> f64 { csv.lines().nth(1).unwrap().split(',').nth(13).unwrap().parse().unwrap() };
    // T0 = m1/2 x1d^2 + ... : lighter body 1, less kinetic energy
    assert!((t0(&csv0) - 23.1875).abs() < 1e-9);
    assert!((t0(&csv0) - t0(&csv1) - 13.0).abs() < 1e-9, "{} vs {}", t0(&csv0), t0(&csv1));
}

#[test]
fn adaptive_run_outputs_at_exact_times() {
    let dir = tmp_dir("dop853");
    let o = ezy(&[
        "run",
        "sleigh",
        "--integrator",
        "dop853",
        "--rtol",
        "1e-10",
        "--atol",
        "1e-10",
        "--every",
        "0.5",
        "--no-figures",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    // outputs at exact multiples of --every from dense output: 0, 0.5, ..., 10
    let ts: Vec<f64> = csv.lines().skip(1).map(|l| l.split(',').next().unwrap().parse().unwrap()).collect();
    assert_eq!(ts.len(), 21);
    for (k, t) in ts.iter().enumerate() {
        assert!((t - 0.5 * k as f64).abs() < 1e-12, "sample {k} at t = {t}");
    }
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("dop853") && out.contains("rejected"), "{out}");
}

#[test]
fn precision_writes_the_exact_csv_columns() {
    let dir = tmp_dir("precision");
    let o = ezy(&["precision", "sleigh", "--format", "csv", "--out", dir.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let mut lines = out.lines();
    assert_eq!(lines.next().unwrap(), "method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual");
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), ezy::precision::ladder().len());
    for r in &rows {
        assert_eq!(r.len(), 9);
        let error: f64 = r[5].parse().unwrap();
        let wall: f64 = r[6].parse().unwrap();
        assert!(error.is_finite() && wall > 0.0, "{r:?}");
    }
    // a tight DOP853 setting is far more accurate than a loose Euler one
    let err_of = |m: &str, key: &str| -> f64 {
        rows.iter()
            .find(|r| r[0] == m && (r[1] == key || r[2] == key) && r[4] == "mass")
            .map(|r| r[5].parse().unwrap())
            .unwrap()
    };
    assert!(err_of("dop853", "1e-10") < 1e-8 && err_of("euler", "1e-2") > 1e-4);
    for f in ["precision.csv", "work_precision.png", "drift.png"] {
        assert!(dir.join(f).exists(), "{f}");
    }
}

/// A step far too large stops with the time, the quantity and a
/// suggestion, and leaves no trajectory behind.
#[test]
fn a_step_far_too_large_is_an_error() {
    let dir = tmp_dir("diverge");
    let o = ezy(&["run", "drive", "--dt", "0.7", "--out", dir.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("at t = 1.4 s") && e.contains("energy balance") && e.contains("--integrator dop853"), "{e}");
    assert!(!e.contains("NaN") && !e.contains("inf"), "{e}");
    assert!(!dir.join("trajectory.csv").exists() && !has_temporaries(&dir));
}

#[test]
fn an_unwritable_output_directory_is_named_before_any_work() {
    let dir = tmp_dir("blocked");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let out = file.join("out");
    let o = ezy(&["run", "drive", "--out", out.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("cannot create output directory") && e.contains("a-file"), "{e}");
    // it failed fast: no integration summary was printed
    assert!(String::from_utf8_lossy(&o.stdout).is_empty());
}

#[test]
fn bad_input_is_named() {
    let cases: &[(&[&str], &str)] = &[
        (&["run", "nowhere"], "unknown scene `nowhere`; known scenes: drive, free, sleigh"),
        (&["run", "drive", "--set", "mass=2"], "unknown parameter `mass`"),
        (&["run", "drive", "--set", "m1=abc"], "`abc` is not a number"),
        (&["run", "drive", "--set", "m1=nan"], "must be finite"),
        (&["run", "drive", "--set", "m1=inf"], "must be finite"),
        (&["run", "drive", "--every", "0"], "--every = 0"),
        (&["run", "drive", "--dt", "-1"], "--dt = -1"),
        (&["run", "drive", "--t-end", "0"], "--t-end = 0"),
        (&["run", "drive", "--set", "m1=-1"], "invalid setting m1 (mass of body body1) = -1"),
        (&["run", "drive", "--set", "I2=-0.5"], "invalid setting I2 (inertia of body body2) = -0.5"),
        (&["run", "drive", "--integrator", "dopri5", "--rtol", "0"], "--rtol = 0"),
        (&["run", "drive", "--integrator", "dop853", "--atol", "1e-20"], "--atol = 1e-20: a tolerance below 1e-14"),
        (&["run", "drive", "--baumgarte", "1"], "expected ALPHA,BETA"),
    ];
    for (args, want) in cases {
        let o = ezy(args);
        assert!(!o.status.success(), "{args:?} succeeded");
        let e = stderr(&o);
        assert!(e.contains(want), "{args:?}: expected `{want}` in: {e}");
    }
}

/// `ezy run models/scenes/drive.toml` and `ezy run drive` write the same
/// bytes, and a copy of the file elsewhere, edited, runs too.
#[test]
fn a_scene_file_by_path_equals_the_builtin_scene() {
    let (a, b) = (tmp_dir("by-name"), tmp_dir("by-path"));
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/drive.toml");
    for (scene, dir) in [("drive", &a), (file, &b)] {
        let o = ezy(&["run", scene, "--t-end", "0.3", "--no-figures", "--out", dir.to_str().unwrap()]);
        assert!(o.status.success(), "{scene}: {}", stderr(&o));
    }
    let csv_a = std::fs::read(a.join("trajectory.csv")).unwrap();
    assert_eq!(csv_a, std::fs::read(b.join("trajectory.csv")).unwrap());

    let dir = tmp_dir("edited");
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(file).unwrap().replace("M0 = 2.0", "M0 = 3.0");
    let mine = dir.join("my_scene.toml");
    std::fs::write(&mine, text).unwrap();
    let out = dir.join("out");
    let o = ezy(&["run", mine.to_str().unwrap(), "--t-end", "0.3", "--no-figures", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let k = header.iter().position(|c| *c == "tau_motor").unwrap();
    let first: Vec<f64> = csv.lines().nth(1).unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(first[k], 3.0);
}

/// `tau_motor` and the printed final state of `ezy run drive` for 1 s with
/// `extra` arguments.
fn drive_torque(name: &str, extra: &[&str]) -> (Vec<(f64, f64)>, String) {
    let dir = tmp_dir(name);
    let mut args = vec!["run", "drive", "--t-end", "1", "--no-figures", "--out", dir.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = ezy(&args);
    assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let last = out.lines().find(|l| l.contains("final state")).unwrap().to_string();
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let k = header.iter().position(|c| *c == "tau_motor").unwrap();
    let tau = csv
        .lines()
        .skip(1)
        .map(|l| {
            let row: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
            (row[0], row[k])
        })
        .collect();
    (tau, last)
}

/// The drive scene's motor is `M0 cos(omega t)` with scene parameters `M0`
/// and `omega`: `--set M0=0.1` and `--set omega=5` change the torque, the
/// motor's own key still works, and an unknown name lists the scene
/// parameters too.
#[test]
fn set_changes_scene_parameters() {
    let (tau, state) = drive_torque("params-default", &[]);
    let max = |tau: &[(f64, f64)]| tau.iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
    assert_eq!(max(&tau), 2.0);
    let (small, small_state) = drive_torque("params-m0", &["--set", "M0=0.1"]);
    assert_ne!(small_state, state);
    assert!((max(&small) - 0.1).abs() <= 1e-15, "max |tau| = {}", max(&small));
    for ((t, a), (_, b)) in tau.iter().zip(&small) {
        assert!((b - 0.05 * a).abs() <= 1e-15, "t = {t}: {b} vs {a} / 20");
    }
    let (fast, _) = drive_torque("params-omega", &["--set", "omega=5"]);
    for (t, v) in &fast {
        assert!((v - 2.0 * (5.0 * t).cos()).abs() <= 1e-12, "t = {t}: {v}");
    }
    // the number's own key still works, and wins over its scene parameter
    let (three, _) = drive_torque("params-key", &["--set", "motor.amplitude=3", "--set", "M0=0.1"]);
    assert_eq!(max(&three), 3.0);
    let o = ezy(&["run", "drive", "--t-end", "0.1", "--no-figures", "--set", "M1=1"]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("unknown parameter `M1`") && e.contains("M0, omega"), "{e}");
}

/// A bad scene file: one line on stderr with file:line:column and the key,
/// exit status 1, and no output directory made.
#[test]
fn a_bad_scene_file_is_named_with_its_line_and_nothing_is_written() {
    let dir = tmp_dir("bad-scene");
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/drive.toml"))
        .unwrap()
        .replace("hinge = \"B\"", "hinge = \"Q\"");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, &text).unwrap();
    let out = dir.join("out");
    let o = ezy(&["run", bad.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let line = text[..text.find("hinge = \"Q\"").unwrap()].matches('\n').count() + 1;
    let err = stderr(&o);
    let want = format!(
        "{}:{line}:9: `effects.motor.hinge`: unknown hinge `Q` in model EzyRoller; its hinges: B",
        bad.display()
    );
    assert_eq!(err.trim(), format!("error: {want}"));
    assert!(!out.exists());
    let o = ezy(&["run", dir.join("missing.toml").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("missing.toml: cannot read the scene file"), "{}", stderr(&o));
}

/// `ezy equations ezyroller` prints docs/physics.md §10.2's formulas, derived by the
/// macro: the hinge residual, the skate rows and the convective terms.
#[test]
fn equations_print_what_the_macro_derived() {
    let o = ezy(&["equations", "ezyroller"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for line in [
        "M = diag(m1, m1, I1, m2, m2, I2)",
        "B.x  x1 + b*cos(phi1) - x2 + d*cos(phi2)",
        "B.y  y1 + b*sin(phi1) - y2 + d*sin(phi2)",
        "A    -x1d*sin(phi1) + y1d*cos(phi1) - a*phi1d = 0   (skate)",
        "C    -x2d*sin(phi2) + y2d*cos(phi2) + c*phi2d = 0   (skate)",
        "G[B.y, y2] = -1",
        "B.x  -b*phi1d^2*cos(phi1) - d*phi2d^2*cos(phi2)",
        "A    phi1d*(-x1d*cos(phi1) - y1d*sin(phi1))",
        "A: (x1d + a*phi1d*sin(phi1), y1d - a*phi1d*cos(phi1))",
    ] {
        assert!(out.contains(line), "`{line}` missing from:\n{out}");
    }
    let o = ezy(&["equations", "ezyroller", "--format", "latex"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let tex = String::from_utf8_lossy(&o.stdout);
    assert!(tex.starts_with("\\documentclass{article}") && tex.trim_end().ends_with("\\end{document}"));
    assert!(tex.contains("x_{1} + b \\cos \\varphi_{1} - x_{2} + d \\cos \\varphi_{2} = 0"), "{tex}");
    assert!(
        tex.contains("-\\dot{x}_{1} \\sin \\varphi_{1} + \\dot{y}_{1} \\cos \\varphi_{1} - a \\dot{\\varphi}_{1}"),
        "{tex}"
    );
    assert_eq!(tex.matches('{').count(), tex.matches('}').count(), "unbalanced braces");
    assert_eq!(tex.matches("\\begin{").count(), tex.matches("\\end{").count());
    let o = ezy(&["equations", "tricycle"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("unknown model `tricycle`; known models: ezyroller, ezyroller_driven, chaplygin_sleigh"),
        "{}",
        stderr(&o)
    );
}

/// `ezy check` passes for every registered model and prints one line per term.
#[test]
fn check_passes_for_every_model() {
    use ezy_scene::registry::ModelCatalog;
    for model in ezy_models::builtins().keys() {
        let o = ezy(&["check", model, "--states", "20"]);
        assert!(o.status.success(), "{model}: {}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains("gamma = d/dq(G qd) qd") && out.contains(" ok "), "{out}");
        assert!(!out.contains("FAILED"), "{out}");
    }
}

/// `ezy check` names the pivots of the minimal coordinates at the given
/// parameters and which one rules them out; a skate 1 mm from body 1's
/// centre of mass (its lateral velocity the pivot, body 1's rates as on
/// any other geometry) passes, and one 1 mm from the hinge on body 2
/// (an angular-rate pivot of 1 mm) is refused.
#[test]
fn check_names_the_pivots_of_minimal_coordinates() {
    let o = ezy(&["check", "ezyroller", "--states", "20"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}{}", stderr(&o));
    assert!(out.contains("minimal coordinates: 4 coordinates, 2 speeds"), "{out}");
    assert!(out.contains("skate `A` fixes the lateral velocity of `body1` in its frame with pivot 1.0000"), "{out}");
    assert!(
        out.contains(
            "skate `C` fixes `phi2d` with pivot 0.2000 m, 2.828 of the radius of gyration 0.0707 m of `body2`"
        ),
        "{out}"
    );
    let o = ezy(&["check", "ezyroller", "--set", "a=0.001"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}{}", stderr(&o));
    assert!(out.contains("minimal coordinates: 4 coordinates, 2 speeds"), "{out}");
    let o = ezy(&["check", "ezyroller", "--set", "c=-0.099"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}{}", stderr(&o));
    assert!(out.contains("minimal coordinates refused at these parameters: the pivot of skate `C`"), "{out}");
    let o = ezy(&["check", "trailer", "--states", "2"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("no minimal coordinates: "), "{}", stderr(&o));
}

/// `ezy equations` and `ezy check` take `--set` for family counts: the
/// snake at two links has six coordinates and one hinge, at twelve links
/// the check compares 3 x 22 x 4 entries of `C_q` (its 36 columns fall in
/// four groups that share no row, each group perturbed at once); a bad
/// count or name is an error that names it.
#[test]
fn equations_and_check_take_family_counts() {
    let o = ezy(&["equations", "snake", "--set", "N=2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("(nq = 6, nc = 4)") && out.contains("J2.x") && !out.contains("J3"), "{out}");
    let o = ezy(&["check", "snake", "--set", "N=12", "--states", "3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // C_q compared at 3 states x 22 hinge rows x 4 column groups
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.lines().any(|l| l.starts_with("C_q") && l.contains(" 264 ")), "{out}");
    let o = ezy(&["equations", "snake", "--set", "N=0"]);
    assert!(!o.status.success() && stderr(&o).contains("N = 0 is a count"), "{}", stderr(&o));
    // a family index of 0 or 1 is simplified away, not printed as a
    // factor (it printed `xc0 - 0.5*L*cos(theta0) - 0*L` and `- 1*L`)
    let o = ezy(&["equations", "n_four_bar"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("O0.x  xc0 - 0.5*L*cos(theta0) = 0") && out.contains("O1.x  -L + xc1"), "{out}");
    assert!(out.contains("- 2*L") && !out.contains("0*L") && !out.contains(" 1*L"), "{out}");
    let o = ezy(&["equations", "n_four_bar", "--format", "latex"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("2 L") && !out.contains("- 0 L") && !out.contains(" 1 L"), "{out}");
    let o = ezy(&["equations", "snake", "--set", "Q=1"]);
    assert!(!o.status.success() && stderr(&o).contains("unknown parameter `Q`"), "{}", stderr(&o));
}

/// A bare name is a known scene, a name with `/` or ending in `.toml` a
/// file; a bare name that is also a file in the working directory is
/// refused as ambiguous, and nothing runs.
#[test]
fn a_bare_name_is_a_scene_and_a_path_is_a_file() {
    let dir = tmp_dir("ambiguous");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("drive"), "not a scene").unwrap();
    let run = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).current_dir(&dir).output().unwrap();
    let o = run(&["run", "drive", "--t-end", "0.01"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("`drive` is both a known scene and a file in the working directory"), "{}", stderr(&o));
    assert!(!dir.join("out").exists(), "nothing is written");
    // `./drive` is the file (not a scene: a located TOML error)
    let o = run(&["run", "./drive"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("./drive:1:"), "{}", stderr(&o));
    // a bare name that is only a file is not read
    std::fs::write(dir.join("mine"), "not a scene").unwrap();
    let o = run(&["run", "mine"]);
    assert!(stderr(&o).contains("unknown scene `mine`"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}
