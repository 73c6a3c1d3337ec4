//! Time functions of the effects: a torque or force given as a constant, a
//! cosine or sine, a sum of harmonics, or a piecewise-linear table.

use serde::{Deserialize, Serialize};

/// One harmonic `amplitude cos(omega t + phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Harmonic {
    /// Amplitude (unit of the quantity: [N m] for a torque, [N] for a force).
    pub amplitude: f64,
    /// Angular frequency [rad/s].
    pub omega: f64,
    /// Phase [rad].
    #[serde(default)]
    pub phase: f64,
}

/// A piecewise-linear function of time through the points `(t_k, value_k)`,
/// held constant before the first and after the last point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table {
    /// Times [s], strictly increasing.
    pub t: Vec<f64>,
    /// Values at those times (same length as `t`).
    pub value: Vec<f64>,
}

/// A scalar function of time `w(t)`. In a scene file it is a one-key table:
///
/// ```toml
/// torque = { constant = 2.0 }
/// torque = { cos = { amplitude = 2.0, omega = 3.141592653589793, phase = 0.0 } }
/// torque = { sin = { amplitude = 2.0, omega = 3.141592653589793 } }
/// torque = { harmonics = [{ amplitude = 2.0, omega = 3.14 }, { amplitude = 0.5, omega = 9.42, phase = 1.0 }] }
/// torque = { table = { t = [0.0, 1.0, 2.0], value = [0.0, 2.0, 0.0] } }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Waveform {
    /// `w(t) = value`.
    Constant(f64),
    /// `w(t) = amplitude cos(omega t + phase)` (the seed's motor with phase 0).
    Cos(Harmonic),
    /// `w(t) = amplitude sin(omega t + phase)`.
    Sin(Harmonic),
    /// `w(t) = sum_k amplitude_k cos(omega_k t + phase_k)`.
    Harmonics(Vec<Harmonic>),
    /// Linear interpolation in a table.
    Table(Table),
}

impl Default for Waveform {
    fn default() -> Self {
        Self::Constant(0.0)
    }
}

impl Waveform {
    /// `w(t)`.
    #[inline]
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            Self::Constant(v) => *v,
            Self::Cos(h) => h.amplitude * (h.omega * t + h.phase).cos(),
            Self::Sin(h) => h.amplitude * (h.omega * t + h.phase).sin(),
            Self::Harmonics(hs) => hs.iter().map(|h| h.amplitude * (h.omega * t + h.phase).cos()).sum(),
            Self::Table(tab) => tab.eval(t),
        }
    }

    /// Checks the numbers: all finite, tables sorted and of equal length.
    ///
    /// # Errors
    /// A sentence saying what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        let finite =
            |name: &str, v: f64| if v.is_finite() { Ok(()) } else { Err(format!("{name} = {v} must be finite")) };
        let harmonic = |h: &Harmonic| -> Result<(), String> {
            finite("amplitude", h.amplitude)?;
            finite("omega", h.omega)?;
            finite("phase", h.phase)
        };
        match self {
            Self::Constant(v) => finite("constant", *v),
            Self::Cos(h) | Self::Sin(h) => harmonic(h),
            Self::Harmonics(hs) => hs.iter().try_for_each(harmonic),
            Self::Table(tab) => {
                if tab.t.is_empty() || tab.t.len() != tab.value.len() {
                    return Err(format!(
                        "a table needs as many values as times, at least one: got {} times and {} values",
                        tab.t.len(),
                        tab.value.len()
                    ));
                }
                tab.t.iter().chain(&tab.value).try_for_each(|&v| finite("table entry", v))?;
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
    /// The interpolated value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        let k = self.t.partition_point(|&tk| tk <= t);
        if k == 0 {
            return self.value[0];
        }
        if k == self.t.len() {
            return self.value[k - 1];
        }
        let (t0, t1) = (self.t[k - 1], self.t[k]);
        let (v0, v1) = (self.value[k - 1], self.value[k]);
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_waveform_at_hand_computed_values() {
        let h = Harmonic { amplitude: 2.0, omega: 3.0, phase: 0.5 };
        assert_eq!(Waveform::Constant(1.5).eval(7.0), 1.5);
        assert_eq!(Waveform::Cos(h).eval(0.25), 2.0 * (0.75f64 + 0.5).cos());
        assert_eq!(Waveform::Sin(h).eval(0.25), 2.0 * (0.75f64 + 0.5).sin());
        let two = Waveform::Harmonics(vec![h, Harmonic { amplitude: -1.0, omega: 1.0, phase: 0.0 }]);
        assert_eq!(two.eval(0.25), 2.0 * 1.25f64.cos() - 0.25f64.cos());
        let tab = Waveform::Table(Table { t: vec![0.0, 1.0, 3.0], value: vec![0.0, 2.0, -2.0] });
        for (t, v) in
            [(-1.0, 0.0), (0.0, 0.0), (0.5, 1.0), (1.0, 2.0), (2.0, 0.0), (2.5, -1.0), (3.0, -2.0), (9.0, -2.0)]
        {
            assert_eq!(tab.eval(t), v, "table at t = {t}");
        }
    }

    #[test]
    fn bad_tables_are_named() {
        let t = |t: Vec<f64>, value: Vec<f64>| Waveform::Table(Table { t, value }).validate().unwrap_err();
        assert!(t(vec![0.0, 1.0], vec![1.0]).contains("2 times and 1 values"));
        assert!(t(vec![0.0, 1.0, 1.0], vec![1.0; 3]).contains("t[2] = 1 follows t[1] = 1"));
        assert!(t(vec![], vec![]).contains("at least one"));
        assert!(Waveform::Constant(f64::NAN).validate().unwrap_err().contains("must be finite"));
    }
}
