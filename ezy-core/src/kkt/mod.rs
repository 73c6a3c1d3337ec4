//! Solving the KKT system of the index-1 DAE (docs/physics.md §5):
//!
//! ```text
//! [ M  G^T ] [ qdd    ]   [ f      ]
//! [ G  0   ] [ lambda ] = [ -gamma ]
//! ```
//!
//! behind one small trait ([`KktSolver`], after diffsol's `LinearSolver`), with
//! two dense paths:
//!
//! - [`SchurCholesky`]: where `M` is invertible (diagonal, all entries > 0),
//!   eliminate `qdd` and solve the (nc x nc) Schur complement
//!   `(G M^-1 G^T) lambda = G M^-1 f + gamma` by Cholesky, then
//!   `qdd = M^-1 (f - G^T lambda)`. For the EzyRoller that is a 4 x 4 SPD
//!   solve instead of a 10 x 10 LU.
//! - [`DenseLu`]: LU with partial pivoting of the whole (nq + nc) KKT matrix
//!   (faer, preallocated workspace): needs no `M^-1`, so it also serves a
//!   singular mass matrix.
//!
//! - [`SparseSchur`]: the same Schur complement in faer's sparse format,
//!   with the ordering and symbolic factor computed once, for large models.
//!
//! [`KktMethod::Auto`] picks the Schur path when every mass entry is positive
//! (measured faster: see `benches/` and the README), the sparse one from
//! [`SPARSE_FROM_ROWS`] constraint rows, else LU.

mod dense_lu;
mod sparse;
pub(crate) mod spd;

pub use dense_lu::DenseLu;
pub use sparse::{SparseSchur, synthetic_chain};
pub use spd::{NormalSystem, PIVOT_RTOL, SchurCholesky, ldl_solve};

use crate::model::Model;

/// Errors of a KKT solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KktError {
    /// The Schur complement `G M^-1 G^T` is not positive definite: the
    /// constraint rows are (numerically) dependent.
    #[error(
        "the constraint matrix G has dependent rows: row {row} depends on the rows before it (G M^-1 G^T, {n} x {n}, is not positive definite)"
    )]
    DependentConstraints {
        /// Size of the Schur complement (nc).
        n: usize,
        /// The first row of `G` found to depend on the rows before it.
        row: usize,
    },
    /// The system has non-finite entries: the state it was built from
    /// overflowed (a step far too large, or absurd initial values).
    #[error("the KKT system ({n} x {n}) has non-finite entries: the state overflowed")]
    NonFinite {
        /// Size of the factored matrix.
        n: usize,
    },
    /// The KKT matrix is singular (LU found a zero pivot).
    #[error("the KKT matrix ({n} x {n}) is singular")]
    SingularKkt {
        /// Size of the KKT matrix (nq + nc).
        n: usize,
    },
    /// The Schur path needs every mass-matrix entry positive.
    #[error("the Schur-complement path needs an invertible mass matrix; M[{index}] = {}", crate::error::fmt_value(*value))]
    SingularMass {
        /// Coordinate index of the offending diagonal entry.
        index: usize,
        /// Its value \[kg\] or \[kg m^2\].
        value: f64,
    },
}

/// One KKT system, borrowed from the caller's workspace.
#[derive(Debug, Clone, Copy)]
pub struct KktSystem<'a> {
    /// Diagonal of the mass matrix `M` (nq) \[kg, kg m^2\].
    pub mass: &'a [f64],
    /// Constraint matrix `G` (nc x nq), dense row-major.
    pub g: &'a [f64],
    /// The same `G` as values at the model's pattern (for the Schur path).
    pub g_values: &'a [f64],
    /// Generalized applied force `f` (nq) \[N, N m\].
    pub f: &'a [f64],
    /// Convective term `gamma` (nc) \[m/s^2\].
    pub gamma: &'a [f64],
}

impl KktSystem<'_> {
    /// Number of coordinates nq.
    pub fn nq(&self) -> usize {
        self.mass.len()
    }
    /// Number of constraints nc.
    pub fn nc(&self) -> usize {
        self.gamma.len()
    }
}

/// A linear solver for the KKT system. Implementations own their workspace,
/// sized at construction, and do not allocate in [`KktSolver::solve`].
pub trait KktSolver {
    /// Solves for `qdd` (nq) \[m/s^2, rad/s^2\] and `lambda` (nc) \[N\].
    ///
    /// # Errors
    /// [`KktError`] when the system is singular for this path.
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError>;
    /// Short name of the path, for reports (`"schur-cholesky"`, `"dense-lu"`).
    fn name(&self) -> &'static str;
    /// A cheap estimate of the conditioning of the last solve, independent
    /// of units and diagonal scaling (`None` if the path has none).
    fn condition_estimate(&self) -> Option<f64> {
        None
    }
}

/// Which KKT path to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KktMethod {
    /// Schur complement when `M` is invertible, else dense LU.
    #[default]
    Auto,
    /// [`SchurCholesky`] (falls back to LU if `M` is singular).
    Schur,
    /// Always [`DenseLu`].
    Lu,
    /// [`SparseSchur`] (falls back to LU if `M` is singular).
    Sparse,
}

/// Number of constraint rows from which [`KktMethod::Auto`] takes the
/// sparse Schur path. Measured with `cargo bench --bench sparse` on chains
/// (2 cores): at nc = 10 the dense path takes 0.75 us against 0.91 us
/// sparse, at nc = 22 3.8 us against 2.1 us; dense grows like nc^3 (187 ms
/// at nc = 997), sparse linearly (108 us at nc = 997, 324 us at 2998).
pub const SPARSE_FROM_ROWS: usize = 16;

/// The largest KKT matrix (nq + nc rows) a run takes on the dense LU path
/// (a massless part): its factorization costs `O((nq + nc)^3)` per
/// right-hand side, 55 ms at 994 rows on one core (the massless 166-link
/// snake), so larger
/// models with a massless body are refused at setup.
pub const DENSE_LU_MAX_ROWS: usize = 1000;

/// The KKT solver chosen for a model, as an enum so the right-hand side
/// dispatches without a virtual call.
#[derive(Debug)]
pub enum AnyKktSolver<M: Model> {
    /// See [`SchurCholesky`].
    Schur(SchurCholesky<M>),
    /// See [`DenseLu`].
    Lu(DenseLu),
    /// See [`SparseSchur`].
    Sparse(Box<SparseSchur>),
}

impl<M: Model> AnyKktSolver<M> {
    /// Builds the solver for `method` and `model` (with its `info`);
    /// `Auto` inspects the mass diagonal (nq) and the number of rows.
    pub fn new(model: &M, info: &crate::ModelInfo, method: KktMethod, mass: &[f64]) -> Self {
        let (nq, nc) = (info.nq(), info.nc());
        let invertible = mass.iter().all(|&m| m > 0.0);
        match method {
            KktMethod::Schur => match SchurCholesky::new(model, info, mass) {
                Ok(s) => Self::Schur(s),
                // not invertible: the Schur path cannot serve; LU can
                Err(_) => Self::Lu(DenseLu::new(nq, nc)),
            },
            KktMethod::Lu => Self::Lu(DenseLu::new(nq, nc)),
            KktMethod::Sparse | KktMethod::Auto
                if invertible
                    && (method == KktMethod::Sparse || nc >= SPARSE_FROM_ROWS || !model.unrolled_kernels()) =>
            {
                Self::Sparse(Box::new(SparseSchur::new(&info.pattern, nc, mass).expect("positive masses")))
            }
            KktMethod::Sparse => Self::Lu(DenseLu::new(nq, nc)),
            KktMethod::Auto if invertible => {
                Self::Schur(SchurCholesky::new(model, info, mass).expect("positive masses give an invertible M"))
            }
            KktMethod::Auto => Self::Lu(DenseLu::new(nq, nc)),
        }
    }
}

impl<M: Model> AnyKktSolver<M> {
    /// Whether [`KktSystem::g`] (dense) is read; the Schur path reads only
    /// [`KktSystem::g_values`], so the caller can skip the scatter.
    #[inline]
    pub fn needs_dense_g(&self) -> bool {
        matches!(self, Self::Lu(_))
    }
}

impl<M: Model> KktSolver for AnyKktSolver<M> {
    #[inline]
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError> {
        match self {
            Self::Schur(s) => s.solve(sys, qdd, lambda),
            Self::Lu(s) => s.solve(sys, qdd, lambda),
            Self::Sparse(s) => s.solve(sys, qdd, lambda),
        }
    }
    fn name(&self) -> &'static str {
        match self {
            Self::Schur(s) => s.name(),
            Self::Lu(s) => s.name(),
            Self::Sparse(s) => s.name(),
        }
    }
    #[inline]
    fn condition_estimate(&self) -> Option<f64> {
        match self {
            Self::Schur(s) => s.condition_estimate(),
            Self::Lu(s) => s.condition_estimate(),
            Self::Sparse(s) => s.condition_estimate(),
        }
    }
}
