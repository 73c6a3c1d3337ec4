//! The stiff scenes under RADAU5: the physics they claim (the servo snake
//! follows its gait, the elastic four-bar moves as the rigid one), the
//! ledger and the constraints, and the structured Newton system (KKT
//! structure, derivatives by grouped differences) against the dense
//! finite-difference Jacobian of the whole right-hand side.

use crate::common;

use common::build;
use ezy_core::formulation::newton::KktNewton;
use ezy_core::integrator::radau5::{DenseNewton, MU_COMPLEX, MU_REAL, NewtonSystem, c64};
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Method, Model, RunSettings, Summary, simulate};
use ezy_models::{ElasticFourBar, SnakeServo, scenes};

fn run<M: Model + Default>(name: &str) -> (common::Recorder, Summary) {
    let scene = scenes::get(name);
    let (mut sys, y0) = build::<M>(&scene, &[], KktMethod::Auto).unwrap();
    let settings = RunSettings { balance_limit: None, max_steps: None, ..scene.run_settings() };
    assert_eq!(settings.method, Method::Radau5);
    let mut rec = common::Recorder::default();
    let summary = simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
    (rec, summary)
}

/// `snake-stiff`: servos of 1e6 N m/rad hold every hinge on the serpenoid
/// `A sin(omega t - (i - 2) delta)`. Measured (rtol 1e-8): largest
/// tracking error 7.7e-6 rad (the servo torques, up to 7.7 N m, over the
/// stiffness), ledger gap 4.2e-8 J, max|C| 1.0e-12 m, 868 steps; the head
/// glides 8.8 m. A servo that lost its command (a sign error in the rate
/// term, a wrong phase) misses by 1e-2 rad and more.
#[test]
fn the_servo_snake_follows_its_gait() {
    let (rec, s) = run::<SnakeServo>("snake-stiff");
    let (a, omega, delta) = (0.5, std::f64::consts::PI, std::f64::consts::TAU / 10.0);
    let mut worst = 0.0f64;
    for (t, y) in rec.t.iter().zip(&rec.y) {
        for i in 2..=10 {
            let alpha = y[3 * (i - 2) + 2] - y[3 * (i - 1) + 2];
            worst = worst.max((alpha - a * (omega * t - (i as f64 - 2.0) * delta).sin()).abs());
        }
    }
    let y = rec.y.last().unwrap();
    let glide = y[0].hypot(y[1]);
    eprintln!(
        "snake-stiff: tracking {worst:e} rad, ledger {:e} J, |C| {:e} m, glide {glide} m, {} steps, {:?}",
        s.max_energy_error, s.max_residual_position, s.steps, s.newton
    );
    assert!(worst <= 2e-5, "tracking error {worst:e} rad");
    assert!(s.max_energy_error <= 1e-6, "ledger gap {:e} J", s.max_energy_error);
    assert!(s.max_residual_position <= 1e-11 && s.max_residual_velocity <= 1e-11);
    assert!(glide > 8.0, "the snake glides {glide} m");
    assert!(s.steps < 3000, "{} steps: the stiffness held the step", s.steps);
    assert!(s.newton.jacobians > 0 && s.newton.factorizations > 0 && s.newton.newton_iterations >= s.steps);
}

/// `four-bar-stiff`: the coupler is a spring-damper of 6e7 N/m, so the
/// crank and rocker angles obey Freudenstein's equation of the rigid
/// four-bar (`tests/mechanisms.rs`) up to the coupler's stretch. Measured:
/// residual 5.3e-6 (the equation changes by `b/(a c) = 11.7` per metre of
/// coupler length: a stretch of about 5e-7 m, some 30 N in the coupler),
/// the crank turning 7 times, ledger gap 3.5e-8 J, max|C| 1e-12 m. A
/// coupler that does not act (a wrong point, no force) leaves the residual
/// O(1).
#[test]
fn the_elastic_four_bar_moves_as_the_rigid_one() {
    let (rec, s) = run::<ElasticFourBar>("four-bar-stiff");
    let m = ezy_models::FourBar::default();
    let (k1, k2, k3) = (m.d / m.a, m.d / m.c, (m.a * m.a - m.b * m.b + m.c * m.c + m.d * m.d) / (2.0 * m.a * m.c));
    let mut worst = 0.0f64;
    for y in &rec.y {
        let (t2, t4) = (y[2], y[5]);
        worst = worst.max((k1 * t4.cos() - k2 * t2.cos() + k3 - (t2 - t4).cos()).abs());
    }
    let turns = (rec.y.last().unwrap()[2] - rec.y[0][2]) / std::f64::consts::TAU;
    eprintln!(
        "four-bar-stiff: Freudenstein {worst:e}, ledger {:e} J, {turns} turns, {} steps",
        s.max_energy_error, s.steps
    );
    assert!(worst <= 2e-5, "Freudenstein residual {worst:e}");
    assert!(turns > 5.0, "the crank turns fully: {turns} turns");
    assert!(s.max_energy_error <= 1e-6, "ledger gap {:e} J", s.max_energy_error);
    assert!(s.max_residual_position <= 1e-11 && s.max_residual_velocity <= 1e-11);
}

/// The structured Newton system solves `(c I - J) x = b` as the dense
/// system with the finite-difference Jacobian of the whole right-hand side
/// does, real and complex, on both stiff scenes at t = 0.19 s. Measured
/// relative differences: q and v 2.6e-6 .. 6.6e-6 at h = 1e-2 (the
/// differences' truncation error), 1e-9 .. 1e-7 at 1e-4; the work states
/// 1e-5 .. 7e-5. Leaving out the constraint forces' geometric stiffness
/// made the difference O(1) (and `snake-stiff` 37k rejected steps).
#[test]
fn the_structured_newton_system_agrees_with_the_dense_jacobian() {
    agree::<SnakeServo>("snake-stiff");
    agree::<ElasticFourBar>("four-bar-stiff");
}

fn agree<M: Model + Default>(name: &str) {
    let scene = scenes::get(name);
    let (mut sys, y0) = build::<M>(&scene, &[], KktMethod::Auto).unwrap();
    let t = 0.19;
    let settings = RunSettings { t_end: t, every: t, balance_limit: None, max_steps: None, ..scene.run_settings() };
    let y = simulate(&mut sys, &y0, &settings, &mut common::Recorder::default()).unwrap().final_state;
    let (n, nq) = (y.len(), sys.nq());
    let mut f = vec![0.0; n];
    sys.rhs(t, &y, &mut f).unwrap();
    let mut dense = DenseNewton::new(n);
    let mut kkt = KktNewton::new(&sys);
    NewtonSystem::<Dynamics<M>>::jacobian(&mut dense, &mut sys, t, &y, &f).unwrap();
    NewtonSystem::<Dynamics<M>>::jacobian(&mut kkt, &mut sys, t, &y, &f).unwrap();
    let b: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
    let rel = |x: &[f64], z: &[f64], r: std::ops::Range<usize>| {
        let num: f64 = r.clone().map(|i| (x[i] - z[i]).powi(2)).sum();
        let den: f64 = r.map(|i| x[i].powi(2)).sum();
        (num / den).sqrt()
    };
    for h in [1e-2, 1e-4] {
        let (real, complex) = (MU_REAL / h, c64::new(MU_COMPLEX.0 / h, MU_COMPLEX.1 / h));
        assert!(NewtonSystem::<Dynamics<M>>::factor(&mut dense, real, complex));
        assert!(NewtonSystem::<Dynamics<M>>::factor(&mut kkt, real, complex));
        let (mut x, mut z) = (b.clone(), b.clone());
        NewtonSystem::<Dynamics<M>>::solve_real(&mut dense, &mut x);
        NewtonSystem::<Dynamics<M>>::solve_real(&mut kkt, &mut z);
        let (dq, dv, dw) = (rel(&x, &z, 0..nq), rel(&x, &z, nq..2 * nq), rel(&x, &z, 2 * nq..n));
        let bc: Vec<c64> = b.iter().map(|&v| c64::new(v, 0.5 * v)).collect();
        let (mut xc, mut zc) = (bc.clone(), bc);
        NewtonSystem::<Dynamics<M>>::solve_complex(&mut dense, &mut xc);
        NewtonSystem::<Dynamics<M>>::solve_complex(&mut kkt, &mut zc);
        let num: f64 = (0..2 * nq).map(|i| (xc[i] - zc[i]).norm().powi(2)).sum();
        let den: f64 = (0..2 * nq).map(|i| xc[i].norm().powi(2)).sum();
        let dc = (num / den).sqrt();
        eprintln!("{name} h = {h:e}: q {dq:e}, v {dv:e}, W {dw:e}, complex {dc:e}");
        assert!(dq <= 1e-4 && dv <= 1e-4 && dc <= 1e-4, "{name} h = {h:e}: q {dq:e}, v {dv:e}, complex {dc:e}");
        assert!(dw <= 1e-3, "{name} h = {h:e}: work states {dw:e}");
    }
}
