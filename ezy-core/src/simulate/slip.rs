//! The watch on what switches a run's forces or rows while it steps:
//! the skates with friction ([`crate::formulation::friction`]: each one's
//! margin) and the events that switch effects
//! ([`crate::events::spec::Action::Switch`]). A step in which one may
//! have switched is scanned on its continuous extension, cut at the
//! earliest switch ([`Run::locate_slip`]), and the run switched there
//! ([`Run::switch_slip`]); the step loop then restarts its method.

use crate::error::SimError;
use crate::formulation::dae::Dynamics;
use crate::formulation::friction::{MarginSample, MarginScan, SkateMode};
use crate::model::Model;
use crate::settings::ProjectionKind;
use crate::simulate::observer::{Observer, RunError};
use crate::simulate::run::Run;

/// Firings of one switching event, or with a fixed step switches of one
/// skate, at most this many accepted steps apart count as one streak;
/// [`crate::events::spec::CHATTER_STEPS`] of them in a row are chattering
/// ([`SimError::Chattering`], [`SimError::SlipChattering`]). (An adaptive
/// run's skate switches count by their intervals instead,
/// [`crate::formulation::friction::SwitchStreak`]: its margin is scanned inside every
/// step, so a fast stick-slip motion is resolved with few steps between
/// switches.)
pub const SLIP_CHATTER_GAP: u64 = 8;

/// Cuts of a step at a skate's switch in a row that each move the run on
/// by rounding only after which it stops ([`SimError::SlipChattering`]):
/// the skates' modes found at the cut are consistent by their rates, yet
/// the margin falls below zero at once.
const STALLED_CUTS: u32 = 16;

impl<'a, M: Model, O: Observer<M>> Run<'a, M, O> {
    /// Sets the watch on the switches of `sys` (when it has any) at the
    /// start `(t_start, y0)`: the margins and switch events' values there;
    /// the skates `start_slides` that slide at the start (as
    /// [`Dynamics::start_friction`] found them) recorded as events, and
    /// their rows released from the projection and the residuals.
    ///
    /// # Errors
    /// As [`Dynamics::slip_samples_at`]; [`SimError::EventLimit`].
    pub(super) fn watch_switches(
        &mut self,
        sys: &mut Dynamics<M>,
        y0: &[f64],
        start_slides: &[(usize, SkateMode, SkateMode)],
    ) -> Result<(), SimError> {
        if !sys.switches() {
            return Ok(());
        }
        let settings = self.settings;
        let (nf, w) = (sys.friction.len(), &mut self.slip);
        w.switches =
            (0..sys.events.len()).filter(|&k| sys.events[k].action == crate::events::spec::Action::Switch).collect();
        let n = nf + w.switches.len();
        (w.left, w.right, w.scratch, w.streaks) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; nf], vec![(0, 0.0, 0); n - nf]);
        (w.left_rate, w.right_rate, w.scratch_rate, w.eps) =
            (vec![0.0; nf], vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]);
        w.suspect = vec![false; nf];
        w.skate_streaks = vec![Default::default(); nf];
        w.times = vec![f64::INFINITY; n];
        w.t_left = self.t_start;
        if nf > 0 {
            let h = settings.dt.min(settings.t_end - self.t_start).max(f64::EPSILON);
            sys.slip_samples_at(self.t_start, h, y0, &mut w.left[..nf], &mut w.left_rate)?;
        }
        for (j, &k) in w.switches.iter().enumerate() {
            w.left[nf + j] = sys.events[k].value(sys, 0.0, y0, &mut w.values);
        }
        for &(k, old, mode) in start_slides {
            self.monitor.record(&sys.friction[k].transition_name(old), 0.0, mode.is_sliding(), y0)?;
        }
        let rows = sys.released_rows();
        self.proj.release(rows);
        self.resid.released.set(&sys.info.pattern, rows);
        Ok(())
    }

    /// Whether a skate's mode may have stopped holding in the accepted
    /// step ending at `t_new` with the full state `y_new`, or a switching
    /// event fired: a skate's margin
    /// ([`crate::formulation::friction::SkateFriction::margin`]) and its rate at the
    /// step's ends leave a violation inside the step possible
    /// ([`crate::formulation::friction::margin_suspect`]: it ends below zero, or comes
    /// within the step's travel of it), so the step's continuous extension
    /// is to be scanned ([`Run::locate_slip`]). `evaluated`: the
    /// right-hand side `dy` the last evaluation found at `y_new` (the
    /// DAE's), which is then not repeated. A step without moves the
    /// margins on.
    ///
    /// # Errors
    /// As [`Dynamics::rhs`].
    pub(super) fn slip_crossed(
        &mut self,
        sys: &mut Dynamics<M>,
        t_new: f64,
        y_new: &[f64],
        evaluated: Option<&[f64]>,
    ) -> Result<bool, SimError> {
        if self.slip.left.is_empty() {
            return Ok(false);
        }
        let rtol = if self.settings.method.is_adaptive() { self.settings.rtol } else { 0.0 };
        let w = &mut self.slip;
        let nf = sys.friction.len();
        if nf > 0 {
            let h = t_new - w.t_left;
            match evaluated {
                Some(dy) => sys.slip_samples_after(t_new, h, y_new, dy, &mut w.right[..nf], &mut w.right_rate)?,
                None => sys.slip_samples_at(t_new, h, y_new, &mut w.right[..nf], &mut w.right_rate)?,
            }
            let nq = sys.nq();
            sys.slip_tolerances(&y_new[nq..2 * nq], rtol, &mut w.eps);
            for k in 0..nf {
                let a = MarginSample { t: w.t_left, m: w.left[k], r: w.left_rate[k] };
                let b = MarginSample { t: t_new, m: w.right[k], r: w.right_rate[k] };
                w.suspect[k] = crate::formulation::friction::margin_suspect(&a, &b, w.eps[k]);
            }
        }
        for (j, &k) in w.switches.iter().enumerate() {
            w.right[nf + j] = sys.events[k].value(sys, t_new, y_new, &mut w.values);
        }
        let crossed = (0..w.left.len()).any(|k| w.crossing(sys, k).is_some());
        if !crossed {
            std::mem::swap(&mut w.left, &mut w.right);
            std::mem::swap(&mut w.left_rate, &mut w.right_rate);
            w.t_left = t_new;
        }
        Ok(crossed)
    }

    /// The earliest time in `(t, t_new]` at which a skate's margin falls
    /// through zero or a switching event fires ([`Run::slip_crossed`]),
    /// located on the step's continuous extension `interpolate(sys, t, y)`
    /// (full states): each suspect skate's margin scanned
    /// ([`crate::formulation::friction::scan_margin`]) and its first violation located
    /// as an event's crossing is ([`crate::simulate::events::locate`]). A margin the
    /// step does not resolve cuts it where it last was (no switch there),
    /// and limits the next steps ([`SlipWatch::h_max`](super::watch::SlipWatch::h_max)).
    ///
    /// # Errors
    /// As [`Dynamics::rhs`], and as `interpolate`.
    #[cold]
    pub(super) fn locate_slip(
        &mut self,
        sys: &mut Dynamics<M>,
        (t, t_new): (f64, f64),
        mut interpolate: impl FnMut(&Dynamics<M>, f64, &mut [f64]) -> Result<(), SimError>,
    ) -> Result<f64, SimError> {
        let mut t_switch = t_new;
        let (w, nf) = (&mut self.slip, sys.friction.len());
        w.times.fill(f64::INFINITY);
        w.full.resize(sys.ny(), 0.0);
        let h = t_new - t;
        for k in 0..w.left.len() {
            if w.crossing(sys, k).is_none() {
                continue;
            }
            let (l, r) = (w.left[k], w.right[k]);
            let x = &mut w.full;
            let te = if k < nf {
                let (margins, rates) = (&mut w.scratch, &mut w.scratch_rate);
                let a = MarginSample { t, m: l, r: w.left_rate[k] };
                let b = MarginSample { t: t_new, m: r, r: w.right_rate[k] };
                let scan = crate::formulation::friction::scan_margin(
                    a,
                    b,
                    w.eps[k],
                    |tau: f64| -> Result<MarginSample, SimError> {
                        interpolate(sys, tau, x)?;
                        sys.slip_samples_at(tau, h, x, margins, rates)?;
                        Ok(MarginSample { t: tau, m: margins[k], r: rates[k] })
                    },
                )?;
                match scan {
                    MarginScan::Holds => continue,
                    MarginScan::Unresolved { at, h_max } => {
                        t_switch = t_switch.min(at);
                        w.h_max = Some(w.h_max.map_or(h_max, |m| m.min(h_max)));
                        continue;
                    }
                    MarginScan::Crosses { lo, hi } => {
                        let g = |tau: f64| -> Result<f64, SimError> {
                            interpolate(sys, tau, x)?;
                            sys.slip_margins_at(tau, x, margins)?;
                            Ok(margins[k])
                        };
                        // a start within rounding of zero counts as holding
                        crate::simulate::events::locate(g, lo.t, lo.m.max(f64::MIN_POSITIVE), hi.t, hi.m.min(-0.0))?
                    }
                }
            } else {
                let (sys, values) = (&*sys, &mut w.values);
                let e = &sys.events[w.switches[k - nf]];
                let g = |tau: f64| -> Result<f64, SimError> {
                    interpolate(sys, tau, x)?;
                    Ok(e.value(sys, tau, x, values))
                };
                crate::simulate::events::locate(g, t, l, t_new, r)?
            };
            w.times[k] = te;
            t_switch = t_switch.min(te);
        }
        // a cut that moves the run on by rounding only, again and again
        // (a margin that falls below zero at once in the mode the skates
        // settle back into) would loop without end: refused
        if t_switch < t_new && t_switch - t <= 1e-12 * t.abs().max(1.0) {
            w.stalls += 1;
            if w.stalls >= STALLED_CUTS {
                let k = (0..nf).find(|&k| w.times[k] == t_switch).unwrap_or(0);
                let skate = sys.friction.get(k).map_or_else(String::new, |f| f.name.clone());
                return Err(SimError::SlipChattering { skate, t0: t, t1: t, switches: 0 });
            }
        } else {
            w.stalls = 0;
        }
        Ok(t_switch)
    }

    /// Switches the skates' modes at `(t, y)`, where one stopped holding
    /// ([`Dynamics::settle_friction`]): the samples queued so far are
    /// observed first (in the modes they were computed in), each switch is
    /// recorded as an event (`slip_<skate>`, rising: it begins to slide;
    /// `stick_<skate>`, falling: it sticks or turns), the projection and
    /// the residuals take the new set of rows, `y` is projected onto it
    /// and the margins start anew there.
    ///
    /// # Errors
    /// As [`Dynamics::settle_friction`] and [`Run::flush`];
    /// [`SimError::SlipChattering`] when a skate has switched
    /// [`crate::events::spec::CHATTER_STEPS`] times in a row, each within
    /// [`SLIP_CHATTER_GAP`] steps of the one before.
    #[cold]
    pub(super) fn switch_slip(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        y: &mut [f64],
    ) -> Result<(), RunError<O::Error>> {
        self.flush(sys)?;
        let step = self.summary.steps;
        // the events that fire here switch their effects first: the skates'
        // modes are then decided under the new forces
        let nf = sys.friction.len();
        for j in 0..self.slip.switches.len() {
            let w = &mut self.slip;
            let Some(rising) = w.crossing(sys, nf + j).filter(|_| w.times[nf + j] <= t) else { continue };
            let e = &sys.events[w.switches[j]];
            let (name, on, off) = (e.name.clone(), e.switch_on.clone(), e.switch_off.clone());
            let s = &mut w.streaks[j];
            *s = if s.0 > 0 && step <= s.2 + SLIP_CHATTER_GAP { (s.0 + 1, s.1, step) } else { (1, t, step) };
            if s.0 >= crate::events::spec::CHATTER_STEPS {
                return Err(SimError::Chattering { event: name, t0: s.1, t1: t, steps: s.0 }.into());
            }
            self.monitor.record(&name, t, rising, y)?;
            on.iter().for_each(|&k| sys.effects[k].on = true);
            off.iter().for_each(|&k| sys.effects[k].on = false);
        }
        let switches = if nf > 0 { sys.settle_friction(t, y)? } else { Vec::new() };
        for &(k, old, new) in &switches {
            let fr = &sys.friction[k];
            self.monitor.record(&fr.transition_name(old), t, new.is_sliding(), y)?;
            let s = &mut self.slip.skate_streaks[k];
            let fixed = (!self.settings.method.is_adaptive()).then_some(SLIP_CHATTER_GAP as f64 * self.settings.dt);
            if s.record(t, fixed) >= crate::events::spec::CHATTER_STEPS {
                let (skate, t0, switches) = (fr.name.clone(), s.since, s.count);
                return Err(SimError::SlipChattering { skate, t0, t1: t, switches }.into());
            }
        }
        let rows = sys.released_rows();
        self.proj.release(rows);
        self.resid.released.set(&sys.info.pattern, rows);
        if self.settings.projection != ProjectionKind::None {
            let nq = sys.nq();
            let (q, rest) = y.split_at_mut(nq);
            self.proj.project(&sys.model, t, q, &mut rest[..nq])?;
        }
        self.jumped_events(sys, t, y)?;
        self.sliding_mode(sys, t, y)?;
        let w = &mut self.slip;
        w.t_left = t;
        if nf > 0 {
            sys.slip_samples_at(t, self.last_step.max(t * f64::EPSILON), y, &mut w.left[..nf], &mut w.left_rate)?;
        }
        for (j, &k) in w.switches.iter().enumerate() {
            let g = sys.events[k].value(sys, t, y, &mut w.values);
            // an event that fired here starts on its new side: where the
            // projection put `g` back across its level by rounding, at it
            // (a start at zero is no crossing)
            let fired = w.times[nf + j] <= t;
            let back = fired && sys.events[k].direction.crossing(w.left[nf + j], g).is_none() && g != 0.0;
            w.left[nf + j] = if back { 0.0 } else { g };
        }
        Ok(())
    }

    /// At a switch at `t` with the state `y` (after it): the recorded
    /// events whose quantity jumped across its level there (an effect
    /// switched off reads 0) recorded at `t`, and every recorded event's
    /// `g` taken on the switch's new side, where the next step starts.
    ///
    /// # Errors
    /// [`SimError::EventLimit`].
    pub(super) fn jumped_events(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), SimError> {
        let m = &mut self.monitor;
        for (k, e) in sys.events.iter().enumerate() {
            if e.action == crate::events::spec::Action::Switch {
                continue;
            }
            let g = e.value(sys, t, y, &mut m.scratch);
            if let Some(rising) = e.direction.crossing(m.left[k], g) {
                m.record(&e.name, t, rising, y)?;
            }
            m.left[k] = g;
        }
        Ok(())
    }

    /// After the switch events that fired at `t` turned their effects,
    /// with the state `y`: refuses a sliding mode, a switch event at its
    /// level whose quantity the new forces move across it in its own
    /// direction at once (its `g` on the linear motion over `t +- d`, `d`
    /// a millionth of the last step, under the new forces) and whose
    /// switch would change the forces back.
    ///
    /// # Errors
    /// [`SimError::SlidingMode`] naming both switches; as [`Dynamics::rhs`].
    pub(super) fn sliding_mode(&mut self, sys: &mut Dynamics<M>, t: f64, y: &[f64]) -> Result<(), SimError> {
        let nf = sys.friction.len();
        let w = &mut self.slip;
        let Some(j_fired) = (0..w.switches.len()).find(|&j| w.times[nf + j] <= t) else { return Ok(()) };
        let d = (1e-6 * self.last_step).max(64.0 * f64::EPSILON * t.abs().max(1.0));
        let mut dy = vec![0.0; y.len()];
        sys.rhs(t, y, &mut dy)?;
        let ahead: Vec<f64> = y.iter().zip(&dy).map(|(y, d_)| y + d * d_).collect();
        for &k in &w.switches {
            let e = &sys.events[k];
            let changes =
                e.switch_on.iter().any(|&i| !sys.effects[i].on) || e.switch_off.iter().any(|&i| sys.effects[i].on);
            if !changes {
                continue;
            }
            let g0 = e.value(sys, t, y, &mut w.values);
            let g1 = e.value(sys, t + d, &ahead, &mut w.values);
            if e.direction.crossing(2.0 * g0 - g1, g1).is_some() {
                let event = sys.events[w.switches[j_fired]].name.clone();
                return Err(SimError::SlidingMode { event, undo: e.name.clone(), t });
            }
        }
        Ok(())
    }
}
