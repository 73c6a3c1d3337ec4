//! `ezy plan` on a model typed as text: the sleigh pushed along its skate
//! from rest to rest over 1 m in 2 s against its closed form (the effort
//! printed, written and the force's nodes), its verification run's end
//! against the target; an unreachable target ends infeasible with its
//! violation and a non-zero exit; each refusal names its culprit and
//! writes nothing.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The sleigh of ezy-core/tests/plan.rs typed as a model file.
pub(crate) const SLEIGH_MODEL: &str = "/// A sleigh: one body on a skate behind its centre of mass.
pub struct Sleigh {
    param m = 2.0;
    param I = 0.1;
    param a = 0.5;
    body s(x, y, phi) { mass: m, inertia: I }
    point P on s at (-a, 0);
    skate P: P along (1, 0);
}
";

/// The sleigh at rest at the origin, a force `push.fx` along its skate
/// (body axes) at its centre of mass, DOP853 at 1e-12, 2 s.
pub(crate) const SLEIGH_SCENE: &str = "name = \"sleigh-push\"
description = \"a sleigh pushed along its skate\"
model = \"sleigh.ezy\"
t_end = 2.0

[initial]
q = { x = 0.0, y = 0.0, phi = 0.0 }
qd = { x = 0.0, phi = 0.0 }

[integrator]
method = \"dop853\"
rtol = 1e-12
atol = 1e-12

[effects.push]
kind = \"force\"
at = \"s\"
frame = \"body\"
fx = { constant = 0.0 }
";

const MASS: f64 = 2.0;

/// The model and the scene written into a fresh directory `what`: the
/// scene's path.
pub(crate) fn sleigh_scene(what: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("plan-{what}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("sleigh.ezy"), SLEIGH_MODEL).unwrap();
    std::fs::write(dir.join("push.toml"), SLEIGH_SCENE).unwrap();
    dir.join("push.toml")
}

fn ezy(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("ezy runs")
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The number after `label` on the line of `out` that starts with it
/// (its first word).
fn number_after(out: &str, label: &str) -> f64 {
    let line = out.lines().find_map(|l| l.trim_start().strip_prefix(label)).unwrap_or_else(|| panic!("{label}: {out}"));
    let word = line.split_whitespace().next().unwrap().trim_end_matches([',', ';']);
    word.parse().unwrap_or_else(|_| panic!("`{word}` after {label}"))
}

/// A CSV file's rows by column name.
fn columns(path: &Path) -> std::collections::HashMap<String, Vec<String>> {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let head: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let mut cols: std::collections::HashMap<String, Vec<String>> = head.iter().map(|h| (h.clone(), vec![])).collect();
    for r in reader.records() {
        for (h, v) in head.iter().zip(r.unwrap().iter()) {
            cols.get_mut(h).unwrap().push(v.to_string());
        }
    }
    cols
}

fn floats(v: &[String]) -> Vec<f64> {
    v.iter().map(|s| s.parse().unwrap()).collect()
}

/// Minimum effort from rest at 0 to rest at `d` in `T` for `m x'' = F`:
/// `F(t) = m (6 d / T^2) (1 - 2 t / T)`, cost `12 d^2 m^2 / T^3` (the
/// Euler-Lagrange equation `F'' = 0`): linear in time, which 4
/// piecewise-linear segments represent exactly. The effort printed and
/// written within 1e-6 of the closed form, the force's nodes within 1e-6
/// of F(0); the end the verification printed and wrote within 1e-6 of
/// the target; exit 0.
#[test]
fn the_sleigh_rest_to_rest_matches_the_closed_form() {
    let scene = sleigh_scene("closed-form");
    let out = scene.with_file_name("out");
    let args = ["plan", scene.to_str().unwrap(), "--input", "push.fx", "--to", "x=1", "--at-rest", "--segments", "4"];
    let clock = std::time::Instant::now();
    let o = ezy(&[&args[..], &["--out", out.to_str().unwrap()]].concat());
    let (said, err) = text(&o);
    eprintln!("{said}{err}({:.2} s)", clock.elapsed().as_secs_f64());
    assert_eq!(o.status.code(), Some(0), "{said}{err}");
    assert!(said.contains("on 4 segments: optimal"), "{said}");
    let (d, t_end) = (1.0, 2.0);
    let cost = 12.0 * d * d * MASS * MASS / f64::powi(t_end, 3);
    let printed = number_after(&said, "effort (sum of the integrals of the inputs squared):");
    eprintln!("effort printed {printed}, closed form {cost}: {:.1e} relative", (printed - cost).abs() / cost);
    assert!((printed - cost).abs() <= 1e-6 * cost, "effort {printed} against {cost}");
    // plan.csv: the nodes against the closed form's linear force
    let plan = columns(&out.join("plan.csv"));
    let (t, f) = (floats(&plan["t"]), floats(&plan["push.fx"]));
    assert_eq!(t.len(), 5);
    let force = |t: f64| MASS * 6.0 * d / (t_end * t_end) * (1.0 - 2.0 * t / t_end);
    let worst = t.iter().zip(&f).fold(0.0f64, |w, (t, u)| w.max((u - force(*t)).abs()));
    eprintln!("force nodes: largest difference from the closed form {worst:.2e} N (F(0) = {} N)", force(0.0));
    assert!(worst <= 1e-6 * force(0.0), "{t:?} {f:?}");
    for (k, tk) in t.iter().enumerate() {
        assert!((tk - t_end * k as f64 / 4.0).abs() <= 1e-15, "{t:?}");
    }
    // the node states: x(t) = d (3 s^2 - 2 s^3), s = t / T
    let x = floats(&plan["x"]);
    let worst_x = t.iter().zip(&x).fold(0.0f64, |w, (t, x)| {
        let s = t / t_end;
        w.max((x - d * (3.0 * s * s - 2.0 * s * s * s)).abs())
    });
    eprintln!("node positions: largest difference from the closed form {worst_x:.2e} m");
    assert!(worst_x <= 1e-6, "{x:?}");
    // plan_summary.csv: the same effort, the verification's end errors
    let summary = columns(&out.join("plan_summary.csv"));
    assert_eq!(summary["status"], ["optimal"]);
    let written: f64 = summary["effort"][0].parse().unwrap();
    assert_eq!(written, printed, "the effort written and printed");
    for name in ["x", "xd", "yd", "phid"] {
        let run: f64 = summary[&format!("run_error_{name}")][0].parse().unwrap();
        let planned: f64 = summary[&format!("plan_error_{name}")][0].parse().unwrap();
        assert!(run.abs() <= 1e-6 && planned.abs() <= 1e-6, "{name}: run {run}, plan {planned}");
    }
    // the end the report prints: the target plus the run's error, and
    // an ordinary run of the written table (the oracle: `ezy run` on the
    // scene with push.fx as plan.csv's table) ends there
    let run_x = number_after(&said, "x = 1: run");
    let table = format!("fx = {{ table = {{ t = {:?}, value = {:?} }} }}", t, f);
    let replayed = SLEIGH_SCENE
        .replace("fx = { constant = 0.0 }", &table)
        .replace("[integrator]", "[output]\nevery = 2.0\n\n[integrator]");
    std::fs::write(scene.with_file_name("replay.toml"), replayed).unwrap();
    let replay_out = scene.with_file_name("replay");
    let r = ezy(&[
        "run",
        scene.with_file_name("replay.toml").to_str().unwrap(),
        "--no-figures",
        "--out",
        replay_out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{:?}", text(&r));
    let trajectory = columns(&replay_out.join("trajectory.csv"));
    let end_x: f64 = trajectory["x"].last().unwrap().parse().unwrap();
    eprintln!("end x: printed {run_x}, `ezy run` of plan.csv's table {end_x}");
    assert!((end_x - run_x).abs() <= 1e-9 && (run_x - 1.0).abs() <= 1e-6, "{run_x} {end_x}");
    for figure in ["plan.png", "plan_path.png"] {
        assert!(out.join(figure).is_file(), "{figure}");
    }
}

/// `|F| <= 0.1 N` moves the 2 kg sleigh from rest to rest at most
/// `a T^2 / 4 = 0.05 m` in 2 s: 1 m is out of reach. The plan ends
/// infeasible with a violation of at least the distance the bound
/// cannot cover, exits non-zero, never says optimal or converged; its
/// least violating inputs are written and stay within the bound.
#[test]
fn an_unreachable_target_is_infeasible() {
    let scene = sleigh_scene("unreachable");
    let out = scene.with_file_name("out");
    let o = ezy(&[
        "plan",
        scene.to_str().unwrap(),
        "--input",
        "push.fx",
        "--bound",
        "push.fx=-0.1:0.1",
        "--to",
        "x=1",
        "--at-rest",
        "--segments",
        "4",
        "--no-figures",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (said, err) = text(&o);
    eprintln!("{said}{err}");
    assert_eq!(o.status.code(), Some(1), "{said}{err}");
    assert!(!said.contains("optimal") && !said.contains("converged") && !err.contains("converged"), "{said}{err}");
    assert!(err.contains("infeasible") && said.contains("infeasible"), "{said}{err}");
    let violation = number_after(&err, "error: infeasible: no point met the target; the smallest violation found is");
    let summary = columns(&out.join("plan_summary.csv"));
    assert_eq!(summary["status"], ["infeasible"]);
    let written: f64 = summary["violation"][0].parse().unwrap();
    assert_eq!(written, violation);
    // a lower bound on the least violation V: |F| <= 0.1 N alone moves
    // the sleigh at most 0.05 m/s^2 (2 s)^2 / 2 = 0.1 m; a jump of at most
    // V in xd at the inner node t_k adds at most V (T - t_k) (1.5 + 1 +
    // 0.5 = 3 V), one in x at most V (3 V), the target's x V: 1 m <= 0.1
    // + 7 V
    eprintln!("violation {violation} m, at least {} by the bound", 0.9 / 7.0);
    assert!(violation >= 0.9 / 7.0, "violation {violation}");
    let plan = columns(&out.join("plan.csv"));
    assert!(floats(&plan["push.fx"]).iter().all(|u| u.abs() <= 0.1 + 1e-12), "{:?}", plan["push.fx"]);
}

/// Each refusal names its culprit, exits non-zero before any work and
/// writes nothing.
#[test]
fn bad_requests_are_refused_by_name() {
    let scene = sleigh_scene("refusals");
    let s = scene.to_str().unwrap();
    let out = scene.with_file_name("out");
    let o = out.to_str().unwrap();
    let base = ["plan", s, "--out", o];
    let cases: &[(&[&str], &str)] = &[
        (
            &["--input", "push.fx", "--bound", "push.fx=1:-1", "--to", "x=1"],
            "--bound `push.fx=1:-1`: the lower bound 1 is above the upper -1",
        ),
        (&["--input", "push.fx", "--bound", "push.fx=nan:1", "--to", "x=1"], "`nan` is not a finite number"),
        (&["--input", "push.fx", "--bound", "push.fx=-1:inf", "--to", "x=1"], "`inf` is not a finite number"),
        (&["--input", "push.fx", "--bound", "tau=-1:1", "--to", "x=1"], "--bound `tau=-1:1`: no --input `tau`"),
        (
            &["--input", "motor.torque", "--to", "x=1"],
            "--input `motor.torque`: scene `sleigh-push` has no effect `motor`; its effects: push",
        ),
        (
            &["--input", "push.fz", "--to", "x=1"],
            "--input `push.fz`: effect `push` (kind force) takes no time function at `fz`",
        ),
        (
            &["--input", "push.at", "--to", "x=1"],
            "--input `push.at`: effect `push` (kind force) takes no time function at `at`",
        ),
        (&["--input", "push", "--to", "x=1"], "--input `push`: expected EFFECT.FIELD"),
        (&["--input", "push.fx", "--to", "z=1"], "--to `z=1`: the model has no coordinate `z`"),
        (&["--input", "push.fx"], "no target: give --to"),
        (
            &["--input", "push.fx", "--to", "x=1", "--segments", "5000"],
            "--segments 5000: 5001 unknowns (5001 input nodes)",
        ),
        (
            &["--input", "push.fx", "--to", "x=1", "--segments", "100", "--intervals", "100"],
            "--segments 100: 596 unknowns (101 input nodes and 5 state components at each of the 99 inner nodes",
        ),
        (&["--input", "push.fx", "--to", "x=1", "--segments", "4", "--intervals", "5"], "--intervals 5: give 1"),
        (&["--input", "push.fx", "--to", "x=1", "--intervals", "0"], "--intervals 0: give 1"),
        (
            &["--input", "push.fx", "--to", "x=1", "--segments", "5000"],
            "more than the limit of 500 (ezy_core::plan::MAX_UNKNOWNS",
        ),
        (&["--input", "push.fx", "--to", "x=1", "--segments", "18446744073709551615"], "more than the limit of 500"),
        (&["--input", "push.fx", "--to", "x=1", "--segments", "0"], "0 segments"),
        (&["--input", "push.fx", "--input", "push.fx", "--to", "x=1"], "--input: `push.fx` is given twice"),
        (&["--input", "push.fx", "--to", "x=1,x=2"], "--to: `x` is given twice"),
    ];
    for (extra, words) in cases {
        let r = ezy(&[&base[..], extra].concat());
        let (said, err) = text(&r);
        assert!(!r.status.success() && err.contains(words), "{extra:?}: {said}{err}");
        assert!(!out.exists(), "{extra:?} wrote {}", out.display());
    }
    // 100 segments, a node at each: 101 input nodes and 5 = 2 * 3 - 1
    // state components (the skate's one constraint) at each of 99 inner
    // nodes
    assert_eq!(101 + 5 * 99, 596);
    assert_eq!(ezy_core::plan::MAX_UNKNOWNS, 500);
}

/// The EzyRoller driven by its hinge alone never comes back to rest, the
/// reason `ezy plan`'s rest-to-rest target on the `drive` scene is
/// infeasible (ezy-core's `roller::rest_to_rest_is_infeasible`). With the
/// hinge angle `psi(t)` prescribed (the `ezyroller_driven` model), the
/// speed `u` of the rear skate along its blade obeys `u' = beta(psi) psi'
/// u + gamma(psi) psi'^2 + delta(psi) psi''`, linear in `u`; with
/// `w = u / E(psi)`, `E' = beta E`, a motion from rest to rest of the
/// hinge changes `w` by `int K(psi) psi'^2 dt`, `K = (gamma - delta' +
/// delta beta) / E`, which is positive at every hinge angle (`E` changes
/// sign where the fork's skate line passes through the rear skate, and
/// the numerator with it), so `w` only grows. The oracle is ezy's own
/// runs: shape motions `psi(t) = pi + sum_k c_k (1 - cos(2 pi k t / T))`
/// (at rest at both ends, the fork straight at the end; one crossing the
/// fork's singular angle and back) from rest all end moving forward, `u(T) > 0`
/// by more than 1e-5 m/s, against the runs' 1e-10 accuracy. The test can
/// fail: the same dynamics are reversible, and the same (time-symmetric)
/// shape motion started from the end state with its velocities reversed
/// ends at rest to 1e-8, where it began.
#[test]
fn the_ezyroller_never_comes_back_to_rest() {
    use ezy_core::effects::{Harmonic, Waveform};
    use ezy_core::problem::Problem;
    use std::f64::consts::PI;
    let cases: [(f64, [f64; 3]); 6] = [
        (2.0, [0.05, 0.0, 0.0]),
        (4.0, [0.3, -0.1, 0.05]),
        (3.0, [-0.2, 0.15, 0.1]),
        (6.0, [0.1, 0.2, -0.15]),
        // swinging 1.5 rad from straight at most: across the fork's
        // singular angle (1.318 rad) and back
        (4.0, [0.75, 0.0, 0.0]),
        // swinging 1.2 rad at most
        (5.0, [-0.5, -0.3, 0.0]),
    ];
    let names = ["x1", "y1", "phi1", "x2", "y2", "phi2"];
    for (t_end, c) in cases {
        // the model's drive angle is phi1 - phi2 = -psi
        let mut terms =
            vec![Harmonic { amplitude: -PI - c.iter().sum::<f64>(), omega: 0.0, phase: 0.0, phase_step: 0.0 }];
        for (k, ck) in c.iter().enumerate() {
            let omega = 2.0 * PI * (k + 1) as f64 / t_end;
            terms.push(Harmonic { amplitude: *ck, omega, phase: 0.0, phase_step: 0.0 });
        }
        let angle = Waveform::Harmonics(terms);
        let run = |q0: &[(&str, f64)], qd0: &[(&str, f64)]| {
            let mut p = Problem::new(ezy_models::EzyRollerDriven::default()).drive("D", angle.clone()).unwrap();
            for (n, v) in q0 {
                p = p.q(n, *v).unwrap();
            }
            for (n, v) in qd0 {
                p = p.qd(n, *v).unwrap();
            }
            let s = p.t_end(t_end).every(t_end).method(ezy_core::Method::Dop853).tolerances(1e-11, 1e-11);
            s.solve().unwrap().final_state()[..12].to_vec()
        };
        let end = run(&[("x1", 0.0), ("y1", 0.0), ("phi1", 0.0)], &[("x1", 0.0)]);
        let u = end[6] * end[2].cos() + end[7] * end[2].sin();
        eprintln!("T = {t_end} s, c = {c:?}: u(T) = {u:.6e} m/s, x1(T) = {:.4} m", end[0]);
        assert!(u > 1e-5, "c = {c:?}: u(T) = {u}");
        // reversed: from the end with the velocities negated, back to rest
        let q0: Vec<(&str, f64)> = names.iter().zip(&end[..6]).map(|(n, v)| (*n, *v)).collect();
        let qd0: Vec<(&str, f64)> = names.iter().zip(&end[6..12]).map(|(n, v)| (*n, -v)).collect();
        let back = run(&q0, &qd0);
        let speed = back[6..12].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let home = back[..3].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        eprintln!("  reversed: largest velocity at its end {speed:.1e}, {home:.1e} from the origin");
        assert!(speed <= 1e-8 && home <= 1e-8, "reversed: {back:?}");
    }
}

/// `ezy plan` on the `drive` scene (DOP853 at 1e-11 instead of its RK4):
/// from rest to 1 m ahead on its line, fork straight and still, with
/// least squared hinge torque on 10 segments. Optimal, exit 0; the
/// effort printed that of ezy-core's library test of the same program
/// (5.193432414, the planner's own path without the scene) to 1e-6
/// relative; the verification run's error on every target component
/// below 1e-6 in plan_summary.csv; the torque within its bound.
#[test]
fn the_ezyroller_goes_one_metre_ahead() {
    let dir = std::env::temp_dir().join(format!("ezy-plan-roller-{}", std::process::id()));
    let out = dir.join("out");
    let pi = std::f64::consts::PI.to_string();
    let to = format!("x1=1,y1=0,phi1=0,phi2={pi},phi2d=0");
    #[rustfmt::skip]
    let args = ["plan", "drive", "--input", "motor.torque", "--bound", "motor.torque=-10:10", "--to", &to,
        "--t-end", "8", "--integrator", "dop853", "--rtol", "1e-11", "--atol", "1e-11", "--no-figures",
        "--out", out.to_str().unwrap()];
    let o = ezy(&args);
    let (said, err) = text(&o);
    eprintln!("{said}{err}");
    assert_eq!(o.status.code(), Some(0), "{said}{err}");
    assert!(said.contains("on 10 segments: optimal") && said.contains("direct single shooting"), "{said}");
    let effort = number_after(&said, "effort (sum of the integrals of the inputs squared):");
    assert!((effort - 5.193432414).abs() <= 1e-6 * effort, "{effort}");
    let summary = columns(&out.join("plan_summary.csv"));
    for name in ["x1", "y1", "phi1", "phi2", "phi2d"] {
        let run: f64 = summary[&format!("run_error_{name}")][0].parse().unwrap();
        assert!(run.abs() <= 1e-6, "{name}: {run}");
    }
    let plan = columns(&out.join("plan.csv"));
    assert!(floats(&plan["motor.torque"]).iter().all(|u| u.abs() <= 10.0), "{:?}", plan["motor.torque"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--guess FILE` starts the search from a file's inputs: the closed
/// form's force at three times (linear, so exact at every node of 4
/// segments) is optimal within the least budget, 2 evaluations, where
/// the scene's own zero force is not (exit 1); the effort is the closed
/// form's to 1e-8. A guess file that is missing, lacks the input's
/// column, or has a cell that is no number or times out of order is
/// refused by name, writing nothing.
#[test]
fn a_guess_file_is_the_warm_start() {
    let scene = sleigh_scene("guess");
    let (s, out) = (scene.to_str().unwrap().to_string(), scene.with_file_name("out"));
    let o = out.to_str().unwrap().to_string();
    let guess = scene.with_file_name("guess.csv");
    // F(t) = m 6 d / T^2 (1 - 2 t / T) = 3 (1 - t) N
    std::fs::write(&guess, "t,push.fx\n0,3\n1,0\n2,-3\n").unwrap();
    let base = ["plan", &s, "--input", "push.fx", "--to", "x=1", "--at-rest", "--segments", "4", "--evaluations", "2"];
    let g = guess.to_str().unwrap();
    let o1 = ezy(&[&base[..], &["--guess", g, "--no-figures", "--out", &o]].concat());
    let (said, err) = text(&o1);
    eprintln!("{said}{err}");
    assert_eq!(o1.status.code(), Some(0), "{said}{err}");
    let effort = number_after(&said, "effort (sum of the integrals of the inputs squared):");
    assert!((effort - 6.0).abs() <= 1e-8 * 6.0, "{effort}");
    let cold = ezy(&[&base[..], &["--no-figures", "--out", &o]].concat());
    assert_eq!(cold.status.code(), Some(1), "{:?}", text(&cold));
    let _ = std::fs::remove_dir_all(&out);
    let bad = |name: &str, body: Option<&str>, words: &str| {
        let path = scene.with_file_name(name);
        if let Some(b) = body {
            std::fs::write(&path, b).unwrap();
        }
        let r = ezy(&[&base[..], &["--guess", path.to_str().unwrap(), "--out", &o]].concat());
        let (said, err) = text(&r);
        assert!(!r.status.success() && err.contains(words), "{name}: {said}{err}");
        assert!(!out.exists(), "{name} wrote {}", out.display());
    };
    bad("absent.csv", None, "absent.csv");
    bad("nocol.csv", Some("t,fx\n0,1\n"), "no column `push.fx` (it has t, fx)");
    bad("word.csv", Some("t,push.fx\n0,1\n1,strong\n"), "line 3, column `push.fx`: `strong` is not a number");
    bad("order.csv", Some("t,push.fx\n1,1\n0,2\n"), "row 2: t = 0 s is not after the row before");
}

/// `--path xd<=0.6` bounds the sleigh's speed at the nodes: on 8
/// segments the plan is the continuous optimum, a force linear to zero
/// at 0.5 s, a coast at 0.6 m/s, and a force linear from zero after
/// 1.5 s; its effort `8 m^2 vmax^2 / (3 t1)` = 7.68 N^2 s (the library's
/// test checks it against an independent solution of the discrete
/// program too). The summary counts the inequalities and the
/// verification run's largest excess between the nodes; each bad bound
/// is refused by name before any work, writing nothing.
#[test]
fn a_speed_bound_on_the_path_is_the_closed_form() {
    let scene = sleigh_scene("path");
    let (s, out) = (scene.to_str().unwrap().to_string(), scene.with_file_name("out"));
    let o = out.to_str().unwrap().to_string();
    let base = ["plan", &s, "--input", "push.fx", "--to", "x=1", "--at-rest", "--segments", "8", "--no-figures"];
    let r = ezy(&[&base[..], &["--path", "xd<=0.6", "--out", &o]].concat());
    let (said, err) = text(&r);
    eprintln!("{said}{err}");
    assert_eq!(r.status.code(), Some(0), "{said}{err}");
    let cost = 8.0 * MASS * MASS * 0.36 / (3.0 * 0.5);
    let effort = number_after(&said, "effort (sum of the integrals of the inputs squared):");
    assert!((effort - cost).abs() <= 1e-8 * cost, "{effort} against {cost}");
    let plan = columns(&out.join("plan.csv"));
    let force = |t: f64| {
        if t <= 0.5 {
            4.8 * (1.0 - t / 0.5)
        } else if t >= 1.5 {
            -4.8 * (t - 1.5) / 0.5
        } else {
            0.0
        }
    };
    for (t, f) in floats(&plan["t"]).iter().zip(floats(&plan["push.fx"])) {
        assert!((f - force(*t)).abs() <= 1e-6 * 4.8, "F({t}) = {f}, closed form {}", force(*t));
    }
    assert!(floats(&plan["xd"]).iter().all(|v| *v <= 0.6 + 1e-8), "{:?}", plan["xd"]);
    let summary = columns(&out.join("plan_summary.csv"));
    assert_eq!(summary["inequalities"], ["8"]);
    let excess: f64 = summary["path_excess"][0].parse().unwrap();
    assert!((0.0..=1e-8).contains(&excess), "{excess}");
    assert!(said.contains("8 inequalities"), "{said}");
    let bad = |path: &str, words: &str| {
        let _ = std::fs::remove_dir_all(&out);
        let r = ezy(&[&base[..], &["--path", path, "--out", &o]].concat());
        let (said, err) = text(&r);
        assert!(!r.status.success() && err.contains(words), "{path}: {said}{err}");
        assert!(!out.exists(), "{path} wrote {}", out.display());
    };
    bad("xd<0.6", "--path `xd<0.6`: no bound");
    bad("zd<=1", "no coordinate `zd`");
    bad("xd<=nan", "`nan` is not a finite number");
    bad("xd>=0.1", "the initial state has qd.x = 0");
    bad("2<=xd<=1", "the lower at most the upper");
}

/// `--minimize time --free-time 1:10` with `|F| <= 1 N` on 8 segments:
/// the least time of the discrete program, whose force is bang-bang
/// through the nodes (+1 to the middle node, 0 there, -1 after: a linear
/// program's vertex), its distance `x_N(T) = T^2 x_N(1)` exact, so `T_N =
/// sqrt(d / x_N(1))` = 2.8584 s, above the continuous `2 sqrt(m d / F)`
/// = 2.8284 s. Printed, written (`t_end`) and the nodes' times; the
/// duration's flags refused by name where they do not make sense.
#[test]
fn least_time_is_the_discrete_bang_bang() {
    let scene = sleigh_scene("time");
    let (s, out) = (scene.to_str().unwrap().to_string(), scene.with_file_name("out"));
    let o = out.to_str().unwrap().to_string();
    let base = [
        "plan",
        &s,
        "--input",
        "push.fx",
        "--bound",
        "push.fx=-1:1",
        "--to",
        "x=1",
        "--at-rest",
        "--segments",
        "8",
        "--no-figures",
    ];
    let r = ezy(&[&base[..], &["--minimize", "time", "--free-time", "1:10", "--out", &o]].concat());
    let (said, err) = text(&r);
    eprintln!("{said}{err}");
    assert_eq!(r.status.code(), Some(0), "{said}{err}");
    let u: Vec<f64> = (0..=8).map(|k: i32| (4 - k).signum() as f64).collect();
    let (h, mut x, mut v) = (1.0 / 8.0, 0.0, 0.0);
    for k in 0..8 {
        x += v * h + h * h * (2.0 * u[k] + u[k + 1]) / (6.0 * MASS);
        v += h * (u[k] + u[k + 1]) / (2.0 * MASS);
    }
    let t_n = (1.0 / x).sqrt();
    let printed = number_after(&said, "duration (free within [1, 10] s):");
    eprintln!("T printed {printed}, the discrete optimum {t_n}");
    assert!((printed - t_n).abs() <= 1e-8 * t_n, "{printed} against {t_n}");
    assert!(said.contains("objective minimized: time ="), "{said}");
    let summary = columns(&out.join("plan_summary.csv"));
    let written: f64 = summary["t_end"][0].parse().unwrap();
    assert!((written - t_n).abs() <= 1e-8 * t_n);
    let plan = columns(&out.join("plan.csv"));
    let t = floats(&plan["t"]);
    assert_eq!(*t.last().unwrap(), written, "the last node is the duration");
    for (f, want) in floats(&plan["push.fx"]).iter().zip(&u) {
        assert!((f - want).abs() <= 1e-6, "{:?}", plan["push.fx"]);
    }
    let bad = |extra: &[&str], words: &str| {
        let _ = std::fs::remove_dir_all(&out);
        let r = ezy(&[&base[..], extra, &["--out", &o]].concat());
        let (said, err) = text(&r);
        assert!(!r.status.success() && err.contains(words), "{extra:?}: {said}{err}");
        assert!(!out.exists(), "{extra:?} wrote {}", out.display());
    };
    bad(&["--minimize", "time"], "the duration is fixed (t_end = 2 s)");
    bad(&["--minimize", "time", "--free-time", "3:4"], "<= t_end (2 s) <= upper");
    bad(&["--free-time", "1:nan"], "`nan` is not a finite number");
    bad(&["--time-weight", "-1", "--free-time", "1:3"], "time_weight -1: give a finite weight >= 0");
}
