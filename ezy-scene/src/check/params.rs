//! `[params]` (the model's parameters and family counts) and
//! `[scene_params]` (the scene's own named numbers, and the numbers of
//! effects and drives bound to them).

use ezy_core::model::info::ModelInfo;

use crate::error::{SceneError, known_or_none};
use crate::schema::Scene;

/// Largest family count a scene may set (a model of a million elements
/// needs gigabytes; larger counts are surely typos).
pub const MAX_COUNT: f64 = 1e6;

/// Checks the value of a family count `name` (`count N = ..;` in the model).
///
/// # Errors
/// A [`SceneError`] at `params.NAME` unless `value` is a whole number in
/// `1..=MAX_COUNT`.
pub fn check_count(name: &str, value: f64) -> Result<(), SceneError> {
    if (1.0..=MAX_COUNT).contains(&value) && value.fract() == 0.0 {
        Ok(())
    } else {
        Err(SceneError::at(
            &["params", name],
            format!(
                "{name} = {} is a count of elements: it must be a whole number from 1 to {}",
                ezy_core::fmt_value(value),
                ezy_core::fmt_value(MAX_COUNT)
            ),
        ))
    }
}

/// Checks `[params]` (known, finite, in range; a count whole and in
/// range), `[scene_params]` (identifiers, not a model parameter's name,
/// finite, in range) and the bindings (each to a declared scene
/// parameter).
///
/// # Errors
/// The first [`SceneError`].
pub(super) fn check(scene: &Scene, info: &ModelInfo) -> Result<Vec<(usize, f64)>, SceneError> {
    let mut indices = Vec::with_capacity(scene.params.len());
    for (name, v) in &scene.params {
        let Some(k) = info.param_index(name) else {
            return Err(SceneError::at(&["params", name], info.unknown_param(name)));
        };
        if !v.is_finite() {
            return Err(SceneError::at(&["params", name], format!("{name} = {v} must be finite")));
        }
        if info.params[k].count {
            check_count(name, *v)?;
        } else {
            ezy_core::check_magnitude(name, *v).map_err(|m| SceneError::at(&["params", name], m))?;
        }
        indices.push((k, *v));
    }
    for (name, v) in &scene.scene_params {
        let path = ["scene_params", name.as_str()];
        if !is_identifier(name) {
            return Err(SceneError::at(
                &path,
                format!("scene parameter `{name}` must be an identifier: a letter or _, then letters, digits and _"),
            ));
        }
        if info.param_index(name).is_some() {
            return Err(SceneError::at(
                &path,
                format!(
                    "`{name}` is both a scene parameter and a parameter of model {}: rename the scene parameter (a model parameter is changed in [params])",
                    info.name
                ),
            ));
        }
        if !v.is_finite() {
            return Err(SceneError::at(&path, format!("{name} = {v} must be finite")));
        }
        // the numbers it gives are checked where they stand, by their key;
        // past this bound no key takes it
        ezy_core::check_magnitude(name, *v).map_err(|m| SceneError::at(&path, m))?;
    }
    if let Some(b) = scene.bindings.iter().find(|b| !scene.scene_params.iter().any(|(n, _)| *n == b.param)) {
        let names: Vec<&str> = scene.scene_params.iter().map(|(n, _)| n.as_str()).collect();
        return Err(SceneError {
            path: b.path.clone(),
            message: format!(
                "`{}` is not a scene parameter; declared in [scene_params]: {}",
                b.param,
                known_or_none(&names)
            ),
        });
    }
    Ok(indices)
}

/// Whether `name` is an identifier: an ASCII letter or `_`, then ASCII
/// letters, digits and `_`.
fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}
