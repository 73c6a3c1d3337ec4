//! The state of a run while it steps ([`Run`]): the projection, the
//! residuals, the energy guard, the singular positions passed, the
//! events' watch, the hand-overs between the formulations and what is
//! left to do to a queued sample ([`Pending`]). The switches' watch is in
//! [`super::watch`] (at work in [`super::slip`]), the output queue in
//! [`super::output`]; the loop that drives it all is [`super::driver`],
//! which also locates the events in a step and switches the formulation.

use std::time::Duration;

use crate::error::KktError;
use crate::error::{SimError, advice};
use crate::formulation::dae::NEAR_SINGULAR;
use crate::formulation::dae::{Counters, Dynamics};
use crate::formulation::projection::{Projector, max_abs};
use crate::model::Model;
use crate::settings::{Formulation, Message, Method, ProjectionKind, RunSettings, Setting};
use crate::simulate::events::Monitor;
use crate::simulate::guard::{EnergyGuard, GROWTH_LIMIT, Verdict, drift_note};
use crate::simulate::observer::{Observer, Summary, singular_note};
use crate::simulate::watch::SlipWatch;

/// Accepted steps in a row whose every KKT solve found `G` rank-deficient
/// after which a run stops with [`SimError::SingularPersists`] (or two
/// such steps spanning a hundredth of the run): a singular position that
/// the motion passes is met by a few stages of one or two steps (the rank
/// returns on either side), one the motion stays in by every stage of
/// every step.
pub const SINGULAR_PERSIST_STEPS: u64 = 8;

/// The singular position being passed, for [`Run::track_singular`].
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct SingularTrack {
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

/// Residual evaluation buffers.
#[derive(Debug, Clone)]
pub(super) struct Residuals {
    phi: Vec<f64>,
    g_values: Vec<f64>,
    pattern: Vec<(usize, usize)>,
    ones: Vec<f64>,
    r: Vec<f64>,
    /// Rows left out of `G qd` (sliding skates).
    pub(super) released: crate::formulation::friction::Released,
}

impl Residuals {
    pub(super) fn new(i: &crate::model::info::ModelInfo) -> Self {
        Self {
            phi: vec![0.0; i.n_holonomic],
            g_values: vec![0.0; i.pattern.len()],
            pattern: i.pattern.clone(),
            ones: vec![1.0; i.nq()],
            r: vec![0.0; i.nc()],
            released: Default::default(),
        }
    }
    pub(super) fn eval<M: Model>(
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

/// The index of the first component of `v` that is not finite, if any:
/// one pass of arithmetic first (`x - x` is 0 for a finite `x` and NaN
/// for an infinite or NaN one; their sum is 0 exactly when every
/// component is finite, in four lanes that the compiler keeps in two
/// vector registers), the search only where that pass found one. The
/// check of every accepted state, about half the instructions of a
/// search that tests each component in turn.
#[expect(clippy::eq_op, reason = "`x - x` is the test: 0 for a finite `x`, NaN for any other")]
#[inline]
pub(super) fn first_non_finite(v: &[f64]) -> Option<usize> {
    let mut lanes = [0.0f64; 4];
    let mut chunks = v.chunks_exact(4);
    for c in &mut chunks {
        for (l, x) in lanes.iter_mut().zip(c) {
            *l += x - x;
        }
    }
    let mut sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for x in chunks.remainder() {
        sum += x - x;
    }
    if sum == 0.0 { None } else { v.iter().position(|x| !x.is_finite()) }
}

/// Samples queued before they go to the observer: about 512 KiB of
/// states, at least one.
pub(super) fn pending_rows(ny: usize) -> usize {
    (65_536 / (ny + 1)).clamp(1, 256)
}

/// What is left to do to a queued sample before it is observed
/// ([`Run::flush`]): the work of the output, timed as such.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Pending {
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

/// The state of a run while it steps ([`super::driver::drive`] goes
/// through it): projection, residuals, energy balance, output timing.
pub(super) struct Run<'a, M: Model, O: Observer<M>> {
    pub(super) settings: &'a RunSettings,
    pub(super) observer: &'a mut O,
    pub(super) proj: Projector<M>,
    pub(super) resid: Residuals,
    pub(super) t0_energy: f64,
    /// The singular position being passed, if any.
    pub(super) singular: SingularTrack,
    /// The energy balance's scales ([`crate::simulate::guard`]).
    pub(super) guard: EnergyGuard,
    /// Size of the last step \[s\] (0 before the first).
    pub(super) last_step: f64,
    /// The time of the last accepted step \[s\] (where a hand-over from
    /// the reduced formulation to the DAE starts).
    pub(super) t_reached: f64,
    /// The time the step loop starts at \[s\]: 0, or the hand-over's.
    pub(super) t_start: f64,
    pub(super) summary: Summary,
    pub(super) output_time: Duration,
    /// Samples `(t, y)` not yet observed, row after row: the first
    /// `pending_len` entries; the rest is room for more rows (written in
    /// place, so that queueing a row writes only its numbers).
    pub(super) pending: Vec<f64>,
    pub(super) pending_len: usize,
    /// For each of them: what is left to do before it is observed.
    pub(super) pending_kind: Vec<Pending>,
    /// Where a [`Pending::Expand`] row's integrator state goes in the full
    /// state `[q, qd, W]`: index `i` of `z` to `sample_places[i]`
    /// ([`crate::formulation::reduced::Reduced::sample_places`]); empty until the first such row.
    pub(super) sample_places: Vec<usize>,
    /// Scratch for one such row's `z` while it is placed.
    pub(super) sample_z: Vec<f64>,
    pub(super) newton: crate::integrator::stepper::NewtonStats,
    /// The events' watch ([`crate::events`]).
    pub(super) monitor: Monitor,
    /// An integrator state's scratch for locating events.
    pub(super) event_x: Vec<f64>,
    /// The full state at the event that stopped the run.
    pub(super) stop: Option<Vec<f64>>,
    /// The skates with friction: their switches' watch.
    pub(super) slip: SlipWatch,
    /// Whether the DAE hands back to the reduced formulation when every
    /// skate sticks again (a run asked for the reduced one, with friction).
    pub(super) hand_back: bool,
    /// Where the step loop handed over to the other formulation, and the
    /// full state there ([`Run::switch_form`]).
    pub(super) handover: Option<(f64, Vec<f64>)>,
    /// Outputs in `[from, until)` \[s\] are not wanted: `from` an output
    /// the observer refused, `until` its [`Observer::next_wanted`] (at
    /// most `t_end`).
    pub(super) skip: std::cell::Cell<(f64, f64)>,
}

impl<'a, M: Model, O: Observer<M>> Run<'a, M, O> {
    /// A run of `sys` from `y0` with `settings` (the projection they ask
    /// for, the energy guard and the events' watch set at `y0`);
    /// `hand_back`: whether the DAE hands back to the reduced formulation
    /// when every skate sticks again.
    pub(super) fn new(
        sys: &Dynamics<M>,
        y0: &[f64],
        settings: &'a RunSettings,
        observer: &'a mut O,
        hand_back: bool,
    ) -> Self {
        let t0_energy = sys.kinetic_energy(&y0[sys.nq()..2 * sys.nq()]);
        Run {
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
            pending_len: 0,
            pending_kind: Vec::with_capacity(pending_rows(y0.len())),
            sample_places: Vec::new(),
            sample_z: Vec::new(),
            newton: Default::default(),
            monitor: Monitor::new(sys, 0.0, y0),
            event_x: Vec::new(),
            stop: None,
            slip: SlipWatch::default(),
            hand_back,
            handover: None,
            skip: std::cell::Cell::new((f64::INFINITY, f64::INFINITY)),
        }
    }

    /// What to do about numbers that blew up in the step from `t` of size
    /// `h` ([`advice`], told how well the energy balance held up to the
    /// last accepted state).
    pub(super) fn advice(&self, t: f64, h: f64) -> Message {
        let balance = (self.summary.steps > 0).then(|| self.guard.balance());
        advice(self.settings.method, t, h, balance)
    }

    /// After an accepted step from `t` to `t_new`: non-finite check,
    /// projection, energy balance. Returns whether `y` was changed.
    pub(super) fn after_step(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        y: &mut [f64],
        h: f64,
    ) -> Result<bool, SimError> {
        let nq = sys.nq();
        let method = self.settings.method;
        if let Some(k) = first_non_finite(y) {
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
        if !(kinetic.is_finite() && energy_error.is_finite()) {
            return Err(self.energy_non_finite(t, t_new, h, kinetic, energy_error));
        }
        self.summary.max_energy_error = self.summary.max_energy_error.max(energy_error);
        match self.guard.check(sys, t_new, y, kinetic, energy_error, self.settings.balance_limit) {
            Verdict::Fine => {}
            Verdict::Diverged { kinetic, given } => {
                let cause = if method.is_adaptive() {
                    Message::text(format!(
                        "the forces did not supply it (it is not T0 + W), so {} made it while meeting its tolerance: a tighter ",
                        method.name()
                    ))
                    .setting(Setting::Rtol)
                    .then(", or ")
                    .setting(Setting::Method(Method::Radau5))
                    .then(" if the scene is stiff")
                } else {
                    advice(method, t, h, None)
                };
                return Err(SimError::Diverged {
                    t: t_new,
                    quantity: "the kinetic energy T relative to the most energy the run was given",
                    value: kinetic / given,
                    limit: GROWTH_LIMIT,
                    dt: h,
                    advice: Message::text(format!(
                        "T = {kinetic:.3e} J against {given:.3e} J (T0 + sum |W_e| at its largest, or the applied forces' work over the mechanism's size): the state diverged; "
                    ))
                    .join(cause),
                });
            }
            Verdict::Balance { relative, error, scale, limit } if !method.is_adaptive() => {
                return Err(SimError::Diverged {
                    t: t_new,
                    quantity: "the energy balance |T - T0 - W| relative to the run's energy scale",
                    value: relative,
                    limit,
                    dt: h,
                    advice: Message::text(format!(
                        "|T - T0 - W| = {error:.3e} J against {scale:.3e} J, the largest energy the run has handled; "
                    ))
                    .join(advice(method, t, h, None)),
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

    /// The error of [`Run::after_step`] for a kinetic energy or an energy
    /// balance that is not finite after the step from `t` of size `h` to
    /// `t_new` (the energy named first if both are not).
    #[cold]
    #[inline(never)]
    fn energy_non_finite(&self, t: f64, t_new: f64, h: f64, kinetic: f64, energy_error: f64) -> SimError {
        let (quantity, value) = if kinetic.is_finite() {
            ("the energy balance |T - T0 - W|", energy_error)
        } else {
            ("the kinetic energy T", kinetic)
        };
        SimError::NonFinite { t: t_new, quantity: quantity.into(), value, dt: h, advice: self.advice(t, h) }
    }

    /// After an accepted step from `t` to `t_new` (positions `q`) whose
    /// KKT solves found `G` rank-deficient, or the first after such
    /// steps: opens a passage, closes it with a note when a step has no
    /// singular solve, and stops the run when every solve of
    /// [`SINGULAR_PERSIST_STEPS`] steps in a row was singular.
    #[cold]
    pub(super) fn track_singular(&mut self, sys: &Dynamics<M>, t: f64, t_new: f64, q: &[f64]) -> Result<(), SimError> {
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
    pub(super) fn close_singular(&mut self) {
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
    #[inline]
    pub(super) fn begin_attempt(
        &self,
        t: f64,
        h: &mut f64,
        stage_failure: &mut Option<SimError>,
    ) -> Result<bool, SimError> {
        let settings = self.settings;
        let attempts = self.summary.steps + self.summary.rejected;
        if let Some(max) = settings.max_steps
            && attempts >= max
        {
            return Err(self.over_budget(t, attempts, max));
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

    /// The error of [`Run::begin_attempt`] at `t` once `attempts` reached
    /// the step budget `max`.
    #[cold]
    #[inline(never)]
    fn over_budget(&self, t: f64, attempts: u64, max: u64) -> SimError {
        let settings = self.settings;
        let estimate = if t > 0.0 { attempts as f64 * settings.t_end / t } else { f64::INFINITY };
        SimError::Budget {
            what: "steps",
            estimate,
            limit: max as f64,
            setting: crate::settings::Setting::MaxSteps,
            detail: format!("extrapolated from {attempts} step attempts to t = {t:.6e} s of {} s", settings.t_end),
        }
    }

    /// Hands the run over to the DAE at `t` (`why`): its settings and a
    /// projector with the released rows, and a note; the first hand-over
    /// for a skate's slide is noted, the later ones are counted.
    #[cold]
    pub(super) fn note_handover(&mut self, sys: &Dynamics<M>, t: f64, dae: &'a RunSettings, why: &str) {
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
}
