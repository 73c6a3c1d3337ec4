//! `ezy analyze`'s output: the tables (equilibria.csv, periodic.csv,
//! branch.csv, growth.csv), the figures and the summary printed.

use std::fmt::Write as _;
use std::path::PathBuf;

use ezy_core::analysis::{
    Analysis, BranchPoint, Growth, GrowthFit, PeriodicOrbit, Solution, Stability, SteadyMotion, c64,
};
use ezy_core::sensitivity::GaitSensitivities;
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

use super::branches::{Branch, Located};
use super::spectrum::{multipliers, ones, steady_eigenvalues, verdict};
use super::{AnalyzeOptions, AnalyzeReport};
use crate::output::csv::{number, record};
use crate::output::transaction::{OutLock, Transaction};
use crate::render::plot::series::{Chart, Series, Stroke};
use crate::session::{Error, rounded, rounded_to};

/// A branch's points, their mean power and efficiency, and its
/// bifurcations.
type BranchView<'a> = (&'a [BranchPoint], &'a [(f64, f64)], &'a [Located]);

/// Writes the analysis' tables and figures into `opts.run.out` as one
/// transaction, retiring the files of an earlier analysis it does not
/// write, in the directory `held` locks (taken before the analysis):
/// the steady motions, or a driven motion's growth without bound, or the
/// periodic orbit with its gait's power and derivatives, and the branch;
/// returns the files written.
pub(super) fn write_analysis<M: Model>(
    an: &Analysis<M>,
    scene: &Scene,
    opts: &AnalyzeOptions,
    (steady, growth): (&[SteadyMotion], Option<&Growth>),
    periodic: Option<(&PeriodicOrbit, Option<&GaitSensitivities>)>,
    branches: &[Branch],
    held: OutLock,
) -> Result<Vec<PathBuf>, Error> {
    let ro = &opts.run;
    // the output is a transaction: all files or none, and none of an
    // earlier analysis left beside them
    let mut tx = Transaction::begin_locked(held)?;
    let mut own: Vec<String> =
        ["equilibria.csv", "periodic.csv", "branch.csv", "branches.csv", "growth.csv"].map(String::from).to_vec();
    own.extend(born_tables(&ro.out));
    for stem in ["eigenvalues", "multipliers", "branch"] {
        own.extend(ezy_scene::FigureFormat::ALL.iter().map(|f| f.file_name(stem)));
    }
    tx.retire(&own);
    let names = an.state_names();
    let shape = shape_columns(an);
    let (format, dpi) = ro.look(scene);
    let mut figures: Vec<(String, Chart)> = Vec::new();
    if !steady.is_empty() {
        tx.write("equilibria.csv", steady_csv(steady, &names, &shape).as_bytes())?;
        let mut chart = Chart::new("Eigenvalues of the steady motions", "Re lambda [1/s]", "Im lambda [1/s]");
        for (k, s) in steady.iter().enumerate() {
            chart.series.push(points_series(format!("motion {} ({})", k + 1, s.stability.name()), &s.eigenvalues));
        }
        figures.push(("eigenvalues".into(), chart));
    }
    if let Some(g) = growth {
        tx.write("growth.csv", growth_csv(g).as_bytes())?;
    }
    if let Some((p, g)) = periodic {
        tx.write("periodic.csv", periodic_csv(p, g, &names, &shape).as_bytes())?;
        let mut chart = Chart::new("Floquet multipliers of the periodic orbit", "Re mu", "Im mu");
        let circle =
            (0..=200).map(|k| (k as f64 * std::f64::consts::TAU / 200.0).sin_cos()).map(|(s, c)| (c, s)).collect();
        chart.series.push(Series { stroke: Stroke::Solid, ..Series::new("unit circle", circle) });
        chart.series.push(points_series(format!("multipliers ({})", p.stability.name()), &p.multipliers));
        chart.equal_axes = true;
        chart.path_ends = false;
        figures.push(("multipliers".into(), chart));
    }
    if let Some((name, _)) = &opts.continuation
        && branches.first().is_some_and(|b| !b.points.is_empty())
    {
        for b in branches {
            tx.write(&b.file(), branch_csv(name, (&b.points, &b.power, &b.bifurcations), &names, &shape).as_bytes())?;
        }
        if branches.len() > 1 {
            tx.write("branches.csv", branches_csv(branches).as_bytes())?;
        }
        figures.push(("branch".into(), branch_chart(name, branches, &names, periodic.is_some())));
    }
    if ro.figures {
        for (stem, chart) in &figures {
            tx.check(None, Some(format!("drawing {stem}")))?;
            let bytes = crate::render::plot::figure(chart, format, dpi)
                .map_err(|e| Error::Input(format!("figure {stem}: {e}")))?;
            tx.write(&format.file_name(stem), &bytes)?;
        }
    }
    Ok(tx.commit()?)
}

/// The branch figure's vertical axis over all the branches' points: the
/// turning rate where branches were born and some turn (a
/// symmetry-breaking pitchfork's arms turn opposite ways at one speed);
/// else the reference body's speed, or where every point is at rest
/// (equilibria of a mechanism) the state's coordinate that changes most,
/// by `names`.
fn branch_axis(points: &[&BranchPoint], names: &[String], periodic: bool, born: bool) -> (String, Axis) {
    // at rest to rounding (1e-16 m/s): below a nanometre per second
    let moving = points.iter().any(|b| b.solution.speed() > 1e-9);
    if born && points.iter().any(|b| b.solution.turning_rate().abs() > 1e-9) {
        return ("turning rate [rad/s]".into(), Axis::Turning);
    }
    let range = |i: usize| {
        let v = points.iter().map(|b| b.solution.state()[i]);
        v.clone().fold(f64::NEG_INFINITY, f64::max) - v.fold(f64::INFINITY, f64::min)
    };
    let widest = (0..names.len()).max_by(|&a, &b| range(a).total_cmp(&range(b))).unwrap_or(0);
    match (moving, periodic) {
        (true, true) => ("mean speed [m/s]".into(), Axis::Speed),
        (true, false) => ("speed [m/s]".into(), Axis::Speed),
        (false, _) => (names.get(widest).cloned().unwrap_or_default(), Axis::State(widest)),
    }
}

/// What the branch figure's vertical axis shows ([`branch_axis`]).
#[derive(Debug, Clone, Copy)]
enum Axis {
    /// The turning rate [rad/s].
    Turning,
    /// The reference body's (mean) speed [m/s].
    Speed,
    /// The state's entry.
    State(usize),
}

impl Axis {
    fn of(self, s: &Solution) -> f64 {
        match self {
            Axis::Turning => s.turning_rate(),
            Axis::Speed => s.speed(),
            Axis::State(i) => s.state()[i],
        }
    }
}

/// The bifurcation diagram: every branch in the parameter `name`, solid
/// where stable and dashed where not, the bifurcations marked by kind;
/// below, the gaits' efficiency where every branch has one.
fn branch_chart(name: &str, branches: &[Branch], names: &[String], periodic: bool) -> Chart {
    let all: Vec<&BranchPoint> = branches.iter().flat_map(|b| &b.points).collect();
    let (label, axis) = branch_axis(&all, names, periodic, branches.len() > 1);
    let title = if branches.len() > 1 {
        format!("Bifurcation diagram in {name}: solid stable, dashed not")
    } else {
        format!("Branch in {name}: solid stable, dashed not")
    };
    let mut chart = Chart::new(title, name.to_string(), label);
    for b in branches {
        // the points in order, each bifurcation's among them on both
        // sides' lines (it joins them)
        let mut seq: Vec<(f64, f64, Option<bool>)> = Vec::new();
        for (k, p) in b.points.iter().enumerate() {
            seq.push((p.value, axis.of(&p.solution), Some(p.solution.stability() == Stability::Stable)));
            for (_, f) in b.bifurcations.iter().filter(|(at, _)| *at == k) {
                seq.push((f.value, axis.of(&f.solution), None));
            }
        }
        for (label, stable) in [("stable", true), ("unstable or neutral", false)] {
            let pts: Vec<(f64, f64)> = seq
                .iter()
                .enumerate()
                .map(|(i, &(x, y, s))| {
                    let on = match s {
                        Some(s) => s == stable,
                        // a bifurcation: on a line that reaches it
                        None => [i.checked_sub(1), Some(i + 1)]
                            .into_iter()
                            .flatten()
                            .any(|j| seq.get(j).is_some_and(|n| n.2 == Some(stable))),
                    };
                    (x, if on { y } else { f64::NAN })
                })
                .collect();
            if branches.len() > 1 && pts.iter().all(|p| p.1.is_nan()) {
                continue;
            }
            let label = if branches.len() > 1 { format!("branch {} {label}", b.id) } else { label.to_string() };
            let stroke = if stable { Stroke::Solid } else { Stroke::Dash(0) };
            chart.series.push(Series { stroke, color: Some(b.id), ..Series::new(label, pts) });
        }
    }
    let marks = branches.len();
    for (j, (_, f)) in branches.iter().flat_map(|b| &b.bifurcations).enumerate() {
        chart.series.push(Series {
            stroke: Stroke::Points,
            color: Some(marks + j),
            ..Series::new(
                format!("{} at {}", f.kind.name(), fmt_value(sig(f.value, 7))),
                vec![(f.value, axis.of(&f.solution))],
            )
        });
    }
    let efficient = |b: &Branch| !b.power.is_empty() && b.power.iter().all(|(_, e)| e.is_finite());
    if branches.iter().all(efficient) {
        chart.lower = Some("efficiency [m/J]".into());
        for b in branches {
            let pts = b.points.iter().zip(&b.power).map(|(p, (_, e))| (p.value, *e)).collect();
            let label = if branches.len() > 1 { format!("branch {} efficiency", b.id) } else { "efficiency".into() };
            chart.series.push(Series { panel: 1, stroke: Stroke::Solid, color: Some(b.id), ..Series::new(label, pts) });
        }
    }
    chart
}

/// The tables `branch-K.csv` an earlier analysis left in `dir` (retired
/// with the rest of its output).
fn born_tables(dir: &std::path::Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    entries
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| {
            n.strip_prefix("branch-")
                .and_then(|r| r.strip_suffix(".csv"))
                .is_some_and(|k| !k.is_empty() && k.bytes().all(|c| c.is_ascii_digit()))
        })
        .collect()
}

/// `branches.csv`: one row per branch, the one followed (0) first, each
/// born one with its parent, the bifurcation it starts from (its
/// parameter's value and kind as the switch told it), the side of
/// the new direction it was sought on, its points and how it ended.
fn branches_csv(branches: &[Branch]) -> String {
    let head = [
        "branch",
        "file",
        "parent",
        "born_at",
        "bifurcation",
        "criticality",
        "symmetry_breaking",
        "side",
        "points",
        "from",
        "to",
        "ended",
    ];
    let mut out = record(head.iter().map(|h| h.to_string()).collect());
    for b in branches {
        let ends = |p: Option<&BranchPoint>| p.map_or(String::new(), |p| number(p.value));
        let (parent, at, kind, crit, breaking, side) = match &b.birth {
            Some(x) => (
                x.parent.to_string(),
                number(x.value),
                x.kind.name().to_string(),
                x.criticality.unwrap_or("").to_string(),
                x.symmetry_breaking.to_string(),
                number(x.side),
            ),
            None => Default::default(),
        };
        out.push_str(&record(vec![
            b.id.to_string(),
            b.file(),
            parent,
            at,
            kind,
            crit,
            breaking,
            side,
            b.points.len().to_string(),
            ends(b.points.first()),
            ends(b.points.last()),
            b.ended.clone(),
        ]));
    }
    out
}

/// The shape columns: each hinge between two bodies, its angle
/// `theta_<H> = phi_a - phi_b` wrapped to (-pi, pi] \[rad\], with the
/// headings' indices.
fn shape_columns<M: Model>(an: &Analysis<M>) -> Vec<(String, usize, usize)> {
    let info = &an.dynamics().info;
    info.hinges
        .iter()
        .filter_map(|h| {
            h.body_b.map(|b| (format!("theta_{}", h.name), info.bodies[h.body_a].coords[2], info.bodies[b].coords[2]))
        })
        .collect()
}

pub(super) fn wrap(angle: f64) -> f64 {
    let a = angle.rem_euclid(std::f64::consts::TAU);
    if a > std::f64::consts::PI { a - std::f64::consts::TAU } else { a }
}

fn shape_cells(shape: &[(String, usize, usize)], x: &[f64]) -> Vec<String> {
    shape.iter().map(|(_, a, b)| number(wrap(x[*a] - x[*b]))).collect()
}

fn spectrum_cells(values: &[c64]) -> Vec<String> {
    values.iter().flat_map(|z| [number(z.re), number(z.im)]).collect()
}

fn spectrum_header(letter: &str, n: usize) -> Vec<String> {
    (1..=n).flat_map(|k| [format!("{letter}{k}_re"), format!("{letter}{k}_im")]).collect()
}

/// `equilibria.csv`: one row per steady motion.
fn steady_csv(steady: &[SteadyMotion], names: &[String], shape: &[(String, usize, usize)]) -> String {
    let n = steady.first().map_or(0, |s| s.eigenvalues.len());
    let mut head: Vec<String> =
        ["motion", "stability", "family", "u", "v", "omega", "speed", "curvature"].map(String::from).to_vec();
    head.extend(shape.iter().map(|s| s.0.clone()));
    head.extend(names.iter().cloned());
    head.extend(spectrum_header("lambda", n));
    let mut out = record(head);
    for (k, s) in steady.iter().enumerate() {
        let [u, v, w] = s.body_velocity;
        let mut cells = vec![
            (k + 1).to_string(),
            s.stability.name().into(),
            s.family.to_string(),
            number(u),
            number(v),
            number(w),
            number(s.speed()),
            number(s.curvature()),
        ];
        cells.extend(shape_cells(shape, &s.state));
        cells.extend(s.state.iter().map(|v| number(*v)));
        cells.extend(spectrum_cells(&s.eigenvalues));
        out.push_str(&record(cells));
    }
    out
}

/// `periodic.csv`: the orbit in one row.
fn periodic_csv(
    p: &PeriodicOrbit,
    g: Option<&GaitSensitivities>,
    names: &[String],
    shape: &[(String, usize, usize)],
) -> String {
    let mut head: Vec<String> = [
        "period",
        "t0",
        "stability",
        "family",
        "mean_speed",
        "mean_forward_speed",
        "dx",
        "dy",
        "dheading",
        "mean_abs_speed",
        "drift_speed",
        "dx_world",
        "dy_world",
    ]
    .map(String::from)
    .to_vec();
    head.extend(shape.iter().map(|s| s.0.clone()));
    head.extend(names.iter().cloned());
    head.extend(spectrum_header("mu", p.multipliers.len()));
    let mut cells = vec![
        number(p.period),
        number(p.t0),
        p.stability.name().into(),
        p.family.to_string(),
        number(p.mean_speed()),
        number(p.mean_forward_speed()),
        number(p.displacement[0]),
        number(p.displacement[1]),
        number(p.heading_change),
        number(p.mean_abs_speed),
        number(p.drift_speed),
        number(p.world_displacement()[0]),
        number(p.world_displacement()[1]),
    ];
    cells.extend(shape_cells(shape, &p.state));
    cells.extend(p.state.iter().map(|v| number(*v)));
    cells.extend(spectrum_cells(&p.multipliers));
    // a limit cycle's headings that turn: whole turns per period
    for &(i, w) in &p.windings {
        head.push(format!("turns_{}", names[i]));
        cells.push(w.to_string());
    }
    let Some(g) = g else { return record(head) + &record(cells) };
    // the mean input power, the efficiency where there is input power,
    // and the derivatives (a NaN efficiency and its derivative left out)
    let efficient = g.efficiency.is_finite();
    head.push("mean_power".into());
    cells.push(number(g.mean_power));
    if efficient {
        head.push("efficiency".into());
        cells.push(number(g.efficiency));
    }
    for (j, param) in g.parameters.iter().enumerate() {
        for (what, v) in g.rows(j) {
            if what == "efficiency" && !efficient {
                continue;
            }
            head.push(format!("d{what}/d{param}"));
            cells.push(number(v));
        }
    }
    record(head) + &record(cells)
}

/// `growth.csv`: one row per window of the stroboscopic samples (the
/// run's second half, then its third and fourth quarters), each with its
/// ends, the kinetic energy's and the speed's power laws fitted each by
/// its own least squares of the logarithms: exponent, standard error and
/// the RMS residual of the log fit (the speed's cells empty where the
/// reference body stands still at a period end).
fn growth_csv(g: &Growth) -> String {
    let head = [
        "window",
        "t_start",
        "t_end",
        "samples",
        "T_start",
        "T_end",
        "energy_exponent",
        "energy_exponent_se",
        "energy_residual",
        "speed_start",
        "speed_end",
        "speed_exponent",
        "speed_exponent_se",
        "speed_residual",
    ];
    let mut out = record(head.map(String::from).to_vec());
    let n = g.t.len();
    let row = |name: &str, f: &GrowthFit, [a, b]: [usize; 2]| {
        let mut cells = vec![
            name.to_string(),
            number(f.t[0]),
            number(f.t[1]),
            f.samples.to_string(),
            number(g.energy[a]),
            number(g.energy[b]),
            number(f.energy.exponent),
            number(f.energy.std_error),
            number(f.energy.residual),
            number(g.speed[a]),
            number(g.speed[b]),
        ];
        match &f.speed {
            Some(v) => cells.extend([number(v.exponent), number(v.std_error), number(v.residual)]),
            None => cells.extend([String::new(), String::new(), String::new()]),
        }
        record(cells)
    };
    let [q3, q4] = &g.quarters;
    out.push_str(&row("second_half", &g.whole, [0, n - 1]));
    out.push_str(&row("third_quarter", q3, [0, n / 2]));
    out.push_str(&row("fourth_quarter", q4, [n / 2, n - 1]));
    out
}

/// `branch.csv`: one row per parameter value, and one per bifurcation
/// located (after the point `k` of its bracket), its kind and critical
/// eigenvalue or multiplier in the last columns (empty on the other rows).
/// A periodic branch's rows carry each orbit's period and phase `t0`:
/// the branch takes its orbits at the first one's phase less whole
/// periods of its forcing, where a frequency's change moves the forcing's
/// phase least, so the states are not at `periodic.csv`'s `t0` where the
/// parameter changes the forcing's frequency (a bifurcation's row at the
/// phase it was located at).
fn branch_csv(
    name: &str,
    (branch, power, bifurcations): BranchView<'_>,
    names: &[String],
    shape: &[(String, usize, usize)],
) -> String {
    let (letter, n) = match &branch[0].solution {
        Solution::Steady(s) => ("lambda", s.eigenvalues.len()),
        Solution::Periodic(p) => ("mu", p.multipliers.len()),
    };
    let mut head: Vec<String> = vec![name.to_string(), "stability".into(), "speed".into(), "turning_rate".into()];
    if letter == "mu" {
        head.extend(["period", "t0"].map(String::from));
    }
    head.extend(shape.iter().map(|s| s.0.clone()));
    head.extend(names.iter().cloned());
    head.extend(spectrum_header(letter, n));
    let efficient = !power.is_empty() && power.iter().all(|(_, e)| e.is_finite());
    if !power.is_empty() {
        head.push("mean_power".into());
    }
    if efficient {
        head.push("efficiency".into());
    }
    if !bifurcations.is_empty() {
        head.extend(["bifurcation", "critical_re", "critical_im"].map(String::from));
    }
    let row = |value: f64, solution: &Solution| {
        let mut cells = vec![
            number(value),
            solution.stability().name().into(),
            number(solution.speed()),
            number(solution.turning_rate()),
        ];
        if let Solution::Periodic(p) = solution {
            cells.extend([number(p.period), number(p.t0)]);
        }
        cells.extend(shape_cells(shape, solution.state()));
        cells.extend(solution.state().iter().map(|v| number(*v)));
        cells.extend(spectrum_cells(match solution {
            Solution::Steady(s) => &s.eigenvalues,
            Solution::Periodic(p) => &p.multipliers,
        }));
        cells
    };
    let mut out = record(head);
    for (k, b) in branch.iter().enumerate() {
        let mut cells = row(b.value, &b.solution);
        if let Some((w, e)) = power.get(k) {
            cells.push(number(*w));
            if efficient {
                cells.push(number(*e));
            }
        }
        if !bifurcations.is_empty() {
            cells.extend([String::new(), String::new(), String::new()]);
        }
        out.push_str(&record(cells));
        for (_, f) in bifurcations.iter().filter(|(at, _)| *at == k) {
            let mut cells = row(f.value, &f.solution);
            if !power.is_empty() {
                cells.push(String::new());
            }
            if efficient {
                cells.push(String::new());
            }
            cells.extend([f.kind.name().to_string(), number(f.critical[0].re), number(f.critical[0].im)]);
            out.push_str(&record(cells));
        }
    }
    out
}

fn points_series(label: String, values: &[c64]) -> Series {
    Series { stroke: Stroke::Points, ..Series::new(label, values.iter().map(|z| (z.re, z.im)).collect()) }
}

/// The text `ezy analyze` prints.
pub(super) fn summary(scene: &str, r: &AnalyzeReport) -> String {
    let mut s = String::new();
    let sym: Vec<String> = r.symmetry.generators().iter().map(|g| g.name(&r.coords)).collect();
    let _ = writeln!(
        s,
        "scene {scene}: symmetry {}",
        if sym.is_empty() {
            "none (ordinary equilibria)".to_string()
        } else {
            format!("{} (steady motions relative to it)", sym.join(", "))
        }
    );
    for (k, m) in r.steady.iter().enumerate() {
        let ev = steady_eigenvalues(&m.eigenvalues, m.family);
        let _ = writeln!(
            s,
            "steady motion {}: {}, speed {} m/s, yaw rate {} rad/s, family {}; eigenvalues [1/s]: {}",
            k + 1,
            m.stability.name(),
            rounded(m.speed()),
            rounded(m.body_velocity[2]),
            m.family,
            ev.join(", ")
        );
    }
    if let Some(g) = &r.growth {
        let _ = writeln!(s, "no periodic orbit: {}", g.describe());
    }
    if let Some(p) = &r.periodic {
        let d = r.decimals;
        let mu = multipliers(p, d, r.resolution);
        let turns: Vec<String> = p.windings.iter().map(|(i, w)| format!("{} {w}", r.coords[*i])).collect();
        let kind = if r.gait.is_none() && !turns.is_empty() {
            format!("limit cycle (turns per period: {})", turns.join(", "))
        } else if r.gait.is_none() {
            "limit cycle".to_string()
        } else {
            "periodic orbit".to_string()
        };
        let _ = writeln!(
            s,
            "{kind}: period {} s, {} ({}), mean speed {} m/s (|displacement| / period; mean |v| {} m/s, drift speed {} m/s), displacement ({}, {}) m in the reference body's frame at t0 and heading change {} rad per period; multipliers: {}",
            // a limit cycle's period is found by Newton too
            if r.gait.is_none() && d < 6 { rounded_to(p.period, d) } else { fmt_value(p.period) },
            p.stability.name(),
            verdict(p),
            rounded_to(p.mean_speed(), d),
            rounded_to(p.mean_abs_speed, d),
            rounded_to(p.drift_speed, d),
            rounded_to(p.displacement[0], d),
            rounded_to(p.displacement[1], d),
            rounded_to(p.heading_change, d),
            if mu.is_empty() { "none".to_string() } else { mu.join(", ") },
        );
        let _ = writeln!(
            s,
            "structural multipliers (left out of the stability and bifurcation tests): {}",
            ones(p, r.gait.is_none(), &r.coords)
        );
        if let Some(g) = &r.gait {
            let sig = |v: f64| fmt_value(sig(v, d + 1));
            let _ = write!(s, "mean input power {} W", sig(g.mean_power));
            if !g.input_ledger.is_empty() {
                let shares: Vec<String> = g.input_ledger.iter().map(|(n, p)| format!("{n} {} W", sig(*p))).collect();
                let _ = write!(s, " ({})", shares.join(", "));
            }
            if g.efficiency.is_finite() {
                let _ = write!(s, ", efficiency {} m/J", sig(g.efficiency));
            }
            s.push('\n');
            for (j, param) in g.parameters.iter().enumerate() {
                let rows: Vec<(&str, f64)> = g.rows(j).into_iter().filter(|(_, v)| v.is_finite()).collect();
                // at loose tolerances each to the digits of the row's largest
                let scale = rows.iter().fold(0.0f64, |m, (_, v)| m.max(v.abs()));
                let shown = |v: f64| if d < 6 { fmt_value(quantized(v, scale, d + 1)) } else { sig(v) };
                let rows: Vec<String> =
                    rows.into_iter().map(|(what, v)| format!("d{what}/d{param} = {}", shown(v))).collect();
                let _ = writeln!(s, "at {param} = {}: {}", fmt_value(g.values[j]), rows.join(", "));
            }
        }
    }
    for n in &r.notes {
        let _ = writeln!(s, "note: {n}");
    }
    for (what, d) in &r.timings {
        let _ = writeln!(s, "time: {what}: {:.3} s", d.as_secs_f64());
    }
    for f in &r.files {
        let _ = writeln!(s, "wrote {}", f.display());
    }
    s
}

/// `v` rounded to a multiple of the unit of the `digits`-th significant
/// digit of `scale` (a row's largest value): a value far below the scale
/// (a derivative that the symmetry makes 0, at the integration's error)
/// is written 0.
fn quantized(v: f64, scale: f64, digits: usize) -> f64 {
    if scale == 0.0 || !scale.is_finite() {
        return v;
    }
    let unit = 10f64.powi(scale.log10().floor() as i32 - (digits.clamp(1, 7) as i32 - 1));
    sig((v / unit).round() * unit, digits) + 0.0
}

/// `v` to `digits` significant digits (at most 7).
fn sig(v: f64, digits: usize) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let d = digits.clamp(1, 7) - 1;
    format!("{v:.d$e}").parse().unwrap_or(v)
}
