//! Planar mechanisms of the textbooks, each with a check that does not
//! come from ezy: a four-bar linkage against Freudenstein's equation, a
//! slider-crank against the closed form of its piston's position, a
//! double pendulum against the frequencies of its linearization, the
//! IFToMM benchmark's N-four-bar (A02) against the one-degree-of-freedom
//! equation of its parallelogram motion (the tests in
//! `tests/mechanisms.rs`), and the simple pendulum of IFToMM's benchmark
//! A01 against its closed form in Jacobi's elliptic functions
//! (`tests/guards.rs`). Links are uniform bars, except the simple
//! pendulum's massless one: a link of length `L` and mass `m` has its
//! centre of mass at its middle and the inertia `m L^2 / 12` (the
//! four-bar's defaults: 2 kg/m).

ezy_core::model! {
    /// A four-bar linkage: crank O2-A, coupler A-B and rocker O4-B on the
    /// ground pivots O2 = (0, 0) and O4 = (d, 0). The default lengths make
    /// a Grashof crank-rocker (the crank, the shortest link, turns fully).
    pub struct FourBar {
        /// Length of the crank O2-A [m]
        param a = 0.1;
        /// Length of the coupler A-B [m]
        param b = 0.35;
        /// Length of the rocker O4-B [m]
        param c = 0.3;
        /// Distance of the ground pivots O2-O4 [m]
        param d = 0.3;
        /// Mass of the crank [kg]
        param m2 = 0.2;
        /// Moment of inertia of the crank about its centre [kg m^2]
        param I2 = 0.00016666666666666666;
        /// Mass of the coupler [kg]
        param m3 = 0.7;
        /// Moment of inertia of the coupler about its centre [kg m^2]
        param I3 = 0.0071458333333333333;
        /// Mass of the rocker [kg]
        param m4 = 0.6;
        /// Moment of inertia of the rocker about its centre [kg m^2]
        param I4 = 0.0045;

        /// The crank, its axis from O2 to A: its heading is the input angle.
        body crank(x2, y2, phi2) { mass: m2, inertia: I2 }
        body coupler(x3, y3, phi3) { mass: m3, inertia: I3 }
        /// The rocker, its axis from O4 to B: its heading is the output angle.
        body rocker(x4, y4, phi4) { mass: m4, inertia: I4 }
        point O2 on crank at (-a / 2, 0);
        point A2 on crank at (a / 2, 0);
        point A3 on coupler at (-b / 2, 0);
        point B3 on coupler at (b / 2, 0);
        point O4 on rocker at (-c / 2, 0);
        point B4 on rocker at (c / 2, 0);
        hinge O2: O2 = ground(0, 0);
        hinge A: A2 = A3;
        hinge B: B3 = B4;
        hinge O4: O4 = ground(d, 0);
    }
}

ezy_core::model! {
    /// The four-bar's crank and rocker on their ground pivots without the
    /// coupler: the scene joins the pins A and B by a spring-damper (a
    /// massless elastic coupler; with a stiff one, `four-bar-stiff`, the
    /// linkage moves as the rigid four-bar and the scene is stiff).
    pub struct ElasticFourBar {
        /// Length of the crank O2-A [m]
        param a = 0.1;
        /// Length of the rocker O4-B [m]
        param c = 0.3;
        /// Distance of the ground pivots O2-O4 [m]
        param d = 0.3;
        /// Mass of the crank [kg]
        param m2 = 0.2;
        /// Moment of inertia of the crank about its centre [kg m^2]
        param I2 = 0.00016666666666666666;
        /// Mass of the rocker [kg]
        param m4 = 0.6;
        /// Moment of inertia of the rocker about its centre [kg m^2]
        param I4 = 0.0045;

        body crank(x2, y2, phi2) { mass: m2, inertia: I2 }
        body rocker(x4, y4, phi4) { mass: m4, inertia: I4 }
        point O2 on crank at (-a / 2, 0);
        point A2 on crank at (a / 2, 0);
        point O4 on rocker at (-c / 2, 0);
        point B4 on rocker at (c / 2, 0);
        hinge O2: O2 = ground(0, 0);
        hinge O4: O4 = ground(d, 0);
    }
}

ezy_core::model! {
    /// A slider-crank: crank O-A on a ground pivot at the origin,
    /// connecting rod A-B, and a piston whose pin B slides on the x axis
    /// (its heading fixed), in a vertical plane.
    pub struct SliderCrank {
        /// Crank radius O-A [m]
        param r = 0.05;
        /// Length of the connecting rod A-B [m]
        param l = 0.2;
        /// Mass of the crank [kg]
        param mc = 0.5;
        /// Mass of the connecting rod [kg]
        param ml = 0.8;
        /// Mass of the piston [kg]
        param mp = 1.0;
        /// Moment of inertia of the piston [kg m^2]
        param Ip = 0.001;

        body crank(x1, y1, phi1) { mass: mc, inertia: mc * r * r / 12 }
        body rod(x2, y2, phi2) { mass: ml, inertia: ml * l * l / 12 }
        body piston(x3, y3, phi3) { mass: mp, inertia: Ip }
        point O on crank at (-r / 2, 0);
        point A1 on crank at (r / 2, 0);
        point A2 on rod at (-l / 2, 0);
        point B2 on rod at (l / 2, 0);
        point P on piston at (0, 0);
        hinge O: O = ground(0, 0);
        hinge A: A1 = A2;
        hinge B: B2 = P;
        slider S: P on ground(0, 0) along (1, 0);
    }
}

ezy_core::model! {
    /// A double pendulum of two uniform bars: the upper hangs from a ground
    /// pivot at the origin, the lower from the upper's end; a heading of
    /// -pi/2 hangs straight down.
    pub struct DoublePendulum {
        /// Length of the upper bar [m]
        param L1 = 1.0;
        /// Length of the lower bar [m]
        param L2 = 0.7;
        /// Mass of the upper bar [kg]
        param m1 = 1.0;
        /// Mass of the lower bar [kg]
        param m2 = 0.6;

        body upper(x1, y1, phi1) { mass: m1, inertia: m1 * L1 * L1 / 12 }
        body lower(x2, y2, phi2) { mass: m2, inertia: m2 * L2 * L2 / 12 }
        point O on upper at (-L1 / 2, 0);
        point E1 on upper at (L1 / 2, 0);
        point E2 on lower at (-L2 / 2, 0);
        point T on lower at (L2 / 2, 0);
        hinge O: O = ground(0, 0);
        hinge J: E1 = E2;
    }
}

ezy_core::model! {
    /// The simple pendulum of the IFToMM multibody benchmark A01: a point
    /// mass `m` on a massless link of length `L` hinged to the ground at the
    /// origin. The body's frame sits at the point mass (its centre of mass,
    /// with inertia `I = 0`: a point), the hinge point `L` behind it along its
    /// axis, so the heading `phi` is the link's angle from the x axis and
    /// `(x, y) = L (cos phi, sin phi)`; `phi = -pi/2` hangs straight down.
    /// Its mass matrix is singular (no inertia for `phi`): the hinge fixes
    /// `phi` from `(x, y)` and the KKT matrix is regular.
    pub struct Pendulum {
        /// Length of the link [m]
        param L = 1.0;
        /// The point mass [kg]
        param m = 1.0;
        /// Moment of inertia of the bob about its centre [kg m^2]: 0 for
        /// the benchmark's point mass
        param I = 0.0;

        body bob(x, y, phi) { mass: m, inertia: I }
        point O on bob at (-L, 0);
        hinge O: O = ground(0, 0);
    }
}

ezy_core::model! {
    /// The N-four-bar mechanism of the IFToMM multibody benchmark library
    /// (problem A02): N + 1 cranks on ground pivots at (i L, 0), i = 0..N,
    /// and N couplers, each joining the tips of two neighbouring cranks;
    /// all bars alike. One degree of freedom: 3 (2N + 1) coordinates and
    /// 2 (3N + 1) independent constraint rows, except in the singular
    /// configuration (all bars on the x axis), passed twice a revolution,
    /// where their rank is 5N + 2 (each of the N loops may leave it as a
    /// parallelogram or not).
    pub struct NFourBar {
        /// Number of couplers (there are N + 1 cranks)
        count N = 2;
        /// Length of every bar [m]
        param L = 1.0;
        /// Mass of every bar [kg]
        param m = 1.0;

        for i in 0..N + 1 {
            /// Crank i, its axis from its ground pivot O[i] to its tip
            /// T[i]: its heading theta_i is the crank angle.
            body crank[i](xc, yc, theta) { mass: m, inertia: m * L * L / 12 }
            point O[i] on crank[i] at (-L / 2, 0);
            point T[i] on crank[i] at (L / 2, 0);
            hinge O[i]: O[i] = ground(i * L, 0);
        }
        for i in 1..N + 1 {
            /// Coupler i, its axis from the tip of crank i - 1 (A[i]) to
            /// the tip of crank i (B[i]).
            body coupler[i](xk, yk, psi) { mass: m, inertia: m * L * L / 12 }
            point A[i] on coupler[i] at (-L / 2, 0);
            point B[i] on coupler[i] at (L / 2, 0);
            hinge A[i]: A[i] = T[i - 1];
            hinge B[i]: B[i] = T[i];
        }
    }
}
