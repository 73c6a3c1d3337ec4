//! Messages that name the culprit (issue 64, item 6): a hostile number
//! given to a model parameter, an effect's key, a waveform, a scene
//! parameter or the Baumgarte rates is refused before any work with a
//! message naming the key and the value, by the command line, by a scene
//! file and by the library (`Problem::effect`, `Problem::solve`). Before,
//! each ran into a failure that named none of them ("the step size fell to
//! 0e0 s", "the KKT system has non-finite entries", "the state component
//! `x` became NaN", "the eigenvalue iteration did not converge") or ran
//! to exit 0 (a slope of 1e300 rad, a forcing of 1e20 rad/s).

use std::f64::consts::PI;
use std::path::Path;

use ezy::App;
use ezy_core::effects::{EffectSpec, MAX_MU};
use ezy_core::{Baumgarte, Model, Problem};
use ezy_models::{ChaplyginSleigh, EzyRoller};

/// Runs `args` through the library's command line; the printed text or
/// the error.
fn cli(args: &[&str]) -> Result<String, String> {
    let mut out = Vec::new();
    let argv = std::iter::once("ezy").chain(args.iter().copied());
    App::new().run_cli(argv, &mut out).map(|()| String::from_utf8_lossy(&out).into_owned()).map_err(|e| e.to_string())
}

/// `ezy run SCENE --t-end 0.05 --no-figures` with `extra`, refused with a
/// message holding every one of `want`; nothing written.
fn refused(dir: &Path, scene: &str, extra: &[&str], want: &[&str]) {
    let out = dir.join("out");
    let mut args = vec!["run", scene, "--t-end", "0.05", "--no-figures", "--out", out.to_str().unwrap()];
    args.extend(extra);
    let e = match cli(&args) {
        Err(e) => e,
        Ok(text) => panic!("{extra:?}: ran, but should be refused: {text}"),
    };
    for w in want {
        assert!(e.contains(w), "{scene} {extra:?}: `{w}` missing from: {e}");
    }
    assert!(!out.join("trajectory.csv").exists(), "{scene} {extra:?}: nothing is written");
}

/// Every `--set NAME=VALUE` of an extreme number is refused naming the key
/// and the value: model parameters (masses, lengths), friction, springs,
/// dampers, drags, loads, waveform amplitudes and frequencies, a slope's
/// inclination, gravity, a drive's waveform, scene parameters.
#[test]
fn hostile_numbers_are_refused_by_key_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: &[(&str, &str, &[&str])] = &[
        // model parameters: a mass, an inertia, lengths
        ("pendulum", "m=1e300", &["params.m", "m = 1e300", "out of range"]),
        ("sleigh", "I=1e300", &["params.I", "I = 1e300"]),
        ("sleigh", "a=1e300", &["params.a", "a = 1e300"]),
        ("drive", "b=-1e300", &["params.b", "b = -1e300"]),
        // friction
        ("sleigh-ice", "slip_P.mu=1e300", &["effects.slip_P.mu", "mu = 1e300 is not a friction coefficient", "1e9"]),
        ("sleigh-ice", "slip_P.mu=1e20", &["effects.slip_P.mu", "mu = 1e20 is not a friction coefficient"]),
        ("snake-slip", "slip.mu=1e300", &["effects.slip1.mu", "mu = 1e300"]),
        ("sleigh-ice", "slip_P.g=1e300", &["effects.slip_P.g", "g = 1e300"]),
        // springs, dampers, drags
        ("four-bar", "spring.stiffness=1e300", &["effects.spring.stiffness", "stiffness = 1e300"]),
        ("four-bar", "spring.damping=1e300", &["effects.spring.damping", "damping = 1e300"]),
        ("four-bar", "spring.rest_length=1e300", &["effects.spring.rest_length", "rest_length = 1e300"]),
        ("snake-stiff", "servo.stiffness=1e300", &["effects.servo2.stiffness", "stiffness = 1e300"]),
        ("snake", "roll.damping=1e300", &["effects.roll1.damping", "damping = 1e300"]),
        ("sleigh-drag", "drag.c=1e300", &["effects.drag.c", "c = 1e300"]),
        ("sleigh-drag", "drag.c_rot=1e300", &["effects.drag.c_rot", "c_rot = 1e300"]),
        ("snake-long", "ground.c_across=1e300", &["effects.ground1.c_across", "c_across = 1e300"]),
        ("trailer", "roll_R.damping=1e300", &["effects.roll_R.damping", "damping = 1e300"]),
        // loads and waveforms
        ("drive", "motor.amplitude=1e300", &["effects.motor.torque", "amplitude = 1e300"]),
        ("drive", "motor.omega=1e20", &["effects.motor.torque", "omega = 1e20", "rates [1/s] up to 2.8e14"]),
        ("snake", "motor.torque.sin.omega=1e300", &["effects.motor2.torque", "omega = 1e300"]),
        ("drive", "motor.phase=1e300", &["effects.motor.torque", "phase = 1e300"]),
        ("four-bar", "motor.constant=1e300", &["effects.motor.torque", "constant = 1e300"]),
        ("trailer", "engine.constant=1e300", &["effects.engine.force", "constant = 1e300"]),
        ("snakeboard", "psi.omega=1e300", &["drives.psi.angle", "omega = 1e300"]),
        ("snakeboard", "phi_f.amplitude=1e300", &["drives.phi_f.angle", "amplitude = 1e300"]),
        // gravity
        ("drive-slope", "gravity.angle=1e300", &["effects.gravity.angle", "angle = 1e300", "-pi/2 to pi/2"]),
        ("drive-slope", "gravity.angle=2", &["effects.gravity.angle", "angle = 2 is not the inclination"]),
        ("drive-slope", "gravity.g=1e300", &["effects.gravity.g", "g = 1e300"]),
        ("pendulum", "gravity.g.1=-1e300", &["effects.gravity.g", "g[1] = -1e300"]),
        // a scene parameter
        ("drive", "M0=1e300", &["scene_params.M0", "M0 = 1e300"]),
    ];
    for (scene, set, want) in cases {
        refused(d, scene, &["--set", set], want);
    }
}

/// A friction coefficient at the bound runs (a skate that never slides,
/// the use the bound keeps); one just above it is refused.
#[test]
fn the_friction_bound_keeps_friction_that_never_acts() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("o");
    let at = format!("slip_P.mu={MAX_MU:e}");
    cli(&["run", "sleigh-ice", "--t-end", "0.05", "--no-figures", "--set", &at, "--out", o.to_str().unwrap()]).unwrap();
    let above = format!("slip_P.mu={:e}", MAX_MU * 1.01);
    refused(dir.path(), "sleigh-ice", &["--set", &above], &["effects.slip_P.mu", "is not a friction coefficient"]);
}

/// Baumgarte rates beyond any step, and beyond a fixed step's stability
/// limit, are refused naming the rate and its value (before: "the state
/// component `x` became NaN", "the KKT system has non-finite entries"; and
/// 1e6 ran to exit 0 with drift of 5e-7 m per step projected away).
#[test]
fn baumgarte_rates_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let dae = ["--formulation", "dae"];
    for (rates, method, want) in [
        ("1e300,1e300", "rk4", "--baumgarte alpha = 1e300: is faster than any step can follow"),
        ("1e300,1e300", "dop853", "--baumgarte alpha = 1e300"),
        ("1,1e300", "dop853", "--baumgarte beta = 1e300"),
        ("1e5,1e5", "rk4", "--baumgarte alpha = 100000: the drift's fastest rate"),
        ("0,1e5", "euler", "--baumgarte beta = 100000"),
    ] {
        let mut extra = vec!["--baumgarte", rates, "--integrator", method];
        extra.extend(dae);
        refused(dir.path(), "drive", &extra, &[want]);
    }
    // within the limit: runs (rk4, h = 1e-4 s: max(2 alpha, beta) h = 2)
    let o = dir.path().join("o");
    let args = ["--baumgarte", "1e4,1e4", "--formulation", "dae", "--out", o.to_str().unwrap()];
    cli(&[&["run", "drive", "--t-end", "0.05", "--no-figures"][..], &args].concat()).unwrap();
}

/// A law too fast for the run, within the numbers' range, is named when
/// the step size collapses (before: "the step size fell to 5e-20 s, the
/// rounding level of t: the problem may be stiff, ..." and nothing more).
#[test]
fn a_law_too_fast_for_the_run_is_named_when_the_step_collapses() {
    let dir = tempfile::tempdir().unwrap();
    refused(
        dir.path(),
        "four-bar",
        &["--set", "spring.stiffness=1e20"],
        &["the step size fell", "the effect `spring` is faster than the run can follow", "stiffness = 1e20"],
    );
    refused(
        dir.path(),
        "sleigh-drag",
        &["--set", "drag.c=1e20"],
        &["the effect `drag` is faster than the run can follow", "c = 1e20"],
    );
    // a fixed step: named beside the advice on the step
    refused(
        dir.path(),
        "four-bar",
        &["--set", "spring.stiffness=1e14", "--integrator", "rk4"],
        &["try a smaller --dt", "the effect `spring` is faster than the run can follow", "stiffness = 1e14"],
    );
}

/// Scene files: the culprit's file, line and key, its value and why.
#[test]
fn scene_files_name_the_line_the_key_and_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let head = r#"name = "hostile"
description = "a sleigh with one hostile number"
model = "chaplygin_sleigh"
t_end = 0.05

[initial]
q = { x = 0.0, y = 0.0, phi = 0.0 }
qd = { x = 1.0, phi = 1.0 }

[integrator]
method = "dopri5"
"#;
    for (k, (table, want)) in [
        (
            "[effects.rc]\nkind = \"rolling-coulomb\"\nskate = \"P\"\nforce = 1e300\nsmoothing = 0.01\n",
            "hostile0.toml:16:9: `effects.rc.force`: force = 1e300 is out of range",
        ),
        (
            "[effects.rc]\nkind = \"rolling-coulomb\"\nskate = \"P\"\nforce = 1.0\nsmoothing = 1e300\n",
            "`effects.rc.smoothing`: smoothing = 1e300",
        ),
        ("[effects.q]\nkind = \"quadratic-drag\"\nbody = \"sleigh\"\nc = 1e300\n", "`effects.q.c`: c = 1e300"),
        (
            "[effects.f]\nkind = \"force\"\nat = \"P\"\nfx = { constant = 1e300 }\n",
            "`effects.f.fx`: constant = 1e300",
        ),
        (
            "[effects.t]\nkind = \"torque\"\nbody = \"sleigh\"\ntorque = { table = { t = [0.0, 1.0], value = [0.0, 1e300] } }\n",
            "`effects.t.torque`: value[1] = 1e300",
        ),
        (
            "[effects.s]\nkind = \"spring-damper\"\nfrom = \"P\"\nto = \"ground(1e300, 0)\"\nstiffness = 1.0\nrest_length = 0.0\n",
            "`effects.s.to`: the ground coordinate = 1e300",
        ),
        (
            "[effects.f]\nkind = \"skate-friction\"\nskate = \"P\"\nmu = 0.5\nnormal = 1e300\n",
            "`effects.f.normal`: normal = 1e300",
        ),
        // not "must be zero or positive": inf is positive
        (
            "[effects.f]\nkind = \"skate-friction\"\nskate = \"P\"\nmu = inf\nshare = 1.0\n",
            "`effects.f.mu`: mu = inf must be finite",
        ),
        ("[effects.g]\nkind = \"gravity\"\ng = [1e300, 0.0]\n", "`effects.g.g`: g[0] = 1e300"),
        ("[effects.g]\nkind = \"slope\"\nangle = 0.1\ndownhill = 1e300\n", "`effects.g.downhill`: downhill = 1e300"),
        ("[params]\nm = 1e300\n", "hostile10.toml:14:5: `params.m`: m = 1e300"),
        ("[scene_params]\nK = 1e300\n", "`scene_params.K`: K = 1e300"),
    ]
    .into_iter()
    .enumerate()
    {
        let path = dir.path().join(format!("hostile{k}.toml"));
        std::fs::write(&path, format!("{head}\n{table}")).unwrap();
        let out = dir.path().join("out");
        let e = cli(&["run", path.to_str().unwrap(), "--no-figures", "--out", out.to_str().unwrap()]).unwrap_err();
        assert!(e.contains(want), "{table}: `{want}` missing from: {e}");
        assert!(!out.exists(), "{table}: nothing is written");
    }
}

/// `ezy linearize` of a body without mass names the mass (before: "the
/// eigenvalue iteration did not converge (NoConvergence)").
#[test]
fn a_massless_body_is_named_by_the_analyses() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lin");
    let e = cli(&["linearize", "sleigh", "--set", "m=0", "--out", out.to_str().unwrap()]).unwrap_err();
    assert!(e.contains("the massless parts (m (mass of body sleigh))"), "{e}");
    assert!(!out.exists());
}

/// The library: `Problem::effect` refuses the spec naming the effect, the
/// key and the value; `Problem::solve` refuses a model parameter past the
/// range and Baumgarte rates past the step, naming them.
#[test]
fn the_library_names_the_culprit_too() {
    let friction = |mu: f64| {
        EffectSpec::SkateFriction(ezy_core::effects::SkateFriction {
            skate: "P".into(),
            mu,
            normal: None,
            share: Some(1.0),
            g: 9.8,
        })
    };
    let e = Problem::new(ChaplyginSleigh::default()).effect("slip_P", friction(1e300)).unwrap_err().to_string();
    assert!(e.starts_with("effect `slip_P`, key `mu`: mu = 1e300 is not a friction coefficient"), "{e}");
    Problem::new(ChaplyginSleigh::default()).effect("slip_P", friction(MAX_MU)).unwrap();

    let spring = EffectSpec::HingeSpring(ezy_core::effects::HingeSpring {
        hinge: "B".into(),
        stiffness: 1e300,
        rest_angle: 0.0,
    });
    let e = Problem::new(EzyRoller::default()).effect("k", spring).unwrap_err().to_string();
    assert!(e.starts_with("effect `k`, key `stiffness`: stiffness = 1e300 is out of range"), "{e}");

    let slope = EffectSpec::Slope(ezy_core::effects::Slope { angle: 1e300, downhill: 0.0, g: 9.8 });
    let e = Problem::new(EzyRoller::default()).effect("slope", slope).unwrap_err().to_string();
    assert!(e.contains("key `angle`: angle = 1e300 is not the inclination of a plane"), "{e}");

    let motor = EffectSpec::HingeMotor(ezy_core::effects::HingeMotor {
        hinge: "B".into(),
        torque: ezy_core::effects::Waveform::cos(2.0, 1e300),
    });
    let e = Problem::new(EzyRoller::default()).effect("motor", motor).unwrap_err().to_string();
    assert!(e.contains("effect `motor`, key `torque`: omega = 1e300"), "{e}");

    // a model parameter set in Rust: refused by solve, before any work
    let mut sleigh = ChaplyginSleigh::default();
    let a = sleigh.info().param_index("a").unwrap();
    sleigh.set_param(a, 1e300);
    let e = Problem::new(sleigh).qd("x", 1.0).unwrap().t_end(0.01).solve().unwrap_err().to_string();
    assert!(e.contains("params.a") && e.contains("a [m] = 1e300 is out of range"), "{e}");

    // Baumgarte rates, set on the problem
    let mut p = Problem::new(EzyRoller::default()).t_end(0.01).formulation(ezy_core::Formulation::Dae);
    for (name, value) in [("x1", 0.0), ("y1", 0.0), ("phi1", 0.0), ("phi2", PI)] {
        p = p.q(name, value).unwrap();
    }
    p = p.qd("x1", 1.0).unwrap().qd("phi1", 0.0).unwrap();
    p.baumgarte = Some(Baumgarte { alpha: 1e300, beta: 0.0 });
    let e = p.clone().solve().unwrap_err().to_string();
    // spelled `baumgarte` by a library, --baumgarte once a command line ran in the process
    assert!(e.contains("baumgarte") && e.contains(" alpha = 1e300: is faster than any step"), "{e}");
    p.baumgarte = Some(Baumgarte { alpha: f64::NAN, beta: 0.0 });
    let e = p.clone().solve().unwrap_err().to_string();
    assert!(e.contains("baumgarte") && e.contains(" alpha = NaN: must be a finite rate"), "{e}");
    p.baumgarte = Some(Baumgarte { alpha: 2.0 * PI, beta: 2.0 * PI });
    p.solve().unwrap();
}
