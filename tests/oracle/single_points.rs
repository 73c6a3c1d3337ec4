//! `ezy analyze SCENE` on every built-in scene: each steady motion and
//! periodic orbit it writes (`equilibria.csv`, `periodic.csv`) checked
//! at its printed state against the oracle of [`super::bifurcations`]:
//! the state is a solution, the printed eigenvalues or multipliers are
//! the spectrum of the oracle's own Jacobian (differences of the
//! right-hand side) or period map (differences of whole runs over a
//! period), modulo the directions the structure makes neutral (the
//! plane's rigid motions where the scene has them, a limit cycle's
//! shift in time), and "stable", "unstable", "neutral" hold beyond
//! three times the oracle's error. A scene the command refuses must say
//! why (a skate that slides, a stiff scene, no steady motion found).
//!
//! Not the oracle's yet: steady motions relative to a symmetry (a
//! sleigh or trailer moving on a circle or a line: their spectrum is
//! that of the motion in its own frame); such scenes are listed.

use ezy_core::Model;
use ezy_core::analysis::c64;
use ezy_core::text::RuntimeModel;
use ezy_scene::Scene;

use super::bifurcations::{Case, Row, check_row};
use crate::analysis::{ezy, fresh, table};

/// What one scene's analysis gave the oracle.
#[derive(Debug, Default)]
struct Tally {
    /// Scenes whose solutions were checked, with their count.
    checked: Vec<(String, usize)>,
    /// Scenes refused by the command, with its message.
    refused: Vec<(String, String)>,
    /// Scenes with relative equilibria (not the oracle's yet).
    relative: Vec<String>,
}

/// The rows of `equilibria.csv` or `periodic.csv` in `dir` as the oracle
/// reads them: the state by the analysis's state names, the spectrum
/// (`lambda<k>` or `mu<k>`), the period and phase of an orbit.
fn rows<M: Model>(case: &Case<M>, dir: &std::path::Path) -> Vec<Row> {
    let file = if case.periodic { "periodic.csv" } else { "equilibria.csv" };
    let (head, rows) = table(&dir.join(file));
    let col = |name: &str| head.iter().position(|h| h == name);
    let (problem, _) = case.scene.problem_with(case.model.clone(), &[]).unwrap();
    let names = problem.analysis().unwrap().0.state_names();
    let letter = if case.periodic { "mu" } else { "lambda" };
    let num = |r: &[String], i: usize| r[i].parse::<f64>().unwrap();
    rows.iter()
        .map(|r| Row {
            value: 0.0,
            stability: r[col("stability").unwrap()].clone(),
            period: col("period").map(|i| num(r, i)),
            t0: col("t0").map_or(0.0, |i| num(r, i)),
            state: names.iter().map(|n| num(r, col(n).unwrap())).collect(),
            spectrum: (1..)
                .map_while(|k| col(&format!("{letter}{k}_re")).map(|i| c64::new(num(r, i), num(r, i + 1))))
                .collect(),
            bifurcation: None,
        })
        .collect()
}

/// Runs `ezy analyze` on `scene` (its file or name `file`) and checks
/// what it wrote; `tally` records the outcome.
fn analyze_one<M: Model>(scene: Scene, model: M, file: &str, tally: &mut Tally) {
    let name = scene.name.clone();
    let dir = fresh(&format!("oracle-single-{name}"));
    let (out, err, ok) = ezy(&["analyze", file, "--no-figures"], &dir);
    if !ok {
        let why = err.lines().find(|l| l.starts_with("error:")).unwrap_or_default().to_string();
        tally.refused.push((name, why));
        return;
    }
    let symmetry = out.lines().find_map(|l| l.split_once(": symmetry ").map(|(_, s)| s.to_string())).unwrap();
    let periodic = dir.join("periodic.csv").exists();
    if !periodic && !dir.join("equilibria.csv").exists() {
        // a growing motion: growth.csv, the growth oracle's
        assert!(dir.join("growth.csv").exists(), "{name}: nothing written: {out}");
        return;
    }
    let plane = symmetry.starts_with("vx, vy, omega");
    if !periodic && !symmetry.starts_with("none") || periodic && !plane && !symmetry.starts_with("none") {
        tally.relative.push(name);
        return;
    }
    // a limit cycle's whole turns per period (`turns_<coordinate>`)
    let turns = if periodic {
        let (head, rows) = table(&dir.join("periodic.csv"));
        head.iter()
            .zip(&rows[0])
            .filter_map(|(h, v)| h.strip_prefix("turns_").map(|c| (c.to_string(), v.parse().unwrap())))
            .collect()
    } else {
        Vec::new()
    };
    let case = Case {
        scene,
        model,
        file: file.into(),
        param: "",
        periodic,
        plane,
        cyclic: &[],
        autonomous: out.contains("limit cycle"),
        turns,
    };
    let rows = rows(&case, &dir);
    assert!(!rows.is_empty(), "{name}: no solution written: {out}");
    for row in &rows {
        let s = check_row(&case, row);
        eprintln!(
            "{name}: {} {} {:?}: printed {:?}, the oracle's {:?} (error {:.1e}, residual {:.1e})",
            if periodic { "orbit" } else { "steady motion" },
            row.stability,
            row.period,
            row.spectrum,
            s.values,
            s.error,
            s.residual
        );
    }
    tally.checked.push((name, rows.len()));
}

impl ezy_scene::registry::Register for Tally {
    fn register<M: Model + Default + 'static>(&mut self, key: &str) {
        for source in ezy::models::scenes::builtin() {
            if source.scene.model == key {
                let name = source.scene.name.clone();
                analyze_one(source.scene, M::default(), &name, self);
            }
        }
    }
}

/// The pendulums and the forced gait: the equilibria of a double
/// pendulum (its four real or imaginary eigenvalue pairs) and the
/// rolling-resistance gait's orbit modulo the plane's motions.
#[test]
fn a_scenes_steady_motions_and_orbits_are_the_oracles() {
    let mut tally = Tally::default();
    for name in ["double-pendulum", "drive-rolling-resistance"] {
        let scene = ezy::models::scenes::get(name);
        match name {
            "double-pendulum" => analyze_one(scene, ezy::models::DoublePendulum::default(), name, &mut tally),
            _ => analyze_one(scene, ezy::models::EzyRoller::default(), name, &mut tally),
        }
    }
    assert_eq!(tally.checked.len(), 2, "{tally:?}");
}

/// Every built-in scene, and the rotor sleigh typed as text (a limit
/// cycle's shift in time and the plane's motions left out).
#[test]
#[ignore = "whole harness: every built-in scene's `ezy analyze` (minutes)"]
fn every_built_in_scene_s_steady_motions_and_orbits_are_the_oracles() {
    let mut tally = Tally::default();
    ezy::models::register(&mut tally);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let path = data.join("rotor-drive.toml");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    analyze_one(Scene::read(&path).unwrap().0, model, path.to_str().unwrap(), &mut tally);
    for (scene, why) in &tally.refused {
        eprintln!("{scene}: refused: {why}");
        let named = ["slides", "stiff", "no steady motion", "radau5"].iter().any(|w| why.contains(w));
        assert!(named, "{scene}: refused without a reason named: {why}");
    }
    eprintln!("checked: {:?}", tally.checked);
    eprintln!("relative equilibria (not the oracle's yet): {:?}", tally.relative);
    assert!(tally.checked.len() >= 10, "{tally:?}");
}
