//! Forward sensitivities of runs (`ezy_core::sensitivity`) against the
//! Chaplygin sleigh's closed form differentiated by hand and against
//! central differences of whole runs, for every explicit method, with
//! respect to scene, effect, model and initial-value parameters.

use crate::common;

use ezy::models::{ChaplyginSleigh, EzyRoller, scenes};
use ezy_core::sensitivity::{Derivative, Parameter, Sensitivities};
use ezy_core::{Method, Model, Problem};

/// The parameters `names` of a built-in scene's problem (as `ezy
/// sensitivity --wrt` takes them).
fn parameters<M: Model + Default>(scene: &ezy_scene::Scene, names: &[&str]) -> Vec<Parameter<M>> {
    names.iter().map(|n| scene.parameter(&M::default(), &[], n).unwrap()).collect()
}

/// `d(column)/dp` at the last sample from central differences of whole
/// runs at `p +- h` and `p +- h/2`, `h = 1e-4 max(1, |p|)`, extrapolated
/// (Richardson: error O(h^4), where a plain difference's O(h^2) was 2e-6
/// of the fork length's sensitivity, `c` = 0.12 m); the runs' own error,
/// about the tolerance 1e-13 relative, stays below 1e-8 of the result.
fn difference<M: Model>(param: &Parameter<M>, settings: &ezy_core::RunSettings, column: &str) -> f64 {
    let end = |v: f64| {
        let mut p = param.problem(v).unwrap();
        p.settings = *settings;
        *p.solve().unwrap().column(column).unwrap().last().unwrap()
    };
    let central = |h: f64| (end(param.value + h) - end(param.value - h)) / (2.0 * h);
    let h = 1e-4 * param.value.abs().max(1.0);
    (4.0 * central(h / 2.0) - central(h)) / 3.0
}

/// Largest relative disagreement between the sensitivity run's last
/// sample and differences of whole runs over `columns` and every
/// parameter, relative to the largest sensitivity of that parameter.
fn worst_against_differences<M: Model>(
    s: &Sensitivities,
    params: &[Parameter<M>],
    settings: &ezy_core::RunSettings,
    columns: &[&str],
) -> f64 {
    let mut worst: f64 = 0.0;
    for p in params {
        let got: Vec<f64> =
            columns.iter().map(|c| *s.column(&format!("d{c}/d{}", p.name)).unwrap().last().unwrap()).collect();
        let scale = common::max_abs(got.iter().copied()).max(1e-300);
        for (c, g) in columns.iter().zip(&got) {
            let want = difference(p, settings, c);
            let rel = (g - want).abs() / scale;
            assert!(rel.is_finite(), "{c}/{}: {g} against {want}", p.name);
            worst = worst.max(rel);
            if rel > 1e-6 {
                eprintln!("d{c}/d{}: {g:.12e} against {want:.12e} (rel {rel:.1e})", p.name);
            }
        }
    }
    worst
}

/// The sleigh's forward speed `u(t) = U tanh(k U t + s0)` with `U^2 =
/// u0^2 + (J/m) w0^2`, `s0 = atanh(u0/U)` (docs/physics.md §9)
/// differentiated by hand with respect to the initial speed `u0`:
/// `dU/du0 = u0/U`, `ds0/du0 = 1/U`, so `du/du0 = (u0/U) tanh z + (1 + k
/// t u0) sech^2 z` with `z = k U t + s0`. The run starts at heading 0,
/// so `u0` is the initial `x` velocity (`initial.qd.x`). RK4 at the
/// scene's `dt = 1e-4 s` integrates the state to 1e-12; the sensitivity
/// agrees to 1e-10 over the 10 s (measured 1.4e-14).
#[test]
fn sleigh_speed_sensitivity_is_the_closed_form_differentiated_by_hand() {
    let scene = scenes::sleigh();
    let (problem, _) = scene.problem::<ChaplyginSleigh>(&[]).unwrap();
    let s = problem.sensitivities(&["initial.qd.x"]).unwrap();
    assert_eq!(s.derivatives, vec![Derivative::InitialOnly]);
    let (u0, w0) = (1.0, 1.0);
    let (big_u, k, s0) = common::sleigh_closed_form(u0, w0);
    let col = |n: &str| s.column(n).unwrap();
    let (phi, xd, yd) = (col("phi"), col("xd"), col("yd"));
    let (dphi, dxd, dyd) = (col("dphi/dinitial.qd.x"), col("dxd/dinitial.qd.x"), col("dyd/dinitial.qd.x"));
    let mut worst: f64 = 0.0;
    for (i, &t) in s.t.iter().enumerate() {
        let (c, sn) = (phi[i].cos(), phi[i].sin());
        let du = dxd[i] * c + dyd[i] * sn + (-xd[i] * sn + yd[i] * c) * dphi[i];
        let z = k * big_u * t + s0;
        let want = u0 / big_u * z.tanh() + (1.0 + k * t * u0) / z.cosh().powi(2);
        worst = worst.max((du - want).abs());
    }
    eprintln!("sleigh: worst {worst:.1e}");
    assert!(worst < 1e-10, "du/du0 deviates from the closed form by {worst:e}");
    assert_eq!(*s.t.last().unwrap(), 10.0);
}

/// The EzyRoller's `drive` over 2 s: sensitivities with respect to the
/// motor's amplitude and frequency (scene parameters), the rear body's
/// mass (a model parameter: masses and nothing else), the fork length `c`
/// (a model parameter in the constraints) and the initial hinge angle,
/// against central differences of whole runs (DOP853 at 1e-13), to 1e-6
/// of the largest sensitivity, for DOP853, DOPRI5 and RK4 (and the
/// differences of RK4 runs at the same fixed step).
#[test]
fn drive_sensitivities_match_differences_of_whole_runs_for_every_method() {
    let mut scene = scenes::drive();
    scene.t_end = 2.0;
    let names = ["M0", "omega", "m2", "c", "initial.q.phi2"];
    let params = parameters::<EzyRoller>(&scene, &names);
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    for (method, tol, dt) in [(Method::Dop853, 1e-13, 1e-4), (Method::Dopri5, 1e-12, 1e-4), (Method::Rk4, 1e-9, 1e-3)] {
        let (mut problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
        problem.settings = ezy_core::RunSettings {
            method,
            rtol: tol,
            atol: tol,
            dt,
            formulation: ezy_core::Formulation::Dae,
            ..problem.settings
        };
        let params: Vec<Parameter<EzyRoller>> = params
            .iter()
            .map(|p| {
                let (settings, p) = (problem.settings, p.clone());
                Parameter::new(p.name.clone(), p.value, move |v| {
                    let mut q: Problem<EzyRoller> = p.problem(v)?;
                    q.settings = settings;
                    Ok(q)
                })
            })
            .collect();
        let s = problem.sensitivities_with(&params).unwrap();
        assert!(s.derivatives.iter().take(4).all(|d| matches!(d, Derivative::Central { .. })), "{:?}", s.derivatives);
        assert_eq!(s.derivatives[4], Derivative::InitialOnly);
        let worst = worst_against_differences(&s, &params, &problem.settings, &columns);
        eprintln!("{method:?}: worst {worst:.1e}");
        assert!(worst < 1e-6, "{method:?}: sensitivities disagree with differences of runs by {worst:.1e}");
    }
}

/// A drag of the user's own, `F = -c (xd, yd)` on the sleigh's centre of
/// mass: a law ezy knows nothing of.
#[derive(Debug, Clone)]
struct Drag {
    c: f64,
}

impl ezy_core::effects::ForceLaw for Drag {
    fn apply(&self, _t: f64, _q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let (fx, fy) = (-self.c * qd[0], -self.c * qd[1]);
        f[0] += fx;
        f[1] += fy;
        (fx * qd[0] + fy * qd[1], fx.hypot(fy))
    }
    fn coords(&self) -> Vec<usize> {
        vec![0, 1]
    }
}

/// A model and a force law of the user's own, the parameter given by a
/// closure that builds the problem (as a user's crate would): the
/// sensitivity to the drag coefficient and to the sleigh's mass agrees
/// with differences of whole runs to 1e-6, for DOP853 at 1e-12.
#[test]
fn a_law_of_the_users_own_is_differentiated_as_a_built_in_one() {
    let build = |c: f64| -> Result<Problem<ChaplyginSleigh>, ezy_core::SimError> {
        Ok(Problem::new(ChaplyginSleigh::default())
            .law("drag", Drag { c })?
            .q("x", 0.0)?
            .q("y", 0.0)?
            .q("phi", 0.0)?
            .qd("x", 1.0)?
            .qd("phi", 1.0)?
            .t_end(2.0)
            .method(Method::Dop853)
            .tolerances(1e-12, 1e-12)
            .formulation(ezy_core::Formulation::Dae))
    };
    let problem = build(0.3).unwrap();
    let params = vec![Parameter::new("c", 0.3, build), Parameter::model(&problem, "m").unwrap()];
    let s = problem.sensitivities_with(&params).unwrap();
    let worst = worst_against_differences(&s, &params, &problem.settings, &["x", "y", "phi", "xd", "phid"]);
    eprintln!("user law: worst {worst:.1e}");
    assert!(worst < 1e-6, "a user's law: sensitivities disagree with differences of runs by {worst:.1e}");
}

/// A rolling resistance of 0 cannot be differentiated centrally (a
/// negative damping is refused): the one-sided difference of second
/// order is taken and said, and agrees with one-sided differences of
/// whole runs to 1e-6.
#[test]
fn a_damping_of_zero_is_differentiated_one_sided() {
    let mut scene = scenes::get("drive-rolling-resistance");
    scene.t_end = 1.0;
    let sets = [("rolling_A.damping".to_string(), 0.0)];
    let (problem, _) = scene.problem::<EzyRoller>(&sets).unwrap();
    let p = scene.parameter(&EzyRoller::default(), &sets, "rolling_A.damping").unwrap();
    assert_eq!(p.value, 0.0);
    let s = problem.sensitivities_with(std::slice::from_ref(&p)).unwrap();
    assert!(matches!(s.derivatives[0], Derivative::OneSided { .. }), "{:?}", s.derivatives);
    let end = |v: f64| p.problem(v).unwrap().solve().unwrap().column("x1").unwrap().last().copied().unwrap();
    let h = 1e-4;
    let want = (-3.0 * end(0.0) + 4.0 * end(h) - end(2.0 * h)) / (2.0 * h);
    let got = *s.column("dx1/drolling_A.damping").unwrap().last().unwrap();
    assert!((got - want).abs() <= 1e-6 * want.abs(), "{got} against {want}");
}

/// What a sensitivity run cannot take is refused before any work, naming
/// the culprit.
#[test]
fn bad_requests_are_refused_naming_the_culprit() {
    let scene = scenes::drive();
    let (problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let err = |p: &Problem<EzyRoller>, names: &[&str]| p.sensitivities(names).unwrap_err().to_string();
    assert!(err(&problem, &[]).contains("no parameters"));
    assert!(err(&problem, &["m9"]).contains("m9"), "{}", err(&problem, &["m9"]));
    assert!(err(&problem, &["m1", "m1"]).contains("named twice"));
    assert!(err(&problem, &["initial.qd.nope"]).contains("nope"));
    // RADAU5 takes the sensitivities (its Newton systems dense): not past
    // 1000 states, 2 nq (1 + np) = 12 x 84 here
    let radau =
        Problem { settings: ezy_core::RunSettings { method: Method::Radau5, ..problem.settings }, ..problem.clone() };
    let many: Vec<Parameter<EzyRoller>> = (0..83)
        .map(|k| {
            let base = radau.clone();
            Parameter::new(format!("p{k}"), 1.0, move |_| Ok(base.clone()))
        })
        .collect();
    let e = radau.sensitivities_with(&many).unwrap_err().to_string();
    assert!(e.contains("radau5") && e.contains("1008 states") && e.contains("1000"), "{e}");
    // the reduced formulation is differentiated (its own steps, against
    // the differences of whole reduced runs in tests/oracle), not refused
    let reduced = Problem {
        settings: ezy_core::RunSettings {
            formulation: ezy_core::Formulation::Reduced,
            t_end: 0.01,
            ..problem.settings
        },
        ..problem.clone()
    };
    let s = reduced.sensitivities(&["m1"]).unwrap();
    assert_eq!(s.formulation, ezy_core::Formulation::Reduced);
    let stabilized = Problem { baumgarte: Some(ezy_core::Baumgarte { alpha: 1.0, beta: 1.0 }), ..problem.clone() };
    assert!(err(&stabilized, &["m1"]).contains("Baumgarte"));
    let huge = Problem { max_output_mb: 0.001, ..problem.clone() };
    assert!(err(&huge, &["m1"]).contains("MB"), "{}", err(&huge, &["m1"]));
    // a scene's unknown number, and one it leaves at its default
    let model = EzyRoller::default();
    assert!(scene.parameter(&model, &[], "motor.nope").unwrap_err().to_string().contains("motor.nope"));
    assert!(scene.parameter(&model, &[], "nope").unwrap_err().to_string().contains("nope"));
}

/// Parameter values at the edge of what ezy takes: `M0 = 1e30` runs with
/// finite sensitivities or ends in an error, never in a number that is not
/// finite; `M0 = 1e34` (the largest magnitude a scene takes) is refused
/// naming the parameter, as its step `M0 + h` is out of range.
#[test]
fn huge_parameter_values_end_in_finite_numbers_or_an_error() {
    let mut scene = scenes::drive();
    scene.t_end = 0.01;
    let model = EzyRoller::default();
    let sets = [("M0".to_string(), 1e30)];
    let (problem, _) = scene.problem::<EzyRoller>(&sets).unwrap();
    let p = scene.parameter(&model, &sets, "M0").unwrap();
    match problem.sensitivities_with(&[p]) {
        Ok(s) => assert!(s.s.iter().chain(&s.x).flatten().all(|v| v.is_finite())),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
    let sets = [("M0".to_string(), 1e34)];
    let (problem, _) = scene.problem::<EzyRoller>(&sets).unwrap();
    let p = scene.parameter(&model, &sets, "M0").unwrap();
    let e = problem.sensitivities_with(&[p]).unwrap_err().to_string();
    assert!(e.contains("parameter `M0`") && e.contains("out of range"), "{e}");
}

/// `ezy sensitivity`: `sensitivity.csv` with `t` and the `d<column>/d<param>`
/// columns, its numbers those of the library's run, a figure per
/// parameter; an unknown parameter refused before anything is written.
#[test]
fn the_command_writes_the_csv_and_a_figure_per_parameter() {
    let dir = std::env::temp_dir().join(format!("ezy-sensitivity-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let ezy = |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().unwrap();
    let out = dir.to_str().unwrap();
    let o = ezy(&["sensitivity", "drive", "--wrt", "M0,initial.q.phi2", "--t-end", "0.5", "--out", out]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.join("sensitivity.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(head[..3], ["t", "dx1/dM0", "dy1/dM0"]);
    assert_eq!(head.len(), 1 + 2 * 12);
    assert!(head.contains(&"dphi2d/dinitial.q.phi2"));
    let last: Vec<f64> = lines.last().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(last[0], 0.5);
    let mut scene = scenes::drive();
    scene.t_end = 0.5;
    let (problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let s = problem.sensitivities_with(&parameters::<EzyRoller>(&scene, &["M0", "initial.q.phi2"])).unwrap();
    assert_eq!(last[1..], s.s.last().unwrap()[..], "the command's numbers are the library's");
    assert!(dir.join("sensitivity_M0.png").exists() && dir.join("sensitivity_initial.q.phi2.png").exists());
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(printed.contains("d/dM0 at M0 = 2"), "{printed}");
    // refused before any work: the output directory keeps what it had
    let o = ezy(&["sensitivity", "drive", "--wrt", "M0,nope", "--out", out]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope"));
    assert!(dir.join("sensitivity_M0.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The gait of `drive-rolling-resistance` at parameter value `v` of
/// `p` (searched from `guess` at its forcing's period), with its mean
/// input power: `(orbit, mean power)`.
fn gait_at(
    p: &Parameter<EzyRoller>,
    v: f64,
    guess: &[f64],
) -> (ezy_core::analysis::PeriodicOrbit, ezy_core::sensitivity::GaitSensitivities) {
    use ezy_core::analysis::PeriodicSettings;
    use ezy_core::effects::Periodicity;
    let problem = p.problem(v).unwrap();
    let (mut an, x0) = problem.clone().analysis().unwrap();
    let Some(Periodicity::Period(period)) = an.forcing() else { panic!("a periodic forcing") };
    let sym = an.symmetry(0.0, &x0).unwrap();
    let orbit = an.periodic_orbit(0.0, period, guess, sym, &PeriodicSettings::default()).unwrap();
    let g = problem.gait_sensitivities(&orbit, std::slice::from_ref(p), &PeriodicSettings::default()).unwrap();
    (orbit, g)
}

/// The gait's sensitivities by the implicit function theorem against
/// central differences of converged orbits (the search's residual 1e-9
/// over steps of 1e-3 relative: about 1e-6 of noise, which the tolerance
/// below takes; measured to 1e-6 and better), with respect to the
/// motor's amplitude and frequency (the period moves with it), a skate's
/// rolling resistance and the fork length `c` (in the constraints): mean
/// speed, displacement, heading change, mean input power, efficiency.
#[test]
fn gait_sensitivities_match_differences_of_converged_orbits() {
    let scene = scenes::get("drive-rolling-resistance");
    let (problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
    let guess = problem.clone().solve().unwrap().final_state()[..12].to_vec();
    let names = ["motor.amplitude", "motor.omega", "rolling_A.damping", "c"];
    for p in parameters::<EzyRoller>(&scene, &names) {
        let (orbit, g) = gait_at(&p, p.value, &guess);
        let h = 1e-3 * p.value.abs().max(0.1);
        let (op, gp) = gait_at(&p, p.value + h, &orbit.state);
        let (om, gm) = gait_at(&p, p.value - h, &orbit.state);
        let fd = |a: f64, b: f64| (a - b) / (2.0 * h);
        let checks = [
            ("mean_speed", g.d_mean_speed[0], fd(op.mean_speed(), om.mean_speed())),
            ("dx", g.d_displacement[0][0], fd(op.displacement[0], om.displacement[0])),
            ("period", g.d_period[0], fd(op.period, om.period)),
            ("mean_power", g.d_mean_power[0], fd(gp.mean_power, gm.mean_power)),
            ("efficiency", g.d_efficiency[0], fd(gp.efficiency, gm.efficiency)),
        ];
        for (what, got, want) in checks {
            let scale = want.abs().max(1e-3 * g.mean_power.max(orbit.mean_speed()));
            eprintln!("d{what}/d{}: {got:.9e} against {want:.9e}", p.name);
            assert!((got - want).abs() <= 1e-5 * scale, "d{what}/d{}: {got} against {want}", p.name);
        }
        assert!(g.d_heading_change[0].abs() < 1e-9, "no net turn whatever the parameter");
    }
}

/// The samples inside steps come from the method's dense output: a
/// sensitivity run's state at every output time, and at times a
/// measurement gives (`sensitivities_at`), equals the ordinary run's to
/// 1e-10 at tolerances 1e-12, for DOPRI5 and DOP853 (DOP853's dense
/// output needs the slope at the step's end, which a first version left
/// unevaluated: 1e-5 m off between step ends).
#[test]
fn samples_inside_steps_are_the_runs_own() {
    let mut scene = scenes::get("drive-rolling-resistance");
    scene.t_end = 3.0;
    for method in [Method::Dop853, Method::Dopri5] {
        let (mut problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
        problem.settings = ezy_core::RunSettings { method, rtol: 1e-12, atol: 1e-12, every: 0.05, ..problem.settings };
        let run = problem.clone().solve().unwrap();
        let params = parameters::<EzyRoller>(&scene, &["motor.amplitude"]);
        let s = problem.sensitivities_with(&params).unwrap();
        let times: Vec<f64> = (1..=30).map(|k| 0.1 * f64::from(k) - 0.0123).collect();
        let at = problem.sensitivities_at(&params, &times, None).unwrap();
        assert_eq!(at.t, times);
        let x1 = run.column("x1").unwrap();
        assert_eq!(s.t, run.t);
        let worst = common::max_abs(s.column("x1").unwrap().iter().zip(&x1).map(|(a, b)| a - b));
        assert!(worst < 1e-10, "{method:?}: {worst:e}");
        // the listed times against the full run's dense samples nearby
        let fine = problem.clone().every(0.0001).solve().unwrap();
        let fx = fine.column("x1").unwrap();
        for (t, x) in at.t.iter().zip(at.column("x1").unwrap()) {
            let k = fine.t.iter().position(|v| (v - t).abs() < 5e-5).unwrap();
            let slope = (fx[k + 1] - fx[k - 1]) / (fine.t[k + 1] - fine.t[k - 1]);
            let want = fx[k] + slope * (t - fine.t[k]);
            assert!((x - want).abs() < 1e-8, "{method:?} at {t}: {x} against {want}");
        }
    }
}

/// The N-four-bar passes a singular position at t = 0.714 s (the ordinary
/// run passes it); a sensitivity run does not yet, and says so, naming
/// the time, instead of a bare "step size too small".
#[test]
fn a_singular_position_is_named_not_passed() {
    let mut scene = scenes::get("four-bar-n2");
    scene.t_end = 1.0;
    let (problem, _) = scene.problem::<ezy::models::NFourBar>(&[]).unwrap();
    let e = problem.sensitivities(&["initial.qd.xc1"]).unwrap_err().to_string();
    assert!(e.contains("singular position") && e.contains("t = 0.71"), "{e}");
}

/// A skate that slides from the start (sleigh-ice: launched sideways,
/// its slip velocity 2 m/s at t = 0): the sensitivities, which take every
/// skate as holding and do not follow the jump of the sensitivities at a
/// stick-slip switch, were 137 % off central differences with exit 0
/// (mu = 100); the linearization at t = 0.1 s, inside the slide, was the
/// ideal sleigh's. Both are refused, naming the skate, its effect and the
/// time, and no table is written.
#[test]
fn a_sliding_skate_is_refused_by_name() {
    let dir = crate::analysis::fresh("sliding-sensitivity");
    for mu in ["0.1", "100"] {
        let set = format!("slip_P.mu={mu}");
        let (_, err, ok) =
            crate::analysis::ezy(&["sensitivity", "sleigh-ice", "--wrt", "m", "--set", &set, "--no-figures"], &dir);
        assert!(!ok && err.contains("skate `P` slides on this run") && err.contains("(effect `slip_P`)"), "{err}");
        assert!(err.contains("at t = 0 s"), "{err}");
        assert!(!dir.join("sensitivity.csv").exists(), "{mu}");
    }
    let (_, err, ok) = crate::analysis::ezy(&["linearize", "sleigh-ice", "--at", "0.1"], &dir.join("l"));
    assert!(!ok && err.contains("skate `P` slides on the state linearized"), "{err}");
    // (the directory's lock, taken before the work, stays behind)
    assert!(!dir.join("l/A.csv").exists());
}
