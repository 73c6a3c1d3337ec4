//! Symmetric positive definite solves of the weighted normal matrix
//! `A = G W^-1 G^T` (m x m), shared by the Schur-complement KKT path and by
//! coordinate projection (docs/physics.md §6), where `W` is `M` (mass-weighted) or the
//! identity (Euclidean).
//!
//! `A` is assembled by the model's generated [`Model::normal_matrix`]:
//! straight-line code over the structural nonzeros of `G`, which the macro
//! knows at compile time (24 products for the EzyRoller). Measured on this
//! machine for the EzyRoller's Schur KKT solve: ~180 ns with run-time
//! sparse index lists or with nalgebra `SMatrix` products and Cholesky,
//! ~56 ns with the generated kernels and the unrolled LDL^T below
//! (`cargo bench --bench kkt`, `kkt/schur-cholesky`).
//!
//! `A` is solved by a small square-root-free Cholesky (`L D L^T`,
//! [`ldl_solve`]), unrolled for m <= 8, that reports a
//! pivot small *relative to its diagonal entry* as dependent constraints
//! (nalgebra's Cholesky only rejects pivots <= 0, which lets a duplicated
//! constraint through with multipliers of 1e18). For m = 2 and m = 4 (the
//! EzyRoller's hinge rows, its whole `G`, and Maggi's 2 x 2 on minimal
//! coordinates) explicit 2 x 2 inverses replace the factorization's chain
//! of divisions, one per pivot, by one per block, with the same pivots
//! checked: the right-hand side's longest chain of dependent operations
//! (RK4 at h = 1e-4 s on `drive`: 0.296 s -> 0.28 s; DOP853 at 1e-11:
//! 1.17 -> 1.09 ms).

use crate::model::Model;

use super::{KktSolver, KktSystem};
use crate::error::KktError;

/// Relative pivot threshold: a pivot `D_jj` with
/// `D_jj <= PIVOT_RTOL * A_jj` means row j of `G` depends on the earlier
/// rows (to rounding), reported as [`KktError::DependentConstraints`].
pub const PIVOT_RTOL: f64 = 1e-13;

/// Calls `$fixed::<M>(args)` with `M = $m` a constant for 1 <= m <= 8
/// (unrolled code), else `$dynamic`.
macro_rules! small_size {
    ($m:expr, $fixed:ident($($arg:expr),*), $dynamic:expr) => {
        match $m {
            1 => $fixed::<1>($($arg),*),
            2 => $fixed::<2>($($arg),*),
            3 => $fixed::<3>($($arg),*),
            4 => $fixed::<4>($($arg),*),
            5 => $fixed::<5>($($arg),*),
            6 => $fixed::<6>($($arg),*),
            7 => $fixed::<7>($($arg),*),
            8 => $fixed::<8>($($arg),*),
            _ => $dynamic,
        }
    };
}
pub(crate) use small_size;

/// Solves `A x = r` for the leading m x m block of the SPD matrix `a`
/// (row-major with row stride `lda`; only the lower triangle is read; `a`
/// is not modified) by a square-root-free Cholesky factorization
/// `A = L D L^T` and substitution. Every use in ezy factors once and solves
/// once, so the two are fused: the factor stays in registers for the
/// sizes of vehicles (m <= 8, unrolled). Larger m use `scratch`
/// (at least m * (m + 1) long), so nothing is allocated.
///
/// Returns the pivot growth `max_j A_jj / D_jj` (>= 1): how much of its
/// diagonal the most dependent row lost, a lower bound of the condition
/// number of the diagonally equilibrated matrix (so independent of units
/// and mass ratios). Rows are refused as dependent above `1 / PIVOT_RTOL`.
///
/// # Errors
/// [`KktError::DependentConstraints`] for a pivot `D_jj <= PIVOT_RTOL * A_jj`.
///
/// The 2 x 2 and 4 x 4 cases (a vehicle's speeds, the EzyRoller's
/// constraints) are inlined into the caller; the other sizes are one call.
#[inline(always)]
pub fn ldl_solve(
    a: &[f64],
    m: usize,
    lda: usize,
    r: &[f64],
    x: &mut [f64],
    scratch: &mut [f64],
) -> Result<f64, KktError> {
    match m {
        0 => Ok(1.0),
        2 => solve_2(a, lda, r, x),
        4 => solve_4(a, lda, r, x),
        _ => ldl_solve_other(a, m, lda, r, x, scratch),
    }
}

/// [`ldl_solve`] for the sizes other than 0, 2 and 4.
#[inline(never)]
fn ldl_solve_other(
    a: &[f64],
    m: usize,
    lda: usize,
    r: &[f64],
    x: &mut [f64],
    scratch: &mut [f64],
) -> Result<f64, KktError> {
    small_size!(m, ldl_solve_fixed(a, lda, r, x), ldl_solve_dynamic(a, m, lda, r, x, scratch))
}

/// [`ldl_solve`] for m = 2 by the explicit inverse: one division where the
/// factorization chains two. The pivots `D_00 = a00`, `D_11 = det / a00`
/// are checked as [`ldl_solve_fixed`] checks them (by products: no
/// division on the way), so the same rows are refused.
#[inline(always)]
fn solve_2(a: &[f64], lda: usize, r: &[f64], x: &mut [f64]) -> Result<f64, KktError> {
    let (a00, a10, a11) = (a[0], a[lda], a[lda + 1]);
    let det = pivot_pair([a00, a10, a11], [a00, a11], 0, 2)?;
    let idet = 1.0 / det;
    x[0] = (a11 * r[0] - a10 * r[1]) * idet;
    x[1] = (a00 * r[1] - a10 * r[0]) * idet;
    Ok((a11 * a00 * idet).max(1.0))
}

/// The pivots of the SPD 2 x 2 block `[[a00, a10], [a10, a11]]` (a
/// Schur complement for the second block) at rows `row`, `row + 1` of an
/// n x n matrix, checked as [`ldl_solve_fixed`] checks `D_jj`: non-finite,
/// then `D_jj <= PIVOT_RTOL A_jj` with `A_jj` the matrix's own diagonal
/// `diag` (`D_00 = a00`, `D_11 = det / a00`, multiplied through by
/// `a00 > 0`). Returns the determinant `a00 D_11`.
#[expect(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "`!(x > 0.0)` is also true for NaN, which a pivot test must refuse"
)]
#[inline(always)]
fn pivot_pair(block: [f64; 3], diag: [f64; 2], row: usize, n: usize) -> Result<f64, KktError> {
    let [a00, a10, a11] = block;
    if !a00.is_finite() {
        return Err(KktError::NonFinite { n });
    }
    if !(a00 > PIVOT_RTOL * diag[0]) {
        return Err(KktError::DependentConstraints { n, row });
    }
    let det = a00 * a11 - a10 * a10;
    if !det.is_finite() {
        return Err(KktError::NonFinite { n });
    }
    if !(det > PIVOT_RTOL * diag[1] * a00) {
        return Err(KktError::DependentConstraints { n, row: row + 1 });
    }
    Ok(det)
}

/// [`ldl_solve`] for m = 4 by 2 x 2 blocks: `A11^-1` and the Schur
/// complement `S = A22 - A21 A11^-1 A12` by explicit 2 x 2 inverses, two
/// divisions in the chain where the factorization has four (the
/// EzyRoller's hinge and skate rows: the right-hand side's longest chain
/// of dependent operations). `D_22 = S_00` and `D_33 = det S / S_00` are
/// the factorization's pivots, checked as it checks them.
#[inline(always)]
fn solve_4(a: &[f64], lda: usize, r: &[f64], x: &mut [f64]) -> Result<f64, KktError> {
    // the lower triangle by rows of known length: one bounds check a row
    let a00 = a[0];
    let [a10, a11] = fixed::<2>(&a[lda..]);
    let [a20, a21, a22] = fixed::<3>(&a[2 * lda..]);
    let [a30, a31, a32, a33] = fixed::<4>(&a[3 * lda..]);
    let r = fixed::<4>(r);
    let x: &mut [f64; 4] = (&mut x[..4]).try_into().expect("x has 4 rows");
    let det1 = pivot_pair([a00, a10, a11], [a00, a11], 0, 4)?;
    let i1 = 1.0 / det1;
    // Y = A11^-1 A12, A12 = [[a20, a30], [a21, a31]]
    let y00 = (a11 * a20 - a10 * a21) * i1;
    let y01 = (a11 * a30 - a10 * a31) * i1;
    let y10 = (a00 * a21 - a10 * a20) * i1;
    let y11 = (a00 * a31 - a10 * a30) * i1;
    let s00 = a22 - (a20 * y00 + a21 * y10);
    let s10 = a32 - (a30 * y00 + a31 * y10);
    let s11 = a33 - (a30 * y01 + a31 * y11);
    let det2 = pivot_pair([s00, s10, s11], [a22, a33], 2, 4)?;
    let i2 = 1.0 / det2;
    let w0 = (a11 * r[0] - a10 * r[1]) * i1;
    let w1 = (a00 * r[1] - a10 * r[0]) * i1;
    let b2 = r[2] - (a20 * w0 + a21 * w1);
    let b3 = r[3] - (a30 * w0 + a31 * w1);
    let x2 = (s11 * b2 - s10 * b3) * i2;
    let x3 = (s00 * b3 - s10 * b2) * i2;
    x[0] = w0 - (y00 * x2 + y01 * x3);
    x[1] = w1 - (y10 * x2 + y11 * x3);
    x[2] = x2;
    x[3] = x3;
    Ok((a11 * a00 * i1).max(a22 / s00).max(a33 * s00 * i2).max(1.0))
}

/// The first `N` values of `v` as an array (one bounds check).
#[inline(always)]
fn fixed<const N: usize>(v: &[f64]) -> [f64; N] {
    v[..N].try_into().expect("a slice of N values")
}

// `!(d > tol)` also rejects NaN pivots, which `d <= tol` would let through.
#[expect(
    clippy::neg_cmp_op_on_partial_ord,
    clippy::needless_range_loop,
    reason = "`!(x > 0.0)` is also true for NaN, which a pivot test must refuse and index loops over the small fixed sizes unroll; iterator chains with skip(k) did not"
)]
#[inline(always)]
pub(crate) fn ldl_solve_fixed<const M: usize>(
    a: &[f64],
    lda: usize,
    r: &[f64],
    x: &mut [f64],
) -> Result<f64, KktError> {
    let mut l = [[0.0f64; M]; M];
    for i in 0..M {
        for j in 0..=i {
            l[i][j] = a[i * lda + j];
        }
    }
    let mut d = [0.0f64; M];
    let mut inv = [0.0f64; M];
    for j in 0..M {
        let mut v = [0.0f64; M];
        let mut dj = l[j][j];
        for k in 0..j {
            v[k] = l[j][k] * d[k];
            dj -= l[j][k] * v[k];
        }
        if !dj.is_finite() {
            return Err(KktError::NonFinite { n: M });
        }
        if !(dj > PIVOT_RTOL * l[j][j]) {
            return Err(KktError::DependentConstraints { n: M, row: j });
        }
        d[j] = dj;
        inv[j] = 1.0 / dj;
        for i in j + 1..M {
            let mut s = l[i][j];
            for k in 0..j {
                s -= l[i][k] * v[k];
            }
            l[i][j] = s * inv[j];
        }
    }
    let mut y = [0.0f64; M];
    for i in 0..M {
        let mut s = r[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s;
    }
    for i in (0..M).rev() {
        let mut s = y[i] * inv[i];
        for k in i + 1..M {
            s -= l[k][i] * y[k];
        }
        y[i] = s;
    }
    x[..M].copy_from_slice(&y);
    let mut growth = 1.0f64;
    for j in 0..M {
        growth = growth.max(l_diag(a, lda, j) * inv[j]);
    }
    Ok(growth)
}

/// `A_jj` of the input matrix.
#[inline(always)]
fn l_diag(a: &[f64], lda: usize, j: usize) -> f64 {
    a[j * lda + j]
}

/// The same for any m, with the factor in `scratch` (m * (m + 1)).
#[expect(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "`!(x > 0.0)` is also true for NaN, which a pivot test must refuse"
)]
fn ldl_solve_dynamic(
    a: &[f64],
    m: usize,
    lda: usize,
    r: &[f64],
    x: &mut [f64],
    scratch: &mut [f64],
) -> Result<f64, KktError> {
    let (l, inv) = scratch[..m * (m + 1)].split_at_mut(m * m);
    for (k, lk) in l.iter_mut().enumerate() {
        *lk = a[(k / m) * lda + k % m];
    }
    for j in 0..m {
        let ajj = l[j * m + j];
        let mut d = ajj;
        for k in 0..j {
            d -= l[j * m + k] * l[j * m + k] * l[k * m + k];
        }
        if !d.is_finite() {
            return Err(KktError::NonFinite { n: m });
        }
        if !(d > PIVOT_RTOL * ajj) {
            return Err(KktError::DependentConstraints { n: m, row: j });
        }
        l[j * m + j] = d;
        inv[j] = 1.0 / d;
        for i in j + 1..m {
            let mut s = l[i * m + j];
            for k in 0..j {
                s -= l[i * m + k] * l[j * m + k] * l[k * m + k];
            }
            l[i * m + j] = s * inv[j];
        }
    }
    ldl_substitute(l, inv, m, r, x);
    Ok((0..m).map(|j| a[j * lda + j] * inv[j]).fold(1.0, f64::max))
}

/// `x = (L D L^T)^-1 r` for the factor `L` (m x m, unit lower triangle
/// below the diagonal, row-major) and `inv = D^-1` (m).
fn ldl_substitute(l: &[f64], inv: &[f64], m: usize, r: &[f64], x: &mut [f64]) {
    for i in 0..m {
        let mut s = r[i];
        for k in 0..i {
            s -= l[i * m + k] * x[k];
        }
        x[i] = s;
    }
    for i in (0..m).rev() {
        let mut s = x[i] * inv[i];
        for k in i + 1..m {
            s -= l[k * m + i] * x[k];
        }
        x[i] = s;
    }
}

/// Relative regularization of [`regularized_solve`]: `A + mu diag(A)` is
/// factored with `mu = SINGULAR_MU`, ten times the pivot threshold
/// [`PIVOT_RTOL`] below which the plain factorization gives up.
pub const SINGULAR_MU: f64 = 1e-12;

/// Most refinement sweeps of [`regularized_solve`]. A component of `x`
/// along an eigenvector of the equilibrated `A` with eigenvalue `s` loses
/// the factor `mu / (s + mu)` per sweep, so the well-determined components
/// converge to rounding in two or three sweeps; the sweeps stop earlier
/// when the update falls to rounding.
pub const SINGULAR_SWEEPS: usize = 16;

/// Length of the workspace [`regularized_solve`] needs for an m x m system.
pub const fn regularized_scratch(m: usize) -> usize {
    m * m + 4 * m
}

/// Solves the symmetric positive *semi*-definite system `A x = r` (m x m,
/// row-major with stride `lda`, lower triangle read) where the plain
/// factorization ([`ldl_solve`]) found `A` singular: a rank-deficient
/// constraint Jacobian at an instant (a dead point, a lock-up, the flat
/// position of a parallelogram), where the accelerations are still unique
/// but the multipliers are not.
///
/// Iterated Tikhonov regularization (the dual form of the augmented
/// Lagrangian method: Bayo & Ledesma, "Augmented Lagrangian and
/// mass-orthogonal projection methods for constrained multibody dynamics",
/// Nonlinear Dynamics 9 (1996) 113-130): `A_mu = A + mu D` with `D =
/// diag(A)` (so the regularization does not depend on units or mass
/// ratios) is factored once by `L D L^T`, and from `x = 0` each sweep adds
/// `A_mu^-1 (r - A x)`. For a consistent `r` this converges to the solution
/// of least `x^T D x` (the minimum-norm multipliers in the equilibrated
/// metric); the components along directions that are singular to rounding
/// stay bounded by `1 / mu` per sweep instead of the `1 / eps` of an exact
/// solve, so `W^-1 G^T x`, the part of the multipliers that moves the
/// system, stays exact to the regularization's level.
///
/// `work` holds at least `regularized_scratch(m)` values. Returns the
/// number of sweeps done.
///
/// # Errors
/// [`KktError::NonFinite`] if `A` or `r` has a non-finite entry.
#[expect(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "`!(x > 0.0)` is also true for NaN, which a pivot test must refuse"
)]
pub fn regularized_solve(
    a: &[f64],
    m: usize,
    lda: usize,
    r: &[f64],
    x: &mut [f64],
    work: &mut [f64],
) -> Result<usize, KktError> {
    let (l, rest) = work[..regularized_scratch(m)].split_at_mut(m * m);
    let (inv, rest) = rest.split_at_mut(m);
    let (scale, rest) = rest.split_at_mut(m);
    let (res, dx) = rest.split_at_mut(m);
    let dmax = (0..m).map(|j| a[j * lda + j]).fold(0.0, f64::max);
    if !dmax.is_finite() || r[..m].iter().any(|v| !v.is_finite()) {
        return Err(KktError::NonFinite { n: m });
    }
    x[..m].fill(0.0);
    if !(dmax > 0.0) {
        // G = 0: every multiplier does, the least is 0
        return Ok(0);
    }
    // a zero row of G (A_jj = 0) is regularized at the scale of the others
    for (j, s) in scale.iter_mut().enumerate() {
        *s = a[j * lda + j].max(f64::EPSILON * dmax);
    }
    for i in 0..m {
        for j in 0..=i {
            l[i * m + j] = a[i * lda + j];
        }
        l[i * m + i] += SINGULAR_MU * scale[i];
    }
    for j in 0..m {
        let mut d = l[j * m + j];
        for k in 0..j {
            d -= l[j * m + k] * l[j * m + k] * l[k * m + k];
        }
        if !d.is_finite() {
            return Err(KktError::NonFinite { n: m });
        }
        // A_mu is positive definite in exact arithmetic; a pivot lost to
        // rounding anyway keeps the regularization's own size
        let d = if d > 0.5 * SINGULAR_MU * scale[j] { d } else { SINGULAR_MU * scale[j] };
        l[j * m + j] = d;
        inv[j] = 1.0 / d;
        for i in j + 1..m {
            let mut s = l[i * m + j];
            for k in 0..j {
                s -= l[i * m + k] * l[j * m + k] * l[k * m + k];
            }
            l[i * m + j] = s * inv[j];
        }
    }
    let mut sweeps = 0;
    for _ in 0..SINGULAR_SWEEPS {
        // res = r - A x, A symmetric from its lower triangle
        for i in 0..m {
            let mut s = r[i];
            for j in 0..m {
                let aij = if j <= i { a[i * lda + j] } else { a[j * lda + i] };
                s -= aij * x[j];
            }
            res[i] = s;
        }
        ldl_substitute(l, inv, m, res, dx);
        sweeps += 1;
        let (mut step, mut size) = (0.0f64, 0.0f64);
        for j in 0..m {
            x[j] += dx[j];
            let w = scale[j].sqrt();
            step = step.max((dx[j] * w).abs());
            size = size.max((x[j] * w).abs());
        }
        if !(step > 8.0 * f64::EPSILON * size) {
            break;
        }
    }
    Ok(sweeps)
}

/// `A = G W^-1 G^T` for model `Mo`, or its leading block (the holonomic
/// rows come first in `G`, so the leading nh x nh block is
/// `C_q W^-1 C_q^T`, used by position projection), assembled and solved.
#[derive(Debug, Clone)]
pub struct NormalSystem {
    nc: usize,
    a: Vec<f64>,
    scratch: Vec<f64>,
    /// Whether the last solve found the block singular and took
    /// [`regularized_solve`].
    singular: bool,
}

impl NormalSystem {
    /// Workspace for `nc` constraint rows.
    pub fn new(nc: usize) -> Self {
        Self { nc, a: vec![0.0; nc * nc], scratch: vec![0.0; regularized_scratch(nc)], singular: false }
    }

    /// Whether the last [`NormalSystem::solve`] found its block singular
    /// (a rank-deficient `G` at this state) and solved it regularized.
    pub fn was_singular(&self) -> bool {
        self.singular
    }

    /// Assembles `A` from `G`'s pattern values and `winv` (nq) and solves
    /// `A_m x = r` with `A_m` its leading `m` x `m` block (x, r: m);
    /// returns the pivot growth (see [`ldl_solve`]). A block that is
    /// singular to rounding (dependent rows of `G` at this state) is solved
    /// by [`regularized_solve`], reported by [`NormalSystem::was_singular`],
    /// with the growth `1 / PIVOT_RTOL`.
    ///
    /// The rows `released` (their entries of `G` zeroed by the caller:
    /// rows taken out, [`KktSystem::released`]) get a unit diagonal.
    ///
    /// # Errors
    /// [`KktError::NonFinite`] if `A` or `r` has a non-finite entry.
    // always into `Dynamics::rhs` (one call per evaluation): left to the
    // inliner, it stayed out of line once `simulate` was split into
    // modules (another partition of the instances), 11 M instructions
    // more on `drive --formulation dae --t-end 6` (callgrind)
    #[inline(always)]
    #[expect(
        clippy::too_many_arguments,
        reason = "a step or an evaluation takes its state as flat borrowed slices (as Hairer's codes pass them): no struct is built per call"
    )]
    pub fn solve<Mo: Model>(
        &mut self,
        model: &Mo,
        pattern: &[(usize, usize)],
        values: &[f64],
        winv: &[f64],
        (m, released): (usize, &[usize]),
        r: &[f64],
        x: &mut [f64],
    ) -> Result<f64, KktError> {
        model.normal_matrix(pattern, self.nc, values, winv, &mut self.a);
        for &row in released.iter().filter(|&&row| row < m) {
            self.a[row * self.nc + row] = 1.0;
        }
        self.singular = false;
        match ldl_solve(&self.a, m, self.nc, r, x, &mut self.scratch) {
            Err(KktError::DependentConstraints { .. }) => self.solve_singular(m, r, x),
            other => other,
        }
    }

    /// The block assembled by the last [`NormalSystem::solve`], solved by
    /// [`regularized_solve`] (kept out of line: rare).
    #[cold]
    #[inline(never)]
    fn solve_singular(&mut self, m: usize, r: &[f64], x: &mut [f64]) -> Result<f64, KktError> {
        regularized_solve(&self.a, m, self.nc, r, x, &mut self.scratch)?;
        self.singular = true;
        Ok(1.0 / PIVOT_RTOL)
    }

    /// Assembles `A = G W^-1 G^T` from `G`'s pattern values and `winv`
    /// (nq) without solving (for [`NormalSystem::strict_rank_check`]).
    pub fn assemble<Mo: Model>(&mut self, model: &Mo, pattern: &[(usize, usize)], values: &[f64], winv: &[f64]) {
        model.normal_matrix(pattern, self.nc, values, winv, &mut self.a);
    }

    /// Solves the block assembled by the last [`NormalSystem::solve`] or
    /// [`NormalSystem::assemble`] with
    /// the strict pivot test only (no regularization): whether its leading
    /// `m` rows are independent, and if not the first dependent row.
    pub fn strict_rank_check(&mut self, m: usize) -> Result<(), KktError> {
        let r = vec![1.0; m];
        let mut x = vec![0.0; m];
        ldl_solve(&self.a, m, self.nc, &r, &mut x, &mut self.scratch).map(|_| ())
    }
}

/// The Schur-complement KKT path: `(G M^-1 G^T) lambda = G M^-1 f + gamma`,
/// `qdd = M^-1 (f - G^T lambda)`. Needs every mass entry > 0.
#[derive(Debug, Clone)]
pub struct SchurCholesky<Mo: Model> {
    /// The model (its generated products with `G`) and the pattern of `G`.
    model: Mo,
    pattern: Vec<(usize, usize)>,
    normal: NormalSystem,
    /// `M^-1` diagonal, from the mass at construction.
    minv: Vec<f64>,
    rhs: Vec<f64>,
    /// Pivot growth of the last solve.
    growth: f64,
    _model: std::marker::PhantomData<Mo>,
}

impl<Mo: Model> SchurCholesky<Mo> {
    /// Workspace for `model` (with its `info`) and mass diagonal `mass`
    /// (nq), fixed for the solver's life (parameters do not change during
    /// a run).
    ///
    /// # Errors
    /// [`KktError::SingularMass`] if an entry is not positive and finite.
    pub fn new(model: &Mo, info: &crate::model::info::ModelInfo, mass: &[f64]) -> Result<Self, KktError> {
        let (nq, nc) = (info.nq(), info.nc());
        let mut minv = vec![0.0; nq];
        for (k, (&m, w)) in mass.iter().zip(&mut minv).enumerate() {
            if !(m > 0.0 && m.is_finite()) {
                return Err(KktError::SingularMass { index: k, value: m });
            }
            *w = 1.0 / m;
        }
        Ok(Self {
            model: model.clone(),
            pattern: info.pattern.clone(),
            normal: NormalSystem::new(nc),
            minv,
            rhs: vec![0.0; nc],
            growth: 1.0,
            _model: std::marker::PhantomData,
        })
    }
}

impl<Mo: Model> KktSolver for SchurCholesky<Mo> {
    #[inline]
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError> {
        debug_assert!(sys.mass.iter().zip(&self.minv).all(|(m, w)| *m * *w == 1.0 || (*m * *w - 1.0).abs() < 1e-15));
        let nc = sys.nc();
        self.model.g_winv_mul(&self.pattern, sys.g_values, &self.minv, sys.f, &mut self.rhs);
        for (r, &g) in self.rhs.iter_mut().zip(sys.gamma) {
            *r += g;
        }
        self.growth = self.normal.solve(
            &self.model,
            &self.pattern,
            sys.g_values,
            &self.minv,
            (nc, sys.released),
            &self.rhs,
            lambda,
        )?;
        for ((a, &w), &f) in qdd.iter_mut().zip(&self.minv).zip(sys.f) {
            *a = w * f;
        }
        self.model.sub_winv_gt_mul(&self.pattern, sys.g_values, &self.minv, lambda, qdd);
        Ok(())
    }
    fn name(&self) -> &'static str {
        "schur-cholesky"
    }
    fn condition_estimate(&self) -> Option<f64> {
        Some(self.growth)
    }
    fn was_singular(&self) -> bool {
        self.normal.was_singular()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A = B B^T + m I for a deterministic B: SPD, well conditioned.
    fn spd(m: usize) -> Vec<f64> {
        let b = |i: usize, j: usize| ((i * 7 + j * 3) % 5) as f64 - 2.0 + 0.1 * (i as f64);
        (0..m * m)
            .map(|k| {
                let (i, j) = (k / m, k % m);
                (0..m).map(|l| b(i, l) * b(j, l)).sum::<f64>() + if i == j { m as f64 } else { 0.0 }
            })
            .collect()
    }

    #[test]
    fn solves_small_and_large_systems() {
        for m in [1, 2, 4, 8, 9, 13] {
            let a = spd(m);
            let r: Vec<f64> = (0..m).map(|i| 1.0 + i as f64).collect();
            let mut x = vec![0.0; m];
            let mut scratch = vec![0.0; m * (m + 1)];
            ldl_solve(&a, m, m, &r, &mut x, &mut scratch).unwrap();
            for i in 0..m {
                let ax: f64 = (0..m).map(|j| a[i * m + j] * x[j]).sum();
                assert!((ax - r[i]).abs() < 1e-12 * r[i].abs().max(1.0), "m = {m}, row {i}: {ax} vs {}", r[i]);
            }
        }
    }

    /// The explicit 2 x 2 and 4 x 4 block solves give the factorization's
    /// solution, pivot growth and refusals (the same row for a dependent
    /// constraint at each position, inside a larger matrix too).
    #[test]
    fn block_solves_match_the_factorization() {
        for m in [2, 4] {
            for shift in [0.0, 1e-3, 10.0] {
                let mut a = spd(m);
                for i in 0..m {
                    a[i * m + i] += shift;
                }
                let r: Vec<f64> = (0..m).map(|i| 1.0 - 0.7 * i as f64).collect();
                let (mut x, mut y) = (vec![0.0; m], vec![0.0; m]);
                let g = ldl_solve(&a, m, m, &r, &mut x, &mut []).unwrap();
                let h = ldl_solve_dynamic(&a, m, m, &r, &mut y, &mut vec![0.0; m * (m + 1)]).unwrap();
                assert!((g - h).abs() <= 1e-12 * h, "m = {m}: growth {g} vs {h}");
                for (u, v) in x.iter().zip(&y) {
                    assert!((u - v).abs() <= 1e-12 * v.abs().max(1.0), "m = {m}: {x:?} vs {y:?}");
                }
            }
            // row k a copy of row k - 1 (Gram matrix of dependent vectors)
            for k in 1..m {
                let v = |i: usize| -> Vec<f64> {
                    let i = if i == k { k - 1 } else { i };
                    (0..m).map(|j| if i == j { 1.0 } else { 0.1 * (i + j) as f64 }).collect()
                };
                let a: Vec<f64> = (0..m * m).map(|n| v(n / m).iter().zip(v(n % m)).map(|(p, q)| p * q).sum()).collect();
                let mut x = vec![0.0; m];
                let fast = ldl_solve(&a, m, m, &vec![1.0; m], &mut x, &mut []);
                let slow = ldl_solve_dynamic(&a, m, m, &vec![1.0; m], &mut x, &mut vec![0.0; m * (m + 1)]);
                assert_eq!(fast, slow, "m = {m}, row {k}");
                assert_eq!(fast, Err(KktError::DependentConstraints { n: m, row: k }));
            }
            let mut a = spd(m);
            a[m * m - 1] = f64::NAN;
            assert_eq!(
                ldl_solve(&a, m, m, &vec![1.0; m], &mut vec![0.0; m], &mut []),
                Err(KktError::NonFinite { n: m })
            );
        }
    }

    /// A rank-deficient, consistent system (G with a repeated row, so
    /// `G G^T` has rank m - 1) is solved by the regularized sweeps to the
    /// least solution: `A x = r` to rounding, and `x` splits the repeated
    /// row's share evenly (the minimum-norm multipliers, to `eps / mu`). A nearly
    /// singular one (the copy tilted by 1e-9) gives the same `G^T x`.
    #[test]
    fn regularized_solve_gives_the_least_solution() {
        for m in [3, 5, 9] {
            for tilt in [0.0, 1e-9] {
                // rows of G (m x m+1): row m-1 repeats row m-2, tilted
                let g = |i: usize, j: usize| -> f64 {
                    let i2 = if i == m - 1 { m - 2 } else { i };
                    let base = if i2 == j { 2.0 } else { 0.1 * ((i2 * 3 + j) % 4) as f64 };
                    base + if i == m - 1 && j == m { tilt } else { 0.0 }
                };
                let n = m + 1;
                let a: Vec<f64> = (0..m * m).map(|k| (0..n).map(|l| g(k / m, l) * g(k % m, l)).sum()).collect();
                // consistent: r = G v for some v
                let v: Vec<f64> = (0..n).map(|j| 1.0 - 0.3 * j as f64).collect();
                let r: Vec<f64> = (0..m).map(|i| (0..n).map(|j| g(i, j) * v[j]).sum()).collect();
                let mut x = vec![0.0; m];
                let mut work = vec![0.0; regularized_scratch(m)];
                let sweeps = regularized_solve(&a, m, m, &r, &mut x, &mut work).unwrap();
                assert!(sweeps <= SINGULAR_SWEEPS);
                let scale = r.iter().fold(0.0f64, |s, v| s.max(v.abs()));
                for i in 0..m {
                    let ax: f64 = (0..m).map(|j| a[i * m + j] * x[j]).sum();
                    assert!((ax - r[i]).abs() < 1e-9 * scale, "m = {m}, tilt {tilt}, row {i}: {ax} vs {}", r[i]);
                }
                // least to eps / mu: rounding in the residual grows by
                // 1 / mu along the null direction (harmless: G^T there is 0)
                if tilt == 0.0 {
                    assert!((x[m - 1] - x[m - 2]).abs() < 1e-3 * x[m - 2].abs().max(1.0), "least: {x:?}");
                }
                // G^T x, what moves the system, equals that of the exact
                // (full-rank) solution of the other rows
                let gtx: Vec<f64> = (0..n).map(|j| (0..m).map(|i| g(i, j) * x[i]).sum()).collect();
                let mut y = vec![0.0; m - 1];
                let b: Vec<f64> = (0..m - 1).flat_map(|i| a[i * m..i * m + m - 1].to_vec()).collect();
                ldl_solve_dynamic(&b, m - 1, m - 1, &r, &mut y, &mut vec![0.0; m * m]).unwrap();
                let gty: Vec<f64> = (0..n).map(|j| (0..m - 1).map(|i| g(i, j) * y[i]).sum()).collect();
                for j in 0..n {
                    assert!((gtx[j] - gty[j]).abs() < 1e-6 * scale, "m = {m}, tilt {tilt}: {gtx:?} vs {gty:?}");
                }
            }
        }
        // and a non-finite system is refused
        let mut x = [0.0; 2];
        assert_eq!(
            regularized_solve(&[f64::NAN, 0.0, 0.0, 1.0], 2, 2, &[1.0, 1.0], &mut x, &mut [0.0; 12]),
            Err(KktError::NonFinite { n: 2 })
        );
    }

    #[test]
    fn leading_block_and_dependent_rows() {
        // the leading 3 x 3 block of a 5 x 5 matrix (row stride 5)
        let a = spd(5);
        let r = [1.0, -2.0, 0.5];
        let mut x = [0.0; 3];
        ldl_solve(&a, 3, 5, &r, &mut x, &mut [0.0; 30]).unwrap();
        for i in 0..3 {
            let ax: f64 = (0..3).map(|j| a[i * 5 + j] * x[j]).sum();
            assert!((ax - r[i]).abs() < 1e-12);
        }
        // rank 1: a duplicated constraint row gives G G^T = [[1, 1], [1, 1]]
        for m in [2, 10] {
            let a: Vec<f64> = vec![1.0; m * m];
            let mut x = vec![0.0; m];
            let err = ldl_solve(&a, m, m, &vec![1.0; m], &mut x, &mut vec![0.0; m * (m + 1)]);
            assert_eq!(err, Err(KktError::DependentConstraints { n: m, row: 1 }));
        }
    }
}
