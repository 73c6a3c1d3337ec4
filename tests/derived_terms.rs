//! The macro's derived terms against three independent references, at 100
//! random states and random parameters per model:
//! - central finite differences (SPEC §5: relative 1e-7 or better),
//! - forward-mode dual numbers (num-dual; exact to rounding: 1e-12),
//! - for the EzyRoller, the hand formulas of SPEC §1.

mod common;

use common::{random_model, random_model_from, random_state, random_state_n, rng};
use ezy_core::Model;
use ezy_core::model::scatter_dense;
use ezy_models::{ChaplyginSleigh, EzyRoller, Snakeboard};
use num_dual::Dual64;

const STATES: usize = 100;
/// Central differences: truncation ~h^2 |f'''| ~ 1e-10, rounding ~eps/h ~ 1e-10.
const FD_STEP: f64 = 1e-5;
const FD_RTOL: f64 = 1e-7;
/// Dual numbers differentiate exactly; only rounding differs from the generated code.
const DUAL_RTOL: f64 = 1e-12;

fn dense_g<M: Model>(m: &M, q: &[f64]) -> Vec<f64> {
    let i = &m.info();
    let mut vals = vec![0.0; i.pattern.len()];
    m.constraint_matrix(q, &mut vals);
    let mut g = vec![0.0; i.nc() * i.nq()];
    scatter_dense(&i.pattern, &vals, i.nq(), &mut g);
    g
}

fn g_times<M: Model>(m: &M, q: &[f64], v: &[f64]) -> Vec<f64> {
    let nq = m.info().nq();
    dense_g(m, q).chunks(nq).map(|row| row.iter().zip(v).map(|(a, b)| a * b).sum()).collect()
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

fn check_against_finite_differences<M: Model + Default>(seed: u64) {
    check_against_finite_differences_at(&M::default(), seed);
}

/// As above, for `base` (its family counts) with random real parameters.
fn check_against_finite_differences_at<M: Model>(base: &M, seed: u64) {
    let info = &base.info();
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    let mut r = rng(seed);
    for s in 0..STATES {
        let m: M = random_model_from(base, &mut r);
        let (q, qd) = random_state_n(nq, &mut r);
        let g = dense_g(&m, &q);
        // also the sparsity pattern claim: entries outside it are zero
        let shifted = |k: usize, h: f64| {
            let mut p = q.clone();
            p[k] += h;
            p
        };
        // holonomic Jacobian = d phi / dq
        for k in 0..nq {
            let (mut fp, mut fm) = (vec![0.0; nh], vec![0.0; nh]);
            m.phi(&shifted(k, FD_STEP), &mut fp);
            m.phi(&shifted(k, -FD_STEP), &mut fm);
            for i in 0..nh {
                let fd = (fp[i] - fm[i]) / (2.0 * FD_STEP);
                assert!(
                    close(g[i * nq + k], fd, FD_RTOL, 1.0),
                    "{} state {s}: dphi{i}/dq{k} = {} vs FD {fd}",
                    info.name,
                    g[i * nq + k]
                );
            }
        }
        // gamma = d/dq (G qd) . qd, as a directional difference along qd
        let along = |h: f64| -> Vec<f64> { q.iter().zip(&qd).map(|(a, b)| a + h * b).collect() };
        let gp = g_times(&m, &along(FD_STEP), &qd);
        let gm = g_times(&m, &along(-FD_STEP), &qd);
        let gam = gamma(&m, &q, &qd);
        for i in 0..nc {
            let fd = (gp[i] - gm[i]) / (2.0 * FD_STEP);
            assert!(close(gam[i], fd, FD_RTOL, 1.0), "{} state {s}: gamma{i} = {} vs FD {fd}", info.name, gam[i]);
        }
        // point velocities = d/dt point positions
        let np = info.points.len();
        let (mut pp, mut pm, mut v) = (vec![0.0; 2 * np], vec![0.0; 2 * np], vec![0.0; 2 * np]);
        m.points(&along(FD_STEP), &mut pp);
        m.points(&along(-FD_STEP), &mut pm);
        m.point_velocities(&q, &qd, &mut v);
        for i in 0..2 * np {
            let fd = (pp[i] - pm[i]) / (2.0 * FD_STEP);
            assert!(close(v[i], fd, FD_RTOL, 1.0), "{} state {s}: point velocity {i} = {} vs FD {fd}", info.name, v[i]);
        }
        // skate rows: S qd is the contact point's velocity across the blade,
        // whose world normal is R(phi) (-t_y, t_x) for the body-frame blade t
        let mut local = vec![0.0; 2 * np];
        let mut blades = vec![0.0; 2 * info.skates.len()];
        m.local_geometry(&mut local, &mut blades);
        for (j, sk) in info.skates.iter().enumerate() {
            let p = sk.point;
            let phi = q[info.bodies[info.points[p].body].coords[2]];
            let (nx, ny) = (-blades[2 * j + 1], blades[2 * j]);
            let (wx, wy) = (phi.cos() * nx - phi.sin() * ny, phi.sin() * nx + phi.cos() * ny);
            let lateral = wx * v[2 * p] + wy * v[2 * p + 1];
            let gq = g_times(&m, &q, &qd)[sk.row];
            assert!(
                close(gq, lateral, 1e-12, 1.0),
                "{} state {s}: skate {} S qd = {gq} vs n.v = {lateral}",
                info.name,
                sk.name
            );
        }
    }
}

fn check_against_dual_numbers<M: Model + Default>(seed: u64) {
    check_against_dual_numbers_at(&M::default(), seed);
}

/// As above, for `base` (its family counts) with random real parameters.
fn check_against_dual_numbers_at<M: Model>(base: &M, seed: u64) {
    let info = &base.info();
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    let mut r = rng(seed);
    for s in 0..STATES {
        let m: M = random_model_from(base, &mut r);
        let (q, qd) = random_state_n(nq, &mut r);
        let g = dense_g(&m, &q);
        for k in 0..nq {
            let qk: Vec<Dual64> =
                q.iter().enumerate().map(|(j, &x)| Dual64::new(x, if j == k { 1.0 } else { 0.0 })).collect();
            let mut phi = vec![Dual64::from(0.0); nh];
            m.phi(&qk, &mut phi);
            for i in 0..nh {
                let exact = phi[i].eps;
                assert!(
                    close(g[i * nq + k], exact, DUAL_RTOL, 1.0),
                    "{} state {s}: dphi{i}/dq{k} = {} vs dual {exact}",
                    info.name,
                    g[i * nq + k]
                );
            }
        }
        // gamma: d/de G(q + e qd) qd at e = 0
        let qe: Vec<Dual64> = q.iter().zip(&qd).map(|(&x, &v)| Dual64::new(x, v)).collect();
        let qd_d: Vec<Dual64> = qd.iter().map(|&v| Dual64::from(v)).collect();
        let mut vals = vec![Dual64::from(0.0); info.pattern.len()];
        m.constraint_matrix(&qe, &mut vals);
        let mut gqd = vec![Dual64::from(0.0); nc];
        for (&(row, col), v) in info.pattern.iter().zip(&vals) {
            gqd[row] += *v * qd_d[col];
        }
        let gam = gamma(&m, &q, &qd);
        for i in 0..nc {
            assert!(
                close(gam[i], gqd[i].eps, DUAL_RTOL, 1.0),
                "{} state {s}: gamma{i} = {} vs dual {}",
                info.name,
                gam[i],
                gqd[i].eps
            );
            assert!(gqd[i].re.is_finite());
        }
    }
}

#[test]
fn ezyroller_matches_finite_differences() {
    check_against_finite_differences::<EzyRoller>(1);
}

#[test]
fn sleigh_matches_finite_differences() {
    check_against_finite_differences::<ChaplyginSleigh>(2);
}

#[test]
fn ezyroller_matches_dual_numbers() {
    check_against_dual_numbers::<EzyRoller>(3);
}

#[test]
fn sleigh_matches_dual_numbers() {
    check_against_dual_numbers::<ChaplyginSleigh>(4);
}

#[test]
fn snakeboard_matches_finite_differences_and_dual_numbers() {
    check_against_finite_differences::<Snakeboard>(5);
    check_against_dual_numbers::<Snakeboard>(6);
}

/// SPEC §1's formulas, typed here (and only here) to compare with what the
/// macro derived.
/// The models with families at their default and at other counts, and the
/// prescribed-angle EzyRoller.
#[test]
fn family_and_driven_models_match_finite_differences_and_dual_numbers() {
    use ezy_models::{EzyRollerDriven, Snake, Trailer};
    for n in [1, 2, 5, 9] {
        let snake = Snake { N: n, ..Default::default() };
        check_against_finite_differences_at(&snake, 40 + n as u64);
        check_against_dual_numbers_at(&snake, 50 + n as u64);
    }
    for n in [1, 2, 4] {
        let trailer = Trailer { n, ..Default::default() };
        check_against_finite_differences_at(&trailer, 60 + n as u64);
        check_against_dual_numbers_at(&trailer, 70 + n as u64);
    }
    check_against_finite_differences::<EzyRollerDriven>(81);
    check_against_dual_numbers::<EzyRollerDriven>(82);
}

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
            assert!(close(g[i], g_spec[i], 1e-14, 1.0), "G[{}][{}] = {} vs SPEC {}", i / 6, i % 6, g[i], g_spec[i]);
        }
        let gam = gamma(&m, &q, &qd);
        for i in 0..4 {
            assert!(close(gam[i], gamma_spec[i], 1e-13, 1.0), "gamma{i} = {} vs SPEC {}", gam[i], gamma_spec[i]);
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
    // SPEC §1: hinge rows touch (x, phi) resp. (y, phi) of both bodies, skate rows their own body
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
