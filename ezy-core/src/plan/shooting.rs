//! The shooting segments of a plan: each segment's problem built from its
//! input nodes and its start state, its run with the sensitivities of its
//! end state, and the equality constraints and effort assembled from them.
//!
//! A node's state is given by its independent components (a partition of
//! `q` and `qd` chosen at the node's warm-start state, as the reduced
//! formulation chooses one: `crate::formulation::reduced`); the problem's
//! consistent initial state completes the dependent ones, so every
//! segment starts on the constraints.

use std::sync::Arc;

use super::BuildInputs;
use crate::analysis::AnalysisError;
use crate::effects::waveform::{Extrapolate, Table};
use crate::error::SimError;
use crate::formulation::initial::Given;
use crate::formulation::reduced::Partition;
use crate::formulation::reduced::lu::pivot_columns;
use crate::model::Model;
use crate::problem::Problem;
use crate::sensitivity::Parameter;

/// How one segment's problem is built: the user's closure, the segment's
/// duration, its inputs' end values and (for every node but the first)
/// its start's independent components.
pub(super) struct SegmentSpec<M: Model> {
    build: Arc<BuildInputs<M>>,
    /// Duration \[s\].
    h: f64,
    /// `[a_0, b_0, a_1, b_1, ...]`: input `j` from `a_j` to `b_j`.
    u: Vec<f64>,
    /// The start: its partition and dependent guesses, and `z`.
    start: Option<(Arc<NodeStart>, Vec<f64>)>,
}

impl<M: Model> Clone for SegmentSpec<M> {
    fn clone(&self) -> Self {
        Self { build: Arc::clone(&self.build), h: self.h, u: self.u.clone(), start: self.start.clone() }
    }
}

/// A node's partition of the state into independent components (the
/// unknowns) and dependent ones, with the dependent coordinates' guess.
#[derive(Debug, Clone)]
pub(super) struct NodeStart {
    pub partition: Partition,
    /// The dependent coordinates' values where Newton's method starts.
    pub guess: Vec<f64>,
    /// The independent components as indices into `[q, qd]` (2 nq).
    pub comps: Vec<usize>,
    /// The start is the last segment's end, every component of `[q,
    /// qd]` given (a segment inside a shooting interval, not a node: the
    /// consistent initial state projects it onto the constraints, which
    /// it meets to the run's accuracy).
    pub chained: bool,
}

impl NodeStart {
    /// The start of a chained segment: every component of `[q, qd]`
    /// (2 nq) given, the last segment's end.
    pub fn chained(n2: usize) -> Self {
        let empty = Partition { q_ind: Vec::new(), v_ind: Vec::new(), q_dep: Vec::new(), v_dep: Vec::new() };
        Self { partition: empty, guess: Vec::new(), comps: (0..n2).collect(), chained: true }
    }
}

impl<M: Model> SegmentSpec<M> {
    /// The segment's problem: the user's, its clock from 0 to `h`, its
    /// start given by `z` where this is not the first segment.
    pub fn problem(&self) -> Result<Problem<M>, SimError> {
        let tables: Vec<Table> = self
            .u
            .chunks_exact(2)
            .map(|ab| Table { t: vec![0.0, self.h], value: ab.to_vec(), extrapolate: Extrapolate::Hold })
            .collect();
        let mut p = (self.build)(&tables)?;
        p.settings.t_end = self.h;
        p.settings.every = self.h;
        if let Some((node, z)) = &self.start {
            let part = &node.partition;
            let nqi = part.q_ind.len();
            if node.chained {
                let nq = z.len() / 2;
                p.given = Given {
                    q: (0..nq).map(|i| (i, z[i])).collect(),
                    qd: (0..nq).map(|i| (i, z[nq + i])).collect(),
                    ..Given::default()
                };
                return Ok(p);
            }
            p.given = Given {
                q: part.q_ind.iter().copied().zip(z[..nqi].iter().copied()).collect(),
                qd: part.v_ind.iter().copied().zip(z[nqi..].iter().copied()).collect(),
                angles: Vec::new(),
                guess: part.q_dep.iter().copied().zip(node.guess.iter().copied()).collect(),
                released: Vec::new(),
            };
        }
        Ok(p)
    }
}

/// The partition of `[q, qd]` at the consistent state `x` (2 nq) of
/// `model`: the dependent columns of `C_q` and of `G` by Gaussian
/// elimination with full pivoting, translations preferred (as the reduced
/// formulation chooses them).
///
/// # Errors
/// [`AnalysisError::Numerics`] where the constraint rows are dependent at `x`.
pub(super) fn node_start<M: Model>(model: &M, x: &[f64], node: usize) -> Result<NodeStart, AnalysisError> {
    let info = model.info();
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    let mut g = vec![0.0; info.pattern.len()];
    model.constraint_matrix(&x[..nq], &mut g);
    let mut dense = vec![0.0; nc * nq];
    crate::model::info::scatter_dense(&info.pattern, &g, nq, &mut dense);
    let mut prefer = vec![false; nq];
    for b in &info.bodies {
        prefer[b.coords[0]] = true;
        prefer[b.coords[1]] = true;
    }
    let dependent = |rows: usize, k: usize| AnalysisError::Numerics {
        reason: format!(
            "at node {node} only {k} of the {rows} constraint rows are independent: a plan's nodes need independent constraints"
        ),
    };
    let q_dep = pivot_columns(&mut dense[..nh * nq].to_vec(), nh, nq, &prefer).map_err(|k| dependent(nh, k))?;
    let v_dep = pivot_columns(&mut dense, nc, nq, &prefer).map_err(|k| dependent(nc, k))?;
    let rest = |dep: &[usize]| (0..nq).filter(|j| !dep.contains(j)).collect::<Vec<_>>();
    let partition = Partition { q_ind: rest(&q_dep), v_ind: rest(&v_dep), q_dep, v_dep };
    let comps = partition.q_ind.iter().copied().chain(partition.v_ind.iter().map(|j| nq + j)).collect();
    let guess = partition.q_dep.iter().map(|&j| x[j]).collect();
    Ok(NodeStart { partition, guess, comps, chained: false })
}

/// One segment's run: its start and end states (2 nq each) and the end
/// state's sensitivities to the segment's parameters, `[z..., u...]`
/// (one column of 2 nq per parameter).
pub(super) struct SegmentRun {
    pub start: Vec<f64>,
    pub end: Vec<f64>,
    pub columns: Vec<Vec<f64>>,
    /// The state's rate `[qd, qdd]` at the end (2 nq), where asked (a
    /// free duration's chain: the run extended by `dt` ends `rate dt`
    /// further).
    pub rate: Option<Vec<f64>>,
}

impl<M: Model> SegmentSpec<M> {
    /// A segment of `h` seconds from `u` (two values per input) and start.
    pub fn new(build: &Arc<BuildInputs<M>>, h: f64, u: Vec<f64>, start: Option<(Arc<NodeStart>, Vec<f64>)>) -> Self {
        Self { build: Arc::clone(build), h, u, start }
    }

    /// The parameters the segment's end depends on: the start's
    /// independent components (named `z.<state>`), then each input's two
    /// nodes (`<input>[0]`, `<input>[1]`, the segment's own).
    fn parameters(&self, names: &[String], inputs: &[String]) -> Vec<Parameter<M>> {
        let mut out = Vec::new();
        if let Some((node, z)) = &self.start {
            for (i, &c) in node.comps.iter().enumerate() {
                let spec = self.clone();
                out.push(Parameter::new(format!("z.{}", names[c]), z[i], move |v| {
                    let mut s = spec.clone();
                    if let Some((_, z)) = &mut s.start {
                        z[i] = v;
                    }
                    s.problem()
                }));
            }
        }
        for (k, &value) in self.u.iter().enumerate() {
            let spec = self.clone();
            out.push(Parameter::new(format!("{}[{}]", inputs[k / 2], k % 2), value, move |v| {
                let mut s = spec.clone();
                s.u[k] = v;
                s.problem()
            }));
        }
        out
    }

    /// The segment's run with its sensitivities, `stop` asked at every
    /// step.
    ///
    /// # Errors
    /// The problem's or the sensitivity run's; [`AnalysisError::Stopped`].
    pub fn run(&self, inputs: &[String], stop: Option<fn() -> bool>, rate: bool) -> Result<SegmentRun, AnalysisError> {
        let problem = self.problem()?;
        let names = problem.state_names();
        let n2 = 2 * problem.model.info().nq();
        let (x0, _) = problem.initial_state()?;
        let params = self.parameters(&names, inputs);
        let sens = problem.sensitivities_at(&params, &[self.h], stop)?;
        let (Some(x), Some(s)) = (sens.x.last(), sens.s.last()) else {
            return Err(AnalysisError::Numerics { reason: "a segment's run gave no end state".into() });
        };
        let end = x[..n2].to_vec();
        let rate = if rate {
            let (mut analysis, _) = problem.analysis()?;
            Some(analysis.rhs(self.h, &end)?)
        } else {
            None
        };
        Ok(SegmentRun {
            start: x0[..n2].to_vec(),
            end,
            columns: s.chunks_exact(n2).map(<[f64]>::to_vec).collect(),
            rate,
        })
    }

    /// The segment's plain run (no sensitivities): its start and end.
    ///
    /// # Errors
    /// The problem's or the run's.
    pub fn simulate(&self) -> Result<(Vec<f64>, Vec<f64>), AnalysisError> {
        let problem = self.problem()?;
        let n2 = 2 * problem.model.info().nq();
        let (x0, _) = problem.initial_state()?;
        let solution = problem.solve()?;
        Ok((x0[..n2].to_vec(), solution.final_state()[..n2].to_vec()))
    }
}
