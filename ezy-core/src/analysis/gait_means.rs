//! A periodic orbit's means that need the whole period, not its ends: the
//! mean of the reference body's speed `|v|` and the drift speed, a speed
//! that does not depend on the phase `t0` the orbit is sampled at.
//!
//! Over a period the reference point moves by `D = p(t0 + T) - p(t0)`
//! and turns by `dth`. The equations are invariant under the plane's
//! rigid motions, so the motion repeats moved by one rigid motion `G`:
//! `p(t + T) = R(dth) p(t) + b` for every `t` (Kelly & Murray,
//! *Geometric phases and robotic locomotion*, J. Robotic Systems 12,
//! 1995, §2: the net motion of a gait is a group element). Where `dth`
//! is not a whole turn, `G` is a rotation about a fixed centre `c`, and
//! `u(t) = p(t) - c` satisfies `u(t + T) = R u(t)`: the mean of `|u|^2`
//! over any period is the same (its derivative in `t0` is
//! `(|R u|^2 - |u|^2) / T = 0`). The drift speed is the root mean square
//! over the period of the speed at which `G` carries each point of the
//! path round the centre, `|dth| |u(t)| / T`, with `dth` wrapped to
//! `(-pi, pi]`; where `dth` is 0 it is `|D| / T`, and it tends to that as
//! `dth -> 0` (the centre recedes to infinity). `|D| / T` itself (the
//! mean speed) depends on `t0` when the gait turns.
//!
//! With `dth = 2h` and `M = dth (I - R)^-1 = [[h, -h cot h], [h cot h,
//! h]]` (bounded as `h -> 0`, where it is the quarter turn), `c - p(t0) =
//! (I - R)^-1 D`, so `dth u(t) = dth (p(t) - p(t0)) - M D` and
//! `mean |dth u|^2 = dth^2 s - 2 dth m . (M D) + |M D|^2` from the
//! period's integrals `m = mean (p - p(t0))` and `s = mean |p - p(t0)|^2`.

use super::periodic::{PeriodicSettings, into_sim};
use super::{Analysis, AnalysisError};
use crate::error::SimError;
use crate::integrator::Rhs;
use crate::integrator::adaptive;
use crate::integrator::dop853::Dop853;
use crate::model::Model;

/// The orbit's state with four quadratures: `∫|v| dt`, `∫(p - p0) dt`
/// (two) and `∫|p - p0|^2 dt` of the reference body `body`.
struct Means<'a, M: Model> {
    analysis: &'a mut Analysis<M>,
    body: [usize; 3],
    p0: [f64; 2],
    failed: Option<AnalysisError>,
}

impl<M: Model> Rhs for Means<'_, M> {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        let n2 = 2 * self.analysis.nq();
        let [i, j, _] = self.body;
        let (nq, p0) = (n2 / 2, self.p0);
        let mut run = |an: &mut Analysis<M>| -> Result<(), AnalysisError> {
            an.check_stop()?;
            let x = &y[..n2];
            let f = an.rhs(t, x)?;
            dy[..n2].copy_from_slice(&f);
            let (dx, dyy) = (x[i] - p0[0], x[j] - p0[1]);
            dy[n2] = x[nq + i].hypot(x[nq + j]);
            dy[n2 + 1] = dx;
            dy[n2 + 2] = dyy;
            dy[n2 + 3] = dx * dx + dyy * dyy;
            Ok(())
        };
        run(self.analysis).map_err(|e| into_sim(e, &mut self.failed))
    }
}

/// The means of one period of a periodic orbit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GaitMeans {
    /// `(1/T) ∫ |v| dt` of the reference body \[m/s\].
    pub mean_abs_speed: f64,
    /// The drift speed (the module's docs) \[m/s\].
    pub drift_speed: f64,
}

/// `h cot h`, 1 at 0.
fn h_cot_h(h: f64) -> f64 {
    if h.abs() < 1e-8 { 1.0 - h * h / 3.0 } else { h / h.tan() }
}

/// The drift speed \[m/s\] from the period `T`, the displacement `d` and
/// heading change `dth` over it (in one frame), and the means `m` of
/// `p - p(t0)` and `s` of `|p - p(t0)|^2` over it (the module's docs).
pub(crate) fn drift_speed(period: f64, d: [f64; 2], dth: f64, m: [f64; 2], s: f64) -> f64 {
    // wrapped to (-pi, pi]: a whole turn more per period moves no point
    let w = dth.rem_euclid(std::f64::consts::TAU);
    let w = if w > std::f64::consts::PI { w - std::f64::consts::TAU } else { w };
    let h = w / 2.0;
    let k = h_cot_h(h);
    let md = [h * d[0] - k * d[1], k * d[0] + h * d[1]];
    let ms = w * w * s - 2.0 * w * (m[0] * md[0] + m[1] * md[1]) + md[0] * md[0] + md[1] * md[1];
    ms.max(0.0).sqrt() / period
}

impl<M: Model> Analysis<M> {
    /// The means over one period from `x0` at `t0` (the orbit's state,
    /// `period` its period, `heading_change` its reference body's turn
    /// over it \[rad\]), integrated by DOP853 at the period map's
    /// tolerances. Zeros for a model without bodies.
    ///
    /// # Errors
    /// As [`crate::integrator::adaptive::integrate`]; as [`Analysis::rhs`].
    pub(crate) fn gait_means(
        &mut self,
        t0: f64,
        x0: &[f64],
        period: f64,
        heading_change: f64,
        settings: &PeriodicSettings,
    ) -> Result<GaitMeans, AnalysisError> {
        let Some(&body) = self.bodies().first() else {
            return Ok(GaitMeans { mean_abs_speed: 0.0, drift_speed: 0.0 });
        };
        let n2 = x0.len();
        let p0 = [x0[body[0]], x0[body[1]]];
        let mut y0 = x0.to_vec();
        y0.extend([0.0; 4]);
        let mut means = Means { analysis: self, body, p0, failed: None };
        let end =
            adaptive::integrate::<Dop853, _>(&mut means, t0, &y0, t0 + period, &settings.tolerance, settings.max_steps);
        if let Some(e) = means.failed.take() {
            return Err(e);
        }
        let y = end?.y;
        let d = [y[body[0]] - p0[0], y[body[1]] - p0[1]];
        let m = [y[n2 + 1] / period, y[n2 + 2] / period];
        Ok(GaitMeans {
            mean_abs_speed: y[n2] / period,
            drift_speed: drift_speed(period, d, heading_change, m, y[n2 + 3] / period),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point on a circle of radius `r` about `c`, turning at `w` rad
    /// per period `T` (so `p(t + T) = R p(t) + b` with `R` the turn about
    /// `c`): its drift speed is `|w| r / T` whatever phase it starts at,
    /// and for a straight line (`w = 0`) the chord `|D| / T`; the means
    /// `m`, `s` here in closed form.
    #[test]
    fn a_circle_drifts_at_its_arc_speed_from_any_phase() {
        let (r, c, period) = (2.0, [0.3, -1.1], 1.5);
        for w in [0.7, -2.5, 3.0, 0.7 + std::f64::consts::TAU] {
            let wrapped = if w > std::f64::consts::PI { w - std::f64::consts::TAU } else { w };
            for a0 in [0.0, 1.0, -2.2] {
                // p(t) = c + r (cos(a0 + w t/T), sin(...)), t in [0, T]
                let p = |a: f64| [c[0] + r * a.cos(), c[1] + r * a.sin()];
                let (p0, p1) = (p(a0), p(a0 + w));
                let d = [p1[0] - p0[0], p1[1] - p0[1]];
                // mean of p - p0: c + r (mean cos, mean sin) - p0
                let (mc, ms) = (((a0 + w).sin() - a0.sin()) / w, (a0.cos() - (a0 + w).cos()) / w);
                let m = [c[0] + r * mc - p0[0], c[1] + r * ms - p0[1]];
                // mean |p - p0|^2 = r^2 + |c - p0|^2 + 2 (c - p0) . r (mean cos, mean sin)
                let e = [c[0] - p0[0], c[1] - p0[1]];
                let s = r * r + e[0] * e[0] + e[1] * e[1] + 2.0 * r * (e[0] * mc + e[1] * ms);
                let got = drift_speed(period, d, w, m, s);
                let want = wrapped.abs() * r / period;
                assert!((got - want).abs() <= 1e-12 * want, "w {w} a0 {a0}: {got} against {want}");
            }
        }
        // straight: |D| / T
        let got = drift_speed(2.0, [0.6, 0.8], 0.0, [0.3, 0.4], 0.5);
        assert!((got - 0.5).abs() <= 1e-15, "{got}");
    }
}
