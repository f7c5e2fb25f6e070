//! The parameter dictionary every table reader reads its keys from (after pbrt-v4's
//! `ParameterDictionary`).
//!
//! A scene file is parsed into spanned [`Value`]s (every key and value keeps its byte range,
//! so errors name the line). Each table type's reader opens its table as a [`Dict`] with the
//! list of keys that type takes ([`Keys`]) and reads them with typed getters that validate
//! (finite, in range, non-zero, ...) and record what was read. A key the type does not take
//! is an error naming the file, line and key and the keys the type takes, with a "did you
//! mean" for a near miss; [`Dict::finish`] makes the same error for a key nobody read.
//!
//! The key lists are the ones in each reader's doc-comment parameter table; a test checks
//! both against `docs/scene-format.md` (see `crate::reference`).

use crate::error::SceneError;
use crate::loader::Loader;
use glam::Vec3;
use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use std::cell::RefCell;
use std::fmt;
use std::ops::Range;
use toml::Spanned;

/// A spanned value: the value and its byte range in the file.
pub(crate) type S<T> = Spanned<T>;

/// A TOML value whose nested keys and values keep their spans.
#[derive(Clone, Debug)]
pub(crate) enum Value {
    String(String),
    Integer(i64),
    Float(f64),
    Boolean(bool),
    Array(Vec<S<Value>>),
    Table(Table),
}

/// A TOML table in file order, keys and values spanned.
#[derive(Clone, Debug, Default)]
pub(crate) struct Table(pub(crate) Vec<(S<String>, S<Value>)>);

impl Table {
    /// The entries in file order.
    pub(crate) fn iter(&self) -> std::slice::Iter<'_, (S<String>, S<Value>)> {
        self.0.iter()
    }
}

impl<'de> Deserialize<'de> for Table {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match Value::deserialize(d)? {
            Value::Table(t) => Ok(t),
            other => Err(de::Error::custom(format!(
                "expected a table, got {}",
                other.type_name()
            ))),
        }
    }
}

impl Value {
    /// The TOML type's name, for messages ("a string", "an array").
    pub(crate) fn type_name(&self) -> &'static str {
        match self {
            Value::String(_) => "a string",
            Value::Integer(_) => "an integer",
            Value::Float(_) => "a float",
            Value::Boolean(_) => "a boolean",
            Value::Array(_) => "an array",
            Value::Table(_) => "a table",
        }
    }

    /// The plain `toml` value (spans dropped), for parts read by serde types.
    pub(crate) fn to_toml(&self) -> toml::Value {
        match self {
            Value::String(s) => toml::Value::String(s.clone()),
            Value::Integer(i) => toml::Value::Integer(*i),
            Value::Float(f) => toml::Value::Float(*f),
            Value::Boolean(b) => toml::Value::Boolean(*b),
            Value::Array(a) => {
                toml::Value::Array(a.iter().map(|v| v.get_ref().to_toml()).collect())
            }
            Value::Table(t) => toml::Value::Table(table_to_toml(t)),
        }
    }

    /// The number as `f64` (integers too), or `None`.
    pub(crate) fn number(&self) -> Option<f64> {
        match self {
            Value::Integer(i) => Some(*i as f64),
            Value::Float(f) => Some(*f),
            _ => None,
        }
    }
}

/// [`Value::to_toml`] of a table.
pub(crate) fn table_to_toml(t: &Table) -> toml::Table {
    t.iter()
        .map(|(k, v)| (k.get_ref().clone(), v.get_ref().to_toml()))
        .collect()
}

impl<'de> Deserialize<'de> for Value {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Value;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a TOML value")
            }
            fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
                Ok(Value::Boolean(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
                Ok(Value::Integer(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Value, E> {
                i64::try_from(v)
                    .map(Value::Integer)
                    .map_err(|_| E::custom(format!("integer {v} is too large")))
            }
            fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
                Ok(Value::Float(v))
            }
            fn visit_str<E>(self, v: &str) -> Result<Value, E> {
                Ok(Value::String(v.to_owned()))
            }
            fn visit_string<E>(self, v: String) -> Result<Value, E> {
                Ok(Value::String(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
                let mut out = Vec::new();
                while let Some(v) = seq.next_element::<S<Value>>()? {
                    out.push(v);
                }
                Ok(Value::Array(out))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
                let mut out = Vec::new();
                while let Some(k) = map.next_key::<S<String>>()? {
                    out.push((k, map.next_value::<S<Value>>()?));
                }
                Ok(Value::Table(Table(out)))
            }
        }
        d.deserialize_any(V)
    }
}

/// The TOML type a key takes; checked for every key of the file before any table is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A string (a path, a name, an option).
    Str,
    /// An integer.
    Int,
    /// A number (integer or float).
    Num,
    /// `true` or `false`.
    Bool,
    /// Three numbers `[x, y, z]`.
    Vec3,
    /// One number or three `[r, g, b]` (a colour, a scale).
    Color,
    /// A table.
    Table,
    /// An array.
    Array,
}

impl Kind {
    /// Whether `v` has this type.
    fn accepts(self, v: &Value) -> bool {
        match self {
            Kind::Str => matches!(v, Value::String(_)),
            Kind::Int => matches!(v, Value::Integer(_)),
            Kind::Num => v.number().is_some(),
            Kind::Bool => matches!(v, Value::Boolean(_)),
            Kind::Vec3 => three_numbers(v).is_some(),
            Kind::Color => v.number().is_some() || three_numbers(v).is_some(),
            Kind::Table => matches!(v, Value::Table(_)),
            Kind::Array => matches!(v, Value::Array(_)),
        }
    }

    /// What this type is, for messages.
    fn describe(self) -> &'static str {
        match self {
            Kind::Str => "a string",
            Kind::Int => "an integer",
            Kind::Num => "a number",
            Kind::Bool => "true or false",
            Kind::Vec3 => "three numbers [x, y, z]",
            Kind::Color => "a number or an array of three numbers [r, g, b]",
            Kind::Table => "a table",
            Kind::Array => "an array",
        }
    }
}

/// A key and the TOML type it takes.
pub(crate) type Key = (&'static str, Kind);

/// The keys of one table type, as its reader's doc-comment table lists them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Keys {
    /// The keys this type takes (besides `type`), in the order messages list them.
    pub(crate) own: &'static [Key],
    /// Keys every type of this table takes (objects: name, material, transform, ...),
    /// listed after `own` in messages.
    pub(crate) common: &'static [Key],
    /// The table takes a `type` key.
    pub(crate) typed: bool,
}

impl Keys {
    /// Keys of a table with no types (`[camera]`, `[film]`).
    pub(crate) const fn plain(own: &'static [Key]) -> Keys {
        Keys {
            own,
            common: &[],
            typed: false,
        }
    }

    /// The type of `key` if this table type takes it (`type` is a string).
    fn kind_of(&self, key: &str) -> Option<Kind> {
        if self.typed && key == "type" {
            return Some(Kind::Str);
        }
        self.own
            .iter()
            .chain(self.common)
            .find(|(k, _)| *k == key)
            .map(|&(_, kind)| kind)
    }

    fn takes(&self, key: &str) -> bool {
        self.kind_of(key).is_some()
    }
}

/// One table opened for reading: its keys, what was read, and where errors point.
pub(crate) struct Dict<'a> {
    pub(crate) ld: &'a Loader,
    /// The table's key in messages: `film`, `light[2]`, `object[0].instances[1]`.
    pub(crate) at: String,
    /// The table's `type`, when it has one.
    pub(crate) kind: Option<&'a str>,
    /// The table's span (from its header).
    pub(crate) span: Range<usize>,
    table: &'a Table,
    keys: Keys,
    /// The keys of the other types of this table's family (lights, materials, ...): a key
    /// of theirs is "not a key of a light of type 'sun'", reported at the table's line.
    siblings: Vec<Keys>,
    read: RefCell<Vec<&'a str>>,
}

impl<'a> Dict<'a> {
    /// Opens `table` (spanned by `span`) as `at`, of type `kind`, taking `keys`; a key it
    /// does not take is an error at once.
    pub(crate) fn open(
        ld: &'a Loader,
        at: impl Into<String>,
        kind: Option<&'a str>,
        span: Range<usize>,
        table: &'a Table,
        keys: Keys,
    ) -> Result<Dict<'a>, SceneError> {
        Self::open_among(ld, at, kind, span, table, keys, Vec::new())
    }

    /// [`Self::open`] for a table of a family of types whose keys are `siblings` (all of
    /// them, this type's included).
    pub(crate) fn open_among(
        ld: &'a Loader,
        at: impl Into<String>,
        kind: Option<&'a str>,
        span: Range<usize>,
        table: &'a Table,
        keys: Keys,
        siblings: Vec<Keys>,
    ) -> Result<Dict<'a>, SceneError> {
        let d = Dict {
            ld,
            at: at.into(),
            kind,
            span,
            table,
            keys,
            siblings,
            read: RefCell::new(Vec::new()),
        };
        if let Some((k, _)) = d.table.iter().find(|(k, _)| !keys.takes(k.get_ref())) {
            return Err(d.not_taken(k));
        }
        for (k, v) in d.table.iter() {
            if let Some(kind) = keys.kind_of(k.get_ref())
                && !kind.accepts(v.get_ref())
            {
                return Err(d.wrong_type(v, k.get_ref(), kind.describe()));
            }
        }
        if keys.typed {
            d.mark("type");
        }
        Ok(d)
    }

    /// The dotted key of `name` in this table.
    pub(crate) fn key(&self, name: &str) -> String {
        format!("{}.{name}", self.at)
    }

    /// An error at `span` about key `name` of this table.
    pub(crate) fn err(&self, span: Range<usize>, name: &str, msg: impl Into<String>) -> SceneError {
        self.ld.err(span, self.key(name), msg)
    }

    fn mark(&self, name: &str) {
        if let Some((k, _)) = self.table.iter().find(|(k, _)| k.get_ref() == name) {
            self.read.borrow_mut().push(k.get_ref().as_str());
        }
    }

    /// The raw value of `name`, recorded as read.
    pub(crate) fn get(&self, name: &str) -> Option<&'a S<Value>> {
        // A reader reading a key its list does not name is a bug (its doc table and the
        // reference would not show the key): fail loudly, in tests and in use.
        assert!(
            self.keys.takes(name),
            "{}: reads '{name}', which its key list does not name",
            self.at
        );
        let v = self.table.iter().find(|(k, _)| k.get_ref() == name)?;
        self.mark(name);
        Some(&v.1)
    }

    /// Every key was read: a key given but read by nobody is an error, as in [`Self::open`].
    pub(crate) fn finish(self) -> Result<(), SceneError> {
        let read = self.read.borrow();
        match self
            .table
            .iter()
            .find(|(k, _)| !read.contains(&k.get_ref().as_str()))
        {
            Some((k, _)) => Err(self.not_taken(k)),
            None => Ok(()),
        }
    }

    /// The error for a key this type does not take.
    fn not_taken(&self, k: &S<String>) -> SceneError {
        let name = k.get_ref().as_str();
        let mut takes: Vec<&str> = Vec::new();
        if self.keys.typed {
            takes.push("type");
        }
        takes.extend(self.keys.own.iter().map(|&(k, _)| k));
        let a_siblings_key = self
            .siblings
            .iter()
            .any(|s| s.own.iter().any(|&(k, _)| k == name));
        if let (Some(kind), true) = (self.kind, a_siblings_key) {
            let common = if self.keys.common.is_empty() {
                String::new()
            } else {
                let names: Vec<&str> = self.keys.common.iter().map(|&(k, _)| k).collect();
                format!(
                    ", and on every {}: {}",
                    self.family_name(),
                    names.join(", ")
                )
            };
            return self.ld.err(
                self.span.clone(),
                self.key(name),
                format!(
                    "is not a key of a {} of type '{kind}' (it takes: {}{common})",
                    self.at,
                    takes.join(", ")
                ),
            );
        }
        takes.extend(self.keys.common.iter().map(|&(k, _)| k));
        let hint = did_you_mean(name, &takes)
            .map(|s| format!(" (did you mean `{s}`?)"))
            .unwrap_or_default();
        let list: Vec<String> = takes.iter().map(|t| format!("`{t}`")).collect();
        self.ld.err(
            k.span(),
            self.key(name),
            format!(
                "unknown field `{name}`{hint}, expected one of {}",
                list.join(", ")
            ),
        )
    }

    /// `object` for `object[3]`.
    fn family_name(&self) -> &str {
        self.at.split('[').next().unwrap_or(&self.at)
    }

    /// An error: `name` has the wrong TOML type.
    fn wrong_type(&self, v: &S<Value>, name: &str, want: &str) -> SceneError {
        self.err(
            v.span(),
            name,
            format!("must be {want}, got {}", v.get_ref().type_name()),
        )
    }

    /// An error: `name` is required for this type.
    pub(crate) fn missing(&self, name: &str) -> SceneError {
        let msg = match self.kind {
            Some(kind) => format!("is required for type '{kind}'"),
            None => "is required".to_string(),
        };
        self.err(self.span.clone(), name, msg)
    }

    /// A string (a file path, a name, an option), spanned.
    pub(crate) fn string(&self, name: &str) -> Result<Option<S<&'a str>>, SceneError> {
        self.get(name)
            .map(|v| match v.get_ref() {
                Value::String(s) => Ok(S::new(v.span(), s.as_str())),
                _ => Err(self.wrong_type(v, name, "a string")),
            })
            .transpose()
    }

    /// One of the named `options` (absent: `default`); another string is an error naming
    /// it as an unknown `what` and listing the options.
    pub(crate) fn choice<T: Copy>(
        &self,
        name: &str,
        what: &str,
        options: &[(&str, T)],
        default: T,
    ) -> Result<T, SceneError> {
        let Some(v) = self.string(name)? else {
            return Ok(default);
        };
        match options.iter().find(|(n, _)| *n == *v.get_ref()) {
            Some(&(_, t)) => Ok(t),
            None => {
                let names: Vec<&str> = options.iter().map(|(n, _)| *n).collect();
                Err(self.err(
                    v.span(),
                    name,
                    format!("unknown {what} '{}' ({})", v.get_ref(), names.join(", ")),
                ))
            }
        }
    }

    /// A required string.
    pub(crate) fn req_string(&self, name: &str) -> Result<S<&'a str>, SceneError> {
        self.string(name)?.ok_or_else(|| self.missing(name))
    }

    /// A boolean.
    pub(crate) fn boolean(&self, name: &str) -> Result<Option<bool>, SceneError> {
        self.get(name)
            .map(|v| match v.get_ref() {
                Value::Boolean(b) => Ok(*b),
                _ => Err(self.wrong_type(v, name, "true or false")),
            })
            .transpose()
    }

    /// A number in `[min, max]` (`(min, max]` when `open_min`).
    pub(crate) fn float_opt(
        &self,
        name: &str,
        min: f32,
        max: f32,
        open_min: bool,
    ) -> Result<Option<f32>, SceneError> {
        let Some(v) = self.get(name) else {
            return Ok(None);
        };
        let x = v
            .get_ref()
            .number()
            .ok_or_else(|| self.wrong_type(v, name, "a number"))? as f32;
        let ok = x.is_finite() && x <= max && if open_min { x > min } else { x >= min };
        if !ok {
            let lo = if open_min { "(" } else { "[" };
            return Err(self.err(
                v.span(),
                name,
                format!("must be in {lo}{min}, {max}], got {x}"),
            ));
        }
        Ok(Some(x))
    }

    /// [`Self::float_opt`], `default` when absent.
    pub(crate) fn float(
        &self,
        name: &str,
        min: f32,
        max: f32,
        open_min: bool,
        default: f32,
    ) -> Result<f32, SceneError> {
        Ok(self.float_opt(name, min, max, open_min)?.unwrap_or(default))
    }

    /// A required number in range.
    pub(crate) fn req_float(
        &self,
        name: &str,
        min: f32,
        max: f32,
        open_min: bool,
    ) -> Result<f32, SceneError> {
        self.float_opt(name, min, max, open_min)?
            .ok_or_else(|| self.missing(name))
    }

    /// An integer in `[min, max]`.
    pub(crate) fn count_opt(
        &self,
        name: &str,
        min: i64,
        max: i64,
    ) -> Result<Option<u32>, SceneError> {
        let Some(v) = self.get(name) else {
            return Ok(None);
        };
        let Value::Integer(x) = *v.get_ref() else {
            return Err(self.wrong_type(v, name, "an integer"));
        };
        if x < min || x > max {
            return Err(self.err(
                v.span(),
                name,
                format!("must be an integer in [{min}, {max}], got {x}"),
            ));
        }
        Ok(Some(x as u32))
    }

    /// [`Self::count_opt`], `default` when absent.
    pub(crate) fn count(
        &self,
        name: &str,
        min: i64,
        max: i64,
        default: u32,
    ) -> Result<u32, SceneError> {
        Ok(self.count_opt(name, min, max)?.unwrap_or(default))
    }

    /// Three numbers `[x, y, z]`, finite.
    pub(crate) fn vec3_opt(&self, name: &str) -> Result<Option<S<Vec3>>, SceneError> {
        let Some(v) = self.get(name) else {
            return Ok(None);
        };
        let a = three_numbers(v.get_ref())
            .ok_or_else(|| self.wrong_type(v, name, "three numbers [x, y, z]"))?;
        if a.iter().any(|c| !c.is_finite()) {
            return Err(self.err(
                v.span(),
                name,
                format!("must be three finite numbers, got {a:?}"),
            ));
        }
        Ok(Some(S::new(v.span(), Vec3::from(a))))
    }

    /// A required `[x, y, z]`.
    pub(crate) fn req_vec3(&self, name: &str) -> Result<Vec3, SceneError> {
        Ok(self.req_vec3_spanned(name)?.into_inner())
    }

    /// A required `[x, y, z]` with its span.
    pub(crate) fn req_vec3_spanned(&self, name: &str) -> Result<S<Vec3>, SceneError> {
        self.vec3_opt(name)?.ok_or_else(|| self.missing(name))
    }

    /// A non-zero direction, normalised.
    pub(crate) fn direction_opt(&self, name: &str) -> Result<Option<Vec3>, SceneError> {
        let Some(v) = self.vec3_opt(name)? else {
            return Ok(None);
        };
        if v.get_ref().length_squared() < 1e-12 {
            return Err(self.err(v.span(), name, "must be a non-zero direction"));
        }
        Ok(Some(v.get_ref().normalize()))
    }

    /// A required direction.
    pub(crate) fn req_direction(&self, name: &str) -> Result<Vec3, SceneError> {
        self.direction_opt(name)?.ok_or_else(|| self.missing(name))
    }

    /// A colour: one number (grey) or `[r, g, b]`, linear, finite, >= 0 and at most `max`.
    pub(crate) fn color_opt(
        &self,
        name: &str,
        max: Option<f32>,
    ) -> Result<Option<Vec3>, SceneError> {
        let Some(v) = self.get(name) else {
            return Ok(None);
        };
        let c = match v.get_ref() {
            Value::Integer(_) | Value::Float(_) => {
                Vec3::splat(v.get_ref().number().unwrap_or(0.0) as f32)
            }
            other => Vec3::from(three_numbers(other).ok_or_else(|| {
                self.wrong_type(v, name, "a number or an array of three numbers [r, g, b]")
            })?),
        };
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(self.err(
                v.span(),
                name,
                format!("must be finite and >= 0, got {:?}", c.to_array()),
            ));
        }
        if let Some(m) = max
            && c.max_element() > m
        {
            return Err(self.err(
                v.span(),
                name,
                format!("must be in [0, {m}], got {:?}", c.to_array()),
            ));
        }
        Ok(Some(c))
    }

    /// A required colour.
    pub(crate) fn req_color(&self, name: &str) -> Result<Vec3, SceneError> {
        self.color_opt(name, None)?
            .ok_or_else(|| self.missing(name))
    }

    /// A number as given (finite or not; the caller validates), spanned.
    pub(crate) fn raw_float(&self, name: &str) -> Result<Option<S<f32>>, SceneError> {
        self.get(name)
            .map(|v| {
                let x = v
                    .get_ref()
                    .number()
                    .ok_or_else(|| self.wrong_type(v, name, "a number"))?;
                Ok(S::new(v.span(), x as f32))
            })
            .transpose()
    }

    /// `[x, y, z]` as given (finite or not; the caller validates), spanned.
    pub(crate) fn raw_vec3(&self, name: &str) -> Result<Option<S<Vec3>>, SceneError> {
        self.get(name)
            .map(|v| {
                let a = three_numbers(v.get_ref())
                    .ok_or_else(|| self.wrong_type(v, name, "three numbers [x, y, z]"))?;
                Ok(S::new(v.span(), Vec3::from(a)))
            })
            .transpose()
    }

    /// One number (all three components) or `[x, y, z]`, as given, spanned.
    pub(crate) fn raw_scale(&self, name: &str) -> Result<Option<S<Vec3>>, SceneError> {
        self.get(name)
            .map(|v| {
                let c = match v.get_ref() {
                    Value::Integer(_) | Value::Float(_) => {
                        Vec3::splat(v.get_ref().number().unwrap_or(0.0) as f32)
                    }
                    other => Vec3::from(three_numbers(other).ok_or_else(|| {
                        self.wrong_type(v, name, "a number or an array of three numbers")
                    })?),
                };
                Ok(S::new(v.span(), c))
            })
            .transpose()
    }

    /// A sub-table (inline or `[a.b]`), spanned.
    pub(crate) fn table(&self, name: &str) -> Result<Option<S<&'a Table>>, SceneError> {
        self.get(name)
            .map(|v| match v.get_ref() {
                Value::Table(t) => Ok(S::new(v.span(), t)),
                _ => Err(self.wrong_type(v, name, "a table")),
            })
            .transpose()
    }

    /// An array, spanned.
    pub(crate) fn array(&self, name: &str) -> Result<Option<S<&'a [S<Value>]>>, SceneError> {
        self.get(name)
            .map(|v| match v.get_ref() {
                Value::Array(a) => Ok(S::new(v.span(), a.as_slice())),
                _ => Err(self.wrong_type(v, name, "an array")),
            })
            .transpose()
    }
}

/// The required `type` of table `at` (`light[2]`), a string.
pub(crate) fn type_of<'a>(
    ld: &Loader,
    at: &str,
    t: &'a S<Table>,
) -> Result<S<&'a str>, SceneError> {
    match t.get_ref().iter().find(|(k, _)| k.get_ref() == "type") {
        None => Err(ld.err(t.span(), format!("{at}.type"), "missing field `type`")),
        Some((_, v)) => match v.get_ref() {
            Value::String(s) => Ok(S::new(v.span(), s.as_str())),
            other => Err(ld.err(
                v.span(),
                format!("{at}.type"),
                format!("must be a string, got {}", other.type_name()),
            )),
        },
    }
}

/// A family of typed tables (`[[light]]`, `[[material]]`, `[[object]]`): each type's
/// name, keys and reader.
pub(crate) type Types<R> = [(&'static str, Keys, R)];

/// The `type` of table `at` of `family` and its entry in `types`, or an error listing the
/// family's types.
pub(crate) fn type_entry<'a, 't, R>(
    ld: &Loader,
    family: &str,
    at: &str,
    t: &'a S<Table>,
    types: &'t Types<R>,
) -> Result<(S<&'a str>, Keys, &'t R), SceneError> {
    let kind = type_of(ld, at, t)?;
    match types.iter().find(|(name, ..)| name == kind.get_ref()) {
        Some((_, keys, reader)) => Ok((kind, *keys, reader)),
        None => {
            let names: Vec<&str> = types.iter().map(|(n, ..)| *n).collect();
            Err(ld.err(
                kind.span(),
                format!("{at}.type"),
                format!(
                    "unknown {family} type '{}' ({})",
                    kind.get_ref(),
                    names.join(", ")
                ),
            ))
        }
    }
}

/// The keys of every type of a family.
pub(crate) fn sibling_keys<R>(types: &Types<R>) -> Vec<Keys> {
    types.iter().map(|(_, keys, _)| *keys).collect()
}

/// Opens table `at` of `family` with the keys of its type; also returns the type's reader.
pub(crate) fn open_typed<'a, 't, R>(
    ld: &'a Loader,
    family: &str,
    at: String,
    t: &'a S<Table>,
    types: &'t Types<R>,
) -> Result<(Dict<'a>, &'t R), SceneError> {
    let (kind, keys, reader) = type_entry(ld, family, &at, t, types)?;
    let d = Dict::open_among(
        ld,
        at,
        Some(kind.into_inner()),
        t.span(),
        t.get_ref(),
        keys,
        sibling_keys(types),
    )?;
    Ok((d, reader))
}

/// `[a, b, c]` of numbers.
fn three_numbers(v: &Value) -> Option<[f32; 3]> {
    let Value::Array(a) = v else { return None };
    if a.len() != 3 {
        return None;
    }
    let mut out = [0.0f32; 3];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x.get_ref().number()? as f32;
    }
    Some(out)
}

/// The key in `takes` nearest to `name` when it is a likely typo: edit distance at most 2
/// (1 for short keys), or `name` a prefix of it.
pub(crate) fn did_you_mean<'k>(name: &str, takes: &[&'k str]) -> Option<&'k str> {
    let limit = if name.len() <= 4 { 1 } else { 2 };
    takes
        .iter()
        .map(|t| (edit_distance(name, t), *t))
        .filter(|&(d, t)| d <= limit || (name.len() >= 3 && t.starts_with(name)))
        .min_by_key(|&(d, _)| d)
        .map(|(_, t)| t)
}

/// Levenshtein distance (insertions, deletions, substitutions), on bytes.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, &ca) in a.iter().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1)
                .min(row[j] + 1)
                .min(diag + usize::from(ca != cb));
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_misses_are_suggested() {
        let takes = ["width", "height", "spp", "filter", "exposure", "tonemap"];
        assert_eq!(did_you_mean("widht", &takes), Some("width"));
        assert_eq!(did_you_mean("exposur", &takes), Some("exposure"));
        assert_eq!(did_you_mean("tone", &takes), Some("tonemap"));
        assert_eq!(did_you_mean("sp", &takes), Some("spp"));
        assert_eq!(did_you_mean("samples", &takes), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
    }
}
