//! The output directory under attack: concurrent runs, planted symbolic
//! links, SIGINT, SIGTERM and SIGHUP during the run, SIGINT during the figures, a run
//! killed outright, failing figures, a failing commit, a full disk and a
//! coordinate plotters cannot draw. Every case checks the invariants: the
//! exit status and message, the previous output byte-identical (or one
//! complete new set), nothing outside the output directory touched, and no
//! temporary left behind.
#![cfg(unix)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common;
use common::DRIVE_FIGURES;

fn ezy() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ezy"))
}

fn run(args: &[&str]) -> Output {
    ezy().args(args).output().expect("ezy runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("ezy-adversarial-").tempdir().expect("scratch dir")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Every entry of `dir`: a file's bytes, a link's target, or a directory.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(dir).expect("read dir") {
        let e = e.unwrap();
        let t = e.file_type().unwrap();
        let v = if t.is_symlink() {
            format!("link -> {}", std::fs::read_link(e.path()).unwrap().display()).into_bytes()
        } else if t.is_dir() {
            b"<dir>".to_vec()
        } else {
            std::fs::read(e.path()).unwrap()
        };
        out.insert(e.file_name().to_string_lossy().into_owned(), v);
    }
    out
}

/// No temporary of any run is left in `dir`.
fn assert_no_temporaries(dir: &Path) {
    for name in snapshot(dir).keys() {
        assert!(
            !name.starts_with(".ezy-run.") && !name.ends_with(".partial") && !name.ends_with(".tmp.png"),
            "temporary {name} left in {}",
            dir.display()
        );
        assert!(!name.starts_with('.') || name == ".ezy.lock", "unexpected hidden file {name}");
    }
}

/// A short drive run into `dir` (the previous output of most cases).
fn previous_output(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let o = run(&["run", "drive", "--t-end", "0.5", "--out", s(dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    snapshot(dir)
}

/// The rows of a CSV: every row has the header's number of fields and `t`
/// strictly increases.
fn check_csv(text: &str) -> Vec<Vec<f64>> {
    let mut lines = text.lines();
    let n = lines.next().expect("header").split(',').count();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            let r: Vec<f64> = l.split(',').map(|v| v.parse().expect("a number")).collect();
            assert_eq!(r.len(), n, "ragged row {l}");
            r
        })
        .collect();
    assert!(rows.windows(2).all(|w| w[1][0] > w[0][0]), "time does not increase");
    rows
}

/// Waits for `child` at most `limit`; kills it and fails if it takes longer.
fn wait_at_most(mut child: Child, limit: Duration) -> Output {
    let start = Instant::now();
    while child.try_wait().expect("try_wait").is_none() {
        if start.elapsed() > limit {
            child.kill().ok();
            child.wait().ok();
            panic!("ezy did not finish within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.wait_with_output().expect("output")
}

/// The private directory of the run writing into `dir`, once it holds a
/// file named by `ready` (polled every millisecond, for at most 20 s).
fn wait_for_private_file(dir: &Path, ready: impl Fn(&str, u64) -> bool) {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(20) {
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().starts_with(".ezy-run.")
                    && let Ok(files) = std::fs::read_dir(e.path())
                {
                    for f in files.flatten() {
                        let len = f.metadata().map_or(0, |m| m.len());
                        if ready(&f.file_name().to_string_lossy(), len) {
                            return;
                        }
                    }
                }
            }
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    panic!("the run never wrote the expected file into its private directory");
}

fn signal(child: &Child, sig: i32) {
    // SAFETY: kill(2) with the pid of a child this test spawned and has not
    // reaped yet.
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, sig) };
    assert_eq!(rc, 0, "kill failed");
}

fn killed_by(status: ExitStatus) -> Option<i32> {
    use std::os::unix::process::ExitStatusExt;
    status.signal()
}

#[test]
fn concurrent_runs_into_one_directory_never_interleave() {
    let root = scratch();
    let dir = root.path().join("same");
    // eight runs at once, each with its own final time so that the CSV
    // tells which run it is from
    let children: Vec<(String, Child)> = (0..8)
        .map(|k| {
            let t_end = format!("0.5{k}");
            let child = ezy()
                .args(["run", "drive", "--t-end", &t_end, "--out", s(&dir)])
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .expect("spawn");
            (t_end, child)
        })
        .collect();
    let mut succeeded = Vec::new();
    for (t_end, child) in children {
        let o = wait_at_most(child, Duration::from_secs(60));
        if o.status.success() {
            succeeded.push(t_end);
        } else {
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{e}");
            assert!(e.contains(&format!("another ezy run is writing into {}", dir.display())), "{e}");
        }
    }
    assert!(!succeeded.is_empty(), "no run succeeded");
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let rows = check_csv(&csv);
    let t_last = rows.last().unwrap()[0];
    let winner = succeeded
        .iter()
        .find(|t| (t.parse::<f64>().unwrap() - t_last).abs() < 1e-9)
        .unwrap_or_else(|| panic!("the CSV ends at t = {t_last}, which no successful run has ({succeeded:?})"));
    // the figures are the winner's: the same run into a fresh directory
    // gives the same bytes for every file
    let reference = root.path().join("reference");
    let o = run(&["run", "drive", "--t-end", winner, "--out", s(&reference)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(snapshot(&dir), snapshot(&reference), "the directory holds a mixed set");
    assert_no_temporaries(&dir);
}

#[test]
fn planted_symbolic_links_are_never_followed() {
    use std::os::unix::fs::symlink;
    let root = scratch();
    let outside = root.path().join("outside");
    std::fs::create_dir(&outside).unwrap();
    let victim = outside.join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let victim_dir = outside.join("victim-dir");
    std::fs::create_dir(&victim_dir).unwrap();
    std::fs::write(victim_dir.join("keep.txt"), b"keep").unwrap();
    let dir = root.path().join("out");
    std::fs::create_dir(&dir).unwrap();
    // every name an ezy run writes or wrote: the final names, the old fixed
    // temporary names, a private-directory name
    let mut names: Vec<String> = vec!["trajectory.csv".into(), "trajectory.csv.partial".into()];
    for f in DRIVE_FIGURES {
        names.push(f.into());
        names.push(format!(".{f}.tmp.png"));
        names.push(format!("{f}.partial"));
    }
    for n in &names {
        symlink(&victim, dir.join(n)).unwrap();
    }
    symlink(&victim_dir, dir.join(".ezy-run.planted")).unwrap();
    let o = run(&["run", "drive", "--t-end", "0.5", "--out", s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert_eq!(snapshot(&victim_dir).len(), 1);
    assert_eq!(std::fs::read(victim_dir.join("keep.txt")).unwrap(), b"keep");
    for f in std::iter::once("trajectory.csv").chain(DRIVE_FIGURES) {
        let m = std::fs::symlink_metadata(dir.join(f)).unwrap();
        assert!(m.is_file(), "{f} is not a regular file");
    }
    check_csv(&std::fs::read_to_string(dir.join("trajectory.csv")).unwrap());

    // a linked lock file: refused, nothing written, the target untouched
    let dir2 = root.path().join("out2");
    std::fs::create_dir(&dir2).unwrap();
    symlink(&victim, dir2.join(".ezy.lock")).unwrap();
    let before = snapshot(&dir2);
    let o = run(&["run", "drive", "--t-end", "0.5", "--out", s(&dir2)]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains(".ezy.lock") && e.contains("symbolic link"), "{e}");
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert_eq!(snapshot(&dir2), before);
}

/// A long run into `dir` over a previous output, stopped by `sig` once its
/// CSV has grown; returns the run's output.
fn interrupt_long_run(dir: &Path, sig: i32) -> Output {
    let child = ezy()
        .args(["run", "drive", "--t-end", "1000", "--dt", "1e-5", "--out", s(dir)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    wait_for_private_file(dir, |name, len| name == "trajectory.csv" && len > 100_000);
    signal(&child, sig);
    wait_at_most(child, Duration::from_secs(20))
}

#[test]
fn sigint_sigterm_and_sighup_during_the_run_leave_the_previous_output() {
    let root = scratch();
    let dir = root.path().join("out");
    let before = previous_output(&dir);
    for (sig, name, code) in
        [(libc::SIGINT, "SIGINT", 130), (libc::SIGTERM, "SIGTERM", 143), (libc::SIGHUP, "SIGHUP", 129)]
    {
        let start = Instant::now();
        let o = interrupt_long_run(&dir, sig);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{e}");
        assert!(e.starts_with(&format!("error: interrupted ({name}) at t = ")), "{e}");
        assert!(e.contains(&format!("; previous output in {} left as it was", dir.display())), "{e}");
        assert_eq!(snapshot(&dir), before, "{name} changed the previous output");
        assert_no_temporaries(&dir);
        assert!(start.elapsed() < Duration::from_secs(20));
    }
}

#[test]
fn sigint_during_the_figures_leaves_the_previous_output() {
    // 40 figures of 24 lines over 20,000 rows: seconds of drawing, and the
    // first figure in the run's private directory shows the figures began
    let drive = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/drive.toml")).unwrap();
    let columns =
        "x1,y1,phi1,x2,y2,phi2,x1d,y1d,phi1d,x2d,y2d,phi2d,T,W,W_motor,A.x,A.y,B1.x,B1.y,B2.x,B2.y,C.x,C.y,tau_motor";
    let lines: Vec<String> = columns.split(',').map(|c| format!("{{ label = \"{c}\", y = \"{c}\" }}")).collect();
    let mut scene = drive.clone();
    for k in 0..40 {
        scene.push_str(&format!(
            "\n[[figures]]\nfile = \"many{k:02}.png\"\ntitle = \"all columns {k}\"\nx_label = \"t [s]\"\ny_label = \"values\"\nlines = [{}]\n",
            lines.join(", ")
        ));
    }
    let root = scratch();
    let file = root.path().join("many-figures.toml");
    std::fs::write(&file, scene).unwrap();
    let dir = root.path().join("out");
    let before = previous_output(&dir);
    let child = ezy()
        .args(["run", s(&file), "--t-end", "200", "--every", "0.01", "--out", s(&dir)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    wait_for_private_file(&dir, |name, _| name.ends_with(".png"));
    signal(&child, libc::SIGINT);
    let o = wait_at_most(child, Duration::from_secs(30));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(e.starts_with("error: interrupted (SIGINT) at t = 200 s, drawing "), "{e}");
    assert_eq!(snapshot(&dir), before);
    assert_no_temporaries(&dir);
}

#[test]
fn a_second_signal_ends_the_run_at_once_and_the_next_run_cleans_up() {
    let root = scratch();
    let dir = root.path().join("out");
    let before = previous_output(&dir);
    let child = ezy()
        .args(["run", "drive", "--t-end", "1000", "--dt", "1e-5", "--out", s(&dir)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    wait_for_private_file(&dir, |name, len| name == "trajectory.csv" && len > 0);
    signal(&child, libc::SIGINT);
    signal(&child, libc::SIGINT);
    let o = wait_at_most(child, Duration::from_secs(10));
    // either the first signal's clean stop won the race or the second one
    // ended the process with SIGINT's default action
    assert!(o.status.code() == Some(130) || killed_by(o.status) == Some(libc::SIGINT), "{:?}", o.status);

    // SIGKILL leaves the private directory; the next run removes it
    let child = ezy()
        .args(["run", "drive", "--t-end", "1000", "--dt", "1e-5", "--out", s(&dir)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    wait_for_private_file(&dir, |name, len| name == "trajectory.csv" && len > 0);
    signal(&child, libc::SIGKILL);
    let o = wait_at_most(child, Duration::from_secs(10));
    assert_eq!(killed_by(o.status), Some(libc::SIGKILL));
    assert_eq!(snapshot(&dir).keys().filter(|n| n.starts_with(".ezy-run.")).count(), 1);
    let mut previous = snapshot(&dir);
    previous.retain(|n, _| !n.starts_with(".ezy-run."));
    assert_eq!(previous, before);
    let o = run(&["run", "drive", "--t-end", "0.5", "--out", s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(snapshot(&dir), before);
}

/// `drive.toml` with `extra` appended (more figures).
fn drive_with(extra: &str, root: &Path, name: &str) -> PathBuf {
    let drive = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/drive.toml")).unwrap();
    let path = root.join(name);
    std::fs::write(&path, format!("{drive}\n{extra}")).unwrap();
    path
}

#[test]
fn a_failing_figure_or_commit_leaves_the_previous_output() {
    let root = scratch();
    let dir = root.path().join("out");
    let before = previous_output(&dir);
    let figure = |file: &str| {
        format!(
            "[[figures]]\nfile = \"{file}\"\ntitle = \"t\"\nx_label = \"t [s]\"\ny_label = \"T [J]\"\nlines = [{{ label = \"T\", y = \"T\" }}]\n"
        )
    };
    let long = format!("{}.png", "a".repeat(300));
    // a duplicate or over-long name is the scene file's mistake: refused
    // at its line before any work
    let cases = [
        (
            drive_with(&figure("fig4_speed.png"), root.path(), "duplicate.toml"),
            "duplicate.toml:96:8: `figures[7].file`: `fig4_speed.png`: another figure of this scene writes that file",
        ),
        (
            drive_with(&figure("fig4_speed.svg"), root.path(), "same-stem.toml"),
            "same-stem.toml:96:8: `figures[7].file`: `fig4_speed.svg`: another figure of this scene writes that file",
        ),
        (
            drive_with(&figure(&long), root.path(), "long.toml"),
            "a figure file name has at most 200 bytes, this one 304",
        ),
        (
            drive_with(&figure(".hidden.png"), root.path(), "hidden.toml"),
            "hidden.toml:96:8: `figures[7].file`: `.hidden.png`: a figure file name must not start with `.`",
        ),
    ];
    for (scene, message) in &cases {
        let o = run(&["run", s(scene), "--t-end", "0.5", "--out", s(&dir)]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        assert!(e.contains(message), "{e}");
        assert_eq!(snapshot(&dir), before, "{}", scene.display());
        assert_no_temporaries(&dir);
    }
    // a directory where a figure belongs: the commit is refused before any
    // file is replaced
    std::fs::remove_file(dir.join("residuals.png")).unwrap();
    std::fs::create_dir(dir.join("residuals.png")).unwrap();
    std::fs::write(dir.join("residuals.png").join("x"), b"x").unwrap();
    let before = snapshot(&dir);
    let o = run(&["run", "drive", "--t-end", "0.7", "--out", s(&dir)]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("residuals.png: is a directory"), "{e}");
    assert_eq!(snapshot(&dir), before);
    assert_no_temporaries(&dir);
}

/// A tmpfs of `size` mounted at a fresh directory, unmounted on drop.
struct Tmpfs {
    at: PathBuf,
    _root: tempfile::TempDir,
}

impl Tmpfs {
    fn mount(size: &str) -> Result<Self, String> {
        let root = scratch();
        let at = root.path().join("mnt");
        std::fs::create_dir(&at).unwrap();
        let o = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs", s(&at)])
            .output()
            .map_err(|e| format!("cannot run mount: {e}"))?;
        if o.status.success() { Ok(Self { at, _root: root }) } else { Err(stderr(&o).trim().to_string()) }
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.at).status();
    }
}

#[test]
fn a_full_disk_leaves_the_previous_output() {
    let fs = match Tmpfs::mount("64k") {
        Ok(fs) => fs,
        Err(why) => {
            println!("skipped: no tmpfs to fill ({why}; mounting one needs root)");
            return;
        }
    };
    let dir = fs.at.join("out");
    // the previous output: a small CSV without figures (28 kB)
    let o = run(&["run", "drive", "--t-end", "0.5", "--no-figures", "--out", s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = snapshot(&dir);
    // the figures (about 100 kB each) do not fit
    let o = run(&["run", "drive", "--t-end", "0.5", "--out", s(&dir)]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains(&format!("{}/fig", dir.display())) && e.contains("No space left on device"), "{e}");
    assert_eq!(snapshot(&dir), before);
    assert_no_temporaries(&dir);
    // nor does a long CSV
    let o = run(&["run", "drive", "--t-end", "20", "--no-figures", "--out", s(&dir)]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains(&format!("{}: No space left on device", dir.join("trajectory.csv").display())), "{e}");
    assert_eq!(snapshot(&dir), before);
    assert_no_temporaries(&dir);
}

#[test]
fn a_coordinate_near_1e300_is_refused_before_drawing() {
    let sleigh = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/scenes/sleigh.toml")).unwrap();
    let root = scratch();
    let dir = root.path().join("out");
    let o = run(&["run", "sleigh", "--t-end", "0.5", "--out", s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = snapshot(&dir);
    for x in ["1e300", "-1.7e308"] {
        let text = sleigh.replace("q = { x = 0.0,", &format!("q = {{ x = {x},"));
        assert_ne!(text, sleigh);
        let file = root.path().join("huge.toml");
        std::fs::write(&file, text).unwrap();
        let start = Instant::now();
        let child = ezy()
            .args(["run", s(&file), "--t-end", "0.5", "--out", s(&dir)])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        let o = wait_at_most(child, Duration::from_secs(20));
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        let value: f64 = x.parse().unwrap();
        assert!(
            e.contains("figure paths.png: column `x` is ")
                && e.contains(&format!("{value:e}"))
                && e.contains("too large"),
            "{e}"
        );
        assert!(start.elapsed() < Duration::from_secs(5), "took {:?}", start.elapsed());
        assert_eq!(snapshot(&dir), before);
        assert_no_temporaries(&dir);
    }
}

#[test]
fn a_held_lock_refuses_run_and_precision_and_precision_is_a_transaction_too() {
    use std::os::unix::fs::symlink;
    let root = scratch();
    let dir = root.path().join("out");
    let o = run(&["precision", "free", "--out", s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = snapshot(&dir);
    for f in ["precision.csv", "work_precision.png", "drift.png", ".ezy.lock"] {
        assert!(before.contains_key(f), "{f} missing");
    }
    // another process (this test) holds the lock
    let lock = std::fs::File::open(dir.join(".ezy.lock")).unwrap();
    lock.try_lock().expect("the lock is free");
    for args in [&["precision", "free"][..], &["run", "free", "--t-end", "0.1"][..]] {
        let o = run(&[args, &["--out", s(&dir)]].concat());
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        assert!(e.contains(&format!("another ezy run is writing into {}", dir.display())), "{e}");
        assert_eq!(snapshot(&dir), before);
    }
    drop(lock);
    // precision's files replace planted links without following them
    let victim = root.path().join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    for f in ["precision.csv", "precision.csv.partial", "drift.png", ".drift.png.tmp.png"] {
        let _ = std::fs::remove_file(dir.join(f));
        symlink(&victim, dir.join(f)).unwrap();
    }
    let o = run(&["precision", "free", "--out", s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert!(std::fs::symlink_metadata(dir.join("precision.csv")).unwrap().is_file());
}
