//! The EzyRoller (docs/physics.md §10): two bodies joined by a hinge at B, one skate on
//! each. Nothing but this declaration describes it: phi, its Jacobian, the
//! skate matrix and all convective terms are derived by `model!`.

ezy_core::model! {
    /// The EzyRoller: a rear frame (body 1, skate A) and a steering fork
    /// (body 2, skate C) joined by a hinge at B. Its equations and scenes:
    /// docs/physics.md §10.
    pub struct EzyRoller {
        /// Distance from body 1's centre of mass back to its skate A [m]
        param a = 0.2;
        /// Distance from body 1's centre of mass forward to the hinge B [m]
        param b = 0.6;
        /// Distance from body 2's centre of mass forward to its skate C [m]
        param c = 0.1;
        /// Distance from body 2's centre of mass back to the hinge B [m]
        param d = 0.1;
        /// Mass of body 1 [kg]
        param m1 = 46.0;
        /// Moment of inertia of body 1 about its centre of mass [kg m^2]
        param I1 = 10.0;
        /// Mass of body 2 [kg]
        param m2 = 1.0;
        /// Moment of inertia of body 2 about its centre of mass [kg m^2]
        param I2 = 0.005;

        /// Rear frame.
        body body1(x1, y1, phi1) { mass: m1, inertia: I1 }
        /// Steering fork.
        body body2(x2, y2, phi2) { mass: m2, inertia: I2 }

        point A on body1 at (-a, 0);
        point B1 on body1 at (b, 0);
        point B2 on body2 at (-d, 0);
        point C on body2 at (c, 0);

        hinge B: B1 = B2;
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}
