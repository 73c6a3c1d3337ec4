//! `ezy check MODEL`: the generated Jacobians, skate rows, convective terms
//! and point velocities against central finite differences of the
//! generated positions at random states and parameters, with the largest
//! relative error per term (the test suite adds dual numbers; this is the
//! check a user runs on a model they wrote).

use ezy_core::Model;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Central-difference step: truncation ~h^2 |f'''| ~ 1e-10 and rounding
/// ~eps/h ~ 1e-11 for the O(1) quantities of a vehicle.
pub const FD_STEP: f64 = 1e-5;

/// A derived term passes when its largest relative error is below this:
/// three orders above what central differences resolve, three below any
/// real mistake (a wrong sign or factor gives O(1)).
pub const TOLERANCE: f64 = 1e-6;

/// The result for one derived term.
#[derive(Debug, Clone, PartialEq)]
pub struct TermCheck {
    /// What was compared, e.g. `C_q = d phi/dq`.
    pub term: &'static str,
    /// Number of scalar comparisons.
    pub compared: usize,
    /// Largest `|generated - fd| / max(|generated|, |fd|, 1)`.
    pub max_error: f64,
    /// Where it occurred: state number and entry.
    pub worst_at: String,
}

impl TermCheck {
    /// Below [`TOLERANCE`].
    pub fn passed(&self) -> bool {
        self.max_error <= TOLERANCE
    }
}

struct Acc {
    term: &'static str,
    compared: usize,
    max_error: f64,
    worst_at: String,
}

impl Acc {
    fn new(term: &'static str) -> Self {
        Self { term, compared: 0, max_error: 0.0, worst_at: String::new() }
    }
    fn add(&mut self, generated: f64, fd: f64, at: impl FnOnce() -> String) {
        let e = (generated - fd).abs() / generated.abs().max(fd.abs()).max(1.0);
        self.compared += 1;
        if e > self.max_error || !e.is_finite() {
            self.max_error = if e.is_finite() { e } else { f64::INFINITY };
            self.worst_at = at();
        }
    }
    fn done(self) -> TermCheck {
        TermCheck { term: self.term, compared: self.compared, max_error: self.max_error, worst_at: self.worst_at }
    }
}

/// Checks model `M` at `states` random states: positions in [-3, 3] m,
/// angles in [-pi, pi], velocities in [-2, 2], every parameter scaled by a
/// random factor in [0.5, 1.5] of its default (seeded, so reproducible);
/// family counts stay at their defaults.
pub fn check<M: Model + Default>(states: usize, seed: u64) -> Vec<TermCheck> {
    check_at(&M::default(), states, seed)
}

/// As [`check`], around `base` (its family counts, its parameters scaled).
pub fn check_at<M: Model>(base: &M, states: usize, seed: u64) -> Vec<TermCheck> {
    let info = &base.info();
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    let np = info.points.len();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut jac = Acc::new("C_q = d phi/dq (hinge rows of G)");
    let mut skate = Acc::new("S = n . d r_P/dq (skate rows of G)");
    let mut gamma = Acc::new("gamma = d/dq(G qd) qd");
    let mut vel = Acc::new("point velocities = d r_P/dt");
    let h = FD_STEP;
    for s in 0..states {
        let mut m = base.clone();
        for (i, p) in info.params.iter().enumerate() {
            if p.count {
                continue;
            }
            let v = m.param(i);
            m.set_param(i, v * rng.random_range(0.5..1.5));
        }
        let q: Vec<f64> = (0..nq).map(|_| rng.random_range(-3.0..3.0)).collect();
        let qd: Vec<f64> = (0..nq).map(|_| rng.random_range(-2.0..2.0)).collect();
        let dense = |q: &[f64]| {
            let mut vals = vec![0.0; info.pattern.len()];
            m.constraint_matrix(q, &mut vals);
            let mut g = vec![0.0; nc * nq];
            for (&(r, c), v) in info.pattern.iter().zip(vals) {
                g[r * nq + c] = v;
            }
            g
        };
        let g = dense(&q);
        let shifted = |k: usize, d: f64| {
            let mut p = q.clone();
            p[k] += d;
            p
        };
        let points = |q: &[f64]| {
            let mut out = vec![0.0; 2 * np];
            m.points(q, &mut out);
            out
        };
        let mut blades = vec![0.0; 2 * info.skates.len()];
        let mut local = vec![0.0; 2 * np];
        m.local_geometry(&mut local, &mut blades);
        for k in 0..nq {
            let (mut fp, mut fm) = (vec![0.0; nh], vec![0.0; nh]);
            m.phi(&shifted(k, h), &mut fp);
            m.phi(&shifted(k, -h), &mut fm);
            for i in 0..nh {
                jac.add(g[i * nq + k], (fp[i] - fm[i]) / (2.0 * h), || {
                    format!("state {s}, G[{}, {}]", info.constraints[i], info.coords[k])
                });
            }
            let (pp, pm) = (points(&shifted(k, h)), points(&shifted(k, -h)));
            for (j, sk) in info.skates.iter().enumerate() {
                let p = sk.point;
                let phi = q[info.bodies[info.points[p].body].coords[2]];
                let (t0, t1) = (blades[2 * j], blades[2 * j + 1]);
                // world normal R(phi) (-t_y, t_x)
                let n = [-phi.cos() * t1 - phi.sin() * t0, -phi.sin() * t1 + phi.cos() * t0];
                let fd = (n[0] * (pp[2 * p] - pm[2 * p]) + n[1] * (pp[2 * p + 1] - pm[2 * p + 1])) / (2.0 * h);
                skate.add(g[sk.row * nq + k], fd, || format!("state {s}, G[{}, {}]", sk.name, info.coords[k]));
            }
        }
        let along = |d: f64| -> Vec<f64> { q.iter().zip(&qd).map(|(a, b)| a + d * b).collect() };
        let g_qd =
            |g: &[f64]| -> Vec<f64> { g.chunks(nq).map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum()).collect() };
        let (gp, gm) = (g_qd(&dense(&along(h))), g_qd(&dense(&along(-h))));
        let mut vals = vec![0.0; info.pattern.len()];
        let mut gam = vec![0.0; nc];
        m.constraint_terms(&q, &qd, &mut vals, &mut gam);
        for i in 0..nc {
            gamma.add(gam[i], (gp[i] - gm[i]) / (2.0 * h), || format!("state {s}, gamma[{}]", info.constraints[i]));
        }
        let (pp, pm) = (points(&along(h)), points(&along(-h)));
        let mut v = vec![0.0; 2 * np];
        m.point_velocities(&q, &qd, &mut v);
        for i in 0..2 * np {
            let axis = if i % 2 == 0 { "x" } else { "y" };
            vel.add(v[i], (pp[i] - pm[i]) / (2.0 * h), || format!("state {s}, {}.{axis}d", info.points[i / 2].name));
        }
    }
    vec![jac.done(), skate.done(), gamma.done(), vel.done()]
}

/// The checks as a table.
pub fn table(model: &str, states: usize, checks: &[TermCheck]) -> String {
    let mut out = format!(
        "{model}: generated terms against central differences (h = {FD_STEP:e}) at {states} random states and parameters\n"
    );
    out.push_str(&format!("{:<38} {:>9} {:>13}  {:<6} worst at\n", "term", "compared", "max rel err", ""));
    for c in checks {
        let verdict = if c.compared == 0 {
            "none"
        } else if c.passed() {
            "ok"
        } else {
            "FAILED"
        };
        out.push_str(&format!(
            "{:<38} {:>9} {:>13.3e}  {:<6} {}\n",
            c.term, c.compared, c.max_error, verdict, c.worst_at
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use ezy_core::{Equations, ModelInfo, Scalar};
    use ezy_models::EzyRoller;

    /// The EzyRoller with one derived term wrong: `gamma` of the hinge's x
    /// row is off by `0.01 phi1d^2` (a slip of a factor in a hand
    /// derivation), everything else delegated.
    #[derive(Debug, Clone, Default)]
    struct SlippedGamma(EzyRoller);

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
    fn the_generated_terms_pass() {
        for c in check::<EzyRoller>(50, 7) {
            assert!(c.passed() && c.compared > 0, "{c:?}");
        }
    }

    /// A wrong convective term is caught and named; the other terms pass.
    #[test]
    fn a_wrong_term_is_caught_and_named() {
        let checks = check::<SlippedGamma>(20, 7);
        let bad: Vec<&TermCheck> = checks.iter().filter(|c| !c.passed()).collect();
        assert_eq!(bad.len(), 1, "{checks:?}");
        assert!(bad[0].term.starts_with("gamma") && bad[0].worst_at.contains("gamma[B.x]"), "{:?}", bad[0]);
        assert!(bad[0].max_error > 1e-4, "{:?}", bad[0]);
        assert!(table("SlippedGamma", 20, &checks).contains("FAILED"));
    }
}
