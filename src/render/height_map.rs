//! The height function of a system's constraint curvature over a grid of
//! its two shape coordinates as a heat map: what `ezy geometry` draws per
//! component of the net motion and `ezy gait-optimize` under its gaits
//! (the component its objective measures). The colours are symmetric
//! about 0 and end at the 80th percentile of the magnitudes: near the
//! singular set the height grows like the inverse square of the distance,
//! and the cells beyond saturate.

use ezy_core::Model;
use ezy_core::geometry::Geometry;
use ezy_scene::FigureFormat;

use super::plot::heat_map::{HeatMap, heatmap_svg};
use super::plot::raster::encode;

/// The quantile of the magnitudes the colours of a height function's map
/// end at.
pub(crate) const HEIGHT_QUANTILE: f64 = 0.8;

/// The `q`-quantile of the finite values in `v` (`q` in [0, 1]), `None`
/// when none is finite.
pub(crate) fn quantile(v: &[f64], q: f64) -> Option<f64> {
    let mut f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        return None;
    }
    f.sort_by(f64::total_cmp);
    Some(f[((f.len() - 1) as f64 * q).round() as usize])
}

/// The colours' range of a height function's map of `values`: `(-b,
/// b)`, `b` the [`HEIGHT_QUANTILE`] of their magnitudes (1 when none is
/// finite).
pub(crate) fn height_range(values: &[f64]) -> (f64, f64) {
    let magnitudes: Vec<f64> = values.iter().map(|v| v.abs()).collect();
    let bound = quantile(&magnitudes, HEIGHT_QUANTILE).unwrap_or(1.0);
    (-bound, bound)
}

/// The grid and the labels of a map over two shape coordinates.
pub(crate) struct ShapePlane<'a> {
    /// The two shape coordinates' names (the axes' labels, in radians).
    pub names: [&'a str; 2],
    /// The grid along the first, ascending \[rad\].
    pub xs: &'a [f64],
    /// The grid along the second, ascending \[rad\].
    pub ys: &'a [f64],
}

/// The heat map of a height function's `values` (`values[i * ys.len() +
/// j]` at `(xs[i], ys[j])`, NaN where none) over `plane`, titled `title`,
/// its colour bar `value_label`, `lines` drawn over it, its colours'
/// range [`height_range`].
pub(crate) fn height_map(
    title: String,
    value_label: String,
    plane: &ShapePlane<'_>,
    values: Vec<f64>,
    lines: Vec<Vec<(f64, f64)>>,
) -> HeatMap {
    let range = height_range(&values);
    HeatMap {
        title,
        x_label: format!("{} [rad]", plane.names[0]),
        y_label: format!("{} [rad]", plane.names[1]),
        value_label,
        xs: plane.xs.to_vec(),
        ys: plane.ys.to_vec(),
        values,
        lines,
        value_range: Some(range),
    }
}

/// `map` as a figure's bytes in `format` at `dpi`, or why it cannot be
/// drawn.
///
/// # Errors
/// As [`heatmap_svg`] and [`encode`], as text.
pub(crate) fn heat(map: &HeatMap, (format, dpi): (FigureFormat, f64)) -> Result<Vec<u8>, String> {
    heatmap_svg(map).and_then(|svg| encode(&svg, format, dpi, &map.title)).map_err(|e| e.to_string())
}

/// `n >= 2` points from `lo` to `hi`, both included.
pub(crate) fn axis(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let last = n.max(2) - 1;
    (0..=last).map(|i| if i == last { hi } else { lo + (hi - lo) * i as f64 / last as f64 }).collect()
}

/// The height function of `geo` (two shape coordinates) weighted by
/// `weights` (`w_x D(-A)_x + w_y D(-A)_y + w_theta D(-A)_theta`) over
/// the grid `xs` x `ys`: `values[i * ys.len() + j]` at `(xs[i], ys[j])`,
/// NaN where the connection is singular (or the geometry was stopped:
/// the caller asks for the signal after).
pub(crate) fn height_grid<M: Model>(geo: &Geometry<M>, xs: &[f64], ys: &[f64], weights: [f64; 3]) -> Vec<f64> {
    xs.iter()
        .flat_map(|x| ys.iter().map(move |y| [*x, *y]))
        .map(|r| match geo.curvature(&r) {
            Ok(k) => k.height.first().map_or(f64::NAN, |h| (0..3).map(|c| weights[c] * h[c]).sum()),
            Err(_) => f64::NAN,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use ezy_models::KinematicSnake;

    /// The grid's value at a point off its diagonal (its two axes of
    /// different lengths: a transposed layout would miss) is the
    /// geometry's own height function there, weighted, to 1e-12; and the
    /// height function itself is that of the connection by central
    /// differences (an oracle apart from the dual numbers), to 1e-6.
    #[test]
    fn the_grid_holds_the_height_function_of_the_connection() {
        let geo = Geometry::new(KinematicSnake::default(), None, None).unwrap();
        let (xs, ys) = (axis(0.2, 1.4, 7), axis(-1.5, -0.3, 5));
        let w = [0.6, -0.8, 0.0];
        let grid = height_grid(&geo, &xs, &ys, w);
        assert_eq!(grid.len(), 35);
        let (i, j) = (4, 1);
        let r = [xs[i], ys[j]];
        let h = geo.curvature(&r).unwrap().height[0];
        let expected = w[0] * h[0] + w[1] * h[1];
        assert!((grid[i * ys.len() + j] - expected).abs() <= 1e-12, "{} against {expected}", grid[i * ys.len() + j]);
        // D(-A) = -(dA_2/dr_1 - dA_1/dr_2) + [A_1, A_2], from A alone
        let a = |r: [f64; 2]| geo.connection(&r).unwrap().a;
        let e = 1e-5;
        let (a0, ap1, am1) = (a(r), a([r[0] + e, r[1]]), a([r[0] - e, r[1]]));
        let (ap2, am2) = (a([r[0], r[1] + e]), a([r[0], r[1] - e]));
        // a: rows x, y, theta; columns the two shape coordinates
        let d = |c: usize| (ap1[c * 2 + 1] - am1[c * 2 + 1]) / (2.0 * e) - (ap2[c * 2] - am2[c * 2]) / (2.0 * e);
        let (a1, a2) = ([a0[0], a0[2], a0[4]], [a0[1], a0[3], a0[5]]);
        let bracket = [a2[2] * a1[1] - a1[2] * a2[1], a1[2] * a2[0] - a2[2] * a1[0], 0.0];
        for c in 0..3 {
            let fd = -d(c) + bracket[c];
            assert!((fd - h[c]).abs() <= 1e-6 * (1.0 + h[c].abs()), "component {c}: {fd} against {}", h[c]);
        }
    }

    /// The colours end at the 80th percentile of the magnitudes,
    /// symmetric; NaN cells are left out.
    #[test]
    fn the_colours_end_at_the_80th_percentile() {
        let v: Vec<f64> = (1..=11).map(|k| -f64::from(k)).chain([f64::NAN]).collect();
        assert_eq!(height_range(&v), (-9.0, 9.0));
        assert_eq!(height_range(&[f64::NAN]), (-1.0, 1.0));
        assert_eq!(axis(-1.0, 1.0, 5), [-1.0, -0.5, 0.0, 0.5, 1.0]);
    }
}
