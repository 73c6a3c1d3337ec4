//! The connection's terms at one configuration, over any [`Scalar`]:
//! the locked motions `E`, the shape motions `H`, the skates' `Omega`
//! and `Psi`, the free directions `K`, `A` and `Gamma`; and the public
//! evaluations built on them.

use faer::Mat;
use num_dual::Dual64;

use super::linalg::{at_b, mul, solve};
use super::{Connection, Curvature, Geometry, GeometryError};
use crate::model::Model;
use crate::names::fmt_value;
use crate::scalar::Scalar;

/// The terms at one configuration (row-major matrices).
pub(crate) struct Terms<S> {
    /// `E` (nq x 3): every coordinate's rate per unit of `xi`.
    pub e: Vec<S>,
    /// `H` (nq x n_shape): every coordinate's rate per unit shape rate,
    /// the reference body held.
    pub h: Vec<S>,
    /// `K` (3 x m): the free directions.
    pub k: Vec<S>,
    /// `A` (3 x n_shape).
    pub a: Vec<S>,
    /// `Gamma` (3 x m).
    pub gamma: Vec<S>,
    /// [`Connection::rank_margin`].
    pub margin: f64,
    /// The determinant of `[Omega; K^T I_loc]` where it is square (its
    /// sign flips across the singular set); NaN otherwise.
    pub det: f64,
}

/// `E`, `H`, `Omega` (n_skates x 3), `Psi` (n_skates x n_shape).
struct Skates<S> {
    e: Vec<S>,
    h: Vec<S>,
    omega: Vec<S>,
    psi: Vec<S>,
}

/// Solves `a x = b`, `a` (rows x cols) of full column rank, `b` (rows x
/// k): directly when square, else by the normal equations (the systems
/// here are consistent, so both give the exact solution).
fn least_squares<S: Scalar>(rows: usize, cols: usize, a: &[S], b: &[S], k: usize) -> Result<Vec<S>, f64> {
    if rows == cols {
        let (mut a, mut b) = (a.to_vec(), b.to_vec());
        solve(cols, &mut a, &mut b, k)?;
        return Ok(b);
    }
    let mut ata = at_b(rows, cols, cols, a, a);
    let mut atb = at_b(rows, cols, k, a, b);
    solve(cols, &mut ata, &mut atb, k)?;
    Ok(atb)
}

/// The singular values of `a` (rows x 3), largest first.
fn singular_values(rows: usize, a: &[f64]) -> Vec<f64> {
    if rows == 0 {
        return Vec::new();
    }
    let m = Mat::from_fn(rows, 3, |i, j| a[i * 3 + j]);
    let mut s: Vec<f64> = m.singular_values().unwrap_or_default();
    s.sort_by(|x, y| y.total_cmp(x));
    s
}

/// The rank of `a` (rows x 3) at relative tolerance 1e-9, and the
/// margin: its `rank`-th singular value over its first.
fn rank_margin(rows: usize, a: &[f64], rank: usize) -> (usize, f64) {
    let s = singular_values(rows, a);
    let Some(&top) = s.first().filter(|t| **t > 0.0) else { return (0, 1.0) };
    let found = s.iter().filter(|v| **v > 1e-9 * top).count();
    let margin = if rank == 0 { 1.0 } else { s.get(rank - 1).copied().unwrap_or(0.0) / top };
    (found, margin)
}

impl<M: Model> Geometry<M> {
    /// The configuration `q` (nq) at shape `r` with the reference body's
    /// frame at the origin: headings out along the tree, each child's
    /// position from its hinge's residual (affine in it).
    pub(crate) fn place<S: Scalar>(&self, r: &[S]) -> Vec<S> {
        let nq = self.info.nq();
        let zero = S::from_f64(0.0);
        let mut q = vec![zero; nq];
        let mut phi = vec![zero; self.info.n_holonomic];
        let bodies = &self.info.bodies;
        for s in &self.steps {
            let [px, py, pp] = bodies[s.parent].coords;
            let [cx, cy, cp] = bodies[s.child].coords;
            q[cp] = q[pp] + S::from_f64(s.sign) * r[s.shape];
            // the parent's position seeds the child's: the residual's
            // part free of the child's position is then small
            q[cx] = q[px];
            q[cy] = q[py];
            self.model.phi(&q, &mut phi);
            let row = self.info.hinges[s.hinge].row;
            let c = S::from_f64(1.0 / s.coefficient);
            q[cx] = q[cx] - phi[row] * c;
            q[cy] = q[cy] - phi[row + 1] * c;
        }
        q
    }

    /// Measures each step's coefficient (the child's position in its
    /// hinge's rows) and checks the placement closes every hinge.
    pub(crate) fn measure_coefficients(&mut self) -> Result<(), GeometryError> {
        let nq = self.info.nq();
        let mut q = vec![0.0; nq];
        let mut phi = vec![0.0; self.info.n_holonomic];
        let r = generic_shape(self.shape.len(), 0);
        for s in 0..self.steps.len() {
            let st = &self.steps[s];
            let [px, py, pp] = self.info.bodies[st.parent].coords;
            let [cx, cy, cp] = self.info.bodies[st.child].coords;
            q[cp] = q[pp] + st.sign * r[st.shape];
            q[cx] = q[px];
            q[cy] = q[py];
            let row = self.info.hinges[st.hinge].row;
            self.model.phi(&q, &mut phi);
            let base = [phi[row], phi[row + 1]];
            q[cx] += 1.0;
            self.model.phi(&q, &mut phi);
            let cxx = phi[row] - base[0];
            let cyx = phi[row + 1] - base[1];
            q[cx] -= 1.0;
            if !((cxx.abs() - 1.0).abs() < 1e-12 && cyx.abs() < 1e-12) {
                return Err(GeometryError::Model {
                    reason: format!(
                        "hinge `{}`: its residual is not the difference of its two points' positions (d/dx = {cxx}, {cyx})",
                        self.info.hinges[st.hinge].name
                    ),
                });
            }
            self.steps[s].coefficient = cxx.signum();
            q[cx] -= base[0] / self.steps[s].coefficient;
            q[cy] -= base[1] / self.steps[s].coefficient;
        }
        self.model.phi(&q, &mut phi);
        for h in &self.info.hinges {
            let worst = phi[h.row].abs().max(phi[h.row + 1].abs());
            if worst.is_nan() || worst >= 1e-9 {
                return Err(GeometryError::Model {
                    reason: format!("hinge `{}` stays open by {worst:.3e} m after placing its bodies", h.name),
                });
            }
        }
        Ok(())
    }

    /// `E`, `H`, `Omega`, `Psi` at `q`.
    fn skates<S: Scalar>(&self, q: &[S]) -> Skates<S> {
        let info = &self.info;
        let (nq, ns, nsk) = (info.nq(), self.shape.len(), self.skates.len());
        let zero = S::from_f64(0.0);
        let one = S::from_f64(1.0);
        let [rx, ry, rp] = info.bodies[self.body].coords;
        let (s, c) = q[rp].sin_cos();
        let mut e = vec![zero; nq * 3];
        for b in &info.bodies {
            let [ix, iy, ip] = b.coords;
            let (dx, dy) = (q[ix] - q[rx], q[iy] - q[ry]);
            e[ix * 3..ix * 3 + 3].copy_from_slice(&[c, -s, -dy]);
            e[iy * 3..iy * 3 + 3].copy_from_slice(&[s, c, dx]);
            e[ip * 3..ip * 3 + 3].copy_from_slice(&[zero, zero, one]);
        }
        let mut h = vec![zero; nq * ns];
        if ns > 0 {
            let mut points = vec![zero; 2 * info.points.len()];
            self.model.points(q, &mut points);
            for st in &self.steps {
                let p = info.hinges[st.hinge].point;
                let (hx, hy) = (points[2 * p], points[2 * p + 1]);
                let sign = S::from_f64(st.sign);
                for &j in &st.subtree {
                    let [jx, jy, jp] = info.bodies[j].coords;
                    let k = st.shape;
                    h[jx * ns + k] = h[jx * ns + k] - sign * (q[jy] - hy);
                    h[jy * ns + k] = h[jy * ns + k] + sign * (q[jx] - hx);
                    h[jp * ns + k] = h[jp * ns + k] + sign;
                }
            }
        }
        let mut values = vec![zero; info.pattern.len()];
        self.model.constraint_matrix(q, &mut values);
        let mut gs = vec![zero; nsk * nq];
        for (&(r, col), &v) in info.pattern.iter().zip(&values) {
            if let Some(i) = self.skates.iter().position(|&s| s == r) {
                gs[i * nq + col] = v;
            }
        }
        let omega = mul(nsk, nq, 3, &gs, &e);
        let psi = mul(nsk, nq, ns, &gs, &h);
        Skates { e, h, omega, psi }
    }

    /// Every term at `q`; `Err(margin)` where the constraints are
    /// singular. With `measure`, [`Terms::margin`] is measured (an SVD of
    /// `Omega`, three quarters of the cost); without, it is NaN and only
    /// an exactly singular solve fails.
    pub(crate) fn terms<S: Scalar>(&self, q: &[S], measure: bool) -> Result<Terms<S>, f64> {
        let (nq, ns, nsk, m) = (self.info.nq(), self.shape.len(), self.skates.len(), self.free.len());
        let zero = S::from_f64(0.0);
        let Skates { e, h, omega, psi } = self.skates(q);
        let margin = if measure {
            let omega_re: Vec<f64> = omega.iter().map(|v| v.re()).collect();
            rank_margin(nsk, &omega_re, self.rank).1
        } else {
            f64::NAN
        };
        if margin < 1e-12 {
            return Err(margin);
        }
        let k = self.free_directions(&omega)?;
        // M E, E^T M E (the locked inertia), E^T M H
        let me: Vec<S> = (0..nq * 3).map(|i| e[i] * S::from_f64(self.mass[i / 3])).collect();
        let i_loc = at_b(nq, 3, 3, &e, &me);
        let emh = at_b(nq, 3, ns, &me, &h);
        // [Omega; K^T I_loc] X = [Psi; K^T E^T M H], A = X
        let kt_i = at_b(3, m, 3, &k, &i_loc);
        let kt_emh = at_b(3, m, ns, &k, &emh);
        let mut rows = omega.clone();
        rows.extend_from_slice(&kt_i);
        let mut rhs = psi;
        rhs.extend_from_slice(&kt_emh);
        let det = if nsk + m == 3 {
            let r: Vec<f64> = rows.iter().map(|v| v.re()).collect();
            r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) + r[2] * (r[3] * r[7] - r[4] * r[6])
        } else {
            f64::NAN
        };
        let a = if ns == 0 { Vec::new() } else { least_squares(nsk + m, 3, &rows, &rhs, ns)? };
        // Gamma = K (K^T I_loc K)^-1
        let gamma = if m == 0 {
            Vec::new()
        } else {
            let mut kik = mul(m, 3, m, &kt_i, &k);
            let mut kt = vec![zero; m * 3];
            for i in 0..3 {
                for j in 0..m {
                    kt[j * 3 + i] = k[i * m + j];
                }
            }
            solve(m, &mut kik, &mut kt, 3)?;
            // kt now (K^T I K)^-1 K^T: its transpose is Gamma
            let mut g = vec![zero; 3 * m];
            for i in 0..3 {
                for j in 0..m {
                    g[i * m + j] = kt[j * 3 + i];
                }
            }
            g
        };
        Ok(Terms { e, h, k, a, gamma, margin, det })
    }

    /// `K` (3 x m) from `Omega`: each free direction has its own free
    /// component 1, the others 0, the rest from `Omega K = 0`.
    fn free_directions<S: Scalar>(&self, omega: &[S]) -> Result<Vec<S>, f64> {
        let (nsk, m) = (self.skates.len(), self.free.len());
        let zero = S::from_f64(0.0);
        let fixed: Vec<usize> = (0..3).filter(|c| !self.free.contains(c)).collect();
        let nf = fixed.len();
        let mut k = vec![zero; 3 * m];
        if m == 0 {
            return Ok(k);
        }
        for (j, &f) in self.free.iter().enumerate() {
            k[f * m + j] = S::from_f64(1.0);
        }
        if nf == 0 {
            return Ok(k);
        }
        let sub: Vec<S> = (0..nsk).flat_map(|i| fixed.iter().map(move |&c| omega[i * 3 + c])).collect();
        let rhs: Vec<S> =
            (0..nsk).flat_map(|i| self.free.iter().map(move |&f| S::from_f64(0.0) - omega[i * 3 + f])).collect();
        let x = least_squares(nsk, nf, &sub, &rhs, m)?;
        for (a, &c) in fixed.iter().enumerate() {
            for j in 0..m {
                k[c * m + j] = x[a * m + j];
            }
        }
        Ok(k)
    }

    /// The rank of `Omega` at generic shapes and the free components of
    /// `xi`, the forward speed first where the skates allow.
    ///
    /// # Errors
    /// [`GeometryError::Model`] when the skates restrict the shape
    /// velocities themselves.
    pub(crate) fn choose_free(&mut self) -> Result<(), GeometryError> {
        let nsk = self.skates.len();
        let ns = self.shape.len();
        let mut rank = 0;
        let mut best = None;
        for seed in 0..4 {
            let q = self.place(&generic_shape(ns, seed));
            let sk = self.skates(&q);
            let (found, _) = rank_margin(nsk, &sk.omega, 3);
            // [Omega Psi] must have Omega's rank: else some skate rows
            // hold the shape velocities themselves
            let mut both = Vec::new();
            for i in 0..nsk {
                both.extend_from_slice(&sk.omega[i * 3..i * 3 + 3]);
                both.extend_from_slice(&sk.psi[i * ns..i * ns + ns]);
            }
            let wide = Mat::from_fn(nsk, 3 + ns, |i, j| both[i * (3 + ns) + j]);
            let sv = if nsk == 0 { Vec::new() } else { wide.singular_values().unwrap_or_default() };
            let top = sv.iter().copied().fold(0.0f64, f64::max);
            let wide_rank = sv.iter().filter(|v| **v > 1e-9 * top).count();
            if wide_rank > found {
                return Err(GeometryError::Model {
                    reason: format!(
                        "the {nsk} skates hold the shape velocities themselves ({wide_rank} independent rows, of which the plane's motions take {found}): the hinge angles cannot change freely, so the shape is not a free variable; give the model fewer skates or fewer hinges"
                    ),
                });
            }
            if found >= rank {
                rank = found;
                best = Some(sk.omega);
            }
        }
        self.rank = rank;
        let m = 3 - rank;
        let Some(omega) = best else { return Ok(()) };
        let candidates: &[&[usize]] = match m {
            0 => &[&[]],
            1 => &[&[0], &[2], &[1]],
            2 => &[&[0, 2], &[0, 1], &[1, 2]],
            _ => &[&[0, 1, 2]],
        };
        // the smallest singular value of the fixed columns, per candidate
        let score = |free: &[usize]| {
            let fixed: Vec<usize> = (0..3).filter(|c| !free.contains(c)).collect();
            if fixed.is_empty() {
                return 1.0;
            }
            let sub = Mat::from_fn(nsk, fixed.len(), |i, j| omega[i * 3 + fixed[j]]);
            sub.singular_values().unwrap_or_default().into_iter().fold(f64::INFINITY, f64::min)
        };
        let scores: Vec<f64> = candidates.iter().map(|c| score(c)).collect();
        let top = scores.iter().copied().fold(0.0f64, f64::max);
        let pick = scores.iter().position(|s| *s > 0.1 * top).unwrap_or(0);
        self.free = candidates[pick].to_vec();
        Ok(())
    }

    /// The singular error at shape `r`.
    pub(crate) fn singular(&self, r: &[f64], margin: f64) -> GeometryError {
        let at: Vec<String> =
            self.shape_names().iter().zip(r).map(|(n, v)| format!("{n} = {}", fmt_value(*v))).collect();
        GeometryError::Singular {
            reason: format!(
                "at shape {}: the skates lose rank in the position (rank margin {margin:.1e}): the connection is singular there",
                at.join(", ")
            ),
        }
    }

    /// The configuration `q` (nq) at shape `r` (n_shape) \[rad\], the
    /// reference body's frame at the origin \[m, rad\].
    ///
    /// # Errors
    /// [`GeometryError::Request`] for a shape of the wrong length or not
    /// finite.
    pub fn configuration(&self, r: &[f64]) -> Result<Vec<f64>, GeometryError> {
        self.check_shape(r)?;
        Ok(self.place(r))
    }

    /// The local connection at shape `r` (n_shape) \[rad\].
    ///
    /// # Errors
    /// As [`Geometry::configuration`]; [`GeometryError::Singular`] where
    /// the skates lose rank.
    pub fn connection(&self, r: &[f64]) -> Result<Connection, GeometryError> {
        self.check_shape(r)?;
        let q = self.place(r);
        let t = self.terms(&q, true).map_err(|m| self.singular(r, m))?;
        Ok(Connection { shape: r.to_vec(), a: t.a, gamma: t.gamma, rank_margin: t.margin })
    }

    /// `A` (3 x n_shape) at shape `r`, without the rank margin.
    pub(crate) fn connection_fast(&self, r: &[f64]) -> Result<Vec<f64>, f64> {
        Ok(self.terms(&self.place(r), false)?.a)
    }

    /// The determinant of the square system fixing `xi` at shape `r`
    /// (`[Omega; K^T I_loc]`, 3 x 3 when the skates' rows are
    /// independent), whose sign flips across the singular set; NaN
    /// where it is not square or is singular.
    pub(crate) fn orientation(&self, r: &[f64]) -> f64 {
        self.terms(&self.place(r), false).map_or(f64::NAN, |t| t.det)
    }

    /// [`Connection::rank_margin`] at shape `r`, 0 on the singular set
    /// (no error there).
    ///
    /// # Errors
    /// As [`Geometry::configuration`].
    pub fn rank_margin(&self, r: &[f64]) -> Result<f64, GeometryError> {
        self.check_shape(r)?;
        let q = self.place(r);
        let sk = self.skates(&q);
        Ok(rank_margin(self.skates.len(), &sk.omega, self.rank).1)
    }

    /// [`Connection::rank_margin`] at shape `r` (n_shape) and its gradient
    /// in `r` (n_shape, per rad): `sigma_k / sigma_1` of `Omega` (`k` its
    /// generic rank) with `d sigma_i = u_i^T dOmega v_i` (the derivative of
    /// a simple singular value; Magnus, "On differentiating eigenvalues and
    /// eigenvectors", Econometric Theory 1(2), 1985), `dOmega/dr_j` by
    /// dual numbers through the generated constraints. No error on the
    /// singular set: the margin is 0 there and its gradient that of the
    /// nearest simple values.
    pub(crate) fn rank_margin_gradient(&self, r: &[f64]) -> (f64, Vec<f64>) {
        let (nsk, ns, rank) = (self.skates.len(), self.shape.len(), self.rank);
        let q = self.place(r);
        let omega = self.skates(&q).omega;
        let m = Mat::from_fn(nsk, 3, |i, j| omega[i * 3 + j]);
        let Some(svd) = (nsk > 0 && rank > 0).then(|| m.thin_svd().ok()).flatten() else {
            return (1.0, vec![0.0; ns]);
        };
        let s: Vec<f64> = svd.S().column_vector().iter().copied().collect();
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by(|a, b| s[*b].total_cmp(&s[*a]));
        let (top, low) = (order[0], order[(rank - 1).min(order.len() - 1)]);
        if s[top] <= 0.0 {
            return (1.0, vec![0.0; ns]);
        }
        let (u, v) = (svd.U(), svd.V());
        let grad = (0..ns)
            .map(|k| {
                let rk: Vec<Dual64> =
                    r.iter().enumerate().map(|(i, x)| Dual64::new(*x, if i == k { 1.0 } else { 0.0 })).collect();
                let d: Vec<f64> = self.skates(&self.place(&rk)).omega.iter().map(|x| x.eps).collect();
                let ds = |c: usize| {
                    (0..nsk).map(|i| (0..3).map(|j| u[(i, c)] * d[i * 3 + j] * v[(j, c)]).sum::<f64>()).sum::<f64>()
                };
                (ds(low) * s[top] - s[low] * ds(top)) / (s[top] * s[top])
            })
            .collect();
        (s[low] / s[top], grad)
    }

    /// The connection and the constraint curvature at shape `r`, its
    /// derivatives exact (dual numbers through the generated
    /// constraints and the solves).
    ///
    /// # Errors
    /// As [`Geometry::connection`].
    pub fn curvature(&self, r: &[f64]) -> Result<Curvature, GeometryError> {
        let connection = self.connection(r)?;
        let ns = self.shape.len();
        let mut da = Vec::with_capacity(ns * 3 * ns);
        for k in 0..ns {
            let rk: Vec<Dual64> =
                r.iter().enumerate().map(|(i, v)| Dual64::new(*v, if i == k { 1.0 } else { 0.0 })).collect();
            let q = self.place(&rk);
            let t = self.terms(&q, false).map_err(|m| self.singular(r, m))?;
            da.extend(t.a.iter().map(|v| v.eps));
        }
        let a = &connection.a;
        let mut height = Vec::new();
        for i in 0..ns {
            for j in i + 1..ns {
                // dA_j/dr_i - dA_i/dr_j, per component
                let d = |c: usize| da[i * 3 * ns + c * ns + j] - da[j * 3 * ns + c * ns + i];
                let (ai, aj) = ([a[i], a[ns + i], a[2 * ns + i]], [a[j], a[ns + j], a[2 * ns + j]]);
                // [X, Y] in se(2): (th_Y y_X - th_X y_Y, th_X x_Y - th_Y x_X, 0)
                let bracket = [aj[2] * ai[1] - ai[2] * aj[1], ai[2] * aj[0] - aj[2] * ai[0], 0.0];
                height.push([-d(0) + bracket[0], -d(1) + bracket[1], -d(2) + bracket[2]]);
            }
        }
        Ok(Curvature { connection, da, height })
    }

    /// The state `(q, qd)` (nq each) at shape `r`, shape velocity `rd`
    /// (n_shape) \[rad/s\] and momentum `p` (m), the reference body's
    /// frame at the origin: `xi = -A rd + Gamma p`, `qd = E xi + H rd`.
    ///
    /// # Errors
    /// As [`Geometry::connection`]; [`GeometryError::Request`] for `rd`
    /// or `p` of the wrong length or not finite.
    pub fn state(&self, r: &[f64], rd: &[f64], p: &[f64]) -> Result<(Vec<f64>, Vec<f64>), GeometryError> {
        self.check_shape(r)?;
        let (ns, m) = (self.shape.len(), self.free.len());
        if rd.len() != ns || p.len() != m || rd.iter().chain(p).any(|v| !v.is_finite()) {
            return Err(GeometryError::Request {
                reason: format!(
                    "a state needs {ns} finite shape rates and {m} finite momenta; given {} and {}",
                    rd.len(),
                    p.len()
                ),
            });
        }
        let q = self.place(r);
        let t = self.terms(&q, false).map_err(|mg| self.singular(r, mg))?;
        let xi = self.xi(&t, rd, p);
        Ok((q.clone(), self.velocities(&t, &xi, rd)))
    }

    /// `xi = -A rd + Gamma p`.
    pub(crate) fn xi(&self, t: &Terms<f64>, rd: &[f64], p: &[f64]) -> [f64; 3] {
        let (ns, m) = (self.shape.len(), self.free.len());
        let mut xi = [0.0; 3];
        for (c, x) in xi.iter_mut().enumerate() {
            *x = -(0..ns).map(|k| t.a[c * ns + k] * rd[k]).sum::<f64>()
                + (0..m).map(|j| t.gamma[c * m + j] * p[j]).sum::<f64>();
        }
        xi
    }

    /// `qd = E xi + H rd`.
    pub(crate) fn velocities(&self, t: &Terms<f64>, xi: &[f64; 3], rd: &[f64]) -> Vec<f64> {
        let (nq, ns) = (self.info.nq(), self.shape.len());
        (0..nq)
            .map(|i| {
                (0..3).map(|c| t.e[i * 3 + c] * xi[c]).sum::<f64>()
                    + (0..ns).map(|k| t.h[i * ns + k] * rd[k]).sum::<f64>()
            })
            .collect()
    }

    /// Checks a state's lengths and values.
    pub(crate) fn check_state(&self, q: &[f64], qd: &[f64]) -> Result<(), GeometryError> {
        let nq = self.info.nq();
        if q.len() != nq || qd.len() != nq {
            return Err(GeometryError::Request {
                reason: format!("a state of {} and {} values given to a model of {nq} coordinates", q.len(), qd.len()),
            });
        }
        if let Some(k) = q.iter().chain(qd).position(|v| !v.is_finite()) {
            return Err(GeometryError::Request { reason: format!("state value {k} is not a finite number") });
        }
        Ok(())
    }
}

/// A shape away from the special ones (straight, symmetric): `seed`
/// picks one of a few.
fn generic_shape(ns: usize, seed: usize) -> Vec<f64> {
    (0..ns).map(|k| 0.37 * ((k + 1) as f64 * (1.3 + seed as f64)).sin() + 0.11 * seed as f64).collect()
}
