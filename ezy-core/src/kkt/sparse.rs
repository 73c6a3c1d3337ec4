//! The sparse Schur-complement path for large models (chains of many
//! links): `A = G M^-1 G^T` assembled in faer's compressed-column format
//! from the sparsity pattern of `G`, its ordering and elimination tree
//! (AMD, symbolic Cholesky) computed once at construction, and only the
//! numeric `L L^T` factorization and the triangular solves per right-hand
//! side. Cost per solve is linear in the number of links for a chain
//! (each coordinate touches a bounded number of constraint rows).
//!
//! Source: Davis, *Direct Methods for Sparse Linear Systems* (SIAM 2006),
//! ch. 4 (symbolic analysis reused across numeric factorizations); faer
//! 0.24's `sparse::linalg::cholesky`.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::spd::SINGULAR_SWEEPS;
use super::{KktSolver, KktSystem};
use crate::error::KktError;
use crate::kkt::spd::{PIVOT_RTOL, SINGULAR_MU};

/// One product term of `A = G M^-1 G^T`: `A[a] += G[gi] G[gj] / M[k]`
/// (indices into `A`'s values, `G`'s pattern values and `M`'s diagonal).
#[derive(Debug, Clone, Copy)]
struct Term {
    a: u32,
    gi: u32,
    gj: u32,
    k: u32,
}

/// The sparse Schur-complement solver: `(G M^-1 G^T) lambda = G M^-1 f +
/// gamma`, `qdd = M^-1 (f - G^T lambda)`, for a constant pattern of `G`.
/// Needs every mass entry > 0. Nothing is allocated per solve.
pub struct SparseSchur {
    nq: usize,
    nc: usize,
    /// `G`'s structural nonzeros `(row, col)`, in the order of its values.
    pattern: Vec<(usize, usize)>,
    minv: Vec<f64>,
    /// Lower triangle of `A` in compressed columns.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    a_values: Vec<f64>,
    /// Diagonal positions in `a_values`, for the pivot-growth estimate.
    diag: Vec<usize>,
    terms: Vec<Term>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    rhs: Vec<f64>,
    /// `perm[j]`: the row of `G` eliminated `j`-th (AMD order).
    perm: Vec<usize>,
    /// Position of `L_jj` in `l_values` (simplicial factor, diagonal first).
    l_diag: Vec<usize>,
    /// Pivot growth `max_j A_jj / L_jj^2` of the last solve.
    growth: f64,
    /// Whether the last solve found `A` singular and took the regularized
    /// sweeps ([`super::regularized_solve`], the same method in sparse form).
    singular: bool,
    /// Scratch of the regularized sweeps (nc each): `G M^-1 f + gamma`,
    /// the regularization's scale `diag(A)`, the residual.
    b: Vec<f64>,
    scale: Vec<f64>,
    res: Vec<f64>,
}

impl std::fmt::Debug for SparseSchur {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseSchur")
            .field("nq", &self.nq)
            .field("nc", &self.nc)
            .field("normal_nonzeros", &self.row_idx.len())
            .field("factor_nonzeros", &self.l_values.len())
            .finish_non_exhaustive()
    }
}

impl SparseSchur {
    /// Analyses the pattern of `G` (nc x nq; `(row, col)` pairs, each once,
    /// in the order `g_values` will have) for the mass diagonal `mass`
    /// (nq): the pattern of `A`, its AMD ordering and symbolic factor.
    ///
    /// # Errors
    /// [`KktError::SingularMass`] if a mass entry is not positive and finite.
    ///
    /// # Panics
    /// If a pattern entry lies outside `nc x nq`, or if faer's symbolic
    /// analysis fails (it only fails on allocation).
    pub fn new(pattern: &[(usize, usize)], nc: usize, mass: &[f64]) -> Result<Self, KktError> {
        let nq = mass.len();
        let mut minv = vec![0.0; nq];
        for (k, (&m, w)) in mass.iter().zip(&mut minv).enumerate() {
            if !(m > 0.0 && m.is_finite()) {
                return Err(KktError::SingularMass { index: k, value: m });
            }
            *w = 1.0 / m;
        }
        // rows of G per column (coordinate), with the index of the value
        let mut by_col: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nq];
        for (v, &(r, c)) in pattern.iter().enumerate() {
            assert!(r < nc && c < nq, "pattern entry ({r}, {c}) outside {nc} x {nq}");
            by_col[c].push((r, v));
        }
        // structural pattern of the lower triangle of A, column by column
        let mut cols: Vec<Vec<usize>> = (0..nc).map(|j| vec![j]).collect();
        for rows in &by_col {
            for &(ri, _) in rows {
                for &(rj, _) in rows {
                    if ri > rj {
                        cols[rj].push(ri);
                    }
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(nc + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        let position = |i: usize, j: usize| -> usize {
            let start = col_ptr[j];
            start + row_idx[start..col_ptr[j + 1]].binary_search(&i).expect("in the pattern")
        };
        let mut terms = Vec::new();
        for (k, rows) in by_col.iter().enumerate() {
            for &(ri, vi) in rows {
                for &(rj, vj) in rows {
                    if ri >= rj {
                        let a = position(ri, rj);
                        terms.push(Term { a: a as u32, gi: vi as u32, gj: vj as u32, k: k as u32 });
                    }
                }
            }
        }
        let diag = (0..nc).map(|j| position(j, j)).collect();
        let a_sym = SymbolicSparseColMatRef::new_checked(nc, nc, &col_ptr, None, &row_idx);
        // simplicial: chains have tiny supernodes, and its factor has the
        // diagonal first in each column (for the pivot-growth check)
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(a_sym, Side::Lower, SymmetricOrdering::Amd, params)
            .expect("symbolic Cholesky only fails on allocation");
        let SymbolicCholeskyRaw::Simplicial(simplicial) = symbolic.raw() else {
            unreachable!("simplicial factorization was forced")
        };
        let l_diag: Vec<usize> = simplicial.col_ptr()[..nc].to_vec();
        for (j, &p) in l_diag.iter().enumerate() {
            assert_eq!(simplicial.row_idx()[p], j, "faer's simplicial factor stores the diagonal first");
        }
        let perm: Vec<usize> = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..nc).collect(),
        };
        let factor_mem = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let solve_mem = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let l_values = vec![0.0; symbolic.len_val()];
        let a_values = vec![0.0; row_idx.len()];
        Ok(Self {
            nq,
            nc,
            pattern: pattern.to_vec(),
            minv,
            col_ptr,
            row_idx,
            a_values,
            diag,
            terms,
            symbolic,
            l_values,
            factor_mem,
            solve_mem,
            rhs: vec![0.0; nc],
            perm,
            l_diag,
            growth: 1.0,
            singular: false,
            b: vec![0.0; nc],
            scale: vec![0.0; nc],
            res: vec![0.0; nc],
        })
    }

    /// Structural nonzeros of the lower triangle of `A = G M^-1 G^T`.
    pub fn normal_nonzeros(&self) -> usize {
        self.row_idx.len()
    }

    /// Nonzeros of the Cholesky factor `L` (after AMD ordering).
    pub fn factor_nonzeros(&self) -> usize {
        self.l_values.len()
    }
}

impl KktSolver for SparseSchur {
    fn solve(&mut self, sys: &KktSystem<'_>, qdd: &mut [f64], lambda: &mut [f64]) -> Result<(), KktError> {
        let (nq, nc) = (self.nq, self.nc);
        debug_assert_eq!((sys.nq(), sys.nc()), (nq, nc));
        let g = sys.g_values;
        self.a_values.fill(0.0);
        for t in &self.terms {
            self.a_values[t.a as usize] += g[t.gi as usize] * g[t.gj as usize] * self.minv[t.k as usize];
        }
        for &row in sys.released {
            self.a_values[self.diag[row]] = 1.0;
        }
        if self.a_values.iter().any(|v| !v.is_finite()) {
            return Err(KktError::NonFinite { n: nc });
        }
        // rhs = G M^-1 f + gamma
        self.rhs.copy_from_slice(sys.gamma);
        for (&(r, c), &v) in self.pattern.iter().zip(g) {
            self.rhs[r] += v * self.minv[c] * sys.f[c];
        }
        self.singular = false;
        match self.factor() {
            Ok(()) => {
                let x = MatMut::from_column_major_slice_mut(&mut self.rhs, nc, 1);
                LltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
                    Conj::No,
                    x,
                    Par::Seq,
                    MemStack::new(&mut self.solve_mem),
                );
                lambda.copy_from_slice(&self.rhs);
            }
            Err(KktError::DependentConstraints { .. }) => self.solve_singular(lambda)?,
            Err(e) => return Err(e),
        }
        // qdd = M^-1 (f - G^T lambda)
        qdd.copy_from_slice(sys.f);
        for (&(r, c), &v) in self.pattern.iter().zip(g) {
            qdd[c] -= v * lambda[r];
        }
        for (q, w) in qdd.iter_mut().zip(&self.minv) {
            *q *= w;
        }
        Ok(())
    }

    fn name(&self) -> &'static str {
        "sparse-cholesky"
    }

    fn condition_estimate(&self) -> Option<f64> {
        Some(self.growth)
    }

    fn was_singular(&self) -> bool {
        self.singular
    }
}

impl SparseSchur {
    /// The first row of `G` (values `g` at the pattern) that depends on the
    /// rows before it in `A = G M^-1 G^T`, by the strict pivot test alone
    /// (no regularization): `None` when `G` has full row rank.
    ///
    /// # Errors
    /// [`KktError::NonFinite`] if `G` has a non-finite entry.
    pub fn dependent_row(&mut self, g: &[f64]) -> Result<Option<usize>, KktError> {
        self.a_values.fill(0.0);
        for t in &self.terms {
            self.a_values[t.a as usize] += g[t.gi as usize] * g[t.gj as usize] * self.minv[t.k as usize];
        }
        if self.a_values.iter().any(|v| !v.is_finite()) {
            return Err(KktError::NonFinite { n: self.nc });
        }
        match self.factor() {
            Ok(()) => Ok(None),
            Err(KktError::DependentConstraints { row, .. }) => Ok(Some(row)),
            Err(e) => Err(e),
        }
    }

    /// Factors `A` (assembled in `a_values`) into `l_values` and checks the
    /// pivot growth, as the dense path does (see `ldl_solve`): a row that
    /// lost all but 1e-13 of its diagonal depends on the rows before it.
    fn factor(&mut self) -> Result<(), KktError> {
        let nc = self.nc;
        let a = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(nc, nc, &self.col_ptr, None, &self.row_idx),
            &self.a_values,
        );
        self.symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_mem),
                Default::default(),
            )
            .map_err(|LltError::NonPositivePivot { index }| {
                // faer counts the failing pivot from 1, in the AMD order
                KktError::DependentConstraints { n: nc, row: self.perm[index.saturating_sub(1).min(nc - 1)] }
            })?;
        self.growth = 1.0;
        for (j, &p) in self.l_diag.iter().enumerate() {
            let row = self.perm[j];
            let l = self.l_values[p];
            let g = self.a_values[self.diag[row]] / (l * l);
            if g.is_nan() || g > 1.0 / PIVOT_RTOL {
                return Err(KktError::DependentConstraints { n: nc, row });
            }
            self.growth = self.growth.max(g);
        }
        Ok(())
    }

    /// The singular `A` of this solve (right-hand side in `rhs`) by the
    /// regularized sweeps of [`super::regularized_solve`]: `A + mu diag(A)`
    /// factored once, `x += A_mu^-1 (b - A x)` from `x = 0`.
    #[cold]
    #[inline(never)]
    #[expect(
        clippy::neg_cmp_op_on_partial_ord,
        reason = "`!(x > 0.0)` is also true for NaN, which a pivot test must refuse"
    )]
    fn solve_singular(&mut self, x: &mut [f64]) -> Result<(), KktError> {
        let nc = self.nc;
        self.b.copy_from_slice(&self.rhs);
        let dmax = self.diag.iter().map(|&p| self.a_values[p]).fold(0.0, f64::max);
        x.fill(0.0);
        if dmax.is_nan() || dmax <= 0.0 {
            return Ok(());
        }
        for (j, s) in self.scale.iter_mut().enumerate() {
            *s = self.a_values[self.diag[j]].max(f64::EPSILON * dmax);
            self.a_values[self.diag[j]] += SINGULAR_MU * *s;
        }
        // positive definite, its pivot growth at most about 1 / mu
        self.factor()?;
        self.singular = true;
        self.growth = 1.0 / PIVOT_RTOL;
        for _ in 0..SINGULAR_SWEEPS {
            // res = b - A x, with A = A_mu - mu diag(scale) from its lower triangle
            self.res.copy_from_slice(&self.b);
            for j in 0..nc {
                self.res[j] += SINGULAR_MU * self.scale[j] * x[j];
                for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                    let (i, v) = (self.row_idx[p], self.a_values[p]);
                    self.res[i] -= v * x[j];
                    if i != j {
                        self.res[j] -= v * x[i];
                    }
                }
            }
            let dx = MatMut::from_column_major_slice_mut(&mut self.res, nc, 1);
            LltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
                Conj::No,
                dx,
                Par::Seq,
                MemStack::new(&mut self.solve_mem),
            );
            let (mut step, mut size) = (0.0f64, 0.0f64);
            for ((xj, d), s) in x.iter_mut().zip(&self.res).zip(&self.scale) {
                *xj += d;
                let w = s.sqrt();
                step = step.max((d * w).abs());
                size = size.max((*xj * w).abs());
            }
            if !(step > 8.0 * f64::EPSILON * size) {
                break;
            }
        }
        Ok(())
    }
}

/// `(pattern of G, values of G, nc, mass diagonal)`.
pub type SyntheticKkt = (Vec<(usize, usize)>, Vec<f64>, usize, Vec<f64>);

/// The KKT data of a planar chain of `n` links without a model, for
/// benchmarks and tests of the KKT paths: `(pattern of G, values, nc,
/// mass diagonal)`. Three coordinates per link; two hinge rows between
/// neighbours (x or y, the first link's heading, the next link's x or y and
/// heading), one skate row per link (x, y, heading); smooth values; `G`
/// row-major sorted.
///
/// # Panics
/// For `n < 2`.
pub fn synthetic_chain(n: usize) -> SyntheticKkt {
    let mut pattern = Vec::new();
    let mut values = Vec::new();
    let mut row = 0;
    for i in 0..n - 1 {
        for axis in 0..2 {
            for (c, v) in [(3 * i + axis, 1.0), (3 * i + 2, 0.3 + 0.01 * i as f64), (3 * i + 3 + axis, -1.0)] {
                pattern.push((row, c));
                values.push(v);
            }
            pattern.push((row, 3 * i + 5));
            values.push(0.2 - 0.02 * axis as f64);
            row += 1;
        }
    }
    for i in 0..n {
        let phi = 0.1 * i as f64;
        for (c, v) in [(3 * i, -phi.sin()), (3 * i + 1, phi.cos()), (3 * i + 2, -0.25)] {
            pattern.push((row, c));
            values.push(v);
        }
        row += 1;
    }
    let mass = (0..3 * n).map(|k| if k % 3 == 2 { 0.05 + 0.001 * k as f64 } else { 1.0 + 0.01 * k as f64 }).collect();
    // rows must be sorted for a row-major pattern: sort both together
    let mut idx: Vec<usize> = (0..pattern.len()).collect();
    idx.sort_by_key(|&k| pattern[k]);
    let pattern: Vec<_> = idx.iter().map(|&k| pattern[k]).collect();
    let values: Vec<_> = idx.iter().map(|&k| values[k]).collect();
    (pattern, values, row, mass)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kkt::spd::ldl_solve;

    /// Dense reference: `A` assembled densely, `ldl_solve`, then `qdd`.
    fn dense(
        pattern: &[(usize, usize)],
        g: &[f64],
        nc: usize,
        mass: &[f64],
        f: &[f64],
        gamma: &[f64],
    ) -> (Vec<f64>, Vec<f64>) {
        let nq = mass.len();
        let mut gd = vec![0.0; nc * nq];
        for (&(r, c), &v) in pattern.iter().zip(g) {
            gd[r * nq + c] = v;
        }
        let mut a = vec![0.0; nc * nc];
        for i in 0..nc {
            for j in 0..=i {
                a[i * nc + j] = (0..nq).map(|k| gd[i * nq + k] * gd[j * nq + k] / mass[k]).sum();
            }
        }
        let r: Vec<f64> =
            (0..nc).map(|i| gamma[i] + (0..nq).map(|k| gd[i * nq + k] * f[k] / mass[k]).sum::<f64>()).collect();
        let mut lambda = vec![0.0; nc];
        ldl_solve(&a, nc, nc, &r, &mut lambda, &mut vec![0.0; nc * (nc + 1)]).unwrap();
        let qdd =
            (0..nq).map(|k| (f[k] - (0..nc).map(|i| gd[i * nq + k] * lambda[i]).sum::<f64>()) / mass[k]).collect();
        (qdd, lambda)
    }

    /// Sparse and dense paths agree to 1e-12 (relative to the largest
    /// entry) for chains of 2 to 50 links.
    #[test]
    fn agrees_with_the_dense_path_on_chains() {
        for n in [2, 3, 5, 10, 20, 50] {
            let (pattern, g, nc, mass) = synthetic_chain(n);
            let nq = mass.len();
            let f: Vec<f64> = (0..nq).map(|k| (0.7 * k as f64).sin()).collect();
            let gamma: Vec<f64> = (0..nc).map(|i| (0.3 * i as f64).cos()).collect();
            let mut s = SparseSchur::new(&pattern, nc, &mass).unwrap();
            let sys = KktSystem { mass: &mass, g: &[], g_values: &g, f: &f, gamma: &gamma, released: &[] };
            let (mut qdd, mut lambda) = (vec![0.0; nq], vec![0.0; nc]);
            s.solve(&sys, &mut qdd, &mut lambda).unwrap();
            let (qdd_d, lambda_d) = dense(&pattern, &g, nc, &mass, &f, &gamma);
            let scale = lambda_d.iter().chain(&qdd_d).fold(1.0f64, |m, v| m.max(v.abs()));
            for (a, b) in qdd.iter().zip(&qdd_d).chain(lambda.iter().zip(&lambda_d)) {
                assert!((a - b).abs() <= 1e-12 * scale, "n = {n}: {a} vs {b}");
            }
            // and it satisfies the constraint rows: G qdd = -gamma
            for (i, gam) in gamma.iter().enumerate() {
                let gq: f64 = pattern.iter().zip(&g).filter(|((r, _), _)| *r == i).map(|((_, c), v)| v * qdd[*c]).sum();
                assert!((gq + gam).abs() <= 1e-11 * scale, "n = {n}, row {i}: {gq}");
            }
        }
    }

    /// A row repeated: the strict check names it; the solve takes the
    /// regularized sweeps, says so, and its accelerations satisfy every
    /// row (`G qdd = -gamma`, consistent: the copy's gamma repeats too)
    /// with the multipliers of the two copies equal (the least ones).
    #[test]
    fn dependent_rows_are_named_and_solved_regularized() {
        let (mut pattern, mut g, nc, mass) = synthetic_chain(4);
        let first: Vec<(usize, f64)> =
            pattern.iter().zip(&g).filter(|((r, _), _)| *r == 0).map(|((_, c), v)| (*c, *v)).collect();
        for (c, v) in first {
            pattern.push((nc, c));
            g.push(v);
        }
        let mut s = SparseSchur::new(&pattern, nc + 1, &mass).unwrap();
        let nq = mass.len();
        let row = s.dependent_row(&g).unwrap();
        assert!(row == Some(0) || row == Some(nc), "{row:?}");
        let f: Vec<f64> = (0..nq).map(|k| (0.7 * k as f64).sin()).collect();
        let mut gamma: Vec<f64> = (0..nc).map(|i| (0.3 * i as f64).cos()).collect();
        gamma.push(gamma[0]);
        let sys = KktSystem { mass: &mass, g: &[], g_values: &g, f: &f, gamma: &gamma, released: &[] };
        let (mut qdd, mut lambda) = (vec![0.0; nq], vec![0.0; nc + 1]);
        s.solve(&sys, &mut qdd, &mut lambda).unwrap();
        assert!(s.was_singular());
        // the same accelerations as the chain without the copy
        let (pattern0, g0, _, _) = synthetic_chain(4);
        let (qdd0, _) = dense(&pattern0, &g0, nc, &mass, &f, &gamma[..nc]);
        let scale = qdd0.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (a, b) in qdd.iter().zip(&qdd0) {
            assert!((a - b).abs() <= 1e-9 * scale, "{a} vs {b}");
        }
        assert!((lambda[0] - lambda[nc]).abs() <= 1e-3 * lambda[0].abs().max(1.0), "{} vs {}", lambda[0], lambda[nc]);
    }

    /// The factor of a chain stays linear in its length (AMD finds the
    /// banded order): nonzeros of L per link bounded.
    #[test]
    fn fill_stays_linear_for_a_chain() {
        let per_link = |n: usize| {
            let (pattern, _, nc, mass) = synthetic_chain(n);
            SparseSchur::new(&pattern, nc, &mass).unwrap().factor_nonzeros() as f64 / n as f64
        };
        let (small, large) = (per_link(100), per_link(2000));
        assert!(large <= 1.5 * small, "L nonzeros per link: {small} at 100 links, {large} at 2000");
    }
}
