//! Design questions on the sensitivities ([`crate::sensitivity`]):
//! parameters fitted to measurements ([`fit`]), and the parameters that
//! minimize or maximize a gait's or a run's quantity under constraints
//! ([`optimize`]); and the shape gait of a kinematic system that
//! maximizes its net motion per cycle, on the geometry of locomotion
//! ([`gait`]), or of a mixed system, its drives' Fourier coefficients a
//! design that [`optimize`] searches over the simulated gait
//! ([`gait::dynamic`]).
//!
//! A [`Design`] is a family of problems over named parameters with
//! bounds: how a problem is built from their values. The library user
//! gives it as a closure; `ezy_scene::Scene::design` makes one from a
//! scene's numbers (what `--over NAME=LO:HI` names).

pub mod fit;
pub mod gait;
pub mod optimize;

use std::sync::Arc;

use crate::analysis::AnalysisError;
use crate::error::SimError;
use crate::model::Model;
use crate::problem::Problem;
use crate::sensitivity::Parameter;

/// How a problem is built from the parameters' values.
pub type BuildAll<M> = dyn Fn(&[f64]) -> Result<Problem<M>, SimError> + Send + Sync;

/// A family of problems over named parameters, each within bounds.
#[derive(Clone)]
pub struct Design<M: Model> {
    /// The parameters' names.
    pub names: Vec<String>,
    /// Their values to start from (the scene's).
    pub start: Vec<f64>,
    /// Lower bounds.
    pub lower: Vec<f64>,
    /// Upper bounds.
    pub upper: Vec<f64>,
    build: Arc<BuildAll<M>>,
}

impl<M: Model> std::fmt::Debug for Design<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Design")
            .field("names", &self.names)
            .field("start", &self.start)
            .field("lower", &self.lower)
            .field("upper", &self.upper)
            .finish_non_exhaustive()
    }
}

impl<M: Model> Design<M> {
    /// The parameters `names` within `[lower, upper]` each, starting
    /// from `start`, the problem at any values built by `build`.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for lists of different lengths, none, a
    /// name given twice, a bound that is not finite, a lower bound not
    /// below its upper one, or a start outside its bounds (naming it).
    pub fn new(
        names: Vec<String>,
        start: Vec<f64>,
        bounds: Vec<(f64, f64)>,
        build: impl Fn(&[f64]) -> Result<Problem<M>, SimError> + Send + Sync + 'static,
    ) -> Result<Self, AnalysisError> {
        let fail = |reason: String| Err(AnalysisError::Request { reason });
        if names.is_empty() || names.len() != start.len() || names.len() != bounds.len() {
            return fail(format!(
                "{} names, {} values and {} bounds: give each parameter once, with its value and bounds",
                names.len(),
                start.len(),
                bounds.len()
            ));
        }
        for (k, (name, (&v, &(lo, hi)))) in names.iter().zip(start.iter().zip(&bounds)).enumerate() {
            if names[..k].contains(name) {
                return fail(format!("parameter `{name}` is named twice"));
            }
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return fail(format!("`{name}={lo}:{hi}`: the bounds must be finite, the lower below the upper"));
            }
            if !(lo..=hi).contains(&v) {
                return fail(format!(
                    "`{name}={lo}:{hi}`: the start, {name} = {v}, is outside the bounds (give bounds around the scene's value)"
                ));
            }
        }
        let (lower, upper) = bounds.into_iter().unzip();
        Ok(Self { names, start, lower, upper, build: Arc::new(build) })
    }

    /// The problem at `values`.
    ///
    /// # Errors
    /// Whatever the builder refuses.
    pub fn problem(&self, values: &[f64]) -> Result<Problem<M>, SimError> {
        (self.build)(values)
    }

    /// The same design with each problem it builds changed by `adjust`
    /// (a caller's settings: the command line's integrator and tolerances).
    #[must_use]
    pub fn adjusted(self, adjust: impl Fn(Problem<M>) -> Problem<M> + Send + Sync + 'static) -> Self {
        let inner = self.build;
        Self { build: Arc::new(move |v| inner(v).map(&adjust)), ..self }
    }

    /// The parameters at `values`, each built by changing its own value
    /// alone (what the sensitivities differentiate).
    pub fn parameters(&self, values: &[f64]) -> Vec<Parameter<M>> {
        (0..self.names.len())
            .map(|k| {
                let (build, at) = (Arc::clone(&self.build), values.to_vec());
                Parameter::new(self.names[k].clone(), values[k], move |v| {
                    let mut at = at.clone();
                    at[k] = v;
                    build(&at)
                })
            })
            .collect()
    }
}
