//! Skates with friction on a user's own model, as for the built-ins: the
//! Roller Racer with its handlebar held coasts on a circle, which needs a
//! centripetal force from its two axles (skates A and C). With friction
//! no force reaches, the user's program runs it exactly as with ideal
//! skates; on a floor that holds less than the turn needs, the axles slide
//! from the start, the switches are written to `events.csv`, and the
//! friction's work closes the energy balance, with RADAU5 and the reduced
//! formulation as with RK4 on the DAE.

use crate::common;

const TURN: &str = r#"name = "turn-friction"
description = "Roller Racer with the handlebar held at 0.3 rad, its axles on a floor with friction"
model = "roller_racer"
t_end = 2.0

[initial]
q = { x1 = 0.0, y1 = 0.0, phi1 = 0.0 }
qd = { x1 = 1.0 }

[integrator]
method = "rk4"
dt = 1e-3

[output]
every = 0.01
include = ["energy", "effects"]

[drives.steer]
angle = { constant = 0.3 }

[effects.slip_A]
kind = "skate-friction"
skate = "A"
mu = MU
share = 0.5

[effects.slip_C]
kind = "skate-friction"
skate = "C"
mu = MU
share = 0.5
"#;

/// Runs the turn with friction coefficient `mu` (or without the friction
/// tables) and the command-line flags `flags`; returns the program's
/// report, the trajectory's rows and `events.csv`.
fn run(tag: &str, mu: Option<f64>, flags: &[&str]) -> (String, Vec<Vec<String>>, String) {
    let out = common::out_dir(&format!("friction-{tag}"));
    std::fs::create_dir_all(&out).unwrap();
    let text = match mu {
        Some(mu) => TURN.replace("MU", &mu.to_string()),
        None => TURN[..TURN.find("[effects.slip_A]").unwrap()].to_string(),
    };
    let scene = out.join("turn-friction.toml");
    std::fs::write(&scene, text).unwrap();
    let o = common::program()
        .args(["run", scene.to_str().unwrap(), "--no-figures", "--out"])
        .arg(out.join("result"))
        .args(flags)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success(), "{said}{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("result/trajectory.csv")).unwrap();
    let rows = csv.lines().map(|l| l.split(',').map(str::to_string).collect()).collect();
    let events = std::fs::read_to_string(out.join("result/events.csv")).unwrap_or_default();
    (said, rows, events)
}

#[test]
fn friction_on_the_users_own_skates() {
    let (_, ideal, _) = run("ideal", None, &[]);
    // friction no force reaches: the coordinates and velocities (the
    // first 1 + 2 nq = 13 columns) to the last digit, no switch
    let (_, held, events) = run("held", Some(1e9), &[]);
    assert_eq!(ideal.len(), held.len());
    for (a, b) in ideal.iter().zip(&held) {
        assert_eq!(a[..13], b[..13]);
    }
    assert_eq!(events.lines().count(), 1, "{events}");
    // a floor that holds less than the turn needs (mu N = 1.6 N an axle)
    let (said, rows, events) = run("slides", Some(0.01), &[]);
    let header = &rows[0];
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no {name}: {header:?}"));
    assert!(events.lines().skip(1).any(|l| l.contains(",slip_A,")), "{events}");
    let last = rows.last().unwrap();
    let w: f64 = last[col("W_slip_A")].parse().unwrap();
    assert!(w < -1e-3, "the friction at A took {w} J");
    let sliding: f64 = rows[1][col("sliding_A")].parse().unwrap();
    assert_eq!(sliding, 1.0);
    // the ledger closes through the switches: the program's own report
    let line = said.lines().find(|l| l.contains("max |T - T0 - W|")).unwrap();
    let gap: f64 = line.split('=').nth(1).unwrap().trim().trim_end_matches(" J").parse().unwrap();
    assert!(gap < 1e-9, "{line}");
    // RADAU5 (its Newton matrix with the released rows) and the reduced
    // formulation (the DAE while an axle slides): the same switches, to
    // the accuracy of the runs (RK4 at 1 ms and RADAU5 at its default
    // tolerance 1e-6 locate them within 1e-4 s of each other; a switch
    // missed or a step late is a whole step off), the same final
    // position within 1e-3 m of a 2 m run
    let times = |events: &str| -> Vec<(String, f64)> {
        let row = |l: &str| {
            let f: Vec<&str> = l.split(',').collect();
            (f[1].to_string(), f[0].parse::<f64>().unwrap())
        };
        events.lines().skip(1).map(row).collect()
    };
    let x1 = |rows: &[Vec<String>]| -> f64 { rows.last().unwrap()[col("x1")].parse().unwrap() };
    for flags in [&["--integrator", "radau5"][..], &["--formulation", "reduced"]] {
        let (said_other, rows_other, events_other) = run(&format!("slides{}", flags[1]), Some(0.01), flags);
        let (a, b) = (times(&events), times(&events_other));
        assert_eq!(a.len(), b.len(), "{flags:?}:\n{events}\n{events_other}");
        for ((na, ta), (nb, tb)) in a.iter().zip(&b) {
            assert!(na == nb && (ta - tb).abs() < 1e-4, "{flags:?}: {na} at {ta}, {nb} at {tb}");
        }
        assert!((x1(&rows) - x1(&rows_other)).abs() < 1e-3, "{flags:?}: x1 {} {}", x1(&rows), x1(&rows_other));
        // the ledger: RADAU5 at rtol 1e-6 closes it to its tolerance's level
        let line = said_other.lines().find(|l| l.contains("max |T - T0 - W|")).unwrap();
        let gap: f64 = line.split('=').nth(1).unwrap().trim().trim_end_matches(" J").parse().unwrap();
        assert!(gap < 1e-5, "{flags:?}: {line}");
    }
}
