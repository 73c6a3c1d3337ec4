//! What the step loop integrates ([`Integrand`]): the DAE's full state
//! ([`Dae`]) or the reduced formulation's independent one
//! ([`Reduced`]), bound to the dynamics as the steppers' right-hand side
//! ([`Bound`]).

use faer::c64;

use crate::error::SimError;
use crate::formulation::dae::Dynamics;
use crate::formulation::newton::KktNewton;
use crate::formulation::reduced::Reduced;
use crate::integrator::Rhs;
use crate::integrator::radau5::NewtonSystem;
use crate::model::Model;
use crate::settings::ProjectionKind;
use crate::simulate::observer::{Observer, RunError};
use crate::simulate::run::{Pending, Run, first_non_finite};

/// What the step loop integrates, `x' = F(t, x)`: the DAE's full state
/// ([`Dae`]: `x = y`, projected after each step) or the reduced one
/// ([`Reduced`]: `x = z`, expanded to `y` for every check and output).
pub(super) trait Integrand<M: Model> {
    /// `dx = F(t, x)`.
    fn eval(&mut self, sys: &mut Dynamics<M>, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError>;
    /// After an accepted step from `t` to `t_new` of size `h`: the full
    /// state's checks ([`Run::after_step`]); returns whether `x` changed.
    /// `evaluated`: the step's last evaluation of `F` was at `x` (DOPRI5's
    /// last stage).
    #[expect(
        clippy::too_many_arguments,
        reason = "a step's state as the loop holds it, borrowed, no struct built per step"
    )]
    fn accept<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        x: &mut [f64],
        h: f64,
        evaluated: bool,
    ) -> Result<bool, SimError>;
    /// The full state `y` of the accepted `x` (as [`Integrand::accept`] left it).
    fn accepted_full<'a>(&'a self, x: &'a [f64]) -> &'a [f64];
    /// The full state `y` of a dense-output state `x` at `t` (the DAE's
    /// is `x` itself, unprojected).
    fn full_of<'a>(&'a mut self, sys: &Dynamics<M>, t: f64, x: &'a [f64]) -> Result<&'a [f64], SimError>;
    /// Whether its states are projected onto the constraints (the DAE's).
    fn projects(&self) -> bool {
        false
    }
    /// Queues the accepted state `x` at `t` as a sample.
    fn emit<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        x: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        run.emit(sys, t, self.accepted_full(x))
    }
    /// Queues the dense-output sample at `t` that `fill` writes (an `x`).
    fn emit_dense<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>>;
    /// Whether this formulation stops near a singular position so that
    /// the DAE can take over (see [`simulate`]): the reduced one, whose
    /// dependent coordinates are not determined there.
    fn hands_over_near_singular(&self) -> bool {
        false
    }
    /// After the accepted step's outputs: whether `x` was rewritten (a new
    /// partition), so that `F` there is to be evaluated again.
    fn settle(&mut self, _sys: &Dynamics<M>, _t: f64, _x: &mut [f64]) -> Result<bool, SimError> {
        Ok(false)
    }
    /// Whether `eval` solves the KKT system of the full state, so that
    /// the skates' margins are read from its multipliers (the DAE's).
    fn solves_kkt(&self) -> bool {
        false
    }
    /// The full state of the integrator state `x` at `t` into `out` (as
    /// [`Integrand::full_of`]).
    ///
    /// # Errors
    /// As [`Integrand::full_of`].
    fn full_into(&mut self, sys: &Dynamics<M>, t: f64, x: &[f64], out: &mut [f64]) -> Result<(), SimError> {
        out.copy_from_slice(self.full_of(sys, t, x)?);
        Ok(())
    }
    /// Forgets what was evaluated ahead at the accepted state (the
    /// forces changed there: a switch).
    fn forget_evaluation(&mut self) {}
    /// Whether the stages' evaluations may leave the full state partly
    /// unwritten ([`Reduced::set_lean_stages`]): a step loop whose accepted
    /// state is evaluated anew says so (not DOPRI5's, whose last stage
    /// is the accepted state's evaluation).
    fn lean_stages(&mut self, _on: bool) {}
    /// The DAE, where this is it: RADAU5 runs on it alone (its Newton
    /// system is built on the KKT matrix).
    fn as_dae(&mut self) -> Option<&mut Dae> {
        None
    }
}

/// The DAE formulation: `x = y = [q, qd, W]`.
pub(super) struct Dae;

impl<M: Model> Integrand<M> for Dae {
    #[inline(always)]
    fn eval(&mut self, sys: &mut Dynamics<M>, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError> {
        sys.rhs(t, x, dx)
    }
    fn accept<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        x: &mut [f64],
        h: f64,
        evaluated: bool,
    ) -> Result<bool, SimError> {
        let _ = evaluated;
        run.after_step(sys, t, t_new, x, h)
    }
    fn accepted_full<'a>(&'a self, x: &'a [f64]) -> &'a [f64] {
        x
    }
    fn full_of<'a>(&'a mut self, _sys: &Dynamics<M>, _t: f64, x: &'a [f64]) -> Result<&'a [f64], SimError> {
        Ok(x)
    }
    fn projects(&self) -> bool {
        true
    }
    fn emit_dense<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        run.queue(sys, t, Pending::Project, fill)
    }
    fn solves_kkt(&self) -> bool {
        true
    }
    fn as_dae(&mut self) -> Option<&mut Dae> {
        Some(self)
    }
}

impl<M: Model> Integrand<M> for Reduced {
    // into the stepper's stage loop, as `Reduced::eval` means its fused
    // path to be (with `#[inline]` alone it stayed a call of its own)
    #[inline(always)]
    fn eval(&mut self, sys: &mut Dynamics<M>, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), SimError> {
        Reduced::eval(self, sys, t, x, dx)
    }
    fn accept<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &mut Dynamics<M>,
        t: f64,
        t_new: f64,
        x: &mut [f64],
        h: f64,
        evaluated: bool,
    ) -> Result<bool, SimError> {
        if let Some(k) = first_non_finite(x) {
            let quantity = format!("the state component `{}`", self.state_name(sys, k));
            let advice = run.advice(t, h);
            return Err(SimError::NonFinite { t, quantity, value: x[k], dt: h, advice });
        }
        Reduced::accept(self, sys, t_new, x, evaluated)?;
        if run.settings.projection == ProjectionKind::None {
            // nothing projects it: the checks read the accepted state in place
            return run.after_step(sys, t, t_new, self.accepted_mut(), h).map(|_| false);
        }
        let mut full = std::mem::take(&mut self.scratch);
        full.clear();
        full.extend_from_slice(self.accepted());
        let res = run.after_step(sys, t, t_new, &mut full, h);
        self.scratch = full;
        res.map(|_| false)
    }
    fn accepted_full<'a>(&'a self, _x: &'a [f64]) -> &'a [f64] {
        self.accepted()
    }
    fn full_of<'a>(&'a mut self, sys: &Dynamics<M>, t: f64, x: &'a [f64]) -> Result<&'a [f64], SimError> {
        self.expand_sample(sys, t, x)?;
        Ok(self.full())
    }
    #[inline(always)]
    fn emit_dense<O: Observer<M>>(
        &mut self,
        run: &mut Run<'_, M, O>,
        sys: &Dynamics<M>,
        t: f64,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        let nz = self.nz(sys.ny());
        if self.defers_samples() {
            // the interpolated `z` is the row until it is observed
            // (`Run::flush` places and completes it), off the step loop
            if run.sample_places.is_empty() {
                run.sample_places = self.sample_places(sys.ny());
            }
            return run.queue(sys, t, Pending::Expand, |row| fill(&mut row[..nz]));
        }
        let mut z = std::mem::take(&mut self.scratch);
        z.resize(nz, 0.0);
        fill(&mut z);
        let res = match self.expand_sample(sys, t, &z) {
            Ok(()) => run.queue(sys, t, Pending::Ready, |row| row.copy_from_slice(self.full())),
            Err(e) => Err(e.into()),
        };
        self.scratch = z;
        res
    }
    // the test of every step in the step loop; a new partition out of line
    #[inline]
    fn settle(&mut self, sys: &Dynamics<M>, t: f64, x: &mut [f64]) -> Result<bool, SimError> {
        self.repartition(sys, t, x)
    }
    fn hands_over_near_singular(&self) -> bool {
        true
    }
    fn forget_evaluation(&mut self) {
        Reduced::forget_evaluation(self);
    }
    fn lean_stages(&mut self, on: bool) {
        self.set_lean_stages(on);
    }
}

/// A formulation bound to its dynamics: the [`Rhs`] the steppers call.
pub(super) struct Bound<'a, M: Model, F> {
    pub(super) sys: &'a mut Dynamics<M>,
    pub(super) form: &'a mut F,
}

impl<M: Model, F: Integrand<M>> Rhs for Bound<'_, M, F> {
    // always into the stepper's stages: the formulation's evaluation is
    // then the call (with the KKT solve inside it, one function), as the
    // step loops had it
    #[inline(always)]
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.form.eval(self.sys, t, y, dy)
    }
}

/// RADAU5's Newton system on the DAE bound to its dynamics: the KKT
/// system's ([`KktNewton`]), which reads the dynamics the bound
/// right-hand side holds. Kept out of RADAU5's step (as the KKT system's
/// own methods are): inlined there, the step's loops took 2.3 M
/// instructions more on `snake-stiff` (callgrind).
impl<M: Model> NewtonSystem<Bound<'_, M, Dae>> for KktNewton {
    #[inline(never)]
    fn jacobian(&mut self, rhs: &mut Bound<'_, M, Dae>, t: f64, y: &[f64], f: &[f64]) -> Result<(), SimError> {
        NewtonSystem::<Dynamics<M>>::jacobian(self, rhs.sys, t, y, f)
    }
    #[inline(never)]
    fn factor(&mut self, real: f64, complex: c64) -> bool {
        NewtonSystem::<Dynamics<M>>::factor(self, real, complex)
    }
    #[inline(never)]
    fn solve_real(&mut self, b: &mut [f64]) {
        NewtonSystem::<Dynamics<M>>::solve_real(self, b);
    }
    #[inline(never)]
    fn solve_complex(&mut self, b: &mut [c64]) {
        NewtonSystem::<Dynamics<M>>::solve_complex(self, b);
    }
}
