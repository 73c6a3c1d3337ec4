//! The reduced formulation: generalized coordinate partitioning (Wehage &
//! Haug 1982, "Generalized coordinate partitioning for dimension reduction
//! in analysis of constrained dynamic systems", J. Mech. Des. 104(1),
//! 247-255; Haug, *Computer-Aided Kinematics and Dynamics of Mechanical
//! Systems*, 1989, §6.3 and §7.3), extended to skates (nonholonomic rows)
//! as in Nikravesh, *Computer-Aided Analysis of Mechanical Systems*, 1988,
//! §13.
//!
//! The integrator advances only the independent coordinates `q_I`
//! (nq - nh of them), the independent velocities `qd_I` (nq - nc) and the
//! work states. At every evaluation the dependent coordinates `q_D` (nh)
//! are recovered from `phi(q) = u(t)` by Newton's method and the dependent
//! velocities `qd_D` (nc) from the linear `G(q) qd = b(t)` (`b` holds the
//! drives' `u'(t)`); the accelerations come from the same KKT system as the
//! DAE's, and only the independent ones are integrated. Every state the run
//! outputs satisfies the constraints to rounding without projection, and
//! the error control sees only the independent components.
//!
//! The dependent columns are chosen by Gaussian elimination with full
//! pivoting (Wehage & Haug's choice) on the row-equilibrated `C_q`
//! (positions) and `G` (velocities), preferring translational coordinates
//! `x, y`: every holonomic row ezy's models have (hinge, slider, slot,
//! drive) is affine in them, so Newton's method converges in one step.
//! The partition is re-chosen when the pivots of its `C_D` or `G_D` fall
//! to a tenth of their value when it was chosen (a vehicle turning through
//! a heading where `G_D` is singular): the integrator then restarts from
//! the same state, expressed in the new independent components.

pub(crate) mod lu;

use crate::error::SimError;
use crate::formulation::dae::Dynamics;
use crate::formulation::reduced::lu::{SquareLu, pivot_columns};
use crate::model::Model;
use crate::settings::{Formulation, Message, Setting};

/// Largest `nc` the reduced formulation takes: it factors the dense
/// `nc x nc` `G_D` at every evaluation (`nc^3 / 3` flops), where the DAE's
/// sparse KKT path grows as `nc`. At 300 rows (a 100-link snake) that is
/// 9e6 flops per evaluation.
pub const MAX_CONSTRAINTS: usize = 300;

/// Which coordinates are independent and which are dependent.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Partition {
    /// Independent coordinates `q_I` (indices into `q`, nq - nh).
    pub q_ind: Vec<usize>,
    /// Dependent coordinates `q_D` (nh), found from `phi(q) = u(t)`.
    pub q_dep: Vec<usize>,
    /// Independent velocities `qd_I` (indices into `qd`, nq - nc).
    pub v_ind: Vec<usize>,
    /// Dependent velocities `qd_D` (nc), found from `G qd = b`.
    pub v_dep: Vec<usize>,
}

/// Re-partition when a pivot ratio of `C_D` or `G_D` falls below this
/// fraction of its value when the partition was chosen.
const DEGRADE: f64 = 0.1;

/// Newton iterations allowed for `q_D`.
const MAX_NEWTON: usize = 12;

/// The smallest pivot of minimal coordinates, as a fraction of the radius
/// of gyration of the body whose angular rate it fixes, that the reduced
/// formulation takes them with.
///
/// A skate row `v_lat = p w` solved for the angular rate `w = v_lat / p`
/// passes the integration error of the lateral speed `v_lat` on to `w`
/// magnified `1 / p`; the Maggi mass matrix `B^T M B` then holds
/// `I / p^2` beside `m`, a condition number of about `(rho / p)^2` with
/// `rho = sqrt(I / m)`. `model!` solves a root body's skate for its
/// lateral velocity instead (pivot 1), so this concerns the skates of
/// hinged bodies (the pivot their distance from the hinge). Measured on
/// the drive scene when skate A's row still fixed body 1's angular rate
/// (DOP853 at 1e-10, radius of gyration 0.47 m): at `p = 0.03 m` minimal coordinates take
/// 5 % more evaluations than the DAE, at 3e-3 m 25 % more and are 10x
/// less accurate, at 1e-3 m 54 % more with an error of 5e-6, and at
/// 1e-6 m the run diverges. Below this fraction (`p < rho / 20`, a
/// condition number above 400) the numeric partition, which pivots on
/// the lateral speed instead, is taken.
pub const MIN_PIVOT_GYRATION: f64 = 0.05;

/// The first pivot of `layout` that rules minimal coordinates out: zero,
/// not finite, or an angular rate's below [`MIN_PIVOT_GYRATION`] times the
/// radius of gyration of its body (from the diagonal mass matrix `mass`,
/// nq); `None` if every pivot is fit. Returns `(skate, pivot [m], radius
/// of gyration [m])`, the radius 0 for a zero or non-finite pivot.
pub fn small_pivot<'a>(
    info: &crate::model::info::ModelInfo,
    mass: &[f64],
    layout: &'a crate::model::info::MinimalLayout,
) -> Option<(&'a str, f64, f64)> {
    layout.pivots.iter().find_map(|(skate, j, p)| {
        if !(*p != 0.0 && p.is_finite()) {
            return Some((skate.as_str(), *p, 0.0));
        }
        let body = info.bodies.iter().find(|b| b.coords[2] == *j)?;
        let (m, inertia) = (mass[body.coords[0]], mass[*j]);
        let rho = (inertia / m).sqrt();
        (rho.is_finite() && p.abs() < MIN_PIVOT_GYRATION * rho).then_some((skate.as_str(), *p, rho))
    })
}

/// Body `j / 3`'s velocity component `j % 3` in its own frame, from the
/// coordinates `q` and global rates `qd` (nq each, three a body:
/// `x, y, phi`): forward and lateral \[m/s\],
/// `(v_x, v_y) = R(phi)^T (xd, yd)`, or the angular rate \[rad/s\]. The
/// speeds of minimal coordinates are these (Kane & Levinson 1985, ch. 4).
pub fn body_velocity<S: crate::scalar::Scalar>(q: &[S], qd: &[S], j: usize) -> S {
    let i = j / 3;
    let (s, c) = (q[3 * i + 2].sin(), q[3 * i + 2].cos());
    let (xd, yd) = (qd[3 * i], qd[3 * i + 1]);
    match j % 3 {
        0 => c * xd + s * yd,
        1 => c * yd - s * xd,
        _ => qd[j],
    }
}

/// The rate of [`body_velocity`] `j` \[m/s^2, rad/s^2\]: from `q`, `qd`
/// and the accelerations `qdd` (nq each), `d/dt (v_x, v_y) = R(phi)^T
/// (xdd, ydd) + w (v_y, -v_x)` (the frame turns at `w = phid`), or the
/// angular acceleration. Generic so that one dual-number pass gives its
/// derivative along a direction (the reduced formulation's
/// sensitivities, `crate::sensitivity`).
pub fn body_acceleration<S: crate::scalar::Scalar>(q: &[S], qd: &[S], qdd: &[S], j: usize) -> S {
    let i = j / 3;
    let (s, c) = q[3 * i + 2].sin_cos();
    let w = qd[3 * i + 2];
    let (xd, yd, xdd, ydd) = (qd[3 * i], qd[3 * i + 1], qdd[3 * i], qdd[3 * i + 1]);
    match j % 3 {
        0 => c * xdd + s * ydd + w * (c * yd - s * xd),
        1 => c * ydd - s * xdd - w * (c * xd + s * yd),
        _ => qdd[j],
    }
}

/// The reduced state and the scratch that expands it to the full one.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// The current partition.
    pub partition: Partition,
    /// Times the partition was re-chosen.
    pub repartitions: u64,
    nq: usize,
    nh: usize,
    nc: usize,
    /// The pattern entries of `C_D`: `(entry, slot in the nh x nh C_D)`.
    c_route: Vec<(usize, usize)>,
    /// The pattern entries of `G_D`: `(entry, slot in the nc x nc G_D)`.
    gd_route: Vec<(usize, usize)>,
    /// The pattern entries of `G_I`: `(entry, row, column)`.
    gi_route: Vec<(usize, usize, usize)>,
    /// Whether each coordinate is a translation `x` or `y`.
    translational: Vec<bool>,
    /// `C_q` is the same at every translation (`phi` affine in `x, y`).
    c_translation_free: bool,
    /// `G` is the same at every translation.
    g_translation_free: bool,
    /// Every dependent coordinate is a translation and `phi` is affine in
    /// them: one Newton step is exact.
    linear: bool,
    c_d: SquareLu,
    /// `C_D` as last factored (its LU is kept while the values repeat:
    /// the hinges' `C_D` in translations is constant).
    c_d_values: Vec<f64>,
    g_d: SquareLu,
    /// `G_D` (nc x nc): zero but at the entries of `gd_route`.
    g_d_values: Vec<f64>,
    phi: Vec<f64>,
    g_values: Vec<f64>,
    r: Vec<f64>,
    /// `q_D` of the last expansion: Newton's start.
    q_dep_last: Vec<f64>,
    /// Full state `[q, qd, W]` of the last expansion, and its derivative.
    y: Vec<f64>,
    /// The `(t, z)` of the last expansion (an evaluation at the accepted
    /// state repeats it).
    expanded_t: f64,
    /// Whether a stage's evaluation may write only the headings of the
    /// full state ([`Reduced::set_lean_stages`]).
    lean_stages: bool,
    expanded_z: Vec<f64>,
    dy: Vec<f64>,
    /// The accepted state, expanded.
    y_accepted: Vec<f64>,
    /// Pivot ratios of `C_D`, `G_D`: when the partition was chosen, at the
    /// last expansion and at the last accepted state.
    quality0: [f64; 2],
    quality: [f64; 2],
    quality_accepted: [f64; 2],
    /// Scratch of the step loop (a dense-output sample's `z`, the
    /// accepted full state where a projection may change it), sized for
    /// the full state when the formulation is built.
    pub(crate) scratch: Vec<f64>,
    /// The partition and the expansion in closed form, when `model!`
    /// derived the model's minimal coordinates ([`crate::model::info::MinimalLayout`]).
    minimal: Option<Minimal>,
}

/// The minimal-coordinate path: the partition of [`crate::model::info::MinimalLayout`]
/// (fixed: its pivots are constants), `q_D`, `qd_D`, `B = dqd/dqd_I` and
/// `c` from the model's generated [`Model::minimal_expand`], and `qdd_I`
/// from Maggi's equations `B^T M B qdd_I = B^T (f - M c)` (nu x nu); or,
/// where the model has it, all of this in one pass of its generated
/// [`Model::minimal_rhs`] (the fused right-hand side).
#[derive(Debug, Clone)]
struct Minimal {
    /// `B` (nq x nu, row-major) and `c` (nq) of the last expansion.
    b: Vec<f64>,
    c: Vec<f64>,
    /// `B^T M B` (nu x nu), `B^T (f - M c)` (nu) and the LDL^T scratch
    /// (for nu > 8; smaller systems are factored in registers).
    a: Vec<f64>,
    r: Vec<f64>,
    ldl: Vec<f64>,
    /// The fused right-hand side's constants ([`Model::minimal_constants`]),
    /// `None` where it is not taken.
    constants: Option<Vec<f64>>,
    /// `F` at the expansion's key (`Reduced::expanded_t`, `expanded_z`),
    /// when `dz_cached`: an accepted state's, evaluated by `accept`, which
    /// the next step's first stage then reads.
    dz: Vec<f64>,
    dz_cached: bool,
    /// Whether the model expands a state that is only output by
    /// [`Model::minimal_state`], so that a dense-output sample's
    /// expansion can wait for the output ([`Reduced::sample_places`]).
    state_only: bool,
    /// Whether every effect is a hinge law, or there is none
    /// ([`Dynamics::hinges_only`]): asked once, when the formulation is
    /// built for a run, which switches effects on and off but never
    /// changes their laws.
    hinges_only: bool,
}

impl Reduced {
    /// The partition for the consistent full state `y = [q, qd, W]` of
    /// `sys` at `t`.
    ///
    /// # Errors
    /// [`SimError::Formulation`] if the constraints are dependent at `y`.
    pub fn new<M: Model>(sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<Self, SimError> {
        let info = &sys.info;
        let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
        if nc > MAX_CONSTRAINTS {
            return Err(SimError::Formulation {
                reason: Message::text(format!(
                    "model {} has {nc} constraint rows, more than the {MAX_CONSTRAINTS} whose dense G_D the reduced formulation factors at every evaluation; take ",
                    info.name
                ))
                .setting(Setting::Formulation(Formulation::Dae))
                .then(" (its sparse KKT path)"),
            });
        }
        if let Some(red) = Self::minimal(sys, t, y)? {
            return Ok(red);
        }
        let mut translational = vec![false; nq];
        for b in &info.bodies {
            translational[b.coords[0]] = true;
            translational[b.coords[1]] = true;
        }
        let nnz = info.pattern.len();
        let (mut g0, mut g1) = (vec![0.0; nnz], vec![0.0; nnz]);
        let mut shifted = y[..nq].to_vec();
        for (k, v) in shifted.iter_mut().enumerate().filter(|(k, _)| translational[*k]) {
            *v += 0.37 + 0.11 * k as f64;
        }
        sys.model.constraint_matrix(&y[..nq], &mut g0);
        sys.model.constraint_matrix(&shifted, &mut g1);
        let same = |k: usize| g0[k].to_bits() == g1[k].to_bits();
        let nhz = info.n_holonomic_nonzeros();
        let empty = Partition { q_ind: vec![], q_dep: vec![], v_ind: vec![], v_dep: vec![] };
        let mut red = Self {
            c_translation_free: (0..nhz).all(same),
            g_translation_free: (0..nnz).all(same),
            translational,
            c_d: SquareLu::new(nh),
            c_d_values: vec![f64::NAN; nh * nh],
            g_d: SquareLu::new(nc),
            g_d_values: vec![0.0; nc * nc],
            phi: vec![0.0; nh],
            g_values: g0,
            r: vec![0.0; nc],
            q_dep_last: vec![0.0; nh],
            dy: vec![0.0; y.len()],
            ..Self::with_partition(empty, (nq, nh, nc), y)
        };
        red.choose(sys, t, y)?;
        Ok(red)
    }

    /// A reduced state on `partition` at the full state `y`, with no
    /// scratch for either expansion: what the two constructors share.
    fn with_partition(partition: Partition, (nq, nh, nc): (usize, usize, usize), y: &[f64]) -> Self {
        Self {
            partition,
            repartitions: 0,
            nq,
            nh,
            nc,
            c_route: Vec::new(),
            gd_route: Vec::new(),
            gi_route: Vec::new(),
            translational: Vec::new(),
            c_translation_free: true,
            g_translation_free: true,
            linear: false,
            c_d: SquareLu::new(0),
            c_d_values: Vec::new(),
            g_d: SquareLu::new(0),
            g_d_values: Vec::new(),
            phi: Vec::new(),
            g_values: Vec::new(),
            r: Vec::new(),
            q_dep_last: Vec::new(),
            y: y.to_vec(),
            expanded_t: f64::NAN,
            lean_stages: false,
            expanded_z: Vec::new(),
            dy: Vec::new(),
            y_accepted: y.to_vec(),
            quality0: [1.0; 2],
            quality: [1.0; 2],
            quality_accepted: [1.0; 2],
            // room for the full state (a dense-output sample's `z` is
            // shorter): the step loop never grows it
            scratch: Vec::with_capacity(y.len()),
            minimal: None,
        }
    }

    /// The reduced state on the model's minimal coordinates, if `model!`
    /// derived them, the scene has no drive and every pivot is well away
    /// from zero at the current parameters ([`small_pivot`]); `None`
    /// otherwise (the numeric partition).
    ///
    /// # Errors
    /// [`SimError::Formulation`] if the expansion of `y` fails.
    fn minimal<M: Model>(sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<Option<Self>, SimError> {
        let Ok(layout) = sys.model.minimal_layout() else {
            return Ok(None);
        };
        if !sys.drives.is_empty() || small_pivot(&sys.info, &sys.mass, &layout).is_some() {
            return Ok(None);
        }
        // Maggi's equations in the body frames take each body's mass alike
        // along x and y (a rotation leaves M unchanged)
        if sys.mass.chunks_exact(3).any(|m| m[0].to_bits() != m[1].to_bits()) {
            return Ok(None);
        }
        let info = &sys.info;
        let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
        let nu = layout.speeds.len();
        let rest = |keep: &[usize]| (0..nq).filter(|j| !keep.contains(j)).collect::<Vec<_>>();
        let partition = Partition {
            q_dep: rest(&layout.coords),
            v_dep: rest(&layout.speeds),
            q_ind: layout.coords,
            v_ind: layout.speeds,
        };
        if partition.q_dep.len() != nh || partition.v_dep.len() != nc {
            return Ok(None);
        }
        // the fused right-hand side has the model's own masses built in
        let mut own_mass = vec![0.0; nq];
        sys.model.mass_diagonal(&mut own_mass);
        let same_mass = own_mass.iter().zip(&sys.mass).all(|(a, b)| a.to_bits() == b.to_bits());
        let constants = sys.model.minimal_constants().filter(|_| same_mass);
        let mut red = Self {
            linear: true,
            minimal: Some(Minimal {
                b: vec![0.0; nq * nu],
                c: vec![0.0; nq + 2 * (nq / 3)],
                a: vec![0.0; nu * nu],
                r: vec![0.0; nu],
                ldl: vec![0.0; nu * (nu + 1)],
                constants,
                dz: vec![0.0; y.len() - nh - nc],
                dz_cached: false,
                state_only: false,
                hinges_only: sys.hinges_only(),
            }),
            ..Self::with_partition(partition, (nq, nh, nc), y)
        };
        let mut z = vec![0.0; red.nz(y.len())];
        red.gather(y, &mut z);
        // whether the model has `minimal_state`: asked once, on a copy
        let mut probe = y.to_vec();
        let (q, qd) = place_minimal(&red.partition, nq, &mut probe, &z, true);
        let state_only = sys.model.minimal_state(q, qd);
        red.minimal.as_mut().expect("minimal path").state_only = state_only;
        red.expand(sys, t, &z)?;
        red.y_accepted.copy_from_slice(&red.y);
        Ok(Some(red))
    }

    /// Whether the right-hand side is the model's fused one
    /// ([`Model::minimal_rhs`]).
    pub fn is_fused(&self) -> bool {
        self.minimal.as_ref().is_some_and(|m| m.constants.is_some())
    }

    /// Whether the partition and the expansion are the closed form of the
    /// model's minimal coordinates ([`crate::model::info::MinimalLayout`]): no Newton
    /// step, no factorization of `G_D`, never a new partition.
    pub fn is_minimal(&self) -> bool {
        self.minimal.is_some()
    }

    /// Chooses the partition at the full state `y` (Gaussian elimination
    /// with full pivoting) and records its pivot ratios.
    fn choose<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, y: &[f64]) -> Result<(), SimError> {
        let info = &sys.info;
        let (nq, nh, nc) = (self.nq, self.nh, self.nc);
        sys.model.constraint_matrix(&y[..nq], &mut self.g_values);
        let mut dense = vec![0.0; nc * nq];
        crate::model::info::scatter_dense(&info.pattern, &self.g_values, nq, &mut dense);
        let dependent = |rows: usize, k: usize| {
            SimError::Formulation {
            reason: Message::text(format!(
                "at t = {} s only {k} of the {rows} {} rows of G are independent; the reduced formulation needs independent constraints (",
                crate::names::fmt_value(t),
                if rows == nh { "holonomic" } else { "constraint" }
            ))
            .setting(Setting::Formulation(Formulation::Dae))
            .then(" names the dependent one)"),
        }
        };
        let q_dep =
            pivot_columns(&mut dense[..nh * nq].to_vec(), nh, nq, &self.translational).map_err(|k| dependent(nh, k))?;
        let v_dep = pivot_columns(&mut dense, nc, nq, &self.translational).map_err(|k| dependent(nc, k))?;
        let rest = |dep: &[usize]| (0..nq).filter(|j| !dep.contains(j)).collect::<Vec<_>>();
        self.partition = Partition { q_ind: rest(&q_dep), v_ind: rest(&v_dep), q_dep, v_dep };
        self.expanded_t = f64::NAN;
        // the routes of the pattern's entries into C_D, G_D and G_I; C_D
        // zero outside them and NaN at them (refactored at once), G_D zero
        let position = |dep: &[usize], c: usize| dep.iter().position(|&d| d == c);
        self.c_d_values.fill(0.0);
        self.g_d_values.fill(0.0);
        self.c_route.clear();
        self.gd_route.clear();
        self.gi_route.clear();
        for (k, &(r, c)) in info.pattern.iter().enumerate() {
            if r < nh
                && let Some(j) = position(&self.partition.q_dep, c)
            {
                self.c_route.push((k, r * nh + j));
                self.c_d_values[r * nh + j] = f64::NAN;
            }
            match position(&self.partition.v_dep, c) {
                Some(j) => self.gd_route.push((k, r * nc + j)),
                None => self.gi_route.push((k, r, c)),
            }
        }
        for (i, &j) in self.partition.q_dep.iter().enumerate() {
            self.q_dep_last[i] = y[j];
        }
        self.linear = self.c_translation_free && self.partition.q_dep.iter().all(|&j| self.translational[j]);
        let mut z = vec![0.0; self.nz(y.len())];
        self.gather(y, &mut z);
        self.expand(sys, t, &z)?;
        self.quality0 = self.quality;
        self.quality_accepted = self.quality;
        Ok(())
    }

    /// Whether the dependent coordinates follow from one Newton step: all
    /// are translations and `phi` is affine in them.
    pub fn is_linear(&self) -> bool {
        self.linear
    }

    /// Length of the reduced state for a full state of length `ny`:
    /// `(nq - nh) + (nq - nc) + ` the work states.
    pub fn nz(&self, ny: usize) -> usize {
        ny - self.nh - self.nc
    }

    /// The reduced state `z = [q_I, qd_I, W]` of the full `y = [q, qd, W]`
    /// (on minimal coordinates the speeds are body-frame velocities,
    /// [`body_velocity`]).
    pub fn gather(&self, y: &[f64], z: &mut [f64]) {
        let (ni, nf) = (self.partition.q_ind.len(), self.partition.v_ind.len());
        for (zi, &j) in z.iter_mut().zip(&self.partition.q_ind) {
            *zi = y[j];
        }
        for (zi, &j) in z[ni..].iter_mut().zip(&self.partition.v_ind) {
            let (q, qd) = y.split_at(self.nq);
            *zi = if self.minimal.is_some() { body_velocity(q, qd, j) } else { qd[j] };
        }
        z[ni + nf..].copy_from_slice(&y[2 * self.nq..]);
    }

    /// Name of component `k` of the reduced state `z`, as
    /// [`Dynamics::state_name`] names the full one (`phi2`, `x1d`, `W_motor`).
    pub fn state_name<M: Model>(&self, sys: &Dynamics<M>, k: usize) -> String {
        let (ni, nf) = (self.partition.q_ind.len(), self.partition.v_ind.len());
        if k < ni {
            sys.state_name(self.partition.q_ind[k])
        } else if k < ni + nf {
            let j = self.partition.v_ind[k - ni];
            match (&self.minimal, j % 3) {
                (Some(_), axis @ (0 | 1)) => {
                    let body = sys.info.bodies.iter().find(|b| b.coords[axis] == j).map_or("?", |b| b.name.as_str());
                    format!("{} velocity of {body} in its frame", ["forward", "lateral"][axis])
                }
                _ => sys.state_name(self.nq + j),
            }
        } else {
            sys.state_name(2 * self.nq + k - ni - nf)
        }
    }

    /// The full state of the last expansion.
    pub fn full(&self) -> &[f64] {
        &self.y
    }

    /// Expands the reduced `z` at `t` into the full state ([`Reduced::full`]):
    /// `q_D` by Newton's method on `phi(q) = u(t)`, `qd_D` from `G qd = b(t)`.
    ///
    /// # Errors
    /// [`SimError::Formulation`] if Newton's method does not converge or
    /// `C_D` or `G_D` is singular at this state.
    pub fn expand<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, z: &[f64]) -> Result<(), SimError> {
        if t.to_bits() == self.expanded_t.to_bits() && z == self.expanded_z.as_slice() {
            return Ok(());
        }
        if let Some(m) = &mut self.minimal {
            m.dz_cached = false;
            self.expand_minimal(&sys.model, z, true);
            self.expanded_t = t;
            self.expanded_z.clear();
            self.expanded_z.extend_from_slice(z);
            return Ok(());
        }
        // an expansion that fails leaves no key behind
        self.expanded_t = f64::NAN;
        let (nq, nh, nc) = (self.nq, self.nh, self.nc);
        let (ni, nf) = (nq - nh, nq - nc);
        let model = &sys.model;
        let (q, rest) = self.y.split_at_mut(nq);
        let (qd, works) = rest.split_at_mut(nq);
        for (&zi, &j) in z.iter().zip(&self.partition.q_ind) {
            q[j] = zi;
        }
        for (&v, &j) in self.q_dep_last.iter().zip(&self.partition.q_dep) {
            q[j] = v;
        }
        works.copy_from_slice(&z[ni + nf..]);
        // positions: Newton's method on phi(q) - u(t) = 0 over q_D
        let mut g_fresh = false;
        if nh > 0 {
            let mut converged = false;
            for _ in 0..MAX_NEWTON {
                model.phi_and_constraint_matrix(q, &mut self.phi, &mut self.g_values);
                crate::drive::shift_positions(&sys.drives, t, &mut self.phi);
                let mut same = true;
                for &(k, slot) in &self.c_route {
                    let (old, v) = (&mut self.c_d_values[slot], self.g_values[k]);
                    same &= old.to_bits() == v.to_bits();
                    *old = v;
                }
                if !same {
                    self.quality[0] = self.c_d.factor(&self.c_d_values);
                }
                if self.quality[0] == 0.0 {
                    return Err(self.failure(t, "C_D, the dependent coordinates' columns of C_q, is singular"));
                }
                self.c_d.solve(&mut self.phi);
                let mut step = 0.0f64;
                let mut size = 1.0f64;
                for (&d, &j) in self.phi.iter().zip(&self.partition.q_dep) {
                    q[j] -= d;
                    step = step.max(d.abs());
                    size = size.max(q[j].abs());
                }
                // an affine phi is solved by one step; otherwise quadratic
                // convergence leaves ~step^2 after a step below 1e-10
                if self.linear || step <= 1e-10 * size {
                    converged = step.is_finite();
                    g_fresh = self.g_translation_free && self.linear;
                    break;
                }
            }
            if !converged {
                return Err(self.failure(t, "Newton's method for the dependent coordinates did not converge"));
            }
            for (v, &j) in self.q_dep_last.iter_mut().zip(&self.partition.q_dep) {
                *v = q[j];
            }
        }
        if !g_fresh {
            model.constraint_matrix(q, &mut self.g_values);
        }
        // velocities: G_D qd_D = b(t) - G_I qd_I
        for (&zi, &j) in z[ni..].iter().zip(&self.partition.v_ind) {
            qd[j] = zi;
        }
        self.r.fill(0.0);
        for &(k, slot) in &self.gd_route {
            self.g_d_values[slot] = self.g_values[k];
        }
        for &(k, r, c) in &self.gi_route {
            self.r[r] -= self.g_values[k] * qd[c];
        }
        for d in &sys.drives {
            self.r[d.row] += d.angle.eval3(t)[1];
        }
        self.quality[1] = self.g_d.factor(&self.g_d_values);
        if self.quality[1] == 0.0 {
            return Err(self.failure(t, "G_D, the dependent velocities' columns of G, is singular"));
        }
        self.g_d.solve(&mut self.r);
        for (&v, &j) in self.r.iter().zip(&self.partition.v_dep) {
            qd[j] = v;
        }
        self.expanded_t = t;
        self.expanded_z.clear();
        self.expanded_z.extend_from_slice(z);
        Ok(())
    }

    fn failure(&self, t: f64, what: &str) -> SimError {
        SimError::Formulation {
            reason: format!("at t = {} s {what}; the reduced formulation cannot go on", crate::names::fmt_value(t))
                .into(),
        }
    }

    /// `dz = F(t, z)`: the full state expanded, the DAE's right-hand side
    /// there, its independent components kept.
    ///
    /// # Errors
    /// As [`Reduced::expand`] and [`Dynamics::rhs`].
    #[inline(always)]
    pub fn eval<M: Model>(&mut self, sys: &mut Dynamics<M>, t: f64, z: &[f64], dz: &mut [f64]) -> Result<(), SimError> {
        // the fused path inline in the integrator's stage loop (one call,
        // the model's, per evaluation); the rest out of line
        if let Some(m) = &mut self.minimal
            && m.constants.is_some()
            && !m.dz_cached
        {
            self.eval_fused(sys, t, z, dz, self.lean_stages)?;
            sys.counters.rhs_evals += 1;
            return Ok(());
        }
        self.eval_general(sys, t, z, dz)
    }

    /// [`Reduced::eval`] but for the fused path's common case.
    #[inline(never)]
    fn eval_general<M: Model>(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        z: &[f64],
        dz: &mut [f64],
    ) -> Result<(), SimError> {
        if let Some(m) = &mut self.minimal
            && m.constants.is_some()
        {
            // the accepted state's F, evaluated by `accept`
            if m.dz_cached && t.to_bits() == self.expanded_t.to_bits() && z == self.expanded_z.as_slice() {
                dz.copy_from_slice(&m.dz);
                m.dz_cached = false;
            } else {
                self.eval_fused(sys, t, z, dz, self.lean_stages)?;
            }
            sys.counters.rhs_evals += 1;
            return Ok(());
        }
        if self.minimal.is_some() {
            // the accepted state was expanded by `accept`, and F there (the
            // next step's k1) reuses it; a stage's time differs from the
            // key's, so the check costs one comparison. A stage's expansion
            // leaves out the work states, so it leaves no key.
            if t.to_bits() != self.expanded_t.to_bits() || z != self.expanded_z.as_slice() {
                self.expand_minimal(&sys.model, z, false);
                self.expanded_t = f64::NAN;
            }
            return self.eval_minimal(sys, t, dz);
        }
        self.expand(sys, t, z)?;
        sys.rhs(t, &self.y, &mut self.dy)?;
        let nq = self.nq;
        let (ni, nf) = (self.partition.q_ind.len(), self.partition.v_ind.len());
        for (d, &j) in dz.iter_mut().zip(&self.partition.q_ind) {
            *d = self.dy[j];
        }
        for (d, &j) in dz[ni..].iter_mut().zip(&self.partition.v_ind) {
            *d = self.dy[nq + j];
        }
        dz[ni + nf..].copy_from_slice(&self.dy[2 * nq..]);
        Ok(())
    }

    /// [`Reduced::expand`] for a state that is only output (a dense-output
    /// sample): on minimal coordinates by the model's [`Model::minimal_state`]
    /// when it has one, the same `q` and `qd` without `B` and `c` (about
    /// 240 instructions fewer per sample on the EzyRoller, callgrind); it
    /// leaves no key, so the next evaluation expands its own state.
    ///
    /// # Errors
    /// As [`Reduced::expand`].
    pub fn expand_sample<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, z: &[f64]) -> Result<(), SimError> {
        if let Some(m) = &mut self.minimal {
            let (q, qd) = place_minimal(&self.partition, self.nq, &mut self.y, z, true);
            if sys.model.minimal_state(q, qd) {
                m.dz_cached = false;
                self.expanded_t = f64::NAN;
                return Ok(());
            }
        }
        self.expand(sys, t, z)
    }

    /// Whether a dense-output sample's expansion waits for the output:
    /// on minimal coordinates whose model has [`Model::minimal_state`],
    /// the sample's row holds `z` until it is placed ([`Reduced::sample_places`]) and
    /// [`complete_sample`] finishes it when it is observed (as the DAE's
    /// samples are projected then), off the step loop.
    pub fn defers_samples(&self) -> bool {
        self.minimal.as_ref().is_some_and(|m| m.state_only)
    }

    /// Where each component of the minimal state `z` (np + nu + works)
    /// goes in the full state `y = [q, qd, W]` (`ny` = 2 nq + works): the kept
    /// coordinates, the independent speeds and the works, the rest left
    /// for [`complete_sample`]. The same places as the expansion's; on
    /// minimal coordinates the partition is fixed for the run.
    pub fn sample_places(&self, ny: usize) -> Vec<usize> {
        let nq = self.nq;
        let works = ny - 2 * nq;
        let mut places = Vec::with_capacity(ny - self.nh - self.nc);
        places.extend(&self.partition.q_ind);
        places.extend(self.partition.v_ind.iter().map(|&j| nq + j));
        places.extend((0..works).map(|w| 2 * nq + w));
        places
    }

    /// The full state of `z` on minimal coordinates: the kept coordinates
    /// and the independent speeds copied, the rest, `B` and `c` from the
    /// model's [`Model::minimal_expand`]; the work states too if `works`
    /// (a right-hand side reads none of them).
    #[inline]
    fn expand_minimal<M: Model>(&mut self, model: &M, z: &[f64], works: bool) {
        let m = self.minimal.as_mut().expect("minimal path");
        let (q, qd) = place_minimal(&self.partition, self.nq, &mut self.y, z, works);
        model.minimal_expand(q, qd, &mut m.b, &mut m.c);
    }

    /// [`Reduced::eval`] on minimal coordinates, at the expanded state:
    /// `pd` from the expansion, `B^T M B u' = B^T (f - M c)` by LDL^T, the
    /// effects' powers.
    fn eval_minimal<M: Model>(&mut self, sys: &mut Dynamics<M>, t: f64, dz: &mut [f64]) -> Result<(), SimError> {
        let m = self.minimal.as_mut().expect("minimal path");
        let nq = self.nq;
        let (ni, nu) = (self.partition.q_ind.len(), self.partition.v_ind.len());
        let q = &self.y[..nq];
        let (pd, rest) = dz.split_at_mut(ni);
        let (ud, power) = rest.split_at_mut(nu);
        let qd = &self.y[nq..2 * nq];
        sys.applied_forces(t, q, qd, power)?;
        sys.model.minimal_maggi(&sys.mass, &m.b, &m.c, sys.applied_force(), &mut m.a, &mut m.r);
        crate::kkt::spd::ldl_solve(&m.a, nu, nu, &m.r, ud, &mut m.ldl).map_err(|source| SimError::Formulation {
            reason: format!(
                "at t = {} s Maggi's equations on the minimal coordinates cannot be solved: {source}",
                crate::names::fmt_value(t)
            )
            .into(),
        })?;
        for (d, &j) in pd.iter_mut().zip(&self.partition.q_ind) {
            *d = self.y[nq + j];
        }
        sys.counters.rhs_evals += 1;
        Ok(())
    }

    /// [`Reduced::eval`] by the model's fused [`Model::minimal_rhs`]: the
    /// full `q, qd` into [`Reduced::full`] (no key: the work states are
    /// not copied), or where `lean` only what the hinge torques read
    /// ([`Model::minimal_rhs_lean`]); `dz` whole. Counts no evaluation
    /// (the caller does).
    #[inline(always)]
    fn eval_fused<M: Model>(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        z: &[f64],
        dz: &mut [f64],
        lean: bool,
    ) -> Result<(), SimError> {
        let m = self.minimal.as_mut().expect("minimal path");
        self.expanded_t = f64::NAN;
        m.dz_cached = false;
        sys.minimal_rhs(t, m.constants.as_deref().expect("fused path"), z, &mut self.y, dz, lean, m.hinges_only)
    }

    /// Lets the stages' evaluations on the fused path leave the full
    /// state unwritten but for the headings ([`Model::minimal_rhs_lean`]):
    /// for a step loop that evaluates every accepted state anew
    /// ([`Reduced::accept`] with `evaluated` false), so that the full
    /// state it keeps is always a whole one. Off until a step loop says so.
    pub fn set_lean_stages(&mut self, on: bool) {
        self.lean_stages = on;
    }

    /// Expands the accepted state `z` at `t` and keeps it
    /// ([`Reduced::accepted`]) with its pivot ratios. On the fused path
    /// ([`Reduced::is_fused`]) it evaluates `F` there as well, which the
    /// next evaluation, the next step's first stage, then reads, unless
    /// `evaluated`: the last evaluation was at this `z` (the last stage of
    /// a method with the first-same-as-last property, DOPRI5), so its full
    /// state is already there.
    ///
    /// # Errors
    /// As [`Reduced::expand`]; on the fused path as [`Reduced::eval`].
    pub fn accept<M: Model>(
        &mut self,
        sys: &mut Dynamics<M>,
        t: f64,
        z: &[f64],
        evaluated: bool,
    ) -> Result<(), SimError> {
        if self.is_fused() {
            if !evaluated {
                let mut dz = std::mem::take(&mut self.minimal.as_mut().expect("minimal path").dz);
                let res = self.eval_fused(sys, t, z, &mut dz, false);
                let m = self.minimal.as_mut().expect("minimal path");
                m.dz = dz;
                res?;
                m.dz_cached = true;
            }
            let (nq, nw) = (self.nq, self.y.len() - 2 * self.nq);
            self.y[2 * nq..].copy_from_slice(&z[z.len() - nw..]);
            self.expanded_t = t;
            self.expanded_z.clear();
            self.expanded_z.extend_from_slice(z);
        } else {
            self.expand(sys, t, z)?;
        }
        self.y_accepted.copy_from_slice(&self.y);
        self.quality_accepted = self.quality;
        Ok(())
    }

    /// Forgets the right-hand side [`Reduced::accept`] evaluated ahead
    /// (and the expansion it is keyed by): the forces changed at this
    /// state (an effect switched at an event), so the next evaluation
    /// computes its own.
    pub fn forget_evaluation(&mut self) {
        if let Some(m) = &mut self.minimal {
            m.dz_cached = false;
        }
        self.expanded_t = f64::NAN;
    }

    /// The full state of the last accepted one ([`Reduced::accept`]).
    pub fn accepted(&self) -> &[f64] {
        &self.y_accepted
    }

    /// [`Reduced::accepted`] for a run's checks of the accepted state
    /// ([`crate::simulate`]'s `Run::after_step`), which change it only
    /// where they project it: never on this formulation, whose run has
    /// no projection.
    pub(crate) fn accepted_mut(&mut self) -> &mut [f64] {
        &mut self.y_accepted
    }

    /// After the accepted state's outputs: when a pivot ratio of `C_D` or
    /// `G_D` there fell below a tenth of its value at the partition's
    /// choice, a new partition at that state, and `z` rewritten in it.
    /// Returns whether it did.
    ///
    /// # Errors
    /// As [`Reduced::new`].
    #[inline]
    pub fn repartition<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, z: &mut [f64]) -> Result<bool, SimError> {
        if !self.degraded() {
            return Ok(false);
        }
        self.choose_again(sys, t, z)
    }

    /// Whether a pivot ratio of `C_D` or `G_D` at the accepted state fell
    /// below a tenth of its value at the partition's choice: what
    /// [`Reduced::repartition`] re-chooses the partition at.
    #[inline]
    pub fn degraded(&self) -> bool {
        let [c, g] = self.quality_accepted;
        c < DEGRADE * self.quality0[0] || g < DEGRADE * self.quality0[1]
    }

    /// [`Reduced::repartition`] once its pivots fell: the new partition.
    ///
    /// # Errors
    /// As [`Reduced::new`].
    #[cold]
    #[inline(never)]
    fn choose_again<M: Model>(&mut self, sys: &Dynamics<M>, t: f64, z: &mut [f64]) -> Result<bool, SimError> {
        let y = self.y_accepted.clone();
        self.choose(sys, t, &y)?;
        self.gather(&y, z);
        self.repartitions += 1;
        Ok(true)
    }
}

/// Completes a row placed at [`Reduced::sample_places`] into the full
/// state `y = [q, qd, W]` (2 nq + works): the dependent coordinates of `q`
/// and all of `qd` (the independent speeds placed there are body-frame
/// speeds; the model writes the global rates) \[m, rad, m/s, rad/s\] by
/// the model's [`Model::minimal_state`], the same expressions as
/// [`Reduced::expand_sample`] and so the same numbers. Returns whether the
/// model did so.
pub fn complete_sample<M: Model>(model: &M, nq: usize, y: &mut [f64]) -> bool {
    let (q, rest) = y.split_at_mut(nq);
    model.minimal_state(q, &mut rest[..nq])
}

/// The kept coordinates and the independent speeds of `z` into the full
/// state `y = [q, qd, W]` (nq coordinates; `partition`'s places), its work states too if
/// `works`; returns `q` and `qd` (nq each) for the model's expansion to
/// complete.
#[inline(always)]
fn place_minimal<'y>(
    partition: &Partition,
    nq: usize,
    y: &'y mut [f64],
    z: &[f64],
    works: bool,
) -> (&'y mut [f64], &'y mut [f64]) {
    let (ni, nf) = (partition.q_ind.len(), partition.v_ind.len());
    let (q, rest) = y.split_at_mut(nq);
    let (qd, w) = rest.split_at_mut(nq);
    for (&zi, &j) in z.iter().zip(&partition.q_ind) {
        q[j] = zi;
    }
    for (&zi, &j) in z[ni..].iter().zip(&partition.v_ind) {
        qd[j] = zi;
    }
    if works {
        w.copy_from_slice(&z[ni + nf..]);
    }
    (q, qd)
}
