//! `ezy run --report`: one self-contained `report.html` per run.
//!
//! The page holds the scene's description, the run summary, the energy
//! ledger (`T(t_end) - T(0)` against the work of every effect and drive,
//! the balance of docs/physics.md §8), an animation of the run (a GIF
//! inlined as a `data:` URI, drawn from the trajectory's rows by
//! [`crate::animate::gif_of_table`]), every figure as inline SVG, and
//! what reproduces the run: the command line and the scene file after the
//! overrides. Nothing is loaded from elsewhere: no scripts, style sheets,
//! fonts or images by address, so the file can be mailed and opened
//! offline.

use base64::Engine as _;
use ezy_core::{Dynamics, Model};

use ezy_scene::Scene;

use crate::commands::run::RunOptions;
use crate::output::Table;

/// Rows of the report's animation at most.
pub const REPORT_FRAMES: usize = 240;
/// Frame rate of the report's animation \[1/s\].
pub const REPORT_FPS: f64 = 12.0;
/// Resolution of the report's animation \[dpi\] (480 x 320 pixels).
pub const REPORT_DPI: f64 = 48.0;

/// `text` with `&`, `<`, `>` and `"` escaped for HTML.
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// One line of the energy ledger: a name, a value \[J\] and what it is.
#[derive(Debug, Clone, PartialEq)]
pub struct LedgerLine {
    /// The quantity (`T(0)`, `W_motor`, ...).
    pub name: String,
    /// Its value \[J\].
    pub value: f64,
    /// What it is.
    pub what: String,
}

/// The energy ledger of a run from its initial and final states `y =
/// \[q, qd, W...\]` (`names` of the state components): the kinetic energy
/// `T = 1/2 qd^T M qd` at both ends (the mass matrix of a planar
/// multibody system in absolute coordinates is diagonal), the work of
/// every effect and drive, their sum, and the gap `T(t_end) - T(0) - sum W`.
pub fn ledger<M: Model>(sys: &Dynamics<M>, y0: &[f64], y1: &[f64], names: &[String]) -> Vec<LedgerLine> {
    let nq = sys.info.nq();
    let t = |y: &[f64]| 0.5 * (0..nq).map(|k| sys.mass[k] * y[nq + k] * y[nq + k]).sum::<f64>();
    let (t0, t1) = (t(y0), t(y1));
    let mut out = vec![
        LedgerLine { name: "T(0)".into(), value: t0, what: "kinetic energy at the start".into() },
        LedgerLine { name: "T(t_end)".into(), value: t1, what: "kinetic energy at the end".into() },
        LedgerLine { name: "T(t_end) - T(0)".into(), value: t1 - t0, what: "change of kinetic energy".into() },
    ];
    let mut sum = 0.0;
    for k in 2 * nq..y1.len().min(names.len()) {
        sum += y1[k];
        out.push(LedgerLine { name: names[k].clone(), value: y1[k], what: "work done on the system".into() });
    }
    out.push(LedgerLine { name: "sum W".into(), value: sum, what: "work of all effects and drives".into() });
    out.push(LedgerLine {
        name: "T(t_end) - T(0) - sum W".into(),
        value: t1 - t0 - sum,
        what: "gap of the balance (integration error)".into(),
    });
    out
}

/// The command line that reruns `scene` with `opts`: the scene by name
/// (a scene from a file is named by the file's path instead; the page
/// shows the scene after the `--set` overrides), then every setting the
/// run was given.
pub fn command_line(scene: &str, opts: &RunOptions) -> String {
    let mut a = vec!["ezy".to_string(), "run".into(), scene.to_string()];
    for (name, v) in &opts.sets {
        a.push(format!("--set {name}={v:?}"));
    }
    let num = |a: &mut Vec<String>, flag: &str, v: Option<f64>| {
        if let Some(v) = v {
            a.push(format!("{flag} {v:?}"));
        }
    };
    num(&mut a, "--dt", opts.dt);
    num(&mut a, "--t-end", opts.t_end);
    num(&mut a, "--every", opts.every);
    num(&mut a, "--rtol", opts.rtol);
    num(&mut a, "--atol", opts.atol);
    if let Some(m) = opts.method {
        a.push(format!("--integrator {}", m.name()));
    }
    if let Some(p) = opts.projection {
        a.push(format!(
            "--projection {}",
            match p {
                ezy_core::ProjectionKind::None => "none",
                ezy_core::ProjectionKind::Euclidean => "euclidean",
                ezy_core::ProjectionKind::MassWeighted => "mass",
            }
        ));
    }
    if let Some(b) = opts.baumgarte {
        a.push(format!("--baumgarte {:?},{:?}", b.alpha, b.beta));
    }
    if let Some(n) = opts.max_steps {
        a.push(format!("--max-steps {n}"));
    }
    num(&mut a, "--max-output-mb", opts.max_output_mb);
    if let Some(f) = opts.figure_format {
        a.push(format!("--format {f}"));
    }
    num(&mut a, "--dpi", opts.dpi);
    if !opts.figures {
        a.push("--no-figures".into());
    }
    a.push("--report".into());
    a.join(" ")
}

/// Everything the page shows.
pub struct Page<'a> {
    /// The scene after the overrides.
    pub scene: &'a Scene,
    /// Name of the model type (`EzyRoller`).
    pub model: &'a str,
    /// Simulated duration \[s\] (after `--t-end`).
    pub t_end: f64,
    /// The run summary (as `ezy run` prints it).
    pub summary: &'a str,
    /// The energy ledger.
    pub ledger: &'a [LedgerLine],
    /// Largest `|T - T0 - W|` over the run \[J\].
    pub max_gap: f64,
    /// The animation (GIF bytes), or why there is none.
    pub animation: Result<Vec<u8>, String>,
    /// Figures: file name, title and SVG text (or why it is missing).
    pub figures: Vec<(String, Result<String, String>)>,
    /// The command line that reruns it.
    pub command: String,
}

/// The HTML page.
pub fn html(p: &Page<'_>) -> String {
    use std::fmt::Write as _;
    let mut h = String::new();
    let name = escape(&p.scene.name);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>ezy run: {name}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n<h1>Scene {name}</h1>\n<p>{}</p>\n<p>Model: {} ({} s simulated).</p>\n",
        escape(&p.scene.description),
        escape(p.model),
        p.t_end
    );
    let _ = write!(h, "<h2>Summary</h2>\n<pre>{}</pre>\n", escape(p.summary));
    h.push_str("<h2>Energy ledger</h2>\n<table>\n<tr><th>quantity</th><th>value [J]</th><th></th></tr>\n");
    for l in p.ledger {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{:.9e}</td><td>{}</td></tr>",
            escape(&l.name),
            l.value,
            escape(&l.what)
        );
    }
    let _ =
        write!(h, "</table>\n<p>Largest |T - T(0) - W| over the run: {:.3e} J.</p>\n<h2>Animation</h2>\n", p.max_gap);
    match &p.animation {
        Ok(gif) => {
            let _ = writeln!(
                h,
                "<img alt=\"the bodies of scene {name} moving\" src=\"data:image/gif;base64,{}\">",
                base64::engine::general_purpose::STANDARD.encode(gif)
            );
        }
        Err(why) => {
            let _ = writeln!(h, "<p>No animation: {}</p>", escape(why));
        }
    }
    h.push_str("<h2>Figures</h2>\n");
    for (file, svg) in &p.figures {
        match svg {
            Ok(svg) => {
                // the XML declaration, if any, is not allowed inside HTML
                let body = svg.find("<svg").map_or(svg.as_str(), |k| &svg[k..]);
                let _ = write!(h, "<figure>\n{body}\n<figcaption>{}</figcaption>\n</figure>\n", escape(file));
            }
            Err(why) => {
                let _ = writeln!(h, "<p>{}: not drawn: {}</p>", escape(file), escape(why));
            }
        }
    }
    let _ = write!(
        h,
        "<h2>To reproduce</h2>\n<pre>{}</pre>\n<p>(For a scene read from a file, give the file's path instead of the name.) The scene after the <code>--set</code> overrides:</p>\n<pre>{}</pre>\n</body>\n</html>\n",
        escape(&p.command),
        escape(&p.scene.to_toml())
    );
    h
}

/// The page's style sheet (inline).
const STYLE: &str =
    "body { font-family: 'DejaVu Sans', sans-serif; max-width: 1000px; margin: 2em auto; padding: 0 1em; color: #222; }
pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
table { border-collapse: collapse; }
td, th { border-bottom: 1px solid #ddd; padding: 0.3em 0.8em; text-align: left; }
td.num { text-align: right; font-family: monospace; }
figure { margin: 1.5em 0; }
figure svg, img { max-width: 100%; height: auto; }
figcaption { color: #666; font-size: 0.9em; }
";

/// The figures of `scene` as SVG for the page, by stem (when the run drew
/// none itself: `--no-figures`).
pub fn figures(info: &ezy_core::ModelInfo, scene: &Scene, table: &Table) -> Vec<(String, Result<String, String>)> {
    use rayon::prelude::*;
    scene
        .figures
        .par_iter()
        .map(|fig| {
            let svg = crate::figures::svg(info, fig, table).map_err(|e| e.to_string());
            (ezy_scene::figure_stem(&fig.file).to_string(), svg)
        })
        .collect()
}
