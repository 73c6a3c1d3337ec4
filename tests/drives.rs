//! Drives (prescribed hinge angles, a rheonomic constraint): the
//! prescribed-angle EzyRoller reproduces the torque-driven `drive` scene
//! when its angle is the torque-driven run's recorded hinge angle, and the
//! drive's torque (its multiplier) reproduces the motor's torque.

use crate::common;

use std::f64::consts::PI;

use common::Recorder;
use common::build;
use ezy_core::effects::{Spline, SplineData, Waveform};
use ezy_core::kkt::KktMethod;
use ezy_core::{RunSettings, simulate};

use ezy_models::{EzyRoller, EzyRollerDriven, scenes};
use ezy_scene::{DriveSpec, InitValue};

const T_END: f64 = 10.0;
const EVERY: f64 = 0.01;

fn settings() -> RunSettings {
    common::dop853(T_END, EVERY, 1e-12)
}

#[test]
fn prescribing_the_recorded_angle_reproduces_the_torque_driven_run() {
    // the torque-driven drive scene, recorded every 10 ms
    let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &[], KktMethod::Auto).unwrap();
    let mut torque_run = Recorder::default();
    simulate(&mut sys, &y0, &settings(), &mut torque_run).unwrap();
    let theta: Vec<f64> = torque_run.y.iter().map(|y| y[2] - y[5]).collect();
    let rate = |y: &[f64]| y[8] - y[11];
    let spline = Spline::new(SplineData {
        t: torque_run.t.clone(),
        value: theta,
        slope_start: Some(rate(&torque_run.y[0])),
        slope_end: Some(rate(torque_run.y.last().unwrap())),
        extrapolate: Default::default(),
    });

    // the same vehicle with that angle prescribed, from the same state
    let mut scene = scenes::get("drive-prescribed");
    scene.t_end = T_END;
    scene.initial.q = ["x1", "y1", "phi1"].iter().map(|n| (n.to_string(), InitValue::Num(0.0))).collect();
    scene.initial.qd = vec![("x1".into(), InitValue::Num(0.0))];
    scene.drives = vec![("D".into(), DriveSpec { angle: Waveform::Spline(spline) })];
    let (mut driven, y0d) = build::<EzyRollerDriven>(&scene, &[], KktMethod::Auto).unwrap();
    for k in 0..12 {
        assert!((y0d[k] - y0[k]).abs() <= 1e-12, "initial state {k}: {} vs {}", y0d[k], y0[k]);
    }
    let mut angle_run = Recorder::default();
    let s = simulate(&mut driven, &y0d, &settings(), &mut angle_run).unwrap();
    assert!(s.max_residual_position <= 1e-12 && s.max_residual_velocity <= 1e-12, "{s:?}");

    // trajectories agree to the spline's accuracy
    let mut worst = 0.0f64;
    for (a, b) in torque_run.y.iter().zip(&angle_run.y) {
        for k in 0..12 {
            worst = worst.max((a[k] - b[k]).abs());
        }
    }
    // measured 4.5e-9: the spline error, h^4 times the fourth derivative, h = 10 ms
    assert!(worst <= 5e-8, "largest difference of a coordinate or velocity over {T_END} s: {worst:e}");

    // the drive's torque -lambda_D is the motor's torque 2 cos(pi t), away
    // from the ends of the table (within two knots the spline's end
    // conditions dominate)
    let row = driven.info.drives[0].row;
    let mut dy = vec![0.0; driven.ny()];
    let mut torque_error = 0.0f64;
    for (t, y) in angle_run.t.iter().zip(&angle_run.y) {
        if *t < 2.0 * EVERY || *t > T_END - 2.0 * EVERY {
            continue;
        }
        let mut state = y[..12].to_vec();
        state.push(0.0);
        driven.rhs(*t, &state, &mut dy).unwrap();
        let tau = -driven.lambda()[row];
        torque_error = torque_error.max((tau - 2.0 * (PI * t).cos()).abs());
    }
    // measured 1.7e-4 N m of 2 N m: the spline second derivative, O(h^2)
    assert!(torque_error <= 1e-3, "drive torque against the motor's: {torque_error:e} N m");
    // the drive's work equals the motor's (both are the work on the hinge)
    // (measured 0.72860816717 J against 0.72860816180 J)
    let (w_motor, w_drive) = (torque_run.y.last().unwrap()[12], angle_run.y.last().unwrap()[12]);
    assert!((w_motor - w_drive).abs() <= 1e-7, "W_motor {w_motor} vs W_D {w_drive}");
}
