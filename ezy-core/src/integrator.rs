//! Time integrators. Issue 2 has the classic fourth-order Runge-Kutta
//! method with a fixed step (Hairer, Nørsett & Wanner, Solving ODEs I,
//! Table 1.2 of section II.1), as the seed uses.

use crate::SimError;
use crate::dynamics::Dynamics;
use crate::model::Model;

/// Classic RK4 with preallocated stages; `step` does not allocate.
#[derive(Debug, Clone)]
pub struct Rk4 {
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    tmp: Vec<f64>,
}

impl Rk4 {
    /// Stages for a state of length `ny`.
    pub fn new(ny: usize) -> Self {
        Self { k1: vec![0.0; ny], k2: vec![0.0; ny], k3: vec![0.0; ny], k4: vec![0.0; ny], tmp: vec![0.0; ny] }
    }

    /// Advances `y` from `t` to `t + h` (four right-hand-side evaluations).
    ///
    /// # Errors
    /// Whatever [`Dynamics::rhs`] returns.
    #[inline]
    pub fn step<M: Model>(&mut self, sys: &mut Dynamics<M>, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError> {
        let Self { k1, k2, k3, k4, tmp } = self;
        sys.rhs(t, y, k1)?;
        axpy(tmp, y, 0.5 * h, k1);
        sys.rhs(t + 0.5 * h, tmp, k2)?;
        axpy(tmp, y, 0.5 * h, k2);
        sys.rhs(t + 0.5 * h, tmp, k3)?;
        axpy(tmp, y, h, k3);
        sys.rhs(t + h, tmp, k4)?;
        let h6 = h / 6.0;
        for i in 0..y.len() {
            y[i] += h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        }
        Ok(())
    }
}

/// `out = y + a k`.
#[inline(always)]
fn axpy(out: &mut [f64], y: &[f64], a: f64, k: &[f64]) {
    for ((o, &yi), &ki) in out.iter_mut().zip(y).zip(k) {
        *o = yi + a * ki;
    }
}
