//! The numerics under the identification and the model loop, host only, f64: least squares
//! on named columns ([`lsq`]), Levenberg–Marquardt ([`lm`]), the zero-phase Butterworth
//! ([`filter`]), amplitude spectra ([`spectrum`]), statistics ([`stats`]), interpolation
//! ([`interp`]) and the exact step of a second-order system ([`second_order`]). Nothing here knows about the robot or a log.

// `!(x > y)` is deliberate: it is true for NaN, so a NaN never passes a check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

pub mod filter;
pub mod interp;
pub mod lm;
pub mod lsq;
pub mod second_order;
pub mod spectrum;
pub mod stats;
