//! A gait found where Newton's method alone does not find it: the period
//! map iterated (the scene run on, period by period) until its motion
//! settles, then the shooting Newton again from there; or the reason there
//! is none to find, measured: an energy that grows without bound, or a
//! motion that does not settle.
//!
//! A stable gait attracts the motions near it at the rate of its largest
//! multiplier `|mu|`: the state at the period ends, modulo the symmetry,
//! approaches the fixed point like `|mu|^k`. A weakly damped scene (the
//! snake, `|mu|` about 0.99) spends hundreds of periods in its transient,
//! and a shooting Newton started inside it meets the period map's strong
//! nonlinearity there; started from the settled motion it converges in a
//! few iterations (Seydel, *Practical Bifurcation and Stability
//! Analysis*, 3rd ed., §7.3: shooting needs a guess near the orbit;
//! simulation provides one for a stable orbit).

use super::growth::Growth;
use super::periodic::{PeriodicOrbit, PeriodicSettings, into_sim};
use super::symmetry::{Symmetry, act, body_pose};
use super::{Analysis, AnalysisError};
use crate::error::SimError;
use crate::integrator::Rhs;
use crate::integrator::adaptive::{self, Tolerance};
use crate::integrator::dop853::Dop853;
use crate::model::Model;
use crate::names::fmt_value;

/// Most periods of the forcing [`Analysis::gait`] runs the scene on for
/// (in all, over its retries).
pub const MAX_SETTLE_PERIODS: usize = 4096;

/// The distances (relative change of the state at the period ends modulo
/// the symmetry) at which [`Analysis::gait`] tries Newton again.
const RETRY_AT: [f64; 3] = [1e-3, 1e-6, 1e-9];

/// Fewest periods a growth of the energy is judged over.
const GROWTH_MIN_PERIODS: usize = 16;

/// How a run of the period map ended ([`Analysis::settle`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Settling {
    /// The state at a period's end, modulo the symmetry, changed by less
    /// than the distance asked over the last period.
    Settled,
    /// The kinetic energy at the period ends grew in every period of the
    /// second half of the run, by more than 5 %, like a power of the time
    /// (no periodic orbit: the forcing's work is not taken by a loss),
    /// measured over that half.
    Grows(Box<Growth>),
    /// Neither, within the periods allowed.
    Unsettled,
}

/// When [`Analysis::settle`] stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Until {
    /// The change of the state at the period ends, modulo the symmetry,
    /// relative to `1 + max |x|` (max norm), below which the motion has
    /// settled.
    pub distance: f64,
    /// Most periods run.
    pub max_periods: usize,
}

/// The end of a run of the period map ([`Analysis::settle`]).
#[derive(Debug, Clone)]
pub struct Settle {
    /// How it ended.
    pub outcome: Settling,
    /// The time reached \[s\] (the start plus whole periods).
    pub t: f64,
    /// The state there (2 nq).
    pub state: Vec<f64>,
    /// Periods run.
    pub periods: usize,
    /// The last period's change of the state modulo the symmetry, relative
    /// to `1 + max |x|` (max norm).
    pub distance: f64,
}

/// The state alone, `x' = f(t, x)`, for the period map's integration.
struct State<'a, M: Model> {
    analysis: &'a mut Analysis<M>,
    failed: Option<AnalysisError>,
}

impl<M: Model> Rhs for State<'_, M> {
    fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError> {
        let nq = x.len() / 2;
        let mut run = |an: &mut Analysis<M>| -> Result<(), AnalysisError> {
            an.check_stop()?;
            let p = an.point(t, x)?;
            dx[..nq].copy_from_slice(&x[nq..]);
            dx[nq..].copy_from_slice(&p.qdd);
            Ok(())
        };
        run(self.analysis).map_err(|e| into_sim(e, &mut self.failed))
    }
}

impl<M: Model> Analysis<M> {
    /// Runs the scene from `x0` (2 nq) at `t0` \[s\] period by period of
    /// `period` \[s\] (DOP853 at the tolerances of `settings`, no looser
    /// than 1e-9) until the state at a period's end, modulo `symmetry`,
    /// changes by less than `until.distance` (relative to `1 + max |x|`)
    /// over a period; until the kinetic energy is seen to grow without bound
    /// (checked after 16, 32, 64, ... periods over the run's second half:
    /// in every period, by more than 5 % in all, at a rate `T ~ t^a`
    /// whose exponent over the half's two quarters agrees to 25 %, which
    /// a transient that saturates does not show); or for
    /// `until.max_periods`.
    ///
    /// # Errors
    /// As [`crate::integrator::adaptive::integrate`] and
    /// [`Analysis::rhs`]; [`AnalysisError::Request`] when a skate with
    /// friction slides on the motion (its holding force past `mu N`).
    pub fn settle(
        &mut self,
        t0: f64,
        x0: &[f64],
        period: f64,
        symmetry: Symmetry,
        settings: &PeriodicSettings,
        until: Until,
    ) -> Result<Settle, AnalysisError> {
        let Until { distance: until, max_periods } = until;
        self.check_state(x0)?;
        let symmetry = symmetry.rigid();
        let bodies = self.bodies().to_vec();
        let gauged = |x: &[f64]| act(&bodies, symmetry.restrict(body_pose(&bodies, 0, x)).inverse(), x);
        let tol = Tolerance { rtol: settings.tolerance.rtol.max(1e-9), atol: settings.tolerance.atol.max(1e-9) };
        let nq = self.nq();
        let (mut t, mut x) = (t0, x0.to_vec());
        let mut before = gauged(&x);
        // the stroboscopic samples: time, kinetic energy, the reference
        // body's speed
        let sample = |an: &Self, t: f64, x: &[f64]| {
            let [i, j, _] = bodies.first().copied().unwrap_or([0; 3]);
            let speed = if bodies.is_empty() { 0.0 } else { x[nq + i].hypot(x[nq + j]) };
            (t, an.sys.kinetic_energy(&x[nq..]), speed)
        };
        let mut samples = vec![sample(self, t, &x)];
        let mut distance = f64::INFINITY;
        self.watch_grip();
        let loose = PeriodicSettings { tolerance: tol, ..*settings };
        for k in 1..=max_periods {
            x = self.end_state(t, &x, period, &loose)?.0;
            t = t0 + k as f64 * period;
            let now = gauged(&x);
            let size = 1.0 + now.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            distance = now.iter().zip(&before).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / size;
            before = now;
            samples.push(sample(self, t, &x));
            self.check_grip(&format!("the motion from t = {} s", fmt_value(t0)))?;
            let outcome = if distance < until {
                Some(Settling::Settled)
            } else if k >= GROWTH_MIN_PERIODS && k.is_power_of_two() {
                growth(period, &samples)
            } else {
                None
            };
            if let Some(outcome) = outcome {
                return Ok(Settle { outcome, t, state: x, periods: k, distance });
            }
        }
        Ok(Settle { outcome: Settling::Unsettled, t, state: x, periods: max_periods, distance })
    }

    /// The state at `t0 + period` from `x0` at `t0` \[s\] (DOP853 at the
    /// tolerances of `settings`, the state alone), and the accepted steps.
    ///
    /// # Errors
    /// As [`crate::integrator::adaptive::integrate`]; as [`Analysis::rhs`].
    pub fn end_state(
        &mut self,
        t0: f64,
        x0: &[f64],
        period: f64,
        settings: &PeriodicSettings,
    ) -> Result<(Vec<f64>, u64), AnalysisError> {
        let mut state = State { analysis: self, failed: None };
        let end =
            adaptive::integrate::<Dop853, _>(&mut state, t0, x0, t0 + period, &settings.tolerance, settings.max_steps);
        if let Some(e) = state.failed.take() {
            return Err(e);
        }
        let end = end?;
        Ok((end.y, end.steps))
    }

    /// Refuses a search whose period the explicit integrator crosses only
    /// in many steps: one period of the state alone from `x0` at `t0`
    /// \[s\] taking more than a tenth of `settings.max_steps` (the
    /// search integrates the variational equations, `(2 nq)^2` more
    /// components with a Jacobian at every stage, over such a period
    /// several times: minutes for a stiff scene). A period that takes
    /// some 10^2 steps is usual; a stiff scene's fast mode holds the step
    /// near its time scale (`snake-stiff`'s servos: 1e-4 s).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] with the steps and the mean step, or
    /// with the integration's failure (a stiff scene's state alone may
    /// blow up under an explicit method); [`AnalysisError::Stopped`].
    pub(crate) fn check_cost(
        &mut self,
        t0: f64,
        x0: &[f64],
        period: f64,
        settings: &PeriodicSettings,
    ) -> Result<(), AnalysisError> {
        let limit = settings.max_steps / 10;
        let probe = PeriodicSettings { max_steps: limit.max(1), ..*settings };
        let steps = match self.end_state(t0, x0, period, &probe) {
            Ok((_, steps)) => steps,
            Err(AnalysisError::Sim(SimError::Budget { .. })) => limit + 1,
            Err(AnalysisError::Sim(e)) => {
                return Err(AnalysisError::Request {
                    reason: format!(
                        "DOP853 could not integrate one period ({} s) of the state alone from t = {} s ({e}); an explicit method fails so on a stiff scene (a fast mode it cannot follow), and the analyses have no implicit integrator yet",
                        fmt_value(period),
                        fmt_value(t0)
                    ),
                });
            }
            Err(e) => return Err(e),
        };
        if steps <= limit {
            return Ok(());
        }
        let n2 = x0.len();
        Err(AnalysisError::Request {
            reason: format!(
                "one period ({} s) of the state alone takes more than {limit} steps of DOP853 (a mean step below {:.1e} s): the scene looks stiff (a fast mode holds an explicit method's step), and the search integrates {} variational equations with the state, several times over; the analyses have no implicit integrator yet. Raise {} to {} or more to search anyway",
                fmt_value(period),
                period / limit as f64,
                n2 * n2,
                crate::settings::Setting::MaxSteps,
                steps.max(limit + 1) * 10
            ),
        })
    }

    /// The periodic orbit of period `period` \[s\] at phase `t0` \[s\]
    /// modulo `symmetry` that the motion from `guess` (2 nq) settles
    /// onto, as [`Analysis::gait_or_growth`]; a motion that gains energy
    /// without bound is an error here, for the callers that need an orbit
    /// (its derivatives, its branch, a design's objective).
    ///
    /// # Errors
    /// [`AnalysisError::NoOrbit`] where the energy grows without bound
    /// (with [`Growth::describe`]'s measurement), and as
    /// [`Analysis::gait_or_growth`].
    pub fn gait(
        &mut self,
        t0: f64,
        period: f64,
        guess: &[f64],
        symmetry: Symmetry,
        settings: &PeriodicSettings,
    ) -> Result<PeriodicOrbit, AnalysisError> {
        match self.gait_or_growth(t0, period, guess, symmetry, settings)? {
            GaitOrGrowth::Gait(orbit) => Ok(*orbit),
            GaitOrGrowth::Grows(g) => Err(AnalysisError::NoOrbit {
                reason: format!(
                    "{}; a gait needs a loss that takes the input's energy (rolling resistance, drag)",
                    g.describe()
                ),
            }),
        }
    }

    /// What the motion of a periodically forced scene from `guess` (2 nq)
    /// at `t0` \[s\] does in the long run: the periodic orbit of period
    /// `period` \[s\] modulo `symmetry` it settles onto, or its energy's
    /// growth without bound, measured ([`Growth`]: the answer, not a
    /// failure, for a scene without a loss that takes the forcing's work).
    ///
    /// [`Analysis::periodic_orbit`] from `guess`; where that fails, the
    /// scene run on ([`Analysis::settle`], up to [`MAX_SETTLE_PERIODS`]
    /// periods in all) until its state at the period ends changes by less
    /// than 1e-3, then 1e-6, then 1e-9 per period, and the search again
    /// from there. The orbit's phase `t0` is then the start's plus whole
    /// periods. The growth is measured over the second half of the run
    /// that found it (16, 32, 64, ... periods from where that run began).
    ///
    /// # Errors
    /// [`AnalysisError::NoOrbit`] where the motion does not settle within
    /// [`MAX_SETTLE_PERIODS`] periods (neither an orbit nor a growth);
    /// [`AnalysisError::NotConverged`] when the search fails even from the
    /// settled motion; as [`Analysis::periodic_orbit`] and
    /// [`Analysis::settle`].
    pub fn gait_or_growth(
        &mut self,
        t0: f64,
        period: f64,
        guess: &[f64],
        symmetry: Symmetry,
        settings: &PeriodicSettings,
    ) -> Result<GaitOrGrowth, AnalysisError> {
        let gait = |o: PeriodicOrbit| Ok(GaitOrGrowth::Gait(Box::new(o)));
        let mut last = match self.periodic_orbit(t0, period, guess, symmetry, settings) {
            Ok(o) => return gait(o),
            Err(e) if searched(&e) => e,
            Err(e) => return Err(e),
        };
        let (mut t, mut x, mut periods) = (t0, guess.to_vec(), 0);
        for until in RETRY_AT {
            let until = Until { distance: until, max_periods: MAX_SETTLE_PERIODS - periods };
            let s = self.settle(t, &x, period, symmetry, settings, until)?;
            (t, x, periods) = (s.t, s.state, periods + s.periods);
            match s.outcome {
                Settling::Settled => {}
                Settling::Grows(g) => return Ok(GaitOrGrowth::Grows(g)),
                Settling::Unsettled => {
                    return Err(AnalysisError::NoOrbit {
                        reason: format!(
                            "the motion does not settle onto one: run on for {periods} periods (to t = {} s), its state at the period ends still changes by {:.1e} per period (relative, modulo the plane's rigid motions), and the search from the run failed ({last}); it may be quasi-periodic or chaotic, or settle later",
                            fmt_value(t),
                            s.distance
                        ),
                    });
                }
            }
            match self.periodic_orbit(t, period, &x, symmetry, settings) {
                Ok(o) => return gait(o),
                Err(e) if searched(&e) => last = e,
                Err(e) => return Err(e),
            }
            if periods >= MAX_SETTLE_PERIODS {
                break;
            }
        }
        Err(last)
    }
}

/// What a periodically forced scene's motion does in the long run
/// ([`Analysis::gait_or_growth`]).
#[derive(Debug, Clone)]
pub enum GaitOrGrowth {
    /// It settles onto this periodic orbit.
    Gait(Box<PeriodicOrbit>),
    /// It gains energy without bound, at the rates measured.
    Grows(Box<Growth>),
}

/// Whether `e` is a search's failure (Newton's, or one that wandered off),
/// not a request's or the scene's.
fn searched(e: &AnalysisError) -> bool {
    matches!(e, AnalysisError::NotConverged { .. } | AnalysisError::Wandered { .. })
}

/// [`Settling::Grows`] when the kinetic energies of the samples `(t, T,
/// v)` at the period ends grow without bound over the second half, as
/// [`Analysis::settle`] says, measured ([`Growth::measure`]).
fn growth(period: f64, samples: &[(f64, f64, f64)]) -> Option<Settling> {
    let half = &samples[samples.len() / 2..];
    let (&(t1, e1, _), &(t2, e2, _)) = (half.first()?, half.last()?);
    let grows = half.windows(2).all(|w| w[1].1 > w[0].1) && e2 > 1.05 * e1 && e1 > 0.0 && t1 > 0.0;
    if !grows {
        return None;
    }
    let rate = |a: (f64, f64, f64), b: (f64, f64, f64)| (b.1 / a.1).ln() / (b.0 / a.0).ln();
    let mid = half[half.len() / 2];
    let (early, late) = (rate(half[0], mid), rate(mid, half[half.len() - 1]));
    let like = late > 0.75 * early && late < early / 0.75 && t2 > t1;
    if !like {
        return None;
    }
    Growth::measure(period, half).map(|g| Settling::Grows(Box::new(g)))
}
