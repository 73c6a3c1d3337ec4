//! DOPRI5: the explicit Runge-Kutta pair of Dormand & Prince (1980), order
//! 5 with an embedded order-4 error estimate, FSAL, and Shampine's
//! order-4 dense output, as in Hairer's code DOPRI5 (Hairer, Nørsett &
//! Wanner, Solving ODEs I, 2nd ed., §II.5 Table 5.2 and §II.6).

use super::Rhs;
use super::adaptive::error_norm;
use crate::error::SimError;
use crate::integrator::adaptive::{EmbeddedRk, Tolerance};

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// Dormand-Prince 5(4) with its stage and dense-output buffers.
#[derive(Debug, Clone)]
pub struct Dopri5 {
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    k5: Vec<f64>,
    k6: Vec<f64>,
    tmp: Vec<f64>,
    err: Vec<f64>,
    /// Dense output coefficients `r1..r5` (each ny), HNW's `rcont1..5`.
    cont: [Vec<f64>; 5],
}

impl EmbeddedRk for Dopri5 {
    const ORDER: u32 = 5;
    const EXPONENT: f64 = 0.2;
    const BETA: f64 = 0.04;
    const FAC_MIN: f64 = 0.2;
    const FAC_MAX: f64 = 10.0;
    const STIFF_LIMIT: f64 = 3.25;
    const DENSE_EVALS: u64 = 0;
    const STAGE_EVALS: u64 = 6;
    const FSAL_IN_ESTIMATE: bool = true;

    fn stiffness(&self, h: f64, y_new: &[f64], k_new: &[f64]) -> f64 {
        super::adaptive::stiffness_quotient(h, y_new, &self.tmp, k_new, &self.k6)
    }

    fn new(ny: usize) -> Self {
        let v = || vec![0.0; ny];
        Self { k2: v(), k3: v(), k4: v(), k5: v(), k6: v(), tmp: v(), err: v(), cont: [v(), v(), v(), v(), v()] }
    }

    fn attempt<R: Rhs>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        k1: &[f64],
        h: f64,
        tol: &Tolerance,
        y_new: &mut [f64],
        k7: &mut [f64],
    ) -> Result<f64, SimError> {
        let Self { k2, k3, k4, k5, k6, tmp, err, .. } = self;
        let n = y.len();
        // `(h a21) k1`, in that order of operations
        stage_arg!(tmp, y, h * A21, [1.0], [k1]);
        rhs.eval(t + C2 * h, tmp, k2)?;
        stage_arg!(tmp, y, h, [A31, A32], [k1, k2]);
        rhs.eval(t + C3 * h, tmp, k3)?;
        stage_arg!(tmp, y, h, [A41, A42, A43], [k1, k2, k3]);
        rhs.eval(t + C4 * h, tmp, k4)?;
        stage_arg!(tmp, y, h, [A51, A52, A53, A54], [k1, k2, k3, k4]);
        rhs.eval(t + C5 * h, tmp, k5)?;
        stage_arg!(tmp, y, h, [A61, A62, A63, A64, A65], [k1, k2, k3, k4, k5]);
        rhs.eval(t + h, tmp, k6)?;
        stage_arg!(y_new, y, h, [A71, A73, A74, A75, A76], [k1, k3, k4, k5, k6]);
        rhs.eval(t + h, y_new, k7)?;
        for i in 0..n {
            err[i] = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
        }
        Ok(error_norm(err, y, y_new, tol))
    }

    fn error_vectors(&self, _k1: &[f64], _h: f64, ea: &mut [f64], _eb: &mut [f64]) {
        ea.copy_from_slice(&self.err);
    }

    fn error_from(_h: f64, ea: &[f64], _eb: &[f64], y: &[f64], y_new: &[f64], tol: &Tolerance) -> f64 {
        error_norm(ea, y, y_new, tol)
    }

    fn prepare_dense<R: Rhs>(
        &mut self,
        _rhs: &mut R,
        _t: f64,
        y: &[f64],
        k1: &[f64],
        h: f64,
        y_new: &[f64],
        k7: &[f64],
    ) -> Result<(), SimError> {
        let Self { k3, k4, k5, k6, cont, .. } = self;
        let [r1, r2, r3, r4, r5] = cont;
        for i in 0..y.len() {
            let ydiff = y_new[i] - y[i];
            let bspl = h * k1[i] - ydiff;
            r1[i] = y[i];
            r2[i] = ydiff;
            r3[i] = bspl;
            r4[i] = ydiff - h * k7[i] - bspl;
            r5[i] = h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i] + D7 * k7[i]);
        }
        Ok(())
    }

    fn interpolate(&self, theta: f64, out: &mut [f64]) {
        let [r1, r2, r3, r4, r5] = &self.cont;
        let s1 = 1.0 - theta;
        for i in 0..out.len() {
            out[i] = r1[i] + theta * (r2[i] + s1 * (r3[i] + theta * (r4[i] + s1 * r5[i])));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::adaptive::{Controller, initial_step};
    use super::*;

    /// y' = (y1, -y0): y = (cos t, -sin t) from (1, 0).
    fn oscillator(_t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0];
    }

    fn exact(t: f64) -> [f64; 2] {
        [t.cos(), -t.sin()]
    }

    fn err_at(y: &[f64], t: f64) -> f64 {
        let e = exact(t);
        (y[0] - e[0]).abs().max((y[1] - e[1]).abs())
    }

    /// Fixed steps of size 4 / n over [0, 4]; the global error at t = 4.
    fn fixed_error(n: usize) -> f64 {
        let mut s = Dopri5::new(2);
        let mut rhs = oscillator;
        let tol = Tolerance { rtol: 1.0, atol: 1.0 };
        let h = 4.0 / n as f64;
        let (mut y, mut k1, mut y_new, mut k_new) = (vec![1.0, 0.0], vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
        oscillator(0.0, &y, &mut k1);
        for i in 0..n {
            s.attempt(&mut rhs, i as f64 * h, &y, &k1, h, &tol, &mut y_new, &mut k_new).unwrap();
            y.copy_from_slice(&y_new);
            k1.copy_from_slice(&k_new);
        }
        err_at(&y, 4.0)
    }

    #[test]
    fn converges_with_order_five() {
        let ns = [8usize, 16, 32, 64];
        let pts: Vec<(f64, f64)> = ns.iter().map(|&n| ((4.0 / n as f64).ln(), fixed_error(n).ln())).collect();
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / 4.0;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / 4.0;
        let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
            / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
        assert!((slope - 5.0).abs() <= 0.3, "fitted order {slope}");
    }

    #[test]
    fn adaptive_run_meets_its_tolerance() {
        for tolv in [1e-6, 1e-9, 1e-12] {
            let tol = Tolerance { rtol: tolv, atol: tolv };
            let mut s = Dopri5::new(2);
            let mut rhs = oscillator;
            let mut ctl = Controller::default();
            let (mut y, mut k1, mut y_new, mut k_new) = (vec![1.0, 0.0], vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
            let (mut w1, mut w2) = (vec![0.0; 2], vec![0.0; 2]);
            oscillator(0.0, &y, &mut k1);
            let mut h = initial_step(&mut rhs, 0.0, &y, &k1, 5, &tol, 10.0, &mut w1, &mut w2).unwrap();
            let (mut t, t_end) = (0.0, 10.0);
            let mut steps = 0;
            while t < t_end {
                h = h.min(t_end - t);
                let err = s.attempt(&mut rhs, t, &y, &k1, h, &tol, &mut y_new, &mut k_new).unwrap();
                let (ok, h_next) = ctl.next::<Dopri5>(err, h);
                if ok {
                    t += h;
                    y.copy_from_slice(&y_new);
                    k1.copy_from_slice(&k_new);
                    steps += 1;
                }
                h = h_next;
            }
            let e = err_at(&y, t_end);
            assert!(e <= 10.0 * tolv, "tol {tolv}: error {e} after {steps} steps");
        }
    }

    #[test]
    fn dense_output_has_order_four_inside_a_step() {
        let tol = Tolerance { rtol: 1.0, atol: 1.0 };
        let mut rhs = oscillator;
        let h = 0.2;
        let mut s = Dopri5::new(2);
        let (y, mut k1, mut y_new, mut k_new) = (vec![1.0, 0.0], vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
        oscillator(0.0, &y, &mut k1);
        s.attempt(&mut rhs, 0.0, &y, &k1, h, &tol, &mut y_new, &mut k_new).unwrap();
        s.prepare_dense(&mut rhs, 0.0, &y, &k1, h, &y_new, &k_new).unwrap();
        let mut out = vec![0.0; 2];
        s.interpolate(0.0, &mut out);
        assert_eq!(out, y);
        s.interpolate(1.0, &mut out);
        assert!((out[0] - y_new[0]).abs() < 1e-16 && (out[1] - y_new[1]).abs() < 1e-16);
        // Inside the step the interpolant is order 4: error ~ C h^5, with
        // h = 0.2: ~3e-4 * C; the exact solution has C ~ 1/120.
        for theta in [0.25, 0.5, 0.75] {
            s.interpolate(theta, &mut out);
            let e = err_at(&out, theta * h);
            assert!(e < 1e-6, "theta {theta}: dense output error {e}");
        }
        // ... and matches a step taken directly to the same time to the
        // interpolant's order: halving h shrinks the gap by ~2^5
        let mut gap = |h: f64, theta: f64| {
            let mut s = Dopri5::new(2);
            let (mut yn, mut kn, mut direct, mut kd, mut out) =
                (vec![0.0; 2], vec![0.0; 2], vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
            s.attempt(&mut rhs, 0.0, &y, &k1, h, &tol, &mut yn, &mut kn).unwrap();
            s.prepare_dense(&mut rhs, 0.0, &y, &k1, h, &yn, &kn).unwrap();
            s.interpolate(theta, &mut out);
            s.attempt(&mut rhs, 0.0, &y, &k1, theta * h, &tol, &mut direct, &mut kd).unwrap();
            (out[0] - direct[0]).abs().max((out[1] - direct[1]).abs())
        };
        for theta in [0.3, 0.6] {
            let (g1, g2) = (gap(0.4, theta), gap(0.2, theta));
            assert!(g1 < 1e-5 && g1 / g2 > 16.0, "theta {theta}: gaps {g1:e}, {g2:e}");
        }
        // and it is not just linear interpolation, whose error is ~h^2/8 = 5e-3
        let mut lin = [0.0; 2];
        for i in 0..2 {
            lin[i] = 0.5 * (y[i] + y_new[i]);
        }
        assert!(err_at(&lin, 0.1) > 1e-3);
    }
}
