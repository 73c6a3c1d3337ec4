//! The geometry of locomotion: the local connection, the momentum
//! equation and the constraint curvature of a model with the plane's
//! symmetry, derived from the constraints the `model!` macro generated.
//!
//! A vehicle or snake whose bodies are joined by hinges in a tree has
//! configuration `(g, r)`: the position `g` in SE(2) of one body's frame
//! (the reference body) and the shape `r` (n_shape), its hinge angles,
//! each `phi_a - phi_b` of its hinge as drives take it. Its velocity is
//! `(xi, r')`, `xi = (u, v, w)` the reference body's velocity in its own
//! frame (forward and lateral \[m/s\], yaw rate \[rad/s\]). The skates'
//! rows `S(q) qd = 0` read `Omega(r) xi + Psi(r) r' = 0`: `Omega`
//! (n_skates x 3) holds what the skates ask of a rigid motion of the
//! locked system, `Psi` (n_skates x n_shape) what they ask of a change of
//! shape. Where `Omega` has rank 3 (a kinematic system: the three-link
//! kinematic snake) the body velocity is fixed by the shape's,
//!
//! `xi = -A(r) r'`, `A = Omega^-1 Psi` (3 x n_shape),
//!
//! the local connection (Ostrowski & Burdick, "The geometric mechanics of
//! undulatory robotic locomotion", IJRR 17(7), 1998; Hatton & Choset,
//! "Geometric motion planning: the local connection, Stokes's theorem,
//! and the importance of coordinate choice", IJRR 30(8), 2011, whose sign
//! convention this is). Where `Omega` has rank `3 - m` (a mixed system:
//! the Chaplygin sleigh, m = 2; the EzyRoller, roller racer and
//! snakeboard, m = 1) the constraints leave `m` directions `K(r)` (3 x m)
//! of the locked motion free, and the nonholonomic momentum `p` (m)
//! along them carries what the constraints do not fix (Bloch,
//! Krishnaprasad, Marsden & Murray, "Nonholonomic mechanical systems with
//! symmetry", ARMA 136, 1996):
//!
//! `xi = -A(r) r' + Gamma(r) p`, `Gamma = K (K^T I_loc K)^-1` (3 x m),
//!
//! `p_j = V_j^T M qd`, `p' = (dV/dt)^T M qd + V^T F`,
//!
//! with `V = E K` (nq x m) the velocities of the locked system along the
//! free directions (`E(q)` (nq x 3) maps `xi` to every body's velocity),
//! `I_loc = E^T M E` (3 x 3) the locked inertia in the reference body's
//! frame, `A` the part of the velocity M-orthogonal to `V`, and `F` (nq)
//! the applied forces: the constraint forces do no work along `V`, so
//! the momentum equation needs none of them. The free directions are
//! taken with fixed components of `xi` (the forward speed `u` first where
//! the skates allow it), so `p` is the forward momentum of the sleigh and
//! the EzyRoller.
//!
//! - [`Geometry`]: the split, `A(r)`, `Gamma(r)`, the momentum and its
//!   rate, and the curvature `D(-A) = -dA + [A_i, A_j]` (the height
//!   functions of Hatton & Choset) by forward-mode differentiation of the
//!   same code (dual numbers through the generated constraints).
//! - [`gait`]: a closed curve in shape space, the net motion it gives by
//!   the body-velocity integral (first order) and with the curvature's
//!   correction (second order), by reconstruction (integrating
//!   `g' = g xi` and the momentum exactly), and as a simulation prescribes
//!   it.
//!
//! The gait of a kinematic system that maximizes its net motion is
//! sought in [`crate::design::gait`].

pub mod gait;
mod linalg;
mod momentum;
mod terms;

pub use gait::{Gait, GaitPrediction, SimulatedGait};
pub use momentum::MomentumTerm;

use crate::analysis::Analysis;
use crate::error::SimError;
use crate::model::Model;
use crate::model::info::ModelInfo;

/// Why a geometric analysis failed.
#[derive(Debug, thiserror::Error)]
pub enum GeometryError {
    /// The model has no split into position and shape this analysis
    /// knows: no plane symmetry (a hinge to the ground), a slider, bodies
    /// not joined by hinges, a loop, skates that restrict the shape
    /// velocities themselves.
    #[error("{reason}")]
    Model {
        /// What, naming the item.
        reason: String,
    },
    /// At this shape the constraints lose rank in `g`: the connection is
    /// singular (the three skate normals of the kinematic snake meet in a
    /// point).
    #[error("{reason}")]
    Singular {
        /// Where, with the measure of rank.
        reason: String,
    },
    /// A request that does not fit: a name the model does not have, a
    /// shape of the wrong length, a value that is not finite.
    #[error("{reason}")]
    Request {
        /// What is wrong, naming the culprit.
        reason: String,
    },
    /// A simulation or force evaluation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The stop hook ([`Geometry::stop_when`]) asked to stop.
    #[error("the geometric analysis was stopped")]
    Stopped,
}

/// Most bodies (and most skates) a model may have for the geometric
/// analysis: its setup tests the rank of the skates' rows (singular values
/// of an n_skates x (3 + n_shape) matrix) and walks the hinge tree from
/// every body, work that grows as the cube of the count (400 bodies took
/// 0.25 s, 1600 took 15 s, 3000 about two minutes). The analysis needs at
/// most three independent skate rows, which few bodies carry.
pub const MAX_BODIES: usize = 400;

/// One step of the hinge tree out from the reference body: `child`
/// placed from `parent` across `hinge`.
#[derive(Debug, Clone)]
struct TreeStep {
    /// Index in [`ModelInfo::hinges`].
    hinge: usize,
    /// Shape coordinate of the hinge.
    shape: usize,
    /// The body already placed.
    parent: usize,
    /// The body placed by this step.
    child: usize,
    /// `d phi_child / d r`: +1 when the child is the hinge's first body
    /// (`r = phi_a - phi_b`), -1 when it is the second.
    sign: f64,
    /// The coefficient of the child's position in its hinge's residual
    /// rows (+1 or -1), measured at construction.
    coefficient: f64,
    /// The bodies beyond the hinge (the child's subtree), which turn
    /// about the hinge when its angle changes with the reference fixed.
    subtree: Vec<usize>,
}

/// A model seen as position and shape: its local connection, momentum
/// equation and curvature (see the module's documentation).
#[derive(Debug)]
pub struct Geometry<M: Model> {
    model: M,
    info: ModelInfo,
    /// Diagonal of `M` (nq).
    mass: Vec<f64>,
    /// The reference body.
    body: usize,
    /// The hinge of each shape coordinate, in shape order.
    shape: Vec<usize>,
    /// The tree, breadth first from the reference body.
    steps: Vec<TreeStep>,
    /// The skates' rows of `G`.
    skates: Vec<usize>,
    /// The components of `xi` (0 = u, 1 = v, 2 = w) fixed at 1 in the
    /// free directions `K` (m of them).
    free: Vec<usize>,
    /// The rank of `Omega` at a generic shape (3 - m).
    rank: usize,
    /// The scene's forces, for the momentum equation.
    forces: Option<Analysis<M>>,
    /// Asked between the steps of a gait's prediction and simulation:
    /// `true` stops them.
    stop: Option<fn() -> bool>,
}

/// The local connection at one shape.
#[derive(Debug, Clone, PartialEq)]
pub struct Connection {
    /// The shape `r` (n_shape) \[rad\].
    pub shape: Vec<f64>,
    /// `A` (3 x n_shape, row-major): rows `u` \[m/rad\], `v` \[m/rad\],
    /// `w` \[1\]; `xi = -A r' + Gamma p`.
    pub a: Vec<f64>,
    /// `Gamma` (3 x m, row-major): the body velocity per unit momentum
    /// (empty for a kinematic system).
    pub gamma: Vec<f64>,
    /// How far from singular the constraints are at this shape: the
    /// smallest singular value of `Omega` among the `3 - m` it has,
    /// over its largest (0 on the singular set) \[1\].
    pub rank_margin: f64,
}

/// The constraint curvature at one shape (two or more shape coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct Curvature {
    /// The connection there.
    pub connection: Connection,
    /// `dA/dr_k` for each shape coordinate k: n_shape blocks of 3 x
    /// n_shape (row-major), the block of k first.
    pub da: Vec<f64>,
    /// The height functions `D(-A)_ij = -(dA_j/dr_i - dA_i/dr_j) +
    /// [A_i, A_j]` for each pair `i < j` of shape coordinates, in the
    /// order (0,1), (0,2), ..., (1,2), ...: three components each, `x`
    /// \[m/rad^2\], `y` \[m/rad^2\], `theta` \[rad/rad^2\]. A small gait
    /// enclosing signed area `S` in the `(r_i, r_j)` plane (positive
    /// counter-clockwise) moves the reference frame by about `D(-A)_ij S`
    /// in its initial body frame (Hatton & Choset 2011, §5).
    pub height: Vec<[f64; 3]>,
}

impl<M: Model> Geometry<M> {
    /// Splits `model` into position (the frame of `body`, or of the body
    /// at the middle of the hinge tree when `None`, the first such in
    /// ties) and shape (the hinge angles in the order of `shape`, or of
    /// the model's hinges when `None`).
    ///
    /// # Errors
    /// [`GeometryError::Request`] for more than [`MAX_BODIES`] bodies or
    /// skates, before any work; [`GeometryError::Model`] for a mass or inertia that is not a
    /// finite number > 0 (the momentum map and the locked inertia divide
    /// by it: a massless body has none), naming the body and the
    /// parameter; for a model without the plane's symmetry
    /// (a hinge to the ground, a slider), bodies not joined by hinges, a
    /// loop of hinges, skates that restrict the shape velocities
    /// themselves (more independent skate rows than the three directions
    /// of the plane can take); [`GeometryError::Request`] for a body or
    /// hinge `shape` names that the model lacks, or a `shape` that is not
    /// every hinge once.
    pub fn new(model: M, body: Option<&str>, shape: Option<&[String]>) -> Result<Self, GeometryError> {
        let info = model.info();
        let (nb, nsk) = (info.bodies.len(), info.skates.len());
        if nb.max(nsk) > MAX_BODIES {
            return Err(GeometryError::Request {
                reason: format!(
                    "model {}: {nb} bodies and {nsk} skates, more than the {MAX_BODIES} the geometric analysis takes (its setup grows as the cube of the count: 1600 bodies take 15 s)",
                    info.name
                ),
            });
        }
        let bad = |reason: String| GeometryError::Model { reason };
        let mut mass = vec![0.0; info.nq()];
        model.mass_diagonal(&mut mass);
        if let Some((k, m)) = mass.iter().enumerate().find(|(_, m)| !(m.is_finite() && **m > 0.0)) {
            return Err(bad(format!(
                "{} = {}: the geometric analysis needs every mass and inertia a finite number > 0 (its locked inertia and momentum map divide by them)",
                info.mass_entry_name(k),
                crate::names::fmt_value(*m)
            )));
        }
        if let Some(s) = info.sliders.first() {
            return Err(bad(format!(
                "slider `{}`: the geometric analysis takes hinge angles as the shape; a slider's travel is not one yet",
                s.name
            )));
        }
        if let Some(h) = info.hinges.iter().find(|h| h.body_b.is_none()) {
            return Err(bad(format!(
                "hinge `{}` fixes body `{}` to the ground: the model has no symmetry under the plane's motions, so it has no position to split from its shape",
                h.name, info.bodies[h.body_a].name
            )));
        }
        let shape = match shape {
            None => (0..info.hinges.len()).collect::<Vec<_>>(),
            Some(names) => {
                let mut out = Vec::new();
                for n in names {
                    let k = info.hinge_index(n).ok_or_else(|| GeometryError::Request {
                        reason: format!(
                            "shape coordinate `{n}`: the model has no hinge of that name (its hinges: {})",
                            info.hinges.iter().map(|h| h.name.as_str()).collect::<Vec<_>>().join(", ")
                        ),
                    })?;
                    if out.contains(&k) {
                        return Err(GeometryError::Request {
                            reason: format!("shape coordinate `{n}` is named twice"),
                        });
                    }
                    out.push(k);
                }
                if let Some(h) = info.hinges.iter().enumerate().find(|(k, _)| !out.contains(k)) {
                    return Err(GeometryError::Request {
                        reason: format!(
                            "hinge `{}` is not among the shape coordinates: the shape is every hinge's angle, in the order given",
                            h.1.name
                        ),
                    });
                }
                out
            }
        };
        if info.hinges.len() + 1 != nb {
            return Err(bad(if info.hinges.len() + 1 > nb {
                format!(
                    "{} hinges join {nb} bodies: a loop of hinges, whose angles are not independent; the analysis takes a tree of hinges",
                    info.hinges.len()
                )
            } else {
                format!(
                    "{} hinges join {nb} bodies: some bodies are not joined to the others, so the shape is not the hinge angles alone",
                    info.hinges.len()
                )
            }));
        }
        let body = match body {
            Some(name) => info.bodies.iter().position(|b| b.name == name).ok_or_else(|| GeometryError::Request {
                reason: format!(
                    "body `{name}`: the model has no body of that name (its bodies: {})",
                    info.bodies.iter().map(|b| b.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            })?,
            None => centre(&info, nb),
        };
        let steps = tree(&info, &shape, body).ok_or_else(|| {
            bad("the hinges do not join every body to the reference body: the shape is not the hinge angles alone"
                .into())
        })?;
        let mut mass = vec![0.0; info.nq()];
        model.mass_diagonal(&mut mass);
        let skates = info.skates.iter().map(|s| s.row).collect();
        let mut geometry =
            Self { model, info, mass, body, shape, steps, skates, free: Vec::new(), rank: 0, forces: None, stop: None };
        geometry.measure_coefficients()?;
        geometry.choose_free()?;
        Ok(geometry)
    }

    /// Adds a scene's applied forces (its effects at their waveforms) to
    /// the momentum equation: `p' = (dV/dt)^T M qd + V^T F`. Without
    /// them `F = 0`.
    ///
    /// # Errors
    /// [`GeometryError::Model`] when the analysis's model is not this
    /// one (another coordinate count).
    pub fn with_forces(mut self, analysis: Analysis<M>) -> Result<Self, GeometryError> {
        if analysis.nq() != self.info.nq() {
            return Err(GeometryError::Model {
                reason: format!("the forces' scene has {} coordinates, the model {}", analysis.nq(), self.info.nq()),
            });
        }
        self.forces = Some(analysis);
        Ok(self)
    }

    /// Sets a hook asked between the steps of a gait's prediction and
    /// simulation ([`Geometry::predict`], [`Geometry::simulate`]); when it
    /// returns `true` they end with [`GeometryError::Stopped`] (a signal
    /// handler's flag: `ezy` stops on Ctrl-C within a step).
    pub fn stop_when(&mut self, stop: fn() -> bool) {
        self.stop = Some(stop);
    }

    /// [`GeometryError::Stopped`] if the stop hook says so.
    pub(crate) fn check_stop(&self) -> Result<(), GeometryError> {
        match self.stop {
            Some(stop) if stop() => Err(GeometryError::Stopped),
            _ => Ok(()),
        }
    }

    /// The model's structure.
    pub fn info(&self) -> &ModelInfo {
        &self.info
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The reference body's name: its frame is the position `g`.
    pub fn body_name(&self) -> &str {
        &self.info.bodies[self.body].name
    }

    /// The reference body's index in [`ModelInfo::bodies`].
    pub fn body(&self) -> usize {
        self.body
    }

    /// The shape coordinates' names (their hinges'), in shape order.
    pub fn shape_names(&self) -> Vec<String> {
        self.shape.iter().map(|&h| self.info.hinges[h].name.clone()).collect()
    }

    /// The hinge index (in [`ModelInfo::hinges`]) of each shape coordinate.
    pub fn shape_hinges(&self) -> &[usize] {
        &self.shape
    }

    /// Number of shape coordinates.
    pub fn n_shape(&self) -> usize {
        self.shape.len()
    }

    /// Number of momentum components `m` (0 for a kinematic system).
    pub fn n_momentum(&self) -> usize {
        self.free.len()
    }

    /// Whether the constraints fix the body velocity (`m = 0`).
    pub fn is_kinematic(&self) -> bool {
        self.free.is_empty()
    }

    /// The names of the components of `xi` the free directions fix at 1:
    /// `u`, `v`, `w` (one per momentum component: `p_u` is the momentum
    /// conjugate to the forward speed).
    pub fn momentum_names(&self) -> Vec<String> {
        self.free.iter().map(|&k| format!("p_{}", ["u", "v", "w"][k])).collect()
    }

    /// The shape `r` of a configuration `q` (nq): each shape hinge's
    /// `phi_a - phi_b` \[rad\].
    pub fn shape_of(&self, q: &[f64]) -> Vec<f64> {
        self.shape
            .iter()
            .map(|&h| {
                let hi = &self.info.hinges[h];
                let b = hi.body_b.unwrap_or(hi.body_a);
                q[self.info.bodies[hi.body_a].coords[2]] - q[self.info.bodies[b].coords[2]]
            })
            .collect()
    }

    /// The reference body's pose `(x, y, theta)` in `q` (nq) \[m, m, rad\].
    pub fn pose_of(&self, q: &[f64]) -> [f64; 3] {
        let [i, j, k] = self.info.bodies[self.body].coords;
        [q[i], q[j], q[k]]
    }

    /// The reference body's velocity in its own frame `xi = (u, v, w)`
    /// \[m/s, m/s, rad/s\] at the state `(q, qd)` (nq each).
    pub fn body_velocity(&self, q: &[f64], qd: &[f64]) -> [f64; 3] {
        let [i, j, k] = self.info.bodies[self.body].coords;
        let (s, c) = q[k].sin_cos();
        [c * qd[i] + s * qd[j], -s * qd[i] + c * qd[j], qd[k]]
    }

    /// Checks a shape's length and values.
    pub(crate) fn check_shape(&self, r: &[f64]) -> Result<(), GeometryError> {
        if r.len() != self.shape.len() {
            return Err(GeometryError::Request {
                reason: format!(
                    "a shape of {} values given to a model of {} shape coordinates ({})",
                    r.len(),
                    self.shape.len(),
                    self.shape_names().join(", ")
                ),
            });
        }
        if let Some(k) = r.iter().position(|v| !v.is_finite() || v.abs() > 1e6) {
            return Err(GeometryError::Request {
                reason: format!(
                    "shape coordinate `{}` = {}: an angle must be a finite number of radians (at most 1e6 in size)",
                    self.shape_names()[k],
                    r[k]
                ),
            });
        }
        Ok(())
    }
}

/// The body at the middle of the hinge tree: the least eccentric, the
/// first in ties.
fn centre(info: &ModelInfo, nb: usize) -> usize {
    let eccentricity = |start: usize| {
        let mut depth = vec![usize::MAX; nb];
        depth[start] = 0;
        let mut queue = std::collections::VecDeque::from([start]);
        while let Some(b) = queue.pop_front() {
            for h in &info.hinges {
                let Some(hb) = h.body_b else { continue };
                for (from, to) in [(h.body_a, hb), (hb, h.body_a)] {
                    if from == b && depth[to] == usize::MAX {
                        depth[to] = depth[b] + 1;
                        queue.push_back(to);
                    }
                }
            }
        }
        depth.into_iter().max().unwrap_or(0)
    };
    (0..nb).min_by_key(|&b| eccentricity(b)).unwrap_or(0)
}

/// The hinge tree breadth first from `root`; `None` when a body is not
/// reached.
fn tree(info: &ModelInfo, shape: &[usize], root: usize) -> Option<Vec<TreeStep>> {
    let nb = info.bodies.len();
    let mut placed = vec![false; nb];
    placed[root] = true;
    let mut steps: Vec<TreeStep> = Vec::new();
    let mut queue = std::collections::VecDeque::from([root]);
    while let Some(b) = queue.pop_front() {
        for (k, &h) in shape.iter().enumerate() {
            let hi = &info.hinges[h];
            let hb = hi.body_b?;
            let (child, sign) = if hi.body_a == b && !placed[hb] {
                (hb, -1.0)
            } else if hb == b && !placed[hi.body_a] {
                (hi.body_a, 1.0)
            } else {
                continue;
            };
            placed[child] = true;
            queue.push_back(child);
            steps.push(TreeStep { hinge: h, shape: k, parent: b, child, sign, coefficient: 1.0, subtree: Vec::new() });
        }
    }
    if placed.iter().any(|p| !p) {
        return None;
    }
    // each step's subtree: its child and every body placed from it
    for s in (0..steps.len()).rev() {
        let mut sub = vec![steps[s].child];
        for later in &steps[s + 1..] {
            if sub.contains(&later.parent) {
                sub.push(later.child);
            }
        }
        steps[s].subtree = sub;
    }
    Some(steps)
}
