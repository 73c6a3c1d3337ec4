//! The step loop of a sensitivity run: the augmented system `[x, S]`
//! stepped by the problem's method through the simulation's
//! [`Stepper`] (the same steppers, chosen by the same
//! [`with_stepper!`]), the state projected after each step and `S` with
//! it, samples at the output interval or the times asked for. What the
//! simulation's driver does besides (events, a skate's switches, the
//! hand-over between formulations) a sensitivity run refuses before its
//! first step.

use super::rhs::Augmented;
use super::stencil::Stencil;
use super::{MAX_PARAMETERS, Parameter, Sensitivities};
use crate::analysis::AnalysisError;
use crate::error::SimError;
use crate::formulation::projection::Projector;
use crate::integrator::adaptive::Tolerance;
use crate::integrator::radau5::{DenseNewton, Radau5Stepper};
use crate::integrator::stepper::{Control, Stepper, Trial};
use crate::integrator::with_stepper;
use crate::model::Model;
use crate::problem::Problem;
use crate::settings::{Formulation, Method, ProjectionKind, RunSettings};

fn request(reason: String) -> AnalysisError {
    AnalysisError::Request { reason }
}

/// Most states `2 nq (1 + np)` a sensitivity run takes with RADAU5: its
/// simplified Newton iteration factors the augmented system's Jacobian
/// dense (real and complex LU, `O(n^3)` each, its forward differences
/// `n` evaluations of the augmented right-hand side), as
/// [`crate::kkt::DENSE_LU_MAX_ROWS`] bounds the KKT matrix's LU (24 MB
/// of matrices at 1000 states).
pub(crate) const RADAU5_MAX_STATES: usize = 1000;

/// Refuses what a sensitivity run does not take, before any work.
fn check_request<M: Model>(problem: &Problem<M>, params: &[Parameter<M>]) -> Result<(), AnalysisError> {
    if params.is_empty() {
        return Err(request("no parameters to differentiate with respect to: name at least one".into()));
    }
    if params.len() > MAX_PARAMETERS {
        return Err(request(format!(
            "{} parameters: a sensitivity run takes at most {MAX_PARAMETERS} (its state has 2 nq (1 + np) values)",
            params.len()
        )));
    }
    for (k, p) in params.iter().enumerate() {
        if params[..k].iter().any(|o| o.name == p.name) {
            return Err(request(format!("parameter `{}` is named twice", p.name)));
        }
        if !p.value.is_finite() {
            return Err(request(format!("parameter `{}` is {}: not a number to differentiate at", p.name, p.value)));
        }
    }
    let s = &problem.settings;
    if s.formulation == Formulation::Reduced {
        return Err(request(
            "sensitivities are integrated on the DAE formulation only: the reduced formulation's steps (on its independent coordinates, the dependent ones recovered from the constraints) are not differentiated yet, and the DAE's sensitivities would be another run's; set the formulation to `dae` or `auto`".into(),
        ));
    }
    if s.method == Method::Radau5 {
        let n = 2 * problem.model.info().nq() * (1 + params.len());
        if n > RADAU5_MAX_STATES {
            return Err(request(format!(
                "radau5 solves its Newton systems on the state and its sensitivities together, dense: 2 nq (1 + np) = {n} states, more than the {RADAU5_MAX_STATES} it takes; choose dop853 (or fewer parameters)"
            )));
        }
    }
    if problem.baumgarte.is_some() {
        return Err(request(
            "sensitivities are integrated with coordinate projection, not Baumgarte stabilization (whose terms would need their own derivative): remove --baumgarte".into(),
        ));
    }
    if let Some(e) = problem.events.first() {
        return Err(request(format!(
            "event `{}`: a run with events is not differentiated (where an event's time moves with a parameter the motion jumps); remove the events",
            e.name
        )));
    }
    Ok(())
}

/// Refuses sample times that are not finite, negative, unsorted (each
/// after the one before) or none, naming the first at fault.
fn check_times(times: &[f64]) -> Result<(), AnalysisError> {
    if times.is_empty() {
        return Err(request("no sample times".into()));
    }
    for (k, &t) in times.iter().enumerate() {
        if !(t.is_finite() && t >= 0.0) {
            return Err(request(format!("sample time {} is {t}: times are finite and >= 0 [s]", k + 1)));
        }
        if k > 0 && t <= times[k - 1] {
            return Err(request(format!(
                "sample time {} ({t} s) is not after the one before ({} s): give the times sorted, each once",
                k + 1,
                times[k - 1]
            )));
        }
    }
    if times.last().is_some_and(|&t| t == 0.0) {
        return Err(request("the sample times end at 0 s: nothing to integrate".into()));
    }
    Ok(())
}

/// The sensitivity run of `problem` with respect to `params`.
pub(super) fn sensitivities<M: Model>(
    problem: &Problem<M>,
    params: &[Parameter<M>],
    stop: Option<fn() -> bool>,
    times: Option<&[f64]>,
) -> Result<Sensitivities, AnalysisError> {
    check_request(problem, params)?;
    let mut settings = problem.settings;
    if let Some(times) = times {
        check_times(times)?;
        settings.t_end = times.last().copied().unwrap_or(0.0);
    }
    settings.validate().map_err(AnalysisError::Sim)?;
    let (mut base, x0) = problem.clone().analysis()?;
    base.check_size()?;
    let n2 = x0.len();
    let np = params.len();
    let rows = times.map_or_else(|| settings.output_rows(), |t| t.len() as f64);
    let mb = rows * (8.0 * (n2 * (1 + np)) as f64 + 40.0) / 1e6;
    if mb.is_nan() || mb > problem.max_output_mb {
        return Err(AnalysisError::Sim(SimError::Budget {
            what: "MB of samples in memory",
            estimate: mb,
            limit: problem.max_output_mb,
            setting: crate::settings::Setting::MaxOutputMb,
            detail: format!("{rows:.2e} samples of {} values", n2 * (1 + np)),
        }));
    }
    let stencils = params.iter().map(|p| Stencil::new(p, &base, &x0)).collect::<Result<Vec<_>, _>>()?;
    let mut y0 = x0.clone();
    for st in &stencils {
        y0.extend_from_slice(&st.x0);
    }
    let derivatives = stencils.iter().map(|s| s.derivative).collect();
    base.watch_grip();
    // a start on which a skate with friction slides (its lateral slip
    // velocity not zero: the run would follow a slide first)
    base.point(0.0, &x0)?;
    base.check_grip("this run")?;
    let sys = base.dynamics();
    let projector = Projector::new(&sys.model, settings.projection, &sys.mass).with_drives(&sys.drives);
    let names = base.state_names();
    let aug = Augmented::new(base, stencils, stop);
    let params_names = params.iter().map(|p| p.name.clone()).collect();
    let times = times.map(<[f64]>::to_vec);
    let listed = times.is_some();
    let mut lp =
        Loop { aug, projector, settings, out: Vec::new(), steps: 0, rejected: 0, n2, params: params_names, times };
    lp.project(0.0, &mut y0)?;
    lp.check_finite(0.0, &y0)?;
    if !listed || lp.out_time(0) == 0.0 {
        lp.out.push((0.0, y0.clone()));
    }
    let tol = Tolerance { rtol: settings.rtol, atol: settings.atol };
    let n = y0.len();
    let result = with_stepper!(settings.method, n, tol, |s| lp.steps(&y0, s), radau5 => {
        lp.steps(&y0, &mut Radau5Stepper::new(n, &tol, DenseNewton::new(n)))
    });
    if let Err(e) = result {
        let e = lp.aug.failed.take().unwrap_or(e);
        return Err(e);
    }
    lp.aug.base.check_grip("this run")?;
    let Loop { aug, out, steps, rejected, .. } = lp;
    let (t, (x, s)) = out.into_iter().map(|(t, y)| (t, (y[..n2].to_vec(), y[n2..].to_vec()))).unzip();
    Ok(Sensitivities {
        t,
        names,
        parameters: params.iter().map(|p| p.name.clone()).collect(),
        values: params.iter().map(|p| p.value).collect(),
        derivatives,
        x,
        s,
        steps,
        rejected,
        evaluations: aug.evaluations,
    })
}

/// The KKT conditioning estimate at which a sensitivity run stops at a
/// singular position: a distance of about 1e-4 (relative) from it, where
/// the run's own criterion ([`crate::formulation::dae::NEAR_SINGULAR`],
/// 1e3) starts its care; away from singular positions the built-in
/// scenes stay below 1.1e2.
pub(crate) const SINGULAR_GROWTH: f64 = 1e8;

struct Loop<M: Model> {
    aug: Augmented<M>,
    projector: Projector<M>,
    settings: RunSettings,
    out: Vec<(f64, Vec<f64>)>,
    steps: u64,
    rejected: u64,
    n2: usize,
    /// The parameters' names.
    params: Vec<String>,
    /// The sample times asked for (sorted, in `[0, t_end]`, the last
    /// `t_end`); `None`: every output interval and the end.
    times: Option<Vec<f64>>,
}

impl<M: Model> Loop<M> {
    /// Projects the state of `y` at `t` onto the constraints and its
    /// sensitivities onto their tangent space.
    fn project(&mut self, t: f64, y: &mut [f64]) -> Result<(), AnalysisError> {
        if self.settings.projection == ProjectionKind::None {
            return Ok(());
        }
        let n2 = self.n2;
        let (x, s) = y.split_at_mut(n2);
        let s = &mut s[..self.params.len() * n2];
        let (q, qd) = x.split_at_mut(n2 / 2);
        self.projector.project(&self.aug.base.dynamics().model, t, q, qd)?;
        self.aug.project(&mut self.projector, t, x, s)
    }

    /// Refuses a step that came to a singular position: the KKT
    /// conditioning estimate, which grows like `1 / s^2` at a distance `s`
    /// from one, past [`SINGULAR_GROWTH`] at the step's end or at any of
    /// its stages (reset before each attempt). An adaptive run would creep
    /// towards the position in ever smaller steps (the N-four-bar: 108 s
    /// before the step fell to rounding); a fixed step jumps over it, and
    /// with a stage that close its sensitivities were off by 2e-6 of
    /// their size (`four-bar-n2` with RK4 at `dt = 1e-4`: stage growth
    /// 1.2e9), where a stage no closer than 1.8e6 (`dt = 1e-3`) leaves
    /// them the discrete run's derivatives to 1.5e-9. The ordinary run
    /// passes singular positions by its own means.
    fn check_singular(&self, t: f64) -> Result<(), AnalysisError> {
        let sys = self.aug.base.dynamics();
        let growth = sys.last_growth.max(sys.max_growth);
        if growth < SINGULAR_GROWTH {
            return Ok(());
        }
        Err(request(format!(
            "at t = {} s the run comes to a singular position (the constraint rows lose rank: KKT conditioning estimate {growth:.1e}); a sensitivity run does not pass singular positions yet (the ordinary run does): end it before (--t-end)",
            crate::names::fmt_value(t)
        )))
    }

    /// Refuses a state or sensitivity that is not finite at `t` (a fixed
    /// step would carry it into the output), naming it.
    fn check_finite(&self, t: f64, y: &[f64]) -> Result<(), AnalysisError> {
        let Some(k) = y.iter().position(|v| !v.is_finite()) else { return Ok(()) };
        let names = self.aug.base.state_names();
        let n2 = self.n2;
        let what = if k < n2 {
            format!("the state's `{}`", names[k])
        } else {
            format!("the sensitivity d{}/d{}", names[(k - n2) % n2], self.params[(k - n2) / n2])
        };
        Err(AnalysisError::Numerics {
            reason: format!(
                "at t = {} s {what} became {}: the run or its sensitivity diverges; take a smaller step or a parameter value nearer the scene's",
                crate::names::fmt_value(t),
                y[k]
            ),
        })
    }

    fn budget(&self, t: f64) -> Result<(), AnalysisError> {
        let limit = self.settings.max_steps.unwrap_or(u64::MAX);
        if self.steps + self.rejected >= limit {
            return Err(AnalysisError::Sim(SimError::Budget {
                what: "steps",
                estimate: limit as f64,
                limit: limit as f64,
                setting: crate::settings::Setting::MaxSteps,
                detail: format!("reached at t = {t} s, before t = {} s", self.settings.t_end),
            }));
        }
        Ok(())
    }

    /// The end of the fixed step from `t`, the `k`-th, and whether its
    /// state is a sample: steps of `dt` on the output grid (the last one
    /// shorter, a sample every output stride and at the end), or steps of
    /// at most `dt` that end at each time asked for.
    fn fixed_target(&self, t: f64, k: u64, next_out: u64) -> (f64, bool) {
        let s = self.settings;
        if self.times.is_some() {
            let target = self.out_time(next_out);
            return if target - t <= s.dt * (1.0 + 1e-12) { (target, true) } else { (t + s.dt, false) };
        }
        let n = (s.t_end / s.dt).ceil().max(1.0) as u64;
        let last = k + 1 == n;
        let t_new = if last { s.t_end } else { (k + 1) as f64 * s.dt };
        (t_new, last || (k + 1).is_multiple_of(s.output_stride()))
    }

    /// The step loop of `stepper` (the simulation's [`Stepper`], on the
    /// augmented state): each accepted state projected with its
    /// sensitivities and checked, samples at the fixed steps' ends or
    /// from an adaptive method's dense output (built on the projected
    /// end, as the simulation's are), and the end.
    fn steps<S: Stepper<Augmented<M>>>(&mut self, y0: &[f64], stepper: &mut S) -> Result<(), AnalysisError> {
        let s = self.settings;
        let fixed = S::CONTROL == Control::Fixed;
        let n = y0.len();
        let (mut y, mut y_new, mut dense) = (y0.to_vec(), vec![0.0; n], vec![0.0; n]);
        let mut h = stepper.start(&mut self.aug, 0.0, &y, s.t_end)?;
        let (mut t, mut k) = (0.0, 0);
        let mut next_out = u64::from(self.out_time(0) == 0.0);
        while t < s.t_end {
            self.budget(t)?;
            if self.aug.stop.is_some_and(|stop| stop()) {
                return Err(AnalysisError::Stopped);
            }
            let (t_new, h_try, sample) = if fixed {
                let (t_new, sample) = self.fixed_target(t, k, next_out);
                (t_new, t_new - t, sample)
            } else if t + h >= s.t_end {
                (s.t_end, s.t_end - t, false)
            } else {
                (t + h, h, false)
            };
            if h_try <= 16.0 * f64::EPSILON * t.abs().max(1e-300) {
                let failure = stepper.stage_failure().take();
                return Err(AnalysisError::Sim(failure.unwrap_or(SimError::StepSizeTooSmall { t, h: h_try })));
            }
            self.aug.base.dynamics_mut().max_growth = 0.0;
            let (accepted, h_next) = match stepper.attempt(&mut self.aug, t, &y, h_try, &mut y_new)? {
                Trial::Accepted { h_next } => (true, h_next),
                Trial::Rejected { h_next } => (false, h_next),
                Trial::Estimate(err) => stepper.control(err),
            };
            h = h_next;
            if !accepted {
                self.rejected += 1;
                continue;
            }
            self.project(t_new, &mut y_new)?;
            self.check_finite(t_new, &y_new)?;
            stepper.accepted(&mut self.aug, t_new, &y_new, true, false)?;
            // samples strictly inside an adaptive step, from its dense output
            while !fixed && self.out_time(next_out) < t_new.min(s.t_end) {
                stepper.prepare_dense(&mut self.aug, t_new, &y, &y_new)?;
                stepper.interpolate(self.out_time(next_out), &mut dense);
                self.out.push((self.out_time(next_out), dense.clone()));
                next_out += 1;
            }
            std::mem::swap(&mut y, &mut y_new);
            t = t_new;
            (self.steps, k) = (self.steps + 1, k + 1);
            let on_grid = !fixed && (self.out_time(next_out) - t).abs() <= 1e-12 * t.abs().max(1.0) && t < s.t_end;
            if sample || on_grid {
                self.out.push((t, y.clone()));
                next_out += 1;
            }
            stepper.advance(&mut self.aug, t, &y)?;
            self.check_singular(t)?;
        }
        if !fixed && (self.times.is_none() || self.out_time(next_out) == s.t_end) {
            self.out.push((s.t_end, y.clone()));
        }
        Ok(())
    }

    /// Sample `k`'s time \[s\]: `k every` on the output grid, or the
    /// `k`-th of the times asked for (infinite past the last).
    fn out_time(&self, k: u64) -> f64 {
        match &self.times {
            None => k as f64 * self.settings.every,
            Some(times) => usize::try_from(k).ok().and_then(|k| times.get(k)).copied().unwrap_or(f64::INFINITY),
        }
    }
}
