//! The snakeboard of Lewis, Ostrowski, Burdick and Murray ("Nonholonomic
//! mechanics and locomotion: the snakeboard example", ICRA 1994): a board,
//! two wheel platforms hinged to it at distance `r` in front of and behind
//! its centre, each carrying an axle that cannot slip sideways (a skate at
//! the hinge), and a rotor hinged at the board's centre. Three drives
//! prescribe the steering angles of the platforms relative to the board,
//! `phi_f = theta_f - theta` and `phi_b = theta_b - theta`, and the rotor's
//! angle relative to the board, `psi = theta_r - theta` (the scene's gait).
//!
//! The default inertias satisfy the paper's simplifying assumption
//! `J + 2 m_w r^2 + J_r + 2 J_w = (m + m_r + 2 m_w) r^2` (total inertia
//! about the board's centre equals total mass times `r^2`), so that with
//! `phi_b = -phi_f` the momentum equation takes the paper's simple form;
//! `tests/snakeboard.rs` also checks other values with the general one.

ezy_core::model! {
    /// Snakeboard: board, front and back wheel platforms (skates at the hinges), rotor at the centre.
    pub struct Snakeboard {
        /// Distance from the board's centre to each platform hinge [m]
        param r = 0.3;
        /// Mass of the board [kg]
        param m = 4.0;
        /// Moment of inertia of the board about its centre [kg m^2]
        param J = 0.23;
        /// Mass of each wheel platform [kg]
        param m_w = 0.5;
        /// Moment of inertia of each wheel platform about its hinge [kg m^2]
        param J_w = 0.01;
        /// Mass of the rotor [kg]
        param m_r = 1.0;
        /// Moment of inertia of the rotor about the board's centre [kg m^2]
        param J_r = 0.2;

        /// The board; heading theta.
        body board(x, y, theta) { mass: m, inertia: J }
        /// Front wheel platform, centred on its hinge; heading theta_f.
        body front(xf, yf, theta_f) { mass: m_w, inertia: J_w }
        /// Back wheel platform, centred on its hinge; heading theta_b.
        body back(xb, yb, theta_b) { mass: m_w, inertia: J_w }
        /// Rotor, centred on the board's centre; heading theta_r.
        body rotor(xr, yr, theta_r) { mass: m_r, inertia: J_r }

        point F on front at (0, 0);
        point B on back at (0, 0);
        point R on rotor at (0, 0);
        point Fb on board at (r, 0);
        point Bb on board at (-r, 0);
        point O on board at (0, 0);

        hinge Hf: F = Fb;
        hinge Hb: B = Bb;
        hinge Hr: R = O;
        drive phi_f: hinge Hf;
        drive phi_b: hinge Hb;
        drive psi: hinge Hr;
        skate F: F along (1, 0);
        skate B: B along (1, 0);
    }
}
