//! `ezy analyze --continue` and `--switch`: the branch of the solution
//! found followed through a parameter, its bifurcations located and
//! named, and the branches born at its branch points, period doublings
//! and Hopf points followed too ([`ezy_core::analysis::switching`]).

use std::time::Instant;

use ezy_core::analysis::arclength::{follow_arclength_from, locate_fold};
use ezy_core::analysis::bifurcation::{locate, near_misses};
use ezy_core::analysis::switching::{Switch, switch_both};
use ezy_core::analysis::{
    Analysis, AnalysisError, Bifurcation, BifurcationKind, BranchEnd, BranchPoint, Follow, Solution,
};
use ezy_core::{Model, fmt_located, fmt_value};
use ezy_scene::Scene;

use super::Log;
use crate::output::progress::Heartbeat;
use crate::output::transaction::{check_interrupt, pending};
use crate::session::{Error, RunOptions, analysis_error, complex, periodic_settings, scene_analysis};

/// The width of the bracket a bifurcation is located to, relative to
/// `1 + |value|`.
const BIFURCATION_TOL: f64 = 1e-8;

/// How far from a bifurcation a branch born there is sought, relative to
/// the largest of 1 and the solution's state: past the Newton matrix's
/// near-singularity there (its smallest singular value grows as the
/// distance) and far enough that the point's critical multiplier or
/// eigenvalue is resolved off the circle or axis (at 1e-3 the
/// rolling-resistance gait's turning arm's was within the 1e-6 counted
/// as on it, neutral), inside the new branch's quadratic bend.
const SWITCH_OFFSET: f64 = 1e-2;

/// A bifurcation located, after the branch's point at the index.
pub(super) type Located = (usize, Bifurcation);

/// Which bifurcations `--switch` follows the branches of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SwitchAt {
    /// Every branch point, period doubling and Hopf point of the branch.
    All,
    /// The k-th of them (1, 2, ...) in the branch's order.
    One(usize),
}

/// Where a branch is born: the branch it leaves, the bifurcation and its
/// kind as told by the branches born, the side of the new direction.
#[derive(Debug, Clone)]
pub(super) struct Birth {
    /// The parent branch's number (0: the branch followed).
    pub(super) parent: usize,
    /// The bifurcation's parameter value.
    pub(super) value: f64,
    /// Its kind, as told by the switch.
    pub(super) kind: BifurcationKind,
    /// `supercritical` or `subcritical`, where told.
    pub(super) criticality: Option<&'static str>,
    /// Whether the two arms break the plane's reflection.
    pub(super) symmetry_breaking: bool,
    /// The side of the new direction it was sought on (+1 or -1).
    pub(super) side: f64,
}

/// A branch: the one followed (number 0) or one born at a bifurcation.
#[derive(Debug, Clone)]
pub(super) struct Branch {
    /// Its number: 0 for the branch followed, 1, 2, ... for those born,
    /// in the order found; `branch.csv` and `branch-K.csv`.
    pub(super) id: usize,
    /// Where it is born (`None` for the branch followed).
    pub(super) birth: Option<Birth>,
    /// Its points.
    pub(super) points: Vec<BranchPoint>,
    /// A periodic branch's mean input power \[W\] and efficiency \[m/J\]
    /// at each point (empty for steady motions).
    pub(super) power: Vec<(f64, f64)>,
    /// The bifurcations located on it.
    pub(super) bifurcations: Vec<Located>,
    /// How it ended: `the range's end`, or why it stopped early.
    pub(super) ended: String,
    /// How it was followed: a forced scene's gaits have a mean input power.
    follow: Follow,
}

impl Branch {
    /// The table it is written to.
    pub(super) fn file(&self) -> String {
        if self.id == 0 { "branch.csv".into() } else { format!("branch-{}.csv", self.id) }
    }
}

/// The scene at the parameter `name`'s value `v`, the run's overrides
/// with it; a signal ends the branch at its next point.
fn builder<'a, M: Model>(
    proto: &'a M,
    scene: &'a Scene,
    ro: &'a RunOptions,
    name: &'a str,
) -> impl Fn(f64) -> Result<Analysis<M>, AnalysisError> + Copy + 'a {
    move |v: f64| {
        if pending().is_some() {
            return Err(AnalysisError::Request { reason: "stopped by a signal".into() });
        }
        let mut sets = ro.sets.clone();
        sets.push((name.to_string(), v));
        scene_analysis(proto, scene, &sets).map(|(a, _)| a).map_err(|e| match e {
            Error::Sim(e) => AnalysisError::Sim(e),
            e => AnalysisError::Request { reason: e.to_string() },
        })
    }
}

/// The branch of the solution from `start` as the parameter `name` takes
/// `values`, its bifurcations located; with `switch`, the branches born
/// at its branch points, period doublings and Hopf points followed to the
/// range's end on their side, their bifurcations located (one
/// generation: the branches born on those are not followed); each
/// branch's power along it. Notes where a branch ends early, where its
/// stability changes, what each bifurcation is; a signal ends the work at
/// the next point.
///
/// # Errors
/// A signal's; the power's integration ([`branch_power`]).
pub(super) fn follow_all<M: Model>(
    proto: &M,
    scene: &Scene,
    ro: &RunOptions,
    (name, values): (&str, &[f64]),
    (start, follow): (&[f64], Follow),
    switch: Option<SwitchAt>,
    log: &mut Log,
) -> Result<Vec<Branch>, Error> {
    let build = builder(proto, scene, ro, name);
    let (points, ended) = follow_branch(ro, (name, values), start, follow, build, log)?;
    let bifurcations = locate_all(ro, name, &points, follow, build, log)?;
    let mut branches = vec![Branch { id: 0, birth: None, points, power: Vec::new(), bifurcations, ended, follow }];
    if let Some(at) = switch {
        let (lo, hi) = (values[0].min(values[values.len() - 1]), values[0].max(values[values.len() - 1]));
        let spacing = (hi - lo) / (values.len().max(2) - 1) as f64;
        switch_all(ro, (name, [lo, hi], spacing), follow, build, at, &mut branches, log)?;
    }
    // a forced scene's gaits' (a limit cycle's power is not computed)
    for b in branches.iter_mut().filter(|b| matches!(b.follow, Follow::Periodic { .. })) {
        b.power = branch_power(proto, scene, ro, name, &b.points, log)?;
    }
    Ok(branches)
}

/// Follows the branches born at the bifurcations of `branches[0]` that
/// `at` picks, within the range `[lo, hi]` on the parent's grid spacing,
/// each pushed onto `branches`; the parent's bifurcations renamed as the
/// switch tells them.
fn switch_all<M: Model>(
    ro: &RunOptions,
    (name, [lo, hi], spacing): (&str, [f64; 2], f64),
    follow: Follow,
    build: impl Fn(f64) -> Result<Analysis<M>, AnalysisError> + Copy,
    at: SwitchAt,
    branches: &mut Vec<Branch>,
    log: &mut Log,
) -> Result<(), Error> {
    let switchable = |k: BifurcationKind| {
        matches!(k, BifurcationKind::BranchPoint | BifurcationKind::PeriodDoubling | BifurcationKind::Hopf)
    };
    let picked: Vec<usize> = (0..branches[0].bifurcations.len())
        .filter(|&i| switchable(branches[0].bifurcations[i].1.kind))
        .enumerate()
        .filter(|&(n, _)| at == SwitchAt::All || at == SwitchAt::One(n + 1))
        .map(|(_, i)| i)
        .collect();
    if at == SwitchAt::All && picked.is_empty() {
        log.notes.push(
            "--switch: no branch point, period doubling or Hopf point was located on the branch; none switched".into(),
        );
    }
    if let (SwitchAt::One(k), true) = (at, picked.is_empty()) {
        let n = branches[0].bifurcations.iter().filter(|(_, b)| switchable(b.kind)).count();
        log.notes.push(format!(
            "--switch {k}: the branch has {n} branch point(s), period doubling(s) and Hopf point(s) to switch at; none switched"
        ));
    }
    for i in picked {
        let (k, b) = branches[0].bifurcations[i].clone();
        let clock = Instant::now();
        let parent = [&branches[0].points[k], &branches[0].points[k + 1]];
        let s = match switch_both(&b, parent, follow, build, SWITCH_OFFSET, periodic_settings(ro)) {
            Ok(s) => s,
            Err(AnalysisError::Stopped) => return Err(check_stop(ro)),
            Err(e) => {
                log.notes.push(format!(
                    "no branch found born at the {} at {name} = {}: {e}",
                    b.kind.name(),
                    fmt_located(b.value, width(&b))
                ));
                continue;
            }
        };
        branches[0].bifurcations[i].1.kind = s.kind;
        log.notes.push(told(name, &b, &s));
        for born in &s.born {
            let v = born.start.value;
            let end = if v >= b.value { hi } else { lo };
            if !(lo..=hi).contains(&v) || (end - v).abs() < 1e-12 * (1.0 + v.abs()) {
                log.notes.push(format!(
                    "the branch born at {name} = {} on side {} starts at {}, at or beyond the range's end: not followed",
                    fmt_located(b.value, width(&b)),
                    born.side,
                    fmt_value(v)
                ));
                continue;
            }
            let n = ((end - v).abs() / spacing).ceil().max(1.0) as usize + 1;
            let grid: Vec<f64> = (0..n).map(|j| v + (end - v) * j as f64 / (n - 1) as f64).collect();
            let id = branches.len();
            let (points, ended) =
                follow_branch(ro, (name, &grid), born.start.solution.state(), born.follow, build, log)?;
            let bifurcations = locate_all(ro, name, &points, born.follow, build, log)?;
            let birth = Birth {
                parent: 0,
                value: b.value,
                kind: s.kind,
                criticality: s.criticality.map(|c| c.name()),
                symmetry_breaking: s.symmetry_breaking,
                side: born.side,
            };
            let follow = born.follow;
            branches.push(Branch { id, birth: Some(birth), points, power: Vec::new(), bifurcations, ended, follow });
        }
        log.timings.push((format!("branches born at {name} = {}", fmt_located(b.value, width(&b))), clock.elapsed()));
    }
    Ok(())
}

/// The width of the last bracket `b` was located in: its value holds the
/// digits above it.
fn width(b: &Bifurcation) -> f64 {
    (b.bracket[1] - b.bracket[0]).abs()
}

/// The note that tells a switch's bifurcation and what was born there.
fn told(name: &str, b: &Bifurcation, s: &Switch) -> String {
    let sides: Vec<String> = s
        .born
        .iter()
        .map(|n| {
            let turn = match &n.start.solution {
                Solution::Steady(m) => format!("yaw rate {} rad/s", fmt_value(m.body_velocity[2])),
                Solution::Periodic(o) => format!("heading change {} rad per period", fmt_value(o.heading_change)),
            };
            format!("at {name} = {} ({}, {turn})", fmt_value(n.start.value), n.start.solution.stability().name())
        })
        .collect();
    let failed = s.failed.as_ref().map(|(side, e)| format!("; side {side} not found: {e}")).unwrap_or_default();
    format!(
        "the bifurcation at {name} = {} is a {}: branches born {}{failed}",
        fmt_located(b.value, width(b)),
        s.describe(),
        sides.join(" and ")
    )
}

/// The error a signal that stopped a search leaves: the interruption's.
fn check_stop(ro: &RunOptions) -> Error {
    match check_interrupt(&ro.out, None, Some("switching branches".into())) {
        Err(e) => e.into(),
        Ok(()) => Error::Input("stopped by a signal".into()),
    }
}

/// The branch from `start` through `values` (followed as `follow` says):
/// its points, and how it ended (`the range's end`, or why not), with a
/// note where it ends early.
fn follow_branch<M: Model>(
    ro: &RunOptions,
    (name, values): (&str, &[f64]),
    start: &[f64],
    follow: Follow,
    build: impl Fn(f64) -> Result<Analysis<M>, AnalysisError> + Copy,
    log: &mut Log,
) -> Result<(Vec<BranchPoint>, String), Error> {
    let clock = Instant::now();
    let beat = ro.progress.then(|| Heartbeat::start(format!("following the branch in {name}")));
    let along = |first: usize| {
        follow_arclength_from(values, first, start, follow, build, |k| {
            if let Some(b) = &beat {
                b.set(format!("following the branch in {name}: point {} (a grid of {} values)", k + 1, values.len()));
            }
        })
    };
    // a grid that starts where there is no solution (beyond a fold) is
    // followed from its first value where the search converges
    let mut first = 0;
    let (mut points, mut ended) = along(0);
    let mut missed = None;
    while points.is_empty() && first + 1 < values.len() && pending().is_none() {
        missed = missed.or(std::mem::replace(&mut ended, BranchEnd::Reached).into_failure());
        first += 1;
        (points, ended) = along(first);
    }
    drop(beat);
    check_interrupt(&ro.out, None, Some(format!("following the branch in {name}")))?;
    if let (Some((v, e)), false) = (&missed, points.is_empty()) {
        let last = fmt_value(values[first - 1]);
        let to = if first > 1 { format!(" to {last}") } else { String::new() };
        log.notes.push(format!(
            "no solution at {name} = {}{to} from the scene's ({e}); the branch begins at {name} = {}",
            fmt_value(*v),
            fmt_value(values[first])
        ));
    }
    let how = match ended {
        BranchEnd::Failed { value, error } => {
            let how = format!("ends at {name} = {}: {error}", fmt_value(value));
            log.notes.push(format!("the branch {how}"));
            how
        }
        BranchEnd::Closed { points: k } => {
            let how =
                format!("closed: it returns to its start at {name} = {} after {k} points", fmt_value(points[0].value));
            log.notes.push(format!("the branch is {how}"));
            how
        }
        BranchEnd::Reached => "the range's end".to_string(),
    };
    log.timings.push((format!("branch of {} points", points.len()), clock.elapsed()));
    Ok((points, how))
}

/// The bifurcations between the points of a branch (followed as `follow`
/// says), located: a fold where the branch turns back in the parameter,
/// else a change of the count of unstable eigenvalues or multipliers;
/// each told in a note.
fn locate_all<M: Model>(
    ro: &RunOptions,
    name: &str,
    points: &[BranchPoint],
    follow: Follow,
    build: impl Fn(f64) -> Result<Analysis<M>, AnalysisError> + Copy,
    log: &mut Log,
) -> Result<Vec<Located>, Error> {
    let clock = Instant::now();
    let mut found = Vec::new();
    for (k, w) in points.windows(2).enumerate() {
        let stability = |b: &BranchPoint| b.solution.stability().name();
        let changes = format!(
            "between {name} = {} ({}) and {} ({})",
            fmt_value(w[0].value),
            stability(&w[0]),
            fmt_value(w[1].value),
            stability(&w[1])
        );
        let located = match locate_fold(&w[0], &w[1], follow, build, BIFURCATION_TOL) {
            Ok(None) => locate(&w[0], &w[1], follow, build, BIFURCATION_TOL),
            other => other,
        };
        match located {
            Ok(Some(b)) => {
                let critical: Vec<String> = b.critical.iter().map(|z| complex(*z)).collect();
                let frequency =
                    b.frequency().map(|f| format!(", frequency {} rad/s", fmt_value(f))).unwrap_or_default();
                log.notes.push(format!(
                    "{} at {name} = {} (to {:.0e}, {} solves; {changes}): critical {} {}{frequency}",
                    b.kind.name(),
                    fmt_located(b.value, width(&b)),
                    (b.bracket[1] - b.bracket[0]).abs(),
                    b.solves,
                    if matches!(b.solution, Solution::Steady(_)) { "eigenvalue" } else { "multiplier" },
                    critical.join(", ")
                ));
                found.push((k, b));
            }
            Ok(None) if stability(&w[0]) != stability(&w[1]) => {
                log.notes.push(format!("stability changes {changes}"));
            }
            Ok(None) => {}
            Err(e) if stability(&w[0]) == stability(&w[1]) => log.notes.push(format!("{changes}: {e}")),
            Err(e) => log.notes.push(format!("stability changes {changes}; not located: {e}")),
        }
    }
    check_interrupt(&ro.out, None, Some(format!("locating the bifurcations in {name}")))?;
    note_near_misses(ro, name, points, log);
    if !found.is_empty() {
        log.timings.push((format!("{} bifurcations located", found.len()), clock.elapsed()));
    }
    Ok(found)
}

/// How close to the stability boundary an eigenvalue or multiplier that
/// turns back is said a near miss ([`near_misses`]), at Newton's
/// tolerance `tol`: `10 tol^(2/3)`. An imperfection `e` (the error that
/// breaks a symmetry) keeps the critical multiplier of a pitchfork it
/// unfolds about `e^(2/3)` from 1 (the cusp's scaling: Golubitsky &
/// Schaeffer I, §I.2); `drive-rolling-resistance`'s came within 8.3e-5
/// at `--rtol 1e-6` (Newton to 1e-4: the bound 2.2e-2) and within
/// 3.3e-3 at `--rtol 1e-4` (1e-3: 0.1); at the default 1e-9, 1e-5.
fn near_miss_bound(tol: f64) -> f64 {
    10.0 * tol.powf(2.0 / 3.0)
}

/// A note for each point of the branch where an eigenvalue or multiplier
/// came within [`near_miss_bound`] of the stability boundary and turned
/// back: a bifurcation that a loose tolerance may have unfolded.
fn note_near_misses(ro: &RunOptions, name: &str, points: &[BranchPoint], log: &mut Log) {
    let tol = periodic_settings(ro).newton_tolerance;
    for m in near_misses(points, near_miss_bound(tol)) {
        let (what, boundary) = match points[m.index].solution {
            Solution::Steady(_) => ("eigenvalue", "the imaginary axis"),
            Solution::Periodic(_) => ("multiplier", "the unit circle"),
        };
        log.notes.push(format!(
            "near {name} = {} the {what} {} came within {:.1e} of {boundary} and turned back: a bifurcation missed by \
             a hair, or one the search's tolerance unfolds (Newton stops at {}: a symmetric solution is symmetric only \
             to that, and a pitchfork splits into branches that pass each other); at a tighter --rtol (the default \
             1e-11) it is located if it is there",
            fmt_value(m.value),
            complex(m.critical),
            m.distance,
            fmt_value(tol),
        ));
    }
}

/// The mean input power \[W\] and efficiency \[m/J\] of each gait of a
/// periodic branch in the parameter `name` (one period's integration
/// each); empty for a branch of steady motions or of limit cycles.
///
/// # Errors
/// A signal's; the integration's.
fn branch_power<M: Model>(
    proto: &M,
    scene: &Scene,
    ro: &RunOptions,
    name: &str,
    branch: &[BranchPoint],
    log: &mut Log,
) -> Result<Vec<(f64, f64)>, Error> {
    let clock = Instant::now();
    let ps = periodic_settings(ro);
    let mut out = Vec::new();
    for b in branch {
        let Solution::Periodic(orbit) = &b.solution else { return Ok(Vec::new()) };
        check_interrupt(&ro.out, None, Some(format!("the mean power along the branch in {name}")))?;
        let mut sets = ro.sets.clone();
        sets.push((name.to_string(), b.value));
        let (problem, _) = scene.problem_with(proto.clone(), &sets)?;
        let g = problem.gait_sensitivities(orbit, &[], &ps).map_err(analysis_error(&ro.out))?;
        out.push((g.mean_power, g.efficiency));
    }
    if !out.is_empty() {
        log.timings.push(("mean power along the branch".into(), clock.elapsed()));
    }
    Ok(out)
}
