//! A tractor with `n` trailers (a family: `n` is a count, 2 by default):
//! the tractor has a driven rear axle and a front axle steered at a fixed
//! angle; each trailer has one axle and hangs on the hitch of the body in
//! front.

ezy_core::model! {
    /// A tractor with a steered front axle pulling n single-axle trailers.
    pub struct Trailer {
        /// Number of trailers
        count n = 2;
        /// Wheelbase of the tractor [m]
        param L = 2.5;
        /// Steering angle of the tractor's front axle [rad]
        param delta = 0.3;
        /// Distance from the hitch of a trailer (its tongue) to its axle [m]
        param l = 4.0;
        /// Distance of each hitch point behind the axle in front of it [m]
        param h = 0.5;
        /// Mass of the tractor [kg]
        param m0 = 3000.0;
        /// Moment of inertia of the tractor [kg m^2]
        param I0 = 3000.0;
        /// Mass of a trailer [kg]
        param m = 2000.0;
        /// Moment of inertia of a trailer [kg m^2]
        param I = 4000.0;

        /// The tractor.
        body tractor(x0, y0, phi0) { mass: m0, inertia: I0 }
        point R on tractor at (-L / 2, 0);
        point F on tractor at (L / 2, 0);
        point H0 on tractor at (-L / 2 - h, 0);
        skate R: R along (1, 0);
        skate F: F along (cos(delta), sin(delta));

        for i in 1..n + 1 {
            body trailer[i](x, y, phi) { mass: m, inertia: I }
            /// tongue, axle and rear hitch of trailer i
            point T[i] on trailer[i] at (l / 2, 0);
            point A[i] on trailer[i] at (-l / 2, 0);
            point H[i] on trailer[i] at (-l / 2 - h, 0);
            skate A[i]: A[i] along (1, 0);
        }
        hinge K1: T[1] = H0;
        for i in 2..n + 1 {
            hinge K[i]: T[i] = H[i - 1];
        }
    }
}
