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

use super::arclength::Equations;
use super::bifurcation::{Bifurcation, BifurcationKind};
use super::branch::{BranchPoint, Follow, Solution};
use super::periodic::PeriodicSettings;
use super::symmetry::{Symmetry, act, body_pose, field_jacobian};
use super::{Analysis, AnalysisError, dense};
use crate::model::Model;
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
