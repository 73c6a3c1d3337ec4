//! Models read from text at run time (`ezy_core::text::RuntimeModel`)
//! against the same models compiled by `model!`: every built-in model's
//! text, taken from its source file, gives the same description, the
//! same equations and the same numbers. Here on the tape evaluator; the
//! JIT's (ezy-core's `jit` feature) are ezy-models' `tests/jit.rs`.

use crate::text_support::*;
use ezy_core::Model;
use ezy_core::text::{Evaluator, RuntimeModel};

/// Every built-in model's text, on the tape, gives the compiled model's
/// numbers bit for bit.
#[test]
fn every_builtin_model_read_from_text_matches_the_compiled_one() {
    crate::text_support::every_builtin_model_read_from_text_matches_the_compiled_one(Evaluator::Tape);
}

/// A build without the JIT (the default: it is ezy's `jit` feature) says
/// so by name when a model is asked to take it, and reads text on the tape.
#[test]
fn a_build_without_the_jit_refuses_it_by_name() {
    let text = "pub struct E { body a(x, y, phi) { mass: 1.0, inertia: 1.0 } }";
    if cfg!(feature = "jit") {
        return;
    }
    let e = RuntimeModel::from_text_with(text, Evaluator::Jit).unwrap_err().to_string();
    assert!(e.contains("--features jit"), "{e}");
    assert_eq!(RuntimeModel::from_text(text).unwrap().evaluator(), Evaluator::Tape);
}

/// A model with a mistake in each of its parts: every one reported in one
/// reading, each at its line and column, in `model!`'s words.
#[test]
fn every_mistake_in_a_text_is_located() {
    let text = "
        pub struct Broken {
            count N = 3;
            param L = 1.0;
            body a(x, y, phi) { mass: 1.0, inertia: 0.1 }
            point P on wheel at (L, 0);
            point Q on a at (0, 0);
            point R on a at (L, 0);
            hinge H: Q = R;
            skate S: Q along (0, 0);
            for i in 1..N + 1 {
                body link[i](xl, yl, pl) { mass: 1.0, inertia: 0.1 }
                point E[i] on link[i] at (L, 0);
            }
            for i in 2..N + 1 {
                hinge K[i]: E[i] = E[i + 5];
            }
        }";
    let e = RuntimeModel::from_text(text).expect_err("five mistakes");
    let ezy_core::text::ModelTextError::Mistakes { mistakes, .. } = &e else { panic!("{e}") };
    let shown = e.to_string();
    eprintln!("{shown}");
    // where each is: the line and the token the column points at
    let at = |m: &ezy_core::text::TextMistake| {
        let line = text.lines().nth(m.line - 1).unwrap();
        line.chars().skip(m.column - 1).take_while(|c| c.is_alphanumeric() || *c == '(').collect::<String>()
    };
    let mut found: Vec<(usize, String)> = mistakes.iter().map(|m| (m.line, at(m))).collect();
    found.sort();
    // the unknown body, the hinge's second point on the first's body, the
    // skate's zero blade, the family index past the family's end (the
    // first token of each)
    let want = [(6, "wheel"), (9, "R"), (10, "(0"), (16, "i")];
    assert_eq!(found, want.map(|(l, t)| (l, t.to_string())), "{shown}");
    for words in ["unknown body `wheel`", "same body `a`", "zero blade direction", "`E[i + 5]` = E7 at i = 2"] {
        assert!(shown.contains(words), "{words}: {shown}");
    }
}

/// Every built-in scene run on the built-in models read from text, against
/// the compiled ones, with DOP853 at 1e-12 (the first second of each), on
/// the tape, on the DAE and the default formulation: the same final
/// state, bit for bit (the same numbers from every model function, product
/// with `G` and fused right-hand side, so the same steps).
#[test]
fn every_builtin_scene_runs_on_the_models_read_from_text() {
    scenes_agree(Evaluator::Tape);
}

fn scenes_agree(evaluator: Evaluator) {
    let compiled = ezy::App::new();
    let catalog = ezy_models::builtins();
    use ezy_scene::registry::ModelCatalog;
    let mut text = ezy::App::empty().default_scene("drive");
    for key in catalog.keys() {
        let name = catalog.info_with(key, &[]).unwrap().unwrap().name;
        let m = RuntimeModel::from_text(&text_of(name)).unwrap().with_evaluator(evaluator).unwrap();
        text = text.model_value(key, m);
    }
    for (file, src) in ezy_models::scenes::BUILTIN {
        text = text.scene(file, src);
    }
    let mut report = vec![format!("{evaluator:?}:")];
    let (mut worst, mut worst_auto): (f64, f64) = (0.0, 0.0);
    for src in compiled.scenes().unwrap() {
        for formulation in [ezy_core::Formulation::Dae, ezy_core::Formulation::Auto] {
            let mut scene = src.scene.clone();
            scene.integrator.method = ezy_core::Method::Dop853;
            (scene.integrator.rtol, scene.integrator.atol) = (1e-12, 1e-12);
            scene.integrator.formulation = formulation;
            scene.t_end = scene.t_end.min(1.0);
            let opts = ezy::RunOptions { figures: false, ..Default::default() };
            let a = compiled.run_scene_in_memory(&scene, &opts, None);
            let b = text.run_scene_in_memory(&scene, &opts, None);
            match (a, b) {
                (Ok(a), Ok(b)) => {
                    let (fa, fb) = (&a.summary.final_state, &b.summary.final_state);
                    let w = fa.iter().zip(fb).map(|(x, y)| (x - y).abs() / x.abs().max(1.0)).fold(0.0, f64::max);
                    let slot = if formulation == ezy_core::Formulation::Dae { &mut worst } else { &mut worst_auto };
                    *slot = slot.max(w);
                    report.push(format!("{} ({formulation:?}): {w:.1e}", scene.name));
                }
                (Err(a), Err(b)) => {
                    assert_eq!(a.to_string(), b.to_string());
                    report.push(format!("{}: both refuse: {a}", scene.name));
                }
                (a, b) => panic!("{}: compiled {:?}, text {:?}", scene.name, a.err(), b.err()),
            }
        }
    }
    eprintln!("{}", report.join("\n"));
    // on the minimal coordinates too: the fused right-hand side gives the
    // compiled one's numbers
    assert!(worst == 0.0 && worst_auto == 0.0, "{}", report.join("\n"));
}

/// Runs `args` (without the program name) through the library.
fn cli(app: &ezy::App, args: &[&str]) -> Result<String, ezy::app::AppError> {
    let mut out = Vec::new();
    app.run_cli(std::iter::once("ezy").chain(args.iter().copied()), &mut out)?;
    Ok(String::from_utf8(out).expect("utf-8"))
}

/// The command line takes a model file wherever it takes a model, and a
/// scene names one relative to itself; a mistake is reported at
/// `file:line:column` before any work, and nothing is written.
#[test]
fn the_command_line_reads_model_files() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("vehicles");
    std::fs::create_dir(&sub).unwrap();
    let model = sub.join("roller.ezy");
    std::fs::write(&model, text_of("EzyRoller")).unwrap();
    let app = ezy::App::new();
    let run = |args: &[&str]| cli(&app, args);
    let m = model.to_str().unwrap();
    let out = run(&["check", m]).unwrap();
    assert!(out.contains("EzyRoller") && out.contains("ok"), "{out}");
    let eq = run(&["equations", m]).unwrap();
    let compiled = run(&["equations", "ezyroller"]).unwrap();
    assert_eq!(eq, compiled);
    // a scene beside the vehicles folder names the file relative to itself
    let scene =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/scenes/drive.toml"))
            .unwrap()
            .replace("model = \"ezyroller\"", "model = \"vehicles/roller.ezy\"")
            .replace("t_end = 60.0", "t_end = 1.0");
    let scene_path = dir.path().join("roller.toml");
    std::fs::write(&scene_path, &scene).unwrap();
    let out_dir = dir.path().join("out");
    let args = ["run", scene_path.to_str().unwrap(), "--out", out_dir.to_str().unwrap(), "--no-figures"];
    run(&args).unwrap();
    assert!(out_dir.join("trajectory.csv").is_file());
    // a mistake: the file, line and column, and nothing written
    std::fs::write(&model, text_of("EzyRoller").replace("point C on body2", "point C on body3")).unwrap();
    let out_bad = dir.path().join("out-bad");
    let fresh = ezy::App::new();
    let err = cli(&fresh, &["run", scene_path.to_str().unwrap(), "--out", out_bad.to_str().unwrap()])
        .unwrap_err()
        .to_string();
    assert!(err.contains("roller.ezy:") && err.contains("unknown body `body3`"), "{err}");
    assert!(!out_bad.exists(), "a refused run wrote {}", out_bad.display());
    let err = cli(&fresh, &["check", m]).unwrap_err().to_string();
    let line = text_of("EzyRoller").lines().position(|l| l.contains("point C on")).unwrap() + 1;
    assert!(err.contains(&format!("roller.ezy:{line}:")), "line {line}: {err}");
}

/// Hostile texts are refused before any work of their size: brackets
/// nested past the parser's depth, declared counts past what ezy sets up,
/// a text past the size limit; each located, none a crash.
#[test]
fn hostile_texts_are_refused_at_their_place() {
    let deep = format!(
        "pub struct Deep {{\n param L = {}1.0{};\n body b(x, y, phi) {{ mass: 1.0, inertia: 0.1 }}\n}}",
        "(".repeat(100_000),
        ")".repeat(100_000)
    );
    let e = RuntimeModel::from_text(&deep).unwrap_err().to_string();
    // the struct's brace is the first of the 65, the 64th `(` the last
    assert!(e.starts_with("line 2, column 75: brackets nested more than 64 deep"), "{e}");
    let big = text_of("Snake").replace("count N = 5;", "count N = 1000000000;");
    let e = RuntimeModel::from_text(&big).unwrap_err().to_string();
    assert!(e.contains("N = 1000000000 gives 3000000000 generalized coordinates"), "{e}");
    let line = big.lines().position(|l| l.contains("count N")).unwrap() + 1;
    assert!(e.starts_with(&format!("line {line}, column ")), "{e}");
    let huge = " ".repeat(ezy_core::text::MAX_TEXT_BYTES as usize + 1);
    let e = RuntimeModel::from_text(&huge).unwrap_err().to_string();
    assert!(e.contains("a model has at most 1048576"), "{e}");
    // a long flat sum is no mistake: derived (its like terms collected)
    let long = format!(
        "pub struct Long {{ param L = 1.0; body b(x, y, phi) {{ mass: 1.0{}, inertia: 0.1 }} }}",
        " + L".repeat(20_000)
    );
    let m = RuntimeModel::from_text(&long).unwrap();
    let mut mass = [0.0; 3];
    m.mass_diagonal(&mut mass);
    assert_eq!(mass[0], 20_001.0);
    // nor is a long sum of distinct terms (one sum per `+` collected its
    // terms anew each time: hours for this one)
    long_distinct_sum_is_exact(Evaluator::Tape);
}

/// A user's own vehicle as text (the Roller Racer of the example crate,
/// its steering a drive, plus a slot the built-ins do not combine with
/// skates): `ezy::testing`'s derivative checks pass on it, and the
/// library runs it as a compiled model, without files.
#[test]
fn a_users_text_model_passes_the_derivative_checks_and_runs() {
    let text = "
        /// A cart whose sliding seat rides in a slot along it.
        pub struct SeatCart {
            /// Distance from the axle forward to the slot's start [m]
            param s = 0.3;
            param m1 = 20.0;
            param I1 = 1.5;
            param m2 = 5.0;
            param I2 = 0.2;
            body cart(x1, y1, phi1) { mass: m1, inertia: I1 }
            body seat(x2, y2, phi2) { mass: m2, inertia: I2 }
            point A on cart at (0, 0);
            point S1 on cart at (s, 0);
            point S2 on seat at (0, 0);
            slot T: S2 on S1 along (1, 0);
            skate A: A along (1, 0);
        }";
    let m = RuntimeModel::from_text(text).unwrap();
    ezy::testing::assert_derivatives(&m);
    let solution = ezy_core::Problem::new(m)
        .q("x1", 0.0)
        .unwrap()
        .q("y1", 0.0)
        .unwrap()
        .q("phi1", 0.0)
        .unwrap()
        .q("x2", 0.5)
        .unwrap()
        .q("phi2", 0.3)
        .unwrap()
        .qd("x1", 1.0)
        .unwrap()
        .qd("phi2", 2.0)
        .unwrap()
        .qd("phi1", 0.5)
        .unwrap()
        .qd("x2", 1.2)
        .unwrap()
        .t_end(2.0)
        .method(ezy_core::Method::Dop853)
        .tolerances(1e-10, 1e-10)
        .solve()
        .unwrap();
    // no force: the kinetic energy 1/2 qd^T M qd stays what it was
    let mass = [20.0, 20.0, 1.5, 5.0, 5.0, 0.2];
    let names = ["x1d", "y1d", "phi1d", "x2d", "y2d", "phi2d"];
    let energy = |k: usize| -> f64 {
        names.iter().zip(mass).map(|(n, m)| 0.5 * m * solution.column(n).unwrap()[k].powi(2)).sum()
    };
    let last = solution.column("x1d").unwrap().len() - 1;
    let (t0, t1) = (energy(0), energy(last));
    assert!(t0 > 1.0 && (t1 - t0).abs() < 1e-8 * t0, "T from {t0} to {t1}");
}

/// The offsets a compiled model's numeric functions walk (its generated
/// `__ezy_layout`) are those of its description, which `info`,
/// `check_counts` and `equations` render (`ezy_core::model::layout`),
/// for every built-in model at its declared counts and at 1, 2, 7 and 40.
#[test]
fn every_builtin_models_generated_layout_is_its_descriptions() {
    macro_rules! check {
        ($($model:ty),* $(,)?) => {$({
            let mut m = <$model>::default();
            let info = m.info();
            let counts: Vec<usize> = (0..info.params.len()).filter(|&i| info.params[i].count).collect();
            let mut at: Vec<Option<f64>> = vec![None];
            if !counts.is_empty() {
                at.extend([1.0, 2.0, 7.0, 40.0].map(Some));
            }
            for n in at {
                for &i in &counts {
                    if let Some(n) = n {
                        m.set_param(i, n);
                    }
                }
                let values: Vec<i64> = counts.iter().map(|&i| m.param(i) as i64).collect();
                ezy_core::__private::describe::layout_agrees(<$model>::__ezy_description(), &values, &m.__ezy_layout())
                    .unwrap_or_else(|e| panic!("{}: {e}", stringify!($model)));
            }
        })*};
    }
    use ezy_models::*;
    check!(
        EzyRoller,
        EzyRollerDriven,
        ChaplyginSleigh,
        Trailer,
        Snake,
        SnakeDriven,
        SnakeServo,
        KinematicSnake,
        Snakeboard,
        FourBar,
        ElasticFourBar,
        SliderCrank,
        DoublePendulum,
        Pendulum,
        NFourBar,
    );
}

/// A sleigh carrying a rotor (the `inertia` of each a parameter defined by
/// an expression) whose spin is prescribed as `psi(t) = 6 t + 0.5 sin(3
/// t)`, a ramp plus a sine. `variant` 0: as described; 1: the inertias
/// written as the numbers their expressions give and the ramp as a
/// two-knot spline continued linearly past its knots.
fn rotor_sleigh(dir: &std::path::Path, variant: usize) -> std::path::PathBuf {
    let (inertias, ramp) = match variant {
        0 => ("param I1 = m1 * (L * L + W * W) / 12; param I2 = m2 * r * r / 2;", "{ linear = { rate = 6.0 } }"),
        _ => (
            "param I1 = 0.4533333333333333; param I2 = 0.0225;",
            "{ spline = { t = [0.0, 1.0], value = [0.0, 6.0], extrapolate = \"linear\" } }",
        ),
    };
    let model = format!(
        "/// A sleigh with a spinning rotor at its centre.
        pub struct RotorSleigh {{
            param m1 = 4.0; param L = 1.0; param W = 0.6;
            param m2 = 0.5; param r = 0.3; param e = 0.25;
            {inertias}
            body cart(x1, y1, phi1) {{ mass: m1, inertia: I1 }}
            body rotor(x2, y2, phi2) {{ mass: m2, inertia: I2 }}
            point P on cart at (e, 0);
            point R on rotor at (0, 0);
            point A on cart at (-L / 2, 0);
            hinge H: P = R;
            drive D: hinge H;
            skate A: A along (1, 0);
        }}"
    );
    let stem = format!("rotor-sleigh-{variant}");
    std::fs::write(dir.join(format!("{stem}.ezy")), model).unwrap();
    let scene = format!(
        "name = \"{stem}\"
        description = \"a sleigh with a rotor spun at a ramp plus a sine\"
        model = \"{stem}.ezy\"
        t_end = 4.0
        [initial]
        q = {{ x1 = 0.0, y1 = 0.0, phi1 = 0.0 }}
        qd = {{ x1 = 0.0, phi1 = 0.0 }}
        [integrator]
        method = \"dop853\"
        rtol = 1e-12
        atol = 1e-12
        [output]
        every = 0.5
        [drives.D]
        angle = {{ sum = [{ramp}, {{ sin = {{ amplitude = 0.5, omega = 3.0 }} }}] }}
        "
    );
    let path = dir.join(format!("{stem}.toml"));
    std::fs::write(&path, scene).unwrap();
    path
}

/// `trajectory.csv` of a run, by column.
fn trajectory(dir: &std::path::Path) -> std::collections::HashMap<String, Vec<f64>> {
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let names: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols = vec![Vec::new(); names.len()];
    for l in lines {
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.push(v.parse::<f64>().unwrap());
        }
    }
    names.into_iter().zip(cols).collect()
}

/// A parameter defined by an expression of others and a drive that ramps
/// (a sum of a `linear` term and a sine) run as the same model written
/// with the numbers and the ramp as a spline continued linearly: the same
/// states to 1e-12 (the inertias' expressions and the spline's line
/// differ from the literals by rounding only). The prescribed angle is
/// the closed form `6 t + 0.5 sin(3 t)` at every output time, its rate
/// `6 + 1.5 cos(3 t)`; setting a defined parameter is refused with its
/// definition.
#[test]
fn an_expression_parameter_and_a_ramp_drive_agree_with_literals_and_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let app = ezy::App::new();
    let runs: Vec<_> = (0..2)
        .map(|variant| {
            let scene = rotor_sleigh(dir.path(), variant);
            let out = dir.path().join(format!("out{variant}"));
            cli(&app, &["run", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-figures"]).unwrap();
            trajectory(&out)
        })
        .collect();
    let (a, b) = (&runs[0], &runs[1]);
    assert_eq!(a["t"].len(), 9);
    for name in ["x1", "y1", "phi1", "x2", "phi2", "x1d", "y1d", "phi1d", "phi2d"] {
        for (k, (u, v)) in a[name].iter().zip(&b[name]).enumerate() {
            assert!((u - v).abs() <= 1e-12 * (1.0 + u.abs()), "{name} at row {k}: {u} vs {v}");
        }
    }
    // the cart moves: the rotor's reaction at the offset hinge drives it
    assert!(a["x1"].iter().chain(&a["y1"]).any(|v| v.abs() > 1e-3), "{:?}", a["x1"]);
    for (k, &t) in a["t"].iter().enumerate() {
        let psi = 6.0 * t + 0.5 * (3.0 * t).sin();
        let rate = 6.0 + 1.5 * (3.0 * t).cos();
        // the drive's row is phi1 - phi2 = psi, held by the projection to
        // the integrator's tolerance
        assert!((a["phi1"][k] - a["phi2"][k] - psi).abs() < 1e-9, "angle at t = {t}");
        assert!((a["phi1d"][k] - a["phi2d"][k] - rate).abs() < 1e-9, "rate at t = {t}");
    }
    let scene = rotor_sleigh(dir.path(), 0);
    let e = cli(
        &app,
        &["run", scene.to_str().unwrap(), "--set", "I2=0.1", "--out", dir.path().join("o").to_str().unwrap()],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("parameter `I2`") && e.contains("defined as `m2 * r * r / 2`"), "{e}");
}
