//! The geometry of locomotion (`ezy geometry`, `ezy_core::geometry`):
//! the local connection `A(r)` and `Gamma(r)`, `dA/dr`, the height
//! functions `D(-A)`, a gait's net motion (first order, second order,
//! reconstructed, simulated) and its momentum, against an oracle that
//! shares no code with ezy's geometry (its placement, `E`, `H`,
//! `Omega`, `Psi`, free directions, dual numbers and quadratures):
//!
//! - the connection by solving the model's velocity constraints directly:
//!   at the configuration of shape `r` (ezy's placement, checked here:
//!   every hinge closed, the reference frame at the origin, every hinge
//!   angle `r`), the velocity `qd` with shape rate `e_k` that satisfies
//!   the hinges' and the skates' rows of the generated constraint matrix
//!   `G(q) qd = 0` with the least kinetic energy `qd^T M qd / 2`. For a
//!   kinematic system the constraints alone fix it; for a mixed one the
//!   least energy is the velocity M-orthogonal to the locked motions the
//!   skates allow, the zero-momentum velocity the module's docs define.
//!   Column `k` of `A` is minus the reference body's velocity in its frame.
//!   `Gamma` from an M-orthonormal basis `N` of the locked motions the
//!   constraints allow (the null space of the same rows with the shape
//!   held): with `X` their body velocities (3 x m) and `P` the rows of
//!   `X` that the free directions fix at 1 (the momentum names `p_u`,
//!   `p_w`), `p = P^-T N^T M qd` and `Gamma = X P^T`. The constraint
//!   rows are reduced by Gram-Schmidt (twice) in the coordinates `M^1/2
//!   qd`, written here; a row that loses rank marks the singular set.
//! - `dA/dr_k` by central differences of the oracle's connection at `r +-
//!   h e_k`, `r +- h/2 e_k` (h = 1e-4 rad), extrapolated (Richardson); the
//!   height functions `-(dA_j/dr_i - dA_i/dr_j) + [A_i, A_j]`, the bracket
//!   of se(2) as the commutator of the 3 x 3 matrices.
//! - a gait's net motion against a whole run of the scene over one
//!   period (DOP853 at 1e-12): the reference body's pose at the end in
//!   its initial frame, the body-velocity integral by Simpson's rule on
//!   the run's samples, the momentum at the end by the oracle's formula;
//!   for a kinematic system the first order also as `-oint A dr` and the
//!   second as that plus the bracket's area integral, both by quadratures
//!   written here; and the order of accuracy of small gaits' predictions
//!   against runs.

use ezy::models::{
    ChaplyginSleigh, EzyRoller, EzyRollerDriven, KinematicSnake, SnakeDriven, SnakeServo, Snakeboard, scenes,
};
use ezy_core::effects::{Harmonic, Waveform};
use ezy_core::geometry::{Gait, Geometry};
use ezy_core::text::RuntimeModel;
use ezy_core::{Method, Model, Problem};
use ezy_scene::Scene;

use crate::analysis::{ezy, fresh, table};

/// What the oracle knows of a model: its structure, masses, and the
/// choices that name ezy's numbers (the reference body, the shape
/// coordinates' hinges in order, the components of `xi` the momentum
/// names fix at 1).
struct Oracle<'a, M: Model> {
    model: &'a M,
    info: ezy_core::model::info::ModelInfo,
    mass: Vec<f64>,
    body: usize,
    shape: Vec<usize>,
    free: Vec<usize>,
}

/// The connection at one shape: `A` (3 x ns) and `Gamma` (3 x m),
/// row-major as ezy's.
struct Connection {
    a: Vec<f64>,
    gamma: Vec<f64>,
}

/// The constraint rows `C` reduced for minimum-energy solves: in `y =
/// M^1/2 qd` the rows `C M^-1/2` by Gram-Schmidt to an orthonormal
/// basis, each kept row's coefficients on the basis before it and its
/// remainder; a row whose remainder is below 1e-9 of its norm is
/// dependent (the constraints lose rank there).
struct Factor {
    /// `M^-1/2` (diagonal).
    s: Vec<f64>,
    basis: Vec<Vec<f64>>,
    /// Per row: `Some((coefficients, remainder))` when kept.
    rows: Vec<Option<(Vec<f64>, f64)>>,
    dependent: usize,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `v` less its components along the orthonormal `basis`, twice
/// (Kahan's "twice is enough"); the coefficients taken.
fn orthogonalize(v: &mut [f64], basis: &[Vec<f64>]) -> Vec<f64> {
    let mut c = vec![0.0; basis.len()];
    for _ in 0..2 {
        for (j, q) in basis.iter().enumerate() {
            let d = dot(q, v);
            c[j] += d;
            v.iter_mut().zip(q).for_each(|(x, y)| *x -= d * y);
        }
    }
    c
}

impl Factor {
    fn new(rows: &[Vec<f64>], mass: &[f64]) -> Self {
        let s: Vec<f64> = mass.iter().map(|m| 1.0 / m.sqrt()).collect();
        let mut f = Self { s, basis: Vec::new(), rows: Vec::new(), dependent: 0 };
        for row in rows {
            let mut v: Vec<f64> = row.iter().zip(&f.s).map(|(a, b)| a * b).collect();
            let size = dot(&v, &v).sqrt();
            let c = orthogonalize(&mut v, &f.basis);
            let rest = dot(&v, &v).sqrt();
            if rest <= 1e-9 * size {
                f.dependent += 1;
                f.rows.push(None);
            } else {
                f.basis.push(v.iter().map(|x| x / rest).collect());
                f.rows.push(Some((c, rest)));
            }
        }
        f
    }

    /// The `qd` of least `qd^T M qd` with `C qd = b` (the kept rows; the
    /// caller checks `dependent`): `y` the combination of the basis that
    /// meets the rows, by forward substitution.
    fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut z: Vec<f64> = Vec::new();
        for (row, bi) in self.rows.iter().zip(b) {
            if let Some((c, rest)) = row {
                z.push((bi - dot(c, &z)) / rest);
            }
        }
        (0..self.s.len()).map(|i| self.s[i] * self.basis.iter().zip(&z).map(|(q, zj)| q[i] * zj).sum::<f64>()).collect()
    }

    /// An M-orthonormal basis of the null space of `C` (as velocities):
    /// the basis completed greedily from unit vectors, the one with the
    /// largest remainder first.
    fn null(&self) -> Vec<Vec<f64>> {
        let n = self.s.len();
        let mut basis = self.basis.clone();
        let mut null = Vec::new();
        while basis.len() < n {
            let best = (0..n)
                .map(|i| {
                    let mut e = vec![0.0; n];
                    e[i] = 1.0;
                    orthogonalize(&mut e, &basis);
                    e
                })
                .max_by(|a, b| dot(a, a).total_cmp(&dot(b, b)))
                .unwrap();
            let size = dot(&best, &best).sqrt();
            let q: Vec<f64> = best.iter().map(|x| x / size).collect();
            null.push(q.iter().zip(&self.s).map(|(a, b)| a * b).collect());
            basis.push(q);
        }
        null
    }
}

/// Inverts a small matrix (rows) by Gauss-Jordan with partial pivoting.
fn inverse(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .enumerate()
        .map(|(i, r)| r.iter().copied().chain((0..n).map(|j| f64::from(i == j))).collect())
        .collect();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs())).unwrap();
        m.swap(c, p);
        let d = m[c][c];
        m[c].iter_mut().for_each(|x| *x /= d);
        for r in 0..n {
            if r != c {
                let f = m[r][c];
                let pivot = m[c].clone();
                m[r].iter_mut().zip(&pivot).for_each(|(x, y)| *x -= f * y);
            }
        }
    }
    m.into_iter().map(|r| r[n..].to_vec()).collect()
}

/// The se(2) bracket `[X, Y]` as the commutator of the matrices
/// `[[0, -th, x], [th, 0, y], [0, 0, 0]]`, read back as `(x, y, th)`.
fn bracket(x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    let m = |v: [f64; 3]| [[0.0, -v[2], v[0]], [v[2], 0.0, v[1]], [0.0, 0.0, 0.0]];
    let (a, b) = (m(x), m(y));
    let c = |i: usize, j: usize| (0..3).map(|k| a[i][k] * b[k][j] - b[i][k] * a[k][j]).sum::<f64>();
    [c(0, 2), c(1, 2), c(1, 0)]
}

impl<'a, M: Model> Oracle<'a, M> {
    fn new(geo: &Geometry<M>, model: &'a M) -> Self {
        let info = model.info();
        let mut mass = vec![0.0; info.nq()];
        model.mass_diagonal(&mut mass);
        let free = geo
            .momentum_names()
            .iter()
            .map(|n| ["p_u", "p_v", "p_w"].iter().position(|p| p == n).unwrap_or_else(|| panic!("momentum {n}")))
            .collect();
        Self { model, info, mass, body: geo.body(), shape: geo.shape_hinges().to_vec(), free }
    }

    /// The reference body's velocity in its own frame at `(q, qd)`.
    fn xi(&self, q: &[f64], qd: &[f64]) -> [f64; 3] {
        let [i, j, k] = self.info.bodies[self.body].coords;
        let (s, c) = q[k].sin_cos();
        [c * qd[i] + s * qd[j], -s * qd[i] + c * qd[j], qd[k]]
    }

    /// The headings `(phi_a, phi_b)` (indices in `q`) whose difference is
    /// hinge `h`'s angle.
    fn angle(&self, h: usize) -> (usize, usize) {
        let hi = &self.info.hinges[h];
        (self.info.bodies[hi.body_a].coords[2], self.info.bodies[hi.body_b.unwrap()].coords[2])
    }

    /// The rows the oracle solves: the hinges' and the skates' rows of
    /// `G(q)` (not the drives'), then one row per shape coordinate,
    /// `qd[phi_a] - qd[phi_b]`.
    fn rows(&self, q: &[f64]) -> Vec<Vec<f64>> {
        let (nq, nc) = (self.info.nq(), self.info.nc());
        let mut values = vec![0.0; self.info.pattern.len()];
        self.model.constraint_matrix(q, &mut values);
        let mut g = vec![vec![0.0; nq]; nc];
        for (&(r, c), v) in self.info.pattern.iter().zip(&values) {
            g[r][c] = *v;
        }
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for h in &self.info.hinges {
            rows.extend([g[h.row].clone(), g[h.row + 1].clone()]);
        }
        rows.extend(self.info.skates.iter().map(|s| g[s.row].clone()));
        for &h in &self.shape {
            let (a, b) = self.angle(h);
            let mut row = vec![0.0; nq];
            row[a] += 1.0;
            row[b] -= 1.0;
            rows.push(row);
        }
        rows
    }

    /// ezy's configuration at shape `r`, checked: every hinge closed to
    /// 1e-12 m, the reference body's frame at the origin, each shape
    /// hinge's angle `r_k` to 1e-14 rad.
    fn configuration(&self, geo: &Geometry<M>, r: &[f64]) -> Vec<f64> {
        let q = geo.configuration(r).unwrap();
        let mut phi = vec![0.0; self.info.n_holonomic];
        self.model.phi(&q, &mut phi);
        for h in &self.info.hinges {
            assert!(phi[h.row].abs().max(phi[h.row + 1].abs()) <= 1e-12, "hinge {} open at shape {r:?}", h.name);
        }
        assert!(self.info.bodies[self.body].coords.iter().all(|&i| q[i] == 0.0), "the frame is not at the origin");
        for (k, &h) in self.shape.iter().enumerate() {
            let (a, b) = self.angle(h);
            assert!(
                (q[a] - q[b] - r[k]).abs() <= 1e-14 * r[k].abs().max(1.0),
                "shape {k}: {} against {}",
                q[a] - q[b],
                r[k]
            );
        }
        q
    }

    /// The momentum `p = P^-T N^T M qd` at `(q, qd)`: `N` the locked
    /// motions the constraints allow at `q` (M-orthonormal), `P` the rows
    /// of their body velocities that the free directions fix.
    fn momentum(&self, q: &[f64], qd: &[f64]) -> Vec<f64> {
        let null = Factor::new(&self.rows(q), &self.mass).null();
        let x: Vec<[f64; 3]> = null.iter().map(|n| self.xi(q, n)).collect();
        let p: Vec<Vec<f64>> = self.free.iter().map(|&f| x.iter().map(|xl| xl[f]).collect()).collect();
        let c: Vec<f64> = null.iter().map(|n| (0..qd.len()).map(|i| n[i] * self.mass[i] * qd[i]).sum()).collect();
        // P^-T c
        let pi = inverse(&p);
        (0..p.len()).map(|i| (0..p.len()).map(|j| pi[j][i] * c[j]).sum()).collect()
    }

    /// The connection at shape `r`, or the count of dependent rows where
    /// the constraints lose rank (the singular set).
    fn connection(&self, geo: &Geometry<M>, r: &[f64]) -> Result<Connection, usize> {
        let q = self.configuration(geo, r);
        let rows = self.rows(&q);
        let f = Factor::new(&rows, &self.mass);
        if f.dependent > 0 {
            return Err(f.dependent);
        }
        let ns = self.shape.len();
        let mut a = vec![0.0; 3 * ns];
        for k in 0..ns {
            let mut b = vec![0.0; rows.len()];
            b[rows.len() - ns + k] = 1.0;
            let xi = self.xi(&q, &f.solve(&b));
            (0..3).for_each(|c| a[c * ns + k] = -xi[c]);
        }
        let null = f.null();
        let x: Vec<[f64; 3]> = null.iter().map(|n| self.xi(&q, n)).collect();
        let m = null.len();
        assert_eq!(m, self.free.len(), "the oracle's locked motions against ezy's momentum count at {r:?}");
        let p: Vec<Vec<f64>> = self.free.iter().map(|&f| x.iter().map(|xl| xl[f]).collect()).collect();
        // Gamma = X P^T
        let gamma = (0..3)
            .flat_map(|c| (0..m).map(move |j| (c, j)))
            .map(|(c, j)| (0..m).map(|l| x[l][c] * p[j][l]).sum())
            .collect();
        Ok(Connection { a, gamma })
    }

    /// `dA/dr_k` (ns blocks of 3 x ns, as ezy's `da`) by Richardson's
    /// extrapolation of central differences at h = 1e-4 and 5e-5 rad, and
    /// the extrapolation's change per entry.
    fn da(&self, geo: &Geometry<M>, r: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let ns = r.len();
        let (mut da, mut change) = (Vec::new(), Vec::new());
        for k in 0..ns {
            let central = |h: f64| {
                let (mut p, mut m) = (r.to_vec(), r.to_vec());
                p[k] += h;
                m[k] -= h;
                let (ap, am) = (self.connection(geo, &p).unwrap().a, self.connection(geo, &m).unwrap().a);
                ap.iter().zip(&am).map(|(x, y)| (x - y) / (2.0 * h)).collect::<Vec<_>>()
            };
            let (d1, d2) = (central(1e-4), central(5e-5));
            for (a, b) in d1.iter().zip(&d2) {
                let rich = b + (b - a) / 3.0;
                da.push(rich);
                change.push((rich - b).abs());
            }
        }
        (da, change)
    }
}

/// The height functions `D(-A)_ij = -(dA_j/dr_i - dA_i/dr_j) + [A_i,
/// A_j]` for pairs `i < j` from `A` and `dA/dr` (ezy's layouts), and each
/// one's error from `da`'s (`change`).
fn heights(a: &[f64], da: &[f64], change: &[f64], ns: usize) -> (Vec<[f64; 3]>, Vec<f64>) {
    let (mut h, mut err) = (Vec::new(), Vec::new());
    let col = |k: usize| [a[k], a[ns + k], a[2 * ns + k]];
    for i in 0..ns {
        for j in i + 1..ns {
            let b = bracket(col(i), col(j));
            let at = |k: usize, c: usize, l: usize| k * 3 * ns + c * ns + l;
            h.push(std::array::from_fn(|c| -(da[at(i, c, j)] - da[at(j, c, i)]) + b[c]));
            err.push((0..3).map(|c| change[at(i, c, j)] + change[at(j, c, i)]).fold(0.0, f64::max));
        }
    }
    (h, err)
}

/// The largest size in `v`.
fn largest<'b>(v: impl IntoIterator<Item = &'b f64>) -> f64 {
    v.into_iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Checks ezy's connection, `dA/dr` and heights at each of `shapes`
/// against the oracle: `A` and `Gamma` to 1e-12 of their largest entry
/// (at least 1e-3, for a connection held at 0 by symmetry: the
/// snakeboard's with its wheels straight), both sides being solves of a
/// few well-conditioned equations, exact to rounding (measured at most
/// 1e-14); with two shape coordinates or more, `dA/dr` to 1e-8 of its
/// largest entry (at least 1e-3) plus three times the extrapolation's
/// change, which must stay below 1e-6 of it (truncation after the
/// extrapolation `O(h^4)`, about 1e-15; the connection's rounding over h
/// = 5e-5 about 1e-11; measured within 3e-10); the heights to 1e-8 of
/// the larger of their largest and `dA/dr`'s largest (they are
/// differences of `dA/dr`'s entries) plus three times their inputs'
/// changes. Returns the worst deviations `(A, dA, D(-A))` relative to
/// those scales.
fn check_shapes<M: Model>(name: &str, geo: &Geometry<M>, model: &M, shapes: &[Vec<f64>]) -> [f64; 3] {
    let oracle = Oracle::new(geo, model);
    let ns = geo.n_shape();
    let mut worst = [0.0f64; 3];
    for r in shapes {
        let want =
            oracle.connection(geo, r).unwrap_or_else(|d| panic!("{name}: {r:?} singular for the oracle ({d} rows)"));
        let got = if ns >= 2 { geo.curvature(r).unwrap().connection } else { geo.connection(r).unwrap() };
        for (what, g, w) in [("A", &got.a, &want.a), ("Gamma", &got.gamma, &want.gamma)] {
            assert_eq!(g.len(), w.len(), "{name}: {what} has {} entries, the oracle's {}", g.len(), w.len());
            let scale = largest(w.iter()).max(1e-3);
            for (i, (x, y)) in g.iter().zip(w.iter()).enumerate() {
                worst[0] = worst[0].max((x - y).abs() / scale);
                assert!((x - y).abs() <= 1e-12 * scale, "{name} at {r:?}: {what}[{i}] = {x:e} against {y:e}");
            }
        }
        if ns < 2 {
            continue;
        }
        let c = geo.curvature(r).unwrap();
        let (da, change) = oracle.da(geo, r);
        let scale = largest(da.iter()).max(1e-3);
        for (i, ((x, y), e)) in c.da.iter().zip(&da).zip(&change).enumerate() {
            assert!(*e <= 1e-6 * scale, "{name} at {r:?}: dA[{i}]: the differences did not settle ({e:.1e})");
            worst[1] = worst[1].max((x - y).abs() / scale);
            assert!((x - y).abs() <= 1e-8 * scale + 3.0 * e, "{name} at {r:?}: dA[{i}] = {x:e} against {y:e}");
        }
        let (h, err) = heights(&want.a, &da, &change, ns);
        let scale = largest(h.iter().flatten()).max(scale);
        for (p, ((x, y), e)) in c.height.iter().zip(&h).zip(&err).enumerate() {
            for k in 0..3 {
                worst[2] = worst[2].max((x[k] - y[k]).abs() / scale);
                assert!(
                    (x[k] - y[k]).abs() <= 1e-8 * scale + 3.0 * e,
                    "{name} at {r:?}: D(-A) pair {p} component {k} = {:e} against {:e}",
                    x[k],
                    y[k]
                );
            }
        }
    }
    eprintln!(
        "{name}: {} shape(s); A, Gamma within {:.1e} of the largest{}",
        shapes.len(),
        worst[0],
        if ns < 2 { String::new() } else { format!(", dA/dr {:.1e}, D(-A) {:.1e}", worst[1], worst[2]) }
    );
    worst
}

/// `g0^-1 g1` for poses `(x, y, theta)`: `g1` in the frame of `g0`.
fn relative(g0: [f64; 3], g1: [f64; 3]) -> [f64; 3] {
    let (s, c) = g0[2].sin_cos();
    let (dx, dy) = (g1[0] - g0[0], g1[1] - g0[1]);
    [c * dx + s * dy, -s * dx + c * dy, g1[2] - g0[2]]
}

/// Gauss-Legendre nodes and weights on [0, 1], `n` points (Newton on the
/// Legendre polynomial from Chebyshev guesses).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            ((1.0 - x) / 2.0, 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// `-oint A(r) dr` over `gait` by the trapezoidal rule on `n` samples of
/// the period (geometric convergence for a smooth periodic integrand),
/// with the oracle's connection.
fn loop_integral<M: Model>(oracle: &Oracle<'_, M>, geo: &Geometry<M>, gait: &Gait, n: usize) -> [f64; 3] {
    let ns = geo.n_shape();
    let mut total = [0.0; 3];
    for i in 0..n {
        let (r, rd) = gait.at(gait.period * i as f64 / n as f64);
        let a = oracle.connection(geo, &r).unwrap().a;
        for (c, t) in total.iter_mut().enumerate() {
            *t -= (0..ns).map(|k| a[c * ns + k] * rd[k]).sum::<f64>() * gait.period / n as f64;
        }
    }
    total
}

/// The area integral of `[A_1, A_2]` over the disc of `centre` and
/// `radius` in a plane of two shape coordinates: in polar coordinates,
/// Gauss-Legendre on `n` nodes in the radius (the integrand times `s`)
/// and the trapezoidal rule on `4 n` angles.
fn disc_bracket<M: Model>(
    oracle: &Oracle<'_, M>,
    geo: &Geometry<M>,
    centre: [f64; 2],
    radius: f64,
    n: usize,
) -> [f64; 3] {
    let mut total = [0.0; 3];
    let angles = 4 * n;
    for (x, w) in gauss_legendre(n) {
        let s = radius * x;
        for k in 0..angles {
            let th = std::f64::consts::TAU * k as f64 / angles as f64;
            let a = oracle.connection(geo, &[centre[0] + s * th.cos(), centre[1] + s * th.sin()]).unwrap().a;
            let b = bracket([a[0], a[2], a[4]], [a[1], a[3], a[5]]);
            let weight = w * radius * s * std::f64::consts::TAU / angles as f64;
            (0..3).for_each(|c| total[c] += b[c] * weight);
        }
    }
    total
}

/// A run of `problem` over one `period` (DOP853 at 1e-12, 2000 samples):
/// the reference body's net motion in its initial frame, its
/// body-velocity integral by Simpson's rule, the states at the start and
/// the end.
fn run_gait<M: Model>(
    oracle: &Oracle<'_, M>,
    problem: Problem<M>,
    period: f64,
) -> ([f64; 3], [f64; 3], Vec<f64>, Vec<f64>) {
    let n = 2000;
    let s =
        problem.t_end(period).every(period / n as f64).method(Method::Dop853).tolerances(1e-12, 1e-12).solve().unwrap();
    assert_eq!(s.t.len(), n + 1, "the run's samples");
    assert!(s.t.iter().enumerate().all(|(i, t)| (t - period * i as f64 / n as f64).abs() <= 1e-12 * period));
    let nq = oracle.info.nq();
    let [i, j, k] = oracle.info.bodies[oracle.body].coords;
    let pose = |y: &[f64]| [y[i], y[j], y[k]];
    let (first, last) = (&s.y[0], &s.y[n]);
    let net = relative(pose(first), pose(last));
    let mut integral = [0.0; 3];
    for (m, y) in s.y.iter().enumerate() {
        let w = if m == 0 || m == n {
            1.0
        } else if m % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let xi = oracle.xi(&y[..nq], &y[nq..2 * nq]);
        (0..3).for_each(|c| integral[c] += w * xi[c] * period / (3.0 * n as f64));
    }
    (net, integral, first[..2 * nq].to_vec(), last[..2 * nq].to_vec())
}

/// The gait the scene's drives prescribe on the shape hinges, of `period`.
fn scene_gait<M: Model>(geo: &Geometry<M>, problem: &Problem<M>, period: f64) -> Gait {
    let info = geo.info();
    let shape = geo
        .shape_hinges()
        .iter()
        .map(|&h| {
            let d = info.drives.iter().find(|d| d.hinge == h).unwrap();
            problem.drives.iter().find(|x| x.name == d.name).unwrap().angle.clone()
        })
        .collect();
    Gait::new(shape, period).unwrap()
}

/// The size of the largest difference of two triples.
fn gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// Checks ezy's prediction of the gait the scene's drives prescribe
/// (period `period`) against a run of the scene over one period from its
/// initial state (ezy's prediction from the momentum the oracle gives
/// that state): the reconstructed net motion against the run's, the
/// first order (the body-velocity integral) against Simpson's rule on
/// the run, the momentum at the end against the oracle's at the run's
/// end, each to 1e-9 of its size (at least 1: the run and the
/// reconstruction at 1e-12 agree to about 1e-11; Simpson's error on 2000
/// intervals about 1e-13); and ezy's momentum of the initial state
/// (what `ezy geometry` starts from) against the oracle's to 1e-12.
/// Returns the prediction.
fn check_gait<M: Model>(name: &str, problem: Problem<M>, period: f64) -> ezy_core::geometry::GaitPrediction {
    let model = problem.model.clone();
    let (analysis, _) = problem.clone().analysis().unwrap();
    let mut geo = Geometry::new(model.clone(), None, None).unwrap().with_forces(analysis).unwrap();
    let oracle = Oracle::new(&geo, &model);
    let gait = scene_gait(&geo, &problem, period);
    let (net, integral, start, end) = run_gait(&oracle, problem, period);
    let nq = oracle.info.nq();
    let (r0, _) = gait.at(0.0);
    for (k, &h) in oracle.shape.iter().enumerate() {
        let (a, b) = oracle.angle(h);
        assert!((start[a] - start[b] - r0[k]).abs() < 1e-12, "{name}: the run does not start on the gait");
    }
    let p0 = oracle.momentum(&start[..nq], &start[nq..]);
    let ezy_p0 = geo.momentum(&start[..nq], &start[nq..]).unwrap();
    assert!(gap(&p0, &ezy_p0) <= 1e-12 * largest(p0.iter()).max(1.0), "{name}: momentum {ezy_p0:?} against {p0:?}");
    let pred = geo.predict(&gait, &p0).unwrap();
    let p_end = oracle.momentum(&end[..nq], &end[nq..]);
    let mut worst = 0.0f64;
    for (what, got, want) in [
        ("reconstructed", &pred.reconstructed[..], &net[..]),
        ("first order", &pred.first[..], &integral[..]),
        ("momentum at the end", &pred.momentum.1[..], &p_end[..]),
    ] {
        let scale = largest(want.iter()).max(1.0);
        eprintln!("{name}: {what} {got:?} against the run's {want:?}");
        worst = worst.max(gap(got, want) / scale);
        assert!(gap(got, want) <= 1e-9 * scale, "{name}: {what} {got:?} against the run's {want:?}");
    }
    eprintln!("{name}: the gait within {worst:.1e} of the run's");
    pred
}

/// The kinematic snake's scene's gait (a circle of radius 0.6 about
/// (0.9, -0.9), counter-clockwise): `-oint A dr` (the first order) and
/// the bracket's area integral (the second order's addition) by the
/// oracle's quadratures, each at two resolutions whose difference (the
/// quadrature's error, asserted below 1e-11) is the oracle's own error.
fn snake_gait_quadratures(geo: &Geometry<KinematicSnake>, model: &KinematicSnake, gait: &Gait) -> ([f64; 3], [f64; 3]) {
    let oracle = Oracle::new(geo, model);
    let (f1, f2) = (loop_integral(&oracle, geo, gait, 200), loop_integral(&oracle, geo, gait, 400));
    assert!(gap(&f1, &f2) <= 1e-11, "-oint A dr did not converge: {f1:?} {f2:?}");
    let (b1, b2) = (disc_bracket(&oracle, geo, [0.9, -0.9], 0.6, 12), disc_bracket(&oracle, geo, [0.9, -0.9], 0.6, 16));
    assert!(gap(&b1, &b2) <= 1e-11, "the bracket's area integral did not converge: {b1:?} {b2:?}");
    (f2, std::array::from_fn(|c| f2[c] + b2[c]))
}

/// `ezy geometry kinematic-snake` through the command line: every row of
/// connection.csv and curvature.csv on a 9 x 9 grid against the oracle
/// (as [`check_shapes`]), the shapes left out exactly those where the
/// oracle's constraints lose rank (the diagonal `alpha1 = alpha2`), and
/// gait.csv's four rows: the first and second order against the
/// oracle's quadratures (to 1e-10: the quadratures' errors are below
/// 1e-11 and ezy's trapezoidal and Gauss-Legendre rules on 200 samples
/// converge as fast), the reconstructed and the simulated motion against
/// a run of the scene over one period (to 1e-9).
#[test]
fn the_commands_connection_curvature_and_gait_are_the_oracles() {
    let dir = fresh("oracle-geometry");
    let (said, err, ok) = ezy(&["geometry", "kinematic-snake", "--grid", "9", "--rtol", "1e-12", "--no-figures"], &dir);
    assert!(ok, "{said}{err}");
    let scene = scenes::get("kinematic-snake");
    let (problem, _) = scene.problem_with(KinematicSnake::default(), &[]).unwrap();
    let model = problem.model.clone();
    let geo = Geometry::new(model.clone(), None, None).unwrap();
    let oracle = Oracle::new(&geo, &model);
    let number = |s: &String| s.parse::<f64>().unwrap();
    let (head, rows) = table(&dir.join("connection.csv"));
    assert_eq!(
        head[..8],
        ["alpha1", "alpha2", "A_u_alpha1", "A_u_alpha2", "A_v_alpha1", "A_v_alpha2", "A_w_alpha1", "A_w_alpha2"]
    );
    let (chead, crows) = table(&dir.join("curvature.csv"));
    assert_eq!(chead, ["alpha1", "alpha2", "DA_x_alpha1_alpha2", "DA_y_alpha1_alpha2", "DA_theta_alpha1_alpha2"]);
    let axis: Vec<f64> = (0..9).map(|i| -2.5 + 5.0 * i as f64 / 8.0).collect();
    let (mut worst, mut present) = ([0.0f64; 3], 0);
    for a1 in &axis {
        for a2 in &axis {
            let r = [*a1, *a2];
            let row = rows.iter().position(|x| number(&x[0]) == r[0] && number(&x[1]) == r[1]);
            let Ok(want) = oracle.connection(&geo, &r) else {
                assert!(row.is_none(), "{r:?}: singular for the oracle, in connection.csv");
                continue;
            };
            let k = row.unwrap_or_else(|| panic!("{r:?}: regular for the oracle, not in connection.csv"));
            present += 1;
            let got: Vec<f64> = rows[k][2..8].iter().map(number).collect();
            let scale = largest(want.a.iter());
            worst[0] = worst[0].max(gap(&got, &want.a) / scale);
            assert!(gap(&got, &want.a) <= 1e-12 * scale, "{r:?}: A {got:?} against {:?}", want.a);
            let (da, change) = oracle.da(&geo, &r);
            let (h, e) = heights(&want.a, &da, &change, 2);
            let crow = crows.iter().find(|x| number(&x[0]) == r[0] && number(&x[1]) == r[1]).unwrap();
            let got: Vec<f64> = crow[2..5].iter().map(number).collect();
            let scale = largest(h[0].iter()).max(largest(da.iter()));
            worst[2] = worst[2].max(gap(&got, &h[0]) / scale);
            assert!(e[0] <= 1e-6 * scale, "{r:?}: the differences did not settle ({:.1e})", e[0]);
            assert!(gap(&got, &h[0]) <= 1e-8 * scale + 3.0 * e[0], "{r:?}: D(-A) {got:?} against {:?}", h[0]);
        }
    }
    assert_eq!((present, rows.len(), crows.len()), (72, 72, 72), "the grid less its diagonal");
    let (_, g) = table(&dir.join("gait.csv"));
    let method =
        |label: &str| -> Vec<f64> { g.iter().find(|r| r[0] == label).unwrap()[1..4].iter().map(number).collect() };
    let gait = scene_gait(&geo, &problem, std::f64::consts::TAU);
    let (first, second) = snake_gait_quadratures(&geo, &model, &gait);
    let (net, integral, _, _) = run_gait(&oracle, problem, gait.period);
    for (label, want, tol) in [
        ("first-order", &first, 1e-10),
        ("first-order", &integral, 1e-9),
        ("second-order", &second, 1e-10),
        ("reconstructed", &net, 1e-9),
        ("simulated", &net, 1e-9),
    ] {
        let got = method(label);
        eprintln!("gait.csv {label}: {got:?} against {want:?} ({:.1e})", gap(&got, want));
        assert!(gap(&got, want) <= tol, "{label}: {got:?} against {want:?}");
    }
    eprintln!("kinematic-snake grid: A within {:.1e}, D(-A) within {:.1e} of the largest", worst[0], worst[2]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A shape of `n` coordinates along a serpenoid curve `0.5 sin(0.7 k +
/// phase)`.
fn serpenoid(n: usize, phase: f64) -> Vec<f64> {
    (0..n).map(|k| 0.5 * (0.7 * k as f64 + phase).sin()).collect()
}

/// The scene's model at its parameters.
fn scene_model<M: Model + Default>(name: &str) -> M {
    scenes::get(name).problem_with(M::default(), &[]).unwrap().0.model
}

/// Checks the scene's connection (and curvature) at `shapes`.
fn check_scene<M: Model + Default>(name: &str, shapes: &[Vec<f64>]) -> [f64; 3] {
    let model: M = scene_model(name);
    let geo = Geometry::new(model.clone(), None, None).unwrap();
    check_shapes(name, &geo, &model, shapes)
}

/// Every built-in scene `ezy geometry` accepts: the kinematic snake
/// (kinematic, two shapes), the EzyRoller of the drive scenes and with its
/// fork prescribed (mixed, one shape, one momentum), the Chaplygin sleigh
/// (no shape, two momenta: `Gamma` alone), the snakeboard (three shapes,
/// one momentum), the ten- and thirty-link snakes without skates (the
/// mechanical connection: nine and 29 shapes, three momenta), as
/// [`check_shapes`].
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn every_scenes_connection_and_curvature_are_the_constraints_solved() {
    let snake = [[0.5, -0.3], [1.0, 0.2], [-0.7, 0.9], [2.0, -2.0], [-1.5, 0.4]].map(|r| r.to_vec());
    check_scene::<KinematicSnake>("kinematic-snake", &snake);
    let fork = [[-3.0], [-2.6], [2.0], [0.7], [-1.2]].map(|r| r.to_vec());
    for name in ["drive", "drive-rolling-resistance", "drive-slip", "drive-damped-hinge", "free"] {
        check_scene::<EzyRoller>(name, &fork);
    }
    check_scene::<EzyRollerDriven>("drive-prescribed", &fork);
    for name in ["sleigh", "sleigh-drag", "sleigh-ice"] {
        check_scene::<ChaplyginSleigh>(name, &[Vec::new()]);
    }
    let board = [[0.3, -0.2, 0.5], [0.4, -0.4, 0.8], [-0.5, 0.1, -1.0], [0.0, 0.0, 0.3]].map(|r| r.to_vec());
    check_scene::<Snakeboard>("snakeboard", &board);
    check_scene::<SnakeServo>("snake-stiff", &[serpenoid(9, 0.0), serpenoid(9, 1.3)]);
    check_scene::<SnakeDriven>("snake-long", &[serpenoid(29, 0.4)]);
}

/// The user's sleighs with a rotor typed as text (`rotor_drive.ezy`,
/// `rotor_sleigh.ezy`: one shape, one momentum each), and a user's
/// three-link kinematic snake typed here with unequal links and its
/// middle skate off the link's centre (two shapes: the curvature), as
/// [`check_shapes`].
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn a_text_models_connection_and_curvature_are_the_constraints_solved() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    for file in ["rotor_drive.ezy", "rotor_sleigh.ezy"] {
        let model = RuntimeModel::from_file(&data.join(file)).unwrap();
        let geo = Geometry::new(model.clone(), None, None).unwrap();
        check_shapes(file, &geo, &model, &[vec![0.4], vec![2.0], vec![-1.0]]);
    }
    let model = RuntimeModel::from_text(SNAKE).unwrap();
    let geo = Geometry::new(model.clone(), Some("middle"), None).unwrap();
    let shapes = [[0.5, -0.3], [1.0, 0.2], [-0.7, 0.9], [-1.5, 0.4]].map(|r| r.to_vec());
    check_shapes("a user's snake", &geo, &model, &shapes);
}

/// A three-link kinematic snake of unequal links (0.9, 0.6, 0.7 m),
/// the middle link's skate 0.1 m ahead of its centre.
const SNAKE: &str = r"
pub struct Lopsided {
    param l1 = 0.9;
    param l2 = 0.6;
    param l3 = 0.7;
    body rear(x1, y1, phi1) { mass: 1.2, inertia: 0.08 }
    body middle(x2, y2, phi2) { mass: 0.8, inertia: 0.03 }
    body front(x3, y3, phi3) { mass: 1.0, inertia: 0.05 }
    point S1 on rear at (0, 0);
    point R on rear at (l1 / 2, 0);
    point M0 on middle at (-l2 / 2, 0);
    point S2 on middle at (0.1, 0);
    point M1 on middle at (l2 / 2, 0);
    point F on front at (-l3 / 2, 0);
    point S3 on front at (0, 0);
    hinge a1: M0 = R;
    hinge a2: F = M1;
    skate S1: S1 along (1, 0);
    skate S2: S2 along (1, 0);
    skate S3: S3 along (1, 0);
}
";

/// The gaits the scenes' drives prescribe, predicted against runs of the
/// scenes (as [`check_gait`]): the kinematic snake (also its first and
/// second order against the oracle's quadratures, as the command's check
/// does), the EzyRoller with its fork prescribed, the snakeboard, and the
/// user's sleigh with a prescribed rotor and drag typed as text (the
/// momentum equation with the scene's forces).
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn the_scenes_gaits_are_their_runs() {
    let scene = scenes::get("kinematic-snake");
    let (problem, _) = scene.problem_with(KinematicSnake::default(), &[]).unwrap();
    let pred = check_gait("kinematic-snake", problem.clone(), std::f64::consts::TAU);
    let geo = Geometry::new(problem.model.clone(), None, None).unwrap();
    let gait = scene_gait(&geo, &problem, std::f64::consts::TAU);
    let (first, second) = snake_gait_quadratures(&geo, &problem.model, &gait);
    assert!(gap(&pred.first, &first) <= 1e-10 && gap(&pred.second.unwrap(), &second) <= 1e-10, "{pred:?}");
    let (problem, _) = scenes::get("drive-prescribed").problem_with(EzyRollerDriven::default(), &[]).unwrap();
    check_gait("drive-prescribed", problem, 2.0);
    let (problem, _) = scenes::get("snakeboard").problem_with(Snakeboard::default(), &[]).unwrap();
    check_gait("snakeboard", problem, 2.0);
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let model = RuntimeModel::from_file(&data.join("rotor_drive.ezy")).unwrap();
    let (scene, _) = Scene::read(&data.join("rotor-drive.toml")).unwrap();
    let (problem, _) = scene.problem_with(model, &[]).unwrap();
    check_gait("rotor-drive", problem, std::f64::consts::TAU / 3.0);
}

/// Small circular gaits of radius `eps` about (0.6, -0.4) on the
/// kinematic snake, run by the scene with its drives prescribing them:
/// the run's net motion less the second order, and less the height
/// function at the centre times the area `pi eps^2`, shrink like `eps^3`
/// (observed order between 2.6 and 3.4 from each halving of eps = 0.2,
/// 0.1, 0.05), less the first order like `eps^2` (1.6 to 2.4): the sign
/// and size of the curvature, and the Lie bracket's, against physics.
#[test]
#[ignore = "the whole harness: cargo test --release --test suite -- --include-ignored oracle::"]
fn small_gaits_move_as_the_curvature_predicts() {
    let scene = scenes::get("kinematic-snake");
    let (base, _) = scene.problem_with(KinematicSnake::default(), &[]).unwrap();
    let model = base.model.clone();
    let mut geo = Geometry::new(model.clone(), None, None).unwrap();
    let oracle = Oracle::new(&geo, &model);
    let height = geo.curvature(&[0.6, -0.4]).unwrap().height[0];
    let harmonic = |amplitude: f64, omega: f64, phase: f64| Harmonic { amplitude, omega, phase, phase_step: 0.0 };
    let mut errors = Vec::new();
    for eps in [0.2, 0.1, 0.05] {
        let w1 = Waveform::Harmonics(vec![harmonic(0.6, 0.0, 0.0), harmonic(eps, 1.0, 0.0)]);
        let w2 = Waveform::Harmonics(vec![harmonic(-0.4, 0.0, 0.0), harmonic(eps, 1.0, -std::f64::consts::FRAC_PI_2)]);
        let problem = base.clone().drive("D1", w1.clone()).unwrap().drive("D2", w2.clone()).unwrap();
        let (net, _, _, _) = run_gait(&oracle, problem, std::f64::consts::TAU);
        let pred = geo.predict(&Gait::new(vec![w1, w2], std::f64::consts::TAU).unwrap(), &[]).unwrap();
        let area = std::f64::consts::PI * eps * eps;
        let e = [gap(&net, &pred.second.unwrap()), gap(&net, &height.map(|h| h * area)), gap(&net, &pred.first)];
        eprintln!(
            "eps {eps}: net {net:?}; off the second order {:.2e}, the height times the area {:.2e}, the first order {:.2e}",
            e[0], e[1], e[2]
        );
        errors.push(e);
    }
    for w in errors.windows(2) {
        let order = |k: usize| (w[0][k] / w[1][k]).log2();
        eprintln!("observed orders: second {:.2}, height {:.2}, first {:.2}", order(0), order(1), order(2));
        assert!((2.6..3.4).contains(&order(0)) && (2.6..3.4).contains(&order(1)), "{errors:?}");
        assert!((1.6..2.4).contains(&order(2)), "{errors:?}");
    }
}
