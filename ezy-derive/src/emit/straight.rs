//! The straight-line form of a model without families (all columns known
//! at compile time): its numeric functions (`phi`, the Jacobians,
//! `gamma`, the points and their velocities) as straight-line code over
//! every expression renamed to global coordinates, with the products with
//! `G` at its compile-time pattern ([`super::products`]) and the minimal
//! coordinates ([`super::minimal`]).

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::lower::{Coords, lower};
use super::minimal::minimal_items;
use super::numeric_fns;
use super::products::sparse_kernels;
use ezy_lang::ast::ModelDef;
use ezy_lang::check::Resolved;
use ezy_lang::kinematics::Derived;
use ezy_lang::sym::Id;

/// The numeric functions of a model without families in straight-line
/// form, its products with `G`, its minimal coordinates (or a
/// `minimal_layout` saying why there are none) and `unrolled_kernels`.
pub(super) fn numerics(d: &mut Derived, def: &ModelDef, res: &Resolved) -> TokenStream {
    let st = ezy_lang::straight::straight_form(d, def, res);
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
