//! Design optimization: the parameters of a [`Design`] within their
//! bounds that minimize or maximize a gait's quantity or a function of a
//! run, subject to bounds on other quantities ([`optimize`]).
//!
//! # Method
//!
//! Kraft's SLSQP (sequential least-squares quadratic programming: a
//! quasi-Newton method, BFGS on the Lagrangian, with the bounds and the
//! inequality constraints in each step's quadratic program; D. Kraft, *A
//! software package for sequential quadratic programming*, DFVLR-FB
//! 88-28, 1988), from the crate `slsqp` (NLopt 2.7.1's code in Rust). One
//! method serves both cases the issue of a design poses: with bounds only
//! it is a bounded quasi-Newton method (as L-BFGS-B, which for the few
//! parameters of a design has no advantage), with constraints an SQP
//! method. Every gradient is exact to the sensitivities' accuracy: a gait's
//! by the implicit function theorem on its shooting equations, a run's by
//! its forward sensitivities (never by differences of whole
//! evaluations).
//!
//! The parameters are scaled to `[0, 1]` by their bounds; the objective
//! so that SLSQP's first step (its Hessian starts as the identity) moves
//! a tenth of the box; each constraint by its bound (or its value at the
//! start). A gait is sought at phase 0 of its forcing from the last gait's
//! fixed point (from a run of the problem where that fails): a search of
//! a few Newton iterations, not a run to a steady state.
//!
//! Where asked ([`OptimizeSettings::polish`]) and no constraint is
//! active, SLSQP's best point is polished by Newton's method on the exact
//! gradients of the parameters off their bounds (`polish`'s docs): the
//! values locate an optimum to the square root of their accuracy only.
//!
//! An evaluation that fails (no gait near, a run that fails) counts as a
//! point with a worse objective than any seen, so the line search steps
//! back; five failures in a row end the optimization with the last one's
//! error. A stop (Ctrl-C) ends it at once with the best point so far.

pub(crate) mod evaluate;
pub(crate) mod kkt;
mod polish;
pub(crate) mod quantity;

use std::cell::RefCell;

pub use kkt::{Binding, Kkt};
pub use quantity::{Constraint, GaitQuantity, Goal, Quantity, RunFunction, Sense, ValuesFunction};

use super::Design;
use crate::analysis::AnalysisError;
use crate::analysis::periodic::{PeriodicOrbit, PeriodicSettings};
use crate::model::Model;
use evaluate::{Evaluator, Point};

/// A constraint as SLSQP calls it: `c(u) <= 0`, its gradient into the slice.
type SlsqpConstraint<'a> = Box<dyn Fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64 + 'a>;

/// What SLSQP returns: the status, the point, the value.
type SlsqpOutcome = Result<(slsqp::SuccessStatus, Vec<f64>, f64), (slsqp::FailStatus, Vec<f64>, f64)>;

/// Most evaluations an optimization may be given.
pub const MAX_EVALUATIONS: usize = 10_000;

/// Most points per axis of the grid around the optimum.
pub const MAX_GRID: usize = 101;

/// The widest bounds a parameter may have, as a multiple of its start's
/// size (at least 1): the search resolves `xtol` of the span, so wider
/// bounds would leave the optimum unresolved.
const MAX_SPAN: f64 = 1e6;

/// A constraint holds where its violation is at most this fraction of
/// its scale (its bound, or its value at the start): the gait quantities'
/// own accuracy (Newton's 1e-9, the integration's 1e-11), so that a
/// point on its bound within rounding ranks as feasible (2.5e-11 outside
/// in the guide's example) and one beyond does not. (At 1e-6 the best
/// point could be one 1.5e-7 outside, ranked above the bound's own for
/// its better objective: found when a more accurate first gradient
/// changed SLSQP's path.)
const FEASIBLE: f64 = 1e-9;

/// Failures in a row that end an optimization.
const FAILURES: usize = 5;

/// Evaluations in a row within `xtol` of the best point, none better,
/// that end an optimization as converged.
const STALL: usize = 3;

/// How long an optimization may go and how close it must get.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimizeSettings {
    /// Most evaluations (gaits or runs with their sensitivities), at
    /// most [`MAX_EVALUATIONS`].
    pub max_evaluations: usize,
    /// Convergence: SLSQP stops when a step moves every parameter by
    /// less than this fraction of its bounds' span.
    pub xtol: f64,
    /// The gait searches' settings.
    pub periodic: PeriodicSettings,
    /// Points per axis of a grid of the objective around the optimum,
    /// for one or two parameters (0: none; at most [`MAX_GRID`]); it spans
    /// a tenth of each parameter's bounds on either side.
    pub grid: usize,
    /// Whether SLSQP's best point is polished by Newton's method on the
    /// exact gradients where no constraint is active (`polish`'s docs:
    /// the values locate an optimum to the square root of their
    /// accuracy, the gradients to theirs), at `2 n + 3` evaluations at
    /// most for `n` parameters off their bounds. Off by default.
    pub polish: bool,
}

impl Default for OptimizeSettings {
    /// 100 evaluations, `xtol = 1e-10`, the default gait searches, no
    /// grid, no polish.
    fn default() -> Self {
        Self { max_evaluations: 100, xtol: 1e-10, periodic: PeriodicSettings::default(), grid: 0, polish: false }
    }
}

/// One evaluation of an optimization.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// The parameters' values.
    pub values: Vec<f64>,
    /// The objective (NaN where the evaluation failed).
    pub objective: f64,
    /// The constraints' quantities (NaN where it failed).
    pub constraints: Vec<f64>,
    /// The objective's gradient (empty on a grid or where it failed).
    pub gradient: Vec<f64>,
    /// Why the evaluation failed.
    pub failure: Option<String>,
}

/// An optimization's result ([`optimize`]).
#[derive(Debug, Clone)]
pub struct Optimum {
    /// The parameters' names.
    pub names: Vec<String>,
    /// The best point: the parameters' values.
    pub values: Vec<f64>,
    /// The objective's name.
    pub objective_name: String,
    /// Its value there.
    pub objective: f64,
    /// Its gradient there (with respect to each parameter, in their units).
    pub gradient: Vec<f64>,
    /// The norm of the gradient with the components that point out of an
    /// active bound removed (0 at a bounded optimum without constraints),
    /// in the parameters' units scaled by their spans (`|dF/du|`, `u` the
    /// parameter's fraction of its span).
    pub projected_gradient_norm: f64,
    /// The constraints' quantities there.
    pub constraints: Vec<f64>,
    /// Each constraint's text (`gait.mean_power <= 1`).
    pub constraint_texts: Vec<String>,
    /// Whether each parameter ended at a bound.
    pub at_bound: Vec<bool>,
    /// Whether it converged: SLSQP (or the line search circling the best
    /// point) ended, the best point satisfies the constraints within
    /// their feasibility tolerance, and the first-order conditions hold
    /// there ([`Optimum::kkt`]). Not after a budget spent, a stop or a
    /// failure.
    pub converged: bool,
    /// The first-order (Karush-Kuhn-Tucker) conditions checked at the best
    /// point: the stationarity residual, and the constraints and bounds
    /// that bind with their multipliers.
    pub kkt: Kkt,
    /// Whether a stop hook ended it.
    pub stopped: bool,
    /// How it ended.
    pub termination: String,
    /// Every evaluation in order.
    pub history: Vec<Evaluation>,
    /// The grid around the optimum (values and objective; empty without).
    pub grid: Vec<Evaluation>,
    /// Gaits found.
    pub orbits: usize,
    /// Runs integrated (with sensitivities, or for a gait's guess).
    pub runs: usize,
    /// The gait at the optimum, for a gait's objective.
    pub orbit: Option<PeriodicOrbit>,
}

/// The optimization's state between SLSQP's calls.
struct State<'a, M: Model> {
    ev: Evaluator<'a, M>,
    lower: Vec<f64>,
    span: Vec<f64>,
    /// `sign * scale` of the objective (sign -1 to maximize).
    objective_scale: f64,
    /// `(sign, scale)` of each constraint: `sign (q - bound) / scale <= 0`.
    constraint_scales: Vec<(f64, f64)>,
    /// The last point evaluated: `u` and what it gave.
    last: Option<(Vec<f64>, Result<Point, String>)>,
    history: Vec<Evaluation>,
    /// Index into `history` of the best point, its point and `u`.
    best: Option<(usize, Point, Vec<f64>)>,
    /// Evaluations in a row within `xtol` of the best that did not improve it.
    stall: usize,
    /// Whether they ended the optimization: converged to the quantities'
    /// accuracy, SLSQP's line search circling the best point.
    settled: bool,
    xtol: f64,
    failures: usize,
    max: usize,
    fatal: Option<AnalysisError>,
    stopped: bool,
}

impl<M: Model> State<'_, M> {
    fn values(&self, u: &[f64]) -> Vec<f64> {
        (0..u.len()).map(|k| self.lower[k] + u[k].clamp(0.0, 1.0) * self.span[k]).collect()
    }

    /// Whether no more evaluations are made: a stop, a fatal failure, or
    /// settled.
    fn frozen(&self) -> bool {
        self.stopped || self.fatal.is_some() || self.settled
    }

    /// Ranks a point: total violation of the constraints beyond their
    /// feasibility tolerance ([`FEASIBLE`] of each one's scale, so that
    /// points on a bound within rounding rank as feasible), then objective
    /// (minimized).
    fn rank(&self, p: &Point) -> (f64, f64) {
        let goal = self.ev.goal;
        let violation = goal
            .constraints
            .iter()
            .zip(&p.values[1..])
            .zip(&self.constraint_scales)
            .map(|((c, &v), (_, scale))| (c.violation(v) / scale - FEASIBLE).max(0.0))
            .sum::<f64>();
        (violation, p.values[0] * self.objective_scale.signum())
    }

    /// The first-order conditions at `p` (at `u`): its objective's and
    /// active constraints' gradients in the scaled variables, the active
    /// bounds; `scale` the start's scaled objective gradient.
    fn kkt(&self, p: &Point, u: &[f64], names: &[String], scale: f64) -> Kkt {
        let n = u.len();
        let os = self.objective_scale;
        let g: Vec<f64> = (0..n).map(|k| os * p.gradients[0][k] * self.span[k]).collect();
        let mut candidates = Vec::new();
        let mut feasible = true;
        for (i, c) in self.ev.goal.constraints.iter().enumerate() {
            let (s, k) = self.constraint_scales[i];
            let value = s * (p.values[i + 1] - c.bound) / k;
            feasible &= value <= FEASIBLE;
            if value >= -kkt::ACTIVE {
                candidates.push(kkt::Candidate {
                    name: c.text(),
                    gradient: (0..n).map(|j| s * p.gradients[i + 1][j] * self.span[j] / k).collect(),
                    // mu_scaled grad c_scaled = (mu_scaled / (|os| k)) |os| s grad q
                    unit: 1.0 / (os.abs() * k),
                });
            }
        }
        for k in 0..n {
            let value = self.lower[k] + u[k] * self.span[k];
            let unit = |dir: f64| kkt::Candidate {
                name: format!(
                    "{} {} {}",
                    names[k],
                    if dir < 0.0 { ">=" } else { "<=" },
                    crate::names::fmt_value(if dir < 0.0 { self.lower[k] } else { self.lower[k] + self.span[k] })
                ),
                gradient: (0..n).map(|j| if j == k { dir } else { 0.0 }).collect(),
                unit: 1.0 / (os.abs() * self.span[k]),
            };
            if value - self.lower[k] <= 1e-9 * self.span[k] {
                candidates.push(unit(-1.0));
            }
            if self.lower[k] + self.span[k] - value <= 1e-9 * self.span[k] {
                candidates.push(unit(1.0));
            }
        }
        let mut conditions = kkt::check(&g, &candidates, scale);
        // an infeasible point satisfies no optimality condition
        conditions.holds &= feasible;
        conditions
    }

    /// The point at `u`, evaluated once.
    fn at(&mut self, u: &[f64]) {
        if self.last.as_ref().is_some_and(|(lu, _)| lu == u) || self.frozen() {
            return;
        }
        if self.history.len() >= self.max {
            self.last = Some((u.to_vec(), Err("the evaluation budget is spent".into())));
            return;
        }
        let values = self.values(u);
        let result = self.ev.at(&values, true);
        let mut record = Evaluation {
            values: values.clone(),
            objective: f64::NAN,
            constraints: vec![f64::NAN; self.ev.goal.constraints.len()],
            gradient: Vec::new(),
            failure: None,
        };
        match result {
            Ok(p) => {
                self.failures = 0;
                record.objective = p.values[0];
                record.constraints = p.values[1..].to_vec();
                record.gradient = p.gradients[0].clone();
                self.history.push(record);
                let better = self.best.as_ref().is_none_or(|(_, b, _)| {
                    let (a, b) = (self.rank(&p), self.rank(b));
                    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
                });
                let near = self
                    .best
                    .as_ref()
                    .is_some_and(|(_, _, ub)| ub.iter().zip(u).all(|(a, b)| (a - b).abs() <= 10.0 * self.xtol));
                self.stall = if near && !better { self.stall + 1 } else { 0 };
                self.settled = self.stall >= STALL;
                if better {
                    self.best = Some((self.history.len() - 1, p.clone(), u.to_vec()));
                }
                self.last = Some((u.to_vec(), Ok(p)));
            }
            Err(AnalysisError::Stopped) => self.stopped = true,
            Err(e) => {
                self.failures += 1;
                record.failure = Some(e.to_string());
                self.history.push(record);
                self.last = Some((u.to_vec(), Err(e.to_string())));
                if self.failures >= FAILURES {
                    self.fatal = Some(e);
                }
            }
        }
    }

    /// Quantity `i`'s scaled value at `u` (the objective for `i = 0`, a
    /// constraint's `<= 0` form after) and its gradient in `u`.
    fn scaled(&mut self, u: &[f64], i: usize, grad: Option<&mut [f64]>) -> f64 {
        self.at(u);
        let fresh = !self.frozen();
        let point = match &self.last {
            Some((lu, Ok(p))) if fresh && lu == u => Some(p),
            _ => None,
        };
        let (sign, scale, shift) = match i {
            0 => (self.objective_scale.signum(), self.objective_scale.abs(), 0.0),
            _ => {
                let c = &self.ev.goal.constraints[i - 1];
                let (s, k) = self.constraint_scales[i - 1];
                (s, 1.0 / k, c.bound)
            }
        };
        match point {
            Some(p) => {
                if let Some(g) = grad {
                    for (k, gk) in g.iter_mut().enumerate() {
                        *gk = sign * scale * p.gradients[i][k] * self.span[k];
                    }
                }
                sign * scale * (p.values[i] - shift)
            }
            None => {
                // a failed point: worse than any seen, flat; after a stop
                // or a fatal failure, the best point's value, flat (SLSQP
                // then ends at once)
                if let Some(g) = grad {
                    g.fill(0.0);
                }
                let best = self.best.as_ref().map(|(_, b, _)| sign * scale * (b.values[i] - shift));
                match (fresh, best) {
                    (true, Some(b)) if i == 0 => b + 1.0 + b.abs(),
                    (true, _) => 1.0,
                    (false, Some(b)) => b,
                    (false, None) => 0.0,
                }
            }
        }
    }
}

/// Checks the request before any work.
fn check<M: Model>(design: &Design<M>, goal: &Goal, settings: &OptimizeSettings) -> Result<(), AnalysisError> {
    let fail = |reason: String| Err(AnalysisError::Request { reason });
    // named as the caller spells them: the command line's flags or the fields
    let flags = crate::settings::Spelling::current() == crate::settings::Spelling::Flags;
    let name = |flag: &'static str, field: &'static str| if flags { flag } else { field };
    if !(2..=MAX_EVALUATIONS).contains(&settings.max_evaluations) {
        return fail(format!(
            "a budget of {} evaluations ({}): give between 2 and {MAX_EVALUATIONS}",
            settings.max_evaluations,
            name("--max-evaluations", "`max_evaluations`")
        ));
    }
    if !(settings.xtol > 0.0 && settings.xtol < 1.0) {
        return fail(format!("xtol {}: give a fraction of the bounds' span in (0, 1)", settings.xtol));
    }
    if settings.grid > MAX_GRID {
        return fail(format!(
            "a grid of {} points per axis ({}): at most {MAX_GRID}",
            settings.grid,
            name("--grid", "`grid`")
        ));
    }
    if design.names.len() > crate::sensitivity::MAX_PARAMETERS {
        return fail(format!("{} parameters: at most {}", design.names.len(), crate::sensitivity::MAX_PARAMETERS));
    }
    for (k, name) in design.names.iter().enumerate() {
        let (span, scale) = (design.upper[k] - design.lower[k], design.start[k].abs().max(1.0));
        if span > MAX_SPAN * scale {
            return fail(format!(
                "`{name}={}:{}`: the bounds span {} for a start of {}; a search resolves a parameter to {:.0e} of its span, so give bounds within {MAX_SPAN:.0e} of the start's size",
                crate::names::fmt_value(design.lower[k]),
                crate::names::fmt_value(design.upper[k]),
                crate::names::fmt_value(span),
                crate::names::fmt_value(design.start[k]),
                settings.xtol
            ));
        }
    }
    for c in &goal.constraints {
        if !c.bound.is_finite() {
            return fail(format!("`{}`: the bound must be a finite number", c.text()));
        }
    }
    Ok(())
}

/// The parameters of `design` within their bounds that minimize or
/// maximize `goal`'s objective subject to its constraints (see the
/// module's docs for the method), from the design's start. `stop` is
/// asked at every step of every run and search; `progress` is told of
/// every evaluation.
///
/// # Errors
/// [`AnalysisError::Request`] for settings out of range, a constraint's
/// bound that is not finite, or a scene without a periodic forcing asked
/// for a gait's quantity; the start's evaluation's failure (a bad start:
/// no gait, a run that fails); the last failure of five in a row.
/// A stop is not an error: the best point so far, `stopped` set.
pub fn optimize<M: Model>(
    design: &Design<M>,
    goal: &Goal,
    settings: &OptimizeSettings,
    stop: Option<fn() -> bool>,
    progress: &mut dyn FnMut(&Evaluation),
) -> Result<Optimum, AnalysisError> {
    check(design, goal, settings)?;
    let n = design.names.len();
    let span: Vec<f64> = (0..n).map(|k| design.upper[k] - design.lower[k]).collect();
    let u0: Vec<f64> = (0..n).map(|k| (design.start[k] - design.lower[k]) / span[k]).collect();
    let mut ev = Evaluator::new(design, goal, settings.periodic, stop);
    let p0 = start(&mut ev, design)?;
    let sign = match goal.sense {
        Sense::Minimize => 1.0,
        Sense::Maximize => -1.0,
    };
    let g0 = (0..n).map(|k| (p0.gradients[0][k] * span[k]).abs()).fold(0.0, f64::max);
    let objective_scale = sign * if g0 > 0.0 && g0.is_finite() { 0.1 / g0 } else { 1.0 };
    let constraint_scales = goal
        .constraints
        .iter()
        .zip(&p0.values[1..])
        .map(|(c, &v)| {
            let k = [c.bound.abs(), v.abs()].into_iter().find(|&x| x > 0.0).unwrap_or(1.0);
            (if c.upper { 1.0 } else { -1.0 }, k)
        })
        .collect();
    let first = Evaluation {
        values: design.start.clone(),
        objective: p0.values[0],
        constraints: p0.values[1..].to_vec(),
        gradient: p0.gradients[0].clone(),
        failure: None,
    };
    progress(&first);
    let state = RefCell::new(State {
        ev,
        lower: design.lower.clone(),
        span: span.clone(),
        objective_scale,
        constraint_scales,
        last: Some((u0.clone(), Ok(p0.clone()))),
        history: vec![first],
        best: Some((0, p0, u0.clone())),
        stall: 0,
        settled: false,
        xtol: settings.xtol,
        failures: 0,
        max: settings.max_evaluations,
        fatal: None,
        stopped: false,
    });
    let seen = std::cell::Cell::new(1usize);
    let report = |st: &State<'_, M>, progress: &mut dyn FnMut(&Evaluation)| {
        while seen.get() < st.history.len() {
            progress(&st.history[seen.get()]);
            seen.set(seen.get() + 1);
        }
    };
    let progress = RefCell::new(progress);
    let objective = |u: &[f64], grad: Option<&mut [f64]>, _: &mut ()| {
        let mut st = state.borrow_mut();
        let v = st.scaled(u, 0, grad);
        report(&st, &mut **progress.borrow_mut());
        v
    };
    let constraints: Vec<SlsqpConstraint<'_>> = (1..=goal.constraints.len())
        .map(|i| {
            let state = &state;
            Box::new(move |u: &[f64], grad: Option<&mut [f64]>, _: &mut ()| state.borrow_mut().scaled(u, i, grad))
                as SlsqpConstraint<'_>
        })
        .collect();
    let tols = slsqp::StopTols { xtol_abs: vec![settings.xtol; n], ..slsqp::StopTols::default() };
    let bounds = vec![(0.0, 1.0); n];
    let outcome = slsqp::minimize(objective, &u0, &bounds, &constraints, (), settings.max_evaluations, Some(tols));
    drop(constraints);
    let mut st = state.into_inner();
    if let Some(e) = st.fatal.take() {
        return Err(e);
    }
    let (converged, termination) = termination(&outcome, &st, settings.max_evaluations);
    if settings.polish && !st.stopped {
        st.polish();
        report(&st, &mut **progress.borrow_mut());
    }
    let (best_index, best, best_u) = st.best.take().expect("the start at least");
    let start_scale = objective_scale.abs() * g0;
    let kkt = st.kkt(&best, &best_u, &design.names, if start_scale.is_finite() { start_scale } else { 0.0 });
    let (converged, termination) =
        verdict(goal, (&best.values[1..], &st.constraint_scales), &kkt, (converged, termination));
    let values = st.history[best_index].values.clone();
    let gradient = best.gradients[0].clone();
    let at_bound: Vec<bool> =
        (0..n).map(|k| (values[k] - design.lower[k]).min(design.upper[k] - values[k]) <= 1e-9 * span[k]).collect();
    let projected_gradient_norm = projected_gradient_norm(design, &values, &gradient, sign);
    let stopped = st.stopped;
    let mut ev = st.ev;
    let mut grid = Vec::new();
    if settings.grid > 0 && n <= 2 && !stopped {
        if let Some(o) = &best.orbit {
            ev.restart_from(o);
        }
        grid = grid_around(&mut ev, design, &values, settings.grid)?;
    }
    Ok(Optimum {
        names: design.names.clone(),
        values,
        objective_name: goal.objective.name(),
        objective: best.values[0],
        gradient,
        projected_gradient_norm,
        constraints: best.values[1..].to_vec(),
        constraint_texts: goal.constraints.iter().map(Constraint::text).collect(),
        at_bound,
        converged: converged && !stopped,
        kkt,
        stopped,
        termination: if stopped { "stopped: the best point so far".into() } else { termination },
        history: st.history,
        grid,
        orbits: ev.orbits,
        runs: ev.runs,
        orbit: best.orbit,
    })
}

/// The start's evaluation: its failure is the optimization's, a
/// search's failure there said with the start's values.
///
/// # Errors
/// The evaluation's, a failed search as [`AnalysisError::Request`].
fn start<M: Model>(ev: &mut Evaluator<'_, M>, design: &Design<M>) -> Result<Point, AnalysisError> {
    ev.at(&design.start, true).map_err(|e| match e {
        e @ (AnalysisError::NotConverged { .. } | AnalysisError::Numerics { .. }) => {
            let at: Vec<String> = design
                .names
                .iter()
                .zip(&design.start)
                .map(|(n, v)| format!("{n} = {}", crate::names::fmt_value(*v)))
                .collect();
            AnalysisError::Request { reason: format!("at the start ({}): {e}", at.join(", ")) }
        }
        e => e,
    })
}

/// Whether the search converged, and how to say it, as SLSQP's
/// `outcome` says and as the best point is: a constraint it violates
/// beyond [`FEASIBLE`] of its scale (`values` and `scales` per
/// constraint), or a stop where the KKT conditions do not hold, is no
/// convergence.
fn verdict(
    goal: &Goal,
    (values, scales): (&[f64], &[(f64, f64)]),
    kkt: &Kkt,
    outcome: (bool, String),
) -> (bool, String) {
    let violated: Vec<String> = goal
        .constraints
        .iter()
        .zip(values)
        .zip(scales)
        .filter(|((c, v), (_, scale))| c.violation(**v) > FEASIBLE * scale)
        .map(|((c, v), _)| format!("{} (it is {} there)", c.text(), crate::names::fmt_value(*v)))
        .collect();
    let (converged, termination) = outcome;
    if !violated.is_empty() {
        (false, format!("no point found satisfies {}: the best has the least violation", violated.join(", ")))
    } else if converged && !kkt.holds {
        // the optimizer's word is not taken: its stop at a point that is
        // not stationary is no convergence
        let why = termination.trim_start_matches("converged: ").trim_start_matches("converged ");
        (false, format!("not converged: the search ended ({why}), but at the best point the {}", kkt.describe()))
    } else {
        (converged, termination)
    }
}

/// The norm of the minimized function's gradient in the unit box (`sign`
/// 1 to minimize, -1 to maximize), a component pinned against its bound
/// left out.
fn projected_gradient_norm<M: Model>(design: &Design<M>, values: &[f64], gradient: &[f64], sign: f64) -> f64 {
    (0..values.len())
        .map(|k| {
            let span = design.upper[k] - design.lower[k];
            // the minimized function's slope in u
            let g = sign * gradient[k] * span;
            let pinned = (values[k] - design.lower[k] <= 1e-9 * span && g > 0.0)
                || (design.upper[k] - values[k] <= 1e-9 * span && g < 0.0);
            if pinned { 0.0 } else { g * g }
        })
        .sum::<f64>()
        .sqrt()
}

/// Whether SLSQP's outcome is a convergence, and how to say it.
fn termination<M: Model>(outcome: &SlsqpOutcome, st: &State<'_, M>, max: usize) -> (bool, String) {
    use slsqp::{FailStatus, SuccessStatus};
    match outcome {
        _ if st.settled => (
            true,
            format!(
                "converged: {STALL} points in a row within xtol of the best, none better (the quantities' accuracy)"
            ),
        ),
        _ if st.history.len() >= max => {
            (false, format!("not converged: the budget of {max} evaluations is spent (raise it, or narrow the bounds)"))
        }
        Ok((SuccessStatus::XtolReached, ..)) => {
            (true, "converged: the last step moved the parameters by less than xtol".into())
        }
        Ok((SuccessStatus::Success | SuccessStatus::FtolReached, ..)) => {
            (true, "converged: the optimality conditions hold (SLSQP)".into())
        }
        Ok((SuccessStatus::MaxEvalReached, ..)) => {
            (false, format!("not converged: the budget of {max} evaluations is spent"))
        }
        Ok((s, ..)) => (false, format!("not converged: SLSQP ended with {s:?}")),
        // the line search found no descent: the gradient and the values no
        // longer agree (the quantities' own accuracy is reached)
        Err((FailStatus::RoundoffLimited, ..)) => {
            (true, "converged to the quantities' accuracy (SLSQP's line search found no further decrease)".into())
        }
        Err((e, ..)) => (false, format!("not converged: SLSQP failed ({e:?})")),
    }
}

/// The objective over a grid of `per_axis` points per parameter around
/// `values` (a tenth of each span on either side, within the bounds),
/// the first parameter varying fastest.
fn grid_around<M: Model>(
    ev: &mut Evaluator<'_, M>,
    design: &Design<M>,
    values: &[f64],
    per_axis: usize,
) -> Result<Vec<Evaluation>, AnalysisError> {
    let axes: Vec<Vec<f64>> = (0..values.len())
        .map(|k| {
            let w = 0.1 * (design.upper[k] - design.lower[k]);
            let (a, b) = ((values[k] - w).max(design.lower[k]), (values[k] + w).min(design.upper[k]));
            if per_axis == 1 {
                return vec![values[k]];
            }
            (0..per_axis).map(|i| a + (b - a) * i as f64 / (per_axis - 1) as f64).collect()
        })
        .collect();
    let total: usize = axes.iter().map(Vec::len).product();
    let mut out = Vec::with_capacity(total);
    for idx in 0..total {
        let (i, j) = (idx % per_axis, idx / per_axis);
        // a snake through the grid: each point next to the last (the
        // gait's guess)
        let i = if j % 2 == 1 { per_axis - 1 - i } else { i };
        let mut at = vec![axes[0][i]];
        if axes.len() > 1 {
            at.push(axes[1][j]);
        }
        let mut e = Evaluation {
            values: at.clone(),
            objective: f64::NAN,
            constraints: Vec::new(),
            gradient: Vec::new(),
            failure: None,
        };
        match ev.at(&at, false) {
            Ok(p) => {
                e.objective = p.values[0];
                e.constraints = p.values[1..].to_vec();
            }
            Err(AnalysisError::Stopped) => break,
            Err(err) => e.failure = Some(err.to_string()),
        }
        out.push(e);
    }
    Ok(out)
}
