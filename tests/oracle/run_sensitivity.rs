//! A run's forward sensitivities (`ezy sensitivity`,
//! `Problem::sensitivities_with`) against central differences of whole
//! runs at `p +- h` and `p +- h/2`, extrapolated (Richardson), to 1e-8 of
//! the largest sensitivity of the parameter, over 20 s: long enough that
//! a difference of a harmonic's waveforms in its frequency (the right-hand
//! side's `df/dp` before it was linearized exactly in the waveforms'
//! numbers) erred by `(h t)^2 / 6`, 3e-8 relative at t = 20 s.
//!
//! The runs are DOP853 at 1e-13 on the DAE formulation (the sensitivity
//! equations are integrated with the state, under the same error
//! control); their error over `2h = 2e-4 |p|` is about 1e-9 of a
//! sensitivity, which the extrapolation's change bounds (asserted).

use ezy::models::{ElasticFourBar, EzyRoller, FourBar, NFourBar, scenes};
use ezy_core::sensitivity::{Parameter, Sensitivities};
use ezy_core::text::RuntimeModel;
use ezy_core::{Method, Model, Problem};
use ezy_scene::Scene;

/// The run settings of the oracle and of the run differentiated.
fn tight(settings: ezy_core::RunSettings) -> ezy_core::RunSettings {
    ezy_core::RunSettings {
        method: Method::Dop853,
        rtol: 1e-13,
        atol: 1e-13,
        formulation: ezy_core::Formulation::Dae,
        ..settings
    }
}

/// Checks the sensitivities of `columns` at the run's end with respect
/// to each of `names` against Richardson's extrapolation of central
/// differences of whole runs (`h = 1e-4 max(0.1, |p|)`: a four-bar's
/// 0.1 m crank at `h = 1e-4` left 4e-5 of curvature in them), to 1e-8 of the
/// parameter's largest sensitivity plus three times the extrapolation's
/// change (the oracle's own error) plus the differences' rounding (`1e-12
/// max(1, |x|) / h`: the runs' 1e-13 times ten, over the step; 1e-8 for a
/// state of size 1), both at the oracle's settings ([`tight`]).
fn check<M: Model>(scene: &Scene, model: &M, names: &[&str], columns: &[&str]) {
    check_with(scene, model, names, columns, tight);
}

/// [`check`] with the run and its differences at `settings`: for a
/// fixed-step method the sensitivities are the derivatives of the
/// discrete run itself (its steps and projections differentiated), so
/// differences of runs at the same step are their oracle to the same
/// 1e-8, however far the discrete run is from the exact motion.
fn check_with<M: Model>(
    scene: &Scene,
    model: &M,
    names: &[&str],
    columns: &[&str],
    settings: impl Fn(ezy_core::RunSettings) -> ezy_core::RunSettings,
) {
    check_against(scene, model, names, columns, &settings, &settings);
}

/// [`check`] with the run differentiated at `run`'s settings and the
/// oracle's runs at `oracle`'s.
fn check_against<M: Model>(
    scene: &Scene,
    model: &M,
    names: &[&str],
    columns: &[&str],
    run: &dyn Fn(ezy_core::RunSettings) -> ezy_core::RunSettings,
    oracle: &dyn Fn(ezy_core::RunSettings) -> ezy_core::RunSettings,
) {
    let (mut problem, _): (Problem<M>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    let params = parameters(scene, model, names, oracle(problem.settings));
    problem.settings = run(problem.settings);
    let s = problem.sensitivities_with(&params).unwrap();
    compare(scene, &params, &s, columns);
}

/// The scene's parameters `names`, each problem built at `settings`.
fn parameters<M: Model>(
    scene: &Scene,
    model: &M,
    names: &[&str],
    settings: ezy_core::RunSettings,
) -> Vec<Parameter<M>> {
    names
        .iter()
        .map(|n| {
            let p = scene.parameter(model, &[], n).unwrap();
            Parameter::new(p.name.clone(), p.value, move |v| {
                let mut q = p.problem(v)?;
                q.settings = settings;
                Ok(q)
            })
        })
        .collect()
}

/// The sensitivities `s` of `columns` at every sample against the
/// differences of whole runs of each of `params` (see [`check`]), each
/// run's sample at the same time: a sample inside an adaptive step is the
/// pair's dense output, in the sensitivities as in the runs.
fn compare<M: Model>(scene: &Scene, params: &[Parameter<M>], s: &Sensitivities, columns: &[&str]) {
    for p in params {
        let method = p.problem(p.value).unwrap().settings.method;
        let h = 1e-4 * p.value.abs().max(0.1);
        // the four runs, each once: `columns` at every sample (rows)
        let runs: Vec<Vec<Vec<f64>>> = [h, -h, h / 2.0, -h / 2.0]
            .iter()
            .map(|d| {
                let run = p.problem(p.value + d).unwrap().solve().unwrap();
                assert_eq!(run.t, s.t, "{}: the runs' samples are not the sensitivities'", scene.name);
                columns.iter().map(|c| run.column(c).unwrap()).collect()
            })
            .collect();
        let got: Vec<Vec<f64>> = columns.iter().map(|c| s.column(&format!("d{c}/d{}", p.name)).unwrap()).collect();
        // the differences' own rounding: a run's samples to about 1e-13 of
        // their size (the tolerance), over 2h; all of what a parameter that
        // moves nothing (a kinematic snake's mass) leaves in them
        let size = runs.iter().flatten().flatten().fold(1.0f64, |m, v| m.max(v.abs()));
        let noise = 1e-12 * size / h;
        let largest = got.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let scale = largest.max(noise);
        for (i, c) in columns.iter().enumerate() {
            for (k, &t) in s.t.iter().enumerate() {
                let central = |r: usize, h: f64| (runs[r][i][k] - runs[r + 1][i][k]) / (2.0 * h);
                let (d1, d2) = (central(0, h), central(2, h / 2.0));
                let want = d2 + (d2 - d1) / 3.0;
                let oracle = (want - d2).abs();
                let g = got[i][k];
                if k + 1 == s.t.len() {
                    eprintln!(
                        "{} (oracle runs {:?}): d{c}/d{} = {g:.12e} against {want:.12e} at t = {t} s (Richardson change {oracle:.1e}, off {:.1e} of the largest)",
                        scene.name,
                        method,
                        p.name,
                        (g - want).abs() / scale
                    );
                }
                let settled = oracle <= 1e-5 * largest + noise;
                assert!(settled, "{}: d{c}/d{} at t = {t} s: the differences did not settle", scene.name, p.name);
                assert!(
                    (g - want).abs() <= 1e-8 * largest + 3.0 * oracle + noise,
                    "{}: d{c}/d{} = {g:.12e} against {want:.12e} at t = {t} s ({:.1e} of the largest)",
                    scene.name,
                    p.name,
                    (g - want).abs() / scale
                );
            }
        }
    }
}

/// The drive scene over 20 s: the motor's frequency and amplitude, a
/// mass, the fork length (in the constraints).
#[test]
fn a_runs_sensitivities_are_the_differences_of_whole_runs() {
    let mut scene = scenes::drive();
    scene.t_end = 20.0;
    // samples inside steps too: the dense output of [x, S]
    scene.output.every = 20.0 / 3.0;
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    check(&scene, &EzyRoller::default(), &["omega", "M0", "m2", "c"], &columns);
}

/// DOPRI5 at 1e-12 (the other embedded pair, its own dense output of
/// order 4 for the samples inside steps) against the oracle's DOP853
/// runs at 1e-13: the drive scene and the text model with a drive over
/// 5 s, sampled at thirds. The pair's error in `S` is about its
/// tolerance times the run's growth, far inside the 1e-8 asked.
#[test]
fn dopri5_sensitivities_are_the_differences_of_whole_runs() {
    let dopri5 = |settings| ezy_core::RunSettings {
        method: Method::Dopri5,
        rtol: 1e-12,
        atol: 1e-12,
        formulation: ezy_core::Formulation::Dae,
        ..settings
    };
    let mut scene = scenes::drive();
    scene.t_end = 5.0;
    scene.output.every = 5.0 / 3.0;
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    check_against(&scene, &EzyRoller::default(), &["omega", "M0", "c"], &columns, &dopri5, &tight);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (mut text, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    text.t_end = 5.0;
    text.output.every = 5.0 / 3.0;
    check_against(&text, &model, &["psi.omega", "drag.c", "m"], &["x", "y", "phi", "xd", "phid"], &dopri5, &tight);
}

/// RADAU5 at `rtol = atol` = 1e-12 (its simplified Newton iteration on
/// the state and the sensitivities together, one error control; the
/// dense output of the samples inside steps its collocation polynomial)
/// against the oracle's DOP853 runs at 1e-13: the drive scene over 5 s,
/// sampled at thirds (3e-10 of the largest off). The stiff four-bar's
/// RADAU5 sensitivities against differences of whole runs:
/// [`the_stiff_four_bar_s_sensitivities_are_the_differences_of_whole_runs`].
#[test]
fn radau5_sensitivities_are_the_differences_of_whole_runs() {
    let mut scene = scenes::drive();
    scene.t_end = 5.0;
    scene.output.every = 5.0 / 3.0;
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    check_against(&scene, &EzyRoller::default(), &["omega", "M0", "c"], &columns, &radau5, &tight);
}

/// `four-bar-stiff` over 10 ms (its coupler a spring-damper of 6e7 N/m
/// between the crank's pin `A2`, at `a / 2` from the crank's centre, and
/// the rocker's `B4`): every parameter of its model and the coupler's
/// rest length, DOP853 at 1e-13 and RADAU5 at 1e-12, against central
/// differences of whole runs (DOP853 at 1e-13) at `h`, `h/2`, `h/4`,
/// `h/8` (`h` = 2e-4 m for a length, 5e-3 of a mass or an inertia)
/// extrapolated twice (Richardson): the differences carry a large `h^2`
/// term (in `dphi2/da`, 1.6e6 h^2), the last two extrapolations agree
/// to 1e-11 of `dphi2/da`. To 1e-9 of the parameter's largest
/// sensitivity plus three times the extrapolations' change plus the
/// differences' rounding (as [`compare`]'s, at `h/8`). The coupler's
/// `dF/dp` was a difference of its forces at `p +- h`, which erred by
/// its stiffness times `h^2` across its line (where the stiff coupler
/// does not take it up): `dphi2/da` was -15.0740006 against the
/// differences' -15.0739881 (8.3e-7 off, growing like `t^2`), `c` 1.7e-7;
/// the law is now differentiated in its numbers (measured: `a` 2.5e-9
/// of the largest, at the oracle's own resolution).
#[test]
fn the_stiff_four_bar_s_sensitivities_are_the_differences_of_whole_runs() {
    let source = scenes::builtin().into_iter().find(|s| s.scene.name == "four-bar-stiff").unwrap();
    let mut scene = source.scene;
    scene.t_end = 0.01;
    scene.output.every = 0.01;
    let model = ElasticFourBar::default();
    let (problem, _): (Problem<ElasticFourBar>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    let names = ["a", "c", "d", "coupler.rest_length", "m2", "I2", "m4", "I4"];
    let params = parameters(&scene, &model, &names, tight(problem.settings));
    let columns: Vec<String> = {
        let coords = problem.model.info().coords;
        coords.iter().cloned().chain(coords.iter().map(|c| format!("{c}d"))).collect()
    };
    // each parameter's sensitivities at the end, by the oracle: the
    // doubly extrapolated differences, their last change and rounding
    let oracle: Vec<(Vec<f64>, Vec<f64>, f64)> = params
        .iter()
        .map(|p| {
            // the lengths at 2e-4 m, the masses and inertias at 5e-3 of their value
            let h = if p.name.starts_with(['m', 'I']) { 5e-3 * p.value } else { 2e-4 };
            let end = |v: f64| {
                let run = p.problem(v).unwrap().solve().unwrap();
                columns.iter().map(|c| *run.column(c).unwrap().last().unwrap()).collect::<Vec<f64>>()
            };
            let hs = [h, h / 2.0, h / 4.0, h / 8.0];
            let d: Vec<Vec<f64>> = hs
                .iter()
                .map(|&h| end(p.value + h).iter().zip(end(p.value - h)).map(|(a, b)| (a - b) / (2.0 * h)).collect())
                .collect();
            let richardson = |u: &[f64], v: &[f64], k: f64| -> Vec<f64> {
                u.iter().zip(v).map(|(u, v)| (k * v - u) / (k - 1.0)).collect()
            };
            let r1: Vec<Vec<f64>> = (0..3).map(|i| richardson(&d[i], &d[i + 1], 4.0)).collect();
            let r2: Vec<Vec<f64>> = (0..2).map(|i| richardson(&r1[i], &r1[i + 1], 16.0)).collect();
            let change = r2[1].iter().zip(&r2[0]).map(|(a, b)| (a - b).abs()).collect();
            let size = end(p.value).iter().fold(1.0f64, |m, v| m.max(v.abs()));
            (r2[1].clone(), change, 1e-12 * size / (h / 8.0))
        })
        .collect();
    for settings in [tight(problem.settings), radau5(problem.settings)] {
        let p = Problem { settings, ..problem.clone() };
        let s = p.sensitivities_with(&params).unwrap();
        for (param, (want, change, noise)) in params.iter().zip(&oracle) {
            let got: Vec<f64> =
                columns.iter().map(|c| *s.column(&format!("d{c}/d{}", param.name)).unwrap().last().unwrap()).collect();
            let largest = got.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let mut worst = 0.0f64;
            for (i, c) in columns.iter().enumerate() {
                let off = (got[i] - want[i]).abs();
                worst = worst.max(off / largest);
                assert!(
                    off <= 1e-9 * largest + 3.0 * change[i] + noise,
                    "four-bar-stiff ({:?}): d{c}/d{} = {:.12e} against the differences' {:.12e} ({:.1e} of the largest; the oracle's change {:.1e})",
                    settings.method,
                    param.name,
                    got[i],
                    want[i],
                    off / largest,
                    change[i] / largest
                );
            }
            eprintln!(
                "four-bar-stiff ({:?}): d/d{}: off {worst:.1e} of the largest ({largest:.3e})",
                settings.method, param.name
            );
        }
    }
}

/// RADAU5 on the DAE formulation at 1e-12 (see
/// [`radau5_sensitivities_are_the_differences_of_whole_runs`]).
fn radau5(settings: ezy_core::RunSettings) -> ezy_core::RunSettings {
    ezy_core::RunSettings {
        method: Method::Radau5,
        rtol: 1e-12,
        atol: 1e-12,
        formulation: ezy_core::Formulation::Dae,
        ..settings
    }
}

/// A user's sleigh with a prescribed rotor, typed as text: the drive's
/// frequency and amplitude (the prescribed angle's derivatives enter the
/// constraint's acceleration term), the drag and a mass.
#[test]
fn a_drives_sensitivities_are_the_differences_of_whole_runs() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (mut scene, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    scene.t_end = 20.0;
    scene.output.every = 20.0;
    check(&scene, &model, &["psi.omega", "psi.amplitude", "drag.c", "m"], &["x", "y", "phi", "xd", "phid"]);
}

/// A fixed-step run on the DAE formulation, projected after every step.
fn fixed(method: Method, dt: f64) -> impl Fn(ezy_core::RunSettings) -> ezy_core::RunSettings {
    move |settings| ezy_core::RunSettings { method, dt, formulation: ezy_core::Formulation::Dae, ..settings }
}

/// RK4 and Euler: the derivatives of the discrete runs (the projection
/// after each step differentiated where it moves the state: Euler's
/// drift, `dt^2` a step, made its sensitivities 2.7e-6 of their size off
/// here before), on the drive scene over 5 s and the text model with a
/// drive, once with a massless rotor (a singular mass matrix: the
/// projection's other path).
#[test]
fn fixed_step_sensitivities_are_the_differences_of_the_discrete_runs() {
    let mut scene = scenes::drive();
    scene.t_end = 5.0;
    scene.output.every = 5.0;
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (mut text, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    text.t_end = 5.0;
    text.output.every = 5.0;
    // the rotor's mass lumped into the sleigh's: `M` singular, the
    // velocities projected by the KKT system, the positions Euclidean
    let mut massless = text.clone();
    massless.params.push(("mr".into(), 0.0));
    for (method, dt) in [(Method::Rk4, 1e-3), (Method::Euler, 1e-3)] {
        check_with(&scene, &EzyRoller::default(), &["omega", "M0", "c"], &columns, fixed(method, dt));
        let text_columns = ["x", "y", "phi", "xd", "phid"];
        check_with(&text, &model, &["psi.omega", "drag.c", "m"], &text_columns, fixed(method, dt));
        check_with(&massless, &model, &["psi.omega", "m", "a"], &text_columns, fixed(method, dt));
    }
}

/// RK4 through `four-bar-n2`'s singular position (t = 0.714 s, every bar
/// on the x axis): at `dt = 1e-3` no stage comes closer than a KKT
/// growth of 1.8e6, and the sensitivities are the discrete run's
/// derivatives to the 1e-8 above, before and after it; at `dt = 1e-4` a
/// stage lands at a growth of 1.2e9, where they were 2e-6 of their size
/// off, silently (the check read the step's end only): refused, naming
/// the singular position.
#[test]
fn a_fixed_step_run_through_a_singular_position_is_differentiated_or_refused() {
    let source = scenes::builtin().into_iter().find(|s| s.scene.name == "four-bar-n2").unwrap();
    let mut scene = source.scene;
    scene.t_end = 1.0;
    scene.output.every = 0.5;
    let model = NFourBar::default();
    let columns = ["theta0", "theta0d", "xc0", "yc1"];
    check_with(&scene, &model, &["L"], &columns, fixed(Method::Rk4, 1e-3));
    let (mut problem, _): (Problem<NFourBar>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    problem.settings = fixed(Method::Rk4, 1e-4)(problem.settings);
    let params = parameters(&scene, &model, &["L"], problem.settings);
    let e = problem.sensitivities_with(&params).unwrap_err().to_string();
    assert!(e.contains("singular position") && e.contains("t = 0.714"), "{e}");
}

/// Every built-in scene on its own model, half a second of its motion
/// (DOP853 at 1e-13 on the DAE formulation), differentiated in its
/// model's first two parameters that are not family counts: to the same
/// 1e-8 as above, the stiff scenes (RADAU5's) included; a scene the
/// sensitivities refuse (events, a skate that slides) must say why by
/// name. Half a second:
/// `four-bar-n40` reaches its singular position at 0.72 s, which a
/// sensitivity run refuses, but only after crawling to it (23 s at the
/// command's 1e-11, minutes at 1e-13).
struct EveryScene {
    /// Scenes checked and scenes refused, with the refusal's text.
    checked: Vec<String>,
    refused: Vec<(String, String)>,
}

impl ezy_scene::registry::Register for EveryScene {
    fn register<M: Model + Default + 'static>(&mut self, key: &str) {
        for source in ezy::models::scenes::builtin() {
            let mut scene = source.scene;
            if scene.model != key {
                continue;
            }
            scene.t_end = scene.t_end.min(0.5);
            scene.output.every = scene.t_end;
            let model = M::default();
            let info = model.info();
            let names: Vec<&str> = info.params.iter().filter(|p| !p.count).map(|p| p.name).take(2).collect();
            let (mut problem, _): (Problem<M>, _) = scene.problem_with(model.clone(), &[]).unwrap();
            // a stiff scene (RADAU5's) too, by DOP853 at 1e-13 like the
            // rest (its sensitivities: `four-bar-stiff` 390,000 steps, 8 s;
            // `snake-stiff` 92,000 steps, 16 s). They were skipped while
            // the stiff four-bar's were 2.2e-7 of the largest off in its
            // crank (its coupler's force differenced in `a`: see
            // `the_stiff_four_bar_s_sensitivities_...`)
            problem.settings = tight(problem.settings);
            let params = parameters(&scene, &model, &names, problem.settings);
            match problem.sensitivities_with(&params) {
                Ok(s) => {
                    // the coordinates at the scene's counts (a family's
                    // default model has fewer)
                    let coords = problem.model.info().coords;
                    let columns: Vec<&str> = coords.iter().map(String::as_str).collect();
                    compare(&scene, &params, &s, &columns);
                    self.checked.push(scene.name.clone());
                }
                Err(e) => self.refused.push((scene.name.clone(), e.to_string())),
            }
        }
    }
}

#[test]
#[ignore = "whole harness: every built-in scene (minutes)"]
fn every_built_in_scene_s_sensitivities_are_the_differences_of_whole_runs() {
    let mut every = EveryScene { checked: Vec::new(), refused: Vec::new() };
    ezy::models::register(&mut every);
    for (scene, why) in &every.refused {
        eprintln!("{scene}: refused: {why}");
        let named = ["event", "slid", "singular", "drive", "radau5", "reduced"].iter().any(|w| why.contains(w));
        assert!(named, "{scene}: refused without a reason named: {why}");
    }
    eprintln!("checked {} scenes: {:?}", every.checked.len(), every.checked);
    for stiff in ["four-bar-stiff", "snake-stiff"] {
        assert!(every.checked.iter().any(|s| s == stiff), "{stiff} not checked");
    }
    assert!(every.checked.len() >= 15, "only {} of the built-in scenes checked", every.checked.len());
}

/// A number left at its default of 0 is a parameter at 0: the four-bar's
/// spring-damper with `--set spring.damping=0` (a scene writes no damping
/// of 0, and `--wrt spring.damping` was refused as "not written in the
/// scene"). A negative damping cannot be built, so the sensitivity takes
/// the one-sided difference of its right-hand side, and the oracle the
/// one-sided differences of whole runs, `(-3 x(0) + 4 x(h) - x(2h)) / 2h`
/// (error `O(h^2)`) at `h` and `h / 2`, extrapolated (Richardson, factor
/// 4). Measured: 1.7e-8 of the largest off the one-sided difference
/// alone at `h = 1e-3`; with the extrapolation at the oracle's rounding.
#[test]
fn a_number_at_its_default_of_zero_is_a_parameter_at_zero() {
    let source = scenes::builtin().into_iter().find(|s| s.scene.name == "four-bar").unwrap();
    let mut scene = source.scene;
    scene.t_end = 0.1;
    scene.output.every = 0.1;
    let model = FourBar::default();
    let sets = [("spring.damping".to_string(), 0.0)];
    let p = scene.parameter(&model, &sets, "spring.damping").unwrap();
    assert_eq!(p.value, 0.0, "a damping set to 0 is a parameter at 0");
    let settings = tight(p.problem(0.0).unwrap().settings);
    let build = |v: f64| {
        let mut q = p.problem(v).unwrap();
        q.settings = settings;
        q
    };
    let s = build(0.0).sensitivities_with(std::slice::from_ref(&p)).unwrap();
    assert!(
        matches!(s.derivatives[0], ezy_core::sensitivity::Derivative::OneSided { .. }),
        "no problem at a negative damping: {:?}",
        s.derivatives[0]
    );
    let columns: Vec<String> = {
        let coords = model.info().coords;
        coords.iter().cloned().chain(coords.iter().map(|c| format!("{c}d"))).collect()
    };
    let end = |v: f64| -> Vec<f64> {
        let run = build(v).solve().unwrap();
        columns.iter().map(|c| *run.column(c).unwrap().last().unwrap()).collect()
    };
    let h = 1e-3;
    let (x0, x1, x2, x4) = (end(0.0), end(h / 2.0), end(h), end(2.0 * h));
    let got: Vec<f64> =
        columns.iter().map(|c| *s.column(&format!("d{c}/dspring.damping")).unwrap().last().unwrap()).collect();
    let largest = got.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1e-4, "the damping moves the linkage: largest sensitivity {largest:.1e}");
    let size = x0.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    let noise = 1e-12 * size / (h / 2.0);
    for (i, c) in columns.iter().enumerate() {
        let d1 = (-3.0 * x0[i] + 4.0 * x2[i] - x4[i]) / (2.0 * h);
        let d2 = (-3.0 * x0[i] + 4.0 * x1[i] - x2[i]) / h;
        let want = d2 + (d2 - d1) / 3.0;
        let change = (want - d2).abs();
        assert!(
            (got[i] - want).abs() <= 1e-8 * largest + 3.0 * change + noise,
            "four-bar, spring.damping = 0: d{c}/dspring.damping = {:.12e} against the one-sided differences' {want:.12e} ({:.1e} of the largest; the oracle's change {:.1e})",
            got[i],
            (got[i] - want).abs() / largest,
            change / largest
        );
    }
}

/// The reduced formulation's settings: `method` at the step `dt`, or
/// DOP853 at 1e-13 ([`tight`]'s) where `method` is adaptive.
fn reduced(method: Method, dt: f64) -> impl Fn(ezy_core::RunSettings) -> ezy_core::RunSettings {
    move |settings| ezy_core::RunSettings {
        formulation: ezy_core::Formulation::Reduced,
        ..if method == Method::Dop853 { tight(settings) } else { fixed(method, dt)(settings) }
    }
}

/// The reduced formulation's sensitivities are the derivatives of the
/// reduced run itself (its steps on the independent components, the
/// dependent ones recovered from the constraints, differentiated): the
/// differences of whole reduced runs are their oracle to the same 1e-8,
/// fixed steps and DOP853 at 1e-13 alike. On the EzyRoller's minimal
/// coordinates (body-frame speeds; `c` moves the geometry the expansion
/// solves) over 5 s, and on the text model with a drive (the numeric
/// partition, the drive's prescribed angle in `phi(q) = u(t)`).
#[test]
fn reduced_sensitivities_are_the_differences_of_whole_reduced_runs() {
    let mut scene = scenes::drive();
    scene.t_end = 5.0;
    scene.output.every = 5.0 / 3.0;
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (mut text, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    text.t_end = 5.0;
    text.output.every = 5.0 / 3.0;
    let text_columns = ["x", "y", "phi", "xd", "yd", "phid", "th"];
    // steps long enough that the discrete reduced run is not the
    // discrete DAE's: the DAE's sensitivities in their place failed here
    // (Euler's 3.4e-7 of the largest off on the EzyRoller, RK4's 3.6e-8
    // on the text model)
    for (method, dt) in [(Method::Euler, 1e-3), (Method::Rk4, 2e-2), (Method::Dop853, 0.0)] {
        check_with(&scene, &EzyRoller::default(), &["omega", "M0", "c", "m1"], &columns, reduced(method, dt));
        check_with(&text, &model, &["psi.omega", "drag.c", "m", "a"], &text_columns, reduced(method, dt));
    }
}

/// A reduced run that re-chooses its partition (the five-link snake's
/// first, between 10 and 20 s): `S_z` rewritten in the new partition from
/// the full `S_x`, the method restarted, and the sensitivities still the
/// differences of whole reduced runs to 1e-8 of the largest.
#[test]
fn reduced_sensitivities_follow_a_new_partition() {
    let mut scene = scenes::builtin().into_iter().find(|s| s.scene.name == "snake").unwrap().scene;
    scene.t_end = 20.0;
    scene.output.every = 10.0;
    let model = ezy::models::Snake::default();
    let (mut problem, _): (Problem<ezy::models::Snake>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    let settings = reduced(Method::Dop853, 0.0);
    let params = parameters(&scene, &model, &["l", "motor.torque.sin.amplitude"], settings(problem.settings));
    problem.settings = settings(problem.settings);
    let s = problem.sensitivities_with(&params).unwrap();
    assert_eq!(s.formulation, ezy_core::Formulation::Reduced);
    assert!(s.repartitions >= 1, "the snake's reduced run re-chooses its partition before 20 s");
    compare(&scene, &params, &s, &["x1", "y1", "phi1", "phi3", "x5d", "phi5d"]);
}
