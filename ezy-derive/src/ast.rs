//! The typed model, with the user's tokens kept for error spans.

use proc_macro2::Span;
use syn::{Attribute, Expr, Ident, Visibility};

/// A whole `model!` invocation.
pub struct ModelDef {
    pub attrs: Vec<Attribute>,
    pub vis: Visibility,
    pub name: Ident,
    pub params: Vec<Param>,
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

/// `body NAME(x, y, phi) { mass: EXPR, inertia: EXPR }`
pub struct Body {
    pub name: Ident,
    pub coords: [Ident; 3],
    pub mass: Expr,
    pub inertia: Expr,
}

/// `point NAME on BODY at (X, Y);`
pub struct Point {
    pub name: Ident,
    pub body: Ident,
    pub at: [Expr; 2],
}

/// The second side of a hinge.
pub enum HingeTarget {
    /// Another named point.
    Point(Ident),
    /// A fixed point of the ground, in world coordinates [m].
    Ground { at: Box<[Expr; 2]> },
}

/// `hinge NAME: P = Q;` or `hinge NAME: P = ground(X, Y);`
pub struct Hinge {
    pub name: Ident,
    pub point: Ident,
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
    pub point: Ident,
    pub target: HingeTarget,
    pub along: [Expr; 2],
    pub along_span: Span,
    pub angle: Option<Expr>,
}

/// `drive NAME: hinge H;`: the hinge's angle `phi_a - phi_b` follows a
/// function of time given by the scene (a rheonomic constraint).
pub struct Drive {
    pub name: Ident,
    pub hinge: Ident,
}

/// `skate NAME: P along (DX, DY);`
pub struct Skate {
    pub name: Ident,
    pub point: Ident,
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

/// Splits a trailing `[unit]` off a doc string: `("Distance", "m")`.
pub fn split_unit(doc: &str) -> (String, String) {
    let t = doc.trim_end();
    if t.ends_with(']')
        && let Some(open) = t.rfind('[')
    {
        return (t[..open].trim_end().to_string(), t[open + 1..t.len() - 1].trim().to_string());
    }
    (t.to_string(), String::new())
}
