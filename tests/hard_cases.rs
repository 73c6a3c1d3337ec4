//! Hard cases that must stay numerically sound (issue 4, growing).

mod common;

use common::{Recorder, max_abs};
use ezy::run::setup;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Method, Model, ProjectionKind, RunSettings, simulate};
use ezy_models::{EzyRoller, scenes};

/// A massless steering fork (m2 = I2 = 0): `M` is singular but the KKT
/// matrix is regular. The automatic choice is the LU path, and
/// mass-weighted projection solves the KKT system instead of inverting `M`.
/// Measured with DOP853 at 1e-10 over 60 s: residuals 1.0e-12 m and
/// 1.8e-16 m/s, energy balance 7.5e-11 J (the tolerance's level).
#[test]
fn massless_fork_runs_on_the_lu_path() {
    let sets = [("m2".to_string(), 0.0), ("I2".to_string(), 0.0)];
    let (model, specs, y0) = setup::<EzyRoller>(&scenes::drive(), &sets).unwrap();
    let effects = specs.iter().map(|s| s.resolve(&EzyRoller::INFO).unwrap()).collect();
    let mut sys = Dynamics::new(model, effects, KktMethod::Auto);
    assert_eq!(sys.kkt_name(), "dense-lu");
    let settings = RunSettings {
        dt: 1e-4,
        t_end: 60.0,
        every: 0.1,
        projection: ProjectionKind::MassWeighted,
        method: Method::Dop853,
        rtol: 1e-10,
        atol: 1e-10,
        balance_limit: None,
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
