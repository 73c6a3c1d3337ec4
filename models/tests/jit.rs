//! Models read from text compiled by the JIT (ezy-core's `jit` feature;
//! `cargo test --release -p ezy-models --features jit --test jit`): every
//! number bit for bit the tape's, which are the compiled models' (the
//! root crate's `tests/text_models.rs`), at random and hostile states.

#[path = "../../tests/support/text_models.rs"]
mod text_support;

use ezy_core::Model;
use ezy_core::text::{Evaluator, RuntimeModel};
use text_support::*;

/// A build with the JIT takes it for a model read from text, on every
/// host CI runs on (x86-64, aarch64).
#[test]
fn a_model_read_from_text_takes_the_jit() {
    let m = RuntimeModel::from_text(&text_of("EzyRoller")).unwrap();
    if cfg!(any(target_arch = "x86_64", target_arch = "aarch64")) {
        assert_eq!(m.evaluator(), Evaluator::Jit);
    }
}

/// Every built-in model's text, compiled by the JIT, gives the compiled
/// model's numbers bit for bit.
#[test]
fn every_builtin_model_read_from_text_matches_the_compiled_one() {
    text_support::every_builtin_model_read_from_text_matches_the_compiled_one(Evaluator::Jit);
}

/// A tape too long to compile quickly is left to the register machine:
/// the same numbers.
#[test]
fn a_long_sum_is_exact_on_the_jit() {
    long_distinct_sum_is_exact(Evaluator::Jit);
}

/// The JIT at states no run should reach (zeros, 1e300, infinities, NaN,
/// subnormals) gives the tape's numbers bit for bit (a NaN where the tape
/// gives one), and slices too short for a model panic on both evaluators
/// as a compiled model's do, never read past their end.
#[test]
fn the_jit_gives_the_tapes_numbers_at_hostile_states_and_checks_bounds() {
    for name in ["EzyRoller", "NFourBar"] {
        let (tape, jit) = (&read_as(&text_of(name), Evaluator::Tape), &read_as(&text_of(name), Evaluator::Jit));
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
        let (tape, jit) = (&read_as(text, Evaluator::Tape), &read_as(text, Evaluator::Jit));
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
