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
//! (measured faster: see `benches/` and the guide's "Numerics" chapter), the sparse one from
//! [`SPARSE_FROM_ROWS`] constraint rows, else LU.

pub(crate) mod dense_lu;
pub(crate) mod sparse;
pub(crate) mod spd;

pub use dense_lu::DenseLu;
pub use sparse::{SparseSchur, synthetic_chain};
pub use spd::{NormalSystem, PIVOT_RTOL, SINGULAR_MU, SchurCholesky, ldl_solve, regularized_solve};

use crate::error::{KktError, SimError};
use crate::model::Model;
use crate::model::info::ModelInfo;
use crate::names::name_list;

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
    /// Released rows: constraint rows taken out of the system (a skate
    /// that slides, [`crate::formulation::friction`]). The caller has zeroed their
    /// entries of `G` and `gamma`; each solver puts a unit diagonal in
    /// their place, so that the rest is solved as if the rows were absent
    /// and their multipliers come out 0. Usually empty.
    pub released: &'a [usize],
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
    /// Whether the last solve found `G` rank-deficient (dependent rows at
    /// this state: a singular position) and solved a regularized system
    /// instead ([`spd::regularized_solve`]): the accelerations are exact to
    /// the regularization's level, the multipliers are the least ones.
    fn was_singular(&self) -> bool {
        false
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
    pub fn new(model: &M, info: &crate::model::info::ModelInfo, method: KktMethod, mass: &[f64]) -> Self {
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
    #[inline]
    fn was_singular(&self) -> bool {
        match self {
            Self::Schur(s) => s.was_singular(),
            Self::Lu(s) => s.was_singular(),
            Self::Sparse(s) => s.was_singular(),
        }
    }
}

/// The first row of `G(q)` (nc x nq) that depends on the rows before it in
/// the Euclidean metric (`G G^T`, so masses play no part; with `mass`
/// (nq), the mass-weighted `G M^-1 G^T`), by the strict
/// pivot test ([`PIVOT_RTOL`]) without regularization; `None` when `G(q)`
/// has full row rank. Dense `L D L^T` below [`SPARSE_FROM_ROWS`] rows, the
/// sparse Cholesky from there (linear in a chain's length).
///
/// # Errors
/// [`KktError::NonFinite`] if `G(q)` has a non-finite entry.
pub fn dependent_row<M: Model>(
    model: &M,
    info: &crate::model::info::ModelInfo,
    q: &[f64],
    mass: Option<&[f64]>,
) -> Result<Option<usize>, KktError> {
    let (nq, nc) = (info.nq(), info.nc());
    if nc == 0 {
        return Ok(None);
    }
    let mut g = vec![0.0; info.pattern.len()];
    model.constraint_matrix(q, &mut g);
    let weights = match mass {
        Some(m) if m.iter().all(|&v| v > 0.0 && v.is_finite()) => m.to_vec(),
        _ => vec![1.0; nq],
    };
    if nc < SPARSE_FROM_ROWS && model.unrolled_kernels() {
        let winv: Vec<f64> = weights.iter().map(|w| 1.0 / w).collect();
        let mut normal = NormalSystem::new(nc);
        normal.assemble(model, &info.pattern, &g, &winv);
        match normal.strict_rank_check(nc) {
            Ok(()) => Ok(None),
            Err(KktError::DependentConstraints { row, .. }) => Ok(Some(row)),
            Err(e) => Err(e),
        }
    } else {
        SparseSchur::new(&info.pattern, nc, &weights).expect("positive weights").dependent_row(&g)
    }
}

impl SimError {
    /// A KKT failure at time `t`, with dependent rows named from the model's `info`.
    pub fn from_kkt(info: &ModelInfo, t: f64, source: KktError) -> Self {
        match source {
            KktError::DependentConstraints { row, .. } if row < info.nc() => {
                let names = &info.constraints;
                SimError::DependentConstraints {
                    t,
                    constraint: names[row].clone(),
                    row,
                    before: name_list(&names[..row]),
                }
            }
            source => SimError::Kkt { t, source },
        }
    }
}
