//! `ezy list`: the models and scenes, one line each ([`App::list`]).

use std::io::Write;

use clap::ArgMatches;

use crate::app::{App, AppError};

/// `ezy list` takes no arguments.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    cmd.about("List the models and scenes, one line each")
}

/// Prints the list.
pub(crate) fn exec(app: &App, _: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    Ok(out.write_all(app.list().map_err(AppError::failed)?.as_bytes())?)
}
