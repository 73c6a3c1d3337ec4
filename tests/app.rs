//! A model that is not built in, added to an [`ezy::App`] the way a user's
//! `main.rs` adds theirs: every command works for it through the library
//! (no subprocess), with the same output and the same located errors as
//! for the built-in vehicles.

use ezy::App;
use ezy::app::AppError;

ezy::model! {
    /// A sleigh with its skate ahead of the centre of mass (unstable
    /// forwards, so it turns round), written in the test.
    pub struct FrontSleigh {
        /// Mass [kg]
        param m = 2.0;
        /// Moment of inertia about the centre of mass [kg m^2]
        param I = 0.2;
        /// Distance from the centre of mass forward to the skate [m]
        param e = 0.3;

        body sled(x, y, phi) { mass: m, inertia: I }
        point K on sled at (e, 0);
        skate K: K along (1, 0);
    }
}

const SCENE: &str = r#"
name = "front-sleigh"
description = "A sleigh with its skate ahead of the centre of mass, 2 s"
model = "front_sleigh"
t_end = 2.0

[params]
m = 2.0

[initial]
q = { x = 0.0, y = 0.0, phi = 0.0 }
qd = { x = 1.0, phi = 0.1 }

[integrator]
method = "rk4"
dt = 1e-3

[output]
every = 0.05
include = ["energy", "points", "residuals"]

[[figures]]
file = "paths.png"
title = "Paths"
x_label = "x [m]"
y_label = "y [m]"
paths = ["sled", "K"]
"#;

fn app() -> App {
    App::new().model::<FrontSleigh>("front_sleigh").scene("front-sleigh.toml", SCENE)
}

/// Runs `args` (without the program name) through the library; the
/// printed text, or the error.
fn cli(app: &App, args: &[&str]) -> Result<String, AppError> {
    let mut out = Vec::new();
    app.run_cli(std::iter::once("my-vehicles").chain(args.iter().copied()), &mut out)?;
    Ok(String::from_utf8(out).expect("utf-8"))
}

#[test]
fn list_shows_the_users_model_and_scene_after_the_built_ins() {
    let out = cli(&app(), &["list"]).unwrap();
    assert!(out.contains("  ezyroller "), "{out}");
    let line = out.lines().find(|l| l.trim_start().starts_with("front_sleigh")).expect(&out);
    assert!(line.contains("A sleigh with its skate ahead") && line.contains("(nq = 3, nc = 1)"), "{line}");
    assert!(out.lines().any(|l| l.trim_start().starts_with("front-sleigh ")), "{out}");
}

#[test]
fn run_writes_the_csv_and_figures_and_takes_set() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    let o = out_dir.to_str().unwrap();
    let text = cli(&app(), &["run", "front-sleigh", "--out", o, "--set", "e=0.5"]).unwrap();
    assert!(text.starts_with("front-sleigh: rk4 2000 steps of h = 0.001 s to t = 2 s"), "{text}");
    assert!(text.contains("final state: x = ") && text.contains("wrote "), "{text}");
    let csv = std::fs::read_to_string(out_dir.join("trajectory.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 41, "header + rows at t = 0, 0.05, .., 2");
    assert!(std::fs::metadata(out_dir.join("paths.png")).unwrap().len() > 1000);
    // the kinetic energy is conserved by the skate: the run's ledger closes
    let max_gap: f64 = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("max |T - T0 - W| = "))
        .and_then(|v| v.trim_end_matches(" J").parse().ok())
        .expect(&text);
    assert!(max_gap < 1e-9, "{text}");
}

#[test]
fn scene_errors_name_the_users_model_and_file() {
    let bad = SCENE.replace("paths = [\"sled\", \"K\"]", "paths = [\"sled\", \"Q\"]");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, bad).unwrap();
    let err = cli(&app(), &["run", path.to_str().unwrap()]).unwrap_err().to_string();
    assert!(err.contains("bad.toml:") && err.contains("`Q`") && err.contains("FrontSleigh"), "{err}");
    // an unknown model key lists the user's model with the built-ins
    let unknown = SCENE.replace("model = \"front_sleigh\"", "model = \"front_sled\"");
    std::fs::write(&path, unknown).unwrap();
    let err = cli(&app(), &["run", path.to_str().unwrap()]).unwrap_err().to_string();
    assert!(err.contains("unknown model `front_sled`") && err.contains("front_sleigh"), "{err}");
}

#[test]
fn check_and_equations_work_for_the_users_model() {
    let out = cli(&app(), &["check", "front_sleigh", "--states", "20"]).unwrap();
    assert!(out.starts_with("FrontSleigh: generated terms at 20 random states"), "{out}");
    assert!(!out.contains("FAILED") && out.contains("dual numbers"), "{out}");
    let eq = cli(&app(), &["equations", "front_sleigh"]).unwrap();
    // the skate row: lateral velocity of K = -sin(phi) xd + cos(phi) yd + e phid
    assert!(eq.contains("K") && eq.contains("e*phid"), "{eq}");
    let err = cli(&app(), &["equations", "front_sleigh", "--set", "f=1"]).unwrap_err().to_string();
    assert!(err.contains("unknown parameter `f` in model FrontSleigh; its parameters: m, I, e"), "{err}");
}

#[test]
fn precision_runs_the_ladder_for_the_users_scene() {
    let short = SCENE.replace("t_end = 2.0", "t_end = 0.1");
    let app = App::empty().model::<FrontSleigh>("front_sleigh").scene("short.toml", Box::leak(short.into_boxed_str()));
    let dir = tempfile::tempdir().unwrap();
    let out =
        cli(&app, &["precision", "front-sleigh", "--format", "csv", "--out", dir.path().to_str().unwrap()]).unwrap();
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(rows[0], "method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual");
    assert_eq!(rows.len() - 1, ezy::precision::ladder().len());
    assert!(dir.path().join("precision.csv").is_file() && dir.path().join("work_precision.png").is_file());
}

#[test]
fn a_key_or_scene_given_twice_is_refused_by_every_command() {
    let twice = app().model::<FrontSleigh>("front_sleigh");
    for args in [&["list"][..], &["run", "front-sleigh"], &["check", "ezyroller"]] {
        let err = cli(&twice, args).unwrap_err().to_string();
        assert!(err.contains("model key `front_sleigh` is registered twice"), "{args:?}: {err}");
    }
    let scene_twice = app().scene("again.toml", SCENE);
    let err = cli(&scene_twice, &["list"]).unwrap_err().to_string();
    assert!(err.contains("scene `front-sleigh` is given twice: in front-sleigh.toml and in again.toml"), "{err}");
}

#[test]
fn the_default_scene_and_usage_errors() {
    let err = cli(&App::empty(), &["run"]).unwrap_err().to_string();
    assert!(err.contains("no default scene"), "{err}");
    assert!(matches!(cli(&app(), &["run", "--dt"]), Err(AppError::Usage(_))));
    let help = cli(&app(), &["--help"]).unwrap_err().to_string();
    assert!(help.contains("precision") && help.contains("equations"), "{help}");
}

/// `run NAME` parses and checks only the scene it names when every scene
/// declares its name plainly: a broken scene beside it does not stop the
/// run, while `list` (which reads them all) names the broken one, and
/// `run` of the broken one gives its error with its file.
#[test]
fn a_broken_scene_stops_only_what_reads_it() {
    let broken = SCENE.replace("front-sleigh", "broken-sleigh").replace("t_end = 2.0", "t_end = -2.0");
    let app = app().scene("broken.toml", Box::leak(broken.into_boxed_str()));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let ran = cli(&app, &["run", "front-sleigh", "--no-figures", "--t-end", "0.1", "--out", out]).unwrap();
    assert!(ran.contains("front-sleigh: rk4"), "{ran}");
    let err = cli(&app, &["list"]).unwrap_err().to_string();
    assert!(err.contains("broken.toml") && err.contains("t_end"), "{err}");
    let err = cli(&app, &["run", "broken-sleigh", "--out", out]).unwrap_err().to_string();
    assert!(err.contains("broken.toml") && err.contains("t_end"), "{err}");
}

/// The user's scene run in memory gives every row of the file run's
/// `trajectory.csv`, number for number (the CSV holds each number's
/// shortest round-trip form), with the same columns, and writes nothing;
/// a stop hook ends it between steps with the time it reached.
#[test]
fn a_run_in_memory_is_the_file_run_without_files() {
    let app = app();
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    let scene = app.load_scene("front-sleigh").unwrap().scene;
    let opts = ezy::RunOptions { out: out_dir.clone(), figures: false, ..Default::default() };
    let file = app.run_scene(&scene, &opts).unwrap();
    let csv = std::fs::read_to_string(out_dir.join("trajectory.csv")).unwrap();
    let memory_out = dir.path().join("never");
    let opts = ezy::RunOptions { out: memory_out.clone(), ..opts };
    let memory = app.run_scene_in_memory(&scene, &opts, None).unwrap();
    assert!(!memory_out.exists() && memory.files.is_empty(), "the in-memory run wrote {:?}", memory.files);
    let table = &memory.table;
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap().split(',').collect::<Vec<_>>(), table.columns);
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 41);
    assert_eq!(table.rows(), rows.len());
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(&table.data[k * row.len()..(k + 1) * row.len()], &row[..], "row {k}");
    }
    assert_eq!(memory.summary.final_state, file.summary.final_state);
    // a hook that stops the run once it has passed t = 0.5 s
    let mut stop = |t: f64| (t >= 0.5).then(|| "enough".to_string());
    let err = app.run_scene_in_memory(&scene, &opts, Some(&mut stop)).unwrap_err();
    match err {
        ezy::session::Error::Stopped { t, ref reason } => {
            assert!((0.5..0.5 + 2e-3).contains(&t) && reason == "enough", "{err}");
        }
        e => panic!("{e}"),
    }
}
