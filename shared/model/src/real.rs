//! The scalar type of the model. The target runs `f32` (hardware FPU on the Cortex-M4F);
//! host tools run `f64`. Everything in this crate is generic over [`Real`] so that the
//! same code is the firmware's model and the host's f64 reference.

use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar with the handful of functions the model needs.
pub trait Real:
    Copy
    + PartialOrd
    + core::fmt::Debug
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    const ZERO: Self;
    const ONE: Self;
    const PI: Self;
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn acos(self) -> Self;
    /// (sin, cos) together; the f32 implementation shares the range reduction.
    #[inline]
    fn sin_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    fn abs(self) -> Self;
    fn is_finite(self) -> bool;

    #[inline]
    fn half() -> Self {
        Self::from_f64(0.5)
    }
    #[inline]
    fn max(self, other: Self) -> Self {
        if self > other {
            self
        } else {
            other
        }
    }
    #[inline]
    fn min(self, other: Self) -> Self {
        if self < other {
            self
        } else {
            other
        }
    }
    /// Clamp into `[lo, hi]`; NaN maps to `lo` so that a NaN can never pass a limit.
    #[inline]
    fn clamp_to(self, lo: Self, hi: Self) -> Self {
        if self >= lo {
            if self <= hi {
                self
            } else {
                hi
            }
        } else {
            lo
        }
    }
    #[inline]
    fn to_radians(self) -> Self {
        self * Self::PI / Self::from_f64(180.0)
    }
    #[inline]
    fn to_degrees(self) -> Self {
        self * Self::from_f64(180.0) / Self::PI
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const PI: Self = core::f64::consts::PI;
    #[inline]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn sqrt(self) -> Self {
        libm::sqrt(self)
    }
    #[inline]
    fn sin(self) -> Self {
        libm::sin(self)
    }
    #[inline]
    fn cos(self) -> Self {
        libm::cos(self)
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        libm::atan2(self, x)
    }
    #[inline]
    fn acos(self) -> Self {
        libm::acos(self)
    }
    #[inline]
    fn abs(self) -> Self {
        libm::fabs(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const PI: Self = core::f32::consts::PI;
    #[inline]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    // sqrt stays with libm even under `micromath`: on the Cortex-M4F libm's sqrtf is
    // exact and compiles to the VSQRT instruction path, micromath's is an approximation.
    #[inline]
    fn sqrt(self) -> Self {
        libm::sqrtf(self)
    }
    #[inline]
    fn sin(self) -> Self {
        self.sin_cos().0
    }
    #[inline]
    fn cos(self) -> Self {
        self.sin_cos().1
    }
    #[inline]
    fn sin_cos(self) -> (Self, Self) {
        #[cfg(feature = "micromath")]
        {
            (micromath::F32Ext::sin(self), micromath::F32Ext::cos(self))
        }
        #[cfg(not(feature = "micromath"))]
        {
            sin_cos_f32(self)
        }
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        #[cfg(feature = "micromath")]
        {
            micromath::F32Ext::atan2(self, x)
        }
        #[cfg(not(feature = "micromath"))]
        {
            libm::atan2f(self, x)
        }
    }
    #[inline]
    fn acos(self) -> Self {
        #[cfg(feature = "micromath")]
        {
            micromath::F32Ext::acos(self)
        }
        #[cfg(not(feature = "micromath"))]
        {
            libm::acosf(self)
        }
    }
    #[inline]
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

/// Horner evaluation of `c[0]·x^(n-1) + … + c[n-1]` (highest power first, as the thesis
/// prints its coefficient tables).
#[inline]
pub fn horner<R: Real, const N: usize>(coeffs: &[R; N], x: R) -> R {
    let mut acc = R::ZERO;
    let mut i = 0;
    while i < N {
        acc = acc * x + coeffs[i];
        i += 1;
    }
    acc
}

/// sin and cos of an f32, computed in f32.
///
/// libm's `sinf`/`cosf` evaluate in f64, which the Cortex-M4F emulates in software (about
/// 900 instructions a call); micromath's are fast but off by up to ~2e-3. This reduces the
/// argument by π/4 in three parts (Cody–Waite, exact for |x| < 8192) and evaluates the
/// classic minimax polynomials on [−π/4, π/4] (the Cephes single-precision
/// coefficients), for an error of a few 1e-8 at a cost of a few dozen instructions.
/// Larger arguments fall back to libm.
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    const FOUR_OVER_PI: f32 = 1.273_239_5;
    const DP1: f32 = 0.785_156_25;
    const DP2: f32 = 2.418_756_5e-4;
    const DP3: f32 = 3.774_895e-8;
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    let ax = libm::fabsf(x);
    if ax > 8192.0 {
        return (libm::sinf(x), libm::cosf(x));
    }
    let mut j = (ax * FOUR_OVER_PI) as u32;
    j += j & 1; // round to an even multiple of π/4: the remainder lies in [−π/4, π/4]
    let y = j as f32;
    let r = ((ax - y * DP1) - y * DP2) - y * DP3;
    let z = r * r;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    let (sin_ax, cos_ax) = match j & 7 {
        0 => (s, c),
        2 => (c, -s),
        4 => (-s, -c),
        _ => (-c, s),
    };
    (if x < 0.0 { -sin_ax } else { sin_ax }, cos_ax)
}
