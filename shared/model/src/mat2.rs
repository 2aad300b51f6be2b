//! 2-vectors and 2×2 matrices, fixed size, no heap.

use crate::real::Real;

pub type Vec2<R> = [R; 2];

/// Row-major 2×2 matrix.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mat2<R>(pub [[R; 2]; 2]);

impl<R: Real> Mat2<R> {
    pub fn new(a: R, b: R, c: R, d: R) -> Self {
        Mat2([[a, b], [c, d]])
    }
    pub fn diag(a: R, d: R) -> Self {
        Mat2([[a, R::ZERO], [R::ZERO, d]])
    }
    /// Symmetric matrix [[s1, s2], [s2, s3]] (the thesis's eq. 4.36 naming).
    pub fn symmetric(s1: R, s2: R, s3: R) -> Self {
        Mat2([[s1, s2], [s2, s3]])
    }
    pub fn rotation(angle_rad: R) -> Self {
        let (s, c) = (angle_rad.sin(), angle_rad.cos());
        Mat2([[c, -s], [s, c]])
    }
    #[inline]
    pub fn det(&self) -> R {
        self.0[0][0] * self.0[1][1] - self.0[0][1] * self.0[1][0]
    }
    #[inline]
    pub fn transpose(&self) -> Self {
        Mat2([[self.0[0][0], self.0[1][0]], [self.0[0][1], self.0[1][1]]])
    }
    /// Inverse, or `None` when the determinant is (relatively) zero.
    pub fn inverse(&self) -> Option<Self> {
        let d = self.det();
        let m = &self.0;
        let scale = m[0][0].abs() * m[1][1].abs() + m[0][1].abs() * m[1][0].abs();
        if !(d.abs() > scale * R::from_f64(1e-9)) || !d.is_finite() {
            return None;
        }
        Some(Mat2([
            [m[1][1] / d, -m[0][1] / d],
            [-m[1][0] / d, m[0][0] / d],
        ]))
    }
    #[inline]
    pub fn mul(&self, o: &Self) -> Self {
        let (a, b) = (&self.0, &o.0);
        Mat2([
            [
                a[0][0] * b[0][0] + a[0][1] * b[1][0],
                a[0][0] * b[0][1] + a[0][1] * b[1][1],
            ],
            [
                a[1][0] * b[0][0] + a[1][1] * b[1][0],
                a[1][0] * b[0][1] + a[1][1] * b[1][1],
            ],
        ])
    }
    #[inline]
    pub fn mul_vec(&self, v: Vec2<R>) -> Vec2<R> {
        [
            self.0[0][0] * v[0] + self.0[0][1] * v[1],
            self.0[1][0] * v[0] + self.0[1][1] * v[1],
        ]
    }
    /// Congruence Aᵀ·X·A (eq. 4.21).
    pub fn congruence(&self, a: &Self) -> Self {
        a.transpose().mul(self).mul(a)
    }
    pub fn max_abs_diff(&self, o: &Self) -> R {
        let mut m = R::ZERO;
        for i in 0..2 {
            for j in 0..2 {
                m = m.max((self.0[i][j] - o.0[i][j]).abs());
            }
        }
        m
    }
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|r| r.iter().all(|x| x.is_finite()))
    }
}
