//! The figures `ezy geometry` draws: the connection's vector fields over
//! the shape plane, the height functions with the gait's curve over them,
//! and the gait's predicted against simulated path.

use std::path::Path;

use ezy_core::AnyModel;
use ezy_core::geometry::Geometry;
use ezy_scene::FigureFormat;

use super::Found;
use crate::output::transaction::{Transaction, TransactionError, check_interrupt};
use crate::render::height_map::{ShapePlane, heat, height_map, quantile};
use crate::render::plot::figure;
use crate::render::plot::heat_map::HeatMap;
use crate::render::plot::series::{Chart, Series, Stroke};

/// The figures' stems (retired before the new ones are drawn).
const STEMS: &[&str] = &[
    "connection_x",
    "connection_y",
    "connection_theta",
    "curvature_x",
    "curvature_y",
    "curvature_theta",
    "connection",
    "momentum",
    "gait",
];

/// Arrows drawn along each axis of a vector field.
const ARROWS: usize = 15;

/// Draws the figures into `tx`; a figure that cannot be drawn is a note.
///
/// # Errors
/// The transaction's, or a signal.
pub(super) fn draw(
    tx: &mut Transaction,
    geo: &Geometry<AnyModel>,
    f: &Found,
    (format, dpi): (FigureFormat, f64),
    dir: &Path,
    notes: &mut Vec<String>,
) -> Result<(), TransactionError> {
    tx.retire(&STEMS.iter().map(|s| format.file_name(s)).collect::<Vec<_>>());
    let names = geo.shape_names();
    let look = (format, dpi);
    let mut put = |stem: &str, bytes: Result<Vec<u8>, String>| -> Result<(), TransactionError> {
        check_interrupt(dir, None, Some(format!("drawing {stem}")))?;
        match bytes {
            Ok(b) => tx.write(&format.file_name(stem), &b),
            Err(e) => {
                notes.push(format!("{} not drawn: {e}", format.file_name(stem)));
                Ok(())
            }
        }
    };
    let gait_curve: Vec<(f64, f64)> = f
        .gait
        .iter()
        .flat_map(|(g, _, _)| {
            (0..=200).map(|i| {
                let (r, _) = g.at(g.period * f64::from(i) / 200.0);
                (r[0], r.get(1).copied().unwrap_or(0.0))
            })
        })
        .collect();
    match f.axes.len() {
        2 => plane(f, &names, &gait_curve, look, &mut put)?,
        1 => line(f, geo, &names, look, &mut put)?,
        _ => {}
    }
    if let Some((_, p, sim)) = &f.gait {
        let mut chart = Chart::new(
            "The gait's path: reconstructed from the connection against simulated",
            "x [m] (initial body frame)",
            "y [m]",
        );
        chart.equal_axes = true;
        chart.series.push(Series::new("reconstructed", p.path.iter().map(|q| (q[1], q[2])).collect()));
        if let Ok(s) = sim {
            chart.series.push(Series::new("simulated", s.path.iter().map(|q| (q[1], q[2])).collect()));
        }
        let end = |label: &str, v: [f64; 3]| Series {
            label: format!("{label}, end of the cycle"),
            points: vec![(v[0], v[1])],
            stroke: Stroke::Points,
            ..Series::default()
        };
        chart.series.push(end("first order", p.first));
        if let Some(s) = p.second {
            chart.series.push(end("second order", s));
        }
        put("gait", figure(&chart, format, dpi).map_err(|e| e.to_string()))?;
    }
    Ok(())
}

/// A figure's sink: its stem and its bytes, or why it was not drawn.
type Put<'a> = dyn FnMut(&str, Result<Vec<u8>, String>) -> Result<(), TransactionError> + 'a;

/// Over two shape coordinates: the connection's fields and the height
/// functions, the gait's curve over them.
fn plane(
    f: &Found,
    names: &[String],
    gait_curve: &[(f64, f64)],
    look: (FigureFormat, f64),
    put: &mut Put<'_>,
) -> Result<(), TransactionError> {
    let (xs, ys) = (&f.axes[0], &f.axes[1]);
    let n = ys.len();
    let comps = [("x", "u", "m/rad"), ("y", "v", "m/rad"), ("theta", "w", "rad/rad")];
    for (c, (label, row, unit)) in comps.iter().enumerate() {
        // the field -A_c: the shape direction that moves the body along c
        let field: Vec<Option<(f64, f64)>> = f
            .curvature
            .iter()
            .map(|k| k.as_ref().ok().map(|k| (-k.connection.a[c * 2], -k.connection.a[c * 2 + 1])))
            .collect();
        let size: Vec<f64> = field.iter().map(|v| v.map_or(f64::NAN, |(a, b)| a.hypot(b))).collect();
        let step = (xs.len() / ARROWS).max(1);
        let spacing = (xs[xs.len() - 1] - xs[0]) / xs.len() as f64 * step as f64;
        let scale = quantile(&size, 0.9).filter(|s| *s > 0.0).unwrap_or(1.0);
        let mut arrows = Vec::new();
        for i in (step / 2..xs.len()).step_by(step) {
            for j in (step / 2..n).step_by(step) {
                let Some((a, b)) = field[i * n + j] else { continue };
                let len = a.hypot(b);
                if len == 0.0 || !len.is_finite() {
                    continue;
                }
                // at most the 90th percentile's length: 0.8 of a spacing
                let k = 0.8 * spacing * (len / scale).min(1.0) / len;
                let (x0, y0) = (xs[i] - 0.5 * k * a, ys[j] - 0.5 * k * b);
                let (x1, y1) = (xs[i] + 0.5 * k * a, ys[j] + 0.5 * k * b);
                let (hx, hy) = (-0.3 * k * a, -0.3 * k * b);
                arrows.push(vec![(x0, y0), (x1, y1)]);
                arrows.push(vec![
                    (x1 + hx - 0.5 * hy, y1 + hy + 0.5 * hx),
                    (x1, y1),
                    (x1 + hx + 0.5 * hy, y1 + hy - 0.5 * hx),
                ]);
            }
        }
        let top = quantile(&size, 0.9).unwrap_or(1.0);
        let map = HeatMap {
            title: format!("Local connection: -A_{row} (arrows) over |A_{row}|"),
            x_label: format!("{} [rad]", names[0]),
            y_label: format!("{} [rad]", names[1]),
            value_label: format!("|A_{row}| [{unit}]"),
            xs: xs.to_vec(),
            ys: ys.to_vec(),
            values: size,
            lines: arrows,
            value_range: Some((0.0, top)),
        };
        put(&format!("connection_{label}"), heat(&map, look))?;
        let values: Vec<f64> = f.curvature.iter().map(|k| k.as_ref().map_or(f64::NAN, |k| k.height[0][c])).collect();
        // near the singular set the height grows like the inverse
        // square of the distance: the colours saturate (`height_range`)
        let unit2 = if c == 2 { "rad/rad^2" } else { "m/rad^2" };
        let plane = ShapePlane { names: [&names[0], &names[1]], xs, ys };
        let map = height_map(
            format!("Height function D(-A)_{label}{}", if gait_curve.is_empty() { "" } else { " and the gait" }),
            format!("D(-A)_{label} [{unit2}]"),
            &plane,
            values,
            if gait_curve.is_empty() { Vec::new() } else { vec![gait_curve.to_vec()] },
        );
        put(&format!("curvature_{label}"), heat(&map, look))?;
    }
    Ok(())
}

/// Over one shape coordinate: the connection's rows and the momentum
/// equation's coefficients.
fn line(
    f: &Found,
    geo: &Geometry<AnyModel>,
    names: &[String],
    (format, dpi): (FigureFormat, f64),
    put: &mut Put<'_>,
) -> Result<(), TransactionError> {
    let xs = &f.axes[0];
    let mut chart = Chart::new("Local connection A(r)", format!("{} [rad]", names[0]), "A [m/rad, 1]");
    for (c, row) in ["u", "v", "w"].iter().enumerate() {
        let pts = xs
            .iter()
            .zip(&f.curvature)
            .map(|(x, k)| (*x, k.as_ref().map_or(f64::NAN, |k| k.connection.a[c])))
            .collect();
        chart.series.push(Series::new(format!("A_{row}"), pts));
    }
    put("connection", figure(&chart, format, dpi).map_err(|e| e.to_string()))?;
    if let Some(terms) = f.momentum.iter().find(|t| !t.is_empty()) {
        let mut chart = Chart::new(
            "Momentum equation without forces: coefficients of p' = sum c z_a z_b",
            format!("{} [rad]", names[0]),
            "coefficient",
        );
        for (t, term) in terms.iter().enumerate() {
            for (j, p) in geo.momentum_names().iter().enumerate() {
                let pts = xs
                    .iter()
                    .zip(&f.momentum)
                    .map(|(x, ts)| (*x, ts.get(t).map_or(f64::NAN, |v| v.value[j])))
                    .collect();
                chart.series.push(Series::new(format!("{p}': {}", term.label), pts));
            }
        }
        put("momentum", figure(&chart, format, dpi).map_err(|e| e.to_string()))?;
    }
    Ok(())
}
