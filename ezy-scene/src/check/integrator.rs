//! The run's numbers: `t_end`, `[integrator]` (step, tolerances) and the
//! numbers of `[output]` (interval, resolution).

use ezy_core::settings::{MAX_RTOL, MIN_TOLERANCE};

use crate::error::SceneError;
use crate::schema::Scene;
use crate::view::{MAX_DPI, MIN_DPI};

/// Checks the duration, the step and tolerances (positive, tolerances
/// between [`MIN_TOLERANCE`] and, for the relative one, [`MAX_RTOL`]), the
/// output interval and the PNG resolution.
///
/// # Errors
/// The first [`SceneError`].
pub(super) fn check(scene: &Scene) -> Result<(), SceneError> {
    let positive = |path: &[&str], v: f64, what: &str| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(SceneError::at(path, format!("{what} must be a positive number, got {}", ezy_core::fmt_value(v))))
        }
    };
    let integrator = &scene.integrator;
    positive(&["t_end"], scene.t_end, "the duration [s]")?;
    positive(&["integrator", "dt"], integrator.dt, "the step [s]")?;
    positive(&["integrator", "rtol"], integrator.rtol, "the relative tolerance")?;
    positive(&["integrator", "atol"], integrator.atol, "the absolute tolerance")?;
    for (key, v) in [("rtol", integrator.rtol), ("atol", integrator.atol)] {
        if v < MIN_TOLERANCE {
            return Err(SceneError::at(
                &["integrator", key],
                format!("a tolerance below {MIN_TOLERANCE:e} cannot be met in double precision, got {v:e}"),
            ));
        }
    }
    if integrator.rtol > MAX_RTOL {
        return Err(SceneError::at(
            &["integrator", "rtol"],
            format!(
                "a relative tolerance above {MAX_RTOL} asks for less than one correct digit, got {:e}",
                integrator.rtol
            ),
        ));
    }
    positive(&["output", "every"], scene.output.every, "the output interval [s]")?;
    if !(MIN_DPI..=MAX_DPI).contains(&scene.output.dpi) {
        return Err(SceneError::at(
            &["output", "dpi"],
            format!("the PNG resolution is between {MIN_DPI} and {MAX_DPI} dpi, got {}", scene.output.dpi),
        ));
    }
    Ok(())
}
