//! A scene's numbers as parameters of its problem
//! ([`ezy_core::sensitivity::Parameter`]): what a sensitivity, an
//! optimization or a fit varies, named as `--set` names them.

use ezy_core::sensitivity::Parameter;
use ezy_core::{Model, SetupError, SimError};

use crate::Scene;

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
    /// [`SetupError::Scene`] for a key left at its default (give it in
    /// the scene) or one whose value the scene does not write as a number;
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
            _ => Err(not_given()),
        }
    }
}
