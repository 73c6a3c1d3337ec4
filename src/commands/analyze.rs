//! `ezy analyze` and `ezy linearize`: the library's analyses
//! ([`ezy_core::analysis`]) on a scene, written as CSV tables and figures.
//!
//! `analyze` decides from the scene what it can ask: a scene whose forces
//! do not change with time has steady motions (relative equilibria, or
//! equilibria of a mechanism), a scene driven periodically has periodic
//! orbits. The guesses come from the scene itself: its consistent start
//! and the state its own run ends in (a settled run ends near a stable
//! solution). `--continue NAME=START:STOP:COUNT` follows the solution as a
//! parameter varies (the same `NAME=...` as `--set` and `ezy sweep`).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use ezy_core::analysis::{
    Analysis, AnalysisError, BranchPoint, Follow, Input, PeriodicOrbit, PeriodicSettings, Solution, Stability,
    SteadyMotion, Symmetry, c64,
};
use ezy_core::effects::Periodicity;
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

use super::run::{self, Error, RunOptions};
use crate::plot::{Chart, Series, Stroke};
use crate::transaction::Transaction;

/// States of the scene's run that are guesses (evenly spaced, the end last).
const GUESSES: u32 = 8;

/// Most parameter values a continuation may take.
pub const MAX_CONTINUATION: u64 = 10_000;

/// What `ezy analyze` is asked.
#[derive(Debug, Clone, Default)]
pub struct AnalyzeOptions {
    /// Output directory, overrides, figure settings; `t_end` is the length
    /// of the run whose end state is a guess.
    pub run: RunOptions,
    /// The forcing period \[s\] (`None`: from the scene's waveforms).
    pub period: Option<f64>,
    /// The kinetic energy \[J\] of the steady motions sought (`None`: the
    /// guess's own for a scene without effects and drives, free otherwise).
    pub energy: Option<f64>,
    /// A parameter to follow the first solution through: its name and values.
    pub continuation: Option<(String, Vec<f64>)>,
}

/// What `ezy analyze` found.
#[derive(Debug, Clone)]
pub struct AnalyzeReport {
    /// The scene's symmetry.
    pub symmetry: Symmetry,
    /// The model's coordinates (the names of its cyclic ones' rates).
    pub coords: Vec<String>,
    /// The steady motions found (distinct), for a time-independent scene.
    pub steady: Vec<SteadyMotion>,
    /// The periodic orbit, for a periodically driven scene.
    pub periodic: Option<PeriodicOrbit>,
    /// The branch, with `--continue`.
    pub branch: Vec<BranchPoint>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// What took how long.
    pub timings: Vec<(String, Duration)>,
    /// Notes for the user (a guess that led nowhere, the end of a branch).
    pub notes: Vec<String>,
}

/// The analysis of `scene` with the overrides `sets` and its consistent
/// initial state.
fn build<M: Model>(proto: &M, scene: &Scene, sets: &[(String, f64)]) -> Result<(Analysis<M>, Vec<f64>), Error> {
    let (problem, _) = scene.problem_with(proto.clone(), sets)?;
    let (mut an, x0) = problem.analysis()?;
    // a model too large for the dense matrices is refused before any run
    an.check_size().map_err(|e| Error::Input(e.to_string()))?;
    an.stop_when(|| crate::transaction::pending().is_some());
    Ok((an, x0))
}

/// The stop event that ended a run early, and its time \[s\].
type Stopped = Option<(String, f64)>;

/// The states `[q, qd]` of a run of the scene (its own settings,
/// overridden by `opts`) to `t_end` \[s\] at `samples` evenly spaced
/// times, the start excluded and the end last (the stop's state where a
/// stop event ended it, with its name and time); a signal stops it within
/// a step.
fn run_to<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    t_end: f64,
    samples: u32,
) -> Result<(Vec<Vec<f64>>, Stopped), Error> {
    let mut settings = run::settings(scene, opts)?;
    settings.t_end = t_end;
    settings.every = t_end / f64::from(samples);
    let (problem, _) = run::problem(proto, scene, opts, settings)?;
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
    type Error = crate::transaction::TransactionError;
    fn observe(&mut self, _sys: &ezy_core::Dynamics<M>, s: &ezy_core::Sample<'_>) -> Result<(), Self::Error> {
        self.x.push([s.q, s.qd].concat());
        Ok(())
    }
    fn poll(&mut self, t: f64) -> Result<(), Self::Error> {
        crate::transaction::check_interrupt(&self.dir, Some(t), Some("running the scene for a guess".into()))
    }
}

/// The command's error for an analysis' error, `dir` the output directory.
fn analysis_error(dir: &std::path::Path) -> impl Fn(AnalysisError) -> Error + '_ {
    move |e| match e {
        AnalysisError::Sim(e) => Error::Sim(e),
        AnalysisError::Stopped => match crate::transaction::check_interrupt(dir, None, Some("analysing".into())) {
            Err(i) => Error::Transaction(i),
            Ok(()) => Error::Input("the analysis was stopped".into()),
        },
        e => Error::Input(e.to_string()),
    }
}

/// `ezy analyze` on `proto`, a model at its defaults.
///
/// # Errors
/// [`Error::Input`] when the scene has neither steady motions nor a known
/// period, or no search converged; the setup's errors; the output's.
pub fn analyze_model<M: Model>(proto: &M, scene: &Scene, opts: &AnalyzeOptions) -> Result<AnalyzeReport, Error> {
    let ro = &opts.run;
    let settings = run::settings(scene, ro)?;
    if let Some(p) = opts.period
        && !(p.is_finite() && p > 0.0)
    {
        return Err(Error::Input(format!("--period {p}: the period must be a positive number of seconds")));
    }
    // the orbit is integrated from t_end over one period: a period below
    // 1e-9 of that time is within 2e-7 of its rounding (eps t), coarser
    // than the shooting's tolerance (1e-9 of the state)
    if let Some(p) = opts.period
        && p < MIN_PERIOD * settings.t_end.max(1.0)
    {
        return Err(Error::Input(format!(
            "--period {}: a periodic orbit is sought from t = {} s (the scene's t_end), and a period below {:.1e} s there is within the time's rounding; give a longer period",
            fmt_value(p),
            fmt_value(settings.t_end),
            MIN_PERIOD * settings.t_end.max(1.0)
        )));
    }
    if let Some(e) = opts.energy
        && !(e.is_finite() && e > 0.0)
    {
        return Err(Error::Input(format!("--energy {e}: the kinetic energy must be a positive number of joules")));
    }
    let (mut an, x0) = build(proto, scene, &ro.sets)?;
    if let Some(e) = opts.energy {
        // the speed it stands for, on all the bodies' mass at once
        let mass: f64 = an.dynamics().mass.iter().step_by(3).sum();
        let v = (2.0 * e / mass).sqrt();
        if v.is_nan() || v < NEAR_REST {
            return Err(Error::Input(format!(
                "--energy {}: the scene would move at about {v:.1e} m/s, below the {} m/s from which the search tells a motion from rest (give a larger energy)",
                fmt_value(e),
                fmt_value(NEAR_REST)
            )));
        }
    }
    // the continuation's parameter is checked before anything is written
    // (its ends: a parameter that sizes a family changes the state, which
    // a branch of one model cannot follow)
    if let Some((name, values)) = &opts.continuation {
        for &value in [values[0], values[values.len() - 1]].iter() {
            let mut sets = ro.sets.clone();
            sets.push((name.clone(), value));
            let (other, _) = build(proto, scene, &sets).map_err(|e| Error::Input(format!("--continue {name}: {e}")))?;
            if other.nq() != an.nq() {
                return Err(Error::Input(format!(
                    "--continue {name}: at {name} = {value} the model has {} coordinates against {} at the start: a branch follows one model, so continue in a parameter that keeps its size",
                    other.nq(),
                    an.nq()
                )));
            }
        }
    }
    Transaction::preflight(&ro.out)?;
    let mut timings = Vec::new();
    let mut notes = Vec::new();
    let clock = Instant::now();
    let symmetry = an.symmetry(0.0, &x0).map_err(analysis_error(&ro.out))?;
    let period = match (opts.period, an.forcing()) {
        // a periodic orbit of a forced scene repeats with a whole number
        // of the forcing's periods
        (Some(p), Some(Periodicity::Period(forcing))) => {
            let m = p / forcing;
            if m < 0.5 || (m - m.round()).abs() > 1e-9 * m {
                return Err(Error::Input(format!(
                    "--period {p}: scene `{}` is forced with period {} s, and a periodic orbit repeats with a whole number of them ({} s, {} s, ...)",
                    scene.name,
                    fmt_value(forcing),
                    fmt_value(forcing),
                    fmt_value(2.0 * forcing)
                )));
            }
            Some(p)
        }
        (Some(p), _) => Some(p),
        (None, Some(Periodicity::Constant)) => None,
        (None, Some(Periodicity::Period(p))) => Some(p),
        (None, Some(Periodicity::Aperiodic)) => {
            return Err(Error::Input(format!(
                "scene `{}` is driven by a table or spline in time: it has neither steady motions nor a period; give --period if it repeats",
                scene.name
            )));
        }
        (None, None) => {
            // at several times no ratio of which is simple: a law forced
            // with one of these offsets as its period still shows
            let a = an.rhs(0.0, &x0).map_err(analysis_error(&ro.out))?;
            let mut changes = false;
            for offset in [0.7391, 0.0531, 2.1913, 13.371] {
                let b = an.rhs(offset, &x0).map_err(analysis_error(&ro.out))?;
                changes |= a.iter().zip(&b).any(|(u, v)| (u - v).abs() > 1e-10 * (1.0 + u.abs()));
            }
            if changes {
                return Err(Error::Input(format!(
                    "scene `{}` changes with time through a force law of its own, whose period ezy cannot see: give --period",
                    scene.name
                )));
            }
            None
        }
    };
    // a line every few seconds of a long analysis (a stiff scene's run
    // and searches take minutes)
    let beat = ro.progress.then(|| {
        crate::progress::Heartbeat::start(format!(
            "analyze {}: running the scene to t = {} s for guesses",
            scene.name,
            fmt_value(settings.t_end)
        ))
    });
    let (samples, _) = run_to(proto, scene, ro, settings.t_end, GUESSES)?;
    let end = samples.last().cloned().unwrap_or_else(|| x0.clone());
    timings.push((format!("run to t = {} s for a guess", fmt_value(settings.t_end)), clock.elapsed()));
    let conservative = an.dynamics().effects.is_empty() && an.dynamics().drives.is_empty();
    let energy_of = |an: &Analysis<M>, x: &[f64]| {
        opts.energy.or_else(|| conservative.then(|| an.dynamics().kinetic_energy(&x[x.len() / 2..])))
    };
    let (mut steady, mut periodic) = (Vec::new(), None);
    let follow;
    match period {
        None => {
            // the start, the end, then the run's other samples; an
            // equilibrium (no symmetry) is at rest: the samples' positions
            let nq = x0.len() / 2;
            let rest = |x: &Vec<f64>| {
                if symmetry == Symmetry::NONE { [&x[..nq], &vec![0.0; nq][..]].concat() } else { x.clone() }
            };
            let mut guesses =
                vec![("the scene's start".to_string(), x0.clone()), ("the end of its run".to_string(), rest(&end))];
            let every = settings.t_end / f64::from(GUESSES);
            for (k, x) in samples.iter().enumerate().rev().skip(1) {
                guesses.push((format!("its run at t = {} s", fmt_value(every * (k + 1) as f64)), rest(x)));
            }
            let angles: Vec<usize> = an.dynamics().info.bodies.iter().map(|b| b.coords[2]).collect();
            let mut failed: Vec<(String, String)> = Vec::new();
            let clock = Instant::now();
            // the run's speed: a motion found far below it is rest to the
            // search's resolution ([`NEAR_REST`])
            let speed_of = |x: &[f64]| x[nq..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let run_speed = guesses.iter().map(|(_, x)| speed_of(x)).fold(0.0f64, f64::max);
            let rest_below = NEAR_REST * (1.0 + run_speed).sqrt();
            let mut near_rest = Vec::new();
            for (k, (label, guess)) in guesses.iter().enumerate() {
                if let Some(b) = &beat {
                    b.set(format!(
                        "analyze {}: searching for a steady motion from {label} ({} of {})",
                        scene.name,
                        k + 1,
                        guesses.len()
                    ));
                }
                let energy = energy_of(&an, guess);
                match an.steady_motion(0.0, guess, symmetry, energy) {
                    Ok(s) if symmetry != Symmetry::NONE && speed_of(&s.state) < rest_below => {
                        near_rest.push(speed_of(&s.state));
                    }
                    Ok(s) => {
                        if !steady.iter().any(|o: &SteadyMotion| same_motion(o, &s, &angles)) {
                            steady.push(s);
                        }
                    }
                    Err(AnalysisError::Sim(e)) => return Err(Error::Sim(e)),
                    Err(e) => failed.push((label.clone(), e.to_string())),
                }
            }
            timings.push((format!("{} searches for steady motions", guesses.len()), clock.elapsed()));
            // the guesses that failed alike, once
            let mut grouped: Vec<(Vec<String>, String)> = Vec::new();
            for (label, why) in failed {
                match grouped.iter_mut().find(|(_, w)| *w == why) {
                    Some((labels, _)) => labels.push(label),
                    None => grouped.push((vec![label], why)),
                }
            }
            for (labels, why) in grouped {
                let from = match labels.len() {
                    1 => labels[0].clone(),
                    n => format!("{} and {} other guesses", labels[0], n - 1),
                };
                notes.push(format!("from {from}: {why}"));
            }
            if !near_rest.is_empty() {
                notes.push(format!(
                    "{} searches ended at speeds below {:.1e} m/s (at most {:.1e} m/s), where the search cannot tell a steady motion from any slow state: rest, to its resolution, and not listed",
                    near_rest.len(),
                    rest_below,
                    near_rest.iter().fold(0.0f64, |m, &v| m.max(v))
                ));
            }
            if steady.is_empty() {
                return Err(Error::Input(format!(
                    "no steady motion of scene `{}` was found: {}",
                    scene.name,
                    notes.join("; ")
                )));
            }
            follow = Follow::Steady { energy: energy_of(&an, &steady[0].state) };
        }
        Some(p) => {
            let clock = Instant::now();
            let t0 = settings.t_end;
            // `--max-steps` bounds each period's integration (the advice of
            // a budget error names it)
            let ps = PeriodicSettings {
                max_steps: ro.max_steps.unwrap_or(PeriodicSettings::default().max_steps),
                ..PeriodicSettings::default()
            };
            if let Some(b) = &beat {
                b.set(format!("analyze {}: searching for the periodic orbit of period {} s", scene.name, fmt_value(p)));
            }
            let orbit = an.periodic_orbit(t0, p, &end, symmetry, &ps).map_err(analysis_error(&ro.out))?;
            timings.push(("periodic orbit".into(), clock.elapsed()));
            follow = Follow::Periodic { t0, period: p, settings: ps };
            periodic = Some(orbit);
        }
    }
    drop(beat);
    let mut branch = Vec::new();
    if let Some((name, values)) = &opts.continuation {
        let clock = Instant::now();
        let start = steady
            .first()
            .map_or_else(|| periodic.as_ref().map(|p| p.state.clone()).unwrap_or_default(), |s| s.state.clone());
        let beat = ro.progress.then(|| crate::progress::Heartbeat::start(format!("following the branch in {name}")));
        let (points, ended) = ezy_core::analysis::branch::follow(
            values,
            &start,
            follow,
            |v| {
                // a signal ends the branch at the next point
                if crate::transaction::pending().is_some() {
                    return Err(AnalysisError::Request { reason: "stopped by a signal".into() });
                }
                let mut sets = ro.sets.clone();
                sets.push((name.clone(), v));
                build(proto, scene, &sets).map(|(a, _)| a).map_err(|e| match e {
                    Error::Sim(e) => AnalysisError::Sim(e),
                    e => AnalysisError::Request { reason: e.to_string() },
                })
            },
            |k| {
                if let Some(b) = &beat {
                    b.set(format!("following the branch in {name}: point {} of {}", k + 1, values.len()));
                }
            },
        );
        drop(beat);
        crate::transaction::check_interrupt(&ro.out, None, Some(format!("following the branch in {name}")))?;
        if let Some((v, e)) = ended {
            notes.push(format!("the branch ends at {name} = {}: {e}", fmt_value(v)));
        }
        for w in points.windows(2) {
            if w[0].solution.stability() != w[1].solution.stability() {
                notes.push(format!(
                    "stability changes between {name} = {} ({}) and {} ({})",
                    fmt_value(w[0].value),
                    w[0].solution.stability().name(),
                    fmt_value(w[1].value),
                    w[1].solution.stability().name()
                ));
            }
        }
        timings.push((format!("branch of {} points", points.len()), clock.elapsed()));
        branch = points;
    }

    // the output is a transaction: all files or none, and none of an
    // earlier analysis left beside them
    let mut tx = Transaction::begin(&ro.out)?;
    let mut own: Vec<String> = ["equilibria.csv", "periodic.csv", "branch.csv"].map(String::from).to_vec();
    for stem in ["eigenvalues", "multipliers", "branch"] {
        own.extend(ezy_scene::FigureFormat::ALL.iter().map(|f| f.file_name(stem)));
    }
    tx.retire(&own);
    let names = an.state_names();
    let shape = shape_columns(&an);
    let (format, dpi) = ro.look(scene);
    let mut figures: Vec<(String, Chart)> = Vec::new();
    if !steady.is_empty() {
        tx.write("equilibria.csv", steady_csv(&steady, &names, &shape).as_bytes())?;
        let mut chart = Chart::new("Eigenvalues of the steady motions", "Re lambda [1/s]", "Im lambda [1/s]");
        for (k, s) in steady.iter().enumerate() {
            chart.series.push(points_series(format!("motion {} ({})", k + 1, s.stability.name()), &s.eigenvalues));
        }
        figures.push(("eigenvalues".into(), chart));
    }
    if let Some(p) = &periodic {
        tx.write("periodic.csv", periodic_csv(p, &names, &shape).as_bytes())?;
        let mut chart = Chart::new("Floquet multipliers of the periodic orbit", "Re mu", "Im mu");
        let circle =
            (0..=200).map(|k| (k as f64 * std::f64::consts::TAU / 200.0).sin_cos()).map(|(s, c)| (c, s)).collect();
        chart.series.push(Series { stroke: Stroke::Solid, ..Series::new("unit circle", circle) });
        chart.series.push(points_series(format!("multipliers ({})", p.stability.name()), &p.multipliers));
        chart.equal_axes = true;
        chart.path_ends = false;
        figures.push(("multipliers".into(), chart));
    }
    if let Some((name, _)) = &opts.continuation
        && !branch.is_empty()
    {
        tx.write("branch.csv", branch_csv(name, &branch, &names, &shape).as_bytes())?;
        let speed = if periodic.is_some() { "mean speed [m/s]" } else { "speed [m/s]" };
        let mut chart = Chart::new(format!("Branch in {name}: solid stable, dashed not"), name.clone(), speed);
        for (label, stable) in [("stable", true), ("unstable or neutral", false)] {
            let pts = branch
                .iter()
                .map(|b| {
                    (
                        b.value,
                        if (b.solution.stability() == Stability::Stable) == stable {
                            b.solution.speed()
                        } else {
                            f64::NAN
                        },
                    )
                })
                .collect();
            chart.series.push(Series {
                stroke: if stable { Stroke::Solid } else { Stroke::Dash(0) },
                ..Series::new(label, pts)
            });
        }
        figures.push(("branch".into(), chart));
    }
    if ro.figures {
        for (stem, chart) in &figures {
            tx.check(None, Some(format!("drawing {stem}")))?;
            let bytes =
                crate::plot::figure(chart, format, dpi).map_err(|e| Error::Input(format!("figure {stem}: {e}")))?;
            tx.write(&format.file_name(stem), &bytes)?;
        }
    }
    let files = tx.commit()?;
    let coords = an.dynamics().info.coords.clone();
    Ok(AnalyzeReport { symmetry, coords, steady, periodic, branch, files, timings, notes })
}

/// Shortest `--period`, as a fraction of the time `t0 = t_end` (at least
/// 1 s) the orbit is sought from: there the time's rounding `eps t0` is
/// 2.2e-7 of the period, above the shooting's tolerance (1e-9 relative).
const MIN_PERIOD: f64 = 1e-9;

/// Slowest speed \[m/s\] a steady motion is told from rest at: the
/// search stops at an absolute residual of `1e-12 (1 + |x| + |f|)`
/// (m/s^2 in the accelerations), while the accelerations that make a
/// motion steady (centripetal, Coriolis) grow as `v^2`; below `v =
/// sqrt(1e-12 / 1e-6) = 1e-3` m/s (times `sqrt(1 + |x| + |f|)`) they are
/// resolved to worse than the `1e-6` to which motions are told apart
/// ([`same_state`]), and any slow state passes as steady. A `--energy`
/// standing for less is refused; a motion found slower than
/// `NEAR_REST sqrt(1 + V)` (`V` the run's speed) is rest, not listed.
const NEAR_REST: f64 = 1e-3;

/// Whether two steady motions are one: the same normalized state
/// ([`same_state`]) or, in a family of motions (a free speed), the same
/// state with the velocities divided by their largest (one motion at
/// another speed: a straight run at 2.161999 m/s and at 2.161984 m/s).
fn same_motion(a: &SteadyMotion, b: &SteadyMotion, angles: &[usize]) -> bool {
    if same_state(&a.state, &b.state, angles) {
        return true;
    }
    if a.family == 0 || b.family == 0 || a.stability != b.stability {
        return false;
    }
    let nq = a.state.len() / 2;
    let unit = |x: &[f64]| {
        let v = x[nq..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut u = x.to_vec();
        if v > 0.0 {
            u[nq..].iter_mut().for_each(|c| *c /= v);
        }
        u
    };
    same_state(&unit(&a.state), &unit(&b.state), angles)
}

/// Whether two normalized states are one solution (to 1e-6 relative),
/// headings (indices `angles`) compared modulo a turn.
fn same_state(a: &[f64], b: &[f64], angles: &[usize]) -> bool {
    let scale = 1.0 + a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).enumerate().all(|(i, (x, y))| {
        let d = if angles.contains(&i) { wrap(x - y) } else { x - y };
        d.abs() < 1e-6 * scale
    })
}

/// The shape columns: each hinge between two bodies, its angle
/// `theta_<H> = phi_a - phi_b` wrapped to (-pi, pi] \[rad\], with the
/// headings' indices.
fn shape_columns<M: Model>(an: &Analysis<M>) -> Vec<(String, usize, usize)> {
    let info = &an.dynamics().info;
    info.hinges
        .iter()
        .filter_map(|h| {
            h.body_b.map(|b| (format!("theta_{}", h.name), info.bodies[h.body_a].coords[2], info.bodies[b].coords[2]))
        })
        .collect()
}

fn wrap(angle: f64) -> f64 {
    let a = angle.rem_euclid(std::f64::consts::TAU);
    if a > std::f64::consts::PI { a - std::f64::consts::TAU } else { a }
}

/// A number for a CSV cell: the shortest decimal that reads back as the
/// same number, as in every CSV file ezy writes.
fn num(v: f64) -> String {
    crate::output::format_number(&mut zmij::Buffer::new(), v).to_string()
}

fn shape_cells(shape: &[(String, usize, usize)], x: &[f64]) -> Vec<String> {
    shape.iter().map(|(_, a, b)| num(wrap(x[*a] - x[*b]))).collect()
}

fn spectrum_cells(values: &[c64]) -> Vec<String> {
    values.iter().flat_map(|z| [num(z.re), num(z.im)]).collect()
}

fn spectrum_header(letter: &str, n: usize) -> Vec<String> {
    (1..=n).flat_map(|k| [format!("{letter}{k}_re"), format!("{letter}{k}_im")]).collect()
}

/// One CSV record, quoted where a cell needs it (a parameter name given
/// on the command line).
fn row(cells: Vec<String>) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    // writing to memory cannot fail
    let _ = w.write_record(&cells);
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// `equilibria.csv`: one row per steady motion.
pub fn steady_csv(steady: &[SteadyMotion], names: &[String], shape: &[(String, usize, usize)]) -> String {
    let n = steady.first().map_or(0, |s| s.eigenvalues.len());
    let mut head: Vec<String> =
        ["motion", "stability", "family", "u", "v", "omega", "speed", "curvature"].map(String::from).to_vec();
    head.extend(shape.iter().map(|s| s.0.clone()));
    head.extend(names.iter().cloned());
    head.extend(spectrum_header("lambda", n));
    let mut out = row(head);
    for (k, s) in steady.iter().enumerate() {
        let [u, v, w] = s.body_velocity;
        let mut cells = vec![
            (k + 1).to_string(),
            s.stability.name().into(),
            s.family.to_string(),
            num(u),
            num(v),
            num(w),
            num(s.speed()),
            num(s.curvature()),
        ];
        cells.extend(shape_cells(shape, &s.state));
        cells.extend(s.state.iter().map(|v| num(*v)));
        cells.extend(spectrum_cells(&s.eigenvalues));
        out.push_str(&row(cells));
    }
    out
}

/// `periodic.csv`: the orbit in one row.
pub fn periodic_csv(p: &PeriodicOrbit, names: &[String], shape: &[(String, usize, usize)]) -> String {
    let mut head: Vec<String> =
        ["period", "t0", "stability", "family", "mean_speed", "mean_forward_speed", "dx", "dy", "dheading"]
            .map(String::from)
            .to_vec();
    head.extend(shape.iter().map(|s| s.0.clone()));
    head.extend(names.iter().cloned());
    head.extend(spectrum_header("mu", p.multipliers.len()));
    let mut cells = vec![
        num(p.period),
        num(p.t0),
        p.stability.name().into(),
        p.family.to_string(),
        num(p.mean_speed()),
        num(p.mean_forward_speed()),
        num(p.displacement[0]),
        num(p.displacement[1]),
        num(p.heading_change),
    ];
    cells.extend(shape_cells(shape, &p.state));
    cells.extend(p.state.iter().map(|v| num(*v)));
    cells.extend(spectrum_cells(&p.multipliers));
    row(head) + &row(cells)
}

/// `branch.csv`: one row per parameter value.
pub fn branch_csv(name: &str, branch: &[BranchPoint], names: &[String], shape: &[(String, usize, usize)]) -> String {
    let (letter, n) = match &branch[0].solution {
        Solution::Steady(s) => ("lambda", s.eigenvalues.len()),
        Solution::Periodic(p) => ("mu", p.multipliers.len()),
    };
    let mut head: Vec<String> = vec![name.to_string(), "stability".into(), "speed".into()];
    if letter == "mu" {
        head.push("period".into());
    }
    head.extend(shape.iter().map(|s| s.0.clone()));
    head.extend(names.iter().cloned());
    head.extend(spectrum_header(letter, n));
    let mut out = row(head);
    for b in branch {
        let mut cells = vec![num(b.value), b.solution.stability().name().into(), num(b.solution.speed())];
        if let Solution::Periodic(p) = &b.solution {
            cells.push(num(p.period));
        }
        cells.extend(shape_cells(shape, b.solution.state()));
        cells.extend(b.solution.state().iter().map(|v| num(*v)));
        cells.extend(spectrum_cells(match &b.solution {
            Solution::Steady(s) => &s.eigenvalues,
            Solution::Periodic(p) => &p.multipliers,
        }));
        out.push_str(&row(cells));
    }
    out
}

fn points_series(label: String, values: &[c64]) -> Series {
    Series { stroke: Stroke::Points, ..Series::new(label, values.iter().map(|z| (z.re, z.im)).collect()) }
}

/// The text `ezy analyze` prints.
pub fn summary(scene: &str, r: &AnalyzeReport) -> String {
    let mut s = String::new();
    let sym: Vec<String> = r.symmetry.generators().iter().map(|g| g.name(&r.coords)).collect();
    let _ = writeln!(
        s,
        "scene {scene}: symmetry {}",
        if sym.is_empty() {
            "none (ordinary equilibria)".to_string()
        } else {
            format!("{} (steady motions relative to it)", sym.join(", "))
        }
    );
    for (k, m) in r.steady.iter().enumerate() {
        let ev: Vec<String> = m.eigenvalues.iter().map(|z| complex(*z)).collect();
        let _ = writeln!(
            s,
            "steady motion {}: {}, speed {} m/s, yaw rate {} rad/s, family {}; eigenvalues [1/s]: {}",
            k + 1,
            m.stability.name(),
            short(m.speed()),
            short(m.body_velocity[2]),
            m.family,
            ev.join(", ")
        );
    }
    if let Some(p) = &r.periodic {
        let mu: Vec<String> = p.multipliers.iter().map(|z| complex(*z)).collect();
        let _ = writeln!(
            s,
            "periodic orbit: period {} s, {}, mean speed {} m/s, displacement ({}, {}) m and heading change {} rad per period; multipliers: {}",
            fmt_value(p.period),
            p.stability.name(),
            short(p.mean_speed()),
            short(p.displacement[0]),
            short(p.displacement[1]),
            short(p.heading_change),
            mu.join(", ")
        );
    }
    for n in &r.notes {
        let _ = writeln!(s, "note: {n}");
    }
    for (what, d) in &r.timings {
        let _ = writeln!(s, "time: {what}: {:.3} s", d.as_secs_f64());
    }
    for f in &r.files {
        let _ = writeln!(s, "wrote {}", f.display());
    }
    s
}

fn short(v: f64) -> String {
    let v = if v.abs() < 1e-12 { 0.0 } else { v };
    format!("{}", (v * 1e6).round() / 1e6)
}

fn complex(z: c64) -> String {
    let (re, im) = (if z.re.abs() < 1e-12 { 0.0 } else { z.re }, if z.im.abs() < 1e-12 { 0.0 } else { z.im });
    if im == 0.0 { format!("{re:.6}") } else { format!("{re:.6}{}{:.6}i", if im < 0.0 { "-" } else { "+" }, im.abs()) }
}

/// What `ezy linearize` is asked.
#[derive(Debug, Clone, Default)]
pub struct LinearizeOptions {
    /// Output directory, overrides; `t_end` is ignored.
    pub run: RunOptions,
    /// The time \[s\] whose state (of the scene's run) is linearized about.
    pub at: f64,
    /// Inputs by column name: `tau_<hinge>`, `scale_<effect>`.
    pub inputs: Vec<String>,
}

/// What `ezy linearize` found and wrote.
#[derive(Debug, Clone)]
pub struct LinearizeReport {
    /// The linearization.
    pub linearization: ezy_core::analysis::Linearization,
    /// Eigenvalues on the constraint manifold.
    pub eigenvalues: Vec<c64>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Parses an input's column name (`tau_<hinge>`, `scale_<effect>`).
///
/// # Errors
/// A name of neither form.
pub fn parse_input(text: &str) -> Result<Input, String> {
    if let Some(h) = text.strip_prefix("tau_").filter(|h| !h.is_empty()) {
        Ok(Input::HingeTorque(h.into()))
    } else if let Some(e) = text.strip_prefix("scale_").filter(|e| !e.is_empty()) {
        Ok(Input::EffectScale(e.into()))
    } else {
        Err(format!("input `{text}`: write tau_HINGE (a torque at a hinge) or scale_EFFECT (an effect's force scaled)"))
    }
}

/// `ezy linearize` on `proto`, a model at its defaults: `A.csv`, `B.csv` (with inputs),
/// `eigenvalues.csv` and `state.csv`.
///
/// # Errors
/// A bad time or input, the setup's and the output's errors.
pub fn linearize_model<M: Model>(proto: &M, scene: &Scene, opts: &LinearizeOptions) -> Result<LinearizeReport, Error> {
    let ro = &opts.run;
    if !(opts.at.is_finite() && opts.at >= 0.0) {
        return Err(Error::Input(format!("--at {}: the time must be zero or a positive number of seconds", opts.at)));
    }
    let inputs = opts.inputs.iter().map(|i| parse_input(i)).collect::<Result<Vec<_>, _>>().map_err(Error::Input)?;
    let (mut an, x0) = build(proto, scene, &ro.sets)?;
    let x = if opts.at > 0.0 {
        let (mut x, stopped) = run_to(proto, scene, ro, opts.at, 1)?;
        // the state of a run that stopped short is not the state at --at
        if let Some((event, t)) = stopped.filter(|(_, t)| *t < opts.at) {
            return Err(Error::Input(format!(
                "--at {}: the run stops at the event `{event}` at t = {} s, before it; linearize at a time the run reaches",
                fmt_value(opts.at),
                fmt_value(t)
            )));
        }
        x.pop().unwrap_or(x0)
    } else {
        x0
    };
    let lin = an.linearize(opts.at, &x, &inputs).map_err(analysis_error(&ro.out))?;
    let eigenvalues = lin.eigenvalues().map_err(analysis_error(&ro.out))?;
    Transaction::preflight(&ro.out)?;
    let names = &lin.state_names;
    let matrix = |m: &ezy_core::faer::Mat<f64>, cols: &[String]| {
        let mut head = vec!["row".to_string()];
        head.extend(cols.iter().cloned());
        let mut out = row(head);
        for (i, name) in names.iter().enumerate() {
            let mut cells = vec![name.clone()];
            cells.extend((0..m.ncols()).map(|j| num(m[(i, j)])));
            out.push_str(&row(cells));
        }
        out
    };
    let mut tx = Transaction::begin(&ro.out)?;
    tx.retire(&["A.csv", "B.csv", "eigenvalues.csv", "state.csv"].map(String::from));
    tx.write("A.csv", matrix(&lin.a, names).as_bytes())?;
    if !inputs.is_empty() {
        tx.write("B.csv", matrix(&lin.b, &lin.input_names).as_bytes())?;
    }
    let mut ev = row(vec!["k".into(), "re".into(), "im".into()]);
    for (k, z) in eigenvalues.iter().enumerate() {
        ev.push_str(&row(vec![(k + 1).to_string(), num(z.re), num(z.im)]));
    }
    tx.write("eigenvalues.csv", ev.as_bytes())?;
    let mut st = row(vec!["name".into(), "value".into()]);
    for (n, v) in names.iter().zip(&lin.state) {
        st.push_str(&row(vec![n.clone(), num(*v)]));
    }
    tx.write("state.csv", st.as_bytes())?;
    let files = tx.commit()?;
    Ok(LinearizeReport { linearization: lin, eigenvalues, files })
}

/// The text `ezy linearize` prints.
pub fn linearize_summary(scene: &str, r: &LinearizeReport) -> String {
    let l = &r.linearization;
    let mut s = format!(
        "scene {scene} at t = {} s: A is {} x {}{}; on the constraint manifold ({} dimensions) the eigenvalues [1/s] are {}\n",
        fmt_value(l.t),
        l.a.nrows(),
        l.a.ncols(),
        if l.forces_by_differences {
            " (applied forces differentiated by central differences, the model's terms exactly)"
        } else {
            " (exact)"
        },
        l.tangent.ncols(),
        r.eigenvalues.iter().map(|z| complex(*z)).collect::<Vec<_>>().join(", ")
    );
    // at a moving state the eigenvalues are those of the world frame's
    // coordinates along the passing motion: no verdict on stability
    let nq = l.state.len() / 2;
    let speed = l.state[nq..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if speed > 0.0 {
        let _ = writeln!(
            s,
            "note: the state moves (largest velocity {} in q's units per second): A and its eigenvalues are those of the world frame's coordinates q, qd along the motion passing through it at t = {} s; they depend on the frame and say nothing of the stability of a steady motion or gait, which `ezy analyze` gives, modulo the plane's rigid motions",
            short(speed),
            fmt_value(l.t)
        );
    }
    for f in &r.files {
        let _ = writeln!(s, "wrote {}", f.display());
    }
    s
}
