//! The trailer and snake models end to end: the trailers' off-tracking
//! against its closed form, the snake's gait moving it head first, and both
//! energy ledgers.

use crate::common;

use common::build;
use ezy_core::kkt::KktMethod;
use ezy_core::{Model, Problem, RunSettings, simulate};
use ezy_models::{Snake, Trailer, scenes};

fn run_scene<M: Model + Default>(name: &str) -> (ezy_core::Dynamics<M>, ezy_core::Summary, Vec<f64>) {
    let scene = scenes::get(name);
    let (mut sys, y0) = build::<M>(&scene, &[], KktMethod::Auto).unwrap();
    let settings = RunSettings { every: scene.t_end, balance_limit: None, max_steps: None, ..scene.run_settings() };
    let s = simulate(&mut sys, &y0, &settings, &mut Last).unwrap();
    (sys, s, y0)
}

struct Last;
impl<M: Model> ezy_core::Observer<M> for Last {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _: &ezy_core::Dynamics<M>, _: &ezy_core::Sample<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// After 300 s on the circle every body turns at the same rate and each
/// axle runs on the radius of the kinematic steady state: the tractor's
/// rear axle on `L / tan(delta)`, each trailer's axle on
/// `sqrt(r_hitch^2 - l^2)` with `r_hitch = sqrt(r_axle_ahead^2 + h^2)`.
/// Radius of curvature `|v_P| / phi_dot` from the generated point
/// velocities; the transient has decayed to below 1e-6 relative.
#[test]
fn trailers_settle_on_the_off_tracking_circles() {
    let (sys, s, _) = run_scene::<Trailer>("trailer");
    let m = &sys.model;
    let y = &s.final_state;
    let (q, qd) = (&y[..9], &y[9..18]);
    let info = m.info();
    let mut v = vec![0.0; 2 * info.points.len()];
    m.point_velocities(q, qd, &mut v);
    let speed = |name: &str| {
        let p = info.point_index(name).unwrap();
        v[2 * p].hypot(v[2 * p + 1])
    };
    let r0 = m.L / m.delta.tan();
    let r1 = (r0.hypot(m.h).powi(2) - m.l * m.l).sqrt();
    let r2 = (r1.hypot(m.h).powi(2) - m.l * m.l).sqrt();
    for (point, rate, want) in [("R", qd[2], r0), ("A1", qd[5], r1), ("A2", qd[8], r2)] {
        let r = speed(point) / rate;
        assert!((r - want).abs() <= 1e-6 * want, "{point}: radius {r} want {want}");
    }
    assert!((qd[2] - qd[5]).abs() <= 1e-9 && (qd[5] - qd[8]).abs() <= 1e-9, "rates {qd:?}");
    // the engine and the resistances each move ~1e5 J; the gap is relative to that flow
    let flow = y[18..].iter().fold(0.0f64, |a, w| a.max(w.abs()));
    assert!(s.max_energy_error <= 1e-10 * flow, "ledger {:e} against {flow:e} J", s.max_energy_error);
}

/// The serpenoid gait moves the snake head first (+x) by more than half a
/// metre in 40 s, and its ledger of nine work columns closes.
#[test]
fn the_snake_advances_head_first() {
    let (sys, s, y0) = run_scene::<Snake>("snake");
    let y = &s.final_state;
    assert!(y[6] - y0[6] > 0.5, "middle link moved from x = {} to {}", y0[6], y[6]);
    assert_eq!(sys.effects.len(), 13);
    assert!(s.max_energy_error <= 1e-8, "ledger {:e}", s.max_energy_error);
    assert!(s.max_residual_position <= 1e-12);
}

/// With every hinge angle prescribed by the drive family (`snake-long`,
/// 30 links, a serpenoid wave from head to tail) and anisotropic ground
/// friction, the snake advances head first, close to its initial mean
/// heading (+x): the head's x gains more than 10 m in 20 s, within 10
/// degrees of the x axis (it settles at about 5), the prescribed angles
/// hold to the projection's tolerance, and
/// the ledger (29 drives and 30 friction columns) closes to 1e-6 of the
/// work that flows.
#[test]
fn the_driven_snake_advances_head_first() {
    let (sys, s, y0) = run_scene::<ezy_models::SnakeDriven>("snake-long");
    let y = &s.final_state;
    let (dx, dy) = (y[0] - y0[0], y[1] - y0[1]);
    assert!(
        dx > 10.0 && dy.abs() < dx * 10f64.to_radians().tan(),
        "head from ({}, {}) to ({}, {})",
        y0[0],
        y0[1],
        y[0],
        y[1]
    );
    assert_eq!((sys.drives.len(), sys.effects.len()), (29, 30));
    // prescribed angles at the end: phi(i-1) - phi(i) = 0.5 sin(pi t - (i - 2) 2 pi/10)
    let t = 20.0;
    for i in 2..=30 {
        let want = 0.5 * (std::f64::consts::PI * t - (i - 2) as f64 * std::f64::consts::PI / 5.0).sin();
        let got = y[3 * (i - 2) + 2] - y[3 * (i - 1) + 2];
        assert!((got - want).abs() <= 1e-9, "hinge {i}: {got} want {want}");
    }
    let flow = y[180..].iter().fold(0.0f64, |a, w| a.max(w.abs()));
    assert!(s.max_energy_error <= 1e-6 * flow, "ledger {:e} against {flow:e} J", s.max_energy_error);
    assert!(s.max_residual_position <= 1e-12);
}

/// The snake scene's family effects expand to one effect per element, the
/// motors' phases stepping by -pi/2 along the hinges; with `N = 20` the
/// same scene expands to 19 motors, 20 resistances, 19 springs, and the
/// `"phi*"` initial value reaches every heading.
#[test]
fn family_effects_expand_per_element() {
    use crate::common::setup;
    use ezy_core::effects::{EffectSpec, Waveform};
    let scene = scenes::get("snake");
    let s = setup::<Snake>(&scene, &[]).unwrap();
    let names: Vec<&str> = s.scene.effects.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "motor2", "motor3", "motor4", "motor5", "roll1", "roll2", "roll3", "roll4", "roll5", "spring2", "spring3",
            "spring4", "spring5"
        ]
    );
    for (k, (_, spec)) in s.scene.effects[..4].iter().enumerate() {
        let ezy_scene::SceneEffect::Builtin(EffectSpec::HingeMotor(ezy_core::effects::HingeMotor {
            hinge,
            torque: Waveform::Sin(h),
        })) = spec
        else {
            panic!("{spec:?}")
        };
        assert_eq!(hinge, &format!("J{}", k + 2));
        assert!((h.phase + k as f64 * std::f64::consts::FRAC_PI_2).abs() <= 1e-15 && h.phase_step == 0.0, "{h:?}");
    }
    let s20 = setup::<Snake>(&scene, &[("N".into(), 20.0)]).unwrap();
    assert_eq!(s20.effects.len(), 19 + 20 + 19);
    assert_eq!(s20.y0.len(), 2 * 60 + 58);
    // phi* = 0 except phi2, phi4: the later entries win
    let phi: Vec<f64> = (0..20).map(|i| s20.y0[3 * i + 2]).collect();
    assert_eq!((phi[1], phi[3]), (0.2, -0.2));
    assert!(phi.iter().enumerate().all(|(i, p)| i == 1 || i == 3 || *p == 0.0), "{phi:?}");
}

/// Family effect errors: a family the model does not have, and a
/// `phase_step` on an effect that is not over a family, name the effect.
#[test]
fn family_effect_errors_name_the_effect() {
    use crate::common::setup;
    let text = scenes::BUILTIN.iter().find(|(f, _)| *f == "snake.toml").unwrap().1;
    let bad = text.replace("hinge = \"J[*]\"\ntorque", "hinge = \"K[*]\"\ntorque");
    let err = scenes::check(ezy_scene::Scene::from_toml(&bad, "bad.toml").unwrap(), &bad, "bad.toml").unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("effects.motor.hinge") && msg.contains("no hinge family `K`") && msg.contains("J2"), "{msg}");
    let mut scene = scenes::get("drive");
    let ezy_scene::SceneEffect::Builtin(ezy_core::EffectSpec::HingeMotor(ezy_core::effects::HingeMotor {
        torque: ezy_core::effects::Waveform::Cos(h),
        ..
    })) = &mut scene.effects[0].1
    else {
        panic!("drive's motor is a cos waveform")
    };
    h.phase_step = 1.0;
    let e = setup::<ezy_models::EzyRoller>(&scene, &[]).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("phase_step") && e.contains("effects.motor"), "{e}");
}

/// A family reference that leaves the family at some count is refused at
/// run time with the element and the range (one that leaves it at the
/// declared counts is a compile error: `text_models`); counts below 1 are
/// refused.
#[test]
fn out_of_range_family_references_are_errors() {
    ezy_core::model! {
        /// A chain of `N` links whose hinge names the third link.
        pub struct Broken {
            count N = 3;
            param l = 1.0;
            for i in 0..N {
                body link[i](x, y, phi) { mass: 1.0, inertia: 0.1 }
                point B[i] on link[i] at (-l, 0);
                point F[i] on link[i] at (l, 0);
            }
            hinge J: B[2] = F[0];
        }
    }
    let mut m = Broken::default();
    assert_eq!(m.check_counts(), Ok(()));
    m.N = 2;
    let e = m.check_counts().unwrap_err();
    assert!(e.contains("hinge `J`") && e.contains("B[2] = B2") && e.contains("0..2"), "{e}");
    // a family's element names can collide with a single item's
    ezy_core::model! {
        /// A single body `x1` next to a family whose first element is also `x1`.
        pub struct Clash {
            count N = 2;
            body base(x1, y1, phi1) { mass: 1.0, inertia: 0.1 }
            for i in 1..N + 1 {
                body link[i](x, y, phi) { mass: 1.0, inertia: 0.1 }
            }
        }
    }
    let e = Clash::default().check_counts().unwrap_err();
    assert!(e.contains("two coordinates are named `x1`"), "{e}");
    let mut ok = Snake::default();
    assert!(ok.check_counts().is_ok());
    ok.N = 0;
    assert!(ok.check_counts().unwrap_err().contains("count `N` is 0"));
}

/// A direction that names the family's index may be zero at one element
/// (`along (i, 0)` at `i = 0`): `check_counts` refuses it, naming the
/// element, the direction as written and its value, where the run would
/// otherwise divide by its zero length (NaN in `G`); the same family from
/// 1 is fine. A zero slot or slider direction likewise.
#[test]
fn a_direction_zero_at_an_element_is_refused() {
    ezy_core::model! {
        /// Skates whose blades turn with the index.
        pub struct Blades {
            count N = 3;
            count K = 2;
            param l = 1.0;
            for i in 0..N {
                body link[i](x, y, phi) { mass: 1.0, inertia: 0.1 }
                point P[i] on link[i] at (l, 0);
                skate S[i]: P[i] along (i, 0);
            }
            for j in 0..K {
                body block[j](u, w, th) { mass: 1.0, inertia: 0.1 }
                point C[j] on block[j] at (0, 0);
                slot W[j]: C[j] on ground(0, 0) along (1 + j, 2 * j - 2);
            }
        }
    }
    let e = Blades::default().check_counts().unwrap_err();
    assert!(e.contains("skate `S0`") && e.contains("`along (i, 0)` = (0, 0)"), "{e}");
    let e = Blades { N: 1, K: 2, ..Default::default() }.check_counts().unwrap_err();
    assert!(e.contains("skate `S0`"), "{e}");
    ezy_core::model! {
        /// The same skates from 1.
        pub struct BladesFromOne {
            count N = 3;
            for i in 1..N + 1 {
                body link[i](x, y, phi) { mass: 1.0, inertia: 0.1 }
                point P[i] on link[i] at (0, 0);
                skate S[i]: P[i] along (i, 0);
            }
            for j in 0..2 {
                body block[j](u, w, th) { mass: 1.0, inertia: 0.1 }
                point C[j] on block[j] at (0, 0);
                slot W[j]: C[j] on ground(0, 0) along (1 - j, 2 * j - 2);
            }
        }
    }
    let e = BladesFromOne::default().check_counts().unwrap_err();
    assert!(e.contains("slot `W1`") && e.contains("= (0, 0)"), "{e}");
    ezy_core::model! {
        /// Every direction nonzero.
        pub struct Fine {
            count N = 3;
            for i in 1..N + 1 {
                body link[i](x, y, phi) { mass: 1.0, inertia: 0.1 }
                point P[i] on link[i] at (0, 0);
                skate S[i]: P[i] along (i, 0);
            }
        }
    }
    assert!(Fine { N: 50 }.check_counts().is_ok());
    // a user's family past `MAX_COORDS` coordinates is refused by its
    // counts before any element is visited (the layout alone is summed)
    assert!(Fine { N: 100_000 }.check_counts().is_ok());
    let e = Fine { N: 100_001 }.check_counts().unwrap_err();
    assert!(e.contains("N = 100001 gives 300003 generalized coordinates, more than the 300000"), "{e}");
    let e = Problem::new(Fine { N: 1_000_000_000 }).solve().unwrap_err().to_string();
    assert!(e.contains("scene key `params`: N = 1000000000 gives 3000000000 generalized coordinates"), "{e}");
    assert!(e.contains("13200 GB for this model"), "{e}");
}

/// A drive family in a scene: `[drives."D[*]"]` gives every element, its
/// phase stepping along the family; a family the model lacks, an element
/// given twice and a `phase_step` on a single drive are errors at the
/// drive.
#[test]
fn drive_families_expand_and_their_errors_name_the_drive() {
    let info = ezy_models::SnakeDriven { N: 4, ..Default::default() }.info();
    let scene = |drives: &str| {
        let text = format!(
            "name = \"s\"\ndescription = \"d\"\nmodel = \"snake_driven\"\nt_end = 1.0\n[initial]\nq = {{ x1 = 0.0, y1 = 0.0, phi1 = 0.0 }}\nqd = {{ x1 = 0.0, y1 = 0.0, phi1 = 0.0 }}\n{drives}"
        );
        ezy_scene::Scene::from_toml(&text, "s.toml").unwrap()
    };
    let s =
        scene("[drives.\"D[*]\"]\nangle = { sin = { amplitude = 0.5, omega = 2.0, phase = 0.1, phase_step = -0.3 } }")
            .expand_families(&info)
            .unwrap();
    let names: Vec<&str> = s.drives.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["D2", "D3", "D4"]);
    for (k, (_, d)) in s.drives.iter().enumerate() {
        let want = 0.5 * (2.0 * 0.7 + 0.1 - 0.3 * k as f64).sin();
        assert!((d.angle.eval(0.7) - want).abs() < 1e-15, "{k}");
    }
    s.check(&info).unwrap();
    for (drives, want) in [
        (
            "[drives.\"E[*]\"]\nangle = { constant = 0.0 }",
            "model SnakeDriven has no drive family `E`; its drives: D2, D3, D4",
        ),
        (
            "[drives.\"D[*]\"]\nangle = { constant = 0.0 }\n[drives.D3]\nangle = { constant = 0.1 }",
            "`D[*]` and `[drives.D3]` both give the angle of drive `D3`",
        ),
        (
            "[drives.D2]\nangle = { sin = { amplitude = 1.0, omega = 1.0, phase_step = 0.2 } }",
            "`phase_step` only applies to a drive family",
        ),
    ] {
        let err = scene(drives).expand_families(&info).unwrap_err();
        assert!(err.message.contains(want) && err.key().starts_with("drives."), "{drives}: {err:?}");
    }
}
