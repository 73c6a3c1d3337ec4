//! Points, hinges and skates -> symbolic constraint expressions.
//!
//! For body `i` with coordinates `(x, y, phi)` and a point at body
//! coordinates `(px, py)`, the point's world position is
//! `r = (x + px cos phi - py sin phi, y + px sin phi + py cos phi)`.
//!
//! - Hinge: `phi_h(q) = r_P - r_Q` (two rows), or `r_P - ground` for a
//!   ground-fixed point. Its Jacobian rows are `d phi_h / dq`.
//! - Slider (prismatic joint) of `P` along the line through `Q` with
//!   direction `t` in the guide's frame: `n . (r_P - r_Q) = 0` with
//!   `n = R(phi_a) (-t_y, t_x) / |t|`, and `phi_b - phi_a - angle = 0`
//!   (for a ground line: `R = I`, `phi_a = 0`). Two holonomic rows,
//!   named `S.n` and `S.phi`, after the hinges' rows. A slot (pin in a
//!   slot) has the first row only: the heading is free.
//! - Drive of a hinge: the row `phi_a - phi_b` (`phi_a` for a ground
//!   hinge), after the sliders' rows; the runtime subtracts the prescribed
//!   angle `u(t)` (and `u'`, `u''` at velocity and acceleration level).
//! - Skate with blade direction `t` (body coordinates, normalized): the
//!   world normal is `n = R(phi) (-t_y, t_x)` and the row of `S(q)` is
//!   `n^T dr_P/dq`, so `S qd` is the contact point's lateral velocity \[m/s\].
//! - Convective term of every velocity-constraint row `g(q) qd`:
//!   `gamma = d/dq(g(q) qd) qd`.
//!
//! Every formula of docs/physics.md §2-§4 and §10.2 follows from these
//! definitions; none is typed in.
//!
//! Each constraint item (a single one, or a `for` family) is derived once,
//! as an element kernel in *local* coordinates: the bodies it touches are
//! its slots, slot `s` owning local coordinates `3 s .. 3 s + 3`. The
//! runtime maps slots to columns of `q` per element; a model without
//! families is also renamed to global coordinates (straight-line code).

use std::collections::HashMap;

use syn::{BinOp, Expr, Ident, UnOp};

use crate::ast::{Affine, Body, HingeTarget, ModelDef, Point};
use crate::check::{BodyRef, Errors, PointRef, Resolved, same_body};
use crate::sym::{Arena, Id, Sym};

/// The kind of a constraint item.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Kind {
    Hinge,
    Slider,
    Drive,
    Skate,
}

impl Kind {
    /// How many kinds there are.
    pub const COUNT: usize = 4;

    /// Its place among the kinds, `0..COUNT`: the order of their rows
    /// and of `ModelInfo`'s lists (hinges, sliders, drives, skates).
    pub fn index(self) -> usize {
        self as usize
    }
}

/// One constraint item (single or a family), derived in local coordinates.
pub struct Group {
    pub kind: Kind,
    /// Index among the items of its kind (`def.hinges[item]`, ...).
    pub item: usize,
    /// The `for` family, if any.
    pub family: Option<usize>,
    /// The bodies it touches: slot `s` has local coordinates `3s..3s+3`.
    pub slots: Vec<BodyRef>,
    /// The family indices its expressions name: `Sym::Index(k)` is the
    /// value of `indices[k]` at the element (`indices[0]` is the item's
    /// own index, `i`; a family point's offsets named by `P[i - 1]` read
    /// `i - 1`, by `P[N]` the count).
    pub indices: Vec<Affine>,
    /// Holonomic residual rows (empty for a skate).
    pub phi: Vec<Id>,
    /// Rows of `G` over the local coordinates (rows x 3 slots).
    pub g: Vec<Vec<Id>>,
    /// Convective terms (rows).
    pub gamma: Vec<Id>,
    /// Velocity forms `G_i qd` (rows), for readable equations.
    pub velocity: Vec<Id>,
    /// Row name suffixes (`.x`, `.y`; `.n`, `.phi`; `` for drives, skates).
    pub suffixes: Vec<&'static str>,
    /// A slider's, slot's or skate's direction as written, `(dx, dy)`,
    /// before it is normalized (`None` for hinges and drives).
    pub direction: Option<[Id; 2]>,
}

impl Group {
    /// Number of rows per element.
    pub fn rows(&self) -> usize {
        self.g.len()
    }
    /// Structural nonzeros `(row, local column)` of one element, row-major.
    pub fn local_pattern(&self, ar: &Arena) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (r, row) in self.g.iter().enumerate() {
            for (c, &e) in row.iter().enumerate() {
                if !ar.is_zero(e) {
                    out.push((r, c));
                }
            }
        }
        out
    }
    /// Whether its rows are holonomic.
    pub fn holonomic(&self) -> bool {
        self.kind != Kind::Skate
    }
}

/// A point item in local coordinates of its body (slot 0); a family
/// point's expressions name its own index as `Sym::Index(0)`.
pub struct PointDerived {
    /// Its body item (`None` if unresolved); a family point sits on the
    /// element of the same index, a single point on
    /// [`Resolved::point_body_index`].
    pub body: Option<usize>,
    /// World position and velocity.
    pub pos: [Id; 2],
    pub vel: [Id; 2],
    /// Body-frame coordinates `(px, py)`, in parameters.
    pub local: [Id; 2],
}

/// Everything the emitter needs.
pub struct Derived {
    pub ar: Arena,
    /// Constraint items in row order: hinges, sliders, drives (holonomic),
    /// then skates.
    pub groups: Vec<Group>,
    pub points: Vec<PointDerived>,
    /// Mass-matrix diagonal `(m, m, I)` of every body item, in parameters
    /// (and a family body's own index, `Sym::Index(0)`).
    pub mass: Vec<[Id; 3]>,
    /// Unit blade direction `(tx, ty)` of every skate item, body frame
    /// (a family skate's own index is `Sym::Index(0)`).
    pub blades: Vec<[Id; 2]>,
}

/// What a user expression may name: the parameters and, in an item of a
/// family, the family's index variable.
pub struct Scope<'a> {
    pub params: &'a [String],
    /// The variable of the item's family (`i` of `for i in ..`), read as
    /// the element's index, `Sym::Index(0)`; `None` outside a family.
    pub var: Option<&'a Ident>,
    /// The variables of every family, to tell a variable named outside
    /// its family from an unknown parameter.
    pub vars: &'a [String],
    /// The parameters defined by expressions, each with its expression
    /// converted (`None`: not yet, or in a cycle, reported by
    /// [`crate::check`]): put in wherever one is named.
    pub derived: &'a [(String, Option<Id>)],
}

impl<'a> Scope<'a> {
    /// The scope of an item of `family` (`None`: a single item).
    fn of(
        def: &'a ModelDef,
        params: &'a [String],
        vars: &'a [String],
        derived: &'a [(String, Option<Id>)],
        family: Option<usize>,
    ) -> Self {
        Scope { params, var: family.map(|f| &def.families[f].var), vars, derived }
    }
}

/// Converts a user expression (numbers, parameters, the family's index
/// variable, + - * /, sqrt/sin/cos).
pub fn expr_to_sym(ar: &mut Arena, e: &Expr, scope: &Scope, what: &str, errs: &mut Errors) -> Id {
    let params = scope.params;
    match e {
        Expr::Lit(_) => match crate::parse::literal_value(e) {
            Some(v) => ar.cst(v),
            None => {
                errs.at(e, format!("{what}: expected a number"));
                ar.cst(0.0)
            }
        },
        Expr::Path(p) if p.path.get_ident().is_some() => {
            let id = p.path.get_ident().expect("checked");
            if scope.var == Some(id) {
                return ar.sym(Sym::Index(0));
            }
            if let Some((_, value)) = scope.derived.iter().find(|(n, _)| id == n) {
                return value.unwrap_or_else(|| ar.cst(0.0));
            }
            match params.iter().position(|n| id == n) {
                Some(i) => ar.sym(Sym::Param(i)),
                None if scope.vars.iter().any(|v| id == v) => {
                    let here = match scope.var {
                        Some(v) => format!("this item's family runs over `{v}`"),
                        None => "this item is not in a family".to_string(),
                    };
                    errs.at(
                        id,
                        format!(
                            "{what}: `{id}` is the index of a family (`for {id} in ..`) and names an element's index only in the items of that family; {here}"
                        ),
                    );
                    ar.cst(0.0)
                }
                None => {
                    let names: Vec<&str> =
                        params.iter().chain(scope.derived.iter().map(|(n, _)| n)).map(String::as_str).collect();
                    let known = if names.is_empty() { "none".to_string() } else { names.join(", ") };
                    errs.at(id, format!("{what}: unknown parameter `{id}`; known parameters: {known}"));
                    ar.cst(0.0)
                }
            }
        }
        Expr::Paren(p) => expr_to_sym(ar, &p.expr, scope, what, errs),
        Expr::Group(g) => expr_to_sym(ar, &g.expr, scope, what, errs),
        Expr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => {
            let a = expr_to_sym(ar, &u.expr, scope, what, errs);
            ar.neg(a)
        }
        Expr::Unary(u) if matches!(u.op, UnOp::Deref(_)) => {
            // `r**2` reads as `r * (*2)`
            errs.at(e, format!("{what}: there is no `**`; write a power as a product (`r*r`)"));
            ar.cst(0.0)
        }
        Expr::Binary(b) if matches!(b.op, BinOp::Add(_) | BinOp::Sub(_) | BinOp::Mul(_) | BinOp::Div(_)) => {
            // a chain `a + b - c + ...` (or `a * b / c * ...`) as one sum
            // (one product): linear in its length where one sum per `+`
            // would be quadratic, and no recursion along its left spine
            // (whose length the text's nesting bound does not limit)
            let sum = matches!(b.op, BinOp::Add(_) | BinOp::Sub(_));
            let mut rights = Vec::new();
            let mut left = e;
            while let Expr::Binary(b) = left {
                match b.op {
                    BinOp::Add(_) | BinOp::Sub(_) if sum => rights.push((matches!(b.op, BinOp::Sub(_)), &*b.right)),
                    BinOp::Mul(_) | BinOp::Div(_) if !sum => rights.push((matches!(b.op, BinOp::Div(_)), &*b.right)),
                    _ => break,
                }
                left = &b.left;
            }
            let mut terms = vec![expr_to_sym(ar, left, scope, what, errs)];
            for (inverse, r) in rights.into_iter().rev() {
                let t = expr_to_sym(ar, r, scope, what, errs);
                terms.push(match (inverse, sum) {
                    (false, _) => t,
                    (true, true) => ar.neg(t),
                    (true, false) => ar.pow(t, -1),
                });
            }
            if sum { ar.add(&terms) } else { ar.mul(&terms) }
        }
        Expr::Binary(b) => {
            // unsupported, and not read further (its operands may chain on)
            errs.at(b.op, format!("{what}: unsupported operator; use + - * /"));
            ar.cst(0.0)
        }
        Expr::Call(c) if c.args.len() == 1 => {
            let f = match &*c.func {
                Expr::Path(p) => p.path.get_ident().map(|i| i.to_string()),
                _ => None,
            };
            let a = expr_to_sym(ar, &c.args[0], scope, what, errs);
            match f.as_deref() {
                Some("sqrt") => ar.sqrt(a),
                Some("sin") => ar.sin(a),
                Some("cos") => ar.cos(a),
                _ => {
                    errs.at(&c.func, format!("{what}: unknown function; use sqrt, sin or cos"));
                    ar.cst(0.0)
                }
            }
        }
        other => {
            let index = scope.var.map_or(String::new(), |v| format!(", the family's index `{v}`"));
            errs.at(
                other,
                format!("{what}: unsupported expression; use numbers, parameters{index}, + - * /, sqrt, sin, cos"),
            );
            ar.cst(0.0)
        }
    }
}

/// The index `i` of a family item's own element (`Group::indices[0]`).
pub fn own_index() -> Affine {
    Affine { var: true, count: None, c: 0, span: proc_macro2::Span::call_site() }
}

/// Position of `index` in `indices`, added if new.
fn index_of(indices: &mut Vec<Affine>, index: &Affine) -> usize {
    match indices.iter().position(|a| a.same(index)) {
        Some(k) => k,
        None => {
            indices.push(index.clone());
            indices.len() - 1
        }
    }
}

/// `R(phi) (vx, vy)`: a body-frame vector turned into the world frame.
fn rotate(ar: &mut Arena, phi: Id, vx: Id, vy: Id) -> [Id; 2] {
    let c = ar.cos(phi);
    let s = ar.sin(phi);
    let xc = ar.mul2(vx, c);
    let ys = ar.mul2(vy, s);
    let xs = ar.mul2(vx, s);
    let yc = ar.mul2(vy, c);
    [ar.sub(xc, ys), ar.add2(xs, yc)]
}

/// The unit vector along `(tx, ty)` and its left normal `(-ty, tx) / |t|`.
fn unit_and_normal(ar: &mut Arena, tx: Id, ty: Id) -> ([Id; 2], [Id; 2]) {
    let tx2 = ar.pow(tx, 2);
    let ty2 = ar.pow(ty, 2);
    let n2 = ar.add2(tx2, ty2);
    let len = ar.sqrt(n2);
    let minus_ty = ar.neg(ty);
    let unit = [ar.div(tx, len), ar.div(ty, len)];
    let normal = [ar.div(minus_ty, len), unit[0]];
    (unit, normal)
}

/// Derives all constraint expressions of a checked model.
pub fn derive(def: &ModelDef, res: &Resolved, errs: &mut Errors) -> Derived {
    let mut ar = Arena::new();
    let mut cx = Ctx {
        def,
        res,
        params: def.params.iter().map(|p| p.name.to_string()).collect(),
        vars: def.families.iter().map(|f| f.var.to_string()).collect(),
        derived: def.derived.iter().map(|d| (d.name.to_string(), None)).collect(),
        points: Vec::new(),
    };
    // the parameters defined by expressions, each after those it names
    for j in crate::check::derived_order(def).0 {
        let d = &def.derived[j];
        let id = expr_to_sym(&mut ar, &d.expr, &cx.scope(None), &format!("parameter `{}`", d.name), errs);
        cx.derived[j].1 = Some(id);
    }
    let mass = def.bodies.iter().map(|b| body_mass(&mut ar, &cx, b, errs)).collect();
    let points = def.points.iter().zip(&res.point_body).map(|(p, &b)| point(&mut ar, &cx, p, b, errs)).collect();
    cx.points = points;

    let mut groups = Vec::new();
    for hi in 0..def.hinges.len() {
        groups.push(hinge(&mut ar, &cx, hi, errs));
    }
    for si in 0..def.sliders.len() {
        groups.push(slider(&mut ar, &cx, si, errs));
    }
    for di in 0..res.drive_hinge.len() {
        groups.push(drive(&mut ar, &cx, di));
    }
    for g in &mut groups {
        let n = 3 * g.slots.len();
        g.g = g.phi.iter().map(|&row| (0..n).map(|k| ar.diff(row, Sym::Q(k))).collect()).collect();
    }
    let mut blades = Vec::with_capacity(def.skates.len());
    for ki in 0..def.skates.len() {
        let (g, blade) = skate(&mut ar, &cx, ki, errs);
        blades.push(blade);
        groups.push(g);
    }
    for g in &mut groups {
        let n = 3 * g.slots.len();
        g.velocity =
            g.g.iter()
                .map(|row| {
                    let terms: Vec<Id> = row
                        .iter()
                        .enumerate()
                        .map(|(k, &gij)| {
                            let v = ar.sym(Sym::Qd(k));
                            ar.mul2(gij, v)
                        })
                        .collect();
                    ar.add(&terms)
                })
                .collect();
        g.gamma = g.velocity.clone().into_iter().map(|gv| time_derivative(&mut ar, gv, n)).collect();
    }

    Derived { ar, groups, points: cx.points, mass, blades }
}

/// What the derivations of the items share: the model, its resolution,
/// the names an expression may use, and the points derived so far.
struct Ctx<'a> {
    def: &'a ModelDef,
    res: &'a Resolved,
    params: Vec<String>,
    vars: Vec<String>,
    derived: Vec<(String, Option<Id>)>,
    points: Vec<PointDerived>,
}

impl Ctx<'_> {
    /// The scope of an item of `family`.
    fn scope(&self, family: Option<usize>) -> Scope<'_> {
        Scope::of(self.def, &self.params, &self.vars, &self.derived, family)
    }

    /// Whether a point reference and its point's body are resolved.
    fn resolved(&self, pr: &PointRef) -> bool {
        pr.0 != usize::MAX && self.res.point_body[pr.0] != usize::MAX
    }
}

/// A body's mass diagonal `(m, m, I)`; a mass or inertia that is a
/// number must be positive.
fn body_mass(ar: &mut Arena, cx: &Ctx, b: &Body, errs: &mut Errors) -> [Id; 3] {
    let before = errs.count();
    let sc = cx.scope(b.family);
    let m = expr_to_sym(ar, &b.mass, &sc, &format!("mass of body `{}`", b.name), errs);
    let after_m = errs.count();
    let i = expr_to_sym(ar, &b.inertia, &sc, &format!("inertia of body `{}`", b.name), errs);
    let (m_ok, i_ok) = (after_m == before, errs.count() == after_m);
    for (what, e, tok, ok) in [("mass", m, &b.mass, m_ok), ("inertia", i, &b.inertia, i_ok)] {
        if !ok {
            continue;
        }
        if let Some(v) = ar.as_const(e)
            && v <= 0.0
        {
            errs.at(tok, format!("{what} of body `{}` must be positive, got {v}", b.name));
        }
    }
    [m, m, i]
}

/// A point on body item `b` (`usize::MAX`: unresolved), in the local
/// coordinates of slot 0.
fn point(ar: &mut Arena, cx: &Ctx, p: &Point, b: usize, errs: &mut Errors) -> PointDerived {
    let what = format!("point `{}`", p.name);
    let sc = cx.scope(p.family);
    let px = expr_to_sym(ar, &p.at[0], &sc, &what, errs);
    let py = expr_to_sym(ar, &p.at[1], &sc, &what, errs);
    if b == usize::MAX {
        let z = ar.cst(0.0);
        return PointDerived { body: None, pos: [z, z], vel: [z, z], local: [px, py] };
    }
    let r = world(ar, 0, px, py);
    let v = [time_derivative(ar, r[0], 3), time_derivative(ar, r[1], 3)];
    PointDerived { body: Some(b), pos: r, vel: v, local: [px, py] }
}

/// Local coordinate `k` of slot `s`.
fn lq(ar: &mut Arena, s: usize, k: usize) -> Id {
    ar.sym(Sym::Q(3 * s + k))
}

/// World position of a body point `(px, py)` on slot `s`.
fn world(ar: &mut Arena, s: usize, px: Id, py: Id) -> [Id; 2] {
    let (x, y, phi) = (lq(ar, s, 0), lq(ar, s, 1), lq(ar, s, 2));
    let [rx, ry] = rotate(ar, phi, px, py);
    [ar.add2(x, rx), ar.add2(y, ry)]
}

/// `de/dt` along the first `n` local coordinates: `sum_k de/dq_k qd_k`.
fn time_derivative(ar: &mut Arena, e: Id, n: usize) -> Id {
    let terms: Vec<Id> = (0..n)
        .map(|k| {
            let d = ar.diff(e, Sym::Q(k));
            let v = ar.sym(Sym::Qd(k));
            ar.mul2(d, v)
        })
        .collect();
    ar.add(&terms)
}

/// Slot of a body element in `slots`, added if new.
fn slot_of(slots: &mut Vec<BodyRef>, b: BodyRef) -> usize {
    match slots.iter().position(|s| same_body(s, &b)) {
        Some(k) => k,
        None => {
            slots.push(b);
            slots.len() - 1
        }
    }
}

/// A point reference's world position in the group's local coordinates,
/// and its body's slot: a family point's offsets name its own index,
/// `Sym::Index(0)`, which is the group's index `pr.1` (`P[i - 1]`: one
/// less than the group's).
fn at(ar: &mut Arena, cx: &Ctx, g: &mut Group, pr: &PointRef) -> ([Id; 2], usize) {
    let s = slot_of(&mut g.slots, cx.res.body_of(cx.def, pr));
    let [mut px, mut py] = cx.points[pr.0].local;
    if let Some(index) = &pr.1 {
        let k = index_of(&mut g.indices, index);
        if k != 0 {
            let rename = |s: Sym| if s == Sym::Index(0) { Sym::Index(k) } else { s };
            let mut memo = HashMap::new();
            px = ar.subst(px, &rename, &mut memo);
            py = ar.subst(py, &rename, &mut memo);
        }
    }
    (world(ar, s, px, py), s)
}

/// An item's group before its rows are derived.
fn new_group(kind: Kind, item: usize, family: Option<usize>) -> Group {
    Group {
        kind,
        item,
        family,
        slots: Vec::new(),
        indices: vec![own_index()],
        phi: Vec::new(),
        g: Vec::new(),
        gamma: Vec::new(),
        velocity: Vec::new(),
        suffixes: Vec::new(),
        direction: None,
    }
}

/// Hinge `hi`: `r_P - r_Q` (or `r_P - ground`), rows `.x`, `.y`.
fn hinge(ar: &mut Arena, cx: &Ctx, hi: usize, errs: &mut Errors) -> Group {
    let (h, (a, b)) = (&cx.def.hinges[hi], &cx.res.hinge_points[hi]);
    let mut g = new_group(Kind::Hinge, hi, h.family);
    if !cx.resolved(a) || b.as_ref().is_some_and(|b| !cx.resolved(b)) {
        return g;
    }
    let (ra, _) = at(ar, cx, &mut g, a);
    let other = match (&h.target, b) {
        (HingeTarget::Point(_), Some(b)) => at(ar, cx, &mut g, b).0,
        (HingeTarget::Ground { at, .. }, _) => {
            let what = format!("ground point of hinge `{}`", h.name);
            let sc = cx.scope(h.family);
            [expr_to_sym(ar, &at[0], &sc, &what, errs), expr_to_sym(ar, &at[1], &sc, &what, errs)]
        }
        _ => unreachable!("hinge target and resolution agree"),
    };
    for (k, axis) in [".x", ".y"].into_iter().enumerate() {
        g.phi.push(ar.sub(ra[k], other[k]));
        g.suffixes.push(axis);
    }
    g
}

/// Slider or slot `si`: the row `.n` (the point on the line), and for a
/// slider `.phi` (the heading).
fn slider(ar: &mut Arena, cx: &Ctx, si: usize, errs: &mut Errors) -> Group {
    let (sl, (p, guide)) = (&cx.def.sliders[si], &cx.res.slider_points[si]);
    let mut g = new_group(Kind::Slider, si, sl.family);
    let kind = if sl.heading { "slider" } else { "slot" };
    let what = format!("{kind} `{}`", sl.name);
    let sc = cx.scope(sl.family);
    let tx = expr_to_sym(ar, &sl.along[0], &sc, &format!("direction of {what}"), errs);
    let ty = expr_to_sym(ar, &sl.along[1], &sc, &format!("direction of {what}"), errs);
    let angle = match &sl.angle {
        Some(e) => expr_to_sym(ar, e, &sc, &format!("angle of {what}"), errs),
        None => ar.cst(0.0),
    };
    if ar.is_zero(tx) && ar.is_zero(ty) {
        errs.push(syn::Error::new(
            sl.along_span,
            format!("{kind} `{}` has a zero direction; give a nonzero (dx, dy)", sl.name),
        ));
        return g;
    }
    if !cx.resolved(p) || guide.as_ref().is_some_and(|g| !cx.resolved(g)) {
        return g;
    }
    // unit normal of the line, in the guide's frame, and the guide's
    // point and heading (the ground: world frame, heading 0)
    g.direction = Some([tx, ty]);
    let (_, [nx, ny]) = unit_and_normal(ar, tx, ty);
    let (rp, sp) = at(ar, cx, &mut g, p);
    let (origin, normal, heading) = match (&sl.target, guide) {
        (HingeTarget::Point(_), Some(gp)) => {
            let (origin, sa) = at(ar, cx, &mut g, gp);
            let phi_a = lq(ar, sa, 2);
            (origin, rotate(ar, phi_a, nx, ny), phi_a)
        }
        (HingeTarget::Ground { at }, _) => {
            let at = [
                expr_to_sym(ar, &at[0], &sc, &format!("ground point of {what}"), errs),
                expr_to_sym(ar, &at[1], &sc, &format!("ground point of {what}"), errs),
            ];
            (at, [nx, ny], ar.cst(0.0))
        }
        _ => unreachable!("slider target and resolution agree"),
    };
    let dx = ar.sub(rp[0], origin[0]);
    let dy = ar.sub(rp[1], origin[1]);
    let ex = ar.mul2(normal[0], dx);
    let ey = ar.mul2(normal[1], dy);
    g.phi.push(ar.add2(ex, ey));
    g.suffixes.push(".n");
    if sl.heading {
        let phi_b = lq(ar, sp, 2);
        let rel = ar.sub(phi_b, heading);
        g.phi.push(ar.sub(rel, angle));
        g.suffixes.push(".phi");
    }
    g
}

/// Drive `di` of its hinge: the row `phi_a - phi_b` (`phi_a` for a
/// ground hinge).
fn drive(ar: &mut Arena, cx: &Ctx, di: usize) -> Group {
    let (def, res) = (cx.def, cx.res);
    let h = res.drive_hinge[di];
    // a family drive's element i drives the hinge element i (same range,
    // checked), so the hinge's point references serve as they are
    let mut g = new_group(Kind::Drive, di, def.drives[di].family);
    let Some((a, b)) = res.hinge_points.get(h) else {
        return g;
    };
    if !cx.resolved(a) || b.as_ref().is_some_and(|b| !cx.resolved(b)) {
        return g;
    }
    let sa = slot_of(&mut g.slots, res.body_of(def, a));
    let phi_a = lq(ar, sa, 2);
    let angle = match b {
        Some(b) => {
            let sb = slot_of(&mut g.slots, res.body_of(def, b));
            let phi_b = lq(ar, sb, 2);
            ar.sub(phi_a, phi_b)
        }
        None => phi_a,
    };
    g.phi.push(angle);
    g.suffixes.push("");
    g
}

/// Skate `ki`: the row of `S`, `n^T dr_P/dq`, and its unit blade
/// direction in the body frame.
fn skate(ar: &mut Arena, cx: &Ctx, ki: usize, errs: &mut Errors) -> (Group, [Id; 2]) {
    let (s, p) = (&cx.def.skates[ki], &cx.res.skate_point[ki]);
    let mut g = new_group(Kind::Skate, ki, s.family);
    let what = format!("blade direction of skate `{}`", s.name);
    let sc = cx.scope(s.family);
    let tx = expr_to_sym(ar, &s.along[0], &sc, &what, errs);
    let ty = expr_to_sym(ar, &s.along[1], &sc, &what, errs);
    let zero = ar.cst(0.0);
    if ar.is_zero(tx) && ar.is_zero(ty) {
        errs.push(syn::Error::new(
            s.along_span,
            format!("skate `{}` has a zero blade direction; give a nonzero (dx, dy)", s.name),
        ));
        return (g, [zero, zero]);
    }
    // normalized blade direction and its body-frame normal (-ty, tx)
    g.direction = Some([tx, ty]);
    let ([ux, uy], [nbx, nby]) = unit_and_normal(ar, tx, ty);
    if !cx.resolved(p) {
        return (g, [ux, uy]);
    }
    let (r, sl) = at(ar, cx, &mut g, p);
    let phi = lq(ar, sl, 2);
    let [nwx, nwy] = rotate(ar, phi, nbx, nby);
    let n = 3 * g.slots.len();
    let row: Vec<Id> = (0..n)
        .map(|k| {
            let dx = ar.diff(r[0], Sym::Q(k));
            let dy = ar.diff(r[1], Sym::Q(k));
            let ex = ar.mul2(nwx, dx);
            let ey = ar.mul2(nwy, dy);
            ar.add2(ex, ey)
        })
        .collect();
    g.g.push(row);
    g.suffixes.push("");
    (g, [ux, uy])
}
