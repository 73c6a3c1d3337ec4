//! The command line's entry: [`App::main`] and [`App::run_cli`] parse the
//! arguments against the table of commands ([`crate::commands::COMMANDS`])
//! and run the one named. The top floor of the crate: the commands sit
//! below it and take the [`App`] (models and scenes) as their context, so
//! that neither the commands nor the catalog import this dispatch.

use std::ffi::OsString;
use std::io::Write;
use std::process::ExitCode;

use crate::app::{App, AppError};
use crate::commands::{COMMANDS, DEFAULT};

impl App {
    /// Parses `std::env::args` like the `ezy` binary, runs the command,
    /// prints its output on stdout and any error on stderr (`error: ...`).
    /// Returns success, or failure (1) when the command failed; a usage
    /// mistake exits with clap's status (2) and `--help` with 0. A closed
    /// stdout (`... | head`) ends quietly. `SIGINT` and `SIGTERM` stop a
    /// run that is writing its output without changing the output directory
    /// (see [`crate::output::transaction::handle_signals`]) and exit with 130 and
    /// 143.
    pub fn main(self) -> ExitCode {
        crate::output::transaction::handle_signals();
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
    /// programs that run commands themselves. Inside it, the settings
    /// its messages advise are spelled as this command line's flags
    /// (`--dt`, `--formulation dae`: [`ezy_core::Spelling::Flags`]); the
    /// errors it returns are rendered already. Outside it, this thread
    /// and the process keep the library's spelling.
    ///
    /// # Errors
    /// [`AppError`]: a usage mistake, a failed command (its message names
    /// the culprit), or a failed write to `out`.
    pub fn run_cli<I, T>(&self, args: I, out: &mut dyn Write) -> Result<(), AppError>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        ezy_core::Spelling::Flags.scope(|| self.dispatch(args, out))
    }

    /// [`App::run_cli`] in the command line's spelling.
    fn dispatch<I, T>(&self, args: I, out: &mut dyn Write) -> Result<(), AppError>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
        let cli = COMMANDS.iter().fold(crate::cli::top(), |top, c| top.subcommand((c.cli)(clap::Command::new(c.name))));
        let matches = cli.clone().try_get_matches_from(&args)?;
        let matches = match matches.subcommand() {
            Some(_) => matches,
            // a bare `ezy`: the default command without arguments
            None => cli.try_get_matches_from([args.first().cloned().unwrap_or_default(), DEFAULT.into()])?,
        };
        let (name, args) = matches.subcommand().expect("a command, given or the default");
        let command = COMMANDS.iter().find(|c| c.name == name).expect("clap matches only the table's commands");
        crate::cli::check_repeats(args).map_err(AppError::Failed)?;
        (command.exec)(self, args, out)
    }
}
