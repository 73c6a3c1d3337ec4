//! Parameters fitted to measurements by nonlinear least squares.
//!
//! The residuals are the run's state columns less the data at the data's
//! times, `r = x_k(t_i; p) - y_ik` (in the columns' units: give columns of
//! one unit, or data whose errors are alike); their Jacobian is the run's
//! forward sensitivities at those times (each run gives both: no
//! difference of runs). Levenberg-Marquardt (Moré's MINPACK `LMDER`, in
//! the crate `levenberg-marquardt`) minimizes `|r|^2 / 2` over
//! `u`, each parameter mapped into its bounds by `p = lo + (hi - lo)(1 +
//! sin u)/2` (MINUIT's transformation for bounded parameters: James,
//! *MINUIT Reference Manual*, CERN D506, §1.3), started from the design's
//! values. The standard errors and correlations come from the covariance
//! `s^2 (J^T J)^-1` in `p` at the estimate, `s^2 = |r|^2 / (m - n)` the
//! residual variance of `m` residuals and `n` parameters (Seber & Wild,
//! *Nonlinear Regression*, §2.1).

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra_lm::{DMatrix, DVector, Dyn, Owned};

use super::Design;
use crate::analysis::AnalysisError;
use crate::model::Model;
use crate::sensitivity::Sensitivities;

/// Most runs one fit may take (each with its sensitivities).
pub const MAX_RUNS: usize = 200;

/// Measurements: state columns at times.
#[derive(Debug, Clone, PartialEq)]
pub struct Data {
    /// Times \[s\], sorted, each once.
    pub t: Vec<f64>,
    /// The columns measured (state names: `x1`, `phi2d`).
    pub columns: Vec<String>,
    /// The values, one list per column, each as long as `t`.
    pub values: Vec<Vec<f64>>,
}

impl Data {
    /// Checks the data: times finite, >= 0 and sorted (each after the one
    /// before), every value finite, columns named once, of `t`'s length.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the first row (1-based) and
    /// column at fault.
    pub fn check(&self) -> Result<(), AnalysisError> {
        let fail = |reason: String| Err(AnalysisError::Request { reason });
        if self.t.is_empty() || self.columns.is_empty() {
            return fail("the data have no rows or no columns".into());
        }
        for (k, c) in self.columns.iter().enumerate() {
            if self.columns[..k].contains(c) {
                return fail(format!("column `{c}` is given twice"));
            }
        }
        if self.values.len() != self.columns.len() || self.values.iter().any(|v| v.len() != self.t.len()) {
            return fail("each column needs one value per time".into());
        }
        for (i, &t) in self.t.iter().enumerate() {
            if !(t.is_finite() && t >= 0.0) {
                return fail(format!("row {}: t = {t} (times are finite and >= 0 [s])", i + 1));
            }
            if i > 0 && t <= self.t[i - 1] {
                return fail(format!(
                    "row {}: t = {t} s is not after the row before ({} s): give the rows sorted by time, each time once",
                    i + 1,
                    self.t[i - 1]
                ));
            }
            for (c, v) in self.columns.iter().zip(&self.values) {
                if !v[i].is_finite() {
                    return fail(format!("row {}, column `{c}`: {} is not a number", i + 1, v[i]));
                }
            }
        }
        Ok(())
    }
}

/// A fit's result ([`fit`]).
#[derive(Debug, Clone)]
pub struct Fit {
    /// The parameters' names.
    pub names: Vec<String>,
    /// Their estimates.
    pub estimate: Vec<f64>,
    /// Their standard errors: NaN, never 0, where the data leave no
    /// degree of freedom (residuals <= parameters) or `J^T J` is singular:
    /// the error is undetermined (test with `is_nan`, or
    /// [`Fit::std_error_of`]).
    pub std_error: Vec<f64>,
    /// Their correlations (n x n, row by row): `(J^T J)^-1` normalized,
    /// determined without a degree of freedom too; NaN where `J^T J` is
    /// singular.
    pub correlation: Vec<Vec<f64>>,
    /// Whether each estimate sits at one of its bounds (its standard error
    /// then says little).
    pub at_bound: Vec<bool>,
    /// The data columns fitted.
    pub columns: Vec<String>,
    /// The root mean square residual of each data column, in its units.
    pub residual_rms: Vec<f64>,
    /// `|r|^2 / 2` at the estimate.
    pub cost: f64,
    /// Runs taken (each with its sensitivities).
    pub runs: usize,
    /// Why Levenberg-Marquardt stopped.
    pub termination: String,
    /// The fitted run at the data's times (state and sensitivities).
    pub fitted: Sensitivities,
}

impl Fit {
    /// The standard error of parameter `k`, `None` where it is
    /// undetermined (no degree of freedom left, or `J^T J` singular).
    pub fn std_error_of(&self, k: usize) -> Option<f64> {
        self.std_error.get(k).copied().filter(|e| !e.is_nan())
    }
}

/// `p` in `[lo, hi]` from the unbounded `u`, and `dp/du`.
fn to_bounded(u: f64, lo: f64, hi: f64) -> (f64, f64) {
    let p = lo + (hi - lo) * (1.0 + u.sin()) / 2.0;
    (p.clamp(lo, hi), (hi - lo) * u.cos() / 2.0)
}

/// `u` of `p` in `[lo, hi]` (the branch in `[-pi/2, pi/2]`).
fn to_free(p: f64, lo: f64, hi: f64) -> f64 {
    (2.0 * (p - lo) / (hi - lo) - 1.0).clamp(-1.0, 1.0).asin()
}

/// A run of a fit: its `u`, residuals, Jacobian in `p`, and the run.
type Evaluated = (DVector<f64>, DVector<f64>, DMatrix<f64>, Sensitivities);

/// The least-squares problem Levenberg-Marquardt sees: one run per new
/// `u`, its residuals and Jacobian kept.
struct Lsq<'a, M: Model> {
    design: &'a Design<M>,
    data: &'a Data,
    /// The data columns' indices in the state.
    cols: Vec<usize>,
    u: DVector<f64>,
    /// The last run: its `u`, residuals, Jacobian in `p`, sensitivities.
    last: Option<Evaluated>,
    runs: usize,
    failed: Option<AnalysisError>,
    stop: Option<fn() -> bool>,
}

impl<M: Model> Lsq<'_, M> {
    fn values(&self, u: &DVector<f64>) -> Vec<f64> {
        let d = self.design;
        (0..d.names.len()).map(|k| to_bounded(u[k], d.lower[k], d.upper[k]).0).collect()
    }

    /// The run at `u`: residuals and Jacobian in `p`.
    fn run(&mut self, u: &DVector<f64>) -> Result<(), AnalysisError> {
        if self.runs >= MAX_RUNS {
            return Err(AnalysisError::Request {
                reason: format!("the fit took {MAX_RUNS} runs without converging; start nearer the data"),
            });
        }
        self.runs += 1;
        let p = self.values(u);
        let problem = self.design.problem(&p)?;
        let params = self.design.parameters(&p);
        let s = problem.sensitivities_at(&params, &self.data.t, self.stop)?;
        if s.t.len() != self.data.t.len() {
            return Err(AnalysisError::Numerics {
                reason: format!("the run gave {} samples for {} data times", s.t.len(), self.data.t.len()),
            });
        }
        let (m, n, n2) = (self.data.t.len() * self.cols.len(), p.len(), s.names.len());
        let mut r = DVector::zeros(m);
        let mut j = DMatrix::zeros(m, n);
        for i in 0..self.data.t.len() {
            for (c, &k) in self.cols.iter().enumerate() {
                let row = i * self.cols.len() + c;
                r[row] = s.x[i][k] - self.data.values[c][i];
                for q in 0..n {
                    j[(row, q)] = s.s[i][q * n2 + k];
                }
            }
        }
        self.last = Some((u.clone(), r, j, s));
        Ok(())
    }

    /// The cached run at the current `u`, running it where needed.
    fn current(&mut self) -> Option<&Evaluated> {
        let fresh = self.last.as_ref().is_some_and(|l| l.0 == self.u);
        if !fresh && self.failed.is_none() {
            let u = self.u.clone();
            if let Err(e) = self.run(&u) {
                self.failed = Some(e);
                self.last = None;
            }
        }
        self.last.as_ref().filter(|l| l.0 == self.u)
    }
}

/// A cell so that `residuals(&self)` can run: the trait takes `&self`.
struct Cell<'a, M: Model>(std::cell::RefCell<Lsq<'a, M>>);

impl<M: Model> LeastSquaresProblem<f64, Dyn, Dyn> for Cell<'_, M> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.0.get_mut().u.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.0.borrow().u.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.0.borrow_mut().current().map(|l| l.1.clone())
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let mut lsq = self.0.borrow_mut();
        let d = lsq.design;
        let u = lsq.u.clone();
        let (_, _, jp, _) = lsq.current()?;
        let mut ju = jp.clone();
        for (k, mut col) in ju.column_iter_mut().enumerate() {
            col *= to_bounded(u[k], d.lower[k], d.upper[k]).1;
        }
        Some(ju)
    }
}

/// Fits the parameters of `design` to `data` (see the module's docs):
/// the estimates with their standard errors and correlations, the
/// residual per column, the runs taken and the fitted run. `stop` is
/// asked at every step of every run.
///
/// # Errors
/// As [`Data::check`]; [`AnalysisError::Request`] for a data column that
/// is not a state column of the model, fewer residuals than parameters,
/// or [`MAX_RUNS`] runs without converging; the first run's failure (a
/// bad starting point); [`AnalysisError::Stopped`].
pub fn fit<M: Model>(design: &Design<M>, data: &Data, stop: Option<fn() -> bool>) -> Result<Fit, AnalysisError> {
    data.check()?;
    let n = design.names.len();
    let m = data.t.len() * data.columns.len();
    if m < n {
        return Err(AnalysisError::Request {
            reason: format!("{m} data values for {n} parameters: a fit needs at least as many values as parameters"),
        });
    }
    let start = design.problem(&design.start)?;
    let names = start.state_names();
    let n2 = 2 * start.model.info().nq();
    let cols = data
        .columns
        .iter()
        .map(|c| {
            names.iter().take(n2).position(|n| n == c).ok_or_else(|| AnalysisError::Request {
                reason: format!("data column `{c}` is not a coordinate or velocity of the model"),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let u0 = DVector::from_iterator(n, (0..n).map(|k| to_free(design.start[k], design.lower[k], design.upper[k])));
    let lsq = Lsq { design, data, cols, u: u0.clone(), last: None, runs: 0, failed: None, stop };
    let cell = Cell(std::cell::RefCell::new(lsq));
    // the start's run first: its failure is the fit's (a bad start)
    if cell.residuals().is_none() {
        return Err(cell.0.into_inner().failed.unwrap_or(AnalysisError::Numerics { reason: "no residuals".into() }));
    }
    let (cell, report) = LevenbergMarquardt::new().with_tol(1e-12).minimize(cell);
    let mut lsq = cell.0.into_inner();
    if let Some(e) = lsq.failed.take() {
        return Err(e);
    }
    // the estimate's own run (LM may end on a trial point)
    let u = lsq.u.clone();
    if lsq.last.as_ref().is_none_or(|l| l.0 != u) {
        lsq.run(&u)?;
    }
    let p = lsq.values(&u);
    let (_, r, jp, fitted) = lsq.last.take().expect("the estimate's run");
    let dof = m.saturating_sub(n);
    let s2 = if dof > 0 { r.norm_squared() / dof as f64 } else { f64::NAN };
    let inv = (jp.transpose() * &jp).try_inverse();
    let cov = inv.as_ref().map(|inv| inv * s2);
    // NaN stays NaN (`f64::max` would make it 0: "+- 0" for an error
    // the data cannot give)
    let std_error: Vec<f64> = (0..n)
        .map(|k| {
            cov.as_ref().map_or(f64::NAN, |c| if c[(k, k)].is_nan() { f64::NAN } else { c[(k, k)].max(0.0).sqrt() })
        })
        .collect();
    // `(J^T J)^-1` normalized: `s^2` cancels, so the correlations are
    // determined without a degree of freedom too (they were NaN there)
    let correlation = (0..n)
        .map(|a| {
            (0..n).map(|b| inv.as_ref().map_or(f64::NAN, |c| c[(a, b)] / (c[(a, a)] * c[(b, b)]).sqrt())).collect()
        })
        .collect();
    let ncols = data.columns.len();
    let residual_rms = (0..ncols)
        .map(|c| ((0..data.t.len()).map(|i| r[i * ncols + c].powi(2)).sum::<f64>() / data.t.len() as f64).sqrt())
        .collect();
    let span = |k: usize| design.upper[k] - design.lower[k];
    let at_bound = (0..n).map(|k| (p[k] - design.lower[k]).min(design.upper[k] - p[k]) <= 1e-9 * span(k)).collect();
    Ok(Fit {
        names: design.names.clone(),
        estimate: p,
        std_error,
        correlation,
        at_bound,
        columns: data.columns.clone(),
        residual_rms,
        cost: r.norm_squared() / 2.0,
        runs: lsq.runs,
        termination: format!("{:?}", report.termination),
        fitted,
    })
}
