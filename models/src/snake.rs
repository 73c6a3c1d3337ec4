//! Snake robots of `N` links (a family: `N` is a count, set per scene).
//! `Snake`: a skate at the middle of each link, hinges between
//! neighbouring links, driven by hinge motors in a serpenoid gait (the
//! scene's effects). `SnakeDriven`: the hinge angles prescribed by a
//! family of drives (the scene's serpenoid curve), the ground acting
//! through anisotropic friction. `SnakeServo`: the same snake with free
//! hinges, for the scene's effects to drive (stiff hinge servos in
//! `snake-stiff`). The generated code is one element kernel
//! per item, looped over the links, so it does not grow with `N`.

ezy_core::model! {
    /// A snake robot of N links with a skate at the middle of each link.
    pub struct Snake {
        /// Number of links
        count N = 5;
        /// Length of a link [m]
        param l = 0.3;
        /// Mass of a link [kg]
        param m = 1.0;
        /// Moment of inertia of a link about its centre [kg m^2]
        param I = 0.0075;

        for i in 1..N + 1 {
            body link[i](x, y, phi) { mass: m, inertia: I }
            point S[i] on link[i] at (0, 0);
            point B[i] on link[i] at (-l / 2, 0);
            point F[i] on link[i] at (l / 2, 0);
            skate S[i]: S[i] along (1, 0);
        }
        // J[i] joins the back of link i - 1 to the front of link i
        for i in 2..N + 1 {
            hinge J[i]: B[i - 1] = F[i];
        }
    }
}

ezy_core::model! {
    /// A snake robot of N links whose hinge angles are prescribed (drives
    /// D2 .. DN): the scene gives the gait once for the family. No skates:
    /// with every angle prescribed the snake keeps three degrees of freedom,
    /// which N skates would overconstrain, so the ground acts through
    /// anisotropic friction (the scene's effects).
    pub struct SnakeDriven {
        /// Number of links
        count N = 30;
        /// Length of a link [m]
        param l = 0.3;
        /// Mass of a link [kg]
        param m = 1.0;
        /// Moment of inertia of a link about its centre [kg m^2]
        param I = 0.0075;

        for i in 1..N + 1 {
            body link[i](x, y, phi) { mass: m, inertia: I }
            point S[i] on link[i] at (0, 0);
            point B[i] on link[i] at (-l / 2, 0);
            point F[i] on link[i] at (l / 2, 0);
        }
        // J[i] joins the back of link i - 1 to the front of link i; its
        // angle phi[i - 1] - phi[i] follows the scene's D[i]
        for i in 2..N + 1 {
            hinge J[i]: B[i - 1] = F[i];
            drive D[i]: hinge J[i];
        }
    }
}

ezy_core::model! {
    /// A snake robot of N links with free hinges, on ground that acts
    /// through the scene's effects (anisotropic friction): the scene's
    /// hinge effects drive it, as position servos in `snake-stiff`.
    pub struct SnakeServo {
        /// Number of links
        count N = 10;
        /// Length of a link [m]
        param l = 0.3;
        /// Mass of a link [kg]
        param m = 1.0;
        /// Moment of inertia of a link about its centre [kg m^2]
        param I = 0.0075;

        for i in 1..N + 1 {
            body link[i](x, y, phi) { mass: m, inertia: I }
            point S[i] on link[i] at (0, 0);
            point B[i] on link[i] at (-l / 2, 0);
            point F[i] on link[i] at (l / 2, 0);
        }
        // J[i] joins the back of link i - 1 to the front of link i; its
        // angle is phi[i - 1] - phi[i]
        for i in 2..N + 1 {
            hinge J[i]: B[i - 1] = F[i];
        }
    }
}
