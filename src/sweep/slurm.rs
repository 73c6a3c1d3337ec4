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
//!
//! What the script holds is safe to run whatever the paths and arguments
//! are: every value ezy puts into a shell line is single-quoted (POSIX),
//! the `#SBATCH` lines take double-quoted values with `\` and `"` escaped
//! (Slurm's own quoting; `%` doubled in log paths, so Slurm does not
//! expand it), the job name is reduced to letters, digits and `._-`, and
//! a path or argument holding a control character (a newline, which no
//! `#SBATCH` line or comment can hold) is refused, naming it.
//!
//! [`write_script`] writes the script without ever replacing something
//! that is not an earlier script of ezy's.

use std::io::Read;
use std::path::Path;

/// How every script ezy writes begins: what [`write_script`] recognises
/// an earlier script by (the scripts of earlier versions begin so too).
pub(crate) const HEADER: &str = "#!/bin/bash\n# ezy sweep ";

/// Most array tasks a script may have (Slurm's own limit, the largest
/// `MaxArraySize`, is 4000001).
pub(crate) const MAX_TASKS: u64 = 1_000_000;

/// Quotes `s` for the shell (single quotes; a quote inside as `'\''`);
/// a word of only `[A-Za-z0-9-_./=:,+@%]` is left as it is.
pub(crate) fn quote(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c)) {
        return s.to_string();
    }
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// A value of an `#SBATCH` option as Slurm reads it: left as it is when
/// plain, else in double quotes with `\` and `"` escaped by `\`. `s` must
/// hold no control character ([`plain`]).
fn sbatch_value(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c)) {
        return s.to_string();
    }
    format!("\"{}\"", s.replace('\\', r"\\").replace('"', "\\\""))
}

/// A path as a Slurm file name pattern that names exactly it (`%` is
/// Slurm's replacement character; `%%` is one `%`).
fn pattern(s: &str) -> String {
    s.replace('%', "%%")
}

/// The name of control character `c` for a message.
fn char_name(c: char) -> String {
    let name = match c {
        '\n' => "a newline",
        '\r' => "a carriage return",
        '\t' => "a tab",
        '\0' => "a NUL",
        '\u{1b}' => "an escape",
        _ => "a control character",
    };
    format!("{name} (U+{:04X})", u32::from(c))
}

/// Refuses `value` (of `what`, as the user knows it) if it holds a
/// control character: no `#SBATCH` line or comment can hold a newline,
/// and ezy writes no control character it did not create.
///
/// # Errors
/// The message names `what`, the value (escaped) and the character.
pub(crate) fn plain(what: &str, value: &str) -> Result<(), String> {
    match value.chars().find(|c| c.is_control()) {
        None => Ok(()),
        Some(c) => Err(format!(
            "{what} \"{}\" contains {}, which a Slurm script cannot hold; choose one without control characters",
            value.escape_debug(),
            char_name(c)
        )),
    }
}

/// The batch script of a sweep of `runs` runs in `tasks` array tasks:
/// `exe` (absolute) runs `sweep SCENE ARGS --shard K/TASKS --out
/// OUT/shard-K --jobs C` in task K (C: the task's CPUs), and `sweep merge`
/// writes `OUT/sweep.csv` and the figures. Task and merge logs go to
/// `OUT/slurm/` (a path holding a `\` makes Slurm take the log's name
/// literally: one log for every task).
///
/// # Errors
/// A path or argument that is not UTF-8 or holds a control character,
/// named (`the path of this program`, `the scene`, `--out`, or the
/// option an argument belongs to); `tasks` of 0 or above [`MAX_TASKS`].
pub(crate) fn script(
    exe: &Path,
    scene: &str,
    args: &[String],
    out: &Path,
    tasks: u64,
    runs: u64,
    name: &str,
) -> Result<String, String> {
    let utf8 = |what: &str, p: &Path| -> Result<String, String> {
        let s = p.to_str().ok_or_else(|| format!("{what} {} is not valid UTF-8", p.display()))?;
        plain(what, s)?;
        Ok(s.to_string())
    };
    let exe = utf8("the path of this program", exe)?;
    let dir = utf8("--out", out)?;
    plain("the scene", scene)?;
    let mut flag = "an argument";
    for a in args {
        if a.starts_with("--") {
            flag = a;
            plain("an argument", a)?;
        } else {
            plain(&format!("the value of {flag}"), a)?;
        }
    }
    if tasks == 0 || tasks > MAX_TASKS {
        return Err(format!("--tasks {tasks}: give from 1 to {MAX_TASKS} array tasks"));
    }
    let sweep_args: Vec<String> = args.iter().map(|a| quote(a)).collect();
    // letters, digits and `._-` only: the name goes into an #SBATCH line
    let job: String = format!("ezy-sweep-{name}")
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' })
        .collect();
    let logs = format!("{dir}/slurm");
    // the merge job's command, run by `sh`: the shard directories are
    // listed by a loop, so its length does not grow with the tasks
    let wrap = format!(
        "EZY={exe_q}; DIR={dir_q}; set --; k=0; while [ \"$k\" -lt {tasks} ]; do set -- \"$@\" \"$DIR/shard-$k\"; k=$((k + 1)); done; exec \"$EZY\" sweep merge --out \"$DIR\" \"$@\"",
        exe_q = quote(&exe),
        dir_q = quote(&dir),
    );
    Ok(format!(
        r#"{HEADER}{scene}: {runs} runs in a Slurm job array of {tasks} tasks (one
# shard each), then `ezy sweep merge` into {dir} as a job that starts
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
#SBATCH --output={task_log}
set -euo pipefail
EZY={exe_q}
DIR={dir_q}
if [ -z "${{SLURM_ARRAY_TASK_ID:-}}" ]; then
    mkdir -p "$DIR/slurm"
    array=$(sbatch --parsable "$0")
    array=${{array%%;*}}
    merge=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes \
        --job-name={job}-merge --ntasks=1 --output={merge_log} "$@" \
        --wrap {wrap_q})
    echo "submitted array job $array ({tasks} tasks) and merge job ${{merge%%;*}}"
    exit 0
fi
exec "$EZY" sweep {scene_q} {sweep_args} \
    --shard "$SLURM_ARRAY_TASK_ID/{tasks}" --out "$DIR/shard-$SLURM_ARRAY_TASK_ID" \
    --jobs "${{SLURM_CPUS_PER_TASK:-1}}" --no-figures
"#,
        last = tasks - 1,
        task_log = sbatch_value(&format!("{}/task-%a.out", pattern(&logs))),
        merge_log = quote(&format!("{}/merge.out", pattern(&logs))),
        exe_q = quote(&exe),
        dir_q = quote(&dir),
        scene_q = quote(scene),
        sweep_args = sweep_args.join(" "),
        wrap_q = quote(&wrap),
    ))
}

/// Writes the script `text` to `file` (temporary file and rename: a
/// reader sees the old script or the new one, never a part). A new file
/// is created without replacing anything put there meanwhile; an existing
/// one is replaced only if it is a regular file that begins as ezy's
/// scripts do ([`HEADER`]) and is not `scene` (the sweep's scene file).
/// Nothing is opened for writing but the new file: a FIFO or a device at
/// `file` is never opened, a symbolic link never followed.
///
/// # Errors
/// `file` is a symbolic link, a directory, a FIFO, a device or a socket,
/// the scene file, or a file ezy did not write; or the write failed.
/// Each message names `file`.
pub(crate) fn write_script(file: &Path, text: &str, scene: Option<&Path>) -> Result<(), String> {
    let show = file.display();
    let io = |e: std::io::Error| format!("{show}: {e}");
    let refuse = |what: &str| {
        format!("{show} is {what}; --emit-slurm replaces only a script it wrote before: give another FILE")
    };
    let existing = match std::fs::symlink_metadata(file) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(io(e)),
        Ok(m) => Some(m),
    };
    if let Some(meta) = &existing {
        let t = meta.file_type();
        if t.is_symlink() {
            return Err(refuse("a symbolic link (ezy never writes through one)"));
        }
        if t.is_dir() {
            return Err(refuse("a directory"));
        }
        if !t.is_file() {
            return Err(refuse(&format!("not a regular file but {}", kind(meta))));
        }
        if let Some(scene) = scene
            && std::fs::metadata(scene).is_ok_and(|s| same_file(&s, meta))
        {
            return Err(refuse("the sweep's scene file"));
        }
        if !written_by_ezy(file, meta).map_err(io)? {
            return Err(refuse(
                "a file that is not a Slurm script of ezy's (it does not begin with `#!/bin/bash` and `# ezy sweep`)",
            ));
        }
    }
    let mut tmp = crate::output::transaction::temp_beside(file).map_err(io)?;
    std::io::Write::write_all(&mut tmp, text.as_bytes()).map_err(io)?;
    tmp.as_file().sync_all().map_err(io)?;
    match existing {
        // replaces the script there (a rename replaces the name, it
        // writes into nothing)
        Some(_) => tmp.persist(file).map(drop).map_err(|e| io(e.error)),
        // fails if something took the name meanwhile
        None => tmp.persist_noclobber(file).map(drop).map_err(|e| {
            if e.error.kind() == std::io::ErrorKind::AlreadyExists {
                format!("{show} appeared while the script was being written; ezy left it as it is")
            } else {
                io(e.error)
            }
        }),
    }
}

/// Whether the regular file `file` (as `meta` found it) begins with
/// [`HEADER`]: opened without following a link or blocking, and checked
/// to be the file `meta` describes.
fn written_by_ezy(file: &Path, meta: &std::fs::Metadata) -> std::io::Result<bool> {
    let f = crate::output::transaction::no_follow(std::fs::OpenOptions::new().read(true)).open(file)?;
    let opened = f.metadata()?;
    if !opened.is_file() || !same_file(&opened, meta) {
        return Ok(false);
    }
    let mut head = Vec::with_capacity(HEADER.len());
    f.take(HEADER.len() as u64).read_to_end(&mut head)?;
    Ok(head == HEADER.as_bytes())
}

#[cfg(unix)]
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_file(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    false
}

/// What a file that is not regular is, for a message.
fn kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    let _ = meta;
    "a special file"
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
        assert_eq!(sbatch_value("/a/b-%a.out"), "/a/b-%a.out");
        assert_eq!(sbatch_value(r#"/a b/"c"\d"#), r#""/a b/\"c\"\\d""#);
        assert_eq!(pattern("/x%u/task-%a"), "/x%%u/task-%%a");
    }

    #[test]
    fn control_characters_are_refused_by_name() {
        let e = plain("--out", "/a\nb").unwrap_err();
        assert!(e.contains("--out \"/a\\nb\"") && e.contains("a newline (U+000A)"), "{e}");
        let e = script(
            Path::new("/bin/ezy"),
            "drive",
            &["--metric".into(), "max(x1)\r".into()],
            Path::new("/o"),
            2,
            4,
            "d",
        )
        .unwrap_err();
        assert!(e.contains("the value of --metric") && e.contains("U+000D"), "{e}");
    }
}
