//! Models registered under keys, and scenes checked against them.
//!
//! A scene names its model by a key (`model = "ezyroller"`). Whoever runs
//! scenes keeps a table of keys: the `ezy` crate's `App` (the built-in
//! vehicles plus a user's own), or the built-ins alone
//! (`ezy_models::builtins()`). Both fill their table through [`Register`],
//! so a vehicle is registered by one line, and both check scenes through
//! [`ModelCatalog`] and [`check_scene`], so a user's scene is checked
//! against the user's model exactly as a built-in one is.

use ezy_core::effects::EffectContext;
use ezy_core::{EffectSpec, Model, ModelInfo, NameIndex, SetupError, SimError};

use crate::check::Checked;
use crate::error::{SceneError, SceneFileError};
use crate::kinds::EffectKinds;
use crate::schema::Scene;

/// Something models can be registered with under a key.
///
/// ```
/// # use ezy_scene::registry::{Register, InfoOnly, ModelCatalog};
/// # ezy_core::model! {
/// #     /// A sleigh.
/// #     pub struct Sleigh {
/// #         param a = 0.5;
/// #         body s(x, y, phi) { mass: 1.0, inertia: 0.1 }
/// #         point P on s at (-a, 0);
/// #         skate P: P along (1, 0);
/// #     }
/// # }
/// let mut models = InfoOnly::default();
/// models.register::<Sleigh>("sleigh");
/// assert_eq!(models.keys(), ["sleigh"]);
/// ```
pub trait Register {
    /// Registers model type `M` (at its `Default` parameters and counts)
    /// under `key`, the name scene files give in `model = "KEY"`. A key
    /// registered twice is a mistake the implementor reports (the `ezy`
    /// crate's `App` refuses to run any command until it is fixed).
    fn register<M: Model + Default + 'static>(&mut self, key: &str);
}

/// The description of a model at the family counts a scene's `[params]`
/// give (other parameters do not change it).
pub type InfoFn = fn(&[(String, f64)]) -> Result<ModelInfo, SceneError>;

/// A table of models by key that scenes are checked against.
pub trait ModelCatalog {
    /// The registered keys, in registration order.
    fn keys(&self) -> Vec<&str>;
    /// The description of the model registered as `key` with the family
    /// counts among `params` applied; `None` for an unknown key.
    ///
    /// # Errors
    /// The inner `Err` is a [`SceneError`] at `params.COUNT` when a count
    /// is not a whole number >= 1 or makes a family refer to an element
    /// that does not exist.
    fn info_with(&self, key: &str, params: &[(String, f64)]) -> Option<Result<ModelInfo, SceneError>>;

    /// The effect kinds of the user's own that scenes may name (default:
    /// none, the built-in kinds only).
    fn effect_kinds(&self) -> Option<&EffectKinds> {
        None
    }

    /// Resolves the effects of kinds of the user's own in `checked` (the
    /// scene bound, families expanded, checked) against the model
    /// registered as `key` at the scene's parameters (default: nothing to
    /// do; see [`check_user_effects`]).
    ///
    /// # Errors
    /// A [`SceneError`] at the effect's key the law refuses.
    fn check_user_effects(&self, _key: &str, _checked: &Checked) -> Result<(), SceneError> {
        Ok(())
    }
}

/// Resolves the effects of kinds of the user's own
/// ([`ezy_core::EffectSpec::User`], read into their types by the check)
/// in `checked` against `model` at the scene's parameters, so that a name
/// the law looks up or a number it refuses is reported at its key in the
/// file before any work (what [`ModelCatalog::check_user_effects`] does
/// for the `ezy` crate's `App`).
///
/// # Errors
/// A [`SceneError`] at `effects.NAME.KEY`, the key the law names.
pub fn check_user_effects<M: Model>(model: &M, checked: &Checked) -> Result<(), SceneError> {
    let is_user = |spec: &EffectSpec| matches!(spec, EffectSpec::User(_));
    if !checked.effects().any(|(_, spec)| is_user(spec)) {
        return Ok(());
    }
    let scene = checked.scene();
    let mut model = model.clone();
    let base = model.info();
    for (name, value) in &scene.params {
        if let Some(i) = base.param_index(name) {
            model.set_param(i, *value);
        }
    }
    let info = model.info();
    let names = NameIndex::new(&info);
    let cx = EffectContext::new(&model, &names).with_scene_params(&scene.scene_params);
    for (name, spec) in checked.effects().filter(|(_, spec)| is_user(spec)) {
        if let Err(e) = spec.resolve_in(name, &cx) {
            return Err(match e {
                // a field's error at the field; one of the whole table (an
                // unknown field) at the effect, without an empty key
                SimError::Setup(SetupError::Effect { field, message, .. }) => {
                    let mut path = vec!["effects".into(), name.to_string()];
                    if !field.is_empty() {
                        path.push(field.into());
                    }
                    SceneError { path, message }
                }
                e => SceneError { path: vec!["effects".into(), name.to_string()], message: e.to_string() },
            });
        }
    }
    Ok(())
}

/// [`InfoFn`] of model type `M`: its default with the counts among
/// `params` applied, checked.
///
/// # Errors
/// As [`ModelCatalog::info_with`].
pub fn info_at<M: Model + Default>(params: &[(String, f64)]) -> Result<ModelInfo, SceneError> {
    info_of(&M::default(), params)
}

/// [`info_at`] of `model` as given instead of `M`'s default.
///
/// # Errors
/// As [`ModelCatalog::info_with`].
pub fn info_of<M: Model>(model: &M, params: &[(String, f64)]) -> Result<ModelInfo, SceneError> {
    let mut model = model.clone();
    set_counts(&mut model, params)?;
    Ok(model.info())
}

/// Sets the family counts among `params` (name, value; other parameters
/// are left alone) on `model`, each checked to be a whole number >= 1,
/// then checks that every family refers to elements that exist: the one
/// place counts are applied (scene check, [`crate::schema::Scene::problem`]).
///
/// # Errors
/// A [`SceneError`] at `params.COUNT`.
pub fn set_counts<M: Model>(model: &mut M, params: &[(String, f64)]) -> Result<(), SceneError> {
    let base = model.info();
    let mut last = None;
    for (name, value) in params {
        if let Some(i) = base.param_index(name)
            && base.params[i].count
        {
            crate::check::params::check_count(name, *value)?;
            model.set_param(i, *value);
            last = Some(name.clone());
        }
    }
    model
        .check_counts()
        .map_err(|message| SceneError { path: vec!["params".into(), last.unwrap_or_default()], message })
}

/// The smallest [`Register`] + [`ModelCatalog`]: keys and descriptions,
/// enough to check scenes. Duplicate keys are kept in `duplicates`.
#[derive(Debug, Clone, Default)]
pub struct InfoOnly {
    models: Vec<(String, InfoFn)>,
    /// Keys registered more than once (the first registration is used).
    pub duplicates: Vec<String>,
}

impl Register for InfoOnly {
    fn register<M: Model + Default + 'static>(&mut self, key: &str) {
        if self.models.iter().any(|(k, _)| k == key) {
            self.duplicates.push(key.to_string());
        } else {
            self.models.push((key.to_string(), info_at::<M>));
        }
    }
}

impl ModelCatalog for InfoOnly {
    fn keys(&self) -> Vec<&str> {
        self.models.iter().map(|(k, _)| k.as_str()).collect()
    }
    fn info_with(&self, key: &str, params: &[(String, f64)]) -> Option<Result<ModelInfo, SceneError>> {
        self.models.iter().find(|(k, _)| k == key).map(|(_, f)| f(params))
    }
}

/// A loaded scene with its source text and where it came from.
#[derive(Debug, Clone)]
pub struct SceneSource {
    /// The checked scene.
    pub scene: Scene,
    /// The TOML text (for locating later errors).
    pub text: String,
    /// The file as errors name it (`models/scenes/drive.toml`, or the path given).
    pub file: String,
}

/// Checks a parsed scene against the model `models` registers under its
/// `model` key: counts, family expansion, and every name and number the
/// scene gives ([`Scene::checked`]), then the laws of the user's own
/// kinds ([`ModelCatalog::check_user_effects`]).
///
/// # Errors
/// [`SceneFileError`] at the `model` key for an unknown model (listing the
/// known ones), else as [`Scene::check_all`], located in `text` (file,
/// line, column, key): one error per part of the scene that has one.
pub fn check_scene(
    models: &dyn ModelCatalog,
    mut scene: Scene,
    text: &str,
    file: &str,
) -> Result<SceneSource, SceneFileError> {
    let Some(info) = models.info_with(&scene.model, &scene.params) else {
        let e = SceneError {
            path: vec!["model".into()],
            message: format!("unknown model `{}`; known models: {}", scene.model, models.keys().join(", ")),
        };
        return Err(Scene::locate_error(text, file, e));
    };
    let info = info.map_err(|e| Scene::locate_error(text, file, e))?;
    scene
        .bind_kinds(models.effect_kinds().unwrap_or(&EffectKinds::default()))
        .map_err(|e| Scene::locate_error(text, file, e))?;
    let locate = |errors: Vec<SceneError>| {
        SceneFileError::collect(errors.into_iter().map(|e| Scene::locate_error(text, file, e))).expect("an error")
    };
    let checked = scene.clone().checked(&info).map_err(locate)?;
    models.check_user_effects(&scene.model, &checked).map_err(|e| Scene::locate_error(text, file, e))?;
    Ok(SceneSource { scene, text: text.to_string(), file: file.to_string() })
}
