//! Links the `ezy` binary as a position-dependent executable on Linux.
//!
//! A position-independent executable (the toolchain's default) has its
//! 20,000 absolute addresses in tables (vtables, string tables of clap,
//! the scenes, the fonts' metadata) relocated by the dynamic loader at
//! every start, each touched page copied: 231 page faults for
//! `ezy --version` against 147 without, and 0.6 ms of a 2.5 ms start on a
//! 2-core virtual machine (README "Against other tools", where the whole
//! process is measured). The code itself is unchanged (it stays
//! position-independent; only the link differs), and only the binary is
//! linked so: the library, the tests and a user's own crate are not
//! touched. What is given up is the address randomization of the
//! executable's own image (the libraries, stack and heap are still
//! randomized).

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let env = std::env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    if os == "linux" && env == "gnu" {
        println!("cargo:rustc-link-arg-bin=ezy=-no-pie");
    }
}
