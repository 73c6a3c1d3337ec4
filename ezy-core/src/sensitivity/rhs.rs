//! The augmented right-hand side `[x, S]' = [f(t, x), (df/dx) S + df/dp]`
//! on the run's own right-hand side and KKT solver, and the projection of
//! `S` onto the constraints' tangent space.

use num_dual::Dual64;

use super::stencil::Stencil;
use crate::analysis::{Analysis, AnalysisError};
use crate::error::SimError;
use crate::formulation::projection::Projector;
use crate::integrator::Rhs;
use crate::model::Model;

/// Scratch of one evaluation, sized once.
struct Scratch {
    /// `[q, qd, W..]` and its rate (the run's state with its work states).
    y: Vec<f64>,
    dy: Vec<f64>,
    lambda: Vec<f64>,
    qdual: Vec<Dual64>,
    qddual: Vec<Dual64>,
    gv: Vec<Dual64>,
    gm: Vec<Dual64>,
    /// One evaluation of `G` (at the pattern) and `gamma` of a problem
    /// around the parameter's value.
    gv_f64: Vec<f64>,
    gamma_f64: Vec<f64>,
    /// The parameters' direct change of the constraint residuals (nh + nc).
    dr: Vec<f64>,
    /// The constraint residuals of the base problem and of one node at
    /// the state projected (nh + nc each).
    base_r: Vec<f64>,
    node_r: Vec<f64>,
    /// `dG` at the pattern, `dgamma`, `dF`, `dM` of one parameter.
    dg: Vec<f64>,
    dgamma: Vec<f64>,
    df: Vec<f64>,
    dm: Vec<f64>,
    /// The input power at the state evaluated, and its derivative along
    /// the column being evaluated \[W\].
    p0: f64,
    dp: f64,
    /// `dF/dq`, `dF/dqd` (nq x nq each, row-major) of the effects that
    /// are not actuators, then of the actuators alone, at the state
    /// evaluated; the actuators' force there (nq).
    jq: Vec<f64>,
    jqd: Vec<f64>,
    aq: Vec<f64>,
    aqd: Vec<f64>,
    fa: Vec<f64>,
    /// The actuators with their waveforms' values at the state's time
    /// (one per actuator, refilled at each evaluation without allocating).
    acts: Vec<(usize, crate::effects::kind::Waveforms)>,
    /// Whether each effect's force depends on the state (not
    /// [`crate::effects::ForceLaw::time_only`]): the effects whose
    /// Jacobian is taken.
    stateful: Vec<bool>,
    /// The coordinates the stateful effects' forces couple (the union of
    /// their [`crate::effects::Effect::coords`]; all of them where a law
    /// is the user's own): the rows and columns of `dF/dq` and `dF/dqd`
    /// that can be nonzero.
    coupled: Vec<usize>,
    power: Vec<f64>,
    /// The KKT right-hand side `[f; -gamma]` of one parameter and its solution.
    f: Vec<f64>,
    gamma: Vec<f64>,
    dqdd: Vec<f64>,
    dlambda: Vec<f64>,
}

/// The state, its sensitivities and what they are evaluated with.
pub(super) struct Augmented<M: Model> {
    pub base: Analysis<M>,
    pub stencils: Vec<Stencil<M>>,
    /// The first failure that is not the right-hand side's own (kept to
    /// report it as it is, not as a `SimError`).
    pub failed: Option<AnalysisError>,
    pub evaluations: u64,
    pub stop: Option<fn() -> bool>,
    ws: Scratch,
    /// The effects whose power is the input power `P_in` integrated as
    /// the energy `E` after `S`, with its derivative along each column
    /// (`[x, S, E, dE/dp]`; empty: no energy).
    pub actuators: Vec<usize>,
    /// Whether the drives' power (`-lambda_row u'(t)`, the constraint
    /// torque times the prescribed rate) joins the input power `P_in`:
    /// a drive is an actuator too.
    pub drive_power: bool,
    /// Whether each actuator's power is integrated as a state of its own
    /// after `[E, dE/dp]` (the effects of `actuators`, then the drives):
    /// the input ledger.
    pub ledger: bool,
    /// The pattern of `G` (its (row, column) entries).
    pattern: Vec<(usize, usize)>,
}

impl<M: Model> Augmented<M> {
    /// The augmented right-hand side of `base` with the parameters'
    /// `stencils`.
    pub fn new(base: Analysis<M>, stencils: Vec<Stencil<M>>, stop: Option<fn() -> bool>) -> Self {
        let sys = base.dynamics();
        let (nq, nc, nnz) = (sys.nq(), sys.info.nc(), sys.info.pattern.len());
        let z = |n: usize| vec![0.0; n];
        let d = |n: usize| vec![Dual64::from(0.0); n];
        let stateful: Vec<bool> = sys.effects.iter().map(|e| !e.law.as_force_law().time_only()).collect();
        let ws = Scratch {
            y: z(sys.ny()),
            dy: z(sys.ny()),
            lambda: z(nc),
            qdual: d(nq),
            qddual: d(nq),
            gv: d(nnz),
            gm: d(nc),
            gv_f64: z(nnz),
            gamma_f64: z(nc),
            dr: z(sys.info.n_holonomic + nc),
            base_r: z(sys.info.n_holonomic + nc),
            node_r: z(sys.info.n_holonomic + nc),
            dg: z(nnz),
            dgamma: z(nc),
            df: z(nq),
            dm: z(nq),
            p0: 0.0,
            dp: 0.0,
            jq: z(nq * nq),
            jqd: z(nq * nq),
            aq: z(nq * nq),
            aqd: z(nq * nq),
            fa: z(nq),
            acts: Vec::new(),
            stateful: stateful.clone(),
            coupled: if sys.effects.iter().any(|e| matches!(e.law, crate::effects::law::Law::User(_))) {
                (0..nq).collect()
            } else {
                let effects = sys.effects.iter().zip(&stateful).filter(|(_, s)| **s);
                let mut c: Vec<usize> = effects.flat_map(|(e, _)| e.coords()).collect();
                c.sort_unstable();
                c.dedup();
                c
            },
            power: z(sys.effects.len()),
            f: z(nq),
            gamma: z(nc),
            dqdd: z(nq),
            dlambda: z(nc),
        };
        let pattern = sys.info.pattern.clone();
        Self {
            base,
            stencils,
            failed: None,
            evaluations: 0,
            stop,
            ws,
            actuators: Vec::new(),
            drive_power: false,
            ledger: false,
            pattern,
        }
    }

    /// Number of coordinates nq.
    pub fn nq(&self) -> usize {
        self.base.nq()
    }

    /// The drives whose power counts (all of them with
    /// [`Augmented::drive_power`], else none).
    fn powered_drives(&self) -> usize {
        if self.drive_power { self.base.dynamics().drives.len() } else { 0 }
    }

    /// Whether an input energy `E` is integrated: some actuator's power
    /// counts.
    fn powered(&self) -> bool {
        !self.actuators.is_empty() || self.powered_drives() > 0
    }

    /// The states after `[x, S]`: `E` and `dE/dp` where powered, then one
    /// per actuator and drive with [`Augmented::ledger`].
    pub fn energy_states(&self) -> usize {
        if !self.powered() {
            return 0;
        }
        1 + self.stencils.len() + if self.ledger { self.actuators.len() + self.powered_drives() } else { 0 }
    }

    /// `d(drive power)/d(column j)` of every powered drive at `t`: the
    /// constraint torque's change `-dlambda_row u'` along the column and,
    /// where the parameter moves the prescribed angle, `-lambda_row du'/dp`.
    fn drive_power_direction(&self, j: usize, t: f64) -> f64 {
        let drives = &self.base.dynamics().drives;
        let st = &self.stencils[j];
        (0..self.powered_drives())
            .map(|k| {
                let d = &drives[k];
                let rate = d.angle.eval3(t)[1];
                -self.ws.dlambda[d.row] * rate - self.ws.lambda[d.row] * st.drive_rate(t, &self.base, k)
            })
            .sum()
    }

    /// `dG` (at the pattern) into `ws.dg` and `dgamma` into `ws.dgamma`
    /// along the direction `(dq, dqd)`: one forward-mode pass of the
    /// generated code.
    fn directional_terms(&mut self, q: &[f64], qd: &[f64], dq: &[f64], dqd: &[f64]) {
        let ws = &mut self.ws;
        for (k, v) in ws.qdual.iter_mut().enumerate() {
            *v = Dual64::new(q[k], dq[k]);
        }
        for (k, v) in ws.qddual.iter_mut().enumerate() {
            *v = Dual64::new(qd[k], dqd[k]);
        }
        self.base.dynamics().model.constraint_terms(&ws.qdual, &ws.qddual, &mut ws.gv, &mut ws.gm);
        ws.dg.iter_mut().zip(&ws.gv).for_each(|(o, v)| *o = v.eps);
        ws.dgamma.iter_mut().zip(&ws.gm).for_each(|(o, v)| *o = v.eps);
    }

    /// The applied forces' Jacobian `dF/dx` at `(t, x)`, of the effects
    /// that are not actuators (`ws.jq`, `ws.jqd`) and of the actuators
    /// (`ws.aq`, `ws.aqd`), and the actuators' force (`ws.fa`): each
    /// law's exact Jacobian
    /// ([`crate::effects::ForceLaw::jacobian`]), central differences of
    /// its force alone for a law of the user's own without one
    /// ([`Analysis::force_blocks`]); none of a law whose force depends on
    /// time alone ([`crate::effects::ForceLaw::time_only`]).
    fn force_jacobians(&mut self, t: f64, x: &[f64]) -> Result<(), AnalysisError> {
        let Self { base, ws, actuators, .. } = self;
        if ws.coupled.is_empty() && actuators.is_empty() {
            return Ok(());
        }
        for b in [&mut ws.jq, &mut ws.jqd, &mut ws.aq, &mut ws.aqd] {
            b.fill(0.0);
        }
        let (acts, stateful): (&[usize], &[bool]) = (actuators, &ws.stateful);
        base.force_blocks(t, x, &|k| stateful[k] && !acts.contains(&k), &mut ws.jq, &mut ws.jqd)?;
        ws.fa.fill(0.0);
        if !acts.is_empty() {
            base.force_blocks(t, x, &|k| stateful[k] && acts.contains(&k), &mut ws.aq, &mut ws.aqd)?;
            // the base's waveforms at t (its right-hand side just took them)
            ws.acts.clear();
            ws.acts.extend(acts.iter().map(|&k| (k, base.dynamics().waves()[k])));
            base.forces_of(t, x, &ws.acts, &mut ws.fa)?;
        }
        Ok(())
    }

    /// `dF/dx s` into `ws.df` (nq) along the state direction `s` (2 nq)
    /// from the Jacobian [`Augmented::force_jacobians`] took at the state
    /// `x`, and the actuators' power's derivative `d(F_a . qd)/dx s =
    /// (dF_a/dx s) . qd + F_a . s_qd` into `ws.dp` (the power of a force
    /// law is its generalized force times the velocities).
    fn force_direction(&mut self, x: &[f64], s: &[f64]) {
        let nq = self.nq();
        let ws = &mut self.ws;
        ws.df.fill(0.0);
        let (sq, sqd, qd) = (&s[..nq], &s[nq..2 * nq], &x[nq..2 * nq]);
        let mut dp = ws.fa.iter().zip(sqd).map(|(f, v)| f * v).sum::<f64>();
        if self.base.dynamics().effects.is_empty() {
            ws.dp = dp;
            return;
        }
        for &i in &ws.coupled {
            let (mut own, mut act) = (0.0, 0.0);
            for &j in &ws.coupled {
                let k = i * nq + j;
                own += ws.jq[k] * sq[j] + ws.jqd[k] * sqd[j];
                act += ws.aq[k] * sq[j] + ws.aqd[k] * sqd[j];
            }
            ws.df[i] = own + act;
            dp += act * qd[i];
        }
        ws.dp = dp;
    }

    /// `dy = [f(t, x), (df/dx) S + df/dp]` for `y = [x, S]`.
    pub fn evaluate(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), AnalysisError> {
        if let Some(stop) = self.stop
            && stop()
        {
            return Err(AnalysisError::Stopped);
        }
        self.evaluations += 1;
        let nq = self.nq();
        let n2 = 2 * nq;
        let (x, s) = y.split_at(n2);
        let s = &s[..self.stencils.len() * n2];
        let (q, qd) = x.split_at(nq);
        // the state's rate by the run's own right-hand side (work states 0)
        self.ws.y[..n2].copy_from_slice(x);
        {
            let sys = self.base.dynamics_mut();
            sys.rhs(t, &self.ws.y, &mut self.ws.dy)?;
            self.ws.lambda.copy_from_slice(sys.lambda());
        }
        let lambda = std::mem::take(&mut self.ws.lambda);
        self.base.note_grip(t, &lambda);
        self.ws.lambda = lambda;
        dy[..n2].copy_from_slice(&self.ws.dy[..n2]);
        self.ws.p0 = self.actuators.iter().map(|&k| self.ws.dy[n2 + k]).sum();
        let np = self.stencils.len();
        let energy = n2 * (1 + np);
        let (n_eff, nd) = (self.base.dynamics().effects.len(), self.powered_drives());
        let drive_power: f64 = (0..nd).map(|d| self.ws.dy[n2 + n_eff + d]).sum();
        let powered = self.powered();
        if powered {
            dy[energy] = self.ws.p0 + drive_power;
        }
        if powered && self.ledger {
            let na = self.actuators.len();
            for (a, &k) in self.actuators.iter().enumerate() {
                dy[energy + 1 + np + a] = self.ws.dy[n2 + k];
            }
            for d in 0..nd {
                dy[energy + 1 + np + na + d] = self.ws.dy[n2 + n_eff + d];
            }
        }
        if !self.stencils.is_empty() {
            self.force_jacobians(t, x)?;
        }
        for j in 0..self.stencils.len() {
            let sj = &s[j * n2..(j + 1) * n2];
            self.directional_terms(q, qd, &sj[..nq], &sj[nq..]);
            self.force_direction(x, sj);
            self.ws.dm.fill(0.0);
            self.parametric(j, t, q, qd)?;
            // [M G^T; G 0] [dqdd; dlambda] = [dF - dM qdd - dG^T lambda; -(dgamma + dG qdd)]
            let ws = &mut self.ws;
            let qdd = &ws.dy[nq..n2];
            for (((f, df), dm), a) in ws.f.iter_mut().zip(&ws.df).zip(&ws.dm).zip(qdd) {
                *f = df - dm * a;
            }
            ws.gamma.copy_from_slice(&ws.dgamma);
            // the buffers as local slices: through `ws` each entry's
            // store made the next entry reload every buffer's address
            // (29 instructions an entry, a quarter of the evaluation's
            // own work on `drive`)
            let (f, gamma, lambda) = (&mut ws.f[..], &mut ws.gamma[..], &ws.lambda[..]);
            for (&(r, c), v) in self.pattern.iter().zip(&ws.dg) {
                f[c] -= v * lambda[r];
                gamma[r] += v * qdd[c];
            }
            self.base.dynamics_mut().solve_kkt_again(t, &ws.f, &ws.gamma, &mut ws.dqdd, &mut ws.dlambda)?;
            let dj = &mut dy[n2 + j * n2..n2 + (j + 1) * n2];
            dj[..nq].copy_from_slice(&sj[nq..]);
            dj[nq..].copy_from_slice(&self.ws.dqdd);
            if powered {
                dy[energy + 1 + j] = self.ws.dp + self.drive_power_direction(j, t);
            }
        }
        Ok(())
    }

    /// The input power of the actuators at `(t, x)` \[W\] (0 without).
    ///
    /// # Errors
    /// As [`crate::formulation::dae::Dynamics::applied_forces`].
    pub fn input_power(&mut self, t: f64, x: &[f64]) -> Result<f64, SimError> {
        if !self.powered() {
            return Ok(0.0);
        }
        let n2 = x.len();
        if self.powered_drives() == 0 {
            self.base.dynamics_mut().applied_forces(t, &x[..n2 / 2], &x[n2 / 2..], &mut self.ws.power)?;
            return Ok(self.actuators.iter().map(|&k| self.ws.power[k]).sum());
        }
        // a drive's power needs its constraint torque: the whole right-hand side
        self.ws.y[..n2].copy_from_slice(x);
        self.base.dynamics_mut().rhs(t, &self.ws.y, &mut self.ws.dy)?;
        let n_eff = self.base.dynamics().effects.len();
        let drives: f64 = (0..self.powered_drives()).map(|d| self.ws.dy[n2 + n_eff + d]).sum();
        Ok(self.actuators.iter().map(|&k| self.ws.dy[n2 + k]).sum::<f64>() + drives)
    }

    /// Adds parameter `j`'s direct terms (`dF/dp`, `dG/dp`, `dgamma/dp`,
    /// `dM/dp`, the drives') into the scratch at `(t, q, qd)`.
    fn parametric(&mut self, j: usize, t: f64, q: &[f64], qd: &[f64]) -> Result<(), AnalysisError> {
        let st = &self.stencils[j];
        let (forces, model, drives) = (st.touches.effects, st.touches.model, st.touches.drives);
        if !(forces || model || drives) {
            return Ok(());
        }
        let ws = &mut self.ws;
        let st = &mut self.stencils[j];
        if forces {
            let base = (&self.base.dynamics().effects[..], self.base.dynamics().waves());
            ws.dp += st.add_forces(t, (q, qd), base, &mut ws.df, &self.actuators)?;
        }
        if model {
            let scratch = (&mut ws.gv_f64[..], &mut ws.gamma_f64[..]);
            st.add_terms(self.base.dynamics(), q, qd, scratch, &mut ws.dg, &mut ws.dgamma, &mut ws.dm);
        }
        st.add_drives(t, &self.base, &mut ws.dgamma);
        Ok(())
    }

    /// Differentiates the projection `projector` last made, to the state
    /// `(t, x)`, along the sensitivities `s` (np blocks of 2 nq):
    /// positions first, then velocities, each step's curvature
    /// (`W^-1 (dG^T y + dW step)`) taken off and the rest projected onto
    /// the tangent space of the constraint manifold
    /// ([`Projector::project_tangent`], the module's docs).
    ///
    /// # Errors
    /// [`AnalysisError::Sim`] when a normal system is singular (a singular
    /// position).
    pub fn project(
        &mut self,
        projector: &mut Projector<M>,
        t: f64,
        x: &[f64],
        s: &mut [f64],
    ) -> Result<(), AnalysisError> {
        let nq = self.nq();
        let n2 = 2 * nq;
        let (q, qd) = x.split_at(nq);
        let touches = self.stencils.iter().any(|st| st.touches.model || st.touches.drives);
        let Scratch { dr, base_r, node_r, qdual, gv, gv_f64, gamma_f64, dg: dg_p, dgamma, dm, .. } = &mut self.ws;
        if touches {
            self.base.residual_into(t, x, gv_f64, base_r);
        }
        let sys = self.base.dynamics();
        let corrected = projector.corrected();
        for (j, st) in self.stencils.iter().enumerate() {
            let (sq, sqd) = s[j * n2..(j + 1) * n2].split_at_mut(nq);
            dr.fill(0.0);
            st.add_residual(&self.base, t, x, base_r, (gv_f64, node_r), dr);
            // the direct dG/dp and dM/dp, for the projection's curvature
            // (none where the projection made no step)
            let direct: (&[f64], &[f64]) = if st.touches.model && corrected {
                for b in [&mut *dg_p, &mut *dgamma, &mut *dm] {
                    b.fill(0.0);
                }
                st.add_terms(sys, q, qd, (&mut gv_f64[..], &mut gamma_f64[..]), dg_p, dgamma, dm);
                (dg_p, dm)
            } else {
                (&[], &[])
            };
            let dg = |sq: &[f64], out: &mut [f64]| {
                for (k, v) in qdual.iter_mut().enumerate() {
                    *v = Dual64::new(q[k], sq[k]);
                }
                sys.model.constraint_matrix(qdual, gv);
                out.iter_mut().zip(gv.iter()).for_each(|(o, v)| *o = v.eps);
            };
            projector.project_tangent(&sys.model, t, (q, qd), sq, sqd, (dr, direct), dg)?;
        }
        Ok(())
    }
}

impl<M: Model> Augmented<M> {
    /// An evaluation's failure as the integrator's error: a
    /// [`SimError`] as it is, any other kept in [`Augmented::failed`] to
    /// be reported as it is.
    pub fn keep_failure(&mut self, e: AnalysisError) -> SimError {
        match e {
            AnalysisError::Sim(e) => e,
            e => {
                let reason = e.to_string();
                self.failed = Some(e);
                SimError::Formulation { reason: reason.into() }
            }
        }
    }
}

impl<M: Model> Rhs for Augmented<M> {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.evaluate(t, y, dy).map_err(|e| self.keep_failure(e))
    }
}
