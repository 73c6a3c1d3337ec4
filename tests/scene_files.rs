//! Scene files (issue 5): every built-in scene loads, runs one second and
//! closes its energy ledger; scene files round-trip; every documented
//! error of a bad scene file names the file, line, column and key.

use std::path::PathBuf;

use ezy::RunOptions;
use ezy_models::scenes;
use ezy_scene::{Scene, SceneEffect};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ezy-scene-files-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// 1 s for every scene: the N-four-bar scenes pass their first singular
/// configuration (every bar on the x axis, 2 (3N + 1) rows of rank
/// 5N + 2) at t = 0.714 s (N = 2) and 0.722 s (N = 40) within it.
pub fn one_second(_scene: &str) -> f64 {
    1.0
}

/// Every built-in scene runs for 1 s with its own integrator settings, and
/// `|T - T0 - sum W_e|` stays below 1e-8 J or 1e-10 of the largest kinetic
/// energy of the run, whichever is larger (its methods run at rtol 1e-10
/// or tighter, or RK4 with h = 1e-4). The 81 bodies of `four-bar-n40`
/// reach T = 1,210 J and pass a singular position within the second,
/// which amplifies the last bits: 8.3e-9 J with glibc's `sin`/`cos`,
/// 1.7e-8 J with the `libm` crate's, and 1.5e-9 to 2.0e-8 J (up to
/// 1.6e-11 of T) over eight runs with the tolerance moved by 0 to 7e-13
/// of itself; a wrong work term is off by far more. The work columns are
/// there, one per effect, and they are not all zero when the scene has
/// effects (a ledger of zeros would close trivially).
#[test]
fn every_builtin_scene_runs_one_second_and_closes_its_ledger() {
    let all = scenes::builtin();
    assert_eq!(all.len(), 24);
    for src in all {
        let info = scenes::model_info_with(&src.scene.model, &src.scene.params).unwrap().unwrap();
        // family effects (`hinge = "J[*]"`) run as one effect per element
        let s = &src.scene.expand_families(&info).unwrap();
        let opts = RunOptions {
            out: tmp_dir(&s.name),
            t_end: Some(one_second(&s.name)),
            figures: true,
            ..RunOptions::default()
        };
        let r = ezy::App::new().run_scene(s, &opts).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        let gap = r.summary.max_energy_error;
        let t_max = r.table.column(r.table.index("T").expect("a T column")).fold(0.0, f64::max);
        assert!(gap <= 1e-8f64.max(1e-10 * t_max), "{}: ledger gap {gap:e} J (T up to {t_max} J)", s.name);
        let friction = s.effects.iter().any(|(_, e)| e.kind() == "skate-friction");
        for (name, e) in &s.effects {
            let k = r.table.index(&format!("W_{name}")).unwrap_or_else(|| panic!("{}: no W_{name}", s.name));
            // a skate with friction that holds does no work (drive-slip's rear skate)
            if e.kind() == "skate-friction" {
                continue;
            }
            let last = r.table.column(k).last().unwrap();
            // 1e-12 J: far above the ledger's rounding, below the smallest
            // real one (a spring at the tail of the 30-link snake, 6e-7 J
            // after 1 s)
            assert!(last.abs() > 1e-12, "{}: W_{name} = {last}", s.name);
        }
        // trajectory.csv, the figures, and events.csv where there are events
        // or skates with friction (their switches)
        let events = usize::from(!s.events.is_empty() || friction);
        assert_eq!(r.files.len(), 1 + s.figures.len() + events, "{}: {:?}", s.name, r.files);
        assert!(r.summary.max_residual_position <= 1e-11 && r.summary.max_residual_velocity <= 1e-11, "{}", s.name);
    }
}

/// parse -> serialize -> parse gives the same scene, for every built-in
/// scene and for a scene with every effect kind and waveform.
#[test]
fn scene_files_round_trip() {
    let mut texts: Vec<(String, String)> =
        scenes::BUILTIN.iter().map(|(f, t)| (f.to_string(), t.to_string())).collect();
    texts.push(("all_effects.toml".into(), include_str!("data/all_effects.toml").into()));
    for (file, text) in texts {
        let a = Scene::from_toml(&text, &file).unwrap();
        let written = a.to_toml();
        let b = Scene::from_toml(&written, "written").unwrap_or_else(|e| panic!("{file}: {e}\n{written}"));
        assert_eq!(a, b, "{file} changes on a round trip:\n{written}");
    }
}

/// The drive scene's text with `from` replaced by `to` (which must occur once).
fn drive_with(from: &str, to: &str) -> String {
    let text = scenes::BUILTIN[0].1;
    assert_eq!(text.matches(from).count(), 1, "`{from}` must occur once in drive.toml");
    text.replace(from, to)
}

/// Loads `text` as `bad.toml` and returns the error message.
fn load_err(text: &str) -> String {
    let scene = match Scene::from_toml(text, "bad.toml") {
        Ok(s) => s,
        Err(e) => return e.to_string(),
    };
    match scenes::check(scene, text, "bad.toml") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Line (from 1) of the first occurrence of `needle` in `text`.
fn line_of(text: &str, needle: &str) -> usize {
    text[..text.find(needle).unwrap()].matches('\n').count() + 1
}

#[test]
fn every_documented_scene_file_error_names_file_line_column_and_key() {
    // (replace, with, the line's text, substrings the message must contain)
    let cases: &[(&str, &str, &str, &[&str])] = &[
        // syntax
        ("t_end = 60.0", "t_end = 60.0.0", "t_end", &["bad.toml:", "invalid"]),
        // a value of the wrong type
        ("t_end = 60.0", "t_end = \"long\"", "t_end", &["invalid type: string \"long\", expected f64"]),
        // an unknown key, with the known ones
        ("t_end = 60.0", "t_end = 60.0\nduration = 60.0", "duration", &["unknown field `duration`", "`t_end`"]),
        // a missing key
        ("hinge = \"B\"\n", "", "[effects.motor]", &["`effects.motor`", "missing field `hinge`"]),
        // an unknown effect kind lists the known kinds
        (
            "kind = \"hinge-motor\"",
            "kind = \"hinge-motr\"",
            "kind = \"hinge-motr\"",
            &["unknown effect kind `hinge-motr`", "hinge-motor", "rolling-viscous", "quadratic-drag"],
        ),
        // an unknown waveform
        (
            "torque = { cos =",
            "torque = { cosine =",
            "[effects.motor]",
            &["`effects.motor`", "unknown variant `cosine`", "harmonics", "table"],
        ),
        // an unknown model lists the known models
        (
            "model = \"ezyroller\"",
            "model = \"ezyrollr\"",
            "model",
            &["`model`", "unknown model `ezyrollr`", "chaplygin_sleigh"],
        ),
        // an unknown hinge lists the model's hinges
        (
            "hinge = \"B\"",
            "hinge = \"H\"",
            "hinge = \"H\"",
            &["`effects.motor.hinge`", "unknown hinge `H` in model EzyRoller; its hinges: B"],
        ),
        // an unknown coordinate
        (
            "phi2 = 3.141592653589793 }",
            "psi = 3.141592653589793 }",
            "q = {",
            &["`initial.q.psi`", "unknown coordinate `psi`", "x1, y1, phi1, x2, y2, phi2"],
        ),
        // a parameter name that is not one
        (
            "y1 = 0.0, phi1",
            "y1 = \"b2\", phi1",
            "q = {",
            &["`initial.q.y1`", "`b2` is neither a number nor a parameter", "m1, I1"],
        ),
        // an unknown parameter override
        (
            "t_end = 60.0",
            "t_end = 60.0\n[params]\nmass = 3.0",
            "mass",
            &["`params.mass`", "unknown parameter `mass`", "a, b, c, d, m1, I1, m2, I2"],
        ),
        // a number out of range
        (
            "dt = 1e-4",
            "dt = -1e-4",
            "dt = -1e-4",
            &["`integrator.dt`", "the step [s] must be a positive number, got -1e-4"],
        ),
        // a figure column the output does not include, with the group to add
        (
            "y = \"T\" }]",
            "y = \"T_total\" }]",
            "y = \"T_total\"",
            &["`figures[2].lines[0].y`", "no column `T_total`", "its columns would be"],
        ),
        (
            "include = [\"energy\", \"points\", \"effects\", \"residuals\"]",
            "include = [\"energy\", \"effects\", \"residuals\"]",
            "paths = [\"A\", \"C\"]",
            &["`figures[0].paths[0]`", "no column `A.x`", "add \"points\" to output.include"],
        ),
        // a function of columns that does not exist
        (
            "y = \"norm(x1d, y1d)\"",
            "y = \"hypot(x1d, y1d)\"",
            "hypot",
            &["unknown function `hypot`", "norm, diff, from_start, balance_gap"],
        ),
        // a waveform table out of order
        (
            "torque = { cos = { amplitude = \"M0\", omega = \"omega\" } }",
            "torque = { table = { t = [0.0, 2.0, 1.0], value = [0.0, 1.0, 2.0] } }",
            "torque = { table",
            &["`effects.motor.torque`", "t[2] = 1 follows t[1] = 2"],
        ),
        // an output group that does not exist
        ("\"residuals\"]", "\"residual\"]", "include", &["unknown variant `residual`", "constraint-forces"]),
        // a name in a number's place that is not a scene parameter lists the declared ones
        (
            "amplitude = \"M0\"",
            "amplitude = \"M1\"",
            "amplitude = \"M1\"",
            &[
                "`effects.motor.torque.cos.amplitude`",
                "`M1` is neither a number nor a scene parameter; declared in [scene_params]: M0, omega",
            ],
        ),
        // a scene parameter with a model parameter's name
        (
            "M0 = 2.0",
            "M0 = 2.0\nm2 = 1.5",
            "m2 = 1.5",
            &["`scene_params.m2`", "`m2` is both a scene parameter and a parameter of model EzyRoller"],
        ),
        // a scene parameter that is not a number, or not an identifier
        ("M0 = 2.0", "M0 = \"two\"", "M0 = \"two\"", &["`scene_params.M0`", "must be a number, not a string"]),
        ("M0 = 2.0", "M0 = 2.0\n\"2M\" = 1.0", "\"2M\"", &["`scene_params.2M`", "must be an identifier"]),
        ("M0 = 2.0", "M0 = inf", "M0 = inf", &["`scene_params.M0`", "M0 = inf must be finite"]),
        // a lower-panel line without the lower panel's label, a panel that
        // does not exist, a figure with no line in the upper panel
        (
            "{ label = \"phi1d [rad/s]\", y = \"phi1d\", panel = 2 }",
            "{ label = \"phi1d [rad/s]\", y = \"phi1d\", panel = 3 }",
            "panel = 3",
            &["`figures[1].lines[1].panel`", "panel is 1 (upper) or 2 (lower), got 3"],
        ),
        (
            "y2_label = \"yaw rate [rad/s]\"\n",
            "",
            "panel = 2",
            &["`figures[1].lines[1].panel`", "needs the figure's `y2_label`"],
        ),
        (
            "{ label = \"tau [N m]\", y = \"tau_motor\" }",
            "{ label = \"tau [N m]\", y = \"tau_motor\", panel = 2 }",
            "lines = [\n    { label = \"tau",
            &["`figures[3].lines`", "the upper panel (1) needs at least one line"],
        ),
        // a figure file that is not .png, .svg or .pdf; the PNG resolution out of range
        ("file = \"fig5_kinetic_energy.png\"", "file = \"fig5.jpg\"", "fig5.jpg", &["ending in .png, .svg or .pdf"]),
        (
            "every = 0.01",
            "every = 0.01\ndpi = 5000",
            "dpi = 5000",
            &["`output.dpi`", "between 24 and 600 dpi, got 5000"],
        ),
    ];
    for (from, to, at, want) in cases {
        let text = drive_with(from, to);
        let err = load_err(&text);
        for w in *want {
            assert!(err.contains(w), "replacing `{from}`: `{w}` missing from:\n{err}");
        }
        let line = line_of(&text, at);
        let prefix = format!("bad.toml:{line}:");
        assert!(err.starts_with(&prefix), "replacing `{from}`: expected {prefix} in:\n{err}");
    }
}

/// Three independent mistakes (an effect's hinge, the step, a figure's
/// column) are three errors from one check, each at its line and key, in
/// the order of the file; a scene with one mistake gets one line.
#[test]
fn three_mistakes_in_three_parts_are_three_errors() {
    let text = drive_with("hinge = \"B\"", "hinge = \"Q\"")
        .replace("dt = 1e-4", "dt = -1e-4")
        .replace("paths = [\"A\", \"C\"]", "paths = [\"A\", \"Z\"]");
    let e = load_err(&text);
    let lines: Vec<&str> = e.lines().collect();
    assert_eq!(lines.len(), 3, "{e}");
    let dt = format!("bad.toml:{}:", line_of(&text, "dt = -1e-4"));
    let hinge = format!("bad.toml:{}:", line_of(&text, "hinge = \"Q\""));
    let path = format!("bad.toml:{}:", line_of(&text, "paths = [\"A\", \"Z\"]"));
    assert!(lines[0].starts_with(&dt) && lines[0].contains("`integrator.dt`"), "{e}");
    assert!(lines[1].starts_with(&hinge) && lines[1].contains("unknown hinge `Q`"), "{e}");
    assert!(lines[2].starts_with(&path) && lines[2].contains("`Z`"), "{e}");
    assert_eq!(load_err(&drive_with("dt = 1e-4", "dt = -1e-4")).lines().count(), 1);
}

#[test]
fn effect_names_must_make_column_names() {
    let text = drive_with("[effects.motor]", "[effects.\"my motor\"]");
    let err = load_err(&text);
    assert!(err.contains("`effects.my motor`") && err.contains("letters, digits and _"), "{err}");
}

/// An unknown body in an effect and an unknown skate list the model's names.
#[test]
fn unknown_bodies_and_skates_list_the_models_names() {
    let text = format!(
        "{}\n[effects.drag]\nkind = \"linear-drag\"\nbody = \"frame\"\nc = 1.0\n",
        scenes::BUILTIN[0].1.split("[[figures]]").next().unwrap()
    );
    let err = load_err(&text);
    assert!(err.contains("unknown body `frame` in model EzyRoller; its bodies: body1, body2"), "{err}");
    let text = text.replace(
        "kind = \"linear-drag\"\nbody = \"frame\"\nc = 1.0",
        "kind = \"rolling-viscous\"\nskate = \"B\"\ndamping = 1.0",
    );
    let err = load_err(&text);
    assert!(err.contains("unknown skate `B` in model EzyRoller; its skates: A, C"), "{err}");
    assert!(err.starts_with(&format!("bad.toml:{}:", line_of(&text, "skate = \"B\""))), "{err}");
}

/// The cases a review found: colliding column names, a scene name that
/// would escape `out/`, drives that a table or a short spline cannot
/// serve, defaults and ambiguous keys in `--set`, and no bogus key on a
/// value's type error.
#[test]
fn review_cases_are_errors_with_names() {
    let prescribed = scenes::BUILTIN.iter().find(|(f, _)| *f == "drive-prescribed.toml").unwrap().1;
    // an effect whose columns collide with the drive's
    let text = format!("{prescribed}\n[effects.D]\nkind = \"hinge-damper\"\nhinge = \"B\"\ndamping = 0.5\n");
    let err = load_err(&text);
    assert!(err.contains("`effects.D`") && err.contains("makes the column `W_D`"), "{err}");
    // a scene name with a path in it
    let err = load_err(&drive_with("name = \"drive\"", "name = \"../drive\""));
    assert!(err.contains("`name`") && err.contains("letters, digits, - and _"), "{err}");
    // a drive given by a table, or by a spline that ends before the run
    let table = prescribed.replace(
        "angle = { harmonics = [{ amplitude = -3.141592653589793, omega = 0.0 }, { amplitude = 0.3, omega = 3.141592653589793, phase = -1.5707963267948966 }] }",
        "angle = { table = { t = [0.0, 40.0], value = [-3.0, -3.2] } }",
    );
    assert_ne!(table, prescribed);
    let err = load_err(&table);
    assert!(err.contains("`drives.D.angle`") && err.contains("give a `spline`"), "{err}");
    let short = table.replace("{ table = { t = [0.0, 40.0]", "{ spline = { t = [0.0, 20.0]");
    let err = load_err(&short);
    assert!(err.contains("cover [0, 20] s but the run covers [0, 30] s"), "{err}");
    // a value of the wrong type is not blamed on a made-up key
    let err = load_err(&drive_with("t_end = 60.0", "t_end = [60.0]"));
    assert!(!err.contains("`60"), "{err}");
    // --set: a key at its default, and an ambiguous key
    let mut slope = scenes::get("drive-slope");
    slope.set(&ezy_models::scenes::model_info("ezyroller").unwrap(), "gravity.g", 1.62).unwrap();
    let toml = slope.to_toml();
    assert!(toml.contains("g = 1.62"), "{toml}");
    let mut driven = scenes::get("drive-prescribed");
    let info = &ezy_models::scenes::model_info("ezyroller_driven").unwrap();
    let err = driven.set(info, "D.amplitude", 0.5).unwrap_err().to_string();
    assert!(err.contains("matches several numbers") && err.contains("angle.harmonics.1.amplitude"), "{err}");
    driven.set(info, "D.harmonics.1.amplitude", 0.5).unwrap();
}

/// The drive scene's motor reads the scene parameters `M0` and `omega`:
/// bit for bit the numbers it had when it wrote them inline; `set` of a
/// scene parameter changes every number bound to it, `set` of the number's
/// own key unbinds it, and a scene writes the names back.
#[test]
fn scene_parameters_give_numbers_that_set_changes() {
    use ezy_core::EffectSpec;
    use ezy_core::effects::{Harmonic, Waveform};

    use ezy_scene::Binding;
    let info = &scenes::model_info("ezyroller").unwrap();
    let motor = |s: &Scene| match &s.effects[0].1 {
        SceneEffect::Builtin(EffectSpec::HingeMotor(ezy_core::effects::HingeMotor {
            torque: Waveform::Cos(h),
            ..
        })) => *h,
        other => panic!("{other:?}"),
    };
    let mut drive = scenes::drive();
    assert_eq!(drive.scene_params, [("M0".to_string(), 2.0), ("omega".to_string(), std::f64::consts::PI)]);
    let bound = |leaf: &str, param: &str| Binding {
        path: ["effects", "motor", "torque", "cos", leaf].map(String::from).to_vec(),
        param: param.into(),
    };
    assert_eq!(drive.bindings, [bound("amplitude", "M0"), bound("omega", "omega")]);
    let h = motor(&drive);
    assert_eq!(h, Harmonic { amplitude: 2.0, omega: std::f64::consts::PI, phase: 0.0, phase_step: 0.0 });
    let written = drive.to_toml();
    assert!(written.contains("amplitude = \"M0\"") && written.contains("omega = \"omega\""), "{written}");

    drive.set(info, "M0", 0.1).unwrap();
    drive.set(info, "omega", 5.0).unwrap();
    assert_eq!((motor(&drive).amplitude, motor(&drive).omega), (0.1, 5.0));
    assert_eq!(drive.scene_params, [("M0".to_string(), 0.1), ("omega".to_string(), 5.0)]);
    let back = Scene::from_toml(&drive.to_toml(), "written").unwrap();
    assert_eq!(back, drive);

    // the number's own key wins and unbinds it, in either order
    drive.set(info, "motor.amplitude", 3.0).unwrap();
    drive.set(info, "M0", 0.5).unwrap();
    assert_eq!((motor(&drive).amplitude, motor(&drive).omega), (3.0, 5.0));
    assert_eq!(drive.bindings, [bound("omega", "omega")]);
    let written = drive.to_toml();
    assert!(written.contains("amplitude = 3.0") && written.contains("M0 = 0.5"), "{written}");
    assert_eq!(Scene::from_toml(&written, "written").unwrap(), drive);

    // an unknown name lists model parameters, scene parameters and keys
    let err = scenes::drive().set(info, "M1", 1.0).unwrap_err().to_string();
    for want in ["unknown parameter `M1`", "m2", "M0", "omega", "motor.torque.cos.amplitude"] {
        assert!(err.contains(want), "`{want}` missing from: {err}");
    }
    // a scene built in code with a scene parameter named like a model parameter
    let mut clash = scenes::drive();
    clash.scene_params.push(("m2".into(), 1.0));
    let err = clash.set(info, "m2", 2.0).unwrap_err().to_string();
    assert!(err.contains("`m2` is both a scene parameter and a parameter of model EzyRoller"), "{err}");
}

/// Scene parameters in a drive's waveform, in numbers that serialize only
/// when not at their default (`rest_angle = 0`, a zero `fx`), and in a
/// family effect (expanded per element; a `phase_step` is baked in).
#[test]
fn scene_parameters_in_drives_defaults_and_families() {
    use ezy_core::EffectSpec;
    use ezy_core::effects::Waveform;
    // a drive's angle
    let prescribed = scenes::BUILTIN.iter().find(|(f, _)| *f == "drive-prescribed.toml").unwrap().1;
    let from = "{ amplitude = 0.3, omega = 3.141592653589793, phase = -1.5707963267948966 }";
    assert_eq!(prescribed.matches(from).count(), 1);
    let text = prescribed
        .replace(from, "{ amplitude = \"swing\", omega = 3.141592653589793, phase = -1.5707963267948966 }")
        .replace("[drives.D]", "[scene_params]\nswing = 0.3\n\n[drives.D]");
    let mut scene = scenes::check(Scene::from_toml(&text, "swing.toml").unwrap(), &text, "swing.toml").unwrap().scene;
    assert_eq!(scene.drives, scenes::get("drive-prescribed").drives);
    let info = &scenes::model_info("ezyroller_driven").unwrap();
    scene.set(info, "swing", 0.5).unwrap();
    let Waveform::Harmonics(hs) = &scene.drives[0].1.angle else { panic!() };
    assert_eq!(hs[1].amplitude, 0.5);
    assert_eq!(Scene::from_toml(&scene.to_toml(), "written").unwrap(), scene);
    // an unknown name in a drive is placed at it
    let err = load_err(&text.replace("amplitude = \"swing\"", "amplitude = \"swung\""));
    assert!(
        err.contains("`drives.D.angle.harmonics[1].amplitude`") && err.contains("declared in [scene_params]: swing"),
        "{err}"
    );

    // numbers at their defaults
    let text = format!(
        "{}\n[scene_params]\nrest = 0.0\nF0 = 0.0\n\n[effects.spring]\nkind = \"hinge-spring\"\nhinge = \"B\"\nstiffness = 1.0\nrest_angle = \"rest\"\n\n[effects.push]\nkind = \"force\"\nat = \"body1\"\nfx = {{ constant = \"F0\" }}\n",
        scenes::BUILTIN[0].1.split("[scene_params]").next().unwrap()
    );
    let mut scene = Scene::from_toml(&text, "defaults.toml").unwrap();
    assert_eq!(scene.bindings.len(), 2);
    assert_eq!(Scene::from_toml(&scene.to_toml(), "written").unwrap(), scene, "{}", scene.to_toml());
    let info = &scenes::model_info("ezyroller").unwrap();
    scene.set(info, "rest", 0.2).unwrap();
    scene.set(info, "F0", 1.5).unwrap();
    assert!(
        matches!(scene.effects[0].1, SceneEffect::Builtin(EffectSpec::HingeSpring(ezy_core::effects::HingeSpring { rest_angle, .. })) if rest_angle == 0.2)
    );
    assert!(
        matches!(&scene.effects[1].1, SceneEffect::Builtin(EffectSpec::Force(ezy_core::effects::Force { fx: Waveform::Constant(f), .. })) if *f == 1.5)
    );

    // a family: the amplitude stays bound in every element, the phase step is baked in
    let snake = scenes::BUILTIN.iter().find(|(f, _)| *f == "snake.toml").unwrap().1;
    let from = "amplitude = 0.6, omega = 3.141592653589793, phase = 0.0, phase_step = -1.5707963267948966";
    assert_eq!(snake.matches(from).count(), 1);
    let text = snake
        .replace(from, "amplitude = \"A\", omega = 3.141592653589793, phase = 0.0, phase_step = \"delta\"")
        .replace("[effects.motor]", "[scene_params]\nA = 0.6\ndelta = -1.5707963267948966\n\n[effects.motor]");
    let mut scene = Scene::from_toml(&text, "snake.toml").unwrap();
    let info = &scenes::model_info("snake").unwrap();
    scene.set(info, "delta", -1.0).unwrap();
    let expanded = scene.expand_families(info).unwrap();
    let params: Vec<(&str, &str)> = expanded.bindings.iter().map(|b| (b.path[1].as_str(), b.param.as_str())).collect();
    assert_eq!(params, [("motor2", "A"), ("motor3", "A"), ("motor4", "A"), ("motor5", "A")]);
    let phases: Vec<f64> = expanded.effects[..4]
        .iter()
        .map(|(_, e)| match e {
            SceneEffect::Builtin(EffectSpec::HingeMotor(ezy_core::effects::HingeMotor {
                torque: Waveform::Sin(h),
                ..
            })) => h.phase,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(phases, [0.0, -1.0, -2.0, -3.0]);
    let mut expanded = expanded;
    expanded.set(info, "A", 0.9).unwrap();
    assert!(
        expanded.effects[..4]
            .iter()
            .all(|(_, e)| matches!(e, SceneEffect::Builtin(EffectSpec::HingeMotor(ezy_core::effects::HingeMotor { torque: Waveform::Sin(h), .. })) if h.amplitude == 0.9))
    );
}

/// Every string an effect kind serializes sits under one of its name keys:
/// everywhere else a string in an effect names a scene parameter.
#[test]
fn effects_hold_strings_only_at_their_name_keys() {
    use ezy_core::effects::EFFECT_KINDS;
    use ezy_scene::NAME_KEYS;
    let all = Scene::from_toml(include_str!("data/all_effects.toml"), "all_effects.toml").unwrap();
    let mut kinds: Vec<&str> = all.effects.iter().map(|(_, e)| e.kind()).collect();
    kinds.sort();
    kinds.dedup();
    let mut want = EFFECT_KINDS.to_vec();
    want.sort();
    assert_eq!(kinds, want, "all_effects.toml must have every kind");
    fn strings(v: &toml::Value, out: &mut usize) {
        match v {
            toml::Value::String(_) => *out += 1,
            toml::Value::Table(t) => t.values().for_each(|v| strings(v, out)),
            toml::Value::Array(a) => a.iter().for_each(|v| strings(v, out)),
            _ => {}
        }
    }
    for (name, e) in &all.effects {
        let toml::Value::Table(t) = toml::Value::try_from(e).unwrap() else { panic!() };
        for (k, v) in &t {
            let mut n = 0;
            strings(v, &mut n);
            assert!(n == 0 || NAME_KEYS.contains(&k.as_str()), "effect {name}: a string under `{k}`");
        }
    }
}

/// Numbers with units (issue 85, item 5): the drive scene written with a
/// parameter in grams, an angle in degrees, a torque in N m, a frequency
/// in Hz and a speed in km/h reads as the scene written in SI, number for
/// number (each suffix's conversion is exact: `"180 deg"` is pi); a unit
/// whose dimension does not fit its place is refused at its line, naming
/// both units, and so are an unknown unit and a place without a unit.
#[test]
fn numbers_with_units_read_as_si_and_a_wrong_dimension_is_refused() {
    let si = drive_with("[integrator]", "[params]\nm2 = 1.0\n\n[integrator]")
        .replace("qd = { x1 = 0.0, phi1 = 0.0 }", "qd = { x1 = 0.5, phi1 = 0.0 }")
        .replace("[scene_params]", "[scene_params]\nunused = 0.0");
    let with_units = si
        .replace("phi2 = 3.141592653589793 }", "phi2 = \"180 deg\" }")
        .replace("m2 = 1.0", "m2 = \"1000 g\"")
        .replace("qd = { x1 = 0.5,", "qd = { x1 = \"1.8 km/h\",")
        .replace("amplitude = \"M0\"", "amplitude = \"2 N m\"")
        .replace("omega = \"omega\"", "omega = \"0.5 Hz\"");
    let si =
        si.replace("amplitude = \"M0\"", "amplitude = 2.0").replace("omega = \"omega\"", "omega = 3.141592653589793");
    let read = |text: &str| {
        let scene = Scene::from_toml(text, "units.toml").unwrap_or_else(|e| panic!("{e}"));
        scenes::check(scene.clone(), text, "units.toml").unwrap_or_else(|e| panic!("{e}"));
        scene
    };
    let (a, mut b) = (read(&si), read(&with_units));
    assert_eq!(b.units.len(), 3, "m2, phi2 and x1's velocity are checked against the model");
    b.units.clear();
    assert_eq!(a, b);
    let refused = [
        ("phi2 = \"180 deg\"", "phi2 = \"3 kg\"", "`3 kg` does not fit initial `q.phi2`, which is in rad"),
        ("m2 = \"1000 g\"", "m2 = \"1 m\"", "`1 m` does not fit parameter `m2`, which is in kg"),
        ("omega = \"0.5 Hz\"", "omega = \"0.5 s\"", "`0.5 s` does not fit `torque.cos.omega`, which is in rad/s"),
        ("amplitude = \"2 N m\"", "amplitude = \"2 N\"", "`2 N` does not fit `torque.cos.amplitude`, which is in N m"),
        ("m2 = \"1000 g\"", "m2 = \"3 stone\"", "unknown unit `stone`"),
    ];
    for (from, to, words) in refused {
        let text = with_units.replace(from, to);
        let e = load_err(&text);
        let line = line_of(&text, to);
        assert!(e.contains(words) && e.contains(&format!("bad.toml:{line}:")), "{to}: {e}");
    }
}
