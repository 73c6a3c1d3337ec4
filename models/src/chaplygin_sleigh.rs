//! The Chaplygin sleigh (docs/physics.md §9): one body, one skate a distance `a`
//! behind the centre of mass. Its closed-form solution checks the whole
//! pipeline end to end.

ezy_core::model! {
    /// The Chaplygin sleigh: one body with a skate at distance a behind its
    /// centre of mass. Its closed-form solution: docs/physics.md §9.
    pub struct ChaplyginSleigh {
        /// Mass [kg]
        param m = 1.0;
        /// Moment of inertia about the centre of mass [kg m^2]
        param I = 0.1;
        /// Distance from the centre of mass back to the skate [m]
        param a = 0.5;

        body sleigh(x, y, phi) { mass: m, inertia: I }
        point P on sleigh at (-a, 0);
        skate P: P along (1, 0);
    }
}
