//! A snake robot of five links (a fixed count until the model language has
//! families): a skate at the middle of each link, hinges between
//! neighbouring links, driven by hinge motors in a serpenoid gait (the
//! scene's effects).

ezy_core::model! {
    /// A five-link snake robot with a skate at the middle of each link.
    pub struct Snake {
        /// Length of a link [m]
        param l = 0.3;
        /// Mass of a link [kg]
        param m = 1.0;
        /// Moment of inertia of a link about its centre [kg m^2]
        param I = 0.0075;

        body link1(x1, y1, phi1) { mass: m, inertia: I }
        body link2(x2, y2, phi2) { mass: m, inertia: I }
        body link3(x3, y3, phi3) { mass: m, inertia: I }
        body link4(x4, y4, phi4) { mass: m, inertia: I }
        body link5(x5, y5, phi5) { mass: m, inertia: I }

        point S1 on link1 at (0, 0);
        point S2 on link2 at (0, 0);
        point S3 on link3 at (0, 0);
        point S4 on link4 at (0, 0);
        point S5 on link5 at (0, 0);
        point B1 on link1 at (-l / 2, 0);
        point F2 on link2 at (l / 2, 0);
        point B2 on link2 at (-l / 2, 0);
        point F3 on link3 at (l / 2, 0);
        point B3 on link3 at (-l / 2, 0);
        point F4 on link4 at (l / 2, 0);
        point B4 on link4 at (-l / 2, 0);
        point F5 on link5 at (l / 2, 0);

        hinge J1: B1 = F2;
        hinge J2: B2 = F3;
        hinge J3: B3 = F4;
        hinge J4: B4 = F5;
        skate S1: S1 along (1, 0);
        skate S2: S2 along (1, 0);
        skate S3: S3 along (1, 0);
        skate S4: S4 along (1, 0);
        skate S5: S5 along (1, 0);
    }
}
