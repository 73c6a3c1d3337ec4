//! From a checked scene to the [`Problem`] it describes: the last stage of
//! `Scene -> with_sets -> Checked -> Problem`. It sets what the check
//! established on the model (parameters, initial values by index, the
//! effects' specs, the drives, the events) and checks only what needs
//! the model's values: the parameters' and masses' ranges, the effects'
//! laws at the model's geometry.

use ezy_core::effects::EffectContext;
use ezy_core::formulation::initial::Given as GivenValues;
use ezy_core::kkt::KktMethod;
use ezy_core::problem::{check_masses, check_params};
use ezy_core::{InitialName, Model, ModelInfo, NameIndex, Problem, SetupError, SimError};

use crate::check::Checked;
use crate::check::initial::{Given, Source};
use crate::error::SceneError;
use crate::schema::Scene;

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
    /// [`SetupError::UnknownName`] for an unknown override or name,
    /// [`SetupError::Scene`] for an override that breaks a scene key,
    /// [`SetupError::Setting`] for a bad mass, [`SetupError::Effect`] for an
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
        let scene = self.with_sets(&model.info(), sets)?;
        let scene_error = |e: SceneError| SimError::Setup(SetupError::Scene { key: e.key(), message: e.message });
        // counts first: they decide the coordinates the rest of the scene names
        crate::registry::set_counts(&mut model, &scene.params).map_err(scene_error)?;
        let info = model.info();
        let checked =
            scene.checked(&info).map_err(|errors| scene_error(errors.into_iter().next().expect("an error")))?;
        checked.problem(model, &info)
    }

    /// The run settings this scene asks for: its integrator, tolerances,
    /// projection, `t_end` and output interval, with the default energy
    /// balance guard ([`ezy_core::settings::BALANCE_LIMIT`]). Callers override
    /// fields with struct update syntax.
    pub fn run_settings(&self) -> ezy_core::RunSettings {
        ezy_core::RunSettings {
            dt: self.integrator.dt,
            t_end: self.t_end,
            every: self.output.every,
            projection: self.integrator.projection,
            method: self.integrator.method,
            formulation: self.integrator.formulation,
            rtol: self.integrator.rtol,
            atol: self.integrator.atol,
            balance_limit: Some(ezy_core::settings::BALANCE_LIMIT),
            max_steps: Some(ezy_core::settings::DEFAULT_MAX_STEPS),
        }
    }
}

/// `(index, value)` pairs: coordinates or hinges and their values.
type Values = Vec<(usize, f64)>;

impl Checked {
    /// The problem on `model`, the model the scene was checked against
    /// (its family counts set; `info` its description), with the scene's
    /// parameters set. Returns the scene as run.
    ///
    /// # Errors
    /// [`SetupError::Scene`] for a starting value of a given coordinate and
    /// a parameter out of range, [`SetupError::Setting`] for a bad mass,
    /// [`SetupError::Effect`] for an effect the model cannot take.
    pub(crate) fn problem<M: Model>(self, mut model: M, info: &ModelInfo) -> Result<(Problem<M>, Scene), SimError> {
        let Checked { scene, params, initial, effects, drives, events } = self;
        for (k, value) in params {
            model.set_param(k, value);
        }
        let (given_q, angles) = values(&model, info, &initial.q);
        let (given_qd, _) = values(&model, info, &initial.qd);
        let (guess, _) = values(&model, info, &initial.guess);
        if let Some(&(k, _)) = guess.iter().find(|(k, _)| given_q.iter().any(|(j, _)| j == k)) {
            return Err(SimError::Setup(SetupError::Scene {
                key: format!("initial.guess.{}", info.coords[k]),
                message: format!(
                    "`{}` is given in `initial.q`, so it is fixed; a starting value is for a coordinate the constraints determine",
                    info.coords[k]
                ),
            }));
        }
        check_params(&model, info)?;
        check_masses(&model, info)?;
        let names = NameIndex::new(info);
        let cx = EffectContext::new(&model, &names).with_scene_params(&scene.scene_params);
        let effects =
            scene.effects.iter().zip(&effects).map(|((n, _), e)| e.resolve_in(n, &cx)).collect::<Result<_, _>>()?;
        let given = GivenValues { q: given_q, qd: given_qd, angles, guess, released: Vec::new() };
        let problem = Problem {
            model,
            effects,
            drives,
            given,
            settings: scene.run_settings(),
            baumgarte: None,
            kkt: KktMethod::Auto,
            events: Vec::new(),
            max_output_mb: ezy_core::problem::DEFAULT_MAX_MEMORY_MB,
        };
        let problem = events.into_iter().try_fold(problem, Problem::with_event)?;
        Ok((problem, scene))
    }
}

/// The values the checked initial entries `list` give, by coordinate and
/// by hinge, a later entry overriding an earlier one (`"phi*" = 0.0,
/// phi3 = 0.5`); a parameter's value is `model`'s.
fn values<M: Model>(model: &M, info: &ModelInfo, list: &[Given]) -> (Values, Values) {
    let mut value_of: Vec<Option<f64>> = vec![None; info.nq()];
    let mut angle_of: Vec<Option<f64>> = vec![None; info.hinges.len()];
    for given in list {
        let x = match given.value {
            Source::Num(x) => x,
            Source::Param(k) => model.param(k),
        };
        match &given.target {
            InitialName::Coords(ks) => ks.iter().for_each(|&k| value_of[k] = Some(x)),
            InitialName::HingeAngle(h) => angle_of[*h] = Some(x),
        }
    }
    let listed = |v: Vec<Option<f64>>| v.into_iter().enumerate().filter_map(|(k, v)| v.map(|x| (k, x))).collect();
    (listed(value_of), listed(angle_of))
}
