//! `steering`: the `ezy` command line with the effect kind `steering`
//! and the scene `steer` added (`steering run` runs it).

fn main() -> std::process::ExitCode {
    steering::app().main()
}
