//! The geometry of locomotion (`ezy_core::geometry`, `ezy geometry`): the
//! kinematic snake's connection against an independent solve of its
//! skates, the curvature's prediction against simulated gaits (error
//! like eps^3), its singular set, the sleigh's and the EzyRoller's
//! momentum against their reduced equations and the reconstruction
//! against simulation, a user's model read from text, and the refusals.

use ezy_core::geometry::{Gait, Geometry};
use ezy_core::problem::Problem;
use ezy_core::text::RuntimeModel;
use ezy_core::{AnyModel, Model};
use ezy_models::{ChaplyginSleigh, EzyRollerDriven, FourBar, KinematicSnake, Snake};

use crate::analysis::{ezy, fresh, table};

/// The kinematic snake's body velocity `xi` (middle link's frame) for
/// shape rates `rd` at shape `r`, links of length `l`, written out from
/// the three skates here (and only here): the rear link's middle at
/// `(-l/2 - l/2 cos a1, l/2 sin a1)` turning at `-a1'` about the hinge
/// `(-l/2, 0)`, the front's at `(l/2 + l/2 cos a2, l/2 sin a2)` turning
/// at `a2'` about `(l/2, 0)`; each middle's velocity has no component
/// along its link's normal. Solved by Cramer's rule.
fn snake_xi(l: f64, r: [f64; 2], rd: [f64; 2]) -> [f64; 3] {
    let (a1, a2) = (r[0], r[1]);
    let j = |p: [f64; 2]| [-p[1], p[0]];
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    let c1 = [-l / 2.0 - l / 2.0 * a1.cos(), l / 2.0 * a1.sin()];
    let c3 = [l / 2.0 + l / 2.0 * a2.cos(), l / 2.0 * a2.sin()];
    let (n1, n3) = ([a1.sin(), a1.cos()], [-a2.sin(), a2.cos()]);
    // n . ((u, v) + w J c) = -n . (shape part)
    let row = |n: [f64; 2], c: [f64; 2]| [n[0], n[1], dot(n, j(c))];
    let m = [row(n1, c1), [0.0, 1.0, 0.0], row(n3, c3)];
    let b = [rd[0] * dot(n1, j([c1[0] + l / 2.0, c1[1]])), 0.0, -rd[1] * dot(n3, j([c3[0] - l / 2.0, c3[1]]))];
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    std::array::from_fn(|c| {
        let mut mc = m;
        (0..3).for_each(|i| mc[i][c] = b[i]);
        det(mc) / d
    })
}

/// `A(r)` of the kinematic snake against [`snake_xi`] at shapes away from
/// the singular set `alpha1 = alpha2`, with Hatton & Choset's sign
/// convention `xi = -A r'`: agreement to 1e-12 (measured 1.1e-16).
#[test]
fn the_kinematic_snakes_connection_is_its_skates_solved() {
    for l in [1.0, 0.6] {
        let g = Geometry::new(KinematicSnake { l, ..Default::default() }, None, None).unwrap();
        assert_eq!(
            (g.body_name(), g.shape_names(), g.n_momentum()),
            ("middle", vec!["alpha1".into(), "alpha2".into()], 0)
        );
        let mut worst = 0.0f64;
        for r in [[0.5, -0.3], [1.0, 0.2], [-0.7, 0.9], [0.1, -1.2], [2.0, -2.0], [-1.5, 0.4]] {
            let c = g.connection(&r).unwrap();
            for k in 0..2 {
                let xi = snake_xi(l, r, std::array::from_fn(|i| if i == k { 1.0 } else { 0.0 }));
                for (comp, x) in xi.iter().enumerate() {
                    worst = worst.max((-c.a[comp * 2 + k] - x).abs());
                }
            }
        }
        assert!(worst < 1e-12, "l = {l}: {worst:e}");
    }
}

/// A circular gait of radius `eps` around `(0.6, -0.4)`: the simulated
/// net motion (the full equations, the drives prescribing the shape)
/// minus the curvature's prediction shrinks like eps^3 (slope fitted on
/// eps = 0.02..0.2: 2.97 measured), the first order's like eps^2, and
/// the reconstruction matches the simulation to the run's tolerance.
#[test]
fn the_curvature_predicts_small_gaits_to_third_order() {
    let mut g = Geometry::new(KinematicSnake::default(), None, None).unwrap();
    let (mut second, mut first) = (Vec::new(), Vec::new());
    let epsilons = [0.2, 0.1, 0.05, 0.035, 0.02];
    for eps in epsilons {
        let gait = Gait::parse(&g.shape_names(), &format!("alpha1=0.6+{eps}*cos(t),alpha2=-0.4+{eps}*sin(t)")).unwrap();
        let p = g.predict(&gait, &[]).unwrap();
        let sim = g.simulate(&gait, Problem::new(KinematicSnake::default()), &[], 1e-11).unwrap();
        let err = |v: [f64; 3]| (0..3).map(|i| (sim.net[i] - v[i]).abs()).fold(0.0, f64::max);
        second.push(err(p.second.unwrap()));
        first.push(err(p.first));
        assert!(err(p.reconstructed) < 1e-9, "eps {eps}: reconstructed {:e}", err(p.reconstructed));
        // a small gait moves the frame by D(-A) times the area, to leading order
        let h = g.curvature(&[0.6, -0.4]).unwrap().height[0];
        let area = std::f64::consts::PI * eps * eps;
        assert!((sim.net[0] - h[0] * area).abs() < 2.0 * eps.powi(3), "eps {eps}");
    }
    let slope = |e: &[f64]| {
        let (x, y): (Vec<f64>, Vec<f64>) = epsilons.iter().zip(e).map(|(a, b)| (a.ln(), b.ln())).unzip();
        let (mx, my) = (x.iter().sum::<f64>() / 5.0, y.iter().sum::<f64>() / 5.0);
        x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum::<f64>()
            / x.iter().map(|a| (a - mx).powi(2)).sum::<f64>()
    };
    let (s2, s1) = (slope(&second), slope(&first));
    eprintln!("second order: errors {second:?}, slope {s2}; first order: slope {s1}");
    assert!((2.8..3.3).contains(&s2), "{s2}");
    assert!((1.8..2.3).contains(&s1), "{s1}");
}

/// The singular set: where `alpha1 = alpha2` the three skates' normal
/// lines meet in one point (the links lie on a circle about it) and the
/// skates cannot fix the body velocity; off it they do not meet. A gait
/// that crosses the set is refused, naming where.
#[test]
fn the_kinematic_snakes_singular_set_is_where_its_normals_meet() {
    let g = Geometry::new(KinematicSnake::default(), None, None).unwrap();
    let info = g.info().clone();
    let point = |name: &str| info.points.iter().position(|p| p.name == name).unwrap();
    // how far the normal line of skate 3 passes from the meeting point of
    // those of skates 1 and 2 [m], at the configuration of shape r
    let miss = |r: [f64; 2]| {
        let q = g.configuration(&r).unwrap();
        let mut pts = vec![0.0; 2 * info.points.len()];
        g.model().points(&q, &mut pts);
        let line = |name: &str, heading: f64| {
            let p = point(name);
            ([pts[2 * p], pts[2 * p + 1]], [-heading.sin(), heading.cos()])
        };
        let (p1, n1) = line("S1", q[2]);
        let (p2, n2) = line("S2", q[5]);
        let (p3, n3) = line("S3", q[8]);
        // p1 + s n1 = p2 + t n2
        let det = n1[0] * (-n2[1]) + n2[0] * n1[1];
        let s = ((p2[0] - p1[0]) * (-n2[1]) + n2[0] * (p2[1] - p1[1])) / det;
        let x = [p1[0] + s * n1[0], p1[1] + s * n1[1]];
        ((x[0] - p3[0]) * n3[1] - (x[1] - p3[1]) * n3[0]).abs()
    };
    for a in [0.3, 0.9, -1.4, 2.2] {
        assert!(miss([a, a]) < 1e-12, "{a}: {}", miss([a, a]));
        assert!(g.rank_margin(&[a, a]).unwrap() < 1e-12);
        let e = g.connection(&[a, a]).unwrap_err().to_string();
        assert!(e.contains("lose rank"), "{e}");
        for off in [0.2, -0.5] {
            assert!(miss([a, a + off]) > 1e-3 && g.rank_margin(&[a, a + off]).unwrap() > 1e-3, "{a} {off}");
        }
    }
    let mut g = g;
    let gait = Gait::parse(&g.shape_names(), "alpha1=0.7+cos(t),alpha2=-0.7+sin(t)").unwrap();
    let e = g.predict(&gait, &[]).unwrap_err().to_string();
    assert!(e.contains("meets the singular set at t = 2.214"), "{e}");
}

/// The Chaplygin sleigh (no shape, two momenta): `p_u = m u` and `p_w =
/// (I + m a^2) w`, and the momentum equation is the reduced equations
/// `m u' = m a w^2`, `(I + m a^2) w' = -m a u w` (Bloch 2003, §1.7), at
/// random states; the reconstruction over 5 s matches the simulation.
#[test]
fn the_sleighs_momentum_equation_is_its_reduced_equations() {
    let (m, i, a) = (1.0, 0.1, 0.5);
    let mut g = Geometry::new(ChaplyginSleigh::default(), None, None).unwrap();
    assert_eq!(g.momentum_names(), vec!["p_u".to_string(), "p_w".into()]);
    let mut seed = 7u64;
    let mut rand = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    for _ in 0..20 {
        let (u, w, phi, x, y) = (2.0 * rand(), 3.0 * rand(), 3.0 * rand(), rand(), rand());
        let (s, c) = phi.sin_cos();
        let v = a * w;
        let q = [x, y, phi];
        let qd = [c * u - s * v, s * u + c * v, w];
        let p = g.momentum(&q, &qd).unwrap();
        let pd = g.momentum_rate(0.0, &q, &qd).unwrap();
        let want = [m * u, (i + m * a * a) * w];
        let want_d = [m * a * w * w, -m * a * u * w];
        for k in 0..2 {
            assert!((p[k] - want[k]).abs() < 1e-13 && (pd[k] - want_d[k]).abs() < 1e-12, "{p:?} {pd:?}");
        }
        let xi = g.reconstructed_velocity(&q, &qd).unwrap();
        assert!((xi[0] - u).abs() < 1e-13 && (xi[1] - v).abs() < 1e-13 && (xi[2] - w).abs() < 1e-13);
    }
    let gait = Gait::new(Vec::new(), 5.0).unwrap();
    let p = g.predict(&gait, &[1.0, 0.2]).unwrap();
    let sim = g.simulate(&gait, Problem::new(ChaplyginSleigh::default()), &[1.0, 0.2], 1e-12).unwrap();
    let gap = (0..3).map(|k| (p.reconstructed[k] - sim.net[k]).abs()).fold(0.0, f64::max);
    assert!(gap < 1e-9 && (p.momentum.1[0] - sim.momentum[0]).abs() < 1e-9, "{gap:e} {p:?}");
}

/// The EzyRoller with its fork swung by the drive: `p_u` against the
/// forward momentum written out here from its geometry (the locked
/// motion with forward speed 1 that both skates allow: yaw rate `k =
/// -sin(alpha) / (cos(alpha) (a + C_x) - sin(alpha) C_y)`, `C` the front
/// skate in body 1's frame) at states of a run, `p'` from the momentum
/// equation against the run's `dp/dt` (fourth-order central differences), and one
/// cycle of reconstruction against the simulation.
#[test]
fn the_ezyrollers_momentum_and_reconstruction_match_its_run() {
    let model = EzyRollerDriven::default();
    let (a, b, c, d) = (model.a, model.b, model.c, model.d);
    let (m1, i1, m2, i2) = (model.m1, model.I1, model.m2, model.I2);
    let mut g = Geometry::new(model.clone(), None, None).unwrap();
    assert_eq!(
        (g.body_name(), g.shape_names(), g.momentum_names()),
        ("body1", vec!["B".to_string()], vec!["p_u".to_string()])
    );
    let angle = ezy_core::effects::Waveform::Harmonics(vec![
        ezy_core::effects::Harmonic { amplitude: -std::f64::consts::PI, omega: 0.0, phase: 0.0, phase_step: 0.0 },
        ezy_core::effects::Harmonic { amplitude: 0.3, omega: std::f64::consts::PI, phase: -1.0, phase_step: 0.0 },
    ]);
    let gait = Gait::new(vec![angle.clone()], 2.0).unwrap();
    let sol = Problem::new(model.clone())
        .drive("D", angle)
        .unwrap()
        .q("x1", 0.0)
        .unwrap()
        .q("y1", 0.0)
        .unwrap()
        .q("phi1", 0.0)
        .unwrap()
        .qd("x1", 0.4)
        .unwrap()
        .t_end(4.0)
        .every(1e-3)
        .method(ezy_core::Method::Dop853)
        .tolerances(1e-12, 1e-12)
        .solve()
        .unwrap();
    let hand = |y: &[f64]| {
        let [x1, y1, p1, x2, y2, p2] = [y[0], y[1], y[2], y[3], y[4], y[5]];
        let [x1d, y1d, p1d, x2d, y2d, p2d] = [y[6], y[7], y[8], y[9], y[10], y[11]];
        let alpha = p1 - p2;
        let (s, co) = alpha.sin_cos();
        let rot = |vx: f64, vy: f64| [p1.cos() * vx + p1.sin() * vy, -p1.sin() * vx + p1.cos() * vy];
        // body 2's centre and front skate in body 1's frame
        let p2c = [b + d * co, -d * s];
        let cc = [b + (c + d) * co, -(c + d) * s];
        let k = -s / (co * (a + cc[0]) - s * cc[1]);
        let v1 = rot(x1d, y1d);
        let v2 = rot(x2d, y2d);
        let _ = (x1, y1, x2, y2);
        m1 * (v1[0] + a * k * v1[1])
            + i1 * k * p1d
            + m2 * (v2[0] * (1.0 - k * p2c[1]) + v2[1] * (a * k + k * p2c[0]))
            + i2 * k * p2d
    };
    let mut worst = (0.0f64, 0.0f64);
    for n in (100..3900).step_by(370) {
        let y = &sol.y[n];
        let p = g.momentum(&y[..6], &y[6..12]).unwrap();
        let scale = 1.0 + p[0].abs();
        worst.0 = worst.0.max((p[0] - hand(y)).abs() / scale);
        let pd = g.momentum_rate(sol.t[n], &y[..6], &y[6..12]).unwrap();
        // fourth-order central differences on the 1 ms samples
        let h = sol.t[n + 1] - sol.t[n];
        let fd = (-hand(&sol.y[n + 2]) + 8.0 * hand(&sol.y[n + 1]) - 8.0 * hand(&sol.y[n - 1]) + hand(&sol.y[n - 2]))
            / (12.0 * h);
        worst.1 = worst.1.max((pd[0] - fd).abs() / (1.0 + pd[0].abs()));
    }
    eprintln!("EzyRoller p against the hand formula: {:e}; p' against the run's differences: {:e}", worst.0, worst.1);
    // differences of step h = 1e-3 s: truncation about h^4 p^(5) / 30
    // (5e-11), the run's local errors (tolerance 1e-12) over h about 1e-9
    // at most (measured 6.3e-10)
    assert!(worst.0 < 1e-12 && worst.1 < 3e-9, "{worst:?}");
    let p0 = g.momentum(&sol.y[0][..6], &sol.y[0][6..12]).unwrap();
    let pred = g.predict(&gait, &p0).unwrap();
    let sim = g.simulate(&gait, Problem::new(model), &p0, 1e-12).unwrap();
    let gap = (0..3).map(|k| (pred.reconstructed[k] - sim.net[k]).abs()).fold(0.0, f64::max);
    assert!(gap < 1e-9 && (pred.momentum.1[0] - sim.momentum[0]).abs() < 1e-8, "{gap:e} {pred:?} {sim:?}");
}

/// The kinematic snake written by a user as model text: the same
/// connection as the built-in at `--set l=0.8`, from the library and from
/// `ezy geometry FILE.ezy`.
#[test]
fn a_users_model_read_from_text_works_as_a_built_in() {
    let text = r"
pub struct MySnake {
    param l = 0.8;
    body rear(x1, y1, phi1) { mass: 1.0, inertia: 0.05 }
    body middle(x2, y2, phi2) { mass: 1.0, inertia: 0.05 }
    body front(x3, y3, phi3) { mass: 1.0, inertia: 0.05 }
    point S1 on rear at (0, 0);
    point R on rear at (l / 2, 0);
    point M0 on middle at (-l / 2, 0);
    point S2 on middle at (0, 0);
    point M1 on middle at (l / 2, 0);
    point F on front at (-l / 2, 0);
    point S3 on front at (0, 0);
    hinge a1: M0 = R;
    hinge a2: F = M1;
    drive D1: hinge a1;
    drive D2: hinge a2;
    skate S1: S1 along (1, 0);
    skate S2: S2 along (1, 0);
    skate S3: S3 along (1, 0);
}
";
    let user = AnyModel::new(RuntimeModel::from_text(text).unwrap());
    let mine = Geometry::new(user.clone(), Some("middle"), None).unwrap();
    let built = Geometry::new(KinematicSnake { l: 0.8, ..Default::default() }, None, None).unwrap();
    for r in [[0.4, -0.6], [-1.0, 0.3]] {
        let (x, y) = (mine.curvature(&r).unwrap(), built.curvature(&r).unwrap());
        let gap = x.connection.a.iter().zip(&y.connection.a).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        let gap_h = (0..3).map(|k| (x.height[0][k] - y.height[0][k]).abs()).fold(0.0, f64::max);
        assert!(gap < 1e-13 && gap_h < 1e-12, "{gap:e} {gap_h:e}");
    }
    let dir = fresh("geometry-user");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("my_snake.ezy");
    std::fs::write(&file, text).unwrap();
    let (out, err, ok) = ezy(
        &[
            "geometry",
            file.to_str().unwrap(),
            "--grid",
            "9",
            "--gait",
            "a1=0.9+0.3*cos(t),a2=-0.9+0.3*sin(t)",
            "--no-figures",
        ],
        &dir.join("out"),
    );
    assert!(ok, "{out}{err}");
    let (head, rows) = table(&dir.join("out/gait.csv"));
    assert_eq!(head, ["method", "dx", "dy", "dtheta"]);
    let col = |label: &str| rows.iter().find(|r| r[0] == label).map(|r| r[1].parse::<f64>().unwrap()).unwrap();
    assert!((col("reconstructed") - col("simulated")).abs() < 1e-8, "{out}");
    assert!(out.contains("position = frame of body `middle`, shape = (a1, a2)"), "{out}");
}

/// What has no split into position and shape is refused by name: a
/// mechanism on the ground, a snake whose skates hold its shape rates,
/// a shape list that is not every hinge; and from the command line bad
/// grids, shapes and gaits before any work.
#[test]
fn what_has_no_geometry_is_refused_naming_why() {
    let e = Geometry::new(FourBar::default(), None, None).unwrap_err().to_string();
    assert!(e.contains("fixes body") && e.contains("no symmetry"), "{e}");
    let e = Geometry::new(Snake::default(), None, None).unwrap_err().to_string();
    assert!(e.contains("hold the shape velocities themselves"), "{e}");
    let e = Geometry::new(KinematicSnake::default(), None, Some(&["alpha1".into()])).unwrap_err().to_string();
    assert!(e.contains("hinge `alpha2` is not among the shape coordinates"), "{e}");
    let e = Geometry::new(KinematicSnake::default(), Some("tail"), None).unwrap_err().to_string();
    assert!(e.contains("no body of that name (its bodies: rear, middle, front)"), "{e}");
    let dir = fresh("geometry-refusals");
    for (args, says) in [
        (&["geometry", "four-bar"][..], "no symmetry under the plane's motions"),
        (&["geometry", "--grid", "1"], "--grid 1: from 2 to 501"),
        (&["geometry", "--range", "1:nan"], "--range `1:nan`"),
        (&["geometry", "--at", "alpha1=nan,alpha2=0"], "alpha1 = NaN: a finite number"),
        (&["geometry", "--at", "alpha1=1e300,alpha2=0"], "at most 1e6"),
        (&["geometry", "--at", "alpha1=0.3"], "`alpha2` is not given"),
        (&["geometry", "--gait", "alpha1=cos(t)*sin(t),alpha2=0"], "product"),
        (&["geometry", "--rtol", "0"], "--rtol 0"),
        (&["geometry", "snake"], "hold the shape velocities"),
    ] {
        let (out, err, ok) = ezy(args, &dir);
        assert!(!ok && err.contains(says), "{args:?}: {out}{err}");
        assert!(!dir.exists(), "{args:?} wrote {}", dir.display());
    }
}

/// `ezy geometry` on the built-in scenes it claims: the kinematic snake
/// (connection and curvature on the grid, its scene's gait predicted and
/// simulated, every figure), the EzyRoller with its fork prescribed (a
/// mixed system: the momentum equation's coefficients, the scene's gait
/// from its own initial momentum), and the sleigh (no shape).
#[test]
fn geometry_writes_the_tables_and_figures_of_the_built_in_scenes() {
    let dir = fresh("geometry-scenes");
    let (out, err, ok) = ezy(&["geometry", "--grid", "21"], &dir.join("snake"));
    assert!(ok, "{out}{err}");
    for f in [
        "connection.csv",
        "curvature.csv",
        "gait.csv",
        "gait-path.csv",
        "curvature_x.png",
        "connection_theta.png",
        "gait.png",
    ] {
        assert!(dir.join("snake").join(f).exists(), "{f}: {out}");
    }
    let (head, rows) = table(&dir.join("snake/curvature.csv"));
    assert_eq!(head, ["alpha1", "alpha2", "DA_x_alpha1_alpha2", "DA_y_alpha1_alpha2", "DA_theta_alpha1_alpha2"]);
    // 21 x 21, less the 21 points on alpha1 = alpha2
    assert_eq!(rows.len(), 21 * 21 - 21);
    let (_, gait) = table(&dir.join("snake/gait.csv"));
    let row = |label: &str| -> Vec<f64> {
        gait.iter().find(|r| r[0] == label).unwrap()[1..4].iter().map(|v| v.parse().unwrap()).collect()
    };
    let (rec, sim) = (row("reconstructed"), row("simulated"));
    assert!((0..3).all(|k| (rec[k] - sim[k]).abs() < 1e-8), "{rec:?} {sim:?}");
    assert!((rec[0] - 0.566436).abs() < 1e-6 && (rec[1] + 0.128569).abs() < 1e-6, "{rec:?}");

    let (out, err, ok) =
        ezy(&["geometry", "drive-prescribed", "--range=-3.6:-2.6", "--grid", "11"], &dir.join("roller"));
    assert!(ok, "{out}{err}");
    assert!(out.contains("mixed: 1 momentum component(s) p_u"), "{out}");
    let (head, rows) = table(&dir.join("roller/momentum.csv"));
    assert_eq!(head, ["B", "p_u:Bd*Bd", "p_u:Bd*p_u", "p_u:p_u*p_u"]);
    assert_eq!(rows.len(), 11);
    let (_, gait) = table(&dir.join("roller/gait.csv"));
    let get = |label: &str, k: usize| gait.iter().find(|r| r[0] == label).unwrap()[k].parse::<f64>().unwrap();
    for k in 1..5 {
        assert!((get("reconstructed", k) - get("simulated", k)).abs() < 1e-7, "{k}: {gait:?}");
    }
    assert!(dir.join("roller/momentum.png").exists() && dir.join("roller/connection.png").exists());

    let (out, err, ok) = ezy(&["geometry", "sleigh", "--no-figures"], &dir.join("sleigh"));
    assert!(ok, "{out}{err}");
    assert!(out.contains("shape = (none); mixed: 2 momentum component(s) p_u, p_w"), "{out}");
}

/// A scene's `[params]` reach the geometry (the model at the scene's
/// parameters, not its defaults), and a stop hook ends a prediction and a
/// simulation at once.
#[test]
fn a_scenes_parameters_reach_the_geometry_and_a_stop_ends_it() {
    let dir = fresh("geometry-params");
    std::fs::create_dir_all(&dir).unwrap();
    let text = ezy_models::scenes::BUILTIN.iter().find(|(f, _)| *f == "kinematic-snake.toml").unwrap().1;
    let scene = text.replace("[initial]", "[params]\nl = 0.7\n\n[initial]");
    std::fs::write(dir.join("short.toml"), scene).unwrap();
    let (out, err, ok) = ezy(
        &["geometry", dir.join("short.toml").to_str().unwrap(), "--at", "alpha1=0.4,alpha2=-0.6"],
        &dir.join("out"),
    );
    assert!(ok, "{out}{err}");
    let (head, rows) = table(&dir.join("out/connection.csv"));
    let a = Geometry::new(KinematicSnake { l: 0.7, ..Default::default() }, None, None)
        .unwrap()
        .connection(&[0.4, -0.6])
        .unwrap()
        .a;
    let k = head.iter().position(|h| h == "A_u_alpha1").unwrap();
    assert!((rows[0][k].parse::<f64>().unwrap() - a[0]).abs() < 1e-15, "{out}");
    let mut g = Geometry::new(KinematicSnake::default(), None, None).unwrap();
    g.stop_when(|| true);
    let gait = Gait::parse(&g.shape_names(), "alpha1=0.9+0.3*cos(t),alpha2=-0.9+0.3*sin(t)").unwrap();
    assert!(matches!(g.predict(&gait, &[]), Err(ezy_core::geometry::GeometryError::Stopped)));
    let run = g.simulate(&gait, Problem::new(KinematicSnake::default()), &[], 1e-10);
    assert!(matches!(run, Err(ezy_core::geometry::GeometryError::Stopped)), "{run:?}");
}

/// Gait optimization (`ezy_core::design::gait`) on the built-in kinematic
/// snake: the circle of radius 0.6 whose centre maximizes the
/// second-order lateral motion `dy` is the one ezy-core's own test finds
/// on its copy of the model (and a dense scan of `predict` confirms
/// there), (1.056717, -1.056717), converged with the KKT conditions
/// holding; `predict`'s second order at the optimum is its objective.
#[test]
fn a_circles_best_centre_on_the_built_in_snake() {
    use ezy_core::design::gait::{FourierGait, GaitObjective, GaitOptimization, Measure, Order, optimize_gait};
    let mut g = Geometry::new(KinematicSnake::default(), None, None).unwrap();
    let circle = FourierGait::circle([0.7, -0.6], 0.6, 0.0, 2.0 * std::f64::consts::PI).unwrap();
    let goal = GaitObjective { measure: Measure::Along([0.0, 1.0]), per_cost: false, order: Order::Second };
    let opt = optimize_gait(&g, &GaitOptimization::new(circle, goal).centre_only()).unwrap();
    assert!(opt.converged && opt.kkt.holds, "{}", opt.termination);
    assert!((opt.values[0] - 1.056717).abs() < 1e-5 && (opt.values[1] + 1.056717).abs() < 1e-5, "{:?}", opt.values);
    let p = g.predict(&opt.gait.gait().unwrap(), &[]).unwrap();
    assert!((p.second.unwrap()[1] - opt.objective).abs() < 1e-12, "{p:?} {}", opt.objective);
}
