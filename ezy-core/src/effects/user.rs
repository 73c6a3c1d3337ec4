//! An effect of a kind of the user's own ([`UserSpec`]): the kind's name
//! and its value behind a type-erased [`EffectKind`], which scene files'
//! tables of that kind read into (crate `ezy-scene`) and
//! [`super::EffectSpec::User`] holds.

use std::fmt;
use std::sync::Arc;

use super::context::{CheckContext, EffectContext, SpecError};
use super::kind::{EffectKind, resolve_kind};
use super::law::Law;

/// An [`EffectKind`] value without its type.
trait BoundKind: fmt::Debug + Send + Sync {
    fn value_prefix(&self) -> &'static str;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError>;
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<Law, SpecError>;
}

impl<T: EffectKind> BoundKind for T {
    fn value_prefix(&self) -> &'static str {
        T::VALUE_PREFIX
    }
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        EffectKind::check(self, cx)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<Law, SpecError> {
        resolve_kind(self, cx)
    }
}

/// An effect of a kind of the user's own ([`EffectKind`]): the kind's
/// name and its value, read and checked (a scene file's table of that
/// kind, once parsed, or a value built in Rust).
#[derive(Clone)]
pub struct UserSpec {
    kind: String,
    value: Arc<dyn BoundKind>,
}

impl UserSpec {
    /// The effect `value` of the kind registered as `kind`.
    pub fn new<T: EffectKind>(kind: &str, value: T) -> Self {
        Self { kind: kind.into(), value: Arc::new(value) }
    }

    /// The kind, as scene files write it.
    pub fn kind(&self) -> &str {
        &self.kind
    }

    /// The value column's prefix ([`EffectKind::VALUE_PREFIX`]).
    pub fn value_prefix(&self) -> &'static str {
        self.value.value_prefix()
    }

    /// The kind's [`EffectKind::check`].
    pub(crate) fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        self.value.check(cx)
    }

    /// The kind's law for the model `cx` describes, checked and resolved.
    pub(crate) fn resolve(&self, cx: &EffectContext<'_>) -> Result<Law, SpecError> {
        self.value.resolve(cx)
    }
}

impl fmt::Debug for UserSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("UserSpec").field("kind", &self.kind).field("value", &self.value).finish()
    }
}

/// Two specs are equal when their kinds are and their values print alike
/// (an [`EffectKind`] need not implement `PartialEq`; its `Debug` form
/// shows every field).
impl PartialEq for UserSpec {
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind && format!("{:?}", self.value) == format!("{:?}", other.value)
    }
}
