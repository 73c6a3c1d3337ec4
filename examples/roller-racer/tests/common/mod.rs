//! What the tests share, in one place: a renamed copy of this crate edits
//! the `use` below and nothing else in `tests/`.

#![allow(dead_code, unused_imports, reason = "each test file uses a part")]

use std::path::PathBuf;
use std::process::Command;

/// This crate's library, as the tests name it.
pub use roller_racer as vehicle;
pub use vehicle::SCENE;

/// The number of the scene the sweep test varies (a `--set` key: the
/// amplitude of the drive `steer`).
pub const SWEPT: &str = "steer.amplitude";

/// This package's program (`target/<profile>/<package name>`, built by
/// cargo for the integration tests), found from the test's own path, so
/// no test spells the package's name.
pub fn program() -> Command {
    let exe = std::env::current_exe().expect("the test's path");
    let profile = exe.parent().and_then(|deps| deps.parent()).expect("target/<profile>/deps/<test>");
    Command::new(profile.join(format!("{}{}", env!("CARGO_PKG_NAME"), std::env::consts::EXE_SUFFIX)))
}

/// A fresh directory for a test's output, under cargo's temporary directory.
pub fn out_dir(what: &str) -> PathBuf {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{what}", env!("CARGO_PKG_NAME")));
    let _ = std::fs::remove_dir_all(&out);
    out
}
