#![warn(missing_docs)]
#![allow(
    rustdoc::broken_intra_doc_links,
    reason = "the docstrings of the #[pymethods] are Python's help: a unit in them is written `[s]`, as Python users read it, not as an intra-doc link"
)]
//! ezy from Python: the extension module `ezy` (built by maturin from this
//! crate: `pip install ./python`) and the means for a user's crate to
//! become a Python module with its own vehicles and force laws
//! ([`python_module!`]).
//!
//! Everything a module offers is [`init_module`] over an [`ezy::App`]:
//! `models()`, `scenes()`, `effect_kinds()`, `scene(...)`, `run(scene,
//! ...)`, `sweep(scene, ...)`, `analyze(scene, ...)`, `sensitivity(scene,
//! wrt=...)`, `linearize(scene,
//! ...)`, `equations(model)` and `check(model)`, the classes `Result`,
//! `Scene`, `Model`, `Equations`, `Analysis` and `Linearization`, and the
//! exception `EzyError`, whose
//! message is the command line's (the file, line, key or keyword at
//! fault), its flags said as the call's keywords (`words`).
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

mod command;
mod kit;
mod model;
mod planning;
mod quantities;
mod reports;
mod result;
mod scene;
mod scene_text;
mod settings;
mod sweep;
mod toolkit;
mod units;
mod words;

pub use kit::Toolkit;
pub use model::PyModel;
pub use reports::{Analysis, Check, Equations, Geometry, Linearization};
pub use result::RunResult;
pub use scene::{Effect, PyScene};

use std::ffi::CString;

use ezy::App;
use numpy::PyArray1;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    ezy,
    EzyError,
    PyException,
    "A scene, model, setting or run that ezy refused; the message names the culprit (file, line, key, keyword or value)."
);

/// The docstring of every module [`init_module`] fills.
const MODULE_DOC: &str = "Planar vehicles and mechanisms with hinges and skates (ezy).

run(scene, **settings)      a scene in memory: a Result with NumPy arrays
sweep(scene, grid, ...)     runs over parameter values: a pandas DataFrame
analyze(scene, ...)         steady motions or the gait and their stability: DataFrames
sensitivity(scene, wrt=..)  the run's derivatives d<column>/d<param>: a DataFrame
fit(scene, data=.., ...)    numbers of the scene fitted to a measured run, with standard errors
optimize(scene, maximize=.., over=..)
                            numbers of the scene that make a gait or a run best: a DataFrame
plan(scene, input=.., to=.., at_rest=True)
                            the least-effort inputs to a target, verified by a run: a DataFrame
gait_optimize(model, gait=.., maximize=..)
                            a kinematic system's best closed gait: a DataFrame
linearize(scene, at=t)      A, B and the eigenvalues at a time of the run
scene(name), scene(toml=..), scene(model=m, t_end=.., initial=.., ...)
                            a Scene to change (parameters, effects' numbers) and run
models(), scenes()          what this module knows
effect_kinds()              the effect kinds a scene may name, with keys and laws
equations(model)            the derived equations (LaTeX in Jupyter)
check(model)                the derived terms against automatic differentiation
Model(text), Model.load(p)  a vehicle from the text of a model (no compiler): run(scene, model=m)

Refused input raises EzyError with the command line's message, its flags
said as the call's keywords; Ctrl-C stops a run (KeyboardInterrupt). A
report of a call without out= says which attributes hold its tables.";

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
/// `scenes`, `effect_kinds`, `scene`, `run`, `sweep`, `analyze`,
/// `sensitivity`, `fit`, `optimize`, `linearize`, `equations`, `check`, the classes `Result`, `Scene`,
/// `Effect`, `Equations`, `Check`, `Analysis`, `Linearization`, `Model`
/// and the exception `EzyError`.
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
    m.add_class::<Analysis>()?;
    m.add_class::<Linearization>()?;
    m.add_class::<Geometry>()?;
    m.add_class::<Toolkit>()?;
    m.add_class::<PyModel>()?;
    let kit = Bound::new(py, Toolkit { app, helpers: helpers.unbind() })?;
    // what the module knows, then the command line's commands it offers
    // (the command table's list: a new command is one line there and one
    // method of the toolkit)
    // (a command's hyphen an underscore: `gait-optimize` is `gait_optimize`)
    for f in ["models", "scenes", "effect_kinds", "scene"].into_iter().chain(ezy::python_commands()) {
        let f = f.replace('-', "_");
        m.add(f.as_str(), kit.getattr(f.as_str())?)?;
    }
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.setattr("__doc__", MODULE_DOC)?;
    Ok(())
}

/// `e` as an `EzyError`, its message the command line's.
fn ezy_err(e: impl std::fmt::Display) -> PyErr {
    EzyError::new_err(e.to_string())
}
