//! `ezy gait-optimize [SCENE | MODEL] --gait NAME=EXPR,.. (--maximize W |
//! --minimize W)`: the closed gait of a kinematic system, a Fourier
//! series per shape coordinate started from `--gait`, that makes a
//! cycle's net motion (or its net motion per path length) largest or
//! smallest within shape ranges, a margin from the singular set and a
//! path-length budget ([`ezy_core::design::gait`]: SLSQP on exact
//! gradients from the connection and curvature). `gait_optimum.csv`,
//! `gait_history.csv` and a figure of the gait in shape space.

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::design::gait::{
    FourierGait, GaitObjective, GaitOptimization, GaitOptimum, MAX_ORDER, Measure, Order, optimize_gait,
};
use ezy_core::design::optimize::Sense;
use ezy_core::effects::Waveform;
use ezy_core::geometry::{Gait, Geometry, GeometryError};
use ezy_core::{AnyModel, fmt_value};

use super::committed;
use crate::app::scenes::is_scene_path;
use crate::app::{App, AppError, is_model_path};
use crate::cli::{parse_over, parse_set};
use crate::output::csv::{number, record};
use crate::output::transaction::{OutLock, Transaction, check_interrupt, pending};
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::session::{Error, with_sets};

/// Optimize a kinematic system's gait: the Fourier series per shape
/// coordinate, started from --gait, that makes a cycle's net motion (or
/// its net motion per path length) largest or smallest within shape
/// ranges, a margin from the singular set and a path-length budget (SLSQP
/// on exact gradients of the connection and curvature): gait_optimum.csv,
/// gait_history.csv and a figure of the gait in shape space.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct GaitOptimizeArgs {
    /// A scene (a known name, see `list`, or a .toml file: its model at
    /// its parameters) or a model (a known key or a .ezy file) [default:
    /// kinematic-snake].
    target: Option<String>,
    /// The start: a gait of one period, t in [0, 2 pi], NAME=EXPRESSION per
    /// shape coordinate, each a sum of constants and cos/sin(k*t + c) with
    /// whole k (as `ezy geometry --gait`).
    #[arg(long, value_name = "NAME=EXPR[,..]", required = true)]
    gait: String,
    /// The net motion per cycle made largest, in the reference body's
    /// initial frame: dx, dy [m], dtheta [rad], or along(UX,UY) (the
    /// displacement along that direction).
    #[arg(long, value_name = "MOTION", required_unless_present = "minimize", conflicts_with = "minimize")]
    maximize: Option<String>,
    /// The net motion made smallest (as --maximize).
    #[arg(long, value_name = "MOTION")]
    minimize: Option<String>,
    /// Divide the net motion by the gait's path length in shape space
    /// (the identity metric): the motion per radian of shape change.
    #[arg(long)]
    per_length: bool,
    /// The order of the net motion: first (-oint A dr), second (with the
    /// Lie bracket's area integral; two shape coordinates) or
    /// reconstructed (g' = g xi integrated).
    #[arg(long, value_name = "ORDER", default_value = "reconstructed", value_parser = ["first", "second", "reconstructed"])]
    order: String,
    /// The Fourier series' order per shape coordinate [default: the
    /// start's highest harmonic, at least 1].
    #[arg(long, value_name = "N")]
    harmonics: Option<usize>,
    /// Hold every coefficient but the constant terms (a gait of fixed
    /// shape moved about shape space).
    #[arg(long)]
    centre_only: bool,
    /// A shape coordinate's range over the cycle, NAME=LO:HI [rad];
    /// repeatable.
    #[arg(long = "range", value_name = "NAME=LO:HI", value_parser = parse_over)]
    ranges: Vec<(String, f64, f64)>,
    /// The least rank margin allowed along the gait, in (0, 1): a
    /// distance from the singular set.
    #[arg(long, value_name = "M")]
    margin: Option<f64>,
    /// The most path length allowed [rad].
    #[arg(long, value_name = "L")]
    budget: Option<f64>,
    /// Most evaluations (each with its gradient).
    #[arg(long, value_name = "N", default_value_t = 200)]
    max_evaluations: usize,
    /// The reference body [default: the body at the middle of the hinge tree].
    #[arg(long, value_name = "BODY")]
    body: Option<String>,
    /// Override a model parameter (--set l=0.5).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Output directory [default: out/gait-optimize/NAME].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw the figure.
    #[arg(long)]
    no_figures: bool,
}

/// The arguments of `ezy gait-optimize`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    GaitOptimizeArgs::augment_args(cmd)
}

/// Optimizes the gait and prints the optimum.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = GaitOptimizeArgs::from_arg_matches(args)?;
    let target = args.target.clone().unwrap_or_else(|| "kinematic-snake".into());
    let model_only = is_model_path(&target)
        || (!is_scene_path(&target) && app.named_scene(Some(&target)).is_err() && app.model_for(&target).is_some());
    let (name, model) = if model_only {
        let stem =
            std::path::Path::new(&target).file_stem().map_or_else(|| target.clone(), |s| s.to_string_lossy().into());
        let proto = app.model_or_error(&target)?;
        (stem, with_sets(&proto, &args.sets).map_err(AppError::Failed)?)
    } else {
        let (_, src) = app.named_scene(Some(&target))?;
        let proto = app.model_or_error(&src.scene.model)?;
        let (problem, _) = src.scene.problem_with(proto, &args.sets).map_err(AppError::failed)?;
        (src.scene.name.clone(), problem.model)
    };
    let dir = args.out.clone().unwrap_or_else(|| PathBuf::from("out").join("gait-optimize").join(&name));
    let clock = Instant::now();
    let (o, files) = run(model, &args, &dir).map_err(AppError::from_run)?;
    let text = summary(&name, &o, clock.elapsed().as_secs_f64(), &files);
    committed(out, &text, &dir)?;
    if o.converged {
        Ok(())
    } else {
        Err(AppError::Failed(format!(
            "{}; the best gait so far is in {}",
            o.termination,
            dir.join("gait_optimum.csv").display()
        )))
    }
}

/// A geometry error as the command's error, `dir` the output directory.
fn input(dir: &std::path::Path) -> impl Fn(GeometryError) -> Error + '_ {
    move |e| match e {
        GeometryError::Sim(e) => Error::Sim(e),
        GeometryError::Stopped => match check_interrupt(dir, None, Some("optimizing the gait".into())) {
            Err(i) => Error::Transaction(i),
            Ok(()) => Error::Input(e.to_string()),
        },
        e => Error::Input(e.to_string()),
    }
}

/// `dx`, `dy`, `dtheta` or `along(UX,UY)`.
fn measure(flag: &str, text: &str) -> Result<Measure, Error> {
    let t = text.trim();
    match t {
        "dx" => return Ok(Measure::Along([1.0, 0.0])),
        "dy" => return Ok(Measure::Along([0.0, 1.0])),
        "dtheta" => return Ok(Measure::Rotation),
        _ => {}
    }
    let bad = || Error::Input(format!("{flag} `{t}`: give dx, dy, dtheta or along(UX,UY) with finite UX, UY"));
    let inner = t.strip_prefix("along(").and_then(|r| r.strip_suffix(')')).ok_or_else(bad)?;
    let (x, y) = inner.split_once(',').ok_or_else(bad)?;
    let (x, y): (f64, f64) = (x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?);
    if x.is_finite() && y.is_finite() { Ok(Measure::Along([x, y])) } else { Err(bad()) }
}

/// The start gait written as `--gait` text as a Fourier series of order
/// `harmonics` (default its highest harmonic).
///
/// # Errors
/// A harmonic whose frequency is not a whole multiple of the gait's, or
/// above the order asked; an order outside 1 to [`MAX_ORDER`].
fn fourier(gait: &Gait, harmonics: Option<usize>, names: &[String]) -> Result<FourierGait, Error> {
    let omega = 2.0 * std::f64::consts::PI / gait.period;
    let mut rows: Vec<Vec<(usize, f64, f64)>> = Vec::new();
    for (k, w) in gait.shape.iter().enumerate() {
        let Waveform::Harmonics(hs) = w else {
            return Err(Error::Input(format!("--gait: {} is not a sum of harmonics", names[k])));
        };
        let mut row = Vec::new();
        for h in hs {
            let n = h.omega / omega;
            if (n - n.round()).abs() > 1e-9 || n.round() < 0.0 {
                return Err(Error::Input(format!(
                    "--gait: {}: a harmonic of frequency {} is not a whole multiple of the period's: write cos(k*t + c) with whole k",
                    names[k],
                    fmt_value(h.omega)
                )));
            }
            // cos(pi / 2) is 6e-17 in floating point: a sine's cosine part is 0
            let snap = |v: f64| if v.abs() <= 1e-15 * h.amplitude.abs() { 0.0 } else { v };
            row.push((n.round() as usize, snap(h.amplitude * h.phase.cos()), snap(-h.amplitude * h.phase.sin())));
        }
        rows.push(row);
    }
    let highest = rows.iter().flatten().map(|h| h.0).max().unwrap_or(0).max(1);
    let order = harmonics.unwrap_or(highest);
    if !(1..=MAX_ORDER).contains(&order) || order < highest {
        return Err(Error::Input(format!(
            "--harmonics {order}: give an order from {highest} (the start's highest harmonic) to {MAX_ORDER}"
        )));
    }
    let coefficients = rows
        .iter()
        .map(|row| {
            let mut c = vec![0.0; 2 * order + 1];
            for &(n, a, b) in row {
                if n == 0 {
                    c[0] += a;
                } else {
                    c[2 * n - 1] += a;
                    c[2 * n] += b;
                }
            }
            c
        })
        .collect();
    FourierGait::new(coefficients, order, gait.period).map_err(|e| Error::Input(e.to_string()))
}

/// The optimization of `model`'s gait, written into `dir`.
fn run(model: AnyModel, args: &GaitOptimizeArgs, dir: &std::path::Path) -> Result<(GaitOptimum, Vec<PathBuf>), Error> {
    let mut geo = Geometry::new(model, args.body.as_deref(), None).map_err(input(dir))?;
    geo.stop_when(|| pending().is_some());
    let names = geo.shape_names();
    let start = Gait::parse(&names, &args.gait).map_err(input(dir))?;
    let start = fourier(&start, args.harmonics, &names)?;
    let (sense, flag, text) = match (&args.maximize, &args.minimize) {
        (Some(t), _) => (Sense::Maximize, "--maximize", t),
        (None, Some(t)) => (Sense::Minimize, "--minimize", t),
        (None, None) => return Err(Error::Input("give --maximize MOTION or --minimize MOTION".into())),
    };
    let order = match args.order.as_str() {
        "first" => Order::First,
        "second" => Order::Second,
        _ => Order::Reconstructed,
    };
    let objective = GaitObjective { measure: measure(flag, text)?, per_cost: args.per_length, order };
    let mut problem = GaitOptimization::new(start, objective);
    if args.centre_only {
        problem = problem.centre_only();
    }
    problem.sense = sense;
    problem.margin = args.margin;
    problem.budget = args.budget;
    problem.max_evaluations = args.max_evaluations;
    if !args.ranges.is_empty() {
        problem.bounds = vec![None; names.len()];
        for (n, lo, hi) in &args.ranges {
            if lo > hi {
                return Err(Error::Input(format!("--range `{n}={lo}:{hi}`: the lower bound is above the upper")));
            }
            let k = names.iter().position(|x| x == n).ok_or_else(|| {
                Error::Input(format!("--range `{n}`: not a shape coordinate; the shape: {}", names.join(", ")))
            })?;
            problem.bounds[k] = Some((*lo, *hi));
        }
    }
    crate::output::transaction::arm_signals();
    let held = OutLock::take(dir)?;
    let o = optimize_gait(&geo, &problem).map_err(input(dir))?;
    if o.stopped {
        check_interrupt(dir, None, Some("optimizing the gait".into()))?;
    }
    let mut tx = Transaction::begin_locked(held)?;
    tx.retire(&["gait_optimum.csv".into(), "gait_history.csv".into()]);
    tx.write("gait_optimum.csv", optimum_csv(&problem, &o, &names).as_bytes())?;
    tx.write("gait_history.csv", history_csv(&o).as_bytes())?;
    if !args.no_figures {
        let chart = shape_chart(&problem.start, &o.gait, &names);
        let format = ezy_scene::FigureFormat::Png;
        let bytes = crate::render::plot::figure(&chart, format, ezy_scene::DEFAULT_DPI)
            .map_err(|e| Error::Input(format!("figure gait_optimum: {e}")))?;
        tx.write(&format.file_name("gait_optimum"), &bytes)?;
    }
    let files = tx.commit()?;
    Ok((o, files))
}

/// `gait_optimum.csv`: every coefficient, its start, its value at the
/// optimum and whether it was free.
fn optimum_csv(problem: &GaitOptimization, o: &GaitOptimum, names: &[String]) -> String {
    let mut text = record(["coefficient", "start", "optimum", "free"].map(str::to_string).to_vec());
    for (j, ((s, v), free)) in problem.start.flat().iter().zip(o.gait.flat()).zip(&problem.free).enumerate() {
        let label = problem.start.coefficient_label(names, j);
        text.push_str(&record(vec![label, number(*s), number(v), free.to_string()]));
    }
    text
}

/// `gait_history.csv`: every evaluation, its free coefficients and
/// objective.
fn history_csv(o: &GaitOptimum) -> String {
    let mut head = vec!["evaluation".to_string()];
    head.extend(o.names.iter().cloned());
    head.extend(["objective".to_string(), "failure".to_string()]);
    let mut text = record(head);
    for (k, e) in o.history.iter().enumerate() {
        let mut row = vec![(k + 1).to_string()];
        row.extend(e.values.iter().map(|v| number(*v)));
        row.push(if e.objective.is_finite() { number(e.objective) } else { String::new() });
        row.push(e.failure.as_deref().map(|f| f.replace(['\n', '\r'], " ")).unwrap_or_default());
        text.push_str(&record(row));
    }
    text
}

/// The start and the optimum in shape space: the first two shape
/// coordinates against each other (one coordinate: against time).
fn shape_chart(start: &FourierGait, optimum: &FourierGait, names: &[String]) -> Chart {
    let path = |g: &FourierGait| -> Vec<(f64, f64)> {
        let Ok(gait) = g.gait() else { return Vec::new() };
        (0..=200)
            .map(|i| {
                let t = gait.period * f64::from(i) / 200.0;
                let (r, _) = gait.at(t);
                if r.len() >= 2 { (r[0], r[1]) } else { (t, r[0]) }
            })
            .collect()
    };
    let (x, y) = if names.len() >= 2 {
        (format!("{} [rad]", names[0]), format!("{} [rad]", names[1]))
    } else {
        ("t [s]".to_string(), format!("{} [rad]", names.first().map_or("r", String::as_str)))
    };
    let mut chart = Chart::new("The gait in shape space: start and optimum", x, y);
    chart.equal_axes = names.len() >= 2;
    chart.series.push(Series { stroke: Stroke::Dash(0), ..Series::new("start", path(start)) });
    chart.series.push(Series { stroke: Stroke::Solid, ..Series::new("optimum", path(optimum)) });
    chart
}

/// The text `ezy gait-optimize` prints.
fn summary(name: &str, o: &GaitOptimum, seconds: f64, files: &[PathBuf]) -> String {
    let at: Vec<String> = o.names.iter().zip(&o.values).map(|(n, v)| format!("{n} = {}", fmt_value(*v))).collect();
    let mut s = format!(
        "{name}: {} = {} at {} (start {})\n",
        o.objective_name,
        fmt_value(o.objective),
        at.join(", "),
        fmt_value(o.start_objective)
    );
    let _ = writeln!(s, "{}", o.termination);
    let _ = writeln!(s, "gradient norm within the bounds: {:.1e}", o.projected_gradient_norm);
    let _ = writeln!(s, "{}", o.kkt.describe());
    let _ = writeln!(
        s,
        "net motion (dx, dy, dtheta) = ({}, {}, {}) at the objective's order; path length {} rad; least rank margin {}",
        fmt_value(o.motion[0]),
        fmt_value(o.motion[1]),
        fmt_value(o.motion[2]),
        fmt_value(o.cost),
        fmt_value(o.rank_margin)
    );
    let _ = writeln!(s, "{} evaluations in {seconds:.2} s (SLSQP on exact gradients)", o.history.len());
    for file in files {
        let _ = writeln!(s, "wrote {}", file.display());
    }
    s
}
