//! What the model says about itself: its [`Description`] (ezy-lang's,
//! the one a model read from text builds) written as a `static` literal
//! (`__ezy_description`), and `info`, `check_counts` and `equations` as
//! calls that render it at the current counts (ezy-core's
//! `model::describe`). The only generated code of its own is the one
//! thing the runtime cannot do from data: a direction that names the
//! family's index, evaluated at an element for `check_counts`.

use proc_macro2::TokenStream;
use quote::quote;

use super::layout::count_lets;
use super::lower::{Coords, lower};
use super::{lit_f64, runtime};
use ezy_lang::ast::ModelDef;
use ezy_lang::description::{
    Body, BodyAt, DerivedParam, Description, Family, Group, Item, Ix, Param, Point, PointAt, Template, describe,
};
use ezy_lang::kinematics::Derived;

/// `__ezy_description` (for the inherent impl) and `info`,
/// `check_counts` and `equations` (for the `Model` impl).
pub(super) fn description_fns(
    def: &ModelDef,
    res: &ezy_lang::check::Resolved,
    d: &Derived,
) -> (TokenStream, TokenStream) {
    let private = runtime();
    let desc = describe(def, res, d);
    let literal = Lit(&private).description(&desc);
    let lets = count_lets(def);
    let counts: Vec<proc_macro2::Ident> = def.counts.iter().map(|c| quote::format_ident!("c_{}", c.name)).collect();
    let counts = quote!(&[#(#counts),*]);
    let mut directions = TokenStream::new();
    for (gi, g) in d.groups.iter().enumerate() {
        if desc.groups[gi].direction.is_none() {
            continue;
        }
        let [tx, ty] = g.direction.expect("a checked direction is written");
        let (lets, ex) = lower(d, def, &[tx, ty], Coords::Local, &g.indices);
        let (ex, ey) = (&ex[0], &ex[1]);
        directions.extend(quote!(#gi => { #lets [#ex, #ey] }));
    }
    let inherent = quote! {
        /// What the model says about itself (names, layout, checks,
        /// equations), rendered by the runtime at the counts.
        #[doc(hidden)]
        pub fn __ezy_description() -> &'static #private::describe::Description {
            static DESCRIPTION: #private::describe::Description = #literal;
            &DESCRIPTION
        }
    };
    let model = quote! {
        fn info(&self) -> #private::ModelInfo {
            #lets
            #private::describe::info(Self::__ezy_description(), #counts)
        }

        fn equations(&self) -> #private::Equations {
            #lets
            #private::describe::equations(Self::__ezy_description(), #counts)
        }

        fn check_counts(&self) -> ::core::result::Result<(), ::std::string::String> {
            type S = f64;
            #lets
            #private::describe::check_counts(Self::__ezy_description(), #counts, &mut |gi: usize, v: i64| -> [f64; 2] {
                match gi {
                    #directions
                    _ => ::core::unreachable!("group {} has no direction to check", gi),
                }
            })
        }
    };
    (inherent, model)
}

/// A [`Description`] as a constant expression: every text and list
/// borrowed (`Cow::Borrowed`), each type named through `PATH::describe`.
/// Each value is taken apart field by field, so that a field added to
/// the description is a compile error here until it is written.
struct Lit<'a>(&'a TokenStream);

fn text(s: &str) -> TokenStream {
    quote!(::std::borrow::Cow::Borrowed(#s))
}

fn list(items: impl IntoIterator<Item = TokenStream>) -> TokenStream {
    let items = items.into_iter();
    quote!(::std::borrow::Cow::Borrowed(&[#(#items),*]))
}

fn option(x: Option<TokenStream>) -> TokenStream {
    match x {
        Some(x) => quote!(::core::option::Option::Some(#x)),
        None => quote!(::core::option::Option::None),
    }
}

impl Lit<'_> {
    fn description(&self, d: &Description) -> TokenStream {
        let p = self.0;
        let Description { name, doc, params, derived, families, bodies, points, groups, own } = d;
        let (name, doc) = (text(name), text(doc));
        let params = list(params.iter().map(|x| self.param(x)));
        let derived = list(derived.iter().map(|x| self.derived(x)));
        let families = list(families.iter().map(|x| self.family(x)));
        let bodies = list(bodies.iter().map(|x| self.body(x)));
        let points = list(points.iter().map(|x| self.point(x)));
        let groups = list(groups.iter().map(|x| self.group(x)));
        let own = self.ix(own);
        quote!(#p::describe::Description { name: #name, doc: #doc, params: #params, derived: #derived, families: #families, bodies: #bodies, points: #points, groups: #groups, own: #own })
    }

    fn ix(&self, x: &Ix) -> TokenStream {
        let p = self.0;
        let Ix { var, count, c, shown } = x;
        let (count, shown) = (option(count.map(|k| quote!(#k))), text(shown));
        quote!(#p::describe::Ix { var: #var, count: #count, c: #c, shown: #shown })
    }

    fn body_at(&self, x: &BodyAt) -> TokenStream {
        let p = self.0;
        let BodyAt { item, index } = x;
        let index = option(index.as_ref().map(|i| self.ix(i)));
        quote!(#p::describe::BodyAt { item: #item, index: #index })
    }

    fn point_at(&self, x: &PointAt) -> TokenStream {
        let p = self.0;
        let PointAt { item, index } = x;
        let index = option(index.as_ref().map(|i| self.ix(i)));
        quote!(#p::describe::PointAt { item: #item, index: #index })
    }

    fn family(&self, x: &Family) -> TokenStream {
        let p = self.0;
        let Family { start, end, range } = x;
        let (start, end, range) = (self.ix(start), self.ix(end), text(range));
        quote!(#p::describe::Family { start: #start, end: #end, range: #range })
    }

    fn param(&self, x: &Param) -> TokenStream {
        let p = self.0;
        let Param { name, default, unit, doc, count } = x;
        let (name, default, unit, doc) = (text(name), lit_f64(*default), text(unit), text(doc));
        quote!(#p::describe::Param { name: #name, default: #default, unit: #unit, doc: #doc, count: #count })
    }

    fn derived(&self, x: &DerivedParam) -> TokenStream {
        let p = self.0;
        let DerivedParam { name, formula, unit, doc } = x;
        let (name, formula, unit, doc) = (text(name), text(formula), text(unit), text(doc));
        quote!(#p::describe::DerivedParam { name: #name, formula: #formula, unit: #unit, doc: #doc })
    }

    fn template(&self, x: &Template) -> TokenStream {
        let p = self.0;
        let Template { text: t, latex, named, at } = x;
        let (t, latex) = (text(t), text(latex));
        let named = list(named.iter().map(|k| quote!(#k)));
        let at = list(at.iter().map(|(a, b)| {
            let (a, b) = (text(a), text(b));
            quote!((#a, #b))
        }));
        quote!(#p::describe::Template { text: #t, latex: #latex, named: #named, at: #at })
    }

    fn templates(&self, xs: &[Template]) -> TokenStream {
        list(xs.iter().map(|x| self.template(x)))
    }

    fn body(&self, x: &Body) -> TokenStream {
        let p = self.0;
        let Body { name, family, coords, mass_param, inertia_param, mass } = x;
        let name = text(name);
        let family = option(family.map(|f| quote!(#f)));
        let coords = coords.iter().map(|c| text(c));
        let (mass_param, inertia_param) =
            (option(mass_param.as_deref().map(text)), option(inertia_param.as_deref().map(text)));
        let mass = self.templates(mass);
        quote!(#p::describe::Body { name: #name, family: #family, coords: [#(#coords),*], mass_param: #mass_param, inertia_param: #inertia_param, mass: #mass })
    }

    fn point(&self, x: &Point) -> TokenStream {
        let p = self.0;
        let Point { name, family, body, velocity } = x;
        let name = text(name);
        let family = option(family.map(|f| quote!(#f)));
        let (body, velocity) = (self.body_at(body), self.templates(velocity));
        quote!(#p::describe::Point { name: #name, family: #family, body: #body, velocity: #velocity })
    }

    fn item(&self, x: &Item) -> TokenStream {
        let p = self.0;
        let other = |o: &Option<PointAt>| option(o.as_ref().map(|o| self.point_at(o)));
        match x {
            Item::Hinge { point, other: o } => {
                let (point, o) = (self.point_at(point), other(o));
                quote!(#p::describe::Item::Hinge { point: #point, other: #o })
            }
            Item::Slider { heading, point, other: o } => {
                let (point, o) = (self.point_at(point), other(o));
                quote!(#p::describe::Item::Slider { heading: #heading, point: #point, other: #o })
            }
            Item::Drive { hinge_group } => quote!(#p::describe::Item::Drive { hinge_group: #hinge_group }),
            Item::Skate { point } => {
                let point = self.point_at(point);
                quote!(#p::describe::Item::Skate { point: #point })
            }
        }
    }

    fn group(&self, x: &Group) -> TokenStream {
        let p = self.0;
        let Group {
            item,
            name,
            family,
            slots,
            indices,
            rows,
            pattern,
            suffixes,
            direction,
            phi,
            velocity,
            jacobian,
            gamma,
        } = x;
        let (item, name) = (self.item(item), text(name));
        let family = option(family.map(|f| quote!(#f)));
        let slots = list(slots.iter().map(|b| self.body_at(b)));
        let indices = list(indices.iter().map(|i| self.ix(i)));
        let pattern = list(pattern.iter().map(|(r, c)| quote!((#r, #c))));
        let suffixes = list(suffixes.iter().map(|s| quote!(#s)));
        let direction = option(direction.as_deref().map(text));
        let (phi, velocity, jacobian, gamma) =
            (self.templates(phi), self.templates(velocity), self.templates(jacobian), self.templates(gamma));
        quote!(#p::describe::Group {
            item: #item, name: #name, family: #family, slots: #slots, indices: #indices, rows: #rows,
            pattern: #pattern, suffixes: #suffixes, direction: #direction,
            phi: #phi, velocity: #velocity, jacobian: #jacobian, gamma: #gamma,
        })
    }
}
