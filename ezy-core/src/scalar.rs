//! The scalar type generated model functions are written over.
//!
//! Every function the `model!` macro emits (phi, Jacobians, convective terms,
//! point positions) is generic over [`Scalar`], so the same code runs on `f64`
//! in the solver and on forward-mode dual numbers in the tests, which is how
//! the generated derivatives are checked against exact ones (DESIGN.md, "Stay
//! concrete": the one reason to be generic over the scalar).

use core::ops::{Add, Div, Mul, Neg, Sub};

/// A real number type the generated model code can evaluate on.
///
/// Implemented for `f64` and for `num_dual::Dual64`, and sealed to them:
/// [`crate::erased::AnyModel`] has one entry per scalar type for each generic
/// method.
pub trait Scalar:
    sealed::Sealed
    + 'static
    + Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Lifts a constant (a literal or a parameter value).
    fn from_f64(value: f64) -> Self;
    /// The real part, as `f64`.
    fn re(self) -> f64;
    /// Sine [rad -> 1].
    fn sin(self) -> Self;
    /// Cosine [rad -> 1].
    fn cos(self) -> Self;
    /// Sine and cosine `(sin, cos)` [rad -> 1] of one angle (one argument
    /// reduction; what generated code calls where it needs both).
    fn sin_cos(self) -> (Self, Self);
    /// Square root.
    fn sqrt(self) -> Self;
    /// Integer power.
    fn powi(self, n: i32) -> Self;
    /// Reciprocal `1 / self`.
    fn recip(self) -> Self;
    /// Runs `f` on `len` values of scratch space kept per thread and per
    /// scalar type (grown, never shrunk, when a thread first needs that
    /// many): the registers of a model read from text
    /// (`text::RuntimeModel`), so that its evaluations do not
    /// allocate. The values on entry are whatever the last user left.
    #[doc(hidden)]
    fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [Self]) -> R) -> R;
}

/// [`Scalar::with_scratch`] on the thread-local buffer `cell`: taken out
/// while `f` runs (a nested call gets a buffer of its own), put back after.
fn scratch_in<T: Copy + 'static, R>(
    cell: &'static std::thread::LocalKey<std::cell::Cell<Vec<T>>>,
    zero: T,
    len: usize,
    f: impl FnOnce(&mut [T]) -> R,
) -> R {
    cell.with(|c| {
        let mut buf = c.take();
        if buf.len() < len {
            buf.resize(len, zero);
        }
        let out = f(&mut buf[..len]);
        c.set(buf);
        out
    })
}

thread_local! {
    static SCRATCH_F64: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
    static SCRATCH_DUAL: std::cell::Cell<Vec<num_dual::Dual64>> = const { std::cell::Cell::new(Vec::new()) };
}

mod sealed {
    /// Keeps [`super::Scalar`] to the types [`crate::erased::AnyModel`] dispatches on.
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for num_dual::Dual64 {}
}

/// The sine and cosine are the `libm` crate's (musl's, within one unit
/// in the last place, as glibc's): called, not looked up through the
/// dynamic linker, with a shorter argument reduction than glibc's
/// `sincos` (drive scene, DOP853 at 3e-11 on the minimal coordinates:
/// 7 % less integration time, 2.7 % fewer instructions; measured in
/// `docs/dev/performance.md`, eighth pass). The effects and waveforms
/// take theirs from here too: the library is chosen in this one place.
impl Scalar for f64 {
    #[inline(always)]
    fn from_f64(value: f64) -> Self {
        value
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sin(self) -> Self {
        libm::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        libm::cos(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        libm::sincos(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        f64::powi(self, n)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        f64::recip(self)
    }
    fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [Self]) -> R) -> R {
        scratch_in(&SCRATCH_F64, 0.0, len, f)
    }
}

impl Scalar for num_dual::Dual64 {
    fn from_f64(value: f64) -> Self {
        <num_dual::Dual64 as num_dual::DualNum>::from_re(value)
    }
    fn re(self) -> f64 {
        num_dual::DualStruct::re(&self)
    }
    fn sin(self) -> Self {
        num_dual::DualNum::sin(&self)
    }
    fn cos(self) -> Self {
        num_dual::DualNum::cos(&self)
    }
    fn sin_cos(self) -> (Self, Self) {
        num_dual::DualNum::sin_cos(&self)
    }
    fn sqrt(self) -> Self {
        num_dual::DualNum::sqrt(&self)
    }
    fn powi(self, n: i32) -> Self {
        num_dual::DualNum::powi(&self, n)
    }
    fn recip(self) -> Self {
        num_dual::DualNum::recip(&self)
    }
    fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [Self]) -> R) -> R {
        scratch_in(&SCRATCH_DUAL, Self::from_f64(0.0), len, f)
    }
}
