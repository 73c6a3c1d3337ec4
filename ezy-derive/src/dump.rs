//! `EZY_DUMP_EXPANSION=DIR`: every expansion of `model!` written to
//! `DIR/CRATE.MODEL.N.rs` (its `to_string()`), for a refactoring of the
//! macro to prove that the generated code did not change (dump before,
//! dump after, `diff -r`). Cargo does not track the variable: a crate is
//! dumped only when it is compiled again (after a change to this crate,
//! every dependent is). A model whose minimal form eliminates positions
//! through a `HashMap` walk (`minimal::frame_velocities`) may number its
//! bindings differently from one compilation to the next (the map's
//! random order): compare such a model's expansions as a set, or run
//! both versions of the macro with a fixed-key hasher.

use proc_macro2::TokenStream;

/// Writes `out`, the expansion of the model `name`, where
/// `EZY_DUMP_EXPANSION` says, if it is set: `N` counts from 0 past the
/// files of other expansions of the same name in the same crate (the
/// same expansion again, as a crate's library and its tests make, is
/// written once).
pub fn dump(name: &str, out: &TokenStream) {
    let Some(dir) = std::env::var_os("EZY_DUMP_EXPANSION") else { return };
    let krate = std::env::var("CARGO_CRATE_NAME").unwrap_or_default();
    let text = out.to_string();
    let dir = std::path::Path::new(&dir);
    let _ = std::fs::create_dir_all(dir);
    for n in 0.. {
        let path = dir.join(format!("{krate}.{name}.{n}.rs"));
        match std::fs::read_to_string(&path) {
            Ok(old) if old == text => return,
            Ok(_) => continue,
            Err(_) => {
                let _ = std::fs::write(&path, &text);
                return;
            }
        }
    }
}
