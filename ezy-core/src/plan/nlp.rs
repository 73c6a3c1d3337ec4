//! The nonlinear program of a plan solved by SLSQP (Kraft 1988, the crate
//! `slsqp`, as [`crate::design::optimize`]), its first-order conditions
//! checked afterwards, and a second program that minimizes the
//! constraints' violation alone where the first found no feasible point.
//!
//! The crate takes inequality constraints `g(x) <= 0` only, so each
//! equality `c_i = 0` enters as the pair `+-c_i / s_i <= eps` (`s_i` its
//! state component's scale, `eps` a hundredth of the feasibility
//! tolerance in those units): the pair's linearizations bound a slab in
//! each quadratic subproblem, whose width keeps them from being active
//! together with opposite multipliers.

use std::cell::RefCell;

use super::transcription::{Point, Transcription};
use crate::analysis::AnalysisError;
use crate::model::Model;

/// A constraint as SLSQP calls it: `g(x) <= 0`, its gradient into the slice.
type SlsqpConstraint<'a> = Box<dyn Fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64 + 'a>;

/// What SLSQP returns: the status, the point, the value.
type SlsqpOutcome = Result<(slsqp::SuccessStatus, Vec<f64>, f64), (slsqp::FailStatus, Vec<f64>, f64)>;

/// Failures of evaluations in a row that end the solve with the last one's error.
const FAILURES: usize = 5;

/// The scales of a program: unknowns (n), equalities (m), path
/// inequalities (p), objective.
#[derive(Debug, Clone)]
pub(super) struct Scales {
    pub w: Vec<f64>,
    pub c: Vec<f64>,
    pub g: Vec<f64>,
    pub f: f64,
}

/// What the program minimizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The objective (the effort times its weight plus the user's term)
    /// subject to the constraints.
    Effort,
    /// `1/2 sum (c_i / s_i)^2 + 1/2 sum max(g_i / s_i, 0)^2`, bounds only.
    Violation,
}

/// The largest violation of `p`'s constraints \[their units: the
/// equalities' state components', the path constraints' own\], with
/// the row (the equalities' first, then the inequalities').
pub(super) fn violation(p: &Point) -> (f64, usize) {
    let m = p.c.len();
    let eq = p.c.iter().enumerate().map(|(i, v)| (v.abs(), i));
    let ineq = p.g.iter().enumerate().map(|(i, v)| (v.max(0.0), m + i));
    eq.chain(ineq).fold((0.0, 0), |(m, at), (v, i)| if v > m { (v, i) } else { (m, at) })
}

/// `1/2 sum (c_i / s_i)^2 + 1/2 sum max(g_i / s_i, 0)^2` at `p`.
fn squared_violation(p: &Point, sc: &Scales) -> f64 {
    let eq = p.c.iter().zip(&sc.c).map(|(c, s)| (c / s) * (c / s)).sum::<f64>();
    let ineq = p.g.iter().zip(&sc.g).map(|(g, s)| (g.max(0.0) / s).powi(2)).sum::<f64>();
    0.5 * (eq + ineq)
}

struct State<'a, M: Model> {
    tr: &'a mut Transcription<M>,
    sc: &'a Scales,
    phase: Phase,
    /// Feasibility tolerance \[state units\].
    tol: f64,
    last: Option<(Vec<f64>, Result<Point, String>)>,
    /// The best point: feasible before infeasible, then by effort.
    best: Option<Point>,
    /// The point of least violation.
    least: Option<Point>,
    evaluations: usize,
    failures: usize,
    fatal: Option<AnalysisError>,
    /// SLSQP proposed a point that is not finite.
    broke: bool,
    /// The stop hook ended the search.
    stopped: bool,
}

impl<M: Model> State<'_, M> {
    fn w(&self, x: &[f64]) -> Vec<f64> {
        x.iter().zip(&self.sc.w).map(|(a, s)| a * s).collect()
    }

    fn rank(&self, p: &Point) -> (bool, f64) {
        let v = violation(p).0;
        if v <= self.tol { (false, p.objective) } else { (true, v) }
    }

    fn at(&mut self, x: &[f64]) {
        if self.last.as_ref().is_some_and(|(lx, _)| lx == x) || self.fatal.is_some() || self.broke || self.stopped {
            return;
        }
        if x.iter().any(|v| !v.is_finite()) {
            // SLSQP's subproblem broke down: its step is no point to run,
            // and this search is over
            self.broke = true;
            return;
        }
        let w = self.w(x);
        self.evaluations += 1;
        let r = self.tr.evaluate(&w);
        match r {
            Ok(p) => {
                self.failures = 0;
                let (r, v) = (self.rank(&p), violation(&p).0);
                if self.best.as_ref().is_none_or(|b| r.partial_cmp(&self.rank(b)) == Some(std::cmp::Ordering::Less)) {
                    self.best = Some(p.clone());
                }
                if self.least.as_ref().is_none_or(|b| v < violation(b).0) {
                    self.least = Some(p.clone());
                }
                self.last = Some((x.to_vec(), Ok(p)));
            }
            Err(AnalysisError::Stopped) => {
                self.stopped = true;
                self.last = Some((x.to_vec(), Err("stopped".into())));
            }
            Err(e) if self.tr.objective_error.is_some() => {
                // the user's objective failed: no point to go on from
                self.last = Some((x.to_vec(), Err(e.to_string())));
                self.fatal = Some(e);
            }
            Err(e) => {
                self.failures += 1;
                self.last = Some((x.to_vec(), Err(e.to_string())));
                if self.failures >= FAILURES {
                    self.fatal = Some(e);
                }
            }
        }
    }

    fn point(&mut self, x: &[f64]) -> Option<&Point> {
        self.at(x);
        match &self.last {
            Some((lx, Ok(p))) if lx == x && self.fatal.is_none() && !self.broke && !self.stopped => Some(p),
            _ => None,
        }
    }

    /// The objective at `x` and its gradient.
    fn objective(&mut self, x: &[f64], grad: Option<&mut [f64]>) -> f64 {
        let (phase, sc) = (self.phase, self.sc);
        let Some(p) = self.point(x) else {
            if let Some(g) = grad {
                g.fill(0.0);
            }
            if self.stopped {
                // the best point's value, flat: SLSQP ends at once
                return self.best.as_ref().map_or(0.0, |b| match phase {
                    Phase::Effort => b.objective / sc.f,
                    Phase::Violation => squared_violation(b, sc),
                });
            }
            let worst = self.best.as_ref().map_or(1.0, |b| b.objective / sc.f);
            return 2.0 * worst.abs() + 1.0;
        };
        match phase {
            Phase::Effort => {
                if let Some(g) = grad {
                    for (k, gk) in g.iter_mut().enumerate() {
                        *gk = p.objective_grad[k] * sc.w[k] / sc.f;
                    }
                }
                p.objective / sc.f
            }
            Phase::Violation => {
                if let Some(g) = grad {
                    g.fill(0.0);
                    let eq = p.jac.iter().zip(p.c.iter().zip(&sc.c));
                    let ineq = p.g_jac.iter().zip(p.g.iter().zip(&sc.g)).map(|(row, (v, s))| (row, (v.max(0.0), s)));
                    let ineq: Vec<_> = ineq.collect();
                    for (row, (v, s)) in eq.map(|(row, (v, s))| (row, (*v, s))).chain(ineq) {
                        let ci = v / s;
                        if ci == 0.0 {
                            continue;
                        }
                        for (k, gk) in g.iter_mut().enumerate() {
                            *gk += ci * row[k] * sc.w[k] / s;
                        }
                    }
                }
                squared_violation(p, sc)
            }
        }
    }

    /// Row `r` of the program as SLSQP takes it at `x`, and its gradient:
    /// `sign c_i / s_i - eps` for an equality's side (`r < 2 m`: row
    /// `r / 2`, sign by parity), `g_i / s_i - eps` for a path inequality.
    fn constraint(&mut self, x: &[f64], r: usize, grad: Option<&mut [f64]>) -> f64 {
        let (sc, m) = (self.sc, self.sc.c.len());
        let (i, sign, ineq) = if r < 2 * m {
            (r / 2, if r.is_multiple_of(2) { 1.0 } else { -1.0 }, false)
        } else {
            (r - 2 * m, 1.0, true)
        };
        let scale = if ineq { sc.g[i] } else { sc.c[i] };
        fn of(p: &Point, i: usize, ineq: bool) -> (f64, &[f64]) {
            if ineq { (p.g[i], &p.g_jac[i]) } else { (p.c[i], &p.jac[i]) }
        }
        let eps = 0.01 * self.tol / scale;
        let Some(p) = self.point(x) else {
            if let Some(g) = grad {
                g.fill(0.0);
            }
            if self.stopped {
                return self.best.as_ref().map_or(0.0, |b| (sign * of(b, i, ineq).0 / scale - eps).min(0.0));
            }
            return 1.0;
        };
        let (value, row) = of(p, i, ineq);
        if let Some(g) = grad {
            for (k, gk) in g.iter_mut().enumerate() {
                *gk = sign * row[k] * sc.w[k] / scale;
            }
        }
        // within half its slack beyond the slab a constraint counts as
        // on it: SLSQP tests its convergence only at points feasible to
        // rounding, and the effort pulls the iterates onto the slab's
        // faces, where the runs' rounding puts half of them outside
        let value = sign * value / scale - eps;
        if value > 0.0 && value <= 0.5 * eps { 0.0 } else { value }
    }
}

/// How a program ended.
pub(super) struct Ended {
    /// The best point (feasible first, then by effort).
    pub best: Point,
    /// The point of least violation.
    pub least: Point,
    /// SLSQP's termination in words.
    pub termination: String,
    pub evaluations: usize,
    /// The stop hook ended it.
    pub stopped: bool,
}

/// Minimizes the objective of `tr` from `w0` within `bounds` (n, unscaled)
/// subject to its constraints, at most `max` evaluations; where no point
/// is feasible within `tol`, then the violation alone from the least
/// violating point.
///
/// # Errors
/// [`AnalysisError::Request`] for inputs that do not act at `w0` (no
/// constraint moves with them, or without constraints no node's state),
/// and for a user's objective that fails or is not finite at any point
/// (naming it); the start's failure. [`FAILURES`] evaluations in a row that failed end
/// the search at the best point so far, the last failure in the
/// termination's words.
pub(super) fn solve<M: Model>(
    tr: &mut Transcription<M>,
    sc: &Scales,
    w0: &[f64],
    bounds: &[(f64, f64)],
    (tol, max): (f64, usize),
) -> Result<Ended, AnalysisError> {
    let p0 = tr.evaluate(w0)?;
    let inert = if p0.jac.is_empty() {
        !p0.acts
    } else {
        (0..tr.n_inputs()).all(|col| p0.jac.iter().all(|row| row[col] == 0.0))
    };
    if inert {
        return Err(AnalysisError::Request {
            reason: format!(
                "the inputs ({}) do not act on the problem: no segment's end moves with them at the warm start; does the problem's builder put its tables into an effect?",
                tr.inputs.join(", ")
            ),
        });
    }
    let m = 2 * p0.c.len() + p0.g.len();
    let x0: Vec<f64> = w0.iter().zip(&sc.w).map(|(a, s)| a / s).collect();
    let xb: Vec<(f64, f64)> = bounds.iter().zip(&sc.w).map(|(&(lo, hi), s)| (lo / s, hi / s)).collect();
    let state = RefCell::new(State {
        tr,
        sc,
        phase: Phase::Effort,
        tol,
        last: Some((x0.clone(), Ok(p0.clone()))),
        best: Some(p0.clone()),
        least: Some(p0),
        evaluations: 1,
        failures: 0,
        fatal: None,
        broke: false,
        stopped: false,
    });
    let tols = |n: usize| slsqp::StopTols { ftol_rel: 1e-12, xtol_abs: vec![1e-10; n], ..slsqp::StopTols::default() };
    let termination = {
        let objective = |x: &[f64], g: Option<&mut [f64]>, _: &mut ()| state.borrow_mut().objective(x, g);
        let constraints: Vec<SlsqpConstraint<'_>> = (0..m)
            .map(|r| {
                let state = &state;
                Box::new(move |x: &[f64], g: Option<&mut [f64]>, _: &mut ()| state.borrow_mut().constraint(x, r, g))
                    as SlsqpConstraint<'_>
            })
            .collect();
        let outcome = slsqp::minimize(objective, &x0, &xb, &constraints, (), max, Some(tols(x0.len())));
        words(&outcome)
    };
    let mut st = state.into_inner();
    if let Some(reason) = st.tr.objective_error.take() {
        return Err(AnalysisError::Request { reason });
    }
    let mut termination = termination;
    if std::mem::take(&mut st.broke) {
        termination = format!("{termination}, its step not finite (its quadratic subproblem broke down)");
    }
    if let Some(e) = st.fatal.take() {
        termination = format!("{termination}, after {FAILURES} evaluations in a row failed (the last: {e})");
        st.fatal = Some(e);
    }
    if st.stopped {
        termination = format!("{termination}, stopped by its stop hook (a signal)");
    }
    let infeasible = st.best.as_ref().is_none_or(|b| violation(b).0 > tol);
    if infeasible && st.evaluations < max && st.fatal.is_none() && !st.stopped {
        // the violation alone, from the least violating point
        let from =
            st.least.as_ref().map_or_else(|| x0.clone(), |p| p.w.iter().zip(&sc.w).map(|(a, s)| a / s).collect());
        st.phase = Phase::Violation;
        let left = max - st.evaluations;
        let state = RefCell::new(st);
        let objective = |x: &[f64], g: Option<&mut [f64]>, _: &mut ()| state.borrow_mut().objective(x, g);
        let none: Vec<SlsqpConstraint<'_>> = Vec::new();
        let outcome = slsqp::minimize(objective, &from, &xb, &none, (), left.max(2), Some(tols(from.len())));
        termination = format!("{termination}; then the violation alone: {}", words(&outcome));
        st = state.into_inner();
        if let Some(reason) = st.tr.objective_error.take() {
            return Err(AnalysisError::Request { reason });
        }
        if std::mem::take(&mut st.broke) {
            termination = format!("{termination}, its step not finite (its quadratic subproblem broke down)");
        }
        if let Some(e) = st.fatal.take() {
            termination = format!("{termination}, after {FAILURES} evaluations in a row failed (the last: {e})");
        }
    }
    let (Some(best), Some(least)) = (st.best, st.least) else {
        return Err(AnalysisError::Numerics { reason: "no point of the plan was evaluated".into() });
    };
    Ok(Ended { best, least, termination, evaluations: st.evaluations, stopped: st.stopped })
}

/// SLSQP's outcome in words.
fn words(outcome: &SlsqpOutcome) -> String {
    use slsqp::{FailStatus, SuccessStatus};
    match outcome {
        Ok((SuccessStatus::Success | SuccessStatus::StopValReached, ..)) => "SLSQP converged".into(),
        Ok((SuccessStatus::FtolReached, ..)) => "SLSQP: the objective stopped changing".into(),
        Ok((SuccessStatus::XtolReached, ..)) => "SLSQP: the steps became shorter than xtol".into(),
        Ok((SuccessStatus::MaxEvalReached | SuccessStatus::MaxTimeReached, ..)) => {
            "SLSQP: the evaluation budget is spent".into()
        }
        Err((FailStatus::RoundoffLimited, ..)) => "SLSQP: limited by rounding".into(),
        Err((FailStatus::ForcedStop, ..)) => "SLSQP: stopped".into(),
        Err((e, ..)) => format!("SLSQP failed ({e:?}: its line search or subproblem found no descent)"),
    }
}

/// The first-order conditions at `p`: the least-squares residual of
/// `grad f + J^T lambda = 0` on the unknowns not at a bound, `J` the
/// equalities' rows and the path inequalities' active ones (within `tol`
/// of their bound), in the scaled unknowns and constraints, relative to
/// `|grad f|` (0 where the gradient is 0), `f` the whole objective;
/// without constraints, `|grad f|` relative to the sum of its terms'
/// (the weighted effort's and the user's), which cancel at a stationary
/// point. An unknown within 1e-6 of its scale of a bound is at it (SLSQP
/// leaves bang-bang inputs a few 1e-9 inside). Where the multipliers are
/// determined (`J` on the free unknowns of full column rank), their
/// signs are checked too: an active inequality's must be >= 0, and a
/// bound's, the reduced gradient `grad f + J^T lambda` at an unknown on
/// its lower bound >= 0 and on its upper <= 0 (else moving off it lowers
/// the objective); the largest wrong sign, relative to `|grad f|`, counts
/// as a residual. At a point with fewer free unknowns than active rows
/// (a vertex, as a bang-bang input's) the signs are not checked.
///
/// Returns the residual and whether the multipliers' signs were read
/// (false where they are not determined, or there is nothing to read).
pub(super) fn stationarity(p: &Point, sc: &Scales, bounds: &[(f64, f64)], tol: f64) -> (f64, bool) {
    let at = |k: usize| {
        let (lo, hi) = bounds[k];
        let margin = 1e-6 * sc.w[k];
        (p.w[k] - lo <= margin, hi - p.w[k] <= margin)
    };
    let free: Vec<usize> = (0..p.w.len()).filter(|&k| at(k) == (false, false)).collect();
    let grad = |k: usize| p.objective_grad[k] * sc.w[k] / sc.f;
    let g: Vec<f64> = free.iter().map(|&k| grad(k)).collect();
    let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    if norm == 0.0 {
        return (0.0, false);
    }
    let active = p.g.iter().zip(&sc.g).zip(&p.g_jac).filter(|((v, _), _)| v.abs() <= tol);
    let rows: Vec<(&Vec<f64>, f64, bool)> = p
        .jac
        .iter()
        .zip(sc.c.iter().map(|s| (*s, false)))
        .chain(active.map(|((_, s), row)| (row, (*s, true))))
        .map(|(row, (s, ineq))| (row, s, ineq))
        .collect();
    if rows.is_empty() && !free.is_empty() {
        let user = |k: usize| p.user_grad.get(k).copied().unwrap_or(0.0);
        let size =
            |term: &dyn Fn(usize) -> f64| free.iter().map(|&k| (term(k) * sc.w[k] / sc.f).powi(2)).sum::<f64>().sqrt();
        let terms = size(&user) + size(&|k| p.objective_grad[k] - user(k));
        return (norm / terms, false);
    }
    if rows.is_empty() || free.is_empty() {
        return (1.0, false);
    }
    let entry = |k: usize, i: usize| rows[i].0[k] * sc.w[k] / rows[i].1;
    let a = nalgebra_lm::DMatrix::from_fn(free.len(), rows.len(), |r, i| entry(free[r], i));
    let b = nalgebra_lm::DVector::from_vec(g.iter().map(|v| -v).collect());
    let svd = a.clone().svd(true, true);
    let largest = svd.singular_values.max();
    let Ok(lambda) = svd.solve(&b, 1e-12 * largest) else { return (1.0, false) };
    let residual = (a * &lambda - b).norm() / norm;
    let determined = svd.singular_values.iter().all(|v| *v > 1e-10 * largest);
    if !determined {
        return (residual, false);
    }
    // the multipliers' signs: the active inequalities', the bounds'
    let mut wrong = rows.iter().zip(lambda.iter()).filter(|(r, _)| r.2).fold(0.0f64, |m, (_, l)| m.max(-l));
    for k in (0..p.w.len()).filter(|&k| at(k) != (false, false)) {
        let reduced = grad(k) + (0..rows.len()).map(|i| entry(k, i) * lambda[i]).sum::<f64>();
        let (lower, upper) = at(k);
        if lower && !upper {
            wrong = wrong.max(-reduced);
        } else if upper && !lower {
            wrong = wrong.max(reduced);
        }
    }
    (residual.max(wrong / norm), true)
}
