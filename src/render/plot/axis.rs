//! Axes: linear, or logarithmic with true decades (plotters' own log
//! scale drops ticks below `f64::EPSILON`), the ranges' padding and
//! equal scales, and the last check of a range before plotters sees it.

use std::ops::Range;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::{Cartesian2d, ChartContext, DrawingArea, SVGBackend};

use super::MAX_AXIS_LENGTH;
use super::series::Chart;

/// [`undrawable`] for an axis' final range, which padding may have widened
/// beyond [`MAX_MAGNITUDE`] but whose length must stay finite.
pub(super) fn undrawable_axis(range: &Range<f64>) -> Option<(f64, &'static str)> {
    let len = range.end - range.start;
    if !(range.start.is_finite() && range.end.is_finite() && len.is_finite() && len <= MAX_AXIS_LENGTH) {
        return Some((len, "is the length of the padded axis, too long to plot"));
    }
    None
}

/// `"x"`, or `"log10 x"` for a logarithmic x axis.
pub(super) fn x_axis_name(chart: &Chart) -> &'static str {
    if chart.log_x { "log10 x" } else { "x" }
}

/// `"y"`, or `"log10 y"` for a logarithmic y axis (whose plot coordinate
/// is the value's `log10`).
pub(super) fn y_axis_name(chart: &Chart) -> &'static str {
    if chart.log_y { "log10 y" } else { "y" }
}

/// Widen `r` by `fraction` of its length on each side; a zero-length range is
/// widened by 10 % of its magnitude (or by 1 around zero) so it has an extent.
pub(super) fn pad(r: Range<f64>, fraction: f64) -> Range<f64> {
    let len = r.end - r.start;
    let margin = if len > 0.0 {
        len * fraction
    } else {
        let m = r.start.abs() * 0.1;
        if m > 0.0 { m } else { 1.0 }
    };
    (r.start - margin)..(r.end + margin)
}

/// Widen `x` or `y` about its centre so that both have the same data units per
/// pixel on a plotting area of `w` x `h` pixels.
pub(super) fn equalize(x: Range<f64>, y: Range<f64>, (w, h): (u32, u32)) -> (Range<f64>, Range<f64>) {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let per_px = ((x.end - x.start) / w).max((y.end - y.start) / h);
    let centred = |r: &Range<f64>, px: f64| {
        let c = 0.5 * (r.start + r.end);
        (c - 0.5 * per_px * px)..(c + 0.5 * per_px * px)
    };
    (centred(&x, w), centred(&y, h))
}

/// An axis in plot coordinates, linear or logarithmic (plot coordinate
/// `log10` of the value, ticks on whole decades, and on 2 and 5 times them
/// when the axis spans few decades, labelled `10⁻⁶`, `2·10⁻⁶`).
///
/// plotters' own `log_scale()` is not used because it drops every tick below
/// `f64::EPSILON` (its zero test is absolute), which hides the 1e-16 region
/// that solver residuals live in.
pub(crate) struct Axis {
    /// Linear map of the plot coordinate onto pixels.
    linear: RangedCoordf64,
    /// For a log axis: positions (`log10` of the value) of the labelled
    /// ticks and of the light grid lines.
    log: Option<(Vec<f64>, Vec<f64>)>,
}

impl Axis {
    /// A linear axis over `range`.
    pub(crate) fn linear(range: Range<f64>) -> Self {
        Self { linear: range.into(), log: None }
    }

    /// A log axis over `log10` values `range`, widened outward to whole
    /// decades so that at least two decades are labelled; at most ~12
    /// labels, the decades in between (or the 2..9 multiples when there
    /// are few decades) get light grid lines.
    pub(super) fn log(range: Range<f64>) -> Self {
        let (lo, hi) = (range.start.floor() as i64, range.end.ceil() as i64);
        let hi = hi.max(lo + 1);
        let range = lo as f64..hi as f64;
        let decades = (hi - lo + 1) as usize;
        let step = decades.div_ceil(12).max(1) as i64;
        let labelled = |k: &i64| k.rem_euclid(step) == 0;
        let mut bold: Vec<f64> = (lo..=hi).filter(labelled).map(|k| k as f64).collect();
        let light = if decades <= 8 {
            (lo..hi).flat_map(|k| (2..10).map(move |m| k as f64 + f64::from(m).log10())).collect()
        } else {
            (lo..=hi).filter(|k| !labelled(k)).map(|k| k as f64).collect()
        };
        if decades <= 3 {
            // Few decades: also label 2 and 5 times each decade.
            bold.extend((lo..hi).flat_map(|k| [2.0f64, 5.0].map(|m| k as f64 + m.log10())));
            bold.sort_by(f64::total_cmp);
        }
        Self { linear: range.into(), log: Some((bold, light)) }
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.linear.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        match &self.log {
            Some((bold, light)) => {
                if hint.weight().allow_light_points() {
                    light.clone()
                } else {
                    bold.clone()
                }
            }
            None => self.linear.key_points(hint),
        }
    }

    fn range(&self) -> Range<f64> {
        self.linear.range()
    }
}

impl ValueFormatter<f64> for Axis {
    fn format_ext(&self, value: &f64) -> String {
        match self.log {
            Some(_) => decade_label(*value),
            None => {
                let r = self.linear.range();
                // a tick at zero computed as -1e-17 reads 0, not -0
                if value.abs() <= 1e-9 * (r.end - r.start).abs() {
                    return "0".into();
                }
                // as many decimals as the tick spacing needs
                let ticks = self.linear.key_points(12usize);
                let step = ticks.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
                let decimals =
                    if step.is_finite() && step > 0.0 { (-step.log10().floor()).clamp(0.0, 15.0) } else { 3.0 };
                format!("{:.*}", decimals as usize, value).replace('-', "\u{2212}")
            }
        }
    }
}

/// The label of a log-axis tick at plot coordinate `v` (`log10` of the
/// value): `0.01` to `1000` written out, else `10⁻⁶` or `2·10⁻⁶`.
pub(super) fn decade_label(v: f64) -> String {
    let k = (v + 1e-9).floor();
    let m = 10f64.powf(v - k).round();
    if (-2.0..=3.0).contains(&k) {
        let value = m * 10f64.powf(k);
        return format!("{}", (value * 100.0).round() / 100.0);
    }
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut exp = String::new();
    if k < 0.0 {
        exp.push('⁻');
    }
    for d in format!("{}", k.abs() as i64).bytes() {
        exp.push(SUP[usize::from(d - b'0')]);
    }
    if m == 1.0 { format!("10{exp}") } else { format!("{m}·10{exp}") }
}

/// A drawing area of the SVG backend.
pub(super) type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;
/// A chart context on both [`Axis`].
pub(super) type Ctx<'a> = ChartContext<'a, SVGBackend<'a>, Cartesian2d<Axis, Axis>>;
