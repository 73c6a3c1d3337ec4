//! Relative equilibria: motions along a one-parameter group of rigid
//! motions (steady straight or turning motion with fixed shape); ordinary
//! equilibria when the scene has no symmetry.

use faer::{Mat, c64};

use super::symmetry::{act, body_pose, field, field_jacobian, fields};
use super::{Analysis, AnalysisError, dense, newton};
use crate::analysis::symmetry::{Generator, Symmetry};
use crate::model::Model;

/// The stability of a steady motion or a periodic orbit from its spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stability {
    /// Every eigenvalue outside the family's own has negative real part
    /// (every multiplier lies inside the unit circle): perturbations decay
    /// to a nearby member of the family.
    Stable,
    /// Some eigenvalue has positive real part (a multiplier lies outside
    /// the unit circle).
    Unstable,
    /// Neither: some eigenvalue lies on the imaginary axis (a multiplier
    /// on the unit circle) and none beyond it, or every eigenvalue is the
    /// family's; the linearization does not decide.
    Neutral,
}

impl Stability {
    /// `stable`, `unstable`, `neutral`.
    pub fn name(self) -> &'static str {
        match self {
            Stability::Stable => "stable",
            Stability::Unstable => "unstable",
            Stability::Neutral => "neutral",
        }
    }

    /// Classifies growth rates `rates` (real parts of eigenvalues, or
    /// `ln |mu|` of multipliers), the `family` ones nearest zero (the
    /// directions along the family of solutions) left out; `tol` is the
    /// rate counted as zero.
    pub(crate) fn classify(mut rates: Vec<f64>, family: usize, tol: f64) -> Stability {
        rates.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
        let rest = &rates[family.min(rates.len())..];
        if rest.iter().any(|&r| r > tol) {
            Stability::Unstable
        } else if !rest.is_empty() && rest.iter().all(|&r| r < -tol) {
            Stability::Stable
        } else {
            Stability::Neutral
        }
    }

    /// The classification of a steady motion's eigenvalues \[1/s\], the
    /// `family` ones nearest the imaginary axis left out: a real part
    /// within 1e-7 of the largest `|lambda|` (at least 1) counts as zero.
    pub(crate) fn of_eigenvalues(eigenvalues: &[c64], family: usize) -> Stability {
        let top = eigenvalues.iter().fold(1.0f64, |m, z| m.max(z.re.hypot(z.im)));
        Stability::classify(eigenvalues.iter().map(|z| z.re).collect(), family, 1e-7 * top)
    }

    /// The classification of a periodic orbit's Floquet multipliers, the
    /// `family` ones nearest the unit circle left out: `ln |mu|` within
    /// 1e-6 of 0 counts as on it.
    pub(crate) fn of_multipliers(multipliers: &[c64], family: usize) -> Stability {
        let rates = multipliers.iter().map(|z| z.re.hypot(z.im).max(1e-300).ln()).collect();
        Stability::classify(rates, family, 1e-6)
    }
}

/// A relative equilibrium `x(t) = exp((t - t0) xi) x0` ([`Analysis::steady_motion`]).
#[derive(Debug, Clone)]
pub struct SteadyMotion {
    /// The time \[s\] of the analysis (the scene is autonomous).
    pub t: f64,
    /// The state `x0 = [q, qd]` (2 nq), moved so that the reference body
    /// (the model's first) is at the origin with heading 0, as far as the
    /// symmetry allows.
    pub state: Vec<f64>,
    /// The symmetry the motion is relative to.
    pub symmetry: Symmetry,
    /// The group velocity `xi`, one coefficient per generator of
    /// [`Symmetry::generators`] (\[m/s\] for a translation, \[rad/s\] for
    /// the rotation about the origin), for the moved state.
    pub xi: Vec<f64>,
    /// The reference body's velocity in its own frame: forward `u` \[m/s\],
    /// lateral `v` \[m/s\], yaw rate `omega` \[rad/s\].
    pub body_velocity: [f64; 3],
    /// Eigenvalues \[1/s\] of the linearization on the constraint manifold
    /// modulo the symmetry, largest real part first.
    pub eigenvalues: Vec<c64>,
    /// Dimension of the family of steady motions through this one, modulo
    /// the symmetry (the sleigh's straight motions at every speed: 1). As
    /// many eigenvalues are zero along it and are left out of the
    /// classification.
    pub family: usize,
    /// The classification of [`SteadyMotion::eigenvalues`].
    pub stability: Stability,
    /// Newton iterations taken.
    pub iterations: usize,
    /// The final residual of the defining equations (max norm).
    pub residual: f64,
}

impl SteadyMotion {
    /// Speed of the reference body \[m/s\].
    pub fn speed(&self) -> f64 {
        self.body_velocity[0].hypot(self.body_velocity[1])
    }

    /// Curvature of the reference body's path `omega / speed` \[1/m\]
    /// (signed; 0 when the body does not translate).
    pub fn curvature(&self) -> f64 {
        let s = self.speed();
        if s > 0.0 { self.body_velocity[2] / s } else { 0.0 }
    }
}

/// Most Newton iterations of the searches.
pub(crate) const MAX_NEWTON: usize = 40;

impl<M: Model> Analysis<M> {
    /// The relative equilibrium nearest `guess` (2 nq) at time `t` under
    /// `symmetry` (from [`Analysis::symmetry`]; [`Symmetry::NONE`] for an
    /// ordinary equilibrium): Newton's method with minimum-norm steps on
    /// `f(x) = xi . X(x)`, `phi(q) = 0`, `G(q) qd = 0` in the unknowns `x`
    /// and `xi` (X the generators' fields), which converges to a nearby
    /// member of a family of solutions. With `energy` \[J\], the kinetic
    /// energy `qd^T M qd / 2 = energy` is one more equation: it picks the
    /// member of a conservative scene's family at that level (without it,
    /// a search from far away may end at rest, where every shape is an
    /// equilibrium). Its eigenvalues are those of
    /// `A - xi . dX/dx` on the constraint manifold's tangent space modulo
    /// the group orbit, which that map leaves invariant.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] if the scene changes with time, or a
    /// skate with friction slides on the motion found (its holding force
    /// past `mu N`); [`AnalysisError::NotConverged`]; as
    /// [`Analysis::linearize`].
    pub fn steady_motion(
        &mut self,
        t: f64,
        guess: &[f64],
        symmetry: Symmetry,
        energy: Option<f64>,
    ) -> Result<SteadyMotion, AnalysisError> {
        self.check_size()?;
        let nq = self.nq();
        let n2 = 2 * nq;
        if guess.len() != n2 {
            return Err(AnalysisError::Request {
                reason: format!("the guess has {} components; the model needs 2 nq = {n2}", guess.len()),
            });
        }
        self.check_autonomous(t, guess)?;
        let gens = symmetry.generators();
        let k = gens.len();
        let bodies = self.bodies().to_vec();
        let x = guess.to_vec();
        let f = self.rhs(t, &x)?;
        let xi = self.group_velocity(t, &x, &gens)?;
        let norm = |r: &[f64]| r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let scale = 1.0 + norm(&x) + norm(&f);
        let r = self.steady_residual(t, &x, &xi, &gens, energy)?;
        // damped down to a step of 2^-9: a steady residual has no
        // integration's noise, so a step that does not lower it is not taken
        let rules = newton::Rules {
            what: "a steady motion",
            max_iterations: MAX_NEWTON,
            tolerance: 1e-12 * scale,
            min_step: 1.0 / 512.0,
            take_last: false,
            slow: None,
            grows: None,
            cutoff: 1e-12,
        };
        let mut search = Relative { an: self, t, gens: &gens, energy, symmetry, x, xi };
        let (iterations, r) = newton::solve(&mut search, r, &rules)?;
        let x = search.x;
        // move the reference body's frame to the origin
        let g = symmetry.restrict(body_pose(&bodies, 0, &x)).inverse();
        let mut x = act(&bodies, g, &x);
        // and each cyclic coordinate to zero
        for g in &gens {
            if let Generator::Shift(k) = *g {
                x[k] = 0.0;
            }
        }
        // every skate with friction holds on it (the motion is steady:
        // its forces are those at this state)
        self.watch_grip();
        self.rhs(t, &x)?;
        self.check_grip("this steady motion")?;
        let xi = self.group_velocity(t, &x, &gens)?;
        let j = self.steady_jacobian(t, &x, &xi, symmetry)?;
        let rank = dense::numerical_rank(j.as_ref(), 1e-8)?;
        let (eigenvalues, orbit) = self.reduced_spectrum(t, &x, &xi, symmetry)?;
        let family = (n2 + k - rank).saturating_sub(orbit);
        let stability = Stability::of_eigenvalues(&eigenvalues, family);
        let [i, jj, kk] = bodies[0];
        let (s, c) = x[kk].sin_cos();
        let (vx, vy) = (x[nq + i], x[nq + jj]);
        let body_velocity = [c * vx + s * vy, -s * vx + c * vy, x[nq + kk]];
        Ok(SteadyMotion {
            t,
            state: x,
            symmetry,
            xi,
            body_velocity,
            eigenvalues,
            family,
            stability,
            iterations,
            residual: norm(&r),
        })
    }

    /// The relative-equilibrium equations at `(x, xi)` (2 nq + k): `f(x)
    /// - xi . X(x)` (2 nq), the constraint residuals (nh + nc) and, with
    /// `energy` \[J\], `qd^T M qd / 2 - energy`.
    pub(crate) fn steady_residual(
        &mut self,
        t: f64,
        x: &[f64],
        xi: &[f64],
        gens: &[Generator],
        energy: Option<f64>,
    ) -> Result<Vec<f64>, AnalysisError> {
        let mut r = self.rhs(t, x)?;
        for (g, c) in gens.iter().zip(xi) {
            for (ri, v) in r.iter_mut().zip(field(self.bodies(), *g, x)) {
                *ri -= c * v;
            }
        }
        r.extend(self.residual_at(t, x));
        if let Some(e) = energy {
            r.push(self.sys.kinetic_energy(&x[x.len() / 2..]) - e);
        }
        Ok(r)
    }

    /// `j` with the row of the kinetic energy's derivative `[0, M qd, 0]` appended.
    pub(crate) fn with_energy_row(&self, j: Mat<f64>, x: &[f64]) -> Mat<f64> {
        let nq = self.nq();
        let m = j.nrows();
        Mat::from_fn(m + 1, j.ncols(), |r, c| {
            if r < m {
                j[(r, c)]
            } else if (nq..2 * nq).contains(&c) {
                self.sys.mass[c - nq] * x[c]
            } else {
                0.0
            }
        })
    }

    /// The Jacobian of the relative-equilibrium equations in `(x, xi)`:
    /// `[[A - xi . dX/dx, -X]; [C, 0]]`.
    pub(crate) fn steady_jacobian(
        &mut self,
        t: f64,
        x: &[f64],
        xi: &[f64],
        symmetry: Symmetry,
    ) -> Result<Mat<f64>, AnalysisError> {
        let n2 = x.len();
        let gens = symmetry.generators();
        let k = gens.len();
        let bodies = self.bodies().to_vec();
        let p = self.point(t, x)?;
        let (a, c) = self.jacobians(t, x, &p)?;
        let mut df = a;
        for (g, v) in gens.iter().zip(xi) {
            df -= field_jacobian(&bodies, *g, n2) * faer::Scale(*v);
        }
        let m = c.nrows();
        let mut j = Mat::<f64>::zeros(n2 + m, n2 + k);
        for r in 0..n2 {
            for col in 0..n2 {
                j[(r, col)] = df[(r, col)];
            }
        }
        for (kk, g) in gens.iter().enumerate() {
            for (r, v) in field(&bodies, *g, x).into_iter().enumerate() {
                j[(r, n2 + kk)] = -v;
            }
        }
        for r in 0..m {
            for col in 0..n2 {
                j[(n2 + r, col)] = c[(r, col)];
            }
        }
        Ok(j)
    }

    /// The eigenvalues of `A - xi . dX/dx` on the constraint manifold's
    /// tangent space modulo the group orbit at `x`, and the orbit's dimension.
    fn reduced_spectrum(
        &mut self,
        t: f64,
        x: &[f64],
        xi: &[f64],
        symmetry: Symmetry,
    ) -> Result<(Vec<c64>, usize), AnalysisError> {
        let n2 = x.len();
        let bodies = self.bodies().to_vec();
        let gens = symmetry.generators();
        let p = self.point(t, x)?;
        let (mut df, c) = self.jacobians(t, x, &p)?;
        for (g, v) in gens.iter().zip(xi) {
            df -= field_jacobian(&bodies, *g, n2) * faer::Scale(*v);
        }
        let tangent = dense::null_space(c.as_ref(), super::linear::RANK_RTOL)?;
        let (q, orbit) = self.quotient_basis(&tangent, x, symmetry)?;
        let reduced = dense::congruence(q.as_ref(), df.as_ref());
        Ok((dense::eigenvalues(reduced.as_ref(), false)?, orbit))
    }

    /// An orthonormal basis of the tangent space `tangent` modulo the
    /// group orbit through `x`, and the orbit's dimension.
    pub(crate) fn quotient_basis(
        &self,
        tangent: &Mat<f64>,
        x: &[f64],
        symmetry: Symmetry,
    ) -> Result<(Mat<f64>, usize), AnalysisError> {
        self.quotient_basis_with(tangent, x, symmetry, &[])
    }

    /// [`Analysis::quotient_basis`] modulo the group orbit and the
    /// directions `extra` (2 nq each, in the tangent space: the structural
    /// ones, [`super::structural`]); the dimension removed.
    pub(crate) fn quotient_basis_with(
        &self,
        tangent: &Mat<f64>,
        x: &[f64],
        symmetry: Symmetry,
        extra: &[Vec<f64>],
    ) -> Result<(Mat<f64>, usize), AnalysisError> {
        let bodies = self.bodies();
        let gens = symmetry.generators();
        let mut f = fields(bodies, &gens, x);
        if !extra.is_empty() {
            let k = f.ncols();
            f = Mat::from_fn(x.len(), k + extra.len(), |i, j| if j < k { f[(i, j)] } else { extra[j - k][i] });
        }
        let o = dense::orthonormal_range(f.as_ref(), 1e-10)?;
        // the orbit lies in the tangent space: project to be safe of rounding
        let o = dense::mul(tangent.as_ref(), dense::mul(tangent.transpose(), o.as_ref()).as_ref());
        let o = dense::orthonormal_range(o.as_ref(), 1e-10)?;
        Ok((dense::complement(tangent.as_ref(), o.as_ref())?, o.ncols()))
    }

    /// The group velocity `xi` that best explains `f(x)` as a motion along
    /// the generators, `f(x) = xi . X(x)` by least squares.
    fn group_velocity(&mut self, t: f64, x: &[f64], generators: &[Generator]) -> Result<Vec<f64>, AnalysisError> {
        let f = self.rhs(t, x)?;
        Ok(dense::min_norm_solve(fields(self.bodies(), generators, x).as_ref(), &f, 1e-12)?.0)
    }

    /// Refuses a steady-motion search on a scene whose accelerations
    /// change with time at a fixed state.
    pub(crate) fn check_autonomous(&mut self, t: f64, x: &[f64]) -> Result<(), AnalysisError> {
        let a = self.rhs(t, x)?;
        let b = self.rhs(t + 0.7391, x)?;
        let scale = 1.0 + a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if a.iter().zip(&b).any(|(u, v)| (u - v).abs() > 1e-10 * scale) {
            return Err(AnalysisError::Request {
                reason: "the scene is driven in time (its accelerations at a fixed state change with t), so it has no steady motions; analyse its periodic orbit instead".into(),
            });
        }
        Ok(())
    }
}

/// The relative-equilibrium equations of [`Analysis::steady_motion`] at
/// their current point `(x, xi)`, for the analyses' Newton
/// ([`newton::solve`]).
struct Relative<'a, M: Model> {
    an: &'a mut Analysis<M>,
    t: f64,
    gens: &'a [Generator],
    energy: Option<f64>,
    symmetry: Symmetry,
    x: Vec<f64>,
    xi: Vec<f64>,
}

impl<M: Model> Relative<'_, M> {
    /// The current point moved by `lambda dz`.
    fn moved(&self, dz: &[f64], lambda: f64) -> (Vec<f64>, Vec<f64>) {
        (newton::moved(&self.x, dz, lambda), newton::moved(&self.xi, &dz[self.x.len()..], lambda))
    }
}

impl<M: Model> newton::Equations for Relative<'_, M> {
    fn jacobian(&mut self) -> Result<Mat<f64>, AnalysisError> {
        self.an.check_stop()?;
        let j = self.an.steady_jacobian(self.t, &self.x, &self.xi, self.symmetry)?;
        Ok(if self.energy.is_some() { self.an.with_energy_row(j, &self.x) } else { j })
    }

    fn trial(&mut self, dz: &[f64], lambda: f64, _last: bool) -> Result<Option<Vec<f64>>, AnalysisError> {
        let (x, xi) = self.moved(dz, lambda);
        // a state where the residual fails (a singular KKT matrix) counts
        // as not lowering it
        Ok(self.an.steady_residual(self.t, &x, &xi, self.gens, self.energy).ok())
    }

    fn take(&mut self, dz: &[f64], lambda: f64) -> Result<(), AnalysisError> {
        (self.x, self.xi) = self.moved(dz, lambda);
        Ok(())
    }
}
