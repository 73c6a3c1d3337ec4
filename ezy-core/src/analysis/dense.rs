//! Small dense linear algebra for the analyses, on faer: null spaces,
//! minimum-norm least squares, orthonormal complements and sorted
//! eigenvalues. The matrices here are a few dozen rows at most (the state
//! of a model), so everything is a dense SVD or LU.

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, c64};

use super::AnalysisError;

/// A singular value decomposition `(s, U, V)`, singular values largest first.
type Svd = (Vec<f64>, Mat<f64>, Mat<f64>);

/// The singular values of `a` and its thin or full SVD factors.
fn svd(a: MatRef<'_, f64>, full: bool) -> Result<Svd, AnalysisError> {
    let s = if full { a.svd() } else { a.thin_svd() }
        .map_err(|e| AnalysisError::Numerics { reason: format!("an SVD did not converge ({e:?})") })?;
    let values: Vec<f64> = s.S().column_vector().iter().copied().collect();
    Ok((values, s.U().to_owned(), s.V().to_owned()))
}

/// The smallest singular value of `a` (m x n, m >= n) and its right
/// singular vector (n, unit): `a`'s nearest null direction.
pub(crate) fn smallest_right_singular(a: MatRef<'_, f64>) -> Result<(f64, Vec<f64>), AnalysisError> {
    let (s, _, v) = svd(a, false)?;
    let k = s.len().saturating_sub(1);
    Ok((s.get(k).copied().unwrap_or(0.0), (0..v.nrows()).map(|i| v[(i, k)]).collect()))
}

/// Numerical rank of a matrix with singular values `s` (largest first):
/// the count above `rtol * s[0]` (and above the smallest normal number).
fn rank(s: &[f64], rtol: f64) -> usize {
    let cut = (rtol * s.first().copied().unwrap_or(0.0)).max(f64::MIN_POSITIVE);
    s.iter().take_while(|&&v| v > cut).count()
}

/// An orthonormal basis (n x d) of the null space of `c` (m x n), rows
/// whose singular value is below `rtol` times the largest counted as
/// dependent. A matrix without rows has the identity's columns.
pub(crate) fn null_space(c: MatRef<'_, f64>, rtol: f64) -> Result<Mat<f64>, AnalysisError> {
    let n = c.ncols();
    if c.nrows() == 0 {
        return Ok(Mat::identity(n, n));
    }
    let (s, _, v) = svd(c, true)?;
    let r = rank(&s, rtol);
    Ok(v.subcols(r, n - r).to_owned())
}

/// The minimum-norm least-squares solution of `j x = r` (`j` m x n),
/// singular values below `rtol` times the largest dropped; and the
/// numerical rank of `j`.
pub(crate) fn min_norm_solve(j: MatRef<'_, f64>, r: &[f64], rtol: f64) -> Result<(Vec<f64>, usize), AnalysisError> {
    let (s, u, v) = svd(j, false)?;
    let k = rank(&s, rtol);
    let mut x = vec![0.0; j.ncols()];
    for i in 0..k {
        let coef = (0..j.nrows()).map(|row| u[(row, i)] * r[row]).sum::<f64>() / s[i];
        for (row, xi) in x.iter_mut().enumerate() {
            *xi += coef * v[(row, i)];
        }
    }
    Ok((x, k))
}

/// The numerical rank of `a`, singular values below `rtol` times the
/// largest counted as zero.
pub(crate) fn numerical_rank(a: MatRef<'_, f64>, rtol: f64) -> Result<usize, AnalysisError> {
    if a.nrows() == 0 || a.ncols() == 0 {
        return Ok(0);
    }
    Ok(rank(&svd(a, false)?.0, rtol))
}

/// The product `a b` (m x k times k x n). Not generic and not inlined:
/// the analyses' model-generic code calls it instead of building faer's
/// matrix product again in every model's crate (a release build shares
/// no generic code between crates).
#[inline(never)]
pub(crate) fn mul(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    a * b
}

/// `q^T a q` (q: n x k, a: n x n), as `(q^T a) q`; compiled once, as [`mul`].
#[inline(never)]
pub(crate) fn congruence(q: MatRef<'_, f64>, a: MatRef<'_, f64>) -> Mat<f64> {
    q.transpose() * a * q
}

/// An orthonormal basis of the range of `v` (n x k), columns within
/// `rtol` of dependence dropped.
pub(crate) fn orthonormal_range(v: MatRef<'_, f64>, rtol: f64) -> Result<Mat<f64>, AnalysisError> {
    if v.ncols() == 0 {
        return Ok(Mat::zeros(v.nrows(), 0));
    }
    let (s, u, _) = svd(v, false)?;
    let r = rank(&s, rtol);
    Ok(u.subcols(0, r).to_owned())
}

/// An orthonormal basis of the part of span(`t`) orthogonal to span(`o`),
/// both with orthonormal columns and span(`o`) inside span(`t`).
pub(crate) fn complement(t: MatRef<'_, f64>, o: MatRef<'_, f64>) -> Result<Mat<f64>, AnalysisError> {
    if o.ncols() == 0 {
        return Ok(t.to_owned());
    }
    let p = t - o * (o.transpose() * t);
    let (s, u, _) = svd(p.as_ref(), false)?;
    // the complement's singular values are 1, the orbit's 0 (to rounding)
    let d = s.iter().take_while(|&&v| v > 0.5).count();
    Ok(u.subcols(0, d).to_owned())
}

/// Solves the square system `a x = b` (columns of `b` at once) by LU with
/// full pivoting.
///
/// # Errors
/// [`AnalysisError::Numerics`] when `a` is singular to working accuracy
/// (the residual of the solve is not small).
pub(crate) fn solve(a: MatRef<'_, f64>, b: MatRef<'_, f64>, what: &str) -> Result<Mat<f64>, AnalysisError> {
    let x = a.full_piv_lu().solve(b);
    let res = a * &x - b;
    let scale = a.norm_max() * x.norm_max() + b.norm_max();
    let ok = x.norm_max().is_finite() && res.norm_max() <= 1e-8 * scale.max(f64::MIN_POSITIVE);
    if ok { Ok(x) } else { Err(AnalysisError::Numerics { reason: format!("{what} is singular at this state") }) }
}

/// The eigenvalues of the square `a`, largest real part first (ties:
/// larger imaginary part first), or, with `by_modulus`, largest modulus
/// first.
pub(crate) fn eigenvalues(a: MatRef<'_, f64>, by_modulus: bool) -> Result<Vec<c64>, AnalysisError> {
    if a.nrows() == 0 {
        return Ok(Vec::new());
    }
    let mut ev = a.eigenvalues().map_err(|e| AnalysisError::Numerics {
        reason: format!("the eigenvalue iteration did not converge ({e:?})"),
    })?;
    let key = |z: &c64| if by_modulus { z.re.hypot(z.im) } else { z.re };
    ev.sort_by(|a, b| key(b).total_cmp(&key(a)).then(b.im.total_cmp(&a.im)));
    Ok(ev)
}

/// `a` (m x n) from a row-major slice.
pub(crate) fn from_rows(m: usize, n: usize, a: &[f64]) -> Mat<f64> {
    Mat::from_fn(m, n, |i, j| a[i * n + j])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_space_and_complement_of_a_plane() {
        // x + y + z = 0: a plane in R^3
        let c = from_rows(1, 3, &[1.0, 1.0, 1.0]);
        let t = null_space(c.as_ref(), 1e-12).unwrap();
        assert_eq!(t.ncols(), 2);
        assert!((&c * &t).norm_max() < 1e-15);
        let o = orthonormal_range(from_rows(3, 1, &[1.0, -1.0, 0.0]).as_ref(), 1e-12).unwrap();
        let q = complement(t.as_ref(), o.as_ref()).unwrap();
        assert_eq!(q.ncols(), 1);
        let want = [1.0, 1.0, -2.0].map(|v: f64| v / 6f64.sqrt());
        let sign = q[(0, 0)].signum();
        for i in 0..3 {
            assert!((sign * q[(i, 0)] - want[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn min_norm_solution_of_an_underdetermined_system() {
        let j = from_rows(1, 2, &[1.0, 1.0]);
        let (x, r) = min_norm_solve(j.as_ref(), &[2.0], 1e-12).unwrap();
        assert_eq!(r, 1);
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn eigenvalues_sorted_by_real_part_and_by_modulus() {
        // a rotation-dilation block and a decaying mode
        let a = from_rows(3, 3, &[0.5, -2.0, 0.0, 2.0, 0.5, 0.0, 0.0, 0.0, -3.0]);
        let ev = eigenvalues(a.as_ref(), false).unwrap();
        assert!((ev[0].re - 0.5).abs() < 1e-14 && (ev[0].im - 2.0).abs() < 1e-14);
        assert!((ev[2].re + 3.0).abs() < 1e-14);
        let ev = eigenvalues(a.as_ref(), true).unwrap();
        assert!((ev[0].re + 3.0).abs() < 1e-14);
    }
}
