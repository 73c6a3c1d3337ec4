//! The user's own model animated and reported as the built-ins are: a GIF
//! with one frame per interval (its `[draw]` table used), and a run report
//! with the scene's figures inline as SVG.

use crate::common;
use common::SCENE;

fn program(args: &[&str]) -> String {
    let o = common::program().args(args).output().expect("runs");
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{args:?}: {text}");
    text
}

#[test]
fn the_users_scene_animates_and_reports() {
    let out = common::out_dir("figures");
    let gif = out.join(format!("{SCENE}.gif"));
    let said =
        program(&["animate", SCENE, "--t-end", "2", "--fps", "5", "--dpi", "24", "--out", gif.to_str().unwrap()]);
    // 2 s at 5 frames per second: 10 intervals and the start
    assert!(said.contains("11 frames of 240 x 160 px"), "{said}");
    let bytes = std::fs::read(&gif).unwrap();
    assert!(bytes.starts_with(b"GIF89a"));
    let dir = out.join("run");
    program(&["run", SCENE, "--t-end", "2", "--format", "svg", "--report", "--out", dir.to_str().unwrap()]);
    for f in ["paths.svg", "speed.svg", "energy.svg", "trajectory.csv"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 3);
    assert!(html.contains("data:image/gif;base64,") && html.contains("W_steer") && !html.contains("<script"));
}
