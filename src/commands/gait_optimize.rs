//! `ezy gait-optimize [SCENE | MODEL] --gait NAME=EXPR,.. (--maximize W |
//! --minimize W)`: the closed gait of a kinematic system, a Fourier
//! series per shape coordinate started from `--gait`, that makes a
//! cycle's net motion (or its net motion per path length) largest or
//! smallest within shape ranges, a margin from the singular set and a
//! path-length budget ([`ezy_core::design::gait`]: SLSQP on exact
//! gradients from the connection and curvature). `gait_optimum.csv`,
//! `gait_history.csv`, a figure of the gait in shape space and, with two
//! shape coordinates, `gait_curvature.png`: the start and the optimum
//! over the height function of the objective's component (none with one
//! shape coordinate: the height function needs a plane); with
//! `--report`, `report.html`.

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::design::gait::{
    FourierGait, GaitObjective, GaitOptimization, GaitOptimum, Measure, Order, optimize_gait,
};
use ezy_core::design::optimize::Sense;
use ezy_core::geometry::{Geometry, GeometryError};
use ezy_core::{AnyModel, fmt_value};
use ezy_scene::FigureFormat;

use super::committed;
use crate::app::scenes::is_scene_path;
use crate::app::{App, AppError, is_model_path};
use crate::cli::{parse_over, parse_set};
use crate::output::csv::{number, record};
use crate::output::transaction::{OutLock, Transaction, check_interrupt, pending};
use crate::render::height_map::{ShapePlane, axis, height_grid, height_map};
use crate::render::plot::chart::chart_svg;
use crate::render::plot::heat_map::{HeatMap, heatmap_svg};
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::render::report;
use crate::session::{Drawn, Error, page_figures, with_sets, write_figures};

/// Optimize a kinematic system's gait: the Fourier series per shape
/// coordinate, started from --gait, that makes a cycle's net motion (or
/// its net motion per path length) largest or smallest within shape
/// ranges, a margin from the singular set and a path-length budget (SLSQP
/// on exact gradients of the connection and curvature): gait_optimum.csv,
/// gait_history.csv, a figure of the gait in shape space and, with two
/// shape coordinates, one of it over the height function.
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
    /// Divide the net motion by the gait's path length in shape space,
    /// int sqrt(r'^T G r') dt in the metric G of --metric (the identity
    /// by default): the motion per radian of shape change.
    #[arg(long)]
    per_length: bool,
    /// The metric G of the path length (--per-length, --budget): its
    /// n x n entries row by row, comma separated, for n shape coordinates
    /// (2,0.3,0.3,1), symmetric positive definite [default: the identity].
    #[arg(long, value_name = "G11,G12,..", value_delimiter = ',', allow_negative_numbers = true)]
    metric: Vec<f64>,
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
    /// Do not write the figures (gait_optimum.png, gait_curvature.png).
    #[arg(long)]
    no_figures: bool,
    /// Also write report.html: the summary, the figures and the command
    /// line that reruns the optimization, in one self-contained file.
    #[arg(long)]
    report: bool,
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
    let (o, files) = run(model, &args, (&name, clock), &dir).map_err(AppError::from_run)?;
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

/// The optimization of `model`'s gait, written into `dir` (`name`: the
/// scene's or model's, `clock` started before it, for the report).
fn run(
    model: AnyModel,
    args: &GaitOptimizeArgs,
    (name, clock): (&str, Instant),
    dir: &std::path::Path,
) -> Result<(GaitOptimum, Vec<PathBuf>), Error> {
    let mut geo = Geometry::new(model, args.body.as_deref(), None).map_err(input(dir))?;
    geo.stop_when(|| pending().is_some());
    let names = geo.shape_names();
    let start = crate::cli::fourier_start(&args.gait, args.harmonics, None, &names).map_err(Error::Input)?;
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
    problem.metric = (!args.metric.is_empty()).then(|| args.metric.clone());
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
    let format = FigureFormat::Png;
    let mut written = vec!["gait_optimum.csv".to_string(), "gait_history.csv".to_string()];
    let mut retired = written.clone();
    retired.extend(FIGURES.iter().map(|stem| format.file_name(stem)));
    retired.push("report.html".into());
    tx.retire(&retired);
    tx.write("gait_optimum.csv", optimum_csv(&problem, &o, &names).as_bytes())?;
    tx.write("gait_history.csv", history_csv(&o).as_bytes())?;
    // drawn as SVG for the figures' files and the report alike; the
    // optimum's figure is the command's own, the heat map a note
    let mut drawn = Vec::new();
    if !args.no_figures || args.report {
        let chart = shape_chart(&problem.start, &o.gait, &names);
        let svg = chart_svg(&chart).map_err(|e| e.to_string());
        drawn.push(Drawn { stem: "gait_optimum", title: chart.title.clone(), svg, required: true });
        if names.len() == 2 {
            tx.check(None, Some("drawing gait_curvature".into()))?;
            let map = curvature_map(&geo, &problem, &o.gait, &names);
            tx.check(None, Some("drawing gait_curvature".into()))?;
            let svg = heatmap_svg(&map).map_err(|e| e.to_string());
            drawn.push(Drawn { stem: "gait_curvature", title: map.title.clone(), svg, required: false });
        }
    }
    if !args.no_figures {
        written.extend(write_figures(&mut tx, &drawn, (format, ezy_scene::DEFAULT_DPI))?);
    }
    if args.report {
        written.push("report.html".into());
        let figures = page_figures(drawn, format);
        let text = summary(name, &o, clock.elapsed().as_secs_f64(), &[]);
        let page = report::analysis_page(
            &format!("ezy gait-optimize: {name}"),
            &text,
            &figures,
            &written,
            &command_line(args),
        );
        tx.write("report.html", page.as_bytes())?;
    }
    let files = tx.commit()?;
    Ok((o, files))
}

/// The figures' stems: the start and the optimum in shape space, and
/// over the objective's height function (two shape coordinates). An
/// earlier run's are retired before a run writes its own.
const FIGURES: &[&str] = &["gait_optimum", "gait_curvature"];

/// Cells of the height function's map along each shape coordinate.
const CURVATURE_CELLS: usize = 60;

/// The margin of the height function's map around the box of the start
/// and the optimum, a fraction of the box's size on each side.
const CURVATURE_MARGIN: f64 = 0.25;

/// The gait `g` sampled at 201 times over its period (empty if it is no
/// gait).
fn samples(g: &FourierGait) -> Vec<Vec<f64>> {
    let Ok(gait) = g.gait() else { return Vec::new() };
    (0..=200).map(|i| gait.at(gait.period * f64::from(i) / 200.0).0).collect()
}

/// The weights of the height function's components `(x, y, theta)` the
/// objective measures (a direction normalized, as the objective's) and
/// their name, as the objective's (`GaitObjective::name`): `D(-A)_x`,
/// `D(-A)_y`, `D(-A)_theta`, `D(-A) along (3, -4)`.
fn height_of(measure: Measure) -> ([f64; 3], String) {
    match measure {
        Measure::Along([x, y]) => {
            let n = x.hypot(y);
            let name = match (x, y) {
                (x, 0.0) if x > 0.0 => "D(-A)_x".to_string(),
                (0.0, y) if y > 0.0 => "D(-A)_y".to_string(),
                (x, y) => format!("D(-A) along ({}, {})", fmt_value(x), fmt_value(y)),
            };
            ([x / n, y / n, 0.0], name)
        }
        Measure::Rotation => ([0.0, 0.0, 1.0], "D(-A)_theta".to_string()),
    }
}

/// The start (dashed) and the optimum over the height function of the
/// objective's component on a grid of [`CURVATURE_CELLS`] cells along
/// each of the two shape coordinates, over the box of both gaits and
/// [`CURVATURE_MARGIN`] of it on each side (a cell on the singular set
/// left grey). The height function `D(-A)` is the integrand of the
/// second-order net motion over the area a gait encloses: the first
/// order leaves out its Lie bracket, the reconstruction adds the higher
/// orders, and per path length the objective divides by the length.
fn curvature_map(
    geo: &Geometry<AnyModel>,
    problem: &GaitOptimization,
    optimum: &FourierGait,
    names: &[String],
) -> HeatMap {
    let (start, best) = (samples(&problem.start), samples(optimum));
    let curve = |s: &[Vec<f64>]| -> Vec<(f64, f64)> { s.iter().map(|r| (r[0], r[1])).collect() };
    let (start, best) = (curve(&start), curve(&best));
    let span = |k: usize| {
        let v = start.iter().chain(&best).map(|p| if k == 0 { p.0 } else { p.1 });
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        // a gait still along a coordinate: a box 0.2 rad wide
        let m = if hi - lo > 1e-9 { CURVATURE_MARGIN * (hi - lo) } else { 0.1 };
        if lo.is_finite() && hi.is_finite() { (lo - m, hi + m) } else { (-1.0, 1.0) }
    };
    let ((x0, x1), (y0, y1)) = (span(0), span(1));
    let (xs, ys) = (axis(x0, x1, CURVATURE_CELLS), axis(y0, y1, CURVATURE_CELLS));
    let (weights, label) = height_of(problem.objective.measure);
    let values = height_grid(geo, &xs, &ys, weights);
    // the start dashed: every other run of its samples
    let mut lines: Vec<Vec<(f64, f64)>> =
        start.chunks(8).map(|c| c[..c.len().min(5)].to_vec()).filter(|c| c.len() >= 2).collect();
    lines.push(best);
    let unit = if weights[2] == 0.0 { "m/rad^2" } else { "rad/rad^2" };
    let plane = ShapePlane { names: [&names[0], &names[1]], xs: &xs, ys: &ys };
    height_map(
        format!("Height function {label} (second order): start dashed"),
        format!("{label} [{unit}]"),
        &plane,
        values,
        lines,
    )
}

/// The command line that reruns the optimization, quoted for a shell
/// (a target that starts like a flag written as a path).
fn command_line(args: &GaitOptimizeArgs) -> String {
    let mut w: Vec<String> = vec!["ezy".into(), "gait-optimize".into()];
    if let Some(t) = &args.target {
        w.push(if t.starts_with('-') { format!("./{t}") } else { t.clone() });
    }
    w.extend(["--gait".into(), args.gait.clone()]);
    if let Some(m) = &args.maximize {
        w.extend(["--maximize".into(), m.clone()]);
    }
    if let Some(m) = &args.minimize {
        w.extend(["--minimize".into(), m.clone()]);
    }
    if args.per_length {
        w.push("--per-length".into());
    }
    if !args.metric.is_empty() {
        let entries: Vec<String> = args.metric.iter().map(|v| format!("{v:?}")).collect();
        w.extend(["--metric".into(), entries.join(",")]);
    }
    w.extend(["--order".into(), args.order.clone()]);
    if let Some(n) = args.harmonics {
        w.extend(["--harmonics".into(), n.to_string()]);
    }
    if args.centre_only {
        w.push("--centre-only".into());
    }
    for (n, lo, hi) in &args.ranges {
        w.extend(["--range".into(), format!("{n}={lo:?}:{hi:?}")]);
    }
    for (flag, v) in [("--margin", args.margin), ("--budget", args.budget)] {
        if let Some(v) = v {
            w.extend([flag.into(), format!("{v:?}")]);
        }
    }
    w.extend(["--max-evaluations".into(), args.max_evaluations.to_string()]);
    if let Some(b) = &args.body {
        w.extend(["--body".into(), b.clone()]);
    }
    for (n, v) in &args.sets {
        w.extend(["--set".into(), format!("{n}={v:?}")]);
    }
    if let Some(out) = &args.out {
        w.extend(["--out".into(), out.display().to_string()]);
    }
    if args.no_figures {
        w.push("--no-figures".into());
    }
    w.push("--report".into());
    w.iter().map(|x| report::shell_quote(x)).collect::<Vec<_>>().join(" ")
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
