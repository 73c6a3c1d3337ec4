//! The typed model, with the user's tokens kept for error spans.

use proc_macro2::Span;
use syn::{Attribute, Expr, Ident, Visibility};

/// A whole `model!` invocation.
pub struct ModelDef {
    pub attrs: Vec<Attribute>,
    pub vis: Visibility,
    pub name: Ident,
    pub params: Vec<Param>,
    pub derived: Vec<DerivedParam>,
    pub counts: Vec<Count>,
    pub families: Vec<Family>,
    pub bodies: Vec<Body>,
    pub points: Vec<Point>,
    pub hinges: Vec<Hinge>,
    pub sliders: Vec<Slider>,
    pub drives: Vec<Drive>,
    pub skates: Vec<Skate>,
}

/// `param NAME = VALUE;`
pub struct Param {
    pub attrs: Vec<Attribute>,
    pub name: Ident,
    pub value: f64,
    pub value_span: Span,
}

/// `param NAME = EXPR;` whose value is an expression of other
/// parameters (`param I = m * r * r;`): not a parameter of its own (a
/// scene cannot set it), but its expression, put in wherever the model
/// names it, so that it follows the parameters it is made of (and their
/// derivatives). Parameters so defined may name one another in any order,
/// but not in a cycle.
pub struct DerivedParam {
    pub attrs: Vec<Attribute>,
    pub name: Ident,
    pub expr: Expr,
}

/// `count NAME = INTEGER;`: the size of `for` families, a runtime
/// parameter (a whole number >= 1).
pub struct Count {
    pub attrs: Vec<Attribute>,
    pub name: Ident,
    pub value: i64,
}

/// An integer index expression `var? + count? + c`: `i`, `i - 1`, `0`,
/// `N - 1`, `N + 1` (a loop variable or a count, plus a constant).
#[derive(Clone)]
pub struct Affine {
    /// Whether the loop variable of the enclosing `for` appears.
    pub var: bool,
    /// A count, by name.
    pub count: Option<Ident>,
    pub c: i64,
    pub span: Span,
}

impl Affine {
    /// Same index (spans aside).
    pub fn same(&self, other: &Affine) -> bool {
        self.var == other.var
            && self.c == other.c
            && self.count.as_ref().map(|c| c.to_string()) == other.count.as_ref().map(|c| c.to_string())
    }
    /// As written: `i - 1`, `N`, `0`.
    pub fn show(&self, var: &str) -> String {
        let mut parts = Vec::new();
        if self.var {
            parts.push(var.to_string());
        }
        if let Some(n) = &self.count {
            parts.push(n.to_string());
        }
        let mut s = parts.join(" + ");
        if s.is_empty() {
            s = self.c.to_string();
        } else if self.c > 0 {
            s.push_str(&format!(" + {}", self.c));
        } else if self.c < 0 {
            s.push_str(&format!(" - {}", -self.c));
        }
        s
    }
}

/// `for VAR in START..END { items }`: the items inside are families, one
/// element per value of `VAR` (bounds: integers or `COUNT +- integer`).
pub struct Family {
    pub var: Ident,
    pub start: Affine,
    pub end: Affine,
}

/// A reference to an item: `NAME` or `NAME[INDEX]` (an element of a family).
pub struct Ref {
    pub name: Ident,
    pub index: Option<Affine>,
}

/// `body NAME(x, y, phi) { mass: EXPR, inertia: EXPR }`
pub struct Body {
    pub name: Ident,
    /// The `for` family (index into [`ModelDef::families`]) it belongs to.
    pub family: Option<usize>,
    pub coords: [Ident; 3],
    pub mass: Expr,
    pub inertia: Expr,
}

/// `point NAME on BODY at (X, Y);`
pub struct Point {
    pub name: Ident,
    pub family: Option<usize>,
    pub body: Ref,
    pub at: [Expr; 2],
}

/// The second side of a hinge.
pub enum HingeTarget {
    /// Another named point.
    Point(Ref),
    /// A fixed point of the ground, in world coordinates \[m\].
    Ground { at: Box<[Expr; 2]> },
}

/// `hinge NAME: P = Q;` or `hinge NAME: P = ground(X, Y);`
pub struct Hinge {
    pub name: Ident,
    pub family: Option<usize>,
    pub point: Ref,
    pub target: HingeTarget,
}

/// `slider NAME: P on Q along (DX, DY) [angle EXPR];` or
/// `slider NAME: P on ground(X, Y) along (DX, DY) [angle EXPR];`: a
/// prismatic joint. Point `P` (of the moving body) stays on the line
/// through `Q` (of the guiding body, or a ground point) along `(DX, DY)`
/// (in the guiding body's frame, or the world's), and the moving body's
/// heading stays at `angle` (default 0) from the guiding body's.
pub struct Slider {
    pub name: Ident,
    pub family: Option<usize>,
    pub point: Ref,
    pub target: HingeTarget,
    pub along: [Expr; 2],
    pub along_span: Span,
    pub angle: Option<Expr>,
    /// `false` for a pin-in-slot joint (`slot NAME: P on Q along (DX,
    /// DY);`): the point stays on the line, the heading is free (one row).
    pub heading: bool,
}

/// `drive NAME: hinge H;`: the hinge's angle `phi_a - phi_b` follows a
/// function of time given by the scene (a rheonomic constraint). In a
/// family, `drive D[i]: hinge J[i];` drives every element of the hinge
/// family `J` (same range).
pub struct Drive {
    pub name: Ident,
    pub family: Option<usize>,
    pub hinge: Ref,
}

/// `skate NAME: P along (DX, DY);`
pub struct Skate {
    pub name: Ident,
    pub family: Option<usize>,
    pub point: Ref,
    pub along: [Expr; 2],
    pub along_span: Span,
}

/// Concatenated doc comment lines of `attrs`.
pub fn doc_of(attrs: &[Attribute]) -> String {
    let mut lines = Vec::new();
    for attr in attrs {
        if !attr.path().is_ident("doc") {
            continue;
        }
        if let syn::Meta::NameValue(nv) = &attr.meta
            && let Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) = &nv.value
        {
            lines.push(s.value().trim().to_string());
        }
    }
    lines.join(" ").trim().to_string()
}

/// Splits a trailing `[unit]` off a doc string: `("Distance", "m")`. A
/// unit the user already escaped for rustdoc, `\[m\]`, is read the same.
pub fn split_unit(doc: &str) -> (String, String) {
    let t = doc.trim_end();
    let (head, open) = match t.strip_suffix("\\]") {
        Some(head) => (head, "\\["),
        None => match t.strip_suffix(']') {
            Some(head) => (head, "["),
            None => return (t.to_string(), String::new()),
        },
    };
    match head.rfind(open) {
        Some(i) => (head[..i].trim_end().to_string(), head[i + open.len()..].trim().to_string()),
        None => (t.to_string(), String::new()),
    }
}

/// `attrs` with the trailing `[unit]` of the doc comment (the one
/// [`split_unit`] reads) written `\[unit\]` for the generated field, so
/// that rustdoc shows it as text instead of taking it for an intra-doc
/// link: `[kg]` would make a user's `cargo doc` warn "unresolved link to
/// `kg`". Other attributes, other brackets and units already escaped are
/// left as they are.
pub fn escape_unit(attrs: &[Attribute]) -> Vec<Attribute> {
    let mut out = attrs.to_vec();
    // (index in `out`, the line's text) of every `#[doc = "..."]` line
    let lines: Vec<(usize, syn::LitStr)> = out
        .iter()
        .enumerate()
        .filter_map(|(k, attr)| match &attr.meta {
            syn::Meta::NameValue(nv) if attr.path().is_ident("doc") => match &nv.value {
                Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) => Some((k, s.clone())),
                _ => None,
            },
            _ => None,
        })
        .collect();
    let Some(last) = lines.iter().rposition(|(_, s)| !s.value().trim().is_empty()) else {
        return out;
    };
    let text = lines[last].1.value();
    let end = text.trim_end().len();
    if !text[..end].ends_with(']') || text[..end].ends_with("\\]") {
        return out;
    }
    // The opening bracket: the last `[` before the closing one, on this line
    // or an earlier one (as `split_unit` reads the joined lines).
    let mut new: Vec<(usize, String)> = vec![(last, format!("{}\\]{}", &text[..end - 1], &text[end..]))];
    let open = match text[..end - 1].rfind('[') {
        Some(i) => Some((last, i)),
        None => lines[..last].iter().enumerate().rev().find_map(|(j, (_, s))| s.value().rfind('[').map(|i| (j, i))),
    };
    let Some((j, i)) = open else {
        return out;
    };
    let line = if j == last { new.pop().expect("the closing line").1 } else { lines[j].1.value() };
    new.push((j, format!("{}\\{}", &line[..i], &line[i..])));
    for (j, value) in new {
        let (k, lit) = &lines[j];
        let lit = syn::LitStr::new(&value, lit.span());
        if let syn::Meta::NameValue(nv) = &mut out[*k].meta {
            nv.value = syn::parse_quote!(#lit);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn docs(attrs: &[Attribute]) -> Vec<String> {
        attrs
            .iter()
            .filter_map(|a| match &a.meta {
                syn::Meta::NameValue(nv) => match &nv.value {
                    Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) => Some(s.value()),
                    _ => None,
                },
                _ => None,
            })
            .collect()
    }

    #[test]
    fn split_unit_reads_plain_and_escaped_units() {
        assert_eq!(split_unit("Mass of body 1 [kg]"), ("Mass of body 1".into(), "kg".into()));
        assert_eq!(split_unit("Inertia \\[kg m^2\\] "), ("Inertia".into(), "kg m^2".into()));
        assert_eq!(split_unit("Number of links"), ("Number of links".into(), String::new()));
    }

    #[test]
    fn escape_unit_escapes_only_the_trailing_unit() {
        let attrs: Vec<Attribute> = vec![
            syn::parse_quote!(#[doc = " Mass [kg] of the"]),
            syn::parse_quote!(#[doc = " front body, see [`Model`] [kg]"]),
            syn::parse_quote!(#[allow(dead_code)]),
        ];
        let out = escape_unit(&attrs);
        assert_eq!(docs(&out), [" Mass [kg] of the", " front body, see [`Model`] \\[kg\\]"]);
        assert!(out[2].path().is_ident("allow"));
        let (doc, unit) = split_unit(&doc_of(&out));
        assert_eq!((doc.as_str(), unit.as_str()), ("Mass [kg] of the front body, see [`Model`]", "kg"));
    }

    #[test]
    fn escape_unit_spans_lines_and_keeps_escaped_units() {
        let attrs: Vec<Attribute> =
            vec![syn::parse_quote!(#[doc = " Moment of inertia [kg"]), syn::parse_quote!(#[doc = " m^2]"])];
        assert_eq!(docs(&escape_unit(&attrs)), [" Moment of inertia \\[kg", " m^2\\]"]);
        let escaped: Vec<Attribute> = vec![syn::parse_quote!(#[doc = " Mass \\[kg\\]"])];
        assert_eq!(docs(&escape_unit(&escaped)), [" Mass \\[kg\\]"]);
        let plain: Vec<Attribute> = vec![syn::parse_quote!(#[doc = " Number of links"])];
        assert_eq!(docs(&escape_unit(&plain)), [" Number of links"]);
    }
}
