//! The straight-line form of a model without families (all columns known
//! at compile time): its numeric functions (`phi`, the Jacobians,
//! `gamma`, the points and their velocities) as straight-line code over
//! every expression renamed to global coordinates, with the products with
//! `G` at its compile-time pattern ([`super::products`]) and the minimal
//! coordinates ([`super::minimal`]).

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use std::collections::HashMap;

use super::layout::point_body;
use super::lower::{Coords, lower};
use super::minimal::minimal_items;
use super::numeric_fns;
use super::products::sparse_kernels;
use ezy_lang::ast::ModelDef;
use ezy_lang::check::{BodyRef, Resolved};
use ezy_lang::kinematics::Derived;
use ezy_lang::sym::{Arena, Id, Sym};

/// The numeric functions of a model without families in straight-line
/// form, its products with `G`, its minimal coordinates (or a
/// `minimal_layout` saying why there are none) and `unrolled_kernels`.
pub(super) fn numerics(d: &mut Derived, def: &ModelDef, res: &Resolved) -> TokenStream {
    let st = static_form(d, def, res);
    let nh = st.phi.len();
    let nnz_h = st.pattern.iter().filter(|(r, _)| *r < nh).count();
    let nq = st.nq;
    let phi_body = assign(d, def, &[("phi", &st.phi)]);
    let jac_body = assign(d, def, &[("values", &st.values[..nnz_h])]);
    let g_body = assign(d, def, &[("values", &st.values)]);
    let terms_body = assign(d, def, &[("values", &st.values), ("gamma", &st.gamma)]);
    let phi_g_body = assign(d, def, &[("phi", &st.phi), ("values", &st.values)]);
    let points_body = assign(d, def, &[("out", &st.points)]);
    let vel_body = assign(d, def, &[("out", &st.vel)]);
    let kernels = sparse_kernels(&st.pattern, nq, st.nc);
    let q_only = quote!(let q = &q[..#nq];);
    let q_qd = quote!(let q = &q[..#nq]; let qd = &qd[..#nq];);
    let fns = numeric_fns(&q_only, &q_qd, [phi_body, jac_body, g_body, phi_g_body, terms_body, points_body, vel_body]);
    let minimal = minimal_items(d, def, res, &st.phi, &st.pattern, &st.values, st.nc);
    quote! {
        #kernels
        #minimal

        fn unrolled_kernels(&self) -> bool {
            true
        }

        #fns
    }
}

/// Straight-line form: every output renamed to global coordinates (a
/// model without families: all columns are known at compile time).
struct Static {
    /// `G` entries in pattern order, `phi` rows, `gamma` rows, point
    /// positions and velocities (x, y per point), all global.
    values: Vec<Id>,
    phi: Vec<Id>,
    gamma: Vec<Id>,
    points: Vec<Id>,
    vel: Vec<Id>,
    pattern: Vec<(usize, usize)>,
    nq: usize,
    nc: usize,
}

/// Every output of `d` renamed to global coordinates (new nodes in the
/// arena), with `G`'s global pattern.
fn static_form(d: &mut Derived, def: &ModelDef, res: &Resolved) -> Static {
    let body_col = |b: &BodyRef| 3 * b.0;
    let mut st = Static {
        values: Vec::new(),
        phi: Vec::new(),
        gamma: Vec::new(),
        points: Vec::new(),
        vel: Vec::new(),
        pattern: Vec::new(),
        nq: 3 * def.bodies.len(),
        nc: 0,
    };
    let groups = std::mem::take(&mut d.groups);
    let mut row = 0;
    for g in &groups {
        let cols: Vec<usize> = g.slots.iter().map(body_col).collect();
        let rename = |s: Sym| match s {
            Sym::Q(k) => Sym::Q(cols[k / 3] + k % 3),
            Sym::Qd(k) => Sym::Qd(cols[k / 3] + k % 3),
            p => p,
        };
        let mut memo = HashMap::new();
        let mut sub = |ar: &mut Arena, id: Id| ar.subst(id, &rename, &mut memo);
        if g.holonomic() {
            for &p in &g.phi {
                let x = sub(&mut d.ar, p);
                st.phi.push(x);
            }
        }
        for (r, c) in g.local_pattern(&d.ar) {
            st.pattern.push((row + r, cols[c / 3] + c % 3));
            let x = sub(&mut d.ar, g.g[r][c]);
            st.values.push(x);
        }
        for &x in &g.gamma {
            let x = sub(&mut d.ar, x);
            st.gamma.push(x);
        }
        row += g.rows();
    }
    d.groups = groups;
    st.nc = row;
    for (pi, p) in d.points.iter().enumerate() {
        let b = point_body(def, res, pi);
        let col = body_col(&b);
        let rename = |s: Sym| match s {
            Sym::Q(k) => Sym::Q(col + k),
            Sym::Qd(k) => Sym::Qd(col + k),
            p => p,
        };
        let mut memo = HashMap::new();
        for k in 0..2 {
            let (a, b) = (p.pos[k], p.vel[k]);
            let a = d.ar.subst(a, &rename, &mut memo);
            let b = d.ar.subst(b, &rename, &mut memo);
            st.points.push(a);
            st.vel.push(b);
        }
    }
    st
}

/// Assignments `out[k] = expr_k` with their bindings (global coordinates).
fn assign(d: &Derived, def: &ModelDef, groups: &[(&str, &[Id])]) -> TokenStream {
    let all: Vec<Id> = groups.iter().flat_map(|(_, ids)| ids.iter().copied()).collect();
    let (lets, exprs) = lower(d, def, &all, Coords::Global, &[]);
    let mut body = lets;
    let mut start = 0;
    for (name, ids) in groups {
        let out = format_ident!("{}", name);
        let n = ids.len();
        body.extend(quote!(let #out = &mut #out[..#n];));
        for (k, e) in exprs[start..start + n].iter().enumerate() {
            body.extend(quote!(#out[#k] = #e;));
        }
        start += n;
    }
    body
}
