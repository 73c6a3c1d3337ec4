//! A parameter's direct effect on the right-hand side, `df/dp`: the
//! problems built at `p +- h` (or `p + h`, `p + 2h`) and the weights of
//! their difference.

use super::Parameter;
use crate::analysis::{Analysis, AnalysisError};
use crate::drive::Drive;
use crate::effects::Effect;
use crate::effects::kind::Waveforms;
use crate::formulation::dae::Dynamics;
use crate::model::Model;
use crate::problem::Problem;

/// How a parameter's direct effect `df/dp` on the right-hand side (and
/// its initial state's derivative) was obtained.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Derivative {
    /// The parameter changes only the initial state (an initial value):
    /// `df/dp = 0`.
    InitialOnly,
    /// Central difference of the problems at `p +- h`, their waveforms
    /// linearized from the base's
    /// ([`crate::effects::Waveform::eval3_toward`]).
    Central {
        /// The step `h`.
        h: f64,
    },
    /// One-sided difference of second order on `p`, `p + h`, `p + 2h`
    /// (the problem at `p - h` could not be built: a damping of 0).
    OneSided {
        /// The step `h`.
        h: f64,
    },
}

impl Derivative {
    /// A phrase for the output: `"central difference of the right-hand
    /// side, h = 6.1e-6"`.
    pub fn describe(&self) -> String {
        match self {
            Self::InitialOnly => "initial state only (df/dp = 0)".into(),
            Self::Central { h } => {
                format!(
                    "central difference of the right-hand side, waveforms and spring-dampers linearized exactly, h = {h:.2e}"
                )
            }
            Self::OneSided { h } => format!(
                "one-sided difference (p, p+h, p+2h) of the right-hand side, waveforms and spring-dampers linearized exactly, h = {h:.2e}"
            ),
        }
    }
}

/// What of the right-hand side a parameter changes.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Touches {
    /// The model's parameters (masses, constraints, geometry).
    pub model: bool,
    /// The effects' laws.
    pub effects: bool,
    /// The drives' angles.
    pub drives: bool,
}

/// The problems around a parameter's value and the weights of their
/// difference: `df/dp = sum_k w_k f_k + w_base f_base`.
pub(super) struct Stencil<M: Model> {
    pub nodes: Vec<(f64, Analysis<M>)>,
    pub base_weight: f64,
    pub touches: Touches,
    pub derivative: Derivative,
    /// `dx0/dp` (2 nq).
    pub x0: Vec<f64>,
    /// The effects (indices) some problem of the stencil has otherwise
    /// than the base: the only ones whose forces enter `dF/dp`.
    pub changed: Vec<usize>,
    /// For each of [`Stencil::changed`], whether its law is differentiated
    /// toward each node's ([`crate::effects::Law::apply_toward`]: a
    /// spring-damper, exact in its geometry and gains) rather than its
    /// forces differenced.
    pub linear: Vec<bool>,
    /// Scratch: one effect's generalized force (nq; empty where
    /// `changed` is).
    pub f: Vec<f64>,
}

/// A problem at one value: its analysis and consistent initial state.
type Node<M> = (Analysis<M>, Vec<f64>);

fn node<M: Model>(param: &Parameter<M>, v: f64) -> Result<Node<M>, AnalysisError> {
    let built = param.problem(v).and_then(Problem::into_system);
    let (sys, y0, _) = built.map_err(|e| AnalysisError::Request {
        reason: format!(
            "parameter `{}` = {}: the problem at {} = {} (a step from it, for the difference of the right-hand side) cannot be built: {e}",
            param.name,
            crate::names::fmt_value(param.value),
            param.name,
            crate::names::fmt_value(v)
        ),
    })?;
    Ok((Analysis::new(sys), y0))
}

impl<M: Model> Stencil<M> {
    /// The stencil of `param` around the problem `base` (its analysis)
    /// with consistent initial state `x0` (2 nq).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] when the problems at `p +- h` differ
    /// from the base in size or in their lists of effects and drives;
    /// [`AnalysisError::Sim`] when neither `p +- h` nor `p + h, p + 2h`
    /// can be built (with the error at `p + h`).
    pub fn new(param: &Parameter<M>, base: &Analysis<M>, x0: &[f64]) -> Result<Self, AnalysisError> {
        let p = param.value;
        let h = f64::EPSILON.cbrt() * p.abs().max(1.0);
        let plus = node(param, p + h)?;
        let (derivative, base_weight, nodes) = match node(param, p - h) {
            Ok(minus) => (Derivative::Central { h }, 0.0, vec![(0.5 / h, plus), (-0.5 / h, minus)]),
            Err(_) => {
                let plus2 = node(param, p + 2.0 * h)?;
                (Derivative::OneSided { h }, -1.5 / h, vec![(2.0 / h, plus), (-0.5 / h, plus2)])
            }
        };
        let n2 = x0.len();
        let b = base.dynamics();
        let mut touches = Touches::default();
        let mut changed = Vec::new();
        let mut dx0 = x0.iter().map(|v| base_weight * v).collect::<Vec<_>>();
        for (w, (an, y0)) in &nodes {
            let d = an.dynamics();
            let same_size = d.info.nq() == b.info.nq()
                && d.info.nc() == b.info.nc()
                && d.info.n_holonomic == b.info.n_holonomic
                && d.info.pattern == b.info.pattern
                && d.effects.len() == b.effects.len()
                && d.drives.len() == b.drives.len();
            if !same_size {
                return Err(AnalysisError::Request {
                    reason: format!(
                        "parameter `{}` changes the problem's size or its lists of effects and drives (at {}): a sensitivity is taken at a fixed size",
                        param.name,
                        crate::names::fmt_value(p + h)
                    ),
                });
            }
            let np = b.info.params.len();
            touches.model |= (0..np).any(|k| d.model.param(k).to_bits() != b.model.param(k).to_bits());
            for (k, (e, be)) in d.effects.iter().zip(&b.effects).enumerate() {
                if e != be && !changed.contains(&k) {
                    changed.push(k);
                }
            }
            touches.drives |= d.drives != b.drives;
            for (o, v) in dx0.iter_mut().zip(&y0[..n2]) {
                *o += w * v;
            }
        }
        touches.effects = !changed.is_empty();
        let changes_rhs = touches.model || touches.effects || touches.drives;
        let (nodes, derivative) = if changes_rhs { (nodes, derivative) } else { (Vec::new(), Derivative::InitialOnly) };
        let nodes: Vec<(f64, Analysis<M>)> = nodes.into_iter().map(|(w, (an, _))| (w, an)).collect();
        changed.sort_unstable();
        let linear = changed
            .iter()
            .map(|&k| {
                let e = &b.effects[k];
                nodes.iter().all(|(_, an)| {
                    let n = &an.dynamics().effects[k];
                    e.on && n.on && e.law.moves_toward(&n.law)
                })
            })
            .collect();
        Ok(Self { nodes, base_weight, touches, derivative, x0: dx0, changed, linear, f: vec![0.0; b.info.nq()] })
    }

    /// Adds `dF/dp` at `(t, q, qd)` into `out` (nq) and returns `dP/dp`
    /// of the input power of the effects `actuators`; `base` the base
    /// problem's effects and their waveforms' values at `t`. Only the
    /// effects the parameter changes ([`Stencil::changed`]) are evaluated:
    /// a force depends on its effect alone (its law and the numbers baked
    /// into it, [`crate::effects::law::apply_effects`]), so an effect that
    /// is the same in every problem of the stencil cancels exactly (the
    /// weights sum to 0). Each node's forces are taken with its waveforms
    /// linearized from the base's
    /// ([`crate::effects::Law::waveforms_toward`]): a harmonic's numbers
    /// enter exactly, whatever `t`. A spring-damper's law is not
    /// differenced but differentiated toward each node's
    /// ([`crate::effects::Law::apply_toward`]: `dF/dp = sum_k w_k dF/ds_k`,
    /// exact in its ends' geometry and its gains, the numbers' own
    /// difference `sum_k w_k theta_k` exact where they are linear in `p`):
    /// a difference of its forces erred by its stiffness times `h^2`
    /// times the geometry's third derivative, across its line too, where
    /// a stiff coupler does not take it up (8e-7 of `ezy sensitivity
    /// four-bar-stiff --wrt a` over 10 ms). The rest of the laws'
    /// dependence on `p` (a gain, a drag's point: smooth, most of it
    /// linear, none of it stiff) is the difference's, at fixed waveforms.
    /// Allocates nothing.
    ///
    /// # Errors
    /// As [`crate::formulation::dae::Dynamics::applied_forces`].
    pub fn add_forces(
        &mut self,
        t: f64,
        (q, qd): (&[f64], &[f64]),
        (effects, waves): (&[Effect], &[Waveforms]),
        out: &mut [f64],
        actuators: &[usize],
    ) -> Result<f64, crate::error::SimError> {
        let mut dp = 0.0;
        let mut power = [0.0];
        let base = (self.base_weight != 0.0).then_some((self.base_weight, effects, waves));
        let Self { nodes, changed, linear, f, .. } = self;
        let nodes = nodes.iter().map(|(w, an)| (*w, &an.dynamics().effects[..], None));
        for (w, own, base_waves) in nodes.chain(base.map(|(w, e, v)| (w, e, Some(v)))) {
            for (&k, &linear) in changed.iter().zip(linear.iter()) {
                // a law differentiated toward the nodes' has none of its
                // own in a one-sided stencil (its derivative toward itself)
                if linear && base_waves.is_some() {
                    continue;
                }
                let e = &own[k];
                // the base's waveforms as they are, a node's linearized from them
                let wave = base_waves.map_or_else(|| effects[k].law.waveforms_toward(&e.law, t), |v| v[k]);
                f.fill(0.0);
                if linear {
                    power[0] = effects[k].law.apply_toward(&e.law, (&waves[k], &wave), q, qd, f);
                } else {
                    crate::effects::law::apply_effects(
                        std::slice::from_ref(e),
                        std::slice::from_ref(&wave),
                        t,
                        q,
                        qd,
                        f,
                        &mut power,
                    )?;
                }
                out.iter_mut().zip(f.iter()).for_each(|(o, v)| *o += w * v);
                if actuators.contains(&k) {
                    dp += w * power[0];
                }
            }
        }
        Ok(dp)
    }

    /// Adds the model's direct terms at `(q, qd)`: `dG/dp` (at the
    /// pattern) into `values`, `dgamma/dp` into `gamma` (nc), `dM/dp`
    /// into `mass` (nq); `base` the base problem's right-hand side,
    /// `scratch` one `G` and one `gamma` to evaluate into.
    #[expect(
        clippy::too_many_arguments,
        reason = "a state and the scratch of an evaluation as flat borrowed slices, no struct built per call"
    )]
    pub fn add_terms(
        &self,
        base: &Dynamics<M>,
        q: &[f64],
        qd: &[f64],
        (gv, gm): (&mut [f64], &mut [f64]),
        values: &mut [f64],
        gamma: &mut [f64],
        mass: &mut [f64],
    ) {
        if !self.touches.model {
            return;
        }
        let axpy = |out: &mut [f64], w: f64, v: &[f64]| out.iter_mut().zip(v).for_each(|(o, v)| *o += w * v);
        let nodes = self.nodes.iter().map(|(w, an)| (*w, an.dynamics()));
        // the base's own terms enter a one-sided difference only
        let base = (self.base_weight != 0.0).then_some((self.base_weight, base));
        for (w, d) in nodes.chain(base) {
            d.model.constraint_terms(q, qd, gv, gm);
            axpy(values, w, gv);
            axpy(gamma, w, gm);
            axpy(mass, w, &d.mass);
        }
    }

    /// Adds the drives' direct term in `gamma` at `t`: `-d(u''(t))/dp` on
    /// each drive's row.
    pub fn add_drives(&self, t: f64, base: &Analysis<M>, gamma: &mut [f64]) {
        if !self.touches.drives {
            return;
        }
        for (k, d) in base.dynamics().drives.iter().enumerate() {
            gamma[d.row] -= self.base_weight * d.angle.eval3(t)[2];
            for (w, an) in &self.nodes {
                gamma[d.row] -= *w * toward(d, &an.dynamics().drives[k], t)[2];
            }
        }
    }

    /// `du'/dp` of drive `k`'s prescribed rate at `t` \[rad/s per unit
    /// of p\] (0 where the parameter does not move the drives).
    pub fn drive_rate(&self, t: f64, base: &Analysis<M>, k: usize) -> f64 {
        if !self.touches.drives {
            return 0.0;
        }
        let d = &base.dynamics().drives[k];
        let rate = |an: &Analysis<M>| toward(d, &an.dynamics().drives[k], t)[1];
        self.base_weight * d.angle.eval3(t)[1] + self.nodes.iter().map(|(w, an)| w * rate(an)).sum::<f64>()
    }

    /// Adds `d r/dp` of the constraint residuals at `(t, x)`
    /// ([`Analysis::constraint_residual`]) into `out` (nh + nc), `base_r`
    /// the base problem's `base`'s; each node's prescribed angles
    /// linearized from the base's, as in [`Stencil::add_forces`];
    /// `values` (`G` at its pattern) and `node_r` (nh + nc) scratch.
    pub fn add_residual(
        &self,
        base: &Analysis<M>,
        t: f64,
        x: &[f64],
        base_r: &[f64],
        (values, node_r): (&mut [f64], &mut [f64]),
        out: &mut [f64],
    ) {
        if !(self.touches.model || self.touches.drives) {
            return;
        }
        for (o, r) in out.iter_mut().zip(base_r) {
            *o += self.base_weight * r;
        }
        let nh = base.dynamics().info.n_holonomic;
        for (w, an) in &self.nodes {
            an.residual_into(t, x, values, node_r);
            for (o, r) in out.iter_mut().zip(node_r.iter()) {
                *o += *w * r;
            }
            // the node's own `-u(t)`, `-u'(t)` replaced by the linearized ones
            for (d, n) in base.dynamics().drives.iter().zip(&an.dynamics().drives) {
                let (own, lin) = (n.angle.eval3(t), toward(d, n, t));
                out[d.row] += *w * (own[0] - lin[0]);
                out[nh + d.row] += *w * (own[1] - lin[1]);
            }
        }
    }
}

/// `(u, u', u'')` of the drive `node` (the base's drive `base` in a
/// problem at a nearby parameter value) linearized from the base's
/// ([`crate::effects::Waveform::eval3_toward`]).
fn toward(base: &Drive, node: &Drive, t: f64) -> [f64; 3] {
    base.angle.eval3_toward(&node.angle, t)
}
