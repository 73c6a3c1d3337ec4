//! The Roller Racer, a ride-on toy propelled by swinging its handlebar:
//! a main platform with a rear axle and a front platform with its own axle,
//! joined by a vertical hinge ahead of the front axle. With no pedals and
//! no motor at the wheels, the rider swings the handlebar, and the wheels,
//! which cannot slip sideways, turn the swinging into forward motion.
//!
//! The model follows Krishnaprasad & Tsakiris, "Oscillations, SE(2)-snakes
//! and motion control: a study of the Roller Racer", Dynamical Systems
//! 16(4):347-397, 2001, §2: each platform's centre of mass sits on its
//! axle, the hinge is `d1` ahead of the rear axle and `d2` ahead of the
//! front axle; each axle is a skate (knife edge) at the axle's midpoint.
//! As there, the rider's input is the steering angle `phi1 - phi2`, a
//! drive (a prescribed function of time that each scene gives); the
//! torque it takes is the drive's multiplier, `tau_steer` in the output.

// ANCHOR: app
ezy::model! {
    /// The Roller Racer: main platform with the rear axle (skate A) and a
    /// front platform with its axle (skate C), joined by the hinge J whose
    /// angle the rider prescribes (drive `steer`).
    pub struct RollerRacer {
        /// Distance from the rear axle (body 1's centre of mass) forward to the hinge [m]
        param d1 = 0.6;
        /// Distance from the front axle (body 2's centre of mass) forward to the hinge [m]
        param d2 = 0.25;
        /// Mass of the main platform with its rider [kg]
        param m1 = 30.0;
        /// Moment of inertia of the main platform about its centre of mass [kg m^2]
        param I1 = 2.5;
        /// Mass of the front platform [kg]
        param m2 = 3.0;
        /// Moment of inertia of the front platform about its centre of mass [kg m^2]
        param I2 = 0.1;

        /// Main platform and rider.
        body main(x1, y1, phi1) { mass: m1, inertia: I1 }
        /// Front platform with the handlebar.
        body front(x2, y2, phi2) { mass: m2, inertia: I2 }

        point A on main at (0, 0);
        point J1 on main at (d1, 0);
        point J2 on front at (d2, 0);
        point C on front at (0, 0);

        hinge J: J1 = J2;
        drive steer: hinge J;
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}

/// The key scene files name the model by (`model = "roller_racer"`).
pub const MODEL: &str = "roller_racer";

/// The scene `run` takes by default (`name = "roller"` in
/// `scenes/roller.toml`); the tests run it by this name.
pub const SCENE: &str = "roller";

/// The application: ezy's built-in vehicles and scenes, the Roller Racer
/// under the key [`MODEL`], and its scene [`SCENE`] (the default of
/// `run`), embedded so the program runs from any directory.
pub fn app() -> ezy::App {
    ezy::App::new()
        .model::<RollerRacer>(MODEL)
        .scene("scenes/roller.toml", include_str!("../scenes/roller.toml"))
        .default_scene(SCENE)
}
// ANCHOR_END: app
