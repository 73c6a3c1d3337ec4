//! Applied forces (effects): documented force laws a scene lists by name.
//!
//! Each effect adds its generalized force into `f` (nq) and returns its
//! power `P = f_e . qd` \[W\]; the right-hand side integrates each power into
//! the effect's own work state `W_<name>` \[J\], so that `T - T0 = sum W`
//! holds for any combination (ideal constraints do no work; docs/physics.md §8).
//! Only the effects a scene lists are built; the right-hand side loops over
//! exactly those, so an effect the scene does not name costs nothing.
//!
//! Conventions (docs/physics.md §1, §8): a force `F` (world frame) at a body point with
//! body-frame offset `p` from the centre of mass acts on the body's
//! coordinates `(x, y, phi)` as `(F_x, F_y, r_x F_y - r_y F_x)` with
//! `r = R(phi) p`; its power is `F . v_P`. A hinge torque `tau` acts `+tau`
//! on the hinge's first body and `-tau` on its second (as the `drive` scene's motor),
//! and the hinge angle is `theta = phi_a - phi_b` (`phi_a` for a ground
//! hinge), so a hinge torque's power is `tau theta_dot`.
//!
//! The module map (it imports the error, scalar and model-description
//! types only, never the `Model` trait or the dynamics; its floor is in
//! docs/dev/architecture.md):
//!
//! - [`kind`]: the traits a law implements, the user's and ezy's alike:
//!   [`ForceLaw`] (the law the right-hand side calls), [`EffectKind`] (its
//!   scene table, read by serde, and how it resolves), [`Reference`] (a
//!   built-in kind's row of the reference page), [`Controller`] (a
//!   closure as a law).
//! - [`registry`]: THE list of built-in kinds, one line each; the scene's
//!   enum of specs [`EffectSpec`], [`EFFECT_KINDS`] and the reference
//!   rows are made from it.
//! - one file per law family, each kind a spec struct implementing
//!   [`EffectKind`] and the family's law struct implementing
//!   [`ForceLaw`]: [`hinge`] (motor, spring, damper, servo), [`blade`]
//!   (rolling resistance, driven wheel), [`body`] (force, torque, slope,
//!   gravity), [`drag`] (linear, quadratic, anisotropic),
//!   [`spring`] (spring-damper-actuator), [`skate_friction`].
//! - `jacobian`: the blocks a law's exact Jacobian
//!   ([`ForceLaw::jacobian`]) adds into, and the chain rule of a force at
//!   a body point the built-in laws share.
//! - [`law`]: the hot enum [`Law`] over the families' law structs
//!   (static dispatch; the module says why), and the loops the
//!   right-hand sides call.
//! - [`context`]: what kinds check and resolve against
//!   ([`CheckContext`], [`EffectContext`]), the handles laws keep
//!   ([`HingeRef`], [`Blade`]) and what is wrong with a spec
//!   ([`SpecError`]).
//! - `waveform`: time functions ([`Waveform`]).

pub mod blade;
pub mod body;
pub mod context;
pub mod drag;
pub mod hinge;
pub(crate) mod jacobian;
pub mod kind;
pub mod law;
pub mod registry;
pub mod skate_friction;
pub mod spring;
pub(crate) mod user;
pub(crate) mod waveform;

pub use blade::*;
pub use body::*;
pub use context::{Blade, CheckContext, EffectContext, HingeRef, SpecError};
pub use drag::*;
pub use hinge::*;
pub use kind::{Controller, EffectKind, ForceLaw, Reference, TimeScale, Waveforms};
pub use law::{Law, UserLaw};
pub use registry::{EFFECT_KINDS, EffectSpec, KindReference, REFERENCE, check_effect_name};
pub use skate_friction::*;
pub use spring::*;
pub use user::UserSpec;
pub use waveform::{Extrapolate, Harmonic, Linear, OrbitTiming, Periodicity, Spline, SplineData, Table, Waveform};

/// An effect resolved against a model, ready for the right-hand side.
#[derive(Debug, Clone, PartialEq)]
pub struct Effect {
    /// The scene's name for it (`W_<name>` is its work column).
    pub name: String,
    /// Name of its output column (see [`EffectSpec::value_column`]).
    pub value_column: String,
    /// The force law.
    pub law: Law,
    /// Whether it acts. An effect switched off (by an event's
    /// `switch_off`, `crate::events::spec::Action::Switch`, or by a library
    /// user before the run) adds no force, its power is 0 (its work state
    /// holds) and its value column reads 0. `simulate` restores each
    /// effect's setting at the run's end.
    pub on: bool,
}

impl Effect {
    /// Adds this effect's generalized force at `(t, q, qd)` into `f` (nq)
    /// and returns `(power [W], value)`, `value` being the effect's output
    /// quantity ([`Effect::value_column`]).
    #[inline]
    pub fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &self.waveforms(t), q, qd, f)
    }

    /// The values at time `t` \[s\] of the effect's waveforms
    /// ([`ForceLaw::waveforms`]: a motor's torque, a servo's target angle
    /// and rate, a driven blade's force, a force's two components, a
    /// torque, a spring-damper's added tension; zeros for an effect
    /// without one).
    #[inline(always)]
    pub fn waveforms(&self, t: f64) -> Waveforms {
        self.law.waveforms(t)
    }

    /// [`Effect::apply`] with the waveforms' values `wave` at the time `t`
    /// \[s\] of the state ([`Effect::waveforms`]); nothing while the
    /// effect is off.
    #[inline(always)]
    pub fn apply_with(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        if !self.on {
            return (0.0, 0.0);
        }
        self.law.apply_with(t, wave, q, qd, f)
    }

    /// The effect's exact Jacobian at `(t, q, qd)` with its waveforms'
    /// values `wave` ([`ForceLaw::jacobian`]): adds `dF/dq` and `dF/dqd`
    /// (nq x nq each, row-major) into `dq` and `dqd` and returns `true`;
    /// `false` (nothing added) for a law without one. An effect switched
    /// off adds nothing and returns `true` (its force is zero).
    #[inline]
    pub fn jacobian(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        if !self.on {
            return true;
        }
        self.law.jacobian(t, wave, q, qd, dq, dqd)
    }

    /// How the effect's force depends on time at a fixed state
    /// ([`ForceLaw::periodicity`]): through its waveforms (a motor's
    /// torque, a servo's angle, a force's components); `None` for a law of
    /// the user's own that does not say.
    pub fn periodicity(&self) -> Option<Periodicity> {
        self.law.as_force_law().periodicity()
    }

    /// The times \[s\] on which the effect's force is defined
    /// ([`ForceLaw::span`]).
    pub fn span(&self) -> (f64, f64) {
        self.law.as_force_law().span()
    }

    /// The highest angular frequency \[rad/s\] driving the force in time
    /// ([`ForceLaw::forcing_omega`]; 0 for a force constant in time).
    pub fn forcing_omega(&self) -> f64 {
        self.law.as_force_law().forcing_omega()
    }

    /// The coordinates a force that depends on time alone acts on (a body
    /// torque, gravity or a slope): its power is `f . qd`, so `dP/dqd = f`
    /// there. Empty for every other effect ([`Effect::coords`]).
    pub fn constant_force_coords(&self) -> Vec<usize> {
        self.law.as_force_law().constant_force_coords()
    }

    /// The coordinates this effect's force depends on or acts on (its
    /// coupling in the Jacobian of the applied forces; empty for a force
    /// that depends on time alone), sorted, each once.
    pub fn coords(&self) -> Vec<usize> {
        let mut out = self.law.as_force_law().coords();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Why this effect's power came out NaN at `q` (for the error that
    /// stops the run; a spring-damper of zero length has no direction).
    pub fn failure(&self, q: &[f64]) -> String {
        self.law.as_force_law().failure(q)
    }

    /// The shortest time scale of the effect's linear terms (hinge
    /// springs, dampers and servos, viscous skate and drag laws,
    /// spring-dampers) against the mass diagonal `mass` (nq); `None` for
    /// other laws and for laws on massless coordinates only. Used to name
    /// a law too fast for the run when the step size collapses
    /// (`SimError::with_fast_law`).
    pub fn time_scale(&self, mass: &[f64]) -> Option<TimeScale> {
        self.law.as_force_law().time_scale(mass)
    }

    /// For a spring-damper: the world positions of its two ends at `q`
    /// \[m\], each with whether it is a fixed ground point (what `ezy
    /// animate` draws as a zig-zag); `None` for every other effect.
    pub fn spring_ends(&self, q: &[f64]) -> Option<[([f64; 2], bool); 2]> {
        match &self.law {
            Law::Spring(s) => Some(s.ends_at(q)),
            _ => None,
        }
    }

    /// Name of the effect's work column, `W_<name>` \[J\].
    pub fn work_column(&self) -> String {
        crate::names::work_name(&self.name)
    }
}
