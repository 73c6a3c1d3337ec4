//! `ezy gait-optimize` on the built-in kinematic snake: the best centre
//! of a circle of fixed radius for the second-order lateral motion, the
//! numbers printed and written against the library's `optimize_gait` on
//! the same gait (the oracle of `geometry::a_circles_best_centre_on_the_
//! built_in_snake`: a dense scan of `predict` in ezy-core's tests), and
//! `predict`'s second order at the centre written; refusals by name.

use ezy_core::design::gait::{FourierGait, GaitObjective, GaitOptimization, Measure, Order, optimize_gait};
use ezy_core::geometry::Geometry;
use ezy_models::KinematicSnake;

use crate::analysis::{ezy, fresh, table};

/// The start: the circle of radius 0.6 about (0.7, -0.6), as `--gait` text.
pub(crate) const CIRCLE: &str = "alpha1=0.7+0.6*cos(t),alpha2=-0.6+0.6*sin(t)";

/// The command's optimum is the library's, number for number (the same
/// computation), and the printed centre the library test's (1.056717,
/// -1.056717) to 1e-5; `predict`'s second-order dy at the written
/// centre is the printed objective to 1e-12.
#[test]
fn the_snake_s_best_circle_centre_is_the_library_s() {
    let out = fresh("gait-optimize");
    let args =
        ["gait-optimize", "--gait", CIRCLE, "--maximize", "dy", "--order", "second", "--centre-only", "--no-figures"];
    let clock = std::time::Instant::now();
    let (said, err, ok) = ezy(&args, &out);
    eprintln!("{said}{err}({:.2} s)", clock.elapsed().as_secs_f64());
    assert!(ok, "{said}{err}");
    // the library on the same start
    let g = Geometry::new(KinematicSnake::default(), None, None).unwrap();
    let circle = FourierGait::circle([0.7, -0.6], 0.6, 0.0, 2.0 * std::f64::consts::PI).unwrap();
    let goal = GaitObjective { measure: Measure::Along([0.0, 1.0]), per_cost: false, order: Order::Second };
    let lib = optimize_gait(&g, &GaitOptimization::new(circle, goal).centre_only()).unwrap();
    assert!(lib.converged);
    let line = said.lines().next().unwrap();
    let expected = format!(
        "kinematic-snake: dy (second order) = {} at alpha1.a0 = {}, alpha2.a0 = {} (start {})",
        ezy_core::fmt_value(lib.objective),
        ezy_core::fmt_value(lib.values[0]),
        ezy_core::fmt_value(lib.values[1]),
        ezy_core::fmt_value(lib.start_objective)
    );
    assert_eq!(line, expected);
    assert!((lib.values[0] - 1.056717).abs() < 1e-5 && (lib.values[1] + 1.056717).abs() < 1e-5, "{:?}", lib.values);
    assert!(said.contains(&format!("{} evaluations in", lib.history.len())), "{said}");
    assert!(said.contains("first-order (KKT) conditions hold"), "{said}");
    // gait_optimum.csv: every coefficient, the centre moved, the rest held
    let (head, rows) = table(&out.join("gait_optimum.csv"));
    assert_eq!(head, ["coefficient", "start", "optimum", "free"]);
    let flat = lib.gait.flat();
    assert_eq!(rows.len(), 6);
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row[2].parse::<f64>().unwrap(), flat[k], "{row:?}");
        assert_eq!(row[3], if k % 3 == 0 { "true" } else { "false" }, "{row:?}");
    }
    assert_eq!(rows[0][0], "alpha1.a0");
    assert_eq!(rows[4][0], "alpha2.a1");
    // predict's second order at the written optimum (an oracle apart
    // from the optimizer: the prediction's own area integral)
    let rows_of = |i: usize| rows[3 * i..3 * i + 3].iter().map(|r| r[2].parse().unwrap()).collect::<Vec<f64>>();
    let written = FourierGait::new(vec![rows_of(0), rows_of(1)], 1, 2.0 * std::f64::consts::PI).unwrap();
    let mut g = g;
    let p = g.predict(&written.gait().unwrap(), &[]).unwrap();
    let printed: f64 = line.split(" = ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    eprintln!("dy printed {printed}, predict's second order {}", p.second.unwrap()[1]);
    assert!((p.second.unwrap()[1] - printed).abs() < 1e-12);
    let (head, rows) = table(&out.join("gait_history.csv"));
    assert_eq!(head, ["evaluation", "alpha1.a0", "alpha2.a0", "objective", "failure"]);
    assert_eq!(rows.len(), lib.history.len());
}

/// Refusals name their culprit before any work.
#[test]
fn gait_optimize_refuses_by_name() {
    let out = fresh("gait-optimize-refusals");
    let cases: &[(&[&str], &str)] = &[
        (&["--gait", "alpha1=0.7+0.6*cos(t),alpha3=sin(t)", "--maximize", "dx"], "alpha3"),
        (&["--gait", CIRCLE, "--maximize", "dz"], "--maximize `dz`: give dx, dy, dtheta or along(UX,UY)"),
        (&["--gait", CIRCLE, "--maximize", "dx", "--harmonics", "0"], "--harmonics 0"),
        (&["--gait", "alpha1=0.7+0.6*cos(1.5*t),alpha2=sin(t)", "--maximize", "dx"], "alpha1"),
        (&["--gait", CIRCLE, "--maximize", "dx", "--range", "beta=-1:1"], "--range `beta`: not a shape coordinate"),
        (&["--gait", CIRCLE, "--maximize", "dx", "--range", "alpha1=1:-1"], "alpha1"),
        (&["--gait", CIRCLE, "--maximize", "dx", "--margin", "2"], "margin"),
    ];
    for (extra, words) in cases {
        let args: Vec<&str> = ["gait-optimize"].into_iter().chain(extra.iter().copied()).collect();
        let (said, err, ok) = ezy(&args, &out);
        assert!(!ok && err.contains(words), "{extra:?}: {said}{err}");
        assert!(!out.join("gait_optimum.csv").exists(), "{extra:?} wrote");
    }
}

/// `--metric G` measures the path length (`--budget`, `--per-length`)
/// as `int sqrt(r'^T G r') dt`. Oracle by scaling: the length in `G = 4
/// I` is twice the identity's, so the forward motion per length is half
/// and a budget of 5 in it is a budget of 2.5 in the identity: the same
/// optimum, coefficient for coefficient, its objective halved (the
/// budget binding at both, with a rank margin of 0.3). A metric that is
/// not diagonal: the command's optimum is the library's with the same
/// metric, number for number. Refused by name: a metric of the wrong
/// size, one not positive definite.
#[test]
fn a_metric_of_the_users_own_measures_the_path_length() {
    let base = [
        "gait-optimize",
        "--gait",
        CIRCLE,
        "--maximize",
        "dx",
        "--order",
        "first",
        "--per-length",
        "--margin",
        "0.3",
        "--no-figures",
    ];
    let optimum = |extra: &[&str], what: &str| {
        let out = fresh(&format!("gait-metric-{what}"));
        let (said, err, ok) = ezy(&[&base[..], extra].concat(), &out);
        assert!(ok, "{said}{err}");
        assert!(said.contains("first-order (KKT) conditions hold") && said.contains("path length <= "), "{said}");
        let printed: f64 =
            said.lines().next().unwrap().split(" = ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
        let (_, rows) = table(&out.join("gait_optimum.csv"));
        (printed, rows.iter().map(|r| r[2].parse::<f64>().unwrap()).collect::<Vec<f64>>())
    };
    let (f1, identity) = optimum(&["--budget", "2.5"], "identity");
    let (f4, scaled) = optimum(&["--budget", "5", "--metric", "4,0,0,4"], "scaled");
    eprintln!("identity, budget 2.5: {f1} at {identity:?}\nG = 4 I, budget 5: {f4} at {scaled:?}");
    for (a, b) in identity.iter().zip(&scaled) {
        assert!((a - b).abs() <= 1e-9, "{identity:?} against {scaled:?}");
    }
    assert!((f1 - 2.0 * f4).abs() <= 1e-12 * f1, "{f1} against 2 x {f4}");
    let (_, skew) = optimum(&["--budget", "3", "--metric", "2,0.3,0.3,1"], "skew");
    let g = Geometry::new(KinematicSnake::default(), None, None).unwrap();
    let start = FourierGait::circle([0.7, -0.6], 0.6, 0.0, 2.0 * std::f64::consts::PI).unwrap();
    let goal = GaitObjective { measure: Measure::Along([1.0, 0.0]), per_cost: true, order: Order::First };
    let mut problem = GaitOptimization::new(start, goal);
    problem.margin = Some(0.3);
    problem.budget = Some(3.0);
    problem.metric = Some(vec![2.0, 0.3, 0.3, 1.0]);
    let lib = optimize_gait(&g, &problem).unwrap();
    assert!(lib.converged);
    assert_eq!(skew, lib.gait.flat(), "the command's optimum is the library's");
    assert!(skew.iter().zip(&identity).any(|(a, b)| (a - b).abs() > 1e-3), "the metric changes the optimum");
    for (metric, words) in [("1,2", "2 entries for 2 shape coordinates (4 wanted)"), ("1,0,0,-1", "positive definite")]
    {
        let out = fresh("gait-metric-bad");
        let (said, err, ok) = ezy(&[&base[..], &["--metric", metric]].concat(), &out);
        assert!(!ok && err.contains(words), "{metric}: {said}{err}");
    }
}
