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
/// and its mode (built by [`crate::Dynamics`] from the effects of kind
/// `skate-friction`).
#[derive(Debug, Clone, PartialEq)]
pub struct SkateFriction {
    /// Index of its effect in [`crate::Dynamics::effects`] (whose work
    /// state holds the friction's work).
    pub effect: usize,
    /// Index of the skate in [`crate::ModelInfo::skates`].
    pub skate: usize,
    /// The skate's name.
    pub name: String,
    /// Its row in `G`.
    pub row: usize,
    /// Its entries in [`crate::ModelInfo::pattern`].
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
