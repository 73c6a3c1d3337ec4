//! Branch switching at a located bifurcation, both ways along the new
//! branch, and the bifurcation told by what is born there: transcritical
//! or pitchfork (symmetry-breaking where the parent goes straight and the
//! two new branches turn opposite ways), a period doubling's direction,
//! each from the new branches' parameter and stability (Seydel,
//! *Practical Bifurcation and Stability Analysis*, 3rd ed., §2.5-2.7 and
//! §5.6; Kuznetsov, *Elements of Applied Bifurcation Theory*, 3rd ed.,
//! §3.1-3.5 and §10.2; Keller 1977 on the orthogonal null vector).
//!
//! At a branch point the defining equations' Jacobian `[R_z R_p]` (in the
//! unknowns `z` and the parameter `p`) has a null space of two: the old
//! branch's tangent `t_old` and the new one's. The new branch leaves along
//! the null vector `t_new` of `[R_z R_p; t_old^T]`, orthogonal to the old
//! (`t_old` is the chord between the two branch points that bracket the
//! bifurcation); a point is sought on each side, `w* +- offset t_new`, on
//! the hyperplane through it normal to `t_new` (it crosses the new branch
//! near `w*` and not the old, which lies along the hyperplane through
//! `w*`). The two points' parameters tell the kind:
//!
//! - on opposite sides of the bifurcation: the new branch crosses the old
//!   one, a transcritical point (the generic branch point);
//! - on the same side: a pitchfork (the parameter quadratic in the new
//!   branch's amplitude, as symmetry makes it), symmetry-breaking where
//!   the parent does not turn and the two new branches turn opposite ways
//!   (left and right: the plane's reflection, which maps the scene's
//!   motions to mirror motions, is the symmetry broken).
//!
//! A pitchfork or period doubling is supercritical where the branch born
//! is as stable as the parent on its stable side (it takes over the
//! stability the parent loses), subcritical otherwise.

use super::arclength::Equations;
use super::bifurcation::{Bifurcation, BifurcationKind, unstable_count};
use super::branch::{BranchPoint, Follow, Solution, solve};
use super::periodic::PeriodicSettings;
use super::{Analysis, AnalysisError, dense};
use crate::effects::waveform::OrbitTiming;
use crate::model::Model;

/// Whether the branch born at a pitchfork, period doubling or Hopf point
/// takes over the stability its parent loses (Kuznetsov §3.3-3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Criticality {
    /// The new branch is as stable as the parent on its stable side (a
    /// soft, safe loss of stability).
    Supercritical,
    /// The new branch is less stable than that (a hard loss: the motion
    /// jumps away).
    Subcritical,
}

impl Criticality {
    /// The word written: `supercritical` or `subcritical`.
    pub fn name(self) -> &'static str {
        match self {
            Criticality::Supercritical => "supercritical",
            Criticality::Subcritical => "subcritical",
        }
    }
}

/// A branch born at a bifurcation: its first point and how to follow it
/// ([`super::arclength::follow_arclength`] from the point's value and state).
#[derive(Debug, Clone)]
pub struct Born {
    /// The first point, `offset` from the bifurcation along the new
    /// branch's direction.
    pub start: BranchPoint,
    /// How the new branch is followed (a doubled period at a period doubling).
    pub follow: Follow,
    /// The side of the direction it was sought on: `+1` or `-1`.
    pub side: f64,
}

/// What switching at a bifurcation found ([`switch_both`]).
#[derive(Debug)]
pub struct Switch {
    /// The bifurcation's kind as told by the branches born: a
    /// [`BifurcationKind::BranchPoint`] becomes
    /// [`BifurcationKind::Transcritical`] or [`BifurcationKind::Pitchfork`]
    /// (it stays a branch point where the two new points' parameters are
    /// within the bifurcation's bracket of it, too near to tell).
    pub kind: BifurcationKind,
    /// A pitchfork whose parent does not turn while its two new branches
    /// turn opposite ways (the plane's reflection broken).
    pub symmetry_breaking: bool,
    /// A pitchfork's, period doubling's or Hopf point's direction, from
    /// the branch born's stability.
    pub criticality: Option<Criticality>,
    /// The branches born, one per side found: two at a branch point
    /// (the two halves of a transcritical branch, or the two arms of a
    /// pitchfork), one at a period doubling (both sides are one doubled
    /// orbit, a forcing period apart).
    pub born: Vec<Born>,
    /// The side whose search failed, with its error (the other side found).
    pub failed: Option<(f64, String)>,
}

impl Switch {
    /// The bifurcation's name with its qualifiers: `pitchfork
    /// (symmetry-breaking, supercritical)`.
    pub fn describe(&self) -> String {
        let mut q = Vec::new();
        if self.symmetry_breaking {
            q.push("symmetry-breaking");
        }
        if let Some(c) = self.criticality {
            q.push(c.name());
        }
        if q.is_empty() { self.kind.name().to_string() } else { format!("{} ({})", self.kind.name(), q.join(", ")) }
    }
}

/// Switches at `b`, a branch point, period doubling or Hopf point located
/// between the parent branch's points `parent` (followed as `follow`
/// says, the scene at a value made by `build`): the branches born there,
/// sought `offset` times the largest of 1 and the solution's unknowns
/// (1e-3 to 1e-2: past the Newton matrix's near-singularity, inside the
/// new branch's quadratic bend) from the
/// bifurcation on both sides of the new direction at a branch point (the
/// module's construction), on one at a period doubling
/// ([`super::arclength::switch_branch`]) or Hopf point (the limit cycles,
/// integrated and solved with `settings`:
/// [`super::cycle_branch::switch_at_hopf`]); the bifurcation told by them.
///
/// # Errors
/// [`AnalysisError::Request`] for a fold, a Neimark-Sacker point, or a
/// kind already told; where no side is found, the first side's error;
/// `build`'s.
pub fn switch_both<M: Model>(
    b: &Bifurcation,
    parent: [&BranchPoint; 2],
    follow: Follow,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    offset: f64,
    settings: PeriodicSettings,
) -> Result<Switch, AnalysisError> {
    let stable_side = unstable_count(&parent[0].solution).min(unstable_count(&parent[1].solution));
    let criticality = |born: &[Born]| {
        (!born.is_empty()).then(|| {
            if born.iter().all(|n| unstable_count(&n.start.solution) <= stable_side) {
                Criticality::Supercritical
            } else {
                Criticality::Subcritical
            }
        })
    };
    let offset = offset * b.solution.state().iter().fold(1.0f64, |m, v| m.max(v.abs()));
    if b.kind != BifurcationKind::BranchPoint {
        let (start, follow) = if b.kind == BifurcationKind::Hopf {
            super::cycle_branch::switch_at_hopf(b, &mut build, offset, settings)?
        } else {
            super::arclength::switch_branch(b, follow, &mut build, offset)?
        };
        let born = vec![Born { start, follow, side: 1.0 }];
        let criticality = match b.kind {
            BifurcationKind::PeriodDoubling | BifurcationKind::Hopf => criticality(&born),
            _ => None,
        };
        return Ok(Switch { kind: b.kind, symmetry_breaking: false, criticality, born, failed: None });
    }
    // the solution at the bifurcation, under the parent's equations
    let mut timing = OrbitTiming::default();
    let at = build(b.value).and_then(|mut an| solve(&mut an, follow, b.solution.state(), &mut timing))?;
    let mut eq = Equations::new(follow, &at);
    eq.timing = timing;
    let w_of = |eq: &Equations, s: &Solution, p: f64| eq.at_gauge([eq.unknowns(s), vec![p]].concat());
    let star = w_of(&eq, &at, b.value);
    // the old branch's direction: the chord between the points bracketing
    // the bifurcation
    let (wa, wb) = (w_of(&eq, &parent[0].solution, parent[0].value), w_of(&eq, &parent[1].solution, parent[1].value));
    let t_old = eq.unit_tangent(wb.iter().zip(&wa).map(|(x, y)| x - y).collect());
    let a = eq.extended_jacobian(&mut build, &star, &t_old)?;
    let (_, t_new) = dense::smallest_right_singular(a.as_ref())?;
    let t_new = eq.unit_tangent(t_new);
    let mut born = Vec::new();
    let mut failed = None;
    let mut first = None;
    for side in [1.0, -1.0] {
        let n: Vec<f64> = t_new.iter().map(|v| side * v).collect();
        let w_hat: Vec<f64> = star.iter().zip(&n).map(|(x, v)| x + offset * v).collect();
        let found = eq.correct(&mut build, &w_hat, &n).and_then(|c| eq.point(&mut build, &c));
        match found {
            Ok(start) => born.push(Born { start, follow: eq_follow(follow, &at), side }),
            Err(AnalysisError::Stopped) => return Err(AnalysisError::Stopped),
            Err(e) if born.is_empty() && failed.is_none() && side > 0.0 => first = Some(e),
            Err(e) if failed.is_none() => failed = Some((side, e.to_string())),
            Err(_) => {}
        }
    }
    if born.is_empty() {
        return Err(first.expect("the first side failed"));
    }
    if let Some(e) = first {
        failed = Some((1.0, e.to_string()));
    }
    // told by the parameters of the points born: opposite sides of the
    // bracket a transcritical point, the same side a pitchfork
    let (lo, hi) = (b.bracket[0].min(b.bracket[1]), b.bracket[0].max(b.bracket[1]));
    let side_of = |p: f64| {
        if p > hi {
            1
        } else if p < lo {
            -1
        } else {
            0
        }
    };
    let sides: Vec<i32> = born.iter().map(|n| side_of(n.start.value)).collect();
    let kind = match sides[..] {
        [x, y] if x != 0 && x == -y => BifurcationKind::Transcritical,
        [x, y] if x != 0 && x == y => BifurcationKind::Pitchfork,
        _ => BifurcationKind::BranchPoint,
    };
    // the parent's turning at the bracketing points: at the bifurcation
    // its search is singular along the new branch's direction (turning,
    // at a symmetry-breaking pitchfork) and its own turning is off by the
    // search's residual over that
    let symmetry_breaking = kind == BifurcationKind::Pitchfork && {
        let r0 = parent[0].solution.turning_rate().abs().max(parent[1].solution.turning_rate().abs());
        let (r1, r2) = (born[0].start.solution.turning_rate(), born[1].start.solution.turning_rate());
        r1 * r2 < 0.0 && r0 < 1e-3 * r1.abs().min(r2.abs())
    };
    let criticality = if kind == BifurcationKind::Pitchfork { criticality(&born) } else { None };
    Ok(Switch { kind, symmetry_breaking, criticality, born, failed })
}

/// The branch's `follow` with a periodic orbit's phase and period those
/// of the orbit `at` (as [`Equations::new`] takes them).
fn eq_follow(follow: Follow, at: &Solution) -> Follow {
    match (follow, at) {
        (Follow::Periodic { settings, .. }, Solution::Periodic(o)) => {
            Follow::Periodic { t0: o.t0, period: o.period, settings }
        }
        (f, _) => f,
    }
}
