#![warn(missing_docs)]
// The docstrings of the #[pymethods] are Python's help: a unit in them is
// written `[s]`, as Python users read it, not as an intra-doc link.
#![allow(rustdoc::broken_intra_doc_links)]
//! ezy from Python: the extension module `ezy` (built by maturin from this
//! crate: `pip install ./python`) and the means for a user's crate to
//! become a Python module with its own vehicles and force laws
//! ([`python_module!`]).
//!
//! Everything a module offers is [`init_module`] over an [`ezy::App`]:
//! `models()`, `scenes()`, `effect_kinds()`, `scene(name)`, `run(scene,
//! ...)`, `sweep(scene, ...)`, `equations(model)` and `check(model)`, the classes
//! `Result`, `Scene` and `Equations`, and the exception `EzyError`, whose
//! message is the command line's (the file, line, key or flag at fault).
//!
//! A run goes through [`ezy::App::run_scene_in_memory`]: no file is
//! written, every output row lands in one NumPy array (rows x columns,
//! moved, not copied, from the Rust table), and the named columns are views
//! into it. The GIL is released while the run integrates; every 50 ms the
//! stop hook takes it back to ask Python for pending signals, so Ctrl-C
//! (or a notebook's interrupt) ends the run within a step and raises
//! `KeyboardInterrupt`. The guide's chapter "Python" shows the whole API.

extern crate self as ezy_python;

pub use numpy;
pub use pyo3;

use std::ffi::CString;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use ezy::commands::run;
use ezy::{App, RunOptions};
use ezy_core::{Choice, Formulation, Method, ModelInfo, ProjectionKind};
use ezy_scene::registry::ModelCatalog as _;
use ezy_scene::registry::SceneSource;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyException, PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PySlice};

pyo3::create_exception!(
    ezy,
    EzyError,
    PyException,
    "A scene, model, setting or run that ezy refused; the message names the culprit (file, line, key, flag or value)."
);

/// The docstring of every module [`init_module`] fills.
const MODULE_DOC: &str = "Planar vehicles and mechanisms with hinges and skates (ezy).

run(scene, **settings)      a scene in memory: a Result with NumPy arrays
sweep(scene, grid, ...)     runs over parameter values: a pandas DataFrame
scene(name)                 a Scene to change (parameters, effects' numbers) and run
models(), scenes()          what this module knows
effect_kinds()              the effect kinds a scene may name, with keys and laws
equations(model)            the derived equations (LaTeX in Jupyter)
check(model)                the derived terms against automatic differentiation

Refused input raises EzyError with the command line's message; Ctrl-C stops
a run (KeyboardInterrupt).";

/// How often a running integration asks Python for pending signals (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// The Python helpers (drawing with matplotlib), compiled into every module.
const HELPERS: &str = include_str!("helpers.py");

/// Makes a Python extension module of a user's crate: `$name` is the
/// module's name (the crate's `[lib] name`, which `import` takes) and
/// `$app` an expression giving the [`ezy::App`] with the crate's models,
/// effect kinds and scenes. The module then offers exactly what `ezy`
/// does, over that application (see [`init_module`]).
///
/// ```ignore
/// ezy_python::python_module!(my_vehicles, ezy::App::empty().model::<Sleigh>("sleigh"));
/// ```
///
/// The crate is a `cdylib` built by maturin (guide: "Your own vehicle in
/// Python").
#[macro_export]
macro_rules! python_module {
    ($name:ident, $app:expr) => {
        #[$crate::pyo3::pymodule]
        #[pyo3(crate = "::ezy_python::pyo3")]
        fn $name(m: &$crate::pyo3::Bound<'_, $crate::pyo3::types::PyModule>) -> $crate::pyo3::PyResult<()> {
            $crate::init_module(m, $app)
        }
    };
}

// The `ezy` module: the built-in vehicles and scenes (what the `ezy`
// command line knows). Named by hand, not by `python_module!`: a Rust item
// called `ezy` would hide the `ezy` crate in this one.
#[pymodule]
#[pyo3(name = "ezy")]
fn ezy_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    init_module(m, App::new())
}

/// Fills module `m` with the API over `app`: the functions `models`,
/// `scenes`, `effect_kinds`, `scene`, `run`, `sweep`, `equations`, `check`, the classes
/// `Result`, `Scene`, `Effect`, `Equations`, `Check` and the exception
/// `EzyError`.
///
/// # Errors
/// A Python error if the module cannot be filled (the helpers fail to
/// compile, an attribute cannot be set).
pub fn init_module(m: &Bound<'_, PyModule>, app: App) -> PyResult<()> {
    let py = m.py();
    let name = m.name()?.extract::<String>()?;
    let code = CString::new(HELPERS).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let file = CString::new(format!("{name}/helpers.py")).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let module = CString::new(format!("{name}._helpers")).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let helpers = PyModule::from_code(py, &code, &file, &module)?;
    // NumPy's C API, loaded now rather than by the first run's result: that
    // first use runs Python code (NumPy's version check), where a Ctrl-C
    // that came after the run's last look at the signals (a short run, or
    // the last 50 ms of one) was raised inside the loading and came out as
    // a PanicException ("Failed to access NumPy array API capsule")
    // instead of KeyboardInterrupt. After this, a run's result is made by C
    // calls only, and such a Ctrl-C is raised as the call returns. (NumPy
    // missing: the ImportError, not a panic.)
    py.import("numpy")?;
    PyArray1::from_vec(py, Vec::<f64>::new());
    m.add("EzyError", py.get_type::<EzyError>())?;
    m.add_class::<RunResult>()?;
    m.add_class::<PyScene>()?;
    m.add_class::<Effect>()?;
    m.add_class::<Equations>()?;
    m.add_class::<Check>()?;
    m.add_class::<Toolkit>()?;
    let kit = Bound::new(py, Toolkit { app, helpers: helpers.unbind() })?;
    for f in ["models", "scenes", "effect_kinds", "scene", "run", "sweep", "equations", "check"] {
        m.add(f, kit.getattr(f)?)?;
    }
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.setattr("__doc__", MODULE_DOC)?;
    Ok(())
}

fn ezy_err(e: impl std::fmt::Display) -> PyErr {
    EzyError::new_err(e.to_string())
}

/// The application behind a module: its models, effect kinds and scenes.
#[pyclass(module = "ezy", frozen)]
pub struct Toolkit {
    app: App,
    helpers: Py<PyModule>,
}

/// What `run` and `sweep` take on top of a scene, as the command line's
/// flags would give it.
#[derive(Default)]
struct Overrides {
    sets: Vec<(String, f64)>,
    integrator: Option<String>,
    formulation: Option<String>,
    projection: Option<String>,
    rtol: Option<f64>,
    atol: Option<f64>,
    dt: Option<f64>,
    t_end: Option<f64>,
    every: Option<f64>,
    max_steps: Option<u64>,
    max_output_mb: Option<f64>,
}

impl Overrides {
    /// The keywords `run` and `sweep` take for settings.
    const KEYWORDS: [&str; 11] = [
        "set",
        "integrator",
        "formulation",
        "projection",
        "rtol",
        "atol",
        "dt",
        "t_end",
        "every",
        "max_steps",
        "max_output_mb",
    ];

    /// A `Scene` object's `sets`, then the keywords `settings` of a call
    /// to `function` (their `set` after the object's).
    fn new(sets: Vec<(String, f64)>, settings: Option<&Bound<'_, PyDict>>, function: &str) -> PyResult<Self> {
        let mut o = Self { sets, ..Self::default() };
        let Some(settings) = settings else { return Ok(o) };
        for (k, v) in settings.iter() {
            let key: String = k.extract()?;
            let bad = |what: &str| PyValueError::new_err(format!("{function}(): `{key}` = {v} is not {what}"));
            let number = || v.extract::<f64>().map_err(|_| bad("a number"));
            let text = || v.extract::<String>().map_err(|_| bad("a string"));
            match key.as_str() {
                "set" => o.sets.extend(sets_of(Some(v.cast::<PyDict>().map_err(|_| bad("a dict"))?))?),
                "integrator" => o.integrator = Some(text()?),
                "formulation" => o.formulation = Some(text()?),
                "projection" => o.projection = Some(text()?),
                "rtol" => o.rtol = Some(number()?),
                "atol" => o.atol = Some(number()?),
                "dt" => o.dt = Some(number()?),
                "t_end" => o.t_end = Some(number()?),
                "every" => o.every = Some(number()?),
                "max_steps" => o.max_steps = Some(v.extract().map_err(|_| bad("a whole number >= 0"))?),
                "max_output_mb" => {
                    let mb = number()?;
                    if !(mb.is_finite() && mb > 0.0) {
                        return Err(bad("a positive number of MB"));
                    }
                    o.max_output_mb = Some(mb);
                }
                _ => {
                    return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                        "{function}() got an unexpected keyword `{key}`; its settings: {}",
                        Self::KEYWORDS.join(", ")
                    )));
                }
            }
        }
        Ok(o)
    }

    fn options(&self) -> PyResult<RunOptions> {
        fn choice<T: Choice>(what: &str, v: &Option<String>) -> PyResult<Option<T>> {
            v.as_deref().map(|s| T::parse(s).map_err(|e| ezy_err(format!("{what}={s:?}: {e}")))).transpose()
        }
        Ok(RunOptions {
            sets: self.sets.clone(),
            method: choice::<Method>("integrator", &self.integrator)?,
            formulation: choice::<Formulation>("formulation", &self.formulation)?,
            projection: choice::<ProjectionKind>("projection", &self.projection)?,
            rtol: self.rtol,
            atol: self.atol,
            dt: self.dt,
            t_end: self.t_end,
            every: self.every,
            max_steps: self.max_steps,
            max_output_mb: self.max_output_mb,
            ..RunOptions::default()
        })
    }
}

/// `{name: value}` as `(name, value)` pairs, in the dict's order.
fn sets_of(set: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, f64)>> {
    let mut out = Vec::new();
    if let Some(d) = set {
        for (k, v) in d.iter() {
            let name: String =
                k.extract().map_err(|_| PyValueError::new_err(format!("set: key {k} is not a string")))?;
            let value: f64 =
                v.extract().map_err(|_| PyValueError::new_err(format!("set: `{name}` = {v} is not a number")))?;
            out.push((name, value));
        }
    }
    Ok(out)
}

/// The scene a call names, with the changes a `Scene` object carries.
struct Resolved {
    /// The scene as loaded and checked.
    src: SceneSource,
    /// A `Scene` object's sets (none for a name or a path).
    sets: Vec<(String, f64)>,
    /// How it was named: a known scene's name or a file's path.
    reference: String,
}

impl Toolkit {
    /// The scene `scene` names (a known name or a path), or a `Scene`
    /// object's, with the object's own sets.
    fn resolve(&self, scene: &Bound<'_, PyAny>) -> PyResult<Resolved> {
        if let Ok(s) = scene.cast::<PyScene>() {
            let s = s.borrow();
            return Ok(Resolved { src: s.src.clone(), sets: s.sets.clone(), reference: s.reference.clone() });
        }
        let name: String = scene.extract().map_err(|_| {
            PyValueError::new_err("scene: give a scene's name, a path to a .toml file, or an ezy.Scene")
        })?;
        let src = self.app.load_scene(&name).map_err(ezy_err)?;
        Ok(Resolved { src, sets: Vec::new(), reference: name })
    }

    fn info(&self, model: &str, params: &[(String, f64)]) -> PyResult<ModelInfo> {
        match self.app.info_with(model, params) {
            Some(Ok(info)) => Ok(info),
            Some(Err(e)) => Err(ezy_err(e.message)),
            None => Err(ezy_err(format!("unknown model `{model}`; known models: {}", self.app.keys().join(", ")))),
        }
    }

    /// Runs the command line `args` (after the program name) with the GIL
    /// released; Ctrl-C asks the command to stop ([`ezy::transaction::request_stop`])
    /// and raises `KeyboardInterrupt` once it has. Returns what it printed.
    fn cli(&self, py: Python<'_>, args: Vec<String>) -> PyResult<Result<String, (String, ezy::app::AppError)>> {
        let app = &self.app;
        let mut interrupt: Option<PyErr> = None;
        let out = py.detach(|| {
            std::thread::scope(|s| {
                let worker = s.spawn(|| {
                    let mut buf = Vec::new();
                    let argv = std::iter::once("ezy".to_string()).chain(args);
                    let r = app.run_cli(argv, &mut buf);
                    let text = String::from_utf8_lossy(&buf).into_owned();
                    r.map(|()| text.clone()).map_err(|e| (text, e))
                });
                while !worker.is_finished() {
                    std::thread::sleep(Duration::from_millis(10));
                    if interrupt.is_none()
                        && let Err(e) = Python::attach(|py| py.check_signals())
                    {
                        interrupt = Some(e);
                        ezy::transaction::request_stop();
                    }
                }
                worker.join()
            })
        });
        ezy::transaction::clear_stop();
        if let Some(e) = interrupt {
            return Err(e);
        }
        out.map_err(|_| EzyError::new_err("the command panicked"))
    }
}

#[pymethods]
impl Toolkit {
    /// The models this module knows: `{key: description}`.
    fn models<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for key in self.app.keys() {
            d.set_item(key, self.info(key, &[])?.doc)?;
        }
        Ok(d)
    }

    /// The scenes this module knows: `{name: description}`.
    ///
    /// Raises EzyError for a bad scene file (its file, line and key).
    fn scenes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for src in self.app.scenes().map_err(ezy_err)? {
            d.set_item(&src.scene.name, &src.scene.description)?;
        }
        Ok(d)
    }

    /// The effect kinds a scene's `[effects.NAME]` table may name by its
    /// `kind`: `{kind: {"builtin": True, "keys": ..., "law": ...,
    /// "value_column": "tau_<name>" or "F_<name>"}}` for the built-in
    /// kinds, in the order of ezy's registry (the rows of the guide's
    /// reference page "Effect kinds"), then `{kind: {"builtin": False}}`
    /// for this module's own kinds.
    fn effect_kinds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for r in ezy_core::effects::REFERENCE {
            let row = PyDict::new(py);
            row.set_item("builtin", true)?;
            row.set_item("keys", r.keys)?;
            row.set_item("law", r.law)?;
            row.set_item("value_column", format!("{}_<name>", r.value_prefix))?;
            d.set_item(r.kind, row)?;
        }
        for kind in self.app.effect_kinds().map(|k| k.names()).unwrap_or_default() {
            let row = PyDict::new(py);
            row.set_item("builtin", false)?;
            d.set_item(kind, row)?;
        }
        Ok(d)
    }

    /// The scene `name` (a known scene's name, or a path to a .toml file)
    /// as an editable `Scene`: change its parameters and effects' numbers,
    /// then `run` it.
    ///
    /// Raises EzyError for an unknown name or a bad file (file, line, key).
    fn scene(slf: &Bound<'_, Self>, name: &str) -> PyResult<PyScene> {
        let this = slf.get();
        let src = this.app.load_scene(name).map_err(ezy_err)?;
        let info = this.info(&src.scene.model, &src.scene.params)?;
        Ok(PyScene { kit: slf.clone().unbind(), src, info, sets: Vec::new(), reference: name.to_string() })
    }

    /// Runs `scene` (a name, a path or a `Scene`) in memory and returns a
    /// `Result`: every output row (the columns of the command line's
    /// trajectory.csv) as NumPy arrays, and the run's summary.
    ///
    /// Keyword arguments override the scene as `ezy run`'s flags do:
    /// `set={"M0": 1.0, "motor.amplitude": 3.0}`, `integrator` ("rk4",
    /// "dopri5", "dop853", "radau5"), `formulation` ("auto", "dae",
    /// "reduced"), `projection`, `rtol`, `atol`, `dt` [s], `t_end` [s],
    /// `every` [s] (output interval), `max_steps`, `max_output_mb` (the
    /// output budget [MB], as the command line's `--max-output-mb`).
    ///
    /// Raises EzyError naming the bad setting, parameter or scene key;
    /// KeyboardInterrupt on Ctrl-C (the run stops within a step).
    #[pyo3(signature = (scene, **settings))]
    fn run(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<RunResult> {
        let Resolved { src, sets, .. } = self.resolve(scene)?;
        let o = Overrides::new(sets, settings, "run")?;
        let opts = o.options()?;
        let info = self.info(&src.scene.model, &src.scene.params)?;
        // A Ctrl-C that came while this call held the GIL (Python runs its
        // handler only when asked): raised before the run's setup
        py.check_signals()?;
        let app = &self.app;
        let mut interrupt: Option<PyErr> = None;
        // the first step asks at once (a Ctrl-C during the setup), then
        // every SIGNAL_POLL
        let mut last: Option<Instant> = None;
        let mut hook = |_t: f64| {
            if last.is_some_and(|l| l.elapsed() < SIGNAL_POLL) {
                return None;
            }
            last = Some(Instant::now());
            match Python::attach(|py| py.check_signals()) {
                Ok(()) => None,
                Err(e) => {
                    interrupt = Some(e);
                    Some("interrupted from Python".to_string())
                }
            }
        };
        let report = py.detach(|| app.run_scene_in_memory(&src.scene, &opts, Some(&mut hook)));
        if let Some(e) = interrupt {
            return Err(e);
        }
        let report = report.map_err(ezy_err)?;
        RunResult::new(py, &src, info, report, self.helpers.clone_ref(py))
    }

    /// Runs `scene` over a grid of parameter values (in parallel, on at
    /// most `jobs` cores) and returns the table of runs as a pandas
    /// DataFrame: one row per run with its values, status, cost, final
    /// state and `metrics`.
    ///
    /// `grid={"M0": [1, 2, 3]}` gives an axis of values, `{"M0": "1:3:5"}`
    /// 5 evenly spaced values from 1 to 3; the first axis varies slowest.
    /// `metrics=["mean(norm(x1d, y1d), 50, 60)", "final(T)"]` as `ezy sweep
    /// --metric`. `out` keeps the sweep's directory (sweep.csv, resumable);
    /// without it the files live in a temporary directory. Other keywords
    /// as `run`.
    ///
    /// Raises EzyError naming the bad axis, metric or setting (by the
    /// command line's flag); KeyboardInterrupt on Ctrl-C.
    #[pyo3(signature = (scene, grid, *, metrics=None, jobs=None, out=None, **settings))]
    #[allow(clippy::too_many_arguments)] // Python's keywords, one argument each
    fn sweep<'py>(
        &self,
        py: Python<'py>,
        scene: &Bound<'py, PyAny>,
        grid: &Bound<'py, PyDict>,
        metrics: Option<Vec<String>>,
        jobs: Option<usize>,
        out: Option<PathBuf>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let Resolved { sets, reference, .. } = self.resolve(scene)?;
        let o = Overrides::new(sets, settings, "sweep")?;
        let opts = o.options()?; // the keywords' own errors first, named as keywords
        let temp = tempfile::Builder::new().prefix("ezy-sweep-").tempdir().map_err(ezy_err)?;
        let dir = out.unwrap_or_else(|| temp.path().join("sweep"));
        // the scene as it was named: a known scene's name or its file's path
        let mut args = vec!["sweep".to_string(), reference];
        if grid.is_empty() {
            return Err(ezy_err("grid: give at least one axis, e.g. grid={\"M0\": [1, 2, 3]}"));
        }
        for (k, v) in grid.iter() {
            let name: String =
                k.extract().map_err(|_| PyValueError::new_err(format!("grid: key {k} is not a string")))?;
            if let Ok(spec) = v.extract::<String>() {
                args.extend(["--grid".into(), format!("{name}={spec}")]);
            } else {
                let values: Vec<f64> = v.extract().map_err(|_| {
                    PyValueError::new_err(format!(
                        "grid: `{name}` needs a list of numbers or \"START:STOP:COUNT\", not {v}"
                    ))
                })?;
                let list: Vec<String> = values.iter().map(|x| format!("{x:?}")).collect();
                args.extend(["--list".into(), format!("{name}={}", list.join(","))]);
            }
        }
        for m in metrics.unwrap_or_default() {
            args.extend(["--metric".into(), m]);
        }
        args.extend(opts.to_args());
        if let Some(j) = jobs {
            args.extend(["--jobs".into(), j.to_string()]);
        }
        args.extend(["--out".into(), dir.display().to_string(), "--no-figures".into()]);
        match self.cli(py, args)? {
            Ok(_) => {}
            Err((_, e)) => return Err(ezy_err(e)),
        }
        let frame = self.helpers.bind(py).call_method1("sweep_frame", (dir.join("sweep.csv"),))?;
        drop(temp);
        Ok(frame)
    }

    /// The derived equations of `model` (with `set` applied to its
    /// parameters and family counts): constraints, Jacobian, convective
    /// terms, point velocities. Jupyter renders them as LaTeX; `str()`
    /// gives the plain text.
    ///
    /// Raises EzyError for an unknown model or parameter.
    #[pyo3(signature = (model, *, set=None))]
    fn equations(&self, py: Python<'_>, model: &str, set: Option<&Bound<'_, PyDict>>) -> PyResult<Equations> {
        let sets = sets_of(set)?;
        let mut args = vec!["equations".to_string(), model.to_string()];
        for (n, v) in &sets {
            args.extend(["--set".into(), format!("{n}={v:?}")]);
        }
        let text = self.cli(py, args.clone())?.map_err(|(_, e)| ezy_err(e))?;
        args.extend(["--format".into(), "latex".into()]);
        let latex = self.cli(py, args)?.map_err(|(_, e)| ezy_err(e))?;
        Ok(Equations { text, latex })
    }

    /// Checks `model`'s derived terms (the constraint Jacobian, the skate
    /// rows, gamma, the point velocities) against automatic
    /// differentiation at `states` random states: a `Check` with `passed`
    /// and the table `ezy check` prints.
    ///
    /// Raises EzyError for an unknown model or parameter.
    #[pyo3(signature = (model, *, set=None, states=None, seed=None))]
    fn check(
        &self,
        py: Python<'_>,
        model: &str,
        set: Option<&Bound<'_, PyDict>>,
        states: Option<usize>,
        seed: Option<u64>,
    ) -> PyResult<Check> {
        let mut args = vec!["check".to_string(), model.to_string()];
        for (n, v) in sets_of(set)? {
            args.extend(["--set".into(), format!("{n}={v:?}")]);
        }
        if let Some(s) = states {
            args.extend(["--states".into(), s.to_string()]);
        }
        if let Some(s) = seed {
            args.extend(["--seed".into(), s.to_string()]);
        }
        match self.cli(py, args)? {
            Ok(table) => Ok(Check { passed: true, table, message: String::new() }),
            // a failed check prints its table first; no table: a bad request
            Err((table, e)) if !table.is_empty() => Ok(Check { passed: false, table, message: e.to_string() }),
            Err((_, e)) => Err(ezy_err(e)),
        }
    }
}

/// A finished run: every output row, in memory.
///
/// `result["x1"]` is a column (a NumPy view into `result.data`, rows x
/// columns), `result.t` the times [s], `result.columns` the names (those of
/// the command line's trajectory.csv), `result.to_pandas()` a DataFrame,
/// `result.plot("fig3_paths")` one of the scene's figures in matplotlib,
/// `result.summary` the text `ezy run` prints.
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
    fn new(
        py: Python<'_>,
        src: &SceneSource,
        info: ModelInfo,
        report: ezy::Report,
        helpers: Py<PyModule>,
    ) -> PyResult<Self> {
        let summary = run::summary(&src.scene.name, &report);
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

    fn index(&self, name: &str) -> PyResult<usize> {
        self.columns.iter().position(|c| c == name).ok_or_else(|| {
            PyKeyError::new_err(format!(
                "no column `{name}` in this run of {}; its columns: {}",
                self.scene,
                self.columns.join(", ")
            ))
        })
    }

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

    fn __len__(&self) -> usize {
        self.columns.len()
    }

    /// The column names (as a mapping's keys).
    fn keys(&self) -> Vec<String> {
        self.columns.clone()
    }

    /// The rows as a pandas DataFrame (over `data`, not a copy where
    /// pandas allows).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.helpers.bind(py).call_method1("to_pandas", (self.data.bind(py), self.columns.clone()))
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
        let table = ezy::output::Table { columns: self.columns.clone(), data: data.as_slice()?.to_vec() };
        let chart = ezy::figures::chart(&self.info, fig, &table).map_err(ezy_err)?;
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
                ezy::plot::Stroke::Auto => "auto".to_string(),
                ezy::plot::Stroke::Solid => "solid".to_string(),
                ezy::plot::Stroke::Dash(k) => format!("dash{k}"),
                ezy::plot::Stroke::Points => "points".to_string(),
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

/// A scene to change and run: `scene["M0"] = 1.0` sets a scene or model
/// parameter, `scene.effects["motor"].amplitude = 1.0` a number of an
/// effect (as `--set motor.amplitude=1.0` would), each checked at once
/// with the command line's message; `scene.run(...)` runs it.
#[pyclass(module = "ezy", name = "Scene")]
pub struct PyScene {
    /// The module's application, which runs it.
    kit: Py<Toolkit>,
    src: SceneSource,
    info: ModelInfo,
    sets: Vec<(String, f64)>,
    /// How the scene was named (its name, or the path it was read from).
    reference: String,
}

impl PyScene {
    /// The scene with every set applied.
    fn applied(&self) -> PyResult<ezy_scene::Scene> {
        let mut s = self.src.scene.clone();
        for (n, v) in &self.sets {
            s.set(&self.info, n, *v).map_err(ezy_err)?;
        }
        Ok(s)
    }

    fn set_value(&mut self, name: &str, value: f64) -> PyResult<()> {
        let mut trial = self.applied()?;
        trial.set(&self.info, name, value).map_err(ezy_err)?;
        // an effect kind of the user's own reads its fields when the run
        // is set up: checked now, as the command line's run would
        self.kit
            .get()
            .app
            .check_user_effects(&trial.model, &trial)
            .map_err(|e| ezy_err(ezy_core::SimError::Scene { key: e.key(), message: e.message }))?;
        self.sets.retain(|(n, _)| n != name);
        self.sets.push((name.to_string(), value));
        Ok(())
    }
}

#[pymethods]
impl PyScene {
    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.src.scene.name.clone()
    }

    /// The model key it runs.
    #[getter]
    fn model(&self) -> String {
        self.src.scene.model.clone()
    }

    /// Its description.
    #[getter]
    fn description(&self) -> String {
        self.src.scene.description.clone()
    }

    /// The file it was read from (as errors name it).
    #[getter]
    fn file(&self) -> String {
        self.src.file.clone()
    }

    /// Its duration [s].
    #[getter]
    fn t_end(&self) -> PyResult<f64> {
        Ok(self.applied()?.t_end)
    }

    /// The changes made so far, as `(name, value)` pairs (what `--set`
    /// would give).
    #[getter]
    fn sets(&self) -> Vec<(String, f64)> {
        self.sets.clone()
    }

    /// The scene's parameters and the model's, with their current values.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.applied()?;
        let d = PyDict::new(py);
        for (n, v) in &s.scene_params {
            d.set_item(n, v)?;
        }
        for p in &self.info.params {
            let v = s.params.iter().find(|(n, _)| n == p.name).map_or(p.default, |(_, v)| *v);
            d.set_item(p.name, v)?;
        }
        Ok(d)
    }

    /// The effects (and drives) by name: `scene.effects["motor"]`.
    #[getter]
    fn effects<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyDict>> {
        let py = slf.py();
        let d = PyDict::new(py);
        let this = slf.borrow();
        let names = this.src.scene.effects.iter().map(|(n, _)| n).chain(this.src.scene.drives.iter().map(|(n, _)| n));
        for name in names {
            d.set_item(name, Effect { scene: slf.clone().unbind(), item: name.clone() })?;
        }
        Ok(d)
    }

    /// The current value of a scene or model parameter.
    fn __getitem__(&self, py: Python<'_>, name: &str) -> PyResult<f64> {
        let params = self.params(py)?;
        match params.get_item(name)? {
            Some(v) => v.extract(),
            None => Err(PyKeyError::new_err(format!(
                "scene {} has no parameter `{name}`; its parameters: {}",
                self.src.scene.name,
                params.keys().iter().map(|k| k.to_string()).collect::<Vec<_>>().join(", ")
            ))),
        }
    }

    /// Sets a scene parameter, a model parameter or `EFFECT.KEY` (as
    /// `--set NAME=VALUE`).
    ///
    /// Raises EzyError naming the unknown name (listing the known ones) or
    /// the bad value.
    fn __setitem__(&mut self, name: &str, value: f64) -> PyResult<()> {
        self.set_value(name, value)
    }

    /// Sets a scene parameter, a model parameter or `EFFECT.KEY`, and
    /// returns the scene (to chain).
    fn set<'py>(slf: Bound<'py, Self>, name: &str, value: f64) -> PyResult<Bound<'py, Self>> {
        slf.borrow_mut().set_value(name, value)?;
        Ok(slf)
    }

    /// Runs this scene with its changes; keywords as `ezy.run`.
    #[pyo3(signature = (**kwargs))]
    fn run<'py>(slf: &Bound<'py, Self>, kwargs: Option<&Bound<'py, PyDict>>) -> PyResult<Bound<'py, PyAny>> {
        let kit = slf.borrow().kit.clone_ref(slf.py());
        kit.bind(slf.py()).getattr("run")?.call((slf,), kwargs)
    }

    fn __repr__(&self) -> String {
        let sets: Vec<String> = self.sets.iter().map(|(n, v)| format!("{n}={v:?}")).collect();
        format!(
            "<ezy.Scene {} (model {}, {}){}>",
            self.src.scene.name,
            self.src.scene.model,
            self.src.file,
            if sets.is_empty() { String::new() } else { format!(" with {}", sets.join(", ")) }
        )
    }
}

/// The numbers of one effect or drive of a `Scene`: read and set them as
/// attributes by their full key (`torque.cos.amplitude` through
/// `getattr`) or their last part when unambiguous (`amplitude`).
#[pyclass(module = "ezy", frozen)]
pub struct Effect {
    scene: Py<PyScene>,
    item: String,
}

#[pymethods]
impl Effect {
    /// `{key: value}` of every number of this effect, current values.
    fn numbers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let scene = self.scene.bind(py).borrow().applied()?;
        let d = PyDict::new(py);
        for (k, v) in scene.numbers(&self.item).unwrap_or_default() {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    fn __getattr__(&self, py: Python<'_>, key: &str) -> PyResult<f64> {
        let scene = self.scene.bind(py).borrow().applied()?;
        let numbers = scene.numbers(&self.item).unwrap_or_default();
        let hits: Vec<&(String, f64)> =
            numbers.iter().filter(|(k, _)| k == key || k.rsplit('.').next() == Some(key)).collect();
        match hits.as_slice() {
            [(_, v)] => Ok(*v),
            _ => {
                let exact = numbers.iter().find(|(k, _)| k == key);
                exact.map(|(_, v)| *v).ok_or_else(|| {
                    let known: Vec<&str> = numbers.iter().map(|(k, _)| k.as_str()).collect();
                    pyo3::exceptions::PyAttributeError::new_err(format!(
                        "`{}.{key}` is {}; its numbers: {}",
                        self.item,
                        if hits.is_empty() { "no number of this effect" } else { "ambiguous" },
                        known.join(", ")
                    ))
                })
            }
        }
    }

    fn __setattr__(&self, py: Python<'_>, key: &str, value: f64) -> PyResult<()> {
        self.scene.bind(py).borrow_mut().set_value(&format!("{}.{key}", self.item), value)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("<ezy.Effect {}: {}>", self.item, self.numbers(py)?.repr()?))
    }
}

/// A model's derived equations: `str()` is the text, Jupyter shows the
/// LaTeX (`_repr_latex_`).
#[pyclass(module = "ezy", frozen)]
pub struct Equations {
    /// The plain text `ezy equations` prints.
    #[pyo3(get)]
    text: String,
    /// The whole LaTeX document (`ezy equations --format latex`).
    #[pyo3(get)]
    latex: String,
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
    passed: bool,
    /// The table `ezy check` prints.
    #[pyo3(get)]
    table: String,
    /// Why the check failed (empty when it passed).
    #[pyo3(get)]
    message: String,
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
