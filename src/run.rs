//! Running a scene: resolve the model and the overrides of
//! [`RunOptions`], find consistent initial conditions, integrate, and
//! write `trajectory.csv` and the figures as one transaction (or keep
//! every row in memory). `ezy run`, [`crate::App::run_scene`], every run
//! of `ezy sweep --save-runs` and the Python package's `ezy.run` come
//! here.

use std::path::PathBuf;
use std::time::Instant;

use ezy_core::{Dynamics, Model, RunError, RunSettings, Summary};
use ezy_scene::Scene;

use crate::output::csv::{CsvObserver, Table};
use crate::output::transaction::Transaction;
use crate::session::{
    DEFAULT_MAX_OUTPUT_MB, Error, Report, RunOptions, StopHook, command_line, output_budget, problem, settings,
    setup_may_be_long, summary,
};
use ezy_scene::RowBuilder;

/// Runs `scene` with `opts` on `proto`, a model at its defaults (what [`crate::App::run_scene`]
/// calls for the model the scene names): resolves the overrides, finds
/// consistent initial values, integrates, writes `trajectory.csv` and the
/// figures into `opts.out`.
///
/// # Errors
/// [`Error`] naming the bad setting, parameter, or file.
pub(crate) fn run_model<M: Model>(proto: &M, scene: &Scene, opts: &RunOptions) -> Result<Report, Error> {
    run_model_tapped(proto, scene, opts, None)
}

/// [`run_model`] that shows every output row, as it is written, to `tap`
/// (what `ezy sweep --save-runs` reduces its metrics from).
///
/// # Errors
/// As [`run_model`].
pub(crate) fn run_model_tapped<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    tap: Option<crate::output::csv::Tap<'_>>,
) -> Result<Report, Error> {
    let wall = Instant::now();
    let settings = settings(scene, opts)?;
    // a line on stderr every few seconds while a phase without its own
    // progress takes long: the setup of a large family (a short setup gets
    // no thread, see `setup_may_be_long`), the figures, the report
    let mut beat = (opts.progress && setup_may_be_long(proto, scene, &opts.sets))
        .then(|| crate::output::progress::Heartbeat::start(format!("setting up scene {}", scene.name)));
    let (format, dpi) = opts.look(scene);
    if opts.figures {
        // a library caller's PDF in a build without the `pdf` feature,
        // before any work (the command line checks this first, naming the
        // scene file's line)
        crate::render::plot::check_format(format).map_err(|e| Error::Input(format!("scene `{}`: {e}", scene.name)))?;
    }
    let Prepared { scene, mut sys, y0, initial, rows, n_rows } = prepare(proto, scene, opts, &settings)?;
    let scene = &scene;

    // The output is a transaction: trajectory.csv and the figures are
    // written into a private directory and committed together (the CSV
    // last) only when all of them succeeded.
    let mut tx = Transaction::begin(&opts.out)?;
    let progress = if opts.progress { crate::output::progress::Progress::new(settings.t_end) } else { None };
    let mut obs = CsvObserver::create(&mut tx, "trajectory.csv", rows, progress, n_rows)?;
    if let Some(tap) = tap {
        obs = obs.with_tap(tap);
    }
    let setup = wall.elapsed();
    if let Some(b) = &beat {
        b.quiet();
    }
    // the threads that will draw the figures, none without figures
    let encoders = if opts.figures && !scene.figures.is_empty() {
        crate::render::figures::encoding_threads(scene.figures.len())
    } else {
        0
    };
    if encoders > 0 {
        // the fonts and an image buffer for each thread that will encode
        // figures, made on another core while this one integrates
        // (detached: it takes milliseconds)
        let _ = std::thread::Builder::new()
            .name("ezy-warm-up".into())
            .spawn(move || crate::render::plot::raster::warm_up(format, dpi, encoders));
    }
    let summary = match ezy_core::simulate(&mut sys, &y0, &settings, &mut obs) {
        Ok(s) => s,
        Err(e) => {
            obs.abandon();
            return Err(match e {
                RunError::Sim(e) => sys.explain(e, &settings).into(),
                RunError::Output(e) => e.into(),
            });
        }
    };
    // the rows now; the CSV's flush and sync go on while the figures are
    // drawn, and are waited for before the run's time is taken
    let (table, csv) = obs.finish_later()?;
    let state_names = sys.state_names();
    // the events' times and states, whenever the scene watches any (a
    // skate with friction records its switches)
    if !sys.events.is_empty() || !sys.friction.is_empty() {
        tx.write("events.csv", crate::output::csv::events_csv(&summary.events, &state_names).as_bytes())?;
    }
    let mut drawn_svgs = Vec::new();
    if opts.figures {
        if opts.progress && !scene.figures.is_empty() {
            crate::output::progress::Heartbeat::report(&mut beat, format!("drawing {} figures", scene.figures.len()));
        }
        // drawn in parallel, largest first, each written as it is done; a
        // signal stops the drawing at the next figure
        let dir = tx.dir().to_path_buf();
        let check = |fig: &ezy_scene::FigureSpec| -> Result<(), Error> {
            Ok(crate::output::transaction::check_interrupt(
                &dir,
                Some(settings.t_end),
                Some(format!("drawing {}", fig.file)),
            )?)
        };
        let mut svgs = vec![None; scene.figures.len()];
        crate::render::figures::render_all(&sys.info, &scene.figures, &table, format, dpi, check, |i, svg, bytes| {
            tx.write(&format.file_name(&scene.figures[i].file), &bytes)?;
            // the report shows the same drawing
            if opts.report {
                svgs[i] = Some(svg.to_string());
            }
            Ok(())
        })?;
        for (fig, svg) in scene.figures.iter().zip(svgs) {
            if let Some(svg) = svg {
                drawn_svgs.push((ezy_scene::figure_stem(&fig.file).to_string(), Ok(svg)));
            }
        }
    }
    csv.wait()?;
    let warnings = run_warnings(&initial, &summary);
    let notes = initial.notes();
    let mut report = Report {
        summary,
        table,
        settings,
        state_names,
        files: Vec::new(),
        setup,
        wall: wall.elapsed(),
        warnings,
        notes,
    };
    if opts.report {
        if opts.progress {
            crate::output::progress::Heartbeat::report(&mut beat, "writing report.html");
        }
        tx.check(Some(settings.t_end), Some("writing report.html".into()))?;
        let figures =
            if opts.figures { drawn_svgs } else { crate::render::report::figures(&sys.info, scene, &report.table) };
        let html = report_html(scene, opts, &sys, &y0, &report, figures);
        tx.write("report.html", html.as_bytes())?;
    }
    report.files = tx.commit()?;
    if opts.figures {
        // written as they were finished: listed in the scene's order
        let names: Vec<String> = scene.figures.iter().map(|f| format.file_name(&f.file)).collect();
        in_figure_order(&mut report.files, &names);
    }
    drop(beat);
    report.wall = wall.elapsed();
    Ok(report)
}

/// Puts the paths among `files` whose file names are in `names` into the
/// order of `names`, in the places they hold; the other paths stay where
/// they are.
fn in_figure_order(files: &mut [PathBuf], names: &[String]) {
    let rank = |p: &PathBuf| p.file_name().and_then(|n| names.iter().position(|f| n == f.as_str()));
    let places: Vec<usize> = (0..files.len()).filter(|&k| rank(&files[k]).is_some()).collect();
    let mut figures: Vec<PathBuf> = places.iter().map(|&k| files[k].clone()).collect();
    figures.sort_by_key(|p| rank(p));
    for (k, p) in places.into_iter().zip(figures) {
        files[k] = p;
    }
}

/// [`run_model`] without files: every output row in [`Report::table`],
/// with the columns `trajectory.csv` would have, and nothing written
/// ([`RunOptions::out`], `figures` and `report` are not read). The notes
/// a file run prints on stderr are in [`Report::notes`]. The table's size
/// is refused before the run as `trajectory.csv`'s would be
/// ([`output_budget`], [`RunOptions::max_output_mb`]). What a library or
/// a notebook embeds (the Python package's `ezy.run`).
///
/// # Errors
/// As [`run_model`] (no file errors); [`Error::Stopped`] when `stop`
/// asked.
pub(crate) fn run_model_in_memory<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    stop: Option<StopHook<'_>>,
) -> Result<Report, Error> {
    let wall = Instant::now();
    let settings = settings(scene, opts)?;
    let Prepared { mut sys, y0, initial, rows: builder, n_rows, .. } = prepare(proto, scene, opts, &settings)?;
    let n = builder.columns.len();
    let table = Table { columns: builder.columns.clone(), data: Vec::with_capacity(n_rows * n) };
    let mut obs = MemoryObserver { builder, row: Vec::with_capacity(n), table, stop, notes: Vec::new() };
    let setup = wall.elapsed();
    let summary = ezy_core::simulate(&mut sys, &y0, &settings, &mut obs).map_err(|e| match e {
        RunError::Sim(e) => sys.explain(e, &settings).into(),
        RunError::Output(e) => e,
    })?;
    let mut notes = initial.notes();
    notes.append(&mut obs.notes);
    Ok(Report {
        warnings: run_warnings(&initial, &summary),
        summary,
        table: obs.table,
        settings,
        state_names: sys.state_names(),
        files: Vec::new(),
        setup,
        wall: wall.elapsed(),
        notes,
    })
}

/// What a run sets up before its first step, whether it writes files or
/// not: the configured scene, the system and its consistent initial
/// state, the row layout (its size refused by [`output_budget`]) and the
/// number of rows to expect.
struct Prepared<M: Model> {
    scene: Scene,
    sys: Dynamics<M>,
    y0: Vec<f64>,
    initial: ezy_core::formulation::initial::InitialReport,
    rows: RowBuilder<M>,
    n_rows: usize,
}

fn prepare<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    settings: &RunSettings,
) -> Result<Prepared<M>, Error> {
    let (problem, scene) = problem(proto, scene, opts, *settings)?;
    let (sys, y0, initial) = problem.into_system()?;
    let rows = RowBuilder::new(&scene, &sys);
    output_budget(settings, rows.columns.len(), opts.max_output_mb.unwrap_or(DEFAULT_MAX_OUTPUT_MB))?;
    let n_rows = (settings.n_steps() / settings.output_stride() + 2) as usize;
    Ok(Prepared { scene, sys, y0, initial, rows, n_rows })
}

/// The warnings of a run: the initial values' corrections, and an
/// ill-conditioned KKT system.
fn run_warnings(initial: &ezy_core::formulation::initial::InitialReport, summary: &Summary) -> Vec<String> {
    let mut warnings = initial.warnings();
    if let Some((t, c)) = summary.ill_conditioned {
        warnings.push(format!(
            "from t = {} s the KKT system is ill-conditioned (estimate {c:.1e} > {:.0e}): constraints are nearly dependent, expect about {:.0e} relative accuracy in the constraint forces",
            ezy_core::fmt_value(t),
            ezy_core::formulation::dae::CONDITION_WARNING,
            c * f64::EPSILON
        ));
    }
    warnings
}

/// The sink of [`run_model_in_memory`]: every row into a table.
struct MemoryObserver<'a, M: Model> {
    builder: RowBuilder<M>,
    row: Vec<f64>,
    table: Table,
    stop: Option<StopHook<'a>>,
    notes: Vec<String>,
}

impl<M: Model> ezy_core::Observer<M> for MemoryObserver<'_, M> {
    type Error = Error;

    fn observe(&mut self, sys: &Dynamics<M>, s: &ezy_core::Sample<'_>) -> Result<(), Error> {
        self.builder.fill(sys, s, &mut self.row)?;
        self.table.data.extend_from_slice(&self.row);
        Ok(())
    }

    fn poll(&mut self, t: f64) -> Result<(), Error> {
        match self.stop.as_mut().and_then(|hook| hook(t)) {
            Some(reason) => Err(Error::Stopped { t, reason }),
            None => Ok(()),
        }
    }

    fn note(&mut self, text: &str) {
        self.notes.push(text.to_string());
    }
}

/// The page of `ezy run --report` (see [`crate::render::report`]).
/// `figures`: each figure's stem and SVG (or why it is missing).
fn report_html<M: Model>(
    scene: &Scene,
    opts: &RunOptions,
    sys: &Dynamics<M>,
    y0: &[f64],
    r: &Report,
    figures: Vec<(String, Result<String, String>)>,
) -> String {
    use crate::render::report::{REPORT_DPI, REPORT_FPS, REPORT_FRAMES};
    let ledger = crate::render::report::ledger(sys, y0, &r.summary.final_state, &r.state_names);
    let animation = crate::render::animation::gif_of_table(sys, scene, &r.table, REPORT_FRAMES, REPORT_FPS, REPORT_DPI)
        .map_err(|e| e.to_string());
    let text = summary(&scene.name, r);
    let page = crate::render::report::Page {
        scene,
        model: sys.info.name,
        t_end: r.settings.t_end,
        summary: &text,
        ledger: &ledger,
        max_gap: r.summary.max_energy_error,
        animation,
        figures,
        command: command_line(&scene.name, opts),
        scene_file: opts.scene_file.as_deref(),
    };
    crate::render::report::html(&page)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_listed_in_the_scenes_order_around_the_other_files() {
        let mut files: Vec<PathBuf> =
            ["out/trajectory.csv", "out/c.png", "out/a.png", "out/events.csv", "out/b.png", "out/report.html"]
                .iter()
                .map(PathBuf::from)
                .collect();
        let names: Vec<String> = ["a.png", "b.png", "c.png"].iter().map(|s| s.to_string()).collect();
        in_figure_order(&mut files, &names);
        let got: Vec<&str> = files.iter().map(|p| p.to_str().unwrap()).collect();
        assert_eq!(
            got,
            ["out/trajectory.csv", "out/a.png", "out/b.png", "out/events.csv", "out/c.png", "out/report.html"]
        );
    }
}
