//! The step loop: RK4, projection after every step, output at a fixed
//! interval, energy balance tracked at every step. The loop itself does not
//! allocate; output goes to an [`Observer`].

pub mod events;
pub mod guard;

use crate::settings::RunSettings;
use std::time::{Duration, Instant};

use crate::error::KktError;
use crate::error::{SimError, advice};
use crate::formulation::dae::NEAR_SINGULAR;
use crate::formulation::dae::{Counters, Dynamics};
use crate::formulation::friction::{MarginSample, MarginScan};
use crate::formulation::projection::{Projector, max_abs};
use crate::formulation::reduced::Reduced;
use crate::integrator::Rhs;
use crate::integrator::adaptive::{Controller, initial_step};
use crate::integrator::adaptive::{EmbeddedRk, Tolerance};
use crate::integrator::dop853::Dop853;
use crate::integrator::dopri5::Dopri5;
use crate::integrator::fixed::{Euler, Rk4};
use crate::model::Model;
use crate::settings::Formulation;
use crate::settings::Method;
use crate::settings::ProjectionKind;
use crate::simulate::events::{Crossing, Monitor};
use crate::simulate::guard::{EnergyGuard, GROWTH_LIMIT, Verdict, drift_note};

/// One output sample.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Time \[s\].
    pub t: f64,
    /// Coordinates (nq).
    pub q: &'a [f64],
    /// Velocities (nq).
    pub qd: &'a [f64],
    /// Kinetic energy \[J\].
    pub kinetic_energy: f64,
    /// Work of all applied forces since t = 0, `sum W_e` \[J\].
    pub work: f64,
    /// Work of each effect since t = 0, `W_e` \[J\], in the order of
    /// [`Dynamics::effects`].
    pub works: &'a [f64],
    /// `max|C(q)|` \[m\].
    pub residual_position: f64,
    /// `max|G(q) qd|` \[m/s\].
    pub residual_velocity: f64,
}

/// Receives the samples of a run.
pub trait Observer<M: Model> {
    /// Error type of the sink.
    type Error;
    /// Called at t = 0, every output interval, and at the final time.
    ///
    /// # Errors
    /// Whatever the sink fails with; the run stops.
    fn observe(&mut self, sys: &Dynamics<M>, sample: &Sample<'_>) -> Result<(), Self::Error>;
    /// Called now and then with the current time, for progress display.
    fn progress(&mut self, _t: f64) {}
    /// A remark on the run while it goes (said once: an explicit method
    /// found the run stiff, [`stiff_note`]); the default ignores it.
    fn note(&mut self, _text: &str) {}
    /// Called after every accepted step with its end time \[s\], so a sink
    /// can stop a run between output rows (a signal asking to stop).
    ///
    /// # Errors
    /// Whatever the sink stops the run with; the default never stops it.
    fn poll(&mut self, _t: f64) -> Result<(), Self::Error> {
        Ok(())
    }
    /// Whether the output at `t` \[s\] is wanted: one that is not is
    /// neither interpolated from the dense output (which costs an adaptive
    /// method's extra stages) nor observed. The start, the final time and
    /// an event's stop are always observed. The default wants every one; a
    /// sink that reads a time window only (a sweep's `final` or windowed
    /// metrics) saves the samples outside it. Results inside the window
    /// are unchanged: outputs never shorten a step. The answer must not
    /// change during the run (it may be asked more than once, or not again).
    fn wants(&self, _t: f64) -> bool {
        true
    }
    /// The earliest time at or after `t` \[s\] whose output the observer
    /// may want, asked after [`Observer::wants`] refused the output at
    /// `t`: the outputs in between are skipped without asking again, for
    /// the rest of the run (a sweep's `final` metric is asked about once
    /// or twice a run, not once per output row). It may be early, never
    /// late: `wants` still decides at and after it. The default is `t`
    /// (ask about every output); a value not after `t`, or NaN, skips
    /// nothing, and the final time is observed whatever it says.
    fn next_wanted(&self, t: f64) -> f64 {
        t
    }
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError<E> {
    /// The numerics failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The output sink failed.
    #[error("output: {0}")]
    Output(E),
}

/// What a run did and how well.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Method used.
    pub method: Method,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts (adaptive methods).
    pub rejected: u64,
    /// Right-hand-side evaluations and KKT solves.
    pub counters: Counters,
    /// Projections applied.
    pub projections: u64,
    /// The formulation integrated ([`Formulation::Dae`] or [`Formulation::Reduced`]).
    pub formulation: Formulation,
    /// Times the reduced formulation re-chose its partition.
    pub repartitions: u64,
    /// Times the run went from the reduced formulation to the DAE (a
    /// skate began to slide, a singular position) or back (every skate
    /// sticks again).
    pub handovers: u64,
    /// Whether the reduced formulation ran on the model's minimal
    /// coordinates (partition and expansion in closed form, from `model!`:
    /// [`crate::model::info::MinimalLayout`]).
    pub minimal_coordinates: bool,
    /// Whether, on minimal coordinates, the right-hand side was the
    /// model's fused one ([`crate::model::Model::minimal_rhs`]: the expansion, the
    /// forces and Maggi's equations in one generated function).
    pub fused_rhs: bool,
    /// Wall time of the integration alone (steps, projections and the
    /// dense output's interpolation; no output work).
    pub integration_time: Duration,
    /// Wall time of the output work: projecting dense-output samples (the
    /// DAE) or expanding them to the full state (the reduced formulation
    /// on minimal coordinates), their energies and residuals, and the
    /// observer (the CSV rows).
    pub output_time: Duration,
    /// Largest `max|C|` over the outputs \[m\].
    pub max_residual_position: f64,
    /// Largest `max|G qd|` over the outputs \[m/s\].
    pub max_residual_velocity: f64,
    /// Largest drift `max|C|` a single step produced before projection \[m\].
    pub max_step_drift: f64,
    /// Largest `|T - T0 - W|` over all steps \[J\].
    pub max_energy_error: f64,
    /// Final state `y = [q, qd, W_1 .. W_k]` (one work state per effect).
    pub final_state: Vec<f64>,
    /// KKT path used.
    pub kkt: &'static str,
    /// Linear algebra of the projection.
    pub projection_path: &'static str,
    /// First `(t [s], estimate)` where the KKT conditioning estimate passed
    /// [`crate::formulation::dae::CONDITION_WARNING`].
    pub ill_conditioned: Option<(f64, f64)>,
    /// The implicit method's Newton iterations, Jacobians and
    /// factorizations (zero for the explicit methods).
    pub newton: crate::integrator::radau5::NewtonStats,
    /// `(t [s], h |lambda|)` where DOPRI5's or DOP853's stiffness test
    /// found the run stiff (their step held by stability, not accuracy;
    /// see [`crate::integrator::adaptive::StiffnessTest`]).
    pub stiff: Option<(f64, f64)>,
    /// The singular positions passed: `(t [s], singular solves)`, the time
    /// of the first accepted step whose KKT solves found `G`
    /// rank-deficient and how many did, one entry per passage (each is
    /// also told to the observer as a note).
    pub singular_passages: Vec<(f64, u64)>,
    /// The events that happened, in time order ([`crate::events`]).
    pub events: Vec<crate::events::spec::EventRecord>,
    /// The event that ended the run (its name and time \[s\]), if one did
    /// (an event with [`crate::events::spec::Action::Stop`]).
    pub stopped: Option<(String, f64)>,
    /// `(t [s], |T - T0 - W| / E)` where an adaptive run's energy balance
    /// first passed [`RunSettings::balance_limit`] relative to the run's
    /// energy scale `E` ([`crate::simulate::guard`]): the drift its tolerance lets
    /// through, noted, not an error.
    pub energy_drift: Option<(f64, f64)>,
}

/// Accepted steps in a row whose every KKT solve found `G` rank-deficient
/// after which a run stops with [`SimError::SingularPersists`] (or two
/// such steps spanning a hundredth of the run): a singular position that
/// the motion passes is met by a few stages of one or two steps (the rank
/// returns on either side), one the motion stays in by every stage of
/// every step.
pub const SINGULAR_PERSIST_STEPS: u64 = 8;

/// The singular position being passed, for [`Run::track_singular`].
#[derive(Debug, Clone, Copy, Default)]
struct SingularTrack {
    /// Counters at the last accepted step.
    solves: u64,
    evals: u64,
    /// `(time of the passage's first step, singular solves so far)`.
    open: Option<(f64, u64)>,
    /// Accepted steps in a row whose every solve was singular, and when
    /// they began.
    persistent: u64,
    since: f64,
}

/// `max / min` of the positive, finite entries of the mass diagonal (1
/// when there are none).
fn mass_spread(mass: &[f64]) -> f64 {
    let positive = mass.iter().filter(|m| **m > 0.0 && m.is_finite());
    let (lo, hi) = positive.fold((f64::INFINITY, 0.0f64), |(lo, hi), &m| (lo.min(m), hi.max(m)));
    if hi > 0.0 { hi / lo } else { 1.0 }
}

/// The note of a singular position passed at `t` \[s\] (`solves` KKT
/// solves found `G` rank-deficient there).
pub fn singular_note(t: f64, solves: u64) -> String {
    format!(
        "passed a singular position at t = {t:.6} s: the constraint Jacobian G lost rank there ({solves} KKT solve{} found its rows dependent and took the regularized solve, whose accelerations are unique and whose multipliers are the least ones)",
        if solves == 1 { "" } else { "s" }
    )
}

/// The note a stiff run gets (`method` found it stiff at `t` with
/// `h |lambda| = hlambda` beyond `limit`).
pub fn stiff_note(method: Method, t: f64, hlambda: f64, limit: f64) -> String {
    format!(
        "from t = {t:.6} s the run is stiff: {}'s steps are held by its stability (Hairer's test: h|lambda| = {hlambda:.1} > {limit} for 15 tests), not by accuracy; {} steps over the fast modes",
        method.name(),
        crate::settings::Setting::Method(Method::Radau5)
    )
}

/// Residual evaluation buffers.
#[derive(Debug, Clone)]
struct Residuals {
    phi: Vec<f64>,
    g_values: Vec<f64>,
    pattern: Vec<(usize, usize)>,
    ones: Vec<f64>,
    r: Vec<f64>,
    /// Rows left out of `G qd` (sliding skates).
    released: crate::formulation::friction::Released,
}

impl Residuals {
    fn new(i: &crate::model::info::ModelInfo) -> Self {
        Self {
            phi: vec![0.0; i.n_holonomic],
            g_values: vec![0.0; i.pattern.len()],
            pattern: i.pattern.clone(),
            ones: vec![1.0; i.nq()],
            r: vec![0.0; i.nc()],
            released: Default::default(),
        }
    }
    fn eval<M: Model>(
        &mut self,
        model: &M,
        drives: &[crate::drive::Drive],
        t: f64,
        q: &[f64],
        qd: &[f64],
    ) -> (f64, f64) {
        // one evaluation of the trigonometric terms for both
        model.phi_and_constraint_matrix(q, &mut self.phi, &mut self.g_values);
        crate::drive::shift_positions(drives, t, &mut self.phi);
        self.released.zero(&mut self.g_values);
        model.g_winv_mul(&self.pattern, &self.g_values, &self.ones, qd, &mut self.r);
        crate::drive::shift_velocities(drives, t, &mut self.r);
        (max_abs(&self.phi), max_abs(&self.r))
    }
}

/// Step-loop state shared by the fixed-step and adaptive drivers:
/// projection, residuals, energy balance, output timing.
struct Run<'a, M: Model, O: Observer<M>> {
    settings: &'a RunSettings,
    observer: &'a mut O,
    proj: Projector<M>,
    resid: Residuals,
    t0_energy: f64,
    /// The singular position being passed, if any.
    singular: SingularTrack,
    /// The energy balance's scales ([`crate::simulate::guard`]).
    guard: EnergyGuard,
    /// Size of the last step \[s\] (0 before the first).
    last_step: f64,
    /// The time of the last accepted step \[s\] (where a hand-over from
    /// the reduced formulation to the DAE starts).
    t_reached: f64,
    /// The time the step loop starts at \[s\]: 0, or the hand-over's.
    t_start: f64,
    summary: Summary,
    output_time: Duration,
    /// Samples `(t, y)` not yet observed, row after row.
    pending: Vec<f64>,
    /// For each of them: what is left to do before it is observed.
    pending_kind: Vec<Pending>,
    /// Where a [`Pending::Expand`] row's integrator state goes in the full
    /// state `[q, qd, W]`: index `i` of `z` to `sample_places[i]`
    /// ([`Reduced::sample_places`]); empty until the first such row.
    sample_places: Vec<usize>,
    /// Scratch for one such row's `z` while it is placed.
    sample_z: Vec<f64>,
    newton: crate::integrator::radau5::NewtonStats,
    /// The events' watch ([`crate::events`]).
    monitor: Monitor,
    /// An integrator state's scratch for locating events.
    event_x: Vec<f64>,
    /// The full state at the event that stopped the run.
    stop: Option<Vec<f64>>,
    /// The skates with friction: their switches' watch.
    slip: SlipWatch,
    /// Whether the DAE hands back to the reduced formulation when every
    /// skate sticks again (a run asked for the reduced one, with friction).
    hand_back: bool,
    /// Where the step loop handed over to the other formulation, and the
    /// full state there ([`Run::switch_form`]).
    handover: Option<(f64, Vec<f64>)>,
    /// Outputs in `[from, until)` \[s\] are not wanted: `from` an output
    /// the observer refused, `until` its [`Observer::next_wanted`] (at
    /// most `t_end`).
    skip: std::cell::Cell<(f64, f64)>,
}

/// Firings of one switching event, or with a fixed step switches of one
/// skate, at most this many accepted steps apart count as one streak;
/// [`crate::events::spec::CHATTER_STEPS`] of them in a row are chattering
/// ([`SimError::Chattering`], [`SimError::SlipChattering`]). (An adaptive
/// run's skate switches count by their intervals instead,
/// [`crate::formulation::friction::SwitchStreak`]: its margin is scanned inside every
/// step, so a fast stick-slip motion is resolved with few steps between
/// switches.)
pub const SLIP_CHATTER_GAP: u64 = 8;

/// Cuts of a step at a skate's switch in a row that each move the run on
/// by rounding only after which it stops ([`SimError::SlipChattering`]):
/// the skates' modes found at the cut are consistent by their rates, yet
/// the margin falls below zero at once.
const STALLED_CUTS: u32 = 16;

/// The watch on what switches the run's forces or rows: the skates with
/// friction ([`crate::formulation::friction`]: each one's margin) and then the events
/// that switch effects ([`crate::events::spec::Action::Switch`]: each one's
/// `g`), at the start and the end of the step, and their switches in a row.
#[derive(Debug, Default)]
struct SlipWatch {
    left: Vec<f64>,
    right: Vec<f64>,
    /// The time of `left` \[s\].
    t_left: f64,
    /// The skates' margin rates at `left` and `right` (one per skate).
    left_rate: Vec<f64>,
    right_rate: Vec<f64>,
    /// The smallest margin that counts as a violation, per skate
    /// ([`Dynamics::slip_tolerances`]).
    eps: Vec<f64>,
    /// Per skate: whether its margin needs a look inside the step
    /// ([`crate::formulation::friction::margin_suspect`]).
    suspect: Vec<bool>,
    /// The skates' margins and rates (one per skate).
    scratch: Vec<f64>,
    scratch_rate: Vec<f64>,
    /// The longest next step after a step cut where a margin was no longer
    /// resolved ([`crate::formulation::friction::MarginScan::Unresolved`]) \[s\].
    h_max: Option<f64>,
    /// Cuts in a row that moved the run on by rounding only.
    stalls: u32,
    /// Per switch event: `(steps in a row with a switch, when they began,
    /// the step count at its last switch)` (the skates':
    /// [`SlipWatch::skate_streaks`]).
    streaks: Vec<(u64, f64, u64)>,
    /// Per skate: its switches at ever shorter intervals.
    skate_streaks: Vec<crate::formulation::friction::SwitchStreak>,
    /// The switch events: indices into [`Dynamics::events`].
    switches: Vec<usize>,
    /// Per skate, then per switch event: where it crossed in the step
    /// being cut (infinite where it did not).
    times: Vec<f64>,
    /// Scratch of [`crate::events::spec::Event::value`].
    values: Vec<f64>,
    /// Scratch: a full state on the step's continuous extension.
    full: Vec<f64>,
}

impl SlipWatch {
    /// Whether watch `k` (a skate, then a switch event) crossed from
    /// `left` to `right`, and which way (`Some(true)`: a skate begins to
    /// slide or turns, an event rises).
    fn crossing<M: Model>(&self, sys: &Dynamics<M>, k: usize) -> Option<bool> {
        let (l, r, nf) = (self.left[k], self.right[k], sys.friction.len());
        if k < nf {
            self.suspect[k].then_some(true)
        } else {
            sys.events[self.switches[k - nf]].direction.crossing(l, r)
        }
    }
}

impl<'a, M: Model, O: Observer<M>> Run<'a, M, O> {
    /// Whether an event's sign changed in the accepted step ending at
    /// `t_new` with the integrator state `x_new` (the step's dense output
    /// is then needed: [`Run::locate_events`]); a step without counts
    /// for the chattering test and moves the events' left values on.
    #[inline]
    fn event_crossed<F: Integrand<M>>(&mut self, form: &F, sys: &Dynamics<M>, t_new: f64, x_new: &[f64]) -> bool {
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
    fn locate_events<F: Integrand<M>>(
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
    fn locate_events_on<F: Integrand<M>>(
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

    /// Whether a skate's mode may have stopped holding in the accepted
    /// step ending at `t_new` with the full state `y_new`, or a switching
    /// event fired: a skate's margin
    /// ([`crate::formulation::friction::SkateFriction::margin`]) and its rate at the
    /// step's ends leave a violation inside the step possible
    /// ([`crate::formulation::friction::margin_suspect`]: it ends below zero, or comes
    /// within the step's travel of it), so the step's continuous extension
    /// is to be scanned ([`Run::locate_slip`]). `evaluated`: the
    /// right-hand side `dy` the last evaluation found at `y_new` (the
    /// DAE's), which is then not repeated. A step without moves the
    /// margins on.
    ///
    /// # Errors
    /// As [`Dynamics::rhs`].
    fn slip_crossed(
        &mut self,
        sys: &mut Dynamics<M>,
        t_new: f64,
        y_new: &[f64],
        evaluated: Option<&[f64]>,
    ) -> Result<bool, SimError> {
        if self.slip.left.is_empty() {
            return Ok(false);
        }
        let rtol = if self.settings.method.is_adaptive() { self.settings.rtol } else { 0.0 };
        let w = &mut self.slip;
        let nf = sys.friction.len();
        if nf > 0 {
            let h = t_new - w.t_left;
            match evaluated {
                Some(dy) => sys.slip_samples_after(t_new, h, y_new, dy, &mut w.right[..nf], &mut w.right_rate)?,
                None => sys.slip_samples_at(t_new, h, y_new, &mut w.right[..nf], &mut w.right_rate)?,
            }
            let nq = sys.nq();
            sys.slip_tolerances(&y_new[nq..2 * nq], rtol, &mut w.eps);
            for k in 0..nf {
                let a = MarginSample { t: w.t_left, m: w.left[k], r: w.left_rate[k] };
                let b = MarginSample { t: t_new, m: w.right[k], r: w.right_rate[k] };
                w.suspect[k] = crate::formulation::friction::margin_suspect(&a, &b, w.eps[k]);
            }
        }
        for (j, &k) in w.switches.iter().enumerate() {
            w.right[nf + j] = sys.events[k].value(sys, t_new, y_new, &mut w.values);
        }
        let crossed = (0..w.left.len()).any(|k| w.crossing(sys, k).is_some());
        if !crossed {
            std::mem::swap(&mut w.left, &mut w.right);
            std::mem::swap(&mut w.left_rate, &mut w.right_rate);
            w.t_left = t_new;
        }
        Ok(crossed)
    }

    /// The earliest time in `(t, t_new]` at which a skate's margin falls
    /// through zero or a switching event fires ([`Run::slip_crossed`]),
    /// located on the step's continuous extension `interpolate(sys, t, y)`
    /// (full states): each suspect skate's margin scanned
    /// ([`crate::formulation::friction::scan_margin`]) and its first violation located
    /// as an event's crossing is ([`crate::simulate::events::locate`]). A margin the
    /// step does not resolve cuts it where it last was (no switch there),
    /// and limits the next steps ([`SlipWatch::h_max`]).
    ///
    /// # Errors
    /// As [`Dynamics::rhs`], and as `interpolate`.
    #[cold]
    fn locate_slip(
        &mut self,
        sys: &mut Dynamics<M>,
        (t, t_new): (f64, f64),
        mut interpolate: impl FnMut(&Dynamics<M>, f64, &mut [f64]) -> Result<(), SimError>,
    ) -> Result<f64, SimError> {
        let mut t_switch = t_new;
        let (w, nf) = (&mut self.slip, sys.friction.len());
        w.times.fill(f64::INFINITY);
        w.full.resize(sys.ny(), 0.0);
        let h = t_new - t;
        for k in 0..w.left.len() {
            if w.crossing(sys, k).is_none() {
                continue;
            }
            let (l, r) = (w.left[k], w.right[k]);
            let x = &mut w.full;
            let te = if k < nf {
                let (margins, rates) = (&mut w.scratch, &mut w.scratch_rate);
                let a = MarginSample { t, m: l, r: w.left_rate[k] };
                let b = MarginSample { t: t_new, m: r, r: w.right_rate[k] };
                let scan = crate::formulation::friction::scan_margin(
                    a,
                    b,
                    w.eps[k],
                    |tau: f64| -> Result<MarginSample, SimError> {
                        interpolate(sys, tau, x)?;
                        sys.slip_samples_at(tau, h, x, margins, rates)?;
                        Ok(MarginSample { t: tau, m: margins[k], r: rates[k] })
                    },
                )?;
                match scan {
                    MarginScan::Holds => continue,
                    MarginScan::Unresolved { at, h_max } => {
                        t_switch = t_switch.min(at);
                        w.h_max = Some(w.h_max.map_or(h_max, |m| m.min(h_max)));
                        continue;
                    }
                    MarginScan::Crosses { lo, hi } => {
                        let g = |tau: f64| -> Result<f64, SimError> {
                            interpolate(sys, tau, x)?;
                            sys.slip_margins_at(tau, x, margins)?;
                            Ok(margins[k])
                        };
                        // a start within rounding of zero counts as holding
                        crate::simulate::events::locate(g, lo.t, lo.m.max(f64::MIN_POSITIVE), hi.t, hi.m.min(-0.0))?
                    }
                }
            } else {
                let (sys, values) = (&*sys, &mut w.values);
                let e = &sys.events[w.switches[k - nf]];
                let g = |tau: f64| -> Result<f64, SimError> {
                    interpolate(sys, tau, x)?;
                    Ok(e.value(sys, tau, x, values))
                };
                crate::simulate::events::locate(g, t, l, t_new, r)?
            };
            w.times[k] = te;
            t_switch = t_switch.min(te);
        }
        // a cut that moves the run on by rounding only, again and again
        // (a margin that falls below zero at once in the mode the skates
        // settle back into) would loop without end: refused
        if t_switch < t_new && t_switch - t <= 1e-12 * t.abs().max(1.0) {
            w.stalls += 1;
            if w.stalls >= STALLED_CUTS {
                let k = (0..nf).find(|&k| w.times[k] == t_switch).unwrap_or(0);
                let skate = sys.friction.get(k).map_or_else(String::new, |f| f.name.clone());
                return Err(SimError::SlipChattering { skate, t0: t, t1: t, switches: 0 });
            }
        } else {
            w.stalls = 0;
        }
        Ok(t_switch)
    }

    /// Switches the skates' modes at `(t, y)`, where one stopped holding
    /// ([`Dynamics::settle_friction`]): the samples queued so far are
    /// observed first (in the modes they were computed in), each switch is
    /// recorded as an event (`slip_<skate>`, rising: it begins to slide;
    /// `stick_<skate>`, falling: it sticks or turns), the projection and
    /// the residuals take the new set of rows, `y` is projected onto it
    /// and the margins start anew there.
    ///
    /// # Errors
    /// As [`Dynamics::settle_friction`] and [`Run::flush`];
    /// [`SimError::SlipChattering`] when a skate has switched
    /// [`crate::events::spec::CHATTER_STEPS`] times in a row, each within
    /// [`SLIP_CHATTER_GAP`] steps of the one before.
    #[cold]
    fn switch_slip(&mut self, sys: &mut Dynamics<M>, t: f64, y: &mut [f64]) -> Result<(), RunError<O::Error>> {
        self.flush(sys)?;
        let step = self.summary.steps;
        // the events that fire here switch their effects first: the skates'
        // modes are then decided under the new forces
        let nf = sys.friction.len();
        for j in 0..self.slip.switches.len() {
            let w = &mut self.slip;
            let Some(rising) = w.crossing(sys, nf + j).filter(|_| w.times[nf + j] <= t) else { continue };
            let e = &sys.events[w.switches[j]];
            let (name, on, off) = (e.name.clone(), e.switch_on.clone(), e.switch_off.clone());
            let s = &mut w.streaks[j];
            *s = if s.0 > 0 && step <= s.2 + SLIP_CHATTER_GAP { (s.0 + 1, s.1, step) } else { (1, t, step) };
            if s.0 >= crate::events::spec::CHATTER_STEPS {
                return Err(SimError::Chattering { event: name, t0: s.1, t1: t, steps: s.0 }.into());
            }
            self.monitor.record(&name, t, rising, y)?;
            on.iter().for_each(|&k| sys.effects[k].on = true);
            off.iter().for_each(|&k| sys.effects[k].on = false);
        }
        let switches = if nf > 0 { sys.settle_friction(t, y)? } else { Vec::new() };
        for &(k, old, new) in &switches {
            let fr = &sys.friction[k];
            self.monitor.record(&fr.transition_name(old), t, new.is_sliding(), y)?;
            let s = &mut self.slip.skate_streaks[k];
            let fixed = (!self.settings.method.is_adaptive()).then_some(SLIP_CHATTER_GAP as f64 * self.settings.dt);
            if s.record(t, fixed) >= crate::events::spec::CHATTER_STEPS {
                let (skate, t0, switches) = (fr.name.clone(), s.since, s.count);
                return Err(SimError::SlipChattering { skate, t0, t1: t, switches }.into());
            }
        }
        let rows = sys.released_rows();
        self.proj.release(rows);
        self.resid.released.set(&sys.info.pattern, rows);
        if self.settings.projection != ProjectionKind::None {
            let nq = sys.nq();
            let (q, rest) = y.split_at_mut(nq);
            self.proj.project(&sys.model, t, q, &mut rest[..nq])?;
        }
        self.jumped_events(sys, t, y)?;
        self.sliding_mode(sys, t, y)?;
        let w = &mut self.slip;
        w.t_left = t;
        if nf > 0 {
            sys.slip_samples_at(t, self.last_step.max(t * f64::EPSILON), y, &mut w.left[..nf], &mut w.left_rate)?;
        }
        for (j, &k) in w.switches.iter().enumerate() {
            let g = sys.events[k].value(sys, t, y, &mut w.values);
            // an event that fired here starts on its new side: where the
            // projection put `g` back across its level by rounding, at it
            // (a start at zero is no crossing)
            let fired = w.times[nf + j] <= t;
            let back = fired && sys.events[k].direction.crossing(w.left[nf + j], g).is_none() && g != 0.0;
            w.left[nf + j] = if back { 0.0 } else { g };
        }
        Ok(())
    }

    /// At a switch at `t` with the state `y` (after it): the recorded
    /// events whose quantity jumped across its level there (an effect
    /// switched off reads 0) recorded at `t`, and every recorded event's
    /// `g` taken on the switch's new side, where the next step starts.
    ///
    /// # Errors
    /// [`SimError::EventLimit`].
    fn jumped_events(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), SimError> {
        let m = &mut self.monitor;
        for (k, e) in sys.events.iter().enumerate() {
            if e.action == crate::events::spec::Action::Switch {
                continue;
            }
            let g = e.value(sys, t, y, &mut m.scratch);
            if let Some(rising) = e.direction.crossing(m.left[k], g) {
                m.record(&e.name, t, rising, y)?;
            }
            m.left[k] = g;
        }
        Ok(())
    }

    /// After the switch events that fired at `t` turned their effects,
    /// with the state `y`: refuses a sliding mode, a switch event at its
    /// level whose quantity the new forces move across it in its own
    /// direction at once (its `g` on the linear motion over `t +- d`, `d`
    /// a millionth of the last step, under the new forces) and whose
    /// switch would change the forces back.
    ///
    /// # Errors
    /// [`SimError::SlidingMode`] naming both switches; as [`Dynamics::rhs`].
    fn sliding_mode(&mut self, sys: &mut Dynamics<M>, t: f64, y: &[f64]) -> Result<(), SimError> {
        let nf = sys.friction.len();
        let w = &mut self.slip;
        let Some(j_fired) = (0..w.switches.len()).find(|&j| w.times[nf + j] <= t) else { return Ok(()) };
        let d = (1e-6 * self.last_step).max(64.0 * f64::EPSILON * t.abs().max(1.0));
        let mut dy = vec![0.0; y.len()];
        sys.rhs(t, y, &mut dy)?;
        let ahead: Vec<f64> = y.iter().zip(&dy).map(|(y, d_)| y + d * d_).collect();
        for &k in &w.switches {
            let e = &sys.events[k];
            let changes =
                e.switch_on.iter().any(|&i| !sys.effects[i].on) || e.switch_off.iter().any(|&i| sys.effects[i].on);
            if !changes {
                continue;
            }
            let g0 = e.value(sys, t, y, &mut w.values);
            let g1 = e.value(sys, t + d, &ahead, &mut w.values);
            if e.direction.crossing(2.0 * g0 - g1, g1).is_some() {
                let event = sys.events[w.switches[j_fired]].name.clone();
                return Err(SimError::SlidingMode { event, undo: e.name.clone(), t });
            }
        }
        Ok(())
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
    fn switch_form<F: Integrand<M>>(
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

    /// Hands the run over to the DAE at `t` (`why`): its settings and a
    /// projector with the released rows, and a note; the first hand-over
    /// for a skate's slide is noted, the later ones are counted.
    #[cold]
    fn note_handover(&mut self, sys: &Dynamics<M>, t: f64, dae: &'a RunSettings, why: &str) {
        self.settings = dae;
        self.proj = Projector::<M>::new(&sys.model, dae.projection, &sys.mass).with_drives(&sys.drives);
        let rows = sys.released_rows();
        self.proj.release(rows);
        self.resid.released.set(&sys.info.pattern, rows);
        self.summary.projection_path = self.proj.path();
        self.summary.handovers += 1;
        if self.summary.handovers == 1 {
            self.observer.note(&format!(
                "{why}: the DAE, projected with {}, takes over from t = {t:.6} s{}",
                dae.projection.name(),
                if self.hand_back { " until every skate sticks again" } else { "" }
            ));
        }
    }

    /// Ends a run at the event at `t_stop` inside the step from `t`: the
    /// outputs before it from the step's dense output, then the event's
    /// state ([`Run::stop`]) as the last sample.
    fn emit_stop<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        t_stop: f64,
        n_out: &mut u64,
        interpolate: impl Fn(f64, &mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        while self.output_due(*n_out, t_stop) && self.out_time(*n_out) < t_stop {
            let t_out = self.out_time(*n_out);
            if self.wanted(t_out) {
                form.emit_dense(self, sys, t_out, |x| interpolate(t_out, x))?;
            }
            *n_out += 1;
        }
        self.emit_stop_state(sys, t_stop)
    }

    /// Queues the state of the event that stopped the run ([`Run::stop`]),
    /// at `t_stop`, as the last sample.
    fn emit_stop_state(&mut self, sys: &Dynamics<M>, t_stop: f64) -> Result<(), RunError<O::Error>> {
        let y = self.stop.take().expect("a stop has its state");
        let res = self.emit(sys, t_stop, &y);
        self.stop = Some(y);
        res
    }

    /// Queues the sample `(t, y)`; the queue goes to the observer when
    /// full ([`Run::flush`]), so the step loop only copies the state.
    fn emit(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), RunError<O::Error>> {
        self.queue(sys, t, Pending::Ready, |row| row.copy_from_slice(y))
    }

    /// Queues a sample at `t` whose state `fill` writes in place; `kind`:
    /// what is left to do before it is observed (a dense-output sample is
    /// projected, or expanded from minimal coordinates, then).
    #[inline(always)]
    fn queue(
        &mut self,
        sys: &Dynamics<M>,
        t: f64,
        kind: Pending,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        let ny = sys.ny();
        let kind = match kind {
            Pending::Project if self.settings.projection == ProjectionKind::None => Pending::Ready,
            kind => kind,
        };
        self.pending_kind.push(kind);
        self.pending.push(t);
        let start = self.pending.len();
        self.pending.resize(start + ny, 0.0);
        fill(&mut self.pending[start..]);
        if self.pending.len() + ny + 1 > self.pending.capacity() {
            self.flush(sys)?;
        }
        Ok(())
    }

    /// Where `red`'s deferred dense-output samples go in the full state
    /// ([`Run::sample_places`]), and the scratch to place one: set when a
    /// reduced formulation takes the run (not in the step loop).
    fn place_samples_of(&mut self, red: &Reduced, sys: &Dynamics<M>) {
        if red.defers_samples() {
            self.sample_places = red.sample_places(sys.ny());
            self.sample_z = vec![0.0; self.sample_places.len()];
        }
    }

    /// Hands the queued samples to the observer, each with its kinetic
    /// energy, work and residuals (computed here, once per sample, off the
    /// step loop). Its time is left out of the integration time.
    fn flush(&mut self, sys: &Dynamics<M>) -> Result<(), RunError<O::Error>> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let clock = Instant::now();
        let mut pending = std::mem::take(&mut self.pending);
        let kinds = std::mem::take(&mut self.pending_kind);
        let places = std::mem::take(&mut self.sample_places);
        let mut z = std::mem::take(&mut self.sample_z);
        z.resize(places.len(), 0.0);
        let res = pending.chunks_exact_mut(sys.ny() + 1).zip(&kinds).try_for_each(|(row, &kind)| {
            let (t, y) = row.split_first_mut().expect("a row holds its time");
            match kind {
                Pending::Ready => return self.observe(sys, *t, y),
                Pending::Expand => {
                    z.copy_from_slice(&y[..places.len()]);
                    y.fill(0.0);
                    for (&v, &j) in z.iter().zip(&places) {
                        y[j] = v;
                    }
                    // the model said it has `minimal_state` when the run
                    // began; one that stops having it is refused, not
                    // written half-expanded (as a failure with its cause,
                    // which no hand-over to the DAE takes for its own:
                    // the rows queued with it are gone)
                    if !crate::formulation::reduced::complete_sample(&sys.model, sys.nq(), y) {
                        let error = SimError::Formulation {
                            reason: format!(
                                "at t = {} s the model's minimal_state gave no full state for a dense-output \
                                 sample, though it did at the start",
                                crate::names::fmt_value(*t)
                            ),
                        };
                        let cause = "Model::minimal_state's answer must be the same at every state".to_string();
                        return Err(RunError::Sim(SimError::Caused { error: Box::new(error), cause }));
                    }
                    return self.observe(sys, *t, y);
                }
                Pending::Project => {}
            }
            // a projected sample's residuals are the projection's own: its
            // last evaluation of phi, at the final q, and G qd with its G
            // there (the same numbers as evaluating them anew)
            let nq = sys.nq();
            let (q, rest) = y.split_at_mut(nq);
            let report = self.proj.project(&sys.model, *t, q, &mut rest[..nq])?;
            let rv = self.proj.velocity_residual(&sys.model, *t, &rest[..nq]);
            let (kinetic, work) = (sys.kinetic_energy(&y[nq..2 * nq]), sys.work(y));
            self.deliver(sys, *t, y, [kinetic, work, report.residual_position, rv])
        });
        self.pending = pending;
        self.pending.clear();
        self.pending_kind = kinds;
        self.pending_kind.clear();
        self.sample_places = places;
        self.sample_z = z;
        self.output_time += clock.elapsed();
        res
    }

    /// The observer's view of the sample `(t, y)`.
    fn observe(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), RunError<O::Error>> {
        let nq = sys.nq();
        let (q, rest) = y.split_at(nq);
        let qd = &rest[..nq];
        let (rp, rv) = self.resid.eval(&sys.model, &sys.drives, t, q, qd);
        self.deliver(sys, t, y, [sys.kinetic_energy(qd), sys.work(y), rp, rv])
    }

    /// Hands the sample `(t, y)` to the observer with its kinetic energy
    /// \[J\], work \[J\], `max|C(q)|` \[m\] and `max|G(q) qd|` \[m/s\].
    fn deliver(
        &mut self,
        sys: &Dynamics<M>,
        t: f64,
        y: &[f64],
        [kinetic, work, rp, rv]: [f64; 4],
    ) -> Result<(), RunError<O::Error>> {
        let nq = sys.nq();
        let (q, rest) = y.split_at(nq);
        let qd = &rest[..nq];
        self.summary.max_residual_position = self.summary.max_residual_position.max(rp);
        self.summary.max_residual_velocity = self.summary.max_residual_velocity.max(rv);
        for (quantity, value) in [
            ("the kinetic energy T", kinetic),
            ("the work W", work),
            ("the position residual max|C(q)|", rp),
            ("the velocity residual max|G(q) qd|", rv),
        ] {
            if !value.is_finite() {
                // the first sample is the initial state: no step made it
                let step = if t == 0.0 { 0.0 } else { self.last_step };
                let (dt, advice) = (step, self.advice(t, step));
                return Err(SimError::NonFinite { t, quantity: quantity.into(), value, dt, advice }.into());
            }
        }
        let sample = Sample {
            t,
            q,
            qd,
            kinetic_energy: kinetic,
            work,
            works: &y[2 * nq..],
            residual_position: rp,
            residual_velocity: rv,
        };
        self.observer.observe(sys, &sample).map_err(RunError::Output)
    }

    /// What to do about numbers that blew up in the step from `t` of size
    /// `h` ([`advice`], told how well the energy balance held up to the
    /// last accepted state).
    fn advice(&self, t: f64, h: f64) -> String {
        let balance = (self.summary.steps > 0).then(|| self.guard.balance());
        advice(self.settings.method, t, h, balance)
    }

    /// After an accepted step from `t` to `t_new`: non-finite check,
    /// projection, energy balance. Returns whether `y` was changed.
    fn after_step(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        y: &mut [f64],
        h: f64,
    ) -> Result<bool, SimError> {
        let nq = sys.nq();
        let method = self.settings.method;
        if let Some(k) = y.iter().position(|v| !v.is_finite()) {
            let quantity = format!("the state component `{}`", sys.state_name(k));
            return Err(SimError::NonFinite { t, quantity, value: y[k], dt: h, advice: self.advice(t, h) });
        }
        if sys.counters.singular_solves != self.singular.solves || self.singular.open.is_some() {
            self.track_singular(sys, t, t_new, &y[..nq])?;
        }
        self.singular.evals = sys.counters.rhs_evals;
        self.last_step = h;
        self.t_reached = t_new;
        let mut changed = false;
        self.proj.refine(sys.max_growth > NEAR_SINGULAR);
        sys.max_growth = 0.0;
        if self.settings.projection != ProjectionKind::None {
            let (q, rest) = y.split_at_mut(nq);
            let report = self.proj.project(&sys.model, t_new, q, &mut rest[..nq])?;
            self.summary.max_step_drift = self.summary.max_step_drift.max(report.drift_position);
            self.summary.projections += 1;
            changed = true;
        }
        let work = sys.work(y);
        let kinetic = sys.kinetic_energy(&y[nq..2 * nq]);
        let energy_error = (kinetic - self.t0_energy - work).abs();
        for (quantity, value) in [("the kinetic energy T", kinetic), ("the energy balance |T - T0 - W|", energy_error)]
        {
            if !value.is_finite() {
                let advice = self.advice(t, h);
                return Err(SimError::NonFinite { t: t_new, quantity: quantity.into(), value, dt: h, advice });
            }
        }
        self.summary.max_energy_error = self.summary.max_energy_error.max(energy_error);
        match self.guard.check(sys, t_new, y, kinetic, energy_error, self.settings.balance_limit) {
            Verdict::Fine => {}
            Verdict::Diverged { kinetic, given } => {
                let cause = if method.is_adaptive() {
                    format!(
                        "the forces did not supply it (it is not T0 + W), so {} made it while meeting its tolerance: a tighter {}, or {} if the scene is stiff",
                        method.name(),
                        crate::settings::Setting::Rtol,
                        crate::settings::Setting::Method(Method::Radau5)
                    )
                } else {
                    advice(method, t, h, None)
                };
                return Err(SimError::Diverged {
                    t: t_new,
                    quantity: "the kinetic energy T relative to the most energy the run was given",
                    value: kinetic / given,
                    limit: GROWTH_LIMIT,
                    dt: h,
                    advice: format!(
                        "T = {kinetic:.3e} J against {given:.3e} J (T0 + sum |W_e| at its largest, or the applied forces' work over the mechanism's size): the state diverged; {cause}"
                    ),
                });
            }
            Verdict::Balance { relative, error, scale, limit } if !method.is_adaptive() => {
                return Err(SimError::Diverged {
                    t: t_new,
                    quantity: "the energy balance |T - T0 - W| relative to the run's energy scale",
                    value: relative,
                    limit,
                    dt: h,
                    advice: format!(
                        "|T - T0 - W| = {error:.3e} J against {scale:.3e} J, the largest energy the run has handled; {}",
                        advice(method, t, h, None)
                    ),
                });
            }
            Verdict::Balance { relative, error, scale, limit } => {
                if self.summary.energy_drift.is_none() {
                    self.summary.energy_drift = Some((t_new, relative));
                    let s = self.settings;
                    self.observer.note(&drift_note(method, s.rtol, s.atol, limit, t_new, [relative, error, scale]));
                }
            }
        }
        self.summary.steps += 1;
        Ok(changed)
    }

    /// After an accepted step from `t` to `t_new` (positions `q`) whose
    /// KKT solves found `G` rank-deficient, or the first after such
    /// steps: opens a passage, closes it with a note when a step has no
    /// singular solve, and stops the run when every solve of
    /// [`SINGULAR_PERSIST_STEPS`] steps in a row was singular.
    #[cold]
    fn track_singular(&mut self, sys: &Dynamics<M>, t: f64, t_new: f64, q: &[f64]) -> Result<(), SimError> {
        let c = sys.counters;
        let (solves, evals) = (c.singular_solves - self.singular.solves, c.rhs_evals - self.singular.evals);
        self.singular.solves = c.singular_solves;
        if solves == 0 {
            if let Some((t0, n)) = self.singular.open.take() {
                self.summary.singular_passages.push((t0, n));
                self.observer.note(&singular_note(t0, n));
            }
            self.singular.persistent = 0;
            return Ok(());
        }
        // rows dependent only in the mass-weighted metric, with masses too
        // far apart for double precision: no singular position but the
        // precision's limit, told as before (the caller adds the cause)
        if self.singular.open.is_none() && mass_spread(&sys.mass) > crate::error::MASS_SPREAD_WARNING {
            let info = &sys.info;
            if crate::kkt::dependent_row(&sys.model, info, q, None) == Ok(None) {
                let row = crate::kkt::dependent_row(&sys.model, info, q, Some(&sys.mass)).ok().flatten().unwrap_or(0);
                return Err(SimError::from_kkt(info, t, KktError::DependentConstraints { n: info.nc(), row }));
            }
        }
        let open = self.singular.open.get_or_insert((t, 0));
        open.1 += solves;
        if solves < evals {
            self.singular.persistent = 0;
            return Ok(());
        }
        if self.singular.persistent == 0 {
            self.singular.since = t;
        }
        self.singular.persistent += 1;
        // steps in a row, or a hundredth of the run (a slow motion's few
        // long steps): never the few stages of a passage
        let span = t_new - self.singular.since;
        if self.singular.persistent < SINGULAR_PERSIST_STEPS
            && (self.singular.persistent < 2 || span < 0.01 * self.settings.t_end)
        {
            return Ok(());
        }
        // which row: in the Euclidean metric, else in the mass-weighted one
        // (masses too far apart for double precision)
        let info = &sys.info;
        let Some(row) = crate::kkt::dependent_row(&sys.model, info, q, None)
            .ok()
            .flatten()
            .or_else(|| crate::kkt::dependent_row(&sys.model, info, q, Some(&sys.mass)).ok().flatten())
        else {
            // ill-conditioned here, not singular: the regularized solves
            // are exact to rounding
            self.singular.persistent = 0;
            return Ok(());
        };
        Err(SimError::SingularPersists {
            t0: self.singular.since,
            t1: t_new,
            steps: self.singular.persistent,
            constraint: info.constraints.get(row).cloned().unwrap_or_default(),
            row,
            before: crate::names::name_list(&info.constraints[..row.min(info.constraints.len())]),
        })
    }

    /// At the end of a run: a singular position passed in its last steps
    /// gets its note too.
    fn close_singular(&mut self) {
        if let Some((t0, n)) = self.singular.open.take() {
            self.summary.singular_passages.push((t0, n));
            self.observer.note(&singular_note(t0, n));
        }
    }

    /// Before an adaptive method's step attempt from `t` with step `h`:
    /// the step budget, `h` cut to end at `t_end` (returns whether this is
    /// the last step), and a step at the rounding level of `t`, or of the
    /// run's own time scale for runs shorter than a second (a 1e-15 s run
    /// is not stiff), which stops the run: with `stage_failure`, an
    /// effect that failed at every step size, as the cause.
    fn begin_attempt(&self, t: f64, h: &mut f64, stage_failure: &mut Option<SimError>) -> Result<bool, SimError> {
        let settings = self.settings;
        let attempts = self.summary.steps + self.summary.rejected;
        if let Some(max) = settings.max_steps
            && attempts >= max
        {
            let estimate = if t > 0.0 { attempts as f64 * settings.t_end / t } else { f64::INFINITY };
            return Err(SimError::Budget {
                what: "steps",
                estimate,
                limit: max as f64,
                setting: crate::settings::Setting::MaxSteps,
                detail: format!("extrapolated from {attempts} step attempts to t = {t:.6e} s of {} s", settings.t_end),
            });
        }
        let last = t + *h >= settings.t_end * (1.0 - 1e-15);
        if last {
            *h = settings.t_end - t;
        }
        if h.abs() <= 16.0 * f64::EPSILON * t.abs().max(settings.t_end.min(1.0)) {
            return Err(stage_failure.take().unwrap_or(SimError::StepSizeTooSmall { t, h: *h }));
        }
        Ok(last)
    }

    /// The time of output number `k` (`k every`, the last one `t_end`).
    fn out_time(&self, k: u64) -> f64 {
        (k as f64 * self.settings.every).min(self.settings.t_end)
    }

    /// Whether an output at `t` \[s\] is the final one: within a relative
    /// 1e-12 of `t_end` (`k every` may round to just below it).
    fn at_end(&self, t: f64) -> bool {
        t >= self.settings.t_end * (1.0 - 1e-12)
    }

    /// Whether the output at `t` is to be observed: the final one always
    /// ([`Run::at_end`]), the others as the observer wants
    /// ([`Observer::wants`]).
    fn wanted(&self, t: f64) -> bool {
        if self.at_end(t) {
            return true;
        }
        let (from, until) = self.skip.get();
        if t >= from && t < until {
            return false;
        }
        if self.observer.wants(t) {
            return true;
        }
        self.skip.set((t, self.observer.next_wanted(t).clamp(t, self.settings.t_end)));
        false
    }

    /// The first output number at or after `n_out` that may be wanted:
    /// past the refused outputs before [`Run::skip`]'s end in one jump.
    fn skip_unwanted(&self, n_out: u64) -> u64 {
        let (from, until) = self.skip.get();
        let t = self.out_time(n_out);
        if t < from || t >= until {
            return n_out;
        }
        // the outputs before k lie before `until` (output k - 1 at least
        // one interval before it)
        n_out.max((until / self.settings.every).floor() as u64)
    }

    /// Whether output number `n_out` is due in a step ending at `t_new`.
    fn output_due(&self, n_out: u64, t_new: f64) -> bool {
        n_out as f64 * self.settings.every <= self.settings.t_end * (1.0 + 1e-12) && self.out_time(n_out) <= t_new
    }

    /// The outputs inside `(t, t_new]` of an accepted step, from the
    /// step's dense output `interpolate(t_out, out)` (in the integrator's
    /// state), queued with the output's work ([`Run::flush`], off the
    /// step loop); `n_out` counts them. An output at the step's end
    /// `t_new` is the accepted state `x_new` itself.
    fn emit_dense<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        t_new: f64,
        x_new: &[f64],
        n_out: &mut u64,
        interpolate: impl Fn(f64, &mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        while self.output_due(*n_out, t_new) {
            let t_out = self.out_time(*n_out);
            if !self.wanted(t_out) {
                *n_out = self.skip_unwanted(*n_out + 1);
                continue;
            }
            if t_out == t_new {
                form.emit(self, sys, t_out, x_new)?;
            } else {
                form.emit_dense(self, sys, t_out, |x| interpolate(t_out, x))?;
            }
            *n_out += 1;
        }
        Ok(())
    }

    /// Whether a wanted output falls inside the step ending at `t_new`,
    /// not on its end (only then is its dense output needed).
    fn output_inside(&self, n_out: u64, t_new: f64) -> bool {
        let mut k = n_out;
        while self.output_due(k, t_new) && self.out_time(k) < t_new {
            if self.wanted(self.out_time(k)) {
                return true;
            }
            k = self.skip_unwanted(k + 1);
        }
        false
    }

    /// The final time is always written: the accepted `x` at `t_end`
    /// unless output number `n_out - 1` was it.
    fn finish_dense<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        n_out: u64,
        x: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        let wrote_final = self.at_end((n_out - 1) as f64 * self.settings.every);
        if !wrote_final {
            form.emit(self, sys, self.settings.t_end, x)?;
        }
        Ok(())
    }
}

/// What is left to do to a queued sample before it is observed
/// ([`Run::flush`]): the work of the output, timed as such.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// Nothing: a state the step loop accepted.
    Ready,
    /// A dense-output sample of the DAE, projected onto the constraints.
    Project,
    /// A dense-output sample of the reduced formulation on minimal
    /// coordinates, queued as the integrator's state `z` at the row's
    /// start: placed into the full state ([`Run::sample_places`]), its
    /// dependent coordinates and its global rates computed
    /// ([`crate::formulation::reduced::complete_sample`]).
    Expand,
}

/// What the step loop integrates, `x' = F(t, x)`: the DAE's full state
/// ([`Dae`]: `x = y`, projected after each step) or the reduced one
/// ([`Reduced`]: `x = z`, expanded to `y` for every check and output).
trait Integrand<M: Model> {
    /// `dx = F(t, x)`.
    fn eval(&mut self, sys: &mut Dynamics<M>, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError>;
    /// After an accepted step from `t` to `t_new` of size `h`: the full
    /// state's checks ([`Run::after_step`]); returns whether `x` changed.
    /// `evaluated`: the step's last evaluation of `F` was at `x` (DOPRI5's
    /// last stage).
    #[expect(
        clippy::too_many_arguments,
        reason = "a step's state as the loop holds it, borrowed, no struct built per step"
    )]
    fn accept<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        x: &mut [f64],
        h: f64,
        evaluated: bool,
    ) -> Result<bool, SimError>;
    /// The full state `y` of the accepted `x` (as [`Integrand::accept`] left it).
    fn accepted_full<'a>(&'a self, x: &'a [f64]) -> &'a [f64];
    /// The full state `y` of a dense-output state `x` at `t` (the DAE's
    /// is `x` itself, unprojected).
    fn full_of<'a>(&'a mut self, sys: &Dynamics<M>, t: f64, x: &'a [f64]) -> Result<&'a [f64], SimError>;
    /// Whether its states are projected onto the constraints (the DAE's).
    fn projects(&self) -> bool {
        false
    }
    /// Queues the accepted state `x` at `t` as a sample.
    fn emit<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        x: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        run.emit(sys, t, self.accepted_full(x))
    }
    /// Queues the dense-output sample at `t` that `fill` writes (an `x`).
    fn emit_dense<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>>;
    /// The error norm of the attempt just made from `(t, x)` to `x_new`
    /// with its part normal to the constraints removed
    /// ([`Projector::remove_normal`]), or `None` where nothing is projected
    /// (the reduced formulation, `--projection none`). `ea`, `eb`: scratch
    /// (nx each).
    #[expect(
        clippy::too_many_arguments,
        reason = "a step's state as the loop holds it, borrowed, no struct built per step"
    )]
    fn tangential_error<O: Observer<M>, E: EmbeddedRk>(
        &mut self,
        _run: &mut Run<'_, M, O>,
        _sys: &Dynamics<M>,
        _stepper: &E,
        _step: (f64, f64, &Tolerance),
        _k1: &[f64],
        _x: &[f64],
        _x_new: &[f64],
        _scratch: (&mut [f64], &mut [f64]),
    ) -> Result<Option<f64>, SimError> {
        Ok(None)
    }
    /// Whether this formulation stops near a singular position so that
    /// the DAE can take over (see [`simulate`]): the reduced one, whose
    /// dependent coordinates are not determined there.
    fn hands_over_near_singular(&self) -> bool {
        false
    }
    /// After the accepted step's outputs: whether `x` was rewritten (a new
    /// partition), so that `F` there is to be evaluated again.
    fn settle(&mut self, _sys: &Dynamics<M>, _t: f64, _x: &mut [f64]) -> Result<bool, SimError> {
        Ok(false)
    }
    /// Whether `eval` solves the KKT system of the full state, so that
    /// the skates' margins are read from its multipliers (the DAE's).
    fn solves_kkt(&self) -> bool {
        false
    }
    /// The full state of the integrator state `x` at `t` into `out` (as
    /// [`Integrand::full_of`]).
    ///
    /// # Errors
    /// As [`Integrand::full_of`].
    fn full_into(&mut self, sys: &Dynamics<M>, t: f64, x: &[f64], out: &mut [f64]) -> Result<(), SimError> {
        out.copy_from_slice(self.full_of(sys, t, x)?);
        Ok(())
    }
    /// Forgets what was evaluated ahead at the accepted state (the
    /// forces changed there: a switch).
    fn forget_evaluation(&mut self) {}
    /// Whether the stages' evaluations may leave the full state partly
    /// unwritten ([`Reduced::set_lean_stages`]): a step loop whose accepted
    /// state is evaluated anew says so (not DOPRI5's, whose last stage
    /// is the accepted state's evaluation).
    fn lean_stages(&mut self, _on: bool) {}
}

/// The DAE formulation: `x = y = [q, qd, W]`.
struct Dae;

impl<M: Model> Integrand<M> for Dae {
    #[inline]
    fn eval(&mut self, sys: &mut Dynamics<M>, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError> {
        sys.rhs(t, x, dx)
    }
    fn accept<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        x: &mut [f64],
        h: f64,
        evaluated: bool,
    ) -> Result<bool, SimError> {
        let _ = evaluated;
        run.after_step(sys, t, t_new, x, h)
    }
    fn tangential_error<O: Observer<M>, E: EmbeddedRk>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        stepper: &E,
        (t_new, h, tol): (f64, f64, &Tolerance),
        k1: &[f64],
        x: &[f64],
        x_new: &[f64],
        (ea, eb): (&mut [f64], &mut [f64]),
    ) -> Result<Option<f64>, SimError> {
        if run.settings.projection == ProjectionKind::None {
            return Ok(None);
        }
        let nq = sys.nq();
        stepper.error_vectors(k1, h, ea, eb);
        for e in [&mut *ea, &mut *eb] {
            let (eq, rest) = e.split_at_mut(nq);
            run.proj.remove_normal(&sys.model, t_new, &x_new[..nq], eq, &mut rest[..nq])?;
        }
        Ok(Some(E::error_from(h, ea, eb, x, x_new, tol)))
    }
    fn accepted_full<'a>(&'a self, x: &'a [f64]) -> &'a [f64] {
        x
    }
    fn full_of<'a>(&'a mut self, _sys: &Dynamics<M>, _t: f64, x: &'a [f64]) -> Result<&'a [f64], SimError> {
        Ok(x)
    }
    fn projects(&self) -> bool {
        true
    }
    fn emit_dense<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        run.queue(sys, t, Pending::Project, fill)
    }
    fn solves_kkt(&self) -> bool {
        true
    }
}

impl<M: Model> Integrand<M> for Reduced {
    #[inline]
    fn eval(&mut self, sys: &mut Dynamics<M>, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError> {
        Reduced::eval(self, sys, t, x, dx)
    }
    fn accept<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        x: &mut [f64],
        h: f64,
        evaluated: bool,
    ) -> Result<bool, SimError> {
        if let Some(k) = x.iter().position(|v| !v.is_finite()) {
            let quantity = format!("the state component `{}`", self.state_name(sys, k));
            let advice = run.advice(t, h);
            return Err(SimError::NonFinite { t, quantity, value: x[k], dt: h, advice });
        }
        Reduced::accept(self, sys, t_new, x, evaluated)?;
        let mut full = std::mem::take(&mut self.scratch);
        full.clear();
        full.extend_from_slice(self.accepted());
        let res = run.after_step(sys, t, t_new, &mut full, h);
        self.scratch = full;
        res.map(|_| false)
    }
    fn accepted_full<'a>(&'a self, _x: &'a [f64]) -> &'a [f64] {
        self.accepted()
    }
    fn full_of<'a>(&'a mut self, sys: &Dynamics<M>, t: f64, x: &'a [f64]) -> Result<&'a [f64], SimError> {
        self.expand_sample(sys, t, x)?;
        Ok(self.full())
    }
    #[inline(always)]
    fn emit_dense<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        let nz = self.nz(sys.ny());
        if self.defers_samples() {
            // the interpolated `z` is the row until it is observed
            // (`Run::flush` places and completes it), off the step loop
            if run.sample_places.is_empty() {
                run.sample_places = self.sample_places(sys.ny());
            }
            return run.queue(sys, t, Pending::Expand, |row| fill(&mut row[..nz]));
        }
        let mut z = std::mem::take(&mut self.scratch);
        z.resize(nz, 0.0);
        fill(&mut z);
        let res = match self.expand_sample(sys, t, &z) {
            Ok(()) => run.queue(sys, t, Pending::Ready, |row| row.copy_from_slice(self.full())),
            Err(e) => Err(e.into()),
        };
        self.scratch = z;
        res
    }
    fn settle(&mut self, sys: &Dynamics<M>, t: f64, x: &mut [f64]) -> Result<bool, SimError> {
        self.repartition(sys, t, x)
    }
    fn hands_over_near_singular(&self) -> bool {
        true
    }
    fn forget_evaluation(&mut self) {
        Reduced::forget_evaluation(self);
    }
    fn lean_stages(&mut self, on: bool) {
        self.set_lean_stages(on);
    }
}

/// A formulation bound to its dynamics: the [`Rhs`] the steppers call.
struct Bound<'a, M: Model, F> {
    sys: &'a mut Dynamics<M>,
    form: &'a mut F,
}

impl<M: Model, F: Integrand<M>> Rhs for Bound<'_, M, F> {
    #[inline]
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.form.eval(self.sys, t, y, dy)
    }
}

/// Integrates `sys` from `y0 = [q, qd, W_1 .. W_k]` with the method of `settings`
/// and projection after every accepted step. Fixed-step methods output
/// every `every` seconds (rounded to whole steps); adaptive methods output
/// at exact multiples of `every` from the dense output of the step that
/// holds them (built on the projected step end), projected like the steps,
/// never shortening a step for it. Samples are queued and handed to the
/// observer in batches, projected and with their energies and residuals,
/// off the step loop: that work is the output's, left out of
/// [`Summary::integration_time`] (see [`Summary::output_time`]).
///
/// # Errors
/// [`RunError::Sim`] on a singular KKT system, a non-finite state (with
/// the time and the component) or a step size below rounding
/// ([`SimError::StepSizeTooSmall`]); [`RunError::Output`] if the observer fails.
pub fn simulate<M: Model, O: Observer<M>>(
    sys: &mut Dynamics<M>,
    y0: &[f64],
    settings: &RunSettings,
    observer: &mut O,
) -> Result<Summary, RunError<O::Error>> {
    // the step loop is compiled once per model, not once per model and
    // observer: it sees every observer as `Erased` (seven observer types
    // had made seven copies of it per model, most of the `ezy` crate's
    // build time). The observer is called per sample and per step, where
    // one indirect call is nothing against a right-hand side.
    let mut parked = Parked { observer, error: None, _model: std::marker::PhantomData };
    let result = simulate_erased(sys, y0, settings, &mut Erased(&mut parked));
    result.map_err(|e| match e {
        RunError::Sim(e) => RunError::Sim(e),
        RunError::Output(Stopped) => RunError::Output(parked.error.take().expect("a stopped run parked its error")),
    })
}

/// Sorts crossings by time (not generic: one copy of the sort).
fn in_time_order(found: &mut [Crossing]) {
    found.sort_by(|a, b| a.t.total_cmp(&b.t));
}

/// The observer's error, kept aside while the step loop unwinds.
#[derive(Debug)]
struct Stopped;

/// An observer whose error is parked ([`Stopped`] goes up instead).
struct Parked<'a, O: Observer<M>, M: Model> {
    observer: &'a mut O,
    error: Option<O::Error>,
    _model: std::marker::PhantomData<fn(&M)>,
}

/// Every observer as one type: what [`simulate`]'s step loop is compiled for.
struct Erased<'a, M: Model>(&'a mut dyn Observer<M, Error = Stopped>);

impl<M: Model, O: Observer<M>> Parked<'_, O, M> {
    fn park<T>(&mut self, r: Result<T, O::Error>) -> Result<T, Stopped> {
        r.map_err(|e| {
            self.error = Some(e);
            Stopped
        })
    }
}

impl<M: Model, O: Observer<M>> Observer<M> for Parked<'_, O, M> {
    type Error = Stopped;
    fn observe(&mut self, sys: &Dynamics<M>, sample: &Sample<'_>) -> Result<(), Stopped> {
        let r = self.observer.observe(sys, sample);
        self.park(r)
    }
    fn progress(&mut self, t: f64) {
        self.observer.progress(t);
    }
    fn note(&mut self, text: &str) {
        self.observer.note(text);
    }
    fn poll(&mut self, t: f64) -> Result<(), Stopped> {
        let r = self.observer.poll(t);
        self.park(r)
    }
    fn wants(&self, t: f64) -> bool {
        self.observer.wants(t)
    }
    fn next_wanted(&self, t: f64) -> f64 {
        self.observer.next_wanted(t)
    }
}

impl<M: Model> Observer<M> for Erased<'_, M> {
    type Error = Stopped;
    fn observe(&mut self, sys: &Dynamics<M>, sample: &Sample<'_>) -> Result<(), Stopped> {
        self.0.observe(sys, sample)
    }
    fn progress(&mut self, t: f64) {
        self.0.progress(t);
    }
    fn note(&mut self, text: &str) {
        self.0.note(text);
    }
    fn poll(&mut self, t: f64) -> Result<(), Stopped> {
        self.0.poll(t)
    }
    fn wants(&self, t: f64) -> bool {
        self.0.wants(t)
    }
    fn next_wanted(&self, t: f64) -> f64 {
        self.0.next_wanted(t)
    }
}

/// [`simulate`] for the one observer type the step loop is built for.
fn simulate_erased<M: Model>(
    sys: &mut Dynamics<M>,
    y0: &[f64],
    settings: &RunSettings,
    observer: &mut Erased<'_, M>,
) -> Result<Summary, RunError<Stopped>> {
    settings.validate()?;
    // before any formulation is built on it
    check_initial(sys, y0)?;
    // the skates with friction: their modes at the start
    let start_slides = sys.start_friction(0.0, y0)?;
    check_switches(sys)?;
    let (nq, nc) = (sys.info.nq(), sys.info.nc());
    // constraints dependent at every configuration are the model's error;
    // at an instant (this one included) they are a singular position
    if let Some(row) =
        crate::formulation::initial::redundant_row(&sys.model, &sys.info, &sys.drives, &sys.mass, &y0[..nq])
            .map_err(|source| SimError::from_kkt(&sys.info, 0.0, source))?
    {
        return Err(SimError::from_kkt(&sys.info, 0.0, KktError::DependentConstraints { n: nc, row }).into());
    }
    // the reduced formulation, built at y0 (auto keeps it only where its
    // dependent coordinates follow from one Newton step)
    let reduced = match settings.formulation {
        Formulation::Dae => None,
        Formulation::Reduced => Some(Reduced::new(sys, 0.0, y0)?),
        Formulation::Auto => {
            // minimal coordinates pay with the explicit methods
            // (docs/physics.md §6.2): fewer evaluations at equal error with
            // DOPRI5 and DOP853, cheaper ones with RK4; a numeric partition
            // only with one degree of freedom (§6.1)
            // (skates with friction release rows, switches restart: the DAE)
            let free = sys.baumgarte.is_none() && !sys.switches();
            let explicit = free && matches!(settings.method, Method::Dopri5 | Method::Dop853 | Method::Rk4);
            let minimal = explicit && sys.drives.is_empty() && sys.model.minimal_layout().is_ok();
            let numeric = free && Formulation::auto_takes_reduced(settings.method, nq, nc);
            ((minimal || numeric) && nc <= crate::formulation::reduced::MAX_CONSTRAINTS)
                .then(|| Reduced::new(sys, 0.0, y0).ok())
                .flatten()
                .filter(|r| if r.is_minimal() { minimal } else { numeric && r.is_linear() })
                // and only if it evaluates at the start: where it cannot
                // (masses spread beyond double precision), the DAE runs,
                // and fails, if it does, with the cause named
                .and_then(|mut r| {
                    let mut z = vec![0.0; r.nz(y0.len())];
                    r.gather(y0, &mut z);
                    let mut dz = vec![0.0; z.len()];
                    let counters = sys.counters;
                    let ok = Integrand::<M>::eval(&mut r, sys, 0.0, &z, &mut dz).is_ok();
                    sys.counters = counters;
                    ok.then_some(r)
                })
        }
    };
    let formulation = if reduced.is_some() { Formulation::Reduced } else { Formulation::Dae };
    // the DAE's settings, for a hand-over from the reduced formulation
    let dae_settings = settings;
    let reduced_settings;
    let settings = if formulation == Formulation::Reduced {
        if settings.method == Method::Radau5 {
            return Err(SimError::Formulation {
                reason: format!(
                    "RADAU5's Newton iteration is built on the DAE's KKT matrix; take {} or an explicit method",
                    crate::settings::Setting::Formulation(crate::settings::Formulation::Dae)
                ),
            }
            .into());
        }
        if sys.baumgarte.is_some() {
            return Err(SimError::Formulation {
                reason: format!(
                    "Baumgarte stabilization is for the DAE; the reduced formulation keeps the constraints without it: drop {} or take {}",
                    crate::settings::Setting::Baumgarte,
                    crate::settings::Setting::Formulation(crate::settings::Formulation::Dae)
                ),
            }
            .into());
        }
        // the constraints hold at every expanded state: nothing to project
        reduced_settings = RunSettings { projection: ProjectionKind::None, ..*settings };
        &reduced_settings
    } else {
        settings
    };
    sys.forget_waveforms();
    let effects_on: Vec<bool> = sys.effects.iter().map(|e| e.on).collect();
    let t0_energy = sys.kinetic_energy(&y0[nq..2 * nq]);
    let counters0 = sys.counters;
    let mut run = Run {
        settings,
        observer,
        proj: Projector::<M>::new(&sys.model, settings.projection, &sys.mass).with_drives(&sys.drives),
        resid: Residuals::new(&sys.info),
        t0_energy,
        guard: EnergyGuard::new(sys, y0),
        last_step: 0.0,
        t_reached: 0.0,
        t_start: 0.0,
        summary: Summary {
            method: settings.method,
            steps: 0,
            rejected: 0,
            counters: Counters::default(),
            projections: 0,
            formulation: Formulation::Dae,
            repartitions: 0,
            handovers: 0,
            minimal_coordinates: false,
            fused_rhs: false,
            integration_time: Duration::ZERO,
            output_time: Duration::ZERO,
            max_residual_position: 0.0,
            max_residual_velocity: 0.0,
            max_step_drift: 0.0,
            max_energy_error: 0.0,
            final_state: Vec::new(),
            kkt: sys.kkt_name(),
            projection_path: "none",
            ill_conditioned: None,
            newton: Default::default(),
            stiff: None,
            singular_passages: Vec::new(),
            energy_drift: None,
            events: Vec::new(),
            stopped: None,
        },
        output_time: Duration::ZERO,
        singular: SingularTrack {
            solves: sys.counters.singular_solves,
            evals: sys.counters.rhs_evals,
            ..SingularTrack::default()
        },
        pending: Vec::with_capacity(pending_rows(y0.len()) * (y0.len() + 1)),
        pending_kind: Vec::with_capacity(pending_rows(y0.len())),
        sample_places: Vec::new(),
        sample_z: Vec::new(),
        newton: Default::default(),
        monitor: Monitor::new(sys, 0.0, y0),
        event_x: Vec::new(),
        stop: None,
        slip: SlipWatch::default(),
        // the reduced formulation keeps every skate's row: the DAE runs
        // while one slides, and hands back when all stick
        hand_back: formulation == Formulation::Reduced && !sys.friction.is_empty(),
        handover: None,
        skip: std::cell::Cell::new((f64::INFINITY, f64::INFINITY)),
    };
    if sys.switches() {
        let (nf, w) = (sys.friction.len(), &mut run.slip);
        w.switches =
            (0..sys.events.len()).filter(|&k| sys.events[k].action == crate::events::spec::Action::Switch).collect();
        let n = nf + w.switches.len();
        (w.left, w.right, w.scratch, w.streaks) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; nf], vec![(0, 0.0, 0); n - nf]);
        (w.left_rate, w.right_rate, w.scratch_rate, w.eps) =
            (vec![0.0; nf], vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]);
        w.suspect = vec![false; nf];
        w.skate_streaks = vec![Default::default(); nf];
        w.times = vec![f64::INFINITY; n];
        w.t_left = run.t_start;
        if nf > 0 {
            let h = settings.dt.min(settings.t_end - run.t_start).max(f64::EPSILON);
            sys.slip_samples_at(run.t_start, h, y0, &mut w.left[..nf], &mut w.left_rate)?;
        }
        for (j, &k) in w.switches.iter().enumerate() {
            w.left[nf + j] = sys.events[k].value(sys, 0.0, y0, &mut w.values);
        }
        for &(k, old, mode) in &start_slides {
            run.monitor.record(&sys.friction[k].transition_name(old), 0.0, mode.is_sliding(), y0)?;
        }
        let rows = sys.released_rows();
        run.proj.release(rows);
        run.resid.released.set(&sys.info.pattern, rows);
    }
    run.summary.projection_path = run.proj.path();
    // minimal coordinates asked for and refused for a pivot: say why
    if settings.formulation == Formulation::Reduced
        && sys.drives.is_empty()
        && reduced.as_ref().is_some_and(|r| !r.is_minimal())
        && let Ok(layout) = sys.model.minimal_layout()
        && let Some((skate, p, rho)) = crate::formulation::reduced::small_pivot(&sys.info, &sys.mass, &layout)
    {
        let why = if rho > 0.0 {
            format!(
                "is {:.2e} m, below {} of its body's radius of gyration {rho:.3} m (an ill-conditioned speed)",
                p.abs(),
                crate::formulation::reduced::MIN_PIVOT_GYRATION
            )
        } else {
            format!("is {p} at these parameters")
        };
        run.observer.note(&format!(
            "minimal coordinates not taken: the pivot of skate `{skate}` (the distance along its blade from the hinge or centre of mass to the contact point) {why}; the reduced formulation runs on a numeric partition"
        ));
    }
    run.emit(sys, 0.0, y0)?;
    let start = Instant::now();
    let mut reduced = reduced;
    if let Some(red) = &reduced {
        run.summary.formulation = Formulation::Reduced;
        run.summary.projection_path = "none: the reduced formulation keeps the constraints";
        run.summary.minimal_coordinates = red.is_minimal();
        run.summary.fused_rhs = red.is_fused();
        run.place_samples_of(red, sys);
    }
    // a skate sliding at the start: the DAE first
    if run.hand_back && !sys.released_rows().is_empty() {
        reduced = None;
        run.note_handover(sys, 0.0, dae_settings, "a skate slides at the start");
    }
    let mut y = y0.to_vec();
    let result = loop {
        let r = match reduced.as_mut() {
            Some(red) => {
                let mut z = vec![0.0; red.nz(y.len())];
                red.gather(&y, &mut z);
                let r = integrate(sys, red, &mut z, &mut run);
                run.summary.repartitions += red.repartitions;
                red.repartitions = 0;
                y.copy_from_slice(Integrand::<M>::accepted_full(red, &z));
                r
            }
            None => integrate(sys, &mut Dae, &mut y, &mut run),
        };
        // a switch handed over: a skate began to slide (to the DAE), or
        // every one sticks again (back to the reduced formulation)
        if let (Ok(()), Some((t, state))) = (&r, run.handover.take()) {
            y = state;
            run.t_start = t;
            if reduced.take().is_some() {
                run.note_handover(sys, t, dae_settings, "a skate began to slide");
            } else {
                match Reduced::new(sys, t, &y) {
                    Ok(red) => {
                        run.place_samples_of(&red, sys);
                        run.summary.handovers += 1;
                        run.settings = settings;
                        run.proj = Projector::<M>::new(&sys.model, settings.projection, &sys.mass);
                        reduced = Some(red);
                    }
                    Err(e) => {
                        run.hand_back = false;
                        run.observer.note(&format!(
                            "the reduced formulation could not take over again at t = {t:.6} s ({e}): the DAE goes on"
                        ));
                    }
                }
            }
            continue;
        }
        // Where the dependent coordinates cannot be solved for (a
        // singular position: the partition's block of G loses rank with
        // G), an adaptive run hands over to the DAE, which passes it,
        // from the last accepted state. (RK4 refuses: a DAE that takes
        // over from it at the N-four-bar's first passage went 4e-3 rad
        // wrong at a later one with h = 1e-4 s, where the DAE from the
        // start is right; not yet understood.)
        if let Err(RunError::Sim(SimError::Formulation { reason })) = &r
            && reduced.is_some()
            && settings.method.is_adaptive()
            && dae_settings.formulation != Formulation::Dae
        {
            let t = run.t_reached;
            let why = format!("the reduced formulation stopped ({reason})");
            run.note_handover(sys, t, dae_settings, &why);
            run.hand_back = false;
            run.t_start = t;
            reduced = None;
            continue;
        }
        break r;
    };
    let final_state = y;
    // the samples queued before a failure are observed before it is
    // told; an observer that stopped the run (a signal) is not shown them:
    // it would stop again at the first of them and name its time, not the
    // time the run reached
    let result = match result {
        Err(RunError::Output(e)) => {
            restore_effects(sys, &effects_on);
            return Err(RunError::Output(e));
        }
        r => r,
    };
    let flushed = run.flush(sys);
    // the effects as they were before the run's switches
    restore_effects(sys, &effects_on);
    result?;
    flushed?;
    run.close_singular();
    let mut summary = run.summary;
    summary.integration_time = start.elapsed().saturating_sub(run.output_time);
    summary.output_time = run.output_time;
    summary.counters = Counters {
        rhs_evals: sys.counters.rhs_evals - counters0.rhs_evals,
        kkt_solves: sys.counters.kkt_solves - counters0.kkt_solves,
        singular_solves: sys.counters.singular_solves - counters0.singular_solves,
    };
    summary.final_state = run.stop.take().unwrap_or(final_state);
    summary.events = std::mem::take(&mut run.monitor.records);
    summary.newton = run.newton;
    summary.ill_conditioned = sys.ill_conditioned;
    Ok(summary)
}

/// Sets each effect of `sys` on or off as `on` says (one per effect).
fn restore_effects<M: Model>(sys: &mut Dynamics<M>, on: &[bool]) {
    for (e, &on) in sys.effects.iter_mut().zip(on) {
        e.on = on;
    }
}

/// Refuses a switch event ([`crate::events::spec::Action::Switch`]) whose
/// effects are not effects of `sys` or are a skate's friction, or that
/// names none: a library user's [`crate::events::spec::Event::switching`] is
/// checked here as a scene's `switch_on` is when it is resolved.
fn check_switches<M: Model>(sys: &Dynamics<M>) -> Result<(), SimError> {
    for e in sys.events.iter().filter(|e| e.action == crate::events::spec::Action::Switch) {
        let err = |field: &'static str, message: String| SimError::Event { event: e.name.clone(), field, message };
        if e.switch_on.is_empty() && e.switch_off.is_empty() {
            return Err(err("action", "a switch names the effects it turns on or off".into()));
        }
        for (field, list) in [("switch_on", &e.switch_on), ("switch_off", &e.switch_off)] {
            for &k in list {
                match sys.effects.get(k) {
                    None => {
                        return Err(err(
                            field,
                            format!("effect {k} does not exist: the run has {}", sys.effects.len()),
                        ));
                    }
                    Some(x) if matches!(x.law, crate::effects::law::Law::SkateFriction(_)) => {
                        return Err(err(
                            field,
                            format!("`{}` is a skate's friction: an event cannot switch it", x.name),
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
    }
    Ok(())
}

/// Refuses an initial state `y0` that is not finite, or whose kinetic
/// energy or work is not: no step size helps, so the error names the
/// component (or the velocity whose share of the kinetic energy
/// overflows) and says the scene's initial values are at fault.
fn check_initial<M: Model>(sys: &Dynamics<M>, y0: &[f64]) -> Result<(), SimError> {
    let nq = sys.nq();
    let at_start = |quantity: String, value: f64, why: &str| SimError::NonFinite {
        t: 0.0,
        quantity,
        value,
        dt: 0.0,
        advice: format!(
            "{why}: the scene's initial values or parameters are out of the range double precision can hold (no step size helps)"
        ),
    };
    if let Some(k) = y0.iter().position(|v| !v.is_finite()) {
        return Err(at_start(
            format!("the initial state component `{}`", sys.state_name(k)),
            y0[k],
            "the initial state is not finite",
        ));
    }
    let kinetic = sys.kinetic_energy(&y0[nq..2 * nq]);
    if !kinetic.is_finite() {
        // the velocity with the largest share m qd^2 / 2 of T
        let share = |k: usize| 0.5 * sys.mass[k] * y0[nq + k] * y0[nq + k];
        let k = (0..nq).max_by(|&a, &b| share(a).total_cmp(&share(b))).unwrap_or(0);
        return Err(at_start(
            "the kinetic energy T".into(),
            kinetic,
            &format!(
                "the initial velocity {} = {} (share m qd^2 / 2 = {}) makes the initial state's kinetic energy overflow",
                sys.state_name(nq + k),
                crate::names::fmt_value(y0[nq + k]),
                crate::names::fmt_value(share(k))
            ),
        ));
    }
    Ok(())
}

/// The step loop of the run's method on the formulation `form` from `x`.
fn integrate<M: Model, O: Observer<M>, F: Integrand<M>>(
    sys: &mut Dynamics<M>,
    form: &mut F,
    x: &mut [f64],
    run: &mut Run<'_, M, O>,
) -> Result<(), RunError<O::Error>> {
    let n = x.len();
    run.event_x.resize(n, 0.0);
    match run.settings.method {
        Method::Euler => fixed(sys, form, x, run, &mut Euler::new(n)),
        Method::Rk4 => fixed(sys, form, x, run, &mut Rk4::new(n)),
        Method::Dopri5 => adaptive::<M, O, F, Dopri5>(sys, form, x, run),
        Method::Dop853 => adaptive::<M, O, F, Dop853>(sys, form, x, run),
        Method::Radau5 => implicit(sys, x, run),
    }
}

/// Samples queued before they go to the observer: about 512 KiB of
/// states, at least one.
fn pending_rows(ny: usize) -> usize {
    (65_536 / (ny + 1)).clamp(1, 256)
}

/// A fixed-step method, for [`fixed`].
trait FixedStep {
    fn advance<R: Rhs>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError>;
    /// As `advance`, with `F(t, y)` known: `f0`.
    fn advance_from<R: Rhs>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64, f0: &[f64]) -> Result<(), SimError>;
    /// `F` at the start of the last step.
    fn start_slope(&self) -> &[f64];
}

impl FixedStep for Euler {
    #[inline]
    fn advance<R: Rhs>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError> {
        self.step(rhs, t, y, h)
    }
    fn advance_from<R: Rhs>(&mut self, _: &mut R, _: f64, y: &mut [f64], h: f64, f0: &[f64]) -> Result<(), SimError> {
        self.step_from(y, h, f0);
        Ok(())
    }
    fn start_slope(&self) -> &[f64] {
        Euler::start_slope(self)
    }
}

impl FixedStep for Rk4 {
    #[inline]
    fn advance<R: Rhs>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64) -> Result<(), SimError> {
        self.step(rhs, t, y, h)
    }
    fn advance_from<R: Rhs>(&mut self, rhs: &mut R, t: f64, y: &mut [f64], h: f64, f0: &[f64]) -> Result<(), SimError> {
        self.step_from(rhs, t, y, h, f0)
    }
    fn start_slope(&self) -> &[f64] {
        Rk4::start_slope(self)
    }
}

fn fixed<M: Model, O: Observer<M>, F: Integrand<M>, S: FixedStep>(
    sys: &mut Dynamics<M>,
    form: &mut F,
    x: &mut [f64],
    run: &mut Run<'_, M, O>,
    stepper: &mut S,
) -> Result<(), RunError<O::Error>> {
    let settings = run.settings;
    let n = settings.n_steps();
    let stride = settings.output_stride();
    // every accepted state is evaluated anew (`Integrand::accept`)
    form.lean_stages(true);
    // the step's start and the slopes at its ends, for the events' Hermite
    // interpolant (only with events)
    let watch = !sys.events.is_empty() || !sys.friction.is_empty();
    // (the step's start also restores a step that failed: the stepper
    // advances `x` in place, and a hand-over starts from the last state)
    let mut x_start = x.to_vec();
    let mut f_end = if watch { vec![0.0; x.len()] } else { Vec::new() };
    // skates with friction or switch events: the step is cut at a switch
    let friction = sys.switches();
    let mut x_cut = if friction { x.to_vec() } else { Vec::new() };
    // with friction, F at the step's end is evaluated for the skates'
    // margins; the next step starts from it (unless a switch changed it)
    let mut f_start = if friction { vec![0.0; x.len()] } else { Vec::new() };
    let mut f_known = false;
    let grid = |i: u64| if i == n { settings.t_end } else { i as f64 * settings.dt };
    // a hand-over's start (`run.t_start`) may lie between grid points: the
    // first step then goes from it to the next one
    let mut i0 = ((run.t_start / settings.dt).floor() as u64).min(n);
    while i0 < n && grid(i0 + 1) <= run.t_start {
        i0 += 1;
    }
    for i in i0..n {
        let (t, t_next) = (grid(i), grid(i + 1));
        // a skate's switch cuts the step there: the method restarts from
        // the switch to the grid point (Hairer, Nørsett & Wanner I, §II.6)
        let mut t_cur = if i == i0 { t.max(run.t_start) } else { t };
        loop {
            x_start.copy_from_slice(x);
            let advanced = if f_known {
                stepper.advance_from(&mut Bound { sys, form }, t_cur, x, t_next - t_cur, &f_start)
            } else {
                stepper.advance(&mut Bound { sys, form }, t_cur, x, t_next - t_cur)
            };
            if let Err(e) = advanced {
                x.copy_from_slice(&x_start);
                return Err(e.into());
            }
            // the reduced formulation hands over before a singular position,
            // from the step's start (as the adaptive methods do)
            if sys.max_growth > NEAR_SINGULAR && form.hands_over_near_singular() {
                x.copy_from_slice(&x_start);
                return Err(SimError::Formulation {
                    reason: format!(
                        "at t = {t_cur:.6} s a singular position is near (KKT conditioning {:.1e}), where the dependent coordinates are not determined",
                        sys.max_growth
                    ),
                }
                .into());
            }
            f_known = false;
            // the step as set (a cut step: what is left of it)
            let h = if t_cur == t { settings.dt } else { t_next - t_cur };
            form.accept(run, sys, t_cur, t_next, x, h, false)?;
            let slipped = friction && {
                form.eval(sys, t_next, x, &mut f_end)?;
                let evaluated = form.solves_kkt().then_some(&f_end[..]);
                run.slip_crossed(sys, t_next, form.accepted_full(x), evaluated)?
            };
            let mut t_end = t_next;
            if slipped {
                let f_start = stepper.start_slope();
                let interpolate = |tau: f64, out: &mut [f64]| {
                    crate::integrator::fixed::hermite((t_cur, &x_start, f_start), (t_next, x, &f_end), tau, out)
                };
                t_end = run.locate_slip(sys, (t_cur, t_next), |sys, tau, out| {
                    interpolate(tau, &mut x_cut);
                    form.full_into(sys, tau, &x_cut, out)
                })?;
                if t_end < t_next {
                    // the cut state accepted as a step's end (projected),
                    // counted with the step it cuts
                    interpolate(t_end, &mut x_cut);
                    form.accept(run, sys, t_cur, t_end, &mut x_cut, t_end - t_cur, false)?;
                    run.summary.steps -= 1;
                }
            }
            let x_end: &[f64] = if t_end < t_next { &x_cut } else { x };
            if run.event_crossed(form, sys, t_end, x_end) {
                if !friction {
                    form.eval(sys, t_next, x, &mut f_end)?;
                }
                let f_start = stepper.start_slope();
                let interpolate = |tau: f64, out: &mut [f64]| {
                    crate::integrator::fixed::hermite((t_cur, &x_start, f_start), (t_next, x, &f_end), tau, out)
                };
                if let Some(t_stop) = run.locate_events(form, sys, (t_cur, t_end), x_end, interpolate)? {
                    // every grid output before it is written
                    return run.emit_stop_state(sys, t_stop);
                }
            }
            if !slipped {
                if friction {
                    std::mem::swap(&mut f_start, &mut f_end);
                    f_known = true;
                }
                break;
            }
            if t_end < t_next {
                x.copy_from_slice(&x_cut);
            }
            if run.switch_form(form, sys, t_end, x)? {
                // the other formulation goes on from here; a sample due at
                // the grid point reached is written first
                if t_end == t_next && ((i + 1) % stride == 0 || i + 1 == n) {
                    form.emit(run, sys, t_next, x)?;
                }
                return Ok(());
            }
            if t_end == t_next {
                break;
            }
            t_cur = t_end;
        }
        run.observer.poll(t_next).map_err(RunError::Output)?;
        if ((i + 1) % stride == 0 && run.wanted(t_next)) || i + 1 == n {
            form.emit(run, sys, t_next, x)?;
        }
        if (i + 1) % (stride * 64) == 0 {
            run.observer.progress(t_next);
        }
        form.settle(sys, t_next, x)?;
    }
    Ok(())
}

fn adaptive<M: Model, O: Observer<M>, F: Integrand<M>, E: EmbeddedRk>(
    sys: &mut Dynamics<M>,
    form: &mut F,
    y: &mut [f64],
    run: &mut Run<'_, M, O>,
) -> Result<(), RunError<O::Error>> {
    let settings = run.settings;
    let ny = y.len();
    let tol = Tolerance { rtol: settings.rtol, atol: settings.atol };
    let mut stepper = E::new(ny);
    let mut ctl = Controller::default();
    let (mut k1, mut y_new, mut k_new) = (vec![0.0; ny], vec![0.0; ny], vec![0.0; ny]);
    let (mut w1, mut w2) = (vec![0.0; ny], vec![0.0; ny]);
    let mut t = run.t_start;
    // the accepted state is evaluated anew unless the last stage was it
    form.lean_stages(!E::FSAL_IN_ESTIMATE);
    form.eval(sys, t, y, &mut k1)?;
    let h_max = settings.t_end - t;
    let mut h = initial_step(&mut Bound { sys, form }, t, y, &k1, E::ORDER, &tol, h_max, &mut w1, &mut w2)?;
    // the tangential error's scratch (see `Integrand::tangential_error`)
    let (mut ea, mut eb) = (Vec::new(), Vec::new());
    // the last step size accepted away from a singular position [s] (the
    // first one until then)
    let mut h_far = h;
    // the KKT conditioning at the step's start (see SINGULAR_LANDING)
    let mut start_growth = sys.last_growth;
    // the first output after the start (all up to it are written)
    let mut n_out: u64 = (t / settings.every).floor() as u64 + 1;
    while run.out_time(n_out) <= t && n_out as f64 * settings.every <= settings.t_end {
        n_out += 1;
    }
    let mut stage_failure: Option<SimError> = None;
    let mut stiffness = crate::integrator::adaptive::StiffnessTest::default();
    while t < settings.t_end {
        let last = match run.begin_attempt(t, &mut h, &mut stage_failure) {
            Err(SimError::StepSizeTooSmall { t, h }) if sys.max_growth > NEAR_SINGULAR => {
                return Err(SimError::SingularTolerance { t, h, rtol: settings.rtol }.into());
            }
            other => other?,
        };
        sys.max_growth = 0.0;
        let mut err = match stepper.attempt(&mut Bound { sys, form }, t, y, &k1, h, &tol, &mut y_new, &mut k_new) {
            // a stage overflowed: as for a non-finite error estimate below
            Err(SimError::Kkt { source: KktError::NonFinite { .. }, .. }) => f64::NAN,
            // an effect failed at a stage, or the reduced formulation's
            // Newton iteration: perhaps the stage went too far (a stiff
            // scene at a step beyond the method's stability), so a smaller
            // step; the error is reported if no step helps
            Err(e @ (SimError::EffectFailed { .. } | SimError::Formulation { .. })) => {
                stage_failure = Some(e);
                f64::NAN
            }
            other => other?,
        };
        if !err.is_finite() {
            // a non-finite stage: retry with a much smaller step
            run.summary.rejected += 1;
            h *= 0.1;
            // a signal stops a run that rejects step after step too
            run.observer.poll(t).map_err(RunError::Output)?;
            continue;
        }
        // Near a singular position the estimate is dominated by a mode
        // normal to the constraints that grows like 1 / s at a distance s
        // (the branch of a bifurcation is unstable), and which the
        // projection removes: resolving it would shrink the steps onto the
        // singular time without end. Only the tangential error counts
        // there.
        if err > 1.0 && sys.max_growth > NEAR_SINGULAR {
            ea.resize(ny, 0.0);
            eb.resize(ny, 0.0);
            let t_new = if last { settings.t_end } else { t + h };
            let step = (t_new, h, &tol);
            if let Some(e) = form.tangential_error(run, sys, &stepper, step, &k1, y, &y_new, (&mut ea, &mut eb))? {
                err = e;
            }
        }
        let end_growth = sys.last_growth;
        let (mut accepted, mut h_next) = ctl.next::<E>(err, h);
        // A step that would end right next to a singular time (its last
        // stage, at t + h, conditioned SINGULAR_LANDING times worse than
        // its start: about 100 times closer, the growth going like
        // 1 / s^2) is taken half as long: from a state that close, every
        // later step's first stage sits on the singularity.
        if accepted && !last && end_growth > NEAR_SINGULAR && end_growth > SINGULAR_LANDING * start_growth {
            accepted = false;
            h_next = 0.5 * h;
        }
        let near = sys.max_growth > NEAR_SINGULAR;
        if !near && accepted {
            h_far = h;
        }
        if near && form.hands_over_near_singular() {
            return Err(SimError::Formulation {
                reason: format!(
                    "at t = {t:.6} s a singular position is near (KKT conditioning {:.1e}), where the dependent coordinates are not determined",
                    sys.max_growth
                ),
            }
            .into());
        }
        // Should that not be enough (the rounding of the positions, eps / s
        // along the other branch, amplified above the tolerance: not seen
        // on the N-four-bars down to rtol 1e-14), the step size collapses
        // onto the singular time: stop at once with the cause rather than
        // after thousands of steps at the rounding level of t.
        if !accepted && near && h_next < SINGULAR_COLLAPSE * h_far {
            return Err(SimError::SingularTolerance { t, h: h_next, rtol: settings.rtol }.into());
        }
        if !accepted {
            run.summary.rejected += 1;
            h = h_next;
            run.observer.poll(t).map_err(RunError::Output)?;
            continue;
        }
        stage_failure = None;
        let t_new = if last { settings.t_end } else { t + h };
        // the accepted state, projected, and F there: the next step's k1
        let projected = form.accept(run, sys, t, t_new, &mut y_new, h, E::FSAL_IN_ESTIMATE)?;
        if projected || !E::FSAL_IN_ESTIMATE {
            form.eval(sys, t_new, &y_new, &mut k_new)?;
        }
        start_growth = sys.last_growth;
        let hlambda = stiffness.due().then(|| stepper.stiffness(h, &y_new, &k_new));
        if stiffness.record(t_new, hlambda, E::STIFF_LIMIT)
            && let Some((t_stiff, hl)) = stiffness.found
        {
            run.summary.stiff = stiffness.found;
            run.observer.note(&stiff_note(settings.method, t_stiff, hl, E::STIFF_LIMIT));
        }
        // a skate's switch cuts the step there (its state from the dense
        // output, projected), and the method restarts from it: k1 anew
        let mut t_new = t_new;
        let evaluated = ((projected || !E::FSAL_IN_ESTIMATE) && form.solves_kkt()).then_some(&k_new[..]);
        let slipped = run.slip_crossed(sys, t_new, form.accepted_full(&y_new), evaluated)?;
        if slipped {
            stepper.prepare_dense(&mut Bound { sys, form }, t, y, &k1, h, &y_new, &k_new)?;
            let mut x = vec![0.0; ny];
            let t_switch = run.locate_slip(sys, (t, t_new), |sys, t_out, out| {
                stepper.interpolate((t_out - t) / h, &mut x);
                form.full_into(sys, t_out, &x, out)
            })?;
            if t_switch < t_new {
                stepper.interpolate((t_switch - t) / h, &mut y_new);
                form.accept(run, sys, t, t_switch, &mut y_new, t_switch - t, false)?;
                run.summary.steps -= 1;
                t_new = t_switch;
            }
        }
        // events and outputs inside (t, t_new] from the dense output, built
        // on the projected end point
        let crossed = run.event_crossed(form, sys, t_new, &y_new);
        if !slipped && (crossed || run.output_inside(n_out, t_new)) {
            stepper.prepare_dense(&mut Bound { sys, form }, t, y, &k1, h, &y_new, &k_new)?;
        }
        if crossed {
            let interpolate = |t_out: f64, out: &mut [f64]| stepper.interpolate((t_out - t) / h, out);
            if let Some(t_stop) = run.locate_events(form, sys, (t, t_new), &y_new, interpolate)? {
                return run.emit_stop(form, sys, t_stop, &mut n_out, interpolate);
            }
        }
        run.emit_dense(form, sys, t_new, &y_new, &mut n_out, |t_out, out| stepper.interpolate((t_out - t) / h, out))?;
        if slipped {
            if run.switch_form(form, sys, t_new, &mut y_new)? {
                return Ok(());
            }
            form.eval(sys, t_new, &y_new, &mut k_new)?;
            // a margin the step did not resolve: the next ones shorter
            if let Some(h_max) = run.slip.h_max.take() {
                h_next = h_next.min(h_max);
            }
        }
        // every 64 attempts, also when no output is due for long (tiny steps)
        if (run.summary.steps + run.summary.rejected).is_multiple_of(64) {
            run.observer.progress(t_new);
        }
        // a new partition restarts the method from the same state
        if form.settle(sys, t_new, &mut y_new)? {
            form.eval(sys, t_new, &y_new, &mut k_new)?;
        }
        y.copy_from_slice(&y_new);
        k1.copy_from_slice(&k_new);
        t = t_new;
        h = h_next;
        run.observer.poll(t).map_err(RunError::Output)?;
    }
    // the final time is always written
    run.finish_dense(form, sys, n_out, y)
}

/// A step size collapsed by this factor near a singular position, against
/// the last step taken away from it, stops an adaptive run with
/// [`SimError::SingularTolerance`] (see [`adaptive`]).
const SINGULAR_COLLAPSE: f64 = 1e-4;
/// Ratio of the KKT conditioning at a step's end to that at its start
/// above which (and above [`NEAR_SINGULAR`] at the end) the step is halved
/// (see [`adaptive`]).
const SINGULAR_LANDING: f64 = 1e4;

/// The step loop of the implicit method (RADAU5): as [`adaptive`], with
/// the Newton system of the model ([`crate::formulation::newton::KktNewton`]).
fn implicit<M: Model, O: Observer<M>>(
    sys: &mut Dynamics<M>,
    y: &mut [f64],
    run: &mut Run<'_, M, O>,
) -> Result<(), RunError<O::Error>> {
    use crate::integrator::radau5::{Attempt, Radau5};
    let settings = run.settings;
    let ny = y.len();
    let tol = Tolerance { rtol: settings.rtol, atol: settings.atol };
    let mut stepper = Radau5::new(ny, &tol);
    let mut newton = crate::formulation::newton::KktNewton::new(sys);
    let (mut f, mut y_new) = (vec![0.0; ny], vec![0.0; ny]);
    let (mut w1, mut w2) = (vec![0.0; ny], vec![0.0; ny]);
    sys.rhs(0.0, y, &mut f)?;
    // the first step as for the order-3 error estimate
    let mut h = initial_step(sys, 0.0, y, &f, 3, &tol, settings.t_end, &mut w1, &mut w2)?;
    let mut t = 0.0;
    let mut n_out: u64 = 1;
    while t < settings.t_end {
        let last = run.begin_attempt(t, &mut h, &mut stepper.stage_failure)?;
        let mut h_next = match stepper.attempt(sys, &mut newton, t, y, &f, h, &mut y_new)? {
            Attempt::Rejected { h_next } => {
                run.summary.rejected += 1;
                h = h_next;
                run.newton = stepper.stats;
                run.observer.poll(t).map_err(RunError::Output)?;
                continue;
            }
            Attempt::Accepted { h_next } => h_next,
        };
        let mut t_new = if last { settings.t_end } else { t + h };
        // the accepted state projected first: an output at t_new is it
        run.after_step(sys, t, t_new, &mut y_new, h)?;
        let interpolate = |t_out: f64, out: &mut [f64]| stepper.interpolate((t_out - t) / h, out);
        // a skate's switch or a switching event cuts the step there (its
        // state from the collocation polynomial, projected); the method
        // restarts from it (see `adaptive`)
        let slipped = run.slip_crossed(sys, t_new, &y_new, None)?;
        if slipped {
            let t_switch = run.locate_slip(sys, (t, t_new), |_, t_out, out| {
                interpolate(t_out, out);
                Ok(())
            })?;
            if t_switch < t_new {
                interpolate(t_switch, &mut y_new);
                run.after_step(sys, t, t_switch, &mut y_new, t_switch - t)?;
                run.summary.steps -= 1;
                t_new = t_switch;
            }
        }
        if run.event_crossed(&Dae, sys, t_new, &y_new)
            && let Some(t_stop) = run.locate_events(&mut Dae, sys, (t, t_new), &y_new, interpolate)?
        {
            return run.emit_stop(&mut Dae, sys, t_stop, &mut n_out, interpolate);
        }
        run.emit_dense(&mut Dae, sys, t_new, &y_new, &mut n_out, interpolate)?;
        if slipped {
            if run.switch_form(&mut Dae, sys, t_new, &mut y_new)? {
                return Ok(());
            }
            stepper.restart();
            if let Some(h_max) = run.slip.h_max.take() {
                h_next = h_next.min(h_max);
            }
        }
        if (run.summary.steps + run.summary.rejected).is_multiple_of(64) {
            run.observer.progress(t_new);
        }
        y.copy_from_slice(&y_new);
        sys.rhs(t_new, y, &mut f)?;
        t = t_new;
        h = h_next;
        run.newton = stepper.stats;
        run.observer.poll(t).map_err(RunError::Output)?;
    }
    run.finish_dense(&mut Dae, sys, n_out, y)
}
