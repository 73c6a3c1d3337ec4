//! `ezy optimize [SCENE] (--maximize Q | --minimize Q) --over NAME=LO:HI ..
//! [--subject-to 'Q <= V' ..]`: the parameters of a scene that make a
//! gait's quantity or a run's metric largest or smallest within bounds
//! and constraints ([`ezy_core::design::optimize`]): `optimum.csv`,
//! `history.csv`, `grid.csv` and figures of the objective along the path
//! and around the optimum. With `--gait`, the numbers are the Fourier
//! coefficients of the scene's drives: a mixed system's gait
//! ([`ezy_core::design::gait::DriveGait`]).

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::design::Design;
use ezy_core::design::gait::DriveGait;
use ezy_core::design::optimize::{Constraint, Evaluation, Goal, OptimizeSettings, Optimum, Quantity, Sense, optimize};
use ezy_core::effects::Periodicity;
use ezy_core::{Model, Problem, fmt_value};
use ezy_scene::Scene;

use super::{committed, scene_and_options};
use crate::app::{App, AppError};
use crate::cli::Overrides;
use crate::output::csv::{number, record};
use crate::output::progress::Heartbeat;
use crate::output::transaction::{Interrupted, OutLock, Transaction, TransactionError};
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::session::{Error, RunOptions, analysis_error, periodic_settings, settings};
use crate::sweep::metric::Metric;

/// Find the parameters that maximize or minimize a gait's quantity or a
/// run's metric within bounds and constraints (SLSQP on exact
/// derivatives), or with --gait a mixed system's gait over its drives'
/// Fourier coefficients: optimum.csv, history.csv and figures of the
/// objective along the path and around the optimum.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct OptimizeArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// The quantity made largest: a gait's, gait.NAME (mean_speed,
    /// mean_forward_speed, displacement, dx, dy, dheading, mean_power,
    /// efficiency, period), or a run's metric over the state's columns
    /// (final(x1), mean(x1d, 50, 60), max(norm(x1d, y1d)), min(..)).
    #[arg(long, value_name = "QUANTITY", required_unless_present = "minimize", conflicts_with = "minimize")]
    maximize: Option<String>,
    /// The quantity made smallest (as --maximize).
    #[arg(long, value_name = "QUANTITY")]
    minimize: Option<String>,
    /// A parameter optimized and its bounds, NAME=LO:HI (names as for
    /// --set, or initial.q.NAME, initial.qd.NAME); repeatable. The search
    /// starts from the scene's value.
    #[arg(long = "over", value_name = "NAME=LO:HI", value_parser = crate::cli::parse_over, required = true)]
    over: Vec<(String, f64, f64)>,
    /// Optimize the gait of the scene's drives (a mixed system's shape
    /// prescribed through its drives) instead of its parameters: the
    /// start, NAME=EXPR per drive over one period, t in [0, 2 pi], each a
    /// sum of constants and cos/sin(k*t + c) with whole k (as
    /// `gait-optimize --gait`). --over then names the gait's Fourier
    /// coefficients, DRIVE.a0, DRIVE.a1, DRIVE.b1, ... [rad]; the gait is
    /// found to 1e-12 and the optimum polished by Newton's method.
    #[arg(long, value_name = "NAME=EXPR[,..]")]
    gait: Option<String>,
    /// The gait's period with --gait [s] [default: the period of the
    /// scene's drives].
    #[arg(long, value_name = "T", requires = "gait")]
    period: Option<f64>,
    /// The Fourier series' order with --gait [default: the start's highest
    /// harmonic, at least 1].
    #[arg(long, value_name = "N", requires = "gait")]
    harmonics: Option<usize>,
    /// A drive's angle range over the cycle with --gait, NAME=LO:HI [rad],
    /// held at 64 times per cycle; repeatable.
    #[arg(long = "range", value_name = "NAME=LO:HI", value_parser = crate::cli::parse_over, requires = "gait")]
    ranges: Vec<(String, f64, f64)>,
    /// A constraint, 'QUANTITY <= VALUE' or 'QUANTITY >= VALUE' (quantities
    /// as for --maximize); repeatable.
    #[arg(long = "subject-to", value_name = "'Q <= V'")]
    subject_to: Vec<String>,
    /// Most evaluations (a gait found, or a run with its sensitivities).
    #[arg(long, value_name = "N", default_value_t = 100)]
    max_evaluations: usize,
    /// Points per axis of the grid of the objective around the optimum
    /// (one or two parameters; 0: none) [default: 15 for one parameter,
    /// 7 for two].
    #[arg(long, value_name = "N")]
    grid: Option<usize>,
    /// Output directory [default: out/optimize/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw the figures.
    #[arg(long)]
    no_figures: bool,
    #[command(flatten)]
    overrides: Overrides,
}

/// The arguments of `ezy optimize`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    OptimizeArgs::augment_args(cmd)
}

/// Optimizes the scene named (or the default scene) and prints the optimum.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = OptimizeArgs::from_arg_matches(args)?;
    let (src, opts) = scene_and_options(
        app,
        args.scene.as_deref(),
        "optimize",
        (args.out.clone(), args.no_figures),
        &args.overrides,
    )?;
    let scene = &src.scene;
    let model = &app.model_or_error(&scene.model)?;
    let clock = Instant::now();
    let (o, files) = optimize_model(app, model, scene, &opts, &args).map_err(AppError::from_run)?;
    let text = summary(&scene.name, &o, clock.elapsed().as_secs_f64(), &files);
    committed(out, &text, &opts.out)?;
    if o.converged {
        Ok(())
    } else {
        Err(AppError::Failed(format!(
            "{}; the best point so far is in {}",
            o.termination,
            opts.out.join("optimum.csv").display()
        )))
    }
}

/// What names a quantity: the caller's own ([`App::quantity`]), the
/// state's columns, the run's end and output interval \[s\] a metric's
/// window is checked against.
struct Lookup<'a> {
    app: &'a App,
    state: &'a [String],
    t_end: f64,
    every: f64,
}

/// A quantity named on the command line: one of the caller's own,
/// `gait.NAME` or a metric of the state's columns (checked against the
/// run's end and output interval).
///
/// # Errors
/// The text and what is wrong with it.
fn quantity(text: &str, at: &Lookup<'_>) -> Result<Quantity, String> {
    let text = text.trim();
    if let Some(function) = at.app.own_quantity(text) {
        return Ok(Quantity::Run { name: text.to_string(), function });
    }
    let (state, t_end, every) = (at.state, at.t_end, at.every);
    if text.starts_with("gait.") {
        return Quantity::gait(text).map_err(|e| e.to_string());
    }
    let m: Metric = text.parse().map_err(|e: String| {
        format!("{e}; or a gait's quantity, gait.{{{}}}", ezy_core::design::optimize::GaitQuantity::names())
    })?;
    if m.event.is_some() {
        return Err(format!(
            "metric `{text}`: an event's time or count has no derivative here (a run with sensitivities has no events)"
        ));
    }
    m.check_columns(state)
        .map_err(|e| format!("{e} (a run's derivatives are those of its coordinates and velocities)"))?;
    m.check_window(t_end, every)?;
    Ok(Quantity::Run { name: m.text.clone(), function: std::sync::Arc::new(move |s| m.with_gradient(s)) })
}

/// `QUANTITY <= VALUE` or `QUANTITY >= VALUE`.
///
/// # Errors
/// Another form; the quantity's error; a bound that is not a finite number.
fn constraint(text: &str, at: &Lookup<'_>) -> Result<Constraint, String> {
    let (q, bound, upper) = match (text.split_once("<="), text.split_once(">=")) {
        (Some((q, b)), None) => (q, b, true),
        (None, Some((q, b))) => (q, b, false),
        _ => return Err(format!("--subject-to `{text}`: expected 'QUANTITY <= VALUE' or 'QUANTITY >= VALUE'")),
    };
    let bound = match bound.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => v,
        _ => return Err(format!("--subject-to `{text}`: the bound `{}` is not a finite number", bound.trim())),
    };
    let quantity = quantity(q, at).map_err(|e| format!("--subject-to `{text}`: {e}"))?;
    Ok(Constraint { quantity, upper, bound })
}

/// The optimization of `scene` on `proto` (a model at its defaults),
/// written into `opts.out`.
///
/// # Errors
/// A bad name, bound, quantity or setting; the evaluations' and the
/// output's errors; an interruption, after the best point so far is written.
fn optimize_model<M: Model>(
    app: &App,
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    args: &OptimizeArgs,
) -> Result<(Optimum, Vec<PathBuf>), Error> {
    let settings = settings(scene, opts)?;
    let state: Vec<String> = {
        let info = proto.clone().info();
        info.coords.iter().map(|c| c.to_string()).chain(info.coords.iter().map(|c| format!("{c}d"))).collect()
    };
    let (t_end, every) = (settings.t_end, settings.every);
    let (sense, text) = match (&args.maximize, &args.minimize) {
        (Some(q), _) => (Sense::Maximize, q),
        (None, Some(q)) => (Sense::Minimize, q),
        (None, None) => return Err(Error::Input("give --maximize QUANTITY or --minimize QUANTITY".into())),
    };
    let flag = if sense == Sense::Maximize { "--maximize" } else { "--minimize" };
    let at = Lookup { app, state: &state, t_end, every };
    let objective = quantity(text, &at).map_err(|e| Error::Input(format!("{flag}: {e}")))?;
    let mut constraints =
        args.subject_to.iter().map(|c| constraint(c, &at)).collect::<Result<Vec<_>, _>>().map_err(Error::Input)?;
    let n = args.over.len();
    let mut os = OptimizeSettings {
        max_evaluations: args.max_evaluations,
        periodic: periodic_settings(opts),
        grid: args.grid.unwrap_or(match n {
            1 => 15,
            2 => 7,
            _ => 0,
        }),
        ..OptimizeSettings::default()
    };
    let design = match &args.gait {
        None => scene.design(proto, &opts.sets, &args.over).map_err(analysis_error(&opts.out))?,
        Some(text) => {
            let (design, ranges) = drive_gait(proto, scene, opts, args, text)?;
            constraints.extend(ranges);
            os = OptimizeSettings {
                max_evaluations: os.max_evaluations,
                grid: os.grid,
                ..DriveGait::optimize_settings()
            };
            design
        }
    };
    let goal = Goal { objective, sense, constraints };
    let design = design.adjusted(move |p| Problem { settings, baumgarte: None, ..p });
    crate::session::check_run(proto, scene, opts)?;
    // the directory is this command's from here to the commit
    // armed before the lock: a signal between the two would take the
    // default action and leave the directory with its lock file
    crate::output::transaction::arm_signals();
    let held = OutLock::take(&opts.out)?;
    // Ctrl-C ends the search with the best point so far written
    let beat = opts.progress.then(|| Heartbeat::start(format!("optimize {}: the start", scene.name)));
    let mut count = 0;
    let o = optimize(&design, &goal, &os, Some(|| crate::output::transaction::pending().is_some()), &mut |e| {
        count += 1;
        if let Some(b) = &beat {
            b.set(format!("optimize {}: evaluation {count}: {}", scene.name, point_text(&design.names, e)));
        }
    })
    .map_err(analysis_error(&opts.out))?;
    drop(beat);
    let tables = tables(&o, &goal);
    if o.stopped {
        return Err(interrupted(&opts.out, &tables));
    }
    let mut tx = Transaction::begin_locked(held)?;
    tx.retire(&["optimum.csv".into(), "history.csv".into(), "grid.csv".into()]);
    for (name, text) in &tables {
        tx.write(name, text.as_bytes())?;
    }
    if opts.figures {
        let (format, dpi) = opts.look(scene);
        let mut charts = vec![("optimize", history_chart(&o, sense))];
        charts.extend(grid_chart(&o).map(|c| ("optimize_grid", c)));
        for (name, chart) in charts {
            tx.check(None, Some(format!("drawing {name}")))?;
            let bytes = crate::render::plot::figure(&chart, format, dpi)
                .map_err(|e| Error::Input(format!("figure {name}: {e}")))?;
            tx.write(&format.file_name(name), &bytes)?;
        }
    }
    let files = tx.commit()?;
    Ok((o, files))
}

/// Samples per cycle at which `--range` holds a drive's angle.
const RANGE_SAMPLES: usize = 64;

/// `--gait`: the design over the free Fourier coefficients of the
/// scene's drives ([`DriveGait`]), each problem the scene's with the
/// drives' angles the gait's, and the constraints of `--range`.
///
/// # Errors
/// A model without drives, a gait text that does not parse or is not a
/// Fourier series, no period (given or the drives'), a coefficient or a
/// drive that does not exist, and what [`DriveGait::design`] refuses.
fn drive_gait<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    args: &OptimizeArgs,
    text: &str,
) -> Result<(Design<M>, Vec<Constraint>), Error> {
    let info = proto.clone().info();
    let drives: Vec<String> = info.drives.iter().map(|d| d.name.to_string()).collect();
    if drives.is_empty() {
        return Err(Error::Input(format!(
            "--gait: model {} has no drives: a mixed system's gait is prescribed through its drives (`drive D: hinge B;` in the model); without --gait, --over names parameters",
            info.name
        )));
    }
    let period = match args.period {
        Some(p) if !(p.is_finite() && p > 0.0 && p < 1e9) => {
            return Err(Error::Input(format!(
                "--period {}: give a positive number of seconds below 1e9",
                fmt_value(p)
            )));
        }
        Some(p) => p,
        None => match Periodicity::combine(scene.drives.iter().map(|(_, d)| d.angle.periodicity())) {
            Periodicity::Period(p) => p,
            _ => {
                return Err(Error::Input(
                    "--gait: the scene's drives do not repeat, so the gait has no period: give --period T [s]".into(),
                ));
            }
        },
    };
    let start = crate::cli::fourier_start(text, args.harmonics, Some(period), &drives).map_err(Error::Input)?;
    let names: Vec<&str> = drives.iter().map(String::as_str).collect();
    let mut dg = DriveGait::new(&names, start);
    for (name, lo, hi) in &args.over {
        dg = dg.free(name, *lo, *hi).map_err(|e| Error::Input(format!("--over {name}: {e}")))?;
    }
    let mut ranges = Vec::new();
    for (d, lo, hi) in &args.ranges {
        ranges.extend(dg.range(d, *lo, *hi, RANGE_SAMPLES).map_err(|e| Error::Input(format!("--range {d}: {e}")))?);
    }
    let (scene, proto, sets) = (scene.clone(), proto.clone(), opts.sets.clone());
    let design = dg
        .design(move || scene.problem_with(proto.clone(), &sets).map(|(p, _)| p))
        .map_err(analysis_error(&opts.out))?;
    Ok((design, ranges))
}

/// A signal stopped the optimization: its best point so far and the
/// evaluations are written (whole files, each renamed into place) and the
/// interruption says where.
fn interrupted(dir: &Path, tables: &[(&'static str, String)]) -> Error {
    let signal = crate::output::transaction::pending().unwrap_or(crate::output::transaction::Signal::Int);
    let written = crate::output::transaction::lock(dir).and_then(|_lock| {
        for (name, text) in tables.iter().filter(|(n, _)| *n != "grid.csv") {
            crate::output::transaction::write_atomically(&dir.join(name), text.as_bytes())?;
        }
        Ok(())
    });
    let kept = match written {
        Ok(()) => format!(
            "the best point so far is in {}, every evaluation in {}",
            dir.join("optimum.csv").display(),
            dir.join("history.csv").display()
        ),
        Err(e) => format!("the best point so far could not be written: {e}"),
    };
    Error::Transaction(TransactionError::Interrupted(Interrupted {
        signal,
        dir: dir.into(),
        t: None,
        doing: Some("optimizing".into()),
        kept: Some(kept),
    }))
}

/// `optimum.csv` (the parameters, the objective and the constraints'
/// quantities at the optimum), `history.csv` (every evaluation) and
/// `grid.csv` (the objective around the optimum, where drawn).
fn tables(o: &Optimum, goal: &Goal) -> Vec<(&'static str, String)> {
    let quantities: Vec<String> =
        std::iter::once(o.objective_name.clone()).chain(goal.constraints.iter().map(|c| c.quantity.name())).collect();
    let mut head: Vec<String> = o.names.clone();
    head.extend(quantities.iter().cloned());
    let mut optimum = record(head.clone());
    let mut row: Vec<String> = o.values.iter().map(|v| number(*v)).collect();
    row.push(number(o.objective));
    row.extend(o.constraints.iter().map(|v| number(*v)));
    optimum.push_str(&record(row));
    let cell = |v: f64| if v.is_finite() { number(v) } else { String::new() };
    let rows = |list: &[Evaluation], gradient: bool| -> String {
        let mut h = vec!["evaluation".to_string()];
        h.extend(head.iter().cloned());
        if gradient {
            h.extend(o.names.iter().map(|p| format!("d{}/d{p}", o.objective_name)));
        }
        h.push("failure".into());
        let mut text = record(h);
        for (k, e) in list.iter().enumerate() {
            let mut r = vec![(k + 1).to_string()];
            r.extend(e.values.iter().map(|v| number(*v)));
            r.push(cell(e.objective));
            r.extend((0..quantities.len() - 1).map(|i| cell(e.constraints.get(i).copied().unwrap_or(f64::NAN))));
            if gradient {
                r.extend((0..o.names.len()).map(|i| cell(e.gradient.get(i).copied().unwrap_or(f64::NAN))));
            }
            r.push(e.failure.as_deref().map(|f| f.replace(['\n', '\r'], " ")).unwrap_or_default());
            text.push_str(&record(r));
        }
        text
    };
    let mut out = vec![("optimum.csv", optimum), ("history.csv", rows(&o.history, true))];
    if !o.grid.is_empty() {
        out.push(("grid.csv", rows(&o.grid, false)));
    }
    out
}

/// `motor.omega = 1.5: gait.mean_speed 0.46` (or the failure).
fn point_text(names: &[String], e: &Evaluation) -> String {
    let at: Vec<String> = names.iter().zip(&e.values).map(|(n, v)| format!("{n} = {}", fmt_value(*v))).collect();
    match &e.failure {
        Some(f) => format!("{}: failed ({f})", at.join(", ")),
        None => format!("{}: {}", at.join(", "), fmt_value(e.objective)),
    }
}

/// The objective at each evaluation and the best so far.
fn history_chart(o: &Optimum, sense: Sense) -> Chart {
    let mut chart = Chart::new("The objective along the optimization", "evaluation", o.objective_name.clone());
    let points: Vec<(f64, f64)> = o.history.iter().enumerate().map(|(k, e)| ((k + 1) as f64, e.objective)).collect();
    let mut best = f64::NAN;
    let running = points
        .iter()
        .map(|&(k, v)| {
            let better = match sense {
                Sense::Maximize => v > best,
                Sense::Minimize => v < best,
            };
            if best.is_nan() || better {
                best = v;
            }
            (k, best)
        })
        .collect();
    chart.series.push(Series { stroke: Stroke::Points, ..Series::new("evaluated", points) });
    chart.series.push(Series { stroke: Stroke::Solid, ..Series::new("best so far", running) });
    chart
}

/// The objective over the grid around the optimum: against the first
/// parameter, one line per value of the second; the optimum marked.
fn grid_chart(o: &Optimum) -> Option<Chart> {
    if o.grid.is_empty() {
        return None;
    }
    let mut chart =
        Chart::new(format!("{} around the optimum", o.objective_name), o.names[0].clone(), o.objective_name.clone());
    let mut lines: Vec<(f64, Vec<(f64, f64)>)> = Vec::new();
    for e in &o.grid {
        let key = e.values.get(1).copied().unwrap_or(f64::NAN);
        match lines.iter_mut().find(|(k, _)| k.to_bits() == key.to_bits()) {
            Some((_, l)) => l.push((e.values[0], e.objective)),
            None => lines.push((key, vec![(e.values[0], e.objective)])),
        }
    }
    for (key, mut line) in lines {
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        let label = if key.is_nan() { String::new() } else { format!("{} = {}", o.names[1], fmt_value(key)) };
        chart.series.push(Series { stroke: Stroke::Solid, ..Series::new(label, line) });
    }
    chart.series.push(Series { stroke: Stroke::Points, ..Series::new("optimum", vec![(o.values[0], o.objective)]) });
    chart.legend_outside = o.names.len() > 1;
    Some(chart)
}

/// The text `ezy optimize` prints.
fn summary(scene: &str, o: &Optimum, seconds: f64, files: &[PathBuf]) -> String {
    let mut s = format!(
        "scene {scene}: {} = {} at {}\n",
        o.objective_name,
        fmt_value(o.objective),
        o.names.iter().zip(&o.values).map(|(n, v)| format!("{n} = {}", fmt_value(*v))).collect::<Vec<_>>().join(", ")
    );
    let _ = writeln!(s, "{}", o.termination);
    let grad: Vec<String> = o.names.iter().zip(&o.gradient).map(|(n, g)| format!("d/d{n} {}", fmt_value(*g))).collect();
    let _ = writeln!(
        s,
        "gradient: {} (norm within the bounds, per unit span: {:.1e})",
        grad.join(", "),
        o.projected_gradient_norm
    );
    for (k, at) in o.at_bound.iter().enumerate() {
        if *at {
            let _ = writeln!(s, "{} is at a bound: widen it to look further", o.names[k]);
        }
    }
    for (text, v) in o.constraint_texts.iter().zip(&o.constraints) {
        let _ = writeln!(s, "constraint {text}: {}", fmt_value(*v));
    }
    if !o.stopped {
        let _ = writeln!(s, "{}", o.kkt.describe());
    }
    if let Some(orbit) = &o.orbit {
        let _ = writeln!(
            s,
            "gait at the optimum: period {} s, {}, largest multiplier modulus {}",
            fmt_value(orbit.period),
            orbit.stability.name(),
            orbit.multipliers.first().map_or("-".into(), |m| format!("{:.6}", m.norm()))
        );
    }
    let grid = if o.grid.is_empty() { String::new() } else { format!(" and {} grid points", o.grid.len()) };
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let _ = writeln!(
        s,
        "{}{grid}: {} found and {} in {seconds:.2} s (SLSQP)",
        plural(o.history.len(), "evaluation"),
        plural(o.orbits, "gait"),
        plural(o.runs, "run")
    );
    for file in files {
        let _ = writeln!(s, "wrote {}", file.display());
    }
    s
}
