//! The Slurm round trip of `ezy sweep --emit-slurm`: a one-node Slurm
//! cluster on this machine (`tests/support/slurm.sh`, Debian's slurm-wlm
//! installed by it when missing), the script submitted with `bash FILE
//! --wait` (a job array of shards, then the merge as a dependent job),
//! and the merged `sweep.csv` compared with the same sweep run locally.
//! Where Slurm cannot be brought up (not root, no apt-get, a daemon that
//! does not start) the test prints why and passes without it.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Stops the cluster when the test ends, passed or not.
struct Cluster {
    state: PathBuf,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash").arg(script()).arg("down").arg(&self.state).status();
    }
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/support/slurm.sh")
}

fn table(path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let h: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let wall = h.iter().position(|c| c == "wall_s").unwrap();
    let mut rows = vec![h];
    rows.extend(r.records().map(|x| x.unwrap().iter().map(String::from).collect()));
    // wall_s is the one column that differs between two runs of a sweep
    rows.iter_mut().for_each(|r| {
        r.remove(wall);
    });
    rows
}

fn logs(dir: &Path) -> String {
    let mut s = String::new();
    for f in ["slurmctld.log", "slurmd.log"] {
        s += &format!("--- {f}\n{}\n", std::fs::read_to_string(dir.join(f)).unwrap_or_default());
    }
    s
}

#[test]
fn a_sweep_on_slurm_equals_the_local_sweep() {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("slurm");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let state = root.join("cluster");
    let started = Instant::now();
    let up = Command::new("bash").arg(script()).arg("up").arg(&state).output().expect("bash runs");
    let said = String::from_utf8_lossy(&up.stdout).into_owned();
    if up.status.code() == Some(77) {
        println!("Slurm round trip skipped: {}", said.trim());
        return;
    }
    let _cluster = Cluster { state: state.clone() };
    assert!(up.status.success(), "slurm.sh up failed: {said}{}", String::from_utf8_lossy(&up.stderr));
    let conf = said.lines().find_map(|l| l.strip_prefix("SLURM_CONF=")).expect("SLURM_CONF").to_string();
    println!(
        "Slurm up in {:.1} s: {}",
        started.elapsed().as_secs_f64(),
        said.split_whitespace().collect::<Vec<_>>().join(" ")
    );

    let sweep = ["sweep", "drive", "--grid", "M0=1:2:5", "--list", "a=0.15,0.25", "--integrator", "dop853"];
    let tail = ["--t-end", "5", "--metric", "mean(norm(x1d, y1d), 1, 5)"];
    let file = root.join("sweep.sh");
    let out = root.join("on-slurm");
    let emit = Command::new(env!("CARGO_BIN_EXE_ezy"))
        .args(sweep)
        .args(tail)
        .arg("--emit-slurm")
        .arg(&file)
        .args(["--tasks", "3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(emit.status.success(), "{}", String::from_utf8_lossy(&emit.stderr));

    // submit the array and the merge after it; --wait returns when the
    // merge has finished
    let submitted = Instant::now();
    let mut child = Command::new("bash")
        .arg(&file)
        .arg("--wait")
        .env("SLURM_CONF", &conf)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(300);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the Slurm jobs did not finish within 300 s\n{}", logs(&state));
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let o = child.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        status.success(),
        "bash {} --wait: {text}{}\n{}",
        file.display(),
        String::from_utf8_lossy(&o.stderr),
        logs(&state)
    );
    assert!(text.contains("submitted array job") && text.contains("(3 tasks) and merge job"), "{text}");
    println!("array and merge done in {:.1} s", submitted.elapsed().as_secs_f64());

    // every task ran its shard and wrote its log; the merge wrote the table
    for k in 0..3 {
        let log = std::fs::read_to_string(out.join(format!("slurm/task-{k}.out"))).unwrap_or_default();
        assert!(log.contains("ran (0 failed)"), "task {k}: {log}");
    }
    let merge_log = std::fs::read_to_string(out.join("slurm/merge.out")).unwrap_or_default();
    assert!(merge_log.contains("merged 3 shards: 10 runs"), "{merge_log}");

    // the same sweep on this machine
    let local = root.join("local");
    let run = Command::new(env!("CARGO_BIN_EXE_ezy")).args(sweep).args(tail).arg("--out").arg(&local).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(table(&out.join("sweep.csv")), table(&local.join("sweep.csv")));
    assert_eq!(
        std::fs::read_to_string(out.join("sweep.toml")).unwrap(),
        std::fs::read_to_string(local.join("sweep.toml")).unwrap()
    );
    assert!(out.join("sweep_1_map.png").is_file(), "the merge draws the figures");
}
