//! RADAU5: the three-stage Radau IIA method of order 5 for stiff problems
//! (Hairer & Wanner, *Solving Ordinary Differential Equations II*, 2nd ed.,
//! §IV.8), after their Fortran code RADAU5 and SciPy's `Radau`, which
//! follows it: the simplified Newton iteration on the transformed stage
//! system (one real and one complex linear system per iteration, from the
//! eigenvalues `MU_REAL` and `MU_COMPLEX` of the inverse coefficient
//! matrix), the convergence test on the contraction rate, Jacobian reuse
//! across steps, the embedded error estimate `(gamma0/h - J)^-1 (f0 + e .
//! Z / h)` (its "stabilized" form after a rejection), Gustafsson's
//! predictive step-size controller, and the cubic collocation polynomial
//! as dense output.
//!
//! The linear algebra is behind [`NewtonSystem`]: [`DenseNewton`] takes
//! the Jacobian of any right-hand side by finite differences and factors
//! `(mu/h) I - J` densely (faer's LU, real and complex); the multibody
//! runtime has its own system built on the KKT structure
//! ([`crate::formulation::newton`]). Nothing is allocated per step.

// the stage loops index several arrays at once, as RADAU5's Fortran does
#![expect(
    clippy::needless_range_loop,
    reason = "index loops over the small fixed sizes unroll; iterator chains with skip(k) did not"
)]

pub use faer::c64;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::factor::{self, PartialPivLuParams};
use faer::linalg::lu::partial_pivoting::solve;
use faer::{Mat, Par, Spec};

use super::Rhs;
use super::adaptive::Tolerance;
use super::stepper::{Control, NewtonStats, Stats, Stepper, Trial};
use crate::error::KktError;
use crate::error::SimError;

/// Nodes of Radau IIA of order 5: `(4 - sqrt 6)/10, (4 + sqrt 6)/10, 1`.
pub const C: [f64; 3] = [0.15505102572168222, 0.6449489742783178, 1.0];
/// Weights of the embedded error estimate (`-13 - 7 sqrt 6`, `-13 + 7 sqrt 6`, `-1`) / 3.
const E: [f64; 3] = [-10.048809399827414, 1.382142733160748, -0.3333333333333333];
/// The real eigenvalue of the inverse coefficient matrix, `3 + 3^(2/3) - 3^(1/3)`.
pub const MU_REAL: f64 = 3.637834252744496;
/// The complex eigenvalue of the inverse coefficient matrix,
/// `3 + (3^(1/3) - 3^(2/3))/2 - i (3^(5/6) + 3^(7/6))/2`.
pub const MU_COMPLEX: (f64, f64) = (2.6810828736277523, -3.050430199247411);
/// The eigenvectors `T` of the coefficient matrix, `A = T diag(1/mu) T^-1`
/// (the digits of RADAU5's `T11 .. T33`).
#[expect(clippy::excessive_precision, reason = "the coefficients as the reference code prints them, digit for digit")]
const T: [[f64; 3]; 3] = [
    [0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
    [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
    [1.0, 1.0, 0.0],
];
/// `T^-1` (RADAU5's `TI11 .. TI33`).
#[expect(clippy::excessive_precision, reason = "the coefficients as the reference code prints them, digit for digit")]
const TI: [[f64; 3]; 3] = [
    [4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
    [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
    [0.50287263494578682, -2.57192694985560522, 0.59603920482822492],
];
/// Dense output: `y(t + x h) = y + sum_k Q_k x^(k+1)`, `Q = Z^T P`.
const P: [[f64; 3]; 3] = [
    [10.048809399827414, -25.62959144707664, 15.580782047249224],
    [-1.382142733160748, 10.296258113743303, -8.914115380582556],
    [0.3333333333333333, -2.6666666666666665, 3.3333333333333335],
];
/// RADAU5's `NIT`: at most `NIT - 1` Newton iterations per step attempt.
const NEWTON_MAXITER: usize = 7;
/// The first contraction rate that counts as divergence (RADAU5: 0.99 for
/// every rate). On stiff multibody scenes the first rate comes out near 1
/// and the next near 0.01 (`four-bar-stiff`: 1.02, then 0.004): with 0.99
/// the scene took 2955 rejected steps of 6921.
const FIRST_RATE_LIMIT: f64 = 2.0;
/// Bounds of the step-size change.
const MIN_FACTOR: f64 = 0.2;
const MAX_FACTOR: f64 = 10.0;

/// The linear algebra of the simplified Newton iteration: a Jacobian
/// `J ~ dF/dy` (n x n) at a chosen point, and the factorizations of
/// `a I - J` for `a = MU_REAL / h` (real) and `a = MU_COMPLEX / h`
/// (complex).
pub trait NewtonSystem<R: ?Sized> {
    /// Evaluates the Jacobian at `(t, y)`, where `f = F(t, y)`.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn jacobian(&mut self, rhs: &mut R, t: f64, y: &[f64], f: &[f64]) -> Result<(), SimError>;
    /// Factors `real I - J` and `complex I - J` for the last Jacobian;
    /// `false` if either is singular.
    fn factor(&mut self, real: f64, complex: c64) -> bool;
    /// Solves `(real I - J) x = b` in place.
    fn solve_real(&mut self, b: &mut [f64]);
    /// Solves `(complex I - J) x = b` in place.
    fn solve_complex(&mut self, b: &mut [c64]);
}

/// What one step attempt did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Attempt {
    /// The step was accepted: `y_new` holds the new state; try `h_next` next.
    Accepted {
        /// The next step size \[s\].
        h_next: f64,
    },
    /// The step was rejected (error too large, Newton did not converge, a
    /// singular matrix); try again from the same point with `h_next`.
    Rejected {
        /// The step size to retry with \[s\].
        h_next: f64,
    },
}

/// The Radau IIA stepper's buffers and the state carried between steps
/// (Jacobian and factorization validity, the previous step and error for
/// the controller, the dense output of the last accepted step).
#[derive(Debug, Clone)]
pub struct Radau5 {
    n: usize,
    z: [Vec<f64>; 3],
    w: [Vec<f64>; 3],
    fs: [Vec<f64>; 3],
    stage: Vec<f64>,
    scale: Vec<f64>,
    dw_real: Vec<f64>,
    dw_complex: Vec<c64>,
    err: Vec<f64>,
    /// Dense output of the last accepted step: `y_old` and `Q` (3 x n).
    y_old: Vec<f64>,
    q: [Vec<f64>; 3],
    t_old: f64,
    h_last: f64,
    have_dense: bool,
    jac_valid: bool,
    current_jac: bool,
    lu_h: Option<f64>,
    h_old: Option<f64>,
    err_old: Option<f64>,
    rejected: bool,
    /// `theta / (1 - theta)` of the last converged iteration (RADAU5's `FACCON`).
    faccon: f64,
    newton_tol: f64,
    /// The internal tolerance ([`internal_tolerance`]).
    tol: Tolerance,
    /// Work done so far.
    pub stats: NewtonStats,
    /// An effect's failure at a stage since the last accepted step: the
    /// cause to report if the step size shrinks to nothing.
    pub stage_failure: Option<SimError>,
}

/// The RMS norm `sqrt(mean((x_i / s_i)^2))`.
fn rms(x: impl Iterator<Item = f64>, n: usize) -> f64 {
    (x.map(|v| v * v).sum::<f64>() / n.max(1) as f64).sqrt()
}

impl Radau5 {
    /// Buffers for a state of length `n` at tolerance `tol` (the Newton
    /// tolerance is `max(10 eps / rtol, min(0.03, sqrt(rtol)))`, HW II
    /// §IV.8 and SciPy).
    pub fn new(n: usize, tol: &Tolerance) -> Self {
        let tol = internal_tolerance(tol);
        let v = || vec![0.0; n];
        Self {
            n,
            z: [v(), v(), v()],
            w: [v(), v(), v()],
            fs: [v(), v(), v()],
            stage: v(),
            scale: v(),
            dw_real: v(),
            dw_complex: vec![c64::new(0.0, 0.0); n],
            err: v(),
            y_old: v(),
            q: [v(), v(), v()],
            t_old: 0.0,
            h_last: 0.0,
            have_dense: false,
            jac_valid: false,
            current_jac: false,
            lu_h: None,
            h_old: None,
            err_old: None,
            rejected: false,
            faccon: 1.0,
            newton_tol: (10.0 * f64::EPSILON / tol.rtol).max(0.03f64.min(tol.rtol.sqrt())),
            tol,
            stats: NewtonStats::default(),
            stage_failure: None,
        }
    }

    /// Attempts a step of size `h` from `(t, y)` with `f = F(t, y)`; on
    /// acceptance writes the new state into `y_new`.
    ///
    /// # Errors
    /// Whatever the right-hand side or the Jacobian fails with, except a
    /// non-finite stage, which rejects the step.
    #[expect(
        clippy::too_many_arguments,
        reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
    )]
    pub fn attempt<R: Rhs + ?Sized, N: NewtonSystem<R>>(
        &mut self,
        rhs: &mut R,
        newton: &mut N,
        t: f64,
        y: &[f64],
        f: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<Attempt, SimError> {
        let n = self.n;
        let tol = self.tol;
        for (s, &yi) in self.scale.iter_mut().zip(y) {
            *s = tol.atol + tol.rtol * yi.abs();
        }
        let (n_iter, theta) = loop {
            if !self.jac_valid {
                newton.jacobian(rhs, t, y, f)?;
                self.stats.jacobians += 1;
                self.jac_valid = true;
                self.current_jac = true;
                self.lu_h = None;
            }
            if self.lu_h != Some(h) {
                self.stats.factorizations += 1;
                let complex = c64::new(MU_COMPLEX.0 / h, MU_COMPLEX.1 / h);
                if !newton.factor(MU_REAL / h, complex) {
                    self.lu_h = None;
                    return Ok(Attempt::Rejected { h_next: 0.5 * h });
                }
                self.lu_h = Some(h);
            }
            self.predict(t, y, h);
            match self.solve_collocation(rhs, newton, t, y, h)? {
                Newton::Converged { iterations, theta } => break (iterations, theta),
                // an old Jacobian: a fresh one, and again with the same step
                Newton::Failed { .. } if !self.current_jac => self.jac_valid = false,
                Newton::Failed { factor } => {
                    self.lu_h = None;
                    return Ok(Attempt::Rejected { h_next: factor * h });
                }
            }
        };
        for j in 0..n {
            y_new[j] = y[j] + self.z[2][j];
        }
        // error estimate (gamma0/h I - J)^-1 (f + sum e_i Z_i / h)
        let ze = |z: &[Vec<f64>; 3], j: usize| (E[0] * z[0][j] + E[1] * z[1][j] + E[2] * z[2][j]) / h;
        for j in 0..n {
            self.err[j] = f[j] + ze(&self.z, j);
        }
        newton.solve_real(&mut self.err);
        for j in 0..n {
            self.scale[j] = tol.atol + tol.rtol * y[j].abs().max(y_new[j].abs());
        }
        let mut err_norm = rms(self.err.iter().zip(&self.scale).map(|(e, s)| e / s), n);
        let safety = 0.9 * (2 * NEWTON_MAXITER + 1) as f64 / (2 * NEWTON_MAXITER + n_iter) as f64;
        if self.rejected && err_norm > 1.0 {
            // the stabilized estimate (HW II §IV.8, p. 123): one more solve
            for j in 0..n {
                self.stage[j] = y[j] + self.err[j];
            }
            match rhs.eval(t, &self.stage, &mut self.fs[0]) {
                Ok(()) => {
                    for j in 0..n {
                        self.err[j] = self.fs[0][j] + ze(&self.z, j);
                    }
                    newton.solve_real(&mut self.err);
                    err_norm = rms(self.err.iter().zip(&self.scale).map(|(e, s)| e / s), n);
                }
                Err(_) => err_norm = f64::INFINITY,
            }
        }
        // a NaN error rejects the step
        if err_norm.is_nan() || err_norm > 1.0 {
            let factor = predict_factor(h, self.h_old, err_norm, self.err_old);
            self.lu_h = None;
            self.rejected = true;
            let fac = if factor.is_finite() { (safety * factor).max(MIN_FACTOR) } else { MIN_FACTOR };
            return Ok(Attempt::Rejected { h_next: h * fac });
        }
        let recompute_jac = theta > 1e-3;
        let mut factor = (safety * predict_factor(h, self.h_old, err_norm, self.err_old)).min(MAX_FACTOR);
        if !recompute_jac && factor < 1.2 {
            factor = 1.0;
        } else {
            self.lu_h = None;
        }
        if recompute_jac {
            self.jac_valid = false;
        } else {
            self.current_jac = false;
        }
        self.h_old = Some(h);
        self.err_old = Some(err_norm);
        self.stage_failure = None;
        self.rejected = false;
        // the collocation polynomial of this step, for output and the next predictor
        self.y_old.copy_from_slice(y);
        for k in 0..3 {
            for j in 0..n {
                self.q[k][j] = self.z[0][j] * P[0][k] + self.z[1][j] * P[1][k] + self.z[2][j] * P[2][k];
            }
        }
        self.t_old = t;
        self.h_last = h;
        self.have_dense = true;
        Ok(Attempt::Accepted { h_next: h * factor })
    }

    /// Forgets what the steps so far carried over: the predictor of the
    /// stage values (the next one starts from zero), the Jacobian and its
    /// factors, and the controller's memory of the last step and error.
    /// Called where the right-hand side changed at an instant (a skate's
    /// switch, an event switching an effect): the next step starts as
    /// the first one did.
    pub fn restart(&mut self) {
        self.have_dense = false;
        self.jac_valid = false;
        self.current_jac = false;
        self.lu_h = None;
        self.h_old = None;
        self.err_old = None;
        self.rejected = false;
        self.faccon = 1.0;
    }

    /// Sets the Newton iteration's stopping tolerance (scaled as the error
    /// norm; [`Radau5::new`] derives it from the tolerance). A tight one
    /// with a loose error tolerance makes every attempt accepted at the
    /// step asked for: fixed steps, for measuring the order.
    pub fn set_newton_tolerance(&mut self, tol: f64) {
        self.newton_tol = tol;
    }

    /// The starting values of the Newton iteration: the last step's
    /// collocation polynomial at the new nodes (zero on the first step).
    fn predict(&mut self, t: f64, y: &[f64], h: f64) {
        for i in 0..3 {
            if self.have_dense {
                let x = (t + C[i] * h - self.t_old) / self.h_last;
                for j in 0..self.n {
                    let p = x * (self.q[0][j] + x * (self.q[1][j] + x * self.q[2][j]));
                    self.z[i][j] = self.y_old[j] + p - y[j];
                }
            } else {
                self.z[i].fill(0.0);
            }
        }
    }

    /// The dense output of the last accepted step at `t_old + theta h`,
    /// `theta` in \[0, 1\] (the collocation polynomial, order 3).
    pub fn interpolate(&self, theta: f64, out: &mut [f64]) {
        let x = theta;
        for j in 0..self.n {
            out[j] = self.y_old[j] + x * (self.q[0][j] + x * (self.q[1][j] + x * self.q[2][j]));
        }
    }

    /// Simplified Newton iterations on the transformed stage system from
    /// the starting values in `self.z` (HW II §IV.8, and RADAU5's
    /// `NEWT` loop): at most `NEWTON_MAXITER - 1` iterations; converged
    /// when `theta / (1 - theta) |dW| <= newton_tol`, with `theta` the
    /// contraction rate (the previous step's for the first iteration);
    /// failed when `theta >= 0.99`, or when the iterations left are
    /// predicted not to reach the tolerance. That prediction is made from
    /// the third iteration on, with `theta` the geometric mean of the last
    /// two rates: on stiff multibody scenes the first rate overstates the
    /// contraction (`snake-stiff`: 0.51, then 0.012, converged in three),
    /// since a good predictor leaves an error in the stiff directions that
    /// the step's change of the Jacobian moves into the others once.
    fn solve_collocation<R: Rhs + ?Sized, N: NewtonSystem<R>>(
        &mut self,
        rhs: &mut R,
        newton: &mut N,
        t: f64,
        y: &[f64],
        h: f64,
    ) -> Result<Newton, SimError> {
        let n = self.n;
        let m_real = MU_REAL / h;
        let (mc_re, mc_im) = (MU_COMPLEX.0 / h, MU_COMPLEX.1 / h);
        let diverged = Newton::Failed { factor: 0.5 };
        // W = T^-1 Z
        for k in 0..3 {
            for j in 0..n {
                self.w[k][j] = TI[k][0] * self.z[0][j] + TI[k][1] * self.z[1][j] + TI[k][2] * self.z[2][j];
            }
        }
        let mut faccon = self.faccon.max(f64::EPSILON).powf(0.8);
        let (mut dw_norm_old, mut thq_old) = (None::<f64>, 0.0);
        let mut theta = None;
        for k in 0..NEWTON_MAXITER - 1 {
            self.stats.newton_iterations += 1;
            for i in 0..3 {
                for j in 0..n {
                    self.stage[j] = y[j] + self.z[i][j];
                }
                match rhs.eval(t + C[i] * h, &self.stage, &mut self.fs[i]) {
                    Ok(()) => {}
                    // an overflowing stage: not converged, a smaller step
                    Err(SimError::Kkt { source: KktError::NonFinite { .. }, .. }) => return Ok(diverged),
                    Err(e @ SimError::EffectFailed { .. }) => {
                        self.stage_failure = Some(e);
                        return Ok(diverged);
                    }
                    Err(e) => return Err(e),
                }
                if self.fs[i].iter().any(|v| !v.is_finite()) {
                    return Ok(diverged);
                }
            }
            for j in 0..n {
                let (f0, f1, f2) = (self.fs[0][j], self.fs[1][j], self.fs[2][j]);
                self.dw_real[j] = TI[0][0] * f0 + TI[0][1] * f1 + TI[0][2] * f2 - m_real * self.w[0][j];
                let (w1, w2) = (self.w[1][j], self.w[2][j]);
                let re = TI[1][0] * f0 + TI[1][1] * f1 + TI[1][2] * f2 - (mc_re * w1 - mc_im * w2);
                let im = TI[2][0] * f0 + TI[2][1] * f1 + TI[2][2] * f2 - (mc_re * w2 + mc_im * w1);
                self.dw_complex[j] = c64::new(re, im);
            }
            newton.solve_real(&mut self.dw_real);
            newton.solve_complex(&mut self.dw_complex);
            let sum: f64 = (0..n)
                .map(|j| {
                    let s = self.scale[j];
                    let (a, b, c) = (self.dw_real[j] / s, self.dw_complex[j].re / s, self.dw_complex[j].im / s);
                    a * a + b * b + c * c
                })
                .sum();
            let dw_norm = (sum / (3 * n).max(1) as f64).sqrt();
            if !dw_norm.is_finite() {
                return Ok(diverged);
            }
            if let Some(old) = dw_norm_old {
                let thq = dw_norm / old;
                let th = if k == 1 { thq } else { (thq * thq_old).sqrt() };
                thq_old = thq;
                theta = Some(th);
                // the first rate may pass 1 once (see above); a real divergence
                // shows in the geometric mean of the first two
                if th >= if k == 1 { FIRST_RATE_LIMIT } else { 0.99 } {
                    return Ok(diverged);
                }
                // (a first rate past 1 converges nothing yet)
                faccon = if th < 0.99 { th / (1.0 - th) } else { f64::INFINITY };
                let left = (NEWTON_MAXITER - 1 - (k + 1)) as i32;
                if k >= 2 && left > 0 {
                    let dyth = faccon * dw_norm * th.powi(left) / self.newton_tol;
                    if dyth >= 1.0 {
                        let q = dyth.clamp(1e-4, 20.0);
                        return Ok(Newton::Failed { factor: 0.8 * q.powf(-1.0 / (4.0 + f64::from(left))) });
                    }
                }
            }
            for j in 0..n {
                self.w[0][j] += self.dw_real[j];
                self.w[1][j] += self.dw_complex[j].re;
                self.w[2][j] += self.dw_complex[j].im;
            }
            // Z = T W
            for i in 0..3 {
                for j in 0..n {
                    self.z[i][j] = T[i][0] * self.w[0][j] + T[i][1] * self.w[1][j] + T[i][2] * self.w[2][j];
                }
            }
            if faccon * dw_norm <= self.newton_tol {
                self.faccon = faccon;
                return Ok(Newton::Converged { iterations: k + 1, theta: theta.unwrap_or(0.0) });
            }
            dw_norm_old = Some(dw_norm.max(f64::EPSILON));
        }
        Ok(diverged)
    }
}

/// How a Newton iteration ended.
enum Newton {
    /// After `iterations`, with the last contraction rate `theta` (0 after one).
    Converged { iterations: usize, theta: f64 },
    /// Diverged or too slow: try again with the step times `factor`.
    Failed { factor: f64 },
}

/// The tolerance the error estimate is held to: RADAU5's
/// `rtol' = 0.1 rtol^(2/3)`, `atol' = rtol' atol / rtol` (HW II §IV.8 and
/// the code's comments). The embedded estimate is of order 3 (its error is
/// `O(h^4)`) while the solution is of order 5, so at `rtol'` the global
/// error comes out near the `rtol` asked for, with fewer steps than the
/// estimate held to `rtol` itself would take.
pub fn internal_tolerance(tol: &Tolerance) -> Tolerance {
    let rtol = 0.1 * tol.rtol.powf(2.0 / 3.0);
    Tolerance { rtol, atol: tol.atol * rtol / tol.rtol }
}

/// Gustafsson's predictive step-size factor (HW II §IV.8, eq. 8.25, as in
/// SciPy's `predict_factor`): `min(1, h/h_old (err_old/err)^(1/4))
/// err^(-1/4)`.
fn predict_factor(h: f64, h_old: Option<f64>, err: f64, err_old: Option<f64>) -> f64 {
    let multiplier = match (h_old, err_old) {
        (Some(ho), Some(eo)) if err > 0.0 => h / ho * (eo / err).powf(0.25),
        _ => 1.0,
    };
    if err == 0.0 { f64::INFINITY } else { multiplier.min(1.0) * err.powf(-0.25) }
}

/// A dense LU with partial pivoting of an `n x n` matrix of `f64` or
/// `c64` on preallocated buffers (faer's unblocked variant, which does
/// not allocate; see [`crate::kkt::dense_lu::DenseLu`]).
pub struct DenseFactor<T: faer::traits::ComplexField> {
    /// The matrix, overwritten by its factors by [`DenseFactor::factor`].
    pub a: Mat<T>,
    rhs: Mat<T>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    mem: MemBuffer,
}

impl<T: faer::traits::ComplexField> std::fmt::Debug for DenseFactor<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseFactor").field("n", &self.perm.len()).finish_non_exhaustive()
    }
}

/// `|x|` of a real or complex scalar, for the pivot test.
pub trait Magnitude {
    /// The modulus.
    fn magnitude(&self) -> f64;
}
impl Magnitude for f64 {
    fn magnitude(&self) -> f64 {
        self.abs()
    }
}
impl Magnitude for c64 {
    fn magnitude(&self) -> f64 {
        self.norm()
    }
}

/// The scalars [`DenseFactor`] factors (`f64` and `c64`). Its methods
/// are compiled once, in this crate, for each of the two: a model's
/// crate that runs RADAU5 calls them instead of building faer's LU and
/// triangular solves again for its own model (a release build does not
/// share generic code between crates).
pub trait LuField: faer::traits::ComplexField + Copy + Magnitude {
    /// [`DenseFactor::new`].
    fn lu_new(n: usize) -> DenseFactor<Self>;
    /// [`DenseFactor::factor`].
    fn lu_factor(lu: &mut DenseFactor<Self>) -> bool;
    /// [`DenseFactor::solve`].
    fn lu_solve(lu: &mut DenseFactor<Self>, b: &mut [Self]);
}

macro_rules! lu_field {
    ($t:ty) => {
        impl LuField for $t {
            #[inline(never)]
            fn lu_new(n: usize) -> DenseFactor<Self> {
                DenseFactor::new_impl(n)
            }
            #[inline(never)]
            fn lu_factor(lu: &mut DenseFactor<Self>) -> bool {
                lu.factor_impl()
            }
            #[inline(never)]
            fn lu_solve(lu: &mut DenseFactor<Self>, b: &mut [Self]) {
                lu.solve_impl(b);
            }
        }
    };
}
lu_field!(f64);
lu_field!(c64);

impl<T: LuField> DenseFactor<T> {
    /// Buffers for `n x n`.
    pub fn new(n: usize) -> Self {
        T::lu_new(n)
    }

    /// Factors `self.a` in place; `false` if a pivot is zero or not finite.
    pub fn factor(&mut self) -> bool {
        T::lu_factor(self)
    }

    /// Solves with the factors in place: `b` (n) is overwritten by the solution.
    pub fn solve(&mut self, b: &mut [T]) {
        T::lu_solve(self, b);
    }

    fn new_impl(n: usize) -> Self {
        let params = lu_params::<T>();
        let req = StackReq::any_of(&[
            factor::lu_in_place_scratch::<usize, T>(n, n, Par::Seq, params),
            solve::solve_in_place_scratch::<usize, T>(n, 1, Par::Seq),
        ]);
        Self {
            a: Mat::zeros(n, n),
            rhs: Mat::zeros(n, 1),
            perm: vec![0; n],
            perm_inv: vec![0; n],
            mem: MemBuffer::new(req),
        }
    }

    fn factor_impl(&mut self) -> bool {
        let n = self.a.nrows();
        let stack = MemStack::new(&mut self.mem);
        factor::lu_in_place(self.a.as_mut(), &mut self.perm, &mut self.perm_inv, Par::Seq, stack, lu_params::<T>());
        (0..n).all(|k| {
            let p = self.a[(k, k)].magnitude();
            p.is_finite() && p > 0.0
        })
    }

    fn solve_impl(&mut self, b: &mut [T]) {
        let n = b.len();
        self.rhs.col_as_slice_mut(0).copy_from_slice(b);
        let perm = faer::perm::PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let stack = MemStack::new(&mut self.mem);
        let lu = self.a.as_ref();
        solve::solve_in_place(lu, lu, perm, self.rhs.as_mut(), Par::Seq, stack);
        b.copy_from_slice(self.rhs.col_as_slice(0));
    }
}

/// faer's LU parameters: the unblocked variant only (it does not allocate).
fn lu_params<T: faer::traits::ComplexField>() -> Spec<PartialPivLuParams, T> {
    let mut params = Spec::<PartialPivLuParams, T>::default();
    params.config.recursion_threshold = usize::MAX;
    params
}

/// [`NewtonSystem`] for any right-hand side: the Jacobian by forward
/// differences, one column at a time (step `sqrt(eps) max(|y_j|, 1e-5)`),
/// and dense LU factorizations of `a I - J`.
#[derive(Debug)]
pub struct DenseNewton {
    n: usize,
    /// `J` row-major (n x n).
    jac: Vec<f64>,
    real: DenseFactor<f64>,
    complex: DenseFactor<c64>,
    y_pert: Vec<f64>,
    f_pert: Vec<f64>,
}

impl DenseNewton {
    /// Buffers for `n` states.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            jac: vec![0.0; n * n],
            real: DenseFactor::new(n),
            complex: DenseFactor::new(n),
            y_pert: vec![0.0; n],
            f_pert: vec![0.0; n],
        }
    }

    /// The last Jacobian, row-major (n x n).
    pub fn jacobian_values(&self) -> &[f64] {
        &self.jac
    }
}

impl<R: Rhs + ?Sized> NewtonSystem<R> for DenseNewton {
    fn jacobian(&mut self, rhs: &mut R, t: f64, y: &[f64], f: &[f64]) -> Result<(), SimError> {
        let n = self.n;
        self.y_pert.copy_from_slice(y);
        for j in 0..n {
            let d = f64::EPSILON.sqrt() * y[j].abs().max(1e-5);
            self.y_pert[j] = y[j] + d;
            let d = self.y_pert[j] - y[j];
            rhs.eval(t, &self.y_pert, &mut self.f_pert)?;
            for i in 0..n {
                self.jac[i * n + j] = (self.f_pert[i] - f[i]) / d;
            }
            self.y_pert[j] = y[j];
        }
        Ok(())
    }

    fn factor(&mut self, real: f64, complex: c64) -> bool {
        let n = self.n;
        for j in 0..n {
            for i in 0..n {
                let d = if i == j { 1.0 } else { 0.0 };
                let jij = self.jac[i * n + j];
                self.real.a[(i, j)] = real * d - jij;
                self.complex.a[(i, j)] = complex * d - c64::new(jij, 0.0);
            }
        }
        self.real.factor() && self.complex.factor()
    }

    fn solve_real(&mut self, b: &mut [f64]) {
        self.real.solve(b);
    }

    fn solve_complex(&mut self, b: &mut [c64]) {
        self.complex.solve(b);
    }
}

/// RADAU5 with its Newton system `N` as a [`Stepper`]: the method
/// accepts or rejects by itself ([`Control::Internal`]), the slope at a
/// step's start is evaluated when the step before it is done
/// ([`Stepper::advance`]), and the dense output is the collocation
/// polynomial.
#[derive(Debug, Clone)]
pub struct Radau5Stepper<N> {
    method: Radau5,
    newton: N,
    tol: Tolerance,
    /// `F` at the step's start.
    f: Vec<f64>,
    /// The last attempt's start \[s\] and size \[s\].
    t: f64,
    h: f64,
    /// Scratch of [`super::adaptive::initial_step`].
    work: [Vec<f64>; 2],
}

impl<N> Radau5Stepper<N> {
    /// RADAU5 for a state of length `n` at tolerance `tol`, with the
    /// Newton system `newton`.
    pub fn new(n: usize, tol: &Tolerance, newton: N) -> Self {
        Self {
            method: Radau5::new(n, tol),
            newton,
            tol: *tol,
            f: vec![0.0; n],
            t: 0.0,
            h: 0.0,
            work: [vec![0.0; n], vec![0.0; n]],
        }
    }
}

impl<R: Rhs, N: NewtonSystem<R>> Stepper<R> for Radau5Stepper<N> {
    const CONTROL: Control = Control::Internal;
    const FSAL: bool = false;

    /// The first step as for the order-3 error estimate.
    fn start(&mut self, rhs: &mut R, t: f64, x: &[f64], h_max: f64) -> Result<f64, SimError> {
        rhs.eval(t, x, &mut self.f)?;
        let [w1, w2] = &mut self.work;
        super::adaptive::initial_step(rhs, t, x, &self.f, 3, &self.tol, h_max, w1, w2)
    }

    fn attempt(&mut self, rhs: &mut R, t: f64, x: &[f64], h: f64, x_new: &mut [f64]) -> Result<Trial, SimError> {
        self.t = t;
        self.h = h;
        Ok(match self.method.attempt(rhs, &mut self.newton, t, x, &self.f, h, x_new)? {
            Attempt::Accepted { h_next } => Trial::Accepted { h_next },
            Attempt::Rejected { h_next } => Trial::Rejected { h_next },
        })
    }

    fn control(&mut self, _err: f64) -> (bool, f64) {
        (true, self.h)
    }

    fn accepted(
        &mut self,
        _rhs: &mut R,
        _t_new: f64,
        _x_new: &[f64],
        _moved: bool,
        _slope: bool,
    ) -> Result<bool, SimError> {
        Ok(false)
    }

    fn end_slope(&self) -> &[f64] {
        &self.f
    }

    fn dense_ready(&self) -> bool {
        true
    }

    fn prepare_dense(&mut self, _rhs: &mut R, _t_new: f64, _x: &[f64], _x_new: &[f64]) -> Result<(), SimError> {
        Ok(())
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        self.method.interpolate((t - self.t) / self.h, out);
    }

    fn restart(&mut self, _rhs: &mut R, _t: f64, _x: &[f64]) -> Result<(), SimError> {
        self.method.restart();
        Ok(())
    }

    fn advance(&mut self, rhs: &mut R, t: f64, x: &[f64]) -> Result<(), SimError> {
        rhs.eval(t, x, &mut self.f)
    }

    fn stage_failure(&mut self) -> &mut Option<SimError> {
        &mut self.method.stage_failure
    }

    fn stats(&self) -> Stats {
        Stats { newton: self.method.stats, stiff: None }
    }
}

/// Work and result of [`integrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// `y(t_end)`.
    pub y: Vec<f64>,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts.
    pub rejected: u64,
    /// The Newton iterations, Jacobians and factorizations.
    pub newton: NewtonStats,
}

/// Integrates `y' = F(t, y)` from `(t0, y0)` to `t_end` with RADAU5 and
/// the dense finite-difference Newton system ([`DenseNewton`]): the
/// generic interface, for plain ODEs (the test problems of stiff
/// integrators). The first step is chosen as for an order-3 error
/// estimate (HW I §II.4).
///
/// # Errors
/// Whatever `F` fails with, or [`SimError::StepSizeTooSmall`].
pub fn integrate<R: Rhs>(rhs: &mut R, t0: f64, y0: &[f64], t_end: f64, tol: &Tolerance) -> Result<Solution, SimError> {
    let n = y0.len();
    let mut stepper = Radau5::new(n, tol);
    let mut newton = DenseNewton::new(n);
    let (mut y, mut y_new, mut f) = (y0.to_vec(), vec![0.0; n], vec![0.0; n]);
    let (mut w1, mut w2) = (vec![0.0; n], vec![0.0; n]);
    rhs.eval(t0, &y, &mut f)?;
    let mut h = super::adaptive::initial_step(rhs, t0, &y, &f, 3, tol, t_end - t0, &mut w1, &mut w2)?;
    let (mut t, mut steps, mut rejected) = (t0, 0u64, 0u64);
    while t < t_end {
        let last = t + h >= t_end;
        let h_try = if last { t_end - t } else { h };
        if h_try <= 16.0 * f64::EPSILON * t.abs().max(1e-300) {
            return Err(stepper.stage_failure.take().unwrap_or(SimError::StepSizeTooSmall { t, h: h_try }));
        }
        match stepper.attempt(rhs, &mut newton, t, &y, &f, h_try, &mut y_new)? {
            Attempt::Accepted { h_next } => {
                t = if last { t_end } else { t + h_try };
                y.copy_from_slice(&y_new);
                rhs.eval(t, &y, &mut f)?;
                steps += 1;
                h = h_next;
            }
            Attempt::Rejected { h_next } => {
                rejected += 1;
                h = h_next;
            }
        }
    }
    Ok(Solution { y, steps, rejected, newton: stepper.stats })
}
