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
//!   named `S.n` and `S.phi`, after the hinges' rows.
//! - Drive of a hinge: the row `phi_a - phi_b` (`phi_a` for a ground
//!   hinge), after the sliders' rows; the runtime subtracts the prescribed
//!   angle `u(t)` (and `u'`, `u''` at velocity and acceleration level).
//! - Skate with blade direction `t` (body coordinates, normalized): the
//!   world normal is `n = R(phi) (-t_y, t_x)` and the row of `S(q)` is
//!   `n^T dr_P/dq`, so `S qd` is the contact point's lateral velocity [m/s].
//! - Convective term of every velocity-constraint row `g(q) qd`:
//!   `gamma = d/dq(g(q) qd) qd`.
//!
//! Every formula of SPEC §1 follows from these definitions; none is typed in.

use syn::{BinOp, Expr, UnOp};

use crate::ast::{HingeTarget, ModelDef};
use crate::check::{Errors, Resolved};
use crate::sym::{Arena, Id, Sym};

/// Everything the emitter needs.
pub struct Derived {
    pub ar: Arena,
    pub nq: usize,
    /// Holonomic residual rows (nh).
    pub phi: Vec<Id>,
    /// Constraint matrix G (nc x nq), holonomic rows first.
    pub g: Vec<Vec<Id>>,
    /// Convective terms (nc).
    pub gamma: Vec<Id>,
    /// Velocity forms `G_i(q) qd` (nc), for readable equations.
    pub velocity: Vec<Id>,
    /// Row names of G.
    pub constraint_names: Vec<String>,
    /// Point positions and velocities, `[x, y]` per point.
    pub points: Vec<[Id; 2]>,
    pub point_vel: Vec<[Id; 2]>,
    /// Mass-matrix diagonal (nq), in terms of parameters.
    pub mass: Vec<Id>,
    /// Body-frame geometry in terms of parameters: `(px, py)` per point,
    /// then the unit blade direction `(tx, ty)` per skate.
    pub local: Vec<Id>,
}

impl Derived {
    /// Structural nonzeros `(row, col)` of G, row-major.
    pub fn pattern(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (r, row) in self.g.iter().enumerate() {
            for (c, &e) in row.iter().enumerate() {
                if !self.ar.is_zero(e) {
                    out.push((r, c));
                }
            }
        }
        out
    }
}

/// Converts a user expression (numbers, parameters, + - * /, sqrt/sin/cos).
pub fn expr_to_sym(ar: &mut Arena, e: &Expr, params: &[String], what: &str, errs: &mut Errors) -> Id {
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
            match params.iter().position(|n| id == n) {
                Some(i) => ar.sym(Sym::Param(i)),
                None => {
                    let known = if params.is_empty() { "none".to_string() } else { params.join(", ") };
                    errs.at(id, format!("{what}: unknown parameter `{id}`; known parameters: {known}"));
                    ar.cst(0.0)
                }
            }
        }
        Expr::Paren(p) => expr_to_sym(ar, &p.expr, params, what, errs),
        Expr::Group(g) => expr_to_sym(ar, &g.expr, params, what, errs),
        Expr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => {
            let a = expr_to_sym(ar, &u.expr, params, what, errs);
            ar.neg(a)
        }
        Expr::Binary(b) => {
            let l = expr_to_sym(ar, &b.left, params, what, errs);
            let r = expr_to_sym(ar, &b.right, params, what, errs);
            match b.op {
                BinOp::Add(_) => ar.add2(l, r),
                BinOp::Sub(_) => ar.sub(l, r),
                BinOp::Mul(_) => ar.mul2(l, r),
                BinOp::Div(_) => ar.div(l, r),
                _ => {
                    errs.at(b.op, format!("{what}: unsupported operator; use + - * /"));
                    ar.cst(0.0)
                }
            }
        }
        Expr::Call(c) if c.args.len() == 1 => {
            let f = match &*c.func {
                Expr::Path(p) => p.path.get_ident().map(|i| i.to_string()),
                _ => None,
            };
            let a = expr_to_sym(ar, &c.args[0], params, what, errs);
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
            errs.at(other, format!("{what}: unsupported expression; use numbers, parameters, + - * /, sqrt, sin, cos"));
            ar.cst(0.0)
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
    let params: Vec<String> = def.params.iter().map(|p| p.name.to_string()).collect();
    let nq = 3 * def.bodies.len();

    let mut mass = Vec::with_capacity(nq);
    for b in &def.bodies {
        let before = errs.count();
        let m = expr_to_sym(&mut ar, &b.mass, &params, &format!("mass of body `{}`", b.name), errs);
        let after_m = errs.count();
        let i = expr_to_sym(&mut ar, &b.inertia, &params, &format!("inertia of body `{}`", b.name), errs);
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
        mass.extend([m, m, i]);
    }

    let q: Vec<Id> = (0..nq).map(|k| ar.sym(Sym::Q(k))).collect();
    let qd: Vec<Id> = (0..nq).map(|k| ar.sym(Sym::Qd(k))).collect();

    // World position of a body point (px, py) on body `b`.
    let world = |ar: &mut Arena, b: usize, px: Id, py: Id| -> [Id; 2] {
        let (x, y) = (q[3 * b], q[3 * b + 1]);
        let [rx, ry] = rotate(ar, q[3 * b + 2], px, py);
        [ar.add2(x, rx), ar.add2(y, ry)]
    };
    let time_derivative = |ar: &mut Arena, e: Id| -> Id {
        let terms: Vec<Id> = (0..nq)
            .map(|k| {
                let d = ar.diff(e, Sym::Q(k));
                ar.mul2(d, qd[k])
            })
            .collect();
        ar.add(&terms)
    };

    let mut points = Vec::with_capacity(def.points.len());
    let mut point_vel = Vec::with_capacity(def.points.len());
    let mut local = Vec::with_capacity(2 * (def.points.len() + def.skates.len()));
    for (p, &b) in def.points.iter().zip(&res.point_body) {
        let what = format!("point `{}`", p.name);
        let px = expr_to_sym(&mut ar, &p.at[0], &params, &what, errs);
        let py = expr_to_sym(&mut ar, &p.at[1], &params, &what, errs);
        local.extend([px, py]);
        if b == usize::MAX {
            let z = ar.cst(0.0);
            points.push([z, z]);
            point_vel.push([z, z]);
            continue;
        }
        let r = world(&mut ar, b, px, py);
        let v = [time_derivative(&mut ar, r[0]), time_derivative(&mut ar, r[1])];
        points.push(r);
        point_vel.push(v);
    }

    let mut phi = Vec::new();
    let mut constraint_names = Vec::new();
    for (h, &(a, b)) in def.hinges.iter().zip(&res.hinge_points) {
        if a == usize::MAX || b == Some(usize::MAX) {
            continue;
        }
        let other = match (&h.target, b) {
            (HingeTarget::Point(_), Some(b)) => points[b],
            (HingeTarget::Ground { at, .. }, _) => {
                let what = format!("ground point of hinge `{}`", h.name);
                [expr_to_sym(&mut ar, &at[0], &params, &what, errs), expr_to_sym(&mut ar, &at[1], &params, &what, errs)]
            }
            _ => unreachable!("hinge target and resolution agree"),
        };
        for (k, axis) in ["x", "y"].iter().enumerate() {
            phi.push(ar.sub(points[a][k], other[k]));
            constraint_names.push(format!("{}.{axis}", h.name));
        }
    }

    for (sl, &(p, guide)) in def.sliders.iter().zip(&res.slider_points) {
        let what = format!("slider `{}`", sl.name);
        let tx = expr_to_sym(&mut ar, &sl.along[0], &params, &format!("direction of {what}"), errs);
        let ty = expr_to_sym(&mut ar, &sl.along[1], &params, &format!("direction of {what}"), errs);
        let angle = match &sl.angle {
            Some(e) => expr_to_sym(&mut ar, e, &params, &format!("angle of {what}"), errs),
            None => ar.cst(0.0),
        };
        if ar.is_zero(tx) && ar.is_zero(ty) {
            errs.push(syn::Error::new(
                sl.along_span,
                format!("slider `{}` has a zero direction; give a nonzero (dx, dy)", sl.name),
            ));
            continue;
        }
        if p == usize::MAX || guide == Some(usize::MAX) || res.point_body[p] == usize::MAX {
            continue;
        }
        let b = res.point_body[p];
        // unit normal of the line, in the guide's frame, and the guide's
        // point and heading (the ground: world frame, heading 0)
        let (_, [nx, ny]) = unit_and_normal(&mut ar, tx, ty);
        let (origin, normal, heading) = match (&sl.target, guide) {
            (HingeTarget::Point(_), Some(gp)) => {
                let a = res.point_body[gp];
                if a == usize::MAX {
                    continue;
                }
                (points[gp], rotate(&mut ar, q[3 * a + 2], nx, ny), q[3 * a + 2])
            }
            (HingeTarget::Ground { at }, _) => {
                let at = [
                    expr_to_sym(&mut ar, &at[0], &params, &format!("ground point of {what}"), errs),
                    expr_to_sym(&mut ar, &at[1], &params, &format!("ground point of {what}"), errs),
                ];
                (at, [nx, ny], ar.cst(0.0))
            }
            _ => unreachable!("slider target and resolution agree"),
        };
        let dx = ar.sub(points[p][0], origin[0]);
        let dy = ar.sub(points[p][1], origin[1]);
        let ex = ar.mul2(normal[0], dx);
        let ey = ar.mul2(normal[1], dy);
        phi.push(ar.add2(ex, ey));
        constraint_names.push(format!("{}.n", sl.name));
        let rel = ar.sub(q[3 * b + 2], heading);
        phi.push(ar.sub(rel, angle));
        constraint_names.push(format!("{}.phi", sl.name));
    }

    for (dr, &h) in def.drives.iter().zip(&res.drive_hinge) {
        let Some(&(pa, pb)) = res.hinge_points.get(h) else { continue };
        if pa == usize::MAX || res.point_body[pa] == usize::MAX || pb == Some(usize::MAX) {
            continue;
        }
        let a = res.point_body[pa];
        let angle = match pb {
            Some(pb) => ar.sub(q[3 * a + 2], q[3 * res.point_body[pb] + 2]),
            None => q[3 * a + 2],
        };
        phi.push(angle);
        constraint_names.push(dr.name.to_string());
    }

    let mut g: Vec<Vec<Id>> =
        phi.iter().map(|&row| (0..nq).map(|k| ar.diff(row, Sym::Q(k))).collect::<Vec<_>>()).collect();

    for (s, &p) in def.skates.iter().zip(&res.skate_point) {
        let what = format!("blade direction of skate `{}`", s.name);
        let tx = expr_to_sym(&mut ar, &s.along[0], &params, &what, errs);
        let ty = expr_to_sym(&mut ar, &s.along[1], &params, &what, errs);
        let zero = ar.cst(0.0);
        local.extend([zero, zero]);
        if ar.is_zero(tx) && ar.is_zero(ty) {
            errs.push(syn::Error::new(
                s.along_span,
                format!("skate `{}` has a zero blade direction; give a nonzero (dx, dy)", s.name),
            ));
            continue;
        }
        if p == usize::MAX || res.point_body[p] == usize::MAX {
            continue;
        }
        let b = res.point_body[p];
        // normalized blade direction and its body-frame normal (-ty, tx)
        let ([ux, uy], [nbx, nby]) = unit_and_normal(&mut ar, tx, ty);
        let k = local.len();
        local[k - 2] = ux;
        local[k - 1] = uy;
        let [nwx, nwy] = rotate(&mut ar, q[3 * b + 2], nbx, nby);
        let row: Vec<Id> = (0..nq)
            .map(|k| {
                let dx = ar.diff(points[p][0], Sym::Q(k));
                let dy = ar.diff(points[p][1], Sym::Q(k));
                let ex = ar.mul2(nwx, dx);
                let ey = ar.mul2(nwy, dy);
                ar.add2(ex, ey)
            })
            .collect();
        g.push(row);
        constraint_names.push(s.name.to_string());
    }

    let velocity: Vec<Id> = g
        .iter()
        .map(|row| {
            let terms: Vec<Id> = row.iter().zip(&qd).map(|(&gij, &v)| ar.mul2(gij, v)).collect();
            ar.add(&terms)
        })
        .collect();
    let gamma = velocity.iter().map(|&gv| time_derivative(&mut ar, gv)).collect();

    Derived { ar, nq, phi, g, gamma, velocity, constraint_names, points, point_vel, mass, local }
}
