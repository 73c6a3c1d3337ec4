//! The module's calls through the command line: [`Toolkit::command`]
//! runs a command on a scene, [`Toolkit::cli`] any command line, with the
//! GIL released and Ctrl-C asking the command to stop; and a quantity of
//! the caller's own Python code for `optimize`.

use std::path::PathBuf;
use std::time::Duration;

use ezy::App;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::model::PyModel;
use crate::settings::Overrides;
use crate::toolkit::Toolkit;
use crate::{EzyError, ezy_err};
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
        let dir = out.unwrap_or_else(|| temp.path().join(name));
        let mut args = vec![name.to_string(), r.cli_scene(temp.path())?];
        args.extend(extra);
        args.extend(opts.to_args());
        args.extend(["--out".into(), dir.display().to_string()]);
        if !figures {
            args.push("--no-figures".into());
        }
        match Self::cli(py, &app, args)? {
            Ok(report) => Ok((report, dir, temp)),
            Err((_, e)) => Err(ezy_err(e)),
        }
    }

    /// Runs the command line `args` (after the program name) with the GIL
    /// released; Ctrl-C asks the command to stop ([`ezy::output::transaction::request_stop`])
    /// and raises `KeyboardInterrupt` once it has. Returns what it printed.
    pub(crate) fn cli(
        py: Python<'_>,
        app: &App,
        args: Vec<String>,
    ) -> PyResult<Result<String, (String, ezy::app::AppError)>> {
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
                        ezy::output::transaction::request_stop();
                    }
                }
                worker.join()
            })
        });
        ezy::output::transaction::clear_stop();
        if let Some(e) = interrupt {
            return Err(e);
        }
        out.map_err(|_| EzyError::new_err("the command panicked"))
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
