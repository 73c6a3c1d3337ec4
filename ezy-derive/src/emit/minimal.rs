//! The minimal coordinates of a model without families
//! (`ezy_core::MinimalLayout`), from the form [`ezy_lang::minimal`] derives:
//! `minimal_layout`, `minimal_expand`, `minimal_state`, `minimal_maggi`,
//! and the fused right-hand side on the minimal coordinates
//! (`minimal_constants`, `minimal_rhs`, `minimal_rhs_lean`) that the
//! runtime's minimal formulation calls; or, for a model that has none, a
//! `minimal_layout` that says why.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::lower::{Coords, Hoisted, lower};
use super::{join, lit_f64, runtime};
use ezy_lang::ast::ModelDef;
use ezy_lang::check::Resolved;
use ezy_lang::kinematics::{Derived, Kind};
use ezy_lang::minimal::{Maggi, Minimal};
use ezy_lang::sym::{Id, Sym};

/// The minimal form derived from the model's global holonomic rows `phi`
/// and `G`'s `values` at `pattern` (`nc` rows), as [`minimal_fns`] and,
/// where there is one, [`fused_fns`] emit it.
pub(super) fn minimal_items(
    d: &mut Derived,
    def: &ModelDef,
    res: &Resolved,
    phi: &[Id],
    pattern: &[(usize, usize)],
    values: &[Id],
    nc: usize,
) -> TokenStream {
    let minimal = ezy_lang::minimal::derive(&mut d.ar, def, res, phi, pattern, values, nc);
    let fused = match &minimal {
        Ok(m) => {
            let mass: Vec<Id> = d.mass.iter().flatten().copied().collect();
            // the hinges in `ModelInfo::hinges`' order (a model with
            // minimal coordinates has no families: a body's slot is its index)
            let hinges: Vec<(usize, Option<usize>)> = d
                .groups
                .iter()
                .filter(|g| g.kind == Kind::Hinge)
                .map(|g| (g.slots[0].0, g.slots.get(1).map(|b| b.0)))
                .collect();
            let maggi = ezy_lang::minimal::maggi(&mut d.ar, m, &mass, &hinges);
            fused_fns(d, def, m, &maggi)
        }
        Err(_) => TokenStream::new(),
    };
    let minimal = minimal_fns(d, def, minimal);
    quote!(#minimal #fused)
}

/// `minimal_maggi` ([`maggi_fn`]), `minimal_layout`, `minimal_expand` and
/// `minimal_state` (`ezy_core::MinimalLayout`) from the derived minimal
/// form, or a `minimal_layout` that says why there is none.
pub(super) fn minimal_fns(d: &Derived, def: &ModelDef, m: Result<Minimal, String>) -> TokenStream {
    let private = runtime();
    let m = match m {
        Ok(m) => m,
        Err(why) => {
            let why = format!("model {} has no minimal coordinates: {why}", def.name);
            return quote! {
                fn minimal_layout(&self) -> ::core::result::Result<#private::MinimalLayout, ::std::string::String> {
                    ::core::result::Result::Err(::std::string::String::from(#why))
                }
            };
        }
    };
    let pivots: Vec<Id> = m.pivots.iter().map(|p| p.2).collect();
    let (pivot_lets, pivot_exprs) = lower(d, def, &pivots, Coords::Global, &[]);
    let pivot_items =
        m.pivots.iter().zip(&pivot_exprs).map(|((name, k, _), e)| quote!((::std::string::String::from(#name), #k, #e)));
    let (coords, speeds) = (&m.coords, &m.speeds);
    let nq = m.qd.len();
    let mut outputs: Vec<Id> = m.q_dep.iter().map(|p| p.1).collect();
    outputs.extend(&m.qd);
    outputs.extend(&m.b);
    outputs.extend(&m.c);
    outputs.extend(&m.frames);
    let (lets, exprs) = lower(d, def, &outputs, Coords::Global, &[]);
    // the state alone (`minimal_state`): the same expressions for q_D and
    // qd, lowered on their own so that none of B's or c's is computed
    let (state_lets, state_exprs) = lower(d, def, &outputs[..m.q_dep.len() + nq], Coords::Global, &[]);
    let mut state_sets = TokenStream::new();
    for ((j, _), e) in m.q_dep.iter().zip(&state_exprs) {
        state_sets.extend(quote!(q[#j] = #e;));
    }
    for (j, e) in state_exprs[m.q_dep.len()..].iter().enumerate() {
        state_sets.extend(quote!(qd_out[#j] = #e;));
    }
    let mut sets = TokenStream::new();
    let nqd = m.q_dep.len();
    for ((j, _), e) in m.q_dep.iter().zip(&exprs) {
        sets.extend(quote!(q[#j] = #e;));
    }
    let mut rest = exprs[nqd..].iter();
    for (j, e) in rest.by_ref().take(nq).enumerate() {
        sets.extend(quote!(qd_out[#j] = #e;));
    }
    for (k, e) in rest.by_ref().take(m.b.len()).enumerate() {
        sets.extend(quote!(b[#k] = #e;));
    }
    for (k, e) in rest.enumerate() {
        sets.extend(quote!(c[#k] = #e;));
    }
    let maggi = maggi_fn(d, &m);
    quote! {
        #maggi

        fn minimal_layout(&self) -> ::core::result::Result<#private::MinimalLayout, ::std::string::String> {
            type S = f64;
            #pivot_lets
            ::core::result::Result::Ok(#private::MinimalLayout {
                coords: ::std::vec![#(#coords),*],
                speeds: ::std::vec![#(#speeds),*],
                pivots: ::std::vec![#(#pivot_items),*],
            })
        }

        #[inline]
        fn minimal_expand<S: #private::Scalar>(&self, q: &mut [S], qd_out: &mut [S], b: &mut [S], c: &mut [S]) {
            // the speeds in, read before anything is written
            #[allow(unused_variables, reason = "a kernel reads only the terms its model has")]
            let qd: [S; #nq] = ::core::array::from_fn(|k| qd_out[k]);
            #lets
            #sets
        }

        #[inline]
        fn minimal_state<S: #private::Scalar>(&self, q: &mut [S], qd_out: &mut [S]) -> bool {
            #[allow(unused_variables, reason = "a kernel reads only the terms its model has")]
            let qd: [S; #nq] = ::core::array::from_fn(|k| qd_out[k]);
            #state_lets
            #state_sets
            true
        }
    }
}

/// `fn minimal_maggi`: Maggi's `B^T M B` and `B^T (F - M c)` from the
/// mass diagonal, `B`, `c` and `f` that `minimal_expand` wrote.
fn maggi_fn(d: &Derived, m: &Minimal) -> TokenStream {
    let nq = m.qd.len();
    // Maggi's B^T M B (lower triangle) and B^T (F - M c) in the body
    // frames over B's structural nonzeros, with B's constant entries
    // inlined; F is f turned into each body's frame by the expansion's
    // cos, sin (c[nq..])
    let nu = m.speeds.len();
    let entry = |j: usize, i: usize| -> Option<TokenStream> {
        let id = m.b[j * nu + i];
        match d.ar.as_const(id) {
            Some(0.0) => None,
            Some(1.0) => Some(TokenStream::new()),
            Some(v) => {
                let v = lit_f64(v);
                Some(quote!(#v *))
            }
            None => {
                let k = j * nu + i;
                Some(quote!(b[#k] *))
            }
        }
    };
    let force = |j: usize| -> TokenStream {
        let (i, axis) = (j / 3, j % 3);
        let (cs, sn) = (nq + 2 * i, nq + 2 * i + 1);
        let (x, y) = (3 * i, 3 * i + 1);
        match axis {
            0 => quote!((c[#cs] * f[#x] + c[#sn] * f[#y])),
            1 => quote!((c[#cs] * f[#y] - c[#sn] * f[#x])),
            _ => quote!(f[#j]),
        }
    };
    let mut maggi = TokenStream::new();
    for i in 0..nu {
        for k in 0..=i {
            let terms: Vec<TokenStream> = (0..nq)
                .filter_map(|j| {
                    let (bi, bk) = (entry(j, i)?, entry(j, k)?);
                    Some(quote!(#bi #bk mass[#j]))
                })
                .collect();
            let sum = if terms.is_empty() { quote!(0.0) } else { join(terms.into_iter(), quote!(+)) };
            let at = i * nu + k;
            maggi.extend(quote!(a[#at] = #sum;));
        }
        let terms: Vec<TokenStream> = (0..nq)
            .filter_map(|j| {
                let bi = entry(j, i)?;
                let fj = force(j);
                Some(if d.ar.is_zero(m.c[j]) { quote!(#bi #fj) } else { quote!(#bi (#fj - mass[#j] * c[#j])) })
            })
            .collect();
        let sum = if terms.is_empty() { quote!(0.0) } else { join(terms.into_iter(), quote!(+)) };
        maggi.extend(quote!(r[#i] = #sum;));
    }
    let nc_len = nq + m.frames.len();
    quote! {
        #[inline]
        fn minimal_maggi(&self, mass: &[f64], b: &[f64], c: &[f64], f: &[f64], a: &mut [f64], r: &mut [f64]) {
            let (mass, b, c, f) = (&mass[..#nq], &b[..#nq * #nu], &c[..#nc_len], &f[..#nq]);
            let (a, r) = (&mut a[..#nu * #nu], &mut r[..#nu]);
            #maggi
        }
    }
}

/// `minimal_constants` and `minimal_rhs`: the right-hand side on the
/// minimal coordinates `m` in one straight-line function (the expansion,
/// the applied force through a closure, Maggi's `B^T M B` and
/// `B^T (F - M c)` from `maggi`), the fixed parts of its expressions read
/// from a table computed once per run.
fn fused_fns(d: &Derived, def: &ModelDef, m: &Minimal, maggi: &Maggi) -> TokenStream {
    let (nq, np, nu) = (m.qd.len(), m.coords.len(), m.speeds.len());
    let nz = np + nu;
    // the kept coordinates and the speeds read from z
    let name = |s: Sym| -> TokenStream {
        let i = match s {
            Sym::Q(j) => m.coords.iter().position(|&c| c == j),
            Sym::Qd(j) => m.speeds.iter().position(|&c| c == j).map(|i| np + i),
            Sym::Param(_) | Sym::Index(_) => None,
        };
        let i = i.unwrap_or_else(|| panic!("the minimal form mentions {s:?}, neither kept nor independent"));
        quote!(z[#i])
    };
    let mut outputs: Vec<Id> = m.q_dep.iter().map(|p| p.1).collect();
    outputs.extend(&m.qd);
    outputs.extend(&maggi.a);
    outputs.extend(&maggi.minus_bmc);
    outputs.extend(&maggi.b);
    outputs.extend(&m.frames);
    outputs.extend(maggi.hinge.iter().flatten());
    let mut h = Hoisted::new(d, def, &outputs, &name);
    let nk = h.table.len();
    let (table_lets, table_exprs) = lower(d, def, &h.table, Coords::Global, &[]);
    // the body of `minimal_rhs` (every coordinate and rate written) or of
    // `minimal_rhs_lean` (only the headings', what a hinge torque reads):
    // the coordinates and rates `write` keeps and the kept coordinates'
    // rates, each value computed just before it is stored, then Maggi's
    // part with its own bindings
    let nh = maggi.hinge.len();
    let private = runtime();
    let fresh = h.done.clone();
    let body = |h: &mut Hoisted, write: &dyn Fn(usize) -> bool| {
        h.done = fresh.clone();
        let mut sets = TokenStream::new();
        for (i, &j) in m.coords.iter().enumerate().filter(|(_, j)| write(**j)) {
            sets.extend(quote!(q[#j] = z[#i];));
        }
        for &(j, e) in m.q_dep.iter().filter(|(j, _)| write(*j)) {
            sets.extend(h.lets_for(&[e]));
            let e = h.refer(e);
            sets.extend(quote!(q[#j] = #e;));
        }
        for (j, &e) in m.qd.iter().enumerate() {
            let kept = m.coords.iter().position(|&c| c == j);
            if !write(j) && kept.is_none() {
                continue;
            }
            sets.extend(h.lets_for(&[e]));
            let e = h.refer(e);
            if write(j) {
                sets.extend(quote!(qd[#j] = #e;));
            }
            if let Some(i) = kept {
                sets.extend(quote!(pd[#i] = #e;));
            }
        }
        let maggi_sets = maggi_tokens(d, m, maggi, h);
        quote! {
            type S = f64;
            // every slice cut to its length once: no bounds check below
            let (k, z) = (&k[..#nk], &z[..#nz]);
            let (q, qd, dz) = (&mut q[..#nq], &mut qd[..#nq], &mut dz[..#nz]);
            let pd = &mut dz[..#np];
            #sets
            let mut f = [0.0f64; #nq];
            let mut tau = [0.0f64; #nh];
            forces(q, qd, &mut f, &mut tau).map_err(#private::MinimalRhsError::Forces)?;
            #maggi_sets
            ::core::result::Result::Ok(())
        }
    };
    // each body twice: the second binds a sine and a cosine of one angle
    // together wherever the first bound both (in separate statements)
    let paired = |h: &mut Hoisted, write: &dyn Fn(usize) -> bool| {
        h.log.clear();
        h.pair_with = None;
        body(h, write);
        let mut bound = vec![false; h.done.len()];
        for id in &h.log {
            bound[id.index()] = true;
        }
        h.pair_with = Some(bound);
        let tokens = body(h, write);
        h.pair_with = None;
        tokens
    };
    let full = paired(&mut h, &|_| true);
    let lean = paired(&mut h, &|j| j % 3 == 2);
    let signature = |name: proc_macro2::Ident| {
        quote! {
            #[inline]
            fn #name<E, F>(
                &self,
                k: &[f64],
                z: &[f64],
                q: &mut [f64],
                qd: &mut [f64],
                dz: &mut [f64],
                forces: F,
            ) -> ::core::result::Result<(), #private::MinimalRhsError<E>>
            where
                F: ::core::ops::FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> ::core::result::Result<(), E>,
        }
    };
    let (rhs, rhs_lean) = (signature(format_ident!("minimal_rhs")), signature(format_ident!("minimal_rhs_lean")));
    quote! {
        fn minimal_constants(&self) -> ::core::option::Option<::std::vec::Vec<f64>> {
            type S = f64;
            #table_lets
            ::core::option::Option::Some(::std::vec![#(#table_exprs),*])
        }

        #rhs { #full }

        #rhs_lean { #lean }
    }
}

/// The Maggi part of the fused right-hand side (`B^T M B`, `B^T (F - M
/// c)` with the applied force and the hinges' torques, and the solve),
/// its bindings emitted where `h` has not bound them yet.
fn maggi_tokens(d: &Derived, m: &Minimal, maggi: &Maggi, h: &mut Hoisted<'_>) -> TokenStream {
    let (nq, np, nu) = (m.qd.len(), m.coords.len(), m.speeds.len());
    // Maggi's B^T M B (lower triangle), then B^T (F - M c): -B^T M c
    // first, then F, the force f turned into each body's frame, a body's
    // force skipped where it is zero (a motor's hinge torque has none)
    let mut maggi_sets = TokenStream::new();
    let mut a = vec![quote!(0.0f64); nu * nu];
    for i in 0..nu {
        for k in 0..=i {
            let e = maggi.a[i * (i + 1) / 2 + k];
            maggi_sets.extend(h.lets_for(&[e]));
            let (e, v) = (h.refer(e), format_ident!("a{}_{}", i, k));
            maggi_sets.extend(quote!(let #v: S = #e;));
            a[i * nu + k] = quote!(#v);
        }
    }
    let r: Vec<proc_macro2::Ident> = (0..nu).map(|i| format_ident!("r{}", i)).collect();
    for (ri, &bmc) in r.iter().zip(&maggi.minus_bmc) {
        maggi_sets.extend(h.lets_for(&[bmc]));
        let e = h.refer(bmc);
        maggi_sets.extend(quote!(let mut #ri: S = #e;));
    }
    for body in 0..nq / 3 {
        let (x, y, w) = (3 * body, 3 * body + 1, 3 * body + 2);
        let (cs, sn) = (m.frames[2 * body], m.frames[2 * body + 1]);
        // `r_i += B_ji F_j` over the body's velocities `j` in `axes`, in a
        // block of its own that runs where the force is not zero (its
        // bindings scoped to it)
        let mut block = |h: &mut Hoisted, axes: &[usize], force: TokenStream, test: TokenStream| {
            let saved = h.done.clone();
            let mut lets = TokenStream::new();
            let mut adds = TokenStream::new();
            for &axis in axes {
                let (j, fj) = (3 * body + axis, [quote!(fx), quote!(fy), quote!(f[#w])][axis].clone());
                for (i, ri) in r.iter().enumerate() {
                    let bji = maggi.b[j * nu + i];
                    match d.ar.as_const(bji) {
                        Some(0.0) => {}
                        Some(1.0) => adds.extend(quote!(#ri += #fj;)),
                        _ => {
                            lets.extend(h.lets_for(&[bji]));
                            let b = h.refer(bji);
                            adds.extend(quote!(#ri += #b * #fj;));
                        }
                    }
                }
            }
            if !adds.is_empty() {
                let frame = if axes.contains(&0) { h.lets_for(&[cs, sn]) } else { TokenStream::new() };
                maggi_sets.extend(quote!(if #test { #frame #lets #force #adds }));
            }
            h.done = saved;
        };
        let (c, s) = (h.refer(cs), h.refer(sn));
        block(
            h,
            &[0, 1],
            quote!(let (fx, fy) = (#c * f[#x] + #s * f[#y], #c * f[#y] - #s * f[#x]);),
            quote!(f[#x] != 0.0 || f[#y] != 0.0),
        );
        block(h, &[2], TokenStream::new(), quote!(f[#w] != 0.0));
    }
    // each hinge's torque along its row `B_a - B_b`, where it is not zero
    for (hinge, row) in maggi.hinge.iter().enumerate() {
        let saved = h.done.clone();
        let mut lets = TokenStream::new();
        let mut adds = TokenStream::new();
        for (ri, &coef) in r.iter().zip(row) {
            match d.ar.as_const(coef) {
                Some(0.0) => {}
                Some(1.0) => adds.extend(quote!(#ri += tau[#hinge];)),
                Some(-1.0) => adds.extend(quote!(#ri -= tau[#hinge];)),
                _ => {
                    lets.extend(h.lets_for(&[coef]));
                    let c = h.refer(coef);
                    adds.extend(quote!(#ri += #c * tau[#hinge];));
                }
            }
        }
        if !adds.is_empty() {
            maggi_sets.extend(quote!(if tau[#hinge] != 0.0 { #lets #adds }));
        }
        h.done = saved;
    }
    let private = runtime();
    let scratch = if nu > 8 { nu * (nu + 1) } else { 0 };
    maggi_sets.extend(quote! {
        let a: [S; #nu * #nu] = [#(#a),*];
        let r: [S; #nu] = [#(#r),*];
        let mut scratch = [0.0f64; #scratch];
        #private::ldl_solve(&a, #nu, #nu, &r, &mut dz[#np..], &mut scratch)
            .map_err(#private::MinimalRhsError::Maggi)?;
    });
    maggi_sets
}
