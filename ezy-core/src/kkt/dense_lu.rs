//! Dense LU with partial pivoting of the whole (nq + nc) KKT matrix
//!
//! ```text
//! K = [ M  G^T ]
//!     [ G  0   ]
//! ```
//!
//! with faer (`lu_in_place` + `solve_in_place`, sequential, on a workspace
//! sized at construction). It needs no `M^-1`, so unlike [`SchurCholesky`]
//! it serves a mass diagonal with zero entries (massless coordinates), as
//! long as `K` itself is regular.
//!
//! Singularity test: `P K = L U`; row `k` of `U` is row `perm[k]` of `K`
//! reduced by elimination, so a pivot `U[k, k]` that is zero, non-finite or
//! below `n * eps * max_j |K[perm[k], j]|` (the rounding left after
//! cancelling a dependent row, relative to that row's own scale, so the test
//! does not depend on the units of a row) is reported as
//! [`KktError::SingularKkt`], as is a non-finite solution.
//!
//! The factorization is always faer's unblocked (right-looking, rank-1
//! update) variant: the blocked variant, used by default above 16 x 16,
//! sends its large updates through gemm, which allocates an L3-sized
//! thread-local packing buffer on the first such product in each thread
//! (measured from n = 50), and `solve` must not allocate. For the sizes of
//! planar models the two cost the same up to n ~ 50; at n = 160 unblocked
//! is about 2.4x slower.
//!
//! [`SchurCholesky`]: super::SchurCholesky

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::factor::{self, PartialPivLuParams};
use faer::linalg::lu::partial_pivoting::solve;
use faer::{Mat, Par, Spec};

use super::{KktSolver, KktSystem};
use crate::error::KktError;

/// LU with partial pivoting of the (nq + nc) KKT matrix; works for a mass
/// diagonal with zero entries, as long as the whole KKT matrix is regular.
///
/// Owns the matrix, right-hand side, permutation and faer scratch buffers,
/// all sized in [`DenseLu::new`]; [`KktSolver::solve`] does not allocate.
pub struct DenseLu {
    /// Number of coordinates nq.
    nq: usize,
    /// Number of constraints nc.
    nc: usize,
    /// The KKT matrix (n x n, n = nq + nc), overwritten by its LU factors.
    lu: Mat<f64>,
    /// Right-hand side `[f; -gamma]` (n x 1), overwritten by `[qdd; lambda]`.
    rhs: Mat<f64>,
    /// Row permutation of the factorization (n) and its inverse (n).
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    /// `max_j |K[i, j]|` of each row of the assembled KKT matrix (n).
    row_scale: Vec<f64>,
    /// Pivot growth of the last solve (see `condition_estimate`).
    growth: f64,
    /// faer scratch for the factorization and the solve.
    mem: MemBuffer,
}

impl std::fmt::Debug for DenseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseLu")
            .field("nq", &self.nq)
            .field("nc", &self.nc)
            .field("lu", &self.lu)
            .field("rhs", &self.rhs)
            .field("perm", &self.perm)
            .field("row_scale", &self.row_scale)
            .finish_non_exhaustive()
    }
}

impl DenseLu {
    /// Workspace for `nq` coordinates and `nc` constraints: the
    /// (nq + nc) x (nq + nc) KKT matrix and faer's scratch.
    pub fn new(nq: usize, nc: usize) -> Self {
        let n = nq + nc;
        let req = StackReq::any_of(&[
            factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, lu_params()),
            solve::solve_in_place_scratch::<usize, f64>(n, 1, Par::Seq),
        ]);
        Self {
            nq,
            nc,
            lu: Mat::zeros(n, n),
            rhs: Mat::zeros(n, 1),
            perm: vec![0; n],
            perm_inv: vec![0; n],
            row_scale: vec![0.0; n],
            growth: 1.0,
            mem: MemBuffer::new(req),
        }
    }

    /// Writes `K` into `self.lu`, `[f; -gamma]` into `self.rhs` and the row
    /// maxima of `|K|` into `self.row_scale`.
    fn assemble(&mut self, sys: &KktSystem<'_>) {
        let (nq, nc) = (self.nq, self.nc);
        self.row_scale[..nq].iter_mut().zip(sys.mass).for_each(|(s, m)| *s = m.abs());
        self.row_scale[nq..].fill(0.0);
        // Columns 0..nq: [M; G] (column k of M is mass[k] e_k).
        for k in 0..nq {
            let col = self.lu.col_as_slice_mut(k);
            col[..nq].fill(0.0);
            col[k] = sys.mass[k];
            for i in 0..nc {
                let v = sys.g[i * nq + k];
                col[nq + i] = v;
                let s = &mut self.row_scale[nq + i];
                *s = s.max(v.abs());
            }
        }
        // Columns nq..n: [G^T; 0].
        for i in 0..nc {
            let row = &sys.g[i * nq..(i + 1) * nq];
            let col = self.lu.col_as_slice_mut(nq + i);
            col[..nq].copy_from_slice(row);
            col[nq..].fill(0.0);
            for (s, v) in self.row_scale[..nq].iter_mut().zip(row) {
                *s = s.max(v.abs());
            }
        }
        for &row in sys.released {
            self.lu.col_as_slice_mut(nq + row)[nq + row] = 1.0;
            self.row_scale[nq + row] = 1.0;
        }
        let rhs = self.rhs.col_as_slice_mut(0);
        rhs[..nq].copy_from_slice(sys.f);
        for (r, g) in rhs[nq..].iter_mut().zip(sys.gamma) {
            *r = -g;
        }
    }
}

/// faer's LU parameters: never recurse into the blocked variant (see the
/// module docs: it would allocate on first use in a thread).
fn lu_params() -> Spec<PartialPivLuParams, f64> {
    let mut params = Spec::<PartialPivLuParams, f64>::default();
    params.config.recursion_threshold = usize::MAX;
    params
}

impl KktSolver for DenseLu {
    /// Solves the KKT system by LU; `M` may have zero entries.
    ///
    /// # Errors
    /// [`KktError::SingularKkt`] (n = nq + nc) when the KKT matrix is
    /// (numerically) singular or the solution is not finite.
    ///
    /// # Panics
    /// If the shapes of `sys`, `qdd` or `lambda` differ from `(nq, nc)` of
    /// [`DenseLu::new`].
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError> {
        let (nq, nc) = (self.nq, self.nc);
        let n = nq + nc;
        assert!(
            sys.nq() == nq
                && sys.nc() == nc
                && sys.g.len() == nc * nq
                && sys.f.len() == nq
                && qdd.len() == nq
                && lambda.len() == nc,
            "DenseLu sized for (nq, nc) = ({nq}, {nc})"
        );
        if n == 0 {
            return Ok(());
        }
        self.assemble(sys);

        let stack = MemStack::new(&mut self.mem);
        let (_, perm) =
            factor::lu_in_place(self.lu.as_mut(), &mut self.perm, &mut self.perm_inv, Par::Seq, stack, lu_params());

        // U[k, k] against the scale of the original row it came from.
        let tol = n as f64 * f64::EPSILON;
        let (fwd, _) = perm.arrays();
        let mut growth = 1.0f64;
        for (k, &row) in fwd.iter().enumerate() {
            let pivot = self.lu[(k, k)];
            if !pivot.is_finite() || pivot.abs() <= tol * self.row_scale[row] {
                return Err(KktError::SingularKkt { n });
            }
            growth = growth.max(self.row_scale[row] / pivot.abs());
        }
        self.growth = growth;

        let lu = self.lu.as_ref();
        solve::solve_in_place(lu, lu, perm, self.rhs.as_mut(), Par::Seq, stack);

        let x = self.rhs.col_as_slice(0);
        if !x.iter().all(|v| v.is_finite()) {
            return Err(KktError::SingularKkt { n });
        }
        qdd.copy_from_slice(&x[..nq]);
        lambda.copy_from_slice(&x[nq..]);
        Ok(())
    }

    fn name(&self) -> &'static str {
        "dense-lu"
    }

    /// `max_k s_k / |U_kk|` with `s_k` the largest entry of the pivot's
    /// original row: how much of its scale the worst pivot lost, a
    /// row-scaling-independent lower bound of the condition number.
    fn condition_estimate(&self) -> Option<f64> {
        Some(self.growth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tiny deterministic LCG (Knuth MMIX constants), uniform in [lo, hi).
    struct Lcg(u64);

    impl Lcg {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let u = (self.0 >> 11) as f64 / (1u64 << 53) as f64;
            lo + (hi - lo) * u
        }
        fn vec(&mut self, n: usize, lo: f64, hi: f64) -> Vec<f64> {
            (0..n).map(|_| self.uniform(lo, hi)).collect()
        }
    }

    fn max_abs(v: &[f64]) -> f64 {
        v.iter().fold(0.0, |a, x| a.max(x.abs()))
    }

    /// Relative infinity-norm distance `|a - b| / |b|`.
    fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
        max_abs(&d) / max_abs(b).max(f64::MIN_POSITIVE)
    }

    /// Relative residual of the KKT equations `M qdd + G^T lambda = f`,
    /// `G qdd = -gamma`, scaled by the sizes of the terms.
    fn kkt_residual(sys: &KktSystem<'_>, qdd: &[f64], lambda: &[f64]) -> f64 {
        let nq = sys.nq();
        let mut worst: f64 = 0.0;
        for (k, ((&m, &f), &a)) in sys.mass.iter().zip(sys.f).zip(qdd).enumerate() {
            let (mut r, mut scale) = (m * a - f, (m * a).abs() + f.abs());
            for (row, &l) in sys.g.chunks_exact(nq).zip(lambda) {
                r += row[k] * l;
                scale += (row[k] * l).abs();
            }
            worst = worst.max(r.abs() / scale.max(1.0));
        }
        for (row, &gam) in sys.g.chunks_exact(nq).zip(sys.gamma) {
            let (mut r, mut scale) = (gam, gam.abs());
            for (&gk, &a) in row.iter().zip(qdd) {
                r += gk * a;
                scale += (gk * a).abs();
            }
            worst = worst.max(r.abs() / scale.max(1.0));
        }
        worst
    }

    /// Reference: nalgebra's LU of the same KKT matrix (an independent code path).
    fn reference(sys: &KktSystem<'_>) -> (Vec<f64>, Vec<f64>) {
        let (nq, nc) = (sys.nq(), sys.nc());
        let n = nq + nc;
        let k = nalgebra::DMatrix::from_fn(n, n, |i, j| match (i < nq, j < nq) {
            (true, true) => {
                if i == j {
                    sys.mass[i]
                } else {
                    0.0
                }
            }
            (true, false) => sys.g[(j - nq) * nq + i],
            (false, true) => sys.g[(i - nq) * nq + j],
            (false, false) => 0.0,
        });
        let rhs = nalgebra::DVector::from_fn(n, |i, _| if i < nq { sys.f[i] } else { -sys.gamma[i - nq] });
        let x = k.lu().solve(&rhs).expect("regular reference system");
        (x.as_slice()[..nq].to_vec(), x.as_slice()[nq..].to_vec())
    }

    #[test]
    fn agrees_with_reference_lu() {
        let (nq, nc) = (6, 4);
        let mut rng = Lcg(0x5eed_1234);
        let mut lu = DenseLu::new(nq, nc);
        for _ in 0..20 {
            let mass = rng.vec(nq, 0.5, 50.0);
            let g = rng.vec(nc * nq, -1.0, 1.0);
            let f = rng.vec(nq, -100.0, 100.0);
            let gamma = rng.vec(nc, -10.0, 10.0);
            let sys = KktSystem { mass: &mass, g: &g, g_values: &[], f: &f, gamma: &gamma, released: &[] };
            let (mut qdd_lu, mut lam_lu) = (vec![0.0; nq], vec![0.0; nc]);
            lu.solve(&sys, &mut qdd_lu, &mut lam_lu).unwrap();
            let (qdd_s, lam_s) = reference(&sys);
            let (dq, dl) = (rel_diff(&qdd_lu, &qdd_s), rel_diff(&lam_lu, &lam_s));
            assert!(dq < 1e-12 && dl < 1e-12, "qdd rel diff {dq:e}, lambda rel diff {dl:e}");
            assert!(kkt_residual(&sys, &qdd_lu, &lam_lu) < 1e-12);
        }
        assert_eq!(lu.name(), "dense-lu");
    }

    #[test]
    fn singular_mass_regular_kkt() {
        let (nq, nc) = (6, 4);
        let mass = [46.0, 46.0, 10.0, 0.0, 0.0, 0.0];
        // Ties the massless q3, q4 to q0, q1, pins q5 and couples q2: the KKT
        // matrix is regular because no q != 0 with G q = 0 has M q = 0.
        #[rustfmt::skip]
        let g = [
            1.0,  0.0, 0.0, -1.0,  0.0, 0.0,
            0.0,  1.0, 0.0,  0.0, -1.0, 0.0,
            0.0,  0.0, 0.0,  0.0,  0.0, 1.0,
            0.3, -0.2, 1.0,  0.0,  0.4, 0.5,
        ];
        let f = [12.0, -451.26, 3.5, 7.0, -2.0, 1.5];
        let gamma = [0.25, -1.0, 0.5, 2.0];
        let sys = KktSystem { mass: &mass, g: &g, g_values: &[], f: &f, gamma: &gamma, released: &[] };

        let (mut qdd, mut lambda) = (vec![0.0; nq], vec![0.0; nc]);

        let mut lu = DenseLu::new(nq, nc);
        lu.solve(&sys, &mut qdd, &mut lambda).unwrap();
        let res = kkt_residual(&sys, &qdd, &lambda);
        assert!(res < 1e-12, "residual {res:e}");
        // The constraints alone fix these: q5 pinned, q3/q4 follow q0/q1.
        assert!((qdd[5] + gamma[2]).abs() < 1e-12);
        assert!((qdd[0] - qdd[3] + gamma[0]).abs() < 1e-12);
        // The massless coordinates carry no inertia: rows 3..6 of
        // M qdd + G^T lambda = f reduce to G^T lambda = f.
        assert!((-lambda[0] - f[3]).abs() < 1e-12 * f[3].abs().max(1.0));
        assert!((-lambda[1] + 0.4 * lambda[3] - f[4]).abs() < 1e-12 * 10.0);
    }

    #[test]
    fn dependent_constraints_are_singular() {
        let (nq, nc) = (6, 4);
        let mut rng = Lcg(42);
        let mut lu = DenseLu::new(nq, nc);
        let (mut qdd, mut lambda) = (vec![0.0; nq], vec![0.0; nc]);
        for case in 0..10 {
            let mass = rng.vec(nq, 0.5, 50.0);
            let mut g = rng.vec(nc * nq, -1.0, 1.0);
            let f = rng.vec(nq, -100.0, 100.0);
            let gamma = rng.vec(nc, -10.0, 10.0);
            // Row 3 := row 1 (two identical constraint rows).
            let (head, tail) = g.split_at_mut(3 * nq);
            tail.copy_from_slice(&head[nq..2 * nq]);
            let sys = KktSystem { mass: &mass, g: &g, g_values: &[], f: &f, gamma: &gamma, released: &[] };
            let r = lu.solve(&sys, &mut qdd, &mut lambda);
            assert_eq!(r, Err(KktError::SingularKkt { n: nq + nc }), "case {case}: qdd {qdd:?} lambda {lambda:?}");
        }
    }

    #[test]
    fn zero_row_nan_input_and_recovery() {
        let (nq, nc) = (6, 4);
        let mut rng = Lcg(7);
        let mass = rng.vec(nq, 0.5, 50.0);
        let g = rng.vec(nc * nq, -1.0, 1.0);
        let f = rng.vec(nq, -100.0, 100.0);
        let gamma = rng.vec(nc, -10.0, 10.0);
        let mut lu = DenseLu::new(nq, nc);
        let (mut qdd, mut lambda) = (vec![0.0; nq], vec![0.0; nc]);
        let singular = Err(KktError::SingularKkt { n: nq + nc });

        // An all-zero constraint row: an exactly zero pivot.
        let mut g0 = g.clone();
        g0[2 * nq..3 * nq].fill(0.0);
        assert_eq!(
            lu.solve(
                &KktSystem { mass: &mass, g: &g0, g_values: &[], f: &f, gamma: &gamma, released: &[] },
                &mut qdd,
                &mut lambda
            ),
            singular
        );

        // A massless coordinate no constraint touches: an all-zero row and column.
        let mut m0 = mass.clone();
        m0[4] = 0.0;
        let mut g1 = g.clone();
        (0..nc).for_each(|i| g1[i * nq + 4] = 0.0);
        assert_eq!(
            lu.solve(
                &KktSystem { mass: &m0, g: &g1, g_values: &[], f: &f, gamma: &gamma, released: &[] },
                &mut qdd,
                &mut lambda
            ),
            singular
        );

        // Non-finite data.
        let mut f_nan = f.clone();
        f_nan[1] = f64::NAN;
        assert_eq!(
            lu.solve(
                &KktSystem { mass: &mass, g: &g, g_values: &[], f: &f_nan, gamma: &gamma, released: &[] },
                &mut qdd,
                &mut lambda
            ),
            singular
        );
        let mut g_inf = g.clone();
        g_inf[5] = f64::INFINITY;
        assert_eq!(
            lu.solve(
                &KktSystem { mass: &mass, g: &g_inf, g_values: &[], f: &f, gamma: &gamma, released: &[] },
                &mut qdd,
                &mut lambda
            ),
            singular
        );

        // The same solver still solves a regular system afterwards.
        let sys = KktSystem { mass: &mass, g: &g, g_values: &[], f: &f, gamma: &gamma, released: &[] };
        lu.solve(&sys, &mut qdd, &mut lambda).unwrap();
        assert!(kkt_residual(&sys, &qdd, &lambda) < 1e-12);
        assert!(format!("{lu:?}").starts_with("DenseLu"));
    }

    #[test]
    fn no_constraints_and_empty() {
        let mass = [2.0, 0.5];
        let f = [4.0, -1.0];
        let mut lu = DenseLu::new(2, 0);
        let mut qdd = [0.0; 2];
        lu.solve(
            &KktSystem { mass: &mass, g: &[], g_values: &[], f: &f, gamma: &[], released: &[] },
            &mut qdd,
            &mut [],
        )
        .unwrap();
        assert_eq!(qdd, [2.0, -2.0]);
        let mut empty = DenseLu::new(0, 0);
        empty
            .solve(&KktSystem { mass: &[], g: &[], g_values: &[], f: &[], gamma: &[], released: &[] }, &mut [], &mut [])
            .unwrap();
    }
}
