//! The step loop (RK4 and the adaptive methods, RADAU5's Newton
//! iterations and factorizations, KKT solve, projection, energy balance) does not
//! allocate: a run of 10,000 steps makes exactly as many heap allocations
//! as a run of 100 steps (only the fixed setup allocates).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use common::Numeric;
use common::build;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Formulation, Method, Model, Observer, ProjectionKind, RunSettings, Sample, simulate};
use ezy_models::{EzyRoller, scenes};

struct Counting;

thread_local! {
    /// Allocations made by this thread (the test harness allocates on others).
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Sums what it sees, without allocating.
struct Sink(f64);

impl<M: Model> Observer<M> for Sink {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.0 += s.kinetic_energy + s.residual_position;
        Ok(())
    }
}

fn allocations_for(t_end: f64, projection: ProjectionKind, kkt: KktMethod, method: Method) -> usize {
    allocations_with::<EzyRoller>(&[], t_end, projection, kkt, method, Formulation::Dae)
}

fn allocations_with<M: Model + Default>(
    sets: &[(String, f64)],
    t_end: f64,
    projection: ProjectionKind,
    kkt: KktMethod,
    method: Method,
    formulation: Formulation,
) -> usize {
    let (mut sys, y0) = build::<M>(&scenes::drive(), sets, kkt).unwrap();
    let settings = RunSettings {
        dt: 1e-4,
        t_end,
        every: 0.01,
        projection,
        method,
        formulation,
        rtol: 1e-9,
        atol: 1e-9,
        balance_limit: Some(1e-2),
        max_steps: None,
    };
    let mut sink = Sink(0.0);
    let before = allocations();
    let s = simulate(&mut sys, &y0, &settings, &mut sink).unwrap();
    let n = allocations() - before;
    assert!(s.steps > 0 && sink.0.is_finite());
    n
}

#[test]
fn the_step_loop_does_not_allocate() {
    for projection in [ProjectionKind::MassWeighted, ProjectionKind::Euclidean, ProjectionKind::None] {
        for kkt in [KktMethod::Schur, KktMethod::Lu] {
            for method in [Method::Euler, Method::Rk4, Method::Dopri5, Method::Dop853, Method::Radau5] {
                let short = allocations_for(0.01, projection, kkt, method);
                let long = allocations_for(2.0, projection, kkt, method);
                assert_eq!(
                    short, long,
                    "{projection:?}/{kkt:?}/{method:?}: 0.01 s allocates {short} times, 2 s {long} times"
                );
            }
        }
    }
}

/// The reduced formulation's expansions, on minimal coordinates (closed
/// form, Maggi's equations) and on a numeric partition (Newton step, LU of
/// `G_D`), and its step loop neither (the drive keeps its partition to
/// 60 s; a new partition, which allocates, is rare).
#[test]
fn the_reduced_formulation_does_not_allocate() {
    for method in [Method::Rk4, Method::Dopri5, Method::Dop853] {
        let f = (ProjectionKind::None, KktMethod::Auto, method, Formulation::Reduced);
        let minimal = |t_end| allocations_with::<EzyRoller>(&[], t_end, f.0, f.1, f.2, f.3);
        let numeric = |t_end| allocations_with::<Numeric<EzyRoller>>(&[], t_end, f.0, f.1, f.2, f.3);
        for (what, run) in [("minimal", &minimal as &dyn Fn(f64) -> usize), ("numeric", &numeric)] {
            let (short, long) = (run(0.01), run(2.0));
            assert_eq!(short, long, "{what} {method:?}: 0.01 s allocates {short} times, 2 s {long} times");
        }
    }
}

#[test]
fn the_singular_mass_path_does_not_allocate() {
    let sets = [("m2".to_string(), 0.0), ("I2".to_string(), 0.0)];
    for method in [Method::Rk4, Method::Dop853] {
        let short = allocations_with::<EzyRoller>(
            &sets,
            0.01,
            ProjectionKind::MassWeighted,
            KktMethod::Auto,
            method,
            Formulation::Dae,
        );
        let long = allocations_with::<EzyRoller>(
            &sets,
            1.0,
            ProjectionKind::MassWeighted,
            KktMethod::Auto,
            method,
            Formulation::Dae,
        );
        assert_eq!(short, long, "{method:?}: 0.01 s allocates {short} times, 1 s {long} times");
    }
}

/// The same for a model with families on the sparse paths (KKT and
/// projection): the snake scene with 20 links and its family effects.
#[test]
fn the_family_sparse_path_does_not_allocate() {
    let run = |t_end: f64| {
        let sets = [("N".to_string(), 20.0)];
        let (mut sys, y0) = build::<ezy_models::Snake>(&scenes::get("snake"), &sets, KktMethod::Auto).unwrap();
        assert_eq!(sys.kkt_name(), "sparse-cholesky");
        let settings = RunSettings {
            dt: 1e-3,
            t_end,
            every: 0.01,
            projection: ProjectionKind::MassWeighted,
            method: Method::Rk4,
            formulation: ezy_core::Formulation::Dae,
            rtol: 1e-9,
            atol: 1e-9,
            balance_limit: None,
            max_steps: None,
        };
        let mut sink = Sink(0.0);
        let before = allocations();
        let s = simulate(&mut sys, &y0, &settings, &mut sink).unwrap();
        assert!(
            s.steps > 0 && sink.0.is_finite() && s.projection_path == "normal-sparse-cholesky",
            "{}",
            s.projection_path
        );
        allocations() - before
    };
    let (short, long) = (run(0.01), run(1.0));
    assert_eq!(short, long, "0.01 s allocates {short} times, 1 s {long} times");
}

/// RADAU5 on the stiff snake: its Newton system on the sparse path (faer's
/// sparse LU, symbolic analysis once, numeric factors refreshed in place)
/// allocates nothing per step either.
#[test]
fn the_implicit_sparse_path_does_not_allocate() {
    let run = |t_end: f64| {
        let (mut sys, y0) = build::<ezy_models::SnakeServo>(&scenes::get("snake-stiff"), &[], KktMethod::Auto).unwrap();
        let settings = RunSettings {
            t_end,
            every: 0.01,
            balance_limit: None,
            max_steps: None,
            ..scenes::get("snake-stiff").run_settings()
        };
        assert_eq!(settings.method, Method::Radau5);
        let mut sink = Sink(0.0);
        let before = allocations();
        let s = simulate(&mut sys, &y0, &settings, &mut sink).unwrap();
        assert!(s.steps > 0 && s.newton.factorizations > 1 && sink.0.is_finite());
        allocations() - before
    };
    let (short, long) = (run(0.05), run(1.0));
    assert_eq!(short, long, "0.05 s allocates {short} times, 1 s {long} times");
}
