//! The stability `ezy analyze` prints, said in words: each multiplier 1
//! (or eigenvalue 0) named with its cause, the verdict on the rest, and
//! the multipliers the period map resolves told from those it does not.
//! The oracle: the same orbit at a tolerance 100 times tighter (a
//! difference of whole runs), whose multipliers the printed ones must
//! match to their last printed digit and whose unresolved ones must lie
//! below the printed bound.

use crate::analysis::{ezy, fresh, table};

/// The user's rotor sleigh (a model typed as text, a balanced rotor on
/// a hinge at the sleigh's centre driven by `0.5 sin(3 t)` N m) with a
/// drag of 20 N s/m: both multipliers are tiny, 2.13e-10 and about
/// 7e-13. At the period map's default tolerance (1e-11) the first is
/// printed to the two digits it holds above that level and the second
/// as `< 1e-11 (unresolved)`, where `0.000000, 0.000000` was printed (a
/// student read 1.2e-13 as a value where 1.6e-15 was true). At 1e-13
/// the first is within half a unit of its last printed digit and the
/// second is below the bound. Its five multipliers 1 are each named:
/// the rotor's angle (cyclic), its rate (nothing else feels it), and
/// the plane's two translations and rotation.
#[test]
fn a_rotors_unit_multipliers_are_named_and_an_unresolved_one_is_said() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let scene = data.join("rotor-sleigh.toml");
    let scene = scene.to_str().unwrap();
    let run = |extra: &[&str], name: &str| {
        let dir = fresh(name);
        let mut args = vec!["analyze", scene, "--no-figures", "--set", "drag.c=20"];
        args.extend(extra);
        let (out, err, ok) = ezy(&args, &dir);
        assert!(ok, "{out}{err}");
        let (head, rows) = table(&dir.join("periodic.csv"));
        let mu = |k: usize| -> f64 {
            let i = head.iter().position(|h| *h == format!("mu{k}_re")).unwrap();
            rows[0][i].parse().unwrap()
        };
        (out, [mu(1), mu(2)])
    };
    let (out, _) = run(&[], "words-default");
    let (_, tight) = run(&["--rtol", "1e-13", "--atol", "1e-13", "--max-steps", "1000000"], "words-tight");
    let line = out.lines().find(|l| l.starts_with("periodic orbit:")).expect("an orbit line");
    assert!(line.contains("stable (all 2 multipliers inside the unit circle)"), "{line}");
    let shown = line.split("multipliers: ").nth(1).unwrap();
    let shown: Vec<&str> = shown.split(", ").collect();
    assert_eq!(shown.len(), 2, "{line}");
    assert_eq!(shown[1], "< 1e-11 (unresolved)", "{line}");
    // the resolved one: exponent form, within half its last digit
    let first: f64 = shown[0].parse().unwrap_or_else(|_| panic!("{line}"));
    let mantissa = shown[0].split('e').next().unwrap();
    let last = 10f64.powi(-(mantissa.split('.').nth(1).map_or(0, str::len) as i32));
    let unit = last * 10f64.powi(shown[0].split('e').nth(1).unwrap().parse::<i32>().unwrap());
    assert!((first - tight[0]).abs() <= 0.5 * unit, "{} printed, {} at 1e-13", shown[0], tight[0]);
    assert!(tight[1].abs() < 1e-11, "the unresolved multiplier is {} at 1e-13", tight[1]);
    let ones = out.lines().find(|l| l.starts_with("structural multipliers")).expect("a structural line");
    for cause in [
        "1 (th: cyclic)",
        "1 (thd: the rate of cyclic th, which nothing else feels)",
        "1 (x: the plane's translation)",
        "1 (y: the plane's translation)",
        "1 (heading: the plane's rotation)",
    ] {
        assert!(ones.contains(cause), "{cause} in {ones}");
    }
}

/// The four-bar's crank turns on a limit cycle (no symmetry, no cyclic
/// coordinate): its one multiplier 1 is the time shift, named; and the
/// sleigh's steady motion has an eigenvalue 0, the family of steady
/// motions at other speeds (the oracle: its count is the printed family
/// dimension, 1, and the value is 0 to the six decimals printed).
#[test]
fn a_cycles_time_shift_and_a_steady_familys_zero_are_named() {
    let (out, err, ok) = ezy(&["analyze", "four-bar", "--no-figures"], &fresh("words-cycle"));
    assert!(ok, "{out}{err}");
    let ones = out.lines().find(|l| l.starts_with("structural multipliers")).expect("a structural line");
    assert!(ones.ends_with(": 1 (the time shift: the cycle started later is the same cycle)"), "{ones}");
    assert!(out.contains("stable (all 1 multiplier inside the unit circle)"), "{out}");
    let (out, err, ok) = ezy(&["analyze", "sleigh", "--no-figures"], &fresh("words-steady"));
    assert!(ok, "{out}{err}");
    let line = out.lines().find(|l| l.starts_with("steady motion 1:")).expect("a steady line");
    assert!(line.contains("family 1;"), "{line}");
    assert_eq!(line.matches("0.000000 (along the family of steady motions)").count(), 1, "{line}");
}
