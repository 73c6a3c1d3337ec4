//! `ezy.Scene`, a scene to change and run (its parameters and its
//! effects' numbers, each change checked at once with the command line's
//! message), and `ezy.Effect`, one effect's or drive's numbers as
//! attributes.

use ezy_core::ModelInfo;
use ezy_scene::registry::ModelCatalog as _;
use ezy_scene::registry::SceneSource;
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::ezy_err;
use crate::kit::Toolkit;
use crate::model::PyModel;
use crate::settings::real;

/// A scene to change and run: `scene["M0"] = 1.0` sets a scene or model
/// parameter, `scene.effects["motor"].amplitude = 1.0` a number of an
/// effect (as `--set motor.amplitude=1.0` would), each checked at once
/// with the command line's message; `scene.run(...)` runs it.
#[pyclass(module = "ezy", name = "Scene")]
pub struct PyScene {
    /// The module's application, which runs it.
    pub(crate) kit: Py<Toolkit>,
    /// The scene as loaded and checked.
    pub(crate) src: SceneSource,
    /// Its model's names and parameters.
    pub(crate) info: ModelInfo,
    /// The changes made so far, in order.
    pub(crate) sets: Vec<(String, f64)>,
    /// How the scene was named (its name, or the path it was read from).
    pub(crate) reference: String,
    /// The model it runs on, when it was made on an `ezy.Model`.
    pub(crate) model: Option<Py<PyModel>>,
    /// Its TOML text, when it was made in Python (no file of its own): the
    /// commands that read a scene file get it in a temporary one.
    pub(crate) toml: Option<String>,
}

impl PyScene {
    /// The module's application, with the scene's own model where it has
    /// one.
    pub(crate) fn app(&self) -> ezy::App {
        let app = self.kit.get().app.clone();
        match &self.model {
            Some(m) => app.with_model_as(&self.src.scene.model, m.get().model.clone()),
            None => app,
        }
    }

    /// The scene with every set applied.
    fn applied(&self) -> PyResult<ezy_scene::Scene> {
        let mut s = self.src.scene.clone();
        for (n, v) in &self.sets {
            s.set(&self.info, n, *v).map_err(ezy_err)?;
        }
        Ok(s)
    }

    /// Sets `name` (as `--set NAME=VALUE`), checked on the scene with
    /// every set applied before it is kept.
    fn set_value(&mut self, name: &str, value: f64) -> PyResult<()> {
        let mut trial = self.applied()?;
        trial.set(&self.info, name, value).map_err(ezy_err)?;
        // an effect kind of the user's own reads its fields when the run
        // is set up: checked now, as the command line's run would
        let app = &self.app();
        if let Some(Ok(info)) = app.info_with(&trial.model, &trial.params) {
            let refused = |e: ezy_scene::SceneError| {
                ezy_err(ezy_core::SimError::Setup(ezy_core::SetupError::Scene { key: e.key(), message: e.message }))
            };
            let checked = trial.clone().checked(&info).map_err(|e| refused(e.into_iter().next().expect("an error")))?;
            app.check_user_effects(&trial.model, &checked).map_err(refused)?;
        }
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
    /// the bad value; TypeError naming it for a value that is not a number
    /// (`True` included).
    fn __setitem__(&mut self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        self.set_value(name, real(&format!("scene[{name:?}]"), value)?)
    }

    /// Takes back what `scene[name] = value` (or `set`) gave: the number
    /// is the scene file's again.
    ///
    /// Raises KeyError when `name` was not set on this scene (listing
    /// what was).
    fn __delitem__(&mut self, name: &str) -> PyResult<()> {
        if !self.sets.iter().any(|(n, _)| n == name) {
            let set: Vec<&str> = self.sets.iter().map(|(n, _)| n.as_str()).collect();
            let set = if set.is_empty() { "nothing".to_string() } else { set.join(", ") };
            return Err(PyKeyError::new_err(format!(
                "`{name}` was not set on scene {}; set on it: {set}",
                self.src.scene.name
            )));
        }
        self.sets.retain(|(n, _)| n != name);
        Ok(())
    }

    /// Sets a scene parameter, a model parameter or `EFFECT.KEY`, and
    /// returns the scene (to chain).
    fn set<'py>(slf: Bound<'py, Self>, name: &str, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, Self>> {
        let value = real(&format!("set(): `{name}`"), value)?;
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

    fn __setattr__(&self, py: Python<'_>, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let name = format!("{}.{key}", self.item);
        let value = real(&format!("`{name}`"), value)?;
        self.scene.bind(py).borrow_mut().set_value(&name, value)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("<ezy.Effect {}: {}>", self.item, self.numbers(py)?.repr()?))
    }
}
