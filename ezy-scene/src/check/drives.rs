//! `[drives.NAME]`: the prescribed angle of each of the model's drives,
//! every drive given, each angle smooth over the run.

use std::collections::{HashMap, HashSet};

use ezy_core::drive::Drive;
use ezy_core::model::info::ModelInfo;

use crate::error::{SceneError, known_or_none};
use crate::schema::{DriveSpec, Scene};

impl Scene {
    /// Checks that every prescribed angle is smooth over `[0, t_end]`: no
    /// `table` (its slope jumps at the knots), and a `spline` whose knots
    /// cover the run (outside them the angle is held, and its rate would
    /// jump to zero).
    ///
    /// # Errors
    /// [`SceneError`] at the drive's `angle`.
    pub fn check_drives_cover(&self, t_end: f64) -> Result<(), SceneError> {
        for (name, d) in &self.drives {
            ezy_core::drive::check_angle(&d.angle, t_end)
                .map_err(|m| SceneError::at(&["drives", name.as_str(), "angle"], m))?;
        }
        Ok(())
    }

    /// The model's drives with the scene's prescribed angles, in the
    /// model's order (a checked scene gives every one).
    pub fn resolve_drives(&self, info: &ModelInfo) -> Vec<Drive> {
        let by_name: HashMap<&str, &DriveSpec> = self.drives.iter().map(|(n, d)| (n.as_str(), d)).collect();
        info.drives
            .iter()
            .filter_map(|d| {
                let spec = by_name.get(d.name.as_str())?;
                Some(Drive { name: d.name.to_string(), row: d.row, angle: spec.angle.clone() })
            })
            .collect()
    }
}

/// Checks the drives of `scene`: each a drive of the model with a valid
/// angle that covers the run, and every drive of the model given. Returns
/// them in the model's order.
///
/// # Errors
/// The first [`SceneError`].
pub(super) fn check(scene: &Scene, info: &ModelInfo) -> Result<Vec<Drive>, SceneError> {
    let model_drives: HashSet<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
    let scene_drives: HashSet<&str> = scene.drives.iter().map(|(n, _)| n.as_str()).collect();
    for (name, d) in &scene.drives {
        if !model_drives.contains(name.as_str()) {
            let known: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
            return Err(SceneError::at(
                &["drives", name],
                format!("unknown drive `{name}` in model {}; its drives: {}", info.name, known_or_none(&known)),
            ));
        }
        d.angle.validate().map_err(|m| SceneError::at(&["drives", name, "angle"], m))?;
    }
    scene.check_drives_cover(scene.t_end)?;
    if let Some(missing) = info.drives.iter().find(|m| !scene_drives.contains(m.name.as_str())) {
        return Err(SceneError::at(
            &["drives"],
            format!(
                "model {} drives hinge `{}` by `{}`: give its angle, [drives.{}] angle = ...",
                info.name, info.hinges[missing.hinge].name, missing.name, missing.name
            ),
        ));
    }
    Ok(scene.resolve_drives(info))
}
