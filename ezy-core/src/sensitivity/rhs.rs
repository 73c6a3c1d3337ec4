//! The augmented right-hand side `[x, S]' = [f(t, x), (df/dx) S + df/dp]`
//! and the projection of `S` onto the constraints' tangent space.

use faer::Mat;
use num_dual::Dual64;

use super::stencil::Stencil;
use crate::analysis::{Analysis, AnalysisError, dense_solve};
use crate::error::SimError;
use crate::integrator::Rhs;
use crate::model::Model;

/// The state, its sensitivities and what they are evaluated with.
pub(super) struct Augmented<M: Model> {
    pub base: Analysis<M>,
    pub stencils: Vec<Stencil<M>>,
    /// The first failure that is not the right-hand side's own (kept to
    /// report it as it is, not as a `SimError`).
    pub failed: Option<AnalysisError>,
    pub evaluations: u64,
    pub stop: Option<fn() -> bool>,
}

/// `G`'s values (at the pattern) and `gamma` along a direction
/// `(dq, dqd)`: one forward-mode pass of the generated code.
pub(super) fn directional_terms<M: Model>(
    model: &M,
    q: &[f64],
    qd: &[f64],
    dq: &[f64],
    dqd: &[f64],
    nnz: usize,
    nc: usize,
) -> (Vec<f64>, Vec<f64>) {
    let qdual: Vec<Dual64> = q.iter().zip(dq).map(|(&v, &d)| Dual64::new(v, d)).collect();
    let qddual: Vec<Dual64> = qd.iter().zip(dqd).map(|(&v, &d)| Dual64::new(v, d)).collect();
    let (mut gv, mut gm) = (vec![Dual64::from(0.0); nnz], vec![Dual64::from(0.0); nc]);
    model.constraint_terms(&qdual, &qddual, &mut gv, &mut gm);
    (gv.iter().map(|v| v.eps).collect(), gm.iter().map(|v| v.eps).collect())
}

impl<M: Model> Augmented<M> {
    /// Number of coordinates nq.
    pub fn nq(&self) -> usize {
        self.base.nq()
    }

    /// `dF/dx s` (nq) along the state direction `s` (2 nq) by a central
    /// difference of the force laws; zero without effects.
    fn force_direction(&mut self, t: f64, x: &[f64], s: &[f64]) -> Result<Vec<f64>, AnalysisError> {
        let nq = self.nq();
        let norm = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if self.base.dynamics().effects.is_empty() || norm == 0.0 {
            return Ok(vec![0.0; nq]);
        }
        let scale = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let h = f64::EPSILON.cbrt() * scale / norm;
        let at = |sign: f64| x.iter().zip(s).map(|(v, d)| v + sign * h * d).collect::<Vec<_>>();
        let (xp, xm) = (at(1.0), at(-1.0));
        let fp = self.base.forces(t, &xp[..nq], &xp[nq..])?;
        let fm = self.base.forces(t, &xm[..nq], &xm[nq..])?;
        Ok(fp.iter().zip(&fm).map(|(a, b)| (a - b) / (2.0 * h)).collect())
    }

    /// `dy = [f(t, x), (df/dx) S + df/dp]` for `y = [x, S]`.
    fn evaluate(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), AnalysisError> {
        if let Some(stop) = self.stop
            && stop()
        {
            return Err(AnalysisError::Stopped);
        }
        self.evaluations += 1;
        let nq = self.nq();
        let n2 = 2 * nq;
        let (x, s) = y.split_at(n2);
        if let Some(k) = x.iter().position(|v| !v.is_finite()) {
            return Err(AnalysisError::Numerics {
                reason: format!(
                    "at t = {} s the state component `{}` became {}",
                    crate::names::fmt_value(t),
                    self.base.dynamics().state_name(k),
                    x[k]
                ),
            });
        }
        let (q, qd) = x.split_at(nq);
        let pt = self.base.point(t, x)?;
        let info = &self.base.dynamics().info;
        let (nc, nnz) = (info.nc(), info.pattern.len());
        let pattern = info.pattern.clone();
        let np = self.stencils.len();
        let touches_any = self.stencils.iter().any(|st| st.touches.model || st.touches.effects);
        let base_f = if touches_any { self.base.forces(t, q, qd)? } else { Vec::new() };
        let needs_terms = self.stencils.iter().any(|st| st.touches.model);
        let (mut base_values, mut base_gamma) = (vec![0.0; nnz], vec![0.0; nc]);
        if needs_terms {
            self.base.dynamics().model.constraint_terms(q, qd, &mut base_values, &mut base_gamma);
        }
        let base_mass = self.base.dynamics().mass.clone();
        let mut rhs = Mat::<f64>::zeros(nq + nc, np);
        for j in 0..np {
            let sj = &s[j * n2..(j + 1) * n2];
            let (mut dg, mut dgamma) =
                directional_terms(&self.base.dynamics().model, q, qd, &sj[..nq], &sj[nq..], nnz, nc);
            let mut df = self.force_direction(t, x, sj)?;
            let mut dm = vec![0.0; nq];
            let st = &mut self.stencils[j];
            st.add_forces(t, q, qd, &base_f, &mut df)?;
            st.add_terms(q, qd, (&base_values, &base_gamma, &base_mass), &mut dg, &mut dgamma, &mut dm);
            st.add_drives(t, &self.base, &mut dgamma);
            // [dF - dM qdd - dG^T mu; -dgamma - dG qdd]
            for i in 0..nq {
                rhs[(i, j)] = df[i] - dm[i] * pt.qdd[i];
            }
            for r in 0..nc {
                rhs[(nq + r, j)] = -dgamma[r];
            }
            for (&(r, c), v) in pattern.iter().zip(&dg) {
                rhs[(c, j)] -= v * pt.mu[r];
                rhs[(nq + r, j)] -= v * pt.qdd[c];
            }
        }
        let sol = if np > 0 {
            dense_solve(pt.kkt.as_ref(), rhs.as_ref(), "the KKT matrix [M G^T; G 0]")?
        } else {
            Mat::zeros(nq + nc, 0)
        };
        dy[..nq].copy_from_slice(qd);
        dy[nq..n2].copy_from_slice(&pt.qdd);
        for j in 0..np {
            let (sj, dj) = (&s[j * n2..(j + 1) * n2], &mut dy[n2 + j * n2..n2 + (j + 1) * n2]);
            dj[..nq].copy_from_slice(&sj[nq..]);
            for i in 0..nq {
                dj[nq + i] = sol[(i, j)];
            }
        }
        Ok(())
    }

    /// Projects the sensitivities `s` (np blocks of 2 nq) at the
    /// projected state `(t, x)` onto the tangent space of the constraint
    /// manifold in the metric `winv` (nq: `W^-1`'s diagonal), positions
    /// first, then velocities (see the module's docs).
    ///
    /// # Errors
    /// [`AnalysisError::Numerics`] when `Cq W^-1 Cq^T` or `G W^-1 G^T` is
    /// singular (a singular position).
    pub fn project(&mut self, t: f64, x: &[f64], s: &mut [f64], winv: &[f64]) -> Result<(), AnalysisError> {
        let nq = self.nq();
        let n2 = 2 * nq;
        let info = &self.base.dynamics().info;
        let (nh, nc, nnz) = (info.n_holonomic, info.nc(), info.pattern.len());
        let pattern = info.pattern.clone();
        let (q, qd) = x.split_at(nq);
        let mut values = vec![0.0; nnz];
        self.base.dynamics().model.constraint_matrix(q, &mut values);
        let g = self.base.dense_g(&values);
        let base_r = self.base.residual_at(t, x);
        // the normal matrices and their solves: rows 0..nh (positions), all rows (velocities)
        let normal =
            |rows: usize| Mat::from_fn(rows, rows, |a, b| (0..nq).map(|k| g[(a, k)] * winv[k] * g[(b, k)]).sum());
        let (npos, nvel) = (normal(nh), normal(nc));
        for (j, st) in self.stencils.iter().enumerate() {
            let sj = &mut s[j * n2..(j + 1) * n2];
            let mut dr = vec![0.0; nh + nc];
            st.add_residual(t, x, &base_r, &mut dr);
            if nh > 0 {
                let r = Mat::from_fn(nh, 1, |a, _| dr[a] + (0..nq).map(|k| g[(a, k)] * sj[k]).sum::<f64>());
                let lam = dense_solve(npos.as_ref(), r.as_ref(), "Cq W^-1 Cq^T")?;
                for k in 0..nq {
                    sj[k] -= winv[k] * (0..nh).map(|a| g[(a, k)] * lam[(a, 0)]).sum::<f64>();
                }
            }
            if nc > 0 {
                // d(G qd) along the corrected S_q, plus G S_qd
                let zero = vec![0.0; nq];
                let (dg, _) = directional_terms(&self.base.dynamics().model, q, qd, &sj[..nq], &zero, nnz, nc);
                let mut r = Mat::from_fn(nc, 1, |a, _| dr[nh + a]);
                for (&(row, c), v) in pattern.iter().zip(&dg) {
                    r[(row, 0)] += v * qd[c];
                }
                for a in 0..nc {
                    r[(a, 0)] += (0..nq).map(|k| g[(a, k)] * sj[nq + k]).sum::<f64>();
                }
                let lam = dense_solve(nvel.as_ref(), r.as_ref(), "G W^-1 G^T")?;
                for k in 0..nq {
                    sj[nq + k] -= winv[k] * (0..nc).map(|a| g[(a, k)] * lam[(a, 0)]).sum::<f64>();
                }
            }
        }
        Ok(())
    }
}

impl<M: Model> Rhs for Augmented<M> {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.evaluate(t, y, dy).map_err(|e| match e {
            AnalysisError::Sim(e) => e,
            e => {
                let reason = e.to_string();
                self.failed = Some(e);
                SimError::Formulation { reason: reason.into() }
            }
        })
    }
}
