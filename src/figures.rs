//! Scene figures: [`FigureSpec`]s resolved against the trajectory table and
//! drawn with [`crate::plot`].

use std::path::Path;

use ezy_core::{Column, FigureSpec, ModelInfo};

use crate::output::Table;
use crate::plot::{Chart, PlotError, Series, render_png};

/// Errors drawing a scene figure.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// The figure names a column the table does not have.
    #[error("figure {figure}: no column `{column}` in the trajectory")]
    Column {
        /// Figure file name.
        figure: String,
        /// Missing column.
        column: String,
    },
    /// Drawing failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Floor of logarithmic axes: exact zeros (a residual projected to machine
/// zero) are drawn here.
pub const LOG_FLOOR: f64 = 1e-18;

/// Values of a column expression, one per row.
///
/// # Errors
/// [`FigureError::Column`] if a named column does not exist.
pub fn values(table: &Table, col: &Column, figure: &str) -> Result<Vec<f64>, FigureError> {
    let get = |name: &str| named(table, name, figure);
    Ok(match col {
        Column::Named(a) => get(a)?,
        Column::Norm(a, b) => get(a)?.into_iter().zip(get(b)?).map(|(x, y)| x.hypot(y)).collect(),
        Column::Diff(a, b) => get(a)?.into_iter().zip(get(b)?).map(|(x, y)| x - y).collect(),
        Column::BalanceGap(a, b) => {
            let v = get(a)?;
            let v0 = v.first().copied().unwrap_or(0.0);
            v.into_iter().zip(get(b)?).map(|(x, w)| (x - v0 - w).abs()).collect()
        }
        Column::FromStart(a) => {
            let v = get(a)?;
            let v0 = v.first().copied().unwrap_or(0.0);
            v.into_iter().map(|x| x - v0).collect()
        }
    })
}

/// Values of the column called `name`.
fn named(table: &Table, name: &str, figure: &str) -> Result<Vec<f64>, FigureError> {
    let k = table.index(name).ok_or_else(|| FigureError::Column { figure: figure.into(), column: name.into() })?;
    Ok(table.column(k).collect())
}

/// Draws `fig` from `table` into `path` (PNG).
///
/// # Errors
/// [`FigureError`] for a missing column or a drawing failure.
pub fn render(info: &ModelInfo, fig: &FigureSpec, table: &Table, path: &Path) -> Result<(), FigureError> {
    let mut chart = Chart {
        title: fig.title.clone(),
        x_label: fig.x_label.clone(),
        y_label: fig.y_label.clone(),
        series: Vec::new(),
        equal_axes: false,
        log_y: false,
        log_floor: LOG_FLOOR,
    };
    if fig.paths.is_empty() {
        chart.log_y = fig.log_y;
        let xs = values(table, &fig.x, &fig.file)?;
        for line in &fig.lines {
            let vs = values(table, &line.y, &fig.file)?;
            chart.series.push(Series { label: line.label.clone(), points: xs.iter().copied().zip(vs).collect() });
        }
    } else {
        chart.equal_axes = true;
        for name in &fig.paths {
            let (x, y, label) = match info.bodies.iter().find(|b| b.name == *name) {
                Some(b) => {
                    let c = &info.coords;
                    (c[b.coords[0]].to_string(), c[b.coords[1]].to_string(), format!("centre of mass of {name}"))
                }
                None => (format!("{name}.x"), format!("{name}.y"), format!("point {name}")),
            };
            let xs = named(table, &x, &fig.file)?;
            let ys = named(table, &y, &fig.file)?;
            chart.series.push(Series { label, points: xs.into_iter().zip(ys).collect() });
        }
    }
    Ok(render_png(&chart, path)?)
}
