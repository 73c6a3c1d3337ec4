//! Natural-parameter continuation of steady motions and periodic orbits.

use super::{Analysis, AnalysisError};
use crate::analysis::periodic::{PeriodicOrbit, PeriodicSettings};
use crate::analysis::steady::{Stability, SteadyMotion};
use crate::effects::waveform::OrbitTiming;
use crate::model::Model;

/// A steady motion or a periodic orbit: a point of a branch.
#[derive(Debug, Clone)]
pub enum Solution {
    /// A relative equilibrium ([`Analysis::steady_motion`]).
    Steady(SteadyMotion),
    /// A periodic orbit ([`Analysis::periodic_orbit`]).
    Periodic(PeriodicOrbit),
}

impl Solution {
    /// The state it is found at (2 nq).
    pub fn state(&self) -> &[f64] {
        match self {
            Solution::Steady(s) => &s.state,
            Solution::Periodic(p) => &p.state,
        }
    }

    /// Its stability.
    pub fn stability(&self) -> Stability {
        match self {
            Solution::Steady(s) => s.stability,
            Solution::Periodic(p) => p.stability,
        }
    }

    /// How fast it turns \[rad/s\]: a steady motion's yaw rate, a periodic
    /// orbit's heading change per period over its period (0 for a motion
    /// that goes straight).
    pub fn turning_rate(&self) -> f64 {
        match self {
            Solution::Steady(s) => s.body_velocity[2],
            Solution::Periodic(p) => p.heading_change / p.period,
        }
    }

    /// The reference body's speed \[m/s\]: steady, or the mean over a period.
    pub fn speed(&self) -> f64 {
        match self {
            Solution::Steady(s) => s.speed(),
            Solution::Periodic(p) => p.mean_speed(),
        }
    }
}

/// How a branch is followed: the solution kind's own settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Follow {
    /// Steady motions, at this kinetic energy \[J\] if `Some` (a
    /// conservative scene's family member; see [`Analysis::steady_motion`]).
    Steady {
        /// The energy level, if fixed.
        energy: Option<f64>,
    },
    /// Periodic orbits of this period \[s\] at phase `t0` \[s\]: at the
    /// first point; where the forcing repeats with a known period, each
    /// later point takes the same whole multiple of its own forcing's
    /// period and the same phase of it (a branch in a forcing frequency:
    /// [`crate::effects::Periodicity::orbit_timing`]).
    Periodic {
        /// Phase.
        t0: f64,
        /// Period.
        period: f64,
        /// Integration and Newton settings.
        settings: PeriodicSettings,
    },
    /// Limit cycles of an autonomous scene ([`Analysis::limit_cycle`]):
    /// the period an unknown, `period` \[s\] only the first point's guess;
    /// along a branch, fixed by a Poincare phase condition through the
    /// branch's previous point ([`super::cycle_branch`]).
    Cycle {
        /// The time \[s\] the cycle's state is taken at (the scene is
        /// autonomous: any).
        t0: f64,
        /// The period's guess \[s\].
        period: f64,
        /// Integration and Newton settings.
        settings: PeriodicSettings,
    },
}

/// One point of a branch: the parameter's value and the solution there.
#[derive(Debug, Clone)]
pub struct BranchPoint {
    /// The parameter's value.
    pub value: f64,
    /// The solution.
    pub solution: Solution,
    /// The parameter's component `dp/ds` of the branch's unit tangent in
    /// `(unknowns, parameter)`, oriented along the branch
    /// ([`super::arclength::follow_arclength`]): a sign change between
    /// two points is a fold. `None` from natural continuation ([`follow`]).
    pub dp_ds: Option<f64>,
}

/// How a branch followed by [`super::arclength::follow_arclength`] ended.
#[derive(Debug)]
pub enum BranchEnd {
    /// The parameter left the range at its end (or the grid had one value).
    Reached,
    /// The branch came back to its first point without leaving the range:
    /// a closed curve (an isola, or a loop through two folds), stopped
    /// there. It has `points` distinct points; the branch's last point is
    /// its first again (corrected there, its headings possibly a whole
    /// number of turns on), so each stretch of the loop, the closing one
    /// too, lies between two consecutive points.
    Closed {
        /// The distinct points of the loop (the branch's length less one).
        points: usize,
    },
    /// The branch ended early, at the parameter's `value`, with the
    /// `error` that ended it.
    Failed {
        /// The parameter's value where it ended.
        value: f64,
        /// Why.
        error: AnalysisError,
    },
}

impl BranchEnd {
    /// The value and error of a branch that ended early; `None` where it
    /// reached the range's end or closed.
    pub fn failure(&self) -> Option<(f64, &AnalysisError)> {
        match self {
            BranchEnd::Failed { value, error } => Some((*value, error)),
            _ => None,
        }
    }

    /// [`BranchEnd::failure`], taken.
    pub fn into_failure(self) -> Option<(f64, AnalysisError)> {
        match self {
            BranchEnd::Failed { value, error } => Some((value, error)),
            _ => None,
        }
    }
}

/// Follows a branch of solutions through the parameter values `values`
/// by natural-parameter continuation (Seydel, *Practical Bifurcation and
/// Stability Analysis*, 3rd ed., §4.1): at each value the scene is built
/// anew by `build` and the solution is sought from a secant predictor,
/// the last solution's state extrapolated along the last two (the first
/// step starts from `start`'s state). Natural continuation cannot pass a
/// fold, where the branch turns back in the parameter; there Newton fails
/// and the branch ends, with the value and the error returned.
/// Changes of stability show between consecutive points.
///
/// # Errors
/// The branch so far and, when it ended early, the value and error that
/// ended it.
pub fn follow<M: Model>(
    values: &[f64],
    start: &[f64],
    follow: Follow,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    mut progress: impl FnMut(usize),
) -> (Vec<BranchPoint>, Option<(f64, AnalysisError)>) {
    let mut points: Vec<BranchPoint> = Vec::new();
    // a periodic branch's start and period in forcing periods, taken at
    // the first point and kept: a parameter that changes the forcing's
    // frequency changes each point's with it
    let mut timing = OrbitTiming::default();
    for (k, &value) in values.iter().enumerate() {
        progress(k);
        let guess: Vec<f64> = match &points[..] {
            [.., a, b] if a.value != b.value => {
                let s = (value - b.value) / (b.value - a.value);
                b.solution.state().iter().zip(a.solution.state()).map(|(xb, xa)| xb + s * (xb - xa)).collect()
            }
            [.., b] => b.solution.state().to_vec(),
            [] => start.to_vec(),
        };
        let found = build(value).and_then(|mut an| solve(&mut an, follow, &guess, &mut timing));
        match found {
            Ok(solution) => points.push(BranchPoint { value, solution, dp_ds: None }),
            Err(e) => return (points, Some((value, e))),
        }
    }
    (points, None)
}

/// The solution of the kind `follow` asks for nearest `guess` (2 nq); a
/// forced orbit's start and period as `timing` keeps them in forcing
/// periods (taken at the first call from `follow`'s,
/// [`crate::effects::Periodicity::orbit_timing`]).
///
/// # Errors
/// As [`Analysis::steady_motion`], [`Analysis::periodic_orbit`] and
/// [`Analysis::limit_cycle`].
pub(crate) fn solve<M: Model>(
    an: &mut Analysis<M>,
    follow: Follow,
    guess: &[f64],
    timing: &mut OrbitTiming,
) -> Result<Solution, AnalysisError> {
    let symmetry = an.symmetry(0.0, guess)?;
    match follow {
        Follow::Steady { energy } => an.steady_motion(0.0, guess, symmetry, energy).map(Solution::Steady),
        Follow::Periodic { t0, period, settings } => {
            let (t0, period) = an.forcing().map_or((t0, period), |f| f.orbit_timing(timing, t0, period));
            an.periodic_orbit(t0, period, guess, symmetry, &settings).map(Solution::Periodic)
        }
        Follow::Cycle { t0, period, settings } => {
            an.limit_cycle(t0, period, guess, symmetry, &settings).map(Solution::Periodic)
        }
    }
}
