//! The bifurcations `ezy analyze --continue` reports (folds, branch
//! points, period doublings) and every stability it prints on a branch,
//! against spectra the oracle computes itself: an equilibrium's Jacobian
//! by central differences of the right-hand side (`Analysis::rhs`), a
//! periodic orbit's period map by central differences of whole runs over
//! one period from the orbit's state (`Analysis::end_state`, DOP853 at
//! 1e-13, the state alone: no variational equations, no shooting),
//! extrapolated (Richardson: the Jacobian from two steps, the period map
//! from three, its two extrapolations' gap its error). Neither shares
//! code with the continuation, its spectra or its classification.
//!
//! The oracle restricts the map to the constraints' tangent space (a
//! basis from differences of the constraint residuals) and takes out what
//! the scene's structure makes neutral, determined here from the model's
//! bodies and coordinates and certified on the oracle's own map: the
//! plane's rigid motions (every body translated, every body rotated about
//! the origin) and a cyclic coordinate with the rate nothing feels span a
//! subspace the map must keep (asserted), and the multipliers that can
//! change are those of the quotient by it.
//!
//! At each row of `branch.csv` the printed state must be a solution to
//! the oracle (an orbit's runs return to it, an equilibrium's right-hand
//! side vanishes), the printed spectrum must be the oracle's, and the
//! printed stability must hold with the oracle's margin. At each reported
//! bifurcation, solutions found on their own (the library's single-point
//! search, not the continuation) at `P* +- d` must show exactly one real
//! multiplier crossing +1 or -1 (a real eigenvalue crossing 0) between
//! them, the others staying on their side; the location must agree with
//! the oracle's own crossing, bisected; at a fold the parameter must turn
//! and no solution exist beyond it. Between two rows without a reported
//! bifurcation the oracle's count of unstable directions must not change.

use ezy::models::{EzyRoller, Pendulum, scenes};
use ezy_core::analysis::{Analysis, PeriodicSettings, c64};
use ezy_core::faer::Mat;
use ezy_core::integrator::Tolerance;
use ezy_core::text::RuntimeModel;
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

use crate::analysis::{ezy, fresh, table};

/// A scene continued in a parameter, and what the oracle knows of it.
pub(super) struct Case<M: Model> {
    /// The scene, as `ezy analyze` reads it.
    pub(super) scene: Scene,
    /// Its model at the defaults.
    pub(super) model: M,
    /// The path or name `ezy analyze` is given.
    pub(super) file: String,
    /// The parameter continued (a `--set` name).
    pub(super) param: &'static str,
    /// Whether the branch is one of periodic orbits (else equilibria).
    pub(super) periodic: bool,
    /// Whether the plane's rigid motions act on every body (a vehicle on
    /// the ground, no force fixed in space).
    pub(super) plane: bool,
    /// Cyclic coordinates whose rate nothing else feels (a balanced
    /// rotor driven by a torque given in time).
    pub(super) cyclic: &'static [&'static str],
    /// Whether the scene is autonomous and the orbit a limit cycle: the
    /// flow's direction `f(x)` is a multiplier 1 of its own (a shift in
    /// time), kept by the map and left out as the structure's.
    pub(super) autonomous: bool,
    /// Whole turns an angle makes per period (a crank's limit cycle,
    /// `turns_<coordinate>` of `periodic.csv`): the map takes them off.
    pub(super) turns: Vec<(String, f64)>,
}

/// One row of `branch.csv`.
#[derive(Debug, Clone)]
pub(super) struct Row {
    pub(super) value: f64,
    pub(super) stability: String,
    pub(super) period: Option<f64>,
    /// The phase \[s\] the state is at (0 for an equilibrium).
    pub(super) t0: f64,
    pub(super) state: Vec<f64>,
    pub(super) spectrum: Vec<c64>,
    /// The bifurcation's kind and critical value, on a bifurcation's row.
    pub(super) bifurcation: Option<(String, c64)>,
}

/// What the oracle computes at a solution.
pub(super) struct Spectrum {
    /// The quotient's eigenvalues \[1/s\] or multipliers.
    pub(super) values: Vec<c64>,
    /// The oracle's error bound on each: the largest change of an
    /// eigenvalue between its two estimates of the map (an equilibrium's:
    /// the extrapolated differences and those at the smaller step; an
    /// orbit's: the two extrapolations), floored at 1e-10.
    pub(super) error: f64,
    /// How far the state is from a solution: `|h^-1 Phi(x) - x|` of an
    /// orbit, `|f(x)|` of an equilibrium.
    pub(super) residual: f64,
}

/// DOP853 at 1e-13 for the oracle's whole runs; Newton to 1e-11 for
/// its single-point searches ([`solve_at`]: 1e-12 does not converge
/// next to a branch point, where the period map's error stays near it).
fn tight() -> PeriodicSettings {
    PeriodicSettings {
        tolerance: Tolerance { rtol: 1e-13, atol: 1e-13 },
        max_steps: 1_000_000,
        newton_tolerance: 1e-11,
    }
}

/// Singular values (largest first) and the full `U`, `V` of `m`.
fn svd(m: &Mat<f64>) -> (Vec<f64>, Mat<f64>, Mat<f64>) {
    let s = m.svd().unwrap();
    (s.S().column_vector().iter().copied().collect(), s.U().to_owned(), s.V().to_owned())
}

/// The largest absolute entry of `v`.
fn norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

impl<M: Model> Case<M> {
    /// The scene's analysis with the parameter at `value`.
    fn analysis(&self, value: f64) -> Analysis<M> {
        // no parameter (a single point): the scene as it is
        let sets: Vec<(String, f64)> =
            if self.param.is_empty() { Vec::new() } else { vec![(self.param.to_string(), value)] };
        let (problem, _) = self.scene.problem_with(self.model.clone(), &sets).unwrap();
        problem.analysis().unwrap().0
    }

    /// An orthonormal basis (2nq x d) of the tangent space of the
    /// constraint manifold at `x`: the null space of the constraint
    /// residuals' Jacobian, by central differences (step 1e-6, error
    /// about 1e-11 against singular values of order 1).
    fn tangent(&self, an: &Analysis<M>, t: f64, x: &[f64]) -> Mat<f64> {
        let n = x.len();
        let m = an.constraint_residual(t, x).unwrap().len();
        let mut c = Mat::<f64>::zeros(m.max(1), n);
        for j in 0..n {
            let h = 1e-6 * x[j].abs().max(1.0);
            let (mut p, mut q) = (x.to_vec(), x.to_vec());
            p[j] += h;
            q[j] -= h;
            let (rp, rq) = (an.constraint_residual(t, &p).unwrap(), an.constraint_residual(t, &q).unwrap());
            for i in 0..m {
                c[(i, j)] = (rp[i] - rq[i]) / (2.0 * h);
            }
        }
        let (s, _, v) = svd(&c);
        let rank = s.iter().filter(|&&v| v > 1e-8 * s[0].max(1e-300)).count();
        Mat::from_fn(n, n - rank, |i, j| v[(i, rank + j)])
    }

    /// The directions the structure makes neutral at `x` (2nq each): the
    /// plane's translations and rotation acting on every body, each
    /// cyclic coordinate's direction and its rate's.
    fn structural(&self, an: &mut Analysis<M>, x: &[f64]) -> Vec<Vec<f64>> {
        let flow = self.autonomous.then(|| an.rhs(0.0, x).unwrap());
        let info = &an.dynamics().info;
        let (n, nq) = (x.len(), info.nq());
        let mut out = Vec::new();
        if self.plane {
            let mut tx = vec![0.0; n];
            let mut ty = vec![0.0; n];
            let mut rot = vec![0.0; n];
            for b in &info.bodies {
                let [i, j, k] = b.coords;
                tx[i] = 1.0;
                ty[j] = 1.0;
                (rot[i], rot[j], rot[k]) = (-x[j], x[i], 1.0);
                (rot[nq + i], rot[nq + j]) = (-x[nq + j], x[nq + i]);
            }
            out.extend([tx, ty, rot]);
        }
        out.extend(flow);
        for name in self.cyclic {
            let k = info.coord_index(name).unwrap();
            out.push((0..n).map(|i| f64::from(u8::from(i == k))).collect());
            out.push((0..n).map(|i| f64::from(u8::from(i == nq + k))).collect());
        }
        out
    }
}

/// `g . x` for the rigid motion `g(p) = R(theta) p + b` of the plane:
/// every body's position and heading moved, its velocity turned.
fn act(bodies: &[[usize; 3]], theta: f64, b: [f64; 2], x: &[f64]) -> Vec<f64> {
    let nq = x.len() / 2;
    let (s, c) = theta.sin_cos();
    let mut y = x.to_vec();
    for &[i, j, k] in bodies {
        (y[i], y[j]) = (c * x[i] - s * x[j] + b[0], s * x[i] + c * x[j] + b[1]);
        y[k] = x[k] + theta;
        (y[nq + i], y[nq + j]) = (c * x[nq + i] - s * x[nq + j], s * x[nq + i] + c * x[nq + j]);
    }
    y
}

/// The oracle's spectrum of the periodic orbit through `x` at `value`
/// (period `period`, phase `t0`): the period map `P(y) = h^-1 Phi(y)`,
/// `Phi` a whole run over one period from `t0`, `h` the rigid motion that
/// carries the reference body's pose at `x` to its pose at `Phi(x)` (the
/// identity without the plane's symmetry); its columns on the tangent
/// basis by central differences at `4e-3`, `2e-3` and `1e-3`, each pair
/// extrapolated (Richardson: the error `O(h^4)`, 1e-11 at these steps,
/// where a run's error over the step, 1e-13 / 1e-3, stays near 1e-10;
/// the smaller steps' noise made the multipliers 1e-7 off on the forced
/// pendulum); restricted to the tangent space (which it must keep,
/// asserted) and taken modulo the structural subspace (which it must
/// keep, asserted). The error is the spectra's change between the two
/// extrapolations. Returns the spectrum and the map on the tangent basis.
fn periodic_spectrum<M: Model>(case: &Case<M>, value: f64, period: f64, t0: f64, x: &[f64]) -> (Spectrum, Mat<f64>) {
    let mut an = case.analysis(value);
    let bodies: Vec<[usize; 3]> = an.dynamics().info.bodies.iter().map(|b| b.coords).collect();
    let info = &an.dynamics().info;
    let turns: Vec<(usize, f64)> =
        case.turns.iter().map(|(c, n)| (info.coord_index(c).unwrap(), std::f64::consts::TAU * n)).collect();
    let tangent = case.tangent(&an, t0, x);
    let (n, d) = (x.len(), tangent.ncols());
    let mut run = |y: &[f64]| an.end_state(t0, y, period, &tight()).unwrap().0;
    let end = run(x);
    // h carries the reference body's pose at x to its pose at Phi(x)
    let (inverse_theta, inverse_b) = if case.plane {
        let [i, j, k] = bodies[0];
        let theta = end[k] - x[k];
        let (s, c) = theta.sin_cos();
        let b = [end[i] - (c * x[i] - s * x[j]), end[j] - (s * x[i] + c * x[j])];
        (-theta, [-(c * b[0] + s * b[1]), -(-s * b[0] + c * b[1])])
    } else {
        (0.0, [0.0; 2])
    };
    let map = |y: Vec<f64>| {
        let mut y = if case.plane { act(&bodies, inverse_theta, inverse_b, &y) } else { y };
        turns.iter().for_each(|(k, a)| y[*k] -= a);
        y
    };
    let back = map(end);
    let residual = norm(&back.iter().zip(x).map(|(a, b)| a - b).collect::<Vec<_>>());
    let mut column = |j: usize, h: f64| {
        let p: Vec<f64> = (0..n).map(|i| x[i] + h * tangent[(i, j)]).collect();
        let m: Vec<f64> = (0..n).map(|i| x[i] - h * tangent[(i, j)]).collect();
        let (fp, fm) = (map(run(&p)), map(run(&m)));
        fp.iter().zip(&fm).map(|(a, b)| (a - b) / (2.0 * h)).collect::<Vec<_>>()
    };
    let (mut fine, mut coarse) = (Mat::<f64>::zeros(n, d), Mat::<f64>::zeros(n, d));
    for j in 0..d {
        let (d1, d2, d3) = (column(j, 4e-3), column(j, 2e-3), column(j, 1e-3));
        for i in 0..n {
            coarse[(i, j)] = d2[i] + (d2[i] - d1[i]) / 3.0;
            fine[(i, j)] = d3[i] + (d3[i] - d2[i]) / 3.0;
        }
    }
    let structural = case.structural(&mut an, x);
    let label = format!("{} at {} = {value}", case.scene.name, case.param);
    let spectrum = quotient(&label, &tangent, &fine, &coarse, &structural, residual);
    (spectrum, tangent.transpose() * &fine)
}

/// The oracle's spectrum of the equilibrium `x` at `value`: the
/// Jacobian by central differences of the right-hand side
/// ([`super::linearization::differences`]), restricted to the tangent
/// space. A scene without symmetry only (its equilibria are points).
fn steady_spectrum<M: Model>(case: &Case<M>, value: f64, x: &[f64]) -> Spectrum {
    assert!(!case.plane && case.cyclic.is_empty(), "relative equilibria are not the oracle's yet");
    let mut an = case.analysis(value);
    let residual = norm(&an.rhs(0.0, x).unwrap());
    let (a, half) = super::linearization::differences(&mut an, 0.0, x, 1);
    let tangent = case.tangent(&an, 0.0, x);
    let (at, at2) = (&a * &tangent, &half * &tangent);
    let label = format!("{} at {} = {value}", case.scene.name, case.param);
    quotient(&label, &tangent, &at, &at2, &[], residual)
}

/// The spectrum of the map whose columns on the orthonormal tangent
/// basis `tangent` (n x d) are `mt` (n x d; `mt2` the same by the
/// oracle's other differences, their gap its error), modulo the span of
/// `structural`: the map must keep the
/// tangent space (`|mt - T T^T mt|` below 1e-7 of it) and the structural
/// subspace (its component off it below 1e-7 of the map), and the
/// quotient's eigenvalues are returned with the oracle's error.
fn quotient(
    label: &str,
    tangent: &Mat<f64>,
    mt: &Mat<f64>,
    mt2: &Mat<f64>,
    structural: &[Vec<f64>],
    residual: f64,
) -> Spectrum {
    let (n, d) = (tangent.nrows(), tangent.ncols());
    let r = tangent.transpose() * mt;
    let off = mt - tangent * &r;
    let size = r.norm_max().max(1.0);
    assert!(off.norm_max() <= 1e-7 * size, "{label}: the map leaves the tangent space by {:.1e}", off.norm_max());
    let k = structural.len();
    let s = Mat::from_fn(n, k.max(1), |i, j| if j < k { structural[j][i] } else { 0.0 });
    let st = tangent.transpose() * &s;
    let off = (&s - tangent * &st).norm_max();
    assert!(off <= 1e-7 * s.norm_max().max(1.0), "{label}: a structural direction leaves the tangent space");
    let (sv, u, _) = svd(&st);
    let rank = if k == 0 { 0 } else { sv.iter().filter(|&&v| v > 1e-8 * sv[0]).count() };
    let qs = Mat::from_fn(d, rank, |i, j| u[(i, j)]);
    let w = Mat::from_fn(d, d - rank, |i, j| u[(i, rank + j)]);
    let leak = w.transpose() * &r * &qs;
    assert!(
        leak.norm_max() <= 1e-7 * size,
        "{label}: the structural subspace is not kept by the map: {:.1e} of it leaks out",
        leak.norm_max()
    );
    if w.ncols() == 0 {
        return Spectrum { values: Vec::new(), error: 1e-10, residual };
    }
    let values = (w.transpose() * &r * &w).eigenvalues().unwrap();
    let r2 = tangent.transpose() * mt2;
    let values2 = (w.transpose() * &r2 * &w).eigenvalues().unwrap();
    let error = values.iter().map(|z| nearest(&values2, *z).1).fold(1e-10, f64::max);
    Spectrum { values, error, residual }
}

/// The index of the value of `set` nearest `z`, and the distance.
fn nearest(set: &[c64], z: c64) -> (usize, f64) {
    set.iter().enumerate().map(|(i, w)| (i, (w - z).norm())).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap()
}

/// `ezy analyze <case> --continue <param>=<grid> --no-figures` into a
/// fresh directory: what it printed and the rows of its `branch.csv`,
/// each bifurcation's row also named in a printed note (`<kind> at
/// <param> = <value>`), and no bifurcation named where none is written.
fn continued<M: Model>(case: &Case<M>, grid: &str, dir: &str) -> (String, Vec<Row>) {
    let dir = fresh(dir);
    let spec = format!("{}={grid}", case.param);
    let (out, err, ok) = ezy(&["analyze", &case.file, "--no-figures", "--continue", &spec], &dir);
    assert!(ok, "{out}{err}");
    let (head, rows) = table(&dir.join("branch.csv"));
    let col = |name: &str| head.iter().position(|h| h == name);
    let names = case.analysis(case.scene.parameter(&case.model, &[], case.param).unwrap().value).state_names();
    let letter = if case.periodic { "mu" } else { "lambda" };
    let num = |r: &[String], i: usize| r[i].parse::<f64>().unwrap();
    let rows: Vec<Row> = rows
        .iter()
        .map(|r| {
            let spectrum = (1..)
                .map_while(|k| col(&format!("{letter}{k}_re")).map(|i| c64::new(num(r, i), num(r, i + 1))))
                .collect();
            let bifurcation = col("bifurcation").filter(|&i| !r[i].is_empty()).map(|i| {
                let (re, im) = (num(r, col("critical_re").unwrap()), num(r, col("critical_im").unwrap()));
                (r[i].clone(), c64::new(re, im))
            });
            Row {
                value: num(r, 0),
                stability: r[1].clone(),
                period: col("period").map(|i| num(r, i)),
                t0: col("t0").map_or(0.0, |i| num(r, i)),
                state: names.iter().map(|n| num(r, col(n).unwrap())).collect(),
                spectrum,
                bifurcation,
            }
        })
        .collect();
    for kind in ["fold", "branch point", "period doubling", "Neimark-Sacker", "Hopf"] {
        let written: Vec<&Row> = rows.iter().filter(|r| r.bifurcation.as_ref().is_some_and(|b| b.0 == kind)).collect();
        for r in &written {
            let note = format!("note: {kind} at {} = {} (", case.param, fmt_value(r.value));
            assert!(out.contains(&note), "`{note}` not printed: {out}");
        }
        assert_eq!(out.matches(&format!("note: {kind} at ")).count(), written.len(), "{kind}: {out}");
    }
    (out, rows)
}

/// The oracle's spectrum of the solution of `row`.
fn spectrum_of<M: Model>(case: &Case<M>, row: &Row) -> Spectrum {
    match row.period {
        Some(period) => periodic_spectrum(case, row.value, period, row.t0, &row.state).0,
        None => steady_spectrum(case, row.value, &row.state),
    }
}

/// The growth rates of a spectrum: `ln |mu|` of multipliers, `Re lambda`
/// of eigenvalues; each with its error (the value's error, over `|mu|`).
fn rates(s: &Spectrum, periodic: bool) -> Vec<(f64, f64)> {
    s.values.iter().map(|z| if periodic { (z.norm().ln(), s.error / z.norm()) } else { (z.re, s.error) }).collect()
}

/// How many of the oracle's rates are positive beyond three times their
/// error (a rate within it counts as neither).
fn unstable(s: &Spectrum, periodic: bool) -> usize {
    rates(s, periodic).iter().filter(|(r, e)| *r > 3.0 * e).count()
}

/// Checks a row of the branch against the oracle at its printed state:
/// the state is a solution (an orbit's runs return to it within 1e-8 of
/// `1 + |x|`: the shooting's Newton stops at 1e-9 of it; an
/// equilibrium's accelerations vanish to 1e-9); the printed spectrum is
/// the oracle's, each value within 1e-8 of `1 + |z|` plus three times the
/// oracle's error (the printed spectrum's own, from variational equations
/// at 1e-11, is about 1e-10); and the printed stability holds: `stable`
/// when every rate is negative beyond three times the oracle's error,
/// `unstable` when one is positive beyond it, `neutral` when the largest
/// is within the band `analyze` calls zero (1e-6 in `ln |mu|`, 1e-7 of
/// the largest `|lambda|`) widened by three times the oracle's error.
pub(super) fn check_row<M: Model>(case: &Case<M>, row: &Row) -> Spectrum {
    let s = spectrum_of(case, row);
    let periodic = row.period.is_some();
    let at = format!("{} at {} = {}", case.scene.name, case.param, row.value);
    let bound = if periodic { 1e-8 * (1.0 + norm(&row.state)) } else { 1e-9 };
    assert!(s.residual <= bound, "{at}: the printed state is {:.1e} from a solution", s.residual);
    assert_eq!(s.values.len(), row.spectrum.len(), "{at}: {:?} against the oracle's {:?}", row.spectrum, s.values);
    let mut left = s.values.clone();
    for z in &row.spectrum {
        let (i, off) = nearest(&left, *z);
        assert!(
            off <= 1e-8 * (1.0 + z.norm()) + 3.0 * s.error,
            "{at}: printed {z} against the oracle's {} (error {:.1e})",
            left[i],
            s.error
        );
        left.remove(i);
    }
    let r = rates(&s, periodic);
    let Some((top, e)) = r.iter().copied().max_by(|a, b| a.0.total_cmp(&b.0)) else {
        // every direction the structure's (a kinematic snake's gait)
        assert_eq!(row.stability, "neutral", "{at}: no direction but the structure's, printed {}", row.stability);
        return s;
    };
    let band = if periodic { 1e-6 } else { 1e-7 * s.values.iter().fold(1.0f64, |m, z| m.max(z.norm())) };
    let holds = match row.stability.as_str() {
        "stable" => r.iter().all(|(v, e)| *v < -3.0 * e),
        "unstable" => top > 3.0 * e,
        "neutral" => top.abs() <= band + 3.0 * e,
        other => panic!("{at}: stability `{other}`"),
    };
    assert!(holds, "{at}: printed {} where the oracle's largest rate is {top:.3e} (error {e:.1e})", row.stability);
    s
}

/// Checks every row of a branch ([`check_row`]) and that the oracle's
/// count of unstable directions changes only across a reported
/// bifurcation (rows in the branch's order, a bifurcation's row between
/// its bracket's ends); `every` checks every `every`-th row of the
/// branch (and each bifurcation's, and the last). Returns the worst
/// deviation of a printed spectrum value from the oracle's.
fn check_branch<M: Model>(case: &Case<M>, rows: &[Row], every: usize) -> f64 {
    let periodic = case.periodic;
    let mut last: Option<(usize, f64)> = None;
    let mut crossed = false;
    let mut worst = 0.0f64;
    for (k, row) in rows.iter().enumerate() {
        if row.bifurcation.is_some() {
            crossed = true;
        }
        if k % every != 0 && k + 1 != rows.len() && row.bifurcation.is_none() {
            continue;
        }
        let s = check_row(case, row);
        for z in &row.spectrum {
            worst = worst.max(nearest(&s.values, *z).1 / (1.0 + z.norm()));
        }
        if row.bifurcation.is_some() {
            continue;
        }
        let count = unstable(&s, periodic);
        if let Some((before, at)) = last {
            assert!(
                count == before || crossed,
                "{}: the oracle's unstable count goes from {before} at {at} to {count} at {} with no bifurcation reported",
                case.scene.name,
                row.value
            );
        }
        (last, crossed) = (Some((count, row.value)), false);
    }
    worst
}

/// The value a bifurcation's critical eigenvalue or multiplier crosses:
/// +1 (a multiplier of a fold or branch point), -1 (period doubling), 0
/// (an eigenvalue of an equilibrium's fold or branch point).
fn target(kind: &str, periodic: bool) -> f64 {
    match (kind, periodic) {
        ("fold" | "branch point", true) => 1.0,
        ("period doubling", true) => -1.0,
        ("fold" | "branch point", false) => 0.0,
        (other, _) => panic!("a {other} is not the oracle's yet"),
    }
}

/// The solution at `value` found on its own from `guess` (the library's
/// single-point search: `periodic_orbit` at the phase and period of
/// `row`, DOP853 1e-13 and Newton 1e-11; or `steady_motion`), not by the
/// continuation.
fn solve_at<M: Model>(case: &Case<M>, value: f64, guess: &[f64], row: &Row) -> Vec<f64> {
    let mut an = case.analysis(value);
    let symmetry = an.symmetry(0.0, guess).unwrap();
    match row.period {
        Some(p) => an.periodic_orbit(row.t0, p, guess, symmetry, &tight()).unwrap().state,
        None => an.steady_motion(0.0, guess, symmetry, None).unwrap().state,
    }
}

/// The oracle's critical value of `s` for a crossing of `c`: the value
/// nearest it, with its rate (`ln |mu|` or `Re lambda`), the rate's
/// error, and the count of the other values' positive rates.
fn critical(s: &Spectrum, c: f64, periodic: bool) -> (c64, f64, f64, usize) {
    let (i, _) = nearest(&s.values, c64::new(c, 0.0));
    let r = rates(s, periodic);
    let others = r.iter().enumerate().filter(|(j, (v, e))| *j != i && *v > 3.0 * e).count();
    (s.values[i], r[i].0, r[i].1, others)
}

/// Checks the bifurcation on `rows[k]` (its bracket's ends the rows
/// before and after it): at a fold the parameter turns there (both ends
/// on one side of `P*`), elsewhere it passes (one on each side). At `P*
/// +- d`, `d = scale (1 + |P*|)` for each of `scales` (at a fold both
/// solutions at `P* - d` on the side the branch lies, from the bracket's
/// states), solutions found on their own ([`solve_at`]) carry the
/// oracle's spectra: the value nearest the crossing's target ([`target`])
/// is real (imaginary part within three times the oracle's error), its
/// rate changes sign between the two (each beyond three times its
/// error), and every other rate keeps its side (their unstable counts
/// agree). Returns the crossing's rates at the nearer pair with their
/// parameter values, for the location ([`locate_crossing`]).
fn check_sides<M: Model>(case: &Case<M>, rows: &[Row], k: usize, scales: &[f64]) -> [(f64, f64); 2] {
    let row = &rows[k];
    let (kind, _) = row.bifurcation.clone().unwrap();
    let periodic = row.period.is_some();
    let c = target(&kind, periodic);
    let (before, after) = (&rows[k - 1], &rows[k + 1]);
    let p = row.value;
    let turns = (before.value - p).signum() == (after.value - p).signum();
    assert_eq!(
        turns,
        kind == "fold",
        "{}: {kind} at {p} between {} and {}",
        case.scene.name,
        before.value,
        after.value
    );
    let mut nearer = [(0.0, 0.0); 2];
    for scale in scales {
        let d = scale * (1.0 + p.abs());
        // the two sides: along the branch before and after the point
        let sides = if turns {
            let v = p + d * (before.value - p).signum();
            [(v, before.state.clone()), (v, after.state.clone())]
        } else {
            [
                (p + d * (before.value - p).signum(), row.state.clone()),
                (p + d * (after.value - p).signum(), row.state.clone()),
            ]
        };
        let mut seen = Vec::new();
        for (v, guess) in sides {
            let x = solve_at(case, v, &guess, row);
            let s = match row.period {
                Some(period) => periodic_spectrum(case, v, period, row.t0, &x).0,
                None => steady_spectrum(case, v, &x),
            };
            let (z, rate, e, others) = critical(&s, c, periodic);
            eprintln!("{}: {kind} at {p}: at {v} the critical {z} (rate {rate:.3e} +- {e:.1e})", case.scene.name);
            assert!(z.im.abs() <= 3.0 * s.error && rate.abs() > 3.0 * e, "{}: at {v}: {:?}", case.scene.name, s.values);
            seen.push((v, x, rate, others));
        }
        let name = &case.scene.name;
        assert!(seen[0].2 * seen[1].2 < 0.0, "{name}: the critical rate keeps its sign across {kind} at {p}");
        assert_eq!(seen[0].3, seen[1].3, "{name}: another rate crosses with the critical one at {p}");
        if turns {
            let gap = norm(&seen[0].1.iter().zip(&seen[1].1).map(|(a, b)| a - b).collect::<Vec<_>>());
            assert!(gap > 1e-6, "{name}: one solution either side of the fold at {p} ({gap:.1e} apart)");
        }
        nearer = [(seen[0].0, seen[0].2), (seen[1].0, seen[1].2)];
    }
    nearer
}

/// The oracle's own crossing of a branch point or period doubling on
/// `row`: regula falsi on the critical rate of solutions found on their
/// own between the parameter values of `pair` (the rates there) until
/// the rate is within three times its error (at most 8 steps). The
/// reported `P*` must be within the bracket `analyze` locates to (1e-8
/// of `1 + |P*|`), plus what its own multipliers' error moves it (its
/// bisection counts the multipliers outside the circle as it computes
/// them: their error at `P*`, measured against the oracle's there, over
/// the rate's slope), plus the oracle's own uncertainty (its rate's
/// error over the slope). At a branch point the search's matrix is
/// singular along the critical direction, so an orbit converged to
/// Newton's default 1e-9 is not held along it: the bisection's orbits
/// put the rolling-resistance gait's branch point 2.4e-8 below the
/// crossing, outside the 1e-8 the command claims, until `locate`
/// converged them to the integration's tolerance (now 6e-9). Returns the
/// oracle's
/// crossing.
fn locate_crossing<M: Model>(case: &Case<M>, row: &Row, pair: [(f64, f64); 2]) -> f64 {
    let (kind, _) = row.bifurcation.clone().unwrap();
    let periodic = row.period.is_some();
    let c = target(&kind, periodic);
    let [(mut a, mut fa), (mut b, mut fb)] = pair;
    let slope = ((fb - fa) / (b - a)).abs();
    // the printed critical multiplier's error, at the printed point
    let at_row = periodic_spectrum(case, row.value, row.period.unwrap(), row.t0, &row.state).0;
    let printed = row.bifurcation.as_ref().unwrap().1;
    let (i, _) = nearest(&at_row.values, printed);
    let own = (at_row.values[i].norm() - printed.norm()).abs() / printed.norm() + 3.0 * at_row.error;
    let (mut at, mut slack) = (row.value, f64::INFINITY);
    for _ in 0..8 {
        let v = b - fb * (b - a) / (fb - fa);
        let x = solve_at(case, v, &row.state, row);
        let s = periodic_spectrum(case, v, row.period.unwrap(), row.t0, &x).0;
        let (_, rate, e, _) = critical(&s, c, periodic);
        (at, slack) = (v, (rate.abs() + 3.0 * e) / slope);
        if rate.abs() <= 3.0 * e {
            break;
        }
        if rate.signum() == fa.signum() {
            (a, fa) = (v, rate);
        } else {
            (b, fb) = (v, rate);
        }
    }
    let off = (row.value - at).abs();
    let moved = own / slope;
    eprintln!(
        "{}: {kind} at {} against the oracle's {at} ({off:.1e}; its multiplier's error moves it {moved:.1e}, the oracle's slack {slack:.1e})",
        case.scene.name, row.value
    );
    assert!(
        off <= 1e-8 * (1.0 + row.value.abs()) + moved + slack,
        "{}: {kind} at {} against {at}",
        case.scene.name,
        row.value
    );
    at
}

/// The loaded pendulum at rest at heading `phi` (2nq): the bob at `L`
/// from the pivot at the origin along its heading (the model's hinge
/// point `(-L, 0)` in the bob's frame; on the constraints:
/// [`check_pendulum_fold`] asserts it).
fn pendulum_at<M: Model>(case: &Case<M>, phi: f64) -> Vec<f64> {
    let l = case.scene.parameter(&case.model, &[], "L").unwrap().value;
    vec![l * phi.cos(), l * phi.sin(), phi, 0.0, 0.0, 0.0]
}

/// The load that holds the pendulum at rest at `phi`: its angular
/// acceleration is affine in the load, so the root from the right-hand
/// sides at loads 0 and 1.
fn balancing_load<M: Model>(case: &Case<M>, phi: f64) -> f64 {
    let x = pendulum_at(case, phi);
    let (f0, f1) = (case.analysis(0.0).rhs(0.0, &x).unwrap()[5], case.analysis(1.0).rhs(0.0, &x).unwrap()[5]);
    -f0 / (f1 - f0)
}

/// The loaded pendulum's fold, by the oracle: along the branch of rest
/// states parameterized by the heading `phi` (each held by its
/// [`balancing_load`]), the sign of the product of the oracle's
/// eigenvalues ([`steady_spectrum`]: it changes where one real eigenvalue
/// crosses 0) bisected in `phi` between the fold's bracket states until
/// `phi` is within 1e-12 (the sign is the oracle's only within its
/// error: `phi` then within that error over the product's slope). The load there is the fold's: it is a maximum of the
/// balancing load (asserted at `phi +- 1e-3`: the parameter turns), and
/// at a maximum the load's error is second order in `phi`'s, below
/// 1e-12. `P*` must lie within 1e-8 of `1 + |P*|` (the bracket `analyze`
/// locates to) of it. Beyond it, at `P* + 1e-3 (1 + |P*|)`, no rest
/// state exists: the angular acceleration at rest, sampled at 10^5
/// headings around the circle, keeps one sign and stays further from 0
/// than its largest change between samples (so no root between them).
fn check_pendulum_fold<M: Model>(case: &Case<M>, rows: &[Row], k: usize) {
    let row = &rows[k];
    // the eigenvalues' product: its sign changes where one real
    // eigenvalue crosses 0 (a complex pair's product is positive)
    let critical_at = |phi: f64| {
        let s = steady_spectrum(case, balancing_load(case, phi), &pendulum_at(case, phi));
        s.values.iter().fold(c64::new(1.0, 0.0), |p, z| p * z).re
    };
    let (mut a, mut b) = (rows[k - 1].state[2], rows[k + 1].state[2]);
    let fa = critical_at(a);
    assert!(fa * critical_at(b) < 0.0, "the critical eigenvalue keeps its sign from phi = {a} to {b}");
    while (b - a).abs() > 1e-12 {
        let m = 0.5 * (a + b);
        if critical_at(m).signum() == fa.signum() {
            a = m;
        } else {
            b = m;
        }
    }
    let phi = 0.5 * (a + b);
    let load = balancing_load(case, phi);
    for side in [phi - 1e-3, phi + 1e-3] {
        assert!(balancing_load(case, side) < load, "the load does not turn at phi = {phi}");
    }
    let off = (row.value - load).abs();
    eprintln!("loaded pendulum: fold at {} against the oracle's {load} (phi = {phi:e}; {off:.1e})", row.value);
    assert!(off <= 1e-8 * (1.0 + row.value.abs()) + 1e-12, "fold at {} against {load}", row.value);
    // beyond the fold: no rest state anywhere on the circle
    let beyond = row.value + 1e-3 * (1.0 + row.value.abs());
    let mut an = case.analysis(beyond);
    let n = 100_000;
    let l = case.scene.parameter(&case.model, &[], "L").unwrap().value;
    let acc: Vec<f64> = (0..n)
        .map(|i| {
            let phi = -std::f64::consts::PI + std::f64::consts::TAU * i as f64 / n as f64;
            let x = vec![l * phi.cos(), l * phi.sin(), phi, 0.0, 0.0, 0.0];
            if i % 1000 == 0 {
                assert!(norm(&an.constraint_residual(0.0, &x).unwrap()) < 1e-14, "phi = {phi}: off the constraints");
            }
            an.rhs(0.0, &x).unwrap()[5]
        })
        .collect();
    let step = (0..n).map(|i| (acc[(i + 1) % n] - acc[i]).abs()).fold(0.0f64, f64::max);
    let least = acc.iter().fold(f64::INFINITY, |m, v| m.min(v.abs()));
    let one_sign = acc.iter().all(|v| v.signum() == acc[0].signum());
    eprintln!("beyond the fold, at {beyond}: |phidd| >= {least:.3e} at rest, {step:.1e} between samples");
    assert!(one_sign && least > step, "a rest state beyond the fold, at {beyond}");
}

/// The loaded pendulum of `tests/continuation.rs` as a case, its scene
/// written into `dir` for `ezy analyze`.
fn loaded_pendulum(dir: &str) -> Case<Pendulum> {
    let dir = fresh(dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("loaded-pendulum.toml");
    std::fs::write(&file, crate::continuation::LOADED_PENDULUM).unwrap();
    Case {
        scene: Scene::from_toml(crate::continuation::LOADED_PENDULUM, "loaded-pendulum.toml").unwrap(),
        model: Pendulum::default(),
        file: file.to_str().unwrap().into(),
        param: "load.torque.constant",
        periodic: false,
        plane: false,
        cyclic: &[],
        autonomous: false,
        turns: Vec::new(),
    }
}

/// The loaded pendulum's equilibria from hanging (`tau = 0`) up the load
/// to 12 N m and back down its upright side: the fold `ezy analyze`
/// reports at 9.81 N m and every row's stability and eigenvalues against
/// the oracle's Jacobian; on either side of the fold (`d = 1e-5` and
/// `1e-6` of `1 + P*`: close enough that the stable side's eigenvalues
/// are real, not yet the damped pair they become farther down), the two
/// rest states found on their own, one real eigenvalue crossing 0 between
/// them; the fold bisected on the oracle's crossing; no rest state
/// beyond it.
#[test]
fn a_loaded_pendulums_fold_is_where_one_eigenvalue_crosses_zero() {
    let case = loaded_pendulum("oracle-fold-case");
    let (_, rows) = continued(&case, "0:12:13", "oracle-fold");
    let worst = check_branch(&case, &rows, 1);
    let folds: Vec<usize> = (0..rows.len()).filter(|&k| rows[k].bifurcation.is_some()).collect();
    assert_eq!(folds.len(), 1, "{rows:?}");
    assert_eq!(rows[folds[0]].bifurcation.as_ref().unwrap().0, "fold");
    check_sides(&case, &rows, folds[0], &[1e-5, 1e-6]);
    check_pendulum_fold(&case, &rows, folds[0]);
    eprintln!("loaded pendulum: {} rows, the printed eigenvalues within {worst:.1e} of the oracle's", rows.len());
}

/// Checks a periodic branch's one reported bifurcation of `kind`: its
/// rows ([`check_branch`]), its sides at `d = 1e-3` and `1e-4` of `1 +
/// |P*|` ([`check_sides`]) and its location ([`locate_crossing`]).
fn check_periodic<M: Model>(case: &Case<M>, rows: &[Row], kind: &str) {
    let worst = check_branch(case, rows, 1);
    let found: Vec<usize> = (0..rows.len()).filter(|&k| rows[k].bifurcation.is_some()).collect();
    assert_eq!(found.len(), 1, "{rows:?}");
    let k = found[0];
    assert_eq!(rows[k].bifurcation.as_ref().unwrap().0, kind, "{:?}", rows[k]);
    let pair = check_sides(case, rows, k, &[1e-3, 1e-4]);
    locate_crossing(case, &rows[k], pair);
    eprintln!("{}: {} rows, the printed multipliers within {worst:.1e} of the oracle's", case.scene.name, rows.len());
}

/// The rolling-resistance gait (`drive-rolling-resistance`) continued in
/// the motor's amplitude from 1 down to 0.5 N m: the branch point `ezy
/// analyze` reports at 0.638 N m (the straight gait's symmetry-breaking
/// pitchfork), its multipliers modulo the plane's rigid motions (three
/// directions the oracle takes out: their subspace is kept by its period
/// map) against the oracle's at every row, one real multiplier crossing
/// +1 between gaits found on their own either side, the crossing bisected.
#[test]
#[ignore = "whole harness: the rolling-resistance gait's branch point"]
fn the_rolling_resistance_gaits_branch_point_is_where_one_multiplier_crosses_one() {
    let case = Case {
        scene: scenes::get("drive-rolling-resistance"),
        model: EzyRoller::default(),
        file: "drive-rolling-resistance".into(),
        param: "motor.amplitude",
        periodic: true,
        plane: true,
        cyclic: &[],
        autonomous: false,
        turns: Vec::new(),
    };
    let (_, rows) = continued(&case, "1:0.5:3", "oracle-branch-point");
    check_periodic(&case, &rows, "branch point");
}

/// Baker and Gollub's forced damped pendulum (`tests/bifurcation.rs`)
/// continued in the torque's amplitude from 10.40 to 10.50 N m: the
/// period doubling `ezy analyze` reports at 10.4611 N m, every row's
/// multipliers against the oracle's (no symmetry: the pendulum is pinned),
/// one real multiplier crossing -1 between orbits found on their own
/// either side, the crossing bisected.
#[test]
#[ignore = "whole harness: the forced pendulum's period doubling"]
fn the_forced_pendulums_period_doubling_is_where_one_multiplier_crosses_minus_one() {
    let (a, w, c) = crate::bifurcation::BAKER_GOLLUB;
    let text = crate::bifurcation::forced_pendulum(a, w, c);
    let dir = fresh("oracle-doubling-case");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("forced-pendulum.toml");
    std::fs::write(&file, &text).unwrap();
    let case = Case {
        scene: Scene::from_toml(&text, "forced-pendulum.toml").unwrap(),
        model: Pendulum::default(),
        file: file.to_str().unwrap().into(),
        param: "motor.torque.cos.amplitude",
        periodic: true,
        plane: false,
        cyclic: &[],
        autonomous: false,
        turns: Vec::new(),
    };
    let (_, rows) = continued(&case, "10.40:10.50:3", "oracle-doubling");
    check_periodic(&case, &rows, "period doubling");
}

/// A user's sleigh with a balanced rotor driven by a torque given in time
/// (`tests/data/oracle/rotor_sleigh.ezy`), continued in the torque's
/// frequency from 1 to 8 rad/s: no bifurcation may be reported, and none
/// is there: the oracle's count of multipliers outside the unit circle is
/// the same at every row checked (every `every`-th), each row's printed
/// multipliers are the oracle's modulo the plane's rigid motions and the
/// rotor's angle and rate, and the two multipliers `analyze` leaves out
/// as structural are so on the oracle's own map: the rotor's angle
/// direction is kept (`P e_th = e_th`) and its rate's turns the angle on
/// by a period (`P e_thd = e_thd + T e_th`), to 1e-7 of the map (the
/// differences' error is about 1e-9).
fn rotor_sleigh(every: usize) {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let path = data.join("rotor-sleigh.toml");
    let case = Case {
        scene: Scene::read(&path).unwrap().0,
        model: RuntimeModel::from_file(&data.join("rotor_sleigh.ezy")).unwrap(),
        file: path.to_str().unwrap().into(),
        param: "w",
        periodic: true,
        plane: true,
        cyclic: &["th"],
        autonomous: false,
        turns: Vec::new(),
    };
    let dir = format!("oracle-rotor-{every}");
    let (out, rows) = continued(&case, "1:8:15", &dir);
    assert!(
        out.contains("structural multipliers (left out of the stability and bifurcation tests): 1 (th: cyclic), 1 (thd: the rate of cyclic th, which nothing else feels)"),
        "{out}"
    );
    assert!(rows.iter().all(|r| r.bifurcation.is_none()) && !out.contains("stability changes"), "{out}");
    let worst = check_branch(&case, &rows, every);
    // the structural block on the oracle's own map, at the first row
    let row = &rows[0];
    let period = row.period.unwrap();
    let (_, r) = periodic_spectrum(&case, row.value, period, row.t0, &row.state);
    let an = case.analysis(row.value);
    let tangent = case.tangent(&an, row.t0, &row.state);
    let k = an.dynamics().info.coord_index("th").unwrap();
    let nq = row.state.len() / 2;
    let on = |i: usize| Mat::from_fn(tangent.ncols(), 1, |j, _| tangent[(i, j)]);
    let (th, thd) = (on(k), on(nq + k));
    let kept = (&r * &th - &th).norm_max();
    let turned = (&r * &thd - &thd - Mat::from_fn(th.nrows(), 1, |j, _| period * th[(j, 0)])).norm_max();
    eprintln!("rotor sleigh: P e_th - e_th {kept:.1e}, P e_thd - e_thd - T e_th {turned:.1e}");
    assert!(kept <= 1e-7 * r.norm_max() && turned <= 1e-7 * r.norm_max(), "{kept:e} {turned:e}");
    eprintln!("rotor sleigh: {} rows, the printed multipliers within {worst:.1e} of the oracle's", rows.len());
}

/// [`rotor_sleigh`] at every eighth row (and the last).
#[test]
fn a_rotors_branch_has_no_bifurcation_and_its_structural_multipliers_are_one() {
    rotor_sleigh(8);
}

/// [`rotor_sleigh`] at every row.
#[test]
#[ignore = "whole harness: every row of the rotor sleigh's branch"]
fn every_row_of_a_rotors_branch_is_the_oracles() {
    rotor_sleigh(1);
}
