#![warn(missing_docs)]
//! The `model!` macro of ezy: a declarative planar multibody model (bodies,
//! points, hinges, skates) in, a struct with the `ezy_core::Model` impl out.
//! Families (`for i in 0..N { .. }`) of bodies, points, hinges, sliders
//! and skates are derived once as element kernels and looped over at run
//! time. The holonomic residual, its Jacobian, the skate constraint matrix, the
//! convective terms and the point kinematics are derived symbolically at
//! compile time by the model language's engine (`ezy_lang`); parameters
//! stay runtime fields.
//!
//! Data flows one way: tokens -> `ezy_lang` (`ast`, `check`,
//! `kinematics`, expressions in `sym`, the model's `description`) ->
//! `emit`. What a model says about itself (names, checks on its counts,
//! equations) is ezy-lang's description, written into the expansion as
//! data and rendered by ezy-core (`model::describe`), the same code a
//! model read from text takes.

use proc_macro::TokenStream;

mod dump;
mod emit;

// The whole documentation of the macro is at `ezy_core::model!` (the
// `macro_rules!` wrapper users call, which passes its `$crate` as the
// runtime's path: `@root($crate)`); its examples run as doctests of
// ezy-core, since this crate cannot depend on ezy-core (`doctest = false`
// in its Cargo.toml).
/// The `model!` procedural macro: called through `ezy_core::model!` (or
/// `ezy::model!`), whose documentation gives the language. The input may
/// begin with `@root(PATH)`, the runtime crate's path (default
/// `::ezy_core`).
#[proc_macro]
pub fn model(input: TokenStream) -> TokenStream {
    let (root, input) = split_root(input.into());
    // a text nested too deep for syn's recursion is refused before it
    if let Err(e) = ezy_lang::depth::check_depth(&input) {
        return e.to_compile_error().into();
    }
    let def = match syn::parse2::<ezy_lang::ast::ModelDef>(input) {
        Ok(def) => def,
        Err(e) => return e.to_compile_error().into(),
    };
    let out = emit::with_root(root, || expand(&def)).unwrap_or_else(|e| e.to_compile_error());
    dump::dump(&def.name.to_string(), &out);
    out.into()
}

/// Splits a leading `@root(PATH)` off the input: the path and the rest.
fn split_root(input: proc_macro2::TokenStream) -> (proc_macro2::TokenStream, proc_macro2::TokenStream) {
    use proc_macro2::{Delimiter, TokenTree};
    let tokens: Vec<TokenTree> = input.clone().into_iter().collect();
    if let [TokenTree::Punct(at), TokenTree::Ident(root), TokenTree::Group(path), ..] = &tokens[..]
        && at.as_char() == '@'
        && root == "root"
        && path.delimiter() == Delimiter::Parenthesis
    {
        return (path.stream(), tokens[3..].iter().cloned().collect());
    }
    (quote::quote!(::ezy_core), input)
}

fn expand(def: &ezy_lang::ast::ModelDef) -> syn::Result<proc_macro2::TokenStream> {
    let (resolved, mut derived) = ezy_lang::derive(def)?;
    Ok(emit::emit(def, &resolved, &mut derived))
}

#[cfg(test)]
mod tests {
    /// The expansion is the same at every compilation: the derivation
    /// walks its maps in a fixed order (a hash map's random order once
    /// renumbered the pendulum's bindings from build to build). Each
    /// expansion below builds its maps with fresh random hash keys.
    #[test]
    fn the_expansion_does_not_depend_on_hash_order() {
        let text = "
            pub struct Pendulum {
                param L = 1.0;
                param m = 1.0;
                body bob(x, y, phi) { mass: m, inertia: 0.1 }
                point O on bob at (-L, 0);
                hinge O: O = ground(0, 0);
            }";
        let expand = || {
            let def: ezy_lang::ast::ModelDef = syn::parse_str(text).expect("the model parses");
            crate::expand(&def).expect("the model expands").to_string()
        };
        let first = expand();
        for _ in 0..8 {
            let other = expand();
            if other != first {
                let (a, b): (Vec<&str>, Vec<&str>) = (first.split(';').collect(), other.split(';').collect());
                let k = a.iter().zip(&b).position(|(x, y)| x != y).unwrap_or(0);
                panic!("two expansions of the pendulum differ from statement {k}: `{}` against `{}`", a[k], b[k]);
            }
        }
    }
}
