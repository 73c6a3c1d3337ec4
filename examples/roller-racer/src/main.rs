//! `roller-racer`: the `ezy` command line with the Roller Racer added
//! (`run`, `list`, `precision`, `equations`, `check`, `scale`).

fn main() -> std::process::ExitCode {
    roller_racer::app().main()
}
