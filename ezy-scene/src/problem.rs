//! From a scene to the [`Problem`] it describes.

use ezy_core::effects::EffectContext;
use ezy_core::formulation::initial::Given;
use ezy_core::kkt::KktMethod;
use ezy_core::problem::{check_masses, check_params, initial_targets, lookup};
use ezy_core::{InitialName, Model, NameIndex, Problem, SimError};

use crate::{InitValue, Scene, SceneError};

impl Scene {
    /// The problem the scene describes for model `M`: the overrides `sets`
    /// (scene parameters, model parameters, `EFFECT.KEY` numbers) applied,
    /// the family counts set, the families expanded, every name and number
    /// checked, the masses checked, the effects and drives resolved, the
    /// initial values taken by name, the scene's settings. Returns the
    /// scene as run (overrides applied, families expanded), whose output
    /// columns and figures the caller draws.
    ///
    /// # Errors
    /// [`SimError::UnknownName`] for an unknown override or name,
    /// [`SimError::Scene`] for an override that breaks a scene key,
    /// [`SimError::Setting`] for a bad mass, [`SimError::Effect`] for an
    /// effect the model cannot take.
    pub fn problem<M: Model + Default>(&self, sets: &[(String, f64)]) -> Result<(Problem<M>, Scene), SimError> {
        self.problem_with(M::default(), sets)
    }

    /// [`Scene::problem`] on `model` as given (its parameters the starting
    /// point the scene's `[params]` and `sets` change) instead of `M`'s
    /// default: what the `ezy` crate's commands call with an
    /// [`ezy_core::AnyModel`].
    ///
    /// # Errors
    /// As [`Scene::problem`].
    pub fn problem_with<M: Model>(
        &self,
        mut model: M,
        sets: &[(String, f64)],
    ) -> Result<(Problem<M>, Scene), SimError> {
        let base = model.info();
        let mut scene = self.clone();
        for (name, value) in sets {
            scene.set(&base, name, *value)?;
        }
        let scene_error = |e: SceneError| SimError::Scene { key: e.key(), message: e.message };
        // counts first: they decide the coordinates the rest of the scene names
        crate::registry::set_counts(&mut model, &scene.params).map_err(scene_error)?;
        let info = &model.info();
        let scene = scene.expand_families(info).map_err(scene_error)?;
        scene.check(info).map_err(scene_error)?;
        for (name, value) in &scene.params {
            model.set_param(info.param_index(name).expect("checked"), *value);
        }
        let value = |v: &InitValue| -> Result<f64, SimError> {
            match v {
                InitValue::Num(x) => Ok(*x),
                InitValue::Param(p) => Ok(model.param(lookup(
                    info,
                    "parameter",
                    p,
                    &info.params.iter().map(|p| p.name).collect::<Vec<_>>(),
                )?)),
            }
        };
        // a name, `stem*` for every coordinate of a family, or `theta_<hinge>`
        // (positions only); a later entry overrides an earlier one (`"phi*" =
        // 0.0, phi3 = 0.5`)
        type Values = Vec<(usize, f64)>;
        let given = |list: &[(String, InitValue)]| -> Result<(Values, Values), SimError> {
            let mut value_of: Vec<Option<f64>> = vec![None; info.nq()];
            let mut angle_of: Vec<Option<f64>> = vec![None; info.hinges.len()];
            for (name, v) in list {
                let x = value(v)?;
                match initial_targets(info, name)? {
                    InitialName::Coords(ks) => ks.into_iter().for_each(|k| value_of[k] = Some(x)),
                    InitialName::HingeAngle(h) => angle_of[h] = Some(x),
                }
            }
            let listed =
                |v: Vec<Option<f64>>| v.into_iter().enumerate().filter_map(|(k, v)| v.map(|x| (k, x))).collect();
            Ok((listed(value_of), listed(angle_of)))
        };
        let (given_q, angles) = given(&scene.initial.q)?;
        let (given_qd, _) = given(&scene.initial.qd)?;
        let (guess, _) = given(&scene.initial.guess)?;
        if let Some(&(k, _)) = guess.iter().find(|(k, _)| given_q.iter().any(|(j, _)| j == k)) {
            return Err(SimError::Scene {
                key: format!("initial.guess.{}", info.coords[k]),
                message: format!(
                    "`{}` is given in `initial.q`, so it is fixed; a starting value is for a coordinate the constraints determine",
                    info.coords[k]
                ),
            });
        }
        check_params(&model, info)?;
        check_masses(&model, info)?;
        let names = NameIndex::new(info);
        let cx = EffectContext::new(&model, &names).with_scene_params(&scene.scene_params);
        let effects = scene.effects.iter().map(|(n, e)| e.resolve_in(n, &cx)).collect::<Result<Vec<_>, _>>()?;
        let drives = scene.resolve_drives(info);
        let given = Given { q: given_q, qd: given_qd, angles, guess, released: Vec::new() };
        let settings = scene.run_settings();
        let problem = Problem {
            model,
            effects,
            drives,
            given,
            settings,
            baumgarte: None,
            kkt: KktMethod::Auto,
            events: Vec::new(),
            max_output_mb: ezy_core::problem::DEFAULT_MAX_MEMORY_MB,
        };
        let problem = scene.events.iter().try_fold(problem, |p, (name, e)| p.event(name, e))?;
        Ok((problem, scene))
    }
}
