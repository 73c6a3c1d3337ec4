//! The step loop, written once for every method ([`drive`]): a
//! [`Stepper`] attempts each step; the loop decides on it (the singular
//! positions' guard, [`judge`]), accepts it (projection, energy guard:
//! [`Integrand::accept`]), cuts it at a skate's switch or a switching
//! event, locates the events inside it, writes the outputs its
//! [`Schedule`] puts there, switches the run and hands it over to the
//! other formulation where a switch says so, and restarts the method.
//! The loop is generic over the stepper and the formulation: each of
//! their pairs is a copy of its own, with no dynamic call in it.

use crate::error::SimError;
use crate::formulation::dae::{Dynamics, NEAR_SINGULAR};
use crate::formulation::newton::KktNewton;
use crate::integrator::adaptive::Tolerance;
use crate::integrator::radau5::Radau5Stepper;
use crate::integrator::stepper::{Control, Stepper, Trial};
use crate::model::Model;
use crate::settings::{Formulation, Message, ProjectionKind, Setting};
use crate::simulate::events::Crossing;
use crate::simulate::integrand::{Bound, Integrand};
use crate::simulate::observer::{Observer, RunError, stiff_note};
use crate::simulate::run::Run;

/// A step size collapsed by this factor near a singular position, against
/// the last step taken away from it, stops an adaptive run with
/// [`SimError::SingularTolerance`] (see [`judge`]).
const SINGULAR_COLLAPSE: f64 = 1e-4;
/// Ratio of the KKT conditioning at a step's end to that at its start
/// above which (and above [`NEAR_SINGULAR`] at the end) the step is halved
/// (see [`judge`]).
const SINGULAR_LANDING: f64 = 1e4;

/// The step loop of the run's method on the formulation `form` from `x`
/// (left holding the last accepted state).
///
/// # Errors
/// As [`drive`]; RADAU5 on the reduced formulation is refused
/// ([`radau5_refused`]).
pub(super) fn integrate<M: Model, O: Observer<M>, F: Integrand<M>>(
    sys: &mut Dynamics<M>,
    form: &mut F,
    x: &mut [f64],
    run: &mut Run<'_, M, O>,
) -> Result<(), RunError<O::Error>> {
    let n = x.len();
    run.event_x.resize(n, 0.0);
    let tol = Tolerance { rtol: run.settings.rtol, atol: run.settings.atol };
    crate::integrator::with_stepper!(run.settings.method, n, tol, |s| drive(sys, form, x, run, s), radau5 => match form.as_dae() {
        Some(dae) => {
            let newton = KktNewton::new(sys);
            drive(sys, dae, x, run, &mut Radau5Stepper::new(n, &tol, newton))
        }
        None => Err(radau5_refused().into()),
    })
}

/// RADAU5 refused on the reduced formulation.
pub(super) fn radau5_refused() -> SimError {
    SimError::Formulation {
        reason: Message::text("RADAU5's Newton iteration is built on the DAE's KKT matrix; take ")
            .setting(Setting::Formulation(Formulation::Dae))
            .then(" or an explicit method"),
    }
}

/// The states the loop holds: a step's start `x` and end `x_new`, and
/// scratch.
struct States {
    x: Vec<f64>,
    x_new: Vec<f64>,
    /// A state on the step's continuous extension.
    scratch: Vec<f64>,
    /// The error vectors of an attempt near a singular position.
    ea: Vec<f64>,
    eb: Vec<f64>,
}

/// The step loop of `stepper` on `form` from `x0` at `run.t_start` to
/// the run's end, or to the hand-over, the stop or the failure that ends
/// it first; `x0` is left holding the last accepted state.
///
/// # Errors
/// [`RunError::Sim`] as the right-hand side, the projection, the guards,
/// the events and the switches fail; [`RunError::Output`] when the
/// observer stops the run.
pub(super) fn drive<M, O, F, S>(
    sys: &mut Dynamics<M>,
    form: &mut F,
    x0: &mut [f64],
    run: &mut Run<'_, M, O>,
    stepper: &mut S,
) -> Result<(), RunError<O::Error>>
where
    M: Model,
    O: Observer<M>,
    F: Integrand<M>,
    S: for<'b> Stepper<Bound<'b, M, F>>,
{
    let n = x0.len();
    let v = || vec![0.0; n];
    let mut states = States { x: x0.to_vec(), x_new: v(), scratch: v(), ea: Vec::new(), eb: Vec::new() };
    let result = steps(sys, form, &mut states, run, stepper);
    x0.copy_from_slice(&states.x);
    run.newton = stepper.stats().newton;
    result
}

/// What the singular positions' guard keeps from step to step.
struct SingularGuard {
    /// The last step size accepted away from a singular position \[s\]
    /// (the first one until then).
    h_far: f64,
    /// The KKT conditioning at the step's start (see [`SINGULAR_LANDING`]).
    start_growth: f64,
}

/// The loop of [`drive`].
fn steps<M, O, F, S>(
    sys: &mut Dynamics<M>,
    form: &mut F,
    st: &mut States,
    run: &mut Run<'_, M, O>,
    stepper: &mut S,
) -> Result<(), RunError<O::Error>>
where
    M: Model,
    O: Observer<M>,
    F: Integrand<M>,
    S: for<'b> Stepper<Bound<'b, M, F>>,
{
    let settings = run.settings;
    let (mut sched, mut t) = Schedule::new(S::CONTROL, run);
    // the accepted state is evaluated anew unless the last stage was it
    form.lean_stages(!S::FSAL);
    let mut h = stepper.start(&mut Bound { sys, form }, t, &st.x, settings.t_end - t)?;
    let mut guard = SingularGuard { h_far: h, start_growth: sys.last_growth };
    // skates with friction or switch events: the slope at a step's end is
    // read for their margins (a fixed step carries it to the next one)
    let switches = sys.switches();
    while sched.running(t) {
        let target = sched.target(run, sys, S::CONTROL, stepper.stage_failure(), t, &mut h)?;
        let trial = stepper.attempt(&mut Bound { sys, form }, t, &st.x, target.h, &mut st.x_new)?;
        let mut h_next = match judge(sys, form, run, stepper, &mut guard, st, t, &target, trial)? {
            Decision::Accept(h_next) => h_next,
            Decision::Reject(h_next) => {
                run.summary.rejected += 1;
                h = h_next;
                // a signal stops a run that rejects step after step too
                run.observer.poll(t).map_err(RunError::Output)?;
                continue;
            }
        };
        // the accepted state, projected, and the slope there
        let mut t_new = target.t_new;
        let moved = form.accept(run, sys, t, t_new, &mut st.x_new, target.h_nominal, S::FSAL)?;
        let fresh = stepper.accepted(&mut Bound { sys, form }, t_new, &st.x_new, moved, switches)?;
        guard.start_growth = sys.last_growth;
        if let Some((t_stiff, hl, limit)) = stepper.test_stiffness(t_new, &st.x_new) {
            run.summary.stiff = Some((t_stiff, hl));
            run.observer.note(&stiff_note(settings.method, t_stiff, hl, limit));
        }
        // a skate's switch or a switching event cuts the step there (its
        // state from the dense output, accepted as the step's end and
        // counted with the step it cuts); the method restarts from it
        // (Hairer, Nørsett & Wanner I, §II.6)
        let evaluated = (fresh && form.solves_kkt()).then(|| stepper.end_slope());
        let slipped = switches && run.slip_crossed(sys, t_new, form.accepted_full(&st.x_new), evaluated)?;
        if slipped {
            stepper.prepare_dense(&mut Bound { sys, form }, t_new, &st.x, &st.x_new)?;
            let x = &mut st.scratch;
            let t_switch = run.locate_slip(sys, (t, t_new), |sys, tau, out| {
                stepper.interpolate(tau, x);
                form.full_into(sys, tau, x, out)
            })?;
            if t_switch < t_new {
                stepper.interpolate(t_switch, &mut st.x_new);
                form.accept(run, sys, t, t_switch, &mut st.x_new, t_switch - t, false)?;
                run.summary.steps -= 1;
                t_new = t_switch;
            }
        }
        // events and outputs inside (t, t_new] from the dense output, built
        // on the accepted end point
        let crossed = run.event_crossed(form, sys, t_new, &st.x_new);
        if !stepper.dense_ready() && (crossed || sched.inside(run, t_new)) {
            stepper.prepare_dense(&mut Bound { sys, form }, t_new, &st.x, &st.x_new)?;
        }
        let interpolate = |tau: f64, out: &mut [f64]| stepper.interpolate(tau, out);
        if crossed && let Some(t_stop) = run.locate_events(form, sys, (t, t_new), &st.x_new, interpolate)? {
            return sched.stop(run, form, sys, t_stop, interpolate);
        }
        sched.emit_inside(run, form, sys, t_new, &st.x_new, interpolate)?;
        let reached = sched.reached(t_new);
        if slipped {
            if run.switch_form(form, sys, t_new, &mut st.x_new)? {
                // the other formulation goes on from here
                return sched.at_handover(run, form, sys, reached, t_new, &st.x_new);
            }
            stepper.restart(&mut Bound { sys, form }, t_new, &st.x_new)?;
            // a margin the step did not resolve: the next ones shorter
            if let Some(h_max) = run.slip.h_max.take() {
                h_next = h_next.min(h_max);
            }
        }
        if reached {
            sched.at_point(run, form, sys, t_new, &st.x_new)?;
            sched.progress(run, t_new);
            // a new partition restarts the method from the same state
            if form.settle(sys, t_new, &mut st.x_new)? {
                stepper.restart(&mut Bound { sys, form }, t_new, &st.x_new)?;
            }
        }
        std::mem::swap(&mut st.x, &mut st.x_new);
        (t, h) = (t_new, h_next);
        stepper.advance(&mut Bound { sys, form }, t, &st.x)?;
        sched.advance(reached);
        if reached {
            run.observer.poll(t).map_err(RunError::Output)?;
        }
    }
    // the final time is always written
    sched.finish(run, form, sys, &st.x)
}

/// What [`judge`] decided on an attempt.
enum Decision {
    /// Accepted; the next step size \[s\].
    Accept(f64),
    /// Rejected; the step size to retry with \[s\].
    Reject(f64),
}

/// The decision on the attempt `trial` of the step `target` from `t`:
/// the method's own, or an embedded estimate's through the method's
/// controller with the singular positions' guard around it. Near a
/// singular position (the KKT conditioning past [`NEAR_SINGULAR`] in the
/// attempt):
///
/// - the estimate is dominated by a mode normal to the constraints that
///   grows like `1 / s` at a distance `s` (the branch of a bifurcation is
///   unstable), and which the projection removes: resolving it would
///   shrink the steps onto the singular time without end. Only the
///   tangential error counts there ([`Stepper::revise_error`]);
/// - a step that would end right next to a singular time (its last stage
///   conditioned [`SINGULAR_LANDING`] times worse than its start: about
///   100 times closer, the growth going like `1 / s^2`) is taken half as
///   long: from a state that close, every later step's first stage sits
///   on the singularity;
/// - should that not be enough (the rounding of the positions, `eps / s`
///   along the other branch, amplified above the tolerance: not seen on
///   the N-four-bars down to rtol 1e-14), the step size collapses onto
///   the singular time: the run stops at once with the cause
///   ([`SimError::SingularTolerance`], [`SINGULAR_COLLAPSE`]) rather than
///   after thousands of steps at the rounding level of `t`;
/// - the reduced formulation stops, whatever the method, so that the DAE
///   can take over ([`near_handover`]).
///
/// # Errors
/// [`SimError::SingularTolerance`]; [`SimError::Formulation`] from
/// [`near_handover`]; as the projection.
#[expect(
    clippy::too_many_arguments,
    reason = "a step's state as the loop holds it, borrowed, no struct built per step"
)]
#[inline(always)]
fn judge<M, O, F, S>(
    sys: &Dynamics<M>,
    form: &F,
    run: &mut Run<'_, M, O>,
    stepper: &mut S,
    guard: &mut SingularGuard,
    st: &mut States,
    t: f64,
    target: &Target,
    trial: Trial,
) -> Result<Decision, SimError>
where
    M: Model,
    O: Observer<M>,
    F: Integrand<M>,
    S: for<'b> Stepper<Bound<'b, M, F>>,
{
    let h = target.h;
    let mut err = match trial {
        Trial::Rejected { h_next } => return Ok(Decision::Reject(h_next)),
        Trial::Accepted { h_next } => {
            near_handover(sys, form, t)?;
            return Ok(Decision::Accept(h_next));
        }
        Trial::Estimate(err) => err,
    };
    if err > 1.0 && sys.max_growth > NEAR_SINGULAR && form.projects() && run.settings.projection != ProjectionKind::None
    {
        let (n, nq) = (st.x.len(), sys.nq());
        st.ea.resize(n, 0.0);
        st.eb.resize(n, 0.0);
        let (proj, x_new) = (&mut run.proj, &st.x_new);
        let remove = |e: &mut [f64]| {
            let (eq, rest) = e.split_at_mut(nq);
            proj.remove_normal(&sys.model, target.t_new, &x_new[..nq], eq, &mut rest[..nq])
        };
        if let Some(e) = stepper.revise_error(&st.x, x_new, &mut st.ea, &mut st.eb, remove)? {
            err = e;
        }
    }
    let end_growth = sys.last_growth;
    let (mut accepted, mut h_next) = stepper.control(err);
    if accepted && !target.last && end_growth > NEAR_SINGULAR && end_growth > SINGULAR_LANDING * guard.start_growth {
        accepted = false;
        h_next = 0.5 * h;
    }
    let near = sys.max_growth > NEAR_SINGULAR;
    if !near && accepted {
        guard.h_far = h;
    }
    near_handover(sys, form, t)?;
    if !accepted && near && h_next < SINGULAR_COLLAPSE * guard.h_far {
        return Err(SimError::SingularTolerance { t, h: h_next, rtol: run.settings.rtol });
    }
    Ok(if accepted { Decision::Accept(h_next) } else { Decision::Reject(h_next) })
}

/// Stops the reduced formulation in a step from `t` that came near a
/// singular position (the KKT conditioning past [`NEAR_SINGULAR`]), where
/// its dependent coordinates are not determined: the DAE takes over from
/// the step's start (see [`super::simulate`]).
///
/// # Errors
/// [`SimError::Formulation`] saying so.
fn near_handover<M: Model, F: Integrand<M>>(sys: &Dynamics<M>, form: &F, t: f64) -> Result<(), SimError> {
    if sys.max_growth > NEAR_SINGULAR && form.hands_over_near_singular() {
        return Err(SimError::Formulation {
            reason: format!(
                "at t = {t:.6} s a singular position is near (KKT conditioning {:.1e}), where the dependent coordinates are not determined",
                sys.max_growth
            ).into(),
        });
    }
    Ok(())
}

/// One step as the schedule sets it.
struct Target {
    /// The size to attempt \[s\].
    h: f64,
    /// Where the step ends if accepted \[s\].
    t_new: f64,
    /// The step size the accepted state is checked with \[s\] (a fixed
    /// step's `dt`, also for the last step of its grid).
    h_nominal: f64,
    /// Whether the step ends the run.
    last: bool,
}

/// When the steps end and the outputs fall: a fixed step's grid, with an
/// output at every `stride`-th point, or an adaptive method's steps, with
/// outputs at the multiples of `every` from each step's dense output.
enum Schedule {
    /// Steps to the points `i dt` (the last at `t_end`); `i` the point
    /// the step taken starts after, of `n`.
    Grid { i: u64, n: u64, dt: f64, t_end: f64, stride: u64 },
    /// The next output's number (at `n_out every`), and the end \[s\].
    Dense { n_out: u64, t_end: f64 },
}

impl Schedule {
    /// The schedule of a method chosing its steps by `control`, and the
    /// time the run goes on from (`run.t_start`, or the grid point after
    /// it if a fixed step's grid rounds there).
    fn new<M: Model, O: Observer<M>>(control: Control, run: &Run<'_, M, O>) -> (Self, f64) {
        let (s, t_start) = (run.settings, run.t_start);
        if control == Control::Fixed {
            let (n, dt) = (s.n_steps(), s.dt);
            let mut sched = Schedule::Grid { i: 0, n, dt, t_end: s.t_end, stride: s.output_stride() };
            // a hand-over's start may lie between grid points: the first
            // step then goes from it to the next one
            let mut i0 = ((t_start / dt).floor() as u64).min(n);
            while i0 < n && sched.point(i0 + 1) <= t_start {
                i0 += 1;
            }
            let t = if i0 < n { sched.point(i0).max(t_start) } else { t_start };
            if let Schedule::Grid { i, .. } = &mut sched {
                *i = i0;
            }
            return (sched, t);
        }
        // the first output after the start (all up to it are written)
        let mut n_out: u64 = (t_start / s.every).floor() as u64 + 1;
        while run.out_time(n_out) <= t_start && n_out as f64 * s.every <= s.t_end {
            n_out += 1;
        }
        (Schedule::Dense { n_out, t_end: s.t_end }, t_start)
    }

    /// The grid's point `k` \[s\] (`t_end` for the last).
    fn point(&self, k: u64) -> f64 {
        match *self {
            Schedule::Grid { n, dt, t_end, .. } => {
                if k == n {
                    t_end
                } else {
                    k as f64 * dt
                }
            }
            Schedule::Dense { .. } => f64::NAN,
        }
    }

    /// Whether a step is left to take from `t`.
    #[inline]
    fn running(&self, t: f64) -> bool {
        match *self {
            Schedule::Grid { i, n, .. } => i < n,
            Schedule::Dense { t_end, .. } => t < t_end,
        }
    }

    /// The step from `t`: to the next grid point, or of size `h` (cut to
    /// end at `t_end`, the budget and the step's size checked:
    /// [`Run::begin_attempt`], with `stage_failure` as the cause of a step
    /// too small; near a singular position an embedded method's
    /// [`SimError::SingularTolerance`]).
    ///
    /// # Errors
    /// As [`Run::begin_attempt`].
    fn target<M: Model, O: Observer<M>>(
        &self,
        run: &Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        control: Control,
        stage_failure: &mut Option<SimError>,
        t: f64,
        h: &mut f64,
    ) -> Result<Target, SimError> {
        if let Schedule::Grid { i, dt, .. } = *self {
            let t_next = self.point(i + 1);
            let h_nominal = if t == self.point(i) { dt } else { t_next - t };
            return Ok(Target { h: t_next - t, t_new: t_next, h_nominal, last: i + 1 == self.steps() });
        }
        let last = match run.begin_attempt(t, h, stage_failure) {
            Err(SimError::StepSizeTooSmall { t, h })
                if control == Control::Embedded && sys.max_growth > NEAR_SINGULAR =>
            {
                return Err(SimError::SingularTolerance { t, h, rtol: run.settings.rtol });
            }
            other => other?,
        };
        if control == Control::Embedded {
            sys.max_growth = 0.0;
        }
        let t_new = if last { run.settings.t_end } else { t + *h };
        Ok(Target { h: *h, t_new, h_nominal: *h, last })
    }

    /// The grid's number of steps (0 for the adaptive schedule).
    fn steps(&self) -> u64 {
        match *self {
            Schedule::Grid { n, .. } => n,
            Schedule::Dense { .. } => 0,
        }
    }

    /// Whether the step ending at `t_new` reached its grid point (not cut
    /// short by a switch); an adaptive step always does.
    #[inline]
    fn reached(&self, t_new: f64) -> bool {
        match *self {
            Schedule::Grid { i, .. } => t_new == self.point(i + 1),
            Schedule::Dense { .. } => true,
        }
    }

    /// The step just taken is done (`reached`: at its grid point).
    #[inline]
    fn advance(&mut self, reached: bool) {
        if let Schedule::Grid { i, .. } = self
            && reached
        {
            *i += 1;
        }
    }

    /// Whether a wanted output falls inside the accepted step ending at
    /// `t_new` (a grid's outputs are on its points, never inside).
    fn inside<M: Model, O: Observer<M>>(&self, run: &Run<'_, M, O>, t_new: f64) -> bool {
        match *self {
            Schedule::Grid { .. } => false,
            // most steps hold no output: that test inline, the search not
            Schedule::Dense { n_out, .. } => run.output_due(n_out, t_new) && run.output_inside(n_out, t_new),
        }
    }

    /// The adaptive outputs inside `(t, t_new]` of the accepted step, from
    /// its dense output `interpolate` ([`Run::emit_dense`]).
    fn emit_inside<M: Model, O: Observer<M>, F: Integrand<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        form: &mut F,
        sys: &Dynamics<M>,
        t_new: f64,
        x_new: &[f64],
        interpolate: impl Fn(f64, &mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        match self {
            Schedule::Grid { .. } => Ok(()),
            Schedule::Dense { n_out, .. } => run.emit_dense(form, sys, t_new, x_new, n_out, interpolate),
        }
    }

    /// Ends the run at the event at `t_stop`: the outputs before it (the
    /// grid's are written), then the event's state.
    fn stop<M: Model, O: Observer<M>, F: Integrand<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        form: &mut F,
        sys: &Dynamics<M>,
        t_stop: f64,
        interpolate: impl Fn(f64, &mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        match self {
            Schedule::Grid { .. } => run.emit_stop_state(sys, t_stop),
            Schedule::Dense { n_out, .. } => run.emit_stop(form, sys, t_stop, n_out, interpolate),
        }
    }

    /// The grid's output at the point `t_new` the step reached: every
    /// `stride`-th point the observer wants, and the last.
    fn at_point<M: Model, O: Observer<M>, F: Integrand<M>>(
        &self,
        run: &mut Run<'_, M, O>,
        form: &mut F,
        sys: &Dynamics<M>,
        t_new: f64,
        x_new: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        if let Schedule::Grid { i, n, stride, .. } = *self
            && (((i + 1) % stride == 0 && run.wanted(t_new)) || i + 1 == n)
        {
            form.emit(run, sys, t_new, x_new)?;
        }
        Ok(())
    }

    /// At a hand-over to the other formulation at `t_new`: the grid's
    /// sample due at the point reached (`reached`) is written first.
    fn at_handover<M: Model, O: Observer<M>, F: Integrand<M>>(
        &self,
        run: &mut Run<'_, M, O>,
        form: &mut F,
        sys: &Dynamics<M>,
        reached: bool,
        t_new: f64,
        x_new: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        if let Schedule::Grid { i, n, stride, .. } = *self
            && reached
            && ((i + 1) % stride == 0 || i + 1 == n)
        {
            form.emit(run, sys, t_new, x_new)?;
        }
        Ok(())
    }

    /// Tells the observer the time `t_new` now and then: every 64 output
    /// strides of a grid; every 64 attempts of an adaptive method, also
    /// when no output is due for long (tiny steps).
    fn progress<M: Model, O: Observer<M>>(&self, run: &mut Run<'_, M, O>, t_new: f64) {
        let due = match *self {
            Schedule::Grid { i, stride, .. } => (i + 1).is_multiple_of(stride * 64),
            Schedule::Dense { .. } => (run.summary.steps + run.summary.rejected).is_multiple_of(64),
        };
        if due {
            run.observer.progress(t_new);
        }
    }

    /// The final time is always written: an adaptive run's accepted `x`
    /// at `t_end` unless its last output was it (a grid's last point is
    /// an output).
    fn finish<M: Model, O: Observer<M>, F: Integrand<M>>(
        &self,
        run: &mut Run<'_, M, O>,
        form: &mut F,
        sys: &Dynamics<M>,
        x: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        match *self {
            Schedule::Grid { .. } => Ok(()),
            Schedule::Dense { n_out, .. } => run.finish_dense(form, sys, n_out, x),
        }
    }
}

/// The run's steps that take the formulation: the events of an accepted
/// step, and a switch that may hand the run over to the other formulation.
impl<M: Model, O: Observer<M>> Run<'_, M, O> {
    /// Whether an event's sign changed in the accepted step ending at
    /// `t_new` with the integrator state `x_new` (the step's dense output
    /// is then needed: [`Run::locate_events`]); a step without counts
    /// for the chattering test and moves the events' left values on.
    #[inline]
    pub(super) fn event_crossed<F: Integrand<M>>(
        &mut self,
        form: &F,
        sys: &Dynamics<M>,
        t_new: f64,
        x_new: &[f64],
    ) -> bool {
        if sys.events.is_empty() {
            return false;
        }
        let crossed = self.monitor.any_crossing(sys, t_new, form.accepted_full(x_new));
        if !crossed {
            self.monitor.quiet_step();
            std::mem::swap(&mut self.monitor.left, &mut self.monitor.right);
        }
        crossed
    }

    /// The events of the accepted step from `t` to `t_new` whose signs
    /// changed ([`Run::event_crossed`]), located on the step's continuous
    /// extension `interpolate(t, x)` ([`crate::simulate::events::locate`]) and
    /// recorded in time order with their states (projected, or expanded),
    /// up to the first that stops the run: its time, its state kept in
    /// [`Run::stop`].
    ///
    /// # Errors
    /// As the formulation's expansion; [`SimError::Chattering`],
    /// [`SimError::EventLimit`].
    #[cold]
    pub(super) fn locate_events<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        span: (f64, f64),
        x_new: &[f64],
        mut interpolate: impl FnMut(f64, &mut [f64]),
    ) -> Result<Option<f64>, SimError> {
        // one copy per formulation, not one per step loop's extension
        self.locate_events_on(form, sys, span, x_new, &mut interpolate)
    }

    /// [`Run::locate_events`] on any continuous extension.
    #[cold]
    pub(super) fn locate_events_on<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        (t, t_new): (f64, f64),
        x_new: &[f64],
        interpolate: &mut dyn FnMut(f64, &mut [f64]),
    ) -> Result<Option<f64>, SimError> {
        let mut found = std::mem::take(&mut self.monitor.found);
        found.clear();
        for (k, e) in sys.events.iter().enumerate() {
            let (l, r) = (self.monitor.left[k], self.monitor.right[k]);
            let Some(rising) = e.direction.crossing(l, r) else { continue };
            let (x, scratch) = (&mut self.event_x, &mut self.monitor.scratch);
            let g = |tau: f64| -> Result<f64, SimError> {
                interpolate(tau, x);
                let y = form.full_of(sys, tau, x)?;
                Ok(e.value(sys, tau, y, scratch))
            };
            let te = crate::simulate::events::locate(g, t, l, t_new, r)?;
            found.push(Crossing { event: k, t: te, rising });
        }
        in_time_order(&mut found);
        let mut stop = None;
        for c in &found {
            let e = &sys.events[c.event];
            let mut y = if c.t == t_new {
                form.accepted_full(x_new).to_vec()
            } else {
                interpolate(c.t, &mut self.event_x);
                form.full_of(sys, c.t, &self.event_x)?.to_vec()
            };
            if c.t != t_new && form.projects() && self.settings.projection != ProjectionKind::None {
                let nq = sys.nq();
                let (q, rest) = y.split_at_mut(nq);
                self.proj.project(&sys.model, c.t, q, &mut rest[..nq])?;
            }
            self.monitor.record(&e.name, c.t, c.rising, &y)?;
            if e.action == crate::events::spec::Action::Stop {
                self.summary.stopped = Some((e.name.clone(), c.t));
                self.stop = Some(y);
                stop = Some(c.t);
                break;
            }
        }
        let counted = self.monitor.count_step(&sys.events, t_new, &found);
        self.monitor.found = found;
        counted?;
        std::mem::swap(&mut self.monitor.left, &mut self.monitor.right);
        Ok(stop)
    }

    /// At a switch at `t`, the accepted state `x` of `form`: the skates'
    /// modes and the effects switched on the full state
    /// ([`Run::switch_slip`]). Returns whether the run hands over to the
    /// other formulation there (the reduced one to the DAE when a skate
    /// begins to slide: it keeps every skate's row; the DAE back to it when
    /// every skate sticks again): the step loop then ends, and
    /// [`Run::handover`] holds the time and the full state.
    ///
    /// # Errors
    /// As [`Run::switch_slip`].
    #[cold]
    pub(super) fn switch_form<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &mut Dynamics<M>,
        t: f64,
        x: &mut [f64],
    ) -> Result<bool, RunError<O::Error>> {
        let dae = form.solves_kkt();
        let mut full = if dae { Vec::new() } else { form.accepted_full(x).to_vec() };
        self.switch_slip(sys, t, if dae { &mut *x } else { &mut full })?;
        // F at this state, evaluated ahead, had the old forces
        form.forget_evaluation();
        let sliding = !sys.released_rows().is_empty();
        let hand = t < self.settings.t_end && if dae { self.hand_back && !sliding } else { sliding };
        if hand {
            self.handover = Some((t, if dae { x.to_vec() } else { full }));
        }
        Ok(hand)
    }
}

/// Sorts crossings by time (not generic: one copy of the sort).
fn in_time_order(found: &mut [Crossing]) {
    found.sort_by(|a, b| a.t.total_cmp(&b.t));
}
