//! Sensitivities of a run on the reduced formulation: the independent
//! components `z` and their sensitivities `S_z = dz/dp` (nz x np,
//! `nz = (nq - nh) + (nq - nc)`) integrated as one system, the steps of
//! the reduced run itself differentiated.
//!
//! The reduced right-hand side is `z' = Z'(x(z, t, p), x'(x, p))`: the
//! full state `x` expanded from `z` ([`Reduced::expand`]), the DAE's rate
//! `x' = f(t, x, p)` there, and the rate of the independent components
//! read from it (the kept coordinates' rates and the independent
//! velocities' accelerations, or on minimal coordinates the body-frame
//! speeds' rates, [`body_acceleration`]). Its derivative along a column
//! is, by the chain rule,
//!
//! - the expansion's: `S_x = x_z S_z + x_p`, the one direction that keeps
//!   the independent components' `S_z` and satisfies the linearized
//!   constraints, `C_q S_q = -dphi/dp` and `G S_qd = -(dG/dq S_q) qd -
//!   d(G qd - b)/dp` (Haug, *Computer-Aided Kinematics and Dynamics of
//!   Mechanical Systems*, 1989, §6.3: the dependent coordinates' implicit
//!   derivative): two `nq x nq` systems, the constraint rows over the rows
//!   that pick the independent components (a unit row; on minimal
//!   coordinates a speed's row of `R(phi)^T`), factored once per
//!   evaluation for every column;
//! - the DAE's sensitivity right-hand side at `(x, S_x)`
//!   ([`Augmented::evaluate`], the module's parent's method);
//! - the rate of the independent components along it: a selection, or
//!   one dual-number pass of [`body_acceleration`].
//!
//! Nothing is projected: every expanded state and direction satisfies the
//! constraints and their linearization to rounding. The samples are
//! expanded to `[x, S_x]`. A new partition (the reduced run's pivots
//! fell) rewrites `S_z` from `S_x` in it and restarts the method, as the
//! run does.

use num_dual::Dual64;

use super::rhs::Augmented;
use crate::analysis::AnalysisError;
use crate::error::SimError;
use crate::formulation::reduced::lu::SquareLu;
use crate::formulation::reduced::{Reduced, body_acceleration, body_velocity};
use crate::integrator::Rhs;
use crate::model::Model;

/// The augmented system `[z, S_z]` on the reduced formulation.
pub(super) struct ReducedAugmented<M: Model> {
    pub aug: Augmented<M>,
    red: Reduced,
    /// `nq`, `nz` and the parameters `np`.
    nq: usize,
    nz: usize,
    np: usize,
    /// `z` with the run's work states (zero: a sensitivity run integrates
    /// none), as [`Reduced::expand`] takes it.
    zpad: Vec<f64>,
    /// `[x, S_x]` of the last expansion (2 nq (1 + np)) and its rate.
    y: Vec<f64>,
    dy: Vec<f64>,
    /// The systems of the expansion's derivative (row-major): `C_D`
    /// (nh x nh), and `G_D` (nc x nc) or on minimal coordinates `[G;
    /// the speeds' rows]` (nq x nq); their factors; one right-hand side.
    cd: Vec<f64>,
    av: Vec<f64>,
    lu_q: SquareLu,
    lu_v: SquareLu,
    b: Vec<f64>,
    /// Each coordinate's and velocity's place in the partition
    /// ([`ReducedAugmented::route`]).
    q_route: Vec<(bool, usize)>,
    v_route: Vec<(bool, usize)>,
    /// `G` at the pattern at the expanded state; scratch of the same
    /// size; the constraint residuals (nh + nc) of the base problem, of
    /// one node, and a parameter's direct change of them.
    g_q: Vec<f64>,
    g: Vec<f64>,
    base_r: Vec<f64>,
    node_r: Vec<f64>,
    dr: Vec<f64>,
    qdual: Vec<Dual64>,
    gv: Vec<Dual64>,
}

/// The coefficients of the velocities `qd` in the independent speed `j`
/// of `red` at the coordinates `q`, into the row `row` (nq): a unit row
/// on a partition, `R(phi)^T`'s row on minimal coordinates.
fn speed_row(red: &Reduced, q: &[f64], j: usize, row: &mut [f64]) {
    row.fill(0.0);
    if !red.is_minimal() || j % 3 == 2 {
        row[j] = 1.0;
        return;
    }
    let i = j / 3;
    let (s, c) = q[3 * i + 2].sin_cos();
    let (a, b) = if j.is_multiple_of(3) { (c, s) } else { (-s, c) };
    row[3 * i] = a;
    row[3 * i + 1] = b;
}

/// The change of the speed [`body_velocity`] `j` at `(q, qd)` along the
/// coordinates' direction `sq` with the velocities held: its frame turns
/// by `sq_phi`, `d(v_x, v_y) = (v_y, -v_x) sq_phi`.
fn speed_turn(q: &[f64], qd: &[f64], sq: &[f64], j: usize) -> f64 {
    let i = j / 3;
    match j % 3 {
        0 => body_velocity(q, qd, 3 * i + 1) * sq[3 * i + 2],
        1 => -body_velocity(q, qd, 3 * i) * sq[3 * i + 2],
        _ => 0.0,
    }
}

/// The derivative of [`body_acceleration`] `j` at `(q, qd, qdd)` along
/// the direction `(sq, sqd, sqdd)` (nq each), in closed form:
/// `a_x = c xdd + s ydd + w v_y` and `a_y = c ydd - s xdd - w v_x`
/// differentiated (`c, s` of the heading, `w` its rate).
fn acceleration_direction(
    (q, qd, qdd): (&[f64], &[f64], &[f64]),
    (sq, sqd, sqdd): (&[f64], &[f64], &[f64]),
    j: usize,
) -> f64 {
    let i = j / 3;
    if j % 3 == 2 {
        return sqdd[j];
    }
    let (s, c) = q[3 * i + 2].sin_cos();
    let (w, dw, dphi) = (qd[3 * i + 2], sqd[3 * i + 2], sq[3 * i + 2]);
    let (xd, yd, xdd, ydd) = (qd[3 * i], qd[3 * i + 1], qdd[3 * i], qdd[3 * i + 1]);
    let (dxd, dyd, dxdd, dydd) = (sqd[3 * i], sqd[3 * i + 1], sqdd[3 * i], sqdd[3 * i + 1]);
    let (vx, vy) = (c * xd + s * yd, c * yd - s * xd);
    let (dvx, dvy) = (c * dxd + s * dyd + dphi * vy, c * dyd - s * dxd - dphi * vx);
    if j.is_multiple_of(3) {
        dphi * (c * ydd - s * xdd) + c * dxdd + s * dydd + dw * vy + w * dvy
    } else {
        -dphi * (s * ydd + c * xdd) + c * dydd - s * dxdd - dw * vx - w * dvx
    }
}

impl<M: Model> ReducedAugmented<M> {
    /// The reduced formulation at the consistent start `x0` (2 nq) of the
    /// augmented system `aug`.
    ///
    /// # Errors
    /// As [`Reduced::new`] (dependent constraints at `x0`).
    pub fn new(aug: Augmented<M>, x0: &[f64]) -> Result<Self, AnalysisError> {
        let sys = aug.base.dynamics();
        let (nq, nh, nc) = (sys.nq(), sys.info.n_holonomic, sys.info.nc());
        let mut full = vec![0.0; sys.ny()];
        full[..2 * nq].copy_from_slice(x0);
        let red = Reduced::new(sys, 0.0, &full)?;
        let np = aug.stencils.len();
        let nz = 2 * nq - nh - nc;
        let nnz = sys.info.pattern.len();
        let mut this = Self {
            red,
            nq,
            nz,
            np,
            zpad: vec![0.0; sys.ny() - nh - nc],
            y: vec![0.0; 2 * nq * (1 + np)],
            dy: vec![0.0; 2 * nq * (1 + np)],
            cd: vec![0.0; nh * nh],
            av: vec![0.0; nq * nq],
            lu_q: SquareLu::new(nh),
            lu_v: SquareLu::new(nq),
            b: vec![0.0; nq],
            q_route: Vec::new(),
            v_route: Vec::new(),
            g_q: vec![0.0; nnz],
            g: vec![0.0; nnz],
            base_r: vec![0.0; nh + nc],
            node_r: vec![0.0; nh + nc],
            dr: vec![0.0; nh + nc],
            qdual: vec![Dual64::from(0.0); nq],
            gv: vec![Dual64::from(0.0); nnz],
            aug,
        };
        this.route();
        Ok(this)
    }

    /// Length of `[z, S_z]`: `nz (1 + np)`.
    pub fn len(&self) -> usize {
        self.nz * (1 + self.np)
    }

    /// `[z, S_z]` of the full `[x, S_x]` (2 nq (1 + np)) in the current
    /// partition: `z` gathered, each column by the gathering's derivative.
    pub fn gather(&self, y: &[f64], w: &mut [f64]) {
        let (nq, nz) = (self.nq, self.nz);
        let mut full = vec![0.0; self.zpad.len() + self.red_dependent()];
        full[..2 * nq].copy_from_slice(&y[..2 * nq]);
        let mut z = vec![0.0; self.zpad.len()];
        self.red.gather(&full, &mut z);
        w[..nz].copy_from_slice(&z[..nz]);
        let (q, qd) = y[..2 * nq].split_at(nq);
        for j in 0..self.np {
            let s = &y[2 * nq * (1 + j)..2 * nq * (2 + j)];
            self.gather_direction(q, qd, s, &mut w[nz * (1 + j)..nz * (2 + j)]);
        }
    }

    /// `nh + nc`: the components the expansion finds.
    fn red_dependent(&self) -> usize {
        self.red.partition.q_dep.len() + self.red.partition.v_dep.len()
    }

    /// The derivative of [`Reduced::gather`] at `(q, qd)` along the full
    /// direction `s` (2 nq) into `out` (nz).
    fn gather_direction(&self, q: &[f64], qd: &[f64], s: &[f64], out: &mut [f64]) {
        let (nq, p) = (self.nq, &self.red.partition);
        let ni = p.q_ind.len();
        for (o, &j) in out.iter_mut().zip(&p.q_ind) {
            *o = s[j];
        }
        let mut row = vec![0.0; nq];
        for (o, &j) in out[ni..].iter_mut().zip(&p.v_ind) {
            *o = if self.red.is_minimal() {
                speed_row(&self.red, q, j, &mut row);
                row.iter().zip(&s[nq..]).map(|(a, b)| a * b).sum::<f64>() + speed_turn(q, qd, &s[..nq], j)
            } else {
                s[nq + j]
            };
        }
    }

    /// Expands `w = [z, S_z]` at `t` into `[x, S_x]` ([`ReducedAugmented::full`]).
    ///
    /// # Errors
    /// As [`Reduced::expand`]; a singular system of the expansion's
    /// derivative (a singular position) as [`SimError::Formulation`].
    pub fn expand(&mut self, t: f64, w: &[f64]) -> Result<(), AnalysisError> {
        let (nq, nz) = (self.nq, self.nz);
        let n2 = 2 * nq;
        self.zpad[..nz].copy_from_slice(&w[..nz]);
        self.red.expand(self.aug.base.dynamics(), t, &self.zpad)?;
        self.y[..n2].copy_from_slice(&self.red.full()[..n2]);
        self.factor(t)?;
        let touches = self.aug.stencils.iter().any(|st| st.touches.model || st.touches.drives);
        // out of `self` while its directions are written (no allocation)
        let mut y = std::mem::take(&mut self.y);
        let (x, cols) = y.split_at_mut(n2);
        if touches {
            self.aug.base.residual_into(t, x, &mut self.g, &mut self.base_r);
        }
        for j in 0..self.np {
            let st = &self.aug.stencils[j];
            self.dr.fill(0.0);
            st.add_residual(&self.aug.base, t, x, &self.base_r, (&mut self.g, &mut self.node_r), &mut self.dr);
            let sz = &w[nz * (1 + j)..nz * (2 + j)];
            let col = &mut cols[n2 * j..n2 * (j + 1)];
            self.direction(x, sz, col);
        }
        self.y = y;
        Ok(())
    }

    /// Factors the expansion's derivative at the expanded state: `C_D`
    /// (nh x nh, the dependent coordinates' columns of `C_q`) and, on a
    /// partition, `G_D` (nc x nc), on minimal coordinates `[G; the
    /// speeds' rows of R(phi)^T]` (nq x nq); `G` kept in `g_q`.
    fn factor(&mut self, t: f64) -> Result<(), AnalysisError> {
        let (nq, p) = (self.nq, &self.red.partition);
        let (nh, nc) = (p.q_dep.len(), p.v_dep.len());
        let sys = self.aug.base.dynamics();
        let q = &self.y[..nq];
        sys.model.constraint_matrix(q, &mut self.g_q);
        self.cd.fill(0.0);
        self.av.fill(0.0);
        let minimal = self.red.is_minimal();
        let nv = if minimal { nq } else { nc };
        for (&(r, c), &v) in sys.info.pattern.iter().zip(&self.g_q) {
            if r < nh && self.q_route[c].0 {
                self.cd[r * nh + self.q_route[c].1] = v;
            }
            if minimal {
                self.av[r * nq + c] = v;
            } else if self.v_route[c].0 {
                self.av[r * nv + self.v_route[c].1] = v;
            }
        }
        if minimal {
            for (i, &j) in p.v_ind.iter().enumerate() {
                speed_row(&self.red, q, j, &mut self.av[(nc + i) * nq..(nc + i + 1) * nq]);
            }
        }
        let singular = |what: &str| {
            AnalysisError::Sim(SimError::Formulation {
                reason: format!(
                    "at t = {} s the {what} of the reduced formulation's expansion is singular (a singular position); a sensitivity run does not pass one: end it before (--t-end)",
                    crate::names::fmt_value(t)
                )
                .into(),
            })
        };
        if self.lu_q.factor(&self.cd) == 0.0 {
            return Err(singular("dependent coordinates' C_D"));
        }
        if self.lu_v.factor(&self.av[..nv * nv]) == 0.0 {
            return Err(singular("dependent velocities' system"));
        }
        Ok(())
    }

    /// The full direction `col = [S_q, S_qd]` (2 nq) of the independent
    /// components' `sz` (nz) at the expanded state `x`, with the
    /// parameter's direct change of the constraint residuals in `dr`:
    /// `C_D S_qD = -dphi/dp - C_I S_qI`, then `G S_qd = -(dG/dq S_q) qd -
    /// d(G qd - b)/dp` with the independent speeds' `S_z`.
    fn direction(&mut self, x: &[f64], sz: &[f64], col: &mut [f64]) {
        let (nq, p) = (self.nq, &self.red.partition);
        let (nh, nc, ni) = (p.q_dep.len(), p.v_dep.len(), p.q_ind.len());
        let sys = self.aug.base.dynamics();
        let (q, qd) = x.split_at(nq);
        let (sq, sqd) = col.split_at_mut(nq);
        for (&j, &v) in p.q_ind.iter().zip(sz) {
            sq[j] = v;
        }
        for r in 0..nh {
            self.b[r] = -self.dr[r];
        }
        for (&(r, c), &v) in sys.info.pattern.iter().zip(&self.g_q) {
            if r < nh && !self.q_route[c].0 {
                self.b[r] -= v * sq[c];
            }
        }
        self.lu_q.solve(&mut self.b[..nh]);
        for (&j, &v) in p.q_dep.iter().zip(&self.b) {
            sq[j] = v;
        }
        // dG/dq along S_q: one dual pass
        for (v, (&a, &d)) in self.qdual.iter_mut().zip(q.iter().zip(sq.iter())) {
            *v = Dual64::new(a, d);
        }
        sys.model.constraint_matrix(&self.qdual, &mut self.gv);
        for r in 0..nc {
            self.b[r] = -self.dr[nh + r];
        }
        for (&(r, c), v) in sys.info.pattern.iter().zip(&self.gv) {
            self.b[r] -= v.eps * qd[c];
        }
        let sv = &sz[ni..];
        if self.red.is_minimal() {
            // a speed's row turns with its heading: its change along S_q
            for (i, &j) in p.v_ind.iter().enumerate() {
                self.b[nc + i] = sv[i] - speed_turn(q, qd, sq, j);
            }
            self.lu_v.solve(&mut self.b);
            sqd.copy_from_slice(&self.b);
            return;
        }
        for (&j, &v) in p.v_ind.iter().zip(sv) {
            sqd[j] = v;
        }
        for (&(r, c), &v) in sys.info.pattern.iter().zip(&self.g_q) {
            if !self.v_route[c].0 {
                self.b[r] -= v * sqd[c];
            }
        }
        self.lu_v.solve(&mut self.b[..nc]);
        for (&j, &v) in p.v_dep.iter().zip(&self.b) {
            sqd[j] = v;
        }
    }

    /// Where each coordinate sits in the current partition: `(dependent,
    /// index among the dependent or the independent)`, for the
    /// coordinates and the velocities.
    fn route(&mut self) {
        let p = &self.red.partition;
        let place = |dep: &[usize], ind: &[usize], j: usize| match dep.iter().position(|&d| d == j) {
            Some(k) => (true, k),
            None => (false, ind.iter().position(|&i| i == j).unwrap_or(0)),
        };
        self.q_route = (0..self.nq).map(|j| place(&p.q_dep, &p.q_ind, j)).collect();
        self.v_route = (0..self.nq).map(|j| place(&p.v_dep, &p.v_ind, j)).collect();
        let (nh, nc) = (p.q_dep.len(), p.v_dep.len());
        let nv = if self.red.is_minimal() { self.nq } else { nc };
        self.lu_q = SquareLu::new(nh);
        self.lu_v = SquareLu::new(nv);
    }

    /// `[x, S_x]` of the last [`ReducedAugmented::expand`] (2 nq (1 + np)).
    pub fn full(&self) -> &[f64] {
        &self.y
    }

    /// `[z, S_z]`'s rate at `t`.
    fn evaluate(&mut self, t: f64, w: &[f64], dw: &mut [f64]) -> Result<(), AnalysisError> {
        self.expand(t, w)?;
        self.aug.evaluate(t, &self.y, &mut self.dy)?;
        let (nq, nz) = (self.nq, self.nz);
        let n2 = 2 * nq;
        let p = &self.red.partition;
        let ni = p.q_ind.len();
        let minimal = self.red.is_minimal();
        let (x, cols) = self.y.split_at(n2);
        let (dx, dcols) = self.dy.split_at(n2);
        let (q, qd) = x.split_at(nq);
        for col in 0..=self.np {
            let out = &mut dw[nz * col..nz * (col + 1)];
            let (s, ds) =
                if col == 0 { (x, dx) } else { (&cols[n2 * (col - 1)..n2 * col], &dcols[n2 * (col - 1)..n2 * col]) };
            for (o, &j) in out.iter_mut().zip(&p.q_ind) {
                *o = ds[j];
            }
            let out = &mut out[ni..];
            if !minimal {
                for (o, &j) in out.iter_mut().zip(&p.v_ind) {
                    *o = ds[nq + j];
                }
            } else if col == 0 {
                for (o, &j) in out.iter_mut().zip(&p.v_ind) {
                    *o = body_acceleration(q, qd, &dx[nq..], j);
                }
            } else {
                let (sq, sqd, sqdd) = (&s[..nq], &s[nq..], &ds[nq..]);
                for (o, &j) in out.iter_mut().zip(&p.v_ind) {
                    *o = acceleration_direction((q, qd, &dx[nq..]), (sq, sqd, sqdd), j);
                }
            }
        }
        Ok(())
    }

    /// After the accepted `w` at `t` and its samples: a new partition
    /// where the reduced run's pivots fell ([`Reduced::repartition`]), `w`
    /// rewritten in it. Returns whether it did (the method restarts).
    ///
    /// # Errors
    /// As [`Reduced::repartition`] and [`ReducedAugmented::expand`].
    pub fn repartition(&mut self, t: f64, w: &mut [f64]) -> Result<bool, AnalysisError> {
        if self.red.is_minimal() {
            return Ok(false);
        }
        let nz = self.nz;
        self.zpad[..nz].copy_from_slice(&w[..nz]);
        self.red.accept(self.aug.base.dynamics_mut(), t, &self.zpad, false)?;
        if !self.red.degraded() {
            return Ok(false);
        }
        // S_x in the partition S_z is written in, before it changes
        self.expand(t, w)?;
        self.red.repartition(self.aug.base.dynamics(), t, &mut self.zpad)?;
        self.route();
        let y = self.y.clone();
        self.gather(&y, w);
        Ok(true)
    }

    /// Times the partition was re-chosen.
    pub fn repartitions(&self) -> u64 {
        self.red.repartitions
    }

    /// The name of component `k` of `[z, S_z]`, with the parameters'
    /// names `params`.
    pub fn component(&self, k: usize, params: &[String]) -> String {
        let sys = self.aug.base.dynamics();
        let name = |k: usize| self.red.state_name(sys, k);
        if k < self.nz {
            format!("the state's `{}`", name(k))
        } else {
            format!("the sensitivity d{}/d{}", name((k - self.nz) % self.nz), params[(k - self.nz) / self.nz])
        }
    }
}

impl<M: Model> Rhs for ReducedAugmented<M> {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.evaluate(t, y, dy).map_err(|e| self.aug.keep_failure(e))
    }
}
