//! The `roller` scene through the program itself: it writes the CSV and
//! the three figures, the vehicle moves forward (about 13 m in 20 s), the
//! energy ledger closes.

use crate::common;
use common::SCENE;

#[test]
fn the_roller_scene_writes_its_csv_and_figures() {
    let out = common::out_dir("scene");
    let o = common::program().args(["run", SCENE, "--out"]).arg(&out).output().expect("the program runs");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).expect("trajectory.csv");
    assert_eq!(csv.lines().count(), 1 + 1001, "header + rows every 0.02 s to 20 s");
    for fig in ["paths.png", "speed.png", "energy.png"] {
        assert!(std::fs::metadata(out.join(fig)).map(|m| m.len() > 1000).unwrap_or(false), "{fig}");
    }
    // the rider's work goes into kinetic energy and nowhere else (RK4 at
    // 1 ms with projection closes it to ~1e-9 J of ~50 J)
    let gap: f64 = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("max |T - T0 - W| = "))
        .and_then(|v| v.trim_end_matches(" J").parse().ok())
        .expect("the summary gives the ledger");
    assert!(gap < 1e-6, "{text}");
    let x1: f64 = text
        .split("x1 = ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|v| v.parse().ok())
        .expect("the final state gives x1");
    assert!(x1 > 5.0, "the Roller Racer moves forward: x1 = {x1}\n{text}");
}

/// The user's model in the reduced formulation (only the independent
/// coordinates and speeds integrated; its drive makes an angle dependent,
/// so Newton's method iterates): the same final state as the DAE's to the
/// integration error (DOP853 at 1e-10 over 20 s: ~1e-8 in the mixed norm
/// `|a - b| / max(1, |b|)`, checked at 1e-6), and the constraints kept to
/// rounding without projection.
#[test]
fn the_users_model_runs_in_the_reduced_formulation() {
    let run = |formulation: &str| {
        let out = common::out_dir(formulation);
        let o = common::program()
            .args(["run", SCENE, "--no-figures", "--integrator", "dop853", "--rtol", "1e-10", "--atol", "1e-10"])
            .args(["--every", "20", "--formulation", formulation, "--out"])
            .arg(&out)
            .output()
            .expect("the program runs");
        let text = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(o.status.success(), "{text}{}", String::from_utf8_lossy(&o.stderr));
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).expect("trajectory.csv");
        let last: Vec<f64> = csv.lines().last().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
        (csv.lines().next().unwrap().to_string(), last, text)
    };
    let (header, dae, _) = run("dae");
    let (reduced_header, reduced, said) = run("reduced");
    assert_eq!(header, reduced_header);
    let gap = dae.iter().zip(&reduced).map(|(a, b)| (a - b).abs() / a.abs().max(1.0)).fold(0.0, f64::max);
    assert!(gap < 1e-6, "final rows differ by {gap:e}\n{said}");
    assert!(said.contains("reduced formulation"), "{said}");
    let residual = |key: &str| -> f64 {
        said.split(key).nth(1).and_then(|s| s.split_whitespace().next()).and_then(|v| v.parse().ok()).unwrap()
    };
    assert!(residual("|C| = ") <= 1e-12 && residual("|G qd| = ") <= 1e-12, "{said}");
}
