//! `ezy equations MODEL`: what the `model!` macro derived, in the notation
//! of docs/physics.md (`phi1d` is the rate of `phi1`), as text or as a LaTeX
//! document.

use std::io::Write;

use clap::{ArgMatches, Args, FromArgMatches, ValueEnum};
use ezy_core::{Model, ModelInfo};

use crate::app::{App, AppError};
use crate::cli::parse_set;
use crate::session::with_sets;

/// Print the equations the model! macro derived (phi, G = [C_q; S], gamma).
#[derive(Args, Debug)]
struct EquationsArgs {
    /// Model name (see `ezy list`), or the path of a model file (`.ezy`).
    model: String,
    /// Set a parameter or a family count first (`--set N=3`); repeatable.
    #[arg(long = "set", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    format: Format,
}

/// Output format.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    /// Plain text in the notation of docs/physics.md (`phi1d` is the rate of `phi1`).
    Text,
    /// A LaTeX document (amsmath).
    Latex,
}

/// The arguments of `ezy equations`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    EquationsArgs::augment_args(cmd)
}

/// Prints the equations of the model named, with the `--set` values.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = EquationsArgs::from_arg_matches(args)?;
    let model = &app.model_or_error(&args.model)?;
    let text = with_sets(model, &args.sets).map(|m| render(&m, args.format)).map_err(AppError::Failed)?;
    Ok(out.write_all(text.as_bytes())?)
}

/// The derived equations of `model` (at its family counts) in `format`.
fn render<M: Model>(model: &M, format: Format) -> String {
    match format {
        Format::Text => text(model),
        Format::Latex => latex(model),
    }
}

/// Kind of constraint row `i`.
fn row_kind(info: &ModelInfo, i: usize) -> &'static str {
    if info.drives.iter().any(|d| d.row == i) {
        "drive"
    } else if let Some(s) = info.sliders.iter().find(|s| s.row == i || (s.heading && s.row + 1 == i)) {
        if s.heading { "slider" } else { "slot" }
    } else if i < info.n_holonomic {
        "hinge"
    } else {
        "skate"
    }
}

/// The right-hand side of row `i` at position level (`u(t)` for a drive).
fn target(info: &ModelInfo, i: usize, level: &str) -> &'static str {
    match (info.drives.iter().any(|d| d.row == i), level) {
        (false, _) => "0",
        (true, "q") => "u(t)",
        (true, _) => "u'(t)",
    }
}

fn text<M: Model>(m: &M) -> String {
    let (info, eq) = (&m.info(), &m.equations());
    let mut out = String::new();
    let w = info.constraints.iter().map(|c| c.len()).max().unwrap_or(0);
    out.push_str(&format!("{}: {}\n", info.name, info.doc));
    out.push_str(&format!("q = [{}]  (nq = {}, nc = {})\n\n", info.coords.join(", "), info.nq(), info.nc()));
    let mass: Vec<&str> = eq.mass.iter().map(|e| e.text.as_str()).collect();
    out.push_str(&format!("Mass matrix\n  M = diag({})\n\n", mass.join(", ")));
    out.push_str("Holonomic constraints phi(q) = 0 [m, rad] (a drive's row equals its prescribed angle u(t))\n");
    let rows = |out: &mut String, exprs: &[ezy_core::EquationExpr], level: &str| {
        for (i, e) in exprs.iter().enumerate() {
            let (name, rhs, kind) = (&info.constraints[i], target(info, i, level), row_kind(info, i));
            out.push_str(&format!("  {name:<w$}  {} = {rhs}   ({kind})\n", e.text));
        }
    };
    rows(&mut out, &eq.phi, "q");
    out.push_str("\nVelocity constraints G(q) qd = 0 [m/s, rad/s] (holonomic rows: d phi/dt; skate rows: S qd, the lateral velocity of the contact point; a drive's row: u'(t))\n");
    rows(&mut out, &eq.velocity, "qd");
    out.push_str(&format!("\nConstraint Jacobian G = [C_q; S] ({} x {}), nonzero entries\n", info.nc(), info.nq()));
    for (&(r, c), e) in info.pattern.iter().zip(&eq.jacobian) {
        out.push_str(&format!("  G[{}, {}] = {}\n", info.constraints[r], info.coords[c], e.text));
    }
    out.push_str(
        "\nConvective terms gamma = d/dq(G qd) qd [m/s^2], so that G qdd = -gamma (+ u''(t) on a drive's row)\n",
    );
    for (i, e) in eq.gamma.iter().enumerate() {
        out.push_str(&format!("  {:<w$}  {}\n", info.constraints[i], e.text));
    }
    out.push_str("\nPoint velocities [m/s]\n");
    for (p, v) in info.points.iter().zip(eq.point_velocities.chunks(2)) {
        out.push_str(&format!("  {}: ({}, {})\n", p.name, v[0].text, v[1].text));
    }
    out
}

/// A constraint or coordinate name as LaTeX text.
fn tex_text(s: &str) -> String {
    format!("\\text{{{}}}", s.replace('_', "\\_"))
}

fn latex<M: Model>(m: &M) -> String {
    let (info, eq) = (&m.info(), &m.equations());
    let mut out = String::new();
    out.push_str("\\documentclass{article}\n\\usepackage{amsmath}\n\\allowdisplaybreaks\n\\begin{document}\n");
    out.push_str(&format!("\\section*{{{}: derived equations}}\n", info.name));
    let q: Vec<&str> = eq.coords.iter().map(|c| c.latex.as_str()).collect();
    out.push_str(&format!(
        "Generalized coordinates\n\\[ q = \\begin{{pmatrix}} {} \\end{{pmatrix}}^T \\]\n",
        q.join(" & ")
    ));
    let mass: Vec<&str> = eq.mass.iter().map(|e| e.latex.as_str()).collect();
    out.push_str(&format!("Mass matrix\n\\[ M = \\operatorname{{diag}}\\left({}\\right) \\]\n", mass.join(",\\ ")));
    out.push_str("Holonomic constraints\n\\begin{align*}\n");
    for (i, e) in eq.phi.iter().enumerate() {
        let rhs = if target(info, i, "q") == "0" { "0" } else { "u(t)" };
        out.push_str(&format!("  \\phi_{{{}}} &= {} = {rhs} \\\\\n", tex_text(&info.constraints[i]), e.latex));
    }
    out.push_str(
        "\\end{align*}\nVelocity constraints $G(q)\\,\\dot q = 0$ (skate rows: $S(q)\\,\\dot q$)\n\\begin{align*}\n",
    );
    for (i, e) in eq.velocity.iter().enumerate() {
        out.push_str(&format!("  G_{{{}}}\\,\\dot q &= {} \\\\\n", tex_text(&info.constraints[i]), e.latex));
    }
    out.push_str("\\end{align*}\nConstraint Jacobian $G = [C_q;\\ S]$, nonzero entries\n\\begin{align*}\n");
    for (&(r, c), e) in info.pattern.iter().zip(&eq.jacobian) {
        out.push_str(&format!(
            "  G_{{{},\\,{}}} &= {} \\\\\n",
            tex_text(&info.constraints[r]),
            eq.coords[c].latex,
            e.latex
        ));
    }
    out.push_str("\\end{align*}\nConvective terms $\\gamma = \\frac{\\partial (G\\dot q)}{\\partial q}\\,\\dot q$, so that $G\\ddot q = -\\gamma$\n\\begin{align*}\n");
    for (i, e) in eq.gamma.iter().enumerate() {
        out.push_str(&format!("  \\gamma_{{{}}} &= {} \\\\\n", tex_text(&info.constraints[i]), e.latex));
    }
    out.push_str("\\end{align*}\nPoint velocities\n\\begin{align*}\n");
    for (p, v) in info.points.iter().zip(eq.point_velocities.chunks(2)) {
        out.push_str(&format!(
            "  v_{{{}}} &= \\left({},\\ {}\\right) \\\\\n",
            tex_text(&p.name),
            v[0].latex,
            v[1].latex
        ));
    }
    out.push_str("\\end{align*}\n\\end{document}\n");
    out
}
