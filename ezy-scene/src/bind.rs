//! Scene parameters and overrides: the numbers of effects and drives a
//! scene parameter gives (`amplitude = "M0"` with `[scene_params] M0 =
//! 2.0`, found as the file is read: [`Binding`]), the command line's
//! `--set NAME=VALUE` ([`Scene::set`], [`Scene::with_sets`]: the first
//! stage of a run), the numbers an override can name ([`Scene::numbers`]),
//! the bindings and `phase_step`s a family's expansion carries over to its
//! elements ([`crate::family`]), and the binding of effects to kinds of the
//! user's own ([`Scene::bind_kinds`]).

use serde::Serialize;

use ezy_core::model::info::ModelInfo;
use ezy_core::{SetupError, SimError};

use crate::error::{SceneError, known_or_none};
use crate::schema::{Binding, Scene};

impl Scene {
    /// The scene as a run takes it: a copy with the command-line
    /// overrides `sets` applied in order ([`Scene::set`]), for the model
    /// `info` describes (at its default counts). The first stage of
    /// `Scene -> with_sets -> Checked -> Problem`.
    ///
    /// # Errors
    /// As [`Scene::set`].
    pub fn with_sets(&self, info: &ModelInfo, sets: &[(String, f64)]) -> Result<Scene, SimError> {
        let mut scene = self.clone();
        for (name, value) in sets {
            scene.set(info, name, *value)?;
        }
        Ok(scene)
    }

    /// Binds the scene's effects of kinds of the user's own
    /// ([`crate::SceneEffect::User`]) to the kinds `kinds` registers, so
    /// that [`Scene::check`] reads their fields and resolving builds their
    /// laws.
    ///
    /// # Errors
    /// A [`SceneError`] at `effects.NAME.kind` for a kind neither built in
    /// nor in `kinds`, listing the known kinds.
    pub fn bind_kinds(&mut self, kinds: &crate::kinds::EffectKinds) -> Result<(), SceneError> {
        for (name, spec) in &mut self.effects {
            spec.bind(kinds).map_err(|e| SceneError::at(&["effects", name, e.field], e.message))?;
        }
        Ok(())
    }

    /// Applies a command-line override `name = value`: a scene parameter
    /// (`M0`: every number bound to it changes, see [`Scene::bindings`]), a
    /// model parameter (`m2`), or a number inside an effect or a drive,
    /// `ITEM.KEY` with the full key path (`motor.torque.cos.amplitude`) or
    /// its last key when that is unambiguous (`motor.amplitude`); a key left
    /// at its default (`gravity.g`) is set by its name; an event's level,
    /// `EVENT.crosses`. A number set by its
    /// key is no longer bound to a scene parameter. Apply it before
    /// [`Scene::expand_families`] (which bakes a bound `phase` or
    /// `phase_step` of a family's waveform into each element's phase).
    ///
    /// # Errors
    /// [`SetupError::UnknownName`] listing the model parameters, the
    /// scene parameters and the effects' and drives' numeric keys;
    /// [`SetupError::Setting`] for a value that is not finite;
    /// [`SetupError::Scene`] for a name that is both a scene and a
    /// model parameter, a parameter the model defines by an expression
    /// (naming it), an ambiguous key, or a binding whose number is gone.
    pub fn set(&mut self, info: &ModelInfo, name: &str, value: f64) -> Result<(), SimError> {
        if !value.is_finite() {
            return Err(SimError::Setup(SetupError::Setting {
                name: name.into(),
                value,
                reason: "must be a finite number",
            }));
        }
        if let Some(k) = self.scene_params.iter().position(|(n, _)| n == name) {
            if info.param_index(name).is_some() {
                return Err(SimError::Setup(SetupError::Scene {
                    key: format!("scene_params.{name}"),
                    message: format!(
                        "`{name}` is both a scene parameter and a parameter of model {}: rename the scene parameter",
                        info.name
                    ),
                }));
            }
            self.scene_params[k].1 = value;
            let bound: Vec<Vec<String>> =
                self.bindings.iter().filter(|b| b.param == name).map(|b| b.path.clone()).collect();
            for path in bound {
                self.set_bound(&path, value)?;
            }
            return Ok(());
        }
        if info.param_index(name).is_some() {
            match self.params.iter_mut().find(|(n, _)| n == name) {
                Some((_, v)) => *v = value,
                None => self.params.push((name.to_string(), value)),
            }
            return Ok(());
        }
        if let Some((item, key)) = name.split_once('.') {
            let changed = if let Some((_, spec)) = self.effects.iter_mut().find(|(n, _)| n == item) {
                set_number(&*spec, key, value, name)?.map(|(changed, leaf)| {
                    *spec = changed.inherit_kind(spec);
                    ("effects", leaf)
                })
            } else if let Some((_, spec)) = self.drives.iter_mut().find(|(n, _)| n == item) {
                set_number(&*spec, key, value, name)?.map(|(changed, leaf)| {
                    *spec = changed;
                    ("drives", leaf)
                })
            } else {
                None
            };
            // an event's level: `EVENT.crosses`
            if changed.is_none()
                && key == "crosses"
                && let Some((_, spec)) = self.events.iter_mut().find(|(n, _)| n == item)
            {
                spec.crosses = value;
                return Ok(());
            }
            if let Some((section, leaf)) = changed {
                // the number is now the one given, no longer a scene parameter's
                let mut path = vec![section.to_string(), item.to_string()];
                path.extend(leaf.split('.').map(str::to_string));
                self.bindings.retain(|b| b.path != path);
                return Ok(());
            }
        }
        if info.derived.iter().any(|d| d.name == name) {
            return Err(SimError::Setup(SetupError::Scene {
                key: name.to_string(),
                message: info.unknown_param(name),
            }));
        }
        let mut known: Vec<String> = info.params.iter().map(|p| p.name.to_string()).collect();
        known.extend(self.scene_params.iter().map(|(n, _)| n.clone()));
        for (n, spec) in &self.effects {
            let tree = toml::Value::try_from(spec).expect("an effect serializes");
            known.extend(numeric_leaves(&tree).into_iter().map(|l| format!("{n}.{l}")));
        }
        for (n, spec) in &self.drives {
            let tree = toml::Value::try_from(spec).expect("a drive serializes");
            known.extend(numeric_leaves(&tree).into_iter().map(|l| format!("{n}.{l}")));
        }
        known.extend(self.events.iter().map(|(n, _)| format!("{n}.crosses")));
        Err(SimError::Setup(SetupError::UnknownName {
            kind: "parameter",
            name: name.to_string(),
            model: info.name,
            known: known.join(", "),
        }))
    }

    /// The numbers of effect or drive `item`, each with its full key path
    /// (`torque.cos.amplitude`) in the order the scene gives them: what
    /// [`Scene::set`] changes as `ITEM.KEY`. `None` if the scene has no
    /// effect or drive of that name.
    pub fn numbers(&self, item: &str) -> Option<Vec<(String, f64)>> {
        let tree = if let Some((_, spec)) = self.effects.iter().find(|(n, _)| n == item) {
            toml::Value::try_from(spec).ok()?
        } else {
            let (_, spec) = self.drives.iter().find(|(n, _)| n == item)?;
            toml::Value::try_from(spec).ok()?
        };
        Some(numeric_values(&tree))
    }

    /// Sets the bound number at `path` (`effects.ITEM...` or `drives.ITEM...`).
    fn set_bound(&mut self, path: &[String], value: f64) -> Result<(), SimError> {
        let fail = |message: String| {
            SimError::Setup(SetupError::Scene {
                key: SceneError { path: path.to_vec(), message: String::new() }.key(),
                message,
            })
        };
        let (section, item, leaf) = match path {
            [section, item, leaf @ ..] if !leaf.is_empty() => (section.as_str(), item, leaf),
            _ => return Err(fail("a scene parameter is bound to no number here".into())),
        };
        let changed =
            match section {
                "effects" => self.effects.iter_mut().find(|(n, _)| n == item).map(|(_, spec)| {
                    with_number(&*spec, leaf, value).map(|changed| *spec = changed.inherit_kind(spec))
                }),
                "drives" => self
                    .drives
                    .iter_mut()
                    .find(|(n, _)| n == item)
                    .map(|(_, spec)| with_number(&*spec, leaf, value).map(|changed| *spec = changed)),
                _ => None,
            };
        match changed {
            Some(r) => r.map_err(fail),
            None => Err(fail(format!("a scene parameter is bound to `{item}`, which the scene does not have"))),
        }
    }
}

/// Removes and returns the bindings to numbers of `section.item` (a family
/// item about to be expanded).
pub(crate) fn take_bindings(bindings: &mut Vec<Binding>, section: &str, item: &str) -> Vec<Binding> {
    let bound = bindings.iter().filter(|b| is_bound_in(section, item, b)).cloned().collect();
    bindings.retain(|b| !is_bound_in(section, item, b));
    bound
}

/// Binds the numbers of the family item's element `element` as `bound`
/// bound the item's (`tree` is the item, serialized), except a
/// `phase_step` and the `phase` it shifts, which differ per element.
pub(crate) fn rebind(bound: &[Binding], tree: &toml::Value, element: &str, bindings: &mut Vec<Binding>) {
    for b in bound.iter().filter(|b| !shifted_by_phase_step(tree, &b.path[2..])) {
        let mut path = b.path.clone();
        path[1] = element.to_string();
        bindings.push(Binding { path, param: b.param.clone() });
    }
}

/// Whether binding `b` is to a number of `section.item`.
fn is_bound_in(section: &str, item: &str, b: &Binding) -> bool {
    b.path.len() > 2 && b.path[0] == section && b.path[1] == item
}

/// Whether the number at key path `leaf` of the serialized effect `tree` is
/// a `phase_step`, or a `phase` next to a `phase_step` (family expansion
/// changes both).
fn shifted_by_phase_step(tree: &toml::Value, leaf: &[String]) -> bool {
    let Some((last, parents)) = leaf.split_last() else { return false };
    if last == "phase_step" {
        return true;
    }
    let mut node = tree;
    for p in parents {
        let next = match node {
            toml::Value::Table(t) => t.get(p),
            toml::Value::Array(a) => p.parse::<usize>().ok().and_then(|i| a.get(i)),
            _ => None,
        };
        match next {
            Some(n) => node = n,
            None => return false,
        }
    }
    last == "phase" && node.get("phase_step").is_some()
}

/// Whether a serialized effect has a nonzero `phase_step` anywhere.
pub(crate) fn has_phase_step(v: &toml::Value) -> bool {
    match v {
        toml::Value::Table(t) => t.iter().any(|(k, v)| {
            (k == "phase_step" && v.as_float().or(v.as_integer().map(|i| i as f64)) != Some(0.0)) || has_phase_step(v)
        }),
        toml::Value::Array(a) => a.iter().any(has_phase_step),
        _ => false,
    }
}

/// `phase += k * phase_step` in every harmonic of a serialized effect,
/// and `phase_step` removed.
pub(crate) fn apply_phase_step(v: &mut toml::Value, k: f64) {
    match v {
        toml::Value::Table(t) => {
            if let Some(step) = t.remove("phase_step") {
                let step = step.as_float().or(step.as_integer().map(|i| i as f64)).unwrap_or(0.0);
                let phase =
                    t.get("phase").and_then(|p| p.as_float().or(p.as_integer().map(|i| i as f64))).unwrap_or(0.0);
                t.insert("phase".into(), toml::Value::Float(phase + k * step));
            }
            for (_, v) in t.iter_mut() {
                apply_phase_step(v, k);
            }
        }
        toml::Value::Array(a) => a.iter_mut().for_each(|v| apply_phase_step(v, k)),
        _ => {}
    }
}

/// `spec` with the number at `key` set to `value`, and the full dotted path
/// of that number: `key` is a full dotted path or the unambiguous last part
/// of one, or a top-level key the serialization left out (a default) that
/// `spec`'s type accepts. `None` if no number matches.
///
/// # Errors
/// [`SetupError::Scene`] when `key` matches several numbers.
fn set_number<T: Serialize + serde::de::DeserializeOwned>(
    spec: &T,
    key: &str,
    value: f64,
    name: &str,
) -> Result<Option<(T, String)>, SimError> {
    let mut tree = toml::Value::try_from(spec).expect("a scene item serializes");
    let leaves = numeric_leaves(&tree);
    let matches: Vec<&String> = leaves.iter().filter(|l| *l == key || l.ends_with(&format!(".{key}"))).collect();
    match matches[..] {
        [path] => {
            let unreachable = || {
                SimError::Setup(SetupError::Scene {
                    key: name.to_string(),
                    message: format!("`{path}` cannot be set: a key on its way contains a `.`"),
                })
            };
            let mut node = &mut tree;
            for part in path.split('.') {
                node = match node {
                    toml::Value::Table(t) => t.get_mut(part).ok_or_else(unreachable)?,
                    toml::Value::Array(a) => {
                        part.parse::<usize>().ok().and_then(|i| a.get_mut(i)).ok_or_else(unreachable)?
                    }
                    _ => return Err(unreachable()),
                };
            }
            *node = number_like(node, value);
            let changed = tree.try_into().map_err(|e: toml::de::Error| {
                SimError::Setup(SetupError::Scene { key: name.to_string(), message: e.message().trim().to_string() })
            })?;
            Ok(Some((changed, path.clone())))
        }
        [] => {
            // a key at its default is not serialized: try it as a new key
            if let toml::Value::Table(t) = &mut tree
                && !key.contains('.')
                && !t.contains_key(key)
            {
                t.insert(key.to_string(), toml::Value::Float(value));
                return Ok(tree.try_into().ok().map(|changed| (changed, key.to_string())));
            }
            Ok(None)
        }
        _ => Err(SimError::Setup(SetupError::Scene {
            key: name.to_string(),
            message: format!(
                "`{key}` matches several numbers ({}); give the full key",
                matches.iter().map(|m| m.as_str()).collect::<Vec<_>>().join(", ")
            ),
        })),
    }
}

/// `value` as the TOML number that replaces `old`: an integer where `old`
/// is one and `value` is whole (a count field of a user's effect kind
/// stays an integer), a float otherwise.
fn number_like(old: &toml::Value, value: f64) -> toml::Value {
    if old.is_integer() && value.fract() == 0.0 && value.abs() < 9e15 {
        toml::Value::Integer(value as i64)
    } else {
        toml::Value::Float(value)
    }
}

/// `spec` with the number at the key path `path` set to `value` (a number
/// at its default, left out of the serialization, is added).
///
/// # Errors
/// What is wrong, when the path leads to no number of `spec`'s type.
fn with_number<T: Serialize + serde::de::DeserializeOwned>(spec: &T, path: &[String], value: f64) -> Result<T, String> {
    let mut tree = toml::Value::try_from(spec).map_err(|e| e.to_string())?;
    let old = path.iter().try_fold(&tree, |node, part| match node {
        toml::Value::Table(t) => t.get(part),
        toml::Value::Array(a) => a.get(part.parse::<usize>().ok()?),
        _ => None,
    });
    let new = old.map_or(toml::Value::Float(value), |old| number_like(old, value));
    set_path(&mut tree, path, new).ok_or("the key path leads to no number")?;
    tree.try_into().map_err(|e: toml::de::Error| e.message().trim().to_string())
}

/// Dotted paths of the numbers in a TOML tree (`torque.cos.amplitude`,
/// `torque.harmonics.1.omega`).
fn numeric_leaves(v: &toml::Value) -> Vec<String> {
    numeric_values(v).into_iter().map(|(leaf, _)| leaf).collect()
}

/// Every number in `v` with its dotted key path (array items by index).
fn numeric_values(v: &toml::Value) -> Vec<(String, f64)> {
    fn walk(v: &toml::Value, prefix: &str, out: &mut Vec<(String, f64)>) {
        let join = |k: &str| if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
        match v {
            toml::Value::Float(x) => out.push((prefix.to_string(), *x)),
            toml::Value::Integer(i) => out.push((prefix.to_string(), *i as f64)),
            toml::Value::Table(t) => t.iter().for_each(|(k, v)| walk(v, &join(k), out)),
            toml::Value::Array(a) => a.iter().enumerate().for_each(|(i, v)| walk(v, &join(&i.to_string()), out)),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, "", &mut out);
    out
}

/// In the parsed file `root`: replaces every string in a number's place
/// inside `[effects.NAME]` (keys other than [`crate::kinds::NAME_KEYS`])
/// and `[drives.NAME]` by the value of the scene parameter it names, the
/// very token written in `[scene_params]` (so the number is bit for bit the
/// one written there), keeping the string's span for later errors.
/// Returns the places, sorted by path.
///
/// # Errors
/// A [`SceneError`] at a scene parameter that is not a number, or at a
/// string that names no scene parameter (listing the declared ones).
pub(crate) fn bind_scene_params(root: &mut toml::de::DeTable<'_>) -> Result<Vec<Binding>, SceneError> {
    use toml::de::DeValue;
    let mut declared: Vec<(String, DeValue<'_>)> = Vec::new();
    if let Some((_, table)) = root.iter().find(|(k, _)| k.get_ref().as_ref() == "scene_params")
        && let DeValue::Table(table) = table.get_ref()
    {
        for (k, v) in table.iter() {
            let name = k.get_ref().to_string();
            match v.get_ref() {
                DeValue::Integer(_) | DeValue::Float(_) => declared.push((name, v.get_ref().clone())),
                other => {
                    return Err(SceneError::at(
                        &["scene_params", &name],
                        format!("scene parameter `{name}` must be a number, not a {}", other.type_str()),
                    ));
                }
            }
        }
    }
    let mut bindings = Vec::new();
    for section in ["effects", "drives"] {
        let Some((_, items)) = root.iter_mut().find(|(k, _)| k.get_ref().as_ref() == section) else { continue };
        let DeValue::Table(items) = items.get_mut() else { continue };
        for (item, v) in items.iter_mut() {
            let mut path = vec![section.to_string(), item.get_ref().to_string()];
            bind_numbers(v, &mut path, section == "effects", &declared, &mut bindings)?;
        }
    }
    bindings.sort();
    Ok(bindings)
}

/// The numbers of `v` (key path `path`) that name a scene parameter,
/// each replaced by its value and recorded; `effect_table` skips the
/// name keys of an effect's own table.
fn bind_numbers<'i>(
    v: &mut toml::Spanned<toml::de::DeValue<'i>>,
    path: &mut Vec<String>,
    effect_table: bool,
    declared: &[(String, toml::de::DeValue<'i>)],
    out: &mut Vec<Binding>,
) -> Result<(), SceneError> {
    crate::kinds::number_strings(v, path, effect_table, &mut |v, path| {
        let Some(name) = v.get_ref().as_str().map(str::to_string) else { return Ok(()) };
        let Some((_, value)) = declared.iter().find(|(n, _)| *n == name) else {
            let names: Vec<&str> = declared.iter().map(|(n, _)| n.as_str()).collect();
            return Err(SceneError {
                path: path.to_vec(),
                message: format!(
                    "`{name}` is neither a number nor a scene parameter; declared in [scene_params]: {}",
                    known_or_none(&names)
                ),
            });
        };
        *v.get_mut() = value.clone();
        out.push(Binding { path: path.to_vec(), param: name });
        Ok(())
    })
}

/// Sets the value at `path` (keys; array entries by index) in `tree`,
/// making the tables on the way that are missing (a number at its default
/// is not serialized). `None` if the path runs into a non-table or past an
/// array's end.
pub(crate) fn set_path(tree: &mut toml::Value, path: &[String], value: toml::Value) -> Option<()> {
    let Some((last, parents)) = path.split_last() else {
        *tree = value;
        return Some(());
    };
    let mut node = tree;
    for part in parents {
        node = match node {
            toml::Value::Table(t) => t.entry(part.clone()).or_insert_with(|| toml::Value::Table(Default::default())),
            toml::Value::Array(a) => a.get_mut(part.parse::<usize>().ok()?)?,
            _ => return None,
        };
    }
    match node {
        toml::Value::Table(t) => {
            t.insert(last.clone(), value);
        }
        toml::Value::Array(a) => *a.get_mut(last.parse::<usize>().ok()?)? = value,
        _ => return None,
    }
    Some(())
}
