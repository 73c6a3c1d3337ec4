//! `fn info`: the `ModelInfo` the runtime reads names, indices and the
//! pattern of `G` from (the coordinates, parameters, bodies, points and
//! constraint items, each element named, at the current counts); and the
//! runtime names of items and elements that `check_counts` shares.

use proc_macro2::TokenStream;
use quote::quote;

use super::layout::{body_column, body_index, each_element, layout_prelude, point_body, point_index};
use super::{lit_f64, runtime};
use ezy_lang::ast::{ModelDef, doc_of, split_unit};
use ezy_lang::check::Resolved;
use ezy_lang::kinematics::{Derived, Group, Kind};

/// The runtime name of an item's element: `"J"` or `format!("J{v}")`.
pub(super) fn element_name(name: &str, family: Option<usize>) -> TokenStream {
    match family {
        Some(_) => quote!(::std::format!("{}{}", #name, v)),
        None => quote!(::std::string::String::from(#name)),
    }
}

/// The declared name of a constraint item.
pub(super) fn item_name(def: &ModelDef, g: &Group) -> String {
    match g.kind {
        Kind::Hinge => def.hinges[g.item].name.to_string(),
        Kind::Slider => def.sliders[g.item].name.to_string(),
        Kind::Drive => def.drives[g.item].name.to_string(),
        Kind::Skate => def.skates[g.item].name.to_string(),
    }
}

/// `fn info(&self)`: names, indices and the pattern at the current counts.
pub(super) fn info_fn(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let private = runtime();
    let prelude = layout_prelude(def);
    let model_name = def.name.to_string();
    let model_doc = doc_of(&def.attrs).split(". ").next().unwrap_or("").trim_end_matches('.').to_string();
    let mut params_info: Vec<TokenStream> = def
        .params
        .iter()
        .map(|p| {
            let (doc, unit) = split_unit(&doc_of(&p.attrs));
            let n = p.name.to_string();
            let v = lit_f64(p.value);
            quote!(#private::ParamInfo { name: #n, default: #v, unit: #unit, doc: #doc, count: false })
        })
        .collect();
    params_info.extend(def.counts.iter().map(|c| {
        let (doc, _) = split_unit(&doc_of(&c.attrs));
        let n = c.name.to_string();
        let v = lit_f64(c.value as f64);
        quote!(#private::ParamInfo { name: #n, default: #v, unit: "", doc: #doc, count: true })
    }));
    // a parameter alone (not a family's index variable, not a number)
    let param_of = |e: &syn::Expr| -> TokenStream {
        match e {
            syn::Expr::Path(p) if p.path.get_ident().is_some_and(|id| def.params.iter().any(|q| q.name == *id)) => {
                let n = p.path.get_ident().expect("checked").to_string();
                quote!(::core::option::Option::Some(#n))
            }
            _ => quote!(::core::option::Option::None),
        }
    };
    let mut body = TokenStream::new();
    for (bi, b) in def.bodies.iter().enumerate() {
        let name = element_name(&b.name.to_string(), b.family);
        let cs: Vec<TokenStream> = b.coords.iter().map(|c| element_name(&c.to_string(), b.family)).collect();
        let (mp, ip) = (param_of(&b.mass), param_of(&b.inertia));
        body.extend(each_element(
            b.family,
            quote! {
                let k = l.body_off[#bi] + 3 * e;
                #(coords.push(#cs);)*
                bodies.push(#private::BodyInfo { name: #name, coords: [k, k + 1, k + 2], mass_param: #mp, inertia_param: #ip });
            },
        ));
    }
    for (pi, p) in def.points.iter().enumerate() {
        let name = element_name(&p.name.to_string(), p.family);
        let b = body_index(def, &point_body(def, res, pi));
        body.extend(each_element(p.family, quote!(points.push(#private::PointInfo { name: #name, body: #b });)));
    }
    for (gi, g) in d.groups.iter().enumerate() {
        let iname = item_name(def, g);
        let name = element_name(&iname, g.family);
        let nr = g.rows();
        let slot = |s: usize| g.slots.get(s).map(|b| body_index(def, b));
        let item = match g.kind {
            Kind::Hinge => {
                let a = slot(0).expect("a hinge has a body");
                let b = match slot(1) {
                    Some(b) => quote!(::core::option::Option::Some(#b)),
                    None => quote!(::core::option::Option::None),
                };
                let p = point_index(def, &res.hinge_points[g.item].0);
                quote!(hinges.push(#private::HingeInfo { name: #name, body_a: #a, body_b: #b, row: rb, point: #p });)
            }
            Kind::Slider => {
                let b = slot(0).expect("a slider has a body");
                let a = match slot(1) {
                    Some(a) => quote!(::core::option::Option::Some(#a)),
                    None => quote!(::core::option::Option::None),
                };
                let heading = def.sliders[g.item].heading;
                quote!(sliders.push(#private::SliderInfo { name: #name, body_a: #a, body_b: #b, row: rb, heading: #heading });)
            }
            Kind::Drive => {
                let h = res.drive_hinge[g.item];
                let hg = d.groups.iter().position(|x| x.kind == Kind::Hinge && x.item == h).expect("hinge group");
                // element e of a family drive drives element e of its hinge family
                quote!(drives.push(#private::DriveInfo { name: #name, hinge: l.item_index[#hg] + e, row: rb });)
            }
            Kind::Skate => {
                let p = point_index(def, &res.skate_point[g.item]);
                quote!(skates.push(#private::SkateInfo { name: #name, point: #p, row: rb });)
            }
        };
        let suffixes = &g.suffixes;
        let cols: Vec<TokenStream> = g.slots.iter().map(|b| body_column(def, b)).collect();
        let ns = cols.len();
        let entries = g.local_pattern(&d.ar).into_iter().map(|(r, c)| {
            let (s, o) = (c / 3, c % 3);
            quote!(pattern.push((rb + #r, cols[#s] + #o));)
        });
        body.extend(each_element(
            g.family,
            quote! {
                let rb = l.row[#gi] + e * #nr;
                let cols: [usize; #ns] = [#(#cols),*];
                #item
                let base = #name;
                #(constraints.push(::std::format!("{}{}", base, #suffixes));)*
                #(#entries)*
            },
        ));
    }
    quote! {
        fn info(&self) -> #private::ModelInfo {
            #prelude
            let mut coords = ::std::vec::Vec::with_capacity(l.nq);
            let mut bodies = ::std::vec::Vec::with_capacity(l.n_bodies);
            let mut points = ::std::vec::Vec::with_capacity(l.n_points);
            let mut hinges = ::std::vec::Vec::new();
            let mut sliders = ::std::vec::Vec::new();
            let mut drives = ::std::vec::Vec::new();
            let mut skates = ::std::vec::Vec::new();
            let mut constraints = ::std::vec::Vec::with_capacity(l.nc);
            let mut pattern = ::std::vec::Vec::with_capacity(l.nnz);
            #body
            #private::ModelInfo {
                name: #model_name,
                doc: #model_doc,
                coords,
                params: ::std::vec![#(#params_info),*],
                bodies,
                points,
                hinges,
                sliders,
                drives,
                skates,
                constraints,
                n_holonomic: l.nh,
                pattern,
            }
        }
    }
}
