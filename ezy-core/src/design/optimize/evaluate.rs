//! One point of an optimization: the problem built at the parameters'
//! values, its gait found (from the last gait's fixed point, or from a
//! run when that fails) and/or its run with sensitivities, every quantity
//! of the goal with its gradient.

use super::quantity::{Goal, Quantity};
use crate::analysis::AnalysisError;
use crate::analysis::periodic::{PeriodicOrbit, PeriodicSettings};
use crate::design::Design;
use crate::effects::waveform::Periodicity;
use crate::formulation::dae::Dynamics;
use crate::model::Model;
use crate::problem::Problem;
use crate::sensitivity::Sensitivities;
use crate::simulate::observer::{Observer, RunError, Sample};

/// The goal's quantities at one point: values and gradients (with
/// respect to the design's parameters, in their units).
#[derive(Debug, Clone)]
pub(crate) struct Point {
    /// The objective's value, then each constraint's quantity's.
    pub values: Vec<f64>,
    /// Their gradients (empty where not asked for).
    pub gradients: Vec<Vec<f64>>,
    /// The gait found there.
    pub orbit: Option<PeriodicOrbit>,
}

/// Evaluates a goal's quantities over a design, keeping the last gait
/// found as the next search's guess.
pub(crate) struct Evaluator<'a, M: Model> {
    pub design: &'a Design<M>,
    pub goal: &'a Goal,
    pub periodic: PeriodicSettings,
    pub stop: Option<fn() -> bool>,
    /// The last gait's fixed point.
    guess: Option<Vec<f64>>,
    /// Whether the goal asks for a gait's quantity / a run's.
    needs: (bool, bool),
    /// Gaits found.
    pub orbits: usize,
    /// Runs integrated (with sensitivities, or for a gait's guess).
    pub runs: usize,
}

/// Keeps a run's last state; asks `stop` at every step.
struct Last {
    x: Vec<f64>,
    stop: Option<fn() -> bool>,
}

impl<M: Model> Observer<M> for Last {
    type Error = AnalysisError;
    fn observe(&mut self, _sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), AnalysisError> {
        self.x.clear();
        self.x.extend_from_slice(s.q);
        self.x.extend_from_slice(s.qd);
        Ok(())
    }
    fn poll(&mut self, _t: f64) -> Result<(), AnalysisError> {
        if self.stop.is_some_and(|s| s()) { Err(AnalysisError::Stopped) } else { Ok(()) }
    }
}

impl<'a, M: Model> Evaluator<'a, M> {
    pub fn new(design: &'a Design<M>, goal: &'a Goal, periodic: PeriodicSettings, stop: Option<fn() -> bool>) -> Self {
        let qs = goal.quantities();
        let needs =
            (qs.iter().any(|q| matches!(q, Quantity::Gait(_))), qs.iter().any(|q| matches!(q, Quantity::Run { .. })));
        Self { design, goal, periodic, stop, guess: None, needs, orbits: 0, runs: 0 }
    }

    /// The goal's quantities at `values`, with their gradients where
    /// `gradients`.
    ///
    /// # Errors
    /// The problem's build, the gait's search, the run's failure;
    /// [`AnalysisError::Request`] for a scene without a periodic forcing
    /// asked for a gait, or a run function that fails or gives a gradient
    /// of another length, or a function of the values that does.
    pub fn at(&mut self, values: &[f64], gradients: bool) -> Result<Point, AnalysisError> {
        let problem = self.design.problem(values)?;
        let params = self.design.parameters(values);
        let (gait, run) = self.needs;
        let orbit = if gait { Some(self.gait(&problem)?) } else { None };
        let g = match &orbit {
            Some(o) => {
                let ps = if gradients { &params[..] } else { &[] };
                Some(problem.gait_sensitivities(o, ps, &self.periodic)?)
            }
            None => None,
        };
        let s = if run {
            self.runs += 1;
            Some(match self.stop {
                Some(stop) => problem.sensitivities_stop_when(&params, stop)?,
                None => problem.sensitivities_with(&params)?,
            })
        } else {
            None
        };
        let mut point = Point { values: Vec::new(), gradients: Vec::new(), orbit: None };
        for q in self.goal.quantities() {
            let (v, d) = match q {
                Quantity::Gait(gq) => gq.of(orbit.as_ref().expect("found"), g.as_ref().expect("found")),
                Quantity::Run { name, function } => {
                    let (v, d) = run_function(name, function.as_ref(), s.as_ref().expect("run"))?;
                    (v, if gradients { d } else { Vec::new() })
                }
                Quantity::Values { name, function } => {
                    let (v, d) = function(values);
                    if d.len() != values.len() {
                        return Err(AnalysisError::Request {
                            reason: format!(
                                "{name}: the function gave {} derivatives for {} parameters",
                                d.len(),
                                values.len()
                            ),
                        });
                    }
                    (v, if gradients { d } else { Vec::new() })
                }
            };
            if !v.is_finite() {
                return Err(AnalysisError::Numerics { reason: format!("{} is {v} here", q.name()) });
            }
            point.values.push(v);
            if gradients {
                point.gradients.push(d);
            }
        }
        point.orbit = orbit;
        Ok(point)
    }

    /// The problem's gait: sought at phase 0 over its forcing's period
    /// (at most the problem's `t_end`) from the last gait's fixed point,
    /// or, where there is none or the search from it fails, from the state
    /// of a run at the last whole period before the problem's `t_end`.
    fn gait(&mut self, problem: &Problem<M>) -> Result<PeriodicOrbit, AnalysisError> {
        let (mut an, x0) = problem.clone().analysis()?;
        if let Some(stop) = self.stop {
            an.stop_when(stop);
        }
        let period = match an.forcing() {
            Some(Periodicity::Period(t)) => t,
            _ => {
                return Err(AnalysisError::Request {
                    reason: "a gait's quantity needs a scene driven periodically (a motor, a force with a waveform): this one is not, so it has no gait to optimize".into(),
                });
            }
        };
        if period > problem.settings.t_end {
            return Err(AnalysisError::Request {
                reason: format!(
                    "the forcing's period, {} s, is longer than the scene's run ({} s) (a gait is sought within it): lengthen the run (t_end) or narrow the bounds",
                    crate::names::fmt_value(period),
                    crate::names::fmt_value(problem.settings.t_end)
                ),
            });
        }
        let symmetry = an.symmetry(0.0, &x0)?;
        if let Some(guess) = self.guess.clone() {
            match an.periodic_orbit(0.0, period, &guess, symmetry, &self.periodic) {
                Ok(o) => return Ok(self.found(o)),
                Err(AnalysisError::Stopped) => return Err(AnalysisError::Stopped),
                // lost it: from the problem's own run instead
                Err(_) => {}
            }
        }
        let whole = (problem.settings.t_end / period).floor().max(1.0);
        let t = whole * period;
        self.runs += 1;
        let mut last = Last { x: x0, stop: self.stop };
        problem.clone().t_end(t).every(t).solve_with(&mut last).map_err(|e| match e {
            RunError::Sim(e) => AnalysisError::Sim(e),
            RunError::Output(e) => e,
        })?;
        // run on from there where the run is still in a transient, or
        // told why there is no gait (an energy growing without bound)
        let o = an.gait(t, period, &last.x, symmetry, &self.periodic)?;
        Ok(self.found(o))
    }

    fn found(&mut self, o: PeriodicOrbit) -> PeriodicOrbit {
        self.orbits += 1;
        self.guess = Some(o.state.clone());
        o
    }

    /// Seek the next gaits from `orbit`'s fixed point.
    pub fn restart_from(&mut self, orbit: &PeriodicOrbit) {
        self.guess = Some(orbit.state.clone());
    }
}

/// A run function's value and gradient, checked.
fn run_function(
    name: &str,
    f: &super::quantity::RunFunction,
    s: &Sensitivities,
) -> Result<(f64, Vec<f64>), AnalysisError> {
    let (v, d) = f(s).map_err(|reason| AnalysisError::Request { reason: format!("{name}: {reason}") })?;
    if d.len() != s.parameters.len() {
        return Err(AnalysisError::Request {
            reason: format!("{name}: the function gave {} derivatives for {} parameters", d.len(), s.parameters.len()),
        });
    }
    if let Some(k) = d.iter().position(|x| !x.is_finite()) {
        return Err(AnalysisError::Numerics {
            reason: format!("{name}: its derivative with respect to {} is {}", s.parameters[k], d[k]),
        });
    }
    Ok((v, d))
}
