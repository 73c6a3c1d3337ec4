//! The check: a scene (overrides applied, families expanded) against the
//! model at its counts, every name and every number, before any work. It
//! collects the first error of each part that can be checked apart, in
//! the order of the file's sections, one module per section; and what a
//! part establishes (parameter indices, initial values' targets, the
//! effects' specs read into their types, the drives in the model's
//! order, the events resolved) is kept in the [`Checked`] scene the
//! problem is built from ([`crate::problem`]), so nothing is looked up or
//! validated twice.

mod drives;
mod effects;
mod events;
pub(crate) mod initial;
mod integrator;
mod output;
pub(crate) mod params;

use ezy_core::drive::Drive;
use ezy_core::model::info::ModelInfo;
use ezy_core::{EffectSpec, Event};

use crate::error::SceneError;
use crate::schema::Scene;

pub use params::{MAX_COUNT, check_count};

use initial::Targets;
pub use output::MAX_FIGURE_NAME;

/// A scene checked against the model at its counts: the scene as it runs
/// (overrides applied, families expanded, kinds of the user's own bound)
/// with what its check established. Made by [`Scene::checked`]; what
/// [`Scene::problem`] builds the problem from, without a second check.
#[derive(Debug, Clone)]
pub struct Checked {
    /// The scene as run: overrides applied, families expanded.
    pub(crate) scene: Scene,
    /// Index and value of each `[params]` entry.
    pub(crate) params: Vec<(usize, f64)>,
    /// The initial values' targets and sources.
    pub(crate) initial: Targets,
    /// Each effect's spec (a kind of the user's own read into its type),
    /// in the order of `scene.effects`.
    pub(crate) effects: Vec<EffectSpec>,
    /// The model's drives with the scene's angles, in the model's order.
    pub(crate) drives: Vec<Drive>,
    /// The events, resolved against the model, effects and drives.
    pub(crate) events: Vec<Event>,
}

impl Checked {
    /// The scene as checked: overrides applied, families expanded.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The scene as checked, given up.
    pub fn into_scene(self) -> Scene {
        self.scene
    }

    /// Each effect's name and spec as checked (a kind of the user's own
    /// read into its type once), in the scene's order.
    pub fn effects(&self) -> impl Iterator<Item = (&str, &EffectSpec)> {
        self.scene.effects.iter().map(|(n, _)| n.as_str()).zip(&self.effects)
    }
}

/// What the parts of a check established, when none failed.
struct Established {
    params: Vec<(usize, f64)>,
    initial: Targets,
    effects: Vec<EffectSpec>,
    drives: Vec<Drive>,
    events: Vec<Event>,
}

impl Scene {
    /// The scene checked against the model `info` describes (at the
    /// scene's family counts): its families expanded
    /// ([`Scene::expand_families`]), then every part checked
    /// ([`Scene::check_all`]). The stage between [`Scene::with_sets`] and
    /// the problem.
    ///
    /// # Errors
    /// The expansion's [`SceneError`] alone, else the first error of every
    /// part that has one, in the order of the file's sections.
    pub fn checked(self, info: &ModelInfo) -> Result<Checked, Vec<SceneError>> {
        let scene = self.expanded(info).map_err(|e| vec![e])?;
        let Established { params, initial, effects, drives, events } = establish(&scene, info)?;
        Ok(Checked { scene, params, initial, effects, drives, events })
    }

    /// Checks every name against the model and every number against its
    /// range, before any work.
    ///
    /// # Errors
    /// The first [`SceneError`], with the key path and the known names.
    pub fn check(&self, info: &ModelInfo) -> Result<(), SceneError> {
        match self.check_all(info).into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// As [`Scene::check`], collecting the first error of each part
    /// that can be checked apart: the name, the parameters, the initial
    /// values, the settings, each effect, the drives, each event, the
    /// output columns, each figure and each drawn body (a scene with
    /// mistakes in three parts gets three errors, in the order of the
    /// file's sections).
    pub fn check_all(&self, info: &ModelInfo) -> Vec<SceneError> {
        establish(self, info).err().unwrap_or_default()
    }
}

/// The errors of a check so far.
#[derive(Default)]
struct Errors(Vec<SceneError>);

impl Errors {
    /// The part's value, or `None` with its error kept.
    fn keep<T>(&mut self, part: Result<T, SceneError>) -> Option<T> {
        part.map_err(|e| self.0.push(e)).ok()
    }
}

/// Checks every part of `scene` (families expanded) against `info`, in
/// the order of the file's sections, keeping what each establishes.
fn establish(scene: &Scene, info: &ModelInfo) -> Result<Established, Vec<SceneError>> {
    let mut errors = Errors::default();
    errors.keep(check_name(&scene.name));
    let params = errors.keep(params::check(scene, info));
    errors.keep(crate::units::check_model_units(&scene.units, info));
    let initial = errors.keep(initial::check(&scene.initial, info));
    errors.keep(integrator::check(scene));
    let effects: Vec<Option<EffectSpec>> = effects::check(scene, info).into_iter().map(|e| errors.keep(e)).collect();
    let drives = errors.keep(drives::check(scene, info));
    let events: Vec<Option<Event>> = events::check(scene, info).into_iter().map(|e| errors.keep(e)).collect();
    for part in output::check(scene, info) {
        errors.keep(part);
    }
    if !errors.0.is_empty() {
        return Err(errors.0);
    }
    let all = "no error: every part is checked";
    Ok(Established {
        params: params.expect(all),
        initial: initial.expect(all),
        effects: effects.into_iter().collect::<Option<_>>().expect(all),
        drives: drives.expect(all),
        events: events.into_iter().collect::<Option<_>>().expect(all),
    })
}

/// Checks the scene's name: it names the output directory.
fn check_name(name: &str) -> Result<(), SceneError> {
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(SceneError::at(
            &["name"],
            format!("scene name `{name}` must be letters, digits, - and _ (it names the output directory)"),
        ));
    }
    Ok(())
}
