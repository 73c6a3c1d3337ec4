//! Where the elements sit at run time: `fn __ezy_layout` (each family's
//! range, each item's first column of `q`, row of `G` and pattern value at
//! the current counts, `ezy_core::__private::Layout`) and what every
//! generated function that walks the items uses of it: the counts, the
//! loop over an item's elements, an element's column and global index,
//! an affine index's value.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::runtime;
use ezy_lang::ast::{Affine, ModelDef};
use ezy_lang::check::{BodyRef, Resolved};
use ezy_lang::kinematics::{Derived, Kind};

/// `(index expression, as i64)` of an affine index at loop value `v`.
pub(super) fn affine_tokens(a: &Affine) -> TokenStream {
    let mut t = quote!(0i64);
    if a.var {
        t = quote!(#t + v);
    }
    if let Some(n) = &a.count {
        let c = format_ident!("c_{}", n);
        t = quote!(#t + #c);
    }
    let c = a.c;
    quote!((#t + #c))
}

/// `let l = self.__ezy_layout();` and the counts (`c_N`, which
/// [`affine_tokens`] names): the opening of every generated function that
/// walks the items.
pub(super) fn layout_prelude(def: &ModelDef) -> TokenStream {
    let counts = count_lets(def);
    quote!(let l = self.__ezy_layout(); #counts)
}

/// The runtime counts as `let c_N: i64` bindings.
pub(super) fn count_lets(def: &ModelDef) -> TokenStream {
    let mut out = TokenStream::new();
    for c in &def.counts {
        let (n, v) = (&c.name, format_ident!("c_{}", c.name));
        out.extend(quote!(let #v: i64 = self.#n as i64;));
    }
    out
}

/// Position of an element in its family (`value - start`), as `i64`
/// (`0` for a single item).
fn position(family: Option<usize>, index: Option<&Affine>) -> TokenStream {
    match (family, index) {
        (Some(f), Some(a)) => {
            let a = affine_tokens(a);
            quote!((#a - l.f_start[#f]))
        }
        _ => quote!(0i64),
    }
}

/// First `q` column of a body element, as `usize` (its position in range
/// is checked by `check_counts`).
pub(super) fn body_column(def: &ModelDef, b: &BodyRef) -> TokenStream {
    let bi = b.0;
    let pos = position(def.bodies[bi].family, b.1.as_ref());
    quote!((l.body_off[#bi] + 3 * (#pos as usize)))
}

/// The body element a point item's element sits on (loop value `v` = the
/// point's index).
pub(super) fn point_body(def: &ModelDef, res: &Resolved, p: usize) -> BodyRef {
    let var = Affine { var: true, count: None, c: 0, span: proc_macro2::Span::call_site() };
    if def.points[p].family.is_some() {
        (res.point_body[p], Some(var))
    } else {
        (res.point_body[p], res.point_body_index[p].clone())
    }
}

/// `for e in 0..len { let v = start + e; #body }` over an item's family,
/// or the body once with `e = 0` for a single item.
pub(super) fn each_element(family: Option<usize>, body: TokenStream) -> TokenStream {
    match family {
        Some(f) => quote! {
            for e in 0..l.f_len[#f] {
                let v: i64 = l.f_start[#f] + e as i64;
                #body
            }
        },
        None => quote! {
            {
                let e = 0usize;
                let v = 0i64;
                #body
            }
        },
    }
}

/// Number of elements of an item (`l.f_len[f]`, or 1).
fn len_tokens(family: Option<usize>) -> TokenStream {
    match family {
        Some(f) => quote!(l.f_len[#f]),
        None => quote!(1usize),
    }
}

/// `fn __ezy_layout(&self)`: where every item's elements sit in `q`, the
/// rows of `G` and its pattern values, at the current counts.
pub(super) fn layout_fn(def: &ModelDef, d: &Derived) -> TokenStream {
    let private = runtime();
    let (nf, nb, np, ng) = (def.families.len(), def.bodies.len(), def.points.len(), d.groups.len());
    let counts = count_lets(def);
    let mut body = TokenStream::new();
    for (f, fam) in def.families.iter().enumerate() {
        let (s, e) = (affine_tokens(&fam.start), affine_tokens(&fam.end));
        body.extend(quote! {
            let start: i64 = #s;
            let end: i64 = #e;
            l.f_start[#f] = start;
            l.f_len[#f] = if end > start { (end - start) as usize } else { 0 };
        });
    }
    body.extend(quote!(let mut off = 0usize; let mut bi = 0usize;));
    for (b, item) in def.bodies.iter().enumerate() {
        let n = len_tokens(item.family);
        body.extend(quote! { l.body_off[#b] = off; l.body_index[#b] = bi; off += 3 * #n; bi += #n; });
    }
    body.extend(quote!(let mut pi = 0usize;));
    for (p, item) in def.points.iter().enumerate() {
        let n = len_tokens(item.family);
        body.extend(quote! { l.point_index[#p] = pi; pi += #n; });
    }
    let kinds = proc_macro2::Literal::usize_unsuffixed(Kind::COUNT);
    body.extend(quote!(let mut row = 0usize; let mut val = 0usize; let mut kc = [0usize; #kinds];));
    for (gi, g) in d.groups.iter().enumerate() {
        let n = len_tokens(g.family);
        let (nr, nnz, k) = (g.rows(), g.local_pattern(&d.ar).len(), g.kind.index());
        body.extend(quote! {
            l.row[#gi] = row; l.val[#gi] = val; l.item_index[#gi] = kc[#k];
            row += #nr * #n; val += #nnz * #n; kc[#k] += #n;
        });
        if g.holonomic() {
            body.extend(quote!(l.nh = row; l.nnz_h = val;));
        }
    }
    quote! {
        /// Offsets of every item at the current counts (public for a test
        /// that checks them against the description's).
        #[doc(hidden)]
        #[inline]
        pub fn __ezy_layout(&self) -> #private::Layout<#nf, #nb, #np, #ng> {
            #counts
            let mut l = #private::Layout {
                f_start: [0; #nf], f_len: [0; #nf], body_off: [0; #nb], body_index: [0; #nb],
                point_index: [0; #np], row: [0; #ng], val: [0; #ng], item_index: [0; #ng],
                nq: 0, nc: 0, nh: 0, nnz: 0, nnz_h: 0, n_bodies: 0, n_points: 0,
            };
            #body
            l.nq = off; l.n_bodies = bi; l.n_points = pi; l.nc = row; l.nnz = val;
            l
        }
    }
}
