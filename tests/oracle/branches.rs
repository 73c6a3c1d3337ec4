//! Branches and the bifurcations on them (`ezy analyze --continue`)
//! against separate searches at each parameter value (each gait found
//! on its own, from its own run), with the structural multipliers (a
//! cyclic coordinate's, a rate nothing else feels) named and left out.

use crate::analysis::{ezy, fresh, table};

/// A sleigh carrying a balanced rotor on a hinge at its centre of mass,
/// driven by an oscillating hinge torque `0.5 sin(w t)` [N m], with drag:
/// a user's model and scene typed as text. The rotor's angle is cyclic
/// and nothing else feels its rate, so its two multipliers are 1 at every
/// `w`: they were taken for 48 "branch points" on `--continue w=1:8:15`,
/// and the branch ended at w = 6.04 as "closed". Now the branch covers
/// 1-8 without a bifurcation, the report names the two multipliers, and
/// each grid point's mean speed and multipliers equal those of a separate
/// `ezy analyze --set w=...` to 1e-8 (both are Newton's at 1e-9 of the
/// state on the same orbit).
#[test]
fn a_rotors_structural_multipliers_make_no_bifurcation() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let scene = data.join("rotor-sleigh.toml");
    let scene = scene.to_str().unwrap();
    let dir = fresh("rotor-branch");
    let (out, err, ok) = ezy(&["analyze", scene, "--no-figures", "--continue", "w=1:8:15"], &dir);
    assert!(ok, "{out}{err}");
    assert!(
        out.contains("structural multipliers (left out of the stability and bifurcation tests): 1 (th: cyclic), 1 (thd: the rate of cyclic th, which nothing else feels)"),
        "{out}"
    );
    assert!(!out.contains("note: stability changes") && !out.contains("closed branch"), "{out}");
    let (head, rows) = table(&dir.join("branch.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {head:?}"));
    let (w, kind, speed, mu1, mu2) = (col("w"), col("stability"), col("speed"), col("mu1_re"), col("mu2_re"));
    assert!(rows.iter().all(|r| r[kind] == "stable"), "{rows:?}");
    let values: Vec<f64> = rows.iter().map(|r| r[w].parse().unwrap()).collect();
    assert!(values.windows(2).all(|p| p[1] > p[0]) && values.last() == Some(&8.0), "{values:?}");
    for k in [1.0, 3.0, 6.5, 8.0] {
        let row = rows.iter().find(|r| r[w].parse::<f64>().unwrap() == k).unwrap();
        let one = fresh(&format!("rotor-at-{k}"));
        let (out, err, ok) = ezy(&["analyze", scene, "--no-figures", "--set", &format!("w={k}")], &one);
        assert!(ok, "{out}{err}");
        let (h1, r1) = table(&one.join("periodic.csv"));
        let c1 = |name: &str| r1[0][h1.iter().position(|h| h == name).unwrap()].parse::<f64>().unwrap();
        let num = |i: usize| row[i].parse::<f64>().unwrap();
        for (name, i) in [("speed", speed), ("mu1_re", mu1), ("mu2_re", mu2)] {
            let (a, b) = (num(i), c1(if name == "speed" { "mean_speed" } else { name }));
            assert!((a - b).abs() <= 1e-8 * (1.0 + b.abs()), "w = {k}: {name} {a} on the branch, {b} alone");
        }
    }
}
