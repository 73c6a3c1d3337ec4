//! The built-in scenes: the TOML files in `models/scenes/`, embedded in the
//! binary so that `ezy run NAME` works from any directory, and their
//! checking against the built-in models (the `ezy` crate's `App` loads
//! scene files given by path, and a user's scenes, against its own table).

use ezy_core::ModelInfo;
pub use ezy_scene::registry::SceneSource;
use ezy_scene::registry::{ModelCatalog, check_scene};

use ezy_scene::{Scene, SceneError, SceneFileError};

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
    ("sleigh-ice.toml", include_str!("../scenes/sleigh-ice.toml")),
    ("drive-slip.toml", include_str!("../scenes/drive-slip.toml")),
    ("trailer.toml", include_str!("../scenes/trailer.toml")),
    ("snake.toml", include_str!("../scenes/snake.toml")),
    ("snake-long.toml", include_str!("../scenes/snake-long.toml")),
    ("snake-stiff.toml", include_str!("../scenes/snake-stiff.toml")),
    ("snake-slip.toml", include_str!("../scenes/snake-slip.toml")),
    ("drive-prescribed.toml", include_str!("../scenes/drive-prescribed.toml")),
    ("snakeboard.toml", include_str!("../scenes/snakeboard.toml")),
    ("kinematic-snake.toml", include_str!("../scenes/kinematic-snake.toml")),
    ("four-bar.toml", include_str!("../scenes/four-bar.toml")),
    ("four-bar-stiff.toml", include_str!("../scenes/four-bar-stiff.toml")),
    ("slider-crank.toml", include_str!("../scenes/slider-crank.toml")),
    ("double-pendulum.toml", include_str!("../scenes/double-pendulum.toml")),
    ("pendulum.toml", include_str!("../scenes/pendulum.toml")),
    ("four-bar-n2.toml", include_str!("../scenes/four-bar-n2.toml")),
    ("four-bar-n40.toml", include_str!("../scenes/four-bar-n40.toml")),
];

/// The description of the built-in model registered as `key`, at its
/// default counts; `None` for an unknown key.
pub fn model_info(key: &str) -> Option<ModelInfo> {
    model_info_with(key, &[]).map(|r| r.expect("default counts are valid"))
}

/// The description of the built-in model registered as `key` with the
/// family counts among `params` applied (other parameters do not change
/// it). `None` for an unknown model.
///
/// # Errors
/// The inner `Err` is a [`SceneError`] at `params.COUNT` when a count is
/// not a whole number >= 1 or makes a family refer to an element that does
/// not exist.
pub fn model_info_with(key: &str, params: &[(String, f64)]) -> Option<Result<ModelInfo, SceneError>> {
    crate::builtins().info_with(key, params)
}

/// Checks a parsed scene against the built-in models.
///
/// # Errors
/// As [`check_scene`].
pub fn check(scene: Scene, text: &str, file: &str) -> Result<SceneSource, SceneFileError> {
    check_scene(&crate::builtins(), scene, text, file)
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

/// The built-in scene called `name`, parsed and checked.
///
/// # Panics
/// If there is no such built-in scene (for tests and benchmarks, which
/// name scenes that exist).
pub fn get(name: &str) -> Scene {
    builtin().into_iter().find(|s| s.scene.name == name).unwrap_or_else(|| panic!("no built-in scene `{name}`")).scene
}

/// The `drive` scene: the hinge motor drives the EzyRoller from rest
/// (docs/physics.md §10.3).
pub fn drive() -> Scene {
    get("drive")
}

/// The `free` scene: the EzyRoller coasts with no forces (docs/physics.md §10.3).
pub fn free() -> Scene {
    get("free")
}

/// The `sleigh` scene: the Chaplygin sleigh, which has a closed form
/// (docs/physics.md §9).
pub fn sleigh() -> Scene {
    get("sleigh")
}
