//! Knobs: a method's settings, each declared once.
//!
//! [`knobs!`](crate::knobs!) declares a configuration struct from one table: per knob its
//! field, type, default, command-line name, doc line, range, and whether the GPU reads it. It
//! yields the struct with its `Default`, the [`Knobs`] table tools list and edit (`set`, `get`,
//! range checks, the spec that rebuilds a configuration), and for the GPU knobs a `u32` word
//! array with the matching WGSL struct (so a pass's parameters never restate a knob). The
//! generic [`parse_config`] turns a method's variant text (named variants and `key=value`
//! knobs joined by `+`) into a configuration, for every method alike.

use std::ops::RangeInclusive;

use reservoir::reuse::Combination;

/// How tools edit a knob.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KnobKind {
    /// `on` / `off`.
    Switch,
    /// A number (or `auto` where the knob allows it).
    Number,
    /// One of these names.
    Choice(&'static [&'static str]),
}

/// One knob of a configuration as tools list it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Knob {
    /// Command-line name (`spatial-k`).
    pub name: &'static str,
    /// What it does (the field's doc comment).
    pub doc: &'static str,
    pub kind: KnobKind,
}

/// A type a knob can have: how it is parsed, shown, range-checked and read by the GPU.
pub trait KnobValue: Sized + Copy {
    const KIND: KnobKind;
    /// The WGSL type of its GPU word.
    const WGSL: &'static str = "u32";
    fn parse_knob(s: &str) -> Option<Self>;
    fn show_knob(&self) -> String;
    /// Whether the value is allowed by `range` (and is a usable value at all: finite floats).
    fn in_range(&self, range: &RangeInclusive<Self>) -> bool;
    /// The 32-bit word the GPU reads.
    fn gpu_word(&self) -> u32;
}

impl KnobValue for u32 {
    const KIND: KnobKind = KnobKind::Number;
    fn parse_knob(s: &str) -> Option<Self> {
        s.parse().ok()
    }
    fn show_knob(&self) -> String {
        self.to_string()
    }
    fn in_range(&self, range: &RangeInclusive<Self>) -> bool {
        range.contains(self)
    }
    fn gpu_word(&self) -> u32 {
        *self
    }
}

impl KnobValue for f32 {
    const KIND: KnobKind = KnobKind::Number;
    const WGSL: &'static str = "f32";
    fn parse_knob(s: &str) -> Option<Self> {
        s.parse().ok()
    }
    /// Scientific notation outside [1e-3, 1e6] (f32::MAX, a range's open end, was printed
    /// with 39 digits).
    fn show_knob(&self) -> String {
        let a = self.abs();
        if a != 0.0 && !(1e-3..1e6).contains(&a) {
            format!("{self:e}")
        } else {
            self.to_string()
        }
    }
    fn in_range(&self, range: &RangeInclusive<Self>) -> bool {
        self.is_finite() && range.contains(self)
    }
    fn gpu_word(&self) -> u32 {
        self.to_bits()
    }
}

impl KnobValue for bool {
    const KIND: KnobKind = KnobKind::Switch;
    fn parse_knob(s: &str) -> Option<Self> {
        match s {
            "on" | "true" | "1" => Some(true),
            "off" | "false" | "0" => Some(false),
            _ => None,
        }
    }
    fn show_knob(&self) -> String {
        if *self { "on" } else { "off" }.into()
    }
    fn in_range(&self, range: &RangeInclusive<Self>) -> bool {
        range.contains(self)
    }
    fn gpu_word(&self) -> u32 {
        u32::from(*self)
    }
}

/// A count that can also be `auto` (`None`): sized by the method.
impl KnobValue for Option<u32> {
    const KIND: KnobKind = KnobKind::Number;
    fn parse_knob(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(None),
            _ => s.parse().ok().map(Some),
        }
    }
    fn show_knob(&self) -> String {
        self.map_or("auto".into(), |v| v.to_string())
    }
    /// `auto` is always allowed; a count must be within the range's counts.
    fn in_range(&self, range: &RangeInclusive<Self>) -> bool {
        match (self, range.start(), range.end()) {
            (None, _, _) => true,
            (Some(v), Some(lo), Some(hi)) => (lo..=hi).contains(&v),
            _ => false,
        }
    }
    fn gpu_word(&self) -> u32 {
        self.unwrap_or(0)
    }
}

/// [`KnobValue`] for a choice enum `$t` with `$t::ALL: [($t, &str); N]` (each mode and its
/// name, in declaration order, each mode's value its index) and `$t::name`: parsed by name, its
/// GPU word the mode's value, a range allowing the modes between its ends.
#[macro_export]
macro_rules! choice_knob {
    ($t:ty) => {
        impl $crate::knobs::KnobValue for $t {
            const KIND: $crate::knobs::KnobKind = $crate::knobs::KnobKind::Choice(&{
                const ALL: &[($t, &str)] = &<$t>::ALL;
                let mut names = [""; <$t>::ALL.len()];
                let mut i = 0;
                while i < names.len() {
                    names[i] = ALL[i].1;
                    i += 1;
                }
                names
            });
            fn parse_knob(s: &str) -> Option<Self> {
                <$t>::ALL.iter().find(|(_, n)| *n == s).map(|(v, _)| *v)
            }
            fn show_knob(&self) -> String {
                self.name().into()
            }
            fn in_range(&self, range: &std::ops::RangeInclusive<Self>) -> bool {
                (*range.start() as u32..=*range.end() as u32).contains(&(*self as u32))
            }
            fn gpu_word(&self) -> u32 {
                *self as u32
            }
        }
    };
}

choice_knob!(Combination);

/// A configuration declared with [`knobs!`](crate::knobs!).
pub trait Knobs: Default + Copy + PartialEq + std::fmt::Debug + 'static {
    /// Every knob, in declaration order.
    const KNOBS: &'static [Knob];
    /// Sets the knob `key` (its name, with `-` or `_`) from text; errors name the knob.
    fn set(&mut self, key: &str, value: &str) -> Result<(), String>;
    /// The knob's value as `set` takes it back.
    fn get(&self, key: &str) -> Result<String, String>;
    /// Checks every knob against its declared range.
    fn check_ranges(&self) -> Result<(), String>;

    /// The knobs where `self` differs from the default, as `key=value` joined by `+` (the
    /// variant text that rebuilds `self`; empty for the default).
    fn knobs_spec(&self) -> String {
        let default = Self::default();
        Self::KNOBS
            .iter()
            .filter_map(|k| {
                let v = self.get(k.name).ok()?;
                (default.get(k.name).ok()? != v).then(|| format!("{}={v}", k.name))
            })
            .collect::<Vec<_>>()
            .join("+")
    }
}

/// Whether `key` names the knob `name` (`-` and `_` alike).
pub fn is_knob(key: &str, name: &str) -> bool {
    key.len() == name.len()
        && key
            .bytes()
            .zip(name.bytes())
            .all(|(a, b)| a == b || (a == b'_' && b == b'-'))
}

/// The error of a knob name no configuration knows.
pub fn unknown_knob(key: &str, knobs: &[Knob]) -> String {
    let names: Vec<&str> = knobs.iter().map(|k| k.name).collect();
    format!("unknown knob {key:?}; known: {}", names.join(", "))
}

/// A knob's value parsed, or an error naming the knob.
pub fn parse_value<T: KnobValue>(key: &str, value: &str) -> Result<T, String> {
    T::parse_knob(value).ok_or_else(|| match T::KIND {
        KnobKind::Switch => format!("{key}: expected on or off, got {value:?}"),
        KnobKind::Choice(names) => {
            format!("{key}: expected one of {}, got {value:?}", names.join(", "))
        }
        KnobKind::Number => format!("{key}: cannot parse {value:?}"),
    })
}

/// Checks a knob's value against its range; the error names the knob.
pub fn check_range<T: KnobValue>(
    name: &str,
    v: &T,
    range: &RangeInclusive<T>,
) -> Result<(), String> {
    if v.in_range(range) {
        Ok(())
    } else {
        Err(format!(
            "{name} {} must be in {}..={}",
            v.show_knob(),
            range.start().show_knob(),
            range.end().show_knob()
        ))
    }
}

/// A named variant of a method: a name, the knobs it sets (`key=value` each) and what it
/// isolates.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Variant {
    pub name: &'static str,
    pub knobs: Vec<&'static str>,
    pub about: &'static str,
}

impl Variant {
    pub fn new(name: &'static str, knobs: &[&'static str], about: &'static str) -> Self {
        Self {
            name,
            knobs: knobs.to_vec(),
            about,
        }
    }
}

/// The variants every spatiotemporal reuse method has, each isolating what one part buys;
/// `spatial_off` is the knob setting that turns the method's spatial reuse off.
pub fn reuse_variants(spatial_off: &'static str) -> Vec<Variant> {
    vec![
        Variant::new(
            "both",
            &[],
            "temporal + spatial reuse, pairwise MIS (the default)",
        ),
        Variant::new(
            "no-reuse",
            &["temporal=off", spatial_off],
            "no temporal, no spatial reuse",
        ),
        Variant::new("temporal", &[spatial_off], "temporal reuse only"),
        Variant::new("spatial", &["temporal=off"], "spatial reuse only"),
        Variant::new(
            "biased",
            &["combine=biased"],
            "the paper's 1/M weights instead of pairwise MIS",
        ),
    ]
}

/// The configuration a variant text describes: named `variants` and knobs `key=value` joined
/// by `+`, applied in order from the default (`None`: the default). Errors name the part.
pub fn parse_config<C: Knobs>(variants: &[Variant], text: Option<&str>) -> Result<C, String> {
    let mut config = C::default();
    for part in text.into_iter().flat_map(|t| t.split('+')) {
        let knobs = match variants.iter().find(|v| v.name == part) {
            Some(v) => v.knobs.clone(),
            None if part.contains('=') => vec![part],
            None => {
                let names: Vec<&str> = variants.iter().map(|v| v.name).collect();
                return Err(format!(
                    "unknown variant {part:?}; known: {}, or knobs key=value ({})",
                    names.join(", "),
                    C::KNOBS
                        .iter()
                        .map(|k| k.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        };
        for (key, value) in knobs.iter().filter_map(|k| k.split_once('=')) {
            config.set(key, value)?;
        }
    }
    Ok(config)
}

/// Declares a configuration struct from one table of knobs (see the module documentation):
///
/// ```ignore
/// knobs! {
///     /// The configuration's doc.
///     #[derive(Debug, Clone, Copy, PartialEq)]
///     pub struct MyConfig {
///         /// Spatial neighbours per pixel.
///         [gpu] spatial_k: u32 = 4, "spatial-k", 0..=16;
///         /// Temporal reuse.
///         temporal: bool = true, "temporal";
///     }
/// }
/// ```
///
/// `[gpu]` knobs are also in `gpu_words()` (in declaration order, padded to a multiple of 4
/// words) and in the WGSL struct `wgsl_struct(name)`, with the field's name.
#[macro_export]
macro_rules! knobs {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $([$gpu:ident])? $field:ident : $ty:ty = $default:expr, $knob:literal
                    $(, $range:expr)? ;
            )*
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $( $(#[doc = $doc])* pub $field: $ty, )*
        }

        impl Default for $name {
            fn default() -> Self {
                Self { $( $field: $default, )* }
            }
        }

        impl $crate::knobs::Knobs for $name {
            const KNOBS: &'static [$crate::knobs::Knob] = &[
                $( $crate::knobs::Knob {
                    name: $knob,
                    doc: concat!($($doc, "\n"),*),
                    kind: <$ty as $crate::knobs::KnobValue>::KIND,
                }, )*
            ];

            fn set(&mut self, key: &str, value: &str) -> Result<(), String> {
                $( if $crate::knobs::is_knob(key, $knob) {
                    self.$field = $crate::knobs::parse_value(key, value)?;
                    return Ok(());
                } )*
                Err($crate::knobs::unknown_knob(key, Self::KNOBS))
            }

            fn get(&self, key: &str) -> Result<String, String> {
                $( if $crate::knobs::is_knob(key, $knob) {
                    return Ok($crate::knobs::KnobValue::show_knob(&self.$field));
                } )*
                Err($crate::knobs::unknown_knob(key, Self::KNOBS))
            }

            fn check_ranges(&self) -> Result<(), String> {
                $( $( $crate::knobs::check_range($knob, &self.$field, &$range)?; )? )*
                Ok(())
            }
        }

        impl $name {
            /// GPU words of the `[gpu]` knobs (before padding).
            pub const GPU_KNOBS: usize = 0 $( $( + { let _ = stringify!($gpu); 1 } )? )*;
            /// The `[gpu]` knobs' field names, in word order.
            pub const GPU_FIELDS: &'static [&'static str] =
                &[$( $( { let _ = stringify!($gpu); stringify!($field) }, )? )*];
            /// GPU words with padding: a multiple of 4 (16 bytes, a uniform struct's).
            pub const GPU_WORDS: usize = Self::GPU_KNOBS.next_multiple_of(4);

            /// The `[gpu]` knobs as the GPU reads them, in declaration order, zero-padded.
            pub fn gpu_words(&self) -> [u32; Self::GPU_WORDS] {
                let mut words = [0u32; Self::GPU_WORDS];
                let mut _i = 0;
                $( $(
                    let _ = stringify!($gpu);
                    words[_i] = $crate::knobs::KnobValue::gpu_word(&self.$field);
                    _i += 1;
                )? )*
                words
            }

            /// The WGSL struct `name` of [`Self::gpu_words`]: one field per `[gpu]` knob.
            pub fn wgsl_struct(name: &str) -> String {
                let mut s = format!("struct {name} {{\n");
                $( $(
                    let _ = stringify!($gpu);
                    s += &format!("    {}: {},\n", stringify!($field),
                                  <$ty as $crate::knobs::KnobValue>::WGSL);
                )? )*
                // (An empty range when the knobs fill whole 16-byte rows.)
                #[allow(clippy::reversed_empty_ranges)]
                for p in Self::GPU_KNOBS..Self::GPU_WORDS {
                    s += &format!("    _pad{p}: u32,\n");
                }
                s + "}\n"
            }
        }
    };
}

/// Test helper for a stage's knob table: `default` validates and spells as the empty spec;
/// `set` applied in order spells as `spec`; each `(knob, value)` of `refused`, set alone on
/// `default`, is refused by `validate` with an error that names the knob.
#[cfg(test)]
pub(crate) fn assert_knob_table<C: Knobs, E: std::fmt::Display + std::fmt::Debug>(
    default: C,
    validate: impl Fn(&C) -> Result<(), E>,
    set: &[(&str, &str)],
    spec: &str,
    refused: &[(&str, &str)],
) {
    validate(&default).unwrap();
    assert_eq!(default.knobs_spec(), "");
    let mut c = default;
    for (k, v) in set {
        c.set(k, v).unwrap();
    }
    assert_eq!(c.knobs_spec(), spec);
    for (k, v) in refused {
        let mut c = default;
        c.set(k, v).unwrap();
        let e = validate(&c)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(k), "{k}={v}: {e:?}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::knobs! {
        /// A test configuration.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct TestConfig {
            /// A count.
            [gpu] count: u32 = 4, "count", 1..=16;
            /// A switch.
            flag: bool = true, "flag";
            /// A fraction.
            [gpu] fraction: f32 = 0.5, "fraction", 0.0..=1.0;
            /// A size or auto.
            size: Option<u32> = None, "size", Some(1)..=Some(100);
            /// A combination.
            [gpu] combine: Combination = Combination::Pairwise, "combine";
        }
    }

    #[test]
    fn the_table_sets_gets_and_checks() {
        let d = TestConfig::default();
        assert_eq!(d.knobs_spec(), "");
        for k in TestConfig::KNOBS {
            let mut c = d;
            c.set(k.name, &d.get(k.name).unwrap()).unwrap();
            assert_eq!(c, d, "{}", k.name);
        }
        let mut c = d;
        c.set("count", "8").unwrap();
        c.set("flag", "off").unwrap();
        c.set("size", "7").unwrap();
        c.set("combine", "biased").unwrap();
        assert_eq!(c.knobs_spec(), "count=8+flag=off+size=7+combine=biased");
        let again: TestConfig = parse_config(&[], Some(&c.knobs_spec())).unwrap();
        assert_eq!(again, c);
        c.check_ranges().unwrap();
        for (k, v) in [("count", "17"), ("fraction", "NaN"), ("size", "0")] {
            let mut e = d;
            e.set(k, v).unwrap();
            let msg = e.check_ranges().unwrap_err();
            assert!(msg.starts_with(k), "{k}={v}: {msg}");
        }
        for (k, v) in [("nosuch", "1"), ("count", "x"), ("flag", "maybe")] {
            let err = d.clone().set(k, v).unwrap_err();
            assert!(err.contains(k), "{err}");
        }
        assert_eq!(TestConfig::KNOBS[1].kind, KnobKind::Switch);
        assert_eq!(TestConfig::KNOBS[3].doc.trim(), "A size or auto.");
    }

    #[test]
    fn gpu_words_follow_the_wgsl_struct() {
        assert_eq!((TestConfig::GPU_KNOBS, TestConfig::GPU_WORDS), (3, 4));
        assert_eq!(TestConfig::GPU_FIELDS, ["count", "fraction", "combine"]);
        let w = TestConfig::default().gpu_words();
        assert_eq!(w, [4, 0.5f32.to_bits(), Combination::Pairwise as u32, 0]);
        assert_eq!(
            TestConfig::wgsl_struct("K"),
            "struct K {\n    count: u32,\n    fraction: f32,\n    combine: u32,\n    _pad3: u32,\n}\n"
        );
    }

    #[test]
    fn variants_apply_in_order() {
        let variants = [Variant::new("small", &["count=2", "flag=off"], "")];
        let c: TestConfig = parse_config(&variants, Some("small+count=3")).unwrap();
        assert_eq!((c.count, c.flag), (3, false));
        let e = parse_config::<TestConfig>(&variants, Some("bogus")).unwrap_err();
        assert!(e.contains("bogus") && e.contains("small"), "{e}");
        assert!(is_knob("max_count", "max-count") && !is_knob("max-count", "max_count"));
    }
}
