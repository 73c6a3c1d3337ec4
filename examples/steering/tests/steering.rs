//! The steering controller, a force law of the user's own, used exactly
//! like a built-in effect: from the scene file and from Rust (a closure)
//! with the same result, closing the energy ledger, under RADAU5, through
//! `--set`, with its mistakes placed in the file.

use ezy::Scene;
use ezy::effects::{EffectKind, ForceLaw};
use ezy::ezy_core::Method;
use ezy::models::EzyRoller;
use steering::{Steering, app, steer_in_rust};

/// The `steer` scene as the application loads it (bound to its kinds).
fn scene() -> Scene {
    app().load_scene("steer").expect("the scene loads").scene
}

/// The scene file and the Rust closure give the same final state.
///
/// Same law, same settings: the torque `-k (theta - theta_ref) - c
/// theta_dot` is the same expression in both, added to the same entries
/// of `f`. Only the power differs by rounding: the closure's is `f . qd`
/// over its coordinates, the law's `tau theta_dot`. The work state is in
/// DOP853's error norm, so that rounding moves the step sizes by about
/// one ulp and the runs part by rounding amplified over ~200 steps:
/// measured 3e-13 relative in q and qd at 1e-10, checked at 1e-11 (a
/// different force would differ by the tolerance or more, 1e-11 of a 10 m
/// run being 1e-10 m).
#[test]
fn the_scene_and_the_closure_give_the_same_final_state() {
    let from_file = scene().problem::<EzyRoller>(&[]).unwrap().0.solve().unwrap();
    let from_rust = steer_in_rust(20.0, 0.5).unwrap().solve().unwrap();
    assert_eq!(from_file.names, from_rust.names);
    assert_eq!(from_file.t.len(), 1001, "samples every 0.01 s to 10 s");
    for (k, (a, b)) in from_file.final_state().iter().zip(from_rust.final_state()).enumerate() {
        assert!((a - b).abs() <= 1e-11 * b.abs().max(1.0), "{}: {a} vs {b}", from_file.names[k]);
    }
    // the controller does drive it forward (9.4 m in 10 s)
    let x1 = from_file.column("x1").unwrap();
    assert!(*x1.last().unwrap() > 5.0, "x1 = {:?}", x1.last());
}

/// The ledger closes with the law's power: `T - T0 = W_steer` to 1e-9 J.
///
/// The work state integrates `tau theta_dot` with the motion at DOP853's
/// 1e-11, so the gap is the integration error of a 48 J balance over
/// 10 s: measured 1.4e-10 J (1.0e-9 J at 1e-10); 1e-9 J leaves room, and
/// a law whose returned power missed a term (`-c theta_dot^2`, some 0.1 W
/// here) would miss by tenths of a joule.
#[test]
fn the_energy_ledger_closes_with_the_laws_power() {
    let s = scene().problem::<EzyRoller>(&[]).unwrap().0.solve().unwrap();
    let (t0, t1) = (s.kinetic_energy[0], *s.kinetic_energy.last().unwrap());
    let w = *s.column("W_steer").unwrap().last().unwrap();
    assert!(w.abs() > 0.1, "the controller does work: W = {w} J");
    assert!((t1 - t0 - w).abs() < 1e-9, "T - T0 = {} J, W = {w} J", t1 - t0);
    assert!(s.summary.max_energy_error < 1e-9, "{}", s.summary.max_energy_error);
}

/// RADAU5 runs the law (its coupling from `coords()`) and lands on
/// DOP853's final state to its tolerance: both at 1e-8 relative, 2 s.
/// The difference is the sum of the two methods' global errors, about
/// 1e-7 for this smooth run; 1e-5 leaves room and fails on a wrong
/// coupling (Newton would not converge) or a wrong force.
#[test]
fn radau5_runs_the_users_law() {
    let run = |m: Method| {
        let mut p = scene().problem::<EzyRoller>(&[]).unwrap().0.t_end(2.0).method(m);
        p = p.tolerances(1e-8, 1e-8);
        p.solve().unwrap()
    };
    let (radau, dop) = (run(Method::Radau5), run(Method::Dop853));
    assert!(radau.summary.newton.newton_iterations > 0, "RADAU5 iterated");
    for (k, (a, b)) in radau.final_state().iter().zip(dop.final_state()).enumerate() {
        assert!((a - b).abs() < 1e-5 * b.abs().max(1.0), "{}: {a} vs {b}", radau.names[k]);
    }
}

/// `--set steer.k=...` reaches the law's number, and a scene parameter
/// bound to it (`k = "K"`) does too: both change the motion alike.
#[test]
fn set_changes_the_laws_numbers() {
    let with = |name: &str| {
        let (p, scene) = scene().problem::<EzyRoller>(&[(name.into(), 5.0)]).unwrap();
        (p.t_end(1.0).solve().unwrap().final_state().to_vec(), scene)
    };
    let (by_key, scene_k) = with("steer.k");
    let (by_param, _) = with("K");
    let base = scene().problem::<EzyRoller>(&[]).unwrap().0.t_end(1.0).solve().unwrap();
    assert_eq!(by_key, by_param, "steer.k = 5 and K = 5 are the same run");
    assert_ne!(by_key, base.final_state(), "k = 5 is another run than k = 20");
    let toml = scene_k.to_toml();
    assert!(toml.contains("kind = \"steering\"") && toml.contains("k = 5.0"), "{toml}");
}

/// The law's `coords()`, power and finiteness pass the checks RADAU5 and
/// the ledger rely on (`ezy::testing::check_force_law`), and the check
/// fails a law that hides a coupling.
#[test]
fn the_law_passes_the_force_law_check() {
    let law = Steering { hinge: "B".into(), k: 20.0, c: 0.5, offset: -3.0, amplitude: 0.5, omega: 3.0 };
    let model = EzyRoller::default();
    let info = ezy::Model::info(&model);
    let names = ezy::ezy_core::NameIndex::new(&info);
    let cx = ezy::effects::EffectContext::new(&model, &names);
    let resolved = law.resolve(&cx).unwrap();
    ezy::testing::check_force_law(&resolved, info.nq(), 50, 1).unwrap();

    /// The same law claiming only the first body's heading.
    #[derive(Debug)]
    struct Hidden(steering::SteeringLaw);
    impl ForceLaw for Hidden {
        fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
            self.0.apply(t, q, qd, f)
        }
        fn coords(&self) -> Vec<usize> {
            vec![self.0.hinge.a]
        }
    }
    let err = ezy::testing::check_force_law(&Hidden(resolved), info.nq(), 5, 1).unwrap_err();
    assert!(err.contains("not among coords()"), "{err}");
}

/// A mistake in the law's fields is an error at its line and key before
/// any work: a negative gain (the law's own check), an unknown hinge (the
/// model's names listed), a missing field (serde's message, at the
/// effect), a kind nobody registered (the known kinds listed).
#[test]
fn a_mistake_in_the_laws_fields_is_placed_in_the_file() {
    let text = include_str!("../scenes/steer.toml");
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("steering-mistakes");
    std::fs::create_dir_all(&dir).unwrap();
    let load = |from: &str, to: &str| {
        assert!(text.contains(from), "{from}");
        let path = dir.join("steer.toml");
        std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
        app().load_scene(path.to_str().unwrap()).map(|_| ()).unwrap_err().to_string()
    };
    let line_of = |s: &str| text.lines().position(|l| l.starts_with(s)).unwrap() + 1;
    let e = load("c = 0.5 ", "c = -0.5 ");
    assert!(e.contains(&format!(":{}:", line_of("c = "))) && e.contains("effects.steer.c"), "{e}");
    assert!(e.contains("c = -0.5 must be zero or positive"), "{e}");
    let e = load("hinge = \"B\"", "hinge = \"Q\"");
    assert!(e.contains(&format!(":{}:", line_of("hinge = "))) && e.contains("effects.steer.hinge"), "{e}");
    assert!(e.contains("unknown hinge `Q`") && e.contains("B"), "{e}");
    let e = load("amplitude = 0.5", "");
    assert!(e.contains("missing field `amplitude`") && e.contains("effects.steer"), "{e}");
    let e = load("kind = \"steering\"", "kind = \"steer-ing\"");
    assert!(e.contains(&format!(":{}:", line_of("kind = "))), "{e}");
    assert!(e.contains("unknown effect kind `steer-ing`") && e.contains("steering"), "{e}");
}

/// The program writes the law's columns, `W_steer` and `tau_steer`, and
/// the figures, like any effect's.
#[test]
fn the_program_writes_the_laws_columns() {
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("steering-run");
    let _ = std::fs::remove_dir_all(&out);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_steering"))
        .args(["run", "--t-end", "1", "--out"])
        .arg(&out)
        .output()
        .expect("the program runs");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).expect("trajectory.csv");
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert!(header.contains(&"W_steer") && header.contains(&"tau_steer"), "{header:?}");
    for fig in ["paths.png", "steering.png"] {
        assert!(std::fs::metadata(out.join(fig)).map(|m| m.len() > 1000).unwrap_or(false), "{fig}");
    }
}
