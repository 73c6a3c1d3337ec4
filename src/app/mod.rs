//! The application: a table of models and scenes, and the command line
//! over it. The `ezy` binary is `App::new().main()`; a user's binary adds
//! their own vehicles and scenes and gets every command for them:
//!
//! ```no_run
//! # ezy::model! {
//! #     /// A sleigh.
//! #     pub struct MySleigh {
//! #         /// Distance from the centre of mass back to the skate [m]
//! #         param a = 0.5;
//! #         body s(x, y, phi) { mass: 1.0, inertia: 0.1 }
//! #         point P on s at (-a, 0);
//! #         skate P: P along (1, 0);
//! #     }
//! # }
//! fn main() -> std::process::ExitCode {
//!     ezy::App::new() // the built-in vehicles and scenes
//!         .model::<MySleigh>("my_sleigh")
//!         .scene("my-sleigh.toml", r#"name = "my-sleigh" ..."#)
//!         .main() // parses std::env::args like the `ezy` binary
//! }
//! ```

mod dispatch;
pub(crate) mod scenes;

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use ezy_core::effects::EffectKind;
use ezy_core::{AnyModel, Model, ModelInfo};
use ezy_scene::EffectKinds;
use ezy_scene::registry::{ModelCatalog, Register, info_of};
use ezy_scene::{Scene, SceneError};

use crate::output::transaction::Interrupted;
use crate::precision;
use crate::session::{Error, Report, RunOptions, StopHook};
pub use scenes::LoadError;
use scenes::SceneEntry;

/// The environment variable that chooses how model files are evaluated:
/// `tape` or `jit` ([`ezy_core::text::Evaluator`]); unset, the JIT where
/// the build and the host have one.
pub const EVALUATOR_VAR: &str = "EZY_EVALUATOR";

/// Whether a model key is the path of a model file: it ends in `.ezy`.
pub(crate) fn is_model_path(key: &str) -> bool {
    key.ends_with(".ezy")
}

/// Why a command could not be carried out.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// The command line is wrong (or asked for `--help`/`--version`, whose
    /// text is the error's display).
    #[error("{0}")]
    Usage(#[from] clap::Error),
    /// The command failed; the message names the culprit (file, line,
    /// column and key for a scene file; the parameter, model or setting
    /// otherwise).
    #[error("{0}")]
    Failed(String),
    /// A signal stopped the command before it committed its output
    /// ([`App::main`] exits with 128 + the signal's number).
    #[error("{0}")]
    Interrupted(Interrupted),
    /// Writing to the output stream failed (a closed pipe ends quietly in
    /// [`App::main`]).
    #[error("writing the output: {0}")]
    Io(#[from] std::io::Error),
}

impl AppError {
    /// A failed command, with `e` as its message.
    pub(crate) fn failed(e: impl std::fmt::Display) -> Self {
        Self::Failed(e.to_string())
    }

    /// A failed run or measurement; an interruption keeps its signal.
    pub(crate) fn from_run(e: Error) -> Self {
        match e.interrupted() {
            Some(i) => Self::Interrupted(i.clone()),
            None => Self::failed(e),
        }
    }
}

/// The models and scenes an `ezy` command line knows, and every command
/// of the `ezy` binary over them ([`App::main`], [`App::run_cli`]).
///
/// Mistakes in building the table (a model key or a scene name given
/// twice) are kept and reported by every command, so the program never
/// runs with a table other than the one written.
#[derive(Clone)]
pub struct App {
    /// Each model as an [`AnyModel`], so that every command is compiled
    /// once, in this crate, for all models: a crate that adds its own
    /// model with [`App::model`] compiles only the model's functions.
    models: Vec<(String, AnyModel)>,
    kinds: EffectKinds,
    scenes: Vec<SceneEntry>,
    default_scene: String,
    errors: Vec<String>,
    /// Models read from `.ezy` files, by the path given (shared by clones).
    file_models: std::sync::Arc<std::sync::Mutex<Vec<(String, AnyModel)>>>,
    /// Quantities of the caller's own, by name ([`App::quantity`]).
    quantities: Vec<(String, std::sync::Arc<ezy_core::design::optimize::RunFunction>)>,
    /// The objective `plan` minimizes, where the caller set one
    /// ([`App::plan_objective`]).
    plan_objective: Option<ezy_core::plan::Objective>,
    /// Path constraints of the caller's own `plan` adds to `--path`'s
    /// ([`App::plan_path`]).
    plan_path: Vec<ezy_core::plan::PathConstraint>,
}

impl Default for App {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for App {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("App")
            .field("models", &self.models.iter().map(|(k, _)| k).collect::<Vec<_>>())
            .field("effect_kinds", &self.kinds.names())
            .field("scenes", &self.scenes)
            .field("default_scene", &self.default_scene)
            .field("errors", &self.errors)
            .finish()
    }
}

impl Register for App {
    fn register<M: Model + Default + 'static>(&mut self, key: &str) {
        self.add(key, AnyModel::new(M::default()));
    }
}

impl ModelCatalog for App {
    fn keys(&self) -> Vec<&str> {
        self.models.iter().map(|(k, _)| k.as_str()).collect()
    }
    fn info_with(&self, key: &str, params: &[(String, f64)]) -> Option<Result<ModelInfo, SceneError>> {
        self.model_for(key).map(|model| {
            let model = model.map_err(|message| SceneError { path: vec!["model".into()], message })?;
            info_of(&model, params)
        })
    }
    fn effect_kinds(&self) -> Option<&EffectKinds> {
        Some(&self.kinds)
    }
    fn check_user_effects(&self, key: &str, checked: &ezy_scene::Checked) -> Result<(), SceneError> {
        match self.model_for(key) {
            Some(Ok(model)) => ezy_scene::registry::check_user_effects(&model, checked),
            _ => Ok(()),
        }
    }
}

impl App {
    /// The built-in vehicles and scenes (what the `ezy` binary knows);
    /// `drive` is the scene `run` takes without a name.
    pub fn new() -> Self {
        let mut app = Self::empty();
        ezy_models::register(&mut app);
        for (file, text) in ezy_models::scenes::BUILTIN {
            app.scenes.push(SceneEntry::Text { file: format!("models/scenes/{file}"), text: Cow::Borrowed(text) });
        }
        app.default_scene = "drive".into();
        app
    }

    /// No models and no scenes: only what the caller adds.
    pub fn empty() -> Self {
        Self {
            models: Vec::new(),
            kinds: EffectKinds::default(),
            scenes: Vec::new(),
            default_scene: String::new(),
            errors: Vec::new(),
            file_models: Default::default(),
            quantities: Vec::new(),
            plan_objective: None,
            plan_path: Vec::new(),
        }
    }

    /// Adds model type `M` under `key` (the name scene files give in
    /// `model = "KEY"` and the commands `equations`, `check`, `scale` take).
    /// A key given twice is reported by every command. The commands run
    /// the model as an [`AnyModel`], compiled once in this crate: the
    /// caller's crate compiles only `M`'s own functions.
    #[must_use]
    pub fn model<M: Model + Default + 'static>(mut self, key: &str) -> Self {
        self.register::<M>(key);
        self
    }

    /// Adds `model` as it is (its parameters and counts) under `key`: a
    /// model value rather than a type, such as one read from text
    /// ([`ezy_core::text::RuntimeModel`]). Otherwise as [`App::model`].
    #[must_use]
    pub fn model_value(mut self, key: &str, model: impl Model) -> Self {
        self.add(key, AnyModel::new(model));
        self
    }

    /// `model` in place of the model `key` names (a registered key, or a
    /// model file's path a scene gives), or added under it: a scene
    /// whose `model` is `key` then runs on `model` (the Python package's
    /// `ezy.run(scene, model=m)`).
    #[must_use]
    pub fn with_model_as(mut self, key: &str, model: impl Model) -> Self {
        self.models.retain(|(k, _)| k != key);
        self.models.push((key.to_string(), AnyModel::new(model)));
        self
    }

    /// Adds effect kind `T`, a force law of the user's own, under `kind`:
    /// scene files then write `[effects.NAME] kind = "KIND"` with `T`'s
    /// fields, exactly as for a built-in kind (its work column closes the
    /// energy ledger, `--set NAME.KEY` changes its numbers, every
    /// integrator runs it, its errors are placed in the file). A kind
    /// given twice, or a built-in kind's name, is reported by every
    /// command.
    #[must_use]
    pub fn effect<T: EffectKind>(mut self, kind: &str) -> Self {
        if let Err(e) = self.kinds.add::<T>(kind) {
            self.errors.push(e);
        }
        self
    }

    /// Adds a scene from its TOML text, usually `include_str!`-ed so the
    /// binary runs it from any directory; `file` is how errors name it. It
    /// is checked against its model when first used; a scene name given
    /// twice is reported by every command.
    #[must_use]
    pub fn scene(mut self, file: &str, text: &'static str) -> Self {
        self.scenes.push(SceneEntry::Text { file: file.to_string(), text: Cow::Borrowed(text) });
        self
    }

    /// Adds a scene file by path, read when the scenes are first needed
    /// (an unreadable or bad file is reported then, with its path).
    #[must_use]
    pub fn scene_file(mut self, path: impl Into<PathBuf>) -> Self {
        self.scenes.push(SceneEntry::Path(path.into()));
        self
    }

    /// Adds a quantity of the caller's own under `name`, which `ezy
    /// optimize --maximize NAME` (`--minimize`, `--subject-to 'NAME <=
    /// V'`) then names as it names a built-in one: a function of a run's
    /// state and sensitivities (`ezy_core::sensitivity::Sensitivities`,
    /// samples every output interval) that returns the value and its
    /// gradient with respect to the run's parameters, or why it cannot.
    /// A name of the caller's shadows a metric of the same text.
    #[must_use]
    pub fn quantity(
        mut self,
        name: &str,
        function: impl Fn(&ezy_core::sensitivity::Sensitivities) -> Result<(f64, Vec<f64>), String> + Send + Sync + 'static,
    ) -> Self {
        self.quantities.retain(|(k, _)| k != name);
        self.quantities.push((name.to_string(), std::sync::Arc::new(function)));
        self
    }

    /// The objective `plan` minimizes instead of the effort
    /// ([`ezy_core::plan::Objective`]: the effort times its weight plus a
    /// term of the caller's own of the run's samples at the nodes, as
    /// Python's `ezy.plan(objective=...)` gives it); the command line's
    /// flags are unchanged. With a term of the caller's own, `plan` takes
    /// no target too (a free end).
    #[must_use]
    pub fn plan_objective(mut self, objective: ezy_core::plan::Objective) -> Self {
        self.plan_objective = Some(objective);
        self
    }

    /// The objective `plan` minimizes, if the caller set one
    /// ([`App::plan_objective`]).
    pub(crate) fn own_plan_objective(&self) -> Option<ezy_core::plan::Objective> {
        self.plan_objective.clone()
    }

    /// A path constraint `plan` adds to those of `--path`
    /// ([`ezy_core::plan::PathConstraint`]: a bound on a function of the
    /// caller's own of one node's sample, as Python's `ezy.plan(path=[(f,
    /// lo, hi)])` gives it); repeatable.
    #[must_use]
    pub fn plan_path(mut self, constraint: ezy_core::plan::PathConstraint) -> Self {
        self.plan_path.push(constraint);
        self
    }

    /// The path constraints of the caller's own ([`App::plan_path`]).
    pub(crate) fn own_plan_path(&self) -> Vec<ezy_core::plan::PathConstraint> {
        self.plan_path.clone()
    }

    /// The caller's own quantity `name` ([`App::quantity`]).
    pub(crate) fn own_quantity(&self, name: &str) -> Option<std::sync::Arc<ezy_core::design::optimize::RunFunction>> {
        self.quantities.iter().find(|(k, _)| k == name).map(|(_, f)| std::sync::Arc::clone(f))
    }

    /// The scene `run` takes when none is named (`App::new`: `drive`).
    #[must_use]
    pub fn default_scene(mut self, name: &str) -> Self {
        self.default_scene = name.to_string();
        self
    }

    /// Adds `model` under `key`, or keeps the mistake (a key given twice,
    /// empty, with spaces, or naming a model file) for every command to
    /// report.
    fn add(&mut self, key: &str, model: AnyModel) {
        if self.models.iter().any(|(k, _)| k == key) {
            self.errors.push(format!("model key `{key}` is registered twice"));
        } else if key.is_empty() || key.chars().any(char::is_whitespace) {
            self.errors.push(format!("model key `{key}` must be non-empty and without spaces"));
        } else if is_model_path(key) {
            self.errors.push(format!("model key `{key}` ends in .ezy, which names a model file; choose another"));
        } else {
            self.models.push((key.to_string(), model));
        }
    }

    fn registered(&self, key: &str) -> Option<&AnyModel> {
        self.models.iter().find(|(k, _)| k == key).map(|(_, model)| model)
    }

    /// The model `key` names: one registered under it, or the model file
    /// it is the path of (`.ezy`, [`is_model_path`]), read once per
    /// application and kept; `None` for neither.
    ///
    /// # Errors
    /// The inner `Err` says why the file could not be read or where its
    /// text is wrong (`file:line:column: message`, one per mistake), or
    /// that [`EVALUATOR_VAR`] names no evaluator this build has. A model
    /// file is evaluated as that variable says (`tape` or `jit`; unset:
    /// the JIT where there is one).
    pub(crate) fn model_for(&self, key: &str) -> Option<Result<AnyModel, String>> {
        if let Some(m) = self.registered(key) {
            return Some(Ok(m.clone()));
        }
        if !is_model_path(key) {
            return None;
        }
        let mut read = self.file_models.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, m)) = read.iter().find(|(k, _)| k == key) {
            return Some(Ok(m.clone()));
        }
        let read_model = || -> Result<ezy_core::text::RuntimeModel, String> {
            use ezy_core::text::{Evaluator, ModelTextError, RuntimeModel};
            let path = Path::new(key);
            match std::env::var(EVALUATOR_VAR) {
                Ok(name) => {
                    let e = Evaluator::parse(&name).map_err(|e| format!("{EVALUATOR_VAR}: {e}"))?;
                    RuntimeModel::from_file_with(path, e).map_err(|e| match e {
                        ModelTextError::NoJit(_) => format!("{EVALUATOR_VAR}={name}: {e}"),
                        e => e.to_string(),
                    })
                }
                Err(_) => RuntimeModel::from_file(path).map_err(|e| e.to_string()),
            }
        };
        Some(match read_model() {
            Ok(m) => {
                let m = AnyModel::new(m);
                read.push((key.to_string(), m.clone()));
                Ok(m)
            }
            Err(e) => Err(e),
        })
    }

    fn registry_ok(&self) -> Result<(), LoadError> {
        match self.errors.first() {
            Some(e) => Err(LoadError::Registry(e.clone())),
            None => Ok(()),
        }
    }

    /// The model registered under `key`, or read from the model file
    /// `key` is the path of.
    ///
    /// # Errors
    /// A table mistake, an unknown key (listing the known ones), or a
    /// model file that cannot be read or has mistakes (each located).
    pub(crate) fn model_or_error(&self, key: &str) -> Result<AnyModel, AppError> {
        self.registry_ok().map_err(AppError::failed)?;
        match self.model_for(key) {
            Some(m) => m.map_err(AppError::Failed),
            None => Err(AppError::Failed(format!(
                "unknown model `{key}`; known models: {} (or give the path of a .ezy model file)",
                self.keys().join(", ")
            ))),
        }
    }

    /// Runs `scene` with `opts` on the model its `model` key names: writes
    /// `trajectory.csv` and the figures into `opts.out`.
    ///
    /// # Errors
    /// [`Error`] naming the bad setting, parameter, or file;
    /// [`Error::UnknownModel`] for a key this application lacks.
    pub fn run_scene(&self, scene: &Scene, opts: &RunOptions) -> Result<Report, Error> {
        match self.model_for(&scene.model) {
            Some(Ok(model)) => crate::run::run_model(&model, scene, opts),
            Some(Err(e)) => Err(Error::Input(e)),
            None => Err(Error::UnknownModel { scene: scene.name.clone(), model: scene.model.clone() }),
        }
    }

    /// Runs `scene` with `opts` on the model its `model` key names, in
    /// memory: every output row in [`Report::table`], with the columns
    /// `trajectory.csv` would have, and nothing written
    /// ([`RunOptions::out`], `figures` and `report` are not read); the
    /// notes a file run prints on stderr are in [`Report::notes`]. The
    /// table's size is refused before the run as `trajectory.csv`'s would
    /// be ([`RunOptions::max_output_mb`]). `stop`, asked after every step,
    /// may end the run. What a library or a notebook embeds (the Python
    /// package's `ezy.run`).
    ///
    /// # Errors
    /// As [`App::run_scene`] (no file errors); [`Error::Stopped`] when
    /// `stop` asked.
    pub fn run_scene_in_memory(
        &self,
        scene: &Scene,
        opts: &RunOptions,
        stop: Option<StopHook<'_>>,
    ) -> Result<Report, Error> {
        match self.model_for(&scene.model) {
            Some(Ok(model)) => crate::run::run_model_in_memory(&model, scene, opts, stop),
            Some(Err(e)) => Err(Error::Input(e)),
            None => Err(Error::UnknownModel { scene: scene.name.clone(), model: scene.model.clone() }),
        }
    }

    /// Runs the work-precision ladder of `scene` and writes
    /// `precision.csv` and its figures into `out`.
    ///
    /// # Errors
    /// [`Error`] if the reference run fails, a saved ladder does not read
    /// or a file cannot be written; [`Error::UnknownModel`] for a key this
    /// application lacks.
    pub fn precision(&self, scene: &Scene, out: &Path) -> Result<precision::Report, Error> {
        self.precision_with(scene, out, &precision::PrecisionOptions::default())
    }

    /// [`App::precision`] with other tools' points over the
    /// work-precision diagram, or redrawing the figures of a saved ladder
    /// (see [`precision::PrecisionOptions`]).
    ///
    /// # Errors
    /// As [`App::precision`].
    pub fn precision_with(
        &self,
        scene: &Scene,
        out: &Path,
        opts: &precision::PrecisionOptions,
    ) -> Result<precision::Report, Error> {
        match self.model_for(&scene.model) {
            Some(Ok(model)) => precision::precision_model(&model, scene, out, opts),
            Some(Err(e)) => Err(Error::Input(e)),
            None => Err(Error::UnknownModel { scene: scene.name.clone(), model: scene.model.clone() }),
        }
    }

    /// The `ezy list` text: every model (key, doc, sizes, counts) and every
    /// scene (name, description).
    ///
    /// # Errors
    /// As [`App::scenes`].
    pub fn list(&self) -> Result<String, LoadError> {
        let scenes = self.scenes()?;
        let mut s = String::from("models:\n");
        for (key, model) in &self.models {
            let info = info_of(model, &[]).map_err(|e| LoadError::Registry(format!("model `{key}`: {}", e.message)))?;
            let counts: Vec<String> =
                info.params.iter().filter(|p| p.count).map(|p| format!("{} = {}", p.name, p.default)).collect();
            let counts = if counts.is_empty() { String::new() } else { format!(", {}", counts.join(", ")) };
            s.push_str(&format!("  {key:<26} {} (nq = {}, nc = {}{counts})\n", info.doc, info.nq(), info.nc()));
        }
        s.push_str("scenes:\n");
        for src in &scenes {
            s.push_str(&format!("  {:<26} {}\n", src.scene.name, src.scene.description));
        }
        Ok(s)
    }
}
