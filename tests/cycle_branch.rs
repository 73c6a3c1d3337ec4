//! Branches of limit cycles (`ezy_core::analysis::cycle_branch`): born at
//! a Hopf point of a user's own model and force law, switched onto and
//! followed by pseudo-arclength, the period free; checked against the
//! closed form and against whole runs of the scene.

use std::f64::consts::TAU;

use ezy_core::analysis::arclength::follow_arclength;
use ezy_core::analysis::bifurcation::{BifurcationKind, locate};
use ezy_core::analysis::branch::{Follow, follow};
use ezy_core::analysis::cycle_branch::switch_at_hopf;
use ezy_core::analysis::{Analysis, AnalysisError, BranchEnd, PeriodicOrbit, PeriodicSettings, Solution, Stability};
use ezy_core::effects::{ForceLaw, Periodicity};
use ezy_core::{Method, Problem};

use crate::optimize::{Cart, K, M};

/// A spring and an energy-seeking damper on the cart's rail: `F = -k x +
/// m (mu - E) xd`, `E = x^2 + xd^2 / omega^2`, `omega^2 = k / m` \[N\].
/// Then `dE/dt = 2 xd^2 (mu - E) / omega^2`: for `mu > 0` the cycle `E =
/// mu`, `x = sqrt(mu) cos(omega t)`, exact, of period `2 pi / omega`
/// whatever `mu`, and the rest `x = 0` (eigenvalues `mu/2 +- i sqrt(omega^2
/// - mu^2/4)`) has a Hopf point at `mu = 0`, its pair `+-i omega`.
#[derive(Debug, Clone)]
struct SeeksEnergy {
    /// Stiffness \[N/m\].
    k: f64,
    /// The cart's mass \[kg\].
    m: f64,
    /// The energy level sought \[m^2\].
    mu: f64,
}

impl ForceLaw for SeeksEnergy {
    fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let (x, v) = (q[0], qd[0]);
        let e = x * x + v * v * self.m / self.k;
        let fx = -self.k * x + self.m * (self.mu - e) * v;
        f[0] += fx;
        (fx * v, fx)
    }
    fn coords(&self) -> Vec<usize> {
        vec![0]
    }
    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }
}

/// The cart under [`SeeksEnergy`] at `mu`, from `(x0, xd0)`, to `t_end`
/// \[s\], DOP853 at 1e-12.
fn cart(mu: f64, (x0, v0): (f64, f64), t_end: f64) -> Result<Problem<Cart>, ezy_core::SimError> {
    Ok(Problem::new(Cart::default())
        .law("seeks", SeeksEnergy { k: K, m: M, mu })?
        .q("x", x0)?
        .q("y", 0.0)?
        .q("phi", 0.0)?
        .qd("x", v0)?
        .t_end(t_end)
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12))
}

/// The scene at `mu` for the analyses.
fn build(mu: f64) -> Result<Analysis<Cart>, AnalysisError> {
    Ok(cart(mu, (0.0, 0.0), 10.0).map_err(AnalysisError::Sim)?.analysis()?.0)
}

/// The period of a whole run at `mu` from `start` (x, xd), over its last
/// 100 s of 200 (the transient decays as `exp(-mu t)` at least): the time
/// between the first and last upward zero crossings of `x` in them,
/// sampled every 1 ms and interpolated linearly (at a crossing of a
/// sinusoid its curvature vanishes: the error is `(omega dt)^3 / 6 omega`
/// = 7e-10 s at each end), over the number of periods between them.
fn run_period(mu: f64, start: (f64, f64)) -> f64 {
    let sol = cart(mu, start, 200.0).unwrap().every(1e-3).solve().unwrap();
    let x = sol.column("x").unwrap();
    let up: Vec<f64> = (1..x.len())
        .filter(|&i| sol.t[i - 1] >= 100.0 && x[i - 1] < 0.0 && x[i] >= 0.0)
        .map(|i| sol.t[i - 1] + (sol.t[i] - sol.t[i - 1]) * (-x[i - 1]) / (x[i] - x[i - 1]))
        .collect();
    (up[up.len() - 1] - up[0]) / (up.len() - 1) as f64
}

/// The orbit of a branch point.
fn orbit(s: &Solution) -> &PeriodicOrbit {
    match s {
        Solution::Periodic(o) => o,
        Solution::Steady(_) => panic!("a limit cycle"),
    }
}

/// The rest's branch in `mu` from -0.3 to 0.3 (4 points, none at 0)
/// loses its stability at a Hopf point located to 1e-8 at 0, its pair
/// `+-i omega` to 1e-6 (the linearization's force derivatives are central
/// differences, 1e-10). Switched onto its cycles at an amplitude 1e-2 and
/// followed to `mu = 1` by pseudo-arclength, the period free: each cycle
/// has the period `2 pi / omega` to 1e-8 (the shooting's Newton stops at
/// 1e-10 of the state, its integration at 1e-11: the period, the
/// residual over the flow's speed `omega sqrt(mu)`, is held to about
/// 1e-10), its energy `E` the parameter `mu` to 1e-8 (near the Hopf
/// point the residual's dependence on `mu` is weak, about `a T` for the
/// amplitude `a = 5e-3`, and the corrector's residual 1e-10 holds `mu`
/// only to about 1e-8 there: measured 6e-10; from `mu = 0.1` on, the
/// amplitude `sqrt(E)` is `sqrt(mu)` to 1e-8 relative), one
/// Floquet multiplier besides the time shift's, `exp(-mu T)` (Liouville:
/// the trace of the linearization, `-2 xd^2 / omega^2`, over the cycle
/// is `-mu T`) to 1e-7, and is stable. Whole runs of the scene from 10%
/// off the cycle, at three values of `mu`, repeat with the cycle's period
/// to 1e-8 (the runs' crossings interpolated to 1e-9 s over 30 periods).
#[test]
fn limit_cycles_born_at_a_hopf_point_are_followed_with_their_period_free() {
    let omega = (K / M).sqrt();
    let how = Follow::Steady { energy: None };
    let (points, ended) = follow(&[-0.3, -0.1, 0.1, 0.3], &[0.0; 6], how, build, |_| {});
    assert!(ended.is_none(), "{ended:?}");
    let b = locate(&points[1], &points[2], how, build, 1e-8).unwrap().expect("a bifurcation");
    eprintln!("hopf: at mu = {:e}, critical {:?}, {} solves", b.value, b.critical, b.solves);
    assert_eq!(b.kind, BifurcationKind::Hopf);
    assert!(b.value.abs() < 1e-8, "{}", b.value);
    for z in &b.critical {
        assert!(z.re.abs() < 1e-6 && (z.im.abs() - omega).abs() < 1e-6, "{z:?}");
    }
    let settings = PeriodicSettings { newton_tolerance: 1e-10, ..PeriodicSettings::default() };
    let (p, how) = switch_at_hopf(&b, build, 1e-2, settings).unwrap();
    let o = orbit(&p.solution);
    eprintln!("switched: at mu = {:e}, period {}, state {:?}", p.value, o.period, o.state);
    assert!(matches!(how, Follow::Cycle { .. }), "{how:?}");
    let values: Vec<f64> = (0..=10).map(|k| p.value + (1.0 - p.value) * k as f64 / 10.0).collect();
    let (branch, ended) = follow_arclength(&values, &o.state, how, build, |_| {});
    assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
    assert_eq!(branch.last().unwrap().value, 1.0);
    let period = TAU / omega;
    let (mut worst_t, mut worst_e, mut worst_a, mut worst_mu) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for q in &branch {
        let o = orbit(&q.solution);
        let mu = q.value;
        let e = o.state[0].powi(2) + o.state[3].powi(2) / (omega * omega);
        let expected = (-mu * o.period).exp();
        eprintln!(
            "mu = {mu:.6}: period {:.12}, amplitude {:.10} (sqrt(mu) {:.10}), multipliers {:?}, {:?}",
            o.period,
            e.sqrt(),
            mu.sqrt(),
            o.multipliers,
            o.stability
        );
        worst_t = worst_t.max((o.period - period).abs());
        worst_e = worst_e.max((e - mu).abs());
        if mu >= 0.1 {
            worst_a = worst_a.max((e.sqrt() - mu.sqrt()).abs() / mu.sqrt());
        }
        assert_eq!(o.multipliers.len(), 1, "{:?}", o.multipliers);
        worst_mu = worst_mu.max((o.multipliers[0].re - expected).abs() + o.multipliers[0].im.abs());
        assert_eq!(o.stability, Stability::Stable);
    }
    eprintln!("worst: period {worst_t:e} s, E - mu {worst_e:e}, amplitude {worst_a:e}, multiplier {worst_mu:e}");
    assert!(branch.len() >= 11, "{} points", branch.len());
    assert!(worst_t < 1e-8, "{worst_t:e}");
    assert!(worst_e < 1e-8, "{worst_e:e}");
    assert!(worst_a < 1e-8, "{worst_a:e}");
    assert!(worst_mu < 1e-7, "{worst_mu:e}");
    // three cycles at mu near 0.3, 0.6 and 1 (the runs' transients decay
    // as exp(-mu t): nearer the Hopf point they leave more than 1e-8)
    let near = |m: f64| branch.iter().min_by(|a, b| (a.value - m).abs().total_cmp(&(b.value - m).abs())).unwrap();
    for q in [near(0.3), near(0.6), near(1.0)] {
        let o = orbit(&q.solution);
        let measured = run_period(q.value, (1.1 * o.state[0], 1.1 * o.state[3]));
        eprintln!("mu = {}: cycle {:.12} s, run {measured:.12} s", q.value, o.period);
        assert!((measured - o.period).abs() < 1e-8, "{measured} against {}", o.period);
    }
}

/// `ezy analyze four-bar --continue motor.torque.constant=0.3:0.31:5`: the
/// scene's run turns on a limit cycle (the crank's heading turning a
/// whole turn a period), whose branch in the motor's torque is followed
/// with the period free (branch.csv: 5 rows, the period falling as the
/// torque drives the crank faster: 0.7830 s to 0.7438 s). At 0.31 N m
/// the branch's period agrees with the limit cycle `ezy analyze` finds
/// there from a run of its own to 1e-8 s: both are shooting solutions to
/// 1e-9 of the state at DOP853's 1e-11 (measured 9.7e-12 s).
#[test]
fn analyze_continues_a_limit_cycle_with_its_period_free() {
    use crate::analysis::{ezy, fresh, table};
    let out = fresh("cycle-branch");
    let (said, err, ok) =
        ezy(&["analyze", "four-bar", "--continue", "motor.torque.constant=0.3:0.31:5", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    assert!(!said.contains("the branch ends") && !err.contains("the branch ends"), "{said}{err}");
    let (head, rows) = table(&out.join("branch.csv"));
    let col = |row: &[String], name: &str| row[head.iter().position(|h| h == name).unwrap()].parse::<f64>().unwrap();
    let values: Vec<f64> = rows.iter().map(|r| col(r, "motor.torque.constant")).collect();
    let periods: Vec<f64> = rows.iter().map(|r| col(r, "period")).collect();
    eprintln!("four-bar's cycles: torques {values:?}, periods {periods:?}");
    assert_eq!(values, [0.3, 0.3025, 0.305, 0.3075, 0.31]);
    assert!(periods.windows(2).all(|w| w[1] < w[0]), "{periods:?}");
    let alone = fresh("cycle-alone");
    let (said, err, ok) = ezy(&["analyze", "four-bar", "--set", "motor.torque.constant=0.31", "--no-figures"], &alone);
    assert!(ok, "{said}{err}");
    let (head, rows) = table(&alone.join("periodic.csv"));
    let period: f64 = rows[0][head.iter().position(|h| h == "period").unwrap()].parse().unwrap();
    eprintln!("at 0.31 N m: the branch's period {}, the analysis' {period}", periods[4]);
    assert!((periods[4] - period).abs() < 1e-8, "{} against {period}", periods[4]);
}

/// The same cycle on a coarse grid, `0.3:0.5:3`: the first arclength step
/// is long, and the tangent at the point it reaches (0.316 N m), computed
/// with the phase condition through 0.3's cycle, has its parameter
/// component of the wrong sign. That used to be located as a "fold" at
/// 0.3158949 N m with the critical multiplier 0.046427, far from the 1 a
/// fold has: a false bifurcation. A fold is now told only where a
/// multiplier is within 1e-2 of the unit circle: this one is said not a
/// fold, and no fold is written.
#[test]
fn a_sign_change_of_the_tangent_without_a_critical_multiplier_is_not_a_fold() {
    use crate::analysis::{ezy, fresh, table};
    let out = fresh("cycle-coarse");
    let (said, err, ok) =
        ezy(&["analyze", "four-bar", "--continue", "motor.torque.constant=0.3:0.5:3", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    assert!(!said.contains("note: fold at"), "{said}");
    let (head, rows) = table(&out.join("branch.csv"));
    // (the column is written where a bifurcation is)
    if let Some(at) = head.iter().position(|h| h == "bifurcation") {
        assert!(rows.iter().all(|r| r[at].is_empty()), "{rows:?}");
    }
    if said.contains("the tangent's parameter component changes sign") {
        assert!(said.contains("not a fold"), "{said}");
    }
}
