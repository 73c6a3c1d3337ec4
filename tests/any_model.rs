//! `AnyModel`, the model behind one table that every command of the `ezy`
//! crate runs (so that a crate with a model of its own compiles only the
//! model's functions), against the model it holds: the same numbers bit
//! for bit on every path of the step loop (the fused right-hand side on
//! the minimal coordinates with hinge torques and with other effects, the
//! DAE's dense and sparse KKT paths, skates that slip, RADAU5's Newton
//! iteration), the dual-number entries the derivative checks take, and
//! the applied forces' error handed back as it was returned.

use ezy_core::model::MinimalRhsError;
use ezy_core::{AnyModel, Formulation, Method, Model, Solution};
use ezy_models::{ElasticFourBar, EzyRoller, Snake, scenes};
use num_dual::Dual64;

/// `scene` on `model` with its own settings, `method` and `formulation`
/// when given, to `t_end` when given.
fn solve<M: Model>(
    model: M,
    scene: &str,
    method: Option<Method>,
    formulation: Option<Formulation>,
    t_end: Option<f64>,
) -> Solution {
    let (mut p, _) = scenes::get(scene).problem_with(model, &[]).unwrap();
    if let Some(m) = method {
        p = p.method(m);
    }
    if let Some(f) = formulation {
        p = p.formulation(f);
    }
    if let Some(t) = t_end {
        p = p.t_end(t);
    }
    p.solve().unwrap()
}

/// The run of `scene` on `M` and on `AnyModel::new(M)`: every sample,
/// energy and counter alike, bit for bit (`==` on `f64` compares bits
/// here: the runs have no NaN).
type Counted = (u64, u64, u64, u64, Formulation, bool, bool);

fn same<M: Model + Default>(
    scene: &str,
    method: Option<Method>,
    formulation: Option<Formulation>,
    t_end: Option<f64>,
) -> Counted {
    let a = solve(M::default(), scene, method, formulation, t_end);
    let b = solve(AnyModel::new(M::default()), scene, method, formulation, t_end);
    assert!(a.t.len() > 2, "{scene}: {} samples", a.t.len());
    assert_eq!(a.t, b.t, "{scene}: times");
    assert_eq!(a.y, b.y, "{scene}: states");
    assert_eq!(a.kinetic_energy, b.kinetic_energy, "{scene}: kinetic energy");
    let counted = |s: &ezy_core::Summary| {
        (s.steps, s.rejected, s.counters.rhs_evals, s.projections, s.formulation, s.minimal_coordinates, s.fused_rhs)
    };
    assert_eq!(counted(&a.summary), counted(&b.summary), "{scene}: counters and the path taken");
    counted(&a.summary)
}

#[test]
fn every_path_of_the_step_loop_gives_the_held_models_numbers() {
    // the fused right-hand side, the motor handed over as a hinge torque
    let fused = same::<EzyRoller>("drive", Some(Method::Dop853), Some(Formulation::Auto), Some(5.0));
    assert!(fused.5 && fused.6, "drive: {fused:?}");
    // the fused right-hand side with effects that are not hinge torques
    let fused = same::<EzyRoller>("drive-rolling-resistance", Some(Method::Dop853), Some(Formulation::Auto), Some(5.0));
    assert!(fused.6, "drive-rolling-resistance: {fused:?}");
    // the DAE on the dense, unrolled KKT kernels, with projection
    let dae = same::<EzyRoller>("drive", Some(Method::Dopri5), Some(Formulation::Dae), Some(5.0));
    assert!(dae.3 > 0 && dae.4 == Formulation::Dae, "drive as a DAE: {dae:?}");
    // a family: the sparse KKT path
    same::<Snake>("snake", None, None, Some(2.0));
    // skates that slip: releasable rows, located events
    same::<EzyRoller>("drive-slip", None, None, Some(2.0));
    // RADAU5's Newton iteration on the KKT system
    same::<ElasticFourBar>("four-bar-stiff", Some(Method::Radau5), None, Some(0.2));
}

#[test]
fn the_dual_number_entries_give_the_held_models_derivatives() {
    let (m, any) = (EzyRoller::default(), AnyModel::new(EzyRoller::default()));
    let info = m.info();
    let (nq, nc, nnz) = (info.nq(), info.nc(), info.pattern.len());
    let q: Vec<Dual64> = (0..nq).map(|i| Dual64::new(0.3 + 0.7 * i as f64, if i == 2 { 1.0 } else { 0.0 })).collect();
    let qd: Vec<Dual64> = (0..nq).map(|i| Dual64::new(0.5 - 0.2 * i as f64, 0.1 * i as f64)).collect();
    let parts = |d: &[Dual64]| d.iter().map(|x| (x.re, x.eps)).collect::<Vec<_>>();
    let terms = |model: &dyn Fn(&mut [Dual64], &mut [Dual64])| {
        let (mut g, mut gamma) = (vec![Dual64::new(0.0, 0.0); nnz], vec![Dual64::new(0.0, 0.0); nc]);
        model(&mut g, &mut gamma);
        (parts(&g), parts(&gamma))
    };
    let direct = terms(&|g, gamma| m.constraint_terms(&q, &qd, g, gamma));
    let through = terms(&|g, gamma| any.constraint_terms(&q, &qd, g, gamma));
    assert!(direct.1.iter().any(|&(_, eps)| eps != 0.0), "gamma depends on phi: {direct:?}");
    assert_eq!(direct, through);
    let points = |model: &dyn Fn(&mut [Dual64])| {
        let mut out = vec![Dual64::new(0.0, 0.0); 2 * info.points.len()];
        model(&mut out);
        parts(&out)
    };
    assert_eq!(points(&|o| m.points(&q, o)), points(&|o| any.points(&q, o)));
    // and the f64 entry of the same generic method
    let (mut a, mut b) = (vec![0.0; 2 * info.points.len()], vec![0.0; 2 * info.points.len()]);
    let qr: Vec<f64> = q.iter().map(|x| x.re).collect();
    m.points(&qr, &mut a);
    any.points(&qr, &mut b);
    assert_eq!(a, b);
}

#[test]
fn the_applied_forces_error_comes_back_as_it_was_returned() {
    let any = AnyModel::new(EzyRoller::default());
    let k = any.minimal_constants().expect("the EzyRoller has a fused right-hand side");
    let info = any.info();
    let layout = any.minimal_layout().unwrap();
    let nz = layout.coords.len() + layout.speeds.len();
    let z = vec![0.1; nz];
    let (mut q, mut qd, mut dz) = (vec![0.0; info.nq()], vec![0.0; info.nq()], vec![0.0; nz]);
    let res = any.minimal_rhs(&k, &z, &mut q, &mut qd, &mut dz, |_, _, _, _| Err("the law failed"));
    assert_eq!(res, Err(MinimalRhsError::Forces("the law failed")));
    let (mut q2, mut qd2, mut dz2) = (vec![0.0; info.nq()], vec![0.0; info.nq()], vec![0.0; nz]);
    let res = any.minimal_rhs(&k, &z, &mut q2, &mut qd2, &mut dz2, |_, _, f, _| {
        f[0] = 1.0;
        Ok::<(), ()>(())
    });
    assert_eq!(res, Ok(()));
    let m = EzyRoller::default();
    let (mut q3, mut qd3, mut dz3) = (vec![0.0; info.nq()], vec![0.0; info.nq()], vec![0.0; nz]);
    m.minimal_rhs(&k, &z, &mut q3, &mut qd3, &mut dz3, |_, _, f, _| {
        f[0] = 1.0;
        Ok::<(), ()>(())
    })
    .unwrap();
    assert_eq!((q2, qd2, dz2), (q3, qd3, dz3));
}
