//! Symmetric positive definite solves of the weighted normal matrix
//! `A = G W^-1 G^T` (m x m), shared by the Schur-complement KKT path and by
//! coordinate projection (SPEC §2), where `W` is `M` (mass-weighted) or the
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
//! `A` is factored by a small in-place, square-root-free Cholesky
//! (`L D L^T`, [`cholesky_in_place`]), unrolled for m <= 8, that reports a
//! pivot small *relative to its diagonal entry* as dependent constraints
//! (nalgebra's Cholesky only rejects pivots <= 0, which lets a duplicated
//! constraint through with multipliers of 1e18).

use crate::model::Model;

use super::{KktError, KktSolver, KktSystem};

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

/// In-place Cholesky factorization `A = L D L^T` (square-root free) of the
/// leading m x m block of the SPD matrix `a` (row-major with row stride
/// `lda`; only the lower triangle is read). The unit lower triangle `L`
/// overwrites the strict lower triangle, `D` the diagonal; `inv_diag` (m)
/// receives `1 / D_jj`.
///
/// # Errors
/// [`KktError::DependentConstraints`] for a pivot `D_jj <= PIVOT_RTOL * A_jj`.
#[inline]
pub fn cholesky_in_place(a: &mut [f64], m: usize, lda: usize, inv_diag: &mut [f64]) -> Result<(), KktError> {
    // Sizes of vehicles get a copy with the size a constant, which the
    // compiler unrolls into straight-line code (measured with callgrind:
    // 310 instructions per 4 x 4 factorization with run-time loops).
    if m == 0 {
        return Ok(());
    }
    small_size!(m, ldl_fixed(a, lda, inv_diag), ldl_dynamic(a, m, lda, inv_diag))
}

// `!(d > tol)` also rejects NaN pivots, which `d <= tol` would let through.
#[allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]
#[inline(always)]
fn ldl_fixed<const M: usize>(a: &mut [f64], lda: usize, inv_diag: &mut [f64]) -> Result<(), KktError> {
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
        if !(dj > PIVOT_RTOL * l[j][j]) {
            return Err(KktError::DependentConstraints { n: M });
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
    for i in 0..M {
        for j in 0..i {
            a[i * lda + j] = l[i][j];
        }
        a[i * lda + i] = d[i];
    }
    inv_diag[..M].copy_from_slice(&inv);
    Ok(())
}

#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn ldl_dynamic(a: &mut [f64], m: usize, lda: usize, inv_diag: &mut [f64]) -> Result<(), KktError> {
    for j in 0..m {
        let ajj = a[j * lda + j];
        let mut d = ajj;
        for k in 0..j {
            d -= a[j * lda + k] * a[j * lda + k] * a[k * lda + k];
        }
        if !(d > PIVOT_RTOL * ajj) {
            return Err(KktError::DependentConstraints { n: m });
        }
        a[j * lda + j] = d;
        inv_diag[j] = 1.0 / d;
        for i in j + 1..m {
            let mut s = a[i * lda + j];
            for k in 0..j {
                s -= a[i * lda + k] * a[j * lda + k] * a[k * lda + k];
            }
            a[i * lda + j] = s * inv_diag[j];
        }
    }
    Ok(())
}

/// Solves `L D L^T x = r` with the factor from [`cholesky_in_place`].
#[inline]
pub fn cholesky_solve(l: &[f64], m: usize, lda: usize, inv_diag: &[f64], r: &[f64], x: &mut [f64]) {
    if m > 0 {
        small_size!(m, solve_fixed(l, lda, inv_diag, r, x), solve_dynamic(l, m, lda, inv_diag, r, x));
    }
}

#[inline(always)]
fn solve_fixed<const M: usize>(l: &[f64], lda: usize, inv_diag: &[f64], r: &[f64], x: &mut [f64]) {
    let mut y = [0.0f64; M];
    y.copy_from_slice(&r[..M]);
    substitute(l, M, lda, inv_diag, &mut y);
    x[..M].copy_from_slice(&y);
}

fn solve_dynamic(l: &[f64], m: usize, lda: usize, inv_diag: &[f64], r: &[f64], x: &mut [f64]) {
    x[..m].copy_from_slice(&r[..m]);
    substitute(l, m, lda, inv_diag, &mut x[..m]);
}

/// Forward (`L`), diagonal (`D`) and backward (`L^T`) substitution in place.
#[inline(always)]
fn substitute(l: &[f64], m: usize, lda: usize, inv_diag: &[f64], y: &mut [f64]) {
    for i in 0..m {
        let mut s = y[i];
        for k in 0..i {
            s -= l[i * lda + k] * y[k];
        }
        y[i] = s;
    }
    for i in (0..m).rev() {
        let mut s = y[i] * inv_diag[i];
        for k in i + 1..m {
            s -= l[k * lda + i] * y[k];
        }
        y[i] = s;
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
    /// `M^-1` diagonal, from the mass at construction.
    minv: Vec<f64>,
    rhs: Vec<f64>,
    _model: std::marker::PhantomData<Mo>,
}

impl<Mo: Model> SchurCholesky<Mo> {
    /// Workspace for model `Mo` with mass diagonal `mass` (nq), fixed for
    /// the solver's life (parameters do not change during a run).
    ///
    /// # Errors
    /// [`KktError::SingularMass`] if an entry is not positive and finite.
    pub fn new(mass: &[f64]) -> Result<Self, KktError> {
        let (nq, nc) = (Mo::INFO.nq(), Mo::INFO.nc());
        let mut minv = vec![0.0; nq];
        for (k, (&m, w)) in mass.iter().zip(&mut minv).enumerate() {
            if !(m > 0.0 && m.is_finite()) {
                return Err(KktError::SingularMass { index: k, value: m });
            }
            *w = 1.0 / m;
        }
        Ok(Self { normal: NormalFactor::new(nc), minv, rhs: vec![0.0; nc], _model: std::marker::PhantomData })
    }
}

impl<Mo: Model> KktSolver for SchurCholesky<Mo> {
    #[inline]
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError> {
        debug_assert!(sys.mass.iter().zip(&self.minv).all(|(m, w)| *m * *w == 1.0 || (*m * *w - 1.0).abs() < 1e-15));
        let nc = sys.nc();
        self.normal.factor::<Mo>(sys.g_values, &self.minv, nc)?;
        Mo::g_winv_mul(sys.g_values, &self.minv, sys.f, &mut self.rhs);
        for (r, &g) in self.rhs.iter_mut().zip(sys.gamma) {
            *r += g;
        }
        self.normal.solve(&self.rhs, lambda);
        for ((a, &w), &f) in qdd.iter_mut().zip(&self.minv).zip(sys.f) {
            *a = w * f;
        }
        Mo::sub_winv_gt_mul(sys.g_values, &self.minv, lambda, qdd);
        Ok(())
    }
    fn name(&self) -> &'static str {
        "schur-cholesky"
    }
}
