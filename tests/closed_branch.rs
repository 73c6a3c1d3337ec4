//! Closed branches and families' members in continuation
//! (`ezy_core::analysis::arclength`): a loop of equilibria of the user's
//! own model through two folds, recognized closed and stopped; a
//! Chaplygin sleigh's straight run (one of a family, at every speed)
//! refused without its level and followed with its kinetic energy fixed,
//! against the closed form of docs/physics.md §9; both through `ezy
//! analyze --continue`.

use ezy::models::{ChaplyginSleigh, scenes};
use ezy_core::Problem;
use ezy_core::analysis::arclength::{follow_arclength, follow_arclength_from, locate_fold};
use ezy_core::analysis::bifurcation::BifurcationKind;
use ezy_core::analysis::{Analysis, AnalysisError, BranchEnd, BranchPoint, Follow, Solution, Stability};
use ezy_core::effects::{ForceLaw, Periodicity, Waveforms};

use crate::analysis::{ezy, fresh, table};
use crate::optimize::{Cart, M};

/// The cart's damping [N s/m] under [`Circle`].
const C: f64 = 0.5;

/// A force on the cart along its rail whose equilibria lie on the circle
/// `x^2 + p^2 = 1`: `F = -(x^2 + p^2 - 1) - c xd` [N], `p` [m] the
/// law's parameter.
#[derive(Debug, Clone)]
struct Circle {
    p: f64,
}

impl ForceLaw for Circle {
    fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let fx = -(q[0] * q[0] + self.p * self.p - 1.0) - C * qd[0];
        f[0] += fx;
        (fx * qd[0], fx)
    }
    fn coords(&self) -> Vec<usize> {
        vec![0]
    }
    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }
    // dF/dx = -2x, dF/dxd = -c
    fn jacobian(&self, _t: f64, _w: &Waveforms, q: &[f64], _qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        // row-major nq x nq: (x, x) is the first entry
        dq[0] -= 2.0 * q[0];
        dqd[0] -= C;
        true
    }
}

/// The cart under [`Circle`] at `p`, from `x` at rest: its analysis and
/// start.
fn circle_cart(p: f64, x: f64) -> Result<(Analysis<Cart>, Vec<f64>), AnalysisError> {
    let problem = || -> Result<Problem<Cart>, ezy_core::SimError> {
        Problem::new(Cart::default()).law("circle", Circle { p })?.q("x", x)?.q("y", 0.0)?.q("phi", 0.0)?.qd("x", 0.0)
    };
    Ok(problem()?.analysis()?)
}

/// The cart's position `x` [m] at a branch point.
fn x_of(b: &BranchPoint) -> f64 {
    b.solution.state()[0]
}

/// The cart under a force of the user's own whose equilibria are the
/// circle `x^2 + p^2 = 1`: the branch from `x = 1` at `p = 0` on the grid
/// `-2:2:41` (its start inside the range, followed toward `p = 2`) goes
/// around the circle through its two folds, at `p = 1` and `p = -1`
/// (`x = 0`), never leaving the range, and comes back to its start:
/// recognized closed (it used to end after `4 * 41 + 64` points as an
/// error), stopped with its last point the first again (`p = 0`, `x =
/// 1`) and the count of distinct points said. Checked: every point on
/// the circle to 1e-10 (the steady search's tolerance, 1e-12 relative,
/// on a curve of unit radius); each point's eigenvalues those of `m s^2 +
/// c s + 2x = 0` (the closed form, `dF/dx = -2x`) to 1e-8, stable where
/// `x > 0` and unstable where `x < 0`; both halves visited; the two folds
/// located to 1e-8 within 1e-8 of `p = +-1` with the critical eigenvalue
/// within 1e-6 of 0 (the located point's own search resolves it to about
/// the square root of its tolerance relative to the other eigenvalue,
/// `c/m = 0.25`). Measured: the folds at 1 - 4e-16 and -1 - 4e-16,
/// their critical eigenvalues 8e-13.
#[test]
fn a_loop_of_equilibria_through_two_folds_is_recognized_closed() {
    let values: Vec<f64> = (0..41).map(|k| -2.0 + 0.1 * f64::from(k)).collect();
    let at = 20;
    assert!(values[at].abs() < 1e-15);
    let (_, x0) = circle_cart(0.0, 1.0).unwrap();
    let build = |p: f64| Ok(circle_cart(p, 0.0)?.0);
    let how = Follow::Steady { energy: None };
    let (points, ended) = follow_arclength_from(&values, at, &x0, how, build, |_| {});
    eprintln!("{ended:?}, {} points", points.len());
    let BranchEnd::Closed { points: k } = ended else { panic!("{ended:?}") };
    assert_eq!(points.len(), k + 1);
    let (first, last) = (&points[0], &points[k]);
    assert!(first.value == 0.0 && last.value == 0.0, "{} {}", first.value, last.value);
    assert!((x_of(first) - 1.0).abs() < 1e-10 && (x_of(last) - 1.0).abs() < 1e-10, "{}", x_of(last));
    for b in &points {
        let (p, x) = (b.value, x_of(b));
        eprintln!("  p {p:+.6} x {x:+.6} {:?} dp/ds {:?}", b.solution.stability(), b.dp_ds);
        assert!((x * x + p * p - 1.0).abs() < 1e-10, "p {p} x {x}");
        let Solution::Steady(s) = &b.solution else { unreachable!() };
        // m s^2 + c s + 2x = 0
        let disc = C * C - 8.0 * M * x;
        let want: Vec<(f64, f64)> = if disc >= 0.0 {
            vec![((-C + disc.sqrt()) / (2.0 * M), 0.0), ((-C - disc.sqrt()) / (2.0 * M), 0.0)]
        } else {
            vec![(-C / (2.0 * M), (-disc).sqrt() / (2.0 * M)), (-C / (2.0 * M), -(-disc).sqrt() / (2.0 * M))]
        };
        assert_eq!(s.eigenvalues.len(), 2, "{:?}", s.eigenvalues);
        for (re, im) in want {
            let near = s.eigenvalues.iter().any(|z| (z.re - re).abs() < 1e-8 && (z.im - im).abs() < 1e-8);
            assert!(near, "p {p} x {x}: {:?} against {re} + {im} i", s.eigenvalues);
        }
        let want = if x > 1e-6 { Stability::Stable } else { Stability::Unstable };
        if x.abs() > 1e-6 {
            assert_eq!(b.solution.stability(), want, "p {p} x {x}");
        }
    }
    assert!(points.iter().filter(|b| x_of(b) < -0.5).count() >= 3);
    assert!(points.iter().filter(|b| x_of(b) > 0.5).count() >= 3);
    let folds: Vec<usize> = (0..k).filter(|&j| points[j].dp_ds.unwrap() * points[j + 1].dp_ds.unwrap() < 0.0).collect();
    assert_eq!(folds.len(), 2, "{folds:?}");
    let mut at_folds = Vec::new();
    for &j in &folds {
        let f = locate_fold(&points[j], &points[j + 1], how, build, 1e-8).unwrap().expect("a fold");
        eprintln!("fold at p = {} (bracket {:?}), critical {:?}, {} solves", f.value, f.bracket, f.critical, f.solves);
        assert_eq!(f.kind, BifurcationKind::Fold);
        assert!((f.value.abs() - 1.0).abs() < 1e-8, "{}", f.value);
        assert!(f.critical[0].norm() < 1e-6, "{:?}", f.critical);
        at_folds.push(f.value);
    }
    // p = 1 first (the branch heads toward the grid's end), then p = -1
    assert!(at_folds[0] > 0.0 && at_folds[1] < 0.0, "{at_folds:?}");
}

/// The energy of the `sleigh` scene's start [J]: the skate makes `yd = a
/// omega = 0.5 m/s`, so `T0 = (m (1 + 0.25) + I) / 2 = 0.675`.
const SLEIGH_ENERGY: f64 = 0.675;

/// The `sleigh` scene (docs/physics.md §9) at the mass `m` [kg]: its
/// analysis and start.
fn sleigh_at(m: f64) -> Result<(Analysis<ChaplyginSleigh>, Vec<f64>), AnalysisError> {
    let sets = [("m".to_string(), m)];
    let scene = scenes::get("sleigh");
    let (p, _) =
        scene.problem::<ChaplyginSleigh>(&sets).map_err(|e| AnalysisError::Request { reason: e.to_string() })?;
    Ok(p.analysis()?)
}

/// [`sleigh_at`]'s analysis.
fn sleigh(m: f64) -> Result<Analysis<ChaplyginSleigh>, AnalysisError> {
    Ok(sleigh_at(m)?.0)
}

/// The Chaplygin sleigh's straight run is one of a family (every speed
/// `U`: family 1). Followed in the mass without a level, its branch is not
/// one curve (the tangent has a free direction, the speed's, and the
/// corrector picked the minimum norm's member: the speed held by
/// accident, whatever the energy): refused at its first point, by name,
/// with the fix. With its kinetic energy fixed at the scene's 0.675 J,
/// the branch over `m` in [0.5, 2] is unique and matches the closed form
/// (docs/physics.md §9): a straight run (yaw rate 0) at `U =
/// sqrt(2 E / m)` with the eigenvalue `-m a U / (I + m a^2)`, both to
/// 1e-10 (the steady search's tolerance, 1e-12 relative).
#[test]
fn a_family_member_is_followed_with_its_energy_fixed() {
    // the straight run at the scene's energy (from the scene's turning
    // start, a search without a level ends near rest, 2e-6 m/s: rest is a
    // member of the family too)
    let (_, mut x0) = sleigh_at(1.0).unwrap();
    x0[3..].copy_from_slice(&[(2.0 * SLEIGH_ENERGY).sqrt(), 0.0, 0.0]);
    let values = [0.5, 1.0, 1.5, 2.0];
    let (points, ended) = follow_arclength(&values, &x0, Follow::Steady { energy: None }, sleigh, |_| {});
    let Some((value, e)) = ended.failure() else { panic!("{ended:?}") };
    let said = e.to_string();
    eprintln!("refused at m = {value}: {said}");
    assert_eq!(value, 0.5);
    assert_eq!(points.len(), 1);
    assert!(said.contains("family") && said.contains("kinetic energy") && said.contains("--energy"), "{said}");

    let how = Follow::Steady { energy: Some(SLEIGH_ENERGY) };
    let (points, ended) = follow_arclength(&values, &x0, how, sleigh, |_| {});
    assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
    let model = ChaplyginSleigh::default();
    assert_eq!(points.iter().map(|b| b.value).collect::<Vec<_>>(), values);
    for b in &points {
        let Solution::Steady(s) = &b.solution else { unreachable!() };
        let m = b.value;
        let u = (2.0 * SLEIGH_ENERGY / m).sqrt();
        let want = -m * model.a * u / (model.I + m * model.a * model.a);
        eprintln!("  m {m}: speed {} (U {u}), family {}, {:?}", s.speed(), s.family, s.eigenvalues);
        assert!((s.speed() - u).abs() < 1e-10, "m {m}: {} against {u}", s.speed());
        assert!(s.body_velocity[2].abs() < 1e-10, "{:?}", s.body_velocity);
        assert!(s.eigenvalues.iter().any(|z| (z.re - want).abs() < 1e-10 && z.im == 0.0), "{:?}", s.eigenvalues);
        assert_eq!(s.stability, Stability::Stable);
    }
}

/// `ezy analyze` on the loaded pendulum's scene over the load's range
/// `-12:12:25` N m, wider than both folds at `+-m g L = +-9.81` N m: the
/// branch begins at -9 N m (no equilibrium below -9.81), climbs the
/// hanging side to the fold at 9.81, comes back over the top, through
/// the fold at -9.81 and up to -9 again, a whole turn on: the summary says
/// it is closed, at -9 after the count of points (it used to end as an
/// error after `4 * 25 + 64` points), branch.csv's last row is its first
/// with the pendulum a turn on (phi + 2 pi, to 1e-9), each row an
/// equilibrium (`tau = m g L cos phi`, 1e-9), and both folds are located
/// (within 1e-8 of +-9.81).
#[test]
fn analyze_says_a_branch_is_closed() {
    let out = fresh("closed-branch");
    std::fs::create_dir_all(&out).unwrap();
    let file = out.with_extension("toml");
    std::fs::write(&file, crate::continuation::LOADED_PENDULUM).unwrap();
    let (said, err, ok) =
        ezy(&["analyze", file.to_str().unwrap(), "--continue", "load.torque.constant=-12:12:25", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    eprintln!("{said}");
    let note = said.lines().find(|l| l.contains("the branch is closed")).unwrap_or_else(|| panic!("{said}"));
    let k: usize = note
        .strip_prefix("note: the branch is closed: it returns to its start at load.torque.constant = -9 after ")
        .and_then(|r| r.strip_suffix(" points"))
        .unwrap_or_else(|| panic!("{note}"))
        .parse()
        .unwrap();
    let (head, rows) = table(&out.join("branch.csv"));
    let at = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (points, folds): (Vec<&Vec<String>>, Vec<&Vec<String>>) =
        rows.iter().partition(|r| r[at("bifurcation")].is_empty());
    assert_eq!(points.len(), k + 1, "{k}");
    let num = |r: &Vec<String>, c: &str| r[at(c)].parse::<f64>().unwrap();
    for r in &points {
        assert!((num(r, "load.torque.constant") - 9.81 * num(r, "phi").cos()).abs() < 1e-9, "{r:?}");
    }
    let (first, last) = (points[0], points[k]);
    assert_eq!(num(first, "load.torque.constant"), -9.0);
    assert_eq!(num(last, "load.torque.constant"), -9.0);
    let turn = num(last, "phi") - num(first, "phi");
    assert!((turn - std::f64::consts::TAU).abs() < 1e-9, "{turn}");
    let mut at_folds: Vec<f64> = folds.iter().map(|r| num(r, "load.torque.constant")).collect();
    at_folds.sort_by(f64::total_cmp);
    assert_eq!(at_folds.len(), 2, "{rows:?}");
    assert!((at_folds[0] + 9.81).abs() < 1e-8 && (at_folds[1] - 9.81).abs() < 1e-8, "{at_folds:?}");
}

/// `ezy analyze sleigh-ice --continue m=0.5:2:4`: the skate's friction
/// makes the scene one with effects, so the energy was not fixed, and
/// the straight run (a family's member, every speed) was followed at the
/// speed the minimum-norm corrector happened to keep (2.162 m/s at every
/// mass, whatever the energy). Now the branch holds the motion's own
/// kinetic energy `E = m U0^2 / 2` (U0 at the scene's `m = 1`), said in a
/// note, and each point runs at `U = sqrt(2 E / m)` (docs/physics.md §9,
/// the skate holding: no work) to 1e-10, the steady search's tolerance.
#[test]
fn analyze_holds_a_family_members_energy_on_its_branch() {
    let out = fresh("family-branch");
    let (said, err, ok) = ezy(&["analyze", "sleigh-ice", "--continue", "m=0.5:2:4", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    assert!(said.contains("steady motion 1 is one of a family of 1 dimension(s) (a free speed): its branch holds its kinetic energy at"), "{said}");
    let (head, rows) = table(&out.join("equilibria.csv"));
    let col = |h: &[String], row: &[String], name: &str| {
        row[h.iter().position(|c| c == name).unwrap()].parse::<f64>().unwrap()
    };
    let u0 = col(&head, &rows[0], "speed");
    let energy = u0 * u0 / 2.0;
    let (bhead, branch) = table(&out.join("branch.csv"));
    assert_eq!(branch.len(), 4);
    for row in &branch {
        let m: f64 = row[0].parse().unwrap();
        let u = (2.0 * energy / m).sqrt();
        let speed = col(&bhead, row, "speed");
        eprintln!("m {m}: speed {speed} against {u}");
        assert!((speed - u).abs() < 1e-10, "m {m}: {speed} against {u}");
    }
}
