//! What one RADAU5 step costs on a family, against its size: the snake of
//! `snake-stiff` (hinge servos, anisotropic friction) with N = 100 ..
//! 10,000 links, on the sparse path. A step is one Jacobian and one
//! factorization (real and complex) of the structured Newton system plus
//! its Newton iterations, each three right-hand sides and two solves;
//! `snake-stiff` averages 3.9 iterations, 0.96 Jacobians and 1.0
//! factorizations per step. Run with `cargo bench --bench radau5`; the
//! README's "Stiff scenes" quotes the fitted exponents.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use ezy_core::Dynamics;
use ezy_core::formulation::newton::KktNewton;
use ezy_core::integrator::Rhs;
use ezy_core::integrator::radau5::{MU_COMPLEX, MU_REAL, NewtonSystem, c64};

use ezy_models::SnakeServo;
use ezy_scene::Scene;

/// `snake-stiff` at any N: the straight snake at rest (the scene's own
/// initial values name the ten links of N = 10).
fn scene() -> Scene {
    let text = ezy_models::scenes::BUILTIN.iter().find(|(f, _)| *f == "snake-stiff.toml").unwrap().1;
    let start = text.find("q = {").unwrap();
    let end = start + text[start..].find("\n[integrator]").unwrap();
    let text = format!(
        "{}q = {{ x1 = 0.0, y1 = 0.0, \"phi*\" = 0.0 }}\nqd = {{ x1 = 0.0, y1 = 0.0, \"phi*\" = 0.0 }}\n{}",
        &text[..start],
        &text[end..]
    );
    Scene::from_toml(&text, "snake-stiff-any-n.toml").unwrap()
}

fn newton_step(c: &mut Criterion) {
    let scene = scene();
    let mut g = c.benchmark_group("radau5-snake");
    g.sample_size(10);
    for n in [100usize, 300, 1000, 3000, 10000] {
        let (mut sys, y, _) = scene.problem::<SnakeServo>(&[("N".into(), n as f64)]).unwrap().0.into_system().unwrap();
        let ny = y.len();
        let mut f = vec![0.0; ny];
        sys.rhs(0.1, &y, &mut f).unwrap();
        let mut newton = KktNewton::new(&sys);
        assert!(newton.is_sparse());
        let h = 0.01;
        let (real, complex) = (MU_REAL / h, c64::new(MU_COMPLEX.0 / h, MU_COMPLEX.1 / h));
        g.bench_function(BenchmarkId::new("jacobian+factor", n), |b| {
            b.iter(|| {
                NewtonSystem::<Dynamics<SnakeServo>>::jacobian(&mut newton, &mut sys, 0.1, black_box(&y), &f).unwrap();
                assert!(NewtonSystem::<Dynamics<SnakeServo>>::factor(&mut newton, real, complex));
            })
        });
        let mut dw = vec![0.0; ny];
        let mut dwc = vec![c64::new(0.0, 0.0); ny];
        let mut fs = vec![0.0; ny];
        g.bench_function(BenchmarkId::new("newton-iteration", n), |b| {
            b.iter(|| {
                for _ in 0..3 {
                    sys.eval(0.1, black_box(&y), &mut fs).unwrap();
                }
                dw.copy_from_slice(&fs);
                for (z, v) in dwc.iter_mut().zip(&fs) {
                    *z = c64::new(*v, -*v);
                }
                NewtonSystem::<Dynamics<SnakeServo>>::solve_real(&mut newton, &mut dw);
                NewtonSystem::<Dynamics<SnakeServo>>::solve_complex(&mut newton, &mut dwc);
            })
        });
        g.bench_function(BenchmarkId::new("dop853-step-rhs", n), |b| {
            b.iter(|| {
                for _ in 0..12 {
                    sys.eval(0.1, black_box(&y), &mut fs).unwrap();
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, newton_step);
criterion_main!(benches);
