//! `ezy precision`: what accuracy costs in time. Runs a ladder of settings
//! (fixed-step methods over step sizes, adaptive methods over tolerances,
//! each with and without projection), measures the error at the final time
//! against a reference computed by ezy itself at the tightest setting, the
//! integration wall time (median of repetitions), the RHS evaluations and
//! the final residuals, and draws a work-precision diagram and a drift plot.

use std::path::{Path, PathBuf};

use ezy_core::settings::Method;
use ezy_core::{Choice, Dynamics, Model, Observer, ProjectionKind, RunSettings, Sample, SimError};

use ezy_scene::Scene;

use crate::output::transaction::{OutLock, Transaction};
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::session::Error;

/// One setting of the ladder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setting {
    /// Method.
    pub method: Method,
    /// Step size \[s\] (fixed-step methods).
    pub dt: Option<f64>,
    /// `rtol = atol` (adaptive methods).
    pub tol: Option<f64>,
    /// Projection after every step.
    pub projection: ProjectionKind,
}

/// One measured row.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The setting.
    pub setting: Setting,
    /// Max over `q` and `qd` of `|y(T) - y_ref(T)|` at the final time `T`
    /// (infinite if the run failed).
    pub error: f64,
    /// Median integration wall time \[s\].
    pub wall_s: f64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// `max(max|C|, max|G qd|)` at the final time.
    pub max_residual: f64,
}

/// The whole measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The reference setting.
    pub reference: Setting,
    /// Estimated error of the reference: `|y_ref - y(next looser setting)|`,
    /// an upper bound of the reference's own error.
    pub reference_error: f64,
    /// The ladder.
    pub rows: Vec<Row>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Tolerances of the adaptive ladder.
pub(crate) const TOLERANCES: [f64; 11] = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13];

/// The ladder of settings, every method with and without projection.
pub fn ladder() -> Vec<Setting> {
    let mut out = Vec::new();
    for projection in [ProjectionKind::MassWeighted, ProjectionKind::None] {
        for dt in [1e-2, 3e-3, 1e-3, 3e-4, 1e-4] {
            out.push(Setting { method: Method::Euler, dt: Some(dt), tol: None, projection });
        }
        for dt in [3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4] {
            out.push(Setting { method: Method::Rk4, dt: Some(dt), tol: None, projection });
        }
        for method in [Method::Dopri5, Method::Dop853, Method::Radau5] {
            for tol in TOLERANCES {
                out.push(Setting { method, dt: None, tol: Some(tol), projection });
            }
        }
    }
    out
}

/// Keeps only the last sample (and optionally the residual history).
#[derive(Default)]
pub(crate) struct Last {
    /// The final state `[q, qd]`.
    pub(crate) y: Vec<f64>,
    residual: f64,
    history: Option<Vec<(f64, f64, f64)>>,
}

impl<M: Model> Observer<M> for Last {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.y.clear();
        self.y.extend_from_slice(s.q);
        self.y.extend_from_slice(s.qd);
        self.residual = s.residual_position.max(s.residual_velocity);
        if let Some(h) = &mut self.history {
            h.push((s.t, s.residual_position, s.residual_velocity));
        }
        Ok(())
    }
}

/// Runs `scene` with `setting`; `every` is the output interval (the final
/// time is always sampled). Returns the final state, the summary and the
/// residual history if asked for.
pub(crate) fn run_once<M: Model>(
    proto: &M,
    scene: &Scene,
    setting: &Setting,
    every: f64,
    history: bool,
) -> Result<(Last, ezy_core::Summary), SimError> {
    run_once_as(proto, scene, setting, every, history, ezy_core::Formulation::Dae)
}

/// [`run_once`] in the given formulation.
pub(crate) fn run_once_as<M: Model>(
    proto: &M,
    scene: &Scene,
    setting: &Setting,
    every: f64,
    history: bool,
    formulation: ezy_core::Formulation,
) -> Result<(Last, ezy_core::Summary), SimError> {
    let (mut sys, y0, _) = scene.problem_with(proto.clone(), &[])?.0.into_system()?;
    let base = scene.run_settings();
    let settings = RunSettings {
        dt: setting.dt.unwrap_or(base.dt),
        every,
        projection: setting.projection,
        method: setting.method,
        formulation,
        rtol: setting.tol.unwrap_or(base.rtol),
        atol: setting.tol.unwrap_or(base.atol),
        // accuracy is what is measured here, not a reason to stop
        balance_limit: None,
        max_steps: None,
        ..base
    };
    let mut last = Last { history: history.then(Vec::new), ..Last::default() };
    let summary = ezy_core::simulate(&mut sys, &y0, &settings, &mut last).map_err(|e| match e {
        ezy_core::RunError::Sim(e) => sys.explain(e, &settings),
        ezy_core::RunError::Output(never) => match never {},
    })?;
    Ok((last, summary))
}

/// Median integration time over enough repetitions to be stable (5 for
/// runs under 50 ms, else 3).
fn timed<M: Model>(proto: &M, scene: &Scene, setting: &Setting) -> Result<(Last, ezy_core::Summary, f64), SimError> {
    let (last, summary) = run_once(proto, scene, setting, scene.t_end, false)?;
    let first = summary.integration_time.as_secs_f64();
    // the median of 5 short runs, of 3 under a second; a longer run once
    // (a stiff scene's explicit rungs take 10 s and more)
    let reps = if first < 0.05 {
        5
    } else if first < 1.0 {
        3
    } else {
        1
    };
    let mut times = vec![first];
    for _ in 1..reps {
        times.push(run_once(proto, scene, setting, scene.t_end, false)?.1.integration_time.as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok((last, summary, times[times.len() / 2]))
}

pub(crate) fn state_error(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// What `ezy precision` draws besides the ladder.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PrecisionOptions {
    /// Other tools' points over the work-precision diagram.
    pub overlay: Vec<Overlay>,
    /// Run no ladder: redraw the figures from the `precision.csv` already
    /// in the output directory (the drift figure's two short runs are
    /// still run).
    pub replot: bool,
}

/// Runs the ladder for `scene` on `proto`, a model at its defaults (what
/// [`crate::App::precision`] calls for the model the scene names), writes
/// `precision.csv` and the figures into `out`; with `opts.replot`, reads
/// the ladder from `out/precision.csv` instead and writes the figures only.
///
/// # Errors
/// [`Error`] if the reference run fails, a saved ladder does not read or
/// a file cannot be written.
pub(crate) fn precision_model<M: Model>(
    proto: &M,
    scene: &Scene,
    out: &Path,
    opts: &PrecisionOptions,
) -> Result<Report, Error> {
    // an unusable or busy output directory is found before minutes of runs
    let held = OutLock::take(out)?;
    let beat = crate::output::progress::Heartbeat::start(format!("precision of {}: the reference runs", scene.name));
    let reference =
        Setting { method: Method::Dop853, dt: None, tol: Some(1e-13), projection: ProjectionKind::MassWeighted };
    let (rows, reference_error) = if opts.replot {
        let rows = read_csv(&out.join("precision.csv")).map_err(|e| {
            Error::Input(format!(
                "--replot redraws the figures from the precision.csv of an earlier `ezy precision` in the output directory: {e}"
            ))
        })?;
        (rows, f64::NAN)
    } else {
        let (ref_run, _) = run_once(proto, scene, &reference, scene.t_end, false)?;
        let looser = Setting { tol: Some(1e-12), ..reference };
        let (loose_run, _) = run_once(proto, scene, &looser, scene.t_end, false)?;
        let reference_error = state_error(&ref_run.y, &loose_run.y);
        let mut rows = Vec::new();
        let settings = ladder();
        let n = settings.len();
        for (k, setting) in settings.into_iter().enumerate() {
            beat.set(format!("precision of {}: setting {} of {n}", scene.name, k + 1));
            let row = match timed(proto, scene, &setting) {
                Ok((last, summary, wall_s)) => Row {
                    setting,
                    error: state_error(&last.y, &ref_run.y),
                    wall_s,
                    rhs_evals: summary.counters.rhs_evals,
                    max_residual: last.residual,
                },
                Err(_) => Row { setting, error: f64::INFINITY, wall_s: f64::NAN, rhs_evals: 0, max_residual: f64::NAN },
            };
            rows.push(row);
        }
        (rows, reference_error)
    };
    // precision.csv and both figures are one transaction (see
    // `crate::output::transaction`): committed together, precision.csv last.
    beat.set(format!("precision of {}: drawing the figures", scene.name));
    let mut tx = Transaction::begin_locked(held)?;
    if !opts.replot {
        tx.write("precision.csv", csv(&rows).as_bytes())?;
    }
    tx.check(None, Some("drawing work_precision.png".into()))?;
    let chart = overlaid(work_precision_chart(&rows, scene), &opts.overlay);
    tx.write("work_precision.png", &figure_png("work_precision.png", &chart)?)?;
    tx.check(None, Some("drawing drift.png".into()))?;
    tx.write("drift.png", &figure_png("drift.png", &drift_chart(proto, scene)?)?)?;
    let files = tx.commit()?;
    Ok(Report { reference, reference_error, rows, files })
}

/// `dt` or `tol` as the CSV prints them (empty when not applicable).
fn opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x:e}")).unwrap_or_default()
}

/// The CSV: `method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual`.
pub(crate) fn csv(rows: &[Row]) -> String {
    let mut s = String::from("method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual\n");
    for r in rows {
        let st = &r.setting;
        s.push_str(&format!(
            "{},{},{},{},{},{:e},{:e},{},{:e}\n",
            st.method.name(),
            opt(st.dt),
            opt(st.tol),
            opt(st.tol),
            st.projection.name(),
            r.error,
            r.wall_s,
            r.rhs_evals,
            r.max_residual
        ));
    }
    s
}

/// A fixed-width table for the terminal.
pub(crate) fn table(report: &Report) -> String {
    let mut s = format!(
        "reference: {} rtol = atol = {:e}, projection {} (estimated error <= {:.1e})\n",
        report.reference.method.name(),
        report.reference.tol.unwrap_or(f64::NAN),
        report.reference.projection.name(),
        report.reference_error
    );
    s.push_str(&format!(
        "{:<7} {:>8} {:>8} {:<5} {:>10} {:>10} {:>10} {:>10}\n",
        "method", "dt [s]", "tol", "proj", "error", "wall [s]", "RHS", "residual"
    ));
    for r in &report.rows {
        let st = &r.setting;
        s.push_str(&format!(
            "{:<7} {:>8} {:>8} {:<5} {:>10.2e} {:>10.2e} {:>10} {:>10.1e}\n",
            st.method.name(),
            opt(st.dt),
            opt(st.tol),
            st.projection.name(),
            r.error,
            r.wall_s,
            r.rhs_evals,
            r.max_residual
        ));
    }
    let ratios = equal_error_speedups(&report.rows);
    if !ratios.is_empty() {
        s.push_str(
            "radau5 against dop853 at the same error (both projected; dop853's time interpolated on its ladder):\n",
        );
        s.push_str(&format!("{:>8} {:>10} {:>12} {:>12} {:>8}\n", "tol", "error", "radau5 [s]", "dop853 [s]", "ratio"));
        for r in ratios {
            s.push_str(&format!(
                "{:>8} {:>10.2e} {:>12.2e} {:>12.2e} {:>7.1}x\n",
                opt(Some(r.tol)),
                r.error,
                r.implicit_s,
                r.explicit_s,
                r.explicit_s / r.implicit_s
            ));
        }
    }
    s
}

/// Points drawn over the work-precision diagram: another tool's (or a
/// paper's) wall times and errors, from `ezy precision --overlay FILE`.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// Legend label (the tool).
    pub label: String,
    /// `(wall time [s], max state error)` pairs.
    pub points: Vec<(f64, f64)>,
}

/// Largest overlay file `ezy precision --overlay` reads \[bytes\]: 32 MiB,
/// about a million points (a diagram shows a few dozen).
pub(crate) const MAX_OVERLAY_BYTES: u64 = 32 << 20;

/// Largest `precision.csv` `ezy precision --replot` reads \[bytes\]:
/// 16 MiB (the ladder writes about 4 KiB).
pub(crate) const MAX_PRECISION_CSV_BYTES: u64 = 16 << 20;

/// Reads an overlay file: CSV with the header `label,wall_s,error` and one
/// point per row; rows with the same label form one series, in the order
/// of their first row.
///
/// # Errors
/// A file that is not a regular one (a FIFO, a device) or is larger than
/// [`MAX_OVERLAY_BYTES`] (nothing past the cap is read); the file, line
/// and field of a missing header, a short row or a value that is not a
/// finite number > 0.
pub(crate) fn read_overlay(path: &Path) -> Result<Vec<Overlay>, String> {
    let name = path.display();
    // a regular file of at most MAX_OVERLAY_BYTES, read whole: a device,
    // a FIFO or an endless file is refused at once
    let bytes = ezy_scene::files::read_capped(path, MAX_OVERLAY_BYTES, "the overlay file")
        .map_err(|e| format!("--overlay {name}: {e}"))?;
    let mut r = csv::ReaderBuilder::new().comment(Some(b'#')).trim(csv::Trim::All).from_reader(bytes.as_slice());
    let header = r.headers().map_err(|e| format!("{name}: {e}"))?.clone();
    if header.iter().collect::<Vec<_>>() != ["label", "wall_s", "error"] {
        return Err(format!(
            "{name}:1: the header must be `label,wall_s,error`, got `{}`",
            header.iter().collect::<Vec<_>>().join(",")
        ));
    }
    let mut out: Vec<Overlay> = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| format!("{name}: {e}"))?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |k: usize, field: &str| -> Result<f64, String> {
            let v = rec.get(k).unwrap_or("");
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
                _ => Err(format!("{name}:{line}: `{field}` = `{v}` is not a finite number > 0")),
            }
        };
        let (label, point) = (rec.get(0).unwrap_or("").to_string(), (num(1, "wall_s")?, num(2, "error")?));
        match out.iter_mut().find(|o| o.label == label) {
            Some(o) => o.points.push(point),
            None => out.push(Overlay { label, points: vec![point] }),
        }
    }
    Ok(out)
}

/// Reads the rows of a `precision.csv` that `ezy precision` wrote.
///
/// # Errors
/// A missing file, one that is not a regular file or is larger than
/// [`MAX_PRECISION_CSV_BYTES`]; the file and line of a row that does not
/// parse (an unknown method or projection, a value that is not a number).
pub(crate) fn read_csv(path: &Path) -> Result<Vec<Row>, String> {
    let name = path.display();
    let text = ezy_scene::files::read_capped_text(path, MAX_PRECISION_CSV_BYTES, "a precision.csv")
        .map_err(|e| format!("{name}: {e}"))?;
    let mut lines = text.lines();
    let header = "method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual";
    if lines.next() != Some(header) {
        return Err(format!("{name}:1: not a precision.csv (its header is `{header}`)"));
    }
    lines
        .enumerate()
        .map(|(k, line)| {
            let bad = |what: &str| format!("{name}:{}: {what} in `{line}`", k + 2);
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != 9 {
                return Err(bad("not 9 fields"));
            }
            let num =
                |s: &str| -> Result<f64, String> { s.parse().map_err(|_| bad(&format!("`{s}` is not a number"))) };
            let opt =
                |s: &str| -> Result<Option<f64>, String> { if s.is_empty() { Ok(None) } else { num(s).map(Some) } };
            let method = Method::parse(f[0]).map_err(|e| bad(&format!("unknown method {e}")))?;
            let projection = ProjectionKind::parse(f[4]).map_err(|e| bad(&format!("unknown projection {e}")))?;
            Ok(Row {
                setting: Setting { method, dt: opt(f[1])?, tol: opt(f[2])?, projection },
                error: num(f[5])?,
                wall_s: num(f[6])?,
                rhs_evals: f[7].parse().map_err(|_| bad("the RHS count is not a whole number"))?,
                max_residual: num(f[8])?,
            })
        })
        .collect()
}

/// `chart` with `overlay`'s points as diamonds, in the colours the
/// methods leave free.
fn overlaid(mut chart: Chart, overlay: &[Overlay]) -> Chart {
    chart.series.extend(overlay.iter().enumerate().map(|(k, o)| Series {
        stroke: Stroke::Points,
        color: Some(5 + k),
        ..Series::new(o.label.clone(), o.points.clone())
    }));
    chart
}

/// One line of [`equal_error_speedups`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Speedup {
    /// radau5's tolerance.
    pub tol: f64,
    /// radau5's error at that tolerance.
    pub error: f64,
    /// radau5's wall time \[s\].
    pub implicit_s: f64,
    /// DOP853's wall time for the same error \[s\]: interpolated linearly
    /// in `log(time)` against `log(error)` between the neighbouring rungs of
    /// its ladder that bracket the error.
    pub explicit_s: f64,
}

/// For each projected radau5 rung with a finite error that DOP853's
/// projected ladder brackets: the time DOP853 takes for the same error.
pub(crate) fn equal_error_speedups(rows: &[Row]) -> Vec<Speedup> {
    let usable =
        |r: &&Row| r.setting.projection == ProjectionKind::MassWeighted && r.error.is_finite() && r.error > 0.0;
    let dop: Vec<&Row> = rows.iter().filter(|r| r.setting.method == Method::Dop853).filter(usable).collect();
    let mut out = Vec::new();
    for r in rows.iter().filter(|r| r.setting.method == Method::Radau5).filter(usable) {
        // the rungs (loosest first) around radau5's error
        if let Some(w) = dop.windows(2).find(|w| w[0].error > r.error && w[1].error <= r.error) {
            let (a, b) = (w[0], w[1]);
            let x = (r.error.ln() - a.error.ln()) / (b.error.ln() - a.error.ln());
            let explicit_s = (a.wall_s.ln() + x * (b.wall_s.ln() - a.wall_s.ln())).exp();
            out.push(Speedup {
                tol: r.setting.tol.unwrap_or(f64::NAN),
                error: r.error,
                implicit_s: r.wall_s,
                explicit_s,
            });
        }
    }
    out
}

/// `chart` as PNG bytes at the default resolution; errors name the figure
/// file `name`.
fn figure_png(name: &str, chart: &Chart) -> Result<Vec<u8>, Error> {
    crate::render::plot::figure(chart, ezy_scene::FigureFormat::Png, ezy_scene::DEFAULT_DPI)
        .map_err(|source| crate::render::figures::FigureError::Plot { figure: name.into(), source }.into())
}

fn work_precision_chart(rows: &[Row], scene: &Scene) -> Chart {
    let mut series = Vec::new();
    for (c, &method) in Method::ALL.iter().enumerate() {
        for projection in [ProjectionKind::MassWeighted, ProjectionKind::None] {
            let points: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.setting.method == method && r.setting.projection == projection)
                .filter(|r| r.error.is_finite() && r.error > 0.0 && r.wall_s > 0.0)
                .map(|r| (r.wall_s, r.error))
                .collect();
            // a method's two variants share its colour; without projection dashed
            let (label, stroke) = match projection {
                ProjectionKind::None => (format!("{}, unprojected", method.name()), Stroke::Dash(0)),
                _ => (method.name().to_string(), Stroke::Solid),
            };
            series.push(Series { stroke, color: Some(c), ..Series::new(label, points) });
        }
    }
    Chart {
        series,
        log_x: true,
        log_y: true,
        log_floor: 1e-18,
        legend_outside: true,
        ..Chart::new(
            format!("Work-precision: scene {}, error at t = {} s", scene.name, scene.t_end),
            "integration wall time [s]",
            "max state error at the final time",
        )
    }
}

fn drift_chart<M: Model>(proto: &M, scene: &Scene) -> Result<Chart, Error> {
    // RK4 at 0.01 s; on a stiff scene, where that step is unstable, the
    // scene's own method (the ladder has RK4's numbers)
    let rk4 = Setting { method: Method::Rk4, dt: Some(1e-2), tol: None, projection: ProjectionKind::None };
    let every = |s: &Setting| (scene.t_end / 500.0).max(s.dt.unwrap_or(0.0));
    let (base, title) = match run_once(proto, scene, &rk4, every(&rk4), true) {
        Ok(_) => (rk4, "RK4 h = 0.01 s".to_string()),
        Err(_) => {
            let own = scene.run_settings();
            let s = Setting {
                method: own.method,
                dt: (!own.method.is_adaptive()).then_some(own.dt),
                tol: own.method.is_adaptive().then_some(own.rtol),
                projection: ProjectionKind::None,
            };
            let what = match s.tol {
                Some(tol) => format!("{} rtol = {tol:e} (RK4 at h = 0.01 s diverges)", s.method.name()),
                None => format!("{} h = {} s (RK4 at h = 0.01 s diverges)", s.method.name(), own.dt),
            };
            (s, what)
        }
    };
    let mut series = Vec::new();
    for projection in [ProjectionKind::None, ProjectionKind::MassWeighted] {
        let setting = Setting { projection, ..base };
        let (last, _) = run_once(proto, scene, &setting, every(&setting), true)?;
        let h = last.history.unwrap_or_default();
        let name = if projection == ProjectionKind::None { "no projection" } else { "projected" };
        series.push(Series::new(format!("max |Φ(q)| [m], {name}"), h.iter().map(|p| (p.0, p.1)).collect()));
        series.push(Series {
            panel: 1,
            ..Series::new(format!("max |G(q) q̇| [m/s], {name}"), h.iter().map(|p| (p.0, p.2)).collect())
        });
    }
    Ok(Chart {
        series,
        lower: Some("velocity residual [m/s]".into()),
        log_y: true,
        log_floor: crate::render::figures::LOG_FLOOR,
        ..Chart::new(format!("Constraint drift, {title}, scene {}", scene.name), "t [s]", "position residual [m]")
    })
}
