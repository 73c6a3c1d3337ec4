//! `ezy sweep --emit-slurm FILE`: a Slurm batch script that runs a sweep
//! as a job array, one shard per array task, and merges the shards in a
//! job that depends on the array (`afterok`).
//!
//! The script is both a batch script and its own submitter: `bash FILE`
//! submits the array (`sbatch FILE`) and then the merge with
//! `--dependency=afterok:ARRAY` (options after `FILE` go to that second
//! `sbatch`, so `bash FILE --wait` returns when the merge is done).
//! `sbatch FILE` alone submits only the array. Paths in the script are
//! absolute: the tasks may start in another directory, on another node
//! that shares the file system.

use std::path::Path;

/// Quotes `s` for the shell (single quotes; a quote inside as `'\''`).
pub fn quote(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c)) {
        return s.to_string();
    }
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The batch script of a sweep of `runs` runs in `tasks` array tasks:
/// `exe` (absolute) runs `sweep SCENE ARGS --shard K/TASKS --out
/// OUT/shard-K --jobs C` in task K (C: the task's CPUs), and `sweep merge`
/// writes `OUT/sweep.csv` and the figures. Task and merge logs go to
/// `OUT/slurm/` (`#SBATCH` lines are not read by a shell: `OUT` must not
/// contain spaces).
pub fn script(exe: &Path, scene: &str, args: &[String], out: &Path, tasks: u64, runs: u64, name: &str) -> String {
    let exe = quote(&exe.display().to_string());
    let dir = quote(&out.display().to_string());
    let logs = out.join("slurm");
    let sweep_args: Vec<String> = args.iter().map(|a| quote(a)).collect();
    let shards: Vec<String> = (0..tasks).map(|k| format!("\"$DIR/shard-{k}\"")).collect();
    let job = quote(&format!("ezy-sweep-{name}"));
    format!(
        r#"#!/bin/bash
# ezy sweep {scene_q}: {runs} runs in a Slurm job array of {tasks} tasks (one
# shard each), then `ezy sweep merge` into {dir_show} as a job that starts
# when every task has succeeded.
#
#   bash THIS_FILE          submits the array and the merge; prints their job ids
#   bash THIS_FILE --wait   the same, and returns when the merge has finished
#   sbatch THIS_FILE        submits the array only (its logs' directory
#                           {logs} must exist)
#
# A task that fails (or a node lost) leaves its shard unfinished: submit the
# script again; every task resumes its shard from its sweep.csv.
#SBATCH --job-name={job}
#SBATCH --array=0-{last}
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --output={logs}/task-%a.out
set -euo pipefail
EZY={exe}
DIR={dir}
if [ -z "${{SLURM_ARRAY_TASK_ID:-}}" ]; then
    mkdir -p "$DIR/slurm"
    array=$(sbatch --parsable "$0")
    array=${{array%%;*}}
    merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
        --job-name={job}-merge --ntasks=1 --output="$DIR/slurm/merge.out" "$@" \
        --wrap "$(printf '%q ' "$EZY" sweep merge --out "$DIR" {shards})")
    echo "submitted array job $array ({tasks} tasks) and merge job ${{merge%%;*}}"
    exit 0
fi
exec "$EZY" sweep {scene} {sweep_args} \
    --shard "$SLURM_ARRAY_TASK_ID/{tasks}" --out "$DIR/shard-$SLURM_ARRAY_TASK_ID" \
    --jobs "${{SLURM_CPUS_PER_TASK:-1}}" --no-figures
"#,
        scene_q = scene.replace('\n', " "),
        dir_show = out.display().to_string().replace('\n', " "),
        last = tasks - 1,
        logs = logs.display(),
        scene = quote(scene),
        sweep_args = sweep_args.join(" "),
        shards = shards.join(" "),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoting() {
        assert_eq!(quote("a=0:1:3"), "a=0:1:3");
        assert_eq!(quote("mean(norm(x1d, y1d), 50, 60)"), "'mean(norm(x1d, y1d), 50, 60)'");
        assert_eq!(quote("it's"), r"'it'\''s'");
        assert_eq!(quote(""), "''");
    }
}
