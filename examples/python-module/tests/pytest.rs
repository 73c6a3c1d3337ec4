//! The module's pytest suite (`tests/test_*.py`), run against the
//! `my_vehicles` module this build made.

#[path = "../../../python/tests/runner.rs"]
mod runner;

#[test]
fn pytest_suite() {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let workspace = here.join("../..");
    runner::run("my_vehicles", "my_vehicles", &here.join("tests"), &workspace);
}
