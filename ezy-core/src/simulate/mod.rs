//! The run: [`simulate`] integrates a model's dynamics with the method
//! and the formulation its settings ask for, projection after every
//! step, the energy balance and the singular positions watched, events
//! located, skates' friction switched, and every sample shown to an
//! [`Observer`]. The loop itself does not allocate.
//!
//! | module | holds |
//! |---|---|
//! | [`observer`] | [`Sample`], [`Observer`], [`RunError`], [`Summary`], the notes |
//! | `run` | the state of a run while it steps: projection, energy guard, singular positions, events, hand-overs, the queue's rows |
//! | `watch` | the state of the watch on the skates' and the switching events' switches |
//! | `slip` | that watch at work: switches located and made |
//! | `output` | the queue of samples and the adaptive output times |
//! | `integrand` | what is integrated: the DAE or the reduced formulation |
//! | `driver` | the one step loop over [`crate::integrator::stepper::Stepper`]; events located in a step, the switch of formulation |
//! | [`events`] | locating events on a step's continuous extension |
//! | [`guard`] | the energy guard |

mod driver;
pub mod events;
pub mod guard;
mod integrand;
pub mod observer;
mod output;
pub(crate) mod run;
pub(crate) mod slip;
mod watch;

pub use observer::{Observer, RunError, Sample, Summary, singular_note, stiff_note};
pub use run::SINGULAR_PERSIST_STEPS;
pub use slip::SLIP_CHATTER_GAP;

use std::time::Instant;

use crate::error::KktError;
use crate::error::SetupError;
use crate::error::SimError;
use crate::formulation::dae::{Counters, Dynamics};
use crate::formulation::projection::Projector;
use crate::formulation::reduced::Reduced;
use crate::model::Model;
use crate::settings::{Formulation, Message, Method, ProjectionKind, RunSettings, Setting};
use crate::simulate::driver::{integrate, radau5_refused};
use crate::simulate::integrand::{Dae, Integrand};
use crate::simulate::observer::{Erased, Parked, Stopped};
use crate::simulate::run::Run;

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

/// [`simulate`] for the one observer type the step loop is built for:
/// the checks, the formulation chosen, the run set up, the step loops
/// across the hand-overs, the summary.
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
    check_spans(&sys.effects, settings.t_end)?;
    check_redundant(sys, y0)?;
    let reduced = choose_reduced(sys, y0, settings)?;
    // the DAE's settings (`settings`), for a hand-over from the reduced
    // formulation; the reduced one's
    let reduced_settings;
    let run_settings = if reduced.is_some() {
        check_reduced(sys, settings)?;
        // the constraints hold at every expanded state: nothing to project
        reduced_settings = RunSettings { projection: ProjectionKind::None, ..*settings };
        &reduced_settings
    } else {
        settings
    };
    sys.forget_waveforms();
    let effects_on: Vec<bool> = sys.effects.iter().map(|e| e.on).collect();
    let counters0 = sys.counters;
    // the reduced formulation keeps every skate's row: the DAE runs
    // while one slides, and hands back when all stick
    let hand_back = reduced.is_some() && !sys.friction.is_empty();
    let mut run = Run::new(sys, y0, run_settings, observer, hand_back);
    run.watch_switches(sys, y0, &start_slides)?;
    run.summary.projection_path = run.proj.path();
    note_pivot(&mut run, sys, reduced.as_ref());
    run.emit(sys, 0.0, y0)?;
    let start = Instant::now();
    let (result, final_state) = integrate_across(sys, y0, reduced, &mut run, settings);
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

/// Refuses constraints of `sys` dependent at every configuration (the
/// model's error; at an instant, this one included, they are a singular
/// position), at `y0`.
fn check_redundant<M: Model>(sys: &Dynamics<M>, y0: &[f64]) -> Result<(), SimError> {
    let (nq, nc) = (sys.info.nq(), sys.info.nc());
    if let Some(row) =
        crate::formulation::initial::redundant_row(&sys.model, &sys.info, &sys.drives, &sys.mass, &y0[..nq])
            .map_err(|source| SimError::from_kkt(&sys.info, 0.0, source))?
    {
        return Err(SimError::from_kkt(&sys.info, 0.0, KktError::DependentConstraints { n: nc, row }));
    }
    Ok(())
}

/// The reduced formulation, built at `y0`, where `settings` ask for it
/// or choose it ([`Formulation::Auto`] keeps it only where its dependent
/// coordinates follow from one Newton step); `None`: the DAE.
///
/// # Errors
/// As [`Reduced::new`] where the reduced formulation is asked for.
fn choose_reduced<M: Model>(
    sys: &mut Dynamics<M>,
    y0: &[f64],
    settings: &RunSettings,
) -> Result<Option<Reduced>, SimError> {
    let (nq, nc) = (sys.info.nq(), sys.info.nc());
    Ok(match settings.formulation {
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
    })
}

/// Refuses what the reduced formulation does not run with: RADAU5 (its
/// Newton system is the DAE's), Baumgarte stabilization.
fn check_reduced<M: Model>(sys: &Dynamics<M>, settings: &RunSettings) -> Result<(), SimError> {
    if settings.method == Method::Radau5 {
        return Err(radau5_refused());
    }
    if sys.baumgarte.is_some() {
        return Err(SimError::Formulation {
            reason: Message::text(
                "Baumgarte stabilization is for the DAE; the reduced formulation keeps the constraints without it: drop ",
            )
            .setting(Setting::Baumgarte)
            .then(" or take ")
            .setting(Setting::Formulation(Formulation::Dae)),
        });
    }
    Ok(())
}

/// Minimal coordinates asked for and refused for a pivot (the reduced
/// formulation `reduced` on a numeric partition): the note says why.
fn note_pivot<M: Model>(run: &mut Run<'_, M, Erased<'_, M>>, sys: &Dynamics<M>, reduced: Option<&Reduced>) {
    if run.settings.formulation == Formulation::Reduced
        && sys.drives.is_empty()
        && reduced.is_some_and(|r| !r.is_minimal())
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
}

/// The step loops from `y0` at 0 to the run's end on the reduced
/// formulation `reduced` or the DAE, and across the hand-overs between
/// them: to the DAE (with its settings, `dae_settings`) where a skate
/// begins to slide or the reduced formulation stops before a singular
/// position, back where every skate sticks again. Returns the result and
/// the last accepted full state.
fn integrate_across<'a, M: Model>(
    sys: &mut Dynamics<M>,
    y0: &[f64],
    mut reduced: Option<Reduced>,
    run: &mut Run<'a, M, Erased<'_, M>>,
    dae_settings: &'a RunSettings,
) -> (Result<(), RunError<Stopped>>, Vec<f64>) {
    let settings = run.settings;
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
                let r = integrate(sys, red, &mut z, run);
                run.summary.repartitions += red.repartitions;
                red.repartitions = 0;
                y.copy_from_slice(Integrand::<M>::accepted_full(red, &z));
                r
            }
            None => integrate(sys, &mut Dae, &mut y, run),
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
    (result, y)
}

/// Sets each effect of `sys` on or off as `on` says (one per effect).
fn restore_effects<M: Model>(sys: &mut Dynamics<M>, on: &[bool]) {
    for (e, &on) in sys.effects.iter_mut().zip(on) {
        e.on = on;
    }
}

/// Refuses a switch event ([`crate::events::spec::Action::Switch`]) whose
/// Whether every effect's force is defined over the run's `[0, t_end]`
/// \[s\] ([`crate::effects::ForceLaw::span`]: a table that does not
/// extrapolate is defined on its times only): checked before the run, as
/// a drive's angle is ([`crate::drive::check_angle`]).
///
/// # Errors
/// [`SetupError::Effect`] naming the first effect whose table ends
/// within the run, its times and the run's.
pub(crate) fn check_spans(effects: &[crate::effects::Effect], t_end: f64) -> Result<(), SimError> {
    for e in effects {
        crate::effects::waveform::covers(e.span(), t_end)
            .map_err(|message| SimError::Setup(SetupError::Effect { effect: e.name.clone(), field: "t", message }))?;
    }
    Ok(())
}

/// effects are not effects of `sys` or are a skate's friction, or that
/// names none: a library user's [`crate::events::spec::Event::switching`] is
/// checked here as a scene's `switch_on` is when it is resolved.
fn check_switches<M: Model>(sys: &Dynamics<M>) -> Result<(), SimError> {
    for e in sys.events.iter().filter(|e| e.action == crate::events::spec::Action::Switch) {
        let err = |field: &'static str, message: String| {
            SimError::Setup(SetupError::Event { event: e.name.clone(), field, message })
        };
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
    let at_start = |quantity: String, value: f64, why: &str| {
        SimError::NonFinite {
        t: 0.0,
        quantity,
        value,
        dt: 0.0,
        advice: format!(
            "{why}: the scene's initial values or parameters are out of the range double precision can hold (no step size helps)"
        ).into(),
    }
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
