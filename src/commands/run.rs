//! Running a scene: resolve the model and overrides, find consistent
//! initial conditions, integrate, write `trajectory.csv` and the figures.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use ezy_core::{Baumgarte, Dynamics, Method, Model, Problem, ProjectionKind, RunError, RunSettings, SimError, Summary};

use ezy_scene::Scene;

use crate::figures::FigureError;
use crate::output::{CsvObserver, OutputError, RowBuilder, Table};
use crate::transaction::{Interrupted, Transaction, TransactionError};

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
    /// ([`run_model_in_memory`]: a notebook's interrupt).
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
    /// Also write `report.html` (see [`crate::report`]).
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
    /// ([`crate::report::command_line`]).
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
/// 24 characters, [`crate::output::format_number`]) and a separator.
pub const BYTES_PER_VALUE: f64 = crate::output::BYTES_PER_NUMBER as f64;

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
/// [`SimError::Setting`] naming the flag of a bad override (`--rtol`),
/// or a setting the scene and overrides make invalid together.
pub fn settings(scene: &Scene, opts: &RunOptions) -> Result<RunSettings, SimError> {
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
            return Err(SimError::Setting { name: flag.into(), value: v, reason });
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
    scene.check_drives_cover(settings.t_end).map_err(|e| SimError::Scene { key: e.key(), message: e.message })?;
    Ok(settings)
}

/// The problem `scene` describes for `proto` (a model at its defaults) with the overrides of
/// `opts` (`--set`, `--baumgarte`) and the run's `settings` (from
/// [`settings`]), and the scene as run (overrides applied, families
/// expanded). `ezy run`, `ezy animate` and every run of `ezy sweep` start
/// here, so a sweep's run is the single run, number for number.
///
/// # Errors
/// As [`ezy_scene::Scene::problem`].
pub fn problem<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    settings: RunSettings,
) -> Result<(Problem<M>, Scene), SimError> {
    let (mut problem, scene) = scene.problem_with(proto.clone(), &opts.sets)?;
    problem.settings = settings;
    problem.baumgarte = opts.baumgarte;
    Ok((problem, scene))
}

/// Elements of a model's families (the sum of its counts) from which a
/// run's setup may take seconds and gets a heartbeat: the snake's setup
/// takes 0.03 s at 1,000 links, 0.45 s at 10,000 and 6.7 s at 100,000
/// (the guide's "Scale" chapter, 2 cores), and the heartbeat's first line comes
/// after [`crate::progress::LINE_EVERY`]; below it the thread's start and
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

/// Runs `scene` with `opts` on `proto`, a model at its defaults (what [`crate::App::run_scene`]
/// calls for the model the scene names): resolves the overrides, finds
/// consistent initial values, integrates, writes `trajectory.csv` and the
/// figures into `opts.out`.
///
/// # Errors
/// [`Error`] naming the bad setting, parameter, or file.
pub fn run_model<M: Model>(proto: &M, scene: &Scene, opts: &RunOptions) -> Result<Report, Error> {
    run_model_tapped(proto, scene, opts, None)
}

/// [`run_model`] that shows every output row, as it is written, to `tap`
/// (what `ezy sweep --save-runs` reduces its metrics from).
///
/// # Errors
/// As [`run_model`].
pub fn run_model_tapped<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    tap: Option<crate::output::Tap<'_>>,
) -> Result<Report, Error> {
    let wall = Instant::now();
    let settings = settings(scene, opts)?;
    // a line on stderr every few seconds while a phase without its own
    // progress takes long: the setup of a large family (a short setup gets
    // no thread, see `setup_may_be_long`), the figures, the report
    let mut beat = (opts.progress && setup_may_be_long(proto, scene, &opts.sets))
        .then(|| crate::progress::Heartbeat::start(format!("setting up scene {}", scene.name)));
    let (format, dpi) = opts.look(scene);
    if opts.figures {
        // a library caller's PDF in a build without the `pdf` feature,
        // before any work (the command line checks this first, naming the
        // scene file's line)
        crate::plot::check_format(format).map_err(|e| Error::Input(format!("scene `{}`: {e}", scene.name)))?;
    }
    let Prepared { scene, mut sys, y0, initial, rows, n_rows } = prepare(proto, scene, opts, &settings)?;
    let scene = &scene;

    // The output is a transaction: trajectory.csv and the figures are
    // written into a private directory and committed together (the CSV
    // last) only when all of them succeeded.
    let mut tx = Transaction::begin(&opts.out)?;
    let progress = if opts.progress { crate::progress::Progress::new(settings.t_end) } else { None };
    let mut obs = CsvObserver::create(&mut tx, "trajectory.csv", rows, progress, n_rows)?;
    if let Some(tap) = tap {
        obs = obs.with_tap(tap);
    }
    let setup = wall.elapsed();
    if let Some(b) = &beat {
        b.quiet();
    }
    // the threads that will draw the figures, none without figures
    let encoders = if opts.figures && !scene.figures.is_empty() {
        crate::figures::encoding_threads(scene.figures.len())
    } else {
        0
    };
    if encoders > 0 {
        // the fonts and an image buffer for each thread that will encode
        // figures, made on another core while this one integrates
        // (detached: it takes milliseconds)
        let _ = std::thread::Builder::new()
            .name("ezy-warm-up".into())
            .spawn(move || crate::plot::warm_up(format, dpi, encoders));
    }
    let summary = match ezy_core::simulate(&mut sys, &y0, &settings, &mut obs) {
        Ok(s) => s,
        Err(e) => {
            obs.abandon();
            return Err(match e {
                RunError::Sim(e) => sys.explain(e, &settings).into(),
                RunError::Output(e) => e.into(),
            });
        }
    };
    // the rows now; the CSV's flush and sync go on while the figures are
    // drawn, and are waited for before the run's time is taken
    let (table, csv) = obs.finish_later()?;
    let state_names = sys.state_names();
    // the events' times and states, whenever the scene watches any (a
    // skate with friction records its switches)
    if !sys.events.is_empty() || !sys.friction.is_empty() {
        tx.write("events.csv", crate::output::events_csv(&summary.events, &state_names).as_bytes())?;
    }
    let mut drawn_svgs = Vec::new();
    if opts.figures {
        if opts.progress && !scene.figures.is_empty() {
            crate::progress::Heartbeat::report(&mut beat, format!("drawing {} figures", scene.figures.len()));
        }
        // drawn in parallel, largest first, each written as it is done; a
        // signal stops the drawing at the next figure
        let dir = tx.dir().to_path_buf();
        let check = |fig: &ezy_scene::FigureSpec| -> Result<(), Error> {
            Ok(crate::transaction::check_interrupt(&dir, Some(settings.t_end), Some(format!("drawing {}", fig.file)))?)
        };
        let mut svgs = vec![None; scene.figures.len()];
        crate::figures::render_all(&sys.info, &scene.figures, &table, format, dpi, check, |i, svg, bytes| {
            tx.write(&format.file_name(&scene.figures[i].file), &bytes)?;
            // the report shows the same drawing
            if opts.report {
                svgs[i] = Some(svg.to_string());
            }
            Ok(())
        })?;
        for (fig, svg) in scene.figures.iter().zip(svgs) {
            if let Some(svg) = svg {
                drawn_svgs.push((ezy_scene::figure_stem(&fig.file).to_string(), Ok(svg)));
            }
        }
    }
    csv.wait()?;
    let warnings = run_warnings(&initial, &summary);
    let notes = initial.notes();
    let mut report = Report {
        summary,
        table,
        settings,
        state_names,
        files: Vec::new(),
        setup,
        wall: wall.elapsed(),
        warnings,
        notes,
    };
    if opts.report {
        if opts.progress {
            crate::progress::Heartbeat::report(&mut beat, "writing report.html");
        }
        tx.check(Some(settings.t_end), Some("writing report.html".into()))?;
        let figures = if opts.figures { drawn_svgs } else { crate::report::figures(&sys.info, scene, &report.table) };
        let html = report_html(scene, opts, &sys, &y0, &report, figures);
        tx.write("report.html", html.as_bytes())?;
    }
    report.files = tx.commit()?;
    if opts.figures {
        // written as they were finished: listed in the scene's order
        let names: Vec<String> = scene.figures.iter().map(|f| format.file_name(&f.file)).collect();
        in_figure_order(&mut report.files, &names);
    }
    drop(beat);
    report.wall = wall.elapsed();
    Ok(report)
}

/// Puts the paths among `files` whose file names are in `names` into the
/// order of `names`, in the places they hold; the other paths stay where
/// they are.
fn in_figure_order(files: &mut [PathBuf], names: &[String]) {
    let rank = |p: &PathBuf| p.file_name().and_then(|n| names.iter().position(|f| n == f.as_str()));
    let places: Vec<usize> = (0..files.len()).filter(|&k| rank(&files[k]).is_some()).collect();
    let mut figures: Vec<PathBuf> = places.iter().map(|&k| files[k].clone()).collect();
    figures.sort_by_key(|p| rank(p));
    for (k, p) in places.into_iter().zip(figures) {
        files[k] = p;
    }
}

/// A caller's hook, asked after every accepted step with the time reached
/// \[s\] whether to stop an in-memory run ([`run_model_in_memory`]):
/// `Some(reason)` stops it with [`Error::Stopped`]. It is called often
/// (every step): a hook that costs more than a comparison should look at
/// the clock and do its work every few milliseconds only.
pub type StopHook<'a> = &'a mut dyn FnMut(f64) -> Option<String>;

/// [`run_model`] without files: every output row in [`Report::table`],
/// with the columns `trajectory.csv` would have, and nothing written
/// ([`RunOptions::out`], `figures` and `report` are not read). The notes
/// a file run prints on stderr are in [`Report::notes`]. The table's size
/// is refused before the run as `trajectory.csv`'s would be
/// ([`output_budget`], [`RunOptions::max_output_mb`]). What a library or
/// a notebook embeds (the Python package's `ezy.run`).
///
/// # Errors
/// As [`run_model`] (no file errors); [`Error::Stopped`] when `stop`
/// asked.
pub fn run_model_in_memory<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    stop: Option<StopHook<'_>>,
) -> Result<Report, Error> {
    let wall = Instant::now();
    let settings = settings(scene, opts)?;
    let Prepared { mut sys, y0, initial, rows: builder, n_rows, .. } = prepare(proto, scene, opts, &settings)?;
    let n = builder.columns.len();
    let table = Table { columns: builder.columns.clone(), data: Vec::with_capacity(n_rows * n) };
    let mut obs = MemoryObserver { builder, row: Vec::with_capacity(n), table, stop, notes: Vec::new() };
    let setup = wall.elapsed();
    let summary = ezy_core::simulate(&mut sys, &y0, &settings, &mut obs).map_err(|e| match e {
        RunError::Sim(e) => sys.explain(e, &settings).into(),
        RunError::Output(e) => e,
    })?;
    let mut notes = initial.notes();
    notes.append(&mut obs.notes);
    Ok(Report {
        warnings: run_warnings(&initial, &summary),
        summary,
        table: obs.table,
        settings,
        state_names: sys.state_names(),
        files: Vec::new(),
        setup,
        wall: wall.elapsed(),
        notes,
    })
}

/// What a run sets up before its first step, whether it writes files or
/// not: the configured scene, the system and its consistent initial
/// state, the row layout (its size refused by [`output_budget`]) and the
/// number of rows to expect.
struct Prepared<M: Model> {
    scene: Scene,
    sys: Dynamics<M>,
    y0: Vec<f64>,
    initial: ezy_core::formulation::initial::InitialReport,
    rows: RowBuilder<M>,
    n_rows: usize,
}

fn prepare<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    settings: &RunSettings,
) -> Result<Prepared<M>, Error> {
    let (problem, scene) = problem(proto, scene, opts, *settings)?;
    let (sys, y0, initial) = problem.into_system()?;
    let rows = RowBuilder::new(&scene, &sys);
    output_budget(settings, rows.columns.len(), opts.max_output_mb.unwrap_or(DEFAULT_MAX_OUTPUT_MB))?;
    let n_rows = (settings.n_steps() / settings.output_stride() + 2) as usize;
    Ok(Prepared { scene, sys, y0, initial, rows, n_rows })
}

/// The warnings of a run: the initial values' corrections, and an
/// ill-conditioned KKT system.
fn run_warnings(initial: &ezy_core::formulation::initial::InitialReport, summary: &Summary) -> Vec<String> {
    let mut warnings = initial.warnings();
    if let Some((t, c)) = summary.ill_conditioned {
        warnings.push(format!(
            "from t = {} s the KKT system is ill-conditioned (estimate {c:.1e} > {:.0e}): constraints are nearly dependent, expect about {:.0e} relative accuracy in the constraint forces",
            ezy_core::fmt_value(t),
            ezy_core::formulation::dae::CONDITION_WARNING,
            c * f64::EPSILON
        ));
    }
    warnings
}

/// The sink of [`run_model_in_memory`]: every row into a table.
struct MemoryObserver<'a, M: Model> {
    builder: RowBuilder<M>,
    row: Vec<f64>,
    table: Table,
    stop: Option<StopHook<'a>>,
    notes: Vec<String>,
}

impl<M: Model> ezy_core::Observer<M> for MemoryObserver<'_, M> {
    type Error = Error;

    fn observe(&mut self, sys: &Dynamics<M>, s: &ezy_core::Sample<'_>) -> Result<(), Error> {
        self.builder.fill(sys, s, &mut self.row)?;
        self.table.data.extend_from_slice(&self.row);
        Ok(())
    }

    fn poll(&mut self, t: f64) -> Result<(), Error> {
        match self.stop.as_mut().and_then(|hook| hook(t)) {
            Some(reason) => Err(Error::Stopped { t, reason }),
            None => Ok(()),
        }
    }

    fn note(&mut self, text: &str) {
        self.notes.push(text.to_string());
    }
}

/// The page of `ezy run --report` (see [`crate::report`]).
/// `figures`: each figure's stem and SVG (or why it is missing).
fn report_html<M: Model>(
    scene: &Scene,
    opts: &RunOptions,
    sys: &Dynamics<M>,
    y0: &[f64],
    r: &Report,
    figures: Vec<(String, Result<String, String>)>,
) -> String {
    use crate::report::{REPORT_DPI, REPORT_FPS, REPORT_FRAMES};
    let ledger = crate::report::ledger(sys, y0, &r.summary.final_state, &r.state_names);
    let animation = crate::animate::gif_of_table(sys, scene, &r.table, REPORT_FRAMES, REPORT_FPS, REPORT_DPI)
        .map_err(|e| e.to_string());
    let text = summary(&scene.name, r);
    let page = crate::report::Page {
        scene,
        model: sys.info.name,
        t_end: r.settings.t_end,
        summary: &text,
        ledger: &ledger,
        max_gap: r.summary.max_energy_error,
        animation,
        figures,
        command: crate::report::command_line(&scene.name, opts),
        scene_file: opts.scene_file.as_deref(),
    };
    crate::report::html(&page)
}

/// Refuses a run whose `trajectory.csv` would exceed `max_mb` \[MB\]:
/// rows (one per output interval, plus the first and the last) times
/// `columns` values of at most [`BYTES_PER_VALUE`] bytes.
///
/// # Errors
/// [`SimError::Budget`] with the estimate and the flag that raises the cap.
pub fn output_budget(settings: &RunSettings, columns: usize, max_mb: f64) -> Result<(), SimError> {
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
pub const SUMMARY_EVENTS: usize = 10;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_listed_in_the_scenes_order_around_the_other_files() {
        let mut files: Vec<PathBuf> =
            ["out/trajectory.csv", "out/c.png", "out/a.png", "out/events.csv", "out/b.png", "out/report.html"]
                .iter()
                .map(PathBuf::from)
                .collect();
        let names: Vec<String> = ["a.png", "b.png", "c.png"].iter().map(|s| s.to_string()).collect();
        in_figure_order(&mut files, &names);
        let got: Vec<&str> = files.iter().map(|p| p.to_str().unwrap()).collect();
        assert_eq!(
            got,
            ["out/trajectory.csv", "out/a.png", "out/b.png", "out/events.csv", "out/c.png", "out/report.html"]
        );
    }
}
