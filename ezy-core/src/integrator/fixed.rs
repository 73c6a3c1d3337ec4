//! Fixed-step methods: explicit Euler (order 1, the baseline) and classic
//! RK4 (order 4; Hairer, Nørsett & Wanner, Solving ODEs I, §II.1, Table 1.2),
//! the default of the built-in scenes.

use super::Rhs;
use super::stepper::{Control, Stats, Stepper, Trial};
use crate::error::SimError;

/// Explicit Euler, `y <- y + h F(t, y)`: one evaluation per step.
#[derive(Debug, Clone)]
pub struct Euler {
    k: Vec<f64>,
}

impl Euler {
    /// Buffers for a state of length `ny`.
    pub fn new(ny: usize) -> Self {
        Self { k: vec![0.0; ny] }
    }

    /// Advances `y` from `t` to `t + h`.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    #[inline]
    pub fn step<R: Rhs + ?Sized>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError> {
        rhs.eval(t, y, &mut self.k)?;
        for (yi, ki) in y.iter_mut().zip(&self.k) {
            *yi += h * ki;
        }
        Ok(())
    }

    /// As [`Euler::step`], from `y` into `y_new`.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    #[inline]
    pub fn step_to<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        rhs.eval(t, y, &mut self.k)?;
        self.update(y, h, y_new);
        Ok(())
    }

    /// As [`Euler::step_to`], with the slope at the start `f0 = F(t, y)`
    /// already known (no evaluation).
    pub fn step_from_to(&mut self, y: &[f64], h: f64, f0: &[f64], y_new: &mut [f64]) {
        self.k.copy_from_slice(f0);
        self.update(y, h, y_new);
    }

    /// `y_new = y + h k`.
    #[inline(always)]
    fn update(&self, y: &[f64], h: f64, y_new: &mut [f64]) {
        for ((yn, yi), ki) in y_new.iter_mut().zip(y).zip(&self.k) {
            *yn = yi + h * ki;
        }
    }

    /// `F(t, y)` at the start of the last step (its slope).
    pub fn start_slope(&self) -> &[f64] {
        &self.k
    }
}

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
    /// Whatever the right-hand side fails with.
    #[inline]
    pub fn step<R: Rhs + ?Sized>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError> {
        rhs.eval(t, y, &mut self.k1)?;
        self.stages(rhs, t, y, h)
    }

    /// As [`Rk4::step`], from `y` into `y_new`.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    #[inline]
    pub fn step_to<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        rhs.eval(t, y, &mut self.k1)?;
        self.slopes(rhs, t, y, h)?;
        self.update_to(y, h, y_new);
        Ok(())
    }

    /// As [`Rk4::step_to`], with the first stage `f0 = F(t, y)` already
    /// known (three evaluations): a run that evaluated `F` at the end of
    /// the last step (for a skate's switch) hands it on.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    pub fn step_from_to<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        f0: &[f64],
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        self.k1.copy_from_slice(f0);
        self.slopes(rhs, t, y, h)?;
        self.update_to(y, h, y_new);
        Ok(())
    }

    /// The stages after the first (in `k1`) and the update in place.
    #[inline(always)]
    fn stages<R: Rhs + ?Sized>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError> {
        self.slopes(rhs, t, y, h)?;
        let h6 = h / 6.0;
        let n = y.len();
        let Self { k1, k2, k3, k4, .. } = self;
        let (k1, k2, k3, k4) = (&k1[..n], &k2[..n], &k3[..n], &k4[..n]);
        for i in 0..n {
            y[i] += h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        }
        Ok(())
    }

    /// The stages after the first (in `k1`): `k2`, `k3`, `k4`.
    #[inline(always)]
    fn slopes<R: Rhs + ?Sized>(&mut self, rhs: &mut R, t: f64, y: &[f64], h: f64) -> Result<(), SimError> {
        let Self { k1, k2, k3, k4, tmp } = self;
        axpy(tmp, y, 0.5 * h, k1);
        rhs.eval(t + 0.5 * h, tmp, k2)?;
        axpy(tmp, y, 0.5 * h, k2);
        rhs.eval(t + 0.5 * h, tmp, k3)?;
        axpy(tmp, y, h, k3);
        rhs.eval(t + h, tmp, k4)
    }

    /// `y_new = y + h/6 (k1 + 2 (k2 + k3) + k4)`, as the update in place
    /// computes it.
    #[inline(always)]
    fn update_to(&self, y: &[f64], h: f64, y_new: &mut [f64]) {
        let h6 = h / 6.0;
        let n = y.len();
        let (k1, k2, k3, k4, y_new) = (&self.k1[..n], &self.k2[..n], &self.k3[..n], &self.k4[..n], &mut y_new[..n]);
        for i in 0..n {
            y_new[i] = y[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        }
    }

    /// `F(t, y)` at the start of the last step (its first stage).
    pub fn start_slope(&self) -> &[f64] {
        &self.k1
    }
}

/// A fixed-step method as [`Fixed`] drives it: Euler or RK4.
pub trait FixedMethod {
    /// Advances `y` from `t` to `t + h` into `y_new`.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn advance<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), SimError>;
    /// As [`FixedMethod::advance`], with `f0 = F(t, y)` known.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn advance_from<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        f0: &[f64],
        y_new: &mut [f64],
    ) -> Result<(), SimError>;
    /// `F` at the start of the last step.
    fn start_slope(&self) -> &[f64];
}

impl FixedMethod for Euler {
    #[inline]
    fn advance<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        self.step_to(rhs, t, y, h, y_new)
    }
    fn advance_from<R: Rhs + ?Sized>(
        &mut self,
        _: &mut R,
        _: f64,
        y: &[f64],
        h: f64,
        f0: &[f64],
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        self.step_from_to(y, h, f0, y_new);
        Ok(())
    }
    fn start_slope(&self) -> &[f64] {
        Euler::start_slope(self)
    }
}

impl FixedMethod for Rk4 {
    #[inline]
    fn advance<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        self.step_to(rhs, t, y, h, y_new)
    }
    fn advance_from<R: Rhs + ?Sized>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        h: f64,
        f0: &[f64],
        y_new: &mut [f64],
    ) -> Result<(), SimError> {
        self.step_from_to(rhs, t, y, h, f0, y_new)
    }
    fn start_slope(&self) -> &[f64] {
        Rk4::start_slope(self)
    }
}

/// A fixed-step method as a [`Stepper`]: every attempt accepted, the
/// slope at the accepted end carried to the next step's first stage
/// where the caller asked for it ([`Stepper::accepted`] with `slope`),
/// and the dense output the cubic [`hermite`] interpolant on the step's
/// ends and slopes.
#[derive(Debug, Clone)]
pub struct Fixed<S> {
    method: S,
    /// The slope at the start of the next step, when `carried`.
    f_start: Vec<f64>,
    carried: bool,
    /// `F` at the accepted end; whether it is (`end_known`), and whether
    /// it goes on to the next step (`carry`).
    f_end: Vec<f64>,
    end_known: bool,
    carry: bool,
    /// The last step's ends `(t0, x0)`, `(t1, x1)` for the interpolant,
    /// copied when it is prepared (`dense`).
    t0: f64,
    t1: f64,
    x0: Vec<f64>,
    x1: Vec<f64>,
    dense: bool,
    /// Never set: a fixed step has no failure to keep.
    stage_failure: Option<SimError>,
}

impl<S: FixedMethod> Fixed<S> {
    /// `method` for a state of length `n`.
    pub fn new(method: S, n: usize) -> Self {
        let v = || vec![0.0; n];
        Self {
            method,
            f_start: v(),
            carried: false,
            f_end: v(),
            end_known: false,
            carry: false,
            t0: 0.0,
            t1: 0.0,
            x0: v(),
            x1: v(),
            dense: false,
            stage_failure: None,
        }
    }
}

impl<R: Rhs + ?Sized, S: FixedMethod> Stepper<R> for Fixed<S> {
    const CONTROL: Control = Control::Fixed;
    const FSAL: bool = false;

    fn start(&mut self, _rhs: &mut R, _t: f64, _x: &[f64], h_max: f64) -> Result<f64, SimError> {
        Ok(h_max)
    }

    #[inline]
    fn attempt(&mut self, rhs: &mut R, t: f64, x: &[f64], h: f64, x_new: &mut [f64]) -> Result<Trial, SimError> {
        let advanced = if self.carried {
            self.method.advance_from(rhs, t, x, h, &self.f_start, x_new)
        } else {
            self.method.advance(rhs, t, x, h, x_new)
        };
        self.carried = false;
        self.end_known = false;
        self.carry = false;
        self.dense = false;
        self.t0 = t;
        advanced?;
        Ok(Trial::Accepted { h_next: h })
    }

    fn control(&mut self, _err: f64) -> (bool, f64) {
        (true, self.t1 - self.t0)
    }

    #[inline]
    fn accepted(
        &mut self,
        rhs: &mut R,
        t_new: f64,
        x_new: &[f64],
        _moved: bool,
        slope: bool,
    ) -> Result<bool, SimError> {
        if !slope {
            return Ok(false);
        }
        rhs.eval(t_new, x_new, &mut self.f_end)?;
        self.end_known = true;
        self.carry = true;
        Ok(true)
    }

    fn end_slope(&self) -> &[f64] {
        &self.f_end
    }

    fn dense_ready(&self) -> bool {
        self.dense
    }

    #[cold]
    fn prepare_dense(&mut self, rhs: &mut R, t_new: f64, x: &[f64], x_new: &[f64]) -> Result<(), SimError> {
        if self.dense {
            return Ok(());
        }
        if !self.end_known {
            rhs.eval(t_new, x_new, &mut self.f_end)?;
            self.end_known = true;
        }
        self.t1 = t_new;
        self.x0.copy_from_slice(x);
        self.x1.copy_from_slice(x_new);
        self.dense = true;
        Ok(())
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        hermite((self.t0, &self.x0, self.method.start_slope()), (self.t1, &self.x1, &self.f_end), t, out);
    }

    fn restart(&mut self, _rhs: &mut R, _t: f64, _x: &[f64]) -> Result<(), SimError> {
        self.carry = false;
        Ok(())
    }

    #[inline]
    fn advance(&mut self, _rhs: &mut R, _t: f64, _x: &[f64]) -> Result<(), SimError> {
        if self.carry {
            std::mem::swap(&mut self.f_start, &mut self.f_end);
            self.carried = true;
        }
        self.carry = false;
        Ok(())
    }

    fn stage_failure(&mut self) -> &mut Option<SimError> {
        &mut self.stage_failure
    }

    fn stats(&self) -> Stats {
        Stats::default()
    }
}

/// The cubic Hermite interpolant of a step from `(t0, y0, f0)` (time
/// \[s\], state, slope) to `(t1, y1, f1)` at `t` into `out`: the continuous
/// extension of order 3 of a fixed-step method (Hairer, Nørsett & Wanner,
/// Solving ODEs I, §II.6), exact at both ends and for cubics.
pub fn hermite((t0, y0, f0): (f64, &[f64], &[f64]), (t1, y1, f1): (f64, &[f64], &[f64]), t: f64, out: &mut [f64]) {
    let h = t1 - t0;
    let s = (t - t0) / h;
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
    for i in 0..out.len() {
        out[i] = h00 * y0[i] + h * h10 * f0[i] + h01 * y1[i] + h * h11 * f1[i];
    }
}

/// `out = y + a k`.
#[inline(always)]
fn axpy(out: &mut [f64], y: &[f64], a: f64, k: &[f64]) {
    for ((o, &yi), &ki) in out.iter_mut().zip(y).zip(k) {
        *o = yi + a * ki;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y' = (y1, -y0) from (1, 0): y = (cos t, -sin t).
    fn oscillator(_t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -y[0];
    }

    type Osc = fn(f64, &[f64], &mut [f64]);

    /// Fitted slope of log(error at t = 4) against log(h), n steps each.
    fn fitted_order(ns: &[usize], mut step: impl FnMut(&mut Osc, f64, &mut [f64], f64)) -> f64 {
        let pts: Vec<(f64, f64)> = ns
            .iter()
            .map(|&n| {
                let h = 4.0 / n as f64;
                let mut y = [1.0, 0.0];
                let mut rhs: Osc = oscillator;
                for i in 0..n {
                    step(&mut rhs, i as f64 * h, &mut y, h);
                }
                let e = (y[0] - 4f64.cos()).abs().max((y[1] + 4f64.sin()).abs());
                (h.ln(), e.ln())
            })
            .collect();
        let k = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / k;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / k;
        pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
    }

    #[test]
    fn hermite_is_exact_for_cubics() {
        let y = |t: f64| [t * t * t - 2.0 * t + 1.0, 0.5 * t * t];
        let f = |t: f64| [3.0 * t * t - 2.0, t];
        let (t0, t1) = (0.3, 1.1);
        let mut out = [0.0; 2];
        for t in [0.3, 0.5, 0.77, 1.1] {
            hermite((t0, &y(t0), &f(t0)), (t1, &y(t1), &f(t1)), t, &mut out);
            for (a, b) in out.iter().zip(y(t)) {
                assert!((a - b).abs() < 1e-15, "{t}: {a} {b}");
            }
        }
    }

    #[test]
    fn euler_has_order_one() {
        let mut e = Euler::new(2);
        let p = fitted_order(&[400, 800, 1600, 3200], |rhs, t, y, h| e.step(rhs, t, y, h).unwrap());
        assert!((p - 1.0).abs() <= 0.3, "Euler fitted order {p}");
    }

    #[test]
    fn rk4_has_order_four() {
        let mut r = Rk4::new(2);
        let p = fitted_order(&[16, 32, 64, 128], |rhs, t, y, h| r.step(rhs, t, y, h).unwrap());
        assert!((p - 4.0).abs() <= 0.3, "RK4 fitted order {p}");
    }
}
