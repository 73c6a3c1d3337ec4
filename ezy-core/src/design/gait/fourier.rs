//! Gaits as truncated Fourier series: the unknowns of a gait
//! optimization, and their map onto the [`Waveform`]s a [`Gait`] runs.

use std::f64::consts::PI;

use crate::effects::waveform::{Harmonic, Waveform};
use crate::geometry::GeometryError;
use crate::geometry::gait::Gait;
use crate::scalar::Scalar;

/// Highest harmonic order a Fourier gait may have: the trapezoidal
/// quadratures of an optimization take `40 order` samples (at least 200)
/// per cycle, and each coefficient is a dual-number pass over them.
pub const MAX_ORDER: usize = 20;

/// A closed gait, each shape coordinate a Fourier series of order `N`
/// over one period `T` (`omega = 2 pi / T`):
///
/// `r_i(t) = a_i0 + sum_{k=1..N} (a_ik cos(k omega t) + b_ik sin(k omega t))`
/// \[rad\].
///
/// The parameterization of Ramasamy & Hatton, "The geometry of optimal
/// gaits for drag-dominated kinematic systems", IEEE T-RO 35(4), 2019,
/// §V (a low-order series spans the efficient gaits of the three-link
/// systems). [`FourierGait::gait`] writes it as a [`Gait`] (a constant
/// and harmonics per coordinate) for [`crate::geometry::Geometry::predict`].
#[derive(Debug, Clone, PartialEq)]
pub struct FourierGait {
    /// The harmonic order `N` (1 to [`MAX_ORDER`]).
    pub order: usize,
    /// The period `T` \[s\]. A kinematic system's net motion per cycle
    /// does not depend on it (only on the curve and its direction).
    pub period: f64,
    /// Per shape coordinate, its `2 N + 1` coefficients \[rad\] in the
    /// order `a_0, a_1, b_1, a_2, b_2, ..., a_N, b_N`.
    pub coefficients: Vec<Vec<f64>>,
}

impl FourierGait {
    /// A gait of these coefficients (one row of `2 order + 1` per shape
    /// coordinate, see [`FourierGait::coefficients`]) and period \[s\].
    ///
    /// # Errors
    /// [`GeometryError::Request`] for an order outside 1 to
    /// [`MAX_ORDER`], a row of another length, a coefficient that is not
    /// finite, a period that is not a positive finite number, no rows.
    pub fn new(coefficients: Vec<Vec<f64>>, order: usize, period: f64) -> Result<Self, GeometryError> {
        let fail = |reason: String| Err(GeometryError::Request { reason });
        if !(1..=MAX_ORDER).contains(&order) {
            return fail(format!("Fourier gait of order {order}: give an order from 1 to {MAX_ORDER}"));
        }
        if !(period.is_finite() && period > 0.0 && period < 1e9) {
            return fail(format!(
                "Fourier gait period {}: must be a positive number of seconds below 1e9",
                crate::names::fmt_value(period)
            ));
        }
        if coefficients.is_empty() {
            return fail("a Fourier gait needs one row of coefficients per shape coordinate; none given".into());
        }
        for (i, row) in coefficients.iter().enumerate() {
            if row.len() != 2 * order + 1 {
                return fail(format!(
                    "Fourier gait coordinate {}: {} coefficients for order {order}, which takes {} (a_0, a_1, b_1, ...)",
                    i + 1,
                    row.len(),
                    2 * order + 1
                ));
            }
            if let Some(j) = row.iter().position(|v| !v.is_finite() || v.abs() > 1e6) {
                return fail(format!(
                    "Fourier gait coordinate {}: coefficient {} = {} is not a finite angle (at most 1e6 rad)",
                    i + 1,
                    coefficient_name(j),
                    row[j]
                ));
            }
        }
        Ok(Self { order, period, coefficients })
    }

    /// The Fourier series of a [`Gait`] whose every shape coordinate is a
    /// sum of harmonics ([`Gait::parse`]'s text) of whole multiples of
    /// the gait's frequency, of order `harmonics` (default: its highest
    /// harmonic, at least 1), over the period `period` \[s\] (default the
    /// gait's: the coefficients do not depend on it). `names` name the
    /// coordinates in the errors.
    ///
    /// # Errors
    /// [`GeometryError::Request`] naming the coordinate: a waveform that
    /// is not a sum of harmonics, a harmonic whose frequency is not a
    /// whole multiple of the gait's; an order below the highest harmonic
    /// or above [`MAX_ORDER`]; and [`FourierGait::new`]'s.
    pub fn from_gait(
        gait: &Gait,
        harmonics: Option<usize>,
        period: Option<f64>,
        names: &[String],
    ) -> Result<Self, GeometryError> {
        let fail = |reason: String| Err(GeometryError::Request { reason });
        let omega = 2.0 * PI / gait.period;
        let name = |k: usize| names.get(k).map_or_else(|| format!("coordinate {}", k + 1), Clone::clone);
        let mut rows: Vec<Vec<(usize, f64, f64)>> = Vec::new();
        for (k, w) in gait.shape.iter().enumerate() {
            let hs = match w {
                Waveform::Harmonics(hs) => hs.clone(),
                Waveform::Constant(c) => vec![Harmonic { amplitude: *c, omega: 0.0, phase: 0.0, phase_step: 0.0 }],
                Waveform::Cos(h) => vec![*h],
                Waveform::Sin(h) => vec![Harmonic { phase: h.phase - PI / 2.0, ..*h }],
                _ => return fail(format!("the gait's {} is not a sum of harmonics", name(k))),
            };
            let mut row = Vec::new();
            for h in &hs {
                let n = h.omega / omega;
                if (n - n.round()).abs() > 1e-9 || n.round() < 0.0 {
                    return fail(format!(
                        "the gait's {}: a harmonic of frequency {} is not a whole multiple of the period's: write cos(k*t + c) with whole k",
                        name(k),
                        crate::names::fmt_value(h.omega)
                    ));
                }
                // cos(pi / 2) is 6e-17 in floating point: a sine's cosine part is 0
                let snap = |v: f64| if v.abs() <= 1e-15 * h.amplitude.abs() { 0.0 } else { v };
                row.push((n.round() as usize, snap(h.amplitude * h.phase.cos()), snap(-h.amplitude * h.phase.sin())));
            }
            rows.push(row);
        }
        let highest = rows.iter().flatten().map(|h| h.0).max().unwrap_or(0).max(1);
        let order = harmonics.unwrap_or(highest);
        if !(1..=MAX_ORDER).contains(&order) || order < highest {
            return fail(format!(
                "a Fourier gait of order {order}: give an order from {highest} (the gait's highest harmonic) to {MAX_ORDER}"
            ));
        }
        let coefficients = rows
            .iter()
            .map(|row| {
                let mut c = vec![0.0; 2 * order + 1];
                for &(n, a, b) in row {
                    if n == 0 {
                        c[0] += a;
                    } else {
                        c[2 * n - 1] += a;
                        c[2 * n] += b;
                    }
                }
                c
            })
            .collect();
        Self::new(coefficients, order, period.unwrap_or(gait.period))
    }

    /// The circle of radius `radius` \[rad\] about `centre` in the plane of
    /// two shape coordinates, order 1, counter-clockwise from the angle
    /// `phase` \[rad\]: `r_1 = c_1 + rho cos(omega t + phase)`, `r_2 = c_2 +
    /// rho sin(omega t + phase)`.
    ///
    /// # Errors
    /// As [`FourierGait::new`].
    pub fn circle(centre: [f64; 2], radius: f64, phase: f64, period: f64) -> Result<Self, GeometryError> {
        let (s, c) = phase.sin_cos();
        Self::new(vec![vec![centre[0], radius * c, -radius * s], vec![centre[1], radius * s, radius * c]], 1, period)
    }

    /// Number of shape coordinates.
    pub fn n_shape(&self) -> usize {
        self.coefficients.len()
    }

    /// Coefficients per coordinate, `2 order + 1`.
    pub fn per_coordinate(&self) -> usize {
        2 * self.order + 1
    }

    /// All the coefficients, coordinate after coordinate (n_shape x (2
    /// order + 1)).
    pub fn flat(&self) -> Vec<f64> {
        self.coefficients.concat()
    }

    /// The gait with the flat coefficients `c` (as [`FourierGait::flat`]).
    pub(crate) fn with_flat(&self, c: &[f64]) -> Self {
        let n = self.per_coordinate();
        Self { order: self.order, period: self.period, coefficients: c.chunks(n).map(<[f64]>::to_vec).collect() }
    }

    /// The angular frequency `omega = 2 pi / T` \[rad/s\].
    pub fn omega(&self) -> f64 {
        2.0 * PI / self.period
    }

    /// The gait as waveforms: each coordinate a constant `a_0` plus its
    /// harmonics `a_k cos + b_k sin = R_k cos(k omega t + phi_k)`, `R_k =
    /// hypot(a_k, b_k)`, `phi_k = atan2(-b_k, a_k)` (a harmonic of zero
    /// amplitude left out).
    ///
    /// # Errors
    /// As [`Gait::new`].
    pub fn gait(&self) -> Result<Gait, GeometryError> {
        let omega = self.omega();
        let shape = self
            .coefficients
            .iter()
            .map(|row| {
                let mut h = vec![Harmonic { amplitude: row[0], omega: 0.0, phase: 0.0, phase_step: 0.0 }];
                for k in 1..=self.order {
                    let (a, b) = (row[2 * k - 1], row[2 * k]);
                    let amplitude = a.hypot(b);
                    if amplitude > 0.0 {
                        h.push(Harmonic { amplitude, omega: k as f64 * omega, phase: (-b).atan2(a), phase_step: 0.0 });
                    }
                }
                Waveform::Harmonics(h)
            })
            .collect();
        Gait::new(shape, self.period)
    }

    /// The name of coefficient `j` of the flat vector, with the shape
    /// coordinates' `names`: `alpha1.a0`, `alpha2.b1`.
    pub fn coefficient_label(&self, names: &[String], j: usize) -> String {
        let n = self.per_coordinate();
        let coordinate = names.get(j / n).cloned().unwrap_or_else(|| format!("r{}", j / n + 1));
        format!("{coordinate}.{}", coefficient_name(j % n))
    }
}

/// `a0`, `a1`, `b1`, ... for a coordinate's coefficient `j`.
fn coefficient_name(j: usize) -> String {
    match j {
        0 => "a0".into(),
        _ if j % 2 == 1 => format!("a{}", j.div_ceil(2)),
        _ => format!("b{}", j / 2),
    }
}

/// The basis function of a coordinate's coefficient `j` and its time
/// derivative at `t`: `1`, `cos(k omega t)`, `sin(k omega t)`.
pub(crate) fn basis(j: usize, omega: f64, t: f64) -> (f64, f64) {
    if j == 0 {
        return (1.0, 0.0);
    }
    let k = j.div_ceil(2) as f64;
    let (s, c) = (k * omega * t).sin_cos();
    if j % 2 == 1 { (c, -k * omega * s) } else { (s, k * omega * c) }
}

/// The shape `r` and its rate `r'` at `t` of a gait of `ns` coordinates
/// with the flat coefficients `c` (any scalar: dual numbers carry a
/// coefficient's direction).
pub(crate) fn shape_at<S: Scalar>(c: &[S], ns: usize, omega: f64, t: f64) -> (Vec<S>, Vec<S>) {
    let n = c.len() / ns;
    let zero = S::from_f64(0.0);
    let (mut r, mut rd) = (vec![zero; ns], vec![zero; ns]);
    for i in 0..ns {
        for j in 0..n {
            let (b, db) = basis(j, omega, t);
            r[i] = r[i] + c[i * n + j] * S::from_f64(b);
            rd[i] = rd[i] + c[i * n + j] * S::from_f64(db);
        }
    }
    (r, rd)
}
