//! The output: the columns' names (no two alike, with every group asked
//! for), `[[figures]]` (file names, and every column, point or body a
//! figure reads) and `[draw]` (each body's outline through its own
//! points).

use std::collections::HashSet;

use ezy_core::model::info::ModelInfo;

use crate::columns::names;
use crate::error::{SceneError, known_or_none};
use crate::schema::{OutputGroup, Scene};
use crate::view::{FigureSpec, figure_stem};

/// Longest figure file name \[bytes\]: file systems take 255, and the
/// run's temporary names add a few.
pub const MAX_FIGURE_NAME: usize = 200;

/// Checks the output columns, then each figure and each drawn body
/// apart.
///
/// # Errors
/// Per part in order, a [`SceneError`] at its key.
pub(super) fn check(scene: &Scene, info: &ModelInfo) -> Vec<Result<(), SceneError>> {
    let mut parts = vec![distinct_columns(scene, info)];
    let columns = scene.columns(info);
    let missing = |col: &str| -> Option<String> {
        if columns.iter().any(|c| c == col) {
            return None;
        }
        Some(format!("no column `{col}` in this scene's output{}", column_hint(scene, info, col)))
    };
    for (i, fig) in scene.figures.iter().enumerate() {
        parts.push(check_file(scene, i, fig).and_then(|()| check_figure(info, &i.to_string(), fig, &missing)));
    }
    for (body, outline) in &scene.draw {
        parts.push(check_outline(info, body, outline));
    }
    parts
}

/// Checks that no two output columns are called alike with every group
/// asked for (an effect named after a drive's work column, say).
fn distinct_columns(scene: &Scene, info: &ModelInfo) -> Result<(), SceneError> {
    let all_columns = names(info, &scene.effects, OutputGroup::ALL);
    let mut seen = HashSet::with_capacity(all_columns.len());
    for c in &all_columns {
        if !seen.insert(c.as_str()) {
            let culprit = (scene.effects.iter())
                .find(|(n, e)| c == &format!("W_{n}") || c == &e.value_column(n))
                .map(|(n, _)| n.clone());
            return Err(match culprit {
                Some(n) => SceneError::at(
                    &["effects", &n],
                    format!(
                        "effect `{n}` makes the column `{c}`, which the model's drives or rows also make: rename the effect"
                    ),
                ),
                None => SceneError::at(&["model"], format!("two output columns are called `{c}`")),
            });
        }
    }
    Ok(())
}

/// For a column the output does not have: the group that would add it.
fn column_hint(scene: &Scene, info: &ModelInfo, col: &str) -> String {
    for g in OutputGroup::ALL {
        if names(info, &scene.effects, [g]).iter().any(|c| c == col) && !scene.includes(g) {
            return format!(" (add \"{}\" to output.include)", g.name());
        }
    }
    format!("; its columns would be: {}", ezy_core::name_list(names(info, &scene.effects, OutputGroup::ALL)))
}

/// Checks the file name of figure `i`: a name with a figure extension,
/// no directory, no control character, not hidden, not too long, and not
/// the file of an earlier figure.
fn check_file(scene: &Scene, i: usize, fig: &FigureSpec) -> Result<(), SceneError> {
    let at = ["figures", &i.to_string(), "file"];
    let at: Vec<&str> = at.iter().map(|s| s.as_ref()).collect();
    let stem = figure_stem(&fig.file);
    if stem.len() == fig.file.len()
        || stem.is_empty()
        || fig.file.contains(['/', '\\'])
        || fig.file.contains(char::is_control)
    {
        return Err(SceneError::at(
            &at,
            format!(
                "`{}` must be a file name ending in .png, .svg or .pdf, without directories or control characters",
                fig.file.escape_debug()
            ),
        ));
    }
    // a file name longer than file systems take, hidden, the CSV's, or one
    // another figure already writes (in any format): refused here, before any work
    let earlier = scene.figures[..i].iter().any(|f| figure_stem(&f.file) == stem);
    if fig.file.len() > MAX_FIGURE_NAME || fig.file.starts_with('.') || earlier {
        let why = if earlier {
            "another figure of this scene writes that file".to_string()
        } else if fig.file.starts_with('.') {
            "a figure file name must not start with `.`".to_string()
        } else {
            format!("a figure file name has at most {MAX_FIGURE_NAME} bytes, this one {}", fig.file.len())
        };
        return Err(SceneError::at(&at, format!("`{}`: {why}", fig.file)));
    }
    Ok(())
}

/// Checks what figure `i` draws: paths or lines (not both, not neither),
/// every body, point and column it reads (`missing` says why a column is
/// not in the output), shading on a line figure over `t`, and the panels
/// of its lines.
fn check_figure(
    info: &ModelInfo,
    i: &str,
    fig: &FigureSpec,
    missing: &dyn Fn(&str) -> Option<String>,
) -> Result<(), SceneError> {
    if fig.paths.is_empty() == fig.lines.is_empty() {
        return Err(SceneError::at(
            &["figures", i],
            "a figure has either `paths` (bodies or points) or `lines`, not both and not neither",
        ));
    }
    for (j, p) in fig.paths.iter().enumerate() {
        let path = ["figures", i, "paths", &j.to_string()];
        let path: Vec<&str> = path.iter().map(|s| s.as_ref()).collect();
        if info.bodies.iter().any(|b| b.name == *p) {
            continue;
        }
        if info.point_index(p).is_some() {
            if let Some(m) = missing(&format!("{p}.x")) {
                return Err(SceneError::at(&path, m));
            }
        } else {
            let mut names: Vec<&str> = info.bodies.iter().map(|b| b.name.as_str()).collect();
            names.extend(info.points.iter().map(|p| p.name.as_str()));
            return Err(SceneError::at(
                &path,
                format!("unknown body or point `{p}` in model {}; known: {}", info.name, known_or_none(&names)),
            ));
        }
    }
    for (j, c) in fig.shade.iter().enumerate() {
        let at = ["figures", i, "shade", &j.to_string()];
        if !fig.paths.is_empty() || fig.x.to_string() != "t" {
            return Err(SceneError::at(&at, "`shade` marks stretches of time: a line figure over t"));
        }
        if let Some(m) = missing(c) {
            return Err(SceneError::at(&at, m));
        }
    }
    for c in fig.x.inputs() {
        if let Some(m) = missing(c) {
            return Err(SceneError::at(&["figures", i, "x"], m));
        }
    }
    if !fig.lines.is_empty() && fig.lines.iter().all(|l| l.panel == 2) {
        return Err(SceneError::at(
            &["figures", i, "lines"],
            "every line is in panel 2: the upper panel (1) needs at least one line",
        ));
    }
    for (j, line) in fig.lines.iter().enumerate() {
        let j = j.to_string();
        if !(1..=2).contains(&line.panel) {
            return Err(SceneError::at(
                &["figures", i, "lines", &j, "panel"],
                format!("panel is 1 (upper) or 2 (lower), got {}", line.panel),
            ));
        }
        if line.panel == 2 && fig.y2_label.is_none() {
            return Err(SceneError::at(
                &["figures", i, "lines", &j, "panel"],
                "a line in panel 2 needs the figure's `y2_label` (the lower panel's axis label, with unit)",
            ));
        }
        for c in line.y.inputs() {
            if let Some(m) = missing(c) {
                return Err(SceneError::at(&["figures", i, "lines", &j, "y"], m));
            }
        }
    }
    Ok(())
}

/// Checks the outline of `body` in `[draw]`: a body of the model, through
/// `cm` and points on that body.
fn check_outline(info: &ModelInfo, body: &str, outline: &[String]) -> Result<(), SceneError> {
    let Some(b) = info.bodies.iter().position(|x| x.name == *body) else {
        let known: Vec<&str> = info.bodies.iter().map(|b| b.name.as_str()).collect();
        return Err(SceneError::at(
            &["draw", body],
            format!("unknown body `{body}` in model {}; known: {}", info.name, known_or_none(&known)),
        ));
    };
    for (j, p) in outline.iter().enumerate() {
        let on_body = p == "cm" || info.point_index(p).is_some_and(|k| info.points[k].body == b);
        if !on_body {
            let names: Vec<&str> = std::iter::once("cm")
                .chain(info.points.iter().filter(|q| q.body == b).map(|q| q.name.as_str()))
                .collect();
            return Err(SceneError::at(
                &["draw", body, &j.to_string()],
                format!("`{p}` is not a point of body {body}; its points: {}", known_or_none(&names)),
            ));
        }
    }
    Ok(())
}
