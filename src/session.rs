//! What the commands share: the options of a run ([`RunOptions`]: a
//! scene's settings overridden from the command line), the settings and
//! the problem they give, what a run reports ([`Report`], [`Error`]) and
//! the summary `ezy run` prints, the command line that reruns a run; and,
//! for the analyses, a scene's [`Analysis`] and the states of its run.
//! The commands meet here instead of importing each other; the run itself
//! is the crate's `run` module.

use std::path::PathBuf;
use std::time::Duration;

use ezy_core::analysis::{Analysis, AnalysisError, c64};
use ezy_core::{Baumgarte, Method, Model, Problem, ProjectionKind, RunSettings, SetupError, SimError, Summary};
use ezy_scene::{FigureFormat, Scene};

use crate::output::csv::{OutputError, Table};
use crate::output::transaction::{Interrupted, Transaction, TransactionError};
use crate::render::figures::FigureError;
use crate::render::report::shell_quote;

/// Everything that can stop `ezy run`.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Setup or numerics.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Writing the table.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Drawing a figure.
    #[error(transparent)]
    Figure(#[from] FigureError),
    /// Locking, writing or committing the output, or a signal that stopped
    /// the run.
    #[error(transparent)]
    Transaction(#[from] TransactionError),
    /// A scene names a model the registry does not have.
    #[error("scene `{scene}` names unknown model `{model}`")]
    UnknownModel {
        /// Scene name.
        scene: String,
        /// Model key.
        model: String,
    },
    /// A file the command reads besides the scene (the `precision.csv`
    /// that `ezy precision --replot` redraws) is missing or bad, the
    /// message naming the file and the flag that asked for it; or the
    /// figures' format is one this build cannot write (PDF without the
    /// `pdf` feature), named before any work.
    #[error("{0}")]
    Input(String),
    /// The caller's stop hook ended an in-memory run between two steps
    /// ([`crate::App::run_scene_in_memory`]: a notebook's interrupt).
    #[error("the run was stopped at t = {t} s: {reason}")]
    Stopped {
        /// The time the run had reached \[s\].
        t: f64,
        /// What the hook said.
        reason: String,
    },
    /// The output directory cannot be created.
    #[error("cannot create output directory {path}: {source}")]
    OutDir {
        /// The directory.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl Error {
    /// The interruption, if a signal stopped the run.
    pub fn interrupted(&self) -> Option<&Interrupted> {
        match self {
            Self::Transaction(TransactionError::Interrupted(i))
            | Self::Output(OutputError::Transaction(TransactionError::Interrupted(i))) => Some(i),
            _ => None,
        }
    }
}

/// Overrides of a scene's settings, from the command line.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output directory.
    pub out: PathBuf,
    /// `NAME=VALUE` overrides of scene parameters, model parameters or
    /// effect numbers (`EFFECT.KEY`, see [`Scene::set`]).
    pub sets: Vec<(String, f64)>,
    /// Step size \[s\].
    pub dt: Option<f64>,
    /// Duration \[s\].
    pub t_end: Option<f64>,
    /// Output interval \[s\].
    pub every: Option<f64>,
    /// Projection kind.
    pub projection: Option<ProjectionKind>,
    /// Integration method.
    pub method: Option<Method>,
    /// Formulation (DAE or reduced).
    pub formulation: Option<ezy_core::Formulation>,
    /// Baumgarte stabilization.
    pub baumgarte: Option<Baumgarte>,
    /// Relative tolerance (adaptive methods).
    pub rtol: Option<f64>,
    /// Absolute tolerance (adaptive methods).
    pub atol: Option<f64>,
    /// Draw the scene's figures.
    pub figures: bool,
    /// File format of the figures (`None`: the scene's `output.figure_format`).
    pub figure_format: Option<ezy_scene::FigureFormat>,
    /// Resolution of PNG figures \[dpi\] (`None`: the scene's `output.dpi`).
    pub dpi: Option<f64>,
    /// Also write `report.html`: the summary, the energy ledger, an
    /// animation, every figure and the command line that reruns the run.
    pub report: bool,
    /// Show progress on stderr for long runs (a bar on a terminal, a line
    /// every few seconds otherwise).
    pub progress: bool,
    /// Most step attempts the run may take (`None`: the scene's, by default
    /// [`ezy_core::settings::DEFAULT_MAX_STEPS`]).
    pub max_steps: Option<u64>,
    /// Largest estimated size of `trajectory.csv` \[MB\] (`None`:
    /// [`DEFAULT_MAX_OUTPUT_MB`]).
    pub max_output_mb: Option<f64>,
    /// The scene file the run was given, as its command line gave it
    /// (`None`: a known scene by name): the report's command line names it
    /// (`command_line`).
    pub scene_file: Option<String>,
}

impl RunOptions {
    /// The figures' format and resolution \[dpi\] for `scene`: these
    /// options' where given, else the scene's `[output]`.
    pub fn look(&self, scene: &Scene) -> (ezy_scene::FigureFormat, f64) {
        (self.figure_format.unwrap_or(scene.output.figure_format), self.dpi.unwrap_or(scene.output.dpi))
    }

    /// The overrides as `ezy run` flags that parse back to them (what a
    /// sweep's manifest records, a Slurm script passes on, and the Python
    /// package's `sweep` hands to the command line): `--set`, the step,
    /// duration, interval and tolerances, the resolution, projection,
    /// Baumgarte, formulation, integrator, step budget and figure format.
    /// The output directory, `figures`, `report`, `progress` and
    /// `max_output_mb` are not overrides of the scene and are left out.
    pub fn to_args(&self) -> Vec<String> {
        let mut a = Vec::new();
        for (name, v) in &self.sets {
            a.push("--set".into());
            a.push(format!("{name}={v:?}"));
        }
        let mut num = |flag: &str, v: Option<f64>| {
            if let Some(v) = v {
                a.push(flag.into());
                a.push(format!("{v:?}"));
            }
        };
        num("--dt", self.dt);
        num("--t-end", self.t_end);
        num("--every", self.every);
        num("--rtol", self.rtol);
        num("--atol", self.atol);
        num("--dpi", self.dpi);
        if let Some(p) = self.projection {
            a.extend(["--projection".into(), p.name().into()]);
        }
        if let Some(b) = self.baumgarte {
            a.extend(["--baumgarte".into(), format!("{:?},{:?}", b.alpha, b.beta)]);
        }
        if let Some(f) = self.formulation {
            a.extend(["--formulation".into(), f.name().into()]);
        }
        if let Some(m) = self.method {
            a.extend(["--integrator".into(), m.name().into()]);
        }
        if let Some(n) = self.max_steps {
            a.extend(["--max-steps".into(), n.to_string()]);
        }
        if let Some(f) = self.figure_format {
            a.extend(["--format".into(), f.name().into()]);
        }
        a
    }
}

/// Default cap on the estimated size of `trajectory.csv`: 1000 MB (the
/// `drive` scene writes 1.6 MB).
pub const DEFAULT_MAX_OUTPUT_MB: f64 = 1000.0;

/// Bytes one CSV value takes at most: its shortest round-trip form (up to
/// 24 characters, [`crate::output::csv::format_number`]) and a separator.
pub(crate) const BYTES_PER_VALUE: f64 = crate::output::csv::BYTES_PER_NUMBER as f64;

/// What a run produced.
#[derive(Debug, Clone)]
pub struct Report {
    /// The step loop's summary.
    pub summary: Summary,
    /// The trajectory table.
    pub table: Table,
    /// Settings used.
    pub settings: RunSettings,
    /// Names of the state components `y = [q, qd, W_1 .. W_k]`.
    pub state_names: Vec<String>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Wall time of the setup: the scene's overrides, the model, its
    /// effects, the consistent initial state, the KKT path's analysis and
    /// the output files' creation (everything before the first step).
    pub setup: Duration,
    /// Wall time of the whole run (setup, integration, output, figures).
    pub wall: Duration,
    /// Warnings (corrections of the initial values).
    pub warnings: Vec<String>,
    /// Notes (the assembly branch taken from starting values).
    pub notes: Vec<String>,
}

/// The settings of a run of `scene` with the overrides of `opts`
/// (duration, step, tolerances, method, projection, step budget).
///
/// # Errors
/// [`SetupError::Setting`] naming the flag of a bad override (`--rtol`),
/// or a setting the scene and overrides make invalid together.
pub(crate) fn settings(scene: &Scene, opts: &RunOptions) -> Result<RunSettings, SimError> {
    for (flag, name, value) in [
        ("--dt", "dt", opts.dt),
        ("--t-end", "t_end", opts.t_end),
        ("--every", "every", opts.every),
        ("--rtol", "rtol", opts.rtol),
        ("--atol", "atol", opts.atol),
    ] {
        if let Some(v) = value
            && let Some(reason) = RunSettings::reject(name, v)
        {
            return Err(SimError::Setup(SetupError::Setting { name: flag.into(), value: v, reason }));
        }
    }
    let base = scene.run_settings();
    let settings = RunSettings {
        max_steps: opts.max_steps.or(base.max_steps),
        dt: opts.dt.unwrap_or(base.dt),
        t_end: opts.t_end.unwrap_or(base.t_end),
        every: opts.every.unwrap_or(base.every),
        projection: opts.projection.unwrap_or(base.projection),
        method: opts.method.unwrap_or(base.method),
        formulation: opts.formulation.unwrap_or(base.formulation),
        rtol: opts.rtol.unwrap_or(base.rtol),
        atol: opts.atol.unwrap_or(base.atol),
        ..base
    };
    settings.validate()?;
    scene
        .check_drives_cover(settings.t_end)
        .map_err(|e| SimError::Setup(SetupError::Scene { key: e.key(), message: e.message }))?;
    Ok(settings)
}

/// The problem `scene` describes for `proto` (a model at its defaults) with the overrides of
/// `opts` (`--set`, `--baumgarte`) and the run's `settings` (from
/// [`settings`]), and the scene as run (overrides applied, families
/// expanded). `ezy run`, `ezy animate` and every run of `ezy sweep` start
/// here, so a sweep's run is the single run, number for number.
///
/// # Errors
/// As [`ezy_scene::Scene::problem`]; a fixed step the scene's effects
/// refuse ([`Problem::check_fixed_step`]), before any work.
pub(crate) fn problem<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    settings: RunSettings,
) -> Result<(Problem<M>, Scene), SimError> {
    let (mut problem, scene) = scene.problem_with(proto.clone(), &opts.sets)?;
    problem.settings = settings;
    problem.baumgarte = opts.baumgarte;
    problem.check_fixed_step()?;
    Ok((problem, scene))
}

/// Checks, before a command that runs the scene takes its output
/// directory, that the run can be set up with the settings of `opts`
/// (as [`problem`]: a fixed step the scene's effects refuse, a bad
/// override), so that such a refusal writes nothing.
///
/// # Errors
/// As [`settings`] and [`problem`].
pub(crate) fn check_run<M: Model>(proto: &M, scene: &Scene, opts: &RunOptions) -> Result<(), Error> {
    problem(proto, scene, opts, settings(scene, opts)?)?;
    Ok(())
}

/// Elements of a model's families (the sum of its counts) from which a
/// run's setup may take seconds and gets a heartbeat: the snake's setup
/// takes 0.03 s at 1,000 links, 0.45 s at 10,000 and 6.7 s at 100,000
/// (the guide's "Scale" chapter, 2 cores), and the heartbeat's first line comes
/// after the progress display's first interval (5 s); below it the thread's start and
/// join (about 0.3 ms) would be a tenth of a small run's whole process.
pub const LONG_SETUP_ELEMENTS: f64 = 1000.0;

/// Whether setting `scene` up on `proto` (a model at its defaults) with the overrides `sets` may
/// take long: its family counts (the model's defaults, the scene's
/// `[params]`, then `sets`, the last value of each winning) sum to at
/// least [`LONG_SETUP_ELEMENTS`]. A value the setup will refuse counts as
/// it is; the answer only decides whether a heartbeat thread is started.
pub fn setup_may_be_long<M: Model>(proto: &M, scene: &Scene, sets: &[(String, f64)]) -> bool {
    let model = proto.clone();
    let info = model.info();
    let elements: f64 = (info.params.iter().enumerate())
        .filter(|(_, p)| p.count)
        .map(|(i, p)| {
            let given = sets.iter().rev().chain(scene.params.iter().rev()).find(|(name, _)| name == p.name);
            given.map_or(model.param(i), |(_, v)| *v)
        })
        .sum();
    elements >= LONG_SETUP_ELEMENTS
}

/// A caller's hook, asked after every accepted step with the time reached
/// \[s\] whether to stop an in-memory run ([`crate::App::run_scene_in_memory`]):
/// `Some(reason)` stops it with [`Error::Stopped`]. It is called often
/// (every step): a hook that costs more than a comparison should look at
/// the clock and do its work every few milliseconds only.
pub type StopHook<'a> = &'a mut dyn FnMut(f64) -> Option<String>;

/// Refuses a run whose `trajectory.csv` would exceed `max_mb` \[MB\]:
/// rows (one per output interval, plus the first and the last) times
/// `columns` values of at most [`BYTES_PER_VALUE`] bytes.
///
/// # Errors
/// [`SimError::Budget`] with the estimate and the flag that raises the cap.
pub(crate) fn output_budget(settings: &RunSettings, columns: usize, max_mb: f64) -> Result<(), SimError> {
    let rows = settings.output_rows();
    let mb = rows * columns as f64 * BYTES_PER_VALUE / 1e6;
    if mb > max_mb {
        return Err(SimError::Budget {
            what: "MB of output",
            estimate: mb,
            limit: max_mb,
            setting: ezy_core::Setting::MaxOutputMb,
            detail: format!("{rows:.2e} rows of {columns} columns in trajectory.csv").replace(".00e", "e"),
        });
    }
    Ok(())
}

/// `v` as Rust prints it when that is short (`0.0001`, `60`), else in
/// scientific notation (`1e-15`, `1e-320`, not hundreds of digits).
fn short(v: f64) -> String {
    let plain = format!("{v}");
    if plain.len() <= 12 { plain } else { format!("{v:e}") }
}

/// At most this many state components in the summary's final state (the
/// 30-link snake's 268 are all printed; a family of 10,000 links is not).
pub const SUMMARY_STATES: usize = 300;

/// At most this many events listed in the summary (all are in `events.csv`).
pub(crate) const SUMMARY_EVENTS: usize = 10;

/// The summary `run` prints: method and steps, RHS evaluations and times,
/// residuals, the energy balance, the final state and the files written.
pub fn summary(scene: &str, r: &Report) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let s = &r.summary;
    let t = s.integration_time.as_secs_f64();
    let how = if s.method.is_adaptive() {
        format!(
            "{} steps ({} rejected), rtol = {:e}, atol = {:e}",
            s.steps, s.rejected, r.settings.rtol, r.settings.atol
        )
    } else {
        // one shortened step when the step is longer than the run
        format!("{} steps of h = {} s", s.steps, short(r.settings.dt.min(r.settings.t_end)))
    };
    let kept = if s.minimal_coordinates {
        // no KKT system: Maggi's equations in the independent speeds
        let fused = if s.fused_rhs { ", fused right-hand side" } else { "" };
        format!(
            "reduced formulation on the minimal coordinates model! derived (no projection, Maggi's equations{fused})"
        )
    } else if s.formulation == ezy_core::Formulation::Reduced {
        format!("reduced formulation ({} re-partitions, no projection), {} KKT path", s.repartitions, s.kkt)
    } else {
        format!("projection {} ({}), {} KKT path", r.settings.projection.name(), s.projection_path, s.kkt)
    };
    // which formulation auto (the default) took, and that it chose
    let kept = if r.settings.formulation == ezy_core::Formulation::Auto { format!("{kept} (auto)") } else { kept };
    // the DAE's turns while a skate slid (or past a singular position)
    let kept = match s.handovers {
        0 => kept,
        n => format!("{kept}; {n} hand-overs to and from the DAE"),
    };
    let _ = writeln!(out, "{scene}: {} {how} to t = {} s, {kept}", s.method.name(), short(r.settings.t_end));
    let _ = writeln!(
        out,
        "  RHS evaluations {}, integration {:.3} s ({:.0} ns per RHS incl. projection), output {:.3} s, setup {:.3} s, whole run {:.3} s",
        s.counters.rhs_evals,
        t,
        t / s.counters.rhs_evals.max(1) as f64 * 1e9,
        s.output_time.as_secs_f64(),
        r.setup.as_secs_f64(),
        r.wall.as_secs_f64()
    );
    if s.method == Method::Radau5 {
        let n = &s.newton;
        let _ = writeln!(
            out,
            "  Newton iterations {} ({:.1} per step), Jacobians {}, LU factorizations {} (each a real and a complex one)",
            n.newton_iterations,
            n.newton_iterations as f64 / s.steps.max(1) as f64,
            n.jacobians,
            n.factorizations
        );
    }
    let _ = writeln!(
        out,
        "  max residuals |C| = {:.2e} m, |G qd| = {:.2e} m/s (largest drift of one step before projection {:.2e} m)",
        s.max_residual_position, s.max_residual_velocity, s.max_step_drift
    );
    let _ = writeln!(out, "  max |T - T0 - W| = {:.3e} J", s.max_energy_error);
    if !s.events.is_empty() {
        let listed: Vec<String> = s
            .events
            .iter()
            .take(SUMMARY_EVENTS)
            .map(|e| format!("{} {} at t = {:.9} s", e.name, if e.rising { "rising" } else { "falling" }, e.t))
            .collect();
        let more = match s.events.len().saturating_sub(SUMMARY_EVENTS) {
            0 => String::new(),
            n => format!(" and {n} more"),
        };
        let _ = writeln!(out, "  events ({}): {}{more} (events.csv)", s.events.len(), listed.join(", "));
    }
    if let Some((name, t)) = &s.stopped {
        let _ = writeln!(out, "  stopped by the event {name} at t = {t:.9} s");
    }
    // a family of thousands of links: the first components, the rest in the CSV
    let shown = s.final_state.len().min(SUMMARY_STATES);
    let state: Vec<String> =
        r.state_names.iter().zip(&s.final_state).take(shown).map(|(n, v)| format!("{n} = {v:.9}")).collect();
    let more = match s.final_state.len() - shown {
        0 => String::new(),
        n => format!(" and {n} more (the last row of trajectory.csv)"),
    };
    let _ = writeln!(out, "  final state: {}{more}", state.join(", "));
    for f in &r.files {
        let _ = writeln!(out, "  wrote {}", f.display());
    }
    out
}

/// The command line that reruns `scene` with `opts`: the scene by name,
/// or the scene file the run was given ([`RunOptions::scene_file`]),
/// quoted for a shell; then every setting the run was given (the page
/// also shows the scene after the `--set` overrides).
pub(crate) fn command_line(scene: &str, opts: &RunOptions) -> String {
    let scene = match opts.scene_file.clone() {
        // a relative path that starts like a flag stays a path
        Some(f) if f.starts_with('-') => format!("./{f}"),
        Some(f) => f,
        None => scene.to_string(),
    };
    let mut a = vec!["ezy".to_string(), "run".into(), shell_quote(&scene)];
    for (name, v) in &opts.sets {
        a.push(format!("--set {}", shell_quote(&format!("{name}={v:?}"))));
    }
    let num = |a: &mut Vec<String>, flag: &str, v: Option<f64>| {
        if let Some(v) = v {
            a.push(format!("{flag} {v:?}"));
        }
    };
    num(&mut a, "--dt", opts.dt);
    num(&mut a, "--t-end", opts.t_end);
    num(&mut a, "--every", opts.every);
    num(&mut a, "--rtol", opts.rtol);
    num(&mut a, "--atol", opts.atol);
    if let Some(m) = opts.method {
        a.push(format!("--integrator {}", m.name()));
    }
    if let Some(f) = opts.formulation {
        a.push(format!("--formulation {}", f.name()));
    }
    if let Some(p) = opts.projection {
        a.push(format!(
            "--projection {}",
            match p {
                ezy_core::ProjectionKind::None => "none",
                ezy_core::ProjectionKind::Euclidean => "euclidean",
                ezy_core::ProjectionKind::MassWeighted => "mass",
            }
        ));
    }
    if let Some(b) = opts.baumgarte {
        a.push(format!("--baumgarte {:?},{:?}", b.alpha, b.beta));
    }
    if let Some(n) = opts.max_steps {
        a.push(format!("--max-steps {n}"));
    }
    num(&mut a, "--max-output-mb", opts.max_output_mb);
    if let Some(f) = opts.figure_format {
        a.push(format!("--format {f}"));
    }
    num(&mut a, "--dpi", opts.dpi);
    if !opts.figures {
        a.push("--no-figures".into());
    }
    a.push("--report".into());
    a.join(" ")
}

/// `proto` (a model at its defaults) with `sets` applied (parameters and family counts).
///
/// # Errors
/// An unknown parameter (listing the model's), a count that is not a whole
/// number >= 1, or one that makes a family refer to a missing element.
pub(crate) fn with_sets<M: Model>(proto: &M, sets: &[(String, f64)]) -> Result<M, String> {
    let mut m = proto.clone();
    let info = m.info();
    for (name, value) in sets {
        let i = info.param_index(name).ok_or_else(|| info.unknown_param(name))?;
        if info.params[i].count {
            ezy_scene::check_count(name, *value).map_err(|e| e.message)?;
        }
        m.set_param(i, *value);
    }
    m.check_counts()?;
    Ok(m)
}

/// The analysis of `scene` with the overrides `sets` and its consistent
/// initial state.
pub(crate) fn scene_analysis<M: Model>(
    proto: &M,
    scene: &Scene,
    sets: &[(String, f64)],
) -> Result<(Analysis<M>, Vec<f64>), Error> {
    let (problem, _) = scene.problem_with(proto.clone(), sets)?;
    let (mut an, x0) = problem.analysis()?;
    // a model too large for the dense matrices is refused before any run
    an.check_size().map_err(|e| Error::Input(e.to_string()))?;
    an.stop_when(|| crate::output::transaction::pending().is_some());
    Ok((an, x0))
}

/// States of a scene's run that are an analysis' guesses (evenly spaced,
/// the end last): `ezy analyze`'s, and a sweep's gait metrics', whose
/// runs are so the same.
pub(crate) const GUESSES: u32 = 8;

/// The stop event that ended a run early, and its time \[s\].
pub(crate) type Stopped = Option<(String, f64)>;

/// The states `[q, qd]` of a run of the scene (its own settings,
/// overridden by `opts`) to `t_end` \[s\] at `samples` evenly spaced
/// times, the start excluded and the end last (the stop's state where a
/// stop event ended it, with its name and time); a signal stops it within
/// a step.
pub(crate) fn run_to<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    t_end: f64,
    samples: u32,
) -> Result<(Vec<Vec<f64>>, Stopped), Error> {
    let mut settings = settings(scene, opts)?;
    settings.t_end = t_end;
    settings.every = t_end / f64::from(samples);
    let (problem, _) = problem(proto, scene, opts, settings)?;
    let mut kept = States { dir: opts.out.clone(), x: Vec::new() };
    let (summary, _) = problem.solve_with(&mut kept).map_err(|e| match e {
        ezy_core::RunError::Sim(e) => Error::Sim(e),
        ezy_core::RunError::Output(e) => Error::Transaction(e),
    })?;
    // the start is the scene's own, and a sample just short of the end
    // (the output interval's rounding) is not kept twice
    let mut x = kept.x.split_off(1.min(kept.x.len()));
    x.truncate(samples as usize);
    Ok((x, summary.stopped))
}

/// Keeps the samples' `[q, qd]`; stops the run when a signal arrives.
struct States {
    dir: PathBuf,
    x: Vec<Vec<f64>>,
}

impl<M: Model> ezy_core::Observer<M> for States {
    type Error = crate::output::transaction::TransactionError;
    fn observe(&mut self, _sys: &ezy_core::Dynamics<M>, s: &ezy_core::Sample<'_>) -> Result<(), Self::Error> {
        self.x.push([s.q, s.qd].concat());
        Ok(())
    }
    fn poll(&mut self, t: f64) -> Result<(), Self::Error> {
        crate::output::transaction::check_interrupt(&self.dir, Some(t), Some("running the scene for a guess".into()))
    }
}

/// The command's error for an analysis' error, `dir` the output directory.
pub(crate) fn analysis_error(dir: &std::path::Path) -> impl Fn(AnalysisError) -> Error + '_ {
    move |e| match e {
        // the analyses integrate with DOP853: a stiff scene's fast mode
        // holds its step
        AnalysisError::Sim(SimError::Budget { what: "steps", estimate, limit, detail, .. }) => Error::Input(format!(
            "the analysis' integration (DOP853, an explicit method) would take about {} steps ({detail}), more than the limit of {}: a stiff scene's fast modes hold an explicit method's step, and the analyses have no implicit integrator yet; pass --max-steps {} (or larger) to wait for it",
            fmt_count(estimate),
            fmt_count(limit),
            fmt_count(estimate)
        )),
        AnalysisError::Sim(e) => Error::Sim(e),
        AnalysisError::Stopped => {
            match crate::output::transaction::check_interrupt(dir, None, Some("analysing".into())) {
                Err(i) => Error::Transaction(i),
                Ok(()) => Error::Input("the analysis was stopped".into()),
            }
        }
        e => Error::Input(e.to_string()),
    }
}

/// A count of steps, whole.
fn fmt_count(v: f64) -> String {
    format!("{:.0}", v)
}

/// `v` rounded to six decimals, `0` below 1e-12 (no `-0`): a speed or
/// a rate in the analyses' summaries.
pub(crate) fn rounded(v: f64) -> String {
    rounded_to(v, 6)
}

/// `v` rounded to `decimals` decimals (at most 6), `0` below 1e-12 (no
/// `-0`).
pub(crate) fn rounded_to(v: f64, decimals: usize) -> String {
    let v = if v.abs() < 1e-12 { 0.0 } else { v };
    let scale = 10f64.powi(decimals.min(6) as i32);
    // + 0.0: a value that rounds to -0 is written 0
    format!("{}", (v * scale).round() / scale + 0.0)
}

/// An eigenvalue or multiplier `re+imi` to six decimals, parts below
/// 1e-12 read as 0.
pub(crate) fn complex(z: c64) -> String {
    complex_to(z, 6)
}

/// An eigenvalue or multiplier `re+imi` to `decimals` decimals (at most
/// 6), parts below 1e-12 read as 0 and a real part that rounds to 0
/// written 0 (not `-0`).
pub(crate) fn complex_to(z: c64, decimals: usize) -> String {
    let d = decimals.min(6);
    let zero = |v: f64| v.abs() < 1e-12;
    let re = if zero(z.re) || (z.re.abs() * 10f64.powi(d as i32)).round() == 0.0 { 0.0 } else { z.re };
    let im = if zero(z.im) { 0.0 } else { z.im };
    if im == 0.0 {
        format!("{re:.d$}")
    } else {
        format!("{re:.d$}{}{:.d$}i", if im < 0.0 { "-" } else { "+" }, im.abs())
    }
}

/// The decimals a periodic orbit's numbers hold when its period map is
/// integrated and its Newton iteration stopped at `newton_tolerance`
/// (relative to `1 + |x0|`): six at the defaults (1e-9) and down to
/// 1e-7, one fewer for each decade above, at least one. The orbit's
/// state is off by about its residual times the period map's
/// conditioning (measured on `drive-rolling-resistance` at `--rtol
/// 1e-4`, Newton to 1e-3: the mean speed 2.8e-4 and the multipliers
/// 3.7e-4 from the defaults'), so the last decimal kept holds to a unit.
pub(crate) fn orbit_decimals(newton_tolerance: f64) -> usize {
    let decades = (-newton_tolerance.log10() + 1e-9).floor();
    (decades - 1.0).clamp(1.0, 6.0) as usize
}

/// The period map's settings: the defaults, `--max-steps` bounding each
/// period's integration (the advice of a budget error names it), and
/// `--rtol`/`--atol` where given: the periodic searches' DOP853 then
/// integrates at them, and Newton stops at 100 times the larger (as the
/// defaults, 1e-11 and 1e-9), at most 1e-3 and at least 1e-13.
pub(crate) fn periodic_settings(ro: &RunOptions) -> ezy_core::analysis::PeriodicSettings {
    let base = ezy_core::analysis::PeriodicSettings::default();
    let tolerance = ezy_core::integrator::Tolerance {
        rtol: ro.rtol.unwrap_or(base.tolerance.rtol),
        atol: ro.atol.unwrap_or(base.tolerance.atol),
    };
    let newton_tolerance = if ro.rtol.is_some() || ro.atol.is_some() {
        // (to 12 digits: 100 x 1e-6 is 1e-4, not 9.999999999999999e-5)
        let t: f64 = format!("{:.11e}", 100.0 * tolerance.rtol.max(tolerance.atol)).parse().unwrap_or(1e-3);
        t.clamp(1e-13, 1e-3)
    } else {
        base.newton_tolerance
    };
    ezy_core::analysis::PeriodicSettings {
        max_steps: ro.max_steps.unwrap_or(base.max_steps),
        tolerance,
        newton_tolerance,
    }
}

/// A figure drawn once as SVG, for a command's files and its report
/// page alike.
pub(crate) struct Drawn {
    /// The file's stem (`plan`, `gait_curvature`).
    pub stem: &'static str,
    /// Its title.
    pub title: String,
    /// The SVG, or why it could not be drawn.
    pub svg: Result<String, String>,
    /// The command fails without it; else a note says it was not drawn.
    pub required: bool,
}

/// Encodes each of `drawn` as `format` at `dpi` and writes it into `tx`
/// as its stem's file, asking `tx` for a signal before each; the files
/// written, in order.
///
/// # Errors
/// A required figure that could not be drawn or encoded
/// ([`Error::Input`] naming it; an optional one is a note on stderr); the
/// transaction's.
pub(crate) fn write_figures(
    tx: &mut Transaction,
    drawn: &[Drawn],
    (format, dpi): (FigureFormat, f64),
) -> Result<Vec<String>, Error> {
    let mut written = Vec::new();
    for d in drawn {
        tx.check(None, Some(format!("drawing {}", d.stem)))?;
        let bytes = d.svg.clone().and_then(|svg| {
            crate::render::plot::raster::encode(&svg, format, dpi, &d.title).map_err(|e| e.to_string())
        });
        match bytes {
            Ok(bytes) => {
                tx.write(&format.file_name(d.stem), &bytes)?;
                written.push(format.file_name(d.stem));
            }
            Err(e) if d.required => return Err(Error::Input(format!("figure {}: {e}", d.stem))),
            Err(e) => eprintln!("note: {} not drawn: {e}", format.file_name(d.stem)),
        }
    }
    Ok(written)
}

/// The figures as a report page embeds them: each file's name and its
/// SVG (whatever the files' format).
pub(crate) fn page_figures(drawn: Vec<Drawn>, format: FigureFormat) -> Vec<(String, Result<String, String>)> {
    drawn.into_iter().map(|d| (format.file_name(d.stem), d.svg)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_given_a_file_is_reproduced_from_it() {
        let opts = RunOptions { t_end: Some(3.0), figures: true, ..RunOptions::default() };
        assert_eq!(command_line("drive", &opts), "ezy run drive --t-end 3.0 --report");
        let file = |f: &str| RunOptions { scene_file: Some(f.into()), ..opts.clone() };
        let named = command_line("drive", &file("my dir/drive.toml"));
        assert_eq!(named, "ezy run 'my dir/drive.toml' --t-end 3.0 --report");
        let flag_like = command_line("x", &file("-x.toml"));
        assert_eq!(flag_like, "ezy run ./-x.toml --t-end 3.0 --report");
    }
}
