//! A gait's derivatives (`ezy analyze --wrt`,
//! `Problem::gait_sensitivities`) against central differences of gaits
//! converged one by one (no sensitivity equations, no shooting Jacobian
//! reused), the step checked by Richardson: every quantity `periodic.csv`
//! carries (period, mean speed, mean forward speed, displacement, heading
//! change, mean input power, efficiency) to 1e-8 relative, each gait at
//! one phase of its forcing (a start `t0 = at T_f` that moves with the
//! forcing's period `T_f`). And against the quantities' own invariances:
//! a gait's mean speed, power and period do not depend on that phase, so
//! their derivatives at `0.37 T_f` equal those at phase 0; a straight
//! gait's heading change is 0 at every parameter value, and so is its
//! derivative.
//!
//! The differences' own error: each gait is converged with DOP853 at
//! 1e-13 and Newton to 1e-12 (`tight`), so over `2h = 4e-4 |p|` the
//! rounding of a difference is about 5e-9 relative (asserted below 1e-6 with the truncation); truncation after
//! Richardson's extrapolation from `h` and `h/2` is `O(h^4)`, about
//! 1e-12. The test asserts the Richardson gap itself (the oracle's error
//! bound) before it compares.

use ezy::models::{EzyRoller, scenes};
use ezy_core::Model;
use ezy_core::analysis::{PeriodicSettings, Symmetry};
use ezy_core::effects::Periodicity;
use ezy_core::integrator::Tolerance;
use ezy_core::problem::Problem;
use ezy_core::text::RuntimeModel;
use ezy_scene::Scene;

/// The quantities of `periodic.csv` in the order of
/// `GaitSensitivities::rows`.
const NAMES: [&str; 8] =
    ["period", "mean_speed", "mean_forward_speed", "dx", "dy", "dheading", "mean_power", "efficiency"];

/// Tighter than `analyze`'s defaults (1e-11, Newton 1e-9): the
/// differences divide the gaits' error by `2h`.
fn tight() -> PeriodicSettings {
    PeriodicSettings {
        tolerance: Tolerance { rtol: 1e-13, atol: 1e-13 },
        newton_tolerance: 1e-12,
        ..PeriodicSettings::default()
    }
}

/// The gait of `problem` with its fixed point at `t0 = at T_f` (`at` in
/// forcing periods `T_f`, which move with the parameters: the forcing's
/// phase `at` held), from a run of the scene to the same phase at its
/// end; its quantities, and the problem's reported derivatives with
/// respect to `param` (when given).
fn gait<M: Model>(
    scene: &Scene,
    model: &M,
    sets: &[(String, f64)],
    at: f64,
    param: Option<&str>,
) -> ([f64; 8], Vec<f64>) {
    let (problem, _): (Problem<M>, _) = scene.problem_with(model.clone(), sets).unwrap();
    let (mut an, x0) = problem.clone().analysis().unwrap();
    let Some(Periodicity::Period(period)) = an.forcing() else { panic!("not forced periodically") };
    let symmetry: Symmetry = an.symmetry(0.0, &x0).unwrap();
    let t_run = ((problem.settings.t_end / period).floor() + at.fract()) * period;
    let end = problem.clone().t_end(t_run).every(t_run).solve().unwrap();
    let guess = end.final_state()[..x0.len()].to_vec();
    let orbit = an.gait(at * period, period, &guess, symmetry, &tight()).unwrap();
    let params: Vec<_> = param.map(|p| scene.parameter(model, sets, p).unwrap()).into_iter().collect();
    let s = problem.gait_sensitivities(&orbit, &params, &tight()).unwrap();
    let q = [
        orbit.period,
        orbit.mean_speed(),
        orbit.mean_forward_speed(),
        orbit.displacement[0],
        orbit.displacement[1],
        orbit.heading_change,
        s.mean_power,
        s.efficiency,
    ];
    let d = if params.is_empty() { Vec::new() } else { s.rows(0).iter().map(|r| r.1).collect() };
    (q, d)
}

/// Checks the derivatives of every quantity of the gait of `scene` on
/// `model` with respect to `param` (value `p`) against Richardson's
/// extrapolation of central differences of gaits at `p +- h` and `p +-
/// h/2`, `h = 2e-4 |p|` (2e-4 at 0): within 1e-8 of the quantity's scale
/// (its derivative's size, at least a tenth of the largest derivative of
/// the gait; a quantity held at 0 by symmetry, the largest: ezy's
/// heading change of a straight gait is 1e-10 to 2e-9 of it, the
/// shooting solve's rounding), plus three times the Richardson change
/// (the oracle's own error).
fn check<M: Model>(scene: &Scene, model: &M, param: &str) {
    check_at(scene, model, param, 0.0);
}

/// [`check`] with every gait's fixed point at `t0 = at T_f` (`at` in
/// forcing periods, the forcing's phase held).
fn check_at<M: Model>(scene: &Scene, model: &M, param: &str, at: f64) {
    let p = scene.parameter(model, &[], param).unwrap().value;
    let (_, reported) = gait(scene, model, &[], at, Some(param));
    let h = 2e-4 * if p == 0.0 { 1.0 } else { p.abs() };
    let slope = |h: f64| {
        let gait_at = |v: f64| gait(scene, model, &[(param.to_string(), v)], at, None).0;
        let (a, b) = (gait_at(p + h), gait_at(p - h));
        (0..8).map(|i| (a[i] - b[i]) / (2.0 * h)).collect::<Vec<_>>()
    };
    let (d1, d2) = (slope(h), slope(h / 2.0));
    let rich: Vec<f64> = (0..8).map(|i| d2[i] + (d2[i] - d1[i]) / 3.0).collect();
    let largest = rich.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for i in 0..8 {
        if reported[i].is_nan() && rich[i].is_nan() {
            // an efficiency without input power (a kinematic gait: its
            // drives' work cancels to rounding): undefined, as printed
            continue;
        }
        // a quantity held at 0 by symmetry (a straight gait's heading
        // change) is compared with the gait's largest derivative
        let scale = if rich[i].abs() < 1e-6 * largest { largest } else { rich[i].abs().max(0.1 * largest) };
        // the oracle's own error: the extrapolation's change, and the
        // gaits' rounding over 2h
        let oracle = (rich[i] - d2[i]).abs();
        eprintln!(
            "{}: d{}/d{param} = {:.12e}, differences {:.12e} (Richardson change {oracle:.1e})",
            scene.name, NAMES[i], reported[i], rich[i]
        );
        assert!(oracle <= 1e-6 * scale, "{}: d{}/d{param}: the differences did not settle", scene.name, NAMES[i]);
        assert!(
            (reported[i] - rich[i]).abs() <= 1e-8 * scale + 3.0 * oracle,
            "{}: d{}/d{param} = {:.12e} against the differences' {:.12e} ({:.1e} relative)",
            scene.name,
            NAMES[i],
            reported[i],
            rich[i],
            (reported[i] - rich[i]).abs() / scale
        );
    }
}

/// The user's sleigh with a prescribed rotor (`drive psi`), typed as text.
fn rotor_drive() -> (Scene, RuntimeModel) {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (scene, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    (scene, model)
}

/// The user's sleigh with a rotor under a harmonic motor torque (its
/// frequency the scene parameter `w`), typed as text.
fn rotor_sleigh() -> (Scene, RuntimeModel) {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_sleigh.ezy")).unwrap();
    let (scene, _) = Scene::read(&data.join("rotor-sleigh.toml")).unwrap();
    (scene, model)
}

/// The case: the rolling-resistance EzyRoller's derivatives in
/// its motor's frequency (ezy gave `dmean_speed/domega = -0.1096064273`,
/// 1.9e-6 off, from differences of the forcing's waveforms at t = 120 s).
#[test]
fn a_gaits_derivatives_in_a_forcing_frequency_are_the_differences() {
    check(&scenes::get("drive-rolling-resistance"), &EzyRoller::default(), "motor.omega");
}

/// A prescribed drive's frequency, on a user's model typed as text.
#[test]
fn a_gaits_derivatives_in_a_drives_frequency_are_the_differences() {
    let (scene, model) = rotor_drive();
    check(&scene, &model, "psi.omega");
}

/// Every other parameter class: a motor's amplitude, a resistance, a
/// mass, a geometry, on the built-in EzyRoller and the two text models.
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn every_parameter_class_is_the_differences() {
    let roller = scenes::get("drive-rolling-resistance");
    for p in ["motor.torque.cos.amplitude", "rolling_A.damping", "m1", "a"] {
        check(&roller, &EzyRoller::default(), p);
    }
    let (scene, model) = rotor_drive();
    for p in ["psi.amplitude", "drag.c", "m", "a"] {
        check(&scene, &model, p);
    }
    let (scene, model) = rotor_sleigh();
    // (not `Ir`: the motor's reaction on the sleigh is its torque, whatever
    // the rotor's inertia, and every derivative is 0 to 1e-12)
    for p in ["w", "drag.c_rot", "I"] {
        check(&scene, &model, p);
    }
}

/// The phase: a gait's derivatives hold the forcing's phase at its fixed
/// point, so at a start between whole periods (`t0 = 0.37 T_f`, which
/// moves with a frequency) every quantity's derivative is the
/// differences' of gaits at that phase, the start's own motion included;
/// at `t0 = 60.37 T_f` (integrated from `0.37 T_f`, where ezy once took
/// the frequency's derivative of the waveform at `t0` itself: `t0 domega`
/// of phase) they are those at `0.37 T_f` to 1e-9 relative. The phase's
/// invariants (period, mean speed, mean power, efficiency) have the
/// derivatives they have at phase 0, and the straight gait's heading
/// change has derivative 0 (ezy gave 3.6e-6) to 1e-9 of its
/// displacement's.
#[test]
fn a_gaits_derivatives_hold_its_phase() {
    let (scene, model) = (scenes::get("drive-rolling-resistance"), EzyRoller::default());
    check_at(&scene, &model, "motor.omega", 0.37);
    let (_, at0) = gait(&scene, &model, &[], 0.0, Some("motor.omega"));
    let (_, at37) = gait(&scene, &model, &[], 0.37, Some("motor.omega"));
    let (_, late) = gait(&scene, &model, &[], 60.37, Some("motor.omega"));
    for i in 0..8 {
        eprintln!("d{}/domega: {:.12e} at 0.37 T_f, {:.12e} at 60.37 T_f", NAMES[i], at37[i], late[i]);
        // (the heading change, 0 by symmetry: against the displacement's)
        let scale = if i == 5 { at37[3].abs().max(at37[4].abs()) } else { at37[i].abs() };
        assert!((late[i] - at37[i]).abs() <= 1e-9 * scale, "d{}: {} against {}", NAMES[i], late[i], at37[i]);
    }
    for i in [0, 1, 6, 7] {
        eprintln!("d{}/domega: {:.12e} at phase 0, {:.12e} at 0.37 T_f", NAMES[i], at0[i], at37[i]);
        assert!((at0[i] - at37[i]).abs() <= 1e-9 * at0[i].abs(), "d{}: {} against {}", NAMES[i], at0[i], at37[i]);
    }
    for d in [&at0, &at37, &late] {
        let displacement = d[3].abs().max(d[4].abs());
        assert!(d[5].abs() <= 1e-9 * displacement, "ddheading/domega = {:e} (ddx {:e})", d[5], d[3]);
    }
}

/// The built-in snakes' gaits (every built-in scene `ezy analyze` finds
/// a gait on, with `drive-rolling-resistance` above): `snake`'s rolling
/// resistance and its motors' frequency (torque-driven, five links);
/// `kinematic-snake`'s drive amplitude and link length (every shape
/// prescribed: the gait is kinematic); `snake-long`'s drive family's
/// frequency and link length (thirty links, prescribed angles).
#[test]
#[ignore = "whole harness: the built-in snakes' gaits (minutes)"]
fn every_built_in_gait_is_the_differences() {
    use ezy::models::{KinematicSnake, Snake, SnakeDriven};
    let mut failed = Vec::new();
    let mut each = |name: &str, p: &str, run: &dyn Fn(&Scene, &str)| {
        let scene = scenes::get(name);
        if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(&scene, p))).is_err() {
            failed.push(format!("{name}: {p}"));
        }
    };
    // (`motor.torque.sin.omega`: ezy's dmean_forward_speed was 57.0, the
    // fixed point's phase moved by `t0 domega` at t0 = 502 s; 0.156)
    for p in ["roll.damping", "motor.torque.sin.omega"] {
        each("snake", p, &|s, p| check(s, &Snake::default(), p));
    }
    for p in ["D1.angle.harmonics.1.amplitude", "l"] {
        each("kinematic-snake", p, &|s, p| check(s, &KinematicSnake::default(), p));
    }
    for p in ["D[*].angle.sin.omega", "l"] {
        each("snake-long", p, &|s, p| check(s, &SnakeDriven::default(), p));
    }
    assert!(failed.is_empty(), "{failed:?}");
}

/// A period-2 orbit: Baker and Gollub's forced pendulum between its first
/// two period doublings (A = 10.52 N m; they are at 10.4611 and about
/// 10.59), its orbit of two
/// forcing periods at phase 0. Its period moves with the forcing's
/// frequency as two forcing periods do, `dT/domega = -4 pi / omega^2`
/// (to 1e-10 relative: ezy differences the forcing's period `2 pi /
/// omega` over `omega +- h`, `h = eps^(1/3) omega`, whose truncation is
/// `(h / omega)^2`, 4e-11); its fixed point's derivative (every state
/// component) and its mean input power's are the central differences of
/// period-2 orbits found one by one at `omega +- h` and `+- h/2`, `h =
/// 2e-5 omega` (the orbit bends fast between doublings; each from the
/// first orbit's fixed point, the copy nearest it), Richardson; to 1e-8
/// of the largest plus three times the Richardson change. Each orbit is checked to be the doubled
/// one: a forcing period apart from itself by more than 1e-3 rad.
#[test]
fn a_period_2_orbits_derivatives_are_the_differences() {
    use ezy::models::Pendulum;
    let (_, omega, c_rot) = crate::bifurcation::BAKER_GOLLUB;
    let param = "motor.torque.cos.omega";
    // (the doubled orbit has two copies a forcing period apart: the one
    // nearest the first found, from its fixed point, at every omega)
    let orbit_at = |w: f64, near: Option<&[f64]>| {
        let scene = Scene::from_toml(&crate::bifurcation::forced_pendulum(10.52, w, c_rot), "p2.toml").unwrap();
        let model = Pendulum::default();
        let (problem, _): (Problem<Pendulum>, _) = scene.problem_with(model.clone(), &[]).unwrap();
        let (mut an, x0) = problem.clone().analysis().unwrap();
        let Some(Periodicity::Period(tf)) = an.forcing() else { panic!("not forced periodically") };
        let symmetry: Symmetry = an.symmetry(0.0, &x0).unwrap();
        let guess = match near {
            Some(x) => x.to_vec(),
            None => {
                problem.clone().t_end(200.0 * tf).every(200.0 * tf).solve().unwrap().final_state()[..x0.len()].to_vec()
            }
        };
        let orbit = an.gait(0.0, 2.0 * tf, &guess, symmetry, &tight()).unwrap();
        let (half, _) = an.end_state(0.0, &orbit.state, tf, &tight()).unwrap();
        let apart = half.iter().zip(&orbit.state).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(apart > 1e-3, "omega = {w}: the orbit repeats every forcing period ({apart:e}): not the doubled one");
        let params: Vec<_> =
            if near.is_none() { vec![scene.parameter(&model, &[], param).unwrap()] } else { Vec::new() };
        let s = problem.gait_sensitivities(&orbit, &params, &tight()).unwrap();
        (orbit, s)
    };
    let (orbit, s) = orbit_at(omega, None);
    let exact = -4.0 * std::f64::consts::PI / (omega * omega);
    eprintln!("period-2: T = {} s, dT/domega = {:.12e} (exactly {exact:.12e})", orbit.period, s.d_period[0]);
    assert!((s.d_period[0] - exact).abs() <= 1e-10 * exact.abs(), "{} against {exact}", s.d_period[0]);
    // the fixed point's components, then the mean input power
    let quantities = |w: f64| {
        let (o, s) = orbit_at(w, Some(&orbit.state));
        [o.state, vec![s.mean_power]].concat()
    };
    let reported = [s.d_state[0].clone(), vec![s.d_mean_power[0]]].concat();
    let slope = |h: f64| {
        let (a, b) = (quantities(omega + h), quantities(omega - h));
        a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect::<Vec<_>>()
    };
    let h = 2e-5 * omega;
    let (d1, d2) = (slope(h), slope(h / 2.0));
    let rich: Vec<f64> = d2.iter().zip(&d1).map(|(a, b)| a + (a - b) / 3.0).collect();
    let largest = rich.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for i in 0..rich.len() {
        let oracle = (rich[i] - d2[i]).abs();
        eprintln!(
            "period-2: component {i}: {:.12e}, differences {:.12e} (Richardson change {oracle:.1e})",
            reported[i], rich[i]
        );
        assert!(oracle <= 1e-6 * largest, "component {i}: the differences did not settle");
        assert!(
            (reported[i] - rich[i]).abs() <= 1e-8 * largest + 3.0 * oracle,
            "component {i}: {} against the differences' {}",
            reported[i],
            rich[i]
        );
    }
}
