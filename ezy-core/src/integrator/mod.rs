//! Time integrators behind one interface, with statistics.
//!
//! | method | order | step | source |
//! |---|---|---|---|
//! | [`Method::Euler`](crate::settings::Method::Euler) | 1 | fixed | explicit Euler, the baseline |
//! | [`Method::Rk4`](crate::settings::Method::Rk4) | 4 | fixed | classic Runge-Kutta (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1, Table 1.2) |
//! | [`Method::Dopri5`](crate::settings::Method::Dopri5) | 5(4) | adaptive, PI control, dense output of order 4 | Dormand & Prince 1980; HNW I §II.5 and §II.6, code DOPRI5 |
//! | [`Method::Dop853`](crate::settings::Method::Dop853) | 8(5,3) | adaptive, PI control, dense output of order 7 | Dormand & Prince; HNW I §II.10, code DOP853 |
//! | [`Method::Radau5`](crate::settings::Method::Radau5) | 5, implicit | adaptive (predictive control), simplified Newton, dense output of order 3 | Radau IIA; HW II §IV.8, code RADAU5 |
//!
//! The steppers see the right-hand side through [`Rhs`], so they are tested
//! on plain ODEs as well as on models (`Dynamics` implements it). The step
//! loop drives each of them through one interface, [`stepper::Stepper`]
//! ([`fixed::Fixed`], [`adaptive::Embedded`], [`radau5::Radau5Stepper`]).

/// `out[i] = y[i] + h * (a1 * k1[i] + a2 * k2[i] + ...)` for every `i`,
/// summed left to right: a stage's argument, written
/// `stage_arg!(out, y, h, [a1, a2, ...], [k1, k2, ...])`. The loop runs in
/// a function of its own, inlined, whose slice parameters the compiler
/// knows not to overlap (`out` is a `&mut` parameter: `noalias`), so it is
/// vectorized without the run-time overlap checks that the same loop on
/// slices cut from `self` needs (one per stage read). A generic function
/// over `[&[f64]; K]` does the same but executes more instructions (drive,
/// DOP853 reduced: 8.88 M against 8.46 M in `simulate`). Defined before
/// the steppers' modules, which use it.
macro_rules! stage_arg {
    ($out:expr, $y:expr, $h:expr, [$a0:expr $(, $a:expr)*], [$k0:ident $(, $k:ident)*] $(,)?) => {{
        #[allow(clippy::too_many_arguments, reason = "one slice per stage of the method: up to 12; an allow, as the methods with few stages do not need it")]
        #[inline(always)]
        fn combine(out: &mut [f64], y: &[f64], h: f64, $k0: &[f64] $(, $k: &[f64])*) {
            let n = out.len();
            let (y, $k0 $(, $k)*) = (&y[..n], &$k0[..n] $(, &$k[..n])*);
            for i in 0..n {
                out[i] = y[i] + h * ($a0 * $k0[i] $(+ $a * $k[i])*);
            }
        }
        combine($out, $y, $h, $k0 $(, $k)*)
    }};
}

/// Calls `f::<N, ..>(args)` with the state length `n` as the compile-time
/// constant `N` where `n` is 1 to 12, else with `N = 0` (the length read
/// at run time): `by_len!(n, f::<_, T>(a, b))`. With `N`
/// known, every loop over the state has a constant trip count, which the
/// compiler unrolls and vectorizes without a remainder loop, as C++ code
/// on `std::array<double, N>` does (Hairer's DOP853 in `benches/peers`).
/// The body reads `N` through [`state_len`]. The lengths cover the small
/// models' reduced states (the EzyRoller's 7, the sleigh's 6); each is one
/// more copy of the step in the binary. 13, the EzyRoller's DAE state, is
/// left to the run-time loop: unrolled it ran 2-5 % slower (`ezy bench
/// drive`, row 3, four alternating runs), where 7 saves 29 % of the
/// stage arithmetic's instructions.
macro_rules! by_len {
    ($n:expr, $f:ident :: <_ $(, $g:ty)*> ($($arg:expr),* $(,)?)) => {
        match $n {
            1 => $f::<1 $(, $g)*>($($arg),*),
            2 => $f::<2 $(, $g)*>($($arg),*),
            3 => $f::<3 $(, $g)*>($($arg),*),
            4 => $f::<4 $(, $g)*>($($arg),*),
            5 => $f::<5 $(, $g)*>($($arg),*),
            6 => $f::<6 $(, $g)*>($($arg),*),
            7 => $f::<7 $(, $g)*>($($arg),*),
            8 => $f::<8 $(, $g)*>($($arg),*),
            9 => $f::<9 $(, $g)*>($($arg),*),
            10 => $f::<10 $(, $g)*>($($arg),*),
            11 => $f::<11 $(, $g)*>($($arg),*),
            12 => $f::<12 $(, $g)*>($($arg),*),
            _ => $f::<0 $(, $g)*>($($arg),*),
        }
    };
}

/// The state length inside a body called through [`by_len!`]: `N`, or
/// `n` (the run-time length) where `N` is 0.
#[inline(always)]
pub(crate) const fn state_len<const N: usize>(n: usize) -> usize {
    if N == 0 { n } else { N }
}

/// The stepper of `method` for a state of length `n` at the tolerance
/// `tol`, bound to `s` in `body`: `with_stepper!(method, n, tol, |s|
/// body, radau5 => other)`. Each explicit method's arm binds its own type
/// (so `body` is instantiated per method, with no dynamic call); RADAU5
/// takes `other`, since its Newton system is the caller's to build. The
/// one place a [`Method`](crate::settings::Method) becomes a stepper: the
/// simulation's step loop and the run sensitivities' go through it.
macro_rules! with_stepper {
    ($method:expr, $n:expr, $tol:expr, |$s:ident| $body:expr, radau5 => $radau5:expr $(,)?) => {{
        use $crate::integrator::{Dop853, Dopri5, Embedded, Euler, Fixed, Rk4};
        use $crate::settings::Method;
        let (n, tol) = ($n, $tol);
        match $method {
            Method::Euler => {
                let $s = &mut Fixed::new(Euler::new(n), n);
                $body
            }
            Method::Rk4 => {
                let $s = &mut Fixed::new(Rk4::new(n), n);
                $body
            }
            Method::Dopri5 => {
                let $s = &mut Embedded::<Dopri5>::new(n, tol);
                $body
            }
            Method::Dop853 => {
                let $s = &mut Embedded::<Dop853>::new(n, tol);
                $body
            }
            Method::Radau5 => $radau5,
        }
    }};
}
pub(crate) use with_stepper;

pub mod adaptive;
pub(crate) mod dop853;
pub(crate) mod dopri5;
pub(crate) mod fixed;
pub mod radau5;
pub mod stepper;

pub use adaptive::{Embedded, EmbeddedRk, Tolerance};
pub use dop853::Dop853;
pub use dopri5::Dopri5;
pub use fixed::{Euler, Fixed, FixedMethod, Rk4, hermite};
pub use stepper::{Control, Stats, Stepper, Trial};

use crate::error::SimError;

/// A right-hand side `y' = F(t, y)`.
pub trait Rhs {
    /// Evaluates `dy = F(t, y)`.
    ///
    /// # Errors
    /// Whatever the evaluation fails with (a singular KKT system).
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError>;
}

impl<F: FnMut(f64, &[f64], &mut [f64])> Rhs for F {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self(t, y, dy);
        Ok(())
    }
}
