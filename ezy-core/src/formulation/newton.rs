//! The Newton system of the implicit method (RADAU5) for a multibody
//! model, built on the KKT structure instead of a dense Jacobian of the
//! right-hand side.
//!
//! The state is `y = [q, v, W]` (n coordinates, n velocities, the work
//! states) and `F(y) = [v; a(q, v, t); P(q, v, t)]` with `a` the
//! accelerations of the index-1 KKT system and `P` the effects' powers.
//! RADAU5 solves `(c I - J) dy = r` for a real `c = MU_REAL/h` and a
//! complex `c = MU_COMPLEX/h`. The acceleration response is linearized
//! in full: from `M a + G^T lambda = f(q, v, t)` and `G a = -gamma(q, v)`,
//!
//! ```text
//! M da + G^T dlambda = K' dq + C dv,   K' = K - d(G^T lambda)/dq,
//! G da = -D dq - Gv dv,                D = d(G a)/dq + d(gamma)/dq,  Gv = d(gamma)/dv
//! ```
//!
//! (`K = df/dq`, `C = df/dv` of the effects' generalized force `f`; `a`
//! and `lambda` held at the Jacobian's point; `gamma` includes Baumgarte's
//! terms when they are on). With `s = 1/c` and `u = s r_q + s^2 r_v` the
//! system reduces to the KKT-structured
//!
//! ```text
//! [ M - s^2 K' - s C      G^T ] [ dq ]   [ M u - s^2 C r_q  ]
//! [ G + s^2 D + s Gv      0   ] [ mu ] = [ G u + s^2 Gv r_q ]
//! ```
//!
//! followed by `dv = c dq - r_q` and `dW = s (r_W + dP/dq dq + dP/dv dv)`
//! (the work states feed nothing back; a drive's power, `-lambda u'`, is
//! left out of `dP`): one (n + nc) solve per system instead of a (2n + k)
//! dense one, well scaled as `h -> 0` (it tends to the KKT matrix of the
//! accelerations). Leaving out `d(G^T lambda)/dq` and `D` (the constraint
//! forces' geometric stiffness and the curvature of the constraints) cost
//! `snake-stiff` 37k rejected steps of 56k: the servo forces' change of
//! direction with the links is what the stiff modes feel.
//!
//! Every derivative is a forward difference over groups of coordinates
//! that share no effect and no row of `G` (Curtis, Powell & Reid 1974),
//! each effect's and each row's change attributed to the one coordinate
//! of the group it reads, so a chain costs a handful of evaluations
//! whatever its length. The matrix is factored densely for small models
//! and by faer's sparse LU (symbolic analysis once) for large ones, real
//! and complex.
//!
//! A skate sliding with friction ([`crate::formulation::friction`]) has its row
//! released: the row and column of its multiplier carry a unit diagonal
//! and nothing else, its right-hand side is zero, and its multiplier in
//! `K'` is the friction's `s mu N` (the Coulomb force `-G_r^T s mu N`
//! turns with the body as a constraint force does). The set is read at
//! each Jacobian; a switch restarts the method, and with it the Jacobian.

use faer::c64;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu, factorize_symbolic_lu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

use crate::error::SimError;
use crate::formulation::dae::Dynamics;
use crate::integrator::radau5::{DenseFactor, NewtonSystem};
use crate::model::Model;

/// The structured Newton system of a model (module docs).
pub struct KktNewton {
    n: usize,
    nc: usize,
    mass: Vec<f64>,
    /// `G`'s pattern (row-major) and values at the Jacobian's point; `D`
    /// and `Gv` on the same pattern.
    g_pattern: Vec<(usize, usize)>,
    g_values: Vec<f64>,
    d_values: Vec<f64>,
    gv_values: Vec<f64>,
    /// The entries (indices into `g_pattern`) of each row, of each column.
    g_row: Vec<Vec<usize>>,
    g_col: Vec<Vec<usize>>,
    /// The pattern of `K'` and `C` (`(row, col)`) and their values.
    kc_pattern: Vec<(usize, usize)>,
    k_values: Vec<f64>,
    c_values: Vec<f64>,
    /// Each effect's coordinates, and the index in `kc_pattern` of each
    /// pair of them (row-major, `len^2`).
    effect_coords: Vec<Vec<usize>>,
    effect_kc: Vec<Vec<usize>>,
    /// Each effect's power's derivatives by its coordinates and their
    /// rates (`dP/dq`, `dP/dv`, in the order of `effect_coords`), for the
    /// work states' rows.
    power_q: Vec<Vec<f64>>,
    power_v: Vec<Vec<f64>>,
    /// Each effect's force at its coordinates and its power at the
    /// Jacobian's point (the base of its differences).
    base_force: Vec<Vec<f64>>,
    base_power: Vec<f64>,
    /// The forces that depend on time alone: their coordinates, and the
    /// force there at the Jacobian's point (their `dP/dv`).
    constant_coords: Vec<Vec<usize>>,
    constant_force: Vec<Vec<f64>>,
    /// For each `G` entry `(r, j)`: the `kc_pattern` index of `(i, j)`
    /// for every entry `(r, i)` of row `r`, in the order of `g_row[r]`.
    geo_kc: Vec<Vec<usize>>,
    /// Coordinates perturbed together, and each coordinate's group.
    groups: Vec<Vec<usize>>,
    group_of: Vec<usize>,
    /// `1/c` of the last factorizations.
    s_real: f64,
    s_complex: c64,
    factors: Factors,
    /// Scratch: the state's accelerations and multipliers, the forces and
    /// constraint terms at the base point and a perturbed one.
    dy: Vec<f64>,
    qdd: Vec<f64>,
    lambda: Vec<f64>,
    f0: Vec<f64>,
    f1: Vec<f64>,
    g1: Vec<f64>,
    gamma0: Vec<f64>,
    gamma1: Vec<f64>,
    phi: Vec<f64>,
    q1: Vec<f64>,
    v1: Vec<f64>,
    cr: Vec<f64>,
    u_real: Vec<f64>,
    u_complex: Vec<c64>,
    rhs_real: Vec<f64>,
    rhs_complex: Vec<c64>,
    /// The rows released by sliding skates at the Jacobian's point
    /// ([`Dynamics::released_rows`]): a unit diagonal and zero couplings
    /// in the Newton matrix, a zero right-hand side (their multipliers
    /// are the friction's, held in `lambda`).
    released: Vec<usize>,
}

impl std::fmt::Debug for KktNewton {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KktNewton")
            .field("n", &self.n)
            .field("nc", &self.nc)
            .field("coupling_nonzeros", &self.kc_pattern.len())
            .field("groups", &self.groups.len())
            .field("sparse", &matches!(self.factors, Factors::Sparse(_)))
            .finish_non_exhaustive()
    }
}

/// Models from this many rows of the Newton matrix (`n + nc`) take the
/// sparse LU, and every model with families (as the KKT solve).
pub const SPARSE_NEWTON_FROM: usize = 64;

enum Factors {
    Dense { real: Box<DenseFactor<f64>>, complex: Box<DenseFactor<c64>> },
    Sparse(Box<SparseFactors>),
}

/// The sparse LU of the Newton matrix: its pattern in compressed columns,
/// where each source entry goes, the symbolic analysis (once) and the
/// numeric factors, real and complex.
struct SparseFactors {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Position in the values of: the mass diagonal (n), each coupling
    /// entry, each `G` entry (row n + r, col c) and its transpose.
    at_mass: Vec<usize>,
    at_kc: Vec<usize>,
    at_g: Vec<usize>,
    at_gt: Vec<usize>,
    /// The rows a skate's friction may release (sorted), and the position
    /// of the diagonal entry `(n + r, n + r)` of each.
    releasable: Vec<usize>,
    at_diag: Vec<usize>,
    symbolic: SymbolicLu<usize>,
    values_real: Vec<f64>,
    values_complex: Vec<c64>,
    numeric_real: NumericLu<usize, f64>,
    numeric_complex: NumericLu<usize, c64>,
    mem: MemBuffer,
    rhs_real: Vec<f64>,
    rhs_complex: Vec<c64>,
}

impl KktNewton {
    /// The system for the run `sys`: the patterns of `G` and of the
    /// coupling (the effects' coordinates, and the coordinates of each row
    /// of `G`, pairwise), the column groups, and the factor storage (dense
    /// below [`SPARSE_NEWTON_FROM`] rows for models without families,
    /// sparse otherwise).
    pub fn new<M: Model>(sys: &Dynamics<M>) -> Self {
        let info = &sys.info;
        let (n, nc) = (info.nq(), info.nc());
        let g_pattern = info.pattern.clone();
        let mut g_row: Vec<Vec<usize>> = vec![Vec::new(); nc];
        let mut g_col: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (e, &(r, c)) in g_pattern.iter().enumerate() {
            g_row[r].push(e);
            g_col[c].push(e);
        }
        let effect_coords: Vec<Vec<usize>> = sys.effects.iter().map(|e| e.coords()).collect();
        let constant_coords: Vec<Vec<usize>> = sys.effects.iter().map(|e| e.constant_force_coords()).collect();
        // the sets of coordinates read together: each effect's, each row's
        let row_coords: Vec<Vec<usize>> = g_row.iter().map(|es| es.iter().map(|&e| g_pattern[e].1).collect()).collect();
        let sets: Vec<&Vec<usize>> = effect_coords.iter().chain(&row_coords).collect();
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        for cs in &sets {
            for &r in cs.iter() {
                for &c in cs.iter() {
                    pairs.push((r, c));
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let kc_index = |r: usize, c: usize| pairs.binary_search(&(r, c)).expect("in the coupling pattern");
        let effect_kc = effect_coords
            .iter()
            .map(|cs| cs.iter().flat_map(|&r| cs.iter().map(move |&c| (r, c))).map(|(r, c)| kc_index(r, c)).collect())
            .collect();
        let geo_kc =
            g_pattern.iter().map(|&(r, j)| g_row[r].iter().map(|&e| kc_index(g_pattern[e].1, j)).collect()).collect();
        // colour the coordinates: two read by one effect or one row never in one group
        let mut sets_of: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (k, cs) in sets.iter().enumerate() {
            for &c in cs.iter() {
                sets_of[c].push(k);
            }
        }
        let mut group_of = vec![usize::MAX; n];
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut taken = Vec::new();
        for c in (0..n).filter(|&c| !sets_of[c].is_empty()) {
            taken.clear();
            for &k in &sets_of[c] {
                taken.extend(sets[k].iter().map(|&d| group_of[d]).filter(|&g| g != usize::MAX));
            }
            let g = (0..).find(|g| !taken.contains(g)).expect("a free group");
            if g == groups.len() {
                groups.push(Vec::new());
            }
            groups[g].push(c);
            group_of[c] = g;
        }
        let sparse = n + nc >= SPARSE_NEWTON_FROM || !sys.model.unrolled_kernels();
        let factors = if sparse {
            // the rows a skate's friction may release get a diagonal entry
            let releasable: Vec<usize> = sys.friction.iter().map(|f| f.row).collect();
            Factors::Sparse(Box::new(SparseFactors::new(n, &pairs, &g_pattern, &releasable)))
        } else {
            Factors::Dense { real: Box::new(DenseFactor::new(n + nc)), complex: Box::new(DenseFactor::new(n + nc)) }
        };
        let (kc, ng) = (pairs.len(), g_pattern.len());
        Self {
            n,
            nc,
            mass: sys.mass.clone(),
            g_values: vec![0.0; ng],
            d_values: vec![0.0; ng],
            gv_values: vec![0.0; ng],
            g_pattern,
            g_row,
            g_col,
            kc_pattern: pairs,
            k_values: vec![0.0; kc],
            c_values: vec![0.0; kc],
            constant_force: constant_coords.iter().map(|cs| vec![0.0; cs.len()]).collect(),
            constant_coords,
            base_force: effect_coords.iter().map(|cs| vec![0.0; cs.len()]).collect(),
            base_power: vec![0.0; effect_coords.len()],
            power_q: effect_coords.iter().map(|cs| vec![0.0; cs.len()]).collect(),
            power_v: effect_coords.iter().map(|cs| vec![0.0; cs.len()]).collect(),
            effect_coords,
            effect_kc,
            geo_kc,
            groups,
            group_of,
            s_real: 0.0,
            s_complex: c64::new(0.0, 0.0),
            factors,
            dy: vec![0.0; sys.ny()],
            qdd: vec![0.0; n],
            lambda: vec![0.0; nc],
            f0: vec![0.0; n],
            f1: vec![0.0; n],
            g1: vec![0.0; ng],
            gamma0: vec![0.0; nc],
            gamma1: vec![0.0; nc],
            phi: vec![0.0; info.n_holonomic],
            q1: vec![0.0; n],
            v1: vec![0.0; n],
            cr: vec![0.0; n],
            u_real: vec![0.0; n],
            u_complex: vec![c64::new(0.0, 0.0); n],
            rhs_real: vec![0.0; n + nc],
            rhs_complex: vec![c64::new(0.0, 0.0); n + nc],
            released: Vec::new(),
        }
    }

    /// Whether the Newton matrix is factored by the sparse LU.
    pub fn is_sparse(&self) -> bool {
        matches!(self.factors, Factors::Sparse(_))
    }

    /// The number of column groups: each Jacobian costs two evaluations of
    /// the effects and of the constraint terms per group.
    pub fn groups(&self) -> usize {
        self.groups.len()
    }

    /// `G` and `gamma` at `(q, v)` (with Baumgarte's terms when they are on).
    fn constraint_terms<M: Model>(
        sys: &Dynamics<M>,
        q: &[f64],
        v: &[f64],
        g: &mut [f64],
        gamma: &mut [f64],
        phi: &mut [f64],
    ) {
        sys.model.constraint_terms(q, v, g, gamma);
        if let Some(crate::formulation::dae::Baumgarte { alpha, beta }) = sys.baumgarte {
            for (&(r, c), &gv) in sys.info.pattern.iter().zip(g.iter()) {
                gamma[r] += 2.0 * alpha * gv * v[c];
            }
            sys.model.phi(q, phi);
            for (gr, p) in gamma.iter_mut().zip(phi.iter()) {
                *gr += beta * beta * p;
            }
        }
    }

    /// The derivatives along the coordinates of `group` moved by `dx`
    /// (`q1` or `v1` already moved): each effect's change into `K` or `C`,
    /// each row's into `K'` and `D` (positions) or `Gv` (velocities).
    fn difference<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, q: &[f64], v: &[f64], group: usize, positions: bool) {
        let (q1, v1): (&[f64], &[f64]) = if positions { (&self.q1, v) } else { (q, &self.v1) };
        let step = |c: usize| if positions { self.q1[c] - q[c] } else { self.v1[c] - v[c] };
        // effects, one at a time: its change belongs to its one coordinate in the group
        for (k, (e, cs)) in sys.effects.iter().zip(&self.effect_coords).enumerate() {
            let Some(lc) = cs.iter().position(|&c| self.group_of[c] == group) else { continue };
            let kcs = &self.effect_kc[k];
            let d = step(cs[lc]);
            for &r in cs {
                self.f1[r] = 0.0;
            }
            let (p1, _) = e.apply(t, q1, v1, &mut self.f1);
            let dp = if positions { &mut self.power_q[k] } else { &mut self.power_v[k] };
            dp[lc] = (p1 - self.base_power[k]) / d;
            let values = if positions { &mut self.k_values } else { &mut self.c_values };
            for ((lr, &r), f0) in cs.iter().enumerate().zip(&self.base_force[k]) {
                values[kcs[lr * cs.len() + lc]] += (self.f1[r] - f0) / d;
            }
        }
        // rows of G: their change belongs to their one coordinate in the group
        Self::constraint_terms(sys, q1, v1, &mut self.g1, &mut self.gamma1, &mut self.phi);
        for c in self.groups[group].iter().copied() {
            let d = step(c);
            for &e in &self.g_col[c] {
                let r = self.g_pattern[e].0;
                let dgamma = (self.gamma1[r] - self.gamma0[r]) / d;
                if positions {
                    // D = d(G a)/dq + d(gamma)/dq; K' -= lambda_r dG_r/dq_c
                    let mut dga = 0.0;
                    for (&ei, &k) in self.g_row[r].iter().zip(&self.geo_kc[e]) {
                        let dg = (self.g1[ei] - self.g_values[ei]) / d;
                        dga += dg * self.qdd[self.g_pattern[ei].1];
                        self.k_values[k] -= self.lambda[r] * dg;
                    }
                    self.d_values[e] = dga + dgamma;
                } else {
                    self.gv_values[e] = dgamma;
                }
            }
        }
    }
}

impl<M: Model> NewtonSystem<Dynamics<M>> for KktNewton {
    fn jacobian(&mut self, sys: &mut Dynamics<M>, t: f64, y: &[f64], _f: &[f64]) -> Result<(), SimError> {
        let n = self.n;
        let (q, rest) = y.split_at(n);
        let v = &rest[..n];
        // the accelerations and multipliers at this state
        sys.rhs(t, y, &mut self.dy)?;
        self.qdd.copy_from_slice(&self.dy[n..2 * n]);
        // a sliding skate's multiplier is its friction `s mu N`: the
        // geometric stiffness below takes its force's turn with the body
        self.lambda.copy_from_slice(sys.lambda());
        self.released.clear();
        self.released.extend_from_slice(sys.released_rows());
        Self::constraint_terms(sys, q, v, &mut self.g_values, &mut self.gamma0, &mut self.phi);
        self.k_values.fill(0.0);
        self.c_values.fill(0.0);
        for (k, (e, cs)) in sys.effects.iter().zip(&self.effect_coords).enumerate() {
            for &r in cs {
                self.f0[r] = 0.0;
            }
            self.base_power[k] = e.apply(t, q, v, &mut self.f0).0;
            for (f, &r) in self.base_force[k].iter_mut().zip(cs) {
                *f = self.f0[r];
            }
        }
        for ((e, cs), fs) in sys.effects.iter().zip(&self.constant_coords).zip(&mut self.constant_force) {
            if cs.is_empty() {
                continue;
            }
            for &c in cs {
                self.f0[c] = 0.0;
            }
            e.apply(t, q, v, &mut self.f0);
            for (f, &c) in fs.iter_mut().zip(cs) {
                *f = self.f0[c];
            }
        }
        self.q1.copy_from_slice(q);
        self.v1.copy_from_slice(v);
        for g in 0..self.groups.len() {
            for &c in &self.groups[g] {
                self.q1[c] = q[c] + f64::EPSILON.sqrt() * q[c].abs().max(1.0);
            }
            self.difference(sys, t, q, v, g, true);
            for &c in &self.groups[g] {
                self.q1[c] = q[c];
                self.v1[c] = v[c] + f64::EPSILON.sqrt() * v[c].abs().max(1.0);
            }
            self.difference(sys, t, q, v, g, false);
            for &c in &self.groups[g] {
                self.v1[c] = v[c];
            }
        }
        Ok(())
    }

    fn factor(&mut self, real: f64, complex: c64) -> bool {
        let (n, nc) = (self.n, self.nc);
        self.s_real = 1.0 / real;
        self.s_complex = c64::new(1.0, 0.0) / complex;
        let (sr, sc) = (self.s_real, self.s_complex);
        let lower_real = |k: usize| self.g_values[k] + sr * sr * self.d_values[k] + sr * self.gv_values[k];
        let lower_complex = |k: usize| sc * sc * self.d_values[k] + sc * self.gv_values[k] + self.g_values[k];
        match &mut self.factors {
            Factors::Dense { real: fr, complex: fc } => {
                for j in 0..n + nc {
                    for i in 0..n + nc {
                        fr.a[(i, j)] = 0.0;
                        fc.a[(i, j)] = c64::new(0.0, 0.0);
                    }
                }
                for (i, &m) in self.mass.iter().enumerate() {
                    fr.a[(i, i)] = m;
                    fc.a[(i, i)] = c64::new(m, 0.0);
                }
                for ((&(r, c), &k), &cv) in self.kc_pattern.iter().zip(&self.k_values).zip(&self.c_values) {
                    fr.a[(r, c)] -= sr * sr * k + sr * cv;
                    fc.a[(r, c)] -= sc * sc * k + sc * cv;
                }
                for (k, (&(r, c), &g)) in self.g_pattern.iter().zip(&self.g_values).enumerate() {
                    fr.a[(n + r, c)] = lower_real(k);
                    fr.a[(c, n + r)] = g;
                    fc.a[(n + r, c)] = lower_complex(k);
                    fc.a[(c, n + r)] = c64::new(g, 0.0);
                }
                for &r in &self.released {
                    for &e in &self.g_row[r] {
                        let c = self.g_pattern[e].1;
                        fr.a[(n + r, c)] = 0.0;
                        fr.a[(c, n + r)] = 0.0;
                        fc.a[(n + r, c)] = c64::new(0.0, 0.0);
                        fc.a[(c, n + r)] = c64::new(0.0, 0.0);
                    }
                    fr.a[(n + r, n + r)] = 1.0;
                    fc.a[(n + r, n + r)] = c64::new(1.0, 0.0);
                }
                fr.factor() && fc.factor()
            }
            Factors::Sparse(sp) => {
                sp.values_real.fill(0.0);
                sp.values_complex.fill(c64::new(0.0, 0.0));
                for (i, &m) in self.mass.iter().enumerate() {
                    sp.values_real[sp.at_mass[i]] += m;
                    sp.values_complex[sp.at_mass[i]] += c64::new(m, 0.0);
                }
                for (k, (&kv, &cv)) in self.k_values.iter().zip(&self.c_values).enumerate() {
                    sp.values_real[sp.at_kc[k]] -= sr * sr * kv + sr * cv;
                    sp.values_complex[sp.at_kc[k]] -= sc * sc * kv + sc * cv;
                }
                for (k, &g) in self.g_values.iter().enumerate() {
                    sp.values_real[sp.at_g[k]] += lower_real(k);
                    sp.values_real[sp.at_gt[k]] += g;
                    sp.values_complex[sp.at_g[k]] += lower_complex(k);
                    sp.values_complex[sp.at_gt[k]] += c64::new(g, 0.0);
                }
                for &r in &self.released {
                    for &e in &self.g_row[r] {
                        for at in [sp.at_g[e], sp.at_gt[e]] {
                            sp.values_real[at] = 0.0;
                            sp.values_complex[at] = c64::new(0.0, 0.0);
                        }
                    }
                    let at = sp.at_diag[sp.releasable.binary_search(&r).expect("a friction row")];
                    sp.values_real[at] = 1.0;
                    sp.values_complex[at] = c64::new(1.0, 0.0);
                }
                sp.factor()
            }
        }
    }

    fn solve_real(&mut self, b: &mut [f64]) {
        let n = self.n;
        let s = self.s_real;
        // u = s r_q + s^2 r_v; right-hand side [M u - s^2 C r_q; G u + s^2 Gv r_q]
        for i in 0..n {
            self.u_real[i] = s * b[i] + s * s * b[n + i];
        }
        self.cr.fill(0.0);
        for (&(r, c), &v) in self.kc_pattern.iter().zip(&self.c_values) {
            self.cr[r] += v * b[c];
        }
        for i in 0..n {
            self.rhs_real[i] = self.mass[i] * self.u_real[i] - s * s * self.cr[i];
        }
        self.rhs_real[n..].fill(0.0);
        for ((&(r, c), &g), &gv) in self.g_pattern.iter().zip(&self.g_values).zip(&self.gv_values) {
            self.rhs_real[n + r] += g * self.u_real[c] + s * s * gv * b[c];
        }
        for &r in &self.released {
            self.rhs_real[n + r] = 0.0;
        }
        match &mut self.factors {
            Factors::Dense { real, .. } => real.solve(&mut self.rhs_real),
            Factors::Sparse(sp) => sp.solve_real(&mut self.rhs_real),
        }
        // dv = c dq - r_q, dW = s (r_W + dP/dq dq + dP/dv dv)
        for i in 0..n {
            let dq = self.rhs_real[i];
            b[n + i] = dq / s - b[i];
            b[i] = dq;
        }
        let (qv, w) = b.split_at_mut(2 * n);
        for (k, wk) in w.iter_mut().enumerate() {
            let mut dp = 0.0;
            if let Some(cs) = self.effect_coords.get(k) {
                for (l, &c) in cs.iter().enumerate() {
                    dp += self.power_q[k][l] * qv[c] + self.power_v[k][l] * qv[n + c];
                }
                for (&c, &f) in self.constant_coords[k].iter().zip(&self.constant_force[k]) {
                    dp += f * qv[n + c];
                }
            }
            *wk = s * (*wk + dp);
        }
    }

    fn solve_complex(&mut self, b: &mut [c64]) {
        let n = self.n;
        let s = self.s_complex;
        let s2 = s * s;
        for i in 0..n {
            self.u_complex[i] = s * b[i] + s2 * b[n + i];
            self.rhs_complex[i] = self.u_complex[i] * self.mass[i];
        }
        for (&(r, c), &v) in self.kc_pattern.iter().zip(&self.c_values) {
            self.rhs_complex[r] -= s2 * b[c] * v;
        }
        self.rhs_complex[n..].fill(c64::new(0.0, 0.0));
        for ((&(r, c), &g), &gv) in self.g_pattern.iter().zip(&self.g_values).zip(&self.gv_values) {
            self.rhs_complex[n + r] += self.u_complex[c] * g + s2 * b[c] * gv;
        }
        for &r in &self.released {
            self.rhs_complex[n + r] = c64::new(0.0, 0.0);
        }
        match &mut self.factors {
            Factors::Dense { complex, .. } => complex.solve(&mut self.rhs_complex),
            Factors::Sparse(sp) => sp.solve_complex(&mut self.rhs_complex),
        }
        for i in 0..n {
            let dq = self.rhs_complex[i];
            b[n + i] = dq / s - b[i];
            b[i] = dq;
        }
        let (qv, w) = b.split_at_mut(2 * n);
        for (k, wk) in w.iter_mut().enumerate() {
            let mut dp = c64::new(0.0, 0.0);
            if let Some(cs) = self.effect_coords.get(k) {
                for (l, &c) in cs.iter().enumerate() {
                    dp += qv[c] * self.power_q[k][l] + qv[n + c] * self.power_v[k][l];
                }
                for (&c, &f) in self.constant_coords[k].iter().zip(&self.constant_force[k]) {
                    dp += qv[n + c] * f;
                }
            }
            *wk = s * (*wk + dp);
        }
    }
}

impl SparseFactors {
    /// The pattern of `[M + coupling, G^T; G, 0]` (with a diagonal entry
    /// at each row of `releasable`) and its symbolic LU.
    fn new(n: usize, kc: &[(usize, usize)], g: &[(usize, usize)], releasable: &[usize]) -> Self {
        let nc = g.iter().map(|&(r, _)| r + 1).max().unwrap_or(0);
        let dim = n + nc;
        let mut entries: Vec<(usize, usize)> = Vec::with_capacity(n + kc.len() + 2 * g.len() + releasable.len());
        entries.extend((0..n).map(|i| (i, i)));
        entries.extend_from_slice(kc);
        entries.extend(g.iter().map(|&(r, c)| (n + r, c)));
        entries.extend(g.iter().map(|&(r, c)| (c, n + r)));
        let mut releasable = releasable.to_vec();
        releasable.sort_unstable();
        entries.extend(releasable.iter().map(|&r| (n + r, n + r)));
        // compressed columns, rows sorted, duplicates merged
        let mut by_col: Vec<Vec<usize>> = vec![Vec::new(); dim];
        for &(r, c) in &entries {
            by_col[c].push(r);
        }
        let mut col_ptr = Vec::with_capacity(dim + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for rows in &mut by_col {
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend_from_slice(rows);
            col_ptr.push(row_idx.len());
        }
        let position = |r: usize, c: usize| -> usize {
            let start = col_ptr[c];
            start + row_idx[start..col_ptr[c + 1]].binary_search(&r).expect("in the pattern")
        };
        let at_mass = (0..n).map(|i| position(i, i)).collect();
        let at_kc = kc.iter().map(|&(r, c)| position(r, c)).collect();
        let at_g = g.iter().map(|&(r, c)| position(n + r, c)).collect();
        let at_gt = g.iter().map(|&(r, c)| position(c, n + r)).collect();
        let at_diag = releasable.iter().map(|&r| position(n + r, n + r)).collect();
        let sym = SymbolicSparseColMatRef::new_checked(dim, dim, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_lu(sym, Default::default()).expect("symbolic LU only fails on allocation");
        let req = faer::dyn_stack::StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.factorize_numeric_lu_scratch::<c64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
            symbolic.solve_in_place_scratch::<c64>(1, Par::Seq),
        ]);
        let nnz = row_idx.len();
        Self {
            col_ptr,
            row_idx,
            at_mass,
            at_kc,
            at_g,
            at_gt,
            releasable,
            at_diag,
            symbolic,
            values_real: vec![0.0; nnz],
            values_complex: vec![c64::new(0.0, 0.0); nnz],
            numeric_real: NumericLu::new(),
            numeric_complex: NumericLu::new(),
            mem: MemBuffer::new(req),
            rhs_real: vec![0.0; dim],
            rhs_complex: vec![c64::new(0.0, 0.0); dim],
        }
    }

    fn factor(&mut self) -> bool {
        let dim = self.col_ptr.len() - 1;
        let sym = SymbolicSparseColMatRef::new_checked(dim, dim, &self.col_ptr, None, &self.row_idx);
        let real = self.symbolic.factorize_numeric_lu(
            &mut self.numeric_real,
            SparseColMatRef::new(sym, &self.values_real),
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        if real.is_err() {
            return false;
        }
        let complex = self.symbolic.factorize_numeric_lu(
            &mut self.numeric_complex,
            SparseColMatRef::new(sym, &self.values_complex),
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        complex.is_ok()
    }

    fn solve_real(&mut self, b: &mut [f64]) {
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric_real);
        self.rhs_real.copy_from_slice(b);
        let x = MatMut::from_column_major_slice_mut(&mut self.rhs_real, b.len(), 1);
        lu.solve_in_place_with_conj(Conj::No, x, Par::Seq, MemStack::new(&mut self.mem));
        b.copy_from_slice(&self.rhs_real);
    }

    fn solve_complex(&mut self, b: &mut [c64]) {
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric_complex);
        self.rhs_complex.copy_from_slice(b);
        let x = MatMut::from_column_major_slice_mut(&mut self.rhs_complex, b.len(), 1);
        lu.solve_in_place_with_conj(Conj::No, x, Par::Seq, MemStack::new(&mut self.mem));
        b.copy_from_slice(&self.rhs_complex);
    }
}
