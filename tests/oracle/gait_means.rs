//! A gait's means over its period (`periodic.csv`'s `mean_abs_speed`,
//! `drift_speed`, `dx_world`, `dy_world`) against the scene's own run
//! long after it has settled, integrated by the library at 1e-12 and
//! reduced here: Simpson's rule over dense samples, the turn's centre
//! solved for explicitly (the analysis uses a closed form that never
//! forms it), the world displacement carried back period by period.

use crate::analysis::{ezy, fresh, table};
use ezy::models::EzyRoller;

/// Simpson's rule over samples `f` at spacing `h` (an even count of
/// intervals).
fn simpson(f: &[f64], h: f64) -> f64 {
    let n = f.len() - 1;
    assert!(n.is_multiple_of(2) && n >= 2);
    let inner: f64 = (1..n).map(|i| if i % 2 == 1 { 4.0 } else { 2.0 } * f[i]).sum();
    h / 3.0 * (f[0] + inner + f[n])
}

/// The turning drive (`tests/data/oracle/drive-turning.toml`: the
/// EzyRoller's motor with a 0.3 N m bias and rolling resistance; its
/// gait turns by -0.63 rad per 2 s period, largest multiplier 0.94).
/// `ezy analyze` takes its orbit at t0 = 120 s. The oracle: the scene's
/// run to 598 s (299 periods: its transient is down to 0.94^239 of the
/// orbit's, below 1e-6), then one more run of two periods from that
/// state at 1e-12, sampled every 0.5 ms, reduced by Simpson's rule
/// (error below 1e-10 here):
/// - `mean_abs_speed`, the mean of `|(x1d, y1d)|` over a period, to 1e-7;
/// - `drift_speed`: the centre `c` of the period's turn solved from
///   `(I - R) (c - p0) = D`, the root mean square of `|p - c|` over the
///   period times `|dheading| / T`, to 1e-7, from two phases 0.7 s apart
///   (where `|D| / T`, the mean speed, differs by more than 1e-3: it
///   depends on the phase, the drift speed does not);
/// - `dx_world`, `dy_world`: the run's displacement over the period from
///   598 s, turned from the run's heading at 598 s to its heading at
///   t0 = 120 s, to 1e-6 m: the orbit's displacement in the frame of the
///   run's reference body at t0 (the run is still 2 % off the orbit
///   there; the heading it gains in settling never decays, so the
///   periods' turn alone, `239 dheading`, misses it by 0.2 rad).
#[test]
fn a_turning_gaits_means_are_its_long_runs() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let path = data.join("drive-turning.toml");
    let dir = fresh("gait-means");
    let (out, err, ok) = ezy(&["analyze", path.to_str().unwrap(), "--no-figures"], &dir);
    assert!(ok, "{out}{err}");
    let (head, rows) = table(&dir.join("periodic.csv"));
    let get = |name: &str| -> f64 { rows[0][head.iter().position(|h| h == name).unwrap()].parse().unwrap() };
    let (period, t0, dth) = (get("period"), get("t0"), get("dheading"));
    assert!((period - 2.0).abs() < 1e-12 && (t0 - 120.0).abs() < 1e-9 && dth < -0.5, "{out}");
    let scene = ezy_scene::Scene::read(&path).unwrap().0;
    let (p, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let settled = p.t_end(598.0).every(2.0).solve().unwrap();
    let names = &settled.names;
    let x = settled.final_state();
    // the state at 598 s starts a run at t = 0: the forcing's phase is the same
    let mut p = scene.problem::<EzyRoller>(&[]).unwrap().0;
    for (k, name) in names.iter().enumerate().take(12) {
        p = match name.strip_suffix('d') {
            Some(c) if names[..6].contains(&c.to_string()) => p.qd(c, x[k]).unwrap(),
            _ => p.q(name, x[k]).unwrap(),
        };
    }
    let h = 5e-4;
    let run = p.t_end(4.0).every(h).tolerances(1e-12, 1e-12).solve().unwrap();
    let col = |n: &str| run.column(n).unwrap();
    let (px, py, th, vx, vy) = (col("x1"), col("y1"), col("phi1"), col("x1d"), col("y1d"));
    let per = (period / h).round() as usize;
    // the means over the period starting at sample `a`
    let means = |a: usize| {
        let b = a + per;
        let speed: Vec<f64> = (a..=b).map(|i| vx[i].hypot(vy[i])).collect();
        let mean_abs = simpson(&speed, h) / period;
        let d = [px[b] - px[a], py[b] - py[a]];
        let turn = th[b] - th[a];
        // (I - R) e = D, e = c - p(a)
        let (s, c) = turn.sin_cos();
        let (m11, m12, m21, m22) = (1.0 - c, s, -s, 1.0 - c);
        let det = m11 * m22 - m12 * m21;
        let e = [(m22 * d[0] - m12 * d[1]) / det, (-m21 * d[0] + m11 * d[1]) / det];
        let centre = [px[a] + e[0], py[a] + e[1]];
        let r2: Vec<f64> = (a..=b).map(|i| (px[i] - centre[0]).powi(2) + (py[i] - centre[1]).powi(2)).collect();
        let drift = turn.abs() * (simpson(&r2, h) / period).sqrt() / period;
        (mean_abs, drift, d[0].hypot(d[1]) / period, d, turn)
    };
    let (mean_abs, drift, chord, d, turn) = means(0);
    let (_, drift_later, chord_later, _, _) = means((0.7 / h).round() as usize);
    eprintln!(
        "turning gait: mean |v| {mean_abs} (ezy {}), drift {drift} and {drift_later} (ezy {}), |D|/T {chord} and {chord_later}",
        get("mean_abs_speed"),
        get("drift_speed")
    );
    assert!((turn - dth).abs() < 1e-7, "{turn} against {dth}");
    assert!((mean_abs - get("mean_abs_speed")).abs() < 1e-7, "{mean_abs} against {}", get("mean_abs_speed"));
    assert!((chord - chord_later).abs() > 1e-3, "|D|/T {chord} and {chord_later}");
    for v in [drift, drift_later] {
        assert!((v - get("drift_speed")).abs() < 1e-7, "{v} against {}", get("drift_speed"));
    }
    // the settled run's displacement in its frame at 598 s, turned to
    // the run's heading at t0 (the heading's offset from the transient
    // never decays: it is the plane's rotation, a neutral direction)
    let heading = settled.column("phi1").unwrap();
    let at = |t: f64| settled.t.iter().position(|s| (s - t).abs() < 1e-9).unwrap();
    let (s, c) = (heading[at(t0)] - x[names.iter().position(|n| n == "phi1").unwrap()]).sin_cos();
    let back = [c * d[0] - s * d[1], s * d[0] + c * d[1]];
    assert!(
        (back[0] - get("dx_world")).abs() < 1e-6 && (back[1] - get("dy_world")).abs() < 1e-6,
        "{back:?} against ({}, {})",
        get("dx_world"),
        get("dy_world")
    );
}
