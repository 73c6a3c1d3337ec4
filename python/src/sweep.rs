//! `ezy.sweep`'s grid: its axes as the command line's `--grid` and
//! `--list` arguments, counted before anything is set up for them.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::ezy_err;
use crate::settings::real;

/// Most runs a sweep from Python may have: 1,000,000. Its table comes
/// back as a DataFrame in memory (a row of some hundred bytes per run),
/// and a run takes milliseconds at the least; the command line's `ezy
/// sweep` (resumable, its table on disk) takes up to 2^40.
pub(crate) const MAX_RUNS: u64 = 1_000_000;

/// The number of values of an axis written `START:STOP:COUNT` (`None`
/// when COUNT does not read as a whole number: the command line names
/// that mistake).
fn grid_count(spec: &str) -> Option<u64> {
    let count = spec.rsplit(':').next()?.trim();
    let n: f64 = count.parse().ok()?;
    (n.is_finite() && n >= 0.0 && n.fract() == 0.0).then_some(if n >= u64::MAX as f64 { u64::MAX } else { n as u64 })
}

/// `grid` (`{name: [values]}` or `{name: "START:STOP:COUNT"}`) as the
/// command line's arguments, after checking the number of runs.
///
/// # Errors
/// EzyError for an empty grid, or for more than [`MAX_RUNS`] runs naming
/// each axis and its count; ValueError for a key that is not a string or
/// a value that is neither a list nor a text; TypeError for a listed
/// value that is not a number (`True` included).
pub(crate) fn grid_args(grid: &Bound<'_, PyDict>) -> PyResult<Vec<String>> {
    if grid.is_empty() {
        return Err(ezy_err("grid: give at least one axis, e.g. grid={\"M0\": [1, 2, 3]}"));
    }
    let mut args = Vec::new();
    let mut counts: Vec<(String, u64)> = Vec::new();
    for (k, v) in grid.iter() {
        let name: String = k.extract().map_err(|_| PyValueError::new_err(format!("grid: key {k} is not a string")))?;
        if let Ok(spec) = v.extract::<String>() {
            if let Some(n) = grid_count(&spec) {
                counts.push((name.clone(), n));
            }
            args.extend(["--grid".into(), format!("{name}={spec}")]);
        } else {
            let items: Vec<Bound<'_, PyAny>> = v.extract().map_err(|_| {
                PyValueError::new_err(format!(
                    "grid: `{name}` needs a list of numbers or \"START:STOP:COUNT\", not {v}"
                ))
            })?;
            counts.push((name.clone(), items.len() as u64));
            let what = format!("grid: a value of `{name}`");
            let list = items.iter().map(|x| real(&what, x).map(|x| format!("{x:?}"))).collect::<PyResult<Vec<_>>>()?;
            args.extend(["--list".into(), format!("{name}={}", list.join(","))]);
        }
    }
    let runs = counts.iter().fold(1u64, |a, (_, n)| a.saturating_mul(*n));
    if runs > MAX_RUNS {
        let axes: Vec<String> = counts.iter().map(|(n, c)| format!("`{n}` has {c}")).collect();
        return Err(ezy_err(format!(
            "grid: {} values: the sweep would have {runs} runs, more than the {MAX_RUNS} a sweep from Python may have (its table comes back in memory); sweep fewer values, or run `ezy sweep --out DIR` on the command line, which writes its table to disk",
            axes.join(", ")
        )));
    }
    Ok(args)
}
