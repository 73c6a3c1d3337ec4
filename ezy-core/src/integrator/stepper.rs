//! The one interface the step loop drives every method through
//! ([`Stepper`]), with its statistics record ([`Stats`], the implicit
//! method's in [`NewtonStats`]).
//!
//! A stepper owns what its method carries from step to step (the slope
//! at the start, the controller's memory, the last step's dense output);
//! the caller owns the states: the start `x` of a step and its end
//! `x_new`, which it may change between the attempt and the next step
//! (a projection, a cut at a switch). The methods:
//!
//! | type | methods | step | dense output |
//! |---|---|---|---|
//! | [`Fixed`](super::fixed::Fixed) | Euler, RK4 | the caller's grid | cubic Hermite on the step's ends |
//! | [`Embedded`](super::adaptive::Embedded) | DOPRI5, DOP853 | PI control of the embedded estimate | the pair's own (orders 4 and 7) |
//! | [`Radau5Stepper`](super::radau5::Radau5Stepper) | RADAU5 | predictive control, simplified Newton | the collocation polynomial |
//!
//! One step, as the caller goes through it: [`Stepper::attempt`]; with
//! [`Trial::Estimate`] the caller may revise the error
//! ([`Stepper::revise_error`]) before [`Stepper::control`] decides; on
//! acceptance [`Stepper::accepted`] with the end state as the caller left
//! it; [`Stepper::prepare_dense`] and [`Stepper::interpolate`] where the
//! step's inside is looked at (events, outputs, a switch);
//! [`Stepper::restart`] where the right-hand side or the state changed at
//! the end (a switch, a new partition); [`Stepper::advance`] once the end
//! is the next step's start.

use super::Rhs;
use crate::error::SimError;

/// How a method chooses its step sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Steps of the caller's grid: every attempt is accepted
    /// ([`Trial::Accepted`]).
    Fixed,
    /// An embedded error estimate, handed to the caller
    /// ([`Trial::Estimate`]), who may revise it before
    /// [`Stepper::control`] accepts or rejects the step.
    Embedded,
    /// The method accepts or rejects by itself ([`Trial::Accepted`],
    /// [`Trial::Rejected`]): RADAU5's Newton iteration and estimate.
    Internal,
}

/// What one attempt did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trial {
    /// The step is accepted: `x_new` holds its end; `h_next` \[s\] is the
    /// size to try next.
    Accepted {
        /// The next step size \[s\].
        h_next: f64,
    },
    /// The step is rejected (an error too large, a Newton iteration that
    /// failed, a stage that was not finite): try again from the same
    /// start with `h_next` \[s\].
    Rejected {
        /// The step size to retry with \[s\].
        h_next: f64,
    },
    /// The embedded error norm of the step (acceptable when at most 1),
    /// finite, for the caller to decide with ([`Stepper::control`]).
    Estimate(f64),
}

/// Work of the implicit method.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NewtonStats {
    /// Newton iterations (each costs three right-hand sides and two solves).
    pub newton_iterations: u64,
    /// Jacobian evaluations.
    pub jacobians: u64,
    /// Factorizations (each of a real and a complex matrix).
    pub factorizations: u64,
}

/// The work of a stepper, one record for every method.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stats {
    /// The implicit method's Newton iterations, Jacobians and
    /// factorizations (zero for the explicit methods).
    pub newton: NewtonStats,
    /// `(t [s], h |lambda|)` where an explicit adaptive method's
    /// stiffness test found the run stiff
    /// ([`crate::integrator::adaptive::StiffnessTest`]).
    pub stiff: Option<(f64, f64)>,
}

/// A time integrator as the step loop drives it, on the right-hand side
/// `R`. Implementations own their buffers, sized by their constructors;
/// no method allocates.
pub trait Stepper<R: Rhs + ?Sized> {
    /// How the method chooses its steps.
    const CONTROL: Control;
    /// Whether an accepted attempt evaluated `F(t + h, x_new)` as its last
    /// stage (DOPRI5's first-same-as-last), so that the end's slope is
    /// known unless the caller moved `x_new`.
    const FSAL: bool;

    /// Prepares a run from `(t, x)`: evaluates what the first step needs
    /// (the slope at the start) and returns the first step size \[s\],
    /// at most `h_max` (fixed steps: `h_max`, unused).
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn start(&mut self, rhs: &mut R, t: f64, x: &[f64], h_max: f64) -> Result<f64, SimError>;

    /// Attempts a step of size `h` from `(t, x)` into `x_new`.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with and the method does not
    /// take for a rejection (see each method).
    fn attempt(&mut self, rhs: &mut R, t: f64, x: &[f64], h: f64, x_new: &mut [f64]) -> Result<Trial, SimError>;

    /// Decides on the last attempt's estimate `err` (perhaps revised):
    /// `(accepted, h_next)`. Asked only of [`Control::Embedded`]; the
    /// others accept at the same size.
    fn control(&mut self, err: f64) -> (bool, f64);

    /// The last attempt's error norm from its error vectors after
    /// `remove` changed each of them (the caller's projection of the error
    /// onto the constraints' tangent space), for the step from `x` to
    /// `x_new`; `ea`, `eb`: scratch, as long as `x`. `None` for a method
    /// without an embedded estimate.
    ///
    /// # Errors
    /// Whatever `remove` fails with.
    fn revise_error(
        &self,
        x: &[f64],
        x_new: &[f64],
        ea: &mut [f64],
        eb: &mut [f64],
        remove: impl FnMut(&mut [f64]) -> Result<(), SimError>,
    ) -> Result<Option<f64>, SimError> {
        let _ = (x, x_new, ea, eb, remove);
        Ok(None)
    }

    /// The last attempt is accepted, ending at `(t_new, x_new)` as the
    /// caller left it (`moved`: changed since the attempt, a projection).
    /// Evaluates the slope there where the method carries it to the next
    /// step (the explicit adaptive methods), or where the caller reads it
    /// (`slope`: the fixed-step methods then carry it too). Returns
    /// whether it was evaluated now ([`Stepper::end_slope`]).
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn accepted(&mut self, rhs: &mut R, t_new: f64, x_new: &[f64], moved: bool, slope: bool) -> Result<bool, SimError>;

    /// `F(t_new, x_new)` as [`Stepper::accepted`] evaluated it.
    fn end_slope(&self) -> &[f64];

    /// Counts the accepted step in the method's stiffness test (DOPRI5,
    /// DOP853; after [`Stepper::accepted`], before the dense output):
    /// `(t [s], h |lambda|, the method's limit)` the one time it finds
    /// the run stiff.
    fn test_stiffness(&mut self, t_new: f64, x_new: &[f64]) -> Option<(f64, f64, f64)> {
        let _ = (t_new, x_new);
        None
    }

    /// Whether the dense output of the accepted step is ready.
    fn dense_ready(&self) -> bool;

    /// Makes the dense output of the accepted step from `x` to
    /// `(t_new, x_new)` ready (may evaluate the right-hand side); does
    /// nothing when it is.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn prepare_dense(&mut self, rhs: &mut R, t_new: f64, x: &[f64], x_new: &[f64]) -> Result<(), SimError>;

    /// The dense output of the accepted step at `t` \[s\] (inside it) into
    /// `out`, after [`Stepper::prepare_dense`].
    fn interpolate(&self, t: f64, out: &mut [f64]);

    /// The right-hand side or the state changed at `(t, x)`, the accepted
    /// end (a switch of forces or rows, a new partition): what the method
    /// carried from before is dropped, and the next step starts as the
    /// first one did.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn restart(&mut self, rhs: &mut R, t: f64, x: &[f64]) -> Result<(), SimError>;

    /// The accepted end `(t, x)` is the next step's start.
    ///
    /// # Errors
    /// Whatever the right-hand side fails with.
    fn advance(&mut self, rhs: &mut R, t: f64, x: &[f64]) -> Result<(), SimError>;

    /// A failure at a stage kept as the cause to report when the step
    /// size shrinks to nothing (cleared on acceptance).
    fn stage_failure(&mut self) -> &mut Option<SimError>;

    /// The work done so far.
    fn stats(&self) -> Stats;
}
