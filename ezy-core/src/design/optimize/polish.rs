//! Newton's polish of a bounded optimum on the exact gradients
//! ([`super::OptimizeSettings::polish`]).
//!
//! SLSQP's line search ranks its points by the objective's value, which
//! a gait gives to the orbit's accuracy only (about 1e-12 of its size at
//! a Newton tolerance of 1e-12): near the optimum the objective changes
//! by `H d^2 / 2` over a step `d`, so the values locate it to `d ~
//! sqrt(1e-12 / H)`, where the gradient is still `H d`, about 1e-5 of its
//! size on the EzyRoller's gait (measured: a projected gradient of 9.7e-6
//! at a best point SLSQP could not tell from its neighbours). The
//! gradient, exact to the orbit's accuracy, locates it far better: its
//! root in the coefficients not held at a bound is found by Newton's
//! method, the Hessian from central differences of the exact gradients
//! (Nocedal & Wright, *Numerical Optimization*, 2nd ed., §3.3 and §8.1)
//! (step [`HESSIAN_STEP`] of each span: its error `H''' h^2` and
//! `noise / h` are about 1e-8 of `H`, so each step divides the gradient
//! by about 1e8 or by its noise). A point is kept only where its
//! projected gradient is smaller and its objective is not worse than the
//! best's beyond [`NOISE`] of its size (the values' own accuracy).
//!
//! Only a bounded optimum is polished: where a constraint is active the
//! first-order conditions are a system in the multipliers too, which
//! SLSQP's answer is left to meet.

use faer::Mat;

use super::evaluate::Point;
use super::{Evaluation, State, kkt};
use crate::analysis::dense::min_norm_solve;
use crate::model::Model;

/// Newton steps at most (with one Hessian).
const POLISH_STEPS: usize = 3;

/// The Hessian's difference step, a fraction of each parameter's span.
const HESSIAN_STEP: f64 = 1e-4;

/// A polished point may have an objective worse than the best's by at
/// most this fraction of its size (the values' accuracy, 1e-12 measured,
/// with a margin): its gradient, not its value, ranks it.
const NOISE: f64 = 1e-10;

/// A component of `u` (in `[0, 1]`) counts as at its bound within this.
const AT_BOUND: f64 = 1e-9;

impl<M: Model> State<'_, M> {
    /// The minimized function's slope in `u` at `p` (`sign dF/dp span`).
    fn slope(&self, p: &Point) -> Vec<f64> {
        let sign = self.objective_scale.signum();
        p.gradients[0].iter().zip(&self.span).map(|(g, s)| sign * g * s).collect()
    }

    /// The components of `u` not pinned at a bound by the slope `g`.
    fn unpinned(u: &[f64], g: &[f64]) -> Vec<usize> {
        (0..u.len())
            .filter(|&k| !((u[k] <= AT_BOUND && g[k] > 0.0) || (u[k] >= 1.0 - AT_BOUND && g[k] < 0.0)))
            .collect()
    }

    /// One evaluation with its gradient, recorded in the history; `None`
    /// where it fails or the budget is spent.
    fn probe(&mut self, u: &[f64]) -> Option<Point> {
        if self.history.len() >= self.max || self.stopped {
            return None;
        }
        let values = self.values(u);
        let mut record = Evaluation {
            values: values.clone(),
            objective: f64::NAN,
            constraints: vec![f64::NAN; self.ev.goal.constraints.len()],
            gradient: Vec::new(),
            failure: None,
        };
        let result = self.ev.at(&values, true);
        let point = match result {
            Ok(p) => {
                record.objective = p.values[0];
                record.constraints = p.values[1..].to_vec();
                record.gradient = p.gradients[0].clone();
                Some(p)
            }
            Err(crate::analysis::AnalysisError::Stopped) => {
                self.stopped = true;
                return None;
            }
            Err(e) => {
                record.failure = Some(e.to_string());
                None
            }
        };
        self.history.push(record);
        point
    }

    /// Polishes the best point by Newton's method on the gradient of the
    /// coefficients not pinned at a bound (see the module's docs); the
    /// best point is replaced by each step kept. A best point with an
    /// active constraint is left as it is.
    pub(super) fn polish(&mut self) {
        let Some((_, best, u0)) = self.best.clone() else { return };
        let active = self.ev.goal.constraints.iter().enumerate().any(|(i, c)| {
            let (s, k) = self.constraint_scales[i];
            s * (best.values[i + 1] - c.bound) / k >= -kkt::ACTIVE
        });
        if active {
            return;
        }
        let g0 = self.slope(&best);
        let free = Self::unpinned(&u0, &g0);
        if free.is_empty() {
            return;
        }
        let Some(h) = self.hessian(&u0, &free) else { return };
        let sign = self.objective_scale.signum();
        let (mut p, mut u) = (best, u0);
        for _ in 0..POLISH_STEPS {
            let g = self.slope(&p);
            let gf: Vec<f64> = free.iter().map(|&k| -g[k]).collect();
            let before = Self::unpinned(&u, &g).iter().map(|&k| g[k] * g[k]).sum::<f64>().sqrt();
            let Ok((d, _)) = min_norm_solve(h.as_ref(), &gf, 1e-12) else { return };
            // not a descent direction: no minimum of the model here
            if d.iter().zip(&gf).map(|(a, b)| a * b).sum::<f64>() <= 0.0 {
                return;
            }
            let mut next = u.clone();
            for (&k, dk) in free.iter().zip(&d) {
                next[k] = (u[k] + dk).clamp(0.0, 1.0);
            }
            let Some(q) = self.probe(&next) else { return };
            let (f, fq) = (sign * p.values[0], sign * q.values[0]);
            let gq = self.slope(&q);
            let after = Self::unpinned(&next, &gq).iter().map(|&k| gq[k] * gq[k]).sum::<f64>().sqrt();
            if !(fq <= f + NOISE * f.abs().max(f64::MIN_POSITIVE) && after < before) {
                return;
            }
            self.best = Some((self.history.len() - 1, q.clone(), next.clone()));
            (p, u) = (q, next);
        }
    }

    /// The Hessian of the minimized function in `u` over the components
    /// `free`, by central differences of the exact gradients (one-sided
    /// where a bound is nearer than the step), symmetrized; `None` where
    /// an evaluation fails.
    fn hessian(&mut self, u: &[f64], free: &[usize]) -> Option<Mat<f64>> {
        let nf = free.len();
        let mut h = Mat::<f64>::zeros(nf, nf);
        for (a, &k) in free.iter().enumerate() {
            let (lo, hi) = ((u[k] - HESSIAN_STEP).max(0.0), (u[k] + HESSIAN_STEP).min(1.0));
            let at = |x: f64| {
                let mut v = u.to_vec();
                v[k] = x;
                v
            };
            let below = self.probe(&at(lo))?;
            let above = self.probe(&at(hi))?;
            let (gl, gh) = (self.slope(&below), self.slope(&above));
            for (b, &j) in free.iter().enumerate() {
                h[(b, a)] = (gh[j] - gl[j]) / (hi - lo);
            }
        }
        Some(Mat::from_fn(nf, nf, |i, j| 0.5 * (h[(i, j)] + h[(j, i)])))
    }
}
