//! Coulomb friction at a skate (one family, one kind: `skate-friction`):
//! a knife edge that can slip. The spec [`SkateFriction`] implements
//! [`EffectKind`] and resolves to [`SkateFrictionLaw`]: the skate and its
//! friction limit `mu N`. Its force is not a function of the state: the
//! skate's mode (sticking or sliding) decides it, so the dynamics apply
//! it (`crate::formulation::friction`: a sliding skate's constraint row is released
//! and its Coulomb force added), and the law's own force here is nothing.

use serde::{Deserialize, Serialize};

use super::body::{default_gravity, is_default_gravity};
use super::context::{Blade, CheckContext, EffectContext, SpecError, finite, non_negative};
use super::kind::{EffectKind, ForceLaw, Reference, Waveforms};
use super::law::Law;
use super::waveform::Periodicity;
use crate::names::fmt_value;

/// The largest friction coefficient a skate takes, 1e9.
///
/// Measured coefficients between solids stay below about 16 (clean copper
/// on copper in vacuum, where the surfaces weld; engineering pairs 0.05 to
/// 1.5): a larger `mu` only says that the skate does not slide, which the
/// ideal skate (no friction effect) models exactly, and values up to 1e9
/// serve that end (friction that never acts: `tests/friction.rs`). The
/// friction force `mu N` is summed with the forces of the size of the
/// weight, which keep a relative accuracy of `mu eps` against it: 2.2e-7
/// (six digits) at 1e9, none at 1e16. And a slide ends within `v / (mu g)`:
/// at `mu = 1e9` and 1 m/s that is 1e-10 s, still 3e4 times the shortest
/// step at t = 1 s ([`crate::settings::MAX_RATE`]). Measured on `sleigh-ice` (a
/// slide of 2 m/s): DOPRI5 ran to `mu = 1e13` and stopped from `1e14`
/// with "the step size fell"; at `mu = 1e300` every method stopped so,
/// RK4 with the friction's work `inf`, none naming `mu`.
pub const MAX_MU: f64 = 1e9;

/// Coulomb friction at a skate (`skate-friction`; a knife edge that can
/// slip, `crate::formulation::friction`): the skate holds while the lateral force it
/// needs, `|lambda|`, is at most `mu N`; beyond that it slides sideways
/// against the force `mu N`, and it sticks again where the slip velocity
/// returns to zero with a holding force within the limit. Both switches
/// are located events. The normal load `N` \[N\] is `normal`, or the static
/// share `share` (0 < share <= 1) of the whole model's weight `m g`. Its
/// value column is the lateral force on the skate \[N\] (along the blade's
/// left normal); its work state the friction's work (negative: it
/// dissipates).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkateFriction {
    /// Skate name.
    pub skate: String,
    /// Friction coefficient, from 0 to [`MAX_MU`] (1e9: see there).
    pub mu: f64,
    /// Normal load \[N\] (or give `share`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<f64>,
    /// Share of the model's weight the skate carries (or give `normal`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub share: Option<f64>,
    /// Gravitational acceleration for `share` \[m/s^2\].
    #[serde(default = "default_gravity", skip_serializing_if = "is_default_gravity")]
    pub g: f64,
}

/// Coulomb friction at a skate, resolved against a model: the family's
/// law struct, in the hot enum as [`Law::SkateFriction`]. Applied by the
/// dynamics, which hold the skate's mode; its own force is nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct SkateFrictionLaw {
    /// Index of the skate in `ModelInfo::skates`.
    pub skate: usize,
    /// The skate's blade.
    pub blade: Blade,
    /// The friction limit `mu N` \[N\].
    pub limit: f64,
}

impl ForceLaw for SkateFrictionLaw {
    /// Nothing: the dynamics apply the friction force (see the module).
    #[inline(always)]
    fn apply(&self, _t: f64, _q: &[f64], _qd: &[f64], _f: &mut [f64]) -> (f64, f64) {
        (0.0, 0.0)
    }

    /// Exact: the law's own force is nothing, so is its derivative (the
    /// analyses take every skate as holding: its row stays in the KKT
    /// system, differentiated with the model's terms).
    fn jacobian(&self, _t: f64, _wave: &Waveforms, _q: &[f64], _qd: &[f64], _dq: &mut [f64], _dqd: &mut [f64]) -> bool {
        true
    }

    fn coords(&self) -> Vec<usize> {
        self.blade.body.to_vec()
    }

    fn failure(&self, _q: &[f64]) -> String {
        super::kind::NOT_A_NUMBER.into()
    }

    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }

    fn into_law(self) -> Law {
        Law::SkateFriction(self)
    }
}

/// A friction coefficient from 0 to [`MAX_MU`].
fn friction_coefficient(v: f64) -> Result<(), SpecError> {
    SpecError::check(!v.is_finite() || v <= MAX_MU, "mu", || {
        format!(
            "mu = {} is not a friction coefficient: give a number from 0 to {MAX_MU:e} (measured ones stay below about 16; for a skate that never slides, leave out its friction effect: the ideal skate)",
            fmt_value(v)
        )
    })?;
    non_negative("mu", v)
}

impl EffectKind for SkateFriction {
    type Law = SkateFrictionLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.skate("skate", &self.skate)?;
        friction_coefficient(self.mu)?;
        match (self.normal, self.share) {
            (Some(n), None) => non_negative("normal", n),
            (None, Some(share)) => {
                SpecError::check(share.is_finite() && share > 0.0 && share <= 1.0, "share", || {
                    format!("share = {} must be a fraction of the weight, 0 < share <= 1", fmt_value(share))
                })?;
                let g = self.g;
                SpecError::check(g.is_finite() && g > 0.0, "g", || {
                    format!("g = {} must be a positive acceleration [m/s^2]", fmt_value(g))
                })?;
                finite("g", g)
            }
            (Some(_), Some(_)) => Err(SpecError {
                field: "share",
                message: "give the normal load either as `normal` [N] or as `share` of the weight, not both".into(),
            }),
            (None, None) => Err(SpecError {
                field: "normal",
                message: "a skate with friction needs its normal load: `normal` [N], or `share` of the weight".into(),
            }),
        }
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<SkateFrictionLaw, SpecError> {
        let skate = cx.check_context().skate("skate", &self.skate)?;
        let mass = cx.mass();
        // the weight of the whole model: each body's mass once
        let weight = || self.g * cx.info().bodies.iter().map(|b| mass[b.coords[0]]).sum::<f64>();
        let normal = self.normal.unwrap_or_else(|| self.share.unwrap_or(1.0) * weight());
        Ok(SkateFrictionLaw { skate, blade: cx.blade(skate), limit: self.mu * normal })
    }
}

impl Reference for SkateFriction {
    const KEYS: &'static str =
        "`skate` (or a family `\"S[*]\"`), `mu`, and `normal` [N] or `share` of the weight (with `g` [m/s^2], 9.80665)";
    const LAW: &'static str = "Coulomb friction: the skate sticks while its lateral force is below `mu N` and slides against `mu N` beyond it, switching at located events ([Skates that slip](../friction.md)); columns `F_<name>`, `v_slip_<skate>`, `sliding_<skate>`, work `W_<name>`";
}
