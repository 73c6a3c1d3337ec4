//! The output columns: each of the optional groups a scene asks for
//! ([`OutputGroup`]) named AND valued in one place. The header of
//! `trajectory.csv` ([`Scene::columns`], [`names`]) and each of its rows ([`RowBuilder::fill`]) are the same walk over the
//! groups, one match with a group's names and its values side by side:
//! a column is added by one edit, and the values cannot drift from the
//! names.
//!
//! Columns: `t`; the coordinates in model order; their velocities in the
//! same order (`<coord>d`); then the groups asked for, in the order of
//! [`OutputGroup::ALL`].

use ezy_core::effects::Law;
use ezy_core::kkt::KktMethod;
use ezy_core::model::Model;
use ezy_core::model::info::ModelInfo;
use ezy_core::names::{velocity_name, work_name};
use ezy_core::{AnyModel, Dynamics, EffectSpec, Sample, SimError};

use crate::kinds::SceneEffect;
use crate::schema::{OutputGroup, Scene};

impl OutputGroup {
    /// Whether the group's values need the KKT solve at the sample (the
    /// multipliers or the accelerations).
    fn needs_kkt(self) -> bool {
        matches!(self, Self::ConstraintForces | Self::Accelerations)
    }
}

impl Scene {
    /// Whether output group `g` is asked for.
    pub fn includes(&self, g: OutputGroup) -> bool {
        self.output.include.contains(&g)
    }

    /// The output columns of this scene for a model with `info`, in order:
    /// `t`, coordinates, `<coord>d`, then the groups asked for (see
    /// [`OutputGroup`]).
    pub fn columns(&self, info: &ModelInfo) -> Vec<String> {
        names(info, &self.effects, OutputGroup::ALL.into_iter().filter(|&g| self.includes(g)))
    }
}

/// The names of the output columns of a model with `info` and the
/// effects `effects` (by name, as the scene gives them): `t`, the
/// coordinates, `<coord>d`, then the columns of each of `groups`, in the
/// order given.
pub fn names(
    info: &ModelInfo,
    effects: &[(String, SceneEffect)],
    groups: impl IntoIterator<Item = OutputGroup>,
) -> Vec<String> {
    let mut out = Vec::new();
    // the header needs no model: any model type stands for it
    let mut walk: Walk<AnyModel> = Walk::Names { info, effects, out: &mut out };
    state(&mut walk);
    for g in groups {
        group(g, &mut walk);
    }
    out
}

/// Where a walk over the columns writes: their names (the header) or
/// their values at one output sample (a row), in the same order.
enum Walk<'a, M: Model> {
    /// The header, for the model `info` describes and the scene's `effects`.
    Names { info: &'a ModelInfo, effects: &'a [(String, SceneEffect)], out: &'a mut Vec<String> },
    /// The row at sample `s` of the run `sys`.
    Values { sys: &'a Dynamics<M>, s: &'a Sample<'a>, scratch: &'a mut Scratch<M>, out: &'a mut Vec<f64> },
}

/// The columns always written: `t`, the coordinates `q` and the
/// velocities `qd` (nq each).
fn state<M: Model>(walk: &mut Walk<'_, M>) {
    match walk {
        Walk::Names { info, out, .. } => {
            out.push("t".into());
            out.extend(info.coords.iter().map(|c| c.to_string()));
            out.extend(info.coords.iter().map(|c| velocity_name(c)));
        }
        Walk::Values { s, out, .. } => {
            out.push(s.t);
            out.extend_from_slice(s.q);
            out.extend_from_slice(s.qd);
        }
    }
}

/// The columns of group `g`: for each group, the arm that names them and
/// the arm that gives their values, side by side.
// One match over every group keeps each group's names beside its values;
// split, the pairs would drift apart again.
fn group<M: Model>(g: OutputGroup, walk: &mut Walk<'_, M>) {
    use Walk::{Names, Values};
    match (g, walk) {
        (OutputGroup::Energy, Names { info, effects, out }) => {
            out.extend(["T".to_string(), "W".to_string()]);
            out.extend(effects.iter().map(|(n, _)| work_name(n)));
            out.extend(info.drives.iter().map(|d| work_name(&d.name)));
        }
        (OutputGroup::Energy, Values { s, out, .. }) => {
            out.extend([s.kinetic_energy, s.work]);
            // the effects' works, then the drives', as the state holds them
            out.extend_from_slice(s.works);
        }
        (OutputGroup::Points, Names { info, out, .. }) => {
            out.extend(info.points.iter().flat_map(|p| [format!("{}.x", p.name), format!("{}.y", p.name)]));
        }
        (OutputGroup::Points, Values { sys, s, scratch, out }) => {
            sys.model.points(s.q, &mut scratch.points);
            out.extend_from_slice(&scratch.points);
        }
        (OutputGroup::PointVelocities, Names { info, out, .. }) => {
            out.extend(info.points.iter().flat_map(|p| [format!("{}.vx", p.name), format!("{}.vy", p.name)]));
        }
        (OutputGroup::PointVelocities, Values { sys, s, scratch, out }) => {
            sys.model.point_velocities(s.q, s.qd, &mut scratch.points);
            out.extend_from_slice(&scratch.points);
        }
        (OutputGroup::Effects, Names { effects, out, .. }) => {
            for (n, e) in effects.iter() {
                out.push(e.value_column(n));
                // a skate with friction: its slip velocity [m/s] and mode
                if let SceneEffect::Builtin(EffectSpec::SkateFriction(ezy_core::effects::SkateFriction {
                    skate, ..
                })) = e
                {
                    out.extend([format!("v_slip_{skate}"), format!("sliding_{skate}")]);
                }
            }
        }
        (OutputGroup::Effects, Values { sys, s, scratch, out }) => {
            scratch.forces.fill(0.0);
            let mut friction = 0;
            for e in &sys.effects {
                if let Law::SkateFriction(_) = e.law {
                    // the lateral force, slip velocity and mode (from the probe)
                    let p = scratch.probe.as_ref().expect("a probe with friction");
                    let fr = &p.sys.friction[friction];
                    out.extend([p.sys.skate_force(friction), fr.slip, f64::from(u8::from(fr.mode.is_sliding()))]);
                    friction += 1;
                } else {
                    out.push(e.apply(s.t, s.q, s.qd, &mut scratch.forces).1);
                }
            }
        }
        (OutputGroup::ConstraintForces, Names { info, out, .. }) => {
            // one per row of G: forces [N], torques [N m] for the rows
            // that lock an angle (a slider's heading, a drive)
            let mut torque = vec![false; info.nc()];
            for d in &info.drives {
                torque[d.row] = true;
            }
            for s in info.sliders.iter().filter(|s| s.heading) {
                torque[s.row + 1] = true;
            }
            for (row, name) in info.constraints.iter().enumerate() {
                out.push(format!("{}_{name}", if torque[row] { "tau" } else { "F" }));
            }
        }
        (OutputGroup::ConstraintForces, Values { scratch, out, .. }) => {
            // M qdd = f - G^T lambda: the constraint force on the
            // coordinates is -G^T lambda, so a hinge row `r_a - r_b` pushes
            // body a with -lambda and a skate row (unit normal n) with -lambda n.
            let p = scratch.probe.as_ref().expect("a probe for the constraint forces");
            out.extend(p.sys.lambda().iter().map(|l| -l));
        }
        (OutputGroup::Accelerations, Names { info, out, .. }) => {
            out.extend(info.coords.iter().map(|c| format!("{c}dd")));
        }
        (OutputGroup::Accelerations, Values { sys, scratch, out, .. }) => {
            let p = scratch.probe.as_ref().expect("a probe for the accelerations");
            let nq = sys.nq();
            out.extend_from_slice(&p.dy[nq..2 * nq]);
        }
        (OutputGroup::Residuals, Names { out, .. }) => {
            out.extend(["res_phi".to_string(), "res_vel".to_string()]);
        }
        (OutputGroup::Residuals, Values { s, out, .. }) => {
            out.extend([s.residual_position, s.residual_velocity]);
        }
    }
}

/// Assembles one output row from a sample: `t`, `q`, `qd`, then exactly the
/// groups the scene asks for (see [`OutputGroup`]); a group not asked for
/// is not computed.
pub struct RowBuilder<M: Model> {
    /// Column names, as [`Scene::columns`] gives them.
    pub columns: Vec<String>,
    /// The groups asked for, in column order.
    groups: Vec<OutputGroup>,
    scratch: Scratch<M>,
}

/// What the values of a row are computed in.
struct Scratch<M: Model> {
    /// A copy of the dynamics for the multipliers and accelerations at
    /// output times (constraint forces or accelerations asked for, or a
    /// skate with friction: its force and mode).
    probe: Option<Box<ForceProbe<M>>>,
    /// Point positions or velocities (2 per point) \[m or m/s\].
    points: Vec<f64>,
    /// Generalized forces of one effect (nq), discarded: the effects'
    /// values are what the row takes.
    forces: Vec<f64>,
}

/// Solves the KKT system at an output sample for the constraint forces.
struct ForceProbe<M: Model> {
    sys: Dynamics<M>,
    y: Vec<f64>,
    dy: Vec<f64>,
}

impl<M: Model> ForceProbe<M> {
    /// The right-hand side at sample `s` of the run `sys`, with the run's
    /// effects switched on and off and its skates' modes at that sample.
    fn solve_at(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), SimError> {
        let nq = sys.nq();
        self.y[..nq].copy_from_slice(s.q);
        self.y[nq..2 * nq].copy_from_slice(s.qd);
        for (pe, e) in self.sys.effects.iter_mut().zip(&sys.effects) {
            pe.on = e.on;
        }
        for (k, fr) in sys.friction.iter().enumerate() {
            if self.sys.friction[k].mode != fr.mode {
                self.sys.set_skate_mode(k, fr.mode);
            }
        }
        self.sys.rhs(s.t, &self.y, &mut self.dy)
    }
}

impl<M: Model> RowBuilder<M> {
    /// The row layout of `scene` for the run `sys`.
    pub fn new(scene: &Scene, sys: &Dynamics<M>) -> Self {
        let groups: Vec<OutputGroup> = OutputGroup::ALL.into_iter().filter(|&g| scene.includes(g)).collect();
        // skates with friction: their force and mode at each sample
        let probe = (groups.iter().any(|g| g.needs_kkt()) || !sys.friction.is_empty()).then(|| {
            let mut copy =
                Dynamics::new(sys.model.clone(), sys.effects.clone(), KktMethod::Auto).with_drives(sys.drives.clone());
            copy.baumgarte = sys.baumgarte;
            let ny = copy.ny();
            Box::new(ForceProbe { sys: copy, y: vec![0.0; ny], dy: vec![0.0; ny] })
        });
        Self {
            columns: names(&sys.info, &scene.effects, groups.iter().copied()),
            groups,
            scratch: Scratch { probe, points: vec![0.0; 2 * sys.info.points.len()], forces: vec![0.0; sys.nq()] },
        }
    }

    /// Fills `row` for sample `s` of the run `sys`.
    ///
    /// # Errors
    /// [`SimError`] if the KKT solve for the constraint forces fails.
    pub fn fill(&mut self, sys: &Dynamics<M>, s: &Sample<'_>, row: &mut Vec<f64>) -> Result<(), SimError> {
        row.clear();
        if let Some(p) = &mut self.scratch.probe {
            p.solve_at(sys, s)?;
        }
        let mut walk = Walk::Values { sys, s, scratch: &mut self.scratch, out: row };
        state(&mut walk);
        for &g in &self.groups {
            group(g, &mut walk);
        }
        Ok(())
    }
}
