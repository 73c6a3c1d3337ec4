//! `impl Parse` for the model language.
//!
//! Grammar (`?` optional, `*` repeated; doc comments allowed before the
//! model and before every item):
//!
//! ```text
//! model  := VIS? "struct" NAME "{" item* "}"
//! item   := "param" NAME "=" NUMBER ";"
//!         | "body" NAME "(" X "," Y "," PHI ")" "{" "mass" ":" EXPR "," "inertia" ":" EXPR ","? "}"
//!         | "point" NAME "on" BODY "at" "(" EXPR "," EXPR ")" ";"
//!         | "hinge" NAME ":" POINT "=" ( POINT | "ground" "(" EXPR "," EXPR ")" ) ";"
//!         | "skate" NAME ":" POINT "along" "(" EXPR "," EXPR ")" ";"
//! EXPR   := numbers, parameter names, + - * /, parentheses, sqrt/sin/cos(...)
//! ```

use syn::parse::{Parse, ParseStream};
use syn::punctuated::Punctuated;
use syn::spanned::Spanned;
use syn::{Attribute, Expr, Ident, Token, braced, parenthesized};

use crate::ast::{Body, Drive, Hinge, HingeTarget, ModelDef, Param, Point, Skate, Slider};

mod kw {
    syn::custom_keyword!(param);
    syn::custom_keyword!(body);
    syn::custom_keyword!(point);
    syn::custom_keyword!(hinge);
    syn::custom_keyword!(skate);
    syn::custom_keyword!(slider);
    syn::custom_keyword!(angle);
    syn::custom_keyword!(drive);
    syn::custom_keyword!(on);
    syn::custom_keyword!(at);
    syn::custom_keyword!(along);
    syn::custom_keyword!(ground);
    syn::custom_keyword!(mass);
    syn::custom_keyword!(inertia);
}

impl Parse for ModelDef {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let attrs = input.call(Attribute::parse_outer)?;
        let vis = input.parse()?;
        input.parse::<Token![struct]>()?;
        let name: Ident = input.parse()?;
        let content;
        braced!(content in input);
        let mut def = ModelDef {
            attrs,
            vis,
            name,
            params: Vec::new(),
            bodies: Vec::new(),
            points: Vec::new(),
            hinges: Vec::new(),
            sliders: Vec::new(),
            drives: Vec::new(),
            skates: Vec::new(),
        };
        while !content.is_empty() {
            let item_attrs = content.call(Attribute::parse_outer)?;
            let look = content.lookahead1();
            if look.peek(kw::param) {
                content.parse::<kw::param>()?;
                let name = content.parse()?;
                content.parse::<Token![=]>()?;
                let (value, value_span) = parse_number(&content)?;
                content.parse::<Token![;]>()?;
                def.params.push(Param { attrs: item_attrs, name, value, value_span });
            } else if look.peek(kw::body) {
                content.parse::<kw::body>()?;
                def.bodies.push(parse_body(&content)?);
            } else if look.peek(kw::point) {
                content.parse::<kw::point>()?;
                let name = content.parse()?;
                content.parse::<kw::on>()?;
                let body = content.parse()?;
                content.parse::<kw::at>()?;
                let (at, _) = parse_pair(&content)?;
                content.parse::<Token![;]>()?;
                def.points.push(Point { name, body, at });
            } else if look.peek(kw::hinge) {
                content.parse::<kw::hinge>()?;
                let name = content.parse()?;
                content.parse::<Token![:]>()?;
                let point = content.parse()?;
                content.parse::<Token![=]>()?;
                let target = parse_target(&content)?;
                content.parse::<Token![;]>()?;
                def.hinges.push(Hinge { name, point, target });
            } else if look.peek(kw::slider) {
                content.parse::<kw::slider>()?;
                let name = content.parse()?;
                content.parse::<Token![:]>()?;
                let point = content.parse()?;
                content.parse::<kw::on>()?;
                let target = parse_target(&content)?;
                content.parse::<kw::along>()?;
                let (along, along_span) = parse_pair(&content)?;
                let angle = if content.peek(kw::angle) {
                    content.parse::<kw::angle>()?;
                    Some(content.parse::<Expr>()?)
                } else {
                    None
                };
                content.parse::<Token![;]>()?;
                def.sliders.push(Slider { name, point, target, along, along_span, angle });
            } else if look.peek(kw::drive) {
                content.parse::<kw::drive>()?;
                let name = content.parse()?;
                content.parse::<Token![:]>()?;
                content.parse::<kw::hinge>()?;
                let hinge = content.parse()?;
                content.parse::<Token![;]>()?;
                def.drives.push(Drive { name, hinge });
            } else if look.peek(kw::skate) {
                content.parse::<kw::skate>()?;
                let name = content.parse()?;
                content.parse::<Token![:]>()?;
                let point = content.parse()?;
                content.parse::<kw::along>()?;
                let (along, along_span) = parse_pair(&content)?;
                content.parse::<Token![;]>()?;
                def.skates.push(Skate { name, point, along, along_span });
            } else {
                return Err(look.error());
            }
        }
        Ok(def)
    }
}

fn parse_body(input: ParseStream) -> syn::Result<Body> {
    let name: Ident = input.parse()?;
    let coords_content;
    let paren = parenthesized!(coords_content in input);
    let coords: Punctuated<Ident, Token![,]> = coords_content.parse_terminated(Ident::parse, Token![,])?;
    let coords: Vec<Ident> = coords.into_iter().collect();
    let coords: [Ident; 3] = coords.try_into().map_err(|_| {
        syn::Error::new(paren.span.join(), format!("body `{name}` needs three coordinate names: (x, y, phi)"))
    })?;
    let fields;
    let brace = braced!(fields in input);
    let mut mass = None;
    let mut inertia = None;
    while !fields.is_empty() {
        let look = fields.lookahead1();
        if look.peek(kw::mass) {
            let k = fields.parse::<kw::mass>()?;
            fields.parse::<Token![:]>()?;
            let e: Expr = fields.parse()?;
            if mass.replace(e).is_some() {
                return Err(syn::Error::new(k.span, format!("body `{name}` has `mass` twice")));
            }
        } else if look.peek(kw::inertia) {
            let k = fields.parse::<kw::inertia>()?;
            fields.parse::<Token![:]>()?;
            let e: Expr = fields.parse()?;
            if inertia.replace(e).is_some() {
                return Err(syn::Error::new(k.span, format!("body `{name}` has `inertia` twice")));
            }
        } else {
            return Err(look.error());
        }
        if !fields.is_empty() {
            fields.parse::<Token![,]>()?;
        }
    }
    let missing = |what: &str| syn::Error::new(brace.span.join(), format!("body `{name}` is missing `{what}: ...`"));
    let mass = mass.ok_or_else(|| missing("mass"))?;
    let inertia = inertia.ok_or_else(|| missing("inertia"))?;
    Ok(Body { name, coords, mass, inertia })
}

/// `Q` (a point) or `ground(EXPR, EXPR)`.
fn parse_target(input: ParseStream) -> syn::Result<HingeTarget> {
    if input.peek(kw::ground) {
        input.parse::<kw::ground>()?;
        let (at, _) = parse_pair(input)?;
        Ok(HingeTarget::Ground { at: Box::new(at) })
    } else {
        Ok(HingeTarget::Point(input.parse()?))
    }
}

/// `( EXPR , EXPR )`
fn parse_pair(input: ParseStream) -> syn::Result<([Expr; 2], proc_macro2::Span)> {
    let content;
    let paren = parenthesized!(content in input);
    let items: Punctuated<Expr, Token![,]> = content.parse_terminated(Expr::parse, Token![,])?;
    let span = paren.span.join();
    let items: Vec<Expr> = items.into_iter().collect();
    let pair: [Expr; 2] = items.try_into().map_err(|_| syn::Error::new(span, "expected two coordinates: (x, y)"))?;
    Ok((pair, span))
}

/// A numeric literal with an optional leading minus.
fn parse_number(input: ParseStream) -> syn::Result<(f64, proc_macro2::Span)> {
    let e: Expr = input.parse()?;
    let span = e.span();
    literal_value(&e).map(|v| (v, span)).ok_or_else(|| syn::Error::new(span, "a parameter's value must be a number"))
}

/// The value of a numeric literal expression (`1`, `0.5`, `-2e3`).
pub fn literal_value(e: &Expr) -> Option<f64> {
    match e {
        Expr::Lit(syn::ExprLit { lit: syn::Lit::Float(f), .. }) => f.base10_parse().ok(),
        Expr::Lit(syn::ExprLit { lit: syn::Lit::Int(i), .. }) => i.base10_parse::<f64>().ok(),
        Expr::Unary(syn::ExprUnary { op: syn::UnOp::Neg(_), expr, .. }) => literal_value(expr).map(|v| -v),
        Expr::Paren(p) => literal_value(&p.expr),
        Expr::Group(g) => literal_value(&g.expr),
        _ => None,
    }
}
