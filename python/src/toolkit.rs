//! The module's functions: [`Toolkit`], the application behind a module,
//! whose methods `models`, `scenes`, `effect_kinds`, `scene`, `run`,
//! `sweep`, `analyze`, `sensitivity`, `fit`, `optimize`, `plan`, `gait_optimize`, `linearize`, `geometry`, `equations` and `check` the module
//! offers as functions; a run in memory with the
//! GIL released and Python's signals polled, a command line run the same
//! way (Ctrl-C stops either and raises `KeyboardInterrupt`).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use ezy::App;
use ezy_core::ModelInfo;
use ezy_scene::registry::ModelCatalog as _;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::command::Resolved;
use crate::ezy_err;
use crate::kit::{Toolkit, equations_in};
use crate::model::PyModel;
use crate::reports::{Analysis, Check, Equations, Geometry, Linearization};
use crate::result::RunResult;
use crate::scene::PyScene;
use crate::settings::{Overrides, names_kw, number_kw, over_args, sets_of, text_kw, whole_kw};
use crate::words::Said;

/// How often a running integration asks Python for pending signals (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

impl Toolkit {
    fn info(&self, model: &str, params: &[(String, f64)]) -> PyResult<ModelInfo> {
        info_in(&self.app, model, params)
    }

    /// [`Toolkit::resolve`] for a run on `model` (an `ezy.Model`, if
    /// given) in place of the scene's own model: the application that has
    /// it under the scene's model key, and the scene checked against it
    /// (a scene file whose model this module does not know is read and
    /// checked against `model` alone).
    pub(crate) fn resolve_on(
        &self,
        scene: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
    ) -> PyResult<(App, Resolved)> {
        let r = match self.resolve(scene) {
            Ok(r) => r,
            Err(e) => {
                // a file naming a model this module does not know
                let Some(m) = model else { return Err(e) };
                let Ok(name) = scene.extract::<String>() else { return Err(e) };
                let path = std::path::Path::new(&name);
                if !path.is_file() {
                    return Err(e);
                }
                let (scene, text) = ezy_scene::Scene::read(path).map_err(ezy_err)?;
                let app = self.app_with(&scene.model, Some(m));
                let src = ezy_scene::registry::check_scene(&app, scene, &text, &name).map_err(ezy_err)?;
                return Ok((app, Resolved { src, sets: Vec::new(), reference: name, model: None, toml: None }));
            }
        };
        // the call's model, else the scene's own
        let own = r.model.as_ref().map(|m| m.bind(scene.py()).clone());
        let Some(m) = model.or(own.as_ref()) else { return Ok((self.app.clone(), r)) };
        let app = self.app_with(&r.src.scene.model, Some(m));
        let src = ezy_scene::registry::check_scene(&app, r.src.scene, &r.src.text, &r.src.file).map_err(ezy_err)?;
        Ok((app, Resolved { src, ..r }))
    }

    /// This toolkit's application with `model` (an `ezy.Model`, if given)
    /// in place of the model `key` names.
    pub(crate) fn app_with(&self, key: &str, model: Option<&Bound<'_, PyModel>>) -> App {
        match model {
            Some(m) => self.app.clone().with_model_as(key, m.get().model.clone()),
            None => self.app.clone(),
        }
    }

    /// `equations` of an `ezy.Model`.
    pub(crate) fn equations_of(
        &self,
        py: Python<'_>,
        model: &PyModel,
        set: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Equations> {
        let app = self.app.clone().with_model_as(&model.key, model.model.clone());
        equations_in(py, &app, &model.key, set)
    }
}

/// The description of `model` in `app` at `params`' counts.
fn info_in(app: &App, model: &str, params: &[(String, f64)]) -> PyResult<ModelInfo> {
    {
        match app.info_with(model, params) {
            Some(Ok(info)) => Ok(info),
            Some(Err(e)) => Err(ezy_err(e.message)),
            None => Err(ezy_err(format!("unknown model `{model}`; known models: {}", app.keys().join(", ")))),
        }
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

    /// A scene as an editable `Scene`: change its parameters and effects'
    /// numbers, then `run`, `sweep`, `analyze` or `linearize` it.
    ///
    /// `scene("drive")` loads a known scene (or a path to a .toml file);
    /// `scene(toml=text)` reads a scene file's text; `scene(model=m,
    /// t_end=20.0, initial={"q": {...}, "qd": {...}}, drives={...},
    /// effects={...}, integrator={...}, output={...})` builds one from
    /// keywords that are a scene file's keys and tables (the guide's
    /// chapter "Scenes and effects"; `name` is then the new scene's,
    /// "python" unless given). `model` is an
    /// `ezy.Model` (the scene then runs on it), a model's key or the path
    /// of a `.ezy` file (relative to the working directory).
    ///
    /// Raises EzyError for an unknown name or a bad scene (its key and,
    /// for text, line); TypeError for a keyword value TOML cannot hold.
    #[pyo3(signature = (name=None, *, toml=None, model=None, **keys))]
    fn scene(
        slf: &Bound<'_, Self>,
        name: Option<&str>,
        toml: Option<&str>,
        model: Option<&Bound<'_, PyAny>>,
        keys: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyScene> {
        let this = slf.get();
        let (pymodel, key) = match model {
            None => (None, None),
            Some(m) => match m.cast::<PyModel>() {
                Ok(pm) => (Some(pm.clone()), Some(pm.get().key.clone())),
                Err(_) => (
                    None,
                    Some(m.extract::<String>().map_err(|_| {
                        pyo3::exceptions::PyTypeError::new_err(
                            "scene(): `model` must be an ezy.Model, a model's key or the path of a .ezy file",
                        )
                    })?),
                ),
            },
        };
        let keys = keys.filter(|k| !k.is_empty());
        // with keys, `name` is the new scene's own
        if let (Some(n), Some(k)) = (name, keys) {
            k.set_item("name", n)?;
        }
        let name = name.filter(|_| keys.is_none());
        let (src, reference, text) = match (name, toml, keys) {
            (Some(name), None, None) => {
                let mut src = this.app.load_scene(name).map_err(ezy_err)?;
                if let Some(m) = &pymodel {
                    let app = this.app_with(&src.scene.model, Some(m));
                    src = ezy_scene::registry::check_scene(&app, src.scene, &src.text, &src.file).map_err(ezy_err)?;
                } else if let Some(k) = &key {
                    src.scene.model = k.clone();
                    src = ezy_scene::registry::check_scene(&this.app, src.scene, &src.text, &src.file)
                        .map_err(ezy_err)?;
                }
                (src, name.to_string(), None)
            }
            (None, text, keys) if text.is_some() != keys.is_some() => {
                let (text, file) = match (text, keys) {
                    (Some(t), _) => (crate::scene_text::with_model(t, key.as_deref())?, "<toml>"),
                    (_, Some(k)) => {
                        if key.is_none() && !k.contains("model")? {
                            return Err(pyo3::exceptions::PyTypeError::new_err(
                                "scene(): a scene made from keywords needs `model=` (an ezy.Model, a model's key or a .ezy path); to change a known scene, load it (ezy.scene(\"drive\")) and set its values",
                            ));
                        }
                        (crate::scene_text::from_keys(k, key.as_deref())?, "<keywords>")
                    }
                    _ => unreachable!("one of the two"),
                };
                // the keywords' own text is not the user's: its errors by key
                // alone, without a line and column in it
                let located = |e: ezy_scene::SceneFileError| {
                    let shown = e.to_string();
                    if file != "<keywords>" {
                        return ezy_err(shown);
                    }
                    let lines: Vec<&str> = shown
                        .lines()
                        .map(|l| {
                            let rest = l.strip_prefix("<keywords>:").and_then(|r| r.splitn(3, ':').nth(2));
                            rest.map_or(l, str::trim_start)
                        })
                        .collect();
                    ezy_err(format!("scene(): {}", lines.join("\n")))
                };
                let scene = ezy_scene::Scene::from_toml(&text, file).map_err(located)?;
                let app = match &pymodel {
                    Some(m) => this.app_with(&scene.model, Some(m)),
                    None => this.app.clone(),
                };
                let src = ezy_scene::registry::check_scene(&app, scene, &text, file).map_err(located)?;
                let reference = src.scene.name.clone();
                (src, reference, Some(text))
            }
            _ => {
                return Err(pyo3::exceptions::PyTypeError::new_err(
                    "scene(): give a scene's name, toml=TEXT, or the scene's keys (model=..., t_end=..., initial=...), one of the three",
                ));
            }
        };
        let app = match &pymodel {
            Some(m) => this.app_with(&src.scene.model, Some(m)),
            None => this.app.clone(),
        };
        let info = info_in(&app, &src.scene.model, &src.scene.params)?;
        Ok(PyScene {
            kit: slf.clone().unbind(),
            src,
            info,
            sets: Vec::new(),
            reference,
            model: pymodel.map(|m| m.unbind()),
            toml: text,
        })
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
    /// `model=m` (an `ezy.Model`) runs the scene on `m` in place of the
    /// model it names (its names checked against `m` first).
    ///
    /// Raises EzyError naming the bad setting, parameter or scene key;
    /// KeyboardInterrupt on Ctrl-C (the run stops within a step).
    #[pyo3(signature = (scene, *, model=None, **settings))]
    fn run(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<RunResult> {
        let (app, Resolved { src, sets, .. }) = self.resolve_on(scene, model)?;
        let app = &app;
        let o = Overrides::new(sets, settings, "run")?;
        let opts = o.options()?;
        let info = info_in(app, &src.scene.model, &src.scene.params)?;
        // A Ctrl-C that came while this call held the GIL (Python runs its
        // handler only when asked): raised before the run's setup
        py.check_signals()?;
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
        let report = report.map_err(|e| ezy_err(crate::words::run_keywords(&e.to_string())))?;
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
    /// as `run` (`model=m` sweeps the scene on an `ezy.Model`).
    ///
    /// Raises EzyError naming the bad axis, metric or setting (by its
    /// keyword: `grid=`, `metrics=`, `rtol=`), or for a grid of more than 1,000,000 runs
    /// (naming each axis's count, before anything is set up: the table
    /// comes back in memory); TypeError for a listed value that is not a
    /// number (`True` included); KeyboardInterrupt on Ctrl-C.
    #[pyo3(signature = (scene, grid, *, model=None, metrics=None, jobs=None, out=None, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn sweep<'py>(
        &self,
        py: Python<'py>,
        scene: &Bound<'py, PyAny>,
        grid: &Bound<'py, PyDict>,
        model: Option<&Bound<'py, PyModel>>,
        metrics: Option<Vec<String>>,
        jobs: Option<&Bound<'py, PyAny>>,
        out: Option<PathBuf>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        // the grid's axes and their size, before anything is set up
        let axes = crate::sweep::grid_args(grid)?;
        let jobs = whole_kw("sweep", "jobs", jobs)?;
        let (app, r) = self.resolve_on(scene, model)?;
        // the grid overrides what the scene object set of the same name
        let swept: Vec<String> = grid.keys().iter().map(|k| k.to_string()).collect();
        let sets = r.sets.iter().filter(|(n, _)| !swept.contains(n)).cloned().collect();
        let o = Overrides::new(sets, settings, "sweep")?;
        let opts = o.options()?; // the keywords' own errors first, named as keywords
        let temp = tempfile::Builder::new().prefix("ezy-sweep-").tempdir().map_err(ezy_err)?;
        let kept = out.is_some();
        let dir = out.unwrap_or_else(|| temp.path().join("sweep"));
        // the scene as it was named: a known scene's name or its file's path
        let scene = r.cli_scene(temp.path())?;
        let said = Said {
            function: "sweep",
            temp: Some(temp.path()).filter(|_| !kept),
            scene: r.toml.is_some().then(|| (scene.clone(), r.reference.clone())),
            report: true,
        };
        let mut args = vec!["sweep".to_string(), scene];
        args.extend(axes);
        for m in metrics.unwrap_or_default() {
            args.extend(["--metric".into(), m]);
        }
        args.extend(opts.to_args());
        if let Some(j) = jobs {
            // at most the cores there are, as the command line caps it (the
            // note it would print for more names its flag)
            let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get) as u64;
            args.extend(["--jobs".into(), j.min(cores).to_string()]);
        }
        args.extend(["--out".into(), dir.display().to_string(), "--no-figures".into()]);
        match Self::cli(py, &app, args, &said)? {
            Ok(_) => {}
            Err((_, e)) => return Err(ezy_err(e)),
        }
        let frame = self.helpers.bind(py).call_method1("sweep_frame", (dir.join("sweep.csv"),))?;
        drop(temp);
        Ok(frame)
    }

    /// Finds `scene`'s steady motions, or, driven periodically, its
    /// periodic orbit (the gait), or, where an autonomous scene turns on
    /// one, its limit cycle, and their stability, as `ezy analyze` does:
    /// an `Analysis` with the report and the tables as DataFrames
    /// (`.periodic`, `.equilibria`, `.branch`; the bifurcations located
    /// on a branch are rows of `.branch` with their `bifurcation` kind).
    ///
    /// `period` [s]: the forcing period (default: from the scene's
    /// waveforms); `energy` [J]: the kinetic energy of the steady motions
    /// sought; `vary="NAME=START:STOP:COUNT"` follows the solution as a
    /// parameter varies (the command line's `--continue`); `wrt` (a name
    /// or a list: `"motor.omega"`, `["M0", "c"]`) adds the gait's
    /// derivatives `d<quantity>/d<param>` to `.periodic`; with `vary`,
    /// `switch=True` also follows the branches born at the branch's branch
    /// points, period doublings and Hopf points (`switch=k`: at the k-th
    /// only; the command line's `--switch`): `.branches` lists every
    /// branch's DataFrame (the one followed first) and `.diagram` says
    /// where each is born and of what bifurcation; `out` keeps the
    /// files (CSV and figures: `figures=True`). Without `out` nothing is
    /// kept on disk, and the report's last line names the attributes that
    /// hold the tables (`table: .periodic of the returned object`). Other
    /// keywords as `run`; `model=m` analyses the scene on an `ezy.Model`.
    ///
    /// Raises EzyError with the command line's message in this call's keywords (no orbit found,
    /// a bad setting); KeyboardInterrupt on Ctrl-C.
    #[pyo3(signature = (scene, *, model=None, period=None, energy=None, vary=None, switch=None, wrt=None, out=None, figures=false, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn analyze(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        period: Option<&Bound<'_, PyAny>>,
        energy: Option<&Bound<'_, PyAny>>,
        vary: Option<&Bound<'_, PyAny>>,
        switch: Option<&Bound<'_, PyAny>>,
        wrt: Option<&Bound<'_, PyAny>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Analysis> {
        let period = number_kw("analyze", "period", period)?;
        let energy = number_kw("analyze", "energy", energy)?;
        let vary = text_kw("analyze", "vary", vary)?;
        let mut extra = Vec::new();
        if let Some(w) = names_kw("analyze", "wrt", wrt)? {
            extra.extend(["--wrt".to_string(), w]);
        }
        if let Some(p) = period {
            extra.extend(["--period".to_string(), format!("{p:?}")]);
        }
        if let Some(e) = energy {
            extra.extend(["--energy".to_string(), format!("{e:?}")]);
        }
        if let Some(v) = vary {
            extra.extend(["--continue".to_string(), v]);
        }
        extra.extend(switch_kw(switch)?);
        let (report, dir, _temp) = self.command(py, "analyze", scene, model, extra, out, figures, settings)?;
        let tables = PyDict::new(py);
        // the branches born (branch-1.csv, ...) in their order, as far as
        // they go
        let born = (1..).map(|k| format!("branch-{k}")).take_while(|n| dir.join(format!("{n}.csv")).is_file());
        for name in ["periodic", "equilibria", "branch", "branches", "growth"].map(String::from).into_iter().chain(born)
        {
            let path = dir.join(format!("{name}.csv"));
            if path.is_file() {
                tables.set_item(&name, self.helpers.bind(py).call_method1("read_table", (path,))?)?;
            }
        }
        Ok(Analysis { report, tables: tables.unbind() })
    }

    /// The geometry of locomotion of a model with the plane's symmetry, as
    /// `ezy geometry` does: its local connection, momentum equation and
    /// constraint curvature on a grid of shapes (or at one, `at={name:
    /// value}` [rad]), and a gait's net motion predicted against simulated
    /// (`gait="alpha1=0.9+0.6*cos(t),alpha2=-0.9+0.6*sin(t)"`, one period
    /// t in [0, 2 pi]; default: the scene's drives). `target` is a scene
    /// (name, path or `Scene`: its forces, its drives' gait, its initial
    /// momentum), a model's key (`"kinematic_snake"`) or an `ezy.Model`.
    /// `grid` points along each shape coordinate over `range=(lo, hi)`
    /// [rad], `body` the reference body, `shape` the hinges in order,
    /// `momentum={name: value}` the gait's initial momentum. Returns a
    /// `Geometry` (the report and the tables as DataFrames: `.connection`,
    /// `.curvature`, `.momentum`, `.gait`); `out` keeps the files
    /// (figures with `figures=True`).
    ///
    /// Raises EzyError with the command line's message in this call's keywords (no plane
    /// symmetry, a gait that meets the singular set); TypeError for
    /// keywords of the wrong kind.
    #[pyo3(signature = (target, *, model=None, at=None, gait=None, grid=None, range=None, body=None, shape=None, momentum=None, out=None, figures=false, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn geometry(
        &self,
        py: Python<'_>,
        target: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        at: Option<std::collections::BTreeMap<String, f64>>,
        gait: Option<&Bound<'_, PyAny>>,
        grid: Option<&Bound<'_, PyAny>>,
        range: Option<(f64, f64)>,
        body: Option<String>,
        shape: Option<&Bound<'_, PyAny>>,
        momentum: Option<std::collections::BTreeMap<String, f64>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Geometry> {
        let pairs = |m: std::collections::BTreeMap<String, f64>| {
            m.iter().map(|(k, v)| format!("{k}={v:?}")).collect::<Vec<_>>().join(",")
        };
        let mut extra = Vec::new();
        if let Some(a) = at {
            extra.extend(["--at".to_string(), pairs(a)]);
        }
        if let Some(g) = text_kw("geometry", "gait", gait)? {
            extra.extend(["--gait".to_string(), g]);
        }
        if let Some(n) = whole_kw("geometry", "grid", grid)? {
            extra.extend(["--grid".to_string(), n.to_string()]);
        }
        if let Some((lo, hi)) = range {
            extra.push(format!("--range={lo:?}:{hi:?}"));
        }
        if let Some(b) = body {
            extra.extend(["--body".to_string(), b]);
        }
        if let Some(s) = names_kw("geometry", "shape", shape)? {
            extra.extend(["--shape".to_string(), s]);
        }
        if let Some(p) = momentum {
            extra.extend(["--momentum".to_string(), pairs(p)]);
        }
        // a model (an `ezy.Model`, or a key no scene has) goes straight to
        // the command line; a scene through the run keywords' path
        let (report, dir, _temp) = self.on_target(py, "geometry", target, model, extra, out, figures, settings)?;
        let tables = PyDict::new(py);
        for (name, file) in [
            ("connection", "connection.csv"),
            ("curvature", "curvature.csv"),
            ("momentum", "momentum.csv"),
            ("gait", "gait.csv"),
            ("gait_path", "gait-path.csv"),
        ] {
            let path = dir.join(file);
            if path.is_file() {
                tables.set_item(name, self.helpers.bind(py).call_method1("read_table", (path,))?)?;
            }
        }
        Ok(Geometry { report, tables: tables.unbind() })
    }

    /// Runs `scene` with the derivatives of its state with respect to the
    /// parameters `wrt` (a name or a list: a scene parameter `"M0"`, a
    /// model parameter, `"motor.omega"`, `"initial.q.phi2"`), as `ezy
    /// sensitivity` does: a DataFrame with `t` [s] and the columns
    /// `d<column>/d<param>` (`dx1/dM0`: the column's unit per the
    /// parameter's, m per N m), the report in `.attrs["report"]` (the
    /// steps taken and the final derivatives; without `out`, its last
    /// line says the table is the returned DataFrame), `.attrs["units"]`
    /// (`{column: unit}`) and `.attrs["description"]` (each column's unit,
    /// meaning, frame and time, from the guide's Quantities page).
    /// Other keywords as `analyze`.
    ///
    /// Raises EzyError with the command line's message in this call's keywords (an unknown
    /// parameter, radau5, a scene with events); KeyboardInterrupt on Ctrl-C.
    #[pyo3(signature = (scene, *, wrt, model=None, out=None, figures=false, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn sensitivity(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        wrt: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let wrt = names_kw("sensitivity", "wrt", Some(wrt))?
            .ok_or_else(|| pyo3::exceptions::PyTypeError::new_err("sensitivity(): `wrt` names no parameter"))?;
        let extra = vec!["--wrt".to_string(), wrt];
        let (report, dir, _temp) = self.command(py, "sensitivity", scene, model, extra, out, figures, settings)?;
        let frame = self.helpers.bind(py).call_method1("read_table", (dir.join("sensitivity.csv"),))?;
        crate::quantities::annotate(py, &frame, "sensitivity.csv")?;
        frame.getattr("attrs")?.set_item("report", report)?;
        Ok(frame.unbind())
    }

    /// Fits numbers of `scene` to a measured run, as `ezy fit` does:
    /// `data` is the path of a CSV file or a DataFrame with a column `t`
    /// [s] and the `columns` fitted (a name or a list: coordinates or
    /// velocities of the model), `over` a dict `{name: (lower, upper)}`
    /// of the numbers fitted (names as `set` takes them), each started
    /// from the scene's value. Returns a DataFrame indexed by parameter
    /// with `estimate` and `std_error` (in the parameter's unit); the
    /// report (correlations, the residual (rms) per column in the
    /// column's unit, the runs taken) in `.attrs["report"]`.
    /// Other keywords as `analyze`.
    ///
    /// Raises EzyError with the command line's message in this call's keywords (data with NaN or
    /// unsorted times, bounds that exclude the start); TypeError for
    /// keywords of the wrong kind; KeyboardInterrupt on Ctrl-C.
    #[pyo3(signature = (scene, *, data, columns, over, model=None, out=None, figures=false, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn fit(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        data: &Bound<'_, PyAny>,
        columns: &Bound<'_, PyAny>,
        over: &Bound<'_, PyDict>,
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let type_error = |m: String| pyo3::exceptions::PyTypeError::new_err(m);
        let columns = names_kw("fit", "columns", Some(columns))?
            .ok_or_else(|| type_error("fit(): `columns` names no column".into()))?;
        let temp = tempfile::Builder::new().prefix("ezy-data-").tempdir().map_err(ezy_err)?;
        let path = if data.hasattr("to_csv")? {
            let path = temp.path().join("data.csv");
            let kw = PyDict::new(py);
            kw.set_item("index", false)?;
            data.call_method("to_csv", (path.clone(),), Some(&kw))?;
            path
        } else {
            data.extract::<PathBuf>()
                .map_err(|_| type_error("fit(): `data` must be a CSV file's path or a DataFrame".into()))?
        };
        let mut extra = vec!["--data".to_string(), path.display().to_string(), "--columns".into(), columns];
        extra.extend(over_args("fit", "over", over)?);
        let (report, dir, _temp) = self.command(py, "fit", scene, model, extra, out, figures, settings)?;
        let frame = self.helpers.bind(py).call_method1("read_table", (dir.join("fit.csv"), "parameter"))?;
        frame.getattr("attrs")?.set_item("report", report)?;
        Ok(frame.unbind())
    }

    /// Optimizes numbers of `scene` as `ezy optimize` does: `maximize` or
    /// `minimize` (one of them) names a gait's quantity (`"gait.mean_speed"`,
    /// `"gait.efficiency"`, ...) or a run's metric (`"final(x1)"`,
    /// `"mean(x1d, 50, 60)"`), or is a function of your own: it takes the
    /// run as a DataFrame (`t`, the state's columns and the derivatives
    /// `d<column>/d<param>`, the parameters in `.attrs["parameters"]`)
    /// and returns `(value, [d value / d param for each parameter])`;
    /// `over` maps each number to its bounds
    /// `(lower, upper)` (the search starts from the scene's value);
    /// `subject_to` lists constraints (`"gait.mean_power <= 1"`). Returns
    /// the optimum as a one-row DataFrame (the parameters, the objective,
    /// the constrained quantities, each in its own unit: `gait.mean_speed`
    /// [m/s], `gait.mean_power` [W], `gait.efficiency` [m/J]), with every
    /// evaluation (and its gradient) in `.attrs["history"]`, the grid's
    /// points (`grid` > 0) in `.attrs["grid"]` and the command's report
    /// (the optimum, the constraints' values and multipliers, the
    /// evaluations taken) in `.attrs["report"]`; each table's
    /// `.attrs["units"]` (`{column: unit}`) and `.attrs["description"]`
    /// (each column's unit, meaning, frame and time). With `gait` (the
    /// start, `"D=-pi+0.3*cos(t)"`: one period, `t` in [0, 2 pi], per drive
    /// of the scene's model) the numbers are the drives' Fourier
    /// coefficients (`over={"D.a1": (0.05, 0.4)}`, as `ezy optimize
    /// --gait`), the gait stretched to `period` seconds (default the
    /// scene's drives' period), of order `harmonics`, each drive's angle
    /// held within `range={"D": (lower, upper)}` [rad] over the cycle.
    ///
    /// Raises EzyError with the command line's message in this call's keywords (an unknown
    /// quantity or parameter, bounds that exclude the start, a search that
    /// did not converge); TypeError for keywords of the wrong kind;
    /// KeyboardInterrupt on Ctrl-C (the best point so far is written to
    /// `out` when given).
    #[pyo3(signature = (
        scene, *, over, maximize=None, minimize=None, subject_to=None, max_evaluations=None, grid=None,
        gait=None, period=None, harmonics=None, range=None, model=None, out=None, figures=false, **settings
    ))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn optimize(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        over: &Bound<'_, PyDict>,
        maximize: Option<&Bound<'_, PyAny>>,
        minimize: Option<&Bound<'_, PyAny>>,
        subject_to: Option<&Bound<'_, PyAny>>,
        max_evaluations: Option<&Bound<'_, PyAny>>,
        grid: Option<&Bound<'_, PyAny>>,
        gait: Option<&Bound<'_, PyAny>>,
        period: Option<&Bound<'_, PyAny>>,
        harmonics: Option<&Bound<'_, PyAny>>,
        range: Option<&Bound<'_, PyDict>>,
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        self.optimize_on(
            py,
            (scene, over),
            (maximize, minimize, subject_to),
            (max_evaluations, grid),
            (gait, period, harmonics, range),
            (model, out, figures, settings),
        )
    }

    /// The least-effort inputs that take `scene` from its initial state to
    /// a target at its t_end, as `ezy plan` does: `input` names the
    /// effects' time functions planned (`"motor.torque"` or a list), each
    /// replaced by a piecewise-linear table on `segments` segments,
    /// `intervals` shooting intervals of them (default 1: single
    /// shooting); `guess`, the warm start, a CSV file's path or a
    /// DataFrame with a column `t` [s] and one per input (an earlier
    /// plan's, on any mesh); `bound={input: (lo, hi)}`, `to={"x1": 1.0, "y1": 0.0}` (a velocity
    /// is its coordinate's name with `d`: `"x1d"`) and `at_rest=True`.
    /// The objective is the effort (the inputs squared integrated over
    /// [0, t_end], summed) times `effort_weight` (default 1) plus, with
    /// `objective=f`, a term of your own: `f(t, q, qd, u)` of the run's
    /// samples at the N + 1 nodes, numpy arrays `t` (N + 1,) [s], `q`
    /// and `qd` (N + 1, nq) [m or rad, m/s or rad/s] and `u` (N + 1,
    /// inputs) [the inputs' units], returning a float, or `(value,
    /// gradients)` with the gradients of the value with respect to `q`,
    /// `qd` and `u` (t is fixed) as a dict `{"q": .., "qd": .., "u": ..}`
    /// (a key left out: zeros) or a tuple `(gq, gqd, gu)`, arrays shaped
    /// as the samples. Without gradients ezy differences `f` with
    /// respect to the samples (central differences: 2 calls of `f` per
    /// sample, no extra simulation) and says so
    /// (`summary["objective_gradient"]`: "exact" or "differenced"); the
    /// chain to the planned inputs uses the exact sensitivities. With an
    /// objective the target may be left out (a free end). `f` is called
    /// holding the GIL. `path` bounds the run at every node: a state
    /// column as text (`"x1d<=0.6"`, `"y1>=-0.5"`, `"-1<=y1<=1"`) or a
    /// function of your own `(g, lo, hi)` (`lo` or `hi` None for no
    /// bound), `g(t, q, qd, u)` of one node's sample (arrays of one row),
    /// returning as `objective` does; a list of them. Between the nodes
    /// the verification run reports the largest excess
    /// (`summary["path_excess"]`). `free_time=(lo, hi)` [s] frees the
    /// duration within those bounds (started at the scene's t_end; the
    /// nodes move with it; `summary["t_end"]` the one planned);
    /// `minimize="time"` then minimizes it alone, and `time_weight=c`
    /// adds `c T` to the effort (or to `objective`).
    ///
    /// Returns a DataFrame of the planned inputs at the nodes (`t` [s],
    /// one column per input in its unit), `.attrs["summary"]` (status,
    /// effort [unit^2 s], the objective minimized, its value and how its
    /// gradient was had, violation, the verification run's errors),
    /// `.attrs["report"]`, `.attrs["units"]` and `.attrs["description"]`.
    /// Other keywords as `run`.
    ///
    /// Raises EzyError with the command line's message in this call's
    /// keywords: a target not met (infeasible, with the least violation
    /// found) or not shown optimal, an unknown effect or coordinate,
    /// bounds lo > hi or not finite, an `effort_weight` not finite and
    /// >= 0 (or 0 without `objective`), an objective value or gradient
    /// entry that is NaN or infinite (naming its sample); the exception
    /// `f` raised, as it was raised (TypeError for a return of another
    /// shape); KeyboardInterrupt on Ctrl-C.
    #[pyo3(signature = (scene, *, input, bound=None, to=None, at_rest=false, segments=None, evaluations=None, intervals=None, guess=None, objective=None, effort_weight=None, path=None, minimize=None, time_weight=None, free_time=None, model=None, out=None, figures=false, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn plan(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        input: &Bound<'_, PyAny>,
        bound: Option<&Bound<'_, PyDict>>,
        to: Option<&Bound<'_, PyDict>>,
        at_rest: bool,
        segments: Option<&Bound<'_, PyAny>>,
        evaluations: Option<&Bound<'_, PyAny>>,
        intervals: Option<&Bound<'_, PyAny>>,
        guess: Option<&Bound<'_, PyAny>>,
        objective: Option<&Bound<'_, PyAny>>,
        effort_weight: Option<&Bound<'_, PyAny>>,
        path: Option<&Bound<'_, PyAny>>,
        minimize: Option<&Bound<'_, PyAny>>,
        time_weight: Option<&Bound<'_, PyAny>>,
        free_time: Option<&Bound<'_, PyAny>>,
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let mesh = (segments, evaluations, intervals, guess);
        let goal = (objective, effort_weight, path);
        let time = (minimize, time_weight, free_time);
        self.plan_on(py, scene, input, (bound, to, at_rest), mesh, goal, time, model, out, figures, settings)
    }

    /// The best closed gait of a kinematic system, as `ezy
    /// gait-optimize` does: from `gait` (`"a1=0.6*cos(t), a2=0.6*sin(t)"`,
    /// t over one period [0, 2 pi]), the Fourier coefficients that make
    /// `maximize` or `minimize` (`"dx"`, `"dy"` [m], `"dtheta"` [rad],
    /// `"along(1,0)"`) largest or smallest, per path length with
    /// `per_length=True`; `order` (`"first"`, `"second"`,
    /// `"reconstructed"`), `harmonics`, `centre_only`, `range={"a1": (lo,
    /// hi)}` [rad], `margin` (0 to 1, from the singular set), `budget`
    /// (the most path length [rad]), `metric` (the path length's metric
    /// `G`, `int sqrt(r'^T G r') dt`: a symmetric positive definite
    /// matrix, a list of rows or a 2-D array; the identity by default),
    /// `max_evaluations`, `body`,
    /// `set={param: value}`. `target` is a scene, a model's key or an
    /// `ezy.Model`. Returns a DataFrame of the coefficients (start,
    /// optimum, bounds, gradient), `.attrs["history"]` (every
    /// evaluation), `.attrs["report"]`.
    ///
    /// Raises EzyError with the command line's message in this call's
    /// keywords: a model without shape variables or not kinematic, a
    /// start on the singular set, a range lo > hi; TypeError for keywords
    /// of the wrong kind.
    #[pyo3(signature = (target, *, gait, maximize=None, minimize=None, per_length=false, order=None, harmonics=None, centre_only=false, range=None, margin=None, budget=None, metric=None, max_evaluations=None, body=None, set=None, model=None, out=None, figures=false))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn gait_optimize(
        &self,
        py: Python<'_>,
        target: &Bound<'_, PyAny>,
        gait: &Bound<'_, PyAny>,
        maximize: Option<&Bound<'_, PyAny>>,
        minimize: Option<&Bound<'_, PyAny>>,
        per_length: bool,
        order: Option<&Bound<'_, PyAny>>,
        harmonics: Option<&Bound<'_, PyAny>>,
        centre_only: bool,
        range: Option<&Bound<'_, PyDict>>,
        margin: Option<&Bound<'_, PyAny>>,
        budget: Option<&Bound<'_, PyAny>>,
        metric: Option<&Bound<'_, PyAny>>,
        max_evaluations: Option<&Bound<'_, PyAny>>,
        body: Option<&Bound<'_, PyAny>>,
        set: Option<&Bound<'_, PyDict>>,
        model: Option<&Bound<'_, PyModel>>,
        out: Option<PathBuf>,
        figures: bool,
    ) -> PyResult<Py<PyAny>> {
        self.gait_optimize_on(
            py,
            target,
            gait,
            (maximize, minimize),
            (per_length, order, harmonics, centre_only),
            (range, margin, budget, metric),
            (max_evaluations, body, set),
            model,
            out,
            figures,
        )
    }

    /// Linearizes `scene` at time `at` [s] of its run, as `ezy linearize`
    /// does: a `Linearization` with `A` (and `B` for `input`, the name of
    /// an effect's or drive's input) as DataFrames, the eigenvalues [1/s]
    /// as a complex array, and the state. Other keywords as `analyze`.
    ///
    /// Raises EzyError with the command line's message in this call's keywords.
    #[pyo3(signature = (scene, *, model=None, at=None, input=None, out=None, **settings))]
    #[expect(clippy::too_many_arguments, reason = "Python's keywords, one argument each")]
    fn linearize(
        &self,
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        model: Option<&Bound<'_, PyModel>>,
        at: Option<&Bound<'_, PyAny>>,
        input: Option<&Bound<'_, PyAny>>,
        out: Option<PathBuf>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Linearization> {
        let at = number_kw("linearize", "at", at)?.unwrap_or(0.0);
        let input = text_kw("linearize", "input", input)?;
        let mut extra = vec!["--at".to_string(), format!("{at:?}")];
        if let Some(i) = input {
            extra.extend(["--input".to_string(), i]);
        }
        let (report, dir, _temp) = self.command(py, "linearize", scene, model, extra, out, true, settings)?;
        let h = self.helpers.bind(py);
        let table = |name: &str| -> PyResult<Option<Py<PyAny>>> {
            let path = dir.join(name);
            if !path.is_file() {
                return Ok(None);
            }
            Ok(Some(h.call_method1("read_table", (path, "row"))?.unbind()))
        };
        let a = table("A.csv")?.ok_or_else(|| ezy_err("linearize wrote no A.csv"))?;
        Ok(Linearization {
            report,
            a,
            b: table("B.csv")?,
            eigenvalues: h.call_method1("eigenvalues", (dir.join("eigenvalues.csv"),))?.unbind(),
            state: h.call_method1("state", (dir.join("state.csv"),))?.cast_into::<PyDict>()?.unbind(),
        })
    }

    /// The derived equations of `model` (a model's key, the path of a
    /// `.ezy` file, or an `ezy.Model`), with `set` applied to its
    /// parameters and family counts: constraints, Jacobian, convective
    /// terms, point velocities. Jupyter renders them as LaTeX; `str()`
    /// gives the plain text.
    ///
    /// Raises EzyError for an unknown model or parameter.
    #[pyo3(signature = (model, *, set=None))]
    fn equations(
        &self,
        py: Python<'_>,
        model: &Bound<'_, PyAny>,
        set: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Equations> {
        if let Ok(m) = model.cast::<PyModel>() {
            return self.equations_of(py, m.get(), set);
        }
        equations_in(py, &self.app, &model_key(model)?, set)
    }

    /// Checks `model`'s derived terms (the constraint Jacobian, the skate
    /// rows, gamma, the point velocities) against automatic
    /// differentiation at `states` random states: a `Check` with `passed`
    /// and the table `ezy check` prints.
    ///
    /// Raises EzyError for an unknown model or parameter, or `states` x
    /// the model's coordinates above 1e8 (before any state); TypeError for
    /// a `states` or `seed` that is not a whole number (`True` included);
    /// KeyboardInterrupt on Ctrl-C (within a state).
    #[pyo3(signature = (model, *, set=None, states=None, seed=None))]
    fn check(
        &self,
        py: Python<'_>,
        model: &Bound<'_, PyAny>,
        set: Option<&Bound<'_, PyDict>>,
        states: Option<&Bound<'_, PyAny>>,
        seed: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Check> {
        let states = whole_kw("check", "states", states)?;
        let seed = whole_kw("check", "seed", seed)?;
        let (app, key) = match model.cast::<PyModel>() {
            Ok(m) => (self.app_with(&m.get().key, Some(m)), m.get().key.clone()),
            Err(_) => (self.app.clone(), model_key(model)?),
        };
        let mut args = vec!["check".to_string(), key];
        for (n, v) in sets_of(set)? {
            args.extend(["--set".into(), format!("{n}={v:?}")]);
        }
        if let Some(s) = states {
            args.extend(["--states".into(), s.to_string()]);
        }
        if let Some(s) = seed {
            args.extend(["--seed".into(), s.to_string()]);
        }
        match Self::cli(py, &app, args, &Said::plain("check"))? {
            Ok(table) => Ok(Check { passed: true, table, message: String::new() }),
            // a failed check prints its table first; no table: a bad request
            Err((table, e)) if !table.is_empty() => Ok(Check { passed: false, table, message: e }),
            Err((_, e)) => Err(ezy_err(e)),
        }
    }
}

/// A model named by a string: a key or a `.ezy` file's path.
fn model_key(model: &Bound<'_, PyAny>) -> PyResult<String> {
    model
        .extract()
        .map_err(|_| PyValueError::new_err("model: give a model's key, the path of a .ezy file, or an ezy.Model"))
}

/// `analyze(switch=...)` as the command line's arguments: `True` is
/// `--switch` (every bifurcation), a whole number `k >= 1` is `--switch k`,
/// `False` or `None` nothing.
///
/// # Errors
/// `TypeError` or `ValueError` naming the keyword for anything else.
fn switch_kw(v: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(v) = v.filter(|v| !v.is_none()) else { return Ok(Vec::new()) };
    if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
        return Ok(if b.is_true() { vec!["--switch".into()] } else { Vec::new() });
    }
    match v.extract::<i64>() {
        Ok(k) if k >= 1 => Ok(vec!["--switch".into(), k.to_string()]),
        Ok(k) => Err(pyo3::exceptions::PyValueError::new_err(format!(
            "analyze(): `switch={k}`: the bifurcations are counted from 1 (switch=1 the first); switch=True for all"
        ))),
        Err(_) => {
            let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
            Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "analyze(): `switch` must be True (every bifurcation) or a whole number k >= 1 (the k-th), not {ty} ({v})"
            )))
        }
    }
}
