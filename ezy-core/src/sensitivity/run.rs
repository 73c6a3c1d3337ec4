//! The step loop of a sensitivity run: the augmented system `[x, S]`
//! stepped by the problem's method through the simulation's
//! [`Stepper`] (the same steppers, chosen by the same
//! [`with_stepper!`]), the state projected after each step and `S` with
//! it, samples at the output interval or the times asked for. What the
//! simulation's driver does besides (events, a skate's switches, the
//! hand-over between formulations) a sensitivity run refuses before its
//! first step.

use super::reduced::ReducedAugmented;
use super::rhs::Augmented;
use super::stencil::Stencil;
use super::{MAX_PARAMETERS, Parameter, Sensitivities};
use crate::analysis::AnalysisError;
use crate::error::SimError;
use crate::formulation::dae::NEAR_SINGULAR;
use crate::formulation::projection::Projector;
use crate::integrator::adaptive::Tolerance;
use crate::integrator::radau5::{DenseNewton, Radau5Stepper};
use crate::integrator::stepper::{Control, Stepper, Trial};
use crate::integrator::{Rhs, with_stepper};
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
    let params_names: Vec<String> = params.iter().map(|p| p.name.clone()).collect();
    let names = base.state_names();
    let reduced = settings.formulation == Formulation::Reduced;
    let sys = base.dynamics();
    let projector = Projector::new(&sys.model, settings.projection, &sys.mass).with_drives(&sys.drives);
    let aug = Augmented::new(base, stencils, stop);
    let times = times.map(<[f64]>::to_vec);
    let out = if reduced {
        let sys = ReducedAugmented::new(aug, &x0)?;
        let mut w0 = vec![0.0; sys.len()];
        sys.gather(&y0, &mut w0);
        Loop::new(sys, settings, params_names, times).run(w0)?
    } else {
        let sys = Projected { aug, projector, projection: settings.projection };
        Loop::new(sys, settings, params_names, times).run(y0)?
    };
    let Outcome { out, steps, rejected, evaluations, repartitions } = out;
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
        evaluations,
        formulation: if reduced { Formulation::Reduced } else { Formulation::Dae },
        repartitions,
    })
}

/// The KKT conditioning estimate at which a sensitivity run stops at a
/// singular position: a distance of about 1e-4 (relative) from it, where
/// the run's own criterion ([`crate::formulation::dae::NEAR_SINGULAR`],
/// 1e3) starts its care; away from singular positions the built-in
/// scenes stay below 1.1e2.
pub(crate) const SINGULAR_GROWTH: f64 = 1e8;

/// What the step loop integrates: `[x, S]` on the DAE, projected after
/// each step ([`Projected`]), or `[z, S_z]` on the reduced formulation
/// ([`ReducedAugmented`]).
trait Integrand<M: Model>: Rhs {
    fn augmented(&mut self) -> &mut Augmented<M>;
    /// Keeps the accepted `y` at `t` on the constraints (the DAE's
    /// projection; the reduced state is on them).
    fn project(&mut self, t: f64, y: &mut [f64]) -> Result<(), AnalysisError>;
    /// After the accepted `y`'s samples: a new partition, `y` rewritten
    /// in it; returns whether the method restarts.
    fn repartition(&mut self, t: f64, y: &mut [f64]) -> Result<bool, AnalysisError>;
    /// The sample `y` at `t` as `[x, S]` (2 nq (1 + np)).
    fn full(&mut self, t: f64, y: &[f64]) -> Result<Vec<f64>, AnalysisError>;
    /// Component `k` of `y` in words, the parameters named `params`.
    fn component(&self, k: usize, params: &[String]) -> String;
    /// Refuses an attempt from `t` that the run would not make on this
    /// formulation (none on the DAE).
    fn check_attempt(&self, _t: f64) -> Result<(), AnalysisError> {
        Ok(())
    }
    /// Times the partition was re-chosen (none on the DAE).
    fn repartitions(&self) -> u64 {
        0
    }
}

/// `[x, S]` on the DAE with the run's projection.
struct Projected<M: Model> {
    aug: Augmented<M>,
    projector: Projector<M>,
    projection: ProjectionKind,
}

impl<M: Model> Rhs for Projected<M> {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.aug.eval(t, y, dy)
    }
}

impl<M: Model> Integrand<M> for Projected<M> {
    fn augmented(&mut self) -> &mut Augmented<M> {
        &mut self.aug
    }
    /// Projects the state of `y` at `t` onto the constraints and its
    /// sensitivities onto their tangent space.
    fn project(&mut self, t: f64, y: &mut [f64]) -> Result<(), AnalysisError> {
        if self.projection == ProjectionKind::None {
            return Ok(());
        }
        let n2 = 2 * self.aug.nq();
        let (x, s) = y.split_at_mut(n2);
        let s = &mut s[..self.aug.stencils.len() * n2];
        let (q, qd) = x.split_at_mut(n2 / 2);
        self.projector.project(&self.aug.base.dynamics().model, t, q, qd)?;
        self.aug.project(&mut self.projector, t, x, s)
    }
    fn repartition(&mut self, _: f64, _: &mut [f64]) -> Result<bool, AnalysisError> {
        Ok(false)
    }
    fn full(&mut self, _: f64, y: &[f64]) -> Result<Vec<f64>, AnalysisError> {
        Ok(y.to_vec())
    }
    fn component(&self, k: usize, params: &[String]) -> String {
        let names = self.aug.base.state_names();
        let n2 = names.len();
        if k < n2 {
            format!("the state's `{}`", names[k])
        } else {
            format!("the sensitivity d{}/d{}", names[(k - n2) % n2], params[(k - n2) / n2])
        }
    }
}

impl<M: Model> Integrand<M> for ReducedAugmented<M> {
    fn augmented(&mut self) -> &mut Augmented<M> {
        &mut self.aug
    }
    fn project(&mut self, _: f64, _: &mut [f64]) -> Result<(), AnalysisError> {
        Ok(())
    }
    fn repartition(&mut self, t: f64, y: &mut [f64]) -> Result<bool, AnalysisError> {
        ReducedAugmented::repartition(self, t, y)
    }
    fn full(&mut self, t: f64, y: &[f64]) -> Result<Vec<f64>, AnalysisError> {
        self.expand(t, y)?;
        Ok(ReducedAugmented::full(self).to_vec())
    }
    fn component(&self, k: usize, params: &[String]) -> String {
        ReducedAugmented::component(self, k, params)
    }
    fn repartitions(&self) -> u64 {
        ReducedAugmented::repartitions(self)
    }
    /// An attempt that came near a singular position (the KKT
    /// conditioning past [`NEAR_SINGULAR`] at a stage), where the reduced
    /// run hands over to the DAE (`crate::simulate`): the sensitivities
    /// would be of another run from there.
    fn check_attempt(&self, t: f64) -> Result<(), AnalysisError> {
        let growth = self.aug.base.dynamics().max_growth;
        if growth <= NEAR_SINGULAR {
            return Ok(());
        }
        Err(request(format!(
            "at t = {} s the reduced run comes near a singular position (KKT conditioning estimate {growth:.1e}), where its dependent coordinates are not determined and the run hands over to the DAE; its sensitivities do not follow the hand-over: take --formulation dae, or end the run before (--t-end)",
            crate::names::fmt_value(t)
        )))
    }
}

/// What a [`Loop::run`] ends with.
struct Outcome {
    /// The samples `(t, [x, S])`.
    out: Vec<(f64, Vec<f64>)>,
    steps: u64,
    rejected: u64,
    evaluations: u64,
    repartitions: u64,
}

struct Loop<M: Model, R: Integrand<M>> {
    sys: R,
    settings: RunSettings,
    out: Vec<(f64, Vec<f64>)>,
    steps: u64,
    rejected: u64,
    /// The parameters' names.
    params: Vec<String>,
    /// The sample times asked for (sorted, in `[0, t_end]`, the last
    /// `t_end`); `None`: every output interval and the end.
    times: Option<Vec<f64>>,
    _model: std::marker::PhantomData<M>,
}

impl<M: Model, R: Integrand<M>> Loop<M, R> {
    /// The loop of `sys` at `settings`, its parameters named `params`,
    /// sampled at `times` (or the output interval's).
    fn new(sys: R, settings: RunSettings, params: Vec<String>, times: Option<Vec<f64>>) -> Self {
        Self { sys, settings, out: Vec::new(), steps: 0, rejected: 0, params, times, _model: std::marker::PhantomData }
    }

    /// The run from `y0` by the problem's method: its samples.
    fn run(mut self, mut y0: Vec<f64>) -> Result<Outcome, AnalysisError> {
        let settings = self.settings;
        let listed = self.times.is_some();
        self.sys.project(0.0, &mut y0)?;
        self.check_finite(0.0, &y0)?;
        if !listed || self.out_time(0) == 0.0 {
            let full = self.sys.full(0.0, &y0)?;
            self.out.push((0.0, full));
        }
        let tol = Tolerance { rtol: settings.rtol, atol: settings.atol };
        let n = y0.len();
        let result = with_stepper!(settings.method, n, tol, |s| self.steps(&y0, s), radau5 => {
            self.steps(&y0, &mut Radau5Stepper::new(n, &tol, DenseNewton::new(n)))
        });
        if let Err(e) = result {
            return Err(self.sys.augmented().failed.take().unwrap_or(e));
        }
        self.sys.augmented().base.check_grip("this run")?;
        Ok(Outcome {
            evaluations: self.sys.augmented().evaluations,
            repartitions: self.sys.repartitions(),
            out: self.out,
            steps: self.steps,
            rejected: self.rejected,
        })
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
    fn check_singular(&mut self, t: f64) -> Result<(), AnalysisError> {
        let sys = self.sys.augmented().base.dynamics();
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
        let what = self.sys.component(k, &self.params);
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
    fn steps<S: Stepper<R>>(&mut self, y0: &[f64], stepper: &mut S) -> Result<(), AnalysisError> {
        let s = self.settings;
        let fixed = S::CONTROL == Control::Fixed;
        let n = y0.len();
        let (mut y, mut y_new, mut dense) = (y0.to_vec(), vec![0.0; n], vec![0.0; n]);
        let mut h = stepper.start(&mut self.sys, 0.0, &y, s.t_end)?;
        let (mut t, mut k) = (0.0, 0);
        let mut next_out = u64::from(self.out_time(0) == 0.0);
        while t < s.t_end {
            self.budget(t)?;
            if self.sys.augmented().stop.is_some_and(|stop| stop()) {
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
            self.sys.augmented().base.dynamics_mut().max_growth = 0.0;
            let (accepted, h_next) = match stepper.attempt(&mut self.sys, t, &y, h_try, &mut y_new)? {
                Trial::Accepted { h_next } => (true, h_next),
                Trial::Rejected { h_next } => (false, h_next),
                Trial::Estimate(err) => stepper.control(err),
            };
            self.sys.check_attempt(t)?;
            h = h_next;
            if !accepted {
                self.rejected += 1;
                continue;
            }
            self.sys.project(t_new, &mut y_new)?;
            self.check_finite(t_new, &y_new)?;
            stepper.accepted(&mut self.sys, t_new, &y_new, true, false)?;
            // samples strictly inside an adaptive step, from its dense output
            while !fixed && self.out_time(next_out) < t_new.min(s.t_end) {
                stepper.prepare_dense(&mut self.sys, t_new, &y, &y_new)?;
                stepper.interpolate(self.out_time(next_out), &mut dense);
                let tau = self.out_time(next_out);
                let full = self.sys.full(tau, &dense)?;
                self.out.push((tau, full));
                next_out += 1;
            }
            std::mem::swap(&mut y, &mut y_new);
            t = t_new;
            (self.steps, k) = (self.steps + 1, k + 1);
            let on_grid = !fixed && (self.out_time(next_out) - t).abs() <= 1e-12 * t.abs().max(1.0) && t < s.t_end;
            if sample || on_grid {
                let full = self.sys.full(t, &y)?;
                self.out.push((t, full));
                next_out += 1;
            }
            // a new partition restarts the method from the same state
            if self.sys.repartition(t, &mut y)? {
                stepper.restart(&mut self.sys, t, &y)?;
            }
            stepper.advance(&mut self.sys, t, &y)?;
            self.check_singular(t)?;
        }
        if !fixed && (self.times.is_none() || self.out_time(next_out) == s.t_end) {
            let full = self.sys.full(s.t_end, &y)?;
            self.out.push((s.t_end, full));
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
