//! Direct multiple shooting's unknowns, constraints and objective (Bock &
//! Plitt 1984; Betts, *Practical Methods for Optimal Control*, 2nd ed.,
//! §4.4-4.5): the input nodes and the nodes' independent state
//! components, the continuity of the state across the nodes and the
//! target at the end, and the effort of the piecewise-linear inputs.
//!
//! Unknowns `w` (n): input `j`'s value at node `k` at `j (N + 1) + k`
//! (N segments, N + 1 nodes), then the independent components of nodes
//! `1 ... N-1` in order (node 0 is the problem's own initial state).
//! Constraints `c(w) = 0`: for each join `k` (the end of segment `k`, the
//! start of `k + 1`) the end state's independent components of node
//! `k + 1` minus that node's unknowns; then the target's components of
//! the last segment's end minus their values. The objective
//! ([`super::objective`]): the effort times its weight plus the user's
//! term of the nodes' samples, differentiated through the chain.

use std::sync::Arc;

use super::BuildInputs;
use super::objective::{self, Objective, SampleNames, Samples};
use super::path::{self, Resolved, Row};
use super::shooting::{NodeStart, SegmentSpec, node_start};
use crate::analysis::AnalysisError;
use crate::model::Model;

/// A point of the transcription: its values and derivatives.
#[derive(Debug, Clone)]
pub(super) struct Point {
    /// The unknowns (n).
    pub w: Vec<f64>,
    /// `sum_j int u_j^2 dt` \[input unit^2 s\].
    pub effort: f64,
    /// The user's term `J_user(samples)`, if the objective has one.
    pub user: Option<f64>,
    /// The objective `effort_weight * effort + J_user`.
    pub objective: f64,
    /// Its gradient (n).
    pub objective_grad: Vec<f64>,
    /// The user's term's gradient (n; empty without one).
    pub user_grad: Vec<f64>,
    /// Some node's state moves with the inputs (its sensitivity to an
    /// input node is not zero).
    pub acts: bool,
    /// The constraints (m), in the units of their state components.
    pub c: Vec<f64>,
    /// Their Jacobian, row by row (m x n).
    pub jac: Vec<Vec<f64>>,
    /// The path constraints' inequalities `g <= 0` (p), in their
    /// functions' units.
    pub g: Vec<f64>,
    /// Their Jacobian, row by row (p x n).
    pub g_jac: Vec<Vec<f64>>,
    /// Each segment's start and end state (N of 2 nq each).
    pub starts: Vec<Vec<f64>>,
    pub ends: Vec<Vec<f64>>,
}

/// Whether node `k` of `segments` starts one of `intervals` shooting
/// intervals (its state an unknown; else the segment is chained to the
/// last one's end).
pub(super) fn is_node(k: usize, segments: usize, intervals: usize) -> bool {
    let m = intervals.clamp(1, segments);
    (1..m).any(|j| (j * segments + m / 2) / m == k)
}

/// The transcription of a plan.
pub(super) struct Transcription<M: Model> {
    build: Arc<BuildInputs<M>>,
    pub inputs: Vec<String>,
    pub segments: usize,
    pub h: f64,
    /// The state's names (2 nq).
    pub names: Vec<String>,
    /// Nodes `1 ... N-1`'s partitions (index 0 unused).
    nodes: Vec<Option<Arc<NodeStart>>>,
    /// Where node `k`'s unknowns start in `w`.
    z_offset: Vec<usize>,
    /// Unknowns.
    pub n: usize,
    /// The target's rows kept as constraints: `(index in [q, qd], value)`.
    pub target: Vec<(usize, f64)>,
    /// Each constraint's name and its state component (for its scale).
    pub rows: Vec<(String, usize)>,
    /// Segment runs made (with sensitivities or plain).
    pub runs: usize,
    /// Asked before each segment and at every step of its run.
    pub stop: Option<fn() -> bool>,
    /// What is minimized.
    pub objective: Objective,
    /// The nodes' times \[s\] (N + 1).
    pub t: Vec<f64>,
    /// The user's term failed (or was not finite): why; the search ends.
    pub objective_error: Option<String>,
    /// The user's term was differenced at some evaluation.
    pub differenced: bool,
    /// The path constraints, resolved.
    pub path: Vec<Resolved>,
    /// Their inequality rows and names (p).
    pub path_rows: Vec<(Row, String)>,
    /// A path constraint's function was differenced at some evaluation.
    pub path_differenced: bool,
    /// The duration `T` is the last unknown ([`Transcription::free_time`]).
    pub free_time: bool,
}

impl<M: Model> Transcription<M> {
    /// The layout for `segments` segments of `h` \[s\] over `inputs`, the
    /// nodes partitioned at the states `x` (N + 1 of 2 nq: a warm start's).
    pub fn new(
        build: &Arc<BuildInputs<M>>,
        inputs: Vec<String>,
        (segments, h, intervals): (usize, f64, usize),
        model: &M,
        x: &[Vec<f64>],
    ) -> Result<Self, AnalysisError> {
        let n_u = inputs.len() * (segments + 1);
        let (mut nodes, mut z_offset, mut n) = (vec![None], vec![0], n_u);
        let n2 = 2 * model.info().nq();
        let chained = Arc::new(NodeStart::chained(n2));
        for (k, xk) in x.iter().enumerate().take(segments).skip(1) {
            if !is_node(k, segments, intervals) {
                z_offset.push(n);
                nodes.push(Some(Arc::clone(&chained)));
                continue;
            }
            let node = node_start(model, xk, k)?;
            z_offset.push(n);
            n += node.comps.len();
            nodes.push(Some(Arc::new(node)));
        }
        let info = model.info();
        let names = crate::formulation::dae::state_names(&info.coords, &[], &[]);
        Ok(Self {
            build: Arc::clone(build),
            inputs,
            segments,
            h,
            names,
            nodes,
            z_offset,
            n,
            target: Vec::new(),
            rows: Vec::new(),
            runs: 0,
            stop: None,
            objective: Objective::effort(),
            t: (0..=segments).map(|k| k as f64 * h).collect(),
            objective_error: None,
            differenced: false,
            path: Vec::new(),
            path_rows: Vec::new(),
            path_differenced: false,
            free_time: false,
        })
    }

    /// The nodes `1 ... N-1` partitioned again at the states `x` (N + 1
    /// of 2 nq): as many unknowns, other components maybe.
    ///
    /// # Errors
    /// As [`node_start`].
    pub fn repartition(&mut self, model: &M, x: &[Vec<f64>]) -> Result<(), AnalysisError> {
        for (k, xk) in x.iter().enumerate().take(self.segments).skip(1) {
            if self.nodes[k].as_ref().is_some_and(|n| n.chained) {
                continue;
            }
            let node = node_start(model, xk, k)?;
            if node.comps.len() != self.nodes[k].as_ref().map_or(0, |n| n.comps.len()) {
                return Err(AnalysisError::Numerics { reason: format!("node {k}'s partition changed its size") });
            }
            self.nodes[k] = Some(Arc::new(node));
        }
        let target = std::mem::take(&mut self.target);
        self.set_target(target);
        Ok(())
    }

    /// The nodes' unknowns: `(column in w, index in [q, qd])`.
    pub fn state_columns(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (k, node) in self.nodes.iter().enumerate() {
            if let Some(node) = node.as_ref().filter(|n| !n.chained) {
                out.extend(node.comps.iter().enumerate().map(|(i, &c)| (self.z_offset[k] + i, c)));
            }
        }
        out
    }

    /// Unknowns of the inputs.
    pub fn n_inputs(&self) -> usize {
        self.inputs.len() * (self.segments + 1)
    }

    /// Sets the target's rows and names every constraint.
    pub fn set_target(&mut self, target: Vec<(usize, f64)>) {
        let mut rows = Vec::new();
        for (k, node) in self.nodes.iter().enumerate() {
            if let Some(node) = node.as_ref().filter(|n| !n.chained) {
                rows.extend(node.comps.iter().map(|&c| (format!("continuity of {} at node {k}", self.names[c]), c)));
            }
        }
        rows.extend(target.iter().map(|&(c, v)| (format!("target {} = {v}", self.names[c]), c)));
        self.target = target;
        self.rows = rows;
    }

    /// Makes the duration `T` an unknown, the last (`n` grows by one).
    pub fn free_time(&mut self) {
        if !self.free_time {
            self.free_time = true;
            self.n += 1;
        }
    }

    /// The column of the duration `T` (a free duration's).
    pub fn col_t(&self) -> usize {
        self.n - 1
    }

    /// The segments' duration at `w` \[s\]: `T / N` with a free duration.
    pub fn h_at(&self, w: &[f64]) -> f64 {
        if self.free_time { w[self.col_t()] / self.segments as f64 } else { self.h }
    }

    /// The nodes' times at `w` \[s\] (N + 1; the last exactly `T`).
    pub fn mesh_at(&self, w: &[f64]) -> Vec<f64> {
        if !self.free_time {
            return self.t.clone();
        }
        let (n, t) = (self.segments, w[self.col_t()]);
        (0..=n).map(|k| if k == n { t } else { t * k as f64 / n as f64 }).collect()
    }

    /// Sets the path constraints and names their rows at the nodes' times.
    pub fn set_path(&mut self, path: Vec<Resolved>) {
        self.path_rows = path::rows(&path, &self.t);
        self.path = path;
    }

    /// The name of constraint row `i`: an equality's (`i < m`), then a
    /// path inequality's.
    pub fn row_name(&self, i: usize) -> String {
        match self.rows.get(i) {
            Some(r) => r.0.clone(),
            None => self.path_rows.get(i - self.rows.len()).map(|r| r.1.clone()).unwrap_or_default(),
        }
    }

    /// Column of input `j` at node `k`.
    pub fn col_u(&self, j: usize, k: usize) -> usize {
        j * (self.segments + 1) + k
    }

    /// Input `j`'s node values in `w` (N + 1).
    pub fn input_nodes<'w>(&self, w: &'w [f64], j: usize) -> &'w [f64] {
        &w[self.col_u(j, 0)..=self.col_u(j, self.segments)]
    }

    /// Segment `k`'s problem builder at `w` (`previous`: the last
    /// segment's end, the start of a chained segment).
    pub fn spec(&self, k: usize, w: &[f64], previous: Option<&[f64]>) -> SegmentSpec<M> {
        let u = (0..self.inputs.len()).flat_map(|j| [w[self.col_u(j, k)], w[self.col_u(j, k + 1)]]).collect();
        let start = self.nodes[k].as_ref().map(|node| {
            let o = self.z_offset[k];
            let z = if node.chained {
                previous.map(<[f64]>::to_vec).unwrap_or_default()
            } else {
                w[o..o + node.comps.len()].to_vec()
            };
            (Arc::clone(node), z)
        });
        SegmentSpec::new(&self.build, self.h_at(w), u, start)
    }

    /// The effort `sum_j sum_k h/3 (a^2 + a b + b^2)` of the
    /// piecewise-linear inputs at `w` (exact) and its gradient (with a
    /// free duration, `d e / d T = e / T`: the effort is linear in `h`).
    pub fn effort(&self, w: &[f64]) -> (f64, Vec<f64>) {
        let mut g = vec![0.0; self.n];
        let mut e = 0.0;
        let h3 = self.h_at(w) / 3.0;
        for j in 0..self.inputs.len() {
            for k in 0..self.segments {
                let (ia, ib) = (self.col_u(j, k), self.col_u(j, k + 1));
                let (a, b) = (w[ia], w[ib]);
                e += h3 * (a * a + a * b + b * b);
                g[ia] += h3 * (2.0 * a + b);
                g[ib] += h3 * (a + 2.0 * b);
            }
        }
        if self.free_time {
            g[self.col_t()] = e / w[self.col_t()];
        }
        (e, g)
    }

    /// The point at `w`: every segment run with its sensitivities, a
    /// chained segment's start (the last one's end) differentiated
    /// through the chain.
    ///
    /// # Errors
    /// A segment's problem or run that fails; [`AnalysisError::Stopped`]
    /// where the stop hook says so.
    pub fn evaluate(&mut self, w: &[f64]) -> Result<Point, AnalysisError> {
        let (effort, effort_grad) = self.effort(w);
        self.t = self.mesh_at(w);
        let (mut starts, mut ends, mut c, mut jac) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let n2 = self.names.len();
        // the derivative of the last segment's end with respect to w (2 nq x n)
        let mut d_end: Vec<Vec<f64>> = vec![vec![0.0; self.n]; n2];
        // each segment's end's, kept for a user's objective of the samples
        let mut d_ends: Vec<Vec<Vec<f64>>> = Vec::new();
        let n_u = self.n_inputs();
        let mut acts = false;
        let mut previous: Option<Vec<f64>> = None;
        for k in 0..self.segments {
            if self.stop.is_some_and(|s| s()) {
                return Err(AnalysisError::Stopped);
            }
            let run = self.spec(k, w, previous.as_deref()).run(&self.inputs, self.stop, self.free_time)?;
            self.runs += 1;
            let node = self.nodes[k].clone();
            let nz = node.as_ref().map_or(0, |n| n.comps.len());
            let mut d: Vec<Vec<f64>> = vec![vec![0.0; self.n]; n2];
            for (p, s) in run.columns.iter().enumerate() {
                if p < nz {
                    let node = node.as_ref().expect("a start's parameters");
                    if node.chained {
                        // dz/dw is the last end's derivative
                        let from = &d_end[node.comps[p]];
                        for (row, sv) in d.iter_mut().zip(s) {
                            if *sv != 0.0 {
                                row.iter_mut().zip(from).for_each(|(a, b)| *a += sv * b);
                            }
                        }
                    } else {
                        let col = self.z_offset[k] + p;
                        d.iter_mut().zip(s).for_each(|(row, sv)| row[col] += sv);
                    }
                } else {
                    let j = (p - nz) / 2;
                    let col = self.col_u(j, k + (p - nz) % 2);
                    d.iter_mut().zip(s).for_each(|(row, sv)| row[col] += sv);
                }
            }
            if let Some(rate) = &run.rate {
                self.chain_duration(&mut d, (k, nz), w, (rate, &run.columns));
            }
            let mut row_of = |comp: usize, value: f64, own: Option<usize>| {
                let mut row = d[comp].clone();
                if let Some(o) = own {
                    row[o] -= 1.0;
                }
                c.push(run.end[comp] - value);
                jac.push(row);
            };
            match self.nodes.get(k + 1).and_then(Option::as_ref) {
                Some(next) if k + 1 < self.segments && !next.chained => {
                    let o = self.z_offset[k + 1];
                    for (i, &comp) in next.comps.iter().enumerate() {
                        row_of(comp, w[o + i], Some(o + i));
                    }
                }
                Some(_) if k + 1 < self.segments => {}
                _ => {
                    for &(comp, value) in &self.target {
                        row_of(comp, value, None);
                    }
                }
            }
            // the dependent coordinates' guess follows the start
            if let Some(node) = self.nodes[k].as_mut().filter(|n| !n.chained) {
                let node = Arc::make_mut(node);
                node.guess = node.partition.q_dep.iter().map(|&j| run.start[j]).collect();
            }
            acts = acts || d.iter().any(|row| row[..n_u].iter().any(|v| *v != 0.0));
            if self.objective.user.is_some() || !self.path.is_empty() {
                d_ends.push(d.clone());
            }
            d_end = d;
            previous = Some(run.end.clone());
            starts.push(run.start);
            ends.push(run.end);
        }
        let weight = self.objective.effort_weight;
        let mut objective_grad: Vec<f64> = effort_grad.iter().map(|g| weight * g).collect();
        let time = if self.free_time {
            objective_grad[self.col_t()] += self.objective.time_weight;
            self.objective.time_weight * w[self.col_t()]
        } else {
            self.objective.time_weight * self.t.last().copied().unwrap_or(0.0)
        };
        let (user, user_grad) = match self.user_term(w, &starts, &ends, &d_ends) {
            Ok(Some((value, grad))) => {
                objective_grad.iter_mut().zip(&grad).for_each(|(a, b)| *a += b);
                (Some(value), grad)
            }
            Ok(None) => (None, Vec::new()),
            Err(reason) => {
                self.objective_error = Some(reason.clone());
                return Err(AnalysisError::Request { reason });
            }
        };
        let objective = weight * effort + time + user.unwrap_or(0.0);
        let (g, g_jac) = match self.path_values(w, &starts, &ends, &d_ends) {
            Ok(v) => v,
            Err(reason) => {
                self.objective_error = Some(reason.clone());
                return Err(AnalysisError::Request { reason });
            }
        };
        Ok(Point {
            w: w.to_vec(),
            effort,
            user,
            objective,
            objective_grad,
            user_grad,
            acts,
            c,
            jac,
            g,
            g_jac,
            starts,
            ends,
        })
    }

    /// Adds segment `k`'s derivative with respect to the duration `T` to
    /// its end's rows `d` (2 nq x n): `h = T / N`, and the segment's end
    /// moves with `h` by its rate at the end plus the stretch of its input
    /// tables, `u(t) = u_k + (u_k+1 - u_k) t / h`, whose derivative at a
    /// fixed `t` is `-(u_k+1 - u_k) / h` times the end node's weight `t /
    /// h`: `dx/dh = f(x_end, u_k+1) - sum_j S_{u_j,k+1} (u_j,k+1 -
    /// u_j,k) / h`, `S_{u_j,k+1}` the end's sensitivity to the node
    /// (column `nz + 2 j + 1` of `columns`, after the start's `nz`). The
    /// start's dependence on `T` came in through the chain already.
    fn chain_duration(
        &self,
        d: &mut [Vec<f64>],
        (k, nz): (usize, usize),
        w: &[f64],
        (rate, columns): (&[f64], &[Vec<f64>]),
    ) {
        let h = self.h_at(w);
        let col = self.col_t();
        for (i, row) in d.iter_mut().enumerate() {
            let mut dh = rate[i];
            for j in 0..self.inputs.len() {
                let (a, b) = (w[self.col_u(j, k)], w[self.col_u(j, k + 1)]);
                dh -= columns[nz + 2 * j + 1][i] * (b - a) / h;
            }
            row[col] += dh / self.segments as f64;
        }
    }

    /// The path constraints' inequalities at `w` and their Jacobian (p x
    /// n), chained through the segments' end sensitivities `d_ends`.
    ///
    /// # Errors
    /// A function's failure, or a value or gradient not finite.
    fn path_values(
        &mut self,
        w: &[f64],
        starts: &[Vec<f64>],
        ends: &[Vec<f64>],
        d_ends: &[Vec<Vec<f64>>],
    ) -> Result<(Vec<f64>, Vec<Vec<f64>>), String> {
        if self.path_rows.is_empty() {
            return Ok((Vec::new(), Vec::new()));
        }
        let s = self.samples(w, starts, ends);
        let nq = self.names.len() / 2;
        let names = SampleNames { coords: &self.names[..nq], inputs: &self.inputs };
        // each constraint's value and gradient once per node
        let mut cache: Vec<Option<(f64, Vec<f64>)>> = vec![None; self.path.len() * (self.segments + 1)];
        let (mut g, mut g_jac) = (Vec::new(), Vec::new());
        for (row, _) in &self.path_rows {
            let slot = row.c * (self.segments + 1) + row.k;
            if cache[slot].is_none() {
                let (v, dx, du, differenced) = path::at_node(&self.path[row.c], &s, row.k, &names)?;
                let dt = if self.free_time { path::time_derivative(&self.path[row.c], &s, row.k)? } else { 0.0 };
                self.path_differenced |= differenced;
                let mut grad = vec![0.0; self.n];
                // node 0 is the problem's own initial state
                if row.k > 0 {
                    for (r, &gx) in d_ends[row.k - 1].iter().zip(&dx) {
                        if gx != 0.0 {
                            grad.iter_mut().zip(r).for_each(|(a, b)| *a += gx * b);
                        }
                    }
                }
                for (j, &v) in du.iter().enumerate() {
                    grad[self.col_u(j, row.k)] += v;
                }
                if self.free_time {
                    grad[self.col_t()] += dt * row.k as f64 / self.segments as f64;
                }
                cache[slot] = Some((v, grad));
            }
            let (v, grad) = cache[slot].as_ref().expect("evaluated above");
            let bound =
                if row.sign > 0.0 { self.path[row.c].constraint.upper } else { self.path[row.c].constraint.lower };
            g.push(row.sign * (v - bound));
            g_jac.push(grad.iter().map(|a| row.sign * a).collect());
        }
        Ok((g, g_jac))
    }

    /// The samples at `w`: the nodes' times, states (node 0 the first
    /// segment's start, node `k >= 1` segment `k - 1`'s end) and inputs.
    pub fn samples(&self, w: &[f64], starts: &[Vec<f64>], ends: &[Vec<f64>]) -> Samples {
        let nq = self.names.len() / 2;
        let x: Vec<&Vec<f64>> = starts.iter().take(1).chain(ends).collect();
        Samples {
            t: self.t.clone(),
            q: x.iter().map(|x| x[..nq].to_vec()).collect(),
            qd: x.iter().map(|x| x[nq..].to_vec()).collect(),
            u: (0..=self.segments).map(|k| (0..self.inputs.len()).map(|j| w[self.col_u(j, k)]).collect()).collect(),
        }
    }

    /// The user's term at `w` and its gradient (n) by the chain rule
    /// through the segments' end sensitivities `d_ends` (N of 2 nq x n);
    /// `None` without one.
    ///
    /// # Errors
    /// The user's function's failure, or a value or gradient not finite.
    fn user_term(
        &mut self,
        w: &[f64],
        starts: &[Vec<f64>],
        ends: &[Vec<f64>],
        d_ends: &[Vec<Vec<f64>>],
    ) -> Result<Option<(f64, Vec<f64>)>, String> {
        let Some((name, f)) = self.objective.user.clone() else { return Ok(None) };
        let s = self.samples(w, starts, ends);
        let nq = self.names.len() / 2;
        let names = SampleNames { coords: &self.names[..nq], inputs: &self.inputs };
        let (value, g, differenced) = objective::evaluate(&*f, &name, &s, &names)?;
        self.differenced |= differenced;
        let mut grad = vec![0.0; self.n];
        // node 0 is the problem's own initial state: no unknown moves it
        for (k, d) in d_ends.iter().enumerate() {
            let dx = g.q[k + 1].iter().chain(&g.qd[k + 1]);
            for (row, &gx) in d.iter().zip(dx) {
                if gx != 0.0 {
                    grad.iter_mut().zip(row).for_each(|(a, b)| *a += gx * b);
                }
            }
        }
        for (k, gu) in g.u.iter().enumerate() {
            for (j, &v) in gu.iter().enumerate() {
                grad[self.col_u(j, k)] += v;
            }
        }
        if self.free_time {
            // the times move with T: t_k = k T / N
            let dt = objective::time_differences(&*f, &format!("the objective `{name}`"), &s)?;
            let n = self.segments as f64;
            grad[self.col_t()] += dt.iter().enumerate().map(|(k, g)| g * k as f64 / n).sum::<f64>();
        }
        Ok(Some((value, grad)))
    }

    /// The nodes' unknowns of the states `x` (N + 1 of 2 nq) into `w`.
    pub fn gather(&self, x: &[Vec<f64>], w: &mut [f64]) {
        for k in 1..self.segments {
            if let Some(node) = self.nodes[k].as_ref().filter(|n| !n.chained) {
                for (i, &c) in node.comps.iter().enumerate() {
                    w[self.z_offset[k] + i] = x[k][c];
                }
            }
        }
    }
}
