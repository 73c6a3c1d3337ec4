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

/// The same turn pushed along the main platform (2 N, body axes) until
/// the rear axle's centre has gone 1 m, where the user's scene switches
/// the push off: `events.csv` has the switch, and the push's value column
/// reads 2 N before it and 0 after, its work `W_push` holding still.
#[test]
fn the_users_program_switches_an_effect_off_at_its_models_event() {
    let scene_text = TURN.replace(
        "[events.turned]\nwhen = \"phi1\"\ncrosses = -1.0\naction = \"stop\"\n",
        "[output]\nevery = 0.05\ninclude = [\"energy\", \"effects\"]\n\n[effects.push]\nkind = \"force\"\nat = \"main\"\nfx = { constant = 2.0 }\nframe = \"body\"\n\n[events.coast]\nwhen = \"x1\"\ncrosses = 1.0\naction = \"switch\"\nswitch_off = [\"push\"]\n",
    );
    assert!(scene_text.contains("switch_off"), "the scene's text changed: {TURN}");
    let out = common::out_dir("switch");
    std::fs::create_dir_all(&out).unwrap();
    let scene = out.join("turn-switch.toml");
    std::fs::write(&scene, &scene_text).unwrap();
    let o = common::program()
        .args(["run", scene.to_str().unwrap(), "--no-figures", "--out"])
        .arg(out.join("result"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    let events = std::fs::read_to_string(out.join("result/events.csv")).unwrap();
    let coast: Vec<&str> =
        events.lines().find(|l| l.contains(",coast,")).expect("the switch is recorded").split(',').collect();
    assert_eq!(coast[2], "rising");
    let t_switch: f64 = coast[0].parse().unwrap();
    let csv = std::fs::read_to_string(out.join("result/trajectory.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col =
        |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}: {header:?}"));
    let (t, f, w) = (col("t"), col("F_push"), col("W_push"));
    let rows: Vec<Vec<f64>> = csv.lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    let w_at_switch = rows.iter().find(|r| r[t] > t_switch).expect("rows after the switch")[w];
    assert!(w_at_switch > 0.0);
    for r in &rows {
        if r[t] < t_switch {
            assert_eq!(r[f], 2.0, "t = {}", r[t]);
        } else if r[t] > t_switch {
            assert_eq!((r[f], r[w]), (0.0, w_at_switch), "t = {}", r[t]);
        }
    }
}
