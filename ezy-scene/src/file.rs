//! The scene file: its text read into a [`Scene`] and written back, and
//! errors placed in it. A mistake the reading finds ([`Scene::from_toml`]:
//! syntax, types, unknown keys, an array out of place, a scene parameter
//! that is not one) is placed by the TOML reader's span; one a later stage
//! finds is a [`SceneError`] (a key path and a message) that
//! [`Scene::locate_error`] places at the key's line and column. Files are
//! read with a bound ([`ezy_core::files`]).

use std::path::Path;

use serde::Deserialize;

use ezy_core::model::info::ModelInfo;

use crate::bind::{bind_scene_params, set_path};
use crate::error::{SceneError, SceneFileError};
use crate::schema::Scene;

/// Largest scene file read \[bytes\]: 1 MiB. The largest built-in scene
/// is under 4 KiB; a spline of 10,000 knots fits easily.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// Line and column (from 1) of byte offset `pos` in `src`.
fn line_column(src: &str, pos: usize) -> (usize, usize) {
    let before = &src[..pos.min(src.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Byte span of the value at `path` in the TOML text `src`: the deepest
/// prefix of the path that exists (so a missing key points at its table).
fn locate(src: &str, path: &[String]) -> Option<std::ops::Range<usize>> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(src).ok()?;
    let mut span = None;
    let mut table = Some(root.get_ref());
    let mut array = None;
    for p in path {
        let next = if let Some(t) = table {
            t.iter().find(|(k, _)| k.get_ref().as_ref() == p.as_str()).map(|(_, v)| v)
        } else if let (Some(a), Ok(i)) = (array, p.parse::<usize>()) {
            let a: &toml::de::DeArray<'_> = a;
            a.get(i)
        } else {
            None
        };
        let Some(v) = next else { break };
        span = Some(v.span());
        (table, array) = match v.get_ref() {
            DeValue::Table(t) => (Some(t), None),
            DeValue::Array(a) => (None, Some(a)),
            _ => (None, None),
        };
    }
    span
}

impl Scene {
    /// Parses a scene file. `file` only names it in errors.
    ///
    /// A number inside `[effects.NAME]` (except the name keys
    /// [`crate::NAME_KEYS`]) or `[drives.NAME]` may be written as
    /// the name of a scene parameter (`amplitude = "M0"` with
    /// `[scene_params] M0 = 2.0`): it takes that parameter's value, exactly
    /// as written there, and the place is recorded in [`Scene::bindings`].
    ///
    /// # Errors
    /// [`SceneFileError`] at the line and column of a syntax error, a value
    /// of the wrong type, an unknown or missing key, or an unknown effect
    /// kind (the message lists the known ones). An error inside an effect's
    /// fields is placed at the effect's `[effects.NAME]` header, with that
    /// key (serde reads an internally tagged table as a whole). A name in a
    /// number's place that is not a scene parameter, and a scene parameter
    /// that is not a number, are placed at the value itself (the message
    /// lists the scene parameters).
    pub fn from_toml(src: &str, file: &str) -> Result<Scene, SceneFileError> {
        let located = |e: toml::de::Error| {
            let start = e.span().map_or(0, |s| s.start);
            let (line, column) = line_column(src, start);
            // Inside an `[effects.NAME]` table (an internally tagged enum,
            // which serde buffers) the span is the table's header: name it.
            let rest = &src[start.min(src.len())..];
            let at_line_start = start == 0 || src[..start.min(src.len())].ends_with('\n');
            let key = rest
                .strip_prefix('[')
                .filter(|r| at_line_start && r.starts_with(|c: char| c.is_alphabetic()))
                .and_then(|r| r.split_once(']'))
                .map(|(k, _)| k.trim().to_string());
            SceneFileError {
                file: file.to_string(),
                line,
                column,
                key,
                message: e.message().trim().to_string(),
                also: Vec::new(),
            }
        };
        let mut root = toml::de::DeTable::parse(src).map_err(located)?;
        refuse_misplaced_arrays(root.get_ref(), &mut Vec::new()).map_err(|e| Self::locate_error(src, file, e))?;
        let units = crate::units::convert(root.get_mut()).map_err(|e| Self::locate_error(src, file, e))?;
        let bindings = bind_scene_params(root.get_mut()).map_err(|e| Self::locate_error(src, file, e))?;
        // the tree keeps the spans of the text, so errors are placed as before
        let mut scene = Scene::deserialize(toml::de::Deserializer::from(root)).map_err(located)?;
        scene.bindings = bindings;
        apply_units(&units, scene).map_err(|message| SceneFileError {
            file: file.to_string(),
            line: 1,
            column: 1,
            key: None,
            message,
            also: Vec::new(),
        })
    }

    /// Parses and checks a scene file against the model `info`.
    ///
    /// # Errors
    /// As [`Scene::from_toml`] and [`Scene::check_all`], located in the
    /// file (every part's mistake, [`SceneFileError::also`]).
    pub fn load(src: &str, file: &str, info: &ModelInfo) -> Result<Scene, SceneFileError> {
        let scene = Self::from_toml(src, file)?;
        let errors = scene.check_all(info).into_iter().map(|e| Self::locate_error(src, file, e));
        match SceneFileError::collect(errors) {
            Some(e) => Err(e),
            None => Ok(scene),
        }
    }

    /// Places a [`SceneError`] in the file text.
    pub fn locate_error(src: &str, file: &str, e: SceneError) -> SceneFileError {
        let (line, column) = locate(src, &e.path).map_or((1, 1), |s| line_column(src, s.start));
        SceneFileError {
            file: file.to_string(),
            line,
            column,
            key: Some(e.key()),
            message: e.message,
            also: Vec::new(),
        }
    }

    /// Reads and parses a scene file from disk.
    ///
    /// # Errors
    /// [`SceneFileError`] (line 0) if the file cannot be read, is not a
    /// regular file (a FIFO, a device, a directory) or is larger than
    /// [`MAX_SCENE_BYTES`], else as [`Scene::from_toml`].
    pub fn read(path: &Path) -> Result<(Scene, String), SceneFileError> {
        let file = path.display().to_string();
        let error = |message: String| SceneFileError {
            file: file.clone(),
            line: 0,
            column: 0,
            key: None,
            message,
            also: Vec::new(),
        };
        // a regular file only, and at most one byte past the cap: a huge
        // file, a device or a FIFO is refused without being held in memory
        // or waited on
        let src = ezy_core::files::read_capped_text(path, MAX_SCENE_BYTES, "the scene file").map_err(error)?;
        Ok((Self::from_toml(&src, &file)?, src))
    }

    /// Writes the scene as TOML, with the name of its scene parameter in
    /// the place of every bound number (so that [`Scene::from_toml`] gives
    /// the same scene back).
    ///
    /// # Panics
    /// Never for a scene: every field has a TOML form.
    pub fn to_toml(&self) -> String {
        if self.bindings.is_empty() {
            return toml::to_string(self).expect("a scene serializes to TOML");
        }
        let mut tree = toml::Value::try_from(self).expect("a scene serializes to TOML");
        for b in &self.bindings {
            set_path(&mut tree, &b.path, toml::Value::String(b.param.clone()))
                .expect("a binding's path leads through tables and arrays");
        }
        toml::to_string(&tree).expect("a scene serializes to TOML")
    }
}

/// `scene` with each number the file wrote with a unit set to its SI
/// value (read with a placeholder in its place: the parsed tree holds
/// only the text's own numbers), and the places to check against the
/// model kept.
///
/// # Errors
/// The scene's serde message, should the tree not read back (it is the
/// scene's own serialization, with numbers in numbers' places).
fn apply_units(units: &crate::units::Converted, scene: Scene) -> Result<Scene, String> {
    if units.values.is_empty() {
        return Ok(scene);
    }
    let mut tree = toml::Value::try_from(&scene).map_err(|e| e.to_string())?;
    for (path, v) in &units.values {
        set_path(&mut tree, path, toml::Value::Float(*v)).ok_or("a unit's place is gone")?;
    }
    let mut out: Scene = tree.try_into().map_err(|e: toml::de::Error| e.message().trim().to_string())?;
    out.bindings = scene.bindings;
    out.units = units.uses.clone();
    Ok(out)
}

/// The keys whose value is an array in a scene file; an array anywhere
/// else stands where a table or a single value belongs, and serde would
/// read a struct from it by position (`integrator = ["euler", 0.01]`).
const ARRAY_KEYS: &[&str] = &[
    "include",
    "paths",
    "lines",
    "shade",
    "switch_on",
    "switch_off",
    "figures",
    "harmonics",
    "sum",
    "t",
    "value",
    "g",
    "bodies",
    "along",
];

/// Refuses an array at a key not in [`ARRAY_KEYS`], and an array as an
/// element of an array (the arrays of a scene hold tables or values).
fn refuse_misplaced_arrays(table: &toml::de::DeTable<'_>, path: &mut Vec<String>) -> Result<(), SceneError> {
    use toml::de::DeValue;
    fn walk(v: &DeValue<'_>, path: &mut Vec<String>, array_ok: bool) -> Result<(), SceneError> {
        match v {
            DeValue::Table(t) => refuse_misplaced_arrays(t, path),
            DeValue::Array(a) if array_ok => {
                for (i, v) in a.iter().enumerate() {
                    path.push(i.to_string());
                    walk(v.get_ref(), path, false)?;
                    path.pop();
                }
                Ok(())
            }
            DeValue::Array(_) => Err(SceneError {
                path: path.clone(),
                message: "an array is not allowed here: write a table (`{ key = value, ... }`) or a single value"
                    .into(),
            }),
            _ => Ok(()),
        }
    }
    for (k, v) in table.iter() {
        let key = k.get_ref().as_ref();
        path.push(key.to_string());
        // the entries of `[draw]` are arrays of point names under body names
        let in_draw = path.len() == 2 && path[0] == "draw";
        walk(v.get_ref(), path, in_draw || ARRAY_KEYS.contains(&key))?;
        path.pop();
    }
    Ok(())
}
