//! A peer benchmark that splits ezy's gap to the hand-written C++
//! (`benches/peers/reduced.cpp`) into the integrator's share and the
//! right-hand side's: ezy-core's own DOP853 and step-size controller (the
//! ones `ezy run --integrator dop853` takes) on the C++'s hand-derived
//! reduced ODE of the EzyRoller's `drive` scene, written again in Rust
//! (Kane's/Maggi's equations with the 2 x 2 mass matrix in closed form;
//! the derivation is in that file's header). Its time against the C++'s is
//! what the integrator costs; ezy's own reduced run against it is what
//! the generated right-hand side and its bookkeeping cost.
//!
//!     cargo run --release -p ezy-core --example peer_reduced -- \
//!         --rtol 3e-11 --reps 21 --ref benches/peers/reference.csv
//!
//! (`bash benches/peers/run.sh` builds and runs it with the other peers.)
//!
//! Prints the peers' CSV line `tool,formulation,rtol,rhs_evals,
//! integration_s_median,error` (`benches/peers/README.md`), the error
//! being the largest difference over q and qd at t = 60 s from the
//! reference's last row. Options: `--rtol R`, `--atol A` (default R),
//! `--reps N` (21), `--ref FILE` (`reference.csv`, as the C++ peers).

use std::f64::consts::PI;

use ezy_core::SimError;
use ezy_core::integrator::Dop853;
use ezy_core::integrator::adaptive::{Controller, EmbeddedRk, Tolerance, initial_step};

// the EzyRoller (docs/physics.md §10) and the drive scene's motor
const A: f64 = 0.2;
const B: f64 = 0.6;
const C: f64 = 0.1;
const D: f64 = 0.1;
const M1: f64 = 46.0;
const I1: f64 = 10.0;
const M2: f64 = 1.0;
const I2: f64 = 0.005;
const M0: f64 = 2.0;
const OMEGA: f64 = PI;
const T_END: f64 = 60.0;
const K: f64 = A + B;
const L: f64 = C + D;
const J: f64 = M2 * C * C + I2;
const IA: f64 = I1 + M1 * A * A;

/// The reduced ODE of `reduced.cpp`, `y = (x1, y1, phi1, phi2, u, w, W)`:
/// `u` body 1's forward speed \[m/s\], `w = phi1d` \[rad/s\], `W` the
/// motor's work \[J\].
fn rhs(t: f64, y: &[f64], dy: &mut [f64]) {
    let (phi1, phi2, u, w) = (y[2], y[3], y[4], y[5]);
    let (s1, c1) = phi1.sin_cos();
    let (s, co) = (phi1 - phi2).sin_cos();
    let p = -(s * u + K * co * w) / L; // phi2d
    let u2 = co * u - K * s * w;
    let thd = w - p;
    let tau = M0 * (OMEGA * t).cos();
    let m11 = M1 + M2 * co * co + J * s * s / (L * L);
    let m12 = K * s * co * (J / (L * L) - M2);
    let m22 = IA + M2 * K * K * s * s + J * K * K * co * co / (L * L);
    let r1 = tau * s / L + M1 * A * w * w
        - M2 * C * co * p * p
        - M2 * C * s * p * u2 / L
        - M2 * L * co * p * thd
        - J * s * u2 * thd / (L * L);
    let r2 = tau * (1.0 + K * co / L) - M1 * A * u * w + M2 * C * K * s * p * p - M2 * C * K * co * p * u2 / L
        + M2 * K * L * s * p * thd
        - J * K * co * u2 * thd / (L * L);
    let det = m11 * m22 - m12 * m12;
    dy[0] = c1 * u - A * s1 * w;
    dy[1] = s1 * u + A * c1 * w;
    dy[2] = w;
    dy[3] = p;
    dy[4] = (m22 * r1 - m12 * r2) / det;
    dy[5] = (m11 * r2 - m12 * r1) / det;
    dy[6] = tau * (w - p);
}

/// `q, qd` (12) of the reduced state.
fn full_state(y: &[f64]) -> [f64; 12] {
    let (x1, y1, phi1, phi2, u, w) = (y[0], y[1], y[2], y[3], y[4], y[5]);
    let (s1, c1) = phi1.sin_cos();
    let (s2, c2) = phi2.sin_cos();
    let s = (phi1 - phi2).sin();
    let co = (phi1 - phi2).cos();
    let p = -(s * u + K * co * w) / L;
    let (x1d, y1d) = (c1 * u - A * s1 * w, s1 * u + A * c1 * w);
    [
        x1,
        y1,
        phi1,
        x1 + B * c1 + D * c2,
        y1 + B * s1 + D * s2,
        phi2,
        x1d,
        y1d,
        w,
        x1d - B * s1 * w - D * s2 * p,
        y1d + B * c1 * w + D * c2 * p,
        p,
    ]
}

/// One integration from rest to `T_END` with the step loop of ezy's
/// adaptive methods (no projection, no output): the final state and the
/// number of evaluations.
fn integrate(tol: &Tolerance) -> Result<([f64; 7], u64), SimError> {
    let mut evals = 0u64;
    let mut f = |t: f64, y: &[f64], dy: &mut [f64]| {
        evals += 1;
        rhs(t, y, dy);
    };
    let mut y = [0.0; 7];
    y[3] = PI;
    let n = y.len();
    let mut stepper = Dop853::new(n);
    let mut ctl = Controller::default();
    let (mut k1, mut y_new, mut k_new) = ([0.0; 7], [0.0; 7], [0.0; 7]);
    let (mut w1, mut w2) = ([0.0; 7], [0.0; 7]);
    f(0.0, &y, &mut k1);
    let mut h = initial_step(&mut f, 0.0, &y, &k1, Dop853::ORDER, tol, T_END, &mut w1, &mut w2)?;
    let mut t = 0.0;
    while t < T_END {
        let last = t + h >= T_END * (1.0 - 1e-15);
        if last {
            h = T_END - t;
        }
        let err = stepper.attempt(&mut f, t, &y, &k1, h, tol, &mut y_new, &mut k_new)?;
        let (accepted, h_next) = ctl.next::<Dop853>(err, h);
        if !accepted {
            h = h_next;
            continue;
        }
        let t_new = if last { T_END } else { t + h };
        f(t_new, &y_new, &mut k_new);
        y = y_new;
        k1 = k_new;
        t = t_new;
        h = h_next;
    }
    Ok((y, evals))
}

/// The reference's `q, qd` (the last data row of a `trajectory.csv`).
fn reference(path: &str) -> Result<[f64; 12], String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read the reference {path}: {e}"))?;
    let rows: Vec<&str> = text.lines().filter(|l| !l.is_empty() && !l.starts_with('#')).collect();
    let names: Vec<&str> = rows.first().ok_or(format!("{path}: no header"))?.split(',').collect();
    let values: Vec<f64> = rows[1..]
        .last()
        .ok_or(format!("{path}: no data row"))?
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("{path}: `{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    let want = ["x1", "y1", "phi1", "x2", "y2", "phi2", "x1d", "y1d", "phi1d", "x2d", "y2d", "phi2d"];
    let mut r = [0.0; 12];
    for (slot, name) in r.iter_mut().zip(want) {
        let k = names.iter().position(|n| *n == name).ok_or(format!("{path}: no column {name}"))?;
        *slot = *values.get(k).ok_or(format!("{path}: the last row has no {name}"))?;
    }
    Ok(r)
}

fn main() -> Result<(), String> {
    let (mut rtol, mut atol, mut reps, mut ref_path) = (1e-11, None, 21usize, None);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        let number = |v: String| v.parse::<f64>().map_err(|e| format!("{a} {v}: {e}"));
        match a.as_str() {
            "--rtol" => rtol = number(value()?)?,
            "--atol" => atol = Some(number(value()?)?),
            "--reps" => reps = value()?.parse().map_err(|e| format!("--reps: {e}"))?,
            "--ref" => ref_path = Some(value()?),
            _ => return Err(format!("unknown option {a} (--rtol R, --atol A, --reps N, --ref FILE)")),
        }
    }
    let tol = Tolerance { rtol, atol: atol.unwrap_or(rtol) };
    let reference = reference(ref_path.as_deref().unwrap_or("reference.csv"))?;
    let mut times = Vec::with_capacity(reps.max(1));
    let mut result = None;
    for _ in 0..reps.max(1) {
        let clock = std::time::Instant::now();
        let r = std::hint::black_box(integrate(&tol).map_err(|e| e.to_string())?);
        times.push(clock.elapsed().as_secs_f64());
        result = Some(r);
    }
    let (y, evals) = result.expect("at least one repetition");
    times.sort_by(f64::total_cmp);
    let error = full_state(&y).iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    println!(
        "Rust hand-written (ezy-core's DOP853),reduced ODE (Kane/Maggi; 7 states),{rtol:.0e},{evals},{:.6e},{error:.3e}",
        times[times.len() / 2]
    );
    Ok(())
}
