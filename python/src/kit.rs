//! The application behind a module, [`Toolkit`] (the `#[pyclass]`; the
//! functions the module offers are its methods in `toolkit`), and the
//! command line it runs with the GIL released ([`Toolkit::cli`]): what
//! every other file of the module builds on.

use std::time::Duration;

use ezy::App;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::reports::Equations;
use crate::settings::sets_of;
use crate::words::Said;
use crate::{EzyError, ezy_err};

/// The application behind a module: its models, effect kinds and scenes.
#[pyclass(module = "ezy", frozen)]
pub struct Toolkit {
    pub(crate) app: App,
    pub(crate) helpers: Py<PyModule>,
}

impl Toolkit {
    /// Runs the command line `args` (after the program name) with the GIL
    /// released; Ctrl-C asks the command to stop ([`ezy::output::transaction::request_stop`])
    /// and raises `KeyboardInterrupt` once it has. Returns what it printed,
    /// or that and its error's message, as `said` says them to Python
    /// (keywords for flags, no file that is gone: [`Said`]).
    pub(crate) fn cli(
        py: Python<'_>,
        app: &App,
        args: Vec<String>,
        said: &Said<'_>,
    ) -> PyResult<Result<String, (String, String)>> {
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
        let out = out.map_err(|_| EzyError::new_err("the command panicked"))?;
        Ok(out.map(|text| said.report(&text)).map_err(|(text, e)| (said.report(&text), said.text(&e.to_string()))))
    }
}

/// `ezy.equations` of `model` in `app`.
pub(crate) fn equations_in(
    py: Python<'_>,
    app: &App,
    model: &str,
    set: Option<&Bound<'_, PyDict>>,
) -> PyResult<Equations> {
    let sets = sets_of(set)?;
    let mut args = vec!["equations".to_string(), model.to_string()];
    for (n, v) in &sets {
        args.extend(["--set".into(), format!("{n}={v:?}")]);
    }
    let said = Said::plain("equations");
    let text = Toolkit::cli(py, app, args.clone(), &said)?.map_err(|(_, e)| ezy_err(e))?;
    args.extend(["--format".into(), "latex".into()]);
    let latex = Toolkit::cli(py, app, args, &said)?.map_err(|(_, e)| ezy_err(e))?;
    Ok(Equations { text, latex })
}
