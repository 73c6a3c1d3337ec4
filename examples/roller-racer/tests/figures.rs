//! The user's own model animated and reported as the built-ins are: a GIF
//! with one frame per interval (its `[draw]` table used), and a run report
//! with the scene's figures inline as SVG.

use std::path::Path;
use std::process::Command;

fn program(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_roller-racer")).args(args).output().expect("runs");
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{args:?}: {text}");
    text
}

#[test]
fn the_users_scene_animates_and_reports() {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("roller-racer-figures");
    let _ = std::fs::remove_dir_all(&out);
    let gif = out.join("roller.gif");
    let said =
        program(&["animate", "roller", "--t-end", "2", "--fps", "5", "--dpi", "24", "--out", gif.to_str().unwrap()]);
    // 2 s at 5 frames per second: 10 intervals and the start
    assert!(said.contains("11 frames of 240 x 160 px"), "{said}");
    let bytes = std::fs::read(&gif).unwrap();
    assert!(bytes.starts_with(b"GIF89a"));
    let dir = out.join("run");
    program(&["run", "roller", "--t-end", "2", "--format", "svg", "--report", "--out", dir.to_str().unwrap()]);
    for f in ["paths.svg", "speed.svg", "energy.svg", "trajectory.csv"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 3);
    assert!(html.contains("data:image/gif;base64,") && html.contains("W_steer") && !html.contains("<script"));
}
