//! `ezy fit [SCENE] --data FILE --columns C[,C..] --over NAME=LO:HI ..`:
//! a scene's parameters fitted to a measured run
//! ([`ezy_core::design::fit`]): `fit.csv` (`parameter, estimate,
//! std_error`) and a figure of the data against the fitted run.

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::design::fit::{Data, Fit, fit};
use ezy_core::{Model, Problem, fmt_value};
use ezy_scene::Scene;

use super::{committed, scene_and_options};
use crate::app::{App, AppError};
use crate::cli::Overrides;
use crate::output::csv::{number, record};
use crate::output::transaction::{OutLock, Transaction};
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::session::{Error, RunOptions, analysis_error, check_run, settings};

/// Fit a scene's parameters to a measured run by nonlinear least squares
/// (Levenberg-Marquardt on the run's sensitivities): fit.csv with the
/// estimates and their standard errors, and a figure of the data against
/// the fitted run.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct FitArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// The measurements: a CSV file with a header row, a column `t` [s]
    /// (sorted) and the columns named by --columns.
    #[arg(long, value_name = "FILE", required = true)]
    data: PathBuf,
    /// The data's columns fitted: coordinates or velocities of the model
    /// (x1, y1, phi1d), comma-separated.
    #[arg(long, value_name = "C[,C..]", value_delimiter = ',', required = true)]
    columns: Vec<String>,
    /// A parameter fitted and its bounds, NAME=LO:HI (names as for --set,
    /// or initial.q.NAME, initial.qd.NAME); repeatable. The fit starts
    /// from the scene's value.
    #[arg(long = "over", value_name = "NAME=LO:HI", value_parser = crate::cli::parse_over, required = true)]
    over: Vec<(String, f64, f64)>,
    /// Output directory [default: out/fit/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw the figure.
    #[arg(long)]
    no_figures: bool,
    #[command(flatten)]
    overrides: Overrides,
}

/// The arguments of `ezy fit`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    FitArgs::augment_args(cmd)
}

/// Fits the scene named (or the default scene) and prints the estimates.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = FitArgs::from_arg_matches(args)?;
    let (src, opts) =
        scene_and_options(app, args.scene.as_deref(), "fit", (args.out, args.no_figures), &args.overrides)?;
    let scene = &src.scene;
    let model = &app.model_or_error(&scene.model)?;
    let clock = Instant::now();
    let data = crate::cli::read_columns(&args.data, &args.columns, "the data file").map_err(AppError::Failed)?;
    let (f, files) = fit_model(model, scene, &opts, &data, &args.over).map_err(AppError::from_run)?;
    committed(out, &summary(&scene.name, &f, clock.elapsed().as_secs_f64(), &files), &opts.out)
}

/// The fit of `scene` on `proto` (a model at its defaults) to `data`,
/// written into `opts.out`.
///
/// # Errors
/// A bad name, bound or setting; the runs' and the output's errors.
fn fit_model<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    data: &Data,
    over: &[(String, f64, f64)],
) -> Result<(Fit, Vec<PathBuf>), Error> {
    let settings = settings(scene, opts)?;
    let design = scene.design(proto, &opts.sets, over).map_err(analysis_error(&opts.out))?;
    // the scene's settings with the command line's (t_end: the data's)
    let design = design.adjusted(move |p| Problem { settings, baumgarte: None, ..p });
    check_run(proto, scene, opts)?;
    // the directory is this command's from here to the commit
    // armed before the lock: a signal between the two would take the
    // default action and leave the directory with its lock file
    crate::output::transaction::arm_signals();
    let held = OutLock::take(&opts.out)?;
    // a signal stops the work (it polls the flag) and leaves the directory as it was
    let f = fit(&design, data, Some(|| crate::output::transaction::pending().is_some()))
        .map_err(analysis_error(&opts.out))?;
    let mut tx = Transaction::begin_locked(held)?;
    tx.retire(&["fit.csv".to_string()]);
    let mut text = record(vec!["parameter".into(), "estimate".into(), "std_error".into()]);
    for k in 0..f.names.len() {
        // an undetermined error (no degree of freedom, J^T J singular) is
        // an empty cell, never 0
        let se = if f.std_error[k].is_finite() { number(f.std_error[k]) } else { String::new() };
        text.push_str(&record(vec![f.names[k].clone(), number(f.estimate[k]), se]));
    }
    tx.write("fit.csv", text.as_bytes())?;
    if opts.figures {
        let (format, dpi) = opts.look(scene);
        tx.check(None, Some("drawing fit".into()))?;
        let bytes = crate::render::plot::figure(&chart(&f, data), format, dpi)
            .map_err(|e| Error::Input(format!("figure fit: {e}")))?;
        tx.write(&format.file_name("fit"), &bytes)?;
    }
    let files = tx.commit()?;
    Ok((f, files))
}

/// The data (points) against the fitted run (lines), column by column.
fn chart(f: &Fit, data: &Data) -> Chart {
    let mut chart = Chart::new("Data and the fitted run", "t [s]", "value [column's unit]");
    for (k, c) in data.columns.iter().enumerate() {
        let i = f.fitted.names.iter().position(|n| n == c).unwrap_or(0);
        let fitted = f.fitted.t.iter().zip(&f.fitted.x).map(|(t, x)| (*t, x[i])).collect();
        chart.series.push(Series {
            stroke: Stroke::Solid,
            color: Some(k),
            ..Series::new(format!("{c} fitted"), fitted)
        });
        let points = data.t.iter().zip(&data.values[k]).map(|(t, v)| (*t, *v)).collect();
        chart.series.push(Series {
            stroke: Stroke::Points,
            color: Some(k),
            ..Series::new(format!("{c} data"), points)
        });
    }
    chart.legend_outside = true;
    chart
}

/// The text `ezy fit` prints.
fn summary(scene: &str, f: &Fit, seconds: f64, files: &[PathBuf]) -> String {
    let mut s = format!(
        "scene {scene}: fitted in {} runs ({:.2} s, Levenberg-Marquardt: {})\n",
        f.runs, seconds, f.termination
    );
    for k in 0..f.names.len() {
        let _ = write!(s, "{} = {}", f.names[k], fmt_value(f.estimate[k]));
        if f.std_error[k].is_finite() {
            let _ = write!(s, " +- {}", fmt_value(f.std_error[k]));
        } else {
            s.push_str(" (standard error undetermined: no degree of freedom left, or J^T J singular)");
        }
        if f.at_bound[k] {
            s.push_str(" (at a bound: widen it)");
        }
        s.push('\n');
    }
    if f.names.len() > 1 {
        let _ = writeln!(s, "correlations:");
        for (k, row) in f.correlation.iter().enumerate() {
            let cells: Vec<String> = row.iter().map(|c| format!("{c:+.4}")).collect();
            let _ = writeln!(s, "  {}: {}", f.names[k], cells.join(" "));
        }
    }
    let cols: Vec<String> =
        f.residual_rms.iter().enumerate().map(|(k, r)| format!("{} {}", f.columns[k], fmt_value(*r))).collect();
    let _ = writeln!(s, "residual (rms) per column: {}", cols.join(", "));
    for file in files {
        let _ = writeln!(s, "wrote {}", file.display());
    }
    s
}
