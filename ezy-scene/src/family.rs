//! Families: an effect over `hinge = "J[*]"` (or a skate, point or body
//! family) and a drive `[drives."D[*]"]` become one item per element of
//! the family at the model's counts, with `phase_step` turned into each
//! element's phase and the scene parameters' bindings carried over
//! ([`crate::bind`]). The stage between the overrides and the check: it
//! needs the counts, and the check sees only single items.

use std::collections::HashSet;

use ezy_core::model::info::{ModelInfo, is_element_of};

use crate::bind::{apply_phase_step, has_phase_step, rebind, take_bindings};
use crate::error::{SceneError, known_or_none};
use crate::kinds::SceneEffect;
use crate::schema::{DriveSpec, Scene};

/// Each family effect's name with the names of its elements, in order.
type Families = Vec<(String, Vec<String>)>;

impl Scene {
    /// The scene with its family effects expanded for a model with `info`:
    /// an effect whose `hinge` or `skate` is written `NAME[*]` becomes one
    /// effect per element of that family (`J[*]`: `J2`, `J3`, ...), named
    /// by the effect's name and the element's index (`gait` on `J3`:
    /// `gait3`); in its waveforms, `phase_step` \[rad\] is added to the
    /// phase once per element along the family (a travelling wave, e.g.
    /// the serpenoid gait `tau_i = A sin(omega t + i delta)`). An event
    /// that switches a family effect (`switch_off = ["gait"]`) switches
    /// each of its elements; an element may be named alone (`gait3`). The
    /// elements' numbers stay bound to the scene parameters that gave them
    /// ([`Scene::bindings`]), except a `phase_step` and the `phase` it
    /// shifts, which differ per element: apply [`Scene::set`] first.
    ///
    /// # Errors
    /// A [`SceneError`] at the effect for a family the model does not
    /// have, a `phase_step` on an effect that is not over a family, or an
    /// expanded name that another effect already has.
    pub fn expand_families(&self, info: &ModelInfo) -> Result<Scene, SceneError> {
        self.clone().expanded(info)
    }

    /// [`Scene::expand_families`] of the scene itself, without a copy.
    ///
    /// # Errors
    /// As [`Scene::expand_families`].
    pub(crate) fn expanded(mut self, info: &ModelInfo) -> Result<Scene, SceneError> {
        let families = self.expand_effects(info)?;
        // an event switching a family effect switches each of its elements
        for (_, event) in &mut self.events {
            for list in [&mut event.switch_on, &mut event.switch_off] {
                if list.iter().any(|n| families.iter().any(|(f, _)| f == n)) {
                    *list = list
                        .iter()
                        .flat_map(|n| match families.iter().find(|(f, _)| f == n) {
                            Some((_, members)) => members.clone(),
                            None => vec![n.clone()],
                        })
                        .collect();
                }
            }
        }
        self.expand_drives(info)?;
        self.bindings.sort();
        Ok(self)
    }

    /// The effects over a family replaced by their elements, in place;
    /// returns each family effect's elements, for the events that switch
    /// it.
    fn expand_effects(&mut self, info: &ModelInfo) -> Result<Families, SceneError> {
        let given = std::mem::take(&mut self.effects);
        // every name given or made so far (a family of 10,000 makes as many)
        let mut taken: HashSet<String> = given.iter().map(|(n, _)| n.clone()).collect();
        let mut families: Families = Vec::new();
        for (name, spec) in given {
            let tree = toml::Value::try_from(&spec).expect("an effect serializes");
            let field = ["hinge", "skate", "at"]
                .into_iter()
                .find(|f| tree.get(f).and_then(toml::Value::as_str).is_some_and(|v| v.ends_with("[*]")));
            let Some(field) = field else {
                if has_phase_step(&tree) {
                    return Err(SceneError::at(
                        &["effects", &name],
                        "`phase_step` only applies to an effect over a family (`hinge = \"J[*]\"` or `skate = \"S[*]\"`)",
                    ));
                }
                self.effects.push((name, spec));
                continue;
            };
            let bound = take_bindings(&mut self.bindings, "effects", &name);
            let pattern = tree[field].as_str().expect("checked").to_string();
            let stem = pattern.trim_end_matches("[*]");
            let all: Vec<&str> = match field {
                "hinge" => info.hinges.iter().map(|h| h.name.as_str()).collect(),
                "skate" => info.skates.iter().map(|s| s.name.as_str()).collect(),
                // `at`: a point family, else a body family
                _ => {
                    let points: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
                    if points.iter().any(|n| is_element_of(n, stem)) {
                        points
                    } else {
                        info.bodies.iter().map(|b| b.name.as_str()).collect()
                    }
                }
            };
            let elements: Vec<&str> = all.iter().copied().filter(|n| is_element_of(n, stem)).collect();
            if elements.is_empty() {
                return Err(SceneError::at(
                    &["effects", &name, field],
                    format!(
                        "`{pattern}`: model {} has no {field} family `{stem}`; its {field}s: {}",
                        info.name,
                        known_or_none(&all)
                    ),
                ));
            }
            let mut members = Vec::with_capacity(elements.len());
            for (k, element) in elements.iter().enumerate() {
                let mut t = tree.clone();
                t[field] = toml::Value::String(element.to_string());
                apply_phase_step(&mut t, k as f64);
                let element_spec: SceneEffect = t.try_into().map_err(|e: toml::de::Error| {
                    SceneError::at(&["effects", &name], format!("expanding over `{pattern}`: {}", e.message()))
                })?;
                let element_spec = element_spec.inherit_kind(&spec);
                let expanded = format!("{name}{}", &element[stem.len()..]);
                if !taken.insert(expanded.clone()) {
                    return Err(SceneError::at(
                        &["effects", &name],
                        format!("expanding over `{pattern}` gives an effect `{expanded}`, a name already taken"),
                    ));
                }
                rebind(&bound, &tree, &expanded, &mut self.bindings);
                self.effects.push((expanded.clone(), element_spec));
                members.push(expanded);
            }
            families.push((name, members));
        }
        Ok(families)
    }

    /// The drives over a family (`[drives."D[*]"]`: every element of the
    /// model's drive family `D`) replaced by their elements, in place.
    fn expand_drives(&mut self, info: &ModelInfo) -> Result<(), SceneError> {
        let listed = std::mem::take(&mut self.drives);
        let mut given: HashSet<String> = listed.iter().map(|(n, _)| n.clone()).collect();
        for (name, spec) in listed {
            let tree = toml::Value::try_from(&spec).expect("a drive serializes");
            let Some(stem) = name.strip_suffix("[*]") else {
                if has_phase_step(&tree) {
                    return Err(SceneError::at(
                        &["drives", &name],
                        "`phase_step` only applies to a drive family (`[drives.\"D[*]\"]`)",
                    ));
                }
                self.drives.push((name, spec));
                continue;
            };
            let bound = take_bindings(&mut self.bindings, "drives", &name);
            let elements: Vec<&str> =
                info.drives.iter().map(|d| d.name.as_str()).filter(|n| is_element_of(n, stem)).collect();
            if elements.is_empty() {
                let all: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
                return Err(SceneError::at(
                    &["drives", &name],
                    format!("model {} has no drive family `{stem}`; its drives: {}", info.name, known_or_none(&all)),
                ));
            }
            for (k, element) in elements.iter().enumerate() {
                if !given.insert(element.to_string()) {
                    return Err(SceneError::at(
                        &["drives", &name],
                        format!("`{name}` and `[drives.{element}]` both give the angle of drive `{element}`"),
                    ));
                }
                let mut t = tree.clone();
                apply_phase_step(&mut t, k as f64);
                let spec: DriveSpec = t.try_into().map_err(|e: toml::de::Error| {
                    SceneError::at(&["drives", &name], format!("expanding over `{name}`: {}", e.message()))
                })?;
                rebind(&bound, &tree, element, &mut self.bindings);
                self.drives.push((element.to_string(), spec));
            }
        }
        Ok(())
    }
}
