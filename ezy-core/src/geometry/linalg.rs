//! Small dense solves over any [`Scalar`], so that the connection's
//! derivatives follow from the same code on dual numbers.

use crate::scalar::Scalar;

/// Solves `a x = b` in place: `a` (n x n, row-major) is overwritten by its
/// LU factors, `b` (n x k, row-major) by `x`. Gaussian elimination with
/// partial pivoting on the real parts (Golub & Van Loan, *Matrix
/// Computations*, 4th ed., §3.4). Returns the smallest pivot over the
/// largest (in real parts), a measure of how near singular `a` is.
///
/// # Errors
/// `Err(ratio)` when a pivot is zero or the ratio is below `1e-14`
/// (singular to rounding).
pub(crate) fn solve<S: Scalar>(n: usize, a: &mut [S], b: &mut [S], k: usize) -> Result<f64, f64> {
    let (mut smallest, mut largest) = (f64::INFINITY, 0.0f64);
    for col in 0..n {
        let pivot =
            (col..n).max_by(|&i, &j| a[i * n + col].re().abs().total_cmp(&a[j * n + col].re().abs())).unwrap_or(col);
        let size = a[pivot * n + col].re().abs();
        smallest = smallest.min(size);
        largest = largest.max(size);
        if size.is_nan() || size <= 0.0 {
            return Err(0.0);
        }
        if pivot != col {
            for j in 0..n {
                a.swap(pivot * n + j, col * n + j);
            }
            for j in 0..k {
                b.swap(pivot * k + j, col * k + j);
            }
        }
        let inv = a[col * n + col].recip();
        for i in col + 1..n {
            let factor = a[i * n + col] * inv;
            for j in col..n {
                let v = a[col * n + j];
                a[i * n + j] = a[i * n + j] - factor * v;
            }
            for j in 0..k {
                let v = b[col * k + j];
                b[i * k + j] = b[i * k + j] - factor * v;
            }
        }
    }
    for col in (0..n).rev() {
        let inv = a[col * n + col].recip();
        for j in 0..k {
            let mut s = b[col * k + j];
            for m in col + 1..n {
                s = s - a[col * n + m] * b[m * k + j];
            }
            b[col * k + j] = s * inv;
        }
    }
    let ratio = if largest > 0.0 { smallest / largest } else { 0.0 };
    if ratio < 1e-14 { Err(ratio) } else { Ok(ratio) }
}

/// `c = a^T b`: `a` (r x n), `b` (r x k), both row-major; `c` (n x k).
pub(crate) fn at_b<S: Scalar>(r: usize, n: usize, k: usize, a: &[S], b: &[S]) -> Vec<S> {
    let mut c = vec![S::from_f64(0.0); n * k];
    for row in 0..r {
        for i in 0..n {
            let ai = a[row * n + i];
            for j in 0..k {
                c[i * k + j] = c[i * k + j] + ai * b[row * k + j];
            }
        }
    }
    c
}

/// `c = a b`: `a` (r x n), `b` (n x k), both row-major; `c` (r x k).
pub(crate) fn mul<S: Scalar>(r: usize, n: usize, k: usize, a: &[S], b: &[S]) -> Vec<S> {
    let mut c = vec![S::from_f64(0.0); r * k];
    for i in 0..r {
        for m in 0..n {
            let aim = a[i * n + m];
            for j in 0..k {
                c[i * k + j] = c[i * k + j] + aim * b[m * k + j];
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use num_dual::Dual64;

    use super::*;

    #[test]
    fn a_system_and_its_derivative_are_solved() {
        // a(s) = [[2 + s, 1], [1, 3]], b = [1, 2]: x(0) = (0.2, 0.6),
        // dx/ds = -a^-1 (da/ds) x = -a^-1 [0.2, 0] = (-0.12, 0.04)
        let mut a = [Dual64::new(2.0, 1.0), Dual64::from(1.0), Dual64::from(1.0), Dual64::from(3.0)];
        let mut b = [Dual64::from(1.0), Dual64::from(2.0)];
        solve(2, &mut a, &mut b, 1).unwrap();
        assert!((b[0].re - 0.2).abs() < 1e-15 && (b[1].re - 0.6).abs() < 1e-15);
        assert!((b[0].eps + 0.12).abs() < 1e-15 && (b[1].eps - 0.04).abs() < 1e-15);
        let mut singular = [1.0, 2.0, 2.0, 4.0];
        let mut rhs = [1.0, 1.0];
        assert!(solve(2, &mut singular, &mut rhs, 1).is_err());
    }
}
