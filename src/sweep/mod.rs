//! `ezy sweep`: many runs of one scene over parameter values, in parallel
//! on every core (rayon), resumable, and split into shards that run
//! anywhere (a Slurm job array, Kubernetes indexed jobs) and merge into
//! the same table.
//!
//! Each run is exactly `ezy run` with the run's `--set` values
//! (`crate::session::problem` and [`ezy_core::simulate()`] with the same
//! settings), so its numbers are the single run's, bit for bit; it
//! writes no file unless `--save-runs` asks. The output directory holds:
//!
//! - `sweep.toml`: the sweep's definition (scene, axes, metrics,
//!   overrides). Re-running the same command in the same directory
//!   resumes the sweep; a different sweep there is refused.
//! - `sweep.csv`: one row per run, in run order, appended as runs finish
//!   (a row is written whole or, after a kill, cut off and re-run on
//!   resume; a row deleted by hand is re-run on resume and the table
//!   written anew in run order). Its columns ([`columns`]): `run`, the swept parameters,
//!   `status` (`ok` or `error: ...`), `wall_s`, `steps`, `rejected`,
//!   `rhs_evals`, the final state `y = [q, qd, W_...]` and `T` \[J\] (the
//!   values of the last row of the run's `trajectory.csv`),
//!   `max_res_phi` \[m\], `max_res_vel` \[m/s\], `max_energy_gap` \[J\] and
//!   the metrics.
//! - `sweep_<k>.png`: metric `k` against the parameters (a line per value
//!   of a second axis, or a heat map for two), once every run is in.
//!
//! Only the table's rows are streamed: a sweep's memory does not grow
//! with its number of runs (the plan computes run `i`'s values from `i`,
//! and the runs already done are read back from `sweep.csv` as the
//! dispatch passes them).

pub(crate) mod figure;
pub(crate) mod gait;
pub(crate) mod metric;
pub(crate) mod plan;
pub(crate) mod slurm;
pub(crate) mod table;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use ezy_core::{Dynamics, Model, Observer, RunError, Sample, SimError};

use ezy_scene::Scene;

use metric::Metric;
use plan::Plan;
use table::Manifest;

use crate::output::transaction::Interrupted;
use crate::session::{self, RunOptions};
use ezy_scene::RowBuilder;

/// A sweep to run: what `ezy sweep` parsed and checked.
#[derive(Debug, Clone)]
pub(crate) struct SweepJob {
    /// The scene.
    pub scene: Scene,
    /// The sweep's definition, recorded in `sweep.toml`.
    pub manifest: Manifest,
    /// The runs.
    pub plan: Plan,
    /// The metrics.
    pub metrics: Vec<Metric>,
    /// The overrides every run takes (`--set`, `--integrator`, ...).
    pub opts: RunOptions,
    /// The output directory.
    pub out: PathBuf,
    /// Runs at once; [`sweep_model`] takes at most the cores this process
    /// may use (`std::thread::available_parallelism`) and at least 1.
    pub jobs: usize,
    /// Shard `(k, n)`: runs `k, k + n, k + 2n, ...`.
    pub shard: Option<(u64, u64)>,
    /// Keep every run's trajectory and figures in `out/runs/RUN`.
    pub save_runs: bool,
    /// Draw the sweep's figures.
    pub figures: bool,
    /// A progress bar (terminal) or lines (log) on stderr.
    pub progress: bool,
    /// Check everything a run needs (names, metrics, windows) and stop
    /// before the first run (`--emit-slurm`).
    pub check_only: bool,
}

/// What a sweep did.
#[derive(Debug, Clone, Default)]
pub(crate) struct SweepReport {
    /// Runs of this shard (all runs when not sharded).
    pub runs: u64,
    /// Runs already in `sweep.csv` when it started (skipped).
    pub done_before: u64,
    /// Runs carried out now.
    pub ran: u64,
    /// Of those, runs that failed (a row with their error).
    pub failed: u64,
    /// Wall time of the runs (dispatch to the last row).
    pub wall: Duration,
    /// Sum of the runs' own wall times (the work: busy time of the jobs).
    pub busy: Duration,
    /// Runs at once.
    pub jobs: usize,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Figures not drawn, and why.
    pub notes: Vec<String>,
}

impl SweepReport {
    /// Runs per second of wall time.
    pub(crate) fn rate(&self) -> f64 {
        self.ran as f64 / self.wall.as_secs_f64().max(1e-9)
    }

    /// Parallel efficiency: the jobs' busy time over `jobs` x wall time.
    pub(crate) fn efficiency(&self) -> f64 {
        self.busy.as_secs_f64() / (self.jobs as f64 * self.wall.as_secs_f64()).max(1e-9)
    }

    /// The summary `ezy sweep` prints.
    pub(crate) fn summary(&self, scene: &str) -> String {
        let mut s = if self.ran == 0 {
            format!("sweep {scene}: {} runs, all done before: nothing to run\n", self.runs)
        } else {
            format!(
                "sweep {scene}: {} runs, {} done before, {} ran ({} failed) in {:.3} s on {} jobs: {:.1} runs/s, {:.1} per job, parallel efficiency {:.0} %, mean run {:.2} ms\n",
                self.runs,
                self.done_before,
                self.ran,
                self.failed,
                self.wall.as_secs_f64(),
                self.jobs,
                self.rate(),
                self.rate() / self.jobs as f64,
                100.0 * self.efficiency(),
                1e3 * self.busy.as_secs_f64() / self.ran.max(1) as f64,
            )
        };
        for n in &self.notes {
            s.push_str(&format!("  note: {n}\n"));
        }
        for f in &self.files {
            s.push_str(&format!("  wrote {}\n", f.display()));
        }
        s
    }
}

/// Why a sweep stopped.
#[derive(Debug, thiserror::Error)]
pub(crate) enum SweepError {
    /// Bad input or a failed write; the message names the culprit.
    #[error("{0}")]
    Failed(String),
    /// A signal stopped the sweep; every row finished before it is in
    /// `sweep.csv`, and re-running the command resumes.
    #[error("{0}")]
    Interrupted(Interrupted),
}

impl From<String> for SweepError {
    fn from(s: String) -> Self {
        Self::Failed(s)
    }
}

/// The columns of `sweep.csv` before the final state.
pub(crate) const LEAD: [&str; 5] = ["status", "wall_s", "steps", "rejected", "rhs_evals"];
/// The columns after the final state, before the metrics.
pub(crate) const TAIL: [&str; 4] = ["T", "max_res_phi", "max_res_vel", "max_energy_gap"];

/// The header of `sweep.csv`: `run`, the axes, [`LEAD`], `state`, [`TAIL`],
/// the metrics.
pub(crate) fn columns(plan: &Plan, state: &[String], metrics: &[Metric]) -> Vec<String> {
    let mut c = vec!["run".to_string()];
    c.extend(plan.names());
    c.extend(LEAD.iter().map(|s| s.to_string()));
    c.extend(state.iter().cloned());
    c.extend(TAIL.iter().map(|s| s.to_string()));
    c.extend(metrics.iter().map(|m| m.text.clone()));
    c
}

/// The overrides of run `i`: the job's, then the run's values.
fn run_sets(job: &SweepJob, values: &[f64]) -> Vec<(String, f64)> {
    let mut sets = job.opts.sets.clone();
    sets.extend(job.plan.axes.iter().zip(values).map(|(a, &v)| (a.name.clone(), v)));
    sets
}

/// Most elements (the sum of the family counts over every combination of
/// the swept family sizes) a sweep sets up before its first run, to check
/// the names and columns at each size: 1e7, minutes of setup (the snake
/// sets up about 15,000 links a second).
pub(crate) const MAX_CHECKED_ELEMENTS: f64 = 1e7;

/// The flag and text that gave the axis `name` (`--list N=1,1000000`).
fn axis_flag(job: &SweepJob, name: &str) -> String {
    let args = &job.manifest.args;
    args.iter()
        .zip(args.iter().skip(1))
        .find(|(f, v)| {
            matches!(f.as_str(), "--grid" | "--list" | "--random")
                && v.split_once('=').is_some_and(|(n, _)| n.trim() == name)
        })
        .map_or_else(|| format!("axis `{name}`"), |(f, v)| format!("{f} {v}"))
}

/// Everything checked before the first run: the settings, the names the
/// axes give, the metrics' columns and windows, and the final state's
/// columns over every family count the sweep takes.
struct Checked {
    settings: ezy_core::RunSettings,
    state: Vec<String>,
}

fn check<M: Model>(proto: &M, job: &SweepJob) -> Result<Checked, String> {
    let settings = session::settings(&job.scene, &job.opts).map_err(|e| e.to_string())?;
    let events: Vec<&str> = job.scene.events.iter().map(|(n, _)| n.as_str()).collect();
    for m in &job.metrics {
        m.check_window(settings.t_end, settings.every)?;
        m.check_event(&events)?;
    }
    let base = proto.clone().info();
    // every name, with the first value of its axis (unknown names and
    // values a key refuses are caught here, before any run)
    let first = job.plan.values(0);
    let mut probe = job.scene.clone();
    for (name, v) in run_sets(job, &first) {
        probe.set(&base, &name, v).map_err(|e| format!("--set/axis `{name}`: {e}"))?;
    }
    // family counts: the final state's columns differ per count; the
    // header takes every count's names in order of first appearance
    let counts: Vec<usize> = job
        .plan
        .axes
        .iter()
        .enumerate()
        .filter(|(_, a)| base.param_index(&a.name).is_some_and(|i| base.params[i].count))
        .map(|(k, _)| k)
        .collect();
    // the family sizes are counted before any model is built: every
    // combination of the count axes' values is set up once below, so
    // their number and their elements are bounded
    let mut combinations: u64 = 1;
    for &k in &counts {
        let n = job.plan.fixed_len(k).ok_or_else(|| {
            format!("family count `{}` cannot be drawn at random: give it with --grid or --list", job.plan.axes[k].name)
        })?;
        combinations = combinations.saturating_mul(n);
    }
    let too_many = |elements: f64| {
        let axes: Vec<String> = counts.iter().map(|&k| axis_flag(job, &job.plan.axes[k].name)).collect();
        format!(
            "{}: the sweep's family sizes come to {} elements over {combinations} combinations of sizes, more than the limit of {}: ezy sets up the model at each family size before the first run (to check names and columns), and that many elements would take hours and gigabytes; sweep fewer or smaller family sizes",
            axes.join(", "),
            ezy_core::fmt_value(elements),
            ezy_core::fmt_value(MAX_CHECKED_ELEMENTS)
        )
    };
    // each size is at least 1 element: refused before any value is looked at
    if combinations as f64 * counts.len() as f64 > MAX_CHECKED_ELEMENTS {
        return Err(too_many(combinations as f64 * counts.len() as f64).replace(" come to ", " come to at least "));
    }
    let (mut elements, mut seen_combinations) = (0f64, 1u64);
    for &k in &counts {
        let n = job.plan.fixed_len(k).expect("a fixed axis");
        let name = &job.plan.axes[k].name;
        let mut sum = 0f64;
        for v in job.plan.fixed_iter(k).expect("a fixed axis") {
            ezy_scene::check_count(name, v).map_err(|e| format!("{}: {}", axis_flag(job, name), e.message))?;
            sum += v;
        }
        // every value of this axis meets every combination of the others
        elements = elements * n as f64 + sum * seen_combinations as f64;
        seen_combinations *= n;
    }
    if elements > MAX_CHECKED_ELEMENTS {
        return Err(too_many(elements));
    }
    let beat = (job.progress && elements >= session::LONG_SETUP_ELEMENTS).then(|| {
        crate::output::progress::Heartbeat::start(format!("sweep {}: checking the family sizes", job.scene.name))
    });
    let mut state: Vec<String> = Vec::new();
    let mut seen: HashSet<String> = HashSet::new();
    let mut metrics_checked = false;
    let mut last_error = None;
    for c in 0..combinations {
        // combination `c` of the count axes' values, the last varying fastest
        let mut tuple = vec![0.0; counts.len()];
        let mut rest = c;
        for (slot, &k) in tuple.iter_mut().zip(&counts).rev() {
            let n = job.plan.fixed_len(k).expect("a fixed axis");
            *slot = job.plan.axes[k].values.get(rest % n);
            rest /= n;
        }
        if let Some(b) = &beat {
            let sizes: Vec<String> =
                counts.iter().zip(&tuple).map(|(&k, v)| format!("{} = {v}", job.plan.axes[k].name)).collect();
            b.set(format!(
                "sweep {}: setting up the model at {} ({} of {combinations}) to check names and columns",
                job.scene.name,
                sizes.join(", "),
                c + 1
            ));
        }
        // the columns depend on the family counts alone: the other swept
        // values are left at the scene's (a run's bad value is its row's
        // error, not the sweep's)
        let mut sets = job.opts.sets.clone();
        for (&k, &v) in counts.iter().zip(&tuple) {
            sets.push((job.plan.axes[k].name.clone(), v));
        }
        match job.scene.problem_with(proto.clone(), &sets) {
            Ok((p, scene)) => {
                for n in p.state_names() {
                    if seen.insert(n.clone()) {
                        state.push(n);
                    }
                }
                if !metrics_checked {
                    let cols = scene.columns(&p.model.info());
                    for m in &job.metrics {
                        m.check_columns(&cols)?;
                    }
                    metrics_checked = true;
                }
            }
            Err(e) => last_error = Some(e.to_string()),
        }
    }
    if !metrics_checked && let Some(e) = last_error {
        return Err(format!("no run of this sweep can be set up: {e}"));
    }
    Ok(Checked { settings, state })
}

/// Reduces the metrics and keeps the last sample: its state and kinetic
/// energy are the run's final values, exactly the last row of the
/// trajectory `ezy run` writes.
struct Tap {
    accs: Vec<metric::Accumulator>,
    kinetic: f64,
    state: Vec<f64>,
}

impl Tap {
    fn new(accs: Vec<metric::Accumulator>) -> Self {
        Self { accs, kinetic: f64::NAN, state: Vec::new() }
    }

    fn take(&mut self, s: &Sample<'_>, row: &[f64]) {
        self.kinetic = s.kinetic_energy;
        self.state.clear();
        self.state.extend_from_slice(s.q);
        self.state.extend_from_slice(s.qd);
        self.state.extend_from_slice(s.works);
        for a in &mut self.accs {
            a.push(row);
        }
    }
}

/// The observer of a run that writes nothing: rows are built only when a
/// metric needs them; a signal stops the run.
struct Quiet<M: Model> {
    rows: Option<RowBuilder<M>>,
    row: Vec<f64>,
    tap: Tap,
    /// The output interval \[s\]: outputs the metrics do not read are
    /// not made ([`Observer::wants`]).
    every: f64,
}

/// Why [`Quiet`] stopped a run.
enum Stop {
    /// A signal asked to stop.
    Signal(crate::output::transaction::Signal),
    /// A row could not be built (the constraint forces' solve failed).
    Row(SimError),
}

impl<M: Model> Observer<M> for Quiet<M> {
    type Error = Stop;

    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Stop> {
        if let Some(rows) = &mut self.rows {
            rows.fill(sys, s, &mut self.row).map_err(Stop::Row)?;
        }
        self.tap.take(s, &self.row);
        poll()
    }

    fn poll(&mut self, _t: f64) -> Result<(), Stop> {
        poll()
    }

    fn wants(&self, t: f64) -> bool {
        self.tap.accs.iter().any(|a| a.reads(t, self.every))
    }

    fn next_wanted(&self, t: f64) -> f64 {
        self.tap.accs.iter().map(|a| a.next_read(t, self.every)).fold(f64::INFINITY, f64::min)
    }
}

fn poll() -> Result<(), Stop> {
    match crate::output::transaction::pending() {
        None => Ok(()),
        Some(signal) => Err(Stop::Signal(signal)),
    }
}

/// One run's outcome.
enum Outcome {
    /// Run `run`'s row of `sweep.csv` (a line, with the newline).
    Row { run: u64, line: Vec<u8>, failed: bool, wall: Duration },
    /// A signal stopped it.
    Interrupted(crate::output::transaction::Signal),
    /// Its output directory (`--save-runs`) cannot be used: the sweep stops.
    Unusable(String),
}

/// What a run yields before it becomes a row.
struct Done {
    summary: ezy_core::Summary,
    state_names: Vec<String>,
    tap: Tap,
    /// Each gait metric's value (`None` for the others).
    gait: Vec<Option<f64>>,
}

/// The run's gait metrics ([`gait::values`]) into `done`: a signal that
/// stopped the search stops the run.
fn with_gait<M: Model>(
    mut done: Done,
    (proto, job): (&M, &SweepJob),
    settings: &ezy_core::RunSettings,
    opts: &RunOptions,
) -> Result<Done, Result<String, crate::output::transaction::Signal>> {
    match gait::values(proto, job, settings, opts, done.summary.stopped.as_ref()) {
        Ok(v) => {
            done.gait = v;
            Ok(done)
        }
        Err(e) => match crate::output::transaction::pending() {
            Some(signal) => Err(Err(signal)),
            None => Err(Ok(e)),
        },
    }
}

fn one_run<M: Model>(
    proto: &M,
    job: &SweepJob,
    settings: &ezy_core::RunSettings,
    opts: &RunOptions,
    save: Option<PathBuf>,
) -> Result<Done, Result<String, crate::output::transaction::Signal>> {
    let fail = |e: String| Err(Ok(e));
    if let Some(dir) = save {
        let opts = RunOptions { out: dir, figures: true, progress: false, ..opts.clone() };
        // the metrics need the row layout: from the configured scene
        let (layout, scene) = job.scene.problem_with(proto.clone(), &opts.sets).map_err(|e| Ok(e.to_string()))?;
        let cols = scene.columns(&layout.model.info());
        let accs = job.metrics.iter().map(|m| metric::Accumulator::new(m, &cols)).collect::<Result<_, _>>();
        let mut tap = Tap::new(accs.map_err(Ok)?);
        let mut f = |s: &Sample<'_>, row: &[f64]| tap.take(s, row);
        let report = match crate::run::run_model_tapped(proto, &job.scene, &opts, Some(&mut f)) {
            Ok(r) => r,
            Err(e) => {
                return match e.interrupted() {
                    Some(i) => Err(Err(i.signal)),
                    None => fail(e.to_string()),
                };
            }
        };
        let done = Done { summary: report.summary, state_names: report.state_names, tap, gait: Vec::new() };
        return with_gait(done, (proto, job), settings, &opts);
    }
    let (problem, scene) = session::problem(proto, &job.scene, opts, *settings).map_err(|e| Ok(e.to_string()))?;
    let (mut sys, y0, _) = problem.into_system().map_err(|e| Ok(e.to_string()))?;
    let rows = (!job.metrics.is_empty()).then(|| RowBuilder::new(&scene, &sys));
    let accs = match &rows {
        Some(r) => job.metrics.iter().map(|m| metric::Accumulator::new(m, &r.columns)).collect::<Result<_, _>>(),
        None => Ok(Vec::new()),
    };
    let mut obs = Quiet { rows, row: Vec::new(), tap: Tap::new(accs.map_err(Ok)?), every: settings.every };
    match ezy_core::simulate(&mut sys, &y0, settings, &mut obs) {
        Ok(summary) => {
            let state_names = sys.state_names();
            with_gait(Done { summary, state_names, tap: obs.tap, gait: Vec::new() }, (proto, job), settings, opts)
        }
        Err(RunError::Output(Stop::Signal(s))) => Err(Err(s)),
        Err(RunError::Output(Stop::Row(e))) => fail(e.to_string()),
        Err(RunError::Sim(e)) => fail(sys.explain(e, settings).to_string()),
    }
}

/// Formats run `i`'s row.
fn row_line(
    i: u64,
    values: &[f64],
    result: Result<Done, String>,
    wall: Duration,
    state_at: &HashMap<String, usize>,
    n_state: usize,
    metrics: &[Metric],
) -> (Vec<u8>, bool) {
    let mut fields: Vec<String> = Vec::with_capacity(8 + values.len() + n_state + metrics.len());
    let mut buf = zmij::Buffer::new();
    let mut f = |v: f64| crate::output::csv::format_number(&mut buf, v).to_string();
    fields.push(i.to_string());
    fields.extend(values.iter().map(|&v| f(v)));
    let mut failed = false;
    let done = result.and_then(|d| {
        let m: Result<Vec<f64>, String> = (d.tap.accs.iter().zip(metrics).enumerate())
            .map(|(k, (a, m))| match d.gait.get(k).copied().flatten() {
                Some(v) => Ok(v),
                None => m.event_value(&d.summary.events).unwrap_or_else(|| a.value(m)),
            })
            .collect();
        m.map(|m| (d, m))
    });
    match done {
        Ok((d, metric_values)) => {
            let s = &d.summary;
            fields.push("ok".into());
            fields.push(f(wall.as_secs_f64()));
            fields.push(s.steps.to_string());
            fields.push(s.rejected.to_string());
            fields.push(s.counters.rhs_evals.to_string());
            let mut state = vec![String::new(); n_state];
            for (name, &v) in d.state_names.iter().zip(&d.tap.state) {
                if let Some(&k) = state_at.get(name) {
                    state[k] = f(v);
                }
            }
            fields.extend(state);
            fields.push(if d.tap.kinetic.is_finite() { f(d.tap.kinetic) } else { String::new() });
            fields.push(f(s.max_residual_position));
            fields.push(f(s.max_residual_velocity));
            fields.push(f(s.max_energy_error));
            fields.extend(metric_values.into_iter().map(&mut f));
        }
        Err(e) => {
            failed = true;
            let one_line: String = e.split_whitespace().collect::<Vec<_>>().join(" ");
            fields.push(format!("error: {one_line}"));
            fields.push(f(wall.as_secs_f64()));
            fields.extend(std::iter::repeat_n(String::new(), 3 + n_state + TAIL.len() + metrics.len()));
        }
    }
    (table::line(&fields), failed)
}

/// The directory of run `i`'s own output (`--save-runs`).
fn run_dir(out: &Path, i: u64, runs: u64) -> PathBuf {
    let width = runs.saturating_sub(1).max(1).to_string().len();
    out.join("runs").join(format!("{i:0width$}"))
}

/// Creates directory `dir` if it is missing, and checks that it is a
/// directory and not a symbolic link (a link planted at `OUT/runs` or
/// `OUT/runs/RUN` would have a run write wherever it points).
///
/// # Errors
/// `dir` is a link or not a directory, or cannot be created; the message
/// names it.
fn real_dir(dir: &Path) -> Result<(), String> {
    if let Err(e) = std::fs::create_dir(dir)
        && e.kind() != std::io::ErrorKind::AlreadyExists
    {
        return Err(format!("cannot create {}: {e}", dir.display()));
    }
    let meta = std::fs::symlink_metadata(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    if meta.file_type().is_symlink() {
        return Err(format!(
            "{} is a symbolic link; ezy never follows links in its output directory (remove it)",
            dir.display()
        ));
    }
    if !meta.is_dir() {
        return Err(format!(
            "{} is not a directory; --save-runs writes each run's output there (remove it)",
            dir.display()
        ));
    }
    Ok(())
}

/// Runs `job` on `proto`, a model at its defaults (what [`crate::App`] calls for the model
/// the scene names): checks everything first, then runs the runs not yet
/// in `sweep.csv` on `job.jobs` threads (at most one per core) and appends their rows in run
/// order, then draws the figures.
///
/// # Errors
/// [`SweepError::Failed`] for bad input (an unknown name, a metric's
/// missing column, a window outside the run, a directory holding another
/// sweep) before any run, or a failed write; [`SweepError::Interrupted`]
/// if a signal stopped it.
pub(crate) fn sweep_model<M: Model>(proto: &M, job: &SweepJob) -> Result<SweepReport, SweepError> {
    let checked = check(proto, job)?;
    if job.check_only {
        return Ok(SweepReport::default());
    }
    let header = columns(&job.plan, &checked.state, &job.metrics);
    let runs = job.plan.runs();
    let (k0, stride) = job.shard.unwrap_or((0, 1));
    let positions = if runs > k0 { (runs - k0).div_ceil(stride) } else { 0 };
    crate::output::transaction::arm_signals();
    let mut out = open_table(job, &header)?;
    let done_before = out.done;
    if job.save_runs {
        real_dir(&job.out.join("runs"))?;
    }
    let todo = positions - done_before;
    // never more threads than cores, whatever the caller asked
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let jobs = job.jobs.clamp(1, cores);
    let shared = Shared {
        proto,
        job,
        settings: &checked.settings,
        order: Mutex::new((0, 0, out.done_cursor()?)),
        stop: AtomicBool::new(false),
        state_at: checked.state.iter().enumerate().map(|(k, n)| (n.clone(), k)).collect(),
        n_state: checked.state.len(),
        shard: (k0, stride),
        positions,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .thread_name(|k| format!("ezy-sweep-{k}"))
        .build()
        .map_err(|e| format!("cannot start {jobs} threads: {e}"))?;
    let progress = job.progress.then(|| Counter::new(todo, &job.scene.name));
    let start = Instant::now();
    let (tx, rx) = std::sync::mpsc::channel::<(u64, Outcome)>();
    let mut report = SweepReport { runs: positions, done_before, jobs, ..SweepReport::default() };
    let (interrupted, write_error) = pool.in_place_scope(|scope| {
        // the workers render their notes and errors as this thread does
        let spelling = ezy_core::Spelling::current();
        for _ in 0..jobs {
            let (tx, shared) = (tx.clone(), &shared);
            scope.spawn(move |_| spelling.scope(|| shared.work(&tx)));
        }
        drop(tx);
        collect(rx, &mut out, &mut report, progress.as_ref(), &shared.stop)
    });
    report.wall = start.elapsed();
    if let Some(p) = progress {
        p.finish();
    }
    out.finish()?;
    if let Some(e) = write_error {
        return Err(SweepError::Failed(e));
    }
    if let Some(signal) = interrupted.or_else(crate::output::transaction::pending) {
        return Err(SweepError::Interrupted(Interrupted {
            signal,
            dir: job.out.clone(),
            t: None,
            doing: Some(format!("running the sweep ({} of {todo} runs finished)", report.ran)),
            kept: Some(format!(
                "their rows are in {}; the same command resumes the sweep",
                job.out.join(table::CSV).display()
            )),
        }));
    }
    report.files.push(out.csv_path());
    if job.figures && job.shard.is_none() {
        let look = job.opts.look(&job.scene);
        let (files, notes) = figure::draw(&job.out, &job.plan, &job.metrics, &proto.clone().info(), look)?;
        report.files.extend(files);
        report.notes.extend(notes);
    }
    Ok(report)
}

/// `sweep.csv` opened (created, or its rows done before read back) for
/// `job` with the columns `header`; a signal while it reads is an
/// interruption that keeps the rows.
fn open_table(job: &SweepJob, header: &[String]) -> Result<table::Output, SweepError> {
    table::Output::open(&job.out, &job.manifest, header, &job.plan, job.shard).map_err(|e| {
        match crate::output::transaction::pending() {
            Some(signal) => SweepError::Interrupted(Interrupted {
                signal,
                dir: job.out.clone(),
                t: None,
                doing: Some("checking the rows already done".into()),
                kept: Some(format!(
                    "the rows in {} are kept; the same command resumes the sweep",
                    job.out.join(table::CSV).display()
                )),
            }),
            None => SweepError::Failed(e),
        }
    })
}

/// What the sweep's threads share.
struct Shared<'a, M: Model> {
    proto: &'a M,
    job: &'a SweepJob,
    settings: &'a ezy_core::RunSettings,
    /// The next position among this shard's runs, the next row's place
    /// in the order of rows, and the runs done before.
    order: Mutex<(u64, u64, table::DoneCursor)>,
    /// Set when the rows cannot be written: the threads stop.
    stop: AtomicBool,
    /// The column of each state component.
    state_at: HashMap<String, usize>,
    n_state: usize,
    /// This shard's runs, `K + p N` for `(K, N)`, and how many.
    shard: (u64, u64),
    positions: u64,
}

impl<M: Model> Shared<'_, M> {
    /// The next run not yet done, and its place in the order of rows.
    fn next(&self) -> Option<(u64, u64)> {
        let (k0, stride) = self.shard;
        let mut d = self.order.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let (pos, seq, cursor) = &mut *d;
        while *pos < self.positions {
            // many runs done before are passed within a second of a signal
            if *pos % 4096 == 0 && crate::output::transaction::pending().is_some() {
                break;
            }
            let i = k0 + *pos * stride;
            *pos += 1;
            if !cursor.is_done(i) {
                let found = (*seq, i);
                *seq += 1;
                return Some(found);
            }
        }
        None
    }

    /// A thread's work: the next run, until none is left, a signal
    /// arrives or the rows cannot be written; each run's outcome sent to
    /// `tx` with its place in the order of rows.
    fn work(&self, tx: &std::sync::mpsc::Sender<(u64, Outcome)>) {
        let job = self.job;
        let mut values = Vec::new();
        loop {
            if self.stop.load(Ordering::SeqCst) || crate::output::transaction::pending().is_some() {
                return;
            }
            let Some((seq, i)) = self.next() else { return };
            job.plan.values_into(i, &mut values);
            let opts = RunOptions { sets: run_sets(job, &values), ..job.opts.clone() };
            let save = job.save_runs.then(|| run_dir(&job.out, i, job.plan.runs()));
            let t = Instant::now();
            let outcome = match save.as_deref().map(real_dir).transpose() {
                Err(e) => Outcome::Unusable(e),
                Ok(_) => match one_run(self.proto, job, self.settings, &opts, save) {
                    Err(Err(signal)) => Outcome::Interrupted(signal),
                    r => {
                        let wall = t.elapsed();
                        let r = r.map_err(|e| e.unwrap_or_else(|_| unreachable!("signals handled above")));
                        let (line, failed) = row_line(i, &values, r, wall, &self.state_at, self.n_state, &job.metrics);
                        Outcome::Row { run: i, line, failed, wall }
                    }
                },
            };
            if tx.send((seq, outcome)).is_err() {
                return;
            }
        }
    }
}

/// Appends the runs' rows to `out` in run order as their outcomes arrive
/// (a finished run waits for the ones before it, at most one less than
/// the threads), counted into `report` and `progress`; at a signal or a
/// row that cannot be written it sets `stop` and writes no more. Returns
/// the signal, or why the rows could not be written.
fn collect(
    rx: std::sync::mpsc::Receiver<(u64, Outcome)>,
    out: &mut table::Output,
    report: &mut SweepReport,
    progress: Option<&Counter>,
    stop: &AtomicBool,
) -> (Option<crate::output::transaction::Signal>, Option<String>) {
    let mut interrupted = None;
    let mut write_error = None;
    let mut pending: BTreeMap<u64, Outcome> = BTreeMap::new();
    let mut next = 0u64;
    for (seq, outcome) in rx {
        pending.insert(seq, outcome);
        while interrupted.is_none()
            && write_error.is_none()
            && let Some(o) = pending.remove(&next)
        {
            match o {
                Outcome::Row { run, line, failed, wall } => {
                    if let Err(e) = out.append(run, &line) {
                        write_error = Some(e);
                        stop.store(true, Ordering::SeqCst);
                        break;
                    }
                    report.ran += 1;
                    report.failed += u64::from(failed);
                    report.busy += wall;
                    if let Some(p) = progress {
                        p.inc(report.ran, report.failed);
                    }
                }
                Outcome::Interrupted(s) => {
                    interrupted = Some(s);
                    stop.store(true, Ordering::SeqCst);
                }
                Outcome::Unusable(e) => {
                    write_error = Some(e);
                    stop.store(true, Ordering::SeqCst);
                }
            }
            next += 1;
        }
    }
    (interrupted, write_error)
}

/// Progress over runs: a bar with the rate and the time left on a
/// terminal, a line every few seconds otherwise.
struct Counter {
    bar: Option<indicatif::ProgressBar>,
    beat: Option<crate::output::progress::Heartbeat>,
    total: u64,
    scene: String,
}

impl Counter {
    fn new(total: u64, scene: &str) -> Self {
        use std::io::IsTerminal;
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(total);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} runs ({msg}), {per_sec}, {elapsed} elapsed, ~{eta} left",
                )
                .expect("static template"),
            );
            bar.set_message("0 failed");
            Self { bar: Some(bar), beat: None, total, scene: scene.into() }
        } else {
            let beat = crate::output::progress::Heartbeat::start(format!("sweep {scene}: 0 of {total} runs"));
            Self { bar: None, beat: Some(beat), total, scene: scene.into() }
        }
    }

    fn inc(&self, done: u64, failed: u64) {
        if let Some(bar) = &self.bar {
            bar.set_position(done);
            bar.set_message(format!("{failed} failed"));
        }
        if let Some(b) = &self.beat {
            b.set(format!("sweep {}: {done} of {} runs ({failed} failed)", self.scene, self.total));
        }
    }

    fn finish(self) {
        if let Some(bar) = self.bar {
            bar.finish_and_clear();
        }
    }
}

/// FNV-1a (64 bit) of `text`, as 16 hex digits: the scene text's
/// fingerprint in `sweep.toml`.
pub(crate) fn fingerprint(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}
