//! The loop form: per constraint item one element kernel inside a loop
//! over its family's elements, the element's coordinates gathered from
//! `q` at the runtime layout, for the numeric functions of a model with
//! families (`phi`, the Jacobians, `gamma`, the points and their
//! velocities); and the mass diagonal and local geometry of every model,
//! which are loops for a model without families too (constant per
//! element).

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::layout::{body_column, each_element, layout_prelude, point_body};
use super::lower::{Coords, lower};
use super::minimal::minimal_fns;
use super::numeric_fns;
use ezy_lang::ast::ModelDef;
use ezy_lang::check::{BodyRef, Resolved};
use ezy_lang::kinematics::{Derived, Kind, own_index};
use ezy_lang::sym::Id;

/// `fn mass_diagonal` and `fn local_geometry` (the points' body
/// coordinates, the blades' directions): a loop over each item's
/// elements.
pub(super) fn geometry_fns(d: &Derived, def: &ModelDef) -> TokenStream {
    let prelude = layout_prelude(def);
    // mass and local geometry: loops over items (constant per element)
    let mut mass_body = TokenStream::new();
    for (bi, b) in def.bodies.iter().enumerate() {
        let (lets, ex) = lower(d, def, &d.mass[bi], Coords::Local, &[own_index()]);
        let (m0, m1, m2) = (&ex[0], &ex[1], &ex[2]);
        mass_body.extend(each_element(
            b.family,
            quote! {
                let k = l.body_off[#bi] + 3 * e;
                #lets
                out[k] = #m0; out[k + 1] = #m1; out[k + 2] = #m2;
            },
        ));
    }
    let mut local_body = TokenStream::new();
    for (pi, p) in def.points.iter().enumerate() {
        let (lets, ex) = lower(d, def, &d.points[pi].local, Coords::Local, &[own_index()]);
        let (a, b) = (&ex[0], &ex[1]);
        local_body.extend(each_element(
            p.family,
            quote! {
                let k = 2 * (l.point_index[#pi] + e);
                #lets
                points[k] = #a; points[k + 1] = #b;
            },
        ));
    }
    for (ki, s) in def.skates.iter().enumerate() {
        let (lets, ex) = lower(d, def, &d.blades[ki], Coords::Local, &[own_index()]);
        let (a, b) = (&ex[0], &ex[1]);
        let gi = d.groups.iter().position(|g| g.kind == Kind::Skate && g.item == ki).expect("one group per skate");
        local_body.extend(each_element(
            s.family,
            quote! {
                let k = 2 * (l.item_index[#gi] + e);
                #lets
                blades[k] = #a; blades[k + 1] = #b;
            },
        ));
    }
    quote! {
        fn mass_diagonal(&self, out: &mut [f64]) {
            type S = f64;
            #prelude
            #mass_body
        }

        fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
            type S = f64;
            #prelude
            #local_body
        }
    }
}

/// The numeric functions of a model with families in loop form, and a
/// `minimal_layout` that says there are no minimal coordinates.
pub(super) fn numerics(d: &Derived, def: &ModelDef, res: &Resolved) -> TokenStream {
    let o = |phi, values, gamma, holonomic_only| Outputs { phi, values, gamma, holonomic_only };
    let phi_body = group_loops(d, def, o(true, false, false, true));
    let jac_body = group_loops(d, def, o(false, true, false, true));
    let g_body = group_loops(d, def, o(false, true, false, false));
    let phi_g_body = group_loops(d, def, o(true, true, false, false));
    let terms_body = group_loops(d, def, o(false, true, true, false));
    let points_body = point_loops(d, def, res, false);
    let vel_body = point_loops(d, def, res, true);
    let layout = layout_prelude(def);
    let fns =
        numeric_fns(&layout, &layout, [phi_body, jac_body, g_body, phi_g_body, terms_body, points_body, vel_body]);
    let minimal = minimal_fns(d, def, Err("it has families (`for`), whose minimal form is not derived yet".into()));
    quote!(#fns #minimal)
}

/// `let ql = [q[c0], q[c0 + 1], ...]` (and `qdl`) for a group's slots.
fn gather(def: &ModelDef, slots: &[BodyRef], with_qd: bool) -> TokenStream {
    let cols: Vec<TokenStream> = slots.iter().map(|b| body_column(def, b)).collect();
    let n = 3 * slots.len();
    let names: Vec<_> = (0..slots.len()).map(|s| format_ident!("col{}", s)).collect();
    let idx: Vec<TokenStream> = (0..n)
        .map(|k| {
            let c = &names[k / 3];
            let o = k % 3;
            quote!(#c + #o)
        })
        .collect();
    let qd = if with_qd { quote!(let qdl: [S; #n] = [#(qd[#idx]),*];) } else { quote!() };
    quote! {
        #(let #names: usize = #cols;)*
        let ql: [S; #n] = [#(q[#idx]),*];
        #qd
    }
}

/// Which outputs a loop-form numeric function writes per group.
#[derive(Clone, Copy)]
struct Outputs {
    phi: bool,
    values: bool,
    gamma: bool,
    holonomic_only: bool,
}

/// Loop form of a constraint function over all groups.
fn group_loops(d: &Derived, def: &ModelDef, o: Outputs) -> TokenStream {
    let mut out = TokenStream::new();
    for (gi, g) in d.groups.iter().enumerate() {
        if (o.holonomic_only && !g.holonomic()) || g.slots.is_empty() {
            continue;
        }
        let pat = g.local_pattern(&d.ar);
        let (nr, nnz) = (g.rows(), pat.len());
        let mut ids: Vec<Id> = Vec::new();
        if o.phi && g.holonomic() {
            ids.extend(&g.phi);
        }
        if o.values {
            ids.extend(pat.iter().map(|&(r, c)| g.g[r][c]));
        }
        if o.gamma {
            ids.extend(&g.gamma);
        }
        let (lets, exprs) = lower(d, def, &ids, Coords::Local, &g.indices);
        let mut writes = TokenStream::new();
        let mut k = 0;
        if o.phi && g.holonomic() {
            for r in 0..nr {
                let ex = &exprs[k];
                writes.extend(quote!(phi[rb + #r] = #ex;));
                k += 1;
            }
        }
        if o.values {
            for j in 0..nnz {
                let ex = &exprs[k];
                writes.extend(quote!(values[vb + #j] = #ex;));
                k += 1;
            }
        }
        if o.gamma {
            for r in 0..nr {
                let ex = &exprs[k];
                writes.extend(quote!(gamma[rb + #r] = #ex;));
                k += 1;
            }
        }
        let gat = gather(def, &g.slots, o.gamma);
        out.extend(each_element(
            g.family,
            quote! {
                #gat
                let rb = l.row[#gi] + e * #nr;
                let vb = l.val[#gi] + e * #nnz;
                #lets
                #writes
            },
        ));
    }
    out
}

/// Loop form of `points` / `point_velocities`.
fn point_loops(d: &Derived, def: &ModelDef, res: &Resolved, vel: bool) -> TokenStream {
    let mut out = TokenStream::new();
    for (pi, p) in d.points.iter().enumerate() {
        if p.body.is_none() {
            continue;
        }
        let ids: Vec<Id> = if vel { p.vel.to_vec() } else { p.pos.to_vec() };
        let (lets, ex) = lower(d, def, &ids, Coords::Local, &[own_index()]);
        let (e0, e1) = (&ex[0], &ex[1]);
        let gat = gather(def, &[point_body(def, res, pi)], vel);
        out.extend(each_element(
            def.points[pi].family,
            quote! {
                #gat
                let k = 2 * (l.point_index[#pi] + e);
                #lets
                out[k] = #e0;
                out[k + 1] = #e1;
            },
        ));
    }
    out
}
