//! Gaits of mixed (and dynamic) systems: a [`FourierGait`] prescribed
//! through a model's drives, its coefficients the parameters of a
//! [`Design`], so that [`crate::design::optimize::optimize`] finds the
//! gait that maximizes or minimizes a gait's quantity per cycle (mean
//! forward speed, displacement, heading change, mean input power,
//! efficiency: [`crate::design::optimize::GaitQuantity`]) over them.
//!
//! # Method
//!
//! A kinematic system's net motion per cycle is a function of the
//! shape's curve alone ([`super::optimize_gait`]); a mixed system's is
//! not: its momentum moves with the cycle's timing and with its losses,
//! so each point of the search is the simulated gait, the periodic orbit
//! of the full dynamics (the momentum included) with the drives' angles
//! prescribed (rheonomic constraints, [`crate::drive`]), found by
//! shooting at phase 0 of the forcing. The gradient is exact: the
//! implicit function theorem on the orbit's shooting equations
//! ([`crate::Problem::gait_sensitivities`]), each coefficient's direct effect on the
//! right-hand side exact too, because each coefficient is the amplitude
//! of one harmonic of fixed frequency and phase (see [`drive_angle`]),
//! which the sensitivities differentiate in closed form
//! ([`crate::effects::Waveform::eval3_toward`]): linear in it, no
//! difference of waveforms. The search, its scaling, its KKT check and
//! its failures are [`crate::design::optimize`]'s.
//!
//! The parameterization is [`FourierGait`]'s (Ramasamy & Hatton, "The
//! geometry of optimal gaits for drag-dominated kinematic systems", IEEE
//! T-RO 35(4), 2019, §V), one series per drive; the orbit's
//! sensitivities are Seydel's shooting (*Practical Bifurcation and
//! Stability Analysis*, 3rd ed., §7.1-7.3) differentiated by the implicit
//! function theorem.
//!
//! The coefficients are bounded each within its own interval (a box:
//! the design's bounds), which bounds the shape's range over the cycle
//! loosely (`|r - a_0| <= sum_k hypot(a_k, b_k)`; for an order-1 gait
//! with `b_1` held at 0, `a_1` is the amplitude); [`DriveGait::range`]
//! bounds it at samples of the cycle, constraints linear in the
//! coefficients that SLSQP holds at each step (as
//! [`super::GaitOptimization::bounds`] does for a kinematic gait). A gait's phase is
//! a symmetry of its mean quantities (a gait shifted in time moves as
//! far, along another heading), so a search over every coefficient has a
//! valley of optima; hold one (`b_1` at 0) to fix it.
//!
//! The search locates an optimum by its values to about the square root
//! of their accuracy, by its gradients to theirs: the settings of
//! [`DriveGait::optimize_settings`] find the gait to 1e-12 and polish
//! SLSQP's answer by Newton's method on the exact gradients
//! ([`OptimizeSettings::polish`]), so that the projected gradient at a
//! bounded optimum falls below 1e-8 of the objective (1.2e-10 on the
//! EzyRoller with rolling resistance; SLSQP alone left 2.2e-9 there, and
//! 3.9e-8 where the optimum is interior; 1.9e-5 with the gait found to
//! the default 1e-9).

use super::fourier::{FourierGait, basis};
use crate::analysis::AnalysisError;
use crate::design::Design;
use crate::design::optimize::OptimizeSettings;
use crate::design::optimize::quantity::{Constraint, Quantity};
use crate::effects::waveform::{Harmonic, Periodicity, Waveform};
use crate::error::SimError;
use crate::model::Model;
use crate::problem::Problem;

/// Most samples of a drive's range ([`DriveGait::range`]).
pub const MAX_SAMPLES: usize = 1000;

/// A Fourier gait of a model's drives (one row of coefficients per drive,
/// [`FourierGait::coefficients`]) with the coefficients to optimize and
/// their bounds: the parameters of a [`Design`] ([`DriveGait::design`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DriveGait {
    /// The drives (the model's `drive NAME: hinge H;`), one per row of
    /// the gait, in its order.
    pub drives: Vec<String>,
    /// The start, and the values of the coefficients held \[rad\].
    pub start: FourierGait,
    /// Per flat coefficient ([`FourierGait::flat`]): `Some((lower,
    /// upper))` \[rad\] where it is free within these bounds, `None` where
    /// it is held at the start's value.
    pub bounds: Vec<Option<(f64, f64)>>,
}

impl DriveGait {
    /// The gait `start` of the drives `drives` (one row each), every
    /// coefficient held: free them with [`DriveGait::free`].
    pub fn new(drives: &[&str], start: FourierGait) -> Self {
        let n = start.n_shape() * start.per_coordinate();
        Self { drives: drives.iter().map(|d| (*d).to_string()).collect(), start, bounds: vec![None; n] }
    }

    /// Frees the coefficient `label` (`D.a0`, `D.a1`, `D.b2`: the drive's
    /// name, then the coefficient's as [`FourierGait::coefficient_label`]
    /// spells it) within `[lower, upper]` \[rad\].
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a label that names no coefficient of
    /// the gait (listing them).
    pub fn free(mut self, label: &str, lower: f64, upper: f64) -> Result<Self, AnalysisError> {
        let labels = self.labels();
        match labels.iter().position(|l| l == label) {
            Some(j) => {
                self.bounds[j] = Some((lower, upper));
                Ok(self)
            }
            None => Err(AnalysisError::Request {
                reason: format!(
                    "`{label}` is not a coefficient of this gait; its coefficients are {}",
                    crate::names::name_list(&labels)
                ),
            }),
        }
    }

    /// The settings of a search over a drive gait: the defaults of
    /// [`OptimizeSettings`] with the gait found to 1e-12 (DOP853 at
    /// `rtol = atol = 1e-12`, Newton to 1e-12: the quantities then agree
    /// with themselves to about 1e-12 of their size, 1e-9 at the
    /// defaults) and the polish on (the module's docs). Measured on the
    /// EzyRoller: 14 evaluations, 0.7 s.
    pub fn optimize_settings() -> OptimizeSettings {
        let mut s = OptimizeSettings { polish: true, ..OptimizeSettings::default() };
        s.periodic.tolerance.rtol = 1e-12;
        s.periodic.tolerance.atol = 1e-12;
        s.periodic.newton_tolerance = 1e-12;
        s
    }

    /// Bounds on drive `drive`'s angle over the cycle, `lower <= u(t_n) <=
    /// upper` \[rad\] at `samples` times `t_n = n T / samples` (`n = 0 ..
    /// samples - 1`), two constraints per sample for
    /// [`crate::design::optimize::Goal::constraints`], each linear in the
    /// free coefficients (a [`Quantity::Values`] named `D(t = 0.5 s)`):
    /// the shape's range, which the coefficients' own bounds bound only
    /// loosely beyond order 1. Between two samples `dt` apart the angle may
    /// pass a bound by up to `|u''| dt^2 / 8`. Give the free coefficients
    /// first ([`DriveGait::free`]): the constraints take the design's
    /// parameters as they are then.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a drive not among the gait's
    /// (listing them), bounds that are not finite or a lower bound not
    /// below the upper, a number of samples outside 1 to
    /// [`MAX_SAMPLES`], no free coefficient.
    pub fn range(&self, drive: &str, lower: f64, upper: f64, samples: usize) -> Result<Vec<Constraint>, AnalysisError> {
        let fail = |reason: String| Err(AnalysisError::Request { reason });
        let Some(row) = self.drives.iter().position(|d| d == drive) else {
            return fail(format!(
                "`{drive}` is not a drive of this gait; its drives are {}",
                crate::names::name_list(&self.drives)
            ));
        };
        if !(lower.is_finite() && upper.is_finite() && lower < upper) {
            return fail(format!(
                "the range {lower}:{upper} of drive `{drive}`: the bounds must be finite, the lower below the upper"
            ));
        }
        if !(1..=MAX_SAMPLES).contains(&samples) {
            return fail(format!("{samples} samples of drive `{drive}`'s range: give 1 to {MAX_SAMPLES}"));
        }
        let free: Vec<usize> = (0..self.bounds.len()).filter(|&j| self.bounds[j].is_some()).collect();
        if free.is_empty() {
            return fail("every coefficient of the gait is held: free them before bounding the range".into());
        }
        let (per, omega, flat) = (self.start.per_coordinate(), self.start.omega(), self.start.flat());
        let mut out = Vec::with_capacity(2 * samples);
        for n in 0..samples {
            let t = n as f64 * self.start.period / samples as f64;
            let (free, flat) = (free.clone(), flat.clone());
            let angle = Quantity::values(format!("{drive}(t = {} s)", crate::names::fmt_value(t)), move |v| {
                let mut c = flat.clone();
                for (&j, &x) in free.iter().zip(v) {
                    c[j] = x;
                }
                let u = (0..per).map(|j| c[row * per + j] * basis(j, omega, t).0).sum();
                let du = free.iter().map(|&j| if j / per == row { basis(j % per, omega, t).0 } else { 0.0 }).collect();
                (u, du)
            });
            out.push(Constraint { quantity: angle.clone(), upper: true, bound: upper });
            out.push(Constraint { quantity: angle, upper: false, bound: lower });
        }
        Ok(out)
    }

    /// Every coefficient's label, in the flat order: `D.a0, D.a1, D.b1,
    /// ...` (n_drives x (2 order + 1)).
    pub fn labels(&self) -> Vec<String> {
        let n = self.start.n_shape() * self.start.per_coordinate();
        (0..n).map(|j| self.start.coefficient_label(&self.drives, j)).collect()
    }

    /// The gait at the free coefficients' values `values` (in the order of
    /// the design's parameters: the free ones in the flat order), the held
    /// ones at the start's.
    ///
    /// # Panics
    /// If `values` has another length than the free coefficients.
    pub fn gait_at(&self, values: &[f64]) -> FourierGait {
        let free: Vec<usize> = (0..self.bounds.len()).filter(|&j| self.bounds[j].is_some()).collect();
        assert_eq!(values.len(), free.len(), "one value per free coefficient");
        let mut flat = self.start.flat();
        for (&j, &v) in free.iter().zip(values) {
            flat[j] = v;
        }
        self.start.with_flat(&flat)
    }

    /// The design over the free coefficients: each problem is `build`'s
    /// (the model, its start, effects and settings) with the drives'
    /// angles prescribed as the gait at the coefficients' values
    /// ([`drive_angle`]), whatever angle `build` gave them. The
    /// parameters are named by their labels (`D.a1`), start at the
    /// start's values, within their bounds.
    ///
    /// # Errors
    /// `build`'s own failure. [`AnalysisError::Request`] for a model
    /// without drives (a mixed system's gait is prescribed through them:
    /// `drive D: hinge B;` in the model), a drive the model does not have
    /// (listing its drives) or named twice, a gait of another number of
    /// rows than drives or whose fields [`FourierGait::new`] refuses, a
    /// `bounds` of another length than the coefficients, no free
    /// coefficient, a start that does not repeat with the gait's period
    /// (no first harmonic: every `a_1`, `b_1` zero), and what
    /// [`Design::new`] refuses (a bound that is not finite, a lower bound
    /// not below its upper, a start outside its bounds), each naming the
    /// coefficient.
    ///
    /// A gait is sought over its drives' common period: where every
    /// first-harmonic coefficient is 0 at once (bounds that reach 0) the
    /// angles repeat faster, and the gait there is sought over a shorter
    /// period (its quantities per period change with it); bound an
    /// amplitude away from 0 to keep the period (`D.a1` within `[0.05,
    /// 0.4]`).
    pub fn design<M: Model>(
        &self,
        build: impl Fn() -> Result<Problem<M>, SimError> + Send + Sync + 'static,
    ) -> Result<Design<M>, AnalysisError> {
        let fail = |reason: String| Err(AnalysisError::Request { reason });
        let base = build()?;
        let info = base.model.info();
        let known: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
        if known.is_empty() {
            return fail(format!(
                "model {} has no drives: a gait of a mixed system is prescribed through its drives (`drive D: hinge B;` in the model), and it has none to optimize",
                info.name
            ));
        }
        for (k, d) in self.drives.iter().enumerate() {
            if !known.contains(&d.as_str()) {
                return fail(format!(
                    "model {} has no drive `{d}`; its drives are {}",
                    info.name,
                    crate::names::name_list(&known)
                ));
            }
            if self.drives[..k].contains(d) {
                return fail(format!("drive `{d}` is named twice: give one row of coefficients per drive"));
            }
        }
        let start = &self.start;
        if start.n_shape() != self.drives.len() {
            return fail(format!(
                "the gait has {} rows of coefficients for {} drives ({}): give one row per drive",
                start.n_shape(),
                self.drives.len(),
                self.drives.join(", ")
            ));
        }
        // the fields are public: the gait's own checks again
        FourierGait::new(start.coefficients.clone(), start.order, start.period)
            .map_err(|e| AnalysisError::Request { reason: e.to_string() })?;
        let labels = self.labels();
        if self.bounds.len() != labels.len() {
            return fail(format!(
                "`bounds` has {} entries for the gait's {} coefficients ({})",
                self.bounds.len(),
                labels.len(),
                labels.join(", ")
            ));
        }
        let free: Vec<usize> = (0..labels.len()).filter(|&j| self.bounds[j].is_some()).collect();
        if free.is_empty() {
            return fail(format!(
                "every coefficient of the gait is held: nothing to optimize (free one of {})",
                labels.join(", ")
            ));
        }
        let flat = start.flat();
        check_period(start, &self.drives)?;
        let names = free.iter().map(|&j| labels[j].clone()).collect();
        let values = free.iter().map(|&j| flat[j]).collect();
        let bounds = free.iter().map(|&j| self.bounds[j].expect("free")).collect();
        let (drives, order, omega) = (self.drives.clone(), start.order, start.omega());
        let per = start.per_coordinate();
        Design::new(names, values, bounds, move |v| {
            let mut c = flat.clone();
            for (&j, &x) in free.iter().zip(v) {
                c[j] = x;
            }
            drives
                .iter()
                .zip(c.chunks(per))
                .try_fold(build()?, |p, (d, row)| p.drive(d, drive_angle(row, order, omega)))
        })
    }
}

/// Refuses a start whose drives' angles do not repeat with the gait's
/// period `T` (their forcing's period is `T / k`, or they are constant).
fn check_period(start: &FourierGait, drives: &[String]) -> Result<(), AnalysisError> {
    let (order, omega, per) = (start.order, start.omega(), start.per_coordinate());
    let parts = start.flat().chunks(per).map(|row| drive_angle(row, order, omega).periodicity()).collect::<Vec<_>>();
    let forcing = Periodicity::combine(parts);
    if forcing.whole_periods(start.period) == Some(1.0) {
        return Ok(());
    }
    let repeats = match forcing {
        Periodicity::Period(t) => format!("repeat every {} s", crate::names::fmt_value(t)),
        _ => "never change".into(),
    };
    Err(AnalysisError::Request {
        reason: format!(
            "the start gait's angles of {} {repeats}, not with its period {} s: give a first harmonic (a nonzero `a1` or `b1`)",
            drives.join(", "),
            crate::names::fmt_value(start.period)
        ),
    })
}

/// The prescribed angle of one row of a Fourier gait's coefficients
/// `row` (`a_0, a_1, b_1, ..., a_N, b_N` \[rad\], `N = order`) at the
/// angular frequency `omega` \[rad/s\]: `u(t) = a_0 + sum_k (a_k cos(k
/// omega t) + b_k sin(k omega t))`, as the harmonics `a_0 cos(0)`, `a_k
/// cos(k omega t)` and `b_k cos(k omega t - pi/2)`, each coefficient the
/// amplitude of its own harmonic of fixed frequency and phase (one
/// harmonic each, a zero amplitude kept), so that the waveform's
/// structure is the same at every value and linear in each coefficient:
/// what the sensitivities' linearization between neighbouring problems
/// ([`Waveform::eval3_toward`]) takes exactly. (The polar form of
/// [`FourierGait::gait`], `R_k cos(k omega t + phi_k)`, is nonlinear in
/// the coefficients and drops a harmonic whose amplitude is zero.)
///
/// # Panics
/// If `row` has another length than `2 order + 1`.
pub fn drive_angle(row: &[f64], order: usize, omega: f64) -> Waveform {
    assert_eq!(row.len(), 2 * order + 1, "2 order + 1 coefficients");
    let harmonic = |amplitude: f64, omega: f64, phase: f64| Harmonic { amplitude, omega, phase, phase_step: 0.0 };
    let mut h = vec![harmonic(row[0], 0.0, 0.0)];
    for k in 1..=order {
        let w = k as f64 * omega;
        h.push(harmonic(row[2 * k - 1], w, 0.0));
        h.push(harmonic(row[2 * k], w, -std::f64::consts::FRAC_PI_2));
    }
    Waveform::Harmonics(h)
}
