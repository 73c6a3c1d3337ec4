//! The analyses (`ezy_core::analysis`) against closed forms and
//! independent checks: the Chaplygin sleigh's steady motions, the double
//! pendulum's linearized frequencies, the exact Jacobian against
//! differences, the free EzyRoller's steady motions, the gaits of
//! `drive-rolling-resistance` and `snake`, and the four-bar's limit
//! cycle.

use crate::common;

use ezy::models::{ChaplyginSleigh, DoublePendulum, EzyRoller, FourBar, Snake, scenes};
use ezy_core::analysis::{Analysis, Input, PeriodicSettings, Stability, Symmetry};
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model};

/// The analysis of a built-in scene and its consistent initial state.
fn analysis<M: Model + Default>(scene: ezy_scene::Scene) -> (Analysis<M>, Vec<f64>) {
    let (problem, _) = scene.problem::<M>(&[]).unwrap();
    problem.analysis().unwrap()
}

/// The Chaplygin sleigh going straight at speed `U` is a relative
/// equilibrium with eigenvalues 0 (the family of speeds) and
/// `-m a U / (I + m a^2)` (docs/physics.md §9: linearize `omega' = -m a u
/// omega / (I + m a^2)` at `omega = 0`): stable forward, unstable backward.
/// Agreement to 1e-10: the eigenvalues come from exact derivatives (the
/// sleigh has no applied forces) and a 2 x 2 eigenproblem.
#[test]
fn sleigh_straight_motion_has_the_closed_form_eigenvalues() {
    let (mut an, _) = analysis::<ChaplyginSleigh>(scenes::sleigh());
    let m = ChaplyginSleigh::default();
    for u in [1.3, -0.8] {
        // heading 0.4 rad, moving along it
        let x = [0.2, -0.1, 0.4, u * 0.4f64.cos(), u * 0.4f64.sin(), 0.0];
        let sym = an.symmetry(0.0, &x).unwrap();
        assert_eq!(sym, Symmetry::SE2);
        let s = an.steady_motion(0.0, &x, sym, None).unwrap();
        let want = -m.m * m.a * u / (m.I + m.m * m.a * m.a);
        assert_eq!(s.eigenvalues.len(), 2, "{:?}", s.eigenvalues);
        assert_eq!(s.family, 1);
        let (big, small) = (
            s.eigenvalues.iter().find(|z| z.re.abs() > 1e-6).unwrap(),
            s.eigenvalues.iter().find(|z| z.re.abs() <= 1e-6).unwrap(),
        );
        assert!((big.re - want).abs() < 1e-10 && big.im.abs() < 1e-12, "{big:?} want {want}");
        assert!(small.re.abs() < 1e-10 && small.im.abs() < 1e-10, "{small:?}");
        assert_eq!(s.stability, if u > 0.0 { Stability::Stable } else { Stability::Unstable });
        assert!(
            (s.body_velocity[0] - u).abs() < 1e-12
                && s.body_velocity[1].abs() < 1e-12
                && s.body_velocity[2].abs() < 1e-12
        );
        // moved to the origin, heading 0
        assert!(s.state[..3].iter().all(|v| v.abs() < 1e-12), "{:?}", s.state);
    }
}

/// The double pendulum hanging straight down: an ordinary equilibrium (no
/// symmetry: hinged to the ground, under gravity) whose eigenvalues are
/// `+-i w` with the normal-mode frequencies of `det(K - w^2 M) = 0`
/// (Goldstein's small oscillations in the bars' absolute angles, as in
/// tests/mechanisms.rs): 2.940 and 7.366 rad/s. Gravity is an applied
/// force (its exact Jacobian is zero: a force of no state), and the
/// frequencies agree to 1e-8.
#[test]
fn double_pendulum_linearized_frequencies() {
    let (mut an, _) = analysis::<DoublePendulum>(scenes::get("double-pendulum"));
    let m = DoublePendulum::default();
    let (l1, l2) = (m.L1, m.L2);
    let (_, _, roots) = common::double_pendulum_modes(&m);
    let want = [roots[1].sqrt(), roots[0].sqrt()];
    assert!((want[0] - 7.366).abs() < 1e-3 && (want[1] - 2.940).abs() < 1e-3, "{want:?}");
    // a guess off the equilibrium: both bars 0.2 rad out, moving
    let (p1, p2) = (-std::f64::consts::FRAC_PI_2 + 0.2, -std::f64::consts::FRAC_PI_2 - 0.1);
    let e1 = [l1 * p1.cos(), l1 * p1.sin()];
    let x = [
        l1 / 2.0 * p1.cos(),
        l1 / 2.0 * p1.sin(),
        p1,
        e1[0] + l2 / 2.0 * p2.cos(),
        e1[1] + l2 / 2.0 * p2.sin(),
        p2,
        0.1,
        0.0,
        0.3,
        0.0,
        0.0,
        -0.2,
    ];
    let sym = an.symmetry(0.0, &x).unwrap();
    assert_eq!(sym, Symmetry::NONE);
    let s = an.steady_motion(0.0, &x, sym, None).unwrap();
    assert!(
        (s.state[2] + std::f64::consts::FRAC_PI_2).abs() < 1e-10
            && (s.state[5] + std::f64::consts::FRAC_PI_2).abs() < 1e-10,
        "{:?}",
        s.state
    );
    assert_eq!(s.eigenvalues.len(), 4);
    assert_eq!(s.stability, Stability::Neutral);
    let mut freqs: Vec<f64> = s.eigenvalues.iter().map(|z| z.im.abs()).collect();
    freqs.sort_by(|a, b| b.total_cmp(a));
    for (k, w) in want.iter().enumerate() {
        for f in &freqs[2 * k..2 * k + 2] {
            assert!((f - w).abs() < 1e-8 * w, "{f} want {w}");
        }
    }
    assert!(s.eigenvalues.iter().all(|z| z.re.abs() < 1e-7), "{:?}", s.eigenvalues);
}

/// The exact `A` and `B` against central differences of the right-hand
/// side (step 1e-6, truncation and rounding about 1e-9 relative) on the
/// EzyRoller under a motor and rolling resistance, at a state off any
/// symmetry: a wrong dual-number seed or sign in the implicit
/// differentiation of the KKT system shows as an O(1) error.
#[test]
fn linearization_matches_differences_of_the_right_hand_side() {
    let (mut an, x0) = analysis::<EzyRoller>(scenes::get("drive-rolling-resistance"));
    let nq = an.nq();
    let mut x = x0.clone();
    for (i, v) in x.iter_mut().enumerate() {
        *v += 0.05 * (1.7 * i as f64).sin();
    }
    let t = 0.37;
    let inputs = [Input::HingeTorque("B".into()), Input::EffectScale("rolling_A".into())];
    let lin = an.linearize(t, &x, &inputs).unwrap();
    // the motor's and the rolling resistance's Jacobians are exact
    assert!(!lin.forces_by_differences);
    assert!(an.differenced_laws().is_empty());
    let h = 1e-6;
    let scale = lin.a.norm_max();
    for j in 0..2 * nq {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[j] += h;
        xm[j] -= h;
        let (fp, fm) = (an.rhs(t, &xp).unwrap(), an.rhs(t, &xm).unwrap());
        for i in 0..2 * nq {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            assert!((fd - lin.a[(i, j)]).abs() < 1e-7 * scale, "A[{i},{j}] = {} against {fd}", lin.a[(i, j)]);
        }
    }
    // B: a torque at hinge B through the scene's motor (same convention),
    // and the rolling resistance at A scaled
    let m = EzyRoller::default();
    let motor = ezy_core::EffectSpec::HingeMotor(ezy_core::effects::HingeMotor {
        hinge: "B".into(),
        torque: ezy_core::effects::Waveform::Constant(1.0),
    });
    let system = |effects| Analysis::new(Dynamics::new(m.clone(), effects, KktMethod::Auto));
    let f_unit = system(vec![motor.resolve("u", &m).unwrap()]).rhs(t, &x).unwrap();
    let f_bare = system(Vec::new()).rhs(t, &x).unwrap();
    for i in 0..2 * nq {
        assert!((f_unit[i] - f_bare[i] - lin.b[(i, 0)]).abs() < 1e-12 * (1.0 + lin.b.norm_max()), "B[{i},0]");
    }
    assert!(lin.b.col(1).iter().any(|v| v.abs() > 1e-6), "the rolling resistance has an effect");
    assert_eq!(lin.input_names, ["tau_B", "scale_rolling_A"]);
    // the reduced matrix lives on the constraint manifold: C T = 0
    assert!((&lin.constraints * &lin.tangent).norm_max() < 1e-12);
    // 12 states less 2 hinge positions, 2 hinge velocities, 2 skates
    assert_eq!(lin.tangent.ncols(), 2 * nq - 6);
}

/// The free EzyRoller (no forces: the kinetic energy is conserved, so its
/// steady motions come in families by energy and are sought at the
/// scene's T0 = 23.1875 J) goes straight in two ways: the fork trailing
/// (hinge angle pi), stable, and the fork leading (hinge angle 0),
/// unstable. The scene's start (fork at 90 degrees) leads Newton to the
/// unstable one; a 60 s simulation of `free` ends at the stable one: its
/// end state has the stable motion's shape and speed to 1e-9 (its
/// eigenvalues -0.78 and -5.0 1/s have damped the start away by e^-47).
#[test]
fn free_ezyroller_settles_on_its_stable_steady_motion() {
    let (mut an, x0) = analysis::<EzyRoller>(scenes::free());
    let t0 = an.dynamics().kinetic_energy(&x0[6..]);
    assert!((t0 - 23.1875).abs() < 1e-9, "{t0}");
    let sym = an.symmetry(0.0, &x0).unwrap();
    assert_eq!(sym, Symmetry::SE2);
    let hinge = |s: &[f64]| (s[5] - s[2]).rem_euclid(std::f64::consts::TAU);
    let leading = an.steady_motion(0.0, &x0, sym, Some(t0)).unwrap();
    assert_eq!(leading.stability, Stability::Unstable);
    assert!(hinge(&leading.state).min(std::f64::consts::TAU - hinge(&leading.state)) < 1e-9, "{:?}", leading.state);
    assert!(leading.eigenvalues[0].re > 1.0, "{:?}", leading.eigenvalues);

    let (problem, _) = scenes::free().problem::<EzyRoller>(&[]).unwrap();
    let sol = problem.t_end(60.0).method(ezy_core::Method::Dop853).tolerances(1e-11, 1e-11).solve().unwrap();
    let end = &sol.final_state()[..12];
    let trailing = an.steady_motion(0.0, end, sym, Some(t0)).unwrap();
    assert_eq!(trailing.stability, Stability::Stable, "{:?}", trailing.eigenvalues);
    assert_eq!(trailing.family, 1);
    assert!((hinge(&trailing.state) - std::f64::consts::PI).abs() < 1e-9, "{:?}", trailing.state);
    assert!((hinge(end) - std::f64::consts::PI).abs() < 1e-9);
    let speed = end[6].hypot(end[7]);
    assert!((speed - trailing.speed()).abs() < 1e-9, "{speed} against {}", trailing.speed());
    assert!(trailing.eigenvalues.iter().skip(1).all(|z| z.re < -0.5), "{:?}", trailing.eigenvalues);
}

/// The gait of `drive-rolling-resistance` (motor `2 cos(pi t)`, period
/// 2 s): found by shooting from the state the scene ends in, it is
/// periodic modulo a translation (no net turn), its multipliers lie inside
/// the unit circle (largest 0.884), a 300 s simulation averages its mean
/// speed to 1e-7 (0.884^130 of the start is left), and a simulation
/// started at the fixed point returns to it, moved by the orbit's shift,
/// after one period to 1e-10 (the integrators' tolerances are 1e-11;
/// measured 3e-12).
#[test]
fn rolling_resistance_gait_is_a_stable_periodic_orbit() {
    let scene = scenes::get("drive-rolling-resistance");
    let (problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let sol = problem.t_end(300.0).solve().unwrap();
    let (mut an, x0) = analysis::<EzyRoller>(scene.clone());
    assert_eq!(an.forcing(), Some(ezy_core::effects::Periodicity::Period(2.0)));
    let sym = an.symmetry(0.0, &x0).unwrap();
    let k = sol.t.iter().position(|&t| t >= 120.0 - 1e-9).unwrap();
    let guess: Vec<f64> = sol.y[k][..12].to_vec();
    let orbit = an.periodic_orbit(0.0, 2.0, &guess, sym, &PeriodicSettings::default()).unwrap();
    assert_eq!(orbit.stability, Stability::Stable);
    assert_eq!(orbit.family, 0);
    assert_eq!(orbit.multipliers.len(), 3);
    assert!(orbit.multipliers.iter().all(|z| z.re.hypot(z.im) < 0.9), "{:?}", orbit.multipliers);
    assert!(orbit.heading_change.abs() < 1e-9, "{}", orbit.heading_change);
    let (x1, y1) = (sol.column("x1").unwrap(), sol.column("y1").unwrap());
    let (n, j) = (sol.t.len(), sol.t.iter().position(|&t| t >= 260.0 - 1e-9).unwrap());
    let mean = (x1[n - 1] - x1[j]).hypot(y1[n - 1] - y1[j]) / (sol.t[n - 1] - sol.t[j]);
    eprintln!(
        "mean speed: orbit {} simulated {mean} (diff {:e}); multipliers {:?}",
        orbit.mean_speed(),
        (mean - orbit.mean_speed()).abs(),
        orbit.multipliers
    );
    assert!((mean - orbit.mean_speed()).abs() < 1e-7, "simulated {mean} against {}", orbit.mean_speed());
    assert!((orbit.mean_speed() - 0.336).abs() < 1e-3);

    // one period from the fixed point, by the ordinary simulation
    let (mut p, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let names = an.state_names();
    for (name, v) in names[..6].iter().zip(&orbit.state) {
        p = p.q(name, *v).unwrap();
    }
    for (name, v) in names[..6].iter().zip(&orbit.state[6..]) {
        p = p.qd(name, *v).unwrap();
    }
    let back = p.t_end(2.0).tolerances(1e-11, 1e-11).solve().unwrap();
    let end = &back.final_state()[..12];
    let s = orbit.shift;
    for (i, (e, x)) in end.iter().zip(&orbit.state).enumerate() {
        let moved = match i {
            0 | 3 => x + s.a,
            1 | 4 => x + s.b,
            _ => *x,
        };
        eprintln!("return {}: {:e}", names[i], (e - moved).abs());
        assert!((e - moved).abs() < 1e-10, "{} after one period: {e} against {moved}", names[i]);
    }
}

/// The monodromy matrix from the variational equations against central
/// differences of whole one-period runs (step 1e-5, both at tolerances
/// 1e-13: differencing noise about 1e-8, truncation about 1e-10; measured
/// 1.7e-9 of the largest entry), from the scene's start.
#[test]
fn variational_equations_match_differences_of_whole_runs() {
    let (mut an, x0) = analysis::<EzyRoller>(scenes::get("drive-rolling-resistance"));
    let tight = PeriodicSettings {
        tolerance: ezy_core::integrator::Tolerance { rtol: 1e-13, atol: 1e-13 },
        ..PeriodicSettings::default()
    };
    let (_, m, _) = an.flow(0.0, &x0, 2.0, &tight).unwrap();
    let h = 1e-5;
    let scale = m.norm_max();
    let mut worst = 0.0f64;
    for j in 0..12 {
        let (mut xp, mut xm) = (x0.clone(), x0.clone());
        xp[j] += h;
        xm[j] -= h;
        let (fp, _, _) = an.flow(0.0, &xp, 2.0, &tight).unwrap();
        let (fm, _, _) = an.flow(0.0, &xm, 2.0, &tight).unwrap();
        for i in 0..12 {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            worst = worst.max((fd - m[(i, j)]).abs() / scale);
            assert!((fd - m[(i, j)]).abs() < 1e-7 * scale, "M[{i},{j}] = {} against {fd}", m[(i, j)]);
        }
    }
    eprintln!("variational against differences: {worst:e} relative");
}

/// `ezy` with `args`, writing into `out`; its stdout, stderr and success.
pub(crate) fn ezy(args: &[&str], out: &std::path::Path) -> (String, String, bool) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).arg("--out").arg(out).output().unwrap();
    (String::from_utf8_lossy(&o.stdout).into(), String::from_utf8_lossy(&o.stderr).into(), o.status.success())
}

/// A fresh directory under cargo's temporary directory.
pub(crate) fn fresh(what: &str) -> std::path::PathBuf {
    let d = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("analysis-{what}"));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The columns of a CSV file by name.
pub(crate) fn table(path: &std::path::Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines().map(|l| l.split(',').map(String::from).collect::<Vec<_>>());
    (lines.next().unwrap(), lines.collect())
}

/// `ezy analyze sleigh` finds the one steady motion at the scene's energy
/// (the skate makes the start's `yd = a omega = 0.5 m/s`, so T0 = 0.675 J
/// and U = sqrt(2 T0 / m)) with the closed-form eigenvalue; `--continue
/// a=...` follows it through the skate's distance, the eigenvalue
/// `-m a U / (I + m a^2)` at every point, to 1e-10.
#[test]
fn analyze_command_on_the_sleigh_and_its_branch_in_a() {
    let out = fresh("sleigh");
    let (said, err, ok) = ezy(&["analyze", "sleigh", "--continue", "a=0.3:0.6:4", "--no-figures"], &out);
    assert!(ok, "{said}{err}");
    let m = ChaplyginSleigh::default();
    let u = (2.0 * 0.675 / m.m).sqrt();
    let (head, rows) = table(&out.join("equilibria.csv"));
    assert_eq!(rows.len(), 1, "{rows:?}");
    let col = |row: &[String], name: &str| row[head.iter().position(|h| h == name).unwrap()].parse::<f64>().unwrap();
    assert!((col(&rows[0], "speed") - u).abs() < 1e-10);
    assert_eq!(rows[0][1], "stable");
    let (bhead, branch) = table(&out.join("branch.csv"));
    assert_eq!(bhead[0], "a");
    assert_eq!(branch.len(), 4);
    for row in &branch {
        let a: f64 = row[0].parse().unwrap();
        let want = -m.m * a * u / (m.I + m.m * a * a);
        let ev: Vec<f64> = (1..=2)
            .map(|k| row[bhead.iter().position(|h| *h == format!("lambda{k}_re")).unwrap()].parse().unwrap())
            .collect();
        assert!(ev.iter().any(|l| (l - want).abs() < 1e-10), "a = {a}: {ev:?} want {want}");
    }
    assert!(!out.join("eigenvalues.png").exists());
}

/// `ezy linearize` writes A and B with named rows and columns and the
/// eigenvalues on the constraint manifold (the double pendulum: 12 states
/// less 4 hinge positions and 4 velocities leave 4); an unknown input
/// names the model's hinges and writes nothing.
#[test]
fn linearize_command_names_rows_and_columns() {
    let out = fresh("linearize");
    let (said, err, ok) =
        ezy(&["linearize", "double-pendulum", "--at", "0.5", "--input", "tau_J", "--input", "scale_gravity"], &out);
    assert!(ok, "{said}{err}");
    let (head, rows) = table(&out.join("A.csv"));
    assert_eq!(head[..4], ["row", "x1", "y1", "phi1"]);
    assert_eq!(rows.len(), 12);
    assert_eq!(rows[6][0], "x1d");
    // the rows of q: d(q)/dt = qd
    assert_eq!(rows[0][7], "1.0");
    let (bhead, brows) = table(&out.join("B.csv"));
    assert_eq!(bhead, ["row", "tau_J", "scale_gravity"]);
    assert_eq!(brows.len(), 12);
    assert_eq!(table(&out.join("eigenvalues.csv")).1.len(), 4);

    let bad = fresh("linearize-bad");
    let (_, err, ok) = ezy(&["linearize", "double-pendulum", "--input", "tau_Q"], &bad);
    assert!(!ok && err.contains("no hinge `Q`") && err.contains("O, J"), "{err}");
    assert!(!bad.exists());
    let (_, err, ok) = ezy(&["linearize", "double-pendulum", "--input", "torque"], &bad);
    assert!(!ok && err.contains("tau_HINGE"), "{err}");
    let (_, err, ok) = ezy(&["analyze", "sleigh", "--continue", "a=1:2"], &bad);
    assert!(!ok && err.contains("--continue") && err.contains("NAME=START:STOP:COUNT"), "{err}");
    let (_, err, ok) = ezy(&["analyze", "sleigh", "--continue", "a=0:1:20000"], &bad);
    assert!(!ok && err.contains("20000 values"), "{err}");
    let (_, err, ok) = ezy(&["analyze", "sleigh", "--continue", "nope=0:1:3"], &bad);
    assert!(!ok && err.contains("nope"), "{err}");
    let (_, err, ok) = ezy(&["analyze", "sleigh", "--period", "0"], &bad);
    assert!(!ok && err.contains("--period"), "{err}");
    // a continuation in a family's size used to panic (index out of
    // bounds in the symmetry test): refused before any work, by name
    let (_, err, ok) = ezy(&["analyze", "four-bar-n2", "--continue", "N=2:3:2"], &bad);
    assert!(!ok && err.contains("--continue N") && err.contains("coordinates") && !err.contains("panicked"), "{err}");
    assert!(!bad.exists());
}

/// The library's analyses refuse a state of the wrong length or with a
/// value that is not a number, by name, instead of indexing past it.
#[test]
fn analyses_refuse_states_that_do_not_fit() {
    let (mut an, x0) = analysis::<ChaplyginSleigh>(ezy_models::scenes::get("sleigh"));
    let short = &x0[..x0.len() - 1];
    for e in [
        an.rhs(0.0, short).unwrap_err(),
        an.symmetry(0.0, short).unwrap_err(),
        an.constraint_residual(0.0, short).unwrap_err(),
    ] {
        assert!(e.to_string().contains("a state of 5 values given to a model of 6"), "{e}");
    }
    let mut nan = x0.clone();
    nan[4] = f64::NAN;
    let e = an.symmetry(0.0, &nan).unwrap_err();
    assert!(e.to_string().contains("`yd` is NaN"), "{e}");
    assert_eq!(an.constraint_residual(0.0, &x0).unwrap().len(), 1);
}

/// A branch in the forcing's frequency: each point's periodic orbit has
/// its own forcing's period (it used to keep the first point's for every
/// point, so the later ones were orbits of the wrong map), written in
/// `branch.csv`'s `period` column; a `--period` that is not a whole
/// number of the forcing's periods is refused.
#[test]
fn a_branch_in_the_forcing_frequency_takes_each_points_period() {
    let out = fresh("branch-omega");
    let (_, err, ok) =
        ezy(&["analyze", "drive-rolling-resistance", "--continue", "motor.omega=3.0:3.3:3", "--no-figures"], &out);
    assert!(ok, "{err}");
    let (head, rows) = table(&out.join("branch.csv"));
    let col = head.iter().position(|h| h == "period").expect("a period column");
    assert_eq!(rows.len(), 3);
    for r in &rows {
        let (omega, period): (f64, f64) = (r[0].parse().unwrap(), r[col].parse().unwrap());
        let want = 2.0 * std::f64::consts::PI / omega;
        assert!((period - want).abs() < 1e-12 * want, "omega {omega}: period {period} against {want}");
    }
    let bad = fresh("branch-omega-bad");
    let (_, err, ok) = ezy(&["analyze", "drive-rolling-resistance", "--period", "3", "--no-figures"], &bad);
    assert!(!ok && err.contains("--period 3") && err.contains("forced with period 2 s"), "{err}");
    let (_, err, ok) = ezy(&["analyze", "drive-rolling-resistance", "--period", "1e-300", "--no-figures"], &bad);
    assert!(!ok && err.contains("below 1.2e-7 s there is within the time's rounding"), "{err}");
    let (_, err, ok) = ezy(&["analyze", "drive-rolling-resistance", "--period", "0.5", "--no-figures"], &bad);
    assert!(!ok && err.contains("whole number"), "{err}");
    // a whole multiple is taken
    let (_, err, ok) = ezy(&["analyze", "drive-rolling-resistance", "--period", "4", "--no-figures"], &bad);
    assert!(ok, "{err}");
}

/// What the analyses cannot follow is refused with its reason, before
/// anything is written (they used to answer as if it were not there):
/// skates with friction that slide on the motion found (a trailer on ice:
/// the ideal circle was "stable"; `linearize drive-slip --input
/// scale_slip_C` at a slide gave B = 0), a switch (a push switched off at
/// once still gave its motion), `--at` past a stop event (the stop's state
/// was labelled with the later time).
#[test]
fn analyses_refuse_slides_switches_and_stops() {
    let dir = fresh("refusals");
    std::fs::create_dir_all(&dir).unwrap();
    // the trailer on ice: every skate with friction mu = 0.002
    let mut ice = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/trailer.toml")).unwrap();
    ice.truncate(ice.find("[[figures]]").unwrap_or(ice.len()));
    for k in ["R", "F", "A1", "A2"] {
        ice.push_str(&format!(
            "\n[effects.slip_{k}]\nkind = \"skate-friction\"\nskate = \"{k}\"\nmu = 0.002\nshare = 0.25\n"
        ));
    }
    let ice_file = dir.join("trailer-ice.toml");
    std::fs::write(&ice_file, &ice).unwrap();
    let ice_file = ice_file.to_str().unwrap();
    let (_, err, ok) = ezy(&["analyze", ice_file, "--no-figures"], &dir.join("a1"));
    assert!(!ok && err.contains("no steady motion") && err.contains("and 8 other guesses"), "{err}");
    assert!(err.contains("skate `F` slides on this steady motion") && err.contains("mu N = 34.32 N"), "{err}");
    assert_eq!(err.matches("skate `F` slides").count(), 1, "the guesses' reasons once: {err}");
    let (_, err, ok) = ezy(&["linearize", "drive-slip", "--at", "5", "--input", "scale_slip_C"], &dir.join("l1"));
    assert!(
        !ok && err.contains("skate `C` slides on the state linearized") && err.contains("(effect `slip_C`)"),
        "{err}"
    );
    // a switch: the scene's effects at the start are not those of its run
    let sleigh = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/sleigh.toml")).unwrap();
    let base = &sleigh[..sleigh.find("[[figures]]").unwrap()];
    let push = "\n[effects.push]\nkind = \"force\"\nat = \"sleigh\"\nfx = { constant = 0.5 }\n";
    let off = "\n[events.off]\nwhen = \"t\"\ncrosses = 1e-9\naction = \"switch\"\nswitch_off = [\"push\"]\n";
    let switched = dir.join("switched.toml");
    std::fs::write(&switched, format!("{base}{push}{off}")).unwrap();
    for command in ["analyze", "linearize"] {
        let (_, err, ok) = ezy(&[command, switched.to_str().unwrap()], &dir.join(command));
        assert!(!ok && err.contains("event `off` switches effects during a run"), "{command}: {err}");
        assert!(!dir.join(command).exists(), "{command}");
    }
    // a stop at x = 1.5 m (t = 1.545 s)
    let stop = "\n[events.far]\nwhen = \"x\"\ncrosses = 1.5\naction = \"stop\"\n";
    let stopped = dir.join("stopped.toml");
    std::fs::write(&stopped, format!("{base}{stop}")).unwrap();
    let (_, err, ok) = ezy(&["linearize", stopped.to_str().unwrap(), "--at", "5"], &dir.join("l2"));
    assert!(!ok && err.contains("--at 5: the run stops at the event `far` at t = 1.545"), "{err}");
    let (out, err, ok) = ezy(&["linearize", stopped.to_str().unwrap(), "--at", "1"], &dir.join("l3"));
    assert!(ok, "{err}");
    // at a moving state the frame of the eigenvalues is named
    assert!(out.contains("note: the state moves") && out.contains("depend on the frame"), "{out}");
}

/// `analyze sleigh-ice` listed the straight run twice (2.161999 and
/// 2.161984 m/s, one family of speeds) and two motions at 1e-6 and 1e-5
/// m/s, where the search's absolute residual (1e-12) cannot tell a steady
/// motion from any slow state: it lists the straight run once and notes
/// the two as rest. `--energy` standing for a speed below 1e-3 m/s is
/// refused.
#[test]
fn steady_motions_are_listed_once_and_rest_is_not_one() {
    let dir = fresh("once");
    let (out, err, ok) = ezy(&["analyze", "sleigh-ice", "--no-figures"], &dir.join("a"));
    assert!(ok, "{err}");
    assert!(out.contains("steady motion 1: stable, speed 2.16") && !out.contains("steady motion 2"), "{out}");
    assert!(out.contains("2 searches ended at speeds below") && out.contains("not listed"), "{out}");
    let (_, rows) = table(&dir.join("a/equilibria.csv"));
    assert_eq!(rows.len(), 1);
    for e in ["1e-300", "1e-7", "0", "-1"] {
        let (_, err, ok) = ezy(&["analyze", "sleigh", "--energy", e, "--no-figures"], &dir.join("e"));
        assert!(!ok && err.contains("--energy") && err.contains(e), "{e}: {err}");
    }
    let (_, err, ok) = ezy(&["analyze", "sleigh", "--energy", "1e-7", "--no-figures"], &dir.join("e"));
    assert!(!ok && err.contains("about 4.5e-4 m/s, below the 0.001 m/s"), "{err}");
    // a period within the time's rounding (it gave a "neutral" orbit at
    // a mean speed of 1.7e300 m/s)
    let (_, err, ok) = ezy(&["analyze", "sleigh", "--period", "1e-300", "--no-figures"], &dir.join("p"));
    assert!(!ok && err.contains("--period 1e-300") && err.contains("within the time's rounding"), "{err}");
    let (out, err, ok) = ezy(&["analyze", "sleigh", "--energy", "0.5", "--no-figures"], &dir.join("e"));
    assert!(ok && out.contains("steady motion 1: stable, speed 1"), "{out}{err}");
}

ezy::model! {
    /// A user's own sleigh carrying an internal rotor (not a built-in): a
    /// balanced disc on a hinge at the sleigh's centre of mass, free to
    /// spin; the skate `a` behind the centre of mass.
    pub struct RotorSleigh {
        /// Sleigh mass [kg]
        param m = 1.0;
        /// Sleigh moment of inertia [kg m^2]
        param I = 0.1;
        /// Rotor mass [kg]
        param mr = 0.5;
        /// Rotor moment of inertia [kg m^2]
        param Ir = 0.05;
        /// Distance from the centre of mass back to the skate [m]
        param a = 0.5;

        body s(x, y, phi) { mass: m, inertia: I }
        body r(xr, yr, th) { mass: mr, inertia: Ir }
        point C on s at (0, 0);
        point R on r at (0, 0);
        point P on s at (-a, 0);
        hinge H: C = R;
        skate P: P along (1, 0);
    }
}

/// An internal rotor's angle is a cyclic coordinate (nothing depends on
/// it): found as a symmetry beside the plane's rigid motions, so a sleigh
/// coasting straight at `U` with its rotor spinning at `w` is one steady
/// motion (it was "neutral", listed once per guess, and the rotor's spin
/// was forced to 0). Its eigenvalues: the family's zeros and the
/// sleigh's yaw decay `-M a U / (I + M a^2)`, `M = m + mr` (the free
/// rotor carries no torque, so its inertia does not enter; docs/physics.md
/// §9 with the rotor's mass at the centre).
#[test]
fn an_internal_rotor_is_a_symmetry_and_its_spin_is_kept() {
    let (u, w) = (1.2, 3.0);
    let p = ezy_core::Problem::new(RotorSleigh::default())
        .q("x", 0.0)
        .and_then(|p| p.q("y", 0.0))
        .and_then(|p| p.q("phi", 0.0))
        .and_then(|p| p.q("th", 0.7))
        .and_then(|p| p.qd("x", u))
        .and_then(|p| p.qd("phi", 0.0))
        .and_then(|p| p.qd("th", w))
        .unwrap();
    let (mut an, x0) = p.analysis().unwrap();
    let sym = an.symmetry(0.0, &x0).unwrap();
    assert!(sym.translate_x && sym.translate_y && sym.rotate, "{sym:?}");
    let th = an.dynamics().info.coords.iter().position(|c| c == "th").unwrap();
    assert_eq!(sym.cyclic, 1 << th, "{sym:?}");
    let s = an.steady_motion(0.0, &x0, sym, None).unwrap();
    let nq = an.nq();
    assert!((s.state[nq + th] - w).abs() <= 1e-12 && s.state[th] == 0.0, "rotor {:?}", &s.state);
    assert!((s.body_velocity[0] - u).abs() <= 1e-12, "{:?}", s.body_velocity);
    let m = RotorSleigh::default();
    let big = m.m + m.mr;
    let want = -big * m.a * u / (m.I + big * m.a * m.a);
    let decay: Vec<f64> = s.eigenvalues.iter().filter(|z| z.re.abs() > 1e-6).map(|z| z.re).collect();
    assert!(decay.len() == 1 && (decay[0] - want).abs() <= 1e-9 * want.abs(), "{:?} against {want}", s.eigenvalues);
    assert_eq!(s.stability, Stability::Stable, "{:?}", s.eigenvalues);
    // the same motion from another rotor angle: one motion
    let mut x1 = x0.clone();
    x1[th] = -2.0;
    let s1 = an.steady_motion(0.0, &x1, sym, None).unwrap();
    assert!(s.state.iter().zip(&s1.state).all(|(a, b)| (a - b).abs() <= 1e-12), "{:?} {:?}", s.state, s1.state);
}

/// `linearize` and `analyze` into a directory an earlier one wrote: the
/// earlier run's files of the command's own set that this run does not
/// write are removed on commit (a `B.csv` from a run with inputs stayed
/// beside the new `A.csv`), and other files are left.
#[test]
fn an_analysis_leaves_no_earlier_file_beside_its_own() {
    let dir = fresh("stale");
    let (_, err, ok) = ezy(&["linearize", "drive", "--input", "tau_B"], &dir);
    assert!(ok && dir.join("B.csv").exists(), "{err}");
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    let (_, err, ok) = ezy(&["linearize", "drive"], &dir);
    assert!(ok, "{err}");
    assert!(dir.join("A.csv").exists() && !dir.join("B.csv").exists());
    assert_eq!(std::fs::read_to_string(dir.join("notes.txt")).unwrap(), "mine");
}

/// The snake's gait (scene `snake`: five links, serpenoid hinge motors,
/// rolling resistance). Its run to 40 s is deep in a transient (the gait
/// attracts at the rate 0.934 per period: some 300 periods to settle), so
/// [`Analysis::gait`] runs it on until its state at the period ends
/// settles and searches from there. Checked: one period from the fixed
/// point returns to it moved by the shift, by the analysis' own DOP853
/// at 1e-12 (independent of the search's variational integration), to
/// 1e-9 (measured 1.5e-10); the Floquet multipliers against the
/// eigenvalues of the period map's Jacobian by central differences of
/// whole periods (state alone, DOP853 at 1e-12, step 1e-5), which holds
/// them and 24 multipliers 1 (the 3 rigid motions, the 8 holonomic
/// constraints twice, the 5 skates once): each of the 6 to 2e-5
/// (measured 5.6e-6; the off-manifold directions' Jordan blocks at 1
/// spread the differenced matrix's error into its eigenvalues: steps
/// 1e-6 and 1e-4 both do worse; a wrong multiplier is off by 1e-3 or
/// more).
#[test]
fn the_snakes_gait_is_found_from_its_transient() {
    let (mut an, x0) = analysis::<Snake>(scenes::get("snake"));
    let sym = an.symmetry(0.0, &x0).unwrap();
    let (problem, _) = scenes::get("snake").problem::<Snake>(&[]).unwrap();
    let guess = problem.t_end(40.0).solve().unwrap().final_state()[..30].to_vec();
    let settings = PeriodicSettings::default();
    let orbit = an.gait(40.0, 2.0, &guess, sym, &settings).unwrap();
    assert_eq!(orbit.stability, Stability::Stable);
    assert_eq!(orbit.multipliers.len(), 6);
    assert!((orbit.mean_speed() - 0.265).abs() < 1e-3, "{}", orbit.mean_speed());
    let tight = PeriodicSettings {
        tolerance: ezy_core::integrator::Tolerance { rtol: 1e-12, atol: 1e-12 },
        ..PeriodicSettings::default()
    };
    // h^-1 x: the shift undone (rotation about the origin after the
    // translation is taken off), body by body
    let back = |x: &[f64]| {
        let g = orbit.shift.inverse();
        let mut y = x.to_vec();
        for b in 0..5 {
            let (i, j, k) = (3 * b, 3 * b + 1, 3 * b + 2);
            [y[i], y[j]] = g.point([x[i], x[j]]);
            y[k] = x[k] + g.theta;
            [y[15 + i], y[15 + j]] = g.vector([x[15 + i], x[15 + j]]);
        }
        y
    };
    let map = |an: &mut Analysis<Snake>, x: &[f64]| back(&an.end_state(orbit.t0, x, orbit.period, &tight).unwrap().0);
    let end = map(&mut an, &orbit.state);
    let worst = end.iter().zip(&orbit.state).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!("snake: one period returns to {worst:e}; multipliers {:?}", orbit.multipliers);
    assert!(worst < 1e-9, "one period from the fixed point returns to {worst:e}");
    let h = 1e-5;
    let mut d = faer::Mat::<f64>::zeros(30, 30);
    for j in 0..30 {
        let (mut xp, mut xm) = (orbit.state.clone(), orbit.state.clone());
        xp[j] += h;
        xm[j] -= h;
        let (fp, fm) = (map(&mut an, &xp), map(&mut an, &xm));
        for i in 0..30 {
            d[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    let ev = d.eigenvalues().unwrap();
    let mut worst = 0.0f64;
    for mu in &orbit.multipliers {
        let near = ev.iter().map(|z| (z.re - mu.re).hypot(z.im - mu.im)).fold(f64::INFINITY, f64::min);
        worst = worst.max(near);
        assert!(near < 2e-5, "multiplier {mu:?}: the differences' nearest is {near:e} away ({ev:?})");
    }
    // the Jordan blocks of the constraints' directions spread their
    // multipliers 1 by the square root of the differencing error
    let ones = ev.iter().filter(|z| (z.re - 1.0).hypot(z.im) < 1e-2).count();
    eprintln!("snake: multipliers against differences {worst:e}; {ones} multipliers 1");
    assert_eq!(ones, 24, "{ev:?}");
}

/// The four-bar's turning crank (scene `four-bar`: a constant torque
/// against a spring-damper, no forcing in time) settles on a limit cycle
/// whose period is an unknown. [`Analysis::return_time`] reads a first
/// period off the run's end, [`Analysis::limit_cycle`] converges on the
/// cycle, the crank's heading turning once per period. Checked: the
/// period against a long run's (the state at 40 s run on by DOP853 at
/// 1e-13 to 80 s, the times the crank's heading passes 0 mod 2 pi found
/// by the secant method to 1e-13 s, their differences after 60 s) to
/// 1e-9 s (measured 3.7e-11); the one nontrivial multiplier (one degree of freedom: the
/// state on the constraint manifold is 2-dimensional, and the flow's
/// own direction has the multiplier 1) against the eigenvalues of the
/// period map's Jacobian by central differences of whole periods (step
/// 1e-5), which holds it, the flow's 1 and 16 multipliers 1 of the
/// 8 holonomic constraints, to 2e-5 (measured 1.3e-6).
#[test]
fn the_four_bars_crank_turns_on_a_limit_cycle() {
    let scene = scenes::get("four-bar");
    let (mut an, x0) = analysis::<FourBar>(scene.clone());
    let sym = an.symmetry(0.0, &x0).unwrap();
    assert_eq!(sym, Symmetry::NONE);
    let (problem, _) = scene.problem::<FourBar>(&[]).unwrap();
    let guess = problem.t_end(40.0).solve().unwrap().final_state()[..18].to_vec();
    let settings = PeriodicSettings::default();
    let first = an.return_time(40.0, &guess, 10.0, &settings).unwrap().expect("the crank comes back");
    let cycle = an.limit_cycle(40.0, first, &guess, sym, &settings).unwrap();
    let tight = PeriodicSettings {
        tolerance: ezy_core::integrator::Tolerance { rtol: 1e-13, atol: 1e-13 },
        newton_tolerance: 1e-12,
        ..PeriodicSettings::default()
    };
    let cycle = an.limit_cycle(40.0, cycle.period, &cycle.state, sym, &tight).unwrap();
    eprintln!(
        "four-bar: first return {first}, period {}, multipliers {:?}, windings {:?}, {} iterations",
        cycle.period, cycle.multipliers, cycle.windings, cycle.iterations
    );
    assert_eq!(cycle.stability, Stability::Stable);
    assert_eq!(cycle.windings.len(), 1);
    assert_eq!(cycle.windings[0].1.abs(), 1);
    assert_eq!(cycle.multipliers.len(), 1);
    let crank = cycle.windings[0].0;
    // the times the crank's heading passes a multiple of 2 pi, 40 s to 80 s
    let dir = cycle.windings[0].1.signum() as f64;
    let turns = |x: &[f64]| dir * x[crank] / std::f64::consts::TAU;
    let (mut t, mut x) = (40.0, guess.clone());
    let step = cycle.period / 50.0;
    let mut passes = Vec::new();
    while t < 80.0 {
        let (y, _) = an.end_state(t, &x, step, &tight).unwrap();
        if turns(&y).floor() > turns(&x).floor() {
            // secant on the time from the bracket's start
            let target = turns(&y).floor();
            let (mut a, mut b) = (0.0, step);
            let (mut fa, mut fb) = (turns(&x) - target, turns(&y) - target);
            for _ in 0..60 {
                if (b - a).abs() < 1e-14 || fb == fa {
                    break;
                }
                let c = b - fb * (b - a) / (fb - fa);
                let fc = turns(&an.end_state(t, &x, c, &tight).unwrap().0) - target;
                (a, fa, b, fb) = (b, fb, c, fc);
            }
            passes.push(t + b);
        }
        (t, x) = (t + step, y);
    }
    let periods: Vec<f64> = passes.windows(2).filter(|w| w[0] > 60.0).map(|w| w[1] - w[0]).collect();
    let worst = periods.iter().fold(0.0f64, |m, p| m.max((p - cycle.period).abs()));
    eprintln!("four-bar: {} periods measured after 60 s, worst {worst:e} off", periods.len());
    assert!(periods.len() > 20);
    assert!(worst < 1e-9, "the run's periods {periods:?} against {}", cycle.period);
    // the multiplier against differences of whole periods
    let h = 1e-5;
    let mut d = faer::Mat::<f64>::zeros(18, 18);
    for j in 0..18 {
        let (mut xp, mut xm) = (cycle.state.clone(), cycle.state.clone());
        xp[j] += h;
        xm[j] -= h;
        let fp = an.end_state(cycle.t0, &xp, cycle.period, &tight).unwrap().0;
        let fm = an.end_state(cycle.t0, &xm, cycle.period, &tight).unwrap().0;
        for i in 0..18 {
            d[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    let ev = d.eigenvalues().unwrap();
    let mu = cycle.multipliers[0];
    let near = ev.iter().map(|z| (z.re - mu.re).hypot(z.im - mu.im)).fold(f64::INFINITY, f64::min);
    // 8 Jordan blocks of size 2 at 1 (a holonomic constraint's value and
    // rate, off the manifold, drift) spread by the differencing's error
    let ones = ev.iter().filter(|z| (z.re - 1.0).hypot(z.im) < 0.05).count();
    eprintln!("four-bar: multiplier {mu:?} against differences {near:e}; {ones} multipliers 1");
    assert!(near < 2e-5, "{mu:?}: the differences' nearest is {near:e} away ({ev:?})");
    assert_eq!(ones, 17, "{ev:?}");
}

/// A stiff scene is refused at once, by name, instead of searching for
/// minutes: `snake-stiff`'s servos (1e6 N m/rad) blow up DOP853's
/// integration of one period of the state alone, which the search tries
/// before it integrates the variational equations (measured 0.06 s).
#[test]
fn a_stiff_scene_is_refused_before_the_search() {
    let dir = fresh("stiff");
    let (_, err, ok) = ezy(&["analyze", "snake-stiff", "--no-figures"], &dir);
    assert!(!ok);
    assert!(err.contains("DOP853 could not integrate one period (2 s)"), "{err}");
    assert!(err.contains("stiff scene") && err.contains("no implicit integrator yet"), "{err}");
    assert!(!dir.join("periodic.csv").exists());
}

/// `--rtol`/`--atol` reach the periodic search (they were read by the
/// guess's run only: a gait found at 1e-11 whatever was asked). At 1e-6
/// the rolling-resistance gait's mean speed moves by about 2e-4 m/s from
/// the default's; at 1e-13 it agrees with it to 1e-9 (the default's
/// Newton tolerance).
#[test]
fn the_tolerances_reach_the_periodic_search() {
    let speed = |extra: &[&str]| {
        let out = fresh(&format!("tolerance{}", extra.len()));
        let args = [&["analyze", "drive-rolling-resistance", "--no-figures"][..], extra].concat();
        let (said, err, ok) = ezy(&args, &out);
        assert!(ok, "{said}{err}");
        let (head, rows) = table(&out.join("periodic.csv"));
        let k = head.iter().position(|h| h == "mean_speed").unwrap();
        rows[0][k].parse::<f64>().unwrap()
    };
    let default = speed(&[]);
    let loose = speed(&["--rtol", "1e-6", "--atol", "1e-6"]);
    let tight = speed(&["--rtol", "1e-13", "--atol", "1e-13", "--max-steps", "1000000"]);
    assert!((loose - default).abs() > 1e-5, "--rtol 1e-6 ignored: {loose} against {default}");
    assert!((tight - default).abs() < 1e-9, "{tight} against {default}");
}

/// The numbers of `ezy analyze`'s orbit line: the mean speed and the
/// multipliers (real), as printed.
fn orbit_numbers(said: &str) -> Vec<String> {
    let line = said.lines().find(|l| l.starts_with("periodic orbit:")).expect("an orbit line");
    let speed = line.split("mean speed ").nth(1).unwrap().split(' ').next().unwrap().to_string();
    let mu = line.split("multipliers: ").nth(1).unwrap().split(", ").map(str::to_string);
    std::iter::once(speed).chain(mu).collect()
}

/// `--rtol 1e-4 --atol 1e-4` loosens the period map (its Newton
/// iteration stops at 1e-3): the orbit's numbers are printed to the 2
/// decimals they hold, a note says so, and each is within a unit of its
/// last decimal of the same orbit's at the defaults (the oracle: 1e-11,
/// Newton to 1e-9). They were printed to six decimals, the mean speed
/// 0.334985 against 0.335262 and a heading change of -0.000012 rad
/// where the symmetric orbit has 0. The defaults' line keeps its six.
#[test]
fn a_loose_tolerance_prints_the_digits_it_holds() {
    let scene = "drive-rolling-resistance";
    let wrt = "motor.torque.cos.amplitude";
    let (said, err, ok) = ezy(&["analyze", scene, "--no-figures", "--wrt", wrt], &fresh("loose-default"));
    assert!(ok, "{err}");
    assert!(!said.contains("decimals"), "{said}");
    let exact = orbit_numbers(&said);
    let exact_d = derivatives(&said);
    assert!(exact.iter().all(|v| v.split('.').nth(1).is_some_and(|d| d.len() == 6)), "{exact:?}");
    let loose = ["analyze", scene, "--no-figures", "--rtol", "1e-4", "--atol", "1e-4", "--wrt", wrt];
    let (said, err, ok) = ezy(&loose, &fresh("loose"));
    assert!(ok, "{err}");
    assert!(said.contains("printed to the 2 decimals") && said.contains("stops at 1e-3"), "{said}");
    assert!(said.contains("heading change 0 rad"), "{said}");
    let got = orbit_numbers(&said);
    assert_eq!(got.len(), exact.len());
    for (g, e) in got.iter().zip(&exact) {
        assert!(g.split('.').nth(1).is_none_or(|d| d.len() <= 2), "{g} has more than 2 decimals");
        let (g, e): (f64, f64) = (g.parse().unwrap(), e.parse().unwrap());
        assert!((g - e).abs() <= 0.01, "{g} against the defaults' {e}");
    }
    // the derivatives to 3 digits of the row's largest (1.01): the
    // heading's, 0 by the symmetry, was printed -1.73e-5
    let got = derivatives(&said);
    let scale = exact_d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert_eq!(got.len(), exact_d.len());
    for (g, e) in got.iter().zip(&exact_d) {
        assert!((g - e).abs() <= 0.01 * scale, "{g} against the defaults' {e}");
    }
    assert!(said.contains(&format!("ddheading/d{wrt} = 0,")), "{said}");
}

/// The gait derivatives `ezy analyze --wrt` prints, in order.
fn derivatives(said: &str) -> Vec<f64> {
    let line = said.lines().find(|l| l.starts_with("at ")).expect("a derivatives line");
    line.split(" = ").skip(2).map(|v| v.split(',').next().unwrap().trim().parse().unwrap()).collect()
}
