//! Consistent initial conditions: the scene gives some coordinates and
//! velocities, the solver computes the rest so that `C(q) = 0` and
//! `G(q) qd = 0` (docs/physics.md §7; for `free`, x1d = 1 and phi1d = 0 give
//! y1d = 0, x2d = 0.5, y2d = 0, phi2d = 5).
//!
//! Positions: Newton on `C(q)` in the unknown coordinates (the Jacobian's
//! columns of the unknowns, which must have full column rank). Velocities:
//! the linear system `G_u qd_u = -G_k qd_k` in the unknown velocities, with
//! the same rank condition. Given values that violate the constraints are
//! then projected onto them with the minimum-norm correction.
//!
//! Two linear-algebra paths solve the same least-squares problems:
//!
//! - dense (models below [`SPARSE_INITIAL_FROM`] coordinates): the SVD of
//!   the dense Jacobian (faer), rank-revealing, `O(nq^3)`;
//! - sparse (larger models, such as a family of a thousand links): the
//!   normal equations `J^T J x = J^T b` (unknown columns) and
//!   `J J^T y = r` (minimum norm) factored by [`SparseSchur`] (AMD ordering,
//!   sparse Cholesky), with iterative refinement against `J` itself, so
//!   that the squared condition number costs accuracy only in the first
//!   solve (Björck, *Numerical Methods for Least Squares Problems*, SIAM
//!   1996, §2.9 and §6.6). Nothing of size `nc x nq` is formed: the cost
//!   is linear in the length of a chain.

use crate::error::KktError;
use crate::error::SetupError;
use crate::error::SimError;
use crate::formulation::projection::max_abs;
use crate::kkt::sparse::SparseSchur;
use crate::kkt::{KktSolver, KktSystem};
use crate::model::Model;
use crate::model::info::{ModelInfo, scatter_dense};
use crate::names::name_list;

/// Tolerance of the consistent initial state: `max|C|` \[m\], and `max|G qd|`
/// \[m/s\] relative to `max(1, max|qd|)`.
pub const INITIAL_TOL: f64 = 1e-12;

/// Models with at least this many coordinates take the sparse path (see
/// the module docs). The dense SVD costs about 1 ms at 90 coordinates
/// (the 30-link snake) and grows like `nq^3`: 0.1 s at 300, 35 s at 1200.
pub const SPARSE_INITIAL_FROM: usize = 100;

/// A thin SVD `J = U S V^T` (faer's; nalgebra's loses accuracy on some
/// chains: a 30-link driven snake's velocity system came back with a
/// residual of 7e-5 m/s, nalgebra issues #1117 and #1172).
struct DenseSvd {
    u: faer::Mat<f64>,
    s: Vec<f64>,
    v: faer::Mat<f64>,
}

impl DenseSvd {
    /// The SVD of the `rows x cols` matrix with entries `at(r, c)`.
    fn new(rows: usize, cols: usize, at: impl Fn(usize, usize) -> f64) -> Result<Self, Fail> {
        let j = faer::Mat::<f64>::from_fn(rows, cols, at);
        let svd = j.thin_svd().map_err(|e| Fail::Other(format!("the SVD did not converge: {e:?}")))?;
        let s = (0..svd.S().dim()).map(|i| svd.S()[i]).collect();
        Ok(Self { u: svd.U().to_owned(), s, v: svd.V().to_owned() })
    }

    fn largest(&self) -> f64 {
        self.s.iter().fold(0.0, |m, &x| m.max(x))
    }

    /// Number of singular values above `tol`.
    fn rank(&self, tol: f64) -> usize {
        self.s.iter().filter(|&&x| x > tol).count()
    }

    /// The minimum-norm least-squares solution of `J x = b`, singular
    /// values at or below `tol` taken as zero.
    fn solve(&self, b: &[f64], tol: f64) -> Vec<f64> {
        let (rows, cols) = (self.u.nrows(), self.v.nrows());
        let mut x = vec![0.0; cols];
        for (i, &si) in self.s.iter().enumerate() {
            if si <= tol {
                continue;
            }
            let c = (0..rows).map(|r| self.u[(r, i)] * b[r]).sum::<f64>() / si;
            for (k, xk) in x.iter_mut().enumerate() {
                *xk += self.v[(k, i)] * c;
            }
        }
        x
    }
}

/// Why a least-squares solve failed.
enum Fail {
    /// The column (index into the unknowns) or row that depends on the others.
    Dependent(usize),
    /// Anything else (non-finite numbers), as text.
    Other(String),
}

impl From<KktError> for Fail {
    fn from(e: KktError) -> Self {
        match e {
            KktError::DependentConstraints { row, .. } => Fail::Dependent(row),
            e => Fail::Other(e.to_string()),
        }
    }
}

/// `out = J v` (rows) for `J` given by its values at `pattern`, only over
/// the columns where `keep` is true.
fn sparse_times(pattern: &[(usize, usize)], values: &[f64], v: &[f64], keep: impl Fn(usize) -> bool, out: &mut [f64]) {
    out.fill(0.0);
    for (&(r, c), &x) in pattern.iter().zip(values) {
        if keep(c) {
            out[r] += x * v[c];
        }
    }
}

/// The least-squares solution `x` of `J_u x = b`, `J_u` the columns `cols`
/// of `J` (rows x ncols, values at `pattern`), on the dense or the sparse
/// path (module docs). Symbolic analysis once, at construction.
struct ColumnSolve {
    rows: usize,
    ncols: usize,
    cols: Vec<usize>,
    sparse: Option<SparseColumns>,
}

/// The sparse path of [`ColumnSolve`]: `J_u^T` as the `G` of a
/// [`SparseSchur`] with unit weights, so that its multipliers are
/// `(J_u^T J_u)^-1 J_u^T b` and its accelerations the residual `b - J_u x`.
struct SparseColumns {
    schur: SparseSchur,
    /// For each entry of `J_u^T`'s pattern, the index of its value in `J`'s.
    src: Vec<usize>,
    values: Vec<f64>,
    ones: Vec<f64>,
    zeros: Vec<f64>,
    resid: Vec<f64>,
    dx: Vec<f64>,
}

impl ColumnSolve {
    fn new(pattern: &[(usize, usize)], rows: usize, ncols: usize, cols: &[usize], sparse: bool) -> Self {
        let sparse = (sparse && !cols.is_empty()).then(|| {
            let mut unknown = vec![usize::MAX; ncols];
            for (k, &c) in cols.iter().enumerate() {
                unknown[c] = k;
            }
            let (mut tpattern, mut src) = (Vec::new(), Vec::new());
            for (v, &(r, c)) in pattern.iter().enumerate() {
                if unknown[c] != usize::MAX {
                    tpattern.push((unknown[c], r));
                    src.push(v);
                }
            }
            let ones = vec![1.0; rows];
            SparseColumns {
                schur: SparseSchur::new(&tpattern, cols.len(), &ones).expect("unit weights"),
                values: vec![0.0; src.len()],
                src,
                ones,
                zeros: vec![0.0; cols.len()],
                resid: vec![0.0; rows],
                dx: vec![0.0; cols.len()],
            }
        });
        Self { rows, ncols, cols: cols.to_vec(), sparse }
    }

    /// A Newton step: as [`ColumnSolve::solve`], except that the dense
    /// path takes the minimum-norm step of a rank-deficient `J_u` (singular
    /// values below 1e-10 of the largest dropped) instead of failing.
    fn step(&mut self, pattern: &[(usize, usize)], values: &[f64], b: &[f64]) -> Result<Vec<f64>, Fail> {
        if self.sparse.is_some() {
            return self.solve(pattern, values, b);
        }
        let svd = self.dense_svd(pattern, values)?;
        Ok(svd.solve(b, 1e-10 * svd.largest()))
    }

    /// `Err(k)` if `J_u` is rank-deficient (on the sparse path: the unknown
    /// `k` found dependent; on the dense path: `k = nu`, no single one).
    fn check_rank(&mut self, pattern: &[(usize, usize)], values: &[f64]) -> Result<(), usize> {
        let nu = self.cols.len();
        if self.sparse.is_some() {
            let zeros = vec![0.0; self.rows];
            return match self.solve(pattern, values, &zeros) {
                Err(Fail::Dependent(k)) => Err(k),
                _ => Ok(()),
            };
        }
        match self.dense_svd(pattern, values) {
            Ok(svd) if svd.rank(1e-10 * svd.largest().max(1.0)) >= nu => Ok(()),
            _ => Err(nu),
        }
    }

    fn dense_svd(&self, pattern: &[(usize, usize)], values: &[f64]) -> Result<DenseSvd, Fail> {
        let mut dense = vec![0.0; self.rows * self.ncols];
        scatter_dense(pattern, values, self.ncols, &mut dense);
        DenseSvd::new(self.rows, self.cols.len(), |r, c| dense[r * self.ncols + self.cols[c]])
    }

    fn solve(&mut self, pattern: &[(usize, usize)], values: &[f64], b: &[f64]) -> Result<Vec<f64>, Fail> {
        let nu = self.cols.len();
        let Some(sp) = &mut self.sparse else {
            let mut dense = vec![0.0; self.rows * self.ncols];
            scatter_dense(pattern, values, self.ncols, &mut dense);
            let svd = DenseSvd::new(self.rows, nu, |r, c| dense[r * self.ncols + self.cols[c]])?;
            if svd.rank(1e-10 * svd.largest().max(1.0)) < nu {
                return Err(Fail::Dependent(nu));
            }
            return Ok(svd.solve(b, 1e-14));
        };
        for (v, &s) in sp.values.iter_mut().zip(&sp.src) {
            *v = values[s];
        }
        let mut x = vec![0.0; nu];
        let sys = KktSystem { mass: &sp.ones, g: &[], g_values: &sp.values, f: b, gamma: &sp.zeros, released: &[] };
        sp.schur.solve(&sys, &mut sp.resid, &mut x)?;
        // undetermined unknowns are named, not solved regularized
        if sp.schur.was_singular() {
            return Err(Fail::from(KktError::DependentConstraints {
                n: nu,
                row: sp.schur.dependent_row(&sp.values)?.unwrap_or(0),
            }));
        }
        // iterative refinement: the residual b - J_u x comes back as the
        // accelerations, and corrects the normal equations' rounding
        let mut resid = vec![0.0; self.rows];
        for _ in 0..3 {
            std::mem::swap(&mut resid, &mut sp.resid);
            let sys =
                KktSystem { mass: &sp.ones, g: &[], g_values: &sp.values, f: &resid, gamma: &sp.zeros, released: &[] };
            sp.schur.solve(&sys, &mut sp.resid, &mut sp.dx)?;
            for (xi, d) in x.iter_mut().zip(&sp.dx) {
                *xi += d;
            }
            if max_abs(&sp.dx) <= f64::EPSILON * max_abs(&x) {
                break;
            }
        }
        Ok(x)
    }
}

/// The minimum-norm `dx` with `J dx = r` (`J` rows x ncols at `pattern`),
/// dense (SVD) or sparse (`dx = J^T (J J^T)^-1 r`, refined).
struct MinNorm {
    rows: usize,
    ncols: usize,
    sparse: Option<(SparseSchur, Vec<f64>, Vec<f64>)>,
}

impl MinNorm {
    fn new(pattern: &[(usize, usize)], rows: usize, ncols: usize, sparse: bool) -> Self {
        let sparse = (sparse && rows > 0).then(|| {
            let ones = vec![1.0; ncols];
            (SparseSchur::new(pattern, rows, &ones).expect("unit weights"), ones, vec![0.0; ncols])
        });
        Self { rows, ncols, sparse }
    }

    fn solve(&mut self, pattern: &[(usize, usize)], values: &[f64], r: &[f64]) -> Result<Vec<f64>, Fail> {
        let Some((schur, ones, zeros)) = &mut self.sparse else {
            let mut dense = vec![0.0; self.rows * self.ncols];
            scatter_dense(pattern, values, self.ncols, &mut dense);
            let svd = DenseSvd::new(self.rows, self.ncols, |i, c| dense[i * self.ncols + c])?;
            return Ok(svd.solve(r, 1e-12));
        };
        // (J J^T) y = r, step = -J^T y: the SparseSchur's accelerations with f = 0
        let mut dx = vec![0.0; self.ncols];
        let (mut step, mut y) = (vec![0.0; self.ncols], vec![0.0; self.rows]);
        let mut left = r.to_vec();
        for _ in 0..3 {
            let sys = KktSystem { mass: ones, g: &[], g_values: values, f: zeros, gamma: &left, released: &[] };
            schur.solve(&sys, &mut step, &mut y)?;
            // the assembly names dependent rows rather than solving them
            // regularized (a singular position is for the run, not the start)
            if schur.was_singular() {
                let row = schur.dependent_row(values)?.unwrap_or(0);
                return Err(Fail::from(KktError::DependentConstraints { n: self.rows, row }));
            }
            for (d, s) in dx.iter_mut().zip(&step) {
                *d -= s;
            }
            // what J dx still misses of r
            sparse_times(pattern, values, &dx, |_| true, &mut left);
            for (l, ri) in left.iter_mut().zip(r) {
                *l = ri - *l;
            }
            if max_abs(&left) <= f64::EPSILON * max_abs(r) {
                break;
            }
        }
        Ok(dx)
    }
}

/// What a scene gives of the initial state, by index into the model's
/// coordinates and hinges.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Given {
    /// Fixed coordinates `(index in q, value)` \[m or rad\].
    pub q: Vec<(usize, f64)>,
    /// Fixed velocities `(index in qd, value)` \[m/s or rad/s\].
    pub qd: Vec<(usize, f64)>,
    /// Fixed hinge angles `(index in ModelInfo::hinges, theta)`,
    /// `theta = phi_a - phi_b` (`phi_a` for a hinge to the ground) \[rad\].
    pub angles: Vec<(usize, f64)>,
    /// Starting values `(index in q, value)` of coordinates the constraints
    /// determine: the Newton iteration starts there, so it finds the
    /// assembly branch nearest them.
    pub guess: Vec<(usize, f64)>,
    /// Skate rows of `G` the velocities need not satisfy (skates with
    /// friction, which may start sliding: [`crate::formulation::friction`]); they are
    /// left out of the velocity solve.
    pub released: Vec<usize>,
}

/// Computes `(q, qd)` (nq each) from the given values.
///
/// `given_q`, `given_qd`: `(coordinate index, value)`; every other entry is
/// solved for, starting from 0. Given values that violate the constraints
/// are projected onto them (positions by Gauss-Newton with minimum-norm
/// steps, velocities by least squares); the [`InitialReport`] says by how
/// much. Models from [`SPARSE_INITIAL_FROM`] coordinates take the sparse
/// path (module docs), whose cost is linear in the length of a chain.
///
/// # Errors
/// [`SetupError::Initial`] when the unknowns are not determined by the
/// constraints (give more values), or no consistent state exists;
/// [`SimError::DependentConstraints`] when the sparse path finds redundant
/// constraints while projecting given values.
pub fn consistent_state<M: Model>(
    model: &M,
    drives: &[crate::drive::Drive],
    given_q: &[(usize, f64)],
    given_qd: &[(usize, f64)],
) -> Result<(Vec<f64>, Vec<f64>, InitialReport), SimError> {
    let given = Given { q: given_q.to_vec(), qd: given_qd.to_vec(), ..Given::default() };
    consistent_state_given(model, drives, &given)
}

/// As [`consistent_state`], with hinge angles and starting values as well
/// ([`Given`]): a closed-loop mechanism assembles from its input angle,
/// on the branch nearest the starting values, and the report says which
/// ([`InitialReport::branch`]).
///
/// # Errors
/// As [`consistent_state`].
pub fn consistent_state_given<M: Model>(
    model: &M,
    drives: &[crate::drive::Drive],
    given: &Given,
) -> Result<(Vec<f64>, Vec<f64>, InitialReport), SimError> {
    let sparse = model.info().nq() >= SPARSE_INITIAL_FROM;
    consistent_state_with(model, drives, given, sparse)
}

/// As [`consistent_state_given`], on the sparse path if `sparse`, else the
/// dense one, whatever the model's size (for tests of the two paths).
///
/// # Errors
/// As [`consistent_state`].
pub fn consistent_state_with<M: Model>(
    model: &M,
    drives: &[crate::drive::Drive],
    given: &Given,
    sparse: bool,
) -> Result<(Vec<f64>, Vec<f64>, InitialReport), SimError> {
    let info = model.info();
    let info = &info;
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    // the holonomic rows, then one row per given hinge angle: phi_a - phi_b - theta
    let angle_cols: Vec<(usize, Option<usize>, f64)> = given
        .angles
        .iter()
        .map(|&(h, theta)| {
            let hinge = &info.hinges[h];
            (info.bodies[hinge.body_a].coords[2], hinge.body_b.map(|b| info.bodies[b].coords[2]), theta)
        })
        .collect();
    let na = angle_cols.len();
    let rows = nh + na;
    let phi_at = |q: &[f64], phi: &mut [f64]| {
        model.phi(q, &mut phi[..nh]);
        crate::drive::shift_positions(drives, 0.0, &mut phi[..nh]);
        for (j, &(a, b, theta)) in angle_cols.iter().enumerate() {
            phi[nh + j] = q[a] - b.map_or(0.0, |b| q[b]) - theta;
        }
    };
    let nnz_h = info.n_holonomic_nonzeros();
    let mut pattern_e: Vec<(usize, usize)> = info.pattern[..nnz_h].to_vec();
    let mut angle_values = Vec::new();
    for (j, &(a, b, _)) in angle_cols.iter().enumerate() {
        pattern_e.push((nh + j, a));
        angle_values.push(1.0);
        if let Some(b) = b {
            pattern_e.push((nh + j, b));
            angle_values.push(-1.0);
        }
    }
    let pattern_e = &pattern_e;
    let jacobian = |q: &[f64], values: &mut [f64]| {
        model.holonomic_jacobian(q, &mut values[..nnz_h]);
        values[nnz_h..].copy_from_slice(&angle_values);
    };
    let row_name = |i: usize| {
        if i < nh { info.constraints[i].clone() } else { format!("theta_{}", info.hinges[given.angles[i - nh].0].name) }
    };
    let initial = |reason: String| SimError::Setup(SetupError::Initial { reason });
    let mut q = vec![0.0; nq];
    for &(i, v) in &given.guess {
        q[i] = v;
    }
    let mut known_q = vec![false; nq];
    for &(i, v) in &given.q {
        q[i] = v;
        known_q[i] = true;
    }
    let unknown_q: Vec<usize> = (0..nq).filter(|&i| !known_q[i]).collect();
    let mut phi = vec![0.0; rows];
    let mut jac_values = vec![0.0; pattern_e.len()];
    if unknown_q.len() > rows {
        // which would do in general: at the given values and guesses, the
        // other unknowns at distinct values (zeros put a linkage's bodies
        // on one another, where its Jacobian loses rank)
        let give = (!sparse).then(|| {
            let mut at = q.clone();
            for (k, &i) in unknown_q.iter().enumerate() {
                if !given.guess.iter().any(|&(j, _)| j == i) {
                    at[i] = 0.3 + 0.17 * k as f64;
                }
            }
            jacobian(&at, &mut jac_values);
            to_give(pattern_e, &jac_values, rows, nq, &unknown_q)
        });
        return Err(too_many(info, &unknown_q, rows, "holonomic constraints and given angles", "", give.flatten()));
    }
    let undetermined =
        |k: usize, unknown: &[usize], what: &str, suffix: &str| undetermined(info, k, unknown, what, suffix);
    let holonomic = "the holonomic constraints (hinges, sliders, drives) and given angles";
    // Newton in the unknowns; on the dense path with minimum-norm steps, so
    // that a Jacobian singular on the way (a linkage passing a dead centre
    // at its starting values) does not stop it: only one singular at the
    // solution means the unknowns are not determined
    let mut newton = ColumnSolve::new(pattern_e, rows, nq, &unknown_q, sparse);
    for _ in 0..50 {
        phi_at(&q, &mut phi);
        if max_abs(&phi) <= INITIAL_TOL || unknown_q.is_empty() {
            break;
        }
        jacobian(&q, &mut jac_values);
        let dx = newton.step(pattern_e, &jac_values, &phi).map_err(|e| match e {
            Fail::Dependent(k) => undetermined(k, &unknown_q, holonomic, ""),
            Fail::Other(e) => initial(e),
        })?;
        for (k, &i) in unknown_q.iter().enumerate() {
            q[i] -= dx[k];
        }
    }
    if !unknown_q.is_empty() {
        jacobian(&q, &mut jac_values);
        newton.check_rank(pattern_e, &jac_values).map_err(|k| undetermined(k, &unknown_q, holonomic, ""))?;
    }
    phi_at(&q, &mut phi);
    let mut report = InitialReport::default();
    let res = max_abs(&phi);
    // a redundant row found while projecting: named like the KKT solve names it
    let redundant = |e: Fail| match e {
        Fail::Dependent(row) if row < nh => {
            SimError::from_kkt(info, 0.0, KktError::DependentConstraints { n: nc, row })
        }
        Fail::Dependent(row) => initial(format!(
            "the given angle `{}` depends on the constraints and the other given values",
            row_name(row)
        )),
        Fail::Other(e) => initial(e),
    };
    if res > INITIAL_TOL {
        // The given values violate the holonomic rows: Gauss-Newton with the
        // minimum-norm step in all coordinates (the projection of docs/physics.md §6).
        report.position_violation = res;
        report.position_worst = phi
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map_or(String::new(), |(i, _)| row_name(i));
        let q_given = q.clone();
        let mut min_norm = MinNorm::new(pattern_e, rows, nq, sparse);
        for _ in 0..50 {
            phi_at(&q, &mut phi);
            if max_abs(&phi) <= INITIAL_TOL {
                break;
            }
            jacobian(&q, &mut jac_values);
            let dx = min_norm.solve(pattern_e, &jac_values, &phi).map_err(redundant)?;
            for i in 0..nq {
                q[i] -= dx[i];
            }
        }
        phi_at(&q, &mut phi);
        let left = max_abs(&phi);
        if left.is_nan() || left > 1e-9 {
            return Err(initial(format!(
                "no configuration satisfies the holonomic constraints near the given coordinates (max|C| = {res:.3e}, {left:.3e} after projection)"
            )));
        }
        report.position_correction = q.iter().zip(&q_given).fold(0.0, |m, (a, b)| m.max((a - b).abs()));
        report.position_changes = largest_changes(&q_given, &q, &known_q, |i| info.coords[i].to_string());
    }
    report.branch = given.guess.iter().map(|&(i, g)| (info.coords[i].clone(), g, q[i])).collect();

    let qd = consistent_velocities(model, drives, given, sparse, &q, &mut report, &redundant)?;
    Ok((q, qd, report))
}

/// The names of the coordinates `idx` with `suffix` (`d` for velocities).
fn coord_names(info: &ModelInfo, idx: &[usize], suffix: &str) -> String {
    name_list(idx.iter().map(|&i| format!("{}{suffix}", info.coords[i])))
}

/// More unknowns than equations: which are missing, how many to give,
/// and (`give`, from [`to_give`]) which would do.
fn too_many(
    info: &ModelInfo,
    unknown: &[usize],
    rows: usize,
    what: &str,
    suffix: &str,
    give: Option<Vec<usize>>,
) -> SimError {
    let example = match give {
        // all of them: the list before says so already
        Some(give) if give.len() < unknown.len() => {
            format!(", for example {} (the {what} then determine the rest)", coord_names(info, &give, suffix))
        }
        _ => String::new(),
    };
    SimError::Setup(SetupError::Initial {
        reason: format!(
            "{} {} are missing ({}) but the {rows} {what} determine at most {rows}; give {} more{example}",
            unknown.len(),
            kind(suffix),
            coord_names(info, unknown, suffix),
            unknown.len() - rows
        ),
    })
}

/// Which of the unknowns `unknown` to give so that `rows` equations with
/// the Jacobian `values` on `pattern` (rows x nq) determine the others:
/// the unknowns' columns, from the last one back, that add to the rank
/// (Gram-Schmidt, twice, against those taken) are the determined ones;
/// the rest, in the model's order, are the answer (so the first bodies'
/// values are the ones asked for, as a user writes them). `None` where
/// the columns have less than full row rank (a redundant constraint, or
/// a dead centre at the guess: no choice determines the rest there).
/// Dense, `O(rows^2 nq)`: only where the initial solve is dense too.
fn to_give(
    pattern: &[(usize, usize)],
    values: &[f64],
    rows: usize,
    nq: usize,
    unknown: &[usize],
) -> Option<Vec<usize>> {
    let mut g = vec![0.0; rows * nq];
    scatter_dense(pattern, values, nq, &mut g);
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(rows);
    let mut determined = vec![false; unknown.len()];
    for (k, &c) in unknown.iter().enumerate().rev() {
        if basis.len() == rows {
            break;
        }
        let mut v: Vec<f64> = (0..rows).map(|r| g[r * nq + c]).collect();
        let n0 = norm(&v);
        if !(n0 > 0.0 && n0.is_finite()) {
            continue;
        }
        for _ in 0..2 {
            for b in &basis {
                let d: f64 = b.iter().zip(&v).map(|(a, x)| a * x).sum();
                v.iter_mut().zip(b).for_each(|(x, a)| *x -= d * a);
            }
        }
        // a column within rounding of those taken adds nothing
        let n = norm(&v);
        if n > 1e-8 * n0 {
            v.iter_mut().for_each(|x| *x /= n);
            basis.push(v);
            determined[k] = true;
        }
    }
    (basis.len() == rows).then(|| unknown.iter().zip(&determined).filter(|&(_, &d)| !d).map(|(&i, _)| i).collect())
}

/// The equations `what` leave the unknowns `unknown` undetermined, the
/// `k`-th depending on the others.
fn undetermined(info: &ModelInfo, k: usize, unknown: &[usize], what: &str, suffix: &str) -> SimError {
    let which = match unknown.get(k) {
        Some(&i) => format!(" (`{}{suffix}` depends on the others)", info.coords[i]),
        None => String::new(),
    };
    SimError::Setup(SetupError::Initial {
        reason: format!(
            "{what} do not determine the {} {}{which}; give them",
            kind(suffix),
            coord_names(info, unknown, suffix)
        ),
    })
}

/// The velocities of [`consistent_state_with`] at the consistent positions
/// `q` (nq): the unknown ones solved from `G qd = -u'` (drives), the given
/// ones projected onto the constraints by least squares where they violate
/// them (docs/physics.md §6); a redundant row is named by the caller's
/// `redundant`, as the positions name it.
///
/// # Errors
/// [`SetupError::Initial`] (or a dependent constraint) as the caller says.
fn consistent_velocities<M: Model>(
    model: &M,
    drives: &[crate::drive::Drive],
    given: &Given,
    sparse: bool,
    q: &[f64],
    report: &mut InitialReport,
    redundant: &dyn Fn(Fail) -> SimError,
) -> Result<Vec<f64>, SimError> {
    let info = model.info();
    let info = &info;
    let (nq, nc) = (info.nq(), info.nc());
    let initial = |reason: String| SimError::Setup(SetupError::Initial { reason });
    let mut qd = vec![0.0; nq];
    let mut known_v = vec![false; nq];
    for &(i, v) in &given.qd {
        qd[i] = v;
        known_v[i] = true;
    }
    let unknown_v: Vec<usize> = (0..nq).filter(|&i| !known_v[i]).collect();
    let mut g_all = vec![0.0; info.pattern.len()];
    model.constraint_matrix(q, &mut g_all);
    // the rows the velocities satisfy: all but the released skate rows,
    // renumbered (those come after every holonomic row, so a drive's row
    // keeps its number)
    let (pattern, g_values, nc) = if given.released.is_empty() {
        (info.pattern.clone(), g_all, nc)
    } else {
        let renumber: Vec<Option<usize>> = {
            let mut next = 0;
            (0..nc)
                .map(|r| {
                    (!given.released.contains(&r)).then(|| {
                        next += 1;
                        next - 1
                    })
                })
                .collect()
        };
        let kept = renumber.iter().flatten().count();
        let (pattern, values): (Vec<(usize, usize)>, Vec<f64>) =
            info.pattern.iter().zip(&g_all).filter_map(|(&(r, c), &v)| renumber[r].map(|r| ((r, c), v))).unzip();
        (pattern, values, kept)
    };
    let info_pattern = &pattern;
    // G qd (nc) over the columns `keep`: dense as before on the dense path
    let g_dense = (!sparse).then(|| {
        let mut g = vec![0.0; nc * nq];
        scatter_dense(info_pattern, &g_values, nq, &mut g);
        g
    });
    let g_times = |v: &[f64], keep: &dyn Fn(usize) -> bool, out: &mut [f64]| match &g_dense {
        Some(g) => {
            for (r, o) in out.iter_mut().enumerate() {
                *o = (0..nq).filter(|&k| keep(k)).map(|k| g[r * nq + k] * v[k]).sum::<f64>();
            }
        }
        None => sparse_times(info_pattern, &g_values, v, keep, out),
    };
    if !unknown_v.is_empty() {
        if unknown_v.len() > nc {
            let give = (!sparse).then(|| to_give(info_pattern, &g_values, nc, nq, &unknown_v)).flatten();
            return Err(too_many(info, &unknown_v, nc, "velocity constraints", "d", give));
        }
        let mut target = vec![0.0; nc];
        crate::drive::shift_velocities(drives, 0.0, &mut target);
        let mut known_part = vec![0.0; nc];
        g_times(&qd, &|k| known_v[k], &mut known_part);
        let rhs: Vec<f64> = target.iter().zip(&known_part).map(|(t, g)| -t - g).collect();
        let x = ColumnSolve::new(info_pattern, nc, nq, &unknown_v, sparse)
            .solve(info_pattern, &g_values, &rhs)
            .map_err(|e| match e {
                Fail::Dependent(k) => undetermined(info, k, &unknown_v, "the constraints", "d"),
                Fail::Other(e) => initial(e),
            })?;
        for (k, &i) in unknown_v.iter().enumerate() {
            qd[i] = x[k];
        }
    }
    let mut r = vec![0.0; nc];
    g_times(&qd, &|_| true, &mut r);
    crate::drive::shift_velocities(drives, 0.0, &mut r);
    let res = max_abs(&r);
    // velocities are only known to rounding relative to their size
    let v_tol = INITIAL_TOL * max_abs(&qd).max(1.0);
    if res > v_tol {
        // The given velocities violate the constraints: least-squares
        // projection of all velocities (docs/physics.md §6).
        report.velocity_violation = res;
        let dv = MinNorm::new(info_pattern, nc, nq, sparse).solve(info_pattern, &g_values, &r).map_err(redundant)?;
        for i in 0..nq {
            qd[i] -= dv[i];
        }
        report.velocity_correction = max_abs(&dv);
        let qd_given: Vec<f64> = qd.iter().zip(&dv).map(|(v, d)| v + d).collect();
        report.velocity_changes =
            largest_changes(&qd_given, &qd, &known_v, |i| crate::names::velocity_name(&info.coords[i]));
        g_times(&qd, &|_| true, &mut r);
        crate::drive::shift_velocities(drives, 0.0, &mut r);
        let left = max_abs(&r);
        if left.is_nan() || left > 1e3 * v_tol {
            return Err(initial(format!(
                "the velocity constraints cannot be met (max|G qd| = {left:.3e} m/s after projection)"
            )));
        }
    }
    Ok(qd)
}

/// The given values (`given[i]` for `known[i]`) the projection changed
/// most, at most three: `(name, given, projected)`, largest change first.
fn largest_changes(
    before: &[f64],
    after: &[f64],
    known: &[bool],
    name: impl Fn(usize) -> String,
) -> Vec<(String, f64, f64)> {
    let mut changed: Vec<usize> = (0..before.len())
        .filter(|&i| known[i] && (after[i] - before[i]).abs() > 1e-12 * before[i].abs().max(1.0))
        .collect();
    changed.sort_by(|&a, &b| (after[b] - before[b]).abs().total_cmp(&(after[a] - before[a]).abs()));
    changed.into_iter().take(3).map(|i| (name(i), before[i], after[i])).collect()
}

/// "coordinates" or, for the suffix `d`, "velocities".
fn kind(suffix: &str) -> &'static str {
    if suffix.is_empty() { "coordinates" } else { "velocities" }
}

/// What [`consistent_state`] had to correct in the given values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InitialReport {
    /// `max|C|` of the given coordinates, when they violated the holonomic
    /// constraints (hinges, sliders, drives) \[m or rad\] (else 0).
    pub position_violation: f64,
    /// The row violated most, e.g. `B.y`.
    pub position_worst: String,
    /// Largest change of a coordinate by the projection \[m or rad\].
    pub position_correction: f64,
    /// `max|G qd|` of the given velocities, when they violated the constraints \[m/s\] (else 0).
    pub velocity_violation: f64,
    /// Largest change of a velocity by the projection \[m/s or rad/s\].
    pub velocity_correction: f64,
    /// The given coordinates the projection changed most (at most three):
    /// `(name, given, projected)` \[m or rad\].
    pub position_changes: Vec<(String, f64, f64)>,
    /// The given velocities the projection changed most (at most three):
    /// `(name, given, projected)` \[m/s or rad/s\].
    pub velocity_changes: Vec<(String, f64, f64)>,
    /// The assembly branch taken: `(coordinate, starting value, solved
    /// value)` for every coordinate given a starting value.
    pub branch: Vec<(String, f64, f64)>,
}

impl InitialReport {
    /// One line naming the assembly branch taken, if starting values were given.
    pub fn notes(&self) -> Vec<String> {
        if self.branch.is_empty() {
            return Vec::new();
        }
        let list: Vec<String> = self.branch.iter().map(|(n, g, v)| format!("{n} = {v:.6} (started at {g})")).collect();
        vec![format!("assembled on the branch nearest the starting values: {}", list.join(", "))]
    }

    /// One warning line per correction made.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let changes = |list: &[(String, f64, f64)]| {
            if list.is_empty() {
                return String::new();
            }
            let each: Vec<String> = list.iter().map(|(n, a, b)| format!("{n} {a} -> {b:.6e}")).collect();
            format!("; given values changed: {}", each.join(", "))
        };
        if self.position_violation > 0.0 {
            w.push(format!(
                "the initial coordinates violate the holonomic constraints by {:.3e} (most: `{}`); projected onto them (largest change {:.3e}){}",
                self.position_violation,
                self.position_worst,
                self.position_correction,
                changes(&self.position_changes)
            ));
        }
        if self.velocity_violation > 0.0 {
            w.push(format!(
                "the initial velocities violate the constraints by {:.3e} m/s; projected onto them (largest change {:.3e}){}",
                self.velocity_violation,
                self.velocity_correction,
                changes(&self.velocity_changes)
            ));
        }
        w
    }
}

/// Whether the model's constraints are dependent at every configuration
/// near the consistent positions `q0` (nq), as a duplicated hinge or a
/// closed loop counted twice makes them, rather than at an instant (a dead
/// point, the flat position of a parallelogram: a singular position the
/// motion passes). `G` is checked at `q0` and, where it is rank-deficient
/// there, at two nearby consistent configurations: `q0` moved by fixed,
/// generic offsets of about 1e-2 in each coordinate and projected back
/// onto `phi(q) = u(0)` (with the `drives`). Returns the dependent row at
/// `q0` when it stays dependent at both.
///
/// # Errors
/// [`KktError::NonFinite`] if `G` has a non-finite entry at `q0`.
pub fn redundant_row<M: Model>(
    model: &M,
    info: &crate::model::info::ModelInfo,
    drives: &[crate::drive::Drive],
    mass: &[f64],
    q0: &[f64],
) -> Result<Option<usize>, crate::error::KktError> {
    let Some(row) = crate::kkt::dependent_row(model, info, q0, None)? else { return Ok(None) };
    let mut projector =
        crate::formulation::projection::Projector::new(model, crate::settings::ProjectionKind::Euclidean, mass)
            .with_drives(drives);
    for k in [1.7, 2.9] {
        let mut q: Vec<f64> = q0
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let s = (k * (i as f64 + 1.0)).sin();
                v + 1e-2 * (0.3 + 0.7 * s.abs()) * s.signum()
            })
            .collect();
        let mut qd = vec![0.0; q.len()];
        let projected = projector.project(model, 0.0, &mut q, &mut qd);
        // a configuration where the rows are independent: an instant
        if projected.is_ok_and(|r| r.residual_position <= 1e-9)
            && crate::kkt::dependent_row(model, info, &q, None) == Ok(None)
        {
            return Ok(None);
        }
    }
    Ok(Some(row))
}
