//! `ezy scale MODEL --n 10,100,1000`: the cost of one right-hand-side
//! evaluation (generated constraint terms, KKT solve) against the size of
//! a model's family, the measurement behind issue 6's linear-cost target.
//!
//! For each count the model is put in a consistent state (random angles,
//! projected onto the constraints) and `Dynamics::rhs` is timed: batches
//! of evaluations long enough for the clock (>= 2 ms), the median over
//! batches. One thread; the KKT path is the one `KktMethod::Auto` takes.

use std::io::Write;
use std::time::{Duration, Instant};

use clap::{ArgMatches, Args, FromArgMatches, ValueEnum};
use ezy_core::formulation::projection::Projector;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, ProjectionKind};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::app::{App, AppError};
use crate::cli::parse_capped;
use crate::output::progress::Heartbeat;

/// Time one right-hand-side evaluation against the size of a model's family.
#[derive(Args, Debug)]
struct ScaleArgs {
    /// Model with a family count (see `ezy list`), e.g. snake.
    model: String,
    /// Family sizes, comma-separated (each from 1 to 1e6).
    #[arg(long, value_delimiter = ',', default_value = "10,100,1000,10000", value_parser = parse_size)]
    n: Vec<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value = "table")]
    format: ScaleFormat,
    /// Batches timed per size (the median is reported), at most 1000.
    #[arg(long, default_value_t = 15, value_parser = parse_batches)]
    batches: usize,
    /// KKT path: auto (dense below 16 rows, sparse from 16), schur (dense), sparse, lu.
    #[arg(long, value_enum, default_value = "auto")]
    kkt: KktArg,
}

/// The KKT path of `--kkt` (the library's [`KktMethod`], which lives in
/// ezy-core without clap).
#[derive(ValueEnum, Clone, Copy, Debug)]
enum KktArg {
    /// Dense Schur complement below 16 constraint rows, sparse from 16.
    Auto,
    /// Dense Schur complement (LDL^T of G M^-1 G^T).
    Schur,
    /// Sparse Schur complement (faer, symbolic factor once).
    Sparse,
    /// Dense LU of the whole KKT matrix.
    Lu,
}

impl From<KktArg> for KktMethod {
    fn from(k: KktArg) -> Self {
        match k {
            KktArg::Auto => KktMethod::Auto,
            KktArg::Schur => KktMethod::Schur,
            KktArg::Sparse => KktMethod::Sparse,
            KktArg::Lu => KktMethod::Lu,
        }
    }
}

/// What `ezy scale` prints.
#[derive(ValueEnum, Clone, Copy, Debug)]
enum ScaleFormat {
    /// Aligned columns and the fitted exponent.
    Table,
    /// n,nq,nc,seconds_per_rhs,path
    Csv,
}

/// `--batches` of `ezy scale`: from 1 to [`MAX_BATCHES`].
///
/// # Errors
/// Not a whole number from 1 to the limit.
fn parse_batches(s: &str) -> Result<usize, String> {
    parse_capped(s, MAX_BATCHES as u64, "batches per size (each takes at least 2 ms, more for large sizes)")
        .map(|n| n as usize)
}

/// A family size of `ezy scale --n`: a whole number (also `1e4`) from 1
/// to [`ezy_scene::MAX_COUNT`].
///
/// # Errors
/// Not a whole number from 1 to the limit.
fn parse_size(s: &str) -> Result<usize, String> {
    parse_capped(s, ezy_scene::MAX_COUNT as u64, "elements of a family (1e6)").map(|n| n as usize)
}

/// The arguments of `ezy scale`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    ScaleArgs::augment_args(cmd)
}

/// Times the model named at each size and prints the table or CSV.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = ScaleArgs::from_arg_matches(args)?;
    if args.n.is_empty() || args.batches == 0 {
        return Err(AppError::Failed("--n needs at least one size and --batches at least 1".into()));
    }
    let model = &app.model_or_error(&args.model)?;
    let csv = matches!(args.format, ScaleFormat::Csv);
    let (info, points) =
        scale(model, &args.n, args.batches, args.kkt.into()).map(|p| (model.info(), p)).map_err(AppError::failed)?;
    Ok(out.write_all(render(info.name, &points, csv).as_bytes())?)
}

/// Most batches `ezy scale` times per size (`--batches`): each takes at
/// least 2 ms, and one evaluation of a family of a million elements
/// about 0.1 s, so 1000 batches of it take minutes.
const MAX_BATCHES: usize = 1000;

/// One measured size.
#[derive(Debug, Clone, PartialEq)]
struct ScalePoint {
    /// The family count.
    n: usize,
    /// Number of coordinates nq.
    nq: usize,
    /// Number of constraint rows nc.
    nc: usize,
    /// Median time of one RHS evaluation \[s\].
    seconds_per_rhs: f64,
    /// The KKT path (`schur-cholesky` dense, `sparse-cholesky`).
    path: &'static str,
}

/// Why a size could not be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum ScaleError {
    /// The model has no family count.
    #[error("model {model} has no family count (`count N = ..;`), so it has no size to scale")]
    NoCount {
        /// Model name, or the path of a model file (`.ezy`).
        model: &'static str,
    },
    /// More batches than [`MAX_BATCHES`].
    #[error("--batches {batches} is more than {MAX_BATCHES}, the most batches per size")]
    Batches {
        /// The batches asked for.
        batches: usize,
    },
    /// A count the model does not accept.
    #[error("--n {n}: {message}")]
    BadCount {
        /// The count's name.
        name: &'static str,
        /// The value asked for.
        n: usize,
        /// Why not.
        message: String,
    },
    /// The state could not be made consistent, or the RHS failed.
    #[error("{name} = {n}: {message}")]
    Failed {
        /// The count's name.
        name: &'static str,
        /// The value.
        n: usize,
        /// The solver's error.
        message: String,
    },
}

/// Times one RHS of `M` at each count in `ns` (the model's first count),
/// with at least `min_batches` batches per size, on the KKT path `kkt`
/// (`Auto`: dense below [`ezy_core::kkt::SPARSE_FROM_ROWS`] rows).
///
/// # Errors
/// [`ScaleError`] for a model without a count, a count the model does not
/// accept, or a state the KKT solve fails on.
fn scale<M: Model>(proto: &M, ns: &[usize], min_batches: usize, kkt: KktMethod) -> Result<Vec<ScalePoint>, ScaleError> {
    let base = proto.clone();
    let info = base.info();
    let (index, name) = info
        .params
        .iter()
        .enumerate()
        .find(|(_, p)| p.count)
        .map(|(i, p)| (i, p.name))
        .ok_or(ScaleError::NoCount { model: info.name })?;
    // every size and the batches checked before any model is built
    for &n in ns {
        if let Err(e) = ezy_scene::check_count(name, n as f64) {
            return Err(ScaleError::BadCount { name, n, message: e.message });
        }
    }
    if min_batches > MAX_BATCHES {
        return Err(ScaleError::Batches { batches: min_batches });
    }
    let mut out = Vec::with_capacity(ns.len());
    let beat = ns
        .iter()
        .any(|&n| n as f64 >= crate::session::LONG_SETUP_ELEMENTS)
        .then(|| Heartbeat::start(format!("scale {}: setting up {name} = {}", info.name, ns[0])));
    for (k, &n) in ns.iter().enumerate() {
        let fail = |message: String| ScaleError::Failed { name, n, message };
        if let Some(b) = &beat {
            b.set(format!("scale {}: {name} = {n} (size {} of {}): setting up and timing", info.name, k + 1, ns.len()));
        }
        let mut model = base.clone();
        model.set_param(index, n as f64);
        model.check_counts().map_err(|message| ScaleError::BadCount { name, n, message })?;
        let mut sys = Dynamics::new(model, Vec::new(), kkt);
        let nq = sys.nq();
        let nc = sys.info.nc();
        // a consistent state: random headings (+-0.3 rad), projected
        let mut rng = StdRng::seed_from_u64(n as u64);
        let mut q: Vec<f64> = (0..nq).map(|k| if k % 3 == 2 { rng.random_range(-0.3..0.3) } else { 0.0 }).collect();
        let mut qd: Vec<f64> = (0..nq).map(|_| rng.random_range(-0.5..0.5)).collect();
        let mut proj = Projector::new(&sys.model, ProjectionKind::MassWeighted, &sys.mass);
        for _ in 0..3 {
            proj.project(&sys.model, 0.0, &mut q, &mut qd).map_err(|e| fail(e.to_string()))?;
        }
        let mut y = q;
        y.extend_from_slice(&qd);
        let mut dy = vec![0.0; y.len()];
        sys.rhs(0.0, &y, &mut dy).map_err(|e| fail(e.to_string()))?;
        // batch size: about 2 ms per batch
        let clock = Instant::now();
        let mut reps = 0usize;
        while clock.elapsed() < Duration::from_millis(2) || reps == 0 {
            sys.rhs(0.0, &y, &mut dy).map_err(|e| fail(e.to_string()))?;
            reps += 1;
        }
        let mut times = Vec::with_capacity(min_batches);
        for _ in 0..min_batches {
            let t0 = Instant::now();
            for _ in 0..reps {
                sys.rhs(std::hint::black_box(0.0), std::hint::black_box(&y), &mut dy)
                    .map_err(|e| fail(e.to_string()))?;
            }
            times.push(t0.elapsed().as_secs_f64() / reps as f64);
        }
        times.sort_by(f64::total_cmp);
        out.push(ScalePoint { n, nq, nc, seconds_per_rhs: times[times.len() / 2], path: sys.kkt_name() });
    }
    Ok(out)
}

/// Least-squares slope of `log(seconds_per_rhs)` against `log(n)` over the
/// points with `n >= from` (the cost's exponent); `None` with fewer than
/// two such points.
fn fitted_exponent(points: &[ScalePoint], from: usize) -> Option<f64> {
    let xy: Vec<(f64, f64)> =
        points.iter().filter(|p| p.n >= from).map(|p| ((p.n as f64).ln(), p.seconds_per_rhs.ln())).collect();
    if xy.len() < 2 {
        return None;
    }
    let k = xy.len() as f64;
    let (mx, my) = (xy.iter().map(|p| p.0).sum::<f64>() / k, xy.iter().map(|p| p.1).sum::<f64>() / k);
    let sxx: f64 = xy.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = xy.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The points as a table (with the fitted exponent) or CSV.
fn render(model: &str, points: &[ScalePoint], csv: bool) -> String {
    let mut out = String::new();
    if csv {
        out.push_str("n,nq,nc,seconds_per_rhs,path\n");
        for p in points {
            out.push_str(&format!("{},{},{},{:e},{}\n", p.n, p.nq, p.nc, p.seconds_per_rhs, p.path));
        }
        return out;
    }
    out.push_str(&format!("{model}: one RHS evaluation (G, gamma, KKT solve), median, one thread\n"));
    out.push_str(&format!(
        "{:>8} {:>8} {:>8} {:>16} {:>14}  path\n",
        "n", "nq", "nc", "seconds_per_rhs", "per element"
    ));
    for p in points {
        out.push_str(&format!(
            "{:>8} {:>8} {:>8} {:>16.3e} {:>14.3e}  {}\n",
            p.n,
            p.nq,
            p.nc,
            p.seconds_per_rhs,
            p.seconds_per_rhs / p.n as f64,
            p.path
        ));
    }
    if let Some(e) = fitted_exponent(points, 100) {
        out.push_str(&format!("fitted exponent of seconds_per_rhs ~ n^k for n >= 100: k = {e:.3}\n"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(n: usize, s: f64) -> ScalePoint {
        ScalePoint { n, nq: 3 * n, nc: 3 * n - 1, seconds_per_rhs: s, path: "sparse-cholesky" }
    }

    #[test]
    fn exponent_of_a_power_law_is_recovered() {
        let pts: Vec<ScalePoint> =
            [10, 100, 1000, 10000].iter().map(|&n| pt(n, 3e-8 * (n as f64).powf(1.05))).collect();
        let k = fitted_exponent(&pts, 100).unwrap();
        assert!((k - 1.05).abs() < 1e-12, "{k}");
        assert_eq!(fitted_exponent(&pts[..2], 100), None);
    }

    #[test]
    fn the_snake_is_measured_and_a_model_without_count_is_refused() {
        let pts = scale(&ezy_models::Snake::default(), &[3, 20], 3, KktMethod::Auto).unwrap();
        assert_eq!((pts[0].nq, pts[0].nc), (9, 2 * 2 + 3));
        assert_eq!((pts[1].nq, pts[1].nc), (60, 2 * 19 + 20));
        // a model with families takes the sparse path at every size
        assert_eq!((pts[0].path, pts[1].path), ("sparse-cholesky", "sparse-cholesky"));
        assert!(pts.iter().all(|p| p.seconds_per_rhs > 0.0 && p.seconds_per_rhs.is_finite()));
        assert!(matches!(
            scale(&ezy_models::EzyRoller::default(), &[10], 3, KktMethod::Auto),
            Err(ScaleError::NoCount { .. })
        ));
        assert!(matches!(
            scale(&ezy_models::Snake::default(), &[0], 3, KktMethod::Auto),
            Err(ScaleError::BadCount { .. })
        ));
        let dense = scale(&ezy_models::Snake::default(), &[20], 3, KktMethod::Schur).unwrap();
        assert_eq!(dense[0].path, "schur-cholesky");
        let csv = render("Snake", &pts, true);
        assert!(csv.starts_with("n,nq,nc,seconds_per_rhs,path\n3,9,7,"), "{csv}");
    }
}
