//! Symmetric positive definite solves of the weighted normal matrix
//! `A = G W^-1 G^T` (m x m), shared by the Schur-complement KKT path and by
//! coordinate projection (SPEC §2), where `W` is `M` (mass-weighted) or the
//! identity (Euclidean).
//!
//! `A` is assembled by the model's generated [`Model::normal_matrix`]:
//! straight-line code over the structural nonzeros of `G`, which the macro
//! knows at compile time (24 products for the EzyRoller). Measured on this
//! machine for the EzyRoller's Schur KKT solve: ~180 ns with run-time
//! sparse index lists or with nalgebra `SMatrix` products, ~XX ns with the
//! generated kernels (see the README).
//!
//! `A` is factored by a small in-place Cholesky ([`cholesky_in_place`])
//! that reports a pivot small *relative to its diagonal entry* as dependent
//! constraints (nalgebra's only rejects pivots <= 0, which lets a duplicated
//! constraint through with multipliers of 1e18).

use crate::model::Model;

use super::{KktError, KktSolver, KktSystem};

/// Relative pivot threshold: a Cholesky pivot `d_j` with
/// `d_j <= PIVOT_RTOL * A_jj` means row j of `G` depends on the earlier
/// rows (to rounding), reported as [`KktError::DependentConstraints`].
pub const PIVOT_RTOL: f64 = 1e-13;

/// In-place Cholesky `A = L L^T` of the leading m x m block of the SPD
/// matrix `a` (row-major with row stride `lda`; only the lower triangle is
/// read; `L` overwrites it). `inv_diag` (m) receives `1 / L_jj`.
///
/// # Errors
/// [`KktError::DependentConstraints`] for a pivot `<= PIVOT_RTOL * A_jj`.
#[inline]
pub fn cholesky_in_place(a: &mut [f64], m: usize, lda: usize, inv_diag: &mut [f64]) -> Result<(), KktError> {
    // Sizes of vehicles get a copy with the size a constant, which the
    // compiler unrolls (measured 2-3x faster for m = 4).
    match m {
        1 => chol_impl(a, 1, lda, inv_diag),
        2 => chol_impl(a, 2, lda, inv_diag),
        3 => chol_impl(a, 3, lda, inv_diag),
        4 => chol_impl(a, 4, lda, inv_diag),
        5 => chol_impl(a, 5, lda, inv_diag),
        6 => chol_impl(a, 6, lda, inv_diag),
        7 => chol_impl(a, 7, lda, inv_diag),
        8 => chol_impl(a, 8, lda, inv_diag),
        _ => chol_impl(a, m, lda, inv_diag),
    }
}

#[inline(always)]
fn chol_impl(a: &mut [f64], m: usize, lda: usize, inv_diag: &mut [f64]) -> Result<(), KktError> {
    let inv_diag = &mut inv_diag[..m];
    for j in 0..m {
        let ajj = a[j * lda + j];
        let mut d = ajj;
        for k in 0..j {
            d -= a[j * lda + k] * a[j * lda + k];
        }
        if !(d > PIVOT_RTOL * ajj) {
            return Err(KktError::DependentConstraints { n: m });
        }
        let d = d.sqrt();
        a[j * lda + j] = d;
        inv_diag[j] = 1.0 / d;
        for i in j + 1..m {
            let mut s = a[i * lda + j];
            for k in 0..j {
                s -= a[i * lda + k] * a[j * lda + k];
            }
            a[i * lda + j] = s * inv_diag[j];
        }
    }
    Ok(())
}

/// Solves `L L^T x = r` with the factor from [`cholesky_in_place`].
#[inline]
pub fn cholesky_solve(l: &[f64], m: usize, lda: usize, inv_diag: &[f64], r: &[f64], x: &mut [f64]) {
    match m {
        1 => solve_impl(l, 1, lda, inv_diag, r, x),
        2 => solve_impl(l, 2, lda, inv_diag, r, x),
        3 => solve_impl(l, 3, lda, inv_diag, r, x),
        4 => solve_impl(l, 4, lda, inv_diag, r, x),
        5 => solve_impl(l, 5, lda, inv_diag, r, x),
        6 => solve_impl(l, 6, lda, inv_diag, r, x),
        7 => solve_impl(l, 7, lda, inv_diag, r, x),
        8 => solve_impl(l, 8, lda, inv_diag, r, x),
        _ => solve_impl(l, m, lda, inv_diag, r, x),
    }
}

#[inline(always)]
fn solve_impl(l: &[f64], m: usize, lda: usize, inv_diag: &[f64], r: &[f64], x: &mut [f64]) {
    let (r, x, inv_diag) = (&r[..m], &mut x[..m], &inv_diag[..m]);
    for i in 0..m {
        let mut s = r[i];
        for k in 0..i {
            s -= l[i * lda + k] * x[k];
        }
        x[i] = s * inv_diag[i];
    }
    for i in (0..m).rev() {
        let mut s = x[i];
        for k in i + 1..m {
            s -= l[k * lda + i] * x[k];
        }
        x[i] = s * inv_diag[i];
    }
}

/// The factorization of `A = G W^-1 G^T` for model `Mo`, or of its leading
/// block (the holonomic rows come first in `G`, so the leading nh x nh
/// block is `C_q W^-1 C_q^T`, used by position projection).
#[derive(Debug, Clone)]
pub struct NormalFactor {
    nc: usize,
    m: usize,
    a: Vec<f64>,
    inv_diag: Vec<f64>,
}

impl NormalFactor {
    /// Workspace for `nc` constraint rows.
    pub fn new(nc: usize) -> Self {
        Self { nc, m: 0, a: vec![0.0; nc * nc], inv_diag: vec![0.0; nc] }
    }

    /// Assembles `A` from `G`'s pattern values and `winv` (nq) and factors
    /// its leading `m` x `m` block.
    ///
    /// # Errors
    /// [`KktError::DependentConstraints`] if that block is not (numerically)
    /// positive definite.
    #[inline]
    pub fn factor<Mo: Model>(&mut self, values: &[f64], winv: &[f64], m: usize) -> Result<(), KktError> {
        Mo::normal_matrix(values, winv, &mut self.a);
        self.m = m;
        cholesky_in_place(&mut self.a, m, self.nc, &mut self.inv_diag)
    }

    /// `x = A^-1 r` (m) with the last factorization.
    #[inline]
    pub fn solve(&self, r: &[f64], x: &mut [f64]) {
        cholesky_solve(&self.a, self.m, self.nc, &self.inv_diag, r, x);
    }
}

/// The Schur-complement KKT path: `(G M^-1 G^T) lambda = G M^-1 f + gamma`,
/// `qdd = M^-1 (f - G^T lambda)`. Needs every mass entry > 0.
#[derive(Debug, Clone)]
pub struct SchurCholesky<Mo: Model> {
    normal: NormalFactor,
    mass: Vec<f64>,
    minv: Vec<f64>,
    minv_f: Vec<f64>,
    rhs: Vec<f64>,
    _model: std::marker::PhantomData<Mo>,
}

impl<Mo: Model> SchurCholesky<Mo> {
    /// Workspace for model `Mo`.
    pub fn new() -> Self {
        let (nq, nc) = (Mo::INFO.nq(), Mo::INFO.nc());
        Self {
            normal: NormalFactor::new(nc),
            mass: vec![f64::NAN; nq],
            minv: vec![0.0; nq],
            minv_f: vec![0.0; nq],
            rhs: vec![0.0; nc],
            _model: std::marker::PhantomData,
        }
    }
}

impl<Mo: Model> Default for SchurCholesky<Mo> {
    fn default() -> Self {
        Self::new()
    }
}

impl<Mo: Model> KktSolver for SchurCholesky<Mo> {
    #[inline]
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError> {
        if self.mass[..] != sys.mass[..] {
            for (k, &m) in sys.mass.iter().enumerate() {
                if !(m > 0.0 && m.is_finite()) {
                    return Err(KktError::SingularMass { index: k, value: m });
                }
                self.minv[k] = 1.0 / m;
            }
            self.mass.copy_from_slice(sys.mass);
        }
        let nc = sys.nc();
        self.normal.factor::<Mo>(sys.g_values, &self.minv, nc)?;
        for ((mf, &w), &f) in self.minv_f.iter_mut().zip(&self.minv).zip(sys.f) {
            *mf = w * f;
        }
        Mo::g_mul(sys.g_values, &self.minv_f, &mut self.rhs);
        for (r, &g) in self.rhs.iter_mut().zip(sys.gamma) {
            *r += g;
        }
        self.normal.solve(&self.rhs, lambda);
        qdd.copy_from_slice(&self.minv_f);
        Mo::sub_winv_gt_mul(sys.g_values, &self.minv, lambda, qdd);
        Ok(())
    }
    fn name(&self) -> &'static str {
        "schur-cholesky"
    }
}
