//! How deep a model's text nests, bounded on its tokens before syn parses
//! them: syn's parser (and the derivation after it) recurses once per
//! bracket, per prefix operator (`- - 1`, `!!x`, `**p`, `&&x`) and per
//! operator whose operand runs on to the right (`a = b = ..`, closures
//! `|a| ..`, `return ..`, `..x`, generic arguments `A<A<..>>`, `fn() ->
//! ..`), with frames of kilobytes: a 1 MiB text of 350,000 `-` overflows
//! even a 1 GiB stack. [`check_depth`] refuses such a text where the
//! bound is passed, so the parser and every recursive walk of the
//! derivation (whose depth follows the expression's) stay shallow.
//! Binary operators that chain to the left (`1 + 1 + ..`, `a * b / c`)
//! do not count: syn parses them in a loop and the derivation reads a
//! chain as one sum or product.

use proc_macro2::{Spacing, Span, TokenStream, TokenTree};

/// Most brackets `( [ {` open at once in a model's text (the built-in
/// models nest 3 deep).
pub const MAX_NESTING: usize = 64;

/// Most operators open at once on the way into an expression: prefix
/// operators (`-`, `!`, `*`, `&`) in a row, together with the operators
/// whose operand runs on to the right (`=`, `|`, `..`, `<`, `->`,
/// `return`, `let`, `if`, ...) since the last `,` or `;` and in the
/// brackets around it. The built-in models open at most 2 (`L = -a`); 64,
/// as for brackets, keeps the parser's recursion, at a few kilobytes a
/// level in a debug build, within a few hundred kilobytes even with every
/// bracket open (far inside a 2 MiB thread's stack, or the compiler's for
/// `model!`).
pub const MAX_OPEN_OPERATORS: usize = 64;

/// Keywords whose operand runs on to the right (`return x`, `let p = x`,
/// `if c {} else if ..`), each a level of syn's recursion.
const OPEN_KEYWORDS: &[&str] = &["return", "break", "yield", "become", "let", "if", "else", "box", "do"];

/// Identifiers that are operands (the others among Rust's keywords are
/// not: after them an operator is a prefix one).
const OPERAND_KEYWORDS: &[&str] = &["self", "Self", "super", "crate", "true", "false"];

/// Rust's keywords, strict and reserved (an identifier not among them, or
/// among [`OPERAND_KEYWORDS`], ends an operand).
const KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "dyn", "else", "enum", "extern", "fn", "for", "if", "impl",
    "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return", "static", "struct", "trait", "type",
    "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final", "macro", "override", "priv", "try",
    "typeof", "unsized", "virtual", "yield", "raw",
];

/// Binary operators (after an operand) whose right operand is parsed by a
/// recursion of syn's: assignments (right-associative), ranges, generic
/// arguments and return types.
const OPEN_BINARY: &[&str] =
    &["=", "+=", "-=", "*=", "/=", "%=", "^=", "&=", "|=", "<<=", ">>=", "..", "..=", "...", "<", "->", "@"];

/// Rust's operators of several characters, longest first: a run of joint
/// punctuation is split into these (and single characters).
const MULTI: &[&str] = &[
    "<<=", ">>=", "...", "..=", "&&", "||", "==", "!=", "<=", ">=", "+=", "-=", "*=", "/=", "%=", "^=", "&=", "|=",
    "<<", ">>", "..", "->", "=>", "::",
];

/// The walk's state in one bracket group.
struct Level {
    /// Open operators inherited from the brackets around the group.
    base: usize,
    /// Open operators of the current part (since the last `,` or `;`),
    /// `base` included.
    open: usize,
    /// Prefix operators in a row just before here.
    run: usize,
    /// Whether the last token ended an operand (what follows is binary).
    after_operand: bool,
}

impl Level {
    fn new(base: usize) -> Self {
        Level { base, open: base, run: 0, after_operand: false }
    }

    fn operand(&mut self) {
        self.run = 0;
        self.after_operand = true;
    }
}

/// Checks that `tokens` (a model's text, or `model!`'s input) nest no
/// deeper than [`MAX_NESTING`] brackets and [`MAX_OPEN_OPERATORS`] open
/// operators; the walk itself keeps its own stack, not the thread's.
///
/// # Errors
/// The first bracket or operator past a bound, at its span (its line and
/// column within a text).
pub fn check_depth(tokens: &TokenStream) -> syn::Result<()> {
    let mut stack: Vec<(proc_macro2::token_stream::IntoIter, Level)> =
        vec![(tokens.clone().into_iter(), Level::new(0))];
    let mut pending: Vec<(char, Spacing, Span)> = Vec::new();
    while !stack.is_empty() {
        let depth = stack.len();
        let (iter, level) = stack.last_mut().expect("not empty");
        let Some(tt) = iter.next() else {
            flush(&mut pending, level)?;
            stack.pop();
            if let Some((_, parent)) = stack.last_mut() {
                parent.operand();
            }
            continue;
        };
        if let TokenTree::Punct(p) = &tt {
            pending.push((p.as_char(), p.spacing(), p.span()));
            if p.spacing() == Spacing::Alone {
                flush(&mut pending, level)?;
            }
            continue;
        }
        flush(&mut pending, level)?;
        match tt {
            TokenTree::Group(g) => {
                if depth > MAX_NESTING {
                    let message = format!("brackets nested more than {MAX_NESTING} deep; write the expression flatter");
                    return Err(syn::Error::new(g.span_open(), message));
                }
                let inner = Level::new(level.open + level.run);
                stack.push((g.stream().into_iter(), inner));
            }
            TokenTree::Ident(id) => {
                let name = id.to_string();
                if OPEN_KEYWORDS.contains(&name.as_str()) {
                    level.open += 1;
                    level.after_operand = false;
                    bound(level, &format!("`{name}`"), id.span())?;
                } else if KEYWORDS.contains(&name.as_str()) && !OPERAND_KEYWORDS.contains(&name.as_str()) {
                    level.after_operand = false;
                } else {
                    level.operand();
                }
            }
            TokenTree::Literal(_) => level.operand(),
            TokenTree::Punct(_) => unreachable!("handled above"),
        }
    }
    Ok(())
}

/// Reads the joint punctuation `pending` (one or more operators written
/// together, `--`, `&&`, `+=`) against `level`, and empties it.
fn flush(pending: &mut Vec<(char, Spacing, Span)>, level: &mut Level) -> syn::Result<()> {
    let mut i = 0;
    while i < pending.len() {
        let rest: String = pending[i..].iter().take(3).map(|p| p.0).collect();
        let op = MULTI.iter().find(|m| rest.starts_with(**m)).map_or(&rest[..1], |m| *m);
        let span = pending[i].2;
        i += op.chars().count();
        if op.starts_with('\'') {
            // a lifetime or label: the identifier after it is its name
            level.after_operand = false;
            continue;
        }
        match op {
            "," | ";" => {
                level.open = level.base;
                level.run = 0;
                level.after_operand = false;
                continue;
            }
            "?" => {
                level.operand();
                continue;
            }
            "#" | "::" | ":" | "." | ">" | ">>" | "=>" => {
                level.after_operand = false;
                continue;
            }
            _ => {}
        }
        if level.after_operand {
            if OPEN_BINARY.contains(&op) {
                level.open += 1;
            }
            // a binary operator ends the prefix operators before it
            level.run = 0;
        } else if matches!(op, "-" | "!" | "*" | "&" | "&&") {
            level.run += op.len();
        } else {
            // `|` and `||` (a closure), `..`, `<`, `=`, `@`, ...
            level.open += 1;
        }
        level.after_operand = false;
        bound(level, &format!("`{op}`"), span)?;
    }
    pending.clear();
    Ok(())
}

/// The mistake of an operator `what` at `span` past [`MAX_OPEN_OPERATORS`].
fn bound(level: &Level, what: &str, span: Span) -> syn::Result<()> {
    if level.open + level.run <= MAX_OPEN_OPERATORS {
        return Ok(());
    }
    let message = format!(
        "{what} opens more than {MAX_OPEN_OPERATORS} operators at once (a chain of prefix operators such as `- - 1`, \
         or of `=`, closures, `<`); write the expression flatter"
    );
    Err(syn::Error::new(span, message))
}

#[cfg(test)]
mod tests {
    use super::check_depth;

    fn check(text: &str) -> Result<(), (usize, usize, String)> {
        let tokens: proc_macro2::TokenStream = text.parse().expect("the text lexes");
        check_depth(&tokens).map_err(|e| {
            let at = e.span().start();
            (at.line, at.column + 1, e.to_string())
        })
    }

    /// Ordinary model text passes: a point at `(-L, - -a)`, a hinge, a
    /// long flat sum, a family.
    #[test]
    fn ordinary_text_passes() {
        let sum = " + L".repeat(10_000);
        let text = format!(
            "pub struct M {{ param L = 1.0; body b(x, y, phi) {{ mass: 1.0{sum}, inertia: 0.1 }}
             point P on b at (-L, - -L * -L - -L / -(L)); hinge H: P = ground(0, -L);
             count N = 3; for i in 0..N {{ body c[i](x, y, phi) {{ mass: 1.0, inertia: 0.1 }} }} }}"
        );
        assert_eq!(check(&text), Ok(()));
    }

    /// A chain of prefix operators past the bound is refused at the 65th,
    /// written apart or together.
    #[test]
    fn prefix_chains_are_refused_where_they_pass_the_bound() {
        for op in ["- ", "-", "! ", "* ", "& ", "&&"] {
            let text = format!("struct M {{\n point P on b at ({}1, 0); }}", op.repeat(350_000));
            let (line, column, message) = check(&text).expect_err(op);
            assert!(message.contains("opens more than 64 operators at once"), "{op}: {message}");
            let per = op.trim_end().len();
            let at = 18 + (64 / per) * op.len() + 1;
            assert_eq!((line, column), (2, at), "{op}: {message}");
        }
    }

    /// Operators whose operand runs on to the right count however they
    /// are spread: assignments, closures, `return`, ranges, generics.
    #[test]
    fn right_running_operators_are_bounded() {
        for (head, rep) in [
            ("", "a = "),
            ("", "|a| "),
            ("", "move || "),
            ("", "return "),
            ("", ".. "),
            ("", "a += "),
            ("", "let a = "),
            ("1 as ", "A<"),
            ("1 as ", "&"),
            ("1 as ", "fn() -> "),
            ("1 as ", "*const "),
            ("", "if a {} else "),
        ] {
            let text = format!("struct M {{ point P on b at ({head}{}1, 0); }}", rep.repeat(100_000));
            let (_, _, message) = check(&text).expect_err(rep);
            assert!(message.contains("opens more than 64 operators"), "{rep}: {message}");
        }
    }

    /// Brackets count as before: the 65th is refused.
    #[test]
    fn brackets_past_the_bound_are_refused() {
        let text = format!("struct M {{ param L = {}1{}; }}", "(".repeat(1000), ")".repeat(1000));
        let (line, column, message) = check(&text).expect_err("too deep");
        assert!(message.starts_with("brackets nested more than 64 deep"), "{message}");
        assert_eq!((line, column), (1, 22 + 63));
    }
}
