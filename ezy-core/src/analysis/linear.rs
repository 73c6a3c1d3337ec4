//! Linearization `x' ~ A dx + B du` at a state and time.

use faer::{Mat, c64};

use super::{Analysis, AnalysisError, dense};
use crate::model::Model;

/// An input of a linearization: a scalar `u` whose effect on `x'` is the
/// column of `B = df/du`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Input {
    /// A torque pair `u` \[N m\] at the named hinge: `+u` on its first
    /// body's heading, `-u` on its second's (the convention of the
    /// `hinge-motor` effect). Column name `tau_<hinge>`.
    HingeTorque(String),
    /// The named effect's force scaled by `1 + u` \[1\] (`u` = 0.1 is 10 %
    /// more of it): the sensitivity to its amplitude. Column name
    /// `scale_<effect>`.
    EffectScale(String),
}

impl Input {
    /// The input's column name in `B`: `tau_<hinge>` or `scale_<effect>`.
    pub fn name(&self) -> String {
        match self {
            Input::HingeTorque(h) => format!("tau_{h}"),
            Input::EffectScale(e) => format!("scale_{e}"),
        }
    }
}

/// The linearization of `x' = f(t, x)` at one state (Analysis::linearize).
#[derive(Debug, Clone)]
pub struct Linearization {
    /// Time \[s\].
    pub t: f64,
    /// The state `x = [q, qd]` (2 nq).
    pub state: Vec<f64>,
    /// Names of the state components (2 nq): the rows of `A` and `B`, the
    /// columns of `A`.
    pub state_names: Vec<String>,
    /// `A = df/dx` (2nq x 2nq) \[1/s, 1/s^2\]: `[[0, I], [dqdd/dq, dqdd/dqd]]`.
    pub a: Mat<f64>,
    /// Names of the inputs, the columns of `B` ([`Input::name`]).
    pub input_names: Vec<String>,
    /// `B = df/du` (2nq x nu): zero in the rows of `q`.
    pub b: Mat<f64>,
    /// The Jacobian `C` ((nh + nc) x 2nq) of the constraint residuals
    /// `[phi(q); G(q) qd]` (drives' angles and rates subtracted).
    pub constraints: Mat<f64>,
    /// An orthonormal basis (2nq x d) of the null space of `C`: the
    /// tangent space of the constraint manifold, `d = 2 nq - rank C`.
    pub tangent: Mat<f64>,
    /// Whether part of the applied forces' derivative in `A` came from
    /// central differences: an effect whose law has no exact Jacobian
    /// ([`crate::effects::kind::ForceLaw::jacobian`];
    /// [`super::Analysis::differenced_laws`] names them). `false` when every force was differentiated exactly (every
    /// built-in law is) or there is none.
    pub forces_by_differences: bool,
}

impl Linearization {
    /// `A` on the constraint manifold, `T^T A T` (d x d) with `T`
    /// [`Linearization::tangent`]: the linearization of the motion that
    /// keeps the constraints.
    pub fn reduced(&self) -> Mat<f64> {
        self.tangent.transpose() * &self.a * &self.tangent
    }

    /// The eigenvalues \[1/s\] of [`Linearization::reduced`], largest real
    /// part first.
    ///
    /// # Errors
    /// [`AnalysisError::Numerics`] if the eigenvalue iteration fails.
    pub fn eigenvalues(&self) -> Result<Vec<c64>, AnalysisError> {
        dense::eigenvalues(self.reduced().as_ref(), false)
    }
}

/// Relative tolerance of the numerical rank of a constraint Jacobian
/// (exact to rounding: dual numbers).
pub(crate) const RANK_RTOL: f64 = 1e-10;

impl<M: Model> Analysis<M> {
    /// The linearization at `(t, x)` (`x` = `[q, qd]`, 2 nq) with inputs
    /// `inputs`.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for an input the model or scene does not
    /// have or one given twice, or a skate with friction that slides at `x` (its holding
    /// force past `mu N`); [`AnalysisError::Numerics`] if the KKT system is singular at
    /// `x`; [`AnalysisError::Sim`] if an effect fails.
    pub fn linearize(&mut self, t: f64, x: &[f64], inputs: &[Input]) -> Result<Linearization, AnalysisError> {
        self.check_size()?;
        let nq = self.nq();
        if x.len() != 2 * nq {
            return Err(AnalysisError::Request {
                reason: format!("the state has {} components; the model needs 2 nq = {}", x.len(), 2 * nq),
            });
        }
        self.check_inputs(inputs)?;
        let columns = inputs.iter().map(|i| self.input_force(t, x, i)).collect::<Result<Vec<_>, _>>()?;
        self.watch_grip();
        let p = self.point(t, x)?;
        self.check_grip("the state linearized")?;
        let (a, c) = self.jacobians(t, x, &p)?;
        let nc = p.mu.len();
        let mut rhs = Mat::<f64>::zeros(nq + nc, inputs.len());
        for (k, col) in columns.iter().enumerate() {
            for i in 0..nq {
                rhs[(i, k)] = col[i];
            }
        }
        let du = dense::solve(p.kkt.as_ref(), rhs.as_ref(), "the KKT matrix [M G^T; G 0]")?;
        let b = Mat::from_fn(2 * nq, inputs.len(), |i, k| if i < nq { 0.0 } else { du[(i - nq, k)] });
        let tangent = dense::null_space(c.as_ref(), RANK_RTOL)?;
        Ok(Linearization {
            t,
            state: x.to_vec(),
            state_names: self.state_names(),
            a,
            input_names: inputs.iter().map(Input::name).collect(),
            b,
            constraints: c,
            tangent,
            forces_by_differences: self.last_differenced(),
        })
    }

    /// The generalized force (nq) of one unit of `input` at `(t, x)`.
    /// Checks, before any work, that the model has every input's hinge
    /// and the scene every input's effect, each input given once (what
    /// [`Analysis::linearize`] refuses).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the input.
    pub fn check_inputs(&mut self, inputs: &[Input]) -> Result<(), AnalysisError> {
        if let Some(k) = (1..inputs.len()).find(|&k| inputs[..k].contains(&inputs[k])) {
            return Err(AnalysisError::Request {
                reason: format!(
                    "input `{}` is given twice (two equal columns of B); give each input once",
                    inputs[k].name()
                ),
            });
        }
        let x = vec![0.0; 2 * self.nq()];
        for i in inputs {
            self.input_force(0.0, &x, i)?;
        }
        Ok(())
    }

    fn input_force(&mut self, t: f64, x: &[f64], input: &Input) -> Result<Vec<f64>, AnalysisError> {
        let nq = self.nq();
        let mut f = vec![0.0; nq];
        match input {
            Input::HingeTorque(name) => {
                let info = &self.sys.info;
                let h = info.hinges.iter().find(|h| &h.name == name).ok_or_else(|| AnalysisError::Request {
                    reason: format!(
                        "input `tau_{name}`: model {} has no hinge `{name}`; its hinges: {}",
                        info.name,
                        names(info.hinges.iter().map(|h| h.name.as_str()))
                    ),
                })?;
                f[info.bodies[h.body_a].coords[2]] += 1.0;
                if let Some(b) = h.body_b {
                    f[info.bodies[b].coords[2]] -= 1.0;
                }
            }
            Input::EffectScale(name) => {
                let e = self.sys.effects.iter().find(|e| &e.name == name).ok_or_else(|| AnalysisError::Request {
                    reason: format!(
                        "input `scale_{name}`: the scene has no effect `{name}`; its effects: {}",
                        names(self.sys.effects.iter().map(|e| e.name.as_str()))
                    ),
                })?;
                e.apply(t, &x[..nq], &x[nq..2 * nq], &mut f);
            }
        }
        Ok(f)
    }
}

/// `a, b, c` or `(none)`.
fn names<'a>(it: impl Iterator<Item = &'a str>) -> String {
    let v: Vec<&str> = it.collect();
    if v.is_empty() { "(none)".into() } else { v.join(", ") }
}
