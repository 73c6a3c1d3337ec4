//! `ezy::testing` catches real mistakes: a hand-written EzyRoller (no
//! macro) passes it, and the same model with the assignment's typo in the
//! hinge Jacobian (`+1` where `-1` belongs in the y2 column of the second
//! hinge row, docs/physics.md §10.4) fails it with the term and the entry named; so does
//! a convective term off by a small factor.

use ezy::testing::{Reference, assert_derivatives, check_derivatives};
use ezy_core::{BodyInfo, Equations, HingeInfo, Model, ModelInfo, ParamInfo, PointInfo, Scalar, SkateInfo};

/// The EzyRoller written out by hand, the way the assignment's MATLAB
/// code does it: `q = (x1, y1, phi1, x2, y2, phi2)`, hinge B joining
/// `(b, 0)` on body 1 to `(-d, 0)` on body 2, skates A at `(-a, 0)` on
/// body 1 and C at `(c, 0)` on body 2. `typo` puts `+1` in `G[B.y, y2]`.
#[derive(Debug, Clone)]
struct HandRoller {
    p: [f64; 8], // a, b, c, d, m1, I1, m2, I2
    typo: bool,
}

impl HandRoller {
    fn new(typo: bool) -> Self {
        Self { p: [0.2, 0.6, 0.1, 0.1, 46.0, 10.0, 1.0, 0.005], typo }
    }
}

/// Structural nonzeros of `G`, row-major: hinge rows B.x, B.y, skates A, C.
const PATTERN: [(usize, usize); 14] =
    [(0, 0), (0, 2), (0, 3), (0, 5), (1, 1), (1, 2), (1, 4), (1, 5), (2, 0), (2, 1), (2, 2), (3, 3), (3, 4), (3, 5)];

impl Model for HandRoller {
    fn info(&self) -> ModelInfo {
        let param = |name, unit| ParamInfo { name, default: 0.0, unit, doc: "", count: false };
        let body = |name: &str, k: usize| BodyInfo {
            name: name.into(),
            coords: [k, k + 1, k + 2],
            mass_param: None,
            inertia_param: None,
        };
        let point = |name: &str, body| PointInfo { name: name.into(), body };
        ModelInfo {
            name: "HandRoller",
            doc: "The EzyRoller written by hand",
            coords: ["x1", "y1", "phi1", "x2", "y2", "phi2"].map(String::from).to_vec(),
            params: vec![
                param("a", "m"),
                param("b", "m"),
                param("c", "m"),
                param("d", "m"),
                param("m1", "kg"),
                param("I1", "kg m^2"),
                param("m2", "kg"),
                param("I2", "kg m^2"),
            ],
            derived: vec![],
            bodies: vec![body("body1", 0), body("body2", 3)],
            points: vec![point("A", 0), point("B1", 0), point("B2", 1), point("C", 1)],
            hinges: vec![HingeInfo { name: "B".into(), body_a: 0, body_b: Some(1), row: 0, point: 1 }],
            sliders: vec![],
            drives: vec![],
            skates: vec![
                SkateInfo { name: "A".into(), point: 0, row: 2 },
                SkateInfo { name: "C".into(), point: 3, row: 3 },
            ],
            constraints: ["B.x", "B.y", "A", "C"].map(String::from).to_vec(),
            n_holonomic: 2,
            pattern: PATTERN.to_vec(),
        }
    }
    fn equations(&self) -> Equations {
        Equations::default()
    }
    fn param(&self, i: usize) -> f64 {
        self.p[i]
    }
    fn set_param(&mut self, i: usize, v: f64) {
        self.p[i] = v;
    }
    fn mass_diagonal(&self, out: &mut [f64]) {
        let [_, _, _, _, m1, i1, m2, i2] = self.p;
        out.copy_from_slice(&[m1, m1, i1, m2, m2, i2]);
    }
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
        let [a, b, c, d, ..] = self.p;
        points.copy_from_slice(&[-a, 0.0, b, 0.0, -d, 0.0, c, 0.0]);
        blades.copy_from_slice(&[1.0, 0.0, 1.0, 0.0]);
    }
    fn phi<S: Scalar>(&self, q: &[S], phi: &mut [S]) {
        let (b, d) = (S::from_f64(self.p[1]), S::from_f64(self.p[3]));
        phi[0] = q[0] + b * q[2].cos() - q[3] + d * q[5].cos();
        phi[1] = q[1] + b * q[2].sin() - q[4] + d * q[5].sin();
    }
    fn holonomic_jacobian<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        let mut all = [S::from_f64(0.0); 14];
        self.constraint_matrix(q, &mut all);
        values.copy_from_slice(&all[..8]);
    }
    fn constraint_matrix<S: Scalar>(&self, q: &[S], v: &mut [S]) {
        let [a, b, c, d, ..] = self.p.map(S::from_f64);
        let one = S::from_f64(1.0);
        let (s1, c1, s2, c2) = (q[2].sin(), q[2].cos(), q[5].sin(), q[5].cos());
        let y2 = if self.typo { one } else { -one };
        v.copy_from_slice(&[one, -b * s1, -one, -d * s2, one, b * c1, y2, d * c2, -s1, c1, -a, -s2, c2, c]);
    }
    fn phi_and_constraint_matrix<S: Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
        self.phi(q, phi);
        self.constraint_matrix(q, values);
    }
    fn constraint_terms<S: Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
        self.constraint_matrix(q, values);
        let (b, d) = (S::from_f64(self.p[1]), S::from_f64(self.p[3]));
        let (s1, c1, s2, c2) = (q[2].sin(), q[2].cos(), q[5].sin(), q[5].cos());
        let (w1, w2) = (qd[2], qd[5]);
        gamma[0] = -(b * w1 * w1 * c1) - d * w2 * w2 * c2;
        gamma[1] = -(b * w1 * w1 * s1) - d * w2 * w2 * s2;
        gamma[2] = -(w1 * (qd[0] * c1 + qd[1] * s1));
        gamma[3] = -(w2 * (qd[3] * c2 + qd[4] * s2));
    }
    fn points<S: Scalar>(&self, q: &[S], out: &mut [S]) {
        let [a, b, c, d, ..] = self.p.map(S::from_f64);
        let (s1, c1, s2, c2) = (q[2].sin(), q[2].cos(), q[5].sin(), q[5].cos());
        out.copy_from_slice(&[
            q[0] - a * c1,
            q[1] - a * s1,
            q[0] + b * c1,
            q[1] + b * s1,
            q[3] - d * c2,
            q[4] - d * s2,
            q[3] + c * c2,
            q[4] + c * s2,
        ]);
    }
    fn point_velocities<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
        let [a, b, c, d, ..] = self.p.map(S::from_f64);
        let (s1, c1, s2, c2) = (q[2].sin(), q[2].cos(), q[5].sin(), q[5].cos());
        let (w1, w2) = (qd[2], qd[5]);
        out.copy_from_slice(&[
            qd[0] + a * s1 * w1,
            qd[1] - a * c1 * w1,
            qd[0] - b * s1 * w1,
            qd[1] + b * c1 * w1,
            qd[3] + d * s2 * w2,
            qd[4] - d * c2 * w2,
            qd[3] - c * s2 * w2,
            qd[4] + c * c2 * w2,
        ]);
    }
}

/// Without the typo, the hand-written model passes: the failure below is
/// the typo's and nothing else's.
#[test]
fn the_hand_written_ezyroller_passes() {
    assert_derivatives(&HandRoller::new(false));
}

/// The typo fails the check against both references, naming the term and
/// the entry `G[B.y, y2]` with its values (+1 generated, -1 reference).
#[test]
fn the_assignments_jacobian_typo_is_caught_and_named() {
    let report = check_derivatives(&HandRoller::new(true));
    assert!(!report.passed());
    let failed: Vec<_> = report.terms.iter().filter(|t| !t.passed()).collect();
    assert_eq!(failed.len(), 2, "{}", report.table("HandRoller"));
    for t in &failed {
        assert!(t.term.starts_with("C_q"), "{t:?}");
        // |1 - (-1)| / max(1, 1, 1) = 2, up to the difference quotient's rounding
        assert!((t.max_error - 2.0).abs() <= 1e-9, "{t:?}");
        assert!(t.worst_at.contains("G[B.y, y2] (generated 1.000000e0, reference -1.000000e0)"), "{t:?}");
    }
    assert_eq!(
        failed.iter().map(|t| t.reference).collect::<Vec<_>>(),
        [Reference::FiniteDifference, Reference::DualNumber]
    );
    let panic = std::panic::catch_unwind(|| assert_derivatives(&HandRoller::new(true))).unwrap_err();
    let msg = panic.downcast_ref::<String>().expect("a formatted message");
    assert!(msg.contains("C_q = d phi/dq") && msg.contains("G[B.y, y2]") && msg.contains("FAILED"), "{msg}");
}

/// The macro's EzyRoller with `gamma[B.x]` off by `0.01 phi1d^2` (a slip
/// of a factor in a hand derivation): caught by both references, and only
/// that term fails.
#[derive(Debug, Clone, Default)]
struct SlippedGamma(ezy_models::EzyRoller);

impl Model for SlippedGamma {
    fn info(&self) -> ModelInfo {
        self.0.info()
    }
    fn equations(&self) -> Equations {
        self.0.equations()
    }
    fn param(&self, i: usize) -> f64 {
        self.0.param(i)
    }
    fn set_param(&mut self, i: usize, v: f64) {
        self.0.set_param(i, v)
    }
    fn mass_diagonal(&self, out: &mut [f64]) {
        self.0.mass_diagonal(out)
    }
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
        self.0.local_geometry(points, blades)
    }
    fn phi<S: Scalar>(&self, q: &[S], phi: &mut [S]) {
        self.0.phi(q, phi)
    }
    fn holonomic_jacobian<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        self.0.holonomic_jacobian(q, values)
    }
    fn constraint_matrix<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        self.0.constraint_matrix(q, values)
    }
    fn phi_and_constraint_matrix<S: Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
        self.0.phi_and_constraint_matrix(q, phi, values)
    }
    fn constraint_terms<S: Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
        self.0.constraint_terms(q, qd, values, gamma);
        gamma[0] = gamma[0] + S::from_f64(0.01) * qd[2] * qd[2];
    }
    fn points<S: Scalar>(&self, q: &[S], out: &mut [S]) {
        self.0.points(q, out)
    }
    fn point_velocities<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
        self.0.point_velocities(q, qd, out)
    }
}

#[test]
fn a_slipped_convective_term_is_caught_and_named() {
    let report = check_derivatives(&SlippedGamma::default());
    let failed: Vec<_> = report.terms.iter().filter(|t| !t.passed()).collect();
    assert_eq!(failed.len(), 2, "{}", report.table("SlippedGamma"));
    for t in failed {
        assert!(t.term.starts_with("gamma") && t.worst_at.contains("gamma[B.x]"), "{t:?}");
        assert!(t.max_error > 1e-4, "{t:?}");
    }
    assert!(report.worst().contains("gamma[B.x]"));
}
