//! Small dense LU factorizations for the reduced formulation: partial
//! pivoting of the square `G_D` (unrolled for the sizes up to 4 that
//! vehicles have, general above), and full pivoting of `G` to choose the
//! dependent coordinates (Wehage & Haug's partition, preferring
//! translations). Row-major, in place; nothing allocated per call.

use crate::kkt::spd::small_size;

/// A pivot taken from a preferred column when it is at least this
/// fraction of the largest remaining entry.
const PREFER: f64 = 0.25;

/// A pivot below this fraction of its row's largest entry means the rows
/// are dependent at this state.
const RANK_TOL: f64 = 1e-10;

/// A dense LU factorization with partial pivoting of an `n x n` matrix,
/// in place (row-major).
#[derive(Debug, Clone)]
pub(crate) struct SquareLu {
    n: usize,
    a: Vec<f64>,
    piv: Vec<usize>,
}

impl SquareLu {
    pub(crate) fn new(n: usize) -> Self {
        Self { n, a: vec![0.0; n * n], piv: vec![0; n] }
    }

    /// Factors the `n x n` row-major `src` into `a`; returns
    /// `min |u_ii| / max |u_ii|` (1 for `n = 0`), 0 if a pivot vanished.
    /// Sizes up to 8 run unrolled code.
    pub(crate) fn factor(&mut self, src: &[f64]) -> f64 {
        match self.n {
            0 => 1.0,
            n => small_size!(n, lu_fixed(src, &mut self.a, &mut self.piv), {
                self.a.copy_from_slice(&src[..n * n]);
                lu_any(n, &mut self.a, &mut self.piv)
            }),
        }
    }

    /// `b <- A^-1 b` with the factors of [`SquareLu::factor`].
    pub(crate) fn solve(&self, b: &mut [f64]) {
        match self.n {
            0 => {}
            n => small_size!(n, solve_fixed(&self.a, &self.piv, b), solve_any(n, &self.a, &self.piv, b)),
        }
    }
}

/// LU with partial pivoting of the `N x N` row-major `a` at a size known
/// at compile time (loops the compiler unrolls); see [`SquareLu::factor`].
#[inline]
#[expect(
    clippy::needless_range_loop,
    reason = "index loops unroll; iterators with skip(k) did not (3x the instructions)"
)]
fn lu_fixed<const N: usize>(src: &[f64], a: &mut [f64], piv: &mut [usize]) -> f64 {
    let (src, a) = (&src[..N * N], &mut a[..N * N]);
    let mut m = [[0.0; N]; N];
    // element by element: a slice copy of a few numbers is a memcpy call
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = src[i * N + j];
        }
    }
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    let mut bad = false;
    // plain index loops without an early exit: the compiler unrolls them
    // (a vanished or NaN pivot leaves non-finite factors, never read)
    for k in 0..N {
        let mut p = k;
        let mut best = m[k][k].abs();
        for i in k + 1..N {
            if m[i][k].abs() > best {
                p = i;
                best = m[i][k].abs();
            }
        }
        piv[k] = p;
        if p != k {
            let (top, bottom) = m.split_at_mut(p);
            std::mem::swap(&mut top[k], &mut bottom[0]);
        }
        bad |= !(best > 0.0 && best.is_finite());
        lo = if best < lo { best } else { lo };
        hi = if best > hi { best } else { hi };
        let d = m[k][k];
        for i in k + 1..N {
            let l = m[i][k] / d;
            m[i][k] = l;
            for j in k + 1..N {
                m[i][j] -= l * m[k][j];
            }
        }
    }
    for (i, row) in m.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            a[i * N + j] = v;
        }
    }
    if bad { 0.0 } else { lo / hi }
}

/// [`SquareLu::solve`] at a size known at compile time.
#[inline]
fn solve_fixed<const N: usize>(a: &[f64], piv: &[usize], b: &mut [f64]) {
    let (a, b) = (&a[..N * N], &mut b[..N]);
    let mut x = [0.0; N];
    for (x, &v) in x.iter_mut().zip(b.iter()) {
        *x = v;
    }
    for (k, &p) in piv.iter().enumerate().take(N) {
        x.swap(k, p);
    }
    for i in 1..N {
        for j in 0..i {
            x[i] -= a[i * N + j] * x[j];
        }
    }
    for i in (0..N).rev() {
        for j in i + 1..N {
            x[i] -= a[i * N + j] * x[j];
        }
        x[i] /= a[i * N + i];
    }
    for (v, &x) in b.iter_mut().zip(&x) {
        *v = x;
    }
}

/// [`SquareLu::factor`] at any size.
fn lu_any(n: usize, a: &mut [f64], piv: &mut [usize]) -> f64 {
    let a = &mut a[..n * n];
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for k in 0..n {
        let mut p = k;
        let mut best = a[k * n + k].abs();
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            if v > best {
                (p, best) = (i, v);
            }
        }
        piv[k] = p;
        if p != k {
            let (top, bottom) = a.split_at_mut(p * n);
            top[k * n..k * n + n].swap_with_slice(&mut bottom[..n]);
        }
        lo = lo.min(best);
        hi = hi.max(best);
        if best == 0.0 || !best.is_finite() {
            return 0.0;
        }
        let (upper, lower) = a.split_at_mut((k + 1) * n);
        let pivot_row = &upper[k * n + k..k * n + n];
        for row in lower.chunks_exact_mut(n) {
            let row = &mut row[k..];
            let l = row[0] / pivot_row[0];
            row[0] = l;
            for (x, &u) in row[1..].iter_mut().zip(&pivot_row[1..]) {
                *x -= l * u;
            }
        }
    }
    lo / hi
}

/// [`SquareLu::solve`] at any size.
fn solve_any(n: usize, a: &[f64], piv: &[usize], b: &mut [f64]) {
    let (a, b) = (&a[..n * n], &mut b[..n]);
    for (k, &p) in piv.iter().enumerate() {
        b.swap(k, p);
    }
    for i in 1..n {
        let s: f64 = a[i * n..i * n + i].iter().zip(&b[..i]).map(|(x, y)| x * y).sum();
        b[i] -= s;
    }
    for i in (0..n).rev() {
        let row = &a[i * n + i..i * n + n];
        let s: f64 = row[1..].iter().zip(&b[i + 1..]).map(|(x, y)| x * y).sum();
        b[i] = (b[i] - s) / row[0];
    }
}

/// The pivot columns of Gaussian elimination with full pivoting on the
/// `m x n` row-major `a` (destroyed), rows equilibrated first; a column
/// with `prefer[j]` is taken when its best entry is at least [`PREFER`]
/// times the largest remaining one.
///
/// # Errors
/// The number of rows eliminated before the rest vanished (dependent rows).
pub(crate) fn pivot_columns(a: &mut [f64], m: usize, n: usize, prefer: &[bool]) -> Result<Vec<usize>, usize> {
    for row in a.chunks_exact_mut(n) {
        let s = row.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        if s > 0.0 {
            row.iter_mut().for_each(|v| *v /= s);
        }
    }
    let mut rows: Vec<usize> = (0..m).collect();
    let mut cols_left: Vec<bool> = vec![true; n];
    let mut chosen = Vec::with_capacity(m);
    for k in 0..m {
        let (mut best, mut best_pref) = ((0.0f64, 0, 0), (0.0f64, 0, 0));
        for (ri, &i) in rows.iter().enumerate().skip(k) {
            for j in (0..n).filter(|&j| cols_left[j]) {
                let v = a[i * n + j].abs();
                if v > best.0 {
                    best = (v, ri, j);
                }
                if prefer[j] && v > best_pref.0 {
                    best_pref = (v, ri, j);
                }
            }
        }
        if best.0 <= RANK_TOL {
            return Err(k);
        }
        let (_, ri, j) = if best_pref.0 >= PREFER * best.0 { best_pref } else { best };
        rows.swap(k, ri);
        let p = rows[k];
        cols_left[j] = false;
        chosen.push(j);
        let d = a[p * n + j];
        for &i in &rows[k + 1..] {
            let l = a[i * n + j] / d;
            if l != 0.0 {
                for c in 0..n {
                    a[i * n + c] -= l * a[p * n + c];
                }
            }
        }
    }
    Ok(chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unrolled_and_general_lu_agree() {
        // a 9 x 9 system (general path) and its leading 5 x 5 (unrolled)
        for n in [5, 9] {
            let a: Vec<f64> = (0..n * n)
                .map(|k| ((k * 7919 % 101) as f64 / 50.0 - 1.0) + if k % (n + 1) == 0 { 0.1 } else { 0.0 })
                .collect();
            let x: Vec<f64> = (0..n).map(|i| i as f64 - 2.5).collect();
            let mut b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum()).collect();
            let mut lu = SquareLu::new(n);
            assert!(lu.factor(&a) > 0.0);
            lu.solve(&mut b);
            for (v, want) in b.iter().zip(&x) {
                assert!((v - want).abs() < 1e-11, "n = {n}: {b:?}");
            }
        }
    }

    #[test]
    fn a_singular_or_non_finite_matrix_has_ratio_zero() {
        for n in [3, 10] {
            let mut lu = SquareLu::new(n);
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                a[i * n + i] = 1.0;
            }
            assert_eq!(lu.factor(&a), 1.0);
            a[n * n - 1] = 0.0;
            assert_eq!(lu.factor(&a), 0.0, "n = {n}: a zero pivot");
            a[n * n - 1] = f64::NAN;
            assert_eq!(lu.factor(&a), 0.0, "n = {n}: a NaN");
        }
    }

    #[test]
    fn lu_solves_a_permuted_system() {
        let mut lu = SquareLu::new(3);
        let ratio = lu.factor(&[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0]);
        assert!(ratio > 0.0 && ratio <= 1.0);
        // A x = b for x = (1, 2, 3)
        let mut b = [7.0, 3.0, 6.0];
        lu.solve(&mut b);
        for (v, want) in b.iter().zip([1.0, 2.0, 3.0]) {
            assert!((v - want).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn full_pivoting_prefers_translations_and_finds_dependent_rows() {
        // rows: x1 + 0.9 phi = .., y1 - 0.9 phi = ..; translations 0 and 1
        let mut a = vec![1.0, 0.0, 0.9, 0.0, 1.0, -0.9];
        assert_eq!(pivot_columns(&mut a, 2, 3, &[true, true, false]), Ok(vec![0, 1]));
        // the same without preference takes the largest entries
        let mut a = vec![0.2, 0.0, 1.0, 0.0, 1.0, 0.1];
        assert_eq!(pivot_columns(&mut a, 2, 3, &[false; 3]), Ok(vec![2, 1]));
        // a repeated row
        let mut a = vec![1.0, 2.0, 3.0, 2.0, 4.0, 6.0];
        assert_eq!(pivot_columns(&mut a, 2, 3, &[false; 3]), Err(1));
    }
}
