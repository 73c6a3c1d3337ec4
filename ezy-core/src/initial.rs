//! Consistent initial conditions: the scene gives some coordinates and
//! velocities, the solver computes the rest so that `C(q) = 0` and
//! `G(q) qd = 0` (docs/physics.md §7; for `free`, x1d = 1 and phi1d = 0 give
//! y1d = 0, x2d = 0.5, y2d = 0, phi2d = 5).
//!
//! Positions: Newton on `C(q)` in the unknown coordinates (the Jacobian's
//! columns of the unknowns, which must have full column rank). Velocities:
//! the linear system `G_u qd_u = -G_k qd_k` in the unknown velocities, with
//! the same rank condition. Both are solved by SVD (nalgebra), once.

use nalgebra::{DMatrix, DVector};

use crate::SimError;
use crate::model::{Model, scatter_dense};
use crate::projection::max_abs;

/// Tolerance of the consistent initial state: `max|C|` \[m\], and `max|G qd|`
/// \[m/s\] relative to `max(1, max|qd|)`.
pub const INITIAL_TOL: f64 = 1e-12;

/// Computes `(q, qd)` (nq each) from the given values.
///
/// `given_q`, `given_qd`: `(coordinate index, value)`; every other entry is
/// solved for, starting from 0. Given values that violate the constraints
/// are projected onto them (positions by Gauss-Newton with minimum-norm
/// steps, velocities by least squares); the [`InitialReport`] says by how much.
///
/// # Errors
/// [`SimError::Initial`] when the unknowns are not determined by the
/// constraints (give more values), or no consistent state exists.
pub fn consistent_state<M: Model>(
    model: &M,
    drives: &[crate::drive::Drive],
    given_q: &[(usize, f64)],
    given_qd: &[(usize, f64)],
) -> Result<(Vec<f64>, Vec<f64>, InitialReport), SimError> {
    let phi_at = |q: &[f64], phi: &mut [f64]| {
        model.phi(q, phi);
        crate::drive::shift_positions(drives, 0.0, phi);
    };
    let info = model.info();
    let info = &info;
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    let names = |idx: &[usize], suffix: &str| {
        idx.iter().map(|&i| format!("{}{suffix}", info.coords[i])).collect::<Vec<_>>().join(", ")
    };
    let mut q = vec![0.0; nq];
    let mut known_q = vec![false; nq];
    for &(i, v) in given_q {
        q[i] = v;
        known_q[i] = true;
    }
    let unknown_q: Vec<usize> = (0..nq).filter(|&i| !known_q[i]).collect();
    let mut phi = vec![0.0; nh];
    let mut jac_values = vec![0.0; info.n_holonomic_nonzeros()];
    let mut cq = vec![0.0; nh * nq];
    if unknown_q.len() > nh {
        return Err(SimError::Initial {
            reason: format!(
                "{} coordinates are missing ({}) but the {} holonomic constraints determine at most {}; give {} more",
                unknown_q.len(),
                names(&unknown_q, ""),
                nh,
                nh,
                unknown_q.len() - nh
            ),
        });
    }
    for _ in 0..50 {
        phi_at(&q, &mut phi);
        if max_abs(&phi) <= INITIAL_TOL || unknown_q.is_empty() {
            break;
        }
        model.holonomic_jacobian(&q, &mut jac_values);
        scatter_dense(&info.pattern[..jac_values.len()], &jac_values, nq, &mut cq);
        let j = DMatrix::from_fn(nh, unknown_q.len(), |r, c| cq[r * nq + unknown_q[c]]);
        let svd = j.svd(true, true);
        if svd.rank(1e-10 * svd.singular_values.max().max(1.0)) < unknown_q.len() {
            return Err(SimError::Initial {
                reason: format!(
                    "the holonomic constraints (hinges, sliders, drives) do not determine the coordinates {}; give them",
                    names(&unknown_q, "")
                ),
            });
        }
        let dx = svd
            .solve(&DVector::from_column_slice(&phi), 1e-14)
            .map_err(|e| SimError::Initial { reason: e.to_string() })?;
        for (k, &i) in unknown_q.iter().enumerate() {
            q[i] -= dx[k];
        }
    }
    phi_at(&q, &mut phi);
    let mut report = InitialReport::default();
    let res = max_abs(&phi);
    if res > INITIAL_TOL {
        // The given coordinates violate the holonomic rows: Gauss-Newton with the
        // minimum-norm step in all coordinates (the projection of docs/physics.md §6).
        report.position_violation = res;
        report.position_worst = phi
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map_or(String::new(), |(i, _)| info.constraints[i].clone());
        let q_given = q.clone();
        let all: Vec<usize> = (0..nq).collect();
        for _ in 0..50 {
            phi_at(&q, &mut phi);
            if max_abs(&phi) <= INITIAL_TOL {
                break;
            }
            model.holonomic_jacobian(&q, &mut jac_values);
            scatter_dense(&info.pattern[..jac_values.len()], &jac_values, nq, &mut cq);
            let j = DMatrix::from_fn(nh, nq, |r, c| cq[r * nq + all[c]]);
            let dx = j
                .svd(true, true)
                .solve(&DVector::from_column_slice(&phi), 1e-12)
                .map_err(|e| SimError::Initial { reason: e.to_string() })?;
            for i in 0..nq {
                q[i] -= dx[i];
            }
        }
        phi_at(&q, &mut phi);
        let left = max_abs(&phi);
        if left.is_nan() || left > 1e-9 {
            return Err(SimError::Initial {
                reason: format!(
                    "no configuration satisfies the holonomic constraints near the given coordinates (max|C| = {res:.3e}, {left:.3e} after projection)"
                ),
            });
        }
        report.position_correction = q.iter().zip(&q_given).fold(0.0, |m, (a, b)| m.max((a - b).abs()));
    }

    let mut qd = vec![0.0; nq];
    let mut known_v = vec![false; nq];
    for &(i, v) in given_qd {
        qd[i] = v;
        known_v[i] = true;
    }
    let unknown_v: Vec<usize> = (0..nq).filter(|&i| !known_v[i]).collect();
    let mut g_values = vec![0.0; info.pattern.len()];
    let mut g = vec![0.0; nc * nq];
    model.constraint_matrix(&q, &mut g_values);
    scatter_dense(&info.pattern, &g_values, nq, &mut g);
    if !unknown_v.is_empty() {
        if unknown_v.len() > nc {
            return Err(SimError::Initial {
                reason: format!(
                    "{} velocities are missing ({}) but the {} velocity constraints determine at most {}; give {} more",
                    unknown_v.len(),
                    names(&unknown_v, "d"),
                    nc,
                    nc,
                    unknown_v.len() - nc
                ),
            });
        }
        let gu = DMatrix::from_fn(nc, unknown_v.len(), |r, c| g[r * nq + unknown_v[c]]);
        let mut target = vec![0.0; nc];
        crate::drive::shift_velocities(drives, 0.0, &mut target);
        let rhs = DVector::from_fn(nc, |r, _| {
            -target[r] - (0..nq).filter(|&k| known_v[k]).map(|k| g[r * nq + k] * qd[k]).sum::<f64>()
        });
        let svd = gu.svd(true, true);
        if svd.rank(1e-10 * svd.singular_values.max().max(1.0)) < unknown_v.len() {
            return Err(SimError::Initial {
                reason: format!(
                    "the constraints do not determine the velocities {}; give them",
                    names(&unknown_v, "d")
                ),
            });
        }
        let x = svd.solve(&rhs, 1e-14).map_err(|e| SimError::Initial { reason: e.to_string() })?;
        for (k, &i) in unknown_v.iter().enumerate() {
            qd[i] = x[k];
        }
    }
    let mut r = vec![0.0; nc];
    crate::projection::mat_vec(&g, &qd, &mut r);
    crate::drive::shift_velocities(drives, 0.0, &mut r);
    let res = max_abs(&r);
    // velocities are only known to rounding relative to their size
    let v_tol = INITIAL_TOL * max_abs(&qd).max(1.0);
    if res > v_tol {
        // The given velocities violate the constraints: least-squares
        // projection of all velocities (docs/physics.md §6).
        report.velocity_violation = res;
        let gm = DMatrix::from_row_slice(nc, nq, &g);
        let dv = gm
            .svd(true, true)
            .solve(&DVector::from_column_slice(&r), 1e-12)
            .map_err(|e| SimError::Initial { reason: e.to_string() })?;
        for i in 0..nq {
            qd[i] -= dv[i];
        }
        report.velocity_correction = dv.amax();
        crate::projection::mat_vec(&g, &qd, &mut r);
        crate::drive::shift_velocities(drives, 0.0, &mut r);
        let left = max_abs(&r);
        if left.is_nan() || left > 1e3 * v_tol {
            return Err(SimError::Initial {
                reason: format!("the velocity constraints cannot be met (max|G qd| = {left:.3e} m/s after projection)"),
            });
        }
    }
    Ok((q, qd, report))
}

/// What [`consistent_state`] had to correct in the given values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InitialReport {
    /// `max|C|` of the given coordinates, when they violated the holonomic
    /// constraints (hinges, sliders, drives) \[m or rad\] (else 0).
    pub position_violation: f64,
    /// The row violated most, e.g. `B.y`.
    pub position_worst: String,
    /// Largest change of a coordinate by the projection \[m or rad\].
    pub position_correction: f64,
    /// `max|G qd|` of the given velocities, when they violated the constraints \[m/s\] (else 0).
    pub velocity_violation: f64,
    /// Largest change of a velocity by the projection \[m/s or rad/s\].
    pub velocity_correction: f64,
}

impl InitialReport {
    /// One warning line per correction made.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.position_violation > 0.0 {
            w.push(format!(
                "the initial coordinates violate the holonomic constraints by {:.3e} (most: `{}`); projected onto them (largest change {:.3e})",
                self.position_violation, self.position_worst, self.position_correction
            ));
        }
        if self.velocity_violation > 0.0 {
            w.push(format!(
                "the initial velocities violate the constraints by {:.3e} m/s; projected onto them (largest change {:.3e})",
                self.velocity_violation, self.velocity_correction
            ));
        }
        w
    }
}
