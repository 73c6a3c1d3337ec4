//! The quantities table (`ezy_core::quantities`) against what the
//! commands write: every column of every CSV file `ezy analyze`, `ezy
//! sensitivity`, `ezy optimize`, `ezy gait-optimize`, `ezy plan` and
//! `ezy geometry` write on scenes that
//! make them write each of their tables is found in it, and every entry
//! of the table is some column of these files, so neither side drifts
//! (the guide's Quantities page is the table's, tests/docs.rs).

use std::collections::BTreeSet;
use std::path::Path;

use ezy_core::quantities::{Names, TABLES, lookup};

use crate::analysis::{ezy, fresh};

/// The names of a model's state: each coordinate and its rate.
fn state(coords: &[&str]) -> Vec<String> {
    coords.iter().map(|c| c.to_string()).chain(coords.iter().map(|c| format!("{c}d"))).collect()
}

fn list(names: &[&str]) -> Vec<String> {
    names.iter().map(|c| c.to_string()).collect()
}

/// A run of the command line: its arguments and the names of the model
/// its patterns are matched against (state, parameters, hinges).
struct Case {
    args: Vec<String>,
    state: Vec<String>,
    parameters: Vec<String>,
    hinges: Vec<String>,
    inputs: Vec<String>,
}

/// The header of a CSV file (quoted names read as the CSV says).
fn header(path: &Path) -> Vec<String> {
    let mut reader = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    reader.headers().unwrap().iter().map(String::from).collect()
}

/// Every column written is in the table, and every entry of the table is
/// a column written: `analyze` (a gait with its derivatives, steady
/// motions, a branch of gaits, a steady branch through a fold, a motion
/// that grows without bound, a limit cycle that turns a crank),
/// `sensitivity`, `optimize` (a gait's every quantity, a run's metric)
/// and `geometry` (a kinematic snake's curvature and gait, a mixed
/// system's momentum).
#[test]
fn every_column_written_is_in_the_table_and_every_entry_is_written() {
    let dir = fresh("quantities");
    std::fs::create_dir_all(&dir).unwrap();
    let pendulum = dir.join("loaded-pendulum.toml");
    std::fs::write(&pendulum, crate::continuation::LOADED_PENDULUM).unwrap();
    let pendulum = pendulum.to_string_lossy().into_owned();
    let plan_scene = crate::plan::sleigh_scene("quantities").to_string_lossy().into_owned();
    let fold = ["analyze", &pendulum, "--continue", "load.torque.constant=0:12:13"];
    let roller = state(&["x1", "y1", "phi1", "x2", "y2", "phi2"]);
    let omega = list(&["motor.omega"]);
    let case = |args: &[&str], state: &[String], parameters: &[String], hinges: &[&str]| Case {
        args: list(args),
        state: state.to_vec(),
        parameters: parameters.to_vec(),
        hinges: list(hinges),
        inputs: Vec::new(),
    };
    let snake = state(&["x1", "y1", "phi1", "x2", "y2", "phi2", "x3", "y3", "phi3"]);
    let cases = [
        case(&["analyze", "drive-rolling-resistance", "--wrt", "motor.omega"], &roller, &omega, &["B"]),
        case(&["analyze", "free"], &roller, &[], &["B"]),
        case(
            &["analyze", "drive-rolling-resistance", "--continue", "motor.amplitude=1:0.4:4", "--switch"],
            &roller,
            &list(&["motor.amplitude"]),
            &["B"],
        ),
        case(&fold, &state(&["x", "y", "phi"]), &list(&["load.torque.constant"]), &[]),
        case(&["analyze", "drive"], &roller, &[], &["B"]),
        case(
            &["analyze", "four-bar"],
            &state(&["x2", "y2", "phi2", "x3", "y3", "phi3", "x4", "y4", "phi4"]),
            &[],
            &["A", "B"],
        ),
        case(&["sensitivity", "drive", "--wrt", "M0", "--t-end", "0.5"], &roller, &list(&["M0"]), &[]),
        case(
            &[
                "optimize",
                "drive-rolling-resistance",
                "--maximize",
                "gait.mean_speed",
                "--over",
                "motor.omega=1:4",
                "--subject-to",
                "gait.mean_forward_speed >= -100",
                "--subject-to",
                "gait.displacement <= 100",
                "--subject-to",
                "gait.dx >= -100",
                "--subject-to",
                "gait.dy >= -100",
                "--subject-to",
                "gait.dheading >= -100",
                "--subject-to",
                "gait.mean_power <= 1000",
                "--subject-to",
                "gait.efficiency >= -100",
                "--subject-to",
                "gait.period >= 0",
            ],
            &roller,
            &omega,
            &[],
        ),
        case(
            &["optimize", "drive", "--maximize", "final(x1)", "--over", "motor.omega=1:6", "--t-end", "2"],
            &roller,
            &omega,
            &[],
        ),
        Case {
            args: list(&["plan", &plan_scene, "--input", "push.fx", "--to", "x=1", "--at-rest", "--segments", "2"]),
            inputs: list(&["push.fx"]),
            ..case(&[], &state(&["x", "y", "phi"]), &[], &[])
        },
        case(
            &[
                "gait-optimize",
                "--gait",
                crate::gait_optimize::CIRCLE,
                "--maximize",
                "dy",
                "--order",
                "second",
                "--centre-only",
            ],
            &snake,
            &[],
            &["alpha1", "alpha2"],
        ),
        case(&["geometry", "--grid", "5"], &snake, &[], &["alpha1", "alpha2"]),
        case(&["geometry", "drive-prescribed", "--range=-3.6:-2.6", "--grid", "5"], &roller, &[], &["B"]),
    ];
    let mut seen: BTreeSet<(&str, &str)> = BTreeSet::new();
    let mut unknown = Vec::new();
    for (k, c) in cases.iter().enumerate() {
        let out = dir.join(format!("run{k}"));
        let args: Vec<&str> = c.args.iter().map(String::as_str).chain(["--no-figures"]).collect();
        let (said, err, ok) = ezy(&args, &out);
        assert!(ok, "{:?}: {said}{err}", c.args);
        let names = Names { state: &c.state, parameters: &c.parameters, hinges: &c.hinges, inputs: &c.inputs };
        let mut files: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        for path in files.iter().filter(|p| p.extension().is_some_and(|x| x == "csv")) {
            let file = path.file_name().unwrap().to_string_lossy().into_owned();
            for column in header(path) {
                match lookup(&file, &column, &names) {
                    Some(entry) => {
                        let table = ezy_core::quantities::table(&file).unwrap();
                        seen.insert((table.file, entry.name));
                    }
                    None => unknown.push(format!("{:?}: {file}: `{column}`", c.args)),
                }
            }
        }
    }
    assert!(unknown.is_empty(), "columns written that the quantities table lacks:\n{}", unknown.join("\n"));
    // a born branch's table is written by branch.csv's writer, its
    // columns the same entries: written in one, written in both
    let written = |(f, n): &(&str, &str)| {
        seen.contains(&(*f, *n)) || (*f == "branch-<k>.csv" && seen.contains(&("branch.csv", *n)))
    };
    let unused: Vec<String> = TABLES
        .iter()
        .flat_map(|t| t.columns().map(move |c| (t.file, c.name)))
        .filter(|e| !written(e))
        .map(|(f, n)| format!("{f}: `{n}`"))
        .collect();
    assert!(unused.is_empty(), "entries of the quantities table no run wrote:\n{}", unused.join("\n"));
}
