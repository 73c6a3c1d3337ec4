//! The seed's `drive` scene run `REPS` times with DOP853 as `ezy bench`
//! runs its fastest settings (through `AnyModel`, as the command line
//! runs every model), with output every `EVERY` seconds to an observer
//! that keeps the last state: the program `benches/peers/icount.sh`
//! counts instructions of (callgrind, inside `simulate` only) against the
//! C++ peer's integration.
//!
//! `cargo run --release -p ezy-models --example drive_runs -- REPS EVERY [dae]`
//! (`dae`: the DAE with projection at 1e-11; otherwise the reduced
//! formulation on minimal coordinates at 3e-11). Prints a checksum so
//! that no run is optimized away.
use ezy_core::{AnyModel, Dynamics, Formulation, Method, Model, Observer, ProjectionKind, RunSettings, Sample};
struct Last(Vec<f64>);
impl<M: Model> Observer<M> for Last {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.0.clear();
        self.0.extend_from_slice(s.q);
        self.0.push(s.residual_position + s.kinetic_energy);
        Ok(())
    }
}
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let reps: Option<usize> = a.get(1).and_then(|s| s.parse().ok()).filter(|&r| (1..=1000).contains(&r));
    let every: Option<f64> = a.get(2).and_then(|s| s.parse().ok()).filter(|&e: &f64| e > 0.0 && e.is_finite());
    let (Some(reps), Some(every)) = (reps, every) else {
        eprintln!("usage: drive_runs REPS EVERY [dae]  (REPS 1 to 1000, EVERY a positive number of seconds)");
        std::process::exit(2);
    };
    let form = if a.get(3).map(String::as_str) == Some("dae") { Formulation::Dae } else { Formulation::Reduced };
    let tol = if form == Formulation::Dae { 1e-11 } else { 3e-11 };
    let scene = ezy_models::scenes::drive();
    let proto = AnyModel::new(ezy_models::EzyRoller::default());
    let mut sum = 0.0;
    for _ in 0..reps {
        let (mut sys, y0, _) = scene.problem_with(proto.clone(), &[]).unwrap().0.into_system().unwrap();
        let base = scene.run_settings();
        let settings = RunSettings {
            every,
            projection: if form == Formulation::Dae { ProjectionKind::MassWeighted } else { ProjectionKind::None },
            method: Method::Dop853,
            formulation: form,
            rtol: tol,
            atol: tol,
            balance_limit: None,
            max_steps: None,
            ..base
        };
        let mut last = Last(Vec::new());
        let s = ezy_core::simulate(&mut sys, &y0, &settings, &mut last).unwrap();
        sum += last.0[0] + s.counters.rhs_evals as f64;
    }
    println!("{sum}");
}
