//! `ezy bench`: seven settings measured against ezy's own reference, with
//! the whole `run` process of each; the numbers are correct, not fast
//! (speed lives in the command's output, not in a test).

use std::process::Command;

#[test]
fn bench_measures_seven_settings_and_their_processes() {
    let o = Command::new(env!("CARGO_BIN_EXE_ezy")).args(["bench", "free", "--repeat", "1"]).output().expect("runs");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{text}{}", String::from_utf8_lossy(&o.stderr));
    let rows: Vec<Vec<&str>> = text.lines().skip(2).take(7).map(|l| l.split_whitespace().collect()).collect();
    assert_eq!(rows.len(), 7, "{text}");
    for r in &rows {
        // ... integration (value unit), RHS evals, error, whole process (value unit)
        let n = r.len();
        let error: f64 = r[n - 3].parse().unwrap_or_else(|_| panic!("error column in {r:?}"));
        let rhs: u64 = r[n - 4].parse().unwrap_or_else(|_| panic!("RHS column in {r:?}"));
        assert!(rhs > 0, "{r:?}");
        // DOP853 at 1e-11 (auto and DAE) and 3e-11 (reduced) and RK4 at
        // 1e-4 s (auto and DAE) all land far below 1e-6 on free (a coasting
        // EzyRoller); a wrong reference or state would not
        assert!(error.is_finite() && error < 1e-6, "{r:?}");
        assert!(["µs", "ms", "s"].contains(&r[n - 1]), "a whole-process time in {r:?}");
    }
    assert!(
        text.contains("1e-11, output every 0.01 s") && text.contains("3e-11, reduced (minimal coordinates)"),
        "{text}"
    );
    assert!(text.contains("3e-11, reduced (minimal coordinates), output every 0.01 s"), "{text}");
    // auto, the default, takes DOP853 and RK4 onto the minimal coordinates
    assert!(text.contains("1e-11, output at 1 s only: reduced (minimal coordinates)"), "{text}");
    assert!(text.contains("(the scene's): reduced (minimal coordinates)"), "{text}");
    assert!(text.contains("1e-11, dae, output at 1 s only"), "{text}");
    assert!(text.contains("dae, projection mass"), "{text}");
}
