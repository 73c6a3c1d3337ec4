//! Coordinate projection after a step (docs/physics.md §6).
//!
//! - Positions: Gauss-Newton on the holonomic constraints only,
//!   `q <- q - W^-1 C_q^T (C_q W^-1 C_q^T)^-1 C(q)`, re-evaluating `C` and
//!   `C_q` each iteration, until `max|C| <= 1e-12` or 10 iterations.
//! - Velocities: one least-squares step on all velocity constraints,
//!   `qd <- qd - W^-1 G^T (G W^-1 G^T)^-1 G qd`.
//!
//! `W = I` is the Euclidean form; `W = M` the kinetic-energy
//! (mass-weighted) form. Mass-weighted is the default: it is the correction
//! of least kinetic energy (the metric of the equations of motion), it does
//! not depend on the units chosen for lengths vs angles (the Euclidean form
//! adds metres and radians), and it reuses the Schur complement's structure.

use crate::error::KktError;
use crate::error::SimError;
use crate::kkt::dense_lu::DenseLu;
use crate::kkt::spd::NormalSystem;
use crate::kkt::{KktSolver, KktSystem};
use crate::model::Model;
use crate::model::info::scatter_dense;
use crate::settings::ProjectionKind;

/// Tolerance on `max|C|` of the position iteration \[m\] (docs/physics.md §6).
pub const POSITION_TOL: f64 = 1e-12;
/// The refining position step ([`Projector::refine`]) is skipped when
/// `max|C|` is at most this many units of rounding of the positions,
/// `POSITION_ULPS eps max(1, |q|)` \[m\].
pub const POSITION_ULPS: f64 = 16.0;
/// Iteration limit of the position iteration (docs/physics.md §6).
pub const POSITION_MAX_ITER: usize = 10;
/// The velocity step is skipped when `max|G qd - b|` is at most this many
/// units of rounding of the velocities, `VELOCITY_ULPS eps max(1, |qd|)`
/// \[m/s\]: the correction would be rounding noise (docs/physics.md §6).
pub const VELOCITY_ULPS: f64 = 16.0;

/// What one projection found and did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ProjectionReport {
    /// `max|C(q)|` before projecting \[m\] (the drift of the step).
    pub drift_position: f64,
    /// `max|C(q)|` after projecting \[m\].
    pub residual_position: f64,
    /// Gauss-Newton iterations done.
    pub iterations: usize,
    /// Whether the velocity step was taken (`false`: `G qd` was already at
    /// rounding, [`VELOCITY_ULPS`]).
    pub velocity_step: bool,
}

/// Workspace of the projection, sized for one model.
#[derive(Debug)]
pub struct Projector<M: Model> {
    kind: ProjectionKind,
    winv: Vec<f64>,
    /// Unit weights (nq), for `G qd`.
    ones: Vec<f64>,
    g_values: Vec<f64>,
    r: Vec<f64>,
    x: Vec<f64>,
    normal: NormalSystem,
    /// The mass-weighted form for a singular `M` (massless parts).
    singular: Option<Box<SingularMass>>,
    /// Prescribed hinge angles: targets of their rows.
    drives: Vec<crate::drive::Drive>,
    /// For large models: `W`-weighted normal systems in sparse form (see
    /// [`SparseProjection`]).
    sparse: Option<Box<SparseProjection>>,
    /// The model's sizes, names and pattern of `G`.
    info: crate::model::info::ModelInfo,
    /// See [`Projector::refine`].
    refine: bool,
    /// Rows taken out of the velocity projection (sliding skates).
    released: crate::formulation::friction::Released,
    /// The multipliers `y` of the last [`Projector::project`]'s
    /// corrections, `W dq = -C_q^T y` (nh, summed over its Gauss-Newton
    /// steps) and `W dqd = -G^T y` (nc; 0 where no step was taken): what
    /// [`Projector::project_tangent`] needs of the projection's
    /// curvature.
    y_positions: Vec<f64>,
    y_velocities: Vec<f64>,
    /// What the last [`Projector::project`] changed: `q` and `qd` after
    /// it minus before (nq each).
    step_positions: Vec<f64>,
    step_velocities: Vec<f64>,
    /// `dG`'s values along a tangent vector, `dG^T y` (nq): scratch.
    dg_values: Vec<f64>,
    dgt_y: Vec<f64>,
    _model: std::marker::PhantomData<M>,
}

/// The normal systems of the projection, `C_q W^-1 C_q^T` (positions) and
/// `G W^-1 G^T` (velocities), factored by the sparse Schur-complement path
/// (ordering and symbolic factor once): for models from
/// [`crate::kkt::SPARSE_FROM_ROWS`] rows, where the dense `LDL^T` costs
/// `O(nc^3)`. The correction `W^-1 G^T x` is the sparse path's
/// `-qdd` with `f = 0` and `gamma = r`.
struct SparseProjection {
    positions: Option<crate::kkt::sparse::SparseSchur>,
    velocities: crate::kkt::sparse::SparseSchur,
    weights: Vec<f64>,
    zeros: Vec<f64>,
    dq: Vec<f64>,
    lambda: Vec<f64>,
}

impl std::fmt::Debug for SparseProjection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseProjection").field("velocities", &self.velocities).finish_non_exhaustive()
    }
}

impl SparseProjection {
    /// `v -= W^-1 G_m^T (G_m W^-1 G_m^T)^-1 r` for the leading `m` rows
    /// (`m = nh`: positions, with `values` the holonomic entries; `m = nc`:
    /// velocities).
    fn correct(
        &mut self,
        positions: bool,
        values: &[f64],
        r: &[f64],
        released: &[usize],
        v: &mut [f64],
    ) -> Result<(), KktError> {
        use crate::kkt::KktSolver;
        let solver =
            if positions { self.positions.as_mut().expect("holonomic rows exist") } else { &mut self.velocities };
        let m = r.len();
        let released = if positions { &[] } else { released };
        let sys = KktSystem { mass: &self.weights, g: &[], g_values: values, f: &self.zeros, gamma: r, released };
        solver.solve(&sys, &mut self.dq, &mut self.lambda[..m])?;
        // dq = -W^-1 G^T x with (G W^-1 G^T) x = r: the step that removes r
        for (vi, d) in v.iter_mut().zip(&self.dq) {
            *vi += d;
        }
        Ok(())
    }
}

/// Mass-weighted velocity projection when `M` is singular: the correction
/// of least kinetic energy `min dqd^T M dqd / 2` subject to `G dqd = -G qd`
/// is the solution of `[M G^T; G 0] [dqd; mu] = [0; -G qd]`, regular
/// whenever the equations of motion are, so no `M^-1` is needed (dense LU).
/// Positions are corrected in the Euclidean metric instead: with the
/// holonomic rows alone the KKT matrix is singular (a massless body can
/// turn about its hinge at no cost), and a correction of <= 1e-12 m does
/// not depend on the metric in any way that matters.
#[derive(Debug)]
struct SingularMass {
    mass: Vec<f64>,
    /// `G` dense row-major (nc x nq).
    g: Vec<f64>,
    /// The right-hand side's force (nq): 0 but in
    /// [`Projector::project_tangent`]'s curvature term.
    force: Vec<f64>,
    dq: Vec<f64>,
    mu: Vec<f64>,
    /// LU of the KKT matrix.
    lu: DenseLu,
}

impl SingularMass {
    /// `v += dv` with `G dv = -r` of least `dv^T M dv`.
    fn correct(
        &mut self,
        pattern: &[(usize, usize)],
        values: &[f64],
        r: &[f64],
        released: &[usize],
        v: &mut [f64],
    ) -> Result<(), KktError> {
        let nq = self.mass.len();
        scatter_dense(pattern, values, nq, &mut self.g);
        let sys = KktSystem { mass: &self.mass, g: &self.g, g_values: &[], f: &self.force, gamma: r, released };
        self.lu.solve(&sys, &mut self.dq, &mut self.mu)?;
        for (vi, d) in v.iter_mut().zip(&self.dq) {
            *vi += d;
        }
        Ok(())
    }
}

impl<M: Model> Projector<M> {
    /// A projector for model `M` with mass diagonal `mass` (nq). With a
    /// singular `M` (zero masses) the mass-weighted form solves the KKT
    /// system instead of inverting `M`.
    pub fn new(model: &M, kind: ProjectionKind, mass: &[f64]) -> Self {
        let info = model.info();
        let sparse = info.nc() >= crate::kkt::SPARSE_FROM_ROWS || !model.unrolled_kernels();
        Self::build(info, kind, mass, sparse)
    }

    /// As [`Projector::new`], with the dense normal systems whatever the
    /// model's size (for tests and benchmarks of the two paths).
    pub fn new_dense(model: &M, kind: ProjectionKind, mass: &[f64]) -> Self {
        Self::build(model.info(), kind, mass, false)
    }

    /// As [`Projector::new`], with the sparse normal systems whatever the
    /// model's size (for tests and benchmarks of the two paths).
    pub fn new_sparse(model: &M, kind: ProjectionKind, mass: &[f64]) -> Self {
        Self::build(model.info(), kind, mass, true)
    }

    fn build(info: crate::model::info::ModelInfo, kind: ProjectionKind, mass: &[f64], sparse: bool) -> Self {
        if kind == ProjectionKind::None {
            // nothing is projected: no workspace (a dense normal system of
            // a 30,000-link snake would take 64 GB)
            return Self {
                kind,
                winv: Vec::new(),
                sparse: None,
                ones: Vec::new(),
                g_values: Vec::new(),
                r: Vec::new(),
                x: Vec::new(),
                normal: NormalSystem::new(0),
                singular: None,
                drives: Vec::new(),
                info,
                refine: false,
                released: Default::default(),
                y_positions: Vec::new(),
                y_velocities: Vec::new(),
                step_positions: Vec::new(),
                step_velocities: Vec::new(),
                dg_values: Vec::new(),
                dgt_y: Vec::new(),
                _model: std::marker::PhantomData,
            };
        }
        let (nq, nc) = (info.nq(), info.nc());
        let invertible = mass.iter().all(|&m| m > 0.0);
        let winv = match kind {
            ProjectionKind::MassWeighted if invertible => mass.iter().map(|m| 1.0 / m).collect(),
            _ => vec![1.0; nq],
        };
        let singular = (kind == ProjectionKind::MassWeighted && !invertible).then(|| {
            Box::new(SingularMass {
                mass: mass.to_vec(),
                g: vec![0.0; nc * nq],
                force: vec![0.0; nq],
                dq: vec![0.0; nq],
                mu: vec![0.0; nc],
                lu: DenseLu::new(nq, nc),
            })
        });
        let nh = info.n_holonomic;
        let sparse = (sparse && singular.is_none()).then(|| {
            let weights: Vec<f64> = winv.iter().map(|w| 1.0 / w).collect();
            let nnz_h = info.n_holonomic_nonzeros();
            Box::new(SparseProjection {
                positions: (nh > 0).then(|| {
                    crate::kkt::sparse::SparseSchur::new(&info.pattern[..nnz_h], nh, &weights)
                        .expect("positive weights")
                }),
                velocities: crate::kkt::sparse::SparseSchur::new(&info.pattern, nc, &weights)
                    .expect("positive weights"),
                weights,
                zeros: vec![0.0; nq],
                dq: vec![0.0; nq],
                lambda: vec![0.0; nc],
            })
        });
        // the dense normal systems only where they serve: a small model,
        // or positions next to the singular mass' LU (which the run takes
        // up to `DENSE_LU_MAX_ROWS` rows only)
        let dense_rows = if sparse.is_some() { 0 } else { nc };
        Self {
            kind,
            winv,
            sparse,
            ones: vec![1.0; nq],
            g_values: vec![0.0; info.pattern.len()],
            r: vec![0.0; nc],
            x: vec![0.0; nc],
            normal: NormalSystem::new(dense_rows),
            singular,
            drives: Vec::new(),
            refine: false,
            released: Default::default(),
            y_positions: vec![0.0; info.n_holonomic],
            y_velocities: vec![0.0; nc],
            step_positions: vec![0.0; nq],
            step_velocities: vec![0.0; nq],
            dg_values: vec![0.0; info.pattern.len()],
            dgt_y: vec![0.0; nq],
            info,
            _model: std::marker::PhantomData,
        }
    }

    /// Projects onto `phi(q) = u(t)` and `G qd = u'(t)` on the drives' rows.
    pub fn with_drives(mut self, drives: &[crate::drive::Drive]) -> Self {
        self.drives = drives.to_vec();
        self
    }

    /// Which linear algebra the projection uses, for reports.
    pub fn path(&self) -> &'static str {
        match (self.kind, &self.singular, &self.sparse) {
            (ProjectionKind::None, _, _) => "none",
            (_, Some(_), _) => "kkt-lu velocities, euclidean positions (singular M)",
            (_, _, Some(_)) => "normal-sparse-cholesky",
            _ => "normal-ldl",
        }
    }

    /// The kind of projection.
    pub fn kind(&self) -> ProjectionKind {
        self.kind
    }

    /// Projects `q` (nq) onto `C(q) = 0`, then `qd` (nq) onto `G(q) qd = 0`
    /// (with the drives' targets `u(t)`, `u'(t)` on their rows).
    ///
    /// # Errors
    /// [`SimError::Kkt`] with [`KktError::DependentConstraints`] when
    /// `C_q W^-1 C_q^T` or `G W^-1 G^T` is singular.
    pub fn project(&mut self, model: &M, t: f64, q: &mut [f64], qd: &mut [f64]) -> Result<ProjectionReport, SimError> {
        if self.kind == ProjectionKind::None {
            return Ok(ProjectionReport::default());
        }
        let report = self.project_steps(model, t, q, qd)?;
        self.step_positions.iter_mut().zip(&*q).for_each(|(d, q)| *d += q);
        self.step_velocities.iter_mut().zip(&*qd).for_each(|(d, v)| *d += v);
        Ok(report)
    }

    /// [`Projector::project`]'s steps, recording their multipliers.
    fn project_steps(
        &mut self,
        model: &M,
        t: f64,
        q: &mut [f64],
        qd: &mut [f64],
    ) -> Result<ProjectionReport, SimError> {
        let mut report = ProjectionReport::default();
        let (nh, nc) = (self.info.n_holonomic, self.info.nc());
        self.y_positions.fill(0.0);
        self.y_velocities.fill(0.0);
        self.step_positions.iter_mut().zip(&*q).for_each(|(d, q)| *d = -q);
        self.step_velocities.iter_mut().zip(&*qd).for_each(|(d, v)| *d = -v);
        // positions: Gauss-Newton on the leading (holonomic) block; G is
        // evaluated with phi, so the last evaluation serves the velocities.
        model.phi_and_constraint_matrix(q, &mut self.r[..nh], &mut self.g_values);
        crate::drive::shift_positions(&self.drives, t, &mut self.r[..nh]);
        if nh > 0 {
            for it in 0..=POSITION_MAX_ITER {
                let res = max_abs(&self.r[..nh]);
                if it == 0 {
                    report.drift_position = res;
                }
                report.residual_position = res;
                // near a singular position one more step at rounding level
                // (see `Projector::refine`)
                let refine = self.refine && it == 0 && res > POSITION_ULPS * f64::EPSILON * max_abs(q).max(1.0);
                if (res <= POSITION_TOL && !refine) || it == POSITION_MAX_ITER {
                    break;
                }
                self.correct_positions(model, q).map_err(|e| SimError::from_kkt(&self.info, t, e))?;
                self.record_multipliers(true, nh);
                report.iterations = it + 1;
                model.phi_and_constraint_matrix(q, &mut self.r[..nh], &mut self.g_values);
                crate::drive::shift_positions(&self.drives, t, &mut self.r[..nh]);
            }
        }
        // velocities: one least-squares step on all rows
        if nc > 0 {
            self.released.zero(&mut self.g_values);
            model.g_winv_mul(&self.info.pattern, &self.g_values, &self.ones, qd, &mut self.r);
            crate::drive::shift_velocities(&self.drives, t, &mut self.r);
            if max_abs(&self.r) <= VELOCITY_ULPS * f64::EPSILON * max_abs(qd).max(1.0) {
                return Ok(report);
            }
            report.velocity_step = true;
            self.correct_velocities(model, qd).map_err(|e| SimError::from_kkt(&self.info, t, e))?;
            self.record_multipliers(false, nc);
        }
        Ok(report)
    }

    /// Adds the multipliers `y` (m) of the correction just made, `W dv =
    /// -G_m^T y` (`positions`: the holonomic rows, in the Euclidean metric
    /// where `M` is singular; else all rows), from whichever path solved
    /// it, to those of the projection (the velocities' start at 0).
    fn record_multipliers(&mut self, positions: bool, m: usize) {
        let y = match (&self.singular, &self.sparse) {
            (Some(s), _) if !positions => &s.mu[..m],
            (_, Some(sp)) => &sp.lambda[..m],
            _ => &self.x[..m],
        };
        let sum = if positions { &mut self.y_positions } else { &mut self.y_velocities };
        sum.iter_mut().zip(y).for_each(|(s, y)| *s += y);
    }

    /// `dgt_y = dG_m^T y + dW step` (nq) for the leading `m` rows and
    /// the position or velocity step, `dG` in `dg_values` (pattern order)
    /// plus the direct `dG/dp` of `direct.0`, `dW = direct.1` where the
    /// metric is the mass-weighted one (the singular `M`'s positions are
    /// Euclidean).
    fn curvature(&mut self, m: usize, positions: bool, (dg_p, dw): (&[f64], &[f64])) {
        self.dgt_y.fill(0.0);
        let y = if positions { &self.y_positions } else { &self.y_velocities };
        let direct = dg_p.iter().chain(std::iter::repeat(&0.0));
        for ((&(r, c), &v), &d) in self.info.pattern.iter().zip(&self.dg_values).zip(direct) {
            if r < m {
                self.dgt_y[c] += (v + d) * y[r];
            }
        }
        let weighted = self.kind == ProjectionKind::MassWeighted && !(positions && self.singular.is_some());
        if weighted && !dw.is_empty() {
            let step = if positions { &self.step_positions } else { &self.step_velocities };
            self.dgt_y.iter_mut().zip(dw).zip(step).for_each(|((o, w), s)| *o += w * s);
        }
    }

    /// `q -= W^-1 C_q^T (C_q W^-1 C_q^T)^-1 r` with `r` the first `nh`
    /// entries of the residual buffer and `C_q` the holonomic rows of the
    /// `G` last evaluated: one Gauss-Newton step on the positions.
    fn correct_positions(&mut self, model: &M, q: &mut [f64]) -> Result<(), KktError> {
        let (info, nh) = (&self.info, self.info.n_holonomic);
        if let Some(sp) = &mut self.sparse {
            let nnz_h = info.n_holonomic_nonzeros();
            sp.correct(true, &self.g_values[..nnz_h], &self.r[..nh], &[], q)
        } else {
            self.normal.solve(
                model,
                &info.pattern,
                &self.g_values,
                &self.winv,
                (nh, &[]),
                &self.r[..nh],
                &mut self.x[..nh],
            )?;
            self.x[nh..].fill(0.0);
            model.sub_winv_gt_mul(&info.pattern, &self.g_values, &self.winv, &self.x, q);
            Ok(())
        }
    }

    /// `qd += dqd`, the correction of least `dqd^T W dqd` with
    /// `G dqd = -r` (`r` the residual buffer, `G` the last evaluated).
    fn correct_velocities(&mut self, model: &M, qd: &mut [f64]) -> Result<(), KktError> {
        let (info, nc) = (&self.info, self.info.nc());
        let released = self.released.rows();
        if let Some(s) = &mut self.singular {
            s.correct(&info.pattern, &self.g_values, &self.r, released, qd)
        } else if let Some(sp) = &mut self.sparse {
            sp.correct(false, &self.g_values, &self.r, released, qd)
        } else {
            let released = (nc, released);
            self.normal.solve(model, &info.pattern, &self.g_values, &self.winv, released, &self.r, &mut self.x)?;
            model.sub_winv_gt_mul(&info.pattern, &self.g_values, &self.winv, &self.x, qd);
            Ok(())
        }
    }

    /// Removes from an error estimate `(eq, eqd)` (nq each: positions
    /// \[m, rad\], velocities \[m/s, rad/s\]) its components normal to the
    /// constraint manifold at `q`, in the projection's metric: what the
    /// projection after the step removes anyway, to first order, so that
    /// only the tangential error is left (Hairer & Wanner, *Solving ODE
    /// II*, §VII.2, on the local error of projected methods). `eq` loses its
    /// part in the range of `W^-1 C_q^T` (holonomic rows), `eqd` its part in
    /// the range of `W^-1 G^T` (all rows). Used near singular positions,
    /// where the estimate is dominated by a mode the projection removes
    /// (see `simulate`). Does nothing for [`ProjectionKind::None`].
    ///
    /// # Errors
    /// [`SimError::Kkt`] when a normal system cannot be solved.
    pub fn remove_normal(
        &mut self,
        model: &M,
        t: f64,
        q: &[f64],
        eq: &mut [f64],
        eqd: &mut [f64],
    ) -> Result<(), SimError> {
        if self.kind == ProjectionKind::None {
            return Ok(());
        }
        let (nh, nc) = (self.info.n_holonomic, self.info.nc());
        model.constraint_matrix(q, &mut self.g_values);
        if nh > 0 {
            model.g_winv_mul(&self.info.pattern, &self.g_values, &self.ones, eq, &mut self.r);
            self.correct_positions(model, eq).map_err(|e| SimError::from_kkt(&self.info, t, e))?;
        }
        if nc > 0 {
            self.released.zero(&mut self.g_values);
            model.g_winv_mul(&self.info.pattern, &self.g_values, &self.ones, eqd, &mut self.r);
            self.correct_velocities(model, eqd).map_err(|e| SimError::from_kkt(&self.info, t, e))?;
        }
        Ok(())
    }

    /// Projects a tangent vector `(sq, sqd)` (nq each) at the state `(q,
    /// qd)` the last [`Projector::project`] left: the derivative of that
    /// projection, applied to a sensitivity `dx/dp` of a manifold that
    /// moves with `p` (Hairer, Lubich & Wanner, *Geometric Numerical
    /// Integration*, §IV.4). The projection `v' = v - W^-1 G^T y` with
    /// `G v' = b` has the derivative `dv' = P (dv - W^-1 dG^T y)` with `P`
    /// the tangent projection onto `G dv' + dG v' = db`: `sq` loses
    /// `W^-1 dC_q^T y` (the constraints' curvature times the position
    /// step's multipliers, summed over its Gauss-Newton steps: exact to
    /// first order in the step's drift, the further steps' multipliers
    /// being of its square) and is corrected so that `C_q sq + dr[..nh] =
    /// 0`; then `sqd` loses `W^-1 dG^T y` of the velocity step (exact: the
    /// step is linear) and is corrected so that `G sqd + dG qd + dr[nh..]
    /// = 0`. `dg(sq, out)` writes the derivative of `G(q)`'s values
    /// (pattern order) along `sq`; `dr` (nh + nc) the residuals' direct
    /// derivative `dC/dp`; `direct` the direct derivatives `dG/dp` (at the
    /// pattern) and `dW/dp` (nq, the mass diagonal's, for the
    /// mass-weighted metric), empty where `p` moves neither: with a
    /// metric that moves, `W^-1 dW` times the step the projection made
    /// joins `W^-1 dG^T y` (from `W (v' - v) + G^T y = 0`). At a point the
    /// step left on the manifold (`y = 0`) this is the tangent projection
    /// alone. Does nothing for [`ProjectionKind::None`].
    ///
    /// # Errors
    /// [`SimError::Kkt`] when a normal system cannot be solved.
    #[expect(
        clippy::too_many_arguments,
        reason = "a state and a tangent vector as flat borrowed slices, as `project` takes them"
    )]
    pub fn project_tangent(
        &mut self,
        model: &M,
        t: f64,
        (q, qd): (&[f64], &[f64]),
        sq: &mut [f64],
        sqd: &mut [f64],
        (dr, direct): (&[f64], (&[f64], &[f64])),
        mut dg: impl FnMut(&[f64], &mut [f64]),
    ) -> Result<(), SimError> {
        if self.kind == ProjectionKind::None {
            return Ok(());
        }
        let (nh, nc) = (self.info.n_holonomic, self.info.nc());
        model.constraint_matrix(q, &mut self.g_values);
        if nh > 0 {
            if self.y_positions.iter().any(|&y| y != 0.0) {
                dg(sq, &mut self.dg_values);
                self.curvature(nh, true, direct);
                sq.iter_mut().zip(&self.winv).zip(&self.dgt_y).for_each(|((s, w), d)| *s -= w * d);
            }
            model.g_winv_mul(&self.info.pattern, &self.g_values, &self.ones, sq, &mut self.r);
            self.r[..nh].iter_mut().zip(dr).for_each(|(r, d)| *r += d);
            self.correct_positions(model, sq).map_err(|e| SimError::from_kkt(&self.info, t, e))?;
        }
        if nc > 0 {
            self.released.zero(&mut self.g_values);
            dg(sq, &mut self.dg_values);
            self.released.zero(&mut self.dg_values);
            let curved = self.y_velocities.iter().any(|&y| y != 0.0);
            if curved {
                self.curvature(nc, false, direct);
                if self.singular.is_none() {
                    sqd.iter_mut().zip(&self.winv).zip(&self.dgt_y).for_each(|((s, w), d)| *s -= w * d);
                }
            }
            model.g_winv_mul(&self.info.pattern, &self.g_values, &self.ones, sqd, &mut self.r);
            for (&(r, c), v) in self.info.pattern.iter().zip(&self.dg_values) {
                self.r[r] += v * qd[c];
            }
            self.r.iter_mut().zip(&dr[nh..]).for_each(|(r, d)| *r += d);
            if let (Some(s), true) = (&mut self.singular, curved) {
                // `M` singular: `-dG^T y` enters the KKT system as a force
                s.force.iter_mut().zip(&self.dgt_y).for_each(|(f, d)| *f = -d);
            }
            let result = self.correct_velocities(model, sqd);
            if let Some(s) = &mut self.singular {
                s.force.fill(0.0);
            }
            result.map_err(|e| SimError::from_kkt(&self.info, t, e))?;
        }
        Ok(())
    }

    /// Whether the last [`Projector::project`] moved the state (a
    /// multiplier of its position or velocity steps is not 0): where it
    /// did not, [`Projector::project_tangent`] has no curvature term and
    /// ignores its `direct` derivatives, which need not be computed.
    pub fn corrected(&self) -> bool {
        self.y_positions.iter().chain(&self.y_velocities).any(|&y| y != 0.0)
    }

    /// Takes the constraint rows `rows` out of the velocity projection
    /// (skates that slide, [`crate::formulation::friction`]): `qd` is projected onto
    /// the other rows' `G qd = 0` only, and
    /// [`Projector::velocity_residual`] leaves them out. Empty: every row.
    pub fn release(&mut self, rows: &[usize]) {
        self.released.set(&self.info.pattern, rows);
    }

    /// Sets whether [`Projector::project`] takes one more Gauss-Newton step
    /// when the position residual is below [`POSITION_TOL`] but above
    /// rounding ([`POSITION_ULPS`]). Near a singular position a
    /// constraint's sensitivity to some direction `d` vanishes like the
    /// distance `s` to it, so a residual of `POSITION_TOL` hides an error of
    /// `POSITION_TOL / s` along `d`, which the equations of motion then
    /// amplify like `1 / s` (the branch of a bifurcation is unstable);
    /// one step at rounding level removes it. The run sets it from the
    /// KKT conditioning ([`crate::formulation::dae::NEAR_SINGULAR`]).
    pub fn refine(&mut self, on: bool) {
        self.refine = on;
    }

    /// `max|G(q) qd - u'(t)|` \[m/s\] for the `q` the last
    /// [`Projector::project`] left and any `qd` (the one it left: the
    /// projected state's velocity residual), from the `G` that projection
    /// evaluated at that `q`: no evaluation of the model. With
    /// [`ProjectionReport::residual_position`], the residuals of a projected
    /// state for the price of one product with `G`. Meaningless (0) for
    /// [`ProjectionKind::None`], which evaluates nothing.
    pub fn velocity_residual(&mut self, model: &M, t: f64, qd: &[f64]) -> f64 {
        if self.kind == ProjectionKind::None {
            return 0.0;
        }
        model.g_winv_mul(&self.info.pattern, &self.g_values, &self.ones, qd, &mut self.r);
        crate::drive::shift_velocities(&self.drives, t, &mut self.r);
        max_abs(&self.r)
    }
}

/// `out = A v` for `A` dense row-major (out.len() x v.len()).
pub fn mat_vec(a: &[f64], v: &[f64], out: &mut [f64]) {
    let n = v.len();
    for (i, o) in out.iter_mut().enumerate() {
        *o = a[i * n..(i + 1) * n].iter().zip(v).map(|(x, y)| x * y).sum();
    }
}

/// `max_i |v_i|` (0 for an empty slice; NaN entries are passed over, as
/// by `f64::max`). A plain comparison: `f64::max`'s NaN handling costs
/// twice the instructions on the projection's short vectors.
pub fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| if x.abs() > m { x.abs() } else { m })
}
