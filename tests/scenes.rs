//! The scenes of docs/physics.md §9 and §10.3, end to end through the generated models,
//! the KKT solve, RK4 and projection, at the assignment's settings.

use crate::common;

use common::{Recorder, max_abs};
use common::{build, setup};
use ezy_core::kkt::KktMethod;
use ezy_core::{Baumgarte, Method, Model, ProjectionKind, RunSettings, simulate};

use ezy_models::scenes;
use ezy_models::{ChaplyginSleigh, EzyRoller};
use ezy_scene::Scene;

fn run<M: Model + Default>(
    scene: &Scene,
    y0: Option<Vec<f64>>,
    projection: ProjectionKind,
) -> (Recorder, ezy_core::Summary) {
    let (mut sys, y0_scene) = build::<M>(scene, &[], KktMethod::Auto).expect("scene sets up");
    // the DAE, whose projection these tests look at
    let settings = RunSettings {
        projection,
        formulation: ezy_core::Formulation::Dae,
        balance_limit: None,
        max_steps: None,
        ..scene.run_settings()
    };
    let mut rec = Recorder::default();
    let summary = simulate(&mut sys, &y0.unwrap_or(y0_scene), &settings, &mut rec).expect("scene runs");
    (rec, summary)
}

#[test]
fn free_initial_velocities_follow_from_the_constraints() {
    let y0 = setup::<EzyRoller>(&scenes::free(), &[]).unwrap().y0;
    let m = EzyRoller::default();
    let want_q = [m.a, 0.0, 0.0, m.a + m.b, m.d, std::f64::consts::FRAC_PI_2];
    let want_qd = [1.0, 0.0, 0.0, 0.5, 0.0, 5.0];
    for k in 0..6 {
        assert!((y0[k] - want_q[k]).abs() < 1e-14, "q[{k}] = {}", y0[k]);
        assert!((y0[6 + k] - want_qd[k]).abs() < 1e-12, "qd[{k}] = {}", y0[6 + k]);
    }
}

/// Over-specified initial velocities (all six given, the lateral speed at
/// skate A among them nonzero) are projected onto the constraints, and
/// the warning says which given values changed, from what to what: each
/// listed pair is the value given and the one the run starts from.
#[test]
fn a_projected_velocity_is_named_with_its_given_and_new_value() {
    let mut p = ezy::Problem::new(EzyRoller::default());
    let m = EzyRoller::default();
    let q = [
        ("x1", m.a),
        ("y1", 0.0),
        ("phi1", 0.0),
        ("x2", m.a + m.b),
        ("y2", m.d),
        ("phi2", std::f64::consts::FRAC_PI_2),
    ];
    let qd = [("x1", 1.0), ("y1", 0.3), ("phi1", 0.0), ("x2", 0.5), ("y2", 0.0), ("phi2", 5.0)];
    for (name, v) in q {
        p = p.q(name, v).unwrap();
    }
    for (name, v) in qd {
        p = p.qd(name, v).unwrap();
    }
    let (y0, report) = p.initial_state().unwrap();
    assert!(report.velocity_violation > 0.1, "{report:?}");
    assert!(!report.velocity_changes.is_empty() && report.velocity_changes.len() <= 3, "{report:?}");
    for (name, given, now) in &report.velocity_changes {
        let k = qd.iter().position(|(n, _)| format!("{n}d") == *name).expect("a given velocity");
        assert_eq!(*given, qd[k].1, "{name}");
        assert_eq!(*now, y0[6 + k], "{name}");
        assert!((now - given).abs() > 1e-3, "{name}: {given} -> {now}");
    }
    let warning = report.warnings().join("\n");
    let (first, given, _) = &report.velocity_changes[0];
    assert!(warning.contains(&format!("given values changed: {first} {given} -> ")), "{warning}");
}

#[test]
fn free_conserves_kinetic_energy() {
    let (rec, s) = run::<EzyRoller>(&scenes::free(), None, ProjectionKind::default());
    // docs/physics.md §10.3: T = 23.1875 J throughout
    assert!((rec.kinetic[0] - 23.1875).abs() < 1e-12, "T0 = {}", rec.kinetic[0]);
    let drift = max_abs(rec.kinetic.iter().map(|t| t - 23.1875));
    assert!(drift <= 1e-10, "T drifts by {drift:e} J");
    assert!(s.max_energy_error <= 1e-10);
    assert!(s.max_residual_position <= 1e-12 && s.max_residual_velocity <= 1e-12);
}

#[test]
fn drive_closes_the_energy_balance_and_stays_on_the_constraints() {
    for projection in [ProjectionKind::MassWeighted, ProjectionKind::Euclidean] {
        let (rec, s) = run::<EzyRoller>(&scenes::drive(), None, projection);
        assert_eq!(s.steps, 600_000);
        assert_eq!(s.counters.rhs_evals, 2_400_000);
        assert!((rec.t.last().unwrap() - 60.0).abs() < 1e-12);
        assert!(s.max_energy_error <= 1e-9, "{projection:?}: max |T - T0 - W| = {:e} J", s.max_energy_error);
        let rp = max_abs(rec.res_phi.iter().copied());
        let rv = max_abs(rec.res_vel.iter().copied());
        assert!(rp <= 1e-12 && rv <= 1e-12, "{projection:?}: residuals {rp:e} m, {rv:e} m/s");
        // the motor did work and the vehicle moved: not a trivial trajectory
        let w = rec.y.last().unwrap()[12];
        assert!(w > 1.0, "W = {w}");
    }
}

#[test]
fn projection_removes_the_drift_of_a_coarse_step() {
    // At the assignment's h = 1e-4 even unprojected RK4 drifts only ~6e-13 m in
    // 60 s (the index-1 form with exact gamma drifts slowly). At h = 0.01 the
    // drift is visible, and projection removes it: a check that the residual
    // columns measure something and that projection acts.
    let mut scene = scenes::drive();
    scene.integrator.dt = 0.01;
    let (free, _) = run::<EzyRoller>(&scene, None, ProjectionKind::None);
    let (proj, _) = run::<EzyRoller>(&scene, None, ProjectionKind::MassWeighted);
    let drift = max_abs(free.res_phi.iter().copied()).max(max_abs(free.res_vel.iter().copied()));
    let kept = max_abs(proj.res_phi.iter().copied()).max(max_abs(proj.res_vel.iter().copied()));
    assert!(drift > 1e-9, "unprojected drift {drift:e}");
    assert!(kept <= 1e-12, "projected residual {kept:e}");
}

/// Rotating by `theta` and translating by `(dx, dy)` the initial state of
/// `drive` rotates and translates the whole trajectory (docs/physics.md §10.3).
#[test]
fn drive_is_se2_invariant() {
    let scene = scenes::drive();
    let y0 = setup::<EzyRoller>(&scene, &[]).unwrap().y0;
    let (theta, dx, dy) = (0.7_f64, 3.0, -1.5);
    let (c, s) = (theta.cos(), theta.sin());
    let rot = |x: f64, y: f64| (c * x - s * y, s * x + c * y);
    let transform = |y: &[f64], translate: bool| -> Vec<f64> {
        let mut z = y.to_vec();
        for b in 0..2 {
            let (x, yy) = rot(y[3 * b], y[3 * b + 1]);
            z[3 * b] = x + if translate { dx } else { 0.0 };
            z[3 * b + 1] = yy + if translate { dy } else { 0.0 };
            z[3 * b + 2] = y[3 * b + 2] + theta;
            let (vx, vy) = rot(y[6 + 3 * b], y[6 + 3 * b + 1]);
            z[6 + 3 * b] = vx;
            z[6 + 3 * b + 1] = vy;
        }
        z
    };
    let (a, _) = run::<EzyRoller>(&scene, None, ProjectionKind::default());
    let (b, _) = run::<EzyRoller>(&scene, Some(transform(&y0, true)), ProjectionKind::default());
    let mut worst: f64 = 0.0;
    for (ya, yb) in a.y.iter().zip(&b.y) {
        let want = transform(ya, true);
        worst = worst.max(max_abs(want.iter().zip(yb).map(|(p, q)| p - q)));
    }
    assert!(worst <= 1e-9, "SE(2) invariance violated by {worst:e}");
}

/// Largest deviation of the forward speed u [m/s] and yaw rate [rad/s]
/// from docs/physics.md §9's closed form over the recorded samples.
fn sleigh_error(rec: &Recorder) -> f64 {
    let w0 = 1.0;
    let (big_u, k, c0) = common::sleigh_closed_form(1.0, w0);
    let mut worst: f64 = 0.0;
    for (t, y) in rec.t.iter().zip(&rec.y) {
        let (phi, xd, yd, phid) = (y[2], y[3], y[4], y[5]);
        let u = xd * phi.cos() + yd * phi.sin();
        let u_exact = big_u * (k * big_u * t + c0).tanh();
        let w_exact = w0 * c0.cosh() / (k * big_u * t + c0).cosh();
        worst = worst.max((u - u_exact).abs()).max((phid - w_exact).abs());
    }
    worst
}

/// docs/physics.md §9: u(t) = U tanh(k U t + atanh(u0/U)),
/// omega(t) = omega0 cosh(atanh(u0/U)) / cosh(k U t + atanh(u0/U)).
#[test]
fn sleigh_matches_the_closed_form() {
    let scene = scenes::sleigh();
    let (rec, s) = run::<ChaplyginSleigh>(&scene, None, ProjectionKind::default());
    let worst = sleigh_error(&rec);
    assert!(worst <= 1e-9, "sleigh deviates from the closed form by {worst:e}");
    assert!(s.max_residual_velocity <= 1e-12);
    // the closed form is not trivial over 10 s: the yaw rate has decayed
    assert!(rec.y.last().unwrap()[5] < 0.5);
}

/// Baumgarte stabilization (alpha = beta = 10 /s) without projection at
/// h = 0.01 s keeps the drift bounded: measured max|C| = 4.0e-10 m and
/// max|G qd| = 6.1e-9 m/s over 60 s, against 2.2e-7 m unstabilized. The
/// bounds below leave a factor ~10 and stay well under the unstabilized drift.
#[test]
fn baumgarte_keeps_the_drift_bounded() {
    let mut scene = scenes::drive();
    scene.integrator.dt = 0.01;
    let drift = |baumgarte: Option<Baumgarte>| {
        let (mut sys, y0) = build::<EzyRoller>(&scene, &[], KktMethod::Auto).unwrap();
        sys.baumgarte = baumgarte;
        let settings = RunSettings {
            dt: scene.integrator.dt,
            t_end: scene.t_end,
            every: scene.output.every,
            projection: ProjectionKind::None,
            method: Method::Rk4,
            formulation: ezy_core::Formulation::Dae,
            rtol: 1e-9,
            atol: 1e-9,
            balance_limit: None,
            max_steps: None,
        };
        let mut rec = Recorder::default();
        simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
        (max_abs(rec.res_phi.iter().copied()), max_abs(rec.res_vel.iter().copied()))
    };
    let (c_free, _) = drift(None);
    let (c, v) = drift(Some(Baumgarte { alpha: 10.0, beta: 10.0 }));
    assert!(c <= 5e-9 && v <= 1e-7, "Baumgarte residuals {c:e} m, {v:e} m/s");
    assert!(c_free > 20.0 * c, "unstabilized {c_free:e} vs Baumgarte {c:e}");
}

/// Adaptive methods meet their tolerance on the sleigh's closed form:
/// error <= 10 x tolerance over 10 s.
#[test]
fn adaptive_methods_meet_their_tolerance_on_the_sleigh() {
    for method in [Method::Dopri5, Method::Dop853] {
        for tol in [1e-6, 1e-9, 1e-11] {
            let mut scene = scenes::sleigh();
            scene.integrator.method = method;
            scene.integrator.rtol = tol;
            scene.integrator.atol = tol;
            let (rec, s) = run::<ChaplyginSleigh>(&scene, None, ProjectionKind::default());
            let worst = sleigh_error(&rec);
            assert!(worst <= 10.0 * tol, "{method:?} tol {tol:e}: error {worst:e} after {} steps", s.steps);
            assert!(s.max_residual_velocity <= 1e-12);
        }
    }
}

#[test]
fn missing_initial_values_are_an_error_that_names_them() {
    let mut scene = scenes::drive();
    scene.initial.qd.clear();
    let err = setup::<EzyRoller>(&scene, &[]).unwrap_err().to_string();
    assert!(err.contains("give 2 more"), "{err}");
    let mut scene = scenes::drive();
    scene.initial.q.retain(|(n, _)| n != "phi2");
    let err = setup::<EzyRoller>(&scene, &[]).unwrap_err().to_string();
    assert!(err.contains("phi2"), "{err}");
}

/// The values `err` suggests giving ("..., for example a, b (the ...").
fn suggested(err: &str) -> Vec<String> {
    let i = err.find("for example ").unwrap_or_else(|| panic!("no suggestion: {err}")) + "for example ".len();
    let j = i + err[i..].find(" (the ").unwrap_or_else(|| panic!("{err}"));
    err[i..j].split(", ").map(str::to_owned).collect()
}

/// A scene short of initial values is told which would do, and giving
/// those, at any values, determines the rest without a correction: the
/// drive scene without velocities (six unknowns, four constraint rows)
/// and the four-bar without coordinates (nine unknowns, eight rows), its
/// suggestion given at the values the whole scene assembles to.
#[test]
fn missing_initial_values_are_answered_with_ones_that_would_do() {
    let mut scene = scenes::drive();
    scene.initial.qd.clear();
    let err = setup::<EzyRoller>(&scene, &[]).unwrap_err().to_string();
    let give = suggested(&err);
    assert!(err.contains("give 2 more") && give.len() == 2, "{err}");
    for (k, name) in give.iter().enumerate() {
        let coord = name.strip_suffix('d').unwrap_or_else(|| panic!("{name}"));
        scene.initial.qd.push((coord.to_owned(), ezy_scene::InitValue::Num(0.3 - 0.7 * k as f64)));
    }
    let s = setup::<EzyRoller>(&scene, &[]).unwrap_or_else(|e| panic!("{give:?}: {e}"));
    assert_eq!(s.initial.velocity_violation, 0.0, "{give:?}");

    let whole = scenes::get("four-bar");
    let assembled = setup::<ezy_models::FourBar>(&whole, &[]).unwrap();
    let coords = ezy_models::FourBar::default().info().coords;
    let mut scene = whole.clone();
    scene.initial.q.clear();
    let err = setup::<ezy_models::FourBar>(&scene, &[]).unwrap_err().to_string();
    let give = suggested(&err);
    assert!(err.contains("give 1 more") && give.len() == 1, "{err}");
    let i = coords.iter().position(|c| *c == give[0]).unwrap_or_else(|| panic!("{err}"));
    scene.initial.q.push((give[0].clone(), ezy_scene::InitValue::Num(assembled.y0[i])));
    scene.initial.guess = coords
        .iter()
        .zip(&assembled.y0)
        .filter(|(c, _)| **c != give[0])
        .map(|(c, &v)| (c.clone(), ezy_scene::InitValue::Num(v)))
        .collect();
    let s = setup::<ezy_models::FourBar>(&scene, &[]).unwrap_or_else(|e| panic!("{give:?}: {e}"));
    assert!(max_abs(s.y0.iter().zip(&assembled.y0).map(|(a, b)| a - b)) < 1e-9, "{give:?}");
}

#[test]
fn overrides_reach_the_model_and_the_motor() {
    let scene = scenes::drive();
    let s = setup::<EzyRoller>(&scene, &[("m2".into(), 2.5), ("motor.amplitude".into(), 3.0)]).unwrap();
    assert_eq!(s.model.m2, 2.5);
    let (_, motor) = &s.scene.effects[0];
    let want = ezy_core::effects::Waveform::Cos(ezy_core::effects::Harmonic {
        amplitude: 3.0,
        omega: std::f64::consts::PI,
        phase: 0.0,
        phase_step: 0.0,
    });
    assert!(
        matches!(motor, ezy_scene::SceneEffect::Builtin(ezy_core::EffectSpec::HingeMotor(ezy_core::effects::HingeMotor { torque, .. })) if *torque == want),
        "{motor:?}"
    );
    // the full key path works too, and the scene given is not changed
    let s = setup::<EzyRoller>(&scene, &[("motor.torque.cos.omega".into(), 2.0)]).unwrap();
    assert!(
        matches!(&s.scene.effects[0].1, ezy_scene::SceneEffect::Builtin(ezy_core::EffectSpec::HingeMotor(ezy_core::effects::HingeMotor { torque: ezy_core::effects::Waveform::Cos(h), .. })) if h.omega == 2.0)
    );
    assert_eq!(scene, scenes::drive());
    let err = setup::<EzyRoller>(&scene, &[("mass".into(), 1.0)]).unwrap_err().to_string();
    assert!(
        err.contains("unknown parameter `mass`") && err.contains("m1") && err.contains("motor.torque.cos.omega"),
        "{err}"
    );
}

/// A run starts a heartbeat thread for its setup only when its families
/// sum to at least `LONG_SETUP_ELEMENTS` elements (its start and join cost
/// about 0.3 ms, a tenth of a small run): the count is read from the
/// model's default, the scene's `[params]` and the overrides, the last
/// override winning, and a model without families never gets one.
#[test]
fn only_a_large_family_sets_up_with_a_heartbeat() {
    use ezy::session::{LONG_SETUP_ELEMENTS, setup_may_be_long};
    let named = |name: &str| scenes::builtin().into_iter().find(|s| s.scene.name == name).unwrap().scene;
    let (snake, long, drive) = (named("snake"), named("snake-long"), named("drive"));
    let n = |v: f64| vec![("N".to_string(), v)];
    let big = LONG_SETUP_ELEMENTS;
    assert!(!setup_may_be_long(&ezy_models::Snake::default(), &snake, &[]), "the model's N = 5");
    assert!(setup_may_be_long(&ezy_models::Snake::default(), &snake, &n(big)));
    assert!(!setup_may_be_long(&ezy_models::Snake::default(), &snake, &n(big - 1.0)));
    let last_wins = [n(big), n(big - 1.0)].concat();
    assert!(!setup_may_be_long(&ezy_models::Snake::default(), &snake, &last_wins));
    let mut huge = long.clone();
    huge.params.iter_mut().filter(|(name, _)| name == "N").for_each(|(_, v)| *v = big);
    assert!(setup_may_be_long(&ezy_models::SnakeDriven::default(), &huge, &[]), "the scene's [params]");
    assert!(!setup_may_be_long(&ezy_models::SnakeDriven::default(), &huge, &n(30.0)), "an override beats the scene");
    assert!(!setup_may_be_long(&EzyRoller::default(), &drive, &[]));
}
