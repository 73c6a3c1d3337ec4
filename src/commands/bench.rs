//! `ezy bench`: what an accurate trajectory costs, in one run.
//!
//! For a scene (the drive scene by default) it measures seven settings
//! in this process, against a reference computed by ezy itself (DOP853 at
//! rtol = atol = 1e-13, projected):
//!
//! 1. DOP853 at rtol = atol = 1e-11 as typed without a formulation (the
//!    default, `auto`: on the `drive` scene the minimal coordinates), one
//!    output at the end: the integration alone;
//! 2. the same with an output every 0.01 s (dense output at each sample);
//! 3. DOP853 at rtol = atol = 1e-11 in the DAE, projected, one output at
//!    the end;
//! 4. DOP853 at rtol = atol = 3e-11 in the reduced formulation (on the
//!    minimal coordinates `model!` derived where there are some, else a
//!    numeric partition; no projection), one output at the end: about
//!    the first's error at fewer steps;
//! 5. the same with an output every 0.01 s;
//! 6. the scene's own setting (for `drive`, the assignment's RK4 at
//!    h = 1e-4 s, in the default formulation);
//! 7. the same in the DAE with the scene's projection.
//!
//! Each integration time is the median of `repeat` runs. The whole
//! process of the matching `run` command (`--no-figures`, CSV written) is
//! timed by the command, which starts the program itself.

use std::io::Write;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::settings::Method;
use ezy_core::{Formulation, Model, ProjectionKind};
use ezy_scene::Scene;

use crate::app::{App, AppError};
use crate::cli::parse_capped;
use crate::output::progress::Heartbeat;
use crate::precision::{Setting, run_once_as, state_error};
use crate::session::Error;

/// Time an accurate trajectory: DOP853 at 1e-11 with and without
/// output, the scene's own setting, and each whole `run` process.
#[derive(Args, Debug, Default)]
struct BenchArgs {
    /// Scene: a known name (default: drive) or a path to a .toml scene file.
    scene: Option<String>,
    /// Runs per setting (the median is reported), at most 100.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = parse_repeat)]
    repeat: u64,
    /// Skip timing the whole `run` processes.
    #[arg(long)]
    no_process: bool,
}

/// `--repeat` of `ezy bench`: from 1 to [`MAX_REPEAT`].
///
/// # Errors
/// Not a whole number from 1 to the limit.
fn parse_repeat(s: &str) -> Result<u64, String> {
    parse_capped(
        s,
        MAX_REPEAT,
        "runs per setting (each repeat runs the seven settings again, and as many whole processes)",
    )
}

/// The arguments of `ezy bench`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    BenchArgs::augment_args(cmd)
}

/// Measures the settings in this process, then (unless `--no-process`)
/// each whole `run` process, and prints the table.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = BenchArgs::from_arg_matches(args)?;
    let (name, src) = app.named_scene(args.scene.as_deref())?;
    let scene = &src.scene;
    let model = &app.model_or_error(&scene.model)?;
    // `--repeat` is at most MAX_REPEAT (its parser), and bench_model
    // refuses more for callers that build the arguments
    let repeat = usize::try_from(args.repeat).unwrap_or(usize::MAX);
    let mut rows = bench_model(model, scene, repeat).map_err(AppError::from_run)?;
    if !args.no_process {
        time_processes(&name, &mut rows, repeat)?;
    }
    Ok(out.write_all(table(&scene.name, &rows).as_bytes())?)
}

/// Times this very program, started anew `repeat` times for each row's
/// setting on the scene `name`: parse, setup, integration and CSV, no
/// figures; the median into the row's `process_s`.
fn time_processes(name: &str, rows: &mut [BenchRow], repeat: usize) -> Result<(), AppError> {
    let exe = std::env::current_exe().map_err(|e| AppError::Failed(format!("finding this program: {e}")))?;
    let tmp = tempfile::tempdir().map_err(|e| AppError::Failed(format!("a scratch directory: {e}")))?;
    let beat = Heartbeat::start(format!("bench {name}: timing the run processes"));
    let n_rows = rows.len();
    for (k, row) in rows.iter_mut().enumerate() {
        let dir = tmp.path().join(k.to_string());
        let mut times = Vec::new();
        for r in 0..repeat {
            beat.set(format!("bench {name}: process of setting {} of {n_rows}, run {} of {repeat}", k + 1, r + 1));
            let start = std::time::Instant::now();
            let status = std::process::Command::new(&exe)
                .arg("run")
                .arg(name)
                .args(&row.args)
                .arg("--no-figures")
                .arg("--out")
                .arg(&dir)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()
                .map_err(|e| AppError::Failed(format!("starting {}: {e}", exe.display())))?;
            if !status.success() {
                return Err(AppError::Failed(format!("`run {name} {}` failed: {status}", row.args.join(" "))));
            }
            times.push(start.elapsed().as_secs_f64());
        }
        row.process_s = Some(median(&mut times));
    }
    Ok(())
}

/// Most runs per setting `ezy bench --repeat` takes: each repeat runs the
/// seven settings once more in this process and, unless `--no-process`,
/// starts the program seven more times (the median of a few is already
/// stable).
const MAX_REPEAT: u64 = 100;

/// One measured setting.
#[derive(Debug, Clone, PartialEq)]
struct BenchRow {
    /// What was run.
    what: String,
    /// Median integration time \[s\].
    integration_s: f64,
    /// Median time of the output work in the same runs \[s\]: projecting
    /// the dense-output samples (the DAE) or expanding them to the full
    /// state (the minimal coordinates), their energies and residuals
    /// ([`ezy_core::Summary::output_time`]; no file is written here).
    output_s: f64,
    /// Right-hand-side evaluations of one run.
    rhs_evals: u64,
    /// Max over `q` and `qd` of the difference from the reference at the
    /// final time.
    error: f64,
    /// The `run` arguments (after the scene) that reproduce the setting.
    args: Vec<String>,
    /// Median wall time of the whole `run` process \[s\] (`None`: not
    /// measured).
    process_s: Option<f64>,
}

/// Measures the seven settings of the module documentation on `scene`,
/// each integration `repeat` times (at least 1, at most [`MAX_REPEAT`]);
/// a line on stderr every few seconds says which run is going.
///
/// # Errors
/// [`Error`] if a run fails, [`Error::Input`] for `repeat` above
/// [`MAX_REPEAT`] (before any run).
fn bench_model<M: Model>(proto: &M, scene: &Scene, repeat: usize) -> Result<Vec<BenchRow>, Error> {
    if repeat as u64 > MAX_REPEAT {
        return Err(Error::Input(format!("--repeat {repeat} is more than {MAX_REPEAT}, the most runs per setting")));
    }
    let beat = Heartbeat::start(format!("bench {}: the reference run", scene.name));
    let t_end = scene.t_end;
    let reference =
        Setting { method: Method::Dop853, dt: None, tol: Some(1e-13), projection: ProjectionKind::MassWeighted };
    let (ref_run, _) = run_once_as(proto, scene, &reference, t_end, false, Formulation::Dae)?;
    let tight = Setting { tol: Some(1e-11), ..reference };
    let own = scene.run_settings();
    let own_setting = Setting {
        method: own.method,
        dt: (!own.method.is_adaptive()).then_some(own.dt),
        tol: own.method.is_adaptive().then_some(own.rtol),
        projection: own.projection,
    };
    let own_what = match own_setting.dt {
        Some(h) => format!("{} h = {} s (the scene's)", own.method.name(), ezy_core::fmt_value(h)),
        None => format!("{} rtol = {:e} (the scene's)", own.method.name(), own.rtol),
    };
    let own_dae = match own_setting.dt {
        Some(h) => {
            format!("{} h = {} s, dae, projection {}", own.method.name(), ezy_core::fmt_value(h), own.projection.name())
        }
        None => format!("{} rtol = {:e}, dae, projection {}", own.method.name(), own.rtol, own.projection.name()),
    };
    let dop = ["--integrator", "dop853", "--rtol", "1e-11", "--atol", "1e-11"].map(String::from).to_vec();
    let dop_reduced = ["--integrator", "dop853", "--rtol", "3e-11", "--atol", "3e-11", "--formulation", "reduced"]
        .map(String::from)
        .to_vec();
    let args = |base: &[String], extra: &[&str]| -> Vec<String> {
        base.iter().cloned().chain(extra.iter().map(|s| s.to_string())).collect()
    };
    let reduced = Setting { tol: Some(3e-11), projection: ProjectionKind::None, ..reference };
    let cases = [
        (
            format!("dop853 rtol = atol = 1e-11, output at {t_end} s only"),
            tight,
            Formulation::Auto,
            t_end,
            args(&dop, &["--every", &format!("{t_end}")]),
        ),
        (
            "dop853 rtol = atol = 1e-11, output every 0.01 s".to_string(),
            tight,
            Formulation::Auto,
            0.01,
            args(&dop, &["--every", "0.01"]),
        ),
        (
            format!("dop853 rtol = atol = 1e-11, dae, output at {t_end} s only"),
            tight,
            Formulation::Dae,
            t_end,
            args(&dop, &["--formulation", "dae", "--every", &format!("{t_end}")]),
        ),
        (
            format!("dop853 rtol = atol = 3e-11, reduced, output at {t_end} s only"),
            reduced,
            Formulation::Reduced,
            t_end,
            args(&dop_reduced, &["--every", &format!("{t_end}")]),
        ),
        (
            "dop853 rtol = atol = 3e-11, reduced, output every 0.01 s".to_string(),
            reduced,
            Formulation::Reduced,
            0.01,
            args(&dop_reduced, &["--every", "0.01"]),
        ),
        (own_what, own_setting, own.formulation, own.every, Vec::new()),
        (own_dae, own_setting, Formulation::Dae, own.every, args(&[], &["--formulation", "dae"])),
    ];
    let mut rows = Vec::new();
    let n_cases = cases.len();
    for (k, (what, setting, formulation, every, args)) in cases.into_iter().enumerate() {
        let (mut times, mut outputs) = (Vec::new(), Vec::new());
        let (mut error, mut rhs_evals, mut minimal) = (f64::NAN, 0, None);
        for r in 0..repeat.max(1) {
            beat.set(format!(
                "bench {}: setting {} of {n_cases}, run {} of {}",
                scene.name,
                k + 1,
                r + 1,
                repeat.max(1)
            ));
            let (last, summary) = run_once_as(proto, scene, &setting, every, false, formulation)?;
            if summary.formulation == Formulation::Reduced {
                minimal = Some(summary.minimal_coordinates);
            }
            times.push(summary.integration_time.as_secs_f64());
            outputs.push(summary.output_time.as_secs_f64());
            error = state_error(&last.y, &ref_run.y);
            rhs_evals = summary.counters.rhs_evals;
        }
        let (integration_s, output_s) = (median(&mut times), median(&mut outputs));
        // the reduced formulation says which partition it ran on, auto
        // which formulation it took
        let partition = match minimal {
            Some(true) => "reduced (minimal coordinates)",
            Some(false) => "reduced (numeric partition)",
            None => "dae",
        };
        let what = if formulation == Formulation::Auto {
            format!("{what}: {partition}")
        } else {
            what.replace(", reduced,", &format!(", {partition},"))
        };
        rows.push(BenchRow { what, integration_s, output_s, rhs_evals, error, args, process_s: None });
    }
    Ok(rows)
}

/// The median of `v` (sorted in place); NaN for none.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A time in the unit that reads best: `1.58 ms`, `0.40 s`.
fn time(s: f64) -> String {
    if s < 1e-3 {
        format!("{:.1} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.2} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

/// The table for people.
fn table(scene: &str, rows: &[BenchRow]) -> String {
    let mut s = format!(
        "ezy bench {scene}: error = max |y(t_end) - y_ref(t_end)| over q and qd against DOP853 at 1e-13; times are medians\n"
    );
    s.push_str(&format!(
        "{:<80} {:>12} {:>10} {:>10} {:>10} {:>14}\n",
        "setting", "integration", "output", "RHS evals", "error", "whole process"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<80} {:>12} {:>10} {:>10} {:>10.1e} {:>14}\n",
            r.what,
            time(r.integration_s),
            time(r.output_s),
            r.rhs_evals,
            r.error,
            r.process_s.map_or("-".into(), time)
        ));
    }
    s.push_str(
        "output: the dense-output samples projected (DAE) or expanded to q, qd (minimal coordinates), \
         their energies and residuals (no file)\n",
    );
    s.push_str("whole process: `ezy run SCENE ARGS --no-figures` started anew (parse, setup, integration, CSV)\n");
    s
}
