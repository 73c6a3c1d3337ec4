//! Runs a pytest suite against an extension module that this `cargo test`
//! has just built: shared by `python/tests/pytest.rs` and
//! `examples/python-module/tests/pytest.rs`.
//!
//! The module's library (`target/PROFILE/libNAME.so`) is copied as
//! `MODULE.abi3.so` into a temporary directory on `PYTHONPATH`, which is
//! what a wheel installs; pytest runs in `target/python-venv`, created on
//! first use with `python/requirements-test.txt` (pinned), reinstalled
//! when that file changes. Without a Python 3.9+ that can make a venv, or
//! without PyPI, the test prints why and skips, unless `CI=true` (then it
//! fails); a suite that collects no test fails.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The profile directory of the running test binary (`target/release`).
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.parent().and_then(Path::parent).expect("target/PROFILE/deps/TEST").to_path_buf()
}

/// Whether a missing prerequisite (Python, PyPI) fails the test rather
/// than skipping it: on CI, which must test the Python package.
fn required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// Skips (prints why) or, on CI, fails.
fn skip(why: &str) {
    assert!(!required(), "CI=true: {why}");
    eprintln!("skipped: {why}");
}

/// A Python 3.9 or later, or why there is none.
fn python() -> Result<String, String> {
    let python = std::env::var("EZY_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = Command::new(&python)
        .args(["-c", "import sys, venv; sys.exit(0 if sys.version_info >= (3, 9) else 1)"])
        .output();
    match probe {
        Ok(o) if o.status.success() => Ok(python),
        Ok(_) => Err(format!("`{python}` is older than 3.9 or lacks the venv module")),
        Err(e) => Err(format!("no `{python}` to run: {e}")),
    }
}

/// The venv with the suite's requirements, made or updated under a lock;
/// `Err` says why it cannot be made (no network for pip).
fn venv(python: &str, target: &Path, requirements: &Path) -> Result<PathBuf, String> {
    let dir = target.join("python-venv");
    std::fs::create_dir_all(target).expect("the target directory");
    let lock = std::fs::File::create(target.join("python-venv.lock")).expect("the venv's lock file");
    lock.lock().expect("lock the venv");
    let wanted = std::fs::read_to_string(requirements).expect("python/requirements-test.txt");
    let stamp = dir.join("ezy-requirements.txt");
    let bin = dir.join("bin").join("python");
    if std::fs::read_to_string(&stamp).ok().as_deref() != Some(wanted.as_str()) || !bin.exists() {
        eprintln!("creating {} with {}", dir.display(), requirements.display());
        let ok = Command::new(python).args(["-m", "venv", "--clear"]).arg(&dir).status().expect("python -m venv");
        if !ok.success() {
            return Err(format!("`{python} -m venv {}` failed", dir.display()));
        }
        let ok = Command::new(&bin)
            .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "-r"])
            .arg(requirements)
            .status()
            .expect("pip");
        if !ok.success() {
            return Err(format!("pip install -r {} failed (is PyPI reachable?)", requirements.display()));
        }
        std::fs::write(&stamp, wanted).expect("the venv's stamp");
    }
    Ok(bin)
}

/// Runs the pytest files in `tests` against the library `lib` (its
/// Cargo name) imported as `module`; `workspace` is the repository root.
pub fn run(lib: &str, module: &str, tests: &Path, workspace: &Path) {
    let python = match python() {
        Ok(p) => p,
        Err(why) => return skip(&format!("the Python tests of `{module}` need Python 3.9+ with venv: {why}")),
    };
    let profile = profile_dir();
    let file = if cfg!(target_os = "macos") { format!("lib{lib}.dylib") } else { format!("lib{lib}.so") };
    // `cargo build` puts it in the profile directory; `cargo test` leaves
    // it in deps/ (built for the test, not uplifted)
    let built = [profile.join(&file), profile.join("deps").join(&file)]
        .into_iter()
        .filter(|p| p.exists())
        .max_by_key(|p| p.metadata().and_then(|m| m.modified()).ok())
        .unwrap_or_else(|| panic!("{file} was not built in {}: run `cargo test` on the workspace", profile.display()));
    let stage = tempfile::tempdir().expect("a staging directory");
    std::fs::copy(&built, stage.path().join(format!("{module}.abi3.so"))).expect("stage the module");
    let target = profile.parent().expect("target/");
    let bin = match venv(&python, target, &workspace.join("python").join("requirements-test.txt")) {
        Ok(bin) => bin,
        Err(why) => return skip(&format!("the Python tests of `{module}` need their packages: {why}")),
    };
    let out = Command::new(&bin)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-W", "error::DeprecationWarning"])
        .arg(tests)
        .env("PYTHONPATH", stage.path())
        .env("MPLBACKEND", "Agg")
        .env("EZY_BIN_DIR", &profile)
        .env("EZY_WORKSPACE", workspace)
        .current_dir(stage.path())
        .output()
        .expect("pytest");
    let stdout = String::from_utf8_lossy(&out.stdout);
    print!("{stdout}");
    eprint!("{}", String::from_utf8_lossy(&out.stderr));
    // pytest's exit status 5: no test collected, which fails here too
    assert!(out.status.success(), "pytest on {} failed ({})", tests.display(), out.status);
    assert!(stdout.contains(" passed"), "pytest on {} ran no test", tests.display());
}
