//! `ezy sweep` through the program: rows equal single runs bit for bit,
//! resume skips done runs (and cuts a row a kill tore), shards merged
//! equal the whole, a failed run is a row, bad input is refused before
//! any run, family counts change the columns.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// DOP853 at 1e-9 over 6 s: short runs of the drive scene.
const SHORT: [&str; 8] = ["--integrator", "dop853", "--rtol", "1e-9", "--atol", "1e-9", "--t-end", "6"];

fn ezy<I: IntoIterator<Item = S>, S: AsRef<std::ffi::OsStr>>(args: I) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("ezy runs")
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
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("sweep-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Header and rows of a CSV file, as strings.
fn table(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r.records().map(|x| x.unwrap().iter().map(String::from).collect()).collect();
    (header, rows)
}

/// The rows without the `wall_s` column (the one column that differs
/// between two runs of the same sweep).
fn without_wall(path: &Path) -> Vec<Vec<String>> {
    let (h, rows) = table(path);
    let k = h.iter().position(|c| c == "wall_s").expect("wall_s");
    rows.into_iter()
        .map(|mut r| {
            r.remove(k);
            r
        })
        .collect()
}

fn args<'a>(list: &'a [&'a str], out: &'a Path) -> Vec<&'a std::ffi::OsStr> {
    let mut a: Vec<&std::ffi::OsStr> = list.iter().map(std::ffi::OsStr::new).collect();
    a.push("--out".as_ref());
    a.push(out.as_os_str());
    a
}

#[test]
fn rows_equal_single_runs_bit_for_bit() {
    let out = dir("rows");
    let mut sweep = vec!["sweep", "drive", "--list", "M0=1,2.5", "--grid", "a=0.15:0.25:2"];
    sweep.extend(["--metric", "mean(norm(x1d, y1d), 2, 6)", "--metric", "max(phi1d)", "--jobs", "2"]);
    sweep.extend(SHORT);
    ok(&ezy(args(&sweep, &out.join("sweep"))));
    let (h, rows) = table(&out.join("sweep/sweep.csv"));
    assert_eq!(rows.len(), 4);
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row[0], k.to_string());
        assert_eq!(row[3], "ok");
        let run_dir = out.join(format!("run{k}"));
        let mut run = vec!["run", "drive", "--no-figures", "--set"];
        let value = |name: &str| &row[h.iter().position(|c| c == name).unwrap()];
        let (m0, a) = (format!("M0={}", value("M0")), format!("a={}", value("a")));
        run.extend([m0.as_str(), "--set", a.as_str()]);
        run.extend(SHORT);
        ok(&ezy(args(&run, &run_dir)));
        let (th, trows) = table(&run_dir.join("trajectory.csv"));
        let last = trows.last().unwrap();
        // every state component and T: the same digits as the last row of
        // the single run's trajectory.csv (the same shortest round trip on
        // both sides, so equal strings are equal bits)
        let state = h.iter().position(|c| c == "x1").unwrap()..h.iter().position(|c| c == "T").unwrap() + 1;
        for c in state {
            let j = th.iter().position(|t| *t == h[c]).unwrap_or_else(|| panic!("{} not in the trajectory", h[c]));
            assert_eq!(row[c], last[j], "run {k}, {}", h[c]);
        }
        // the metrics, from the single run's trajectory by the definition:
        // the time average over the rows in [2, 6] s (trapezoidal rule), the
        // largest value
        let col = |name: &str| th.iter().position(|t| t == name).unwrap();
        let (t, xd, yd, pd) = (col("t"), col("x1d"), col("y1d"), col("phi1d"));
        let num = |r: &Vec<String>, j: usize| r[j].parse::<f64>().unwrap();
        let window: Vec<(f64, f64)> = trows
            .iter()
            .map(|r| (num(r, t), num(r, xd).hypot(num(r, yd))))
            .filter(|(t, _)| (2.0..=6.0).contains(t))
            .collect();
        let integral: f64 = window.windows(2).map(|w| 0.5 * (w[1].0 - w[0].0) * (w[0].1 + w[1].1)).sum();
        let mean = integral / (window.last().unwrap().0 - window[0].0);
        let got: f64 = row[h.len() - 2].parse().unwrap();
        // the same sum in the same order: equal to rounding of the final
        // division at most
        assert!((got - mean).abs() <= 4.0 * f64::EPSILON * mean.abs(), "run {k}: mean {got} against {mean}");
        let max = trows.iter().map(|r| num(r, pd)).fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(row[h.len() - 1].parse::<f64>().unwrap(), max, "run {k}: max(phi1d)");
    }
    // two fixed axes: the lines and the heat map of each metric
    for f in ["sweep_1.png", "sweep_1_map.png", "sweep_2.png", "sweep_2_map.png"] {
        let bytes = std::fs::read(out.join("sweep").join(f)).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{f}");
    }
}

#[test]
fn resume_skips_done_runs_and_cuts_a_torn_row() {
    let out = dir("resume");
    let mut sweep = vec!["sweep", "drive", "--grid", "M0=1:3:5", "--metric", "final(x1)", "--no-figures"];
    sweep.extend(SHORT);
    let full = out.join("full");
    ok(&ezy(args(&sweep, &full)));
    // a sweep killed after two rows, in the middle of writing the third
    let part = out.join("part");
    std::fs::create_dir_all(&part).unwrap();
    std::fs::copy(full.join("sweep.toml"), part.join("sweep.toml")).unwrap();
    let text = std::fs::read_to_string(full.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let torn = format!("{}\n{}\n{}\n{}", lines[0], lines[1], lines[2], &lines[3][..lines[3].len() / 2]);
    std::fs::write(part.join("sweep.csv"), torn).unwrap();
    let said = ok(&ezy(args(&sweep, &part)));
    assert!(said.contains("5 runs, 2 done before, 3 ran (0 failed)"), "{said}");
    assert_eq!(without_wall(&part.join("sweep.csv")), without_wall(&full.join("sweep.csv")));
    // once more: nothing to run, nothing changed
    let before = std::fs::read(part.join("sweep.csv")).unwrap();
    let said = ok(&ezy(args(&sweep, &part)));
    assert!(said.contains("all done before: nothing to run"), "{said}");
    assert_eq!(std::fs::read(part.join("sweep.csv")).unwrap(), before);
    // another sweep into the same directory is refused, the table kept
    let mut other = sweep.clone();
    other[3] = "M0=1:3:6";
    let e = err(&ezy(args(&other, &part)));
    assert!(e.contains("holds another sweep") && e.contains("M0=1:3:5"), "{e}");
    assert_eq!(std::fs::read(part.join("sweep.csv")).unwrap(), before);
    // a row that is not this sweep's (edited by hand) is refused by name
    let edited = String::from_utf8(before).unwrap().replacen("\n1,1.5,", "\n1,1.25,", 1);
    std::fs::write(part.join("sweep.csv"), edited).unwrap();
    let e = err(&ezy(args(&sweep, &part)));
    assert!(e.contains("line 3") && e.contains("run 1 has M0 = 1.25"), "{e}");
}

#[test]
fn shards_merged_equal_the_whole() {
    let out = dir("shards");
    let mut sweep = vec!["sweep", "drive", "--list", "M0=1,2", "--random", "omega=2:4", "--samples", "3"];
    sweep.extend(["--seed", "9", "--metric", "final(from_start(phi1))", "--no-figures", "--jobs", "1"]);
    sweep.extend(SHORT);
    let whole = out.join("whole");
    ok(&ezy(args(&sweep, &whole)));
    let mut shard_dirs = Vec::new();
    for k in 0..3 {
        let d = out.join(format!("shard-{k}"));
        let shard = format!("{k}/3");
        let mut a = sweep.clone();
        a.extend(["--shard", shard.as_str()]);
        let said = ok(&ezy(args(&a, &d)));
        assert!(said.contains("2 runs, 0 done before, 2 ran"), "{said}");
        shard_dirs.push(d);
    }
    let merged = out.join("merged");
    let mut m: Vec<&std::ffi::OsStr> = vec!["sweep".as_ref(), "merge".as_ref()];
    m.extend(shard_dirs.iter().rev().map(|d| d.as_os_str()));
    m.extend(["--out".as_ref(), merged.as_os_str(), "--no-figures".as_ref()]);
    let said = ok(&ezy(&m));
    assert!(said.contains("merged 3 shards: 6 runs"), "{said}");
    assert_eq!(without_wall(&merged.join("sweep.csv")), without_wall(&whole.join("sweep.csv")));
    assert_eq!(
        std::fs::read_to_string(merged.join("sweep.toml")).unwrap(),
        std::fs::read_to_string(whole.join("sweep.toml")).unwrap()
    );
    // the random draws depend on the run and the seed only
    let (_, rows) = table(&whole.join("sweep.csv"));
    let omegas: Vec<&str> = rows.iter().map(|r| r[2].as_str()).collect();
    assert_eq!(omegas[0..3], omegas[3..6], "each M0 takes the same three draws");
    // a missing shard, and an unfinished one, are named
    let e = err(&ezy([
        "sweep".as_ref(),
        "merge".as_ref(),
        shard_dirs[0].as_os_str(),
        shard_dirs[1].as_os_str(),
        "--out".as_ref(),
        out.join("m2").as_os_str(),
    ]));
    assert!(e.contains("shard 2/3 is missing"), "{e}");
    let csv = shard_dirs[2].join("sweep.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let cut: Vec<&str> = text.lines().collect();
    std::fs::write(&csv, format!("{}\n{}\n", cut[0], cut[1])).unwrap();
    let mut m3 = m.clone();
    let out3 = out.join("m3");
    let n = m3.len();
    m3[n - 2] = out3.as_os_str();
    let e = err(&ezy(&m3));
    assert!(e.contains("run 5 is missing") && e.contains("shard-2"), "{e}");
}

#[test]
fn a_failed_run_is_a_row() {
    let out = dir("failed");
    let said = ok(&ezy(args(&["sweep", "drive", "--list", "m2=-1,1", "--t-end", "1", "--no-figures"], &out)));
    assert!(said.contains("2 ran (1 failed)"), "{said}");
    let (h, rows) = table(&out.join("sweep.csv"));
    assert!(rows[0][2].starts_with("error: invalid setting m2 (mass of body body2) = -1"), "{:?}", rows[0]);
    assert!(rows[0][h.len() - 1].is_empty());
    assert_eq!(rows[1][2], "ok");
}

#[test]
fn bad_input_is_refused_before_any_run() {
    let out = dir("bad");
    for (argv, says) in [
        (vec!["sweep", "drive", "--grid", "mm2=1:2:3"], "unknown parameter `mm2`"),
        (vec!["sweep", "drive", "--grid", "m2=1:2:0"], "COUNT `0` must be a whole number >= 1"),
        (vec!["sweep", "drive", "--list", "m2=1", "--metric", "max(zz)"], "no column `zz`"),
        (vec!["sweep", "drive", "--list", "m2=1", "--metric", "mean(T, 50, 70)"], "after the run's end at 60 s"),
        (vec!["sweep", "drive", "--list", "m2=1", "--metric", "avg(T)"], "unknown function `avg`"),
        (vec!["sweep", "drive", "--random", "m2=1:2"], "--random needs --samples"),
        (vec!["sweep", "drive", "--list", "m2=1", "--set", "m2=2"], "both swept and fixed"),
        (vec!["sweep", "drive", "--list", "m2=1", "--shard", "3/3"], "need 0 <= K < N"),
        (vec!["sweep", "drive"], "no axis"),
        (vec!["sweep", "snake", "--random", "N=2:4", "--samples", "2"], "cannot be drawn at random"),
        (vec!["run", "drive", "--set", "m2=1,2"], "ezy sweep SCENE --list m2=1,2"),
    ] {
        let e = err(&ezy(args(&argv, &out)));
        assert!(e.contains(says), "{argv:?}: {e}");
        assert!(!out.exists(), "{argv:?} wrote {}", out.display());
    }
}

#[test]
fn a_family_count_changes_the_columns() {
    let out = dir("counts");
    let argv = ["sweep", "snake", "--list", "N=5,6", "--t-end", "1", "--metric", "final(x1)", "--no-figures"];
    ok(&ezy(args(&argv, &out)));
    let (h, rows) = table(&out.join("sweep.csv"));
    let x6 = h.iter().position(|c| c == "x6").expect("N = 6 adds x6");
    assert!(h.iter().position(|c| c == "x5").unwrap() < x6);
    assert!(h.iter().position(|c| c == "x1d").unwrap() < h.iter().position(|c| c == "x6d").unwrap());
    assert!(rows[0][x6].is_empty(), "N = 5 has no x6");
    assert!(!rows[1][x6].is_empty());
    assert!(rows.iter().all(|r| r[2] == "ok"), "{rows:?}");
}

#[test]
fn the_slurm_script_runs_shards_and_merges() {
    let out = dir("slurm");
    let script = out.join("sweep.sh");
    std::fs::create_dir_all(&out).unwrap();
    let argv = ["sweep", "drive", "--grid", "M0=1:2:5", "--metric", "mean(T, 1, 2)", "--emit-slurm"];
    let mut a: Vec<&std::ffi::OsStr> = argv.iter().map(std::ffi::OsStr::new).collect();
    let o = out.join("o");
    a.extend([script.as_os_str(), "--tasks".as_ref(), "2".as_ref(), "--out".as_ref(), o.as_os_str()]);
    let said = ok(&ezy(&a));
    assert!(said.contains("5 runs in 2 array tasks"), "{said}");
    let text = std::fs::read_to_string(&script).unwrap();
    for want in [
        "#SBATCH --array=0-1",
        "--dependency=\"afterok:$array\"",
        "sweep drive --grid M0=1:2:5 --metric 'mean(T, 1, 2)'",
        "--shard \"$SLURM_ARRAY_TASK_ID/2\"",
        "while [ \"$k\" -lt 2 ]; do set -- \"$@\" \"$DIR/shard-$k\"",
        "exec \"$EZY\" sweep merge --out \"$DIR\" \"$@\"",
    ] {
        assert!(text.contains(want), "{want}\n{text}");
    }
    let syntax = Command::new("bash").arg("-n").arg(&script).output().unwrap();
    assert!(syntax.status.success(), "{}", String::from_utf8_lossy(&syntax.stderr));
    // nothing ran: the sweep's directory is not created
    assert!(!out.join("o").exists());
}

#[test]
fn the_sleighs_turn_against_its_skate_position_matches_the_closed_form() {
    // docs/physics.md §9: with k = m a / (I + m a^2), U = sqrt(2 E / m) and
    // s0 = atanh(u0 / U), the yaw rate is omega0 cosh(s0) / cosh(k U t + s0),
    // so the heading turns by omega0 cosh(s0) / (k U) (gd(k U t + s0) -
    // gd(s0)), gd(x) = 2 atan(tanh(x / 2)). Skate behind (a > 0): a small
    // turn and the sleigh settles; skate ahead (a < 0): it swings round.
    let out = dir("sleigh");
    let argv = ["sweep", "sleigh", "--list", "a=-0.5,-0.2,0.2,0.5", "--metric", "final(from_start(phi))"];
    let tail = ["--integrator", "dop853", "--rtol", "1e-11", "--atol", "1e-11", "--t-end", "10", "--no-figures"];
    ok(&ezy(args(&[&argv[..], &tail[..]].concat(), &out)));
    let (h, rows) = table(&out.join("sweep.csv"));
    let (m, i, u0, w0, t) = (1.0f64, 0.1f64, 1.0f64, 1.0f64, 10.0f64);
    let gd = |x: f64| 2.0 * (x / 2.0).tanh().atan();
    for row in &rows {
        let a: f64 = row[1].parse().unwrap();
        let e = 0.5 * (m * u0 * u0 + (i + m * a * a) * w0 * w0);
        let (u, k) = ((2.0 * e / m).sqrt(), m * a / (i + m * a * a));
        let s0 = (u0 / u).atanh();
        let turn = w0 * s0.cosh() / (k * u) * (gd(k * u * t + s0) - gd(s0));
        let got: f64 = row[h.len() - 1].parse().unwrap();
        // DOP853 at 1e-11 over 10 s: the heading to about 1e-10 rad
        assert!((got - turn).abs() < 1e-8, "a = {a}: turned {got} rad, closed form {turn}");
    }
    let turn = |a: &str| rows.iter().find(|r| r[1] == a).unwrap()[h.len() - 1].parse::<f64>().unwrap();
    assert!(turn("-0.5") > 2.5 && turn("0.5") < 1.0, "skate ahead swings round, behind settles");
}

#[test]
fn a_signal_keeps_the_finished_rows_and_the_same_command_resumes() {
    let out = dir("signal");
    // ten runs of about 0.1 s each (RK4 at 1e-4 s over 20 s) on one job
    let argv = ["sweep", "drive", "--grid", "M0=1:2:10", "--t-end", "20", "--jobs", "1", "--no-figures"];
    let child = Command::new(env!("CARGO_BIN_EXE_ezy"))
        .args(argv)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let csv = out.join("sweep.csv");
    let start = std::time::Instant::now();
    while std::fs::read_to_string(&csv).map_or(0, |t| t.lines().count()) < 3 {
        assert!(start.elapsed().as_secs() < 60, "no rows after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // a second sweep into the directory while this one runs is refused
    let e = err(&ezy(args(&argv, &out)));
    assert!(e.contains("another ezy run is writing into"), "{e}");
    // SAFETY: kill(2) on the child's pid, which has not been waited for
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
    let o = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(143), "{stderr}");
    assert!(stderr.contains("interrupted (SIGTERM)") && stderr.contains("the same command resumes"), "{stderr}");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.ends_with('\n'), "only whole rows");
    let kept = text.lines().count() - 1;
    assert!((2..10).contains(&kept), "{kept} rows kept");
    let (_, rows) = table(&csv);
    assert!(rows.iter().enumerate().all(|(k, r)| r[0] == k.to_string() && r[2] == "ok"), "{rows:?}");
    let said = ok(&ezy(args(&argv, &out)));
    assert!(said.contains(&format!("10 runs, {kept} done before, {} ran", 10 - kept)), "{said}");
    assert_eq!(table(&csv).1.len(), 10);
}

/// A sweep's metric may name a gait's quantity (`gait.mean_speed`), as
/// `periodic.csv` names it: each run's gait is sought from its end as
/// `ezy analyze` seeks it, so each value equals that of `ezy analyze
/// --set` at the same value to 1e-9 (both are Newton's at 1e-9 on the
/// same run's end; measured equal to the last digit); the mean power
/// takes the orbit's extra integral (`oracle::gait_means` checks the
/// values against a settled run). A scene without a gait (the
/// drive: its energy grows) gives a failed row that names the metric;
/// an unknown quantity is refused before any run, with the list.
#[test]
fn a_sweep_metric_names_a_gait_quantity_as_analyze_does() {
    let out = dir("gait-metric");
    let names = ["gait.mean_speed", "gait.drift_speed", "gait.mean_abs_speed", "gait.mean_power", "gait.dx"];
    let mut list = vec!["sweep", "drive-rolling-resistance", "--list", "motor.omega=2.5,3.0", "--no-figures"];
    for n in names {
        list.extend(["--metric", n]);
    }
    ok(&ezy(args(&list, &out)));
    let (h, rows) = table(&out.join("sweep.csv"));
    let col = |name: &str| h.iter().position(|c| c == name).unwrap_or_else(|| panic!("{name} in {h:?}"));
    for (row, omega) in rows.iter().zip(["2.5", "3.0"]) {
        assert_eq!(row[col("status")], "ok", "{row:?}");
        let a = dir(&format!("gait-metric-analyze-{omega}"));
        let set = format!("motor.omega={omega}");
        ok(&ezy(args(&["analyze", "drive-rolling-resistance", "--set", &set, "--no-figures"], &a)));
        let (ph, prow) = table(&a.join("periodic.csv"));
        for n in names {
            let q = n.strip_prefix("gait.").unwrap();
            let want: f64 = prow[0][ph.iter().position(|c| c == q).unwrap()].parse().unwrap();
            let got: f64 = row[col(n)].parse().unwrap();
            assert!((got - want).abs() <= 1e-9 * want.abs().max(1e-3), "{n} at {omega}: {got} against {want}");
        }
    }
    let out = dir("gait-metric-none");
    let list = ["sweep", "drive", "--list", "M0=1", "--t-end", "20", "--metric", "gait.dx", "--no-figures"];
    ezy(args(&list, &out));
    let (h, rows) = table(&out.join("sweep.csv"));
    let status = &rows[0][h.iter().position(|c| c == "status").unwrap()];
    assert!(status.starts_with("error: metric `gait.dx`: no periodic orbit"), "{status}");
    let out = dir("gait-metric-unknown");
    let e = err(&ezy(args(&["sweep", "drive", "--list", "M0=1", "--metric", "gait.speed"], &out)));
    assert!(e.contains("a gait has no quantity `speed`") && e.contains("gait.drift_speed"), "{e}");
    assert!(!out.join("sweep.csv").exists());
}
