//! `ezy geometry [SCENE_OR_MODEL]`: the geometry of locomotion
//! ([`ezy_core::geometry`]) of a model with the plane's symmetry: its
//! local connection and constraint curvature on a grid of shapes (or at
//! one), its momentum equation, and a gait's net motion predicted against
//! simulated, as CSV tables and figures.

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::geometry::{Gait, GaitPrediction, Geometry, GeometryError, SimulatedGait};
use ezy_core::problem::Problem;
use ezy_core::{AnyModel, fmt_value};
use ezy_scene::{FigureFormat, Scene};

mod figures;
mod tables;

use super::committed;
use crate::app::scenes::is_scene_path;
use crate::app::{App, AppError, is_model_path};
use crate::cli::{parse_dpi, parse_figure_format, parse_set};
use crate::output::transaction::{OutLock, Transaction, check_interrupt, pending};
use crate::session::{Error, rounded, scene_analysis, with_sets};

/// The connection, momentum equation and constraint curvature of a model
/// with the plane's symmetry, on a grid of shapes or at one, and a gait's
/// net motion predicted against simulated: connection.csv,
/// curvature.csv, momentum.csv, gait.csv and figures.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct GeometryArgs {
    /// A scene (a known name, see `list`, or a .toml file: its model, its
    /// forces and its drives' gait) or a model (a known key or a .ezy
    /// file) [default: kinematic-snake].
    target: Option<String>,
    /// The reference body, whose frame is the position [default: the
    /// body at the middle of the hinge tree].
    #[arg(long, value_name = "BODY")]
    body: Option<String>,
    /// The shape coordinates: every hinge once, in this order [default:
    /// the model's hinges in order].
    #[arg(long, value_name = "HINGE[,HINGE..]", value_delimiter = ',')]
    shape: Vec<String>,
    /// One shape instead of a grid: every shape coordinate's angle [rad].
    #[arg(long, value_name = "NAME=VALUE[,..]")]
    at: Option<String>,
    /// Points of the grid along each shape coordinate (one or two
    /// coordinates).
    #[arg(long, value_name = "N", default_value_t = 41)]
    grid: usize,
    /// The grid's range along each shape coordinate [rad].
    #[arg(long, value_name = "LO:HI", default_value = "-2.5:2.5")]
    range: String,
    /// A gait of one period, t in [0, 2 pi]: NAME=EXPRESSION per shape
    /// coordinate, each a sum of constants and cos/sin(k*t + c)
    /// [default: the scene's drives, where they prescribe every shape
    /// coordinate periodically].
    #[arg(long, value_name = "NAME=EXPR[,..]")]
    gait: Option<String>,
    /// The momentum at the gait's start, per momentum component (p_u,
    /// p_v, p_w as the model has them) [default: the scene's initial
    /// state's, or 0].
    #[arg(long, value_name = "NAME=VALUE[,..]")]
    momentum: Option<String>,
    /// Tolerance (relative and absolute) of the gait's simulation
    /// (DOP853).
    #[arg(long, value_name = "TOL", default_value_t = 1e-10)]
    rtol: f64,
    /// Override a model parameter (--set l=0.5).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Output directory [default: out/geometry/NAME].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw the figures.
    #[arg(long)]
    no_figures: bool,
    /// File format of the figures: png, svg or pdf [default: the scene's,
    /// else png].
    #[arg(long, value_name = "FORMAT", value_parser = parse_figure_format)]
    format: Option<FigureFormat>,
    /// Resolution of PNG figures [dpi] [default: the scene's, else 144].
    #[arg(long, value_name = "DPI", value_parser = parse_dpi)]
    dpi: Option<f64>,
}

/// The arguments of `ezy geometry`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    GeometryArgs::augment_args(cmd)
}

/// Most grid points along one shape coordinate.
const MAX_GRID: usize = 501;

/// What `ezy geometry` is asked, resolved.
struct Request {
    /// The scene or model's name (the output directory's default).
    name: String,
    /// The scene, when one was named.
    scene: Option<Scene>,
    /// The arguments.
    args: GeometryArgs,
    /// The grid's range \[rad\].
    range: (f64, f64),
    /// Output directory.
    out: PathBuf,
    /// Figure format and resolution.
    look: (FigureFormat, f64),
}

/// Runs `ezy geometry` and prints what it found.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = GeometryArgs::from_arg_matches(args)?;
    let target = args.target.clone().unwrap_or_else(|| "kinematic-snake".into());
    // a scene by name or path first; a model key or .ezy file otherwise
    let model_only = is_model_path(&target)
        || (!is_scene_path(&target) && app.named_scene(Some(&target)).is_err() && app.model_for(&target).is_some());
    let (name, scene, key) = if model_only {
        {
            let stem = std::path::Path::new(&target)
                .file_stem()
                .map_or_else(|| target.clone(), |s| s.to_string_lossy().into_owned());
            (stem, None, target.clone())
        }
    } else {
        let (_, src) = app.named_scene(Some(&target))?;
        let key = src.scene.model.clone();
        (src.scene.name.clone(), Some(src.scene), key)
    };
    let range = parse_range(&args.range).map_err(AppError::Failed)?;
    if !(2..=MAX_GRID).contains(&args.grid) {
        return Err(AppError::Failed(format!(
            "--grid {}: from 2 to {MAX_GRID} points along each shape coordinate",
            args.grid
        )));
    }
    if !(args.rtol.is_finite() && (1e-14..=1e-2).contains(&args.rtol)) {
        return Err(AppError::Failed(format!("--rtol {}: a tolerance from 1e-14 to 1e-2", args.rtol)));
    }
    let look = match &scene {
        Some(s) => (args.format.unwrap_or(s.output.figure_format), args.dpi.unwrap_or(s.output.dpi)),
        None => (args.format.unwrap_or(FigureFormat::Png), args.dpi.unwrap_or(ezy_scene::DEFAULT_DPI)),
    };
    let out_dir = args.out.clone().unwrap_or_else(|| PathBuf::from("out").join("geometry").join(&name));
    let model = app.model_or_error(&key)?;
    let req = Request { name, scene, args, range, out: out_dir, look };
    let text = geometry(&model, &req).map_err(AppError::from_run)?;
    committed(out, &text, &req.out)
}

/// `LO:HI` with LO < HI, both finite and at most 1e3 in size.
fn parse_range(text: &str) -> Result<(f64, f64), String> {
    let bad = || format!("--range `{text}`: write LO:HI in radians, LO < HI, each at most 1000 in size");
    let (lo, hi) = text.split_once(':').ok_or_else(bad)?;
    let (lo, hi): (f64, f64) = (lo.trim().parse().map_err(|_| bad())?, hi.trim().parse().map_err(|_| bad())?);
    if lo.is_finite() && hi.is_finite() && lo < hi && lo.abs() <= 1e3 && hi.abs() <= 1e3 {
        Ok((lo, hi))
    } else {
        Err(bad())
    }
}

/// `NAME=VALUE,...` giving every one of `names` once.
fn parse_values(flag: &str, text: &str, names: &[String]) -> Result<Vec<f64>, Error> {
    let bad = |m: String| Error::Input(format!("{flag} `{text}`: {m}"));
    let mut values = vec![None; names.len()];
    for part in text.split(',').filter(|p| !p.trim().is_empty()) {
        let (n, v) = part.split_once('=').ok_or_else(|| bad(format!("`{part}` is not NAME=VALUE")))?;
        let k = names
            .iter()
            .position(|x| x == n.trim())
            .ok_or_else(|| bad(format!("`{}` is not one of {}", n.trim(), names.join(", "))))?;
        let v: f64 = v.trim().parse().map_err(|_| bad(format!("`{}` is not a number", v.trim())))?;
        if !v.is_finite() || v.abs() > 1e6 {
            return Err(bad(format!("{} = {v}: a finite number at most 1e6 in size", names[k])));
        }
        if values[k].replace(v).is_some() {
            return Err(bad(format!("`{}` is given twice", names[k])));
        }
    }
    values.into_iter().enumerate().map(|(k, v)| v.ok_or_else(|| bad(format!("`{}` is not given", names[k])))).collect()
}

/// A geometry error as the command's error, `dir` the output directory
/// (a stop by a signal is the run's interruption there).
fn input(dir: &std::path::Path) -> impl Fn(GeometryError) -> Error + '_ {
    move |e| match e {
        GeometryError::Sim(e) => Error::Sim(e),
        GeometryError::Stopped => match check_interrupt(dir, None, Some("the gait".into())) {
            Err(i) => Error::Transaction(i),
            Ok(()) => Error::Input(e.to_string()),
        },
        e => Error::Input(e.to_string()),
    }
}

/// Everything `ezy geometry` computed.
pub(super) struct Found {
    /// The shapes evaluated (grid or one).
    pub shapes: Vec<Vec<f64>>,
    /// The grid's axes (empty at one shape).
    pub axes: Vec<Vec<f64>>,
    /// Per shape: the curvature (its connection inside), or why none.
    pub curvature: Vec<Result<ezy_core::geometry::Curvature, String>>,
    /// Per shape: the momentum equation's terms (mixed systems).
    pub momentum: Vec<Vec<ezy_core::geometry::MomentumTerm>>,
    /// The gait, its prediction and its simulation (or why none).
    pub gait: Option<(Gait, GaitPrediction, Result<SimulatedGait, String>)>,
    /// Seconds the grid took.
    pub seconds: f64,
    /// Seconds the gait's prediction took (first and second order and
    /// the reconstruction).
    pub predicted_in: f64,
}

/// `ezy geometry` on `proto`: computes, writes, and returns the summary.
fn geometry(proto: &AnyModel, req: &Request) -> Result<String, Error> {
    let args = &req.args;
    // the model at the scene's parameters and the overrides
    let (model, scene_problem) = match &req.scene {
        Some(scene) => {
            let (problem, _) = scene.problem_with(proto.clone(), &args.sets)?;
            (problem.model.clone(), Some(problem))
        }
        None => (with_sets(proto, &args.sets).map_err(Error::Input)?, None),
    };
    let shape = (!args.shape.is_empty()).then_some(&args.shape[..]);
    let mut geo = Geometry::new(model.clone(), args.body.as_deref(), shape).map_err(|e| match e {
        // the counts a model's size comes from, as the command line set them
        GeometryError::Request { reason } if reason.contains("bodies and") && !args.sets.is_empty() => {
            let sets: Vec<String> = args.sets.iter().map(|(n, v)| format!("{n}={}", fmt_value(*v))).collect();
            Error::Input(format!("--set {}: {reason}", sets.join(" --set ")))
        }
        e => input(&req.out)(e),
    })?;
    geo.stop_when(|| pending().is_some());
    let names = geo.shape_names();
    let ns = names.len();
    // the scene's forces and initial momentum
    let mut p0 = vec![0.0; geo.n_momentum()];
    let mut notes = Vec::new();
    if let Some(scene) = &req.scene {
        let (mut an, x0) = scene_analysis(proto, scene, &args.sets)?;
        let nq = an.nq();
        let sliding: Vec<&str> = an.dynamics().friction.iter().map(|f| f.name.as_str()).collect();
        if !sliding.is_empty() {
            notes.push(format!(
                "skate(s) {} have Coulomb friction in scene {}: the connection and the momentum equation take every skate as holding, the simulation lets them slide, so the two part where a skate slides",
                sliding.join(", "),
                scene.name
            ));
        }
        if geo.n_momentum() > 0 {
            let sym = an.symmetry(0.0, &x0).map_err(|e| Error::Input(e.to_string()))?;
            if !(sym.translate_x && sym.translate_y && sym.rotate) {
                return Err(Error::Input(format!(
                    "scene {}: its forces change under the plane's motions (invariant under translation along x: {}, along y: {}, rotation: {}), so its momentum equation depends on the position too; analyse the model alone (`ezy geometry {}`)",
                    scene.name, sym.translate_x, sym.translate_y, sym.rotate, scene.model
                )));
            }
            p0 = geo.momentum(&x0[..nq], &x0[nq..]).map_err(input(&req.out))?;
        }
        geo = geo.with_forces(an).map_err(input(&req.out))?;
    }
    if let Some(text) = &args.momentum {
        p0 = parse_values("--momentum", text, &geo.momentum_names())?;
    }
    // the shapes: one, or a grid of one or two coordinates
    let (shapes, axes) = match &args.at {
        Some(text) => (vec![parse_values("--at", text, &names)?], Vec::new()),
        None if ns == 0 => (vec![Vec::new()], Vec::new()),
        None if ns <= 2 => {
            let n = args.grid;
            let axis: Vec<f64> =
                (0..n).map(|i| req.range.0 + (req.range.1 - req.range.0) * i as f64 / (n - 1) as f64).collect();
            let shapes = if ns == 1 {
                axis.iter().map(|a| vec![*a]).collect()
            } else {
                axis.iter().flat_map(|a| axis.iter().map(move |b| vec![*a, *b])).collect()
            };
            (shapes, vec![axis; ns])
        }
        None => {
            return Err(Error::Input(format!(
                "the model has {ns} shape coordinates ({}): a grid is drawn over one or two; give one shape with --at",
                names.join(", ")
            )));
        }
    };
    // a gait given is read before any work
    let given = args.gait.as_ref().map(|text| Gait::parse(&names, text)).transpose().map_err(input(&req.out))?;
    // the directory is this command's from here to the commit
    let held = OutLock::take(&req.out)?;
    let start = Instant::now();
    let mut curvature = Vec::with_capacity(shapes.len());
    let mut momentum = Vec::new();
    for (i, r) in shapes.iter().enumerate() {
        if i % 64 == 0 {
            check_interrupt(&req.out, None, Some("the shape grid".into()))?;
        }
        let c = if ns >= 2 {
            geo.curvature(r)
        } else {
            geo.connection(r).map(|c| ezy_core::geometry::Curvature {
                connection: c,
                da: Vec::new(),
                height: Vec::new(),
            })
        };
        let c = c.map_err(|e| e.to_string());
        if geo.n_momentum() > 0 {
            momentum.push(if c.is_ok() { geo.momentum_equation(r).map_err(input(&req.out))? } else { Vec::new() });
        }
        curvature.push(c);
    }
    let seconds = start.elapsed().as_secs_f64();
    // the gait
    let gait = match given {
        Some(g) => Some(g),
        None => scene_problem.as_ref().and_then(|p| scene_gait(&geo, p, &mut notes)),
    };
    let mut predicted_in = 0.0;
    let gait = match gait {
        Some(g) => {
            check_interrupt(&req.out, None, Some("the gait's prediction".into()))?;
            let start = Instant::now();
            let prediction = geo.predict(&g, &p0).map_err(input(&req.out))?;
            predicted_in = start.elapsed().as_secs_f64();
            let problem = match scene_problem.clone() {
                Some(mut p) => {
                    p.given = Default::default();
                    p.events.clear();
                    p
                }
                None => Problem::new(model.clone()),
            };
            let simulated = match geo.simulate(&g, problem, &p0, args.rtol) {
                Err(GeometryError::Stopped) => return Err(input(&req.out)(GeometryError::Stopped)),
                r => r.map_err(|e| e.to_string()),
            };
            Some((g, prediction, simulated))
        }
        None => None,
    };
    let found = Found { shapes, axes, curvature, momentum, gait, seconds, predicted_in };
    let mut tx = Transaction::begin_locked(held)?;
    tables::write(&mut tx, &geo, &found)?;
    if !args.no_figures {
        figures::draw(&mut tx, &geo, &found, req.look, &req.out, &mut notes)?;
    }
    let files = tx.commit()?;
    Ok(summary(&req.name, &geo, &found, &notes, &files))
}

/// The scene's gait: its drives on every shape hinge, periodic with one
/// common period. `None` (with a note) otherwise.
fn scene_gait(geo: &Geometry<AnyModel>, problem: &Problem<AnyModel>, notes: &mut Vec<String>) -> Option<Gait> {
    use ezy_core::effects::Periodicity;
    let info = geo.info();
    if geo.n_shape() == 0 {
        notes.push("no gait: the model has no hinge, so no shape to move".into());
        return None;
    }
    let mut shape = Vec::new();
    for &h in geo.shape_hinges() {
        let Some(d) = info.drives.iter().find(|d| d.hinge == h) else {
            notes.push(format!(
                "no gait: hinge `{}` has no drive in the model (give one with --gait to predict it)",
                info.hinges[h].name
            ));
            return None;
        };
        let Some(given) = problem.drives.iter().find(|x| x.name == d.name) else {
            notes.push(format!("no gait: the scene does not prescribe drive `{}`", d.name));
            return None;
        };
        shape.push(given.angle.clone());
    }
    match Periodicity::combine(shape.iter().map(|w| w.periodicity())) {
        Periodicity::Period(t) => Gait::new(shape, t).ok(),
        Periodicity::Constant => {
            notes.push("no gait: the scene's drives hold the shape still (give one with --gait)".into());
            None
        }
        Periodicity::Aperiodic => {
            notes.push("no gait: the scene's drives do not repeat with a common period (give one with --gait)".into());
            None
        }
    }
}

/// The text `ezy geometry` prints.
fn summary(name: &str, geo: &Geometry<AnyModel>, f: &Found, notes: &[String], files: &[PathBuf]) -> String {
    let mut s = String::new();
    let names = geo.shape_names();
    let kind = if geo.is_kinematic() {
        "kinematic: the skates fix the body velocity, xi = -A(r) r'".to_string()
    } else {
        format!(
            "mixed: {} momentum component(s) {} along the directions the skates leave free, xi = -A(r) r' + Gamma(r) p",
            geo.n_momentum(),
            geo.momentum_names().join(", ")
        )
    };
    let _ = writeln!(
        s,
        "{name}: position = frame of body `{}`, shape = ({}); {kind}",
        geo.body_name(),
        if names.is_empty() { "none".into() } else { names.join(", ") }
    );
    let singular = f.curvature.iter().filter(|c| c.is_err()).count();
    let _ = writeln!(
        s,
        "{} shape(s) in {} s{}",
        f.shapes.len(),
        rounded(f.seconds),
        if singular > 0 {
            format!(
                "; {singular} on the singular set, where the skates cannot fix the body velocity (left out of the tables)"
            )
        } else {
            String::new()
        }
    );
    if let (1, Some(Ok(c))) = (f.shapes.len(), f.curvature.first()) {
        let ns = names.len();
        for (row, comp) in ["u", "v", "w"].iter().enumerate() {
            let cells: Vec<String> = (0..ns).map(|k| fmt_value(c.connection.a[row * ns + k])).collect();
            if ns > 0 {
                let _ = writeln!(s, "  A[{comp}] = [{}]", cells.join(", "));
            }
        }
        let pairs = (0..ns).flat_map(|i| (i + 1..ns).map(move |j| (i, j)));
        for ((i, j), h) in pairs.zip(&c.height) {
            let _ = writeln!(
                s,
                "  D(-A) over ({}, {}): x {}, y {}, theta {}",
                names[i],
                names[j],
                fmt_value(h[0]),
                fmt_value(h[1]),
                fmt_value(h[2])
            );
        }
    }
    if let Some((g, p, sim)) = &f.gait {
        let _ = writeln!(
            s,
            "gait of period {} s (rank margin at least {} along it), predicted in {} s; net motion per cycle in the initial body frame (dx [m], dy [m], dtheta [rad]):",
            fmt_value(g.period),
            rounded(p.rank_margin),
            rounded(f.predicted_in)
        );
        let row = |label: &str, v: &[f64; 3]| {
            format!("  {label:<14} {:>12} {:>12} {:>12}\n", rounded(v[0]), rounded(v[1]), rounded(v[2]))
        };
        s.push_str(&row("first order", &p.first));
        if let Some(second) = &p.second {
            s.push_str(&row("second order", second));
        }
        s.push_str(&row("reconstructed", &p.reconstructed));
        match sim {
            Ok(sim) => {
                s.push_str(&row("simulated", &sim.net));
                let gap = (0..3).map(|i| (sim.net[i] - p.reconstructed[i]).abs()).fold(0.0, f64::max);
                let _ = writeln!(s, "  reconstructed against simulated: {gap:.1e} at most");
            }
            Err(e) => {
                let _ = writeln!(s, "  not simulated: {e}");
            }
        }
    }
    for n in notes {
        let _ = writeln!(s, "note: {n}");
    }
    for file in files {
        let _ = writeln!(s, "wrote {}", file.display());
    }
    s
}
