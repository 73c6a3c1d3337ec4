//! A gait's mean input power and efficiency (`ezy analyze`) against the
//! work ledger of a plain run (`ezy run`) started at the gait's fixed
//! point and integrated over one period: the actuators' work columns
//! over the period, and the dissipation that balances them.

use crate::analysis::{ezy, fresh, table};

/// The number in column `name` of the first row of the CSV at `path`.
fn cell(path: &std::path::Path, row: usize, name: &str) -> f64 {
    let (head, rows) = table(path);
    let k = head.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {head:?}"));
    rows[row][k].parse().unwrap()
}

/// A sleigh propelled by a rotor whose angle to the sleigh is
/// prescribed (`drive psi: hinge H;`, `psi = sin(3 t)`), with drag: a
/// user's model typed as text. `ezy analyze` printed "mean input power 0
/// W" and an efficiency of NaN for such gaits (a drive's power, its
/// constraint torque times its rate, was not counted). Now the mean input
/// power is the drive's, and a run from the fixed point over one period
/// (the scene's drive shifted to the orbit's phase) gives the same
/// `W_psi / T` and `-W_drag / T` to 1e-8 relative (the run at 1e-12).
#[test]
fn a_drives_power_is_the_gaits_input_power() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oracle");
    let dir = fresh("drive-power");
    let (out, err, ok) = ezy(&["analyze", data.join("rotor-drive.toml").to_str().unwrap(), "--no-figures"], &dir);
    assert!(ok, "{out}{err}");
    let periodic = dir.join("periodic.csv");
    let (t0, period, power) =
        (cell(&periodic, 0, "t0"), cell(&periodic, 0, "period"), cell(&periodic, 0, "mean_power"));
    let speed = cell(&periodic, 0, "mean_speed");
    assert!(power > 1e-3, "mean input power {power} W:\n{out}");
    assert!(out.contains("(psi ") && !out.contains("NaN"), "{out}");
    let efficiency = cell(&periodic, 0, "efficiency");
    assert!((efficiency - speed / power).abs() <= 1e-12 * efficiency, "{efficiency} against {}", speed / power);
    // the run: the same model and drag, from the fixed point, the drive at the orbit's phase
    let run = fresh("drive-power-run");
    std::fs::create_dir_all(&run).unwrap();
    std::fs::copy(data.join("rotor_drive.ezy"), run.join("rotor_drive.ezy")).unwrap();
    let v = |n: &str| cell(&periodic, 0, n);
    let scene = format!(
        "name = \"rotor-drive-period\"\ndescription = \"one period of the gait\"\nmodel = \"rotor_drive.ezy\"\nt_end = {period:e}\n\n[initial]\nq = {{ x = {:e}, y = {:e}, phi = {:e} }}\nqd = {{ x = {:e}, phi = {:e} }}\n\n[integrator]\nmethod = \"dop853\"\nrtol = 1e-12\natol = 1e-12\n\n[output]\nevery = {period:e}\ninclude = [\"energy\", \"effects\"]\n\n[drives.psi]\nangle = {{ sin = {{ amplitude = 1.0, omega = 3.0, phase = {:e} }} }}\n\n[effects.drag]\nkind = \"linear-drag\"\nbody = \"s\"\nc = 0.5\nc_rot = 0.05\n",
        v("x"),
        v("y"),
        v("phi"),
        v("xd"),
        v("phid"),
        3.0 * t0
    );
    std::fs::write(run.join("scene.toml"), scene).unwrap();
    let (out, err, ok) = ezy(&["run", run.join("scene.toml").to_str().unwrap(), "--no-figures"], &run.join("out"));
    assert!(ok, "{out}{err}");
    let trajectory = run.join("out/trajectory.csv");
    let (_, rows) = table(&trajectory);
    let last = rows.len() - 1;
    let (w_psi, w_drag) = (cell(&trajectory, last, "W_psi"), cell(&trajectory, last, "W_drag"));
    assert!((cell(&trajectory, last, "t") - period).abs() <= 1e-12 * period);
    eprintln!("gait {power} W; run over a period: W_psi/T {}, -W_drag/T {}", w_psi / period, -w_drag / period);
    assert!((w_psi / period - power).abs() <= 1e-8 * power, "W_psi / T = {} against {power}", w_psi / period);
    assert!((-w_drag / period - power).abs() <= 1e-8 * power, "-W_drag / T = {} against {power}", -w_drag / period);
}
