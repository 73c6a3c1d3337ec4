//! The module's commands on a scene: the scene a call names
//! ([`Toolkit::resolve`]); [`Toolkit::command`] runs one (with
//! the scene's sets, the run keywords and a temporary directory) through
//! [`Toolkit::cli`]; and a quantity of the caller's own Python code for
//! `optimize`.

use std::path::PathBuf;

use ezy::App;
use ezy_scene::registry::SceneSource;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::ezy_err;
use crate::kit::Toolkit;
use crate::model::PyModel;
use crate::scene::PyScene;
use crate::settings::Overrides;
use crate::words::Said;

impl Toolkit {
    /// Runs the command `name` on `scene` (with `model`, the scene's sets,
    /// `extra` flags and the run keywords `settings`) into `out` (or a
    /// temporary directory, returned to keep it while its files are
    /// read): what it printed and the directory.
    #[expect(clippy::too_many_arguments, reason = "the keywords every command takes")]
    pub(crate) fn command(
        &self,
        py: Python<'_>,
        name: &str,
        scene: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        extra: Vec<String>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<(String, PathBuf, tempfile::TempDir)> {
        self.command_on(py, name, scene, model, extra, out, figures, settings, &|app| app)
    }

    /// [`Toolkit::command`] on the application `adjust` makes of the
    /// scene's (one with a quantity of the caller's own).
    #[expect(clippy::too_many_arguments, reason = "the keywords every command takes")]
    pub(crate) fn command_on(
        &self,
        py: Python<'_>,
        name: &str,
        scene: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        extra: Vec<String>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
        adjust: &dyn Fn(App) -> App,
    ) -> PyResult<(String, PathBuf, tempfile::TempDir)> {
        let (app, r) = self.resolve_on(scene, model)?;
        let app = adjust(app);
        let opts = Overrides::new(r.sets.clone(), settings, name)?.options()?;
        let temp = tempfile::Builder::new().prefix("ezy-").tempdir().map_err(ezy_err)?;
        let kept = out.is_some();
        let dir = out.unwrap_or_else(|| temp.path().join(name));
        let scene = r.cli_scene(temp.path())?;
        let said = Said {
            function: name,
            temp: Some(temp.path()).filter(|_| !kept),
            scene: r.toml.is_some().then(|| (scene.clone(), r.reference.clone())),
            report: true,
        };
        let mut args = vec![name.to_string(), scene];
        args.extend(extra);
        args.extend(opts.to_args());
        args.extend(["--out".into(), dir.display().to_string()]);
        if !figures {
            args.push("--no-figures".into());
        }
        match Self::cli(py, &app, args, &said)? {
            Ok(report) => Ok((report, dir, temp)),
            Err((_, e)) => Err(ezy_err(e)),
        }
    }
}

/// A quantity of the caller's Python code: `function(run)` with the run
/// (state and sensitivities) as a DataFrame, returning `(value,
/// gradient)`; its exceptions become the evaluation's failure.
pub(crate) fn python_quantity(
    function: Py<PyAny>,
    helpers: Py<PyModule>,
) -> impl Fn(&ezy_core::sensitivity::Sensitivities) -> Result<(f64, Vec<f64>), String> + Send + Sync + 'static {
    move |s| {
        Python::attach(|py| {
            let columns = PyDict::new(py);
            let fail = |e: PyErr| e.to_string();
            columns.set_item("t", s.t.clone()).map_err(fail)?;
            for (i, name) in s.names.iter().enumerate() {
                columns.set_item(name, s.x.iter().map(|r| r[i]).collect::<Vec<f64>>()).map_err(fail)?;
            }
            for (k, name) in s.columns().iter().enumerate() {
                columns.set_item(name, s.s.iter().map(|r| r[k]).collect::<Vec<f64>>()).map_err(fail)?;
            }
            let frame = helpers.bind(py).call_method1("frame", (columns, s.parameters.clone())).map_err(fail)?;
            let r = function.bind(py).call1((frame,)).map_err(fail)?;
            r.extract::<(f64, Vec<f64>)>().map_err(|_| {
                format!(
                    "the function returned {}; return (value, [d value / d param for {}])",
                    r.repr().map_or("something else".into(), |t| t.to_string()),
                    s.parameters.join(", ")
                )
            })
        })
    }
}

/// The scene a call names, with the changes a `Scene` object carries.
pub(crate) struct Resolved {
    /// The scene as loaded and checked.
    pub(crate) src: SceneSource,
    /// A `Scene` object's sets (none for a name or a path).
    pub(crate) sets: Vec<(String, f64)>,
    /// How it was named: a known scene's name or a file's path.
    pub(crate) reference: String,
    /// A `Scene` object's own model (one made on an `ezy.Model`).
    pub(crate) model: Option<Py<PyModel>>,
    /// A `Scene` object's TOML text, when it was made in Python.
    pub(crate) toml: Option<String>,
}

impl Resolved {
    /// The scene as the command line names it: its name or path, or, for a
    /// scene made in Python, a file in `dir` holding its text.
    pub(crate) fn cli_scene(&self, dir: &std::path::Path) -> PyResult<String> {
        let Some(text) = &self.toml else { return Ok(self.reference.clone()) };
        let path = dir.join(format!("{}.toml", self.src.scene.name.replace(['/', '\\'], "_")));
        std::fs::write(&path, text).map_err(ezy_err)?;
        Ok(path.display().to_string())
    }
}

impl Toolkit {
    /// The scene `scene` names (a known name or a path), or a `Scene`
    /// object's, with the object's own sets.
    pub(crate) fn resolve(&self, scene: &Bound<'_, PyAny>) -> PyResult<Resolved> {
        if let Ok(s) = scene.cast::<PyScene>() {
            let s = s.borrow();
            return Ok(Resolved {
                src: s.src.clone(),
                sets: s.sets.clone(),
                reference: s.reference.clone(),
                model: s.model.as_ref().map(|m| m.clone_ref(scene.py())),
                toml: s.toml.clone(),
            });
        }
        let name: String = scene.extract().map_err(|_| {
            PyValueError::new_err("scene: give a scene's name, a path to a .toml file, or an ezy.Scene")
        })?;
        let src = self.app.load_scene(&name).map_err(ezy_err)?;
        Ok(Resolved { src, sets: Vec::new(), reference: name, model: None, toml: None })
    }
}
