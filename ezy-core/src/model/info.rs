//! The static description ([`ModelInfo`]) every generated model carries:
//! data only (it imports the modules everything speaks, names, settings,
//! errors, and nothing else), read by integrators, effects, drives and the
//! rest.
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

/// A parameter defined in the model by an expression of others (`param
/// I = m * r * r;`): not settable; its expression stands wherever the
/// model names it, so it follows the parameters it is made of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DerivedParamInfo {
    /// Its name, e.g. `"I"`.
    pub name: &'static str,
    /// Its expression as written, tokens spaced: `"m * r * r"`.
    pub formula: &'static str,
    /// Unit, taken from the `[...]` at the end of the doc comment (`""` if none).
    pub unit: &'static str,
    /// The doc comment, without the unit.
    pub doc: &'static str,
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
/// Built by [`Model::info`](crate::model::Model::info) (it allocates: call it once when a run is set
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
    /// Parameters defined by expressions of others, in declaration order
    /// (not in `params`: they cannot be set).
    pub derived: Vec<DerivedParamInfo>,
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
    /// Why `name` cannot be set: a parameter the model defines by an
    /// expression (naming it), or an unknown one (listing the model's).
    pub fn unknown_param(&self, name: &str) -> String {
        if let Some(d) = self.derived.iter().find(|d| d.name == name) {
            return format!(
                "parameter `{name}` of model {} is defined as `{}` and follows the parameters it names; set those instead",
                self.name, d.formula
            );
        }
        let known: Vec<&str> = self.params.iter().map(|p| p.name).collect();
        let known = if known.is_empty() { "none".to_string() } else { known.join(", ") };
        format!("unknown parameter `{name}` in model {}; its parameters: {known}", self.name)
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
/// [`ModelInfo::pattern`]): the generic form of [`Model::normal_matrix`](crate::model::Model::normal_matrix).
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
/// so a model past this is refused by [`Model::check_counts`](crate::model::Model::check_counts) before any
/// of it is allocated.
pub const MAX_COORDS: usize = ezy_lang::MAX_COORDS;

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
        crate::names::fmt_value((nq as f64 * SETUP_BYTES_PER_COORD / 1e8).round() / 10.0),
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
/// `[initial] q` key, [`crate::problem::Problem::q`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum InitialName {
    /// Coordinates, by index (one, or a family's for `stem*`).
    Coords(Vec<usize>),
    /// A hinge's angle, by the hinge's index.
    HingeAngle(usize),
}

impl ModelInfo {
    /// Whether coordinate `k` is an angle (a body's heading) \[rad\]
    /// rather than a position \[m\].
    pub fn is_angle(&self, k: usize) -> bool {
        self.bodies.iter().any(|b| b.coords[2] == k)
    }

    /// Checks an initial value `value` given to `target` in `group`
    /// (`q`, `qd` or `guess`): an angle (a heading, a hinge angle among
    /// the positions) at most [`crate::settings::MAX_ANGLE`] in size, as
    /// the waveforms' phases are; other values are checked where they are
    /// used (a kinetic energy that overflows names its velocity).
    ///
    /// # Errors
    /// The sentence of [`crate::settings::check_angle`], naming
    /// `name = value`.
    pub fn check_initial(&self, group: &str, target: &InitialName, name: &str, value: f64) -> Result<(), String> {
        let angle = group != "qd"
            && match target {
                InitialName::Coords(ks) => ks.iter().any(|&k| self.is_angle(k)),
                InitialName::HingeAngle(_) => true,
            };
        if angle { crate::settings::check_angle(name, value) } else { Ok(()) }
    }

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
