//! `roller-racer sweep`: a user's own model and scene swept as the
//! built-ins are (a drive's amplitude and a model parameter), in two
//! shards merged into the whole, each row the single run's numbers.

use std::path::Path;

use crate::common;
use common::{SCENE, SWEPT};

fn program(args: &[&str], out: &Path) -> String {
    let o = common::program().args(args).arg("--out").arg(out).output().expect("runs");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{args:?}: {text}{}", String::from_utf8_lossy(&o.stderr));
    text
}

fn rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines().map(|l| l.split(',').map(String::from).collect::<Vec<_>>());
    (lines.next().unwrap(), lines.collect())
}

#[test]
fn a_sweep_of_the_users_model_in_shards_equals_the_whole() {
    let out = common::out_dir("sweep");
    let grid = format!("{SWEPT}=0.3:0.6:3");
    let sweep = ["sweep", SCENE, "--grid", &grid, "--list", "d2=0.2,0.3", "--t-end", "4"];
    fn with<'a>(sweep: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        [sweep, extra, &["--metric", "final(x1)", "--no-figures"]].concat()
    }
    let said = program(&with(&sweep, &[]), &out.join("whole"));
    assert!(said.contains("6 runs, 0 done before, 6 ran (0 failed)"), "{said}");
    program(&with(&sweep, &["--shard", "0/2"]), &out.join("s0"));
    program(&with(&sweep, &["--shard", "1/2"]), &out.join("s1"));
    let s0 = out.join("s0").display().to_string();
    let s1 = out.join("s1").display().to_string();
    program(&["sweep", "merge", &s1, &s0, "--no-figures"], &out.join("merged"));
    let (h, whole) = rows(&out.join("whole/sweep.csv"));
    let (_, merged) = rows(&out.join("merged/sweep.csv"));
    let wall = h.iter().position(|c| c == "wall_s").unwrap();
    let strip = |r: &[Vec<String>]| -> Vec<Vec<String>> {
        r.iter().map(|x| x.iter().enumerate().filter(|(k, _)| *k != wall).map(|(_, v)| v.clone()).collect()).collect()
    };
    assert_eq!(strip(&merged), strip(&whole));
    // run 5 (amplitude 0.6, d2 = 0.3) is the single run, digit for digit
    let set = format!("{SWEPT}=0.6");
    let run =
        program(&["run", SCENE, "--set", &set, "--set", "d2=0.3", "--t-end", "4", "--no-figures"], &out.join("single"));
    assert!(run.contains(&format!("{SCENE}: rk4")), "{run}");
    let (th, traj) = rows(&out.join("single/trajectory.csv"));
    let last = traj.last().unwrap();
    let row = &whole[5];
    assert_eq!((row[1].as_str(), row[2].as_str(), row[3].as_str()), ("0.6", "0.3", "ok"));
    for name in ["x1", "y1", "phi1", "x2", "phi2d", "W_steer", "T"] {
        let (a, b) = (h.iter().position(|c| c == name).unwrap(), th.iter().position(|c| c == name).unwrap());
        assert_eq!(row[a], last[b], "{name}");
    }
    assert_eq!(row[h.len() - 1], row[h.iter().position(|c| c == "x1").unwrap()], "final(x1) is x1");
    // the same command again: every run is done
    let again = program(&with(&sweep, &[]), &out.join("whole"));
    assert!(again.contains("all done before"), "{again}");
}
