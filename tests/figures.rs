//! Figures, animations and reports: each format a valid file of its kind,
//! every built-in scene's figures in every format, one animation frame per
//! interval, and a report that loads nothing from elsewhere.

use std::path::{Path, PathBuf};
use std::process::Command;

use ezy::RunOptions;
use ezy::models::scenes;
use ezy::render::plot::{self, FigureFormat};

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("figures-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn ezy(args: &[&str]) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("runs");
    (o.status.success(), format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr)))
}

/// `(width, height)` of a PNG from its IHDR chunk, after checking the signature.
fn png_size(b: &[u8]) -> (u32, u32) {
    assert!(b.starts_with(&[0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A]), "not a PNG");
    assert_eq!(&b[12..16], b"IHDR");
    (u32::from_be_bytes(b[16..20].try_into().unwrap()), u32::from_be_bytes(b[20..24].try_into().unwrap()))
}

/// Every built-in scene (1 s) draws its figures as SVG that parses as XML,
/// and each SVG converts to a PNG of the asked size and to a PDF.
#[test]
fn every_builtin_scene_draws_in_every_format() {
    let mut count = 0;
    for src in scenes::builtin() {
        let info = scenes::model_info_with(&src.scene.model, &src.scene.params).unwrap().unwrap();
        let s = &src.scene.expand_families(&info).unwrap();
        let out = tmp(&s.name);
        let t_end = 1.0;
        let opts = RunOptions {
            out: out.clone(),
            t_end: Some(t_end),
            figures: true,
            figure_format: Some(FigureFormat::Svg),
            ..RunOptions::default()
        };
        ezy::App::new().run_scene(s, &opts).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        for fig in &s.figures {
            let file = out.join(FigureFormat::Svg.file_name(&fig.file));
            let svg = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            let doc = roxmltree::Document::parse(&svg).unwrap_or_else(|e| panic!("{}: not XML: {e}", file.display()));
            assert_eq!(doc.root_element().tag_name().name(), "svg");
            let texts: Vec<&str> = doc.descendants().filter_map(|n| n.text()).map(str::trim).collect();
            assert!(texts.iter().any(|t| !t.is_empty()), "{}: no text", file.display());
            assert!(!texts.iter().any(|t| *t == "-0" || *t == "\u{2212}0"), "{}: a tick reads -0", file.display());
            let png = plot::encode(&svg, FigureFormat::Png, 48.0, &fig.file).unwrap();
            assert_eq!(png_size(&png), (480, 320), "{}", file.display());
            let pdf = plot::encode(&svg, FigureFormat::Pdf, 96.0, &fig.file);
            if plot::PDF {
                let pdf = pdf.unwrap();
                assert!(pdf.starts_with(b"%PDF-") && pdf.windows(5).any(|w| w == b"%%EOF"), "{}", file.display());
            } else {
                assert!(matches!(pdf, Err(plot::PlotError::Unavailable { .. })), "{}", file.display());
            }
            count += 1;
        }
        let _ = std::fs::remove_dir_all(&out);
    }
    assert!(count >= 60, "{count} figures");
}

/// `--format` and `--dpi` on the command line: the files take the format's
/// extension; a PNG at 192 dpi has twice the pixels of one at 96.
#[test]
fn format_and_dpi_flags_name_and_size_the_files() {
    let out = tmp("flags");
    let dir = out.display().to_string();
    let (ok, said) = ezy(&["run", "free", "--t-end", "0.5", "--format", "pdf", "--out", &dir]);
    if plot::PDF {
        assert!(ok, "{said}");
        assert!(out.join("fig2_paths.pdf").is_file() && !out.join("fig2_paths.png").exists(), "{said}");
    } else {
        // refused by name before anything is written
        assert!(!ok && said.contains("`pdf` feature") && !out.exists(), "{said}");
    }
    let (ok, said) = ezy(&["run", "free", "--t-end", "0.5", "--dpi", "192", "--out", &dir]);
    assert!(ok, "{said}");
    assert_eq!(png_size(&std::fs::read(out.join("fig2_paths.png")).unwrap()), (1920, 1280));
    for (flag, value) in [("--format", "jpeg"), ("--dpi", "5000"), ("--dpi", "x")] {
        let (ok, said) = ezy(&["run", "free", "--t-end", "0.5", flag, value, "--out", &dir]);
        assert!(!ok && said.contains(value), "{flag} {value}: {said}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// The animation has one frame per `speed / fps` of simulated time (and
/// the start), each `1 / fps` long, at the size `--dpi` gives.
#[test]
fn an_animation_has_a_frame_per_interval() {
    let out = tmp("animate");
    let gif = out.join("four-bar.gif");
    let (ok, said) = ezy(&[
        "animate",
        "four-bar",
        "--t-end",
        "2",
        "--fps",
        "10",
        "--speed",
        "0.5",
        "--dpi",
        "32",
        "--out",
        gif.to_str().unwrap(),
    ]);
    assert!(ok, "{said}");
    let bytes = std::fs::read(&gif).unwrap();
    assert!(bytes.starts_with(b"GIF89a"));
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::Indexed);
    let mut d = opts.read_info(bytes.as_slice()).unwrap();
    assert_eq!((d.width(), d.height()), (320, 213));
    let mut frames = 0;
    while let Some(f) = d.read_next_frame().unwrap() {
        assert_eq!(f.delay, 10, "1/10 s per frame");
        frames += 1;
    }
    // 2 s at 10 frames per second of animation and half speed: 40 intervals
    assert_eq!(frames, 41, "{said}");
    assert!(said.contains("41 frames"), "{said}");
    // a fixed-step method samples every whole number of steps: 1/40 s
    // is 1.67 steps of 0.015 s, so frames are 2 steps (0.03 s) apart and
    // play at 33.3 fps (3/100 s each): 67 steps, 34 samples and the end
    let fixed = out.join("sleigh.gif");
    let (ok, said) = ezy(&[
        "animate",
        "sleigh",
        "--t-end",
        "1",
        "--dt",
        "0.015",
        "--fps",
        "40",
        "--dpi",
        "24",
        "--out",
        fixed.to_str().unwrap(),
    ]);
    assert!(ok, "{said}");
    let bytes = std::fs::read(&fixed).unwrap();
    let mut d = gif::DecodeOptions::new().read_info(bytes.as_slice()).unwrap();
    let mut delays = Vec::new();
    while let Some(f) = d.read_next_frame().unwrap() {
        delays.push(f.delay);
    }
    assert_eq!(delays.len(), 35, "{said}");
    assert!(delays.iter().all(|&d| d == 3), "{delays:?}");
    // refused before any work, nothing written
    for (args, want) in [
        (vec!["--out", "x.mp4"], "must end in .gif"),
        (vec!["--fps", "0"], "--fps 0"),
        (vec!["--speed", "-1"], "--speed -1"),
        (vec!["--speed", "0.001"], "raise --speed"),
        (vec!["--format", "svg"], "always a GIF"),
        (vec!["--every", "0.1"], "set --speed and --fps instead"),
    ] {
        let mut a = vec!["animate", "four-bar"];
        a.extend(&args);
        if !args.contains(&"--out") {
            a.extend(["--out", "never.gif"]);
        }
        let (ok, said) = ezy(&a);
        assert!(!ok && said.contains(want), "{args:?}: {said}");
    }
    // frames 0.015 s apart would play at 66.7 fps
    let (ok, said) = ezy(&["animate", "sleigh", "--dt", "0.015", "--fps", "50", "--out", "never.gif"]);
    assert!(!ok && said.contains("choose --speed as a multiple of 0.015 s"), "{said}");
    assert!(!Path::new("never.gif").exists() && !Path::new("x.mp4").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// `--report` writes one HTML file with the figures inline, the animation
/// as a data URI, the ledger and the scene, and nothing it would load from
/// elsewhere.
#[test]
fn the_report_is_self_contained() {
    let out = tmp("report");
    let dir = out.display().to_string();
    let (ok, said) = ezy(&["run", "drive", "--t-end", "3", "--report", "--out", &dir]);
    assert!(ok, "{said}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    for external in ["<script", "<link", "src=\"http", "href=", "url(", "@import"] {
        assert!(!html.contains(external), "the report loads something: {external}");
    }
    // every src is inline data: the animation
    let srcs: Vec<&str> = html.match_indices("src=\"").map(|(k, _)| &html[k + 5..k + 40]).collect();
    assert_eq!(srcs.len(), 1);
    assert!(srcs[0].starts_with("data:image/gif;base64,R0lGODlh"), "a GIF89a: {}", srcs[0]);
    assert_eq!(html.matches("<svg").count(), 7, "the drive scene's seven figures inline");
    for part in
        ["Energy ledger", "W_motor", "T(t_end) - T(0) - sum W", "ezy run drive --t-end 3.0 --report", "[effects.motor]"]
    {
        assert!(html.contains(part), "missing {part}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// `text` as one word of a POSIX shell's command line.
fn sh_word(text: &str) -> String {
    format!("'{}'", text.replace('\'', "'\\''"))
}

/// The report of a run given a scene file names that file in the command
/// that reproduces the run, quoted for a shell, and that command reruns
/// it; the frame rate the report states is the one its GIF plays; the
/// ledger's names and numbers do not wrap.
#[test]
fn the_report_reproduces_a_scene_file_and_states_its_frame_rate() {
    let out = tmp("report-file");
    std::fs::create_dir_all(&out).unwrap();
    let file = out.join("Bob's drive $1.toml");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(root.join("models/scenes/drive.toml"), &file).unwrap();
    let first = out.join("first");
    let (ok, said) = ezy(&[
        "run",
        file.to_str().unwrap(),
        "--t-end",
        "2",
        "--set",
        "M0=0.5",
        "--no-figures",
        "--report",
        "--out",
        first.to_str().unwrap(),
    ]);
    assert!(ok, "{said}");
    let html = std::fs::read_to_string(first.join("report.html")).unwrap();
    let unescape = |s: &str| s.replace("&quot;", "\"").replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&");
    let command = |html: &str| {
        let after = html.split("<h2>To reproduce</h2>\n<pre>").nth(1).expect("a command to reproduce the run");
        unescape(after.split("</pre>").next().unwrap())
    };
    let given = command(&html);
    let want =
        format!("ezy run {} --set M0=0.5 --t-end 2.0 --no-figures --report", sh_word(&file.display().to_string()));
    assert_eq!(given, want);
    // the command reruns the run, from any directory
    let again = out.join("again");
    let script = format!(
        "{} --out {}",
        given.replacen("ezy", &sh_word(env!("CARGO_BIN_EXE_ezy")), 1),
        sh_word(&again.display().to_string())
    );
    let o = Command::new("sh").arg("-c").arg(&script).current_dir(std::env::temp_dir()).output().unwrap();
    assert!(o.status.success(), "{script}: {}", String::from_utf8_lossy(&o.stderr));
    let rerun = std::fs::read_to_string(again.join("report.html")).unwrap();
    assert_eq!(command(&rerun), given);
    // the frame rate stated is the GIF's: each frame 100 / fps hundredths of a second
    let stated: f64 = html
        .split(" frames per second")
        .next()
        .and_then(|s| s.rsplit('>').next())
        .and_then(|s| s.trim().parse().ok())
        .expect("the report states the animation's frame rate");
    let data = html.split("data:image/gif;base64,").nth(1).unwrap().split('"').next().unwrap();
    use base64::Engine as _;
    let gif = base64::engine::general_purpose::STANDARD.decode(data).unwrap();
    let mut d = gif::DecodeOptions::new().read_info(gif.as_slice()).unwrap();
    let mut delays = Vec::new();
    while let Some(f) = d.read_next_frame().unwrap() {
        delays.push(f.delay);
    }
    assert!(!delays.is_empty());
    for delay in delays {
        assert_eq!(100.0 / f64::from(delay), stated, "a frame of {delay}/100 s plays at {stated} fps");
    }
    // the ledger scrolls rather than wrapping its names and numbers
    assert!(html.contains("<div class=\"wide\">\n<table>"), "the ledger in a scrolling box");
    assert!(html.contains("td.name, td.num { white-space: nowrap; }"));
    assert!(html.contains("<td class=\"num\">"));
    let _ = std::fs::remove_dir_all(&out);
}

/// `ezy precision --replot --overlay`: the figures redrawn from a saved
/// ladder with other tools' points, the ladder kept; a bad overlay file
/// is refused at its line.
#[test]
fn the_work_precision_diagram_takes_an_overlay() {
    let out = tmp("overlay");
    std::fs::create_dir_all(&out).unwrap();
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/book/src/figures/precision");
    std::fs::copy(docs.join("precision.csv"), out.join("precision.csv")).unwrap();
    let dir = out.display().to_string();
    let peers = docs.join("peers.csv").display().to_string();
    let (ok, said) = ezy(&["precision", "drive", "--replot", "--overlay", &peers, "--out", &dir]);
    assert!(ok && said.contains("redrew"), "{said}");
    png_size(&std::fs::read(out.join("work_precision.png")).unwrap());
    assert!(out.join("drift.png").is_file());
    let saved = std::fs::read_to_string(docs.join("precision.csv")).unwrap();
    assert_eq!(std::fs::read_to_string(out.join("precision.csv")).unwrap(), saved, "the ladder is kept");
    let bad = out.join("bad.csv");
    std::fs::write(&bad, "label,wall_s,error\nC++,1e-3,1e-9\nC++,fast,1e-9\n").unwrap();
    let (ok, said) = ezy(&["precision", "drive", "--replot", "--overlay", bad.to_str().unwrap(), "--out", &dir]);
    assert!(!ok && said.contains("bad.csv:3: `wall_s` = `fast` is not a finite number > 0"), "{said}");
    let _ = std::fs::remove_dir_all(&out);
}
