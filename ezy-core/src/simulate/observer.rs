//! What a run shows and returns: each sample ([`Sample`]) to an
//! [`Observer`], the notes it tells while it goes ([`singular_note`],
//! [`stiff_note`]), what it did ([`Summary`]) or why it stopped
//! ([`RunError`]); and every observer seen as one type by the step loop
//! (`Erased`), which is then compiled once per model.

use std::time::Duration;

use crate::error::SimError;
use crate::formulation::dae::{Counters, Dynamics};
use crate::model::Model;
use crate::settings::{Formulation, Method};

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
    pub newton: crate::integrator::stepper::NewtonStats,
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
    /// first passed [`crate::settings::RunSettings::balance_limit`] relative to the run's
    /// energy scale `E` ([`crate::simulate::guard`]): the drift its tolerance lets
    /// through, noted, not an error.
    pub energy_drift: Option<(f64, f64)>,
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

/// The observer's error, kept aside while the step loop unwinds.
#[derive(Debug)]
pub(super) struct Stopped;

/// An observer whose error is parked ([`Stopped`] goes up instead).
pub(super) struct Parked<'a, O: Observer<M>, M: Model> {
    pub(super) observer: &'a mut O,
    pub(super) error: Option<O::Error>,
    pub(super) _model: std::marker::PhantomData<fn(&M)>,
}

/// Every observer as one type: what [`super::simulate`]'s step loop is compiled for.
pub(super) struct Erased<'a, M: Model>(pub(super) &'a mut dyn Observer<M, Error = Stopped>);

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
