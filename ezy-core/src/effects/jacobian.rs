//! Exact force Jacobians ([`ForceLaw::jacobian`]): the two dense blocks a
//! law adds its partial derivatives into ([`Blocks`]), and the chain rule
//! of a world force at a body point that the built-in laws share.
//!
//! A world force `F` \[N\] at a body point with world lever arm `r = R(phi)
//! p` \[m\] acts on the body's `(x, y, phi)` as `(F_x, F_y, r_x F_y - r_y
//! F_x)` (docs/physics.md §8). Along any coordinate or velocity `z` its
//! derivative is `(dF_x, dF_y, r_x dF_y - r_y dF_x)` ([`Blocks::force`]),
//! and along the body's own heading the lever turns as well, `dr/dphi =
//! (-r_y, r_x)`, adding `-(r . F)` to the heading's row
//! ([`Blocks::lever`]). The point's velocity `v = (xd - w r_y, yd + w
//! r_x)` (`w` the heading rate) has `dv/dphi = -w r`, `dv/dxd = (1, 0)`,
//! `dv/dyd = (0, 1)` and `dv/dw = (-r_y, r_x)` ([`Blocks::point_force`]).
//!
//! [`ForceLaw::jacobian`]: super::kind::ForceLaw::jacobian

/// A column of a force Jacobian: a coordinate `q[j]` or a velocity `qd[j]`.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Var {
    /// `q[j]`: a column of `dF/dq`.
    Q(usize),
    /// `qd[j]`: a column of `dF/dqd`.
    Qd(usize),
}

/// The blocks `dF/dq` and `dF/dqd` (nq x nq each, row-major: entry `i nq +
/// j` is the derivative of `f[i]` along `q[j]` or `qd[j]`) that a law's
/// exact Jacobian adds into.
pub(crate) struct Blocks<'a> {
    nq: usize,
    dq: &'a mut [f64],
    dqd: &'a mut [f64],
}

/// `(-u_y, u_x)`: `u` turned a quarter left (its derivative along the
/// heading, for a vector turning with the body).
#[inline(always)]
pub(crate) fn perp(u: [f64; 2]) -> [f64; 2] {
    [-u[1], u[0]]
}

/// `u . v`.
#[inline(always)]
pub(crate) fn dot(u: [f64; 2], v: [f64; 2]) -> f64 {
    u[0] * v[0] + u[1] * v[1]
}

/// `m x` for the 2 x 2 matrix `m` (rows).
#[inline(always)]
pub(crate) fn mat_vec(m: [[f64; 2]; 2], x: [f64; 2]) -> [f64; 2] {
    [m[0][0] * x[0] + m[0][1] * x[1], m[1][0] * x[0] + m[1][1] * x[1]]
}

impl<'a> Blocks<'a> {
    /// The blocks `dq`, `dqd` (nq x nq each, row-major) of a model with
    /// `nq` coordinates.
    pub(crate) fn new(nq: usize, dq: &'a mut [f64], dqd: &'a mut [f64]) -> Self {
        debug_assert!(dq.len() == nq * nq && dqd.len() == nq * nq, "(nq x nq) blocks");
        Self { nq, dq, dqd }
    }

    /// Adds `v` to the derivative of `f[row]` along `col`.
    #[inline(always)]
    pub(crate) fn add(&mut self, row: usize, col: Var, v: f64) {
        match col {
            Var::Q(j) => self.dq[row * self.nq + j] += v,
            Var::Qd(j) => self.dqd[row * self.nq + j] += v,
        }
    }

    /// Adds the derivative `df` \[N per unit of `col`\] along `col` of a
    /// world force at lever arm `r` \[m\] on `body` (its `(x, y, phi)`
    /// indices), the lever held fixed: `(df_x, df_y, r x df)`.
    #[inline(always)]
    pub(crate) fn force(&mut self, body: [usize; 3], r: [f64; 2], col: Var, df: [f64; 2]) {
        self.add(body[0], col, df[0]);
        self.add(body[1], col, df[1]);
        self.add(body[2], col, r[0] * df[1] - r[1] * df[0]);
    }

    /// Adds the turn of the lever arm `r` \[m\] with `body`'s heading under
    /// the world force `force` \[N\]: `d(r x F)/dphi = -(r . F)` \[N m/rad\].
    #[inline(always)]
    pub(crate) fn lever(&mut self, body: [usize; 3], r: [f64; 2], force: [f64; 2]) {
        self.add(body[2], Var::Q(body[2]), -dot(r, force));
    }

    /// Adds the Jacobian of a world force `force` \[N\] at lever arm `r`
    /// \[m\] on `body` that depends on the body's heading (`dphi`, its
    /// derivative at a fixed point velocity \[N/rad\]) and on the point's
    /// world velocity `v` (`dv[i][j] = dF_i/dv_j` \[N s/m\]), `w` being the
    /// heading rate \[rad/s\]: the chain rule through `v(phi, xd, yd, w)`
    /// and the lever's turn.
    pub(crate) fn point_force(
        &mut self,
        body: [usize; 3],
        r: [f64; 2],
        w: f64,
        force: [f64; 2],
        dphi: [f64; 2],
        dv: [[f64; 2]; 2],
    ) {
        let through_v = mat_vec(dv, [-w * r[0], -w * r[1]]);
        self.force(body, r, Var::Q(body[2]), [dphi[0] + through_v[0], dphi[1] + through_v[1]]);
        self.force(body, r, Var::Qd(body[0]), [dv[0][0], dv[1][0]]);
        self.force(body, r, Var::Qd(body[1]), [dv[0][1], dv[1][1]]);
        self.force(body, r, Var::Qd(body[2]), mat_vec(dv, perp(r)));
        self.lever(body, r, force);
    }
}
