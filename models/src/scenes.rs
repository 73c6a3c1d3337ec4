//! The built-in scenes: the TOML files in `models/scenes/`, embedded in the
//! binary so that `ezy run NAME` works from any directory; and loading of
//! scene files given by path.

use std::path::Path;

use ezy_core::{ModelInfo, Scene, SceneError, SceneFileError};

/// `(file name, text)` of every built-in scene, in the order `ezy list`
/// shows them.
pub const BUILTIN: &[(&str, &str)] = &[
    ("drive.toml", include_str!("../scenes/drive.toml")),
    ("free.toml", include_str!("../scenes/free.toml")),
    ("sleigh.toml", include_str!("../scenes/sleigh.toml")),
    ("drive-rolling-resistance.toml", include_str!("../scenes/drive-rolling-resistance.toml")),
    ("drive-slope.toml", include_str!("../scenes/drive-slope.toml")),
    ("drive-damped-hinge.toml", include_str!("../scenes/drive-damped-hinge.toml")),
    ("sleigh-drag.toml", include_str!("../scenes/sleigh-drag.toml")),
    ("trailer.toml", include_str!("../scenes/trailer.toml")),
    ("snake.toml", include_str!("../scenes/snake.toml")),
    ("snake-long.toml", include_str!("../scenes/snake-long.toml")),
    ("drive-prescribed.toml", include_str!("../scenes/drive-prescribed.toml")),
    ("snakeboard.toml", include_str!("../scenes/snakeboard.toml")),
];

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

/// The description of the model registered as `key`, at its default counts.
pub fn model_info(key: &str) -> Option<ModelInfo> {
    model_info_with(key, &[]).map(|r| r.expect("default counts are valid"))
}

/// The description of the model registered as `key` with the family
/// counts among `params` applied (other parameters do not change it).
/// `None` for an unknown model.
///
/// # Errors
/// The inner `Err` is a [`SceneError`] at `params.COUNT` when a count is
/// not a whole number >= 1 or makes a family refer to an element that does
/// not exist.
pub fn model_info_with(key: &str, params: &[(String, f64)]) -> Option<Result<ModelInfo, SceneError>> {
    struct WithCounts<'a>(&'a [(String, f64)]);
    impl ezy_core::ModelVisitor for WithCounts<'_> {
        type Output = Result<ModelInfo, SceneError>;
        fn visit<M: ezy_core::Model + Default>(self) -> Self::Output {
            let mut model = M::default();
            let base = model.info();
            let mut last = None;
            for (name, value) in self.0 {
                if let Some(i) = base.param_index(name)
                    && base.params[i].count
                {
                    ezy_core::scene::check_count(name, *value)?;
                    model.set_param(i, *value);
                    last = Some(name.clone());
                }
            }
            model
                .check_counts()
                .map_err(|message| SceneError { path: vec!["params".into(), last.unwrap_or_default()], message })?;
            Ok(model.info())
        }
    }
    crate::visit(key, WithCounts(params))
}

/// Checks a parsed scene against its model.
///
/// # Errors
/// [`SceneFileError`] at the `model` key for an unknown model (listing the
/// known ones), else as [`Scene::check`], located in `text`.
pub fn check(scene: Scene, text: &str, file: &str) -> Result<SceneSource, SceneFileError> {
    let Some(info) = model_info_with(&scene.model, &scene.params) else {
        let known: Vec<&str> = crate::MODEL_KEYS.to_vec();
        let e = ezy_core::SceneError {
            path: vec!["model".into()],
            message: format!("unknown model `{}`; known models: {}", scene.model, known.join(", ")),
        };
        return Err(Scene::locate_error(text, file, e));
    };
    let info = info.map_err(|e| Scene::locate_error(text, file, e))?;
    let expanded = scene.expand_families(&info).map_err(|e| Scene::locate_error(text, file, e))?;
    expanded.check(&info).map_err(|e| Scene::locate_error(text, file, e))?;
    Ok(SceneSource { scene, text: text.to_string(), file: file.to_string() })
}

/// Every built-in scene, parsed and checked.
///
/// # Panics
/// If a built-in scene file is broken (the test suite loads them all).
pub fn builtin() -> Vec<SceneSource> {
    BUILTIN
        .iter()
        .map(|(f, text)| {
            let file = format!("models/scenes/{f}");
            let scene = Scene::from_toml(text, &file).unwrap_or_else(|e| panic!("built-in scene: {e}"));
            check(scene, text, &file).unwrap_or_else(|e| panic!("built-in scene: {e}"))
        })
        .collect()
}

/// Why a scene could not be found or loaded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LoadError {
    /// Neither a built-in name nor a `.toml` file.
    #[error("unknown scene `{name}`; known scenes: {known} (or give a path to a .toml scene file)")]
    Unknown {
        /// What was asked for.
        name: String,
        /// The built-in names.
        known: String,
    },
    /// The file is bad.
    #[error(transparent)]
    File(#[from] SceneFileError),
}

/// A built-in scene by name, or a scene file by path (anything ending in
/// `.toml` or naming an existing file).
///
/// # Errors
/// [`LoadError`]: unknown name, unreadable file, or a bad scene file with
/// its line, column and key.
pub fn load(name_or_path: &str) -> Result<SceneSource, LoadError> {
    let path = Path::new(name_or_path);
    if name_or_path.ends_with(".toml") || path.is_file() {
        let (scene, text) = Scene::read(path)?;
        return Ok(check(scene, &text, name_or_path)?);
    }
    let all = builtin();
    let known = all.iter().map(|s| s.scene.name.clone()).collect::<Vec<_>>().join(", ");
    all.into_iter()
        .find(|s| s.scene.name == name_or_path)
        .ok_or_else(|| LoadError::Unknown { name: name_or_path.to_string(), known })
}

/// The built-in scene called `name`, parsed and checked.
///
/// # Panics
/// If there is no such built-in scene (for tests and benchmarks, which
/// name scenes that exist).
pub fn get(name: &str) -> Scene {
    builtin().into_iter().find(|s| s.scene.name == name).unwrap_or_else(|| panic!("no built-in scene `{name}`")).scene
}

/// The `drive` scene (seed questions f-j).
pub fn drive() -> Scene {
    get("drive")
}

/// The `free` scene (seed question e).
pub fn free() -> Scene {
    get("free")
}

/// The `sleigh` scene (SPEC §5).
pub fn sleigh() -> Scene {
    get("sleigh")
}
