//! `impl Parse` for the model language.
//!
//! Grammar (`?` optional, `*` repeated; doc comments allowed before the
//! model and before every item):
//!
//! ```text
//! model  := VIS? "struct" NAME "{" (item | family)* "}"
//! family := "for" VAR "in" BOUND ".." BOUND "{" item* "}"   (items named NAME[VAR])
//! BOUND  := INTEGER | COUNT | COUNT ("+" | "-") INTEGER
//! REF    := NAME | NAME "[" INDEX "]"   (INDEX: VAR, COUNT, INTEGER, +- INTEGER)
//! item   := "count" NAME "=" INTEGER ";"
//!         | "param" NAME "=" NUMBER ";"
//!         | "body" NAME "(" X "," Y "," PHI ")" "{" "mass" ":" EXPR "," "inertia" ":" EXPR ","? "}"
//!         | "point" NAME "on" REF "at" "(" EXPR "," EXPR ")" ";"
//!         | "hinge" NAME ":" REF "=" ( REF | "ground" "(" EXPR "," EXPR ")" ) ";"
//!         | "slider" NAME ":" REF "on" ( REF | "ground" "(" EXPR "," EXPR ")" ) "along" "(" EXPR "," EXPR ")" ("angle" EXPR)? ";"
//!         | "slot" NAME ":" REF "on" ( REF | "ground" "(" EXPR "," EXPR ")" ) "along" "(" EXPR "," EXPR ")" ";"
//!         | "drive" NAME ":" "hinge" REF ";"   (in a family: drive D[i]: hinge J[i];)
//!         | "skate" NAME ":" REF "along" "(" EXPR "," EXPR ")" ";"
//! EXPR   := numbers, parameter names, + - * /, parentheses, sqrt/sin/cos(...),
//!           and in a family's items its VAR (the element's index, a real number)
//! ```

use syn::parse::{Parse, ParseStream};
use syn::punctuated::Punctuated;
use syn::spanned::Spanned;
use syn::{Attribute, BinOp, Expr, Ident, Token, braced, bracketed, parenthesized};

use crate::ast::{
    Affine, Body, Count, DerivedParam, Drive, Family, Hinge, HingeTarget, ModelDef, Param, Point, Ref, Skate, Slider,
};

mod kw {
    syn::custom_keyword!(param);
    syn::custom_keyword!(count);
    syn::custom_keyword!(body);
    syn::custom_keyword!(point);
    syn::custom_keyword!(hinge);
    syn::custom_keyword!(skate);
    syn::custom_keyword!(slider);
    syn::custom_keyword!(slot);
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
            derived: Vec::new(),
            counts: Vec::new(),
            families: Vec::new(),
            bodies: Vec::new(),
            points: Vec::new(),
            hinges: Vec::new(),
            sliders: Vec::new(),
            drives: Vec::new(),
            skates: Vec::new(),
        };
        while !content.is_empty() {
            let item_attrs = content.call(Attribute::parse_outer)?;
            if content.peek(Token![for]) {
                content.parse::<Token![for]>()?;
                let var: Ident = content.parse()?;
                content.parse::<Token![in]>()?;
                let range = Expr::parse_without_eager_brace(&content)?;
                let Expr::Range(r) = &range else {
                    return Err(syn::Error::new(range.span(), "expected a range `START..END`"));
                };
                if !matches!(r.limits, syn::RangeLimits::HalfOpen(_)) {
                    return Err(syn::Error::new(range.span(), "use a half-open range `START..END`"));
                }
                let bound = |e: &Option<Box<Expr>>| -> syn::Result<Affine> {
                    let e =
                        e.as_ref().ok_or_else(|| syn::Error::new(range.span(), "a family range needs both bounds"))?;
                    affine(e, None)
                };
                let (start, end) = (bound(&r.start)?, bound(&r.end)?);
                let items;
                braced!(items in content);
                let family = def.families.len();
                def.families.push(Family { var, start, end });
                while !items.is_empty() {
                    let attrs = items.call(Attribute::parse_outer)?;
                    parse_item(&items, attrs, &mut def, Some(family))?;
                }
            } else {
                parse_item(&content, item_attrs, &mut def, None)?;
            }
        }
        Ok(def)
    }
}

/// One item; `family` is the enclosing `for` (its items are named `NAME[VAR]`).
fn parse_item(
    content: ParseStream,
    item_attrs: Vec<Attribute>,
    def: &mut ModelDef,
    family: Option<usize>,
) -> syn::Result<()> {
    let var = family.map(|f| def.families[f].var.clone());
    let var = var.as_ref();
    let look = content.lookahead1();
    let not_in_family = |what: &str, span: proc_macro2::Span| -> syn::Result<()> {
        match family {
            Some(_) => {
                Err(syn::Error::new(span, format!("`{what}` cannot be inside a `for` family; declare it outside")))
            }
            None => Ok(()),
        }
    };
    if look.peek(kw::param) {
        let k = content.parse::<kw::param>()?;
        not_in_family("param", k.span)?;
        let name = content.parse()?;
        content.parse::<Token![=]>()?;
        let expr: Expr = content.parse()?;
        content.parse::<Token![;]>()?;
        // a number is a parameter a scene may set; any other expression
        // defines this one by others
        match literal_value(&expr) {
            Some(value) => def.params.push(Param { attrs: item_attrs, name, value, value_span: expr.span() }),
            None => def.derived.push(DerivedParam { attrs: item_attrs, name, expr }),
        }
    } else if look.peek(kw::count) {
        let k = content.parse::<kw::count>()?;
        not_in_family("count", k.span)?;
        let name = content.parse()?;
        content.parse::<Token![=]>()?;
        let lit: syn::LitInt = content.parse().map_err(|e| {
            syn::Error::new(e.span(), "a count's value must be a whole number >= 1 (the default number of elements)")
        })?;
        let value: i64 = lit.base10_parse()?;
        if !(1..=crate::MAX_COUNT).contains(&value) {
            return Err(syn::Error::new(
                lit.span(),
                format!("a count's value must be a whole number from 1 to {}", crate::MAX_COUNT),
            ));
        }
        content.parse::<Token![;]>()?;
        def.counts.push(Count { attrs: item_attrs, name, value });
    } else if look.peek(kw::body) {
        content.parse::<kw::body>()?;
        def.bodies.push(parse_body(content, var, family)?);
    } else if look.peek(kw::point) {
        content.parse::<kw::point>()?;
        let name = item_name(content, var)?;
        content.parse::<kw::on>()?;
        let body = parse_ref(content, var)?;
        content.parse::<kw::at>()?;
        let (at, _) = parse_pair(content)?;
        content.parse::<Token![;]>()?;
        def.points.push(Point { name, family, body, at });
    } else if look.peek(kw::hinge) {
        content.parse::<kw::hinge>()?;
        let name = item_name(content, var)?;
        content.parse::<Token![:]>()?;
        let point = parse_ref(content, var)?;
        content.parse::<Token![=]>()?;
        let target = parse_target(content, var)?;
        content.parse::<Token![;]>()?;
        def.hinges.push(Hinge { name, family, point, target });
    } else if look.peek(kw::slider) || look.peek(kw::slot) {
        // a slot is a slider without its heading row (pin-in-slot)
        let heading = if content.peek(kw::slot) {
            content.parse::<kw::slot>()?;
            false
        } else {
            content.parse::<kw::slider>()?;
            true
        };
        let name = item_name(content, var)?;
        content.parse::<Token![:]>()?;
        let point = parse_ref(content, var)?;
        content.parse::<kw::on>()?;
        let target = parse_target(content, var)?;
        content.parse::<kw::along>()?;
        let (along, along_span) = parse_pair(content)?;
        let angle = if content.peek(kw::angle) {
            let k = content.parse::<kw::angle>()?;
            if !heading {
                return Err(syn::Error::new(
                    k.span,
                    "a slot leaves the heading free, so it has no `angle`; a `slider` keeps the heading",
                ));
            }
            Some(content.parse::<Expr>()?)
        } else {
            None
        };
        content.parse::<Token![;]>()?;
        def.sliders.push(Slider { name, family, point, target, along, along_span, angle, heading });
    } else if look.peek(kw::drive) {
        content.parse::<kw::drive>()?;
        let name = item_name(content, var)?;
        content.parse::<Token![:]>()?;
        content.parse::<kw::hinge>()?;
        let hinge = parse_ref(content, var)?;
        content.parse::<Token![;]>()?;
        def.drives.push(Drive { name, family, hinge });
    } else if look.peek(kw::skate) {
        content.parse::<kw::skate>()?;
        let name = item_name(content, var)?;
        content.parse::<Token![:]>()?;
        let point = parse_ref(content, var)?;
        content.parse::<kw::along>()?;
        let (along, along_span) = parse_pair(content)?;
        content.parse::<Token![;]>()?;
        def.skates.push(Skate { name, family, point, along, along_span });
    } else {
        if family.is_none() {
            let _ = look.peek(Token![for]);
        }
        return Err(look.error());
    }
    Ok(())
}

/// The name of an item: `NAME`, or `NAME[VAR]` inside a family.
fn item_name(input: ParseStream, var: Option<&Ident>) -> syn::Result<Ident> {
    let name: Ident = input.parse()?;
    match var {
        None => {
            if input.peek(syn::token::Bracket) {
                let inner;
                let b = bracketed!(inner in input);
                let _ = inner.parse::<proc_macro2::TokenStream>();
                return Err(syn::Error::new(
                    b.span.join(),
                    format!(
                        "`{name}[..]` names a family element; put the item inside `for VAR in START..END {{ .. }}`"
                    ),
                ));
            }
            Ok(name)
        }
        Some(v) => {
            let err = || syn::Error::new(name.span(), format!("an item inside `for {v} in ..` is named `{name}[{v}]`"));
            if !input.peek(syn::token::Bracket) {
                return Err(err());
            }
            let inner;
            bracketed!(inner in input);
            let i: Ident = inner.parse().map_err(|_| err())?;
            if i != *v || !inner.is_empty() {
                return Err(err());
            }
            Ok(name)
        }
    }
}

/// `NAME` or `NAME[INDEX]`.
fn parse_ref(input: ParseStream, var: Option<&Ident>) -> syn::Result<Ref> {
    let name: Ident = input.parse()?;
    let index = if input.peek(syn::token::Bracket) {
        let inner;
        bracketed!(inner in input);
        let e: Expr = inner.parse()?;
        Some(affine(&e, var)?)
    } else {
        None
    };
    Ok(Ref { name, index })
}

/// An index `VAR`, `COUNT`, an integer, or one of those `+-` an integer.
fn affine(e: &Expr, var: Option<&Ident>) -> syn::Result<Affine> {
    let span = e.span();
    let bad = || {
        let v = var.map_or("".to_string(), |v| format!("`{v}`, `{v} - 1`, "));
        syn::Error::new(span, format!("an index is {v}an integer, a count `N` or `N - 1`"))
    };
    match e {
        Expr::Lit(syn::ExprLit { lit: syn::Lit::Int(i), .. }) => {
            let c: i64 = i.base10_parse()?;
            if c.abs() > crate::MAX_COUNT {
                return Err(syn::Error::new(
                    span,
                    format!("an index's number is at most {} in size", crate::MAX_COUNT),
                ));
            }
            Ok(Affine { var: false, count: None, c, span })
        }
        Expr::Paren(p) => affine(&p.expr, var),
        Expr::Group(g) => affine(&g.expr, var),
        Expr::Path(p) => {
            let id = p.path.get_ident().ok_or_else(bad)?;
            if var == Some(id) {
                Ok(Affine { var: true, count: None, c: 0, span })
            } else {
                Ok(Affine { var: false, count: Some(id.clone()), c: 0, span })
            }
        }
        Expr::Binary(b) if matches!(b.op, BinOp::Add(_) | BinOp::Sub(_)) => {
            // the chain `a + b - c ...` along its left spine, in a loop
            // (its length is not bounded by the text's nesting)
            let mut rights = Vec::new();
            let mut left = e;
            while let Expr::Binary(b) = left {
                if !matches!(b.op, BinOp::Add(_) | BinOp::Sub(_)) {
                    break;
                }
                rights.push((matches!(b.op, BinOp::Sub(_)), &*b.right));
                left = &b.left;
            }
            let mut l = affine(left, var)?;
            for (neg, r) in rights.into_iter().rev() {
                let r = affine(r, var)?;
                if neg && (r.var || r.count.is_some()) {
                    return Err(bad());
                }
                let count = match (l.count, r.count) {
                    (Some(_), Some(_)) => return Err(bad()),
                    (a, b) => a.or(b),
                };
                if l.var && r.var {
                    return Err(bad());
                }
                let c = if neg { l.c.checked_sub(r.c) } else { l.c.checked_add(r.c) };
                l = Affine { var: l.var || r.var, count, c: c.ok_or_else(bad)?, span };
            }
            Ok(l)
        }
        _ => Err(bad()),
    }
}

fn parse_body(input: ParseStream, var: Option<&Ident>, family: Option<usize>) -> syn::Result<Body> {
    let name: Ident = item_name(input, var)?;
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
    Ok(Body { name, family, coords, mass, inertia })
}

/// `Q` (a point) or `ground(EXPR, EXPR)`.
fn parse_target(input: ParseStream, var: Option<&Ident>) -> syn::Result<HingeTarget> {
    if input.peek(kw::ground) {
        input.parse::<kw::ground>()?;
        let (at, _) = parse_pair(input)?;
        Ok(HingeTarget::Ground { at: Box::new(at) })
    } else {
        Ok(HingeTarget::Point(parse_ref(input, var)?))
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
