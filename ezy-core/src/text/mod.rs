//! A model read from text at run time: [`RuntimeModel`].
//!
//! The text is what goes between the braces of `model! { ... }` (a
//! `.ezy` file holds exactly that). It is parsed, checked and derived by
//! the engine `model!` uses (the `ezy-lang` crate: one grammar, the same
//! messages), and each derived expression is lowered once to a tape
//! (straight-line code for a register machine) that evaluates
//! over `f64` and over dual numbers, and that Cranelift compiles to
//! machine code for `f64` where it can ([`Evaluator`]). A family (`for`) is one element
//! kernel looped over its elements at the current counts, as in compiled
//! code, so parameters and counts stay parameters: a sweep changes them
//! without deriving anything again.

mod fused;
mod plan;
mod tape;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::model::Model;
use crate::model::describe;
use crate::model::info::{Equations, ModelInfo};
use crate::model::layout::Layout;
use crate::scalar::Scalar;
use plan::{GroupPlan, Plan};
use tape::{Inputs, Tape};

/// The largest model text read \[bytes\]: 1 MiB (the built-in models are
/// 1-4 kB; a hostile text of this size, one sum of 250,000 terms, takes
/// about 3 s and 0.4 GB to derive).
pub const MAX_TEXT_BYTES: u64 = 1 << 20;

/// One mistake in a model's text, where it is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextMistake {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1, in characters.
    pub column: usize,
    /// What is wrong: the message `model!` gives as a compile error.
    pub message: String,
}

/// Why a model could not be read from text.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelTextError {
    /// The file could not be read (or is too large to be a model).
    #[error("cannot read model file {}: {reason}", file.display())]
    Read {
        /// The file.
        file: PathBuf,
        /// Why.
        reason: String,
    },
    /// The JIT was asked for where there is none (a build without the
    /// `jit` feature, or a host Cranelift has no back end for).
    #[error("no JIT evaluator: {0}")]
    NoJit(String),
    /// The text has mistakes: every one found, each located.
    #[error("{}", show_mistakes(file.as_deref(), mistakes))]
    Mistakes {
        /// The file, if the text came from one.
        file: Option<PathBuf>,
        /// Every mistake, in the order found.
        mistakes: Vec<TextMistake>,
    },
}

/// `file:line:column: message` per mistake (`line:column: ...` without a
/// file), one per line.
fn show_mistakes(file: Option<&Path>, mistakes: &[TextMistake]) -> String {
    let at = |m: &TextMistake| match file {
        Some(f) => format!("{}:{}:{}", f.display(), m.line, m.column),
        None => format!("line {}, column {}", m.line, m.column),
    };
    let lines: Vec<String> = mistakes.iter().map(|m| format!("{}: {}", at(m), m.message)).collect();
    lines.join("\n")
}

/// A model read from text at run time, derived by the engine `model!`
/// uses and evaluated by tapes: it implements [`Model`], so it runs
/// wherever a compiled model does ([`crate::Problem`],
/// [`crate::AnyModel`], every formulation and analysis). Cloning it
/// shares the derived code.
///
/// A model without families whose hinges form a tree has the minimal
/// coordinates `model!` derives ([`Model::minimal_layout`],
/// [`Model::minimal_expand`], [`Model::minimal_state`]) and the fused
/// right-hand side on them ([`Model::minimal_rhs`]: one tape from the
/// kept coordinates and speeds to Maggi's equations, its parameter-only
/// subexpressions hoisted into [`Model::minimal_constants`]).
///
/// Evaluation: by machine code Cranelift compiles when the model is read
/// (the JIT, [`Evaluator::Jit`]), where the build and the host have one,
/// by the tape otherwise ([`RuntimeModel::with_evaluator`]); both give the
/// same numbers, bit for bit.
///
/// ```
/// use ezy_core::Model;
/// use ezy_core::text::RuntimeModel;
/// let m = RuntimeModel::from_text("
///     pub struct Pendulum {
///         param L = 1.0;
///         body bob(x, y, phi) { mass: 1.0, inertia: 0.1 }
///         point O on bob at (-L, 0);
///         hinge O: O = ground(0, 0);
///     }").unwrap();
/// let mut phi = [0.0; 2];
/// m.phi(&[1.0, 0.0, 0.0], &mut phi); // the bob hangs 1 m right of O
/// assert_eq!(phi, [0.0, 0.0]);
/// ```
#[derive(Clone, Debug)]
pub struct RuntimeModel {
    plan: Arc<Plan>,
    /// Parameter values: the reals, then the counts.
    values: Vec<f64>,
    layout: Arc<Layout>,
    /// Whether `f64` evaluations take the compiled kernels.
    jit: bool,
}

/// How a [`RuntimeModel`] evaluates its derived expressions.
///
/// Both give the same numbers bit for bit (the same operations in the
/// same order, the same `libm`); they differ in cost. Dual numbers (the
/// derivative checks, linearizations and analyses) always take the tape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluator {
    /// The tape: a register machine over any scalar, on every platform.
    /// Reading a model costs nothing more than its derivation; each
    /// evaluation pays a dispatch per operation.
    Tape,
    /// Machine code compiled by Cranelift when the model is read (x86-64,
    /// aarch64, s390x and riscv64 hosts, with ezy-core's `jit` feature, on
    /// by default): the default where available.
    Jit,
}

impl Evaluator {
    /// The evaluator named `name` (`"tape"` or `"jit"`).
    ///
    /// # Errors
    /// Any other name, in a message that lists the two.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "tape" => Ok(Evaluator::Tape),
            "jit" => Ok(Evaluator::Jit),
            other => Err(format!("unknown evaluator `{other}`: use `tape` or `jit`")),
        }
    }
}

impl RuntimeModel {
    /// Reads, checks and derives the model `text` (what goes between the
    /// braces of `model! { ... }`).
    ///
    /// # Errors
    /// [`ModelTextError::Mistakes`] with every mistake found, each at its
    /// line and column, in the words of `model!`'s compile errors.
    pub fn from_text(text: &str) -> Result<Self, ModelTextError> {
        Self::read(text, None, None)
    }

    /// [`RuntimeModel::from_text`] evaluated by `evaluator` (the tape
    /// compiles nothing).
    ///
    /// # Errors
    /// As [`RuntimeModel::from_text`], and [`ModelTextError::NoJit`] for
    /// [`Evaluator::Jit`] where there is none.
    pub fn from_text_with(text: &str, evaluator: Evaluator) -> Result<Self, ModelTextError> {
        Self::read(text, None, Some(evaluator))
    }

    /// Reads the model file `path` (a `.ezy` file: the text of a
    /// [`RuntimeModel::from_text`]).
    ///
    /// # Errors
    /// [`ModelTextError::Read`] if it cannot be read, is not a regular
    /// file (a FIFO, a device: refused before anything is read) or is
    /// larger than [`MAX_TEXT_BYTES`] (at most one byte more is read); [`ModelTextError::Mistakes`] with the file's
    /// name on each mistake.
    pub fn from_file(path: &Path) -> Result<Self, ModelTextError> {
        Self::from_file_as(path, None)
    }

    /// [`RuntimeModel::from_file`] evaluated by `evaluator`.
    ///
    /// # Errors
    /// As [`RuntimeModel::from_file`], and [`ModelTextError::NoJit`] for
    /// [`Evaluator::Jit`] where there is none.
    pub fn from_file_with(path: &Path, evaluator: Evaluator) -> Result<Self, ModelTextError> {
        Self::from_file_as(path, Some(evaluator))
    }

    fn from_file_as(path: &Path, evaluator: Option<Evaluator>) -> Result<Self, ModelTextError> {
        let fail = |reason: String| ModelTextError::Read { file: path.to_path_buf(), reason };
        // a regular file only (a FIFO would block, /dev/zero never end),
        // and no more than MAX_TEXT_BYTES + 1 bytes of it read
        let text = crate::files::read_capped_text(path, MAX_TEXT_BYTES, "the model file").map_err(fail)?;
        Self::read(&text, Some(path), evaluator)
    }

    /// `evaluator`: `None` for the JIT where there is one, the tape
    /// otherwise.
    fn read(text: &str, file: Option<&Path>, evaluator: Option<Evaluator>) -> Result<Self, ModelTextError> {
        let mistakes =
            |m: Vec<TextMistake>| ModelTextError::Mistakes { file: file.map(Path::to_path_buf), mistakes: m };
        if text.len() as u64 > MAX_TEXT_BYTES {
            let message = format!("the text has {} bytes; a model has at most {MAX_TEXT_BYTES}", text.len());
            return Err(mistakes(vec![TextMistake { line: 1, column: 1, message }]));
        }
        if let Some(m) = too_deep(text) {
            return Err(mistakes(vec![m]));
        }
        // the parser and the derivation recurse into nested expressions
        // (`((..))`, `a + b + ...`): on a stack of their own, large enough
        // for the deepest expression a text of MAX_TEXT_BYTES can hold
        let owned = text.to_owned();
        let plan = std::thread::Builder::new()
            .name("ezy-derive-text".into())
            .stack_size(DERIVE_STACK_BYTES)
            .spawn(move || derive_plan(&owned))
            .map_err(|e| {
                mistakes(vec![TextMistake { line: 1, column: 1, message: format!("cannot start the derivation: {e}") }])
            })?
            .join()
            .unwrap_or_else(|_| {
                Err(vec![TextMistake {
                    line: 1,
                    column: 1,
                    message: "the derivation failed (an internal error in ezy)".into(),
                }])
            })
            .map_err(mistakes)?;
        let values: Vec<f64> = plan.params.iter().map(|p| p.default).collect();
        let layout = Layout::new(&plan.desc, &counts_of(&plan, &values));
        let model = Self { plan: Arc::new(plan), values, layout: Arc::new(layout), jit: false };
        match evaluator {
            Some(e) => model.with_evaluator(e),
            None => Ok(model.clone().with_evaluator(Evaluator::Jit).unwrap_or(model)),
        }
    }

    /// The model evaluated by `evaluator`: the JIT compiles its tapes (once
    /// per model text: clones share the code).
    ///
    /// # Errors
    /// [`ModelTextError::NoJit`] for [`Evaluator::Jit`] where there is no
    /// JIT (a build without the `jit` feature, a host without a Cranelift
    /// back end), or should Cranelift refuse the code.
    pub fn with_evaluator(mut self, evaluator: Evaluator) -> Result<Self, ModelTextError> {
        self.jit = match evaluator {
            Evaluator::Tape => false,
            Evaluator::Jit => {
                self.plan.compile().map_err(ModelTextError::NoJit)?;
                true
            }
        };
        Ok(self)
    }

    /// How the model evaluates (see [`Evaluator`]).
    pub fn evaluator(&self) -> Evaluator {
        if self.jit { Evaluator::Jit } else { Evaluator::Tape }
    }

    /// Operations in the model's tapes (how much code its text became).
    pub fn operations(&self) -> usize {
        self.plan.ops()
    }

    /// Whether the right-hand side on the minimal coordinates
    /// ([`Model::minimal_rhs`]) runs compiled whole: the JIT evaluates,
    /// the model has minimal coordinates with at most 8 speeds, and its
    /// kernels fit the JIT's budget. Otherwise the tapes evaluate it, with
    /// the same numbers, the same bits.
    pub fn compiled_minimal_rhs(&self) -> bool {
        #[cfg(feature = "jit")]
        if self.jit {
            return self.minimal().is_ok_and(|m| m.fused.compiled());
        }
        false
    }

    /// Runs `f` with scratch for the register machine: none where the
    /// compiled kernels evaluate (`f64` with the JIT), which need none.
    #[inline]
    fn scratch<S: Scalar, R>(&self, f: impl FnOnce(&mut [S]) -> R) -> R {
        if self.jit && std::any::TypeId::of::<S>() == std::any::TypeId::of::<f64>() {
            f(&mut [])
        } else {
            S::with_scratch(self.plan.registers, f)
        }
    }

    /// Evaluates, per element of each group `pick` gives a tape for, that
    /// tape into `a` and `b` ([`Tape::eval_to`]) at the offsets `at(group,
    /// element's first row, element's first value)` gives (`None`: the
    /// tape writes nothing there).
    fn each_group<S: Scalar>(
        &self,
        q: &[S],
        qd: &[S],
        pick: fn(&GroupPlan) -> Option<&Tape>,
        at: Offsets,
        a: &mut [S],
        b: &mut [S],
    ) {
        let (plan, l) = (&*self.plan, &*self.layout);
        self.scratch(|regs| {
            for (gi, (g, gd)) in plan.groups.iter().zip(plan.desc.groups.iter()).enumerate() {
                let Some(tape) = pick(g).filter(|_| !gd.slots.is_empty()) else { continue };
                let mut cols = [0usize; plan::MAX_SLOTS];
                let mut ix = [0.0f64; plan::MAX_INDICES];
                for (e, v) in l.elements(gd.family) {
                    for (c, s) in cols.iter_mut().zip(gd.slots.iter()) {
                        *c = l.body_column(&plan.desc, s, v);
                    }
                    for (x, a) in ix.iter_mut().zip(gd.indices.iter()) {
                        *x = a.at(v, &l.counts) as f64;
                    }
                    let (oa, ob) = at(g, l.row[gi] + e * gd.rows, l.val[gi] + e * gd.pattern.len());
                    let x = Inputs { params: &self.values, indices: &ix, cols: &cols, q, qd, compiled: self.jit };
                    let (a, b) = (oa.map_or(&mut [][..], |o| &mut a[o..]), ob.map_or(&mut [][..], |o| &mut b[o..]));
                    tape.eval_to(&x, regs, a, b);
                }
            }
        });
    }

    /// Evaluates the straight-line tape `pick` gives (a model without
    /// families) into `a` and `b` ([`Tape::eval_to`]); `false` for a model
    /// with families.
    fn straight<S: Scalar>(
        &self,
        q: &[S],
        qd: &[S],
        pick: fn(&plan::Straight) -> &Tape,
        a: &mut [S],
        b: &mut [S],
    ) -> bool {
        let Some(st) = &self.plan.straight else { return false };
        self.scratch(|regs| {
            let x = Inputs { params: &self.values, indices: &[], cols: &st.cols, q, qd, compiled: self.jit };
            pick(st).eval_to(&x, regs, a, b);
        });
        true
    }

    /// Evaluates a point tape (`pick`) for every point element, its two
    /// outputs to `out[2 k]`, `out[2 k + 1]` (`k` the element's index
    /// among all points).
    fn each_point<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S], pick: impl Fn(&plan::PointPlan) -> &Tape) {
        let (plan, l) = (&*self.plan, &*self.layout);
        self.scratch(|regs| {
            for (pi, (p, pd)) in plan.points.iter().zip(plan.desc.points.iter()).enumerate() {
                for (e, v) in l.elements(pd.family) {
                    let cols = [l.body_column(&plan.desc, &pd.body, v)];
                    let k = 2 * (l.point_index[pi] + e);
                    let x =
                        Inputs { params: &self.values, indices: &[v as f64], cols: &cols, q, qd, compiled: self.jit };
                    pick(p).eval_to(&x, regs, &mut out[k..], &mut []);
                }
            }
        });
    }
}

/// Where a group's element writes: from its first row and first value,
/// its offsets in [`Tape::eval_to`]'s two destinations (`None`: none).
type Offsets = fn(&GroupPlan, usize, usize) -> (Option<usize>, Option<usize>);

/// The stack the parser and the derivation run on \[bytes\]: reserved,
/// not committed, until a deep expression needs it.
const DERIVE_STACK_BYTES: usize = 1 << 30;

/// Most brackets `( [ {` open at once in a model's text (the built-in
/// models nest 3 deep); prefix operators and the like are bounded by
/// [`MAX_OPEN_OPERATORS`] (both checked before anything recurses).
pub use ezy_lang::depth::{MAX_NESTING, MAX_OPEN_OPERATORS};

/// The first bracket that opens more than [`MAX_NESTING`] at once, as a
/// mistake.
fn too_deep(text: &str) -> Option<TextMistake> {
    let (mut depth, mut line, mut column) = (0usize, 1usize, 0usize);
    for c in text.chars() {
        column += 1;
        match c {
            '\n' => (line, column) = (line + 1, 0),
            '(' | '[' | '{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    let message = format!("brackets nested more than {MAX_NESTING} deep; write the expression flatter");
                    return Some(TextMistake { line, column, message });
                }
            }
            ')' | ']' | '}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    None
}

/// Parses, checks and derives `text` and makes its [`Plan`]; every mistake
/// located (what [`RuntimeModel::read`] runs on a stack of its own).
fn derive_plan(text: &str) -> Result<Plan, Vec<TextMistake>> {
    let mut derived = ezy_lang::derive_text(text).map_err(|e| {
        e.into_iter()
            .map(|e| {
                let at = e.span().start();
                TextMistake { line: at.line.max(1), column: at.column + 1, message: e.to_string() }
            })
            .collect::<Vec<_>>()
    })?;
    let plan = Plan::new(&mut derived).map_err(|message| vec![TextMistake { line: 1, column: 1, message }])?;
    // a model its own declared counts make too large to set up is refused
    // here, at the counts, before anything of that size is allocated
    let values: Vec<f64> = plan.params.iter().map(|p| p.default).collect();
    let layout = Layout::new(&plan.desc, &counts_of(&plan, &values));
    let counts: Vec<(&str, usize)> =
        plan.params[plan.n_real..].iter().zip(&layout.counts).map(|(c, &v)| (c.name, v as usize)).collect();
    if let Err(message) = crate::model::info::check_model_size(layout.nq, &counts) {
        let at = derived.def.counts.first().map_or((1, 1), |c| {
            let at = c.name.span().start();
            (at.line.max(1), at.column + 1)
        });
        return Err(vec![TextMistake { line: at.0, column: at.1, message }]);
    }
    Ok(plan)
}

/// The counts among `values` (the real parameters first).
fn counts_of(plan: &Plan, values: &[f64]) -> Vec<i64> {
    values[plan.n_real..].iter().map(|&c| c as i64).collect()
}

impl Model for RuntimeModel {
    fn info(&self) -> ModelInfo {
        describe::info_at(&self.plan.desc, &self.layout)
    }

    fn equations(&self) -> Equations {
        describe::equations_at(&self.plan.desc, &self.layout)
    }

    fn check_counts(&self) -> Result<(), String> {
        let (plan, l) = (&*self.plan, &*self.layout);
        f64::with_scratch(plan.registers, |regs| {
            describe::check_counts_at(&plan.desc, l, &mut |gi, v| {
                let ix: Vec<f64> = plan.desc.groups[gi].indices.iter().map(|a| a.at(v, &l.counts) as f64).collect();
                let tape = plan.groups[gi].direction.as_ref().expect("a group whose direction is checked has its tape");
                let mut t = [0.0; 2];
                tape.eval(&Inputs::fixed(&self.values, &ix), regs, |j, x| t[j] = x);
                t
            })
        })
    }

    fn param(&self, index: usize) -> f64 {
        match self.values.get(index) {
            Some(&v) => v,
            None => panic!("parameter index {index} out of range"),
        }
    }

    fn set_param(&mut self, index: usize, value: f64) {
        assert!(index < self.values.len(), "parameter index {index} out of range");
        if index >= self.plan.n_real {
            let name = self.plan.params[index].name;
            assert!(
                value >= 1.0 && value.fract() == 0.0 && value <= 1e9,
                "count `{name}` must be a whole number >= 1, got {value}"
            );
            self.values[index] = value;
            self.layout = Arc::new(Layout::new(&self.plan.desc, &counts_of(&self.plan, &self.values)));
        } else {
            self.values[index] = value;
        }
    }

    /// A model without families: its products with `G` are summed in the
    /// order `model!`'s straight-line ones sum them (and so give the same
    /// numbers), and the KKT solve takes the dense path as for a compiled
    /// model.
    fn unrolled_kernels(&self) -> bool {
        self.plan.straight.is_some()
    }

    fn normal_matrix(&self, pattern: &[(usize, usize)], nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
        let Some(st) = &self.plan.straight else {
            return crate::model::info::normal_matrix_at(pattern, nc, values, winv, a);
        };
        for (idx, terms) in &st.normal {
            let terms = &st.normal_terms[terms.clone()];
            a[*idx] = match terms.split_first() {
                None => 0.0,
                Some((&[e1, e2, k], rest)) => {
                    let mut sum = values[e1] * values[e2] * winv[k];
                    for &[e1, e2, k] in rest {
                        sum += values[e1] * values[e2] * winv[k];
                    }
                    sum
                }
            };
        }
    }

    fn sub_winv_gt_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
        let Some(st) = &self.plan.straight else {
            for (&(r, c), &g) in pattern.iter().zip(values) {
                v[c] -= winv[c] * (g * x[r]);
            }
            return;
        };
        for (k, entries) in &st.by_column {
            let mut sum = values[entries[0].0] * x[entries[0].1];
            for &(e, r) in &entries[1..] {
                sum += values[e] * x[r];
            }
            v[*k] -= winv[*k] * sum;
        }
    }

    fn mass_diagonal(&self, out: &mut [f64]) {
        let (plan, l) = (&*self.plan, &*self.layout);
        f64::with_scratch(plan.registers, |regs| {
            for (bi, (b, bd)) in plan.bodies.iter().zip(plan.desc.bodies.iter()).enumerate() {
                for (e, v) in l.elements(bd.family) {
                    let k = l.body_off[bi] + 3 * e;
                    b.mass.eval(&Inputs::fixed(&self.values, &[v as f64]), regs, |j, x| out[k + j] = x);
                }
            }
        });
    }

    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
        let (plan, l) = (&*self.plan, &*self.layout);
        f64::with_scratch(plan.registers, |regs| {
            for (pi, (p, pd)) in plan.points.iter().zip(plan.desc.points.iter()).enumerate() {
                for (e, v) in l.elements(pd.family) {
                    let k = 2 * (l.point_index[pi] + e);
                    p.local.eval(&Inputs::fixed(&self.values, &[v as f64]), regs, |j, x| points[k + j] = x);
                }
            }
            for (gi, tape) in &plan.blades {
                for (e, v) in l.elements(plan.desc.groups[*gi].family) {
                    let k = 2 * (l.item_index[*gi] + e);
                    tape.eval(&Inputs::fixed(&self.values, &[v as f64]), regs, |j, x| blades[k + j] = x);
                }
            }
        });
    }

    fn phi<S: Scalar>(&self, q: &[S], phi: &mut [S]) {
        if self.straight(q, &[], |st| &st.phi, phi, &mut []) {
            return;
        }
        self.each_group(q, &[], |g| g.holonomic().then_some(&g.phi), |_, rb, _| (Some(rb), None), phi, &mut []);
    }

    fn holonomic_jacobian<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        if self.straight(q, &[], |st| &st.jacobian, values, &mut []) {
            return;
        }
        self.each_group(q, &[], |g| g.holonomic().then_some(&g.g), |_, _, vb| (Some(vb), None), values, &mut []);
    }

    fn constraint_matrix<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        if self.straight(q, &[], |st| &st.g, values, &mut []) {
            return;
        }
        self.each_group(q, &[], |g| Some(&g.g), |_, _, vb| (Some(vb), None), values, &mut []);
    }

    fn phi_and_constraint_matrix<S: Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
        if self.straight(q, &[], |st| &st.phi_g, phi, values) {
            return;
        }
        self.each_group(q, &[], |g| Some(&g.phi_g), |g, rb, vb| (g.holonomic().then_some(rb), Some(vb)), phi, values);
    }

    fn constraint_terms<S: Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
        if self.straight(q, qd, |st| &st.terms, values, gamma) {
            return;
        }
        self.each_group(q, qd, |g| Some(&g.terms), |_, rb, vb| (Some(vb), Some(rb)), values, gamma);
    }

    fn points<S: Scalar>(&self, q: &[S], out: &mut [S]) {
        if self.straight(q, &[], |st| &st.points, out, &mut []) {
            return;
        }
        self.each_point(q, &[], out, |p| &p.pos);
    }

    fn point_velocities<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
        if self.straight(q, qd, |st| &st.vel, out, &mut []) {
            return;
        }
        self.each_point(q, qd, out, |p| &p.vel);
    }

    fn minimal_layout(&self) -> Result<crate::model::info::MinimalLayout, String> {
        let m = self.minimal()?;
        let mut pivots: Vec<(String, usize, f64)> = m.pivots.iter().map(|(n, k)| (n.clone(), *k, 0.0)).collect();
        f64::with_scratch(self.plan.registers, |regs| {
            m.pivot_values.eval(&Inputs::fixed(&self.values, &[]), regs, |j, x| pivots[j].2 = x);
        });
        Ok(crate::model::info::MinimalLayout { coords: m.coords.clone(), speeds: m.speeds.clone(), pivots })
    }

    fn minimal_expand<S: Scalar>(&self, q: &mut [S], qd: &mut [S], b: &mut [S], c: &mut [S]) {
        let Ok(m) = self.minimal() else { return };
        self.minimal_outputs(&m.expand, q, qd, |j, x, q, qd| {
            let (nd, nq, nb) = (m.q_dep.len(), qd.len(), b.len());
            if j < nd {
                q[m.q_dep[j]] = x;
            } else if j < nd + nq {
                qd[j - nd] = x;
            } else if j < nd + nq + nb {
                b[j - nd - nq] = x;
            } else {
                c[j - nd - nq - nb] = x;
            }
        });
    }

    /// The fused right-hand side's parameter-only subexpressions, computed
    /// once per parameter change (as `model!` hoists them).
    fn minimal_constants(&self) -> Option<Vec<f64>> {
        self.minimal().ok().map(|m| m.fused.table(&self.values, self.plan.registers))
    }

    fn minimal_rhs<E, F>(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: F,
    ) -> Result<(), crate::model::MinimalRhsError<E>>
    where
        F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
    {
        let Some(call) = self.fused_call(k) else { return Ok(()) };
        fused::rhs(&call, false, z, q, qd, dz, forces)
    }

    fn minimal_rhs_lean<E, F>(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: F,
    ) -> Result<(), crate::model::MinimalRhsError<E>>
    where
        F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
    {
        let Some(call) = self.fused_call(k) else { return Ok(()) };
        fused::rhs(&call, true, z, q, qd, dz, forces)
    }

    fn minimal_state<S: Scalar>(&self, q: &mut [S], qd: &mut [S]) -> bool {
        let Ok(m) = self.minimal() else { return false };
        self.minimal_outputs(&m.state, q, qd, |j, x, q, qd| {
            let nd = m.q_dep.len();
            if j < nd { q[m.q_dep[j]] = x } else { qd[j - nd] = x }
        });
        true
    }
}

impl RuntimeModel {
    /// What the fused right-hand side reads besides the state, with the
    /// table `k` of [`Model::minimal_constants`]; `None` without minimal
    /// coordinates.
    #[inline(always)]
    fn fused_call<'a>(&'a self, k: &'a [f64]) -> Option<fused::FusedCall<'a>> {
        let (Ok(m), Some(st)) = (self.minimal(), &self.plan.straight) else { return None };
        Some(fused::FusedCall {
            fused: &m.fused,
            params: &self.values,
            table: k,
            cols: &st.cols,
            coords: &m.coords,
            speeds: &m.speeds,
            compiled: self.jit,
        })
    }

    /// The minimal coordinates, or why there are none.
    #[inline]
    fn minimal(&self) -> Result<&plan::MinimalPlan, String> {
        match &self.plan.straight {
            Some(st) => st.minimal.as_ref().map_err(Clone::clone),
            None => Err(format!(
                "model {} has no minimal coordinates: it has families (`for`), whose minimal form is not derived yet",
                self.plan.desc.name
            )),
        }
    }

    /// Evaluates a minimal-coordinate tape on the kept coordinates in `q`
    /// and the speeds in `qd` (read before anything is written), then
    /// hands each output to `write(j, value, q, qd)`.
    fn minimal_outputs<S: Scalar>(
        &self,
        tape: &Tape,
        q: &mut [S],
        qd: &mut [S],
        mut write: impl FnMut(usize, S, &mut [S], &mut [S]),
    ) {
        let st = self.plan.straight.as_ref().expect("a model with minimal coordinates has no families");
        S::with_scratch(self.plan.registers, |regs| {
            tape.eval_in(
                &Inputs { params: &self.values, indices: &[], cols: &st.cols, q, qd, compiled: self.jit },
                regs,
            );
            for j in 0..tape.outputs() {
                write(j, regs[tape.output_at(j)], q, qd);
            }
        });
    }
}
