//! Branch switching told by what is born (`ezy_core::analysis::switching`):
//! a pitchfork and a transcritical point, each known in closed form, on
//! the user's own cart (`tests/optimize.rs`) and force laws of the user's
//! own, told apart by name; both new branches followed and checked
//! against the closed form, their stability with them.

use ezy_core::analysis::arclength::follow_arclength;
use ezy_core::analysis::bifurcation::{BifurcationKind, locate};
use ezy_core::analysis::switching::{Criticality, switch_both};
use ezy_core::analysis::{Analysis, AnalysisError, BranchEnd, BranchPoint, Follow, Stability};
use ezy_core::effects::{ForceLaw, Periodicity};
use ezy_core::{Method, Problem};

use crate::optimize::{Cart, M};

/// The two closed forms, in `y = x - a mu` (x the cart's position \[m\],
/// `mu` the parameter \[m\]): `Pitchfork` `F/m = mu y - y^3` (rest at
/// `y = 0` for every `mu`, `y = +-sqrt(mu)` for `mu > 0`), `Transcritical`
/// `F/m = -y (y + 3 mu)` (`y = 0` and `y = -3 mu`, crossing at 0). The
/// parent branch `x = a mu` is tilted (`a = 0.5`), so the new branch is
/// not along a coordinate: the switch must find its direction.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Normal {
    Pitchfork,
    Transcritical,
    /// The pitchfork with an imperfection `e` \[m/s^2\]: `F/m = mu y - y^3 + e`.
    Imperfect(f64),
}

/// The tilt of the parent branch `x = A mu`.
const A: f64 = 0.5;
/// The cart's damping [N s/m]: every rest is a node or focus, stable
/// where `dF/dx < 0`.
const C: f64 = 1.0;

/// `F = m g(y; mu) - c xd` on the cart's x.
#[derive(Debug, Clone)]
struct NormalForm {
    kind: Normal,
    mu: f64,
}

impl NormalForm {
    /// `g` and `dg/dy` at `y`.
    fn g(&self, y: f64) -> (f64, f64) {
        match self.kind {
            Normal::Pitchfork => (self.mu * y - y * y * y, self.mu - 3.0 * y * y),
            Normal::Transcritical => (-y * (y + 3.0 * self.mu), -(2.0 * y + 3.0 * self.mu)),
            Normal::Imperfect(e) => (self.mu * y - y * y * y + e, self.mu - 3.0 * y * y),
        }
    }
}

impl ForceLaw for NormalForm {
    fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let (g, _) = self.g(q[0] - A * self.mu);
        let fx = M * g - C * qd[0];
        f[0] += fx;
        (fx * qd[0], fx)
    }
    fn coords(&self) -> Vec<usize> {
        vec![0]
    }
    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }
}

/// The scene at `mu`, from `x0` at rest.
fn scene(kind: Normal, mu: f64, x0: f64) -> Result<Problem<Cart>, ezy_core::SimError> {
    Ok(Problem::new(Cart::default())
        .law("normal_form", NormalForm { kind, mu })?
        .q("x", x0)?
        .q("y", 0.0)?
        .q("phi", 0.0)?
        .qd("x", 0.0)?
        .t_end(10.0)
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12))
}

/// Follows the parent from `mu = -1` to `1` (8 points, none at 0),
/// locates its change of stability, switches there and follows each
/// branch born to the range's end on its side; returns the kind told,
/// its criticality and every point of the branches born.
fn switched(kind: Normal) -> (BifurcationKind, Option<Criticality>, bool, Vec<BranchPoint>) {
    let build = |mu: f64| -> Result<Analysis<Cart>, AnalysisError> {
        Ok(scene(kind, mu, A * mu).map_err(AnalysisError::Sim)?.analysis()?.0)
    };
    let values: Vec<f64> = (0..8).map(|k| -1.0 + 2.0 * k as f64 / 7.0).collect();
    let (_, x0) = scene(kind, -1.0, -A).unwrap().analysis().unwrap();
    let how = Follow::Steady { energy: None };
    let (points, ended) = follow_arclength(&values, &x0, how, build, |_| {});
    assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
    let k = points.windows(2).position(|w| w[0].solution.stability() != w[1].solution.stability()).unwrap();
    let b = locate(&points[k], &points[k + 1], how, build, 1e-10).unwrap().expect("a bifurcation");
    assert_eq!(b.kind, BifurcationKind::BranchPoint);
    assert!(b.value.abs() < 1e-9, "{}", b.value);
    let s = switch_both(&b, [&points[k], &points[k + 1]], how, build, 1e-3, Default::default()).unwrap();
    eprintln!(
        "{kind:?}: {} at {}; born at {:?}",
        s.describe(),
        b.value,
        s.born.iter().map(|n| n.start.value).collect::<Vec<_>>()
    );
    assert!(s.failed.is_none(), "{:?}", s.failed);
    let mut all = Vec::new();
    for n in &s.born {
        let end = if n.start.value > b.value { 1.0 } else { -1.0 };
        let (new, ended) = follow_arclength(&[n.start.value, end], n.start.solution.state(), n.follow, build, |_| {});
        assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
        assert_eq!(new.last().unwrap().value, end);
        all.extend(new);
    }
    (s.kind, s.criticality, s.symmetry_breaking, all)
}

/// Each point of a branch born lies on the closed form's other branch:
/// its distance in the `(mu, x)` plane from `mu = y^2` (pitchfork) or
/// `y = -3 mu` (transcritical) below 1e-9 (the steady search's residual
/// 1e-12 over the curve's gradient, at least 1 in these forms: well
/// conditioned even next to the bifurcation, where the distance in `x`
/// alone is the residual over `dF/dx -> 0`: 4e-8 at 1.2e-6 from it).
/// Its stability is the closed form's (`dF/dx < 0`) where that is
/// resolved (`|dF/dx|` above 1e-5 of its scale 1).
fn check_born(kind: Normal, born: &[BranchPoint]) {
    for p in born {
        let (mu, x) = (p.value, p.solution.state()[0]);
        let y = x - A * mu;
        let off = match kind {
            Normal::Pitchfork => (mu - y * y).abs() / (1.0 + 4.0 * y * y).sqrt(),
            Normal::Transcritical => (y + 3.0 * mu).abs() / 10f64.sqrt(),
            Normal::Imperfect(_) => unreachable!("nothing is born at an imperfect pitchfork"),
        };
        assert!(off < 1e-9, "{kind:?} at mu = {mu}: x = {x}, off the closed form's branch by {off:e}");
        let slope = NormalForm { kind, mu }.g(y).1;
        if slope.abs() > 1e-5 {
            assert_eq!(p.solution.stability() == Stability::Stable, slope < 0.0, "{kind:?} at mu = {mu}");
        }
    }
}

/// `F/m = mu y - y^3`: the parent `x = mu / 2` loses its stability at
/// `mu = 0` and two stable rests `y = +-sqrt(mu)` are born for `mu > 0`:
/// a supercritical pitchfork, both arms on the same side. Neither arm
/// turns (the cart is on a rail): not told symmetry-breaking.
#[test]
fn a_pitchfork_is_told_from_its_branches_on_one_side() {
    let (kind, criticality, breaking, born) = switched(Normal::Pitchfork);
    assert_eq!(kind, BifurcationKind::Pitchfork);
    assert_eq!(criticality, Some(Criticality::Supercritical));
    assert!(!breaking);
    assert!(born.iter().all(|p| p.value > 0.0));
    // both arms: above and below the parent
    assert!(born.iter().any(|p| p.solution.state()[0] > A * p.value + 0.5));
    assert!(born.iter().any(|p| p.solution.state()[0] < A * p.value - 0.5));
    check_born(Normal::Pitchfork, &born);
}

/// `F/m = -y (y + 3 mu)`: the parent `x = mu / 2` (stable for `mu > 0`)
/// and `y = -3 mu` (stable for `mu < 0`) cross at 0 and exchange their
/// stability: transcritical, the branch born on both sides.
#[test]
fn a_transcritical_point_is_told_from_its_branch_across() {
    let (kind, criticality, _, born) = switched(Normal::Transcritical);
    assert_eq!(kind, BifurcationKind::Transcritical);
    assert_eq!(criticality, None);
    assert!(born.iter().any(|p| p.value == 1.0) && born.iter().any(|p| p.value == -1.0));
    check_born(Normal::Transcritical, &born);
}

/// The pitchfork unfolded by an imperfection `e = 1e-3`: `y^3 - mu y =
/// e` has a smooth branch from `mu = -1` (`y ~ e / |mu|`) onto the upper
/// arm (`y ~ sqrt(mu)`), on which `dg/dy = mu - 3 y^2` never reaches 0:
/// its largest is `-6 (e/4)^(2/3)` = -0.024 at `mu = -3 (e/4)^(2/3)`
/// (the cusp's `e^(2/3)`). On the grid `-1:1:81` no bifurcation is
/// located (the unstable count never changes), and [`near_misses`]
/// names the grid point of the largest `dg/dy` with its eigenvalue, the
/// slow root of `lambda^2 + (c/m) lambda - dg/dy = 0`, to 1e-9 (the steady
/// search's residual 1e-12 over `dF/dx`, above 0.04 m here). The perfect
/// pitchfork's branch (on `-1:1:8`, no point at 0, where its search is
/// singular), whose eigenvalue crosses 0, has none. (On `-1:1:20` the
/// step from -0.026 to 0.026 jumps onto the unfolding's middle, unstable
/// branch, y = -0.019, whose tangent there is the stable one's within 37
/// degrees: the grid's step must be small against the cusp's `e^(2/3)`.)
#[test]
fn an_unfolded_pitchfork_is_a_near_miss_and_the_perfect_one_is_not() {
    use ezy_core::analysis::bifurcation::near_misses;
    let e = 1e-3;
    let grid = |n: usize| -> Vec<f64> { (0..n).map(|k| -1.0 + 2.0 * k as f64 / (n - 1) as f64).collect() };
    let branch = |kind: Normal, values: &[f64]| {
        let build = move |mu: f64| -> Result<Analysis<Cart>, AnalysisError> {
            Ok(scene(kind, mu, A * mu).map_err(AnalysisError::Sim)?.analysis()?.0)
        };
        let (_, x0) = scene(kind, -1.0, -A).unwrap().analysis().unwrap();
        let (points, ended) = follow_arclength(values, &x0, Follow::Steady { energy: None }, build, |_| {});
        assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
        points
    };
    let points = branch(Normal::Imperfect(e), &grid(81));
    let path: Vec<(f64, f64)> = points.iter().map(|p| (p.value, p.solution.state()[0] - A * p.value)).collect();
    assert!(points.iter().all(|p| p.solution.stability() == Stability::Stable), "{path:?}");
    // dg/dy at each point, the point on the closed form's branch
    let slopes: Vec<f64> = points
        .iter()
        .map(|p| {
            let (mu, y) = (p.value, p.solution.state()[0] - A * p.value);
            assert!((mu * y - y * y * y + e).abs() < 1e-10, "off the branch at {mu}: y = {y}");
            mu - 3.0 * y * y
        })
        .collect();
    let top = (0..slopes.len()).max_by(|&a, &b| slopes[a].total_cmp(&slopes[b])).unwrap();
    assert!(top > 0 && top + 1 < points.len() && slopes[top] < -0.02, "{slopes:?}");
    let misses = near_misses(&points, 0.1);
    assert_eq!(misses.len(), 1, "{misses:?}");
    let m = &misses[0];
    assert_eq!(m.index, top, "{m:?}");
    let (b, c) = (C / M, -slopes[top]);
    let slow = 0.5 * (-b + (b * b - 4.0 * c).sqrt());
    eprintln!("near miss at mu = {}: {:?} against {slow:e}", m.value, m.critical);
    assert!((m.critical.re - slow).abs() < 1e-9 && m.critical.im == 0.0, "{m:?} against {slow}");
    assert!(near_misses(&branch(Normal::Pitchfork, &grid(8)), 0.1).is_empty());
}

/// The last forcing period's heading change over its duration [rad/s] of
/// a 2000 s run of the rolling-resistance scene at the motor amplitude
/// `a` [N m] from the scene's start, sampled every forcing period (2 s),
/// and the period before's: the run's verdict on the gait it settles on.
fn run_turning(a: f64) -> (f64, f64) {
    use ezy::models::{EzyRoller, scenes};
    let scene = scenes::get("drive-rolling-resistance");
    let sets = [("motor.amplitude".to_string(), a)];
    let (run, _) = scene.problem::<EzyRoller>(&sets).unwrap();
    let sol = run.t_end(2000.0).every(2.0).solve().unwrap();
    let phi = sol.column("phi1").unwrap();
    let n = phi.len();
    ((phi[n - 1] - phi[n - 2]) / 2.0, (phi[n - 2] - phi[n - 3]) / 2.0)
}

/// `ezy analyze drive-rolling-resistance --continue
/// motor.amplitude=0.8:0.4:9 --switch`: the straight gait's loss of
/// stability at 0.6380639 N m is told a supercritical symmetry-breaking
/// pitchfork, and its two arms (branch-1.csv, branch-2.csv), followed
/// down to 0.4 N m, turn opposite ways, stable. Against whole runs of the
/// scene at +0.4 N m and at -0.4 N m (the motor's torque reversed: the
/// mirror image of the motion, which turns the other way), 2000 s each:
/// each arm's turning rate at 0.4 equals one run's last forcing period's
/// heading change over its 2 s, to 1e-8 rad/s (the issue asks 1e-6; the
/// arms' own are Newton's at 1e-9 of the state, the runs' transient is
/// down by 0.97^1000; measured 3.9e-11 and 3.2e-10), and each run has
/// settled (its last two periods agree to 1e-9 rad/s), as a stable gait
/// lets it.
#[test]
fn the_cli_switches_onto_both_turning_arms_of_the_rolling_resistance_gait() {
    use crate::analysis::{ezy, fresh, table};
    let out = fresh("switch-rolling");
    let (said, err, ok) = ezy(
        &["analyze", "drive-rolling-resistance", "--continue", "motor.amplitude=0.8:0.4:9", "--switch", "--no-figures"],
        &out,
    );
    assert!(ok, "{said}{err}");
    assert!(said.contains("is a pitchfork (symmetry-breaking, supercritical)"), "{said}");
    let (head, rows) = table(&out.join("branches.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 3, "{rows:?}");
    for r in &rows[1..] {
        assert_eq!(r[col("bifurcation")], "pitchfork");
        assert_eq!(r[col("criticality")], "supercritical");
        assert_eq!(r[col("symmetry_breaking")], "true");
        assert_eq!(r[col("to")], "0.4");
        let born: f64 = r[col("born_at")].parse().unwrap();
        assert!((born - 0.6380639).abs() < 1e-6, "{born}");
    }
    // the parent's row for the bifurcation names it as told
    let (bh, brows) = table(&out.join("branch.csv"));
    assert!(brows.iter().any(|r| r[bh.iter().position(|h| h == "bifurcation").unwrap()] == "pitchfork"));
    let arm = |k: usize| {
        let (h, rows) = table(&out.join(format!("branch-{k}.csv")));
        let at = |name: &str| h.iter().position(|c| c == name).unwrap();
        assert!(rows.iter().all(|r| r[at("stability")] == "stable"), "branch {k}: {rows:?}");
        let last = rows.last().unwrap();
        assert_eq!(last[0], "0.4");
        last[at("turning_rate")].parse::<f64>().unwrap()
    };
    let (r1, r2) = (arm(1), arm(2));
    eprintln!("arms at 0.4 N m: turning {r1:e} and {r2:e} rad/s");
    assert!(r1 * r2 < 0.0, "{r1} {r2}");
    for a in [0.4, -0.4] {
        let (last, before) = run_turning(a);
        let arm = if (last - r1).abs() < (last - r2).abs() { r1 } else { r2 };
        eprintln!("run at {a} N m: {last:e} rad/s (the period before {before:e}), the arm {arm:e}");
        assert!((last - arm).abs() < 1e-8, "run at {a}: {last} against the arm's {arm}");
        assert!((last - before).abs() < 1e-9, "run at {a} has not settled: {last} then {before}");
    }
}

/// The same branch at `--rtol 1e-6`: Newton stops at 1e-4, the straight
/// gait is straight only to that (its turning rate 9e-4 rad/s at 0.8 N m
/// where the default's is 5e-10), and the pitchfork unfolds into two
/// branches that pass each other: the branch followed bends smoothly onto
/// the turning arm, no multiplier crosses 1, and nothing is located. ezy
/// must not pass over it in silence: the critical multiplier's closest
/// approach (0.99992 near 0.6386 N m, against the bound `10 (1e-4)^(2/3)`
/// = 2.2e-2) is said a near miss, at the grid's stretch around the
/// branch point (0.63 to 0.65), and `--switch` says it found nothing to
/// switch at. The grid's values are written as given (0.6, not
/// 0.6000000000000001), and at the default tolerances no near miss is said
/// (the previous test's run: its multiplier crosses).
#[test]
fn a_loose_tolerance_that_unfolds_the_pitchfork_is_said() {
    use crate::analysis::{ezy, fresh, table};
    let out = fresh("switch-loose");
    let (said, err, ok) = ezy(
        &[
            "analyze",
            "drive-rolling-resistance",
            "--continue",
            "motor.amplitude=0.8:0.4:9",
            "--switch",
            "--rtol",
            "1e-6",
            "--atol",
            "1e-6",
            "--no-figures",
        ],
        &out,
    );
    assert!(ok, "{said}{err}");
    let note = said.lines().find(|l| l.contains("came within")).unwrap_or_else(|| panic!("no near miss: {said}"));
    let at: f64 = note.split("near motor.amplitude = ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((0.63..0.65).contains(&at), "{note}");
    assert!(note.contains("the unit circle") && note.contains("Newton stops at 1e-4"), "{note}");
    assert!(said.contains("--switch: no branch point, period doubling or Hopf point was located"), "{said}");
    let (_, rows) = table(&out.join("branch.csv"));
    let values: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    for v in ["0.8", "0.75", "0.7", "0.65", "0.6", "0.55", "0.5", "0.45", "0.4"] {
        assert!(values.contains(&v), "{v} not in {values:?}");
    }
    // at the default tolerances: crossed and located, no near miss
    let tight = fresh("switch-tight");
    let (said, err, ok) = ezy(
        &["analyze", "drive-rolling-resistance", "--continue", "motor.amplitude=0.8:0.4:9", "--no-figures"],
        &tight,
    );
    assert!(ok, "{said}{err}");
    assert!(said.contains("branch point at motor.amplitude") && !said.contains("came within"), "{said}");
}

/// `ezy analyze` on Baker and Gollub's forced pendulum (`tests/bifurcation.rs`)
/// with `--continue motor.torque.cos.amplitude=10.40:10.50:3 --switch`:
/// the period-1 gait, stable below its period doubling at g = 1.0664
/// (A = 10.461 N m) and unstable above, and the doubled branch born there
/// (branch-1.csv), followed to 10.50: its period twice the forcing's (to
/// 1e-9 relative), stable, the doubling supercritical. A whole run at
/// 10.50 from the doubled orbit's state put 1e-3 rad off (the run from
/// hanging at rest settles on the mirror image, which turns the other
/// way), 200 forcing periods sampled once a period, comes back to the
/// orbit's angle to 1e-8 rad (the transient's remains after 200 periods
/// and the run's 1e-10 tolerances; measured 9.7e-11), as a stable orbit
/// lets it, and
/// alternates: it is not period-1.
#[test]
fn the_cli_switches_onto_the_forced_pendulums_doubled_branch() {
    use crate::analysis::{ezy, fresh, table};
    use crate::bifurcation::{BAKER_GOLLUB, forced_pendulum};
    let out = fresh("switch-pendulum");
    std::fs::create_dir_all(&out).unwrap();
    let text = forced_pendulum(BAKER_GOLLUB.0, BAKER_GOLLUB.1, BAKER_GOLLUB.2);
    let file = out.join("forced-pendulum.toml");
    std::fs::write(&file, &text).unwrap();
    let (said, err, ok) = ezy(
        &[
            "analyze",
            file.to_str().unwrap(),
            "--continue",
            "motor.torque.cos.amplitude=10.40:10.50:3",
            "--switch",
            "--no-figures",
        ],
        &out.join("out"),
    );
    assert!(ok, "{said}{err}");
    assert!(said.contains("is a period doubling (supercritical)"), "{said}");
    let forcing = std::f64::consts::TAU / BAKER_GOLLUB.1;
    let (h, parent) = table(&out.join("out/branch.csv"));
    let at = |name: &str| h.iter().position(|c| c == name).unwrap();
    for r in parent.iter().filter(|r| r[at("bifurcation")].is_empty()) {
        let a: f64 = r[0].parse().unwrap();
        assert_eq!(r[at("stability")], if a < 10.461 { "stable" } else { "unstable" }, "{r:?}");
    }
    let (h, born) = table(&out.join("out/branch-1.csv"));
    let at = |name: &str| h.iter().position(|c| c == name).unwrap();
    for r in &born {
        let period: f64 = r[at("period")].parse().unwrap();
        assert!((period - 2.0 * forcing).abs() < 1e-9 * forcing, "{period}");
        assert_eq!(r[at("stability")], "stable", "{r:?}");
    }
    let last = born.last().unwrap();
    assert_eq!(last[0], "10.5");
    let phi: f64 = last[at("phi")].parse().unwrap();
    let phid: f64 = last[at("phid")].parse().unwrap();
    let t0: f64 = last[at("t0")].parse().unwrap();
    assert_eq!(t0, 0.0, "a forced scene's branch holds the forcing's phase 0");
    // the run from the doubled orbit's state put 1e-3 off, sampled once a
    // forcing period: it comes back to the orbit (stable) and alternates
    let scene = ezy_scene::Scene::from_toml(&text, "forced-pendulum.toml").unwrap();
    let sets = [("motor.torque.cos.amplitude".to_string(), 10.5)];
    let (run, _) = scene.problem::<ezy::models::Pendulum>(&sets).unwrap();
    let run = run.q("phi", phi + 1e-3).unwrap().qd("phi", phid).unwrap();
    let sol = run.t_end(200.0 * forcing).every(forcing).solve().unwrap();
    let p = sol.column("phi").unwrap();
    let wrap = |a: f64| (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    let n = p.len();
    assert_eq!(n, 201, "a sample per forcing period");
    // 200 periods on: an even number, the orbit's own phase
    let (a, b) = (wrap(p[n - 1]), wrap(p[n - 2]));
    let off = wrap(phi - a).abs();
    eprintln!("pendulum at 10.5: the doubled orbit's phi {phi}, the run's last two {a} {b}: off by {off:e}");
    assert!(off < 1e-8, "{phi} against the run's {a}");
    assert!(wrap(a - b).abs() > 1e-2, "the run repeats every period: {a} {b}");
}
