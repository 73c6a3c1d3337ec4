//! Bifurcations located on branches (`ezy_core::analysis::bifurcation`):
//! a Hopf point known in closed form, on a model and force law of the
//! user's own; the forced damped pendulum's first period doubling against
//! the literature and whole runs; the rolling-resistance gait's branch
//! point in the motor's amplitude, checked on both sides by independent
//! searches.

use ezy::models::{EzyRoller, Pendulum, scenes};
use ezy_core::analysis::arclength::{follow_arclength, switch_branch};
use ezy_core::analysis::bifurcation::{BifurcationKind, locate};
use ezy_core::analysis::branch::{Follow, follow};
use ezy_core::analysis::{Analysis, AnalysisError, BranchEnd, PeriodicSettings, Solution, Stability};

use crate::optimize::{Cart, K, M, cart};

/// The cart on its rail (the user's own model) held by a spring `k` and
/// a damper `c` of the user's own law: its rest at x = 0 has the
/// eigenvalues `-c / 2m +- i sqrt(k/m - c^2/4m^2)`, a pair crossing the
/// imaginary axis at `c = 0` (a Hopf point, the normal form's linear
/// part) with the critical eigenvalues `+-i sqrt(k/m)` = `+-2i`. The
/// branch in `c` from -0.3 to 0.2 N s/m, 6 points (none at 0), holds the
/// change; located to 1e-8: within 1e-8 of 0 (the bisection's bracket
/// holds it), its kind Hopf, its critical pair within 1e-6 of `+-2i`
/// (the linearization's force derivatives are central differences,
/// 1e-10). Measured: c = -1.5e-9 in 25 solves, the pair 3.7e-10 +- 2i.
#[test]
fn a_hopf_point_is_located_where_the_damping_changes_sign() {
    let build = |c: f64| -> Result<Analysis<Cart>, AnalysisError> {
        Ok(cart(K, c, None, 0.0, 10.0).map_err(AnalysisError::Sim)?.analysis()?.0)
    };
    let (_, x0) = cart(K, -0.3, None, 0.0, 10.0).unwrap().analysis().unwrap();
    let values = [-0.3, -0.2, -0.1, 0.05, 0.1, 0.2];
    let how = Follow::Steady { energy: None };
    let (points, ended) = follow(&values, &x0, how, build, |_| {});
    assert!(ended.is_none(), "{ended:?}");
    let k = points.windows(2).position(|w| w[0].value < 0.0 && w[1].value > 0.0).unwrap();
    let b = locate(&points[k], &points[k + 1], how, build, 1e-8).unwrap().expect("a bifurcation");
    eprintln!("hopf: at c = {:e}, bracket {:?}, critical {:?}, {} solves", b.value, b.bracket, b.critical, b.solves);
    assert_eq!(b.kind, BifurcationKind::Hopf);
    assert!(b.value.abs() < 1e-8, "{}", b.value);
    assert!(b.bracket[0] < 0.0 && b.bracket[1] >= 0.0 || b.bracket[0] >= 0.0 && b.bracket[1] < 0.0, "{:?}", b.bracket);
    let omega = (K / M).sqrt();
    assert_eq!(b.critical.len(), 2);
    for z in &b.critical {
        assert!(z.re.abs() < 1e-6 && (z.im.abs() - omega).abs() < 1e-6, "{z:?}");
    }
}

/// The rolling-resistance gait (`drive-rolling-resistance`) loses its
/// stability as the motor's amplitude falls: the branch from 4 to 0.5
/// N m (15 points) is stable down to 0.75 and unstable at 0.5; located
/// to 1e-8 between them, a branch point at 0.6380639 N m (the straight
/// gait's symmetry-breaking pitchfork: a run below it turns), its
/// critical multiplier real and within 1e-6 of 1. Checked by searches
/// of their own 1e-5 N m either side: the largest multiplier below 1
/// above the point and above 1 below it (measured: 0.6380638704, the
/// critical multiplier 1 + 1.4e-10; 0.9999981 and 1.0000019 either side).
/// Switched onto the other branch there (turning gaits) and followed to
/// 0.5 N m: a stable gait turning -0.0618441 rad per period, a 1000 s
/// run's last period -0.0618417 (bound 1e-5: the run's own tolerances
/// and its transient's remains; the turn's sign is the branch's, left and
/// right being mirror images).
#[test]
fn the_rolling_resistance_gait_has_a_branch_point_in_the_motor_amplitude() {
    let scene = scenes::get("drive-rolling-resistance");
    let build = |a: f64| -> Result<Analysis<EzyRoller>, AnalysisError> {
        let sets = [("motor.amplitude".to_string(), a)];
        Ok(scene
            .problem::<EzyRoller>(&sets)
            .map_err(|e| AnalysisError::Request { reason: e.to_string() })?
            .0
            .analysis()?
            .0)
    };
    let (problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let guess = problem.t_end(120.0).solve().unwrap().final_state()[..12].to_vec();
    let settings = PeriodicSettings::default();
    let how = Follow::Periodic { t0: 0.0, period: 2.0, settings };
    let values: Vec<f64> = (0..15).map(|k| 4.0 - 0.25 * k as f64).collect();
    let (points, ended) = follow(&values, &guess, how, build, |_| {});
    assert!(ended.is_none(), "{ended:?}");
    let k = points.windows(2).position(|w| w[0].solution.stability() != w[1].solution.stability()).unwrap();
    let b = locate(&points[k], &points[k + 1], how, build, 1e-8).unwrap().expect("a bifurcation");
    eprintln!("rolling resistance: {:?} at {}, bracket {:?}, critical {:?}", b.kind, b.value, b.bracket, b.critical);
    assert_eq!(b.kind, BifurcationKind::BranchPoint);
    assert!((b.value - 0.6380639).abs() < 1e-6, "{}", b.value);
    assert!((b.bracket[1] - b.bracket[0]).abs() <= 1e-8 * (1.0 + b.value), "{:?}", b.bracket);
    assert!((b.critical[0].re - 1.0).abs() < 1e-6 && b.critical[0].im == 0.0, "{:?}", b.critical);
    for (side, above) in [(b.value + 1e-5, true), (b.value - 1e-5, false)] {
        let mut an = build(side).unwrap();
        let sym = an.symmetry(0.0, b.solution.state()).unwrap();
        let o = an.periodic_orbit(0.0, 2.0, b.solution.state(), sym, &settings).unwrap();
        let largest = o.multipliers.iter().map(|z| z.re.hypot(z.im)).fold(0.0, f64::max);
        eprintln!("at {side}: largest multiplier {largest}");
        assert_eq!(largest < 1.0, above, "at {side}: {:?}", o.multipliers);
    }
    // the other branch: turning gaits, switched onto along the critical
    // direction and followed down to 0.5 N m, against a whole run there
    let (p, how2) = switch_branch(&b, how, build, 1e-3).unwrap();
    let turn = |s: &Solution| match s {
        Solution::Periodic(o) => o.heading_change,
        Solution::Steady(_) => unreachable!(),
    };
    eprintln!("switched: at {} heading change {} per period", p.value, turn(&p.solution));
    assert!(turn(&p.solution).abs() > 1e-4, "{}", turn(&p.solution));
    let values = [p.value, 0.5];
    let (new, ended) = follow_arclength(&values, p.solution.state(), how2, build, |_| {});
    assert!(matches!(ended, BranchEnd::Reached), "{ended:?}");
    let last = new.last().unwrap();
    assert_eq!(last.value, 0.5);
    let sets = [("motor.amplitude".to_string(), 0.5)];
    let (run, _) = scene.problem::<EzyRoller>(&sets).unwrap();
    let sol = run.t_end(1000.0).every(2.0).solve().unwrap();
    let phi = sol.column("phi1").unwrap();
    let n = phi.len();
    let measured = phi[n - 1] - phi[n - 2];
    eprintln!("at 0.5 N m: the branch turns {} per period, a 1000 s run {measured}", turn(&last.solution));
    // the run's scene tolerances and what is left of its transient
    // bound the agreement (measured 2.4e-6 rad of 0.0618 rad)
    assert!((turn(&last.solution).abs() - measured.abs()).abs() < 1e-5, "{} against {measured}", turn(&last.solution));
    assert_eq!(last.solution.stability(), Stability::Stable);
}

/// Baker and Gollub's forced damped pendulum, `theta'' + theta' / q +
/// sin(theta) = g cos(omega_D t)` in time scaled by `omega_0 = sqrt(g/L)`,
/// with `q = 2` and `omega_D = 2/3`, on the built-in pendulum (1 kg at
/// 1 m, 9.81 m/s^2): a rotational drag `c_rot = omega_0 / q` and a torque
/// `A cos(omega t)` with `omega = 2 omega_0 / 3` and `A = g omega_0^2`.
/// `(A, omega, c_rot)` [N m, rad/s, N m s/rad].
pub(crate) const BAKER_GOLLUB: (f64, f64, f64) = (10.4, 2.08806130178211, 1.5660459763365826);

/// A scene of the built-in pendulum (1 kg at 1 m) under gravity, a torque
/// `amplitude cos(omega t)` [N m, rad/s] and a rotational drag `c_rot`
/// [N m s/rad], hanging at rest to start, DOP853 at 1e-10: Baker and
/// Gollub's pendulum here, the resonance curve of `tests/continuation.rs`.
pub(crate) fn forced_pendulum(amplitude: f64, omega: f64, c_rot: f64) -> String {
    format!(
        r#"
name = "forced-pendulum"
description = "a forced damped pendulum"
model = "pendulum"
t_end = 300.0

[initial]
q = {{ phi = -1.5707963267948966 }}
qd = {{ phi = 0.0 }}

[integrator]
method = "dop853"
rtol = 1e-10
atol = 1e-10

[effects.gravity]
kind = "gravity"
g = [0.0, -9.81]

[effects.motor]
kind = "torque"
body = "bob"
torque = {{ cos = {{ amplitude = {amplitude:?}, omega = {omega:?} }} }}

[effects.drag]
kind = "linear-drag"
body = "bob"
c = 0.0
c_rot = {c_rot:?}
"#
    )
}

/// The forced damped pendulum's first period doubling (Baker & Gollub,
/// *Chaotic Dynamics: An Introduction*, 2nd ed., §3.3: `q = 2`,
/// `omega_D = 2/3`, the period-1 oscillation doubles at `g = 1.0663`).
/// The gait's branch in the torque's amplitude, 10.40 to 10.50 N m, is
/// stable then unstable; located to 1e-8: period doubling, its critical
/// multiplier real and within 1e-6 of -1, at `g = A / omega_0^2` within
/// 1e-4 of 1.0663 (measured 1.066373, 20 solves). Whole runs of their own (600 s,
/// sampled once a forcing period) confirm it: 0.02 N m below, the motion
/// repeats every period; 0.02 N m above, every second period only.
/// Switched onto the doubled orbits' branch: an orbit of twice the
/// period, not the period-1 one (a forcing period apart from itself by
/// more than 1e-3 rad), on the side the runs double on.
#[test]
fn the_forced_pendulums_first_period_doubling_is_located() {
    let scene = ezy_scene::Scene::from_toml(
        &forced_pendulum(BAKER_GOLLUB.0, BAKER_GOLLUB.1, BAKER_GOLLUB.2),
        "forced-pendulum.toml",
    )
    .unwrap();
    let with = |a: f64| [("motor.torque.cos.amplitude".to_string(), a)];
    let build = |a: f64| -> Result<Analysis<Pendulum>, AnalysisError> {
        let p = scene.problem::<Pendulum>(&with(a)).map_err(|e| AnalysisError::Request { reason: e.to_string() })?;
        Ok(p.0.analysis()?.0)
    };
    let (problem, _) = scene.problem::<Pendulum>(&[]).unwrap();
    let guess = problem.solve().unwrap().final_state()[..6].to_vec();
    let omega0 = 9.81f64.sqrt();
    let period = std::f64::consts::TAU / (2.0 * omega0 / 3.0);
    let how = Follow::Periodic { t0: 300.0, period, settings: PeriodicSettings::default() };
    let (points, ended) = follow(&[10.40, 10.45, 10.50], &guess, how, build, |_| {});
    assert!(ended.is_none(), "{ended:?}");
    let b = locate(&points[1], &points[2], how, build, 1e-8).unwrap().expect("a bifurcation");
    let g = b.value / (omega0 * omega0);
    eprintln!("pendulum: {:?} at A = {} (g = {g}), critical {:?}, {} solves", b.kind, b.value, b.critical, b.solves);
    assert_eq!(b.kind, BifurcationKind::PeriodDoubling);
    assert!((b.critical[0].re + 1.0).abs() < 1e-6 && b.critical[0].im == 0.0, "{:?}", b.critical);
    assert!((g - 1.0663).abs() < 1e-4, "g = {g}");
    // whole runs, sampled once a period from 200 periods on
    for (a, doubled) in [(b.value - 0.02, false), (b.value + 0.02, true)] {
        let (p, _) = scene.problem::<Pendulum>(&with(a)).unwrap();
        let sol = p.t_end(200.0 * period).every(period).solve().unwrap();
        let phi = sol.column("phi").unwrap();
        let n = phi.len();
        let (one, two) = ((phi[n - 1] - phi[n - 2]).abs(), (phi[n - 1] - phi[n - 3]).abs());
        eprintln!("pendulum at A = {a}: a period's change {one:e}, two periods' {two:e}");
        assert!(two < 1e-3, "A = {a}: {two:e} after two periods");
        assert_eq!(one > 1e-2, doubled, "A = {a}: {one:e} after one period");
    }
    // the doubled orbits' branch, switched onto: twice the period, half a
    // period apart from itself, and on the side the runs double on
    let (p, how2) = switch_branch(&b, how, build, 1e-2).unwrap();
    let (Solution::Periodic(o), Follow::Periodic { t0, settings, .. }) = (&p.solution, how2) else {
        panic!("a periodic orbit")
    };
    let (half, _) = build(p.value).unwrap().end_state(t0, &o.state, period, &settings).unwrap();
    let apart = (half[2] - o.state[2]).abs();
    eprintln!(
        "doubled: at A = {} (period {} s), one forcing period apart by {apart} rad, {:?}",
        p.value, o.period, o.stability
    );
    assert!((o.period - 2.0 * period).abs() < 1e-9 * period, "{}", o.period);
    assert!(apart > 1e-3, "{apart}");
    assert!(p.value > b.value - 1e-7, "{} against {}", p.value, b.value);
}
