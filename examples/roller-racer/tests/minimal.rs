//! A vehicle of the user's own, declared in this crate (ezy its only
//! dependency), gets the minimal coordinates `model!` derives exactly as
//! the built-in EzyRoller does: a tow cart whose rear axle is behind its
//! centre of mass, pulling a one-axle trailer on a hitch, a motor in the
//! hitch. Its derived terms (the expansion's `B` and `c` among them) pass
//! the check a model author runs, and its scene runs through the program
//! in the reduced formulation on those coordinates, on the constraints to
//! rounding, to the DAE's final state.

use ezy::App;

ezy::model! {
    /// A cart (skate R behind its centre of mass) towing a trailer (skate
    /// T) hinged at the hitch H.
    pub struct TowCart {
        /// Centre of mass of the cart to its rear axle R [m]
        param a = 0.3;
        /// Centre of mass of the cart to the hitch H, behind it [m]
        param h = 0.8;
        /// Hitch to the trailer's centre of mass [m]
        param e = 0.6;
        /// Trailer's centre of mass to its axle T [m]
        param f = 0.2;
        /// Mass of the cart [kg]
        param m1 = 20.0;
        /// Moment of inertia of the cart [kg m^2]
        param I1 = 1.5;
        /// Mass of the trailer [kg]
        param m2 = 8.0;
        /// Moment of inertia of the trailer [kg m^2]
        param I2 = 0.6;

        /// The cart.
        body cart(x1, y1, phi1) { mass: m1, inertia: I1 }
        /// The trailer.
        body trailer(x2, y2, phi2) { mass: m2, inertia: I2 }

        point R on cart at (-a, 0);
        point H1 on cart at (-h, 0);
        point H2 on trailer at (e, 0);
        point T on trailer at (-f, 0);

        hinge H: H1 = H2;
        skate R: R along (1, 0);
        skate T: T along (1, 0);
    }
}

const SCENE: &str = r#"
name = "tow"
description = "Tow cart and trailer from a slow start, a motor in the hitch, 10 s"
model = "tow_cart"
t_end = 10.0

[initial]
q = { x1 = 0.0, y1 = 0.0, phi1 = 0.0, phi2 = 0.3 }
qd = { x1 = 0.2, y1 = 0.0 }

[integrator]
method = "dop853"
rtol = 1e-10
atol = 1e-10

[output]
every = 10.0

[effects.motor]
kind = "hinge-motor"
hinge = "H"
torque = { cos = { amplitude = 1.5, omega = 2.0 } }
"#;

#[test]
fn the_users_tree_model_has_minimal_coordinates_that_pass_the_check() {
    use ezy::Model;
    let layout = TowCart::default().minimal_layout().expect("a tree of hinges, skates off their hinges");
    // kept: the cart's x, y, phi and the trailer's phi; independent: the
    // cart's forward velocity and yaw rate (body-frame speeds); skate R
    // fixes the cart's lateral velocity (pivot 1), skate T the trailer's
    // angular rate (pivot e + f)
    assert_eq!((layout.coords, layout.speeds), (vec![0, 1, 2, 5], vec![0, 2]));
    let pivots: Vec<(String, usize, f64)> = layout.pivots.iter().map(|p| (p.0.clone(), p.1, p.2)).collect();
    assert_eq!(pivots[0], ("R".to_string(), 1, 1.0));
    assert_eq!((pivots[1].0.as_str(), pivots[1].1), ("T", 5));
    assert!((pivots[1].2.abs() - 0.8).abs() < 1e-15, "{pivots:?}");
    ezy::testing::assert_derivatives(&TowCart::default());
    // the fused right-hand side `model!` generated for it (the one the
    // reduced runs take) agrees with the expansion and Maggi's equations
    let report = ezy::testing::check_derivatives(&TowCart::default());
    let fused = report.terms.iter().find(|t| t.term == ezy::testing::MIN_FUSED).expect("the fused term is checked");
    assert!(fused.compared > 0 && fused.passed(), "{fused:?}");
    assert!(TowCart::default().minimal_constants().is_some());
}

#[test]
fn the_users_scene_runs_on_its_minimal_coordinates() {
    let app = App::new().model::<TowCart>("tow_cart").scene("tow.toml", SCENE);
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("tow-cart");
    let run = |formulation: &str| {
        let out = dir.join(formulation);
        let _ = std::fs::remove_dir_all(&out);
        let mut said = Vec::new();
        let args = ["ezy", "run", "tow", "--no-figures", "--formulation", formulation, "--out"];
        app.run_cli(args.iter().map(|s| s.to_string()).chain([out.display().to_string()]), &mut said)
            .expect("the run succeeds");
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).expect("trajectory.csv");
        let last: Vec<f64> = csv.lines().last().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
        (csv.lines().next().unwrap().to_string(), last, String::from_utf8(said).unwrap())
    };
    let (header, dae, _) = run("dae");
    let (reduced_header, reduced, said) = run("reduced");
    assert_eq!(header, reduced_header);
    assert!(said.contains("reduced formulation on the minimal coordinates model! derived"), "{said}");
    assert!(said.contains("fused right-hand side"), "{said}");
    // DOP853 at 1e-10 over 10 s: both within ~1e-9 of the exact state in
    // the mixed norm |a - b| / max(1, |b|); 1e-7 leaves room for the
    // reduced formulation's error control on fewer components
    let gap = dae.iter().zip(&reduced).map(|(a, b)| (a - b).abs() / a.abs().max(1.0)).fold(0.0, f64::max);
    assert!(gap < 1e-7, "final rows differ by {gap:e}\n{said}");
    let residual = |key: &str| -> f64 {
        said.split(key).nth(1).and_then(|s| s.split_whitespace().next()).and_then(|v| v.parse().ok()).unwrap()
    };
    assert!(residual("|C| = ") <= 1e-12 && residual("|G qd| = ") <= 1e-12, "{said}");
}
