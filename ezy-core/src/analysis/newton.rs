//! One globalized Newton for the analyses' searches (a steady motion, a
//! periodic orbit, a limit cycle): minimum-norm steps on the Newton
//! matrix, halved until the residual falls (Deuflhard, *Newton Methods
//! for Nonlinear Problems*, Springer 2004, §3.1: the monotonicity test
//! in the residual's max norm), the give-up rules and the statistics in
//! one place. What differs between the searches is what a trial costs
//! and what a failed one means ([`Equations`]) and how far a step may be
//! damped ([`Rules`]). The searches are the steady motions', the periodic
//! orbits', the limit cycles' and the continuation's corrector (an
//! undamped Newton on the bordered system, given up where it diverges).

use faer::Mat;

use super::{AnalysisError, dense};

/// How a search's iteration is damped and when it gives up.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rules {
    /// What is sought, for the error: "a periodic orbit".
    pub what: &'static str,
    /// Most iterations.
    pub max_iterations: usize,
    /// The converged residual's max norm.
    pub tolerance: f64,
    /// The smallest step fraction tried (a power of 1/2): past it the
    /// search ends.
    pub min_step: f64,
    /// Whether the trial at `min_step` is taken even where the residual
    /// did not fall (a shooting search, whose residual carries the
    /// integration's noise: it goes on from there).
    pub take_last: bool,
    /// Damped steps in a row that gain less than half the residual, after
    /// which the search ends: the guess is outside the region Newton
    /// converges from (a transient the caller may settle first). `None`:
    /// no such rule.
    pub slow: Option<usize>,
    /// From the second iteration on, a residual that grew over the step
    /// while above this multiple of `tolerance` ends the search (an
    /// undamped search, `min_step = 1`: the predictor was too far, and
    /// its caller retries a shorter one). `None`: no such rule.
    pub grows: Option<f64>,
    /// The relative singular-value cutoff of the minimum-norm step
    /// ([`dense::min_norm_solve`]): directions below it are not moved.
    pub cutoff: f64,
}

/// The equations of one search, at its current point.
pub(crate) trait Equations {
    /// The Newton matrix at the current point: the residual's rows, then
    /// [`Equations::gauge_rows`] rows whose right-hand side is 0.
    fn jacobian(&mut self) -> Result<Mat<f64>, AnalysisError>;

    /// Rows of the Newton matrix after the residual's (a gauge held).
    fn gauge_rows(&self) -> usize {
        0
    }

    /// The residual at the current point moved by `lambda dz` (not taken
    /// yet); `Ok(None)` where it cannot be evaluated there (a run that
    /// fails): a shorter step is tried. `last`: no shorter step follows,
    /// so an error returned says why the search ends (the generic
    /// [`AnalysisError::NotConverged`] otherwise).
    ///
    /// # Errors
    /// What ends the search at once (a stop).
    fn trial(&mut self, dz: &[f64], lambda: f64, last: bool) -> Result<Option<Vec<f64>>, AnalysisError>;

    /// Takes the point of the last trial (`lambda dz` from the current).
    ///
    /// # Errors
    /// What ends the search (its Jacobian's integration failing).
    fn take(&mut self, dz: &[f64], lambda: f64) -> Result<(), AnalysisError>;
}

/// `z + lambda dz` over `z`'s length: a part of the unknowns moved by
/// the step (`dz` from that part's first component on).
pub(crate) fn moved(z: &[f64], dz: &[f64], lambda: f64) -> Vec<f64> {
    z.iter().zip(dz).map(|(a, d)| a + lambda * d).collect()
}

/// The residual's max norm.
fn norm(r: &[f64]) -> f64 {
    r.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Newton's method on `eq` from its current point with residual `r`
/// under `rules`: the iterations it took and the residual it ended with.
///
/// # Errors
/// [`AnalysisError::NotConverged`] after `rules.max_iterations`, where no
/// step down to `rules.min_step` lowers the residual, or after
/// `rules.slow` slow steps in a row; the equations' own errors.
pub(crate) fn solve(
    eq: &mut impl Equations,
    mut r: Vec<f64>,
    rules: &Rules,
) -> Result<(usize, Vec<f64>), AnalysisError> {
    let fail = |iterations: usize, r: &[f64]| AnalysisError::NotConverged {
        what: rules.what,
        iterations,
        residual: norm(r),
        tolerance: rules.tolerance,
    };
    let (mut iterations, mut slow) = (0, 0);
    while norm(&r) > rules.tolerance {
        if iterations == rules.max_iterations {
            return Err(fail(iterations, &r));
        }
        iterations += 1;
        let j = eq.jacobian()?;
        let neg: Vec<f64> = r.iter().map(|v| -v).chain(std::iter::repeat_n(0.0, eq.gauge_rows())).collect();
        let (dz, _) = dense::min_norm_solve(j.as_ref(), &neg, rules.cutoff)?;
        let mut lambda = 1.0;
        loop {
            let last = lambda <= rules.min_step;
            match eq.trial(&dz, lambda, last)? {
                Some(rt) if norm(&rt) < norm(&r) || (last && rules.take_last) => {
                    slow = if lambda < 1.0 && norm(&rt) > 0.5 * norm(&r) { slow + 1 } else { 0 };
                    let diverges = rules
                        .grows
                        .is_some_and(|g| iterations >= 2 && norm(&rt) > norm(&r) && norm(&rt) > g * rules.tolerance);
                    eq.take(&dz, lambda)?;
                    r = rt;
                    if rules.slow == Some(slow) || diverges {
                        return Err(fail(iterations, &r));
                    }
                    break;
                }
                _ if last => return Err(fail(iterations, &r)),
                _ => lambda *= 0.5,
            }
        }
    }
    Ok((iterations, r))
}
