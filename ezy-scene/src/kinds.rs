//! Effects as a scene file writes them: a built-in kind, or a kind of the
//! user's own read through the kinds an application registers.
//!
//! A scene file's `[effects.NAME]` table whose `kind` is built in reads
//! as an [`EffectSpec`]; any other kind is kept as its table
//! ([`UserTable`]) until the scene is bound to an application's kinds
//! ([`crate::Scene::bind_kinds`]), which read it into the kind's type
//! ([`EffectKind`]) when the scene is checked and run.

use std::fmt;
use std::marker::PhantomData;
use std::sync::Arc;

use ezy_core::effects::{EFFECT_KINDS, Effect, EffectContext, EffectKind, EffectSpec, SpecError, UserSpec};
use ezy_core::{NameIndex, SetupError, SimError};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The keys of an `[effects.NAME]` table whose values are names (the kind,
/// the model's hinges, skates, bodies and points, the frame) rather than
/// numbers. Every other value in an effect is a number or holds numbers,
/// so a string there names a scene parameter (`amplitude = "M0"`, see
/// [`crate::Scene::from_toml`]).
pub const NAME_KEYS: &[&str] = &["kind", "hinge", "skate", "body", "at", "frame", "from", "to", "bodies"];

/// A value of a parsed scene file, with its place in the text.
type Value<'i> = toml::Spanned<toml::de::DeValue<'i>>;

/// Calls `on` with every string in a number's place under `v` (key path
/// `path`, array entries by index): not at an effect's name keys
/// ([`NAME_KEYS`], in its own table: `effect_table`), not at a
/// waveform's `extrapolate` (a word at any depth). What the scene file
/// reader reads there: a scene parameter's name, a number with a unit.
///
/// # Errors
/// The first error of `on`.
pub(crate) fn number_strings<'i, E, F>(
    v: &mut Value<'i>,
    path: &mut Vec<String>,
    effect_table: bool,
    on: &mut F,
) -> Result<(), E>
where
    F: FnMut(&mut Value<'i>, &[String]) -> Result<(), E>,
{
    use toml::de::DeValue;
    match v.get_mut() {
        DeValue::String(_) => on(v, path)?,
        DeValue::Table(t) => {
            for (k, v) in t.iter_mut() {
                let k = k.get_ref().as_ref();
                if (effect_table && NAME_KEYS.contains(&k)) || k == "extrapolate" {
                    continue;
                }
                path.push(k.to_string());
                number_strings(v, path, false, on)?;
                path.pop();
            }
        }
        DeValue::Array(a) => {
            for (i, v) in a.iter_mut().enumerate() {
                path.push(i.to_string());
                number_strings(v, path, false, on)?;
                path.pop();
            }
        }
        _ => {}
    }
    Ok(())
}

/// The known kinds as an error lists them: the built-in ones and `user`.
pub(crate) fn known_kinds(user: &[&str]) -> String {
    let mut all: Vec<&str> = EFFECT_KINDS.to_vec();
    all.extend_from_slice(user);
    format!("known kinds: {}", ezy_core::name_list(all))
}

/// An [`EffectKind`] without its type: reads a table into the kind.
trait ErasedKind: Send + Sync {
    fn parse(&self, kind: &str, params: &toml::Table) -> Result<UserSpec, SpecError>;
}

struct Typed<T>(PhantomData<fn() -> T>);

impl<T: EffectKind> ErasedKind for Typed<T> {
    fn parse(&self, kind: &str, params: &toml::Table) -> Result<UserSpec, SpecError> {
        let value: T = toml::Value::Table(params.clone())
            .try_into()
            .map_err(|e: toml::de::Error| SpecError { field: "", message: e.message().trim().to_string() })?;
        Ok(UserSpec::new(kind, value))
    }
}

/// A registered kind: its name and its type's reader.
#[derive(Clone)]
pub struct KindHandle {
    name: Arc<str>,
    value_prefix: &'static str,
    kind: Arc<dyn ErasedKind>,
}

impl fmt::Debug for KindHandle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "KindHandle({})", self.name)
    }
}

/// The effect kinds of the user's own an application knows, by the name
/// scene files give in `kind = "..."`.
#[derive(Debug, Clone, Default)]
pub struct EffectKinds {
    kinds: Vec<KindHandle>,
}

impl EffectKinds {
    /// Registers kind `T` as `name`.
    ///
    /// # Errors
    /// A message if `name` is a built-in kind ([`EFFECT_KINDS`]), is
    /// already registered, or is not lowercase letters, digits and `-`.
    pub fn add<T: EffectKind>(&mut self, name: &str) -> Result<(), String> {
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-') {
            return Err(format!(
                "effect kind `{name}` must be lowercase letters, digits and - (as scene files write it)"
            ));
        }
        if EFFECT_KINDS.contains(&name) {
            return Err(format!("effect kind `{name}` is a built-in kind: give yours another name"));
        }
        if self.get(name).is_some() {
            return Err(format!("effect kind `{name}` is registered twice"));
        }
        self.kinds.push(KindHandle {
            name: name.into(),
            value_prefix: T::VALUE_PREFIX,
            kind: Arc::new(Typed::<T>(PhantomData)),
        });
        Ok(())
    }

    /// The kind registered as `name`.
    pub fn get(&self, name: &str) -> Option<&KindHandle> {
        self.kinds.iter().find(|k| &*k.name == name)
    }

    /// The registered names, in registration order.
    pub fn names(&self) -> Vec<&str> {
        self.kinds.iter().map(|k| &*k.name).collect()
    }
}

/// An effect of a kind of the user's own as a scene holds it: the kind's
/// name and the rest of its `[effects.NAME]` table, and, once the scene
/// is bound to an application's kinds ([`crate::Scene::bind_kinds`]), the
/// kind's reader.
#[derive(Clone)]
pub struct UserTable {
    /// The kind, as the scene writes it.
    pub kind: String,
    /// The table's other keys.
    pub params: toml::Table,
    handle: Option<KindHandle>,
}

impl UserTable {
    /// An effect of kind `kind` with the fields of `params` (what the
    /// scene file's table gives, `kind` excepted), not yet bound.
    ///
    /// # Errors
    /// A message if `params` does not serialize to a table.
    pub fn new<T: Serialize>(kind: &str, params: &T) -> Result<Self, String> {
        match toml::Value::try_from(params).map_err(|e| e.to_string())? {
            toml::Value::Table(params) => Ok(Self { kind: kind.into(), params, handle: None }),
            _ => Err(format!("effect kind `{kind}`: its fields must serialize to a table")),
        }
    }

    /// Whether the kind is bound to its reader.
    pub fn is_bound(&self) -> bool {
        self.handle.is_some()
    }

    /// The table read into its kind's type.
    ///
    /// # Errors
    /// A [`SpecError`] at `kind` listing the known kinds when the table is
    /// not bound to any (`known` gives them); the type's serde error
    /// (unknown or missing field, wrong type) otherwise.
    pub fn parse(&self, known: &str) -> Result<UserSpec, SpecError> {
        let h = self.handle.as_ref().ok_or_else(|| SpecError {
            field: "kind",
            message: format!("unknown effect kind `{}`; {known}", self.kind),
        })?;
        h.kind.parse(&self.kind, &self.params)
    }
}

impl fmt::Debug for UserTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("UserTable").field("kind", &self.kind).field("params", &self.params).finish()
    }
}

impl PartialEq for UserTable {
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind && self.params == other.params
    }
}

/// An `[effects.NAME]` table of a scene: a built-in kind, read and typed,
/// or a kind of the user's own, kept as its table.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneEffect {
    /// A built-in kind.
    Builtin(EffectSpec),
    /// A kind of the user's own.
    User(UserTable),
}

impl From<EffectSpec> for SceneEffect {
    fn from(spec: EffectSpec) -> Self {
        Self::Builtin(spec)
    }
}

// A table whose `kind` is built in reads as that EffectSpec variant; any
// other kind is kept as the table, for the application's kinds to read.
impl<'de> Deserialize<'de> for SceneEffect {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut table = toml::Table::deserialize(d)?;
        let kind = match table.get("kind") {
            None => return Err(D::Error::missing_field("kind")),
            Some(toml::Value::String(k)) => k.clone(),
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "`kind` must be a string naming the effect kind, got {}",
                    other.type_str()
                )));
            }
        };
        if EFFECT_KINDS.contains(&kind.as_str()) {
            return EffectSpec::deserialize(toml::Value::Table(table))
                .map(SceneEffect::Builtin)
                .map_err(|e: toml::de::Error| D::Error::custom(e.message().trim()));
        }
        table.remove("kind");
        Ok(SceneEffect::User(UserTable { kind, params: table, handle: None }))
    }
}

impl Serialize for SceneEffect {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap as _;
        match self {
            SceneEffect::User(u) => {
                let mut map = s.serialize_map(Some(u.params.len() + 1))?;
                map.serialize_entry("kind", &u.kind)?;
                for (k, v) in &u.params {
                    map.serialize_entry(k, v)?;
                }
                map.end()
            }
            SceneEffect::Builtin(spec) => spec.serialize(s),
        }
    }
}

impl SceneEffect {
    /// The kind as a scene file spells it.
    pub fn kind(&self) -> &str {
        match self {
            Self::Builtin(spec) => spec.kind(),
            Self::User(u) => &u.kind,
        }
    }

    /// Name of the output column of the effect called `name`
    /// ([`EffectSpec::value_column`]; a kind of the user's own takes its
    /// [`EffectKind::VALUE_PREFIX`], `F` while unbound).
    pub fn value_column(&self, name: &str) -> String {
        match self {
            Self::Builtin(spec) => spec.value_column(name),
            Self::User(u) => format!("{}_{name}", u.handle.as_ref().map_or("F", |h| h.value_prefix)),
        }
    }

    /// This effect, bound to the kind `from` is bound to when both are of
    /// the same kind of the user's own (an effect read back from its TOML
    /// form, by `--set` or a family's expansion, is not bound).
    #[must_use]
    pub fn inherit_kind(mut self, from: &SceneEffect) -> Self {
        if let (SceneEffect::User(u), SceneEffect::User(f)) = (&mut self, from)
            && u.kind == f.kind
        {
            u.handle = f.handle.clone();
        }
        self
    }

    /// Binds a kind of the user's own to its reader in `kinds`.
    ///
    /// # Errors
    /// A [`SpecError`] at `kind` for a kind neither built in nor in
    /// `kinds`, listing the known kinds.
    pub fn bind(&mut self, kinds: &EffectKinds) -> Result<(), SpecError> {
        if let SceneEffect::User(u) = self {
            match kinds.get(&u.kind) {
                Some(h) => u.handle = Some(h.clone()),
                None => {
                    return Err(SpecError {
                        field: "kind",
                        message: format!("unknown effect kind `{}`; {}", u.kind, known_kinds(&kinds.names())),
                    });
                }
            }
        }
        Ok(())
    }

    /// The effect as the runtime takes it: the built-in spec, or the
    /// user's table read into its kind.
    ///
    /// # Errors
    /// As [`UserTable::parse`].
    pub fn to_spec(&self) -> Result<EffectSpec, SpecError> {
        match self {
            Self::Builtin(spec) => Ok(spec.clone()),
            Self::User(u) => u.parse(&known_kinds(&[])).map(EffectSpec::User),
        }
    }

    /// Checks names against the model and numbers against their ranges
    /// ([`EffectSpec::check_in`]); a kind of the user's own is read into
    /// its type (its names are checked as it resolves).
    ///
    /// # Errors
    /// [`SpecError`] naming the field.
    pub fn check_in(&self, names: &NameIndex<'_>, scene_params: &[(String, f64)]) -> Result<(), SpecError> {
        self.to_spec()?.check_in(names, scene_params)
    }

    /// Resolves the effect `name` against the model `cx` describes
    /// ([`EffectSpec::resolve_in`]).
    ///
    /// # Errors
    /// [`SetupError::Effect`] naming the field at fault.
    pub fn resolve_in(&self, name: &str, cx: &EffectContext<'_>) -> Result<Effect, SimError> {
        let spec = self.to_spec().map_err(|e| {
            SimError::Setup(SetupError::Effect { effect: name.to_string(), field: e.field, message: e.message })
        })?;
        spec.resolve_in(name, cx)
    }
}
