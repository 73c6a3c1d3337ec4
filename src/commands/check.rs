//! `ezy check MODEL`: the derived Jacobians and convective terms against
//! finite differences and dual numbers (the work: [`crate::testing`]).

use std::io::Write;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::{AnyModel, Model, ModelInfo};

use crate::app::{App, AppError};
use crate::cli::parse_set;
use crate::output::progress::Heartbeat;
use crate::session::with_sets;
use crate::testing;

/// Check the derived Jacobians and convective terms against finite differences.
#[derive(Args, Debug)]
struct CheckArgs {
    /// Model name (see `ezy list`), or the path of a model file (`.ezy`).
    model: String,
    /// Set a family count (or a parameter's centre) first (`--set N=3`); repeatable.
    #[arg(long = "set", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Number of random states (and random parameter sets) [default: 100;
    /// fewer above 3000 coordinates, where one state already checks every
    /// element of a family: states x coordinates about 3e5, at least 3].
    #[arg(long)]
    states: Option<usize>,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// The arguments of `ezy check`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    CheckArgs::augment_args(cmd)
}

/// Checks the model named and prints the table; fails when a term is off.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = CheckArgs::from_arg_matches(args)?;
    if args.states == Some(0) {
        return Err(AppError::Failed("--states = 0: check at least one state".into()));
    }
    let model = &app.model_or_error(&args.model)?;
    let (info, report) = check_model(model, &args.sets, args.states, args.seed).map_err(AppError::Failed)?;
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

/// `ezy check` on `proto` with `sets` applied: the sets, the number of
/// states (`None`: by the model's size), the seed; a heartbeat while it
/// takes long. Returns the model's description and the report.
fn check_model(
    proto: &AnyModel,
    sets: &[(String, f64)],
    states: Option<usize>,
    seed: u64,
) -> Result<(ModelInfo, testing::Report), String> {
    let m = with_sets(proto, sets)?;
    let info = m.info();
    let states = states.unwrap_or_else(|| testing::default_states(info.nq()));
    let beat = Heartbeat::start(format!("checking {}", info.name));
    let report = testing::check_derivatives_observed(&m, states, seed, |s| {
        beat.set(format!("checking {}: state {} of {states}", info.name, s + 1));
    });
    Ok((info, report))
}
