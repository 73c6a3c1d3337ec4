//! `sweep.toml` and `sweep.csv`: creating, resuming, appending, merging.

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Seek, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::plan::Plan;

/// The table's file name.
pub(crate) const CSV: &str = "sweep.csv";
/// The definition's file name.
pub(crate) const TOML: &str = "sweep.toml";

/// A sweep's definition, as `sweep.toml` records it: what makes two
/// invocations the same sweep (resume) or shards of one sweep (merge).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Manifest {
    /// The scene: a known name, or the absolute path of its file.
    pub scene: String,
    /// FNV-1a of the scene's text (an edited scene file is another sweep).
    pub scene_fingerprint: String,
    /// Number of runs (all shards).
    pub runs: u64,
    /// The sweep's arguments after the scene (axes, samples, seed,
    /// metrics, overrides), as `ezy sweep` takes them.
    pub args: Vec<String>,
    /// `K/N` for a shard.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<String>,
}

impl Manifest {
    fn read(dir: &Path) -> Result<Option<Self>, String> {
        let path = dir.join(TOML);
        match std::fs::symlink_metadata(&path) {
            Err(_) => return Ok(None),
            Ok(m) if !m.is_file() => {
                return Err(format!("{} is not a regular file; ezy keeps a sweep's definition there", path.display()));
            }
            Ok(_) => {}
        }
        let text = ezy_scene::files::read_capped_text(&path, 1 << 20, "a sweep definition")
            .map_err(|e| format!("{}: {e}", path.display()))?;
        toml::from_str(&text).map(Some).map_err(|e| format!("{}: not a sweep definition: {e}", path.display()))
    }

    fn text(&self) -> String {
        let body = toml::to_string(self).expect("a manifest serializes");
        format!(
            "# The definition of the ezy sweep whose rows are in sweep.csv. Running the same\n# command with this directory as --out resumes it; `ezy sweep merge` checks\n# that shards share it.\n{body}"
        )
    }

    /// The first field in which `self` (found in `dir`) differs from `want`.
    fn differs(&self, want: &Self) -> Option<String> {
        let show = |v: &dyn std::fmt::Debug| format!("{v:?}");
        if self.scene != want.scene {
            return Some(format!("scene {} (this command: {})", show(&self.scene), show(&want.scene)));
        }
        if self.scene_fingerprint != want.scene_fingerprint {
            return Some("the scene's text (the scene file changed since)".into());
        }
        if self.args != want.args {
            return Some(format!("arguments {} (this command: {})", self.args.join(" "), want.args.join(" ")));
        }
        if self.runs != want.runs {
            return Some(format!("{} runs (this command: {})", self.runs, want.runs));
        }
        if self.shard != want.shard {
            let s = |v: &Option<String>| v.clone().unwrap_or_else(|| "no shard".into());
            return Some(format!("shard {} (this command: {})", s(&self.shard), s(&want.shard)));
        }
        None
    }
}

/// A CSV writer of `sweep.csv`'s dialect (`\n` line ends) into `w`.
fn writer<W: Write>(w: W) -> csv::Writer<W> {
    csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_writer(w)
}

/// One row of `sweep.csv`, with its line end.
pub(crate) fn line<S: AsRef<[u8]>>(fields: &[S]) -> Vec<u8> {
    let mut w = writer(Vec::new());
    w.write_record(fields).expect("writing to memory");
    w.into_inner().expect("writing to memory")
}

fn io(path: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: {e}", path.display())
}

/// Byte length of `file` up to and including its last newline (a row cut
/// off by a kill is dropped).
fn complete_length(file: &mut File, path: &Path) -> Result<u64, String> {
    file.rewind().map_err(|e| io(path, e))?;
    let mut reader = BufReader::with_capacity(1 << 16, &mut *file);
    let (mut pos, mut good) = (0u64, 0u64);
    loop {
        let buf = reader.fill_buf().map_err(|e| io(path, e))?;
        if buf.is_empty() {
            break;
        }
        if let Some(k) = buf.iter().rposition(|&b| b == b'\n') {
            good = pos + k as u64 + 1;
        }
        let n = buf.len();
        pos += n as u64;
        reader.consume(n);
    }
    Ok(good)
}

/// Where the header `found` first differs from `want`: the first column
/// (by number and name) that is not the same, or the columns one has
/// beyond the other.
fn header_difference(found: &[String], want: &[String]) -> String {
    match found.iter().zip(want).position(|(f, w)| f != w) {
        Some(k) => format!("column {} is `{}`, this sweep's is `{}`", k + 1, found[k], want[k]),
        None if found.len() > want.len() => format!(
            "it has {} columns, this sweep {}: `{}` and after it are not this sweep's",
            found.len(),
            want.len(),
            found[want.len()]
        ),
        None => format!(
            "it has {} columns, this sweep {}: it lacks `{}` and the columns after it",
            found.len(),
            want.len(),
            want[found.len()]
        ),
    }
}

/// The rows of a `sweep.csv` (its first `len` bytes) as `(run, record)`.
struct Rows {
    reader: csv::Reader<std::io::Take<File>>,
    path: PathBuf,
    record: csv::StringRecord,
}

impl Rows {
    /// Opens `path`, reads the header and checks it against `header`.
    fn open(path: &Path, len: Option<u64>, header: Option<&[String]>) -> Result<(Self, Vec<String>), String> {
        let file = crate::output::transaction::no_follow(OpenOptions::new().read(true))
            .open(path)
            .map_err(|e| ezy_scene::files::io_message(path, &e, &format!("cannot open {}", path.display())))?;
        let len = match len {
            Some(l) => l,
            None => file.metadata().map_err(|e| io(path, e))?.len(),
        };
        let mut reader = csv::ReaderBuilder::new().has_headers(true).from_reader(file.take(len));
        let found: Vec<String> = reader.headers().map_err(|e| io(path, e))?.iter().map(String::from).collect();
        if let Some(h) = header
            && found != h
        {
            return Err(format!(
                "{}: its header is not this sweep's ({}); use another --out",
                path.display(),
                header_difference(&found, h)
            ));
        }
        Ok((Self { reader, path: path.into(), record: csv::StringRecord::new() }, found))
    }

    /// The next row's run number, or `None` at the end.
    fn next(&mut self) -> Result<Option<u64>, String> {
        if !self.reader.read_record(&mut self.record).map_err(|e| io(&self.path, e))? {
            return Ok(None);
        }
        let line = self.record.position().map_or(0, |p| p.line());
        self.record
            .get(0)
            .and_then(|s| s.parse().ok())
            .map(Some)
            .ok_or_else(|| format!("{} line {line}: the first field is not a run number", self.path.display()))
    }

    fn line(&self) -> u64 {
        self.record.position().map_or(0, |p| p.line())
    }
}

/// Which runs `sweep.csv` already has, read as the dispatch passes them
/// (run numbers ascend in the file).
pub(crate) struct DoneCursor {
    rows: Option<Rows>,
    next: Option<u64>,
}

impl DoneCursor {
    /// Whether run `i` is done; `i` must not decrease between calls.
    pub(crate) fn is_done(&mut self, i: u64) -> bool {
        while let Some(n) = self.next {
            if n >= i {
                return n == i;
            }
            self.next = self.rows.as_mut().and_then(|r| r.next().ok().flatten());
        }
        false
    }
}

/// A sweep's output directory, locked, with `sweep.csv` open for
/// appending.
pub(crate) struct Output {
    _lock: File,
    file: File,
    path: PathBuf,
    /// Byte length of the rows that were there when it was opened.
    len: u64,
    /// Runs already in `sweep.csv` when it was opened.
    pub done: u64,
    /// When runs are missing between the rows already there (a row
    /// deleted by hand): the table being rewritten in run order.
    refill: Option<Refill>,
}

/// Prefix of the temporary table a resume that fills gaps writes (next
/// to `sweep.csv`; one a kill left behind is removed by the next resume).
const REFILL_PREFIX: &str = ".sweep.csv.";

/// A resume that fills gaps: the new table (a temporary file next to
/// `sweep.csv`) takes the rows already there and the new ones in run
/// order, and replaces `sweep.csv` (a rename) when the sweep stops.
struct Refill {
    tmp: tempfile::NamedTempFile,
    /// The rows already there, read as the new ones pass them.
    old: Rows,
    /// The run of the row in `old.record` not yet copied.
    next_old: Option<u64>,
}

impl Refill {
    /// Copies the rows already there whose run is below `i` (all with
    /// `None`) into the new table, each written as ezy writes a row.
    fn copy_below(&mut self, i: Option<u64>, path: &Path) -> Result<(), String> {
        while let Some(j) = self.next_old {
            if i.is_some_and(|i| j >= i) {
                break;
            }
            let fields: Vec<&str> = self.old.record.iter().collect();
            self.tmp.write_all(&line(&fields)).map_err(|e| io(path, e))?;
            self.next_old = self.old.next()?;
        }
        Ok(())
    }
}

impl Output {
    /// Locks `dir`, checks or writes `sweep.toml`, and opens `sweep.csv`:
    /// a new one with `header`, or the one there after checking each row
    /// against `plan` (its parameter values must be the plan's for its
    /// run number) and cutting off a row a kill left unfinished. When
    /// runs are missing between the rows there (a row deleted), the rows
    /// of this sweep go into a new table in run order, which replaces
    /// `sweep.csv` at [`Output::finish`] (the rows there are kept as they
    /// are until then).
    ///
    /// # Errors
    /// `dir` locked by another run or holding another sweep, a row that
    /// is not this sweep's, or an I/O error, each naming the file; a
    /// signal that arrived while the rows were checked.
    pub(crate) fn open(
        dir: &Path,
        manifest: &Manifest,
        header: &[String],
        plan: &Plan,
        shard: Option<(u64, u64)>,
    ) -> Result<Self, String> {
        let lock = crate::output::transaction::lock(dir).map_err(|e| e.to_string())?;
        let path = dir.join(CSV);
        match Manifest::read(dir)? {
            Some(found) => {
                if let Some(d) = found.differs(manifest) {
                    return Err(format!(
                        "{} holds another sweep: its {TOML} has {d}; give another --out, or remove the directory to start over",
                        dir.display()
                    ));
                }
            }
            None => {
                if std::fs::symlink_metadata(&path).is_ok() {
                    return Err(format!(
                        "{} exists without {TOML}: it is not a sweep of this ezy; give another --out",
                        path.display()
                    ));
                }
                crate::output::transaction::write_atomically(&dir.join(TOML), manifest.text().as_bytes())
                    .map_err(|e| e.to_string())?;
            }
        }
        remove_stale_refills(dir);
        let exists = std::fs::symlink_metadata(&path).is_ok();
        let mut file = crate::output::transaction::no_follow(OpenOptions::new().read(true).append(true).create(true))
            .open(&path)
            .map_err(|e| ezy_scene::files::io_message(&path, &e, &format!("cannot open {}", path.display())))?;
        if !file.metadata().map_err(|e| io(&path, e))?.is_file() {
            return Err(format!("{} is not a regular file", path.display()));
        }
        let header_line = line(header);
        let len = if exists { complete_length(&mut file, &path)? } else { 0 };
        let mut done = 0;
        let mut gaps = false;
        if len == 0 {
            file.set_len(0).map_err(|e| io(&path, e))?;
            file.write_all(&header_line).map_err(|e| io(&path, e))?;
            file.sync_all().map_err(|e| io(&path, e))?;
        } else {
            // cut off what a kill left unfinished, then check every row
            file.set_len(len).map_err(|e| io(&path, e))?;
            let (mut rows, _) = Rows::open(&path, Some(len), Some(header))?;
            let (k0, stride) = shard.unwrap_or((0, 1));
            let mut last: Option<u64> = None;
            let mut values = Vec::new();
            let mut buf = zmij::Buffer::new();
            while let Some(i) = rows.next()? {
                // a long table is read within a second of a signal
                if done % 4096 == 0 && crate::output::transaction::pending().is_some() {
                    return Err(format!("stopped while checking the rows of {}", path.display()));
                }
                let line = rows.line();
                let bad = |why: String| format!("{} line {line}: {why}; give another --out", path.display());
                if i >= plan.runs() || i % stride != k0 {
                    return Err(bad(format!("run {i} is not a run of this sweep (or shard)")));
                }
                if last.is_some_and(|l| l >= i) {
                    return Err(bad(format!("run {i} is out of order")));
                }
                plan.values_into(i, &mut values);
                for (k, v) in values.iter().enumerate() {
                    let found = rows.record.get(k + 1).unwrap_or("");
                    // the number read back, so that any shortest round-trip
                    // form of the value is the value
                    if found.parse::<f64>().map(f64::to_bits) != Ok(v.to_bits()) {
                        return Err(bad(format!(
                            "run {i} has {} = {found}, but this sweep's run {i} has {}",
                            plan.axes[k].name,
                            crate::output::csv::format_number(&mut buf, *v)
                        )));
                    }
                }
                // a run of this shard skipped since the row before
                gaps |= (i - k0) / stride != done;
                last = Some(i);
                done += 1;
            }
        }
        let refill = if gaps {
            let mut tmp = crate::output::transaction::temp_beside(&path).map_err(|e| io(&path, e))?;
            tmp.write_all(&header_line).map_err(|e| io(&path, e))?;
            let (mut old, _) = Rows::open(&path, Some(len), None)?;
            let next_old = old.next()?;
            Some(Refill { tmp, old, next_old })
        } else {
            None
        };
        Ok(Self { _lock: lock, file, path, len, done, refill })
    }

    /// The runs already done, for the dispatch.
    ///
    /// # Errors
    /// The file cannot be read again.
    pub(crate) fn done_cursor(&self) -> Result<DoneCursor, String> {
        if self.done == 0 {
            return Ok(DoneCursor { rows: None, next: None });
        }
        let (mut rows, _) = Rows::open(&self.path, Some(self.len), None)?;
        let next = rows.next()?;
        Ok(DoneCursor { rows: Some(rows), next })
    }

    /// Appends run `i`'s row (a whole line); runs come in ascending order.
    /// When gaps are being filled, the rows already there below `i` go
    /// first.
    ///
    /// # Errors
    /// The write failed (a full disk), naming the file.
    pub(crate) fn append(&mut self, i: u64, line: &[u8]) -> Result<(), String> {
        match &mut self.refill {
            None => self.file.write_all(line).map_err(|e| io(&self.path, e)),
            Some(r) => {
                r.copy_below(Some(i), &self.path)?;
                r.tmp.write_all(line).map_err(|e| io(&self.path, e))
            }
        }
    }

    /// Syncs the table to disk. When gaps are being filled, the rows
    /// already there that remain go into the new table, which then
    /// replaces `sweep.csv` (so a sweep stopped by a signal keeps every
    /// row, in run order).
    ///
    /// # Errors
    /// The sync or the rename failed, naming the file (`sweep.csv` is
    /// then left as it was).
    pub(crate) fn finish(&mut self) -> Result<(), String> {
        let Some(mut r) = self.refill.take() else {
            return self.file.sync_all().map_err(|e| io(&self.path, e));
        };
        r.copy_below(None, &self.path)?;
        r.tmp.as_file().sync_all().map_err(|e| io(&self.path, e))?;
        r.tmp.persist(&self.path).map_err(|e| io(&self.path, e.error))?;
        if let Some(dir) = self.path.parent()
            && let Ok(d) = File::open(dir)
        {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// The table's path.
    pub(crate) fn csv_path(&self) -> PathBuf {
        self.path.clone()
    }
}

/// Combines the `sweep.csv` of a sweep's shards (`dirs`, in any order)
/// into `out/sweep.csv` and `out/sweep.toml`, identical to what the
/// unsharded sweep writes (the runs' `wall_s` aside). Returns the merged
/// definition and the files written.
///
/// # Errors
/// A directory that is not a shard of the same sweep, a shard missing or
/// given twice, a run missing (its shard unfinished: re-run it to resume,
/// then merge again), `out` among the shards or holding another sweep.
pub(crate) fn merge(dirs: &[PathBuf], out: &Path) -> Result<(Manifest, Vec<PathBuf>), String> {
    let mut shards: Vec<(u64, u64, PathBuf, Manifest)> = Vec::new();
    for d in dirs {
        let m =
            Manifest::read(d)?.ok_or_else(|| format!("{}: no {TOML}; not the output of `ezy sweep`", d.display()))?;
        let (k, n) = match &m.shard {
            Some(s) => parse_shard(s).map_err(|e| format!("{}: shard {e}", d.join(TOML).display()))?,
            None => (0, 1),
        };
        shards.push((k, n, d.clone(), m));
    }
    let n = shards[0].1;
    let mut merged = shards[0].3.clone();
    merged.shard = None;
    for (k, nk, d, m) in &shards {
        let mut m = m.clone();
        m.shard = None;
        if let Some(diff) = m.differs(&merged) {
            return Err(format!("{} is a shard of another sweep than {}: {diff}", d.display(), shards[0].2.display()));
        }
        if *nk != n {
            return Err(format!("{} is shard {k}/{nk}, but {} is one of {n}", d.display(), shards[0].2.display()));
        }
        if same_dir(d, out) {
            return Err(format!("--out {} is one of the shards; merge into another directory", out.display()));
        }
    }
    shards.sort_by_key(|s| s.0);
    for k in 0..n {
        match shards.iter().filter(|s| s.0 == k).count() {
            1 => {}
            0 => return Err(format!("shard {k}/{n} is missing (given: {})", list_dirs(&shards))),
            _ => return Err(format!("shard {k}/{n} is given twice")),
        }
    }
    let mut readers = Vec::new();
    let mut header: Option<Vec<String>> = None;
    for (_, _, d, _) in &shards {
        let (rows, h) = Rows::open(&d.join(CSV), None, header.as_deref())?;
        header.get_or_insert(h);
        readers.push(rows);
    }
    let header = header.expect("at least one shard");
    let lock = crate::output::transaction::lock(out).map_err(|e| e.to_string())?;
    if let Some(found) = Manifest::read(out)?
        && let Some(d) = found.differs(&merged)
    {
        return Err(format!("{} holds another sweep: its {TOML} has {d}; merge into another directory", out.display()));
    }
    let csv_path = out.join(CSV);
    // 0666 less the umask, as any table ezy writes
    let mut tmp = crate::output::transaction::temp_beside(&csv_path).map_err(|e| io(&csv_path, e))?;
    {
        let mut w = writer(std::io::BufWriter::new(tmp.as_file_mut()));
        w.write_record(&header).map_err(|e| io(&csv_path, e))?;
        // run i is in shard i mod n, whose rows ascend
        for i in 0..merged.runs {
            let k = (i % n) as usize;
            let r = &mut readers[k];
            match r.next()? {
                Some(j) if j == i => {
                    if r.record.len() != header.len() {
                        return Err(format!(
                            "{} line {}: {} fields, expected {}",
                            r.path.display(),
                            r.line(),
                            r.record.len(),
                            header.len()
                        ));
                    }
                    w.write_record(&r.record).map_err(|e| io(&csv_path, e))?;
                }
                other => {
                    let at = other.map_or_else(|| "its table ends".to_string(), |j| format!("it has run {j} instead"));
                    return Err(format!(
                        "run {i} is missing from {} (shard {k}/{n}: {at}); run that shard's command again to finish it, then merge again",
                        shards[k].2.display()
                    ));
                }
            }
        }
        for (k, r) in readers.iter_mut().enumerate() {
            if let Some(j) = r.next()? {
                return Err(format!(
                    "{} holds run {j}, beyond this sweep's {} runs",
                    shards[k].2.display(),
                    merged.runs
                ));
            }
        }
        w.flush().map_err(|e| io(&csv_path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| io(&csv_path, e))?;
    crate::output::transaction::write_atomically(&out.join(TOML), merged.text().as_bytes())
        .map_err(|e| e.to_string())?;
    tmp.persist(&csv_path).map_err(|e| io(&csv_path, e.error))?;
    drop(lock);
    Ok((merged, vec![csv_path, out.join(TOML)]))
}

/// Removes the temporary tables of resumes that were killed while
/// filling gaps (the caller holds the directory's lock). Links and
/// directories of such a name are left alone.
fn remove_stale_refills(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().starts_with(REFILL_PREFIX) && e.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

fn list_dirs(shards: &[(u64, u64, PathBuf, Manifest)]) -> String {
    shards.iter().map(|s| format!("{} ({}/{})", s.2.display(), s.0, s.1)).collect::<Vec<_>>().join(", ")
}

/// Reads the columns `names` of every `ok` row of `dir/sweep.csv` (as
/// `f64`, `NaN` for a failed run's empty fields), in run order: what the
/// figures draw.
///
/// # Errors
/// The file cannot be read, or lacks a column.
pub(crate) fn read_columns(dir: &Path, names: &[String]) -> Result<Vec<Vec<f64>>, String> {
    let path = dir.join(CSV);
    let (mut rows, header) = Rows::open(&path, None, None)?;
    let at: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).ok_or_else(|| format!("{}: no column `{n}`", path.display())))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::new();
    while rows.next()?.is_some() {
        out.push(at.iter().map(|&k| rows.record.get(k).and_then(|s| s.parse().ok()).unwrap_or(f64::NAN)).collect());
    }
    Ok(out)
}

/// `K/N` of `--shard`: 0 <= K < N.
///
/// # Errors
/// Not two whole numbers, N = 0 or K >= N.
pub(crate) fn parse_shard(s: &str) -> Result<(u64, u64), String> {
    let (k, n) = s.split_once('/').ok_or_else(|| format!("`{s}`: expected K/N (shard K of N, K from 0)"))?;
    let k: u64 = k.trim().parse().map_err(|_| format!("`{s}`: `{k}` is not a whole number"))?;
    let n: u64 = n.trim().parse().map_err(|_| format!("`{s}`: `{n}` is not a whole number"))?;
    if n == 0 || k >= n {
        return Err(format!("`{s}`: need 0 <= K < N"));
    }
    Ok((k, n))
}
