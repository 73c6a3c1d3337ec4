//! The traits a force law implements, the user's and ezy's alike: the law
//! the right-hand side calls ([`ForceLaw`]), its serialized form read by
//! serde from a scene file's table ([`EffectKind`]), and a closure as a
//! law ([`Controller`]); and a built-in kind's row of the reference page
//! ([`Reference`]).
//!
//! Every built-in kind (the registry's list, [`super::registry`]) is an
//! [`EffectKind`] whose law is a [`ForceLaw`], exactly as a kind of the
//! user's own: a spec struct in its family's file (`hinge.rs`,
//! `blade.rs`, ...) resolving to its family's law struct. The one
//! difference is where the resolved law is kept: a built-in law's
//! [`ForceLaw::into_law`] puts it in its family's variant of the hot enum
//! [`super::law::Law`], which the right-hand side dispatches with a
//! `match` (the family's methods inlined, no virtual call), while a law of
//! the user's own is kept behind an `Arc<dyn ForceLaw>` (one virtual call
//! per evaluation). See [`super::law`] for why, and what it measured.
//!
//! A law of the user's own gets what a built-in effect gets: its work
//! state `W_<name>` closes the energy ledger with the power it returns,
//! its value column `<prefix>_<name>`, `--set NAME.KEY` on its numbers,
//! families (`hinge = "J[*]"`), every integrator (RADAU5 takes its
//! coupling from [`ForceLaw::coords`]) and errors located in the scene
//! file.

use std::fmt;
use std::sync::Arc;

use serde::Serialize;
use serde::de::DeserializeOwned;

use super::context::{CheckContext, EffectContext, SpecError};
use super::law::{Law, UserLaw};
use super::waveform::Periodicity;

/// What an effect's force takes from the time alone: the values of its
/// waveforms at one time ([`ForceLaw::waveforms`]), so that stages at one
/// time (RK4's two midpoints, a step's end and the next step's start)
/// evaluate them once. Their meaning is the law's own (a motor's torque
/// \[N m\]; a servo's target angle \[rad\] and rate \[rad/s\]; a force's two
/// components \[N\]).
pub type Waveforms = [f64; 3];

/// The failure text of a built-in law's NaN power that has no more
/// particular reason ([`ForceLaw::failure`]).
pub(crate) const NOT_A_NUMBER: &str = "gave a force or power that is not a number (its inputs are not finite)";

/// A resolved force law: what the right-hand side calls at every
/// evaluation. Implement it for the law of an [`EffectKind`], or pass a
/// closure as a [`Controller`]. The built-in laws implement it too, one
/// struct per family ([`super::hinge::HingeLaw`], ...).
///
/// Conventions as for the built-in effects (docs/physics.md §1, §8): a
/// world force `F` \[N\] at a body point with world lever arm `r` \[m\]
/// from the centre of mass adds `(F_x, F_y, r_x F_y - r_y F_x)` to the
/// body's `(x, y, phi)` entries of `f`; a hinge torque `tau` \[N m\] adds
/// `+tau` to the first body's heading and `-tau` to the second's.
///
/// Only [`ForceLaw::apply`] and [`ForceLaw::coords`] are required; the
/// provided methods tell ezy more about the law (its forcing period, its
/// time scale, its time-only part, its exact Jacobian) and have defaults
/// that are right for any law.
pub trait ForceLaw: Send + Sync + fmt::Debug + 'static {
    /// Adds the law's generalized force at `(t, q, qd)` (`t` \[s\], `q`
    /// and `qd` nq each) into `f` (nq) \[N, N m\] and returns `(power,
    /// value)`: `power = f_law . qd` \[W\], the rate of the law's work
    /// state `W_<name>`, and `value` the number written to its value
    /// column (a torque \[N m\] or a force \[N\]).
    ///
    /// Called at every right-hand-side evaluation: it should not allocate.
    /// A NaN power at a finite state stops the run with
    /// [`crate::error::SimError::EffectFailed`] and [`ForceLaw::failure`]'s text.
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

    /// The values at time `t` \[s\] of what the force takes from the time
    /// alone (its waveforms), handed back to [`ForceLaw::apply_with`] for
    /// every state at that time. The default: none (zeros).
    #[inline(always)]
    fn waveforms(&self, _t: f64) -> Waveforms {
        [0.0; 3]
    }

    /// [`ForceLaw::apply`] with the values `wave` that
    /// [`ForceLaw::waveforms`] gave at the time `t` \[s\] of the state:
    /// what the right-hand side calls. The default ignores `wave` and
    /// calls [`ForceLaw::apply`].
    #[inline(always)]
    fn apply_with(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let _ = wave;
        self.apply(t, q, qd, f)
    }

    /// The law's exact Jacobian at `(t, q, qd)` (`t` \[s\], `q` and `qd`
    /// nq each) with the waveforms' values `wave` ([`ForceLaw::waveforms`]
    /// at `t`, held fixed): ADDS the partial derivatives of the generalized
    /// force it adds in [`ForceLaw::apply_with`] into `dq` = `dF/dq` and
    /// `dqd` = `dF/dqd`, each dense (nq x nq), row-major (`dq[i * nq + j]`
    /// is `df_i/dq_j`: \[N/m\], \[N/rad\], \[N m/m\] or \[N m/rad\] by the
    /// coordinates; `dqd[i * nq + j]` is `df_i/dqd_j`, the same per unit of
    /// velocity: \[N s/m\], ...), and returns `true`. Only the entries of
    /// the law's rows and columns change; another law's may already be
    /// there, so add, never overwrite.
    ///
    /// The default adds nothing and returns `false`: "no exact Jacobian".
    /// The analyses (steady motions, periodic orbits' variational
    /// equations, [`crate::analysis::Analysis::linearize`]: the Jacobian
    /// `A = df/dx` of the state equations, Seydel, *Practical Bifurcation
    /// and Stability Analysis*, 3rd ed., §7.1-7.3; Hairer & Wanner, *Solving
    /// ODEs II*, §VII.1) then differentiate this law's force alone by
    /// central differences, step `eps^(1/3) max(1, |x_j|)` (error about
    /// 1e-10 relative, Nocedal & Wright, *Numerical Optimization*, 2nd ed.,
    /// §8.1) and name it ([`crate::analysis::Analysis::differenced_laws`]),
    /// which their output states. A law that returns `false` must leave
    /// `dq` and `dqd` as they were.
    ///
    /// Every built-in law implements it exactly; where a law is not smooth
    /// its documentation says which derivative it gives. Implement it
    /// where the derivatives are at hand: a hinge torque `tau(theta,
    /// theta_dot)` (a [`super::context::HingeRef`] `h`) adds `s_i s_j
    /// dtau/dtheta` at `dq[i * nq + j]` and `s_i s_j dtau/dtheta_dot` at
    /// `dqd[i * nq + j]` for `i, j` in `h.a` (`s = +1`) and `h.b` (`s = -1`):
    ///
    /// ```
    /// use ezy_core::effects::{ForceLaw, HingeRef, Waveforms};
    ///
    /// /// A torsion spring at a hinge, `tau = -k theta` [N m].
    /// #[derive(Debug)]
    /// struct Torsion {
    ///     hinge: HingeRef,
    ///     k: f64,
    /// }
    ///
    /// impl ForceLaw for Torsion {
    ///     fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
    ///         let tau = -self.k * self.hinge.angle(q);
    ///         (self.hinge.add_torque(tau, qd, f), tau)
    ///     }
    ///     fn coords(&self) -> Vec<usize> {
    ///         self.hinge.coords()
    ///     }
    ///     // dtau/dtheta = -k, dtau/dtheta_dot = 0
    ///     fn jacobian(&self, _t: f64, _w: &Waveforms, q: &[f64], _qd: &[f64], dq: &mut [f64], _dqd: &mut [f64]) -> bool {
    ///         let nq = q.len();
    ///         let ends = [(Some(self.hinge.a), 1.0), (self.hinge.b, -1.0)];
    ///         for (i, si) in ends {
    ///             for (j, sj) in ends {
    ///                 if let (Some(i), Some(j)) = (i, j) {
    ///                     dq[i * nq + j] += si * sj * -self.k;
    ///                 }
    ///             }
    ///         }
    ///         true
    ///     }
    /// }
    ///
    /// // headings at q[2] and q[5] of nq = 6
    /// let law = Torsion { hinge: HingeRef { index: 0, a: 2, b: Some(5) }, k: 3.0 };
    /// let (mut dq, mut dqd) = (vec![0.0; 36], vec![0.0; 36]);
    /// assert!(law.jacobian(0.0, &[0.0; 3], &[0.0; 6], &[0.0; 6], &mut dq, &mut dqd));
    /// assert_eq!((dq[2 * 6 + 2], dq[2 * 6 + 5]), (-3.0, 3.0));
    /// ```
    fn jacobian(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        let _ = (t, wave, q, qd, dq, dqd);
        false
    }

    /// Whether the force depends on time alone, at every state the same (a
    /// motor's torque `w(t)`, a torque on a body, a uniform field): its
    /// Jacobian is zero everywhere, and the forward sensitivities
    /// ([`crate::sensitivity`]) neither take it nor difference the force
    /// along `S`. The default: `false`. A law that says `true` adds
    /// nothing in [`ForceLaw::jacobian`].
    fn time_only(&self) -> bool {
        false
    }

    /// How the force depends on time at a fixed state (constant, periodic
    /// with a period \[s\], or neither), for the analyses' forcing; `None`
    /// (the default) when ezy cannot see into the law.
    fn periodicity(&self) -> Option<Periodicity> {
        None
    }

    /// The times \[s\] on which the force is defined, `(first, last)`:
    /// its waveforms' ([`super::Waveform::span`]; a table that does not
    /// extrapolate is defined on its times only). A run over `[0, t_end]`
    /// outside them is refused before it starts. The default: everywhere.
    fn span(&self) -> (f64, f64) {
        (f64::NEG_INFINITY, f64::INFINITY)
    }

    /// The highest angular frequency \[rad/s\] at which the force is
    /// driven in time (a harmonic motor's `omega`), for the check that a
    /// fixed step samples it (more than two steps per period); the default
    /// reads it from [`ForceLaw::periodicity`] (`2 pi / period`, 0 when
    /// constant, aperiodic or not known).
    fn forcing_omega(&self) -> f64 {
        match self.periodicity() {
            Some(Periodicity::Period(p)) if p > 0.0 => 2.0 * std::f64::consts::PI / p,
            _ => 0.0,
        }
    }

    /// The shortest time scale of the law's linear terms against the mass
    /// diagonal `mass` (nq) \[kg, kg m^2\] ([`TimeScale`]), used to name a
    /// law too fast for the run when the step size collapses
    /// ([`crate::error::SimError::with_fast_law`]); `None` (the default) for a law
    /// without one.
    fn time_scale(&self, _mass: &[f64]) -> Option<TimeScale> {
        None
    }

    /// The coordinates a force that depends on time alone acts on (a body
    /// torque, gravity): its power is `f . qd`, so `dP/dqd = f` there.
    /// Empty (the default) for every other law.
    fn constant_force_coords(&self) -> Vec<usize> {
        Vec::new()
    }

    /// The law as the right-hand side keeps it. Leave the default (behind
    /// an `Arc<dyn ForceLaw>`, [`Law::User`]); each built-in family
    /// returns its own variant of the hot enum [`Law`].
    fn into_law(self) -> Law
    where
        Self: Sized,
    {
        Law::User(UserLaw(Arc::new(self)))
    }
}

/// An effect kind, as scene files write it: the fields of its
/// `[effects.NAME]` table (read through serde, `kind` excepted) and how
/// they resolve against a model. The built-in kinds implement it (the
/// registry, [`super::registry`]); register one of your own with
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

    /// Checks the fields against the model's names and the numbers
    /// against their ranges, before any model is built (a scene file's
    /// check): the names through `cx`'s lookups. The default checks
    /// nothing ([`EffectKind::resolve`] still does). Every caller of
    /// [`EffectKind::resolve`] in ezy calls this first.
    ///
    /// # Errors
    /// A [`SpecError`] naming the field at fault.
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        let _ = cx;
        Ok(())
    }

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

/// `kind` checked ([`EffectKind::check`]) and resolved against `cx` into
/// the law the right-hand side keeps ([`ForceLaw::into_law`]): the one
/// way ezy resolves a kind, built-in or the user's.
///
/// # Errors
/// The [`SpecError`] of either step.
pub(crate) fn resolve_kind<K: EffectKind>(kind: &K, cx: &EffectContext<'_>) -> Result<Law, SpecError> {
    kind.check(&cx.check_context())?;
    Ok(kind.resolve(cx)?.into_law())
}

/// What the effects reference page says of a built-in kind (its row of
/// `docs/book/src/reference/effects.md`, generated from
/// [`REFERENCE`](super::registry::REFERENCE)): a built-in kind implements
/// it beside [`EffectKind`].
pub trait Reference {
    /// The keys of its table, with units and defaults in parentheses
    /// (every key serde reads is named: `tests/docs.rs` checks it).
    const KEYS: &'static str;
    /// Its force law, with what its columns hold where that is not plain.
    const LAW: &'static str;
}

/// The time scale of a linear force law on the masses it acts on: what
/// a step must resolve (an explicit method is stable only for steps of
/// about this size or below).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeScale {
    /// The time scale \[s\]: `sqrt(m / |k|)` for a stiffness `k`, `m / c`
    /// for a damping `c`.
    pub seconds: f64,
    /// The key of the effect that sets it (`stiffness`, `damping`, `c`,
    /// `c_rot`, `c_along`, `c_across`).
    pub key: &'static str,
    /// Its value.
    pub value: f64,
    /// The mass or inertia it acts on: the smallest positive entry of the
    /// mass diagonal at the law's coordinates \[kg or kg m^2\].
    pub mass: f64,
}

impl TimeScale {
    /// The smallest positive finite entry of the mass diagonal `mass` (nq)
    /// at the coordinates `coords` \[kg or kg m^2\]; `None` where all are
    /// massless.
    pub fn smallest_mass(mass: &[f64], coords: impl IntoIterator<Item = usize>) -> Option<f64> {
        coords
            .into_iter()
            .filter_map(|k| mass.get(k).copied())
            .filter(|m| *m > 0.0 && m.is_finite())
            .min_by(f64::total_cmp)
    }

    /// `best`, or the time scale of the coefficient `key` = `value` on the
    /// mass `m` if that is shorter (strictly: the first of equals stays):
    /// `sqrt(m / |value|)` for a stiffness, `m / |value|` for a damping.
    /// Nothing for no mass, or a zero or non-finite coefficient.
    #[must_use]
    pub fn shorter(best: Option<Self>, m: Option<f64>, key: &'static str, value: f64, stiffness: bool) -> Option<Self> {
        let Some(m) = m else { return best };
        if value == 0.0 || !value.is_finite() {
            return best;
        }
        let seconds = if stiffness { (m / value.abs()).sqrt() } else { m / value.abs() };
        if best.is_none_or(|b| seconds < b.seconds) { Some(TimeScale { seconds, key, value, mass: m }) } else { best }
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
