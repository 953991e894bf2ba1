//! How a parameter is declared: [`Parameter`] (name, ROS type, unit, doc, domain, whether it is
//! fixed while the node runs), the [`Setting`] types a parameter can have, and the
//! `parameters!` macro that turns the table in `params.rs` into [`Config`](super::Config) and
//! [`PARAMETERS`](super::PARAMETERS).

use super::choices::Choice;
pub(crate) use super::error::ValueError;
use serde_yaml_ng::Value;
use std::fmt;

/// The ROS type of a parameter (`rcl_interfaces/msg/ParameterType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RosType {
    /// `PARAMETER_BOOL`.
    Bool,
    /// `PARAMETER_INTEGER`.
    Integer,
    /// `PARAMETER_DOUBLE`.
    Double,
    /// `PARAMETER_STRING`.
    String,
    /// `PARAMETER_DOUBLE_ARRAY` (of a fixed length; the domain bounds each element).
    DoubleArray,
    /// `PARAMETER_STRING_ARRAY`.
    StringArray,
}

impl RosType {
    /// The name `ros2 param describe` prints.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            RosType::Bool => "bool",
            RosType::Integer => "integer",
            RosType::Double => "double",
            RosType::String => "string",
            RosType::DoubleArray => "double_array",
            RosType::StringArray => "string_array",
        }
    }
}

/// The values a parameter may take, enforced on every set and stated by its ROS descriptor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Domain {
    /// Every value of the type.
    Any,
    /// One of these names.
    Choices(&'static [&'static str]),
    /// Integers from `min` to `max`, both included.
    Integer {
        /// Smallest allowed.
        min: i64,
        /// Largest allowed.
        max: i64,
    },
    /// Real numbers from `min` to `max`, both included; finite bounds exclude infinities and NaN.
    Real {
        /// Smallest allowed.
        min: f64,
        /// Largest allowed.
        max: f64,
    },
    /// Real numbers from `min` (included) up to `limit` (excluded): the domain of a value the
    /// solver refuses from `limit` on, so that no setting is accepted that every candidate would
    /// then be refused for.
    Below {
        /// Smallest allowed.
        min: f64,
        /// Least value refused.
        limit: f64,
    },
}

impl Domain {
    /// Every finite real number (no NaN, no infinity).
    pub(crate) const FINITE: Domain = Domain::Real {
        min: f64::MIN,
        max: f64::MAX,
    };

    /// Real numbers `>= min`, finite.
    pub(crate) const fn at_least(min: f64) -> Self {
        Domain::Real { min, max: f64::MAX }
    }

    /// Integers `>= min`.
    pub(crate) const fn at_least_integer(min: i64) -> Self {
        Domain::Integer { min, max: i64::MAX }
    }
}

impl fmt::Display for Domain {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Domain::Any => f.write_str("any"),
            Domain::Choices(names) => write!(f, "one of {}", names.join(", ")),
            Domain::Integer { min, max } if *max == i64::MAX => write!(f, ">= {min}"),
            Domain::Integer { min, max } => write!(f, "in {min}..={max}"),
            Domain::Real { min, max } if *min == f64::MIN && *max == f64::MAX => {
                f.write_str("finite")
            }
            Domain::Real { min, max } if *max == f64::MAX => write!(f, ">= {}", Real(*min)),
            Domain::Real { min, max } => write!(f, "in [{}, {}]", Real(*min), Real(*max)),
            Domain::Below { min, limit } => write!(f, "in [{}, {})", Real(*min), Real(*limit)),
        }
    }
}

/// A double as people write it: plain when moderate, with an exponent when very large or small
/// (`1e300`, not three hundred digits).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Real(pub f64);

impl fmt::Display for Real {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// One declared parameter. The table of them is [`PARAMETERS`](super::PARAMETERS).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Parameter {
    /// The ROS parameter name, and the field of [`Config`](super::Config).
    pub(crate) name: &'static str,
    /// The ROS type.
    pub(crate) ros_type: RosType,
    /// The unit (SI), or empty when it has none.
    pub(crate) unit: &'static str,
    /// What it does, its doc comment's lines joined (each with its leading space; see
    /// [`Parameter::summary`]).
    pub(crate) doc: &'static str,
    /// The values it may take.
    pub(crate) domain: Domain,
    /// Whether it is fixed while the node runs (it shapes the node's endpoints).
    pub(crate) fixed: bool,
}

impl Parameter {
    /// The one line on what it does.
    pub(crate) fn summary(&self) -> &'static str {
        self.doc.trim()
    }
}

/// A type a parameter can have: how it reads from and writes to YAML and ROS, and how it is
/// checked against a [`Domain`].
pub(crate) trait Setting: Sized {
    /// The ROS type of its parameter.
    const ROS_TYPE: RosType;
    /// The domain every value of the type has, unless the declaration narrows it.
    const DOMAIN: Domain = Domain::Any;
    /// Reads a YAML value; `Err` says why not.
    fn from_yaml(value: Value) -> Result<Self, ValueError>;
    /// The YAML value.
    fn to_yaml(&self) -> Value;
    /// `Ok` when the value lies in `domain`; the reason otherwise.
    fn check(&self, _domain: &Domain) -> Result<(), ValueError> {
        Ok(())
    }
}

fn from_serde<T: serde::de::DeserializeOwned>(value: Value) -> Result<T, ValueError> {
    serde_yaml_ng::from_value(value).map_err(|e| ValueError::Type(e.to_string()))
}

impl Setting for bool {
    const ROS_TYPE: RosType = RosType::Bool;
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        from_serde(value)
    }
    fn to_yaml(&self) -> Value {
        Value::Bool(*self)
    }
}

impl Setting for String {
    const ROS_TYPE: RosType = RosType::String;
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        from_serde(value)
    }
    fn to_yaml(&self) -> Value {
        Value::String(self.clone())
    }
}

impl Setting for i64 {
    const ROS_TYPE: RosType = RosType::Integer;
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        from_serde(value)
    }
    fn to_yaml(&self) -> Value {
        Value::Number((*self).into())
    }
    fn check(&self, domain: &Domain) -> Result<(), ValueError> {
        match domain {
            Domain::Integer { min, max } if !(min..=max).contains(&self) => {
                Err(ValueError::Domain {
                    domain: domain.to_string(),
                    value: self.to_string(),
                })
            }
            _ => Ok(()),
        }
    }
}

impl Setting for f64 {
    const ROS_TYPE: RosType = RosType::Double;
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        from_serde(value)
    }
    fn to_yaml(&self) -> Value {
        Value::Number((*self).into())
    }
    fn check(&self, domain: &Domain) -> Result<(), ValueError> {
        match domain {
            // Written so that NaN fails.
            Domain::Real { min, max } if !(*self >= *min && *self <= *max) => {
                Err(ValueError::Domain {
                    domain: domain.to_string(),
                    value: Real(*self).to_string(),
                })
            }
            Domain::Below { min, limit } if !(*self >= *min && *self < *limit) => {
                Err(ValueError::Domain {
                    domain: domain.to_string(),
                    value: Real(*self).to_string(),
                })
            }
            _ => Ok(()),
        }
    }
}

/// Three real numbers (a vector), each checked against the domain.
impl Setting for [f64; 3] {
    const ROS_TYPE: RosType = RosType::DoubleArray;
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        let list: Vec<f64> = from_serde(value)?;
        <[f64; 3]>::try_from(list.as_slice()).map_err(|_| ValueError::Components(list.len()))
    }
    fn to_yaml(&self) -> Value {
        Value::Sequence(self.iter().map(|v| Value::Number((*v).into())).collect())
    }
    fn check(&self, domain: &Domain) -> Result<(), ValueError> {
        for (axis, v) in ["x", "y", "z"].into_iter().zip(self) {
            v.check(domain).map_err(|why| ValueError::Component {
                axis,
                why: Box::new(why),
            })?;
        }
        Ok(())
    }
}

/// A list of strings (`mesh_roots`' directories).
impl Setting for Vec<String> {
    const ROS_TYPE: RosType = RosType::StringArray;
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        from_serde(value)
    }
    fn to_yaml(&self) -> Value {
        Value::Sequence(self.iter().cloned().map(Value::String).collect())
    }
}

impl<T: Choice> Setting for T {
    const ROS_TYPE: RosType = RosType::String;
    const DOMAIN: Domain = Domain::Choices(T::NAMES);
    fn from_yaml(value: Value) -> Result<Self, ValueError> {
        from_serde::<String>(value)?
            .parse::<T>()
            .map_err(|e| ValueError::Name(e.to_string()))
    }
    fn to_yaml(&self) -> Value {
        Value::String(self.to_string())
    }
}

/// Declares the parameters. Each entry is its doc comment (one sentence or two, joined into one
/// line) and one line:
///
/// `NAME [(fixed)]: TYPE = DEFAULT, "UNIT" [, in DOMAIN];`
///
/// The domain defaults to the type's ([`Setting::DOMAIN`]); `(fixed)` marks a parameter that
/// cannot change while the node runs. It generates [`Config`](super::Config) with one documented field
/// per parameter, its `Default`, [`PARAMETERS`](super::PARAMETERS), and by-name access.
macro_rules! parameters {
    ($(
        $(#[doc = $doc:literal])+
        $name:ident $(($fixed:ident))?: $ty:ty = $default:expr, $unit:literal $(, in $domain:expr)?;
    )*) => {
        /// Every setting of grasp_orient, one field per ROS parameter, each value in its domain
        /// once checked ([`Config::solver_settings`]). Declared in `src/config/params.rs`.
        #[derive(Debug, Clone, PartialEq)]
        pub struct Config {
            $(
                $(#[doc = $doc])+
                pub $name: $ty,
            )*
        }

        impl Default for Config {
            fn default() -> Self {
                Self { $( $name: $default, )* }
            }
        }

        /// Every parameter, in declaration order.
        pub(crate) const PARAMETERS: &[$crate::config::declare::Parameter] = &[$(
            $crate::config::declare::Parameter {
                name: stringify!($name),
                ros_type: <$ty as $crate::config::declare::Setting>::ROS_TYPE,
                unit: $unit,
                doc: concat!($($doc),+),
                domain: $crate::config::declare::domain_or!(
                    $($domain)?; <$ty as $crate::config::declare::Setting>::DOMAIN
                ),
                fixed: $crate::config::declare::is_fixed!($($fixed)?),
            },
        )*];

        impl Config {
            /// Sets parameter `name` from a YAML value, checking its type but not its domain.
            pub(crate) fn set_value(
                &mut self,
                name: &str,
                value: ::serde_yaml_ng::Value,
            ) -> Result<(), $crate::config::error::ConfigError> {
                use $crate::config::{declare::Setting, error::ConfigError};
                match name {
                    $(
                        stringify!($name) => {
                            self.$name = Setting::from_yaml(value).map_err(|why| {
                                ConfigError::Value { name: stringify!($name), why }
                            })?;
                        }
                    )*
                    _ => return Err(ConfigError::Unknown { name: name.to_string() }),
                }
                Ok(())
            }

            /// Every parameter as `(name, YAML value)`, in declaration order.
            pub(crate) fn parameters(&self) -> Vec<(&'static str, ::serde_yaml_ng::Value)> {
                use $crate::config::declare::Setting;
                vec![$( (stringify!($name), Setting::to_yaml(&self.$name)), )*]
            }

            /// Checks every value against the domain its declaration states.
            pub(crate) fn check_domains(&self) -> Result<(), $crate::config::error::ConfigError> {
                use $crate::config::{declare::Setting, error::ConfigError};
                let mut declared = PARAMETERS.iter();
                $(
                    if let Some(p) = declared.next() {
                        Setting::check(&self.$name, &p.domain)
                            .map_err(|why| ConfigError::Value { name: p.name, why })?;
                    }
                )*
                Ok(())
            }
        }
    };
}

/// The declared domain, or the type's.
macro_rules! domain_or {
    ($domain:expr; $default:expr) => {
        $domain
    };
    (; $default:expr) => {
        $default
    };
}

/// `fixed` or nothing.
macro_rules! is_fixed {
    () => {
        false
    };
    (fixed) => {
        true
    };
}

pub(crate) use {domain_or, is_fixed, parameters};
