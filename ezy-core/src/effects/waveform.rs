//! Time functions of the effects and drives: a torque, a force or a
//! prescribed angle given as a constant, a ramp, a cosine or sine, a sum
//! of harmonics, a piecewise-linear table or a cubic spline (held, or
//! continued linearly or periodically past its ends), or a sum of these.

use serde::{Deserialize, Serialize};

use crate::scalar::Scalar;

/// One harmonic `amplitude cos(omega t + phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Harmonic {
    /// Amplitude (unit of the quantity: \[N m\] for a torque, \[N\] for a force).
    pub amplitude: f64,
    /// Angular frequency \[rad/s\].
    pub omega: f64,
    /// Phase \[rad\].
    #[serde(default)]
    pub phase: f64,
    /// Phase added per element when the effect runs over a family
    /// (`hinge = "J[*]"`, see `Scene::expand_families`) \[rad\]; must be 0
    /// otherwise.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub phase_step: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// A piecewise-linear function of time through the points `(t_k, value_k)`,
/// defined on `[t_0, t_last]` only unless `extrapolate` says what it is
/// outside ([`Extrapolate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table {
    /// Times \[s\], strictly increasing.
    pub t: Vec<f64>,
    /// Values at those times (same length as `t`).
    pub value: Vec<f64>,
    /// What the table is outside `[t_0, t_last]`.
    #[serde(default, skip_serializing_if = "Extrapolate::is_none")]
    pub extrapolate: Extrapolate,
}

/// What a table or a spline is outside its first and last times.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Extrapolate {
    /// Nothing: the function is defined on its times only, and a run whose
    /// time span `[0, t_end]` passes them is refused before it starts
    /// ([`Waveform::span`]; `extrapolate = "none"`, the default). A table
    /// that ends before the run would otherwise hold its last value
    /// silently; say so with [`Extrapolate::Hold`] where that is meant.
    #[default]
    None,
    /// The end values held (zero derivatives).
    Hold,
    /// Continued along the end slopes (a spline's second derivative zero
    /// outside, continuous at a natural end).
    Linear,
    /// Repeated with the period `t_last - t_0`: `w(t) = w(t_0 + (t - t_0)
    /// mod (t_last - t_0))`. Continuous where the last value is the
    /// first (a spline's derivatives where its end slopes match too).
    Periodic,
}

impl Extrapolate {
    fn is_none(&self) -> bool {
        *self == Extrapolate::None
    }

    /// Where to evaluate at `t` \[s\] a function given on `[t0, t1]`:
    /// `Ok(t)` inside (or periodic, wrapped into it), `Err(end)` past an
    /// end (`0`: before `t0`, `1`: after `t1`) when held or continued, or
    /// not defined there (then evaluated as held: a run is refused before
    /// it gets there, [`Waveform::span`]).
    fn locate(self, t: f64, t0: f64, t1: f64) -> Result<f64, usize> {
        if (t0..=t1).contains(&t) {
            return Ok(t);
        }
        match self {
            Extrapolate::Periodic if t1 > t0 => Ok(t0 + (t - t0).rem_euclid(t1 - t0)),
            _ if t < t0 => Err(0),
            _ => Err(1),
        }
    }
}

/// A ramp `w(t) = value + rate t`: a rotor's mean spin, a force growing
/// steadily. In a scene file: `{ linear = { value = 0.0, rate = 6.0 } }`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Linear {
    /// Value at `t = 0` (unit of the quantity: \[rad\] for an angle,
    /// \[N m\] for a torque).
    #[serde(default)]
    pub value: f64,
    /// Rate (the quantity's unit per second: \[rad/s\] for an angle).
    pub rate: f64,
}

/// A scalar function of time `w(t)`. In a scene file it is a one-key table:
///
/// ```toml
/// torque = { constant = 2.0 }
/// torque = { cos = { amplitude = 2.0, omega = 3.141592653589793, phase = 0.0 } }
/// torque = { sin = { amplitude = 2.0, omega = 3.141592653589793 } }
/// torque = { harmonics = [{ amplitude = 2.0, omega = 3.14 }, { amplitude = 0.5, omega = 9.42, phase = 1.0 }] }
/// torque = { table = { t = [0.0, 1.0, 2.0], value = [0.0, 2.0, 0.0], extrapolate = "periodic" } }
/// torque = { linear = { value = 0.0, rate = 0.5 } }
/// angle = { sum = [{ linear = { rate = 6.0 } }, { sin = { amplitude = 0.5, omega = 3.0 } }] }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Waveform {
    /// `w(t) = value`.
    Constant(f64),
    /// `w(t) = amplitude cos(omega t + phase)` (the `drive` scene's motor with phase 0).
    Cos(Harmonic),
    /// `w(t) = amplitude sin(omega t + phase)`.
    Sin(Harmonic),
    /// `w(t) = sum_k amplitude_k cos(omega_k t + phase_k)`.
    Harmonics(Vec<Harmonic>),
    /// Linear interpolation in a table.
    Table(Table),
    /// A cubic spline through a table (twice continuously differentiable:
    /// for prescribed motions, whose second derivative enters the
    /// accelerations).
    Spline(Spline),
    /// `w(t) = value + rate t`.
    Linear(Linear),
    /// `w(t) = sum_k w_k(t)`: terms of the other kinds (a sum's terms are
    /// not sums), e.g. a rotor's angle `omega t + a sin(nu t)`.
    Sum(Vec<Waveform>),
}

/// A cubic spline through `(t_k, value_k)` (Press et al., *Numerical
/// Recipes*, 3rd ed., §3.3), natural (zero second derivative) at an end
/// unless the slope there is given; held constant outside the table, with
/// zero derivatives. In a scene file: `{ spline = { t = [...], value =
/// [...], slope_start = 0.0 } }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "SplineData", into = "SplineData")]
pub struct Spline {
    data: SplineData,
    /// Second derivatives at the knots.
    m: Vec<f64>,
}

/// The knots of a [`Spline`] and its optional end slopes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplineData {
    /// Times \[s\], strictly increasing, at least two.
    pub t: Vec<f64>,
    /// Values at those times.
    pub value: Vec<f64>,
    /// Slope at the first knot (clamped end); natural end if absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slope_start: Option<f64>,
    /// Slope at the last knot (clamped end); natural end if absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slope_end: Option<f64>,
    /// What the spline is outside its knots.
    #[serde(default, skip_serializing_if = "Extrapolate::is_none")]
    pub extrapolate: Extrapolate,
}

impl From<Spline> for SplineData {
    fn from(s: Spline) -> Self {
        s.data
    }
}

impl From<SplineData> for Spline {
    fn from(data: SplineData) -> Self {
        let m = spline_second_derivatives(&data);
        Self { data, m }
    }
}

impl Spline {
    /// The spline through `data`.
    pub fn new(data: SplineData) -> Self {
        data.into()
    }

    /// The knots.
    pub fn data(&self) -> &SplineData {
        &self.data
    }

    /// `(s(t), s'(t), s''(t))`.
    pub fn eval3(&self, t: f64) -> [f64; 3] {
        let (ts, ys) = (&self.data.t, &self.data.value);
        let n = ts.len();
        if n == 0 {
            return [0.0; 3];
        }
        if n < 2 {
            return [ys[0], 0.0, 0.0];
        }
        // outside the knots: held, continued along the end slope, or
        // wrapped; on the end knots: the spline's own derivatives
        let t = match self.data.extrapolate.locate(t, ts[0], ts[n - 1]) {
            Ok(t) => t,
            Err(end) => {
                let k = if end == 0 { 0 } else { n - 1 };
                return match self.data.extrapolate {
                    Extrapolate::Linear => {
                        let slope = self.eval3(ts[k])[1];
                        [ys[k] + slope * (t - ts[k]), slope, 0.0]
                    }
                    _ => [ys[k], 0.0, 0.0],
                };
            }
        };
        let k = ts.partition_point(|&tk| tk <= t).clamp(1, n - 1) - 1;
        let h = ts[k + 1] - ts[k];
        let a = (ts[k + 1] - t) / h;
        let b = (t - ts[k]) / h;
        let (m0, m1) = (self.m[k], self.m[k + 1]);
        let y = a * ys[k] + b * ys[k + 1] + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
        let dy = (ys[k + 1] - ys[k]) / h - (3.0 * a * a - 1.0) / 6.0 * h * m0 + (3.0 * b * b - 1.0) / 6.0 * h * m1;
        [y, dy, a * m0 + b * m1]
    }
}

/// Second derivatives of the cubic spline at the knots: the tridiagonal
/// system of continuous slopes, natural or clamped ends (Thomas algorithm).
fn spline_second_derivatives(d: &SplineData) -> Vec<f64> {
    let (t, y) = (&d.t, &d.value);
    let n = t.len();
    if n < 2 || y.len() != n {
        return vec![0.0; n];
    }
    let h = |i: usize| t[i + 1] - t[i];
    let slope = |i: usize| (y[i + 1] - y[i]) / h(i);
    // rows: sub[i] m[i-1] + diag[i] m[i] + sup[i] m[i+1] = rhs[i]
    let (mut sub, mut diag, mut sup, mut rhs) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    match d.slope_start {
        Some(s0) => {
            diag[0] = 2.0 * h(0);
            sup[0] = h(0);
            rhs[0] = 6.0 * (slope(0) - s0);
        }
        None => diag[0] = 1.0,
    }
    for i in 1..n - 1 {
        sub[i] = h(i - 1);
        diag[i] = 2.0 * (h(i - 1) + h(i));
        sup[i] = h(i);
        rhs[i] = 6.0 * (slope(i) - slope(i - 1));
    }
    match d.slope_end {
        Some(s1) => {
            sub[n - 1] = h(n - 2);
            diag[n - 1] = 2.0 * h(n - 2);
            rhs[n - 1] = 6.0 * (s1 - slope(n - 2));
        }
        None => diag[n - 1] = 1.0,
    }
    for i in 1..n {
        let w = sub[i] / diag[i - 1];
        diag[i] -= w * sup[i - 1];
        rhs[i] -= w * rhs[i - 1];
    }
    let mut m = vec![0.0; n];
    m[n - 1] = rhs[n - 1] / diag[n - 1];
    for i in (0..n - 1).rev() {
        m[i] = (rhs[i] - sup[i] * m[i + 1]) / diag[i];
    }
    m
}

impl Default for Waveform {
    fn default() -> Self {
        Self::Constant(0.0)
    }
}

impl Waveform {
    /// `w(t) = amplitude cos(omega t)` (`omega` \[rad/s\]).
    pub fn cos(amplitude: f64, omega: f64) -> Self {
        Self::Cos(Harmonic { amplitude, omega, phase: 0.0, phase_step: 0.0 })
    }

    /// `w(t) = amplitude sin(omega t)` (`omega` \[rad/s\]).
    pub fn sin(amplitude: f64, omega: f64) -> Self {
        Self::Sin(Harmonic { amplitude, omega, phase: 0.0, phase_step: 0.0 })
    }

    /// `w(t)`. A constant and a cosine (a harmonic motor's torque) are
    /// inline in the caller, the right-hand side; the rest is one call.
    #[inline(always)]
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            Self::Constant(v) => *v,
            Self::Cos(h) => h.amplitude * Scalar::cos(h.omega * t + h.phase),
            _ => self.eval_other(t),
        }
    }

    /// [`Waveform::eval`] for the kinds it does not inline.
    #[inline(never)]
    fn eval_other(&self, t: f64) -> f64 {
        match self {
            Self::Constant(_) | Self::Cos(_) => self.eval(t),
            Self::Sin(h) => h.amplitude * Scalar::sin(h.omega * t + h.phase),
            Self::Harmonics(hs) => hs.iter().map(|h| h.amplitude * Scalar::cos(h.omega * t + h.phase)).sum(),
            Self::Table(tab) => tab.eval(t),
            Self::Spline(s) => s.eval3(t)[0],
            Self::Linear(l) => l.value + l.rate * t,
            Self::Sum(terms) => terms.iter().map(|w| w.eval(t)).sum(),
        }
    }

    /// `(w(t), w'(t), w''(t))`, for prescribed motions. A `table` is only
    /// continuous: its slope jumps at the knots and its second derivative
    /// is taken as zero (use `spline` for a prescribed motion).
    pub fn eval3(&self, t: f64) -> [f64; 3] {
        let harmonic = |h: &Harmonic, shift: f64| {
            let (s, c) = Scalar::sin_cos(h.omega * t + h.phase + shift);
            [h.amplitude * c, -h.amplitude * h.omega * s, -h.amplitude * h.omega * h.omega * c]
        };
        match self {
            Self::Constant(v) => [*v, 0.0, 0.0],
            Self::Cos(h) => harmonic(h, 0.0),
            Self::Sin(h) => harmonic(h, -std::f64::consts::FRAC_PI_2),
            Self::Harmonics(hs) => {
                hs.iter().map(|h| harmonic(h, 0.0)).fold([0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            }
            Self::Table(tab) => [tab.eval(t), tab.slope(t), 0.0],
            Self::Spline(s) => s.eval3(t),
            Self::Linear(l) => [l.value + l.rate * t, l.rate, 0.0],
            Self::Sum(terms) => terms.iter().map(|w| w.eval3(t)).fold([0.0; 3], add3),
        }
    }

    /// `(w(t), w'(t), w''(t))` of the waveform whose numbers are this
    /// one's moved toward `other`'s, to first order in the move: for two
    /// harmonics of one shape (a cosine and a cosine, a sine and a sine,
    /// sums of as many terms) `eval3(t) + dw/d(amplitude, omega, phase)
    /// . (other - self)`, exact in `t` (the secular `t sin(omega t)` of
    /// a frequency's derivative is not differenced); for any other pair,
    /// `other.eval3(t)` (a constant is linear in its value; a table's and
    /// a spline's dependence on their numbers does not grow with `t`).
    ///
    /// The forward sensitivities ([`crate::sensitivity`]) take the
    /// difference of the right-hand sides at `p +- h` with each
    /// waveform at `p +- h` replaced by this linearization from the one
    /// at `p`: a harmonic's frequency then enters `df/dp` exactly
    /// (`-a t sin(omega t + phase) domega/dp`) where a difference of the
    /// waveforms themselves errs by `(h t)^2 / 6` relative, a growth with
    /// the time of the orbit or the run.
    pub fn eval3_toward(&self, other: &Waveform, t: f64) -> [f64; 3] {
        let move3 = |h: &Harmonic, g: &Harmonic, shift: f64| {
            let (s, c) = Scalar::sin_cos(h.omega * t + h.phase + shift);
            let (a, w) = (h.amplitude, h.omega);
            let (da, dw, dth) = (g.amplitude - a, g.omega - w, (g.omega - w) * t + (g.phase - h.phase));
            [
                a * c + da * c - a * s * dth,
                -a * w * s - (da * w + a * dw) * s - a * w * c * dth,
                -a * w * w * c - (da * w * w + 2.0 * a * w * dw) * c + a * w * w * s * dth,
            ]
        };
        match (self, other) {
            (Self::Cos(h), Self::Cos(g)) => move3(h, g, 0.0),
            (Self::Sin(h), Self::Sin(g)) => move3(h, g, -std::f64::consts::FRAC_PI_2),
            (Self::Harmonics(hs), Self::Harmonics(gs)) if hs.len() == gs.len() => {
                hs.iter().zip(gs).map(|(h, g)| move3(h, g, 0.0)).fold([0.0; 3], add3)
            }
            (Self::Sum(ws), Self::Sum(vs)) if ws.len() == vs.len() => {
                ws.iter().zip(vs).map(|(w, v)| w.eval3_toward(v, t)).fold([0.0; 3], add3)
            }
            _ => other.eval3(t),
        }
    }

    /// Checks the numbers: all finite, values, rates and times at most
    /// [`crate::settings::MAX_MAGNITUDE`], frequencies at most [`crate::settings::MAX_RATE`]
    /// (faster ones change within the rounding level of t), phases at most
    /// [`crate::settings::MAX_ANGLE`]; tables sorted and of equal length,
    /// two times at least for a periodic one; a sum's terms, none a sum,
    /// at least one.
    ///
    /// # Errors
    /// A sentence saying what is wrong, naming the number and its value.
    pub fn validate(&self) -> Result<(), String> {
        let finite = crate::settings::check_magnitude;
        let harmonic = |h: &Harmonic| -> Result<(), String> {
            finite("amplitude", h.amplitude)?;
            crate::settings::check_rate("omega", h.omega)?;
            crate::settings::check_angle("phase", h.phase)?;
            crate::settings::check_angle("phase_step", h.phase_step)
        };
        match self {
            Self::Constant(v) => finite("constant", *v),
            Self::Cos(h) | Self::Sin(h) => harmonic(h),
            Self::Harmonics(hs) => hs.iter().try_for_each(harmonic),
            Self::Spline(s) => {
                let d = s.data();
                if d.t.len() < 2 || d.t.len() != d.value.len() {
                    return Err(format!(
                        "a spline needs as many values as times, at least two: got {} times and {} values",
                        d.t.len(),
                        d.value.len()
                    ));
                }
                Self::Table(Table { t: d.t.clone(), value: d.value.clone(), extrapolate: d.extrapolate }).validate()?;
                d.slope_start.into_iter().chain(d.slope_end).try_for_each(|v| finite("slope", v))
            }
            Self::Linear(l) => finite("value", l.value).and_then(|()| finite("rate", l.rate)),
            Self::Sum(terms) => {
                if terms.is_empty() {
                    return Err("a sum needs at least one term".into());
                }
                for (k, w) in terms.iter().enumerate() {
                    if matches!(w, Self::Sum(_)) {
                        return Err(format!("term {k} of a sum is a sum; write its terms in the outer one"));
                    }
                    w.validate().map_err(|e| format!("term {k} of the sum: {e}"))?;
                }
                Ok(())
            }
            Self::Table(tab) => {
                if tab.extrapolate == Extrapolate::Periodic && tab.t.len() < 2 {
                    return Err(
                        "a periodic table needs two times at least (its period is the last less the first)".into()
                    );
                }
                if tab.t.is_empty() || tab.t.len() != tab.value.len() {
                    return Err(format!(
                        "a table needs as many values as times, at least one: got {} times and {} values",
                        tab.t.len(),
                        tab.value.len()
                    ));
                }
                for (k, (&t, &v)) in tab.t.iter().zip(&tab.value).enumerate() {
                    finite(&format!("t[{k}]"), t)?;
                    finite(&format!("value[{k}]"), v)?;
                }
                match tab.t.windows(2).position(|w| w[1] <= w[0]) {
                    Some(k) => Err(format!(
                        "table times must increase strictly: t[{}] = {} follows t[{k}] = {}",
                        k + 1,
                        tab.t[k + 1],
                        tab.t[k]
                    )),
                    None => Ok(()),
                }
            }
        }
    }
}

impl Table {
    /// The segment `(k, t)` that gives the value at `t` \[s\]: `t` in
    /// `[t_k, t_k+1]` (wrapped when periodic; an end segment continued
    /// when linear), or `None` where the end value is held.
    fn segment(&self, t: f64) -> Option<(usize, f64)> {
        let n = self.t.len();
        if n < 2 {
            return None;
        }
        let t = match self.extrapolate.locate(t, self.t[0], self.t[n - 1]) {
            Ok(t) => t,
            Err(end) if self.extrapolate == Extrapolate::Linear => return Some((if end == 0 { 0 } else { n - 2 }, t)),
            Err(_) => return None,
        };
        Some((self.t.partition_point(|&tk| tk <= t).clamp(1, n - 1) - 1, t))
    }

    /// The interpolated value at `t` \[s\].
    pub fn eval(&self, t: f64) -> f64 {
        match self.segment(t) {
            Some((k, t)) => {
                let (t0, t1) = (self.t[k], self.t[k + 1]);
                let (v0, v1) = (self.value[k], self.value[k + 1]);
                v0 + (v1 - v0) * (t - t0) / (t1 - t0)
            }
            None if t < self.t[0] => self.value[0],
            None => self.value[self.value.len() - 1],
        }
    }

    /// The slope at `t` \[unit/s\]: the segment's (the later one's at a
    /// knot), zero where the end value is held.
    pub fn slope(&self, t: f64) -> f64 {
        match self.segment(t) {
            Some((k, _)) => (self.value[k + 1] - self.value[k]) / (self.t[k + 1] - self.t[k]),
            None => 0.0,
        }
    }
}

/// Whether the times `span = (first, last)` \[s\] on which a waveform or
/// a force is defined ([`Waveform::span`]) cover a run's `[0, t_end]`.
///
/// # Errors
/// A sentence naming the times covered and the run's, and the way out
/// (`extrapolate`).
pub fn covers((first, last): (f64, f64), t_end: f64) -> Result<(), String> {
    if first <= 0.0 && last >= t_end {
        return Ok(());
    }
    Err(format!(
        "its table covers [{}, {}] s but the run covers [0, {}] s: extend the table, or say what it is outside its times with `extrapolate = \"hold\"` (its end values), \"linear\" or \"periodic\"",
        crate::names::fmt_value(first),
        crate::names::fmt_value(last),
        crate::names::fmt_value(t_end)
    ))
}

/// Componentwise sum of two `(w, w', w'')`.
fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_waveform_at_hand_computed_values() {
        let h = Harmonic { amplitude: 2.0, omega: 3.0, phase: 0.5, phase_step: 0.0 };
        assert_eq!(Waveform::Constant(1.5).eval(7.0), 1.5);
        // the waveforms take `Scalar`'s sine and cosine, as the generated
        // code does (the libm crate's: `crate::scalar`)
        assert_eq!(Waveform::Cos(h).eval(0.25), 2.0 * Scalar::cos(0.75f64 + 0.5));
        assert_eq!(Waveform::Sin(h).eval(0.25), 2.0 * Scalar::sin(0.75f64 + 0.5));
        let two = Waveform::Harmonics(vec![h, Harmonic { amplitude: -1.0, omega: 1.0, phase: 0.0, phase_step: 0.0 }]);
        assert_eq!(two.eval(0.25), 2.0 * Scalar::cos(1.25f64) - Scalar::cos(0.25f64));
        let tab = Waveform::Table(Table {
            t: vec![0.0, 1.0, 3.0],
            value: vec![0.0, 2.0, -2.0],
            extrapolate: Extrapolate::Hold,
        });
        for (t, v) in
            [(-1.0, 0.0), (0.0, 0.0), (0.5, 1.0), (1.0, 2.0), (2.0, 0.0), (2.5, -1.0), (3.0, -2.0), (9.0, -2.0)]
        {
            assert_eq!(tab.eval(t), v, "table at t = {t}");
        }
    }

    /// Each waveform's first and second derivatives against central
    /// differences (h = 1e-4: truncation about 1e-8 |w^(3)|, rounding
    /// about 1e-12 / h).
    #[test]
    fn derivatives_match_differences_of_the_values() {
        let h = Harmonic { amplitude: 2.0, omega: 3.0, phase: 0.5, phase_step: 0.0 };
        let knots = SplineData {
            t: vec![0.0, 0.4, 1.0, 1.7, 2.0],
            value: vec![0.0, 0.3, -0.2, 0.5, 0.1],
            slope_start: Some(0.0),
            slope_end: None,
            extrapolate: Default::default(),
        };
        let waves = [
            Waveform::Cos(h),
            Waveform::Sin(h),
            Waveform::Harmonics(vec![h, Harmonic { amplitude: 0.5, omega: 7.0, phase: -1.0, phase_step: 0.0 }]),
            Waveform::Spline(Spline::new(knots)),
        ];
        let d = 1e-4;
        for w in &waves {
            for t in [0.13, 0.55, 1.2, 1.9] {
                let [v, d1, d2] = w.eval3(t);
                assert!((v - w.eval(t)).abs() <= 1e-15 * (1.0 + v.abs()));
                let fd1 = (w.eval(t + d) - w.eval(t - d)) / (2.0 * d);
                let fd2 = (w.eval3(t + d)[1] - w.eval3(t - d)[1]) / (2.0 * d);
                assert!((d1 - fd1).abs() <= 1e-6 * (1.0 + d1.abs()), "{w:?} at {t}: {d1} vs {fd1}");
                assert!((d2 - fd2).abs() <= 1e-5 * (1.0 + d2.abs()), "{w:?} at {t}: {d2} vs {fd2}");
            }
        }
    }

    /// The linearization toward a harmonic's moved numbers: equal to
    /// `eval3` with no move, and its central difference along a move
    /// equal to the exact derivative `d(eval3)/d(amplitude, omega, phase)`
    /// at a late time (a difference of the waveforms themselves errs by
    /// `(h t)^2 / 6` relative: 2.4e-7 at h = 1e-5, t = 120 s).
    #[test]
    fn linearization_toward_moved_numbers_is_exact_in_time() {
        let h = Harmonic { amplitude: 2.0, omega: 3.0, phase: 0.5, phase_step: 0.0 };
        let d = Harmonic { amplitude: 0.3, omega: 1.0, phase: -0.2, phase_step: 0.0 };
        let moved = |s: f64| Harmonic {
            amplitude: h.amplitude + s * d.amplitude,
            omega: h.omega + s * d.omega,
            phase: h.phase + s * d.phase,
            phase_step: 0.0,
        };
        let t = 120.0;
        for (base, make) in [
            (Waveform::Cos(h), Waveform::Cos as fn(Harmonic) -> Waveform),
            (Waveform::Sin(h), Waveform::Sin as fn(Harmonic) -> Waveform),
        ] {
            assert_eq!(base.eval3_toward(&base, t), base.eval3(t));
            let eps = 1e-5;
            let lin = |s: f64| base.eval3_toward(&make(moved(s)), t);
            // exact derivative of a cos(omega t + phase + shift) along d
            let shift = if matches!(base, Waveform::Cos(_)) { 0.0 } else { -std::f64::consts::FRAC_PI_2 };
            let th = h.omega * t + h.phase + shift;
            let dth = d.omega * t + d.phase;
            let (a, w) = (h.amplitude, h.omega);
            let exact = [
                d.amplitude * th.cos() - a * th.sin() * dth,
                -(d.amplitude * w + a * d.omega) * th.sin() - a * w * th.cos() * dth,
                -(d.amplitude * w * w + 2.0 * a * w * d.omega) * th.cos() + a * w * w * th.sin() * dth,
            ];
            for k in 0..3 {
                let fd = (lin(eps)[k] - lin(-eps)[k]) / (2.0 * eps);
                let scale = exact[k].abs().max(1.0);
                assert!((fd - exact[k]).abs() <= 1e-9 * scale, "{base:?} [{k}]: {fd} vs {exact:?}");
            }
        }
    }

    /// The spline is exact for a cubic when its end slopes are given, and
    /// its second derivative is continuous across the knots.
    #[test]
    fn spline_interpolates_and_is_smooth() {
        let f = |t: f64| 1.0 + 0.5 * t - 0.3 * t * t + 0.2 * t * t * t;
        let df = |t: f64| 0.5 - 0.6 * t + 0.6 * t * t;
        let t: Vec<f64> = vec![0.0, 0.3, 0.7, 1.0, 1.6, 2.0];
        let s = Spline::new(SplineData {
            value: t.iter().map(|&x| f(x)).collect(),
            slope_start: Some(df(0.0)),
            slope_end: Some(df(2.0)),
            t: t.clone(),
            extrapolate: Default::default(),
        });
        for x in [0.0, 0.1, 0.35, 0.9, 1.3, 1.99] {
            assert!((s.eval3(x)[0] - f(x)).abs() <= 1e-13, "at {x}: {} vs {}", s.eval3(x)[0], f(x));
        }
        for &k in &t[1..t.len() - 1] {
            let (l, r) = (s.eval3(k - 1e-12), s.eval3(k + 1e-12));
            assert!((l[2] - r[2]).abs() <= 1e-9, "second derivative jumps at {k}");
        }
    }

    #[test]
    fn bad_tables_are_named() {
        let t = |t: Vec<f64>, value: Vec<f64>| {
            Waveform::Table(Table { t, value, extrapolate: Extrapolate::Hold }).validate().unwrap_err()
        };
        assert!(t(vec![0.0, 1.0], vec![1.0]).contains("2 times and 1 values"));
        assert!(t(vec![0.0, 1.0, 1.0], vec![1.0; 3]).contains("t[2] = 1 follows t[1] = 1"));
        assert!(t(vec![], vec![]).contains("at least one"));
        assert!(Waveform::Constant(f64::NAN).validate().unwrap_err().contains("must be finite"));
    }
    /// A ramp, a sum and the extrapolations at hand-computed values:
    /// a table continued along its end segments or repeated, a spline
    /// continued along its end slopes (its second derivative zero
    /// outside); their periodicities.
    #[test]
    fn ramps_sums_and_extrapolations_at_hand_computed_values() {
        let ramp = Waveform::Linear(Linear { value: 1.0, rate: 2.0 });
        assert_eq!(ramp.eval3(3.0), [7.0, 2.0, 0.0]);
        let sum = Waveform::Sum(vec![ramp.clone(), Waveform::sin(0.5, 3.0)]);
        let t: f64 = 0.7;
        let want = [1.0 + 2.0 * t + 0.5 * (3.0 * t).sin(), 2.0 + 1.5 * (3.0 * t).cos(), -4.5 * (3.0 * t).sin()];
        let got = sum.eval3(t);
        assert!((0..3).all(|k| (got[k] - want[k]).abs() < 1e-15), "{got:?} vs {want:?}");
        assert_eq!(sum.eval(t), got[0]);
        let table = |extrapolate| Table { t: vec![0.0, 1.0, 2.0], value: vec![0.0, 1.0, 3.0], extrapolate };
        let held = table(Extrapolate::Hold);
        assert_eq!((held.eval(-1.0), held.eval(5.0), held.slope(5.0)), (0.0, 3.0, 0.0));
        let line = table(Extrapolate::Linear);
        assert_eq!((line.eval(-1.0), line.slope(-1.0), line.eval(3.0), line.slope(3.0)), (-1.0, 1.0, 5.0, 2.0));
        let wrap = table(Extrapolate::Periodic);
        assert_eq!((wrap.eval(2.5), wrap.eval(-0.5), wrap.slope(3.5)), (0.5, 2.0, 2.0));
        assert_eq!(Waveform::Table(wrap).periodicity(), Periodicity::Period(2.0));
        assert_eq!(Waveform::Table(line).periodicity(), Periodicity::Aperiodic);
        assert_eq!(sum.periodicity(), Periodicity::Aperiodic);
        assert_eq!(Waveform::Linear(Linear { value: 1.0, rate: 0.0 }).periodicity(), Periodicity::Constant);
        // a natural spline through three points, continued past its last
        // knot along its end slope
        let s = Spline::new(SplineData {
            t: vec![0.0, 1.0, 2.0],
            value: vec![0.0, 1.0, 0.0],
            slope_start: None,
            slope_end: None,
            extrapolate: Extrapolate::Linear,
        });
        let end = s.eval3(2.0);
        let past = s.eval3(2.5);
        assert_eq!(past, [end[0] + 0.5 * end[1], end[1], 0.0]);
        assert!(end[2].abs() < 1e-15, "natural: {end:?}");
        // a sum of sums and an empty sum are refused
        let nested = Waveform::Sum(vec![Waveform::Sum(vec![ramp.clone()])]).validate().unwrap_err();
        assert!(nested.contains("term 0 of a sum is a sum"), "{nested}");
        assert!(Waveform::Sum(vec![]).validate().unwrap_err().contains("at least one term"));
        let bad = Waveform::Linear(Linear { value: 0.0, rate: f64::NAN }).validate().unwrap_err();
        assert!(bad.contains("rate"), "{bad}");
    }

    #[test]
    fn a_table_is_defined_on_its_times_unless_it_says_otherwise() {
        let table = |t: Vec<f64>, extrapolate| {
            let value = vec![1.0; t.len()];
            Waveform::Table(Table { t, value, extrapolate })
        };
        let everywhere = (f64::NEG_INFINITY, f64::INFINITY);
        // the default is none: a scene's table without the key
        assert_eq!(Extrapolate::default(), Extrapolate::None);
        let short = table(vec![0.0, 2.0], Extrapolate::None);
        assert_eq!(short.span(), (0.0, 2.0));
        assert_eq!(short.check_span(2.0), Ok(()));
        let e = short.check_span(2.5).unwrap_err();
        assert!(e.contains("covers [0, 2] s but the run covers [0, 2.5] s") && e.contains("\"hold\""), "{e}");
        // a table that starts late leaves the run's start undefined
        assert!(table(vec![0.5, 9.0], Extrapolate::None).check_span(1.0).unwrap_err().contains("[0.5, 9]"));
        for x in [Extrapolate::Hold, Extrapolate::Linear, Extrapolate::Periodic] {
            assert_eq!(table(vec![0.0, 2.0], x).span(), everywhere, "{x:?}");
        }
        // a sum is defined where every term is; a harmonic everywhere
        let sum = Waveform::Sum(vec![
            table(vec![-1.0, 3.0], Extrapolate::None),
            Waveform::sin(1.0, 2.0),
            table(vec![0.5, 5.0], Extrapolate::None),
        ]);
        assert_eq!(sum.span(), (0.5, 3.0));
        assert_eq!(Waveform::sin(1.0, 2.0).span(), everywhere);
        let spline = Spline::new(SplineData {
            t: vec![0.0, 1.0, 2.0],
            value: vec![0.0, 1.0, 0.0],
            slope_start: None,
            slope_end: None,
            extrapolate: Extrapolate::None,
        });
        assert_eq!(Waveform::Spline(spline).span(), (0.0, 2.0));
    }
}

/// A forced orbit's start and period in periods of its forcing, taken at
/// the first point of a branch and kept ([`Periodicity::orbit_timing`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct OrbitTiming {
    /// `(t0 / T_f, T / T_f)`, once taken.
    kept: Option<(f64, f64)>,
}

/// How a quantity depends on time, for the analyses that need a scene's
/// forcing period ([`crate::analysis`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Periodicity {
    /// Does not change with time.
    Constant,
    /// Repeats with this period \[s\] (the smallest one known).
    Period(f64),
    /// Changes with time without a period (a table, a spline).
    Aperiodic,
}

impl Periodicity {
    /// The periodicity of a sum or combination of quantities with these
    /// periodicities: constant if all are, the smallest common period if
    /// every period divides it (found among the first 64 multiples of the
    /// longest, each ratio whole to 1e-9), aperiodic otherwise.
    pub fn combine(parts: impl IntoIterator<Item = Periodicity>) -> Periodicity {
        let mut periods = Vec::new();
        for p in parts {
            match p {
                Periodicity::Constant => {}
                Periodicity::Period(t) => periods.push(t),
                Periodicity::Aperiodic => return Periodicity::Aperiodic,
            }
        }
        let Some(longest) = periods.iter().copied().reduce(f64::max) else { return Periodicity::Constant };
        (1..=64)
            .map(|n| n as f64 * longest)
            .find(|t| periods.iter().all(|p| ((t / p) - (t / p).round()).abs() < 1e-9))
            .map_or(Periodicity::Aperiodic, Periodicity::Period)
    }

    /// The period \[s\], where this repeats with one.
    pub fn period(self) -> Option<f64> {
        match self {
            Periodicity::Period(t) => Some(t),
            _ => None,
        }
    }

    /// How many periods of this forcing make `period` \[s\]: `Some(n)`
    /// where this repeats with a period `T_f` and `period = n T_f` for a
    /// whole `n >= 1` (to 1e-9 relative), the only periods a periodic
    /// orbit of a scene forced so can have; `None` otherwise (a constant
    /// forcing: an autonomous scene's orbit has a period of its own).
    pub fn whole_periods(self, period: f64) -> Option<f64> {
        let m = period / self.period()?;
        (m >= 0.5 && (m - m.round()).abs() <= 1e-9 * m).then(|| m.round())
    }

    /// The start and period `(t0, T)` \[s\] of an orbit of a scene forced
    /// so, as `timing` keeps them: at its first use, the start's phase
    /// `t0 / T_f` and the period's whole number of forcing periods `T_f`
    /// (the nearest, at least 1) are taken from `(t0, period)`; then every
    /// call gives `(phase T_f, n T_f)` at the scene's own `T_f`, so that a
    /// parameter that moves the forcing's frequency moves both with it
    /// and every point of a branch is its orbit at one phase of its
    /// forcing (as a gait's derivatives hold it, [`crate::sensitivity`]).
    /// `(t0, period)` themselves where the scene is not forced
    /// periodically.
    pub fn orbit_timing(self, timing: &mut OrbitTiming, t0: f64, period: f64) -> (f64, f64) {
        let Some(forcing) = self.period() else { return (t0, period) };
        let (phase, n) = *timing.kept.get_or_insert_with(|| (t0 / forcing, (period / forcing).round().max(1.0)));
        (phase * forcing, n * forcing)
    }
}

impl Waveform {
    /// The highest angular frequency \[rad/s\] among its harmonics of
    /// nonzero amplitude; 0 for a constant, a table or a spline (whose
    /// corners a fixed step passes at its own pace).
    pub fn max_omega(&self) -> f64 {
        let omega = |h: &Harmonic| if h.amplitude == 0.0 { 0.0 } else { h.omega.abs() };
        match self {
            Waveform::Cos(h) | Waveform::Sin(h) => omega(h),
            Waveform::Harmonics(hs) => hs.iter().map(omega).fold(0.0, f64::max),
            Waveform::Sum(terms) => terms.iter().map(Waveform::max_omega).fold(0.0, f64::max),
            Waveform::Constant(_) | Waveform::Table(_) | Waveform::Spline(_) | Waveform::Linear(_) => 0.0,
        }
    }

    /// The times \[s\] on which the waveform is defined, `(first, last)`:
    /// a table's or a spline's `[t_0, t_last]` where it does not
    /// extrapolate ([`Extrapolate::None`]), everywhere (`(-inf, inf)`)
    /// otherwise; a sum's the intersection of its terms'. A run over
    /// `[0, t_end]` needs `first <= 0` and `last >= t_end`
    /// ([`Waveform::check_span`]).
    pub fn span(&self) -> (f64, f64) {
        match self {
            Waveform::Table(Table { t, extrapolate: Extrapolate::None, .. })
            | Waveform::Spline(Spline { data: SplineData { t, extrapolate: Extrapolate::None, .. }, .. })
                if !t.is_empty() =>
            {
                (t[0], t[t.len() - 1])
            }
            Waveform::Sum(terms) => terms
                .iter()
                .map(Waveform::span)
                .fold((f64::NEG_INFINITY, f64::INFINITY), |(a, b), (c, d)| (a.max(c), b.min(d))),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    /// Whether the waveform is defined over a run's `[0, t_end]` \[s\]
    /// ([`Waveform::span`]; `covers`).
    ///
    /// # Errors
    /// The sentence of `covers` (this module's).
    pub fn check_span(&self, t_end: f64) -> Result<(), String> {
        covers(self.span(), t_end)
    }

    /// How the waveform depends on time: a harmonic of angular frequency
    /// `omega` repeats every `2 pi / |omega|` (constant when `omega = 0`
    /// or its amplitude is 0); a periodic table or spline every `t_last -
    /// t_0`; other tables and splines and a ramp (of nonzero rate) are
    /// aperiodic; a sum as [`Periodicity::combine`] of its terms.
    pub fn periodicity(&self) -> Periodicity {
        let harmonic = |h: &Harmonic| {
            if h.omega == 0.0 || h.amplitude == 0.0 {
                Periodicity::Constant
            } else {
                Periodicity::Period(2.0 * std::f64::consts::PI / h.omega.abs())
            }
        };
        match self {
            Waveform::Constant(_) => Periodicity::Constant,
            Waveform::Cos(h) | Waveform::Sin(h) => harmonic(h),
            Waveform::Harmonics(hs) => Periodicity::combine(hs.iter().map(harmonic)),
            Waveform::Table(Table { t, value, extrapolate })
            | Waveform::Spline(Spline { data: SplineData { t, value, extrapolate, .. }, .. }) => {
                if value.iter().all(|v| *v == value[0]) {
                    Periodicity::Constant
                } else if *extrapolate == Extrapolate::Periodic {
                    Periodicity::Period(t[t.len() - 1] - t[0])
                } else {
                    Periodicity::Aperiodic
                }
            }
            Waveform::Linear(l) if l.rate == 0.0 => Periodicity::Constant,
            Waveform::Linear(_) => Periodicity::Aperiodic,
            Waveform::Sum(terms) => Periodicity::combine(terms.iter().map(Waveform::periodicity)),
        }
    }
}
