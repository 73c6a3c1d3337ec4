//! Skates that can slip: a knife edge whose lateral force is limited by
//! Coulomb friction, `|lambda| <= mu N`.
//!
//! A skate given friction (the effect kind `skate-friction`,
//! [`crate::effects::EffectSpec::SkateFriction`]) is in one of two modes:
//!
//! - **sticking** ([`SkateMode::Sticking`]): the ideal skate. Its row of
//!   `G` holds the contact point's lateral velocity at zero and its
//!   multiplier `lambda` \[N\] is the lateral force the ground supplies.
//!   Valid while `|lambda| <= mu N`.
//! - **sliding** ([`SkateMode::Sliding`]): the row is *released*, taken
//!   out of the KKT system and of the velocity projection
//!   ([`crate::kkt::KktSystem::released`]), and the ground pushes with the
//!   Coulomb force `-s mu N` along the blade normal, `s = +-1` the sign of
//!   the lateral slip velocity `v = G_row qd` \[m/s\]. In the KKT system's
//!   sign convention (`M qdd + G^T lambda = f`) that is `lambda = s mu N`,
//!   a generalized force `-G_row^T s mu N`, and the power `-mu N |v|`
//!   \[W\] goes into the effect's work state, so the energy balance
//!   `T - T0 = sum W` keeps closing.
//!
//! The run switches modes at located events (`crate::simulate`): a
//! sticking skate slides when `mu N - |lambda|` falls through zero, with
//! `s` the sign of `lambda` there (the force is continuous through the
//! switch, and the slip it starts makes the friction dissipate); a sliding
//! skate stops slipping when `s v` falls through zero, and then sticks if
//! the force needed to hold it, `lambda` with the row restored, is within
//! `mu N`; otherwise it slides on the other way, `s = sign(lambda)`.
//! (Stewart, "Rigid-body dynamics with friction and impact", SIAM Review
//! 42 (2000) §2-3; Pfeiffer & Glocker, *Multibody Dynamics with Unilateral
//! Contacts*, Wiley 1996, ch. 5: the stick-slip transitions of planar
//! Coulomb contact as switching of the constraint set.)

use std::ops::Range;

/// A skate's contact mode.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum SkateMode {
    /// The ideal skate: no lateral slip, the force is the multiplier.
    #[default]
    Sticking,
    /// Slipping sideways in the direction `sign` (+1 or -1) of the lateral
    /// velocity `G_row qd`, against the force `mu N`.
    Sliding {
        /// The sign of the slip velocity (+1.0 or -1.0).
        sign: f64,
    },
}

impl SkateMode {
    /// `"sticking"` or `"sliding"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sticking => "sticking",
            Self::Sliding { .. } => "sliding",
        }
    }
    /// Whether the skate slides.
    pub fn is_sliding(self) -> bool {
        matches!(self, Self::Sliding { .. })
    }
}

/// A skate with Coulomb friction in a run: where its row is, its limit
/// and its mode (built by [`crate::formulation::dae::Dynamics`] from the effects of kind
/// `skate-friction`).
#[derive(Debug, Clone, PartialEq)]
pub struct SkateFriction {
    /// Index of its effect in [`crate::formulation::dae::Dynamics::effects`] (whose work
    /// state holds the friction's work).
    pub effect: usize,
    /// Index of the skate in [`crate::model::info::ModelInfo::skates`].
    pub skate: usize,
    /// The skate's name.
    pub name: String,
    /// Its row in `G`.
    pub row: usize,
    /// Its entries in [`crate::model::info::ModelInfo::pattern`].
    pub entries: Range<usize>,
    /// The friction limit `mu N` \[N\].
    pub limit: f64,
    /// The current mode.
    pub mode: SkateMode,
    /// The lateral slip velocity `G_row qd` \[m/s\] at the last evaluation
    /// of the right-hand side.
    pub slip: f64,
    /// Its rate `G_row qdd + gamma_row` \[m/s^2\] at the last evaluation
    /// (zero to rounding while sticking).
    pub slip_rate: f64,
    /// The row's `gamma` \[m/s^2\] at the last evaluation.
    pub gamma: f64,
}

impl SkateFriction {
    /// The multiplier `lambda` \[N\] a sliding skate's friction stands for
    /// (`s mu N`); 0 while sticking.
    pub fn sliding_lambda(&self) -> f64 {
        match self.mode {
            SkateMode::Sliding { sign } => sign * self.limit,
            SkateMode::Sticking => 0.0,
        }
    }

    /// How far the mode is from its switch, given the skate's multiplier
    /// `lambda` \[N\] with its row in place (sticking) and its slip
    /// velocity (sliding): `mu N - |lambda|` \[N\] while sticking, `s v`
    /// \[m/s\] while sliding. Positive while the mode holds; the run
    /// switches where it falls through zero.
    pub fn margin(&self, lambda: f64) -> f64 {
        match self.mode {
            SkateMode::Sticking => self.limit - lambda.abs(),
            SkateMode::Sliding { sign } => sign * self.slip,
        }
    }

    /// The event name of a switch out of the mode `from`, for the run's
    /// records: `slip_<skate>` (from sticking: it begins to slide) or
    /// `stick_<skate>` (from sliding: it sticks or turns).
    pub fn transition_name(&self, from: SkateMode) -> String {
        match from {
            SkateMode::Sticking => format!("slip_{}", self.name),
            SkateMode::Sliding { .. } => format!("stick_{}", self.name),
        }
    }
}

/// A skate's margin ([`SkateFriction::margin`]) and its rate at one time
/// of a step: `m` \[N or m/s\], `r = dm/dt` \[N/s or m/s^2\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarginSample {
    /// Time \[s\].
    pub t: f64,
    /// The margin.
    pub m: f64,
    /// Its rate along the motion.
    pub r: f64,
}

/// What the watch over one skate's margin found in a step
/// ([`scan_margin`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MarginScan {
    /// The mode holds over the whole step: the margin stays above `-eps`.
    Holds,
    /// The margin falls below zero in `(lo.t, hi.t]`, first there: `lo`
    /// at or above `-eps`, `hi` below (a bracket for
    /// [`crate::simulate::events::locate`]).
    Crosses {
        /// The bracket's start (the mode still holds).
        lo: MarginSample,
        /// Its end (the mode no longer holds).
        hi: MarginSample,
    },
    /// The margin holds up to `at` (the step's end, or where the scan ran
    /// out of samples and cuts the step) but was resolved only in pieces of
    /// [`SCAN_DEPTH`] halvings (it varies faster than the step, or jumps):
    /// the next steps are taken no longer than `h_max` \[s\].
    Unresolved {
        /// Where the step is cut \[s\].
        at: f64,
        /// The longest step that resolved it \[s\].
        h_max: f64,
    },
}

/// Samples of one skate's margin a step's scan takes at most
/// ([`scan_margin`]); past them the step is cut where the margin was last
/// resolved.
pub const SCAN_SAMPLES: usize = 40;

/// Halvings of a step a scan makes at most ([`scan_margin`]): an interval
/// of `h / 2^SCAN_DEPTH` whose samples stay above `-eps` is taken as
/// resolved, and the next steps are no longer than a few of it.
pub const SCAN_DEPTH: u32 = 6;

/// The cubic Hermite interpolant of the margin through the values and
/// rates of `a` and `b`, at `t`.
pub fn hermite_margin(a: &MarginSample, b: &MarginSample, t: f64) -> f64 {
    let h = b.t - a.t;
    if h <= 0.0 {
        return a.m;
    }
    let s = (t - a.t) / h;
    let (s2, s3) = (s * s, s * s * s);
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = s3 - 2.0 * s2 + s;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = s3 - s2;
    h00 * a.m + h10 * h * a.r + h01 * b.m + h11 * h * b.r
}

/// The rate of [`hermite_margin`] at `t`.
pub fn hermite_rate(a: &MarginSample, b: &MarginSample, t: f64) -> f64 {
    let h = b.t - a.t;
    if h <= 0.0 {
        return a.r;
    }
    let s = (t - a.t) / h;
    let s2 = s * s;
    let d00 = (6.0 * s2 - 6.0 * s) / h;
    let d10 = 3.0 * s2 - 4.0 * s + 1.0;
    let d01 = (-6.0 * s2 + 6.0 * s) / h;
    let d11 = 3.0 * s2 - 2.0 * s;
    d00 * a.m + d10 * a.r + d01 * b.m + d11 * b.r
}

/// The least value of [`hermite_margin`] on `[a.t, b.t]` and where it is
/// taken: the ends and the interior stationary points of the cubic.
pub fn hermite_min(a: &MarginSample, b: &MarginSample) -> (f64, f64) {
    let mut best = if a.m <= b.m { (a.t, a.m) } else { (b.t, b.m) };
    let h = b.t - a.t;
    if h.is_nan() || h <= 0.0 {
        return best;
    }
    // H(s) = a.m + c1 s + c2 s^2 + c3 s^3 on s in [0, 1]
    let (d, ra, rb) = (b.m - a.m, h * a.r, h * b.r);
    let c1 = ra;
    let c2 = 3.0 * d - 2.0 * ra - rb;
    let c3 = -2.0 * d + ra + rb;
    // H'(s) = c1 + 2 c2 s + 3 c3 s^2
    let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, c1);
    let mut roots = [f64::NAN; 2];
    if qa.abs() <= 1e-14 * (qb.abs() + qc.abs()) {
        if qb != 0.0 {
            roots[0] = -qc / qb;
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            let q = -0.5 * (qb + qb.signum() * sq);
            roots[0] = q / qa;
            if q != 0.0 {
                roots[1] = qc / q;
            }
        }
    }
    for s in roots {
        if s > 0.0 && s < 1.0 {
            let t = a.t + s * h;
            let m = hermite_margin(a, b, t);
            if m < best.1 {
                best = (t, m);
            }
        }
    }
    best
}

/// Whether a margin known at the ends of `[a.t, b.t]` (values and rates)
/// needs a closer look there: it ends below `-eps`, its Hermite
/// interpolant dips below `-eps`, or it comes within one interval's
/// travel (the interval times the larger rate, or the change of the
/// values) of zero, where a dip and return between the ends could hide.
/// A margin that is not finite always does.
pub fn margin_suspect(a: &MarginSample, b: &MarginSample, eps: f64) -> bool {
    let h = b.t - a.t;
    let travel = (h * a.r.abs().max(b.r.abs())).max((b.m - a.m).abs());
    let near = a.m.min(b.m) <= travel;
    !(a.m.is_finite() && b.m.is_finite() && a.r.is_finite() && b.r.is_finite())
        || b.m < -eps
        || near
        || hermite_min(a, b).1 < -eps
}

/// Whether a margin `m` violates its mode (below `-eps`, or not a number).
fn violated(m: f64, eps: f64) -> bool {
    m.is_nan() || m < -eps
}

/// On an interval whose ends' interpolant is trusted: its end if that
/// violates the mode, else the interpolant's lowest point if it dips below
/// `-eps` and a sample there confirms it (counted in `samples`).
///
/// # Errors
/// Whatever `sample` fails with.
fn first_violation<E>(
    u: &MarginSample,
    v: &MarginSample,
    eps: f64,
    sample: &mut impl FnMut(f64) -> Result<MarginSample, E>,
    samples: &mut usize,
) -> Result<Option<MarginSample>, E> {
    if violated(v.m, eps) {
        return Ok(Some(*v));
    }
    let (tm, hm) = hermite_min(u, v);
    if hm < -eps && tm > u.t && tm < v.t {
        let s = sample(tm)?;
        *samples += 1;
        if violated(s.m, eps) {
            return Ok(Some(s));
        }
    }
    Ok(None)
}

/// Watches one skate's margin over a step from `a` to `b` (its values
/// and rates at the ends; `a.m >= -eps`, the mode held at the step's
/// start) with `sample(t)` giving it anywhere inside, on the step's
/// continuous extension. Where the ends leave it in doubt
/// ([`margin_suspect`]), the step is halved and each half sampled at its
/// middle, left to right: an interval whose midpoint value and rate the
/// ends' cubic Hermite interpolant predicts to within a tenth of the
/// margin's least value there (or `1e-3` of its size, at least `eps`;
/// the rate's miss times half the interval) is resolved, and
/// its two halves' interpolants decide it; one that is not is halved
/// again, up to [`SCAN_DEPTH`] times and [`SCAN_SAMPLES`] samples. The
/// first interval whose margin falls below `-eps` is returned as a
/// bracket; a dip of a resolved interpolant is confirmed by one sample at
/// its lowest point. So a margin that dips below zero and returns inside
/// one step is found, however the ends look, once the step's samples
/// resolve its variation; a step too long for that is cut where they
/// stopped resolving it ([`MarginScan::Unresolved`]).
///
/// (The switching-function test of event location, Hairer, Nørsett &
/// Wanner I §II.6 and Shampine & Thompson, "Event location for ordinary
/// differential equations", Comput. Math. Appl. 39 (2000), extended from
/// the step's ends to its interior by the interpolant's extrema.)
///
/// # Errors
/// Whatever `sample` fails with.
pub fn scan_margin<E>(
    a: MarginSample,
    b: MarginSample,
    eps: f64,
    mut sample: impl FnMut(f64) -> Result<MarginSample, E>,
) -> Result<MarginScan, E> {
    if !margin_suspect(&a, &b, eps) {
        return Ok(MarginScan::Holds);
    }
    let (mut samples, mut h_max) = (0, f64::INFINITY);
    // intervals still to decide, the leftmost last
    let mut stack = vec![(a, b, 0u32)];
    while let Some((l, r, depth)) = stack.pop() {
        if !margin_suspect(&l, &r, eps) {
            continue;
        }
        if samples >= SCAN_SAMPLES || depth >= SCAN_DEPTH {
            // as small as this scan goes: decided by its ends and the
            // interpolant's lowest point
            if let Some(hi) = first_violation(&l, &r, eps, &mut sample, &mut samples)? {
                return Ok(MarginScan::Crosses { lo: l, hi });
            }
            // the next steps no longer than a few of this piece
            h_max = h_max.min(4.0 * (r.t - l.t));
            if samples >= SCAN_SAMPLES && l.t > a.t {
                // out of samples: cut where it was last resolved
                return Ok(MarginScan::Unresolved { at: l.t, h_max });
            }
            // a piece of h / 2^SCAN_DEPTH whose samples hold is taken as
            // holding (a kink or a jump of the margin, where the forces
            // change at an instant, is resolved by no halving)
            continue;
        }
        let c = sample(0.5 * (l.t + r.t))?;
        samples += 1;
        let (predicted, slope) = (hermite_margin(&l, &r, c.t), hermite_rate(&l, &r, c.t));
        let size = l.m.abs().max(c.m.abs()).max(r.m.abs());
        let tol = (0.1 * l.m.min(c.m).min(r.m).max(0.0)).max(1e-3 * size).max(eps);
        let half = 0.5 * (r.t - l.t);
        if c.m.is_finite() && (c.m - predicted).abs() <= tol && half * (c.r - slope).abs() <= tol {
            // resolved: each half's interpolant decides it
            for (u, v) in [(l, c), (c, r)] {
                if let Some(hi) = first_violation(&u, &v, eps, &mut sample, &mut samples)? {
                    return Ok(MarginScan::Crosses { lo: u, hi });
                }
            }
            continue;
        }
        stack.push((c, r, depth + 1));
        stack.push((l, c, depth + 1));
    }
    Ok(if h_max.is_finite() { MarginScan::Unresolved { at: b.t, h_max } } else { MarginScan::Holds })
}

/// Ratio of one skate's interval between two switches to the interval
/// before at or below which its switches count as one streak
/// ([`SwitchStreak`]).
pub const CHATTER_SHRINK: f64 = 0.9;

/// One skate's switches in a row at ever shorter intervals (each at most
/// [`CHATTER_SHRINK`] of the one before, or within a few units of
/// rounding of the last), or, with a fixed step, a few steps apart
/// ([`SwitchStreak::record`]): [`crate::events::spec::CHATTER_STEPS`] of them
/// are chattering ([`crate::error::SimError::SlipChattering`]), switches piling
/// up at a finite time (Zeno), sitting at the limit within rounding, or
/// faster than the fixed step. A stick-slip motion that an adaptive
/// method's steps resolve, however fast, switches at intervals that do not
/// shrink without end, and so never makes one.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SwitchStreak {
    /// Switches in the streak.
    pub count: u64,
    /// When it began \[s\].
    pub since: f64,
    last: f64,
    gap: f64,
}

impl SwitchStreak {
    /// Records a switch at `t` and returns the streak's length. With a
    /// fixed step, a switch within `fixed` \[s\] of the last (a few
    /// steps: [`crate::simulate::SLIP_CHATTER_GAP`]) continues the streak too: such a
    /// step does not resolve the motion between the switches (it cannot
    /// shrink to follow them, as an adaptive one does), so a run switching
    /// every few steps for that long is refused with the advice of a
    /// smaller step.
    pub fn record(&mut self, t: f64, fixed: Option<f64>) -> u64 {
        let gap = t - self.last;
        let rounding = 1e-12 * t.abs().max(1.0);
        let close = fixed.is_some_and(|g| gap <= g);
        if self.count > 0 && (gap <= CHATTER_SHRINK * self.gap || gap <= rounding || close) {
            self.count += 1;
        } else {
            (self.count, self.since) = (1, t);
        }
        (self.last, self.gap) = (t, gap);
        self.count
    }
}

/// Constraint rows taken out of a linear system (sliding skates): their
/// row numbers and their entries in the pattern of `G`, to zero.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Released {
    rows: Vec<usize>,
    ranges: Vec<Range<usize>>,
}

impl Released {
    /// Releases `rows` of `G` with row-major sorted `pattern` (the
    /// previous set is replaced; empty restores every row).
    pub fn set(&mut self, pattern: &[(usize, usize)], rows: &[usize]) {
        self.rows.clear();
        self.rows.extend_from_slice(rows);
        self.ranges.clear();
        self.ranges.extend(rows.iter().map(|&r| row_entries(pattern, r)));
    }

    /// The released rows.
    pub fn rows(&self) -> &[usize] {
        &self.rows
    }

    /// Whether no row is released.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Zeroes the released rows' entries of `values` (`G` at the pattern).
    #[inline]
    pub fn zero(&self, values: &mut [f64]) {
        for r in &self.ranges {
            values[r.clone()].fill(0.0);
        }
    }
}

/// The entries of row `row` in a row-major sorted `pattern`.
pub fn row_entries(pattern: &[(usize, usize)], row: usize) -> Range<usize> {
    pattern.partition_point(|&(r, _)| r < row)..pattern.partition_point(|&(r, _)| r <= row)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn released_rows_zero_their_entries_only() {
        let pattern = [(0, 0), (0, 2), (1, 1), (2, 0), (2, 1), (2, 2)];
        assert_eq!(row_entries(&pattern, 2), 3..6);
        assert_eq!(row_entries(&pattern, 1), 2..3);
        let mut released = Released::default();
        released.set(&pattern, &[2]);
        let mut v = [1.0; 6];
        released.zero(&mut v);
        assert_eq!(v, [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]);
        released.set(&pattern, &[]);
        assert!(released.is_empty());
    }

    /// A margin `m(t)` and its rate as a sampler.
    fn sampler(m: impl Fn(f64) -> (f64, f64)) -> impl FnMut(f64) -> Result<MarginSample, ()> {
        move |t| {
            let (m, r) = m(t);
            Ok(MarginSample { t, m, r })
        }
    }

    fn at(m: &impl Fn(f64) -> (f64, f64), t: f64) -> MarginSample {
        let (v, r) = m(t);
        MarginSample { t, m: v, r }
    }

    #[test]
    fn the_hermite_interpolant_is_exact_for_cubics_and_finds_their_minimum() {
        let m = |t: f64| (t * t * t - 2.0 * t * t + 0.5, 3.0 * t * t - 4.0 * t);
        let (a, b) = (at(&m, 0.0), at(&m, 2.0));
        for t in [0.3, 1.0, 1.7] {
            assert!((hermite_margin(&a, &b, t) - m(t).0).abs() < 1e-14);
            assert!((hermite_rate(&a, &b, t) - m(t).1).abs() < 1e-13);
        }
        // the minimum at t = 4/3
        let (tm, hm) = hermite_min(&a, &b);
        assert!((tm - 4.0 / 3.0).abs() < 1e-12 && (hm - m(4.0 / 3.0).0).abs() < 1e-14, "{tm} {hm}");
    }

    /// A margin that dips below zero and returns inside the step, with
    /// both ends well above zero: the ends alone say nothing, the scan
    /// finds the dip and brackets its first crossing.
    #[test]
    fn a_dip_and_return_inside_a_step_is_found() {
        // 1 - 1.2 |cos(w t)| near a peak: t in [0, 1], dip around t = 0.5
        let m = |t: f64| {
            let x = (t - 0.5) * 6.0;
            (x * x * 0.5 - 0.2, 6.0 * x)
        };
        let (a, b) = (at(&m, 0.0), at(&m, 1.0));
        assert!(a.m > 0.0 && b.m > 0.0);
        match scan_margin(a, b, 1e-12, sampler(m)).unwrap() {
            MarginScan::Crosses { lo, hi } => {
                // the root at x = -sqrt(0.4): t = 0.5 - 0.1054
                let root = 0.5 - 0.4f64.sqrt() / 6.0;
                assert!(lo.m >= 0.0 && hi.m < 0.0 && lo.t <= root && root <= hi.t, "{lo:?} {hi:?} {root}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// A margin far from zero and slow needs no sample; one that oscillates
    /// many times within the step is not taken as holding: its first dip is
    /// found, or the step is cut where the samples stopped resolving it.
    #[test]
    fn far_margins_cost_nothing_and_fast_ones_are_not_trusted() {
        let slow = |t: f64| (1.0 + 0.1 * t, 0.1);
        let mut n = 0;
        let scan = scan_margin(at(&slow, 0.0), at(&slow, 1.0), 1e-12, |t| {
            n += 1;
            sampler(slow)(t)
        });
        assert_eq!((scan.unwrap(), n), (MarginScan::Holds, 0));
        // 0.98 - 1.2 |cos(1000 t)| over 0.05 s: 16 periods, ends near 0.98
        let w = 1000.0;
        let fast = |t: f64| {
            let c: f64 = (w * t).cos();
            (0.98 - 1.2 * c.abs(), 1.2 * w * (w * t).sin() * c.signum())
        };
        let (a, b) = (at(&fast, std::f64::consts::FRAC_PI_2 / w), at(&fast, std::f64::consts::FRAC_PI_2 / w + 0.05));
        match scan_margin(a, b, 1e-12, sampler(fast)).unwrap() {
            MarginScan::Crosses { lo, hi } => {
                assert!(lo.m >= 0.0 && hi.m < 0.0 && hi.t < a.t + std::f64::consts::PI / w)
            }
            MarginScan::Unresolved { at, h_max } => assert!(at < b.t && h_max < 0.05, "{at} {h_max}"),
            MarginScan::Holds => panic!("a margin crossing zero 32 times taken as holding"),
        }
    }

    #[test]
    fn switch_streaks_count_shrinking_intervals_only() {
        let mut s = SwitchStreak::default();
        // periodic stick-slip: alternating intervals never make a streak
        let mut t = 0.0;
        for k in 0..200 {
            t += if k % 2 == 0 { 1.3e-3 } else { 1.9e-3 };
            assert!(s.record(t, None) <= 2);
        }
        // Zeno: each interval a fifth of the one before
        let (mut s, mut t, mut gap) = (SwitchStreak::default(), 1.0, 0.1);
        let mut longest = 0;
        for _ in 0..40 {
            t += gap;
            gap *= 0.2;
            longest = longest.max(s.record(t, None));
        }
        assert_eq!(longest, 40);
        // a fixed step of 1e-3 with a switch every 1.5 steps
        let mut s = SwitchStreak::default();
        let n = (1..=64).map(|k| s.record(k as f64 * 1.5e-3, Some(8e-3))).max().unwrap();
        assert_eq!(n, 64);
    }

    #[test]
    fn margins_and_lambda() {
        let mut f = SkateFriction {
            effect: 0,
            skate: 0,
            name: "A".into(),
            row: 3,
            entries: 0..3,
            limit: 2.0,
            mode: SkateMode::Sticking,
            slip: 0.0,
            slip_rate: 0.0,
            gamma: 0.0,
        };
        assert_eq!(f.margin(-1.5), 0.5);
        assert_eq!(f.margin(2.5), -0.5);
        assert_eq!(f.transition_name(SkateMode::Sticking), "slip_A");
        f.mode = SkateMode::Sliding { sign: -1.0 };
        f.slip = -0.25;
        assert_eq!(f.margin(0.0), 0.25);
        assert_eq!(f.sliding_lambda(), -2.0);
        assert_eq!(f.transition_name(f.mode), "stick_A");
    }
}
