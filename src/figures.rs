//! Scene figures: [`FigureSpec`]s resolved against the trajectory table and
//! drawn with [`crate::plot`]. Every value is checked before anything is
//! drawn: a value that is not finite or beyond
//! [`crate::plot::MAX_MAGNITUDE`] is an error naming the figure file, the
//! column, the value and its time.

use ezy_core::{Column, FigureSpec, ModelInfo};

use crate::output::Table;
use crate::plot::{Chart, PlotError, Series};

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
    /// A value the figure would have to draw cannot be drawn: it is not
    /// finite, or its magnitude is beyond [`crate::plot::MAX_MAGNITUDE`].
    #[error("figure {figure}: column `{column}` is {value:e} at t = {t} s, which {reason}; the figure is not drawn")]
    Value {
        /// Figure file name.
        figure: String,
        /// The column (or column expression, `norm(x1d, y1d)`).
        column: String,
        /// The value.
        value: f64,
        /// The row's time in seconds.
        t: f64,
        /// Why it cannot be drawn.
        reason: &'static str,
    },
    /// Drawing failed.
    #[error("figure {figure}: {source}")]
    Plot {
        /// Figure file name.
        figure: String,
        /// The cause.
        #[source]
        source: PlotError,
    },
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

/// Checks that every value of `column` can be drawn (see
/// [`FigureError::Value`]); `times` are the rows' times [s], `log` whether
/// the column is drawn on a logarithmic axis (where any finite value can).
fn check_values(figure: &str, column: String, values: &[f64], times: &[f64], log: bool) -> Result<(), FigureError> {
    for (k, &v) in values.iter().enumerate() {
        let reason = if !v.is_finite() {
            "is not a finite number"
        } else if !log && v.abs() > crate::plot::MAX_MAGNITUDE {
            "is too large to plot (magnitude above 1e100)"
        } else {
            continue;
        };
        let t = times.get(k).copied().unwrap_or(f64::NAN);
        return Err(FigureError::Value { figure: figure.into(), column, value: v, t, reason });
    }
    Ok(())
}

/// Draws `fig` from `table` as PNG and returns the file's bytes. Every
/// value is checked before drawing.
///
/// # Errors
/// [`FigureError::Column`] for a missing column, [`FigureError::Value`] for
/// a value that is not finite or too large to draw, and
/// [`FigureError::Plot`] for a drawing failure (see [`crate::plot::png`]).
pub fn render(info: &ModelInfo, fig: &FigureSpec, table: &Table) -> Result<Vec<u8>, FigureError> {
    let mut chart = Chart {
        title: fig.title.clone(),
        x_label: fig.x_label.clone(),
        y_label: fig.y_label.clone(),
        series: Vec::new(),
        equal_axes: false,
        log_y: false,
        log_floor: LOG_FLOOR,
    };
    let times: Vec<f64> = if table.columns.is_empty() { Vec::new() } else { table.column(0).collect() };
    let check = |column: String, values: &[f64], log| check_values(&fig.file, column, values, &times, log);
    if fig.paths.is_empty() {
        chart.log_y = fig.log_y;
        let xs = values(table, &fig.x, &fig.file)?;
        check(fig.x.to_string(), &xs, false)?;
        for line in &fig.lines {
            let vs = values(table, &line.y, &fig.file)?;
            check(line.y.to_string(), &vs, fig.log_y)?;
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
            check(x, &xs, false)?;
            check(y, &ys, false)?;
            chart.series.push(Series { label, points: xs.into_iter().zip(ys).collect() });
        }
    }
    crate::plot::png(&chart).map_err(|source| FigureError::Plot { figure: fig.file.clone(), source })
}
