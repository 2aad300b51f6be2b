//! The schema fingerprint: a 32-bit FNV-1a hash of the shape of every wire type, computed
//! at compile time (a `const`, so it costs the firmware four bytes of flash).
//!
//! Every wire type is declared through [`wire_struct!`] or [`wire_enum!`], which emit the
//! type exactly as written and, from the same tokens, its [`Schema::SCHEMA_HASH`]: the
//! type's name, then in order each field's (or variant's) name and the hash of its type.
//! So adding, removing, reordering, renaming or retyping a field or a variant changes the
//! hash of the type and of every message that contains it; no list is kept by hand.
//! Primitives hash their postcard kind (`u16` is a varint, `u8` a byte, `f32` four bytes…),
//! arrays their element and length, `Option`/`Result` their arguments.

/// FNV-1a offset basis (32 bit).
pub const FNV_OFFSET: u32 = 0x811C_9DC5;
const FNV_PRIME: u32 = 0x0100_0193;

/// FNV-1a over `bytes`, continuing from `h`.
pub const fn fnv_bytes(mut h: u32, bytes: &[u8]) -> u32 {
    let mut i = 0;
    while i < bytes.len() {
        h ^= bytes[i] as u32;
        h = h.wrapping_mul(FNV_PRIME);
        i += 1;
    }
    h
}

// the published FNV-1a test vectors, checked at every build: `params_hash` and the schema
// fingerprint both hash with this one function
const _: () = assert!(fnv_bytes(FNV_OFFSET, b"") == 0x811C_9DC5);
const _: () = assert!(fnv_bytes(FNV_OFFSET, b"a") == 0xE40C_292C);
const _: () = assert!(fnv_bytes(FNV_OFFSET, b"foobar") == 0xBF9C_F968);

pub const fn fnv_str(h: u32, s: &str) -> u32 {
    fnv_bytes(h, s.as_bytes())
}

pub const fn fnv_u32(h: u32, v: u32) -> u32 {
    fnv_bytes(h, &v.to_le_bytes())
}

/// One named member (field or variant) of a type: its name, then its type's hash.
pub const fn member(h: u32, name: &str, ty: u32) -> u32 {
    fnv_u32(fnv_str(fnv_str(h, name), ":"), ty)
}

/// The shape of a wire type, as a hash (see the module doc).
pub trait Schema {
    const SCHEMA_HASH: u32;
}

macro_rules! primitive {
    ($($t:ty),*) => {
        $(impl Schema for $t {
            const SCHEMA_HASH: u32 = fnv_str(FNV_OFFSET, stringify!($t));
        })*
    };
}
primitive!(bool, u8, u16, u32, u64, i8, i16, i32, i64, f32, f64);

impl Schema for () {
    const SCHEMA_HASH: u32 = fnv_str(FNV_OFFSET, "()");
}

impl<T: Schema, const N: usize> Schema for [T; N] {
    const SCHEMA_HASH: u32 = fnv_u32(
        fnv_u32(fnv_str(FNV_OFFSET, "[;]"), T::SCHEMA_HASH),
        N as u32,
    );
}

impl<T: Schema> Schema for Option<T> {
    const SCHEMA_HASH: u32 = fnv_u32(fnv_str(FNV_OFFSET, "Option"), T::SCHEMA_HASH);
}

impl<T: Schema, E: Schema> Schema for Result<T, E> {
    const SCHEMA_HASH: u32 = fnv_u32(
        fnv_u32(fnv_str(FNV_OFFSET, "Result"), T::SCHEMA_HASH),
        E::SCHEMA_HASH,
    );
}

/// Declares a wire struct (named fields only) and its [`Schema`].
macro_rules! wire_struct {
    (
        $(#[$attr:meta])*
        $vis:vis struct $name:ident {
            $( $(#[$fattr:meta])* $fvis:vis $field:ident : $ty:ty ),* $(,)?
        }
    ) => {
        $(#[$attr])*
        $vis struct $name {
            $( $(#[$fattr])* $fvis $field : $ty ),*
        }

        impl $crate::wire::schema::Schema for $name {
            const SCHEMA_HASH: u32 = {
                #[allow(unused_mut)]
                let mut h = $crate::wire::schema::fnv_str(
                    $crate::wire::schema::FNV_OFFSET,
                    concat!("struct ", stringify!($name), "{"),
                );
                $(
                    h = $crate::wire::schema::member(
                        h,
                        stringify!($field),
                        <$ty as $crate::wire::schema::Schema>::SCHEMA_HASH,
                    );
                )*
                $crate::wire::schema::fnv_str(h, "}")
            };
        }
    };
}

/// Declares a wire enum (unit, tuple and struct variants, no explicit discriminants: the
/// tag is the variant's index) and its [`Schema`].
macro_rules! wire_enum {
    (
        $(#[$attr:meta])*
        $vis:vis enum $name:ident {
            $(
                $(#[$vattr:meta])*
                $variant:ident
                $( ( $( $tty:ty ),* $(,)? ) )?
                $( { $( $(#[$fattr:meta])* $field:ident : $fty:ty ),* $(,)? } )?
            ),* $(,)?
        }
    ) => {
        $(#[$attr])*
        $vis enum $name {
            $(
                $(#[$vattr])*
                $variant
                $( ( $( $tty ),* ) )?
                $( { $( $(#[$fattr])* $field : $fty ),* } )?
            ),*
        }

        impl $crate::wire::schema::Schema for $name {
            const SCHEMA_HASH: u32 = {
                #[allow(unused_mut)]
                let mut h = $crate::wire::schema::fnv_str(
                    $crate::wire::schema::FNV_OFFSET,
                    concat!("enum ", stringify!($name), "{"),
                );
                $(
                    h = $crate::wire::schema::fnv_str(h, concat!("|", stringify!($variant)));
                    $(
                        h = $crate::wire::schema::fnv_str(h, "(");
                        $( h = $crate::wire::schema::fnv_u32(
                            h,
                            <$tty as $crate::wire::schema::Schema>::SCHEMA_HASH,
                        ); )*
                        h = $crate::wire::schema::fnv_str(h, ")");
                    )?
                    $(
                        h = $crate::wire::schema::fnv_str(h, "{");
                        $( h = $crate::wire::schema::member(
                            h,
                            stringify!($field),
                            <$fty as $crate::wire::schema::Schema>::SCHEMA_HASH,
                        ); )*
                        h = $crate::wire::schema::fnv_str(h, "}");
                    )?
                )*
                $crate::wire::schema::fnv_str(h, "}")
            };
        }
    };
}

pub(crate) use {wire_enum, wire_struct};

#[cfg(test)]
#[allow(dead_code)] // the test types exist for their hashes
mod tests {
    use super::Schema;

    mod base {
        crate::wire::schema::wire_struct! {
            pub struct S { pub x: u16, pub y: f32 }
        }
        crate::wire::schema::wire_enum! {
            pub enum E { A, B(u8), C { s: S } }
        }
    }
    mod reordered {
        crate::wire::schema::wire_struct! {
            pub struct S { pub y: f32, pub x: u16 }
        }
    }
    mod retyped {
        crate::wire::schema::wire_struct! {
            pub struct S { pub x: u32, pub y: f32 }
        }
        crate::wire::schema::wire_enum! {
            pub enum E { A, B(u8), C { s: S } }
        }
    }
    mod renamed {
        crate::wire::schema::wire_struct! {
            pub struct S { pub x: u16, pub z: f32 }
        }
    }
    mod added {
        crate::wire::schema::wire_struct! {
            pub struct S { pub x: u16, pub y: f32, pub z: u8 }
        }
    }
    mod variants_reordered {
        use super::base::S;
        crate::wire::schema::wire_enum! {
            pub enum E { B(u8), A, C { s: S } }
        }
    }
    mod variant_added {
        use super::base::S;
        crate::wire::schema::wire_enum! {
            pub enum E { A, B(u8), C { s: S }, D }
        }
    }

    #[test]
    fn any_change_of_a_wire_type_changes_its_hash() {
        let s = [
            base::S::SCHEMA_HASH,
            reordered::S::SCHEMA_HASH,
            retyped::S::SCHEMA_HASH,
            renamed::S::SCHEMA_HASH,
            added::S::SCHEMA_HASH,
        ];
        for i in 0..s.len() {
            for j in 0..i {
                assert_ne!(s[i], s[j], "struct variants {i} and {j}");
            }
        }
        // a change inside a field's type reaches the containing type
        let e = [
            base::E::SCHEMA_HASH,
            retyped::E::SCHEMA_HASH,
            variants_reordered::E::SCHEMA_HASH,
            variant_added::E::SCHEMA_HASH,
        ];
        for i in 0..e.len() {
            for j in 0..i {
                assert_ne!(e[i], e[j], "enum variants {i} and {j}");
            }
        }
        // arrays: element and length count
        assert_ne!(<[u8; 2]>::SCHEMA_HASH, <[u8; 3]>::SCHEMA_HASH);
        assert_ne!(<[u8; 2]>::SCHEMA_HASH, <[i8; 2]>::SCHEMA_HASH);
        assert_ne!(<Option<u16>>::SCHEMA_HASH, <u16>::SCHEMA_HASH);
    }

    #[test]
    fn the_hash_is_deterministic() {
        // the same declaration in another module hashes the same (names, not paths)
        mod again {
            crate::wire::schema::wire_struct! {
                pub struct S { pub x: u16, pub y: f32 }
            }
        }
        assert_eq!(again::S::SCHEMA_HASH, base::S::SCHEMA_HASH);
        assert_eq!(super::fnv_str(super::FNV_OFFSET, ""), 0x811C_9DC5);
        // FNV-1a reference value
        assert_eq!(super::fnv_str(super::FNV_OFFSET, "a"), 0xE40C_292C);
    }
}
