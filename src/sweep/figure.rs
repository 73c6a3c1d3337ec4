//! The sweep's figures, drawn from `sweep.csv` once every run is in: for
//! each metric `k`, `sweep_<k>.png` (the metric against the first
//! parameter, a line per value of the second) and, for two fixed axes,
//! `sweep_<k>_map.png` (a heat map over both); in the format and at the
//! resolution `--format` and `--dpi` give (PNG at 144 dpi by default).

use std::path::{Path, PathBuf};

use super::SweepError;
use super::metric::Metric;
use super::plan::{Plan, Values};
use crate::output::transaction::Interrupted;
use crate::render::plot::heat_map::HeatMap;
use crate::render::plot::series::{Chart, Series};
use ezy_scene::FigureFormat;

/// Most lines in a figure (one per value of the second axis); beyond it
/// only the heat map is drawn.
pub(crate) const MAX_LINES: usize = 10;

/// Most runs the figures are drawn from: the figures hold every run's
/// point in memory (and a heat map a cell per run), so a larger sweep
/// gets its table only.
pub(crate) const MAX_FIGURE_RUNS: u64 = 1_000_000;

/// Draws the figures of the sweep in `dir` and returns the files written
/// and notes on the figures not drawn (a metric whose every run failed,
/// more than two axes), in `format` (PNG at `dpi`). A signal (once
/// `transaction::arm_signals` handles them) stops it before the
/// next figure; each figure is written whole (a rename) or not at all.
///
/// # Errors
/// [`SweepError::Failed`]: `sweep.csv` cannot be read, or a figure cannot
/// be written; [`SweepError::Interrupted`]: a signal arrived.
pub(crate) fn draw(
    dir: &Path,
    plan: &Plan,
    metrics: &[Metric],
    info: &ezy_core::ModelInfo,
    (format, dpi): (FigureFormat, f64),
) -> Result<(Vec<PathBuf>, Vec<String>), SweepError> {
    let labels = axis_labels(plan, info);
    let (mut files, mut notes) = (Vec::new(), Vec::new());
    if metrics.is_empty() {
        notes.push("no figure: give a --metric to draw it against the parameters".into());
        return Ok((files, notes));
    }
    let axes = plan.axes.len();
    if axes > 2 {
        notes.push(format!("no figure: {axes} swept parameters (figures are drawn for one or two)"));
        return Ok((files, notes));
    }
    let random = plan.axes.iter().any(|a| matches!(a.values, Values::Random { .. }));
    if random && axes > 1 {
        notes.push("no figure: random draws over two parameters (figures are drawn for one random parameter)".into());
        return Ok((files, notes));
    }
    let runs = plan.runs();
    if runs > MAX_FIGURE_RUNS {
        notes.push(format!(
            "no figure: {runs} runs, more than the {MAX_FIGURE_RUNS} a figure is drawn from (sweep.csv has every run)"
        ));
        return Ok((files, notes));
    }
    let mut names = plan.names();
    names.extend(metrics.iter().map(|m| m.text.clone()));
    let rows = super::table::read_columns(dir, &names)?;
    for (k, m) in metrics.iter().enumerate() {
        let col = axes + k;
        let file = format.file_name(&format!("sweep_{}", k + 1));
        let title = format!("{} against {}", m.text, plan.names().join(" and "));
        let mut series = Vec::new();
        if axes == 1 || random {
            let mut pts: Vec<(f64, f64)> = rows.iter().map(|r| (r[0], r[col])).collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            series.push(Series::new("", pts));
        } else {
            if plan.fixed_len(1).is_some_and(|n| n <= MAX_LINES as u64) {
                for y in plan.fixed_iter(1).expect("fixed") {
                    let pts: Vec<(f64, f64)> = rows.iter().filter(|r| r[1] == y).map(|r| (r[0], r[col])).collect();
                    series.push(Series::new(format!("{} = {}", labels[1], ezy_core::fmt_value(y)), pts));
                }
            }
        }
        if !series.is_empty() {
            stop_if_signalled(dir, &file)?;
            let chart = Chart { series, ..Chart::new(&title, &labels[0], &m.text) };
            match crate::render::plot::figure(&chart, format, dpi) {
                Ok(png) => files.push(write(dir, &file, &png)?),
                Err(e) => notes.push(format!("{file} not drawn: {e}")),
            }
        }
        if axes == 2 && !random {
            // at most MAX_FIGURE_RUNS cells: the product of the axes' lengths
            let xs = sorted(plan.fixed_iter(0).expect("fixed").collect());
            let ys = sorted(plan.fixed_iter(1).expect("fixed").collect());
            let mut values = vec![f64::NAN; xs.len() * ys.len()];
            let at = |v: &[f64], x: f64| v.binary_search_by(|a| a.total_cmp(&x)).ok();
            for r in &rows {
                if let (Some(i), Some(j)) = (at(&xs, r[0]), at(&ys, r[1])) {
                    values[i * ys.len() + j] = r[col];
                }
            }
            let map = HeatMap {
                title,
                x_label: labels[0].clone(),
                y_label: labels[1].clone(),
                value_label: m.text.clone(),
                xs,
                ys,
                values,
                lines: Vec::new(),
                value_range: None,
            };
            let file = format.file_name(&format!("sweep_{}_map", k + 1));
            stop_if_signalled(dir, &file)?;
            let png = crate::render::plot::heat_map::heatmap_svg(&map)
                .and_then(|svg| crate::render::plot::raster::encode(&svg, format, dpi, &map.title));
            match png {
                Ok(png) => files.push(write(dir, &file, &png)?),
                Err(e) => notes.push(format!("{file} not drawn: {e}")),
            }
        }
    }
    Ok((files, notes))
}

/// [`SweepError::Interrupted`] if a signal asked to stop before `file`
/// is drawn.
fn stop_if_signalled(dir: &Path, file: &str) -> Result<(), SweepError> {
    match crate::output::transaction::pending() {
        None => Ok(()),
        Some(signal) => Err(SweepError::Interrupted(Interrupted {
            signal,
            dir: dir.into(),
            t: None,
            doing: Some(format!("drawing {file}")),
            kept: Some(format!(
                "every row is in {}; the same command draws the figures",
                dir.join(super::table::CSV).display()
            )),
        })),
    }
}

/// The axes' names, with the unit of a model parameter (`a [m]`).
pub(crate) fn axis_labels(plan: &Plan, info: &ezy_core::ModelInfo) -> Vec<String> {
    plan.axes
        .iter()
        .map(|a| match info.param_index(&a.name).map(|i| info.params[i].unit) {
            Some(unit) if !unit.is_empty() => format!("{} [{unit}]", a.name),
            _ => a.name.clone(),
        })
        .collect()
}

/// The distinct values, ascending.
fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<PathBuf, String> {
    let path = dir.join(name);
    crate::output::transaction::write_atomically(&path, bytes).map_err(|e| e.to_string())?;
    Ok(path)
}
