//! What `equations`, `check`, `analyze` and `linearize` return:
//! `ezy.Equations` (the text, and the LaTeX Jupyter renders), `ezy.Check`
//! (passed or not, and the table), `ezy.Analysis` (the steady motions or
//! the gait, as DataFrames) and `ezy.Linearization` (A, B and the
//! eigenvalues).

use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The file a geometry's table of key `key` was read from.
fn geometry_file(key: &str) -> String {
    format!("{}.csv", key.replace('_', "-"))
}

/// A model's derived equations: `str()` is the text, Jupyter shows the
/// LaTeX (`_repr_latex_`).
#[pyclass(module = "ezy", frozen)]
pub struct Equations {
    /// The plain text `ezy equations` prints.
    #[pyo3(get)]
    pub(crate) text: String,
    /// The whole LaTeX document (`ezy equations --format latex`).
    #[pyo3(get)]
    pub(crate) latex: String,
}

#[pymethods]
impl Equations {
    /// The document's body, for Jupyter (MathJax renders the displayed
    /// equations; the section heading becomes bold text).
    fn _repr_latex_(&self) -> String {
        let body = self
            .latex
            .split_once("\\begin{document}")
            .map_or(self.latex.as_str(), |(_, b)| b)
            .split("\\end{document}")
            .next()
            .unwrap_or_default();
        body.replace("\\section*{", "\\textbf{").trim().to_string()
    }

    fn __str__(&self) -> String {
        self.text.clone()
    }

    fn __repr__(&self) -> String {
        self.text.clone()
    }
}

/// The outcome of `check`: whether every derived term matched its
/// reference, and the table.
#[pyclass(module = "ezy", frozen)]
pub struct Check {
    /// Whether every derived term matched its reference within its tolerance.
    #[pyo3(get)]
    pub(crate) passed: bool,
    /// The table `ezy check` prints.
    #[pyo3(get)]
    pub(crate) table: String,
    /// Why the check failed (empty when it passed).
    #[pyo3(get)]
    pub(crate) message: String,
}

#[pymethods]
impl Check {
    fn __bool__(&self) -> bool {
        self.passed
    }

    fn __repr__(&self) -> String {
        if self.passed { self.table.clone() } else { format!("{}\n{}", self.table, self.message) }
    }
}

/// What `ezy.analyze` found: the report `ezy analyze` prints and its
/// tables as pandas DataFrames (`periodic`: the gait, one row per orbit,
/// with its period [s], mean speed [m/s], displacement per period [m],
/// heading change [rad], Floquet multipliers and stability; `equilibria`:
/// the steady motions; `branch`: a continuation's points; `growth`: a
/// driven motion that gains energy without bound, its energy's and
/// speed's power laws per window, as growth.csv). A table the analysis
/// did not write is `None`.
#[pyclass(module = "ezy", frozen)]
pub struct Analysis {
    /// The text `ezy analyze` prints.
    #[pyo3(get)]
    pub(crate) report: String,
    /// Every table written: `{"periodic": DataFrame, ...}`.
    #[pyo3(get)]
    pub(crate) tables: Py<pyo3::types::PyDict>,
}

impl Analysis {
    fn table<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.tables.bind(py).get_item(name)
    }
}

#[pymethods]
impl Analysis {
    /// The periodic orbit (gait) table, or None.
    #[getter]
    fn periodic<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.table(py, "periodic")
    }

    /// The steady motions (equilibria of the reduced dynamics), or None.
    #[getter]
    fn equilibria<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.table(py, "equilibria")
    }

    /// The continuation's branch, or None.
    #[getter]
    fn branch<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.table(py, "branch")
    }

    /// With `switch=`: every branch's DataFrame, the one followed first
    /// (`.branch`), then each born at one of its bifurcations (`branch-1`,
    /// ...: their numbers in `.diagram`); without, `[.branch]` or `[]`.
    #[getter]
    fn branches<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyAny>>> {
        let first = self.table(py, "branch")?;
        let born = (1..).map_while(|k| self.table(py, &format!("branch-{k}")).transpose());
        first.into_iter().map(Ok).chain(born).collect()
    }

    /// With `switch=`: the bifurcation diagram's branches, one row each:
    /// `branch` (0 the one followed), `file`, `parent`, `born_at` (the
    /// bifurcation's parameter value), `bifurcation` (transcritical,
    /// pitchfork, period doubling, Hopf), `criticality`,
    /// `symmetry_breaking`, `side`, `points`, `from`, `to`, `ended`; or None.
    #[getter]
    fn diagram<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.table(py, "branches")
    }

    /// A motion's growth without bound (no gait), or None: one row per
    /// window, the kinetic energy's and the speed's exponents each by its
    /// own fit, with standard errors and log residuals.
    #[getter]
    fn growth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.table(py, "growth")
    }

    /// Each table's columns' units: `{"periodic": {"drift_speed": "m/s",
    /// ...}, ...}` (from the guide's Quantities page; "" for a pure number).
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        Ok(crate::quantities::of_tables(py, self.tables.bind(py), |k| format!("{k}.csv"))?.0)
    }

    /// Each table's columns with their unit, meaning, and the frame and
    /// time they are taken at, one line per column (consecutive columns of
    /// one kind, such as the state's, on one line).
    fn describe(&self, py: Python<'_>) -> PyResult<String> {
        Ok(crate::quantities::of_tables(py, self.tables.bind(py), |k| format!("{k}.csv"))?.1)
    }

    fn __str__(&self) -> String {
        self.report.clone()
    }

    fn __repr__(&self) -> String {
        self.report.clone()
    }
}

/// What `ezy.geometry` gives: the report `ezy geometry` prints and its
/// tables as DataFrames: `connection` (the local connection `A` and, for a
/// mixed system, `Gamma` at each shape), `curvature` (the height functions
/// `D(-A)`), `momentum` (the momentum equation's coefficients), `gait`
/// (first order, second order, reconstructed and simulated net motion per
/// cycle) and `gait_path`; a table not written is `None`.
#[pyclass(module = "ezy", frozen)]
pub struct Geometry {
    /// The text `ezy geometry` prints.
    #[pyo3(get)]
    pub(crate) report: String,
    /// Every table written: `{"connection": DataFrame, ...}`.
    #[pyo3(get)]
    pub(crate) tables: Py<pyo3::types::PyDict>,
}

#[pymethods]
impl Geometry {
    /// The local connection at each shape, or None: the shape [rad],
    /// `A_<u,v,w>_<hinge>` (the body velocity in its own frame per shape
    /// velocity, `xi = -A r'`: [m/rad] for u, v, [1] for w),
    /// `Gamma_<u,v,w>_<p>` of a mixed system ([1/kg] for u, v), and
    /// `rank_margin` (how far from the singular set).
    #[getter]
    fn connection<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.tables.bind(py).get_item("connection")
    }

    /// The height functions `DA_<x,y,theta>_<i>_<j>` at each shape (two
    /// or more shape coordinates), or None: the net motion per unit area
    /// of a small loop in the plane of shapes i and j.
    #[getter]
    fn curvature<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.tables.bind(py).get_item("curvature")
    }

    /// The momentum equation's coefficients at each shape (a mixed
    /// system), or None: `<p>:<z_a>*<z_b>` the coefficient of `z_a z_b`
    /// in `p'`, `z = [r', p]`.
    #[getter]
    fn momentum<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.tables.bind(py).get_item("momentum")
    }

    /// The gait's net motion per cycle by each `method` (first-order,
    /// second-order, reconstructed, simulated), or None: `dx`, `dy` [m]
    /// and `dtheta` [rad] in the initial body frame, and a mixed
    /// system's momentum after the cycle `<p>_end`.
    #[getter]
    fn gait<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.tables.bind(py).get_item("gait")
    }

    /// Each table's columns' units: `{"gait": {"dx": "m", ...}, ...}` (from
    /// the guide's Quantities page; "" for a pure number).
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        Ok(crate::quantities::of_tables(py, self.tables.bind(py), geometry_file)?.0)
    }

    /// Each table's columns with their unit, meaning, and the frame and
    /// time they are taken at, one line per column (consecutive columns of
    /// one kind on one line).
    fn describe(&self, py: Python<'_>) -> PyResult<String> {
        Ok(crate::quantities::of_tables(py, self.tables.bind(py), geometry_file)?.1)
    }

    /// The gait's path along one period, or None: `t` [s], the shape
    /// coordinates [rad], and the reference body's frame reconstructed
    /// from the connection (`x_reconstructed`, `y_reconstructed` [m],
    /// `theta_reconstructed` [rad]) and, where simulated, the same of the
    /// simulation (`x_simulated`, ...). Also `tables["gait_path"]`.
    #[getter]
    fn gait_path<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.tables.bind(py).get_item("gait_path")
    }

    fn __str__(&self) -> String {
        self.report.clone()
    }

    fn __repr__(&self) -> String {
        self.report.clone()
    }
}

/// What `ezy.linearize` gives: `A` (and `B` with an input) as DataFrames
/// labelled by the state's names, the eigenvalues [1/s] as a complex
/// NumPy array, the state linearized about (`{name: value}`), and the
/// report `ezy linearize` prints.
#[pyclass(module = "ezy", frozen)]
pub struct Linearization {
    /// The text `ezy linearize` prints.
    #[pyo3(get)]
    pub(crate) report: String,
    /// The state matrix (2 nq x 2 nq), rows and columns named.
    #[pyo3(get, name = "A")]
    pub(crate) a: Py<PyAny>,
    /// The input matrix (2 nq x 1), or None without `input`.
    #[pyo3(get, name = "B")]
    pub(crate) b: Option<Py<PyAny>>,
    /// The eigenvalues on the constraint manifold [1/s], complex.
    #[pyo3(get)]
    pub(crate) eigenvalues: Py<PyAny>,
    /// The state linearized about: `{name: value}`.
    #[pyo3(get)]
    pub(crate) state: Py<pyo3::types::PyDict>,
}

#[pymethods]
impl Linearization {
    fn __str__(&self) -> String {
        self.report.clone()
    }

    fn __repr__(&self) -> String {
        self.report.clone()
    }
}
