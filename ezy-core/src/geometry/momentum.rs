//! The nonholonomic momentum, its equation and the reconstruction of
//! the body velocity from it.

use num_dual::Dual64;

use super::linalg::mul;
use super::{Geometry, GeometryError};
use crate::model::Model;

/// One term of the momentum equation without forces, `p' = sum c z_a
/// z_b` over `z = [r', p]`: its coefficient for each momentum component
/// at one shape.
#[derive(Debug, Clone, PartialEq)]
pub struct MomentumTerm {
    /// The product, e.g. `B'^2`, `B' p_u`, `p_u^2`.
    pub label: String,
    /// Index of the first factor in `z = [r', p]`.
    pub a: usize,
    /// Index of the second factor (`>= a`).
    pub b: usize,
    /// The coefficient for each momentum component (m).
    pub value: Vec<f64>,
}

impl<M: Model> Geometry<M> {
    /// The nonholonomic momentum `p = K^T E^T M qd` (m) at the state
    /// `(q, qd)` (nq each, any position in the plane): `p_u` \[kg m/s\]
    /// along a direction whose forward speed is 1, `p_w` \[kg m^2/s\]
    /// along one whose yaw rate is 1.
    ///
    /// # Errors
    /// [`GeometryError::Request`] for a state of the wrong length or not
    /// finite; [`GeometryError::Singular`] where the skates lose rank.
    pub fn momentum(&self, q: &[f64], qd: &[f64]) -> Result<Vec<f64>, GeometryError> {
        self.check_state(q, qd)?;
        let t = self.terms(q, false).map_err(|mg| self.singular(&self.shape_of(q), mg))?;
        let m = self.free.len();
        let v = mul(self.info.nq(), 3, m, &t.e, &t.k);
        Ok((0..m).map(|j| (0..q.len()).map(|i| v[i * m + j] * self.mass[i] * qd[i]).sum()).collect())
    }

    /// The momentum equation's right-hand side `p' = (dV/dt)^T M qd +
    /// V^T F` (m) at time `t` \[s\] and state `(q, qd)` (nq each): `dV/dt`
    /// exact (dual numbers along `qd`), `F` the scene's applied forces
    /// ([`Geometry::with_forces`]; none without).
    ///
    /// # Errors
    /// As [`Geometry::momentum`]; the forces' failure.
    pub fn momentum_rate(&mut self, t: f64, q: &[f64], qd: &[f64]) -> Result<Vec<f64>, GeometryError> {
        self.momentum_rate_with(t, q, qd, true)
    }

    /// [`Geometry::momentum_rate`], the forces left out without `forces`.
    fn momentum_rate_with(&mut self, t: f64, q: &[f64], qd: &[f64], forces: bool) -> Result<Vec<f64>, GeometryError> {
        self.check_state(q, qd)?;
        let nq = q.len();
        let m = self.free.len();
        let qq: Vec<Dual64> = q.iter().zip(qd).map(|(a, b)| Dual64::new(*a, *b)).collect();
        let terms = self.terms(&qq, false).map_err(|mg| self.singular(&self.shape_of(q), mg))?;
        let v = mul(nq, 3, m, &terms.e, &terms.k);
        let f = match self.forces.as_mut().filter(|_| forces) {
            Some(an) => an.forces(t, q, qd).map_err(|e| GeometryError::Request { reason: e.to_string() })?,
            None => vec![0.0; nq],
        };
        Ok((0..m)
            .map(|j| (0..nq).map(|i| v[i * m + j].eps * self.mass[i] * qd[i] + v[i * m + j].re * f[i]).sum())
            .collect())
    }

    /// The reduced velocity `xi` from the full state: what the
    /// reconstruction equation gives, `-A r' + Gamma p` with `r'` and `p`
    /// read off `(q, qd)` (equal to [`Geometry::body_velocity`] on a
    /// state that keeps the constraints).
    ///
    /// # Errors
    /// As [`Geometry::momentum`].
    pub fn reconstructed_velocity(&self, q: &[f64], qd: &[f64]) -> Result<[f64; 3], GeometryError> {
        let p = self.momentum(q, qd)?;
        let t = self.terms(q, false).map_err(|mg| self.singular(&self.shape_of(q), mg))?;
        let rd = self.shape_of(qd);
        Ok(self.xi(&t, &rd, &p))
    }

    /// The momentum equation's coefficients at shape `r` without the
    /// applied forces: `p' = sum_{a <= b} c_ab z_a z_b`, `z = [r', p]`
    /// (n_shape + m), by polarization of the quadratic form (`p'` is
    /// quadratic in `z`: `qd` is linear in it, and so is `dV/dt`).
    /// Empty for a kinematic system.
    ///
    /// # Errors
    /// As [`Geometry::connection`].
    pub fn momentum_equation(&mut self, r: &[f64]) -> Result<Vec<MomentumTerm>, GeometryError> {
        let (ns, m) = (self.n_shape(), self.n_momentum());
        if m == 0 {
            self.check_shape(r)?;
            return Ok(Vec::new());
        }
        let n = ns + m;
        let mut names: Vec<String> = self.shape_names().iter().map(|s| format!("{s}'")).collect();
        names.extend(self.momentum_names());
        let mut quad = |z: &[f64]| -> Result<Vec<f64>, GeometryError> {
            let (q, qd) = self.state(r, &z[..ns], &z[ns..])?;
            self.momentum_rate_with(0.0, &q, &qd, false)
        };
        let unit = |a: usize, b: usize| -> Vec<f64> {
            let mut z = vec![0.0; n];
            z[a] += 1.0;
            z[b] += 1.0;
            z
        };
        let diagonal: Vec<Vec<f64>> =
            (0..n).map(|a| quad(&unit(a, a)).map(|v| v.iter().map(|x| x / 4.0).collect())).collect::<Result<_, _>>()?;
        let mut out = Vec::new();
        for a in 0..n {
            for b in a..n {
                let value = if a == b {
                    diagonal[a].clone()
                } else {
                    let both = quad(&unit(a, b))?;
                    (0..m).map(|j| both[j] - diagonal[a][j] - diagonal[b][j]).collect()
                };
                let label = if a == b { format!("{}^2", names[a]) } else { format!("{} {}", names[a], names[b]) };
                out.push(MomentumTerm { label, a, b, value });
            }
        }
        Ok(out)
    }
}
