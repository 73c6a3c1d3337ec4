//! Output as a transaction, and the signals that may cancel one.
//!
//! A command that writes several files into an output directory (`ezy run`:
//! `trajectory.csv` and the figures; `ezy precision`: `precision.csv` and
//! its figures) writes them through a `Transaction`:
//!
//! 1. `Transaction::begin` creates the directory, opens the lock file
//!    [`LOCK_FILE`] in it (never through a symbolic link) and takes an
//!    exclusive advisory lock on it without waiting: a second run into the
//!    same directory is refused with "another ezy run is writing into DIR".
//!    It then removes the private directories of runs that were killed
//!    (`SIGKILL`, a second Ctrl-C, a power cut), which only a run holding
//!    the lock may do, and creates its own private directory
//!    `DIR/.ezy-run.XXXXXX` (random name, mode 0700, created exclusively).
//! 2. Every file is written into that private directory, created
//!    exclusively (`O_CREAT | O_EXCL | O_NOFOLLOW`), and synced to disk.
//! 3. `Transaction::commit` renames each file onto its final name in the
//!    output directory, the *first* file staged (the table) *last*; a rename
//!    replaces a symbolic link of that name, it never writes through it. If
//!    a rename fails, the files already renamed are put back (from hard
//!    links of the previous files taken just before).
//! 4. Dropping a transaction that was not committed (an error, an
//!    interruption) removes the private directory: the previous output is
//!    left exactly as it was. An output directory the command created
//!    (and its parents) goes too, with its lock file, where nothing was
//!    committed into it: a refusal leaves no empty directory behind.
//!
//! What a reader sees: every file is always either the previous complete
//! version or the new complete version, never a partial one (a rename is
//! atomic per file). While a commit is under way (a few renames, well under
//! a millisecond) the figures may already be new while the table is still
//! the previous one; once the table is new, every file of the set is. A
//! reader that must never see a mixed set takes a shared lock on
//! [`LOCK_FILE`] (`flock -s DIR/.ezy.lock cat DIR/trajectory.csv`), which
//! waits for a run in progress. Files a run does not write (figures of
//! another scene, or all figures with `--no-figures`) are left untouched.
//!
//! Signals: [`handle_signals`] (called by [`crate::App::main`]) makes the
//! first `SIGINT` or `SIGTERM` received after a transaction began only
//! set a flag; the run checks it at every output row and before every
//! figure (`check_interrupt`) and stops with [`Interrupted`]. A second
//! signal ends the process at once with the default action (its private
//! directory is then removed by the next run into the same directory).

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// The lock file every run takes in its output directory. It stays there
/// (empty) after the run: removing it would let two runs lock two
/// different files of one name. (A directory the command created and
/// committed nothing into is removed with it, before the lock is
/// released.)
pub const LOCK_FILE: &str = ".ezy.lock";

/// How long a lock found taken is tried again before the run is refused
/// as [`TransactionError::Busy`] (see [`lock`]): 50 ms, far longer than
/// a fork takes to exec; a run that ends within it leaves the directory
/// to this one, as if this one had started 50 ms later.
const LOCK_PATIENCE: std::time::Duration = std::time::Duration::from_millis(50);

/// Prefix of a run's private directory inside the output directory.
pub(crate) const TEMP_PREFIX: &str = ".ezy-run.";

/// A termination signal that stops a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// `SIGINT` (Ctrl-C).
    Int,
    /// `SIGTERM`.
    Term,
    /// `SIGHUP` (the terminal closed).
    Hup,
}

impl Signal {
    /// `"SIGINT"`, `"SIGTERM"` or `"SIGHUP"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Int => "SIGINT",
            Self::Term => "SIGTERM",
            Self::Hup => "SIGHUP",
        }
    }

    /// The conventional exit status of a process stopped by the signal:
    /// 128 + its number (130 for `SIGINT`, 143 for `SIGTERM`, 129 for
    /// `SIGHUP`).
    pub fn exit_code(self) -> u8 {
        match self {
            Self::Int => 130,
            Self::Term => 143,
            Self::Hup => 129,
        }
    }
}

/// A run stopped by a signal before it committed anything.
#[derive(Debug, Clone, PartialEq)]
pub struct Interrupted {
    /// The signal.
    pub signal: Signal,
    /// The output directory, left as it was.
    pub dir: PathBuf,
    /// Simulated time in seconds the run had reached, when it had one.
    pub t: Option<f64>,
    /// What the run was doing (`"drawing fig3.png"`), when not integrating.
    pub doing: Option<String>,
    /// What became of the output, when not "previous output in DIR left
    /// as it was" (a sweep keeps the rows of its finished runs).
    pub kept: Option<String>,
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "interrupted ({})", self.signal.name())?;
        if let Some(t) = self.t {
            // 9 significant digits at most: `25.41`, not `25.410000000000004`
            // (and `1e300`, not 301 digits)
            let t: f64 = format!("{t:.8e}").parse().unwrap_or(t);
            write!(f, " at t = {} s", ezy_core::fmt_value(t))?;
        }
        if let Some(d) = &self.doing {
            write!(f, ", {d}")?;
        }
        match &self.kept {
            Some(k) => write!(f, "; {k}"),
            None => write!(f, "; previous output in {} left as it was", self.dir.display()),
        }
    }
}

/// Why output could not be written or committed. In every case the
/// previous output is left as it was.
#[derive(Debug, thiserror::Error)]
pub enum TransactionError {
    /// Another process holds the directory's lock.
    #[error("another ezy run is writing into {}; wait for it to finish or choose another --out", dir.display())]
    Busy {
        /// The output directory.
        dir: PathBuf,
    },
    /// The output directory cannot be created.
    #[error("{}", ezy_scene::files::io_message(path, source, &format!("cannot create output directory {}", path.display())))]
    OutDir {
        /// The directory.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file could not be created, written, synced or renamed. `path` is
    /// the file's final name (its temporary copy lives in the run's
    /// private directory).
    #[error("{}", ezy_scene::files::io_message(path, source, &path.display().to_string()))]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A name in the output directory is not what ezy may use: a symbolic
    /// link or other non-regular file where the lock file belongs, or a
    /// directory where an output file belongs.
    #[error("{}: {reason}", path.display())]
    Unusable {
        /// The path.
        path: PathBuf,
        /// Why.
        reason: &'static str,
    },
    /// An output file name is not a plain file name.
    #[error("`{name}` cannot be an output file name: {reason}")]
    Name {
        /// The name.
        name: String,
        /// Why.
        reason: &'static str,
    },
    /// One run would write the same file twice (two figures with one file
    /// name).
    #[error("{}: written twice by this run (two figures with one file name?)", path.display())]
    Duplicate {
        /// The file.
        path: PathBuf,
    },
    /// A rename failed during the commit; the files already renamed were
    /// put back (`restored`) or, where no earlier version could be kept,
    /// removed.
    #[error("{}: {source} (while committing the output; {})", path.display(),
        if *restored { "the previous files were put back" } else { "some previous files could not be put back" })]
    Commit {
        /// The file whose rename failed.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
        /// Whether every file already renamed was restored.
        restored: bool,
    },
    /// A signal stopped the run.
    #[error("{0}")]
    Interrupted(Interrupted),
}

/// One run's output: a locked directory, a private directory inside it with
/// the files written so far, and the names they get on commit.
///
/// Dropping it without [`Transaction::commit`] removes the private
/// directory and releases the lock, leaving the directory as it was.
#[derive(Debug)]
pub(crate) struct Transaction {
    // Field order is drop order: the private directory goes before the
    // lock is released, and a directory this run created and left empty
    // with it.
    tmp: tempfile::TempDir,
    _fresh: Fresh,
    _lock: File,
    dir: PathBuf,
    staged: Vec<String>,
    /// Files of the command's own set this run does not write, removed
    /// after the renames ([`Transaction::retire`]).
    retired: Vec<String>,
}

/// An output directory's lock, taken by a command before its work (the
/// runs of `ezy optimize`, `ezy analyze`'s searches) and held until its
/// transaction commits ([`Transaction::begin_locked`]) or the command
/// ends: a second command into the same directory meanwhile is refused
/// at its start ([`TransactionError::Busy`]), instead of both working and
/// the last commit silently replacing the first one's output.
#[derive(Debug)]
pub(crate) struct OutLock {
    // drop order: the directories before the lock is released
    fresh: Fresh,
    file: File,
    dir: PathBuf,
}

/// The output directory and the parents of it that a command created:
/// dropped while the directory holds nothing but [`LOCK_FILE`] (a command
/// refused or stopped after it took the lock, before anything was
/// committed), the lock file and those directories are removed again, so
/// that a refusal leaves the file system as it found it. Dropped before
/// the lock is released: a run that waited for it then finds the
/// directory gone and is refused cleanly.
#[derive(Debug, Default)]
struct Fresh {
    /// The directories created, the output directory first.
    created: Vec<PathBuf>,
}

impl Fresh {
    /// The directories of `dir`'s path (itself and its parents) that do
    /// not exist yet, `dir` first.
    fn missing(dir: &Path) -> Self {
        let created = dir.ancestors().take_while(|d| !d.as_os_str().is_empty() && !d.exists()).map(Path::to_path_buf);
        Self { created: created.collect() }
    }
}

impl Drop for Fresh {
    fn drop(&mut self) {
        let Some(dir) = self.created.first() else { return };
        let only_lock = std::fs::read_dir(dir)
            .map(|entries| entries.flatten().all(|e| e.file_name() == LOCK_FILE))
            .unwrap_or(false);
        if !only_lock || std::fs::remove_file(dir.join(LOCK_FILE)).is_err() {
            return;
        }
        // each removal fails, harmlessly, where something else is inside
        for d in &self.created {
            if std::fs::remove_dir(d).is_err() {
                return;
            }
        }
    }
}

impl OutLock {
    /// Creates `dir` if needed and takes its lock (see [`lock`]). Arms no
    /// signal handler: Ctrl-C keeps its default action during the work,
    /// which writes nothing.
    ///
    /// # Errors
    /// As [`Transaction::begin`]: [`TransactionError::Busy`] naming `dir`
    /// if another run holds it.
    pub(crate) fn take(dir: &Path) -> Result<Self, TransactionError> {
        let fresh = Fresh::missing(dir);
        let file = lock(dir)?;
        Ok(Self { fresh, file, dir: dir.into() })
    }
}

/// What was at a final name before the commit.
enum Previous {
    /// Nothing.
    Absent,
    /// A file, hard-linked here.
    Kept(PathBuf),
    /// A file that could not be linked (a file system without hard links).
    Lost,
}

/// `O_NOFOLLOW`: opening a symbolic link fails instead of following it.
#[cfg(unix)]
pub(crate) fn no_follow(o: &mut OpenOptions) -> &mut OpenOptions {
    use std::os::unix::fs::OpenOptionsExt;
    // O_NONBLOCK: a FIFO planted as the lock file cannot block the open.
    o.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
}

#[cfg(not(unix))]
pub(crate) fn no_follow(o: &mut OpenOptions) -> &mut OpenOptions {
    o
}

impl Transaction {
    /// Creates `dir` (and its parents) if needed, locks it, removes what
    /// killed runs left and creates this run's private directory.
    ///
    /// # Errors
    /// [`TransactionError::Busy`] if another run holds the lock,
    /// [`TransactionError::OutDir`] if `dir` cannot be created,
    /// [`TransactionError::Unusable`] if the lock file is a symbolic link or
    /// not a regular file, [`TransactionError::Io`] if it cannot be opened or
    /// locked or the private directory cannot be created,
    /// [`TransactionError::Interrupted`] if a signal has already arrived.
    pub(crate) fn begin(dir: &Path) -> Result<Self, TransactionError> {
        arm_signals();
        Self::begin_locked(OutLock::take(dir)?)
    }

    /// Begins a transaction in the directory `held` locks: the lock a
    /// command took before its work ([`OutLock::take`]) is kept through
    /// the commit, so that no other run commits into the directory
    /// between the two.
    ///
    /// # Errors
    /// As [`Transaction::begin`], [`TransactionError::Busy`] aside.
    pub(crate) fn begin_locked(held: OutLock) -> Result<Self, TransactionError> {
        arm_signals();
        let OutLock { fresh, file: lock, dir } = held;
        remove_stale(&dir);
        let mut builder = tempfile::Builder::new();
        builder.prefix(TEMP_PREFIX);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o700));
        }
        let tmp = builder
            .tempdir_in(&dir)
            .map_err(|source| TransactionError::Io { path: dir.join(format!("{TEMP_PREFIX}XXXXXX")), source })?;
        let tx = Self { tmp, _fresh: fresh, _lock: lock, dir, staged: Vec::new(), retired: Vec::new() };
        tx.check(None, None)?;
        Ok(tx)
    }

    /// The output directory.
    pub(crate) fn dir(&self) -> &Path {
        &self.dir
    }

    /// The final path of output file `name`.
    pub(crate) fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Creates output file `name` in the private directory (exclusively,
    /// never through a link) for the caller to write; the caller syncs it
    /// ([`sync`]). The first file created is renamed last on commit.
    ///
    /// # Errors
    /// [`TransactionError::Name`] for a name that is not a plain file name
    /// (or is one of ezy's own), [`TransactionError::Duplicate`] for a name
    /// given twice, [`TransactionError::Io`] naming the final path if the
    /// file cannot be created (a name too long for the file system, a full
    /// disk).
    pub(crate) fn create(&mut self, name: &str) -> Result<File, TransactionError> {
        check_name(name)?;
        if self.staged.iter().any(|n| n == name) {
            return Err(TransactionError::Duplicate { path: self.path(name) });
        }
        let file = no_follow(OpenOptions::new().write(true).create_new(true))
            .open(self.tmp.path().join(name))
            .map_err(|source| TransactionError::Io { path: self.path(name), source })?;
        self.staged.push(name.to_string());
        Ok(file)
    }

    /// Writes output file `name` with `bytes` and syncs it (see
    /// [`Transaction::create`]).
    ///
    /// # Errors
    /// As [`Transaction::create`]; [`TransactionError::Io`] naming the final
    /// path if writing or syncing fails (a full disk).
    pub(crate) fn write(&mut self, name: &str, bytes: &[u8]) -> Result<(), TransactionError> {
        let mut file = self.create(name)?;
        let path = self.path(name);
        file.write_all(bytes).map_err(|source| TransactionError::Io { path: path.clone(), source })?;
        sync(&file, &path)
    }

    /// Marks files of the command's own set that this run does not write
    /// (`B.csv` of a `linearize` without inputs, `periodic.csv` of an
    /// `analyze` that found steady motions): a previous run's are removed
    /// on commit, after the renames, so the directory never holds this
    /// run's files beside another's. Names written, or not plain file
    /// names, are ignored; a directory of the name is left.
    pub(crate) fn retire(&mut self, names: &[String]) {
        self.retired.extend(names.iter().filter(|n| check_name(n).is_ok()).cloned());
    }

    /// [`check_interrupt`] for this transaction's directory.
    ///
    /// # Errors
    /// [`TransactionError::Interrupted`] if a signal has arrived.
    pub(crate) fn check(&self, t: Option<f64>, doing: Option<String>) -> Result<(), TransactionError> {
        check_interrupt(&self.dir, t, doing)
    }

    /// Renames every file written onto its final name, the first one
    /// created last, and removes the private directory. Returns the final
    /// paths in the order the files were created.
    ///
    /// # Errors
    /// [`TransactionError::Interrupted`] if a signal arrived before the
    /// commit began (nothing is renamed), [`TransactionError::Unusable`] if
    /// a final name is a directory (nothing is renamed),
    /// [`TransactionError::Commit`] if a rename fails (the renamed files are
    /// put back).
    pub(crate) fn commit(self) -> Result<Vec<PathBuf>, TransactionError> {
        self.check(None, None)?;
        let mut order: Vec<&String> = self.staged.iter().skip(1).collect();
        order.extend(self.staged.first());
        for name in &order {
            let target = self.path(name);
            if std::fs::symlink_metadata(&target).is_ok_and(|m| m.is_dir()) {
                return Err(TransactionError::Unusable {
                    path: target,
                    reason: "is a directory; ezy writes a file of this name here (remove or rename it)",
                });
            }
        }
        // Hard links of the previous files, to put them back if a rename
        // fails half-way. The links live in the private directory. The
        // last file renamed needs none (its failed rename leaves it as it
        // was), so a single file (`--no-figures`) takes no link at all.
        let previous = self.tmp.path().join(".previous");
        let backed_up = &order[..order.len().saturating_sub(1)];
        let kept = !backed_up.is_empty() && std::fs::create_dir(&previous).is_ok();
        let before: Vec<Previous> = backed_up
            .iter()
            .map(|name| {
                let target = self.path(name);
                let backup = previous.join(name);
                if std::fs::symlink_metadata(&target).is_err() {
                    Previous::Absent
                } else if kept && std::fs::hard_link(&target, &backup).is_ok() {
                    Previous::Kept(backup)
                } else {
                    Previous::Lost
                }
            })
            .collect();
        for (k, name) in order.iter().enumerate() {
            let target = self.path(name);
            if let Err(source) = std::fs::rename(self.tmp.path().join(name), &target) {
                let mut restored = true;
                for (done, prev) in order[..k].iter().zip(&before).rev() {
                    let target = self.path(done);
                    restored &= match prev {
                        Previous::Kept(b) => std::fs::rename(b, &target).is_ok(),
                        Previous::Absent => std::fs::remove_file(&target).is_ok(),
                        Previous::Lost => false,
                    };
                }
                return Err(TransactionError::Commit { path: target, source, restored });
            }
        }
        for name in self.retired.iter().filter(|n| !self.staged.contains(n)) {
            let target = self.path(name);
            if std::fs::symlink_metadata(&target).is_ok_and(|m| !m.is_dir()) {
                let _ = std::fs::remove_file(&target);
            }
        }
        if let Ok(d) = File::open(&self.dir) {
            let _ = d.sync_all();
        }
        let files = self.staged.iter().map(|n| self.path(n)).collect();
        Ok(files)
    }
}

/// Syncs `file` to disk; errors name `path` (the file's final name).
///
/// # Errors
/// [`TransactionError::Io`] if the data cannot be written (a full disk).
pub(crate) fn sync(file: &File, path: &Path) -> Result<(), TransactionError> {
    file.sync_all().map_err(|source| TransactionError::Io { path: path.into(), source })
}

/// Writes one file atomically without a lock: `bytes` go into a uniquely
/// named hidden temporary file next to `path` (created exclusively, never
/// through a link), which is synced and renamed onto `path`; on failure it
/// is removed and `path` is left as it was. The parent directory must
/// exist.
///
/// # Errors
/// [`TransactionError::Io`] naming `path`.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), TransactionError> {
    let io = |source| TransactionError::Io { path: path.into(), source };
    let mut tmp = temp_beside(path).map_err(io)?;
    tmp.write_all(bytes).map_err(io)?;
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

/// A uniquely named hidden temporary file next to `path` (`.NAME.XXXXXX`
/// in the same directory, so that renaming it onto `path` is atomic),
/// created exclusively, never through a link, with the mode a file
/// created by [`File::create`] gets: 0666 less the umask (a bare
/// [`tempfile::NamedTempFile`] is 0600 whatever the umask). Every file ezy
/// persists from a temporary file is made here. The parent directory must
/// exist.
///
/// # Errors
/// The file cannot be created (a missing or read-only directory).
pub(crate) fn temp_beside(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name().map_or_else(|| "output".into(), |n| n.to_string_lossy());
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix);
    #[cfg(unix)]
    {
        // like a file created by `File::create`: 0666 less the umask
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir)
}

/// A name ezy may give an output file: one plain path component, not one
/// of the names ezy uses for itself.
fn check_name(name: &str) -> Result<(), TransactionError> {
    let bad = |reason| Err(TransactionError::Name { name: name.into(), reason });
    let mut parts = Path::new(name).components();
    match (parts.next(), parts.next()) {
        (Some(Component::Normal(n)), None) if n == name => {}
        _ => return bad("it must be a plain file name, without directories"),
    }
    if name == LOCK_FILE || name.starts_with(TEMP_PREFIX) || name == ".previous" {
        return bad("ezy uses this name itself");
    }
    Ok(())
}

fn is_symlink(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}

/// Removes the private directories of earlier runs that never finished
/// (the caller holds the lock, so no live run owns one). A symbolic link
/// of such a name is left alone; nothing is followed.
fn remove_stale(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().starts_with(TEMP_PREFIX) && e.file_type().is_ok_and(|t| t.is_dir()) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

// ---------------------------------------------------------------- signals

/// Whether this process handles SIGINT and SIGTERM itself.
static HANDLE: AtomicBool = AtomicBool::new(false);
/// Set by the first SIGINT or SIGTERM once the handlers are installed.
static STOP: AtomicBool = AtomicBool::new(false);
/// Which signal set [`STOP`] (its number).
static WHICH: AtomicUsize = AtomicUsize::new(0);

/// Lets output transactions handle `SIGINT` and `SIGTERM` in this process:
/// from the first [`Transaction::begin`] on, the first such signal stops
/// the run at its next output row or figure, which removes its temporary
/// files and returns [`Interrupted`]; a second one ends the process at once.
/// Creates `dir` (and its parents) if needed and takes the exclusive lock
/// on its lock file, without waiting and never through a link.
pub(crate) fn lock(dir: &Path) -> Result<File, TransactionError> {
    std::fs::create_dir_all(dir).map_err(|source| TransactionError::OutDir { path: dir.into(), source })?;
    let lock_path = dir.join(LOCK_FILE);
    let lock =
        no_follow(OpenOptions::new().read(true).write(true).create(true)).open(&lock_path).map_err(|source| {
            if is_symlink(&lock_path) {
                TransactionError::Unusable {
                    path: lock_path.clone(),
                    reason: "is a symbolic link; ezy never follows links in its output directory (remove it)",
                }
            } else {
                TransactionError::Io { path: lock_path.clone(), source }
            }
        })?;
    let meta = lock.metadata().map_err(|source| TransactionError::Io { path: lock_path.clone(), source })?;
    if !meta.is_file() {
        return Err(TransactionError::Unusable {
            path: lock_path,
            reason: "is not a regular file; ezy uses this name as its lock file (remove it)",
        });
    }
    // A lock found taken is tried again for up to LOCK_PATIENCE: a process
    // forked by this one (a program, or a test harness, that starts
    // processes from other threads) holds a copy of every open file until
    // it execs, and with it this lock, for an instant after it was
    // released here. A run that truly holds it still refuses at once to
    // a person's eye.
    let deadline = std::time::Instant::now() + LOCK_PATIENCE;
    loop {
        match lock.try_lock() {
            Ok(()) => return Ok(lock),
            Err(std::fs::TryLockError::WouldBlock) if std::time::Instant::now() < deadline => {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            Err(std::fs::TryLockError::WouldBlock) => return Err(TransactionError::Busy { dir: dir.into() }),
            Err(std::fs::TryLockError::Error(source)) => return Err(TransactionError::Io { path: lock_path, source }),
        }
    }
}

/// Before a transaction begins (setup, `ezy precision`'s measurements) the
/// signals keep their default action, which writes nothing. Called by
/// [`crate::App::main`]; a program embedding ezy that handles signals
/// itself does not call it.
pub fn handle_signals() {
    HANDLE.store(true, Ordering::SeqCst);
}

/// Installs the handlers (once) if [`handle_signals`] was called.
pub(crate) fn arm_signals() {
    #[cfg(unix)]
    {
        static ARMED: std::sync::Once = std::sync::Once::new();
        if HANDLE.load(Ordering::SeqCst) {
            ARMED.call_once(|| {
                use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
                for sig in [SIGINT, SIGTERM, SIGHUP] {
                    // The order matters: the default action runs only on a
                    // signal that finds STOP already set (the second one).
                    let _ = signal_hook::flag::register_conditional_default(sig, &STOP);
                    let _ = signal_hook::flag::register_usize(sig, &WHICH, sig as usize);
                    let _ = signal_hook::flag::register(sig, &STOP);
                }
            });
        }
    }
}

/// Asks every run, sweep and output transaction of this process to stop
/// at its next check, as a first `SIGINT` would ([`pending`] then returns
/// [`Signal::Int`]): for a program that embeds ezy and catches the
/// interrupt itself (the Python package on `KeyboardInterrupt`). Undo it
/// with [`clear_stop`] once the stopped command has returned.
pub fn request_stop() {
    #[cfg(unix)]
    WHICH.store(signal_hook::consts::SIGINT as usize, Ordering::SeqCst);
    STOP.store(true, Ordering::SeqCst);
}

/// Forgets a stop asked by [`request_stop`] (or a signal), so that the next
/// command of an embedding program runs.
pub fn clear_stop() {
    STOP.store(false, Ordering::SeqCst);
    WHICH.store(0, Ordering::SeqCst);
}

/// The signal that asked this process to stop, if any.
pub fn pending() -> Option<Signal> {
    if !STOP.load(Ordering::SeqCst) {
        return None;
    }
    #[cfg(unix)]
    {
        let which = WHICH.load(Ordering::SeqCst);
        if which == signal_hook::consts::SIGTERM as usize {
            return Some(Signal::Term);
        }
        if which == signal_hook::consts::SIGHUP as usize {
            return Some(Signal::Hup);
        }
    }
    Some(Signal::Int)
}

/// Stops a run into `dir` if a signal has arrived.
///
/// # Errors
/// [`TransactionError::Interrupted`] with the signal, `dir`, the simulated
/// time `t` reached (seconds) and what the run was `doing`.
pub(crate) fn check_interrupt(dir: &Path, t: Option<f64>, doing: Option<String>) -> Result<(), TransactionError> {
    match pending() {
        None => Ok(()),
        Some(signal) => {
            Err(TransactionError::Interrupted(Interrupted { signal, dir: dir.into(), t, doing, kept: None }))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        for bad in ["", "a/b", "../x.png", "/x.png", ".", "..", LOCK_FILE, ".ezy-run.abc"] {
            assert!(check_name(bad).is_err(), "{bad:?}");
        }
        for good in ["trajectory.csv", "fig3 paths.png", "..png", ".hidden.png"] {
            assert!(check_name(good).is_ok(), "{good:?}");
        }
    }

    #[test]
    fn commit_renames_and_drop_cleans() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("out");
        let mut tx = Transaction::begin(&dir).unwrap();
        tx.write("a.csv", b"new table").unwrap();
        tx.write("b.png", b"new figure").unwrap();
        assert!(matches!(tx.write("b.png", b"again"), Err(TransactionError::Duplicate { .. })));
        assert!(matches!(Transaction::begin(&dir), Err(TransactionError::Busy { .. })));
        let files = tx.commit().unwrap();
        assert_eq!(files, vec![dir.join("a.csv"), dir.join("b.png")]);
        assert_eq!(std::fs::read(dir.join("a.csv")).unwrap(), b"new table");
        // an abandoned transaction leaves everything as it was
        let mut tx = Transaction::begin(&dir).unwrap();
        tx.write("a.csv", b"other").unwrap();
        drop(tx);
        assert_eq!(std::fs::read(dir.join("a.csv")).unwrap(), b"new table");
        assert_eq!(names_in(&dir), [LOCK_FILE, "a.csv", "b.png"]);
    }

    /// A directory (and parents) a transaction or a held lock created
    /// goes again when nothing was committed into it; one that existed
    /// keeps its lock file, and a committed one its output.
    #[test]
    fn an_abandoned_fresh_directory_is_removed() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("new/out");
        drop(OutLock::take(&dir).unwrap());
        assert!(!root.path().join("new").exists(), "the lock's directories were left");
        let mut tx = Transaction::begin(&dir).unwrap();
        tx.write("a.csv", b"table").unwrap();
        drop(tx);
        assert!(!root.path().join("new").exists(), "an abandoned transaction's directories were left");
        // a directory that existed keeps what it had
        std::fs::create_dir_all(&dir).unwrap();
        drop(OutLock::take(&dir).unwrap());
        assert_eq!(names_in(&dir), [LOCK_FILE]);
        // one that another file came into is kept
        let other = root.path().join("other");
        let held = OutLock::take(&other).unwrap();
        std::fs::write(other.join("mine.txt"), b"user's").unwrap();
        drop(held);
        assert_eq!(names_in(&other), [LOCK_FILE, "mine.txt"]);
        // a committed one keeps its output
        let done = root.path().join("done");
        let mut tx = Transaction::begin(&done).unwrap();
        tx.write("a.csv", b"table").unwrap();
        tx.commit().unwrap();
        assert_eq!(names_in(&done), [LOCK_FILE, "a.csv"]);
    }

    /// The names in `dir`, sorted.
    fn names_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    /// A directory holding the previous `a.csv` and `b.png`.
    fn previous_output() -> tempfile::TempDir {
        let root = tempfile::tempdir().unwrap();
        std::fs::write(root.path().join("a.csv"), b"old table").unwrap();
        std::fs::write(root.path().join("b.png"), b"old b").unwrap();
        root
    }

    /// Stages `files` (the first one the table) in a transaction into
    /// `dir`, loses the staged `lost` and commits: the commit fails and
    /// says the renamed files were put back.
    fn failed_commit(dir: &Path, files: &[&str], lost: &str) {
        let mut tx = Transaction::begin(dir).unwrap();
        for f in files {
            tx.write(f, format!("new {f}").as_bytes()).unwrap();
        }
        std::fs::remove_file(tx.tmp.path().join(lost)).unwrap();
        let err = tx.commit().unwrap_err();
        assert!(matches!(err, TransactionError::Commit { restored: true, .. }), "{err}");
        assert_eq!(std::fs::read(dir.join("a.csv")).unwrap(), b"old table");
        assert_eq!(std::fs::read(dir.join("b.png")).unwrap(), b"old b");
    }

    #[test]
    fn a_failed_rename_puts_the_previous_files_back() {
        let root = previous_output();
        // renamed in the order b.png, c.png, a.csv: c.png's rename fails
        failed_commit(root.path(), &["a.csv", "b.png", "c.png"], "c.png");
        assert!(!root.path().join("c.png").exists());
    }

    /// The table is renamed last and backed up by no link: when its rename
    /// fails, the figures renamed before it are put back and the previous
    /// table is untouched; a single file takes no link and fails the same.
    #[test]
    fn a_failed_last_rename_leaves_the_previous_table() {
        let root = previous_output();
        let dir = root.path();
        failed_commit(dir, &["a.csv", "b.png"], "a.csv");
        failed_commit(dir, &["a.csv"], "a.csv");
        let mut tx = Transaction::begin(dir).unwrap();
        tx.write("a.csv", b"new table").unwrap();
        tx.commit().unwrap();
        assert_eq!(std::fs::read(dir.join("a.csv")).unwrap(), b"new table");
        assert_eq!(names_in(dir), [LOCK_FILE, "a.csv", "b.png"]);
    }

    #[test]
    fn write_atomically_replaces_a_link_without_following_it() {
        let root = tempfile::tempdir().unwrap();
        let outside = root.path().join("outside.txt");
        std::fs::write(&outside, b"keep").unwrap();
        let dir = root.path().join("d");
        std::fs::create_dir(&dir).unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(&outside, dir.join("f.png")).unwrap();
        write_atomically(&dir.join("f.png"), b"new").unwrap();
        assert_eq!(std::fs::read(&outside).unwrap(), b"keep");
        assert_eq!(std::fs::read(dir.join("f.png")).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    }
}
