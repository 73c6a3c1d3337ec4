//! The three KKT paths (dense Schur, dense LU, sparse Schur) give the same
//! accelerations and multipliers at random states (EzyRoller, sleigh, the
//! snake family for 2 to 50 links), the same trajectory over a second of
//! `drive`, and the sparse projection the dense one's state.

use crate::common;

use common::build;
use common::{random_model, random_state, random_state_n, rng};
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, ProjectionKind, RunSettings, simulate};
use ezy_models::{ChaplyginSleigh, EzyRoller, scenes};

/// Dense Schur, dense LU and sparse Schur at the state `(q, qd)` of `m`:
/// `dy` and `lambda` agree to 1e-12 relative to the largest entry
/// (`context` names the case in a failure).
fn three_paths_agree<M: Model>(m: &M, q: &[f64], qd: &[f64], context: &str) {
    let mut y = q.to_vec();
    y.extend_from_slice(qd);
    let mut out = Vec::new();
    for method in [KktMethod::Schur, KktMethod::Lu, KktMethod::Sparse] {
        let mut sys = Dynamics::new(m.clone(), vec![], method);
        let mut dy = vec![0.0; y.len()];
        sys.rhs(0.0, &y, &mut dy).unwrap();
        out.push((sys.kkt_name(), dy, sys.lambda().to_vec()));
    }
    assert_eq!((out[0].0, out[1].0, out[2].0), ("schur-cholesky", "dense-lu", "sparse-cholesky"));
    let scale = out[0].1.iter().chain(&out[0].2).fold(1.0f64, |a, v| a.max(v.abs()));
    for (name, dy, lambda) in &out[1..] {
        for (a, b) in dy.iter().chain(lambda).zip(out[0].1.iter().chain(&out[0].2)) {
            assert!((a - b).abs() <= 1e-12 * scale, "{context}, {name}: {a} vs {b} (scale {scale:e})");
        }
    }
}

/// The three paths agree at 100 random states and parameter sets.
fn paths_agree<M: Model + Default>(seed: u64) {
    let mut r = rng(seed);
    let name = M::default().info().name;
    for s in 0..100 {
        let m: M = random_model(&mut r);
        let (q, qd) = random_state::<M>(&mut r);
        three_paths_agree(&m, &q, &qd, &format!("{name} state {s}"));
    }
}

/// Sparse and dense paths on the snake family for N = 2 ... 50 links
/// (nc = 3N - 2 = 4 ... 148 rows): five random states each (as
/// `random_state`), agreement to 1e-12 relative to the largest entry of
/// `dy` and `lambda`.
#[test]
fn snake_paths_agree_for_2_to_50_links() {
    let mut r = rng(31);
    for n in 2..=50 {
        let m = ezy_models::Snake { N: n, ..Default::default() };
        for s in 0..5 {
            let (q, qd) = random_state_n(3 * n, &mut r);
            three_paths_agree(&m, &q, &qd, &format!("N = {n} state {s}"));
        }
    }
}

#[test]
fn ezyroller_paths_agree() {
    paths_agree::<EzyRoller>(11);
}

#[test]
fn sleigh_paths_agree() {
    paths_agree::<ChaplyginSleigh>(12);
}

/// One second of `drive` (RK4, h = 1e-4, projected) on the sparse path ends
/// within 1e-12 of the dense Schur path.
#[test]
fn drive_on_the_sparse_path_matches_the_dense_one() {
    let scene = scenes::drive();
    let mut finals = Vec::new();
    for method in [KktMethod::Schur, KktMethod::Sparse] {
        let (mut sys, y0) = build::<EzyRoller>(&scene, &[], method).unwrap();
        let settings = RunSettings {
            dt: 1e-4,
            t_end: 1.0,
            every: 1.0,
            projection: ProjectionKind::MassWeighted,
            method: ezy_core::Method::Rk4,
            formulation: ezy_core::Formulation::Dae,
            rtol: 1e-9,
            atol: 1e-9,
            balance_limit: None,
            max_steps: None,
        };
        let s = simulate(&mut sys, &y0, &settings, &mut common::Recorder::default()).unwrap();
        assert_eq!(s.kkt, if method == KktMethod::Sparse { "sparse-cholesky" } else { "schur-cholesky" });
        finals.push(s.final_state);
    }
    for (a, b) in finals[0].iter().zip(&finals[1]) {
        assert!((a - b).abs() <= 1e-12, "{a} vs {b}");
    }
}

/// The sparse normal systems of the projection give the dense path's
/// projected state for every model at perturbed random states (positions
/// 1e-3 off the constraints, velocities 1e-2 off): to 1e-10, since both
/// stop Gauss-Newton once max|C| <= 1e-12 and may stop one rounding-level
/// step apart (measured up to 5e-12 on random snake configurations).
fn projections_agree<M: Model + Default>(seed: u64) {
    use ezy_core::formulation::projection::Projector;
    let mut r = rng(seed);
    let info = M::default().info();
    let nq = info.nq();
    for kind in [ProjectionKind::MassWeighted, ProjectionKind::Euclidean] {
        for s in 0..20 {
            let m: M = random_model(&mut r);
            let mut mass = vec![0.0; nq];
            m.mass_diagonal(&mut mass);
            let (q0, qd0) = random_state::<M>(&mut r);
            // a consistent state, then a perturbation
            let (mut q, mut qd) = (q0.clone(), qd0.clone());
            let mut dense = Projector::<M>::new_dense(&m, kind, &mass);
            assert_eq!(dense.path(), "normal-ldl");
            if dense.project(&m, 0.0, &mut q, &mut qd).is_err() {
                continue;
            }
            for (k, (a, b)) in q.iter_mut().zip(qd.iter_mut()).enumerate() {
                *a += 1e-3 * ((k as f64) * 0.7).sin();
                *b += 1e-2 * ((k as f64) * 1.3).cos();
            }
            let (mut qs, mut qds) = (q.clone(), qd.clone());
            let report = dense.project(&m, 0.0, &mut q, &mut qd).unwrap();
            let velocity = dense.velocity_residual(&m, 0.0, &qd);
            residuals_are_the_projections(&m, &q, &qd, report.residual_position, velocity);
            let mut sparse = Projector::<M>::new_sparse(&m, kind, &mass);
            assert_eq!(sparse.path(), "normal-sparse-cholesky");
            let report = sparse.project(&m, 0.0, &mut qs, &mut qds).unwrap();
            let velocity = sparse.velocity_residual(&m, 0.0, &qds);
            residuals_are_the_projections(&m, &qs, &qds, report.residual_position, velocity);
            for (a, b) in q.iter().chain(&qd).zip(qs.iter().chain(&qds)) {
                assert!((a - b).abs() <= 1e-10 * (1.0 + a.abs()), "{} {kind:?} state {s}: {a} vs {b}", info.name);
            }
            // the tangential part of an error estimate: C_q eq = 0 and
            // G eqd = 0 after, a second removal changes nothing (a
            // projector), and both paths agree
            let e0: Vec<f64> = (0..2 * nq).map(|k| 1e-6 * ((k as f64) * 2.1).cos()).collect();
            let (mut ed, mut es) = (e0.clone(), e0.clone());
            let (dq, dqd) = ed.split_at_mut(nq);
            dense.remove_normal(&m, 0.0, &q, dq, dqd).unwrap();
            let (sq, sqd) = es.split_at_mut(nq);
            sparse.remove_normal(&m, 0.0, &q, sq, sqd).unwrap();
            let mut g = vec![0.0; info.pattern.len()];
            m.constraint_matrix(&q, &mut g);
            let mut rows = vec![0.0; 2 * info.nc()];
            for (&(r, c), v) in info.pattern.iter().zip(&g) {
                if r < info.n_holonomic {
                    rows[r] += v * ed[c];
                }
                rows[info.nc() + r] += v * ed[nq + c];
            }
            let big = rows.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            assert!(big <= 1e-15, "{} {kind:?} state {s}: normal part left {big:e}", info.name);
            let mut twice = ed.clone();
            let (tq, tqd) = twice.split_at_mut(nq);
            dense.remove_normal(&m, 0.0, &q, tq, tqd).unwrap();
            for ((a, b), c) in ed.iter().zip(&twice).zip(&es) {
                assert!(
                    (a - b).abs() <= 1e-15 && (a - c).abs() <= 1e-15,
                    "{} {kind:?} state {s}: {a} {b} {c}",
                    info.name
                );
            }
        }
    }
}

/// The residuals a projection reports for the state it left (what the
/// step loop writes for a projected dense-output sample) are, to the bit,
/// `max|C(q)|` and `max|G(q) qd|` evaluated anew at that state.
fn residuals_are_the_projections<M: Model>(m: &M, q: &[f64], qd: &[f64], position: f64, velocity: f64) {
    let info = m.info();
    let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let mut phi = vec![0.0; info.n_holonomic];
    m.phi(q, &mut phi);
    let mut g = vec![0.0; info.pattern.len()];
    m.constraint_matrix(q, &mut g);
    let mut gqd = vec![0.0; info.nc()];
    for (&(r, c), v) in info.pattern.iter().zip(&g) {
        gqd[r] += v * qd[c];
    }
    assert_eq!(position.to_bits(), max_abs(&phi).to_bits(), "{}: max|C| {position} vs {}", info.name, max_abs(&phi));
    // G qd summed in another order here: equal to rounding
    assert!((velocity - max_abs(&gqd)).abs() <= 1e-15 * (1.0 + max_abs(qd)), "{}: max|G qd| {velocity}", info.name);
}

#[test]
fn sparse_projection_agrees_with_the_dense_one() {
    projections_agree::<EzyRoller>(21);
    projections_agree::<ezy_models::Snake>(22);
    projections_agree::<ezy_models::Trailer>(23);
}

/// Consistent initial values on the dense path (SVD) and the sparse path
/// (normal equations by sparse Cholesky, refined) of
/// `ezy_core::formulation::initial::consistent_state_with` agree to 1e-12 m (1e-12
/// m/s relative to the largest velocity), for given values that determine
/// the rest and for given values that violate the constraints (the
/// minimum-norm projection, 1e-10: a nonlinear iteration that both paths
/// take with the same steps to rounding); both report the same corrections.
fn initial_paths_agree<M: Model>(
    m: &M,
    drives: &[ezy_core::drive::Drive],
    q: &[(usize, f64)],
    qd: &[(usize, f64)],
    tol: f64,
) {
    use ezy_core::formulation::initial::{Given, consistent_state_with};
    let name = m.info().name;
    let given = Given { q: q.to_vec(), qd: qd.to_vec(), ..Given::default() };
    let (qa, qda, ra) = consistent_state_with(m, drives, &given, false).unwrap();
    let (qb, qdb, rb) = consistent_state_with(m, drives, &given, true).unwrap();
    let vscale = qda.iter().fold(1.0f64, |a, v| a.max(v.abs()));
    for (k, (a, b)) in qa.iter().zip(&qb).enumerate() {
        assert!((a - b).abs() <= tol, "{name}: q[{k}] dense {a} sparse {b}");
    }
    for (k, (a, b)) in qda.iter().zip(&qdb).enumerate() {
        assert!((a - b).abs() <= tol * vscale, "{name}: qd[{k}] dense {a} sparse {b}");
    }
    assert_eq!(ra.position_worst, rb.position_worst);
    for (a, b) in [
        (ra.position_violation, rb.position_violation),
        (ra.position_correction, rb.position_correction),
        (ra.velocity_violation, rb.velocity_violation),
        (ra.velocity_correction, rb.velocity_correction),
    ] {
        assert!((a - b).abs() <= tol.max(1e-9 * a.abs()), "{name}: report {ra:?} vs {rb:?}");
    }
}

#[test]
fn initial_value_paths_agree() {
    let mut r = rng(47);
    use rand::Rng;
    // the snake at 5 and 30 links: x1, y1 and every heading given, the
    // rest from the hinges; x1d and every heading rate given
    for n in [5usize, 30] {
        let m = ezy_models::Snake { N: n, ..Default::default() };
        let info = m.info();
        for _ in 0..3 {
            let mut q = vec![(0, r.random_range(-1.0..1.0)), (1, r.random_range(-1.0..1.0))];
            let mut qd = vec![(0, r.random_range(-1.0..1.0))];
            for b in &info.bodies {
                q.push((b.coords[2], r.random_range(-0.8..0.8)));
                qd.push((b.coords[2], r.random_range(-1.0..1.0)));
            }
            initial_paths_agree(&m, &[], &q, &qd, 1e-12);
            // x2 given off the hinge, and every velocity given: both projected
            let off: Vec<(usize, f64)> = q.iter().copied().chain([(3, 0.01)]).collect();
            let all_qd: Vec<(usize, f64)> = (0..info.nq()).map(|k| (k, r.random_range(-1.0..1.0))).collect();
            initial_paths_agree(&m, &[], &off, &all_qd, 1e-10);
        }
    }
    // the trailer family and the EzyRoller with its prescribed hinge angle
    let t = ezy_models::Trailer { n: 4, ..Default::default() };
    let q: Vec<(usize, f64)> = [(0, 0.0), (1, 0.0), (2, 0.2), (5, 0.1), (8, -0.1), (11, 0.3), (14, 0.0)].into();
    initial_paths_agree(&t, &[], &q, &[(0, 1.5)], 1e-12);
    let s = scenes::get("drive-prescribed");
    let m: ezy_models::EzyRollerDriven = Default::default();
    let drives = s.resolve_drives(&m.info());
    let given = |list: &[(String, ezy_scene::InitValue)]| -> Vec<(usize, f64)> {
        list.iter()
            .map(|(n, v)| match v {
                ezy_scene::InitValue::Num(x) => (m.info().coord_index(n).unwrap(), *x),
                ezy_scene::InitValue::Param(_) => unreachable!("numbers in this scene"),
            })
            .collect()
    };
    initial_paths_agree(&m, &drives, &given(&s.initial.q), &given(&s.initial.qd), 1e-12);
    // the 30-link snake with every hinge angle prescribed: the velocities
    // follow from the drives' rates (nalgebra's SVD missed them by 5e-3 m/s)
    let s = scenes::get("snake-long");
    let m = ezy_models::SnakeDriven { N: 30, ..Default::default() };
    let s = s.expand_families(&m.info()).unwrap();
    let drives = s.resolve_drives(&m.info());
    assert_eq!(drives.len(), 29);
    let q = [(0, 0.0), (1, 0.0), (2, -0.7694208842938135)];
    initial_paths_agree(&m, &drives, &q, &[(0, 0.0), (1, 0.0), (2, 0.0)], 1e-12);
    let given = ezy_core::formulation::initial::Given {
        q: q.to_vec(),
        qd: vec![(0, 0.0), (1, 0.0), (2, 0.0)],
        ..Default::default()
    };
    let (_, _, report) = ezy_core::formulation::initial::consistent_state_with(&m, &drives, &given, false).unwrap();
    assert_eq!(report.velocity_violation, 0.0, "consistent values need no projection: {report:?}");
}

/// Coordinates the constraints do not determine at the start (the
/// Jacobian of the unknowns is singular there) are refused on both paths,
/// naming them (a long list cut short); the sparse path also names one it
/// found dependent.
#[test]
fn undetermined_coordinates_are_named_on_both_paths() {
    use ezy_core::formulation::initial::{Given, consistent_state_with};
    let m = ezy_models::Snake { N: 30, ..Default::default() };
    // x1, y1, x30 and every heading but phi7 (which starts at 0) given:
    // x30 moves with sin(phi7), zero there, so nothing fixes phi7
    let q: Vec<(usize, f64)> = [(0, 0.0), (1, 0.0), (87, -8.7)]
        .into_iter()
        .chain((0..30).filter(|&i| i != 6).map(|i| (3 * i + 2, 0.0)))
        .collect();
    for sparse in [false, true] {
        let given = Given { q: q.clone(), ..Given::default() };
        let err = consistent_state_with(&m, &[], &given, sparse).unwrap_err().to_string();
        assert!(err.contains("do not determine the coordinates x2, y2, x3"), "{sparse}: {err}");
        assert!(err.contains("and 28 more"), "a long list is cut: {err}");
        if sparse {
            assert!(err.contains("` depends on the others)"), "{err}");
        }
    }
}
