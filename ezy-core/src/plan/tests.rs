//! The transcription's Jacobian against central differences of its
//! constraints, on the EzyRoller (written here with `model!`: the models
//! crate is out of ezy-core's reach), with a node at every segment, at
//! some and at none (single shooting).

use std::sync::Arc;

use super::transcription::Transcription;
use super::*;
use crate::Method;
use crate::effects::HingeMotor;

crate::model! {
    /// The EzyRoller (as `ezy_models::EzyRoller`).
    pub struct Roller {
        param a = 0.2;
        param b = 0.6;
        param c = 0.1;
        param d = 0.1;
        param m1 = 46.0;
        param I1 = 10.0;
        param m2 = 1.0;
        param I2 = 0.005;
        body body1(x1, y1, phi1) { mass: m1, inertia: I1 }
        body body2(x2, y2, phi2) { mass: m2, inertia: I2 }
        point A on body1 at (-a, 0);
        point B1 on body1 at (b, 0);
        point B2 on body2 at (-d, 0);
        point C on body2 at (c, 0);
        hinge B: B1 = B2;
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}

fn roller(tables: &[Table]) -> Result<Problem<Roller>, SimError> {
    Problem::new(Roller::default())
        .q("x1", 0.0)?
        .q("y1", 0.0)?
        .q("phi1", 0.0)?
        .q("phi2", std::f64::consts::PI)?
        .qd("x1", 0.0)?
        .qd("phi1", 0.0)?
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12)
        .effect("motor", HingeMotor { hinge: "B".into(), torque: Waveform::Table(tables[0].clone()) })
}

/// The largest difference of the Jacobian from central differences of
/// the constraints (h = 1e-6 of each unknown's size), relative to the
/// column's largest entry.
fn jacobian_error(intervals: usize) -> f64 {
    let (n, t_end) = (6usize, 3.0);
    let h = t_end / n as f64;
    let build: Arc<BuildInputs<Roller>> = Arc::new(roller);
    let plan = Plan::new(
        vec![Input::new("tau", -10.0, 10.0).guess_waveform(Waveform::cos(2.0, std::f64::consts::PI))],
        Target::new().q("x1", 1.0).at_rest(),
        PlanSettings { intervals, ..PlanSettings::new(n, t_end) },
        roller,
    )
    .unwrap();
    let mesh = plan.mesh();
    let guess: Vec<f64> = mesh.iter().map(|&t| plan.inputs[0].guess.eval(t)).collect();
    let first = check::problem(&plan, &guess).unwrap();
    let target = check::target(&first, &plan.target).unwrap();
    let x = plan.warm_start(&first, h, &guess).unwrap();
    let mut tr = Transcription::new(&build, vec!["tau".into()], (n, h, intervals), &first.model, &x).unwrap();
    let mut w = guess;
    w.resize(tr.n, 0.0);
    tr.gather(&x, &mut w);
    // off the warm start: the inputs and the nodes moved
    for (k, v) in w.iter_mut().enumerate() {
        *v += 0.01 * ((k as f64) * 1.7).sin();
    }
    tr.set_target(check::independent(&first.model, &x[n], &target));
    let p = tr.evaluate(&w).unwrap();
    let mut worst = 0.0f64;
    for k in 0..tr.n {
        let step = 1e-6 * w[k].abs().max(1.0);
        let (mut a, mut b) = (w.clone(), w.clone());
        a[k] += step;
        b[k] -= step;
        let (pa, pb) = (tr.evaluate(&a).unwrap(), tr.evaluate(&b).unwrap());
        let size = p.jac.iter().fold(1e-3f64, |m, row| m.max(row[k].abs()));
        for (i, row) in p.jac.iter().enumerate() {
            let fd = (pa.c[i] - pb.c[i]) / (2.0 * step);
            let e = (fd - row[k]).abs() / size;
            if e > worst {
                eprintln!("unknown {k}, {}: jac {} fd {fd} ({e:.1e})", tr.rows[i].0, row[k]);
            }
            worst = worst.max(e);
        }
    }
    eprintln!("{intervals} intervals, {} unknowns: largest relative error {worst:.2e}", tr.n);
    worst
}

/// Differences at h = 1e-6 with runs at 1e-12 are good to about 1e-6
/// relative; a wrong chain term (a missed product) is of order 1.
#[test]
fn the_jacobian_is_the_constraints_derivative() {
    for intervals in [6, 2, 1] {
        assert!(jacobian_error(intervals) <= 1e-5, "{intervals} intervals");
    }
}
