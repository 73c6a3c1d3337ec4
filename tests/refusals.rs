//! Requests every command refuses by name before any work: a repeated
//! name in a repeatable flag, a second command into an output directory
//! one is working in, a body without a positive mass, and a fixed step
//! that cannot follow a scene's forcing or its skate friction.
#![cfg(unix)]

use std::path::Path;
use std::process::{Command, Output};

fn ezy(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("ezy runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("ezy-refusals-").tempdir().expect("scratch dir")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// `ezy ARGS` refused (exit 1) with a message containing every one of
/// `needles`.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = ezy(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {e}{}", String::from_utf8_lossy(&o.stdout));
    for n in needles {
        assert!(e.contains(n), "{args:?}: `{n}` not in: {e}");
    }
    e
}

/// A flag that names something, given one name twice, is refused naming
/// the flag and the name, before anything is written: `--input` of
/// `linearize` (it gave two equal columns of B), `--set` of every
/// command, `--over` of `fit` and `optimize`, `--wrt` of `analyze` and
/// `sensitivity`.
#[test]
fn a_name_given_twice_in_a_repeatable_flag_is_refused() {
    let root = scratch();
    let out = root.path().join("out");
    let o = s(&out);
    let cases: &[(&[&str], &str)] = &[
        (&["linearize", "drive", "--input", "tau_B", "--input", "tau_B"], "--input: `tau_B` is given twice"),
        (&["run", "drive", "--set", "m1=2", "--set", "m1=3"], "--set: `m1` is given twice (--set m1=2 and --set m1=3)"),
        (&["linearize", "drive", "--set", "M0=1", "--set", " M0=1"], "--set: `M0` is given twice"),
        (
            &["optimize", "drive", "--maximize", "final(x1)", "--over", "M0=1:3", "--over", "M0=0.5:4"],
            "--over: `M0` is given twice",
        ),
        (&["sensitivity", "drive", "--wrt", "M0,M0"], "--wrt: `M0` is given twice"),
        (
            &["fit", "drive", "--data", "nowhere.csv", "--columns", "x1,x1", "--over", "M0=1:3"],
            "--columns: `x1` is given twice",
        ),
        (&["analyze", "sleigh", "--wrt", "a", "--wrt", "a"], "--wrt: `a` is given twice"),
    ];
    for (args, needle) in cases {
        refused(&[args, &["--out", o][..]].concat(), &[needle]);
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}
