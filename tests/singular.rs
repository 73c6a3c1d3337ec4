//! Singular positions: the IFToMM multibody benchmark A02, the N-four-bar
//! mechanism (N = 2, written out here by hand as a user's model would be),
//! whose bars all lie on the ground line twice a revolution: there the
//! constraint Jacobian loses rank (the parallelogram branch crosses a
//! folded one). Every run must pass all ten passages of 10 s, keep the
//! parallelogram branch (all cranks at one angle) and match the
//! one-degree-of-freedom solution `J theta'' = -g c cos(theta)`, integrated
//! here independently. Source: IFToMM Technical Committee for Multibody
//! Dynamics, "Library of computational benchmark problems", problem A02.

use ezy::App;

ezy_core::model! {
    /// The N-four-bar, N = 2: cranks k0..k2 on ground pivots at 0, L, 2L,
    /// couplers c1, c2 joining their tips; uniform bars of 1 m and 1 kg.
    pub struct A02N2 {
        param L = 1.0;
        param m = 1.0;
        param I = 0.08333333333333333;
        body k0(x0, y0, p0) { mass: m, inertia: I }
        body k1(x1, y1, p1) { mass: m, inertia: I }
        body k2(x2, y2, p2) { mass: m, inertia: I }
        body c1(u1, v1, r1) { mass: m, inertia: I }
        body c2(u2, v2, r2) { mass: m, inertia: I }
        point O0 on k0 at (-L / 2, 0);
        point T0 on k0 at (L / 2, 0);
        point O1 on k1 at (-L / 2, 0);
        point T1 on k1 at (L / 2, 0);
        point O2 on k2 at (-L / 2, 0);
        point T2 on k2 at (L / 2, 0);
        point P1 on c1 at (-L / 2, 0);
        point Q1 on c1 at (L / 2, 0);
        point P2 on c2 at (-L / 2, 0);
        point Q2 on c2 at (L / 2, 0);
        hinge G0: O0 = ground(0, 0);
        hinge G1: O1 = ground(L, 0);
        hinge G2: O2 = ground(2 * L, 0);
        hinge H1: P1 = T0;
        hinge K1: Q1 = T1;
        hinge H2: P2 = T1;
        hinge K2: Q2 = T2;
    }
}

const SCENE: &str = r#"
name = "a02n2"
description = "IFToMM A02, N = 2, written out"
model = "a02n2"
t_end = 10.0
[initial]
q = { x0 = 0.0, y0 = 0.5, p0 = 1.5707963267948966, x1 = 1.0, y1 = 0.5, p1 = 1.5707963267948966, x2 = 2.0, y2 = 0.5, p2 = 1.5707963267948966, u1 = 0.5, v1 = 1.0, r1 = 0.0, u2 = 1.5, v2 = 1.0, r2 = 0.0 }
qd = { x0 = 0.5, y0 = 0.0, p0 = -1.0, x1 = 0.5, y1 = 0.0, p1 = -1.0, x2 = 0.5, y2 = 0.0, p2 = -1.0, u1 = 1.0, v1 = 0.0, r1 = 0.0, u2 = 1.0, v2 = 0.0, r2 = 0.0 }
[integrator]
method = "dop853"
rtol = 1e-10
atol = 1e-10
[output]
every = 0.01
include = ["energy", "residuals"]
[effects.gravity]
kind = "gravity"
g = [0.0, -9.81]
"#;

/// The crank angle of the one-degree-of-freedom parallelogram at the
/// times `ts` (increasing), by classic RK4 at h = 1e-5 s from
/// `theta0` [rad], `omega0` [rad/s] for N = 2: `J = (N+1) m L^2/3 + N m
/// L^2 = 3`, `c = (N+1) m L/2 + N m L = 3.5` for m = L = 1, g = 9.81.
fn parallelogram(theta0: f64, omega0: f64, ts: &[f64]) -> Vec<f64> {
    parallelogram_n(2, theta0, omega0, ts)
}

/// As [`parallelogram`] for `n` couplers.
fn parallelogram_n(n: usize, theta0: f64, omega0: f64, ts: &[f64]) -> Vec<f64> {
    let n = n as f64;
    let (j, c, g) = ((n + 1.0) / 3.0 + n, (n + 1.0) / 2.0 + n, 9.81);
    let f = |th: f64| -g * c / j * th.cos();
    let (mut th, mut w, mut t) = (theta0, omega0, 0.0f64);
    let h: f64 = 1e-5;
    ts.iter()
        .map(|&te| {
            while t < te - 1e-12 {
                let hh = h.min(te - t);
                let (k1t, k1w) = (w, f(th));
                let (k2t, k2w) = (w + 0.5 * hh * k1w, f(th + 0.5 * hh * k1t));
                let (k3t, k3w) = (w + 0.5 * hh * k2w, f(th + 0.5 * hh * k2t));
                let (k4t, k4w) = (w + hh * k3w, f(th + hh * k3t));
                th += hh / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t);
                w += hh / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
                t += hh;
            }
            th
        })
        .collect()
}

/// Runs the scene with `args` and returns `(t, p0, p1, p2)` per sample and
/// the printed report.
fn run(scene: &'static str, args: &[&str]) -> (Vec<[f64; 4]>, String) {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let app = App::new().model::<A02N2>("a02n2").scene("scenes/a02n2.toml", scene);
    let mut out = Vec::new();
    let argv =
        ["ezy", "run", "a02n2", "--no-figures", "--out", o.to_str().unwrap()].into_iter().chain(args.iter().copied());
    if let Err(e) = app.run_cli(argv, &mut out) {
        panic!("{args:?}: {e}");
    }
    let text = std::fs::read_to_string(o.join("trajectory.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let cols = [col("t"), col("p0"), col("p1"), col("p2")];
    let rows = lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
            cols.map(|c| v[c])
        })
        .collect();
    (rows, String::from_utf8(out).unwrap())
}

/// Largest `|p0 - theta_ref|` and `|p_i - p0|` over the samples.
fn errors(rows: &[[f64; 4]], theta0: f64, omega0: f64) -> (f64, f64) {
    let ts: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let reference = parallelogram(theta0, omega0, &ts);
    let err = rows.iter().zip(&reference).map(|(r, th)| (r[1] - th).abs()).fold(0.0, f64::max);
    let branch = rows.iter().map(|r| (r[2] - r[1]).abs().max((r[3] - r[1]).abs())).fold(0.0, f64::max);
    (err, branch)
}

/// What ten singular passages leave of any accuracy \[rad\] at rtol 1e-11
/// and below: each passage amplifies a perturbation of the positions at
/// the rounding level to about its square root (sqrt(eps) = 1.5e-8), so
/// there the error is set by the last bits of the step sizes and of every
/// sine and cosine, not by the tolerance; ten passages that add up give
/// about 1.5e-7. Measured on N = 2 with DOP853, the tolerance moved by 0
/// to 7e-13 of itself (eight runs each): 3.7e-10 to 1.2e-8 at 1e-10,
/// 5.0e-10 to 7.8e-8 at 1e-11, 1.2e-9 to 2.6e-8 at 1e-12; with `powf` in
/// the step-size controller (before its three square roots) 1.5e-9 to
/// 7.8e-9, 2.9e-10 to 1.5e-7 and 9.3e-10 to 1.5e-7. That the tolerance
/// still decides where it can is checked before the first passage
/// ([`before_the_first_passage`]).
const FLOOR: f64 = 5e-7;

/// The largest error the rows before the first singular passage (t <
/// 0.7 s; it comes at 0.714 s for N = 2, 0.722 s for N = 40) may have
/// with the settings `args`: 100 rtol for the adaptive methods (DOP853
/// and DOPRI5 measured 2 and 7 rtol, RADAU5 30 rtol at 1e-10), 1e-10 rad
/// for RK4 at h = 1e-3 s (measured 2e-12). A tolerance the run did not
/// honour (capped at 1e-8, say) shows here, where the passages' floor
/// would hide it.
fn before_the_first_passage(args: &[&str]) -> f64 {
    match args.iter().position(|a| *a == "--rtol") {
        Some(i) => 100.0 * args[i + 1].parse::<f64>().expect("a tolerance"),
        None => 1e-10,
    }
}

/// DOP853 at 1e-6 to 1e-12, DOPRI5, RK4 and RADAU5 pass all ten singular
/// passages of 10 s on the parallelogram branch. Measured (2 cores):
/// errors against the reference 1.1e-4, 8.9e-8, 7.1e-9, 7.8e-8 and
/// 1.3e-8 rad (DOP853 at 1e-6, 1e-8, 1e-10, 1e-11, 1e-12; 3.7e-9, 3.0e-9
/// and 1.2e-9 at the last three with `powf` in the step-size controller),
/// 2.1e-8 (DOPRI5, 1e-10), 3.7e-9 (RK4, h = 1e-3 s), 1.1e-7 (RADAU5,
/// 1e-8), 7.0e-9 (RADAU5, 1e-10), 1.4e-7 (the reduced formulation at
/// 1e-8, handing over to the DAE); with the tolerance moved by 0 to 7e-13
/// of itself, eight runs each: DOPRI5 2.1e-8 to 2.2e-8, RADAU5 at 1e-10
/// 5.5e-9 to 9.1e-9, RK4 (h moved alike) 3.6e-9 to 3.8e-9; the cranks'
/// angles agree to 3e-10 rad in all of them. The bound is 200 rtol (the
/// global error of 10 s over 30 rad of crank angle) at 1e-6 and 1e-8,
/// 5e-8 at 1e-10 (four times the largest measured), [`FLOOR`] at 1e-11
/// and 1e-12; 1e-7 for DOPRI5, 1e-8 for RK4 and 2e-8 for RADAU5 at 1e-10
/// (two to four times their largest); the rows before the first passage
/// as [`before_the_first_passage`]. A run that stopped, switched branch
/// (the folded branch keeps one crank still) or integrated the
/// regularized system wrongly fails by orders of magnitude.
#[test]
fn the_n_four_bar_passes_its_singular_positions() {
    let half = std::f64::consts::FRAC_PI_2;
    for (args, bound) in [
        (vec!["--rtol", "1e-6", "--atol", "1e-6"], 2e-4),
        (vec!["--rtol", "1e-8", "--atol", "1e-8"], 2e-6),
        (vec!["--rtol", "1e-10", "--atol", "1e-10"], 5e-8),
        (vec!["--rtol", "1e-11", "--atol", "1e-11"], FLOOR),
        (vec!["--rtol", "1e-12", "--atol", "1e-12"], FLOOR),
        (vec!["--integrator", "dopri5", "--rtol", "1e-10", "--atol", "1e-10"], 1e-7),
        (vec!["--integrator", "rk4", "--dt", "1e-3"], 1e-8),
        // the reduced formulation hands over to the DAE near the first
        // passage (a note), which goes on from its last accepted state
        (vec!["--formulation", "reduced", "--rtol", "1e-8", "--atol", "1e-8"], 2e-6),
        (vec!["--integrator", "radau5", "--rtol", "1e-8", "--atol", "1e-8"], 2e-6),
        (vec!["--integrator", "radau5", "--rtol", "1e-10", "--atol", "1e-10"], 2e-8),
    ] {
        let (rows, report) = run(SCENE, &args);
        assert_eq!(rows.last().unwrap()[0], 10.0, "{args:?}: {report}");
        // ten passages: the crank angle from pi/2 past -9 pi
        assert!(rows.last().unwrap()[1] < -9.0 * std::f64::consts::PI, "{args:?}");
        let (err, branch) = errors(&rows, half, -1.0);
        assert!(err < bound, "{args:?}: error {err:e} against the parallelogram");
        assert!(branch < 1e-8, "{args:?}: cranks apart by {branch:e} rad (branch switched)");
        let early: Vec<[f64; 4]> = rows.iter().copied().filter(|r| r[0] < 0.7).collect();
        let (err, _) = errors(&early, half, -1.0);
        let pre = before_the_first_passage(&args);
        assert!(err < pre, "{args:?}: error {err:e} before the first passage, above {pre:e}");
    }
}

/// A run started exactly at the singular position (every bar on the
/// ground line, G rank-deficient at t = 0) runs: the setup refuses only
/// constraints dependent at every configuration.
#[test]
fn a_run_started_at_the_singular_position_runs() {
    // theta = 0 with the rate of the passage at t = 0.714 s: E = J w^2 / 2 + g c sin(theta)
    let w0 = -(2.0 * (0.5 * 3.0 + 9.81 * 3.5) / 3.0f64).sqrt();
    let scene: &'static str = Box::leak(
        SCENE
            .replace("p0 = 1.5707963267948966", "p0 = 0.0")
            .replace("p1 = 1.5707963267948966", "p1 = 0.0")
            .replace("p2 = 1.5707963267948966", "p2 = 0.0")
            .replace("x0 = 0.0, y0 = 0.5", "x0 = 0.5, y0 = 0.0")
            .replace("x1 = 1.0, y1 = 0.5", "x1 = 1.5, y1 = 0.0")
            .replace("x2 = 2.0, y2 = 0.5", "x2 = 2.5, y2 = 0.0")
            .replace("u1 = 0.5, v1 = 1.0", "u1 = 1.5, v1 = 0.0")
            .replace("u2 = 1.5, v2 = 1.0", "u2 = 2.5, v2 = 0.0")
            .replace("x0 = 0.5, y0 = 0.0, p0 = -1.0", &format!("x0 = 0.0, y0 = {}, p0 = {w0}", 0.5 * w0))
            .replace("x1 = 0.5, y1 = 0.0, p1 = -1.0", &format!("x1 = 0.0, y1 = {}, p1 = {w0}", 0.5 * w0))
            .replace("x2 = 0.5, y2 = 0.0, p2 = -1.0", &format!("x2 = 0.0, y2 = {}, p2 = {w0}", 0.5 * w0))
            .replace("u1 = 1.0, v1 = 0.0", &format!("u1 = 0.0, v1 = {w0}"))
            .replace("u2 = 1.0, v2 = 0.0", &format!("u2 = 0.0, v2 = {w0}"))
            .replace("t_end = 10.0", "t_end = 2.0")
            .into_boxed_str(),
    );
    let (rows, report) = run(scene, &["--rtol", "1e-10", "--atol", "1e-10"]);
    assert_eq!(rows.last().unwrap()[0], 2.0, "{report}");
    let (err, branch) = errors(&rows, 0.0, w0);
    assert!(err < 2e-8, "error {err:e}: {report}");
    assert!(branch < 1e-8, "cranks apart by {branch:e} rad");
}

/// The built-in N = 40 scene (`four-bar-n40`: 81 bodies, 242 rows, the
/// sparse paths) passes its ten passages of 10 s with DOP853 from 1e-6 to
/// 1e-12, RK4, RADAU5 and the reduced formulation (handing over to the
/// DAE) on the parallelogram branch (all 41 cranks at one angle, to
/// 1e-8 rad). Measured (2 cores): errors 3.7e-5, 3.0e-7, 1.8e-9 and
/// 1.4e-9 rad with DOP853 at 1e-6, 1e-8, 1e-10 and 1e-12 (0.14-0.20 s per
/// run), 2.4e-9 with RK4 at h = 1e-3 s (1.2 s), 3.7e-7 with RADAU5 at 1e-8,
/// 7.7e-8 reduced at 1e-8 (1.6 s), all with glibc's sines and cosines;
/// with the libm crate's and the tolerance (RK4: h) moved by 0 to 5e-13
/// of itself, six runs each: DOP853 at 1e-10 9.8e-10 to 1.4e-8, at 1e-12
/// 8.1e-10 to 1.9e-9, RK4 1.5e-9 to 1.0e-8, the cranks within 2e-10 rad
/// of each other. Bounds as for N = 2, RK4's 5e-8 (its spread here five
/// times N = 2's).
#[test]
fn the_n_four_bar_of_forty_passes_its_singular_positions() {
    let dop853 = |tol: &'static str| vec!["--rtol", tol, "--atol", tol];
    for (args, bound) in [
        (dop853("1e-6"), 2e-4),
        (dop853("1e-8"), 2e-6),
        (dop853("1e-10"), 5e-8),
        (dop853("1e-12"), FLOOR),
        (vec!["--integrator", "rk4", "--dt", "1e-3"], 5e-8),
        (vec!["--integrator", "radau5", "--rtol", "1e-8", "--atol", "1e-8"], 2e-6),
        (vec!["--formulation", "reduced", "--rtol", "1e-8", "--atol", "1e-8"], 2e-6),
    ] {
        let tol = format!("{args:?}");
        let dir = tempfile::tempdir().unwrap();
        let o = dir.path().join("out");
        let argv = ["ezy", "run", "four-bar-n40", "--no-figures", "--out", o.to_str().unwrap()]
            .into_iter()
            .chain(args.iter().copied());
        let mut out = Vec::new();
        if let Err(e) = App::new().run_cli(argv, &mut out) {
            panic!("rtol {tol}: {e}");
        }
        let text = std::fs::read_to_string(o.join("trajectory.csv")).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
        let cranks: Vec<usize> = (0..=40).map(|i| col(&format!("theta{i}"))).collect();
        let (it, mut ts, mut rows) = (col("t"), Vec::new(), Vec::new());
        for l in lines {
            let v: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
            ts.push(v[it]);
            rows.push(cranks.iter().map(|&c| v[c]).collect::<Vec<f64>>());
        }
        assert_eq!(*ts.last().unwrap(), 10.0, "rtol {tol}");
        let reference = parallelogram_n(40, std::f64::consts::FRAC_PI_2, -1.0, &ts);
        let err = rows.iter().zip(&reference).map(|(r, th)| (r[0] - th).abs()).fold(0.0, f64::max);
        let branch = rows.iter().map(|r| r.iter().map(|v| (v - r[0]).abs()).fold(0.0, f64::max)).fold(0.0, f64::max);
        assert!(err < bound, "rtol {tol}: error {err:e} against the parallelogram");
        assert!(branch < 1e-8, "rtol {tol}: cranks apart by {branch:e} rad (branch switched)");
        let early = rows.iter().zip(&reference).zip(&ts).filter(|(_, t)| **t < 0.7);
        let err = early.map(|((r, th), _)| (r[0] - th).abs()).fold(0.0, f64::max);
        let pre = before_the_first_passage(&args);
        assert!(err < pre, "rtol {tol}: error {err:e} before the first passage, above {pre:e}");
    }
}

/// Below what double precision resolves at a singular position (DOP853 at
/// rtol 1e-14 on `four-bar-n2`: the rounding of the positions, amplified
/// near the crossing, stays above the tolerance) the run stops at once
/// with an error that names the cause, not after thousands of steps at
/// the rounding level of t with "step size fell", nor with "redundant
/// constraints".
#[test]
fn a_tolerance_beyond_the_rounding_at_a_singular_position_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let argv = [
        "ezy",
        "run",
        "four-bar-n2",
        "--no-figures",
        "--rtol",
        "1e-14",
        "--atol",
        "1e-14",
        "--out",
        o.to_str().unwrap(),
    ];
    let err = App::new().run_cli(argv, &mut Vec::new()).expect_err("rtol 1e-14 is beyond rounding there").to_string();
    assert!(err.contains("next to a singular position") && err.contains("a looser tolerance"), "{err}");
    assert!(!err.contains("redundant"), "{err}");
}

/// RK4 on the reduced formulation stops before the first singular
/// passage, from the last step's start, saying why (it stopped after it,
/// from a state the failed step had half advanced, with "Newton's method
/// for the dependent coordinates did not converge").
#[test]
fn rk4_on_the_reduced_formulation_stops_before_a_passage() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let app = App::new().model::<A02N2>("a02n2").scene("scenes/a02n2.toml", SCENE);
    let argv = ["ezy", "run", "a02n2", "--integrator", "rk4", "--formulation", "reduced", "--no-figures", "--out"];
    let err = app.run_cli(argv.into_iter().chain([o.to_str().unwrap()]), &mut Vec::new()).unwrap_err().to_string();
    assert!(err.contains("a singular position is near") && err.contains("at t = 0.70"), "{err}");
}
