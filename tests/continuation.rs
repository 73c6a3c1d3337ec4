//! Pseudo-arclength continuation through folds
//! (`ezy_core::analysis::arclength`): an equilibrium branch that folds in
//! a load, known in closed form, in the library and through `ezy analyze
//! --continue`; the forced pendulum's resonance curve, whose periodic
//! orbits fold twice in the forcing's frequency, checked by whole runs.

use ezy::models::Pendulum;
use ezy_core::analysis::arclength::{follow_arclength, locate_fold};
use ezy_core::analysis::bifurcation::BifurcationKind;
use ezy_core::analysis::{
    Analysis, AnalysisError, BranchEnd, BranchPoint, Follow, PeriodicSettings, Solution, Stability,
};

use crate::analysis::{ezy, fresh, table};

/// The built-in pendulum (1 kg at 1 m under 9.81 m/s^2, heading `phi`
/// from the x axis, hanging at -pi/2) loaded by a constant torque `tau`
/// and a rotational damper: its equilibria satisfy `tau = m g L cos phi`,
/// a branch that folds at `tau* = m g L` (the bob level with the pivot,
/// `phi = 0`), stable below it (hanging) and unstable beyond it.
pub(crate) const LOADED_PENDULUM: &str = r#"
name = "loaded-pendulum"
description = "a pendulum under a constant torque"
model = "pendulum"
t_end = 10.0

[initial]
q = { phi = -1.5707963267948966 }
qd = { phi = 0.0 }

[effects.gravity]
kind = "gravity"
g = [0.0, -9.81]

[effects.load]
kind = "torque"
body = "bob"
torque = { constant = 0.0 }

[effects.drag]
kind = "linear-drag"
body = "bob"
c = 0.0
c_rot = 0.5
"#;

/// The loaded pendulum's equilibria from hanging (`tau = 0`) up the load
/// to 12 N m (13 grid values): the branch passes the fold at `tau* = m g
/// L = 9.81` N m and comes back on its other side to `tau = 0` upright
/// (`phi = pi/2`), where it leaves the range. Checked: at every point the
/// accelerations vanish and `tau = m g L cos phi` (closed form, 1e-10);
/// the points advance along the curve (each step's chord turns less
/// than 90 degrees from the last, and `phi`, the curve's natural
/// parameter, increases at every step); stable before the fold and
/// unstable after; the fold located to 1e-8 within 1e-8 of 9.81, its
/// critical eigenvalue real and within 1e-6 of 0.
#[test]
fn an_equilibrium_branch_is_followed_around_its_fold() {
    let scene = ezy_scene::Scene::from_toml(LOADED_PENDULUM, "loaded-pendulum.toml").unwrap();
    let build = |tau: f64| -> Result<Analysis<Pendulum>, AnalysisError> {
        let sets = [("load.torque.constant".to_string(), tau)];
        let p = scene.problem::<Pendulum>(&sets).map_err(|e| AnalysisError::Request { reason: e.to_string() })?;
        Ok(p.0.analysis()?.0)
    };
    let (_, x0) = scene.problem::<Pendulum>(&[]).unwrap().0.analysis().unwrap();
    let values: Vec<f64> = (0..13).map(|k| k as f64).collect();
    let how = Follow::Steady { energy: None };
    let (points, ended) = follow_arclength(&values, &x0, how, build, |_| {});
    assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
    let mgl = 9.81;
    let phi = |b: &BranchPoint| b.solution.state()[2];
    eprintln!("{} points", points.len());
    for b in &points {
        eprintln!("  tau {:.6} phi {:.6} {:?} dp/ds {:?}", b.value, phi(b), b.solution.stability(), b.dp_ds);
        let mut an = build(b.value).unwrap();
        let f = an.rhs(0.0, b.solution.state()).unwrap();
        assert!(f.iter().all(|v| v.abs() < 1e-10), "tau {}: {f:?}", b.value);
        assert!((b.value - mgl * phi(b).cos()).abs() < 1e-10, "tau {} phi {}", b.value, phi(b));
    }
    let chords: Vec<Vec<f64>> = points
        .windows(2)
        .map(|w| {
            let mut c: Vec<f64> = w[1].solution.state().iter().zip(w[0].solution.state()).map(|(a, b)| a - b).collect();
            c.push(w[1].value - w[0].value);
            c
        })
        .collect();
    for c in chords.windows(2) {
        assert!(c[0].iter().zip(&c[1]).map(|(a, b)| a * b).sum::<f64>() > 0.0, "the branch turned back");
    }
    assert!(points.windows(2).all(|w| phi(&w[1]) > phi(&w[0])));
    let last = points.last().unwrap();
    assert!(last.value.abs() < 1e-12 && (phi(last) - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{}", phi(last));
    let k = points.windows(2).position(|w| w[0].dp_ds.unwrap() * w[1].dp_ds.unwrap() < 0.0).expect("a fold");
    for (j, b) in points.iter().enumerate() {
        let want = if j <= k { Stability::Stable } else { Stability::Unstable };
        assert_eq!(b.solution.stability(), want, "tau {} phi {}", b.value, phi(b));
    }
    let fold = locate_fold(&points[k], &points[k + 1], how, build, 1e-8).unwrap().expect("a fold");
    eprintln!(
        "fold at {} (bracket {:?}), critical {:?}, {} solves",
        fold.value, fold.bracket, fold.critical, fold.solves
    );
    assert_eq!(fold.kind, BifurcationKind::Fold);
    assert!((fold.value - mgl).abs() < 1e-8, "{}", fold.value);
    assert_eq!(fold.critical.len(), 1);
    assert!(fold.critical[0].norm() < 1e-6, "{:?}", fold.critical);
}

/// `ezy analyze` on the loaded pendulum's scene file with `--continue
/// load.torque.constant=0:12:13` writes the branch around the fold: the
/// 13 grid values on the hanging side, points closer together near the
/// fold, the upright side back to 0, and a row for the fold at 9.81 N m
/// (to the 1e-8 the command locates to) with its critical eigenvalue 0,
/// neutral (it was written "stable": the point's own family count took
/// the fold's singular direction for a family's and left the critical
/// eigenvalue out); the summary names it.
#[test]
fn analyze_follows_a_branch_around_its_fold() {
    let out = fresh("fold");
    std::fs::create_dir_all(&out).unwrap();
    let file = out.with_extension("toml");
    std::fs::write(&file, LOADED_PENDULUM).unwrap();
    let (said, err, ok) =
        ezy(&["analyze", file.to_str().unwrap(), "--continue", "load.torque.constant=0:12:13", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    assert!(said.contains("fold at load.torque.constant = 9.81"), "{said}");
    let (head, rows) = table(&out.join("branch.csv"));
    let at = |name: &str| head.iter().position(|h| h == name).unwrap();
    let folds: Vec<&Vec<String>> = rows.iter().filter(|r| r[at("bifurcation")] == "fold").collect();
    assert_eq!(folds.len(), 1, "{rows:?}");
    let value: f64 = folds[0][0].parse().unwrap();
    assert!((value - 9.81).abs() < 1e-8, "{value}");
    assert!(folds[0][at("critical_re")].parse::<f64>().unwrap().abs() < 1e-6);
    // its critical eigenvalue 0 classified (it was "stable": its own
    // family count took the singular direction for a family's)
    assert_eq!(folds[0][at("stability")], "neutral");
    let values: Vec<f64> = rows.iter().map(|r| r[0].parse().unwrap()).collect();
    for k in 0..13 {
        let hits = values.iter().filter(|v| (**v - k as f64).abs() < 1e-12).count();
        assert_eq!(hits, if k < 10 { 2 } else { 0 }, "tau = {k}: {values:?}");
    }
}

/// Started beyond the fold (`--continue load.torque.constant=12:0:13`:
/// no equilibrium at 12, 11 or 10 N m), `ezy analyze` wrote no branch
/// though equilibria exist over most of the range. Now the branch begins
/// at the grid's first value where the search converges, 9 N m, and runs
/// down the hanging side to 0, each point stable and an equilibrium (the
/// load balancing gravity's moment, `tau = m g L cos(phi)`, to 1e-9), and
/// the note names the values without one.
#[test]
fn a_branch_started_beyond_its_fold_begins_where_there_is_a_solution() {
    let out = fresh("beyond-fold");
    std::fs::create_dir_all(&out).unwrap();
    let file = out.with_extension("toml");
    std::fs::write(&file, LOADED_PENDULUM).unwrap();
    let (said, err, ok) =
        ezy(&["analyze", file.to_str().unwrap(), "--continue", "load.torque.constant=12:0:13", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    assert!(said.contains("no solution at load.torque.constant = 12 to 10"), "{said}");
    assert!(said.contains("the branch begins at load.torque.constant = 9"), "{said}");
    let (head, rows) = table(&out.join("branch.csv"));
    let at = |name: &str| head.iter().position(|h| h == name).unwrap();
    let values: Vec<f64> = rows.iter().map(|r| r[0].parse().unwrap()).collect();
    assert_eq!(values, (0..10).rev().map(f64::from).collect::<Vec<_>>(), "{values:?}");
    for r in &rows {
        let (tau, phi): (f64, f64) = (r[0].parse().unwrap(), r[at("phi")].parse().unwrap());
        // m = 1 kg, L = 1 m, g = 9.81: the load balances gravity's moment
        assert!((tau - 9.81 * phi.cos()).abs() < 1e-9, "tau {tau}, phi {phi}");
        assert_eq!(r[at("stability")], "stable");
    }
}

/// The forced damped pendulum near resonance (the built-in pendulum, a
/// rotational damper 0.1 N m s, a torque `0.3 cos(omega t)` N m): the
/// pendulum softens, so its resonance curve leans toward low frequencies
/// and folds twice. The branch of periodic orbits from 2.6 to 3.4 rad/s
/// (17 grid values) passes both folds: stable on the large-swing side up
/// to the first fold, unstable between, stable on the small-swing side,
/// each fold's critical multiplier within 1e-6 of +1. Between the folds
/// two whole runs of their own (400 s from each stable orbit's state,
/// perturbed by 0.05 rad) settle onto the two stable orbits, 1e-6 apart
/// from them at the period's end: the hysteresis the folds bound.
#[test]
fn a_resonance_curve_is_followed_through_both_folds() {
    let scene =
        ezy_scene::Scene::from_toml(&crate::bifurcation::forced_pendulum(0.3, 2.6, 0.1), "forced.toml").unwrap();
    let with = |w: f64| [("motor.torque.cos.omega".to_string(), w)];
    let build = |w: f64| -> Result<Analysis<Pendulum>, AnalysisError> {
        let p = scene.problem::<Pendulum>(&with(w)).map_err(|e| AnalysisError::Request { reason: e.to_string() })?;
        Ok(p.0.analysis()?.0)
    };
    let (problem, _) = scene.problem::<Pendulum>(&with(2.6)).unwrap();
    let guess = problem.solve().unwrap().final_state()[..6].to_vec();
    let how = Follow::Periodic { t0: 0.0, period: std::f64::consts::TAU / 2.6, settings: PeriodicSettings::default() };
    let values: Vec<f64> = (0..17).map(|k| 2.6 + 0.05 * k as f64).collect();
    let (points, ended) = follow_arclength(&values, &guess, how, build, |_| {});
    assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
    let swing = |b: &BranchPoint| match &b.solution {
        Solution::Periodic(p) => p.state[2] + std::f64::consts::FRAC_PI_2,
        Solution::Steady(_) => unreachable!(),
    };
    for b in &points {
        eprintln!("  omega {:.6} phi0+pi/2 {:.6} {:?} dp/ds {:?}", b.value, swing(b), b.solution.stability(), b.dp_ds);
    }
    let folds: Vec<usize> =
        (0..points.len() - 1).filter(|&k| points[k].dp_ds.unwrap() * points[k + 1].dp_ds.unwrap() < 0.0).collect();
    assert_eq!(folds.len(), 2, "{folds:?}");
    let mut at = Vec::new();
    for &k in &folds {
        let f = locate_fold(&points[k], &points[k + 1], how, build, 1e-8).unwrap().expect("a fold");
        eprintln!(
            "fold at omega = {} (bracket {:?}), critical {:?}, {} solves",
            f.value, f.bracket, f.critical, f.solves
        );
        assert_eq!(f.kind, BifurcationKind::Fold);
        assert!((f.critical[0].re - 1.0).abs() < 1e-6 && f.critical[0].im == 0.0, "{:?}", f.critical);
        at.push(f.value);
    }
    let (hi, lo) = (at[0], at[1]);
    assert!(lo < hi, "{at:?}");
    for (j, b) in points.iter().enumerate() {
        let want = if j <= folds[0] || j > folds[1] { Stability::Stable } else { Stability::Unstable };
        assert_eq!(b.solution.stability(), want, "omega {}", b.value);
    }
    // a grid value between the folds: its two stable orbits, by runs
    let w = values.iter().copied().find(|w| *w > lo + 0.01 && *w < hi - 0.01).expect("a grid value between the folds");
    let orbits: Vec<&BranchPoint> =
        points.iter().filter(|b| b.value == w && b.solution.stability() == Stability::Stable).collect();
    assert_eq!(orbits.len(), 2, "omega = {w}");
    let period = std::f64::consts::TAU / w;
    for b in orbits {
        let x = b.solution.state();
        let (p, _) = scene.problem::<Pendulum>(&with(w)).unwrap();
        let p = p.q("phi", x[2] + 0.05).unwrap().qd("phi", x[5]).unwrap().t_end(400.0 * period);
        let end = p.solve().unwrap().final_state()[..6].to_vec();
        let gap = end.iter().zip(b.solution.state()).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        eprintln!("omega {w}: the run from the orbit at swing {:.4} ends {gap:e} from it", swing(b));
        assert!(gap < 1e-6, "{gap:e}");
    }
}
