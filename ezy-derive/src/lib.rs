#![warn(missing_docs)]
//! The `model!` macro of ezy: a declarative planar multibody model (bodies,
//! points, hinges, skates) in, a struct with the `ezy_core::Model` impl out.
//! Families (`for i in 0..N { .. }`) of bodies, points, hinges, sliders
//! and skates are derived once as element kernels and looped over at run
//! time. The holonomic residual, its Jacobian, the skate constraint matrix, the
//! convective terms and the point kinematics are derived symbolically at
//! compile time (see `kinematics` and `sym`); parameters stay runtime fields.
//!
//! Data flows one way through the private modules: tokens -> `ast`
//! (`parse`) -> `check` -> `kinematics` (expressions in `sym`) -> `emit`.

use proc_macro::TokenStream;

mod ast;
mod check;
mod emit;
mod kinematics;
mod minimal;
mod parse;
// `eval`/`display` serve the tests now and readable equations later.
#[cfg_attr(not(test), allow(dead_code))]
mod sym;

// The whole documentation of the macro, shown here and, inlined, at the
// re-exports `ezy_core::model!` and `ezy::model!`. Its examples use
// `ezy_core::model!`, which this crate cannot depend on, so they run as
// doctests of ezy-core (`ModelDocExamples` in ezy-core/src/lib.rs) and this
// crate's doctests are off (`doctest = false` in its Cargo.toml).
#[doc = include_str!("model.md")]
#[proc_macro]
pub fn model(input: TokenStream) -> TokenStream {
    let def = syn::parse_macro_input!(input as ast::ModelDef);
    expand(&def).unwrap_or_else(|e| e.to_compile_error()).into()
}

fn expand(def: &ast::ModelDef) -> syn::Result<proc_macro2::TokenStream> {
    let mut errs = check::Errors::default();
    let resolved = check::check(def, &mut errs);
    let mut derived = kinematics::derive(def, &resolved, &mut errs);
    errs.finish()?;
    emit::runtime_root().map_err(|msg| syn::Error::new(def.name.span(), msg))?;
    Ok(emit::emit(def, &resolved, &mut derived))
}
