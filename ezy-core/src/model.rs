//! The [`Model`] trait the `model!` macro implements, and the static
//! description ([`ModelInfo`]) every generated model carries.
//!
//! Conventions (SPEC §1): every body has three generalized coordinates, the
//! position of its centre of mass and its heading, `(x [m], y [m], phi [rad])`,
//! so the mass matrix is diagonal, `diag(m, m, I)` per body. The constraints
//! are stacked as `G = [C_q; S]` (nc x nq): first the `nh` holonomic rows
//! (two per hinge, the Jacobian of `phi(q)`), then one row per skate (the
//! skate constraint matrix `S(q)`, `S(q) qd` = lateral velocity of the skate's
//! contact point [m/s]). `gamma` (nc) is the convective term,
//! `gamma = d/dq(G(q) qd) qd`, so that `G qdd = -gamma` on the constraint
//! manifold.

use crate::Scalar;

/// A parameter of a model: a runtime field of the generated struct.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamInfo {
    /// Field name, e.g. `"m1"`.
    pub name: &'static str,
    /// Value declared in the model.
    pub default: f64,
    /// Unit, taken from the `[...]` at the end of the doc comment (`""` if none).
    pub unit: &'static str,
    /// The doc comment, without the unit.
    pub doc: &'static str,
}

/// A rigid body: indices of its coordinates `(x, y, phi)` in `q`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BodyInfo {
    /// Body name, e.g. `"body1"`.
    pub name: &'static str,
    /// Indices of `x [m]`, `y [m]`, `phi [rad]` in `q`.
    pub coords: [usize; 3],
    /// The parameter that is the body's mass, if the model wrote it as one.
    pub mass_param: Option<&'static str>,
    /// The parameter that is the body's inertia, if the model wrote it as one.
    pub inertia_param: Option<&'static str>,
}

/// A named point fixed on a body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PointInfo {
    /// Point name, e.g. `"A"`.
    pub name: &'static str,
    /// Index of the body it is fixed on, in [`ModelInfo::bodies`].
    pub body: usize,
}

/// A revolute joint (hinge): a point of body `body_a` coincides with a point
/// of body `body_b`, or with a fixed point of the ground (`body_b = None`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HingeInfo {
    /// Hinge name, e.g. `"B"`.
    pub name: &'static str,
    /// Index of the first body.
    pub body_a: usize,
    /// Index of the second body, `None` for the ground.
    pub body_b: Option<usize>,
    /// Index of its first residual row in `phi` (its rows are `row`, `row + 1`).
    pub row: usize,
}

/// A slider (prismatic joint): a point of body `body_b` stays on a line
/// fixed in body `body_a` (or in the ground, `body_a = None`), and the two
/// headings keep a fixed difference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SliderInfo {
    /// Slider name, e.g. `"S"`.
    pub name: &'static str,
    /// Index of the guiding body, `None` for the ground.
    pub body_a: Option<usize>,
    /// Index of the moving body.
    pub body_b: usize,
    /// Index of its first residual row in `phi` (rows `row` = `S.n`, the
    /// offset from the line [m], and `row + 1` = `S.phi`, the heading [rad]).
    pub row: usize,
}

/// A drive: a hinge whose angle `phi_a - phi_b` follows a function of time
/// `u(t)` given at run time (a rheonomic constraint, `phi_row(q) = u(t)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveInfo {
    /// Drive name, e.g. `"D"`.
    pub name: &'static str,
    /// Index of the driven hinge in [`ModelInfo::hinges`].
    pub hinge: usize,
    /// Its row in `phi` and `G`.
    pub row: usize,
}

/// A skate (knife edge): a body point whose velocity has no component along
/// the blade normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SkateInfo {
    /// Skate name, e.g. `"A"`.
    pub name: &'static str,
    /// Index of its contact point in [`ModelInfo::points`].
    pub point: usize,
    /// Index of its row in `G` (>= `n_holonomic`).
    pub row: usize,
}

/// Everything static about a model: sizes, names and the sparsity pattern of
/// the constraint matrix `G`, fixed at compile time by the macro.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelInfo {
    /// Model name, e.g. `"EzyRoller"`.
    pub name: &'static str,
    /// First line of the model's doc comment.
    pub doc: &'static str,
    /// Names of the generalized coordinates, in order (nq).
    pub coords: &'static [&'static str],
    /// Parameters, in declaration order.
    pub params: &'static [ParamInfo],
    /// Bodies, in declaration order.
    pub bodies: &'static [BodyInfo],
    /// Named points, in declaration order.
    pub points: &'static [PointInfo],
    /// Hinges, in declaration order.
    pub hinges: &'static [HingeInfo],
    /// Sliders, in declaration order (their rows follow the hinges').
    pub sliders: &'static [SliderInfo],
    /// Drives, in declaration order (their rows follow the sliders').
    pub drives: &'static [DriveInfo],
    /// Skates, in declaration order.
    pub skates: &'static [SkateInfo],
    /// Names of the constraint rows of `G` (nc): `B.x`, `B.y` per hinge,
    /// `S.n`, `S.phi` per slider, one per drive, then one per skate.
    pub constraints: &'static [&'static str],
    /// Number of holonomic constraint rows `nh` (two per hinge and per
    /// slider, one per drive).
    pub n_holonomic: usize,
    /// Structural nonzeros `(row, col)` of `G` (nc x nq), row-major sorted.
    /// The entries of rows `< n_holonomic` come first.
    pub pattern: &'static [(usize, usize)],
}

impl ModelInfo {
    /// Number of generalized coordinates `nq`.
    pub const fn nq(&self) -> usize {
        self.coords.len()
    }
    /// Number of velocity constraints `nc` (holonomic rows + skates).
    pub const fn nc(&self) -> usize {
        self.constraints.len()
    }
    /// Number of structural nonzeros of the holonomic Jacobian `C_q`.
    pub fn n_holonomic_nonzeros(&self) -> usize {
        self.pattern.iter().take_while(|(r, _)| *r < self.n_holonomic).count()
    }
    /// Index of a coordinate by name.
    pub fn coord_index(&self, name: &str) -> Option<usize> {
        self.coords.iter().position(|c| *c == name)
    }
    /// Index of a parameter by name.
    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }
    /// Index of a hinge by name.
    pub fn hinge_index(&self, name: &str) -> Option<usize> {
        self.hinges.iter().position(|h| h.name == name)
    }
    /// Index of a point by name.
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }
}

/// One derived expression, as text (SPEC §1's notation: `x1`, `phi1d` for
/// the rate of `phi1`) and as LaTeX.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EquationExpr {
    /// Plain text, e.g. `x1 - x2 + b*cos(phi1) + d*cos(phi2)`.
    pub text: &'static str,
    /// LaTeX math, e.g. `x_{1} - x_{2} + b \cos \varphi_{1} + ...`.
    pub latex: &'static str,
}

/// What the macro derived, for reading and checking (`ezy equations`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Equations {
    /// The generalized coordinates (nq): their names and LaTeX symbols.
    pub coords: &'static [EquationExpr],
    /// Mass-matrix diagonal (nq), in terms of parameters.
    pub mass: &'static [EquationExpr],
    /// Holonomic residual rows `phi(q)` (nh) [m].
    pub phi: &'static [EquationExpr],
    /// Velocity constraints `G_i(q) qd` (nc) [m/s]: `d phi_i/dt` for the
    /// holonomic rows, the skate's lateral velocity for the skate rows.
    pub velocity: &'static [EquationExpr],
    /// Entries of `G = [C_q; S]` at [`ModelInfo::pattern`].
    pub jacobian: &'static [EquationExpr],
    /// Convective terms `gamma = d/dq(G qd) qd` (nc) [m/s^2].
    pub gamma: &'static [EquationExpr],
    /// Velocities of the named points (2 x npoints, x then y) [m/s].
    pub point_velocities: &'static [EquationExpr],
}

/// A planar multibody model with hinges and skates, as generated by
/// `model!`. All matrices are passed as flat slices; sizes are given by
/// [`Model::INFO`]. No method allocates.
pub trait Model: Clone + Send + Sync + 'static {
    /// Static description: sizes, names, sparsity pattern of `G`.
    const INFO: ModelInfo;
    /// The derived equations as text and LaTeX.
    const EQUATIONS: Equations;

    /// Current value of parameter `index` (order of [`ModelInfo::params`]).
    fn param(&self, index: usize) -> f64;
    /// Sets parameter `index` (order of [`ModelInfo::params`]).
    fn set_param(&mut self, index: usize, value: f64);

    /// `A = G W^-1 G^T` (nc x nc) from the values of `G` at
    /// [`ModelInfo::pattern`] and the diagonal `winv` (nq) of `W^-1`: the
    /// lower triangle `a[i * nc + j]`, `j <= i`, is written (the upper is not
    /// touched). Straight-line code at the compile-time pattern.
    fn normal_matrix(values: &[f64], winv: &[f64], a: &mut [f64]);
    /// `out = G W^-1 u` (u, winv: nq; out: nc), `G` given by its pattern
    /// values (one kernel for `G M^-1 f` and, with `winv = 1`, `G qd`).
    fn g_winv_mul(values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]);
    /// `v -= W^-1 G^T x` (x: nc, v: nq), `G` given by its pattern values.
    fn sub_winv_gt_mul(values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]);

    /// Diagonal of the mass matrix `M` (nq): `m [kg], m [kg], I [kg m^2]` per body.
    fn mass_diagonal(&self, out: &mut [f64]);

    /// Body-frame geometry at the current parameters: `points` (2 x
    /// npoints) gets each named point's coordinates `(px, py)` [m] in its
    /// body's frame (centre of mass at the origin, heading along x);
    /// `blades` (2 x nskates) gets each skate's unit blade direction
    /// `(tx, ty)` in its body's frame. Effects that act at a point or along
    /// a blade are built from these (SPEC §1 conventions).
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]);

    /// Holonomic residual `phi(q)` (nh) [m].
    fn phi<S: Scalar>(&self, q: &[S], phi: &mut [S]);
    /// Values of the holonomic Jacobian `C_q = d phi / dq` at the first
    /// [`ModelInfo::n_holonomic_nonzeros`] entries of [`ModelInfo::pattern`].
    fn holonomic_jacobian<S: Scalar>(&self, q: &[S], values: &mut [S]);
    /// Values of `G(q) = [C_q; S]` (nc x nq) at the entries of
    /// [`ModelInfo::pattern`].
    fn constraint_matrix<S: Scalar>(&self, q: &[S], values: &mut [S]);
    /// `phi(q)` and `G(q)` together, sharing subexpressions (one evaluation
    /// of the trigonometric terms for coordinate projection).
    fn phi_and_constraint_matrix<S: Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]);
    /// `G(q)` (as in [`Model::constraint_matrix`]) and the convective term
    /// `gamma(q, qd) = d/dq(G qd) qd` (nc) [m/s^2], sharing subexpressions.
    fn constraint_terms<S: Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]);
    /// Positions of the named points (2 x npoints, `x, y` per point) [m].
    fn points<S: Scalar>(&self, q: &[S], out: &mut [S]);
    /// Velocities of the named points (2 x npoints) [m/s].
    fn point_velocities<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]);
}

/// Scatters pattern values into a dense row-major matrix (rows x ncols).
/// Entries not in the pattern are set to zero.
pub fn scatter_dense(pattern: &[(usize, usize)], values: &[f64], ncols: usize, dense: &mut [f64]) {
    dense.iter_mut().for_each(|v| *v = 0.0);
    for (&(r, c), &v) in pattern.iter().zip(values) {
        dense[r * ncols + c] = v;
    }
}
