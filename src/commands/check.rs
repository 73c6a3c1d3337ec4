//! `ezy check MODEL`: the derived Jacobians and convective terms against
//! finite differences and dual numbers (the work: [`crate::testing`]).

use std::io::Write;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::{AnyModel, Model, ModelInfo};

use crate::app::{App, AppError};
use crate::cli::parse_set;
use crate::output::progress::Heartbeat;
use crate::output::transaction::pending;
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
    /// element of a family: states x coordinates about 3e5, at least 3;
    /// at most states x coordinates = 1e8].
    #[arg(long)]
    states: Option<usize>,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Most states x coordinates `ezy check` takes (`--states`): 1e8, checked
/// before any state is drawn.
const MAX_CHECK_WORK: usize = 100_000_000;

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
    let work = states.saturating_mul(info.nq().max(1));
    if work > MAX_CHECK_WORK {
        return Err(format!(
            "--states {states}: {states} states x {} coordinates of {} = {:.1e}, more than the {:.0e} a check takes (its time grows with the product: 1.8e7, the snake of 60 links at 100,000 states, takes some 10 s); give at most {} states",
            info.nq(),
            info.name,
            work as f64,
            MAX_CHECK_WORK as f64,
            (MAX_CHECK_WORK / info.nq().max(1)).max(1)
        ));
    }
    let beat = Heartbeat::start(format!("checking {}", info.name));
    // a stop asked (Ctrl-C in the Python package) ends it between states
    let mut reached = 0;
    let report = testing::check_derivatives_until(&m, states, seed, |s| {
        beat.set(format!("checking {}: state {} of {states}", info.name, s + 1));
        reached = s + 1;
        pending().is_none()
    })
    .ok_or_else(|| format!("the check of {} was stopped at state {reached} of {states}", info.name))?;
    Ok((info, report))
}
