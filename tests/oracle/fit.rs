//! A fit's numbers (`ezy fit`, `ezy_core::design::fit::fit`: the
//! estimates, their standard errors, the residual, "converged", "at a
//! bound") against a Gauss-Newton solve written here on the same
//! residuals: `r(p)` the model's columns at the data's times less the
//! data, each evaluated by a whole run (`Problem::solve`, DOP853 at
//! 1e-13, no sensitivity equations), the Jacobian by central differences
//! of whole runs at `p +- h` and `p +- h/2` extrapolated (Richardson),
//! the Gauss-Newton steps by the normal equations solved here, from the
//! fit's start until a step is below 1e-10 of the parameter.
//!
//! The data are a run at known parameters plus deterministic
//! pseudo-noise (uniform, standard deviation 1 mm), so the minimum has a
//! residual and the standard errors `s^2 (J^T J)^-1`, `s^2 = |r|^2 / (m -
//! n)`, are numbers to check. What each comparison's tolerance rests on
//! is in its helper's docstring.

use std::path::Path;

use ezy::models::{EzyRoller, scenes};
use ezy_core::design::fit::{Data, Fit, fit};
use ezy_core::text::RuntimeModel;
use ezy_core::{Method, Model};
use ezy_scene::Scene;

/// One fitting problem: the scene (its integrator set to DOP853 at
/// 1e-12 for the fit's runs), the model, the parameters fitted with their
/// bounds, the data.
struct Case<M: Model> {
    scene: Scene,
    model: M,
    over: Vec<(String, f64, f64)>,
    data: Data,
}

/// The oracle's minimum: parameters, residuals, Jacobian (Richardson),
/// the Jacobian's own error (the extrapolation's change, largest over
/// each column relative to the column's norm), Gauss-Newton steps taken.
struct Minimum {
    p: Vec<f64>,
    r: Vec<f64>,
    j: Vec<Vec<f64>>,
    j_error: f64,
    steps: usize,
}

/// Deterministic pseudo-noise: uniform on `[-sqrt(3), sqrt(3)] sigma`
/// (standard deviation `sigma`), from a linear congruential generator
/// (Knuth's MMIX constants) seeded by `seed`.
fn noise(seed: u64, n: usize, sigma: f64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(2862933555777941757).wrapping_add(3037000493);
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            (2.0 * u - 1.0) * 3f64.sqrt() * sigma
        })
        .collect()
}

/// The scene's run at `sets`, DOP853 at `tol`, sampled every `every` s
/// to `t_end`: the columns `columns` (one list each) and the times.
fn run<M: Model>(
    scene: &Scene,
    model: &M,
    sets: &[(String, f64)],
    (t_end, every, tol): (f64, f64, f64),
    columns: &[String],
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let (problem, _) = scene.problem_with(model.clone(), sets).unwrap();
    let s = problem.t_end(t_end).every(every).method(Method::Dop853).tolerances(tol, tol).solve().unwrap();
    let cols = columns.iter().map(|c| s.column(c).unwrap_or_else(|| panic!("no column {c}"))).collect();
    (s.t, cols)
}

/// Data: the run at `truth` every `every` s to `t_end` (DOP853 at 1e-13),
/// the columns with pseudo-noise of 1 mm added.
fn data<M: Model>(scene: &Scene, model: &M, truth: &[(String, f64)], t_end: f64, every: f64, columns: &[&str]) -> Data {
    let columns: Vec<String> = columns.iter().map(|c| (*c).to_string()).collect();
    let (t, values) = run(scene, model, truth, (t_end, every, 1e-13), &columns);
    let values = values.into_iter().enumerate().map(|(c, v)| {
        let n = noise(c as u64 + 1, v.len(), 1e-3);
        v.iter().zip(n).map(|(a, b)| a + b).collect()
    });
    Data { t, columns, values: values.collect() }
}

/// The residuals at `p` by one whole run: `r = x_k(t_i; p) - y_ik`,
/// row by row (time-major, as the data's columns).
fn residuals<M: Model>(case: &Case<M>, p: &[f64]) -> Vec<f64> {
    let sets: Vec<(String, f64)> = case.over.iter().zip(p).map(|(o, v)| (o.0.clone(), *v)).collect();
    let d = &case.data;
    let t_end = *d.t.last().unwrap();
    let every = if d.t.len() > 1 { d.t[1] - d.t[0] } else { t_end };
    let (t, cols) = run(&case.scene, &case.model, &sets, (t_end, every, 1e-13), &d.columns);
    // each data time a sample of the run
    let at: Vec<usize> =
        d.t.iter()
            .map(|td| {
                t.iter().position(|ts| (ts - td).abs() <= 1e-12).expect("the oracle's run does not sample a data time")
            })
            .collect();
    (0..at.len())
        .flat_map(|i| (0..cols.len()).map(move |c| (i, c)))
        .map(|(i, c)| cols[c][at[i]] - d.values[c][i])
        .collect()
}

/// Central differences of whole runs in parameter `k` at step `h`.
fn column<M: Model>(case: &Case<M>, p: &[f64], k: usize, h: f64) -> Vec<f64> {
    let (mut a, mut b) = (p.to_vec(), p.to_vec());
    a[k] += h;
    b[k] -= h;
    let (ra, rb) = (residuals(case, &a), residuals(case, &b));
    ra.iter().zip(&rb).map(|(x, y)| (x - y) / (2.0 * h)).collect()
}

/// The Jacobian at `p` (columns), by central differences at `h = 1e-4
/// max(1, |p_k|)` and `h/2` extrapolated (Richardson); and the largest
/// change the extrapolation made, relative to its column's norm (the
/// differences' own error: truncation `O(h^4)` after the extrapolation,
/// the runs' error at 1e-13 over `h`, about 1e-9 of a column).
fn jacobian<M: Model>(case: &Case<M>, p: &[f64]) -> (Vec<Vec<f64>>, f64) {
    let mut worst = 0.0f64;
    let j = (0..p.len())
        .map(|k| {
            let h = 1e-4 * p[k].abs().max(1.0);
            let (d1, d2) = (column(case, p, k, h), column(case, p, k, h / 2.0));
            let c: Vec<f64> = d1.iter().zip(&d2).map(|(a, b)| b + (b - a) / 3.0).collect();
            let change = c.iter().zip(&d2).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
            worst = worst.max(change / norm(&c));
            c
        })
        .collect();
    (j, worst)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves `a x = b` (n x n) by Gaussian elimination with partial
/// pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs())).unwrap();
        a.swap(c, p);
        b.swap(c, p);
        assert!(a[c][c] != 0.0, "singular normal equations");
        let pivot = a[c].clone();
        for r in c + 1..n {
            let f = a[r][c] / pivot[c];
            a[r].iter_mut().zip(&pivot).skip(c).for_each(|(x, y)| *x -= f * y);
            b[r] -= f * b[c];
        }
    }
    for c in (0..n).rev() {
        b[c] = (b[c] - (c + 1..n).map(|k| a[c][k] * b[k]).sum::<f64>()) / a[c][c];
    }
    b
}

/// `J^T J` of the columns `j`.
fn normal(j: &[Vec<f64>]) -> Vec<Vec<f64>> {
    j.iter().map(|a| j.iter().map(|b| dot(a, b)).collect()).collect()
}

/// Gauss-Newton from `p0` over the parameters `free` (the others held at
/// `p0`'s values): `J^T J d = -J^T r` with the Jacobian by plain central
/// differences (h = 1e-4 max(1, |p|)), the step halved while it leaves
/// the bounds or does not lower `|r|` (a long first step from a far
/// start), until every step is below 1e-10 of its parameter; then the
/// residuals and the Richardson Jacobian (every parameter's column) at
/// the minimum.
fn gauss_newton<M: Model>(case: &Case<M>, p0: &[f64], free: &[usize]) -> Minimum {
    let mut p = p0.to_vec();
    let mut steps = 0;
    let inside = |p: &[f64]| case.over.iter().zip(p).all(|(o, v)| (o.1..=o.2).contains(v));
    let mut r = residuals(case, &p);
    loop {
        let j: Vec<Vec<f64>> = free.iter().map(|&k| column(case, &p, k, 1e-4 * p[k].abs().max(1.0))).collect();
        let g: Vec<f64> = j.iter().map(|c| -dot(c, &r)).collect();
        let mut d = solve(normal(&j), g);
        let last = loop {
            let mut trial = p.clone();
            for (&k, dk) in free.iter().zip(&d) {
                trial[k] += dk;
            }
            let small = free.iter().zip(&d).all(|(&k, dk)| dk.abs() <= 1e-10 * p[k].abs());
            if inside(&trial) {
                let rt = residuals(case, &trial);
                // at the minimum |r| no longer falls: a step below the
                // tolerance is taken as it is
                if small || norm(&rt) < norm(&r) {
                    (p, r) = (trial, rt);
                    break small;
                }
            }
            d.iter_mut().for_each(|x| *x /= 2.0);
            assert!(d.iter().any(|x| *x != 0.0), "Gauss-Newton's step vanished at {p:?}");
        };
        steps += 1;
        if last {
            break;
        }
        assert!(steps < 50, "Gauss-Newton did not settle: {p:?}, last step {d:?}");
    }
    let (j, j_error) = jacobian(case, &p);
    Minimum { p, r, j, j_error, steps }
}

/// The standard errors `sqrt(diag(s^2 (J^T J)^-1))`, `s^2 = |r|^2 / (m -
/// n)`, of the parameters `free` (their columns of `j`).
fn std_errors(r: &[f64], j: &[Vec<f64>], free: &[usize]) -> Vec<f64> {
    let n = free.len();
    let s2 = dot(r, r) / (r.len() - n) as f64;
    let cols: Vec<Vec<f64>> = free.iter().map(|&k| j[k].clone()).collect();
    let jtj = normal(&cols);
    (0..n)
        .map(|k| {
            let e: Vec<f64> = (0..n).map(|i| if i == k { 1.0 } else { 0.0 }).collect();
            (s2 * solve(jtj.clone(), e)[k]).sqrt()
        })
        .collect()
}

/// The correlations of the parameters `free`: `(J^T J)^-1` normalized
/// (`s^2` cancels).
fn correlations(j: &[Vec<f64>], free: &[usize]) -> Vec<Vec<f64>> {
    let cols: Vec<Vec<f64>> = free.iter().map(|&k| j[k].clone()).collect();
    let jtj = normal(&cols);
    let n = free.len();
    let inv: Vec<Vec<f64>> =
        (0..n).map(|k| solve(jtj.clone(), (0..n).map(|i| if i == k { 1.0 } else { 0.0 }).collect())).collect();
    (0..n).map(|a| (0..n).map(|b| inv[a][b] / (inv[a][a] * inv[b][b]).sqrt()).collect()).collect()
}

/// The gradient's components as angles: `J_k^T r / (|J_k| |r|)`, the
/// first-order condition's measure free of the parameters' units; its
/// sign is that of `d|r|^2/dp_k`.
fn gradient_angles(j: &[Vec<f64>], r: &[f64]) -> Vec<f64> {
    j.iter().map(|c| dot(c, r) / (norm(c) * norm(r))).collect()
}

/// The first-order condition at `p` over the parameters `free`: the
/// Gauss-Newton step `-(J^T J)^-1 J^T r` that would reach the stationary
/// point, each component in units of its standard error, by the oracle's
/// residuals and Jacobian at `p`; and the gradient angles of every
/// parameter there.
fn first_order<M: Model>(case: &Case<M>, p: &[f64], free: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let r = residuals(case, p);
    let (j, _) = jacobian(case, p);
    let cols: Vec<Vec<f64>> = free.iter().map(|&k| j[k].clone()).collect();
    let d = solve(normal(&cols), cols.iter().map(|c| -dot(c, &r)).collect());
    let se = std_errors(&r, &j, free);
    (d.iter().zip(&se).map(|(a, b)| a / b).collect(), gradient_angles(&j, &r))
}

/// How far an estimate may lie from the oracle's: 1e-8 of its value
/// (the fit's runs at 1e-12 shift the minimum by about `(J^T J)^-1 J^T
/// dr`, 1e-10 relative here) plus 1e-5 of its standard error. The second
/// is where Levenberg-Marquardt's `ftol` of 1e-12 lets it stop: a point
/// `d` from the minimum along a parameter costs `(d / se)^2 s^2 / 2` more
/// than the minimum's `(m - n) s^2 / 2`, a relative reduction of `(d /
/// se)^2 / (m - n)` still to make, below 1e-12 for `d < sqrt(m - n) 1e-6
/// se` (9e-6 se with the 80 degrees of freedom here; measured 2e-8 se
/// inside the bounds, 6e-7 se at one).
fn estimate_tolerance(p: f64, se: f64) -> f64 {
    1e-8 * p.abs() + 1e-5 * se
}

/// Checks a fit of an interior minimum against the oracle: each estimate
/// within [`estimate_tolerance`]; `|r|^2` and each column's rms to 1e-8
/// (second order in the estimates' difference, first order in the runs'
/// error); the standard errors to 1e-6 relative and the correlations to
/// 1e-6 (the Jacobians' errors:
/// the fit's sensitivities at 1e-12, the differences' at most 1e-7 of a
/// column, asserted, measured 1e-9 to 1e-8; the covariance is quadratic
/// in `J`); the convergence claim (the termination is `Converged`)
/// against the first-order condition at the fit's own estimate: the
/// Gauss-Newton step from there below 1e-5 of a standard error, as
/// [`estimate_tolerance`] (measured 2e-8).
fn check_interior<M: Model>(case: &Case<M>, f: &Fit, min: &Minimum) {
    let n = min.p.len();
    let all: Vec<usize> = (0..n).collect();
    let se = std_errors(&min.r, &min.j, &all);
    eprintln!("oracle: {:?} in {} Gauss-Newton steps, Jacobian error {:.1e}", min.p, min.steps, min.j_error);
    eprintln!("fit: {:?} +- {:?} in {} runs ({})", f.estimate, f.std_error, f.runs, f.termination);
    assert!(min.j_error <= 1e-7, "the differences did not settle: {:.1e}", min.j_error);
    for (k, &sek) in se.iter().enumerate() {
        let off = (f.estimate[k] - min.p[k]).abs();
        eprintln!(
            "{}: {:.15e} against {:.15e} ({:.1e} relative, {:.1e} standard errors)",
            f.names[k],
            f.estimate[k],
            min.p[k],
            off / min.p[k].abs(),
            off / sek
        );
        assert!(
            off <= estimate_tolerance(min.p[k], sek),
            "{}: estimate {} against {}",
            f.names[k],
            f.estimate[k],
            min.p[k]
        );
        assert!(!f.at_bound[k], "{}: at a bound, inside {:?}", f.names[k], case.over[k]);
    }
    let rss = dot(&min.r, &min.r);
    let off = (2.0 * f.cost - rss).abs() / rss;
    eprintln!("|r|^2: {:.15e} against {rss:.15e} ({off:.1e})", 2.0 * f.cost);
    assert!(off <= 1e-8, "|r|^2 = {} against Gauss-Newton's {rss}", 2.0 * f.cost);
    // the rms per column is |r| of the column over sqrt(rows)
    let cols = case.data.columns.len();
    for (c, rms) in f.residual_rms.iter().enumerate() {
        let mine = (min.r.iter().skip(c).step_by(cols).map(|x| x * x).sum::<f64>() / case.data.t.len() as f64).sqrt();
        assert!((rms - mine).abs() <= 1e-8 * mine, "{}: rms {rms} against {mine}", case.data.columns[c]);
    }
    for (k, se) in se.iter().enumerate() {
        let off = (f.std_error[k] - se).abs() / se;
        eprintln!("{}: standard error {:.12e} against {se:.12e} ({off:.1e})", f.names[k], f.std_error[k]);
        assert!(off <= 1e-6, "{}: standard error {} against {se}", f.names[k], f.std_error[k]);
    }
    for (a, row) in correlations(&min.j, &all).iter().enumerate() {
        for (b, c) in row.iter().enumerate() {
            assert!(
                (f.correlation[a][b] - c).abs() <= 1e-6,
                "correlation {a} {b}: {} against {c}",
                f.correlation[a][b]
            );
        }
    }
    assert!(f.termination.starts_with("Converged"), "the fit does not claim convergence: {}", f.termination);
    let (step, _) = first_order(case, &f.estimate, &all);
    eprintln!("the Gauss-Newton step from the fit's estimate, in standard errors: {step:?}");
    assert!(step.iter().all(|d| d.abs() <= 1e-5), "not a stationary point: {step:?}");
}

/// The rolling-resistance EzyRoller over 4 s, data (x1, y1) every 0.1 s
/// at the front skate's damping 1.3 N s/m and the motor's amplitude 2.4
/// N m (the scene has 1 and 2), fitted over `over`.
fn roller(over: &[(&str, f64, f64)]) -> Case<EzyRoller> {
    let mut scene = scenes::get("drive-rolling-resistance");
    tighten(&mut scene);
    let model = EzyRoller::default();
    let truth = [("rolling_A.damping".to_string(), 1.3), ("motor.amplitude".to_string(), 2.4)];
    let data = data(&scene, &model, &truth, 4.0, 0.1, &["x1", "y1"]);
    let over = over.iter().map(|(n, a, b)| ((*n).to_string(), *a, *b)).collect();
    Case { scene, model, over, data }
}

/// The fit's runs at DOP853 1e-12 (the scene's own settings otherwise).
fn tighten(scene: &mut Scene) {
    scene.integrator.method = Method::Dop853;
    scene.integrator.rtol = 1e-12;
    scene.integrator.atol = 1e-12;
}

/// The fit of `case` through the library, from the scene's values.
fn fitted<M: Model>(case: &Case<M>) -> Fit {
    let design = case.scene.design(&case.model, &[], &case.over).unwrap();
    fit(&design, &case.data, None).unwrap()
}

/// The data as a CSV file `t, columns..` (each number to the bit).
fn write_data(data: &Data, path: &Path) {
    let mut text = format!("t,{}\n", data.columns.join(","));
    for (i, t) in data.t.iter().enumerate() {
        let row: Vec<String> =
            std::iter::once(*t).chain(data.values.iter().map(|v| v[i])).map(|v| format!("{v:e}")).collect();
        text.push_str(&row.join(","));
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// `ezy fit drive-rolling-resistance` on `case`'s data (written as a
/// CSV file, every number to the bit) over `over` (`NAME=LO:HI`), at
/// DOP853 1e-12: what it printed and fit.csv's rows (name, estimate,
/// standard error).
fn cli_fit(case: &Case<EzyRoller>, what: &str, over: &[&str]) -> (String, Vec<(String, f64, f64)>) {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("oracle-fit-{what}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("data.csv");
    write_data(&case.data, &file);
    let out = dir.join("fit");
    let mut args = vec!["fit", "drive-rolling-resistance", "--data", file.to_str().unwrap(), "--columns", "x1,y1"];
    for o in over {
        args.extend(["--over", o]);
    }
    args.extend(["--integrator", "dop853", "--rtol", "1e-12", "--atol", "1e-12", "--no-figures"]);
    args.extend(["--out", out.to_str().unwrap()]);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(&args).output().unwrap();
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success(), "{said}{}", String::from_utf8_lossy(&o.stderr));
    eprintln!("{said}");
    let table = std::fs::read_to_string(out.join("fit.csv")).unwrap();
    let rows = table
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            // an undetermined standard error is an empty cell: NaN here
            (c[0].to_string(), c[1].parse().unwrap(), if c[2].is_empty() { f64::NAN } else { c[2].parse().unwrap() })
        })
        .collect();
    let _ = std::fs::remove_dir_all(&dir);
    (said, rows)
}

/// `ezy fit` on the rolling-resistance EzyRoller's noisy data through
/// the command line: fit.csv's estimates and standard errors (to the bit
/// as written) against Gauss-Newton's, with the tolerances of
/// [`check_interior`], and the printed claim (`Converged`, no bound);
/// then the library's fit against the same oracle ([`check_interior`]).
#[test]
fn a_fit_is_the_gauss_newton_minimum_of_its_residuals() {
    let case = roller(&[("rolling_A.damping", 0.0, 5.0), ("motor.amplitude", 1.0, 3.0)]);
    let (said, rows) = cli_fit(&case, "interior", &["rolling_A.damping=0:5", "motor.amplitude=1:3"]);
    let min = gauss_newton(&case, &[1.0, 2.0], &[0, 1]);
    let se = std_errors(&min.r, &min.j, &[0, 1]);
    assert_eq!(rows.len(), 2);
    for (k, (name, e, s)) in rows.iter().enumerate() {
        assert_eq!(name, &case.over[k].0);
        eprintln!("fit.csv {name}: {e:.15e} +- {s:.12e}; Gauss-Newton {:.15e} +- {:.12e}", min.p[k], se[k]);
        assert!((e - min.p[k]).abs() <= estimate_tolerance(min.p[k], se[k]), "{name}: {e} against {}", min.p[k]);
        assert!((s - se[k]).abs() <= 1e-6 * se[k], "{name}: standard error {s} against {}", se[k]);
    }
    assert!(said.contains("Converged") && !said.contains("at a bound"), "{said}");
    let f = fitted(&case);
    check_interior(&case, &f, &min);
}

/// A bound that excludes the minimum: the motor's amplitude over
/// `1:2.38` (the unbounded fit's is 2.396, 2.3 standard errors above).
/// The fit must end at the bound and say so (`at_bound`; `ezy fit`
/// prints "at a bound" on that parameter's line alone, and writes the
/// same estimates to fit.csv), and the oracle confirms it is the
/// constrained minimum: Gauss-Newton over the damping alone with the
/// amplitude held at 2.38 gives the fit's damping (within
/// [`estimate_tolerance`]) and residual (to 1e-8); at the fit's estimate
/// the damping's Gauss-Newton step is below 1e-5 of its standard error
/// while the amplitude's gradient points out of the bound (`d|r|^2/dp <
/// 0` at an upper bound: the residual falls beyond it) and is not small
/// (its angle above 1e-3: a bound that binds).
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn a_fit_at_a_bound_is_the_constrained_minimum() {
    let case = roller(&[("rolling_A.damping", 0.0, 5.0), ("motor.amplitude", 1.0, 2.38)]);
    let f = fitted(&case);
    let min = gauss_newton(&case, &[1.0, 2.38], &[0]);
    let se = std_errors(&min.r, &min.j, &[0])[0];
    eprintln!("fit: {:?} (at bound {:?}) in {} runs ({})", f.estimate, f.at_bound, f.runs, f.termination);
    eprintln!("oracle: {:?} in {} steps", min.p, min.steps);
    assert!(!f.at_bound[0] && f.at_bound[1], "{:?}", f.at_bound);
    assert!((f.estimate[1] - 2.38).abs() <= 1e-9 * 1.38, "amplitude {} not at its bound 2.38", f.estimate[1]);
    let off = (f.estimate[0] - min.p[0]).abs();
    eprintln!("damping {:.15e} against {:.15e} ({:.1e} standard errors)", f.estimate[0], min.p[0], off / se);
    assert!(off <= estimate_tolerance(min.p[0], se), "damping {} against {}", f.estimate[0], min.p[0]);
    let rss = dot(&min.r, &min.r);
    assert!((2.0 * f.cost - rss).abs() <= 1e-8 * rss, "|r|^2 {} against {rss}", 2.0 * f.cost);
    let (step, angles) = first_order(&case, &f.estimate, &[0]);
    eprintln!("at the fit's estimate: the damping's step {step:?} standard errors, gradient angles {angles:?}");
    assert!(step[0].abs() <= 1e-5, "the damping is not at its minimum: {step:?}");
    assert!(angles[1] < -1e-3, "the amplitude's gradient does not point out of its upper bound: {angles:?}");
    let (said, rows) = cli_fit(&case, "bound", &["rolling_A.damping=0:5", "motor.amplitude=1:2.38"]);
    assert!((rows[0].1 - min.p[0]).abs() <= estimate_tolerance(min.p[0], se), "{rows:?}");
    assert!((rows[1].1 - 2.38).abs() <= 1.38e-9, "{rows:?}");
    let line = |name: &str| said.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("{said}"));
    assert!(
        line("motor.amplitude = ").contains("at a bound") && !line("rolling_A.damping = ").contains("at a bound"),
        "{said}"
    );
}

/// A user's sleigh with a torque-driven rotor, typed as text
/// (`tests/data/oracle/rotor_sleigh.ezy`, its scene beside it): the
/// linear drag `drag.c` and the sleigh's inertia `I` fitted to (x, y)
/// every 0.1 s over 6 s made at `drag.c = 0.7`, `I = 0.13` (the scene has
/// 0.5 and 0.1), as [`check_interior`].
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn a_fit_of_a_model_typed_as_text_is_the_gauss_newton_minimum() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&dir.join("rotor_sleigh.ezy")).unwrap();
    let (mut scene, _) = Scene::read(&dir.join("rotor-sleigh.toml")).unwrap();
    tighten(&mut scene);
    let truth = [("drag.c".to_string(), 0.7), ("I".to_string(), 0.13)];
    let data = data(&scene, &model, &truth, 6.0, 0.1, &["x", "y"]);
    let over = vec![("drag.c".to_string(), 0.1, 2.0), ("I".to_string(), 0.02, 0.5)];
    let case = Case { scene, model, over, data };
    let f = fitted(&case);
    let min = gauss_newton(&case, &[0.5, 0.1], &[0, 1]);
    check_interior(&case, &f, &min);
}

/// No degree of freedom: one data row (x1, y1 at t = 2 s, without noise:
/// the square system's solution is then the data's parameters, inside
/// the bounds) for the two parameters. Gauss-Newton reaches `r = 0`; the
/// fit's estimates are that solution (to 1e-8 relative: the residual
/// left is zero, so only the fit's runs at 1e-12 and its step tolerance
/// separate them) with `|r|` below 1e-10 m, and the standard errors are
/// undetermined (NaN, `None`), as `ezy fit` prints them ("standard error
/// undetermined", an empty cell in fit.csv), never a number; the
/// correlations, which `s^2` cancels from, are the oracle's (to 1e-6).
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn a_fit_without_a_degree_of_freedom_is_the_exact_solution_its_errors_undetermined() {
    let mut case = roller(&[("rolling_A.damping", 0.0, 5.0), ("motor.amplitude", 1.0, 3.0)]);
    let truth = [("rolling_A.damping".to_string(), 1.3), ("motor.amplitude".to_string(), 2.4)];
    let (t, values) = run(&case.scene, &case.model, &truth, (2.0, 2.0, 1e-13), &case.data.columns);
    case.data.t = vec![t[1]];
    case.data.values = values.iter().map(|v| vec![v[1]]).collect();
    let f = fitted(&case);
    let min = gauss_newton(&case, &[1.0, 2.0], &[0, 1]);
    eprintln!(
        "fit: {:?} +- {:?} ({}); Gauss-Newton {:?}, |r| {:.1e}",
        f.estimate,
        f.std_error,
        f.termination,
        min.p,
        norm(&min.r)
    );
    assert!(norm(&min.r) <= 1e-10 && (2.0 * f.cost).sqrt() <= 1e-10, "not an exact solution: {:e}", f.cost);
    for k in 0..2 {
        assert!(
            (f.estimate[k] - min.p[k]).abs() <= 1e-8 * min.p[k],
            "{}: {} against {}",
            f.names[k],
            f.estimate[k],
            min.p[k]
        );
        assert!(f.std_error[k].is_nan() && f.std_error_of(k).is_none(), "{}: {}", f.names[k], f.std_error[k]);
    }
    // the correlations do not need s^2: determined (ezy gave NaN)
    let corr = correlations(&min.j, &[0, 1]);
    eprintln!("correlations {:?} against {corr:?}", f.correlation);
    assert!((f.correlation[0][1] - corr[0][1]).abs() <= 1e-6 && f.correlation[0][0] == 1.0, "{:?}", f.correlation);
    let (said, rows) = cli_fit(&case, "square", &["rolling_A.damping=0:5", "motor.amplitude=1:3"]);
    assert_eq!(said.matches("standard error undetermined").count(), 2, "{said}");
    for (k, (name, e, se)) in rows.iter().enumerate() {
        assert!((e - min.p[k]).abs() <= 1e-8 * min.p[k] && se.is_nan(), "{name}: {e} +- {se}");
    }
}
