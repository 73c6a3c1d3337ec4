//! Scenes: which model, where it starts, which effects act, how long, and
//! which figures to draw. Built-in scenes live in `ezy-models`.

use crate::effects::EffectSpec;
use crate::integrator::Method;
use crate::model::Model;
use crate::projection::ProjectionKind;

/// An initial value: a number or a model parameter's value.
#[derive(Debug, Clone, PartialEq)]
pub enum InitValue {
    /// A number (SI units of the coordinate).
    Num(f64),
    /// The current value of the named model parameter.
    Param(&'static str),
}

/// A column of the output table, or a quantity derived from columns.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// A CSV column by name.
    Named(&'static str),
    /// `sqrt(a^2 + b^2)` of two columns (a speed from two velocity components).
    Norm(&'static str, &'static str),
    /// `a - b`.
    Diff(&'static str, &'static str),
    /// `a(t) - a(0)`.
    FromStart(&'static str),
    /// `|a(t) - a(0) - b(t)|`: the gap of a balance such as `T - T0 = W`.
    BalanceGap(&'static str, &'static str),
}

/// What a figure shows.
#[derive(Debug, Clone, PartialEq)]
pub enum FigureKind {
    /// Paths in the plane, equal axes, of named points or of bodies' centres
    /// of mass (by body name).
    Paths(Vec<&'static str>),
    /// Lines `(x, y_i)`; each with a legend label.
    Lines {
        /// Horizontal axis.
        x: Column,
        /// `(label, column)` per line.
        ys: Vec<(&'static str, Column)>,
        /// Logarithmic vertical axis.
        log_y: bool,
    },
}

/// One PNG figure of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureSpec {
    /// File name in the output directory, e.g. `fig3_paths.png`.
    pub file: &'static str,
    /// Title.
    pub title: &'static str,
    /// Horizontal axis label with unit.
    pub x_label: &'static str,
    /// Vertical axis label with unit.
    pub y_label: &'static str,
    /// Content.
    pub kind: FigureKind,
}

/// A scene (SPEC §3).
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Name, e.g. `drive`.
    pub name: &'static str,
    /// One line: what it shows.
    pub description: &'static str,
    /// Registry key of the model, e.g. `ezyroller`.
    pub model: &'static str,
    /// Duration [s].
    pub t_end: f64,
    /// Step size [s].
    pub dt: f64,
    /// Output interval [s].
    pub every: f64,
    /// Projection after every step.
    pub projection: ProjectionKind,
    /// Integration method.
    pub method: Method,
    /// Relative tolerance (adaptive methods).
    pub rtol: f64,
    /// Absolute tolerance (adaptive methods).
    pub atol: f64,
    /// Given coordinates by name; the rest follow from the hinges.
    pub q0: Vec<(&'static str, InitValue)>,
    /// Given velocities by coordinate name; the rest follow from the constraints.
    pub qd0: Vec<(&'static str, InitValue)>,
    /// Applied forces.
    pub effects: Vec<EffectSpec>,
    /// Figures to draw.
    pub figures: Vec<FigureSpec>,
}

/// Runs generic code for a model chosen by name at run time (the model
/// registry calls [`ModelVisitor::visit`] with the concrete type).
pub trait ModelVisitor {
    /// Result of the visit.
    type Output;
    /// Called with the model type.
    fn visit<M: Model + Default>(self) -> Self::Output;
}
