//! The module's planning functions behind [`Toolkit`]'s `plan` and
//! `gait_optimize` (`ezy plan` and `ezy gait-optimize`), and the call on
//! a target that is a scene or a model (`geometry` and `gait_optimize`).

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use ezy::App;
use ezy_core::plan::{Objective, PathConstraint, SampleGradient, Samples, UserValue};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::command::python_quantity;
use crate::ezy_err;
use crate::kit::Toolkit;
use crate::model::PyModel;
use crate::settings::{Overrides, names_kw, number_kw, over_args, sets_of, text_kw, whole_kw};
use crate::words::Said;

/// A keyword's value, absent or any Python object.
type Kw<'a, 'py> = Option<&'a Bound<'py, PyAny>>;

/// A keyword's dict, absent or given.
type KwDict<'a, 'py> = Option<&'a Bound<'py, PyDict>>;

/// `{name: value}` as `--flag NAME=VALUE,..` (nothing for an empty dict).
fn pairs_arg(flag: &str, d: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let pairs = sets_of(d)?;
    if pairs.is_empty() {
        return Ok(Vec::new());
    }
    Ok(vec![flag.to_string(), pairs.iter().map(|(k, v)| format!("{k}={v:?}")).collect::<Vec<_>>().join(",")])
}

/// `{name: (lo, hi)}` as `--flag NAME=LO:HI` per entry.
fn ranges_arg(function: &str, flag: &str, d: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let Some(d) = d else { return Ok(Vec::new()) };
    let over = over_args(function, flag.trim_start_matches("--"), d)?;
    Ok(over.chunks_exact(2).flat_map(|pair| [flag.to_string(), pair[1].clone()]).collect())
}

/// The first exception a Python objective raised during a plan, raised
/// again when the command returns.
type Raised = Arc<Mutex<Option<PyErr>>>;

/// A gradient block `what` (`q`, `qd`, `u`) of a Python objective's
/// return as rows (`None`: zeros shaped as `like`).
fn rows_of(py: Python<'_>, what: &str, g: Option<Bound<'_, PyAny>>, like: &[Vec<f64>]) -> PyResult<Vec<Vec<f64>>> {
    let Some(g) = g.filter(|g| !g.is_none()) else { return Ok(like.iter().map(|r| vec![0.0; r.len()]).collect()) };
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (g, "float64")).map_err(|e| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "the objective's gradient `{what}`: not an array of numbers ({e})"
        ))
    })?;
    if a.getattr("ndim")?.extract::<usize>()? != 2 {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "the objective's gradient `{what}` has shape {}: give ({}, {})",
            a.getattr("shape")?.repr()?,
            like.len(),
            like.first().map_or(0, Vec::len)
        )));
    }
    a.call_method0("tolist")?.extract()
}

/// A Python objective's return: a number, or `(value, gradients)` with
/// the gradients `None`, a dict with `q`, `qd`, `u` (one left out: zeros)
/// or a tuple of the three.
fn user_value(py: Python<'_>, r: &Bound<'_, PyAny>, s: &Samples) -> PyResult<UserValue> {
    if let Ok(value) = r.extract::<f64>() {
        return Ok(UserValue { value, gradient: None });
    }
    let wrong = || {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "the objective returned {}: return a number, or (value, gradients) with gradients a dict {{'q': .., 'qd': .., 'u': ..}} or a tuple (q, qd, u) of arrays shaped as the samples",
            r.repr().map_or("something else".into(), |t| t.to_string())
        ))
    };
    let pair = r.cast::<PyTuple>().map_err(|_| wrong())?;
    if pair.len() != 2 {
        return Err(wrong());
    }
    let value = pair.get_item(0)?.extract::<f64>().map_err(|_| wrong())?;
    let g = pair.get_item(1)?;
    if g.is_none() {
        return Ok(UserValue { value, gradient: None });
    }
    let (q, qd, u) = if let Ok(d) = g.cast::<PyDict>() {
        if let Some(k) =
            d.keys().iter().find(|k| k.extract::<String>().is_ok_and(|k| !["q", "qd", "u"].contains(&k.as_str())))
        {
            return Err(pyo3::exceptions::PyKeyError::new_err(format!(
                "the objective's gradients: unknown key {}: give q, qd and u",
                k.repr()?
            )));
        }
        (d.get_item("q")?, d.get_item("qd")?, d.get_item("u")?)
    } else if let Ok(t) = g.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>, Bound<'_, PyAny>)>() {
        (Some(t.0), Some(t.1), Some(t.2))
    } else {
        return Err(wrong());
    };
    let gradient = SampleGradient {
        q: rows_of(py, "q", q, &s.q)?,
        qd: rows_of(py, "qd", qd, &s.qd)?,
        u: rows_of(py, "u", u, &s.u)?,
    };
    Ok(UserValue { value, gradient: Some(gradient) })
}

/// `function(t, q, qd, u)` of the caller's Python code as a plan's
/// objective term (numpy arrays: `t` (N + 1,), `q` and `qd` (N + 1, nq),
/// `u` (N + 1, inputs)), called holding the GIL; its first exception is
/// kept in `raised` and the plan fails naming it.
fn python_objective(
    function: Py<PyAny>,
    raised: Raised,
) -> impl Fn(&Samples) -> Result<UserValue, String> + Send + Sync {
    move |s| {
        Python::attach(|py| {
            let call = || -> PyResult<UserValue> {
                let t = PyArray1::from_vec(py, s.t.clone());
                let array = |rows: &[Vec<f64>]| {
                    PyArray2::from_vec2(py, rows).map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
                };
                let r = function.bind(py).call1((t, array(&s.q)?, array(&s.qd)?, array(&s.u)?))?;
                user_value(py, &r, s)
            };
            call().map_err(|e| {
                let text = e.to_string();
                let mut slot = raised.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                if slot.is_none() {
                    *slot = Some(e);
                }
                format!("it raised {text}")
            })
        })
    }
}

/// `plan(path=...)`: a bound as text (`"x1d<=0.6"`, the command line's
/// `--path`), a tuple `(f, lo, hi)` of a function of the caller's own
/// `f(t, q, qd, u)` of one node's sample (arrays of one row; `lo` or
/// `hi` None for no bound), or a list of them.
///
/// # Errors
/// TypeError for anything else.
fn path_kw(path: Kw<'_, '_>, raised: &Raised) -> PyResult<(Vec<String>, Vec<PathConstraint>)> {
    let wrong = || {
        pyo3::exceptions::PyTypeError::new_err(
            "plan(path=...): give a bound as text (\"x1d<=0.6\"), a tuple (f, lo, hi) of a function f(t, q, qd, u) of one node's sample and its bounds (None for none), or a list of them",
        )
    };
    let Some(path) = path.filter(|p| !p.is_none()) else { return Ok((Vec::new(), Vec::new())) };
    let items: Vec<Bound<'_, PyAny>> = if path.extract::<String>().is_ok()
        || path.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>, Bound<'_, PyAny>)>().is_ok_and(|t| t.0.is_callable())
    {
        vec![path.clone()]
    } else {
        path.try_iter().map_err(|_| wrong())?.collect::<PyResult<_>>()?
    };
    let (mut texts, mut own) = (Vec::new(), Vec::new());
    for item in items {
        if let Ok(t) = item.extract::<String>() {
            texts.push(t);
            continue;
        }
        let (f, lo, hi) = item.extract::<(Bound<'_, PyAny>, Option<f64>, Option<f64>)>().map_err(|_| wrong())?;
        if !f.is_callable() {
            return Err(wrong());
        }
        let name = f.getattr("__name__").and_then(|n| n.extract::<String>()).unwrap_or("path".into());
        let g = python_objective(f.clone().unbind(), Arc::clone(raised));
        own.push(PathConstraint::function(name, lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY), g));
    }
    Ok((texts, own))
}

impl Toolkit {
    /// The command `name` on `target`: a scene (a name, a path, a
    /// `Scene`) through the run keywords' path, or a model (an
    /// `ezy.Model`, or a key no scene has) straight to the command line
    /// (`settings` then only for a command that takes run settings).
    #[expect(clippy::too_many_arguments, reason = "the keywords every command takes")]
    pub(crate) fn on_target(
        &self,
        py: Python<'_>,
        name: &'static str,
        target: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        extra: Vec<String>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<(String, PathBuf, tempfile::TempDir)> {
        let own = target.cast::<PyModel>().ok();
        let key = match (&own, target.extract::<String>()) {
            (Some(m), _) => Some(m.get().key.clone()),
            (None, Ok(key)) if self.resolve(target).is_err() => Some(key),
            _ => None,
        };
        let Some(key) = key else { return self.command(py, name, target, model, extra, out, figures, settings) };
        let app = self.app_with(&key, own.or(model));
        let temp = tempfile::Builder::new().prefix("ezy-").tempdir().map_err(ezy_err)?;
        let kept = out.is_some();
        let dir = out.unwrap_or_else(|| temp.path().join(name));
        let said = Said { function: name, temp: Some(temp.path()).filter(|_| !kept), scene: None, report: true };
        let mut args = vec![name.to_string(), key];
        args.extend(extra);
        args.extend(Overrides::new(Vec::new(), settings, name)?.options()?.to_args());
        args.extend(["--out".into(), dir.display().to_string()]);
        if !figures {
            args.push("--no-figures".into());
        }
        let report = Self::cli(py, &app, args, &said)?.map_err(|(_, e)| ezy_err(e))?;
        Ok((report, dir, temp))
    }

    /// `optimize(...)`: see the method's docstring in `toolkit.rs`.
    pub(crate) fn optimize_on(
        &self,
        py: Python<'_>,
        (scene, over): (&Bound<'_, PyAny>, &Bound<'_, PyDict>),
        (maximize, minimize, subject_to): (Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
        (max_evaluations, grid): (Kw<'_, '_>, Kw<'_, '_>),
        (gait, period, harmonics, range): (Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>, KwDict<'_, '_>),
        (model, out, figures, settings): (Option<&Bound<'_, PyModel>>, Option<PathBuf>, bool, KwDict<'_, '_>),
    ) -> PyResult<Py<PyAny>> {
        let type_error = |m: String| pyo3::exceptions::PyTypeError::new_err(m);
        // a function of the caller's own: named by its __name__
        let mut own: Option<(String, Py<PyAny>)> = None;
        let mut text = |key: &str, v: Option<&Bound<'_, PyAny>>| -> PyResult<Option<String>> {
            match v {
                Some(f) if f.is_callable() => {
                    let name = f.getattr("__name__").and_then(|n| n.extract::<String>()).unwrap_or("objective".into());
                    own = Some((name.clone(), f.clone().unbind()));
                    Ok(Some(name))
                }
                v => text_kw("optimize", key, v),
            }
        };
        let goal = match (text("maximize", maximize)?, text("minimize", minimize)?) {
            (Some(q), None) => ["--maximize".to_string(), q],
            (None, Some(q)) => ["--minimize".to_string(), q],
            _ => return Err(type_error("optimize(): give one of `maximize` and `minimize`".into())),
        };
        let mut extra = goal.to_vec();
        extra.extend(over_args("optimize", "over", over)?);
        if let Some(g) = text_kw("optimize", "gait", gait)? {
            extra.extend(["--gait".to_string(), g]);
        }
        if let Some(p) = number_kw("optimize", "period", period)? {
            extra.extend(["--period".to_string(), p.to_string()]);
        }
        if let Some(n) = whole_kw("optimize", "harmonics", harmonics)? {
            extra.extend(["--harmonics".to_string(), n.to_string()]);
        }
        extra.extend(ranges_arg("optimize", "--range", range)?);
        if let Some(list) = subject_to {
            let list: Vec<String> = if let Ok(one) = list.extract::<String>() {
                vec![one]
            } else {
                list.extract().map_err(|_| {
                    type_error("optimize(): `subject_to` must be a constraint's text or a list of them".into())
                })?
            };
            for c in list {
                extra.extend(["--subject-to".to_string(), c]);
            }
        }
        if let Some(n) = whole_kw("optimize", "max_evaluations", max_evaluations)? {
            extra.extend(["--max-evaluations".to_string(), n.to_string()]);
        }
        if let Some(n) = whole_kw("optimize", "grid", grid)? {
            extra.extend(["--grid".to_string(), n.to_string()]);
        }
        let helpers = self.helpers.clone_ref(py);
        let adjust = |app: App| match &own {
            Some((name, f)) => app.quantity(name, python_quantity(f.clone_ref(py), helpers.clone_ref(py))),
            None => app,
        };
        let (report, dir, _temp) =
            self.command_on(py, "optimize", scene, model, extra, out, figures, settings, &adjust)?;
        let helpers = self.helpers.bind(py);
        let frame = helpers.call_method1("read_table", (dir.join("optimum.csv"),))?;
        crate::quantities::annotate(py, &frame, "optimum.csv")?;
        let history = helpers.call_method1("read_table", (dir.join("history.csv"), "evaluation"))?;
        crate::quantities::annotate(py, &history, "history.csv")?;
        frame.getattr("attrs")?.set_item("history", history)?;
        // the grid's evaluations (a search started from the best of a grid)
        let grid = dir.join("grid.csv");
        if grid.is_file() {
            let grid = helpers.call_method1("read_table", (grid,))?;
            crate::quantities::annotate(py, &grid, "grid.csv")?;
            frame.getattr("attrs")?.set_item("grid", grid)?;
        }
        frame.getattr("attrs")?.set_item("report", report)?;
        Ok(frame.unbind())
    }

    /// `plan(...)`: see the method's docstring in `toolkit.rs`.
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    pub(crate) fn plan_on(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        input: &Bound<'_, PyAny>,
        (bound, to, at_rest): (KwDict<'_, '_>, KwDict<'_, '_>, bool),
        (segments, evaluations, intervals, guess): (Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
        (objective, effort_weight, path): (Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
        (minimize, time_weight, free_time): (Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: KwDict<'_, '_>,
    ) -> PyResult<Py<PyAny>> {
        let inputs = names_kw("plan", "input", Some(input))?.unwrap_or_default();
        let mut extra = Vec::new();
        for i in inputs.split(',').filter(|i| !i.is_empty()) {
            extra.extend(["--input".to_string(), i.to_string()]);
        }
        extra.extend(ranges_arg("plan", "--bound", bound)?);
        extra.extend(pairs_arg("--to", to)?);
        if at_rest {
            extra.push("--at-rest".into());
        }
        if let Some(n) = whole_kw("plan", "segments", segments)? {
            extra.extend(["--segments".to_string(), n.to_string()]);
        }
        if let Some(n) = whole_kw("plan", "evaluations", evaluations)? {
            extra.extend(["--evaluations".to_string(), n.to_string()]);
        }
        if let Some(n) = whole_kw("plan", "intervals", intervals)? {
            extra.extend(["--intervals".to_string(), n.to_string()]);
        }
        // a DataFrame is written where the command line reads it; the
        // file lives until the call returns
        let mut _guess_file = None;
        if let Some(g) = guess.filter(|g| !g.is_none()) {
            let path = if g.hasattr("to_csv")? {
                let file = tempfile::Builder::new().suffix(".csv").tempfile().map_err(|e| ezy_err(e.to_string()))?;
                let kw = PyDict::new(py);
                kw.set_item("index", false)?;
                g.call_method("to_csv", (file.path(),), Some(&kw))?;
                let path = file.path().to_path_buf();
                _guess_file = Some(file);
                path
            } else {
                g.extract::<PathBuf>().map_err(|_| {
                    pyo3::exceptions::PyTypeError::new_err(
                        "plan(guess=...): give a CSV file's path or a DataFrame with a column `t` and one per input",
                    )
                })?
            };
            extra.extend(["--guess".to_string(), path.display().to_string()]);
        }
        let raised: Raised = Arc::new(Mutex::new(None));
        let (texts, own_path) = path_kw(path, &raised)?;
        for t in texts {
            extra.extend(["--path".to_string(), t]);
        }
        let own = match objective.filter(|f| !f.is_none()) {
            Some(f) if !f.is_callable() => {
                return Err(pyo3::exceptions::PyTypeError::new_err(
                    "plan(): `objective` must be a function f(t, q, qd, u) returning a number or (value, gradients)",
                ));
            }
            Some(f) => {
                let name = f.getattr("__name__").and_then(|n| n.extract::<String>()).unwrap_or("objective".into());
                Some(Objective::user(name, python_objective(f.clone().unbind(), Arc::clone(&raised))))
            }
            None => None,
        };
        let weight = number_kw("plan", "effort_weight", effort_weight)?;
        let time_weight = number_kw("plan", "time_weight", time_weight)?;
        if let Some(m) = text_kw("plan", "minimize", minimize)? {
            extra.extend(["--minimize".to_string(), m]);
        }
        if let Some(range) = free_time.filter(|f| !f.is_none()) {
            let (lo, hi) = range.extract::<(f64, f64)>().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err(format!(
                    "plan(): `free_time` must be a pair of numbers (lo, hi) [s], not {range}"
                ))
            })?;
            extra.extend(["--free-time".to_string(), format!("{lo:?}:{hi:?}")]);
        }
        let goal = match (own, weight) {
            (Some(o), w) => Some(o.effort_weight(w.unwrap_or(1.0)).time_weight(time_weight.unwrap_or(0.0))),
            (None, w) => {
                if let Some(tw) = time_weight {
                    extra.extend(["--time-weight".to_string(), format!("{tw:?}")]);
                }
                w.map(|w| Objective::effort().effort_weight(w))
            }
        };
        let adjust = |app: App| {
            let app = match &goal {
                Some(o) => app.plan_objective(o.clone()),
                None => app,
            };
            own_path.iter().fold(app, |app, p| app.plan_path(p.clone()))
        };
        let done = self.command_on(py, "plan", scene, model, extra, out, figures, settings, &adjust);
        // the objective's own exception, as it was raised
        if let Some(e) = raised.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take() {
            return Err(e);
        }
        let (report, dir, _temp) = done?;
        let helpers = self.helpers.bind(py);
        let frame = helpers.call_method1("read_table", (dir.join("plan.csv"),))?;
        crate::quantities::annotate(py, &frame, "plan.csv")?;
        let summary = helpers.call_method1("read_table", (dir.join("plan_summary.csv"),))?;
        crate::quantities::annotate(py, &summary, "plan_summary.csv")?;
        frame.getattr("attrs")?.set_item("summary", summary)?;
        frame.getattr("attrs")?.set_item("report", report)?;
        Ok(frame.unbind())
    }

    /// `gait_optimize(...)`: see the method's docstring in `toolkit.rs`.
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    pub(crate) fn gait_optimize_on(
        &self,
        py: Python<'_>,
        target: &Bound<'_, PyAny>,
        gait: &Bound<'_, PyAny>,
        (maximize, minimize): (Kw<'_, '_>, Kw<'_, '_>),
        (per_length, order, harmonics, centre_only): (bool, Kw<'_, '_>, Kw<'_, '_>, bool),
        (range, margin, budget, metric): (KwDict<'_, '_>, Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
        (max_evaluations, body, set): (Kw<'_, '_>, Kw<'_, '_>, KwDict<'_, '_>),
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
    ) -> PyResult<Py<PyAny>> {
        let f = "gait_optimize";
        let mut extra = vec!["--gait".to_string(), text_kw(f, "gait", Some(gait))?.unwrap_or_default()];
        match (text_kw(f, "maximize", maximize)?, text_kw(f, "minimize", minimize)?) {
            (Some(w), None) => extra.extend(["--maximize".to_string(), w]),
            (None, Some(w)) => extra.extend(["--minimize".to_string(), w]),
            _ => {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "{f}(): give one of `maximize` and `minimize` (dx, dy, dtheta or along(UX,UY))"
                )));
            }
        }
        if per_length {
            extra.push("--per-length".into());
        }
        if let Some(o) = text_kw(f, "order", order)? {
            extra.extend(["--order".to_string(), o]);
        }
        if let Some(n) = whole_kw(f, "harmonics", harmonics)? {
            extra.extend(["--harmonics".to_string(), n.to_string()]);
        }
        if centre_only {
            extra.push("--centre-only".into());
        }
        extra.extend(ranges_arg(f, "--range", range)?);
        if let Some(m) = number_kw(f, "margin", margin)? {
            extra.push(format!("--margin={m:?}"));
        }
        if let Some(b) = number_kw(f, "budget", budget)? {
            extra.push(format!("--budget={b:?}"));
        }
        if let Some(m) = metric.filter(|m| !m.is_none()) {
            // a matrix (a list of rows, a 2-D array) or its entries row by row
            let flat = m.call_method0("__iter__").is_ok().then(|| -> PyResult<Vec<f64>> {
                let numpy = m.py().import("numpy")?;
                let a = numpy.call_method1("asarray", (m,))?.call_method1("astype", ("float64",))?;
                a.call_method0("ravel")?.call_method0("tolist")?.extract()
            });
            let entries = match flat {
                Some(Ok(v)) => v,
                _ => {
                    return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                        "{f}(): `metric` must be a square matrix of numbers (a list of rows or a 2-D array), not {m}"
                    )));
                }
            };
            let text: Vec<String> = entries.iter().map(|v| format!("{v:?}")).collect();
            extra.push(format!("--metric={}", text.join(",")));
        }
        if let Some(n) = whole_kw(f, "max_evaluations", max_evaluations)? {
            extra.extend(["--max-evaluations".to_string(), n.to_string()]);
        }
        if let Some(b) = text_kw(f, "body", body)? {
            extra.extend(["--body".to_string(), b]);
        }
        for (k, v) in sets_of(set)? {
            extra.push(format!("--set={k}={v:?}"));
        }
        let (report, dir, _temp) = self.on_target(py, "gait-optimize", target, model, extra, out, figures, None)?;
        let helpers = self.helpers.bind(py);
        let frame = helpers.call_method1("read_table", (dir.join("gait_optimum.csv"),))?;
        crate::quantities::annotate(py, &frame, "gait_optimum.csv")?;
        let history = helpers.call_method1("read_table", (dir.join("gait_history.csv"),))?;
        crate::quantities::annotate(py, &history, "gait_history.csv")?;
        frame.getattr("attrs")?.set_item("history", history)?;
        frame.getattr("attrs")?.set_item("report", report)?;
        Ok(frame.unbind())
    }
}
