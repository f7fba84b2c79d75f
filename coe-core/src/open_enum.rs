//! The `open_enum!` macro: protocol codes that keep unknown values (smoltcp's `enum_with_unknown!`).
//!
//! A code from the specification becomes a variant; any other value survives a round trip as
//! `Unknown(raw)`, so a parser never rejects a code the specification allows to be extended.

/// Declares an enum with named codes plus `Unknown(raw)` and the two `From` conversions.
///
/// ```
/// coe_core::open_enum! {
///     /// Example codes.
///     pub enum Example(u8) {
///         /// The first one.
///         One = 1,
///     }
/// }
/// assert_eq!(Example::from(1u8), Example::One);
/// assert_eq!(u8::from(Example::Unknown(9)), 9);
/// ```
#[macro_export]
macro_rules! open_enum {
    (
        $( #[$enum_attr:meta] )*
        pub enum $name:ident($ty:ty) {
            $(
              $( #[$variant_attr:meta] )*
              $variant:ident = $value:expr
            ),+ $(,)?
        }
    ) => {
        $( #[$enum_attr] )*
        #[derive(Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Clone, Copy)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum $name {
            $(
              $( #[$variant_attr] )*
              $variant
            ),*,
            /// A value the specification does not name (kept, not rejected).
            Unknown($ty)
        }

        impl $name {
            /// The value for a code (a `const` version of `From`; one copy in the program).
            #[inline(never)]
            pub const fn from_raw(value: $ty) -> Self {
                $( if value == $value { return $name::$variant; } )*
                $name::Unknown(value)
            }
        }

        impl ::core::convert::From<$ty> for $name {
            fn from(value: $ty) -> Self {
                match value {
                    $( value if value == $value => $name::$variant ),*,
                    other => $name::Unknown(other)
                }
            }
        }

        impl ::core::convert::From<$name> for $ty {
            // One copy per enum: a code table compiles to a jump table with a branch per
            // code, too big to repeat at every call site in a 32 KB firmware.
            #[inline(never)]
            fn from(value: $name) -> Self {
                // The codes as a table indexed by the variant's position (a match with a
                // branch per code is bigger).
                const CODES: &[$ty] = &[$( $value ),*];
                let mut position = 0usize;
                $(
                    if let $name::$variant = value {
                        return CODES.get(position).copied().unwrap_or_default();
                    }
                    position += 1;
                )*
                match value {
                    $name::Unknown(other) => other,
                    _ => CODES.get(position).copied().unwrap_or_default(),
                }
            }
        }
    }
}
