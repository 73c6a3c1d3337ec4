//! Gait optimization for kinematic systems: the Fourier gait that
//! maximizes (or minimizes) a cycle's net motion along a direction, its
//! net rotation, or either per unit of the shape path's length, subject
//! to ranges of the shape, a margin from the singular set and a budget
//! of path length ([`optimize_gait`]).
//!
//! # Method
//!
//! Each shape coordinate is a Fourier series ([`FourierGait`]); the
//! unknowns are its coefficients, any of them held at the start's value
//! ([`GaitOptimization::free`]). The net motion per cycle is that of
//! [`Geometry::predict`] at the order asked ([`Order`]): the first order
//! `-oint A(r) dr` (by Stokes's theorem the area integral of `-dA`),
//! the second with the Lie bracket's area integral (two shape
//! coordinates), or the reconstruction `g' = g xi` integrated exactly
//! (Hatton & Choset, "Geometric motion planning: the local connection,
//! Stokes's theorem, and the importance of coordinate choice", IJRR
//! 30(8), 2011). The cost is the gait's length in a metric of shape space
//! `int sqrt(r'^T G r') dt` (the identity by default), and the efficiency
//! the net motion per unit of it (Ramasamy & Hatton, "The geometry of
//! optimal gaits for drag-dominated kinematic systems", IEEE T-RO 35(4),
//! 2019, §IV). Every gradient is exact (see `evaluate`'s docs: dual
//! numbers through the quadratures and the connection, the variational
//! equations of the reconstruction).
//!
//! The search is Kraft's SLSQP (crate `slsqp`), as in
//! [`crate::design::optimize`]: the free coefficients boxed within
//! [`GaitOptimization::coefficient_limit`], the objective scaled so that
//! the first step moves about 0.1 rad, each coordinate's range as linear
//! constraints at the quadrature's samples, the rank margin at every
//! sample and the path length as nonlinear ones. Its word is not taken:
//! the best point is declared converged only where it is feasible and
//! the first-order (KKT) conditions hold on the exact gradients
//! ([`Kkt`]), so a start that is not stationary is never returned as its
//! own optimum. A gait that meets the singular set (or crosses to its
//! other side) counts as a failed point, worse than any seen; five in a
//! row end the search, not converged, at the best point so far (an
//! objective that grows toward the singular set, as the kinematic
//! snake's efficiency does, needs a margin); five failures of another
//! kind end it with the last one's error.
//!
//! A mixed system (a momentum the skates leave free) is refused here:
//! its net motion depends on more than the curve. Its gait is a
//! [`DriveGait`], the Fourier coefficients of its drives' prescribed
//! angles as a [`crate::design::Design`], optimized by
//! [`crate::design::optimize::optimize`] over the simulated gait with
//! its exact sensitivities ([`dynamic`]).

mod check;
pub mod dynamic;
#[cfg(test)]
mod dynamic_tests;
mod evaluate;
mod fourier;
#[cfg(test)]
mod tests;

use std::cell::RefCell;

pub use dynamic::{DriveGait, drive_angle};
pub use fourier::{FourierGait, MAX_ORDER};

use crate::design::optimize::kkt::{self, ACTIVE, Candidate, Kkt};
use crate::design::optimize::quantity::Sense;
use crate::geometry::{Geometry, GeometryError};
use crate::model::Model;
use check::check;
use evaluate::{Point, Setup, evaluate, side_of};

/// Most evaluations an optimization may be given.
pub const MAX_EVALUATIONS: usize = 10_000;

/// A constraint holds where its scaled violation is at most this (as in
/// [`crate::design::optimize`]).
const FEASIBLE: f64 = 1e-9;

/// Failures in a row that end a search.
const FAILURES: usize = 5;

/// Evaluations in a row within `xtol` of the best, none better, that end
/// a search as settled.
const STALL: usize = 3;

/// Which order of the prediction the objective takes (the fields of
/// [`crate::geometry::GaitPrediction`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// `-oint A dr`: first order in the gait's size.
    First,
    /// The first order plus the bracket's area integral (two shape
    /// coordinates only): second order.
    Second,
    /// The reconstruction `g' = g xi` integrated over the cycle: exact to
    /// the integration's tolerance (1e-12).
    Reconstructed,
}

/// What of the net motion `(dx, dy, dtheta)` the objective measures, in
/// the reference body's initial frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measure {
    /// The displacement along a direction `(ux, uy)` (normalized; `[1,
    /// 0]` is `dx`, `[0, 1]` is `dy`) \[m\].
    Along([f64; 2]),
    /// The net rotation `dtheta` \[rad\].
    Rotation,
}

/// The objective: a measure of the net motion per cycle at an order,
/// alone or per unit cost (the path length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaitObjective {
    /// What is measured.
    pub measure: Measure,
    /// Divided by the cost (the efficiency of Ramasamy & Hatton 2019):
    /// \[m/rad\] or \[rad/rad\].
    pub per_cost: bool,
    /// At which order.
    pub order: Order,
}

impl GaitObjective {
    /// The objective's name: `dx (first order)`, `dy per path length
    /// (reconstructed)`.
    pub fn name(&self) -> String {
        let what = match self.measure {
            Measure::Along([x, y]) if y == 0.0 && x > 0.0 => "dx".to_string(),
            Measure::Along([x, y]) if x == 0.0 && y > 0.0 => "dy".to_string(),
            Measure::Along([x, y]) => format!("displacement along ({x}, {y})"),
            Measure::Rotation => "dtheta".into(),
        };
        let order = match self.order {
            Order::First => "first order",
            Order::Second => "second order",
            Order::Reconstructed => "reconstructed",
        };
        format!("{what}{} ({order})", if self.per_cost { " per path length" } else { "" })
    }

    /// The value and gradient from the net motion and the cost with theirs.
    fn value(&self, motion: [f64; 3], dmotion: &[[f64; 3]], cost: f64, dcost: &[f64]) -> (f64, Vec<f64>) {
        let project = |m: &[f64; 3]| match self.measure {
            Measure::Along([x, y]) => {
                let n = x.hypot(y);
                (x * m[0] + y * m[1]) / n
            }
            Measure::Rotation => m[2],
        };
        let d = project(&motion);
        let dd: Vec<f64> = dmotion.iter().map(project).collect();
        if self.per_cost {
            (d / cost, dd.iter().zip(dcost).map(|(a, b)| (a * cost - d * b) / (cost * cost)).collect())
        } else {
            (d, dd)
        }
    }
}

/// A gait optimization: the start, which coefficients are free, the
/// objective and its sense, the constraints and the search's settings.
#[derive(Debug, Clone)]
pub struct GaitOptimization {
    /// The start, and the values of the coefficients held.
    pub start: FourierGait,
    /// Per flat coefficient ([`FourierGait::flat`]), whether it is free
    /// (all by default).
    pub free: Vec<bool>,
    /// The objective.
    pub objective: GaitObjective,
    /// Maximize (the default) or minimize it.
    pub sense: Sense,
    /// The metric `G` of the cost (n_shape x n_shape, row-major,
    /// symmetric positive definite) \[1\]; `None` for the identity.
    pub metric: Option<Vec<f64>>,
    /// Per shape coordinate, its range `(lower, upper)` over the cycle
    /// \[rad\], held at the quadrature's samples (empty: none): between
    /// two samples `dt` apart the curve may pass a bound by up to `|r''|
    /// dt^2 / 8` (about 1e-4 rad for an order-1 gait of amplitude 0.6).
    pub bounds: Vec<Option<(f64, f64)>>,
    /// The least rank margin ([`crate::geometry::Connection::rank_margin`])
    /// allowed along the gait, in (0, 1) \[1\].
    pub margin: Option<f64>,
    /// The most path length allowed \[rad\].
    pub budget: Option<f64>,
    /// Each free coefficient stays within `+-` this \[rad\] (default pi:
    /// a hinge angle beyond half a turn folds the links on each other).
    pub coefficient_limit: f64,
    /// Most evaluations (each with its gradient), at most
    /// [`MAX_EVALUATIONS`] (default 200).
    pub max_evaluations: usize,
    /// SLSQP stops when a step moves every free coefficient by less than
    /// this \[rad\] (default 1e-10).
    pub xtol: f64,
}

impl GaitOptimization {
    /// Maximize `objective` from `start`, every coefficient free, no
    /// constraints, the defaults of the fields.
    pub fn new(start: FourierGait, objective: GaitObjective) -> Self {
        let n = start.n_shape() * start.per_coordinate();
        Self {
            start,
            free: vec![true; n],
            objective,
            sense: Sense::Maximize,
            metric: None,
            bounds: Vec::new(),
            margin: None,
            budget: None,
            coefficient_limit: std::f64::consts::PI,
            max_evaluations: 200,
            xtol: 1e-10,
        }
    }

    /// Holds every coefficient but the constant terms `a_0` (the circle
    /// of fixed radius about a free centre, for an order-1 circle).
    pub fn centre_only(mut self) -> Self {
        let n = self.start.per_coordinate();
        self.free = (0..self.free.len()).map(|j| j % n == 0).collect();
        self
    }
}

/// One evaluation of a search.
#[derive(Debug, Clone)]
pub struct GaitEvaluation {
    /// The free coefficients' values \[rad\].
    pub values: Vec<f64>,
    /// The objective (NaN where the evaluation failed).
    pub objective: f64,
    /// Why it failed.
    pub failure: Option<String>,
}

/// A gait optimization's result ([`optimize_gait`]).
#[derive(Debug, Clone)]
pub struct GaitOptimum {
    /// The best gait found (the held coefficients at their values).
    pub gait: FourierGait,
    /// The free coefficients' names (`alpha1.a0`).
    pub names: Vec<String>,
    /// Their values at the best gait \[rad\].
    pub values: Vec<f64>,
    /// The objective's name ([`GaitObjective::name`]).
    pub objective_name: String,
    /// Its value at the best gait \[m\], \[rad\], or per rad of path.
    pub objective: f64,
    /// Its value at the start.
    pub start_objective: f64,
    /// Its gradient in the free coefficients (per rad).
    pub gradient: Vec<f64>,
    /// The norm of the gradient of the optimized function (the objective,
    /// negated to maximize) with the components that push against an
    /// active coefficient bound removed (per rad; 0 at an unconstrained
    /// optimum).
    pub projected_gradient_norm: f64,
    /// The net motion `(dx, dy, dtheta)` \[m, m, rad\] at the objective's
    /// order.
    pub motion: [f64; 3],
    /// The path length in the metric \[rad\].
    pub cost: f64,
    /// The least rank margin along the gait (at the quadrature's samples).
    pub rank_margin: f64,
    /// Whether it converged: SLSQP (or the line search circling the best
    /// point) ended, the best point is feasible and the KKT conditions
    /// hold there. Never for a budget spent, a stop or a failure.
    pub converged: bool,
    /// The first-order conditions at the best point: the stationarity
    /// residual, the constraints and bounds that bind (by name, with their
    /// multipliers).
    pub kkt: Kkt,
    /// Whether a stop hook ended it.
    pub stopped: bool,
    /// How it ended.
    pub termination: String,
    /// Every evaluation in order (each with its gradient): the count is
    /// the search's cost.
    pub history: Vec<GaitEvaluation>,
}

/// A constraint in SLSQP's `c(x) <= 0` form (scaled).
#[derive(Debug, Clone, Copy)]
enum Con {
    /// Coordinate `coord`'s value at sample `n` against `bound`: `r - hi
    /// <= 0` (upper) or `lo - r <= 0`.
    Range { coord: usize, n: usize, upper: bool, bound: f64 },
    /// `(margin - m_n) / margin <= 0` at sample `n`.
    Margin { n: usize, margin: f64 },
    /// `(L - budget) / budget <= 0`.
    Budget { budget: f64 },
}

/// The search's state between SLSQP's calls.
struct State<'g, M: Model> {
    g: &'g Geometry<M>,
    setup: Setup,
    names: Vec<String>,
    side: f64,
    cons: Vec<Con>,
    /// `sign * scale` of the objective (sign -1 to maximize).
    objective_scale: f64,
    limit: f64,
    last: Option<(Vec<f64>, Result<Point, String>)>,
    history: Vec<GaitEvaluation>,
    best: Option<(Point, Vec<f64>)>,
    stall: usize,
    settled: bool,
    xtol: f64,
    failures: usize,
    max: usize,
    fatal: Option<GeometryError>,
    /// Five points in a row met the singular set: the last one's words.
    blocked: Option<String>,
    stopped: bool,
}

/// The gait of `problem`'s form on `geometry` (a kinematic system) that
/// maximizes or minimizes its objective subject to its constraints, from
/// its start (see the module's docs for the method).
///
/// # Errors
/// [`GeometryError::Model`] for a model without shape coordinates, or
/// one that is not kinematic (a momentum: the net motion then depends
/// on more than the curve). [`GeometryError::Request`] for a start of
/// another shape count, no free coefficient, a free coefficient beyond
/// the coefficient limit, the second order without exactly two shape
/// coordinates, a zero or non-finite direction, a metric that is not
/// symmetric positive definite (the cost would not bound the gait), an
/// objective per cost at a start of zero length, a range whose lower
/// bound is above its upper or not finite, a margin outside (0, 1), a
/// budget that is not a positive number, settings out of range.
/// [`GeometryError::Singular`] for a start that meets the singular set,
/// naming the time and shape. The last failure of five in a row (but
/// the singular set met five times in a row is no error: the best point
/// so far, not converged).
pub fn optimize_gait<M: Model>(
    geometry: &Geometry<M>,
    problem: &GaitOptimization,
) -> Result<GaitOptimum, GeometryError> {
    let setup = check(geometry, problem)?;
    let start = problem.start.flat();
    let x0: Vec<f64> = setup.free.iter().map(|&j| start[j]).collect();
    let side = side_of(geometry, &setup, &start);
    let p0 = evaluate(geometry, &setup, &x0, 0.0).map_err(|e| match e {
        GeometryError::Singular { reason } => GeometryError::Singular { reason: format!("the start: {reason}") },
        e => e,
    })?;
    if problem.objective.per_cost && p0.cost.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(GeometryError::Request {
            reason: "the start gait has zero path length (every amplitude 0): its net motion per path length has no value; start from a gait that moves".into(),
        });
    }
    let sign = match problem.sense {
        Sense::Minimize => 1.0,
        Sense::Maximize => -1.0,
    };
    let g0 = p0.gradient.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let objective_scale = sign * if g0 > 0.0 && g0.is_finite() { 0.1 / g0 } else { 1.0 };
    let names = setup.free.iter().map(|&j| problem.start.coefficient_label(&geometry.shape_names(), j)).collect();
    let cons = constraints(problem, &setup);
    let start_objective = p0.objective;
    let state = RefCell::new(State {
        g: geometry,
        setup,
        names,
        side,
        cons,
        objective_scale,
        limit: problem.coefficient_limit,
        last: Some((x0.clone(), Ok(p0.clone()))),
        history: vec![GaitEvaluation { values: x0.clone(), objective: p0.objective, failure: None }],
        best: Some((p0, x0.clone())),
        stall: 0,
        settled: false,
        xtol: problem.xtol,
        failures: 0,
        max: problem.max_evaluations,
        fatal: None,
        blocked: None,
        stopped: false,
    });
    let outcome = search(&state, &x0, problem);
    let mut st = state.into_inner();
    if let Some(e) = st.fatal.take() {
        return Err(e);
    }
    finish(st, problem, start_objective, g0, &outcome)
}

/// What SLSQP returns: the status, the point, the value.
type Outcome = Result<(slsqp::SuccessStatus, Vec<f64>, f64), (slsqp::FailStatus, Vec<f64>, f64)>;

/// A constraint as SLSQP calls it.
type SlsqpConstraint<'a> = Box<dyn Fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64 + 'a>;

/// Runs SLSQP on the state from `x0`.
fn search<M: Model>(state: &RefCell<State<'_, M>>, x0: &[f64], problem: &GaitOptimization) -> Outcome {
    let n = x0.len();
    let objective = |x: &[f64], grad: Option<&mut [f64]>, _: &mut ()| state.borrow_mut().objective(x, grad);
    let count = state.borrow().cons.len();
    let constraints: Vec<SlsqpConstraint<'_>> = (0..count)
        .map(|i| {
            Box::new(move |x: &[f64], grad: Option<&mut [f64]>, _: &mut ()| state.borrow_mut().constraint(x, i, grad))
                as SlsqpConstraint<'_>
        })
        .collect();
    let tols = slsqp::StopTols { xtol_abs: vec![problem.xtol; n], ..slsqp::StopTols::default() };
    let bounds = vec![(-problem.coefficient_limit, problem.coefficient_limit); n];
    slsqp::minimize(objective, x0, &bounds, &constraints, (), problem.max_evaluations, Some(tols))
}

/// The result from the state after the search.
fn finish<M: Model>(
    mut st: State<'_, M>,
    problem: &GaitOptimization,
    start_objective: f64,
    g0: f64,
    outcome: &Outcome,
) -> Result<GaitOptimum, GeometryError> {
    let (converged, termination) = termination(outcome, &st, problem.max_evaluations);
    let (best, x) = st.best.take().expect("the start at least");
    let kkt = st.kkt(&best, &x, st.objective_scale.abs() * g0);
    let feasible = st.violation(&best, &x) == 0.0;
    let (converged, termination) = if !feasible {
        let what: Vec<String> = st
            .cons
            .iter()
            .enumerate()
            .filter(|(i, _)| st.scaled_constraint(&best, &x, *i).0 > FEASIBLE)
            .map(|(_, c)| st.describe(c))
            .take(3)
            .collect();
        (false, format!("no point found satisfies {}: the best has the least violation", what.join(", ")))
    } else if converged && !kkt.holds {
        (
            false,
            // the optimizer's word is not taken: its stop at a point that
            // is not stationary is no convergence
            format!(
                "not converged: the search ended ({}), but at the best point the {}",
                termination.trim_start_matches("converged: "),
                kkt.describe()
            ),
        )
    } else {
        (converged, termination)
    };
    let sign = st.objective_scale.signum();
    let projected_gradient_norm = best
        .gradient
        .iter()
        .zip(&x)
        .map(|(gk, xk)| {
            let g = sign * gk;
            let pinned = (xk + st.limit <= 1e-9 * st.limit && g > 0.0) || (st.limit - xk <= 1e-9 * st.limit && g < 0.0);
            if pinned { 0.0 } else { g * g }
        })
        .sum::<f64>()
        .sqrt();
    let gait = problem.start.with_flat(&st.setup.full(&x));
    let rank_margin = best.margins.iter().map(|m| m.0).fold(f64::INFINITY, f64::min);
    Ok(GaitOptimum {
        gait,
        names: st.names.clone(),
        values: x,
        objective_name: problem.objective.name(),
        objective: best.objective,
        start_objective,
        gradient: best.gradient.clone(),
        projected_gradient_norm,
        motion: best.motion,
        cost: best.cost,
        rank_margin,
        converged: converged && !st.stopped,
        kkt,
        stopped: st.stopped,
        termination: if st.stopped { "stopped: the best point so far".into() } else { termination },
        history: st.history,
    })
}

/// Whether SLSQP's outcome is a convergence, and how to say it.
fn termination<M: Model>(outcome: &Outcome, st: &State<'_, M>, max: usize) -> (bool, String) {
    use slsqp::{FailStatus, SuccessStatus};
    match outcome {
        _ if st.blocked.is_some() => (
            false,
            format!(
                "not converged: {FAILURES} points in a row met the singular set, the last as: {}; a margin from it (`margin`) keeps the search away",
                st.blocked.as_deref().unwrap_or("")
            ),
        ),
        _ if st.settled => (true, format!("converged: {STALL} points in a row within xtol of the best, none better")),
        _ if st.history.len() >= max => (false, format!("not converged: the budget of {max} evaluations is spent")),
        Ok((SuccessStatus::XtolReached, ..)) => {
            (true, "converged: the last step moved the coefficients by less than xtol".into())
        }
        Ok((SuccessStatus::Success | SuccessStatus::FtolReached, ..)) => {
            (true, "converged: the optimality conditions hold (SLSQP)".into())
        }
        Ok((s, ..)) => (false, format!("not converged: SLSQP ended with {s:?}")),
        Err((FailStatus::RoundoffLimited, ..)) => {
            (true, "converged to rounding (SLSQP's line search found no further decrease)".into())
        }
        Err((e, ..)) => (false, format!("not converged: SLSQP failed ({e:?})")),
    }
}

/// The constraints of `problem`: the ranges at every sample, the margin
/// at every sample, the budget.
fn constraints(problem: &GaitOptimization, setup: &Setup) -> Vec<Con> {
    let mut cons = Vec::new();
    for (coord, b) in problem.bounds.iter().enumerate() {
        if let Some((lo, hi)) = *b {
            for n in 0..setup.samples {
                cons.push(Con::Range { coord, n, upper: true, bound: hi });
                cons.push(Con::Range { coord, n, upper: false, bound: lo });
            }
        }
    }
    if let Some(margin) = problem.margin {
        cons.extend((0..setup.samples).map(|n| Con::Margin { n, margin }));
    }
    if let Some(budget) = problem.budget {
        cons.push(Con::Budget { budget });
    }
    cons
}

impl<M: Model> State<'_, M> {
    /// The point at `x`, evaluated once.
    fn at(&mut self, x: &[f64]) {
        if self.last.as_ref().is_some_and(|(lx, _)| lx == x) || self.frozen() {
            return;
        }
        if self.history.len() >= self.max {
            self.last = Some((x.to_vec(), Err("the evaluation budget is spent".into())));
            return;
        }
        match evaluate(self.g, &self.setup, x, self.side) {
            Ok(p) => {
                self.failures = 0;
                self.history.push(GaitEvaluation { values: x.to_vec(), objective: p.objective, failure: None });
                let better = self.best.as_ref().is_none_or(|(b, bx)| {
                    let (a, b) = (self.rank(&p, x), self.rank(b, bx));
                    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
                });
                let near = self
                    .best
                    .as_ref()
                    .is_some_and(|(_, bx)| bx.iter().zip(x).all(|(a, b)| (a - b).abs() <= 10.0 * self.xtol));
                self.stall = if near && !better { self.stall + 1 } else { 0 };
                self.settled = self.stall >= STALL;
                if better {
                    self.best = Some((p.clone(), x.to_vec()));
                }
                self.last = Some((x.to_vec(), Ok(p)));
            }
            Err(GeometryError::Stopped) => self.stopped = true,
            Err(e) => {
                self.failures += 1;
                self.history.push(GaitEvaluation {
                    values: x.to_vec(),
                    objective: f64::NAN,
                    failure: Some(e.to_string()),
                });
                self.last = Some((x.to_vec(), Err(e.to_string())));
                if self.failures >= FAILURES {
                    match e {
                        GeometryError::Singular { reason } => self.blocked = Some(reason),
                        e => self.fatal = Some(e),
                    }
                }
            }
        }
    }

    /// Whether no more evaluations are made: a stop, a fatal failure,
    /// the singular set met five times in a row, or settled.
    fn frozen(&self) -> bool {
        self.stopped || self.fatal.is_some() || self.blocked.is_some() || self.settled
    }

    /// The point at `x` if its evaluation succeeded and the search goes on.
    fn fresh(&self, x: &[f64]) -> Option<&Point> {
        if self.frozen() {
            return None;
        }
        match &self.last {
            Some((lx, Ok(p))) if lx == x => Some(p),
            _ => None,
        }
    }

    /// The scaled objective at `x` and its gradient.
    fn objective(&mut self, x: &[f64], grad: Option<&mut [f64]>) -> f64 {
        self.at(x);
        let os = self.objective_scale;
        if let Some(p) = self.fresh(x) {
            if let Some(g) = grad {
                g.iter_mut().zip(&p.gradient).for_each(|(gk, d)| *gk = os * d);
            }
            return os * p.objective;
        }
        if let Some(g) = grad {
            g.fill(0.0);
        }
        let best = self.best.as_ref().map_or(0.0, |(b, _)| os * b.objective);
        // a failed point: worse than any seen; after a stop, settling or a
        // fatal failure, the best value, flat (SLSQP then ends at once)
        if self.frozen() { best } else { best + 1.0 + best.abs() }
    }

    /// Constraint `i`'s scaled value at `x` and its gradient: a range's
    /// from the coefficients alone (linear), the others' from the point
    /// (a failed one's: violated, flat).
    fn constraint(&mut self, x: &[f64], i: usize, grad: Option<&mut [f64]>) -> f64 {
        let found = if let Con::Range { coord, n, upper, bound } = self.cons[i] {
            Some(self.range(x, coord, n, upper, bound))
        } else {
            self.at(x);
            match &self.last {
                Some((lx, Ok(p))) if lx == x => Some(self.scaled_constraint(p, x, i)),
                _ => None,
            }
        };
        let (v, d) = found.unwrap_or_else(|| (1.0, vec![0.0; x.len()]));
        if let Some(g) = grad {
            g.copy_from_slice(&d);
        }
        v
    }

    /// The range constraint of coordinate `coord` at sample `n` (`r - hi`
    /// for an upper bound, `lo - r` for a lower) at the free values `x`,
    /// and its gradient (the basis functions there).
    fn range(&self, x: &[f64], coord: usize, n: usize, upper: bool, bound: f64) -> (f64, Vec<f64>) {
        let s = &self.setup;
        let c = s.full(x);
        let t = s.time(n);
        let r = fourier::shape_at(&c, s.ns, s.omega, t).0[coord];
        let per = c.len() / s.ns;
        let sign = if upper { 1.0 } else { -1.0 };
        let grad = s
            .free
            .iter()
            .map(|&j| if j / per == coord { sign * fourier::basis(j % per, s.omega, t).0 } else { 0.0 })
            .collect();
        (sign * (r - bound), grad)
    }

    /// Constraint `i`'s scaled value `c <= 0` at point `p` (free values
    /// `x`) and its gradient.
    fn scaled_constraint(&self, p: &Point, x: &[f64], i: usize) -> (f64, Vec<f64>) {
        let nf = x.len();
        match self.cons[i] {
            Con::Range { coord, n, upper, bound } => self.range(x, coord, n, upper, bound),
            Con::Margin { n, margin } => {
                let (m, dm) = &p.margins[n];
                ((margin - m) / margin, (0..nf).map(|k| -dm[k] / margin).collect())
            }
            Con::Budget { budget } => {
                ((p.cost - budget) / budget, p.cost_gradient.iter().map(|d| d / budget).collect())
            }
        }
    }

    /// Total scaled violation beyond [`FEASIBLE`] at `p`.
    fn violation(&self, p: &Point, x: &[f64]) -> f64 {
        (0..self.cons.len()).map(|i| (self.scaled_constraint(p, x, i).0 - FEASIBLE).max(0.0)).sum()
    }

    /// A point's rank: violation, then the scaled objective (minimized).
    fn rank(&self, p: &Point, x: &[f64]) -> (f64, f64) {
        (self.violation(p, x), p.objective * self.objective_scale)
    }

    /// A constraint in words.
    fn describe(&self, c: &Con) -> String {
        let names = self.g.shape_names();
        let fmt = crate::names::fmt_value;
        match *c {
            Con::Range { coord, n, upper, bound } => format!(
                "{} {} {} at t = {} s",
                names[coord],
                if upper { "<=" } else { ">=" },
                fmt(bound),
                fmt(self.setup.time(n))
            ),
            Con::Margin { n, margin } => {
                format!("rank margin >= {} at t = {} s", fmt(margin), fmt(self.setup.time(n)))
            }
            Con::Budget { budget } => format!("path length <= {}", fmt(budget)),
        }
    }

    /// The first-order conditions at the best point `p` (free values
    /// `x`); `scale` the start's scaled gradient.
    fn kkt(&self, p: &Point, x: &[f64], scale: f64) -> Kkt {
        let os = self.objective_scale;
        let n = x.len();
        let g: Vec<f64> = p.gradient.iter().map(|d| os * d).collect();
        let mut candidates = Vec::new();
        for (i, c) in self.cons.iter().enumerate() {
            let (v, grad) = self.scaled_constraint(p, x, i);
            if v >= -ACTIVE {
                let k = match *c {
                    Con::Range { .. } => 1.0,
                    Con::Margin { margin, .. } => margin,
                    Con::Budget { budget } => budget,
                };
                candidates.push(Candidate { name: self.describe(c), gradient: grad, unit: 1.0 / (os.abs() * k) });
            }
        }
        for (k, &xk) in x.iter().enumerate() {
            let unit = |dir: f64| Candidate {
                name: format!(
                    "{} {} {}",
                    self.names[k],
                    if dir < 0.0 { ">=" } else { "<=" },
                    crate::names::fmt_value(dir * self.limit)
                ),
                gradient: (0..n).map(|j| if j == k { dir } else { 0.0 }).collect(),
                unit: 1.0 / os.abs(),
            };
            if xk + self.limit <= 1e-9 * self.limit {
                candidates.push(unit(-1.0));
            }
            if self.limit - xk <= 1e-9 * self.limit {
                candidates.push(unit(1.0));
            }
        }
        let mut conditions = kkt::check(&g, &candidates, scale);
        conditions.holds &= self.violation(p, x) == 0.0;
        conditions
    }
}
