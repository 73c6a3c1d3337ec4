//! Requests every command refuses by name before any work: a repeated
//! name in a repeatable flag, a second command into an output directory
//! one is working in, a body without a positive mass, and a fixed step
//! that cannot follow a scene's forcing or its skate friction.
#![cfg(unix)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn ezy(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("ezy runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("ezy-refusals-").tempdir().expect("scratch dir")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Every file under `dir` (recursively) with its bytes, the private
/// directories of a run at work (`.ezy-run.*`) aside.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if e.file_name().to_string_lossy().starts_with(".ezy-run.") {
                continue;
            }
            if p.is_dir() {
                todo.push(p);
            } else {
                out.insert(p.clone(), std::fs::read(&p).unwrap_or_default());
            }
        }
    }
    out
}

/// `ezy ARGS` refused (exit 1) with a message containing every one of
/// `needles`.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = ezy(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {e}{}", String::from_utf8_lossy(&o.stdout));
    for n in needles {
        assert!(e.contains(n), "{args:?}: `{n}` not in: {e}");
    }
    e
}

/// A flag that names something, given one name twice, is refused naming
/// the flag and the name, before anything is written: `--input` of
/// `linearize` (it gave two equal columns of B), `--set` of every
/// command, `--over` of `fit` and `optimize`, `--wrt` of `analyze` and
/// `sensitivity`.
#[test]
fn a_name_given_twice_in_a_repeatable_flag_is_refused() {
    let root = scratch();
    let out = root.path().join("out");
    let o = s(&out);
    let cases: &[(&[&str], &str)] = &[
        (&["linearize", "drive", "--input", "tau_B", "--input", "tau_B"], "--input: `tau_B` is given twice"),
        (&["run", "drive", "--set", "m1=2", "--set", "m1=3"], "--set: `m1` is given twice (--set m1=2 and --set m1=3)"),
        (&["linearize", "drive", "--set", "M0=1", "--set", " M0=1"], "--set: `M0` is given twice"),
        (
            &["optimize", "drive", "--maximize", "final(x1)", "--over", "M0=1:3", "--over", "M0=0.5:4"],
            "--over: `M0` is given twice",
        ),
        (&["sensitivity", "drive", "--wrt", "M0,M0"], "--wrt: `M0` is given twice"),
        (
            &["fit", "drive", "--data", "nowhere.csv", "--columns", "x1,x1", "--over", "M0=1:3"],
            "--columns: `x1` is given twice",
        ),
        (&["analyze", "sleigh", "--wrt", "a", "--wrt", "a"], "--wrt: `a` is given twice"),
    ];
    for (args, needle) in cases {
        refused(&[args, &["--out", o][..]].concat(), &[needle]);
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}

/// A command refused after it took its output directory's lock (the
/// request checked against the scene: a formulation a sensitivity run
/// does not take, a motion on which a skate slides) leaves no directory
/// behind: it was an empty directory holding `.ezy.lock`.
#[test]
fn a_refusal_after_the_lock_leaves_no_directory() {
    let root = scratch();
    let out = root.path().join("new/out");
    let o = s(&out);
    let cases: &[(&[&str], &str)] = &[
        (&["sensitivity", "drive", "--wrt", "M0", "--baumgarte", "10,10"], "Baumgarte stabilization"),
        (&["analyze", "drive-slip", "--no-figures"], "skate `C` slides"),
    ];
    for (args, needle) in cases {
        refused(&[args, &["--out", o][..]].concat(), &[needle]);
        assert!(!root.path().join("new").exists(), "{args:?} left {}", out.display());
    }
}

/// Whether another process holds the lock of output directory `dir`.
fn lock_held(dir: &Path) -> bool {
    std::fs::File::open(dir.join(".ezy.lock"))
        .is_ok_and(|f| matches!(f.try_lock(), Err(std::fs::TryLockError::WouldBlock)))
}

/// Starts `ezy ARGS --out OUT` (work of minutes), waits until it holds
/// the lock of `dir` (OUT, or the directory OUT is in), and returns it.
fn working(args: &[&str], out: &Path, dir: &Path) -> Child {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ezy"))
        .args(args)
        .arg("--out")
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let deadline = Instant::now() + Duration::from_secs(20);
    while !lock_held(dir) {
        if let Some(status) = child.try_wait().unwrap() {
            let mut e = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut e).unwrap();
            panic!("{args:?} ended ({status}) without holding the lock of {} while it worked: {e}", dir.display());
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} did not hold the lock of {} while it worked (20 s)", dir.display());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child
}

/// Every command that commits into an output directory takes its lock
/// before its work and holds it to the commit: while one works, a second
/// into the same directory is refused at once naming the directory, and
/// nothing in it changes (before, `fit`, `sensitivity`, `optimize`,
/// `analyze`, `linearize`, `geometry`, `precision` and `animate` locked it
/// only at their commit, and the last commit silently won).
#[test]
fn a_command_working_in_a_directory_refuses_a_second_one_there() {
    let root = scratch();
    let data = root.path().join("data.csv");
    std::fs::write(&data, "t,x1\n1000,0.5\n2000,1\n").unwrap();
    let long: &[&[&str]] = &[
        &["run", "drive", "--t-end", "3000", "--no-figures"],
        &["linearize", "drive", "--at", "3000"],
        &["sensitivity", "drive", "--wrt", "M0", "--t-end", "3000", "--no-figures"],
        &["fit", "drive", "--data", s(&data), "--columns", "x1", "--over", "M0=1:3", "--no-figures"],
        &["optimize", "drive", "--maximize", "final(x1)", "--over", "M0=0.5:4", "--t-end", "3000", "--grid", "0"],
        &["analyze", "sleigh", "--t-end", "900", "--integrator", "rk4", "--dt", "1e-5", "--no-figures"],
        &["geometry", "--grid", "501", "--no-figures"],
        &["precision", "drive"],
        &["animate", "drive", "--t-end", "3000", "--speed", "100", "--fps", "5"],
    ];
    for (k, args) in long.iter().enumerate() {
        let dir = root.path().join(format!("out{k}"));
        // animate's --out is the GIF, in the directory it locks
        let out = if args[0] == "animate" { dir.join("a.gif") } else { dir.clone() };
        let mut first = working(args, &out, &dir);
        let before = snapshot(&dir);
        let started = Instant::now();
        let o = Command::new(env!("CARGO_BIN_EXE_ezy")).args(*args).arg("--out").arg(&out).output().unwrap();
        let e = stderr(&o);
        let _ = first.kill();
        let _ = first.wait();
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(e.contains(&format!("another ezy run is writing into {}", dir.display())), "{args:?}: {e}");
        assert!(started.elapsed() < Duration::from_secs(10), "{args:?} refused only after {:?}", started.elapsed());
        assert_eq!(snapshot(&dir), before, "{args:?} changed {}", dir.display());
    }
}

/// SIGINT while `sensitivity` or `fit` works (before anything is
/// written) stops it within seconds with exit code 130, saying so, and
/// the output directory it created goes again: the signal's default
/// action killed them, leaving the directory with its lock file.
#[test]
fn a_signal_stops_a_sensitivity_run_or_a_fit_and_leaves_no_directory() {
    let root = scratch();
    let data = root.path().join("data.csv");
    std::fs::write(&data, "t,x1\n1000,0.5\n2000,1\n").unwrap();
    let long: &[&[&str]] = &[
        &["sensitivity", "drive", "--wrt", "M0", "--t-end", "3000", "--no-figures"],
        &["fit", "drive", "--data", s(&data), "--columns", "x1", "--over", "M0=1:3", "--no-figures"],
    ];
    for (k, args) in long.iter().enumerate() {
        let dir = root.path().join(format!("new{k}/out"));
        let child = working(args, &dir, &dir);
        let started = Instant::now();
        // SAFETY: kill(2) with the pid of a child this test spawned and
        // has not reaped yet
        assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) }, 0);
        let o = child.wait_with_output().unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(130), "{args:?}: {e}");
        assert!(e.contains("interrupted (SIGINT)"), "{args:?}: {e}");
        assert!(started.elapsed() < Duration::from_secs(5), "{args:?} stopped after {:?}", started.elapsed());
        assert!(!root.path().join(format!("new{k}")).exists(), "{args:?} left {}", dir.display());
    }
}

/// A body's mass or inertia that is not a finite number > 0 is refused
/// naming the parameter and the body wherever a model is built without a
/// run's own check: `ezy geometry` (a mass of -46 kg gave `Gamma_u =
/// -0.022`, one of 0 an empty momentum.csv) and the library's
/// `Geometry::new`; a search (`optimize`, `fit`) whose bounds would build
/// such a body, before any run.
#[test]
fn a_body_without_a_positive_mass_or_inertia_is_refused_by_name() {
    use ezy::models::EzyRoller;
    use ezy_core::Model;
    use ezy_core::geometry::Geometry;
    let root = scratch();
    let out = root.path().join("out");
    let o = s(&out);
    for set in ["m1=-46", "m1=0", "I1=-1"] {
        let name = &set[..2];
        let what = if name == "m1" { "mass" } else { "inertia" };
        refused(&["geometry", "ezyroller", "--set", set, "--out", o], &[&format!("{name} ({what} of body body1)")]);
        assert!(!out.exists(), "geometry --set {set} wrote {}", out.display());
    }
    refused(
        &["optimize", "drive", "--maximize", "final(x1)", "--over", "m1=-1:50", "--t-end", "1", "--out", o],
        &["`m1=-1:50`", "m1 is the mass of body body1", "lower bound above 0"],
    );
    assert!(!out.exists());
    for value in [-46.0, 0.0, f64::NAN] {
        let mut m = EzyRoller::default();
        let k = m.info().params.iter().position(|p| p.name == "m2").unwrap();
        m.set_param(k, value);
        let Err(e) = Geometry::new(m, None, None) else { panic!("m2 = {value} accepted") };
        let e = e.to_string();
        assert!(e.contains("m2 (mass of body body2)"), "{value}: {e}");
    }
}

/// RK4 (and Euler) refuse, before any work, a forcing faster than their
/// fixed step samples: `drive`'s motor at omega = 1e5 rad/s with dt =
/// 1e-4 s (omega dt = 10 > pi) exited 0 with an aliased run; the message
/// names the effect, its frequency, the step and the step that would do.
/// Below the limit the run goes on; an adaptive method is not checked.
#[test]
fn a_fixed_step_refuses_a_forcing_past_its_nyquist_frequency() {
    let root = scratch();
    let out = root.path().join("out");
    let o = s(&out);
    let needles = ["effect `motor`", "omega = 100000 rad/s", "dt = 1e-4 s", "past pi", "below pi / omega = 3.14e-5 s"];
    for cmd in [&["run", "drive"][..], &["sensitivity", "drive", "--wrt", "M0"], &["linearize", "drive", "--at", "1"]] {
        let args = [cmd, &["--integrator", "rk4", "--set", "omega=1e5", "--t-end", "2", "--out", o]].concat();
        refused(&args, &needles);
        assert!(!out.exists(), "{cmd:?} wrote {}", out.display());
    }
    refused(&["run", "drive", "--integrator", "euler", "--set", "omega=4e4", "--t-end", "1", "--out", o], &["euler"]);
    for ok in [&["--integrator", "rk4", "--set", "omega=3e4"][..], &["--integrator", "dopri5", "--set", "omega=1e5"]] {
        let r = ezy(&[&["run", "drive", "--t-end", "0.01", "--no-figures", "--out", o][..], ok].concat());
        assert!(r.status.success(), "{ok:?}: {}", stderr(&r));
    }
    // the library's problem refuses it too
    let scene = ezy::models::scenes::get("drive");
    let (p, _) = scene.problem::<ezy::models::EzyRoller>(&[("omega".into(), 1e5)]).unwrap();
    let e = p.solve().unwrap_err().to_string();
    assert!(e.contains("effect `motor`") && e.contains("past pi"), "{e}");
}

/// A drive's prescribed angle is a forcing too: `drive-prescribed` (the
/// hinge angle `-pi + 0.3 sin(omega t)`) at omega = 1e5 rad/s under RK4
/// at dt = 1e-4 s ran and exited 0 (the check read the effects only);
/// now refused naming the drive and its frequency; at 1e3 it runs (at
/// 3e4, below pi / dt, the angle's acceleration 0.3 omega^2 breaks the
/// energy balance, which says so).
#[test]
fn a_fixed_step_refuses_a_drive_past_its_nyquist_frequency() {
    let root = scratch();
    let out = root.path().join("out");
    let o = s(&out);
    let scene = ezy::models::scenes::get("drive-prescribed");
    let key = scene.drives.first().expect("a drive").0.clone();
    let set = |w: &str| format!("{key}.angle.harmonics.1.omega={w}");
    let fast = set("1e5");
    let args =
        ["run", "drive-prescribed", "--integrator", "rk4", "--dt", "1e-4", "--set", &fast, "--t-end", "1", "--out", o];
    refused(&args, &[&format!("drive `{key}`"), "omega = 100000 rad/s", "past pi"]);
    assert!(!out.exists(), "wrote {}", out.display());
    let slow = set("1e3");
    let r = ezy(&[
        "run",
        "drive-prescribed",
        "--integrator",
        "rk4",
        "--dt",
        "1e-4",
        "--set",
        &slow,
        "--t-end",
        "0.01",
        "--no-figures",
        "--out",
        o,
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
}

/// RK4 (and Euler) refuse, before any work, a skate whose friction stops
/// the slide the run starts with faster than their fixed step is stable:
/// `sleigh-ice` at mu = 1e6 (a slide of 1.5 m/s stopped within 4e-8 s)
/// exited 0 with a 1.6e3 J gap in its energy ledger; the message names
/// the skate, its effect, the bound and the step that would do. At mu =
/// 1e3 (rate times step 0.5) RK4 runs and closes its ledger; an adaptive
/// method is not checked; friction that never acts is not refused.
#[test]
fn a_fixed_step_refuses_a_skate_friction_faster_than_its_stability_bound() {
    let root = scratch();
    let out = root.path().join("out");
    let o = s(&out);
    let needles =
        ["effect `slip_P`, key `mu`", "skate `P` starts sliding at 1.5 m/s", "stability bound 2.785", "--dt below"];
    for cmd in [&["run", "sleigh-ice"][..], &["sensitivity", "sleigh-ice", "--wrt", "slip_P.mu"]] {
        refused(&[cmd, &["--integrator", "rk4", "--set", "slip_P.mu=1e6", "--out", o]].concat(), &needles);
        assert!(!out.exists(), "{cmd:?} wrote {}", out.display());
    }
    refused(&["run", "sleigh-ice", "--integrator", "euler", "--set", "slip_P.mu=1e6", "--out", o], &["bound 2 "]);
    let r = ezy(&["run", "sleigh-ice", "--integrator", "rk4", "--set", "slip_P.mu=1e3", "--no-figures", "--out", o]);
    let said = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", stderr(&r));
    let gap: f64 = said.split("max |T - T0 - W| = ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(gap < 1e-8, "{said}");
    let r = ezy(&["run", "sleigh-ice", "--set", "slip_P.mu=1e6", "--no-figures", "--out", o]);
    assert!(r.status.success(), "dopri5: {}", stderr(&r));
    // the library's problem refuses it too
    let scene = ezy::models::scenes::get("sleigh-ice");
    let (p, _) = scene.problem::<ezy::models::ChaplyginSleigh>(&[("slip_P.mu".into(), 1e6)]).unwrap();
    let e = p.method(ezy_core::Method::Rk4).solve().unwrap_err().to_string();
    assert!(e.contains("skate `P`") && e.contains("2.785"), "{e}");
}

/// `ezy geometry` sizes the model before its rank tests, whose time grows
/// as the cube of the body count (issue 82: the snake at N = 3000 worked
/// for minutes before it was refused by its skates' rank): at once,
/// naming the count set and the limit.
#[test]
fn geometry_of_a_snake_too_long_is_refused_at_once() {
    let dir = scratch();
    let out = dir.path().join("geo");
    let start = Instant::now();
    let o = ezy(&["geometry", "snake", "--set", "N=3000", "--no-figures", "--out", s(&out)]);
    let took = start.elapsed();
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(took < Duration::from_secs(1), "refused after {took:?}: {err}");
    assert!(err.contains("N=3000") && err.contains("3000 bodies") && err.contains("400"), "{err}");
    assert!(!out.exists(), "nothing written");
}

/// A gait's steps are counted from its fastest harmonic before any work
/// (issue 82: `cos(1000000*t)` ran without bound), the refusal naming the
/// coordinate, the frequency and the count.
#[test]
fn a_gait_too_fast_to_integrate_is_refused_at_once() {
    let dir = scratch();
    let out = dir.path().join("geo");
    let start = Instant::now();
    let gait = "alpha1=0.9+0.3*cos(1000000*t),alpha2=-0.9+0.3*sin(t)";
    let o = ezy(&["geometry", "kinematic-snake", "--gait", gait, "--no-figures", "--out", s(&out)]);
    let took = start.elapsed();
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(took < Duration::from_secs(1), "refused after {took:?}: {err}");
    assert!(err.contains("alpha1") && err.contains("1e6 rad/s") && err.contains("2.0e7"), "{err}");
    // a slow one still runs
    let slow = "alpha1=0.9+0.3*cos(t),alpha2=-0.9+0.3*sin(t)";
    let o = ezy(&["geometry", "kinematic-snake", "--gait", slow, "--no-figures", "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// An initial heading is an angle, bounded as the waveforms' phases are
/// (issue 82: a heading of 1e17 was taken, and its rounding lost the
/// sleigh's turning); a scene file's value is refused at its key.
#[test]
fn an_initial_heading_past_the_angles_bound_is_refused() {
    let dir = scratch();
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/sleigh.toml")).unwrap();
    for (v, ok) in [("0.5", true), ("1e17", false), ("1e33", false), ("1e308", false)] {
        let path = dir.path().join(format!("sleigh{v}.toml"));
        std::fs::write(&path, text.replace("phi = 0.0 }", &format!("phi = {v} }}"))).unwrap();
        let out = dir.path().join(format!("out{v}"));
        let o = ezy(&["run", s(&path), "--t-end", "0.1", "--no-figures", "--out", s(&out)]);
        let err = stderr(&o);
        assert_eq!(o.status.success(), ok, "{v}: {err}");
        if !ok {
            assert!(err.contains("initial.q.phi") && err.contains("1e6"), "{v}: {err}");
        }
    }
}

/// `ezy check --states` is sized by states x coordinates before any state.
#[test]
fn a_check_of_too_many_states_is_refused_at_once() {
    let start = Instant::now();
    let o = ezy(&["check", "snake", "--set", "N=60", "--states", "100000000"]);
    let err = stderr(&o);
    assert!(!o.status.success() && start.elapsed() < Duration::from_secs(1), "{err}");
    assert!(err.contains("--states 100000000") && err.contains("1e8"), "{err}");
}

/// `--energy` is refused where `analyze` cannot honour it (it was
/// ignored: the pendulum's limit cycle and the rolling-resistance gait
/// came at the run's own energy), and kept where it picks a steady
/// motion: the sleigh's straight run at 2 J.
#[test]
fn an_energy_the_analysis_cannot_honour_is_refused() {
    let dir = scratch();
    let out = dir.path().join("out");
    refused(
        &["analyze", "pendulum", "--energy", "3", "--no-figures", "--out", s(&out)],
        &["--energy 3", "no symmetry", "equilibria"],
    );
    refused(
        &["analyze", "drive-rolling-resistance", "--energy", "3", "--no-figures", "--out", s(&out)],
        &["--energy 3", "forced with period 2 s"],
    );
    let o = ezy(&["analyze", "sleigh", "--energy", "2", "--no-figures", "--out", s(&out)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", stderr(&o));
    assert!(text.contains("steady"), "{text}");
}
