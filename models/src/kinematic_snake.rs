//! The three-link kinematic snake (Hatton & Choset, "Geometric motion
//! planning: the local connection, Stokes's theorem, and the importance
//! of coordinate choice", IJRR 30(8), 2011, §4): three links of length
//! `l` with a skate at each link's middle, the two hinge angles
//! prescribed. Three skates fix the body velocity of the middle link from
//! the shape's rate (a kinematic system), everywhere but where the
//! skates' normals meet in one point (`alpha1 = alpha2`).

ezy_core::model! {
    /// The three-link kinematic snake: links `rear`, `middle`, `front` of
    /// length l, a skate at each middle, hinge angles alpha1 = middle's
    /// heading minus rear's and alpha2 = front's minus middle's
    /// (counter-clockwise positive), each prescribed by a drive.
    pub struct KinematicSnake {
        /// Length of a link [m]
        param l = 1.0;
        /// Mass of a link [kg]
        param m = 1.0;
        /// Moment of inertia of a link about its middle [kg m^2]
        param I = 0.08333333333333333;

        body rear(x1, y1, phi1) { mass: m, inertia: I }
        body middle(x2, y2, phi2) { mass: m, inertia: I }
        body front(x3, y3, phi3) { mass: m, inertia: I }
        point S1 on rear at (0, 0);
        point R on rear at (l / 2, 0);
        point M0 on middle at (-l / 2, 0);
        point S2 on middle at (0, 0);
        point M1 on middle at (l / 2, 0);
        point F on front at (-l / 2, 0);
        point S3 on front at (0, 0);
        // each hinge's angle is phi(first body) - phi(second body)
        hinge alpha1: M0 = R;
        hinge alpha2: F = M1;
        drive D1: hinge alpha1;
        drive D2: hinge alpha2;
        skate S1: S1 along (1, 0);
        skate S2: S2 along (1, 0);
        skate S3: S3 along (1, 0);
    }
}
