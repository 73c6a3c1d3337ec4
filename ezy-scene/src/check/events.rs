//! `[events.NAME]`: each event's name, level, watched quantity and the
//! effects it switches, resolved against the model, the scene's effects
//! and the model's drives into the [`Event`] the run watches.

use ezy_core::events::{Quantity, check_event_name, friction_force_unwatched};
use ezy_core::model::info::ModelInfo;
use ezy_core::{EffectSpec, Event};

use crate::error::SceneError;
use crate::kinds::SceneEffect;
use crate::schema::Scene;

/// Checks each event of `scene` apart. Returns, per event in order, the
/// event as the run takes it.
///
/// # Errors
/// Per event, a [`SceneError`] at `events.NAME` or at the key at fault.
pub(super) fn check(scene: &Scene, info: &ModelInfo) -> Vec<Result<Event, SceneError>> {
    let effect_columns: Vec<(String, String)> =
        scene.effects.iter().map(|(n, e)| (n.clone(), e.value_column(n))).collect();
    let effect_columns: Vec<(&str, &str)> = effect_columns.iter().map(|(n, v)| (n.as_str(), v.as_str())).collect();
    let drive_names: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
    // a skate's friction switches itself: no event watches or switches it
    let switchable: Vec<(&str, bool)> = (scene.effects.iter())
        .map(|(n, e)| (n.as_str(), matches!(e, SceneEffect::Builtin(EffectSpec::SkateFriction(_)))))
        .collect();
    (scene.events.iter())
        .map(|(name, event)| {
            let at = |key: &str, message: String| SceneError::at(&["events", name, key], message);
            check_event_name(name).map_err(|m| SceneError::at(&["events", name], m))?;
            if !event.crosses.is_finite() {
                return Err(at("crosses", format!("the level must be a finite number, not {}", event.crosses)));
            }
            let quantity =
                Quantity::resolve(&event.when, info, &effect_columns, &drive_names).map_err(|m| at("when", m))?;
            if let Quantity::EffectValue(k) = quantity
                && let Some(&(effect, true)) = switchable.get(k)
            {
                return Err(at("when", friction_force_unwatched(&event.when, effect)));
            }
            let (switch_on, switch_off) = event.switched(&switchable).map_err(|(key, m)| at(key, m))?;
            Ok(Event {
                name: name.clone(),
                quantity,
                level: event.crosses,
                direction: event.direction,
                action: event.action,
                switch_on,
                switch_off,
            })
        })
        .collect()
}
