//! The Python package's test suite (`python/tests/test_*.py`), run by
//! pytest against the `ezy` module this build made (see `runner.rs`).

mod runner;

#[test]
fn pytest_suite() {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    runner::run("ezy_python", "ezy", &here.join("tests"), here.parent().expect("the workspace"));
}
