//! The trajectory table: written to `trajectory.csv` as the run goes (into
//! the run's [`Transaction`], committed with the figures only when the whole
//! run succeeded, so a failed or interrupted run never leaves a truncated
//! file that looks complete) and kept in memory for the figures.
//!
//! Columns: `t`; the coordinates in model order; their velocities in the
//! same order (`<coord>d`); then the optional groups the scene's
//! `output.include` asks for, in this order (see [`OutputGroup`]): energy
//! (`T`, `W`, `W_<effect>` \[J\]), points (`<point>.x`, `<point>.y` \[m\]),
//! point velocities (`<point>.vx`, `<point>.vy` \[m/s\]), effects
//! (`tau_<effect>` \[N m\] or `F_<effect>` \[N\]), constraint forces
//! (`F_<hinge>.x`, `F_<hinge>.y`, `F_<skate>` \[N\]), accelerations
//! (`<coord>dd`), residuals (`res_phi`
//! = `max|C(q)|` \[m\], `res_vel` = `max|G(q) qd|` \[m/s\]).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, Observer, Sample, SimError};

use ezy_scene::{OutputGroup, Scene};

use crate::transaction::{Transaction, TransactionError};

/// Errors writing the table.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be written (the path is the file's final name).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The constraint forces could not be computed at an output time.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The CSV writer failed (the path is the file's final name).
    #[error("{}: {source}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: csv::Error,
    },
    /// Creating the file in the run's transaction failed, or a signal
    /// stopped the run.
    #[error(transparent)]
    Transaction(#[from] TransactionError),
}

/// Assembles one output row from a sample: `t`, `q`, `qd`, then exactly the
/// groups the scene asks for (see [`OutputGroup`]); a group not asked for
/// is not computed.
pub struct RowBuilder<M: Model> {
    /// Column names, from [`Scene::columns`].
    pub columns: Vec<String>,
    energy: bool,
    points: bool,
    point_velocities: bool,
    effects: bool,
    forces: bool,
    accelerations: bool,
    residuals: bool,
    /// A copy of the dynamics for the multipliers and accelerations at
    /// output times (constraint forces or accelerations asked for).
    probe: Option<Box<ForceProbe<M>>>,
    point_buf: Vec<f64>,
    f_scratch: Vec<f64>,
}

/// Solves the KKT system at an output sample for the constraint forces.
struct ForceProbe<M: Model> {
    sys: Dynamics<M>,
    y: Vec<f64>,
    dy: Vec<f64>,
}

impl<M: Model> RowBuilder<M> {
    /// The row layout of `scene` for the run `sys`.
    pub fn new(scene: &Scene, sys: &Dynamics<M>) -> Self {
        let forces = scene.includes(OutputGroup::ConstraintForces);
        let accelerations = scene.includes(OutputGroup::Accelerations);
        // skates with friction: their force and mode at each sample
        let probe = (forces || accelerations || !sys.friction.is_empty()).then(|| {
            let mut copy =
                Dynamics::new(sys.model.clone(), sys.effects.clone(), KktMethod::Auto).with_drives(sys.drives.clone());
            copy.baumgarte = sys.baumgarte;
            let ny = copy.ny();
            Box::new(ForceProbe { sys: copy, y: vec![0.0; ny], dy: vec![0.0; ny] })
        });
        Self {
            columns: scene.columns(&sys.info),
            energy: scene.includes(OutputGroup::Energy),
            points: scene.includes(OutputGroup::Points),
            point_velocities: scene.includes(OutputGroup::PointVelocities),
            effects: scene.includes(OutputGroup::Effects),
            forces,
            accelerations,
            residuals: scene.includes(OutputGroup::Residuals),
            probe,
            point_buf: vec![0.0; 2 * sys.info.points.len()],
            f_scratch: vec![0.0; sys.nq()],
        }
    }

    /// Fills `row` for sample `s` of the run `sys`.
    ///
    /// # Errors
    /// [`SimError`] if the KKT solve for the constraint forces fails.
    pub fn fill(&mut self, sys: &Dynamics<M>, s: &Sample<'_>, row: &mut Vec<f64>) -> Result<(), SimError> {
        row.clear();
        row.push(s.t);
        row.extend_from_slice(s.q);
        row.extend_from_slice(s.qd);
        if self.energy {
            row.push(s.kinetic_energy);
            row.push(s.work);
            row.extend_from_slice(s.works);
        }
        if self.points {
            sys.model.points(s.q, &mut self.point_buf);
            row.extend_from_slice(&self.point_buf);
        }
        if self.point_velocities {
            sys.model.point_velocities(s.q, s.qd, &mut self.point_buf);
            row.extend_from_slice(&self.point_buf);
        }
        if let Some(p) = &mut self.probe {
            let nq = sys.nq();
            p.y[..nq].copy_from_slice(s.q);
            p.y[nq..2 * nq].copy_from_slice(s.qd);
            // the effects switched on and off and the skates' modes of
            // the run at this sample
            for (pe, e) in p.sys.effects.iter_mut().zip(&sys.effects) {
                pe.on = e.on;
            }
            for (k, fr) in sys.friction.iter().enumerate() {
                if p.sys.friction[k].mode != fr.mode {
                    p.sys.set_skate_mode(k, fr.mode);
                }
            }
            p.sys.rhs(s.t, &p.y, &mut p.dy)?;
        }
        if self.effects {
            self.f_scratch.fill(0.0);
            let mut friction = 0;
            for e in &sys.effects {
                if let ezy_core::effects::Law::SkateFriction(_) = e.law {
                    // the lateral force, slip velocity and mode (probe: above)
                    let p = self.probe.as_ref().expect("a probe with friction");
                    let fr = &p.sys.friction[friction];
                    row.extend([p.sys.skate_force(friction), fr.slip, f64::from(u8::from(fr.mode.is_sliding()))]);
                    friction += 1;
                } else {
                    row.push(e.apply(s.t, s.q, s.qd, &mut self.f_scratch).1);
                }
            }
        }
        if let Some(p) = &mut self.probe {
            let nq = sys.nq();
            // M qdd = f - G^T lambda: the constraint force on the
            // coordinates is -G^T lambda, so a hinge row `r_a - r_b` pushes
            // body a with -lambda and a skate row (unit normal n) with -lambda n.
            if self.forces {
                row.extend(p.sys.lambda().iter().map(|l| -l));
            }
            if self.accelerations {
                row.extend_from_slice(&p.dy[nq..2 * nq]);
            }
        }
        if self.residuals {
            row.push(s.residual_position);
            row.push(s.residual_velocity);
        }
        Ok(())
    }
}

/// `events.csv` of a run: a header `t,event,direction,` and the state's
/// names, then a row per event in time order (`direction`: `rising` or
/// `falling`), numbers as in `trajectory.csv` ([`format_number`]). Event
/// names are letters, digits, `_` and `-` ([`ezy_core::events::check_event_name`]),
/// so no field needs quotes.
pub fn events_csv(records: &[ezy_core::EventRecord], state_names: &[String]) -> String {
    let mut buf = zmij::Buffer::new();
    let mut out = String::from("t,event,direction");
    for n in state_names {
        out.push(',');
        out.push_str(n);
    }
    out.push('\n');
    for r in records {
        out.push_str(format_number(&mut buf, r.t));
        out.push(',');
        out.push_str(&r.name);
        out.push_str(if r.rising { ",rising" } else { ",falling" });
        for &v in &r.y {
            out.push(',');
            out.push_str(format_number(&mut buf, v));
        }
        out.push('\n');
    }
    out
}

/// Bytes the CSV writer gathers before a write to the file.
const CSV_BUFFER: usize = 1 << 16;

/// Rows handed to the writer thread at a time ([`RowWriter`]).
const BATCH_ROWS: usize = 512;

/// Batches on their way to the writer thread at most (memory stays bounded:
/// the run waits when the disk or the formatting falls behind).
const BATCHES_IN_FLIGHT: usize = 4;

/// The rows of `trajectory.csv`, formatted in shortest round-trip decimal
/// ([`format_number`]) and written off the step loop: once a run has a
/// batch of [`BATCH_ROWS`] rows, a thread of its own takes over the file
/// and formats each batch while the run computes the next (formatting is
/// most of an output's work: 6,000 rows of 27 columns took 70 M
/// instructions with `ryu` and the `csv` crate's field writer, against
/// the integration's 15 M). A short run's rows are formatted on the
/// calling thread at the end. The bytes written are the same either way.
struct RowWriter {
    path: PathBuf,
    ncols: usize,
    batch: Vec<f64>,
    state: Writing,
}

enum Writing {
    /// No batch handed over yet: the file is written here.
    Here(Box<BufWriter<File>>),
    /// A writer thread owns the file; emptied batches come back for reuse.
    Thread {
        send: std::sync::mpsc::SyncSender<Vec<f64>>,
        recycled: std::sync::mpsc::Receiver<Vec<f64>>,
        handle: std::thread::JoinHandle<std::io::Result<BufWriter<File>>>,
    },
    /// Finished, failed or abandoned.
    Closed,
}

/// Writes `rows` (row-major, `ncols` values each) as CSV records: the
/// numbers joined by commas, a line each (numbers never need quotes).
fn write_rows(writer: &mut impl Write, rows: &[f64], ncols: usize) -> std::io::Result<()> {
    let mut buf = zmij::Buffer::new();
    let mut line = Vec::with_capacity(ncols * BYTES_PER_NUMBER);
    for row in rows.chunks_exact(ncols) {
        line.clear();
        for (k, &v) in row.iter().enumerate() {
            if k > 0 {
                line.push(b',');
            }
            line.extend_from_slice(format_number(&mut buf, v).as_bytes());
        }
        line.push(b'\n');
        writer.write_all(&line)?;
    }
    Ok(())
}

/// Most bytes [`format_number`] writes for one number (and its comma):
/// `-1.2345678901234567e-308`.
pub const BYTES_PER_NUMBER: usize = 25;

/// `v` in the shortest decimal that reads back as the same `f64` (the
/// Schubfach algorithm of the `zmij` crate, 1.7x as fast as `ryu` here:
/// the same digits, an exponent from `e16` on written `e+16`). Every number
/// of ezy's CSV files is written so.
pub fn format_number(buf: &mut zmij::Buffer, v: f64) -> &str {
    buf.format(v)
}

impl RowWriter {
    fn new(path: PathBuf, writer: BufWriter<File>, ncols: usize) -> Self {
        Self { path, ncols, batch: Vec::with_capacity(BATCH_ROWS * ncols), state: Writing::Here(Box::new(writer)) }
    }

    fn io_error(&self, source: std::io::Error) -> OutputError {
        OutputError::Io { path: self.path.clone(), source }
    }

    /// Queues one row (`ncols` values).
    fn push(&mut self, row: &[f64]) -> Result<(), OutputError> {
        self.batch.extend_from_slice(row);
        if self.batch.len() >= BATCH_ROWS * self.ncols { self.hand_over() } else { Ok(()) }
    }

    /// Sends the batch to the writer thread, starting it the first time.
    fn hand_over(&mut self) -> Result<(), OutputError> {
        if let Writing::Here(_) = self.state {
            let Writing::Here(mut writer) = std::mem::replace(&mut self.state, Writing::Closed) else {
                unreachable!("matched above")
            };
            let (send, receive) = std::sync::mpsc::sync_channel::<Vec<f64>>(BATCHES_IN_FLIGHT);
            let (give_back, recycled) = std::sync::mpsc::channel::<Vec<f64>>();
            let ncols = self.ncols;
            let handle = std::thread::Builder::new()
                .name("ezy-csv".into())
                .spawn(move || {
                    for mut rows in receive {
                        write_rows(&mut writer, &rows, ncols)?;
                        rows.clear();
                        let _ = give_back.send(rows);
                    }
                    Ok(*writer)
                })
                .map_err(|source| OutputError::Io { path: self.path.clone(), source })?;
            self.state = Writing::Thread { send, recycled, handle };
        }
        let Writing::Thread { send, recycled, .. } = &self.state else {
            return Ok(());
        };
        let next = recycled.try_recv().unwrap_or_else(|_| Vec::with_capacity(BATCH_ROWS * self.ncols));
        let full = std::mem::replace(&mut self.batch, next);
        if send.send(full).is_err() {
            // the thread stopped on an error: it tells which
            return match self.join() {
                Some(Err(e)) => Err(self.io_error(e)),
                _ => Err(OutputError::Io {
                    path: self.path.clone(),
                    source: std::io::Error::other("the CSV writer thread stopped"),
                }),
            };
        }
        Ok(())
    }

    /// Ends the writer thread, if any, after the batches it was given.
    fn join(&mut self) -> Option<std::io::Result<BufWriter<File>>> {
        let Writing::Thread { send, handle, .. } = std::mem::replace(&mut self.state, Writing::Closed) else {
            return None;
        };
        drop(send);
        Some(handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
    }

    /// Writes the rows left and returns the file, flushed.
    fn finish(mut self) -> Result<File, OutputError> {
        let mut writer = match std::mem::replace(&mut self.state, Writing::Closed) {
            Writing::Here(w) => *w,
            thread @ Writing::Thread { .. } => {
                self.state = thread;
                self.join().expect("a thread").map_err(|e| self.io_error(e))?
            }
            Writing::Closed => {
                // a failed hand-over already reported its error
                return Err(OutputError::Io {
                    path: self.path.clone(),
                    source: std::io::Error::other("the CSV writer stopped earlier"),
                });
            }
        };
        let rows = std::mem::take(&mut self.batch);
        write_rows(&mut writer, &rows, self.ncols).map_err(|e| self.io_error(e))?;
        writer.into_inner().map_err(|e| self.io_error(e.into_error()))
    }
}

impl Drop for RowWriter {
    /// An abandoned run waits for its writer thread (the file is closed
    /// before the transaction removes it).
    fn drop(&mut self) {
        let _ = self.join();
    }
}

/// Writes `writer`'s rows left, flushes and syncs its file at `path`.
fn close(writer: RowWriter, path: &Path) -> Result<(), OutputError> {
    let file = writer.finish()?;
    crate::transaction::sync(&file, path)?;
    Ok(())
}

/// The end of a CSV file being written, flushed and synced on a thread of
/// its own ([`CsvObserver::finish_later`]). Dropped without
/// [`CsvTail::wait`] (a failed run), it still waits for the file to be
/// closed, before the transaction removes it.
pub struct CsvTail {
    handle: Option<std::thread::JoinHandle<Result<(), OutputError>>>,
}

impl CsvTail {
    /// Waits until the file is written and synced.
    ///
    /// # Errors
    /// As [`CsvObserver::finish`].
    pub fn wait(mut self) -> Result<(), OutputError> {
        match self.handle.take() {
            Some(handle) => handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            None => Ok(()),
        }
    }
}

impl Drop for CsvTail {
    fn drop(&mut self) {
        if let Some(handle) = self.handle.take() {
            let _ = handle.join();
        }
    }
}

/// Most rows kept in memory for the figures; beyond it every other row is
/// dropped and the sampling interval doubles.
pub const FIGURE_ROWS: usize = 20_000;

/// The in-memory table: column names and row-major values.
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Column names.
    pub columns: Vec<String>,
    /// Values, `columns.len()` per row.
    pub data: Vec<f64>,
}

impl Table {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        if self.columns.is_empty() { 0 } else { self.data.len() / self.columns.len() }
    }
    /// Index of a column.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }
    /// The values of column `k`.
    pub fn column(&self, k: usize) -> impl Iterator<Item = f64> + '_ {
        self.data.iter().skip(k).step_by(self.columns.len()).copied()
    }
}

/// What sees every output row as it is written (a sweep's metrics):
/// the sample and the row.
pub type Tap<'a> = &'a mut dyn FnMut(&Sample<'_>, &[f64]);

/// Writes samples to CSV and keeps them for figures.
pub struct CsvObserver<'a, M: Model> {
    /// The final path (errors name it).
    path: PathBuf,
    /// The output directory (an interruption names it).
    dir: PathBuf,
    writer: RowWriter,
    /// The rows kept for the figures: every `keep`-th row written, at most
    /// [`FIGURE_ROWS`] (the CSV streams every row; memory does not grow
    /// with the horizon).
    pub table: Table,
    keep: u64,
    written: u64,
    row: Vec<f64>,
    builder: RowBuilder<M>,
    progress: Option<crate::progress::Progress>,
    tap: Option<Tap<'a>>,
    /// The latest simulated time the run reported \[s\] (samples are
    /// observed in batches, behind the step loop): what an interruption
    /// names.
    reached: f64,
}

impl<'a, M: Model> CsvObserver<'a, M> {
    /// Creates the table `name` (`trajectory.csv`) in the transaction `tx`
    /// (the first file of the transaction, so the last one committed) and
    /// writes the header; `rows` is the expected number of rows (the table
    /// is preallocated).
    ///
    /// # Errors
    /// [`OutputError`] if the file cannot be created or written.
    pub fn create(
        tx: &mut Transaction,
        name: &str,
        builder: RowBuilder<M>,
        progress: Option<crate::progress::Progress>,
        rows: usize,
    ) -> Result<Self, OutputError> {
        let columns = builder.columns.clone();
        let path = tx.path(name);
        let file = tx.create(name)?;
        // the writer's own buffer, 64 KiB: one write call per ~3,000 numbers
        let mut header = csv::WriterBuilder::new().buffer_capacity(1024).from_writer(file);
        header.write_record(&columns).map_err(|source| OutputError::Csv { path: path.clone(), source })?;
        let file = header.into_inner().map_err(|e| OutputError::Io { path: path.clone(), source: e.into_error() })?;
        // the rows are numbers, written without the csv crate (no quotes needed)
        let writer = BufWriter::with_capacity(CSV_BUFFER, file);
        let n = columns.len();
        Ok(Self {
            writer: RowWriter::new(path.clone(), writer, n),
            path,
            dir: tx.dir().to_path_buf(),
            table: Table { columns, data: Vec::with_capacity(rows.min(FIGURE_ROWS + 1) * n) },
            keep: 1,
            written: 0,
            row: Vec::with_capacity(n),
            builder,
            progress,
            tap: None,
            reached: 0.0,
        })
    }

    /// Shows every row, as written, to `tap` too.
    #[must_use]
    pub fn with_tap(mut self, tap: Tap<'a>) -> Self {
        self.tap = Some(tap);
        self
    }

    /// Flushes and syncs the file (its transaction commits it) and returns
    /// the rows kept for the figures.
    ///
    /// # Errors
    /// [`OutputError`] if flushing or syncing fails (a full disk).
    pub fn finish(mut self) -> Result<Table, OutputError> {
        if let Some(p) = self.progress.take() {
            p.finish();
        }
        close(self.writer, &self.path)?;
        Ok(self.table)
    }

    /// [`CsvObserver::finish`] that returns the rows at once and leaves
    /// the file's last rows, flush and sync to a thread of their own
    /// ([`CsvTail`]), so that the figures are drawn while the disk syncs
    /// (3-4 ms of a `drive` run). Where no thread can be started, the file
    /// is finished here.
    ///
    /// # Errors
    /// As [`CsvObserver::finish`], where no thread could be started.
    pub fn finish_later(mut self) -> Result<(Table, CsvTail), OutputError> {
        use std::sync::{Arc, Mutex, PoisonError};
        if let Some(p) = self.progress.take() {
            p.finish();
        }
        let finish = |(writer, path): (RowWriter, PathBuf)| close(writer, &path);
        let parts = Arc::new(Mutex::new(Some((self.writer, self.path))));
        let theirs = Arc::clone(&parts);
        let spawned = std::thread::Builder::new().name("ezy-csv-sync".into()).spawn(move || {
            match theirs.lock().unwrap_or_else(PoisonError::into_inner).take() {
                Some(parts) => finish(parts),
                None => Ok(()),
            }
        });
        let handle = match spawned {
            Ok(handle) => Some(handle),
            Err(_) => {
                // the thread never ran: the parts are still here
                if let Some(parts) = parts.lock().unwrap_or_else(PoisonError::into_inner).take() {
                    finish(parts)?;
                }
                None
            }
        };
        Ok((self.table, CsvTail { handle }))
    }

    /// Stops writing (after a failed run); the transaction, dropped
    /// uncommitted, removes the file.
    pub fn abandon(self) {
        if let Some(p) = &self.progress {
            p.finish();
        }
    }
}

impl<M: Model> Observer<M> for CsvObserver<'_, M> {
    type Error = OutputError;

    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), OutputError> {
        self.reached = self.reached.max(s.t);
        crate::transaction::check_interrupt(&self.dir, Some(self.reached), None)?;
        self.builder.fill(sys, s, &mut self.row)?;
        self.writer.push(&self.row)?;
        if let Some(tap) = &mut self.tap {
            tap(s, &self.row);
        }
        if self.written.is_multiple_of(self.keep) {
            if self.table.rows() >= FIGURE_ROWS {
                let n = self.table.columns.len();
                let kept: Vec<f64> = self.table.data.chunks(n).step_by(2).flatten().copied().collect();
                self.table.data = kept;
                self.keep *= 2;
            }
            if self.written.is_multiple_of(self.keep) {
                self.table.data.extend_from_slice(&self.row);
            }
        }
        self.written += 1;
        Ok(())
    }

    /// Stops the run if a signal arrived (see [`crate::transaction`]).
    fn poll(&mut self, t: f64) -> Result<(), OutputError> {
        self.reached = self.reached.max(t);
        Ok(crate::transaction::check_interrupt(&self.dir, Some(self.reached), None)?)
    }

    fn progress(&mut self, t: f64) {
        self.reached = self.reached.max(t);
        if let Some(p) = &mut self.progress {
            p.update(t);
        }
    }

    fn note(&mut self, text: &str) {
        match &self.progress {
            Some(p) => p.println(&format!("note: {text}")),
            None => {
                eprintln!("note: {text}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows written here (a short run) and by the writer thread (several
    /// batches and a partial one) are the same bytes as formatting each
    /// number with `ryu` and joining with commas (the digits are the same;
    /// `ryu` writes a positive exponent `e16` where `zmij` writes `e+16`).
    #[test]
    fn rows_are_the_same_bytes_here_and_on_the_writer_thread() {
        let dir = tempfile::tempdir().unwrap();
        for n in [3, 2 * BATCH_ROWS + 7] {
            let path = dir.path().join(format!("rows{n}.csv"));
            let file = File::create(&path).unwrap();
            let mut w = RowWriter::new(path.clone(), BufWriter::new(file), 3);
            let mut want = String::new();
            for k in 0..n {
                let row = [k as f64, 0.1 * k as f64, -1e-300 / (k as f64 + 1.0) + 3e21 * (k % 2) as f64];
                w.push(&row).unwrap();
                let fields: Vec<String> =
                    row.iter().map(|v| ryu::Buffer::new().format(*v).replace("e", "e+").replace("e+-", "e-")).collect();
                want.push_str(&fields.join(","));
                want.push('\n');
            }
            assert_eq!(matches!(w.state, Writing::Thread { .. }), n > BATCH_ROWS);
            drop(w.finish().unwrap());
            assert_eq!(std::fs::read_to_string(&path).unwrap(), want, "{n} rows");
        }
    }
}
