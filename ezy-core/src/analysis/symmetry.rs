//! The plane's rigid motions acting on a model's state, and the test of
//! which of them leave a scene invariant.

use faer::Mat;

use super::{Analysis, AnalysisError};
use crate::model::Model;

/// An element of SE(2), the plane's rigid motions: a rotation by `theta`
/// \[rad\] about the origin, then a translation by `(a, b)` \[m\]. Acting on
/// a state, it moves every body's centre of mass, adds `theta` to every
/// heading and rotates every velocity of a centre of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Rotation \[rad\].
    pub theta: f64,
    /// Translation along x \[m\].
    pub a: f64,
    /// Translation along y \[m\].
    pub b: f64,
}

impl Pose {
    /// The identity.
    pub const IDENTITY: Pose = Pose { theta: 0.0, a: 0.0, b: 0.0 };

    /// `self` after `other`: `x -> self(other(x))`.
    pub fn compose(self, other: Pose) -> Pose {
        let [a, b] = self.point([other.a, other.b]);
        Pose { theta: self.theta + other.theta, a, b }
    }

    /// The inverse motion.
    pub fn inverse(self) -> Pose {
        let (s, c) = self.theta.sin_cos();
        Pose { theta: -self.theta, a: -(c * self.a + s * self.b), b: s * self.a - c * self.b }
    }

    /// The image of the point `p` \[m\].
    pub fn point(self, p: [f64; 2]) -> [f64; 2] {
        let [x, y] = self.vector(p);
        [x + self.a, y + self.b]
    }

    /// The image of the vector `v` (rotated only).
    pub fn vector(self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.theta.sin_cos();
        [c * v[0] - s * v[1], s * v[0] + c * v[1]]
    }
}

/// A one-parameter symmetry group: a subgroup of SE(2), whose
/// coefficient in a group velocity `xi` is a speed along x or y \[m/s\]
/// or a yaw rate about the origin \[rad/s\]; or the shift of one cyclic
/// coordinate (an internal rotor's angle), whose coefficient is that
/// coordinate's rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Generator {
    /// Translation along x.
    TranslateX,
    /// Translation along y.
    TranslateY,
    /// Rotation about the origin.
    Rotate,
    /// The shift of coordinate `q[k]` alone: a cyclic coordinate, which
    /// neither the constraints, the mass matrix nor the forces depend on
    /// (an internal rotor's angle; Marsden & Ratiu, §8.5 on cyclic
    /// variables).
    Shift(usize),
}

impl Generator {
    /// The name of the coefficient: `vx`, `vy`, `omega`, or for a shift
    /// the rate of its coordinate (`coords` the model's coordinate names:
    /// `thetad`).
    pub fn name(self, coords: &[String]) -> String {
        match self {
            Generator::TranslateX => "vx".into(),
            Generator::TranslateY => "vy".into(),
            Generator::Rotate => "omega".into(),
            Generator::Shift(k) => coords.get(k).map_or_else(|| format!("q{k}d"), |c| crate::names::velocity_name(c)),
        }
    }

    /// `exp(s * self)` in SE(2) (the identity for a shift, which moves no
    /// body in the plane).
    pub fn exp(self, s: f64) -> Pose {
        match self {
            Generator::TranslateX => Pose { a: s, ..Pose::IDENTITY },
            Generator::TranslateY => Pose { b: s, ..Pose::IDENTITY },
            Generator::Rotate => Pose { theta: s, ..Pose::IDENTITY },
            Generator::Shift(_) => Pose::IDENTITY,
        }
    }
}

/// The rigid motions and cyclic coordinates that leave a scene
/// invariant, as found by [`Analysis::symmetry`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Symmetry {
    /// Invariant under translations along x.
    pub translate_x: bool,
    /// Invariant under translations along y.
    pub translate_y: bool,
    /// Invariant under rotations about the origin.
    pub rotate: bool,
    /// Bit `k`: invariant under a shift of coordinate `q[k]` alone (a
    /// cyclic heading, such as an internal rotor's; among the first 64
    /// coordinates).
    pub cyclic: u64,
}

impl Symmetry {
    /// None: a mechanism fixed to the ground, a scene with gravity in the
    /// plane and a hinge to the ground.
    pub const NONE: Symmetry = Symmetry { translate_x: false, translate_y: false, rotate: false, cyclic: 0 };
    /// All of SE(2): a vehicle on a level plane.
    pub const SE2: Symmetry = Symmetry { translate_x: true, translate_y: true, rotate: true, cyclic: 0 };

    /// The generators of the symmetry group, in the order x, y, rotation,
    /// then the cyclic coordinates' shifts by index.
    pub fn generators(self) -> Vec<Generator> {
        let mut g: Vec<Generator> = [
            (self.translate_x, Generator::TranslateX),
            (self.translate_y, Generator::TranslateY),
            (self.rotate, Generator::Rotate),
        ]
        .into_iter()
        .filter_map(|(on, g)| on.then_some(g))
        .collect();
        g.extend((0..64).filter(|k| self.cyclic >> k & 1 == 1).map(Generator::Shift));
        g
    }

    /// The rigid motions alone (no cyclic coordinate): the group the
    /// periodic orbits are taken modulo.
    pub fn rigid(self) -> Symmetry {
        Symmetry { cyclic: 0, ..self }
    }

    /// A pose built from the parameters `p` (one per generator, in the
    /// order of [`Symmetry::generators`]): rotation, then translation.
    pub fn pose(self, p: &[f64]) -> Pose {
        let mut pose = Pose::IDENTITY;
        for (g, v) in self.generators().into_iter().zip(p) {
            match g {
                Generator::TranslateX => pose.a = *v,
                Generator::TranslateY => pose.b = *v,
                Generator::Rotate => pose.theta = *v,
                Generator::Shift(_) => {}
            }
        }
        pose
    }

    /// The parameters of `pose` in the order of [`Symmetry::generators`]
    /// (the inverse of [`Symmetry::pose`] on the group).
    pub fn params(self, pose: Pose) -> Vec<f64> {
        self.generators()
            .into_iter()
            .map(|g| match g {
                Generator::TranslateX => pose.a,
                Generator::TranslateY => pose.b,
                Generator::Rotate => pose.theta,
                Generator::Shift(_) => 0.0,
            })
            .collect()
    }

    /// The part of `pose` inside the group: the frame that moves the
    /// reference body's frame to the origin, as far as the symmetry allows.
    pub fn restrict(self, pose: Pose) -> Pose {
        Pose {
            theta: if self.rotate { pose.theta } else { 0.0 },
            a: if self.translate_x { pose.a } else { 0.0 },
            b: if self.translate_y { pose.b } else { 0.0 },
        }
    }
}

/// Applies `g` to the state `x = [q, qd]` of a model with bodies `bodies`.
pub(crate) fn act(bodies: &[[usize; 3]], g: Pose, x: &[f64]) -> Vec<f64> {
    let nq = x.len() / 2;
    let mut y = x.to_vec();
    for &[i, j, k] in bodies {
        [y[i], y[j]] = g.point([x[i], x[j]]);
        y[k] = x[k] + g.theta;
        [y[nq + i], y[nq + j]] = g.vector([x[nq + i], x[nq + j]]);
    }
    y
}

/// Applies `g` to accelerations `qdd` (nq): rotates those of the centres of mass.
fn act_accel(bodies: &[[usize; 3]], g: Pose, qdd: &[f64]) -> Vec<f64> {
    let mut y = qdd.to_vec();
    for &[i, j, _] in bodies {
        [y[i], y[j]] = g.vector([qdd[i], qdd[j]]);
    }
    y
}

/// The infinitesimal generator of `generator` at `x` (2 nq): `d/ds exp(s generator) x` at `s = 0`.
pub(crate) fn field(bodies: &[[usize; 3]], generator: Generator, x: &[f64]) -> Vec<f64> {
    let nq = x.len() / 2;
    let mut v = vec![0.0; x.len()];
    if let Generator::Shift(k) = generator {
        v[k] = 1.0;
        return v;
    }
    for &[i, j, k] in bodies {
        match generator {
            Generator::TranslateX => v[i] = 1.0,
            Generator::TranslateY => v[j] = 1.0,
            Generator::Rotate => {
                [v[i], v[j], v[k]] = [-x[j], x[i], 1.0];
                [v[nq + i], v[nq + j]] = [-x[nq + j], x[nq + i]];
            }
            Generator::Shift(_) => {}
        }
    }
    v
}

/// The generators' fields at `x` as the columns of a (2nq x k) matrix.
pub(crate) fn fields(bodies: &[[usize; 3]], generators: &[Generator], x: &[f64]) -> Mat<f64> {
    let cols: Vec<Vec<f64>> = generators.iter().map(|g| field(bodies, *g, x)).collect();
    Mat::from_fn(x.len(), generators.len(), |i, j| cols[j][i])
}

/// The derivative of [`field`] with respect to `x` (2nq x 2nq): zero for
/// a translation and a shift, the rotation's generator on positions and
/// velocities.
pub(crate) fn field_jacobian(bodies: &[[usize; 3]], generator: Generator, n2: usize) -> Mat<f64> {
    let nq = n2 / 2;
    let mut m = Mat::zeros(n2, n2);
    if generator == Generator::Rotate {
        for &[i, j, _] in bodies {
            for o in [0, nq] {
                m[(o + i, o + j)] = -1.0;
                m[(o + j, o + i)] = 1.0;
            }
        }
    }
    m
}

/// The derivative of [`act`] with respect to `x` (2nq x 2nq): rotation
/// blocks on positions and velocities.
pub(crate) fn act_jacobian(bodies: &[[usize; 3]], g: Pose, n2: usize) -> Mat<f64> {
    let nq = n2 / 2;
    let mut m = Mat::identity(n2, n2);
    let (s, c) = g.theta.sin_cos();
    for &[i, j, _] in bodies {
        for o in [0, nq] {
            m[(o + i, o + i)] = c;
            m[(o + i, o + j)] = -s;
            m[(o + j, o + i)] = s;
            m[(o + j, o + j)] = c;
        }
    }
    m
}

/// The frame of body `body` in the state `x`: rotation by its heading,
/// translation to its centre of mass.
pub(crate) fn body_pose(bodies: &[[usize; 3]], body: usize, x: &[f64]) -> Pose {
    let [i, j, k] = bodies[body];
    Pose { theta: x[k], a: x[i], b: x[j] }
}

impl<M: Model> Analysis<M> {
    /// The rigid motions of the plane that leave the scene invariant at
    /// time `t`, tested at the state `x` and at a perturbed copy of it:
    /// a motion `g` (a shift of 0.37 m along x, -0.29 m along y, a turn of
    /// 0.41 rad) counts when the constraint residual at `g x` is as long
    /// as at `x` (a hinge's residual turns with the motion; one to the
    /// ground does not) and the accelerations at `g x` are those at `x` carried by
    /// `g`, to 1e-9 relative. A body's heading is cyclic when turning that
    /// body alone (by 0.41 rad) leaves the residual and the accelerations
    /// as they were (an internal rotor on a hinge at its centre of mass,
    /// with no torque that depends on its angle). Found numerically, so it
    /// holds for the user's own force laws exactly as for the built-in ones.
    ///
    /// # Errors
    /// As [`Analysis::rhs`].
    pub fn symmetry(&mut self, t: f64, x: &[f64]) -> Result<Symmetry, AnalysisError> {
        self.check_state(x)?;
        let nq = self.nq();
        let perturbed: Vec<f64> =
            x.iter()
                .enumerate()
                .map(|(i, v)| {
                    if i < nq {
                        v + 0.01 * (3.0 * i as f64 + 1.0).sin()
                    } else {
                        v + 0.1 * (2.0 * i as f64 + 1.0).cos()
                    }
                })
                .collect();
        let mut invariant = |g: Pose| -> Result<bool, AnalysisError> {
            for state in [x, &perturbed[..]] {
                let moved = act(&self.bodies, g, state);
                // a hinge's residual is a vector that turns with the
                // motion: compare lengths
                let length = |r: Vec<f64>| r.iter().map(|v| v * v).sum::<f64>().sqrt();
                let (r0, r1) = (length(self.residual_at(t, state)), length(self.residual_at(t, &moved)));
                let scale = 1.0 + state.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if (r0 - r1).abs() > 1e-10 * scale {
                    return Ok(false);
                }
                let (p0, p1) = (self.point(t, state)?, self.point(t, &moved)?);
                let want = act_accel(&self.bodies, g, &p0.qdd);
                let scale = 1.0 + want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if want.iter().zip(&p1.qdd).any(|(a, b)| (a - b).abs() > 1e-9 * scale) {
                    return Ok(false);
                }
            }
            Ok(true)
        };
        let mut sym = Symmetry {
            translate_x: invariant(Pose { a: 0.37, ..Pose::IDENTITY })?,
            translate_y: invariant(Pose { b: -0.29, ..Pose::IDENTITY })?,
            rotate: invariant(Pose { theta: 0.41, ..Pose::IDENTITY })?,
            cyclic: 0,
        };
        // a heading nothing depends on: the constraint residual and the
        // accelerations the same after turning that body alone
        let headings: Vec<usize> = self.bodies.iter().map(|b| b[2]).filter(|&k| k < 64).collect();
        for k in headings {
            let mut cyclic = true;
            for state in [x, &perturbed[..]] {
                let mut moved = state.to_vec();
                moved[k] += 0.41;
                let (r0, r1) = (self.residual_at(t, state), self.residual_at(t, &moved));
                let scale = 1.0 + state.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if r0.iter().zip(&r1).any(|(a, b)| (a - b).abs() > 1e-10 * scale) {
                    cyclic = false;
                    break;
                }
                let (p0, p1) = (self.point(t, state)?, self.point(t, &moved)?);
                let scale = 1.0 + p0.qdd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if p0.qdd.iter().zip(&p1.qdd).any(|(a, b)| (a - b).abs() > 1e-9 * scale) {
                    cyclic = false;
                    break;
                }
            }
            if cyclic {
                sym.cyclic |= 1 << k;
            }
        }
        Ok(sym)
    }

    /// Bodies' `(x, y, phi)` indices.
    pub(crate) fn bodies(&self) -> &[[usize; 3]] {
        &self.bodies
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_compose_and_invert() {
        let g = Pose { theta: 0.7, a: 1.5, b: -0.3 };
        let h = Pose { theta: -1.1, a: 0.2, b: 2.0 };
        let p = [0.4, -0.9];
        let gh = g.compose(h).point(p);
        let want = g.point(h.point(p));
        assert!((gh[0] - want[0]).abs() < 1e-15 && (gh[1] - want[1]).abs() < 1e-15);
        let id = g.compose(g.inverse());
        assert!(id.theta.abs() < 1e-15 && id.a.abs() < 1e-15 && id.b.abs() < 1e-15);
    }

    #[test]
    fn the_generator_field_is_the_derivative_of_the_action() {
        let bodies = [[0, 1, 2], [3, 4, 5]];
        let x: Vec<f64> = (0..12).map(|i| (i as f64 * 0.7).sin()).collect();
        for generator in [Generator::TranslateX, Generator::TranslateY, Generator::Rotate] {
            let h = 1e-6;
            let (p, m) = (act(&bodies, generator.exp(h), &x), act(&bodies, generator.exp(-h), &x));
            let v = field(&bodies, generator, &x);
            for i in 0..12 {
                assert!(((p[i] - m[i]) / (2.0 * h) - v[i]).abs() < 1e-9, "{generator:?} {i}");
            }
        }
    }
}
