//! Models read from text at run time (`ezy_core::text::RuntimeModel`)
//! against the same models compiled by `model!`: every built-in model's
//! text, taken from its source file, gives the same description, the
//! same equations and the same numbers.

use ezy_core::text::{Evaluator, RuntimeModel};
use ezy_core::{AnyModel, Model};
use num_dual::Dual64;

/// The text inside each `model! { ... }` of the models crate's sources.
fn builtin_texts() -> Vec<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/src");
    let mut texts = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let src = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        let mut rest = src.as_str();
        while let Some(i) = rest.find("model! {") {
            let body = &rest[i + "model! {".len()..];
            let mut depth = 1;
            let end = body
                .char_indices()
                .find(|&(_, c)| {
                    depth += match c {
                        '{' => 1,
                        '}' => -1,
                        _ => 0,
                    };
                    depth == 0
                })
                .map(|(j, _)| j)
                .unwrap();
            texts.push(body[..end].to_string());
            rest = &body[end..];
        }
    }
    texts
}

/// The text of the built-in model `name` (its struct's name).
fn text_of(name: &str) -> String {
    let texts = builtin_texts();
    let pat = format!("struct {name} ");
    texts.into_iter().find(|t| t.contains(&pat)).unwrap_or_else(|| panic!("no model! text for {name}"))
}

/// A reproducible number in `[-1, 1)`.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Largest `|a - b| / max(|a|, |b|, 1)` over two slices.
fn worst(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs() / x.abs().max(y.abs()).max(1.0)).fold(0.0, f64::max)
}

/// Every function of `Model` of `compiled` and `text` at `states` random
/// states: the largest relative difference over them.
/// The fused right-hand side's own worst difference goes to `fused`.
fn compare(compiled: &AnyModel, text: &RuntimeModel, states: usize, fused: &std::cell::Cell<f64>) -> f64 {
    let info = compiled.info();
    assert_eq!(info, text.info(), "{}: the descriptions differ", info.name);
    assert_eq!(compiled.check_counts(), text.check_counts());
    let (ce, te) = (compiled.equations(), text.equations());
    assert_eq!(format!("{ce:?}"), format!("{te:?}"), "{}: the equations differ", info.name);
    let (nq, nc, nh, nnz, np) = (info.nq(), info.nc(), info.n_holonomic, info.pattern.len(), info.points.len());
    let nnz_h = info.n_holonomic_nonzeros();
    let mut w: f64 = 0.0;
    let two = |m: &dyn Fn(&mut [f64], &mut [f64]), n1: usize, n2: usize| {
        let (mut a, mut b) = (vec![0.0; n1], vec![0.0; n2]);
        m(&mut a, &mut b);
        [a, b].concat()
    };
    w = w.max(worst(&two(&|a, _| compiled.mass_diagonal(a), nq, 0), &two(&|a, _| text.mass_diagonal(a), nq, 0)));
    let ns = info.skates.len();
    w = w.max(worst(
        &two(&|a, b| compiled.local_geometry(a, b), 2 * np, 2 * ns),
        &two(&|a, b| text.local_geometry(a, b), 2 * np, 2 * ns),
    ));
    let mut rng = Lcg(7);
    for _ in 0..states {
        let q: Vec<f64> = (0..nq).map(|_| 3.0 * rng.next()).collect();
        let qd: Vec<f64> = (0..nq).map(|_| 3.0 * rng.next()).collect();
        type Pair<'a> = (
            &'a dyn Fn(&AnyModel, &mut [f64], &mut [f64]),
            &'a dyn Fn(&RuntimeModel, &mut [f64], &mut [f64]),
            usize,
            usize,
        );
        let cases: [Pair; 7] = [
            (&|m, a, _| m.phi(&q, a), &|m, a, _| m.phi(&q, a), nh, 0),
            (&|m, a, _| m.holonomic_jacobian(&q, a), &|m, a, _| m.holonomic_jacobian(&q, a), nnz_h, 0),
            (&|m, a, _| m.constraint_matrix(&q, a), &|m, a, _| m.constraint_matrix(&q, a), nnz, 0),
            (
                &|m, a, b| m.phi_and_constraint_matrix(&q, a, b),
                &|m, a, b| m.phi_and_constraint_matrix(&q, a, b),
                nh,
                nnz,
            ),
            (&|m, a, b| m.constraint_terms(&q, &qd, a, b), &|m, a, b| m.constraint_terms(&q, &qd, a, b), nnz, nc),
            (&|m, a, _| m.points(&q, a), &|m, a, _| m.points(&q, a), 2 * np, 0),
            (&|m, a, _| m.point_velocities(&q, &qd, a), &|m, a, _| m.point_velocities(&q, &qd, a), 2 * np, 0),
        ];
        for (c, t, n1, n2) in cases {
            w = w.max(worst(&two(&|a, b| c(compiled, a, b), n1, n2), &two(&|a, b| t(text, a, b), n1, n2)));
        }
        // over dual numbers: the derivative along a random direction
        let dir: Vec<f64> = (0..nq).map(|_| rng.next()).collect();
        let qx: Vec<Dual64> = q.iter().zip(&dir).map(|(&x, &d)| Dual64::new(x, d)).collect();
        let qdx: Vec<Dual64> = qd.iter().map(|&x| Dual64::new(x, 0.0)).collect();
        let zero = Dual64::new(0.0, 0.0);
        let (mut cv, mut cg, mut tv, mut tg) = (vec![zero; nnz], vec![zero; nc], vec![zero; nnz], vec![zero; nc]);
        compiled.constraint_terms(&qx, &qdx, &mut cv, &mut cg);
        text.constraint_terms(&qx, &qdx, &mut tv, &mut tg);
        let parts = |v: &[Dual64]| -> Vec<f64> { v.iter().flat_map(|d| [d.re, d.eps]).collect() };
        w = w.max(worst(&[parts(&cv), parts(&cg)].concat(), &[parts(&tv), parts(&tg)].concat()));
        w = w.max(compare_minimal(compiled, text, &q, &qd));
        // the fused right-hand side, every other body's force and hinge's
        // torque zero, to take both branches of each
        let f: Vec<f64> = (0..nq).map(|j| if (j / 3) % 2 == 0 { 2.0 * rng.next() } else { 0.0 }).collect();
        let tau: Vec<f64> = (0..info.hinges.len()).map(|h| if h % 2 == 0 { rng.next() } else { 0.0 }).collect();
        if let Some(wf) = compare_fused(compiled, text, &q, &qd, &f, &tau) {
            fused.set(fused.get().max(wf));
        }
    }
    w
}

/// A model's `minimal_expand` (or `minimal_state`) on `(q, qd, b, c)`.
type Expand<'a> = dyn Fn(&mut [f64], &mut [f64], &mut [f64], &mut [f64]) + 'a;

/// The minimal coordinates' expansion and state of both models from the
/// kept coordinates of `q` and the speeds `qd` (the first nu entries).
fn compare_minimal(compiled: &AnyModel, text: &RuntimeModel, q: &[f64], qd: &[f64]) -> f64 {
    let layout = compiled.minimal_layout();
    assert_eq!(layout, text.minimal_layout(), "{}: the minimal layouts differ", text.info().name);
    let Ok(layout) = layout else { return 0.0 };
    let (nq, nu) = (q.len(), layout.speeds.len());
    let run = |m: &Expand| {
        let (mut q, mut qd) = (q.to_vec(), qd.to_vec());
        let (mut b, mut c) = (vec![0.0; nq * nu], vec![0.0; nq + 2 * (nq / 3)]);
        m(&mut q, &mut qd, &mut b, &mut c);
        [q, qd, b, c].concat()
    };
    let mut w = worst(
        &run(&|q, qd, b, c| compiled.minimal_expand(q, qd, b, c)),
        &run(&|q, qd, b, c| text.minimal_expand(q, qd, b, c)),
    );
    w = w.max(worst(
        &run(&|q, qd, _, _| assert!(compiled.minimal_state(q, qd))),
        &run(&|q, qd, _, _| assert!(text.minimal_state(q, qd))),
    ));
    w
}

/// A model's `minimal_rhs` on `(k, q, qd, dz)`.
type Rhs<'a> = dyn Fn(&[f64], &mut [f64], &mut [f64], &mut [f64]) + 'a;

/// The fused right-hand side on the minimal coordinates of both models at
/// the kept coordinates of `q` and the speeds `qd[..nu]`, with the applied
/// force `f` and the hinges' torques `tau` (what `forces` gives): the
/// largest relative difference of what each writes (`q`, `qd`, `dz`).
/// `None` for a model without minimal coordinates.
fn compare_fused(
    compiled: &AnyModel,
    text: &RuntimeModel,
    q: &[f64],
    qd: &[f64],
    f: &[f64],
    tau: &[f64],
) -> Option<f64> {
    let layout = compiled.minimal_layout().ok()?;
    let (np, nu) = (layout.coords.len(), layout.speeds.len());
    let z: Vec<f64> = layout.coords.iter().map(|&j| q[j]).chain(qd[..nu].iter().copied()).collect();
    let run = |k: Vec<f64>, rhs: &Rhs| {
        let (mut q, mut qd, mut dz) = (vec![0.0; q.len()], vec![0.0; q.len()], vec![0.0; np + nu]);
        rhs(&k, &mut q, &mut qd, &mut dz);
        [q, qd, dz].concat()
    };
    let forces = |_: &[f64], _: &[f64], fo: &mut [f64], to: &mut [f64]| {
        fo.copy_from_slice(f);
        to.copy_from_slice(tau);
        Ok::<(), ()>(())
    };
    let a = run(compiled.minimal_constants()?, &|k, q, qd, dz| compiled.minimal_rhs(k, &z, q, qd, dz, forces).unwrap());
    let b = run(text.minimal_constants()?, &|k, q, qd, dz| text.minimal_rhs(k, &z, q, qd, dz, forces).unwrap());
    // an integrator's stage: `dz`, and of `q`, `qd` the headings (what a
    // hinge torque reads; the rest is the callee's to leave)
    let lean = |v: Vec<f64>| -> Vec<f64> {
        let n = q.len();
        v.iter().enumerate().filter(|(i, _)| *i >= 2 * n || (i % n) % 3 == 2).map(|(_, x)| *x).collect()
    };
    let la = run(compiled.minimal_constants()?, &|k, q, qd, dz| {
        compiled.minimal_rhs_lean(k, &z, q, qd, dz, forces).unwrap()
    });
    let lb = run(text.minimal_constants()?, &|k, q, qd, dz| text.minimal_rhs_lean(k, &z, q, qd, dz, forces).unwrap());
    Some(worst(&a, &b).max(worst(&lean(la), &lean(lb))))
}

/// Both evaluators: the tape, and the JIT, which a default build has on
/// every host CI runs on (x86-64, aarch64): a model read from text takes
/// it by default.
fn evaluators(text: &str) -> Vec<(Evaluator, RuntimeModel)> {
    let m = RuntimeModel::from_text(text).unwrap_or_else(|e| panic!("{e}"));
    if cfg!(any(target_arch = "x86_64", target_arch = "aarch64")) {
        assert_eq!(m.evaluator(), Evaluator::Jit, "a default build on this host has the JIT");
    }
    let mut all = vec![(Evaluator::Tape, m.clone().with_evaluator(Evaluator::Tape).unwrap())];
    if m.evaluator() == Evaluator::Jit {
        all.push((Evaluator::Jit, m));
    }
    all
}

/// Every built-in model, its `model!` text read at run time, against the
/// compiled one at 100 random states, with each evaluator.
#[test]
fn every_builtin_model_read_from_text_matches_the_compiled_one() {
    let models: Vec<(&str, AnyModel)> = vec![
        ("EzyRoller", AnyModel::new(ezy_models::EzyRoller::default())),
        ("EzyRollerDriven", AnyModel::new(ezy_models::EzyRollerDriven::default())),
        ("ChaplyginSleigh", AnyModel::new(ezy_models::ChaplyginSleigh::default())),
        ("Trailer", AnyModel::new(ezy_models::Trailer::default())),
        ("Snake", AnyModel::new(ezy_models::Snake::default())),
        ("SnakeDriven", AnyModel::new(ezy_models::SnakeDriven::default())),
        ("SnakeServo", AnyModel::new(ezy_models::SnakeServo::default())),
        ("Snakeboard", AnyModel::new(ezy_models::Snakeboard::default())),
        ("FourBar", AnyModel::new(ezy_models::FourBar::default())),
        ("ElasticFourBar", AnyModel::new(ezy_models::ElasticFourBar::default())),
        ("SliderCrank", AnyModel::new(ezy_models::SliderCrank::default())),
        ("DoublePendulum", AnyModel::new(ezy_models::DoublePendulum::default())),
        ("Pendulum", AnyModel::new(ezy_models::Pendulum::default())),
        ("NFourBar", AnyModel::new(ezy_models::NFourBar::default())),
    ];
    let (mut report, mut worst_fused) = (Vec::new(), 0.0f64);
    for ((name, compiled), (evaluator, text)) in
        models.iter().flat_map(|m| evaluators(&text_of(m.0)).into_iter().map(move |e| (m, e)))
    {
        let fused = std::cell::Cell::new(0.0);
        let mut w = compare(compiled, &text, 100, &fused);
        report.push(format!("{name} ({evaluator:?}): {w:.1e}, fused minimal right-hand side {:.1e}", fused.get()));
        worst_fused = worst_fused.max(fused.get());
        // a model with families at other counts too: 7, and a 40-link one
        let counts: Vec<usize> =
            (0..compiled.info().params.len()).filter(|&i| compiled.info().params[i].count).collect();
        for n in [7.0, 40.0] {
            let (mut compiled, mut text) = (compiled.clone(), text.clone());
            for &i in &counts {
                compiled.set_param(i, n);
                text.set_param(i, n);
            }
            if !counts.is_empty() {
                let wn = compare(&compiled, &text, 10, &std::cell::Cell::new(0.0));
                report.push(format!("{name} ({evaluator:?}) at counts {n}: {wn:.1e}"));
                w = w.max(wn);
            }
        }
        // the same expressions evaluated in the same order: bit for bit
        assert!(w == 0.0, "{}", report.join("\n"));
    }
    eprintln!("{}", report.join("\n"));
    // the same expressions, the same parameter-only ones hoisted, the
    // forces added in the same order: bit for bit too
    assert!(worst_fused == 0.0, "{}", report.join("\n"));
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
/// the compiled ones, with DOP853 at 1e-12 (the first second of each), with
/// each evaluator, on the DAE and the default formulation: the same final
/// state, bit for bit (the same numbers from every model function, product
/// with `G` and fused right-hand side, so the same steps).
#[test]
fn every_builtin_scene_runs_on_the_models_read_from_text() {
    for evaluator in
        evaluators("pub struct E { body a(x, y, phi) { mass: 1.0, inertia: 1.0 } }").into_iter().map(|e| e.0)
    {
        scenes_agree(evaluator);
    }
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
    // terms anew each time: hours for this one) or a tape too long to
    // compile quickly (left to the register machine, the same numbers)
    let n = 5_000;
    let params: String = (0..n).map(|i| format!(" param P{i} = {};", i + 1)).collect();
    let sum = (0..n).map(|i| format!("P{i}")).collect::<Vec<_>>().join(" + ");
    let wide = format!(
        "pub struct Wide {{{params} body b(x, y, phi) {{ mass: 1.0, inertia: 0.1 }} point T on b at ({sum}, 0); }}"
    );
    for (evaluator, m) in evaluators(&wide) {
        let mut p = [0.0; 2];
        m.points(&[1.0, 0.0, 0.0], &mut p);
        // 1 + (1 + 2 + ... + n): integers, exact
        assert_eq!(p, [1.0 + (n * (n + 1) / 2) as f64, 0.0], "{evaluator:?}");
    }
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

/// The JIT at states no run should reach (zeros, 1e300, infinities, NaN,
/// subnormals) gives the tape's numbers bit for bit (a NaN where the tape
/// gives one), and slices too short for a model panic on both evaluators
/// as a compiled model's do, never read past their end.
#[test]
fn the_jit_gives_the_tapes_numbers_at_hostile_states_and_checks_bounds() {
    for name in ["EzyRoller", "NFourBar"] {
        let all = evaluators(&text_of(name));
        let Some((_, jit)) = all.iter().find(|e| e.0 == Evaluator::Jit) else { return };
        let tape = &all[0].1;
        let info = tape.info();
        let (nq, nnz, nc, np) = (info.nq(), info.pattern.len(), info.nc(), info.points.len());
        for v in [0.0, -0.0, 1e300, -1e300, f64::INFINITY, f64::NAN, 5e-324] {
            let q: Vec<f64> = (0..nq).map(|j| if j % 2 == 0 { v } else { 0.3 }).collect();
            let eval = |m: &RuntimeModel| {
                let (mut vals, mut gamma, mut p) = (vec![0.0; nnz], vec![0.0; nc], vec![0.0; 2 * np]);
                m.constraint_terms(&q, &q, &mut vals, &mut gamma);
                m.points(&q, &mut p);
                [vals, gamma, p]
                    .concat()
                    .iter()
                    .map(|x| if x.is_nan() { u64::MAX } else { x.to_bits() })
                    .collect::<Vec<_>>()
            };
            assert_eq!(eval(tape), eval(jit), "{name} at {v}");
        }
        for m in [tape, jit] {
            let short = std::panic::catch_unwind(|| {
                let mut phi = vec![0.0; info.n_holonomic];
                m.phi(&vec![0.0; nq - 1], &mut phi);
            });
            assert!(short.is_err(), "{name}: a short q was read");
            let short = std::panic::catch_unwind(|| {
                let (mut vals, mut gamma) = (vec![0.0; nnz - 1], vec![0.0; nc]);
                m.constraint_terms(&vec![0.0; nq], &vec![0.0; nq], &mut vals, &mut gamma);
            });
            assert!(short.is_err(), "{name}: a short output was written");
        }
    }
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

/// A chain of `n` bodies (mass `m`), the first on a skate where `skate`,
/// each joined to the next by a hinge where `hinged` (else free):
/// `3 n - 2 (n - 1) - 1` speeds hinged and skated, `3 n` free.
fn chain(n: usize, hinged: bool, skate: bool) -> String {
    let mut t = String::from("pub struct Chain {\n param m = 2.0;\n param L = 0.5;\n");
    for i in 0..n {
        t += &format!(" body b{i}(x{i}, y{i}, phi{i}) {{ mass: m, inertia: 0.3 * m }}\n");
        t += &format!(" point F{i} on b{i} at (L, 0);\n point R{i} on b{i} at (-L, 0);\n");
    }
    if hinged {
        for i in 1..n {
            t += &format!(" hinge H{i}: F{} = R{i};\n", i - 1);
        }
    }
    if skate {
        t += " skate S: R0 along (1, 0);\n";
    }
    t + "}\n"
}

/// `minimal_rhs` and `minimal_rhs_lean` of `m` at `z` with the forces
/// `forces` adds: the bits of what each writes (`q`, `qd`, `dz`; a NaN as
/// one pattern), or the error's words.
fn fused_bits<F>(m: &RuntimeModel, z: &[f64], forces: F) -> Vec<Result<Vec<u64>, String>>
where
    F: Fn(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), String> + Copy,
{
    let (nq, k) = (m.info().nq(), m.minimal_constants().unwrap());
    [false, true]
        .into_iter()
        .map(|lean| {
            let (mut q, mut qd, mut dz) = (vec![0.5; nq], vec![-0.25; nq], vec![0.0; z.len()]);
            let r = if lean {
                m.minimal_rhs_lean(&k, z, &mut q, &mut qd, &mut dz, forces)
            } else {
                m.minimal_rhs(&k, z, &mut q, &mut qd, &mut dz, forces)
            };
            r.map(|()| [q, qd, dz].concat().iter().map(|x| if x.is_nan() { u64::MAX } else { x.to_bits() }).collect())
                .map_err(|e| format!("{e:?}"))
        })
        .collect()
}

/// The right-hand side on the minimal coordinates compiled whole (two
/// Cranelift functions around the forces' call) for every built-in model
/// that has minimal coordinates and for users' chains of 1 to 3 bodies
/// (1 to 6 speeds: the 2 x 2 and 4 x 4 block inverses and the unrolled
/// `L D L^T`), not for 9 speeds (the tapes then);
/// bit for bit the tapes' numbers (which are the compiled models':
/// `every_builtin_model_read_from_text_matches_the_compiled_one`) at
/// random and hostile states, with bodies pushed, turned and hinges
/// torqued, or not; the same errors where the forces fail, where the mass
/// matrix is singular (zero masses) or not finite; a panic in the forces
/// reaches the caller and leaves the model as it was.
#[test]
fn the_whole_right_hand_side_compiled_gives_the_tapes_bits_and_errors() {
    let mut texts: Vec<(String, String)> = builtin_texts()
        .into_iter()
        .map(|t| (t.split("struct ").nth(1).unwrap().split_whitespace().next().unwrap().to_owned(), t))
        .collect();
    for (n, hinged, skate) in
        [(1, false, false), (2, true, false), (2, true, true), (3, true, false), (2, false, false), (3, false, false)]
    {
        texts.push((format!("chain of {n} (hinged {hinged}, skate {skate})"), chain(n, hinged, skate)));
    }
    let mut speeds_seen = std::collections::BTreeSet::new();
    let mut rng = Lcg(7);
    for (name, text) in &texts {
        let all = evaluators(text);
        let (Some((_, jit)), tape) = (all.iter().find(|e| e.0 == Evaluator::Jit), &all[0].1) else { continue };
        let Ok(layout) = tape.minimal_layout() else { continue };
        let (np, nu, nq, nh) = (layout.coords.len(), layout.speeds.len(), tape.info().nq(), tape.info().hinges.len());
        assert_eq!(jit.compiled_minimal_rhs(), nu <= 8, "{name}: {nu} speeds");
        assert!(!tape.compiled_minimal_rhs(), "{name}");
        if jit.compiled_minimal_rhs() {
            speeds_seen.insert(nu);
        }
        let mut states: Vec<Vec<f64>> = (0..20).map(|_| (0..np + nu).map(|_| 3.0 * rng.next()).collect()).collect();
        for v in [0.0, -0.0, 1e300, f64::INFINITY, f64::NAN, 5e-324] {
            states.push((0..np + nu).map(|i| if i % 2 == 0 { v } else { 0.3 }).collect());
        }
        let (f, tau): (Vec<f64>, Vec<f64>) =
            ((0..nq).map(|_| rng.next()).collect(), (0..nh).map(|_| rng.next()).collect());
        for z in &states {
            // pushed, turned and torqued; then with no force at all; then
            // a force on body 0's heading only
            let push = |_: &[f64], _: &[f64], fo: &mut [f64], to: &mut [f64]| {
                fo.copy_from_slice(&f);
                to.copy_from_slice(&tau);
                Ok(())
            };
            let calm = |_: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]| Ok(());
            let turn = |_: &[f64], _: &[f64], fo: &mut [f64], _: &mut [f64]| {
                fo[2] = -0.0;
                fo[5 % fo.len()] = 1.5;
                Ok(())
            };
            let fail = |_: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]| Err("a law said no".to_owned());
            assert_eq!(fused_bits(tape, z, push), fused_bits(jit, z, push), "{name} at {z:?}, pushed");
            assert_eq!(fused_bits(tape, z, calm), fused_bits(jit, z, calm), "{name} at {z:?}, no force");
            assert_eq!(fused_bits(tape, z, turn), fused_bits(jit, z, turn), "{name} at {z:?}, turned");
            let failed = fused_bits(jit, z, fail);
            assert_eq!(failed, fused_bits(tape, z, fail), "{name}");
            assert!(
                failed.iter().all(|r| r.as_ref().is_err_and(|e| e.contains("a law said no"))),
                "{name}: {failed:?}"
            );
        }
        // a panic in a law reaches the caller; the model goes on
        let z = &states[0];
        let before = fused_bits(jit, z, |_: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]| Ok::<(), String>(()));
        let panicked = std::panic::catch_unwind(|| {
            fused_bits(jit, z, |_: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]| -> Result<(), String> {
                panic!("a law's bug")
            })
        });
        assert!(panicked.is_err(), "{name}");
        let after = fused_bits(jit, z, |_: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]| Ok::<(), String>(()));
        assert_eq!(before, after, "{name}");
        // a singular or not finite mass matrix: the solve's own errors
        if name.starts_with("chain") {
            for mass in [0.0, f64::NAN, 1e300] {
                let (mut t, mut j) = (tape.clone(), jit.clone());
                t.set_param(0, mass);
                j.set_param(0, mass);
                let calm = |_: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]| Ok::<(), String>(());
                let (bt, bj) = (fused_bits(&t, z, calm), fused_bits(&j, z, calm));
                assert_eq!(bt, bj, "{name}, mass {mass}");
                if mass != 1e300 {
                    assert!(bj.iter().all(Result::is_err), "{name}, mass {mass}: {bj:?}");
                }
            }
        }
    }
    // every solve the kernel unrolls
    for nu in 1..=6 {
        assert!(speeds_seen.contains(&nu), "no model with {nu} speeds was compiled: {speeds_seen:?}");
    }
}
