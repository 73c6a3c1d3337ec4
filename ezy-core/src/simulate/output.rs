//! The output of a run: samples queued by the step loop, which only
//! copies a state (or its integrator state) into the queue, and handed
//! to the observer in batches with their energies and residuals
//! ([`Run::flush`], timed as the output's work); the output times of the
//! adaptive methods (multiples of `every`) and which of them the observer
//! wants.

use std::time::Instant;

use crate::error::SimError;
use crate::formulation::dae::Dynamics;
use crate::formulation::reduced::Reduced;
use crate::model::Model;
use crate::settings::ProjectionKind;
use crate::simulate::integrand::Integrand;
use crate::simulate::observer::{Observer, RunError, Sample};
use crate::simulate::run::{Pending, Run};

impl<'a, M: Model, O: Observer<M>> Run<'a, M, O> {
    /// Ends a run at the event at `t_stop` inside the step from `t`: the
    /// outputs before it from the step's dense output, then the event's
    /// state ([`Run::stop`]) as the last sample.
    pub(super) fn emit_stop<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        t_stop: f64,
        n_out: &mut u64,
        interpolate: impl Fn(f64, &mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        while self.output_due(*n_out, t_stop) && self.out_time(*n_out) < t_stop {
            let t_out = self.out_time(*n_out);
            if self.wanted(t_out) {
                form.emit_dense(self, sys, t_out, |x| interpolate(t_out, x))?;
            }
            *n_out += 1;
        }
        self.emit_stop_state(sys, t_stop)
    }

    /// Queues the state of the event that stopped the run ([`Run::stop`]),
    /// at `t_stop`, as the last sample.
    pub(super) fn emit_stop_state(&mut self, sys: &Dynamics<M>, t_stop: f64) -> Result<(), RunError<O::Error>> {
        let y = self.stop.take().expect("a stop has its state");
        let res = self.emit(sys, t_stop, &y);
        self.stop = Some(y);
        res
    }

    /// Queues the sample `(t, y)`; the queue goes to the observer when
    /// full ([`Run::flush`]), so the step loop only copies the state.
    pub(super) fn emit(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), RunError<O::Error>> {
        self.queue(sys, t, Pending::Ready, |row| row.copy_from_slice(y))
    }

    /// Queues a sample at `t` whose state `fill` writes in place; `kind`:
    /// what is left to do before it is observed (a dense-output sample is
    /// projected, or expanded from minimal coordinates, then).
    #[inline(always)]
    pub(super) fn queue(
        &mut self,
        sys: &Dynamics<M>,
        t: f64,
        kind: Pending,
        fill: impl FnOnce(&mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        let ny = sys.ny();
        let kind = match kind {
            Pending::Project if self.settings.projection == ProjectionKind::None => Pending::Ready,
            kind => kind,
        };
        self.pending_kind.push(kind);
        let (start, end) = (self.pending_len, self.pending_len + ny + 1);
        if end > self.pending.len() {
            // more room (cold: in the first batch only)
            self.grow_pending(end);
        }
        let row = &mut self.pending[start..end];
        row[0] = t;
        // `fill` writes the row's numbers over the last batch's (a
        // minimal-coordinate row only its first `z.len()`: `flush` places
        // them in a zeroed row)
        fill(&mut row[1..]);
        self.pending_len = end;
        if end + ny + 1 > self.pending.capacity() {
            self.flush(sys)?;
        }
        Ok(())
    }

    /// Room for the queued rows up to `end` entries, zeroed: twice the
    /// room there was, up to the queue's capacity (a run that outputs a
    /// few rows zeroes only them; one that fills the queue grows it a
    /// few times, in its first batch).
    #[cold]
    #[inline(never)]
    fn grow_pending(&mut self, end: usize) {
        let room = (2 * self.pending.len()).min(self.pending.capacity()).max(end);
        self.pending.resize(room, 0.0);
    }

    /// Where `red`'s deferred dense-output samples go in the full state
    /// ([`Run::sample_places`]), and the scratch to place one: set when a
    /// reduced formulation takes the run (not in the step loop).
    pub(super) fn place_samples_of(&mut self, red: &Reduced, sys: &Dynamics<M>) {
        if red.defers_samples() {
            self.sample_places = red.sample_places(sys.ny());
            self.sample_z = vec![0.0; self.sample_places.len()];
        }
    }

    /// Hands the queued samples to the observer, each with its kinetic
    /// energy, work and residuals (computed here, once per sample, off the
    /// step loop). Its time is left out of the integration time.
    pub(super) fn flush(&mut self, sys: &Dynamics<M>) -> Result<(), RunError<O::Error>> {
        if self.pending_len == 0 {
            return Ok(());
        }
        let clock = Instant::now();
        let mut pending = std::mem::take(&mut self.pending);
        let kinds = std::mem::take(&mut self.pending_kind);
        let places = std::mem::take(&mut self.sample_places);
        let mut z = std::mem::take(&mut self.sample_z);
        z.resize(places.len(), 0.0);
        let rows = &mut pending[..self.pending_len];
        let res = rows.chunks_exact_mut(sys.ny() + 1).zip(&kinds).try_for_each(|(row, &kind)| {
            let (t, y) = row.split_first_mut().expect("a row holds its time");
            match kind {
                Pending::Ready => return self.observe(sys, *t, y),
                Pending::Expand => {
                    z.copy_from_slice(&y[..places.len()]);
                    y.fill(0.0);
                    for (&v, &j) in z.iter().zip(&places) {
                        y[j] = v;
                    }
                    // the model said it has `minimal_state` when the run
                    // began; one that stops having it is refused, not
                    // written half-expanded (as a failure with its cause,
                    // which no hand-over to the DAE takes for its own:
                    // the rows queued with it are gone)
                    if !crate::formulation::reduced::complete_sample(&sys.model, sys.nq(), y) {
                        let error = SimError::Formulation {
                            reason: format!(
                                "at t = {} s the model's minimal_state gave no full state for a dense-output \
                                 sample, though it did at the start",
                                crate::names::fmt_value(*t)
                            )
                            .into(),
                        };
                        let cause = "Model::minimal_state's answer must be the same at every state".to_string();
                        return Err(RunError::Sim(SimError::Caused { error: Box::new(error), cause }));
                    }
                    return self.observe(sys, *t, y);
                }
                Pending::Project => {}
            }
            // a projected sample's residuals are the projection's own: its
            // last evaluation of phi, at the final q, and G qd with its G
            // there (the same numbers as evaluating them anew)
            let nq = sys.nq();
            let (q, rest) = y.split_at_mut(nq);
            let report = self.proj.project(&sys.model, *t, q, &mut rest[..nq])?;
            let rv = self.proj.velocity_residual(&sys.model, *t, &rest[..nq]);
            let (kinetic, work) = (sys.kinetic_energy(&y[nq..2 * nq]), sys.work(y));
            self.deliver(sys, *t, y, [kinetic, work, report.residual_position, rv])
        });
        self.pending = pending;
        self.pending_len = 0;
        self.pending_kind = kinds;
        self.pending_kind.clear();
        self.sample_places = places;
        self.sample_z = z;
        self.output_time += clock.elapsed();
        res
    }

    /// The observer's view of the sample `(t, y)`.
    pub(super) fn observe(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), RunError<O::Error>> {
        let nq = sys.nq();
        let (q, rest) = y.split_at(nq);
        let qd = &rest[..nq];
        let (rp, rv) = self.resid.eval(&sys.model, &sys.drives, t, q, qd);
        self.deliver(sys, t, y, [sys.kinetic_energy(qd), sys.work(y), rp, rv])
    }

    /// Hands the sample `(t, y)` to the observer with its kinetic energy
    /// \[J\], work \[J\], `max|C(q)|` \[m\] and `max|G(q) qd|` \[m/s\].
    pub(super) fn deliver(
        &mut self,
        sys: &Dynamics<M>,
        t: f64,
        y: &[f64],
        [kinetic, work, rp, rv]: [f64; 4],
    ) -> Result<(), RunError<O::Error>> {
        let nq = sys.nq();
        let (q, rest) = y.split_at(nq);
        let qd = &rest[..nq];
        self.summary.max_residual_position = self.summary.max_residual_position.max(rp);
        self.summary.max_residual_velocity = self.summary.max_residual_velocity.max(rv);
        for (quantity, value) in [
            ("the kinetic energy T", kinetic),
            ("the work W", work),
            ("the position residual max|C(q)|", rp),
            ("the velocity residual max|G(q) qd|", rv),
        ] {
            if !value.is_finite() {
                // the first sample is the initial state: no step made it
                let step = if t == 0.0 { 0.0 } else { self.last_step };
                let (dt, advice) = (step, self.advice(t, step));
                return Err(SimError::NonFinite { t, quantity: quantity.into(), value, dt, advice }.into());
            }
        }
        let sample = Sample {
            t,
            q,
            qd,
            kinetic_energy: kinetic,
            work,
            works: &y[2 * nq..],
            residual_position: rp,
            residual_velocity: rv,
        };
        self.observer.observe(sys, &sample).map_err(RunError::Output)
    }

    /// The time of output number `k` (`k every`, the last one `t_end`).
    pub(super) fn out_time(&self, k: u64) -> f64 {
        (k as f64 * self.settings.every).min(self.settings.t_end)
    }

    /// Whether an output at `t` \[s\] is the final one: within a relative
    /// 1e-12 of `t_end` (`k every` may round to just below it).
    pub(super) fn at_end(&self, t: f64) -> bool {
        t >= self.settings.t_end * (1.0 - 1e-12)
    }

    /// Whether the output at `t` is to be observed: the final one always
    /// ([`Run::at_end`]), the others as the observer wants
    /// ([`Observer::wants`]).
    pub(super) fn wanted(&self, t: f64) -> bool {
        if self.at_end(t) {
            return true;
        }
        let (from, until) = self.skip.get();
        if t >= from && t < until {
            return false;
        }
        if self.observer.wants(t) {
            return true;
        }
        self.skip.set((t, self.observer.next_wanted(t).clamp(t, self.settings.t_end)));
        false
    }

    /// The first output number at or after `n_out` that may be wanted:
    /// past the refused outputs before [`Run::skip`]'s end in one jump.
    pub(super) fn skip_unwanted(&self, n_out: u64) -> u64 {
        let (from, until) = self.skip.get();
        let t = self.out_time(n_out);
        if t < from || t >= until {
            return n_out;
        }
        // the outputs before k lie before `until` (output k - 1 at least
        // one interval before it)
        n_out.max((until / self.settings.every).floor() as u64)
    }

    /// Whether output number `n_out` is due in a step ending at `t_new`.
    #[inline]
    pub(super) fn output_due(&self, n_out: u64, t_new: f64) -> bool {
        n_out as f64 * self.settings.every <= self.settings.t_end * (1.0 + 1e-12) && self.out_time(n_out) <= t_new
    }

    /// The outputs inside `(t, t_new]` of an accepted step, from the
    /// step's dense output `interpolate(t_out, out)` (in the integrator's
    /// state), queued with the output's work ([`Run::flush`], off the
    /// step loop); `n_out` counts them. An output at the step's end
    /// `t_new` is the accepted state `x_new` itself.
    #[inline]
    pub(super) fn emit_dense<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        t_new: f64,
        x_new: &[f64],
        n_out: &mut u64,
        interpolate: impl Fn(f64, &mut [f64]),
    ) -> Result<(), RunError<O::Error>> {
        while self.output_due(*n_out, t_new) {
            let t_out = self.out_time(*n_out);
            if !self.wanted(t_out) {
                *n_out = self.skip_unwanted(*n_out + 1);
                continue;
            }
            if t_out == t_new {
                form.emit(self, sys, t_out, x_new)?;
            } else {
                form.emit_dense(self, sys, t_out, |x| interpolate(t_out, x))?;
            }
            *n_out += 1;
        }
        Ok(())
    }

    /// Whether a wanted output falls inside the step ending at `t_new`,
    /// not on its end (only then is its dense output needed).
    pub(super) fn output_inside(&self, n_out: u64, t_new: f64) -> bool {
        let mut k = n_out;
        while self.output_due(k, t_new) && self.out_time(k) < t_new {
            if self.wanted(self.out_time(k)) {
                return true;
            }
            k = self.skip_unwanted(k + 1);
        }
        false
    }

    /// The final time is always written: the accepted `x` at `t_end`
    /// unless output number `n_out - 1` was it.
    pub(super) fn finish_dense<F: Integrand<M>>(
        &mut self,
        form: &mut F,
        sys: &Dynamics<M>,
        n_out: u64,
        x: &[f64],
    ) -> Result<(), RunError<O::Error>> {
        let wrote_final = self.at_end((n_out - 1) as f64 * self.settings.every);
        if !wrote_final {
            form.emit(self, sys, self.settings.t_end, x)?;
        }
        Ok(())
    }
}
