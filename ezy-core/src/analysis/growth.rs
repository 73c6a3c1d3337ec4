//! A motion that gains energy without bound, measured: the verdict of
//! [`Analysis::gait_or_growth`](super::Analysis::gait_or_growth) where a
//! periodically forced scene has no gait because the forcing's work is
//! not taken by a loss.
//!
//! Seen stroboscopically, at the ends of the forcing's periods, such a
//! motion's kinetic energy `T` and speed `v` grow like powers of time,
//! `T ~ t^a`, `v ~ t^b`. Each exponent is measured by its own
//! least-squares fit of the logarithms (`ln T` against `ln t`, `ln v`
//! against `ln t`), not one from the other: `b = a / 2` holds only where
//! the energy is the translation's alone, and where the speed is not yet
//! on its asymptote (a finite window) the two fits differ. The example is
//! the Chaplygin sleigh with a rotor whose angular momentum varies
//! periodically and no friction, whose speed grows like `t^(1/3)` and
//! energy like `t^(2/3)` (Bizyaev, Borisov, Kozlov & Mamaev, "Fermi-like
//! acceleration and power-law energy growth in nonholonomic systems",
//! Nonlinearity 32, 3209, 2019: an analogue of Fermi's acceleration).

use crate::names::fmt_value;

/// A power law `y = c t^a` fitted by least squares to the logarithms,
/// `ln y = ln c + a ln t`, over a window's samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerLaw {
    /// The exponent `a` (dimensionless).
    pub exponent: f64,
    /// The coefficient `c`, in the unit of `y` per `s^a`.
    pub coefficient: f64,
    /// The root mean square of the fit's residuals `ln y_k - ln c - a ln
    /// t_k` (dimensionless: a relative error of `y`).
    pub residual: f64,
    /// The exponent's standard error, `sqrt(s^2 / sum (ln t_k - mean)^2)`
    /// with `s^2` the residuals' sum of squares over `n - 2`.
    pub std_error: f64,
}

impl PowerLaw {
    /// The least-squares power law through the samples `(t_k, y_k)`;
    /// `None` where there are fewer than 3, or a `t_k` or `y_k` is not
    /// positive and finite, or all `t_k` are equal.
    pub fn fit(t: &[f64], y: &[f64]) -> Option<PowerLaw> {
        let n = t.len();
        let good = |v: &f64| v.is_finite() && *v > 0.0;
        if n < 3 || y.len() != n || !t.iter().all(good) || !y.iter().all(good) {
            return None;
        }
        let (lx, ly): (Vec<f64>, Vec<f64>) = t.iter().zip(y).map(|(t, y)| (t.ln(), y.ln())).unzip();
        let (mx, my) = (lx.iter().sum::<f64>() / n as f64, ly.iter().sum::<f64>() / n as f64);
        let sxx: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
        let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
        if sxx <= 0.0 {
            return None;
        }
        let exponent = sxy / sxx;
        let intercept = my - exponent * mx;
        let ssr: f64 = lx.iter().zip(&ly).map(|(x, y)| (y - intercept - exponent * x).powi(2)).sum();
        let law = PowerLaw {
            exponent,
            coefficient: intercept.exp(),
            residual: (ssr / n as f64).sqrt(),
            std_error: (ssr / (n - 2) as f64 / sxx).sqrt(),
        };
        [law.exponent, law.coefficient, law.residual, law.std_error].iter().all(|v| v.is_finite()).then_some(law)
    }
}

/// The power laws of one window of the stroboscopic samples.
#[derive(Debug, Clone, PartialEq)]
pub struct GrowthFit {
    /// The window's first and last sample time \[s\].
    pub t: [f64; 2],
    /// The samples in it (period ends, both ends included).
    pub samples: usize,
    /// The kinetic energy's law `T ~ t^a` (`T` in J).
    pub energy: PowerLaw,
    /// The speed's law `v ~ t^b` (`v` in m/s), by its own fit; `None`
    /// where the reference body stands still at a period end (a motion
    /// that grows in rotation alone).
    pub speed: Option<PowerLaw>,
}

/// A motion that gains energy without bound, measured over the second
/// half of the run that found it ([`Analysis::settle`](super::Analysis::settle)).
#[derive(Debug, Clone, PartialEq)]
pub struct Growth {
    /// The forcing's period \[s\].
    pub period: f64,
    /// The sample times \[s\]: the ends of the forcing's periods over the
    /// run's second half, from the scene's start at `t = 0` (the laws'
    /// origin of time).
    pub t: Vec<f64>,
    /// The kinetic energy at each sample \[J\] (as `t`), growing at every
    /// sample.
    pub energy: Vec<f64>,
    /// The reference body's (the model's first) speed `|(x', y')|` at
    /// each sample \[m/s\] (as `t`).
    pub speed: Vec<f64>,
    /// The laws over all the samples.
    pub whole: GrowthFit,
    /// The laws over each half of the samples, the run's third and fourth
    /// quarters (the middle sample in both): exponents that agree say the
    /// growth is steady over the window; the slow approach of an
    /// asymptotic exponent shows as a drift between them.
    pub quarters: [GrowthFit; 2],
}

impl Growth {
    /// The growth measured from the samples `(t, T, v)` at the period ends
    /// (`t` \[s\], `T` \[J\], `v` \[m/s\]), `None` where there are fewer
    /// than 5 or the energy's law cannot be fitted (a sample not positive).
    pub(crate) fn measure(period: f64, samples: &[(f64, f64, f64)]) -> Option<Growth> {
        if samples.len() < 5 {
            return None;
        }
        let t: Vec<f64> = samples.iter().map(|s| s.0).collect();
        let energy: Vec<f64> = samples.iter().map(|s| s.1).collect();
        let speed: Vec<f64> = samples.iter().map(|s| s.2).collect();
        let fit = |r: std::ops::Range<usize>| -> Option<GrowthFit> {
            Some(GrowthFit {
                t: [t[r.start], t[r.end - 1]],
                samples: r.len(),
                energy: PowerLaw::fit(&t[r.clone()], &energy[r.clone()])?,
                speed: PowerLaw::fit(&t[r.clone()], &speed[r]),
            })
        };
        let (n, mid) = (t.len(), t.len() / 2);
        let whole = fit(0..n)?;
        let quarters = [fit(0..mid + 1)?, fit(mid..n)?];
        Some(Growth { period, t, energy, speed, whole, quarters })
    }

    /// The verdict in words: the energy's and the speed's laws with their
    /// residuals, the quarters' exponents, and the energy's first and
    /// last samples.
    pub fn describe(&self) -> String {
        let law = |p: &PowerLaw| {
            format!(
                "like t^{:.4} (standard error {:.1e}, RMS residual of the log fit {:.1e})",
                p.exponent, p.std_error, p.residual
            )
        };
        let [q3, q4] = &self.quarters;
        let n = self.t.len() - 1;
        let mut s = format!(
            "the motion gains energy without bound: at the ends of the forcing's periods ({} s) its kinetic energy grows in every period, from {} J at t = {} s to {} J at t = {} s, {}",
            fmt_value(self.period),
            sig7(self.energy[0]),
            fmt_value(self.t[0]),
            sig7(self.energy[n]),
            fmt_value(self.t[n]),
            law(&self.whole.energy)
        );
        match &self.whole.speed {
            Some(v) => s.push_str(&format!(", and the speed of the reference body {}", law(v))),
            None => s.push_str(", while the reference body stands still at a period end (no speed law)"),
        }
        s.push_str(&format!(
            "; over the run's third and fourth quarters the energy like t^{:.4} and t^{:.4}",
            q3.energy.exponent, q4.energy.exponent
        ));
        if let (Some(a), Some(b)) = (&q3.speed, &q4.speed) {
            s.push_str(&format!(", the speed like t^{:.4} and t^{:.4}", a.exponent, b.exponent));
        }
        s
    }
}

/// `v` to 7 significant digits.
pub(crate) fn sig7(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return fmt_value(v);
    }
    let scale = 10f64.powi(6 - v.abs().log10().floor() as i32);
    fmt_value((v * scale).round() / scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exact_power_law_is_fitted_to_rounding() {
        let t: Vec<f64> = (10..=20).map(f64::from).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * t.powf(2.0 / 3.0)).collect();
        let p = PowerLaw::fit(&t, &y).unwrap();
        assert!((p.exponent - 2.0 / 3.0).abs() < 1e-13, "{p:?}");
        assert!((p.coefficient - 3.0).abs() < 1e-12, "{p:?}");
        assert!(p.residual < 1e-14 && p.std_error < 1e-13, "{p:?}");
    }

    #[test]
    fn a_sample_not_positive_has_no_law() {
        assert_eq!(PowerLaw::fit(&[1.0, 2.0, 3.0], &[1.0, 0.0, 2.0]), None);
        assert_eq!(PowerLaw::fit(&[1.0, 2.0, 3.0], &[1.0, f64::NAN, 2.0]), None);
        assert_eq!(PowerLaw::fit(&[1.0, 2.0], &[1.0, 2.0]), None);
        assert_eq!(PowerLaw::fit(&[2.0, 2.0, 2.0], &[1.0, 2.0, 3.0]), None);
    }
}
