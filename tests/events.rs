//! Located events (`ezy_core::events`) against a closed form: the
//! Chaplygin sleigh's heading crossing a level, for every integrator with
//! a continuous extension and both formulations; a stop event ending the
//! run at the event; a function of the user's own; chattering reported.

use crate::common;

use ezy::models::ChaplyginSleigh;
use ezy_core::effects::{EffectSpec, Frame, Waveform};
use ezy_core::events::{Action, Direction, Event, EventSpec};
use ezy_core::{Formulation, Method, Problem, SimError};

/// The sleigh from `u0 = 1` m/s, `omega0 = 1` rad/s (the scene `sleigh`).
fn sleigh() -> Problem<ChaplyginSleigh> {
    Problem::new(ChaplyginSleigh::default())
        .q("x", 0.0)
        .and_then(|p| p.q("y", 0.0))
        .and_then(|p| p.q("phi", 0.0))
        .and_then(|p| p.qd("x", 1.0))
        .and_then(|p| p.qd("phi", 1.0))
        .unwrap()
        .t_end(3.0)
}

/// When the sleigh's heading reaches `level` \[rad\] (docs/physics.md §9):
/// `omega = omega0 cosh(s0) / cosh(k U t + s0)`, so
/// `phi = omega0 cosh(s0) / (k U) (gd(k U t + s0) - gd(s0))` with the
/// Gudermannian `gd(x) = 2 atan(tanh(x / 2))`, inverted by
/// `gd^-1(y) = atanh(sin y)`.
fn heading_time(level: f64) -> f64 {
    let (big_u, k, s0) = common::sleigh_closed_form(1.0, 1.0);
    let gd = |x: f64| 2.0 * (0.5 * x).tanh().atan();
    let target = gd(s0) + level * k * big_u / s0.cosh();
    (target.sin().atanh() - s0) / (k * big_u)
}

/// The sleigh's yaw rate at `t` \[rad/s\] (docs/physics.md §9).
fn heading_rate(t: f64) -> f64 {
    let (big_u, k, s0) = common::sleigh_closed_form(1.0, 1.0);
    s0.cosh() / (k * big_u * t + s0).cosh()
}

/// Each integrator finds the heading's crossing of 0.5 rad at its closed
/// form's time to 1e-10 s, in both formulations. The bound: the
/// location itself is exact to rounding (a few 1e-16 s), so what is left
/// is the continuous extension's error at rtol 1e-12 (RK4: h = 1e-3 s,
/// local error about 1e-14) over the heading's rate there (about 0.2
/// rad/s), well under 1e-10; a wrong interpolant (the step's end instead
/// of the crossing, a linear one) is off by 1e-4 s or more.
#[test]
fn heading_crossing_is_located_to_1e_10_by_every_integrator() {
    let want = heading_time(0.5);
    assert!(want > 0.5 && want < 3.0, "{want}");
    let spec = EventSpec { direction: Direction::Rising, ..EventSpec::new("phi", 0.5) };
    for method in [Method::Rk4, Method::Dopri5, Method::Dop853, Method::Radau5] {
        for formulation in [Formulation::Dae, Formulation::Reduced] {
            if method == Method::Radau5 && formulation == Formulation::Reduced {
                continue;
            }
            // RADAU5 meets rtol^(2/3) / 10 (Hairer's conversion of the
            // tolerance): 1e-14 asks it for about 5e-11
            let tol = if method == Method::Radau5 { 1e-14 } else { 1e-12 };
            let p = sleigh().method(method).tolerances(tol, tol).dt(1e-3).formulation(formulation);
            let clock = EventSpec::new("t", want);
            let solution = p.event("half", &spec).unwrap().event("clock", &clock).unwrap().solve().unwrap();
            let events = &solution.summary.events;
            // the solution's own error there, against which the location is judged
            let own = events.iter().find(|e| e.name == "clock").map(|e| e.y[2] - 0.5).unwrap();
            eprintln!("{method:?} {formulation:?}: phi(t*) - 0.5 = {own:.1e} rad");
            let events: Vec<_> = events.iter().filter(|e| e.name == "half").cloned().collect();
            assert_eq!(events.len(), 1, "{method:?} {formulation:?}: {events:?}");
            let e = &events[0];
            assert_eq!(e.name, "half");
            assert!(e.rising);
            let err = (e.t - want).abs();
            eprintln!("{method:?} {formulation:?}: t = {:.15} s, error {err:.1e} s", e.t);
            assert!(err < 1e-10, "{method:?} {formulation:?}: t = {} against {want}: {err:e}", e.t);
            // and what the location adds to the solution's own error
            // (its heading off by `own` at t*, so its crossing off by
            // -own / phid): below 1e-12 s, a tenth of DOP853's 6e-12
            let added = (e.t - want) + own / heading_rate(want);
            assert!(added.abs() < 1e-12, "{method:?} {formulation:?}: the location adds {added:e} s");
            // the state recorded is at the crossing and on the constraints
            assert!((e.y[2] - 0.5).abs() < 1e-9, "{method:?}: phi = {}", e.y[2]);
            let (phi, xd, yd, w) = (e.y[2], e.y[3], e.y[4], e.y[5]);
            let slip = -xd * phi.sin() + yd * phi.cos() - 0.5 * w;
            assert!(slip.abs() < 1e-12, "{method:?}: skate residual {slip:e}");
            // the run went on to its end
            assert_eq!(solution.t.last(), Some(&3.0));
            assert!(solution.summary.stopped.is_none());
        }
    }
}

/// A stop event ends the run at the event: its state is the last row and
/// the final state, at the closed form's time; a falling event of the
/// same quantity is not fired by a rising crossing.
#[test]
fn a_stop_event_ends_the_run_at_the_event_with_the_row_written() {
    let want = heading_time(0.3);
    for method in [Method::Rk4, Method::Dop853, Method::Radau5] {
        let solution = sleigh()
            .method(method)
            .tolerances(1e-12, 1e-12)
            .dt(1e-3)
            .every(0.1)
            .event("down", &EventSpec { direction: Direction::Falling, ..EventSpec::new("phi", 0.3) })
            .unwrap()
            .event("far", &EventSpec { action: Action::Stop, ..EventSpec::new("phi", 0.3) })
            .unwrap()
            .solve()
            .unwrap();
        let t_last = *solution.t.last().unwrap();
        assert!((t_last - want).abs() < 1e-10, "{method:?}: {t_last} against {want}");
        assert_eq!(solution.summary.stopped.as_ref().map(|(n, t)| (n.as_str(), *t)), Some(("far", t_last)));
        assert_eq!(solution.summary.events.len(), 1, "{:?}", solution.summary.events);
        let last = solution.y.last().unwrap();
        assert_eq!(last.as_slice(), solution.final_state());
        assert!((last[2] - 0.3).abs() < 1e-9, "{method:?}: phi = {}", last[2]);
        // the rows before it are the output grid's, in order
        let n = solution.t.len();
        assert!(solution.t[n - 2] < t_last && t_last - solution.t[n - 2] <= 0.1 + 1e-12);
    }
}

/// A function of the user's own gives the same event as the named
/// quantity, and several events of one step are recorded in time order.
#[test]
fn a_user_function_and_several_events_in_time_order() {
    let solution = sleigh()
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12)
        .event("b", &EventSpec::new("phi", 0.45))
        .unwrap()
        .with_event(Event::from_fn("a", |_, q, _| q[2] - 0.4).unwrap())
        .unwrap()
        .event("clock", &EventSpec::new("t", 2.5))
        .unwrap()
        .solve()
        .unwrap();
    let names: Vec<&str> = solution.summary.events.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "clock"]);
    let times: Vec<f64> = solution.summary.events.iter().map(|e| e.t).collect();
    assert!((times[0] - heading_time(0.4)).abs() < 1e-10);
    assert!((times[1] - heading_time(0.45)).abs() < 1e-10);
    // a time event is exact to rounding
    assert!((times[2] - 2.5).abs() < 1e-15, "{}", times[2]);
}

/// Events that record do not change the run: the samples with events
/// are the samples without, bit for bit (RK4 and DOP853, events that fire
/// several times).
#[test]
fn recording_events_leaves_the_run_bit_for_bit() {
    for method in [Method::Rk4, Method::Dop853] {
        let plain = sleigh().method(method).dt(1e-3).t_end(10.0);
        let watched = plain
            .clone()
            .event("turn", &EventSpec::new("phi", 0.3))
            .unwrap()
            .event("slow", &EventSpec::new("phid", 0.1))
            .unwrap()
            .event("side", &EventSpec::new("P.vy", 0.5))
            .unwrap();
        let (a, b) = (plain.solve().unwrap(), watched.solve().unwrap());
        assert!(b.summary.events.len() >= 3, "{method:?}: {:?}", b.summary.events);
        assert_eq!(a.t, b.t);
        assert_eq!(a.y, b.y, "{method:?}");
    }
}

/// A quantity that changes sign at every step (it sits on its level)
/// chatters: the run stops with the event named, not looping on it.
#[test]
fn chattering_is_reported_with_the_event_and_time() {
    let flip = Event::from_fn("flip", |t, _, _| if ((t / 1e-3).round() as i64) % 2 == 0 { 1.0 } else { -1.0 }).unwrap();
    let err = sleigh().method(Method::Rk4).dt(1e-3).with_event(flip).unwrap().solve().unwrap_err();
    match &err {
        SimError::Chattering { event, t0, t1, steps } => {
            assert_eq!(event, "flip");
            assert_eq!(*steps, ezy_core::events::CHATTER_STEPS);
            assert!(*t0 < 0.01 && *t1 < 0.1, "{t0} {t1}");
        }
        other => panic!("{other}"),
    }
    assert!(err.to_string().contains("the event `flip` chatters"), "{err}");
    // two events taking turns, each firing every other step: every step
    // has an event, but neither chatters
    let step = |t: f64| (t / 1e-3).round() as i64;
    let sign = |k: i64| if k % 2 == 0 { 1.0 } else { -1.0 };
    let even = Event::from_fn("even", move |t, _, _| sign(step(t) / 2)).unwrap();
    let odd = Event::from_fn("odd", move |t, _, _| sign((step(t) + 1) / 2)).unwrap();
    let run = sleigh().method(Method::Rk4).dt(1e-3).t_end(0.3).with_event(even).unwrap().with_event(odd).unwrap();
    let events = run.solve().unwrap().summary.events;
    assert!(events.len() >= 290, "{}", events.len());
}

/// The sleigh from rest at `phi = 0`, pushed along x at its centre of
/// mass by `F = 0.5` N (`push`), its push turned off by a switch where
/// the centre has gone `L = 2` m.
fn pushed_sleigh(method: Method) -> Problem<ChaplyginSleigh> {
    let push = EffectSpec::Force(ezy_core::effects::Force {
        at: "sleigh".into(),
        fx: Waveform::Constant(0.5),
        fy: Waveform::Constant(0.0),
        frame: Frame::World,
    });
    let coast = EventSpec { action: Action::Switch, switch_off: vec!["push".into()], ..EventSpec::new("x", 2.0) };
    Problem::new(ChaplyginSleigh::default())
        .effect("push", push)
        .and_then(|p| p.event("coast", &coast))
        .and_then(|p| p.q("x", 0.0))
        .and_then(|p| p.q("y", 0.0))
        .and_then(|p| p.q("phi", 0.0))
        .and_then(|p| p.qd("x", 0.0))
        .and_then(|p| p.qd("phi", 0.0))
        .unwrap()
        .method(method)
        .tolerances(1e-12, 1e-12)
        .dt(1e-3)
        .every(0.5)
        .t_end(5.0)
}

/// A switch turns the push off at the event: the sleigh goes straight
/// (the force is along its skate, through its centre of mass, so the
/// skate holds it with no lateral force) with `x = F t^2 / (2 m)` until
/// `x = L` at `t* = sqrt(2 m L / F) = 2.828 s`, then coasts at
/// `v* = F t* / m`: `x(t_end) = L + v* (t_end - t*)`, and the push's work
/// is `F L`. Each method and its continuous extension are exact on a
/// quadratic and a line (RADAU5's collocation polynomial is cubic), so
/// the event's time, the final position and the work hold to rounding
/// (1e-12), on the DAE and on the reduced formulation (which restarts at
/// the switch as the DAE does); a switch taken at the step's end instead
/// of the event is off by `F/m h (t_end - t*)`, 1e-3 m at `h` = 1e-3 s
/// (RK4) and more with the adaptive steps.
#[test]
fn a_switch_turns_an_effect_off_at_the_event_and_the_motion_follows_the_closed_form() {
    let (f, m, l, t_end): (f64, f64, f64, f64) = (0.5, 1.0, 2.0, 5.0);
    let t_star = (2.0 * m * l / f).sqrt();
    let v_star = f * t_star / m;
    for (method, formulation) in common::SWITCHING_RUNS {
        let solution = pushed_sleigh(method).formulation(formulation).solve();
        let method = format!("{method:?} {formulation:?}");
        let solution = solution.unwrap_or_else(|e| panic!("{method}: {e}"));
        assert_eq!(solution.summary.formulation, formulation, "{method}");
        let s = &solution.summary;
        assert_eq!(s.events.len(), 1, "{method}: {:?}", s.events);
        let (name, t_event) = (&s.events[0].name, s.events[0].t);
        assert!(name == "coast" && s.events[0].rising, "{method}: {:?}", s.events[0]);
        assert!((t_event - t_star).abs() <= 1e-12 * t_star, "{method}: {t_event} against {t_star}");
        let end = solution.final_state();
        let x = |name: &str| end[solution.names.iter().position(|n| n == name).unwrap()];
        let want = l + v_star * (t_end - t_star);
        assert!((x("x") - want).abs() <= 1e-12 * want, "{method}: x = {} against {want}", x("x"));
        assert!((x("xd") - v_star).abs() <= 1e-12 * v_star, "{method}: xd = {} against {v_star}", x("xd"));
        assert!(x("y").abs() <= 1e-12 && x("phi").abs() <= 1e-12, "{method}: y {} phi {}", x("y"), x("phi"));
        assert!((x("W_push") - f * l).abs() <= 1e-12, "{method}: W_push = {}", x("W_push"));
        // the samples before the event keep the push, those after coast
        let xd = solution.column("xd").unwrap();
        for (t, v) in solution.t.iter().zip(&xd) {
            let want = if *t <= t_star { f * t / m } else { v_star };
            assert!((v - want).abs() <= 1e-12, "{method}: xd({t}) = {v} against {want}");
        }
    }
}

/// A switch names effects the run has (not a skate's friction), each
/// once, under `action = "switch"`; a run leaves its effects as it found
/// them.
#[test]
fn switches_are_checked_and_undone_after_the_run() {
    let base = pushed_sleigh(Method::Dop853);
    let event = |spec: EventSpec| base.clone().event("e", &spec).map(|_| ()).unwrap_err().to_string();
    let text = event(EventSpec { action: Action::Switch, switch_on: vec!["pull".into()], ..EventSpec::new("x", 1.0) });
    assert!(
        text.contains("key `switch_on`") && text.contains("`pull` is no effect") && text.contains("push"),
        "{text}"
    );
    let text = event(EventSpec { switch_off: vec!["push".into()], ..EventSpec::new("x", 1.0) });
    assert!(text.contains("key `switch_off`") && text.contains("only `action = \"switch\"`"), "{text}");
    let text = event(EventSpec { action: Action::Switch, ..EventSpec::new("x", 1.0) });
    assert!(text.contains("key `action`") && text.contains("`switch_on`, `switch_off`"), "{text}");
    let both = vec!["push".to_string()];
    let text = event(EventSpec {
        action: Action::Switch,
        switch_on: both.clone(),
        switch_off: both,
        ..EventSpec::new("x", 1.0)
    });
    assert!(text.contains("switched on and off at once"), "{text}");
    // a library user's switch by index, checked before the first step
    let (mut sys, y0, _) = pushed_sleigh(Method::Dop853).into_system().unwrap();
    let settings = common::dop853(5.0, 0.5, 1e-12);
    sys.events[0] = sys.events[0].clone().switching(&[], &[7]);
    let err = ezy_core::simulate(&mut sys, &y0, &settings, &mut common::Recorder::default()).unwrap_err();
    assert!(err.to_string().contains("effect 7 does not exist"), "{err}");
    let push = sys.effect_index("push").unwrap();
    sys.events[0] = sys.events[0].clone().switching(&[], &[push]);
    ezy_core::simulate(&mut sys, &y0, &settings, &mut common::Recorder::default()).unwrap();
    assert!(sys.effects[push].on, "the run switched `push` off and left it so");
}

/// Names the run does not have are refused with the names it has.
#[test]
fn unknown_quantities_and_bad_levels_are_refused() {
    let err = sleigh().event("e", &EventSpec::new("x2", 1.0)).unwrap_err();
    let text = err.to_string();
    assert!(text.contains("event `e`, key `when`") && text.contains("`x2` is no quantity"), "{text}");
    assert!(text.contains("phid") && text.contains("P.vy"), "{text}");
    let err = sleigh().event("e", &EventSpec::new("x", f64::NAN)).unwrap_err();
    assert!(err.to_string().contains("key `crosses`"), "{err}");
    let err = sleigh().event("e", &EventSpec::new("x", 1.0)).unwrap().event("e", &EventSpec::new("y", 1.0));
    assert!(err.unwrap_err().to_string().contains("already given"));
}

/// The guide's scene `sleigh-events` (docs/book/src/events.md, the
/// ```toml block holding `name = "sleigh-events"`): the sleigh with three
/// events, the heading's crossing of 0.5 rad recorded, the yaw rate's
/// falls through 0.3 rad/s, and the centre's reaching x = 1.5 m ending
/// the run. Read from the guide, so the example a user copies is the one
/// tested.
fn guide_scene() -> String {
    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/book/src/events.md")).unwrap();
    let blocks = guide.split("```toml\n").skip(1).map(|b| b.split("```").next().unwrap());
    blocks.filter(|b| b.contains("name = \"sleigh-events\"")).map(str::to_string).next().expect("the guide's scene")
}

fn ezy(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_ezy")).args(args).output().expect("ezy runs")
}

/// `ezy run` writes `events.csv` (time, name, direction, state), lists
/// the events in its summary, and a stop event's state is the last row of
/// `trajectory.csv`; `ezy sweep` reads `event_time` and `event_count`
/// metrics; a scene naming a quantity the run lacks is refused at its line.
#[test]
fn the_command_line_writes_events_and_sweeps_read_them() {
    let dir = std::env::temp_dir().join(format!("ezy-events-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("sleigh-events.toml");
    let text = guide_scene();
    std::fs::write(&scene, &text).unwrap();
    let out = dir.join("run");
    let o = ezy(&["run", scene.to_str().unwrap(), "--no-figures", "--out", out.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("events (3): slow falling at t = "), "{stdout}");
    assert!(stdout.contains("stopped by the event far at t = "), "{stdout}");
    let events = std::fs::read_to_string(out.join("events.csv")).unwrap();
    let mut lines = events.lines();
    assert_eq!(lines.next(), Some("t,event,direction,x,y,phi,xd,yd,phid"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let names: Vec<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(names, ["slow", "half", "far"]);
    assert_eq!(rows[1][2], "rising");
    let t_half: f64 = rows[1][0].parse().unwrap();
    assert!((t_half - heading_time(0.5)).abs() < 1e-10, "{t_half}");
    // the stop: its row is the trajectory's last, number for number
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let last: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    assert_eq!(last[..7], [&[rows[2][0]], &rows[2][3..9]].concat()[..]);
    assert!((last[1].parse::<f64>().unwrap() - 1.5).abs() < 1e-12, "{last:?}");

    let sweep = dir.join("sweep");
    let o = ezy(&[
        "sweep",
        scene.to_str().unwrap(),
        "--list",
        "far.crosses=1.5,1.2",
        "--metric",
        "event_time(half)",
        "--metric",
        "event_count(slow)",
        "--jobs",
        "1",
        "--out",
        sweep.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = std::fs::read_to_string(sweep.join("sweep.csv")).unwrap();
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let row: Vec<&str> = table.lines().nth(1).unwrap().split(',').collect();
    let at = |c: &str| header.iter().position(|h| *h == c).unwrap();
    assert_eq!(row[at("event_time(half)")], rows[1][0]);
    assert_eq!(row[at("event_count(slow)")], "1.0");
    // the second run stopped where its level was set
    let second: Vec<&str> = table.lines().nth(2).unwrap().split(',').collect();
    assert!((second[at("x")].parse::<f64>().unwrap() - 1.2).abs() < 1e-12, "{second:?}");
    assert_eq!(second[at("event_time(half)")], rows[1][0]);
    // an event metric of an event the scene lacks: refused before any run
    let o = ezy(&["sweep", scene.to_str().unwrap(), "--list", "a=0.5", "--metric", "event_time(nope)"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("the scene has no event `nope`; its events: half, slow, far"));

    // a quantity the run lacks: the file, line and key
    std::fs::write(&scene, text.replace("when = \"x\"", "when = \"x9\"")).unwrap();
    let line = 1 + text.lines().position(|l| l == "when = \"x\"").unwrap();
    let o = ezy(&["run", scene.to_str().unwrap(), "--no-figures", "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains(&format!("sleigh-events.toml:{line}:")) && err.contains("events.far.when"), "{err}");
    assert!(err.contains("`x9` is no quantity of this run"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An event that switches a family effect switches each of its elements:
/// the `snake-slip` snake's serpenoid motors (`motor` over `J[*]`, four
/// hinge motors `motor2` .. `motor5`) switched off at `t = 1` s, by the
/// family's name, and its spring `spring3` alone. After the switch every
/// motor's work and the one spring's hold still (no force, no power) while
/// the other springs keep working.
#[test]
fn a_switch_of_a_family_effect_switches_each_element() {
    let mut scene = ezy_models::scenes::get("snake-slip");
    let rest = EventSpec {
        action: Action::Switch,
        switch_off: vec!["motor".into(), "spring3".into()],
        ..EventSpec::new("t", 1.0)
    };
    scene.events.push(("rest".into(), rest));
    let (p, _) = scene.problem::<ezy_models::Snake>(&[]).unwrap();
    let s = p.t_end(2.0).solve().unwrap();
    assert_eq!(s.summary.events.iter().filter(|e| e.name == "rest").count(), 1, "{:?}", s.summary.events);
    let after: Vec<usize> = (0..s.t.len()).filter(|&k| s.t[k] >= 1.0).collect();
    let moved = |name: &str| {
        let w = s.column(name).unwrap_or_else(|| panic!("no column {name}: {:?}", s.names));
        w[after[0]..].iter().any(|&v| v != w[after[0]])
    };
    for k in 2..=5 {
        assert!(!moved(&format!("W_motor{k}")), "motor{k} worked after the switch");
    }
    assert!(!moved("W_spring3"), "spring3 worked after the switch");
    assert!(moved("W_spring2") && moved("W_spring4"), "the other springs stopped too");
}

ezy::model! {
    /// A user's own cart, written in the test (not a built-in): one body
    /// on a skate at its centre of mass, along its x axis.
    pub struct OwnCart {
        /// Mass [kg]
        param m = 2.0;
        /// Moment of inertia about the centre of mass [kg m^2]
        param I = 0.1;

        body c(x, y, phi) { mass: m, inertia: I }
        point P on c at (0, 0);
        skate P: P along (1, 0);
    }
}

/// The user's cart from `xd = 0.5` m/s, pushed by `push` (0.5 N along x)
/// and, from the start, not braked (`brake`, -1 N, switched off at
/// 1e-9 s); `fast` turns the push off and the brake on where `xd` rises
/// through 1 m/s (at `t* = (1 - 0.5) m / 0.5 = 2` s), and `slow`, when
/// given, turns them back where `xd` falls through `slow_at`.
fn cruise(method: Method, formulation: Formulation, slow_at: Option<f64>) -> Problem<OwnCart> {
    let force = |fx: f64| {
        EffectSpec::Force(ezy_core::effects::Force {
            at: "c".into(),
            fx: Waveform::Constant(fx),
            fy: Waveform::Constant(0.0),
            frame: Frame::World,
        })
    };
    let switch = |when: &str, level: f64, direction: Direction, on: &str, off: &str| EventSpec {
        action: Action::Switch,
        direction,
        switch_on: vec![on.into()],
        switch_off: vec![off.into()],
        ..EventSpec::new(when, level)
    };
    let start = EventSpec { action: Action::Switch, switch_off: vec!["brake".into()], ..EventSpec::new("t", 1e-9) };
    let mut p = Problem::new(OwnCart::default())
        .effect("push", force(0.5))
        .and_then(|p| p.effect("brake", force(-1.0)))
        .and_then(|p| p.event("start", &start))
        .and_then(|p| p.event("fast", &switch("xd", 1.0, Direction::Rising, "brake", "push")))
        .and_then(|p| p.q("x", 0.0))
        .and_then(|p| p.q("y", 0.0))
        .and_then(|p| p.q("phi", 0.0))
        .and_then(|p| p.qd("x", 0.5))
        .and_then(|p| p.qd("phi", 0.0))
        .unwrap();
    if let Some(level) = slow_at {
        p = p.event("slow", &switch("xd", level, Direction::Falling, "push", "brake")).unwrap();
    }
    p.method(method).formulation(formulation).tolerances(1e-10, 1e-10).dt(1e-3).every(0.1).t_end(3.0)
}

/// A switch whose quantity the new forces send back across the level at
/// once, where another switch turns the forces back (a sliding mode: the
/// brake above 1 m/s, the push below), is refused by every method at the
/// first switch, naming both. Before, every method recorded `fast` only
/// and went on braking below 1 m/s with the push off, exit 0 (earlier,
/// RK4 and RADAU5 stopped with "chatters" while DOPRI5 and DOP853 went
/// on). The same switches with levels apart (`slow` at 0.9 m/s) run,
/// and the brake alone (no `slow`) brakes the cart from 1 m/s at
/// `t* = 2` s to `1 - (3 - 2) / 2 = 0.5` m/s.
#[test]
fn a_sliding_mode_is_refused_by_every_method() {
    for (method, formulation) in common::SWITCHING_RUNS {
        let run = format!("{method:?} {formulation:?}");
        match cruise(method, formulation, Some(1.0)).solve() {
            Err(SimError::SlidingMode { event, undo, t }) => {
                assert!(event == "fast" && undo == "slow", "{run}: {event} {undo}");
                assert!((t - 2.0).abs() <= 1e-8, "{run}: at {t}");
            }
            other => panic!("{run}: {:?}", other.map(|s| s.summary.events)),
        }
        let s = cruise(method, formulation, Some(0.9)).solve().unwrap_or_else(|e| panic!("{run}: {e}"));
        let names: Vec<&str> = s.summary.events.iter().map(|e| e.name.as_str()).collect();
        assert!(
            names.len() >= 4 && names[1..].chunks(2).all(|p| p[0] == "fast" && p.get(1).is_none_or(|&n| n == "slow")),
            "{run}: {names:?}"
        );
        let s = cruise(method, formulation, None).solve().unwrap_or_else(|e| panic!("{run}: {e}"));
        let xd = *s.column("xd").unwrap().last().unwrap();
        assert!((xd - 0.5).abs() <= 1e-8, "{run}: xd(3) = {xd}");
    }
}

/// A recorded event on a quantity that jumps at a switch (the push's
/// force `F_push`, 0.5 N, read 0 once the push is switched off) fires at
/// the switch itself, taken on both sides of it: at the coast's time to
/// the last bit, for every method. An event on a skate's friction force,
/// which the skate's mode sets (not the state), is refused by name.
#[test]
fn events_on_a_quantity_that_jumps_at_a_switch_fire_there() {
    let half = EventSpec { direction: Direction::Falling, ..EventSpec::new("F_push", 0.25) };
    for (method, formulation) in common::SWITCHING_RUNS {
        let run = format!("{method:?} {formulation:?}");
        let s = pushed_sleigh(method).formulation(formulation).event("half", &half).unwrap().solve();
        let s = s.unwrap_or_else(|e| panic!("{run}: {e}"));
        let ev = &s.summary.events;
        assert!(ev.len() == 2 && ev[0].name == "coast" && ev[1].name == "half" && !ev[1].rising, "{run}: {ev:?}");
        assert_eq!(ev[1].t, ev[0].t, "{run}");
    }
    let friction = EffectSpec::SkateFriction(ezy_core::effects::SkateFriction {
        skate: "P".into(),
        mu: 0.1,
        normal: None,
        share: Some(1.0),
        g: ezy_core::effects::STANDARD_GRAVITY,
    });
    let p = cruise(Method::Dop853, Formulation::Dae, None).effect("slip_P", friction).unwrap();
    let e = p.event("grip", &EventSpec::new("F_slip_P", 0.5)).map(|_| ()).unwrap_err().to_string();
    assert!(
        e.contains("event `grip`, key `when`") && e.contains("`F_slip_P` is the friction force of effect `slip_P`"),
        "{e}"
    );
}
