//! The dense and the sparse Schur-complement KKT paths on chains of n links
//! (nq = 3n, nc = 3n - 2): one solve each (assemble `G M^-1 G^T`, factor,
//! solve, back-substitute), for the crossover of `KktMethod::Auto`
//! (`ezy_core::kkt::SPARSE_FROM_ROWS`). Run with `cargo bench --bench sparse`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use ezy_core::kkt::{KktSolver, KktSystem, SparseSchur, ldl_solve, synthetic_chain};

/// The dense path for a pattern known only at run time: `A` assembled
/// column by column of `G`, then the fused dense `LDL^T` of the Schur path.
struct DenseSchur {
    nc: usize,
    by_col: Vec<Vec<(usize, usize)>>,
    minv: Vec<f64>,
    a: Vec<f64>,
    r: Vec<f64>,
    scratch: Vec<f64>,
}

impl DenseSchur {
    fn new(pattern: &[(usize, usize)], nc: usize, mass: &[f64]) -> Self {
        let mut by_col = vec![Vec::new(); mass.len()];
        for (v, &(r, c)) in pattern.iter().enumerate() {
            by_col[c].push((r, v));
        }
        Self {
            nc,
            by_col,
            minv: mass.iter().map(|m| 1.0 / m).collect(),
            a: vec![0.0; nc * nc],
            r: vec![0.0; nc],
            scratch: vec![0.0; nc * (nc + 1)],
        }
    }

    fn solve(&mut self, g: &[f64], f: &[f64], gamma: &[f64], qdd: &mut [f64], lambda: &mut [f64]) {
        let nc = self.nc;
        self.a.fill(0.0);
        self.r.copy_from_slice(gamma);
        for (k, rows) in self.by_col.iter().enumerate() {
            for &(ri, vi) in rows {
                self.r[ri] += g[vi] * self.minv[k] * f[k];
                for &(rj, vj) in rows {
                    if ri >= rj {
                        self.a[ri * nc + rj] += g[vi] * g[vj] * self.minv[k];
                    }
                }
            }
        }
        ldl_solve(&self.a, nc, nc, &self.r, lambda, &mut self.scratch).unwrap();
        qdd.copy_from_slice(f);
        for (k, rows) in self.by_col.iter().enumerate() {
            for &(r, v) in rows {
                qdd[k] -= g[v] * lambda[r];
            }
            qdd[k] *= self.minv[k];
        }
    }
}

fn dense_vs_sparse(c: &mut Criterion) {
    let mut group = c.benchmark_group("kkt-chain");
    for n in [2, 4, 8, 16, 22, 32, 64, 128, 333, 1000] {
        let (pattern, g, nc, mass) = synthetic_chain(n);
        let nq = mass.len();
        let f: Vec<f64> = (0..nq).map(|k| (0.7 * k as f64).sin()).collect();
        let gamma: Vec<f64> = (0..nc).map(|i| (0.3 * i as f64).cos()).collect();
        let (mut qdd, mut lambda) = (vec![0.0; nq], vec![0.0; nc]);
        if n <= 333 {
            let mut dense = DenseSchur::new(&pattern, nc, &mass);
            group.bench_with_input(BenchmarkId::new("dense", nc), &nc, |b, _| {
                b.iter(|| dense.solve(black_box(&g), &f, &gamma, &mut qdd, &mut lambda))
            });
        }
        let mut sparse = SparseSchur::new(&pattern, nc, &mass).unwrap();
        let sys = KktSystem { mass: &mass, g: &[], g_values: &g, f: &f, gamma: &gamma, released: &[] };
        group.bench_with_input(BenchmarkId::new("sparse", nc), &nc, |b, _| {
            b.iter(|| sparse.solve(black_box(&sys), &mut qdd, &mut lambda).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, dense_vs_sparse);
criterion_main!(benches);
