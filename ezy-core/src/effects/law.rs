//! The hot enum: a resolved law as the right-hand side keeps it
//! ([`Law`]), one variant per law family holding that family's law
//! struct, and one for the laws of the user's own; with the loops the
//! right-hand sides call over a run's effects (`apply_effects`, and
//! `hinge_torques` for the fused right-hand side on the minimal
//! coordinates).
//!
//! Static dispatch, and why. Every family's law struct implements
//! [`ForceLaw`], the trait a user's law implements; the right-hand side
//! reaches it through a `match` on [`Law`] whose arms call the family's
//! `#[inline(always)]` [`ForceLaw::apply_with`], so a built-in law costs
//! what the one big `match` over every law cost before the families were
//! split out (one jump, no virtual call, the law's arithmetic inlined into
//! the loop), and the fused path hands hinge torques to the model's
//! generated code, which needs to see that every effect is a hinge law
//! ([`Law::Hinge`]) to fold away the rest. Behind `dyn ForceLaw` every
//! built-in law would cost an indirect call per evaluation and the fused
//! path could not tell hinge laws apart; the laws of the user's own take
//! that call ([`Law::User`]). Measured before and after the split
//! (`ezy bench drive`, `ezy bench drive-rolling-resistance` and `cargo
//! bench --bench effects`, alternating runs on a loaded machine): every
//! ratio within 0.95 to 1.03, the noise of repeated runs
//! (`docs/dev/performance.md`, "Effects by family").
//!
//! A new law in an existing family touches its family's file only; a new
//! family adds its file and one line to the `families!` list below.

use std::sync::Arc;

use super::Effect;
use super::blade::BladeLaw;
use super::body::BodyLaw;
use super::drag::DragLaw;
use super::hinge::HingeLaw;
use super::kind::{ForceLaw, Waveforms};
use super::skate_friction::SkateFrictionLaw;
use super::spring::SpringLaw;
use crate::error::SetupError;
use crate::error::SimError;

/// The hot enum [`Law`] over the families' law structs, with its
/// conversions and its dispatch: one line per family.
macro_rules! families {
    ($( $(#[$doc:meta])* $variant:ident($law:ty), )*) => {
        /// A resolved force law (indices into `q`, body-frame geometry): a
        /// family's law struct, or a law of the user's own.
        #[derive(Debug, Clone, PartialEq)]
        pub enum Law {
            $( $(#[$doc])* $variant($law), )*
            /// A law of the user's own ([`ForceLaw`]), behind one virtual call.
            User(UserLaw),
        }

        impl Law {
            /// The law as its trait object, for the queries off the hot
            /// path (coordinates, periodicity, time scale, failure).
            pub fn as_force_law(&self) -> &dyn ForceLaw {
                match self {
                    $( Law::$variant(l) => l, )*
                    Law::User(u) => &*u.0,
                }
            }

            /// [`ForceLaw::apply_with`] of the law, statically dispatched.
            #[inline(always)]
            pub fn apply_with(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
                match self {
                    $( Law::$variant(l) => l.apply_with(t, wave, q, qd, f), )*
                    Law::User(u) => u.0.apply_with(t, wave, q, qd, f),
                }
            }

            /// [`ForceLaw::jacobian`] of the law, statically dispatched:
            /// adds its exact `dF/dq` and `dF/dqd` (nq x nq each, row-major)
            /// into `dq` and `dqd` and returns `true`, or returns `false`
            /// (a law of the user's own without one: differences).
            #[inline]
            pub fn jacobian(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
                match self {
                    $( Law::$variant(l) => l.jacobian(t, wave, q, qd, dq, dqd), )*
                    Law::User(u) => u.0.jacobian(t, wave, q, qd, dq, dqd),
                }
            }

            /// [`ForceLaw::waveforms`] of the law, statically dispatched.
            #[inline(always)]
            pub fn waveforms(&self, t: f64) -> Waveforms {
                match self {
                    $( Law::$variant(l) => l.waveforms(t), )*
                    Law::User(u) => u.0.waveforms(t),
                }
            }
        }
    };
}

families! {
    /// A torque pair at a hinge ([`super::hinge`]).
    Hinge(HingeLaw),
    /// A force along a skate's blade at its contact point ([`super::blade`]).
    Blade(BladeLaw),
    /// A body load or a gravity field ([`super::body`]).
    Body(BodyLaw),
    /// Drag at a body or a body point ([`super::drag`]).
    Drag(DragLaw),
    /// A spring-damper-actuator between two ends ([`super::spring`]).
    Spring(SpringLaw),
    /// Coulomb friction at a skate ([`super::skate_friction`]): applied by
    /// the dynamics themselves, which hold the skate's mode; its own force
    /// is nothing.
    SkateFriction(SkateFrictionLaw),
}

impl Law {
    /// The waveforms' values at `t` \[s\] of `other` (the same effect in
    /// a problem at a nearby parameter value) as this law's moved toward
    /// it to first order ([`super::waveform::Waveform::eval3_toward`]):
    /// exact in `t` for harmonics; `other`'s own values for a law of
    /// another family or of the user's own (whose waveforms ezy cannot
    /// see into).
    pub fn waveforms_toward(&self, other: &Law, t: f64) -> Waveforms {
        match (self, other) {
            (Law::Hinge(a), Law::Hinge(b)) => a.waveforms_toward(b, t),
            (Law::Blade(a), Law::Blade(b)) => a.waveforms_toward(b, t),
            (Law::Body(a), Law::Body(b)) => a.waveforms_toward(b, t),
            (Law::Spring(a), Law::Spring(b)) => a.waveforms_toward(b, t),
            _ => other.waveforms(t),
        }
    }

    /// Whether [`Law::apply_toward`] differentiates this law toward
    /// `other` (the same effect in a problem at a nearby parameter
    /// value): a spring-damper whose ends stay on their bodies; `false`
    /// for the other families, whose forces the sensitivities difference.
    pub fn moves_toward(&self, other: &Law) -> bool {
        match (self, other) {
            (Law::Spring(a), Law::Spring(b)) => a.moves_toward(b),
            _ => false,
        }
    }

    /// The derivative of the law's generalized force at `(q, qd)` as its
    /// numbers move toward `other`'s to first order, added into `f` (nq),
    /// and of its power (returned), `wave` this law's waveforms' values
    /// and `toward` `other`'s linearized from them
    /// ([`Law::waveforms_toward`]): [`super::spring::SpringLaw::apply_toward`];
    /// where [`Law::moves_toward`] is `false`, nothing (and NaN).
    pub fn apply_toward(
        &self,
        other: &Law,
        waves: (&Waveforms, &Waveforms),
        q: &[f64],
        qd: &[f64],
        f: &mut [f64],
    ) -> f64 {
        match (self, other) {
            (Law::Spring(a), Law::Spring(b)) if a.moves_toward(b) => a.apply_toward(b, waves, q, qd, f),
            _ => f64::NAN,
        }
    }

    /// A law of the user's own for the effect `name` on a model with `nq`
    /// coordinates.
    ///
    /// # Errors
    /// [`SetupError::Effect`] if [`ForceLaw::coords`] lists a coordinate
    /// beyond the model's (the right-hand side and RADAU5's coupling index
    /// `q` with them).
    pub fn user(name: &str, law: Arc<dyn ForceLaw>, nq: usize) -> Result<Law, SimError> {
        Law::checked(name, Law::User(UserLaw(law)), nq)
    }

    /// `law`, for the effect `name` on a model with `nq` coordinates,
    /// once a law of the user's own is seen to index only those
    /// coordinates (a built-in law does by construction).
    ///
    /// # Errors
    /// As [`Law::user`].
    pub fn checked(name: &str, law: Law, nq: usize) -> Result<Law, SimError> {
        if let Law::User(u) = &law
            && let Some(k) = u.0.coords().into_iter().find(|&k| k >= nq)
        {
            return Err(SimError::Setup(SetupError::Effect {
                effect: name.to_string(),
                field: "",
                message: format!("the law's coords() lists coordinate {k}, but the model has {nq}"),
            }));
        }
        Ok(law)
    }
}

/// A resolved law of the user's own, shared by the copies of its
/// effect (two are equal when they are the same law).
#[derive(Debug, Clone)]
pub struct UserLaw(pub Arc<dyn ForceLaw>);

impl PartialEq for UserLaw {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Adds each effect's generalized force at `(t, q, qd)` (nq each) to `f`
/// (nq) and writes its power \[W\] to `power` (one per effect), from the
/// effects' waveforms at `t` (`waves`, one per effect).
///
/// # Errors
/// [`SimError::EffectFailed`] if an effect gives no force at a finite state.
#[inline(always)]
pub(crate) fn apply_effects(
    effects: &[Effect],
    waves: &[Waveforms],
    t: f64,
    q: &[f64],
    qd: &[f64],
    f: &mut [f64],
    power: &mut [f64],
) -> Result<(), SimError> {
    for ((e, p), wave) in effects.iter().zip(power).zip(waves) {
        let value;
        (*p, value) = e.apply_with(t, wave, q, qd, f);
        // a NaN from a finite state is the effect's own failure (a
        // spring-damper of zero length); so is an infinite power or a
        // value for its column that is not finite (a law of the user's
        // own: it would reach the CSV); a non-finite state is reported
        // where the state is checked
        if !(p.is_finite() && value.is_finite()) && q.iter().chain(qd).all(|v| v.is_finite()) {
            return Err(effect_failed(e, t, q, *p, value));
        }
    }
    Ok(())
}

/// The error of effect `e` whose power or value at `(t, q)` is not finite.
#[cold]
#[inline(never)]
fn effect_failed(e: &Effect, t: f64, q: &[f64], power: f64, value: f64) -> SimError {
    let reason = if power.is_nan() {
        e.failure(q)
    } else if !power.is_finite() {
        format!("gave a power of {power} W")
    } else {
        format!("gave {value} for its value column, which is not a finite number")
    };
    SimError::EffectFailed { t, effect: e.name.clone(), reason }
}

/// Adds each hinge effect's torque at `(t, q, qd)` (nq each) to its
/// hinge's entry of `tau` (nh, `ModelInfo::hinges`) and writes its power
/// \[W\] to `power` (one per effect), its waveforms evaluated at `t` (for
/// the fused right-hand side, `Model::minimal_rhs`; effects of other laws
/// are skipped: the caller passes only hinge effects). The torque is the
/// one [`HingeLaw::torque`] gives the generic path. A hinge law gives a
/// finite torque at a finite state, so nothing here fails.
#[inline(always)]
pub(crate) fn hinge_torques(effects: &[Effect], t: f64, q: &[f64], qd: &[f64], tau: &mut [f64], power: &mut [f64]) {
    for (e, p) in effects.iter().zip(power) {
        if !e.on {
            *p = 0.0;
        } else if let Law::Hinge(law) = &e.law {
            let (torque, rate) = law.torque_at(t, q, qd);
            tau[law.hinge.index] += torque;
            *p = torque * rate;
        }
    }
}

/// Whether every effect is a hinge law (or there is none): then the fused
/// right-hand side takes them as the hinges' torques ([`hinge_torques`]).
#[inline(always)]
pub(crate) fn hinges_only(effects: &[Effect]) -> bool {
    effects.iter().all(|e| matches!(e.law, Law::Hinge(_)))
}
