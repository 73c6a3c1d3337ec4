//! The EzyRoller's right-hand side per KKT path, its pieces, one RK4 step,
//! one DOP853 step, and the whole `drive` scene (60 s) at the assignment's
//! settings and with DOP853 at tight tolerances. Run with
//! `cargo bench --bench kkt`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ezy_core::integrator::{Dop853, EmbeddedRk, Rk4, Tolerance};
use ezy_core::kkt::{DenseLu, KktMethod, KktSolver, KktSystem, SchurCholesky};
use ezy_core::model::info::scatter_dense;
use ezy_core::{Dynamics, Method, Model, Observer, ProjectionKind, RunSettings, Sample, simulate};
use ezy_models::{EzyRoller, scenes};

/// A state of the `drive` scene after a few seconds.
fn state() -> Vec<f64> {
    vec![0.31, -0.12, -0.4, 0.77, -0.35, 2.4, 0.3, -0.12, 0.05, 0.29, -0.1, -0.6, 0.4]
}

fn dynamics(method: KktMethod) -> Dynamics<EzyRoller> {
    scenes::drive().problem::<EzyRoller>(&[]).unwrap().0.kkt(method).into_system().unwrap().0
}

fn rhs(c: &mut Criterion) {
    let y = state();
    let mut dy = vec![0.0; y.len()];
    for (name, method) in [("rhs/schur-cholesky", KktMethod::Schur), ("rhs/dense-lu", KktMethod::Lu)] {
        let mut sys = dynamics(method);
        c.bench_function(name, |b| b.iter(|| sys.rhs(black_box(1.3), black_box(&y), &mut dy).unwrap()));
    }
}

fn pieces(c: &mut Criterion) {
    let m = EzyRoller::default();
    let y = state();
    let (q, qd) = (&y[..6], &y[6..12]);
    let info = m.info();
    let mut vals = vec![0.0; info.pattern.len()];
    let mut gamma = vec![0.0; 4];
    c.bench_function("generated/constraint_terms", |b| {
        b.iter(|| m.constraint_terms(black_box(q), black_box(qd), &mut vals, &mut gamma))
    });
    let mut g = vec![0.0; 24];
    scatter_dense(&info.pattern, &vals, 6, &mut g);
    let mut mass = vec![0.0; 6];
    m.mass_diagonal(&mut mass);
    let f = [0.0, 0.0, 1.5, 0.0, 0.0, -1.5];
    let sys = KktSystem { mass: &mass, g: &g, g_values: &vals, f: &f, gamma: &gamma, released: &[] };
    let (mut qdd, mut lambda) = (vec![0.0; 6], vec![0.0; 4]);
    let mut schur = SchurCholesky::<EzyRoller>::new(&m, &info, &mass).unwrap();
    c.bench_function("kkt/schur-cholesky", |b| b.iter(|| schur.solve(black_box(&sys), &mut qdd, &mut lambda).unwrap()));
    let mut lu = DenseLu::new(6, 4);
    c.bench_function("kkt/dense-lu", |b| b.iter(|| lu.solve(black_box(&sys), &mut qdd, &mut lambda).unwrap()));
}

fn dop853_step(c: &mut Criterion) {
    let mut sys = dynamics(KktMethod::Auto);
    let mut st = Dop853::new(13);
    let y = state();
    let mut k1 = vec![0.0; 13];
    sys.rhs(1.3, &y, &mut k1).unwrap();
    let (mut y_new, mut k_new) = (vec![0.0; 13], vec![0.0; 13]);
    let tol = Tolerance { rtol: 1e-12, atol: 1e-12 };
    c.bench_function("dop853/step", |b| {
        b.iter(|| st.attempt(&mut sys, black_box(1.3), &y, &k1, 0.05, &tol, &mut y_new, &mut k_new).unwrap())
    });
}

fn step(c: &mut Criterion) {
    let mut sys = dynamics(KktMethod::Auto);
    let mut rk = Rk4::new(13);
    let y0 = state();
    let mut y = y0.clone();
    c.bench_function("rk4/step", |b| {
        b.iter(|| {
            y.copy_from_slice(&y0);
            rk.step(&mut sys, black_box(1.3), &mut y, 1e-4).unwrap()
        })
    });
}

struct Sink;
impl<M: Model> Observer<M> for Sink {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        black_box(s.kinetic_energy);
        Ok(())
    }
}

fn scene(c: &mut Criterion) {
    let y0 = scenes::drive().problem::<EzyRoller>(&[]).unwrap().0.initial_state().unwrap().0;
    let settings = RunSettings {
        dt: 1e-4,
        t_end: 1.0,
        every: 0.01,
        projection: ProjectionKind::MassWeighted,
        method: Method::Rk4,
        formulation: ezy_core::Formulation::Dae,
        rtol: 1e-9,
        atol: 1e-9,
        balance_limit: None,
        max_steps: None,
    };
    let mut g = c.benchmark_group("drive");
    g.sample_size(10);
    let seed = RunSettings { t_end: 60.0, every: 60.0, ..settings };
    g.bench_function("60s_rk4_h1e-4_projected", |b| {
        b.iter(|| {
            let mut sys = dynamics(KktMethod::Auto);
            simulate(&mut sys, &y0, &seed, &mut Sink).unwrap()
        })
    });
    for tol in [1e-11, 1e-12] {
        let adaptive = RunSettings { method: Method::Dop853, rtol: tol, atol: tol, ..seed };
        g.bench_function(format!("60s_dop853_tol{tol:e}_projected"), |b| {
            b.iter(|| {
                let mut sys = dynamics(KktMethod::Auto);
                simulate(&mut sys, &y0, &adaptive, &mut Sink).unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, rhs, pieces, step, dop853_step, scene);
criterion_main!(benches);
