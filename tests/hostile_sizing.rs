//! Requests sized before anything is allocated for them, inputs read with
//! a bound, and messages that say what happened (issue 38): huge grids,
//! batch and repeat counts, family sizes, `/dev/zero` and FIFOs as
//! inputs, a snake of 30,000 links without projection, and the messages
//! testers found misleading. Every hostile case runs the binary under a
//! memory cap and a timeout, so a regression fails the test instead of
//! swapping the machine or hanging.

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use ezy::App;

/// Virtual memory the hostile runs may take \[KiB\]: 4 GB.
const MEMORY_KB: u64 = 4_000_000;

/// The binary under `ulimit -v MEMORY_KB`, in `dir`.
fn capped(dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!("ulimit -v {MEMORY_KB}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_ezy"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Waits for `child` at most `limit`; kills it and fails if it takes longer.
fn wait_at_most(mut child: Child, limit: Duration, what: &str) -> Output {
    let start = Instant::now();
    while child.try_wait().expect("try_wait").is_none() {
        if start.elapsed() > limit {
            child.kill().ok();
            child.wait().ok();
            panic!("`ezy {what}` did not finish within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().expect("output")
}

/// Runs `args` under the memory cap, for at most `secs` seconds.
fn bounded(dir: &Path, args: &[&str], secs: u64) -> Output {
    let child = capped(dir, args).spawn().expect("spawn");
    wait_at_most(child, Duration::from_secs(secs), &args.join(" "))
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Refused (exit 1, or 2 for a bad command line) with a message holding
/// every one of `want`.
fn refused(o: &Output, want: &[&str]) -> String {
    let e = stderr(o);
    assert!(matches!(o.status.code(), Some(1 | 2)), "{:?}: {e}", o.status);
    for w in want {
        assert!(e.contains(w), "`{w}` missing from: {e}");
    }
    e
}

/// Runs `args` through the library; the printed text or the error.
fn cli(args: &[&str]) -> Result<String, String> {
    let mut out = Vec::new();
    let argv = std::iter::once("ezy").chain(args.iter().copied());
    App::new().run_cli(argv, &mut out).map(|()| String::from_utf8_lossy(&out).into_owned()).map_err(|e| e.to_string())
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Whether `text` holds a run of `n` digits (a number printed whole).
fn has_digits(text: &str, n: usize) -> bool {
    let mut run = 0;
    for c in text.chars() {
        run = if c.is_ascii_digit() { run + 1 } else { 0 };
        if run >= n {
            return true;
        }
    }
    false
}

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(s(path)).unwrap();
    // SAFETY: a valid C string; mkfifo(3) only creates the node.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "mkfifo");
}

/// A grid axis of 2^40 (or a billion) values is not built: the sweep
/// gets past its plan at once (to a bad metric, checked next); one value
/// more than 2^40 is refused naming the flag, the count and the limit.
/// Before, the axis was materialized: a billion values climbed for over
/// a minute, 2^40 aborted on an 8 TB allocation.
#[test]
fn grid_axes_are_counted_not_built() {
    let dir = tempfile::tempdir().unwrap();
    for count in ["1099511627776", "1000000000"] {
        let grid = format!("M0=0:1:{count}");
        let o = bounded(dir.path(), &["sweep", "drive", "--grid", &grid, "--metric", "mean(nope)", "--out", "s"], 60);
        refused(&o, &["metric `mean(nope)`: the trajectory has no column `nope`"]);
    }
    let o = bounded(dir.path(), &["sweep", "drive", "--grid", "M0=0:1:1099511627777", "--out", "s"], 60);
    refused(&o, &["--grid `M0=0:1:1099511627777`: COUNT 1099511627777 is more than 1099511627776"]);
    let o =
        bounded(dir.path(), &["sweep", "drive", "--grid", "M0=0:1:1e7", "--grid", "omega=1:2:1e7", "--out", "s"], 60);
    refused(&o, &["the sweep has 100000000000000 runs (M0 (10000000) x omega (10000000)), more than 1099511627776"]);
    assert!(!dir.path().join("s").exists());
}

/// `ezy scale --batches` and `ezy bench --repeat` have limits, checked
/// when the command line is read: the message names the flag, the value
/// and the limit. Before, `--batches 1000000000000` aborted on its
/// allocation (and `1e12` was "invalid digit"), and `--repeat 1e12` ran
/// silently (in effect a thousand repeats of every setting).
#[test]
fn batches_and_repeats_are_capped() {
    let dir = tempfile::tempdir().unwrap();
    for batches in ["1e12", "1000000000000"] {
        let o = bounded(dir.path(), &["scale", "snake", "--n", "10", "--batches", batches], 60);
        refused(&o, &[&format!("invalid value '{batches}' for '--batches"), "is more than 1000, the most batches"]);
    }
    let o = bounded(dir.path(), &["bench", "--repeat", "1e12", "--no-process"], 60);
    refused(&o, &["invalid value '1e12' for '--repeat", "is more than 100, the most runs per setting"]);
    let o = bounded(dir.path(), &["scale", "snake", "--n", "1e18"], 60);
    refused(&o, &["invalid value '1e18' for '--n", "is more than 1000000"]);
}

/// A sweep over family sizes sets up the model at each size before its
/// first run: the sizes' elements are summed arithmetically and refused
/// above the limit, naming the axis. Before, a million sizes were set up
/// one by one, silently, for hours.
#[test]
fn family_sizes_are_summed_before_any_model_is_built() {
    let dir = tempfile::tempdir().unwrap();
    let o = bounded(dir.path(), &["sweep", "snake", "--grid", "N=1:1000000:1000000", "--out", "s"], 60);
    refused(&o, &["--grid N=1:1000000:1000000: the sweep's family sizes come to 5.000005e11 elements", "limit of 1e7"]);
    assert!(!dir.path().join("s").exists());
}

/// An overlay or a scene that is a device or a FIFO is refused at once
/// (not read, not waited on), and an overlay larger than its cap is
/// refused without being read. Before, `--overlay /dev/zero` and a FIFO
/// never returned.
#[test]
fn devices_fifos_and_huge_files_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let o = bounded(dir.path(), &["precision", "drive", "--replot", "--overlay", "/dev/zero", "--out", "p"], 30);
    refused(&o, &["--overlay /dev/zero: the overlay file must be a regular file, and this is a character device"]);
    let o = bounded(dir.path(), &["run", "/dev/zero", "--out", "r"], 30);
    refused(&o, &["/dev/zero: the scene file must be a regular file, and this is a character device"]);
    let fifo = dir.path().join("pipe.toml");
    mkfifo(&fifo);
    let o = bounded(dir.path(), &["run", s(&fifo), "--out", "r"], 30);
    refused(&o, &["pipe.toml: the scene file must be a regular file, and this is a FIFO (named pipe)"]);
    let o = bounded(dir.path(), &["precision", "drive", "--replot", "--overlay", s(&fifo), "--out", "p"], 30);
    refused(&o, &["the overlay file must be a regular file, and this is a FIFO (named pipe)"]);
    // a sparse file of 33 MiB: its size alone refuses it
    let big = dir.path().join("big.csv");
    std::fs::File::create(&big).unwrap().set_len(33 << 20).unwrap();
    let o = bounded(dir.path(), &["precision", "drive", "--replot", "--overlay", s(&big), "--out", "p"], 30);
    refused(&o, &["the overlay file is larger than 32 MiB"]);
    assert!(!dir.path().join("r").exists() && !dir.path().join("p").exists());
}

/// `--projection none` builds no projection workspace: a snake of 30,000
/// links (about 90,000 constraint rows) sets up and runs under a 4 GB
/// cap. Before, the dense normal systems (nc x nc) asked for 64 GB.
#[test]
fn no_projection_allocates_no_projection_workspace() {
    let dir = tempfile::tempdir().unwrap();
    let o = bounded(
        dir.path(),
        &["run", "snake", "--set", "N=30000", "--projection", "none", "--t-end", "1e-4", "--no-figures", "--out", "sn"],
        300,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("projection none (none)"));
}

/// An interrupted run names the time it reached, not the time of the
/// first sample still queued for output. Before, a run with a long
/// output interval said "interrupted at t = 0 s" however far it was.
#[test]
fn an_interrupted_run_names_the_time_reached() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let child =
        capped(dir.path(), &["run", "drive", "--t-end", "5000", "--every", "1000", "--no-figures", "--out", s(&out)])
            .spawn()
            .expect("spawn");
    // the table's header in the run's private directory: the run is set up
    // and its signals are handled
    let start = Instant::now();
    let started = || {
        std::fs::read_dir(&out).into_iter().flatten().flatten().any(|e| {
            e.file_name().to_string_lossy().starts_with(".ezy-run.")
                && std::fs::read_dir(e.path()).into_iter().flatten().flatten().next().is_some()
        })
    };
    while !started() {
        assert!(start.elapsed() < Duration::from_secs(30), "the run never started");
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: kill(2) with the pid of a child this test spawned and has not
    // reaped (`sh` exec'd the program, so the pid is ezy's).
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) }, 0);
    let o = wait_at_most(child, Duration::from_secs(30), "run drive (interrupted)");
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(130), "{e}");
    let t: f64 = e
        .strip_prefix("error: interrupted (SIGINT) at t = ")
        .and_then(|r| r.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no time in: {e}"));
    assert!(t > 0.0 && t < 5000.0, "{e}");
}

/// A sweep directory whose table has another header names the first
/// column that differs. Before: "found 24 columns, expected 24".
#[test]
fn a_foreign_sweep_header_names_the_column() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sw");
    let args =
        ["sweep", "drive", "--list", "M0=1,2", "--t-end", "0.01", "--jobs", "1", "--no-figures", "--out", s(&out)];
    cli(&args).unwrap();
    let csv = out.join("sweep.csv");
    let text = std::fs::read_to_string(&csv).unwrap().replacen("steps", "stepz", 1);
    std::fs::write(&csv, text).unwrap();
    let e = cli(&args).unwrap_err();
    assert!(e.contains("its header is not this sweep's (column 5 is `stepz`, this sweep's is `steps`)"), "{e}");
}

/// A loop of symbolic links is named as such (which link, what ezy was
/// doing), not as the system's "Too many levels of symbolic links".
#[test]
fn link_loops_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("loop");
    std::os::unix::fs::symlink(&link, &link).unwrap();
    let inside = link.join("out");
    for (args, doing) in [
        (vec!["run", s(&link)], "cannot read the scene file"),
        (vec!["run", "drive", "--t-end", "0.01", "--out", s(&inside)], "cannot create output directory"),
        (vec!["precision", "drive", "--replot", "--overlay", s(&link)], "cannot read the overlay file"),
    ] {
        let e = cli(&args).unwrap_err();
        assert!(e.contains(doing), "{args:?}: {e}");
        assert!(e.contains(&format!("{} is a symbolic link that leads back to itself", link.display())), "{e}");
        assert!(!e.contains("Too many levels"), "{e}");
    }
}

/// A metric whose column function nests another is reported whole, with
/// what is wrong. Before: "`norm(x1` is not a column name".
#[test]
fn a_nested_metric_is_reported_whole() {
    let dir = tempfile::tempdir().unwrap();
    let o = s(dir.path());
    let e =
        cli(&["sweep", "drive", "--list", "M0=1", "--metric", "max(norm(norm(x1, y1), x2))", "--out", o]).unwrap_err();
    assert!(
        e.contains("`norm(norm(x1, y1), x2)`: the argument `norm(x1, y1)` of norm is a function; functions of columns do not nest"),
        "{e}"
    );
    let e = cli(&["sweep", "drive", "--list", "M0=1", "--metric", "max(norm(x1d, y1d)", "--out", o]).unwrap_err();
    assert!(e.contains("metric `max(norm(x1d, y1d)`: a `(` is not closed"), "{e}");
}

/// Numbers in messages are written short (`1e300`), never as hundreds
/// of digits.
#[test]
fn huge_numbers_are_written_short() {
    let dir = tempfile::tempdir().unwrap();
    let o = s(dir.path());
    for args in [
        vec!["run", "snake", "--set", "N=1e300", "--out", o],
        vec!["sweep", "drive", "--grid", "M0=1e300:-1e300:1", "--out", o],
        vec!["run", "drive", "--dt", "1e300", "--no-figures", "--out", o],
        vec!["animate", "drive", "--fps", "1e300", "--out", "x.gif"],
        vec!["equations", "snake", "--set", "N=1e300"],
    ] {
        let e = cli(&args).unwrap_err();
        assert!(e.contains("1e300") && !has_digits(&e, 20), "{args:?}: {e}");
    }
}

/// A grid or a random axis between finite bounds whose difference
/// overflows gives finite values. Before, `--grid M0=-1e308:1e308:3`
/// failed with "M0 = NaN".
#[test]
fn finite_bounds_give_finite_values() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g");
    let text =
        cli(&["sweep", "drive", "--grid", "M0=-1e308:1e308:3", "--t-end", "0.001", "--jobs", "1", "--out", s(&out)])
            .unwrap();
    assert!(text.contains("3 runs"), "{text}");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let m0: Vec<f64> = csv.lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse().unwrap()).collect();
    assert_eq!(m0, [-1e308, 0.0, 1e308]);
    let out = dir.path().join("r");
    let text = cli(&[
        "sweep",
        "drive",
        "--random",
        "M0=-1.7e308:1.7e308",
        "--samples",
        "3",
        "--t-end",
        "0.001",
        "--jobs",
        "1",
        "--out",
        s(&out),
    ])
    .unwrap();
    assert!(text.contains("3 runs"), "{text}");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert!(csv.lines().skip(1).all(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap().is_finite()), "{csv}");
}

/// `ezy precision --replot` without a saved ladder names the flag and
/// the file, not a scene key.
#[test]
fn replot_without_a_ladder_names_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let e = cli(&["precision", "drive", "--replot", "--out", s(dir.path())]).unwrap_err();
    assert!(e.starts_with("--replot redraws the figures from the precision.csv"), "{e}");
    assert!(e.contains("precision.csv: cannot read a precision.csv: No such file"), "{e}");
    assert!(!e.contains("scene key"), "{e}");
}

/// An initial state whose kinetic energy overflows is blamed on the
/// scene's initial values, naming the velocity, whatever the method and
/// formulation.
/// Before, Euler without projection advised a smaller --dt.
#[test]
fn an_infinite_initial_state_is_not_blamed_on_the_step() {
    let dir = tempfile::tempdir().unwrap();
    let drive = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/drive.toml")).unwrap();
    let scene = dir.path().join("fast.toml");
    std::fs::write(&scene, drive.replace("qd = { x1 = 0.0, phi1 = 0.0 }", "qd = { x1 = 1e160, phi1 = 0.0 }")).unwrap();
    for (method, formulation) in [("euler", "dae"), ("rk4", "dae"), ("dop853", "dae"), ("dop853", "reduced")] {
        let e = cli(&[
            "run",
            s(&scene),
            "--integrator",
            method,
            "--formulation",
            formulation,
            "--projection",
            "none",
            "--t-end",
            "0.01",
            "--out",
            s(&dir.path().join("o")),
        ])
        .unwrap_err();
        assert!(e.starts_with("at t = 0 s the kinetic energy T became inf; the initial velocity "), "{e}");
        assert!(e.contains("no step size helps") && !e.contains("smaller --dt"), "{e}");
    }
}

/// The library's `Problem::solve` keeps its samples in memory: a run whose
/// samples would take more than its budget (1,000 MB by default) is
/// refused before it starts, with the size and the setting that raises it
/// (it used to fill the memory and abort: `t_end(1e300)`, `every(1e-9)`).
#[test]
fn library_runs_size_their_samples_before_taking_memory() {
    use ezy::models::ChaplyginSleigh;
    use ezy_core::{Method, Problem, SimError};
    let sleigh = || {
        Problem::new(ChaplyginSleigh::default())
            .q("x", 0.0)
            .and_then(|p| p.q("y", 0.0))
            .and_then(|p| p.q("phi", 0.0))
            .and_then(|p| p.qd("x", 1.0))
            .and_then(|p| p.qd("phi", 1.0))
            .unwrap()
            .method(Method::Dop853)
    };
    let cases = [
        (sleigh().t_end(1e300), "1e302 samples of 6 values to t_end = 1e300 s", "no budget makes this feasible"),
        // (the setting spelled as the library's field, or as the command
        // line's flag where a test in this process ran the command line)
        (sleigh().t_end(10.0).every(1e-9), "1e10 samples", "max_output_mb` to 881000"),
    ];
    for (p, rows, advice) in cases {
        match p.solve() {
            Err(e @ SimError::Budget { .. }) => {
                let text = e.to_string();
                assert!(text.contains(rows) && text.contains("MB of samples in memory"), "{text}");
                let flag = advice.replace("max_output_mb` to", "--max-output-mb");
                assert!(text.contains(advice) || text.contains(&flag), "{text}");
            }
            other => panic!("expected a budget error, got {:?}", other.map(|s| s.t.len())),
        }
    }
    // a budget given is kept; within it the run goes on
    let s = sleigh().t_end(1.0).every(1e-4).max_output_mb(10.0).solve().unwrap();
    assert!((10_001..=10_002).contains(&s.t.len()), "{}", s.t.len());
    assert!(matches!(sleigh().t_end(1.0).every(1e-5).max_output_mb(1.0).solve(), Err(SimError::Budget { .. })));
}

/// The analyses solve and differentiate densely: a snake of 10,000 links
/// (30,000 coordinates) asked 7 GB and more of `linearize` and `analyze`,
/// which aborted. Under a 4 GB cap both are refused with the size, before
/// any matrix is taken.
#[test]
fn analyses_size_their_dense_matrices_first() {
    let dir = tempfile::tempdir().unwrap();
    for command in ["linearize", "analyze"] {
        let o = bounded(dir.path(), &[command, "snake", "--set", "N=10000", "--out", "an"], 300);
        let err = refused(&o, &["dense matrices", "GB each", "a family's size"]);
        assert!(!err.contains("memory allocation"), "{command}: {err}");
    }
    assert!(!dir.path().join("an").exists());
}

/// A family count the scene accepts can still make a model too large to
/// set up: the snake at N = 1,000,000 (3,000,000 coordinates, about 13 GB)
/// aborted `ezy equations` (and the Python interpreter through
/// `ezy.equations`), `run` and `sweep` under a 4 GB cap after 25 s of
/// set-up. Each is refused at once with the size, by the count's name;
/// a sweep runs its other rows.
#[test]
fn a_model_too_large_to_set_up_is_refused_by_its_count() {
    let dir = tempfile::tempdir().unwrap();
    let want = ["N = 1000000 gives 3000000 generalized coordinates", "13.2 GB"];
    for args in [
        &["equations", "snake", "--set", "N=1000000"][..],
        &["run", "snake", "--set", "N=1000000", "--out", "r"],
        &["analyze", "snake", "--set", "N=1000000", "--out", "a"],
    ] {
        let o = bounded(dir.path(), args, 60);
        let err = refused(&o, &want);
        assert!(!err.contains("memory allocation"), "{args:?}: {err}");
    }
    let o = bounded(dir.path(), &["sweep", "snake", "--list", "N=5,1000000", "--t-end", "0.01", "--out", "s"], 60);
    let csv = std::fs::read_to_string(dir.path().join("s/sweep.csv")).unwrap_or_else(|e| panic!("{e}: {}", stderr(&o)));
    assert!(csv.lines().count() == 3 && csv.contains("3000000 generalized coordinates"), "{csv}");
    assert!(!dir.path().join("r").exists() && !dir.path().join("a").exists());
}
