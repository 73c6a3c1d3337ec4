//! Absent effects cost nothing (issue 5): the `free` scene's right-hand
//! side against the bare model's (no effect code at all, see
//! `tests/support/bare_rhs.rs`), and `drive` against `free` plus one
//! evaluation of the motor alone. Run with `cargo bench --bench effects`.

#[path = "../tests/support/bare_rhs.rs"]
mod bare_rhs;

use std::hint::black_box;

use bare_rhs::BareRhs;
use criterion::{Criterion, criterion_group, criterion_main};
use ezy_core::integrator::Rhs;
use ezy_models::{EzyRoller, scenes};

/// A moving state `[q, qd]` of the EzyRoller (on no particular scene).
const STATE: [f64; 12] = [0.31, -0.12, -0.4, 0.77, -0.35, 2.4, 0.3, -0.12, 0.05, 0.29, -0.1, -0.6];

fn absent_effects(c: &mut Criterion) {
    let mut g = c.benchmark_group("rhs");
    let y = STATE.to_vec();
    let mut dy = vec![0.0; 12];
    let mut bare = BareRhs::new(EzyRoller::default());
    g.bench_function("bare-model", |b| b.iter(|| bare.eval(black_box(1.3), black_box(&y), &mut dy).unwrap()));
    let (mut free, _, _) = scenes::free().problem::<EzyRoller>(&[]).unwrap().0.into_system().unwrap();
    g.bench_function("free-scene", |b| b.iter(|| free.rhs(black_box(1.3), black_box(&y), &mut dy).unwrap()));
    let (mut drive, _, _) = scenes::drive().problem::<EzyRoller>(&[]).unwrap().0.into_system().unwrap();
    let mut yw = y.clone();
    yw.push(0.0);
    let mut dyw = vec![0.0; 13];
    g.bench_function("drive-scene", |b| b.iter(|| drive.rhs(black_box(1.3), black_box(&yw), &mut dyw).unwrap()));
    g.finish();
    let motor = drive.effects[0].clone();
    let mut f = [0.0; 6];
    c.bench_function("effect/motor", |b| {
        b.iter(|| motor.apply(black_box(1.3), black_box(&STATE[..6]), black_box(&STATE[6..]), &mut f))
    });
}

criterion_group!(benches, absent_effects);
criterion_main!(benches);
