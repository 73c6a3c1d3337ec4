//! ezy's model language, the engine behind `model!`: a declarative planar
//! multibody model (bodies, points, hinges, sliders, drives, skates,
//! families of them) parsed from tokens or text ([`ast`], [`parse`]),
//! checked with every mistake located ([`check`]), and derived
//! symbolically ([`kinematics`], [`minimal`], expressions in [`sym`]): the
//! holonomic residual `phi` (nh), its Jacobian, the skate rows of the
//! constraint matrix `G` (nc x nq), the convective terms `gamma`, the
//! points' kinematics and, where the constraints allow it, the
//! minimal-coordinate equations (Maggi's; Kane & Levinson 1985, ch. 6).
//!
//! `ezy-derive` calls it on the tokens of a `model! { ... }` and emits
//! Rust; a runtime model can call it on a string ([`derive_text`]): one
//! grammar, one set of messages. Data flows one way: tokens ->
//! [`ast::ModelDef`] -> [`check::Resolved`] -> [`kinematics::Derived`]
//! -> [`description::Description`], what the model says about itself
//! (names, checks, equations), one piece of data for both back ends.

pub mod ast;
pub mod check;
pub mod depth;
pub mod description;
pub mod kinematics;
pub mod minimal;
pub mod parse;
pub mod straight;
pub mod sym;

/// The largest value a count may take, declared or set \[elements\]:
/// 10^9 (index arithmetic stays far inside `i64`).
pub const MAX_COUNT: i64 = 1_000_000_000;

/// Most generalized coordinates a model may have at its family counts:
/// 300,000 (the snake at `N = 100,000`; ezy-core's `MAX_COORDS`, which
/// sizes a run's set-up). A model whose declared counts give more is a
/// mistake at its first count.
pub const MAX_COORDS: usize = 300_000;

/// Most bodies a model's text may declare one by one (a family, `for i in
/// 0..N { body ... }`, counts once): 100. The derivation's time grows as
/// the cube of that count (measured: 50 bodies 0.9 s, 100 bodies 5.5 s,
/// 200 about a minute), so a larger text is refused before it starts;
/// write a chain of alike bodies as a family.
pub const MAX_TEXT_BODIES: usize = 100;

/// A model checked and derived: what a back end (the macro's Rust, a
/// run-time evaluator) turns into code.
pub struct Derivation {
    /// The model as written.
    pub def: ast::ModelDef,
    /// Its names resolved (indices of coordinates, parameters, bodies).
    pub resolved: check::Resolved,
    /// Its derived terms.
    pub derived: kinematics::Derived,
}

/// Template of a derived expression for the runtime's `render_equation`
/// (text, LaTeX): coordinates, rates and parameters as markers
/// `\u{1}q3\u{2}` (coordinate 3 of the expression's own numbering),
/// `\u{1}d3\u{2}` (its rate), `\u{1}p1\u{2}` (parameter 1), a family index
/// `Sym::Index(k)` as [`index_marker`], which the back end replaces by
/// the element's index before rendering. Shared by `model!`'s generated
/// `equations` and a model read from text.
pub fn equation_templates(ar: &sym::Arena, id: sym::Id) -> (String, String) {
    use sym::Sym;
    let name = |s: Sym| match s {
        Sym::Q(k) => format!("\u{1}q{k}\u{2}"),
        Sym::Qd(k) => format!("\u{1}d{k}\u{2}"),
        Sym::Param(i) => format!("\u{1}p{i}\u{2}"),
        Sym::Index(k) => index_marker(k),
    };
    (ar.display(id, &name), ar.latex(id, &name))
}

/// The marker of `Sym::Index(k)` in an [`equation_templates`] template:
/// control characters that neither the other markers nor a name contain.
pub fn index_marker(k: usize) -> String {
    format!("\u{3}{k}\u{4}")
}

/// Checks `def` and derives its terms.
///
/// # Errors
/// Every mistake found, each at its span, combined into one
/// [`syn::Error`] (the messages `model!` reports as compile errors).
pub fn derive(def: &ast::ModelDef) -> syn::Result<(check::Resolved, kinematics::Derived)> {
    let mut errs = check::Errors::default();
    let resolved = check::check(def, &mut errs);
    let derived = kinematics::derive(def, &resolved, &mut errs);
    errs.finish()?;
    Ok((resolved, derived))
}

/// Parses the text of a model (what goes between the braces of
/// `model! { ... }`), checks it and derives its terms.
///
/// # Errors
/// A text nested too deep ([`depth::check_depth`]), a parse error or
/// more than [`MAX_TEXT_BODIES`] bodies declared one by one (at the
/// model's name, before any derivation), or
/// every mistake [`derive()`] finds, each with its span:
/// `error.span().start()` is its line (from 1) and column (from 0, in
/// characters) within `text`.
pub fn derive_text(text: &str) -> syn::Result<Derivation> {
    let tokens: proc_macro2::TokenStream = text.parse().map_err(syn::Error::from)?;
    depth::check_depth(&tokens)?;
    let def: ast::ModelDef = syn::parse2(tokens)?;
    if def.bodies.len() > MAX_TEXT_BODIES {
        return Err(syn::Error::new(
            def.name.span(),
            format!(
                "{} declares {} bodies, more than the {MAX_TEXT_BODIES} a model's text may declare one by one: the derivation's time grows as the cube of the body count (100 bodies take some 6 s, 200 a minute); write a chain of alike bodies as a family (`for i in 0..N {{ body ... }}`)",
                def.name,
                def.bodies.len()
            ),
        ));
    }
    let (resolved, derived) = derive(&def)?;
    Ok(Derivation { def, resolved, derived })
}

#[cfg(test)]
mod tests {
    const PENDULUM: &str = "
        pub struct Pendulum {
            param L = 1.0;
            body bob(x, y, phi) { mass: 1.0, inertia: 0.1 }
            point O on bob at (-L, 0);
            hinge O: O = ground(0, 0);
        }";

    /// Text derives as tokens do: the pendulum's two hinge rows over its
    /// three coordinates.
    #[test]
    fn a_model_derives_from_text() {
        let m = super::derive_text(PENDULUM).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.def.name.to_string(), "Pendulum");
        assert_eq!(m.def.bodies.len(), 1);
        assert_eq!(m.def.hinges.len(), 1);
    }

    /// Counts are sized before anything is made of them: a declared value
    /// past `MAX_COUNT` is refused where it is written, and declared
    /// counts that give more than `MAX_COORDS` coordinates at the count.
    #[test]
    fn counts_are_sized_where_they_are_declared() {
        let chain = |n: &str| {
            format!(
                "pub struct Chain {{
                    count N = {n};
                    for i in 0..N {{ body link[i](x, y, phi) {{ mass: 1.0, inertia: 0.1 }} }}
                }}"
            )
        };
        assert!(super::derive_text(&chain("100000")).is_ok());
        let e = super::derive_text(&chain("100001")).err().expect("300,003 coordinates");
        assert!(e.to_string().contains("N = 100001 gives 300003 generalized coordinates, more than the 300000"), "{e}");
        assert_eq!(e.span().start().line, 2);
        let e = super::derive_text(&chain("2000000000")).err().expect("past MAX_COUNT");
        assert!(e.to_string().contains("from 1 to 1000000000"), "{e}");
    }

    /// A mistake in the text is the same message `model!` gives at compile
    /// time, naming what is wrong.
    #[test]
    fn a_mistake_in_text_is_named() {
        let text = PENDULUM.replace("point O on bob", "point O on rod");
        let e = super::derive_text(&text).err().expect("an unknown body is refused");
        assert!(e.to_string().contains("rod"), "{e}");
        // where: `rod` on the text's fifth line (the first is empty), in
        // the column after `point O on ` (proc-macro2's `span-locations`)
        let at = e.span().start();
        let line = text.lines().nth(at.line - 1).expect("the line exists");
        assert_eq!((at.line, &line[at.column..at.column + 3]), (5, "rod"), "{line}");
    }

    /// A parameter defined by an expression of others stands for its
    /// expression wherever it is named, in any order of definition: the
    /// mass matrix holds the expression of the numbered parameters; a
    /// cycle is refused at its first name with the whole cycle, and `**`
    /// is told to be a product.
    #[test]
    fn parameters_defined_by_expressions_follow_theirs_and_cycles_are_refused() {
        let text = |defs: &str| {
            format!(
                "pub struct Disk {{
                    {defs}
                    body b(x, y, phi) {{ mass: m, inertia: I }}
                }}"
            )
        };
        // `I` before the `r2` it names
        let m = super::derive_text(&text("param m = 2.0; param I = m * r2 / 2; param r2 = r * r; param r = 0.3;"))
            .unwrap_or_else(|e| panic!("{e}"));
        let inertia = m.derived.mass[0][2];
        let value = m.derived.ar.eval(inertia, &|s| match s {
            super::sym::Sym::Param(i) => [2.0, 0.3][i],
            _ => unreachable!(),
        });
        assert_eq!(value, 2.0 * (0.3 * 0.3) / 2.0);
        assert_eq!(m.def.params.len(), 2, "the defined ones are not settable parameters");
        let cyc = text("param m = 2.0;\n param I = m * a;\n param a = b + 1;\n param b = I * 2;");
        let e = super::derive_text(&cyc).err().expect("a cycle");
        assert!(e.to_string().contains("parameter `I` is defined by itself: I -> a -> b -> I"), "{e}");
        assert_eq!(e.span().start().line, 3, "{e}");
        let e = super::derive_text(&text("param m = 2.0; param I = m*0.2**2;")).err().expect("no power");
        assert!(e.to_string().contains("there is no `**`"), "{e}");
        let e = super::derive_text(&text("param m = 2.0; param I = m * rr;")).err().expect("an unknown name");
        assert!(e.to_string().contains("parameter `I`: unknown parameter `rr`; known parameters: m, I"), "{e}");
    }
}
