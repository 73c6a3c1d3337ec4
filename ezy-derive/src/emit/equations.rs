//! `fn equations`: every derived expression (masses, `phi`, velocity
//! rows, Jacobian entries, `gamma`, point velocities) as text and LaTeX
//! templates that the generated code renders per element with the
//! runtime's coordinate and parameter names, for `ezy equations` and the
//! documentation.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::layout::{affine_tokens, body_column, each_element, layout_prelude, point_body};
use super::runtime;
use ezy_lang::ast::{Affine, ModelDef};
use ezy_lang::check::{BodyRef, Resolved};
use ezy_lang::kinematics::{Derived, own_index};
use ezy_lang::sym::{Id, Sym};

/// `fn equations(&self)`: each item's templates rendered per element.
pub(super) fn equations_fn(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let private = runtime();
    let prelude = layout_prelude(def);
    let params: Vec<String> = def.params.iter().map(|p| p.name.to_string()).collect();
    // a template naming family indices gets the element's values first
    // (an integer; a negative one in parentheses); where it names one
    // index, its forms at 0, 1 and -1 come simplified from the arena
    // (`x - 0*L` is `x`, `x - 1*L` is `x - L`)
    let mut ar = d.ar.clone();
    let mut render = |id: Id, out: &str, indices: &[Affine]| -> TokenStream {
        let (t, x) = ezy_lang::equation_templates(&ar, id);
        let out = format_ident!("{}", out);
        let named: Vec<usize> = (0..indices.len())
            .filter(|&k| {
                let m = ezy_lang::index_marker(k);
                t.contains(&m) || x.contains(&m)
            })
            .collect();
        if named.is_empty() {
            return quote!(eq.#out.push(#private::render_equation(#t, #x, &names, &params)););
        }
        let mut subs = TokenStream::new();
        for &k in &named {
            let m = ezy_lang::index_marker(k);
            let a = affine_tokens(&indices[k]);
            subs.extend(quote! {
                let n: i64 = #a;
                let n = if n < 0 { ::std::format!("({})", n) } else { ::std::format!("{}", n) };
                let (t, x) = (t.replace(#m, &n), x.replace(#m, &n));
            });
        }
        let generic = quote!({
            let (t, x) = (::std::string::String::from(#t), ::std::string::String::from(#x));
            #subs
            eq.#out.push(#private::render_equation(&t, &x, &names, &params));
        });
        let [k] = named[..] else { return generic };
        let a = affine_tokens(&indices[k]);
        let arms = [0i64, 1, -1].map(|v| {
            let value = ar.cst(v as f64);
            let at = ar.replace(id, &|s| (s == Sym::Index(k)).then_some(value), &mut Default::default());
            let (t, x) = ezy_lang::equation_templates(&ar, at);
            quote!(#v => eq.#out.push(#private::render_equation(#t, #x, &names, &params)),)
        });
        quote!(match #a as i64 { #(#arms)* _ => #generic })
    };
    let names_of = |slots: &[BodyRef]| -> TokenStream {
        let cols: Vec<TokenStream> = slots.iter().map(|b| body_column(def, b)).collect();
        let n = 3 * slots.len();
        let idx = (0..n).map(|k| {
            let (s, o) = (k / 3, k % 3);
            quote!(info.coords[cols[#s] + #o].as_str())
        });
        let ns = slots.len();
        quote! {
            let cols: [usize; #ns] = [#(#cols),*];
            let names: [&str; #n] = [#(#idx),*];
        }
    };
    let own = [own_index()];
    let mut body = TokenStream::new();
    for (bi, b) in def.bodies.iter().enumerate() {
        let pushes: Vec<TokenStream> = d.mass[bi].iter().map(|&m| render(m, "mass", &own)).collect();
        body.extend(each_element(b.family, quote!(let names: [&str; 0] = []; #(#pushes)*)));
    }
    for g in &d.groups {
        if g.slots.is_empty() {
            continue;
        }
        let names = names_of(&g.slots);
        let mut pushes = TokenStream::new();
        let ix = &g.indices;
        if g.holonomic() {
            pushes.extend(g.phi.iter().map(|&x| render(x, "phi", ix)));
        }
        pushes.extend(g.velocity.iter().map(|&x| render(x, "velocity", ix)));
        pushes.extend(g.local_pattern(&d.ar).into_iter().map(|(r, c)| render(g.g[r][c], "jacobian", ix)));
        pushes.extend(g.gamma.iter().map(|&x| render(x, "gamma", ix)));
        body.extend(each_element(g.family, quote!(#names #pushes)));
    }
    for (pi, p) in d.points.iter().enumerate() {
        if p.body.is_none() {
            continue;
        }
        let names = names_of(&[point_body(def, res, pi)]);
        let pushes: Vec<TokenStream> = p.vel.iter().map(|&x| render(x, "point_velocities", &own)).collect();
        body.extend(each_element(def.points[pi].family, quote!(#names #(#pushes)*)));
    }
    quote! {
        fn equations(&self) -> #private::Equations {
            #prelude
            let info = <Self as #private::Model>::info(self);
            let params: &[&str] = &[#(#params),*];
            let mut eq = #private::Equations::default();
            eq.coords = info.coords.iter().map(|c| #private::render_equation("\u{1}q0\u{2}", "\u{1}q0\u{2}", &[c.as_str()], &[])).collect();
            #body
            eq
        }
    }
}
