//! `ezy.Result`, a finished run in memory: every output row as one NumPy
//! array with the columns as views into it, the run's summary and
//! numbers, its figures drawn with matplotlib on request.

use ezy::session;
use ezy_core::ModelInfo;
use ezy_scene::registry::SceneSource;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PySlice};

use crate::ezy_err;

/// A finished run: every output row, in memory.
///
/// `result["x1"]` is a column (a NumPy view into `result.data`, rows x
/// columns), `result.t` the times [s], `result.columns` the names (those of
/// the command line's trajectory.csv), `result.to_pandas()` a DataFrame,
/// `result.plot("fig3_paths")` one of the scene's figures in matplotlib,
/// `result.summary` the text `ezy run` prints. `len(result)` counts the
/// rows, iterating gives them, `np.asarray(result)` is the table, and
/// `result.units` / `result.describe()` say what each column is.
#[pyclass(module = "ezy", name = "Result", frozen)]
pub struct RunResult {
    data: Py<PyArray2<f64>>,
    columns: Vec<String>,
    /// The scene's name.
    #[pyo3(get)]
    scene: String,
    /// The summary `ezy run` prints (method, steps, evaluations, times,
    /// residuals, energy balance, final state).
    #[pyo3(get)]
    summary: String,
    stats: Py<PyDict>,
    /// Warnings of the run (corrected initial values, an ill-conditioned
    /// KKT system).
    #[pyo3(get)]
    warnings: Vec<String>,
    /// Notes of the run (the assembly branch taken, hand-overs).
    #[pyo3(get)]
    notes: Vec<String>,
    figures: Vec<ezy_scene::FigureSpec>,
    info: ModelInfo,
    helpers: Py<PyModule>,
}

impl RunResult {
    /// The result of `report`, a run of `src`'s scene on the model `info`
    /// describes: its table moved into NumPy.
    pub(crate) fn new(
        py: Python<'_>,
        src: &SceneSource,
        info: ModelInfo,
        report: ezy::Report,
        helpers: Py<PyModule>,
    ) -> PyResult<Self> {
        let summary = session::summary(&src.scene.name, &report);
        let s = &report.summary;
        let stats = PyDict::new(py);
        stats.set_item("method", s.method.name())?;
        stats.set_item("steps", s.steps)?;
        stats.set_item("rejected", s.rejected)?;
        stats.set_item("rhs_evals", s.counters.rhs_evals)?;
        stats.set_item("integration_s", s.integration_time.as_secs_f64())?;
        stats.set_item("setup_s", report.setup.as_secs_f64())?;
        stats.set_item("wall_s", report.wall.as_secs_f64())?;
        stats.set_item("max_energy_gap", s.max_energy_error)?;
        stats.set_item("handovers", s.handovers)?;
        let rows = report.table.rows();
        let columns = report.table.columns;
        let n = columns.len();
        // moved into NumPy, not copied: row-major, one row per output time
        let data = PyArray1::from_vec(py, report.table.data).reshape([rows, n])?;
        Ok(Self {
            data: data.unbind(),
            columns,
            scene: src.scene.name.clone(),
            summary,
            stats: stats.unbind(),
            warnings: report.warnings,
            notes: report.notes,
            figures: src.scene.figures.clone(),
            info,
            helpers,
        })
    }

    /// The column `name`'s index, or a KeyError listing the columns.
    fn index(&self, name: &str) -> PyResult<usize> {
        self.columns.iter().position(|c| c == name).ok_or_else(|| {
            PyKeyError::new_err(format!(
                "no column `{name}` in this run of {}; its columns: {}",
                self.scene,
                self.columns.join(", ")
            ))
        })
    }

    /// A figure's file name without its extension (the name `plot` takes).
    fn stem(file: &str) -> &str {
        file.rsplit_once('.').map_or(file, |(stem, _)| stem)
    }
}

#[pymethods]
impl RunResult {
    /// Every output row: a 2-D float64 array (rows x columns).
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.data.bind(py).clone()
    }

    /// The column names, in order.
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.columns.clone()
    }

    /// The output times [s] (the column `t`).
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.__getitem__(py, "t")
    }

    /// The run's numbers: method, steps, rejected, rhs_evals,
    /// integration_s, setup_s, wall_s [s], max_energy_gap [J], handovers.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> Bound<'py, PyDict> {
        self.stats.bind(py).clone()
    }

    /// The names of the scene's figures (`plot` draws them).
    #[getter]
    fn figures(&self) -> Vec<String> {
        self.figures.iter().map(|f| Self::stem(&f.file).to_string()).collect()
    }

    /// The column `name` as a float64 array (a view into `data`).
    ///
    /// Raises KeyError listing the columns.
    fn __getitem__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let k = self.index(name)?;
        self.data.bind(py).get_item((PySlice::full(py), k))
    }

    fn __contains__(&self, name: &str) -> bool {
        self.columns.iter().any(|c| c == name)
    }

    /// The number of output rows.
    fn __len__(&self, py: Python<'_>) -> usize {
        self.data.bind(py).shape()[0]
    }

    /// The rows, each a float64 array over the columns (as iterating
    /// `result.data`).
    fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.data.bind(py).as_any().try_iter().map(Bound::into_any)
    }

    /// `np.asarray(result)`: the table (rows x columns), `data`.
    #[pyo3(signature = (dtype=None, copy=None))]
    fn __array__<'py>(
        &self,
        py: Python<'py>,
        dtype: Option<&Bound<'py, PyAny>>,
        copy: Option<bool>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let data = self.data.bind(py).as_any().clone();
        let np = py.import("numpy")?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("dtype", dtype)?;
        if copy == Some(true) {
            return np.call_method("array", (data,), Some(&kwargs));
        }
        np.call_method("asarray", (data,), Some(&kwargs))
    }

    /// Each column's unit: `{column: "m/s"}` ("" for a pure number).
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for c in &self.columns {
            d.set_item(c, crate::units::unit_and_meaning(c, &self.info).0)?;
        }
        Ok(d)
    }

    /// Each column with its unit and meaning, one line each (the text is
    /// also what `print(result.describe())` shows).
    fn describe(&self) -> String {
        let rows: Vec<(String, String, String)> = self
            .columns
            .iter()
            .map(|c| {
                let (u, m) = crate::units::unit_and_meaning(c, &self.info);
                (c.clone(), if u.is_empty() { String::new() } else { format!("[{u}]") }, m)
            })
            .collect();
        let w0 = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
        let w1 = rows.iter().map(|r| r.1.len()).max().unwrap_or(0);
        let lines: Vec<String> =
            rows.iter().map(|(c, u, m)| format!("{c:<w0$}  {u:<w1$}  {m}").trim_end().to_string()).collect();
        format!("run of scene {}: {} columns\n{}", self.scene, self.columns.len(), lines.join("\n"))
    }

    /// The column names (as a mapping's keys).
    fn keys(&self) -> Vec<String> {
        self.columns.clone()
    }

    /// The rows as a pandas DataFrame (over `data`, not a copy where
    /// pandas allows).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let units = self.units(py)?;
        self.helpers.bind(py).call_method1("to_pandas", (self.data.bind(py), self.columns.clone(), units))
    }

    /// Draws the scene's figure `name` (e.g. "fig3_paths"; see `figures`)
    /// with matplotlib, as `ezy run` draws it, and returns the Figure;
    /// `ax` draws a one-panel figure into that Axes. Nothing is drawn
    /// unless asked.
    ///
    /// Raises KeyError listing the figures for an unknown name, EzyError
    /// for a value that cannot be drawn.
    #[pyo3(signature = (name, ax=None))]
    fn plot<'py>(&self, py: Python<'py>, name: &str, ax: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyAny>> {
        let fig = self.figures.iter().find(|f| Self::stem(&f.file) == Self::stem(name)).ok_or_else(|| {
            PyKeyError::new_err(format!(
                "scene {} has no figure `{name}`; its figures: {}",
                self.scene,
                self.figures().join(", ")
            ))
        })?;
        let data = self.data.bind(py).readonly();
        let table = ezy::output::csv::Table { columns: self.columns.clone(), data: data.as_slice()?.to_vec() };
        let chart = ezy::render::figures::chart(&self.info, fig, &table).map_err(ezy_err)?;
        let d = PyDict::new(py);
        d.set_item("file", &fig.file)?;
        d.set_item("title", &chart.title)?;
        d.set_item("x_label", &chart.x_label)?;
        d.set_item("y_label", &chart.y_label)?;
        d.set_item("lower", &chart.lower)?;
        d.set_item("equal_axes", chart.equal_axes)?;
        d.set_item("path_ends", chart.path_ends)?;
        d.set_item("log_x", chart.log_x)?;
        d.set_item("log_y", chart.log_y)?;
        d.set_item("log_floor", chart.log_floor)?;
        d.set_item("shade", &chart.shade)?;
        let series = PyList::empty(py);
        for s in &chart.series {
            let e = PyDict::new(py);
            e.set_item("label", &s.label)?;
            let (x, y): (Vec<f64>, Vec<f64>) = s.points.iter().copied().unzip();
            e.set_item("x", PyArray1::from_vec(py, x))?;
            e.set_item("y", PyArray1::from_vec(py, y))?;
            e.set_item("panel", s.panel)?;
            let stroke = match s.stroke {
                ezy::render::plot::Stroke::Auto => "auto".to_string(),
                ezy::render::plot::Stroke::Solid => "solid".to_string(),
                ezy::render::plot::Stroke::Pieces => "pieces".to_string(),
                ezy::render::plot::Stroke::Dash(k) => format!("dash{k}"),
                ezy::render::plot::Stroke::Points => "points".to_string(),
            };
            e.set_item("stroke", stroke)?;
            e.set_item("color", s.color)?;
            series.append(e)?;
        }
        d.set_item("series", series)?;
        self.helpers.bind(py).call_method1("draw", (d, ax))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let shape = self.data.bind(py).shape().to_vec();
        format!(
            "<ezy.Result of scene {}: {} rows x {} columns ({}), {} steps>",
            self.scene,
            shape[0],
            shape[1],
            self.columns.iter().take(6).cloned().collect::<Vec<_>>().join(", ")
                + if self.columns.len() > 6 { ", ..." } else { "" },
            self.stats.bind(py).get_item("steps").ok().flatten().map_or_else(|| "?".into(), |s| s.to_string())
        )
    }
}
