//! An observer that reads a window of the output grid
//! ([`Observer::wants`], [`Observer::next_wanted`]) gets exactly the rows
//! a full run writes there, bit for bit, and is asked about the rows
//! outside it a handful of times, not once per row.

use std::cell::Cell;

use crate::common::{Recorder, build};
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Formulation, Method, Model, Observer, RunSettings, Sample, simulate};
use ezy_models::{EzyRoller, scenes};

/// Keeps the samples in `[t0, t1]` (and the run's first and last, which
/// are always observed), counting how often it is asked.
struct Window {
    t0: f64,
    t1: f64,
    jump: bool,
    asked: Cell<usize>,
    rows: Recorder,
}

impl<M: Model> Observer<M> for Window {
    type Error = std::convert::Infallible;
    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.rows.observe(sys, s)
    }
    fn wants(&self, t: f64) -> bool {
        self.asked.set(self.asked.get() + 1);
        t >= self.t0 && t <= self.t1
    }
    fn next_wanted(&self, t: f64) -> f64 {
        match (self.jump, t < self.t0, t > self.t1) {
            (false, ..) => t,
            (true, true, _) => self.t0,
            (true, _, true) => f64::INFINITY,
            (true, false, false) => t,
        }
    }
}

fn settings(method: Method, formulation: Formulation) -> RunSettings {
    RunSettings {
        dt: 1e-3,
        t_end: 6.0,
        every: 0.01,
        projection: ezy_core::ProjectionKind::MassWeighted,
        method,
        formulation,
        rtol: 1e-9,
        atol: 1e-9,
        balance_limit: None,
        max_steps: None,
    }
}

#[test]
fn a_window_observer_gets_the_full_runs_rows_and_is_asked_rarely() {
    let (t0, t1) = (2.0, 2.5);
    let runs =
        [(Method::Dop853, Formulation::Auto), (Method::Dopri5, Formulation::Dae), (Method::Rk4, Formulation::Auto)];
    for (method, formulation) in runs {
        let s = settings(method, formulation);
        let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &[], KktMethod::Schur).unwrap();
        let mut full = Recorder::default();
        simulate(&mut sys, &y0, &s, &mut full).unwrap();
        let mut asked = Vec::new();
        for jump in [false, true] {
            let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &[], KktMethod::Schur).unwrap();
            let mut w = Window { t0, t1, jump, asked: Cell::new(0), rows: Recorder::default() };
            simulate(&mut sys, &y0, &s, &mut w).unwrap();
            // the window's rows, the first and the last, as the full run has them
            let kept: Vec<usize> = (0..full.t.len())
                .filter(|&i| i == 0 || i + 1 == full.t.len() || (full.t[i] >= t0 && full.t[i] <= t1))
                .collect();
            assert_eq!(w.rows.t.len(), kept.len(), "{method:?} {formulation:?} jump {jump}");
            for (k, &i) in kept.iter().enumerate() {
                assert_eq!(w.rows.t[k].to_bits(), full.t[i].to_bits(), "{method:?} row {k}");
                assert!(
                    w.rows.y[k].iter().zip(&full.y[i]).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{method:?} {formulation:?} at t = {}: {:?} against {:?}",
                    full.t[i],
                    w.rows.y[k],
                    full.y[i]
                );
            }
            asked.push(w.asked.get());
        }
        // without `next_wanted` every refused row (all but the first, the
        // last and the window's) is asked about; with it, the window's
        // rows (twice where a step holds one: is its dense output needed,
        // then the row) and the first refused row before and after it
        let window = full.t.iter().filter(|&&t| t >= t0 && t <= t1).count();
        let refused = full.t.len() - 2 - window;
        assert!(asked[0] >= refused, "{method:?}: asked {} times without next_wanted, {refused} refused", asked[0]);
        assert!(asked[1] <= 2 * window + 4, "{method:?}: asked {} times with next_wanted, {window} wanted", asked[1]);
    }
}

/// Keeps nothing but what the step loop always observes.
struct Nothing(Recorder);

impl<M: Model> Observer<M> for Nothing {
    type Error = std::convert::Infallible;
    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.0.observe(sys, s)
    }
    fn wants(&self, _t: f64) -> bool {
        false
    }
    fn next_wanted(&self, _t: f64) -> f64 {
        f64::INFINITY
    }
}

#[test]
fn the_final_row_is_observed_when_the_grid_rounds_below_the_end() {
    // 30 x 0.03 = 0.8999999999999999 < 0.9: the grid's last row is the
    // final one, and an observer that wants no row still gets it (a
    // sweep's `final(...)` read the start here once)
    for (method, formulation) in [(Method::Dop853, Formulation::Auto), (Method::Radau5, Formulation::Dae)] {
        let s = RunSettings { t_end: 0.9, every: 0.03, ..settings(method, formulation) };
        assert!(30.0 * s.every < s.t_end);
        let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &[], KktMethod::Schur).unwrap();
        let mut full = Recorder::default();
        simulate(&mut sys, &y0, &s, &mut full).unwrap();
        let (mut sys, y0) = build::<EzyRoller>(&scenes::drive(), &[], KktMethod::Schur).unwrap();
        let mut none = Nothing(Recorder::default());
        simulate(&mut sys, &y0, &s, &mut none).unwrap();
        let (last, got) = (full.t.len() - 1, &none.0);
        assert!(full.t[last] > 0.9 * (1.0 - 1e-12), "{method:?}: {:?}", full.t);
        assert_eq!(got.t.len(), 2, "{method:?}: the first and the final row, got {:?}", got.t);
        assert_eq!(got.t[1].to_bits(), full.t[last].to_bits(), "{method:?}");
        assert!(got.y[1].iter().zip(&full.y[last]).all(|(a, b)| a.to_bits() == b.to_bits()), "{method:?}");
    }
}
