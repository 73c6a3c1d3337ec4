//! `ezy run --report`: one self-contained `report.html` per run (and
//! the plainer page of an analysis command's `--report`,
//! [`analysis_page`]).
//!
//! The page holds the scene's description, the run summary, the energy
//! ledger (`T(t_end) - T(0)` against the work of every effect and drive,
//! the balance of docs/physics.md §8), an animation of the run (a GIF
//! inlined as a `data:` URI, drawn from the trajectory's rows by
//! [`crate::render::animation::gif_of_table`]), every figure as inline SVG, and
//! what reproduces the run: the command line (naming the scene file a run
//! was given, [`RunOptions::scene_file`]) and the scene file after the
//! overrides. Nothing is loaded from elsewhere: no scripts, style sheets,
//! fonts or images by address, so the file can be mailed and opened
//! offline.

use base64::Engine as _;
use ezy_core::{Dynamics, Model};

use ezy_scene::Scene;

use crate::output::csv::Table;

/// Rows of the report's animation at most.
pub(crate) const REPORT_FRAMES: usize = 240;
/// Frame rate of the report's animation \[1/s\]: a GIF gives each frame a
/// whole number of hundredths of a second, so the rate is one that plays
/// exactly (10 hundredths a frame; 12 fps would play at 12.5).
pub(crate) const REPORT_FPS: f64 = 10.0;
/// Resolution of the report's animation \[dpi\] (480 x 320 pixels).
pub(crate) const REPORT_DPI: f64 = 48.0;

/// `text` with `&`, `<`, `>` and `"` escaped for HTML, and every control
/// character but a line break and a tab (which HTML does not allow, and
/// a terminal would act on when the page is printed) written visibly as
/// `\u{1b}`.
pub(crate) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\n' | '\t' => out.push(c),
            c if c.is_control() => out.push_str(&format!("\\u{{{:x}}}", u32::from(c))),
            c => out.push(c),
        }
    }
    out
}

/// One line of the energy ledger: a name, a value \[J\] and what it is.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LedgerLine {
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
pub(crate) fn ledger<M: Model>(sys: &Dynamics<M>, y0: &[f64], y1: &[f64], names: &[String]) -> Vec<LedgerLine> {
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

/// `word` as one word of a POSIX shell's command line: as it is when it
/// holds only characters no shell treats specially, else in single
/// quotes (a `'` inside written `'\''`).
pub(crate) fn shell_quote(word: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}

/// Everything the page shows.
pub(crate) struct Page<'a> {
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
    /// The scene file the run was given, as given (`None`: a known scene).
    pub scene_file: Option<&'a str>,
}

/// The HTML page.
pub(crate) fn html(p: &Page<'_>) -> String {
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
    h.push_str(
        "<h2>Energy ledger</h2>\n<div class=\"wide\">\n<table>\n<tr><th>quantity</th><th>value [J]</th><th></th></tr>\n",
    );
    for l in p.ledger {
        let _ = writeln!(
            h,
            "<tr><td class=\"name\">{}</td><td class=\"num\">{:.9e}</td><td>{}</td></tr>",
            escape(&l.name),
            l.value,
            escape(&l.what)
        );
    }
    let _ = write!(
        h,
        "</table>\n</div>\n<p>Largest |T - T(0) - W| over the run: {:.3e} J.</p>\n<h2>Animation</h2>\n",
        p.max_gap
    );
    match &p.animation {
        Ok(gif) => {
            let _ = writeln!(
                h,
                "<img alt=\"the bodies of scene {name} moving\" src=\"data:image/gif;base64,{}\">\n<p>{} frames per second. The label gives the simulated time <code>t</code> and how many times faster than real time the animation plays.</p>",
                base64::engine::general_purpose::STANDARD.encode(gif),
                REPORT_FPS
            );
        }
        Err(why) => {
            let _ = writeln!(h, "<p>No animation: {}</p>", escape(why));
        }
    }
    h.push_str("<h2>Figures</h2>\n");
    figures_html(&mut h, &p.figures);
    let _ = write!(h, "<h2>To reproduce</h2>\n<pre>{}</pre>\n", escape(&p.command));
    // a relative path reruns from the directory the run was started in
    let relative = p.scene_file.filter(|f| std::path::Path::new(f).is_relative());
    if let (Some(file), Ok(dir)) = (relative, std::env::current_dir()) {
        let _ = writeln!(
            h,
            "<p>The scene file <code>{}</code> is relative to the directory the run was started in, <code>{}</code>.</p>",
            escape(file),
            escape(&dir.display().to_string())
        );
    }
    let _ = write!(
        h,
        "<p>The scene after the <code>--set</code> overrides:</p>\n<pre>{}</pre>\n</body>\n</html>\n",
        escape(&p.scene.to_toml())
    );
    h
}

/// Each figure inline (its SVG in a `<figure>`, its file name the
/// caption), or why it was not drawn.
fn figures_html(h: &mut String, figures: &[(String, Result<String, String>)]) {
    use std::fmt::Write as _;
    for (file, svg) in figures {
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
}

/// The self-contained page of an analysis command's `--report` (`ezy
/// gait-optimize`, `ezy plan`): `title`, the `summary` the command
/// prints, every figure inline as SVG (file name and SVG text, or why it
/// is missing), the names of the `files` it wrote, and the `command`
/// line that reruns it (already quoted for a shell), with the directory
/// it was started in (a relative path in it is relative to that). All
/// the text is escaped here; nothing is loaded from elsewhere.
pub(crate) fn analysis_page(
    title: &str,
    summary: &str,
    figures: &[(String, Result<String, String>)],
    files: &[String],
    command: &str,
) -> String {
    use std::fmt::Write as _;
    let title = escape(title);
    let mut h = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{title}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n"
    );
    let _ = write!(h, "<h2>Summary</h2>\n<pre>{}</pre>\n", escape(summary));
    if !figures.is_empty() {
        h.push_str("<h2>Figures</h2>\n");
        figures_html(&mut h, figures);
    }
    h.push_str("<h2>Files</h2>\n<ul>\n");
    for f in files {
        let _ = writeln!(h, "<li><code>{}</code></li>", escape(f));
    }
    h.push_str("</ul>\n");
    let _ = write!(h, "<h2>To reproduce</h2>\n<pre>{}</pre>\n", escape(command));
    if let Ok(dir) = std::env::current_dir() {
        let _ = writeln!(
            h,
            "<p>Started in <code>{}</code>: a relative path above is relative to it.</p>",
            escape(&dir.display().to_string())
        );
    }
    h.push_str("</body>\n</html>\n");
    h
}

/// The page's style sheet (inline).
const STYLE: &str =
    "body { font-family: 'DejaVu Sans', sans-serif; max-width: 1000px; margin: 2em auto; padding: 0 1em; color: #222; }
pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
div.wide { overflow-x: auto; }
table { border-collapse: collapse; }
td, th { border-bottom: 1px solid #ddd; padding: 0.3em 0.8em; text-align: left; }
td.name, td.num { white-space: nowrap; }
td.num { text-align: right; font-family: monospace; }
figure { margin: 1.5em 0; }
figure svg, img { max-width: 100%; height: auto; }
figcaption { color: #666; font-size: 0.9em; }
";

/// The figures of `scene` as SVG for the page, by stem (when the run drew
/// none itself: `--no-figures`).
pub(crate) fn figures(
    info: &ezy_core::ModelInfo,
    scene: &Scene,
    table: &Table,
) -> Vec<(String, Result<String, String>)> {
    use rayon::prelude::*;
    scene
        .figures
        .par_iter()
        .map(|fig| {
            let svg = crate::render::figures::svg(info, fig, table).map_err(|e| e.to_string());
            (ezy_scene::figure_stem(&fig.file).to_string(), svg)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_quoted_for_a_shell_only_when_they_need_it() {
        assert_eq!(shell_quote("drive"), "drive");
        assert_eq!(shell_quote("scenes/my-drive.toml"), "scenes/my-drive.toml");
        assert_eq!(shell_quote("M0=0.5"), "M0=0.5");
        assert_eq!(shell_quote("my scene.toml"), "'my scene.toml'");
        assert_eq!(shell_quote("it's.toml"), "'it'\\''s.toml'");
        assert_eq!(shell_quote("$HOME/a;b`c`.toml"), "'$HOME/a;b`c`.toml'");
        assert_eq!(shell_quote(""), "''");
    }

    /// A control character (an escape sequence a terminal would act on,
    /// a NUL HTML does not allow) is written visibly; line breaks and tabs
    /// are kept.
    #[test]
    fn control_characters_are_written_visibly() {
        assert_eq!(escape("a\u{1b}[31m<b>\r\n\tc\u{7f}\u{0}"), "a\\u{1b}[31m&lt;b&gt;\\u{d}\n\tc\\u{7f}\\u{0}");
        assert_eq!(escape("plain & \"quoted\""), "plain &amp; &quot;quoted&quot;");
    }

    /// The analysis page escapes everything it is given, holds each
    /// figure's SVG without its XML declaration, and says why a figure is
    /// missing.
    #[test]
    fn the_analysis_page_escapes_what_it_is_given() {
        let figures = vec![
            ("a.png".to_string(), Ok("<?xml version=\"1.0\"?>\n<svg width=\"1\"></svg>".to_string())),
            ("b<i>.png".to_string(), Err("no \"values\" & <none>".to_string())),
        ];
        let files = ["x&y.csv".to_string()];
        let page = analysis_page("ezy plan: <s>", "a < b & c", &figures, &files, "ezy plan 'o<b>&\"'");
        assert!(page.starts_with("<!DOCTYPE html>") && page.ends_with("</html>\n"), "{page}");
        assert!(page.contains("<title>ezy plan: &lt;s&gt;</title>"), "{page}");
        assert!(page.contains("<pre>a &lt; b &amp; c</pre>"), "{page}");
        assert!(page.contains("<figure>\n<svg width=\"1\"></svg>\n<figcaption>a.png</figcaption>"), "{page}");
        assert!(!page.contains("<?xml"), "{page}");
        assert!(page.contains("b&lt;i&gt;.png: not drawn: no &quot;values&quot; &amp; &lt;none&gt;"), "{page}");
        assert!(page.contains("<code>x&amp;y.csv</code>"), "{page}");
        assert!(page.contains("<pre>ezy plan 'o&lt;b&gt;&amp;&quot;'</pre>"), "{page}");
        assert!(!page.contains("<b>") && !page.contains("<s>") && !page.contains("<i>"), "{page}");
    }

    /// A GIF's frame lasts a whole number of hundredths of a second: the
    /// report's rate is one a GIF plays exactly.
    #[test]
    fn the_report_s_frame_rate_is_one_a_gif_plays() {
        let delay = 100.0 / REPORT_FPS;
        assert_eq!(delay, delay.round(), "{REPORT_FPS} fps");
    }
}
