//! The commands of the command line, one file each (as cargo's
//! `src/bin/cargo/commands/`): its arguments (clap) and its `exec`, which
//! loads what the arguments name, calls the work (the run, the sweep, the
//! precision ladder, or the command's own below its `exec`) and prints
//! what it did. [`COMMANDS`] is the one list of them: adding a command is
//! a file here and a line there. A command imports no other command;
//! what they share is in [`crate::session`] and [`crate::cli`].

use std::io::Write;
use std::path::Path;

use clap::ArgMatches;
use ezy_scene::registry::SceneSource;
use ezy_scene::{FigureFormat, Scene, SceneError};

use crate::app::{App, AppError};

mod analyze;
mod animate;
mod bench;
mod check;
mod equations;
mod fit;
mod gait_optimize;
mod geometry;
mod linearize;
mod list;
mod optimize;
mod plan;
mod precision;
mod run;
mod scale;
mod sensitivity;
mod sweep;

/// A command of the command line.
pub(crate) struct Command {
    /// Its name (`ezy NAME`).
    pub name: &'static str,
    /// Its arguments and help, added to the subcommand `NAME`.
    pub cli: fn(clap::Command) -> clap::Command,
    /// Runs it on the application's models and scenes with the arguments
    /// parsed, writing what it prints to `out`.
    pub exec: fn(&App, &ArgMatches, &mut dyn Write) -> Result<(), AppError>,
    /// Whether the Python module offers it as a function of the same name
    /// ([`python_commands`]); not the ones that measure this machine
    /// (`precision`, `scale`, `bench`), write a video (`animate`) or list
    /// (`list`: the module's `models()` and `scenes()`).
    pub python: bool,
}

/// The commands the Python module offers, by name, in the order `ezy
/// --help` lists them (the command table's): its functions of the same
/// names take the command's options as keyword arguments.
pub fn python_commands() -> impl Iterator<Item = &'static str> {
    COMMANDS.iter().filter(|c| c.python).map(|c| c.name)
}

/// Every command, in the order `ezy --help` lists them.
pub(crate) const COMMANDS: &[Command] = &[
    Command { name: "run", cli: run::cli, exec: run::exec, python: true },
    Command { name: "list", cli: list::cli, exec: list::exec, python: false },
    Command { name: "precision", cli: precision::cli, exec: precision::exec, python: false },
    Command { name: "equations", cli: equations::cli, exec: equations::exec, python: true },
    Command { name: "check", cli: check::cli, exec: check::exec, python: true },
    Command { name: "scale", cli: scale::cli, exec: scale::exec, python: false },
    Command { name: "sweep", cli: sweep::cli, exec: sweep::exec, python: true },
    Command { name: "animate", cli: animate::cli, exec: animate::exec, python: false },
    Command { name: "bench", cli: bench::cli, exec: bench::exec, python: false },
    Command { name: "analyze", cli: analyze::cli, exec: analyze::exec, python: true },
    Command { name: "linearize", cli: linearize::cli, exec: linearize::exec, python: true },
    Command { name: "geometry", cli: geometry::cli, exec: geometry::exec, python: true },
    Command { name: "sensitivity", cli: sensitivity::cli, exec: sensitivity::exec, python: true },
    Command { name: "fit", cli: fit::cli, exec: fit::exec, python: true },
    Command { name: "optimize", cli: optimize::cli, exec: optimize::exec, python: true },
    Command { name: "gait-optimize", cli: gait_optimize::cli, exec: gait_optimize::exec, python: true },
    Command { name: "plan", cli: plan::cli, exec: plan::exec, python: true },
];

/// The command a bare `ezy` runs (with no arguments).
pub(crate) const DEFAULT: &str = "run";

/// PDF figures refused before any work where this build of ezy leaves out
/// its `pdf` feature ([`crate::render::plot::check_format`]): `--format`
/// if given, else the scene's `output.figure_format` (named with its file
/// and line); nothing to check with `figures` off.
fn check_figure_format(src: &SceneSource, format: Option<FigureFormat>, figures: bool) -> Result<(), AppError> {
    if !figures {
        return Ok(());
    }
    if let Some(f) = format {
        return crate::render::plot::check_format(f).map_err(|e| AppError::Failed(format!("--format {f}: {e}")));
    }
    crate::render::plot::check_format(src.scene.output.figure_format).map_err(|e| {
        let e = SceneError { path: vec!["output".into(), "figure_format".into()], message: e.to_string() };
        AppError::failed(Scene::locate_error(&src.text, &src.file, e))
    })
}

/// The scene named (or the default one) and the run options of a command
/// `command` that writes into `out` (default `out/COMMAND/SCENE`) and
/// draws figures unless `no_figures`; a PDF format this build cannot
/// write refused before any work.
///
/// # Errors
/// An unknown scene; a figure format this build lacks.
fn scene_and_options(
    app: &App,
    scene: Option<&str>,
    command: &str,
    (out, no_figures): (Option<std::path::PathBuf>, bool),
    overrides: &crate::cli::Overrides,
) -> Result<(SceneSource, crate::session::RunOptions), AppError> {
    let (_, src) = app.named_scene(scene)?;
    let opts = crate::session::RunOptions {
        out: out.unwrap_or_else(|| Path::new("out").join(command).join(&src.scene.name)),
        figures: !no_figures,
        ..overrides.options()
    };
    check_figure_format(&src, opts.figure_format, opts.figures)?;
    Ok((src, opts))
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
