//! `roller-racer analyze`: a user's own model, in a user's scene file,
//! analysed as the built-ins are. With the handlebar held at a fixed angle
//! (a constant drive) the Roller Racer is a rigid vehicle on two axles and
//! turns steadily about the point where the axles' lines meet; its rear
//! axle's path has curvature `1 / R` with `R = Cy + Cx cos(phi2) /
//! sin(phi2)` in the main platform's frame (`C` the front axle, `phi2`
//! the front platform's heading, `phi1 = 0`). The library finds the same
//! motion for the model directly, without files.

use ezy::analysis::Stability;
use ezy::effects::Waveform;
use roller_racer::RollerRacer;

use crate::common;

/// The steady turn's curvature [1/m] of the rear axle at steering angle
/// `phi1 - phi2 = delta` [rad], from the geometry alone.
fn curvature(m: &RollerRacer, delta: f64) -> f64 {
    let phi2 = -delta;
    let (cx, cy) = (m.d1 - m.d2 * phi2.cos(), -m.d2 * phi2.sin());
    1.0 / (cy + cx * phi2.cos() / phi2.sin())
}

const TURN: &str = r#"name = "turn"
description = "Roller Racer with the handlebar held at 0.3 rad, coasting"
model = "roller_racer"
t_end = 2.0

[initial]
q = { x1 = 0.0, y1 = 0.0, phi1 = 0.0 }
qd = { x1 = 1.0 }

[integrator]
method = "dop853"

[drives.steer]
angle = { constant = 0.3 }
"#;

#[test]
fn the_users_model_turns_steadily_with_the_handlebar_held() {
    let out = common::out_dir("analyze");
    std::fs::create_dir_all(&out).unwrap();
    let scene = out.join("turn.toml");
    std::fs::write(&scene, TURN).unwrap();
    let o = common::program()
        .args(["analyze", scene.to_str().unwrap(), "--energy", "20", "--no-figures", "--out"])
        .arg(out.join("result"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{said}{}", String::from_utf8_lossy(&o.stderr));
    assert!(said.contains("symmetry vx, vy, omega"), "{said}");
    let text = std::fs::read_to_string(out.join("result/equilibria.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| row[head.iter().position(|h| *h == name).unwrap()].parse::<f64>().unwrap();
    let want = curvature(&RollerRacer::default(), 0.3);
    assert!((col("curvature") - want).abs() < 1e-9 * want.abs(), "{} against {want}", col("curvature"));
    assert!((col("theta_J") - 0.3).abs() < 1e-12);
    for k in 1..=head.iter().filter(|h| h.ends_with("_re")).count() {
        assert!(head.contains(&format!("lambda{k}_im").as_str()));
    }

    // the same through the library, on the model itself
    let problem = ezy::Problem::new(RollerRacer::default())
        .drive("steer", Waveform::Constant(0.3))
        .unwrap()
        .q("x1", 0.0)
        .unwrap()
        .q("y1", 0.0)
        .unwrap()
        .q("phi1", 0.0)
        .unwrap()
        .qd("x1", 1.0)
        .unwrap();
    let (mut an, x0) = problem.analysis().unwrap();
    let symmetry = an.symmetry(0.0, &x0).unwrap();
    let e = an.dynamics().kinetic_energy(&x0[6..]);
    let s = an.steady_motion(0.0, &x0, symmetry, Some(e)).unwrap();
    assert!((s.curvature() - want).abs() < 1e-9 * want.abs(), "{} against {want}", s.curvature());
    assert_ne!(s.stability, Stability::Unstable, "{:?}", s.eigenvalues);
}
