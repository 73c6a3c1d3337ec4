//! The figures and pages of `ezy gait-optimize` and `ezy plan`: the
//! optimal gait over the height function (`gait_curvature.png`, a PNG
//! with a heat map's colours), `--report`'s `report.html` (the summary
//! as printed, every figure inline as SVG, the files, and a command line
//! that reruns the command, quoted for a shell and escaped for HTML even
//! in an output directory named `<b>&"`), and `--no-figures` retiring
//! the figures and the page of an earlier run.

use std::path::Path;
use std::process::Command;

use crate::analysis::{ezy, fresh};
use crate::gait_optimize::CIRCLE;

/// `text` escaped for HTML (as the page must: `&` first).
fn escaped(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// `text` of an HTML page unescaped (`&amp;` last).
fn unescaped(text: &str) -> String {
    text.replace("&quot;", "\"").replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&")
}

/// `word` in single quotes for a POSIX shell.
fn quoted(word: &str) -> String {
    format!("'{}'", word.replace('\'', "'\\''"))
}

/// The command line of the page's "To reproduce" section, unescaped.
fn reproduce(page: &str) -> String {
    let head = "<h2>To reproduce</h2>\n<pre>";
    let at = page.find(head).expect("a To reproduce section") + head.len();
    let end = page[at..].find("</pre>").unwrap();
    unescaped(&page[at..at + end])
}

/// Runs `command` (its first word `ezy`) in a shell with ezy's binary.
fn rerun(command: &str) -> (String, bool) {
    let rest = command.strip_prefix("ezy ").expect("starts with ezy");
    let line = format!("{} {rest}", quoted(env!("CARGO_BIN_EXE_ezy")));
    let o = Command::new("sh").arg("-c").arg(&line).output().unwrap();
    (format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr)), o.status.success())
}

/// The pixels of a PNG file (decoded: a valid PNG) as RGB(A) rows.
fn pixels(path: &Path) -> (png::OutputInfo, Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info, buf)
}

/// The page's figures: how many `<figure>`s hold an inline `<svg`.
fn inline_figures(page: &str) -> usize {
    page.matches("<figure>\n<svg").count()
}

/// The snake's best circle centre (the case of `gait_optimize.rs`) with
/// `--report` into a directory named `<b>&"`: `gait_curvature.png` is a
/// PNG of many colours (a heat map, not a blank canvas), `report.html`
/// holds both figures inline, the printed summary's first line (the
/// objective's value as printed) and the command line quoted and
/// escaped, which reruns to the same optimum; a rerun with
/// `--no-figures` and no `--report` retires the figures and the page.
#[test]
fn gait_optimize_draws_the_gait_over_the_height_function_and_reports() {
    let out = fresh("gait-report").join("o<b>&\"");
    let args =
        ["gait-optimize", "--gait", CIRCLE, "--maximize", "dy", "--order", "second", "--centre-only", "--report"];
    let clock = std::time::Instant::now();
    let (said, err, ok) = ezy(&args, &out);
    eprintln!("{said}{err}({:.2} s)", clock.elapsed().as_secs_f64());
    assert!(ok, "{said}{err}");
    for f in ["gait_optimum.png", "gait_curvature.png", "report.html"] {
        assert!(said.contains(&format!("wrote {}", out.join(f).display())), "{f}: {said}");
    }
    // the heat map: a valid PNG of a heat map's many colours
    let (info, px) = pixels(&out.join("gait_curvature.png"));
    let step = info.color_type.samples();
    let colours: std::collections::HashSet<&[u8]> = px.chunks(step).collect();
    let white = px.chunks(step).filter(|p| p.iter().all(|v| *v == 255)).count();
    eprintln!("gait_curvature.png: {} x {}, {} colours, {white} white pixels", info.width, info.height, colours.len());
    assert!(info.width >= 400 && info.height >= 300, "{info:?}");
    assert!(colours.len() >= 50, "{} colours: blank?", colours.len());
    assert!(white < px.len() / step / 2, "{white} of {} pixels white", px.len() / step);
    // the page
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(page.starts_with("<!DOCTYPE html>") && page.contains("<title>ezy gait-optimize: kinematic-snake</title>"));
    let first = said.lines().next().unwrap();
    let value = first.split(" = ").nth(1).unwrap().split(' ').next().unwrap();
    assert!(value.parse::<f64>().is_ok(), "{first}");
    assert!(page.contains(&format!("<pre>{}\n", escaped(first))), "the summary's first line {first}");
    assert!(page.contains(&format!("dy (second order) = {value} at")), "{value}");
    assert_eq!(inline_figures(&page), 2, "two figures inline");
    for caption in ["gait_optimum.png", "gait_curvature.png"] {
        assert!(page.contains(&format!("<figcaption>{caption}</figcaption>")), "{caption}");
    }
    assert!(page.contains("Height function D(-A)_y (second order): start dashed"), "the heat map's title");
    for file in ["gait_optimum.csv", "gait_history.csv", "report.html"] {
        assert!(page.contains(&format!("<li><code>{file}</code></li>")), "{file}");
    }
    assert!(!page.contains("<script") && !page.contains("src=\"http"), "self-contained");
    // the hostile directory: quoted for the shell, then escaped
    let dir = out.display().to_string();
    assert!(page.contains(&escaped(&quoted(&dir))), "the output directory quoted and escaped");
    assert!(!page.contains("o<b>&\"") && !page.contains("<b>"), "a raw `<b>&\"` on the page");
    // the command line reruns the optimization to the same first line
    let command = reproduce(&page);
    eprintln!("to reproduce: {command}");
    assert!(command.contains(" --report") && command.contains(" --centre-only"), "{command}");
    let (again, ok) = rerun(&command);
    assert!(ok, "{command}: {again}");
    assert_eq!(again.lines().next(), Some(first), "{again}");
    // --no-figures and no --report: an earlier run's figures and page retired
    let (said, err, ok) =
        ezy(&args[..args.len() - 1].iter().copied().chain(["--no-figures"]).collect::<Vec<_>>(), &out);
    assert!(ok, "{said}{err}");
    for f in ["gait_optimum.png", "gait_curvature.png", "report.html"] {
        assert!(!out.join(f).exists(), "{f} left from the earlier run");
    }
    assert!(out.join("gait_optimum.csv").is_file());
}

/// The sleigh's rest-to-rest plan (the fast case of `plan.rs`) with
/// `--report`: the page holds both figures inline as SVG, the effort
/// line as printed, the files, and a command line that reruns the plan
/// to the same effort.
#[test]
fn plan_reports_its_figures_inline() {
    let scene = crate::plan::sleigh_scene("report");
    let out = scene.with_file_name("out");
    let s = scene.to_str().unwrap();
    let args = ["plan", s, "--input", "push.fx", "--to", "x=1", "--at-rest", "--segments", "4", "--report"];
    let (said, err, ok) = ezy(&args, &out);
    eprintln!("{said}{err}");
    assert!(ok, "{said}{err}");
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(page.contains("<title>ezy plan: sleigh-push</title>"), "the title");
    assert_eq!(inline_figures(&page), 2, "two figures inline");
    for caption in ["plan.png", "plan_path.png"] {
        assert!(page.contains(&format!("<figcaption>{caption}</figcaption>")), "{caption}");
        assert!(out.join(caption).is_file(), "{caption}");
    }
    for file in ["plan.csv", "plan_summary.csv", "plan.png", "plan_path.png", "report.html"] {
        assert!(page.contains(&format!("<li><code>{file}</code></li>")), "{file}");
    }
    let effort = said.lines().find(|l| l.starts_with("effort (sum")).expect("the effort line");
    assert!(page.contains(&escaped(effort)), "{effort}");
    let command = reproduce(&page);
    eprintln!("to reproduce: {command}");
    assert!(
        command.starts_with(&format!("ezy plan {s} --input push.fx --to x=1.0 --at-rest --segments 4")),
        "{command}"
    );
    let (again, ok) = rerun(&command);
    assert!(ok, "{command}: {again}");
    assert!(again.contains(effort), "{again}");
}
