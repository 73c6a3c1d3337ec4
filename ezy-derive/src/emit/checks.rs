//! `fn check_counts`: what the counts a model is given at run time must
//! satisfy, each failure a message naming the item and element: every
//! family reference inside the family it names, a direction not zero at
//! any element, joints between distinct bodies, unique names.

use proc_macro2::TokenStream;
use quote::quote;

use super::info::{element_name, item_name};
use super::layout::{affine_tokens, body_index, each_element, layout_prelude, point_body};
use super::lower::{Coords, lower};
use super::runtime;
use ezy_lang::ast::{Affine, ModelDef};
use ezy_lang::check::{PointRef, Resolved};
use ezy_lang::kinematics::{Derived, Kind};
use ezy_lang::sym::Sym;

/// `fn check_counts(&self)`: every family reference stays inside the
/// family it names, joints join distinct bodies, and names are unique.
pub(super) fn check_fn(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let private = runtime();
    let prelude = layout_prelude(def);
    let mut body = TokenStream::new();
    for c in &def.counts {
        let n = &c.name;
        let msg = format!("count `{}` is 0; it must be at least 1", c.name);
        body.extend(quote!(if self.#n < 1 { return ::core::result::Result::Err(::std::string::String::from(#msg)); }));
    }
    if !def.counts.is_empty() {
        let pairs = def.counts.iter().map(|c| {
            let (n, s) = (&c.name, c.name.to_string());
            quote!((#s, self.#n))
        });
        body.extend(quote!(#private::check_model_size(l.nq, &[#(#pairs),*])?;));
    }
    // does element `value` of family `f` exist? else an error naming `what`
    let in_range = |f: usize, index: &Affine, var: &str, owner: TokenStream, what: String| -> TokenStream {
        let a = affine_tokens(index);
        let shown = index.show(var);
        let fam = &def.families[f];
        let range = format!("{}..{}", fam.start.show(""), fam.end.show(""));
        quote! {
            let value: i64 = #a;
            if value < l.f_start[#f] || value >= l.f_start[#f] + l.f_len[#f] as i64 {
                return ::core::result::Result::Err(::std::format!(
                    "{} refers to {}[{}] = {}{}, which does not exist: {} has elements {}..{} ({})",
                    #owner, #what, #shown, #what, value, #what, l.f_start[#f], l.f_start[#f] + l.f_len[#f] as i64, #range
                ));
            }
        }
    };
    for (pi, p) in def.points.iter().enumerate() {
        let b = res.point_body[pi];
        let Some(fb) = def.bodies[b].family else { continue };
        let var = p.family.map(|f| def.families[f].var.to_string()).unwrap_or_default();
        let owner_name = element_name(&p.name.to_string(), p.family);
        let owner = quote!(::std::format!("point `{}`", #owner_name));
        let (_, index) = point_body(def, res, pi);
        let check = in_range(fb, index.as_ref().expect("family body"), &var, owner, def.bodies[b].name.to_string());
        body.extend(each_element(p.family, check));
    }
    for g in &d.groups {
        let var = g.family.map(|f| def.families[f].var.to_string()).unwrap_or_default();
        let kind = match g.kind {
            Kind::Hinge => "hinge",
            Kind::Slider if !def.sliders[g.item].heading => "slot",
            Kind::Slider => "slider",
            Kind::Drive => "drive",
            Kind::Skate => "skate",
        };
        let owner_name = element_name(&item_name(def, g), g.family);
        let owner = quote!(::std::format!("{} `{}`", #kind, #owner_name));
        let mut checks = TokenStream::new();
        let refs: Vec<&PointRef> = match g.kind {
            Kind::Hinge => {
                let (a, b) = &res.hinge_points[g.item];
                std::iter::once(a).chain(b).collect()
            }
            Kind::Slider => {
                let (a, b) = &res.slider_points[g.item];
                std::iter::once(a).chain(b).collect()
            }
            Kind::Skate => vec![&res.skate_point[g.item]],
            Kind::Drive => Vec::new(),
        };
        for r in refs {
            if let (Some(fp), Some(index)) = (def.points[r.0].family, &r.1) {
                checks.extend(in_range(fp, index, &var, owner.clone(), def.points[r.0].name.to_string()));
            }
        }
        for b in &g.slots {
            if let (Some(fb), Some(index)) = (def.bodies[b.0].family, &b.1) {
                checks.extend(in_range(fb, index, &var, owner.clone(), def.bodies[b.0].name.to_string()));
            }
        }
        // a direction naming the family's index is not zero at any element
        // (one zero at the compile-time numbers is a compile error)
        if let Some([tx, ty]) = g.direction
            && (d.ar.mentions(tx, &|s| matches!(s, Sym::Index(_)))
                || d.ar.mentions(ty, &|s| matches!(s, Sym::Index(_))))
        {
            let (lets, ex) = lower(d, def, &[tx, ty], Coords::Local, &g.indices);
            let (ex, ey) = (&ex[0], &ex[1]);
            let shown = match g.kind {
                Kind::Skate => "blade direction `along",
                _ => "direction `along",
            };
            let (ax, ay) = match g.kind {
                Kind::Skate => (&def.skates[g.item].along[0], &def.skates[g.item].along[1]),
                _ => (&def.sliders[g.item].along[0], &def.sliders[g.item].along[1]),
            };
            let written = format!("{shown} ({}, {})`", quote!(#ax), quote!(#ay));
            checks.extend(quote! {
                #lets
                let (tx, ty): (f64, f64) = (#ex, #ey);
                let n2 = tx * tx + ty * ty;
                if !(n2 > 0.0 && n2.is_finite()) {
                    return ::core::result::Result::Err(::std::format!(
                        "{} has its {} = ({}, {}) at this element and these parameters: not a direction; give one that is not zero at any element",
                        #owner, #written, tx, ty
                    ));
                }
            });
        }
        if g.slots.len() == 2 && g.kind != Kind::Drive {
            let (a, b) = (body_index(def, &g.slots[0]), body_index(def, &g.slots[1]));
            checks.extend(quote! {
                if #a == #b {
                    return ::core::result::Result::Err(::std::format!("{} joins two points of the same body", #owner));
                }
            });
        }
        body.extend(each_element(g.family, checks));
    }
    quote! {
        fn check_counts(&self) -> ::core::result::Result<(), ::std::string::String> {
            type S = f64;
            #prelude
            #body
            let info = <Self as #private::Model>::info(self);
            #private::unique_names(&info)
        }
    }
}
