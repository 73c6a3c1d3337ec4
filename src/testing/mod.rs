//! Checks of a model's derived terms, for a model author's own tests:
//! [`assert_derivatives`] in one line, or [`check_derivatives`] for a
//! [`Report`] to inspect. The same check is `ezy check MODEL` on the
//! command line.
//!
//! Every term the constraint solve uses is compared against two
//! independent references at random states and parameters:
//!
//! | term | finite differences | dual numbers |
//! |---|---|---|
//! | holonomic Jacobian `C_q = d phi/dq` (nh x nq) | central differences of `phi` | forward-mode derivative of `phi` |
//! | skate rows `S` (one per skate, x nq) | `n . d r_P/dq` by central differences of the point positions | `n . d r_P/dq` by dual numbers |
//! | convective term `gamma = d/dq(G qd) qd` (nc) \[m/s^2\] | central difference of `G(q + e qd) qd` in `e` | dual derivative of `G(q + e qd) qd` |
//! | point velocities `d r_P/dt` (2 x npoints) \[m/s\] | central difference of `r_P(q + e qd)` | dual derivative of `r_P(q + e qd)` |
//!
//! | minimal coordinates, where `model!` derived them: `B = dV/du` (nq x nu), `V` the body-frame velocities | central differences of the expanded `V` in each speed | dual derivative of the expanded `V` |
//! | minimal coordinates: `c`, the body-frame acceleration at `u' = 0` (nq) \[m/s^2\] | central difference of the expanded `V` along `pd` at fixed `u`, plus the frame's turning | dual derivative along `pd`, plus the turning |
//!
//! plus the agreement of the model's own entry points with each other
//! (`holonomic_jacobian`, `phi_and_constraint_matrix` and
//! `constraint_terms` against `constraint_matrix` and `phi`), which a
//! hand-written [`Model`] can break, and, for minimal coordinates, every
//! constraint at the expanded state (`phi = 0`, `G qd = 0`, to the same
//! tolerance, each residual divided by the size of the terms that cancel
//! in it: the largest coordinate for `phi`, `sum_k |G_ik qd_k|` for
//! `G qd`, at least 1), and the fused right-hand side `model!` generates
//! for them ([`Model::minimal_rhs`]) against the expansion and Maggi's
//! equations computed apart, under a force on every coordinate and a
//! torque at every hinge (which the fused function takes apart and maps
//! at compile time): the full
//! state exactly, the speeds' rates by the backward error of Maggi's
//! equations ([`MIN_FUSED`], same tolerance). Below the table, the pivots
//! of the minimal coordinates at the model's parameters ([`minimal_notes`]).
//!
//! Errors are relative, `|generated - reference| / max(|generated|,
//! |reference|, 1)`, so an O(1) mistake (a wrong sign, a missing factor)
//! shows as an O(1) error. The tolerances:
//!
//! - finite differences, [`FD_TOLERANCE`] = 1e-6 at step [`FD_STEP`] = 1e-5:
//!   the central difference's truncation error is `h^2 |f'''| / 6`, about
//!   1e-10 for the metre-sized, O(1)-curvature terms of a vehicle, and its
//!   rounding error is about `eps |f| / h`, 2e-11 |f|: the tolerance is
//!   three to four orders above both (room for lengths of tens of metres)
//!   and five below a real mistake.
//! - dual numbers, [`DUAL_TOLERANCE`] = 1e-12: forward mode differentiates
//!   exactly; generated and dual results differ only by the rounding of a
//!   few dozen operations, ~1e-15 relative.
//! - agreement of entry points, [`SAME_TOLERANCE`] = 1e-13: the same
//!   quantity computed twice; generated code may share subexpressions
//!   differently, nothing more.
//!
//! Sources: finite-difference error bounds, Nocedal & Wright, *Numerical
//! Optimization*, 2nd ed., §8.1; forward-mode automatic differentiation
//! with dual numbers, Griewank & Walther, *Evaluating Derivatives*, 2nd
//! ed., ch. 3.

mod minimal;

use ezy_core::Model;
use ezy_core::Scalar;
use num_dual::Dual64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use minimal::check_minimal;
pub use minimal::minimal_notes;

/// Central-difference step [m, rad] (see the module docs).
pub const FD_STEP: f64 = 1e-5;
/// Largest relative error against central differences (see the module docs).
pub const FD_TOLERANCE: f64 = 1e-6;
/// Largest relative error against dual numbers (see the module docs).
pub const DUAL_TOLERANCE: f64 = 1e-12;
/// Largest relative difference between two entry points computing the
/// same quantity (see the module docs).
pub const SAME_TOLERANCE: f64 = 1e-13;
/// Random states (with random parameters) [`assert_derivatives`] checks.
pub const DEFAULT_STATES: usize = 50;

/// The number of random states `ezy check` uses for a model of `nq`
/// coordinates: 100, and for large models (a family of thousands of
/// links) so many that `states x nq` is about [`CHECK_BUDGET`], at least
/// 3. Each state draws every coordinate afresh, so a family's element
/// kernel is checked at `states x count` random element states: at
/// 100,000 links, 3 states check each kernel at 300,000.
pub fn default_states(nq: usize) -> usize {
    (CHECK_BUDGET / nq.max(1)).clamp(3, 100)
}

/// The coordinates times states [`default_states`] aims at.
pub const CHECK_BUDGET: usize = 300_000;

/// What a term is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reference {
    /// Central finite differences of the generated positions.
    FiniteDifference,
    /// Forward-mode dual numbers through the generated positions.
    DualNumber,
    /// The same quantity from another entry point of the model.
    SameModel,
}

impl Reference {
    /// The tolerance on the relative error.
    pub fn tolerance(self) -> f64 {
        match self {
            Self::FiniteDifference => FD_TOLERANCE,
            Self::DualNumber => DUAL_TOLERANCE,
            Self::SameModel => SAME_TOLERANCE,
        }
    }
    /// Short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::FiniteDifference => "finite diff.",
            Self::DualNumber => "dual numbers",
            Self::SameModel => "same model",
        }
    }
}

/// The result for one derived term against one reference.
#[derive(Debug, Clone, PartialEq)]
pub struct TermCheck {
    /// What was compared, e.g. `C_q = d phi/dq (hinge rows of G)`.
    pub term: &'static str,
    /// What it was compared with.
    pub reference: Reference,
    /// Number of scalar comparisons.
    pub compared: usize,
    /// Largest `|generated - reference| / max(|generated|, |reference|, 1)`
    /// (infinite for a NaN or infinite value).
    pub max_error: f64,
    /// Where it occurred: the state (numbered from 0) and the entry by
    /// name (`G[B.y, y2]`), with both values.
    pub worst_at: String,
}

impl TermCheck {
    /// The largest error is within the reference's tolerance.
    pub fn passed(&self) -> bool {
        self.max_error <= self.reference.tolerance()
    }
}

/// Every term of a model against every reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Number of random states (each with random parameters).
    pub states: usize,
    /// Seed of the random states.
    pub seed: u64,
    /// One entry per term and reference.
    pub terms: Vec<TermCheck>,
    /// What the table's rows do not say: whether the model has minimal
    /// coordinates at its given parameters, and how well conditioned
    /// each pivot is ([`minimal_notes`]).
    pub notes: Vec<String>,
}

impl Report {
    /// Every term within its tolerance.
    pub fn passed(&self) -> bool {
        self.terms.iter().all(TermCheck::passed)
    }

    /// The failed term with the largest error relative to its tolerance,
    /// as `term against reference: error at entry` (empty if all passed).
    pub fn worst(&self) -> String {
        self.terms
            .iter()
            .filter(|c| !c.passed())
            .max_by(|a, b| (a.max_error / a.reference.tolerance()).total_cmp(&(b.max_error / b.reference.tolerance())))
            .map(|c| {
                format!(
                    "{} against {}: relative error {:.3e} > {:e} at {}",
                    c.term,
                    c.reference.name(),
                    c.max_error,
                    c.reference.tolerance(),
                    c.worst_at
                )
            })
            .unwrap_or_default()
    }

    /// A table, one line per term and reference, naming the worst entry.
    pub fn table(&self, model: &str) -> String {
        let mut out = format!(
            "{model}: generated terms at {} random states and parameters (seed {}), finite differences with h = {FD_STEP:e}\n",
            self.states, self.seed
        );
        out.push_str(&format!(
            "{:<36} {:<13} {:>8} {:>11} {:>7}  {:<6} worst at\n",
            "term", "against", "compared", "max rel err", "tol", ""
        ));
        for c in &self.terms {
            let verdict = if c.compared == 0 {
                "none"
            } else if c.passed() {
                "ok"
            } else {
                "FAILED"
            };
            out.push_str(&format!(
                "{:<36} {:<13} {:>8} {:>11.3e} {:>7.0e}  {:<6} {}\n",
                c.term,
                c.reference.name(),
                c.compared,
                c.max_error,
                c.reference.tolerance(),
                verdict,
                c.worst_at
            ));
        }
        for n in &self.notes {
            out.push_str(n);
            out.push('\n');
        }
        out
    }
}

/// Checks every derived term of `model` (at its family counts, around its
/// parameters) against finite differences and dual numbers at
/// [`DEFAULT_STATES`] random states, and panics with the table of
/// [`Report::table`] naming the worst entry if any term is off.
///
/// ```
/// # ezy::model! {
/// #     /// A sleigh.
/// #     pub struct Sleigh {
/// #         /// Distance from the centre of mass back to the skate [m]
/// #         param a = 0.5;
/// #         body s(x, y, phi) { mass: 1.0, inertia: 0.1 }
/// #         point P on s at (-a, 0);
/// #         skate P: P along (1, 0);
/// #     }
/// # }
/// ezy::testing::assert_derivatives(&Sleigh::default());
/// ```
///
/// # Panics
/// If a term exceeds its tolerance, or a value is NaN or infinite.
#[track_caller]
pub fn assert_derivatives<M: Model>(model: &M) {
    let report = check_derivatives(model);
    if !report.passed() {
        panic!("{}\n{}", report.worst(), report.table(model.info().name));
    }
}

/// As [`assert_derivatives`], returning the [`Report`] instead of panicking.
pub fn check_derivatives<M: Model>(model: &M) -> Report {
    check_derivatives_with(model, DEFAULT_STATES, 1)
}

/// The comparisons of [`check_derivatives`] at `states` random states
/// drawn from `seed`: every coordinate uniform in \[-3, 3\] (metres or
/// radians), every velocity in \[-2, 2\], every real parameter scaled by a
/// factor uniform in \[0.5, 1.5\] (family counts kept).
pub fn check_derivatives_with<M: Model>(base: &M, states: usize, seed: u64) -> Report {
    check_derivatives_observed(base, states, seed, |_| {})
}

/// As [`check_derivatives_with`], calling `on_state(s)` before state `s`
/// (numbered from 0), for progress reports.
pub fn check_derivatives_observed<M: Model>(
    base: &M,
    states: usize,
    seed: u64,
    mut on_state: impl FnMut(usize),
) -> Report {
    let go_on = |s| {
        on_state(s);
        true
    };
    check_derivatives_until(base, states, seed, go_on).expect("never stopped")
}

/// As [`check_derivatives_observed`], `on_state(s)` returning whether to
/// go on: `None` when it stopped the check (a stop request, Ctrl-C).
pub fn check_derivatives_until<M: Model>(
    base: &M,
    states: usize,
    seed: u64,
    mut on_state: impl FnMut(usize) -> bool,
) -> Option<Report> {
    let info = &base.info();
    let (nq, nc, nnz) = (info.nq(), info.nc(), info.pattern.len());
    let mut rng = StdRng::seed_from_u64(seed);
    let names = Names(info);
    let mut checks = Checks::new(base);
    let (groups, by_col) = column_groups(&info.pattern, nq);
    let mut columns = Columns { by_col, in_group: vec![None; nc] };
    for s in 0..states {
        if !on_state(s) {
            return None;
        }
        let mut m = base.clone();
        for (i, p) in info.params.iter().enumerate() {
            if !p.count {
                let v = m.param(i);
                m.set_param(i, v * rng.random_range(0.5..1.5));
            }
        }
        let q: Vec<f64> = (0..nq).map(|_| rng.random_range(-3.0..3.0)).collect();
        let qd: Vec<f64> = (0..nq).map(|_| rng.random_range(-2.0..2.0)).collect();
        let mut vals = vec![0.0; nnz];
        m.constraint_matrix(&q, &mut vals);
        let at = At { s, q: &q, qd: &qd, vals: &vals };
        let gam = check_entry_points(&m, &at, &names, &mut checks.same);
        let normals = skate_normals(&m, &q, &names);
        for group in &groups {
            check_columns(&m, &at, group, &mut columns, &normals, &names, &mut checks);
        }
        check_along_velocities(&m, &at, &gam, &names, &mut checks);
        if let (Some(acc), Ok(layout)) = (&mut checks.minimal, m.minimal_layout()) {
            check_minimal(&m, &layout, &q, &qd, s, acc);
        }
    }
    Some(checks.report(base, states, seed))
}

/// The comparisons of [`check_derivatives_observed`] as they accumulate,
/// one per term and reference.
struct Checks {
    jac: [Acc; 2],
    skate: [Acc; 2],
    gamma: [Acc; 2],
    vel: [Acc; 2],
    same: Acc,
    /// Where `model!` derived minimal coordinates: the expanded state's
    /// constraints, `B` and `c` by both references, the fused right-hand
    /// side.
    minimal: Option<(Acc, [Acc; 2], [Acc; 2], Acc)>,
}

impl Checks {
    fn new<M: Model>(base: &M) -> Self {
        use Reference::{DualNumber as Dual, FiniteDifference as Fd, SameModel as Same};
        Self {
            jac: [Acc::new(JAC, Fd), Acc::new(JAC, Dual)],
            skate: [Acc::new(SKATE, Fd), Acc::new(SKATE, Dual)],
            gamma: [Acc::new(GAMMA, Fd), Acc::new(GAMMA, Dual)],
            vel: [Acc::new(VEL, Fd), Acc::new(VEL, Dual)],
            same: Acc::new("entry points agree", Same),
            minimal: base.minimal_layout().ok().map(|_| {
                (
                    Acc::new(MIN_KEPT, Same),
                    [Acc::new(MIN_B, Fd), Acc::new(MIN_B, Dual)],
                    [Acc::new(MIN_C, Fd), Acc::new(MIN_C, Dual)],
                    Acc::new(MIN_FUSED, Same),
                )
            }),
        }
    }

    /// The report of `states` states drawn from `seed` on `base`.
    fn report<M: Model>(self, base: &M, states: usize, seed: u64) -> Report {
        let mut terms = Vec::new();
        for pair in [self.jac, self.skate, self.gamma, self.vel] {
            terms.extend(pair.into_iter().map(Acc::done));
        }
        if let Some((kept, b, c, fused)) = self.minimal {
            terms.push(kept.done());
            terms.extend(b.into_iter().chain(c).map(Acc::done));
            if fused.compared > 0 {
                terms.push(fused.done());
            }
        }
        terms.push(self.same.done());
        Report { states, seed, terms, notes: minimal_notes(base) }
    }
}

/// State number `s` of a check: its coordinates, velocities, and the
/// values of `G` there.
struct At<'a> {
    s: usize,
    q: &'a [f64],
    qd: &'a [f64],
    vals: &'a [f64],
}

/// The columns of `G` by their rows, and the entry of the group being
/// checked in each row.
struct Columns {
    by_col: ByColumn,
    /// Per row: the group's column in it and the index of its value.
    in_group: Vec<Option<(usize, usize)>>,
}

/// The model's entry points against each other at `at` (`phi`,
/// `phi_and_constraint_matrix`, `holonomic_jacobian`, `constraint_terms`
/// against `constraint_matrix`), into `same`; returns `gamma` from
/// `constraint_terms`.
fn check_entry_points<M: Model>(m: &M, at: &At<'_>, names: &Names<'_>, same: &mut Acc) -> Vec<f64> {
    let info = names.0;
    let (nh, nc, nnz, nhz) = (info.n_holonomic, info.nc(), info.pattern.len(), info.n_holonomic_nonzeros());
    let (s, q, qd, vals) = (at.s, at.q, at.qd, at.vals);
    let mut phi = vec![0.0; nh];
    m.phi(q, &mut phi);
    let (mut phi2, mut vals2) = (vec![0.0; nh], vec![0.0; nnz]);
    m.phi_and_constraint_matrix(q, &mut phi2, &mut vals2);
    let mut hj = vec![0.0; nhz];
    m.holonomic_jacobian(q, &mut hj);
    let (mut vals3, mut gam) = (vec![0.0; nnz], vec![0.0; nc]);
    m.constraint_terms(q, qd, &mut vals3, &mut gam);
    for i in 0..nh {
        same.add(phi2[i], phi[i], || format!("state {s}, phi[{}] of phi_and_constraint_matrix", names.row(i)));
    }
    for (k, &(r, c)) in info.pattern.iter().enumerate() {
        let at = |what: &str| format!("state {s}, {} of {what}", names.g(r, c));
        same.add(vals2[k], vals[k], || at("phi_and_constraint_matrix"));
        same.add(vals3[k], vals[k], || at("constraint_terms"));
        if k < nhz {
            same.add(hj[k], vals[k], || at("holonomic_jacobian"));
        }
    }
    gam
}

/// The world normals of the skates' blades at `q` (`names`: of the
/// model's rows and entries, and its description).
fn skate_normals<M: Model>(m: &M, q: &[f64], names: &Names<'_>) -> Vec<[f64; 2]> {
    let info = names.0;
    let mut local = vec![0.0; 2 * info.points.len()];
    let mut blades = vec![0.0; 2 * info.skates.len()];
    m.local_geometry(&mut local, &mut blades);
    info.skates
        .iter()
        .enumerate()
        .map(|(j, sk)| {
            let phi = q[info.bodies[info.points[sk.point].body].coords[2]];
            let (nx, ny) = (-blades[2 * j + 1], blades[2 * j]);
            [phi.cos() * nx - phi.sin() * ny, phi.sin() * nx + phi.cos() * ny]
        })
        .collect()
}

/// `C_q` and the skate rows `S` in the columns `group` at `at`: d/dq by
/// central differences and by a dual seed, for the group's columns at
/// once (they share no row of G, so each row sees at most one of them):
/// the cost is linear in the size of a family.
fn check_columns<M: Model>(
    m: &M,
    at: &At<'_>,
    group: &[usize],
    columns: &mut Columns,
    normals: &[[f64; 2]],
    names: &Names<'_>,
    checks: &mut Checks,
) {
    let info = names.0;
    let (nh, np) = (info.n_holonomic, info.points.len());
    let (s, q, vals) = (at.s, at.q, at.vals);
    let h = FD_STEP;
    let shifted = |d: f64| {
        let mut p = q.to_vec();
        for &k in group {
            p[k] += d;
        }
        p
    };
    let (mut fp, mut fm) = (vec![0.0; nh], vec![0.0; nh]);
    m.phi(&shifted(h), &mut fp);
    m.phi(&shifted(-h), &mut fm);
    let mut qk: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
    for &k in group {
        qk[k].eps = 1.0;
    }
    // the group's entry in each row: (column, index of its value)
    for &k in group {
        for &(r, v) in &columns.by_col[k] {
            columns.in_group[r] = Some((k, v));
        }
    }
    let in_group = &columns.in_group;
    let generated = |r: usize| in_group[r].map_or(0.0, |(_, v)| vals[v]);
    let name = |r: usize| match in_group[r] {
        Some((k, _)) => names.g(r, k),
        None => names.outside(r, group),
    };
    let mut phid = vec![Dual64::from(0.0); nh];
    m.phi(&qk, &mut phid);
    for i in 0..nh {
        let at = || format!("state {s}, {}", name(i));
        checks.jac[0].add(generated(i), (fp[i] - fm[i]) / (2.0 * h), at);
        checks.jac[1].add(generated(i), phid[i].eps, at);
    }
    let (pp, pm) = (points(m, &shifted(h), np), points(m, &shifted(-h), np));
    let mut pd = vec![Dual64::from(0.0); 2 * np];
    m.points(&qk, &mut pd);
    for (j, sk) in info.skates.iter().enumerate() {
        let (p, n) = (sk.point, normals[j]);
        let fd = (n[0] * (pp[2 * p] - pm[2 * p]) + n[1] * (pp[2 * p + 1] - pm[2 * p + 1])) / (2.0 * h);
        let dual = n[0] * pd[2 * p].eps + n[1] * pd[2 * p + 1].eps;
        let at = || format!("state {s}, {}", name(sk.row));
        checks.skate[0].add(generated(sk.row), fd, at);
        checks.skate[1].add(generated(sk.row), dual, at);
    }
    for &k in group {
        for &(r, _) in &columns.by_col[k] {
            columns.in_group[r] = None;
        }
    }
}

/// `gamma` (from `constraint_terms`: `gam`) and the point velocities at
/// `at`, as derivatives along the velocity: d/de at `q + e qd` of
/// `G(q + e qd) qd` and of `r_P(q + e qd)`, by central differences and by
/// dual numbers.
fn check_along_velocities<M: Model>(m: &M, at: &At<'_>, gam: &[f64], names: &Names<'_>, checks: &mut Checks) {
    let info = names.0;
    let (nc, nnz, np) = (info.nc(), info.pattern.len(), info.points.len());
    let (s, q, qd) = (at.s, at.q, at.qd);
    let h = FD_STEP;
    let along = |d: f64| -> Vec<f64> { q.iter().zip(qd).map(|(a, b)| a + d * b).collect() };
    let g_qd = |q: &[f64]| {
        let mut v = vec![0.0; nnz];
        m.constraint_matrix(q, &mut v);
        times(info, &v, qd)
    };
    let (gp, gm) = (g_qd(&along(h)), g_qd(&along(-h)));
    let qe: Vec<Dual64> = q.iter().zip(qd).map(|(&x, &v)| Dual64::new(x, v)).collect();
    let mut vd = vec![Dual64::from(0.0); nnz];
    m.constraint_matrix(&qe, &mut vd);
    let qd_dual: Vec<Dual64> = qd.iter().map(|&v| Dual64::from(v)).collect();
    let gqd_dual = times(info, &vd, &qd_dual);
    for i in 0..nc {
        let at = || format!("state {s}, gamma[{}]", names.row(i));
        checks.gamma[0].add(gam[i], (gp[i] - gm[i]) / (2.0 * h), at);
        checks.gamma[1].add(gam[i], gqd_dual[i].eps, at);
    }
    let (pp, pm) = (points(m, &along(h), np), points(m, &along(-h), np));
    let mut pe = vec![Dual64::from(0.0); 2 * np];
    m.points(&qe, &mut pe);
    let mut v = vec![0.0; 2 * np];
    m.point_velocities(q, qd, &mut v);
    for i in 0..2 * np {
        let axis = if i % 2 == 0 { "x" } else { "y" };
        let at = || format!("state {s}, velocity {}.{axis}", info.points[i / 2].name);
        checks.vel[0].add(v[i], (pp[i] - pm[i]) / (2.0 * h), at);
        checks.vel[1].add(v[i], pe[i].eps, at);
    }
}

const MIN_KEPT: &str = "minimal: phi = 0, G qd = 0 expanded";
const MIN_B: &str = "minimal: B = dV/du, body frame";
const MIN_C: &str = "minimal: c = V'(u' = 0), body frame";
/// The term of the fused right-hand side ([`Model::minimal_rhs`]) against
/// the expansion and Maggi's equations apart, in a [`Report`].
pub const MIN_FUSED: &str = "minimal: fused = expand + Maggi";
const JAC: &str = "C_q = d phi/dq (holonomic rows of G)";
const SKATE: &str = "S = n . d r_P/dq (skate rows of G)";
const GAMMA: &str = "gamma = d/dq(G qd) qd";
const VEL: &str = "point velocities d r_P/dt";

/// A model's description, and the names of its rows and entries for
/// messages.
struct Names<'a>(&'a ezy_core::ModelInfo);

impl Names<'_> {
    fn row(&self, i: usize) -> &str {
        &self.0.constraints[i]
    }
    fn g(&self, r: usize, c: usize) -> String {
        format!("G[{}, {}]", self.0.constraints[r], self.0.coords[c])
    }
    /// Row `r` at a column outside its pattern, one of `group` (perturbed together).
    fn outside(&self, r: usize, group: &[usize]) -> String {
        let cols = ezy_core::name_list(group.iter().map(|&c| self.0.coords[c].as_str()));
        format!("G[{}, one of {cols}] (outside the pattern of G)", self.0.constraints[r])
    }
}

/// For each column of `G`, its rows and the indices of their values.
type ByColumn = Vec<Vec<(usize, usize)>>;

/// Groups of columns of `G` (nq columns, `pattern` its nonzeros) no two
/// of which share a row, by greedy colouring in column order (Curtis,
/// Powell & Reid, *J. Inst. Maths Applics* 13, 1974; Coleman & Moré,
/// *SIAM J. Numer. Anal.* 20(1), 1983): a chain needs a handful of groups
/// whatever its length. Also the rows of each column with the index of
/// their value.
fn column_groups(pattern: &[(usize, usize)], nq: usize) -> (Vec<Vec<usize>>, ByColumn) {
    let mut by_col: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nq];
    let mut by_row: Vec<Vec<usize>> = Vec::new();
    for (v, &(r, c)) in pattern.iter().enumerate() {
        by_col[c].push((r, v));
        if by_row.len() <= r {
            by_row.resize(r + 1, Vec::new());
        }
        by_row[r].push(c);
    }
    let mut color = vec![usize::MAX; nq];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut taken = Vec::new();
    for k in 0..nq {
        taken.clear();
        for &(r, _) in &by_col[k] {
            taken.extend(by_row[r].iter().map(|&c| color[c]).filter(|&g| g != usize::MAX));
        }
        let g = (0..).find(|g| !taken.contains(g)).expect("a free group");
        if g == groups.len() {
            groups.push(Vec::new());
        }
        groups[g].push(k);
        color[k] = g;
    }
    (groups, by_col)
}

/// The largest magnitude in `v`.
fn max_abs_of(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// `G v` (nc) from the values of `G` at the pattern.
fn times<S: Scalar>(info: &ezy_core::ModelInfo, vals: &[S], v: &[S]) -> Vec<S> {
    let mut out = vec![S::from_f64(0.0); info.nc()];
    for (&(r, c), &x) in info.pattern.iter().zip(vals) {
        out[r] = out[r] + x * v[c];
    }
    out
}

fn points<M: Model>(m: &M, q: &[f64], np: usize) -> Vec<f64> {
    let mut out = vec![0.0; 2 * np];
    m.points(q, &mut out);
    out
}

struct Acc {
    term: &'static str,
    reference: Reference,
    compared: usize,
    max_error: f64,
    worst_at: String,
}

impl Acc {
    fn new(term: &'static str, reference: Reference) -> Self {
        Self { term, reference, compared: 0, max_error: 0.0, worst_at: String::new() }
    }
    fn add(&mut self, generated: f64, reference: f64, at: impl FnOnce() -> String) {
        let e = (generated - reference).abs() / generated.abs().max(reference.abs()).max(1.0);
        self.compared += 1;
        if e > self.max_error || !e.is_finite() {
            self.max_error = if e.is_finite() { e } else { f64::INFINITY };
            self.worst_at = format!("{} (generated {generated:.6e}, reference {reference:.6e})", at());
        }
    }
    fn done(self) -> TermCheck {
        TermCheck {
            term: self.term,
            reference: self.reference,
            compared: self.compared,
            max_error: self.max_error,
            worst_at: self.worst_at,
        }
    }
}

/// Checks a force law of the user's own ([`ezy_core::effects::ForceLaw`])
/// at `states` random states `(t, q, qd)` of a model with `nq`
/// coordinates (`t` in [0, 10] s, every `q` and `qd` in [-2, 2]), seed
/// `seed`: what RADAU5's coupling and the energy ledger rely on.
///
/// 1. It writes `f` only at its [`ForceLaw::coords`](ezy_core::effects::ForceLaw::coords),
///    each below `nq`.
/// 2. The power it returns is `f_law . qd` to [`SAME_TOLERANCE`] relative
///    to `sum_k |f_k qd_k|` (at least 1 W): its work column then closes
///    the ledger `T - T0 = sum W`.
/// 3. Its force, power and value do not change when `q` or `qd` change
///    outside its coordinates (each such entry moved by 0.5, compared
///    exactly): otherwise RADAU5's Jacobian misses a coupling.
/// 4. Force, power and value are finite.
///
/// # Errors
/// The first violation, with the state and the entry.
pub fn check_force_law(
    law: &dyn ezy_core::effects::ForceLaw,
    nq: usize,
    states: usize,
    seed: u64,
) -> Result<(), String> {
    let coords = law.coords();
    if let Some(k) = coords.iter().find(|&&k| k >= nq) {
        return Err(format!("coords() lists {k}, but the model has nq = {nq}"));
    }
    let mut rng = StdRng::seed_from_u64(seed);
    let eval = |t: f64, q: &[f64], qd: &[f64]| {
        let mut f = vec![0.0; nq];
        let (p, v) = law.apply(t, q, qd, &mut f);
        (f, p, v)
    };
    for s in 0..states {
        let t = rng.random_range(0.0..10.0);
        let q: Vec<f64> = (0..nq).map(|_| rng.random_range(-2.0..2.0)).collect();
        let qd: Vec<f64> = (0..nq).map(|_| rng.random_range(-2.0..2.0)).collect();
        let at = format!("state {s} (t = {t}, seed {seed})");
        let (f, p, v) = eval(t, &q, &qd);
        if !(f.iter().all(|x| x.is_finite()) && p.is_finite() && v.is_finite()) {
            return Err(format!("{at}: force {f:?}, power {p} or value {v} is not finite"));
        }
        if let Some(k) = (0..nq).find(|k| f[*k] != 0.0 && !coords.contains(k)) {
            return Err(format!("{at}: f[{k}] = {} but {k} is not among coords() = {coords:?}", f[k]));
        }
        let fqd: f64 = f.iter().zip(&qd).map(|(a, b)| a * b).sum();
        let scale = f.iter().zip(&qd).map(|(a, b)| (a * b).abs()).sum::<f64>().max(1.0);
        if (p - fqd).abs() > SAME_TOLERANCE * scale {
            return Err(format!("{at}: power {p} W, but f . qd = {fqd} W"));
        }
        for j in (0..nq).filter(|j| !coords.contains(j)) {
            for moved_velocity in [false, true] {
                let (mut q2, mut qd2) = (q.clone(), qd.clone());
                if moved_velocity {
                    qd2[j] += 0.5
                } else {
                    q2[j] += 0.5
                }
                let (f2, p2, v2) = eval(t, &q2, &qd2);
                // the power reads qd[j] only through f[j] = 0
                if f2 != f || v2 != v || (!moved_velocity && p2 != p) {
                    let what = if moved_velocity { "qd" } else { "q" };
                    return Err(format!(
                        "{at}: the law changes when {what}[{j}] changes, but {j} is not among coords() = {coords:?}"
                    ));
                }
            }
        }
    }
    Ok(())
}
