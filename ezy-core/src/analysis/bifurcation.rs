//! Bifurcations on a branch, located and named: where the count of
//! eigenvalues in the right half-plane (a steady motion) or of Floquet
//! multipliers outside the unit circle (a periodic orbit) changes between
//! two points of a branch, the parameter is bisected until the interval is
//! below the tolerance asked, and the kind is read off the critical
//! eigenvalue or multiplier there (Seydel, *Practical Bifurcation and
//! Stability Analysis*, 3rd ed., §5.2 and §7.4-7.6; Kuznetsov, *Elements
//! of Applied Bifurcation Theory*, 3rd ed., §3-4).

use faer::c64;

use super::branch::{BranchPoint, Follow, Solution, solve};
use super::cycle_phase::between;
use super::periodic::PeriodicSettings;
use super::steady::Stability;
use super::{Analysis, AnalysisError};
use crate::effects::waveform::OrbitTiming;
use crate::model::Model;

/// Most bisections of [`locate`]: a bracket shrinks by 2^-60, far past
/// any tolerance a double resolves.
const MAX_BISECTIONS: usize = 60;

/// What changes at a bifurcation, from the critical eigenvalue or
/// multiplier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BifurcationKind {
    /// The branch turns back in the parameter (a saddle-node, limit
    /// point): a real eigenvalue crosses 0 (a real multiplier +1) where
    /// the tangent's parameter component `dp/ds` changes sign
    /// ([`super::arclength::locate_fold`]).
    Fold,
    /// A real multiplier crosses +1 (a real eigenvalue crosses 0), the
    /// branch going on on both sides: a transcritical or pitchfork branch
    /// point (the symmetry-breaking pitchfork of a straight gait that
    /// turns beyond it); where the branch turns back instead, a [`BifurcationKind::Fold`].
    BranchPoint,
    /// A branch point where the new branch crosses the old one, taking
    /// its stability on the other side (exchange of stability), as told
    /// by [`super::switching::switch_both`]: the generic branch point.
    Transcritical,
    /// A branch point where two new branches leave on the same side of
    /// it, the parameter quadratic in their amplitude (a symmetry of the
    /// scene makes it generic), as told by
    /// [`super::switching::switch_both`].
    Pitchfork,
    /// A real multiplier crosses -1: period doubling (flip).
    PeriodDoubling,
    /// A complex pair of multipliers crosses the unit circle:
    /// Neimark-Sacker (torus).
    NeimarkSacker,
    /// A complex pair of eigenvalues of a steady motion crosses the
    /// imaginary axis: Hopf (a periodic orbit is born).
    Hopf,
}

impl BifurcationKind {
    /// The name written in `branch.csv`.
    pub fn name(self) -> &'static str {
        match self {
            BifurcationKind::Fold => "fold",
            BifurcationKind::BranchPoint => "branch point",
            BifurcationKind::Transcritical => "transcritical",
            BifurcationKind::Pitchfork => "pitchfork",
            BifurcationKind::PeriodDoubling => "period doubling",
            BifurcationKind::NeimarkSacker => "Neimark-Sacker",
            BifurcationKind::Hopf => "Hopf",
        }
    }
}

/// A bifurcation located between two points of a branch ([`locate`]).
#[derive(Debug, Clone)]
pub struct Bifurcation {
    /// The parameter's value, the middle of the last bracket.
    pub value: f64,
    /// The last bracket `[before, after]` (in the branch's direction):
    /// its width is below the tolerance asked.
    pub bracket: [f64; 2],
    /// What changes there.
    pub kind: BifurcationKind,
    /// The critical eigenvalue(s) \[1/s\] or multiplier(s) at `value`:
    /// one real, or a complex pair.
    pub critical: Vec<c64>,
    /// The solution at `value`, its family and stability those of the
    /// bracket's ends (the critical eigenvalue or multiplier classified:
    /// neutral where nothing else is unstable).
    pub solution: Solution,
    /// Solutions computed to locate it.
    pub solves: usize,
}

impl Bifurcation {
    /// The frequency \[rad/s\] of the motion a Hopf or Neimark-Sacker
    /// point brings: a Hopf point's critical `|Im lambda|`, a
    /// Neimark-Sacker point's critical `|arg mu| / T` (the torus's second
    /// frequency, `T` the orbit's period; Kuznetsov §3.4 and §4.7).
    /// `None` for the other kinds.
    pub fn frequency(&self) -> Option<f64> {
        let z = self.critical.first()?;
        match (self.kind, &self.solution) {
            (BifurcationKind::Hopf, _) => Some(z.im.abs()),
            (BifurcationKind::NeimarkSacker, Solution::Periodic(o)) => Some(z.im.atan2(z.re).abs() / o.period),
            _ => None,
        }
    }
}

/// The dimension of the family of solutions through `s` (its
/// eigenvalues 0 or multipliers 1 along it).
pub(crate) fn family(s: &Solution) -> usize {
    match s {
        Solution::Steady(m) => m.family,
        Solution::Periodic(p) => p.family,
    }
}

/// The rates of `s` (`Re lambda` of a steady motion, `ln |mu|` of a
/// periodic orbit) with their eigenvalues or multipliers, nearest zero
/// first, `family` of them (the nearest zero) left out. At a bifurcation
/// the critical one is nearest zero and the solution's own family count
/// takes it in (its Newton matrix is singular there): the family is
/// counted away from it.
fn rates(s: &Solution, family: usize) -> Vec<(f64, c64)> {
    let (values, periodic) = match s {
        Solution::Steady(m) => (&m.eigenvalues, false),
        Solution::Periodic(p) => (&p.multipliers, true),
    };
    let mut r: Vec<(f64, c64)> =
        values.iter().map(|z| (if periodic { z.re.hypot(z.im).max(1e-300).ln() } else { z.re }, *z)).collect();
    r.sort_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
    r.split_off(family.min(r.len()))
}

/// `s`, a solution at a bifurcation between branch points whose family
/// is `family`, with that family and its stability classified with it.
/// Its own family count takes the critical eigenvalue or multiplier in
/// (the bifurcation makes its Newton matrix singular, as a family would)
/// and its classification left it out: a fold or branch point was
/// "stable" with its critical eigenvalue 0 or multiplier 1. Counted away
/// from it, the critical one is classified (on the axis or circle:
/// neutral where nothing else is unstable).
pub(crate) fn at_bifurcation(mut s: Solution, family: usize) -> Solution {
    match &mut s {
        Solution::Steady(m) => {
            m.family = family;
            m.stability = Stability::of_eigenvalues(&m.eigenvalues, family);
        }
        Solution::Periodic(p) => {
            p.family = family;
            p.stability = Stability::of_multipliers(&p.multipliers, family);
        }
    }
    s
}

/// How many eigenvalues (multipliers) of `s` are unstable: right of the
/// imaginary axis (outside the unit circle), the family's left out.
pub fn unstable_count(s: &Solution) -> usize {
    rates(s, family(s)).iter().filter(|(r, _)| *r > 0.0).count()
}

/// A point of a branch where an eigenvalue or multiplier came close to
/// the stability boundary and went back without crossing it
/// ([`near_misses`]).
#[derive(Debug, Clone)]
pub struct NearMiss {
    /// The index of the point in the branch.
    pub index: usize,
    /// The parameter's value there.
    pub value: f64,
    /// The eigenvalue \[1/s\] or multiplier nearest the boundary there.
    pub critical: c64,
    /// Its distance to the boundary: `|ln |mu||` of a periodic orbit
    /// (about `||mu| - 1|`), `|Re lambda| / max(1, |lambda|max)` of a
    /// steady motion (its eigenvalues in 1/s).
    pub distance: f64,
}

/// The points of a branch where the eigenvalue or multiplier nearest the
/// stability boundary (the family's left out) comes closer to it than
/// `within` and goes back, with the count of unstable ones the same at
/// the point and its two neighbours and no fold between them: a
/// bifurcation missed by a hair, or one the problem's imperfection
/// unfolds. A symmetric gait found to a loose tolerance is symmetric
/// only to that tolerance, and its pitchfork splits into two branches
/// that pass each other, the critical multiplier turning back before 1
/// (the imperfect pitchfork: Golubitsky & Schaeffer, *Singularities and
/// Groups in Bifurcation Theory* I, §I.2; Seydel §2.10):
/// `drive-rolling-resistance` at `--rtol 1e-6` passed its branch point
/// at 0.638 N m with a multiplier 0.99992, on a branch that turned.
/// `within` is a distance as [`NearMiss::distance`] measures it.
pub fn near_misses(points: &[BranchPoint], within: f64) -> Vec<NearMiss> {
    let nearest = |s: &Solution| -> Option<(f64, c64, usize)> {
        let r = rates(s, family(s));
        let unstable = r.iter().filter(|(x, _)| *x > 0.0).count();
        r.first().map(|&(_, z)| (boundary_distance(s, z), z, unstable))
    };
    let near: Vec<Option<(f64, c64, usize)>> = points.iter().map(|p| nearest(&p.solution)).collect();
    let mut out = Vec::new();
    for i in 1..points.len().saturating_sub(1) {
        let (Some(a), Some(b), Some(c)) = (near[i - 1], near[i], near[i + 1]) else { continue };
        let fold = match (points[i - 1].dp_ds, points[i + 1].dp_ds) {
            (Some(x), Some(y)) => x * y <= 0.0,
            _ => false,
        };
        if b.0 < within && b.0 < a.0 && b.0 < c.0 && a.2 == b.2 && b.2 == c.2 && !fold {
            out.push(NearMiss { index: i, value: points[i].value, critical: b.1, distance: b.0 });
        }
    }
    out
}

/// How far `z`, an eigenvalue \[1/s\] or multiplier of `s`, is from the
/// stability boundary, as [`NearMiss::distance`] measures it.
pub(crate) fn boundary_distance(s: &Solution, z: c64) -> f64 {
    match s {
        Solution::Steady(m) => z.re.abs() / m.eigenvalues.iter().map(|v| v.norm()).fold(1.0, f64::max),
        Solution::Periodic(_) => z.re.hypot(z.im).max(1e-300).ln().abs(),
    }
}

/// The critical eigenvalue(s) or multiplier(s) of `at`, a bifurcation
/// between the branch points `a` and `b`: the rate nearest zero, the
/// family counted at the bracket's ends; a complex pair or one real.
/// Empty where `at` has none outside its family.
pub(crate) fn critical(at: &Solution, a: &Solution, b: &Solution) -> Vec<c64> {
    let r = rates(at, family(a).min(family(b)));
    let Some(&(_, z)) = r.first() else { return Vec::new() };
    let complex = z.im.abs() > 1e-6 * (1.0 + z.re.abs());
    if complex { r.iter().take(2).map(|p| p.1).collect() } else { vec![z] }
}

/// Locates the bifurcation between the branch points `a` and `b` whose
/// [`unstable_count`]s differ: the parameter bisected (`build` makes the
/// scene at a value, the solution sought as `follow` says from the
/// bracket's states interpolated) until the bracket is narrower than
/// `tol (1 + |a.value|)`. `None` where the counts agree.
///
/// # Errors
/// The search's error at a value inside the bracket (the branch may fold
/// there); `build`'s.
pub fn locate<M: Model>(
    a: &BranchPoint,
    b: &BranchPoint,
    follow: Follow,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    tol: f64,
) -> Result<Option<Bifurcation>, AnalysisError> {
    let fam = family(&a.solution).min(family(&b.solution));
    let count = |s: &Solution| rates(s, fam).iter().filter(|(r, _)| *r > 0.0).count();
    let before = count(&a.solution);
    if before == count(&b.solution) {
        return Ok(None);
    }
    let (mut lo, mut hi) = (a.clone(), b.clone());
    let width = tol * (1.0 + a.value.abs());
    // the branch's phase and period in forcing periods, as its points
    // hold them (taken at `a`'s orbit, at `a`'s forcing)
    let mut timing = OrbitTiming::default();
    if let (Follow::Periodic { .. }, Solution::Periodic(o)) = (follow, &a.solution)
        && let Some(f) = build(a.value)?.forcing()
    {
        f.orbit_timing(&mut timing, o.t0, o.period);
    }
    let mut solves = 0;
    let at = |lo: &BranchPoint, hi: &BranchPoint, value: f64| -> Vec<f64> {
        let s = (value - lo.value) / (hi.value - lo.value);
        lo.solution.state().iter().zip(hi.solution.state()).map(|(x, y)| x + s * (y - x)).collect()
    };
    // orbits converged to the integration's tolerance: next to the
    // bifurcation the search's matrix is singular along the critical
    // direction, so Newton's residual leaves the state off along it by
    // the residual over the distance to it, and the critical multiplier
    // (the count bisected) off with it (Newton's default 1e-9 put the
    // rolling-resistance gait's branch point 2.4e-8 of the parameter off,
    // found by the oracle harness); where the search cannot reach it, its
    // own tolerance
    let tight = match follow {
        Follow::Periodic { t0, period, settings } => {
            let floor = settings.tolerance.rtol.max(settings.tolerance.atol).max(1e-13);
            let newton_tolerance = settings.newton_tolerance.min(floor);
            Follow::Periodic { t0, period, settings: PeriodicSettings { newton_tolerance, ..settings } }
        }
        steady => steady,
    };
    let mut mid = None;
    for _ in 0..MAX_BISECTIONS {
        let value = 0.5 * (lo.value + hi.value);
        let guess = at(&lo, &hi, value);
        let solution = build(value).and_then(|mut an| {
            // (a stop is not a search's failure: passed through, not retried)
            // (a limit cycle's period guessed between the bracket's)
            let (tight, follow) = (between(tight, &lo, &hi, value), between(follow, &lo, &hi, value));
            solve(&mut an, tight, &guess, &mut timing).or_else(|e| match e {
                AnalysisError::Stopped => Err(e),
                _ => solve(&mut an, follow, &guess, &mut timing),
            })
        })?;
        solves += 1;
        let point = BranchPoint { value, solution, dp_ds: None };
        if (hi.value - lo.value).abs() <= width {
            mid = Some(point);
            break;
        }
        if count(&point.solution) == before {
            lo = point;
        } else {
            hi = point;
        }
    }
    let point = mid.unwrap_or(lo.clone());
    let critical = critical(&point.solution, &a.solution, &b.solution);
    let Some(&z) = critical.first() else { return Ok(None) };
    let kind = match (&point.solution, critical.len() == 2) {
        (Solution::Steady(_), true) => BifurcationKind::Hopf,
        (Solution::Steady(_), false) => BifurcationKind::BranchPoint,
        (Solution::Periodic(_), true) => BifurcationKind::NeimarkSacker,
        (Solution::Periodic(_), false) if z.re < 0.0 => BifurcationKind::PeriodDoubling,
        (Solution::Periodic(_), false) => BifurcationKind::BranchPoint,
    };
    Ok(Some(Bifurcation {
        value: point.value,
        bracket: [lo.value, hi.value],
        kind,
        critical,
        solution: at_bifurcation(point.solution, fam),
        solves,
    }))
}
