//! The [`Model`] trait the `model!` macro implements, and the static
//! description ([`ModelInfo`]) every generated model carries.
//!
//! Conventions (docs/physics.md §1-§4): every body has three generalized coordinates, the
//! position of its centre of mass and its heading, `(x [m], y [m], phi [rad])`,
//! so the mass matrix is diagonal, `diag(m, m, I)` per body. The constraints
//! are stacked as `G = [C_q; S]` (nc x nq): first the `nh` holonomic rows
//! (two per hinge, the Jacobian of `phi(q)`), then one row per skate (the
//! skate constraint matrix `S(q)`, `S(q) qd` = lateral velocity of the skate's
//! contact point \[m/s\]). `gamma` (nc) is the convective term,
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
    /// A family count (`count N = 5;`): a whole number >= 1 that sets how
    /// many elements the model's `for` families have.
    pub count: bool,
}

/// A rigid body: indices of its coordinates `(x, y, phi)` in `q`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BodyInfo {
    /// Body name, e.g. `"body1"`.
    pub name: String,
    /// Indices of `x [m]`, `y [m]`, `phi [rad]` in `q`.
    pub coords: [usize; 3],
    /// The parameter that is the body's mass, if the model wrote it as one.
    pub mass_param: Option<&'static str>,
    /// The parameter that is the body's inertia, if the model wrote it as one.
    pub inertia_param: Option<&'static str>,
}

/// A named point fixed on a body.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PointInfo {
    /// Point name, e.g. `"A"`.
    pub name: String,
    /// Index of the body it is fixed on, in [`ModelInfo::bodies`].
    pub body: usize,
}

/// A revolute joint (hinge): a point of body `body_a` coincides with a point
/// of body `body_b`, or with a fixed point of the ground (`body_b = None`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HingeInfo {
    /// Hinge name, e.g. `"B"`.
    pub name: String,
    /// Index of the first body.
    pub body_a: usize,
    /// Index of the second body, `None` for the ground.
    pub body_b: Option<usize>,
    /// Index of its first residual row in `phi` (its rows are `row`, `row + 1`).
    pub row: usize,
    /// Index of the hinge's point on body `body_a` in [`ModelInfo::points`]
    /// (where the hinge is drawn).
    pub point: usize,
}

/// A slider (prismatic joint): a point of body `body_b` stays on a line
/// fixed in body `body_a` (or in the ground, `body_a = None`), and the two
/// headings keep a fixed difference; or a slot (pin-in-slot joint,
/// `heading = false`): the point stays on the line, the heading is free.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SliderInfo {
    /// Slider name, e.g. `"S"`.
    pub name: String,
    /// Index of the guiding body, `None` for the ground.
    pub body_a: Option<usize>,
    /// Index of the moving body.
    pub body_b: usize,
    /// Index of its first residual row in `phi` (rows `row` = `S.n`, the
    /// offset from the line \[m\], and for a slider `row + 1` = `S.phi`,
    /// the heading \[rad\]).
    pub row: usize,
    /// Whether the heading row `S.phi` exists (a slider) or not (a slot).
    pub heading: bool,
}

/// A drive: a hinge whose angle `phi_a - phi_b` follows a function of time
/// `u(t)` given at run time (a rheonomic constraint, `phi_row(q) = u(t)`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DriveInfo {
    /// Drive name, e.g. `"D"`.
    pub name: String,
    /// Index of the driven hinge in [`ModelInfo::hinges`].
    pub hinge: usize,
    /// Its row in `phi` and `G`.
    pub row: usize,
}

/// A skate (knife edge): a body point whose velocity has no component along
/// the blade normal.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkateInfo {
    /// Skate name, e.g. `"A"`.
    pub name: String,
    /// Index of its contact point in [`ModelInfo::points`].
    pub point: usize,
    /// Index of its row in `G` (>= `n_holonomic`).
    pub row: usize,
}

/// Everything structural about a model at its current family counts:
/// sizes, names and the sparsity pattern of the constraint matrix `G`.
/// Built by [`Model::info`] (it allocates: call it once when a run is set
/// up, not per step). Elements of a `for` family are named by the family's
/// name and the index value: `link3`, `x3`, `J3`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelInfo {
    /// Model name, e.g. `"EzyRoller"`.
    pub name: &'static str,
    /// First line of the model's doc comment.
    pub doc: &'static str,
    /// Names of the generalized coordinates, in order (nq).
    pub coords: Vec<String>,
    /// Parameters, in declaration order.
    pub params: Vec<ParamInfo>,
    /// Bodies, in declaration order.
    pub bodies: Vec<BodyInfo>,
    /// Named points, in declaration order.
    pub points: Vec<PointInfo>,
    /// Hinges, in declaration order.
    pub hinges: Vec<HingeInfo>,
    /// Sliders, in declaration order (their rows follow the hinges').
    pub sliders: Vec<SliderInfo>,
    /// Drives, in declaration order (their rows follow the sliders').
    pub drives: Vec<DriveInfo>,
    /// Skates, in declaration order.
    pub skates: Vec<SkateInfo>,
    /// Names of the constraint rows of `G` (nc): `B.x`, `B.y` per hinge,
    /// `S.n`, `S.phi` per slider, one per drive, then one per skate.
    pub constraints: Vec<String>,
    /// Number of holonomic constraint rows `nh` (two per hinge and per
    /// slider, one per drive).
    pub n_holonomic: usize,
    /// Structural nonzeros `(row, col)` of `G` (nc x nq), row-major sorted.
    /// The entries of rows `< n_holonomic` come first.
    pub pattern: Vec<(usize, usize)>,
}

impl ModelInfo {
    /// Number of generalized coordinates `nq`.
    pub fn nq(&self) -> usize {
        self.coords.len()
    }
    /// Number of velocity constraints `nc` (holonomic rows + skates).
    pub fn nc(&self) -> usize {
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
    /// Indices of the coordinates `name` stands for: the coordinate of
    /// that name, or, for `stem*`, every coordinate of a family written
    /// `stem` followed by its index (`phi*`: `phi1`, `phi2`, ...). Empty if
    /// none.
    pub fn coords_matching(&self, name: &str) -> Vec<usize> {
        match name.strip_suffix('*') {
            None => self.coord_index(name).into_iter().collect(),
            Some(stem) => (0..self.coords.len()).filter(|&k| is_element_of(&self.coords[k], stem)).collect(),
        }
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
    /// Name of entry `k` of the mass diagonal for messages: the parameter
    /// and what it is, `m1 (mass of body body1)`, or `inertia of body
    /// body1` when the model wrote a number; the coordinate's name for an
    /// index outside every body.
    pub fn mass_entry_name(&self, k: usize) -> String {
        for b in &self.bodies {
            for (what, i, param) in
                [("mass", 0, b.mass_param), ("mass", 1, b.mass_param), ("inertia", 2, b.inertia_param)]
            {
                if b.coords[i] == k {
                    return match param {
                        Some(p) => format!("{p} ({what} of body {})", b.name),
                        None => format!("{what} of body {}", b.name),
                    };
                }
            }
        }
        self.coords.get(k).cloned().unwrap_or_default()
    }
}

/// Name-to-index maps of a [`ModelInfo`]: one hash lookup per name, so
/// that resolving the effects of a family of ten thousand links (one per
/// element) costs time linear in the count, not quadratic. Built once per
/// setup.
#[derive(Debug)]
pub struct NameIndex<'a> {
    /// The model described.
    pub info: &'a ModelInfo,
    coords: std::collections::HashMap<&'a str, usize>,
    bodies: std::collections::HashMap<&'a str, usize>,
    points: std::collections::HashMap<&'a str, usize>,
    hinges: std::collections::HashMap<&'a str, usize>,
    skates: std::collections::HashMap<&'a str, usize>,
}

impl<'a> NameIndex<'a> {
    /// The maps of `info` (the first of equal names wins, as a linear search would).
    pub fn new(info: &'a ModelInfo) -> Self {
        fn map<'a>(names: impl Iterator<Item = &'a str>) -> std::collections::HashMap<&'a str, usize> {
            let mut m = std::collections::HashMap::new();
            for (i, n) in names.enumerate() {
                m.entry(n).or_insert(i);
            }
            m
        }
        Self {
            info,
            coords: map(info.coords.iter().map(String::as_str)),
            bodies: map(info.bodies.iter().map(|b| b.name.as_str())),
            points: map(info.points.iter().map(|p| p.name.as_str())),
            hinges: map(info.hinges.iter().map(|h| h.name.as_str())),
            skates: map(info.skates.iter().map(|s| s.name.as_str())),
        }
    }
    /// Index of a coordinate in `q`.
    pub fn coord(&self, name: &str) -> Option<usize> {
        self.coords.get(name).copied()
    }
    /// Index of a body in [`ModelInfo::bodies`].
    pub fn body(&self, name: &str) -> Option<usize> {
        self.bodies.get(name).copied()
    }
    /// Index of a point in [`ModelInfo::points`].
    pub fn point(&self, name: &str) -> Option<usize> {
        self.points.get(name).copied()
    }
    /// Index of a hinge in [`ModelInfo::hinges`].
    pub fn hinge(&self, name: &str) -> Option<usize> {
        self.hinges.get(name).copied()
    }
    /// Index of a skate in [`ModelInfo::skates`].
    pub fn skate(&self, name: &str) -> Option<usize> {
        self.skates.get(name).copied()
    }
}

/// One derived expression, as text (the notation of docs/physics.md: `x1`, `phi1d` for
/// the rate of `phi1`) and as LaTeX.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EquationExpr {
    /// Plain text, e.g. `x1 - x2 + b*cos(phi1) + d*cos(phi2)`.
    pub text: String,
    /// LaTeX math, e.g. `x_{1} - x_{2} + b \cos \varphi_{1} + ...`.
    pub latex: String,
}

/// What the macro derived, for reading and checking (`ezy equations`), at
/// the model's current family counts (each family element's expressions
/// are the element kernel's, with the element's coordinates filled in).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Equations {
    /// The generalized coordinates (nq): their names and LaTeX symbols.
    pub coords: Vec<EquationExpr>,
    /// Mass-matrix diagonal (nq), in terms of parameters.
    pub mass: Vec<EquationExpr>,
    /// Holonomic residual rows `phi(q)` (nh) \[m\].
    pub phi: Vec<EquationExpr>,
    /// Velocity constraints `G_i(q) qd` (nc) [m/s]: `d phi_i/dt` for the
    /// holonomic rows, the skate's lateral velocity for the skate rows.
    pub velocity: Vec<EquationExpr>,
    /// Entries of `G = [C_q; S]` at [`ModelInfo::pattern`].
    pub jacobian: Vec<EquationExpr>,
    /// Convective terms `gamma = d/dq(G qd) qd` (nc) \[m/s^2\].
    pub gamma: Vec<EquationExpr>,
    /// Velocities of the named points (2 x npoints, x then y) \[m/s\].
    pub point_velocities: Vec<EquationExpr>,
}

/// A planar multibody model with hinges and skates, as generated by
/// `model!`. All matrices are passed as flat slices; sizes are given by
/// [`Model::info`]. No method but `info` and `equations` allocates.
///
/// The sizes may depend on the model's family counts (`count N = 5;`,
/// parameters like any other): the generated code loops over each family
/// with one element kernel, so it does not grow with the counts.
pub trait Model: Clone + Send + Sync + 'static {
    /// Sizes, names and the sparsity pattern of `G` at the current counts.
    /// Allocates: call once per run, not per step.
    fn info(&self) -> ModelInfo;
    /// The derived equations as text and LaTeX at the current counts.
    fn equations(&self) -> Equations;
    /// Whether the current family counts give a well-formed model: every
    /// family element refers to an element that exists and names are
    /// unique.
    ///
    /// # Errors
    /// A message naming the count and the reference that falls outside
    /// its family (e.g. "hinge `J[i]` refers to `link[i - 1]` = `link0`,
    /// outside `link` = 1..6").
    fn check_counts(&self) -> Result<(), String> {
        Ok(())
    }

    /// Current value of parameter `index` (order of [`ModelInfo::params`]).
    fn param(&self, index: usize) -> f64;
    /// Sets parameter `index` (order of [`ModelInfo::params`]); a count
    /// takes the value as a whole number (the caller checks it is one).
    fn set_param(&mut self, index: usize, value: f64);

    /// Whether [`Model::normal_matrix`], [`Model::g_winv_mul`] and
    /// [`Model::sub_winv_gt_mul`] are straight-line code at a compile-time
    /// pattern (models without families). The generic loops over the
    /// pattern are slower than the sparse path at every size (measured on
    /// the snake: 0.61 us dense against 0.46 us sparse at 4 rows), so
    /// `KktMethod::Auto` takes the dense path only for unrolled models.
    fn unrolled_kernels(&self) -> bool {
        false
    }

    /// `A = G W^-1 G^T` (nc x nc) from the values of `G` at `pattern` (the
    /// model's [`ModelInfo::pattern`]) and the diagonal `winv` (nq) of
    /// `W^-1`: the lower triangle `a[i * nc + j]`, `j <= i`, is written
    /// (the upper is not touched). Models without families override it
    /// with straight-line code at their compile-time pattern.
    fn normal_matrix(&self, pattern: &[(usize, usize)], nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
        normal_matrix_at(pattern, nc, values, winv, a);
    }
    /// `out = G W^-1 u` (u, winv: nq; out: nc), `G` given by its values at
    /// `pattern` (one kernel for `G M^-1 f` and, with `winv = 1`, `G qd`).
    fn g_winv_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        for (&(r, c), &v) in pattern.iter().zip(values) {
            out[r] += v * (winv[c] * u[c]);
        }
    }
    /// `v -= W^-1 G^T x` (x: nc, v: nq), `G` given by its values at `pattern`.
    fn sub_winv_gt_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
        for (&(r, c), &g) in pattern.iter().zip(values) {
            v[c] -= winv[c] * (g * x[r]);
        }
    }

    /// Diagonal of the mass matrix `M` (nq): `m [kg], m [kg], I [kg m^2]` per body.
    fn mass_diagonal(&self, out: &mut [f64]);

    /// Body-frame geometry at the current parameters: `points` (2 x
    /// npoints) gets each named point's coordinates `(px, py)` \[m\] in its
    /// body's frame (centre of mass at the origin, heading along x);
    /// `blades` (2 x nskates) gets each skate's unit blade direction
    /// `(tx, ty)` in its body's frame. Effects that act at a point or along
    /// a blade are built from these (conventions of docs/physics.md §1).
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]);

    /// Holonomic residual `phi(q)` (nh) \[m\].
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
    /// `gamma(q, qd) = d/dq(G qd) qd` (nc) \[m/s^2\], sharing subexpressions.
    fn constraint_terms<S: Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]);
    /// Positions of the named points (2 x npoints, `x, y` per point) \[m\].
    fn points<S: Scalar>(&self, q: &[S], out: &mut [S]);
    /// Velocities of the named points (2 x npoints) \[m/s\].
    fn point_velocities<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]);

    /// The minimal coordinates `model!` derived for this model, or why it
    /// could not (see [`MinimalLayout`]). The default: none.
    ///
    /// # Errors
    /// A sentence saying which item keeps the model from them (a family, a
    /// slider, a drive, a hinge closing a loop, a skate whose row no
    /// velocity enters with a coefficient free of the coordinates).
    fn minimal_layout(&self) -> Result<MinimalLayout, String> {
        Err(format!("`model!` derived no minimal coordinates for model {}", self.info().name))
    }

    /// The full state from the minimal one ([`MinimalLayout`]): reads the
    /// kept coordinates `q[p]` and the independent speeds `qd[u]`, these
    /// being body-frame velocities `V` (`V[3 i]`, `V[3 i + 1]` body `i`'s
    /// forward and lateral velocity in its own frame \[m/s\], `V[3 i + 2]`
    /// its angular rate \[rad/s\]); writes every other entry of `q` (nq),
    /// all of `qd` (nq) as global rates, `b = dV/du` (nq x nu, row-major)
    /// and `c` (nq + 2 nb, nb = nq / 3): first the body-frame acceleration
    /// at `u' = 0` (the rate of `V` along `pd` plus the frame's turning
    /// `(-w v_y, w v_x, 0)`), so that a body's acceleration in its frame
    /// is `b u' + c[..nq]` \[m/s^2, rad/s^2\], then each body's `cos phi,
    /// sin phi`. Straight-line code with shared subexpressions; does
    /// nothing for a model without a layout.
    fn minimal_expand<S: Scalar>(&self, q: &mut [S], qd: &mut [S], b: &mut [S], c: &mut [S]) {
        let _ = (q, qd, b, c);
    }

    /// [`Model::minimal_expand`] without `b` and `c`: the full `q` and `qd`
    /// (nq each) \[m, rad, m/s, rad/s\] from the kept coordinates `q[p]` and
    /// the independent speeds `qd[u]`, the same expressions and so the same
    /// numbers, for a state that is only output (a dense-output sample).
    /// Returns whether it did so; the default does nothing and returns
    /// `false`, and the caller then uses [`Model::minimal_expand`]. The
    /// answer is the model's, the same at every state: a run asks once,
    /// at its start, and then leaves its dense-output samples to it.
    fn minimal_state<S: Scalar>(&self, q: &mut [S], qd: &mut [S]) -> bool {
        let _ = (q, qd);
        false
    }

    /// The table of fixed quantities [`Model::minimal_rhs`] reads: every
    /// subexpression of it that mentions only parameters and numbers
    /// (`d / (c + d)`, `m2 c^2 + I2`), computed once for the current
    /// parameters, so that an evaluation does not repeat them (loop-invariant
    /// code motion). `None` when the model has no fused right-hand side
    /// (no [`MinimalLayout`], or a hand-written model): the default.
    /// Computed anew after any parameter change.
    fn minimal_constants(&self) -> Option<Vec<f64>> {
        None
    }

    /// The right-hand side on the minimal coordinates in one pass, for a
    /// model whose [`Model::minimal_constants`] is `Some(k)`: from
    /// `z = [p, u]` (the kept coordinates and the independent speeds of
    /// [`MinimalLayout`], np + nu, read), writes the full `q` and `qd`
    /// (nq each, global rates \[m, rad, m/s, rad/s\]) exactly as
    /// [`Model::minimal_expand`] does, calls `forces(q, qd, f, tau)` once
    /// for the generalized applied force `f` (nq, zero on entry, global)
    /// \[N, N m\] and the hinges' torques `tau` (nh, zero on entry, in
    /// the order of [`ModelInfo::hinges`]) \[N m\], each acting `+tau` on
    /// its hinge's first body and `-tau` on its second (a motor, spring,
    /// damper or servo at a hinge, [`crate::effects::hinge::HingeLaw`]), and
    /// writes `dz = [pd, u']` (np + nu): the kept
    /// coordinates' rates and the speeds' rates from Maggi's equations in
    /// the body frames, `B^T M B u' = B^T (F - M c)` (Kane & Levinson 1985,
    /// ch. 6; [`Model::minimal_maggi`] up to rounding), solved by LDL^T
    /// with the checks of the KKT path. `model!` generates it as
    /// straight-line code, with each hinge's torque mapped onto the
    /// speeds at compile time (`B^T` of the two headings' rows) and each
    /// body's force skipped where it is zero: where `forces` writes no `f`
    /// (a scene whose effects are all hinge torques, or none) the
    /// optimizer removes `f`'s part entirely. The default does nothing (it
    /// is never called without constants).
    ///
    /// # Errors
    /// [`MinimalRhsError::Forces`] with what `forces` returned, or
    /// [`MinimalRhsError::Maggi`] if `B^T M B` is not positive definite
    /// (a non-finite state); `dz` is then partly written.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn minimal_rhs<E, F>(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: F,
    ) -> Result<(), MinimalRhsError<E>>
    where
        F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
    {
        let _ = (k, z, q, qd, dz, forces);
        Ok(())
    }

    /// [`Model::minimal_rhs`] for an evaluation whose `q` and `qd` no one
    /// reads afterwards (a stage of the integrator) and whose `forces`
    /// read only the headings (hinge torques: each body's angle `q[3 i +
    /// 2]` and angular rate `qd[3 i + 2]`): `dz` as
    /// [`Model::minimal_rhs`] writes it, but of `q` and `qd` only the
    /// headings are written, the rest left as they were, so that the
    /// eliminated coordinates' positions and global rates are not
    /// computed. `model!` generates it; the default calls
    /// [`Model::minimal_rhs`].
    ///
    /// # Errors
    /// As [`Model::minimal_rhs`].
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn minimal_rhs_lean<E, F>(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: F,
    ) -> Result<(), MinimalRhsError<E>>
    where
        F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
    {
        self.minimal_rhs(k, z, q, qd, dz, forces)
    }

    /// [`Model::minimal_rhs`] with a run's effects as its `forces`, the
    /// call [`crate::Dynamics`] makes at every evaluation of the fused
    /// right-hand side: with `waves` empty (every effect a hinge torque, or
    /// none) the effects are handed over as the hinges' torques, which the
    /// model maps at compile time, and where `lean` (a stage, whose full
    /// state no one reads) through [`Model::minimal_rhs_lean`]; otherwise
    /// each effect adds its generalized force from its waveforms `waves`
    /// at `t` \[s\] (one per effect). Each effect's power \[W\] goes to
    /// `power` (one per effect). A method of the trait so that
    /// [`crate::AnyModel`] reaches the model's own code in one indirect
    /// call; models do not override it.
    ///
    /// # Errors
    /// As [`Model::minimal_rhs`], the forces' error a
    /// [`crate::SimError::EffectFailed`].
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn minimal_rhs_effects(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        t: f64,
        effects: &[crate::Effect],
        waves: &[crate::effects::Waveforms],
        power: &mut [f64],
        lean: bool,
    ) -> Result<(), MinimalRhsError<crate::SimError>> {
        use crate::effects::law::{apply_effects, hinge_torques};
        if waves.is_empty() {
            // the applied-force part of the generated code, never written,
            // folds away
            // a closure for each call, so that each is inlined into its own
            if lean {
                self.minimal_rhs_lean(k, z, q, qd, dz, |q, qd, _, tau| {
                    hinge_torques(effects, t, q, qd, tau, power);
                    Ok(())
                })
            } else {
                self.minimal_rhs(k, z, q, qd, dz, |q, qd, _, tau| {
                    hinge_torques(effects, t, q, qd, tau, power);
                    Ok(())
                })
            }
        } else {
            self.minimal_rhs(k, z, q, qd, dz, |q, qd, f, _| apply_effects(effects, waves, t, q, qd, f, power))
        }
    }

    /// Maggi's equations on the minimal coordinates in the body frames,
    /// from the expansion's `b` (nq x nu) and `c` (nq + 2 nb), the mass
    /// diagonal `mass` (nq, each body's alike along x and y) and the
    /// applied force `f` (nq, global): with `F` the force turned into each
    /// body's frame by `c`'s cos and sin, the lower triangle of
    /// `a = B^T M B` (nu x nu, row-major) \[kg, kg m, kg m^2\] and
    /// `r = B^T (F - M c)` (nu) \[N, N m\] (Kane & Levinson 1985, ch. 6).
    /// `model!` generates it over `B`'s structural nonzeros with its
    /// constant entries inlined; this default loops.
    fn minimal_maggi(&self, mass: &[f64], b: &[f64], c: &[f64], f: &[f64], a: &mut [f64], r: &mut [f64]) {
        let (nu, nq) = (r.len(), f.len());
        a.fill(0.0);
        r.fill(0.0);
        for (j, ((row, &cj), &mj)) in b.chunks_exact(nu).zip(c).zip(mass).enumerate() {
            let (i, (cs, sn)) = (j / 3, (c[nq + 2 * (j / 3)], c[nq + 2 * (j / 3) + 1]));
            let fj = match j % 3 {
                0 => cs * f[3 * i] + sn * f[3 * i + 1],
                1 => cs * f[3 * i + 1] - sn * f[3 * i],
                _ => f[j],
            } - mj * cj;
            for (k, &bk) in row.iter().enumerate() {
                r[k] += bk * fj;
                for (l, &bl) in row[..=k].iter().enumerate() {
                    a[k * nu + l] += mj * bk * bl;
                }
            }
        }
    }
}

/// Why [`Model::minimal_rhs`] stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum MinimalRhsError<E> {
    /// The applied forces failed: what the `forces` callback returned.
    Forces(E),
    /// Maggi's mass matrix `B^T M B` could not be factored (a pivot not
    /// positive, or non-finite entries: the state overflowed).
    Maggi(crate::kkt::KktError),
}

/// The effects' context read from a model (the effects, a floor below
/// the [`Model`] trait, take the model's values as data:
/// [`crate::effects::EffectContext::from_values`]).
impl<'a> crate::effects::EffectContext<'a> {
    /// The context of `model`, whose names `names` indexes: its body-frame
    /// point offsets and blade directions, mass diagonal and parameter
    /// values at its current parameters.
    pub fn new<M: Model>(model: &M, names: &'a NameIndex<'a>) -> Self {
        let info = names.info;
        let mut points = vec![0.0; 2 * info.points.len()];
        let mut blades = vec![0.0; 2 * info.skates.len()];
        model.local_geometry(&mut points, &mut blades);
        let mut mass = vec![0.0; info.nq()];
        model.mass_diagonal(&mut mass);
        let model_params = (0..info.params.len()).map(|i| model.param(i)).collect();
        Self::from_values(names, points, blades, mass, model_params)
    }
}

impl crate::effects::EffectSpec {
    /// Resolves names to coordinate indices and body-frame geometry of
    /// `model` (at its current parameters): the effect called `name`. For
    /// many effects of one model build an
    /// [`crate::effects::EffectContext`] once and call
    /// [`crate::effects::EffectSpec::resolve_in`].
    ///
    /// # Errors
    /// As [`crate::effects::EffectSpec::resolve_in`].
    pub fn resolve<M: Model>(&self, name: &str, model: &M) -> Result<crate::effects::Effect, crate::SimError> {
        let info = model.info();
        self.resolve_in(name, &crate::effects::EffectContext::new(model, &NameIndex::new(&info)))
    }
}

/// Minimal coordinates of a model whose hinges form a tree and whose
/// skate rows each fix one velocity with a constant coefficient, derived
/// symbolically by `model!` (Wehage & Haug's coordinate partitioning with
/// the partition and the dependent quantities in closed form; the
/// null-space form `qd = B(p) u` of Kane's method, Kane & Levinson,
/// *Dynamics: Theory and Applications*, 1985, ch. 4).
///
/// - Every hinge of the tree gives its child body's `x, y` as functions of
///   the parent's coordinates and the child's angle; the kept coordinates
///   `p` (indices into `q`) are every root body's `x, y, phi` and every
///   other body's `phi` (a body hinged to the ground keeps only `phi`).
/// - The speeds are body-frame velocities (Kane's choice of generalized
///   speeds): each body's forward and lateral velocity in its own frame
///   and its angular rate, `V` (nq, indexed as `q`).
/// - Every skate row, linear in `V`, is solved for one of them whose
///   coefficient is a constant: a root body's lateral (or forward)
///   velocity first, with a dimensionless pivot that no geometry zeroes,
///   else a body's angular rate (the pivot the distance from the hinge to
///   the contact point along the blade); the others are the independent
///   speeds `u` (indices into `V`), `pd = N(p) u`.
///
/// The equations of motion are then Maggi's (Kane's) `B^T M B u' = B^T (F -
/// M c)` (nu x nu) in the body frames, `F` the applied force turned into
/// them, with no constraint left to drift.
#[derive(Debug, Clone, PartialEq)]
pub struct MinimalLayout {
    /// Kept coordinates `p` (indices into `q`, ascending).
    pub coords: Vec<usize>,
    /// Independent speeds `u` (indices into the body-frame velocities `V`,
    /// ascending; a subset of `coords`).
    pub speeds: Vec<usize>,
    /// Each skate row's constant coefficient at the current parameters:
    /// `(skate, index of the velocity it fixes, coefficient [m or 1])`. A
    /// zero (parameters that put the hinge on the skate's axle, the line
    /// through the contact point across the blade) leaves that velocity
    /// undetermined, and the reduced formulation takes a numeric partition.
    pub pivots: Vec<(String, usize, f64)>,
}

/// Whether `name` is an element of the family `stem`: `stem` followed by
/// a whole number (`J12` of `J`).
pub fn is_element_of(name: &str, stem: &str) -> bool {
    name.strip_prefix(stem).is_some_and(|rest| !rest.is_empty() && rest.bytes().all(|b| b.is_ascii_digit()))
}

/// Scatters pattern values into a dense row-major matrix (rows x ncols).
/// Entries not in the pattern are set to zero.
pub fn scatter_dense(pattern: &[(usize, usize)], values: &[f64], ncols: usize, dense: &mut [f64]) {
    dense.iter_mut().for_each(|v| *v = 0.0);
    for (&(r, c), &v) in pattern.iter().zip(values) {
        dense[r * ncols + c] = v;
    }
}

/// `A = G W^-1 G^T`, lower triangle (`a[i * nc + j]`, `j <= i`), from `G`'s
/// values at a row-grouped `pattern` (rows ascending, as
/// [`ModelInfo::pattern`]): the generic form of [`Model::normal_matrix`].
/// `O(nc^2 + sum over row pairs of their entries)`; for large models the
/// sparse path assembles `A` itself.
pub fn normal_matrix_at(pattern: &[(usize, usize)], nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
    let row = |r: usize| pattern.partition_point(|p| p.0 < r)..pattern.partition_point(|p| p.0 <= r);
    for i in 0..nc {
        let ri = row(i);
        for j in 0..=i {
            let mut sum = 0.0;
            for e1 in ri.clone() {
                let k = pattern[e1].1;
                for e2 in row(j) {
                    if pattern[e2].1 == k {
                        sum += values[e1] * values[e2] * winv[k];
                    }
                }
            }
            a[i * nc + j] = sum;
        }
    }
}

/// The rate of a coordinate as LaTeX: the dot over the letter, not over
/// its subscript (`phi1` -> `\dot{\varphi}_{1}`).
pub fn latex_rate(name: &str) -> String {
    let n = latex_name(name);
    match n.find("_{") {
        Some(k) => format!("\\dot{{{}}}{}", &n[..k], &n[k..]),
        None => format!("\\dot{{{n}}}"),
    }
}

/// A name as LaTeX: trailing digits become a subscript, Greek letter names
/// become commands (`phi1` -> `\varphi_{1}`, `I1` -> `I_{1}`, `x` -> `x`).
pub fn latex_name(name: &str) -> String {
    let split = name.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let (stem, digits) = name.split_at(split);
    let (stem, rest) = match stem.split_once('_') {
        Some((s, r)) => (s, Some(r)),
        None => (stem, None),
    };
    const GREEK: &[&str] = &[
        "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa", "lambda", "mu", "nu",
        "xi", "pi", "rho", "sigma", "tau", "upsilon", "chi", "psi", "omega", "Gamma", "Delta", "Theta", "Lambda", "Xi",
        "Pi", "Sigma", "Phi", "Psi", "Omega",
    ];
    let mut out = if stem == "phi" {
        "\\varphi".to_string()
    } else if GREEK.contains(&stem) {
        format!("\\{stem}")
    } else if stem.chars().count() > 1 {
        format!("\\mathrm{{{stem}}}")
    } else {
        stem.to_string()
    };
    let sub: Vec<&str> = rest.into_iter().chain((!digits.is_empty()).then_some(digits)).collect();
    if !sub.is_empty() {
        out.push_str(&format!("_{{{}}}", sub.join(",")));
    }
    out
}

/// Renders a template of the macro (`ezy equations`): markers
/// `\u{1}qK\u{2}` (the element's local coordinate `K`), `\u{1}dK\u{2}`
/// (its rate) and `\u{1}pK\u{2}` (parameter `K`) become the names in
/// `coords` and `params`, as text and as LaTeX ([`latex_name`]).
#[doc(hidden)]
pub fn render_equation(text: &str, latex: &str, coords: &[&str], params: &[&str]) -> EquationExpr {
    let fill = |t: &str, tex: bool| -> String {
        let mut out = String::with_capacity(t.len());
        let mut rest = t;
        while let Some(i) = rest.find('\u{1}') {
            out.push_str(&rest[..i]);
            let end = rest[i..].find('\u{2}').map(|j| i + j).expect("closed marker");
            let kind = rest.as_bytes()[i + 1];
            let k: usize = rest[i + 2..end].parse().expect("marker index");
            let name = match kind {
                b'p' => params[k],
                _ => coords[k],
            };
            match (kind, tex) {
                (b'd', false) => {
                    out.push_str(name);
                    out.push('d');
                }
                (b'd', true) => out.push_str(&latex_rate(name)),
                (_, false) => out.push_str(name),
                (_, true) => out.push_str(&latex_name(name)),
            }
            rest = &rest[end + 1..];
        }
        out.push_str(rest);
        out
    };
    EquationExpr { text: fill(text, false), latex: fill(latex, true) }
}

/// Offsets of every item of a generated model at its current counts: the
/// first element of family `f` and its length, each body item's first
/// column in `q` and index among all bodies, each point item's index,
/// each constraint item's first row, first pattern value and index among
/// the items of its kind. Generated code only.
#[doc(hidden)]
#[derive(Debug, Clone, Copy)]
pub struct Layout<const NF: usize, const NB: usize, const NP: usize, const NG: usize> {
    pub f_start: [i64; NF],
    pub f_len: [usize; NF],
    pub body_off: [usize; NB],
    pub body_index: [usize; NB],
    pub point_index: [usize; NP],
    pub row: [usize; NG],
    pub val: [usize; NG],
    pub item_index: [usize; NG],
    pub nq: usize,
    pub nc: usize,
    pub nh: usize,
    pub nnz: usize,
    pub nnz_h: usize,
    pub n_bodies: usize,
    pub n_points: usize,
}

/// Most generalized coordinates a model may have at its family counts:
/// 300,000 (the snake at `N = 100,000`). Setting a run up takes about
/// [`SETUP_BYTES_PER_COORD`] per coordinate (the snake at `N = 100,000`:
/// 1.3 GB and 5 s on 2 cores; at `N = 1,000,000` it would take 13 GB),
/// so a model past this is refused by [`Model::check_counts`] before any
/// of it is allocated.
pub const MAX_COORDS: usize = 300_000;

/// The largest magnitude ezy takes for a number of a model (a parameter,
/// a mass or an inertia) or of an effect (a coefficient, a load, a
/// waveform's amplitude), in SI units: 1e34.
///
/// Every entry of the right-hand side is a product of a few such numbers
/// and the state (a spring's power is stiffness x stretch x rate, the
/// gravity's m g v, an acceleration a force over a mass), and the adaptive
/// methods square the entries divided by the tolerance (down to
/// [`crate::simulate::MIN_TOLERANCE`] = 1e-14) in their error norm and
/// their first step: past sqrt(1.8e308) x 1e-14 = 1.3e140 that square
/// overflows and the step collapses to 0 at t = 0 (measured: a spring of
/// 1e300 N/m, a mass of 1e150 kg under gravity, a torque of 1e300 N m
/// stopped with "the step size fell to 0e0 s"). A product of four numbers
/// up to 1e34 stays below 1e136. The numbers of a planar mechanism lie far
/// inside (the Sun's mass is 2e30 kg); a larger one is a slip of the
/// keyboard or a stand-in for "infinite", which ezy models otherwise (a
/// contact that never slides is the ideal skate, a rigid link a hinge).
/// The bound is necessary, not sufficient: a value inside it may still
/// make a scene too stiff to integrate.
pub const MAX_MAGNITUDE: f64 = 1e34;

/// The fastest rate \[1/s\] (an angular frequency \[rad/s\], a Baumgarte
/// rate) a run can follow: 1 / (16 eps) = 2.8e14 1/s. The shortest step an
/// integrator takes at time t is 16 eps max(t, min(t_end, 1 s)), the
/// rounding level of t (`simulate`'s floor, 3.6e-15 s at t = 1 s): a
/// quantity that changes by a radian, or decays by a factor e, within it
/// cannot be followed by any step.
pub const MAX_RATE: f64 = 1.0 / (16.0 * f64::EPSILON);

/// The largest magnitude of an angle a scene gives \[rad\] (a phase, a rest
/// angle, a direction): 1e6 rad (160,000 turns). An angle carries the
/// rounding eps |angle|, 2.2e-10 rad at 1e6 rad, about the tightest
/// tolerances runs ask for (1e-9 to 1e-12); a phase of 1e300 rad swamps
/// `omega t` entirely (the waveform is a constant).
pub const MAX_ANGLE: f64 = 1e6;

/// `Ok` if `v` is finite and at most [`MAX_MAGNITUDE`] in magnitude.
///
/// # Errors
/// A sentence naming `name = v` and why it is refused.
pub fn check_magnitude(name: &str, v: f64) -> Result<(), String> {
    check_bound(
        name,
        v,
        MAX_MAGNITUDE,
        "numbers",
        "the forces, powers and energies formed from a larger one overflow double precision",
    )
}

/// `Ok` if `v` is finite and at most [`MAX_ANGLE`] in magnitude.
///
/// # Errors
/// A sentence naming `name = v` and why it is refused.
pub fn check_angle(name: &str, v: f64) -> Result<(), String> {
    check_bound(
        name,
        v,
        MAX_ANGLE,
        "angles [rad]",
        "beyond, the angle's rounding (eps |angle|) passes the tolerances a run keeps",
    )
}

/// `Ok` if `v` is finite and at most [`MAX_RATE`] in magnitude.
///
/// # Errors
/// A sentence naming `name = v` and why it is refused.
pub fn check_rate(name: &str, v: f64) -> Result<(), String> {
    check_bound(
        name,
        v,
        MAX_RATE,
        "rates [1/s]",
        "a faster one changes within the rounding level of t (16 eps t, the shortest step), so no step can follow it",
    )
}

fn check_bound(name: &str, v: f64, bound: f64, what: &str, why: &str) -> Result<(), String> {
    if !v.is_finite() {
        return Err(format!("{name} = {v} must be finite"));
    }
    if v.abs() <= bound {
        return Ok(());
    }
    Err(format!(
        "{name} = {} is out of range: ezy takes {what} up to {:e} in magnitude ({why})",
        crate::fmt_value(v),
        round_bound(bound),
    ))
}

/// A bound as a message writes it (2.8e14, not 281474976710656).
fn round_bound(b: f64) -> f64 {
    format!("{b:.1e}").parse().unwrap_or(b)
}

/// Memory a run's set-up takes per generalized coordinate \[bytes\]:
/// measured as the peak resident size of `ezy run snake --t-end 0.01`
/// at `N = 100,000` and `300,000` (1.32 GB / 300,000 and 3.86 GB /
/// 900,000 coordinates).
pub const SETUP_BYTES_PER_COORD: f64 = 4.4e3;

/// Refuses a model of more than [`MAX_COORDS`] coordinates, naming the
/// family counts that make them (generated `check_counts`, before any
/// element is visited).
///
/// # Errors
/// A message naming the counts, the coordinates and the memory a run
/// would take.
#[doc(hidden)]
pub fn check_model_size(nq: usize, counts: &[(&str, usize)]) -> Result<(), String> {
    if nq <= MAX_COORDS {
        return Ok(());
    }
    let given: Vec<String> = counts.iter().map(|(n, v)| format!("{n} = {v}")).collect();
    Err(format!(
        "{} give{} {nq} generalized coordinates, more than the {MAX_COORDS} ezy sets up (about {:.1} kB each: {} GB for this model); take a smaller count",
        given.join(", "),
        if counts.len() == 1 { "s" } else { "" },
        SETUP_BYTES_PER_COORD / 1e3,
        crate::fmt_value((nq as f64 * SETUP_BYTES_PER_COORD / 1e8).round() / 10.0),
    ))
}

/// Checks that the names of `info` are unique per kind (coordinates,
/// bodies, points, joints and drives, skates): family elements are named
/// by their index, so `x1` of a family can collide with a single `x1`.
///
/// # Errors
/// A message naming the repeated name and its kind.
#[doc(hidden)]
pub fn unique_names(info: &ModelInfo) -> Result<(), String> {
    fn once<'a>(kind: &str, names: impl Iterator<Item = &'a str>) -> Result<(), String> {
        let mut seen = std::collections::HashSet::new();
        for n in names {
            if !seen.insert(n) {
                return Err(format!("two {kind}s are named `{n}` at these counts"));
            }
        }
        Ok(())
    }
    once("coordinate", info.coords.iter().map(String::as_str))?;
    once("body", info.bodies.iter().map(|b| b.name.as_str()))?;
    once("point", info.points.iter().map(|p| p.name.as_str()))?;
    once(
        "joint or drive",
        info.hinges
            .iter()
            .map(|h| h.name.as_str())
            .chain(info.sliders.iter().map(|s| s.name.as_str()))
            .chain(info.drives.iter().map(|d| d.name.as_str())),
    )?;
    once("skate", info.skates.iter().map(|s| s.name.as_str()))
}

/// What a name of an initial value stands for in a model (a scene's
/// `[initial] q` key, [`crate::Problem::q`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum InitialName {
    /// Coordinates, by index (one, or a family's for `stem*`).
    Coords(Vec<usize>),
    /// A hinge's angle, by the hinge's index.
    HingeAngle(usize),
}

impl ModelInfo {
    /// What `name` stands for as an initial value: coordinates (a name,
    /// or `stem*` for a family), or `theta_<hinge>` a hinge angle (a
    /// coordinate of that name wins); `None` for neither.
    pub fn initial_name(&self, name: &str) -> Option<InitialName> {
        let ks = self.coords_matching(name);
        if !ks.is_empty() {
            return Some(InitialName::Coords(ks));
        }
        let hinge = name.strip_prefix("theta_")?;
        self.hinge_index(hinge).map(InitialName::HingeAngle)
    }
}
