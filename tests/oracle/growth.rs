//! A motion's growth without bound (`ezy analyze` on a driven scene
//! without a loss: the verdict printed and `growth.csv`) against a plain
//! run (`ezy run`) of the same scene sampled at the same period ends, and
//! least squares of its logarithms written here: the kinetic energy's
//! and the speed's exponents, standard errors and residuals, each
//! window's, and the samples at the window's ends.

use crate::analysis::{ezy, fresh, table};

/// A power law's fit `(exponent, standard error, RMS residual)` of
/// `ln y` against `ln t`, by the normal equations of the straight line
/// (sums of products, not the library's centred sums).
fn least_squares(t: &[f64], y: &[f64]) -> (f64, f64, f64) {
    let n = t.len() as f64;
    let (x, z): (Vec<f64>, Vec<f64>) = t.iter().zip(y).map(|(t, y)| (t.ln(), y.ln())).unzip();
    let (sx, sz) = (x.iter().sum::<f64>(), z.iter().sum::<f64>());
    let sxx: f64 = x.iter().map(|x| x * x).sum();
    let sxz: f64 = x.iter().zip(&z).map(|(x, z)| x * z).sum();
    let det = n * sxx - sx * sx;
    let slope = (n * sxz - sx * sz) / det;
    let intercept = (sxx * sz - sx * sxz) / det;
    let ssr: f64 = x.iter().zip(&z).map(|(x, z)| (z - intercept - slope * x).powi(2)).sum();
    // var(slope) = s^2 n / det, det = n sum (x - mean)^2
    (slope, (ssr / (n - 2.0) * n / det).sqrt(), (ssr / n).sqrt())
}

/// What a scene's oracle needs: the scene, its reference body's velocity
/// columns, the run's extra arguments.
struct Case {
    scene: String,
    vx: &'static str,
    vy: &'static str,
    run: Vec<&'static str>,
}

/// The numbers after each `key` in `text`, in order (up to a space,
/// comma, parenthesis or semicolon).
fn numbers_after(text: &str, key: &str) -> Vec<f64> {
    text.split(key)
        .skip(1)
        .map(|rest| {
            let end = rest.find([' ', ',', ')', ';']).unwrap_or(rest.len());
            rest[..end].parse().unwrap_or_else(|e| panic!("`{}` after `{key}`: {e}", &rest[..end]))
        })
        .collect()
}

/// `ezy analyze` (with `extra`) on the case's scene against its run:
/// every number of growth.csv and of the printed verdict. Returns the
/// whole window's energy and speed exponents.
fn check(case: &Case, tag: &str, extra: &[&str], slack: f64) -> (f64, f64) {
    let dir = fresh(&format!("growth-oracle-{tag}"));
    let mut args = vec!["analyze", case.scene.as_str(), "--no-figures"];
    args.extend(extra);
    let (out, err, ok) = ezy(&args, &dir);
    assert!(ok, "{out}{err}");
    assert!(!out.contains("NaN") && !out.contains("inf"), "{out}");
    let (head, rows) = table(&dir.join("growth.csv"));
    let col = |row: usize, name: &str| -> f64 {
        let k = head.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {head:?}"));
        rows[row][k].parse().unwrap()
    };
    assert_eq!(rows.len(), 3, "{rows:?}");
    assert_eq!(
        rows.iter().map(|r| r[0].as_str()).collect::<Vec<_>>(),
        ["second_half", "third_quarter", "fourth_quarter"]
    );
    let (t0, t1) = (col(0, "t_start"), col(0, "t_end"));
    // the run to the window's end, sampled at every output time
    let run = fresh(&format!("growth-oracle-{tag}-run"));
    let t_end = format!("{t1}");
    let mut args = vec!["run", case.scene.as_str(), "--t-end", t_end.as_str(), "--no-figures"];
    args.extend(&case.run);
    let (o, e, ok) = ezy(&args, &run);
    assert!(ok, "{o}{e}");
    let (rh, rrows) = table(&run.join("trajectory.csv"));
    let rc = |name: &str| rh.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {rh:?}"));
    let (ct, ce, cx, cy) = (rc("t"), rc("T"), rc(case.vx), rc(case.vy));
    // the period ends: the window's samples, evenly spaced
    let n = col(0, "samples") as usize;
    let period = (t1 - t0) / (n - 1) as f64;
    let mut samples = Vec::new();
    for k in 0..n {
        let tk = t0 + k as f64 * period;
        let r = rrows
            .iter()
            .find(|r| (r[ct].parse::<f64>().unwrap() - tk).abs() < 1e-9 * tk)
            .unwrap_or_else(|| panic!("no output at t = {tk}"));
        let v = |c: usize| r[c].parse::<f64>().unwrap();
        samples.push((tk, v(ce), v(cx).hypot(v(cy))));
    }
    let windows = [(0, "second_half", 0..n), (1, "third_quarter", 0..n / 2 + 1), (2, "fourth_quarter", n / 2..n)];
    let mut printed_laws = Vec::new();
    for (row, name, range) in windows {
        let s = &samples[range];
        let t: Vec<f64> = s.iter().map(|s| s.0).collect();
        let (e, v): (Vec<f64>, Vec<f64>) = s.iter().map(|s| (s.1, s.2)).unzip();
        assert_eq!(col(row, "samples") as usize, t.len(), "{name}");
        assert!(
            (col(row, "t_start") - t[0]).abs() < 1e-9 * t[0]
                && (col(row, "t_end") - t[t.len() - 1]).abs() < 1e-9 * t[0]
        );
        for (what, y) in [("energy", &e), ("speed", &v)] {
            let (a, se, rms) = least_squares(&t, y);
            let (ca, cse, crms) = (
                col(row, &format!("{what}_exponent")),
                col(row, &format!("{what}_exponent_se")),
                col(row, &format!("{what}_residual")),
            );
            eprintln!(
                "{tag} {name} {what}: exponent {ca} against {a} ({:.1e}), se {cse} against {se}, residual {crms} against {rms}",
                (ca - a).abs()
            );
            // the analysis integrates the period map by DOP853 at its own
            // tolerance and the run by the scene's integrator (with
            // projection): the samples' logarithms differ by ~1e-11, the
            // exponents over a window of width ln(t1/t0) ~ 0.1 by ~1e-10
            // (measured 6e-11 at most)
            assert!((ca - a).abs() < 1e-9 * slack, "{tag} {name} {what} exponent {ca} against {a}");
            // the residuals (1e-7 to 1e-3) and standard errors of fits
            // whose samples differ by ~1e-11: to 1e-6 relative (measured
            // 3e-9 at most), 1e-14 absolute
            assert!(
                (crms - rms).abs() < (1e-14 + 1e-6 * rms) * slack,
                "{tag} {name} {what} residual {crms} against {rms}"
            );
            assert!((cse - se).abs() < (1e-14 + 1e-6 * se) * slack, "{tag} {name} {what} se {cse} against {se}");
            if row == 0 {
                printed_laws.push((a, se, rms));
            }
        }
        let ends = [(e[0], "T_start"), (e[e.len() - 1], "T_end"), (v[0], "speed_start"), (v[v.len() - 1], "speed_end")];
        for (want, column) in ends {
            let got = col(row, column);
            eprintln!("{tag} {name} {column}: {got} against {want} ({:.1e} relative)", (got - want).abs() / want);
            assert!((got - want).abs() < 1e-9 * want * slack, "{tag} {name} {column} {got} against {want}");
        }
    }
    // the verdict printed: the energies and times at the window's ends
    // (7 significant digits), the whole window's laws (exponents to 4
    // decimals, standard errors and residuals to 2 digits), the quarters'
    // exponents
    let line = out.lines().find(|l| l.contains("gains energy without bound")).unwrap_or_else(|| panic!("{out}"));
    let joules = numbers_after(line, "from ");
    let e0 = samples[0].1;
    assert!((joules[0] - e0).abs() <= (5e-7 + 1e-9 * slack) * e0, "{line}");
    let at = numbers_after(line, "at t = ");
    assert!((at[0] - t0).abs() < 1e-9 * t0 && (at[1] - t1).abs() < 1e-9 * t1, "{line}");
    let to = numbers_after(line, "J at t = ");
    assert_eq!(to.len(), 2, "{line}");
    let last = samples[n - 1].1;
    let e1 = numbers_after(line, "s to ")[0];
    assert!((e1 - last).abs() <= (5e-7 + 1e-9 * slack) * last, "{line}: {e1} against {last}");
    let exponents = numbers_after(line, "t^");
    let errors = numbers_after(line, "standard error ");
    let residuals = numbers_after(line, "log fit ");
    assert_eq!((exponents.len(), errors.len(), residuals.len()), (6, 2, 2), "{line}");
    for (k, (a, se, rms)) in printed_laws.iter().enumerate() {
        assert!((exponents[k] - a).abs() <= 5e-5 + 1e-9 * slack, "{line}: {} against {a}", exponents[k]);
        assert!((errors[k] - se).abs() <= 0.05 * se + 1e-6 * se * slack, "{line}: {} against {se}", errors[k]);
        assert!(
            (residuals[k] - rms).abs() <= 0.05 * rms + 1e-6 * rms * slack,
            "{line}: {} against {rms}",
            residuals[k]
        );
    }
    // the quarters' exponents: energy's two, then the speed's two
    for (k, (row, what)) in [(1, "energy"), (2, "energy"), (1, "speed"), (2, "speed")].iter().enumerate() {
        let want = col(*row, &format!("{what}_exponent"));
        assert!((exponents[2 + k] - want).abs() <= 5e-5 + 1e-12, "{line}: quarter {k} {what}");
    }
    (col(0, "energy_exponent"), col(0, "speed_exponent"))
}

/// The scene file of the Fermi-like sleigh (the guide's example).
fn fermi() -> String {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs/book/src/examples/fermi-sleigh/fermi-sleigh.toml")
        .display()
        .to_string()
}

/// `drive` (the EzyRoller, no loss): growth.csv and the verdict against
/// a run with the scene's own RK4 at 1e-4 s (its error ~1e-12 over the
/// window), sampled at the period ends 76 s to 92 s.
#[test]
fn drives_growth_is_the_runs() {
    let case = Case { scene: "drive".into(), vx: "x1d", vy: "y1d", run: vec![] };
    let (a, b) = check(&case, "drive", &[], 1.0);
    assert!((a - 1.0805).abs() < 1e-4 && (b - 0.5402).abs() < 1e-4, "{a} {b}");
}

/// The Fermi-like sleigh (the guide's example), at the scene's
/// tolerances and at `--rtol 1e-6` and `1e-12` (the run for the guess
/// and the period map at each, DOP853): growth.csv and the verdict
/// against a run at 1e-12. At the scene's 1e-10 and at 1e-12 the
/// samples agree to 1e-12 (measured 7.7e-13), the exponents to 1e-10
/// (measured 4e-11); at 1e-6 the samples are 1.1e-8 off and the
/// exponents 1.0e-8, so its bounds are 100 times wider.
#[test]
fn the_fermi_sleighs_growth_is_the_runs() {
    let case = Case { scene: fermi(), vx: "xd", vy: "yd", run: vec!["--rtol", "1e-12", "--atol", "1e-12"] };
    let (a, b) = check(&case, "fermi", &[], 1.0);
    for tol in ["1e-6", "1e-12"] {
        let slack = if tol == "1e-6" { 100.0 } else { 1.0 };
        let (a2, b2) = check(&case, &format!("fermi-{tol}"), &["--rtol", tol, "--atol", tol], slack);
        eprintln!("--rtol {tol}: exponents {a2} {b2} against {a} {b}");
        assert!((a2 - a).abs() < 1e-9 * slack && (b2 - b).abs() < 1e-9 * slack, "{tol}: {a2} {b2} against {a} {b}");
    }
}
