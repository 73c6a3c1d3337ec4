//! `ezy precision SCENE`: error against wall time over a ladder of
//! integrators and settings (the work: [`crate::precision`]).

use std::io::Write;
use std::path::PathBuf;

use clap::{ArgMatches, Args, FromArgMatches, ValueEnum};

use super::committed;
use crate::app::{App, AppError};
use crate::precision;

/// Measure error against wall time over a ladder of integrators and settings.
#[derive(Args, Debug)]
struct PrecisionArgs {
    /// Scene name (see `ezy list`).
    scene: String,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value = "table")]
    format: Format,
    /// Directory for precision.csv and the figures [default: out/precision/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Draw other tools' points over the work-precision diagram: a CSV
    /// file with the header label,wall_s,error (wall time [s], max state
    /// error at the final time), one point per row.
    #[arg(long, value_name = "FILE")]
    overlay: Option<PathBuf>,
    /// Run no ladder: redraw the figures from the precision.csv already in
    /// the output directory (with --overlay; the drift figure's two short
    /// runs are still run).
    #[arg(long)]
    replot: bool,
}

/// What `ezy precision` prints.
#[derive(ValueEnum, Clone, Copy, Debug)]
enum Format {
    /// A table for people.
    Table,
    /// CSV: method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual.
    Csv,
}

/// The arguments of `ezy precision`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    PrecisionArgs::augment_args(cmd)
}

/// Runs the ladder (or redraws its figures) and prints the table or CSV.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = PrecisionArgs::from_arg_matches(args)?;
    let src = app.load_scene(&args.scene).map_err(AppError::failed)?;
    let scene = &src.scene;
    let dir = args.out.unwrap_or_else(|| PathBuf::from("out").join("precision").join(&scene.name));
    let overlay = match &args.overlay {
        Some(path) => precision::read_overlay(path).map_err(AppError::Failed)?,
        None => Vec::new(),
    };
    let opts = precision::PrecisionOptions { overlay, replot: args.replot };
    let report = app.precision_with(scene, &dir, &opts).map_err(AppError::from_run)?;
    if args.replot {
        let files: Vec<String> = report.files.iter().map(|f| format!("redrew {}\n", f.display())).collect();
        return committed(out, &files.concat(), &dir);
    }
    let text = match args.format {
        Format::Table => {
            let mut text = precision::table(&report);
            for f in &report.files {
                text.push_str(&format!("wrote {}\n", f.display()));
            }
            text
        }
        Format::Csv => precision::csv(&report.rows),
    };
    committed(out, &text, &dir)
}
