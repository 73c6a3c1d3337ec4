//! The `ezy` command line: `ezy run [SCENE | FILE.toml]`, `ezy list` and
//! the other commands (`ezy --help`), over the built-in vehicles and
//! scenes. A program with its own vehicles is the same line with
//! `.model::<M>("key")` added (see [`ezy::App`]).

fn main() -> std::process::ExitCode {
    ezy::App::new().main()
}
