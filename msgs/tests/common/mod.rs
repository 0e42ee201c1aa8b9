//! Test helpers: a small `.msg` parser and a serde serializer that records field kinds.

#![allow(dead_code)]

use std::fmt;

use serde::ser::{self, Serialize};

/// Primitive types of the ROS 2 `.msg` language.
pub const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring",
];

/// Array suffix of a field type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Array {
    None,
    Unbounded,
    Fixed(usize),
    Bounded(usize),
}

/// One field line of a `.msg` file.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Base type as written, without array suffix or string bound (`"float64"`, `"Point"`).
    pub base: String,
    pub array: Array,
    pub name: String,
    /// Default value, if the line has one.
    pub default: Option<String>,
}

/// One constant line of a `.msg` file.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstantLine {
    pub ty: String,
    pub name: String,
    pub value: String,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct MsgSpec {
    pub fields: Vec<Field>,
    pub constants: Vec<ConstantLine>,
}

/// Parses a `.msg` text (field and constant lines; comments and blank lines skipped).
pub fn parse_msg(text: &str) -> Result<MsgSpec, String> {
    let mut spec = MsgSpec::default();
    for (lineno, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (ty, rest) = line
            .split_once(char::is_whitespace)
            .ok_or_else(|| format!("line {}: no field name in {raw:?}", lineno + 1))?;
        let rest = rest.trim_start();
        if ty == "string" || ty.starts_with("string<=") {
            // String constant values run to the end of the line.
            if let Some((name, value)) = rest.split_once('=') {
                let name = name.trim();
                if !name.is_empty() && !name.contains(char::is_whitespace) {
                    spec.constants.push(ConstantLine {
                        ty: ty.to_string(),
                        name: name.to_string(),
                        value: value.trim().to_string(),
                    });
                    continue;
                }
            }
        }
        let rest = rest.split('#').next().unwrap_or("").trim();
        let (name_part, default) = match rest.split_once(char::is_whitespace) {
            Some((n, d)) => (n, Some(d.trim().to_string())),
            None => (rest, None),
        };
        if let Some((name, value)) = name_part.split_once('=') {
            let value = match &default {
                Some(d) if value.is_empty() => d.clone(),
                _ => value.to_string(),
            };
            spec.constants.push(ConstantLine {
                ty: ty.to_string(),
                name: name.to_string(),
                value,
            });
            continue;
        }
        let (base, array) = match ty.split_once('[') {
            None => (ty, Array::None),
            Some((base, suffix)) => {
                let inner = suffix
                    .strip_suffix(']')
                    .ok_or_else(|| format!("line {}: bad array type {ty:?}", lineno + 1))?;
                let array = if inner.is_empty() {
                    Array::Unbounded
                } else if let Some(n) = inner.strip_prefix("<=") {
                    Array::Bounded(n.parse().map_err(|e| format!("line {}: {e}", lineno + 1))?)
                } else {
                    Array::Fixed(
                        inner
                            .parse()
                            .map_err(|e| format!("line {}: {e}", lineno + 1))?,
                    )
                };
                (base, array)
            }
        };
        let base = base.split("<=").next().unwrap_or(base);
        spec.fields.push(Field {
            base: base.to_string(),
            array,
            name: name_part.to_string(),
            default,
        });
    }
    Ok(spec)
}

impl Field {
    /// `Some("pkg/Name")` for a non-primitive type (unqualified names are in `package`).
    pub fn dependency(&self, package: &str) -> Option<String> {
        if PRIMITIVES.contains(&self.base.as_str()) {
            None
        } else if self.base.contains('/') {
            Some(self.base.clone())
        } else {
            Some(format!("{package}/{}", self.base))
        }
    }
}

/// What serde saw for one value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Kind {
    Bool,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
    Str,
    Bytes,
    Seq,
    Tuple(usize),
    Struct(&'static str),
    Other(&'static str),
}

impl Kind {
    /// The kind a `.msg` field type must serialise as.
    pub fn expected(field: &Field) -> Vec<Kind> {
        let scalar = match field.base.as_str() {
            "bool" => Kind::Bool,
            "byte" | "char" | "uint8" => Kind::U8,
            "int8" => Kind::I8,
            "int16" => Kind::I16,
            "uint16" => Kind::U16,
            "int32" => Kind::I32,
            "uint32" => Kind::U32,
            "int64" => Kind::I64,
            "uint64" => Kind::U64,
            "float32" => Kind::F32,
            "float64" => Kind::F64,
            "string" | "wstring" => Kind::Str,
            other => Kind::Struct(leak(other.rsplit('/').next().unwrap_or(other))),
        };
        match field.array {
            Array::None => vec![scalar],
            Array::Fixed(n) => vec![Kind::Tuple(n)],
            Array::Unbounded | Array::Bounded(_) if scalar == Kind::U8 => {
                vec![Kind::Seq, Kind::Bytes]
            }
            Array::Unbounded | Array::Bounded(_) => vec![Kind::Seq],
        }
    }
}

fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

#[derive(Debug)]
pub struct RecordError(String);

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RecordError {}

impl ser::Error for RecordError {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        RecordError(msg.to_string())
    }
}

/// A struct's name and its fields (name, kind) in serialisation order.
pub type StructRecord = (&'static str, Vec<(&'static str, Kind)>);

/// Records the top-level struct of `value`.
pub fn record_fields<T: Serialize>(value: &T) -> Result<StructRecord, RecordError> {
    value.serialize(TopSerializer)
}

struct TopSerializer;

pub struct FieldRecorder {
    name: &'static str,
    fields: Vec<(&'static str, Kind)>,
}

impl ser::SerializeStruct for FieldRecorder {
    type Ok = StructRecord;
    type Error = RecordError;

    fn serialize_field<V: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        value: &V,
    ) -> Result<(), RecordError> {
        self.fields.push((key, value.serialize(KindSerializer)?));
        Ok(())
    }

    fn end(self) -> Result<Self::Ok, RecordError> {
        Ok((self.name, self.fields))
    }
}

macro_rules! not_a_struct {
    ($($method:ident($($arg:ty),*)),* $(,)?) => {
        $(fn $method(self, $(_: $arg),*) -> Result<Self::Ok, RecordError> {
            Err(RecordError(concat!("top level is not a struct: ", stringify!($method)).into()))
        })*
    };
}

impl ser::Serializer for TopSerializer {
    type Ok = StructRecord;
    type Error = RecordError;
    type SerializeSeq = ser::Impossible<Self::Ok, RecordError>;
    type SerializeTuple = ser::Impossible<Self::Ok, RecordError>;
    type SerializeTupleStruct = ser::Impossible<Self::Ok, RecordError>;
    type SerializeTupleVariant = ser::Impossible<Self::Ok, RecordError>;
    type SerializeMap = ser::Impossible<Self::Ok, RecordError>;
    type SerializeStruct = FieldRecorder;
    type SerializeStructVariant = ser::Impossible<Self::Ok, RecordError>;

    fn serialize_struct(
        self,
        name: &'static str,
        len: usize,
    ) -> Result<FieldRecorder, RecordError> {
        Ok(FieldRecorder {
            name,
            fields: Vec::with_capacity(len),
        })
    }

    not_a_struct!(
        serialize_bool(bool),
        serialize_i8(i8),
        serialize_i16(i16),
        serialize_i32(i32),
        serialize_i64(i64),
        serialize_u8(u8),
        serialize_u16(u16),
        serialize_u32(u32),
        serialize_u64(u64),
        serialize_f32(f32),
        serialize_f64(f64),
        serialize_char(char),
        serialize_str(&str),
        serialize_bytes(&[u8]),
        serialize_none(),
        serialize_unit(),
        serialize_unit_struct(&'static str),
        serialize_unit_variant(&'static str, u32, &'static str),
    );

    fn serialize_some<V: ?Sized + Serialize>(self, _: &V) -> Result<Self::Ok, RecordError> {
        Err(RecordError("top level is an Option".into()))
    }
    fn serialize_newtype_struct<V: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: &V,
    ) -> Result<Self::Ok, RecordError> {
        Err(RecordError("top level is a newtype".into()))
    }
    fn serialize_newtype_variant<V: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &V,
    ) -> Result<Self::Ok, RecordError> {
        Err(RecordError("top level is an enum".into()))
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, RecordError> {
        Err(RecordError("top level is a sequence".into()))
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, RecordError> {
        Err(RecordError("top level is a tuple".into()))
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, RecordError> {
        Err(RecordError("top level is a tuple struct".into()))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, RecordError> {
        Err(RecordError("top level is an enum".into()))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, RecordError> {
        Err(RecordError("top level is a map".into()))
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, RecordError> {
        Err(RecordError("top level is an enum".into()))
    }
}

/// Classifies one value without descending into it.
struct KindSerializer;

/// Swallows the elements of a compound value and returns its kind.
pub struct Skip(Kind);

impl ser::SerializeSeq for Skip {
    type Ok = Kind;
    type Error = RecordError;
    fn serialize_element<V: ?Sized + Serialize>(&mut self, _: &V) -> Result<(), RecordError> {
        Ok(())
    }
    fn end(self) -> Result<Kind, RecordError> {
        Ok(self.0)
    }
}

impl ser::SerializeTuple for Skip {
    type Ok = Kind;
    type Error = RecordError;
    fn serialize_element<V: ?Sized + Serialize>(&mut self, _: &V) -> Result<(), RecordError> {
        Ok(())
    }
    fn end(self) -> Result<Kind, RecordError> {
        Ok(self.0)
    }
}

impl ser::SerializeStruct for Skip {
    type Ok = Kind;
    type Error = RecordError;
    fn serialize_field<V: ?Sized + Serialize>(
        &mut self,
        _: &'static str,
        _: &V,
    ) -> Result<(), RecordError> {
        Ok(())
    }
    fn end(self) -> Result<Kind, RecordError> {
        Ok(self.0)
    }
}

macro_rules! kind_of {
    ($($method:ident($arg:ty) => $kind:expr),* $(,)?) => {
        $(fn $method(self, _: $arg) -> Result<Kind, RecordError> { Ok($kind) })*
    };
}

impl ser::Serializer for KindSerializer {
    type Ok = Kind;
    type Error = RecordError;
    type SerializeSeq = Skip;
    type SerializeTuple = Skip;
    type SerializeTupleStruct = ser::Impossible<Kind, RecordError>;
    type SerializeTupleVariant = ser::Impossible<Kind, RecordError>;
    type SerializeMap = ser::Impossible<Kind, RecordError>;
    type SerializeStruct = Skip;
    type SerializeStructVariant = ser::Impossible<Kind, RecordError>;

    kind_of!(
        serialize_bool(bool) => Kind::Bool, serialize_i8(i8) => Kind::I8,
        serialize_i16(i16) => Kind::I16, serialize_i32(i32) => Kind::I32,
        serialize_i64(i64) => Kind::I64, serialize_u8(u8) => Kind::U8,
        serialize_u16(u16) => Kind::U16, serialize_u32(u32) => Kind::U32,
        serialize_u64(u64) => Kind::U64, serialize_f32(f32) => Kind::F32,
        serialize_f64(f64) => Kind::F64, serialize_char(char) => Kind::Other("char"),
        serialize_str(&str) => Kind::Str, serialize_bytes(&[u8]) => Kind::Bytes,
        serialize_unit_struct(&'static str) => Kind::Other("unit struct"),
    );

    fn serialize_none(self) -> Result<Kind, RecordError> {
        Ok(Kind::Other("option"))
    }
    fn serialize_unit(self) -> Result<Kind, RecordError> {
        Ok(Kind::Other("unit"))
    }
    fn serialize_some<V: ?Sized + Serialize>(self, _: &V) -> Result<Kind, RecordError> {
        Ok(Kind::Other("option"))
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
    ) -> Result<Kind, RecordError> {
        Ok(Kind::Other("enum"))
    }
    fn serialize_newtype_struct<V: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: &V,
    ) -> Result<Kind, RecordError> {
        Ok(Kind::Other("newtype"))
    }
    fn serialize_newtype_variant<V: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &V,
    ) -> Result<Kind, RecordError> {
        Ok(Kind::Other("enum"))
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Skip, RecordError> {
        Ok(Skip(Kind::Seq))
    }
    fn serialize_tuple(self, len: usize) -> Result<Skip, RecordError> {
        Ok(Skip(Kind::Tuple(len)))
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, RecordError> {
        Err(RecordError("tuple struct field".into()))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, RecordError> {
        Err(RecordError("enum field".into()))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, RecordError> {
        Err(RecordError("map field".into()))
    }
    fn serialize_struct(self, name: &'static str, _: usize) -> Result<Skip, RecordError> {
        Ok(Skip(Kind::Struct(name)))
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, RecordError> {
        Err(RecordError("enum field".into()))
    }
}
