//! The run's energy guard: the balance `|T - T0 - W|` measured against the
//! problem's own energy scale, never against an absolute amount of joules.
//!
//! Ideal constraints do no work, so `T - T0 - W` (`W`: the work of every
//! effect and drive, integrated as states) is the integration's own error.
//! What it is compared with decides whether the guard is right:
//!
//! - the energies the run has handled so far, [`EnergyGuard::scale`]: the
//!   largest kinetic energy `T` and the largest ledger `T0 + sum_e |W_e|`
//!   (the initial kinetic energy, the work a motor did, the energy a damper
//!   took, the potential energy gravity turned into motion); it grows with
//!   the masses, so a sleigh of 1e14 kg is measured in units of its own
//!   1e14 J, not in joules;
//! - at least the work the applied forces do over the mechanism's size,
//!   `sum_i |f_i| l_i` (`l_i` the largest distance of a named point from
//!   its body's centre of mass for `x, y`, 1 rad for `phi`), evaluated only
//!   when the first measure fails: a mechanism at rest, or in its first
//!   steps from rest, has energies at the rounding level or of order `h^2`
//!   and a balance as large as they are, which is no reason to stop.
//!
//! The verdict ([`Verdict`]) separates a drift from a divergence: the
//! kinetic energy growing [`GROWTH_LIMIT`] times beyond everything the
//! run was given is energy the integration made, whatever the method; a
//! balance beyond the limit otherwise is a fixed step too large for the
//! scene, or the accumulated error of an adaptive method that met the
//! tolerance it was asked for at every step (a note, not an error).

use crate::formulation::dae::Dynamics;
use crate::model::Model;
use crate::settings::Method;

/// The factor by which the kinetic energy must exceed every energy the
/// run was given (the largest ledger `T0 + sum_e |W_e|` and the applied
/// forces' work over the mechanism's size) for the run to have diverged:
/// six orders of magnitude, beyond any drift a tolerance lets through
/// (that stays within a few times the scale) and well before an overflow.
pub const GROWTH_LIMIT: f64 = 1e6;

/// What the energy balance of one accepted state says ([`EnergyGuard::check`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Within the limit of the scale.
    Fine,
    /// `|T - T0 - W| = error` \[J\] is `relative` of the scale `scale` \[J\],
    /// beyond the limit, while `T` stays within what the run was given: a
    /// fixed step too large, or an adaptive method's accumulated drift.
    Balance {
        /// `error / scale`.
        relative: f64,
        /// `|T - T0 - W|` \[J\].
        error: f64,
        /// The energy scale \[J\].
        scale: f64,
        /// The limit `relative` passed.
        limit: f64,
    },
    /// The kinetic energy `kinetic` \[J\] is more than [`GROWTH_LIMIT`] times
    /// `given` \[J\], the most energy the run was given: the state itself
    /// grew beyond any scale the run has seen.
    Diverged {
        /// `T` \[J\].
        kinetic: f64,
        /// The largest ledger `T0 + sum_e |W_e|`, or the force scale if
        /// larger \[J\].
        given: f64,
    },
}

/// The energy balance's yardstick over a run: the scales seen so far and
/// the scratch to evaluate the force scale without allocating.
#[derive(Debug, Clone)]
pub struct EnergyGuard {
    /// `T0` \[J\].
    t0: f64,
    /// Largest `T0 + sum_e |W_e|` so far \[J\].
    ledger: f64,
    /// Largest `T` so far \[J\].
    kinetic: f64,
    /// Largest force scale evaluated so far \[J\] (0 before any).
    forces: f64,
    /// `|T - T0 - W| / scale` at the last state checked (0 before any).
    balance: f64,
    /// `l_i` per coordinate \[m or rad\].
    lengths: Vec<f64>,
    /// Scratch: the effects' powers.
    power: Vec<f64>,
}

impl EnergyGuard {
    /// The guard of a run of `sys` from `y0 = [q, qd, W_1 .. W_k]`.
    pub fn new<M: Model>(sys: &Dynamics<M>, y0: &[f64]) -> Self {
        let nq = sys.nq();
        let info = &sys.info;
        let mut points = vec![0.0; 2 * info.points.len()];
        let mut blades = vec![0.0; 2 * info.skates.len()];
        sys.model.local_geometry(&mut points, &mut blades);
        let size = points.chunks_exact(2).map(|p| p[0].hypot(p[1])).filter(|l| l.is_finite()).fold(0.0, f64::max);
        let mut lengths = vec![1.0; nq];
        for b in &info.bodies {
            lengths[b.coords[0]] = size;
            lengths[b.coords[1]] = size;
        }
        let t0 = sys.kinetic_energy(&y0[nq..2 * nq]);
        Self {
            t0,
            ledger: ledger(t0, &y0[2 * nq..]),
            kinetic: t0,
            forces: 0.0,
            balance: 0.0,
            lengths,
            power: vec![0.0; sys.effects.len()],
        }
    }

    /// The energy scale so far \[J\]: the largest of `T`, `T0 + sum_e |W_e|`
    /// and the force scale evaluated so far.
    pub fn scale(&self) -> f64 {
        self.ledger.max(self.kinetic).max(self.forces)
    }

    /// `|T - T0 - W| / scale` at the last state checked: how well the
    /// energy balance held up to there (0 before any).
    pub fn balance(&self) -> f64 {
        self.balance
    }

    /// The verdict on the accepted state `y` at `t` \[s\] with kinetic energy
    /// `kinetic` \[J\] and `|T - T0 - W| = error` \[J\] (both finite), against
    /// the relative limit `limit` (`None`: the scales and the balance are
    /// kept, the verdict is always [`Verdict::Fine`]). Evaluates the
    /// applied forces (into `sys`'s workspace) only when the balance fails
    /// the scales seen.
    pub fn check<M: Model>(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        y: &[f64],
        kinetic: f64,
        error: f64,
        limit: Option<f64>,
    ) -> Verdict {
        let nq = sys.nq();
        self.ledger = self.ledger.max(ledger(self.t0, &y[2 * nq..]));
        self.kinetic = self.kinetic.max(kinetic);
        self.balance = relative(error, self.scale());
        let Some(limit) = limit else { return Verdict::Fine };
        if error <= limit * self.scale() {
            return Verdict::Fine;
        }
        // the work the forces at hand do over the mechanism's size; an
        // effect that fails here fails the next step too, with its message
        if sys.applied_forces(t, &y[..nq], &y[nq..2 * nq], &mut self.power).is_ok() {
            let work: f64 = sys.applied_force().iter().zip(&self.lengths).map(|(f, l)| (f * l).abs()).sum();
            if work.is_finite() {
                self.forces = self.forces.max(work);
            }
        }
        self.balance = relative(error, self.scale());
        self.judge(kinetic, error, limit)
    }

    /// The verdict from the scales as they stand.
    fn judge(&self, kinetic: f64, error: f64, limit: f64) -> Verdict {
        let scale = self.scale();
        if error <= limit * scale {
            return Verdict::Fine;
        }
        // nothing given at all (no energy, no force) has no factor to grow by
        let given = self.ledger.max(self.forces);
        if given > 0.0 && kinetic > GROWTH_LIMIT * given {
            return Verdict::Diverged { kinetic, given };
        }
        Verdict::Balance { relative: relative(error, scale), error, scale, limit }
    }
}

/// `error / scale`, 0 for no error (`error <= 3 scale` always: `T`, `T0`
/// and `|W|` are each at most the scale).
fn relative(error: f64, scale: f64) -> f64 {
    if error == 0.0 { 0.0 } else { error / scale }
}

/// `T0 + sum_e |W_e|` \[J\]: the energy the run's ledger holds.
fn ledger(t0: f64, works: &[f64]) -> f64 {
    t0 + works.iter().map(|w| w.abs()).sum::<f64>()
}

/// The note an adaptive run gets the first time its energy balance passes
/// the limit `limit` (`method` with tolerances `rtol`, `atol`; at `t` \[s\],
/// `|T - T0 - W| = error` \[J\] is `relative` of the scale `scale` \[J\]).
pub fn drift_note(
    method: Method,
    rtol: f64,
    atol: f64,
    limit: f64,
    t: f64,
    [relative, error, scale]: [f64; 3],
) -> String {
    format!(
        "from t = {t:.6} s the energy balance |T - T0 - W| = {error:.3e} J is {relative:.3e} of the run's energy scale {scale:.3e} J (the largest energy it has handled), beyond {limit:e}: {} met rtol = {rtol:e}, atol = {atol:e} at every step and its error accumulates over the run; a tighter {} keeps the energy",
        method.name(),
        crate::settings::Setting::Rtol
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard(t0: f64, ledger: f64, kinetic: f64, forces: f64) -> EnergyGuard {
        EnergyGuard { t0, ledger, kinetic, forces, balance: 0.0, lengths: vec![], power: vec![] }
    }

    /// A common factor on every energy changes no verdict: the balance is
    /// measured in units of the problem's own energies.
    #[test]
    fn verdicts_do_not_depend_on_the_energy_unit() {
        for unit in [1e-30, 1.0, 1e14, 1e200] {
            assert_eq!(guard(unit, unit, unit, 0.0).judge(unit, 1e-3 * unit, 1e-2), Verdict::Fine);
            let v = guard(unit, unit, unit, 0.0).judge(unit, 0.05 * unit, 1e-2);
            assert!(matches!(v, Verdict::Balance { relative, .. } if (relative - 0.05).abs() < 1e-12), "{v:?}");
            let v = guard(unit, unit, 1e7 * unit, 0.0).judge(1e7 * unit, 1e7 * unit, 1e-2);
            assert!(matches!(v, Verdict::Diverged { .. }), "{v:?}");
        }
    }

    /// Energies at the rounding level under forces that could do joules of
    /// work are fine; a kinetic energy a million times what the run was
    /// given is a divergence, a smaller excess a balance error.
    #[test]
    fn the_force_scale_is_a_floor_and_growth_is_divergence() {
        assert_eq!(guard(0.0, 1e-37, 1e-37, 9.81).judge(1e-37, 1e-37, 1e-2), Verdict::Fine);
        assert!(matches!(guard(0.0, 0.0, 1e-30, 0.0).judge(1e-30, 1e-30, 1e-2), Verdict::Balance { .. }));
        assert!(matches!(guard(1.0, 1.0, 20.0, 0.0).judge(20.0, 19.0, 1e-2), Verdict::Balance { .. }));
        assert!(matches!(
            guard(1.0, 1.0, 2e6, 0.0).judge(2e6, 2e6, 1e-2),
            Verdict::Diverged { kinetic, given } if kinetic == 2e6 && given == 1.0
        ));
    }
}
