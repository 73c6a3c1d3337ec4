//! Embedded explicit Runge-Kutta pairs with error control and dense output.

use super::Rhs;
use super::stepper::{Control, Stats, Stepper, Trial};
use crate::error::SimError;

/// Error tolerances: a component `i` of the local error is compared with
/// `atol + rtol * max(|y_i|, |y_new_i|)` (HNW I, eq. II.4.10).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance (units of each state component).
    pub atol: f64,
}

impl Tolerance {
    /// The scale `atol + rtol * max(|a|, |b|)` of one component.
    #[inline]
    pub fn scale(&self, a: f64, b: f64) -> f64 {
        self.atol + self.rtol * a.abs().max(b.abs())
    }
}

/// An embedded Runge-Kutta pair with dense output. Implementations own
/// their stage buffers, sized by `new`; no method allocates.
pub trait EmbeddedRk {
    /// Order of the propagated solution.
    const ORDER: u32;
    /// Exponent of the step-size controller, `1 / (q + 1)` with `q` the
    /// order the error estimate is asymptotically of (HNW I §II.4).
    const EXPONENT: f64;
    /// PI controller weight of the previous error (Gustafsson; HNW's
    /// `beta`: 0.04 in DOPRI5, 0 in DOP853).
    const BETA: f64;
    /// Bounds of the step-size change factor `h_new / h` (HNW's `fac1`, `fac2`).
    const FAC_MIN: f64;
    /// See [`EmbeddedRk::FAC_MIN`].
    const FAC_MAX: f64;

    /// The limit of `h |lambda|` in Hairer's stiffness test (DOPRI5 3.25,
    /// DOP853 6.1): about where the method's stability region ends on the
    /// negative real axis.
    const STIFF_LIMIT: f64;

    /// Buffers for a state of length `ny`.
    fn new(ny: usize) -> Self;

    /// `h |lambda|`, the estimate of Hairer's stiffness test (HW II §IV.2,
    /// the codes' `HLAMB`): `h |k_new - k_s| / |y_new - s|`, with `s` the
    /// argument of the last stage at `t + h` and `k_s` its value, which
    /// approximates the dominant eigenvalue of the Jacobian times `h`.
    /// Valid after an accepted `attempt` and before `prepare_dense`
    /// (which reuses the stage buffers), with `k_new = F(t + h, y_new)`;
    /// 0 if `y_new = s`.
    fn stiffness(&self, h: f64, y_new: &[f64], k_new: &[f64]) -> f64;

    /// Attempts a step of size `h` from `(t, y)` with `k1 = F(t, y)`.
    /// Writes the new state into `y_new` and returns the error norm
    /// (accept when <= 1). A method whose error estimate uses
    /// `F(t + h, y_new)` ([`EmbeddedRk::FSAL_IN_ESTIMATE`], DOPRI5) writes
    /// it into `k_new`; otherwise (DOP853) `k_new` is left alone and the
    /// caller evaluates `F` once the step is accepted (and projected), so
    /// a rejected step or a projected state costs no evaluation in vain.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    #[expect(
        clippy::too_many_arguments,
        reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
    )]
    fn attempt<R: Rhs>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        k1: &[f64],
        h: f64,
        tol: &Tolerance,
        y_new: &mut [f64],
        k_new: &mut [f64],
    ) -> Result<f64, SimError>;

    /// Builds the dense output of the step just accepted (`attempt`'s
    /// arguments and results); may evaluate the right-hand side.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    #[expect(
        clippy::too_many_arguments,
        reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
    )]
    fn prepare_dense<R: Rhs>(
        &mut self,
        rhs: &mut R,
        t: f64,
        y: &[f64],
        k1: &[f64],
        h: f64,
        y_new: &[f64],
        k_new: &[f64],
    ) -> Result<(), SimError>;

    /// Right-hand-side evaluations done by `prepare_dense` (0 for DOPRI5, 3 for DOP853).
    const DENSE_EVALS: u64;
    /// Right-hand-side evaluations of one `attempt` (DOPRI5 6, DOP853 11).
    const STAGE_EVALS: u64;
    /// Whether `attempt` evaluates `F(t + h, y_new)` for its error
    /// estimate (DOPRI5's `k7`); DOP853's estimate does without it.
    const FSAL_IN_ESTIMATE: bool;

    /// The error estimate of the last `attempt` as vectors (ny each,
    /// unscaled): `ea` and, for a method with a second estimator (DOP853's
    /// order-3 one), `eb` (DOPRI5 leaves it alone). Valid right after
    /// `attempt` (before `prepare_dense`), with the same `k1` and `h`.
    fn error_vectors(&self, k1: &[f64], h: f64, ea: &mut [f64], eb: &mut [f64]);

    /// The error norm `attempt` returns, from vectors of
    /// [`EmbeddedRk::error_vectors`] (perhaps changed since: see
    /// [`crate::formulation::projection::Projector::remove_normal`]).
    fn error_from(h: f64, ea: &[f64], eb: &[f64], y: &[f64], y_new: &[f64], tol: &Tolerance) -> f64;

    /// The dense output `y(t + theta h)`, `theta` in [0, 1], after `prepare_dense`.
    fn interpolate(&self, theta: f64, out: &mut [f64]);
}

/// The step-size controller of HNW's DOPRI5/DOP853 codes: a PI controller
/// with safety factor 0.9 and the change factor bounded to
/// `[FAC_MIN, FAC_MAX]`.
#[derive(Debug, Clone, Copy)]
pub struct Controller {
    err_old: f64,
    last_rejected: bool,
}

impl Default for Controller {
    fn default() -> Self {
        Self { err_old: 1e-4, last_rejected: false }
    }
}

/// Safety factor of the step-size prediction.
const SAFETY: f64 = 0.9;

impl Controller {
    /// The next step size after a step of size `h` with error norm `err`;
    /// returns `(accepted, h_next)`.
    pub fn next<E: EmbeddedRk>(&mut self, err: f64, h: f64) -> (bool, f64) {
        let expo1 = E::EXPONENT - E::BETA * 0.75;
        let fac11 = power(err.max(1e-300), expo1);
        if err <= 1.0 {
            let fac = fac11 / power(self.err_old, E::BETA);
            let fac = (fac / SAFETY).clamp(1.0 / E::FAC_MAX, 1.0 / E::FAC_MIN);
            let mut h_new = h / fac;
            if self.last_rejected {
                h_new = h_new.min(h);
            }
            self.err_old = err.max(1e-4);
            self.last_rejected = false;
            (true, h_new)
        } else {
            let h_new = h / (fac11 / SAFETY).min(1.0 / E::FAC_MIN);
            self.last_rejected = true;
            (false, h_new)
        }
    }
}

/// `x^e` for the controller's exponents (`x > 0`): 1 for 0, and for
/// DOP853's 1/8 three square roots, each correctly rounded, which agree
/// with `powf` to an ulp or two at a twentieth of its cost (a step's
/// size is a safety-factored estimate: its last bits decide nothing).
/// The exponent is a method's constant, so the choice folds away.
#[inline(always)]
fn power(x: f64, e: f64) -> f64 {
    if e == 0.0 {
        1.0
    } else if e == 0.125 {
        x.sqrt().sqrt().sqrt()
    } else {
        x.powf(e)
    }
}

/// Initial step size (HNW I §II.4, "Starting step size"; code `hinit`):
/// a step for which an explicit Euler step's estimated error matches the
/// tolerance, for a method of order `order`. Costs one evaluation.
///
/// # Errors
/// Whatever the right-hand side fails with.
#[expect(
    clippy::too_many_arguments,
    reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
)]
pub fn initial_step<R: Rhs>(
    rhs: &mut R,
    t: f64,
    y: &[f64],
    f0: &[f64],
    order: u32,
    tol: &Tolerance,
    h_max: f64,
    work: &mut [f64],
    f1: &mut [f64],
) -> Result<f64, SimError> {
    let n = y.len() as f64;
    let norm = |v: &dyn Fn(usize) -> f64| -> f64 {
        ((0..y.len()).map(|i| (v(i) / tol.scale(y[i], y[i])).powi(2)).sum::<f64>() / n).sqrt()
    };
    let d0 = norm(&|i| y[i]);
    let d1 = norm(&|i| f0[i]);
    let h0 = if d0 < 1e-5 || d1 < 1e-5 { 1e-6 } else { 0.01 * d0 / d1 };
    let h0 = h0.min(h_max);
    for i in 0..y.len() {
        work[i] = y[i] + h0 * f0[i];
    }
    rhs.eval(t + h0, work, f1)?;
    let d2 = norm(&|i| f1[i] - f0[i]) / h0;
    let dmax = d1.max(d2);
    let h1 = if dmax <= 1e-15 { (h0 * 1e-3).max(1e-6) } else { (0.01 / dmax).powf(1.0 / f64::from(order + 1)) };
    Ok((100.0 * h0).min(h1).min(h_max))
}

/// The scaled RMS norm `sqrt(mean((e_i / sc_i)^2))` of an error vector.
#[inline]
pub fn error_norm(err: &[f64], y: &[f64], y_new: &[f64], tol: &Tolerance) -> f64 {
    let sum: f64 = err.iter().zip(y).zip(y_new).map(|((e, a), b)| (e / tol.scale(*a, *b)).powi(2)).sum();
    (sum / err.len() as f64).sqrt()
}

/// `h |k - k_s| / |y - s|` (0 when `y = s`), for [`EmbeddedRk::stiffness`].
pub fn stiffness_quotient(h: f64, y: &[f64], s: &[f64], k: &[f64], k_s: &[f64]) -> f64 {
    let num: f64 = k.iter().zip(k_s).map(|(a, b)| (a - b) * (a - b)).sum();
    let den: f64 = y.iter().zip(s).map(|(a, b)| (a - b) * (a - b)).sum();
    if den > 0.0 { h.abs() * (num / den).sqrt() } else { 0.0 }
}

/// Hairer's bookkeeping of the stiffness test (DOPRI5 and DOP853): tested
/// every [`StiffnessTest::EVERY`] accepted steps, and after every step
/// while positive; stiff after 15 positive tests in a row (6 negative
/// ones reset the count).
#[derive(Debug, Clone, Copy, Default)]
pub struct StiffnessTest {
    accepted: u64,
    positive: u32,
    negative: u32,
    /// `(t [s], h |lambda|)` when the run was found stiff.
    pub found: Option<(f64, f64)>,
}

impl StiffnessTest {
    /// Hairer's `NSTIFF`.
    pub const EVERY: u64 = 1000;
    /// Positive tests in a row that make a run stiff.
    pub const POSITIVE: u32 = 15;

    /// Whether the accepted step about to be counted is tested.
    pub fn due(&self) -> bool {
        self.found.is_none() && ((self.accepted + 1).is_multiple_of(Self::EVERY) || self.positive > 0)
    }

    /// Counts an accepted step at `t` \[s\] with the test's value
    /// `hlambda` (when [`StiffnessTest::due`]); `true` the one time it
    /// finds the run stiff.
    pub fn record(&mut self, t: f64, hlambda: Option<f64>, limit: f64) -> bool {
        self.accepted += 1;
        let Some(hl) = hlambda else { return false };
        if hl > limit {
            self.negative = 0;
            self.positive += 1;
            if self.positive == Self::POSITIVE {
                self.found = Some((t, hl));
                return true;
            }
        } else {
            self.negative += 1;
            if self.negative == 6 {
                self.positive = 0;
            }
        }
        false
    }
}

/// An embedded pair `E` as a [`Stepper`]: its PI [`Controller`] on the
/// error norm (which the caller may revise first, [`Trial::Estimate`]),
/// the slope at the start carried from the accepted end (evaluated anew
/// where the caller moved the end, or where the pair's last stage was not
/// at it), Hairer's [`StiffnessTest`] and the pair's dense output.
#[derive(Debug, Clone)]
pub struct Embedded<E> {
    pair: E,
    ctl: Controller,
    tol: Tolerance,
    /// `F` at the step's start and at its end.
    k1: Vec<f64>,
    k_new: Vec<f64>,
    /// The last attempt's start \[s\] and size \[s\].
    t: f64,
    h: f64,
    dense: bool,
    stiffness: StiffnessTest,
    stage_failure: Option<SimError>,
    /// Scratch of [`initial_step`].
    work: [Vec<f64>; 2],
}

impl<E: EmbeddedRk> Embedded<E> {
    /// The pair for a state of length `n` at tolerance `tol`.
    pub fn new(n: usize, tol: Tolerance) -> Self {
        let v = || vec![0.0; n];
        Self {
            pair: E::new(n),
            ctl: Controller::default(),
            tol,
            k1: v(),
            k_new: v(),
            t: 0.0,
            h: 0.0,
            dense: false,
            stiffness: StiffnessTest::default(),
            stage_failure: None,
            work: [v(), v()],
        }
    }
}

impl<R: Rhs, E: EmbeddedRk> Stepper<R> for Embedded<E> {
    const CONTROL: Control = Control::Embedded;
    const FSAL: bool = E::FSAL_IN_ESTIMATE;

    fn start(&mut self, rhs: &mut R, t: f64, x: &[f64], h_max: f64) -> Result<f64, SimError> {
        rhs.eval(t, x, &mut self.k1)?;
        let [w1, w2] = &mut self.work;
        initial_step(rhs, t, x, &self.k1, E::ORDER, &self.tol, h_max, w1, w2)
    }

    /// A stage that overflowed, or at which an effect or the reduced
    /// formulation's Newton iteration failed (perhaps the stage went too
    /// far: a stiff scene at a step beyond the method's stability), and a
    /// non-finite error estimate reject the step for a tenth of its size;
    /// the failure is kept ([`Stepper::stage_failure`]) and reported if no
    /// step helps.
    #[inline]
    fn attempt(&mut self, rhs: &mut R, t: f64, x: &[f64], h: f64, x_new: &mut [f64]) -> Result<Trial, SimError> {
        self.t = t;
        self.h = h;
        self.dense = false;
        let err = match self.pair.attempt(rhs, t, x, &self.k1, h, &self.tol, x_new, &mut self.k_new) {
            Err(SimError::Kkt { source: crate::error::KktError::NonFinite { .. }, .. }) => f64::NAN,
            Err(e @ (SimError::EffectFailed { .. } | SimError::Formulation { .. })) => {
                self.stage_failure = Some(e);
                f64::NAN
            }
            other => other?,
        };
        if err.is_finite() { Ok(Trial::Estimate(err)) } else { Ok(Trial::Rejected { h_next: h * 0.1 }) }
    }

    fn control(&mut self, err: f64) -> (bool, f64) {
        self.ctl.next::<E>(err, self.h)
    }

    fn revise_error(
        &self,
        x: &[f64],
        x_new: &[f64],
        ea: &mut [f64],
        eb: &mut [f64],
        mut remove: impl FnMut(&mut [f64]) -> Result<(), SimError>,
    ) -> Result<Option<f64>, SimError> {
        self.pair.error_vectors(&self.k1, self.h, ea, eb);
        remove(ea)?;
        remove(eb)?;
        Ok(Some(E::error_from(self.h, ea, eb, x, x_new, &self.tol)))
    }

    #[inline]
    fn accepted(
        &mut self,
        rhs: &mut R,
        t_new: f64,
        x_new: &[f64],
        moved: bool,
        _slope: bool,
    ) -> Result<bool, SimError> {
        let evaluate = moved || !E::FSAL_IN_ESTIMATE;
        if evaluate {
            rhs.eval(t_new, x_new, &mut self.k_new)?;
        }
        self.stage_failure = None;
        Ok(evaluate)
    }

    fn end_slope(&self) -> &[f64] {
        &self.k_new
    }

    #[inline]
    fn test_stiffness(&mut self, t_new: f64, x_new: &[f64]) -> Option<(f64, f64, f64)> {
        let hlambda = self.stiffness.due().then(|| self.pair.stiffness(self.h, x_new, &self.k_new));
        if self.stiffness.record(t_new, hlambda, E::STIFF_LIMIT) {
            return self.stiffness.found.map(|(t, hl)| (t, hl, E::STIFF_LIMIT));
        }
        None
    }

    fn dense_ready(&self) -> bool {
        self.dense
    }

    fn prepare_dense(&mut self, rhs: &mut R, _t_new: f64, x: &[f64], x_new: &[f64]) -> Result<(), SimError> {
        if !self.dense {
            self.pair.prepare_dense(rhs, self.t, x, &self.k1, self.h, x_new, &self.k_new)?;
            self.dense = true;
        }
        Ok(())
    }

    #[inline]
    fn interpolate(&self, t: f64, out: &mut [f64]) {
        self.pair.interpolate((t - self.t) / self.h, out);
    }

    /// The slope at the new state; the controller keeps its memory.
    fn restart(&mut self, rhs: &mut R, t: f64, x: &[f64]) -> Result<(), SimError> {
        rhs.eval(t, x, &mut self.k_new)
    }

    #[inline]
    fn advance(&mut self, _rhs: &mut R, _t: f64, _x: &[f64]) -> Result<(), SimError> {
        std::mem::swap(&mut self.k1, &mut self.k_new);
        Ok(())
    }

    fn stage_failure(&mut self) -> &mut Option<SimError> {
        &mut self.stage_failure
    }

    fn stats(&self) -> Stats {
        Stats { newton: Default::default(), stiff: self.stiffness.found }
    }
}

/// The end of an integration by [`integrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Endpoint {
    /// `y(t_end)`.
    pub y: Vec<f64>,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts.
    pub rejected: u64,
}

/// Integrates `y' = F(t, y)` from `(t0, y0)` to exactly `t_end` with the
/// embedded pair `E` and its PI controller, without projection or output:
/// the generic interface for plain ODEs, such as the variational equations
/// of [`crate::analysis`] (HNW I §II.4 for the step control, §I.14 for
/// integrating the variational equations with the same error control as
/// the state). At most `max_steps` attempted steps.
///
/// # Errors
/// Whatever `F` fails with; [`SimError::StepSizeTooSmall`] when the step
/// falls below rounding; [`SimError::Budget`] after `max_steps` attempts.
pub fn integrate<E: EmbeddedRk, R: Rhs>(
    rhs: &mut R,
    t0: f64,
    y0: &[f64],
    t_end: f64,
    tol: &Tolerance,
    max_steps: u64,
) -> Result<Endpoint, SimError> {
    let n = y0.len();
    let mut stepper = E::new(n);
    let mut ctrl = Controller::default();
    let (mut y, mut y_new, mut k1, mut k_new) = (y0.to_vec(), vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut w1, mut w2) = (vec![0.0; n], vec![0.0; n]);
    rhs.eval(t0, &y, &mut k1)?;
    let mut h = initial_step(rhs, t0, &y, &k1, E::ORDER, tol, t_end - t0, &mut w1, &mut w2)?;
    let (mut t, mut steps, mut rejected) = (t0, 0u64, 0u64);
    while t < t_end {
        if steps + rejected >= max_steps {
            // the steps the whole interval would take at the rate so far
            let done = (t - t0) / (t_end - t0);
            let estimate = if done > 0.0 { (max_steps as f64 / done).ceil() } else { max_steps as f64 };
            return Err(SimError::Budget {
                what: "steps",
                estimate,
                limit: max_steps as f64,
                setting: crate::settings::Setting::MaxSteps,
                detail: format!("reached at t = {t} s, before t = {t_end} s"),
            });
        }
        let last = t + h >= t_end;
        let h_try = if last { t_end - t } else { h };
        if h_try <= 16.0 * f64::EPSILON * t.abs().max(1e-300) {
            return Err(SimError::StepSizeTooSmall { t, h: h_try });
        }
        let err = stepper.attempt(rhs, t, &y, &k1, h_try, tol, &mut y_new, &mut k_new)?;
        let (accepted, h_next) = ctrl.next::<E>(if err.is_finite() { err } else { 1e10 }, h_try);
        if accepted {
            t = if last { t_end } else { t + h_try };
            y.copy_from_slice(&y_new);
            if E::FSAL_IN_ESTIMATE {
                k1.copy_from_slice(&k_new);
            } else {
                rhs.eval(t, &y, &mut k1)?;
            }
            steps += 1;
        } else {
            rejected += 1;
        }
        h = h_next;
    }
    Ok(Endpoint { y, steps, rejected })
}
