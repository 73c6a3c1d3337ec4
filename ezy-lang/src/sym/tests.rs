//! The symbolic engine's identity table: each row builds both sides with
//! the constructors and asserts they intern to the same node (hash-consing
//! makes structural equality an id comparison).

use std::collections::HashMap;

use super::{Arena, Id, Sym};

const X: Sym = Sym::Q(0);
const Y: Sym = Sym::Q(1);
const A: Sym = Sym::Param(0);

fn names(s: Sym) -> String {
    match s {
        Sym::Q(0) => "x".into(),
        Sym::Q(1) => "y".into(),
        Sym::Param(0) => "a".into(),
        other => format!("{other:?}"),
    }
}

struct T {
    ar: Arena,
    x: Id,
    y: Id,
    a: Id,
}

fn setup() -> T {
    let mut ar = Arena::new();
    let x = ar.sym(X);
    let y = ar.sym(Y);
    let a = ar.sym(A);
    T { ar, x, y, a }
}

#[test]
fn derivative_identities() {
    type Case = (&'static str, fn(&mut T) -> (Id, Id));
    let cases: &[Case] = &[
        ("d/dx sin(x) = cos(x)", |t| {
            let s = t.ar.sin(t.x);
            (t.ar.diff(s, X), t.ar.cos(t.x))
        }),
        ("d/dx cos(x) = -sin(x)", |t| {
            let c = t.ar.cos(t.x);
            let s = t.ar.sin(t.x);
            (t.ar.diff(c, X), t.ar.neg(s))
        }),
        ("d/dx x^3 = 3 x^2", |t| {
            let p = t.ar.pow(t.x, 3);
            let k = t.ar.cst(3.0);
            let x2 = t.ar.pow(t.x, 2);
            (t.ar.diff(p, X), t.ar.mul2(k, x2))
        }),
        ("d/dx x y = y", |t| {
            let p = t.ar.mul2(t.x, t.y);
            (t.ar.diff(p, X), t.y)
        }),
        ("d/dx a x^2 = 2 a x", |t| {
            let x2 = t.ar.pow(t.x, 2);
            let p = t.ar.mul2(t.a, x2);
            let two = t.ar.cst(2.0);
            (t.ar.diff(p, X), t.ar.mul(&[two, t.a, t.x]))
        }),
        ("d/dx sin(x^2) = 2 x cos(x^2)", |t| {
            let x2 = t.ar.pow(t.x, 2);
            let s = t.ar.sin(x2);
            let two = t.ar.cst(2.0);
            let c = t.ar.cos(x2);
            (t.ar.diff(s, X), t.ar.mul(&[two, t.x, c]))
        }),
        ("d/dx sin(x) cos(x) = cos(x)^2 - sin(x)^2", |t| {
            let s = t.ar.sin(t.x);
            let c = t.ar.cos(t.x);
            let p = t.ar.mul2(s, c);
            let c2 = t.ar.pow(c, 2);
            let s2 = t.ar.pow(s, 2);
            (t.ar.diff(p, X), t.ar.sub(c2, s2))
        }),
        ("d/dx sqrt(x) = 0.5 / sqrt(x)", |t| {
            let r = t.ar.sqrt(t.x);
            let half = t.ar.cst(0.5);
            let q = t.ar.div(half, r);
            (t.ar.diff(r, X), q)
        }),
        ("d/dx 1/x = -x^-2", |t| {
            let inv = t.ar.pow(t.x, -1);
            let m2 = t.ar.pow(t.x, -2);
            (t.ar.diff(inv, X), t.ar.neg(m2))
        }),
        ("d/dx a = 0", |t| {
            let z = t.ar.cst(0.0);
            (t.ar.diff(t.a, X), z)
        }),
        ("d/dx y = 0", |t| {
            let z = t.ar.cst(0.0);
            (t.ar.diff(t.y, X), z)
        }),
        ("d/dx (x + a sin(y)) = 1", |t| {
            let s = t.ar.sin(t.y);
            let p = t.ar.mul2(t.a, s);
            let e = t.ar.add2(t.x, p);
            let one = t.ar.cst(1.0);
            (t.ar.diff(e, X), one)
        }),
    ];
    for (name, case) in cases {
        let mut t = setup();
        let (lhs, rhs) = case(&mut t);
        assert_eq!(lhs, rhs, "{name}: got {}, want {}", t.ar.display(lhs, &names), t.ar.display(rhs, &names));
    }
}

#[test]
fn simplification_identities() {
    type Case = (&'static str, fn(&mut T) -> (Id, Id));
    let cases: &[Case] = &[
        ("x + 0 = x", |t| {
            let z = t.ar.cst(0.0);
            (t.ar.add2(t.x, z), t.x)
        }),
        ("x * 1 = x", |t| {
            let o = t.ar.cst(1.0);
            (t.ar.mul2(t.x, o), t.x)
        }),
        ("x * 0 = 0", |t| {
            let z = t.ar.cst(0.0);
            (t.ar.mul2(t.x, z), z)
        }),
        ("x - x = 0", |t| {
            let z = t.ar.cst(0.0);
            (t.ar.sub(t.x, t.x), z)
        }),
        ("2x + 3x = 5x", |t| {
            let two = t.ar.cst(2.0);
            let three = t.ar.cst(3.0);
            let five = t.ar.cst(5.0);
            let l = t.ar.mul2(two, t.x);
            let r = t.ar.mul2(three, t.x);
            (t.ar.add2(l, r), t.ar.mul2(five, t.x))
        }),
        ("x x = x^2", |t| (t.ar.mul2(t.x, t.x), t.ar.pow(t.x, 2))),
        ("x / x = 1", |t| {
            let o = t.ar.cst(1.0);
            (t.ar.div(t.x, t.x), o)
        }),
        ("-(-x) = x", |t| {
            let n = t.ar.neg(t.x);
            (t.ar.neg(n), t.x)
        }),
        ("x y = y x", |t| (t.ar.mul2(t.x, t.y), t.ar.mul2(t.y, t.x))),
        ("x + y = y + x", |t| (t.ar.add2(t.x, t.y), t.ar.add2(t.y, t.x))),
        ("(x + y) + a = x + (y + a)", |t| {
            let l = t.ar.add2(t.x, t.y);
            let r = t.ar.add2(t.y, t.a);
            (t.ar.add2(l, t.a), t.ar.add2(t.x, r))
        }),
        ("2 * 3 = 6", |t| {
            let two = t.ar.cst(2.0);
            let three = t.ar.cst(3.0);
            let six = t.ar.cst(6.0);
            (t.ar.mul2(two, three), six)
        }),
        ("sqrt(4) = 2", |t| {
            let four = t.ar.cst(4.0);
            let two = t.ar.cst(2.0);
            (t.ar.sqrt(four), two)
        }),
        ("(x^2)^3 = x^6", |t| {
            let x2 = t.ar.pow(t.x, 2);
            (t.ar.pow(x2, 3), t.ar.pow(t.x, 6))
        }),
        ("sqrt(x)^2 = x", |t| {
            let r = t.ar.sqrt(t.x);
            (t.ar.pow(r, 2), t.x)
        }),
        ("(2x)^2 = 4 x^2", |t| {
            let two = t.ar.cst(2.0);
            let four = t.ar.cst(4.0);
            let tx = t.ar.mul2(two, t.x);
            let x2 = t.ar.pow(t.x, 2);
            (t.ar.pow(tx, 2), t.ar.mul2(four, x2))
        }),
        ("sin(x)^2 + cos(x)^2 = 1", |t| {
            let s = t.ar.sin(t.x);
            let c = t.ar.cos(t.x);
            let s2 = t.ar.pow(s, 2);
            let c2 = t.ar.pow(c, 2);
            let one = t.ar.cst(1.0);
            (t.ar.add2(s2, c2), one)
        }),
        ("-a sin(x)^2 - a cos(x)^2 + y = y - a", |t| {
            let s = t.ar.sin(t.x);
            let c = t.ar.cos(t.x);
            let s2 = t.ar.pow(s, 2);
            let c2 = t.ar.pow(c, 2);
            let l1 = t.ar.mul2(t.a, s2);
            let l2 = t.ar.mul2(t.a, c2);
            let n1 = t.ar.neg(l1);
            let n2 = t.ar.neg(l2);
            let lhs = t.ar.add(&[n1, n2, t.y]);
            (lhs, t.ar.sub(t.y, t.a))
        }),
        ("sin(0) = 0, cos(0) = 1", |t| {
            let z = t.ar.cst(0.0);
            let s = t.ar.sin(z);
            let c = t.ar.cos(z);
            let one = t.ar.cst(1.0);
            (t.ar.add2(s, c), one)
        }),
        ("-0 = 0", |t| {
            let z = t.ar.cst(0.0);
            let mz = t.ar.cst(-0.0);
            (mz, z)
        }),
    ];
    for (name, case) in cases {
        let mut t = setup();
        let (lhs, rhs) = case(&mut t);
        assert_eq!(lhs, rhs, "{name}: got {}, want {}", t.ar.display(lhs, &names), t.ar.display(rhs, &names));
    }
}

#[test]
fn a_sin_squared_plus_b_cos_squared_is_not_collapsed() {
    // Different coefficients must not trigger the Pythagoras rule.
    let mut t = setup();
    let s = t.ar.sin(t.x);
    let c = t.ar.cos(t.x);
    let s2 = t.ar.pow(s, 2);
    let c2 = t.ar.pow(c, 2);
    let two = t.ar.cst(2.0);
    let l = t.ar.mul2(two, s2);
    let e = t.ar.add2(l, c2);
    let env = |s: Sym| if s == X { 0.3 } else { 0.0 };
    let want = 2.0 * 0.3f64.sin().powi(2) + 0.3f64.cos().powi(2);
    assert!((t.ar.eval(e, &env) - want).abs() < 1e-15);
}

#[test]
fn derivative_matches_finite_difference() {
    // f = a sqrt(x^2 + y^2) sin(x y) / (1 + x^2) cos(a x)
    let mut t = setup();
    let x2 = t.ar.pow(t.x, 2);
    let y2 = t.ar.pow(t.y, 2);
    let r2 = t.ar.add2(x2, y2);
    let r = t.ar.sqrt(r2);
    let xy = t.ar.mul2(t.x, t.y);
    let s = t.ar.sin(xy);
    let one = t.ar.cst(1.0);
    let den = t.ar.add2(one, x2);
    let ax = t.ar.mul2(t.a, t.x);
    let c = t.ar.cos(ax);
    let num = t.ar.mul(&[t.a, r, s, c]);
    let f = t.ar.div(num, den);
    let df = t.ar.diff(f, X);
    let at = |x: f64| {
        move |s: Sym| match s {
            Sym::Q(0) => x,
            Sym::Q(1) => 0.7,
            _ => 1.3,
        }
    };
    let x0 = 0.45;
    let h = 1e-6;
    let fd = (t.ar.eval(f, &at(x0 + h)) - t.ar.eval(f, &at(x0 - h))) / (2.0 * h);
    let exact = t.ar.eval(df, &at(x0));
    assert!((fd - exact).abs() < 1e-8 * exact.abs().max(1.0), "fd {fd} vs symbolic {exact}");
}

#[test]
fn display_reads_like_the_spec() {
    // -b sin(phi1) as the hinge Jacobian entry of docs/physics.md §10.2
    let mut ar = Arena::new();
    let phi = ar.sym(Sym::Q(2));
    let b = ar.sym(Sym::Param(1));
    let s = ar.sin(phi);
    let bs = ar.mul2(b, s);
    let e = ar.neg(bs);
    let name = |s: Sym| match s {
        Sym::Q(2) => "phi1".to_string(),
        Sym::Param(1) => "b".to_string(),
        _ => "?".to_string(),
    };
    assert_eq!(ar.display(e, &name), "-b*sin(phi1)");
}

#[test]
fn replace_substitutes_and_cancels_like_terms() {
    // x2 - (x1 + b cos(phi1)) with x2 := x1 + b cos(phi1) is zero: the
    // replacement's -1 is distributed over the sum so its terms meet
    let mut ar = Arena::new();
    let (x1, x2, phi1, b) = (ar.sym(Sym::Q(0)), ar.sym(Sym::Q(3)), ar.sym(Sym::Q(2)), ar.sym(Sym::Param(1)));
    let c = ar.cos(phi1);
    let bc = ar.mul2(b, c);
    let hinge = ar.add2(x1, bc);
    let row = ar.sub(x2, hinge);
    let solved = ar.replace(row, &|s| (s == Sym::Q(3)).then_some(hinge), &mut HashMap::new());
    assert!(ar.is_zero(solved));
    // symbols not mapped stay (the sum's coefficient distributed: the
    // same value); mentions finds what remains
    let kept = ar.replace(row, &|_| None, &mut HashMap::new());
    let at = |s: Sym| match s {
        Sym::Q(k) => 0.3 + k as f64,
        Sym::Qd(_) => 0.0,
        Sym::Param(_) | Sym::Index(_) => 0.7,
    };
    assert!((ar.eval(kept, &at) - ar.eval(row, &at)).abs() < 1e-15);
    assert!(ar.mentions(row, &|s| s == Sym::Q(3)) && !ar.mentions(bc, &|s| s == Sym::Q(3)));
}

/// `linearize`, `trig_products` and `factor` (the minimal coordinates'
/// passes) change the form of a trigonometric polynomial, never its value:
/// `(a cos x cos y + a sin x sin y)^2 + x sin x cos y - cos(x) sin(y) y`
/// evaluated at a grid of points before and after each pass (rounding
/// only: 1e-13 relative), and `cos x cos y + sin x sin y` becomes
/// `cos(x - y)` under `linearize`.
#[test]
fn trigonometric_passes_keep_the_value() {
    let mut t = setup();
    let (cx, sx, cy, sy) = (t.ar.cos(t.x), t.ar.sin(t.x), t.ar.cos(t.y), t.ar.sin(t.y));
    let p1 = t.ar.mul(&[t.a, cx, cy]);
    let p2 = t.ar.mul(&[t.a, sx, sy]);
    let s = t.ar.add2(p1, p2);
    let sq = t.ar.pow(s, 2);
    let q1 = t.ar.mul(&[t.x, sx, cy]);
    let q2 = t.ar.mul(&[cx, sy, t.y]);
    let q2 = t.ar.neg(q2);
    let f = t.ar.add(&[sq, q1, q2]);
    let lin = t.ar.linearize(f);
    let prod = t.ar.trig_products(lin, &mut HashMap::new());
    let fac = t.ar.factor(prod, &mut HashMap::new());
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (-2.0 + 0.9 * i as f64, -1.7 + 0.8 * j as f64);
            let env = |s: Sym| match s {
                Sym::Q(0) => x,
                Sym::Q(1) => y,
                _ => 1.3,
            };
            let want = t.ar.eval(f, &env);
            for (pass, g) in [("linearize", lin), ("trig_products", prod), ("factor", fac)] {
                let got = t.ar.eval(g, &env);
                assert!((got - want).abs() <= 1e-13 * want.abs().max(1.0), "{pass} at ({x}, {y}): {got} vs {want}");
            }
        }
    }
    let (c1, c2) = (t.ar.mul2(cx, cy), t.ar.mul2(sx, sy));
    let sum = t.ar.add2(c1, c2);
    let d = t.ar.sub(t.x, t.y);
    let want = t.ar.cos(d);
    let got = t.ar.linearize(sum);
    assert_eq!(got, want, "{}", t.ar.display(got, &names));
}

/// A family index is a constant for the derivatives (`d(i a cos x)/dx =
/// -i a sin x`, nothing from `i`) but not fixed: a table of constants
/// computed once per run must not hold it, nor a product that mentions
/// it, while the parameter-only nodes stay fixed.
#[test]
fn a_family_index_is_constant_in_q_but_not_fixed() {
    let mut ar = Arena::new();
    let (x, i, a) = (ar.sym(X), ar.sym(Sym::Index(0)), ar.sym(A));
    let c = ar.cos(x);
    let e = ar.mul(&[i, a, c]);
    let d = ar.diff(e, X);
    let s = ar.sin(x);
    let m1 = ar.cst(-1.0);
    let want = ar.mul(&[m1, i, a, s]);
    assert_eq!(d, want);
    let ia = ar.mul2(i, a);
    let d_ia = ar.diff(ia, X);
    assert!(ar.is_zero(d_ia));
    let two = ar.cst(2.0);
    let a2 = ar.mul2(two, a);
    let fixed = ar.fixed_nodes();
    assert!(!fixed[i.index()] && !fixed[ia.index()] && !fixed[e.index()]);
    assert!(fixed[a.index()] && fixed[a2.index()]);
    // read numbers first, then the index, then parameters
    let name = |s: Sym| if s == Sym::Index(0) { "i".to_string() } else { names(s) };
    let e2 = ar.mul(&[a2, i, c]);
    assert_eq!(ar.display(e2, &name), "2*i*a*cos(x)");
}

/// A product of 40 sums is not multiplied out into 2^40 products: its
/// parameter-only factors stay whole, the coordinate's sine is spread,
/// and the value is the same.
#[test]
fn a_product_of_many_sums_expands_within_the_budget() {
    let mut ar = Arena::new();
    let (a, b, q) = (ar.sym(Sym::Param(0)), ar.sym(Sym::Param(1)), ar.sym(Sym::Q(0)));
    let (s, c) = (ar.sin(q), ar.cos(q));
    let mut fs: Vec<Id> = (0..40)
        .map(|k| {
            let k = ar.cst(f64::from(k));
            ar.add(&[a, b, k])
        })
        .collect();
    fs.push(ar.add2(s, c));
    let e = ar.mul(&fs);
    let x = ar.expand(e);
    let super::Node::Add(ts) = ar.node(x).clone() else { panic!("a sum of two terms") };
    assert_eq!(ts.len(), 2);
    let env = |v: Sym| match v {
        Sym::Param(0) => 0.25,
        Sym::Param(1) => -0.5,
        _ => 0.7,
    };
    let (want, got) = (ar.eval(e, &env), ar.eval(x, &env));
    assert!((got - want).abs() <= 1e-12 * want.abs(), "{got} vs {want}");
    let l = ar.linearize(e);
    assert!((ar.eval(l, &env) - want).abs() <= 1e-12 * want.abs());
}
