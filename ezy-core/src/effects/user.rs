//! Force laws of the user's own: a trait for the law the right-hand side
//! calls ([`ForceLaw`]), a trait for its serialized form ([`EffectKind`]:
//! the fields a scene file's table gives, read by serde), an effect of
//! such a kind ([`UserSpec`]), and a closure as a law ([`Controller`]).
//!
//! A law of the user's own gets what a built-in effect gets: its work
//! state `W_<name>` closes the energy ledger with the power it returns,
//! its value column `<prefix>_<name>`, `--set NAME.KEY` on its numbers,
//! families (`hinge = "J[*]"`), every integrator (RADAU5 takes its
//! coupling from [`ForceLaw::coords`]) and errors located in the scene
//! file. The built-in kinds stay an enum ([`super::EffectSpec`]) so that
//! the right-hand side dispatches them without a virtual call; a user law
//! costs one virtual call per evaluation.

use std::fmt;
use std::sync::Arc;

use serde::Serialize;
use serde::de::DeserializeOwned;

use super::{EffectContext, SpecError};

/// A resolved force law: what the right-hand side calls at every
/// evaluation. Implement it for the law of an [`EffectKind`], or pass a
/// closure as a [`Controller`].
///
/// Conventions as for the built-in effects (docs/physics.md §1, §8): a
/// world force `F` \[N\] at a body point with world lever arm `r` \[m\]
/// from the centre of mass adds `(F_x, F_y, r_x F_y - r_y F_x)` to the
/// body's `(x, y, phi)` entries of `f`; a hinge torque `tau` \[N m\] adds
/// `+tau` to the first body's heading and `-tau` to the second's.
pub trait ForceLaw: Send + Sync + fmt::Debug + 'static {
    /// Adds the law's generalized force at `(t, q, qd)` (`t` \[s\], `q`
    /// and `qd` nq each) into `f` (nq) \[N, N m\] and returns `(power,
    /// value)`: `power = f_law . qd` \[W\], the rate of the law's work
    /// state `W_<name>`, and `value` the number written to its value
    /// column (a torque \[N m\] or a force \[N\]).
    ///
    /// Called at every right-hand-side evaluation: it should not allocate.
    /// A NaN power at a finite state stops the run with
    /// [`crate::SimError::EffectFailed`] and [`ForceLaw::failure`]'s text.
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64);

    /// The coordinates (indices into `q`) the force reads or acts on: the
    /// law's coupling in the Jacobian RADAU5 factors. Give every one: a
    /// coordinate left out makes the Newton iteration converge slowly or
    /// not at all (the results stay right where it converges).
    fn coords(&self) -> Vec<usize>;

    /// Why the law gave a NaN power at `q` (nq), for the error that stops
    /// the run.
    fn failure(&self, _q: &[f64]) -> String {
        "gave a force or power that is not a number".into()
    }
}

/// An effect kind of the user's own, as scene files write it: the fields
/// of its `[effects.NAME]` table (read through serde, `kind` excepted)
/// and how they resolve against a model. Register it with
/// `App::effect::<T>("my-kind")` (crate `ezy`) or `EffectKinds::add`
/// (crate `ezy-scene`); in Rust, pass a value to `Problem::kind`.
///
/// Strings in a scene file's table are names only under the name keys
/// (`hinge`, `skate`, `body`, `at`, `frame`, `from`, `to`, `bodies`,
/// `ezy_scene::NAME_KEYS`); in any other key a string names a scene parameter
/// (`k = "K0"` with `[scene_params] K0 = 2.0`). A key `hinge`, `skate` or
/// `at` written `"J[*]"` makes one effect per element of the family.
///
/// ```
/// use ezy_core::effects::{EffectContext, EffectKind, ForceLaw, HingeRef, SpecError};
/// use serde::{Deserialize, Serialize};
///
/// /// A torsion spring at a hinge, `tau = -k theta` [N m].
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// #[serde(deny_unknown_fields)]
/// struct Torsion {
///     hinge: String,
///     /// Stiffness [N m/rad].
///     k: f64,
/// }
///
/// #[derive(Debug)]
/// struct TorsionLaw {
///     hinge: HingeRef,
///     k: f64,
/// }
///
/// impl ForceLaw for TorsionLaw {
///     fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
///         let tau = -self.k * self.hinge.angle(q);
///         (self.hinge.add_torque(tau, qd, f), tau) // (power, value)
///     }
///     fn coords(&self) -> Vec<usize> {
///         self.hinge.coords()
///     }
/// }
///
/// impl EffectKind for Torsion {
///     type Law = TorsionLaw;
///     const VALUE_PREFIX: &'static str = "tau";
///     fn resolve(&self, cx: &EffectContext<'_>) -> Result<TorsionLaw, SpecError> {
///         let h = cx.hinge("hinge", &self.hinge)?;
///         SpecError::check(self.k >= 0.0, "k", || format!("k = {} must be zero or positive", self.k))?;
///         Ok(TorsionLaw { hinge: h, k: self.k })
///     }
/// }
/// ```
pub trait EffectKind: Serialize + DeserializeOwned + Clone + fmt::Debug + Send + Sync + 'static {
    /// The law the right-hand side calls.
    type Law: ForceLaw;

    /// Prefix of the effect's value column `<prefix>_<name>`: `tau` for a
    /// torque \[N m\], `F` (the default) for a force \[N\].
    const VALUE_PREFIX: &'static str = "F";

    /// Checks the fields against the model `cx` describes and builds the
    /// law (indices into `q`, body-frame geometry at the model's parameter
    /// values).
    ///
    /// # Errors
    /// A [`SpecError`] naming the field at fault: a name the model does
    /// not have (the [`EffectContext`] lookups give these), a number out
    /// of range. The scene file's check places it at that key.
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<Self::Law, SpecError>;
}

/// An [`EffectKind`] value without its type.
trait BoundKind: fmt::Debug + Send + Sync {
    fn value_prefix(&self) -> &'static str;
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<Arc<dyn ForceLaw>, SpecError>;
}

impl<T: EffectKind> BoundKind for T {
    fn value_prefix(&self) -> &'static str {
        T::VALUE_PREFIX
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<Arc<dyn ForceLaw>, SpecError> {
        Ok(Arc::new(EffectKind::resolve(self, cx)?))
    }
}

/// An effect of a kind of the user's own ([`EffectKind`]): the kind's
/// name and its value, read and checked (a scene file's table of that
/// kind, once parsed, or a value built in Rust).
#[derive(Clone)]
pub struct UserSpec {
    kind: String,
    value: Arc<dyn BoundKind>,
}

impl UserSpec {
    /// The effect `value` of the kind registered as `kind`.
    pub fn new<T: EffectKind>(kind: &str, value: T) -> Self {
        Self { kind: kind.into(), value: Arc::new(value) }
    }

    /// The kind, as scene files write it.
    pub fn kind(&self) -> &str {
        &self.kind
    }

    /// The value column's prefix ([`EffectKind::VALUE_PREFIX`]).
    pub fn value_prefix(&self) -> &'static str {
        self.value.value_prefix()
    }

    /// The kind's law for the model `cx` describes.
    pub(crate) fn resolve(&self, cx: &EffectContext<'_>) -> Result<Arc<dyn ForceLaw>, SpecError> {
        self.value.resolve(cx)
    }
}

impl fmt::Debug for UserSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("UserSpec").field("kind", &self.kind).field("value", &self.value).finish()
    }
}

/// Two specs are equal when their kinds are and their values print alike
/// (an [`EffectKind`] need not implement `PartialEq`; its `Debug` form
/// shows every field).
impl PartialEq for UserSpec {
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind && format!("{:?}", self.value) == format!("{:?}", other.value)
    }
}

/// Relative size, against `sum |f_k qd_k|`, of the power of a
/// [`Controller`]'s writes outside its coordinates that is taken as
/// rounding (two sums of `nq` products differ by far less).
const OUTSIDE_RTOL: f64 = 1e-9;

/// A closure as a force law (a feedback controller): it adds its
/// generalized force at `(t, q, qd)` into `f` (nq) and returns the value
/// of its column (a torque \[N m\] or a force \[N\]); its power, `f_law .
/// qd` \[W\], is computed from what it added at [`Controller::coords`].
///
/// ```
/// use ezy_core::effects::Controller;
/// // a PD torque holding heading 2 at zero, +tau on q[2]
/// let pd = Controller::new(vec![2], |_t, q: &[f64], qd: &[f64], f: &mut [f64]| {
///     let tau = -5.0 * q[2] - 0.5 * qd[2];
///     f[2] += tau;
///     tau
/// });
/// # let _ = pd;
/// ```
pub struct Controller<F> {
    coords: Vec<usize>,
    law: F,
}

impl<F> Controller<F>
where
    F: Fn(f64, &[f64], &[f64], &mut [f64]) -> f64 + Send + Sync + 'static,
{
    /// A controller that writes only `f[k]` for `k` in `coords` and reads
    /// only those entries of `q`, `qd` (give all `0..nq` when unsure: the
    /// power and RADAU5's coupling are then right at a little cost).
    pub fn new(mut coords: Vec<usize>, law: F) -> Self {
        coords.sort_unstable();
        coords.dedup();
        Self { coords, law }
    }
}

impl<F> fmt::Debug for Controller<F> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Controller").field("coords", &self.coords).finish_non_exhaustive()
    }
}

impl<F> ForceLaw for Controller<F>
where
    F: Fn(f64, &[f64], &[f64], &mut [f64]) -> f64 + Send + Sync + 'static,
{
    #[inline]
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        // the power of what the closure adds: sum over its coordinates of
        // (f after - f before) qd, without scratch space; and over all of
        // them, to see a write outside its coordinates (which would break
        // the power, and the energy ledger with it): a NaN power then
        // stops the run with `failure`'s text
        let power = |ks: &mut dyn Iterator<Item = usize>, f: &[f64]| ks.map(|k| f[k] * qd[k]).sum::<f64>();
        let (before, all_before) = (power(&mut self.coords.iter().copied(), f), power(&mut (0..f.len()), f));
        let value = (self.law)(t, q, qd, f);
        let (after, all_after) = (power(&mut self.coords.iter().copied(), f), power(&mut (0..f.len()), f));
        let outside = (all_after - all_before) - (after - before);
        let scale: f64 = f.iter().zip(qd).map(|(f, v)| (f * v).abs()).sum();
        if outside.abs() > OUTSIDE_RTOL * scale {
            return (f64::NAN, value);
        }
        (after - before, value)
    }
    fn coords(&self) -> Vec<usize> {
        self.coords.clone()
    }
    fn failure(&self, _q: &[f64]) -> String {
        format!(
            "wrote a force outside the coordinates it declared ({:?}), whose power (and the energy ledger with it) would be wrong: give Controller::new every coordinate it writes (all of 0..nq when unsure)",
            self.coords
        )
    }
}
