//! A scene's numbers as parameters of its problem
//! ([`ezy_core::sensitivity::Parameter`]): what a sensitivity, an
//! optimization or a fit varies, named as `--set` names them.

use ezy_core::analysis::AnalysisError;
use ezy_core::design::Design;
use ezy_core::sensitivity::Parameter;
use ezy_core::{Model, Problem, SetupError, SimError};

use crate::schema::Scene;

/// The defaults a scene leaves unwritten (`skip_serializing_if`) among
/// the effects' numbers: 0 (dampings, phases, offsets), 1 (a drag's
/// direction `(1, 0)`) and standard gravity (a uniform field `(0, -g)`,
/// a skate friction's `g`).
const DEFAULTS: [f64; 4] =
    [0.0, 1.0, -ezy_core::effects::body::STANDARD_GRAVITY, ezy_core::effects::body::STANDARD_GRAVITY];

impl Scene {
    /// The number `name` of this scene (with the overrides `sets`) as a
    /// parameter of its problem on `model`: a scene parameter (`M0`), a
    /// model parameter (`m2`), an effect's or a drive's number
    /// (`motor.omega`, `roll.damping`, as [`Scene::set`] takes them), or
    /// an initial value `initial.q.<coord>` / `initial.qd.<coord>`. Its
    /// value is the scene's; the problem at another value is the scene
    /// with `name` set to it.
    ///
    /// # Errors
    /// As [`Scene::set`] for a name the scene does not have;
    /// [`SetupError::Scene`] for a key the scene does not write as a
    /// number (a key left at its default is taken at it where that is 0,
    /// 1 or standard gravity, the defaults the effects leave unwritten);
    /// as [`Scene::problem_with`].
    pub fn parameter<M: Model>(&self, model: &M, sets: &[(String, f64)], name: &str) -> Result<Parameter<M>, SimError> {
        let (problem, _) = self.problem_with(model.clone(), sets)?;
        if name.starts_with("initial.q.") || name.starts_with("initial.qd.") {
            return problem.parameter(name);
        }
        let info = problem.model.info();
        let scene = self.with_sets(&info, sets)?;
        let value = scene.value_of(&problem.model, name)?;
        let (base, model) = (self.clone(), model.clone());
        let mut sets = sets.to_vec();
        let key = name.to_string();
        sets.push((key.clone(), value));
        Ok(Parameter::new(name, value, move |v| {
            let mut sets = sets.clone();
            sets.last_mut().expect("the parameter's own set").1 = v;
            base.problem_with(model.clone(), &sets).map(|(p, _)| p)
        }))
    }

    /// The scene's numbers `over` (`(name, lower, upper)`: names as
    /// [`Scene::parameter`] takes them) as a [`Design`] over its problem on
    /// `model` with the overrides `sets`: starting from the scene's
    /// values, the problem at other values being the scene with each
    /// name set (an initial value given).
    ///
    /// # Errors
    /// As [`Scene::parameter`] for each name; as [`Design::new`] (bounds
    /// that exclude the scene's value, a name given twice);
    /// [`AnalysisError::Request`] for a body's mass or inertia whose lower
    /// bound is not > 0 (the search would build a body of no or negative
    /// mass), naming the parameter and the body.
    pub fn design<M: Model>(
        &self,
        model: &M,
        sets: &[(String, f64)],
        over: &[(String, f64, f64)],
    ) -> Result<Design<M>, AnalysisError> {
        let info = model.info();
        for (n, lo, hi) in over {
            let body = info.bodies.iter().find_map(|b| {
                let what = if b.mass_param == Some(n.as_str()) {
                    "mass"
                } else if b.inertia_param == Some(n.as_str()) {
                    "inertia"
                } else {
                    return None;
                };
                Some((what, b.name.as_str()))
            });
            if let Some((what, body)) = body
                && *lo <= 0.0
            {
                return Err(AnalysisError::Request {
                    reason: format!(
                        "`{n}={lo}:{hi}`: {n} is the {what} of body {body}, which must stay a finite number > 0: give a lower bound above 0"
                    ),
                });
            }
        }
        let start = over
            .iter()
            .map(|(n, _, _)| Ok(self.parameter(model, sets, n)?.value))
            .collect::<Result<Vec<_>, SimError>>()?;
        let names: Vec<String> = over.iter().map(|(n, _, _)| n.clone()).collect();
        let bounds = over.iter().map(|&(_, lo, hi)| (lo, hi)).collect();
        let (scene, model, sets, keys) = (self.clone(), model.clone(), sets.to_vec(), names.clone());
        Design::new(names, start, bounds, move |values| scene.problem_at(&model, &sets, &keys, values))
    }

    /// The problem on `model` with the overrides `sets` and then each
    /// of `names` set to its value of `values` (`initial.q.X`,
    /// `initial.qd.X` given as initial values).
    ///
    /// # Errors
    /// As [`Scene::problem_with`]; as [`Problem::q`] for an initial value.
    pub fn problem_at<M: Model>(
        &self,
        model: &M,
        sets: &[(String, f64)],
        names: &[String],
        values: &[f64],
    ) -> Result<Problem<M>, SimError> {
        let mut all = sets.to_vec();
        let mut initial = Vec::new();
        for (n, &v) in names.iter().zip(values) {
            if n.starts_with("initial.q.") || n.starts_with("initial.qd.") {
                initial.push((n.as_str(), v));
            } else {
                all.push((n.clone(), v));
            }
        }
        let (mut problem, _) = self.problem_with(model.clone(), &all)?;
        for (n, v) in initial {
            problem = match n.strip_prefix("initial.q.") {
                Some(c) => problem.q(c, v)?,
                None => problem.qd(n.trim_start_matches("initial.qd."), v)?,
            };
        }
        Ok(problem)
    }

    /// The value of the number `name` as this scene gives it (see
    /// [`Scene::parameter`]); `model` has the scene's parameters set.
    fn value_of<M: Model>(&self, model: &M, name: &str) -> Result<f64, SimError> {
        if let Some((_, v)) = self.scene_params.iter().find(|(n, _)| n == name) {
            return Ok(*v);
        }
        let info = model.info();
        if let Some(k) = info.param_index(name) {
            return Ok(model.param(k));
        }
        // an unknown name gets `set`'s error, listing the names there are
        self.clone().set(&info, name, 0.0)?;
        let not_given = || {
            SimError::Setup(SetupError::Scene {
                key: name.to_string(),
                message: format!(
                    "`{name}` is not written in the scene as a number (a key left at its default): give it in the scene to take it as a parameter"
                ),
            })
        };
        let (item, key) = name.split_once('.').ok_or_else(not_given)?;
        let numbers = self.numbers(item).ok_or_else(not_given)?;
        let hits: Vec<f64> = numbers
            .iter()
            .filter(|(path, _)| path == key || path.rsplit('.').next() == Some(key))
            .map(|(_, v)| *v)
            .collect();
        match hits.as_slice() {
            [v] => Ok(*v),
            // a key left at its default is not written (a damping or a
            // phase of 0, a drag's direction (1, 0), a uniform field
            // straight down at standard gravity): set to the value it
            // has, the item's numbers stay as they are, and to any other
            // they change, so a default found this way is the value
            [] => {
                let unchanged = |d: f64| {
                    let mut probe = self.clone();
                    probe.set(&info, name, d).is_ok() && probe.numbers(item).as_ref() == Some(&numbers)
                };
                DEFAULTS.into_iter().find(|&d| unchanged(d)).ok_or_else(not_given)
            }
            _ => Err(not_given()),
        }
    }
}
