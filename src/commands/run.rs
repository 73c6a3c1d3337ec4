//! `ezy run [SCENE | FILE.toml]`: run a scene and write `trajectory.csv`,
//! its figures and, with `--report`, `report.html` (the run itself:
//! [`crate::App::run_scene`]).

use std::io::Write;
use std::path::PathBuf;

use clap::{ArgMatches, Args, FromArgMatches};

use super::{check_figure_format, committed};
use crate::app::scenes::is_scene_path;
use crate::app::{App, AppError};
use crate::cli::{Overrides, parse_positive};
use crate::session::{RunOptions, summary};

/// Run a scene and write trajectory.csv and its figures (default: drive).
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct RunArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file (a name with `/` or ending in `.toml`).
    scene: Option<String>,
    /// Output directory [default: out/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    overrides: Overrides,
    /// Refuse runs whose trajectory.csv would be larger than this many MB
    /// (estimated before the run) [default: 1000].
    #[arg(long, value_name = "MB", value_parser = parse_positive)]
    max_output_mb: Option<f64>,
    /// Skip the figures (CSV only).
    #[arg(long)]
    no_figures: bool,
    /// Also write report.html: the summary, the energy ledger, an
    /// animation, every figure and the settings to reproduce the run, in
    /// one self-contained file.
    #[arg(long)]
    report: bool,
}

impl RunArgs {
    /// The run's overrides; the output directory defaults to `out/SCENE`.
    fn options(self, scene: &str) -> RunOptions {
        RunOptions {
            out: self.out.unwrap_or_else(|| PathBuf::from("out").join(scene)),
            figures: !self.no_figures,
            report: self.report,
            progress: true,
            max_output_mb: self.max_output_mb,
            ..self.overrides.options()
        }
    }
}

/// The arguments of `ezy run`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    RunArgs::augment_args(cmd)
}

/// Runs the scene named (or the default scene), prints the summary.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = RunArgs::from_arg_matches(args)?;
    let (name, src) = app.named_scene(args.scene.as_deref())?;
    let scene = &src.scene;
    // a scene file given by its path: the report's command line names it
    let opts = RunOptions { scene_file: is_scene_path(&name).then(|| name.clone()), ..args.options(&scene.name) };
    check_figure_format(&src, opts.figure_format, opts.figures)?;
    let report = app.run_scene(scene, &opts).map_err(AppError::from_run)?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    for n in &report.notes {
        eprintln!("note: {n}");
    }
    committed(out, &summary(&scene.name, &report), &opts.out)
}
