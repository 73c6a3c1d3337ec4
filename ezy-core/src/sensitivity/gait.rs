//! Sensitivities of a gait (a periodic orbit, [`PeriodicOrbit`]) by the
//! implicit function theorem on its shooting equations.
//!
//! The orbit solves `R(z; p) = [x(t0 + T(p); x0, p) - h . x0; C(x0; p)] =
//! 0` in `z = (x0, h)` (the fixed point and the rigid motion over a
//! period). Differentiating, `J dz/dp = -dR/dp` with `J` the shooting
//! Jacobian the search used (Seydel, *Practical Bifurcation and Stability
//! Analysis*, 3rd ed., §7.1-7.3) and `dR/dp = [dx(T)/dp + f(t0 + T, x(T))
//! dT/dp; dC/dp]`: `dx(T)/dp` at a fixed `x0` is the run's forward
//! sensitivity from `S(t0) = 0` over one period, integrated with the
//! monodromy matrix in one pass (DOP853 under the orbit's tolerance);
//! then one minimum-norm solve per parameter, no orbit searched again.
//!
//! A gait of a periodically forced scene is compared with its neighbours
//! at the same phase of the forcing: its period is `n T_f` and its start
//! `t0 = k T_f + r` (`k`, `n` whole) moves as `r T_f(p) / T_f`, which
//! adds `f(t0 + T) dt0/dp - Phi f(t0) dt0/dp` to `dR/dp` and the
//! constraints' own rate in time to `dC/dp`. (At a fixed `t0` a
//! frequency would move the forcing's phase there by `t0 domega`: the
//! fixed point of a snake at `t0 = 502 s` slid along its orbit, and its
//! forward speed in the head's frame with it, 57 where the gaits at one
//! phase give 0.156.) The period is integrated from `r`, the same motion,
//! where a frequency's derivative of a waveform (`t cos(omega t)`) stays
//! of the size of one period's.
//!
//! The mean input power is the work per period of the actuators, over
//! the period: the effects whose force is driven by time (motors, driven
//! wheels, forces and torques with a waveform) and the drives (a
//! prescribed hinge angle `u(t)` works at `tau u'(t)`, its constraint
//! torque `tau = -lambda_row` times its rate); its derivative is
//! integrated along (`dE/dx0 Phi` and `dE/dp`, a drive's through the
//! multiplier's own sensitivity `dlambda`), each actuator's share beside
//! it ([`GaitSensitivities::input_ledger`]). Every quantity of the gait
//! (mean speed, displacement, heading change, mean power, efficiency =
//! mean speed per mean power) is then a function of `(x0, h, T, E)`
//! whose derivative along `(dx0/dp, dh/dp, dT/dp, dE/dp)` is the
//! geometry's five-point difference along `(dx0/dp, dh/dp)` (no
//! integration) and the quotient rule in `T` and `E`.

use faer::Mat;

use super::rhs::Augmented;
use super::stencil::{Derivative, Stencil};
use super::{MAX_PARAMETERS, Parameter};
use crate::analysis::AnalysisError;
use crate::analysis::dense::min_norm_solve;
use crate::analysis::periodic::{PeriodicOrbit, PeriodicSettings, gait_geometry, gauge_coordinates, with_gauge};
use crate::analysis::symmetry::Symmetry;
use crate::effects::waveform::Periodicity;
use crate::integrator::adaptive;
use crate::integrator::dop853::Dop853;
use crate::model::Model;
use crate::problem::Problem;

/// A gait's mean input power and efficiency, and the derivatives of its
/// quantities with respect to parameters ([`Problem::gait_sensitivities`]).
#[derive(Debug, Clone)]
pub struct GaitSensitivities {
    /// The parameters, in the order of every `d_` list.
    pub parameters: Vec<String>,
    /// Their values.
    pub values: Vec<f64>,
    /// How each parameter's direct effect was differentiated.
    pub derivatives: Vec<Derivative>,
    /// Mean input power of the actuators over a period \[W\]: the effects
    /// driven by time and the drives (0 without actuators).
    pub mean_power: f64,
    /// Mean speed per mean input power \[m/J\] (NaN without input power).
    pub efficiency: f64,
    /// Each actuator's mean power over the period \[W\], by name: the
    /// effects driven by time (motors, forces with a waveform), then the
    /// drives (a prescribed hinge angle's constraint torque times its
    /// rate); they add up to `mean_power`. Empty without actuators.
    pub input_ledger: Vec<(String, f64)>,
    /// `d(fixed point)/dp` (2 nq each), in the orbit's frame, at the
    /// forcing's phase held (the module's docs).
    pub d_state: Vec<Vec<f64>>,
    /// `dT/dp` \[s per unit of p\]: `n dT_f/dp` for a period of `n`
    /// forcing periods `T_f`; 0 where the scene is not forced (an
    /// autonomous limit cycle's period is not differentiated).
    pub d_period: Vec<f64>,
    /// `d(mean speed)/dp`.
    pub d_mean_speed: Vec<f64>,
    /// `d(mean forward speed)/dp`.
    pub d_mean_forward_speed: Vec<f64>,
    /// `d(displacement per period)/dp` (forward, lateral).
    pub d_displacement: Vec<[f64; 2]>,
    /// `d(heading change per period)/dp`.
    pub d_heading_change: Vec<f64>,
    /// `d(mean input power)/dp`.
    pub d_mean_power: Vec<f64>,
    /// `d(efficiency)/dp`.
    pub d_efficiency: Vec<f64>,
    /// Accepted steps of the period's integration.
    pub steps: u64,
}

impl GaitSensitivities {
    /// The quantities differentiated, by the names `periodic.csv` gives
    /// them, with the derivative of each with respect to parameter `j`.
    pub fn rows(&self, j: usize) -> Vec<(&'static str, f64)> {
        vec![
            ("period", self.d_period[j]),
            ("mean_speed", self.d_mean_speed[j]),
            ("mean_forward_speed", self.d_mean_forward_speed[j]),
            ("dx", self.d_displacement[j][0]),
            ("dy", self.d_displacement[j][1]),
            ("dheading", self.d_heading_change[j]),
            ("mean_power", self.d_mean_power[j]),
            ("efficiency", self.d_efficiency[j]),
        ]
    }
}

impl<M: Model> Stencil<M> {
    /// The column of `Phi` along state component `j` (of `n2`): no direct
    /// effect, `Phi(t0) e_j = e_j`.
    fn identity(n2: usize, j: usize) -> Self {
        let mut x0 = vec![0.0; n2];
        x0[j] = 1.0;
        Self {
            nodes: Vec::new(),
            base_weight: 0.0,
            touches: Default::default(),
            derivative: Derivative::InitialOnly,
            x0,
            changed: Vec::new(),
            linear: Vec::new(),
            f: Vec::new(),
        }
    }
}

/// The gait's quantities as a function of `(x0, h, T, E)`: mean speed,
/// mean forward speed, displacement (2), heading change, mean power,
/// efficiency.
fn quantities(bodies: &[[usize; 3]], symmetry: Symmetry, x0: &[f64], hp: &[f64], t: f64, e: f64) -> [f64; 7] {
    let (_, shift, d) = gait_geometry(bodies, symmetry, x0, symmetry.pose(hp));
    let speed = d[0].hypot(d[1]) / t;
    let power = e / t;
    [speed, d[0] / t, d[0], d[1], shift.theta, power, if power > 0.0 { speed / power } else { f64::NAN }]
}

/// The derivatives of [`quantities`] at `(x0, h, T, E)` along `(dx0, dh,
/// dT, dE)`: the displacement and the heading change (the geometry of
/// the fixed point and the rigid motion over the period) by a five-point
/// difference along `(dx0, dh)` alone, the largest of those moved by 1e-3
/// (coordinates and angles: truncation about 1e-3^4 / 30 of their fifth
/// derivative, rounding about 1e-13; a two-point one at 1e-6 left 1e-8),
/// then the period's and the energy's part by the quotient rule, exact
/// (a difference through `E / T` and `speed / power` moved a small input
/// energy by several percent: 4.7e-6 off in an efficiency).
fn quantity_derivatives(
    bodies: &[[usize; 3]],
    symmetry: Symmetry,
    (x0, hp, t, e): (&[f64], &[f64], f64, f64),
    (dx0, dhp, dt, de): (&[f64], &[f64], f64, f64),
) -> [f64; 7] {
    let geometry = |s: f64| {
        let x: Vec<f64> = x0.iter().zip(dx0).map(|(a, b)| a + s * b).collect();
        let h: Vec<f64> = hp.iter().zip(dhp).map(|(a, b)| a + s * b).collect();
        let (_, shift, d) = gait_geometry(bodies, symmetry, &x, symmetry.pose(&h));
        [d[0], d[1], shift.theta]
    };
    let scale = dx0.iter().chain(dhp).fold(0.0f64, |a, v| a.max(v.abs()));
    let dg: [f64; 3] = if scale > 0.0 {
        let eps = 1e-3 / scale;
        let (p1, m1, p2, m2) = (geometry(eps), geometry(-eps), geometry(2.0 * eps), geometry(-2.0 * eps));
        std::array::from_fn(|i| (8.0 * (p1[i] - m1[i]) - (p2[i] - m2[i])) / (12.0 * eps))
    } else {
        [0.0; 3]
    };
    let [d0, d1, _] = geometry(0.0);
    let length = d0.hypot(d1);
    let dlength = if length > 0.0 { (d0 * dg[0] + d1 * dg[1]) / length } else { 0.0 };
    let (speed, power) = (length / t, e / t);
    let dspeed = dlength / t - speed * dt / t;
    let dpower = de / t - power * dt / t;
    let defficiency = if power > 0.0 { (dspeed * power - speed * dpower) / (power * power) } else { f64::NAN };
    [dspeed, dg[0] / t - d0 / t * dt / t, dg[0], dg[1], dg[2], dpower, defficiency]
}

impl<M: Model> Problem<M> {
    /// The derivatives of the gait `orbit` of this problem (found by
    /// [`crate::analysis::Analysis::periodic_orbit`] on its analysis)
    /// with respect to `params`, and its mean input power and efficiency
    /// (see the module's docs for the method).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for more than [`MAX_PARAMETERS`] or a
    /// parameter named twice, a parameter whose problems differ in size;
    /// [`AnalysisError::Numerics`] when the shooting Jacobian is
    /// singular; as [`Problem::analysis`]; the integration's failure.
    pub fn gait_sensitivities(
        &self,
        orbit: &PeriodicOrbit,
        params: &[Parameter<M>],
        settings: &PeriodicSettings,
    ) -> Result<GaitSensitivities, AnalysisError> {
        if params.len() > MAX_PARAMETERS {
            return Err(AnalysisError::Request {
                reason: format!("{} parameters: a gait's sensitivities take at most {MAX_PARAMETERS}", params.len()),
            });
        }
        if let Some((k, p)) = params.iter().enumerate().find(|(k, p)| params[..*k].iter().any(|o| o.name == p.name)) {
            return Err(AnalysisError::Request { reason: format!("parameter `{}` is named twice (at {k})", p.name) });
        }
        let (base, _) = self.clone().analysis()?;
        base.check_size()?;
        let n2 = 2 * base.nq();
        let (t0, x0, period) = (orbit.t0, orbit.state.clone(), orbit.period);
        base.check_state(&x0)?;
        let np = params.len();
        let stencils = params.iter().map(|p| Stencil::new(p, &base, &x0)).collect::<Result<Vec<_>, _>>()?;
        // the forcing's period T_f and its derivative: the orbit's period is
        // n T_f (n whole) and moves with it; the phase of the forcing at the
        // fixed point is held, so the start t0 = k T_f + r moves as
        // r T_f(p) / T_f (k whole periods move the phase by nothing)
        let forcing_period = |f: Option<Periodicity>| f.and_then(Periodicity::period);
        let periods = base.forcing().and_then(|f| f.whole_periods(period));
        // T_f where the orbit repeats with whole forcing periods
        let phased = forcing_period(base.forcing()).filter(|_| periods.is_some());
        let d_forcing: Vec<f64> = stencils
            .iter()
            .map(|st| match phased {
                Some(tf) => {
                    st.base_weight * tf
                        + st.nodes.iter().map(|(w, an)| w * forcing_period(an.forcing()).unwrap_or(tf)).sum::<f64>()
                }
                None => 0.0,
            })
            .collect();
        let d_period: Vec<f64> = d_forcing.iter().map(|d| d * periods.unwrap_or(0.0)).collect();
        let start = phased.map_or(t0, |tf| phase_start(t0, tf));
        let d_start: Vec<f64> = d_forcing.iter().map(|d| phased.map_or(0.0, |tf| start / tf * d)).collect();
        let derivatives = stencils.iter().map(|s| s.derivative).collect();
        // residuals' direct derivatives at the fixed point
        let base_r = base.residual_at(start, &x0);
        let dr: Vec<Vec<f64>> = stencils
            .iter()
            .map(|st| {
                let (mut out, mut node_r) = (vec![0.0; base_r.len()], vec![0.0; base_r.len()]);
                let mut values = vec![0.0; base.dynamics().info.pattern.len()];
                st.add_residual(&base, start, &x0, &base_r, (&mut values, &mut node_r), &mut out);
                out
            })
            .collect();
        let residual_rate = base.residual_rate(start);
        let actuators: Vec<usize> = (base.dynamics().effects.iter().enumerate())
            .filter(|(_, e)| !matches!(e.periodicity(), Some(Periodicity::Constant)))
            .map(|(k, _)| k)
            .collect();
        let bodies = base.bodies().to_vec();
        let symmetry = orbit.symmetry;
        let hp = symmetry.params(orbit.shift);
        // one period of [x, Phi, S, E, dE/dx0, dE/dp]
        let mut columns: Vec<Stencil<M>> = (0..n2).map(|j| Stencil::identity(n2, j)).collect();
        columns.extend(stencils);
        let ncol = columns.len();
        let mut y0 = x0.clone();
        for (j, st) in columns.iter().enumerate() {
            y0.extend(if j < n2 { st.x0.clone() } else { vec![0.0; n2] });
        }
        // the input ledger's names: the actuating effects, then the drives
        let ledger_names: Vec<String> = actuators
            .iter()
            .map(|&k| base.dynamics().effects[k].name.clone())
            .chain(base.dynamics().drives.iter().map(|d| d.name.clone()))
            .collect();
        let mut aug = Augmented::new(base, columns, None);
        aug.actuators = actuators;
        aug.drive_power = true;
        aug.ledger = true;
        y0.extend(std::iter::repeat_n(0.0, (1 + ncol).max(aug.energy_states())));
        let end = adaptive::integrate::<Dop853, _>(
            &mut aug,
            start,
            &y0,
            start + period,
            &settings.tolerance,
            settings.max_steps,
        );
        if let Some(e) = aug.failed.take() {
            return Err(e);
        }
        let end = end?;
        let y = &end.y;
        let (xt, blocks) = y.split_at(n2);
        let col = |j: usize| &blocks[j * n2..(j + 1) * n2];
        let energy = &y[n2 * (1 + ncol)..];
        let m = Mat::from_fn(n2, n2, |i, j| col(j)[i]);
        let ft = aug.base.rhs(start + period, xt)?;
        let pt = aug.input_power(start + period, xt)?;
        // the start's own rate, carried over the period (`Phi f(t0)`), and
        // its input power: what a later start from the same state changes
        let f0 = aug.base.rhs(start, &x0)?;
        let phi_f0: Vec<f64> = (0..n2).map(|i| (0..n2).map(|j| m[(i, j)] * f0[j]).sum()).collect();
        let p0 = aug.input_power(start, &x0)?;
        // held at the gauge the orbit is written in (the reference body at
        // the origin with heading 0, as far as the symmetry allows), one
        // row per generator as the search holds it: the symmetry's
        // directions are not left to a minimum-norm solve's rank cut
        let gauge = gauge_coordinates(&bodies, &symmetry.generators());
        let j = with_gauge(aug.base.shooting_jacobian(start, &x0, &m, symmetry, &hp)?, &gauge);
        let q0 = quantities(&bodies, symmetry, &x0, &hp, period, energy[0]);
        let input_ledger = if aug.energy_states() > 0 {
            ledger_names.into_iter().zip(&energy[1 + ncol..]).map(|(n, e)| (n, e / period)).collect()
        } else {
            Vec::new()
        };
        let mut out = GaitSensitivities {
            parameters: params.iter().map(|p| p.name.clone()).collect(),
            values: params.iter().map(|p| p.value).collect(),
            derivatives,
            mean_power: q0[5],
            efficiency: q0[6],
            input_ledger,
            d_state: Vec::new(),
            d_period: d_period.clone(),
            d_mean_speed: Vec::new(),
            d_mean_forward_speed: Vec::new(),
            d_displacement: Vec::new(),
            d_heading_change: Vec::new(),
            d_mean_power: Vec::new(),
            d_efficiency: Vec::new(),
            steps: end.steps,
        };
        for k in 0..np {
            let (dt, ds) = (d_period[k], d_start[k]);
            // dR/dp = S + f(t0 + T) (dT + dt0) - Phi f(t0) dt0, and the
            // constraints' own rate in time at the start times dt0
            let mut rp: Vec<f64> = (0..n2).map(|i| -(col(n2 + k)[i] + ft[i] * (dt + ds) - phi_f0[i] * ds)).collect();
            rp.extend(dr[k].iter().zip(&residual_rate).map(|(v, r)| -(v + r * ds)));
            rp.extend(gauge.iter().map(|_| 0.0));
            let (dz, _) = min_norm_solve(j.as_ref(), &rp, 1e-12)?;
            let (dx0, dhp) = dz.split_at(n2);
            // dE/dp = dE/dx0 (dx0 - f(t0) dt0) + dE/dp + P(t0 + T) (dT + dt0) - P(t0) dt0
            let de = (0..n2).map(|i| energy[1 + i] * (dx0[i] - f0[i] * ds)).sum::<f64>()
                + energy[1 + n2 + k]
                + pt * (dt + ds)
                - p0 * ds;
            let dq = quantity_derivatives(&bodies, symmetry, (&x0, &hp, period, energy[0]), (dx0, dhp, dt, de));
            out.d_state.push(dx0.to_vec());
            out.d_mean_speed.push(dq[0]);
            out.d_mean_forward_speed.push(dq[1]);
            out.d_displacement.push([dq[2], dq[3]]);
            out.d_heading_change.push(dq[4]);
            out.d_mean_power.push(dq[5]);
            out.d_efficiency.push(dq[6]);
        }
        Ok(out)
    }
}

/// The start `t0` \[s\] of an orbit of a scene forced with period `tf`
/// \[s\], less its whole forcing periods: the same motion (the
/// right-hand side repeats with `tf`), where a frequency's derivative of
/// a waveform (`t cos(omega t)`) stays of the size of one period's. A
/// start a whole number of periods to rounding (1e-12 of them) is 0.
fn phase_start(t0: f64, tf: f64) -> f64 {
    let m = t0 / tf;
    if (m - m.round()).abs() <= 1e-12 * m.abs().max(1.0) { 0.0 } else { t0 - m.floor() * tf }
}
