//! Hard cases that must stay numerically sound (issue 4, growing).

use crate::common;

use common::{Recorder, max_abs};
use common::{build, setup};
use ezy::RunOptions;
use ezy::output::csv::FIGURE_ROWS;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Method, Model, ProjectionKind, RunSettings, simulate};

use ezy_models::{EzyRoller, scenes};
use ezy_scene::InitValue;

/// A massless steering fork (m2 = I2 = 0): `M` is singular but the KKT
/// matrix is regular. The automatic choice is the LU path, and
/// mass-weighted projection solves the KKT system instead of inverting `M`.
/// Measured with DOP853 at 1e-10 over 60 s: residuals 1.0e-12 m and
/// 1.8e-16 m/s, energy balance 7.5e-11 J (the tolerance's level).
#[test]
fn massless_fork_runs_on_the_lu_path() {
    let sets = [("m2".to_string(), 0.0), ("I2".to_string(), 0.0)];
    let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &sets, KktMethod::Auto).unwrap();
    assert_eq!(sys.kkt_name(), "dense-lu");
    let settings = RunSettings {
        dt: 1e-4,
        t_end: 60.0,
        every: 0.1,
        projection: ProjectionKind::MassWeighted,
        method: Method::Dop853,
        formulation: ezy_core::Formulation::Dae,
        rtol: 1e-10,
        atol: 1e-10,
        balance_limit: None,
        max_steps: None,
    };
    let mut rec = Recorder::default();
    let s = simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
    assert!(s.projection_path.contains("singular M"), "{}", s.projection_path);
    let rp = max_abs(rec.res_phi.iter().copied());
    let rv = max_abs(rec.res_vel.iter().copied());
    assert!(rp <= 1e-12 && rv <= 1e-12, "residuals {rp:e} m, {rv:e} m/s");
    assert!(s.max_energy_error <= 1e-9, "energy balance {:e} J", s.max_energy_error);
    // the fork carries no energy: T is body 1's alone, and the vehicle moved
    let last = rec.y.last().unwrap();
    let m = EzyRoller::default();
    let t1 = 0.5 * m.m1 * (last[6] * last[6] + last[7] * last[7]) + 0.5 * m.I1 * last[8] * last[8];
    assert!((rec.kinetic.last().unwrap() - t1).abs() < 1e-12);
    assert!(last[12] > 1.0, "W = {}", last[12]);
}

/// One hour of `drive` with DOP853 at 1e-10: residuals <= 1e-9 and the
/// relative energy balance |T - T0 - W| / max(1, |W|) <= 1e-7. Measured:
/// residuals 9.8e-13 m and 7.6e-16 m/s, |T - T0 - W| = 1.3e-10 J, 0.31 s of
/// integration, 11 MB peak memory for the whole process.
#[test]
fn one_hour_keeps_constraints_and_energy() {
    let dir = std::env::temp_dir().join(format!("ezy-hard-{}-hour", std::process::id()));
    let opts = RunOptions {
        out: dir.clone(),
        method: Some(Method::Dop853),
        rtol: Some(1e-10),
        atol: Some(1e-10),
        t_end: Some(3600.0),
        every: Some(10.0),
        figures: false,
        ..RunOptions::default()
    };
    let r = ezy::App::new().run_scene(&scenes::drive(), &opts).unwrap();
    let s = &r.summary;
    assert!(s.max_residual_position <= 1e-9 && s.max_residual_velocity <= 1e-9);
    let w = s.final_state[12];
    let relative = s.max_energy_error / w.abs().max(1.0);
    assert!(relative <= 1e-7, "relative energy balance {relative:e} (W = {w} J)");
    assert_eq!(r.table.rows(), 361);
    let _ = std::fs::remove_dir_all(dir);
}

/// The CSV streams every row, the figures keep a bounded sample: memory does
/// not grow with the horizon.
#[test]
fn output_memory_is_bounded() {
    let dir = std::env::temp_dir().join(format!("ezy-hard-{}-rows", std::process::id()));
    let opts = RunOptions {
        out: dir.clone(),
        method: Some(Method::Dop853),
        t_end: Some(500.0),
        every: Some(0.005),
        figures: false,
        ..RunOptions::default()
    };
    let r = ezy::App::new().run_scene(&scenes::sleigh(), &opts).unwrap();
    assert!(r.table.rows() <= FIGURE_ROWS, "{} rows kept", r.table.rows());
    assert!(r.table.rows() >= FIGURE_ROWS / 2);
    let lines = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap().lines().count();
    assert_eq!(lines, 1 + 100_001);
    let _ = std::fs::remove_dir_all(dir);
}

ezy_core::model! {
    /// Two bodies joined twice at the same points: a duplicated hinge.
    pub struct DoubleHinge {
        /// Half length [m]
        param l = 0.5;
        body left(x1, y1, phi1) { mass: 1.0, inertia: 0.1 }
        body right(x2, y2, phi2) { mass: 1.0, inertia: 0.1 }
        point P on left at (l, 0);
        point Q on right at (-l, 0);
        hinge H1: P = Q;
        hinge H2: P = Q;
    }
}

/// Constraints dependent at every configuration (a duplicated hinge) are
/// the model's error: the run stops at setup, naming the dependent row
/// (the strict pivot test, relative 1e-13, at generic configurations).
/// Constraints dependent only at some states are singular positions: the
/// right-hand side solves them regularized, and a run that stays at one
/// (both skates on the hinge point, bodies aligned, rolling straight) is
/// stopped after `SINGULAR_PERSIST_STEPS` steps, or a hundredth of the run
/// of them, naming the row.
#[test]
fn redundant_constraints_are_named() {
    let settings = common::dop853(1.0, 0.1, 1e-10);
    // a duplicated hinge: H2 repeats H1
    let mut sys = Dynamics::new(DoubleHinge::default(), vec![], KktMethod::Auto);
    let y = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.3, 0.0];
    let ny = sys.ny();
    let err = simulate(&mut sys, &y[..ny], &settings, &mut Recorder::default()).unwrap_err().to_string();
    assert!(err.contains("constraint `H2.x` (row 2 of G) depends on the constraints before it (H1.x, H1.y)"), "{err}");
    assert!(err.contains("the model has redundant constraints"), "{err}");
    // both skates on the hinge point (a = -b, c = -d) with aligned bodies:
    // the two skates constrain the same lateral velocity, here only
    let mut m = EzyRoller::default();
    m.a = -m.b;
    m.c = -m.d;
    let mut sys = Dynamics::new(m, vec![], KktMethod::Auto);
    let y = [0.0, 0.0, 0.0, 0.7, 0.0, 0.0, 0.1, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
    let mut dy = [0.0; 13];
    sys.rhs(0.0, &y, &mut dy).unwrap();
    assert_eq!(sys.counters.singular_solves, 1, "solved regularized");
    // rolling straight: the accelerations are zero, whatever the multipliers
    assert!(dy[6..12].iter().all(|a| a.abs() < 1e-12), "{dy:?}");
    let err = simulate(&mut sys, &y[..12], &settings, &mut Recorder::default()).unwrap_err().to_string();
    assert!(err.contains("the constraint `C` (row 3 of G) stayed dependent on the constraints before it"), "{err}");
    assert!(err.contains("from t = 0 s to t = ") && err.contains("steps in a row"), "{err}");
}

ezy_core::model! {
    /// A bar pinned to the ground at both ends, the pins 3 m apart but the
    /// bar only 1 m long: no configuration exists.
    pub struct OverstretchedBar {
        /// Half length [m]
        param l = 0.5;
        body bar(x, y, phi) { mass: 1.0, inertia: 0.1 }
        point P on bar at (-l, 0);
        point Q on bar at (l, 0);
        hinge O1: P = ground(0, 0);
        hinge O2: Q = ground(3, 0);
    }
}

/// Inconsistent initial values are projected with a warning that gives the
/// size of each correction; an impossible configuration is an error.
#[test]
fn inconsistent_initial_conditions_are_projected_or_refused() {
    let mut scene = scenes::drive();
    scene.initial.q.push(("x2".into(), InitValue::Num(0.5 + 1e-3)));
    scene.initial.q.push(("y2".into(), InitValue::Num(-2e-3)));
    scene.initial.qd.push(("y1".into(), InitValue::Num(0.01)));
    let common::Setup { model: m, y0, initial: report, .. } = setup::<EzyRoller>(&scene, &[]).unwrap();
    assert!((report.position_violation - 2e-3).abs() < 1e-14, "{report:?}");
    assert!(report.position_correction > 1e-4 && report.position_correction < 3e-3, "{report:?}");
    // what least squares in the unknowns leaves of the 0.01 m/s given in y1d
    assert!(report.velocity_violation > 5e-3 && report.velocity_violation < 1.1e-2, "{report:?}");
    let w = report.warnings();
    assert_eq!(w.len(), 2);
    assert!(w[0].contains("violate the holonomic constraints by 2.000e-3 (most: `B.y`)"), "{}", w[0]);
    let mut phi = [0.0; 2];
    m.phi(&y0[..6], &mut phi);
    assert!(phi.iter().all(|c: &f64| c.abs() <= 1e-12), "{phi:?}");

    let scene = ezy_scene::Scene {
        model: "bar".into(),
        initial: Default::default(),
        figures: vec![],
        effects: vec![],
        ..scenes::free()
    };
    let err = setup::<OverstretchedBar>(&scene, &[]).unwrap_err().to_string();
    assert!(err.contains("no configuration satisfies the holonomic constraints"), "{err}");
}

/// A mass ratio of 1e8 (m2 = 1e-6 kg, I2 = 5e-9 kg m^2 against m1 = 46 kg,
/// I1 = 10 kg m^2): the Schur complement `G M^-1 G^T` has entries from 1e-1
/// to 2e8, but an LDL^T of an SPD matrix is backward stable whatever its
/// diagonal scaling (the factorization commutes with it), so accuracy holds.
/// Measured with RK4 at h = 1e-3 s: |T - T0 - W| = 4.5e-10 J, residuals
/// 9.6e-13 m (at the assignment's h = 1e-4: 4.7e-11 J, 7.6e-13 m); the
/// trajectory stays within 1.2e-6 m of the massless limit (m2 = I2 = 0, LU
/// path), as a perturbation of order m2 should.
#[test]
fn a_mass_ratio_of_1e8_keeps_its_accuracy() {
    let run = |m2: f64, i2: f64| {
        let sets = [("m2".to_string(), m2), ("I2".to_string(), i2)];
        let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &sets, KktMethod::Auto).unwrap();
        let settings = RunSettings {
            dt: 1e-3,
            t_end: 60.0,
            every: 1.0,
            projection: ProjectionKind::MassWeighted,
            method: Method::Rk4,
            formulation: ezy_core::Formulation::Dae,
            rtol: 1e-10,
            atol: 1e-10,
            balance_limit: None,
            max_steps: None,
        };
        let mut rec = Recorder::default();
        let s = simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
        (s, rec, sys.kkt_name())
    };
    let (s, rec, path) = run(1e-6, 5e-9);
    assert_eq!(path, "schur-cholesky");
    assert!(s.max_energy_error <= 1e-9, "energy balance {:e} J", s.max_energy_error);
    assert!(s.max_residual_position <= 1e-12 && s.max_residual_velocity <= 1e-12);
    let (_, limit, path0) = run(0.0, 0.0);
    assert_eq!(path0, "dense-lu");
    let far = rec.y.iter().zip(&limit.y).map(|(a, b)| max_abs((0..6).map(|k| a[k] - b[k]))).fold(0.0, f64::max);
    assert!(far < 1e-5, "distance to the massless limit {far:e}");
    assert!(far > 1e-8, "the light fork should still matter at order m2: {far:e}");
}

/// Nearly dependent constraints (skate A 1e-5 m from the hinge point, C on it,
/// bodies aligned) are flagged once, with the time; a mass ratio of 1e8 is
/// not (the estimate is the pivot growth of the equilibrated Schur
/// complement, independent of units and mass scaling).
#[test]
fn ill_conditioning_is_detected_and_mass_ratios_are_not() {
    let mut m = EzyRoller::default();
    m.a = -m.b + 1e-5;
    m.c = -m.d;
    let mut sys = Dynamics::new(m, vec![], KktMethod::Auto);
    let y = [0.0, 0.0, 0.0, 0.7, 0.0, 0.0, 0.1, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
    let mut dy = [0.0; 13];
    sys.rhs(0.25, &y, &mut dy).unwrap();
    let (t, c) = sys.ill_conditioned.expect("flagged");
    assert_eq!(t, 0.25);
    assert!(c > 1e10, "estimate {c:e}");
    sys.rhs(0.5, &y, &mut dy).unwrap();
    assert_eq!(sys.ill_conditioned.unwrap().0, 0.25, "recorded once");

    // the same on the LU path (massless fork with its skate 1e-11 m from
    // the hinge, so its heading is nearly free): the estimate is the pivot
    // growth relative to the rows' scales, measured ~1/offset (1e3 at 1e-3 m)
    let lu = EzyRoller { a: 0.2, c: -0.1 + 1e-11, m2: 0.0, I2: 0.0, ..EzyRoller::default() };
    let mut sys = Dynamics::new(lu, vec![], KktMethod::Auto);
    assert_eq!(sys.kkt_name(), "dense-lu");
    let y = [0.0, 0.0, 0.0, 0.7, 0.0, 0.0, 0.1, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
    match sys.rhs(0.25, &y, &mut dy) {
        Ok(()) => assert!(sys.ill_conditioned.is_some_and(|(_, c)| c > 1e10), "{:?}", sys.condition_estimate()),
        Err(e) => panic!("{e}"),
    }

    let light = EzyRoller { m2: 1e-6, I2: 5e-9, ..EzyRoller::default() };
    let mut sys = Dynamics::new(light, vec![], KktMethod::Auto);
    let y = [0.0, 0.0, 0.0, 0.5, 0.0, std::f64::consts::PI, 0.1, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
    sys.rhs(0.0, &y, &mut dy).unwrap();
    assert_eq!(sys.ill_conditioned, None);
}

ezy_core::model! {
    /// A parallelogram linkage with a third, redundant crank: three equal
    /// cranks pinned to the ground carry one coupler. Grübler's count gives
    /// 12 - 12 = 0 degrees of freedom, the geometry gives 1: one hinge
    /// equation is redundant in every configuration.
    pub struct TripleCrank {
        /// Crank length [m]
        param r = 1.0;
        /// Distance between the outer ground pins [m]
        param l = 2.0;
        body crank1(x1, y1, phi1) { mass: 1.0, inertia: 0.1 }
        body crank2(x2, y2, phi2) { mass: 1.0, inertia: 0.1 }
        body crank3(x3, y3, phi3) { mass: 1.0, inertia: 0.1 }
        body coupler(x4, y4, phi4) { mass: 2.0, inertia: 0.5 }
        point B1 on crank1 at (-r / 2, 0);
        point T1 on crank1 at (r / 2, 0);
        point B2 on crank2 at (-r / 2, 0);
        point T2 on crank2 at (r / 2, 0);
        point B3 on crank3 at (-r / 2, 0);
        point T3 on crank3 at (r / 2, 0);
        point K1 on coupler at (-l / 2, 0);
        point K2 on coupler at (l / 2, 0);
        point K3 on coupler at (0, 0);
        hinge G1: B1 = ground(0, 0);
        hinge G2: B2 = ground(l, 0);
        hinge G3: B3 = ground(l / 2, 0);
        hinge H1: T1 = K1;
        hinge H2: T2 = K2;
        hinge H3: T3 = K3;
    }
}

/// The parallelogram with a redundant crank: the last hinge row repeats
/// what the others already impose at every configuration, and the run
/// stops at setup naming it.
#[test]
fn a_redundant_parallelogram_crank_is_named() {
    let half = std::f64::consts::FRAC_PI_2;
    // cranks upright, coupler level on top
    let q = [0.0, 0.5, half, 2.0, 0.5, half, 1.0, 0.5, half, 1.0, 1.0, 0.0];
    let mut phi = [0.0; 12];
    TripleCrank::default().phi(&q, &mut phi);
    assert!(phi.iter().all(|c| c.abs() < 1e-15), "the state is consistent: {phi:?}");
    let mut y = q.to_vec();
    y.extend([0.0; 13]);
    let mut sys = Dynamics::new(TripleCrank::default(), vec![], KktMethod::Auto);
    let settings = common::dop853(1.0, 0.1, 1e-10);
    let ny = sys.ny();
    let err = simulate(&mut sys, &y[..ny], &settings, &mut Recorder::default()).unwrap_err().to_string();
    assert!(err.contains("the constraint `H3.y` (row 11 of G) depends on the constraints before it"), "{err}");
}

/// An adaptive method whose stages overflow (absurd initial rates: the
/// convective terms pass f64::MAX) shrinks its step until it is below the
/// rounding level of t and stops with `StepSizeTooSmall`, never looping and
/// never writing NaN; at rates whose kinetic energy itself overflows, the
/// run stops at t = 0 naming it.
#[test]
fn overflowing_stages_stop_with_step_size_too_small() {
    for (rate, want) in [(1e150, "the step size fell to"), (1e160, "at t = 0 s the kinetic energy T became inf")] {
        overflowing_stages_stop(rate, want);
    }
}

fn overflowing_stages_stop(rate: f64, want: &str) {
    let mut scene = scenes::free();
    scene.initial.qd = vec![("x1".into(), InitValue::Num(rate)), ("phi1".into(), InitValue::Num(rate))];
    let common::Setup { model, y0, .. } = setup::<EzyRoller>(&scene, &[]).unwrap();
    let mut sys = Dynamics::new(model, vec![], KktMethod::Auto);
    let settings = RunSettings {
        dt: 1e-3,
        t_end: 1.0,
        every: 0.1,
        projection: ProjectionKind::MassWeighted,
        method: Method::Dopri5,
        formulation: ezy_core::Formulation::Dae,
        rtol: 1e-8,
        atol: 1e-8,
        balance_limit: None,
        max_steps: None,
    };
    let mut rec = Recorder::default();
    let err = simulate(&mut sys, &y0, &settings, &mut rec).unwrap_err().to_string();
    assert!(err.contains(want), "{rate:e}: {err}");
    assert!(rec.y.iter().flatten().all(|v| v.is_finite()), "no NaN was written");
}
