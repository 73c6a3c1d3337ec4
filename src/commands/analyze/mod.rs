//! `ezy analyze [SCENE]`: the library's analyses ([`ezy_core::analysis`])
//! on a scene, written as CSV tables and figures.
//!
//! `analyze` decides from the scene what it can ask: a scene whose forces
//! do not change with time has steady motions (relative equilibria, or
//! equilibria of a mechanism), a scene driven periodically has periodic
//! orbits; a scene without steady motions whose run turns on a cycle
//! has a limit cycle. The guesses come from the scene itself: its consistent start
//! and the state its own run ends in (a settled run ends near a stable
//! solution). `--continue NAME=START:STOP:COUNT` follows the solution as a
//! parameter varies (the same `NAME=...` as `--set` and `ezy sweep`).

use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::analysis::{
    Analysis, AnalysisError, Follow, GaitOrGrowth, Growth, PeriodicOrbit, PeriodicSettings, SteadyMotion, Symmetry,
};
use ezy_core::effects::Periodicity;
use ezy_core::sensitivity::GaitSensitivities;
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

mod branches;
mod report;
mod spectrum;

use super::{check_figure_format, committed};
use crate::app::{App, AppError};
use crate::cli::{Overrides, parse_positive};
use crate::output::progress::Heartbeat;
use crate::output::transaction::OutLock;
use crate::session::{
    Error, RunOptions, analysis_error, check_run, orbit_decimals, periodic_settings, run_to, scene_analysis, settings,
};
use branches::{SwitchAt, follow_all};
use report::{summary, wrap, write_analysis};

/// Find a scene's steady motions (or, driven periodically, its
/// periodic orbit; or, where a scene without forcing in time turns on
/// one, its limit cycle) and their stability; follow them as a parameter
/// varies: equilibria.csv, periodic.csv, branch.csv and figures; or
/// measure how a driven motion without a gait gains energy: growth.csv.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct AnalyzeArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// Output directory [default: out/analyze/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// The forcing period [s] [default: from the scene's waveforms].
    #[arg(long, value_name = "T", value_parser = parse_positive)]
    period: Option<f64>,
    /// The kinetic energy [J] of the steady motions sought, held along
    /// their branch (--continue) [default: the guess's own in a scene
    /// without effects, where energy is conserved; on a branch, a family's
    /// member's own (a sleigh's straight run at any speed: the speed is
    /// free unless a level picks it)].
    #[arg(long, value_name = "J", value_parser = parse_positive)]
    energy: Option<f64>,
    /// Follow the solution as a parameter takes COUNT evenly spaced
    /// values from START to STOP (a NAME as for --set).
    #[arg(long = "continue", value_name = "NAME=START:STOP:COUNT")]
    continuation: Option<String>,
    /// With --continue: also follow the branches born at the branch's
    /// branch points, period doublings and Hopf points, each to the
    /// range's end on its side: at all of them, or at the K-th (1, 2, ...
    /// in the branch's order). Each branch is written to its own table
    /// (branch-1.csv, ...), listed with its parent and the bifurcation it
    /// starts from in branches.csv, and drawn in branch.png; a branch
    /// point is told transcritical or pitchfork by them.
    #[arg(long, value_name = "K", num_args = 0..=1, value_parser = clap::value_parser!(u64).range(1..=MAX_SWITCH))]
    switch: Option<Option<u64>>,
    /// The gait's derivatives with respect to these parameters
    /// (comma-separated or repeated; names as for --set, or
    /// initial.q.NAME, initial.qd.NAME): d<quantity>/d<param> columns in
    /// periodic.csv.
    #[arg(long, value_name = "NAME[,NAME..]", value_delimiter = ',')]
    wrt: Vec<String>,
    /// Do not draw the figures.
    #[arg(long)]
    no_figures: bool,
    #[command(flatten)]
    overrides: Overrides,
}

/// The arguments of `ezy analyze`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    AnalyzeArgs::augment_args(cmd)
}

/// Analyzes the scene named (or the default scene) and prints what it
/// found.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = AnalyzeArgs::from_arg_matches(args)?;
    let (_, src) = app.named_scene(args.scene.as_deref())?;
    let scene = &src.scene;
    if args.switch.is_some() && args.continuation.is_none() {
        return Err(AppError::Failed(
            "--switch follows the branches born on a branch: give the branch with --continue NAME=START:STOP:COUNT"
                .into(),
        ));
    }
    let continuation = match &args.continuation {
        Some(text) => {
            let axis = crate::sweep::plan::grid(text).map_err(|e| AppError::Failed(format!("--continue {e}")))?;
            let n = axis.values.count().unwrap_or(0);
            if n > MAX_CONTINUATION {
                return Err(AppError::Failed(format!(
                    "--continue `{text}`: {n} values is more than {MAX_CONTINUATION}, the most a continuation takes"
                )));
            }
            Some((axis.name.clone(), (0..n).map(|k| axis.values.get(k)).collect()))
        }
        None => None,
    };
    let opts = AnalyzeOptions {
        run: RunOptions {
            out: args.out.unwrap_or_else(|| PathBuf::from("out").join("analyze").join(&scene.name)),
            figures: !args.no_figures,
            progress: true,
            ..args.overrides.options()
        },
        period: args.period,
        energy: args.energy,
        continuation,
        switch: args.switch.map(|k| k.map_or(SwitchAt::All, |k| SwitchAt::One(k as usize))),
        wrt: args.wrt,
    };
    check_figure_format(&src, opts.run.figure_format, opts.run.figures)?;
    let model = &app.model_or_error(&scene.model)?;
    let report = analyze_model(model, scene, &opts).map_err(AppError::from_run)?;
    committed(out, &summary(&scene.name, &report), &opts.run.out)
}

/// Most parameter values a continuation may take.
const MAX_CONTINUATION: u64 = 10_000;

/// The largest K of `--switch K`: a branch has no more bifurcations
/// than points, at most [`MAX_CONTINUATION`].
const MAX_SWITCH: u64 = MAX_CONTINUATION;

/// What `ezy analyze` is asked.
#[derive(Debug, Clone, Default)]
struct AnalyzeOptions {
    /// Output directory, overrides, figure settings; `t_end` is the length
    /// of the run whose end state is a guess.
    run: RunOptions,
    /// The forcing period \[s\] (`None`: from the scene's waveforms).
    period: Option<f64>,
    /// The kinetic energy \[J\] of the steady motions sought (`None`: the
    /// guess's own for a scene without effects and drives, free otherwise).
    energy: Option<f64>,
    /// A parameter to follow the first solution through: its name and values.
    continuation: Option<(String, Vec<f64>)>,
    /// The bifurcations whose branches are followed too (`--switch`).
    switch: Option<SwitchAt>,
    /// Parameters the gait is differentiated with respect to.
    wrt: Vec<String>,
}

/// What `ezy analyze` found.
#[derive(Debug, Clone)]
struct AnalyzeReport {
    /// The scene's symmetry.
    symmetry: Symmetry,
    /// The model's coordinates (the names of its cyclic ones' rates).
    coords: Vec<String>,
    /// The steady motions found (distinct), for a time-independent scene.
    steady: Vec<SteadyMotion>,
    /// The periodic orbit, for a periodically driven scene; or the limit
    /// cycle of an autonomous one.
    periodic: Option<PeriodicOrbit>,
    /// A gait's mean input power, efficiency and derivatives (not a
    /// limit cycle's).
    gait: Option<GaitSensitivities>,
    /// For a periodically driven scene without a gait, the growth without
    /// bound of its energy, measured.
    growth: Option<Growth>,
    /// Files written.
    files: Vec<PathBuf>,
    /// What took how long.
    timings: Vec<(String, Duration)>,
    /// Notes for the user (a guess that led nowhere, the end of a branch).
    notes: Vec<String>,
    /// The decimals the periodic orbit's numbers hold at the period map's
    /// settings ([`crate::session::orbit_decimals`]): 6 at the defaults.
    decimals: usize,
    /// What the period map's integration resolves: a multiplier below it
    /// (times the largest, at least 1) is printed as unresolved
    /// ([`spectrum::multipliers`]): the larger of its rtol and atol.
    resolution: f64,
}

/// `ezy analyze` on `proto`, a model at its defaults: the request
/// checked, the scene's symmetry and period, its run for guesses, the
/// steady motions or the periodic orbit, the branch, the output.
///
/// # Errors
/// [`Error::Input`] when the scene has neither steady motions nor a known
/// period, or no search converged; the setup's errors; the output's.
fn analyze_model<M: Model>(proto: &M, scene: &Scene, opts: &AnalyzeOptions) -> Result<AnalyzeReport, Error> {
    let ro = &opts.run;
    let settings = settings(scene, ro)?;
    check_request(opts, settings.t_end)?;
    let (mut an, x0) = scene_analysis(proto, scene, &ro.sets)?;
    check_on_model(proto, scene, opts, &an)?;
    // the parameters named before any work
    let params = opts.wrt.iter().map(|n| scene.parameter(proto, &ro.sets, n.trim())).collect::<Result<Vec<_>, _>>()?;
    check_run(proto, scene, ro)?;
    // the directory is this command's from here to the commit
    let held = OutLock::take(&ro.out)?;
    let mut log = Log::default();
    let clock = Instant::now();
    let symmetry = an.symmetry(0.0, &x0).map_err(analysis_error(&ro.out))?;
    let period = period(&mut an, &x0, opts.period, scene, &ro.out)?;
    check_energy(opts, scene, period, symmetry)?;
    // a line every few seconds of a long analysis (a stiff scene's run
    // and searches take minutes)
    // a forced scene's gait is sought at the forcing's phase 0, the last
    // whole forcing period of the run (at least one): its fixed point and
    // displacement compare with those at another parameter value, and
    // with the gait's derivatives, which hold that phase
    let forcing = an.forcing().and_then(Periodicity::period);
    let t_run = match (period, forcing) {
        (Some(_), Some(tf)) => (settings.t_end / tf).floor().max(1.0) * tf,
        _ => settings.t_end,
    };
    let beat = ro.progress.then(|| {
        Heartbeat::start(format!("analyze {}: running the scene to t = {} s for guesses", scene.name, fmt_value(t_run)))
    });
    let (samples, _) = run_to(proto, scene, ro, t_run, crate::session::GUESSES)?;
    let end = samples.last().cloned().unwrap_or_else(|| x0.clone());
    log.timings.push((format!("run to t = {} s for a guess", fmt_value(t_run)), clock.elapsed()));
    if let (Some(m), Some(_)) = (ro.method, period) {
        log.notes.push(format!(
            "--integrator {}: the run to the guess uses it; the searches for the orbit and its derivatives integrate \
             the period with DOP853 (its variational equations under one error control)",
            m.name()
        ));
    }
    let mut growth = None;
    let (steady, periodic, follow) = match period {
        None => {
            let guesses = guesses(&x0, &end, &samples, settings.t_end, symmetry);
            match steady_motions(&mut an, scene, opts, symmetry, &guesses, beat.as_ref(), &mut log) {
                Ok((steady, follow)) => (steady, None, follow),
                // none: does the run turn on a limit cycle?
                // a limit cycle's energy is the run's, not the one asked
                Err(Error::Input(none)) if opts.energy.is_none() => {
                    let clock = Instant::now();
                    if let Some(b) = &beat {
                        b.set(format!("analyze {}: searching for a limit cycle", scene.name));
                    }
                    let ps = periodic_settings(ro);
                    let t0 = settings.t_end;
                    let cycle = limit_cycle(&mut an, t0, &end, symmetry, &ps).map_err(analysis_error(&ro.out));
                    let Some(orbit) = cycle? else { return Err(Error::Input(none)) };
                    log.timings.push(("limit cycle".into(), clock.elapsed()));
                    // the steady searches' failures told once, not each
                    log.notes = vec![format!(
                        "no steady motion was found ({} searches); the run turns on a limit cycle",
                        guesses.len()
                    )];
                    // its branch's period free ([`Follow::Cycle`])
                    let period = orbit.period;
                    (Vec::new(), Some(orbit), Follow::Cycle { t0, period, settings: ps })
                }
                Err(e) => return Err(e),
            }
        }
        Some(p) => {
            let clock = Instant::now();
            let t0 = t_run;
            let ps = periodic_settings(ro);
            if let Some(b) = &beat {
                b.set(format!("analyze {}: searching for the periodic orbit of period {} s", scene.name, fmt_value(p)));
            }
            let found = an.gait_or_growth(t0, p, &end, symmetry, &ps).map_err(analysis_error(&ro.out))?;
            let orbit = match found {
                GaitOrGrowth::Gait(orbit) => {
                    log.timings.push(("periodic orbit".into(), clock.elapsed()));
                    Some(*orbit)
                }
                GaitOrGrowth::Grows(g) => {
                    log.timings.push(("the run on, the energy's growth measured".into(), clock.elapsed()));
                    growth = Some(*g);
                    None
                }
            };
            // a forced scene's branch at the forcing's phase 0 at every
            // value (t0 = 0, a whole number of its periods at any)
            let t0 = if forcing.is_some() { 0.0 } else { t0 };
            (Vec::new(), orbit, Follow::Periodic { t0, period: p, settings: ps })
        }
    };
    drop(beat);
    // a motion that gains energy without bound has no gait to
    // differentiate or follow
    if let Some(g) = &growth {
        check_growth_request(opts, g)?;
    }
    // a limit cycle's period is an unknown: its derivatives (at a fixed
    // period) are not its own yet; its branch is followed with the period
    // free
    if period.is_none() && periodic.is_some() && !params.is_empty() {
        return Err(Error::Input(
            "--wrt: the derivatives of a limit cycle (an autonomous scene's periodic orbit, its period an unknown) are not computed yet; a forced scene's gait has them".into(),
        ));
    }
    let gait = match (&periodic, &follow) {
        (Some(_), _) if period.is_none() => None,
        (Some(orbit), Follow::Periodic { settings: ps, .. }) => {
            let clock = Instant::now();
            let (problem, _) = scene.problem_with(proto.clone(), &ro.sets)?;
            let g = problem.gait_sensitivities(orbit, &params, ps).map_err(analysis_error(&ro.out))?;
            log.timings.push(("mean power and the gait's derivatives".into(), clock.elapsed()));
            Some(g)
        }
        _ if !params.is_empty() && growth.is_none() => {
            return Err(Error::Input(
                "--wrt: the derivatives are those of a gait (a periodically driven scene's periodic orbit); this scene's steady motions are not differentiated yet".into(),
            ));
        }
        _ => None,
    };
    let branches = match &opts.continuation {
        Some((name, values)) => {
            let start = steady
                .first()
                .map_or_else(|| periodic.as_ref().map(|p| p.state.clone()).unwrap_or_default(), |s| s.state.clone());
            follow_all(proto, scene, ro, (name, values), (&start, follow), opts.switch, &mut log)?
        }
        None => Vec::new(),
    };
    let differenced = an.differenced_laws();
    if !differenced.is_empty() {
        log.notes.push(format!(
            "the force of {} has no exact Jacobian (its law does not implement ForceLaw::jacobian): differentiated by central differences, about 1e-10 relative",
            differenced.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
        ));
    }
    let files = write_analysis(
        &an,
        scene,
        opts,
        (&steady, growth.as_ref()),
        periodic.as_ref().map(|p| (p, gait.as_ref())),
        &branches,
        held,
    )?;
    let coords = an.dynamics().info.coords.clone();
    let Log { timings, mut notes } = log;
    let (decimals, loose) = orbit_precision(ro, periodic.is_some());
    notes.extend(loose);
    let tolerance = periodic_settings(ro).tolerance;
    let resolution = tolerance.rtol.max(tolerance.atol);
    Ok(AnalyzeReport { symmetry, coords, steady, periodic, gait, growth, files, timings, notes, decimals, resolution })
}

/// The decimals a periodic orbit's numbers hold at the period map's
/// settings ([`orbit_decimals`]), and the note that they are printed to
/// them where `--rtol`/`--atol` loosened those below the six of the
/// defaults (for a scene with an orbit).
fn orbit_precision(ro: &RunOptions, orbit: bool) -> (usize, Option<String>) {
    let ps = periodic_settings(ro);
    let decimals = orbit_decimals(ps.newton_tolerance);
    let note = (orbit && decimals < 6).then(|| {
        format!(
            "the period map is integrated at rtol {:e}, atol {:e} and its Newton iteration stops at {:e} (the defaults: 1e-11 and 1e-9): the orbit's numbers are printed to the {decimals} decimals they hold (its power and efficiency to {digits} significant digits, each derivative to {digits} of its row's largest), and its CSV files carry more digits than that",
            ps.tolerance.rtol,
            ps.tolerance.atol,
            ps.newton_tolerance,
            digits = decimals + 1
        )
    });
    (decimals, note)
}

/// Refuses `--energy` where it cannot be honoured: a scene forced
/// periodically (a gait's kinetic energy follows from its forcing), and
/// a scene without symmetry (its steady motions are equilibria, at rest).
/// Where the steady searches find no motion of that energy, the limit
/// cycle (of the run's energy) is not offered in its place.
fn check_energy(opts: &AnalyzeOptions, scene: &Scene, period: Option<f64>, symmetry: Symmetry) -> Result<(), Error> {
    let Some(e) = opts.energy else { return Ok(()) };
    let why = if let Some(p) = period {
        format!(
            "scene {} is forced with period {} s, and a gait's kinetic energy follows from its forcing",
            scene.name,
            fmt_value(p)
        )
    } else if symmetry == Symmetry::NONE {
        format!(
            "scene {} has no symmetry, so its steady motions are equilibria (at rest, kinetic energy 0)",
            scene.name
        )
    } else {
        return Ok(());
    };
    Err(Error::Input(format!(
        "--energy {}: {why}; --energy picks the steady motions of an unforced scene relative to its symmetry (a sleigh's straight run or turn)",
        fmt_value(e)
    )))
}

/// Refuses what needs a gait on a motion that gains energy without bound
/// (`growth`): the derivatives (`--wrt`) and the branch (`--continue`),
/// each by name, with the verdict.
fn check_growth_request(opts: &AnalyzeOptions, growth: &Growth) -> Result<(), Error> {
    let flag = if !opts.wrt.is_empty() {
        "--wrt: the derivatives are those of a gait"
    } else if opts.continuation.is_some() {
        "--continue: a branch follows a gait"
    } else {
        return Ok(());
    };
    Err(Error::Input(format!(
        "{flag}, and this scene has none to differentiate or follow: {}; analyze without {} for this verdict and growth.csv",
        growth.describe(),
        flag.split(':').next().unwrap_or(flag)
    )))
}

/// The limit cycle an autonomous scene's run from `end` at `t0` \[s\]
/// turns on, if it comes back near `end` within the run's length
/// ([`Analysis::return_time`]); `None` where it does not.
///
/// # Errors
/// The search's, where the run comes back but no cycle converges.
fn limit_cycle<M: Model>(
    an: &mut Analysis<M>,
    t0: f64,
    end: &[f64],
    symmetry: Symmetry,
    settings: &PeriodicSettings,
) -> Result<Option<PeriodicOrbit>, AnalysisError> {
    let Some(first) = an.return_time(t0, end, t0.max(1e-3), settings)? else { return Ok(None) };
    an.limit_cycle(t0, first, end, symmetry, settings).map(Some)
}

/// What an analysis tells besides its results: what took how long, and
/// notes for the user.
#[derive(Default)]
struct Log {
    timings: Vec<(String, Duration)>,
    notes: Vec<String>,
}

/// The request's own numbers, before any work: a period that is not
/// positive or within the time's rounding at `t_end` \[s\], an energy that
/// is not positive.
fn check_request(opts: &AnalyzeOptions, t_end: f64) -> Result<(), Error> {
    if let Some(p) = opts.period
        && !(p.is_finite() && p > 0.0)
    {
        return Err(Error::Input(format!("--period {p}: the period must be a positive number of seconds")));
    }
    // the orbit is integrated from t_end over one period: a period below
    // 1e-9 of that time is within 2e-7 of its rounding (eps t), coarser
    // than the shooting's tolerance (1e-9 of the state)
    if let Some(p) = opts.period
        && p < MIN_PERIOD * t_end.max(1.0)
    {
        return Err(Error::Input(format!(
            "--period {}: a periodic orbit is sought from t = {} s (the scene's t_end), and a period below {:.1e} s there is within the time's rounding; give a longer period",
            fmt_value(p),
            fmt_value(t_end),
            MIN_PERIOD * t_end.max(1.0)
        )));
    }
    if let Some(e) = opts.energy
        && !(e.is_finite() && e > 0.0)
    {
        return Err(Error::Input(format!("--energy {e}: the kinetic energy must be a positive number of joules")));
    }
    Ok(())
}

/// The request against the model: an energy that stands for a speed the
/// search cannot tell from rest, a continuation whose ends change the
/// model's size.
fn check_on_model<M: Model>(proto: &M, scene: &Scene, opts: &AnalyzeOptions, an: &Analysis<M>) -> Result<(), Error> {
    let ro = &opts.run;
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
            let (other, _) =
                scene_analysis(proto, scene, &sets).map_err(|e| Error::Input(format!("--continue {name}: {e}")))?;
            if other.nq() != an.nq() {
                return Err(Error::Input(format!(
                    "--continue {name}: at {name} = {value} the model has {} coordinates against {} at the start: a branch follows one model, so continue in a parameter that keeps its size",
                    other.nq(),
                    an.nq()
                )));
            }
        }
    }
    Ok(())
}

/// The period of the orbit sought (`None`: steady motions): `given`
/// (`--period`, a whole number of the forcing's periods), else the
/// forcing's; a scene driven by a table in time, or changing with time
/// through a law of its own, needs `--period`.
fn period<M: Model>(
    an: &mut Analysis<M>,
    x0: &[f64],
    given: Option<f64>,
    scene: &Scene,
    dir: &std::path::Path,
) -> Result<Option<f64>, Error> {
    Ok(match (given, an.forcing()) {
        // a periodic orbit of a forced scene repeats with a whole number
        // of the forcing's periods
        (Some(p), Some(Periodicity::Period(forcing))) => {
            if Periodicity::Period(forcing).whole_periods(p).is_none() {
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
            let a = an.rhs(0.0, x0).map_err(analysis_error(dir))?;
            let mut changes = false;
            for offset in [0.7391, 0.0531, 2.1913, 13.371] {
                let b = an.rhs(offset, x0).map_err(analysis_error(dir))?;
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
    })
}

/// The guesses of the steady motions, each with what it is: the scene's
/// start `x0`, the `end` of its run to `t_end` \[s\], then the run's other
/// `samples`, latest first; an equilibrium (no symmetry) is at rest: the
/// samples' positions.
fn guesses(x0: &[f64], end: &[f64], samples: &[Vec<f64>], t_end: f64, symmetry: Symmetry) -> Vec<(String, Vec<f64>)> {
    let nq = x0.len() / 2;
    let rest = |x: &[f64]| {
        if symmetry == Symmetry::NONE { [&x[..nq], &vec![0.0; nq][..]].concat() } else { x.to_vec() }
    };
    let mut guesses =
        vec![("the scene's start".to_string(), x0.to_vec()), ("the end of its run".to_string(), rest(end))];
    let every = t_end / f64::from(crate::session::GUESSES);
    for (k, x) in samples.iter().enumerate().rev().skip(1) {
        guesses.push((format!("its run at t = {} s", fmt_value(every * (k + 1) as f64)), rest(x)));
    }
    guesses
}

/// The distinct steady motions found from the `guesses`, and how to
/// follow the first. The guesses that failed alike are noted once, as
/// are the searches that ended at rest.
fn steady_motions<M: Model>(
    an: &mut Analysis<M>,
    scene: &Scene,
    opts: &AnalyzeOptions,
    symmetry: Symmetry,
    guesses: &[(String, Vec<f64>)],
    beat: Option<&Heartbeat>,
    log: &mut Log,
) -> Result<(Vec<SteadyMotion>, Follow), Error> {
    let conservative = an.dynamics().effects.is_empty() && an.dynamics().drives.is_empty();
    let energy_of = |an: &Analysis<M>, x: &[f64]| {
        opts.energy.or_else(|| conservative.then(|| an.dynamics().kinetic_energy(&x[x.len() / 2..])))
    };
    let mut steady: Vec<SteadyMotion> = Vec::new();
    let nq = an.nq();
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
        if let Some(b) = beat {
            b.set(format!(
                "analyze {}: searching for a steady motion from {label} ({} of {})",
                scene.name,
                k + 1,
                guesses.len()
            ));
        }
        let energy = energy_of(an, guess);
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
    log.timings.push((format!("{} searches for steady motions", guesses.len()), clock.elapsed()));
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
        log.notes.push(format!("from {from}: {why}"));
    }
    if !near_rest.is_empty() {
        log.notes.push(format!(
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
            log.notes.join("; ")
        )));
    }
    let first = &steady[0];
    let mut energy = energy_of(an, &first.state);
    // a family's member (a free speed) is followed at its own kinetic
    // energy: without a level the branch through it is not one curve
    if energy.is_none() && first.family > 0 {
        let e = an.dynamics().kinetic_energy(&first.state[nq..]);
        if opts.continuation.is_some() {
            log.notes.push(format!(
                "steady motion 1 is one of a family of {} dimension(s) (a free speed): its branch holds its kinetic energy at {} J (--energy J holds another)",
                first.family,
                fmt_value(e)
            ));
        }
        energy = Some(e);
    }
    Ok((steady, Follow::Steady { energy }))
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
