//! The module's planning functions behind [`Toolkit`]'s `plan` and
//! `gait_optimize` (`ezy plan` and `ezy gait-optimize`), and the call on
//! a target that is a scene or a model (`geometry` and `gait_optimize`).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

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

    /// `plan(...)`: see the method's docstring in `toolkit.rs`.
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    pub(crate) fn plan_on(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        input: &Bound<'_, PyAny>,
        (bound, to, at_rest): (KwDict<'_, '_>, KwDict<'_, '_>, bool),
        (segments, evaluations, intervals, guess): (Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
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
        let (report, dir, _temp) = self.command(py, "plan", scene, model, extra, out, figures, settings)?;
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
        (range, margin, budget): (KwDict<'_, '_>, Kw<'_, '_>, Kw<'_, '_>),
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
