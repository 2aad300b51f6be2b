//! The ellipse of a 2×2 symmetric matrix (eq. 4.36–4.37): area, aspect ratio, orientation.

use crate::mat2::Mat2;
use crate::real::Real;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse<R> {
    /// λ1 ≤ λ2, the eigenvalues (eq. 4.37a).
    pub lambda_min: R,
    pub lambda_max: R,
    /// π·λ1·λ2 (eq. 4.37b).
    pub area: R,
    /// λ2/λ1 (eq. 4.37c); meaningless (∞ or negative) if the matrix is not positive definite.
    pub aspect_ratio: R,
    /// Angle of the major axis (eigenvector of λ2) from the X axis, in (−π/2, π/2].
    pub orientation_rad: R,
}

impl<R: Real> Ellipse<R> {
    /// Uses the symmetric part of `m` ((m + mᵀ)/2).
    ///
    /// Eq. 4.37d, θ = atan(s2 / (λ2 − s3)), is undefined when s2 = 0 and λ2 = s3; the
    /// equivalent θ = ½·atan2(2 s2, s1 − s3) is used, which has no such hole.
    pub fn of(m: &Mat2<R>) -> Self {
        let s1 = m.0[0][0];
        let s2 = (m.0[0][1] + m.0[1][0]) * R::half();
        let s3 = m.0[1][1];
        let mean = (s1 + s3) * R::half();
        let half_diff = (s1 - s3) * R::half();
        let radius = (half_diff * half_diff + s2 * s2).sqrt();
        let lambda_max = mean + radius;
        let lambda_min = mean - radius;
        let orientation_rad = if radius > R::ZERO {
            R::half() * (R::from_f64(2.0) * s2).atan2(s1 - s3)
        } else {
            R::ZERO
        };
        let aspect_ratio = if lambda_min != R::ZERO {
            lambda_max / lambda_min
        } else {
            R::from_f64(f64::INFINITY)
        };
        Ellipse {
            lambda_min,
            lambda_max,
            area: R::PI * lambda_min * lambda_max,
            aspect_ratio,
            orientation_rad,
        }
    }

    pub fn is_positive_definite(&self) -> bool {
        self.lambda_min > R::ZERO
    }
}
