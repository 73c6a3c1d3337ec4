//! What the tests of models read from text share: the built-in models'
//! texts, taken from their source files, and the comparison of a model
//! read from text with the compiled one. Part of the root crate's suite
//! (`tests/text_models.rs`, the tape) and of ezy-models' JIT tests
//! (`models/tests/jit.rs`, built with the `jit` feature).

use ezy_core::text::{Evaluator, RuntimeModel};
use ezy_core::{AnyModel, Model};
use num_dual::Dual64;

/// The model read from `text`, evaluated by `evaluator` (the JIT only in a
/// build with ezy-core's `jit` feature).
pub fn read_as(text: &str, evaluator: Evaluator) -> RuntimeModel {
    RuntimeModel::from_text_with(text, evaluator).unwrap_or_else(|e| panic!("{e}"))
}

/// The text inside each `model! { ... }` of the models crate's sources.
pub fn builtin_texts() -> Vec<String> {
    // this file is part of the root crate's suite and of ezy-models' own
    // JIT tests (models/tests/jit.rs)
    let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = if manifest.ends_with("models") { manifest.join("src") } else { manifest.join("models/src") };
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
pub fn text_of(name: &str) -> String {
    let texts = builtin_texts();
    let pat = format!("struct {name} ");
    texts.into_iter().find(|t| t.contains(&pat)).unwrap_or_else(|| panic!("no model! text for {name}"))
}

/// A reproducible number in `[-1, 1)`.
pub struct Lcg(pub u64);
impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Largest `|a - b| / max(|a|, |b|, 1)` over two slices.
pub fn worst(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs() / x.abs().max(y.abs()).max(1.0)).fold(0.0, f64::max)
}

/// Every function of `Model` of `compiled` and `text` at `states` random
/// states: the largest relative difference over them.
/// The fused right-hand side's own worst difference goes to `fused`.
pub fn compare(compiled: &AnyModel, text: &RuntimeModel, states: usize, fused: &std::cell::Cell<f64>) -> f64 {
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
pub fn compare_minimal(compiled: &AnyModel, text: &RuntimeModel, q: &[f64], qd: &[f64]) -> f64 {
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
pub fn compare_fused(
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

/// Every built-in model, its `model!` text read at run time and evaluated
/// by `evaluator`, against the compiled one at 100 random states: bit for
/// bit.
pub fn every_builtin_model_read_from_text_matches_the_compiled_one(evaluator: Evaluator) {
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
    for (name, compiled) in &models {
        let text = read_as(&text_of(name), evaluator);
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

/// A point at the sum of 5,000 distinct parameters: derived at once, and
/// (the JIT) a tape too long to compile quickly left to the register
/// machine, with the same numbers: 1 + (1 + 2 + ... + 5000), exact.
pub fn long_distinct_sum_is_exact(evaluator: Evaluator) {
    let n = 5_000;
    let params: String = (0..n).map(|i| format!(" param P{i} = {};", i + 1)).collect();
    let sum = (0..n).map(|i| format!("P{i}")).collect::<Vec<_>>().join(" + ");
    let wide = format!(
        "pub struct Wide {{{params} body b(x, y, phi) {{ mass: 1.0, inertia: 0.1 }} point T on b at ({sum}, 0); }}"
    );
    let m = read_as(&wide, evaluator);
    let mut p = [0.0; 2];
    m.points(&[1.0, 0.0, 0.0], &mut p);
    // 1 + (1 + 2 + ... + n): integers, exact
    assert_eq!(p, [1.0 + (n * (n + 1) / 2) as f64, 0.0], "{evaluator:?}");
}
