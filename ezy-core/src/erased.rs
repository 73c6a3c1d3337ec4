//! [`AnyModel`]: a model of any type behind one vtable, so that the code
//! that runs models (the step loop, the integrators, every command of the
//! `ezy` crate) is compiled once for all of them instead of once per
//! model type.
//!
//! A release build shares no generic code between crates: every crate
//! that names `simulate::<MyModel>` compiles the whole step loop, its
//! integrators and their linear algebra again. A model's own crate (a
//! user's vehicle, built with `model!`) that hands its model over as an
//! [`AnyModel`] compiles only its generated functions and the table of
//! them (about 40 entries); the step loop runs the table through one
//! indirect call per model function, a few nanoseconds against the
//! microseconds of an evaluation. The fused right-hand side keeps its
//! compile-time folding: [`Model::minimal_rhs_effects`] is one of the
//! entries, compiled with the model.
//!
//! The generic functions over [`Scalar`] (`phi`, the Jacobians, the
//! points) have one entry per scalar type [`Scalar`] is implemented for
//! (`f64` and `num_dual::Dual64`; the trait is sealed).

use core::any::TypeId;

use num_dual::Dual64;

use crate::error::KktError;
use crate::error::SimError;
use crate::model::info::{Equations, MinimalLayout, ModelInfo};
use crate::model::{MinimalCall, MinimalRhsError, Model};
use crate::scalar::Scalar;

/// `f(q, qd, f, tau)` of [`ModelObject::minimal_rhs_dyn`]: `false` when
/// the forces failed (the caller keeps the error).
type ForcesFn<'a> = dyn FnMut(&[f64], &[f64], &mut [f64], &mut [f64]) -> bool + 'a;

/// The object-safe face of [`Model`]: every method, the generic ones once
/// per scalar type (`_f64`, `_dual` for `num_dual::Dual64`). Implemented
/// for every [`Model`]; what [`AnyModel`] holds. Each method does what
/// the [`Model`] method of its name documents (shapes and units there).
/// Private to ezy-core: [`AnyModel`] is its one user.
pub(crate) trait ModelObject: Send + Sync {
    fn clone_box(&self) -> Box<dyn ModelObject>;
    fn info(&self) -> ModelInfo;
    fn equations(&self) -> Equations;
    fn check_counts(&self) -> Result<(), String>;
    fn param(&self, index: usize) -> f64;
    fn set_param(&mut self, index: usize, value: f64);
    fn unrolled_kernels(&self) -> bool;
    fn normal_matrix(&self, pattern: &[(usize, usize)], nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]);
    fn g_winv_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]);
    fn sub_winv_gt_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]);
    fn mass_diagonal(&self, out: &mut [f64]);
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]);
    fn phi_f64(&self, q: &[f64], phi: &mut [f64]);
    fn phi_dual(&self, q: &[Dual64], phi: &mut [Dual64]);
    fn holonomic_jacobian_f64(&self, q: &[f64], values: &mut [f64]);
    fn holonomic_jacobian_dual(&self, q: &[Dual64], values: &mut [Dual64]);
    fn constraint_matrix_f64(&self, q: &[f64], values: &mut [f64]);
    fn constraint_matrix_dual(&self, q: &[Dual64], values: &mut [Dual64]);
    fn phi_and_constraint_matrix_f64(&self, q: &[f64], phi: &mut [f64], values: &mut [f64]);
    fn phi_and_constraint_matrix_dual(&self, q: &[Dual64], phi: &mut [Dual64], values: &mut [Dual64]);
    fn constraint_terms_f64(&self, q: &[f64], qd: &[f64], values: &mut [f64], gamma: &mut [f64]);
    fn constraint_terms_dual(&self, q: &[Dual64], qd: &[Dual64], values: &mut [Dual64], gamma: &mut [Dual64]);
    fn points_f64(&self, q: &[f64], out: &mut [f64]);
    fn points_dual(&self, q: &[Dual64], out: &mut [Dual64]);
    fn point_velocities_f64(&self, q: &[f64], qd: &[f64], out: &mut [f64]);
    fn point_velocities_dual(&self, q: &[Dual64], qd: &[Dual64], out: &mut [Dual64]);
    fn minimal_layout(&self) -> Result<MinimalLayout, String>;
    fn minimal_expand_f64(&self, q: &mut [f64], qd: &mut [f64], b: &mut [f64], c: &mut [f64]);
    fn minimal_expand_dual(&self, q: &mut [Dual64], qd: &mut [Dual64], b: &mut [Dual64], c: &mut [Dual64]);
    fn minimal_state_f64(&self, q: &mut [f64], qd: &mut [f64]) -> bool;
    fn minimal_state_dual(&self, q: &mut [Dual64], qd: &mut [Dual64]) -> bool;
    fn minimal_constants(&self) -> Option<Vec<f64>>;
    /// [`Model::minimal_rhs`] with its `forces` behind a pointer: `Err(None)`
    /// when `forces` returned `false`, `Err(Some(e))` when Maggi's matrix
    /// could not be factored.
    fn minimal_rhs_dyn(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: &mut ForcesFn<'_>,
    ) -> Result<(), Option<KktError>>;
    fn minimal_rhs_effects(&self, call: &mut MinimalCall<'_>) -> Result<(), MinimalRhsError<SimError>>;
    fn minimal_maggi(&self, mass: &[f64], b: &[f64], c: &[f64], f: &[f64], a: &mut [f64], r: &mut [f64]);
}

impl<M: Model> ModelObject for M {
    fn clone_box(&self) -> Box<dyn ModelObject> {
        Box::new(self.clone())
    }
    fn info(&self) -> ModelInfo {
        Model::info(self)
    }
    fn equations(&self) -> Equations {
        Model::equations(self)
    }
    fn check_counts(&self) -> Result<(), String> {
        Model::check_counts(self)
    }
    fn param(&self, index: usize) -> f64 {
        Model::param(self, index)
    }
    fn set_param(&mut self, index: usize, value: f64) {
        Model::set_param(self, index, value);
    }
    fn unrolled_kernels(&self) -> bool {
        Model::unrolled_kernels(self)
    }
    fn normal_matrix(&self, pattern: &[(usize, usize)], nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
        Model::normal_matrix(self, pattern, nc, values, winv, a);
    }
    fn g_winv_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]) {
        Model::g_winv_mul(self, pattern, values, winv, u, out);
    }
    fn sub_winv_gt_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
        Model::sub_winv_gt_mul(self, pattern, values, winv, x, v);
    }
    fn mass_diagonal(&self, out: &mut [f64]) {
        Model::mass_diagonal(self, out);
    }
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
        Model::local_geometry(self, points, blades);
    }
    fn phi_f64(&self, q: &[f64], phi: &mut [f64]) {
        Model::phi(self, q, phi);
    }
    fn phi_dual(&self, q: &[Dual64], phi: &mut [Dual64]) {
        Model::phi(self, q, phi);
    }
    fn holonomic_jacobian_f64(&self, q: &[f64], values: &mut [f64]) {
        Model::holonomic_jacobian(self, q, values);
    }
    fn holonomic_jacobian_dual(&self, q: &[Dual64], values: &mut [Dual64]) {
        Model::holonomic_jacobian(self, q, values);
    }
    fn constraint_matrix_f64(&self, q: &[f64], values: &mut [f64]) {
        Model::constraint_matrix(self, q, values);
    }
    fn constraint_matrix_dual(&self, q: &[Dual64], values: &mut [Dual64]) {
        Model::constraint_matrix(self, q, values);
    }
    fn phi_and_constraint_matrix_f64(&self, q: &[f64], phi: &mut [f64], values: &mut [f64]) {
        Model::phi_and_constraint_matrix(self, q, phi, values);
    }
    fn phi_and_constraint_matrix_dual(&self, q: &[Dual64], phi: &mut [Dual64], values: &mut [Dual64]) {
        Model::phi_and_constraint_matrix(self, q, phi, values);
    }
    fn constraint_terms_f64(&self, q: &[f64], qd: &[f64], values: &mut [f64], gamma: &mut [f64]) {
        Model::constraint_terms(self, q, qd, values, gamma);
    }
    fn constraint_terms_dual(&self, q: &[Dual64], qd: &[Dual64], values: &mut [Dual64], gamma: &mut [Dual64]) {
        Model::constraint_terms(self, q, qd, values, gamma);
    }
    fn points_f64(&self, q: &[f64], out: &mut [f64]) {
        Model::points(self, q, out);
    }
    fn points_dual(&self, q: &[Dual64], out: &mut [Dual64]) {
        Model::points(self, q, out);
    }
    fn point_velocities_f64(&self, q: &[f64], qd: &[f64], out: &mut [f64]) {
        Model::point_velocities(self, q, qd, out);
    }
    fn point_velocities_dual(&self, q: &[Dual64], qd: &[Dual64], out: &mut [Dual64]) {
        Model::point_velocities(self, q, qd, out);
    }
    fn minimal_layout(&self) -> Result<MinimalLayout, String> {
        Model::minimal_layout(self)
    }
    fn minimal_expand_f64(&self, q: &mut [f64], qd: &mut [f64], b: &mut [f64], c: &mut [f64]) {
        Model::minimal_expand(self, q, qd, b, c);
    }
    fn minimal_expand_dual(&self, q: &mut [Dual64], qd: &mut [Dual64], b: &mut [Dual64], c: &mut [Dual64]) {
        Model::minimal_expand(self, q, qd, b, c);
    }
    fn minimal_state_f64(&self, q: &mut [f64], qd: &mut [f64]) -> bool {
        Model::minimal_state(self, q, qd)
    }
    fn minimal_state_dual(&self, q: &mut [Dual64], qd: &mut [Dual64]) -> bool {
        Model::minimal_state(self, q, qd)
    }
    fn minimal_constants(&self) -> Option<Vec<f64>> {
        Model::minimal_constants(self)
    }
    fn minimal_rhs_dyn(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: &mut ForcesFn<'_>,
    ) -> Result<(), Option<KktError>> {
        Model::minimal_rhs(self, k, z, q, qd, dz, |q, qd, f, tau| if forces(q, qd, f, tau) { Ok(()) } else { Err(()) })
            .map_err(|e| match e {
                MinimalRhsError::Forces(()) => None,
                MinimalRhsError::Maggi(e) => Some(e),
            })
    }
    fn minimal_rhs_effects(&self, call: &mut MinimalCall<'_>) -> Result<(), MinimalRhsError<SimError>> {
        Model::minimal_rhs_effects(self, call)
    }
    fn minimal_maggi(&self, mass: &[f64], b: &[f64], c: &[f64], f: &[f64], a: &mut [f64], r: &mut [f64]) {
        Model::minimal_maggi(self, mass, b, c, f, a, r);
    }
}

/// A model of any type, its methods called through one table: what the
/// `ezy` crate's commands run, so that they are compiled once for every
/// model (see the [module](self)). Built from any [`Model`] by
/// [`AnyModel::new`]; a [`Model`] itself, with the same numbers bit for
/// bit as the model it holds.
pub struct AnyModel(Box<dyn ModelObject>);

impl AnyModel {
    /// Wraps `model`.
    pub fn new<M: Model>(model: M) -> Self {
        Self(Box::new(model))
    }
}

impl Clone for AnyModel {
    fn clone(&self) -> Self {
        Self(self.0.clone_box())
    }
}

impl std::fmt::Debug for AnyModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("AnyModel").field(&self.0.info().name).finish()
    }
}

/// Whether `S` is `T`.
#[inline(always)]
fn is<S: 'static, T: 'static>() -> bool {
    TypeId::of::<S>() == TypeId::of::<T>()
}

/// `s` as a slice of `T`.
///
/// # Safety
/// `S` is `T` ([`is`]).
#[inline(always)]
unsafe fn cast<S, T>(s: &[S]) -> &[T] {
    // SAFETY: the caller checked that S and T are one type
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len()) }
}

/// `s` as a mutable slice of `T`.
///
/// # Safety
/// `S` is `T` ([`is`]).
#[inline(always)]
unsafe fn cast_mut<S, T>(s: &mut [S]) -> &mut [T] {
    // SAFETY: the caller checked that S and T are one type
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast(), s.len()) }
}

/// Calls the `f64` or the `Dual64` entry of a generic method: `$f` with
/// every slice argument cast to `f64`, or `$d` with them cast to
/// `Dual64`. [`Scalar`] is sealed to these two.
macro_rules! by_scalar {
    ($s:ty, $self:ident . $f:ident / $d:ident ( $($a:ident: $k:ident),* )) => {
        if is::<$s, f64>() {
            // SAFETY: S is f64
            unsafe { $self.0.$f($(by_scalar!(@$k $a, f64)),*) }
        } else if is::<$s, Dual64>() {
            // SAFETY: S is Dual64
            unsafe { $self.0.$d($(by_scalar!(@$k $a, Dual64)),*) }
        } else {
            unreachable!("Scalar is sealed to f64 and Dual64")
        }
    };
    (@r $a:ident, $t:ty) => { cast::<_, $t>($a) };
    (@w $a:ident, $t:ty) => { cast_mut::<_, $t>($a) };
}

impl Model for AnyModel {
    fn info(&self) -> ModelInfo {
        self.0.info()
    }
    fn equations(&self) -> Equations {
        self.0.equations()
    }
    fn check_counts(&self) -> Result<(), String> {
        self.0.check_counts()
    }
    fn param(&self, index: usize) -> f64 {
        self.0.param(index)
    }
    fn set_param(&mut self, index: usize, value: f64) {
        self.0.set_param(index, value);
    }
    fn unrolled_kernels(&self) -> bool {
        self.0.unrolled_kernels()
    }
    fn normal_matrix(&self, pattern: &[(usize, usize)], nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
        self.0.normal_matrix(pattern, nc, values, winv, a);
    }
    fn g_winv_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]) {
        self.0.g_winv_mul(pattern, values, winv, u, out);
    }
    fn sub_winv_gt_mul(&self, pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
        self.0.sub_winv_gt_mul(pattern, values, winv, x, v);
    }
    fn mass_diagonal(&self, out: &mut [f64]) {
        self.0.mass_diagonal(out);
    }
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
        self.0.local_geometry(points, blades);
    }
    fn phi<S: Scalar>(&self, q: &[S], phi: &mut [S]) {
        by_scalar!(S, self.phi_f64 / phi_dual(q: r, phi: w));
    }
    fn holonomic_jacobian<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        by_scalar!(S, self.holonomic_jacobian_f64 / holonomic_jacobian_dual(q: r, values: w));
    }
    fn constraint_matrix<S: Scalar>(&self, q: &[S], values: &mut [S]) {
        by_scalar!(S, self.constraint_matrix_f64 / constraint_matrix_dual(q: r, values: w));
    }
    fn phi_and_constraint_matrix<S: Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
        by_scalar!(S, self.phi_and_constraint_matrix_f64 / phi_and_constraint_matrix_dual(q: r, phi: w, values: w));
    }
    fn constraint_terms<S: Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
        by_scalar!(S, self.constraint_terms_f64 / constraint_terms_dual(q: r, qd: r, values: w, gamma: w));
    }
    fn points<S: Scalar>(&self, q: &[S], out: &mut [S]) {
        by_scalar!(S, self.points_f64 / points_dual(q: r, out: w));
    }
    fn point_velocities<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
        by_scalar!(S, self.point_velocities_f64 / point_velocities_dual(q: r, qd: r, out: w));
    }
    fn minimal_layout(&self) -> Result<MinimalLayout, String> {
        self.0.minimal_layout()
    }
    fn minimal_expand<S: Scalar>(&self, q: &mut [S], qd: &mut [S], b: &mut [S], c: &mut [S]) {
        by_scalar!(S, self.minimal_expand_f64 / minimal_expand_dual(q: w, qd: w, b: w, c: w));
    }
    fn minimal_state<S: Scalar>(&self, q: &mut [S], qd: &mut [S]) -> bool {
        by_scalar!(S, self.minimal_state_f64 / minimal_state_dual(q: w, qd: w))
    }
    fn minimal_constants(&self) -> Option<Vec<f64>> {
        self.0.minimal_constants()
    }
    fn minimal_rhs<E, F>(
        &self,
        k: &[f64],
        z: &[f64],
        q: &mut [f64],
        qd: &mut [f64],
        dz: &mut [f64],
        forces: F,
    ) -> Result<(), MinimalRhsError<E>>
    where
        F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
    {
        let (mut forces, mut error) = (Some(forces), None);
        let mut call = |q: &[f64], qd: &[f64], f: &mut [f64], tau: &mut [f64]| match forces.take() {
            Some(forces) => match forces(q, qd, f, tau) {
                Ok(()) => true,
                Err(e) => {
                    error = Some(e);
                    false
                }
            },
            // `minimal_rhs` calls `forces` once
            None => true,
        };
        let res = self.0.minimal_rhs_dyn(k, z, q, qd, dz, &mut call);
        match res {
            Ok(()) => Ok(()),
            Err(Some(e)) => Err(MinimalRhsError::Maggi(e)),
            Err(None) => Err(MinimalRhsError::Forces(error.expect("the forces' error"))),
        }
    }
    #[inline]
    fn minimal_rhs_effects(&self, call: &mut MinimalCall<'_>) -> Result<(), MinimalRhsError<SimError>> {
        self.0.minimal_rhs_effects(call)
    }
    fn minimal_maggi(&self, mass: &[f64], b: &[f64], c: &[f64], f: &[f64], a: &mut [f64], r: &mut [f64]) {
        self.0.minimal_maggi(mass, b, c, f, a, r);
    }
}
