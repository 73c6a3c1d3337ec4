//! Design questions on the sensitivities (`ezy_core::design`): parameters
//! fitted to measurements, from noise-free and noisy synthetic data.

use crate::common;

use ezy::models::{EzyRoller, scenes};
use ezy_core::design::fit::{Data, fit};
use rand::Rng;

/// The rolling-resistance scene over 4 s at DOP853 1e-12, and the true
/// values the data are made at: the front skate's damping 1.3 N s/m and
/// the motor's amplitude 2.4 N m (the scene has 1 and 2).
fn setting() -> (ezy_scene::Scene, Vec<(String, f64, f64)>, [f64; 2]) {
    let mut scene = scenes::get("drive-rolling-resistance");
    scene.t_end = 4.0;
    scene.integrator.rtol = 1e-12;
    scene.integrator.atol = 1e-12;
    let over = vec![("rolling_A.damping".to_string(), 0.0, 5.0), ("motor.amplitude".to_string(), 1.0, 3.0)];
    (scene, over, [1.3, 2.4])
}

/// The run at the true values sampled every 0.1 s (x1, y1), with noise of
/// standard deviation `sigma` [m].
fn data(scene: &ezy_scene::Scene, truth: [f64; 2], sigma: f64) -> Data {
    let sets = [("rolling_A.damping".to_string(), truth[0]), ("motor.amplitude".to_string(), truth[1])];
    let (mut problem, _) = scene.problem::<EzyRoller>(&sets).unwrap();
    problem.settings.every = 0.1;
    let run = problem.solve().unwrap();
    let mut rng = common::rng(7);
    let mut noisy = |v: Vec<f64>| -> Vec<f64> {
        v.into_iter()
            .map(|x| {
                // Box-Muller
                let (a, b): (f64, f64) = (rng.random(), rng.random());
                x + sigma * (-2.0 * (1.0 - a).ln()).sqrt() * (std::f64::consts::TAU * b).cos()
            })
            .collect()
    };
    let (x1, y1) = (run.column("x1").unwrap(), run.column("y1").unwrap());
    Data { t: run.t.clone(), columns: vec!["x1".into(), "y1".into()], values: vec![noisy(x1), noisy(y1)] }
}

/// Noise-free data: the fit recovers both parameters to 1e-8 (relative)
/// from the scene's values, in at most 20 runs (the target; the
/// runs' error at 1e-12 leaves about 1e-10 in the estimates).
#[test]
fn a_fit_recovers_parameters_from_noise_free_data() {
    let (scene, over, truth) = setting();
    let design = scene.design(&EzyRoller::default(), &[], &over).unwrap();
    assert_eq!(design.start, vec![1.0, 2.0]);
    let f = fit(&design, &data(&scene, truth, 0.0), None).unwrap();
    eprintln!("noise-free: {:?} in {} runs ({})", f.estimate, f.runs, f.termination);
    for (e, t) in f.estimate.iter().zip(truth) {
        assert!((e - t).abs() <= 1e-8 * t, "estimate {e} against {t}");
    }
    assert!(f.runs <= 20, "{} runs", f.runs);
    assert!(f.residual_rms.iter().all(|r| *r < 1e-8), "{:?}", f.residual_rms);
}

/// Data with noise of 1 mm: each estimate lies within two standard
/// errors of the truth, the standard errors are positive and finite, the
/// residual per column is near the noise (0.5 to 2 mm).
#[test]
fn a_fit_to_noisy_data_lies_within_two_standard_errors() {
    let (scene, over, truth) = setting();
    let design = scene.design(&EzyRoller::default(), &[], &over).unwrap();
    let f = fit(&design, &data(&scene, truth, 1e-3), None).unwrap();
    eprintln!(
        "noisy: {:?} +- {:?}, corr {:?}, rms {:?}, {} runs",
        f.estimate, f.std_error, f.correlation, f.residual_rms, f.runs
    );
    for (k, t) in truth.iter().enumerate() {
        let (e, se) = (f.estimate[k], f.std_error[k]);
        assert!(se.is_finite() && se > 0.0);
        assert!((e - t).abs() <= 2.0 * se, "{k}: {e} +- {se}");
    }
    assert!(f.residual_rms.iter().all(|r| (5e-4..2e-3).contains(r)), "{:?}", f.residual_rms);
    assert!((f.correlation[0][1] - f.correlation[1][0]).abs() < 1e-12);
}

/// Bad requests are refused before any run, naming the culprit: data
/// with NaN or unsorted times, a column the model does not have, bounds
/// that exclude the start.
#[test]
fn bad_fits_are_refused_naming_the_culprit() {
    let (scene, over, truth) = setting();
    let model = EzyRoller::default();
    let design = scene.design(&model, &[], &over).unwrap();
    let good = data(&scene, truth, 0.0);
    let mut nan = good.clone();
    nan.values[1][3] = f64::NAN;
    assert!(fit(&design, &nan, None).unwrap_err().to_string().contains("row 4, column `y1`"));
    let mut unsorted = good.clone();
    unsorted.t.swap(2, 3);
    assert!(fit(&design, &unsorted, None).unwrap_err().to_string().contains("row 4"));
    let mut other = good.clone();
    other.columns[1] = "nope".into();
    assert!(fit(&design, &other, None).unwrap_err().to_string().contains("`nope`"));
    let outside = vec![("rolling_A.damping".to_string(), 2.0, 5.0)];
    assert!(scene.design(&model, &[], &outside).unwrap_err().to_string().contains("outside the bounds"));
    assert!(scene.design(&model, &[], &[("nope".into(), 0.0, 1.0)]).unwrap_err().to_string().contains("nope"));
}

/// `ezy fit` on a run written by `ezy run`: the estimates recovered (to
/// 1e-8), fit.csv and the figure written; data with NaN refused naming
/// the file, the row and the column.
#[test]
fn the_command_fits_a_run_written_by_ezy_run() {
    let dir = std::env::temp_dir().join(format!("ezy-fit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let ezy = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().unwrap();
    let (data, out) = (dir.join("data"), dir.join("fit"));
    let tight = ["--rtol", "1e-12", "--atol", "1e-12"];
    let mut run = vec!["run", "drive-rolling-resistance", "--set", "rolling_A.damping=1.3", "--set"];
    run.extend(["motor.amplitude=2.4", "--t-end", "4", "--every", "0.1", "--no-figures"]);
    run.extend(tight);
    run.extend(["--out", data.to_str().unwrap()]);
    let o = ezy(&run);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = data.join("trajectory.csv");
    let mut fit = vec!["fit", "drive-rolling-resistance", "--data", csv.to_str().unwrap(), "--columns", "x1,y1"];
    fit.extend(["--over", "rolling_A.damping=0:5", "--over", "motor.amplitude=1:3"]);
    fit.extend(tight);
    fit.extend(["--out", out.to_str().unwrap()]);
    let o = ezy(&fit);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = std::fs::read_to_string(out.join("fit.csv")).unwrap();
    let rows: Vec<Vec<&str>> = table.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows[0][0], "rolling_A.damping");
    let est: Vec<f64> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert!((est[0] - 1.3).abs() < 1e-8 && (est[1] - 2.4).abs() < 1e-8, "{est:?}");
    assert!(out.join("fit.png").exists());
    // a NaN in the data: refused before any run
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let cells: Vec<&str> = lines[3].split(',').collect();
    lines[3] = [cells[0], "nan"].into_iter().chain(cells[2..].iter().copied()).collect::<Vec<_>>().join(",");
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, lines.join("\n")).unwrap();
    fit[3] = bad.to_str().unwrap();
    let o = ezy(&fit);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("bad.csv") && err.contains("row 3, column `x1`"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// One data row of two columns for two parameters leaves no degree of
/// freedom: the standard errors are undetermined (NaN, `None`), never 0
/// (`f64::max` made the NaN 0).
#[test]
fn a_fit_without_a_degree_of_freedom_leaves_its_standard_errors_undetermined() {
    let (scene, over, truth) = setting();
    let design = scene.design(&EzyRoller::default(), &[], &over).unwrap();
    let all = data(&scene, truth, 0.0);
    let one = Data {
        t: vec![all.t[10]],
        columns: all.columns.clone(),
        values: vec![vec![all.values[0][10]], vec![all.values[1][10]]],
    };
    let f = fit(&design, &one, None).unwrap();
    assert!(f.std_error.iter().all(|e| e.is_nan()), "{:?}", f.std_error);
    assert!((0..2).all(|k| f.std_error_of(k).is_none()));
}

/// `ezy fit` on one data row (two columns) for two parameters prints the standard
/// errors as undetermined and leaves their cells of fit.csv empty, never
/// "+- 0".
#[test]
fn the_command_reports_undetermined_standard_errors() {
    let dir = std::env::temp_dir().join(format!("ezy-fit-undetermined-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (scene, _, truth) = setting();
    let all = data(&scene, truth, 0.0);
    let ezy = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().unwrap();
    let one = dir.join("one.csv");
    std::fs::write(&one, format!("t,x1,y1\n{},{},{}\n", all.t[10], all.values[0][10], all.values[1][10])).unwrap();
    let out = dir.join("fit");
    let mut fit = vec!["fit", "drive-rolling-resistance", "--data", one.to_str().unwrap(), "--columns", "x1,y1"];
    fit.extend(["--over", "rolling_A.damping=0:5", "--over", "motor.amplitude=1:3", "--no-figures"]);
    fit.extend(["--out", out.to_str().unwrap()]);
    let o = ezy(&fit);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!text.contains("+- 0") && text.matches("standard error undetermined").count() == 2, "{text}");
    let table = std::fs::read_to_string(out.join("fit.csv")).unwrap();
    for row in table.lines().skip(1) {
        assert!(row.ends_with(','), "an undetermined error is an empty cell: {table}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A data file naming a fitted column twice is refused naming the column
/// and the file (it silently took the first); nothing is written.
#[test]
fn a_column_named_twice_is_refused() {
    let dir = std::env::temp_dir().join(format!("ezy-fit-twice-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let ezy = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().unwrap();
    let twice = dir.join("twice.csv");
    std::fs::write(&twice, "t,x1,x1\n0.5,1,2\n1,1.5,2.5\n").unwrap();
    let out2 = dir.join("fit2");
    let mut bad = vec!["fit", "drive-rolling-resistance", "--data", twice.to_str().unwrap(), "--columns", "x1"];
    bad.extend(["--over", "rolling_A.damping=0:5", "--no-figures", "--out", out2.to_str().unwrap()]);
    let o = ezy(&bad);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("twice.csv") && err.contains("column `x1` twice"), "{err}");
    assert!(!out2.exists());
    // `t` twice too
    std::fs::write(&twice, "t,x1,t\n0.5,1,2\n1,1.5,2.5\n").unwrap();
    let o = ezy(&bad);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("twice.csv") && err.contains("column `t` twice"), "{err}");
    assert!(!out2.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
