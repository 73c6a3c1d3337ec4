//! `ezy sweep` attacked as a cluster user would: hostile `--out` paths in
//! a Slurm script, `--emit-slurm` aimed at files it must not replace, a
//! huge `--jobs`, a signal while runs are under way, links planted where
//! `--save-runs` writes, a row deleted from `sweep.csv` before a resume,
//! and the modes of the tables under a umask. Everything runs the `ezy`
//! binary; no Slurm is needed (a fake `sbatch` records what it is given).

use std::ffi::OsStr;
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn ezy() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ezy"))
}

fn run<I: IntoIterator<Item = S>, S: AsRef<OsStr>>(args: I) -> Output {
    ezy().args(args).output().expect("ezy runs")
}

fn ok(o: &Output) -> String {
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{text}{}", String::from_utf8_lossy(&o.stderr));
    text
}

fn err(o: &Output) -> String {
    assert!(!o.status.success(), "should fail: {}", String::from_utf8_lossy(&o.stdout));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("hostile-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Waits for `child` at most `limit`; kills it (and fails) if it takes
/// longer, so that no test can hang.
fn wait_within(mut child: Child, limit: Duration, what: &str) -> Output {
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} did not return within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// `ezy ARGS` in a shell that first limits the address space to 2 GB
/// (glibc's arenas limited too): a `--jobs` that started its threads
/// anyway would fail to, not take the machine.
fn guarded(args: &[&str]) -> Command {
    let mut c = Command::new("sh");
    c.arg("-c").arg("ulimit -v 2000000; exec \"$0\" \"$@\"").arg(env!("CARGO_BIN_EXE_ezy")).args(args);
    c.env("MALLOC_ARENA_MAX", "2");
    c
}

/// The rows of a `sweep.csv` without its `wall_s` column (the one column
/// two runs of a sweep differ in), header first.
fn without_wall(path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let k = h.iter().position(|c| c == "wall_s").expect("wall_s");
    let mut rows = vec![h];
    rows.extend(r.records().map(|x| x.unwrap().iter().map(String::from).collect()));
    for row in &mut rows {
        row.remove(k);
    }
    rows
}

fn mode(path: &Path) -> u32 {
    std::fs::metadata(path).unwrap().permissions().mode() & 0o777
}

// ------------------------------------------------------------ 1. injection

/// A fake `sbatch` on `PATH`: writes its arguments (NUL-separated) to
/// `LOG/N` for the N-th call and prints a job id.
fn fake_sbatch(root: &Path) -> (PathBuf, PathBuf) {
    let bin = root.join("bin");
    let log = root.join("sbatch-calls");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::create_dir_all(&log).unwrap();
    let sbatch = bin.join("sbatch");
    std::fs::write(
        &sbatch,
        "#!/bin/sh\nn=$(ls \"$SBATCH_LOG\" | wc -l)\nprintf '%s\\0' \"$@\" > \"$SBATCH_LOG/$n\"\necho \"4$n;cluster\"\n",
    )
    .unwrap();
    std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    (bin, log)
}

#[test]
fn a_hostile_out_cannot_inject_into_the_slurm_script() {
    let root = dir("inject");
    let sweep = ["sweep", "drive", "--grid", "M0=1:2:3", "--t-end", "0.2", "--metric", "final(x1)"];
    // a newline cannot be held by an #SBATCH line or a comment: refused,
    // naming --out and the character, and nothing written
    let script = root.join("nl.sh");
    let out = root.join("x\ntouch pwned-nl");
    let mut a: Vec<&OsStr> = sweep.iter().map(OsStr::new).collect();
    a.extend([OsStr::new("--emit-slurm"), script.as_os_str(), OsStr::new("--out"), out.as_os_str()]);
    let e = err(&run(&a));
    assert!(e.contains("--out") && e.contains("a newline (U+000A)"), "{e}");
    assert!(!script.exists(), "a script with a newline in --out was written");

    // command substitution, a backtick, a single quote, a space and a `%`
    // (Slurm's pattern character): quoted, and the script runs as meant
    let out = root.join("a$(touch pwned-1)b`touch pwned-2`c it's 100%u");
    let script = root.join("sweep.sh");
    let mut a: Vec<&OsStr> = sweep.iter().map(OsStr::new).collect();
    a.extend([OsStr::new("--emit-slurm"), script.as_os_str(), OsStr::new("--tasks"), OsStr::new("2")]);
    a.extend([OsStr::new("--out"), out.as_os_str()]);
    ok(&run(&a));
    let text = std::fs::read_to_string(&script).unwrap();
    let syntax = Command::new("bash").arg("-n").arg(&script).output().unwrap();
    assert!(syntax.status.success(), "{}\n{text}", String::from_utf8_lossy(&syntax.stderr));
    // the #SBATCH line takes the path in Slurm's double quotes, `%` doubled
    let line = text.lines().find(|l| l.starts_with("#SBATCH --output=")).unwrap();
    let want = format!("#SBATCH --output=\"{}/slurm/task-%a.out\"", out.display().to_string().replace('%', "%%"));
    assert_eq!(line, want);
    // every shell line holds the path only inside single quotes
    for l in text.lines().filter(|l| !l.starts_with('#')) {
        assert!(!l.contains("$(touch") || l.contains("'"), "unquoted: {l}");
    }

    // submit with a fake sbatch, run both array tasks as Slurm would, then
    // the merge job's command as sbatch --wrap would (with sh)
    let (bin, log) = fake_sbatch(&root);
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let sub = Command::new("bash")
        .arg(&script)
        .current_dir(&root)
        .env("PATH", &path)
        .env("SBATCH_LOG", &log)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .output()
        .unwrap();
    assert!(sub.status.success(), "{}", String::from_utf8_lossy(&sub.stderr));
    assert!(String::from_utf8_lossy(&sub.stdout).contains("submitted array job 40 (2 tasks) and merge job 41"));
    let calls: Vec<Vec<String>> = (0..2)
        .map(|n| {
            let raw = std::fs::read(log.join(n.to_string())).unwrap();
            raw.split(|&b| b == 0).filter(|s| !s.is_empty()).map(|s| String::from_utf8_lossy(s).into()).collect()
        })
        .collect();
    assert_eq!(calls[0], ["--parsable", script.to_str().unwrap()]);
    let merge = &calls[1];
    assert!(merge.contains(&"--dependency=afterok:40".to_string()), "{merge:?}");
    let log_arg = format!("--output={}/slurm/merge.out", out.display().to_string().replace('%', "%%"));
    assert!(merge.contains(&log_arg), "{merge:?}");
    for k in 0..2 {
        let task = Command::new("bash")
            .arg(&script)
            .current_dir(&root)
            .env("SLURM_ARRAY_TASK_ID", k.to_string())
            .env("SLURM_CPUS_PER_TASK", "1")
            .output()
            .unwrap();
        assert!(task.status.success(), "task {k}: {}", String::from_utf8_lossy(&task.stderr));
    }
    let wrap = &merge[merge.iter().position(|a| a == "--wrap").unwrap() + 1];
    let m = Command::new("sh").arg("-c").arg(wrap).current_dir(&root).output().unwrap();
    assert!(m.status.success(), "{wrap}\n{}", String::from_utf8_lossy(&m.stderr));
    assert!(String::from_utf8_lossy(&m.stdout).contains("merged 2 shards: 3 runs"));
    assert_eq!(without_wall(&out.join("sweep.csv")).len(), 4);
    // nothing injected ran, anywhere
    for marker in ["pwned-nl", "pwned-1", "pwned-2"] {
        assert!(!root.join(marker).exists(), "{marker} was created");
    }
}

// ---------------------------------------------------- 2. what FILE replaces

fn emit(scene: &str, file: &Path, out: &Path) -> Output {
    let argv = ["sweep", scene, "--grid", "M0=1:2:2", "--t-end", "0.2", "--emit-slurm"];
    let mut c = ezy();
    c.args(argv).arg(file).arg("--out").arg(out).stdout(Stdio::piped()).stderr(Stdio::piped());
    wait_within(c.spawn().unwrap(), Duration::from_secs(30), "ezy sweep --emit-slurm")
}

#[test]
fn emit_slurm_replaces_only_its_own_script() {
    let root = dir("emit");
    let out = root.join("o");
    // the scene file itself
    let scene = root.join("scene.toml");
    let scene_text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("models/scenes/drive.toml")).unwrap();
    std::fs::write(&scene, &scene_text).unwrap();
    let e = err(&emit(scene.to_str().unwrap(), &scene, &out));
    assert!(e.contains("scene.toml") && e.contains("the sweep's scene file"), "{e}");
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), scene_text);

    // a file ezy did not write
    let notes = root.join("notes.txt");
    std::fs::write(&notes, "my notes\n").unwrap();
    let e = err(&emit("drive", &notes, &out));
    assert!(e.contains("notes.txt") && e.contains("not a Slurm script of ezy's"), "{e}");
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "my notes\n");

    // a FIFO: never opened (nothing could block), left a FIFO
    let fifo = root.join("fifo.sh");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo(3) on a NUL-terminated path
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    let e = err(&emit("drive", &fifo, &out));
    assert!(e.contains("fifo.sh") && e.contains("a FIFO"), "{e}");
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());

    // a device like /dev/null (made here, where replacing it harms
    // nothing; creating one needs root)
    let dev = root.join("null.sh");
    let c = std::ffi::CString::new(dev.to_str().unwrap()).unwrap();
    // SAFETY: mknod(2) on a NUL-terminated path, for /dev/null's numbers
    if unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) } == 0 {
        let e = err(&emit("drive", &dev, &out));
        assert!(e.contains("null.sh") && e.contains("a device"), "{e}");
        assert!(std::fs::symlink_metadata(&dev).unwrap().file_type().is_char_device());
    } else {
        println!("device case skipped: mknod needs root");
    }

    // a symbolic link: neither followed nor replaced
    let link = root.join("link.sh");
    std::os::unix::fs::symlink(&notes, &link).unwrap();
    let e = err(&emit("drive", &link, &out));
    assert!(e.contains("link.sh") && e.contains("symbolic link"), "{e}");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "my notes\n");

    // a new file, then the script ezy wrote there: replaced
    let file = root.join("sweep.sh");
    ok(&emit("drive", &file, &out));
    std::fs::write(&file, std::fs::read_to_string(&file).unwrap().replace("--t-end 0.2", "--t-end 0.1")).unwrap();
    ok(&emit("drive", &file, &out));
    assert!(std::fs::read_to_string(&file).unwrap().contains("--t-end 0.2"));
    assert!(!out.exists(), "--emit-slurm runs nothing");
}

// --------------------------------------------------- 3. jobs and signals

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

#[test]
fn a_huge_jobs_is_capped_to_the_machine() {
    let out = dir("jobs").join("o");
    let argv = ["sweep", "drive", "--list", "M0=1,2,3", "--t-end", "0.2", "--no-figures", "--jobs", "100000"];
    let mut c = guarded(&argv);
    c.arg("--out").arg(&out).stdout(Stdio::piped()).stderr(Stdio::piped());
    let o = wait_within(c.spawn().unwrap(), Duration::from_secs(60), "a sweep with --jobs 100000");
    let said = ok(&o);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let n = cores();
    assert!(stderr.contains(&format!("--jobs 100000 capped to {n}")), "{stderr}");
    assert!(said.contains("3 ran (0 failed)") && said.contains(&format!("on {n} jobs")), "{said}");
    let rows = without_wall(&out.join("sweep.csv"));
    assert_eq!(rows.len(), 4);
    assert!(rows[1..].iter().enumerate().all(|(k, r)| r[0] == k.to_string() && r[2] == "ok"), "{rows:?}");
}

/// A sweep of long runs sent SIGTERM a second after it started exits
/// within 3 s with 143, whatever `--jobs` asked, and its table holds only
/// whole rows in run order.
#[test]
fn sigterm_stops_a_sweep_within_a_second() {
    for jobs in ["2", "100000"] {
        let out = dir(&format!("signal-{jobs}")).join("o");
        // 400 runs of about 0.1 s (RK4 at 1e-4 s over 20 s)
        let argv = ["sweep", "drive", "--grid", "M0=1:2:400", "--t-end", "20", "--no-figures", "--jobs", jobs];
        let mut c = guarded(&argv);
        c.arg("--out").arg(&out).stdout(Stdio::null()).stderr(Stdio::piped());
        let child = c.spawn().unwrap();
        std::thread::sleep(Duration::from_secs(1));
        let sent = Instant::now();
        // SAFETY: kill(2) on the child's pid, which has not been waited for
        assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
        let o = wait_within(child, Duration::from_secs(10), "a sweep sent SIGTERM");
        let took = sent.elapsed();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(143), "--jobs {jobs}: {stderr}");
        assert!(took < Duration::from_secs(3), "--jobs {jobs}: exited {took:?} after SIGTERM");
        assert!(stderr.contains("interrupted (SIGTERM)"), "{stderr}");
        let text = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
        assert!(text.ends_with('\n'), "only whole rows");
        let rows = without_wall(&out.join("sweep.csv"));
        assert!(rows.len() < 401, "--jobs {jobs}: the sweep ran to its end");
        assert!(rows[1..].iter().enumerate().all(|(k, r)| r[0] == k.to_string() && r[2] == "ok"), "{rows:?}");
    }
}

/// SIGTERM once every row is in, while the sweep draws its 40 figures:
/// it stops before the next figure (exit 143), the table whole.
#[test]
fn sigterm_stops_the_figures_too() {
    let out = dir("signal-figures").join("o");
    let mut argv: Vec<String> =
        ["sweep", "drive", "--grid", "M0=1:2:2", "--list", "a=0.15,0.25", "--t-end", "0.2"].map(String::from).to_vec();
    for col in ["x1", "y1", "phi1", "x2", "y2", "phi2", "x1d"] {
        for f in ["final", "max", "min"] {
            if argv.len() < 8 + 2 * 20 {
                argv.extend(["--metric".into(), format!("{f}({col})")]);
            }
        }
    }
    argv.extend(["--jobs".into(), "1".into(), "--out".into(), out.display().to_string()]);
    let child = ezy().args(&argv).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let csv = out.join("sweep.csv");
    let start = Instant::now();
    // the first figure is there: the runs are done, the drawing under way
    while !out.join("sweep_1.png").exists() {
        assert!(start.elapsed() < Duration::from_secs(30), "no figure after 30 s");
        std::thread::sleep(Duration::from_millis(5));
    }
    // SAFETY: kill(2) on the child's pid, which has not been waited for
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
    let o = wait_within(child, Duration::from_secs(30), "a sweep sent SIGTERM while drawing");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(143), "{stderr}");
    assert!(stderr.contains("interrupted (SIGTERM), drawing sweep_"), "{stderr}");
    let drawn = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".png"));
    assert!(drawn.count() < 40, "every figure was drawn after the signal");
    assert_eq!(without_wall(&csv).len(), 5);
}

// ------------------------------------------------- 4. links in --save-runs

#[test]
fn save_runs_never_writes_through_a_planted_link() {
    let root = dir("links");
    let out = root.join("o");
    let elsewhere = root.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let argv = ["sweep", "drive", "--list", "M0=1,2", "--t-end", "0.2", "--no-figures", "--save-runs", "--jobs", "1"];
    let sweep = || {
        let mut a: Vec<&OsStr> = argv.iter().map(OsStr::new).collect();
        a.extend([OsStr::new("--out"), out.as_os_str()]);
        run(a)
    };
    // OUT/runs a link to another directory
    std::os::unix::fs::symlink(&elsewhere, out.join("runs")).unwrap();
    let e = err(&sweep());
    assert!(e.contains(&format!("{} is a symbolic link", out.join("runs").display())), "{e}");
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0, "wrote through OUT/runs");
    // OUT/runs/0 a link to another directory
    std::fs::remove_file(out.join("runs")).unwrap();
    std::fs::create_dir(out.join("runs")).unwrap();
    std::os::unix::fs::symlink(&elsewhere, out.join("runs/0")).unwrap();
    let e = err(&sweep());
    assert!(e.contains(&format!("{} is a symbolic link", out.join("runs/0").display())), "{e}");
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0, "wrote through OUT/runs/0");
    // without the link, the same command writes every run's output
    std::fs::remove_file(out.join("runs/0")).unwrap();
    ok(&sweep());
    assert!(out.join("runs/0/trajectory.csv").is_file() && out.join("runs/1/trajectory.csv").is_file());
    assert_eq!(without_wall(&out.join("sweep.csv")).len(), 3);
}

// ---------------------------------------------- 5. a row deleted by hand

#[test]
fn a_deleted_row_is_run_again_in_its_place() {
    let root = dir("deleted");
    let argv = ["sweep", "drive", "--grid", "M0=1:3:5", "--t-end", "0.5", "--metric", "final(x1)", "--no-figures"];
    let sweep = |out: &Path| {
        let mut a: Vec<&OsStr> = argv.iter().map(OsStr::new).collect();
        a.extend([OsStr::new("--out"), out.as_os_str()]);
        run(a)
    };
    let fresh = root.join("fresh");
    ok(&sweep(&fresh));
    let part = root.join("part");
    ok(&sweep(&part));
    let text = std::fs::read_to_string(part.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let without: String = lines.iter().enumerate().filter(|(k, _)| *k != 3).map(|(_, l)| format!("{l}\n")).collect();
    std::fs::write(part.join("sweep.csv"), without).unwrap();
    let said = ok(&sweep(&part));
    assert!(said.contains("5 runs, 4 done before, 1 ran (0 failed)"), "{said}");
    // the table in run order, as the fresh sweep wrote it (wall_s aside),
    // the rows that were there unchanged byte for byte
    assert_eq!(without_wall(&part.join("sweep.csv")), without_wall(&fresh.join("sweep.csv")));
    let after = std::fs::read_to_string(part.join("sweep.csv")).unwrap();
    let after: Vec<&str> = after.lines().collect();
    assert_eq!(after.len(), lines.len());
    for k in (0..lines.len()).filter(|&k| k != 3) {
        assert_eq!(after[k], lines[k], "line {}", k + 1);
    }
    assert!(after[3].starts_with("2,2.0,ok,"), "{}", after[3]);
    // no temporary table left behind
    let names: Vec<String> =
        std::fs::read_dir(&part).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(names.iter().all(|n| !n.starts_with(".sweep.csv.")), "{names:?}");
    // resumed again: nothing to run, nothing changed; and it merges
    let before = std::fs::read(part.join("sweep.csv")).unwrap();
    let said = ok(&sweep(&part));
    assert!(said.contains("all done before: nothing to run"), "{said}");
    assert_eq!(std::fs::read(part.join("sweep.csv")).unwrap(), before);
    let merged = root.join("merged");
    let said = ok(&run([
        OsStr::new("sweep"),
        OsStr::new("merge"),
        part.as_os_str(),
        OsStr::new("--out"),
        merged.as_os_str(),
        OsStr::new("--no-figures"),
    ]));
    assert!(said.contains("merged 1 shards: 5 runs"), "{said}");
    assert_eq!(std::fs::read(merged.join("sweep.csv")).unwrap(), before);
}

// ------------------------------------------------------------- 6. umask

#[test]
fn merged_tables_honour_the_umask() {
    let root = dir("umask");
    let shard = root.join("shard");
    ok(&run([
        OsStr::new("sweep"),
        OsStr::new("drive"),
        OsStr::new("--list"),
        OsStr::new("M0=1,2"),
        OsStr::new("--t-end"),
        OsStr::new("0.2"),
        OsStr::new("--no-figures"),
        OsStr::new("--out"),
        shard.as_os_str(),
    ]));
    for (umask, want) in [("022", 0o644), ("077", 0o600)] {
        let merged = root.join(format!("merged-{umask}"));
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!("umask {umask}; exec \"$0\" \"$@\""))
            .arg(env!("CARGO_BIN_EXE_ezy"))
            .args([OsStr::new("sweep"), OsStr::new("merge"), shard.as_os_str(), OsStr::new("--out")])
            .arg(&merged)
            .arg("--no-figures")
            .output()
            .unwrap();
        ok(&o);
        for f in ["sweep.csv", "sweep.toml"] {
            assert_eq!(mode(&merged.join(f)), want, "umask {umask}: {f} is {:o}", mode(&merged.join(f)));
        }
    }
}
