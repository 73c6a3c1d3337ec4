//! `quote!` the struct, its `Default` and its `Model` impl from the derived
//! expressions: the back end of `model!`, split by what it emits.
//!
//! A model without families gets straight-line code: every expression it
//! needs, renamed to global coordinates, in arena order, as `let` bindings
//! (shared subexpressions computed once per call), and straight-line
//! products with `G` at its compile-time pattern. A model with families
//! gets, per constraint item, one element kernel inside a loop over the
//! family's elements: the element's coordinates are gathered from `q` by
//! the runtime layout (`ezy_core::__private::Layout`), so the generated
//! code does not grow with the counts.
//!
//! This module emits the struct, its `Default`, the parameters by index
//! and the `impl` blocks around what the others emit, and holds what they
//! share (the runtime's path, numbers, sums):
//!
//! - [`lower`]: the derived expressions as Rust (`let` bindings, one
//!   expression per output), with or without a table of fixed values;
//! - [`layout`]: `__ezy_layout` (where each item's elements sit at the
//!   current counts) and the element loops and addresses every walking
//!   function uses;
//! - [`families`]: the loop form (element kernels looped at run time) of
//!   the numeric functions, and the mass diagonal and local geometry of
//!   every model;
//! - [`straight`]: the straight-line numeric functions of a model without
//!   families;
//! - [`products`]: its products with `G` at the compile-time pattern;
//! - [`minimal`]: its minimal coordinates and fused right-hand side;
//! - [`describe`]: the model's description (ezy-lang's, as a `static`)
//!   and `info`, `check_counts` and `equations` as calls that render it.

mod describe;
mod families;
mod layout;
mod lower;
mod minimal;
mod products;
mod straight;

use proc_macro2::{Literal, TokenStream};
use quote::quote;

use ezy_lang::ast::{ModelDef, escape_unit};
use ezy_lang::check::Resolved;
use ezy_lang::kinematics::Derived;

/// A literal `f64` (suffixed), or `NAN` for a value that is not finite.
fn lit_f64(v: f64) -> TokenStream {
    if v.is_finite() {
        let l = Literal::f64_suffixed(v);
        quote!(#l)
    } else {
        quote!(::core::f64::NAN)
    }
}

/// `a op b op c ...`
fn join(items: impl Iterator<Item = TokenStream>, op: TokenStream) -> TokenStream {
    let mut out = TokenStream::new();
    for (i, item) in items.enumerate() {
        if i > 0 {
            out.extend(op.clone());
        }
        out.extend(item);
    }
    out
}

thread_local! {
    /// The runtime crate's path for the expansion under way ([`with_root`]).
    static ROOT: std::cell::RefCell<TokenStream> = std::cell::RefCell::new(quote!(::ezy_core));
}

/// Runs `f` with `root` as the path of the runtime crate: the `$crate` of
/// the `model!` the user called (`ezy_core::model!`, re-exported as
/// `ezy::model!`, passes its own), so the generated code names the crate
/// that defined the macro however the user depends on it (directly,
/// through `ezy`, renamed), without reading their `Cargo.toml`.
pub fn with_root<T>(root: TokenStream, f: impl FnOnce() -> T) -> T {
    let old = ROOT.with(|r| r.replace(root));
    let out = f();
    ROOT.with(|r| r.replace(old));
    out
}

/// `ROOT::__private`, the paths the generated code uses (see [`with_root`]).
fn runtime() -> TokenStream {
    ROOT.with(|r| {
        let root = r.borrow().clone();
        quote!(#root::__private)
    })
}

/// The whole expansion.
pub fn emit(def: &ModelDef, res: &Resolved, d: &mut Derived) -> TokenStream {
    let name = &def.name;
    let private = runtime();
    let is_static = def.families.is_empty() && def.counts.is_empty();

    let struct_and_default = struct_and_default(def);
    let params = param_fns(def);
    let layout = layout::layout_fn(def, d);
    // before the numerics, which add to the arena
    let (description, describe) = describe::description_fns(def, res, d);
    let geometry = families::geometry_fns(d, def);
    let numerics = if is_static { straight::numerics(d, def, res) } else { families::numerics(d, def, res) };

    quote! {
        #struct_and_default

        #[allow(non_snake_case, unused_variables, unused_mut, unused_parens, clippy::all, clippy::pedantic, reason = "generated: the model's own names, and terms a model may not use")]
        impl #name {
            #layout
            #description
        }

        #[allow(non_snake_case, unused_variables, unused_mut, unused_parens, clippy::all, clippy::pedantic, reason = "generated: the model's own names, and terms a model may not use")]
        impl #private::Model for #name {
            #describe
            #params
            #geometry
            #numerics
        }
    }
}

/// The model's struct (a field per parameter, then per count) and its
/// `Default` (the declared values).
fn struct_and_default(def: &ModelDef) -> TokenStream {
    let name = &def.name;
    let vis = &def.vis;
    let attrs = &def.attrs;
    let fields = def.params.iter().map(|p| {
        let pattrs = escape_unit(&p.attrs);
        let n = &p.name;
        quote!(#(#pattrs)* pub #n: f64,)
    });
    let count_fields = def.counts.iter().map(|c| {
        let cattrs = escape_unit(&c.attrs);
        let n = &c.name;
        quote!(#(#cattrs)* pub #n: usize,)
    });
    let defaults = def.params.iter().map(|p| {
        let n = &p.name;
        let v = lit_f64(p.value);
        quote!(#n: #v,)
    });
    let count_defaults = def.counts.iter().map(|c| {
        let n = &c.name;
        let v = c.value as usize;
        quote!(#n: #v,)
    });
    quote! {
        #(#attrs)*
        #[derive(Debug, Clone, PartialEq)]
        #[allow(non_snake_case, reason = "the model's parameters keep the names its text gives them")]
        #vis struct #name {
            #(#fields)*
            #(#count_fields)*
        }

        impl ::core::default::Default for #name {
            fn default() -> Self {
                Self { #(#defaults)* #(#count_defaults)* }
            }
        }
    }
}

/// `fn param` and `fn set_param`: the parameters by index, the reals,
/// then the counts (a count set to a whole number >= 1 only).
fn param_fns(def: &ModelDef) -> TokenStream {
    let np = def.params.len();
    let get_arms = def.params.iter().enumerate().map(|(i, p)| {
        let n = &p.name;
        quote!(#i => self.#n,)
    });
    let set_arms = def.params.iter().enumerate().map(|(i, p)| {
        let n = &p.name;
        quote!(#i => self.#n = value,)
    });
    let get_counts = def.counts.iter().enumerate().map(|(i, c)| {
        let (n, i) = (&c.name, np + i);
        quote!(#i => self.#n as f64,)
    });
    let set_counts = def.counts.iter().enumerate().map(|(i, c)| {
        let (n, i) = (&c.name, np + i);
        let msg = format!("count `{}` must be a whole number >= 1, got {{}}", c.name);
        quote!(#i => {
            assert!(value >= 1.0 && value.fract() == 0.0 && value <= 1e9, #msg, value);
            self.#n = value as usize;
        })
    });
    quote! {
        fn param(&self, index: usize) -> f64 {
            match index {
                #(#get_arms)*
                #(#get_counts)*
                _ => panic!("parameter index {} out of range", index),
            }
        }

        fn set_param(&mut self, index: usize, value: f64) {
            match index {
                #(#set_arms)*
                #(#set_counts)*
                _ => panic!("parameter index {} out of range", index),
            }
        }
    }
}

/// The seven generic numeric functions of `Model` around their bodies
/// (`phi`, `holonomic_jacobian`, `constraint_matrix`,
/// `phi_and_constraint_matrix`, `constraint_terms`, `points`,
/// `point_velocities`), each opening with `q_prelude` or, when it takes
/// `qd`, `qd_prelude`.
fn numeric_fns(q_prelude: &TokenStream, qd_prelude: &TokenStream, bodies: [TokenStream; 7]) -> TokenStream {
    let private = runtime();
    let [phi, jac, g, phi_g, terms, points, vel] = bodies;
    quote! {
        #[inline]
        fn phi<S: #private::Scalar>(&self, q: &[S], phi: &mut [S]) {
            #q_prelude
            #phi
        }

        #[inline]
        fn holonomic_jacobian<S: #private::Scalar>(&self, q: &[S], values: &mut [S]) {
            #q_prelude
            #jac
        }

        #[inline]
        fn constraint_matrix<S: #private::Scalar>(&self, q: &[S], values: &mut [S]) {
            #q_prelude
            #g
        }

        #[inline]
        fn phi_and_constraint_matrix<S: #private::Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
            #q_prelude
            #phi_g
        }

        #[inline]
        fn constraint_terms<S: #private::Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
            #qd_prelude
            #terms
        }

        #[inline]
        fn points<S: #private::Scalar>(&self, q: &[S], out: &mut [S]) {
            #q_prelude
            #points
        }

        #[inline]
        fn point_velocities<S: #private::Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
            #qd_prelude
            #vel
        }
    }
}
