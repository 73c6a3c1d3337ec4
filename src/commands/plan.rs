//! `ezy plan [SCENE] --input EFFECT.FIELD .. (--to NAME=VALUE,.. |
//! --at-rest)`: the least-effort inputs that drive a scene from its
//! initial state to a target at `t_end` ([`ezy_core::plan`]: direct
//! multiple shooting, SLSQP on exact sensitivities), each input a time
//! function of one of the scene's effects replaced by a piecewise-linear
//! table; the plan verified by an ordinary run. `plan.csv`,
//! `plan_summary.csv`, figures of the inputs over time and of the path
//! in the plane and, with `--report`, `report.html`.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::design::fit::Data;
use ezy_core::effects::{Extrapolate, Table, Waveform};
use ezy_core::plan::{
    BuildInputs, Input, MAX_UNKNOWNS, Maneuver, Objective, PathConstraint, Plan, PlanSettings, Status, Target,
};
use ezy_core::{Model, Problem, RunSettings, SetupError, SimError, fmt_value};
use ezy_scene::{Scene, SceneEffect};

use super::{committed, scene_and_options};
use crate::app::{App, AppError};
use crate::cli::Overrides;
use crate::output::csv::{number, record};
use crate::output::progress::Heartbeat;
use crate::output::transaction::{Interrupted, OutLock, Transaction, TransactionError};
use crate::render::plot::chart::chart_svg;
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::render::report;
use crate::session::{Drawn, Error, RunOptions, analysis_error, page_figures, settings, write_figures};

/// Plan the least-effort inputs that take a scene from its initial
/// state to a target at t_end (direct multiple shooting, SLSQP on exact
/// sensitivities), each input an effect's time function replaced by a
/// piecewise-linear table, verified by an ordinary run: plan.csv,
/// plan_summary.csv and figures of the inputs and of the path.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct PlanArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// An input planned: a time function of an effect of the scene,
    /// EFFECT.FIELD (push.fx, motor.torque), replaced by a piecewise-linear
    /// table through the plan's nodes, its warm start the scene's own
    /// function at the nodes (within the bounds); repeatable.
    #[arg(long = "input", value_name = "EFFECT.FIELD", required = true)]
    inputs: Vec<String>,
    /// Bounds of an input, EFFECT.FIELD=LO:HI (finite numbers, LO <= HI;
    /// an input without --bound is free); repeatable.
    #[arg(long = "bound", value_name = "EFFECT.FIELD=LO:HI", value_parser = crate::cli::parse_over)]
    bounds: Vec<(String, f64, f64)>,
    /// The target at t_end: coordinates and velocities NAME=VALUE, comma
    /// separated (x1=1,y1=0; a velocity is its coordinate's name with d
    /// appended, x1d=0); repeatable.
    #[arg(long = "to", value_name = "NAME=VALUE,..", value_delimiter = ',', value_parser = crate::cli::parse_set)]
    to: Vec<(String, f64)>,
    /// At rest at t_end: every velocity zero (with the coordinates of --to).
    #[arg(long)]
    at_rest: bool,
    /// A path constraint: a state column bounded at every node of the
    /// mesh, NAME<=HI, NAME>=LO or LO<=NAME<=HI (x1d<=0.6, y1>=-0.5; a
    /// velocity is its coordinate's name with d appended); between the
    /// nodes the verification run reports its largest excess; repeatable.
    #[arg(long = "path", value_name = "BOUND")]
    paths: Vec<String>,
    /// What the plan minimizes: effort (the inputs squared, integrated
    /// and summed) or time (the duration, free within --free-time).
    #[arg(long, value_enum, default_value = "effort")]
    minimize: Minimize,
    /// The duration's weight W added to the effort (effort + W T; W in
    /// the effort's unit per second), with --free-time.
    #[arg(long, value_name = "W")]
    time_weight: Option<f64>,
    /// The duration free within [LO, HI] s, started at the scene's t_end
    /// (LO <= t_end <= HI): the nodes move with it.
    #[arg(long, value_name = "LO:HI", value_parser = parse_free_time)]
    free_time: Option<(f64, f64)>,
    /// Segments of the time mesh over [0, t_end] (the inputs have N + 1
    /// nodes, linear between them).
    #[arg(long, value_name = "N", default_value_t = 10)]
    segments: usize,
    /// Shooting intervals M of the N segments: the state is an unknown
    /// where each starts (1, the default: single shooting, which
    /// converges on the EzyRoller where a node at every segment does not;
    /// more for dynamics unstable over the horizon; at most N).
    #[arg(long, value_name = "M", default_value_t = 1)]
    intervals: usize,
    /// The warm start from a CSV file: a column `t` [s] and one named as
    /// each input (an earlier plan's plan.csv, on any mesh), each input's
    /// values linear between its rows and held past them, taken at the
    /// nodes within the bounds, instead of the scene's own time functions.
    #[arg(long, value_name = "FILE")]
    guess: Option<PathBuf>,
    /// Most evaluations of the program (each runs the N segments with
    /// their sensitivities).
    #[arg(long, value_name = "K", default_value_t = 500)]
    evaluations: usize,
    /// Output directory [default: out/plan/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw the figures.
    #[arg(long)]
    no_figures: bool,
    /// Also write report.html: the summary, the figures and the command
    /// line that reruns the plan, in one self-contained file.
    #[arg(long)]
    report: bool,
    #[command(flatten)]
    overrides: Overrides,
    /// The objective minimized instead of the effort, where the caller
    /// set one on the `App` ([`App::plan_objective`]; no flag).
    #[arg(skip)]
    objective: Option<Objective>,
    /// Path constraints of the caller's own, where it set some on the
    /// `App` ([`App::plan_path`]; no flag).
    #[arg(skip)]
    own_path: Vec<PathConstraint>,
}

/// What `--minimize` names.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Minimize {
    /// The effort: the inputs squared, integrated and summed.
    #[default]
    Effort,
    /// The duration (with --free-time).
    Time,
}

/// `LO:HI` of `--free-time`: two finite numbers.
fn parse_free_time(s: &str) -> Result<(f64, f64), String> {
    let (lo, hi) = s.split_once(':').ok_or_else(|| format!("`{s}`: expected LO:HI [s]"))?;
    let num = |v: &str| match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{s}`: `{}` is not a finite number", v.trim())),
    };
    Ok((num(lo)?, num(hi)?))
}

/// The objective of `--minimize` and `--time-weight`, or the caller's
/// own (which these flags may not change).
///
/// # Errors
/// A caller's objective with either flag.
fn objective(args: &PlanArgs) -> Result<Objective, Error> {
    let flags = args.minimize == Minimize::Time || args.time_weight.is_some();
    match (&args.objective, flags) {
        (Some(_), true) => Err(Error::Input(
            "--minimize time and --time-weight: the objective is the caller's own (App::plan_objective); set its time weight there".into(),
        )),
        (Some(o), false) => Ok(o.clone()),
        (None, _) => {
            let base = if args.minimize == Minimize::Time { Objective::time() } else { Objective::effort() };
            Ok(match args.time_weight {
                Some(w) => base.time_weight(w),
                None => base,
            })
        }
    }
}

/// The arguments of `ezy plan`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    PlanArgs::augment_args(cmd)
}

/// Plans the scene named (or the default scene) and prints the maneuver.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let mut args = PlanArgs::from_arg_matches(args)?;
    args.objective = app.own_plan_objective();
    args.own_path = app.own_plan_path();
    let (src, opts) =
        scene_and_options(app, args.scene.as_deref(), "plan", (args.out.clone(), args.no_figures), &args.overrides)?;
    let opts = RunOptions { progress: true, ..opts };
    let scene = &src.scene;
    let model = &app.model_or_error(&scene.model)?;
    let (m, files) = plan_model(model, scene, &opts, &args).map_err(AppError::from_run)?;
    let text = summary(&scene.name, (&args.inputs, args.intervals), &m, &files);
    committed(out, &text, &opts.out)?;
    match &m.status {
        Status::Optimal => Ok(()),
        Status::Infeasible { violation, constraint } => Err(AppError::Failed(format!(
            "infeasible: no point met the target; the smallest violation found is {} ({constraint}); the least violating inputs are in {}",
            fmt_value(*violation),
            opts.out.join("plan.csv").display()
        ))),
        Status::NotConverged { reason } => Err(AppError::Failed(format!(
            "not converged: {reason}; the best inputs so far are in {}",
            opts.out.join("plan.csv").display()
        ))),
    }
}

/// The heartbeat the planner's problems report to, once started.
type Beat = Arc<Mutex<Option<Heartbeat>>>;

/// Where an input is: its effect's index in the scene and the field's
/// key path in the effect's table.
#[derive(Debug, Clone)]
struct Slot {
    effect: usize,
    path: Vec<String>,
}

/// The scene's effects with each input's time function replaced by its
/// table of `tables` (in the inputs' order).
///
/// # Errors
/// The input and why its field takes no table: not a key of the effect,
/// or a key that is not a time function.
fn with_tables(scene: &Scene, names: &[String], slots: &[Slot], tables: &[Table]) -> Result<Scene, SimError> {
    let mut out = scene.clone();
    for ((name, slot), table) in names.iter().zip(slots).zip(tables) {
        let (effect, spec) = &out.effects[slot.effect];
        let fail = |message: String| {
            SimError::Setup(SetupError::Scene {
                key: format!("effects.{effect}.{}", slot.path.join(".")),
                message: format!("--input `{name}`: {message}"),
            })
        };
        let mut tree = toml::Value::try_from(spec).map_err(|e| fail(e.to_string()))?;
        let value = toml::Value::try_from(Waveform::Table(table.clone())).map_err(|e| fail(e.to_string()))?;
        let mut node = &mut tree;
        for (k, part) in slot.path.iter().enumerate() {
            let toml::Value::Table(t) = node else {
                return Err(fail(format!("`{}` is not a table of keys", slot.path[..k].join("."))));
            };
            node = if k + 1 == slot.path.len() {
                t.insert(part.clone(), toml::Value::Boolean(false));
                t.get_mut(part).expect("just inserted")
            } else {
                t.get_mut(part).ok_or_else(|| fail(format!("effect `{effect}` has no key `{part}`")))?
            };
        }
        *node = value;
        let changed: SceneEffect = tree.try_into().map_err(|e: toml::de::Error| {
            fail(format!(
                "effect `{effect}` (kind {}) takes no time function at `{}`: {}",
                spec.kind(),
                slot.path.join("."),
                e.message().trim()
            ))
        })?;
        out.effects[slot.effect].1 = changed.inherit_kind(spec);
    }
    Ok(out)
}

/// The slot of each input `EFFECT.FIELD` in `scene`.
///
/// # Errors
/// An input without a `.`, or naming an effect the scene does not have
/// (listing its effects).
fn slots(scene: &Scene, inputs: &[String]) -> Result<Vec<Slot>, Error> {
    inputs
        .iter()
        .map(|i| {
            let Some((effect, field)) = i.split_once('.').filter(|(e, f)| !e.is_empty() && !f.is_empty()) else {
                return Err(Error::Input(format!(
                    "--input `{i}`: expected EFFECT.FIELD, an effect of the scene and its time function (push.fx, motor.torque)"
                )));
            };
            let Some(k) = scene.effects.iter().position(|(n, _)| n == effect) else {
                let known: Vec<&str> = scene.effects.iter().map(|(n, _)| n.as_str()).collect();
                return Err(Error::Input(format!(
                    "--input `{i}`: scene `{}` has no effect `{effect}`; its effects: {}",
                    scene.name,
                    if known.is_empty() { "none".to_string() } else { known.join(", ") }
                )));
            };
            Ok(Slot { effect: k, path: field.split('.').map(str::to_string).collect() })
        })
        .collect()
}

/// The inputs with their bounds (free where no `--bound` names them).
///
/// # Errors
/// A `--bound` naming no input, or with its lower bound above its upper.
fn inputs(args: &PlanArgs) -> Result<Vec<Input>, Error> {
    for (name, lo, hi) in &args.bounds {
        if !args.inputs.contains(name) {
            return Err(Error::Input(format!(
                "--bound `{name}={lo}:{hi}`: no --input `{name}`; the inputs: {}",
                args.inputs.join(", ")
            )));
        }
        if lo > hi {
            return Err(Error::Input(format!(
                "--bound `{name}={lo}:{hi}`: the lower bound {lo} is above the upper {hi}: give LO <= HI"
            )));
        }
    }
    Ok(args
        .inputs
        .iter()
        .map(|name| match args.bounds.iter().find(|(n, _, _)| n == name) {
            Some(&(_, lo, hi)) => Input::new(name.clone(), lo, hi),
            None => Input::new(name.clone(), f64::NEG_INFINITY, f64::INFINITY),
        })
        .collect())
}

/// Each input with its warm start: the guess file's column of its name
/// (`guess`: `--guess`) or else the scene's own time function, its
/// values at the nodes of `n` segments over `[0, t_end]`, each within
/// the input's bounds (a field the scene leaves at its default, or one
/// that is not a waveform, starts from 0 or the bound nearest it).
fn warm_starts(
    scene: &Scene,
    slots: &[Slot],
    (inputs, guess): (Vec<Input>, Option<&Data>),
    n: usize,
    t_end: f64,
) -> Vec<Input> {
    let t: Vec<f64> = (0..=n).map(|k| if k == n { t_end } else { t_end * k as f64 / n as f64 }).collect();
    inputs
        .into_iter()
        .zip(slots)
        .enumerate()
        .map(|(k, (input, slot))| {
            let tree = toml::Value::try_from(&scene.effects[slot.effect].1).ok();
            let field = slot.path.iter().fold(tree, |node, part| node.and_then(|v| v.get(part).cloned()));
            let wave = match guess {
                Some(g) => Some(Waveform::Table(Table {
                    t: g.t.clone(),
                    value: g.values[k].clone(),
                    extrapolate: Extrapolate::Hold,
                })),
                None => field.and_then(|v| v.try_into::<Waveform>().ok()),
            };
            let Some(wave) = wave else { return input };
            let value = t.iter().map(|&tk| wave.eval(tk).clamp(input.lower, input.upper)).collect();
            let table = Table { t: t.clone(), value, extrapolate: Extrapolate::Hold };
            input.guess_waveform(Waveform::Table(table))
        })
        .collect()
}

/// The target of `--to` and `--at-rest` on a model of coordinates `coords`.
///
/// # Errors
/// No target; a name that is neither a coordinate nor a coordinate's
/// velocity (listing the state's names).
fn target(args: &PlanArgs, coords: &[String]) -> Result<Target, Error> {
    // a user's objective may leave the end free
    let own = args.objective.as_ref().is_some_and(|o| o.user.is_some());
    if args.to.is_empty() && !args.at_rest && !own {
        return Err(Error::Input("no target: give --to NAME=VALUE,.. (x1=1,y1=0) or --at-rest, or both".into()));
    }
    let mut t = Target::new();
    for (name, value) in &args.to {
        t = if coords.contains(name) {
            t.q(name, *value)
        } else if let Some(c) = name.strip_suffix('d').filter(|c| coords.iter().any(|k| k == c)) {
            t.qd(c, *value)
        } else {
            let state: Vec<String> = coords.iter().cloned().chain(coords.iter().map(|c| format!("{c}d"))).collect();
            return Err(Error::Input(format!(
                "--to `{name}={value}`: the model has no coordinate `{name}` (nor is it a coordinate's velocity); its state: {}",
                state.join(", ")
            )));
        };
    }
    Ok(if args.at_rest { t.at_rest() } else { t })
}

/// The path constraints of `--path` on a model of coordinates `coords`.
///
/// # Errors
/// A bound not of the forms `NAME<=HI`, `NAME>=LO`, `LO<=NAME<=HI`; a
/// number that is not finite; a name that is neither a coordinate nor a
/// coordinate's velocity (listing the state's names).
fn path_constraints(paths: &[String], coords: &[String]) -> Result<Vec<PathConstraint>, Error> {
    let mut out = Vec::new();
    for text in paths {
        let bad = |why: &str| {
            Error::Input(format!("--path `{text}`: {why}; give NAME<=HI, NAME>=LO or LO<=NAME<=HI (x1d<=0.6)"))
        };
        let number = |s: &str| -> Result<f64, Error> {
            match s.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(bad(&format!("`{}` is not a finite number", s.trim()))),
            }
        };
        let (name, lo, hi) = if text.contains(">=") {
            let parts: Vec<&str> = text.split(">=").collect();
            if parts.len() != 2 || text.contains("<=") {
                return Err(bad("one `>=` and no `<=`"));
            }
            (parts[0].trim(), number(parts[1])?, f64::INFINITY)
        } else {
            match text.split("<=").collect::<Vec<_>>()[..] {
                [name, hi] => (name.trim(), f64::NEG_INFINITY, number(hi)?),
                [lo, name, hi] => (name.trim(), number(lo)?, number(hi)?),
                _ => return Err(bad("no bound")),
            }
        };
        let p = if coords.iter().any(|c| c == name) {
            PathConstraint::q(name, lo, hi)
        } else if let Some(c) = name.strip_suffix('d').filter(|c| coords.iter().any(|k| k == c)) {
            PathConstraint::qd(c, lo, hi)
        } else {
            let state: Vec<String> = coords.iter().cloned().chain(coords.iter().map(|c| format!("{c}d"))).collect();
            return Err(bad(&format!(
                "the model has no coordinate `{name}` (nor is it a coordinate's velocity); its state: {}",
                state.join(", ")
            )));
        };
        out.push(p);
    }
    Ok(out)
}

/// The input 0 over `[0, t_end]` (two nodes: what the scene is checked
/// with before the mesh's size is).
fn zero(t_end: f64) -> Table {
    Table { t: vec![0.0, t_end], value: vec![0.0; 2], extrapolate: Extrapolate::Hold }
}

/// The plan of `scene` on `proto` (a model at its defaults), written
/// into `opts.out`.
///
/// # Errors
/// A bad input, bound, target or setting, refused before any work; the
/// planner's and the output's errors; an interruption, after the best
/// inputs so far are written.
fn plan_model<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    args: &PlanArgs,
) -> Result<(Maneuver, Vec<PathBuf>), Error> {
    let run: RunSettings = settings(scene, opts)?;
    let inputs = inputs(args)?;
    let base = scene.with_sets(&proto.info(), &opts.sets)?;
    let slots = slots(&base, &args.inputs)?;
    // the scene with flat inputs: its errors (a field that is no time
    // function, a bad override) before any work
    let zeros: Vec<Table> = inputs.iter().map(|_| zero(run.t_end)).collect();
    let (first, _) = with_tables(&base, &args.inputs, &slots, &zeros)?.problem_with(proto.clone(), &[])?;
    let info = first.model.info();
    let coords: Vec<String> = info.coords.iter().map(|c| c.to_string()).collect();
    let target = target(args, &coords)?;
    let mut path = path_constraints(&args.paths, &coords)?;
    path.extend(args.own_path.iter().cloned());
    if !(1..=args.segments.max(1)).contains(&args.intervals) {
        return Err(Error::Input(format!(
            "--intervals {}: give 1 (single shooting) to --segments ({})",
            args.intervals, args.segments
        )));
    }
    let plan_settings = PlanSettings {
        max_evaluations: args.evaluations,
        intervals: args.intervals,
        free_time: args.free_time,
        ..PlanSettings::new(args.segments, run.t_end)
    };
    let objective = objective(args)?;
    // the program's size before anything of it is allocated
    let nz = 2 * info.nq() - info.n_holonomic - info.nc();
    let unknowns = plan_settings.unknowns(inputs.len(), nz);
    if unknowns > MAX_UNKNOWNS as u128 {
        let nodes = inputs.len() as u128 * (args.segments as u128 + 1);
        let what = match args.intervals {
            1 => format!("{nodes} input nodes"),
            m => format!(
                "{nodes} input nodes and {nz} state components at each of the {} inner nodes that start a shooting interval",
                m - 1
            ),
        };
        return Err(Error::Input(format!(
            "--segments {}: {unknowns} unknowns ({what}), more than the limit of {MAX_UNKNOWNS} (ezy_core::plan::MAX_UNKNOWNS: SLSQP is dense): take fewer segments{}",
            args.segments,
            if args.intervals > 1 { " or intervals" } else { "" }
        )));
    }
    let guess = match &args.guess {
        Some(path) => Some(crate::cli::read_columns(path, &args.inputs, "the guess file").map_err(Error::Input)?),
        None => None,
    };
    let inputs = warm_starts(&base, &slots, (inputs, guess.as_ref()), args.segments, run.t_end);
    let beat: Beat = Arc::new(Mutex::new(None));
    let build = {
        let (names, model, baumgarte, beat) = (args.inputs.clone(), proto.clone(), opts.baumgarte, Arc::clone(&beat));
        let (built, scene_name) = (AtomicUsize::new(0), scene.name.clone());
        Arc::new(move |tables: &[Table]| -> Result<Problem<M>, SimError> {
            if crate::output::transaction::pending().is_some() {
                return Err(SimError::Setup(SetupError::Scene {
                    key: "plan".into(),
                    message: "stopped by a signal".into(),
                }));
            }
            let n = built.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(b) = beat.lock().unwrap_or_else(std::sync::PoisonError::into_inner).as_ref() {
                b.set(format!("plan {scene_name}: {n} segment problems built"));
            }
            let (mut p, _) = with_tables(&base, &names, &slots, tables)?.problem_with(model.clone(), &[])?;
            p.settings = run;
            p.baumgarte = baumgarte;
            Ok(p)
        })
    };
    let shared = Arc::clone(&build);
    let plan = Plan::with_objective(inputs, target, plan_settings, objective, move |t: &[Table]| shared(t))
        .map_err(analysis_error(&opts.out))?
        .with_path(path)
        .map_err(analysis_error(&opts.out))?
        .stop_when(|| crate::output::transaction::pending().is_some());
    crate::output::transaction::arm_signals();
    let held = OutLock::take(&opts.out)?;
    if opts.progress {
        *beat.lock().unwrap_or_else(std::sync::PoisonError::into_inner) =
            Some(Heartbeat::start(format!("plan {}: the warm start", scene.name)));
    }
    let solved = plan.solve();
    // the heartbeat stopped
    drop(beat.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take());
    if crate::output::transaction::pending().is_some() {
        let tables = solved.as_ref().ok().map(|m| vec![("plan.csv", plan_csv(&args.inputs, m))]).unwrap_or_default();
        drop(held);
        return Err(interrupted(&opts.out, &tables));
    }
    let m = solved.map_err(analysis_error(&opts.out))?;
    let mut tx = Transaction::begin_locked(held)?;
    tx.retire(&["plan.csv".into(), "plan_summary.csv".into(), "report.html".into()]);
    tx.write("plan.csv", plan_csv(&args.inputs, &m).as_bytes())?;
    tx.write("plan_summary.csv", summary_csv(&m).as_bytes())?;
    let mut written = vec!["plan.csv".to_string(), "plan_summary.csv".to_string()];
    let (format, dpi) = opts.look(scene);
    // drawn as SVG for the figures' files and the report alike
    let mut drawn = Vec::new();
    if opts.figures || args.report {
        let mut charts = vec![("plan", inputs_chart(&args.inputs, &m))];
        charts.extend(path_chart(&*build, m.t_end, &m, &info).map(|c| ("plan_path", c)));
        for (stem, chart) in charts {
            tx.check(None, Some(format!("drawing {stem}")))?;
            let svg = chart_svg(&chart).map_err(|e| e.to_string());
            drawn.push(Drawn { stem, title: chart.title.clone(), svg, required: true });
        }
    }
    if opts.figures {
        written.extend(write_figures(&mut tx, &drawn, (format, dpi))?);
    }
    if args.report {
        written.push("report.html".into());
        let figures = page_figures(drawn, format);
        let text = summary(&scene.name, (&args.inputs, args.intervals), &m, &[]);
        let command = command_line(args, &scene.name, opts);
        let page = report::analysis_page(&format!("ezy plan: {}", scene.name), &text, &figures, &written, &command);
        tx.write("report.html", page.as_bytes())?;
    }
    let files = tx.commit()?;
    Ok((m, files))
}

/// The command line that reruns the plan of scene `scene` (the one
/// named, else the default's name), quoted for a shell: the plan's flags
/// and the overrides as `ezy run --report` writes them
/// ([`RunOptions::to_args`]).
fn command_line(args: &PlanArgs, scene: &str, opts: &RunOptions) -> String {
    let scene = args.scene.clone().unwrap_or_else(|| scene.to_string());
    // a relative path that starts like a flag stays a path
    let scene = if scene.starts_with('-') { format!("./{scene}") } else { scene };
    let mut w: Vec<String> = vec!["ezy".into(), "plan".into(), scene];
    for i in &args.inputs {
        w.extend(["--input".into(), i.clone()]);
    }
    for (n, lo, hi) in &args.bounds {
        w.extend(["--bound".into(), format!("{n}={lo:?}:{hi:?}")]);
    }
    for (n, v) in &args.to {
        w.extend(["--to".into(), format!("{n}={v:?}")]);
    }
    if args.at_rest {
        w.push("--at-rest".into());
    }
    for p in &args.paths {
        w.extend(["--path".into(), p.clone()]);
    }
    if args.minimize == Minimize::Time {
        w.extend(["--minimize".into(), "time".into()]);
    }
    if let Some(tw) = args.time_weight {
        w.extend(["--time-weight".into(), format!("{tw:?}")]);
    }
    if let Some((lo, hi)) = args.free_time {
        w.extend(["--free-time".into(), format!("{lo:?}:{hi:?}")]);
    }
    w.extend(["--segments".into(), args.segments.to_string(), "--intervals".into(), args.intervals.to_string()]);
    if let Some(g) = &args.guess {
        w.extend(["--guess".into(), g.display().to_string()]);
    }
    w.extend(["--evaluations".into(), args.evaluations.to_string()]);
    if let Some(out) = &args.out {
        w.extend(["--out".into(), out.display().to_string()]);
    }
    if args.no_figures {
        w.push("--no-figures".into());
    }
    w.extend(opts.to_args());
    w.push("--report".into());
    let line = w.iter().map(|x| report::shell_quote(x)).collect::<Vec<_>>().join(" ");
    // a caller's objective (a Rust closure, a Python function) has no flag
    let mut line = match args.objective.as_ref().and_then(|o| o.user.as_ref()) {
        Some((name, _)) => format!(
            "{line}\n# the objective of the caller's own, {}, is not on this line: run as written, the command minimizes the effort",
            name.replace(['\n', '\r'], " ")
        ),
        None => line,
    };
    if !args.own_path.is_empty() {
        let names: Vec<String> = args.own_path.iter().map(|p| p.describe().replace(['\n', '\r'], " ")).collect();
        line.push_str(&format!(
            "\n# the path constraints of the caller's own ({}) are not on this line: run as written, the command leaves them out",
            names.join("; ")
        ));
    }
    line
}

/// A signal stopped the plan: the best inputs so far (where the planner
/// returned them) are written and the interruption says where.
fn interrupted(dir: &Path, tables: &[(&'static str, String)]) -> Error {
    let signal = crate::output::transaction::pending().unwrap_or(crate::output::transaction::Signal::Int);
    let written = crate::output::transaction::lock(dir).and_then(|_lock| {
        for (name, text) in tables {
            crate::output::transaction::write_atomically(&dir.join(name), text.as_bytes())?;
        }
        Ok(())
    });
    let kept = match (written, tables.is_empty()) {
        (Ok(()), false) => {
            format!("the best inputs so far (not verified, not optimal) are in {}", dir.join("plan.csv").display())
        }
        (Ok(()), true) => "nothing: the planner had no point yet".to_string(),
        (Err(e), _) => format!("the best inputs so far could not be written: {e}"),
    };
    Error::Transaction(TransactionError::Interrupted(Interrupted {
        signal,
        dir: dir.into(),
        t: None,
        doing: Some("planning".into()),
        kept: Some(kept),
    }))
}

/// `plan.csv`: one row per node, its time, each input's value and the
/// state there; after an objective of the caller's own, a first line
/// `# objective: ...` naming it and how its gradient was had.
fn plan_csv(names: &[String], m: &Maneuver) -> String {
    let mut head = vec!["t".to_string()];
    head.extend(names.iter().cloned());
    head.extend(m.names.iter().cloned());
    let mut text = match m.user_objective {
        Some(_) => format!(
            "# objective: {} = {} (its gradient {})\n",
            m.objective_name.replace(['\n', '\r'], " "),
            number(m.objective),
            m.objective_gradient.as_str()
        ),
        None => String::new(),
    };
    text.push_str(&record(head));
    for (k, t) in m.t.iter().enumerate() {
        let mut row = vec![number(*t)];
        row.extend(m.inputs.iter().map(|i| number(i.value[k])));
        row.extend(m.states.get(k).into_iter().flatten().map(|v| number(*v)));
        text.push_str(&record(row));
    }
    text
}

/// The status as one word: optimal, not_converged, infeasible.
fn status_word(s: &Status) -> &'static str {
    match s {
        Status::Optimal => "optimal",
        Status::NotConverged { .. } => "not_converged",
        Status::Infeasible { .. } => "infeasible",
    }
}

/// `plan_summary.csv`: one row, how the plan ended and each target
/// component's error at the verification run's end and the plan's.
fn summary_csv(m: &Maneuver) -> String {
    let mut head: Vec<String> = [
        "status",
        "t_end",
        "effort",
        "violation",
        "violated",
        "stationarity",
        "state_jump",
        "evaluations",
        "runs",
        "unknowns",
        "equalities",
        "inequalities",
        "path_excess",
        "path_excess_at",
        "objective",
        "objective_value",
        "objective_gradient",
    ]
    .map(str::to_string)
    .to_vec();
    let mut row = vec![
        status_word(&m.status).to_string(),
        number(m.t_end),
        number(m.effort),
        number(m.violation.0),
        m.violation.1.clone(),
        number(m.stationarity),
        number(m.state_jump.0),
        m.evaluations.to_string(),
        m.runs.to_string(),
        m.unknowns.to_string(),
        m.equalities.to_string(),
        m.inequalities.to_string(),
        m.verification.as_ref().map_or_else(|_| String::new(), |v| number(v.path_violation.0)),
        m.verification.as_ref().map_or_else(|_| String::new(), |v| v.path_violation.1.clone()),
        m.objective_name.clone(),
        number(m.objective),
        m.objective_gradient.as_str().to_string(),
    ];
    if let Ok(v) = &m.verification {
        for e in &v.errors {
            head.extend([
                format!("target_{}", e.name),
                format!("run_error_{}", e.name),
                format!("plan_error_{}", e.name),
            ]);
            row.extend([number(e.target), number(e.run), number(e.plan)]);
        }
    }
    let mut text = record(head);
    text.push_str(&record(row));
    text
}

/// The inputs over time (each linear between its nodes, marked).
fn inputs_chart(names: &[String], m: &Maneuver) -> Chart {
    let mut chart = Chart::new("The planned inputs", "t [s]", "input");
    for (name, table) in names.iter().zip(&m.inputs) {
        let points = m.t.iter().copied().zip(table.value.iter().copied()).collect();
        chart.series.push(Series { stroke: Stroke::Solid, ..Series::new(name.clone(), points) });
    }
    chart
}

/// Samples of the verification's run drawn in the path figure.
const PATH_SAMPLES: f64 = 400.0;

/// Poses of the vehicle drawn along the path (the start, the end and
/// the times between at equal intervals).
const POSES: usize = 4;

/// Each body's centre along the planned inputs' run (an ordinary run,
/// as the verification's), the nodes' states marked on the first body's,
/// and the vehicle at [`POSES`] + 1 times: each body a line from its
/// centre to each of its named points (a skate, a hinge); `None` where
/// the run fails (its failure is the verification's, in the report).
fn path_chart<M: Model>(build: &BuildInputs<M>, t_end: f64, m: &Maneuver, info: &ezy_core::ModelInfo) -> Option<Chart> {
    let problem = build(&m.inputs).ok()?.t_end(t_end).every(t_end / PATH_SAMPLES);
    let model = problem.model.clone();
    let s = problem.solve().ok()?;
    let mut chart = Chart::new("The planned path", "x [m]", "y [m]");
    chart.equal_axes = true;
    for b in &info.bodies {
        let (i, j) = (b.coords[0], b.coords[1]);
        let points = s.y.iter().map(|y| (y[i], y[j])).collect();
        chart.series.push(Series { stroke: Stroke::Solid, ..Series::new(b.name.to_string(), points) });
    }
    if let Some(b) = info.bodies.first() {
        let nodes = m.states.iter().map(|x| (x[b.coords[0]], x[b.coords[1]])).collect();
        chart.series.push(Series { stroke: Stroke::Points, ..Series::new(format!("{} at the nodes", b.name), nodes) });
    }
    if !info.points.is_empty() && s.y.len() > 1 {
        let nq = info.nq();
        let mut at = vec![0.0; 2 * info.points.len()];
        let mut lines = Vec::new();
        for k in 0..=POSES {
            let y = &s.y[k * (s.y.len() - 1) / POSES];
            model.points(&y[..nq], &mut at);
            for (p, point) in info.points.iter().enumerate() {
                let c = &info.bodies[point.body].coords;
                lines.extend([(y[c[0]], y[c[1]]), (at[2 * p], at[2 * p + 1]), (f64::NAN, f64::NAN)]);
            }
        }
        let label = format!("the vehicle every {} s", fmt_value(t_end / POSES as f64));
        chart.series.push(Series { stroke: Stroke::Pieces, ..Series::new(label, lines) });
    }
    Some(chart)
}

/// The text `ezy plan` prints (`inputs`: the inputs' names and the
/// shooting intervals).
fn summary(scene: &str, inputs: (&[String], usize), m: &Maneuver, files: &[PathBuf]) -> String {
    let (names, intervals) = inputs;
    let t_end = m.t.last().copied().unwrap_or(0.0);
    let status = match &m.status {
        Status::Optimal => "optimal".to_string(),
        Status::NotConverged { reason } => format!("not converged: {reason}"),
        Status::Infeasible { violation, constraint } => {
            format!("infeasible: the smallest violation found is {} ({constraint})", fmt_value(*violation))
        }
    };
    let mut s = format!(
        "scene {scene}: plan of {} over {} s on {} segments: {status}\n",
        names.join(", "),
        fmt_value(t_end),
        m.t.len().saturating_sub(1)
    );
    if let Some((lo, hi)) = m.free_time {
        let _ =
            writeln!(s, "duration (free within [{}, {}] s): {} s", fmt_value(lo), fmt_value(hi), fmt_value(m.t_end));
    }
    let _ = writeln!(s, "effort (sum of the integrals of the inputs squared): {}", fmt_value(m.effort));
    let _ = writeln!(
        s,
        "objective minimized: {} = {} (its gradient {})",
        m.objective_name,
        fmt_value(m.objective),
        m.objective_gradient.as_str()
    );
    let _ = writeln!(
        s,
        "largest violation {:.1e} ({}); stationarity {:.1e}{}; largest state jump at a node {:.1e}",
        m.violation.0,
        m.violation.1,
        m.stationarity,
        if m.signs_checked || m.stationarity > ezy_core::plan::STATIONARY {
            ""
        } else {
            " (the multipliers' signs not checked: undetermined at a vertex, or no constraint)"
        },
        m.state_jump.0
    );
    let _ = writeln!(s, "{}", m.termination);
    match &m.verification {
        Ok(v) => {
            let _ = writeln!(
                s,
                "verification (the planned inputs run over [0, {}] s, {} steps): largest end error {:.1e}, the plan's own {:.1e}",
                fmt_value(t_end),
                v.steps,
                v.max_run_error,
                v.max_plan_error
            );
            for e in &v.errors {
                let _ = writeln!(
                    s,
                    "  {} = {}: run {}, plan {}",
                    e.name,
                    fmt_value(e.target),
                    fmt_value(e.target + e.run),
                    fmt_value(e.target + e.plan)
                );
            }
            if m.inequalities > 0 {
                let _ = match v.path_violation.0 {
                    0.0 => writeln!(s, "  the path constraints hold over the run (8 samples per segment)"),
                    e => writeln!(
                        s,
                        "  the path constraints are exceeded between the nodes by up to {e:.1e} ({}; 8 samples per segment)",
                        v.path_violation.1
                    ),
                };
            }
        }
        Err(e) => {
            let _ = writeln!(s, "verification failed: {e}");
        }
    }
    let _ = writeln!(
        s,
        "{} evaluations, {} segment runs, {} unknowns, {} equalities, {} inequalities in {:.2} s ({}, SLSQP)",
        m.evaluations,
        m.runs,
        m.unknowns,
        m.equalities,
        m.inequalities,
        m.seconds,
        match intervals {
            1 => "direct single shooting".to_string(),
            m => format!("direct multiple shooting on {m} intervals"),
        }
    );
    for file in files {
        let _ = writeln!(s, "wrote {}", file.display());
    }
    s
}
