//! `ezy.Model`: a vehicle defined from the text of a model (what goes
//! between the braces of `model! { ... }`, or a `.ezy` file), derived at
//! run time by the engine `model!` uses, usable wherever a model is
//! (`ezy.run(scene, model=m)`, `ezy.sweep(..., model=m)`,
//! `ezy.equations(m)`, `ezy.check(m)`).

use std::path::PathBuf;

use ezy_core::Model as _;
use ezy_core::text::{ModelTextError, RuntimeModel};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::ezy_err;

/// A planar vehicle or mechanism read from text: bodies, points, hinges,
/// sliders, drives and skates in ezy's model language (the guide's
/// chapter "Writing a model"), derived when it is made.
///
/// `ezy.Model(text)` reads the text; `ezy.Model.load(path)` a `.ezy`
/// file. A mistake raises EzyError with every mistake found, each at its
/// line and column (and file), in the words of `model!`'s compile errors.
/// `key` is the name commands know it by (default: the struct's name).
#[pyclass(module = "ezy", name = "Model", frozen)]
pub struct PyModel {
    pub(crate) model: RuntimeModel,
    /// The name commands know it by.
    #[pyo3(get)]
    pub(crate) key: String,
}

#[pymethods]
impl PyModel {
    /// Reads and derives `text`, with the GIL released (other threads run
    /// meanwhile); Ctrl-C raises KeyboardInterrupt within 50 ms.
    ///
    /// Raises EzyError with each mistake at `line:column`, or for a text
    /// of more than 100 bodies declared one by one (the derivation's time
    /// grows as the cube of their count).
    #[new]
    #[pyo3(signature = (text, *, key=None))]
    fn new(py: Python<'_>, text: &str, key: Option<String>) -> PyResult<Self> {
        let text = text.to_owned();
        Self::made(derived(py, move || RuntimeModel::from_text(&text))?, key)
    }

    /// The model in the file `path` (a `.ezy` file), derived as
    /// `ezy.Model(text)` is.
    ///
    /// Raises EzyError if it cannot be read, or with each mistake at
    /// `file:line:column`.
    #[staticmethod]
    #[pyo3(signature = (path, *, key=None))]
    fn load(py: Python<'_>, path: PathBuf, key: Option<String>) -> PyResult<Self> {
        Self::made(derived(py, move || RuntimeModel::from_file(&path))?, key)
    }

    /// The struct's name (`EzyRoller`).
    #[getter]
    fn name(&self) -> &'static str {
        self.model.info().name
    }

    /// The parameters and family counts with their current values:
    /// `{name: value}` (units in the model's doc comments).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (i, p) in self.model.info().params.iter().enumerate() {
            d.set_item(p.name, self.model.param(i))?;
        }
        Ok(d)
    }

    /// The generalized coordinates' names, in order (nq).
    #[getter]
    fn coords(&self) -> Vec<String> {
        self.model.info().coords
    }

    /// The derived equations (as `ezy.equations(m)`): LaTeX in Jupyter.
    fn equations(&self, py: Python<'_>) -> PyResult<crate::reports::Equations> {
        let app = ezy::App::empty().with_model_as(&self.key, self.model.clone());
        crate::kit::equations_in(py, &app, &self.key, None)
    }

    fn __repr__(&self) -> String {
        let info = self.model.info();
        format!("ezy.Model({}: nq = {}, nc = {}, key = {:?})", info.name, info.nq(), info.nc(), self.key)
    }
}

/// What `derive` gives, computed on a thread of its own while this one
/// waits with the GIL released, asking Python for pending signals every
/// [`SIGNAL_POLL`]: a Ctrl-C raises KeyboardInterrupt at once. The
/// derivation cannot be stopped midway; it finishes on its thread (its
/// time bounded by the body count ezy-lang's `MAX_TEXT_BODIES` allows)
/// and its result is dropped.
fn derived(
    py: Python<'_>,
    derive: impl FnOnce() -> Result<RuntimeModel, ModelTextError> + Send + 'static,
) -> PyResult<Result<RuntimeModel, ModelTextError>> {
    py.check_signals()?;
    let worker = std::thread::Builder::new().name("ezy-model".into()).spawn(derive).map_err(ezy_err)?;
    py.detach(|| {
        while !worker.is_finished() {
            std::thread::sleep(SIGNAL_POLL);
            Python::attach(|py| py.check_signals())?;
        }
        worker.join().map_err(|_| crate::EzyError::new_err("the derivation panicked"))
    })
}

/// How often a derivation's wait asks Python for pending signals.
const SIGNAL_POLL: std::time::Duration = std::time::Duration::from_millis(20);

impl PyModel {
    fn made(model: Result<RuntimeModel, ModelTextError>, key: Option<String>) -> PyResult<Self> {
        let model = model.map_err(ezy_err)?;
        let key = key.unwrap_or_else(|| model.info().name.to_string());
        if key.is_empty() || key.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(ezy_err(format!("key {key:?}: give a name without spaces")));
        }
        Ok(Self { model, key })
    }
}
