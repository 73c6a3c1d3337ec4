//! A limit cycle branch's phase condition (its [`Phase`]: a Poincare
//! section through the branch's previous point, moved as the branch goes)
//! and a cycle's period guessed between two branch points ([`between`]):
//! what the continuation's equations ([`super::arclength`]) and the
//! bisection of a bifurcation ([`super::bifurcation::locate`]) take of a
//! cycle branch (Doedel, Keller & Kernevez, "Numerical analysis and
//! control of bifurcation problems (II)", Int. J. Bifurcation and Chaos 1,
//! 1991, §3; Seydel, *Practical Bifurcation and Stability Analysis*, 3rd
//! ed., §7.3). The branches themselves: [`super::cycle_branch`].

use std::f64::consts::TAU;

use faer::Mat;

use super::branch::{BranchPoint, Follow, Solution};
use super::periodic::PeriodicSettings;
use super::symmetry::{Symmetry, act};
use super::{Analysis, AnalysisError};
use crate::model::Model;

/// The phase condition of a cycle branch and the cycle's whole turns of
/// headings: the section's point `anchor` (2 nq) and normal `normal`
/// (2 nq, the flow there), set at the first evaluation and moved to each
/// point of the branch as it is found ([`Phase::move_to`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct Phase {
    anchor: Vec<f64>,
    normal: Vec<f64>,
    /// Whole turns of each heading over a period ([`super::periodic::PeriodicOrbit::windings`]).
    windings: Vec<(usize, i64)>,
}

impl Phase {
    /// A phase condition to be set at the first evaluation, the cycle's
    /// headings turning `windings` whole turns a period.
    pub(crate) fn new(windings: Vec<(usize, i64)>) -> Self {
        Phase { anchor: Vec::new(), normal: Vec::new(), windings }
    }

    /// The section moved to pass through `x` (2 nq), normal to the flow of
    /// the scene `an` there at `t0` \[s\].
    ///
    /// # Errors
    /// As [`Analysis::rhs`].
    pub(crate) fn move_to<M: Model>(&mut self, an: &mut Analysis<M>, t0: f64, x: &[f64]) -> Result<(), AnalysisError> {
        self.normal = an.rhs(t0, x)?;
        self.anchor = x.to_vec();
        Ok(())
    }

    /// The cycle's equations (the module's docs) at `x` (2 nq) and `u =
    /// [h, T]` (k + 1) of the scene `an` at `t0` \[s\], the symmetry
    /// `symmetry` (its rigid part); with `jacobian`, their Jacobian in
    /// `[x, h, T]` too (the monodromy matrix from the variational
    /// equations). The gauge's rows are the caller's.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a period that is not positive; as
    /// [`Analysis::flow`] and [`Analysis::end_state`].
    pub(crate) fn eval<M: Model>(
        &mut self,
        an: &mut Analysis<M>,
        (t0, settings): (f64, &PeriodicSettings),
        symmetry: Symmetry,
        x: &[f64],
        u: &[f64],
        jacobian: bool,
    ) -> Result<(Vec<f64>, Option<Mat<f64>>), AnalysisError> {
        let k = u.len() - 1;
        let (g, period) = (&u[..k], u[k]);
        if !(period.is_finite() && period > 0.0) {
            return Err(AnalysisError::Request { reason: format!("a cycle's period must be positive, not {period}") });
        }
        if self.anchor.is_empty() {
            self.move_to(an, t0, x)?;
        }
        let (xt, m) = if jacobian {
            let (xt, m, _) = an.flow(t0, x, period, settings)?;
            (xt, Some(m))
        } else {
            (an.end_state(t0, x, period, settings)?.0, None)
        };
        let mut r: Vec<f64> = xt.iter().zip(act(an.bodies(), symmetry.pose(g), x)).map(|(a, b)| a - b).collect();
        for &(i, w) in &self.windings {
            r[i] -= TAU * w as f64;
        }
        r.extend(an.residual_at(t0, x));
        r.push(self.normal.iter().zip(x.iter().zip(&self.anchor)).map(|(n, (a, b))| n * (a - b)).sum());
        let j = match m {
            Some(m) => Some(an.cycle_jacobian(t0, (x, &xt), &m, symmetry, g, (period, &self.normal))?),
            None => None,
        };
        Ok((r, j))
    }
}

/// `follow` at the parameter's value `value` between the branch points
/// `lo` and `hi`: a cycle branch's period guess interpolated linearly
/// between theirs (for [`super::bifurcation::locate`]'s bisection); any
/// other `follow` as it is.
pub(crate) fn between(follow: Follow, lo: &BranchPoint, hi: &BranchPoint, value: f64) -> Follow {
    match (follow, &lo.solution, &hi.solution) {
        (Follow::Cycle { t0, settings, .. }, Solution::Periodic(a), Solution::Periodic(b)) => {
            let s = if hi.value == lo.value { 0.0 } else { (value - lo.value) / (hi.value - lo.value) };
            Follow::Cycle { t0, period: a.period + s * (b.period - a.period), settings }
        }
        (f, _, _) => f,
    }
}
