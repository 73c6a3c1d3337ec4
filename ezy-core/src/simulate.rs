//! The step loop: RK4, projection after every step, output at a fixed
//! interval, energy balance tracked at every step. The loop itself does not
//! allocate; output goes to an [`Observer`].

use std::time::{Duration, Instant};

use crate::SimError;
use crate::dynamics::{Counters, Dynamics};
use crate::integrator::Rk4;
use crate::model::Model;
use crate::projection::{ProjectionKind, Projector, mat_vec, max_abs};

/// Settings of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSettings {
    /// Step size `h` [s].
    pub dt: f64,
    /// Final time [s] (start is 0).
    pub t_end: f64,
    /// Output interval [s]; rounded to a whole number of steps. The final
    /// time is always output.
    pub every: f64,
    /// Projection after every step.
    pub projection: ProjectionKind,
}

impl RunSettings {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`SimError::Setting`] naming the first bad setting.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |name: &str, value: f64, reason| Err(SimError::Setting { name: name.into(), value, reason });
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return bad("--dt", self.dt, "the step must be a positive number of seconds");
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return bad("--t-end", self.t_end, "the duration must be a positive number of seconds");
        }
        if !(self.every.is_finite() && self.every > 0.0) {
            return bad("--every", self.every, "the output interval must be a positive number of seconds");
        }
        Ok(())
    }

    /// Number of steps to reach `t_end` (the last one may be shorter).
    pub fn n_steps(&self) -> u64 {
        ((self.t_end / self.dt) - 1e-9).ceil().max(1.0) as u64
    }

    /// Steps between outputs.
    pub fn output_stride(&self) -> u64 {
        ((self.every / self.dt).round() as u64).max(1)
    }
}

/// One output sample.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Time [s].
    pub t: f64,
    /// Coordinates (nq).
    pub q: &'a [f64],
    /// Velocities (nq).
    pub qd: &'a [f64],
    /// Kinetic energy [J].
    pub kinetic_energy: f64,
    /// Work of the applied forces since t = 0 [J].
    pub work: f64,
    /// `max|C(q)|` [m].
    pub residual_position: f64,
    /// `max|G(q) qd|` [m/s].
    pub residual_velocity: f64,
}

/// Receives the samples of a run.
pub trait Observer<M: Model> {
    /// Error type of the sink.
    type Error;
    /// Called at t = 0, every output interval, and at the final time.
    ///
    /// # Errors
    /// Whatever the sink fails with; the run stops.
    fn observe(&mut self, sys: &Dynamics<M>, sample: &Sample<'_>) -> Result<(), Self::Error>;
    /// Called now and then with the current time, for progress display.
    fn progress(&mut self, _t: f64) {}
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError<E> {
    /// The numerics failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The output sink failed.
    #[error("output: {0}")]
    Output(E),
}

/// What a run did and how well.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Steps taken.
    pub steps: u64,
    /// Right-hand-side evaluations and KKT solves.
    pub counters: Counters,
    /// Projections applied.
    pub projections: u64,
    /// Wall time of the integration alone (steps and projections, no output).
    pub integration_time: Duration,
    /// Largest `max|C|` over the outputs [m].
    pub max_residual_position: f64,
    /// Largest `max|G qd|` over the outputs [m/s].
    pub max_residual_velocity: f64,
    /// Largest drift `max|C|` a single step produced before projection [m].
    pub max_step_drift: f64,
    /// Largest `|T - T0 - W|` over all steps [J].
    pub max_energy_error: f64,
    /// Final state `y = [q, qd, W]`.
    pub final_state: Vec<f64>,
    /// KKT path used.
    pub kkt: &'static str,
}

/// Residual evaluation buffers.
#[derive(Debug, Clone)]
struct Residuals {
    phi: Vec<f64>,
    g_values: Vec<f64>,
    g: Vec<f64>,
    r: Vec<f64>,
}

impl Residuals {
    fn new<M: Model>() -> Self {
        let i = &M::INFO;
        Self {
            phi: vec![0.0; i.n_holonomic],
            g_values: vec![0.0; i.pattern.len()],
            g: vec![0.0; i.nc() * i.nq()],
            r: vec![0.0; i.nc()],
        }
    }
    fn eval<M: Model>(&mut self, model: &M, q: &[f64], qd: &[f64]) -> (f64, f64) {
        let nq = M::INFO.nq();
        model.phi(q, &mut self.phi);
        model.constraint_matrix(q, &mut self.g_values);
        for (&(r, c), &v) in M::INFO.pattern.iter().zip(&self.g_values) {
            self.g[r * nq + c] = v;
        }
        mat_vec(&self.g, qd, &mut self.r);
        (max_abs(&self.phi), max_abs(&self.r))
    }
}

/// Integrates `sys` from `y0 = [q, qd, W]` with RK4 and projection.
///
/// # Errors
/// [`RunError::Sim`] on a singular KKT system or a non-finite state (with
/// the time and the component), [`RunError::Output`] if the observer fails.
pub fn simulate<M: Model, O: Observer<M>>(
    sys: &mut Dynamics<M>,
    y0: &[f64],
    settings: &RunSettings,
    observer: &mut O,
) -> Result<Summary, RunError<O::Error>> {
    settings.validate()?;
    let nq = M::INFO.nq();
    let ny = Dynamics::<M>::NY;
    let mut y = y0.to_vec();
    let mut rk = Rk4::new(ny);
    let mut proj = Projector::<M>::new(settings.projection, &sys.mass);
    let mut resid = Residuals::new::<M>();
    let n = settings.n_steps();
    let stride = settings.output_stride();
    let t0_energy = sys.kinetic_energy(&y[nq..2 * nq]);
    let mut summary = Summary {
        steps: 0,
        counters: Counters::default(),
        projections: 0,
        integration_time: Duration::ZERO,
        max_residual_position: 0.0,
        max_residual_velocity: 0.0,
        max_step_drift: 0.0,
        max_energy_error: 0.0,
        final_state: Vec::new(),
        kkt: sys.kkt_name(),
    };
    let mut emit = |sys: &Dynamics<M>, t: f64, y: &[f64], summary: &mut Summary, observer: &mut O| {
        let (q, rest) = y.split_at(nq);
        let qd = &rest[..nq];
        let (rp, rv) = resid.eval(&sys.model, q, qd);
        summary.max_residual_position = summary.max_residual_position.max(rp);
        summary.max_residual_velocity = summary.max_residual_velocity.max(rv);
        let sample = Sample {
            t,
            q,
            qd,
            kinetic_energy: sys.kinetic_energy(qd),
            work: y[2 * nq],
            residual_position: rp,
            residual_velocity: rv,
        };
        observer.observe(sys, &sample).map_err(RunError::Output)
    };
    emit(sys, 0.0, &y, &mut summary, observer)?;
    let start = Instant::now();
    let mut output_time = Duration::ZERO;
    for i in 0..n {
        let t = i as f64 * settings.dt;
        let t_next = if i + 1 == n { settings.t_end } else { (i + 1) as f64 * settings.dt };
        rk.step(sys, t, &mut y, t_next - t)?;
        if let Some(k) = y.iter().position(|v| !v.is_finite()) {
            return Err(SimError::NonFinite { t, quantity: state_name::<M>(k), value: y[k], dt: settings.dt }.into());
        }
        if settings.projection != ProjectionKind::None {
            let (q, rest) = y.split_at_mut(nq);
            let report = proj.project(&sys.model, t_next, q, &mut rest[..nq])?;
            summary.max_step_drift = summary.max_step_drift.max(report.drift_position);
            summary.projections += 1;
        }
        let energy_error = (sys.kinetic_energy(&y[nq..2 * nq]) - t0_energy - y[2 * nq]).abs();
        summary.max_energy_error = summary.max_energy_error.max(energy_error);
        summary.steps += 1;
        if (i + 1) % stride == 0 || i + 1 == n {
            let t_out = Instant::now();
            emit(sys, t_next, &y, &mut summary, observer)?;
            if (i + 1) % (stride * 64) == 0 {
                observer.progress(t_next);
            }
            output_time += t_out.elapsed();
        }
    }
    summary.integration_time = start.elapsed().saturating_sub(output_time);
    summary.counters = sys.counters;
    summary.final_state = y;
    Ok(summary)
}

/// Name of state component `k` of `y = [q, qd, W]`.
pub fn state_name<M: Model>(k: usize) -> String {
    let c = M::INFO.coords;
    if k < c.len() {
        c[k].to_string()
    } else if k < 2 * c.len() {
        format!("{}d", c[k - c.len()])
    } else {
        "W".to_string()
    }
}
