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

use std::borrow::Cow;
use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Parser;
use ezy_core::effects::EffectKind;
use ezy_core::{AnyModel, Model, ModelInfo};
use ezy_scene::EffectKinds;
use ezy_scene::registry::{ModelCatalog, Register, SceneSource, check_scene, info_of};

use ezy_scene::{Scene, SceneError};

use crate::cli::{self, Cli, Command};
use crate::commands::run::{Report, RunOptions};
use crate::commands::{analyze, run};
use crate::{equations, precision, scale, sweep, testing};

/// What one command does with a model type, as plain function pointers
/// (one monomorphized copy per registered model), so the table holds
/// models of any type.
/// `NAME=VALUE` settings of parameters and family counts (`--set`).
type Sets = [(String, f64)];
/// What `check` and `scale` print: the model's description and the result.
type Described<T> = (ModelInfo, T);

/// `ezy check` on `proto` with `sets` applied: the sets, the number of
/// states (`None`: by the model's size), the seed; a heartbeat while it
/// takes long.
fn check_model(
    proto: &AnyModel,
    sets: &Sets,
    states: Option<usize>,
    seed: u64,
) -> Result<Described<testing::Report>, String> {
    let m = with_sets(proto, sets)?;
    let info = m.info();
    let states = states.unwrap_or_else(|| testing::default_states(info.nq()));
    let beat = crate::progress::Heartbeat::start(format!("checking {}", info.name));
    let report = testing::check_derivatives_observed(&m, states, seed, |s| {
        beat.set(format!("checking {}: state {} of {states}", info.name, s + 1));
    });
    Ok((info, report))
}

/// `proto` (a model at its defaults) with `sets` applied (parameters and family counts).
///
/// # Errors
/// An unknown parameter (listing the model's), a count that is not a whole
/// number >= 1, or one that makes a family refer to a missing element.
pub fn with_sets<M: Model>(proto: &M, sets: &[(String, f64)]) -> Result<M, String> {
    let mut m = proto.clone();
    let info = m.info();
    for (name, value) in sets {
        let i = info.param_index(name).ok_or_else(|| {
            let known: Vec<&str> = info.params.iter().map(|p| p.name).collect();
            format!("unknown parameter `{name}` in model {}; its parameters: {}", info.name, known.join(", "))
        })?;
        if info.params[i].count {
            ezy_scene::check_count(name, *value).map_err(|e| e.message)?;
        }
        m.set_param(i, *value);
    }
    m.check_counts()?;
    Ok(m)
}

/// The `name` a scene's text declares, read without parsing it: a
/// top-level line `name = "..."` (a basic string without escapes,
/// perhaps followed by a comment) before the first table header. `None`
/// when the text gives it otherwise; the caller then parses the text.
fn declared_name(text: &str) -> Option<&str> {
    for line in text.lines() {
        let line = line.trim_start();
        if line.starts_with('[') {
            return None;
        }
        let Some(rest) = line.strip_prefix("name").map(str::trim_start).and_then(|r| r.strip_prefix('=')) else {
            continue;
        };
        let rest = rest.trim_start().strip_prefix('"')?;
        let end = rest.find('"')?;
        let (value, after) = (&rest[..end], rest[end + 1..].trim());
        let plain = !value.is_empty() && !value.contains('\\') && (after.is_empty() || after.starts_with('#'));
        return plain.then_some(value);
    }
    None
}

/// A scene the application knows by name: its file as errors name it and
/// its text, or a path read when the scene is first needed.
#[derive(Debug, Clone)]
enum SceneEntry {
    Text { file: String, text: Cow<'static, str> },
    Path(PathBuf),
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
    Interrupted(crate::transaction::Interrupted),
    /// Writing to the output stream failed (a closed pipe ends quietly in
    /// [`App::main`]).
    #[error("writing the output: {0}")]
    Io(#[from] std::io::Error),
}

impl AppError {
    fn failed(e: impl std::fmt::Display) -> Self {
        Self::Failed(e.to_string())
    }

    /// A failed run or measurement; an interruption keeps its signal.
    fn from_run(e: run::Error) -> Self {
        match e.interrupted() {
            Some(i) => Self::Interrupted(i.clone()),
            None => Self::failed(e),
        }
    }
}

/// PDF figures refused before any work where this build of ezy leaves out
/// its `pdf` feature ([`crate::plot::check_format`]): `--format` if given,
/// else the scene's `output.figure_format` (named with its file and
/// line); nothing to check with `figures` off.
fn check_figure_format(
    src: &SceneSource,
    format: Option<ezy_scene::FigureFormat>,
    figures: bool,
) -> Result<(), AppError> {
    if !figures {
        return Ok(());
    }
    if let Some(f) = format {
        return crate::plot::check_format(f).map_err(|e| AppError::Failed(format!("--format {f}: {e}")));
    }
    crate::plot::check_format(src.scene.output.figure_format).map_err(|e| {
        let e = SceneError { path: vec!["output".into(), "figure_format".into()], message: e.to_string() };
        AppError::failed(Scene::locate_error(&src.text, &src.file, e))
    })
}

/// Why a scene could not be found or loaded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LoadError {
    /// Neither a known scene name nor a `.toml` file.
    #[error("unknown scene `{name}`; known scenes: {known} (or give a path to a .toml scene file)")]
    Unknown {
        /// What was asked for.
        name: String,
        /// The known names.
        known: String,
    },
    /// A bare name that is both a known scene and a file in the working
    /// directory.
    #[error(
        "`{name}` is both a known scene and a file in the working directory; write `./{name}` for the file or rename it"
    )]
    Ambiguous {
        /// What was asked for.
        name: String,
    },
    /// The application's table is inconsistent (a key or scene name given
    /// twice).
    #[error("{0}")]
    Registry(String),
    /// The file is bad.
    #[error(transparent)]
    File(#[from] ezy_scene::SceneFileError),
}

/// The models and scenes an `ezy` command line knows, and the commands
/// over them: `run`, `list`, `precision`, `equations`, `check`, `scale`.
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
        if self.models.iter().any(|(k, _)| k == key) {
            self.errors.push(format!("model key `{key}` is registered twice"));
        } else if key.is_empty() || key.chars().any(char::is_whitespace) {
            self.errors.push(format!("model key `{key}` must be non-empty and without spaces"));
        } else {
            self.models.push((key.to_string(), AnyModel::new(M::default())));
        }
    }
}

impl ModelCatalog for App {
    fn keys(&self) -> Vec<&str> {
        self.models.iter().map(|(k, _)| k.as_str()).collect()
    }
    fn info_with(&self, key: &str, params: &[(String, f64)]) -> Option<Result<ModelInfo, SceneError>> {
        self.registered(key).map(|model| info_of(model, params))
    }
    fn effect_kinds(&self) -> Option<&EffectKinds> {
        Some(&self.kinds)
    }
    fn check_user_effects(&self, key: &str, checked: &ezy_scene::Checked) -> Result<(), SceneError> {
        self.registered(key).map_or(Ok(()), |model| ezy_scene::registry::check_user_effects(model, checked))
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

    /// The scene `run` takes when none is named (`App::new`: `drive`).
    #[must_use]
    pub fn default_scene(mut self, name: &str) -> Self {
        self.default_scene = name.to_string();
        self
    }

    fn registered(&self, key: &str) -> Option<&AnyModel> {
        self.models.iter().find(|(k, _)| k == key).map(|(_, model)| model)
    }

    fn registry_ok(&self) -> Result<(), LoadError> {
        match self.errors.first() {
            Some(e) => Err(LoadError::Registry(e.clone())),
            None => Ok(()),
        }
    }

    /// Every known scene, read, parsed and checked against its model, in
    /// the order added.
    ///
    /// # Errors
    /// [`LoadError`]: a table mistake, an unreadable or bad scene file
    /// (file, line, column, key), or two scenes with one name.
    pub fn scenes(&self) -> Result<Vec<SceneSource>, LoadError> {
        self.registry_ok()?;
        let mut out: Vec<SceneSource> = Vec::new();
        for entry in &self.scenes {
            let src = match entry {
                SceneEntry::Text { file, text } => {
                    let scene = Scene::from_toml(text, file)?;
                    check_scene(self, scene, text, file)?
                }
                SceneEntry::Path(path) => self.load_file(path)?,
            };
            if let Some(first) = out.iter().find(|s| s.scene.name == src.scene.name) {
                return Err(LoadError::Registry(format!(
                    "scene `{}` is given twice: in {} and in {}",
                    src.scene.name, first.file, src.file
                )));
            }
            out.push(src);
        }
        Ok(out)
    }

    fn load_file(&self, path: &Path) -> Result<SceneSource, LoadError> {
        let (scene, text) = Scene::read(path)?;
        Ok(check_scene(self, scene, &text, &path.display().to_string())?)
    }

    /// A known scene by name, or a scene file by path: a name containing
    /// `/` (or the platform's separator) or ending in `.toml` is a path,
    /// any other name is a known scene. A bare name that is both a known
    /// scene and a file in the working directory is refused as ambiguous.
    ///
    /// # Errors
    /// [`LoadError`]: unknown or ambiguous name, unreadable file, or a bad
    /// scene file with its line, column and key.
    pub fn load_scene(&self, name_or_path: &str) -> Result<SceneSource, LoadError> {
        self.registry_ok()?;
        if is_scene_path(name_or_path) {
            return self.load_file(Path::new(name_or_path));
        }
        if let Some(src) = self.quick_scene(name_or_path)? {
            return Ok(src);
        }
        let all = self.scenes()?;
        let known = all.iter().map(|s| s.scene.name.clone()).collect::<Vec<_>>().join(", ");
        match all.into_iter().find(|s| s.scene.name == name_or_path) {
            Some(_) if Path::new(name_or_path).is_file() => {
                Err(LoadError::Ambiguous { name: name_or_path.to_string() })
            }
            Some(s) => Ok(s),
            None => Err(LoadError::Unknown { name: name_or_path.to_string(), known }),
        }
    }

    /// The known scene `name` with only its own text parsed and checked,
    /// when every scene declares its name plainly ([`declared_name`]) and
    /// the names are distinct; `None` leaves the lookup to
    /// [`App::scenes`], which parses them all (and reports what is wrong
    /// with any). Parsing and checking every built-in scene took most
    /// of a short run's setup.
    fn quick_scene(&self, name: &str) -> Result<Option<SceneSource>, LoadError> {
        let mut found = None;
        let mut names = std::collections::HashSet::new();
        for entry in &self.scenes {
            let SceneEntry::Text { file, text } = entry else { return Ok(None) };
            let Some(declared) = declared_name(text) else { return Ok(None) };
            if !names.insert(declared) {
                return Ok(None);
            }
            if declared == name {
                found = Some((file, text));
            }
        }
        let Some((file, text)) = found else { return Ok(None) };
        if Path::new(name).is_file() {
            return Err(LoadError::Ambiguous { name: name.to_string() });
        }
        let scene = Scene::from_toml(text, file)?;
        if scene.name != name {
            return Ok(None);
        }
        Ok(Some(check_scene(self, scene, text, file)?))
    }

    fn model_or_error(&self, key: &str) -> Result<&AnyModel, AppError> {
        self.registry_ok().map_err(AppError::failed)?;
        self.registered(key)
            .ok_or_else(|| AppError::Failed(format!("unknown model `{key}`; known models: {}", self.keys().join(", "))))
    }

    /// Runs `scene` with `opts` on the model its `model` key names: writes
    /// `trajectory.csv` and the figures into `opts.out`.
    ///
    /// # Errors
    /// [`run::Error`] naming the bad setting, parameter, or file;
    /// [`run::Error::UnknownModel`] for a key this application lacks.
    pub fn run_scene(&self, scene: &Scene, opts: &RunOptions) -> Result<Report, run::Error> {
        match self.registered(&scene.model) {
            Some(model) => run::run_model(model, scene, opts),
            None => Err(run::Error::UnknownModel { scene: scene.name.clone(), model: scene.model.clone() }),
        }
    }

    /// Runs `scene` with `opts` on the model its `model` key names, in
    /// memory: every output row in [`Report::table`], no file written
    /// ([`run::run_model_in_memory`]); `stop`, asked after every step,
    /// may end the run.
    ///
    /// # Errors
    /// As [`run::run_model_in_memory`]; [`run::Error::UnknownModel`] for
    /// a key this application lacks.
    pub fn run_scene_in_memory(
        &self,
        scene: &Scene,
        opts: &RunOptions,
        stop: Option<run::StopHook<'_>>,
    ) -> Result<Report, run::Error> {
        match self.registered(&scene.model) {
            Some(model) => run::run_model_in_memory(model, scene, opts, stop),
            None => Err(run::Error::UnknownModel { scene: scene.name.clone(), model: scene.model.clone() }),
        }
    }

    /// Runs the work-precision ladder of `scene` and writes
    /// `precision.csv` and its figures into `out`.
    ///
    /// # Errors
    /// As [`precision::precision_model`]; [`run::Error::UnknownModel`] for
    /// a key this application lacks.
    pub fn precision(&self, scene: &Scene, out: &Path) -> Result<precision::Report, run::Error> {
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
    ) -> Result<precision::Report, run::Error> {
        match self.registered(&scene.model) {
            Some(model) => precision::precision_model(model, scene, out, opts),
            None => Err(run::Error::UnknownModel { scene: scene.name.clone(), model: scene.model.clone() }),
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

    /// Parses `std::env::args` like the `ezy` binary, runs the command,
    /// prints its output on stdout and any error on stderr (`error: ...`).
    /// Returns success, or failure (1) when the command failed; a usage
    /// mistake exits with clap's status (2) and `--help` with 0. A closed
    /// stdout (`... | head`) ends quietly. `SIGINT` and `SIGTERM` stop a
    /// run that is writing its output without changing the output directory
    /// (see [`crate::transaction::handle_signals`]) and exit with 130 and
    /// 143.
    pub fn main(self) -> ExitCode {
        crate::transaction::handle_signals();
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        match self.run_cli(std::env::args_os(), &mut out) {
            Ok(()) => ExitCode::SUCCESS,
            Err(AppError::Usage(e)) => e.exit(),
            Err(AppError::Io(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
            Err(AppError::Interrupted(i)) => {
                let _ = out.flush();
                eprintln!("error: {i}");
                ExitCode::from(i.signal.exit_code())
            }
            Err(e) => {
                let _ = out.flush();
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        }
    }

    /// Parses `args` (the first is the program name, as in
    /// `std::env::args_os`) and runs the command, writing what it prints to
    /// `out`; warnings and the progress bar go to stderr. This is
    /// [`App::main`] without the process around it, for tests and for
    /// programs that run commands themselves. From its first call on,
    /// the process spells the settings its messages advise as this
    /// command line's flags (`--dt`, `--formulation dae`:
    /// [`ezy_core::spell_settings_as_flags`]).
    ///
    /// # Errors
    /// [`AppError`]: a usage mistake, a failed command (its message names
    /// the culprit), or a failed write to `out`.
    pub fn run_cli<I, T>(&self, args: I, out: &mut dyn Write) -> Result<(), AppError>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        ezy_core::spell_settings_as_flags();
        let cli = Cli::try_parse_from(args)?;
        match cli.command {
            None => self.cmd_run(cli::RunArgs { scene: None, ..cli::RunArgs::default() }, out),
            Some(Command::Run(args)) => self.cmd_run(args, out),
            Some(Command::List) => Ok(out.write_all(self.list().map_err(AppError::failed)?.as_bytes())?),
            Some(Command::Precision(args)) => self.cmd_precision(args, out),
            Some(Command::Sweep(args)) => self.cmd_sweep(*args, out),
            Some(Command::Animate(args)) => self.cmd_animate(args, out),
            Some(Command::Bench(args)) => self.cmd_bench(args, out),
            Some(Command::Analyze(args)) => self.cmd_analyze(args, out),
            Some(Command::Linearize(args)) => self.cmd_linearize(args, out),
            Some(Command::Equations(args)) => {
                let model = self.model_or_error(&args.model)?;
                let text = with_sets(model, &args.sets)
                    .map(|m| equations::render(&m, args.format.into()))
                    .map_err(AppError::Failed)?;
                Ok(out.write_all(text.as_bytes())?)
            }
            Some(Command::Check(args)) => {
                if args.states == Some(0) {
                    return Err(AppError::Failed("--states = 0: check at least one state".into()));
                }
                let model = self.model_or_error(&args.model)?;
                let (info, report) =
                    check_model(model, &args.sets, args.states, args.seed).map_err(AppError::Failed)?;
                out.write_all(report.table(info.name).as_bytes())?;
                if report.passed() {
                    Ok(())
                } else {
                    Err(AppError::Failed(format!(
                        "model `{}`: a derived term differs from its reference by more than its tolerance ({})",
                        info.name,
                        report.worst()
                    )))
                }
            }
            Some(Command::Scale(args)) => {
                if args.n.is_empty() || args.batches == 0 {
                    return Err(AppError::Failed("--n needs at least one size and --batches at least 1".into()));
                }
                let model = self.model_or_error(&args.model)?;
                let csv = matches!(args.format, cli::ScaleFormat::Csv);
                let (info, points) = scale::scale(model, &args.n, args.batches, args.kkt.into())
                    .map(|p| (model.info(), p))
                    .map_err(AppError::failed)?;
                Ok(out.write_all(scale::render(info.name, &points, csv).as_bytes())?)
            }
        }
    }

    fn cmd_precision(&self, args: cli::PrecisionArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let src = self.load_scene(&args.scene).map_err(AppError::failed)?;
        let scene = &src.scene;
        let dir = args.out.unwrap_or_else(|| PathBuf::from("out").join("precision").join(&scene.name));
        let overlay = match &args.overlay {
            Some(path) => precision::read_overlay(path).map_err(AppError::Failed)?,
            None => Vec::new(),
        };
        let opts = precision::PrecisionOptions { overlay, replot: args.replot };
        let report = self.precision_with(scene, &dir, &opts).map_err(AppError::from_run)?;
        if args.replot {
            let files: Vec<String> = report.files.iter().map(|f| format!("redrew {}\n", f.display())).collect();
            return committed(out, &files.concat(), &dir);
        }
        let text = match args.format {
            cli::Format::Table => {
                let mut text = precision::table(&report);
                for f in &report.files {
                    text.push_str(&format!("wrote {}\n", f.display()));
                }
                text
            }
            cli::Format::Csv => precision::csv(&report.rows),
        };
        committed(out, &text, &dir)
    }

    /// The sweep `args` define on the scene `src` (named `name` on the
    /// command line): axes, metrics, overrides, output directory, jobs.
    fn sweep_job(&self, src: &SceneSource, name: &str, args: &cli::SweepArgs) -> Result<sweep::SweepJob, AppError> {
        let scene = &src.scene;
        let mut axes = Vec::new();
        for g in &args.grids {
            axes.push(sweep::plan::grid(g).map_err(|e| AppError::Failed(format!("--grid {e}")))?);
        }
        for l in &args.lists {
            axes.push(sweep::plan::list(l).map_err(|e| AppError::Failed(format!("--list {e}")))?);
        }
        for r in &args.randoms {
            axes.push(sweep::plan::random(r).map_err(|e| AppError::Failed(format!("--random {e}")))?);
        }
        if let Some(a) = axes.iter().find(|a| args.overrides.sets.iter().any(|(n, _)| *n == a.name)) {
            return Err(AppError::Failed(format!("`{}` is both swept and fixed by --set", a.name)));
        }
        let plan = sweep::Plan::new(axes, args.samples, args.seed).map_err(AppError::Failed)?;
        let metrics = args
            .metrics
            .iter()
            .map(|m| m.parse::<sweep::Metric>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(AppError::Failed)?;
        // at most the cores this process may use: more threads only
        // contend (and a huge --jobs would start them all)
        let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
        let jobs = match args.jobs {
            Some(0) => return Err(AppError::Failed("--jobs 0: give at least 1".into())),
            Some(j) => j.min(cores),
            None => cores,
        };
        let mut definition = Vec::new();
        for (flag, list) in [("--grid", &args.grids), ("--list", &args.lists), ("--random", &args.randoms)] {
            for v in list {
                definition.extend([flag.to_string(), v.trim().to_string()]);
            }
        }
        if let Some(n) = args.samples {
            definition.extend(["--samples".into(), n.to_string(), "--seed".into(), args.seed.to_string()]);
        }
        for m in &metrics {
            definition.extend(["--metric".into(), m.text.clone()]);
        }
        definition.extend(args.overrides.to_args());
        let scene_ref = if is_scene_path(name) {
            std::fs::canonicalize(name).map_or_else(|_| name.to_string(), |p| p.display().to_string())
        } else {
            scene.name.clone()
        };
        let manifest = sweep::Manifest {
            scene: scene_ref,
            scene_fingerprint: sweep::fingerprint(&src.text),
            runs: plan.runs(),
            args: definition,
            shard: args.shard.map(|(k, n)| format!("{k}/{n}")),
        };
        let out = args.out.clone().unwrap_or_else(|| PathBuf::from("out").join("sweep").join(&scene.name));
        Ok(sweep::SweepJob {
            scene: scene.clone(),
            manifest,
            plan,
            metrics,
            opts: args.overrides.options(),
            out,
            jobs,
            shard: args.shard,
            save_runs: args.save_runs,
            figures: !args.no_figures,
            progress: true,
            check_only: false,
        })
    }

    fn cmd_sweep(&self, args: cli::SweepArgs, out: &mut dyn Write) -> Result<(), AppError> {
        if let Some(cli::SweepCommand::Merge(m)) = args.command {
            return self.cmd_merge(m, out);
        }
        let Some(name) = args.scene.clone() else {
            return Err(AppError::Failed(
                "sweep needs a scene and at least one axis: `ezy sweep SCENE --grid NAME=START:STOP:COUNT` (see `ezy sweep --help`)".into(),
            ));
        };
        let src = self.load_scene(&name).map_err(AppError::failed)?;
        let mut job = self.sweep_job(&src, &name, &args)?;
        // the sweep's own figures, and each saved run's
        check_figure_format(&src, job.opts.figure_format, job.figures || job.save_runs)?;
        let model = self.model_or_error(&src.scene.model)?;
        if let Some(file) = &args.emit_slurm {
            if args.shard.is_some() {
                return Err(AppError::Failed("--emit-slurm writes the shards itself: leave out --shard".into()));
            }
            job.check_only = true;
            sweep::sweep_model(model, &job).map_err(AppError::failed)?;
            let runs = job.plan.runs();
            let tasks = args.tasks.unwrap_or(4).min(runs);
            let dir =
                std::path::absolute(&job.out).map_err(|e| AppError::Failed(format!("{}: {e}", job.out.display())))?;
            let exe =
                std::env::current_exe().map_err(|e| AppError::Failed(format!("the path of this program: {e}")))?;
            let text =
                sweep::slurm::script(&exe, &job.manifest.scene, &job.manifest.args, &dir, tasks, runs, &src.scene.name)
                    .map_err(AppError::Failed)?;
            // the scene's file (a known scene is none), never replaced
            let scene_file = Path::new(&job.manifest.scene);
            let scene_file = scene_file.is_absolute().then_some(scene_file);
            sweep::slurm::write_script(file, &text, scene_file).map_err(AppError::Failed)?;
            let msg = format!(
                "wrote {} ({runs} runs in {tasks} array tasks, merged into {}); submit it with `bash {}`\n",
                file.display(),
                dir.display(),
                file.display()
            );
            return Ok(out.write_all(msg.as_bytes())?);
        }
        if let Some(asked) = args.jobs.filter(|&j| j > job.jobs) {
            eprintln!("note: --jobs {asked} capped to {}, the number of cores this process may use", job.jobs);
        }
        let report = sweep::sweep_model(model, &job).map_err(|e| match e {
            sweep::SweepError::Interrupted(i) => AppError::Interrupted(i),
            e => AppError::failed(e),
        })?;
        committed(out, &report.summary(&src.scene.name), &job.out)
    }

    fn cmd_merge(&self, args: cli::MergeArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let (manifest, mut files) = sweep::merge(&args.dirs, &args.out).map_err(AppError::Failed)?;
        let mut notes = Vec::new();
        if !args.no_figures {
            // the plan and the metrics, from the definition the shards share
            let mut argv = vec!["ezy".to_string(), "sweep".into(), manifest.scene.clone()];
            argv.extend(manifest.args.iter().cloned());
            let parsed = match Cli::try_parse_from(&argv) {
                Ok(Cli { command: Some(Command::Sweep(a)) }) => *a,
                Ok(_) => {
                    return Err(AppError::Failed(format!("the shards' sweep.toml does not parse: {}", argv.join(" "))));
                }
                Err(e) => {
                    let why = e.to_string();
                    let why = why.lines().next().unwrap_or_default().trim_start_matches("error: ");
                    return Err(AppError::Failed(format!(
                        "the shards' sweep.toml does not parse: {}: {why}",
                        argv.join(" ")
                    )));
                }
            };
            let src = self.load_scene(&manifest.scene).map_err(AppError::failed)?;
            let job = self.sweep_job(&src, &manifest.scene, &parsed)?;
            check_figure_format(&src, job.opts.figure_format, true)?;
            let info = info_of(self.model_or_error(&src.scene.model)?, &[]).map_err(|e| AppError::Failed(e.message))?;
            let look = job.opts.look(&job.scene);
            let (f, n) = sweep::figure::draw(&args.out, &job.plan, &job.metrics, &info, look).map_err(|e| match e {
                sweep::SweepError::Interrupted(i) => AppError::Interrupted(i),
                e => AppError::failed(e),
            })?;
            files.extend(f);
            notes = n;
        }
        let mut text =
            format!("merged {} shards: {} runs into {}\n", args.dirs.len(), manifest.runs, args.out.display());
        for n in notes {
            text.push_str(&format!("  note: {n}\n"));
        }
        for f in files {
            text.push_str(&format!("  wrote {}\n", f.display()));
        }
        committed(out, &text, &args.out)
    }

    /// The scene a command names (`given`), or the default scene, loaded;
    /// with the name as given.
    fn named_scene(&self, given: Option<&str>) -> Result<(String, SceneSource), AppError> {
        let name = given.map_or_else(|| self.default_scene.clone(), str::to_string);
        if name.is_empty() {
            return Err(AppError::Failed("no scene given and this program has no default scene".into()));
        }
        let src = self.load_scene(&name).map_err(AppError::failed)?;
        Ok((name, src))
    }

    fn cmd_bench(&self, args: cli::BenchArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let (name, src) = self.named_scene(args.scene.as_deref())?;
        let scene = &src.scene;
        let model = self.model_or_error(&scene.model)?;
        // `--repeat` is at most bench::MAX_REPEAT (its parser), and
        // bench_model refuses more for callers that build the arguments
        let repeat = usize::try_from(args.repeat).unwrap_or(usize::MAX);
        let mut rows = crate::bench::bench_model(model, scene, repeat).map_err(AppError::from_run)?;
        if !args.no_process {
            // this very program, started anew for each setting: parse,
            // setup, integration and CSV, no figures
            let exe = std::env::current_exe().map_err(|e| AppError::Failed(format!("finding this program: {e}")))?;
            let tmp = tempfile::tempdir().map_err(|e| AppError::Failed(format!("a scratch directory: {e}")))?;
            let beat = crate::progress::Heartbeat::start(format!("bench {name}: timing the run processes"));
            let n_rows = rows.len();
            for (k, row) in rows.iter_mut().enumerate() {
                let dir = tmp.path().join(k.to_string());
                let mut times = Vec::new();
                for r in 0..repeat {
                    beat.set(format!(
                        "bench {name}: process of setting {} of {n_rows}, run {} of {repeat}",
                        k + 1,
                        r + 1
                    ));
                    let start = std::time::Instant::now();
                    let status = std::process::Command::new(&exe)
                        .arg("run")
                        .arg(&name)
                        .args(&row.args)
                        .arg("--no-figures")
                        .arg("--out")
                        .arg(&dir)
                        .stdout(std::process::Stdio::null())
                        .stderr(std::process::Stdio::null())
                        .status()
                        .map_err(|e| AppError::Failed(format!("starting {}: {e}", exe.display())))?;
                    if !status.success() {
                        return Err(AppError::Failed(format!("`run {name} {}` failed: {status}", row.args.join(" "))));
                    }
                    times.push(start.elapsed().as_secs_f64());
                }
                row.process_s = Some(crate::bench::median(&mut times));
            }
        }
        Ok(out.write_all(crate::bench::table(&scene.name, &rows).as_bytes())?)
    }

    fn cmd_animate(&self, args: cli::AnimateArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let (_, src) = self.named_scene(args.scene.as_deref())?;
        let scene = &src.scene;
        let anim = args.options(&scene.name).map_err(AppError::Failed)?;
        let opts = args.overrides.options();
        let model = self.model_or_error(&scene.model)?;
        let report = crate::animate::animate_model(model, scene, &opts, &anim).map_err(|e| match e {
            crate::animate::AnimateError::Run(e) => AppError::from_run(e),
            other => AppError::failed(other),
        })?;
        let dir = anim.out.parent().unwrap_or(Path::new("."));
        committed(out, &report.summary(&anim), dir)
    }

    fn cmd_analyze(&self, args: cli::AnalyzeArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let (_, src) = self.named_scene(args.scene.as_deref())?;
        let scene = &src.scene;
        let continuation = match &args.continuation {
            Some(text) => {
                let axis = sweep::plan::grid(text).map_err(|e| AppError::Failed(format!("--continue {e}")))?;
                let n = axis.values.count().unwrap_or(0);
                if n > analyze::MAX_CONTINUATION {
                    return Err(AppError::Failed(format!(
                        "--continue `{text}`: {n} values is more than {}, the most a continuation takes",
                        analyze::MAX_CONTINUATION
                    )));
                }
                Some((axis.name.clone(), (0..n).map(|k| axis.values.get(k)).collect()))
            }
            None => None,
        };
        let opts = analyze::AnalyzeOptions {
            run: RunOptions {
                out: args.out.unwrap_or_else(|| PathBuf::from("out").join("analyze").join(&scene.name)),
                figures: !args.no_figures,
                progress: true,
                ..args.overrides.options()
            },
            period: args.period,
            energy: args.energy,
            continuation,
        };
        check_figure_format(&src, opts.run.figure_format, opts.run.figures)?;
        let model = self.model_or_error(&scene.model)?;
        let report = analyze::analyze_model(model, scene, &opts).map_err(AppError::from_run)?;
        committed(out, &analyze::summary(&scene.name, &report), &opts.run.out)
    }

    fn cmd_linearize(&self, args: cli::LinearizeArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let (_, src) = self.named_scene(args.scene.as_deref())?;
        let scene = &src.scene;
        let opts = analyze::LinearizeOptions {
            run: RunOptions {
                out: args.out.unwrap_or_else(|| PathBuf::from("out").join("linearize").join(&scene.name)),
                ..args.overrides.options()
            },
            at: args.at,
            inputs: args.inputs,
        };
        let model = self.model_or_error(&scene.model)?;
        let report = analyze::linearize_model(model, scene, &opts).map_err(AppError::from_run)?;
        committed(out, &analyze::linearize_summary(&scene.name, &report), &opts.run.out)
    }

    fn cmd_run(&self, args: cli::RunArgs, out: &mut dyn Write) -> Result<(), AppError> {
        let (name, src) = self.named_scene(args.scene.as_deref())?;
        let scene = &src.scene;
        // a scene file given by its path: the report's command line names it
        let opts = RunOptions { scene_file: is_scene_path(&name).then(|| name.clone()), ..args.options(&scene.name) };
        check_figure_format(&src, opts.figure_format, opts.figures)?;
        let report = self.run_scene(scene, &opts).map_err(AppError::from_run)?;
        for w in &report.warnings {
            eprintln!("warning: {w}");
        }
        for n in &report.notes {
            eprintln!("note: {n}");
        }
        committed(out, &run::summary(&scene.name, &report), &opts.out)
    }
}

/// Whether a scene given on the command line is a file's path rather than
/// a known scene's name: it contains `/` (or the platform's separator) or
/// ends in `.toml` ([`App::load_scene`]).
fn is_scene_path(name: &str) -> bool {
    name.ends_with(".toml") || name.contains('/') || name.contains(std::path::MAIN_SEPARATOR)
}

/// Writes `text`, the report of a command whose output is already
/// committed in `dir`: a failure to write it says that the output is
/// there (exit 1), a closed pipe ends quietly (exit 0, as for any reader
/// that stops early).
fn committed(out: &mut dyn Write, text: &str, dir: &Path) -> Result<(), AppError> {
    out.write_all(text.as_bytes()).and_then(|()| out.flush()).map_err(|e| {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            AppError::Io(e)
        } else {
            AppError::Failed(format!(
                "the run finished and its output is in {}, but its report could not be written to standard output: {e}",
                dir.display()
            ))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::declared_name;

    #[test]
    fn declared_names_are_read_only_when_plain() {
        assert_eq!(declared_name("# c\nname = \"drive\"\nmodel = \"m\"\n"), Some("drive"));
        assert_eq!(declared_name("name=\"a-b\"   # the scene\n[initial]\n"), Some("a-b"));
        assert_eq!(declared_name("model = \"m\"\nnames = 1\nname = \"x\"\n"), Some("x"));
        // anything else is left to the TOML parser
        for text in [
            "[output]\nname = \"x\"\n",
            "name = 'x'\n",
            "name = \"a\\u0041\"\n",
            "name = \"\"\"x\"\"\"\n",
            "name = \"x\" extra\n",
            "name = \"\"\n",
            "model = \"m\"\n",
        ] {
            assert_eq!(declared_name(text), None, "{text}");
        }
    }
}
