//! Events while a run steps, with the step loop: a quantity's
//! value at a state ([`Event::value`], through the DAE's
//! [`Dynamics`]), its crossing located on the dense output ([`locate`]:
//! Anderson-Björck regula falsi, as SciPy's `solve_ivp` and Hairer's
//! SOLOUT), and the per-run bookkeeping of crossings, chatter and records
//! (`Monitor`). What an event *is* (its spec, direction, action,
//! records) sits below, in [`crate::events::spec`].

use crate::error::SimError;
use crate::events::spec::{Action, CHATTER_STEPS, Event, EventRecord, Quantity, max_records};
use crate::formulation::dae::Dynamics;
use crate::model::Model;

impl Event {
    /// `g = quantity - level` at the time `t` \[s\] and state `y` (ny) of
    /// the run `sys`; `scratch` holds points or forces between calls.
    pub fn value<M: Model>(&self, sys: &Dynamics<M>, t: f64, y: &[f64], scratch: &mut Vec<f64>) -> f64 {
        let nq = sys.nq();
        let (q, qd) = (&y[..nq], &y[nq..2 * nq]);
        let v = match &self.quantity {
            Quantity::Time => t,
            Quantity::State(k) => y[*k],
            Quantity::HingeAngle(h) => h.angle(q),
            Quantity::HingeRate(h) => h.rate(qd),
            Quantity::Point { index, axis } => {
                scratch.resize(2 * sys.info.points.len(), 0.0);
                sys.model.points(q, scratch);
                scratch[2 * index + axis]
            }
            Quantity::PointVelocity { index, axis } => {
                scratch.resize(2 * sys.info.points.len(), 0.0);
                sys.model.point_velocities(q, qd, scratch);
                scratch[2 * index + axis]
            }
            Quantity::EffectValue(k) => {
                scratch.clear();
                scratch.resize(nq, 0.0);
                sys.effects[*k].apply(t, q, qd, scratch).1
            }
            Quantity::KineticEnergy => sys.kinetic_energy(qd),
            Quantity::User(g) => g(t, q, qd),
        };
        v - self.level
    }
}

/// Finds where `g` changes sign in `(a, b]` given `ga = g(a)` of one sign
/// (not zero) and `gb = g(b)` of the other or zero: the end of a bracket
/// `[a', b']` no wider than a few units of rounding of `b'`, at which `g`
/// has `gb`'s sign or is zero (Anderson-Björck regula falsi; at most 200
/// evaluations, each halving the bracket at worst).
///
/// # Errors
/// Whatever `g` fails with.
pub fn locate<E>(
    mut g: impl FnMut(f64) -> Result<f64, E>,
    mut a: f64,
    mut ga: f64,
    mut b: f64,
    mut gb: f64,
) -> Result<f64, E> {
    let before = ga.signum();
    for k in 0..200 {
        if gb == 0.0 || b - a <= 4.0 * f64::EPSILON * a.abs().max(b.abs()) {
            break;
        }
        // the secant through the bracket's ends; bisection every few
        // iterations and whenever the secant falls outside
        let mut c = b - gb * (b - a) / (gb - ga);
        if !(c > a && c < b) || k % 8 == 7 {
            c = 0.5 * (a + b);
        }
        let gc = g(c)?;
        if gc == 0.0 || gc.signum() != before {
            // the root is in (a, c]
            b = c;
            gb = gc;
        } else {
            // in (c, b]: the Anderson-Björck weight on the kept end
            let m = 1.0 - gc / ga;
            gb *= if m > 0.0 { m } else { 0.5 };
            a = c;
            ga = gc;
        }
    }
    Ok(b)
}

/// An event found in a step: its index in the run's events, its time and
/// whether it rose.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Crossing {
    pub event: usize,
    pub t: f64,
    pub rising: bool,
}

/// The run's watch over its events: `g` at the last accepted state, the
/// steps in a row with an event, the records.
#[derive(Debug, Default)]
pub(crate) struct Monitor {
    /// `g` of each event at the last accepted state.
    pub left: Vec<f64>,
    /// `g` of each event at the step's end.
    pub right: Vec<f64>,
    /// Scratch of [`Event::value`].
    pub scratch: Vec<f64>,
    /// The events found in the step, by time.
    pub found: Vec<Crossing>,
    /// For each event, the accepted steps in a row in which it fired and
    /// the time the first of them ended.
    pub streaks: Vec<(u64, f64)>,
    /// Whether any streak is open (so a step without an event resets them).
    pub streaking: bool,
    /// The records.
    pub records: Vec<EventRecord>,
    /// Most records kept ([`max_records`]).
    pub limit: usize,
}

impl Monitor {
    /// Watches the events of `sys` from the state `y` at `t`.
    pub fn new<M: Model>(sys: &Dynamics<M>, t: f64, y: &[f64]) -> Self {
        let mut m = Monitor { limit: max_records(y.len()), ..Monitor::default() };
        m.left = sys.events.iter().map(|e| e.value(sys, t, y, &mut m.scratch)).collect();
        m.right = m.left.clone();
        m.streaks = vec![(0, t); sys.events.len()];
        m
    }

    /// After a step without an event: every streak ends.
    #[inline]
    pub fn quiet_step(&mut self) {
        if self.streaking {
            self.streaks.iter_mut().for_each(|s| s.0 = 0);
            self.streaking = false;
        }
    }

    /// Whether any event's sign changed between the last accepted state
    /// and the accepted state `y` at `t`: fills `right` (no location yet).
    #[inline]
    pub fn any_crossing<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> bool {
        let mut any = false;
        for ((e, l), r) in sys.events.iter().zip(&self.left).zip(&mut self.right) {
            // a switch cuts the step: the run's switch watch has it
            if e.action == Action::Switch {
                continue;
            }
            *r = e.value(sys, t, y, &mut self.scratch);
            any |= e.direction.crossing(*l, *r).is_some();
        }
        any
    }

    /// After a step ending at `t` \[s\] in which the events `fired`
    /// (indices into `events`) were found: each one's streak grows, the
    /// others' end; a streak of [`CHATTER_STEPS`] stops the run.
    ///
    /// # Errors
    /// [`SimError::Chattering`] naming the event.
    pub fn count_step(&mut self, events: &[Event], t: f64, fired: &[Crossing]) -> Result<(), SimError> {
        for (k, s) in self.streaks.iter_mut().enumerate() {
            if !fired.iter().any(|c| c.event == k) {
                s.0 = 0;
                continue;
            }
            if s.0 == 0 {
                s.1 = t;
            }
            s.0 += 1;
            if s.0 >= CHATTER_STEPS {
                return Err(SimError::Chattering { event: events[k].name.clone(), t0: s.1, t1: t, steps: s.0 });
            }
        }
        self.streaking = true;
        Ok(())
    }

    /// Keeps a record.
    ///
    /// # Errors
    /// [`SimError::EventLimit`] past [`Monitor::limit`] records.
    pub fn record(&mut self, name: &str, t: f64, rising: bool, y: &[f64]) -> Result<(), SimError> {
        if self.records.len() >= self.limit {
            return Err(SimError::EventLimit { event: name.to_string(), t, limit: self.limit });
        }
        self.records.push(EventRecord { name: name.to_string(), t, rising, y: y.to_vec() });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locate_finds_a_root_to_rounding_with_the_new_sign() {
        let g = |t: f64| -> Result<f64, ()> { Ok((t - 0.3).powi(3) + 0.1 * (t - 0.3)) };
        let t = locate(g, 0.0, g(0.0).unwrap(), 1.0, g(1.0).unwrap()).unwrap();
        assert!((t - 0.3).abs() <= 4.0 * f64::EPSILON, "{t}");
        assert!(g(t).unwrap() >= 0.0);
        // a root at the bracket's end
        let t = locate(|t: f64| Ok::<_, ()>(t - 1.0), 0.0, -1.0, 1.0, 0.0).unwrap();
        assert_eq!(t, 1.0);
        // falling, steep and flat parts
        let h = |t: f64| -> Result<f64, ()> { Ok((2.0 - t).tanh() * 1e-3) };
        let t = locate(h, 1.0, h(1.0).unwrap(), 5.0, h(5.0).unwrap()).unwrap();
        assert!((t - 2.0).abs() <= 8.0 * f64::EPSILON, "{t}");
        assert!(h(t).unwrap() <= 0.0);
    }
}
