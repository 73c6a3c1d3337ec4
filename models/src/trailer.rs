//! A tractor with two trailers (a fixed count until the model language has
//! families): the tractor has a driven rear axle and a front axle steered
//! at a fixed angle; each trailer has one axle and hangs on the hitch of
//! the body in front.

ezy_core::model! {
    /// A tractor with a steered front axle pulling two single-axle trailers.
    pub struct Trailer {
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
        /// The first trailer.
        body trailer1(x1, y1, phi1) { mass: m, inertia: I }
        /// The second trailer.
        body trailer2(x2, y2, phi2) { mass: m, inertia: I }

        point R on tractor at (-L / 2, 0);
        point F on tractor at (L / 2, 0);
        point H0 on tractor at (-L / 2 - h, 0);
        point T1 on trailer1 at (l / 2, 0);
        point A1 on trailer1 at (-l / 2, 0);
        point H1 on trailer1 at (-l / 2 - h, 0);
        point T2 on trailer2 at (l / 2, 0);
        point A2 on trailer2 at (-l / 2, 0);

        hinge K1: T1 = H0;
        hinge K2: T2 = H1;
        skate R: R along (1, 0);
        skate F: F along (cos(delta), sin(delta));
        skate A1: A1 along (1, 0);
        skate A2: A2 along (1, 0);
    }
}
