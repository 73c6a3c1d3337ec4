//! RADAU5 through its generic interface (`integrator::radau5`): the order
//! of the method, and the classic stiff test problems against reference
//! solutions that do not come from ezy.

use ezy_core::integrator::Tolerance;
use ezy_core::integrator::radau5::{Attempt, DenseNewton, Radau5, integrate};

/// Radau IIA with three stages is of order 5 (HW II, Table IV.5.x): on
/// the harmonic oscillator over [0, 1] with fixed steps h = 1/8 .. 1/64
/// the global error falls by 2^5 per halving. Measured observed orders
/// 5.00, 5.00, 5.00 (errors 4.2e-9 .. 1.3e-13); the bounds 4.8 .. 5.2
/// fail for an order-3 or order-4 slip (a wrong node or weight).
#[test]
fn order_five_on_a_smooth_problem() {
    let mut f = |_t: f64, y: &[f64], dy: &mut [f64]| {
        dy[0] = y[1];
        dy[1] = -y[0];
    };
    let mut error = |steps: usize| {
        let h = 1.0 / steps as f64;
        // a loose error tolerance accepts every step; a tight Newton
        // tolerance solves the stage equations to rounding
        let mut st = Radau5::new(2, &Tolerance { rtol: 1e3, atol: 1e3 });
        st.set_newton_tolerance(1e-16);
        let mut newton = DenseNewton::new(2);
        let (mut y, mut fy, mut y_new) = (vec![1.0, 0.0], vec![0.0; 2], vec![0.0; 2]);
        for k in 0..steps {
            let t = k as f64 * h;
            f(t, &y, &mut fy);
            match st.attempt(&mut f, &mut newton, t, &y, &fy, h, &mut y_new).unwrap() {
                Attempt::Accepted { .. } => y.copy_from_slice(&y_new),
                Attempt::Rejected { .. } => panic!("step {k} of h = {h} rejected"),
            }
        }
        ((y[0] - 1f64.cos()).powi(2) + (y[1] + 1f64.sin()).powi(2)).sqrt()
    };
    let errs: Vec<f64> = [8, 16, 32, 64].iter().map(|&n| error(n)).collect();
    for w in errs.windows(2) {
        let order = (w[0] / w[1]).log2();
        eprintln!("errors {:e} -> {:e}: order {order:.2}", w[0], w[1]);
        if w[1] > 1e-13 {
            assert!((4.8..=5.2).contains(&order), "observed order {order} from {errs:?}");
        }
    }
}

/// Van der Pol's equation in Hairer's scaling (HW II §IV.10, problem
/// VDPOL): `y1' = y2`, `y2' = ((1 - y1^2) y2 - y1) / eps`, `eps = 1e-6`
/// (mu = 1e6 in the unscaled form), `y(0) = (2, 0)`, to `t = 2`. Reference
/// values from the test set for IVP solvers (Mazzia & Magherini, Bari),
/// computed there by RADAU5 at tolerance 1e-14:
/// `y1(2) = 1.706167732170469`, `y2(2) = -0.8928097010248125`. Measured
/// (max over both components): 1.3e-7 at rtol = atol = 1e-6 (505 steps),
/// 5.3e-11 at 1e-10 (2235 steps): the global error follows the tolerance,
/// as RADAU5's tolerance transformation intends.
#[test]
fn van_der_pol_matches_the_reference() {
    let eps = 1e-6;
    let mut f = |_t: f64, y: &[f64], dy: &mut [f64]| {
        dy[0] = y[1];
        dy[1] = ((1.0 - y[0] * y[0]) * y[1] - y[0]) / eps;
    };
    let reference = [1.706167732170469, -0.8928097010248125];
    for (tol, bound) in [(1e-6, 1e-6), (1e-10, 1e-10)] {
        let s = integrate(&mut f, 0.0, &[2.0, 0.0], 2.0, &Tolerance { rtol: tol, atol: tol }).unwrap();
        let err = (s.y[0] - reference[0]).abs().max((s.y[1] - reference[1]).abs());
        eprintln!("tol {tol:e}: error {err:e}, {} steps, {} rejected, {:?}", s.steps, s.rejected, s.newton);
        assert!(err <= bound, "tol {tol:e}: y(2) = {:?}, error {err:e}", s.y);
        // stiff: an explicit method would need ~1e6 steps; radau5 a few thousand
        assert!(s.steps < 20_000, "{} steps", s.steps);
    }
}

/// Robertson's chemical kinetics (HW II §IV.1, problem ROBER): stiff
/// (eigenvalues down to -1e4 and beyond), with the linear invariant
/// `y1 + y2 + y3 = 1`, which a Runge-Kutta method keeps to rounding (and
/// the simplified Newton iteration too: its increments sum to zero). At
/// `t = 40` against HW II's reference values (p. 3, Fig. 1.3's data:
/// `y1 = 0.7158270687193772`, `y2 = 9.185534764557054e-6`,
/// `y3 = 0.2841637457458830`): measured relative errors 1.7e-11, 4.1e-11
/// and 4.2e-11 at rtol = 1e-10, atol = 1e-14 (180 steps), the sum off by
/// 6.7e-16.
#[test]
fn robertson_keeps_its_invariant_and_matches_the_reference() {
    let mut f = |_t: f64, y: &[f64], dy: &mut [f64]| {
        dy[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
        dy[2] = 3e7 * y[1] * y[1];
        dy[1] = -dy[0] - dy[2];
    };
    let reference = [0.7158270687193772, 9.185534764557054e-6, 0.284163745745883];
    let s = integrate(&mut f, 0.0, &[1.0, 0.0, 0.0], 40.0, &Tolerance { rtol: 1e-10, atol: 1e-14 }).unwrap();
    let sum = s.y.iter().sum::<f64>();
    let rel: Vec<f64> = s.y.iter().zip(&reference).map(|(a, b)| (a - b).abs() / b).collect();
    eprintln!("robertson: y(40) = {:?}, relative errors {rel:?}, sum - 1 = {:e}, {} steps", s.y, sum - 1.0, s.steps);
    assert!((sum - 1.0).abs() <= 1e-14, "y1 + y2 + y3 - 1 = {:e}", sum - 1.0);
    for (k, r) in rel.iter().enumerate() {
        assert!(*r <= 1e-9, "y{} relative error {r:e}", k + 1);
    }
    assert!(s.steps < 2_000, "{} steps", s.steps);
}
