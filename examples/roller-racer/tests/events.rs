//! Events in a user's own crate, as for the built-ins: the Roller Racer
//! with its handlebar held coasts on a circle (see `analyze.rs`), so its
//! heading turns at the constant rate `v_A kappa`, `kappa` the rear
//! axle's curvature from the geometry alone: the heading reaches -1 rad
//! at `t* = 1 / |v_A kappa|`. The user's program stops there and writes
//! the event.

use roller_racer::RollerRacer;

use crate::common;

const TURN: &str = r#"name = "turn-events"
description = "Roller Racer with the handlebar held at 0.3 rad, stopped when it has turned 1 rad"
model = "roller_racer"
t_end = 4.0

[initial]
q = { x1 = 0.0, y1 = 0.0, phi1 = 0.0 }
qd = { x1 = 1.0 }

[integrator]
method = "dop853"
rtol = 1e-12
atol = 1e-12

[drives.steer]
angle = { constant = 0.3 }

[events.turned]
when = "phi1"
crosses = -1.0
action = "stop"

[events.axle_north]
when = "A.vx"
crosses = 0.0
"#;

#[test]
fn the_users_program_stops_at_its_models_event() {
    let out = common::out_dir("events");
    std::fs::create_dir_all(&out).unwrap();
    let scene = out.join("turn-events.toml");
    std::fs::write(&scene, TURN).unwrap();
    let o = common::program()
        .args(["run", scene.to_str().unwrap(), "--no-figures", "--out"])
        .arg(out.join("result"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{said}{}", String::from_utf8_lossy(&o.stderr));
    assert!(said.contains("stopped by the event turned at t = "), "{said}");
    // the geometry's curvature: the heading's rate is v_A kappa, v_A = 1 m/s
    let m = RollerRacer::default();
    let phi2: f64 = -0.3;
    let (cx, cy) = (m.d1 - m.d2 * phi2.cos(), -m.d2 * phi2.sin());
    let kappa: f64 = 1.0 / (cy + cx * phi2.cos() / phi2.sin());
    let want = 1.0 / kappa.abs();
    let events = std::fs::read_to_string(out.join("result/events.csv")).unwrap();
    let rows: Vec<Vec<&str>> = events.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.last().unwrap()[1], "turned");
    let t: f64 = rows.last().unwrap()[0].parse().unwrap();
    assert!((t - want).abs() < 1e-9 * want, "t* = {t} against {want}");
    // no event before it: A's velocity turns from +x through the north at
    // phi1 = -pi/2, after the stop
    assert_eq!(rows.len(), 1, "{events}");
    // the stop's state is the trajectory's last row
    let csv = std::fs::read_to_string(out.join("result/trajectory.csv")).unwrap();
    let last: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    assert_eq!(last[0], rows[0][0]);
    assert_eq!(last[3], rows[0][5]);
}
