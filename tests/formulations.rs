//! The reduced formulation (coordinate partitioning, `--formulation
//! reduced`) against the DAE: the same trajectories to the tolerance, the
//! constraints kept to rounding at every output without projection, a new
//! partition where the old one degrades, `auto`'s choice, and the errors
//! of what it cannot do.

use crate::common;

use common::build;
use common::{Numeric, Recorder, max_abs};
use ezy_core::kkt::KktMethod;
use ezy_core::{Formulation, Method, Model, ProjectionKind, RunSettings, Setting, SimError, simulate};
use ezy_models::{EzyRoller, EzyRollerDriven, FourBar, SliderCrank, Snake, Snakeboard, Trailer, scenes};

/// `scene` with `formulation`, DOP853 at `tol`, outputs every `every`.
fn run<M: Model + Default>(
    scene: &str,
    formulation: Formulation,
    tol: f64,
    every: f64,
) -> (Recorder, ezy_core::Summary) {
    let scene = scenes::get(scene);
    let (mut sys, y0) = build::<M>(&scene, &[], KktMethod::Auto).unwrap();
    let settings = RunSettings {
        every,
        formulation,
        projection: if formulation == Formulation::Reduced {
            ProjectionKind::None
        } else {
            ProjectionKind::MassWeighted
        },
        ..common::dop853(scene.t_end, every, tol)
    };
    let mut rec = Recorder::default();
    let summary = simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
    (rec, summary)
}

/// Each scene's reduced run at rtol = atol = 1e-10 against its DAE run at
/// 1e-12: every output on the constraints to rounding (`|C|` <= 1e-12 m,
/// `|G qd|` <= 1e-12 m/s, where a run without projection drifts by the
/// integration error, ~1e-9), the whole trajectory as accurate as the
/// DAE's at the same tolerance (within 10x of its error, in the mixed norm
/// `|a - b| / max(1, |b|)`; the error at 1e-10 ranges from 1e-9 on the
/// EzyRoller to 1e-6 on the slider-crank's 100 rad of crank angle), the
/// energy ledger closed to 1e-7 of the work done.
#[test]
fn the_reduced_formulation_follows_the_dae_and_keeps_the_constraints() {
    fn gap(a: &Recorder, b: &Recorder) -> f64 {
        a.y.iter()
            .zip(&b.y)
            .map(|(a, b)| max_abs(a.iter().zip(b).map(|(x, y)| (x - y) / y.abs().max(1.0))))
            .fold(0.0, f64::max)
    }
    fn check<M: Model + Default>(scene: &str, every: f64) -> u64 {
        let (red, s) = run::<M>(scene, Formulation::Reduced, 1e-10, every);
        let (dae, _) = run::<M>(scene, Formulation::Dae, 1e-10, every);
        let (reference, _) = run::<M>(scene, Formulation::Dae, 1e-12, every);
        assert_eq!(s.formulation, Formulation::Reduced);
        assert_eq!((s.projections, red.t.len()), (0, dae.t.len()), "{scene}");
        assert!(max_abs(red.res_phi.iter().copied()) <= 1e-12, "{scene}: |C| = {:?}", red.res_phi);
        assert!(max_abs(red.res_vel.iter().copied()) <= 1e-12, "{scene}: |G qd|");
        let (e_red, e_dae) = (gap(&red, &reference), gap(&dae, &reference));
        // the error control watches only the independent components: on
        // minimal coordinates the EzyRoller's body 2 rate is the
        // independent speeds over c + d = 0.2 m, which amplifies its
        // error (free: 3.1e-9 against the DAE's 2.6e-10 on the earlier
        // speeds x1d, y1d);
        // 1e-8 is 100 x rtol, the global error a method at rtol can show
        // over a run, far below an O(1) mistake's
        assert!(e_red <= (10.0 * e_dae).max(1e-8), "{scene}: error {e_red:e} reduced, {e_dae:e} DAE");
        let work = max_abs(red.y.iter().map(|y| y[y.len() - 1])).max(1.0);
        assert!(s.max_energy_error <= 1e-7 * work, "{scene}: |T - T0 - W| = {:e}", s.max_energy_error);
        assert_eq!(s.minimal_coordinates, M::default().minimal_layout().is_ok(), "{scene}");
        s.repartitions
    }
    // on the minimal coordinates model! derived: never a new partition
    assert_eq!(check::<EzyRoller>("drive", 0.5), 0);
    assert_eq!(check::<EzyRoller>("free", 0.05), 0);
    // the numeric partition: hinges and skates (Newton in one step), a new
    // partition on the way
    assert_eq!(check::<Numeric<EzyRoller>>("drive", 0.5), 0);
    assert!(check::<Numeric<EzyRoller>>("free", 0.05) >= 1, "the free EzyRoller turns through a singular G_D");
    assert!(check::<Trailer>("trailer", 5.0) >= 1);
    // a drive (a dependent angle: Newton iterates), a closed loop, a slider
    check::<EzyRollerDriven>("drive-prescribed", 0.5);
    check::<FourBar>("four-bar", 0.1);
    check::<SliderCrank>("slider-crank", 0.05);
}

/// The drive scene at DOP853 rtol = atol = 1e-11 against the reference
/// state at 60 s (DOP853 of the DAE at 1e-13, benches/peers/reference.csv):
/// within 1e-9, the accuracy the peer comparison asks of every tool (it
/// reaches 3.7e-10; the DAE at the same tolerance 5.3e-10).
#[test]
fn the_reduced_drive_reaches_the_reference_at_60_s() {
    let (_, s) = run::<EzyRoller>("drive", Formulation::Reduced, 1e-11, 60.0);
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/benches/peers/reference.csv")).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let names: Vec<&str> = lines.next().unwrap().split(',').collect();
    let values: Vec<f64> = lines.next().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    // the reference row: t, q (6), qd (6), W; the final state: q, qd, W
    assert_eq!((names[0], names.len(), s.final_state.len()), ("t", 14, 13));
    let err = max_abs(values[1..].iter().zip(&s.final_state).map(|(r, y)| r - y));
    assert!(err <= 1e-9, "max error at 60 s {err:e}");
}

/// `auto` takes the reduced formulation only where it was measured to pay:
/// an adaptive explicit method on a model with one degree of freedom in
/// velocity whose dependent coordinates follow from one Newton step, and
/// the explicit methods on minimal coordinates.
#[test]
fn auto_takes_the_reduced_formulation_only_where_it_pays() {
    fn chosen<M: Model + Default>(scene: &str, method: Method) -> Formulation {
        let scene = scenes::get(scene);
        let (mut sys, y0) = build::<M>(&scene, &[], KktMethod::Auto).unwrap();
        let settings = RunSettings {
            t_end: 0.05,
            every: 0.05,
            dt: 1e-3,
            method,
            formulation: Formulation::Auto,
            ..scene.run_settings()
        };
        simulate(&mut sys, &y0, &settings, &mut Recorder::default()).unwrap().formulation
    }
    assert_eq!(chosen::<Trailer>("trailer", Method::Dop853), Formulation::Reduced);
    assert_eq!(chosen::<Trailer>("trailer", Method::Dopri5), Formulation::Reduced);
    // a fixed step saves nothing; RADAU5 is built on the DAE
    assert_eq!(chosen::<Trailer>("trailer", Method::Rk4), Formulation::Dae);
    assert_eq!(chosen::<Trailer>("trailer", Method::Radau5), Formulation::Dae);
    // two degrees of freedom on a numeric partition
    assert_eq!(chosen::<Numeric<EzyRoller>>("drive", Method::Dop853), Formulation::Dae);
    assert_eq!(chosen::<Snakeboard>("snakeboard", Method::Dop853), Formulation::Dae);
    // minimal coordinates: the explicit methods (RK4 at the assignment's
    // step: 13 % fewer instructions than the DAE with projection, 0.65-0.89x
    // its wall time in five alternated pairs)
    for method in [Method::Dopri5, Method::Dop853, Method::Rk4] {
        assert_eq!(chosen::<EzyRoller>("drive", method), Formulation::Reduced, "{method:?}");
    }
    assert_eq!(chosen::<EzyRoller>("drive", Method::Radau5), Formulation::Dae);
    // a drive makes an angle dependent: no minimal coordinates
    assert_eq!(chosen::<EzyRollerDriven>("drive-prescribed", Method::Dop853), Formulation::Dae);
}

/// What the reduced formulation cannot do is refused before any step,
/// with the reason and the way out.
#[test]
fn the_reduced_formulation_refuses_what_it_cannot_do() {
    // the setting advised is data; a library spells it by its name, the
    // command line (inside `Spelling::Flags.scope`) by its flag
    let reason = |e: ezy_core::RunError<std::convert::Infallible>| match e {
        ezy_core::RunError::Sim(SimError::Formulation { reason }) => {
            let advised: Vec<_> = reason.settings().collect();
            assert!(advised.contains(&Setting::Formulation(Formulation::Dae)), "{reason}: {advised:?}");
            let flags = ezy_core::Spelling::Flags.scope(|| reason.to_string());
            assert!(flags.contains("--formulation dae") && format!("{reason:#}") == flags, "{flags}");
            reason.to_string()
        }
        other => panic!("{other}"),
    };
    let dae = |e: &str| e.contains("`formulation = dae`");
    let scene = scenes::drive();
    let (mut sys, y0) = build::<EzyRoller>(&scene, &[], KktMethod::Auto).unwrap();
    let base = RunSettings { t_end: 0.1, every: 0.1, formulation: Formulation::Reduced, ..scene.run_settings() };
    let radau = RunSettings { method: Method::Radau5, ..base };
    let e = reason(simulate(&mut sys, &y0, &radau, &mut Recorder::default()).unwrap_err());
    assert!(e.contains("RADAU5") && dae(&e), "{e}");
    sys.baumgarte = Some(ezy_core::Baumgarte { alpha: 10.0, beta: 10.0 });
    let e = reason(simulate(&mut sys, &y0, &base, &mut Recorder::default()).unwrap_err());
    assert!(e.contains("Baumgarte") && dae(&e), "{e}");
    // a 101-link snake: 2 x 100 hinge rows and 101 skates
    let snake = scenes::get("snake");
    let (mut sys, y0) = build::<Snake>(&snake, &[("N".into(), 101.0)], KktMethod::Auto).unwrap();
    let e = reason(simulate(&mut sys, &y0, &base, &mut Recorder::default()).unwrap_err());
    assert!(e.contains("301 constraint rows") && dae(&e), "{e}");
}

/// Through the program: the same CSV columns as the DAE's, the summary
/// names the formulation.
#[test]
fn the_program_writes_the_same_columns_in_either_formulation() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("formulations");
    let _ = std::fs::remove_dir_all(&dir);
    let header = |formulation: &str| {
        let out = dir.join(formulation);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_ezy"))
            .args(["run", "free", "--no-figures", "--formulation", formulation, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(o.status.success(), "{said}{}", String::from_utf8_lossy(&o.stderr));
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        (csv.lines().next().unwrap().to_string(), csv.lines().count(), said)
    };
    let (dae, rows, _) = header("dae");
    let (reduced, reduced_rows, said) = header("reduced");
    assert_eq!((dae, rows), (reduced, reduced_rows));
    assert!(said.contains("reduced formulation on the minimal coordinates"), "{said}");
}

/// A scene file asks for its formulation in `[integrator]`; a misspelt
/// one is refused with its file, line and column and the choices.
#[test]
fn a_scene_file_asks_for_its_formulation() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/free.toml")).unwrap();
    let ask = |value: &str| text.replace("[integrator]", &format!("[integrator]\nformulation = \"{value}\""));
    let scene = ezy_scene::Scene::from_toml(&ask("reduced"), "free.toml").unwrap();
    assert_eq!(scene.run_settings().formulation, Formulation::Reduced);
    // none asked: auto, the fastest of the two for the run
    assert_eq!(ezy_scene::Scene::from_toml(&text, "free.toml").unwrap().run_settings().formulation, Formulation::Auto);
    let e = ezy_scene::Scene::from_toml(&ask("reduce"), "free.toml").unwrap_err().to_string();
    assert!(e.starts_with("free.toml:13:") && e.contains("`reduce`") && e.contains("`dae`, `reduced`"), "{e}");
}

ezy_core::model! {
    /// Three bodies in a chain, each with a skate off its hinges: a
    /// tractor and two trailers (the minimal coordinates of a deeper tree).
    pub struct TwoTrailers {
        param a = 0.3;
        param h = 0.8;
        param e = 0.6;
        param f = 0.2;
        body tractor(x1, y1, phi1) { mass: 20.0, inertia: 1.5 }
        body first(x2, y2, phi2) { mass: 8.0, inertia: 0.6 }
        body second(x3, y3, phi3) { mass: 6.0, inertia: 0.4 }
        point R on tractor at (-a, 0);
        point H1 on tractor at (-h, 0);
        point H2 on first at (e, 0);
        point T2 on first at (-f, 0);
        point K2 on first at (-e, 0);
        point K3 on second at (e, 0);
        point T3 on second at (-f, 0);
        hinge H: H1 = H2;
        hinge K: K2 = K3;
        skate R: R along (1, 0);
        skate T2: T2 along (1, 0);
        skate T3: T3 along (1, 0);
    }
}

ezy_core::model! {
    /// Two bodies whose hinges close a loop through the ground.
    pub struct GroundLoop {
        body left(x1, y1, phi1) { mass: 1.0, inertia: 0.1 }
        body right(x2, y2, phi2) { mass: 1.0, inertia: 0.1 }
        point L0 on left at (-0.5, 0);
        point L1 on left at (0.5, 0);
        point R1 on right at (-0.5, 0);
        point R0 on right at (0.5, 0);
        hinge A: L0 = ground(0, 0);
        hinge B: L1 = R1;
        hinge C: R0 = ground(1.5, 0);
    }
}

ezy_core::model! {
    /// A skate whose axle (the line through its contact point across the
    /// blade) runs through the hinge: its row has no constant coefficient.
    pub struct AxleThroughHinge {
        body base(x1, y1, phi1) { mass: 5.0, inertia: 0.5 }
        body arm(x2, y2, phi2) { mass: 1.0, inertia: 0.1 }
        point S on base at (-0.4, 0);
        point B1 on base at (0.5, 0);
        point B2 on arm at (0, 0);
        point C on arm at (0, 0.3);
        hinge B: B1 = B2;
        skate S: S along (1, 0);
        skate C: C along (1, 0);
    }
}

/// `model!`'s minimal coordinates: the kept coordinates and independent
/// speeds of the tree models, the terms checked against finite
/// differences and dual numbers, and the reason each other model gives.
#[test]
fn model_derives_minimal_coordinates_for_trees_and_says_why_not_otherwise() {
    let layout = TwoTrailers::default().minimal_layout().unwrap();
    // the tractor's x, y, phi and each trailer's phi; the tractor's skate
    // fixes its lateral velocity, each trailer's its angular rate, and the
    // tractor's forward velocity and angular rate are the speeds
    assert_eq!((layout.coords, layout.speeds), (vec![0, 1, 2, 5, 8], vec![0, 2]));
    assert_eq!(layout.pivots.iter().map(|p| p.1).collect::<Vec<_>>(), [1, 5, 8]);
    ezy::testing::assert_derivatives(&TwoTrailers::default());
    // a chain hinged to the ground keeps only angles, and every speed
    let layout = ezy_models::DoublePendulum::default().minimal_layout().unwrap();
    assert_eq!((layout.coords, layout.speeds), (vec![2, 5], vec![2, 5]));
    ezy::testing::assert_derivatives(&ezy_models::DoublePendulum::default());
    let why = |m: Result<ezy_core::MinimalLayout, String>| m.unwrap_err();
    for (reason, want) in [
        (why(GroundLoop::default().minimal_layout()), "hinge `C` closes a loop"),
        (why(FourBar::default().minimal_layout()), "closes a loop"),
        (why(AxleThroughHinge::default().minimal_layout()), "skate `C`"),
        (why(SliderCrank::default().minimal_layout()), "slider or slot"),
        (why(EzyRollerDriven::default().minimal_layout()), "drive"),
        (why(Trailer::default().minimal_layout()), "families"),
    ] {
        assert!(reason.contains(want), "{reason}");
    }
    // skate A at body 1's centre of mass: its row fixes body 1's lateral
    // velocity with pivot 1 whatever `a`, so minimal coordinates still run
    // (on speeds of global rates its pivot was `a`, and zero here)
    let (mut sys, y0) = build::<EzyRoller>(&scenes::get("drive"), &[("a".into(), 0.0)], KktMethod::Auto).unwrap();
    let layout = sys.model.minimal_layout().unwrap();
    assert_eq!((layout.pivots[0].1, layout.pivots[0].2), (1, 1.0));
    let settings = RunSettings {
        formulation: Formulation::Reduced,
        projection: ProjectionKind::None,
        ..common::dop853(0.5, 0.5, 1e-8)
    };
    let s = simulate(&mut sys, &y0, &settings, &mut Recorder::default()).unwrap();
    assert_eq!((s.formulation, s.minimal_coordinates), (Formulation::Reduced, true));
}

/// Skate A 1 µm from body 1's centre of mass (radius of gyration
/// 0.47 m): on speeds of global rates its row fixed the angular rate
/// `v_lat / a`, and minimal coordinates diverged at 25 s of the drive at
/// 1e-10; on body-frame speeds it fixes the lateral velocity with pivot 1
/// and the run follows the DAE. An angular-rate pivot far below its body's
/// radius of gyration (skate C 1 mm from the hinge, radius 0.071 m) is
/// still refused: the reduced formulation takes the numeric partition and
/// says why, auto the DAE; the threshold `c + d = 0.05 rho` is where it
/// says.
#[test]
fn a_skate_at_the_centre_of_mass_runs_and_a_small_angular_pivot_is_refused() {
    let run = |sys: &mut ezy_core::Dynamics<EzyRoller>, y0: &[f64], formulation, t_end| {
        let settings = RunSettings {
            formulation,
            projection: ProjectionKind::MassWeighted,
            ..common::dop853(t_end, t_end, 1e-10)
        };
        let mut rec = Recorder::default();
        let s = simulate(sys, y0, &settings, &mut rec).unwrap();
        (s, rec)
    };
    let (mut sys, y0) = build::<EzyRoller>(&scenes::get("drive"), &[("a".into(), 1e-6)], KktMethod::Auto).unwrap();
    let (dae, _) = run(&mut sys, &y0, Formulation::Dae, 30.0);
    let (red, rec) = run(&mut sys, &y0, Formulation::Reduced, 30.0);
    assert!(red.minimal_coordinates && rec.notes.is_empty(), "{:?}", rec.notes);
    // both at 1e-10 over 30 s: 2e-9 apart measured at 60 s; the old
    // angular-rate pivot drifted 5e-6 already at a = 1e-3
    let gap = max_abs(red.final_state.iter().zip(&dae.final_state).map(|(a, b)| a - b));
    assert!(gap <= 1e-8, "{gap:e}");
    // skate C's pivot is `c + d` on body 2's angular rate (rho = 0.0707 m)
    let rho = 0.005f64.sqrt();
    for (pivot, minimal) in [(0.049 * rho, false), (0.051 * rho, true), (0.2, true)] {
        let c = ("c".to_string(), pivot - 0.1);
        let (sys, _) = build::<EzyRoller>(&scenes::get("drive"), &[c], KktMethod::Auto).unwrap();
        let layout = sys.model.minimal_layout().unwrap();
        let small = ezy_core::formulation::reduced::small_pivot(&sys.info, &sys.mass, &layout);
        assert_eq!(small.is_none(), minimal, "c + d = {pivot}: {small:?}");
    }
    let (mut sys, y0) = build::<EzyRoller>(&scenes::get("drive"), &[("c".into(), -0.099)], KktMethod::Auto).unwrap();
    let (dae, _) = run(&mut sys, &y0, Formulation::Dae, 5.0);
    let (red, rec) = run(&mut sys, &y0, Formulation::Reduced, 5.0);
    assert_eq!((red.formulation, red.minimal_coordinates), (Formulation::Reduced, false));
    assert!(rec.notes.iter().any(|n| n.contains("skate `C`") && n.contains("radius of gyration")), "{:?}", rec.notes);
    // the numeric partition follows the DAE: 6.5e-7 apart at 5 s measured
    // (body 2's rate enters skate C's row times 1 mm: ill-conditioned in
    // either formulation); a wrong partition is off by centimetres
    let gap = max_abs(red.final_state.iter().zip(&dae.final_state).map(|(a, b)| a - b));
    assert!(gap <= 1e-5, "{gap:e}");
    let (auto, rec) = run(&mut sys, &y0, Formulation::Auto, 5.0);
    assert_eq!(auto.formulation, Formulation::Dae);
    assert!(rec.notes.is_empty(), "{:?}", rec.notes);
}

/// A scene of a model with three skates on its minimal coordinates: the
/// same trajectory as the DAE's and the constraints to rounding.
#[test]
fn a_deeper_tree_runs_on_its_minimal_coordinates() {
    let scene = ezy_scene::Scene::from_toml(
        r#"
name = "train"
description = "tractor and two trailers coasting into a turn"
model = "two_trailers"
t_end = 5.0
[initial]
q = { x1 = 0.0, y1 = 0.0, phi1 = 0.0, phi2 = 0.2, phi3 = -0.1 }
qd = { x1 = 1.0, y1 = 0.1 }
"#,
        "train.toml",
    )
    .unwrap();
    let (mut sys, y0) = build::<TwoTrailers>(&scene, &[], KktMethod::Auto).unwrap();
    let mut runs = Vec::new();
    for (formulation, tol) in [(Formulation::Reduced, 1e-11), (Formulation::Dae, 1e-12)] {
        let settings = RunSettings {
            formulation,
            projection: if formulation == Formulation::Dae {
                ProjectionKind::MassWeighted
            } else {
                ProjectionKind::None
            },
            ..common::dop853(5.0, 0.5, tol)
        };
        let mut rec = Recorder::default();
        let s = simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
        runs.push((rec, s));
    }
    let ((red, s), (dae, _)) = (&runs[0], &runs[1]);
    assert!(s.minimal_coordinates);
    assert!(max_abs(red.res_phi.iter().copied()) <= 1e-12 && max_abs(red.res_vel.iter().copied()) <= 1e-12);
    // DOP853 at 1e-11 and 1e-12 over 5 s: ~1e-10 apart; an O(1) mistake
    // in B or c moves the trailers by centimetres
    let gap =
        red.y.iter().zip(&dae.y).flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs())).fold(0.0, f64::max);
    assert!(gap <= 1e-8, "{gap:e}");
    assert!(red.y.last().unwrap()[0] > 2.0, "the train coasts forward");
}

/// A scene whose effects are all hinge torques hands them to the model's
/// fused right-hand side as such (`model!` maps each hinge's torque onto
/// the speeds at compile time, and the force vector's part folds away);
/// with any other effect beside them they go through the force vector.
/// At one state both give the same `dz` (rates and each hinge effect's
/// power) to rounding: the two routes differ only in how `B^T` meets the
/// torque, so 1e-13 of the largest term, where a wrong sign, hinge or law
/// is O(1).
#[test]
fn hinge_torques_compiled_in_match_the_generic_forces() {
    use ezy_core::effects::{EffectSpec, Waveform};
    use ezy_core::formulation::reduced::Reduced;
    use ezy_scene::Scene;
    use ezy_scene::SceneEffect;
    // the all-effects scene's four hinge laws at hinge B, alone and with
    // its force `wind`, made zero, beside them (the generic route)
    let all = Scene::from_toml(include_str!("data/all_effects.toml"), "all_effects.toml").unwrap();
    let is_hinge = |e: &SceneEffect| {
        matches!(
            e,
            SceneEffect::Builtin(
                EffectSpec::HingeMotor(_)
                    | EffectSpec::HingeSpring(_)
                    | EffectSpec::HingeDamper(_)
                    | EffectSpec::HingeServo(_)
            )
        )
    };
    let mut hinges = all.clone();
    hinges.effects.retain(|(_, e)| is_hinge(e));
    assert_eq!(hinges.effects.len(), 4);
    let mut generic = hinges.clone();
    let mut wind = all.effects.iter().find(|(name, _)| name == "wind").unwrap().clone();
    let SceneEffect::Builtin(EffectSpec::Force(ezy_core::effects::Force { fx, fy, .. })) = &mut wind.1 else {
        panic!("`wind` is a force")
    };
    (*fx, *fy) = (Waveform::Constant(0.0), Waveform::Constant(0.0));
    generic.effects.push(wind);
    let t = 0.8;
    let dz = |scene: &Scene| {
        let (mut sys, y0) = build::<EzyRoller>(scene, &[], KktMethod::Auto).unwrap();
        let mut red = Reduced::new(&sys, t, &y0).unwrap();
        assert!(red.is_fused());
        let mut z = vec![0.0; red.nz(y0.len())];
        red.gather(&y0, &mut z);
        let mut dz = vec![f64::NAN; z.len()];
        red.eval(&mut sys, t, &z, &mut dz).unwrap();
        dz
    };
    let (compiled, generic) = (dz(&hinges), dz(&generic));
    // the generic run has one more work state, the zero force's, last
    assert_eq!((compiled.len() + 1, generic[generic.len() - 1]), (generic.len(), 0.0));
    let size = max_abs(compiled.iter().copied()).max(1.0);
    for (k, (a, b)) in compiled.iter().zip(&generic).enumerate() {
        assert!((a - b).abs() <= 1e-13 * size, "dz[{k}]: {a:e} compiled in, {b:e} through the forces");
    }
    // every torque is there: the hinge's rate changes with each law
    assert!(compiled[compiled.len() - 4..].iter().all(|p| *p != 0.0), "{compiled:?}");
}
