//! The Karush-Kuhn-Tucker conditions checked at an optimization's best
//! point: an optimizer's own word ("converged") is not taken, the first-
//! order conditions are verified on the exact gradients (Nocedal &
//! Wright, *Numerical Optimization*, 2nd ed., §12.3, Theorem 12.1).
//!
//! In the scaled variables `u` (each parameter's fraction of its span) the
//! best point minimizes `f(u)` subject to `c_i(u) <= 0` and `0 <= u <= 1`.
//! The constraints active there (within [`ACTIVE`] of their scale, the
//! bounds within 1e-9 of the span) are the candidates; the multipliers
//! `mu >= 0` are the non-negative least-squares solution of `grad f +
//! sum mu_i grad c_i = 0` (Lawson & Hanson, *Solving Least Squares
//! Problems*, 1974, ch. 23), so a multiplier of the wrong sign shows as a
//! residual. The conditions hold where the residual is at most
//! [`STATIONARITY`] of the objective's gradient.

use faer::Mat;

use crate::analysis::dense::min_norm_solve;

/// A constraint counts as active (a candidate for a multiplier) where its
/// scaled value `c_i` is above `-ACTIVE`: a millionth of its bound's
/// size, below which SLSQP's own steps do not resolve it.
pub(crate) const ACTIVE: f64 = 1e-6;

/// The conditions hold where the stationarity residual is at most this
/// fraction of the objective's gradient (the larger of the start's and
/// the best point's, in the scaled variables): the exact gradients agree
/// to about 1e-8 of their size, the residual at a point SLSQP left within
/// `xtol` of the optimum is smaller still, and a point that is not
/// stationary leaves a residual of the gradient's own size.
pub(crate) const STATIONARITY: f64 = 1e-4;

/// A constraint or bound that binds at the best point, with its
/// multiplier.
#[derive(Debug, Clone, PartialEq)]
pub struct Binding {
    /// What binds: the constraint's text (`gait.mean_power <= 0.3`) or
    /// a parameter's bound (`motor.omega >= 0.5`).
    pub name: String,
    /// Its Lagrange multiplier in the problem's own units: the rate at
    /// which the objective would improve per unit the bound is relaxed
    /// (objective units per constraint or parameter unit, `>= 0`).
    pub multiplier: f64,
}

/// The first-order optimality conditions at the best point.
#[derive(Debug, Clone, PartialEq)]
pub struct Kkt {
    /// Whether they hold (residual at most the tolerance, and the point
    /// feasible).
    pub holds: bool,
    /// `|grad f + sum mu_i grad c_i|` (max norm, scaled variables).
    pub residual: f64,
    /// The tolerance it was held to: 1e-4 times the larger
    /// of the start's and the best point's objective gradient (scaled).
    pub tolerance: f64,
    /// The constraints and bounds whose multiplier is positive.
    pub binding: Vec<Binding>,
}

impl Kkt {
    /// One line: `KKT conditions hold (residual 1e-12 of 1e-5); binding:
    /// gait.mean_power <= 0.3 (multiplier 0.21)`.
    pub fn describe(&self) -> String {
        let verdict = if self.holds { "hold" } else { "fail" };
        let mut s = format!(
            "first-order (KKT) conditions {verdict}: stationarity residual {:.1e} (tolerance {:.1e})",
            self.residual, self.tolerance
        );
        if !self.binding.is_empty() {
            let b: Vec<String> = self
                .binding
                .iter()
                .map(|b| format!("{} (multiplier {})", b.name, crate::names::fmt_value(b.multiplier)))
                .collect();
            s.push_str(&format!("; binding: {}", b.join(", ")));
        }
        s
    }
}

/// A candidate for a multiplier: its name, its gradient in the scaled
/// variables (`<= 0` form), and the factor that turns its scaled
/// multiplier into the problem's units.
pub(crate) struct Candidate {
    pub name: String,
    pub gradient: Vec<f64>,
    pub unit: f64,
}

/// The conditions at a point whose scaled objective gradient is `g`,
/// with the active constraints' and bounds' `candidates`; `scale` the
/// gradient size the residual is measured against.
pub(crate) fn check(g: &[f64], candidates: &[Candidate], scale: f64) -> Kkt {
    let n = g.len();
    let a = Mat::from_fn(n, candidates.len(), |i, j| candidates[j].gradient[i]);
    let b: Vec<f64> = g.iter().map(|v| -v).collect();
    let mu = nnls(&a, &b);
    let finite = g.iter().chain(candidates.iter().flat_map(|c| &c.gradient)).all(|v| v.is_finite());
    let residual = if finite {
        (0..n).map(|i| (g[i] + (0..candidates.len()).map(|j| a[(i, j)] * mu[j]).sum::<f64>()).abs()).fold(0.0, f64::max)
    } else {
        // a gradient that is not finite: nothing holds
        f64::NAN
    };
    let tolerance = STATIONARITY * scale.max(g.iter().fold(0.0, |m, v| m.max(v.abs())));
    let binding = candidates
        .iter()
        .zip(&mu)
        .filter(|(_, m)| **m > 0.0)
        .map(|(c, m)| Binding { name: c.name.clone(), multiplier: m * c.unit })
        .collect();
    Kkt { holds: residual <= tolerance, residual, tolerance, binding }
}

/// The non-negative least-squares solution of `a x = b` (Lawson & Hanson's
/// active-set method; `a` n x m, m small).
fn nnls(a: &Mat<f64>, b: &[f64]) -> Vec<f64> {
    let (n, m) = (a.nrows(), a.ncols());
    let mut x = vec![0.0; m];
    let mut passive = vec![false; m];
    let residual =
        |x: &[f64]| -> Vec<f64> { (0..n).map(|i| b[i] - (0..m).map(|j| a[(i, j)] * x[j]).sum::<f64>()).collect() };
    let scale = (0..n).map(|i| b[i].abs()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    for _ in 0..3 * m + 3 {
        let r = residual(&x);
        let w: Vec<f64> = (0..m).map(|j| (0..n).map(|i| a[(i, j)] * r[i]).sum()).collect();
        let Some(j) = (0..m).filter(|&j| !passive[j] && w[j] > 1e-14 * scale).max_by(|&p, &q| w[p].total_cmp(&w[q]))
        else {
            break;
        };
        passive[j] = true;
        for _ in 0..3 * m + 3 {
            let cols: Vec<usize> = (0..m).filter(|&j| passive[j]).collect();
            let sub = Mat::from_fn(n, cols.len(), |i, k| a[(i, cols[k])]);
            let Ok((zp, _)) = min_norm_solve(sub.as_ref(), b, 1e-12) else { return x };
            let mut z = vec![0.0; m];
            for (k, &c) in cols.iter().enumerate() {
                z[c] = zp[k];
            }
            if cols.iter().all(|&c| z[c] > 0.0) {
                x = z;
                break;
            }
            let alpha = cols
                .iter()
                .filter(|&&c| z[c] <= 0.0)
                .map(|&c| x[c] / (x[c] - z[c]))
                .fold(f64::INFINITY, f64::min)
                .clamp(0.0, 1.0);
            for c in 0..m {
                x[c] += alpha * (z[c] - x[c]);
                if passive[c] && x[c] <= 1e-15 {
                    passive[c] = false;
                    x[c] = 0.0;
                }
            }
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(name: &str, gradient: Vec<f64>) -> Candidate {
        Candidate { name: name.into(), gradient, unit: 1.0 }
    }

    /// An interior stationary point holds; a point with a gradient and no
    /// constraint fails; a constraint pushing the right way holds with
    /// its multiplier, the wrong way fails (no negative multiplier).
    #[test]
    fn stationarity_and_the_multipliers_sign() {
        assert!(check(&[1e-9, -1e-9], &[], 0.1).holds);
        let k = check(&[0.1, 0.0], &[], 0.1);
        assert!(!k.holds && (k.residual - 0.1).abs() < 1e-15, "{k:?}");
        // minimize x subject to -x <= 0 at x = 0: grad f = 1, grad c = -1, mu = 1
        let k = check(&[1.0, 0.0], &[cand("c", vec![-1.0, 0.0])], 0.1);
        assert!(k.holds && k.binding.len() == 1 && (k.binding[0].multiplier - 1.0).abs() < 1e-12, "{k:?}");
        // the same constraint against a gradient the other way: mu would be -1
        let k = check(&[-1.0, 0.0], &[cand("c", vec![-1.0, 0.0])], 0.1);
        assert!(!k.holds && k.binding.is_empty() && (k.residual - 1.0).abs() < 1e-12, "{k:?}");
        // two candidates, one of them not binding (its multiplier 0)
        let k = check(&[1.0, 2.0], &[cand("a", vec![-1.0, -2.0]), cand("b", vec![1.0, 0.0])], 0.1);
        assert!(k.holds && k.binding.len() == 1 && k.binding[0].name == "a", "{k:?}");
        // NaN fails
        assert!(!check(&[f64::NAN], &[], 0.1).holds);
    }
}
