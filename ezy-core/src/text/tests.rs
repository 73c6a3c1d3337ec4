//! Texts that once crashed or hung the reader: each refused, located,
//! quickly.

use super::RuntimeModel;
use crate::Model;

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
