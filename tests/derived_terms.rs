//! The macro's derived terms against three independent references, at 100
//! random states and random parameters per model:
//! - central finite differences and forward-mode dual numbers, through
//!   `ezy::testing` (tolerances justified there),
//! - for the EzyRoller, the hand formulas (docs/physics.md §10.2).

mod common;

use common::{random_model, random_state, rng};
use ezy_core::Model;
use ezy_core::model::scatter_dense;
use ezy_models::{ChaplyginSleigh, EzyRoller, Snakeboard};

const STATES: usize = 100;

fn dense_g<M: Model>(m: &M, q: &[f64]) -> Vec<f64> {
    let i = &m.info();
    let mut vals = vec![0.0; i.pattern.len()];
    m.constraint_matrix(q, &mut vals);
    let mut g = vec![0.0; i.nc() * i.nq()];
    scatter_dense(&i.pattern, &vals, i.nq(), &mut g);
    g
}

fn gamma<M: Model>(m: &M, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let i = &m.info();
    let mut vals = vec![0.0; i.pattern.len()];
    let mut gam = vec![0.0; i.nc()];
    m.constraint_terms(q, qd, &mut vals, &mut gam);
    gam
}

fn close(a: f64, b: f64, rtol: f64, scale: f64) -> bool {
    (a - b).abs() <= rtol * a.abs().max(b.abs()).max(scale)
}

/// Every generated term of `model` against finite differences and dual
/// numbers ([`ezy::testing`], the check model authors run) at
/// [`STATES`] random states and parameters.
fn assert_terms<M: Model>(model: &M, seed: u64) {
    let report = ezy::testing::check_derivatives_with(model, STATES, seed);
    assert!(report.passed(), "{}\n{}", report.worst(), report.table(model.info().name));
    let info = model.info();
    let absent = |t: &ezy::testing::TermCheck| {
        (t.term.starts_with("C_q") && info.n_holonomic == 0) || (t.term.starts_with("S =") && info.skates.is_empty())
    };
    assert!(report.terms.iter().all(|t| t.compared > 0 || absent(t)), "{report:?}");
    // a model with a fused right-hand side has it checked
    let fused = report.terms.iter().any(|t| t.term == ezy::testing::MIN_FUSED && t.compared > 0);
    assert_eq!(fused, model.minimal_constants().is_some(), "{report:?}");
}

#[test]
fn every_model_matches_finite_differences_and_dual_numbers() {
    assert_terms(&EzyRoller::default(), 1);
    assert_terms(&ChaplyginSleigh::default(), 2);
    assert_terms(&Snakeboard::default(), 5);
}

/// The models with families at their default and at other counts, and the
/// prescribed-angle EzyRoller.
#[test]
fn family_and_driven_models_match_finite_differences_and_dual_numbers() {
    use ezy_models::{EzyRollerDriven, Snake, Trailer};
    for n in [1, 2, 5, 9] {
        assert_terms(&Snake { N: n, ..Default::default() }, 40 + n as u64);
    }
    for n in [1, 2, 4] {
        assert_terms(&Trailer { n, ..Default::default() }, 60 + n as u64);
    }
    assert_terms(&EzyRollerDriven::default(), 81);
    // a family of drives: each element's row is its hinge's angle
    for n in [2, 3, 7] {
        let m = ezy_models::SnakeDriven { N: n, ..Default::default() };
        assert_terms(&m, 90 + n as u64);
        let info = m.info();
        assert_eq!(info.drives.len(), n - 1);
        for (k, d) in info.drives.iter().enumerate() {
            assert_eq!(
                (d.name.as_str(), info.hinges[d.hinge].name.as_str()),
                (format!("D{}", k + 2).as_str(), format!("J{}", k + 2).as_str())
            );
            assert_eq!(info.constraints[d.row], d.name);
        }
    }
}

/// The hand formulas of the EzyRoller, typed here (and only here) to
/// compare with what the macro derived.
#[test]
fn ezyroller_matches_spec_formulas() {
    let mut r = rng(5);
    for _ in 0..STATES {
        let m: EzyRoller = random_model(&mut r);
        let (q, qd) = random_state::<EzyRoller>(&mut r);
        let (a, b, c, d) = (m.a, m.b, m.c, m.d);
        let [x1, y1, p1, x2, y2, p2] = q[..] else { unreachable!() };
        let [x1d, y1d, p1d, x2d, y2d, p2d] = qd[..] else { unreachable!() };
        let phi_spec = [x1 + b * p1.cos() - x2 + d * p2.cos(), y1 + b * p1.sin() - y2 + d * p2.sin()];
        #[rustfmt::skip]
        let g_spec = [
            1.0, 0.0, -b * p1.sin(), -1.0, 0.0, -d * p2.sin(),
            0.0, 1.0, b * p1.cos(), 0.0, -1.0, d * p2.cos(),
            -p1.sin(), p1.cos(), -a, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, -p2.sin(), p2.cos(), c,
        ];
        let gamma_spec = [
            -b * p1d * p1d * p1.cos() - d * p2d * p2d * p2.cos(),
            -b * p1d * p1d * p1.sin() - d * p2d * p2d * p2.sin(),
            -p1d * (x1d * p1.cos() + y1d * p1.sin()),
            -p2d * (x2d * p2.cos() + y2d * p2.sin()),
        ];
        let mut phi = [0.0; 2];
        m.phi(&q, &mut phi);
        for i in 0..2 {
            assert!(close(phi[i], phi_spec[i], 1e-14, 1.0), "phi{i}");
        }
        let g = dense_g(&m, &q);
        for i in 0..24 {
            assert!(
                close(g[i], g_spec[i], 1e-14, 1.0),
                "G[{}][{}] = {} vs docs/physics.md {}",
                i / 6,
                i % 6,
                g[i],
                g_spec[i]
            );
        }
        let gam = gamma(&m, &q, &qd);
        for i in 0..4 {
            assert!(
                close(gam[i], gamma_spec[i], 1e-13, 1.0),
                "gamma{i} = {} vs docs/physics.md {}",
                gam[i],
                gamma_spec[i]
            );
        }
        let mut mass = [0.0; 6];
        m.mass_diagonal(&mut mass);
        assert_eq!(mass, [m.m1, m.m1, m.I1, m.m2, m.m2, m.I2]);
    }
}

#[test]
fn sparsity_pattern_and_names() {
    let i = &EzyRoller::default().info();
    assert_eq!(i.coords, ["x1", "y1", "phi1", "x2", "y2", "phi2"]);
    assert_eq!(i.constraints, ["B.x", "B.y", "A", "C"]);
    assert_eq!(i.n_holonomic, 2);
    // docs/physics.md §10.2: hinge rows touch (x, phi) resp. (y, phi) of both bodies, skate rows their own body
    #[rustfmt::skip]
    let want = [(0, 0), (0, 2), (0, 3), (0, 5), (1, 1), (1, 2), (1, 4), (1, 5), (2, 0), (2, 1), (2, 2), (3, 3), (3, 4), (3, 5)];
    assert_eq!(i.pattern, want);
    assert_eq!(i.params.iter().map(|p| p.name).collect::<Vec<_>>(), ["a", "b", "c", "d", "m1", "I1", "m2", "I2"]);
    assert_eq!(i.params[0].unit, "m");
    assert_eq!(i.params[5].unit, "kg m^2");
    assert_eq!(ChaplyginSleigh::default().info().coords, ["x", "y", "phi"]);
}

/// The products with `G` (straight-line for single models, loops over
/// the pattern for models with families) against dense products.
fn kernels_match_dense_products<M: Model + Default>(seed: u64) {
    let mut r = rng(seed);
    let i = &M::default().info();
    let (nq, nc) = (i.nq(), i.nc());
    for _ in 0..20 {
        let m: M = random_model(&mut r);
        let (q, u) = random_state::<M>(&mut r);
        let winv: Vec<f64> = (0..nq).map(|k| 0.1 + k as f64).collect();
        let x: Vec<f64> = (0..nc).map(|k| 1.0 - 0.3 * k as f64).collect();
        let mut vals = vec![0.0; i.pattern.len()];
        m.constraint_matrix(&q, &mut vals);
        let g = dense_g(&m, &q);
        let mut a = vec![0.0; nc * nc];
        m.normal_matrix(&i.pattern, nc, &vals, &winv, &mut a);
        for r_ in 0..nc {
            for c in 0..=r_ {
                let want: f64 = (0..nq).map(|k| g[r_ * nq + k] * g[c * nq + k] * winv[k]).sum();
                assert!(close(a[r_ * nc + c], want, 1e-14, 1.0));
            }
        }
        let mut gu = vec![0.0; nc];
        m.g_winv_mul(&i.pattern, &vals, &winv, &u, &mut gu);
        let mut v = u.clone();
        m.sub_winv_gt_mul(&i.pattern, &vals, &winv, &x, &mut v);
        for r_ in 0..nc {
            let want: f64 = (0..nq).map(|k| g[r_ * nq + k] * winv[k] * u[k]).sum();
            assert!(close(gu[r_], want, 1e-14, 1.0));
        }
        for k in 0..nq {
            let want = u[k] - winv[k] * (0..nc).map(|r_| g[r_ * nq + k] * x[r_]).sum::<f64>();
            assert!(close(v[k], want, 1e-14, 1.0));
        }
    }
}

#[test]
fn generated_sparse_kernels_match_dense_products() {
    kernels_match_dense_products::<EzyRoller>(6);
    kernels_match_dense_products::<ezy_models::Trailer>(7);
    kernels_match_dense_products::<ezy_models::Snake>(8);
}
