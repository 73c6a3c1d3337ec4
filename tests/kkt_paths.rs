//! The three KKT paths (dense Schur, dense LU, sparse Schur) give the same
//! accelerations and multipliers for every registered model at random
//! states, and the same trajectory over a second of `drive`.

mod common;

use common::{random_model, random_state, rng};
use ezy::run::build;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, ProjectionKind, RunSettings, simulate};
use ezy_models::{ChaplyginSleigh, EzyRoller, scenes};

/// `dy` and `lambda` of the three paths agree to 1e-12 relative to the
/// largest entry at 100 random states and parameter sets.
fn paths_agree<M: Model + Default>(seed: u64) {
    let mut r = rng(seed);
    let nq = M::INFO.nq();
    for s in 0..100 {
        let m: M = random_model(&mut r);
        let (q, qd) = random_state::<M>(&mut r);
        let mut y = q.clone();
        y.extend_from_slice(&qd);
        let mut out = Vec::new();
        for method in [KktMethod::Schur, KktMethod::Lu, KktMethod::Sparse] {
            let mut sys = Dynamics::new(m.clone(), vec![], method);
            let mut dy = vec![0.0; 2 * nq];
            sys.rhs(0.0, &y, &mut dy).unwrap();
            out.push((sys.kkt_name(), dy, sys.lambda().to_vec()));
        }
        assert_eq!(out[2].0, "sparse-cholesky");
        let scale = out[0].1.iter().chain(&out[0].2).fold(1.0f64, |a, v| a.max(v.abs()));
        for (name, dy, lambda) in &out[1..] {
            for (a, b) in dy.iter().chain(lambda).zip(out[0].1.iter().chain(&out[0].2)) {
                assert!((a - b).abs() <= 1e-12 * scale, "{} state {s}, {name}: {a} vs {b}", M::INFO.name);
            }
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
            rtol: 1e-9,
            atol: 1e-9,
            balance_limit: None,
        };
        let s = simulate(&mut sys, &y0, &settings, &mut common::Recorder::default()).unwrap();
        assert_eq!(s.kkt, if method == KktMethod::Sparse { "sparse-cholesky" } else { "schur-cholesky" });
        finals.push(s.final_state);
    }
    for (a, b) in finals[0].iter().zip(&finals[1]) {
        assert!((a - b).abs() <= 1e-12, "{a} vs {b}");
    }
}
