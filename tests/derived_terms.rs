//! The macro's derived terms against three independent references, at 100
//! random states and random parameters per model:
//! - central finite differences and forward-mode dual numbers, through
//!   `ezy::testing` (tolerances justified there),
//! - for the EzyRoller, the hand formulas (docs/physics.md §10.2).

use crate::common;

use common::{random_model, random_state, rng};
use ezy_core::Model;
use ezy_core::model::info::scatter_dense;
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

/// The models with families at their default and at other counts (the
/// N-four-bar too, up to the benchmark's N = 40), and the prescribed-angle
/// EzyRoller.
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
    // the N-four-bar: its ground pivots at (i L, 0) name the index
    for n in [1, 2, 5, 40] {
        assert_terms(&ezy_models::NFourBar { N: n, ..Default::default() }, 120 + n as u64);
    }
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

ezy_core::model! {
    /// Every expression of a family item names the family's index: masses
    /// and inertias, point offsets (read by a neighbour, `P[i - 1]`, by the
    /// count, `P[N]`, and by a fixed element, `Q[1]`), a ground point, a
    /// slider's direction and angle, a slot's line, a skate's blade.
    pub struct Indexed {
        count N = 3;
        param a = 0.3;
        param m = 1.5;
        for i in 1..N + 1 {
            body link[i](x, y, phi) { mass: m * i, inertia: m * (1 + i * i) / 12 }
            point P[i] on link[i] at (i * a, 0.1 * i);
            point Q[i] on link[i] at (-a, sin(i));
            skate S[i]: Q[i] along (1, i);
        }
        for i in 1..N + 1 {
            body block[i](u, w, th) { mass: m, inertia: 0.1 * i }
            point C[i] on block[i] at (0.05 * i, -a);
        }
        for i in 2..N + 1 {
            hinge J[i]: P[i - 1] = Q[i];
        }
        hinge K: P[N] = ground(a, 2);
        hinge K0: Q[1] = ground(1, a);
        for i in 2..N + 1 {
            slider R[i]: C[i] on P[i - 1] along (cos(i), 1) angle 0.1 * i;
        }
        for i in 1..N + 1 {
            slot W[i]: C[i] on ground(i * a, i) along (i, 2);
        }
    }
}

ezy_core::model! {
    /// `Indexed` at N = 3 written out by hand, element by element, every
    /// index a number: no family.
    pub struct Unrolled {
        param a = 0.3;
        param m = 1.5;
        body link1(x1, y1, phi1) { mass: m * 1, inertia: m * (1 + 1 * 1) / 12 }
        body link2(x2, y2, phi2) { mass: m * 2, inertia: m * (1 + 2 * 2) / 12 }
        body link3(x3, y3, phi3) { mass: m * 3, inertia: m * (1 + 3 * 3) / 12 }
        body block1(u1, w1, th1) { mass: m, inertia: 0.1 * 1 }
        body block2(u2, w2, th2) { mass: m, inertia: 0.1 * 2 }
        body block3(u3, w3, th3) { mass: m, inertia: 0.1 * 3 }
        point P1 on link1 at (1 * a, 0.1 * 1);
        point P2 on link2 at (2 * a, 0.1 * 2);
        point P3 on link3 at (3 * a, 0.1 * 3);
        point Q1 on link1 at (-a, sin(1));
        point Q2 on link2 at (-a, sin(2));
        point Q3 on link3 at (-a, sin(3));
        point C1 on block1 at (0.05 * 1, -a);
        point C2 on block2 at (0.05 * 2, -a);
        point C3 on block3 at (0.05 * 3, -a);
        skate S1: Q1 along (1, 1);
        skate S2: Q2 along (1, 2);
        skate S3: Q3 along (1, 3);
        hinge J2: P1 = Q2;
        hinge J3: P2 = Q3;
        hinge K: P3 = ground(a, 2);
        hinge K0: Q1 = ground(1, a);
        slider R2: C2 on P1 along (cos(2), 1) angle 0.1 * 2;
        slider R3: C3 on P2 along (cos(3), 1) angle 0.1 * 3;
        slot W1: C1 on ground(1 * a, 1) along (1, 2);
        slot W2: C2 on ground(2 * a, 2) along (2, 2);
        slot W3: C3 on ground(3 * a, 3) along (3, 2);
    }
}

/// A family whose expressions name the index computes, element by
/// element, what the same model written out by hand computes: the names,
/// `phi`, `G` (dense), `gamma`, the points and their velocities, the mass
/// matrix and the body-frame geometry, at random states and parameters
/// (to rounding: the family multiplies by the index at run time where the
/// written-out model folds the numbers). Then its derived terms against
/// finite differences and dual numbers at N = 3 and other counts.
#[test]
fn family_index_expressions_match_the_model_written_out() {
    let mut r = rng(17);
    let close_all = |what: &str, a: &[f64], b: &[f64]| {
        assert_eq!(a.len(), b.len(), "{what}");
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(close(*x, *y, 1e-13, 1.0), "{what}[{k}]: family {x} vs written out {y}");
        }
    };
    let (fi, ui) = (Indexed::default().info(), Unrolled::default().info());
    assert_eq!(fi.coords, ui.coords);
    assert_eq!(fi.constraints, ui.constraints);
    assert_eq!(fi.n_holonomic, ui.n_holonomic);
    let names = |i: &ezy_core::ModelInfo| i.points.iter().map(|p| p.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&fi), names(&ui));
    let (nq, nc, np) = (fi.nq(), fi.nc(), fi.points.len());
    for _ in 0..STATES {
        let f: Indexed = random_model(&mut r);
        let u = Unrolled { a: f.a, m: f.m };
        let (q, qd) = random_state::<Indexed>(&mut r);
        let (mut pf, mut pu) = (vec![0.0; fi.n_holonomic], vec![0.0; ui.n_holonomic]);
        f.phi(&q, &mut pf);
        u.phi(&q, &mut pu);
        close_all("phi", &pf, &pu);
        close_all("G", &dense_g(&f, &q), &dense_g(&u, &q));
        close_all("gamma", &gamma(&f, &q, &qd), &gamma(&u, &q, &qd));
        let (mut a, mut b) = (vec![0.0; 2 * np], vec![0.0; 2 * np]);
        f.points(&q, &mut a);
        u.points(&q, &mut b);
        close_all("points", &a, &b);
        f.point_velocities(&q, &qd, &mut a);
        u.point_velocities(&q, &qd, &mut b);
        close_all("point velocities", &a, &b);
        let (mut a, mut b) = (vec![0.0; nq], vec![0.0; nq]);
        f.mass_diagonal(&mut a);
        u.mass_diagonal(&mut b);
        close_all("mass", &a, &b);
        let (mut a, mut b, mut ba, mut bb) = (vec![0.0; 2 * np], vec![0.0; 2 * np], vec![0.0; 6], vec![0.0; 6]);
        f.local_geometry(&mut a, &mut ba);
        u.local_geometry(&mut b, &mut bb);
        close_all("local points", &a, &b);
        close_all("blades", &ba, &bb);
    }
    assert_eq!(nc, 2 * 4 + 2 * 2 + 3 + 3);
    // `ezy equations` shows each element's index as its number: P[i - 1]
    // of J3 at 2, P[N] of K at 3, the slot W2's ground point at 2
    let eq = Indexed::default().equations();
    let row = |name: &str| eq.phi[fi.constraints.iter().position(|c| c == name).unwrap()].text.clone();
    assert!(row("J3.x").contains("2*a*cos(phi2)"), "{}", row("J3.x"));
    assert!(row("K.x").contains("3*a*cos(phi3)"), "{}", row("K.x"));
    assert!(row("W2.n").contains("2*a"), "{}", row("W2.n"));
    assert_terms(&Indexed::default(), 111);
    for n in [1, 2, 6] {
        assert_terms(&Indexed { N: n, ..Default::default() }, 111 + n as u64);
    }
}
