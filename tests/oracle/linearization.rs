//! A linearization's `A = df/dx` (`ezy linearize`,
//! `Analysis::linearize`: dual numbers through the generated code, the
//! laws' exact Jacobians and the KKT system differentiated) against
//! central differences of the right-hand side `f(t, x) = [qd, qdd]`
//! itself (`Analysis::rhs`, one KKT solve per state, no derivative code),
//! column by column at `x +- h e_j` and `x +- h/2 e_j`, extrapolated
//! (Richardson): every entry to 1e-8 of the largest entry of `A` plus
//! three times the extrapolation's change (the oracle's own error, which
//! must stay below 1e-6 of it), at a state a run reached.

use ezy::models::{EzyRoller, FourBar, scenes};
use ezy_core::Model;
use ezy_core::problem::Problem;
use ezy_core::text::RuntimeModel;
use ezy_scene::Scene;

/// Checks `A` of `scene` on `model` at the state its run reaches at `t`.
fn check<M: Model>(scene: &Scene, model: &M, t: f64) {
    let (problem, _): (Problem<M>, _) = scene.problem_with(model.clone(), &[]).unwrap();
    let end = problem.clone().t_end(t).every(t).solve().unwrap();
    let (mut an, x0) = problem.analysis().unwrap();
    let x = end.final_state()[..x0.len()].to_vec();
    let a = an.linearize(t, &x, &[]).unwrap().a;
    let n = x.len();
    let largest = (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).fold(0.0f64, |m, (i, j)| m.max(a[(i, j)].abs()));
    let mut worst = 0.0f64;
    for j in 0..n {
        let column = |an: &mut ezy_core::analysis::Analysis<M>, h: f64| {
            let (mut p, mut m) = (x.clone(), x.clone());
            p[j] += h;
            m[j] -= h;
            let (fp, fm) = (an.rhs(t, &p).unwrap(), an.rhs(t, &m).unwrap());
            fp.iter().zip(&fm).map(|(a, b)| (a - b) / (2.0 * h)).collect::<Vec<_>>()
        };
        let h = 1e-4 * x[j].abs().max(1.0);
        let (d1, d2) = (column(&mut an, h), column(&mut an, h / 2.0));
        for i in 0..n {
            let want = d2[i] + (d2[i] - d1[i]) / 3.0;
            let oracle = (want - d2[i]).abs();
            assert!(
                oracle <= 1e-6 * largest,
                "{}: A[{i}][{j}]: the differences did not settle ({oracle:.1e})",
                scene.name
            );
            let off = (a[(i, j)] - want).abs();
            worst = worst.max(off / largest);
            assert!(
                off <= 1e-8 * largest + 3.0 * oracle,
                "{}: A[{i}][{j}] = {:.12e} against the differences' {want:.12e} ({:.1e} of the largest)",
                scene.name,
                a[(i, j)],
                off / largest
            );
        }
    }
    eprintln!("{}: A ({n} x {n}) at t = {t} s within {worst:.1e} of its largest entry ({largest:.3e})", scene.name);
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
