//! The trailer and snake models end to end: the trailers' off-tracking
//! against its closed form, the snake's gait moving it head first, and both
//! energy ledgers.

use ezy::run::build;
use ezy_core::kkt::KktMethod;
use ezy_core::{Model, RunSettings, simulate};
use ezy_models::{Snake, Trailer, scenes};

fn run_scene<M: Model + Default>(name: &str) -> (ezy_core::Dynamics<M>, ezy_core::Summary, Vec<f64>) {
    let scene = scenes::get(name);
    let (mut sys, y0) = build::<M>(&scene, &[], KktMethod::Auto).unwrap();
    let settings = RunSettings {
        dt: scene.integrator.dt,
        t_end: scene.t_end,
        every: scene.t_end,
        projection: scene.integrator.projection,
        method: scene.integrator.method,
        rtol: scene.integrator.rtol,
        atol: scene.integrator.atol,
        balance_limit: None,
    };
    let s = simulate(&mut sys, &y0, &settings, &mut Last).unwrap();
    (sys, s, y0)
}

struct Last;
impl<M: Model> ezy_core::Observer<M> for Last {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _: &ezy_core::Dynamics<M>, _: &ezy_core::Sample<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// After 300 s on the circle every body turns at the same rate and each
/// axle runs on the radius of the kinematic steady state: the tractor's
/// rear axle on `L / tan(delta)`, each trailer's axle on
/// `sqrt(r_hitch^2 - l^2)` with `r_hitch = sqrt(r_axle_ahead^2 + h^2)`.
/// Radius of curvature `|v_P| / phi_dot` from the generated point
/// velocities; the transient has decayed to below 1e-6 relative.
#[test]
fn trailers_settle_on_the_off_tracking_circles() {
    let (sys, s, _) = run_scene::<Trailer>("trailer");
    let m = &sys.model;
    let y = &s.final_state;
    let (q, qd) = (&y[..9], &y[9..18]);
    let info = m.info();
    let mut v = vec![0.0; 2 * info.points.len()];
    m.point_velocities(q, qd, &mut v);
    let speed = |name: &str| {
        let p = info.point_index(name).unwrap();
        v[2 * p].hypot(v[2 * p + 1])
    };
    let r0 = m.L / m.delta.tan();
    let r1 = (r0.hypot(m.h).powi(2) - m.l * m.l).sqrt();
    let r2 = (r1.hypot(m.h).powi(2) - m.l * m.l).sqrt();
    for (point, rate, want) in [("R", qd[2], r0), ("A1", qd[5], r1), ("A2", qd[8], r2)] {
        let r = speed(point) / rate;
        assert!((r - want).abs() <= 1e-6 * want, "{point}: radius {r} want {want}");
    }
    assert!((qd[2] - qd[5]).abs() <= 1e-9 && (qd[5] - qd[8]).abs() <= 1e-9, "rates {qd:?}");
    // the engine and the resistances each move ~1e5 J; the gap is relative to that flow
    let flow = y[18..].iter().fold(0.0f64, |a, w| a.max(w.abs()));
    assert!(s.max_energy_error <= 1e-10 * flow, "ledger {:e} against {flow:e} J", s.max_energy_error);
}

/// The serpenoid gait moves the snake head first (+x) by more than half a
/// metre in 40 s, and its ledger of nine work columns closes.
#[test]
fn the_snake_advances_head_first() {
    let (sys, s, y0) = run_scene::<Snake>("snake");
    let y = &s.final_state;
    assert!(y[6] - y0[6] > 0.5, "middle link moved from x = {} to {}", y0[6], y[6]);
    assert_eq!(sys.effects.len(), 13);
    assert!(s.max_energy_error <= 1e-8, "ledger {:e}", s.max_energy_error);
    assert!(s.max_residual_position <= 1e-12);
}
