//! A linearization's `A = df/dx` and `B = df/du` (`ezy linearize`,
//! `Analysis::linearize`: dual numbers through the generated code, the
//! laws' exact Jacobians and the KKT system differentiated) against
//! central differences of the right-hand side `f(t, x) = [qd, qdd]`
//! itself (`Analysis::rhs`, one KKT solve per state, no derivative code).
//!
//! `A`: column by column at `x +- h e_j` and `x +- h/2 e_j`, extrapolated
//! (Richardson): every entry to 1e-8 of the largest entry of `A` plus
//! three times the extrapolation's change (the oracle's own error, which
//! must stay below 1e-6 of it), at a state a run reached; on four scenes
//! in CI and on every built-in scene in the whole harness, where a scene
//! the linearization refuses must be refused by name, for the reason the
//! oracle sees at that state itself.
//!
//! `B`: the input put into the problem as a force of its own and the
//! right-hand side differenced in it: a hinge's torque pair `tau_H` as a
//! `hinge-motor` effect of constant torque `+-u` added to the scene (the
//! convention `B`'s columns state), an effect's scale `scale_E` as the
//! effect's coefficients multiplied by `1 +- u` through `--set`'s names.
//! The force enters `qdd` linearly, so the differences are exact to
//! rounding (their Richardson change is asserted below 1e-10 of `B`).

use ezy::models::{EzyRoller, FourBar, scenes};
use ezy_core::Model;
use ezy_core::analysis::{Analysis, Input};
use ezy_core::effects::{HingeMotor, Waveform};
use ezy_core::faer::Mat;
use ezy_core::problem::Problem;
use ezy_core::text::RuntimeModel;
use ezy_scene::registry::Register;
use ezy_scene::{Scene, SceneEffect};

use crate::analysis::{ezy, fresh, table};

/// The oracle's `A` at `(t, x)`: Richardson's extrapolation of central
/// differences of `an.rhs` at `h = 1e-4 max(1, |x_j|)` and `h/2`, and
/// the differences at `h/2` alone (their gap is the extrapolation's
/// change, the oracle's own error), column by column: every `stride`-th
/// column and the last (the others left 0).
pub(super) fn differences<M: Model>(an: &mut Analysis<M>, t: f64, x: &[f64], stride: usize) -> (Mat<f64>, Mat<f64>) {
    let n = x.len();
    let (mut want, mut half) = (Mat::<f64>::zeros(n, n), Mat::<f64>::zeros(n, n));
    for j in (0..n).filter(|j| j % stride == 0 || j + 1 == n) {
        let mut column = |h: f64| {
            let (mut p, mut m) = (x.to_vec(), x.to_vec());
            p[j] += h;
            m[j] -= h;
            let (fp, fm) = (an.rhs(t, &p).unwrap(), an.rhs(t, &m).unwrap());
            fp.iter().zip(&fm).map(|(a, b)| (a - b) / (2.0 * h)).collect::<Vec<_>>()
        };
        let h = 1e-4 * x[j].abs().max(1.0);
        let (d1, d2) = (column(h), column(h / 2.0));
        for i in 0..n {
            want[(i, j)] = d2[i] + (d2[i] - d1[i]) / 3.0;
            half[(i, j)] = d2[i];
        }
    }
    (want, half)
}

/// Checks `a` against the oracle's differences at `(t, x)` of scene
/// `name`: every entry to 1e-8 of the largest entry of `a` plus three
/// times the extrapolation's change, which must stay below 1e-6 of it;
/// of a state above 200 components (`four-bar-n40`'s 486: its 40 loops
/// alike) every column of about 60 spread over it, each a KKT solve of
/// the whole model four times. Returns the worst deviation relative to
/// the largest entry.
fn check_a<M: Model>(an: &mut Analysis<M>, name: &str, t: f64, x: &[f64], a: &Mat<f64>) -> f64 {
    let n = x.len();
    let largest = a.norm_max();
    let stride = if n > 200 { n.div_ceil(60) } else { 1 };
    let (want, half) = differences(an, t, x, stride);
    let mut worst = 0.0f64;
    for j in (0..n).filter(|j| j % stride == 0 || j + 1 == n) {
        for i in 0..n {
            let oracle = (want[(i, j)] - half[(i, j)]).abs();
            assert!(oracle <= 1e-6 * largest, "{name}: A[{i}][{j}]: the differences did not settle ({oracle:.1e})");
            let off = (a[(i, j)] - want[(i, j)]).abs();
            worst = worst.max(off / largest);
            assert!(
                off <= 1e-8 * largest + 3.0 * oracle,
                "{name}: A[{i}][{j}] = {:.12e} against the differences' {:.12e} ({:.1e} of the largest)",
                a[(i, j)],
                want[(i, j)],
                off / largest
            );
        }
    }
    let columns = if stride == 1 { String::new() } else { format!(", every {stride}th column") };
    eprintln!("{name}: A ({n} x {n}{columns}) at t = {t} s within {worst:.1e} of its largest entry ({largest:.3e})");
    worst
}

/// The state the run of `scene` on `model` reaches at `t` (the scene's
/// own integrator), and the scene's analysis.
fn reached<M: Model>(scene: &Scene, model: &M, t: f64) -> (Analysis<M>, Vec<f64>) {
    let (problem, _): (Problem<M>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    let (an, x0) = problem.clone().analysis().unwrap();
    if t == 0.0 {
        return (an, x0);
    }
    let end = problem.t_end(t).every(t).solve().unwrap();
    let x = end.final_state()[..x0.len()].to_vec();
    (an, x)
}

/// Checks `A` of `scene` on `model` at the state its run reaches at `t`.
fn check<M: Model>(scene: &Scene, model: &M, t: f64) {
    let (mut an, x) = reached(scene, model, t);
    let a = an.linearize(t, &x, &[]).unwrap().a;
    check_a(&mut an, &scene.name, t, &x, &a);
}

/// The EzyRoller under its motor, with and without rolling resistance;
/// the four-bar (a closed loop, a spring-damper); a user's sleigh with a
/// prescribed rotor typed as text (a rheonomic constraint).
#[test]
fn a_linearization_is_the_differences_of_the_right_hand_side() {
    check(&scenes::get("drive"), &EzyRoller::default(), 1.0);
    check(&scenes::get("drive-rolling-resistance"), &EzyRoller::default(), 3.0);
    check(&scenes::get("four-bar"), &FourBar::default(), 1.0);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (scene, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    check(&scene, &model, 2.0);
}

/// The time at which every built-in scene is linearized \[s\]: early in
/// its run, the motion under way.
const EVERY_SCENE_AT: f64 = 0.5;

/// The skates whose lateral slip velocity at `x` is not zero (beyond 1e-6
/// of the velocities' size: a run's holding skate keeps its row to its
/// tolerance), by name with the velocity: the oracle's own view of a
/// slide, from the skates' rows of the velocity constraints `G qd`.
fn sliding<M: Model>(an: &Analysis<M>, t: f64, x: &[f64]) -> Vec<(String, f64)> {
    let info = &an.dynamics().info;
    let r = an.constraint_residual(t, x).unwrap();
    let nq = x.len() / 2;
    let scale = x[nq..].iter().fold(1.0f64, |m, v| m.max(v.abs()));
    info.skates
        .iter()
        .map(|s| (s.name.clone(), r[info.n_holonomic + s.row]))
        .filter(|(_, v)| v.abs() > 1e-6 * scale)
        .collect()
}

/// Linearizes `scene` at the state its run reaches at [`EVERY_SCENE_AT`]
/// and checks `A`; where a skate slides there (the oracle's view,
/// [`sliding`]), the linearization must refuse, naming that skate, its
/// slip velocity (to the 4 digits printed) and its friction effect; then
/// the scene's start is tried ([`at_start`]). Any other refusal fails.
fn linearized_or_refused<M: Model>(scene: &Scene, model: &M) -> String {
    let t = EVERY_SCENE_AT;
    let (mut an, x) = reached(scene, model, t);
    let slides = sliding(&an, t, &x);
    match an.linearize(t, &x, &[]) {
        Ok(lin) => {
            assert!(slides.is_empty(), "{}: linearized at t = {t} s where skates slide: {slides:?}", scene.name);
            let worst = check_a(&mut an, &scene.name, t, &x, &lin.a);
            format!("{}: {} x {} within {worst:.1e}", scene.name, x.len(), x.len())
        }
        Err(e) => {
            let said = e.to_string();
            let Some((skate, v)) = slides.first() else {
                panic!("{}: refused at t = {t} s, where no skate slides: {said}", scene.name)
            };
            // the friction effect on that skate, as the scene expanded it
            let sys = an.dynamics();
            let friction = sys.friction.iter().find(|f| f.name == *skate).map(|f| &sys.effects[f.effect].name);
            let friction =
                friction.unwrap_or_else(|| panic!("{}: skate `{skate}` slides without friction", scene.name));
            let named = said.contains(&format!("skate `{skate}` slides on the state linearized"))
                && said.contains(&format!("(effect `{friction}`)"));
            let speed = said.split("lateral slip velocity is ").nth(1).and_then(|s| s.split(' ').next());
            let speed: f64 = speed.and_then(|s| s.parse().ok()).unwrap_or(f64::NAN);
            assert!(named && (speed - v).abs() <= 1e-3 * v.abs(), "{}: {said} (the oracle: {slides:?})", scene.name);
            let at_start = at_start(scene, model);
            format!("{}: refused at {t} s (skate `{skate}` slides, {v:.4} m/s); {at_start}", scene.name)
        }
    }
}

/// `A` of a scene refused at [`EVERY_SCENE_AT`], at its start (at rest,
/// no skate slides): checked where the linearization accepts it; where
/// it refuses, the refusal must name a skate with friction that cannot
/// hold there and its friction effect (the lateral force the skate would
/// need is past `mu N` from the start: `snake-slip`).
fn at_start<M: Model>(scene: &Scene, model: &M) -> String {
    let (mut an, x0) = reached(scene, model, 0.0);
    assert!(sliding(&an, 0.0, &x0).is_empty(), "{}: slides at its start", scene.name);
    match an.linearize(0.0, &x0, &[]) {
        Ok(lin) => format!("at 0 s within {:.1e}", check_a(&mut an, &scene.name, 0.0, &x0, &lin.a)),
        Err(e) => {
            let said = e.to_string();
            let sys = an.dynamics();
            let named = sys.friction.iter().any(|f| {
                said.contains(&format!("skate `{}` slides on the state linearized: holding it takes", f.name))
                    && said.contains(&format!("(effect `{}`)", sys.effects[f.effect].name))
            });
            assert!(named, "{}: refused at its start without naming a skate with friction: {said}", scene.name);
            format!("at 0 s refused too: {said}")
        }
    }
}

/// A [`Register`] that runs [`linearized_or_refused`] on the model type
/// registered under the scene's model key (the dispatch `ezy` itself
/// builds from `ezy::models::register`, so a new built-in model is
/// covered as it is added).
struct OnItsModel<'a> {
    scene: &'a Scene,
    said: Option<String>,
}

impl Register for OnItsModel<'_> {
    fn register<M: Model + Default + 'static>(&mut self, key: &str) {
        if key == self.scene.model {
            self.said = Some(linearized_or_refused(self.scene, &M::default()));
        }
    }
}

/// Every built-in scene (`models/scenes/*.toml`) on its model,
/// linearized at the state its run reaches at 0.5 s: `A` against the
/// differences; a scene refused there (`snake-slip`: a skate slides) by
/// name, for the slide the oracle sees, and tried at its start (refused
/// there too, by name: its skates cannot hold from the start). The 486 x
/// 486 `A` of `four-bar-n40` takes most of the time.
#[test]
#[ignore = "whole harness: every built-in scene linearized"]
fn every_built_in_scene_is_linearized_or_refused_by_name() {
    let mut said = Vec::new();
    for src in scenes::builtin() {
        let mut on = OnItsModel { scene: &src.scene, said: None };
        ezy::models::register(&mut on);
        said.push(on.said.unwrap_or_else(|| panic!("{}: no built-in model `{}`", src.scene.name, src.scene.model)));
    }
    assert_eq!(said.len(), scenes::BUILTIN.len());
    eprintln!("{}", said.join("\n"));
}

/// An input of the linearization and how the oracle puts it into the
/// problem: a hinge's torque as a `hinge-motor` effect of its own, an
/// effect's scale by the coefficients its force is proportional to.
enum Probe {
    /// `tau_<hinge>`.
    Torque(&'static str),
    /// `scale_<effect>`, the effect's coefficients (names as for `--set`).
    Scale(&'static str, &'static [&'static str]),
}

impl Probe {
    fn input(&self) -> Input {
        match self {
            Probe::Torque(h) => Input::HingeTorque((*h).into()),
            Probe::Scale(e, _) => Input::EffectScale((*e).into()),
        }
    }

    /// The right-hand side at `(t, x)` of `scene` on `model` with the
    /// input at `u`, built as a problem of its own.
    fn rhs<M: Model>(&self, scene: &Scene, model: &M, t: f64, x: &[f64], u: f64) -> Vec<f64> {
        let mut scene = scene.clone();
        let mut sets = Vec::new();
        match self {
            Probe::Torque(h) => scene.effects.push((
                "oracle_probe".into(),
                SceneEffect::Builtin(ezy_core::EffectSpec::HingeMotor(HingeMotor {
                    hinge: (*h).into(),
                    torque: Waveform::Constant(u),
                })),
            )),
            Probe::Scale(_, coefficients) => {
                for c in *coefficients {
                    let v = scene.parameter(model, &[], c).unwrap().value;
                    sets.push(((*c).to_string(), v * (1.0 + u)));
                }
            }
        }
        let (problem, _): (Problem<M>, _) = scene.problem_with(model.clone(), &sets).unwrap();
        problem.analysis().unwrap().0.rhs(t, x).unwrap()
    }
}

/// Checks `b` (2nq x inputs, the columns in the order of `probes`) of
/// `scene` on `model` at `(t, x)`: each column against central
/// differences of the right-hand side in the input put into the problem
/// ([`Probe`]) at `u = +-1` and `+-1/2`, extrapolated: to 1e-8 of `B`'s
/// largest entry plus three times the change, which must stay below 1e-10
/// of it (the force enters linearly: the differences are exact to
/// rounding). Returns the worst deviation relative to the largest entry.
fn check_b<M: Model>(scene: &Scene, model: &M, t: f64, x: &[f64], b: &Mat<f64>, probes: &[Probe]) -> f64 {
    let n = x.len();
    let mut want = Mat::<f64>::zeros(n, probes.len());
    let mut change = Mat::<f64>::zeros(n, probes.len());
    for (k, p) in probes.iter().enumerate() {
        let column = |u: f64| {
            let (fp, fm) = (p.rhs(scene, model, t, x, u), p.rhs(scene, model, t, x, -u));
            fp.iter().zip(&fm).map(|(a, b)| (a - b) / (2.0 * u)).collect::<Vec<_>>()
        };
        let (d1, d2) = (column(1.0), column(0.5));
        for i in 0..n {
            want[(i, k)] = d2[i] + (d2[i] - d1[i]) / 3.0;
            change[(i, k)] = (want[(i, k)] - d2[i]).abs();
        }
    }
    let largest = b.norm_max().max(want.norm_max());
    assert!(largest > 0.0, "{}: B and the differences are zero", scene.name);
    let mut worst = 0.0f64;
    for k in 0..probes.len() {
        let name = probes[k].input().name();
        for i in 0..n {
            let oracle = change[(i, k)];
            assert!(oracle <= 1e-10 * largest, "{}: B[{i}][{name}]: the differences did not settle", scene.name);
            let off = (b[(i, k)] - want[(i, k)]).abs();
            worst = worst.max(off / largest);
            assert!(
                off <= 1e-8 * largest + 3.0 * oracle,
                "{}: B[{i}][{name}] = {:.12e} against the differences' {:.12e}",
                scene.name,
                b[(i, k)],
                want[(i, k)]
            );
        }
    }
    let names: Vec<String> = probes.iter().map(|p| p.input().name()).collect();
    eprintln!(
        "{}: B ({}) at t = {t} s within {worst:.1e} of its largest entry ({largest:.3e})",
        scene.name,
        names.join(", ")
    );
    worst
}

/// `ezy linearize drive --at 1 --input tau_B`: `A.csv` and `B.csv` at the
/// state `state.csv` names, against the differences there; `B`'s column
/// is the hinge motor's torque pair's (a unit of `tau_B` moves the state
/// as a unit of the scene's own motor does).
#[test]
fn a_linearizations_input_matrix_is_the_differences_in_the_input() {
    let dir = fresh("oracle-linearize-b");
    let (out, err, ok) = ezy(&["linearize", "drive", "--at", "1", "--input", "tau_B"], &dir);
    assert!(ok, "{out}{err}");
    let matrix = |file: &str| {
        let (head, rows) = table(&dir.join(file));
        Mat::from_fn(rows.len(), head.len() - 1, |i, j| rows[i][j + 1].parse::<f64>().unwrap())
    };
    let (a, b) = (matrix("A.csv"), matrix("B.csv"));
    let (_, state) = table(&dir.join("state.csv"));
    let x: Vec<f64> = state.iter().map(|r| r[1].parse().unwrap()).collect();
    let scene = scenes::get("drive");
    let model = EzyRoller::default();
    let (problem, _): (Problem<EzyRoller>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    let mut an = problem.analysis().unwrap().0;
    check_a(&mut an, "drive (ezy linearize)", 1.0, &x, &a);
    check_b(&scene, &model, 1.0, &x, &b, &[Probe::Torque("B")]);
}

/// `B` of `scene` on `model` at the state its run reaches at `t`, with
/// the inputs of `probes`, checked ([`check_b`]).
fn b_at<M: Model>(scene: &Scene, model: &M, t: f64, probes: &[Probe]) -> Mat<f64> {
    let (mut an, x) = reached(scene, model, t);
    let inputs: Vec<Input> = probes.iter().map(Probe::input).collect();
    let b = an.linearize(t, &x, &inputs).unwrap().b;
    check_b(scene, model, t, &x, &b, probes);
    b
}

/// `B` through the library on the EzyRoller with rolling resistance (the
/// motor's hinge torque, a skate's resistance scaled), on a user's
/// sleigh with a torque-driven rotor (`tau_H`, the drag scaled) and on
/// one whose rotor's angle is prescribed (`tau_H` is then taken up by the
/// drive: its column is 0 to rounding, and so are the differences; the
/// drag scaled).
#[test]
#[ignore = "whole harness: B on three scenes"]
fn every_input_matrix_is_the_differences_in_its_inputs() {
    let probes = [Probe::Torque("B"), Probe::Scale("rolling_A", &["rolling_A.damping"])];
    b_at(&scenes::get("drive-rolling-resistance"), &EzyRoller::default(), 3.0, &probes);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let text = |file: &str| RuntimeModel::from_file(&data.join(file)).unwrap();
    let probes = [Probe::Torque("H"), Probe::Scale("drag", &["drag.c", "drag.c_rot"])];
    let (sleigh, _) = Scene::read(&data.join("rotor-sleigh.toml")).unwrap();
    let b = b_at(&sleigh, &text("rotor_sleigh.ezy"), 2.0, &probes);
    assert!(b.col(0).norm_max() > 0.1 * b.norm_max(), "a free rotor's torque moves the sleigh: {b:?}");
    let (drive, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    let b = b_at(&drive, &text("rotor_drive.ezy"), 2.0, &probes);
    assert!(b.col(0).norm_max() <= 1e-12 * b.norm_max(), "a prescribed hinge's torque moves nothing: {b:?}");
}
