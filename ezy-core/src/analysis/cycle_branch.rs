//! Branches of limit cycles of autonomous scenes, followed by
//! pseudo-arclength continuation ([`super::arclength::follow_arclength`]
//! with [`Follow::Cycle`]), and the switch onto them at a Hopf point of a
//! branch of steady motions ([`switch_at_hopf`]).
//!
//! A cycle's unknowns are `z = [x0, h, T]` (2 nq + k + 1): its start, the
//! rigid motion over a period (k parameters, [`Symmetry::params`]) and its
//! period, free. The equations are those of [`Analysis::limit_cycle`]:
//! `x(t0 + T; x0) = h . x0 + 2 pi w`, `phi(q0) = 0`, `G(q0) qd0 = 0`, with
//! the phase condition `f(x_prev) . (x0 - x_prev) = 0`: a Poincare section
//! through the branch's previous point `x_prev`, normal to the flow there,
//! moved to each point as it is found, so the phase does not drift along
//! the branch (AUTO's and MatCont's phase condition against the previous
//! point, here in its Poincare form: Doedel, Keller & Kernevez, "Numerical
//! analysis and control of bifurcation problems (II)", Int. J. Bifurcation
//! and Chaos 1, 1991, §3; Seydel, *Practical Bifurcation and Stability
//! Analysis*, 3rd ed., §7.3). The time shift's multiplier 1 is not among a
//! cycle's [`super::periodic::PeriodicOrbit::multipliers`], so folds
//! ([`super::arclength::locate_fold`]), period doublings and
//! Neimark-Sacker points ([`super::bifurcation::locate`]) are found on a
//! cycle branch as on a forced orbit's.

use std::f64::consts::TAU;

use faer::Mat;

use super::arclength::Equations;
use super::bifurcation::{Bifurcation, BifurcationKind};
use super::branch::{BranchPoint, Follow, Solution};
use super::periodic::PeriodicSettings;
use super::symmetry::{Symmetry, act, body_pose, field_jacobian};
use super::{Analysis, AnalysisError, dense};
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

/// The critical plane of the steady motion `x` (2 nq) with group velocity
/// `xi` of the scene `an` at a Hopf point whose critical pair is
/// `+-i omega` (`omega` \[rad/s\]): a unit vector (2 nq) of the real
/// invariant plane of the pair, in the constraint manifold's tangent
/// space modulo the group orbit. It is the null vector of `A^2 + omega^2
/// I`, `A` the linearization reduced to that space (as the steady
/// motion's eigenvalues are computed): the real part of the critical
/// eigenvector at some phase, all phases giving the same cycle (Kuznetsov,
/// *Elements of Applied Bifurcation Theory*, 3rd ed., §3.4).
///
/// # Errors
/// The linearization's ([`Analysis::point`]); a singular value
/// decomposition that fails.
fn critical_plane<M: Model>(
    an: &mut Analysis<M>,
    x: &[f64],
    xi: &[f64],
    symmetry: Symmetry,
    omega: f64,
) -> Result<Vec<f64>, AnalysisError> {
    let n2 = x.len();
    let bodies = an.bodies().to_vec();
    let p = an.point(0.0, x)?;
    let (mut df, c) = an.jacobians(0.0, x, &p)?;
    for (g, v) in symmetry.generators().iter().zip(xi) {
        df -= field_jacobian(&bodies, *g, n2) * faer::Scale(*v);
    }
    let tangent = dense::null_space(c.as_ref(), super::linear::RANK_RTOL)?;
    let (q, _) = an.quotient_basis(&tangent, x, symmetry)?;
    let a = dense::congruence(q.as_ref(), df.as_ref());
    let mut a2 = dense::mul(a.as_ref(), a.as_ref());
    for i in 0..a2.nrows() {
        a2[(i, i)] += omega * omega;
    }
    let (_, vr) = dense::smallest_right_singular(a2.as_ref())?;
    let v: Vec<f64> = (0..n2).map(|i| (0..q.ncols()).map(|j| q[(i, j)] * vr[j]).sum()).collect();
    let len = v.iter().map(|a| a * a).sum::<f64>().sqrt();
    Ok(v.iter().map(|a| a / len).collect())
}

/// The first limit cycle of the branch born at the Hopf point `b` of a
/// branch of steady motions ([`super::bifurcation::locate`]), and how to
/// follow it ([`super::arclength::follow_arclength`] from the point's
/// value and state): from the steady motion `x*` plus `offset` times a
/// unit vector `v` of the critical pair's real plane (the real part of
/// the critical eigenvector, in the constraint manifold's tangent space:
/// consistent with the constraints to first order, the corrector's
/// constraint rows putting the cycle on the manifold), a cycle of period
/// `2 pi / omega` (`omega` the pair's imaginary part) is corrected with
/// the parameter free on the hyperplane `v . (x0 - x*) = offset` and the
/// phase condition through the predicted start (Kuznetsov, *Elements of
/// Applied Bifurcation Theory*, 3rd ed., §3.4 and §10.2; Seydel,
/// *Practical Bifurcation and Stability Analysis*, 3rd ed., §7.6). The
/// cycle's amplitude is about `offset`, in the state's units (1e-3 to
/// 1e-2 of its scale: past the equilibrium's branch, where the cycle's
/// amplitude still grows as the square root of the parameter's distance);
/// its parameter's value is on the side the cycles are (supercritical or
/// subcritical). `settings` are the cycle's integration and Newton
/// settings; the cycles are taken at `t0 = 0` (the scene is autonomous).
///
/// # Errors
/// [`AnalysisError::Request`] for a bifurcation that is not a Hopf point
/// of steady motions; the corrector's where it does not converge (an
/// offset too large, or a degenerate Hopf point); `build`'s.
pub fn switch_at_hopf<M: Model>(
    b: &Bifurcation,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    offset: f64,
    settings: PeriodicSettings,
) -> Result<(BranchPoint, Follow), AnalysisError> {
    let (BifurcationKind::Hopf, Solution::Steady(m)) = (b.kind, &b.solution) else {
        return Err(AnalysisError::Request {
            reason: format!(
                "a limit cycle is switched onto at a Hopf point of steady motions, not at a {}",
                b.kind.name()
            ),
        });
    };
    let omega = b.critical.iter().fold(0.0f64, |w, z| w.max(z.im.abs()));
    if omega <= 0.0 {
        return Err(AnalysisError::Request { reason: "the Hopf point's critical pair has no frequency".into() });
    }
    let t0 = 0.0;
    let period = TAU / omega;
    let symmetry = m.symmetry.rigid();
    let mut an = build(b.value)?;
    let bodies = an.bodies().to_vec();
    // the steady motion at the gauge, its shift over a period the flow's
    let x = act(&bodies, symmetry.restrict(body_pose(&bodies, 0, &m.state)).inverse(), &m.state);
    let v = critical_plane(&mut an, &x, &m.xi, m.symmetry, omega)?;
    let (xt, _) = an.end_state(t0, &x, period, &settings)?;
    let h = symmetry.restrict(body_pose(&bodies, 0, &xt).compose(body_pose(&bodies, 0, &x).inverse()));
    let follow = Follow::Cycle { t0, period, settings };
    let mut eq = Equations::new(follow, &b.solution);
    let x_hat: Vec<f64> = x.iter().zip(&v).map(|(a, d)| a + offset * d).collect();
    let w_hat = [x_hat, symmetry.params(h), vec![period, b.value]].concat();
    let nz = w_hat.len() - 1;
    // the hyperplane v . (x0 - x*) = offset, the parameter free
    let mut n = vec![0.0; nz + 1];
    n[..v.len()].copy_from_slice(&v);
    let c = eq.correct(&mut build, &w_hat, &n)?;
    let point = eq.point(&mut build, &c)?;
    Ok((point, Follow::Cycle { t0, period: c.w[nz - 1], settings }))
}
