//! Texts that once crashed or hung the reader: each refused, located,
//! quickly.

use super::RuntimeModel;
use crate::model::Model;

/// A point whose first coordinate is `expr`.
fn point_at(expr: &str) -> String {
    format!("pub struct Deep {{\n body b(x, y, phi) {{ mass: 1.0, inertia: 0.1 }}\n point P on b at ({expr}, 0);\n}}")
}

/// 350,000 unary minus signs (700 kB, under the size limit) overflowed
/// the derivation's 1 GiB stack and aborted the process: refused at the
/// 65th, by line and column, written together or apart; `!` and `*`
/// chains too.
#[test]
fn prefix_chains_are_refused_at_their_place() {
    // `point P on b at (` is 18 characters of line 3
    for (op, n, column) in [("-", 350_000, 18 + 65), ("- ", 300_000, 18 + 2 * 64 + 1), ("! ", 300_000, 18 + 129)] {
        let text = point_at(&format!("{}1", op.repeat(n)));
        assert!(text.len() < super::MAX_TEXT_BYTES as usize);
        let e = RuntimeModel::from_text(&text).unwrap_err().to_string();
        let want = format!("line 3, column {column}: `{}` opens more than 64 operators at once", op.trim());
        assert!(e.starts_with(&want), "{e}");
    }
    // 64 are only unusual: `- - ... - 1` is -1 or 1
    let m = RuntimeModel::from_text(&point_at(&format!("{}1", "- ".repeat(63)))).unwrap();
    let mut p = [0.0; 2];
    m.points(&[1.0, 0.0, 0.0], &mut p);
    assert_eq!(p, [0.0, 0.0], "63 signs: -1, at x = 1 the point is at 0");
}

/// Long chains of left-associative operators are no mistake: syn reads
/// them in a loop and the derivation as one sum or product.
#[test]
fn long_binary_chains_are_read() {
    let m = RuntimeModel::from_text(&point_at(&format!("2{}", " / 1 * 1".repeat(50_000)))).unwrap();
    let mut p = [0.0; 2];
    m.points(&[1.0, 0.0, 0.0], &mut p);
    assert_eq!(p, [3.0, 0.0]);
}

/// A product of 25 or 50 sums in a point hinged to the ground took 53 s
/// and 271 MB to derive (25 factors), or never ended (50): multiplied
/// out into 2^n products. Read now in well under a second each, and
/// exactly right.
#[test]
fn products_of_sums_are_read_quickly_and_exactly() {
    for n in [25, 50] {
        let product: Vec<String> = (1..=n).map(|k| format!("(a + {k})")).collect();
        let text = format!(
            "pub struct Product {{\n param a = 0.5;\n body b(x, y, phi) {{ mass: 1.0, inertia: 0.1 }}\n \
             point P on b at ({}, 0);\n hinge H: P = ground(0, 0);\n}}",
            product.join(" * ")
        );
        let start = std::time::Instant::now();
        let m = RuntimeModel::from_text_with(&text, super::Evaluator::Tape).unwrap();
        let took = start.elapsed();
        assert!(took.as_secs_f64() < 10.0, "{n} factors: {took:?}");
        let px: f64 = (1..=n).map(|k| 0.5 + k as f64).product();
        let mut p = [0.0; 2];
        m.points(&[1.0, 2.0, 0.3], &mut p);
        let want = [1.0 + px * 0.3f64.cos(), 2.0 + px * 0.3f64.sin()];
        for (got, want) in p.iter().zip(want) {
            assert!((got - want).abs() <= 1e-12 * want.abs(), "{n} factors: {got} vs {want}");
        }
    }
}

/// A model path that is a FIFO hung the reader (waiting for a writer),
/// and a link to `/dev/zero` read until memory ran out: both refused
/// before a byte is read, by name and kind; a file past the size limit
/// too, with at most one byte more read.
#[cfg(unix)]
#[test]
fn model_paths_that_are_not_regular_files_are_refused() {
    let dir = std::env::temp_dir().join(format!("ezy-model-paths-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("model.ezy");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid C string; mkfifo only creates the node
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let e = RuntimeModel::from_file(&fifo).unwrap_err().to_string();
    assert!(e.starts_with(&format!("cannot read model file {}: ", fifo.display())), "{e}");
    assert!(e.contains("is a FIFO (named pipe): nothing was read"), "{e}");
    let zero = dir.join("zero.ezy");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let e = RuntimeModel::from_file(&zero).unwrap_err().to_string();
    assert!(e.contains("zero.ezy") && e.contains("is a character device"), "{e}");
    let big = dir.join("big.ezy");
    std::fs::write(&big, " ".repeat(super::MAX_TEXT_BYTES as usize + 1)).unwrap();
    let e = RuntimeModel::from_file(&big).unwrap_err().to_string();
    assert!(e.contains("big.ezy") && e.contains("larger than 1 MiB"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
