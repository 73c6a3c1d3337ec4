//! `[effects.NAME]`: each effect's name, and its spec (a kind of the
//! user's own read into its type, once) against the model's names and
//! each number's range.

use ezy_core::EffectSpec;
use ezy_core::effects::{SpecError, check_effect_name};
use ezy_core::model::info::{ModelInfo, NameIndex};

use crate::error::SceneError;
use crate::schema::Scene;

/// Checks each effect of `scene` apart: its name, then its spec
/// ([`EffectSpec::check_in`]). Returns, per effect in order, its spec as
/// the runtime takes it.
///
/// # Errors
/// Per effect, a [`SceneError`] at `effects.NAME` or at the field at fault.
pub(super) fn check(scene: &Scene, info: &ModelInfo) -> Vec<Result<EffectSpec, SceneError>> {
    let names = NameIndex::new(info);
    let at = |name: &str, err: SpecError| {
        let path: &[&str] = if err.field.is_empty() { &["effects", name] } else { &["effects", name, err.field] };
        SceneError::at(path, err.message)
    };
    (scene.effects.iter())
        .map(|(name, e)| {
            check_effect_name(name).map_err(|m| SceneError::at(&["effects", name], m))?;
            let spec = e.to_spec().map_err(|err| at(name, err))?;
            spec.check_in(&names, &scene.scene_params).map_err(|err| at(name, err))?;
            Ok(spec)
        })
        .collect()
}
