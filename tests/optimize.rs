//! Design optimization (`ezy_core::design::optimize`): optima known in
//! closed form reached to 1e-6 in the parameter (a gait's, a run's, and
//! one held by a constraint), on a model and laws of the user's own; the
//! EzyRoller's speed-optimal motor frequency within the budget of
//! 40 orbits; bad requests refused before any work.

use std::f64::consts::{PI, TAU};

use ezy::models::{EzyRoller, scenes};
use ezy_core::design::Design;
use ezy_core::design::optimize::{Constraint, GaitQuantity, Goal, OptimizeSettings, Quantity, Sense, optimize};
use ezy_core::effects::{ForceLaw, Periodicity};
use ezy_core::{Method, Problem};

ezy_core::model! {
    /// A cart on a straight ground rail along x, its heading fixed at 0.
    pub struct Cart {
        /// Mass [kg]
        param m = 2.0;
        /// Inertia [kg m^2]
        param I = 0.3;
        body cart(x, y, phi) { mass: m, inertia: I }
        point P on cart at (0, 0);
        slider R: P on ground(0, 0) along (1, 0) angle 0.0;
    }
}

/// A spring to the origin and a damper on the cart: `-k x - c xd` [N].
#[derive(Debug, Clone)]
pub(crate) struct SpringDamper {
    /// Stiffness [N/m].
    pub(crate) k: f64,
    /// Damping [N s/m] (negative: a source of energy).
    pub(crate) c: f64,
}

impl ForceLaw for SpringDamper {
    fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let fx = -self.k * q[0] - self.c * qd[0];
        f[0] += fx;
        (fx * qd[0], fx)
    }
    fn coords(&self) -> Vec<usize> {
        vec![0]
    }
    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }
}

/// A push `f0 sin(omega t)` [N] along the rail: the actuator.
#[derive(Debug, Clone)]
struct Push {
    f0: f64,
    omega: f64,
}

impl ForceLaw for Push {
    fn apply(&self, t: f64, _q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let fx = self.f0 * (self.omega * t).sin();
        f[0] += fx;
        (fx * qd[0], fx)
    }
    fn coords(&self) -> Vec<usize> {
        vec![0]
    }
    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Period(TAU / self.omega))
    }
}

pub(crate) const M: f64 = 2.0;
pub(crate) const K: f64 = 8.0;

/// The cart with spring `k`, damping `c` and, where given, a push of
/// amplitude 1 N at `omega` [rad/s]; from `x0` at rest, to `t_end`, by
/// DOP853 at 1e-12.
pub(crate) fn cart(
    k: f64,
    c: f64,
    omega: Option<f64>,
    x0: f64,
    t_end: f64,
) -> Result<Problem<Cart>, ezy_core::SimError> {
    let mut p = Problem::new(Cart::default()).law("spring", SpringDamper { k, c })?;
    if let Some(omega) = omega {
        p = p.law("push", Push { f0: 1.0, omega })?;
    }
    Ok(p.q("x", x0)?
        .q("y", 0.0)?
        .q("phi", 0.0)?
        .qd("x", 0.0)?
        .t_end(t_end)
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12))
}

/// The cart with damping 0.5 N s/m pushed at a frequency `omega` from
/// 1.2 rad/s within [0.5, 5], and the goal of the largest mean power.
fn resonance() -> (f64, Design<Cart>, Goal) {
    let c = 0.5;
    let design =
        Design::new(vec!["omega".into()], vec![1.2], vec![(0.5, 5.0)], move |v| cart(K, c, Some(v[0]), 0.0, 20.0))
            .unwrap();
    let goal = Goal { objective: Quantity::Gait(GaitQuantity::MeanPower), sense: Sense::Maximize, constraints: vec![] };
    (c, design, goal)
}

/// The resonance: a mass on a spring and damper pushed by `F0 sin(w t)`
/// takes the mean power `F0^2 c w^2 / (2 ((k - m w^2)^2 + c^2 w^2))`,
/// largest at `w = sqrt(k / m)` whatever the damping (the transfer
/// function's). Maximizing the gait's mean power over the push's
/// frequency from 1.2 rad/s finds 2 rad/s to 1e-6; the value agrees with
/// the formula to 1e-8.
#[test]
fn a_gait_optimum_known_in_closed_form_is_reached() {
    let (c, design, goal) = resonance();
    let settings = OptimizeSettings { grid: 5, ..OptimizeSettings::default() };
    let o = optimize(&design, &goal, &settings, None, &mut |_| {}).unwrap();
    let w = (K / M).sqrt();
    let power = c * w * w / (2.0 * ((K - M * w * w).powi(2) + (c * w).powi(2)));
    eprintln!(
        "omega {} in {} evaluations, {} orbits ({}), |g| {:.1e}",
        o.values[0],
        o.history.len(),
        o.orbits,
        o.termination,
        o.projected_gradient_norm
    );
    assert!(o.converged, "{}", o.termination);
    assert!((o.values[0] - w).abs() < 1e-6, "omega {} against {w}", o.values[0]);
    assert!((o.objective - power).abs() < 1e-8 * power, "power {} against {power}", o.objective);
    assert!(o.orbits <= 30, "{} orbits", o.orbits);
    // the grid around the optimum: 5 points, none above the optimum
    assert_eq!(o.grid.len(), 5);
    assert!(o.grid.iter().all(|e| e.objective <= o.objective * (1.0 + 1e-9)), "{:?}", o.grid);
}

/// A bound that holds the optimum: the same resonance with the period
/// kept at or above `2 pi / 1.5` s (the push at most 1.5 rad/s, below
/// resonance, where the power still grows) ends on the constraint, at 1.5
/// rad/s to 1e-6.
#[test]
fn a_constraint_holds_the_optimum_on_its_bound() {
    let design =
        Design::new(vec!["omega".into()], vec![1.0], vec![(0.5, 5.0)], move |v| cart(K, 0.5, Some(v[0]), 0.0, 20.0))
            .unwrap();
    let constraint = Constraint { quantity: Quantity::Gait(GaitQuantity::Period), upper: false, bound: TAU / 1.5 };
    let goal = Goal {
        objective: Quantity::Gait(GaitQuantity::MeanPower),
        sense: Sense::Maximize,
        constraints: vec![constraint],
    };
    let o = optimize(&design, &goal, &OptimizeSettings::default(), None, &mut |_| {}).unwrap();
    eprintln!("omega {} in {} evaluations ({})", o.values[0], o.history.len(), o.termination);
    assert!(o.converged, "{}", o.termination);
    assert!((o.values[0] - 1.5).abs() < 1e-6, "omega {} against 1.5", o.values[0]);
    assert!(o.constraints[0] >= TAU / 1.5 * (1.0 - 1e-9), "the constraint is violated: {}", o.constraints[0]);
}

/// A run's objective of the user's own code: the cart released from
/// `x = 1` on an undamped spring is at `cos(sqrt(k / m) t)`; the smallest
/// `x(1 s)` over `k` in [1, 40] N/m is at `sqrt(k / m) = pi`,
/// `k = pi^2 m`. From k = 8 it is found to 1e-6, `x = -1` to 1e-10.
#[test]
fn a_run_optimum_of_a_users_own_objective_is_reached() {
    let design =
        Design::new(vec!["k".into()], vec![8.0], vec![(1.0, 40.0)], |v| cart(v[0], 0.0, None, 1.0, 1.0)).unwrap();
    let final_x = Quantity::run("final x", |s| {
        let i = s.names.iter().position(|n| n == "x").ok_or("no x")?;
        let (last, n2) = (s.x.len() - 1, s.names.len());
        let grad = (0..s.parameters.len()).map(|j| s.s[last][j * n2 + i]).collect();
        Ok((s.x[last][i], grad))
    });
    let goal = Goal { objective: final_x, sense: Sense::Minimize, constraints: vec![] };
    let o = optimize(&design, &goal, &OptimizeSettings::default(), None, &mut |_| {}).unwrap();
    let k = PI * PI * M;
    eprintln!("k {} in {} runs ({}), x {}", o.values[0], o.runs, o.termination, o.objective);
    assert!(o.converged, "{}", o.termination);
    assert!((o.values[0] - k).abs() < 1e-6 * k, "k {} against {k}", o.values[0]);
    assert!((o.objective + 1.0).abs() < 1e-10, "x(1) = {}", o.objective);
    assert_eq!(o.orbits, 0);
}

/// The EzyRoller with rolling resistance: its speed-optimal motor
/// frequency from the scene's 1.5 rad/s within the budget of 40
/// orbits; at the optimum the gradient vanishes and the speed 0.5 % of the
/// span to either side is lower.
#[test]
fn the_ezyrollers_fastest_motor_frequency_takes_few_orbits() {
    let scene = scenes::get("drive-rolling-resistance");
    let over = vec![("motor.omega".to_string(), 0.5, 8.0)];
    let design = scene.design(&EzyRoller::default(), &[], &over).unwrap();
    let goal =
        Goal { objective: Quantity::gait("gait.mean_speed").unwrap(), sense: Sense::Maximize, constraints: vec![] };
    let o = optimize(&design, &goal, &OptimizeSettings { grid: 3, ..OptimizeSettings::default() }, None, &mut |_| {})
        .unwrap();
    eprintln!(
        "omega {} speed {} in {} orbits, {} runs ({}); |g| {:.1e}; grid {:?}",
        o.values[0],
        o.objective,
        o.orbits - o.grid.len(),
        o.runs,
        o.termination,
        o.projected_gradient_norm,
        o.grid.iter().map(|e| (e.values[0], e.objective)).collect::<Vec<_>>()
    );
    assert!(o.converged, "{}", o.termination);
    assert!(o.orbits - o.grid.len() <= 40, "{} orbits", o.orbits);
    assert!(o.gradient[0].abs() < 1e-6, "dv/domega {}", o.gradient[0]);
    assert!(o.grid.iter().all(|e| e.objective <= o.objective), "{:?}", o.grid);
}

/// A constraint no point satisfies (a period of at least 1000 s where the
/// push's is at most 4 pi s): the search ends not converged, saying so,
/// with the point of least violation; and a push too slow for the scene's
/// run (a period beyond its 20 s) is a failed evaluation, not a search
/// that runs for ever.
#[test]
fn an_infeasible_constraint_is_said_not_converged() {
    let (_, design, goal) = resonance();
    let never = Constraint { quantity: Quantity::Gait(GaitQuantity::Period), upper: false, bound: 1000.0 };
    let goal = Goal { constraints: vec![never], ..goal };
    let o = optimize(&design, &goal, &OptimizeSettings::default(), None, &mut |_| {}).unwrap();
    assert!(
        !o.converged && o.termination.contains("no point found satisfies gait.period >= 1000"),
        "{}",
        o.termination
    );
    assert!((o.values[0] - 0.5).abs() < 1e-9, "the least violation is at the slowest push: {}", o.values[0]);
    // the first-order conditions do not hold at an infeasible point
    assert!(!o.kkt.holds, "{:?}", o.kkt);
    let slow = Design::new(vec!["omega".into()], vec![1.2], vec![(1e-3, 5.0)], |v| cart(K, 0.5, Some(v[0]), 0.0, 20.0))
        .unwrap();
    let (_, _, goal) = resonance();
    let o = optimize(&slow, &goal, &OptimizeSettings::default(), None, &mut |_| {}).unwrap();
    assert!(o.converged && (o.values[0] - 2.0).abs() < 1e-6, "{} at {:?}", o.termination, o.values);
    for e in o.history.iter().filter_map(|e| e.failure.as_deref()) {
        assert!(e.contains("longer than the scene's run"), "{e}");
    }
}

static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// A stop (what Ctrl-C asks) after the fourth evaluation ends the
/// optimization within the next search, with the best point so far: not
/// converged, said stopped, no grid.
#[test]
fn a_stop_ends_with_the_best_point_so_far() {
    use std::sync::atomic::Ordering;
    let (_, design, goal) = resonance();
    let settings = OptimizeSettings { grid: 5, ..OptimizeSettings::default() };
    let mut seen = 0;
    let o = optimize(&design, &goal, &settings, Some(|| STOP.load(Ordering::Relaxed)), &mut |_| {
        seen += 1;
        if seen == 4 {
            STOP.store(true, Ordering::Relaxed);
        }
    })
    .unwrap();
    STOP.store(false, Ordering::Relaxed);
    assert!(o.stopped && !o.converged, "{}", o.termination);
    assert_eq!(o.history.len(), 4, "no evaluation after the stop");
    assert!(o.grid.is_empty());
    let best = o.history.iter().map(|e| e.objective).fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(o.objective, best);
}

/// Bad requests end before any run, naming the culprit: a gait's quantity
/// of a scene that is not driven periodically, a budget out of range, a
/// bound that is not finite.
#[test]
fn bad_requests_are_refused_naming_the_culprit() {
    let design =
        Design::new(vec!["k".into()], vec![8.0], vec![(1.0, 40.0)], |v| cart(v[0], 0.0, None, 1.0, 1.0)).unwrap();
    let gait = Goal { objective: Quantity::Gait(GaitQuantity::MeanSpeed), sense: Sense::Maximize, constraints: vec![] };
    let e = optimize(&design, &gait, &OptimizeSettings::default(), None, &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("driven periodically"), "{e}");
    let settings = OptimizeSettings { max_evaluations: 1_000_000, ..OptimizeSettings::default() };
    let e = optimize(&design, &gait, &settings, None, &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("1000000 evaluations"), "{e}");
    let nan = Constraint { quantity: Quantity::Gait(GaitQuantity::Period), upper: true, bound: f64::NAN };
    let bad = Goal { constraints: vec![nan], ..gait.clone() };
    let e = optimize(&design, &bad, &OptimizeSettings::default(), None, &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("gait.period <= NaN") && e.contains("finite"), "{e}");
    let wide =
        Design::new(vec!["k".into()], vec![8.0], vec![(0.0, 1e300)], |v| cart(v[0], 0.0, None, 1.0, 1.0)).unwrap();
    let e = optimize(&wide, &gait, &OptimizeSettings::default(), None, &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("`k=0:1e300`") && e.contains("span"), "{e}");
    let e = Quantity::gait("gait.speed").unwrap_err().to_string();
    assert!(e.contains("gait.speed") && e.contains("mean_speed"), "{e}");
}

/// `ezy optimize`: `optimum.csv` with the library's optimum (the same
/// numbers), `history.csv` with every evaluation and its gradient,
/// `grid.csv` and both figures; a run's metric with a constraint on
/// another; bad requests refused before anything is written.
#[test]
fn the_command_writes_the_optimum_history_grid_and_figures() {
    let dir = std::env::temp_dir().join(format!("ezy-optimize-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let ezy = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().unwrap();
    let out = dir.to_str().unwrap();
    let args = ["optimize", "drive-rolling-resistance", "--maximize", "gait.mean_speed"];
    let o = ezy(&[&args[..], &["--over", "motor.omega=0.5:8", "--grid", "3", "--out", out]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let optimum = std::fs::read_to_string(dir.join("optimum.csv")).unwrap();
    let mut lines = optimum.lines();
    assert_eq!(lines.next(), Some("motor.omega,gait.mean_speed"));
    let row: Vec<f64> = lines.next().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    let scene = scenes::get("drive-rolling-resistance");
    let design = scene.design(&EzyRoller::default(), &[], &[("motor.omega".into(), 0.5, 8.0)]).unwrap();
    let goal =
        Goal { objective: Quantity::gait("gait.mean_speed").unwrap(), sense: Sense::Maximize, constraints: vec![] };
    let lib = optimize(&design, &goal, &OptimizeSettings::default(), None, &mut |_| {}).unwrap();
    assert_eq!(row, [lib.values[0], lib.objective], "the command's optimum is the library's");
    let history = std::fs::read_to_string(dir.join("history.csv")).unwrap();
    assert!(history.starts_with("evaluation,motor.omega,gait.mean_speed,dgait.mean_speed/dmotor.omega,failure\n"));
    assert_eq!(history.lines().count(), 1 + lib.history.len());
    assert_eq!(std::fs::read_to_string(dir.join("grid.csv")).unwrap().lines().count(), 1 + 3);
    assert!(dir.join("optimize.png").exists() && dir.join("optimize_grid.png").exists());
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(printed.contains("gait.mean_speed = 0.469") && printed.contains("stable"), "{printed}");
    // a run's metric, bounded by a constraint on another: the drive scene
    // over 2 s, the fork's final heading rate at most 0.1 rad/s
    let o = ezy(&[
        "optimize",
        "drive",
        "--maximize",
        "final(x1)",
        "--subject-to",
        "final(phi1d) <= 0.1",
        "--over",
        "M0=0.5:4",
        "--t-end",
        "2",
        "--grid",
        "0",
        "--no-figures",
        "--out",
        out,
    ]);
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}{printed}", String::from_utf8_lossy(&o.stderr));
    assert!(printed.contains("constraint final(phi1d) <= 0.1"), "{printed}");
    assert!(!dir.join("grid.csv").exists(), "the last command's grid is retired");
    // refused before any work: the directory keeps what it had
    for (bad, culprit) in [
        (&["--maximize", "gait.speed", "--over", "motor.omega=0.5:8"][..], "gait.speed"),
        (&["--maximize", "final(T)", "--over", "motor.omega=0.5:8"][..], "`T`"),
        (&["--maximize", "gait.mean_speed", "--over", "motor.omega=5:8"][..], "outside the bounds"),
        (
            &["--maximize", "gait.mean_speed", "--over", "motor.omega=0.5:8", "--subject-to", "gait.mean_power < 1"][..],
            "<=",
        ),
        (&["--maximize", "gait.mean_speed", "--over", "motor.omega=0.5:8", "--max-evaluations", "1"][..], "between 2"),
    ] {
        let o = ezy(&[&["optimize", "drive-rolling-resistance"][..], bad, &["--out", out]].concat());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(culprit), "{bad:?}: {e}");
    }
    assert!(dir.join("optimum.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A quantity of the embedding program's own (`App::quantity`), named on
/// the command line as a built-in one: the final `x1` computed by the
/// caller gives the same search, to the bit, as the metric `final(x1)`.
#[test]
fn a_quantity_of_the_callers_own_is_named_as_a_built_in_one() {
    let app = ezy::App::new().quantity("my_final_x1", |s| {
        let (last, n2) = (s.x.len() - 1, s.names.len());
        let i = s.names.iter().position(|n| n == "x1").ok_or("no x1")?;
        Ok((s.x[last][i], (0..s.parameters.len()).map(|j| s.s[last][j * n2 + i]).collect()))
    });
    let dir = std::env::temp_dir().join(format!("ezy-optimize-own-{}", std::process::id()));
    let optimum = |q: &str| {
        let args = ["optimize", "drive", "--maximize", q, "--over", "motor.omega=1:6", "--t-end", "2", "--grid", "0"];
        let mut printed = Vec::new();
        let out = ["--no-figures", "--out", dir.to_str().unwrap()];
        let argv = std::iter::once("ezy").chain(args).chain(out).map(String::from);
        app.run_cli(argv, &mut printed).unwrap();
        std::fs::read_to_string(dir.join("optimum.csv")).unwrap()
    };
    let own = optimum("my_final_x1");
    let built_in = optimum("final(x1)");
    assert!(own.starts_with("motor.omega,my_final_x1\n"), "{own}");
    assert_eq!(own.lines().nth(1), built_in.lines().nth(1));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `ezy optimize --gait`: the gait of a scene's drives (the EzyRoller's
/// fork swing with rolling resistance at both skates, a scene file of
/// the user's) is the library's [`DriveGait`] optimum on the same scene,
/// number for number: the amplitude's bound binds and is named, the
/// first-order conditions hold (the library's own test checks the
/// projected gradient to 1e-8 of the objective). Refused by name: a
/// model without drives, a coefficient the gait does not have, a drive
/// range on a drive that does not exist.
#[test]
fn the_gait_of_a_scenes_drives_is_the_librarys_optimum() {
    use ezy_core::design::gait::{DriveGait, FourierGait};
    let dir = std::env::temp_dir().join(format!("ezy-optimize-gait-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let prescribed = scenes::BUILTIN.iter().find(|(f, _)| *f == "drive-prescribed.toml").unwrap().1;
    let rolling = "\n[effects.rolling_A]\nkind = \"rolling-viscous\"\nskate = \"A\"\ndamping = 1.0\n\n[effects.rolling_C]\nkind = \"rolling-viscous\"\nskate = \"C\"\ndamping = 1.0\n";
    let text = format!("{prescribed}{rolling}");
    let file = dir.join("rolling.toml");
    std::fs::write(&file, &text).unwrap();
    let ezy = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().unwrap();
    let out = dir.join("out");
    let (file_s, out_s) = (file.to_str().unwrap(), out.to_str().unwrap());
    let over = ["--over", "D.a0=-3.641592653589793:-2.641592653589793", "--over", "D.a1=0.05:0.4"];
    let base = ["optimize", file_s, "--gait", "D=-pi+0.1+0.3*cos(t)", "--maximize", "gait.mean_forward_speed"];
    let o = ezy(&[&base[..], &over, &["--grid", "0", "--no-figures", "--out", out_s]].concat());
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}{printed}", String::from_utf8_lossy(&o.stderr));
    assert!(printed.contains("D.a1 is at a bound"), "{printed}");
    let optimum = std::fs::read_to_string(out.join("optimum.csv")).unwrap();
    let mut lines = optimum.lines();
    assert_eq!(lines.next(), Some("D.a0,D.a1,gait.mean_forward_speed"));
    let row: Vec<f64> = lines.next().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    // the library on the same scene: the gait's start, bounds and settings
    let scene = ezy_scene::Scene::from_toml(&text, "rolling.toml").unwrap();
    let start = FourierGait::new(vec![vec![-PI + 0.1, 0.3, 0.0]], 1, 2.0).unwrap();
    let gait =
        DriveGait::new(&["D"], start).free("D.a0", -PI - 0.5, -PI + 0.5).unwrap().free("D.a1", 0.05, 0.4).unwrap();
    let design = gait.design(move || scene.problem::<ezy::models::EzyRollerDriven>(&[]).map(|(p, _)| p)).unwrap();
    let goal =
        Goal { objective: Quantity::Gait(GaitQuantity::MeanForwardSpeed), sense: Sense::Maximize, constraints: vec![] };
    let settings = OptimizeSettings { grid: 0, ..DriveGait::optimize_settings() };
    let lib = optimize(&design, &goal, &settings, None, &mut |_| {}).unwrap();
    assert!(lib.converged && lib.kkt.holds && lib.at_bound == [false, true], "{}", lib.termination);
    assert_eq!(lib.values[1], 0.4);
    for (k, (a, b)) in row.iter().zip(lib.values.iter().chain([&lib.objective])).enumerate() {
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "column {k}: the command's {a}, the library's {b}");
    }
    // refused before any work, naming the culprit
    for (args, culprit) in [
        (vec!["optimize", "drive", "--gait", "D=0.3*cos(t)", "--over", "D.a1=0:1"], "has no drives"),
        (vec!["optimize", file_s, "--gait", "D=-pi+0.3*cos(t)", "--over", "D.a3=0:1"], "`D.a3` is not a coefficient"),
        (vec!["optimize", file_s, "--gait", "D=-pi+0.3*cos(t)", "--over", "D.a1=0:1", "--range", "E=-4:-2"], "`E`"),
        (vec!["optimize", file_s, "--gait", "D=-pi+0.3*cos(t)", "--over", "D.a1=0:1", "--harmonics", "0"], "order 0"),
        (
            vec!["optimize", file_s, "--gait", "D=-pi+0.3*cos(t)", "--over", "D.a1=0:1", "--period", "1e300"],
            "--period 1e300",
        ),
    ] {
        let o = ezy(&[&args[..], &["--maximize", "gait.mean_forward_speed", "--out", out_s]].concat());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(culprit), "{args:?}: {e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
